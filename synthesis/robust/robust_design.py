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
(``_dual_lmi``). For the regions drop ``z, w`` and replace ``(A, Bu, Bp)`` by ``(A +
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

Every result returned as ``"optimal"`` has been re-verified without the solver (:func:`verify`):
each LMI rebuilt in numpy from the returned matrices (with the returned K), its extreme
eigenvalue of the right sign with a margin; otherwise ``"unverified"``. An optimal
interior-point solution lies within the solver's accuracy (about 1e-8 of the largest entry) of
the boundary, often too close for such a check. So the minimizer is checked first at the levels
``1 + b`` times the optimum (b in :data:`BACKOFFS`: its LMIs are strict by eps, and raising the
levels only loosens them); if none verifies, a back-off solve follows: the levels fixed at
``1 + b`` times the optimum and the smallest strictness margin of all the LMIs maximized, for b
in :data:`BACKOFFS` until one verifies. The programs are built as arrays for Clarabel
(:mod:`satfmu.synthesis.core.lmi`).

The analysis of a given gain with a parameter-dependent Lyapunov function is
:mod:`satfmu.synthesis.robust.pdlf`; the exact norms of sampled loops, for independent checks of every bound,
are :mod:`satfmu.synthesis.core.system_norms`.
"""
from __future__ import annotations

import itertools
import logging
import time
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import scipy.linalg as sla

from satfmu.synthesis.core import lmi, solve_policy
from satfmu.synthesis.robust.lft_plant import (LFTPlant, OptionError, PlantDataError, _block_starts,
                                 _check_gain, _check_vertices,
                                 _matrix, _sym, box_vertices)

LOG = logging.getLogger(__name__)

ABS_MARGIN = 1e-9
"""Smallest eigenvalue margin accepted as strict (the solver is asked for ``eps``, default
1e-7; numpy's eigenvalue error is about 1e-16 times the largest entry)."""

BACKOFFS = (1e-4, 1e-3, 1e-2)
"""Relative back-offs of the optimal levels, tried in turn: after the minimization, gamma and
nu (or g) are fixed at ``(1 + b)`` times the solver's values and the smallest strictness margin
of all the LMIs is maximized (a second solve), so that the certificate checked without the
solver is far from the solver's accuracy (about 1e-8 relative to the largest entry). A larger b
is tried only when the certificate at the smaller one fails :func:`verify`: a poorly
conditioned program (DEMETER's momentum mode at -1e-3 1/s) can report an optimum slightly
below the true one, and no strictly feasible point exists at 1e-4 above it."""

MAX_VERTICES = 4096
"""Default largest number of box vertices (2^N) a vertex program may enumerate."""

CONVENTIONS = ("satfmu", "romuloc")
"""How the levels enter the LMIs (module docstring): ours, or the R-RoMulOC toolbox's."""

EPS = 1e-7
"""Default strictness of the LMIs in the solver."""


def _check_convention(convention: str) -> None:
    if convention not in CONVENTIONS:
        raise OptionError(f"convention must be one of {CONVENTIONS}, got {convention!r}")


def _check_eps(eps: float) -> None:
    if not (np.isfinite(eps) and eps > 0):
        raise OptionError(f"eps must be finite and > 0, got {eps!r}")


def _vertex_deltas(plant: LFTPlant) -> list[np.ndarray]:
    """``Delta`` at every vertex of the box, each (n_q, n_q)."""
    return [np.diag(np.repeat(v, plant.repetitions)) for v in box_vertices(plant.n_params)]


@dataclass
class RobustCheck:
    """Solver-independent check of a certificate (every LMI rebuilt in numpy).

    ``max_eig[name]``: largest eigenvalue of each matrix that must be negative definite (an
    array: one per vertex where the LMI is imposed per vertex); ``min_eig[name]``: smallest
    eigenvalue of each matrix that must be positive definite (Y, the i2p block, the
    scalings ``S_k`` or ``Qt``, ``P(delta_v)``). ``structure_error``: the largest deviation
    from the D-G structure (``Rt = -Qt``, ``St = -St^T``, both block diagonal), which must be
    exactly 0. ``margin``: the smaller of ``-max(max_eig)`` and ``min(min_eig)`` less the
    rounding allowance ``max(ABS_MARGIN, 1000 eps_machine scale)`` (``scale``: the largest entry
    of the matrices checked).

    Attributes
    ----------
    max_eig : dict of str to numpy.ndarray
        Largest eigenvalues of the matrices that must be negative definite, by name (``"hinf"``,
        ``"alpha"``, ``"hinf/vertices"``, ``"i2p/C2"``, ...).
    min_eig : dict of str to numpy.ndarray
        Smallest eigenvalues of the matrices that must be positive definite, by name (``"Y"``,
        ``"i2p/B2"``, ``"hinf/S"``, ...).
    margin : float
        The certificate's margin less the rounding allowance; > 0 when every matrix has the
        right sign.
    scale : float
        Largest absolute entry of the matrices checked.
    structure_error : float, optional
        Largest deviation from the D-G structure (0: exact).
    details : list of str, optional
        One line per matrix whose extreme eigenvalue misses the rounding allowance, and one for
        a violated D-G structure; empty when the check passes.
    """

    max_eig: dict[str, np.ndarray]
    min_eig: dict[str, np.ndarray]
    margin: float
    scale: float
    structure_error: float = 0.0
    details: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return self.margin > 0 and self.structure_error == 0


def _allowance(scale: float) -> float:
    """The rounding allowance of a check whose largest matrix entry is ``scale``."""
    return max(ABS_MARGIN, 1e3 * np.finfo(float).eps * scale)


def _finish_check(neg: dict[str, list[np.ndarray]], pos: dict[str, list[np.ndarray]],
                  structure_error: float = 0.0) -> RobustCheck:
    scale = max(float(np.max(np.abs(m))) for mats in (*neg.values(), *pos.values()) for m in mats if m.size)
    max_eig = {k: np.array([np.linalg.eigvalsh(m)[-1] for m in v]) for k, v in neg.items()}
    min_eig = {k: np.array([np.linalg.eigvalsh(m)[0] for m in v]) for k, v in pos.items()}
    allowance = _allowance(scale)
    top = max(float(v.max()) for v in max_eig.values())
    low = min(float(v.min()) for v in min_eig.values())
    details = [f"{k}: max eig {v.max():.3e}" for k, v in max_eig.items() if v.max() > -allowance]
    details += [f"{k}: min eig {v.min():.3e}" for k, v in min_eig.items() if v.min() < allowance]
    if structure_error:
        details.append(f"D-G structure violated by {structure_error:.3e}")
    return RobustCheck(max_eig, min_eig, min(-top, low) - allowance, scale, structure_error, details)


@dataclass
class Multiplier:
    """Dual multiplier ``Pi~ = [[Q, S], [S^T, R]]`` on ``(q, p)`` of one robust LMI.

    D-G (``kind="norm"``): ``Q = blockdiag(S_k) > 0``, ``S = blockdiag(H_k)`` skew, ``R = -Q``.
    Full block (``kind="vertex"``): free, ``Q > 0`` and the vertex inequalities.

    Attributes
    ----------
    kind : {"norm", "vertex"}
        D-G scalings or full-block multiplier.
    Q : numpy.ndarray, shape (n_q, n_q)
        Block on q (positive definite).
    S : numpy.ndarray, shape (n_q, n_q)
        Coupling block of q and p.
    R : numpy.ndarray, shape (n_q, n_q)
        Block on p.
    """

    kind: str
    Q: np.ndarray
    S: np.ndarray
    R: np.ndarray


@dataclass(frozen=True)
class _Spec:
    """One robust LMI: the loop ``x' = A x + Bu u + Bp p + Bw w`` with the q channel of
    ``plant`` and ``z = Cz x + Dzu u + Dzp p + Dzw w`` (no w, z: a Lyapunov/region condition),
    in ``copies`` copies of the state (``Y``, ``W`` enter as ``I_copies (x) Y``, ``(x) W``)."""

    name: str
    plant: LFTPlant
    A: np.ndarray
    Bu: np.ndarray
    Bp: np.ndarray
    Bw: np.ndarray
    Dqw: np.ndarray
    Cz: np.ndarray
    Dzu: np.ndarray
    Dzp: np.ndarray
    Dzw: np.ndarray
    copies: int = 1


def _region_spec(name: str, plant: LFTPlant, A, Bu, Bp, copies: int = 1) -> _Spec:
    n, nq, m = A.shape[0], plant.Cq.shape[0], Bu.shape[1]
    return _Spec(name, plant, A, Bu, Bp, np.zeros((n, 0)), np.zeros((nq, 0)), np.zeros((0, n)), np.zeros((0, m)),
                 np.zeros((0, nq)), np.zeros((0, 0)), copies)


def _sector_plant(plant: LFTPlant, theta: float) -> LFTPlant:
    """The LFT of ``M (x) A_cl(Delta)``, ``M = [[sin t, cos t], [-cos t, sin t]]``: the q channel
    doubled (``I_2 (x) Delta``), reordered so that each parameter's ``2 r_k`` channels are
    contiguous (one D-G block or vertex value per parameter); w, z unused (zeros)."""
    M = np.array([[np.sin(theta), np.cos(theta)], [-np.cos(theta), np.sin(theta)]])
    I2 = np.eye(2)
    nq, n, m = plant.Cq.shape[0], plant.A.shape[0], plant.Bu.shape[1]
    start = _block_starts(plant.repetitions)
    perm = np.concatenate([np.r_[a:b, nq + a:nq + b] for a, b in itertools.pairwise(start)]).astype(int) \
        if nq else np.zeros(0, int)
    z = np.zeros
    return LFTPlant(np.kron(M, plant.A), np.kron(M, plant.Bp)[:, perm], np.kron(M, plant.Bu), z((2 * n, 1)),
                    z((2 * n, 1)), np.kron(I2, plant.Cq)[perm], np.kron(I2, plant.Dqp)[np.ix_(perm, perm)],
                    np.kron(I2, plant.Dqu)[perm], z((2 * nq, 1)), z((1, 2 * n)), z((1, 2 * nq)), z((1, 2 * m)),
                    z((1, 1)), z((1, 2 * n)), tuple((name, 2 * r) for name, r in plant.blocks))


ROBUST_LMIS = ("hinf", "alpha", "beta", "sector")
"""Names of the robust LMIs of ``_specs``."""


def _specs(plant: LFTPlant, alpha: float, beta: float | None, hinf: bool, sector: float | None = None
           ) -> list[_Spec]:
    """The robust LMIs: "hinf" (if asked), "alpha" (``Re s < -alpha``), "beta" (``Re s > -beta``,
    if given), "sector" (``|Im s| < tan(sector) (-Re s)``, if given; Chilali & Gahinet, IEEE TAC
    41, 1996: ``He(M (x) A_cl Y) < 0``)."""
    n = plant.A.shape[0]
    out = []
    if hinf:
        out.append(_Spec("hinf", plant, plant.A, plant.Bu, plant.Bp, plant.B1, plant.Dq1, plant.C1, plant.D1u,
                         plant.D1p, plant.D11))
    out.append(_region_spec("alpha", plant, plant.A + alpha * np.eye(n), plant.Bu, plant.Bp))
    if beta is not None:
        out.append(_region_spec("beta", plant, -plant.A - beta * np.eye(n), -plant.Bu, -plant.Bp))
    if sector is not None:
        sp = _sector_plant(plant, sector)
        out.append(_region_spec("sector", sp, sp.A, sp.Bu, sp.Bp, copies=2))
    return out


Selection = tuple[frozenset[str], ...] | None
"""Per plant of a program, the names of its robust LMIs that the program imposes (``_specs``;
its i2p blocks always): a constraint generation's subset. None: every LMI of every plant."""


def _selected_specs(plants: tuple[LFTPlant, ...], alpha: float, beta: float | None, hinf: bool,
                    sector: float | None, only: Selection) -> list[list[_Spec]]:
    """:func:`_specs` of each plant, those ``only`` names (all if None)."""
    return [[s for s in _specs(p, alpha, beta, hinf, sector) if only is None or s.name in only[i]]
            for i, p in enumerate(plants)]


def _weights(convention: str, level) -> tuple:
    """``(z side, w side)`` of an H-infinity or impulse-to-peak LMI at the program's level (a
    variable or a number): ``(level, level)`` in ``"satfmu"``, ``(level, 1)`` in ``"romuloc"``."""
    return (level, level) if convention == "satfmu" else (level, 1.0)


def _level(convention: str, bound: float) -> float:
    """The program's level of a bound (gamma or nu): itself, or its square in ``"romuloc"``."""
    return bound if convention == "satfmu" else bound**2


def _bound(convention: str, level: float) -> float:
    """The bound (gamma or nu) certified by a program's level: :func:`_level` inverted."""
    return level if convention == "satfmu" else float(np.sqrt(level))


def _dual_lmi(s: _Spec, Y, W, mult, weights, stack, bmat):
    """The dual robust LMI of spec ``s`` (must be < 0), rows ``(x', q, z, w)``, built with the
    array functions given: numpy's (``np.vstack, np.block``) for a check, :mod:`satfmu.synthesis.core.lmi`'s for
    the program.

    ``mult = (Qt, St, Rt)`` (ignored when ``n_q = 0``); ``weights = (z side, w side)`` of the
    level (:func:`_weights`), unused without w, z.
    """
    plant = s.plant
    if s.copies == 2:
        Y = bmat([[Y, np.zeros(Y.shape)], [np.zeros(Y.shape), Y]])
        W = bmat([[W, np.zeros(W.shape)], [np.zeros(W.shape), W]])
    n, nq, nz, nw = s.A.shape[0], plant.Cq.shape[0], s.Cz.shape[0], s.Bw.shape[1]
    rows, gp, gw = [s.A @ Y + s.Bu @ W], [s.Bp], [s.Bw]
    if nq:
        rows.append(plant.Cq @ Y + plant.Dqu @ W)
        gp.append(plant.Dqp)
        gw.append(s.Dqw)
    if nz:
        rows.append(s.Cz @ Y + s.Dzu @ W)
        gp.append(s.Dzp)
        gw.append(s.Dzw)
    dim = n + nq + nz
    E = np.eye(dim)
    Ex, Eq, Ez = E[:, :n], E[:, n:n + nq], E[:, n + nq:]
    T = stack(rows) @ Ex.T
    L = T + T.T
    if nq:
        Qt, St, Rt = mult
        Gp = np.vstack(gp)
        U = Gp @ St.T @ Eq.T
        L = L + U + U.T - Gp @ Rt @ Gp.T - Eq @ Qt @ Eq.T
    if nz:
        L = L - weights[0] * (Ez @ Ez.T)
    if nw:
        Gw = np.vstack(gw)
        L = bmat([[L, Gw], [Gw.T, -weights[1] * np.eye(nw)]])
    return (L + L.T) / 2


def _i2p_blocks(plant: LFTPlant, Y, weights, bmat) -> tuple:
    """``[[Y, B2], [B2^T, w I]]`` (must be > 0) and ``C2 Y C2^T - z I`` (must be < 0), ``(z, w) =
    weights`` (:func:`_weights`: ``(nu, nu)``, or ``(g_i2p, 1)`` in the toolbox's form)."""
    m2, p2 = plant.B2.shape[1], plant.C2.shape[0]
    upper = bmat([[Y, plant.B2], [plant.B2.T, weights[1] * np.eye(m2)]])
    lower = plant.C2 @ Y @ plant.C2.T - weights[0] * np.eye(p2)
    return (upper + upper.T) / 2, (lower + lower.T) / 2


def _vertex_condition(Qt, St, Rt, D: np.ndarray):
    """``Delta Qt Delta - Delta St - St^T Delta + Rt`` (the dual multiplier inequality, <= 0)."""
    V = D @ Qt @ D - D @ St - St.T @ D + Rt
    return (V + V.T) / 2


def _blockdiag(mats: list, sizes: list[int]) -> lmi.Affine:
    return lmi.bmat([[mats[i] if i == j else np.zeros((sizes[i], sizes[j])) for j in range(len(sizes))]
                     for i in range(len(sizes))])


def _multiplier_program(prog: lmi.LMIProgram, plant: LFTPlant, uncertainty: str, deltas: list[np.ndarray], margin):
    """The ``(Qt, St, Rt)`` expressions of one multiplier, its conditions (strict by ``margin``)
    added to ``prog``, and a function returning the numeric :class:`Multiplier` after the solve."""
    reps = [int(r) for r in plant.repetitions]
    nq = sum(reps)
    if uncertainty == "norm":
        S = [prog.variable((r, r), symmetric=True) for r in reps]
        U = [prog.variable((r, r)) if r > 1 else None for r in reps]
        H = [u - u.T if u is not None else np.zeros((1, 1)) for u in U]
        for s, r in zip(S, reps):
            prog.add_psd(s - margin * np.eye(r))
        Qt, St = _blockdiag(S, reps), _blockdiag(H, reps)

        def norm_value() -> Multiplier:
            Q = sla.block_diag(*[_sym(prog.value(s)) for s in S])
            Hs = sla.block_diag(*[prog.value(h) if isinstance(h, lmi.Affine) else h for h in H])
            return Multiplier("norm", Q, Hs, -Q)

        return (Qt, St, -Qt), norm_value
    Qt = prog.variable((nq, nq), symmetric=True)
    St = prog.variable((nq, nq))
    Rt = prog.variable((nq, nq), symmetric=True)
    prog.add_psd(Qt - margin * np.eye(nq))
    for D in deltas:
        prog.add_psd(-_vertex_condition(Qt, St, Rt, D) - margin * np.eye(nq))

    def value() -> Multiplier:
        return Multiplier("vertex", _sym(prog.value(Qt)), prog.value(St), _sym(prog.value(Rt)))

    return (Qt, St, Rt), value


def _dg_structure_error(mult: Multiplier, reps: np.ndarray) -> float:
    """Largest deviation of a D-G multiplier from its structure (0 when exact)."""
    mask = sla.block_diag(*[np.ones((r, r)) for r in reps]) == 0
    return float(max(np.max(np.abs(mult.R + mult.Q)), np.max(np.abs(mult.S + mult.S.T)),
                     np.max(np.abs(mult.Q[mask]), initial=0.0), np.max(np.abs(mult.S[mask]), initial=0.0)))


def verify(plant: LFTPlant, K, Y, gamma: float | None, nu: float, multipliers: dict[str, Multiplier], *,
           alpha: float, beta: float | None, sector: float | None = None, convention: str = "satfmu"
           ) -> RobustCheck:
    """Check the dual robust LMIs of :func:`design` / :func:`i2p_bound` with numpy only.

    Rebuilds, from the returned ``K, Y`` (``W = K Y``), ``gamma``, ``nu`` and multipliers: every
    robust LMI (``"hinf"`` if gamma is given, ``"alpha"``, ``"beta"`` if beta is given), the
    multiplier conditions (D-G: structure exact, ``S_k > 0``; full block: ``Qt > 0`` and the
    vertex inequality at every vertex), ``Y > 0`` and the i2p blocks.

    Parameters
    ----------
    plant : LFTPlant
        The uncertain plant the certificate is for.
    K : ndarray, shape (m, n)
        The gain of ``u = K x``.
    Y : ndarray, shape (n, n)
        The common Lyapunov matrix ``Y = P^-1``.
    gamma : float or None
        H-infinity bound (None: no H-infinity LMI, as in :func:`i2p_bound`).
    nu : float
        Impulse-to-peak bound.
    multipliers : dict
        :class:`Multiplier` per robust LMI name (empty when the plant has no blocks).
    alpha, beta : float
        The pole region (beta None: no ``Re s > -beta`` LMI).
    sector : float, optional
        Half-angle (rad) of the sector ``|Im s| < tan(sector) (-Re s)`` (None: no sector LMI).
    convention : {"satfmu", "romuloc"}
        How the bounds enter the LMIs (module docstring).
    """
    _check_convention(convention)
    n = plant.A.shape[0]
    K = _check_gain(K, plant.Bu.shape[1], n)
    Y = _matrix("Y", Y)
    if Y.shape != (n, n):
        raise PlantDataError(f"Y must have shape ({n}, {n}), got {Y.shape}")
    Y = _sym(Y)
    W = K @ Y
    neg: dict[str, list[np.ndarray]] = {}
    pos: dict[str, list[np.ndarray]] = {"Y": [Y]}
    structure = 0.0
    for s in _specs(plant, alpha, beta, gamma is not None, sector):
        triple = None
        if plant.n_params:
            if s.name not in multipliers:
                raise PlantDataError(f"no multiplier for the {s.name!r} LMI")
            mu = multipliers[s.name]
            triple = (mu.Q, mu.S, mu.R)
            if mu.kind == "norm":
                structure = max(structure, _dg_structure_error(mu, s.plant.repetitions))
                start = _block_starts(s.plant.repetitions)
                pos[f"{s.name}/S"] = [mu.Q[a:b, a:b] for a, b in itertools.pairwise(start)]
            else:
                pos[f"{s.name}/Q"] = [mu.Q]
                neg[f"{s.name}/vertices"] = [_vertex_condition(mu.Q, mu.S, mu.R, D)
                                             for D in _vertex_deltas(s.plant)]
        weights = None if gamma is None else _weights(convention, _level(convention, gamma))
        neg[s.name] = [_dual_lmi(s, Y, W, triple, weights, np.vstack, np.block)]
    upper, lower = _i2p_blocks(plant, Y, _weights(convention, _level(convention, nu)), np.block)
    pos["i2p/B2"] = [upper]
    neg["i2p/C2"] = [lower]
    return _finish_check(neg, pos, structure)


@dataclass
class RobustDesign:
    """Result of :func:`design` or :func:`i2p_bound`.

    ``status``: ``"optimal"`` (solved and verified: K, gamma, nu, Y, multipliers certified),
    ``"infeasible"`` (the solver proved infeasibility), ``"unverified"`` (a solution that failed
    :func:`verify`, or no usable solver answer; K, gamma, nu are then None, ``check`` tells why).
    ``gamma`` (H-infinity bound, units of z1/w1) and ``nu`` (peak bound, units of z2 per unit
    impulse of w2) are the bounds of the program's optimal levels times ``1 + backoff`` (the
    first of :data:`BACKOFFS` that verifies), at which the returned certificate (from the
    back-off solve) is verified: the levels themselves in the ``"satfmu"`` ``convention``, their
    square roots in ``"romuloc"`` (levels ``gamma^2``, ``nu^2``);
    ``solver_objective`` is the minimized objective itself (``w_hinf gamma + w_i2p nu``, or
    ``w_hinf gamma^2 + w_i2p nu^2`` in ``"romuloc"``; not certified).
    ``n_vertices``: box
    vertices enumerated (0 with D-G scalings); ``n_multipliers``: scaling pairs (D-G: one per
    block and robust LMI) or full-block multipliers (one per robust LMI). Times in seconds:
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
        :func:`i2p_bound`).
    nu : float or None
        Impulse-to-peak bound of ``w2 -> z2``, units of z2 per unit impulse of w2.
    Y : numpy.ndarray, shape (n, n), or None
        The common Lyapunov matrix ``Y = P^-1``, in the plant's coordinates.
    multipliers : dict of str to Multiplier
        The multiplier of each robust LMI, by name (``"hinf"``, ``"alpha"``, ...; ``"i/hinf"``
        for plant i of several); empty for a plant without uncertain parameters.
    check : RobustCheck or None
        :func:`verify` of the returned certificate, or of the last one tried when it failed;
        None when the solver gave no solution.
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
        The back-off of :data:`BACKOFFS` that verified.
    state_scaling : numpy.ndarray, shape (n,), optional
        T of the coordinates ``x = diag(T) x_s`` of the certificate (None: the plant's own).
    active_plants : int, optional
        Plants with an LMI in the last program of the constraint generation over many plants
        (None: all).
    convention : {"satfmu", "romuloc"}, optional
        How the levels entered the LMIs (:data:`CONVENTIONS`).
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
    """How the levels entered the LMIs (:data:`CONVENTIONS`)."""


def _failed(out: solve_policy.SolveOutcome) -> str:
    """Status of a minimization without a solution: proved infeasible, or no usable answer."""
    return "infeasible" if out.status == "infeasible" else "unverified"


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


def _key(i: int, name: str, n_plants: int) -> str:
    """Name of a robust LMI: the spec's, prefixed by the plant's index when there are several."""
    return name if n_plants == 1 else f"{i}/{name}"


def _distinct_i2p(plants: tuple[LFTPlant, ...]) -> list[int]:
    """The index of one plant per distinct ``(B2, C2)``: the i2p blocks of the others are the same LMIs."""
    out: list[int] = []
    for i, p in enumerate(plants):
        if not any(np.array_equal(p.B2, plants[j].B2) and np.array_equal(p.C2, plants[j].C2) for j in out):
            out.append(i)
    return out


def _robust_constraints(prog: lmi.LMIProgram, plants: tuple[LFTPlant, ...], K: np.ndarray | None,
                        specs: list[list[_Spec]], uncertainty: str, margin, gamma, nu, convention: str = "satfmu"
                        ) -> tuple[lmi.Affine, lmi.Affine, dict]:
    """``(Y, W, multiplier values)`` of the common-Lyapunov program over every plant (``specs[i]``
    of plant i), its LMIs added to ``prog``, every one strict by ``margin`` (eps, or the variable
    the back-off maximizes); gamma, nu the program's levels (:func:`_level`), variables or
    constants (nu None: no impulse-to-peak LMIs). Each plant's LMIs are tagged with its index
    ``(plant index, LMI name)`` (:meth:`lmi.LMIProgram.dual_weights`; the i2p blocks
    ``(i, "i2p")`` with the plant that carries them)."""
    n, m = plants[0].A.shape[0], plants[0].Bu.shape[1]
    Y = prog.variable((n, n), symmetric=True)
    W = prog.variable((m, n)) if K is None else K @ Y
    prog.add_psd(Y - margin * np.eye(n))
    values = {}
    for i, (plant, plant_specs) in enumerate(zip(plants, specs)):
        for s in plant_specs:
            triple = None
            if plant.n_params:
                deltas = _vertex_deltas(s.plant) if uncertainty == "vertex" else []
                triple, values[_key(i, s.name, len(plants))] = _multiplier_program(
                    prog, s.plant, uncertainty, deltas, margin)
            L = _dual_lmi(s, Y, W, triple, _weights(convention, gamma), lmi.vstack, lmi.bmat)
            prog.add_psd(-L - margin * np.eye(L.shape[0]), tag=(i, s.name))
    for i in _distinct_i2p(plants) if nu is not None else ():
        upper, lower = _i2p_blocks(plants[i], Y, _weights(convention, nu), lmi.bmat)
        prog.add_psd(upper - margin * np.eye(upper.shape[0]), tag=(i, "i2p"))
        prog.add_psd(-lower - margin * np.eye(lower.shape[0]), tag=(i, "i2p"))
    return Y, W, values


def _verify_plants(plants: tuple[LFTPlant, ...], K, Y, gamma, nu, multipliers: dict[str, Multiplier], *,
                   alpha: float, beta: float | None, sector: float | None, convention: str,
                   only: Selection = None) -> RobustCheck:
    """:func:`verify` at every plant, merged: the smallest margin, names prefixed as :func:`_key`;
    with ``only``, each plant's check judged on the robust LMIs the program imposed
    (:func:`_judged_on`)."""
    options: dict[str, Any] = {"alpha": alpha, "beta": beta, "sector": sector, "convention": convention}
    checks = []
    for i, plant in enumerate(plants):
        own = multipliers if len(plants) == 1 else {k.split("/", 1)[1]: v for k, v in multipliers.items()
                                                    if k.startswith(f"{i}/")}
        check = verify(plant, K, Y, gamma, nu, own, **options)
        checks.append(check if only is None else _judged_on(check, only[i]))
    return checks[0] if len(plants) == 1 else _merge_checks(checks)


def _judged_on(check: RobustCheck, names: frozenset[str]) -> RobustCheck:
    """``check`` with its margin over the robust LMIs ``names`` and the other matrices (Y, the
    i2p blocks, the multipliers' conditions) only: the LMIs a program left out are not its to
    meet. The rounding allowance stays the whole check's."""
    left_out = {s for s in ROBUST_LMIS if s not in names}
    max_eig = {k: v for k, v in check.max_eig.items() if k.split("/")[0] not in left_out}
    min_eig = {k: v for k, v in check.min_eig.items() if k.split("/")[0] not in left_out}
    allowance = _allowance(check.scale)
    top = max((float(v.max()) for v in max_eig.values()), default=-np.inf)
    low = min((float(v.min()) for v in min_eig.values()), default=np.inf)
    details = [d for d in check.details if d.split("/")[0].split(":")[0] not in left_out]
    return replace(check, margin=min(-top, low) - allowance, details=details)


def _merge_checks(checks: list[RobustCheck]) -> RobustCheck:
    """One check of several plants' (names prefixed by the plant's index)."""
    worst = min(range(len(checks)), key=lambda i: checks[i].margin)
    return RobustCheck({f"{i}/{k}": v for i, c in enumerate(checks) for k, v in c.max_eig.items()},
                       {f"{i}/{k}": v for i, c in enumerate(checks) for k, v in c.min_eig.items()},
                       checks[worst].margin, max(c.scale for c in checks),
                       max(c.structure_error for c in checks), [f"plant {worst}: {d}" for d in checks[worst].details])


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
    :func:`verify`, the same again (up to ``depth`` times) in the coordinates where the
    minimizer's Y has a unit diagonal (``x = diag(sqrt(Y_ii)) x_s``); failing that, the larger
    back-offs at the same minimizer. When Y's diagonal spans less than :data:`RESCALE_SPREAD`,
    the larger back-offs come before the rescaling (the scaling is not what fails). Each
    program is minimized once (``minimizer``: its :func:`_minimize` already done by the
    caller): the solver is deterministic, so solving it again would give the same answer, or
    the same failure.

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

    The same Y serves both conventions up to the levels' scale, but the solver's path does not:
    in the toolbox's forms the constants ``Bw Bw^T`` and ``B2 B2^T`` fix Y's size, which follows
    the slow momentum mode's Gramian (DEMETER: 10^5 times the stiff states' entries), and the
    interior-point iterates stall (two-axis rows: NumericalError, or a certificate that fails
    :func:`verify` at every back-off, in 30 s); ours keeps the levels on both sides of each LMI
    and converges. In its coordinates the toolbox's program is well scaled: DEMETER row 10 then
    takes one solve (1.6 s) and its minimizer verifies at the first back-off. Any well-scaled
    coordinates do: the D-G design's Y is within a factor of a few of the vertex design's on
    the diagonal, and costs a tenth (DEMETER row 12: 8 s instead of 105 s; the whole design 71 s,
    was 625 s in the vertex design's coordinates).

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


def _with_times(res: RobustDesign, others: list[RobustDesign]) -> RobustDesign:
    """``res`` with the solve and build times of ``others`` (the solves made before it) added."""
    return replace(res, solve_seconds=res.solve_seconds + sum(o.solve_seconds for o in others),
                   build_seconds=res.build_seconds + sum(o.build_seconds for o in others))


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
    program's: :func:`_level`), the multipliers, the objective, the times, the result's info
    and each LMI's dual weight (``support``: :meth:`lmi.LMIProgram.dual_weights` per
    ``(plant index, LMI name)``, "i2p" for a plant's i2p blocks; zero where the LMI does not
    bind)."""

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
        """The bounds (:func:`_bound`) at the levels times ``1 + b``."""
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
        check = _verify_plants(plants, Kv, Yv, g, nv, mults, alpha=alpha, beta=beta, sector=sector,
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
        check = _verify_plants(plants, m.K, m.Y, g, nv, m.multipliers, alpha=options["alpha"], beta=options["beta"],
                               sector=options.get("sector"), convention=convention, only=options.get("only"))
        if check.ok:
            status = m.times["solver_status"] + f"; the minimizer verified at back-off {b:g}"
            return RobustDesign("optimal", m.K, g, nv, m.Y, m.multipliers, check, m.optimum, **m.info,
                                **{**m.times, "solver_status": status}, backoff=b)
    return _back_off(plants, K, m, backoffs, **options)


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
        there are more than :data:`SCENARIO_BATCH` (see ``active_plants`` of the result).
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
        If the certificate fails :func:`verify`, solve once more in the coordinates where the
        first solve's Y has a unit diagonal (see ``state_scaling`` of the result); a
        ``"romuloc"`` synthesis is solved in the coordinates of the ``"satfmu"`` design
        (``_in_our_coordinates``; False: in the caller's, once).
    convention : {"satfmu", "romuloc"}
        How the levels enter the LMIs and the objective (module docstring): ours (levels gamma,
        nu on both sides of each LMI) or the R-RoMulOC toolbox's (squared levels on the z side).

    Returns
    -------
    RobustDesign
        ``status == "optimal"`` only if re-verified by :func:`verify`; an infeasible problem
        returns ``"infeasible"`` (no exception).

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


SCENARIO_BATCH = 100
"""The most LMIs ``_constraint_generation`` adds per round; :func:`design` solves more
certain plants than this by constraint generation."""

SCENARIO_FIRST = 10
"""Plants in the first program of ``_constraint_generation`` (every LMI of each)."""

SUPPORT_TOL = 1e-4
"""An LMI whose dual weight (``_Minimizer`` ``support``) is below this fraction of the
largest does not bind: ``_constraint_generation`` leaves it out of the next round (DEMETER
row 1: 9 plants of 110 between 0.03 and 1, the others at 2e-6 to 8e-6, the interior-point
path's floor)."""


def _lmi_margins(check: RobustCheck) -> dict[str, float]:
    """Each LMI's margin in one plant's check (as :attr:`RobustCheck.margin`): the robust LMIs
    by name, ``"i2p"`` the two i2p blocks', ``"Y"`` the Lyapunov matrix's."""
    allowance = _allowance(check.scale)
    out = {k: -float(v.max()) - allowance for k, v in check.max_eig.items() if k in ROBUST_LMIS}
    out["i2p"] = min(float(check.min_eig["i2p/B2"].min()), -float(check.max_eig["i2p/C2"].max())) - allowance
    out["Y"] = float(check.min_eig["Y"].min()) - allowance
    return out


def _i2p_representatives(plants: tuple[LFTPlant, ...]) -> list[int]:
    """For each plant, the first plant with the same ``(B2, C2)``: the same i2p blocks."""
    first: dict[bytes, int] = {}
    return [first.setdefault(p.B2.tobytes() + p.C2.tobytes() + bytes(str(p.B2.shape + p.C2.shape), "ascii"), i)
            for i, p in enumerate(plants)]


def _constraint_generation(plants: tuple[LFTPlant, ...], K: np.ndarray | None, rescale: bool, **options
                           ) -> RobustDesign:
    """The program over many certain plants (scenarios), solved on a changing subset of their LMIs.

    Each plant brings its robust LMIs (:func:`_specs`: "hinf", "alpha", "beta", "sector") and
    its i2p blocks ("i2p", one per distinct ``(B2, C2)``); the subset is a set of such
    ``(plant, LMI)`` pairs. Minimize over every LMI of the first :data:`SCENARIO_FIRST` plants;
    :func:`verify` every plant at the minimizer (levels at each of :data:`BACKOFFS` in turn
    while only LMIs of the subset fail: larger levels loosen every LMI); if any outside the
    subset is violated, the next subset is the LMIs that bind (dual weight above
    :data:`SUPPORT_TOL`; one left out once stays in when it comes back, so the rounds end; if
    the smaller subset gives no answer, those left out are put back) and the most violated
    outside (at most :data:`SCENARIO_BATCH`), minimized again in the coordinates where the last
    minimizer's Y has a unit diagonal (as :func:`_rescaled_program`). When only LMIs of the
    subset fail, the back-off solves at the minimizer's levels in those coordinates
    (:func:`_back_off`, from the back-off that verified in the last round: DEMETER row 13
    failed at 1e-4 and 1e-3 and verified at 1e-2 in each round; failing them, the subset's
    certified solve :func:`_rescaled_program`) and :func:`verify` of every plant at the
    answer; LMIs it violates join the subset and the rounds go on.

    Leaving out LMIs that do not bind keeps the optimum (convex program, complementary
    slackness), so each subset's optimum is a lower bound of the whole program's, and the
    returned certificate, verified on every LMI of every plant, is feasible for it at the last
    optimum times ``1 + backoff``. An infeasible subset proves the whole program infeasible. A
    scenario program has at most as many support constraints as decision variables, and in
    practice far fewer, so the solver never sees the thousands of LMIs at once; of a binding
    plant's LMIs often only one binds (DEMETER row 9: 131 LMIs of 110 plants in its second
    round, against 330 when every LMI of a plant came with it).
    """
    convention = options["convention"]
    check_options = {"alpha": options["alpha"], "beta": options["beta"], "sector": options["sector"],
                     "convention": convention}
    names = [s.name for s in _specs(plants[0], options["alpha"], options["beta"], options["hinf"],
                                    options["sector"])]
    rep = _i2p_representatives(plants)
    first = range(min(SCENARIO_FIRST, len(plants)))
    active = list(dict.fromkeys([(i, name) for i in first for name in names] + [(rep[i], "i2p") for i in first]))
    left_out: set[tuple[int, str]] = set()
    T = np.ones(plants[0].A.shape[0])
    seconds: dict[str, Any] = {"solve_seconds": 0.0, "build_seconds": 0.0}  # floats, passed as keywords
    status: list[str] = []

    def subset(T: np.ndarray) -> tuple[list[int], tuple[LFTPlant, ...], np.ndarray | None, dict]:
        """The subset's plants (indices; in the coordinates T), gain and solve options."""
        idx = list(dict.fromkeys(i for i, _ in active))
        chosen: dict[int, set[str]] = {i: set() for i in idx}
        for i, name in active:
            chosen[i].add(name)
        return (idx, tuple(plants[i].scale_states(T) for i in idx), None if K is None else K * T,
                {**options, "only": tuple(frozenset(chosen[i]) for i in idx)})

    def size() -> str:
        return f"{len(active)} LMIs of {len({i for i, _ in active})} plants"

    def say(line: str) -> None:
        """One round's line of the result's ``solver_status``, also logged (INFO)."""
        status.append(line)
        LOG.info("constraint generation: %s", line)

    def account(res) -> None:
        for k in seconds:
            seconds[k] += res.times[k] if isinstance(res, _Minimizer) else getattr(res, k)

    def check_all(K, Y, gamma, nu) -> tuple[list[RobustCheck], list[tuple[int, str]]]:
        """Every plant's check in the coordinates T, and the worst violated LMIs outside the subset
        (Y > 0 is in every subset)."""
        checks = [verify(p.scale_states(T), K, Y, gamma, nu, {}, **check_options) for p in plants]
        inside = set(active)
        worst = sorted((v, key) for i, c in enumerate(checks) if not c.ok for name, v in _lmi_margins(c).items()
                       if v <= 0 and name != "Y" and (key := (rep[i] if name == "i2p" else i, name)) not in inside)
        return checks, list(dict.fromkeys(key for _, key in worst))[:SCENARIO_BATCH]

    def binding(m: _Minimizer, idx: list[int]) -> set[tuple[int, str]]:
        top = max(m.support.values())
        return {(rep[idx[j]] if name == "i2p" else idx[j], name) for (j, name), w in m.support.items()
                if w >= SUPPORT_TOL * top}

    restore: list[tuple[int, str]] = []  # the LMIs the last round left out
    first_backoff = 0  # index in BACKOFFS of the back-off solves' first try
    while True:
        idx, sub, Ks, sub_options = subset(T)
        m = _minimize(sub, Ks, **sub_options)
        res = None
        if not isinstance(m, _Minimizer) and m.status != "infeasible" and restore:
            # no answer without them (DEMETER row 7: NumericalError at 24 plants, not at 39)
            say(f"{size()}: {m.solver_status}; the {len(restore)} left out put back")
            account(m)
            active, restore = restore + active, []
            continue
        if isinstance(m, _Minimizer):
            account(m)
            say(f"{size()}: {m.times['solver_status']}")
            for b in BACKOFFS:  # larger levels only loosen the LMIs: those outside stay met
                g, nv = m.levels(convention, b)
                checks, new = check_all(m.K, m.Y, g, nv)
                if new or all(c.ok for c in checks):
                    break
            if all(c.ok for c in checks):  # the minimizer is the certificate
                res = RobustDesign("optimal", m.K, g, nv, m.Y, {}, _merge_checks(checks), m.optimum, **m.info,
                                   **seconds, solver_status="; ".join(status) + f"; the minimizer verified at "
                                   f"back-off {b:g}", backoff=b)
                return replace(_back_to_caller(res, T), active_plants=len(idx))
            if rescale and np.all(np.diag(m.Y) > 0):
                T = T * np.sqrt(np.diag(m.Y))
            if new:
                keep = binding(m, idx)
                dropped = {k for k in active if k not in keep and k not in left_out}
                left_out |= dropped
                restore = [k for k in active if k in dropped]
                active = [k for k in active if k not in dropped] + new
                continue
            idx, sub, Ks, sub_options = subset(T)
            res = _back_off(sub, Ks, replace(m, times={k: 0.0 for k in seconds} | {"solver_status": ""}),
                            BACKOFFS[first_backoff:], **sub_options)  # m's times already counted
            account(res)
            if res.status == "optimal":  # smaller back-offs failed: the next round starts at this one
                first_backoff = BACKOFFS.index(res.backoff)
            say(f"{size()} at the minimizer's levels: {res.solver_status.removeprefix('; ')}")
        if res is None or res.status != "optimal":  # m: this program's failed minimization, if it was
            res = _rescaled_program(sub, Ks, rescale, minimizer=None if res is not None else m, **sub_options)
            account(res)
            say(f"{size()}, certified: {res.solver_status}")
        res = replace(res, **seconds, solver_status="; ".join(status), active_plants=len(idx))
        if res.status != "optimal":
            return res
        res = _back_to_caller(res, T)
        # optimal: K and Y are set, and _back_to_caller sets the scaling
        assert res.K is not None and res.Y is not None and res.state_scaling is not None
        T = res.state_scaling  # the coordinates of res.check
        checks, new = check_all(res.K * T, res.Y / T[:, None] / T[None, :], res.gamma, res.nu)
        if not new:
            if all(c.ok for c in checks):
                return replace(res, check=_merge_checks(checks))
            # an LMI of the subset fails in the total coordinates (rounding): no certificate
            return replace(res, status="unverified", K=None, gamma=None, nu=None, Y=None,
                           check=_merge_checks(checks))
        active, restore = active + new, []


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
        If the certificate fails :func:`verify`, solve once more in better-conditioned
        coordinates (as :func:`design`).

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
