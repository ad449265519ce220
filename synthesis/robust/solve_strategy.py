"""How a robust program is solved into a verified certificate: minimize, then check or back off.

``_minimize`` solves the common-Lyapunov program for its optimal levels (a ``_Minimizer``).
``_certified`` checks the minimizer at its levels raised by each of :data:`BACKOFFS`; failing
those, ``_back_off`` fixes the levels and maximizes the strictness margin of every LMI, one
back-off after the other. ``_phase_one`` finds a Lyapunov matrix of the region LMIs alone, for
the coordinates of a retry, when the minimization gives no answer.
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from satfmu.synthesis.core import lmi, solve_policy
from satfmu.synthesis.robust.certificate import _certify_plants
from satfmu.synthesis.robust.design_result import RobustDesign, _failed
from satfmu.synthesis.robust.dual_lmis import Selection, _bound, _robust_constraints, _selected_specs, _specs
from satfmu.synthesis.robust.lft_plant import LFTPlant, _sym
from satfmu.synthesis.robust.multipliers import Multiplier

BACKOFFS = (1e-4, 1e-3, 1e-2)
"""Relative back-offs of the optimal levels, tried in turn: after the minimization, gamma and
nu (or g) are fixed at ``(1 + b)`` times the solver's values and the smallest strictness margin
of all the LMIs is maximized (a second solve), so that the certificate checked without the
solver is far from the solver's accuracy (about 1e-8 relative to the largest entry). A larger b
is tried only when the certificate at the smaller one fails
:func:`~satfmu.synthesis.robust.certificate.certify`: a poorly conditioned program (DEMETER's
momentum mode at -1e-3 1/s) can report an optimum slightly below the true one, and no strictly
feasible point exists at 1e-4 above it."""


def _phase_one(plants: tuple[LFTPlant, ...], K: np.ndarray | None, *, alpha: float, beta: float | None,
               uncertainty: str, sector: float | None = None, **_) -> np.ndarray | None:
    """Y of the region LMIs alone (no H-infinity, no i2p), normalized ``t I <= Y <= I`` with the
    common margin t maximized (at most 1): a bounded problem that the solver answers where the
    full minimization fails; its Y's diagonal gives the coordinates of the retry."""
    prog = lmi.LMIProgram()
    t = prog.variable()
    specs = [_specs(p, alpha, beta, False, sector) for p in plants]
    Y = _robust_constraints(prog, plants, K, specs, uncertainty, t, None, None)[0]
    prog.add_psd(np.eye(Y.shape[0]) - Y)
    prog.add_nonneg(1.0 - t)
    if not prog.solve(t, maximize=True).solved:
        return None
    return _sym(prog.value(Y))


@dataclass
class _Minimizer:
    """The solver's minimizer of the common-Lyapunov program: K, Y, the optimal levels (the
    program's: :func:`~satfmu.synthesis.robust.dual_lmis._level`), the multipliers, the objective,
    the times, the result's info and each LMI's dual weight (``support``:
    :meth:`lmi.LMIProgram.dual_weights` per ``(plant index, LMI name)``, "i2p" for a plant's i2p
    blocks; zero where the LMI does not bind)."""

    K: np.ndarray
    Y: np.ndarray
    gamma: float | None
    nu: float
    multipliers: dict[str, Multiplier]
    optimum: float
    times: dict
    info: dict
    support: dict[tuple[int, str], float]

    def levels(self, convention: str, b: float) -> tuple[float | None, float]:
        """The bounds (:func:`~satfmu.synthesis.robust.dual_lmis._bound`) at the levels times ``1 + b``."""
        g = None if self.gamma is None else _bound(convention, self.gamma * (1 + b))
        return g, _bound(convention, self.nu * (1 + b))


def _minimize(plants: tuple[LFTPlant, ...], K: np.ndarray | None, *, hinf: bool, w_hinf: float, w_i2p: float,
              alpha: float, beta: float | None, uncertainty: str, eps: float, sector: float | None = None,
              convention: str = "satfmu", ladder: solve_policy.RungMemory | None = None, only: Selection = None
              ) -> _Minimizer | RobustDesign:
    """Minimize the objective of the common-Lyapunov program (options already checked; ``only``
    its robust LMIs, default all): the minimizer, or the failed :class:`RobustDesign` when the
    solver gives no answer; ``ladder`` the rungs shared by the minimizations of one design
    (default: a fresh ladder)."""
    t0 = time.perf_counter()
    specs = _selected_specs(plants, alpha, beta, hinf, sector, only)
    prog = lmi.LMIProgram()
    gamma = prog.variable() if hinf else None
    nu = prog.variable()
    Y, W, values = _robust_constraints(prog, plants, K, specs, uncertainty, eps, gamma, nu, convention)
    objective = w_i2p * nu + (w_hinf * gamma if gamma is not None else 0.0)  # gamma is None iff not hinf
    build = time.perf_counter() - t0
    sol = prog.solve(objective, ladder=solve_policy.LADDER if ladder is None else ladder)
    out = sol.outcome
    n_mult = sum(len(s) * (p.n_params if uncertainty == "norm" else min(p.n_params, 1))
                 for p, s in zip(plants, specs))
    info: dict[str, Any] = {"uncertainty": uncertainty,
                            "n_vertices": sum(2**p.n_params for p in plants) if uncertainty == "vertex" else 0,
                            "n_multipliers": n_mult, "fixed_gain": K is not None, "convention": convention}
    if not sol.solved:
        return RobustDesign(_failed(out), None, None, None, None, {}, None, None, **info,
                            solver_status=out.solver_status, solve_seconds=out.seconds, build_seconds=build)
    Y1 = _sym(prog.value(Y))
    weights = prog.dual_weights()
    return _Minimizer(np.linalg.solve(Y1, prog.value(W).T).T if K is None else K, Y1,
                      float(prog.value(gamma)[0, 0]) if gamma is not None else None, float(prog.value(nu)[0, 0]),
                      {k: f() for k, f in values.items()}, sol.objective,
                      {"solver_status": out.solver_status, "solve_seconds": out.seconds, "build_seconds": build}, info,
                      {(i, name): weights.get((i, name), 0.0) for i, plant_specs in enumerate(specs)
                       for name in [s.name for s in plant_specs] + ["i2p"]})


def _back_off(plants: tuple[LFTPlant, ...], K: np.ndarray | None, m: _Minimizer, backoffs: tuple[float, ...], *,
              uncertainty: str, alpha: float, beta: float | None, sector: float | None = None,
              convention: str = "satfmu", only: Selection = None, **_) -> RobustDesign:
    """The back-off solves after the minimizer ``m`` of the same plants and LMIs (``only``; in any
    state coordinates: the levels do not depend on them): for b in ``backoffs``, the levels fixed
    at ``1 + b`` times m's, the smallest strictness margin of every LMI maximized and the answer
    verified; the first that verifies, or ``"unverified"``."""
    times = dict(m.times)
    specs = _selected_specs(plants, alpha, beta, m.gamma is not None, sector, only)
    mults, check = {}, None
    for b in backoffs:
        t0 = time.perf_counter()
        g = None if m.gamma is None else m.gamma * (1 + b)
        nv = m.nu * (1 + b)
        back = lmi.LMIProgram()
        t = back.variable()
        Yb, Wb, values = _robust_constraints(back, plants, K, specs, uncertainty, t, g, nv, convention)
        times["build_seconds"] += time.perf_counter() - t0
        sol = back.solve(t, maximize=True)
        out = sol.outcome
        times["solver_status"] += f"; back-off {b:g}: {out.solver_status}"
        times["solve_seconds"] += out.seconds
        if not sol.solved:
            continue
        Yv = _sym(back.value(Yb))
        Kv = np.linalg.solve(Yv, back.value(Wb).T).T if K is None else K
        mults = {k: f() for k, f in values.items()}
        g, nv = (None if g is None else _bound(convention, g)), _bound(convention, nv)
        check = _certify_plants(plants, Kv, Yv, g, nv, mults, alpha=alpha, beta=beta, sector=sector,
                               convention=convention, only=only)
        if check.ok:
            return RobustDesign("optimal", Kv, g, nv, Yv, mults, check, m.optimum, **m.info, **times, backoff=b)
    return RobustDesign("unverified", None, None, None, None, mults, check, m.optimum, **m.info, **times)


def _certified(plants: tuple[LFTPlant, ...], K: np.ndarray | None, m: _Minimizer, backoffs: tuple[float, ...],
               **options) -> RobustDesign:
    """The minimizer ``m`` of the common-Lyapunov program, verified at its levels times
    ``1 + b`` for b in ``backoffs`` (no second solve if it verifies); failing every b, the
    back-off solves (:func:`_back_off`). The times and status start from m's."""
    convention = m.info["convention"]
    for b in backoffs:
        g, nv = m.levels(convention, b)
        check = _certify_plants(plants, m.K, m.Y, g, nv, m.multipliers, alpha=options["alpha"], beta=options["beta"],
                               sector=options.get("sector"), convention=convention, only=options.get("only"))
        if check.ok:
            status = m.times["solver_status"] + f"; the minimizer verified at back-off {b:g}"
            return RobustDesign("optimal", m.K, g, nv, m.Y, m.multipliers, check, m.optimum, **m.info,
                                **{**m.times, "solver_status": status}, backoff=b)
    return _back_off(plants, K, m, backoffs, **options)
