"""Affine matrix expressions and LMI programs, handed to Clarabel as arrays (no modelling layer).

The robust and PDLF programs (:mod:`satfmu.synthesis.robust.robust_design`,
:mod:`satfmu.synthesis.robust.pdlf`) are small
matrix inequalities, affine in a few hundred scalars, repeated over many plants or vertices. A
general modelling layer re-canonicalizes each of them expression by expression (cvxpy spent a
quarter of the DEMETER table's time there, and added symmetry equalities to every LMI); here an
:class:`Affine` holds its coefficients as one dense array over the variables it involves, the
operations are numpy products on that array, and :class:`LMIProgram` writes each inequality
straight into Clarabel's scaled-svec PSD cone (:mod:`satfmu.synthesis.core.conic`).

An :class:`Affine` of shape ``(r, c)`` is ``X(x) = C0 + sum_k x_{v_k} C_k``: ``coef`` has shape
``(r c, 1 + len(vars))``, row-major entries, column 0 the constant. It supports ``+``, ``-``,
products with numbers and constant matrices (``M @ X``, ``X @ M``; a 1 x 1 expression times a
constant matrix), ``X.T``, ``/`` by a number, and :func:`bmat` / :func:`vstack` of expressions
and constants; numpy arrays on the left defer to it. Products of two expressions are refused
(they would not be affine).

Size guard: Clarabel factors its KKT system in memory, and a failed allocation in its Rust
core aborts the Python process (no exception to catch). Each program therefore keeps an
estimate of its factor's size as it is built (:meth:`LMIProgram.solver_bytes`) and refuses,
with :class:`~satfmu.synthesis.robust.lft_plant.ProgramTooLargeError`, to grow past ``max_bytes`` (default
:data:`MAX_SOLVER_BYTES`, half the machine's memory), before the solver runs. The estimate
follows the factor of a good elimination order; Clarabel's own order can fill far more (row 14's
vertex i2p analysis: 5.7 GB estimated, a single 12.6 GB allocation asked). So a program estimated
above :data:`ISOLATE_BYTES` is solved in a child process capped at ``max_bytes``
(:func:`satfmu.synthesis.core.conic.solve_clarabel`'s ``memory_limit``), and running out there is the same
``ProgramTooLargeError``.
"""
from __future__ import annotations

import logging
import os
import time
from dataclasses import dataclass
from typing import Any, Hashable, Sequence

import numpy as np
import scipy.sparse as sps

from satfmu.synthesis.core import solve_policy
from satfmu.fmus.errors import ProgramTooLargeError
from satfmu.synthesis.core.conic import (REFUTED, SOLVED, ConicProblem, SolverMemoryError, solve_clarabel, svec_indices,
                                    svec_scale)
from satfmu.fmus.errors import LMIError


LOG = logging.getLogger(__name__)
"""Each solve at DEBUG: its outcome, seconds and size (for cost breakdowns of long runs)."""

FACTORIZATION: dict[str, Any] = {"direct_solve_method": "faer", "max_threads": 1}
"""Clarabel's KKT factorization for LMI programs (a rung's settings override it): faer's
supernodal LDL^T, which handles the dense block that each PSD cone of order N puts in the KKT
matrix (N(N+1)/2 rows) as dense blocks, on one thread. DEMETER row 10's 21-cone program of
order <= 32, two interleaved runs: 1.51 / 1.84 s on one thread, 2.14 / 2.27 s with Clarabel's
default (``"auto"``: faer on every core), 6.16 / 6.93 s with QDLDL."""


def _half_the_memory(default: int = 8 * 2**30) -> int:
    """Half the physical memory, bytes (``default`` where the OS does not say: Windows)."""
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") // 2
    except (AttributeError, ValueError, OSError):
        return default


MAX_SOLVER_BYTES = _half_the_memory()
"""Default largest :meth:`LMIProgram.solver_bytes` of a program (half the physical memory)."""

ISOLATE_BYTES = 2**30
"""Programs estimated above this (bytes) are solved in a child process capped at their
``max_bytes`` (module docstring); below it a new interpreter (about 1 s) would cost more than the risk."""

BYTES_PER_ENTRY = 64
"""Bytes of the solver per entry of the estimate of :meth:`LMIProgram.solver_bytes`, fitted on
Clarabel 0.11 to the largest of three DEMETER programs so that it over-estimates the others:
105 PSD cones of order up to 32 (9411 rows) over 1070 variables, 1.1e7 entries, used 0.42 GB
(0.72 estimated); 777 cones up to 51 (182,268 rows) over 3083 variables, 6.1e8 entries, asked
38.8 GB at once and aborted (38.8 estimated); the two-axis PDLF program, 32 cones of order 48
and 32 of 16, 1.3e8 entries, over 13 GB when stopped (8.5 estimated)."""


def _const(value, shape: tuple[int, int] | None = None) -> np.ndarray:
    a = np.asarray(value, dtype=float)
    if a.ndim == 0 and shape is not None:
        return np.full(shape, float(a))
    if a.ndim == 1:
        a = a.reshape(-1, 1) if shape is None or shape[1] == 1 else a.reshape(1, -1)
    if a.ndim != 2:
        raise LMIError(f"a constant must be a number or a matrix, got shape {a.shape}")
    return a


class Affine:
    """An affine matrix expression ``C0 + sum_k x_{vars[k]} C_k`` (module docstring).

    Built by :meth:`LMIProgram.variable`, :meth:`constant` and the operations, rarely directly.

    Parameters
    ----------
    shape : tuple of (int, int)
        ``(r, c)``, the shape of the matrix.
    vars : numpy.ndarray of int, shape (n_vars,)
        Indices of the program's scalar variables the expression involves, sorted.
    coef : numpy.ndarray, shape (r c, 1 + n_vars)
        Coefficients: row-major entries, column 0 the constant ``C0``, column ``1 + k`` the
        coefficient ``C_k`` of variable ``vars[k]``.
    """

    __array_ufunc__ = None  # numpy defers ``M @ X``, ``M + X`` to the reflected methods
    __slots__ = ("shape", "vars", "coef")

    def __init__(self, shape: tuple[int, int], vars: np.ndarray, coef: np.ndarray) -> None:
        self.shape = (int(shape[0]), int(shape[1]))
        self.vars = vars
        self.coef = coef

    @classmethod
    def constant(cls, value) -> Affine:
        """A constant expression (no variables).

        Parameters
        ----------
        value : float or array_like
            A matrix; a 1-D array is a column, a number is 1 x 1.

        Raises
        ------
        LMIError
            If ``value`` has more than two dimensions.
        """
        a = _const(value)
        return cls(a.shape, np.zeros(0, dtype=np.int64), a.reshape(-1, 1).copy())

    def _c3(self) -> np.ndarray:
        return self.coef.reshape(self.shape[0], self.shape[1], -1)

    def _lifted(self, vars: np.ndarray) -> np.ndarray:
        """``coef`` over the (sorted) superset ``vars`` of its variables."""
        if len(vars) == len(self.vars):
            return self.coef
        out = np.zeros((self.coef.shape[0], 1 + len(vars)))
        out[:, 0] = self.coef[:, 0]
        out[:, 1 + np.searchsorted(vars, self.vars)] = self.coef[:, 1:]
        return out

    def __add__(self, other) -> Affine:
        if isinstance(other, Affine):
            if other.shape != self.shape:
                raise LMIError(f"cannot add shapes {self.shape} and {other.shape}")
            vars = np.union1d(self.vars, other.vars)
            return Affine(self.shape, vars, self._lifted(vars) + other._lifted(vars))
        c = _const(other, self.shape)
        if c.shape != self.shape:
            raise LMIError(f"cannot add shapes {self.shape} and {c.shape}")
        coef = self.coef.copy()
        coef[:, 0] += c.ravel()
        return Affine(self.shape, self.vars, coef)

    __radd__ = __add__

    def __neg__(self) -> Affine:
        return Affine(self.shape, self.vars, -self.coef)

    def __sub__(self, other) -> Affine:
        return self + (-other)

    def __rsub__(self, other) -> Affine:
        return (-self) + other

    def __mul__(self, other) -> Affine:
        if isinstance(other, Affine):
            raise LMIError("a product of two expressions is not affine")
        c = np.asarray(other, dtype=float)
        if c.ndim == 0:
            return Affine(self.shape, self.vars, self.coef * float(c))
        if self.shape != (1, 1):
            raise LMIError(f"only a 1 x 1 expression multiplies a matrix, got shape {self.shape}")
        c = _const(c)
        return Affine(c.shape, self.vars, np.outer(c.ravel(), self.coef[0]))

    __rmul__ = __mul__

    def __truediv__(self, other) -> Affine:
        return self * (1.0 / float(other))

    def __matmul__(self, other) -> Affine:
        if isinstance(other, Affine):
            raise LMIError("a product of two expressions is not affine")
        M = _const(other)
        if M.shape[0] != self.shape[1]:
            raise LMIError(f"cannot multiply shapes {self.shape} and {M.shape}")
        out = np.matmul(M.T, self._c3())  # (r, q, nv): row i of X M is M^T applied to X's row i
        return Affine((self.shape[0], M.shape[1]), self.vars, out.reshape(-1, self.coef.shape[1]))

    def __rmatmul__(self, other) -> Affine:
        M = _const(other)
        if M.shape[1] != self.shape[0]:
            raise LMIError(f"cannot multiply shapes {M.shape} and {self.shape}")
        out = M @ self.coef.reshape(self.shape[0], -1)
        return Affine((M.shape[0], self.shape[1]), self.vars, out.reshape(-1, self.coef.shape[1]))

    @property
    def T(self) -> Affine:
        """The transposed expression."""
        c3 = self._c3().transpose(1, 0, 2)
        return Affine((self.shape[1], self.shape[0]), self.vars, np.ascontiguousarray(c3).reshape(self.coef.shape))


def _as_affine(block) -> Affine:
    return block if isinstance(block, Affine) else Affine.constant(block)


def bmat(blocks: Sequence[Sequence[Any]]) -> Affine:
    """The block matrix of expressions and constants (rows of blocks; sizes must agree).

    Parameters
    ----------
    blocks : sequence of sequence
        Rows of blocks, each an :class:`Affine` or a constant (number or matrix); the blocks of a
        row have one height, those of a column one width.

    Returns
    -------
    Affine
        The assembled matrix, over the union of the blocks' variables.

    Raises
    ------
    LMIError
        If the block sizes do not agree.
    """
    grid = [[_as_affine(b) for b in row] for row in blocks]
    heights = [row[0].shape[0] for row in grid]
    widths = [b.shape[1] for b in grid[0]]
    for i, row in enumerate(grid):
        if len(row) != len(widths) or any(b.shape != (heights[i], widths[j]) for j, b in enumerate(row)):
            raise LMIError(f"block row {i} does not match the block sizes {heights} x {widths}")
    vars = np.unique(np.concatenate([b.vars for row in grid for b in row]))
    out = np.zeros((sum(heights), sum(widths), 1 + len(vars)))
    r0 = 0
    for i, row in enumerate(grid):
        c0 = 0
        for j, b in enumerate(row):
            out[r0:r0 + heights[i], c0:c0 + widths[j]] = b._lifted(vars).reshape(heights[i], widths[j], -1)
            c0 += widths[j]
        r0 += heights[i]
    return Affine(out.shape[:2], vars, out.reshape(-1, 1 + len(vars)))


def vstack(blocks: Sequence[Any]) -> Affine:
    """Expressions and constants stacked vertically.

    Parameters
    ----------
    blocks : sequence
        :class:`Affine` expressions and constants of one width, top to bottom.

    Returns
    -------
    Affine
        The stacked matrix (:func:`bmat` of one column).
    """
    return bmat([[b] for b in blocks])


@dataclass
class LMISolution:
    """What :meth:`LMIProgram.solve` gave: the ladder's outcome and, when solved, ``x`` and the
    dual ``z`` (Clarabel's, one entry per constraint row).

    Attributes
    ----------
    outcome : satfmu.synthesis.core.solve_policy.SolveOutcome
        The solve ladder's status and attempts.
    x : numpy.ndarray or None
        The value of every scalar variable, shape (n,); None when not solved.
    objective : float
        The objective's value at ``x`` (as given, not negated for a maximization); nan without
        an objective or a solution.
    z : numpy.ndarray or None, optional
        Clarabel's dual, one entry per constraint row (scalar inequalities first, then the PSD
        cones' scaled svecs); None when not solved.
    """

    outcome: solve_policy.SolveOutcome
    x: np.ndarray | None
    objective: float
    z: np.ndarray | None = None

    @property
    def solved(self) -> bool:
        """Whether the ladder solved the program and ``x`` holds the solution."""
        return self.outcome.solved and self.x is not None


class LMIProgram:
    """Variables, LMIs ``M(x) >= 0`` and scalar inequalities ``e(x) >= 0``, as Clarabel's arrays.

    Parameters
    ----------
    max_bytes : int, optional
        Largest :meth:`solver_bytes` the program may grow to, bytes (default
        :data:`MAX_SOLVER_BYTES`); beyond it adding a constraint raises
        ``ProgramTooLargeError``.
    """

    def __init__(self, max_bytes: int | None = None) -> None:
        self.n = 0
        self.max_bytes = MAX_SOLVER_BYTES if max_bytes is None else int(max_bytes)
        """Largest :meth:`solver_bytes` accepted (module docstring)."""
        self._psd_rows: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []  # (b, vars, A block)
        self._psd: list[int] = []
        self._tags: list[Hashable] = []  # one per PSD cone (None: untagged)
        self._nonneg: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
        self._cone_entries = self._rows = 0
        self.solution: LMISolution | None = None

    def solver_bytes(self) -> int:
        """Estimated memory of Clarabel's factorization of the program as built so far, bytes.

        A PSD cone of ``d = N (N + 1) / 2`` rows puts a dense ``d x d`` block into the KKT
        matrix, and the factor couples every constraint row to the variables: ``sum d^2 + R n``
        entries for ``R`` rows and ``n`` variables, times :data:`BYTES_PER_ENTRY` (a fit to
        measured solves, within 2x above them).
        """
        return BYTES_PER_ENTRY * (self._cone_entries + self._rows * self.n)

    def _grow(self, rows: int, dense: bool, what: str) -> None:
        self._rows += rows
        self._cone_entries += rows * rows if dense else 0
        if self.solver_bytes() > self.max_bytes:
            raise ProgramTooLargeError(
                f"the LMI program would need about {self.solver_bytes() / 1e9:.3g} GB in the solver "
                f"({len(self._psd)} PSD cones up to order {max(self._psd, default=0)}, {self.n} variables, "
                f"at {what}) > max_bytes = {self.max_bytes / 1e9:.3g} GB")

    def variable(self, shape: tuple[int, int] = (1, 1), symmetric: bool = False) -> Affine:
        """A new matrix variable (``symmetric``: ``r (r + 1) / 2`` scalars, square shape).

        Parameters
        ----------
        shape : tuple of (int, int), optional
            ``(r, c)``, the shape of the variable (default a scalar).
        symmetric : bool, optional
            A symmetric matrix (``r == c``), one scalar per entry of its upper triangle.

        Returns
        -------
        Affine
            The variable, over ``r c`` (or ``r (r + 1) / 2``) new scalars.

        Raises
        ------
        LMIError
            If a symmetric variable is not square.
        """
        r, c = shape
        if symmetric:
            if r != c:
                raise LMIError(f"a symmetric variable must be square, got {shape}")
            i, j = np.triu_indices(r)
            k = np.arange(len(i))
            coef = np.zeros((r * r, 1 + len(i)))
            coef[i * r + j, 1 + k] = 1.0
            coef[j * r + i, 1 + k] = 1.0
        else:
            k = np.arange(r * c)
            coef = np.zeros((r * c, 1 + r * c))
            coef[k, 1 + k] = 1.0
        vars = self.n + np.arange(coef.shape[1] - 1, dtype=np.int64)
        self.n += len(vars)
        return Affine((r, c), vars, coef)

    def add_psd(self, M: Affine, tag: Hashable = None) -> None:
        """``M(x) >= 0`` (its symmetric part), one PSD cone of order ``M.shape[0]``; ``tag`` names
        it for :meth:`dual_weights`.

        Parameters
        ----------
        M : Affine
            A square expression (or constant matrix); only its symmetric part counts.
        tag : hashable, optional
            A name that groups the cone for :meth:`dual_weights` (None: not reported).

        Raises
        ------
        ProgramTooLargeError
            If the program would then exceed ``max_bytes`` (:meth:`solver_bytes`).
        """
        M = _as_affine(M)
        N = M.shape[0]
        if M.shape != (N, N):
            raise LMIError(f"an LMI needs a square matrix, got shape {M.shape}")
        i, j = svec_indices(N)
        rows = 0.5 * (M.coef[i * N + j] + M.coef[j * N + i]) * svec_scale(N)[:, None]
        self._psd_rows.append((rows[:, 0], M.vars, -rows[:, 1:]))
        self._psd.append(N)
        self._tags.append(tag)
        self._grow(len(i), True, f"an LMI of order {N}")

    def add_nonneg(self, e: Affine) -> None:
        """Every entry of ``e(x) >= 0``.

        Parameters
        ----------
        e : Affine
            An expression (or constant) of any shape, one inequality per entry.

        Raises
        ------
        ProgramTooLargeError
            If the program would then exceed ``max_bytes`` (:meth:`solver_bytes`).
        """
        e = _as_affine(e)
        self._nonneg.append((e.coef[:, 0], e.vars, -e.coef[:, 1:]))
        self._grow(e.coef.shape[0], False, "a scalar inequality")

    def _problem(self, objective: Affine | None) -> ConicProblem:
        q = np.zeros(self.n)
        if objective is not None:
            if objective.shape != (1, 1):
                raise LMIError(f"the objective must be 1 x 1, got shape {objective.shape}")
            q[objective.vars] = objective.coef[0, 1:]
        if not self._nonneg and not self._psd_rows:
            raise LMIError("the program has no constraints")
        bs, ri, ci, vi = [], [], [], []
        row = 0
        for b, vars, A in self._nonneg + self._psd_rows:
            r, c = np.nonzero(A)
            ri.append(row + r)
            ci.append(vars[c])
            vi.append(A[r, c])
            bs.append(b)
            row += len(b)
        A = sps.csc_matrix((np.concatenate(vi), (np.concatenate(ri), np.concatenate(ci))), shape=(row, self.n))
        return ConicProblem(q, A, np.concatenate(bs), 0, sum(len(b) for b, _, _ in self._nonneg), list(self._psd))

    def solve(self, objective: Affine | None = None, *, maximize: bool = False,
              ladder: Sequence[tuple[str, dict[str, Any]]] | solve_policy.RungMemory = solve_policy.LADDER
              ) -> LMISolution:
        """Minimize (or maximize) the 1 x 1 ``objective`` (feasibility if None) under the
        project's solve policy (:mod:`satfmu.synthesis.core.solve_policy`; ``ladder`` a sequence of rungs or
        a :class:`~satfmu.synthesis.core.solve_policy.RungMemory` shared by a family of programs); the
        values are then read with :meth:`value`.

        Parameters
        ----------
        objective : Affine, optional
            A 1 x 1 expression; None for a feasibility problem.
        maximize : bool, optional
            Maximize ``objective`` instead of minimizing it.
        ladder : sequence of (str, dict) or satfmu.synthesis.core.solve_policy.RungMemory, optional
            The rungs (solver, settings) to try in turn (default
            :data:`satfmu.synthesis.core.solve_policy.LADDER`); the solver must be ``"CLARABEL"``.

        Returns
        -------
        LMISolution
            The outcome, also kept as ``solution``.

        Raises
        ------
        ProgramTooLargeError
            If the solver runs out of memory in its child process.
        LMIError
            If the program has no constraints or the objective is not 1 x 1.
        """
        obj = None if objective is None else (-objective if maximize else objective)
        problem = self._problem(obj)
        results = []
        limit = self.max_bytes if self.solver_bytes() > ISOLATE_BYTES else None

        def run(solver: str, settings: dict[str, Any]) -> str:
            if solver != "CLARABEL":
                raise LMIError(f"LMIProgram solves with Clarabel only, got {solver!r}")
            try:
                results.append(solve_clarabel(problem, memory_limit=limit, **{**FACTORIZATION, **settings}))
            except SolverMemoryError as exc:
                raise ProgramTooLargeError(
                    f"the LMI program ran out of memory in the solver ({len(self._psd)} PSD cones up to order "
                    f"{max(self._psd, default=0)}, {self.n} variables, {self.solver_bytes() / 1e9:.3g} GB "
                    f"estimated): {exc}") from exc
            status = results[-1].status
            if status not in SOLVED.values() and status not in REFUTED.values():
                raise solve_policy.SolverFailure(status)
            return status

        t0 = time.perf_counter()
        outcome = solve_policy.solve_with(run, ladder)
        LOG.debug("LMI solve: %s in %.3f s (%s), %d PSD cones up to order %d, %d rows, %d variables",
                  outcome.status, time.perf_counter() - t0,
                  ", ".join(f"{a.status} {a.seconds:.3f} s" for a in outcome.attempts),
                  len(self._psd), max(self._psd, default=0), self._rows, self.n)
        x = results[-1].x if outcome.solved else None
        value = float("nan")
        if x is not None and objective is not None:
            value = float(objective.coef[0, 0] + objective.coef[0, 1:] @ x[objective.vars])
        self.solution = LMISolution(outcome, x, value, results[-1].z if x is not None else None)
        return self.solution

    def dual_weights(self) -> dict[Hashable, float]:
        """Per tag of :meth:`add_psd`, the summed Frobenius norms of its cones' dual matrices at
        the last solve (the svec's 2-norm: the scaled svec is an isometry). By complementary
        slackness a cone strictly inside the PSD cone at the optimum has a zero dual: a small
        weight marks LMIs that do not bind (to the solver's accuracy)."""
        if self.solution is None or self.solution.z is None:
            raise LMIError("no dual to read: solve first (and check that it solved)")
        out: dict[Hashable, float] = {}
        row = sum(len(b) for b, _, _ in self._nonneg)
        for N, tag in zip(self._psd, self._tags):
            d = N * (N + 1) // 2
            if tag is not None:
                out[tag] = out.get(tag, 0.0) + float(np.linalg.norm(self.solution.z[row:row + d]))
            row += d
        return out

    def value(self, e: Affine) -> np.ndarray:
        """The value of ``e`` at the last solve's solution.

        Parameters
        ----------
        e : Affine
            An expression in the program's variables (or a constant).

        Returns
        -------
        numpy.ndarray
            Its value, of its shape.

        Raises
        ------
        LMIError
            If the program was not solved.
        """
        if self.solution is None or self.solution.x is None:
            raise LMIError("no solution to read: solve first (and check that it solved)")
        e = _as_affine(e)
        return (e.coef[:, 0] + e.coef[:, 1:] @ self.solution.x[e.vars]).reshape(e.shape)
