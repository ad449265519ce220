"""Rescaled state coordinates in which a robust program is well conditioned, and the way back.

When a certificate fails its check, ``_rescaled_program`` solves the program again in the
coordinates where the minimizer's Lyapunov matrix has a unit diagonal (at most
:data:`RESCALE_DEPTH` times; the larger back-offs first when that diagonal spans less than
:data:`RESCALE_SPREAD`); ``_back_to_caller`` gives the result in the caller's coordinates, and
``_in_our_coordinates`` solves a ``"romuloc"`` synthesis in a ``"satfmu"`` design's coordinates.
"""
from __future__ import annotations

import logging
from dataclasses import replace

import numpy as np

from satfmu.synthesis.core import solve_policy
from satfmu.synthesis.robust.design_result import RobustDesign, _with_times
from satfmu.synthesis.robust.lft_plant import LFTPlant
from satfmu.synthesis.robust.solve_strategy import BACKOFFS, _certified, _minimize, _Minimizer, _phase_one

LOG = logging.getLogger(__name__)

RESCALE_DEPTH = 2
"""Rescalings ``_rescaled_program`` may chain (each from the last solve's Lyapunov matrix)."""

RESCALE_SPREAD = 1e4
"""Ratio of the largest to the smallest diagonal entry of the minimizer's Y above which
``_rescaled_program`` rescales before it tries the larger back-offs (DEMETER row 1: 10^7, no
back-off verifies; row 12 in the D-G design's coordinates: 10^3, the minimizer's levels verify
at back-off 1e-3, and the two rescalings that came first took 130 s of 226)."""


def _rescaled_program(plants: tuple[LFTPlant, ...], K: np.ndarray | None, rescale: bool, depth: int = RESCALE_DEPTH,
                      minimizer: _Minimizer | RobustDesign | None = None, **options) -> RobustDesign:
    """The minimizer certified at the first back-off (:func:`_certified`); if that fails
    :func:`~satfmu.synthesis.robust.certificate.certify`, the same again (up to ``depth`` times) in
    the coordinates where the minimizer's Y has a unit diagonal (``x = diag(sqrt(Y_ii)) x_s``);
    failing that, the larger back-offs at the same minimizer. When Y's diagonal spans less than
    :data:`RESCALE_SPREAD`, the larger back-offs come before the rescaling (the scaling is not what
    fails). Each program is minimized once (``minimizer``: its :func:`_minimize` already done by the
    caller): the solver is deterministic, so solving it again would give the same answer, or the
    same failure.

    A Lyapunov matrix with eigenvalues 10^7 apart (slow modes next to stiff ones) leaves the
    solver's answer just outside the feasible set whatever the back-off; the diagonal scaling
    from its own first answer brings Y's condition number to about 10 (DEMETER row 1: 10^7 to
    13). When a solve gives no answer at all, the scaling comes from :func:`_phase_one`
    (DEMETER, one axis, four identical appendages: phase one, then one more rescaling). The
    returned K, Y are in the caller's coordinates; ``state_scaling`` holds the total scale,
    ``check`` and the multipliers in the last coordinates (:meth:`LFTPlant.scale_states`, then
    :meth:`LFTPlant.balance_channels`); the status and times are those of every solve made.
    """
    m = _minimize(plants, K, **options) if minimizer is None else minimizer
    Y1: np.ndarray | None
    if isinstance(m, _Minimizer):
        d = np.diag(m.Y)
        ill = bool(d.min() <= 0 or d.max() > RESCALE_SPREAD * d.min())
        out = _certified(plants, K, m, BACKOFFS[:1] if ill else BACKOFFS, **options)
        if out.status != "unverified":
            return out
        Y1 = m.Y
    else:
        out = m
        if m.status == "infeasible":
            return m
        Y1 = _phase_one(plants, K, **options) if rescale and depth > 0 else None  # no answer: region LMIs alone
    if rescale and depth > 0 and Y1 is not None and np.all(np.diag(Y1) > 0):
        T = np.sqrt(np.diag(Y1))
        LOG.debug("rescaling %d plants: diag(Y) from %.3g to %.3g", len(plants), Y1.diagonal().min(),
                  Y1.diagonal().max())
        scaled = _rescaled_program(tuple(p.scale_states(T).balance_channels() for p in plants),
                                   None if K is None else K * T, rescale, depth - 1, **options)
        if scaled.status == "optimal":
            return _back_to_caller(scaled, T, out, f"{out.solver_status}; rescaled: {scaled.solver_status}")
        out = replace(_with_times(out, [scaled]),
                      solver_status=f"{out.solver_status}; rescaled: {scaled.solver_status}")
    if not isinstance(m, _Minimizer) or not ill:  # not ill: every back-off already tried
        return out
    so_far = {"solver_status": out.solver_status, "solve_seconds": out.solve_seconds,
              "build_seconds": out.build_seconds}
    return _certified(plants, K, replace(m, times=so_far), BACKOFFS[1:], **options)


def _back_to_caller(res: RobustDesign, T: np.ndarray, before: RobustDesign | None = None,
                    status: str | None = None) -> RobustDesign:
    """``res``, solved in the coordinates ``x = diag(T) x_s``, with K and Y in the caller's, the
    total ``state_scaling``, and the times of ``before`` (the solves that chose T) added."""
    inner = np.ones_like(T) if res.state_scaling is None else res.state_scaling
    out = replace(res, K=res.K / T, Y=T[:, None] * res.Y * T[None, :], state_scaling=T * inner)
    if before is None:
        return out
    assert status is not None  # every caller that passes before passes its status too
    return replace(_with_times(out, [before]), solver_status=status)


def _in_our_coordinates(plants: tuple[LFTPlant, ...], rescale: bool, **options) -> RobustDesign:
    """A ``"romuloc"`` synthesis in the coordinates where a ``"satfmu"`` design's Y has a unit
    diagonal (:func:`_rescaled_program` of each): with ``"vertex"`` multipliers, first the D-G
    design's (one LMI per objective instead of one per vertex), then the same multipliers'; failing
    both, the toolbox's forms in the caller's coordinates.

    The same Y serves both conventions up to the levels' scale, but the solver's path does not: in
    the toolbox's forms the constants ``Bw Bw^T`` and ``B2 B2^T`` fix Y's size, which follows the
    slow momentum mode's Gramian (DEMETER: 10^5 times the stiff states' entries), and the
    interior-point iterates stall (two-axis rows: NumericalError, or a certificate that fails
    :func:`~satfmu.synthesis.robust.certificate.certify` at every back-off, in 30 s); ours keeps the
    levels on both sides of each LMI and converges. In its coordinates the toolbox's program is well
    scaled: DEMETER row 10 then takes one solve (1.6 s) and its minimizer verifies at the first
    back-off. Any well-scaled coordinates do: the D-G design's Y is within a factor of a few of the
    vertex design's on the diagonal, and costs a tenth (DEMETER row 12: 8 s instead of 105 s; the
    whole design 71 s, was 625 s in the vertex design's coordinates).

    An infeasible satfmu program with the same multipliers proves this one infeasible: with the
    levels free, both ask for a Y (and multipliers, and W = K Y) meeting the region LMIs
    strictly, which are homogeneous in them; scaling such a Y up meets either convention's
    H-infinity and i2p LMIs at large enough levels (``Bw Bw^T`` and ``Y >= B2 B2^T`` in the
    toolbox's forms, ``Bw Bw^T / gamma`` in ours). The D-G program is more conservative than the
    vertex one, so its infeasibility proves nothing here.
    """
    kinds = ["norm", "vertex"] if options["uncertainty"] == "vertex" else [options["uncertainty"]]
    spent: list[RobustDesign] = []
    for kind in kinds:
        ours = _rescaled_program(plants, None, rescale, **{**options, "convention": "satfmu", "uncertainty": kind,
                                                           "ladder": solve_policy.RungMemory()})
        spent.append(ours)
        if ours.status == "infeasible" and kind == options["uncertainty"]:
            return replace(_with_times(ours, spent[:-1]), convention="romuloc",
                           solver_status=f"the satfmu program: {ours.solver_status}")
        if ours.status == "optimal" and ours.Y is not None and np.all(np.diag(ours.Y) > 0):  # optimal: Y is set
            T = np.sqrt(np.diag(ours.Y))
            res = _rescaled_program(tuple(p.scale_states(T).balance_channels() for p in plants), None, rescale,
                                    **options)
            if res.status == "optimal":
                return _back_to_caller(res, T, _with_times(ours, spent[:-1]),
                                       f"in the satfmu {kind} design's coordinates ({ours.solver_status}): "
                                       f"{res.solver_status}")
            spent.append(res)
    return _with_times(_rescaled_program(plants, None, rescale, **options), spent)
