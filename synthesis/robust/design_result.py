"""The result of a robust design or analysis: status, gain, bounds, certificate and times.

:class:`RobustDesign` is what :func:`~satfmu.synthesis.robust.robust_design.design` and
:func:`~satfmu.synthesis.robust.robust_design.i2p_bound` return, and what each solve of their strategy
(:mod:`~satfmu.synthesis.robust.solve_strategy`, :mod:`~satfmu.synthesis.robust.rescaling`,
:mod:`~satfmu.synthesis.robust.constraint_generation`) hands on.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from satfmu.synthesis.core import solve_policy
from satfmu.synthesis.robust.checks import RobustCheck
from satfmu.synthesis.robust.multipliers import Multiplier


@dataclass
class RobustDesign:
    """Result of :func:`~satfmu.synthesis.robust.robust_design.design` or
    :func:`~satfmu.synthesis.robust.robust_design.i2p_bound`.

    ``status``: ``"optimal"`` (solved and verified: K, gamma, nu, Y, multipliers certified),
    ``"infeasible"`` (the solver proved infeasibility), ``"unverified"`` (a solution that failed
    :func:`~satfmu.synthesis.robust.certificate.certify`, or no usable solver answer; K, gamma, nu
    are then None, ``check`` tells why). ``gamma`` (H-infinity bound, units of z1/w1) and ``nu``
    (peak bound, units of z2 per unit impulse of w2) are the bounds of the program's optimal levels
    times ``1 + backoff`` (the first of :data:`~satfmu.synthesis.robust.solve_strategy.BACKOFFS`
    that verifies), at which the returned certificate (from the back-off solve) is verified: the
    levels themselves in the ``"satfmu"`` ``convention``, their square roots in ``"romuloc"``
    (levels ``gamma^2``, ``nu^2``); ``solver_objective`` is the minimized objective itself
    (``w_hinf gamma + w_i2p nu``, or ``w_hinf gamma^2 + w_i2p nu^2`` in ``"romuloc"``; not
    certified). ``n_vertices``: box vertices enumerated (0 with D-G scalings); ``n_multipliers``:
    scaling pairs (D-G: one per block and robust LMI) or full-block multipliers (one per robust
    LMI). Times in seconds:
    ``build_seconds`` to build the LMI programs (:mod:`satfmu.synthesis.core.lmi`), ``solve_seconds`` the wall
    time of Clarabel (set-up and solve), both summed over all the solves.
    ``backoff``: the back-off that verified; ``state_scaling``: None, or T when the certificate
    was found (and ``check`` computed) in the coordinates ``x = diag(T) x_s``: K and Y are given
    in the plant's own coordinates (``Y = diag(T) Y_s diag(T)``).

    Attributes
    ----------
    status : {"optimal", "infeasible", "unverified"}
        Outcome (above).
    K : numpy.ndarray, shape (m, n), or None
        The gain of ``u = K x`` (the given one for a fixed-gain analysis).
    gamma : float or None
        H-infinity bound of ``w1 -> z1`` over the box, units of z1/w1 (None for
        :func:`~satfmu.synthesis.robust.robust_design.i2p_bound`).
    nu : float or None
        Impulse-to-peak bound of ``w2 -> z2``, units of z2 per unit impulse of w2.
    Y : numpy.ndarray, shape (n, n), or None
        The common Lyapunov matrix ``Y = P^-1``, in the plant's coordinates.
    multipliers : dict of str to Multiplier
        The multiplier of each robust LMI, by name (``"hinf"``, ``"alpha"``, ...; ``"i/hinf"``
        for plant i of several); empty for a plant without uncertain parameters.
    check : RobustCheck or None
        :func:`~satfmu.synthesis.robust.certificate.certify` of the returned certificate, or of the
        last one tried when it failed; None when the solver gave no solution.
    solver_objective : float or None
        The minimized objective (not certified).
    uncertainty : {"norm", "vertex"}
        The multiplier class.
    n_vertices : int
        Box vertices enumerated (0 with D-G scalings).
    n_multipliers : int
        Scaling pairs or full-block multipliers of the program.
    fixed_gain : bool
        Whether K was given (analysis) rather than designed.
    solver_status : str
        What the solver reported, for every solve made.
    solve_seconds : float
        Wall time of Clarabel over all the solves, s.
    build_seconds : float
        Time to build the LMI programs, s.
    backoff : float, optional
        The back-off of :data:`~satfmu.synthesis.robust.solve_strategy.BACKOFFS` that verified.
    state_scaling : numpy.ndarray, shape (n,), optional
        T of the coordinates ``x = diag(T) x_s`` of the certificate (None: the plant's own).
    active_plants : int, optional
        Plants with an LMI in the last program of the constraint generation over many plants
        (None: all).
    convention : {"satfmu", "romuloc"}, optional
        How the levels entered the LMIs (:data:`~satfmu.synthesis.robust.checks.CONVENTIONS`).
    """

    status: str
    K: np.ndarray | None
    gamma: float | None
    nu: float | None
    Y: np.ndarray | None
    multipliers: dict[str, Multiplier]
    check: RobustCheck | None
    solver_objective: float | None
    uncertainty: str
    n_vertices: int
    n_multipliers: int
    fixed_gain: bool
    solver_status: str
    solve_seconds: float
    build_seconds: float
    backoff: float | None = None
    state_scaling: np.ndarray | None = None
    active_plants: int | None = None
    """Plants with an LMI in the last program of the constraint generation over many plants (None:
    all)."""
    convention: str = "satfmu"
    """How the levels entered the LMIs (:data:`~satfmu.synthesis.robust.checks.CONVENTIONS`)."""


def _failed(out: solve_policy.SolveOutcome) -> str:
    """Status of a minimization without a solution: proved infeasible, or no usable answer."""
    return "infeasible" if out.status == "infeasible" else "unverified"


def _with_times(res: RobustDesign, others: list[RobustDesign]) -> RobustDesign:
    """``res`` with the solve and build times of ``others`` (the solves made before it) added."""
    return replace(res, solve_seconds=res.solve_seconds + sum(o.solve_seconds for o in others),
                   build_seconds=res.build_seconds + sum(o.build_seconds for o in others))
