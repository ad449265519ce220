"""The synthesis layer's one solve policy (synthesis/core/solve_policy.py): the ladder's rules."""
from __future__ import annotations

import cvxpy as cp
import numpy as np
import pytest

from satfmu.synthesis.core import solve_policy as sp_


def _scripted(statuses: list[str | Exception]):
    """A run function answering the rungs in turn with ``statuses`` (an exception is raised)."""
    calls: list[tuple[str, dict]] = []

    def run(solver: str, settings: dict) -> str:
        calls.append((solver, settings))
        answer = statuses[len(calls) - 1]
        if isinstance(answer, Exception):
            raise answer
        return answer

    return run, calls


@pytest.mark.parametrize(("statuses", "status", "tries"), [
    (["optimal"], "solved", 1),
    (["optimal_inaccurate"], "solved", 1),  # verification judges an inaccurate solution, no retry
    (["infeasible"], "infeasible", 1),  # a clean certificate is final
    (["unbounded"], "infeasible", 1),
    ([sp_.SolverFailure("numerical"), "optimal"], "solved", 2),
    ([cp.error.SolverError("stalled"), sp_.SolverFailure("kkt"), "optimal"], "solved", 3),
    (["infeasible_inaccurate", "optimal"], "solved", 2),  # an inaccurate claim is retried
    (["infeasible_inaccurate", "infeasible_inaccurate", sp_.SolverFailure("x")], "infeasible", 3),
    ([sp_.SolverFailure("a"), sp_.SolverFailure("b"), "user_limit"], "failed", 3),
])
def test_ladder_rules(statuses: list, status: str, tries: int) -> None:
    run, calls = _scripted(statuses)
    out = sp_.solve_with(run)
    assert out.status == status and len(out.attempts) == tries == len(calls)
    assert [c[1] for c in calls] == [s for _, s in sp_.LADDER[:tries]]  # the rungs in order
    assert out.solved == (status == "solved") and out.seconds >= 0.0


def test_solver_status_names_every_rung() -> None:
    run, _ = _scripted([sp_.SolverFailure("stalled"), "infeasible_inaccurate", "optimal"])
    out = sp_.solve_with(run)
    assert out.solver_status == ("solver error: stalled; retry clarabel relaxed: infeasible_inaccurate; "
                                 "retry clarabel regularized: optimal")
    assert out.solver == "CLARABEL"
    with pytest.raises(ValueError, match="empty"):
        sp_.solve_with(run, ladder=())


def test_rung_memory_starts_where_the_family_last_solved() -> None:
    memory = sp_.RungMemory()
    run, calls = _scripted([sp_.SolverFailure("a"), sp_.SolverFailure("b"), "optimal"])
    assert sp_.solve_with(run, memory).solved and len(calls) == 3
    # the next program of the family starts at the regularized rung, named in its status
    run, calls = _scripted(["optimal"])
    out = sp_.solve_with(run, memory)
    assert [c[1] for c in calls] == [sp_.REGULARIZED] and out.solver_status == "clarabel regularized: optimal"
    # a program that needs another rung still gets every rung, and that one is remembered
    run, calls = _scripted([sp_.SolverFailure("c"), "optimal"])
    out = sp_.solve_with(run, memory)
    assert [c[1] for c in calls] == [sp_.REGULARIZED, {}]
    assert out.solver_status == "clarabel regularized: solver error: c; retry clarabel: optimal"
    run, calls = _scripted(["optimal"])
    sp_.solve_with(run, memory)
    assert [c[1] for c in calls] == [{}]
    # an inaccurate certificate before the solve is not a rung that cannot start: no change
    run, _ = _scripted(["infeasible_inaccurate", "optimal"])
    sp_.solve_with(run, memory)
    assert memory.rungs() == sp_.LADDER
    with pytest.raises(ValueError, match="empty"):
        sp_.RungMemory(())


def test_cvxpy_problems_solve_and_certify_infeasibility() -> None:
    x = cp.Variable(2)
    prob = cp.Problem(cp.Minimize(cp.sum(x)), [x >= 1])
    out = sp_.solve_cvxpy(prob)
    assert out.solved and out.solver_status == "optimal" and len(out.attempts) == 1
    np.testing.assert_allclose(x.value, [1.0, 1.0], atol=1e-7)  # Clarabel's default tolerance, 1e-8
    X = cp.Variable((2, 2), symmetric=True)
    bad = cp.Problem(cp.Minimize(0), [X >> 0, X[0, 0] <= -1])
    out = sp_.solve_cvxpy(bad)
    assert out.status == "infeasible" and not out.solved
