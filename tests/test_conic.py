"""Conic problems in Clarabel's form: the svec convention, the cones, the statuses."""
from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sps

from satfmu.synthesis.core.conic import (THREADED_FROM, ConicProblem, solve_clarabel, svec_indices, svec_scale,
                                        threads_for)


def _largest_offdiagonal(diagonal: tuple[float, float, float]) -> ConicProblem:
    """max X_01 over PSD X with the given diagonal (x = svec entries, unscaled)."""
    i, j = svec_indices(3)
    d = len(i)
    fix = sps.csr_matrix((np.ones(3), (np.arange(3), np.flatnonzero(i == j))), shape=(3, d))
    q = -1.0 * ((i == 0) & (j == 1))
    A = sps.vstack([fix, -sps.diags(svec_scale(3))], format="csc")
    return ConicProblem(q, A, np.r_[diagonal, np.zeros(d)], zero=3, nonneg=0, psd=[3])


def test_svec_is_clarabels_upper_triangle_by_columns() -> None:
    i, j = svec_indices(3)
    assert list(zip(i, j)) == [(0, 0), (0, 1), (1, 1), (0, 2), (1, 2), (2, 2)]
    assert np.allclose(svec_scale(3), [1, np.sqrt(2), 1, np.sqrt(2), np.sqrt(2), 1])
    # X_00 = 1, X_11 = 4, X_22 = 9: the largest X_01 is sqrt(1 * 4) = 2 only in this order
    res = solve_clarabel(_largest_offdiagonal((1.0, 4.0, 9.0)))
    assert res.status == "optimal" and res.objective == pytest.approx(-2.0, abs=1e-7)


def test_zero_nonnegative_and_psd_cones_together() -> None:
    # the same problem with one non-negative row, X_01 <= 1.5: the optimum moves to 1.5
    p = _largest_offdiagonal((1.0, 4.0, 9.0))
    i, j = svec_indices(3)
    row = sps.csr_matrix(((i == 0) & (j == 1)).astype(float))
    p = ConicProblem(p.q, sps.vstack([p.A[:3], row, p.A[3:]], format="csc"), np.r_[p.b[:3], 1.5, p.b[3:]],
                     zero=3, nonneg=1, psd=[3])
    res = solve_clarabel(p)
    assert res.status == "optimal" and res.objective == pytest.approx(-1.5, abs=1e-7)
    assert res.x[1] == pytest.approx(1.5, abs=1e-7)


def test_infeasible_and_bad_settings() -> None:
    res = solve_clarabel(_largest_offdiagonal((1.0, -1.0, 1.0)))  # a negative diagonal entry
    assert res.status == "infeasible" and res.x is None
    with pytest.raises(TypeError, match="no_such_setting"):
        solve_clarabel(_largest_offdiagonal((1.0, 1.0, 1.0)), no_such_setting=1)


def test_one_thread_below_the_threaded_cone_side_every_core_from_it(monkeypatch: pytest.MonkeyPatch) -> None:
    import clarabel

    def with_cones(*psd: int) -> ConicProblem:
        return ConicProblem(np.zeros(1), sps.csc_matrix((0, 1)), np.zeros(0), zero=0, nonneg=0, psd=list(psd))

    assert threads_for(with_cones()) == 1  # no PSD cone: an LP
    assert threads_for(with_cones(6, THREADED_FROM - 1)) == 1
    assert threads_for(with_cones(6, THREADED_FROM)) == 0  # Clarabel's "every core"
    seen: list[int] = []
    solver = clarabel.DefaultSolver

    def spy(P, q, A, b, cones, settings):  # type: ignore[no-untyped-def]
        seen.append(settings.max_threads)
        return solver(P, q, A, b, cones, settings)

    monkeypatch.setattr(clarabel, "DefaultSolver", spy)
    res = solve_clarabel(_largest_offdiagonal((1.0, 4.0, 9.0)))  # a cone of side 3: the rule's one thread
    assert res.status == "optimal" and res.iterations > 0
    res = solve_clarabel(_largest_offdiagonal((1.0, 4.0, 9.0)), max_threads=2)  # the caller's word wins
    assert res.status == "optimal" and res.iterations > 0
    assert seen == [1, 2]
