"""Linearization of a symbolic model at an operating point, from its exact Jacobians.

``dx = A dx + B du``, ``dy = C dx + D du`` around ``(x0, u0)``: the Jacobians of the model's
right-hand side and outputs are taken symbolically (every named definition substituted first),
then evaluated at the point with the model's parameters. No finite differences: the matrices are
exact to rounding. Piecewise branches are those taken at the point (a saturation off, a switch
on) — the linearization of what the model does there.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping, Sequence

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


def _expanded(model: Model, exprs: Sequence[sp.Expr]) -> list[sp.Expr]:
    """``exprs`` with every definition of the model substituted (latest first)."""
    out = [sp.sympify(e) for e in exprs]
    for sym, value in reversed(model.definitions):
        out = [e.xreplace({sym: value}) if e.has(sym) else e for e in out]
    return out


def linearize(model: Model, x0: Mapping[str, float] | None = None, u0: Mapping[str, float] | None = None,
              parameters: Mapping[str, float] | None = None, inputs: Sequence[str] | None = None,
              outputs: Sequence[str] | None = None, t: float = 0.0) -> Linearization:
    """The linearization of ``model`` at ``(x0, u0)``.

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
    if model.sampler is not None:
        raise ValueError(f"{model.name}: a sampled model holds values between instants; it has no continuous "
                         "linearization")
    state_names = [s.variable.name for s in model.states]
    input_names = [v.name for v in model.inputs]
    output_names = [o.variable.name for o in model.outputs]
    for given, known, what in ((x0 or {}, state_names, "state"), (u0 or {}, input_names, "input"),
                               (dict.fromkeys(inputs or ()), input_names, "input"),
                               (dict.fromkeys(outputs or ()), output_names, "output")):
        unknown = [k for k in given if k not in known]
        if unknown:
            raise ValueError(f"{model.name}: no {what} named {', '.join(map(repr, unknown))}")
    sel_in = list(inputs) if inputs is not None else input_names
    sel_out = list(outputs) if outputs is not None else output_names
    x = np.array([float((x0 or {}).get(n, 0.0)) for n in state_names])
    u = np.array([float((u0 or {}).get(n, 0.0)) for n in input_names])
    p = model.parameter_vector(dict(parameters or {}))
    xs, us = model.state_symbols, model.input_symbols
    subs = {model.t: t, **dict(zip(xs, x)), **dict(zip(us, u)), **dict(zip(model.parameter_symbols, p))}
    subs.update({prev: subs[cur] for prev, cur in zip(model.previous_symbols, xs)})
    rhs = sp.Matrix(_expanded(model, list(model.rhs))) if model.states else sp.zeros(0, 1)
    outs = sp.Matrix(_expanded(model, [model.outputs[output_names.index(n)].expression for n in sel_out]))
    u_sel = sp.Matrix([us[input_names.index(n)] for n in sel_in])
    x_sym = sp.Matrix(xs)

    def evaluate(matrix: sp.Matrix, rows: int, cols: int, what: str) -> np.ndarray:
        if rows == 0 or cols == 0:
            return np.zeros((rows, cols))
        value = np.array(matrix.xreplace(subs).evalf(), dtype=float).reshape(rows, cols)
        if not np.all(np.isfinite(value)):
            raise ValueError(f"{model.name}: {what} is not finite at the operating point")
        return value

    n, m, q = len(xs), len(sel_in), len(sel_out)
    A = evaluate(rhs.jacobian(x_sym), n, n, "A") if n else np.zeros((0, 0))
    B = evaluate(rhs.jacobian(u_sel), n, m, "B") if n else np.zeros((0, m))
    C = evaluate(outs.jacobian(x_sym), q, n, "C") if n else np.zeros((q, 0))
    D = evaluate(outs.jacobian(u_sel), q, m, "D")
    return Linearization(A, B, C, D, tuple(state_names), tuple(sel_in), tuple(sel_out), x, u)
