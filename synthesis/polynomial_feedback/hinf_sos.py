"""Seed 000, Theorem 1: polynomial state feedback for the MRP satellite by SOS.

Seed: the seed 000 paper, eq. (23) and section 5.2; restated in
docs/models.md, "Seed 000". Find a constant ``Q = Q^T > 0`` and a polynomial ``K(x)``
(3 x 6) with

    M(x) = A(x) Q + Q A(x)^T + B K(x) + K(x)^T B^T  <= -E        (E >= 0, an SOS-matrix condition)

then ``u = K(x) P x``, ``P = Q^-1``, and ``V = x^T P x`` satisfies
``dV/dt = (P x)^T M(x) (P x) <= -(P x)^T E (P x)``. Following the paper's numerical
advice, ``B = [I3; 0]`` in the program (the plant's constant input block ``G`` of
``B_u = [G; 0]`` folded into K) and the torque law is ``u = G^-1 K(x) P x``: for the MRP
satellite ``G = J^-1`` and ``u = J K(x) P x`` (seed 000: ``diag(I) K(x) P x``), with the
plant's inertia tensor, products of inertia included.

What can be proved (docs/models.md, "What a certificate can prove"):

- ``region=None``: ``E = diag(eps I3, 0)``, globally. ``dV/dt <= -eps |P_w x|^2`` and
  LaSalle's invariance principle gives global asymptotic stability ("global,
  semi-definite + LaSalle").
- ``region=r < 1``: ``E = eps I`` on ``|sigma| <= r`` (S-procedure multipliers): strict
  decrease on that region (``"strict on |sigma| <= r"``).
"""
from __future__ import annotations

import functools
import operator
import time
from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np
import scipy.sparse as sps
import sympy as sp

from satfmu.controllers import artifact as artifacts, domain
from satfmu.fmus.plants import mrp_satellite
from satfmu.fmus.model import Model
from satfmu.synthesis.core.polynomial import Poly, PolyMatrix, monomials
from satfmu.synthesis.core.sos import Check, SOSProgram, SOSSolution, check_numbers, certify


@dataclass
class Theorem1Result:
    """A solved and independently verified Theorem 1 design.

    Attributes
    ----------
    Q : numpy.ndarray, shape (n, n)
        The Lyapunov matrix ``Q = P^-1`` (``V = x^T Q^-1 x``; n = 6 for the MRP satellite).
    K : list of list of satfmu.synthesis.core.polynomial.Poly
        Torque gains ``G^-1 K(x)`` (MRP satellite: ``J K(x)``) as numeric polynomials in x
        (3 x 6); the law is ``u = K(x) P x`` (N m).
    checks : list of satfmu.synthesis.core.sos.Check
        The independent verification of every SOS constraint.
    proved : str
        What the certificate proves, e.g. ``"strict on |sigma| <= 0.9: dV/dt <= ..."``.
    region : str
        Where it is proved: ``"global"`` or ``"|sigma| <= r"``.
    domain : list of dict
        The same in numbers (:mod:`satfmu.controllers.domain`): ``[]`` globally, the ball on sigma.
    solution : satfmu.synthesis.core.sos.SOSSolution
        The solver's output.
    timings : dict, optional
        ``"build"``, ``"solve"`` and ``"verify"`` times, s.
    """

    Q: np.ndarray
    K: list[list[Poly]]
    """Torque gains ``G^-1 K(x)`` (MRP satellite: ``J K(x)``) as numeric polynomials in x (3 x 6)."""
    checks: list[Check]
    proved: str
    region: str
    domain: list[dict[str, Any]]
    solution: SOSSolution
    timings: dict[str, float] = field(default_factory=dict)

    @property
    def certified(self) -> bool:
        """Every SOS constraint passed the independent verification."""
        return all(c.certified for c in self.checks)

    def law_terms(self) -> list[list[list[dict[str, Any]]]]:
        """K as artifact terms (``gain_times_lyapunov`` form)."""
        return [[[{"c": float(c), "e": [int(v) for v in e]} for c, e in zip(p.c0, p.exps) if c != 0.0]
                 for p in row] for row in self.K]


def theorem1(model: Model | None = None, k_degree: int = 2, rate_margin: float = 1e-2,
             region: float | None = None, strict_margin: float = 1e-3, decay_rate: float = 0.0,
             multiplier_degree: int = 0,
             q_min: float = 1.0,
             coefficient_bounds: Mapping[tuple[int, int], tuple[float | None, float | None]] | None = None,
             coefficient_limit: float | None = None) -> Theorem1Result:
    """Solve Theorem 1 for ``model``'s SDC form at its parameters' values (``start``).

    Parameters
    ----------
    model : satfmu.fmus.model.Model, optional
        The plant (default: seed 000's MRP satellite). Design for your own spacecraft with
        ``satfmu.fmus.plants.mrp_satellite.build(spacecraft)``. Its SDC input matrix must be
        ``B_u = [G; 0]`` with a constant invertible ``G`` (3 x 3).
    k_degree : int
        Degree of every entry of K(x).
    rate_margin : float
        eps of ``E = diag(eps I3, 0)`` in the global variant (1/s, on ``Q``'s scale).
    region : float, optional
        r < 1: prove strict decrease (``E = strict_margin I``) on ``|sigma| <= r``.
    strict_margin : float
        eps of ``E = eps I`` with ``region`` (1/s, on ``Q``'s scale), > 0; unused globally.
    decay_rate : float
        With ``region``: also ``M + 2 decay_rate Q <= -E`` there, i.e.
        ``dV/dt <= -2 decay_rate V`` (exponential convergence at that rate, 1/s, inside the
        largest level set of V in the region). The design knob of the two-step iteration.
    multiplier_degree : int
        Degree of the S-procedure multipliers of the region (even; 0: constant multipliers).
    q_min : float
        ``Q >= q_min I`` fixes the scale of the homogeneous problem; trace(Q) is minimized.
    coefficient_bounds : mapping, optional
        ``{(i, j): (lower, upper)}``: bounds on the constant coefficient of ``K[i][j]``
        (0-based; ``None`` for no bound), the paper's "coefficient <= -2" tuning knob
        (section 4, eq. 30). In the program's units (B's diagonal folded into K).
    coefficient_limit : float, optional
        ``|k| <= coefficient_limit`` for every coefficient of K (program units): keeps the
        gains finite where the objective does not price them.

    Raises
    ------
    satfmu.synthesis.core.sos.SOSError
        If the program is infeasible (e.g. a strict margin globally).
    ValueError
        Bad arguments (checked before any program is built).
    """
    model = mrp_satellite.MODEL if model is None else model
    m = 3
    _check_arguments(len(model.states), m, k_degree, region, decay_rate, strict_margin, q_min,
                     coefficient_bounds, coefficient_limit)
    t0 = time.perf_counter()
    xs = [s.symbol for s in model.states]
    n = len(xs)
    subs = {v.symbol: sp.Float(v.start) for v in model.parameters}  # xreplace: numbers for symbols
    A = PolyMatrix.from_sympy(model.sdc.A.xreplace(subs), xs)  # type: ignore[union-attr]
    G_inv = _input_gain_inverse(model, subs, m)
    Bf = PolyMatrix.from_sympy(sp.Matrix(sp.BlockMatrix([[sp.eye(m)], [sp.zeros(n - m, m)]])), xs)
    prog = SOSProgram(n)
    Qe = prog.new_symmetric(n)
    Q = PolyMatrix(Qe)
    K = PolyMatrix([[prog.new_poly(monomials(n, k_degree)) for _ in range(n)] for _ in range(m)])
    AQ, BK = A @ Q, Bf @ K
    negM = -(AQ + AQ.T + BK + BK.T)
    if coefficient_limit is not None:
        allk = sps.vstack([e.with_decision_size(prog.n_decision).C for row in K.entries for e in row],
                          format="csr")
        lim = np.full(allk.shape[0], float(coefficient_limit))
        prog.add_linear(allk, lim, kind="ge")
        prog.add_linear(-allk, lim, kind="ge")
    for (i, j), (lower, upper) in (coefficient_bounds or {}).items():
        entry = K.entries[i][j]
        row = entry.C[np.flatnonzero(~entry.exps.any(axis=1))]
        if lower is not None:
            prog.add_linear(row, np.array([-float(lower)]), kind="ge")
        if upper is not None:
            prog.add_linear(-row, np.array([float(upper)]), kind="ge")
    prog.add_psd_constant(Qe, "Q >= q_min I", margin=q_min)
    if region is None:
        E = np.diag([rate_margin] * m + [0.0] * (n - m))
        label, proved = "global", f"global, semi-definite + LaSalle: dV/dt <= -{rate_margin:g} |P_w x|^2"
        prog.add_sos_matrix(negM - PolyMatrix.constant(E, n), "-M - E", label=label)
    else:
        E = strict_margin * np.eye(n)
        label = f"|sigma| <= {region:g}"
        proved = f"strict on |sigma| <= {region:g}: dV/dt <= -{strict_margin:g} |P x|^2"
        if decay_rate > 0:
            negM = negM - Q.scale(2 * decay_rate)
            proved += f" - {2 * decay_rate:g} V"
        s2 = sum(sp.Symbol(f"sigma[{i}]", real=True) ** 2 for i in (1, 2, 3))
        ball = Poly.from_sympy(region**2 - s2, xs)
        prog.add_sos_matrix(negM - PolyMatrix.constant(E, n), "-M - E", region=[ball],
                            multiplier_degree=multiplier_degree, label=label)
    trace = sum(Qe[i][i].C for i in range(n))
    t1 = time.perf_counter()
    sol = prog.solve(objective=trace)
    t2 = time.perf_counter()
    checks = certify(prog, sol)
    # sol.timings["build"] = the program's own constraint building (inside t1 - t0) + cvxpy set-up
    timings = {"build": t1 - t0 + sol.timings["build"] - prog.build_seconds, "solve": sol.timings["solve"],
               "verify": time.perf_counter() - t2}
    Qv = np.array([[float(e.value(sol.y).c0[0]) for e in row] for row in Qe])
    Kv = [[K.entries[i][j].value(sol.y) for j in range(n)] for i in range(m)]
    Kt = [[functools.reduce(operator.add, [Kv[l][j].scale(float(G_inv[i, l])) for l in range(m) if G_inv[i, l]])
           for j in range(n)] for i in range(m)]
    sigma = [f"sigma[{i}]" for i in (1, 2, 3)]
    return Theorem1Result(Qv, Kt, checks, proved, label, [] if region is None else [domain.ball(sigma, region)],
                          sol, timings)


def _input_gain_inverse(model: Model, subs: dict, m: int) -> np.ndarray:
    """``G^-1`` of the SDC input block ``B_u = [G; 0]`` (the first ``m`` columns of B).

    Raises
    ------
    ValueError
        If ``B_u`` depends on the state, has non-zero rows below ``G``, or ``G`` is singular.
    """
    Bu = model.sdc.B[:, :m].xreplace(subs)  # type: ignore[union-attr]
    if Bu.free_symbols:
        raise ValueError(f"{model.name}: the SDC input matrix depends on {sorted(map(str, Bu.free_symbols))}; "
                         f"Theorem 1 needs a constant one")
    Bu = np.array(Bu, dtype=float)
    if np.any(Bu[m:] != 0.0):
        raise ValueError(f"{model.name}: the SDC input matrix must be [G; 0] (inputs act on the first {m} states)")
    if np.linalg.cond(Bu[:m]) > 1e12:
        raise ValueError(f"{model.name}: the input block G of the SDC form is singular")
    return np.linalg.inv(Bu[:m])


def _check_arguments(n: int, m: int, k_degree: int, region: float | None, decay_rate: float,
                     strict_margin: float, q_min: float,
                     coefficient_bounds: Mapping[tuple[int, int], tuple[float | None, float | None]] | None,
                     coefficient_limit: float | None) -> None:
    """Theorem 1's arguments, refused with ``ValueError`` before a program is built."""
    if not (isinstance(k_degree, int) and k_degree >= 0):
        raise ValueError(f"k_degree must be an integer >= 0, got {k_degree!r}")
    if region is not None and not 0 < region < 1:
        raise ValueError(f"region radius must be in (0, 1), got {region}")
    if not decay_rate >= 0:
        raise ValueError(f"decay rate must be >= 0, got {decay_rate}")
    if region is not None and not strict_margin > 0:
        raise ValueError(f"strict margin must be > 0, got {strict_margin}")
    if not q_min > 0:
        raise ValueError(f"q_min must be > 0, got {q_min}")
    if coefficient_limit is not None and not coefficient_limit > 0:
        raise ValueError(f"coefficient limit must be > 0, got {coefficient_limit}")
    for (i, j) in coefficient_bounds or {}:
        if not (0 <= i < m and 0 <= j < n):
            raise ValueError(f"coefficient bound on K[{i}][{j}]: K is {m} x {n}")


def artifact_data(result: Theorem1Result, name: str, model: Model | None = None) -> dict[str, Any]:
    """Controller artifact (JSON data, format of :mod:`satfmu.controllers.artifact`) of a design for
    ``model`` (the plant it was designed for; default seed 000's MRP satellite), which the
    artifact records (model, parameter values, digest).

    The certificate status is "certified" only when every SOS constraint passed the
    independent verification; the numbers of each check are recorded.

    Parameters
    ----------
    result : Theorem1Result
        The design.
    name : str
        The artifact's name, lower_snake_case (the controller FMU's modelIdentifier).
    model : satfmu.fmus.model.Model, optional
        The plant the design was made for (default seed 000's MRP satellite).

    Returns
    -------
    dict
        The artifact's JSON data, law of form ``gain_times_lyapunov``
        (:func:`satfmu.controllers.artifact.new_data`).
    """
    return artifacts.new_data(
        mrp_satellite.MODEL if model is None else model, name,
        f"Seed 000 Theorem 1 state feedback u = J K(x) P x, synthesized by satfmu ({result.region})",
        law={"form": "gain_times_lyapunov", "K": result.law_terms(), "P": np.linalg.inv(result.Q).tolist()},
        lyapunov={"Q": result.Q.tolist(), "note": "V = x^T Q^-1 x"},
        certificate={"status": "certified" if result.certified else "not_verified",
                     "proved": result.proved, "region": result.region, "domain": result.domain,
                     "numbers": check_numbers(result.checks)},
        provenance={"source": "satfmu satfmu.synthesis.polynomial_feedback.hinf_sos.theorem1 (seed 000 eq. 23)",
                    "solver": result.solution.solver, "timings_s": result.timings})
