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
With ``memory_limit``, :func:`solve_clarabel` therefore solves in a forked child whose address
space is capped at that many bytes above the caller's, and turns the child's death into
:class:`SolverMemoryError` (where the OS has no ``fork`` or no address-space limit, e.g.
Windows, it solves in the process).
"""
from __future__ import annotations

import multiprocessing
import os
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.sparse as sps

SOLVED = {"Solved": "optimal", "AlmostSolved": "optimal_inaccurate"}
"""Clarabel statuses with a solution, and their names in :class:`ConicResult` (those cvxpy
gives them, as the SOS layer's solutions always said)."""
REFUTED = {"PrimalInfeasible": "infeasible", "DualInfeasible": "unbounded",
           "AlmostPrimalInfeasible": "infeasible_inaccurate", "AlmostDualInfeasible": "unbounded_inaccurate"}
"""Clarabel's certificates of infeasibility or unboundedness (clean, or to a reduced accuracy), in
the words of :mod:`synthesis.solve_policy`."""


@dataclass
class ConicProblem:
    """``min q^T x`` s.t. ``A x + s = b``, ``s`` in the product of cones (order: zero,
    non-negative, then one PSD cone per entry of ``psd``, each of ``N (N + 1) / 2`` rows)."""

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
    when a solution is present, ``q^T x`` and Clarabel's wall time (s, setting up and
    solving)."""

    status: str
    x: np.ndarray | None
    objective: float
    seconds: float


def svec_indices(N: int) -> tuple[np.ndarray, np.ndarray]:
    """Row and column ``(i, j)``, ``i <= j``, of each entry of the svec of an N x N matrix,
    in Clarabel's order (upper triangle, column-major)."""
    j, i = np.tril_indices(N)
    return i, j


def svec_scale(N: int) -> np.ndarray:
    """1 on the diagonal, sqrt 2 off it, in :func:`svec_indices` order."""
    i, j = svec_indices(N)
    return np.where(i == j, 1.0, np.sqrt(2.0))


class SolverMemoryError(MemoryError):
    """Clarabel ran out of the memory allowed to it (:func:`solve_clarabel`'s ``memory_limit``)."""


def _address_space() -> int | None:
    """This process's virtual memory size, bytes (None where /proc does not say)."""
    try:
        with open("/proc/self/statm") as f:
            return int(f.read().split()[0]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, AttributeError):
        return None


def _child(problem: ConicProblem, settings: dict[str, Any], limit: int, conn) -> None:
    import faulthandler
    import resource

    faulthandler.disable()  # an abort here is the expected answer, not a crash to report
    resource.setrlimit(resource.RLIMIT_AS, (limit, resource.getrlimit(resource.RLIMIT_AS)[1]))
    try:
        conn.send(_solve(problem, settings))
    except MemoryError:
        conn.send(SolverMemoryError())
    except Exception as exc:  # re-raised in the parent (a bad setting, ...)
        conn.send(exc)


def _isolated(problem: ConicProblem, settings: dict[str, Any], memory_limit: int) -> ConicResult:
    ctx = multiprocessing.get_context("fork")
    receive, send = ctx.Pipe(duplex=False)
    child = ctx.Process(target=_child, args=(problem, settings, _address_space() + memory_limit, send))
    child.start()
    send.close()
    try:
        out = receive.recv()
    except EOFError:  # the child died without an answer: Clarabel's allocation failed
        out = SolverMemoryError()
    child.join()
    if isinstance(out, SolverMemoryError):
        raise SolverMemoryError(f"Clarabel needed more than {memory_limit / 1e9:.3g} GB "
                                f"(its process ended with exit code {child.exitcode})")
    if isinstance(out, Exception):
        raise out
    return out


def solve_clarabel(problem: ConicProblem, *, memory_limit: int | None = None, **settings: Any) -> ConicResult:
    """Solve with ``clarabel.DefaultSolver`` on the problem's arrays (no re-formulation).

    ``settings`` are attributes of ``clarabel.DefaultSettings`` (e.g. ``tol_feas``);
    ``verbose`` is off unless given. ``memory_limit`` (bytes): solve in a child process allowed
    that much memory (module docstring); None: in this process.

    Raises
    ------
    TypeError
        If a setting is not one of Clarabel's.
    SolverMemoryError
        If Clarabel needs more than ``memory_limit``.
    """
    if memory_limit is not None and hasattr(os, "fork") and _address_space() is not None:
        return _isolated(problem, settings, int(memory_limit))
    return _solve(problem, settings)


def _solve(problem: ConicProblem, settings: dict[str, Any]) -> ConicResult:
    import clarabel

    opts = clarabel.DefaultSettings()
    opts.verbose = False
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
        return ConicResult(SOLVED[status], x, float(problem.q @ x), seconds)
    return ConicResult(REFUTED.get(status, status), None, float("nan"), seconds)

