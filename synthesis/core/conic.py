"""Conic programs in Clarabel's standard form, handed to Clarabel as arrays.

A :class:`ConicProblem` is

    minimize q^T x   subject to   A x + s = b,   s in {0}^zero x R_+^nonneg x S(N_1) x ... x S(N_p)

where ``S(N)`` is the cone of N x N positive semidefinite matrices in Clarabel's
*scaled svec* form: the upper triangle in column-major order,
``(0,0), (0,1), (1,1), (0,2), (1,2), (2,2), ...``, off-diagonal entries times sqrt 2 (so
the svec inner product is the trace inner product; :func:`svec_indices`,
:func:`svec_scale`). :func:`solve_clarabel` hands the arrays to
``clarabel.DefaultSolver`` as they are: no modelling layer re-canonicalizes them.

A failed allocation in Clarabel's Rust core aborts the process, with no exception to catch.
With ``memory_limit``, :func:`solve_clarabel` therefore solves in a child interpreter whose
address space is capped at that many bytes above its own, and turns the child's death into
:class:`SolverMemoryError` (where the OS has no address-space limit, e.g. Windows, it solves
in the process).
"""
from __future__ import annotations

import os
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import scipy.sparse as sps
from satfmu.fmus.errors import SolverMemoryError

SOLVED = {"Solved": "optimal", "AlmostSolved": "optimal_inaccurate"}
"""Clarabel statuses with a solution, and their names in :class:`ConicResult` (those cvxpy
gives them, as the SOS layer's solutions always said)."""
REFUTED = {"PrimalInfeasible": "infeasible", "DualInfeasible": "unbounded",
           "AlmostPrimalInfeasible": "infeasible_inaccurate", "AlmostDualInfeasible": "unbounded_inaccurate"}
"""Clarabel's certificates of infeasibility or unboundedness (clean, or to a reduced accuracy), in
the words of :mod:`satfmu.synthesis.core.solve_policy`."""


@dataclass
class ConicProblem:
    """``min q^T x`` s.t. ``A x + s = b``, ``s`` in the product of cones (order: zero,
    non-negative, then one PSD cone per entry of ``psd``, each of ``N (N + 1) / 2`` rows).

    Attributes
    ----------
    q : numpy.ndarray, shape (n,)
        Cost vector.
    A : scipy.sparse.csc_matrix, shape (m, n)
        Constraint matrix, rows in the cones' order.
    b : numpy.ndarray, shape (m,)
        Constraint right-hand side.
    zero : int
        Rows of the zero cone (equalities), first.
    nonneg : int
        Rows of the non-negative cone, next.
    psd : list of int
        Orders ``N`` of the PSD cones, last, each in scaled svec form (:func:`svec_indices`).
    """

    q: np.ndarray
    A: sps.csc_matrix
    b: np.ndarray
    zero: int
    nonneg: int
    psd: list[int]
    """Orders ``N`` of the PSD cones."""


@dataclass
class ConicResult:
    """Clarabel's answer: the status (``optimal``, ``optimal_inaccurate``, ``infeasible``,
    ``unbounded``, their ``_inaccurate`` forms, or Clarabel's own word for a failure, e.g.
    ``NumericalError``, ``MaxIterations``), ``x``
    when a solution is present, ``q^T x``, Clarabel's wall time (s, setting up and
    solving) and, with ``x``, the dual ``z`` (one entry per row of ``A``, the cones' order).

    Attributes
    ----------
    status : str
        ``"optimal"``, ``"optimal_inaccurate"`` (:data:`SOLVED`), a refutation of :data:`REFUTED`
        or Clarabel's status of a failure.
    x : numpy.ndarray or None
        The primal solution, shape (n,); None without a solution.
    objective : float
        ``q^T x``; nan without a solution.
    seconds : float
        Clarabel's wall time, setting up and solving (s).
    z : numpy.ndarray or None, optional
        The dual, shape (m,); None without a solution.
    iterations : int, optional
        Clarabel's interior-point iterations.
    """

    status: str
    x: np.ndarray | None
    objective: float
    seconds: float
    z: np.ndarray | None = None
    iterations: int = 0
    """Clarabel's interior-point iterations."""


def svec_indices(N: int) -> tuple[np.ndarray, np.ndarray]:
    """Row and column ``(i, j)``, ``i <= j``, of each entry of the svec of an N x N matrix,
    in Clarabel's order (upper triangle, column-major).

    Parameters
    ----------
    N : int
        Order of the matrix.

    Returns
    -------
    i, j : numpy.ndarray of int, shape (N (N + 1) / 2,)
        Row and column of each svec entry.
    """
    j, i = np.tril_indices(N)
    return i, j


def svec_scale(N: int) -> np.ndarray:
    """1 on the diagonal, sqrt 2 off it, in :func:`svec_indices` order.

    Parameters
    ----------
    N : int
        Order of the matrix.

    Returns
    -------
    numpy.ndarray, shape (N (N + 1) / 2,)
        The factor of each svec entry.
    """
    i, j = svec_indices(N)
    return np.where(i == j, 1.0, np.sqrt(2.0))


def _address_space() -> int | None:
    """This process's virtual memory size, bytes (None where /proc does not say)."""
    try:
        with open("/proc/self/statm") as f:
            return int(f.read().split()[0]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, AttributeError):
        return None


def _serve() -> None:
    """The child's side of :func:`_isolated`: read ``(problem, settings, memory_limit)`` pickled
    on stdin, cap the address space that far above this fresh interpreter's, solve, and write
    the pickled answer (or the exception) to stdout."""
    import pickle
    import resource

    import clarabel  # noqa: F401  (loaded before the cap: mapping it is not the solve's memory)

    answer = os.fdopen(os.dup(1), "wb")
    os.dup2(2, 1)  # anything the solver prints goes to stderr, not into the answer
    problem, settings, memory_limit = pickle.load(sys.stdin.buffer)
    limit = _address_space() + memory_limit
    resource.setrlimit(resource.RLIMIT_AS, (limit, resource.getrlimit(resource.RLIMIT_AS)[1]))
    try:
        out: Any = _solve(problem, settings)
    except MemoryError:
        out = SolverMemoryError()
    except Exception as exc:  # re-raised in the parent (a bad setting, ...)
        out = exc
    pickle.dump(out, answer)
    answer.close()


def _isolated(problem: ConicProblem, settings: dict[str, Any], memory_limit: int) -> ConicResult:
    """Solve in a new interpreter (not a fork: a fork of a process whose solver thread pool is
    running deadlocks in the child) whose address space is capped ``memory_limit`` bytes above
    its own at start (:func:`_serve`)."""
    import pickle
    import subprocess

    root = str(Path(__file__).resolve().parents[2])  # the directory holding this package
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [root, os.environ.get("PYTHONPATH")]))}
    env.pop("PYTHONFAULTHANDLER", None)  # an abort there is the expected answer, not a crash to report
    run = subprocess.run([sys.executable, "-c", "from satfmu.synthesis.core.conic import _serve; _serve()"],
                         input=pickle.dumps((problem, settings, memory_limit)), capture_output=True, env=env)
    try:
        out = pickle.loads(run.stdout)
    except (pickle.UnpicklingError, EOFError):  # no answer: the child died (Clarabel's allocation failed)
        last = run.stderr.decode(errors="replace").strip().splitlines()[-1:]
        out = SolverMemoryError(f"exit code {run.returncode}{': ' + last[0] if last else ''}")
    if isinstance(out, SolverMemoryError):
        raise SolverMemoryError(f"Clarabel needed more than {memory_limit / 1e9:.3g} GB "
                                f"(its process ended with {str(out) or 'a memory error'})")
    if isinstance(out, Exception):
        raise out
    return out


THREADED_FROM = 48
"""Side of the largest PSD cone from which Clarabel factors on every core (``max_threads`` 0);
below it, one thread. Measured (``python bench/sos_threads.py --repeat 3``, 2 cores, ratios of
median wall and CPU time, every core against one thread): sides 21 to 45 (seed 000's Theorem 1,
side 33, and lower bounds of random sums of squares) 0.94-1.29x the wall time for 1.07-1.29x the
CPU; sides 55 to 78 (seed 001's Theorem 8, sides 57 and 54: 14.5 s against 16.1 s) 0.88-1.03x
the wall time for 1.07-1.21x the CPU."""


def threads_for(problem: ConicProblem) -> int:
    """Clarabel's ``max_threads`` for ``problem``: 1 below :data:`THREADED_FROM`, else 0 (every core).

    Parameters
    ----------
    problem : ConicProblem
        The program.
    """
    return 0 if max(problem.psd, default=0) >= THREADED_FROM else 1


def solve_clarabel(problem: ConicProblem, *, memory_limit: int | None = None, **settings: Any) -> ConicResult:
    """Solve with ``clarabel.DefaultSolver`` on the problem's arrays (no re-formulation).

    ``settings`` are attributes of ``clarabel.DefaultSettings`` (e.g. ``tol_feas``);
    ``verbose`` is off and ``max_threads`` is :func:`threads_for` the problem unless given.
    ``memory_limit`` (bytes): solve in a child process allowed
    that much memory (module docstring); None: in this process.

    Parameters
    ----------
    problem : ConicProblem
        The program.
    memory_limit : int, optional
        Memory the solve may take, bytes: the solve runs in a child process whose address space
        is capped that far above its own at start. None (default): solved in this process (so
        too where the OS has no address-space limit).

    Returns
    -------
    ConicResult
        Clarabel's status, solution and time.

    Raises
    ------
    TypeError
        If a setting is not one of Clarabel's.
    SolverMemoryError
        If Clarabel needs more than ``memory_limit``.
    """
    if memory_limit is not None and _address_space() is not None:
        return _isolated(problem, settings, int(memory_limit))
    return _solve(problem, settings)


def _solve(problem: ConicProblem, settings: dict[str, Any]) -> ConicResult:
    import clarabel

    opts = clarabel.DefaultSettings()
    opts.verbose = False
    opts.max_threads = threads_for(problem)
    for name, value in settings.items():
        if not hasattr(opts, name):
            raise TypeError(f"Clarabel: unrecognized solver setting {name!r}")
        setattr(opts, name, value)
    cones = ([clarabel.ZeroConeT(problem.zero)] if problem.zero else []) + \
        ([clarabel.NonnegativeConeT(problem.nonneg)] if problem.nonneg else []) + \
        [clarabel.PSDTriangleConeT(N) for N in problem.psd]
    n = len(problem.q)
    t0 = time.perf_counter()
    sol = clarabel.DefaultSolver(sps.csc_matrix((n, n)), problem.q, problem.A, problem.b, cones, opts).solve()
    seconds = time.perf_counter() - t0
    status = str(sol.status)
    if status in SOLVED:
        x = np.asarray(sol.x, float)
        return ConicResult(SOLVED[status], x, float(problem.q @ x), seconds, np.asarray(sol.z, float),
                           int(sol.iterations))
    return ConicResult(REFUTED.get(status, status), None, float("nan"), seconds, None, int(sol.iterations))

