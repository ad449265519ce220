"""Conic programs in Clarabel's standard form, handed to Clarabel as arrays.

A :class:`ConicProblem` is

    minimize q^T x   subject to   A x + s = b,   s in {0}^zero x R_+^nonneg x S(N_1) x ... x S(N_p)

where ``S(N)`` is the cone of N x N positive semidefinite matrices in Clarabel's
*scaled svec* form: the upper triangle in column-major order,
``(0,0), (0,1), (1,1), (0,2), (1,2), (2,2), ...``, off-diagonal entries times sqrt 2 (so
the svec inner product is the trace inner product; :func:`svec_indices`,
:func:`svec_scale`). :func:`solve_clarabel` hands the arrays to
``clarabel.DefaultSolver`` as they are: no modelling layer re-canonicalizes them.
"""
from __future__ import annotations

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


def solve_clarabel(problem: ConicProblem, **settings: Any) -> ConicResult:
    """Solve with ``clarabel.DefaultSolver`` on the problem's arrays (no re-formulation).

    ``settings`` are attributes of ``clarabel.DefaultSettings`` (e.g. ``tol_feas``);
    ``verbose`` is off unless given.

    Raises
    ------
    TypeError
        If a setting is not one of Clarabel's.
    """
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

