"""Robust H-infinity analysis of a state feedback with a parameter-dependent Lyapunov function.

:func:`pdlf_hinf` bounds the closed-loop H-infinity norm ``w1 -> z1`` of ``u = K x`` over the
whole box on an :class:`~satfmu.synthesis.robust.lft_plant.AffineDescriptor` (implicit system affine in
``delta``), with ``V = x^T P(delta) x``, ``P(delta) = P0 + sum_k delta_k Pk``, by dilated LMIs
at the box vertices (the derivation is in its docstring); ``common=True`` is the bound of one
common Lyapunov matrix. The program's size is estimated before it is built
(:func:`pdlf_size`, :data:`PDLF_MAX_ENTRIES`). As in :mod:`satfmu.synthesis.robust.robust_design`, the
minimizer is checked at the backed-off levels (:data:`~satfmu.synthesis.robust.solve_strategy.BACKOFFS`), then,
if it fails, back-off solves follow, and a
result is ``"optimal"`` only when :func:`certify_pdlf` has re-checked every vertex LMI in numpy;
when the minimization gives no usable optimum, a bisection on gamma from the nominal loop's
exact norm (:func:`satfmu.synthesis.core.system_norms.hinf_norm`) finds the smallest verified level.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np

from satfmu.synthesis.core import lmi, solve_policy
from satfmu.synthesis.robust.lft_plant import (AffineDescriptor, NotHurwitzError, OptionError, PlantDataError,
                                 ProgramTooLargeError, _check_gain, _check_vertices, _matrix, _sym, box_vertices)
from satfmu.synthesis.robust.checks import EPS, RobustCheck, _check_eps, _finish_check
from satfmu.synthesis.robust.multipliers import MAX_VERTICES
from satfmu.synthesis.robust.solve_strategy import BACKOFFS
from satfmu.synthesis.core.system_norms import hinf_norm

PDLF_MAX_ENTRIES = 10_000_000
"""Default largest :func:`pdlf_size` accepted by :func:`pdlf_hinf`. Measured on this machine
(Clarabel 0.11): DEMETER 1 axis, 2 appendages (8 vertices, LMIs of size 30) 6.9e6, seconds;
2 axes (32 vertices, size 48) 4.4e7, over 8 minutes and 13 GB without converging."""

PDLF_BISECTION_TOL = 5e-3
"""Relative width in gamma at which :func:`pdlf_hinf`'s bisection stops."""
PDLF_MAX_DOUBLINGS = 30
"""Doublings of the nominal norm tried before the bisection gives up finding a feasible level."""


@dataclass
class PDLFResult:
    """Result of :func:`pdlf_hinf`.

    ``gamma``: the certified bound of ``||w1 -> z1||_inf`` over the box (sqrt of the minimized
    ``g``, times ``1 + backoff``: :data:`~satfmu.synthesis.robust.solve_strategy.BACKOFFS`; with ``method ==
    "bisection"`` the smallest level verified by the bisection, within
    :data:`PDLF_BISECTION_TOL` of the smallest it could not verify); ``P0``, ``Pk`` (shape (N,
    n, n), zeros if ``common``) the Lyapunov matrix ``P(delta) = P0 + sum delta_k Pk[k]``; ``F``
    the slack, shape (2 n + n_v + m_w, n + n_v). With ``state_scaling`` (T) the certificate
    holds in the coordinates ``x = diag(T) x_s``: ``certify_pdlf(desc.scale_states(T), K * T, P0,
    Pk, F, gamma)`` (:meth:`AffineDescriptor.scale_states`; gamma does not depend on them).
    Status and times as :class:`~satfmu.synthesis.robust.design_result.RobustDesign`.

    Attributes
    ----------
    status : {"optimal", "infeasible", "unverified"}
        Verified certificate, infeasibility proved by the solver, or no verified level.
    gamma : float or None
        The certified bound (units of z1 per unit of w1); None unless ``"optimal"``.
    P0 : numpy.ndarray, shape (n, n), or None
        Constant part of the Lyapunov matrix.
    Pk : numpy.ndarray, shape (N, n, n), or None
        Its parameter-dependent parts (zeros if ``common``).
    F : numpy.ndarray, shape (2 n + n_v + m_w, n + n_v), or None
        The slack matrix.
    check : satfmu.synthesis.robust.checks.RobustCheck or None
        :func:`certify_pdlf` of the certificate returned, or of the last one that failed.
    common : bool
        One common Lyapunov matrix (``Pk = 0``) instead of a PDLF.
    n_vertices : int
        Box vertices, ``2^N``.
    solver_status : str
        The statuses of every solve made, ``"; "``-separated.
    solve_seconds : float
        Clarabel's wall time summed over the solves, s.
    build_seconds : float
        Time to build the LMI programs, summed, s.
    backoff : float, optional
        The back-off of :data:`~satfmu.synthesis.robust.solve_strategy.BACKOFFS` at which the
        certificate verified (None: bisection, or no certificate).
    method : {"minimize", "bisection"}, optional
        How ``gamma`` was found. Default ``"minimize"``.
    state_scaling : numpy.ndarray, shape (n,), optional
        The scaling T of the certificate's coordinates, None if it is in the caller's.
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
    state_scaling: np.ndarray | None = None


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


def certify_pdlf(desc: AffineDescriptor, K, P0, Pk, F, gamma: float) -> RobustCheck:
    """Check :func:`pdlf_hinf`'s LMIs at every vertex with numpy: ``P(delta_v) > 0`` (``"P"``)
    and the dilated H-infinity LMI at ``g = gamma^2`` (``"hinf"``), one eigenvalue per vertex.

    Parameters
    ----------
    desc : satfmu.synthesis.robust.lft_plant.AffineDescriptor
        The plant, affine in the N parameters.
    K : numpy.ndarray, shape (m_u, n)
        The state-feedback gain, ``u = K x``.
    P0 : numpy.ndarray, shape (n, n)
        Constant part of the Lyapunov matrix (its symmetric part is used).
    Pk : numpy.ndarray, shape (N, n, n)
        Parameter-dependent parts of the Lyapunov matrix.
    F : numpy.ndarray, shape (2 n + n_v + m_w, n + n_v)
        The slack matrix.
    gamma : float
        The H-infinity level checked, units of z1 per unit of w1 (finite, > 0).

    Returns
    -------
    satfmu.synthesis.robust.checks.RobustCheck
        Eigenvalues per vertex and the margin; ``ok`` when every LMI holds.

    Raises
    ------
    PlantDataError
        If ``K``, ``P0``, ``Pk`` or ``F`` has the wrong shape or is not finite.
    OptionError
        If ``gamma`` is not finite and > 0.
    """
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
    neg: dict[str, list[np.ndarray]] = {"hinf": []}
    pos: dict[str, list[np.ndarray]] = {"P": []}
    for v in box_vertices(desc.n_params):
        P = P0 + _sym(np.tensordot(v, Pk, axes=1)) if len(v) else P0
        pos["P"].append(P)
        neg["hinf"].append(_pdlf_lmi(desc, K, P, F, gamma**2, v, np.block))
    return _finish_check(neg, pos)


def pdlf_size(desc: AffineDescriptor) -> int:
    """Size of the :func:`pdlf_hinf` program of ``desc``: the sum over its LMIs of the squared
    number of their distinct entries, ``2^N ((s (s + 1) / 2)^2 + (n (n + 1) / 2)^2)``, ``s = 2 n +
    n_v + m_w + p``. Clarabel's KKT system holds a dense block of that many entries per PSD cone,
    and the slack F couples every cone, so this is the memory and time the solve needs.

    Parameters
    ----------
    desc : satfmu.synthesis.robust.lft_plant.AffineDescriptor
        The plant, affine in the N parameters.
    """
    n, s = desc.n, _pdlf_side(desc)
    return 2**desc.n_params * ((s * (s + 1) // 2) ** 2 + (n * (n + 1) // 2) ** 2)


def _pdlf_side(desc: AffineDescriptor) -> int:
    """Size of the dilated H-infinity LMI of :func:`pdlf_hinf`: ``(x', x, v, w1)`` and ``z1``."""
    return 2 * desc.n + desc.n_v + desc.m_w + desc.C1.shape[0]


def pdlf_hinf(desc: AffineDescriptor, K, *, common: bool = False, max_vertices: int = MAX_VERTICES,
              max_entries: int = PDLF_MAX_ENTRIES, eps: float = EPS, rescale: bool = True,
              ladder: solve_policy.RungMemory | None = None) -> PDLFResult:
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

    When the minimizer verifies at no back-off, ``rescale`` minimizes once more in the
    coordinates where its P0 has a unit diagonal (``state_scaling`` of the result): a P0 whose
    diagonal spans 10^7 (DEMETER row 1: 5e-4 to 8e3) leaves every answer just outside the
    feasible set; in those coordinates the minimizer verifies (row 1: 2.7 s and 3.29, where the
    back-offs and the bisection of the plain program took 41 s to certify 3.73). Failing that,
    the back-off solves in the caller's coordinates (a first minimizer solved only to a reduced
    accuracy gives poor coordinates: DEMETER row 2 in our convention), then the bisection in the
    rescaled ones if that program was solved. ``ladder``: the Clarabel rungs shared by several
    analyses of the same loop (:class:`~satfmu.synthesis.core.solve_policy.RungMemory`; DEMETER: the PDLF
    and common-P programs both fail twice before the regularized rung).

    Parameters
    ----------
    desc : satfmu.synthesis.robust.lft_plant.AffineDescriptor
        The plant, affine in the N parameters ``delta`` in ``[-1, 1]``.
    K : numpy.ndarray, shape (m_u, n)
        The state-feedback gain, ``u = K x``.
    common : bool, optional
        One common Lyapunov matrix (``Pk = 0``) instead of the PDLF. Default False.
    max_vertices : int, optional
        Largest number of box vertices ``2^N`` accepted (default
        :data:`~satfmu.synthesis.robust.multipliers.MAX_VERTICES`).
    max_entries : int, optional
        Largest :func:`pdlf_size` accepted (default :data:`PDLF_MAX_ENTRIES`).
    eps : float, optional
        Strictness of the LMIs in the solver (default
        :data:`~satfmu.synthesis.robust.checks.EPS`).
    rescale : bool, optional
        Minimize once more in the coordinates where P0 has a unit diagonal when the first
        minimizer does not verify (above). Default True.
    ladder : satfmu.synthesis.core.solve_policy.RungMemory, optional
        The solver rungs to share with other analyses of the same loop; default a new one.

    Returns
    -------
    PDLFResult
        The bound and its certificate, or why there is none.

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
    info = {"common": common, "n_vertices": 2**desc.n_params, "solve_seconds": 0.0, "build_seconds": 0.0,
            "solver_status": ""}
    memory = solve_policy.RungMemory() if ladder is None else ladder
    first = _minimized(desc, K, common, eps, info, memory)
    if first.result is not None or first.infeasible:
        return first.result or PDLFResult("infeasible", None, None, None, None, None, **info)
    check = first.check
    bisect_desc, bisect_K, bisect_T = desc, K, None  # the coordinates of the bisection
    if rescale and first.P0 is not None and np.all(np.diag(first.P0) > 0):
        T = 1.0 / np.sqrt(np.diag(first.P0))
        scaled = desc.scale_states(T)
        info["solver_status"] += "; rescaled: "
        second = _minimized(scaled, K * T, common, eps, info, memory)
        if second.result is not None:
            return replace(second.result, state_scaling=T)
        if second.P0 is not None:
            bisect_desc, bisect_K, bisect_T = scaled, K * T, T
    if first.root is not None:
        for b in BACKOFFS:
            found, check = _pdlf_at(desc, K, common, first.root * (1 + b), info, f"back-off {b:g}", memory)
            if found is not None:
                return replace(found, backoff=b)
    res = _pdlf_bisection(bisect_desc, bisect_K, common, info, check, memory)
    return res if bisect_T is None or res.status != "optimal" else replace(res, state_scaling=bisect_T)


@dataclass
class _Minimum:
    """:func:`_minimized`'s answer: the verified result, or the minimizer's root, P0 and check."""

    result: PDLFResult | None
    infeasible: bool = False
    root: float | None = None
    P0: np.ndarray | None = None
    check: RobustCheck | None = None


def _minimized(desc: AffineDescriptor, K: np.ndarray, common: bool, eps: float, info: dict,
               ladder: solve_policy.RungMemory) -> _Minimum:
    """Minimize g (times and status added to ``info``) and verify the minimizer itself at each
    of :data:`BACKOFFS` (no second solve if it verifies)."""
    t0 = time.perf_counter()
    prog = lmi.LMIProgram()
    g = prog.variable()
    P0, Pk, F = _pdlf_constraints(prog, desc, K, common, eps, g)
    info["build_seconds"] += time.perf_counter() - t0
    out = _timed_solve(prog, g, False, info, ladder)
    info["solver_status"] += out.solver_status
    if out.status == "infeasible":
        return _Minimum(None, infeasible=True)
    assert prog.solution is not None  # set by the solve in _timed_solve
    if not prog.solution.solved:
        return _Minimum(None)
    root = float(np.sqrt(max(float(prog.value(g)[0, 0]), 0.0)))
    P0v, Pkv, Fv = _pdlf_values(prog, desc, P0, Pk, F)
    check = None
    for b in BACKOFFS:
        check = certify_pdlf(desc, K, P0v, Pkv, Fv, root * (1 + b))
        if check.ok:
            info["solver_status"] += f"; the minimizer verified at back-off {b:g}"
            return _Minimum(PDLFResult("optimal", root * (1 + b), P0v, Pkv, Fv, check, **info, backoff=b))
    return _Minimum(None, root=root, P0=P0v, check=check)


def _timed_solve(prog: lmi.LMIProgram, objective: lmi.Affine, maximize: bool, info: dict,
                 ladder: solve_policy.RungMemory) -> solve_policy.SolveOutcome:
    out = prog.solve(objective, maximize=maximize, ladder=ladder).outcome
    info["solve_seconds"] += out.seconds
    return out


def _pdlf_at(desc: AffineDescriptor, K: np.ndarray, common: bool, gamma: float, info: dict, label: str,
             ladder: solve_policy.RungMemory) -> tuple[PDLFResult | None, RobustCheck | None]:
    """The largest common margin of the PDLF LMIs at level ``gamma`` (bounded by 1), verified:
    ``(result, check)``; result None if the certificate fails :func:`certify_pdlf`."""
    t0 = time.perf_counter()
    prog = lmi.LMIProgram()
    t = prog.variable()
    P0, Pk, F = _pdlf_constraints(prog, desc, K, common, t, gamma**2)
    prog.add_nonneg(1.0 - t)
    info["build_seconds"] += time.perf_counter() - t0
    out = _timed_solve(prog, t, True, info, ladder)
    info["solver_status"] += f"; {label}: {out.solver_status}"
    assert prog.solution is not None  # set by the solve in _timed_solve
    if not prog.solution.solved or prog.value(t)[0, 0] <= 0:
        return None, None
    P0v, Pkv, Fv = _pdlf_values(prog, desc, P0, Pk, F)
    check = certify_pdlf(desc, K, P0v, Pkv, Fv, gamma)
    if not check.ok:
        return None, check
    return PDLFResult("optimal", gamma, P0v, Pkv, Fv, check, **info), check


def _pdlf_values(prog: lmi.LMIProgram, desc: AffineDescriptor, P0, Pk, F) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(P0, Pk, F)`` at the solution of ``prog`` (``Pk`` zeros, shape (N, n, n), if common)."""
    n, N = desc.n, desc.n_params
    Pkv = np.stack([_sym(prog.value(p)) for p in Pk]) if Pk else np.zeros((N, n, n))
    return _sym(prog.value(P0)), Pkv, prog.value(F)


def _pdlf_bisection(desc: AffineDescriptor, K: np.ndarray, common: bool, info: dict,
                    check: RobustCheck | None, ladder: solve_policy.RungMemory) -> PDLFResult:
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
        best, check = _pdlf_at(desc, K, common, high, info, f"bisection {high:.6g}", ladder)
        if best is not None:
            break
        low = high
    if best is None:
        return PDLFResult("unverified", None, None, None, None, check, **info)
    while high > low * (1 + PDLF_BISECTION_TOL):
        mid = float(np.sqrt(low * high))
        found, _ = _pdlf_at(desc, K, common, mid, info, f"bisection {mid:.6g}", ladder)
        if found is None:
            low = mid
        else:
            best, high = found, mid
    return replace(best, **{k: info[k] for k in ("solver_status", "solve_seconds", "build_seconds")},
                   method="bisection")


def _pdlf_constraints(prog: lmi.LMIProgram, desc: AffineDescriptor, K: np.ndarray, common: bool, margin, g
                      ) -> tuple:
    """``(P0, Pk, F)`` of :func:`pdlf_hinf`, its LMIs (strict by ``margin``, at level ``g``)
    added to ``prog``."""
    n, N = desc.n, desc.n_params
    P0 = prog.variable((n, n), symmetric=True)
    Pk = [] if common else [prog.variable((n, n), symmetric=True) for _ in range(N)]
    F = prog.variable((2 * n + desc.n_v + desc.m_w, n + desc.n_v))
    for v in box_vertices(N):
        P = P0 + sum(d * Pj for d, Pj in zip(v, Pk))
        L = _pdlf_lmi(desc, K, P, F, g, v, lmi.bmat)
        prog.add_psd(P - margin * np.eye(n))
        prog.add_psd(-L - margin * np.eye(L.shape[0]))
    return P0, Pk, F
