"""Polynomials whose coefficients are affine in decision variables, by vectorized numpy.

A :class:`Poly` in variables ``x = (x_1..x_n)`` is a list of exponent rows
``exps`` (k x n, int) with coefficients ``c0 + C @ y``, where ``y`` is the decision
vector of an SOS program (``C`` is a k x n_y sparse matrix; a numeric polynomial has
``C = 0``). Products, sums and coefficient matching are done on these arrays, never by
symbolic expansion, so building a program costs numpy time.

A :class:`PolyMatrix` holds all its entries' terms in one table (the entry of each term
beside its exponent row and coefficients), so a matrix product, a sum or a quadratic
form is a few array operations whatever the matrix size: a product pairs every term of
row ``i`` of the left factor with every term of column ``j`` of the right one by index
arithmetic, adds their exponent keys (:mod:`satfmu.synthesis.core.exponents`) and merges equal
``(entry, exponent)`` keys with one sparse summation.
"""
from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations_with_replacement
from typing import NamedTuple, Sequence

import numpy as np
import scipy.sparse as sps
import sympy as sp

from satfmu.synthesis.core.exponents import keys, weights


def monomials(n: int, max_degree: int, min_degree: int = 0) -> np.ndarray:
    """All exponent rows of ``n`` variables with total degree in [min_degree, max_degree],
    graded (lowest degree first).

    Parameters
    ----------
    n : int
        Number of variables.
    max_degree : int
        Largest total degree.
    min_degree : int, optional
        Smallest total degree. Default 0.

    Returns
    -------
    numpy.ndarray of int, shape (k, n)
        One exponent row per monomial (none if ``min_degree > max_degree``).
    """
    rows = []
    for d in range(min_degree, max_degree + 1):
        for combo in combinations_with_replacement(range(n), d):
            e = np.zeros(n, dtype=np.int64)
            for i in combo:
                e[i] += 1
            rows.append(e)
    return np.array(rows, dtype=np.int64).reshape(-1, n)


def _csr(C: sps.spmatrix, width: int) -> sps.csr_matrix:
    """``C`` as CSR with ``width`` columns (padded with empty columns)."""
    C = C if isinstance(C, sps.csr_matrix) else sps.csr_matrix(C)
    if C.shape[1] == width:
        return C
    if C.shape[1] > width:
        raise ValueError("cannot shrink the decision vector")
    return sps.csr_matrix((C.data, C.indices, C.indptr), shape=(C.shape[0], width))


def _vstack(mats: Sequence[sps.spmatrix], width: int) -> sps.csr_matrix:
    """Row-stack CSR matrices of at most ``width`` columns (one concatenation of their arrays)."""
    mats = [_csr(m, width) for m in mats]
    nnz = np.cumsum([0] + [m.nnz for m in mats])
    indptr = np.concatenate([[0]] + [m.indptr[1:] + off for m, off in zip(mats, nnz)])
    data = np.concatenate([m.data for m in mats]) if mats else np.zeros(0)
    indices = np.concatenate([m.indices for m in mats]) if mats else np.zeros(0, np.int32)
    return sps.csr_matrix((data, indices, indptr), shape=(len(indptr) - 1, width))


def _sympy_terms(expr: sp.Expr, index: dict[sp.Symbol, int]) -> tuple[np.ndarray, np.ndarray]:
    """Exponent rows and coefficients of the expanded ``expr``, a polynomial in the symbols of
    ``index`` (symbol -> exponent column) with numeric coefficients.

    Read term by term from sympy's expanded sum (a ``sympy.Poly`` per entry infers a domain
    and costs ~0.5 ms; this ~20 us): each term is a number times powers of the variables.

    Raises
    ------
    ValueError
        If a term has a variable to a power that is not a non-negative integer, a factor that
        is neither a variable power nor a number, or a coefficient that is not a finite real.
    """
    expr = sp.sympify(expr)
    exps, coefs = [], []
    for term in sp.Add.make_args(sp.expand(expr)):
        row = [0] * len(index)
        numeric = []
        for base, power in term.as_powers_dict().items():
            i = index.get(base)
            if i is None:
                numeric.append(sp.Pow(base, power))
            elif power.is_Integer and power >= 0:
                row[i] += int(power)
            else:
                raise ValueError(f"{expr} is not a polynomial in {list(index)}: {base}**{power}")
        coef = sp.Mul(*numeric)
        if not coef.is_number:
            raise ValueError(f"{expr} has non-numeric coefficients in {list(index)}: {coef}")
        try:
            value = float(coef)
        except TypeError:
            raise ValueError(f"{expr} has a coefficient that is not real: {coef}") from None
        if not np.isfinite(value):
            raise ValueError(f"{expr} has a coefficient that is not finite: {coef}")
        exps.append(row)
        coefs.append(value)
    return np.array(exps, np.int64).reshape(len(coefs), len(index)), np.array(coefs, float)


class _Terms(NamedTuple):
    """Terms of a polynomial matrix: entry index (row-major), exponent row, ``c0``, ``C`` row."""

    entry: np.ndarray
    exps: np.ndarray
    c0: np.ndarray
    C: sps.csr_matrix


def _merge(t: _Terms) -> _Terms:
    """Sum the coefficients of equal ``(entry, exponent row)``; sorted by entry, then
    exponent row lexicographically."""
    if len(t.entry) == 0:
        return t
    key = keys(np.column_stack([t.entry, t.exps]))
    _, first, inv = np.unique(key, return_index=True, return_inverse=True)
    if len(first) == len(inv) and np.array_equal(first, np.arange(len(first))):
        return t  # already distinct and in order
    if t.C.nnz == 0:  # numeric coefficients
        C = sps.csr_matrix((len(first), t.C.shape[1]))
    else:
        C = sps.csr_matrix((np.ones(len(inv)), (inv, np.arange(len(inv)))), shape=(len(first), len(inv))) @ t.C
    return _Terms(t.entry[first], t.exps[first], np.bincount(inv, t.c0, len(first)), C)


def _ragged_arange(counts: np.ndarray) -> np.ndarray:
    """``concatenate([arange(c) for c in counts])`` without the loop."""
    ends = np.cumsum(counts)
    return np.arange(ends[-1] if len(ends) else 0) - np.repeat(ends - counts, counts)


def _product(left: _Terms, right: _Terms, shape: tuple[int, int, int]) -> _Terms:
    """Terms of the matrix product of ``left`` (r x k) and ``right`` (k x c), merged.

    Every term of entry ``(i, m)`` on the left is paired with every term of entry
    ``(m, j)`` on the right (output entry ``(i, j)``): exponents add, ``c0`` multiply and
    ``C`` rows combine as ``c0_l C_r + c0_r C_l`` (affine as long as no pair has decision
    variables on both sides).

    Raises
    ------
    ValueError
        If some pair of entries both depend on decision variables.
    """
    r, k, c = shape
    if left.exps.shape[1] != right.exps.shape[1]:
        raise ValueError(f"polynomials in {left.exps.shape[1]} and {right.exps.shape[1]} variables")
    width = max(left.C.shape[1], right.C.shape[1])
    mid_l, mid_r = left.entry % k, right.entry // c
    order_l = np.argsort(mid_l, kind="stable")
    order_r = np.argsort(mid_r, kind="stable")
    count_r = np.bincount(mid_r, minlength=k)
    start_r = np.cumsum(count_r) - count_r
    per_l = count_r[mid_l[order_l]]
    pl = np.repeat(order_l, per_l)
    pr = order_r[np.repeat(start_r[mid_l[order_l]], per_l) + _ragged_arange(per_l)]
    n_vars = left.exps.shape[1]
    if len(pl) == 0:
        return _Terms(np.zeros(0, np.int64), np.zeros((0, n_vars), np.int64), np.zeros(0),
                      sps.csr_matrix((0, width)))
    if np.any((np.diff(left.C.indptr) > 0)[pl] & (np.diff(right.C.indptr) > 0)[pr]):
        raise ValueError("the product of two polynomials with decision-variable coefficients is not affine")
    entry = (left.entry[pl] // k) * c + right.entry[pr] % c
    bound = left.exps.max(axis=0) + right.exps.max(axis=0) + 1
    w = weights(bound, r * c)
    if w is not None:  # exponent keys add; the entry is the leading digit
        key = entry * (int(w[0]) * int(bound[0])) + (left.exps @ w)[pl] + (right.exps @ w)[pr]
    else:
        key = keys(np.column_stack([entry, left.exps[pl] + right.exps[pr]]))
    _, first, inv = np.unique(key, return_index=True, return_inverse=True)
    u = len(first)
    S_l = sps.csr_matrix((right.c0[pr], (inv, pl)), shape=(u, len(left.entry)))
    S_r = sps.csr_matrix((left.c0[pl], (inv, pr)), shape=(u, len(right.entry)))
    C = S_l @ _csr(left.C, width) + S_r @ _csr(right.C, width)
    return _Terms(entry[first], left.exps[pl[first]] + right.exps[pr[first]],
                  np.bincount(inv, left.c0[pl] * right.c0[pr], u), sps.csr_matrix(C))


@dataclass
class Poly:
    """A polynomial with affine coefficients ``c0 + C y`` on exponent rows ``exps``.

    Attributes
    ----------
    exps : numpy.ndarray of int, shape (k, n)
        Exponent rows, one per term, one column per variable.
    c0 : numpy.ndarray, shape (k,)
        Constant part of each term's coefficient.
    C : scipy.sparse.csr_matrix, shape (k, n_y)
        Decision-variable part of each term's coefficient (``n_y`` columns: the decision
        variables existing when the polynomial was made; 0 for a numeric polynomial).
    """

    exps: np.ndarray
    c0: np.ndarray
    C: sps.csr_matrix

    @property
    def n_vars(self) -> int:
        """Number of polynomial variables (columns of ``exps``)."""
        return self.exps.shape[1]

    @property
    def n_decision(self) -> int:
        """Number of decision variables the coefficients refer to (columns of ``C``)."""
        return self.C.shape[1]

    def _terms(self) -> _Terms:
        return _Terms(np.zeros(len(self.c0), np.int64), self.exps, self.c0, _csr(self.C, self.n_decision))

    @staticmethod
    def _of(t: _Terms) -> "Poly":
        return Poly(t.exps, t.c0, t.C)

    @staticmethod
    def constant(value: float, n_vars: int, n_decision: int = 0) -> "Poly":
        """The constant polynomial ``value`` (one degree-0 term).

        Parameters
        ----------
        value : float
            The constant.
        n_vars : int
            Number of variables.
        n_decision : int, optional
            Number of decision-variable columns of ``C`` (all zero). Default 0.
        """
        return Poly(np.zeros((1, n_vars), np.int64), np.array([float(value)]), sps.csr_matrix((1, n_decision)))

    @staticmethod
    def numeric(exps: np.ndarray, coefs: np.ndarray, n_decision: int = 0) -> "Poly":
        """A polynomial with numeric coefficients; terms with equal exponent rows are summed.

        Parameters
        ----------
        exps : numpy.ndarray of int, shape (k, n)
            Exponent rows of the terms.
        coefs : numpy.ndarray, shape (k,)
            Their coefficients.
        n_decision : int, optional
            Number of decision-variable columns of ``C`` (all zero). Default 0.
        """
        exps = np.asarray(exps, np.int64).reshape(len(coefs), -1)
        return Poly._of(_merge(_Terms(np.zeros(len(coefs), np.int64), exps, np.asarray(coefs, float),
                                      sps.csr_matrix((len(coefs), n_decision)))))

    @staticmethod
    def from_sympy(expr: sp.Expr, variables: Sequence[sp.Symbol], n_decision: int = 0) -> "Poly":
        """A numeric polynomial from a sympy expression polynomial in ``variables``.

        Parameters
        ----------
        expr : sympy.Expr
            The expression, polynomial in ``variables`` with numeric coefficients.
        variables : sequence of sympy.Symbol
            The variables, in the order of the exponent columns.
        n_decision : int, optional
            Number of decision-variable columns of ``C`` (all zero). Default 0.

        Raises
        ------
        ValueError
            If ``expr`` is not polynomial in ``variables`` with numeric coefficients.
        """
        exps, coefs = _sympy_terms(expr, {v: i for i, v in enumerate(variables)})
        return Poly.numeric(exps, coefs, n_decision)

    def with_decision_size(self, n: int) -> "Poly":
        """The same polynomial with ``C`` padded to ``n`` decision columns.

        Parameters
        ----------
        n : int
            Number of decision variables, at least :attr:`n_decision`.

        Raises
        ------
        ValueError
            If ``n`` is smaller than the current count.
        """
        if n < self.n_decision:
            raise ValueError("cannot shrink the decision vector")
        return self if n == self.n_decision else Poly(self.exps, self.c0, _csr(self.C, n))

    @staticmethod
    def sum(polys: Sequence["Poly"]) -> "Poly":
        """Sum of polynomials in the same variables (one merge for all terms).

        Parameters
        ----------
        polys : sequence of Poly
            The polynomials (at least one), in the same variables.

        Raises
        ------
        ValueError
            If ``polys`` is empty.
        """
        if not polys:
            raise ValueError("sum of no polynomials")
        n = max(p.n_decision for p in polys)
        return Poly._of(_merge(_Terms(np.zeros(sum(len(p.c0) for p in polys), np.int64),
                                      np.vstack([p.exps for p in polys]), np.concatenate([p.c0 for p in polys]),
                                      _vstack([p.C for p in polys], n))))

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
        """The polynomial times the number ``s`` (constant and decision parts alike).

        Parameters
        ----------
        s : float
            The factor.
        """
        return Poly(self.exps, s * self.c0, (s * self.C).tocsr())

    def __mul__(self, other: "Poly | float") -> "Poly":
        if not isinstance(other, Poly):
            return self.scale(float(other))
        return Poly._of(_product(self._terms(), other._terms(), (1, 1, 1)))

    __rmul__ = __mul__

    def diff(self, i: int) -> "Poly":
        """The partial derivative with respect to variable ``i`` (coefficients stay affine in
        the decision variables: ``d/dx_i (c0 + C y) x^e = e_i (c0 + C y) x^(e - 1_i)``).

        Parameters
        ----------
        i : int
            Index of the variable, ``0 <= i < n_vars``.

        Raises
        ------
        IndexError
            If there is no variable ``i``.
        """
        if not 0 <= i < self.n_vars:
            raise IndexError(f"variable {i} of a polynomial in {self.n_vars} variables")
        factor = self.exps[:, i].astype(float)
        keep = np.flatnonzero(factor > 0)
        if keep.size == 0:
            return Poly.constant(0.0, self.n_vars, self.n_decision)
        exps = self.exps[keep].copy()
        exps[:, i] -= 1
        return Poly(exps, self.c0[keep] * factor[keep], sps.diags(factor[keep]) @ _csr(self.C, self.n_decision)[keep])

    def is_affine_free(self) -> bool:
        """True when no coefficient depends on decision variables."""
        return self.C.nnz == 0

    def value(self, y: np.ndarray | None = None) -> "Poly":
        """The numeric polynomial obtained with decision values ``y``.

        Parameters
        ----------
        y : numpy.ndarray, shape (n_y,), optional
            Decision values (at least :attr:`n_decision` of them; extra ones are ignored);
            None: the constant part ``c0`` alone.
        """
        c = self.c0 if y is None or self.n_decision == 0 else self.c0 + self.C @ y[: self.n_decision]
        return Poly(self.exps, np.asarray(c, float), sps.csr_matrix((len(c), 0)))

    def evaluate(self, x: np.ndarray, y: np.ndarray | None = None) -> np.ndarray:
        """Values at points ``x`` of shape (m, n) (or (n,)).

        Parameters
        ----------
        x : numpy.ndarray, shape (m, n) or (n,)
            The points, one per row.
        y : numpy.ndarray, shape (n_y,), optional
            Decision values (:meth:`value`); None: the constant part ``c0``.

        Returns
        -------
        numpy.ndarray, shape (m,)
        """
        c = self.value(y).c0
        x = np.atleast_2d(np.asarray(x, float))
        out = np.zeros(len(x))
        # points per block: the (block, k) temporaries stay near 1 MB, inside a core's cache
        # (twice as fast as one pass over 2000 points for the seed 000 certificate's 588 terms)
        chunk = max(1, 131_072 // max(1, len(c)))
        for i in range(0, len(x), chunk):
            out[i:i + chunk] = _term_values(self.exps, x[i:i + chunk]) @ c
        return out

    def degree(self) -> int:
        """Largest total degree of a term (0 for a polynomial without terms)."""
        return int(self.exps.sum(axis=1).max()) if self.exps.size else 0

    def support(self, tol: float = 0.0) -> np.ndarray:
        """Exponent rows whose coefficient is not identically zero.

        Parameters
        ----------
        tol : float, optional
            A term with ``|c0| <= tol`` and no decision-variable part counts as zero.
            Default 0.
        """
        nz = (np.abs(self.c0) > tol) | (np.asarray(abs(self.C).sum(axis=1)).ravel() > 0)
        return self.exps[nz]

    def to_sympy(self, variables: Sequence[sp.Symbol], y: np.ndarray | None = None) -> sp.Expr:
        """The polynomial as a sympy expression (numeric coefficients, zero terms dropped).

        Parameters
        ----------
        variables : sequence of sympy.Symbol
            One symbol per variable, in column order.
        y : numpy.ndarray, shape (n_y,), optional
            Decision values (:meth:`value`); None: the constant part ``c0``.
        """
        c = self.value(y).c0
        return sp.Add(*[sp.Float(ci) * sp.Mul(*[v ** int(e) for v, e in zip(variables, row)])
                        for ci, row in zip(c, self.exps) if ci != 0])


def _term_values(exps: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Monomial values ``x^e`` (m x k) of the points ``x`` (m x n) for exponent rows ``exps``
    (k x n): powers by repeated products, then one gather-multiply per variable."""
    terms = np.ones((len(x), len(exps)))
    if not len(exps):
        return terms
    top = int(exps.max(initial=0))
    pw = np.ones((len(x), exps.shape[1], top + 1))
    for d in range(1, top + 1):
        pw[:, :, d] = pw[:, :, d - 1] * x
    for j in range(exps.shape[1]):
        if exps[:, j].any():
            terms *= pw[:, j, exps[:, j]]
    return terms


class PolyMatrix:
    """A matrix of :class:`Poly` entries, held as one table of terms.

    Built from a row-major list of lists of :class:`Poly` (``PolyMatrix(entries)``) or by
    the operations below; :attr:`entries` gives the polynomials back.

    Parameters
    ----------
    entries : sequence of sequence of Poly
        The rows of the matrix, equally long and non-empty, all entries in the same
        variables.

    Raises
    ------
    ValueError
        If the rows are empty or differ in length.
    """

    __slots__ = ("shape", "_t", "_entries")

    def __init__(self, entries: Sequence[Sequence[Poly]]) -> None:
        rows = [list(row) for row in entries]
        if not rows or not rows[0] or any(len(row) != len(rows[0]) for row in rows):
            raise ValueError("a polynomial matrix needs equally long, non-empty rows")
        flat = [p for row in rows for p in row]
        counts = [len(p.c0) for p in flat]
        self.shape = (len(rows), len(rows[0]))
        self._t = _Terms(np.repeat(np.arange(len(flat)), counts), np.vstack([p.exps for p in flat]),
                         np.concatenate([p.c0 for p in flat]), _vstack([p.C for p in flat],
                                                                       max(p.n_decision for p in flat)))
        self._entries: list[list[Poly]] | None = rows

    @classmethod
    def _of(cls, shape: tuple[int, int], t: _Terms) -> "PolyMatrix":
        """A matrix from its terms (sorted by entry)."""
        out = cls.__new__(cls)
        out.shape, out._t, out._entries = shape, t, None
        return out

    @property
    def n_vars(self) -> int:
        """Number of polynomial variables of the entries."""
        return self._t.exps.shape[1]

    @property
    def entries(self) -> list[list[Poly]]:
        """The entries as polynomials (row-major list of lists)."""
        if self._entries is None:
            r, c = self.shape
            t = self._t
            start = np.searchsorted(t.entry, np.arange(r * c + 1))
            flat = [Poly(t.exps[a:b], t.c0[a:b], t.C[a:b]) for a, b in zip(start[:-1], start[1:])]
            self._entries = [flat[i * c:(i + 1) * c] for i in range(r)]
        return self._entries

    @staticmethod
    def from_sympy(M: sp.Matrix, variables: Sequence[sp.Symbol], n_decision: int = 0) -> "PolyMatrix":
        """A numeric polynomial matrix from a sympy matrix (each entry read as :meth:`Poly.from_sympy` reads it).

        Parameters
        ----------
        M : sympy.Matrix
            Entries polynomial in ``variables`` with numeric coefficients.
        variables : sequence of sympy.Symbol
            The variables, in the order of the exponent columns.
        n_decision : int, optional
            Number of decision-variable columns (all zero). Default 0.

        Raises
        ------
        ValueError
            If ``M`` is empty or an entry is not polynomial in ``variables`` with numeric coefficients.
        """
        r, c = M.shape
        if r == 0 or c == 0:
            raise ValueError("a polynomial matrix needs equally long, non-empty rows")
        index = {v: i for i, v in enumerate(variables)}
        parts = [_sympy_terms(M[i, j], index) for i in range(r) for j in range(c)]
        coefs = np.concatenate([co for _, co in parts])
        return PolyMatrix._of((r, c), _merge(_Terms(np.repeat(np.arange(r * c), [len(co) for _, co in parts]),
                                                    np.vstack([e for e, _ in parts]), coefs,
                                                    sps.csr_matrix((len(coefs), n_decision)))))

    def __matmul__(self, other: "PolyMatrix") -> "PolyMatrix":
        (r, k), (k2, c) = self.shape, other.shape
        if k != k2:
            raise ValueError(f"shapes {self.shape} and {other.shape} do not multiply")
        return PolyMatrix._of((r, c), _product(self._t, other._t, (r, k, c)))

    @staticmethod
    def constant(M: np.ndarray, n_vars: int) -> "PolyMatrix":
        """A numeric constant matrix as degree-0 polynomials in ``n_vars`` variables (zero
        entries have no term).

        Parameters
        ----------
        M : numpy.ndarray, shape (r, c)
            The matrix (a scalar or vector is taken as one row).
        n_vars : int
            Number of polynomial variables.
        """
        M = np.atleast_2d(np.asarray(M, float))
        entry = np.flatnonzero(M)
        return PolyMatrix._of(M.shape, _Terms(entry, np.zeros((len(entry), n_vars), np.int64), M.ravel()[entry],
                                              sps.csr_matrix((len(entry), 0))))

    @staticmethod
    def block(rows: Sequence[Sequence["PolyMatrix | None"]]) -> "PolyMatrix":
        """Assemble a block matrix; ``None`` is a zero block (its size from its row and column).

        Parameters
        ----------
        rows : sequence of sequence of PolyMatrix or None
            The block rows, equally long; every block row and block column needs one block
            that is not None.

        Raises
        ------
        ValueError
            If a block's shape does not match its block row and column.
        """
        heights = [next(b.shape[0] for b in row if b is not None) for row in rows]
        widths = [next(rows[i][j].shape[1] for i in range(len(rows)) if rows[i][j] is not None)  # type: ignore[union-attr]
                  for j in range(len(rows[0]))]
        cols = sum(widths)
        r0 = np.cumsum([0] + heights)
        c0 = np.cumsum([0] + widths)
        parts: list[_Terms] = []
        for i, row in enumerate(rows):
            for j, b in enumerate(row):
                if b is None:
                    continue
                if b.shape != (heights[i], widths[j]):
                    raise ValueError(f"block ({i}, {j}) is {b.shape}, expected {(heights[i], widths[j])}")
                bi, bj = np.divmod(b._t.entry, b.shape[1])
                parts.append(b._t._replace(entry=(r0[i] + bi) * cols + c0[j] + bj))
        width = max(p.C.shape[1] for p in parts)
        entry = np.concatenate([p.entry for p in parts])
        order = np.argsort(entry, kind="stable")
        t = _Terms(entry, np.vstack([p.exps for p in parts]), np.concatenate([p.c0 for p in parts]),
                   _vstack([p.C for p in parts], width))
        return PolyMatrix._of((sum(heights), cols), _Terms(t.entry[order], t.exps[order], t.c0[order], t.C[order]))

    def scale(self, s: float) -> "PolyMatrix":
        """The matrix times the number ``s``.

        Parameters
        ----------
        s : float
            The factor.
        """
        return PolyMatrix._of(self.shape, self._t._replace(c0=s * self._t.c0, C=(s * self._t.C).tocsr()))

    def __neg__(self) -> "PolyMatrix":
        return self.scale(-1.0)

    def __sub__(self, other: "PolyMatrix") -> "PolyMatrix":
        return self + (-other)

    def __add__(self, other: "PolyMatrix") -> "PolyMatrix":
        if self.shape != other.shape:
            raise ValueError(f"shapes {self.shape} and {other.shape} do not add")
        a, b = self._t, other._t
        width = max(a.C.shape[1], b.C.shape[1])
        return PolyMatrix._of(self.shape, _merge(_Terms(np.concatenate([a.entry, b.entry]), np.vstack([a.exps, b.exps]),
                                                        np.concatenate([a.c0, b.c0]), _vstack([a.C, b.C], width))))

    @property
    def T(self) -> "PolyMatrix":
        """The transpose."""
        r, c = self.shape
        i, j = np.divmod(self._t.entry, c)
        entry = j * r + i
        order = np.argsort(entry, kind="stable")
        t = self._t
        return PolyMatrix._of((c, r), _Terms(entry[order], t.exps[order], t.c0[order], t.C[order]))

    def symmetric_from_lower(self) -> "PolyMatrix":
        """The symmetric matrix whose lower triangle (diagonal included) is this one's."""
        r, c = self.shape
        if r != c:
            raise ValueError(f"a {self.shape} matrix has no symmetric counterpart")
        t = self._t
        i, j = np.divmod(t.entry, c)
        lower, strict = np.flatnonzero(i >= j), np.flatnonzero(i > j)
        take = np.concatenate([lower, strict])
        entry = np.concatenate([t.entry[lower], j[strict] * c + i[strict]])
        order = np.argsort(entry, kind="stable")
        return PolyMatrix._of(self.shape, _Terms(entry[order], t.exps[take[order]], t.c0[take[order]],
                                                 t.C[take[order]]))

    def degree(self) -> int:
        """Largest total degree of a term (0 for a matrix without terms)."""
        return int(self._t.exps.sum(axis=1).max(initial=0))

    def substitute(self, polys: Sequence[Poly]) -> "PolyMatrix":
        """The matrix with each variable ``x_j`` replaced by the numeric polynomial ``polys[j]``
        (all in the same new variables ``z``): a polynomial matrix in ``z``.

        One variable at a time, as a batched product: the term ``c x^e`` of entry ``(i, j)``
        goes to column ``e_j`` of a ``(rows * cols) x (d + 1)`` matrix (``x_j`` dropped from
        it), multiplied by the column of powers ``polys[j]^0 .. polys[j]^d``.

        Parameters
        ----------
        polys : sequence of Poly
            One numeric polynomial per variable of the matrix, all in the same new variables.

        Raises
        ------
        ValueError
            If the count of ``polys`` is not the number of variables, or a substitute
            depends on decision variables.
        """
        if len(polys) != self.n_vars:
            raise ValueError(f"{len(polys)} substitutes for {self.n_vars} variables")
        if not all(q.is_affine_free() for q in polys):
            raise ValueError("substitutes must be numeric polynomials")
        n, m = self.n_vars, polys[0].n_vars
        t = self._t
        cur = t._replace(exps=np.hstack([t.exps, np.zeros((len(t.entry), m), np.int64)]))
        cells = self.shape[0] * self.shape[1]
        for j, q in enumerate(polys):
            d = cur.exps[:, j].copy()
            top = int(d.max(initial=0))
            powers = [Poly.constant(1.0, m)]
            for _ in range(top):
                powers.append(powers[-1] * q)
            counts = [len(pw.c0) for pw in powers]
            right = _Terms(np.repeat(np.arange(top + 1), counts),
                           np.hstack([np.zeros((sum(counts), n), np.int64), np.vstack([pw.exps for pw in powers])]),
                           np.concatenate([pw.c0 for pw in powers]), sps.csr_matrix((sum(counts), 0)))
            exps = cur.exps.copy()
            exps[:, j] = 0
            cur = _product(cur._replace(entry=cur.entry * (top + 1) + d, exps=exps), right, (cells, top + 1, 1))
        return PolyMatrix._of(self.shape, cur._replace(exps=cur.exps[:, n:]))

    def evaluate(self, x: np.ndarray, y: np.ndarray | None = None) -> np.ndarray:
        """Numeric matrix at one point ``x`` of shape (n,).

        Parameters
        ----------
        x : numpy.ndarray, shape (n,)
            The point.
        y : numpy.ndarray, shape (n_y,), optional
            Decision values; None: the constant parts ``c0``.

        Returns
        -------
        numpy.ndarray
            Of the matrix's shape.
        """
        t = self._t
        c = t.c0 if y is None or t.C.shape[1] == 0 else t.c0 + t.C @ y[: t.C.shape[1]]
        vals = _term_values(t.exps, np.atleast_2d(np.asarray(x, float)))[0] * c
        return np.bincount(t.entry, vals, self.shape[0] * self.shape[1]).reshape(self.shape)


def quadratic_form(M: PolyMatrix) -> Poly:
    """``v^T M(x) v`` as a polynomial in ``(x, v)`` (``M`` square; ``v`` appended).

    Parameters
    ----------
    M : PolyMatrix
        Square polynomial matrix, shape (r, r), in ``n`` variables.

    Returns
    -------
    Poly
        In ``n + r`` variables: ``x``, then ``v``.

    Raises
    ------
    ValueError
        If ``M`` is not square.
    """
    r, c = M.shape
    if r != c:
        raise ValueError(f"quadratic form of a non-square {M.shape} matrix")
    t = M._t
    v = np.zeros((len(t.entry), r), np.int64)
    i, j = np.divmod(t.entry, r)
    np.add.at(v, (np.arange(len(i)), i), 1)
    np.add.at(v, (np.arange(len(j)), j), 1)
    q = _merge(_Terms(np.zeros(len(t.entry), np.int64), np.hstack([t.exps, v]), t.c0, t.C))
    return Poly(q.exps, q.c0, q.C) if len(q.entry) else Poly.constant(0.0, M.n_vars + r, t.C.shape[1])
