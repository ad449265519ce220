"""Polynomial matrices as one term table: every operation against a term-by-term reference."""
from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sps
import sympy as sp

from satfmu.synthesis.core import exponents
from satfmu.synthesis.core.polynomial import Poly, PolyMatrix, quadratic_form

Terms = dict[tuple[int, ...], np.ndarray]
"""Reference polynomial: exponent tuple -> [c0, C row...] (dense)."""


def _random_poly(rng: np.random.Generator, n_vars: int, n_y: int, affine: bool, max_exp: int = 3) -> Poly:
    k = int(rng.integers(0, 5))
    exps = rng.integers(0, max_exp + 1, size=(k, n_vars))
    c0 = rng.normal(size=k) * (rng.random(k) < 0.8)
    C = sps.random(k, n_y, density=0.3, random_state=rng, format="csr") if affine else sps.csr_matrix((k, n_y))
    return Poly(exps, c0, C)


def _terms(p: Poly, n_y: int) -> Terms:
    out: Terms = {}
    C = p.C.toarray()
    for e, c, row in zip(p.exps, p.c0, C):
        v = out.setdefault(tuple(int(x) for x in e), np.zeros(1 + n_y))
        v[0] += c
        v[1:1 + len(row)] += row
    return out


def _same(a: Terms, b: Terms) -> bool:
    return all(np.allclose(a.get(k, 0.0), b.get(k, 0.0), atol=1e-12) for k in set(a) | set(b))


def _ref_product(a: Terms, b: Terms) -> Terms:
    out: Terms = {}
    for ea, va in a.items():
        for eb, vb in b.items():
            v = out.setdefault(tuple(x + y for x, y in zip(ea, eb)), np.zeros_like(va))
            v[0] += va[0] * vb[0]
            v[1:] += va[0] * vb[1:] + vb[0] * va[1:]
    return out


def _ref_sum(parts: list[Terms]) -> Terms:
    out: Terms = {}
    for t in parts:
        for e, v in t.items():
            out[e] = out.get(e, 0.0) + v
    return out


def _matrix(rng: np.random.Generator, shape: tuple[int, int], n_vars: int, n_y: int, affine: bool,
            max_exp: int = 3) -> PolyMatrix:
    return PolyMatrix([[_random_poly(rng, n_vars, n_y, affine, max_exp) for _ in range(shape[1])]
                       for _ in range(shape[0])])


@pytest.mark.parametrize("n_vars,max_exp", [(3, 3), (40, 6)], ids=["mixed radix", "keys compressed"])
def test_matrix_product_sum_and_transpose_match_the_reference(n_vars: int, max_exp: int) -> None:
    # 40 variables of exponent up to 12 in the product: 13^40 overflows int64, the keys compress
    rng = np.random.default_rng(3)
    n_y = 7
    A = _matrix(rng, (3, 4), n_vars, n_y, affine=False, max_exp=max_exp)
    B = _matrix(rng, (4, 2), n_vars, n_y, affine=True, max_exp=max_exp)
    assert (exponents.weights(np.full(n_vars, 2 * max_exp + 1), 6) is None) == (n_vars == 40)
    P = A @ B
    for i in range(3):
        for j in range(2):
            ref = _ref_sum([_ref_product(_terms(A.entries[i][m], n_y), _terms(B.entries[m][j], n_y))
                            for m in range(4)])
            assert _same(_terms(P.entries[i][j], n_y), ref)
            assert _same(_terms(P.T.entries[j][i], n_y), ref)
            # a merged entry: distinct exponent rows in lexicographic order
            rows = [tuple(r) for r in P.entries[i][j].exps]
            assert rows == sorted(set(rows))
    S = P + P.scale(-0.5)
    assert all(_same(_terms(S.entries[i][j], n_y), {e: 0.5 * v for e, v in _terms(P.entries[i][j], n_y).items()})
               for i in range(3) for j in range(2))


def test_product_of_two_affine_entries_is_refused() -> None:
    rng = np.random.default_rng(0)
    A = PolyMatrix([[Poly(np.zeros((1, 2), np.int64), np.ones(1), sps.csr_matrix(np.ones((1, 3))))]])
    with pytest.raises(ValueError, match="not affine"):
        A @ A
    assert (A @ _matrix(rng, (1, 2), 2, 3, affine=False)).shape == (1, 2)


def test_quadratic_form_block_and_symmetric_part_match_the_reference() -> None:
    rng = np.random.default_rng(5)
    n_y = 4
    M = _matrix(rng, (3, 3), 2, n_y, affine=True)
    q = quadratic_form(M)
    ref = _ref_sum([{e + tuple(int(k == i) + int(k == j) for k in range(3)): v
                     for e, v in _terms(M.entries[i][j], n_y).items()} for i in range(3) for j in range(3)])
    assert _same(_terms(q, n_y), ref)
    L = M.symmetric_from_lower()
    assert all(_same(_terms(L.entries[i][j], n_y), _terms(M.entries[max(i, j)][min(i, j)], n_y))
               for i in range(3) for j in range(3))
    Z = PolyMatrix.constant(np.array([[0.0, 2.0], [3.0, 0.0]]), 2)
    Bk = PolyMatrix.block([[M, None], [None, Z]])
    assert Bk.shape == (5, 5) and Bk.entries[3][1].exps.shape[0] == 0
    assert _same(_terms(Bk.entries[1][2], n_y), _terms(M.entries[1][2], n_y))
    assert _same(_terms(Bk.entries[4][3], n_y), {(0, 0): np.r_[3.0, np.zeros(n_y)]})


def test_substitute_and_evaluate_agree_with_sympy() -> None:
    a, c, w, s, t = sp.symbols("a c w s t")
    M = sp.Matrix([[1 + a**2 * c - 3 * w, a * w**2], [0, c**3 + 2 * a * c * w]])
    subs = {a: sp.Rational(1, 2) + s / 5, c: 1 - (s + t) / 3, w: t / 10 - sp.Rational(2, 5)}
    P = PolyMatrix.from_sympy(M, [a, c, w]).substitute([Poly.from_sympy(subs[v], [s, t]) for v in (a, c, w)])
    f = sp.lambdify((s, t), M.subs(subs))
    for x in np.random.default_rng(0).normal(size=(10, 2)):
        assert np.allclose(P.evaluate(x), np.array(f(*x), float), rtol=1e-13, atol=1e-13)


def test_keys_order_rows_lexicographically() -> None:
    rng = np.random.default_rng(1)
    rows = rng.integers(0, 2**20, size=(500, 5))  # (2^20)^5 > 2^62: compressed on the way
    k = exponents.keys(rows)
    assert [tuple(r) for r in rows[np.argsort(k, kind="stable")]] == sorted(tuple(r) for r in rows)
    assert len(np.unique(k)) == len({tuple(r) for r in rows})
    w = exponents.weights(np.full(3, 10))
    assert w is not None and list(w) == [100, 10, 1]  # mixed radix: keys add as exponents do


def test_partial_derivative_matches_sympy_with_decision_coefficients() -> None:
    x, y = sp.symbols("x y")
    p = Poly.from_sympy(3 * x**3 * y - x * y**2 + 5 * y + 2, [x, y], n_decision=2)
    p = p + Poly(np.array([[2, 1], [0, 0]]), np.zeros(2), sps.csr_matrix(np.array([[1.0, 0.0], [0.0, 4.0]])))
    dec = np.array([0.5, -2.0])  # p = 3 x^3 y - x y^2 + 5 y + 2 + 0.5 x^2 y - 8
    expr = 3 * x**3 * y - x * y**2 + 5 * y + 2 + dec[0] * x**2 * y + 4 * dec[1]
    for i, v in enumerate((x, y)):
        d = p.diff(i)
        assert d.n_decision == 2  # still affine in the same decision variables
        assert sp.expand(d.to_sympy([x, y], dec) - sp.diff(expr, v)) == 0
    const = Poly.constant(2.0, 2, 3).diff(1)
    assert const.n_vars == 2 and const.n_decision == 3 and not const.evaluate(np.ones((1, 2))).any()
    with pytest.raises(IndexError, match="variable 2 of a polynomial in 2"):
        p.diff(2)


_X, _Y, _Z = sp.symbols("x y z", real=True)


@pytest.mark.parametrize("expr", [
    3 * _X, -_X, sp.Integer(0), _X - _X, sp.Float(2.5) * _X**2 * sp.pi, sp.sqrt(2) * _X, _X**2 * sp.Rational(1, 3),
    -_X * _Y**3 * _Z + 0.1, (_X + 1) ** 3 * (_Y - 2), sp.exp(2) * _X, 2 ** sp.Rational(1, 3) * _X * _Y,
    (0.3 * _X + 1e-20 * _Y) ** 2, 1e300 * _X, -sp.Float("1e-300") * _Z**7, sp.Float("0.1", 40) * _Y,
])
def test_from_sympy_reads_the_terms_sympy_poly_finds(expr: sp.Expr) -> None:
    """The term reader against ``sympy.Poly`` (floats to 1 ulp: both round each coefficient once)."""
    variables = [_X, _Y, _Z]
    p = Poly.from_sympy(expr, variables)
    ref = {t: float(c) for t, c in sp.Poly(expr, *variables).terms() if c != 0}
    got = {tuple(int(v) for v in e): c for e, c in zip(p.exps, p.c0) if c != 0.0}
    assert set(got) == set(ref)
    for t, c in ref.items():
        assert got[t] == pytest.approx(c, rel=2.3e-16, abs=0.0)
    M = PolyMatrix.from_sympy(sp.Matrix([[expr, _X], [1, expr * _Y]]), variables)
    assert M.entries[0][0].exps.tolist() == p.exps.tolist() and M.entries[0][0].c0.tolist() == p.c0.tolist()
    assert M.entries[1][1].evaluate(np.array([[0.3, -0.7, 1.1]]))[0] == pytest.approx(
        float((expr * _Y).subs({_X: 0.3, _Y: -0.7, _Z: 1.1})), rel=1e-12, abs=1e-300)


@pytest.mark.parametrize("expr, message", [
    (sp.sin(_X), "non-numeric"), (1 / _X, "not a polynomial"), (sp.sqrt(_X), "not a polynomial"),
    (_X**_Y, "not a polynomial"), (_X * sp.Symbol("a"), "non-numeric"), (sp.nan * _X, "not finite"),
    (sp.oo * _X, "not finite"), (sp.I * _X, "not real"), (2**_X, "non-numeric"),
])
def test_from_sympy_refuses_what_is_not_a_real_polynomial(expr: sp.Expr, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        Poly.from_sympy(expr, [_X, _Y])
    with pytest.raises(ValueError, match=message):
        PolyMatrix.from_sympy(sp.Matrix([[1, expr]]), [_X, _Y])
