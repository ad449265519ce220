"""Periodic stochastic H-infinity state feedback by coupled LMIs (seed 003, Theorem 2).

Discrete-time N-periodic system with multiplicative white noises ``xi_l(k)`` (independent,
zero mean, unit variance, l = 1..r; ``xi_0 = 1``)::

    x(k+1) = sum_l xi_l (A_l(k) x + B1_l(k) w + B2_l(k) u),    z = C(k) x + D(k) u

Theorem 2: with ``Y(k) > 0``, ``Y(N) = Y(0)`` and, for k = 0..N-1,

    [ -Y(k)   0          M(k)        N(k) ]
    [  0     -gamma^2 I  Bcal(k)     0    ]  < 0,
    [  M^T    Bcal^T    -Ycal(k+1)   0    ]
    [  N^T    0          0          -I    ]

    M = [Y A_0^T + Z B2_0^T, ..., Y A_r^T + Z B2_r^T],  N = Y C^T + Z D^T,
    Bcal = [B1_0^T, ..., B1_r^T],  Ycal(k+1) = diag(Y(k+1), ..., Y(k+1)) (r+1 copies),

the gains ``F(k) = Z(k)^T Y(k)^-1`` make ``u = F(k) x`` exponentially stable in mean square
(ESMS) with the H-infinity level ``gamma`` from w to z.

- :func:`design`: the LMIs at a given gamma (cvxpy + Clarabel), re-verified without the
  solver (:func:`certify`: every block's largest eigenvalue, Y's smallest, with the gains
  actually returned) before anything is returned as feasible.
- :func:`gamma_min` (the level minimized directly: the LMIs are affine in gamma^2) and
  :func:`bisect_gamma` (feasibility bisection); each checks the other in the tests.
- :func:`monodromy` / :func:`ms_spectral_radius`: the second-moment operator
  ``X -> sum_l Acl_l X Acl_l^T`` over one period, ESMS iff its spectral radius is < 1,
  with no Lyapunov matrix involved; :func:`second_moment` propagates ``E[x x^T]`` exactly
  and :func:`monte_carlo` draws seeded realizations of the same loop.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import cvxpy as cp
import numpy as np

from satfmu.synthesis.core import solve_policy
from satfmu.fmus.errors import PeriodicSystemError


@dataclass(frozen=True)
class PeriodicSystem:
    """An N-periodic system with r multiplicative noises (index 0: the nominal matrices).

    Parameters
    ----------
    A : ndarray, shape (N, r+1, n, n)
        State matrices ``A_l(k)``.
    B1 : ndarray, shape (N, r+1, n, m1)
        Disturbance input matrices.
    B2 : ndarray, shape (N, r+1, n, m2)
        Control input matrices.
    C : ndarray, shape (N, p, n)
        Output matrices ``C(k)`` of the quality output z.
    D : ndarray, shape (N, p, m2)
        Quality output ``z = C x + D u``.
    """

    A: np.ndarray
    B1: np.ndarray
    B2: np.ndarray
    C: np.ndarray
    D: np.ndarray

    def __post_init__(self) -> None:
        arrays = {k: np.asarray(getattr(self, k), float) for k in ("A", "B1", "B2", "C", "D")}
        for k, v in arrays.items():
            object.__setattr__(self, k, v)
            if not np.all(np.isfinite(v)):
                raise PeriodicSystemError(f"{k} has non-finite entries")
        A, B1, B2, C, D = arrays.values()
        if A.ndim != 4 or A.shape[2] != A.shape[3]:
            raise PeriodicSystemError(f"A must have shape (N, r+1, n, n), got {A.shape}")
        N, r1, n, _ = A.shape
        for k, v, tail in (("B1", B1, None), ("B2", B2, None)):
            if v.ndim != 4 or v.shape[:3] != (N, r1, n):
                raise PeriodicSystemError(f"{k} must have shape ({N}, {r1}, {n}, m), got {v.shape}")
        if C.ndim != 3 or C.shape[0] != N or C.shape[2] != n:
            raise PeriodicSystemError(f"C must have shape ({N}, p, {n}), got {C.shape}")
        if D.shape != (N, C.shape[1], B2.shape[3]):
            raise PeriodicSystemError(f"D must have shape ({N}, {C.shape[1]}, {B2.shape[3]}), got {D.shape}")

    @property
    def dims(self) -> tuple[int, int, int, int, int, int]:
        """(N, r, n, m1, m2, p)."""
        N, r1, n, _ = self.A.shape
        return N, r1 - 1, n, self.B1.shape[3], self.B2.shape[3], self.C.shape[1]

    def output_scale(self) -> float:
        """``a = max_k ||[C(k) D(k)]||`` (at least 1): the LMIs are posed for ``a x`` (see :func:`scaled`)."""
        return max(1.0, max(float(np.linalg.norm(np.hstack([c, d]), 2)) for c, d in zip(self.C, self.D)))

    def scaled(self) -> "PeriodicSystem":
        """The same loop for the state ``a x`` (:meth:`output_scale`): ``C/a, D/a, B1 a``.

        Theorem 2 for it, with ``Y' = a^2 Y`` and ``Z' = a^2 Z``, is the congruence
        ``diag(a I, I, a I, I)`` of the original LMIs (same gains, same gamma), with Y' of
        order one instead of ``1/a^2``: the solver's strictness margin then means the same
        for every output weight.
        """
        a = self.output_scale()
        return PeriodicSystem(self.A, self.B1 * a, self.B2, self.C / a, self.D / a)

    def closed_loop(self, F: np.ndarray) -> np.ndarray:
        """``A_l(k) + B2_l(k) F(k)``, shape (N, r+1, n, n), for gains F of shape (N, m2, n).

        Parameters
        ----------
        F : numpy.ndarray, shape (N, m2, n)
            State-feedback gains ``u = F(k) x``, one per step of the period.

        Raises
        ------
        PeriodicSystemError
            If ``F`` has the wrong shape or non-finite entries.
        """
        F = np.asarray(F, float)
        N, r, n, _, m2, _ = self.dims
        if F.shape != (N, m2, n) or not np.all(np.isfinite(F)):
            raise PeriodicSystemError(f"gains must be finite with shape ({N}, {m2}, {n}), got {F.shape}")
        return self.A + self.B2 @ F[:, None]


@dataclass
class PeriodicDesign:
    """A verified solution of Theorem 2 at level ``gamma``.

    Attributes
    ----------
    gamma : float
        The H-infinity level from w to z that the solution certifies.
    Y : numpy.ndarray, shape (N, n, n)
        ``Y(k) > 0``, k = 0..N-1, of the original (unscaled) system.
    Z : numpy.ndarray, shape (N, n, m2)
        ``Z(k)``, of the original system.
    F : numpy.ndarray, shape (N, m2, n)
        The gains ``F(k) = Z(k)^T Y(k)^-1`` of ``u = F(k) x``.
    check : LMICheck
        The solver-independent check of the LMIs (:func:`certify`), passed.
    solver_status : str
        What the solver reported.
    solve_seconds : float
        Wall time of the solver, s.
    """

    gamma: float
    Y: np.ndarray
    Z: np.ndarray
    F: np.ndarray
    check: "LMICheck"
    solver_status: str
    solve_seconds: float


@dataclass
class LMICheck:
    """Solver-independent check of Theorem 2 for given Y, Z (the gains derived from them).

    ``block_max_eig[k]`` is the largest eigenvalue of the k-th LMI block (must be < 0),
    ``y_min_eig[k]`` the smallest of Y(k) (must be > 0), both for the scaled system
    (:meth:`PeriodicSystem.scaled`, where Y is of order one); ``margin`` is the smaller of
    ``-max(block_max_eig)`` and ``min(y_min_eig)`` less the rounding allowance
    ``max(ABS_MARGIN, 1000 eps_machine scale)`` (``scale``: the largest block entry).

    Attributes
    ----------
    block_max_eig : numpy.ndarray, shape (N,)
        Largest eigenvalue of each LMI block (must be < 0).
    y_min_eig : numpy.ndarray, shape (N,)
        Smallest eigenvalue of each Y(k) (must be > 0).
    margin : float
        The smallest margin less the rounding allowance; the check passes when it is > 0.
    scale : float
        Largest absolute entry of the blocks.
    details : list of str, optional
        One line per violated condition (empty when all hold).
    """

    block_max_eig: np.ndarray
    y_min_eig: np.ndarray
    margin: float
    scale: float
    details: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return self.margin > 0


ABS_MARGIN = 1e-9
"""Smallest eigenvalue margin accepted as strict in the scaled coordinates (the solver is asked
for EPS = 1e-6; numpy's eigenvalue error is about 1e-16 times the largest entry)."""


def _theorem2(sys: PeriodicSystem, k: int, Yk, Yn, Zk, g2, stack, kron, block):
    """The k-th matrix of Theorem 2 (not yet symmetrized), built with the array functions given:
    numpy's (``np.hstack, np.kron, np.block``) for a check, cvxpy's for the program."""
    N, r, n, m1, m2, p = sys.dims
    M = stack([Yk @ sys.A[k, l].T + Zk @ sys.B2[k, l].T for l in range(r + 1)])
    Nk = Yk @ sys.C[k].T + Zk @ sys.D[k].T
    Bcal = np.hstack([sys.B1[k, l].T for l in range(r + 1)])
    z = np.zeros
    return block([[-Yk, z((n, m1)), M, Nk],
                  [z((m1, n)), -g2 * np.eye(m1), Bcal, z((m1, p))],
                  [M.T, Bcal.T, -kron(np.eye(r + 1), Yn), z(((r + 1) * n, p))],
                  [Nk.T, z((p, m1)), z((p, (r + 1) * n)), -np.eye(p)]])


def lmi_block(sys: PeriodicSystem, Y: np.ndarray, Z: np.ndarray, gamma: float, k: int) -> np.ndarray:
    """The k-th matrix of Theorem 2 evaluated in numpy (symmetric, size n + m1 + (r+1) n + p).

    Parameters
    ----------
    sys : PeriodicSystem
        The system.
    Y : numpy.ndarray, shape (N, n, n)
        ``Y(k)`` for k = 0..N-1 (``Y(N) = Y(0)``).
    Z : numpy.ndarray, shape (N, n, m2)
        ``Z(k)`` for k = 0..N-1.
    gamma : float
        The H-infinity level.
    k : int
        Step of the period, 0..N-1.
    """
    L = _theorem2(sys, k, Y[k], Y[(k + 1) % sys.dims[0]], Z[k], gamma**2, np.hstack, np.kron, np.block)
    return (L + L.T) / 2


def certify(sys: PeriodicSystem, Y: np.ndarray, Z: np.ndarray, gamma: float) -> LMICheck:
    """Check Theorem 2's LMIs and Y(k) > 0 with numpy eigenvalues (no solver involved).

    The blocks are evaluated for the scaled system (:meth:`PeriodicSystem.scaled`, a
    congruence: the same signs) so that the relative margin does not depend on the weights.

    Parameters
    ----------
    sys : PeriodicSystem
        The system (unscaled).
    Y : numpy.ndarray, shape (N, n, n)
        ``Y(k)`` of the unscaled system.
    Z : numpy.ndarray, shape (N, n, m2)
        ``Z(k)`` of the unscaled system.
    gamma : float
        The H-infinity level to check.

    Returns
    -------
    LMICheck
    """
    N = sys.dims[0]
    a2 = sys.output_scale() ** 2
    sys, Y, Z = sys.scaled(), np.asarray(Y) * a2, np.asarray(Z) * a2
    blocks = [lmi_block(sys, Y, Z, gamma, k) for k in range(N)]
    scale = max(float(np.max(np.abs(b))) for b in blocks)
    top = np.array([np.linalg.eigvalsh(b)[-1] for b in blocks])
    ymin = np.array([np.linalg.eigvalsh((Y[k] + Y[k].T) / 2)[0] for k in range(N)])
    details = [f"block {k}: max eig {top[k]:.3e}" for k in range(N) if top[k] >= 0]
    details += [f"Y({k}): min eig {ymin[k]:.3e}" for k in range(N) if ymin[k] <= 0]
    allowance = max(ABS_MARGIN, 1e3 * np.finfo(float).eps * scale)
    return LMICheck(top, ymin, float(min(-top.max(), ymin.min()) - allowance), scale, details)


def _problem(sys: PeriodicSystem, gamma: float | None, eps: float, F: np.ndarray | None = None
             ) -> tuple[cp.Problem, list[cp.Variable], list, cp.Variable | cp.Constant]:
    N, r, n, m1, m2, p = sys.dims
    Y = [cp.Variable((n, n), symmetric=True) for _ in range(N)]
    Z = [cp.Variable((n, m2)) for _ in range(N)] if F is None else [Y[k] @ F[k].T for k in range(N)]
    g = cp.Variable(nonneg=True) if gamma is None else cp.Constant(gamma**2)
    cons = []
    for k in range(N):
        L = _theorem2(sys, k, Y[k], Y[(k + 1) % N], Z[k], g, cp.hstack, cp.kron, cp.bmat)
        cons += [(L + L.T) / 2 << -eps * np.eye(L.shape[0]), Y[k] >> eps * np.eye(n)]
    objective = cp.Minimize(g) if gamma is None else cp.Minimize(0)
    return cp.Problem(objective, cons), Y, Z, g


EPS = 1e-6
"""Strictness margin of the LMIs in the solver (the check then demands ABS_MARGIN)."""


def design(sys: PeriodicSystem, gamma: float, eps: float = EPS) -> PeriodicDesign | None:
    """Solve Theorem 2 at ``gamma``; None if infeasible or if the solution fails :func:`certify`.

    Parameters
    ----------
    sys : PeriodicSystem
        The system.
    gamma : float
        The H-infinity level from w to z, > 0.
    eps : float, optional
        Strictness margin of the LMIs in the solver (scaled coordinates).

    Returns
    -------
    PeriodicDesign or None

    Raises
    ------
    ValueError
        If ``gamma`` is not a finite positive number.
    """
    if not (np.isfinite(gamma) and gamma > 0):
        raise ValueError(f"gamma must be finite and > 0, got {gamma!r}")
    prob, Y, Z, _ = _problem(sys.scaled(), gamma, eps)
    return _solved(sys, prob, Y, Z, gamma)


def _solved(sys: PeriodicSystem, prob: cp.Problem, Y: list, Z: list, gamma: float | None
            ) -> PeriodicDesign | None:

    out = solve_policy.solve_cvxpy(prob)  # an inaccurate solution is judged by certify() below
    if not out.solved or Y[0].value is None:
        return None
    a2 = sys.output_scale() ** 2  # the problem was posed for the scaled system
    Yv = np.stack([(y.value + y.value.T) / 2 for y in Y]) / a2
    Zv = np.stack([np.asarray(z.value) for z in Z]) / a2
    if gamma is None:  # the minimized level, checked at a hair above the solver's value
        gamma = float(np.sqrt(prob.value)) * (1 + 1e-6)
    check = certify(sys, Yv, Zv, gamma)
    if not check.ok:
        return None
    F = np.stack([np.linalg.solve(Yv[k], Zv[k]).T for k in range(len(Y))])
    return PeriodicDesign(gamma, Yv, Zv, F, check, out.solver_status, out.seconds)


def gamma_min(sys: PeriodicSystem, eps: float = EPS) -> PeriodicDesign | None:
    """The smallest level of Theorem 2, minimized directly (the LMIs are affine in gamma^2).

    Parameters
    ----------
    sys : PeriodicSystem
        The system.
    eps : float, optional
        Strictness margin of the LMIs in the solver (scaled coordinates).

    Returns
    -------
    PeriodicDesign or None
        The design at the minimized level (verified a hair above the solver's value), or None
        if the solve or the check fails.
    """
    prob, Y, Z, _ = _problem(sys.scaled(), None, eps)
    return _solved(sys, prob, Y, Z, None)


def analyze(sys: PeriodicSystem, F: np.ndarray, eps: float = EPS) -> PeriodicDesign | None:
    """The smallest level Theorem 2 proves for the given gains (``Z(k) = Y(k) F(k)^T``): the
    analysis of a fixed design (the seed's published gains, say). None if none is found.

    Parameters
    ----------
    sys : PeriodicSystem
        The system.
    F : numpy.ndarray, shape (N, m2, n)
        The gains ``u = F(k) x`` to analyse.
    eps : float, optional
        Strictness margin of the LMIs in the solver (scaled coordinates).

    Returns
    -------
    PeriodicDesign or None
    """
    sys.closed_loop(F)  # checks the shape
    prob, Y, Z, _ = _problem(sys.scaled(), None, eps, np.asarray(F, float))
    return _solved(sys, prob, Y, Z, None)


def bisect_gamma(sys: PeriodicSystem, lo: float, hi: float, rel_tol: float = 1e-3, eps: float = EPS
                 ) -> tuple[float, float, int]:
    """Bisection on feasibility of :func:`design` in [lo, hi] (geometric midpoints).

    Returns ``(infeasible, feasible, n_solves)``: the bracket of the smallest feasible level.

    Parameters
    ----------
    sys : PeriodicSystem
        The system.
    lo : float
        Lower end of the bracket, an infeasible level (> 0).
    hi : float
        Upper end of the bracket, a feasible level.
    rel_tol : float, optional
        Stop when ``hi / lo <= 1 + rel_tol``.
    eps : float, optional
        Strictness margin of the LMIs in the solver (:func:`design`).

    Raises
    ------
    ValueError
        If ``hi`` is infeasible, ``lo`` is feasible, or the bounds are not 0 < lo < hi.
    """
    if not (0 < lo < hi):
        raise ValueError(f"need 0 < lo < hi, got {lo!r}, {hi!r}")
    solves = 2
    if design(sys, hi, eps) is None:
        raise ValueError(f"gamma = {hi:g} is infeasible: raise hi")
    if design(sys, lo, eps) is not None:
        raise ValueError(f"gamma = {lo:g} is feasible: lower lo")
    while hi / lo > 1 + rel_tol:
        mid = float(np.sqrt(lo * hi))
        solves += 1
        if design(sys, mid, eps) is None:
            lo = mid
        else:
            hi = mid
    return lo, hi, solves


def monodromy(sys: PeriodicSystem, F: np.ndarray) -> np.ndarray:
    """Matrix (n^2 x n^2) of the second-moment map over one period, from k = 0.

    One step is ``vec X -> sum_l (Acl_l kron Acl_l) vec X`` (unit-variance independent
    noises, no disturbance).

    Parameters
    ----------
    sys : PeriodicSystem
        The system.
    F : numpy.ndarray, shape (N, m2, n)
        The gains ``u = F(k) x``.
    """
    Acl = sys.closed_loop(F)
    N, r, n = sys.dims[:3]
    T = np.eye(n * n)
    for k in range(N):
        T = sum(np.kron(Acl[k, l], Acl[k, l]) for l in range(r + 1)) @ T
    return T


def ms_spectral_radius(sys: PeriodicSystem, F: np.ndarray) -> float:
    """Spectral radius of :func:`monodromy`: the loop is ESMS iff it is < 1.

    Parameters
    ----------
    sys : PeriodicSystem
        The system.
    F : numpy.ndarray, shape (N, m2, n)
        The gains ``u = F(k) x``.
    """
    return float(np.max(np.abs(np.linalg.eigvals(monodromy(sys, F)))))


def second_moment(sys: PeriodicSystem, F: np.ndarray, X0: np.ndarray, n_steps: int) -> np.ndarray:
    """Exact ``E[x(k) x(k)^T]`` for k = 0..n_steps from ``X0`` (no disturbance), shape (n_steps+1, n, n).

    Parameters
    ----------
    sys : PeriodicSystem
        The system.
    F : numpy.ndarray, shape (N, m2, n)
        The gains ``u = F(k) x``.
    X0 : numpy.ndarray, shape (n, n)
        ``E[x(0) x(0)^T]``, at step 0 of the period.
    n_steps : int
        Number of steps to propagate.
    """
    Acl = sys.closed_loop(F)
    N, r = sys.dims[:2]
    X = [np.asarray(X0, float)]
    for k in range(n_steps):
        A = Acl[k % N]
        X.append(sum(A[l] @ X[-1] @ A[l].T for l in range(r + 1)))
    return np.stack(X)


def monte_carlo(sys: PeriodicSystem, F: np.ndarray, x0: np.ndarray, n_steps: int, n_runs: int, seed: int
                ) -> tuple[np.ndarray, np.ndarray]:
    """Seeded realizations of the closed loop (no disturbance).

    Returns ``(x, u)``: states at the samples, shape (n_runs, n_steps+1, n), and the inputs
    ``u(k) = F(k) x(k)``, shape (n_runs, n_steps, m2).

    Parameters
    ----------
    sys : PeriodicSystem
        The system.
    F : numpy.ndarray, shape (N, m2, n)
        The gains ``u = F(k) x``.
    x0 : numpy.ndarray, shape (n,) or (n_runs, n)
        Initial state at step 0 of the period: the same for every run, or one per run.
    n_steps : int
        Number of steps, >= 1.
    n_runs : int
        Number of realizations, >= 1.
    seed : int
        Seed of the generator of the noises ``xi_l(k)``.

    Raises
    ------
    ValueError
        If ``n_runs`` or ``n_steps`` is below 1.
    """
    if n_runs < 1 or n_steps < 1:
        raise ValueError("n_runs and n_steps must be >= 1")
    Acl = sys.closed_loop(F)
    N, r, n = sys.dims[:3]
    F = np.asarray(F, float)
    rng = np.random.default_rng(seed)
    x = np.empty((n_runs, n_steps + 1, n))
    u = np.empty((n_runs, n_steps, F.shape[1]))
    x[:, 0] = x0
    for k in range(n_steps):
        xi = np.concatenate([np.ones((n_runs, 1)), rng.standard_normal((n_runs, r))], axis=1)
        A = np.einsum("bl,lij->bij", xi, Acl[k % N])
        u[:, k] = x[:, k] @ F[k % N].T
        x[:, k + 1] = np.einsum("bij,bj->bi", A, x[:, k])
    return x, u
