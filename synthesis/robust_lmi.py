"""Robust multi-objective state feedback by LMIs over real parametric uncertainty (R-ROMULOC seed).

Plant (:class:`LFTPlant`), continuous time, in linear-fractional form::

    x' = A x + Bp p + Bu u + B1 w1 + B2 w2
    q  = Cq x + Dqp p + Dqu u + Dq1 w1
    z1 = C1 x + D1p p + D1u u + D11 w1          (H-infinity channel w1 -> z1)
    z2 = C2 x                                   (impulse-to-peak channel w2 -> z2)
    p  = Delta q,   Delta = blockdiag(delta_1 I_r1, ..., delta_N I_rN),  delta_k real in [-1, 1]

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
(:func:`_dual_lmi`). For the regions drop ``z, w`` and replace ``(A, Bu, Bp)`` by ``(A +
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

Analysis with a parameter-dependent Lyapunov function (:func:`pdlf_hinf`) on an
:class:`AffineDescriptor` (implicit system affine in ``delta``), exact values per sample
(:func:`hinf_norm`, Boyd-Balakrishnan-Bruinsma-Steinbuch; :func:`impulse_to_peak`) for
independent checks of every bound.

Every result returned as ``"optimal"`` has been re-verified without the solver (:func:`verify`,
:func:`verify_pdlf`): each LMI rebuilt in numpy from the returned matrices (with the returned
K), its extreme eigenvalue of the right sign with a margin; otherwise ``"unverified"``. An
optimal interior-point solution lies within the solver's accuracy (about 1e-8 of the largest
entry) of the boundary, too close for such a check, so every minimization is followed by a
back-off solve: the levels fixed at ``1 + b`` times the optimum and the smallest strictness
margin of all the LMIs maximized, for b in :data:`BACKOFFS` until one verifies. The certificate
returned is the back-off one.
"""
from __future__ import annotations

import itertools
import time
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import cvxpy as cp
import numpy as np
import scipy.linalg as sla

from synthesis import solve_policy

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
PDLF_MAX_ENTRIES = 10_000_000
"""Default largest :func:`pdlf_size` accepted by :func:`pdlf_hinf`. Measured on this machine
(Clarabel 0.11): DEMETER 1 axis, 2 appendages (8 vertices, LMIs of size 30) 6.9e6, seconds;
2 axes (32 vertices, size 48) 4.4e7, over 8 minutes and 13 GB without converging."""

EPS = 1e-7
"""Default strictness of the LMIs in the solver."""


class RobustLMIError(ValueError):
    """Base class of this module's input errors."""


class PlantDataError(RobustLMIError):
    """A plant, descriptor, gain or system has wrong shapes or non-finite entries."""


class DeltaError(RobustLMIError):
    """A parameter vector has the wrong length, is not finite, is outside [-1, 1], or the
    system is ill posed (singular) there."""


class TooManyVerticesError(RobustLMIError):
    """The box has more vertices than ``max_vertices``."""


class ProgramTooLargeError(RobustLMIError):
    """A program's estimated size exceeds its limit (checked before anything is built)."""


class NotHurwitzError(RobustLMIError):
    """The H-infinity norm was asked for an unstable system."""


class OptionError(RobustLMIError):
    """A design option (weights, region, eps, uncertainty kind) is invalid."""


def _matrix(name: str, value) -> np.ndarray:
    a = np.asarray(value, dtype=float)
    if a.ndim != 2:
        raise PlantDataError(f"{name} must be a 2-D array, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise PlantDataError(f"{name} has non-finite entries")
    return a


def _sym(a: np.ndarray) -> np.ndarray:
    return (a + a.T) / 2


def _check_delta(delta, n_params: int) -> np.ndarray:
    d = np.asarray(delta, dtype=float)
    if d.shape != (n_params,):
        raise DeltaError(f"delta must have shape ({n_params},), got {d.shape}")
    if not np.all(np.isfinite(d)):
        raise DeltaError("delta has non-finite entries")
    if np.any(np.abs(d) > 1):
        raise DeltaError(f"delta must lie in [-1, 1], got {d}")
    return d


def _check_gain(K, m: int, n: int) -> np.ndarray:
    K = _matrix("K", K)
    if K.shape != (m, n):
        raise PlantDataError(f"K must have shape ({m}, {n}), got {K.shape}")
    return K


def _check_vertices(n_params: int, max_vertices: int) -> None:
    if not (isinstance(max_vertices, (int, np.integer)) and max_vertices >= 1):
        raise OptionError(f"max_vertices must be an integer >= 1, got {max_vertices!r}")
    if 2**n_params > max_vertices:
        raise TooManyVerticesError(f"{n_params} uncertain parameters give 2^{n_params} = {2**n_params} "
                                   f"box vertices, more than max_vertices = {max_vertices}")


def _check_eps(eps: float) -> None:
    if not (np.isfinite(eps) and eps > 0):
        raise OptionError(f"eps must be finite and > 0, got {eps!r}")


def _block_starts(reps: np.ndarray) -> np.ndarray:
    """Offsets of the blocks in q (and p): ``[0, r_1, r_1 + r_2, ..., n_q]``."""
    return np.cumsum(np.concatenate([[0], reps])).astype(int)


def box_vertices(n_params: int) -> np.ndarray:
    """The ``2^N`` vertices of ``[-1, 1]^N``, shape (2^N, N) (one empty vertex when N = 0)."""
    return np.array(list(itertools.product((-1.0, 1.0), repeat=n_params))).reshape(2**n_params, n_params)


def _vertex_deltas(plant: LFTPlant) -> list[np.ndarray]:
    """``Delta`` at every vertex of the box, each (n_q, n_q)."""
    return [np.diag(np.repeat(v, plant.repetitions)) for v in box_vertices(plant.n_params)]


_LFT_FIELDS = ("A", "Bp", "Bu", "B1", "B2", "Cq", "Dqp", "Dqu", "Dq1", "C1", "D1p", "D1u", "D11", "C2")


@dataclass(frozen=True)
class LFTPlant:
    """Uncertain continuous-time plant in linear-fractional form (module docstring).

    Sizes: ``n`` states, ``m`` inputs u, ``n_q`` uncertainty channels (``sum r_k``), ``m1``,
    ``p1`` for w1, z1 and ``m2``, ``p2`` for w2, z2; every channel but q has at least one
    signal (pass a zero column for an unused one). Units are the caller's (time in s).

    Parameters
    ----------
    A : ndarray, shape (n, n)
    Bp, Bu, B1, B2 : ndarray, shapes (n, n_q), (n, m), (n, m1), (n, m2)
    Cq : ndarray, shape (n_q, n)
    Dqp, Dqu, Dq1 : ndarray, shapes (n_q, n_q), (n_q, m), (n_q, m1)
    C1 : ndarray, shape (p1, n)
    D1p, D1u, D11 : ndarray, shapes (p1, n_q), (p1, m), (p1, m1)
    C2 : ndarray, shape (p2, n)
    blocks : tuple of (str, int)
        ``(name, r_k)`` per uncertain parameter, in the order of ``q`` and ``p``; empty for a
        certain plant (then ``n_q = 0``: see :meth:`without_uncertainty`).
    """

    A: np.ndarray
    Bp: np.ndarray
    Bu: np.ndarray
    B1: np.ndarray
    B2: np.ndarray
    Cq: np.ndarray
    Dqp: np.ndarray
    Dqu: np.ndarray
    Dq1: np.ndarray
    C1: np.ndarray
    D1p: np.ndarray
    D1u: np.ndarray
    D11: np.ndarray
    C2: np.ndarray
    blocks: tuple[tuple[str, int], ...] = ()

    def __post_init__(self) -> None:
        for k in _LFT_FIELDS:
            object.__setattr__(self, k, _matrix(k, getattr(self, k)))
        n, nq = self.A.shape[0], self.Cq.shape[0]
        m, m1, m2 = self.Bu.shape[1], self.B1.shape[1], self.B2.shape[1]
        p1, p2 = self.C1.shape[0], self.C2.shape[0]
        expected = {"A": (n, n), "Bp": (n, nq), "Bu": (n, m), "B1": (n, m1), "B2": (n, m2),
                    "Cq": (nq, n), "Dqp": (nq, nq), "Dqu": (nq, m), "Dq1": (nq, m1),
                    "C1": (p1, n), "D1p": (p1, nq), "D1u": (p1, m), "D11": (p1, m1), "C2": (p2, n)}
        for k, shape in expected.items():
            if getattr(self, k).shape != shape:
                raise PlantDataError(f"{k} must have shape {shape}, got {getattr(self, k).shape}")
        for name, size in (("x", n), ("u", m), ("w1", m1), ("z1", p1), ("w2", m2), ("z2", p2)):
            if size < 1:
                raise PlantDataError(f"the plant needs at least one {name} signal")
        try:
            blocks = tuple((str(name), int(r)) for name, r in self.blocks)
        except (TypeError, ValueError) as exc:
            raise PlantDataError(f"blocks must be (name, repetition) pairs, got {self.blocks!r}") from exc
        if any(r < 1 or r != rr for (_, r), (_, rr) in zip(blocks, self.blocks)):
            raise PlantDataError(f"block repetitions must be integers >= 1, got {self.blocks!r}")
        if len({b[0] for b in blocks}) != len(blocks):
            raise PlantDataError(f"block names must be unique, got {[b[0] for b in blocks]}")
        if sum(r for _, r in blocks) != nq:
            raise PlantDataError(f"block repetitions sum to {sum(r for _, r in blocks)}, Cq has {nq} rows")
        object.__setattr__(self, "blocks", blocks)

    @classmethod
    def without_uncertainty(cls, A, Bu, B1, B2, C1, D1u, D11, C2) -> LFTPlant:
        """A certain plant (no blocks, ``n_q = 0``)."""
        A, Bu, B1, C1 = (np.asarray(a, float) for a in (A, Bu, B1, C1))
        n, m, m1, p1 = A.shape[0], Bu.shape[1], B1.shape[1], C1.shape[0]
        z = np.zeros
        return cls(A, z((n, 0)), Bu, B1, B2, z((0, n)), z((0, 0)), z((0, m)), z((0, m1)),
                   C1, z((p1, 0)), D1u, D11, C2, ())

    @property
    def n_params(self) -> int:
        """Number N of uncertain parameters (blocks)."""
        return len(self.blocks)

    @property
    def repetitions(self) -> np.ndarray:
        """``r_k`` per block, shape (N,)."""
        return np.array([r for _, r in self.blocks], dtype=int)

    def delta_matrix(self, delta) -> np.ndarray:
        """``Delta = blockdiag(delta_k I_rk)``, shape (n_q, n_q); delta in [-1, 1]^N."""
        return np.diag(np.repeat(_check_delta(delta, self.n_params), self.repetitions))

    def evaluate(self, delta) -> tuple[np.ndarray, ...]:
        """The plant at ``delta`` (upper star product): ``(A, Bu, B1, C1, D1u, D11)``.

        ``X = Delta (I - Dqp Delta)^-1``; ``A + Bp X Cq``, ``Bu + Bp X Dqu``, ``B1 + Bp X Dq1``,
        ``C1 + D1p X Cq``, ``D1u + D1p X Dqu``, ``D11 + D1p X Dq1``.

        Raises
        ------
        DeltaError
            If delta is not in the box, or ``I - Dqp Delta`` is singular (ill-posed loop).
        """
        D = self.delta_matrix(delta)
        M = np.eye(len(D)) - self.Dqp @ D
        if len(D) and np.linalg.cond(M) > 1e12:
            raise DeltaError(f"I - Dqp Delta is singular at delta = {np.asarray(delta)}: the LFT is ill posed")
        X = D @ np.linalg.solve(M, np.hstack([self.Cq, self.Dqu, self.Dq1]))
        n, m = self.A.shape[0], self.Bu.shape[1]
        top = np.hstack([self.A, self.Bu, self.B1]) + self.Bp @ X
        bottom = np.hstack([self.C1, self.D1u, self.D11]) + self.D1p @ X
        return top[:, :n], top[:, n:n + m], top[:, n + m:], bottom[:, :n], bottom[:, n:n + m], bottom[:, n + m:]

    def nominal(self) -> tuple[np.ndarray, ...]:
        """:meth:`evaluate` at ``delta = 0``."""
        return self.evaluate(np.zeros(self.n_params))

    def closed_loop(self, K, delta) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(A + Bu K, B1, C1 + D1u K, D11)`` at ``delta`` for ``u = K x`` (K shape (m, n))."""
        A, Bu, B1, C1, D1u, D11 = self.evaluate(delta)
        K = _check_gain(K, Bu.shape[1], A.shape[0])
        return A + Bu @ K, B1, C1 + D1u @ K, D11

    def at(self, delta) -> LFTPlant:
        """The certain plant at ``delta`` (no blocks; w2, z2 unchanged)."""
        A, Bu, B1, C1, D1u, D11 = self.evaluate(delta)
        return LFTPlant.without_uncertainty(A, Bu, B1, self.B2, C1, D1u, D11, self.C2)

    def scale_states(self, T) -> LFTPlant:
        """The same plant in the coordinates ``x_s`` of ``x = diag(T) x_s`` (T > 0, shape (n,)).

        A gain ``K`` of this plant becomes ``K_s = K diag(T)``; a dual Lyapunov matrix ``Y``
        becomes ``Y_s = diag(T)^-1 Y diag(T)^-1``; bounds, multipliers and poles are unchanged.
        """
        T = np.asarray(T, dtype=float)
        if T.shape != (self.A.shape[0],) or not np.all(np.isfinite(T) & (T > 0)):
            raise PlantDataError(f"T must be {self.A.shape[0]} positive scales, got {T}")
        out = {k: getattr(self, k) for k in _LFT_FIELDS}
        out["A"] = self.A * T[None, :] / T[:, None]
        for k in ("Bp", "Bu", "B1", "B2"):
            out[k] = out[k] / T[:, None]
        for k in ("Cq", "C1", "C2"):
            out[k] = out[k] * T[None, :]
        return LFTPlant(**out, blocks=self.blocks)

    def balance_channels(self) -> LFTPlant:
        """The same plant with each uncertainty channel i scaled, ``p_i / c_i = delta (q_i / c_i)``,
        ``c_i = sqrt(|Cq_i| / |Bp_i|)``: its input and output columns get the same size (exact: a
        common factor on ``p_i`` and ``q_i`` keeps ``p = Delta q``)."""
        bp, cq = np.linalg.norm(self.Bp, axis=0), np.linalg.norm(self.Cq, axis=1)
        c = np.sqrt(np.where((bp > 0) & (cq > 0), cq / np.where(bp > 0, bp, 1.0), 1.0))
        out = {k: getattr(self, k) for k in _LFT_FIELDS}
        out["Bp"], out["D1p"] = self.Bp * c, self.D1p * c
        out["Dqp"] = self.Dqp * c[None, :] / c[:, None]
        for k in ("Cq", "Dqu", "Dq1"):
            out[k] = out[k] / c[:, None]
        return LFTPlant(**out, blocks=self.blocks)


@dataclass(frozen=True)
class AffineDescriptor:
    """Implicit plant affine in the parameters: ``N(delta) [x'; x; v; u; w1] = 0``.

    ``N(delta) = N0 + sum_k delta_k Nk[k]`` with ``n + n_v`` rows and ``2 n + n_v + m_u + m_w``
    columns in the order ``(x', x, v, u, w1)``; ``z1 = C1 x + D1u u + D11 w1``. For every
    delta in ``[-1, 1]^N`` the columns of ``x'`` and ``v`` must form a nonsingular matrix.

    Parameters
    ----------
    N0 : ndarray, shape (n + n_v, 2 n + n_v + m_u + m_w)
    Nk : ndarray, shape (N, n + n_v, 2 n + n_v + m_u + m_w)
    n, n_v, m_u, m_w : int
        Sizes of x (>= 1), v (>= 0), u (>= 1), w1 (>= 1).
    C1, D1u, D11 : ndarray, shapes (p, n), (p, m_u), (p, m_w)
    names : tuple of str
        The N parameter names.
    """

    N0: np.ndarray
    Nk: np.ndarray
    n: int
    n_v: int
    m_u: int
    m_w: int
    C1: np.ndarray
    D1u: np.ndarray
    D11: np.ndarray
    names: tuple[str, ...]

    def __post_init__(self) -> None:
        for k, low in (("n", 1), ("n_v", 0), ("m_u", 1), ("m_w", 1)):
            v = getattr(self, k)
            if not (isinstance(v, (int, np.integer)) and v >= low):
                raise PlantDataError(f"{k} must be an integer >= {low}, got {v!r}")
            object.__setattr__(self, k, int(v))
        rows, cols = self.n + self.n_v, 2 * self.n + self.n_v + self.m_u + self.m_w
        N0 = _matrix("N0", self.N0)
        Nk = np.asarray(self.Nk, dtype=float)
        if N0.shape != (rows, cols):
            raise PlantDataError(f"N0 must have shape ({rows}, {cols}), got {N0.shape}")
        if Nk.ndim != 3 or Nk.shape[1:] != (rows, cols):
            raise PlantDataError(f"Nk must have shape (N, {rows}, {cols}), got {Nk.shape}")
        if not np.all(np.isfinite(Nk)):
            raise PlantDataError("Nk has non-finite entries")
        names = tuple(self.names)
        if len(names) != Nk.shape[0] or len(set(names)) != len(names) or \
                not all(isinstance(name, str) for name in names):
            raise PlantDataError(f"names must be {Nk.shape[0]} distinct strings, got {self.names!r}")
        C1, D1u, D11 = (_matrix(k, getattr(self, k)) for k in ("C1", "D1u", "D11"))
        p = C1.shape[0]
        for k, a, shape in (("C1", C1, (p, self.n)), ("D1u", D1u, (p, self.m_u)), ("D11", D11, (p, self.m_w))):
            if a.shape != shape or p < 1:
                raise PlantDataError(f"{k} must have shape {shape} with p >= 1, got {a.shape}")
        for k, v in (("N0", N0), ("Nk", Nk), ("C1", C1), ("D1u", D1u), ("D11", D11), ("names", names)):
            object.__setattr__(self, k, v)

    @classmethod
    def from_lft(cls, plant: LFTPlant) -> AffineDescriptor:
        """The LFT as a descriptor with ``v = p``: ``x' = A x + Bp p + Bu u + B1 w1`` and
        ``p - Delta (Cq x + Dqp p + Dqu u + Dq1 w1) = 0`` (affine in delta); w2, z2 dropped.

        Raises
        ------
        PlantDataError
            If ``D1p != 0`` (the descriptor's z1 cannot depend on v).
        """
        if np.any(plant.D1p != 0):
            raise PlantDataError("from_lft needs D1p = 0: the descriptor's z1 does not depend on v")
        n, nq, m, m1 = plant.A.shape[0], plant.Cq.shape[0], plant.Bu.shape[1], plant.B1.shape[1]
        N0 = np.block([[np.eye(n), -plant.A, -plant.Bp, -plant.Bu, -plant.B1],
                       [np.zeros((nq, n)), np.zeros((nq, n)), np.eye(nq), np.zeros((nq, m)), np.zeros((nq, m1))]])
        Nk = np.zeros((plant.n_params,) + N0.shape)
        start = _block_starts(plant.repetitions)
        for k in range(plant.n_params):
            Xi = np.zeros((nq, nq))
            Xi[start[k]:start[k + 1], start[k]:start[k + 1]] = np.eye(plant.repetitions[k])
            Nk[k, n:] = -Xi @ np.hstack([np.zeros((nq, n)), plant.Cq, plant.Dqp, plant.Dqu, plant.Dq1])
        return cls(N0, Nk, n, nq, m, m1, plant.C1, plant.D1u, plant.D11, tuple(b[0] for b in plant.blocks))

    @property
    def n_params(self) -> int:
        return len(self.names)

    def _slices(self) -> tuple[slice, slice, slice, slice, slice]:
        n, nv, mu = self.n, self.n_v, self.m_u
        return (slice(0, n), slice(n, 2 * n), slice(2 * n, 2 * n + nv),
                slice(2 * n + nv, 2 * n + nv + mu), slice(2 * n + nv + mu, None))

    def matrix(self, delta) -> np.ndarray:
        """``N(delta)``, shape (n + n_v, 2 n + n_v + m_u + m_w)."""
        d = _check_delta(delta, self.n_params)
        return self.N0 + np.tensordot(d, self.Nk, axes=1)

    def state_space(self, delta) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(A, Bu, B1)`` of ``x' = A x + Bu u + B1 w1`` at delta, solving N for ``(x', v)``.

        Raises
        ------
        DeltaError
            If the ``(x', v)`` columns of N(delta) are singular.
        """
        Nd = self.matrix(delta)
        sd, sx, sv, su, sw = self._slices()
        E = np.hstack([Nd[:, sd], Nd[:, sv]])
        if np.linalg.cond(E) > 1e12:
            raise DeltaError(f"the (x', v) columns of N are singular at delta = {np.asarray(delta)}")
        S = -np.linalg.solve(E, np.hstack([Nd[:, sx], Nd[:, su], Nd[:, sw]]))[:self.n]
        return S[:, :self.n], S[:, self.n:self.n + self.m_u], S[:, self.n + self.m_u:]

    def loop_constraint(self, K, delta) -> np.ndarray:
        """``M(delta)`` with ``M [x'; x; v; w1] = 0`` the loop ``u = K x``: ``[N_x', N_x + N_u K, N_v, N_w]``."""
        K = _check_gain(K, self.m_u, self.n)
        Nd = self.matrix(delta)
        sd, sx, sv, su, sw = self._slices()
        return np.hstack([Nd[:, sd], Nd[:, sx] + Nd[:, su] @ K, Nd[:, sv], Nd[:, sw]])


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


def _finish_check(neg: dict[str, list[np.ndarray]], pos: dict[str, list[np.ndarray]],
                  structure_error: float = 0.0) -> RobustCheck:
    scale = max(float(np.max(np.abs(m))) for mats in (*neg.values(), *pos.values()) for m in mats if m.size)
    max_eig = {k: np.array([np.linalg.eigvalsh(m)[-1] for m in v]) for k, v in neg.items()}
    min_eig = {k: np.array([np.linalg.eigvalsh(m)[0] for m in v]) for k, v in pos.items()}
    allowance = max(ABS_MARGIN, 1e3 * np.finfo(float).eps * scale)
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


def _dual_lmi(s: _Spec, Y, W, mult, gamma, stack, bmat):
    """The dual robust LMI of spec ``s`` (must be < 0), rows ``(x', q, z, w)``, built with the
    array functions given: numpy's (``np.vstack, np.block``) for a check, cvxpy's for the program.

    ``mult = (Qt, St, Rt)`` (ignored when ``n_q = 0``); ``gamma`` is unused without w, z.
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
        L = L - gamma * (Ez @ Ez.T)
    if nw:
        Gw = np.vstack(gw)
        L = bmat([[L, Gw], [Gw.T, -gamma * np.eye(nw)]])
    return (L + L.T) / 2


def _i2p_blocks(plant: LFTPlant, Y, nu, bmat) -> tuple:
    """``[[Y, B2], [B2^T, nu I]]`` (must be > 0) and ``C2 Y C2^T - nu I`` (must be < 0)."""
    m2, p2 = plant.B2.shape[1], plant.C2.shape[0]
    upper = bmat([[Y, plant.B2], [plant.B2.T, nu * np.eye(m2)]])
    lower = plant.C2 @ Y @ plant.C2.T - nu * np.eye(p2)
    return (upper + upper.T) / 2, (lower + lower.T) / 2


def _vertex_condition(Qt, St, Rt, D: np.ndarray):
    """``Delta Qt Delta - Delta St - St^T Delta + Rt`` (the dual multiplier inequality, <= 0)."""
    V = D @ Qt @ D - D @ St - St.T @ D + Rt
    return (V + V.T) / 2


def _blockdiag(mats: list, sizes: list[int]):
    return cp.bmat([[mats[i] if i == j else np.zeros((sizes[i], sizes[j])) for j in range(len(sizes))]
                    for i in range(len(sizes))])


def _multiplier_program(plant: LFTPlant, uncertainty: str, deltas: list[np.ndarray], margin):
    """Constraints (strict by ``margin``) and ``(Qt, St, Rt)`` expressions of one multiplier, plus
    a function returning the numeric :class:`Multiplier` after the solve."""
    reps = [int(r) for r in plant.repetitions]
    nq = sum(reps)
    if uncertainty == "norm":
        S = [cp.Variable((r, r), symmetric=True) for r in reps]
        U = [cp.Variable((r, r)) if r > 1 else None for r in reps]
        H = [u - u.T if u is not None else np.zeros((1, 1)) for u in U]
        cons = [s >> margin * np.eye(r) for s, r in zip(S, reps)]
        Qt, St = _blockdiag(S, reps), _blockdiag(H, reps)

        def value() -> Multiplier:
            Q = sla.block_diag(*[_sym(s.value) for s in S])
            Hs = sla.block_diag(*[u.value - u.value.T if u is not None else np.zeros((1, 1)) for u in U])
            return Multiplier("norm", Q, Hs, -Q)

        return cons, (Qt, St, -Qt), value
    Qt = cp.Variable((nq, nq), symmetric=True)
    St = cp.Variable((nq, nq))
    Rt = cp.Variable((nq, nq), symmetric=True)
    cons = [Qt >> margin * np.eye(nq)]
    cons += [_vertex_condition(Qt, St, Rt, D) << -margin * np.eye(nq) for D in deltas]

    def value() -> Multiplier:
        return Multiplier("vertex", _sym(Qt.value), np.asarray(St.value), _sym(Rt.value))

    return cons, (Qt, St, Rt), value


def _dg_structure_error(mult: Multiplier, reps: np.ndarray) -> float:
    """Largest deviation of a D-G multiplier from its structure (0 when exact)."""
    mask = sla.block_diag(*[np.ones((r, r)) for r in reps]) == 0
    return float(max(np.max(np.abs(mult.R + mult.Q)), np.max(np.abs(mult.S + mult.S.T)),
                     np.max(np.abs(mult.Q[mask]), initial=0.0), np.max(np.abs(mult.S[mask]), initial=0.0)))


def verify(plant: LFTPlant, K, Y, gamma: float | None, nu: float, multipliers: dict[str, Multiplier], *,
           alpha: float, beta: float | None, sector: float | None = None) -> RobustCheck:
    """Check the dual robust LMIs of :func:`design` / :func:`i2p_bound` with numpy only.

    Rebuilds, from the returned ``K, Y`` (``W = K Y``), ``gamma``, ``nu`` and multipliers: every
    robust LMI (``"hinf"`` if gamma is given, ``"alpha"``, ``"beta"`` if beta is given), the
    multiplier conditions (D-G: structure exact, ``S_k > 0``; full block: ``Qt > 0`` and the
    vertex inequality at every vertex), ``Y > 0`` and the i2p blocks.

    Parameters
    ----------
    plant : LFTPlant
    K : ndarray, shape (m, n)
    Y : ndarray, shape (n, n)
    gamma : float or None
        H-infinity level (None: no H-infinity LMI, as in :func:`i2p_bound`).
    nu : float
        Impulse-to-peak level.
    multipliers : dict
        :class:`Multiplier` per robust LMI name (empty when the plant has no blocks).
    alpha, beta : float
        The pole region (beta None: no ``Re s > -beta`` LMI).
    sector : float, optional
        Half-angle (rad) of the sector ``|Im s| < tan(sector) (-Re s)`` (None: no sector LMI).
    """
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
        neg[s.name] = [_dual_lmi(s, Y, W, triple, gamma, np.vstack, np.block)]
    upper, lower = _i2p_blocks(plant, Y, nu, np.block)
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
    impulse of w2) are the solver's optimal values times ``1 + backoff`` (the first of
    :data:`BACKOFFS` that verifies), the levels at which the returned certificate (from the
    back-off solve) is verified;
    ``solver_objective`` is the minimized ``w_hinf gamma + w_i2p nu`` itself (not certified).
    ``n_vertices``: box
    vertices enumerated (0 with D-G scalings); ``n_multipliers``: scaling pairs (D-G: one per
    block and robust LMI) or full-block multipliers (one per robust LMI). Times in seconds:
    ``build_seconds`` to build the cvxpy problem, ``solve_seconds`` the wall time of
    ``Problem.solve`` (canonicalization and Clarabel), both summed over all the solves.
    ``backoff``: the back-off that verified; ``state_scaling``: None, or T when the certificate
    was found (and ``check`` computed) in the coordinates ``x = diag(T) x_s``: K and Y are given
    in the plant's own coordinates (``Y = diag(T) Y_s diag(T)``).
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
    """Plants in the last program of the constraint generation over many plants (None: all)."""


def _solve(prob: cp.Problem) -> solve_policy.SolveOutcome:
    """:func:`synthesis.solve_policy.solve_cvxpy`: the synthesis layer's one solve policy."""
    return solve_policy.solve_cvxpy(prob)


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


def _distinct_i2p(plants: tuple[LFTPlant, ...]) -> list[LFTPlant]:
    """One plant per distinct ``(B2, C2)``: the i2p blocks of the others are the same LMIs."""
    out: list[LFTPlant] = []
    for p in plants:
        if not any(np.array_equal(p.B2, q.B2) and np.array_equal(p.C2, q.C2) for q in out):
            out.append(p)
    return out


def _robust_constraints(plants: tuple[LFTPlant, ...], K: np.ndarray | None, specs: list[list[_Spec]],
                        uncertainty: str, margin, gamma, nu) -> tuple[cp.Variable, object, dict, list]:
    """``(Y, W, multiplier values, constraints)`` of the common-Lyapunov program over every plant
    (``specs[i]`` of plant i), every LMI strict by ``margin`` (eps, or the variable the back-off
    maximizes); gamma, nu variables or constants (nu None: no impulse-to-peak LMIs)."""
    n, m = plants[0].A.shape[0], plants[0].Bu.shape[1]
    Y = cp.Variable((n, n), symmetric=True)
    W = cp.Variable((m, n)) if K is None else K @ Y
    cons = [Y >> margin * np.eye(n)]
    values = {}
    for i, (plant, plant_specs) in enumerate(zip(plants, specs)):
        for s in plant_specs:
            triple = None
            if plant.n_params:
                deltas = _vertex_deltas(s.plant) if uncertainty == "vertex" else []
                mcons, triple, values[_key(i, s.name, len(plants))] = _multiplier_program(
                    s.plant, uncertainty, deltas, margin)
                cons += mcons
            L = _dual_lmi(s, Y, W, triple, gamma, cp.vstack, cp.bmat)
            cons.append(L << -margin * np.eye(L.shape[0]))
    for plant in _distinct_i2p(plants) if nu is not None else ():
        upper, lower = _i2p_blocks(plant, Y, nu, cp.bmat)
        cons += [upper >> margin * np.eye(upper.shape[0]), lower << -margin * np.eye(lower.shape[0])]
    return Y, W, values, cons


def _verify_plants(plants: tuple[LFTPlant, ...], K, Y, gamma, nu, multipliers: dict[str, Multiplier], *,
                   alpha: float, beta: float | None, sector: float | None) -> RobustCheck:
    """:func:`verify` at every plant, merged: the smallest margin, names prefixed as :func:`_key`."""
    if len(plants) == 1:
        return verify(plants[0], K, Y, gamma, nu, multipliers, alpha=alpha, beta=beta, sector=sector)
    checks = []
    for i, plant in enumerate(plants):
        own = {k.split("/", 1)[1]: v for k, v in multipliers.items() if k.startswith(f"{i}/")}
        checks.append(verify(plant, K, Y, gamma, nu, own, alpha=alpha, beta=beta, sector=sector))
    return _merge_checks(checks)


def _merge_checks(checks: list[RobustCheck]) -> RobustCheck:
    """One check of several plants' (names prefixed by the plant's index)."""
    worst = min(range(len(checks)), key=lambda i: checks[i].margin)
    return RobustCheck({f"{i}/{k}": v for i, c in enumerate(checks) for k, v in c.max_eig.items()},
                       {f"{i}/{k}": v for i, c in enumerate(checks) for k, v in c.min_eig.items()},
                       checks[worst].margin, max(c.scale for c in checks),
                       max(c.structure_error for c in checks), [f"plant {worst}: {d}" for d in checks[worst].details])


RESCALE_DEPTH = 2
"""Rescalings :func:`_rescaled_program` may chain (each from the last solve's Lyapunov matrix)."""


def _rescaled_program(plants: tuple[LFTPlant, ...], K: np.ndarray | None, rescale: bool, depth: int = RESCALE_DEPTH,
                      **options) -> RobustDesign:
    """:func:`_robust_program` at the first back-off; if its certificate fails :func:`verify`,
    the same again (up to ``depth`` times) in the coordinates where that solve's Y has a unit
    diagonal (``x = diag(sqrt(Y_ii)) x_s``); failing that, the caller's coordinates with the
    larger back-offs.

    A Lyapunov matrix with eigenvalues 10^7 apart (slow modes next to stiff ones) leaves the
    solver's answer just outside the feasible set whatever the back-off; the diagonal scaling
    from its own first answer brings Y's condition number to about 10 (DEMETER row 1: 10^7 to
    13). When a solve gives no answer at all, the scaling comes from :func:`_phase_one`
    (DEMETER, one axis, four identical appendages: phase one, then one more rescaling). The
    returned K, Y are in the caller's coordinates; ``state_scaling`` holds the total scale,
    ``check`` and the multipliers in the last coordinates (:meth:`LFTPlant.scale_states`, then
    :meth:`LFTPlant.balance_channels`).
    """
    out, Y1 = _robust_program(plants, K, backoffs=BACKOFFS[:1], **options)
    if out.status != "unverified":
        return out
    if Y1 is None and rescale:  # no answer at all: coordinates from a bounded region-only problem
        Y1 = _phase_one(plants, K, **options)
    scaled = None
    if rescale and depth > 0 and Y1 is not None and np.all(np.diag(Y1) > 0):
        T = np.sqrt(np.diag(Y1))
        scaled = _rescaled_program(tuple(p.scale_states(T).balance_channels() for p in plants),
                                   None if K is None else K * T, rescale, depth - 1, **options)
    if scaled is None or scaled.status != "optimal":
        return _robust_program(plants, K, backoffs=BACKOFFS[1:], **options)[0]
    inner = np.ones_like(T) if scaled.state_scaling is None else scaled.state_scaling
    return replace(scaled, K=scaled.K / T, Y=T[:, None] * scaled.Y * T[None, :], state_scaling=T * inner,
                   solve_seconds=scaled.solve_seconds + out.solve_seconds,
                   build_seconds=scaled.build_seconds + out.build_seconds,
                   solver_status=f"{out.solver_status}; rescaled: {scaled.solver_status}")


def _phase_one(plants: tuple[LFTPlant, ...], K: np.ndarray | None, *, alpha: float, beta: float | None,
               uncertainty: str, sector: float | None = None, **_) -> np.ndarray | None:
    """Y of the region LMIs alone (no H-infinity, no i2p), normalized ``t I <= Y <= I`` with the
    common margin t maximized (at most 1): a bounded problem that the solver answers where the
    full minimization fails; its Y's diagonal gives the coordinates of the retry."""
    t = cp.Variable()
    specs = [_specs(p, alpha, beta, False, sector) for p in plants]
    Y, _, _, cons = _robust_constraints(plants, K, specs, uncertainty, t, None, None)
    cons[1:1] = [Y << np.eye(Y.shape[0]), t <= 1]  # next to t I <= Y (the solver's path depends on the order)
    prob = cp.Problem(cp.Maximize(t), cons)
    if not _solve(prob).solved or Y.value is None:
        return None
    return _sym(Y.value)


def _robust_program(plants: tuple[LFTPlant, ...], K: np.ndarray | None, *, hinf: bool, w_hinf: float,
                    w_i2p: float,
                    alpha: float, beta: float | None, uncertainty: str, eps: float,
                    backoffs: tuple[float, ...] = BACKOFFS, sector: float | None = None
                    ) -> tuple[RobustDesign, np.ndarray | None]:
    """Solve (minimize the objective), back off (levels x (1 + b), b in BACKOFFS, largest common margin)
    and verify the common-Lyapunov program (options already checked); also the first solve's Y."""
    t0 = time.perf_counter()
    specs = [_specs(p, alpha, beta, hinf, sector) for p in plants]
    gamma = cp.Variable() if hinf else None
    nu = cp.Variable()
    Y, W, _, cons = _robust_constraints(plants, K, specs, uncertainty, eps, gamma, nu)
    prob = cp.Problem(cp.Minimize(w_i2p * nu + (w_hinf * gamma if hinf else 0)), cons)
    build = time.perf_counter() - t0
    out = _solve(prob)
    n_mult = sum(len(s) * (p.n_params if uncertainty == "norm" else min(p.n_params, 1))
                 for p, s in zip(plants, specs))
    info = {"uncertainty": uncertainty,
            "n_vertices": sum(2**p.n_params for p in plants) if uncertainty == "vertex" else 0,
            "n_multipliers": n_mult, "fixed_gain": K is not None}
    if not out.solved or Y.value is None:
        return RobustDesign(_failed(out), None, None, None, None, {}, None, None, **info,
                            solver_status=out.solver_status, solve_seconds=out.seconds, build_seconds=build), None
    optimum, Y1 = float(prob.value), _sym(Y.value)
    times = {"solver_status": out.solver_status, "solve_seconds": out.seconds, "build_seconds": build}
    mults, check = {}, None
    for b in backoffs:
        t0 = time.perf_counter()
        g = float(gamma.value) * (1 + b) if hinf else None
        nv = float(nu.value) * (1 + b)
        t = cp.Variable()
        Yb, Wb, values, cons = _robust_constraints(plants, K, specs, uncertainty, t, g, nv)
        prob = cp.Problem(cp.Maximize(t), cons)
        times["build_seconds"] += time.perf_counter() - t0
        out2 = _solve(prob)
        times["solver_status"] += f"; back-off {b:g}: {out2.solver_status}"
        times["solve_seconds"] += out2.seconds
        if not out2.solved or Yb.value is None:
            continue
        Yv = _sym(Yb.value)
        Kv = np.linalg.solve(Yv, np.asarray(Wb.value).T).T if K is None else K
        mults = {k: f() for k, f in values.items()}
        check = _verify_plants(plants, Kv, Yv, g, nv, mults, alpha=alpha, beta=beta, sector=sector)
        if check.ok:
            return RobustDesign("optimal", Kv, g, nv, Yv, mults, check, optimum, **info, **times, backoff=b), Y1
    return RobustDesign("unverified", None, None, None, None, mults, check, optimum, **info, **times), Y1


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
           max_vertices: int = MAX_VERTICES, eps: float = EPS, rescale: bool = True) -> RobustDesign:
    """Robust multi-objective state feedback ``u = K x`` with one Lyapunov matrix (module docstring).

    Minimizes ``w_hinf gamma + w_i2p nu`` (the seed's "+1*hinfty +100*i2p") subject to, for
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
        first solve's Y has a unit diagonal (see ``state_scaling`` of the result).

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
    if sector is not None and not (np.isfinite(sector) and 0 < sector < np.pi / 2):
        raise OptionError(f"sector must be a half-angle in (0, pi/2) rad, got {sector!r}")
    plants = _plant_list(plant, uncertainty, max_vertices)
    if K is not None:
        K = _check_gain(K, plants[0].Bu.shape[1], plants[0].A.shape[0])
    options = {"hinf": True, "w_hinf": w_hinf, "w_i2p": w_i2p, "alpha": alpha, "beta": beta,
               "uncertainty": uncertainty, "eps": eps, "sector": sector}
    if len(plants) > SCENARIO_BATCH and not any(p.n_params for p in plants):
        return _constraint_generation(plants, K, rescale, **options)
    return _rescaled_program(plants, K, rescale, **options)


SCENARIO_BATCH = 100
"""Plants in the first program of :func:`_constraint_generation`, and the most plants it adds
per round."""


def _constraint_generation(plants: tuple[LFTPlant, ...], K: np.ndarray | None, rescale: bool, **options
                           ) -> RobustDesign:
    """The program over many certain plants (scenarios), solved on a growing subset.

    Solve with the first :data:`SCENARIO_BATCH` plants; :func:`verify` every plant at the
    answer; add the most violated (at most SCENARIO_BATCH) and solve again, until the answer
    holds for every plant. The whole program has the same optimum up to the back-off: the last
    subset's optimum is a lower bound of the whole program's (fewer constraints), and the
    returned certificate, verified on every plant, is feasible for it, at the subset's optimum
    times ``1 + backoff``. An infeasible subset proves the whole program infeasible. A scenario
    program has at most as many support constraints as decision variables, so the last subset
    stays small (DEMETER one axis, 962 scenarios: see ``active_plants``), and the solver never
    sees the thousands of LMIs at once.
    """
    active = list(range(SCENARIO_BATCH))
    solve_seconds = build_seconds = 0.0
    while True:
        res = _rescaled_program(tuple(plants[i] for i in active), K, rescale, **options)
        solve_seconds, build_seconds = solve_seconds + res.solve_seconds, build_seconds + res.build_seconds
        res = replace(res, solve_seconds=solve_seconds, build_seconds=build_seconds, active_plants=len(active))
        if res.status != "optimal":
            return res
        T = np.ones(res.K.shape[1]) if res.state_scaling is None else res.state_scaling
        Ks, Ys = res.K * T, res.Y / T[:, None] / T[None, :]  # the coordinates of res.check
        checks = [verify(p.scale_states(T), Ks, Ys, res.gamma, res.nu, {}, alpha=options["alpha"],
                         beta=options["beta"], sector=options["sector"]) for p in plants]
        violated = sorted((c.margin, i) for i, c in enumerate(checks) if not c.ok)
        if not violated:
            return replace(res, check=_merge_checks(checks))
        new = [i for _, i in violated if i not in active][:SCENARIO_BATCH]
        if not new:  # an active plant fails in the total coordinates (rounding): no certificate
            return replace(res, status="unverified", K=None, gamma=None, nu=None, Y=None,
                           check=_merge_checks(checks))
        active += new


def i2p_bound(plant: LFTPlant | Sequence[LFTPlant], K, *, alpha: float = 0.0, uncertainty: str = "norm",
              max_vertices: int = MAX_VERTICES, eps: float = EPS, rescale: bool = True) -> RobustDesign:
    """Deterministic impulse-to-peak bound of the loop ``u = K x`` over the whole box.

    Smallest ``nu`` with ``[[Y, B2], [B2^T, nu I]] >= 0``, ``C2 Y C2^T <= nu I`` and the robust
    ``A_cl Y + Y A_cl^T + 2 alpha Y < 0`` (same multipliers as :func:`design`, fixed K, no
    H-infinity or beta LMI): then ``sup_t |z2(t)| <= nu`` for every delta (module docstring).
    Returns a :class:`RobustDesign` with ``gamma = None``.

    Raises
    ------
    OptionError, PlantDataError, TooManyVerticesError
        As :func:`design`.
    """
    _check_options(0.0, 1.0, alpha, None, uncertainty, eps)
    plants = _plant_list(plant, uncertainty, max_vertices)
    K = _check_gain(K, plants[0].Bu.shape[1], plants[0].A.shape[0])
    return _rescaled_program(plants, K, rescale, hinf=False, w_hinf=0.0, w_i2p=1.0, alpha=alpha, beta=None,
                             uncertainty=uncertainty, eps=eps)


@dataclass
class PDLFResult:
    """Result of :func:`pdlf_hinf`.

    ``gamma``: the certified bound of ``||w1 -> z1||_inf`` over the box (sqrt of the minimized
    ``g``, times ``1 + backoff``: :data:`BACKOFFS`; with ``method == "bisection"`` the smallest
    level verified by the bisection, within :data:`PDLF_BISECTION_TOL` of the smallest it could
    not verify); ``P0``, ``Pk`` (shape (N, n, n), zeros if ``common``) the Lyapunov matrix
    ``P(delta) = P0 + sum delta_k Pk[k]``; ``F`` the slack, shape (2 n + n_v + m_w, n + n_v).
    Status and times as :class:`RobustDesign`.
    """

    status: str
    gamma: float | None
    P0: np.ndarray | None
    Pk: np.ndarray | None
    F: np.ndarray | None
    check: RobustCheck | None
    common: bool
    n_vertices: int
    solver_status: str
    solve_seconds: float
    build_seconds: float
    backoff: float | None = None
    method: str = "minimize"


def _pdlf_lmi(desc: AffineDescriptor, K: np.ndarray, P, F, g, delta: np.ndarray, bmat):
    """``[[Phi(P, g) + He(F M(delta)), Z^T], [Z, -I]]`` (must be < 0), xi = (x', x, v, w1)."""
    n, nv, mw = desc.n, desc.n_v, desc.m_w
    E = np.eye(2 * n + nv + mw)
    Ed, Ex, Ew = E[:, :n], E[:, n:2 * n], E[:, 2 * n + nv:]
    p = desc.C1.shape[0]
    Z = np.hstack([np.zeros((p, n)), desc.C1 + desc.D1u @ K, np.zeros((p, nv)), desc.D11])
    T = Ed @ P @ Ex.T + F @ desc.loop_constraint(K, delta)
    L = bmat([[T + T.T - g * (Ew @ Ew.T), Z.T], [Z, -np.eye(p)]])
    return (L + L.T) / 2


def verify_pdlf(desc: AffineDescriptor, K, P0, Pk, F, gamma: float) -> RobustCheck:
    """Check :func:`pdlf_hinf`'s LMIs at every vertex with numpy: ``P(delta_v) > 0`` (``"P"``)
    and the dilated H-infinity LMI at ``g = gamma^2`` (``"hinf"``), one eigenvalue per vertex."""
    n, N = desc.n, desc.n_params
    K = _check_gain(K, desc.m_u, n)
    P0, F = _matrix("P0", P0), _matrix("F", F)
    Pk = np.asarray(Pk, dtype=float)
    for name, a, shape in (("P0", P0, (n, n)), ("Pk", Pk, (N, n, n)),
                           ("F", F, (2 * n + desc.n_v + desc.m_w, n + desc.n_v))):
        if a.shape != shape or not np.all(np.isfinite(a)):
            raise PlantDataError(f"{name} must be finite with shape {shape}, got {a.shape}")
    if not (np.isfinite(gamma) and gamma > 0):
        raise OptionError(f"gamma must be finite and > 0, got {gamma!r}")
    P0 = _sym(P0)
    neg, pos = {"hinf": []}, {"P": []}
    for v in box_vertices(desc.n_params):
        P = P0 + _sym(np.tensordot(v, Pk, axes=1)) if len(v) else P0
        pos["P"].append(P)
        neg["hinf"].append(_pdlf_lmi(desc, K, P, F, gamma**2, v, np.block))
    return _finish_check(neg, pos)


def pdlf_size(desc: AffineDescriptor) -> int:
    """Size of the :func:`pdlf_hinf` program of ``desc``: the sum over its LMIs of the squared
    number of their distinct entries, ``2^N ((s (s + 1) / 2)^2 + (n (n + 1) / 2)^2)``, ``s = 2 n +
    n_v + m_w + p``. Clarabel's KKT system holds a dense block of that many entries per PSD cone,
    and the slack F couples every cone, so this is the memory and time the solve needs."""
    n, s = desc.n, _pdlf_side(desc)
    return 2**desc.n_params * ((s * (s + 1) // 2) ** 2 + (n * (n + 1) // 2) ** 2)


def _pdlf_side(desc: AffineDescriptor) -> int:
    """Size of the dilated H-infinity LMI of :func:`pdlf_hinf`: ``(x', x, v, w1)`` and ``z1``."""
    return 2 * desc.n + desc.n_v + desc.m_w + desc.C1.shape[0]


def pdlf_hinf(desc: AffineDescriptor, K, *, common: bool = False, max_vertices: int = MAX_VERTICES,
              max_entries: int = PDLF_MAX_ENTRIES, eps: float = EPS) -> PDLFResult:
    """Upper bound of the closed-loop H-infinity norm w1 -> z1 over the box, ``u = K x``, with a
    parameter-dependent Lyapunov function ``V = x^T P(delta) x``, ``P = P0 + sum delta_k Pk``.

    With ``xi = (x', x, v, w1)`` and the loop ``M(delta) xi = 0``
    (:meth:`AffineDescriptor.loop_constraint`, affine in delta), ``Phi(P, g)`` the form
    ``xi^T Phi xi = 2 x^T P x' - g |w1|^2`` (= ``dV/dt - g |w1|^2`` for constant delta) and
    ``Z xi = z1``, require at every vertex ``delta_v`` of the box

        P(delta_v) > 0,   [[Phi(P(delta_v), g) + F M(delta_v) + M(delta_v)^T F^T, Z^T], [Z, -I]] < 0,

    with one parameter-independent slack F (Finsler / dilated LMIs: de Oliveira, Bernussou &
    Geromel, Syst. Control Lett. 37, 1999; Peaucelle, Arzelier, Bachelier & Bernussou, Syst.
    Control Lett. 40, 2000), minimizing ``g = gamma^2``.

    Why the vertices suffice: for fixed ``(P0, Pk, F, g)`` both matrices are affine in delta
    (P, M affine, F constant, Z independent of delta), and ``x^T L(delta) x`` is then affine in
    delta for every x, so its maximum on the box is at a vertex: an affine matrix function is
    negative (positive) definite on the box iff it is at the vertices. At any delta of the box
    the LMI, with the Schur complement, says ``xi^T (Phi + Z^T Z) xi < 0`` on ``ker M(delta)``
    (Finsler), i.e. ``dV/dt + |z1|^2 - g |w1|^2 < 0`` along the loop: stability and
    ``||w1 -> z1||_inf < sqrt(g)``. Restricted to ``x = 0, w1 = 0`` it also proves the descriptor
    well posed on the box. Valid for constant (time-invariant) parameters; ``common=True``
    (``Pk = 0``) is a special case, so the PDLF bound is never larger (up to solver accuracy),
    and the common bound also holds for arbitrarily fast time-varying parameters.

    Raises
    ------
    PlantDataError, OptionError, TooManyVerticesError
        Wrong gain shape, bad eps, or ``2^N > max_vertices`` (checked before building).
    ProgramTooLargeError
        ``pdlf_size(desc) > max_entries`` (checked before building).
    """
    _check_eps(eps)
    _check_vertices(desc.n_params, max_vertices)
    if pdlf_size(desc) > max_entries:
        raise ProgramTooLargeError(f"the PDLF program has {2**desc.n_params} vertex LMIs of size "
                                   f"{_pdlf_side(desc)}: size {pdlf_size(desc):.3g} > max_entries = "
                                   f"{max_entries:.3g} (pdlf_size)")
    K = _check_gain(K, desc.m_u, desc.n)
    t0 = time.perf_counter()
    g = cp.Variable()
    P0, Pk, F, cons = _pdlf_constraints(desc, K, common, eps, g)
    prob = cp.Problem(cp.Minimize(g), cons)
    info = {"common": common, "n_vertices": 2**desc.n_params, "solve_seconds": 0.0,
            "build_seconds": time.perf_counter() - t0}
    out = _timed_solve(prob, info)
    info["solver_status"] = out.solver_status
    if out.status == "infeasible":
        return PDLFResult("infeasible", None, None, None, None, None, **info)
    check = None
    if out.solved and g.value is not None:
        root = float(np.sqrt(max(float(g.value), 0.0)))
        for b in BACKOFFS:
            found, check = _pdlf_at(desc, K, common, root * (1 + b), info, f"back-off {b:g}")
            if found is not None:
                return replace(found, backoff=b)
    return _pdlf_bisection(desc, K, common, info, check)


PDLF_BISECTION_TOL = 5e-3
"""Relative width in gamma at which :func:`pdlf_hinf`'s bisection stops."""
PDLF_MAX_DOUBLINGS = 30
"""Doublings of the nominal norm tried before the bisection gives up finding a feasible level."""


def _timed_solve(prob: cp.Problem, info: dict) -> solve_policy.SolveOutcome:
    out = _solve(prob)
    info["solve_seconds"] += out.seconds
    return out


def _pdlf_at(desc: AffineDescriptor, K: np.ndarray, common: bool, gamma: float, info: dict, label: str
             ) -> tuple[PDLFResult | None, RobustCheck | None]:
    """The largest common margin of the PDLF LMIs at level ``gamma`` (bounded by 1), verified:
    ``(result, check)``; result None if the certificate fails :func:`verify_pdlf`."""
    t0 = time.perf_counter()
    t = cp.Variable()
    P0, Pk, F, cons = _pdlf_constraints(desc, K, common, t, gamma**2)
    prob = cp.Problem(cp.Maximize(t), cons + [t <= 1])
    info["build_seconds"] += time.perf_counter() - t0
    out = _timed_solve(prob, info)
    info["solver_status"] += f"; {label}: {out.solver_status}"
    if not out.solved or P0.value is None or t.value is None or t.value <= 0:
        return None, None
    n, N = desc.n, desc.n_params
    P0v = _sym(P0.value)
    Pkv = np.stack([_sym(p.value) for p in Pk]) if Pk else np.zeros((N, n, n))
    Fv = np.asarray(F.value)
    check = verify_pdlf(desc, K, P0v, Pkv, Fv, gamma)
    if not check.ok:
        return None, check
    return PDLFResult("optimal", gamma, P0v, Pkv, Fv, check, **info), check


def _pdlf_bisection(desc: AffineDescriptor, K: np.ndarray, common: bool, info: dict,
                    check: RobustCheck | None) -> PDLFResult:
    """Smallest verified PDLF level by bisection on gamma, each level a bounded-margin
    feasibility problem (:func:`_pdlf_at`): the fallback when the minimization of g fails (a
    slow closed-loop mode next to stiff ones leaves Clarabel without a usable optimum, while the
    feasibility problems stay well posed). Starts from the nominal closed loop's exact norm (a
    lower bound of any robust bound) and doubles it until a level verifies; stops when the
    bracket is narrower than :data:`PDLF_BISECTION_TOL`."""
    A, Bu, B1 = desc.state_space(np.zeros(desc.n_params))
    try:
        low = float(hinf_norm(A + Bu @ K, B1, desc.C1 + desc.D1u @ K, desc.D11))
    except NotHurwitzError:
        info["solver_status"] += "; bisection: the nominal loop is not stable"
        return PDLFResult("infeasible", None, None, None, None, None, **info)
    best = None
    high = low
    for _ in range(PDLF_MAX_DOUBLINGS):
        high *= 2.0
        best, check = _pdlf_at(desc, K, common, high, info, f"bisection {high:.6g}")
        if best is not None:
            break
        low = high
    if best is None:
        return PDLFResult("unverified", None, None, None, None, check, **info)
    while high > low * (1 + PDLF_BISECTION_TOL):
        mid = float(np.sqrt(low * high))
        found, _ = _pdlf_at(desc, K, common, mid, info, f"bisection {mid:.6g}")
        if found is None:
            low = mid
        else:
            best, high = found, mid
    return replace(best, **{k: info[k] for k in ("solver_status", "solve_seconds", "build_seconds")},
                   method="bisection")


def _pdlf_constraints(desc: AffineDescriptor, K: np.ndarray, common: bool, margin, g) -> tuple:
    """``(P0, Pk, F, constraints)`` of :func:`pdlf_hinf`, strict by ``margin``, at level ``g``."""
    n, N = desc.n, desc.n_params
    P0 = cp.Variable((n, n), symmetric=True)
    Pk = [] if common else [cp.Variable((n, n), symmetric=True) for _ in range(N)]
    F = cp.Variable((2 * n + desc.n_v + desc.m_w, n + desc.n_v))
    cons = []
    for v in box_vertices(N):
        P = P0 + sum(d * Pj for d, Pj in zip(v, Pk))
        L = _pdlf_lmi(desc, K, P, F, g, v, cp.bmat)
        cons += [P >> margin * np.eye(n), L << -margin * np.eye(L.shape[0])]
    return P0, Pk, F, cons


def _system_stack(A, B, C, D=None) -> tuple[np.ndarray, ...]:
    """Validate (n, n), (n, m), (p, n)[, (p, m)] arrays, or a stack of A (leading axis S) with
    B, C, D either stacked too or 2-D (then shared by every system)."""
    arrays = [np.asarray(a, dtype=float) for a in ((A, B, C) if D is None else (A, B, C, D))]
    if arrays[0].ndim not in (2, 3):
        raise PlantDataError(f"A must have shape (n, n) or (S, n, n), got {arrays[0].shape}")
    lead = arrays[0].shape[:-2]
    for k, (name, a) in enumerate(zip("ABCD", arrays)):
        if not np.all(np.isfinite(a)):
            raise PlantDataError(f"{name} has non-finite entries")
        if a.ndim == 2 and lead:
            arrays[k] = np.broadcast_to(a, lead + a.shape)
    A, B, C = arrays[:3]
    n, m, p = A.shape[-1], B.shape[-1], C.shape[-2]
    shapes = [(n, n), (n, m), (p, n)] + ([] if D is None else [(p, m)])
    for name, a, shape in zip("ABCD", arrays, shapes, strict=False):
        if a.shape != lead + shape:
            raise PlantDataError(f"{name} must have shape {lead + shape}, got {a.shape}")
    return tuple(arrays)


def _hamiltonian_crossings(A, B, C, D, g: float) -> np.ndarray:
    """Frequencies (rad/s, both signs, sorted) where ``g`` is a singular value of G(jw): the
    imaginary-axis eigenvalues of the Hamiltonian of the bounded-real lemma (R = g^2 I - D^T D)."""
    R = g**2 * np.eye(D.shape[1]) - D.T @ D
    Ri = np.linalg.inv(R)
    Ah = A + B @ Ri @ D.T @ C
    H = np.block([[Ah, B @ Ri @ B.T], [-C.T @ (np.eye(D.shape[0]) + D @ Ri @ D.T) @ C, -Ah.T]])
    lam = np.linalg.eigvals(H)
    scale = max(1.0, float(np.max(np.abs(H))))
    return np.sort(lam[np.abs(lam.real) <= 1e-7 * scale].imag)


def _sigma_max(A, B, C, D, w: float) -> float:
    G = C @ np.linalg.solve(1j * w * np.eye(A.shape[0]) - A, B) + D
    return float(np.linalg.svd(G, compute_uv=False)[0])


def _hinf_one(A, B, C, D, tol: float) -> float:
    lam = np.linalg.eigvals(A)
    if np.max(lam.real) >= 0:
        raise NotHurwitzError(f"A is not Hurwitz (max Re eig {np.max(lam.real):.3e}): "
                              "the H-infinity norm is infinite")
    low = max([float(np.linalg.norm(D, 2))] + [_sigma_max(A, B, C, D, w) for w in (0.0, *np.abs(lam))])
    if low == 0.0:
        return 0.0
    for _ in range(200):
        g = (1 + 2 * tol) * low
        w = _hamiltonian_crossings(A, B, C, D, g)
        if len(w) == 0:
            return g
        mids = np.unique(np.abs((w[:-1] + w[1:]) / 2)) if len(w) > 1 else np.abs(w)
        best = max(_sigma_max(A, B, C, D, m) for m in mids)
        if best <= g:  # the crossings found are numerical, not a band where sigma_max > g
            return g
        low = best
    raise RuntimeError("the H-infinity bisection did not converge in 200 iterations")


def hinf_norm(A, B, C, D, tol: float = 1e-9):
    """H-infinity norm of a stable continuous system ``(A, B, C, D)``, or of a stack of them.

    Boyd-Balakrishnan / Bruinsma-Steinbuch iteration (Boyd, Balakrishnan & Kabamba, MCSS 2,
    1989; Bruinsma & Steinbuch, Syst. Control Lett. 14, 1990): a lower bound ``low`` achieved
    at a frequency; ``g = (1 + 2 tol) low`` is tested by the imaginary-axis eigenvalues of the
    Hamiltonian; if there are any, ``low`` becomes the largest ``sigma_max(G(jw))`` at the
    midpoints of the crossing frequencies (quadratic convergence). The value returned is that
    final ``g``: an upper bound, within relative ``2 tol`` of the norm. Eigenvalues with
    ``|Re| <= 1e-7 max(1, max|H_ij|)`` count as imaginary; a spurious one is harmless: it only
    adds a midpoint, and if no midpoint exceeds ``g`` the crossings were numerical and ``g`` is
    returned (a genuine band where ``sigma_max > g`` always contains a midpoint).

    Parameters
    ----------
    A, B, C, D : ndarray
        Shapes (n, n), (n, m), (p, n), (p, m); or A with a leading sample axis S, and B, C, D
        with it or shared (2-D).
    tol : float
        Relative accuracy (> 0).

    Returns
    -------
    float or ndarray of shape (S,)

    Raises
    ------
    NotHurwitzError
        If (any) A has an eigenvalue with ``Re >= 0``.
    """
    A, B, C, D = _system_stack(A, B, C, D)
    if not (np.isfinite(tol) and tol > 0):
        raise OptionError(f"tol must be finite and > 0, got {tol!r}")
    if A.ndim == 3:
        return np.array([_hinf_one(a, b, c, d, tol) for a, b, c, d in zip(A, B, C, D)])
    return _hinf_one(A, B, C, D, tol)


PEAK_BLOCK = 64
"""Grid points per block in :func:`impulse_to_peak` (``C Phi^j`` kept for j < PEAK_BLOCK)."""


def impulse_to_peak(A, B, C, t_end: float, n_points: int = 2001):
    """``max_k sigma_max(C e^(A t_k) B)`` on the grid ``t_k = k t_end / (n_points - 1)``.

    The largest ``|z(t_k)|`` over unit-norm impulses ``w = w0 delta_Dirac`` (``x(0+) = B w0``).
    Exact propagation: ``Phi = expm(A dt)`` once, then repeated multiplication, in blocks:
    ``C Phi^j`` for ``j < PEAK_BLOCK`` and ``X_(i+1) = Phi^PEAK_BLOCK X_i`` from ``X_0 = B``.
    A lower estimate of the supremum over all t (the grid may miss the peak or end before it).

    Parameters
    ----------
    A, B, C : ndarray
        Shapes (n, n), (n, m), (p, n); or A with a leading sample axis S, and B, C with it or
        shared (2-D).
    t_end : float
        Horizon, s (> 0).
    n_points : int
        Grid points (>= 2), t = 0 included.

    Returns
    -------
    float or ndarray of shape (S,)
    """
    A, B, C = _system_stack(A, B, C)
    if not (np.isfinite(t_end) and t_end > 0):
        raise OptionError(f"t_end must be finite and > 0, got {t_end!r}")
    if not (isinstance(n_points, (int, np.integer)) and n_points >= 2):
        raise OptionError(f"n_points must be an integer >= 2, got {n_points!r}")
    Phi = sla.expm(A * (t_end / (n_points - 1)))
    CPhi = [C]  # C Phi^j, j < PEAK_BLOCK, by repeated multiplication
    for _ in range(min(PEAK_BLOCK, n_points) - 1):
        CPhi.append(CPhi[-1] @ Phi)
    CPhi = np.stack(CPhi, axis=-3)  # (..., b, p, n)
    b = CPhi.shape[-3]
    step = np.linalg.matrix_power(Phi, b)
    X = B.copy()
    peak = np.zeros(A.shape[:-2])
    for start in range(0, n_points, b):
        count = min(b, n_points - start)
        Z = CPhi[..., :count, :, :] @ X[..., None, :, :]  # C Phi^(start + j) B
        peak = np.maximum(peak, _sigma_max_stack(Z).max(axis=-1))
        X = step @ X
    return peak if A.ndim == 3 else float(peak)


def _sigma_max_stack(Z: np.ndarray) -> np.ndarray:
    """Largest singular value of every matrix of a stack (..., p, m)."""
    p, m = Z.shape[-2:]
    if min(p, m) == 1:  # a row or column: the Euclidean norm
        return np.sqrt(np.sum(Z * Z, axis=(-2, -1)))
    G = np.swapaxes(Z, -1, -2) @ Z if m <= p else Z @ np.swapaxes(Z, -1, -2)
    return np.sqrt(np.maximum(np.linalg.eigvalsh(G)[..., -1], 0.0))
