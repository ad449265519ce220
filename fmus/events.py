"""The event indicators of a model for model exchange: where its right-hand side or its post-step
map switches.

A co-simulation FMU integrates its own substeps: the post-step map (an MRP set switched to its
shadow, a wheel stopped in stiction, a momentum clamped at its bound) is applied after each one,
and a law that reads the substep-start state (:meth:`satfmu.fmus.model.Model.previous`, a friction
mode) is frozen over it. Under model exchange the importer's solver takes the steps, so the FMU
says where the switching happens instead: an event indicator is a continuous function of the state
that changes sign there, and at each event the FMU applies the post-step map and freezes the law
anew (the state at the event stands for the substep-start state until the next event).

The indicators come from the model's own expressions, so they cannot drift from the dynamics:
every relation ``a > b`` (``>=``, ``<``, ``<=``) in the right-hand side, the post-step map and the
definitions they use gives ``a - b``, and every ``sign(a)`` or ``Heaviside(a)`` gives ``a``, with
the substep-start state read as the current state. A relation that depends on neither the state
nor the time (a parameter switch such as ``shadow_switching > 1/2``, an input saturation) cannot
change between events and gives none; nor does a relation on a definition that is itself a 0/1
switch (its own relations give the indicators). Each indicator appears once (``a - b`` and
``b - a`` are one); one that cannot be negative (``w**2``, from ``previous(w) * w < 0``) is none.

Between events a model-exchange FMU holds each indicator's side (:func:`sided`): the relations and
signs that give indicator ``k`` read its side ``s[k]`` (the sign of ``g_k`` at the last event) instead
of the state, so the right-hand side is smooth between events, and the FMU can evaluate it with a
side forced, the two fields of a sliding mode (``fmus/c/satfmu_me.h``).
"""
from __future__ import annotations

from collections.abc import Sequence

import sympy as sp

from satfmu.fmus.model import Model


def _is_switch(expr: sp.Expr) -> bool:
    """Whether ``expr`` is a Piecewise whose every value is 0 or 1 (a Boolean held as a number)."""
    return isinstance(expr, sp.Piecewise) and all(value in (sp.S.Zero, sp.S.One) for value, _ in expr.args)


def _never_negative(expr: sp.Expr) -> bool:
    """An even power (``w**2`` from ``previous(w) * w < 0`` read at one time): it touches 0, never
    changes sign."""
    return isinstance(expr, sp.Pow) and expr.exp.is_even is True


def event_indicators(model: Model) -> list[sp.Expr]:
    """The model's event indicators (see the module docstring), in the model's symbols.

    Parameters
    ----------
    model : Model
        The model.

    Returns
    -------
    list of sympy.Expr
        One expression per indicator, in the order found (right-hand side, post-step map, then
        the definitions they use); it may use the model's definitions' symbols.
    """
    post = list(model.post_step) if model.post_step is not None else []
    roots = list(model.rhs) + post
    definitions = model.used_definitions(roots)
    current = dict(zip(model.previous_symbols, model.state_symbols))
    switches = {sym for sym, e in definitions if _is_switch(e)}
    depends: dict[sp.Symbol, bool] = {}  # definition -> it depends on the state or the time
    moving = set(model.state_symbols) | set(model.previous_symbols) | {sp.Symbol("t", real=True)}
    for sym, e in definitions:
        depends[sym] = any(s in moving or depends.get(s, False) for s in e.free_symbols)

    def varies(expr: sp.Expr) -> bool:
        return any(s in moving or depends.get(s, False) for s in expr.free_symbols)

    found: list[sp.Expr] = []
    seen: set[sp.Expr] = set()
    for expr in roots + [e for _, e in definitions]:
        candidates = [r.lhs - r.rhs for r in sorted(expr.atoms(sp.core.relational.Relational), key=sp.default_sort_key)]
        candidates += [f.args[0] for f in sorted(expr.atoms(sp.sign, sp.Heaviside), key=sp.default_sort_key)]
        for g in candidates:
            g = sp.sympify(g).xreplace(current)
            if not varies(g) or g.free_symbols & switches or _never_negative(g):
                continue
            if g in seen or -g in seen:
                continue
            seen.add(g)
            found.append(g)
    return found


def sided(model: Model, exprs: Sequence[sp.Expr], sides: Sequence[sp.Symbol]) -> list[sp.Expr]:
    """``exprs`` with each relation and sign that gives an event indicator read from its side.

    A relation ``a > b`` whose ``a - b`` is indicator ``k`` (:func:`event_indicators`; the
    substep-start state read as the current one) becomes ``s_k > 0`` (``-s_k > 0`` when ``b - a`` is
    the indicator; likewise ``>=``, ``<``, ``<=``), ``sign(a)`` becomes ``sign(s_k)`` and
    ``Heaviside(a)`` ``Heaviside(s_k)``, with ``s_k = sides[k]`` in ``{-1, 0, 1}``. Relations that
    give no indicator (on parameters, on 0/1 switches, never negative) are kept.

    Parameters
    ----------
    model : Model
        The model.
    exprs : sequence of sympy.Expr
        Expressions in the model's symbols (right-hand sides, outputs, definitions).
    sides : sequence of sympy.Symbol
        One symbol per indicator of :func:`event_indicators`, in its order.

    Returns
    -------
    list of sympy.Expr
        The expressions with those relations and signs replaced.
    """
    indicators = {g: k for k, g in enumerate(event_indicators(model))}
    current = dict(zip(model.previous_symbols, model.state_symbols))

    def side_of(g: sp.Expr) -> sp.Expr | None:
        g = sp.sympify(g).xreplace(current)
        if g in indicators:
            return sides[indicators[g]]
        if -g in indicators:
            return -sides[indicators[-g]]
        return None

    out = []
    for expr in map(sp.sympify, exprs):
        replace: dict[sp.Basic, sp.Basic] = {}
        for r in expr.atoms(sp.core.relational.Relational):
            side = side_of(r.lhs - r.rhs)
            if side is not None:
                replace[r] = r.func(side, 0)
        for f in expr.atoms(sp.sign, sp.Heaviside):
            side = side_of(f.args[0])
            if side is not None:
                replace[f] = f.func(side, *f.args[1:])
        out.append(expr.xreplace(replace))
    return out
