"""Polynomials whose coefficients are affine in decision variables, by vectorized numpy.

A :class:`Poly` in variables ``x = (x_1..x_n)`` is a list of exponent rows
``exps`` (k x n, int) with coefficients ``c0 + C @ y``, where ``y`` is the decision
vector of an SOS program (``C`` is a k x n_y sparse matrix; a numeric polynomial has
``C = 0``). Products, sums and coefficient matching are done on these arrays, never by
symbolic expansion, so building a program costs numpy time. :class:`PolyMatrix` is a
matrix of such polynomials (entry-wise).
"""
from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations_with_replacement
from typing import Sequence

import numpy as np
import scipy.sparse as sps
import sympy as sp


def monomials(n: int, max_degree: int, min_degree: int = 0) -> np.ndarray:
    """All exponent rows of ``n`` variables with total degree in [min_degree, max_degree],
    graded (lowest degree first)."""
    rows = []
    for d in range(min_degree, max_degree + 1):
        for combo in combinations_with_replacement(range(n), d):
            e = np.zeros(n, dtype=np.int64)
            for i in combo:
                e[i] += 1
            rows.append(e)
    return np.array(rows, dtype=np.int64).reshape(-1, n)


def _merge(exps: np.ndarray, c0: np.ndarray, C: sps.spmatrix) -> tuple[np.ndarray, np.ndarray, sps.csr_matrix]:
    """Sum the coefficients of equal exponent rows."""
    if exps.shape[0] == 0:
        return exps, c0, sps.csr_matrix(C)
    uniq, inv = np.unique(exps, axis=0, return_inverse=True)
    inv = inv.ravel()
    S = sps.csr_matrix((np.ones(len(inv)), (inv, np.arange(len(inv)))), shape=(len(uniq), len(inv)))
    return uniq, S @ c0, sps.csr_matrix(S @ C)


@dataclass
class Poly:
    """A polynomial with affine coefficients ``c0 + C y`` on exponent rows ``exps``."""

    exps: np.ndarray
    c0: np.ndarray
    C: sps.csr_matrix

    @property
    def n_vars(self) -> int:
        return self.exps.shape[1]

    @property
    def n_decision(self) -> int:
        return self.C.shape[1]

    @staticmethod
    def constant(value: float, n_vars: int, n_decision: int = 0) -> "Poly":
        return Poly(np.zeros((1, n_vars), np.int64), np.array([float(value)]), sps.csr_matrix((1, n_decision)))

    @staticmethod
    def numeric(exps: np.ndarray, coefs: np.ndarray, n_decision: int = 0) -> "Poly":
        exps = np.asarray(exps, np.int64).reshape(len(coefs), -1)
        return Poly(*_merge(exps, np.asarray(coefs, float), sps.csr_matrix((len(coefs), n_decision))))

    @staticmethod
    def from_sympy(expr: sp.Expr, variables: Sequence[sp.Symbol], n_decision: int = 0) -> "Poly":
        """A numeric polynomial from a sympy expression polynomial in ``variables``.

        Raises
        ------
        ValueError
            If ``expr`` is not polynomial in ``variables`` with numeric coefficients.
        """
        p = sp.Poly(sp.expand(expr), *variables)
        if not all(c.is_number for c in p.coeffs()):
            raise ValueError(f"{expr} has non-numeric coefficients in {variables}")
        terms = p.terms() or [((0,) * len(variables), 0)]
        exps = np.array([t[0] for t in terms], np.int64)
        return Poly.numeric(exps, np.array([float(t[1]) for t in terms]), n_decision)

    def with_decision_size(self, n: int) -> "Poly":
        """The same polynomial with ``C`` padded to ``n`` decision columns."""
        if n < self.n_decision:
            raise ValueError("cannot shrink the decision vector")
        if n == self.n_decision:
            return self
        C = sps.csr_matrix((self.C.data, self.C.indices, self.C.indptr), shape=(self.C.shape[0], n))
        return Poly(self.exps, self.c0, C)

    @staticmethod
    def sum(polys: Sequence["Poly"]) -> "Poly":
        """Sum of polynomials in the same variables (one merge for all terms)."""
        if not polys:
            raise ValueError("sum of no polynomials")
        n = max(p.n_decision for p in polys)
        polys = [p.with_decision_size(n) for p in polys]
        return Poly(*_merge(np.vstack([p.exps for p in polys]), np.concatenate([p.c0 for p in polys]),
                            sps.vstack([p.C for p in polys], format="csr")))

    def __add__(self, other: "Poly | float") -> "Poly":
        if not isinstance(other, Poly):
            other = Poly.constant(float(other), self.n_vars, self.n_decision)
        if self.n_vars != other.n_vars:
            raise ValueError(f"polynomials in {self.n_vars} and {other.n_vars} variables")
        return Poly.sum([self, other])

    __radd__ = __add__

    def __neg__(self) -> "Poly":
        return Poly(self.exps, -self.c0, -self.C)

    def __sub__(self, other: "Poly | float") -> "Poly":
        return self + (-other)

    def __rsub__(self, other: float) -> "Poly":
        return (-self) + other

    def scale(self, s: float) -> "Poly":
        return Poly(self.exps, s * self.c0, (s * self.C).tocsr())

    def __mul__(self, other: "Poly | float") -> "Poly":
        if not isinstance(other, Poly):
            return self.scale(float(other))
        if self.is_affine_free() or other.is_affine_free():
            num, aff = (self, other) if self.is_affine_free() else (other, self)
            ka, kn = aff.exps.shape[0], num.exps.shape[0]
            exps = (aff.exps[:, None, :] + num.exps[None, :, :]).reshape(ka * kn, -1)
            c0 = np.outer(aff.c0, num.c0).ravel()
            C = sps.kron(aff.C, sps.csr_matrix(num.c0[:, None])).tocsr()
            return Poly(*_merge(exps, c0, C))
        raise ValueError("the product of two polynomials with decision-variable coefficients is not affine")

    __rmul__ = __mul__

    def is_affine_free(self) -> bool:
        """True when no coefficient depends on decision variables."""
        return self.C.nnz == 0

    def value(self, y: np.ndarray | None = None) -> "Poly":
        """The numeric polynomial obtained with decision values ``y``."""
        c = self.c0 if y is None or self.n_decision == 0 else self.c0 + self.C @ y[: self.n_decision]
        return Poly(self.exps, np.asarray(c, float), sps.csr_matrix((len(c), 0)))

    def evaluate(self, x: np.ndarray, y: np.ndarray | None = None) -> np.ndarray:
        """Values at points ``x`` of shape (m, n) (or (n,))."""
        c = self.value(y).c0
        x = np.atleast_2d(np.asarray(x, float))
        out = np.zeros(len(x))
        if not len(c):
            return out
        # powers x_j^d by repeated products, then one gather-multiply per variable
        chunk = max(1, 4_000_000 // max(1, len(c)))  # bounds the (m, k) temporary
        top = int(self.exps.max(initial=0))
        for i in range(0, len(x), chunk):
            xc = x[i:i + chunk]
            pw = np.ones((len(xc), self.n_vars, top + 1))
            for d in range(1, top + 1):
                pw[:, :, d] = pw[:, :, d - 1] * xc
            terms = np.ones((len(xc), len(c)))
            for j in range(self.n_vars):
                if self.exps[:, j].any():
                    terms *= pw[:, j, self.exps[:, j]]
            out[i:i + chunk] = terms @ c
        return out

    def degree(self) -> int:
        return int(self.exps.sum(axis=1).max()) if self.exps.size else 0

    def support(self, tol: float = 0.0) -> np.ndarray:
        """Exponent rows whose coefficient is not identically zero."""
        nz = (np.abs(self.c0) > tol) | (np.asarray(abs(self.C).sum(axis=1)).ravel() > 0)
        return self.exps[nz]

    def to_sympy(self, variables: Sequence[sp.Symbol], y: np.ndarray | None = None) -> sp.Expr:
        c = self.value(y).c0
        return sp.Add(*[sp.Float(ci) * sp.Mul(*[v ** int(e) for v, e in zip(variables, row)])
                        for ci, row in zip(c, self.exps) if ci != 0])


@dataclass
class PolyMatrix:
    """A matrix of :class:`Poly` entries (row-major list of lists)."""

    entries: list[list[Poly]]

    @property
    def shape(self) -> tuple[int, int]:
        return len(self.entries), len(self.entries[0])

    @staticmethod
    def from_sympy(M: sp.Matrix, variables: Sequence[sp.Symbol], n_decision: int = 0) -> "PolyMatrix":
        return PolyMatrix([[Poly.from_sympy(M[i, j], variables, n_decision) for j in range(M.shape[1])]
                           for i in range(M.shape[0])])

    def __matmul__(self, other: "PolyMatrix") -> "PolyMatrix":
        (r, k), (k2, c) = self.shape, other.shape
        if k != k2:
            raise ValueError(f"shapes {self.shape} and {other.shape} do not multiply")
        n = self.entries[0][0].n_vars
        out = []
        for i in range(r):
            out.append([Poly.sum([Poly.constant(0.0, n)] + [self.entries[i][m] * other.entries[m][j]
                                                            for m in range(k)]) for j in range(c)])
        return PolyMatrix(out)

    @staticmethod
    def constant(M: np.ndarray, n_vars: int) -> "PolyMatrix":
        """A numeric constant matrix as degree-0 polynomials in ``n_vars`` variables."""
        M = np.atleast_2d(np.asarray(M, float))
        return PolyMatrix([[Poly.constant(v, n_vars) for v in row] for row in M])

    @staticmethod
    def block(rows: Sequence[Sequence["PolyMatrix | None"]]) -> "PolyMatrix":
        """Assemble a block matrix; ``None`` is a zero block (its size from its row and column)."""
        heights = [next(b.shape[0] for b in row if b is not None) for row in rows]
        widths = [next(rows[i][j].shape[1] for i in range(len(rows)) if rows[i][j] is not None)  # type: ignore[union-attr]
                  for j in range(len(rows[0]))]
        n = next(b for row in rows for b in row if b is not None).entries[0][0].n_vars
        out: list[list[Poly]] = []
        for i, row in enumerate(rows):
            for r in range(heights[i]):
                line: list[Poly] = []
                for j, b in enumerate(row):
                    if b is None:
                        line.extend(Poly.constant(0.0, n) for _ in range(widths[j]))
                    else:
                        if b.shape != (heights[i], widths[j]):
                            raise ValueError(f"block ({i}, {j}) is {b.shape}, expected {(heights[i], widths[j])}")
                        line.extend(b.entries[r])
                out.append(line)
        return PolyMatrix(out)

    def scale(self, s: float) -> "PolyMatrix":
        return PolyMatrix([[e.scale(s) for e in row] for row in self.entries])

    def __neg__(self) -> "PolyMatrix":
        return self.scale(-1.0)

    def __sub__(self, other: "PolyMatrix") -> "PolyMatrix":
        return self + (-other)

    def __add__(self, other: "PolyMatrix") -> "PolyMatrix":
        if self.shape != other.shape:
            raise ValueError(f"shapes {self.shape} and {other.shape} do not add")
        return PolyMatrix([[a + b for a, b in zip(ra, rb)] for ra, rb in zip(self.entries, other.entries)])

    @property
    def T(self) -> "PolyMatrix":
        r, c = self.shape
        return PolyMatrix([[self.entries[i][j] for i in range(r)] for j in range(c)])

    def evaluate(self, x: np.ndarray, y: np.ndarray | None = None) -> np.ndarray:
        """Numeric matrix at one point ``x`` of shape (n,)."""
        return np.array([[float(e.evaluate(x, y)[0]) for e in row] for row in self.entries])


def quadratic_form(M: PolyMatrix) -> Poly:
    """``v^T M(x) v`` as a polynomial in ``(x, v)`` (``M`` square; ``v`` appended)."""
    r, c = M.shape
    if r != c:
        raise ValueError(f"quadratic form of a non-square {M.shape} matrix")
    n = M.entries[0][0].n_vars
    terms = [Poly.constant(0.0, n + r)]
    for i in range(r):
        for j in range(r):
            e = M.entries[i][j]
            if e.exps.shape[0] == 0:
                continue
            v = np.zeros((e.exps.shape[0], r), np.int64)
            v[:, i] += 1
            v[:, j] += 1
            terms.append(Poly(np.hstack([e.exps, v]), e.c0, e.C))
    return Poly.sum(terms)

