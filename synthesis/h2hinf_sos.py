"""Seed 001, Theorem 8: mixed H2/H-infinity state feedback with slack variables, by SOS.

Seed: shared/seeds/001_c293a0e070ac305a.txt (Chinese); restated in clean notation in
shared/MODELS.md, "Seed 001". For ``x' = A(x) x + Bu u + Bw w``, ``z = C x`` (the MRPs),
find symmetric ``X2``, ``Xinf`` > 0, a slack matrix ``F`` and a polynomial ``Y(x)`` with

    -[ G11 + e I   *              *        *      ]
     [ G12         -a (F + F^T)   *        *      ]   SOS matrix (H2 part, ``a = alpha``)
     [ F           a F           -Qh^-1    *      ]
     [ Y           a Y            0       -Rh^-1  ]

    -[ G13 + e I   *              *        *      ]
     [ G14         -b (F + F^T)   *        *      ]   SOS matrix (H-infinity part, ``b = beta``)
     [ Bw^T        0             -g^2 I    *      ]
     [ C F         b C F          0       -I      ]

    [ lambda  x0^T ; x0  X2 ] >= 0

with ``G11 = G13 = A F + Bu Y + (A F + Bu Y)^T`` and ``G12 = X2 - F + a (A F + Bu Y)^T``,
``G14 = Xinf - F + b (A F + Bu Y)^T``; minimize ``lambda``. The law is
``u = Y(x) F^-1 x``. The closed loop then has H2 cost ``J2 <= lambda`` from ``x0`` and L2 gain
``w -> z`` below ``gamma`` where the conditions hold.

Choices (MODELS.md, "Checked numerically before building"):

- ``X2``, ``Xinf`` and ``F`` are constant: then the ``dX/dx`` terms vanish and
  ``u = Y(x) F^-1 x`` is a polynomial (no linear solve at run time). With a constant F the
  conditions cannot hold for large ``|sigma|``, so they are certified on ``|sigma| <= r``
  (S-procedure), and the artifact says so.
- The margin ``e`` is a full-matrix margin (the seed's sits on the (1,1) block only), so
  ``-a (F + F^T) < 0`` and F is invertible.
- ``variant="common"``: ``X2 = Xinf = F`` (symmetric), the common-Lyapunov baseline the
  seed says the slack design beats.
- ``alpha`` and ``beta`` are fixed in one SDP and searched outside (:func:`search`).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np
from scipy.optimize import minimize_scalar

from controllers import artifact as artifacts
from fmus import mrp_satellite
from fmus.model import Model
from synthesis.polynomial import Poly, PolyMatrix, monomials
from synthesis.sos import Check, SOSError, SOSProgram, SOSSolution, check_numbers, verify

X0_200 = np.array([0.0, 0.0, 0.0, 0.5992, -0.7976, 0.6517])
"""x(0) of the H2 bound: seed 000's 200 deg rest-to-rest start (**substitute**, MODELS.md)."""
VARIANTS = ("slack", "common")


@dataclass
class Theorem8Result:
    """A solved and independently verified Theorem 8 design at fixed gamma, alpha, beta."""

    variant: str
    gamma: float
    alpha: float
    beta: float
    lam: float
    """The certified H2 bound lambda (objective)."""
    X2: np.ndarray
    Xinf: np.ndarray
    F: np.ndarray
    Y: list[list[Poly]]
    checks: list[Check]
    region: str
    x0: np.ndarray
    solution: SOSSolution
    timings: dict[str, float] = field(default_factory=dict)

    @property
    def certified(self) -> bool:
        return all(c.certified for c in self.checks) and _psd_margin(self) >= -1e-9

    @property
    def proved(self) -> str:
        return (f"mixed H2/H-infinity ({self.variant} Lyapunov matrices) on {self.region}: "
                f"J2 <= lambda = {self.lam:.6g} from x0 while the state stays in the region, "
                f"L2 gain w -> sigma <= gamma = {self.gamma:g}")

    def gain(self) -> list[list[Poly]]:
        """``K(x) = Y(x) F^-1`` (3 x 6 numeric polynomials), so that ``u = K(x) x``."""
        Fi = np.linalg.inv(self.F)
        return [[Poly.sum([self.Y[i][k].scale(Fi[k, j]) for k in range(Fi.shape[0])]) for j in range(Fi.shape[1])]
                for i in range(len(self.Y))]

    def law_terms(self) -> list[list[dict[str, Any]]]:
        """``u_i = sum_j K_ij(x) x_j`` as artifact terms (form "polynomial")."""
        out = []
        for row in self.gain():
            n = row[0].n_vars
            parts = []
            for j, k in enumerate(row):
                e = np.zeros((1, n), np.int64)
                e[0, j] = 1
                parts.append(k * Poly.numeric(e, np.ones(1)))
            p = Poly.sum(parts)
            out.append([{"c": float(c), "e": [int(v) for v in e]} for c, e in zip(p.c0, p.exps) if c != 0.0])
        return out


def _psd_margin(r: Theorem8Result) -> float:
    """Smallest eigenvalue of X2, Xinf and the lambda block (independent of the solver)."""
    lam_block = np.block([[np.array([[r.lam]]), r.x0[None, :]], [r.x0[:, None], r.X2]])
    return float(min(np.linalg.eigvalsh(r.X2).min(), np.linalg.eigvalsh(r.Xinf).min(),
                     np.linalg.eigvalsh(lam_block).min() / max(1.0, r.lam)))


def _constant_matrix(prog: SOSProgram, rows: int, cols: int, symmetric: bool = False) -> PolyMatrix:
    if symmetric:
        return PolyMatrix(prog.new_symmetric(rows))
    zero = np.zeros((1, prog.n_vars), np.int64)
    return PolyMatrix([[prog.new_poly(zero) for _ in range(cols)] for _ in range(rows)])


def theorem8(gamma: float, alpha: float, beta: float, variant: str = "slack", region: float = 0.9,
             y_degree: int = 2, Qh: np.ndarray | None = None, Rh: np.ndarray | None = None,
             x0: np.ndarray = X0_200, margin: float = 1e-4, multiplier_degree: int = 0,
             frozen: bool = False, rate_max: float | None = None,
             model: Model = mrp_satellite.MODEL) -> Theorem8Result:
    """Solve Theorem 8 at fixed ``gamma``, ``alpha``, ``beta`` (minimize lambda).

    Parameters
    ----------
    gamma : float
        L2-gain bound w -> sigma to certify (N m -> 1).
    alpha, beta : float
        The seed's scalars (> 0), fixed here; see :func:`search`.
    variant : {"slack", "common"}
        Separate X2, Xinf and slack F (the seed's design) or X2 = Xinf = F.
    region : float
        Certificate region ``|sigma| <= region``.
    y_degree : int
        Degree of every entry of Y(x).
    Qh, Rh : ndarray, optional
        H2 weights (default I6, I3: **substitute**, the seed gives none).
    margin : float
        Full-matrix margin ``e`` of both SOS-matrix conditions and of X2, Xinf.
    frozen : bool
        Freeze A(x) at x = 0 (the linearization; LMIs): the reference design of MODELS.md.
    rate_max : float, optional
        Also restrict the region to ``|omega_i| <= rate_max`` (rad/s): the H2 condition's
        (2,1) block is linear in the rates through the gyroscopic terms.

    Raises
    ------
    ValueError
        On invalid scalars, variant or weights.
    synthesis.sos.SOSError
        If the program is infeasible at these values.
    """
    if variant not in VARIANTS:
        raise ValueError(f"variant must be one of {VARIANTS}, got {variant!r}")
    for name, v in (("gamma", gamma), ("alpha", alpha), ("beta", beta), ("region", region)):
        if not (np.isfinite(v) and v > 0):
            raise ValueError(f"{name} must be finite and > 0, got {v}")
    if rate_max is not None and not (np.isfinite(rate_max) and rate_max > 0):
        raise ValueError(f"rate_max must be finite and > 0, got {rate_max}")
    t0 = time.perf_counter()
    xs = [s.symbol for s in model.states]
    n = len(xs)
    subs = {v.symbol: v.start for v in model.parameters}
    sdc = model.sdc
    assert sdc is not None
    A_sym = sdc.A.subs(subs)
    A = PolyMatrix.from_sympy(A_sym.subs({x: 0 for x in xs}) if frozen else A_sym, xs)
    Bfull = np.array(sdc.B.subs(subs), float)
    m = Bfull.shape[1] // 2
    Bu, Bw = Bfull[:, :m], Bfull[:, m:]
    C = np.hstack([np.zeros((n - m, m)), np.eye(n - m)])
    Qh = np.eye(n) if Qh is None else np.asarray(Qh, float)
    Rh = np.eye(m) if Rh is None else np.asarray(Rh, float)
    for name, W, k in (("Qh", Qh, n), ("Rh", Rh, m)):
        if W.shape != (k, k) or not np.allclose(W, W.T) or np.linalg.eigvalsh(W).min() <= 0:
            raise ValueError(f"{name} must be a symmetric positive definite {k} x {k} matrix")
    x0 = np.asarray(x0, float)
    if x0.shape != (n,) or not np.all(np.isfinite(x0)):
        raise ValueError(f"x0 must be {n} finite numbers")

    prog = SOSProgram(n)
    F = _constant_matrix(prog, n, n, symmetric=variant == "common")
    if variant == "common":
        X2 = Xinf = F
    else:
        X2 = _constant_matrix(prog, n, n, symmetric=True)
        Xinf = _constant_matrix(prog, n, n, symmetric=True)
    Y = PolyMatrix([[prog.new_poly(monomials(n, y_degree)) for _ in range(n)] for _ in range(m)])
    lam_idx = prog.new_variables(1)

    def const(M: np.ndarray) -> PolyMatrix:
        return PolyMatrix.constant(M, n)

    AFBY = A @ F + const(Bu) @ Y
    G11 = AFBY + AFBY.T
    FFt = F + F.T
    eye = np.eye
    M2 = PolyMatrix.block([
        [G11 + const(margin * eye(n)), None, None, None],
        [X2 - F + AFBY.T.scale(alpha), -FFt.scale(alpha), None, None],
        [F, F.scale(alpha), const(-np.linalg.inv(Qh)), None],
        [Y, Y.scale(alpha), None, const(-np.linalg.inv(Rh))],
    ])
    CF = const(C) @ F
    Minf = PolyMatrix.block([
        [G11 + const(margin * eye(n)), None, None, None],
        [Xinf - F + AFBY.T.scale(beta), -FFt.scale(beta), None, None],
        [const(Bw.T), None, const(-gamma**2 * eye(m)), None],
        [CF, CF.scale(beta), None, const(-eye(n - m))],
    ])
    if frozen:  # constant matrices: plain LMIs, no region
        regions, label = None, "x = 0 (A frozen at the origin: the linearization)"
    else:
        regions = [Poly.from_sympy(region**2 - sum(x**2 for x in xs[n - 3:]), xs)]
        label = f"|sigma| <= {region:g}"
        if rate_max is not None:
            regions += [Poly.from_sympy(rate_max**2 - x**2, xs) for x in xs[:n - 3]]
            label = f"|omega_i| <= {rate_max:g} rad/s, " + label
    for name, M in (("H2", M2), ("Hinf", Minf)):
        prog.add_sos_matrix(_symmetrize_lower(M).scale(-1.0), f"-M_{name}", region=regions,
                            multiplier_degree=multiplier_degree, label=label)
    prog.add_psd_constant(X2.entries, "X2 > 0", margin=margin)
    if variant == "slack":
        prog.add_psd_constant(Xinf.entries, "Xinf > 0", margin=margin)
    # [lambda x0^T; x0 X2] >= 0
    lam = Poly(np.zeros((1, n), np.int64), np.zeros(1), prog.selector(lam_idx))
    x0c = [Poly.constant(v, n) for v in x0]
    block = [[lam] + x0c] + [[x0c[i]] + X2.entries[i] for i in range(n)]
    prog.add_psd_constant(block, "lambda bound")
    objective = prog.selector(lam_idx)
    t1 = time.perf_counter()
    # tighter than Clarabel's defaults (1e-8): the optimum sits on the cone boundary and the
    # independent verification checks coefficient residuals at 1e-7 relative
    sol = prog.solve(objective=objective, tol_feas=1e-10, tol_gap_abs=1e-10, tol_gap_rel=1e-10)
    t2 = time.perf_counter()
    checks = verify(prog, sol, sample_radius=region)
    timings = {"build": t1 - t0 + sol.timings["build"] - prog.build_seconds, "solve": sol.timings["solve"],
               "verify": time.perf_counter() - t2}

    def num(M: PolyMatrix) -> np.ndarray:
        return np.array([[float(e.value(sol.y).c0[0]) if e.exps.shape[0] else 0.0 for e in row] for row in M.entries])

    Yv = [[Y.entries[i][j].value(sol.y) for j in range(n)] for i in range(m)]
    return Theorem8Result(variant, float(gamma), float(alpha), float(beta), float(sol.y[lam_idx[0]]),
                          num(X2), num(Xinf), num(F), Yv, checks, label, x0, sol, timings)


def _symmetrize_lower(M: PolyMatrix) -> PolyMatrix:
    """The symmetric matrix whose lower triangle (diagonal included) is that of ``M``."""
    r, _ = M.shape
    e = M.entries
    return PolyMatrix([[e[i][j] if i >= j else e[j][i] for j in range(r)] for i in range(r)])


Progress = Callable[[int, int, str], None]


@dataclass
class SearchResult:
    """Best design over alpha, beta at one gamma, with every evaluated point."""

    best: Theorem8Result | None
    evaluations: list[tuple[float, float, float]]
    """``(alpha, beta, lambda)`` per SDP (lambda inf where infeasible or not certified)."""


def search(gamma: float, variant: str = "slack", alpha_bounds: tuple[float, float] = (1e-5, 1.0),
           beta_bounds: tuple[float, float] = (1e-5, 1.0), sweeps: int = 2, progress: Progress | None = None,
           **kwargs: Any) -> SearchResult:
    """Minimize lambda over log alpha and log beta (coordinate-wise golden section, ``sweeps``
    passes), one certified SDP per evaluation."""
    evaluations: list[tuple[float, float, float]] = []
    cache: dict[tuple[float, float], Theorem8Result | None] = {}
    budget = sweeps * 2 * 14 + 2
    state = {"best": None}

    def solve(a: float, b: float) -> float:
        key = (round(np.log10(a), 6), round(np.log10(b), 6))
        if key not in cache:
            if progress is not None:
                progress(min(len(evaluations), budget - 1), budget,
                         f"{variant}, gamma = {gamma:g}: alpha = {a:.3g}, beta = {b:.3g}")
            try:
                r = theorem8(gamma, a, b, variant, **kwargs)
                cache[key] = r if r.certified else None
            except SOSError:
                cache[key] = None
            r = cache[key]
            evaluations.append((a, b, r.lam if r is not None else float("inf")))
            if r is not None and (state["best"] is None or r.lam < state["best"].lam):
                state["best"] = r
        r = cache[key]
        return r.lam if r is not None else float("inf")

    a, b = np.sqrt(alpha_bounds[0] * alpha_bounds[1]), np.sqrt(beta_bounds[0] * beta_bounds[1])
    for _ in range(sweeps):
        for which in ("alpha", "beta"):
            lo, hi = np.log10(alpha_bounds if which == "alpha" else beta_bounds)
            res = minimize_scalar(lambda t: solve(10**t, b) if which == "alpha" else solve(a, 10**t),
                                  bounds=(lo, hi), method="bounded", options={"xatol": 0.05, "maxiter": 12})
            if np.isfinite(res.fun):
                if which == "alpha":
                    a = 10**res.x
                else:
                    b = 10**res.x
    if progress is not None:
        progress(budget, budget, "done")
    return SearchResult(state["best"], evaluations)


def artifact_data(result: Theorem8Result, name: str, model: Model = mrp_satellite.MODEL) -> dict[str, Any]:
    """Controller artifact (format of :mod:`controllers.artifact`, form "polynomial")."""
    return artifacts.new_data(
        model, name,
        (f"Seed 001 Theorem 8 mixed H2/H-infinity state feedback u = Y(x) F^-1 x "
         f"({result.variant} Lyapunov matrices, gamma = {result.gamma:g}), synthesized by satfmu"),
        law={"form": "polynomial", "terms": result.law_terms()},
        lyapunov={"Q": result.X2.tolist(), "note": "X2: J2 <= x0^T X2^-1 x0 <= lambda"},
        certificate={
            "status": "certified" if result.certified else "not_verified",
            "proved": result.proved, "region": result.region,
            "numbers": {**check_numbers(result.checks), "lambda": result.lam, "gamma": result.gamma,
                        "alpha": result.alpha, "beta": result.beta, "psd_margin": _psd_margin(result)},
            "h2": {"lambda": result.lam, "x0": result.x0.tolist()},
            "Xinf": result.Xinf.tolist(), "F": result.F.tolist(),
        },
        provenance={"source": "satfmu synthesis.h2hinf_sos.theorem8 (seed 001 Theorem 8)",
                    "solver": result.solution.solver, "timings_s": result.timings})


