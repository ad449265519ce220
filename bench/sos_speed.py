"""SOS engine speed, end to end: satfmu vs Drake's MathematicalProgram vs SumOfSquares.py.

Four programs of the project (issue 29), each posed by the three tools:

``thm1-global``
    Seed 000 Theorem 1, global (:func:`satfmu.synthesis.polynomial_feedback.hinf_sos.theorem1` with ``rate_margin``
    1e-2): constant ``Q >= I``, ``K(x)`` 3 x 6 of degree 2, ``-(A Q + Q A^T + B K + K^T B^T) -
    diag(eps I3, 0)`` an SOS matrix, minimize trace(Q).
``thm1-regional``
    The same on ``|sigma| <= 0.9`` (``theorem1(region=0.9)``, as the project's tests pose
    it): strict margin ``1e-3 I``, one S-procedure multiplier of degree 0.
``thm8-regional``
    Seed 001 Theorem 8, slack variant, gamma 0.7 at the alpha, beta of the shipped design
    (controllers/artifacts/mrp_h2hinf_satfmu.json), ``|sigma| <= 0.45`` for every rate
    (:func:`satfmu.synthesis.polynomial_feedback.h2hinf_sos.theorem8`): two SOS matrices of 21 x 21 with a multiplier
    each, three LMIs, minimize lambda, Clarabel tolerances 1e-10.
``vscmg-box``
    Seed 002 region certificate of the approximated SDRE servo on
    :data:`satfmu.synthesis.servo.vscmg_region.OPERATING_BOX` (:func:`satfmu.synthesis.servo.vscmg_region.certify`):
    two 7 x 7 SOS matrices (cos q2 on the chord and on the tangent) with Finsler multipliers
    of degree 4 and two box multipliers of degree 4 each, ``Y >= I``, ``trace Y <= 100``,
    maximize eps.

The contenders, each end to end and each verifying its own certificate:

- satfmu: the public function above, as a user calls it (build, solve and verify: Gram
  eigenvalues, coefficient residuals, sampled values; see :func:`satfmu.synthesis.core.sos.verify`).
  "without verify" is the same run minus the time after the solve returned.
- Drake (PyPI ``drake``, bench extra): the same program written with
  ``pydrake.solvers.MathematicalProgram``: the plant data converted from the same sympy
  model (``sympy.Poly`` terms to ``pydrake.symbolic.Polynomial``), the products done with
  Drake's polynomial arithmetic, decision variables and multipliers of the same degrees
  (``NewFreePolynomial``), each SOS condition an ``AddSosConstraint`` on *our* Gram basis
  (extracted from our program, monomial by monomial), LMIs with
  ``AddLinearMatrixInequalityConstraint``; solved by Drake's Clarabel (``ClarabelSolver``,
  Clarabel 0.11 like the wheel we call, default settings and the same options as ours);
  then Drake's Gram matrices checked as :func:`satfmu.synthesis.core.sos.verify` checks ours.
- SumOfSquares.py (PyPI, bench extra): the same program with its sympy/picos API
  (``add_matrix_sos_constraint``, its own Newton-polytope basis: it takes none from the
  caller), solved by CVXOPT (picos offers no Clarabel), then the same three checks. Slow:
  ``--sospy-rounds`` limits the rounds it takes part in; a program it cannot pose is skipped
  with the reason printed. Each of its runs is a forked child process stopped after
  ``--sospy-limit`` seconds or when its resident memory passes ``--sospy-memory`` GiB (its
  sympy expansion of the larger programs grows past 12 GiB): then the reason is printed and
  the ratio as a bound, ours / SumOfSquares.py < (our median) / (the time it ran).

Before timing, each program is run once by each tool (warm-up, not timed) and Drake's
program is compared with ours coefficient by coefficient: every SOS polynomial (as affine
functions of the decision vector, in our variable order), every Gram basis, every LMI,
linear constraint and the objective. Then ``--repeat`` rounds run the tools interleaved
(satfmu, Drake, SumOfSquares.py, satfmu, ...; the machine is shared and noisy). Printed per
program: Gram basis sizes, objectives, min and median of each tool's end-to-end time, the
medians of its build / solver / verify split ("solver": the time Clarabel reports for ours
and Drake's, the picos solve call for SumOfSquares.py; "build": everything before it,
our or Drake's translation to the solver's form included), and the ratios of medians
ours/Drake (end to end and of the build) and ours/SumOfSquares.py. Drake's warm-up run is a
forked child given ``--drake-limit`` seconds: past them (Drake's one-thread QDLDL takes more
than 10 minutes on the vscmg box) Drake's timed rounds stop Clarabel after one iteration
(``max_iter`` 1), which times its whole build, and the end-to-end ratio is printed as a bound.

    python bench/sos_speed.py [--repeat 5] [--programs thm1-global ...] [--sospy-rounds 1]
                              [--sospy-limit 600] [--sospy-memory 12] [--drake-limit 300]

What the bench reads from our side: the public functions above, the :class:`SOSProgram`
each one solves (caught in :meth:`SOSProgram.solve`: its ``sos`` constraints' ``basis``
and ``poly`` (``exps``, ``c0``, ``C``), ``psd``, ``inequalities``, ``equalities``,
``n_decision``), the :class:`SOSSolution` it returns (``objective``) and Clarabel's Python
``DefaultSolver`` (its reported ``solve_time``).
"""
from __future__ import annotations

import argparse
import functools
import multiprocessing
import time
from importlib import metadata
from dataclasses import dataclass
from typing import Any, Callable, Iterator

import numpy as np
import scipy.linalg as sla
import sympy as sp

from satfmu.controllers import artifact
from satfmu.controllers.polynomial import ARTIFACTS
from satfmu.fmus.plants import mrp_satellite
from satfmu.synthesis.polynomial_feedback import h2hinf_sos, hinf_sos, split_plant
from satfmu.synthesis.polynomial_feedback.coordinates import Coordinates
from satfmu.synthesis.servo import vscmg_region
from satfmu.synthesis.core.polynomial import Poly, monomials
from satfmu.synthesis.core.conic import THREADED_FROM
from satfmu.synthesis.core.sos import SOSProgram
from timing import interleaved, min_median

N_SAMPLES = 2000
"""Sampled points per SOS constraint in every tool's verification (as :func:`satfmu.synthesis.core.sos.verify`)."""
EIG_TOL = RES_TOL = 1e-7
"""Relative tolerances of the verification (those of :func:`satfmu.synthesis.core.sos.verify`)."""


# ---------------------------------------------------------------------------- records
@dataclass
class Run:
    """One end-to-end run of one tool on one program (wall-clock seconds).

    ``build`` is what is neither the solver nor the verification: posing the program and
    translating it to the solver's form.
    """

    total: float
    solver: float
    verify: float
    objective: float
    gram_sizes: tuple[int, ...]
    min_eig: float
    """Smallest Gram eigenvalue over the SOS constraints."""
    residual: float
    """Largest coefficient residual ``|p - z^T G z|`` over the SOS constraints."""
    certified: bool

    @property
    def build(self) -> float:
        return self.total - self.solver - self.verify

    @property
    def without_verify(self) -> float:
        return self.total - self.verify


@dataclass
class Gram:
    """Verification numbers of one SOS constraint: ``p = z^T G z``, ``G >= 0``, ``p >= 0`` sampled."""

    size: int
    min_eig: float
    residual: float
    sampled_min: float
    certified: bool


def _judge(G: np.ndarray, residual: float, pscale: float, sampled_min: float) -> Gram:
    """The numbers of one constraint and the rule of :func:`satfmu.synthesis.core.sos.verify` on them."""
    min_eig = float(np.linalg.eigvalsh((G + G.T) / 2).min())
    gscale = max(1.0, float(np.max(np.abs(G))))
    pscale = max(1.0, pscale)
    N = G.shape[0]
    ok = min_eig >= -EIG_TOL * gscale and residual <= RES_TOL * pscale and sampled_min >= -RES_TOL * pscale * N
    return Gram(N, min_eig, residual, sampled_min, bool(ok))


def _sample_points(rng: np.random.Generator, n_x: int, n_v: int, radius: float) -> np.ndarray:
    """Points as :func:`satfmu.synthesis.core.sos.verify` draws them: uniform in the ball of ``radius``
    in all ``n_x + n_v`` variables, then the last ``n_v`` (those of an SOS matrix's ``v``)
    redrawn on the unit sphere. Shape (N_SAMPLES, n_x + n_v)."""
    n = n_x + n_v
    pts = rng.normal(size=(N_SAMPLES, n))
    pts *= (radius * rng.random(N_SAMPLES) ** (1 / n) / np.linalg.norm(pts, axis=1))[:, None]
    if n_v:
        v = rng.normal(size=(N_SAMPLES, n_v))
        pts[:, n_x:] = v / np.linalg.norm(v, axis=1, keepdims=True)
    return pts


def _summarize(grams: list[Gram], total: float, solver: float, verify: float, objective: float) -> Run:
    return Run(total, solver, verify, objective, tuple(g.size for g in grams),
               min((g.min_eig for g in grams), default=float("nan")),
               max((g.residual for g in grams), default=float("nan")), all(g.certified for g in grams))


# ---------------------------------------------------------------------------- satfmu
@dataclass
class Caught:
    """What :class:`_Probe` saw of one run: the program solved, its objective row, its solution."""

    program: SOSProgram
    objective: Any
    solution: Any
    settings: dict[str, Any]
    """The Clarabel settings the program was solved with (those of the call, the ladder's first rung)."""


class _Probe:
    """Looks into one run of a public satfmu function from outside, without changing it.

    Inside ``with probe:`` :meth:`SOSProgram.solve` and ``clarabel.DefaultSolver`` are
    wrapped (the solver :func:`satfmu.synthesis.core.conic.solve_clarabel` calls): the probe keeps the
    last program solved (with its objective row and solution), the time its solve returned,
    and the solver's own time
    (Clarabel's ``solve_time``, summed over calls, s). With ``qdldl`` Clarabel factors its
    KKT systems with QDLDL on one thread (Drake's only choice) instead of faer (on the
    threads :func:`satfmu.synthesis.core.conic.threads_for` gives it).
    """

    def __init__(self, qdldl: bool = False) -> None:
        self.qdldl = qdldl
        self.caught: Caught | None = None
        self.solved_at = float("nan")
        self.solver = 0.0

    def __enter__(self) -> "_Probe":
        import clarabel

        self._sos_solve, self._clarabel = SOSProgram.solve, clarabel.DefaultSolver
        probe, sos_solve, make_solver = self, SOSProgram.solve, clarabel.DefaultSolver

        def solve(prog: SOSProgram, *args: Any, **kwargs: Any) -> Any:
            sol = sos_solve(prog, *args, **kwargs)
            probe.caught = Caught(prog, kwargs.get("objective", args[0] if args else None), sol,
                                  {k: v for k, v in kwargs.items() if k != "objective"})
            probe.solved_at = time.perf_counter()
            return sol

        class TimedSolver:
            """Clarabel's solver, adding each solve's reported time to the probe."""

            def __init__(self, P: Any, q: Any, A: Any, b: Any, cones: Any, settings: Any) -> None:
                if probe.qdldl:  # as Drake's Clarabel runs
                    settings.direct_solve_method, settings.max_threads = "qdldl", 1
                self._solver = make_solver(P, q, A, b, cones, settings)

            def solve(self) -> Any:
                out = self._solver.solve()
                probe.solver += float(out.solve_time)
                return out

            def __getattr__(self, name: str) -> Any:
                return getattr(self._solver, name)

        SOSProgram.solve = solve  # type: ignore[method-assign]
        clarabel.DefaultSolver = TimedSolver
        return self

    def __exit__(self, *exc: object) -> None:
        import clarabel

        SOSProgram.solve = self._sos_solve  # type: ignore[method-assign]
        clarabel.DefaultSolver = self._clarabel


def run_ours(fn: Callable[[], Any], qdldl: bool = False) -> tuple[Run, Caught]:
    """One end-to-end run of our public function ``fn`` (its result has ``checks`` and
    ``certified``), timed, with the program it solved (``qdldl``: see :class:`_Probe`)."""
    with _Probe(qdldl) as probe:
        t0 = time.perf_counter()
        result = fn()
        total = time.perf_counter() - t0
    if probe.caught is None:
        raise RuntimeError("the function solved no SOSProgram")
    grams = [Gram(c.basis_size, c.min_eig, c.residual, c.sampled_min, c.certified) for c in result.checks]
    run = _summarize(grams, total, probe.solver, t0 + total - probe.solved_at, float(probe.caught.solution.objective))
    run.certified = bool(result.certified)
    return run, probe.caught


# ---------------------------------------------------------------------------- Drake
@dataclass
class DrakeSos:
    """One SOS constraint of a Drake program: ``p`` in ``variables``, its basis and Gram matrix."""

    p: Any
    variables: np.ndarray
    """satfmu's order of the constraint's variables: x, then v of an SOS matrix."""
    basis: np.ndarray
    gram: np.ndarray
    n_v: int


@dataclass
class DrakeProgram:
    """One bench program posed with Drake's MathematicalProgram, and what its checks need."""

    prog: Any
    sos: list[DrakeSos]
    """In the order of our program's SOS constraints."""
    layout: list[tuple[str, Any]]
    """The decision variables in our order, as pieces: ("sym", matrix: upper triangle row by
    row), ("matrix", matrix: row by row), ("var", variable), ("poly", (polynomial, x,
    degree): its coefficients in the order of :func:`satfmu.synthesis.core.polynomial.monomials`)."""
    lmis: list[np.ndarray]
    """Expression matrices constrained PSD, in our order."""
    linear_ge: list[Any]
    """Expressions constrained ``>= 0``, in our order."""
    objective: Any
    options: dict[str, float]
    sample_radius: float


def _drake() -> Any:
    """The pydrake modules (imported on first use: drake is a bench-only extra)."""
    import pydrake.solvers as solvers
    import pydrake.symbolic as sym

    return sym, solvers


def _drake_arithmetic(fn: Callable[..., DrakeProgram]) -> Callable[..., DrakeProgram]:
    """``fn`` run with numpy's "invalid" floating-point warning off: numpy checks the
    floating-point flags after each ufunc on object arrays (matmul, add, ...) and Drake's
    symbolic code raises the invalid flag in its own NaN checks, so every product of
    polynomial matrices would warn. (The coefficients are compared with ours: no NaN.)"""
    @functools.wraps(fn)
    def quiet(*args: Any, **kwargs: Any) -> DrakeProgram:
        with np.errstate(invalid="ignore"):
            return fn(*args, **kwargs)
    return quiet


def _to_drake(expr: sp.Expr, gens: list[sp.Symbol], variables: np.ndarray) -> Any:
    """A sympy polynomial in ``gens`` with numeric coefficients as a Drake polynomial in ``variables``."""
    sym, _ = _drake()
    terms = sp.Poly(expr, *gens).terms()
    return sym.Polynomial({sym.Monomial(variables, np.asarray(e, np.int32)): sym.Expression(float(c))
                           for e, c in terms if c != 0})


def _constant(value: Any) -> Any:
    """A number or a decision-variable expression as a Drake polynomial of degree 0."""
    sym, _ = _drake()
    return sym.Polynomial({sym.Monomial(): sym.Expression(value)})


def _substitute(p: Any, sub: list[tuple[Any, Any]]) -> Any:
    """``p`` with each of its indeterminates replaced by a polynomial (``sub``: pairs of
    variable and polynomial), expanded.

    Written out (powers cached per variable) because Drake 1.51's
    ``Polynomial.SubstituteAndExpand`` fails on some of this bench's polynomials ("The
    exponent is negative": its cache of monomial expansions divides by a cached monomial
    that does not divide the one it expands).
    """
    sym, _ = _drake()
    by_id = {var.get_id(): q for var, q in sub}
    powers: dict[tuple[int, int], Any] = {}

    def power(var: int, k: int) -> Any:
        if (var, k) not in powers:
            powers[var, k] = by_id[var] if k == 1 else power(var, k - 1) * by_id[var]
        return powers[var, k]

    out = sym.Polynomial()
    for m, coef in p.monomial_to_coefficient_map().items():
        term = sym.Polynomial({sym.Monomial(): coef})
        for var, k in m.get_powers().items():
            term *= power(var.get_id(), k)
        out += term
    return out


def _var_matrix(M: np.ndarray) -> np.ndarray:
    """A matrix of decision variables as constant Drake polynomials."""
    return np.vectorize(_constant, otypes=[object])(M)


def _quadratic_form(S: np.ndarray, v: np.ndarray) -> Any:
    """``v^T S v`` for a symmetric matrix ``S`` of Drake polynomials (``v`` indeterminates)."""
    sym, _ = _drake()
    q = sym.Polynomial()
    for i in range(S.shape[0]):
        q += S[i, i] * sym.Monomial(v[i], 2)
        for j in range(i + 1, S.shape[0]):
            q += 2 * S[i, j] * (sym.Monomial(v[i]) * sym.Monomial(v[j]))
    return q


def _add_sos(prog: Any, p: Any, variables: np.ndarray, basis: np.ndarray, n_v: int = 0) -> DrakeSos:
    """``p`` SOS on the monomial basis given as exponent rows over ``variables``."""
    sym, _ = _drake()
    z = np.array([sym.Monomial(variables, row.astype(np.int32)) for row in basis])
    return DrakeSos(p, variables, z, prog.AddSosConstraint(p, z), n_v)


def _add_sos_matrix(prog: Any, S: np.ndarray, x: np.ndarray, v: np.ndarray, bases: Iterator[np.ndarray],
                    region: list[Any], multiplier_degree: int, rows: range | None = None) -> list[DrakeSos]:
    """``S(x) >= 0`` as an SOS matrix where every ``g in region`` is ``>= 0``, posed as
    :meth:`satfmu.synthesis.core.sos.SOSProgram.add_sos_matrix` does: ``v^T S v - sum_i s_i g_i
    v_R^T v_R`` SOS with SOS multipliers ``s_i`` of ``multiplier_degree`` (``v_R``: the
    entries of ``v`` in ``rows``, default all). Returns the multipliers' constraints, then
    the matrix's, each on the next basis of ``bases``."""
    sym, _ = _drake()
    dim = S.shape[0]
    vs = v[:dim]
    q = _quadratic_form(S, vs)
    out = []
    if region:
        vv = sym.Polynomial({sym.Monomial(vs[i], 2): sym.Expression(1.0) for i in (rows or range(dim))})
        for g in region:
            s = prog.NewFreePolynomial(sym.Variables(x), multiplier_degree, "s")
            out.append(_add_sos(prog, s, x, next(bases)))
            q -= s * g * vv
    out.append(_add_sos(prog, q, np.concatenate([x, vs]), next(bases), dim))
    return out


def _decision_vector(layout: list[tuple[str, Any]]) -> list[Any]:
    """Drake's decision variables in our order (see :attr:`DrakeProgram.layout`)."""
    sym, _ = _drake()
    out: list[Any] = []
    for kind, piece in layout:
        if kind == "sym":
            out += [piece[i, j] for i in range(piece.shape[0]) for j in range(i, piece.shape[0])]
        elif kind == "matrix":
            out += list(piece.ravel())
        elif kind == "var":
            out.append(piece)
        else:
            p, x, degree = piece
            coef = p.monomial_to_coefficient_map()
            for e in monomials(len(x), degree):
                (var,) = coef[sym.Monomial(x, e.astype(np.int32))].GetVariables()
                out.append(var)
    return out


@_drake_arithmetic
def drake_theorem1(bases: list[np.ndarray], region: float | None) -> DrakeProgram:
    """Seed 000 Theorem 1 as :func:`satfmu.synthesis.polynomial_feedback.hinf_sos.theorem1` poses it (its defaults:
    K of degree 2, rate margin 1e-2 globally, strict margin 1e-3 and multiplier degree 0 on
    ``|sigma| <= region``, ``Q >= I``, minimize trace Q)."""
    sym, solvers = _drake()
    model = mrp_satellite.MODEL
    xs = [s.symbol for s in model.states]
    n, m = len(xs), 3
    A = model.sdc.A.subs({p.symbol: p.start for p in model.parameters})  # type: ignore[union-attr]
    prog = solvers.MathematicalProgram()
    x = prog.NewIndeterminates(n, "x")
    v = prog.NewIndeterminates(n, "v")
    Ad = np.array([[_to_drake(A[i, j], xs, x) for j in range(n)] for i in range(n)])
    Q = prog.NewSymmetricContinuousVariables(n, "Q")
    K = np.array([[prog.NewFreePolynomial(sym.Variables(x), 2, f"K{i}{j}") for j in range(n)] for i in range(m)])
    AQ = Ad @ _var_matrix(Q)
    BK = np.vstack([K, np.full((n - m, n), _constant(0.0))])
    M = AQ + AQ.T + BK + BK.T
    layout = [("sym", Q)] + [("poly", (K[i, j], x, 2)) for i in range(m) for j in range(n)]
    bases_it = iter(bases)
    if region is None:
        E = np.diag([1e-2] * m + [0.0] * (n - m))
        sos = _add_sos_matrix(prog, -M - E, x, v, bases_it, [], 0)
    else:
        s2 = sum(sp.Symbol(f"sigma[{i}]", real=True) ** 2 for i in (1, 2, 3))
        ball = _to_drake(region**2 - s2, xs, x)
        sos = _add_sos_matrix(prog, -M - 1e-3 * np.eye(n), x, v, bases_it, [ball], 0)
        layout.append(("poly", (sos[0].p, x, 0)))
    lmi = Q - np.eye(n)
    prog.AddLinearMatrixInequalityConstraint(lmi)
    objective = np.trace(Q)
    prog.AddLinearCost(objective)
    return DrakeProgram(prog, sos, layout, [lmi], [], objective, {}, 1.0)


@dataclass(frozen=True)
class Theorem8Data:
    """Theorem 8's plant data in the balanced units :func:`satfmu.synthesis.polynomial_feedback.h2hinf_sos.theorem8`
    solves in (:mod:`satfmu.synthesis.polynomial_feedback.coordinates`), from our split and scaling (plant data, as
    Theorem 1 takes the model's sympy matrices): every tool builds the program's products itself."""

    plant: split_plant.SplitPlant
    """The split plant in the scaled units."""
    Qs: np.ndarray
    Rs: np.ndarray
    gamma: float
    alpha: float
    beta: float
    x0: np.ndarray

    @classmethod
    def of(cls, gamma: float, alpha: float, beta: float) -> "Theorem8Data":
        user = split_plant.split(mrp_satellite.MODEL)
        Qh, Rh = np.eye(user.n), np.eye(user.m)
        coords = Coordinates.balanced(user, Qh, Rh, alpha, beta)
        Qs, Rs = coords.weights(user, Qh, Rh)
        return cls(coords.plant(user), Qs, Rs, coords.gamma(gamma), coords.scalar(alpha), coords.scalar(beta),
                   coords.state(user, h2hinf_sos.X0_90))


def _poly_to_drake(p: Poly, variables: np.ndarray) -> Any:
    """A numeric polynomial of ours (no decision variables) as a Drake polynomial in ``variables``."""
    sym, _ = _drake()
    if p.C.nnz:
        raise ValueError("the polynomial has decision-variable coefficients")
    return sym.Polynomial({sym.Monomial(variables, e.astype(np.int32)): sym.Expression(float(c))
                           for e, c in zip(p.exps, p.c0) if c != 0})


@_drake_arithmetic
def drake_theorem8(bases: list[np.ndarray], gamma: float, alpha: float, beta: float) -> DrakeProgram:
    """Seed 001 Theorem 8, slack variant, as :func:`satfmu.synthesis.polynomial_feedback.h2hinf_sos.theorem8` poses
    and solves it (its defaults: ``|x~| <= 0.45``, Y of degree 1, multipliers of degree 0 on the
    first two block rows, margin 1e-6, ``Qh = I6``, ``Rh = I3``, x0 the 90 deg start, minimize
    lambda, Clarabel tolerances 1e-10), in the balanced units it solves in
    (:mod:`satfmu.synthesis.polynomial_feedback.coordinates`): the plant split and scaled by our
    code (plant data, as Theorem 1 takes the model's sympy matrices), every product of the
    program done with Drake's polynomials (:class:`Theorem8Data`)."""
    sym, solvers = _drake()
    d = Theorem8Data.of(gamma, alpha, beta)
    plant, g, a, b, x0 = d.plant, d.gamma, d.alpha, d.beta, d.x0
    n, m = plant.n, plant.m
    nt, radius, margin = len(plant.tilde), 0.45, 1e-6
    prog = solvers.MathematicalProgram()
    xt = prog.NewIndeterminates(nt, "x")
    A_t = np.array([[_poly_to_drake(p, xt) for p in row] for row in plant.A_tilde.entries])
    F = prog.NewContinuousVariables(n, n, "F")
    X2 = prog.NewSymmetricContinuousVariables(n, "X2")
    Xinf = prog.NewSymmetricContinuousVariables(n, "Xinf")
    Y = np.array([[prog.NewFreePolynomial(sym.Variables(xt), 1, f"Y{i}{j}") for j in range(n)] for i in range(m)])
    lam = prog.NewContinuousVariables(1, "lambda")[0]
    Fp, X2p, Xinfp = _var_matrix(F), _var_matrix(X2), _var_matrix(Xinf)
    AFBY = A_t @ Fp + plant.Bu @ Y
    G11 = AFBY + AFBY.T
    FFt = Fp + Fp.T
    Z = np.full((n, n), _constant(0.0))
    nz = plant.C.shape[0]
    CF = plant.C @ Fp
    M2 = np.block([[G11, Z, Z, Z[:, :m]],
                   [X2p - Fp + a * AFBY.T, -a * FFt, Z, Z[:, :m]],
                   [Fp, a * Fp, _var_matrix(-np.linalg.inv(d.Qs)), Z[:, :m]],
                   [Y, a * Y, Z[:m], _var_matrix(-np.linalg.inv(d.Rs))]])
    Minf = np.block([[G11, Z, Z[:, :m], Z[:, :nz]],
                     [Xinfp - Fp + b * AFBY.T, -b * FFt, Z[:, :m], Z[:, :nz]],
                     [_var_matrix(plant.Bw.T), Z[:m], _var_matrix(-g**2 * np.eye(m)), Z[:m, :nz]],
                     [CF, b * CF, Z[:nz, :m], _var_matrix(-np.eye(nz))]])
    ball = sym.Polynomial({sym.Monomial(): sym.Expression(radius**2)})
    for x in xt:
        ball -= sym.Polynomial({sym.Monomial(x, 2): sym.Expression(1.0)})
    v = prog.NewIndeterminates(M2.shape[0], "v")
    bases_it = iter(bases)
    sos = []
    for M, scalar in ((M2, a), (Minf, b)):
        M = M + margin * np.diag(np.concatenate([np.ones(n), np.full(n, scalar), np.ones(M.shape[0] - 2 * n)]))
        S = -np.array([[M[max(i, j), min(i, j)] for j in range(len(M))]
                       for i in range(len(M))])  # from the lower triangle
        sos += _add_sos_matrix(prog, S, xt, v, bases_it, [ball], 0, range(2 * n))
    lmis = [X2 - margin * np.eye(n), Xinf - margin * np.eye(n),
            np.block([[np.array([[lam]]), x0[None, :]], [x0[:, None], X2]])]
    for L in lmis:
        prog.AddLinearMatrixInequalityConstraint(L)
    prog.AddLinearCost(lam)
    layout = ([("matrix", F), ("sym", X2), ("sym", Xinf)]
              + [("poly", (Y[i, j], xt, 1)) for i in range(m) for j in range(n)]
              + [("var", lam), ("poly", (sos[0].p, xt, 0)), ("poly", (sos[2].p, xt, 0))])
    options = {"tol_feas": 1e-10, "tol_gap_abs": 1e-10, "tol_gap_rel": 1e-10}
    return DrakeProgram(prog, sos, layout, lmis, [], lam, options, radius)


@_drake_arithmetic
def drake_vscmg_box(bases: list[np.ndarray], loop: vscmg_region.ClosedLoop) -> DrakeProgram:
    """Seed 002 region certificate on the operating box as :func:`satfmu.synthesis.servo.vscmg_region.certify`
    poses it (its defaults: box multipliers of degree 4, ``trace Y <= 100``; coordinates
    scaled by the Cholesky factor of the box centre's Riccati solution of
    ``(Ae - SCALE_SHIFT I, Be)``), from the same :class:`~satfmu.synthesis.servo.vscmg_region.ClosedLoop`;
    the substitutions (cos q2 by a line in sin q2, then the box scaled to [-1, 1]^2) done
    with Drake's polynomial arithmetic (:func:`_substitute`)."""
    sym, solvers = _drake()
    w4 = vscmg_region.OPERATING_BOX[1]
    a_lo, a_hi, L = _vscmg_scaling(loop)
    Li = np.linalg.inv(L)
    a, c, w = sp.symbols("a c w4", real=True)  # the symbols of loop.acl
    prog = solvers.MathematicalProgram()
    st = prog.NewIndeterminates(2, "x")
    da, dc, dw = sym.Variable("a"), sym.Variable("c"), sym.Variable("w4")
    a_s = _constant((a_lo + a_hi) / 2) + (a_hi - a_lo) / 2 * sym.Polynomial(sym.Monomial(st[0]))
    w_t = _constant(sum(w4) / 2) + (w4[1] - w4[0]) / 2 * sym.Polynomial(sym.Monomial(st[1]))
    acl = np.array([[_to_drake(e, [a, c, w], np.array([da, dc, dw])) for e in row] for row in loop.acl.tolist()])
    mom = np.array([_to_drake(e, [a], np.array([da])) for e in loop.momentum])
    p = Li @ np.array([_substitute(e, [(da, a_s)]) for e in mom])
    p_degree = max(e.TotalDegree() for e in p)
    Y = prog.NewSymmetricContinuousVariables(7, "Y")
    eps = prog.NewContinuousVariables(1, "eps")[0]
    lmi = Y - np.eye(7)
    prog.AddLinearMatrixInequalityConstraint(lmi)
    trace_room = 100.0 - np.trace(Y)
    prog.AddLinearConstraint(trace_room >= 0)
    box = [_constant(1.0) - sym.Polynomial(sym.Monomial(st[i], 2)) for i in range(2)]
    v = prog.NewIndeterminates(7, "v")
    Yp = _var_matrix(Y)
    layout: list[tuple[str, Any]] = [("sym", Y), ("var", eps)]
    bases_it = iter(bases)
    sos = []
    for line in vscmg_region.cos_enclosure(a_lo, a_hi):
        c0, c1 = (float(sp.Poly(line, a).coeff_monomial(a**k)) for k in (0, 1))
        sub = [(da, a_s), (dc, c0 * _constant(1.0) + c1 * a_s), (dw, w_t)]
        As = L.T @ np.array([[_substitute(e, sub) for e in row] for row in acl]) @ Li.T
        G = As.T @ Yp
        Qm = -(G + G.T)
        lam_degree = max(max(e.TotalDegree() for e in Qm.ravel()) - p_degree, 0)
        lam = np.array([prog.NewFreePolynomial(sym.Variables(st), lam_degree, f"lam{i}") for i in range(7)])
        Fm = np.outer(lam, p)
        S = Qm - Fm - Fm.T - np.diag([_constant(eps)] * 7)
        found = _add_sos_matrix(prog, S, st, v, bases_it, box, 4)
        layout += [("poly", (e, st, lam_degree)) for e in lam] + [("poly", (d.p, st, 4)) for d in found[:2]]
        sos += found
    prog.AddLinearCost(-eps)
    return DrakeProgram(prog, sos, layout, [lmi], [trace_room], -eps, {}, 1.0)


def run_drake(pose: Callable[[], DrakeProgram], build_only: bool = False) -> Run:
    """One end-to-end run of Drake: pose, solve with Clarabel, check the Gram matrices.

    ``build_only``: Clarabel stopped after one iteration (``max_iter`` 1, which Drake passes on),
    nothing checked: the run's ``build`` (posing and Drake's translation to Clarabel's form) is
    Drake's whole build, for programs whose solve takes longer than the bench waits."""
    _, solvers = _drake()
    t0 = time.perf_counter()
    dp = pose()
    options = solvers.SolverOptions()
    for k, val in {**dp.options, **({"max_iter": 1} if build_only else {})}.items():
        options.SetOption(solvers.ClarabelSolver.id(), k, val)
    result = solvers.ClarabelSolver().Solve(dp.prog, None, options)
    t1 = time.perf_counter()
    solver = result.get_solver_details().solve_time
    if build_only:
        return Run(t1 - t0, solver, 0.0, float("nan"), (), float("nan"), float("nan"), False)
    if not result.is_success():
        raise RuntimeError(f"Drake: {result.get_solution_result()}")
    grams = drake_verify(dp, result)
    total = time.perf_counter() - t0
    return _summarize(grams, total, solver, total - (t1 - t0), float(result.get_optimal_cost()))


def drake_verify(dp: DrakeProgram, result: Any) -> list[Gram]:
    """Drake's certificate checked as :func:`satfmu.synthesis.core.sos.verify` checks ours: per SOS
    constraint the Gram matrix's smallest eigenvalue, the largest coefficient of ``p -
    z^T G z`` (``p`` at the solution) and ``p`` at sampled points."""
    rng = np.random.default_rng(0)
    out = []
    for c in dp.sos:
        G = np.reshape(result.GetSolution(c.gram), (len(c.basis), len(c.basis)))
        p = result.GetSolution(c.p)
        coef = {m: e.Evaluate() for m, e in p.monomial_to_coefficient_map().items()}
        gram: dict[Any, float] = {}
        z = c.basis
        for i in range(len(z)):
            gram[z[i] * z[i]] = gram.get(z[i] * z[i], 0.0) + G[i, i]
            for j in range(i + 1, len(z)):
                gram[z[i] * z[j]] = gram.get(z[i] * z[j], 0.0) + 2 * G[i, j]
        residual = max(abs(coef.get(k, 0.0) - gram.get(k, 0.0)) for k in coef.keys() | gram.keys())
        pts = _sample_points(rng, len(c.variables) - c.n_v, c.n_v, dp.sample_radius)
        vals = p.EvaluateIndeterminates(c.variables, np.asfortranarray(pts.T))
        out.append(_judge(G, residual, max(map(abs, coef.values()), default=0.0), float(vals.min())))
    return out


def same_program(caught: Caught, dp: DrakeProgram) -> tuple[float, float]:
    """Compare Drake's program with ours coefficient by coefficient (in our variable order).

    Returns the largest absolute difference of any coefficient (SOS polynomials as affine
    functions of the decision vector, LMI entries, linear constraints, objective) and the
    largest coefficient (its scale).

    Raises
    ------
    ValueError
        If the two differ in structure: decision count, constraint counts, a Gram basis.
    """
    sym, _ = _drake()
    prog = caught.program
    y = np.array(_decision_vector(dp.layout))
    nd = prog.n_decision
    if len(y) != nd:
        raise ValueError(f"{len(y)} decision variables in Drake's program, {nd} in ours")
    if len(prog.sos) != len(dp.sos) or len(prog.psd) != len(dp.lmis) or prog.equalities:
        raise ValueError("the two programs have different constraints")

    def affine(exprs: list[Any]) -> np.ndarray:
        """Rows [coefficients of y, constant] of affine expressions in y."""
        if not exprs:
            return np.zeros((0, nd + 1))
        M, b = sym.DecomposeAffineExpressions(
            np.array([e if isinstance(e, sym.Expression) else sym.Expression(e) for e in exprs]), y)
        return np.hstack([M, b[:, None]])

    def ours_rows(C: Any, c0: np.ndarray) -> np.ndarray:
        C = C.toarray()
        return np.hstack([C, np.zeros((C.shape[0], nd - C.shape[1])), np.asarray(c0, float)[:, None]])

    diffs, scales = [0.0], [0.0]

    def compare(a: np.ndarray, b: np.ndarray) -> None:
        diffs.append(float(np.max(np.abs(a - b), initial=0.0)))
        scales.append(float(np.max(np.abs(a), initial=0.0)))

    for c, d in zip(prog.sos, dp.sos):
        if c.basis.shape[1] != len(d.variables):
            raise ValueError(f"{c.name}: {c.basis.shape[1]} variables in ours, {len(d.variables)} in Drake's")
        drake_basis = {tuple(m.degree(x) for x in d.variables) for m in d.basis}
        if drake_basis != {tuple(map(int, r)) for r in c.basis} or len(d.basis) != len(c.basis):
            raise ValueError(f"{c.name}: the Gram bases differ")
        mono = d.p.monomial_to_coefficient_map()
        keys = [tuple(m.degree(x) for x in d.variables) for m in mono]
        theirs = dict(zip(keys, affine(list(mono.values()))))
        mine = dict(zip(map(tuple, c.poly.exps.tolist()), ours_rows(c.poly.C, c.poly.c0)))
        zero = np.zeros(nd + 1)
        keys_all = sorted(theirs.keys() | mine.keys())
        compare(np.array([mine.get(k, zero) for k in keys_all]), np.array([theirs.get(k, zero) for k in keys_all]))
    for (_, entries), L in zip(prog.psd, dp.lmis):
        rows = np.array([[ours_rows(C, np.array([c0]))[0] for C, c0 in row] for row in entries])
        sym_rows = (rows + rows.transpose(1, 0, 2)) / 2
        compare(sym_rows.reshape(-1, nd + 1), affine(list(np.asarray(L).ravel())))
    mine_ge = [ours_rows(A, b) for A, b in prog.inequalities]
    compare(np.vstack(mine_ge) if mine_ge else np.zeros((0, nd + 1)), affine(dp.linear_ge))
    obj = caught.objective
    compare(ours_rows(obj, np.zeros(1)) if obj is not None else np.zeros((1, nd + 1)), affine([dp.objective]))
    return max(diffs), max(scales)


# ---------------------------------------------------------------------------- SumOfSquares.py
def _sospy_verify(prob: Any, consts: list[tuple[Any, sp.Expr, list[sp.Symbol], list[sp.Symbol]]],
                  radius: float) -> list[Gram]:
    """SumOfSquares.py's certificate checked as ours is: per constraint ``(constraint, p, x,
    v)`` the Gram matrix's eigenvalue, the coefficients of ``p - b^T G b`` (``p`` at the
    solution) and ``p`` at sampled points (``x`` in the ball, ``v`` on the sphere).

    SumOfSquares.py leaves the coefficients of monomials outside its basis products
    unconstrained (they never reach the solver, so their symbols have no value); SOS needs
    them zero, so they are set to zero here.
    """
    rng = np.random.default_rng(0)
    out = []
    for const, expr, xs, vs in consts:
        b = sp.Matrix(np.ravel(const.b_sym).tolist())
        G = np.reshape(np.array(const.Qval, float), (len(b), len(b)))
        p = prob.subs_with_sol(expr)
        p = p.subs({s: 0 for s in p.free_symbols - set(xs) - set(vs)})
        diff = sp.Poly(sp.expand(p - (b.T * sp.Matrix(G) * b)[0]), *const.symbols)
        residual = float(max(abs(float(c)) for c in diff.coeffs()))
        pts = _sample_points(rng, len(xs), len(vs), radius)
        vals = np.broadcast_to(sp.lambdify(xs + vs, p, "numpy")(*pts.T), (N_SAMPLES,))
        pscale = float(max((abs(float(c)) for c in sp.Poly(p, *(xs + vs)).coeffs()), default=0.0))
        out.append(_judge(G, residual, pscale, float(vals.min())))
    return out


def _sospy_matrix(prob: Any, S: sp.Matrix, xs: list[sp.Symbol], name: str) -> tuple[Any, sp.Expr, list, list]:
    """``S(x)`` an SOS matrix in SumOfSquares.py (Newton-polytope basis), with what its check needs."""
    vs = list(sp.symbols(f"{name}_:{S.shape[0]}"))
    const = prob.add_matrix_sos_constraint(S, xs, sparse=True, aux_var_name=name)
    y = sp.Matrix([vs])
    return const, sp.expand((y * S * y.T)[0]), xs, vs


def _sospy_run(pose: Callable[[], tuple[Any, list, Any, float]]) -> Run:
    """One end-to-end run of SumOfSquares.py: pose (returns the problem, its SOS constraints,
    the objective's picos expression and the sampling radius), solve by CVXOPT, check."""
    t0 = time.perf_counter()
    prob, consts, objective, radius = pose()
    t1 = time.perf_counter()
    sol = prob.solve(solver="cvxopt")
    t2 = time.perf_counter()
    grams = _sospy_verify(prob, consts, radius)
    total = time.perf_counter() - t0
    return _summarize(grams, total, float(sol.searchTime) or t2 - t1, total - (t2 - t0), float(objective.value))


@dataclass(frozen=True)
class Limits:
    """What a SumOfSquares.py run is given: wall seconds and resident memory (GiB)."""

    seconds: float
    memory_gib: float


def _resident_gib(pid: int) -> float:
    """Resident memory of process ``pid`` (GiB; 0 once it is gone)."""
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) / 2**20
    except FileNotFoundError:
        pass
    return 0.0


@dataclass(frozen=True)
class NoResult:
    """Why a bounded run gave no result, and after how long (s). ``stopped``: the bench stopped
    it at a limit, so the run takes longer than ``seconds``; otherwise it failed."""

    reason: str
    seconds: float
    stopped: bool


def bounded(fn: Callable[[], Run], limits: Limits) -> Run | NoResult:
    """``fn()`` in a forked child process, or why it gave no result: stopped at the time or
    memory limit, or the exception it raised."""
    ctx = multiprocessing.get_context("fork")
    recv, send = ctx.Pipe(duplex=False)

    def child() -> None:
        try:
            send.send(fn())
        except BaseException as exc:  # the child reports everything, the parent decides
            send.send(f"failed: {type(exc).__name__}: {exc}")

    proc = ctx.Process(target=child, daemon=True)
    proc.start()
    t0 = time.perf_counter()
    out: Run | NoResult | None = None
    peak = 0.0
    while out is None:
        elapsed = time.perf_counter() - t0
        if recv.poll(0.5):
            got = recv.recv()
            out = NoResult(got, elapsed, False) if isinstance(got, str) else got
        elif not proc.is_alive():
            out = NoResult(f"died with exit code {proc.exitcode}", elapsed, False)
        elif (peak := max(peak, _resident_gib(proc.pid))) > limits.memory_gib:
            out = NoResult(f"stopped at {peak:.1f} GiB resident after {elapsed:.0f} s "
                           f"(limit {limits.memory_gib:g} GiB)", elapsed, True)
        elif elapsed > limits.seconds:
            out = NoResult(f"did not finish within {limits.seconds:g} s ({peak:.1f} GiB resident)", elapsed, True)
    proc.kill()
    proc.join()
    return out


def _bounded_run(pose: Callable[[], tuple[Any, list, Any, float]], limits: Limits) -> Run:
    """A timed round of SumOfSquares.py in its bounded child; a round that gives no result
    after the warm-up did is an error of the bench."""
    out = bounded(lambda: _sospy_run(pose), limits)
    if isinstance(out, NoResult):
        raise RuntimeError(f"SumOfSquares.py: {out.reason} (its warm-up run finished)")
    return out


def sospy_theorem1(region: float | None) -> tuple[Any, list, Any, float]:
    """Theorem 1 in SumOfSquares.py, as :func:`drake_theorem1` poses it."""
    from SumOfSquares import SOSProblem, poly_variable

    model = mrp_satellite.MODEL
    xs = [s.symbol for s in model.states]
    A = model.sdc.A.subs({v.symbol: v.start for v in model.parameters})  # type: ignore[union-attr]
    n, m = 6, 3
    prob = SOSProblem()
    Q = sp.Matrix(n, n, lambda i, j: sp.Symbol(f"q_{min(i, j)}_{max(i, j)}"))
    K = sp.Matrix(m, n, lambda i, j: poly_variable(f"k_{i}_{j}", xs, 2))
    Bf = sp.Matrix(sp.BlockMatrix([[sp.eye(m)], [sp.zeros(n - m, m)]]))
    M = A * Q + Q * A.T + Bf * K + K.T * Bf.T
    consts = []
    if region is None:
        S = -M - sp.diag(*([1e-2] * m + [0] * (n - m)))
    else:
        s = sp.Symbol("s0")
        consts.append((prob.add_sos_constraint(s, xs, sparse=True), s, xs, []))
        ball = region**2 - sum(sp.Symbol(f"sigma[{i}]", real=True) ** 2 for i in (1, 2, 3))
        S = -M - 1e-3 * sp.eye(n) - s * ball * sp.eye(n)
    consts.append(_sospy_matrix(prob, S.applyfunc(sp.expand), xs, "v"))
    Qp = prob.sp_mat_to_picos(Q)
    prob.add_constraint(Qp - np.eye(n) >> 0)
    objective = sum(prob.sym_to_var(Q[i, i]) for i in range(n))
    prob.set_objective("min", objective)
    return prob, consts, objective, 1.0


def sospy_theorem8(gamma: float, alpha: float, beta: float) -> tuple[Any, list, Any, float]:
    """Theorem 8 in SumOfSquares.py, as :func:`drake_theorem8` poses it (:class:`Theorem8Data`)."""
    from SumOfSquares import SOSProblem, poly_variable

    d = Theorem8Data.of(gamma, alpha, beta)
    plant, a, b, x0 = d.plant, d.alpha, d.beta, d.x0
    n, m = plant.n, plant.m
    xt = plant.tilde_symbols
    radius, margin = 0.45, 1e-6
    A_t = sp.Matrix([[p.to_sympy(xt) for p in row] for row in plant.A_tilde.entries])
    prob = SOSProblem()
    F = sp.Matrix(n, n, lambda i, j: sp.Symbol(f"f_{i}_{j}"))
    X2 = sp.Matrix(n, n, lambda i, j: sp.Symbol(f"x2_{min(i, j)}_{max(i, j)}"))
    Xinf = sp.Matrix(n, n, lambda i, j: sp.Symbol(f"xi_{min(i, j)}_{max(i, j)}"))
    Y = sp.Matrix(m, n, lambda i, j: poly_variable(f"y_{i}_{j}", xt, 1))
    lam = sp.Symbol("lam")
    AFBY = A_t * F + sp.Matrix(plant.Bu) * Y
    G11 = AFBY + AFBY.T
    FFt = F + F.T
    Z = sp.zeros(n, n)
    nz = plant.C.shape[0]
    CF = sp.Matrix(plant.C) * F
    M2 = sp.Matrix(sp.BlockMatrix([[G11, Z, Z, Z[:, :m]],
                                   [X2 - F + a * AFBY.T, -a * FFt, Z, Z[:, :m]],
                                   [F, a * F, sp.Matrix(-np.linalg.inv(d.Qs)), Z[:, :m]],
                                   [Y, a * Y, Z[:m, :], sp.Matrix(-np.linalg.inv(d.Rs))]]))
    Minf = sp.Matrix(sp.BlockMatrix([[G11, Z, Z[:, :m], Z[:, :nz]],
                                     [Xinf - F + b * AFBY.T, -b * FFt, Z[:, :m], Z[:, :nz]],
                                     [sp.Matrix(plant.Bw.T), Z[:m, :], -d.gamma**2 * sp.eye(m), Z[:m, :nz]],
                                     [CF, b * CF, Z[:nz, :m], -sp.eye(nz)]]))
    ball = radius**2 - sum(x**2 for x in xt)
    consts = []
    for k, (M, scalar) in enumerate(((M2, a), (Minf, b))):
        dim = M.shape[0]
        M = M + margin * sp.diag(*([1] * n + [scalar] * n + [1] * (dim - 2 * n)))
        S = -sp.Matrix(dim, dim, lambda i, j: M[max(i, j), min(i, j)])
        s = sp.Symbol(f"s{k}")
        consts.append((prob.add_sos_constraint(s, xt, sparse=True), s, xt, []))
        S = S - s * ball * sp.diag(*([1] * (2 * n) + [0] * (dim - 2 * n)))
        consts.append(_sospy_matrix(prob, S.applyfunc(sp.expand), xt, f"v{k}"))
    X2p, Xinfp = prob.sp_mat_to_picos(X2), prob.sp_mat_to_picos(Xinf)
    prob.add_constraint(X2p - margin * np.eye(n) >> 0)
    prob.add_constraint(Xinfp - margin * np.eye(n) >> 0)
    lam_p = prob.sym_to_var(lam)
    prob.add_constraint(((lam_p & x0[None, :]) // (x0[:, None] & X2p)) >> 0)
    prob.set_objective("min", lam_p)
    return prob, consts, lam_p, radius


def _vscmg_scaling(loop: vscmg_region.ClosedLoop) -> tuple[float, float, np.ndarray]:
    """``sin`` of the operating box's q2 ends and the coordinate scaling L of ``certify``: the
    Cholesky factor of the Riccati solution of ``(Ae - SCALE_SHIFT I, Be)`` at the box centre."""
    q2, w4 = vscmg_region.OPERATING_BOX
    A0, B0 = loop.servo.matrices(np.array([0.0, sum(q2) / 2, 0.0, 0.0, 0.0, sum(w4) / 2]))
    P = sla.solve_continuous_are(A0 - vscmg_region.SCALE_SHIFT * np.eye(7), B0, loop.servo.Q, loop.servo.R)
    return float(np.sin(q2[0])), float(np.sin(q2[1])), np.linalg.cholesky((P + P.T) / 2)


def sospy_vscmg_box(loop: vscmg_region.ClosedLoop) -> tuple[Any, list, Any, float]:
    """The seed 002 region certificate in SumOfSquares.py, as :func:`drake_vscmg_box` poses it
    (the substitutions in sympy)."""
    from SumOfSquares import SOSProblem, poly_variable

    w4 = vscmg_region.OPERATING_BOX[1]
    a_lo, a_hi, L = _vscmg_scaling(loop)
    a, c, w, s, t = sp.symbols("a c w4 s t", real=True)
    sub = {a: (a_lo + a_hi) / 2 + (a_hi - a_lo) / 2 * s, w: sum(w4) / 2 + (w4[1] - w4[0]) / 2 * t}
    Lt, Lti = sp.Matrix(L.T), sp.Matrix(np.linalg.inv(L.T))
    prob = SOSProblem()
    Y = sp.Matrix(7, 7, lambda i, j: sp.Symbol(f"y_{min(i, j)}_{max(i, j)}"))
    eps = sp.Symbol("eps")
    p = (sp.Matrix(np.linalg.inv(L)) * loop.momentum).subs(sub).applyfunc(sp.expand)
    p_degree = max(sp.Poly(e, s, t).total_degree() for e in p)
    box = [1 - s**2, 1 - t**2]
    consts = []
    for k, line in enumerate(vscmg_region.cos_enclosure(a_lo, a_hi)):
        A = (Lt * loop.acl.subs(c, line) * Lti).subs(sub).applyfunc(sp.expand)
        G = A.T * Y
        Q = -(G + G.T)
        degree = max(sp.Poly(e, s, t).total_degree() for e in Q)
        lam = sp.Matrix(7, 1, lambda i, _: poly_variable(f"lam{k}_{i}", [s, t], max(degree - p_degree, 0)))
        Fm = lam * p.T
        S = Q - Fm - Fm.T - eps * sp.eye(7)
        for j, g in enumerate(box):
            mult = poly_variable(f"m{k}_{j}", [s, t], 4)
            consts.append((prob.add_sos_constraint(mult, [s, t], sparse=True), mult, [s, t], []))
            S = S - mult * g * sp.eye(7)
        consts.append(_sospy_matrix(prob, S.applyfunc(sp.expand), [s, t], f"v{k}"))
    Yp = prob.sp_mat_to_picos(Y)
    prob.add_constraint(Yp - np.eye(7) >> 0)
    prob.add_constraint(sum(prob.sym_to_var(Y[i, i]) for i in range(7)) <= 100.0)
    objective = -prob.sym_to_var(eps)
    prob.set_objective("min", objective)
    return prob, consts, objective, 1.0


# ---------------------------------------------------------------------------- the programs
@functools.cache
def _vscmg_loop() -> vscmg_region.ClosedLoop:
    """The approximated SDRE servo's closed loop (the input of ``certify``; built once, not timed)."""
    return vscmg_region.ClosedLoop.build(artifact.load(ARTIFACTS / "vscmg_sdre_approx.json"))


def _h2hinf_design() -> tuple[float, float, float]:
    """gamma, alpha, beta of the shipped seed 001 design."""
    numbers = artifact.load(ARTIFACTS / "mrp_h2hinf_satfmu.json").certificate["numbers"]
    return float(numbers["gamma"]), float(numbers["alpha"]), float(numbers["beta"])


@dataclass(frozen=True)
class Program:
    """One program of the bench, as each tool poses it."""

    key: str
    title: str
    ours: Callable[[], Any]
    drake: Callable[[list[np.ndarray]], DrakeProgram]
    sospy: Callable[[], tuple[Any, list, Any, float]] | str
    """The SumOfSquares.py posing, or why there is none."""


def programs() -> list[Program]:
    gamma, alpha, beta = _h2hinf_design()
    return [
        Program("thm1-global", "seed 000 Theorem 1, global (rate margin 1e-2)",
                lambda: hinf_sos.theorem1(rate_margin=1e-2), lambda b: drake_theorem1(b, None),
                lambda: sospy_theorem1(None)),
        Program("thm1-regional", "seed 000 Theorem 1, |sigma| <= 0.9 (strict margin 1e-3)",
                lambda: hinf_sos.theorem1(region=0.9), lambda b: drake_theorem1(b, 0.9),
                lambda: sospy_theorem1(0.9)),
        Program("thm8-regional", f"seed 001 Theorem 8, slack, gamma {gamma:g}, alpha {alpha:.4g}, beta {beta:.4g}, "
                                 "|sigma| <= 0.45",
                lambda: h2hinf_sos.theorem8(gamma, alpha, beta), lambda b: drake_theorem8(b, gamma, alpha, beta),
                lambda: sospy_theorem8(gamma, alpha, beta)),
        Program("vscmg-box", f"seed 002 region certificate, q2 x w4 box {vscmg_region.OPERATING_BOX}",
                lambda: vscmg_region.certify(_vscmg_loop(), *vscmg_region.OPERATING_BOX),
                lambda b: drake_vscmg_box(b, _vscmg_loop()), lambda: sospy_vscmg_box(_vscmg_loop())),
    ]


# ---------------------------------------------------------------------------- report
def _fmt(t: float) -> str:
    return f"{t:9.3f}" if np.isfinite(t) else f"{'-':>9}"


DRAKE_BUILD = "Drake build only"
"""The runs timing Drake's build alone (one Clarabel iteration), when its whole run exceeds ``--drake-limit``."""


def bench(program: Program, repeat: int, sospy_rounds: int, qdldl: bool, limits: Limits,
          drake_limit: float) -> dict[str, Any]:
    """Warm up, compare the programs, then time the tools interleaved; print and return the figures."""
    print(f"\n== {program.key}: {program.title}")
    ref, caught = run_ours(program.ours)
    bases = [c.basis for c in caught.program.sos]
    diff, scale = same_program(caught, program.drake(bases))
    print(f"same program in Drake: largest coefficient difference {diff:.1e} (coefficients up to {scale:.3g}; "
          f"{caught.program.n_decision} decision variables, {len(bases)} SOS constraints, Gram bases identical)")
    runs: dict[str, Callable[[], Run]] = {"satfmu": lambda: run_ours(program.ours)[0]}
    if qdldl:
        runs["satfmu qdldl"] = lambda: run_ours(program.ours, qdldl=True)[0]
    refs = {"satfmu": ref}
    drake_first = bounded(lambda: run_drake(lambda: program.drake(bases)), Limits(drake_limit, limits.memory_gib))
    drake_missing: NoResult | None = None
    if isinstance(drake_first, NoResult):
        drake_missing = drake_first
        print(f"Drake: {drake_first.reason}; its build timed on runs stopped after one Clarabel iteration")
        runs[DRAKE_BUILD] = lambda: run_drake(lambda: program.drake(bases), build_only=True)
    else:
        refs["Drake"] = drake_first
        runs["Drake"] = lambda: run_drake(lambda: program.drake(bases))
    sospy_missing: NoResult | None = None
    if isinstance(program.sospy, str):
        print(f"SumOfSquares.py: skipped ({program.sospy})")
    elif sospy_rounds > 0:
        pose = program.sospy
        first = bounded(lambda: _sospy_run(pose), limits)
        if isinstance(first, NoResult):
            sospy_missing = first
            print(f"SumOfSquares.py: {first.reason}")
        else:
            refs["SumOfSquares.py"] = first
            runs["SumOfSquares.py"] = lambda: _bounded_run(pose, limits)
    timed = interleaved(runs, repeat, {"SumOfSquares.py": sospy_rounds})
    for name, r in refs.items():
        print(f"{name:16} Gram sizes {list(r.gram_sizes)}  objective {r.objective:.10g}  "
              f"min eig {r.min_eig:.1e}  residual {r.residual:.1e}  certified {r.certified}")
    print("objective differences: " + ", ".join(f"{name} - satfmu {r.objective - ref.objective:+.1e}"
                                                 for name, r in refs.items() if name != "satfmu"))
    print(f"{'':16}{'runs':>5}{'min s':>9}{'median s':>9}  {'build':>9}{'solver':>9}{'verify':>9}  "
          f"{'w/o verify':>10}   (split and w/o verify: medians)")
    med: dict[str, float] = {}
    med_nv: dict[str, float] = {}
    for name, rs in timed.items():
        lo, med[name] = min_median([r.total for r in rs])
        med_nv[name] = min_median([r.without_verify for r in rs])[1]
        split = [min_median([getattr(r, k) for r in rs])[1] for k in ("build", "solver", "verify")]
        print(f"{name:16}{len(rs):5d}{lo:9.3f}{med[name]:9.3f}  {''.join(map(_fmt, split))}  {med_nv[name]:10.3f}")
    build = {name: min_median([r.build for r in rs])[1] for name, rs in timed.items()}
    drake = "Drake" if "Drake" in timed else DRAKE_BUILD
    ratios = {"ours/Drake build": build["satfmu"] / build[drake]}
    if drake_missing is None:
        ratios.update({"ours/Drake": med["satfmu"] / med["Drake"],
                       "ours/Drake w/o verify": med_nv["satfmu"] / med_nv["Drake"]})
        if qdldl:
            ratios["ours qdldl/Drake"] = med["satfmu qdldl"] / med["Drake"]
    else:  # Drake's run takes longer than it was given
        print(f"ours/Drake < {med['satfmu'] / drake_missing.seconds:.3g} (Drake {drake_missing.reason})")
    if "SumOfSquares.py" in med:
        ratios["ours/SumOfSquares.py"] = med["satfmu"] / med["SumOfSquares.py"]
    elif sospy_missing is not None and sospy_missing.stopped:  # its run takes longer than it was given
        print(f"ours/SumOfSquares.py < {med['satfmu'] / sospy_missing.seconds:.3g} "
              f"(SumOfSquares.py {sospy_missing.reason})")
    print("ratios of medians: " + ", ".join(f"{k} {v:.3g}" for k, v in ratios.items()))
    return {"key": program.key, "grams": {k: r.gram_sizes for k, r in refs.items()},
            "objectives": {k: r.objective for k, r in refs.items()}, "median": med, "ratios": ratios,
            "build": (build["satfmu"], build[drake])}


def main(argv: list[str] | None = None) -> None:
    all_programs = programs()
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5, help="interleaved rounds (default: 5)")
    ap.add_argument("--programs", nargs="+", choices=[p.key for p in all_programs],
                    default=[p.key for p in all_programs])
    ap.add_argument("--sospy-rounds", type=int, default=1,
                    help="rounds SumOfSquares.py takes part in (default: 1; 0: left out)")
    ap.add_argument("--sospy-limit", type=float, default=600.0,
                    help="wall seconds a SumOfSquares.py run is given (default: 600)")
    ap.add_argument("--sospy-memory", type=float, default=12.0,
                    help="resident GiB a SumOfSquares.py run is given (default: 12)")
    ap.add_argument("--drake-limit", type=float, default=300.0,
                    help="wall seconds Drake's warm-up run is given; past it only its build is timed (default: 300)")
    ap.add_argument("--qdldl", action="store_true",
                    help="also time satfmu with Clarabel on QDLDL, one thread (Drake's linear algebra)")
    args = ap.parse_args(argv)
    try:
        _drake()
    except ImportError:
        raise SystemExit("Drake is not installed: pip install -e '.[bench]'") from None
    import clarabel

    print(f"satfmu: Clarabel {clarabel.__version__} (Python wheel, our arrays handed to it directly), "
          f"linear algebra: faer, one thread below a PSD cone of side {THREADED_FROM}, every core from it"
          f"{'; satfmu qdldl: QDLDL, one thread' if args.qdldl else ''}\n"
          f"Drake {metadata.version('drake')}: Clarabel through ClarabelSolver, linear algebra: QDLDL, one thread "
          f"(Drake builds Clarabel without faer and does not pass direct_solve_method)\n"
          f"SumOfSquares.py {metadata.version('SumOfSquares')}: CVXOPT {metadata.version('cvxopt')} through picos "
          f"{metadata.version('picos')}")
    t0 = time.perf_counter()
    limits = Limits(args.sospy_limit, args.sospy_memory)
    rows = [bench(p, args.repeat, args.sospy_rounds, args.qdldl, limits, args.drake_limit) for p in all_programs
            if p.key in args.programs]
    names = ["satfmu"] + (["satfmu qdldl"] if args.qdldl else []) + ["Drake", "SumOfSquares.py"]
    nan = float("nan")
    print(f"\n{'program':15}{'Gram sizes':>18}" + "".join(f"{n:>16}" for n in names)
          + f"{'ours/Drake':>11}{'ours/sos.py':>12}{'build ours':>11}{'Drake':>8}{'ratio':>7}\n"
          f"{'':33}{'(median s, end to end, verification included)':>48}")
    for r in rows:
        sizes = ",".join(map(str, r["grams"]["satfmu"]))
        ours_build, drake_build = r["build"]
        print(f"{r['key']:15}{sizes:>18}" + "".join(f"{r['median'].get(n, nan):16.3f}" for n in names)
              + f"{r['ratios'].get('ours/Drake', nan):11.3g}{r['ratios'].get('ours/SumOfSquares.py', nan):12.3g}"
              + f"{ours_build:11.3f}{drake_build:8.3f}{r['ratios']['ours/Drake build']:7.2f}")
    print(f"bench wall time {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
