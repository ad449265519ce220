"""Seed 001, Theorem 8: mixed H2/H-infinity state feedback with slack variables, by SOS.

Seed: the seed 001 paper (Chinese); restated in clean notation in
docs/models.md, "Seed 001". For ``x' = A(x) x + Bu u + Bw w``, ``z = C x`` (the MRPs),
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

Choices (docs/models.md, "Checked numerically before building", and what we measured):

- ``Y = Y~(x~) + Kg(x) F``: ``Kg`` cancels the actuated rows of ``A(x)`` (the gyroscopic
  torque; :class:`satfmu.synthesis.polynomial_feedback.split_plant.SplitPlant`), so the
  conditions involve ``A~(x~)`` only and hold for *every* rate, on ``|x~| <= r`` (S-procedure). The law is
  ``u = omega x I omega + Y~(sigma) F^-1 x``.
- ``X2``, ``Xinf`` and ``F`` are constant, so the ``dX/dx`` terms vanish and the law is a
  polynomial (no linear solve at run time). A state-dependent ``F`` cannot widen the
  region: with ``U = [Acl; -I; I; K]``, ``V = [I; a I; 0; 0]`` the H2 matrix is
  ``Psi + He(U F V^T)``, and projecting on ``ker U^T`` gives
  ``Acl X2 + X2 Acl^T + X2 (Qh + K^T Rh K) X2 < 0`` whatever F is. Its sigma-sigma block,
  ``G(sigma) X2_ws + (.)^T``, no feedback can change, and no constant ``X2_ws`` keeps it
  negative once ``B(sigma)/(1 + |sigma|^2)`` (a rotation by ``2 atan|sigma|``) reaches
  90 deg: constant Lyapunov matrices certify only ``|sigma| < 1``. (Measured at r = 0.3:
  F of degree 2 in sigma lowers lambda by 1 % for a 9x slower, uncertified solve.)
- The same projection (``ker [Acl; -I; 0; C]^T``) gives the dual bounded-real lemma from
  the H-infinity matrix, so both conditions are sound for any ``a, b > 0``.
- The margin ``e`` sits on every diagonal block (the seed's sits on the (1,1) block only),
  as ``a e`` on ``-a (F + F^T)``, so ``F + F^T >= e I`` and F is invertible.
- ``variant="common"``: ``X2 = Xinf = F`` (symmetric), the common-Lyapunov baseline the
  seed says the slack design beats.
- ``alpha`` and ``beta`` are fixed in one SDP and searched outside
  (:func:`satfmu.synthesis.polynomial_feedback.h2hinf_search.search`); below
  ``a ~ 0.05`` the SDPs become too ill-conditioned for Clarabel.
- ``x0`` of the H2 bound: seed 000's 200 deg start has ``|sigma| = 1.19``, outside any
  region constant Lyapunov matrices can certify, so the default is the 90 deg rest-to-rest
  about the same axis (``|sigma| = 0.414``; **substitute**, a parameter).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import sympy as sp
from scipy.integrate import solve_ivp

from satfmu.controllers import artifact as artifacts, domain
from satfmu.fmus import codegen
from satfmu.fmus.plants import mrp_satellite
from satfmu.fmus.model import Model
from satfmu.synthesis.core.polynomial import Poly, PolyMatrix, monomials
from satfmu.synthesis.core.sos import Check, SOSError, SOSProgram, SOSSolution, check_numbers, certify
from satfmu.synthesis.polynomial_feedback.coordinates import Coordinates
from satfmu.synthesis.polynomial_feedback.split_plant import SplitPlant, split

X0_200 = np.array([0.0, 0.0, 0.0, 0.5992, -0.7976, 0.6517])
"""Seed 000's 200 deg rest-to-rest start (docs/models.md's x(0), outside every certifiable region)."""
X0_90 = np.concatenate([np.zeros(3), X0_200[3:] / np.linalg.norm(X0_200[3:]) * np.tan(np.pi / 8)])
"""Default x(0) of the H2 bound: 90 deg rest-to-rest about the 200 deg case's axis."""
VARIANTS = ("slack", "common")


@dataclass
class Theorem8Result:
    """A solved and independently verified Theorem 8 design at fixed gamma, alpha, beta.

    Attributes
    ----------
    variant : {"slack", "common"}
        Separate X2, Xinf and slack F, or ``X2 = Xinf = F`` (:func:`theorem8`).
    gamma : float
        The L2-gain bound ``w -> z`` of the design (N m -> 1).
    alpha, beta : float
        The seed's scalars the SDP was solved at.
    lam : float
        The certified H2 bound lambda (below).
    X2, Xinf : numpy.ndarray, shape (n, n)
        The Lyapunov matrices of the H2 and the H-infinity condition (``V = x^T X^-1 x``).
    F : numpy.ndarray, shape (n, n)
        The slack matrix (below).
    Y : list of list of satfmu.synthesis.core.polynomial.Poly
        ``Y~(x~)``, m x n polynomials in ``x~`` (below).
    plant : SplitPlant
        The split plant the conditions were posed on.
    checks : list of satfmu.synthesis.core.sos.Check
        The independent verification of every SOS constraint.
    region : str
        Description of the certified region, e.g. ``"|sigma| <= 0.45, any omega"``.
    radius : float
        Radius of the region, ``|x~| <= radius`` (MRP, dimensionless).
    x0 : numpy.ndarray, shape (n,)
        Initial state of the H2 bound (rates in rad/s, MRPs).
    Qh, Rh : numpy.ndarray
        The H2 weights, shapes (n, n) and (m, m) (below).
    solution : satfmu.synthesis.core.sos.SOSSolution
        The solver's output mapped to the user's units (decision values and Gram matrices).
    timings : dict of str to float, optional
        ``"build"``, ``"solve"`` and ``"verify"`` times, s.
    coordinates : Coordinates, optional
        The units the program was solved in (:mod:`satfmu.synthesis.polynomial_feedback.coordinates`).
    frozen : bool
        The conditions were posed on the linearization (A frozen at the origin): no region.
    """

    variant: str
    gamma: float
    alpha: float
    beta: float
    lam: float
    """The certified H2 bound lambda (objective)."""
    X2: np.ndarray
    Xinf: np.ndarray
    F: np.ndarray
    """The slack matrix (constant: see the module notes)."""
    Y: list[list[Poly]]
    """Y~(x~): the law is ``u = Kg(x) x + Y~(x~) F^-1 x``."""
    plant: SplitPlant
    checks: list[Check]
    region: str
    radius: float
    x0: np.ndarray
    Qh: np.ndarray
    Rh: np.ndarray
    """The H2 weights the design used."""
    solution: SOSSolution
    timings: dict[str, float] = field(default_factory=dict)
    coordinates: Coordinates = field(default_factory=Coordinates.identity)
    frozen: bool = False

    @property
    def domain(self) -> list[dict[str, Any]] | None:
        """The region in numbers (:mod:`satfmu.controllers.domain`): the ball ``|x~| <= radius``;
        None for a frozen design (its claim holds at the origin only)."""
        return None if self.frozen else [domain.ball([str(x) for x in self.plant.tilde_symbols], self.radius)]
    """The units the program was solved in (the certificate is checked in the user's)."""

    @property
    def certified(self) -> bool:
        """Every SOS constraint passed :func:`satfmu.synthesis.core.sos.certify` and X2, Xinf and the
        lambda block are positive semidefinite (to 1e-9), checked without the solver."""
        return all(c.certified for c in self.checks) and _psd_margin(self) >= -1e-9

    def h2_level(self) -> float:
        """``x0^T X2^-1 x0`` (<= lambda): the H2 cost bound and the Lyapunov level from x0."""
        return float(self.x0 @ np.linalg.solve(self.X2, self.x0))

    def reach(self, X: np.ndarray, level: float) -> float:
        """Largest ``|x~|`` on the ellipsoid ``x^T X^-1 x <= level`` (any rates).

        Parameters
        ----------
        X : numpy.ndarray, shape (n, n)
            Positive definite matrix of the ellipsoid (``X2`` or ``Xinf``).
        level : float
            Level of the sublevel set (e.g. :meth:`h2_level`).
        """
        C = self.plant.C
        return float(np.sqrt(level * np.linalg.eigvalsh(C @ X @ C.T).max()))

    @property
    def h2_proved(self) -> bool:
        """The trajectory from x0 cannot leave the region: its Lyapunov sublevel set of X2
        lies inside ``|x~| <= radius`` (so ``J2 <= lambda`` is proved, not just local)."""
        return self.reach(self.X2, self.h2_level()) <= self.radius

    def disturbance_energy(self) -> float:
        """Largest ``||w||_2^2`` (N^2 m^2 s) from rest for which the state provably stays in
        the region: ``x^T Xinf^-1 x <= gamma^2 ||w||^2`` along trajectories."""
        return float(self.radius**2 / (self.gamma**2 * np.linalg.eigvalsh(
            self.plant.C @ self.Xinf @ self.plant.C.T).max()))

    @property
    def proved(self) -> str:
        h2 = ("J2 <= lambda = {:.6g} from x0 (its X2 sublevel set lies in the region)" if self.h2_proved
              else "J2 <= lambda = {:.6g} from x0 while the trajectory stays in the region").format(self.lam)
        return (f"mixed H2/H-infinity ({self.variant} Lyapunov matrices) on {self.region}: {h2}; "
                f"L2 gain w -> {self.plant.tilde_name} <= gamma = {self.gamma:g} from rest for "
                f"||w||_2^2 <= {self.disturbance_energy():.4g} (the state then stays in the region)")

    def law(self) -> sp.Matrix:
        """``u = Kg(x) x + Y~(x~) F^-1 x``, expanded polynomials in the state symbols."""
        xs = sp.Matrix(self.plant.symbols)
        Y = sp.Matrix([[p.to_sympy(self.plant.tilde_symbols) for p in row] for row in self.Y])
        Fi = sp.Matrix(np.linalg.inv(self.F))
        return (self.plant.Kg * xs + Y * (Fi * xs)).applyfunc(sp.expand)

    def law_terms(self) -> list[list[dict[str, Any]]]:
        """:meth:`law` as artifact terms (form "polynomial")."""
        xs = self.plant.symbols
        return [[{"c": float(c), "e": [int(v) for v in e]} for e, c in sp.Poly(u, *xs).terms() if c != 0]
                for u in self.law()]


def _psd_margin(r: Theorem8Result) -> float:
    """Smallest eigenvalue of X2, Xinf and the lambda block (independent of the solver)."""
    lam_block = np.block([[np.array([[r.lam]]), r.x0[None, :]], [r.x0[:, None], r.X2]])
    return float(min(np.linalg.eigvalsh(r.X2).min(), np.linalg.eigvalsh(r.Xinf).min(),
                     np.linalg.eigvalsh(lam_block).min() / max(1.0, r.lam)))


@dataclass
class _Program:
    """Theorem 8 posed on one plant in one set of units, with its decision matrices."""

    prog: SOSProgram
    F: PolyMatrix
    X2: PolyMatrix
    Xinf: PolyMatrix
    Y: PolyMatrix
    lam_idx: np.ndarray
    label: str
    """The region the conditions hold on."""


def _program(plant: SplitPlant, gamma: float, alpha: float, beta: float, Qh: np.ndarray, Rh: np.ndarray,
             x0: np.ndarray, margins: tuple[np.ndarray, np.ndarray, np.ndarray], h2_weights: np.ndarray,
             hinf_weights: np.ndarray, *, variant: str, region: float, y_degree: int, multiplier_degree: int,
             frozen: bool) -> _Program:
    """Theorem 8's program (module notes) on ``plant`` with diagonal margins ``(H2, Hinf, X)`` and
    the multiplier weight of every row of each condition."""
    n, m, nt = plant.n, plant.m, len(plant.tilde)
    prog = SOSProgram(nt)  # the conditions depend on x~ only
    zero = np.zeros((1, nt), np.int64)
    if variant == "common":
        F = PolyMatrix(prog.new_symmetric(n))
        X2 = Xinf = F
    else:
        F = PolyMatrix([[prog.new_poly(zero) for _ in range(n)] for _ in range(n)])
        X2, Xinf = PolyMatrix(prog.new_symmetric(n)), PolyMatrix(prog.new_symmetric(n))
    Y = PolyMatrix([[prog.new_poly(monomials(nt, y_degree)) for _ in range(n)] for _ in range(m)])
    lam_idx = prog.new_variables(1)

    def const(M: np.ndarray) -> PolyMatrix:
        return PolyMatrix.constant(M, nt)

    # A F + Bu Y with Y = Y~ + Kg F: the actuated rows of A cancel (A~ = A + Bu Kg)
    AFBY = plant.A_tilde @ F + const(plant.Bu) @ Y
    G11 = AFBY + AFBY.T
    FFt = F + F.T
    M2 = PolyMatrix.block([
        [G11, None, None, None],
        [X2 - F + AFBY.T.scale(alpha), -FFt.scale(alpha), None, None],
        [F, F.scale(alpha), const(-np.linalg.inv(Qh)), None],
        [Y, Y.scale(alpha), None, const(-np.linalg.inv(Rh))],
    ])
    CF = const(plant.C) @ F
    Minf = PolyMatrix.block([
        [G11, None, None, None],
        [Xinf - F + AFBY.T.scale(beta), -FFt.scale(beta), None, None],
        [const(plant.Bw.T), None, const(-gamma**2 * np.eye(plant.Bw.shape[1])), None],
        [CF, CF.scale(beta), None, const(-np.eye(plant.C.shape[0]))],
    ])
    if frozen:  # constant matrices: plain LMIs, no region
        regions, label = None, "x = 0 (A frozen at the origin: the linearization)"
    else:
        regions = [Poly.from_sympy(region**2 - sum(x**2 for x in plant.tilde_symbols), plant.tilde_symbols)]
        label = f"|{plant.tilde_name}| <= {region:g}, any {plant.actuated_name}"
    for name, M, margin, weights in (("H2", M2, margins[0], h2_weights), ("Hinf", Minf, margins[1], hinf_weights)):
        # only the first two block rows are quadratic in x~; the weight rows are at most
        # linear and need no multiplier (smaller Gram basis)
        rows = range(2 * n) if y_degree <= 1 else range(M.shape[0])
        prog.add_sos_matrix((M + const(np.diag(margin))).symmetric_from_lower().scale(-1.0), f"-M_{name}",
                            region=regions, multiplier_degree=multiplier_degree, label=label,
                            multiplier_rows=rows, multiplier_weights=weights[list(rows)].tolist())
    prog.add_psd_constant(X2.entries, "X2 > 0", margin=margins[2])
    if variant == "slack":
        prog.add_psd_constant(Xinf.entries, "Xinf > 0", margin=margins[2])
    # [lambda x0^T; x0 X2] >= 0
    lam = Poly(zero, np.zeros(1), prog.selector(lam_idx))
    x0c = [Poly.constant(v, nt) for v in x0]
    block = [[lam] + x0c] + [[x0c[i]] + X2.entries[i] for i in range(n)]
    prog.add_psd_constant(block, "lambda bound")
    return _Program(prog, F, X2, Xinf, Y, lam_idx, label)


def _in_user_units(scaled: _Program, user: _Program, sol: SOSSolution, coords: Coordinates, plant: SplitPlant,
                   rows: tuple[np.ndarray, np.ndarray]) -> SOSSolution:
    """The scaled program's solution as a solution of the user-unit program: the decision
    matrices mapped back (``T F T``, ``torque Y T``; multipliers and lambda unchanged) and each
    SOS-matrix Gram matrix by its congruence (a basis monomial ``v_i z(x)`` scales by ``D_i``)."""
    y = np.array(sol.y, float)
    Yu = coords.gain_numerator(plant, PolyMatrix([[p.value(sol.y) for p in row] for row in scaled.Y.entries]))
    for M, values in ((user.F, coords.matrix(plant, scaled.F.evaluate(np.zeros(scaled.F.n_vars), sol.y))),
                      (user.X2, coords.matrix(plant, scaled.X2.evaluate(np.zeros(scaled.X2.n_vars), sol.y))),
                      (user.Xinf, coords.matrix(plant, scaled.Xinf.evaluate(np.zeros(scaled.Xinf.n_vars), sol.y)))):
        for i, row in enumerate(M.entries):
            for j, p in enumerate(row):
                y[p.C.indices] = values[i, j]
    for row, urow in zip(user.Y.entries, Yu.entries):
        for p, pu in zip(row, urow):
            # the same exponent rows in the same order: Y's coefficients are fresh variables
            order = {tuple(e): k for k, e in enumerate(pu.exps)}
            y[p.C.indices] = [pu.c0[order[tuple(e)]] if tuple(e) in order else 0.0 for e in p.exps]
    grams = {}
    for k, (cs, cu) in enumerate(zip(scaled.prog.sos, user.prog.sos)):
        key = f"{k}:{cs.name}"
        if key not in sol.grams:
            continue
        if not np.array_equal(cs.basis, cu.basis):
            raise SOSError(f"{cs.name}: the scaled and user-unit programs have different Gram bases")
        G = sol.grams[key]
        if cs.basis.shape[1] > scaled.prog.n_vars:  # SOS matrix: basis v_i z(x)
            d = rows[0] if cs.name == "-M_H2" else rows[1]
            scale = d[np.argmax(cs.basis[:, scaled.prog.n_vars:], axis=1)]
            G = G * np.outer(scale, scale)
        grams[key] = G
    return SOSSolution(y, grams, sol.status, sol.solver, float(y[user.lam_idx[0]]), dict(sol.timings))


def theorem8(gamma: float, alpha: float, beta: float, variant: str = "slack", region: float = 0.45,
             y_degree: int = 1, Qh: np.ndarray | None = None, Rh: np.ndarray | None = None,
             x0: np.ndarray = X0_90, margin: float = 1e-6, multiplier_degree: int = 0,
             frozen: bool = False, model: Model | None = None,
             coordinates: Coordinates | None = None) -> Theorem8Result:
    """Solve Theorem 8 at fixed ``gamma``, ``alpha``, ``beta`` (minimize lambda).

    Parameters
    ----------
    gamma : float
        L2-gain bound w -> sigma to certify (N m -> 1).
    alpha, beta : float
        The seed's scalars (> 0), fixed here; see
        :func:`satfmu.synthesis.polynomial_feedback.h2hinf_search.search`.
    variant : {"slack", "common"}
        Separate X2, Xinf and slack F (the seed's design) or X2 = Xinf = F.
    region : float
        Certificate region ``|x~| <= region`` (x~: the MRPs), any rates.
    y_degree : int
        Degree in x~ of every entry of Y~(x~) (0 or 1: higher degrees put the weight rows'
        entries at degree 2 and every row needs a multiplier).
    Qh, Rh : ndarray, optional
        H2 weights (default I6, I3: **substitute**, the seed gives none).
    x0 : numpy.ndarray, shape (n,), optional
        Initial state of the H2 bound ``J2 <= lambda`` (rates in rad/s, then MRPs); default
        :data:`X0_90`.
    margin : float
        Margin ``e`` on the diagonal blocks of both SOS-matrix conditions (``a e`` on the
        F block) and on X2, Xinf.
    multiplier_degree : int
        Degree of the S-procedure multipliers of the region (even).
    frozen : bool
        Freeze A(x) at x = 0 (the linearization; LMIs): the reference design of docs/models.md.
    model : Model, optional
        The plant, with an SDC form whose input columns are ``[u w]`` (default the MRP
        satellite, ``satfmu.fmus.plants.mrp_satellite.MODEL``).
    coordinates : Coordinates, optional
        Units of the solved program (default
        :meth:`satfmu.synthesis.polynomial_feedback.coordinates.Coordinates.balanced` for this plant,
        weights and scalars; ``Coordinates.identity()``: the user's units). The result and its
        certificate are in the user's units whatever these are.

    Raises
    ------
    ValueError
        On invalid scalars, degrees, variant or weights, or a model whose conditions do
        not reduce to x~ after the actuated rows are cancelled.
    satfmu.synthesis.core.sos.SOSError
        If the program is infeasible at these values.
    """
    model = mrp_satellite.MODEL if model is None else model
    if variant not in VARIANTS:
        raise ValueError(f"variant must be one of {VARIANTS}, got {variant!r}")
    for name, v in (("gamma", gamma), ("alpha", alpha), ("beta", beta), ("region", region)):
        if not (np.isfinite(v) and v > 0):
            raise ValueError(f"{name} must be finite and > 0, got {v}")
    if int(y_degree) != y_degree or y_degree < 0:
        raise ValueError(f"y_degree must be a non-negative integer, got {y_degree}")
    t0 = time.perf_counter()
    plant = split(model, frozen)
    n, m, nt = plant.n, plant.m, len(plant.tilde)
    Qh = np.eye(n) if Qh is None else np.asarray(Qh, float)
    Rh = np.eye(m) if Rh is None else np.asarray(Rh, float)
    for name, W, k in (("Qh", Qh, n), ("Rh", Rh, m)):
        if W.shape != (k, k) or not np.allclose(W, W.T) or np.linalg.eigvalsh(W).min() <= 0:
            raise ValueError(f"{name} must be a symmetric positive definite {k} x {k} matrix")
    x0 = np.asarray(x0, float)
    if x0.shape != (n,) or not np.all(np.isfinite(x0)):
        raise ValueError(f"x0 must be {n} finite numbers")

    coords = (Coordinates.balanced(plant, Qh, Rh, alpha, beta) if coordinates is None else coordinates)
    scaled = coords.plant(plant)
    Qs, Rs = coords.weights(plant, Qh, Rh)
    e = margin
    # the margins of the scaled program, e diag(I, a I, I) on each condition (so F + F^T >= e I)
    m2 = e * np.concatenate([np.ones(n), np.full(n, coords.scalar(alpha)), np.ones(n + m)])
    minf = e * np.concatenate([np.ones(n), np.full(n, coords.scalar(beta)), np.ones(n)])
    options: dict[str, Any] = dict(variant=variant, region=region, y_degree=y_degree,
                                   multiplier_degree=multiplier_degree, frozen=frozen)
    solved = _program(scaled, coords.gamma(gamma), coords.scalar(alpha), coords.scalar(beta), Qs, Rs,
                      coords.state(plant, x0), (m2, minf, np.full(n, e)), np.ones(len(m2)), np.ones(len(minf)),
                      **options)
    t1 = time.perf_counter()
    # tighter than Clarabel's defaults (1e-8): the optimum sits on the cone boundary and the
    # independent verification checks coefficient residuals at 1e-7 relative
    sol = solved.prog.solve(objective=solved.prog.selector(solved.lam_idx), tol_feas=1e-10, tol_gap_abs=1e-10,
                            tol_gap_rel=1e-10)
    t2 = time.perf_counter()
    # the same conditions in the user's units: the congruences D M' D of the module notes
    d2, dinf = coords.h2_rows(plant), coords.hinf_rows(plant)
    t = coords.states(plant)
    user = _program(plant, gamma, alpha, beta, Qh, Rh, x0, (d2**2 * m2, dinf**2 * minf, t**2 * e),
                    d2**2, dinf**2, **options)
    user_sol = _in_user_units(solved, user, sol, coords, plant, (d2, dinf))
    checks = certify(user.prog, user_sol, sample_radius=region)
    timings = {"build": t1 - t0 + sol.timings["build"], "solve": sol.timings["solve"],
               "verify": time.perf_counter() - t2}

    def num(M: PolyMatrix) -> np.ndarray:
        return M.evaluate(np.zeros(nt), user_sol.y)

    def polys(M: PolyMatrix) -> list[list[Poly]]:
        return [[p.value(user_sol.y) for p in row] for row in M.entries]

    return Theorem8Result(variant, float(gamma), float(alpha), float(beta), float(user_sol.y[user.lam_idx[0]]),
                          num(user.X2), num(user.Xinf), num(user.F), polys(user.Y), plant, checks, user.label,
                          float(region), x0, Qh, Rh, user_sol, timings, coords, frozen)


@dataclass(frozen=True)
class ClosedLoopCheck:
    """The law on the nonlinear plant, independent of the solver (continuous time, no w).

    Attributes
    ----------
    j2 : float
        Simulated H2 cost (below; inf if the integration failed).
    tail : float
        The certificate's remaining cost after ``stop_time`` (below).
    max_tilde : float
        Largest ``|x~|`` along the trajectory (MRP, dimensionless).
    max_real_eig : float
        Largest real part of the eigenvalues of the linearized closed loop, 1/s.
    stop_time : float
        Length of the simulation, s.
    lam : float
        The certified bound lambda of the design.
    peak_torque : float
        Largest ``|u_i|`` along the trajectory (at the integrator's steps), N m.
    """

    j2: float
    """``integral of x^T Qh x + u^T Rh u`` from x0 over ``stop_time`` (must be <= lambda)."""
    tail: float
    """``x(T)^T X2^-1 x(T)``: what the certificate still allows after ``stop_time``."""
    max_tilde: float
    """Largest ``|x~|`` along the trajectory (the certificate needs it <= the region radius)."""
    max_real_eig: float
    """Largest real part of the closed loop linearized at the origin (< 0: locally stable)."""
    stop_time: float
    lam: float
    """The certified bound."""
    peak_torque: float = float("nan")

    @property
    def passed(self) -> bool:
        """Locally stable and the simulated cost within the certified bound."""
        return bool(self.max_real_eig < 0 and np.isfinite(self.j2) and self.j2 <= self.lam)


def closed_loop_check(result: Theorem8Result, stop_time: float = 300.0,
                      model: Model | None = None) -> ClosedLoopCheck:
    """Simulate ``x' = f(x, u(x))`` from x0 (scipy DOP853, rtol 1e-10) with the cost (the
    design's weights) as an extra state, and linearize the closed loop at the origin.

    Parameters
    ----------
    result : Theorem8Result
        The design whose law is simulated, from its ``x0``.
    stop_time : float, optional
        Simulated time, s. Default 300.
    model : Model, optional
        The plant simulated, the one the design was made for (default the MRP satellite,
        ``satfmu.fmus.plants.mrp_satellite.MODEL``).
    """
    model = mrp_satellite.MODEL if model is None else model
    xs = result.plant.symbols
    n, m = result.plant.n, result.plant.m
    Qh, Rh = result.Qh, result.Rh
    law = result.law()
    u_of = sp.lambdify([xs], list(law), "numpy")
    plant = codegen.load_python(model)
    p = model.parameter_vector().tolist()
    n_inputs = len(model.inputs)

    def rhs(_t: float, z: np.ndarray) -> np.ndarray:
        x = z[:n]
        u = np.asarray(u_of(x), float)
        dx = plant.derivatives(0.0, x.tolist(), x.tolist(), list(u) + [0.0] * (n_inputs - m), p)
        return np.concatenate([dx, [x @ Qh @ x + u @ Rh @ u]])

    sol = solve_ivp(rhs, (0.0, stop_time), np.concatenate([result.x0, [0.0]]), method="DOP853",
                    rtol=1e-10, atol=1e-12, dense_output=False)
    xT = sol.y[:n, -1]
    subs = {v.symbol: v.start for v in model.parameters}
    f = sp.Matrix(model.rhs).subs(subs).subs(dict(zip([v.symbol for v in model.inputs[:m]], law)))
    f = f.subs({v.symbol: 0 for v in model.inputs[m:]})
    J = np.array(f.jacobian(xs).subs({x: 0 for x in xs}), float)
    tilde = np.linalg.norm(sol.y[list(result.plant.tilde)], axis=0)
    peak = max(float(np.abs(np.asarray(u_of(x), float)).max()) for x in sol.y[:n].T)
    return ClosedLoopCheck(float(sol.y[n, -1]) if sol.success else float("inf"),
                           float(xT @ np.linalg.solve(result.X2, xT)), float(tilde.max()),
                           float(np.linalg.eigvals(J).real.max()), stop_time, result.lam, peak)


def artifact_data(result: Theorem8Result, name: str, check: ClosedLoopCheck,
                  model: Model | None = None) -> dict[str, Any]:
    """Controller artifact (format of :mod:`satfmu.controllers.artifact`, form "polynomial").

    Status "certified" needs the SOS checks and the closed-loop check to pass.

    Parameters
    ----------
    result : Theorem8Result
        The design.
    name : str
        Name of the controller artifact.
    check : ClosedLoopCheck
        Its closed-loop check (:func:`closed_loop_check`).
    model : Model, optional
        The plant the controller is for (default the MRP satellite,
        ``satfmu.fmus.plants.mrp_satellite.MODEL``).

    Returns
    -------
    dict
        The artifact's JSON data (:func:`satfmu.controllers.artifact.new_data`).
    """
    model = mrp_satellite.MODEL if model is None else model
    ok = result.certified and check.passed
    return artifacts.new_data(
        model, name,
        (f"Seed 001 Theorem 8 mixed H2/H-infinity state feedback u = omega x I omega + Y(sigma) F^-1 x "
         f"({result.variant} Lyapunov matrices, gamma = {result.gamma:g}), synthesized by satfmu"),
        law={"form": "polynomial", "terms": result.law_terms()},
        lyapunov={"Q": result.X2.tolist(), "note": "X2: V = x^T X2^-1 x, J2 <= x0^T X2^-1 x0 <= lambda"},
        certificate={
            "status": "certified" if ok else "not_verified",
            "proved": result.proved, "region": result.region,
            **({} if result.domain is None else {"domain": result.domain}),
            "numbers": {**check_numbers(result.checks), "lambda": result.lam, "gamma": result.gamma,
                        "alpha": result.alpha, "beta": result.beta, "psd_margin": _psd_margin(result),
                        "h2 level x0^T X2^-1 x0": result.h2_level(),
                        "max disturbance energy ||w||^2 (N^2 m^2 s)": result.disturbance_energy(),
                        f"simulated J2 over {check.stop_time:g} s": check.j2,
                        "simulated tail bound x(T)^T X2^-1 x(T)": check.tail,
                        f"max |{result.plant.tilde_name}| along the x0 trajectory": check.max_tilde,
                        "max real part of eig(Acl(0))": check.max_real_eig,
                        "peak |u_i| along the x0 trajectory (N m)": check.peak_torque},
            "h2": {"lambda": result.lam, "x0": result.x0.tolist(), "sublevel_set_in_region": result.h2_proved,
                   "Qh": result.Qh.tolist(), "Rh": result.Rh.tolist()},
            "Xinf": result.Xinf.tolist(), "F": result.F.tolist(),
        },
        provenance={"source": "satfmu satfmu.synthesis.polynomial_feedback.h2hinf_sos.theorem8 (seed 001 Theorem 8)",
                    "solver": result.solution.solver, "timings_s": result.timings,
                    "solved_in_units": {"time_s": result.coordinates.time, "rate_rad_per_s": result.coordinates.rate,
                                        "torque_N_m": result.coordinates.torque,
                                        "note": "the certificate is checked in SI units"}})
