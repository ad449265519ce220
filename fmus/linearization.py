"""Linearization of a symbolic model at an operating point, from its exact Jacobians.

``dx = A dx + B du``, ``dy = C dx + D du`` around ``(x0, u0)``: the Jacobians of the model's
right-hand side, outputs and named definitions are taken symbolically, then evaluated at the
point with the model's parameters and chained through the definitions (:class:`Linearizer`). No
finite differences: the matrices are exact to rounding. Piecewise branches are those taken at the
point (a saturation off, a switch on) — the linearization of what the model does there.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping, Sequence

import numpy as np
import sympy as sp

from satfmu.fmus.model import Model


@dataclass(frozen=True)
class Linearization:
    """A model's linearization at one operating point.

    Parameters
    ----------
    A, B, C, D : numpy.ndarray
        ``(n, n)``, ``(n, m)``, ``(p, n)``, ``(p, m)``: state, input, output and feedthrough
        matrices in the model's units.
    states, inputs, outputs : tuple of str
        The names of the rows and columns, in the model's order (the selected ones).
    x0, u0 : numpy.ndarray
        The operating point: state and input values.
    y0 : numpy.ndarray
        The selected outputs' values at the point.
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    states: tuple[str, ...]
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    x0: np.ndarray
    u0: np.ndarray
    y0: np.ndarray


COMPILE_NODES = 2000
"""Most expression-tree nodes compiled to numpy by :class:`Linearizer`; larger expressions (a law of
thousands of polynomial terms, whose printing alone takes minutes) are evaluated by substitution."""


COMPILE_AFTER = 3
"""Calls of a :class:`Linearizer` after which its small expressions are compiled (printing and
compiling one costs about as much as 100 evaluations by substitution)."""


def _small(exprs: Sequence[sp.Expr]) -> bool:
    """Whether the expressions hold at most :data:`COMPILE_NODES` tree nodes (counting stops there)."""
    count = 0
    for e in exprs:
        for _ in sp.preorder_traversal(e):
            count += 1
            if count > COMPILE_NODES:
                return False
    return True


def _derivative(expr: sp.Expr, symbol: sp.Symbol) -> sp.Expr:
    """``d expr / d symbol``, the branch at the point: a sign's or a step's derivative (a Dirac
    impulse at the switch, friction's ``sign(w)``) is 0, as on either side of the switch."""
    return sp.diff(expr, symbol).replace(sp.DiracDelta, lambda *args: sp.S.Zero)


def _real(value: sp.Expr) -> float:
    """A substituted expression as a float; NaN for what has none (``zoo``: a division by 0, the
    derivative of a norm at 0), which the caller reports as not finite."""
    try:
        return float(value)
    except TypeError:
        return math.nan


class _Node:
    """One expression of a model and its partial derivatives: with respect to the linearization's
    variables (columns) and to the definitions it reads (chained by :class:`Linearizer`)."""

    def __init__(self, expr: sp.Expr, columns: list[sp.Symbol], defined: dict[sp.Symbol, int],
                 args: list[sp.Symbol]) -> None:
        expr = sp.sympify(expr)
        free = expr.free_symbols
        self.by_column = [(k, _derivative(expr, c)) for k, c in enumerate(columns) if c in free]
        self.by_definition = [(defined[d], _derivative(expr, d)) for d in free if d in defined]
        self.exprs = [expr] + [d for _, d in self.by_column] + [d for _, d in self.by_definition]
        self.args = args
        self.calls = 0
        self.compiled: Any = None

    def evaluate(self, values: list[float], subs: dict[sp.Symbol, sp.Float]) -> list[float]:
        """The expression and its partial derivatives at the point (compiled to numpy from the
        :data:`COMPILE_AFTER`-th call on, when small: a campaign's samples, not one analysis)."""
        self.calls += 1
        if self.calls == COMPILE_AFTER and _small(self.exprs):
            try:
                self.compiled = sp.lambdify(self.args, self.exprs, modules="numpy")
            except (TypeError, NameError, SyntaxError):  # a function numpy has no name for: substitution
                self.compiled = None
        if self.compiled is not None:
            with np.errstate(all="ignore"):
                try:
                    return [float(v) for v in self.compiled(*values)]
                except (TypeError, ValueError, ZeroDivisionError, NameError):
                    pass
        try:
            return [_real(sp.sympify(e).xreplace(subs).evalf()) for e in self.exprs]
        except (TypeError, ValueError):  # a comparison of NaN (a switch reading an undefined value)
            return [math.nan] * len(self.exprs)


class Linearizer:
    """The exact Jacobians of a model for chosen inputs and outputs, prepared once: each call is the
    linearization at one point (a campaign's samples, a sweep of operating points).

    The model's named definitions are not substituted into one another (a wheel plant's 140 of
    them would swell into expressions of millions of terms): each definition's partial derivatives
    are taken symbolically and chained numerically at the point (forward mode), which is exact to
    rounding, as the substituted Jacobian is.

    Parameters
    ----------
    model : Model
        A model without a sampler (a sampled law has no linearization of this kind).
    inputs, outputs : sequence of str, optional
        The inputs (columns of ``B``, ``D``) and outputs (rows of ``C``, ``D``) kept, by name, in
        that order (default all; a name may repeat).

    Raises
    ------
    ValueError
        A sampled model or an unknown name.
    """

    def __init__(self, model: Model, inputs: Sequence[str] | None = None,
                 outputs: Sequence[str] | None = None) -> None:
        if model.sampler is not None:
            raise ValueError(f"{model.name}: a sampled model holds values between instants; it has no continuous "
                             "linearization")
        self.model = model
        self.state_names = [s.variable.name for s in model.states]
        self.input_names = [v.name for v in model.inputs]
        output_names = [o.variable.name for o in model.outputs]
        for given, known, what in ((inputs or (), self.input_names, "input"),
                                   (outputs or (), output_names, "output")):
            unknown = [k for k in dict.fromkeys(given) if k not in known]
            if unknown:
                raise ValueError(f"{model.name}: no {what} named {', '.join(map(repr, unknown))}")
        self.inputs = tuple(inputs) if inputs is not None else tuple(self.input_names)
        self.outputs = tuple(outputs) if outputs is not None else tuple(output_names)
        xs, us = model.state_symbols, model.input_symbols
        prev = dict(zip(model.previous_symbols, xs))  # the substep-start state is the state at a point
        columns = list(xs) + [us[self.input_names.index(n)] for n in self.inputs]
        self._args = [model.t, *xs, *us, *model.parameter_symbols]
        defined: dict[sp.Symbol, int] = {}
        self._definitions = []
        for sym, e in model.definitions:
            self._definitions.append((sym, _Node(sp.sympify(e).xreplace(prev), columns, defined,
                                                 self._args + list(defined))))
            defined[sym] = len(defined)
        args = self._args + list(defined)
        self._rhs = [_Node(sp.sympify(e).xreplace(prev), columns, defined, args) for e in model.rhs]
        exprs = {o.variable.name: o.expression for o in model.outputs}
        self._outputs = [_Node(sp.sympify(exprs[n]).xreplace(prev), columns, defined, args) for n in self.outputs]

    def __call__(self, x0: Mapping[str, float] | None = None, u0: Mapping[str, float] | None = None,
                 parameters: Mapping[str, float] | None = None, t: float = 0.0) -> Linearization:
        """The linearization at ``(x0, u0)``.

        Parameters
        ----------
        x0, u0 : mapping of str to float, optional
            State and input values by name (the others 0: the origin).
        parameters : mapping of str to float, optional
            Parameter values by name (the others their start values).
        t : float, optional
            Time of the point, s (for a time-varying model).

        Raises
        ------
        ValueError
            An unknown name, or a matrix that is not finite at the point.
        """
        for given, known, what in ((x0 or {}, self.state_names, "state"), (u0 or {}, self.input_names, "input")):
            unknown = [k for k in given if k not in known]
            if unknown:
                raise ValueError(f"{self.model.name}: no {what} named {', '.join(map(repr, unknown))}")
        x = np.array([float((x0 or {}).get(n, 0.0)) for n in self.state_names])
        u = np.array([float((u0 or {}).get(n, 0.0)) for n in self.input_names])
        p = self.model.parameter_vector(dict(parameters or {}))
        values = [float(t), *x, *u, *p]
        subs = {a: sp.Float(v) for a, v in zip(self._args, values)}
        n_cols = len(x) + len(self.inputs)
        grads: list[np.ndarray] = []

        def gradient(node: _Node) -> tuple[float, np.ndarray]:
            found = node.evaluate(values, subs)
            g = np.zeros(n_cols)
            for (k, _), d in zip(node.by_column, found[1:]):
                g[k] += d
            for (j, _), d in zip(node.by_definition, found[1 + len(node.by_column):]):
                g += d * grads[j]
            return found[0], g

        for sym, node in self._definitions:
            value, g = gradient(node)
            values.append(value)
            subs[sym] = sp.Float(value)
            grads.append(g)
        n = len(x)
        rows = [gradient(node)[1] for node in self._rhs]
        found = [gradient(node) for node in self._outputs]
        out_rows = [g for _, g in found]
        J = np.array(rows).reshape(n, n_cols)
        H = np.array(out_rows).reshape(len(self.outputs), n_cols)
        A, B, C, D = J[:, :n], J[:, n:], H[:, :n], H[:, n:]
        for what, matrix in zip("ABCD", (A, B, C, D)):
            if not np.all(np.isfinite(matrix)):
                raise ValueError(f"{self.model.name}: {what} is not finite at the operating point")
        return Linearization(A, B, C, D, tuple(self.state_names), self.inputs, self.outputs, x, u,
                             np.array([v for v, _ in found]))


def linearize(model: Model, x0: Mapping[str, float] | None = None, u0: Mapping[str, float] | None = None,
              parameters: Mapping[str, float] | None = None, inputs: Sequence[str] | None = None,
              outputs: Sequence[str] | None = None, t: float = 0.0) -> Linearization:
    """The linearization of ``model`` at ``(x0, u0)`` (one call of a :class:`Linearizer`).

    Parameters
    ----------
    model : Model
        A model without a sampler (a sampled law has no linearization of this kind).
    x0, u0 : mapping of str to float, optional
        State and input values by name (the others 0: the origin).
    parameters : mapping of str to float, optional
        Parameter values by name (the others their start values).
    inputs, outputs : sequence of str, optional
        The inputs (columns of ``B``, ``D``) and outputs (rows of ``C``, ``D``) kept, by name
        (default all).
    t : float, optional
        Time of the point, s (for a time-varying model).

    Returns
    -------
    Linearization

    Raises
    ------
    ValueError
        A sampled model, an unknown name, or a matrix that is not finite at the point.
    """
    return Linearizer(model, inputs, outputs)(x0, u0, parameters, t)
