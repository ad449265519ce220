"""The SOS layer on textbook cases with known answers."""
from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from satfmu.synthesis.core.polynomial import Poly, PolyMatrix, monomials, quadratic_form
from satfmu.synthesis.core.sos import SOSError, SOSProgram, newton_basis, certify

x, y = sp.symbols("x y", real=True)


def test_polynomial_arithmetic_matches_sympy() -> None:
    a = Poly.from_sympy(3 * x**2 - x * y + 2, [x, y])
    b = Poly.from_sympy(x - 4 * y**3, [x, y])
    assert sp.expand((a * b).to_sympy([x, y]) - (3 * x**2 - x * y + 2) * (x - 4 * y**3)) == 0
    assert sp.expand((a - b).to_sympy([x, y]) - (3 * x**2 - x * y + 2 - x + 4 * y**3)) == 0
    pts = np.random.default_rng(0).normal(size=(20, 2))
    f = sp.lambdify((x, y), (3 * x**2 - x * y + 2) * (x - 4 * y**3))
    assert np.allclose((a * b).evaluate(pts), f(pts[:, 0], pts[:, 1]), rtol=1e-13)


def test_quadratic_form_of_a_polynomial_matrix() -> None:
    M = PolyMatrix.from_sympy(sp.Matrix([[1 + x**2, x], [x, 2]]), [x])
    q = quadratic_form(M)
    v1, v2 = sp.symbols("v1 v2")
    assert sp.expand(q.to_sympy([x, v1, v2]) - ((1 + x**2) * v1**2 + 2 * x * v1 * v2 + 2 * v2**2)) == 0


def test_newton_basis_prunes_to_the_half_polytope() -> None:
    # x^4 y^2 + x^2 y^4 + 1: candidate monomials of degree <= 3 reduce to {1, x y, x^2 y, x y^2}
    supp = np.array([[4, 2], [2, 4], [0, 0], [2, 2]])
    basis = {tuple(r) for r in newton_basis(supp)}
    assert basis == {(0, 0), (1, 1), (2, 1), (1, 2)}
    assert len(monomials(2, 3)) == 10


def _prove(expr: sp.Expr) -> tuple[SOSProgram, list]:
    prog = SOSProgram(2)
    prog.add_sos(Poly.from_sympy(expr, [x, y]), "p")
    sol = prog.solve()
    return prog, certify(prog, sol)


def test_sos_polynomial_is_certified() -> None:
    # (x^2 - y)^2 + (x y - 1)^2 + x^2 is SOS by construction
    prog, checks = _prove((x**2 - y) ** 2 + (x * y - 1) ** 2 + x**2)
    assert checks[0].certified and checks[0].exact and checks[0].min_eig > 0


def test_motzkin_polynomial_is_not_sos() -> None:
    # Motzkin: non-negative but not a sum of squares; the program must be reported infeasible
    with pytest.raises(SOSError, match=r"not solved \(infeasible\)"):
        _prove(x**4 * y**2 + x**2 * y**4 - 3 * x**2 * y**2 + 1)


def test_a_failed_solve_is_retried_on_the_policys_next_rung(monkeypatch) -> None:
    # Clarabel stopping without a solution (NumericalError) is not the end: the solve policy's
    # relaxed rung is tried, keeps the caller's settings it does not change, and its answer is used
    import satfmu.synthesis.core.sos as sos
    from satfmu.synthesis.core.conic import ConicResult
    from satfmu.synthesis.core.solve_policy import RELAXED_TOLERANCES

    seen: list[dict] = []
    real = sos.solve_clarabel

    def flaky(problem, **settings):
        seen.append(settings)
        return ConicResult("NumericalError", None, float("nan"), 0.0) if len(seen) == 1 else real(problem, **settings)

    monkeypatch.setattr(sos, "solve_clarabel", flaky)
    prog = SOSProgram(2)
    prog.add_sos(Poly.from_sympy((x**2 - y) ** 2 + x**2 + 1, [x, y]), "p")
    sol = prog.solve(max_iter=80)
    assert seen == [{"max_iter": 80}, {"max_iter": 80, **RELAXED_TOLERANCES}]
    assert sol.status == "NumericalError; retry clarabel relaxed: optimal"
    assert certify(prog, sol)[0].certified


def test_failures_on_every_rung_say_what_each_returned(monkeypatch) -> None:
    import satfmu.synthesis.core.sos as sos
    from satfmu.synthesis.core.conic import ConicResult

    monkeypatch.setattr(sos, "solve_clarabel",
                        lambda problem, **s: ConicResult("MaxIterations", None, float("nan"), 0.0))
    prog = SOSProgram(2)
    prog.add_sos(Poly.from_sympy(x**2 + y**2, [x, y]), "p")
    with pytest.raises(SOSError, match=r"not solved \(failed\): MaxIterations; retry clarabel relaxed: "
                                       r"MaxIterations; retry clarabel regularized: MaxIterations"):
        prog.solve()


def test_global_lower_bound_by_sos() -> None:
    # max g s.t. x^4 - 3 x^2 + 2 - g is SOS: the true minimum -0.25 at x^2 = 1.5 (univariate: exact)
    prog = SOSProgram(1)
    g = prog.new_variables(1)
    p = Poly.from_sympy(x**4 - 3 * x**2 + 2, [x])
    gp = Poly(np.zeros((1, 1), np.int64), np.zeros(1), prog.selector(g))
    prog.add_sos(p - gp, "p - g")
    obj = -prog.selector(g)
    sol = prog.solve(objective=obj)
    # the bound is tight (univariate: non-negative = SOS); interior-point accuracy ~1e-8
    assert sol.y[g[0]] == pytest.approx(-0.25, abs=1e-6)
    assert certify(prog, sol)[0].certified
    sol.y[g[0]] += 0.1  # tampered decision value: claims a bound above the true minimum
    check = certify(prog, sol)[0]
    assert not check.certified and check.residual == pytest.approx(0.1, rel=1e-6)


def test_lyapunov_function_for_a_nonlinear_system() -> None:
    # x' = -x + y, y' = -x^3 - y: V = x^4/2 + y^2 works; search V of degree 2..4 with
    # V - 0.01 (x^2 + y^2) SOS and -dV/dt SOS, then check V decreases along a simulation.
    prog = SOSProgram(2)
    V = prog.new_poly(monomials(2, 4, 2))
    r2 = Poly.from_sympy(x**2 + y**2, [x, y])
    prog.add_sos(V - 0.01 * r2, "V positive")
    f = [Poly.from_sympy(-x + y, [x, y]), Poly.from_sympy(-x**3 - y, [x, y])]
    Vdot = V.diff(0) * f[0] + V.diff(1) * f[1]
    prog.add_sos(-Vdot, "-dV/dt")
    sol = prog.solve()
    assert sol.solver == "CLARABEL"  # solved by the default solver, no fallback needed
    checks = certify(prog, sol)
    assert all(c.certified for c in checks), [c.to_json() for c in checks]
    from scipy.integrate import solve_ivp

    traj = solve_ivp(lambda t, s: [-s[0] + s[1], -s[0] ** 3 - s[1]], (0, 5), [1.5, -1.0], rtol=1e-9, max_step=0.05)
    vals = V.evaluate(traj.y.T, sol.y)
    assert np.all(np.diff(vals) <= 1e-9)  # non-increasing along the trajectory


def test_tampered_certificate_is_rejected() -> None:
    prog = SOSProgram(2)
    prog.add_sos(Poly.from_sympy((x**2 - y) ** 2 + (x * y - 1) ** 2 + x**2, [x, y]), "p")
    sol = prog.solve()
    key = next(iter(sol.grams))
    G = sol.grams[key]
    w, V = np.linalg.eigh(G)
    sol.grams[key] = G - (w[0] + 1e-3) * np.outer(V[:, 0], V[:, 0])  # one eigenvalue to -1e-3
    check = certify(prog, sol)[0]
    assert not check.certified and check.min_eig == pytest.approx(-1e-3, rel=1e-6)
    sol.grams[key] = G + np.eye(len(G))  # PSD but no longer z^T G z = p: residual 1 > margin
    check = certify(prog, sol)[0]
    assert not check.certified and check.residual == pytest.approx(1.0, rel=1e-6)


def test_sos_matrix_on_a_region() -> None:
    # M(x) = [[1 - x^2, 0], [0, 1]] is PSD only for |x| <= 1: infeasible globally, feasible on |x| <= 0.9
    M = PolyMatrix.from_sympy(sp.Matrix([[1 - x**2, 0], [0, 1]]), [x])
    prog = SOSProgram(1)
    prog.add_sos_matrix(M, "M")
    with pytest.raises(SOSError):
        prog.solve()
    prog = SOSProgram(1)
    ball = Poly.from_sympy(sp.Rational(81, 100) - x**2, [x])
    prog.add_sos_matrix(M, "M on |x| <= 0.9", region=[ball], multiplier_degree=0, label="|x| <= 0.9")
    sol = prog.solve()
    assert all(c.certified for c in certify(prog, sol))


def test_verify_expands_the_polynomials_without_the_programs_matching_map(monkeypatch) -> None:
    # the residual is p - z^T G z expanded from the polynomials: neither the conic data nor
    # the integer exponent keys the build matched coefficients with take part
    p = (x**2 - y) ** 2 + (x * y - 1) ** 2 + x**2
    prog = SOSProgram(2)
    prog.add_sos(Poly.from_sympy(p, [x, y]), "p")
    sol = prog.solve()
    key = next(iter(sol.grams))
    G = sol.grams[key] + 1e-3 * np.eye(len(sol.grams[key]))  # residual 1e-3 on the squares

    def no_build(*args, **kwargs):
        raise AssertionError("verify used the build path")

    monkeypatch.setattr(SOSProgram, "conic_problem", no_build)
    monkeypatch.setattr("satfmu.synthesis.core.exponents.keys", no_build)
    monkeypatch.setattr("satfmu.synthesis.core.sos.keys", no_build)
    sol.grams[key] = G
    z = sp.Matrix([sp.Mul(*[v**int(e) for v, e in zip((x, y), row)]) for row in prog.sos[0].basis])
    diff = sp.Poly(sp.expand(p - (z.T * sp.Matrix(G) * z)[0]), x, y)
    check = certify(prog, sol)[0]
    assert check.residual == pytest.approx(max(abs(float(c)) for c in diff.coeffs()), rel=1e-9)
    assert check.residual == pytest.approx(1e-3, rel=1e-6) and not check.certified


def _odd_lyapunov(sign_symmetry: bool) -> tuple[SOSProgram, list]:
    # x' = -x + y, y' = -x^3 - y is odd, so a V of even monomials (degrees 2 and 4) keeps the joint
    # flip (x, y) -> (-x, -y): every Gram basis splits into its odd and even monomials.
    # V - 0.01 |x|^2 and -dV/dt - 0.01 |x|^2 SOS
    prog = SOSProgram(2, sign_symmetry=sign_symmetry)
    V = prog.new_poly(np.vstack([monomials(2, 2, 2), monomials(2, 4, 4)]))
    r2 = Poly.from_sympy(x**2 + y**2, [x, y])
    prog.add_sos(V - 0.01 * r2, "V positive")
    f = [Poly.from_sympy(-x + y, [x, y]), Poly.from_sympy(-x**3 - y, [x, y])]
    prog.add_sos(-(V.diff(0) * f[0] + V.diff(1) * f[1]) - 0.01 * r2, "-dV/dt")
    sol = prog.solve()
    return prog, sol


def test_sign_symmetry_splits_the_gram_matrices_of_a_lyapunov_search() -> None:
    split, sol = _odd_lyapunov(True)
    whole, _ = _odd_lyapunov(False)
    assert [[len(b) for b in c.blocks] for c in split.sos] == [[2, 3], [4, 3]]
    assert [[len(b) for b in c.blocks] for c in whole.sos] == [[5], [7]]
    # the blocks' certificate is verified on the original program: full Gram matrices, zero
    # between the blocks, residuals expanded from the polynomials
    checks = certify(split, sol)
    assert all(c.certified for c in checks), [c.to_json() for c in checks]
    G = sol.grams["1:-dV/dt"]
    odd, even = split.sos[1].blocks
    assert G.shape == (7, 7) and not G[np.ix_(odd, even)].any()


@pytest.mark.parametrize("sign_symmetry", [True, False])
def test_sign_symmetry_keeps_the_optimum(sign_symmetry: bool) -> None:
    # max g s.t. p - g SOS, p = x^4 + y^4 + x^2 y^2 - 3 x^2 - 2 y^2: even in x and in y, so the basis
    # (1, x, y, x^2, x y, y^2) splits by the parities of its exponents into {1, x^2, y^2}, {x}, {y},
    # {x y}. A bivariate quartic is non-negative iff SOS (Hilbert): the bound is the true minimum,
    # found on a fine grid (the grid's spacing 1e-3 puts it within ~1e-6 of the minimum).
    prog = SOSProgram(2, sign_symmetry=sign_symmetry)
    g = prog.new_variables(1)
    p = Poly.from_sympy(x**4 + y**4 + x**2 * y**2 - 3 * x**2 - 2 * y**2, [x, y], n_decision=1)
    prog.add_sos(p - Poly(np.zeros((1, 2), np.int64), np.zeros(1), prog.selector(g)), "p - g")
    sol = prog.solve(objective=-prog.selector(g))
    blocks = sorted(len(b) for b in prog.sos[0].blocks)
    assert blocks == ([1, 1, 1, 3] if sign_symmetry else [6])
    assert certify(prog, sol)[0].certified
    t = np.linspace(-2, 2, 4001)
    X, Y = np.meshgrid(t, t)
    true_min = float((X**4 + Y**4 + X**2 * Y**2 - 3 * X**2 - 2 * Y**2).min())
    assert sol.y[g[0]] == pytest.approx(true_min, abs=1e-5)
