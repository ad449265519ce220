"""Sum-of-squares programs solved by Clarabel, with independent verification of every result.

Layers (each a function or class with a test):

1. :mod:`satfmu.synthesis.core.polynomial`: polynomials with affine decision-variable coefficients.
2. :class:`SOSProgram`: decision variables and polynomials, scalar SOS constraints
   ``p(x) = z(x)^T G z(x), G >= 0`` on a pruned monomial basis ``z``, SOS-matrix
   constraints (``v^T M(x) v`` SOS in ``(x, v)``), S-procedure multipliers for ball and
   box regions, linear and PSD constraints.
3. :meth:`SOSProgram.conic_problem`: the whole program as one conic problem
   (:mod:`satfmu.synthesis.core.conic`) over ``x = (y, svec G_1, ..., svec G_p)``; the coefficient
   matching of every SOS constraint is one sparse linear map, assembled at once from
   integer keys of the exponent rows (:mod:`satfmu.synthesis.core.exponents`).
4. :meth:`SOSProgram.solve`: Clarabel on those arrays, under the solve policy of
   :mod:`satfmu.synthesis.core.solve_policy`; returns a :class:`SOSSolution` with
   the decision values and Gram matrices.
5. :func:`certify`: re-checks each SOS constraint without the solver and without the
   program's matching map: minimum eigenvalue of the Gram matrix, the coefficients of
   ``p - z^T G z`` expanded from the polynomials, and a sampled check of the polynomial
   inequality. A constraint is *certified* when ``lambda_min(G) >= N * max|residual|``
   (then ``p - z^T G z`` is absorbed by ``G``'s margin: ``p`` is SOS exactly) and the
   sampled values are non-negative.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np
import scipy.sparse as sps

from satfmu.synthesis.core.conic import ConicProblem, ConicResult, solve_clarabel, svec_indices, svec_scale
from satfmu.synthesis.core.exponents import keys
from satfmu.synthesis.core.polynomial import Poly, PolyMatrix, monomials, quadratic_form
from satfmu.synthesis.core.sign_symmetry import symmetry_blocks
from satfmu.synthesis.core.solve_policy import solve_with, ladder_with
from satfmu.fmus.errors import SOSError


def _in_hull(points: np.ndarray, targets: np.ndarray) -> np.ndarray:
    """For each target, whether it lies in the convex hull of ``points`` (one small LP each)."""
    from scipy.optimize import linprog

    k = points.shape[0]
    A_eq = np.vstack([points.T.astype(float), np.ones((1, k))])
    out = np.zeros(len(targets), bool)
    for i, t in enumerate(targets):
        res = linprog(np.zeros(k), A_eq=A_eq, b_eq=np.append(t.astype(float), 1.0), bounds=(0, None),
                      method="highs")
        out[i] = res.status == 0
    return out


def newton_basis(support: np.ndarray) -> np.ndarray:
    """A monomial basis ``z`` for ``p = z^T G z`` from ``p``'s support.

    Start from every monomial with degree between half the lowest and half the highest
    degree of the support, keep those in half the Newton polytope (``2 z`` in the convex
    hull of the support: at once when ``2 z`` is a support point, else by an LP), then
    repeatedly drop ``z_i`` whose square ``2 z_i`` is neither in the support nor the sum of
    two other basis monomials (its diagonal Gram entry would be forced to zero, hence its
    whole row).

    Parameters
    ----------
    support : numpy.ndarray of int, shape (k, n)
        Exponent rows of the terms of ``p`` that are not identically zero
        (:meth:`satfmu.synthesis.core.polynomial.Poly.support`), one row per term, one column per
        variable.

    Returns
    -------
    numpy.ndarray of int, shape (N, n)
        The basis monomials ``z`` as exponent rows (none when ``support`` is empty).
    """
    if support.shape[0] == 0:
        return np.zeros((0, support.shape[1]), np.int64)
    n = support.shape[1]
    deg = support.sum(axis=1)
    lo, hi = int(np.ceil(deg.min() / 2)), int(deg.max() // 2)
    cand = monomials(n, hi, lo)
    half_max = support.max(axis=0) // 2
    half_min = (support.min(axis=0) + 1) // 2
    cand = cand[np.all(cand <= half_max, axis=1) & np.all(cand >= half_min, axis=1)]
    if len(cand):
        k = keys(np.vstack([2 * cand, support]))
        inside = np.isin(k[: len(cand)], k[len(cand):])  # 2 z a support point: in the hull, no LP
        if not inside.all():
            inside[~inside] = _in_hull(np.unique(support, axis=0), 2 * cand[~inside])
        cand = cand[inside]
    return prune_diagonal(cand, support)


def prune_diagonal(cand: np.ndarray, support: np.ndarray) -> np.ndarray:
    """Drop basis monomials whose Gram diagonal entry is forced to zero, until none is.

    ``z_i`` goes when ``2 z_i`` is neither in ``support`` nor the sum of two other
    basis monomials: then ``G_ii = 0``, so ``G >= 0`` zeroes its whole row.

    Parameters
    ----------
    cand : numpy.ndarray of int, shape (N, n)
        Candidate basis monomials, as exponent rows.
    support : numpy.ndarray of int, shape (k, n)
        Exponent rows of the polynomial's terms that are not identically zero.

    Returns
    -------
    numpy.ndarray of int, shape (N', n)
        The rows of ``cand`` kept, in their order.
    """
    while True:
        i, j = np.triu_indices(len(cand), 1)
        k = keys(np.vstack([2 * cand, support, cand[i] + cand[j]]))
        squares, reached = k[: len(cand)], k[len(cand):]
        keep = np.isin(squares, reached)
        if keep.all():
            return cand
        cand = cand[keep]


@dataclass
class SOSConstraint:
    """A scalar SOS constraint ``p = z^T G z`` (``p`` may depend on decision variables).

    Attributes
    ----------
    name : str
        Name of the constraint, in the :class:`Check` and error messages and in the key
        ``"<index>:<name>"`` of its Gram matrix in ``SOSSolution.grams``.
    poly : satfmu.synthesis.core.polynomial.Poly
        The polynomial ``p``, coefficients affine in the decision variables; in the program's
        ``n_vars`` variables, or in ``(x, v)`` for an SOS-matrix constraint.
    basis : numpy.ndarray of int, shape (N, n)
        The monomial basis ``z`` as exponent rows (N = 0: ``p`` must vanish identically).
    region : str, optional
        Label of the region on which the constraint proves ``p >= 0``, for the reports
        (``"global"`` by default; the S-procedure's region description otherwise).
    blocks : list of numpy.ndarray of int, optional
        Indices into ``basis`` of the diagonal blocks ``G`` may be restricted to (below).
    """

    name: str
    poly: Poly
    basis: np.ndarray
    region: str = "global"
    blocks: list[np.ndarray] = field(default_factory=list)
    """Indices into ``basis`` of the diagonal blocks ``G`` may be restricted to (the sign
    symmetries of ``poly``, :mod:`satfmu.synthesis.core.sign_symmetry`); one block ``arange(N)`` when none
    separates the basis, none when the basis is empty."""


@dataclass
class SOSSolution:
    """Solver output: decision vector, Gram matrices, status and timings (s).

    Attributes
    ----------
    y : numpy.ndarray, shape (n_decision,)
        Values of the decision variables, in the order the program created them.
    grams : dict of str to numpy.ndarray
        Gram matrix ``G``, shape (N, N), of every constraint with a non-empty basis, keyed
        ``"<index>:<name>"`` (index into ``SOSProgram.sos``); zero outside its symmetry
        blocks.
    status : str
        The solver statuses of every attempt of the solve policy, ``"; "``-separated.
    solver : str
        The solver that gave the solution (``"CLARABEL"``).
    objective : float
        The minimized objective ``objective @ y`` (0 for a feasibility problem).
    timings : dict of str to float, optional
        ``"build"`` and ``"solve"`` times, s.
    """

    y: np.ndarray
    grams: dict[str, np.ndarray]
    status: str
    solver: str
    objective: float
    timings: dict[str, float] = field(default_factory=dict)


@dataclass
class Check:
    """Independent verification of one SOS constraint.

    Attributes
    ----------
    name : str
        Name of the constraint checked (``SOSConstraint.name``).
    region : str
        Label of the region the constraint holds on (``SOSConstraint.region``).
    basis_size : int
        Size N of its monomial basis (0: the polynomial must vanish).
    min_eig : float
        Smallest eigenvalue of its Gram matrix (0 without a basis).
    residual : float
        Largest coefficient of ``p - z^T G z`` (:func:`gram_residual`).
    sampled_min : float
        Smallest value of ``p`` at the sampled points (``-residual`` without a basis).
    certified : bool
        SOS to the solver's accuracy (the tolerances of :func:`certify`).
    exact : bool
        Certified and ``lambda_min(G) >= N * residual`` (below).
    """

    name: str
    region: str
    basis_size: int
    min_eig: float
    residual: float
    sampled_min: float
    certified: bool
    exact: bool
    """``lambda_min(G) >= N * residual``: then p is SOS exactly, not only to tolerance."""

    def to_json(self) -> dict[str, Any]:
        """The check as a JSON-ready dict of its fields (numpy floats as float)."""
        return {k: (float(v) if isinstance(v, (float, np.floating)) else v) for k, v in self.__dict__.items()}


class SOSProgram:
    """An SOS program in the polynomial variables ``x`` (count ``n_vars``).

    Parameters
    ----------
    n_vars : int
        Number of polynomial variables ``x``.
    gram_margin : float, optional
        Constrain every Gram matrix to ``G >= gram_margin I`` (tightens each SOS condition by
        ``gram_margin * z^T z``; use it when a strictly interior, exactly checkable certificate
        is wanted and the basis has no forced-zero monomials). Default 0.
    sign_symmetry : bool, optional
        Split each Gram matrix into the diagonal blocks the sign symmetries of its polynomial
        allow (lossless: :mod:`satfmu.synthesis.core.sign_symmetry`); False: one block per
        constraint. Default True.

    Examples
    --------
    >>> import sympy as sp
    >>> x, y = sp.symbols("x y")
    >>> prog = SOSProgram(2)
    >>> _ = prog.add_sos(Poly.from_sympy(x**2 - 2*x*y + 2*y**2, [x, y]), "p")
    >>> sol = prog.solve()
    >>> all(c.certified for c in certify(prog, sol))
    True
    """

    def __init__(self, n_vars: int, gram_margin: float = 0.0, sign_symmetry: bool = True) -> None:
        """``gram_margin``: constrain every Gram matrix to ``G >= gram_margin I`` (tightens each
        SOS condition by ``gram_margin * z^T z``; use it when a strictly interior, exactly
        checkable certificate is wanted and the basis has no forced-zero monomials).
        ``sign_symmetry``: split each Gram matrix into the diagonal blocks the sign symmetries
        of its polynomial allow (lossless: the program is feasible with the blocks if and only
        if it is without them; :mod:`satfmu.synthesis.core.sign_symmetry`); off, one block per constraint."""
        self.n_vars = n_vars
        self.gram_margin = gram_margin
        self.sign_symmetry = sign_symmetry
        self.n_decision = 0
        self.sos: list[SOSConstraint] = []
        self.equalities: list[tuple[sps.csr_matrix, np.ndarray]] = []   # A y + b == 0
        self.inequalities: list[tuple[sps.csr_matrix, np.ndarray]] = []  # A y + b >= 0
        self.psd: list[tuple[str, list[list[tuple[sps.csr_matrix, float]]]]] = []
        self.build_seconds = 0.0

    # ---------------------------------------------------------------- variables
    def new_variables(self, n: int) -> np.ndarray:
        """Indices of ``n`` fresh scalar decision variables.

        Parameters
        ----------
        n : int
            How many variables to create.

        Returns
        -------
        numpy.ndarray of int, shape (n,)
            Their indices in the decision vector ``y``.
        """
        idx = np.arange(self.n_decision, self.n_decision + n)
        self.n_decision += n
        return idx

    def selector(self, indices: np.ndarray) -> sps.csr_matrix:
        """Rows picking decision variables ``indices`` (width = current decision count).

        Parameters
        ----------
        indices : numpy.ndarray of int, shape (k,)
            Indices of decision variables (e.g. from :meth:`SOSProgram.new_variables`).

        Returns
        -------
        scipy.sparse.csr_matrix, shape (k, n_decision)
            Row ``i`` picks ``y[indices[i]]``.
        """
        k = len(indices)  # one entry a row: the CSR arrays directly
        return sps.csr_matrix((np.ones(k), np.asarray(indices, np.int64), np.arange(k + 1)), shape=(k, self.n_decision))

    def new_poly(self, exps: np.ndarray) -> Poly:
        """A polynomial with one fresh coefficient per exponent row.

        Parameters
        ----------
        exps : numpy.ndarray of int, shape (k, n_vars)
            Exponent rows of the terms (e.g. from :func:`satfmu.synthesis.core.polynomial.monomials`).
        """
        exps = np.asarray(exps, np.int64).reshape(-1, self.n_vars)
        idx = self.new_variables(len(exps))
        return Poly(exps, np.zeros(len(exps)), self.selector(idx))

    def new_symmetric(self, n: int) -> list[list[Poly]]:
        """A constant symmetric n x n matrix of fresh variables, as constant polynomials.

        Parameters
        ----------
        n : int
            Size of the matrix (``n (n + 1) / 2`` new variables).

        Returns
        -------
        list of list of satfmu.synthesis.core.polynomial.Poly
            The entries, row-major; ``M[i][j]`` and ``M[j][i]`` are the same polynomial.
        """
        idx = self.new_variables(n * (n + 1) // 2)
        zero = np.zeros((1, self.n_vars), np.int64)
        M: list[list[Poly | None]] = [[None] * n for _ in range(n)]
        k = 0
        for i in range(n):
            for j in range(i, n):
                p = Poly(zero, np.zeros(1), self.selector(idx[k:k + 1]))
                M[i][j] = M[j][i] = p
                k += 1
        return M  # type: ignore[return-value]

    # ---------------------------------------------------------------- constraints
    def add_sos(self, p: Poly, name: str, region: str = "global") -> SOSConstraint:
        """Require ``p`` to be a sum of squares (``p >= 0`` everywhere).

        Parameters
        ----------
        p : satfmu.synthesis.core.polynomial.Poly
            Polynomial in the program's ``n_vars`` variables, coefficients affine in the
            decision variables.
        name : str
            Name of the constraint (reports, error messages, Gram key).
        region : str, optional
            Label of the region the constraint stands for, recorded for the reports only
            (``SOSConstraint.region``). Default ``"global"``.

        Returns
        -------
        SOSConstraint
            The constraint recorded, with its basis and Gram blocks.

        Raises
        ------
        satfmu.fmus.errors.SOSError
            If ``p`` is not in ``n_vars`` variables.
        """
        t0 = time.perf_counter()
        if p.n_vars != self.n_vars:
            raise SOSError(f"{name}: polynomial in {p.n_vars} variables, program has {self.n_vars}")
        support = p.support()
        c = self._constraint(name, p, newton_basis(support), support, region)
        self.build_seconds += time.perf_counter() - t0
        return c

    def _constraint(self, name: str, p: Poly, basis: np.ndarray, support: np.ndarray, region: str) -> SOSConstraint:
        """Record ``p = z^T G z`` on ``basis`` with the Gram blocks its support allows."""
        blocks = (symmetry_blocks(basis, support) if self.sign_symmetry
                  else [np.arange(basis.shape[0])] if basis.shape[0] else [])
        c = SOSConstraint(name, p, basis, region, blocks)
        self.sos.append(c)
        return c

    def add_sos_on_region(self, p: Poly, name: str, region: list[Poly], multiplier_degree: int,
                          label: str) -> SOSConstraint:
        """Require ``p >= 0`` where every ``g in region`` is ``>= 0`` (S-procedure).

        ``p - sum_i s_i g_i`` must be SOS with SOS multipliers ``s_i`` of degree
        ``multiplier_degree`` (even).

        Parameters
        ----------
        p : satfmu.synthesis.core.polynomial.Poly
            Polynomial in the program's ``n_vars`` variables, coefficients affine in the
            decision variables.
        name : str
            Name of the constraint; its multipliers are named ``"<name>: multiplier <k>"``.
        region : list of satfmu.synthesis.core.polynomial.Poly
            The numeric polynomials ``g_i`` whose joint non-negativity defines the region.
        multiplier_degree : int
            Degree of every multiplier ``s_i`` (even).
        label : str
            Description of the region, recorded as the constraint's
            ``SOSConstraint.region``.

        Returns
        -------
        SOSConstraint
            The constraint on ``p - sum_i s_i g_i``.

        Raises
        ------
        satfmu.fmus.errors.SOSError
            If ``multiplier_degree`` is odd.
        """
        if multiplier_degree % 2:
            raise SOSError(f"{name}: multiplier degree must be even, got {multiplier_degree}")
        rest = p
        for k, g in enumerate(region):
            s = self.new_poly(monomials(self.n_vars, multiplier_degree))
            self.add_sos(s, f"{name}: multiplier {k}", "global")
            rest = rest - s * g
        return self.add_sos(rest, name, label)

    def add_sos_matrix(self, M: PolyMatrix, name: str, region: list[Poly] | None = None,
                       multiplier_degree: int = 2, label: str = "global",
                       multiplier_rows: Sequence[int] | None = None,
                       multiplier_weights: Sequence[float] | None = None) -> SOSConstraint:
        """Require ``M(x) >= 0`` as an SOS matrix: ``v^T M(x) v`` SOS in ``(x, v)``.

        With ``region`` the condition holds where the region polynomials are ``>= 0``:
        the multipliers are ``v_R^T v_R * s_i(x)`` with ``v_R`` the entries of ``v`` in
        ``multiplier_rows`` (default all; ``M - s_i g_i D_R >= 0`` with ``D_R >= 0`` still
        proves ``M >= 0`` where ``g_i >= 0``). Leaving out rows whose entries are constant
        or linear in x keeps their ``v_i z(x)`` monomials out of the Gram basis. The
        constraint is recorded in the extended program of ``n_vars + dim`` variables.

        Parameters
        ----------
        M : satfmu.synthesis.core.polynomial.PolyMatrix
            Square symmetric polynomial matrix, shape (dim, dim), in the program's ``n_vars``
            variables.
        name : str
            Name of the constraint; its multipliers are named ``"<name>: multiplier <k>"``.
        region : list of satfmu.synthesis.core.polynomial.Poly, optional
            The numeric polynomials ``g_i >= 0`` defining the region; None or empty: everywhere.
        multiplier_degree : int, optional
            Degree of the multipliers ``s_i(x)`` (even). Default 2.
        label : str, optional
            Description of the region, recorded as ``SOSConstraint.region``. Default
            ``"global"``.
        multiplier_rows : sequence of int, optional
            The rows ``R`` of ``v`` the multipliers act on (indices in ``0 .. dim - 1``); default
            all.
        multiplier_weights : sequence of float, optional
            Positive weights ``W``, one per row of ``R`` in increasing row order: the multipliers
            are ``v_R^T W v_R * s_i(x)`` (a diagonal congruence of the condition scales them so).
            Default all 1.

        Returns
        -------
        SOSConstraint
            The constraint on ``v^T M v`` less the multiplier terms, in ``(x, v)``.

        Raises
        ------
        satfmu.fmus.errors.SOSError
            If ``multiplier_rows`` is empty or out of range, or the weights are not one positive
            number per row.
        """
        q = quadratic_form(M)
        dim = M.shape[0]
        sub = _Extended(self, dim)
        if region:
            rows = np.arange(dim) if multiplier_rows is None else np.asarray(sorted(set(multiplier_rows)), np.int64)
            if rows.size == 0 or rows.min() < 0 or rows.max() >= dim:
                raise SOSError(f"{name}: multiplier_rows must be a non-empty subset of 0..{dim - 1}")
            # v_R^T v_R = sum_{i in R} v_i^2 in (x, v)
            vexp = np.zeros((rows.size, dim), np.int64)
            vexp[np.arange(rows.size), rows] = 2
            w = np.ones(rows.size) if multiplier_weights is None else np.asarray(multiplier_weights, float)
            if w.shape != (rows.size,) or not np.all(np.isfinite(w) & (w > 0)):
                raise SOSError(f"{name}: multiplier_weights must be {rows.size} positive numbers")
            vv = Poly.numeric(np.hstack([np.zeros((rows.size, self.n_vars), np.int64), vexp]), w)
            for k, g in enumerate(region):
                s = self.new_poly(monomials(self.n_vars, multiplier_degree))
                self.add_sos(s, f"{name}: multiplier {k}")
                q = q - (_lift(s, dim) * _lift(g, dim)) * vv
        return sub.add(q, name, label)

    def add_linear(self, A: sps.spmatrix, b: np.ndarray, kind: str = "eq") -> None:
        """``A y + b == 0`` (kind "eq") or ``>= 0`` (kind "ge").

        Parameters
        ----------
        A : scipy.sparse.spmatrix, shape (k, n_y)
            Coefficients of the decision variables (``n_y`` at most the current decision
            count: variables created later do not appear).
        b : numpy.ndarray, shape (k,)
            Constant term.
        kind : {"eq", "ge"}, optional
            Equality or element-wise inequality (any other value is taken as ``"ge"``).
            Default ``"eq"``.
        """
        (self.equalities if kind == "eq" else self.inequalities).append((sps.csr_matrix(A), np.asarray(b, float)))

    def add_psd_constant(self, M: list[list[Poly]], name: str, margin: float | np.ndarray = 0.0) -> None:
        """A constant polynomial matrix (one degree-0 term per entry) with ``M - margin I`` PSD.

        Parameters
        ----------
        M : list of list of satfmu.synthesis.core.polynomial.Poly
            Square matrix of constant polynomials (e.g. from :meth:`SOSProgram.new_symmetric`), row-major;
            its symmetric part is constrained.
        name : str
            Name of the constraint (error messages).
        margin : float or numpy.ndarray, optional
            Required smallest eigenvalue, or the diagonal ``d`` of a margin ``M - diag(d)`` PSD.
            Default 0.

        Raises
        ------
        satfmu.fmus.errors.SOSError
            If an entry is not a single degree-0 term.
        """
        if any(e.exps.shape[0] != 1 or e.exps.any() for row in M for e in row):
            raise SOSError(f"{name}: add_psd_constant needs constant entries")
        d = np.broadcast_to(np.asarray(margin, float), (len(M),))
        entries = [[(e.C, float(e.c0[0]) - (d[i] if i == j else 0.0)) for j, e in enumerate(row)]
                   for i, row in enumerate(M)]
        self.psd.append((name, entries))

    # ---------------------------------------------------------------- solve
    def conic_problem(self, objective: sps.spmatrix | None = None) -> ConicProblem:
        """The program as one conic problem over ``x = (y, svec G_1, ..., svec G_p)``.

        Rows, in cone order: the coefficient matching of every SOS constraint
        (:func:`coefficient_matching`) and the linear equalities; the linear inequalities;
        then one PSD cone per Gram block (``G_block - gram_margin I``; one block per Gram
        matrix unless sign symmetries split it) and per constant PSD block (its symmetric
        part). Gram entries are the variables ``G_ij``, ``i <= j`` within a block, in
        :func:`satfmu.synthesis.core.conic.svec_indices` order.

        Parameters
        ----------
        objective : scipy.sparse.spmatrix, shape (1, n_y), optional
            Cost row on the decision variables (``n_y`` at most the decision count); None: a
            feasibility problem (zero cost).
        """
        cones, n = self._gram_layout()
        match, rhs = coefficient_matching(self.sos, cones, n)
        zero = [match] + [-_widen(A, n) for A, _ in self.equalities]  # A y + b == 0: -A y + s = b, s = 0
        zero_b = [rhs] + [b for _, b in self.equalities]
        ineq = [-_widen(A, n) for A, _ in self.inequalities]  # A y + b >= 0: -A y + s = b, s >= 0
        ineq_b = [b for _, b in self.inequalities]
        rows, cones_b, psd = [], [], []
        for _, block, off in cones:  # s = scale svec(G_block) - margin svec(I)
            N = len(block)
            i, j = svec_indices(N)
            rows.append(sps.csr_matrix((-svec_scale(N), (np.arange(len(i)), off + np.arange(len(i)))),
                                       shape=(len(i), n)))
            cones_b.append(np.where(i == j, -self.gram_margin, 0.0))
            psd.append(N)
        for _, entries in self.psd:  # s = scale svec((M + M^T) / 2)
            N = len(entries)
            i, j = svec_indices(N)
            half = svec_scale(N) / 2
            sym = sps.csr_matrix((np.concatenate([half, half]), (np.tile(np.arange(len(i)), 2),
                                                                  np.concatenate([i * N + j, j * N + i]))),
                                 shape=(len(i), N * N))
            rows.append(-_widen(sym @ sps.vstack([_widen(C, n) for line in entries for C, _ in line]), n))
            cones_b.append(sym @ np.array([c for line in entries for _, c in line]))
            psd.append(N)
        q = np.zeros(n)
        if objective is not None:
            o = sps.csr_matrix(objective)
            q[: o.shape[1]] = o.toarray().ravel()
        A = sps.vstack(zero + ineq + rows, format="csc")
        return ConicProblem(q, A, np.concatenate(zero_b + ineq_b + cones_b), sum(len(b) for b in zero_b),
                            sum(len(b) for b in ineq_b), psd)

    def solve(self, objective: sps.spmatrix | None = None, **settings: Any) -> SOSSolution:
        """Minimize ``objective @ y`` (feasibility if None) subject to all constraints.

        Clarabel gets the arrays of :meth:`conic_problem` as they are (no re-formulation),
        under the project's solve policy (:mod:`satfmu.synthesis.core.solve_policy`): ``settings``
        (Clarabel's, e.g. ``tol_feas``) first, then the policy's relaxed and regularized
        rungs when Clarabel stops without a solution or a clean certificate.

        Parameters
        ----------
        objective : scipy.sparse.spmatrix, shape (1, n_y), optional
            Cost row on the decision variables ``y`` (e.g. ``prog.selector(idx)``); None: find
            any feasible point.

        Returns
        -------
        SOSSolution
            Decision values, Gram matrices, status and times; check them with :func:`certify`.

        Raises
        ------
        SOSError
            If no rung returns a solution (infeasible, unbounded, or failures such as
            ``NumericalError``; every attempt's status is in the message).
        """
        t0 = time.perf_counter()
        problem = self.conic_problem(objective)
        build = time.perf_counter() - t0 + self.build_seconds
        results: list[ConicResult] = []

        def run(solver: str, rung: dict[str, Any]) -> str:
            results.append(solve_clarabel(problem, **rung))
            return results[-1].status

        outcome = solve_with(run, ladder_with(settings))
        result = results[-1]
        if not outcome.solved:
            raise SOSError(f"SOS program not solved ({outcome.status}): {outcome.solver_status} (solver CLARABEL)")
        assert result.x is not None  # solved: the last rung's status is optimal(_inaccurate), which comes with x
        grams = {f"{k}:{c.name}": np.zeros((len(c.basis), len(c.basis))) for k, c in enumerate(self.sos)
                 if c.basis.shape[0]}
        for k, block, off in self._gram_layout()[0]:  # zero outside the blocks
            i, j = svec_indices(len(block))
            G = grams[f"{k}:{self.sos[k].name}"]
            G[block[i], block[j]] = G[block[j], block[i]] = result.x[off:off + len(i)]
        return SOSSolution(result.x[: self.n_decision].copy(), grams, outcome.solver_status, outcome.solver,
                           result.objective, {"build": build, "solve": outcome.seconds})

    def _gram_layout(self) -> tuple[list[tuple[int, np.ndarray, int]], int]:
        """The Gram blocks as ``(constraint index, block's indices into its basis, offset of
        its svec in x)``, after the decision variables, and the length of ``x``."""
        cones, off = [], self.n_decision
        for k, c in enumerate(self.sos):
            for block in c.blocks:
                cones.append((k, block, off))
                off += len(block) * (len(block) + 1) // 2
        return cones, off


def coefficient_matching(constraints: Sequence[SOSConstraint], cones: Sequence[tuple[int, np.ndarray, int]],
                         n: int) -> tuple[sps.csr_matrix, np.ndarray]:
    """The coefficient matching of SOS constraints as one sparse linear map ``A x = b``.

    For each constraint ``p = z^T G z`` (``G``'s blocks given by ``cones``: constraint index,
    the block's indices into the basis, the offset of its svec in ``x``, after the decision
    variables ``y``): one row per monomial of the blocks' ``z_i z_j``, where the coefficient
    ``c0 + C y`` of ``p`` equals the sum of the Gram entries reaching it (``G_ij`` twice off
    the diagonal); one row ``c0 + C y = 0`` per term of ``p`` no Gram entry reaches (every
    term of a constraint with an empty basis: ``p = 0``). Assembled at once:
    every ``(constraint, exponent row)``, of the Gram products and of the polynomials, gets
    an integer key (:func:`satfmu.synthesis.core.exponents.keys`); the Gram monomials are the unique
    keys and each term of ``p`` finds its row by ``searchsorted``.

    Parameters
    ----------
    constraints : sequence of SOSConstraint
        The SOS constraints, in program order (``SOSProgram.sos``).
    cones : sequence of tuple of (int, numpy.ndarray, int)
        The Gram blocks: constraint index, the block's indices into that constraint's basis,
        and the offset of the block's svec in ``x``.
    n : int
        Length of ``x`` (decision variables and every Gram block's svec).

    Returns
    -------
    A : scipy.sparse.csr_matrix
        Rows x ``n`` (``n`` the length of ``x``).
    b : ndarray
        One constant per row: the ``c0`` coefficients matched by that row.
    """
    polys = [c.poly for c in constraints]
    width = max([p.n_vars for p in polys], default=0)

    def tagged(k: int, e: np.ndarray) -> np.ndarray:  # (constraint, exponent row) at a common width
        return np.hstack([np.full((len(e), 1), k), e, np.zeros((len(e), width - e.shape[1]), np.int64)])

    pair_rows, pair_cols, pair_vals = [], [], []
    for k, block, off in cones:
        i, j = (block[ij] for ij in svec_indices(len(block)))
        basis = constraints[k].basis
        pair_rows.append(tagged(k, basis[i] + basis[j]))
        pair_cols.append(off + np.arange(len(i)))
        pair_vals.append(np.where(i == j, 1.0, 2.0))
    n_pairs = sum(len(r) for r in pair_rows)
    all_keys = keys(np.vstack(pair_rows + [tagged(k, p.exps) for k, p in enumerate(polys)] +
                              [np.zeros((0, width + 1), np.int64)]))
    mons, pair_row = np.unique(all_keys[:n_pairs], return_inverse=True)
    term_keys = all_keys[n_pairs:]
    pos = np.minimum(np.searchsorted(mons, term_keys), max(len(mons) - 1, 0))
    matched = (mons[pos] == term_keys) if len(mons) else np.zeros(len(term_keys), bool)
    C = sps.vstack([_widen(p.C, n) for p in polys] + [sps.csr_matrix((0, n))], format="csr")
    c0 = np.concatenate([p.c0 for p in polys] + [np.zeros(0)])
    outside = ~matched & ((c0 != 0) | (np.diff(C.indptr) > 0))  # must vanish
    term_row = np.where(matched, pos, -1)
    term_row[outside] = len(mons) + np.arange(outside.sum())
    rows = len(mons) + int(outside.sum())
    Ct = C.tocoo()
    use = term_row[Ct.row] >= 0
    A = sps.csr_matrix((np.concatenate([-Ct.data[use], *pair_vals]),
                        (np.concatenate([term_row[Ct.row[use]], pair_row]),
                         np.concatenate([Ct.col[use], *pair_cols]))), shape=(rows, n))
    keep = term_row >= 0
    return A, np.bincount(term_row[keep], c0[keep], rows)


def _widen(C: sps.spmatrix, n: int) -> sps.csr_matrix:
    """``C`` (CSR) with ``n`` columns (variables created after it, and the Gram entries, are
    not in it)."""
    C = sps.csr_matrix(C)
    return sps.csr_matrix((C.data, C.indices, C.indptr), shape=(C.shape[0], n))


class _Extended:
    """Adds an SOS constraint in (x, v) to a program in x (for SOS-matrix conditions)."""

    def __init__(self, prog: SOSProgram, dim: int) -> None:
        self.prog, self.dim = prog, dim

    def add(self, q: Poly, name: str, label: str) -> SOSConstraint:
        t0 = time.perf_counter()
        support = q.support()
        # q is quadratic in v, so the basis monomials are v_i * z(x), z from the x parts
        quadratic = support[:, self.prog.n_vars:].sum(axis=1) == 2
        basis_x = newton_basis(support[quadratic, : self.prog.n_vars])
        rows = []
        for i in range(self.dim):
            v = np.zeros((len(basis_x), self.dim), np.int64)
            v[:, i] = 1
            rows.append(np.hstack([basis_x, v]))
        basis = np.vstack(rows) if rows else np.zeros((0, self.prog.n_vars + self.dim), np.int64)
        c = self.prog._constraint(name, q, prune_diagonal(basis, support), support, label)
        self.prog.build_seconds += time.perf_counter() - t0
        return c


def _lift(p: Poly, dim: int) -> Poly:
    """``p(x)`` as a polynomial in ``(x, v)``."""
    return Poly(np.hstack([p.exps, np.zeros((p.exps.shape[0], dim), np.int64)]), p.c0, p.C)


def gram_residual(p: Poly, basis: np.ndarray, G: np.ndarray) -> float:
    """Largest coefficient of ``p - z^T G z`` (``p`` numeric, ``z`` the monomials of ``basis``).

    Expanded from the polynomials alone, independently of the program's matching map:
    every entry ``G_ij`` (both triangles) is a term ``z_i z_j``; with ``p``'s terms, equal
    exponent rows are summed (``np.unique`` over whole rows, not the program's integer
    keys). Terms of ``p`` no Gram entry reaches count in full.

    Parameters
    ----------
    p : satfmu.synthesis.core.polynomial.Poly
        Numeric polynomial (decision values substituted, e.g. by ``Poly.value``).
    basis : numpy.ndarray of int, shape (N, n)
        Exponent rows of the basis monomials ``z``.
    G : numpy.ndarray, shape (N, N)
        The Gram matrix.
    """
    N = basis.shape[0]
    pairs = (basis[:, None, :] + basis[None, :, :]).reshape(N * N, -1)
    _, inv = np.unique(np.vstack([p.exps, pairs]), axis=0, return_inverse=True)
    coefficients = np.bincount(inv.ravel(), np.concatenate([p.c0, -G.ravel()]))
    return float(np.max(np.abs(coefficients), initial=0.0))


def check_numbers(checks: list[Check]) -> dict[str, float]:
    """The verification numbers of ``checks`` as a flat ``{"<name>: <quantity>": value}`` map.

    Parameters
    ----------
    checks : list of Check
        The checks of :func:`certify`; ``min_eig``, ``residual`` and ``sampled_min`` of each
        are reported.
    """
    return {f"{c.name}: {k}": float(getattr(c, k)) for c in checks for k in ("min_eig", "residual", "sampled_min")}


def certify(prog: SOSProgram, sol: SOSSolution, n_samples: int = 2000, sample_radius: float = 1.0,
           seed: int = 0, eig_tol: float = 1e-7, res_tol: float = 1e-7) -> list[Check]:
    """Re-check every SOS constraint from the numbers alone (no solver).

    For each constraint: ``lambda_min`` of its Gram matrix, the largest coefficient of
    ``p(y) - z^T G z``, and the smallest value of ``p(y)`` at ``n_samples`` points drawn
    uniformly in the ball of radius ``sample_radius`` (for SOS-matrix constraints ``v`` is
    drawn on the unit sphere). *Certified*: ``lambda_min >= -eig_tol * max(1, |G|)``,
    residual ``<= res_tol * max(1, |p|)`` and no sampled value below ``-res_tol`` relative,
    i.e. SOS to the solver's accuracy (interior-point solutions of degenerate programs sit
    on the cone's boundary). *Exact*: additionally ``lambda_min >= N * residual``.

    Parameters
    ----------
    prog : SOSProgram
        The program whose SOS constraints are checked.
    sol : SOSSolution
        Its solution (:meth:`SOSProgram.solve`).
    n_samples : int, optional
        Number of sample points per constraint. Default 2000.
    sample_radius : float, optional
        Radius of the ball in ``x`` the points are drawn from, in the units of ``x``.
        Default 1.
    seed : int, optional
        Seed of the random generator. Default 0.
    eig_tol : float, optional
        Tolerance on the smallest Gram eigenvalue, relative to ``max(1, |G|)``. Default 1e-7.
    res_tol : float, optional
        Tolerance on the residual and on the sampled values, relative to ``max(1, |p|)``.
        Default 1e-7.

    Returns
    -------
    list of Check
        One per SOS constraint, in program order.
    """
    rng = np.random.default_rng(seed)
    out = []
    for k, c in enumerate(prog.sos):
        key = f"{k}:{c.name}"
        p = c.poly.value(sol.y)
        N = c.basis.shape[0]
        if N == 0:
            res = float(np.max(np.abs(p.c0))) if p.c0.size else 0.0
            out.append(Check(c.name, c.region, 0, 0.0, res, -res, res <= res_tol, res == 0.0))
            continue
        G = sol.grams[key]
        residual = gram_residual(p, c.basis, G)
        min_eig = float(np.linalg.eigvalsh((G + G.T) / 2).min())
        n = p.n_vars
        pts = rng.normal(size=(n_samples, n))
        pts *= (sample_radius * rng.random(n_samples) ** (1 / n) / np.linalg.norm(pts, axis=1))[:, None]
        if n > prog.n_vars:  # SOS matrix: v on the unit sphere
            v = rng.normal(size=(n_samples, n - prog.n_vars))
            pts[:, prog.n_vars:] = v / np.linalg.norm(v, axis=1, keepdims=True)
        vals = p.evaluate(pts)
        sampled_min = float(vals.min())
        pscale = max(1.0, float(np.max(np.abs(p.c0))))
        gscale = max(1.0, float(np.max(np.abs(G))))
        certified = (min_eig >= -eig_tol * gscale and residual <= res_tol * pscale
                     and sampled_min >= -res_tol * pscale * N)
        exact = certified and min_eig >= N * residual
        out.append(Check(c.name, c.region, N, min_eig, residual, sampled_min, bool(certified), bool(exact)))
    return out
