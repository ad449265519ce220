"""Robust multi-objective state feedback by LMIs over real parametric uncertainty (R-ROMULOC seed).

The plant is an :class:`~satfmu.synthesis.robust.lft_plant.LFTPlant` (its module docstring gives the
linear-fractional form and the box of the parameters).

Design (:func:`design`): ``u = K x``, ``K = W Y^-1``, one Lyapunov matrix ``Y = P^-1 > 0``
for every specification and every ``delta`` (quadratic stability), minimizing
``w_hinf gamma + w_i2p nu``:

- H-infinity: ``||w1 -> z1||_inf < gamma`` for every ``delta``;
- impulse-to-peak: ``sup_t ||z2(t)|| <= nu`` after ``w2 = w0 delta_Dirac(t)``, ``||w0|| <= 1``;
- pole region: every closed-loop eigenvalue in ``-beta < Re s < -alpha`` and, optionally, in
  the sector ``|Im s| < tan(theta) (-Re s)`` (damping above ``cos(theta)``).

Each robust specification is a Lyapunov inequality for an uncertain loop written as
``[x'; q; z] = G [x; p; w]`` (the closed loop ``A_cl = A + Bu K``, ``Cq_cl = Cq + Dqu K``,
``C1_cl = C1 + D1u K``; ``Bp, Dqp, D1p`` do not depend on K). The primal condition
(full-block S-procedure, Scherer 2001) is, with ``P > 0`` and a multiplier ``Pi`` on ``(q, p)``
such that ``[I; Delta]^T Pi [I; Delta] >= 0`` for every admissible ``Delta``::

    [*]^T diag([0 P; P 0], Pi, Pp) [I; G] < 0   on (x, p, w) -> ((x, p, w), (x', q, z))

(``Pp = diag(-gamma I, I / gamma)`` on ``(w, z)``, absent for the region conditions): along
any trajectory with ``p = Delta q`` the multiplier term is >= 0, so
``d/dt x^T P x + ||z||^2 / gamma - gamma ||w||^2 < 0``. Synthesis needs it in ``Y = P^-1``:
the **dualization lemma** (C. W. Scherer, "LPV control and full block multipliers",
Automatica 37, 2001; C. Scherer & S. Weiland, *Linear Matrix Inequalities in Control*,
lecture notes, the dualization lemma and robust performance with dual multipliers) turns it,
with ``Pi~ = Pi^-1 = [[Qt, St], [St^T, Rt]]`` on ``(q, p)``, into the dual conditions::

    Qt > 0,   [-Delta^T; I]^T Pi~ [-Delta^T; I] = Delta Qt Delta - Delta St - St^T Delta + Rt <= 0,
    Rt <= 0,

    [ He(Tx) + He(Gp St^T Eq^T) - Gp Rt Gp^T - diag(0, Qt, gamma I)    Gw     ]
    [ Gw^T                                                            -gamma I ]  < 0,

    Tx = [A_cl Y; Cq_cl Y; C1_cl Y] Ex^T,  Gp = [Bp; Dqp; D1p],  Gw = [B1; Dq1; D11],

rows/columns ``(x', q, z1, w1)``, ``Ex``, ``Eq`` the selectors of the ``x'`` and ``q`` rows
(derivation: ``[-G^T; I]^T M~ [-G^T; I] > 0`` with ``M~ = diag([0 Y; Y 0], Pi~, Pp^-1)``, then a
Schur complement on ``Gw Gw^T / gamma``). It is linear in ``(Y, W = K Y, Qt, St, Rt, gamma)``
(``dual_lmis._dual_lmi``). For the regions drop ``z, w`` and replace ``(A, Bu, Bp)`` by ``(A +
alpha I, Bu, Bp)`` (``A_cl Y + Y A_cl^T + 2 alpha Y < 0``) or by ``(-A - beta I, -Bu, -Bp)``
(``-(A_cl Y + Y A_cl^T) - 2 beta Y < 0``; ``-A_cl(Delta) - beta I`` is the LFT of the loop
with ``-Bp`` in place of ``Bp``). The lemma (nonsingular outer factors) gives the primal back
from the dual: ``M~ <= 0`` on the input signals ``(x, p, w)`` because ``Rt <= 0``, and ``Pi~ >
0`` on ``im [I; 0]`` with ``Pi~ <= 0`` on ``im [-Delta^T; I]`` is, by the same lemma, ``Pi <
0`` on ``im [0; I]`` with ``Pi >= 0`` on ``im [I; Delta]``. Strictness also makes the loop
well posed (``I - Dqp Delta`` nonsingular: restrict the primal to ``x = 0, w = 0``). Two
multiplier classes:

- ``uncertainty="norm"``: **D-G scalings**, one pair per block and per robust LMI. The primal
  D-G multiplier ``[[D, G], [G^T, -D]]`` (``D = D^T > 0``, ``G = -G^T``, blockwise) satisfies
  ``J Pi J = -Pi`` with ``J = [[0, I], [I, 0]]``, hence so does its inverse, which is therefore
  again of the D-G form ``[[S, H], [H^T, -S]]``, ``S = (D + G D^-1 G^T)^-1 > 0``, ``H = -H^T``
  (``S = D^-1`` when ``G = 0``); conversely. For these the dual multiplier inequality holds
  exactly (``Delta Qt Delta - Delta St - St^T Delta + Rt = (delta_k^2 - 1) S_k <= 0``
  blockwise), so the dual D-G test is *equivalent* to the primal one: G is kept, and dualizing
  adds no conservatism. The variables are ``S_k > 0`` (``r_k x r_k``) and ``H_k = U_k -
  U_k^T`` (none when ``r_k = 1``).
- ``uncertainty="vertex"``: **full-block multipliers** ("vertex separators", Iwasaki &
  Shibata, IEEE TAC 46(8), 2001; Scherer 2001; Peaucelle et al., Automatica 43, 2007): free
  ``Qt, St, Rt`` (``n_q x n_q``) with ``Qt > 0`` and the multiplier inequality at the ``2^N``
  vertices of the box, strictly (``<= -eps I``). Sufficiency of the vertices: for fixed
  ``Pi~`` the map ``Delta -> Delta Qt Delta - Delta St - St^T Delta + Rt`` is convex along
  every ``x`` (``x^T Delta Qt Delta x = |Qt^(1/2) Delta x|^2``) because ``Qt >= 0``, so its
  largest value on the box is at a vertex. This convexity plays the part of the primal
  concavity condition (``R_kk <= 0``) and costs nothing: ``Qt > 0`` is required by the
  dualization anyway. ``Rt`` is the value at ``Delta = 0``, hence ``< 0`` by convexity, which
  also makes ``Pi~`` nonsingular. The D-G multipliers satisfy the vertex inequality with
  equality, so (after an O(eps) perturbation) they are a subset: the vertex design is never
  worse than the norm one, up to solver accuracy and ``eps``. The parameter dependence is
  rational (the LFT), so checking ``A(delta)`` at the vertices would **not** be valid; only
  the multiplier inequality is checked there.

Both multiplier classes act pointwise in time, so these common-Lyapunov certificates also hold
for time-varying ``delta(t)`` in the box (the H-infinity bound as an L2 gain).

Impulse-to-peak: with ``[[Y, B2], [B2^T, nu I]] >= 0``, ``C2 Y C2^T <= nu I`` and
``A_cl Y + Y A_cl^T < 0`` for every ``delta`` (implied by the alpha region LMI, which is
``P A_cl + A_cl^T P < -2 alpha P <= 0`` after the congruence by ``P = Y^-1``, alpha >= 0):
the impulse puts the state at ``x(0+) = B2 w0``. ``V = x^T P x`` does not increase, so
``V(t) <= w0^T B2^T P B2 w0 <= nu |w0|^2 <= nu`` (Schur complement of the first LMI, ``Y >
0``). Then ``|z2(t)|^2 = |C2 Y^(1/2) Y^(-1/2) x|^2 <= lambda_max(C2 Y C2^T) V(t) <= nu * nu``,
i.e. ``sup_t |z2(t)| <= nu``, for every ``delta`` (even time-varying).

Fixed gain (``design(plant, K=K0)`` and :func:`i2p_bound`): ``W = K0 Y`` is *linear* in
``Y``, so the same dual LMIs are the common-Lyapunov analysis of the given gain.

Two conventions (``convention=``) put the levels into these LMIs differently; each LMI alone
is the same condition in both (``Y`` rescaled), but with **one** ``Y`` for every specification
they bound different sets of level pairs:

- ``"satfmu"`` (the default): the forms above, levels ``gamma`` and ``nu`` themselves, on both
  sides of each LMI (``-gamma I`` on the w and on the z block; ``nu I`` beside ``B2`` and
  beside ``C2 Y C2^T``); objective ``w_hinf gamma + w_i2p nu``.
- ``"romuloc"``: the forms of the R-RoMulOC toolbox (release R20160826, which the seed used):
  squared levels ``g_inf = gamma^2``, ``g_i2p = nu^2`` on the z side only: the H-infinity LMI
  with ``Gw`` against ``-I`` and ``-g_inf I`` on the z block (for a certain plant
  ``[He(A Y + Bu W) + Bw Bw^T, (C1 Y + D1u W)^T + Bw D11^T; *, -g_inf I + D11 D11^T] <= 0``),
  the impulse-to-peak LMIs ``Y >= B2 B2^T`` and ``C2 Y C2^T <= g_i2p I``; objective
  ``w_hinf g_inf + w_i2p g_i2p`` (the toolbox's "+1*hinfty +100*i2p"); the bounds reported are
  ``sqrt(g)``.

Neither is tighter in general: a shared ``Y`` that must dominate a slowly decaying mode's
Gramian (``Y >= c G``, from the H-infinity LMI; DEMETER's momentum pseudo-integrator) costs
``nu >= c'/gamma`` in ``"satfmu"`` (the product gamma nu is bounded below; a small nu for a large
gamma) and ``nu^2 >= c'`` in ``"romuloc"`` (nu bounded below whatever gamma; gamma free).

Every result returned as ``"optimal"`` has been re-verified without the solver
(:func:`~satfmu.synthesis.robust.certificate.certify`): each LMI rebuilt in numpy from the
returned matrices (with the returned K), its extreme eigenvalue of the right sign with a margin;
otherwise ``"unverified"``. An optimal interior-point solution lies within the solver's accuracy
(about 1e-8 of the largest entry) of the boundary, often too close for such a check. So the
minimizer is checked first at the levels ``1 + b`` times the optimum (b in
:data:`~satfmu.synthesis.robust.solve_strategy.BACKOFFS`: its LMIs are strict by eps, and raising
the levels only loosens them); if none verifies, a back-off solve follows: the levels fixed at
``1 + b`` times the optimum and the smallest strictness margin of all the LMIs maximized, for b
in :data:`~satfmu.synthesis.robust.solve_strategy.BACKOFFS` until one verifies. The programs are
built as arrays for Clarabel (:mod:`satfmu.synthesis.core.lmi`).

This module holds the entry points, :func:`design` and :func:`i2p_bound`, and re-exports the
public names of the modules that implement them: the specifications and their dual LMIs
(:mod:`~satfmu.synthesis.robust.dual_lmis`), the multipliers (:mod:`~satfmu.synthesis.robust.multipliers`),
the check without the solver (:mod:`~satfmu.synthesis.robust.certificate`; the check's record,
tolerances and conventions: :mod:`~satfmu.synthesis.robust.checks`), the solve strategy
(:mod:`~satfmu.synthesis.robust.solve_strategy`), the rescaled coordinates
(:mod:`~satfmu.synthesis.robust.rescaling`), the constraint generation over many scenarios
(:mod:`~satfmu.synthesis.robust.constraint_generation`) and the result
(:mod:`~satfmu.synthesis.robust.design_result`).

The analysis of a given gain with a parameter-dependent Lyapunov function is
:mod:`satfmu.synthesis.robust.pdlf`; the exact norms of sampled loops, for independent checks of every bound,
are :mod:`satfmu.synthesis.core.system_norms`.
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from satfmu.synthesis.core import solve_policy
from satfmu.synthesis.robust.certificate import certify
from satfmu.synthesis.robust.checks import ABS_MARGIN, CONVENTIONS, EPS, RobustCheck, _check_convention, _check_eps
from satfmu.synthesis.robust.constraint_generation import (SCENARIO_BATCH, SCENARIO_FIRST, SUPPORT_TOL,
                                                           _constraint_generation)
from satfmu.synthesis.robust.design_result import RobustDesign
from satfmu.synthesis.robust.dual_lmis import ROBUST_LMIS, Selection
from satfmu.synthesis.robust.lft_plant import LFTPlant, OptionError, PlantDataError, _check_gain, _check_vertices
from satfmu.synthesis.robust.multipliers import MAX_VERTICES, Multiplier
from satfmu.synthesis.robust.rescaling import RESCALE_DEPTH, RESCALE_SPREAD, _in_our_coordinates, _rescaled_program
from satfmu.synthesis.robust.solve_strategy import BACKOFFS

# the entry points, and the public names of the modules that implement them (importable from here)
__all__ = ["ABS_MARGIN", "BACKOFFS", "CONVENTIONS", "EPS", "MAX_VERTICES", "RESCALE_DEPTH", "RESCALE_SPREAD",
           "ROBUST_LMIS", "SCENARIO_BATCH", "SCENARIO_FIRST", "SUPPORT_TOL", "Multiplier", "RobustCheck",
           "RobustDesign", "Selection", "design", "i2p_bound", "certify"]


def _check_options(w_hinf: float, w_i2p: float, alpha: float, beta: float | None, uncertainty: str,
                   eps: float) -> None:
    for k, v in (("w_hinf", w_hinf), ("w_i2p", w_i2p)):
        if not (np.isfinite(v) and v >= 0):
            raise OptionError(f"{k} must be finite and >= 0, got {v!r}")
    if w_hinf + w_i2p <= 0:
        raise OptionError("at least one of w_hinf, w_i2p must be > 0")
    if not (np.isfinite(alpha) and alpha >= 0):
        raise OptionError(f"alpha must be finite and >= 0, got {alpha!r}")
    if beta is not None and not (np.isfinite(beta) and beta > alpha):
        raise OptionError(f"beta must be finite and > alpha = {alpha!r}, got {beta!r}")
    if uncertainty not in ("norm", "vertex"):
        raise OptionError(f"uncertainty must be 'norm' or 'vertex', got {uncertainty!r}")
    _check_eps(eps)


def _plant_list(plant: LFTPlant | Sequence[LFTPlant], uncertainty: str, max_vertices: int
                ) -> tuple[LFTPlant, ...]:
    """The plants of a program: one, or several sharing the state and input sizes (each checked
    against ``max_vertices`` with ``"vertex"``)."""
    plants = (plant,) if isinstance(plant, LFTPlant) else tuple(plant)
    if not plants or not all(isinstance(p, LFTPlant) for p in plants):
        raise PlantDataError("plant must be an LFTPlant or a non-empty sequence of them")
    n, m = plants[0].A.shape[0], plants[0].Bu.shape[1]
    if any(p.A.shape[0] != n or p.Bu.shape[1] != m for p in plants):
        raise PlantDataError(f"every plant must have {n} states and {m} inputs")
    if uncertainty == "vertex":
        for p in plants:
            _check_vertices(p.n_params, max_vertices)
    return plants


def design(plant: LFTPlant | Sequence[LFTPlant], K=None, *, w_hinf: float = 1.0, w_i2p: float = 100.0,
           alpha: float = 1e-4, beta: float = 10.0, sector: float | None = None, uncertainty: str = "norm",
           max_vertices: int = MAX_VERTICES, eps: float = EPS, rescale: bool = True,
           convention: str = "satfmu") -> RobustDesign:
    """Robust multi-objective state feedback ``u = K x`` with one Lyapunov matrix (module docstring).

    Minimizes ``w_hinf gamma + w_i2p nu`` (the seed's "+1*hinfty +100*i2p"; with
    ``convention="romuloc"`` the toolbox's ``w_hinf gamma^2 + w_i2p nu^2``) subject to, for
    every delta in ``[-1, 1]^N``: ``||w1 -> z1||_inf < gamma``; ``sup_t |z2(t)| <= nu`` after a
    unit impulse on w2; closed-loop eigenvalues in ``-beta < Re s < -alpha`` and, with ``sector``,
    in ``|Im s| < tan(sector) (-Re s)`` (damping ratio above ``cos(sector)``). The
    ``A_cl Y + Y A_cl^T < 0`` that the i2p bound needs is the alpha LMI (alpha >= 0).

    Parameters
    ----------
    plant : LFTPlant or sequence of LFTPlant
        Several plants: the same Lyapunov matrix, gain and levels for all (each with its own
        multipliers, named ``"i/hinf"`` etc.); a list of certain plants (:meth:`LFTPlant.at`)
        is the scenario program of a randomized design, solved by constraint generation when
        there are more than :data:`~satfmu.synthesis.robust.constraint_generation.SCENARIO_BATCH` (see
        ``active_plants`` of the result).
    K : ndarray, shape (m, n), optional
        A fixed gain: the same LMIs with ``W = K Y`` (linear in Y), i.e. the common-Lyapunov
        analysis of that gain (``gamma``, ``nu`` minimized for it). None: synthesis.
    w_hinf, w_i2p : float
        Objective weights (>= 0, not both 0).
    alpha, beta : float
        Pole region, 1/s: ``0 <= alpha < beta``.
    sector : float, optional
        Half-angle of the pole sector, rad, in (0, pi/2) (None: no sector).
    uncertainty : {"norm", "vertex"}
        D-G scalings (dual form) or full-block multipliers at the box vertices.
    max_vertices : int
        Largest ``2^N`` accepted with ``"vertex"``.
    eps : float
        Strictness of the LMIs in the solver.
    rescale : bool
        If the certificate fails :func:`~satfmu.synthesis.robust.certificate.certify`, solve once more in
        the coordinates where the first solve's Y has a unit diagonal (see ``state_scaling`` of
        the result); a ``"romuloc"`` synthesis is solved in the coordinates of the ``"satfmu"``
        design (``rescaling._in_our_coordinates``; False: in the caller's, once).
    convention : {"satfmu", "romuloc"}
        How the levels enter the LMIs and the objective (module docstring): ours (levels gamma,
        nu on both sides of each LMI) or the R-RoMulOC toolbox's (squared levels on the z side).

    Returns
    -------
    RobustDesign
        ``status == "optimal"`` only if re-verified by
        :func:`~satfmu.synthesis.robust.certificate.certify`; an infeasible problem returns
        ``"infeasible"`` (no exception).

    Raises
    ------
    OptionError, PlantDataError
        Bad options or a gain of the wrong shape.
    TooManyVerticesError
        With ``"vertex"`` when ``2^N > max_vertices`` (before anything is built).
    """
    _check_options(w_hinf, w_i2p, alpha, beta, uncertainty, eps)
    _check_convention(convention)
    if sector is not None and not (np.isfinite(sector) and 0 < sector < np.pi / 2):
        raise OptionError(f"sector must be a half-angle in (0, pi/2) rad, got {sector!r}")
    plants = _plant_list(plant, uncertainty, max_vertices)
    if K is not None:
        K = _check_gain(K, plants[0].Bu.shape[1], plants[0].A.shape[0])
    options: dict[str, Any] = {"hinf": True, "w_hinf": w_hinf, "w_i2p": w_i2p, "alpha": alpha, "beta": beta,
                               "uncertainty": uncertainty, "eps": eps, "sector": sector, "convention": convention,
                               "ladder": solve_policy.RungMemory()}
    if len(plants) > SCENARIO_BATCH and not any(p.n_params for p in plants):
        return _constraint_generation(plants, K, rescale, **options)
    if convention == "romuloc" and K is None and rescale:
        return _in_our_coordinates(plants, rescale, **options)
    return _rescaled_program(plants, K, rescale, **options)


def i2p_bound(plant: LFTPlant | Sequence[LFTPlant], K, *, alpha: float = 0.0, uncertainty: str = "norm",
              max_vertices: int = MAX_VERTICES, eps: float = EPS, rescale: bool = True) -> RobustDesign:
    """Deterministic impulse-to-peak bound of the loop ``u = K x`` over the whole box.

    Smallest ``nu`` with ``[[Y, B2], [B2^T, nu I]] >= 0``, ``C2 Y C2^T <= nu I`` and the robust
    ``A_cl Y + Y A_cl^T + 2 alpha Y < 0`` (same multipliers as :func:`design`, fixed K, no
    H-infinity or beta LMI): then ``sup_t |z2(t)| <= nu`` for every delta (module docstring).
    Returns a :class:`RobustDesign` with ``gamma = None``. Alone, the impulse-to-peak LMIs bound
    the same nu in both conventions (``Y = P / nu`` turns ours into the toolbox's), so this
    analysis has none.

    Parameters
    ----------
    plant : LFTPlant or sequence of LFTPlant
        The uncertain plant, or several sharing one Lyapunov matrix (as :func:`design`).
    K : numpy.ndarray, shape (m, n)
        The gain of ``u = K x`` to analyse.
    alpha : float, optional
        Pole region ``Re s < -alpha`` of the robust Lyapunov LMI, 1/s, >= 0 (0: stability).
    uncertainty : {"norm", "vertex"}, optional
        D-G scalings (dual form) or full-block multipliers at the box vertices.
    max_vertices : int, optional
        Largest ``2^N`` accepted with ``"vertex"``.
    eps : float, optional
        Strictness of the LMIs in the solver.
    rescale : bool, optional
        If the certificate fails :func:`~satfmu.synthesis.robust.certificate.certify`, solve once more in
        better-conditioned coordinates (as :func:`design`).

    Returns
    -------
    RobustDesign

    Raises
    ------
    OptionError, PlantDataError, TooManyVerticesError
        As :func:`design`.
    """
    _check_options(0.0, 1.0, alpha, None, uncertainty, eps)
    plants = _plant_list(plant, uncertainty, max_vertices)
    K = _check_gain(K, plants[0].Bu.shape[1], plants[0].A.shape[0])
    return _rescaled_program(plants, K, rescale, hinf=False, w_hinf=0.0, w_i2p=1.0, alpha=alpha, beta=None,
                             uncertainty=uncertainty, eps=eps, ladder=solve_policy.RungMemory())
