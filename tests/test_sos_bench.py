"""bench/sos_speed.py: its Drake programs are ours, coefficient by coefficient, and solve alike.

Drake (PyPI ``drake``) is a bench-only extra (``pip install -e '.[bench]'``): the tests that
need it skip without it. Seed 000's Theorem 1 is the smallest program of the bench (one
second per tool), global (one SOS matrix) and on ``|sigma| <= 0.9`` (with a multiplier).
"""
from __future__ import annotations

import importlib
import sys
from pathlib import Path
from types import ModuleType

import pytest

from satfmu.synthesis.polynomial_feedback import h2hinf_sos, hinf_sos

BENCH = Path(__file__).resolve().parents[1] / "bench"


@pytest.fixture(scope="module")
def sos_speed() -> ModuleType:
    """bench/sos_speed.py as a module (it imports its sibling bench/timing.py)."""
    sys.path.insert(0, str(BENCH))
    try:
        return importlib.import_module("sos_speed")
    finally:
        sys.path.remove(str(BENCH))


@pytest.fixture(scope="module")
def drake() -> None:
    pytest.importorskip("pydrake", reason="drake is a bench-only extra: pip install -e '.[bench]'")


def test_interleaved_runs_in_turn_and_limits_slow_contenders(sos_speed: ModuleType) -> None:
    calls: list[str] = []
    out = sos_speed.interleaved({k: (lambda k=k: calls.append(k) or k) for k in "abc"}, 3, {"c": 1})
    assert calls == ["a", "b", "c", "a", "b", "a", "b"]
    assert out == {"a": ["a"] * 3, "b": ["b"] * 3, "c": ["c"]}


def test_bounded_runs_return_the_result_or_say_why_there_is_none(sos_speed: ModuleType) -> None:
    """SumOfSquares.py runs in a bounded child: its result comes back through the pipe; a run
    past the time limit, past the memory limit, raising or dying is named, not waited for."""
    import os
    import time

    import numpy as np

    generous = sos_speed.Limits(seconds=60.0, memory_gib=8.0)
    assert sos_speed.bounded(lambda: ("ran", 3), generous) == ("ran", 3)
    t0 = time.perf_counter()
    slow = sos_speed.bounded(lambda: time.sleep(30), sos_speed.Limits(seconds=1.0, memory_gib=8.0))
    assert slow.reason.startswith("did not finish within 1 s") and slow.stopped, slow
    assert 1.0 < slow.seconds < 10  # the time it ran: the run takes longer
    assert time.perf_counter() - t0 < 10  # stopped, not waited for (poll every 0.5 s, kill)

    def grow() -> None:
        blocks = []
        while True:  # 64 MiB a step, touched so that it is resident
            blocks.append(np.ones(2**23))
            time.sleep(0.01)

    hungry = sos_speed.bounded(grow, sos_speed.Limits(seconds=60.0, memory_gib=0.5))
    assert hungry.reason.startswith("stopped at") and "limit 0.5 GiB" in hungry.reason and hungry.stopped, hungry

    def fail() -> None:
        raise ValueError("bad program")

    failed, died = sos_speed.bounded(fail, generous), sos_speed.bounded(lambda: os._exit(3), generous)
    assert failed.reason == "failed: ValueError: bad program" and not failed.stopped  # no bound on its time
    assert died.reason == "died with exit code 3" and not died.stopped


@pytest.mark.parametrize("region", [None, 0.9])
def test_drake_poses_our_theorem1_and_finds_the_same_optimum(sos_speed: ModuleType, drake: None,
                                                             region: float | None) -> None:
    ours, caught = sos_speed.run_ours(lambda: hinf_sos.theorem1(rate_margin=1e-2, region=region))
    bases = [c.basis for c in caught.program.sos]
    diff, scale = sos_speed.same_program(caught, sos_speed.drake_theorem1(bases, region))
    assert diff <= 1e-12 * scale
    theirs = sos_speed.run_drake(lambda: sos_speed.drake_theorem1(bases, region))
    assert theirs.gram_sizes == ours.gram_sizes == ((33,) if region is None else (1, 33))
    assert theirs.certified and ours.certified
    # both solve the same SDP with Clarabel to its default tolerance (1e-8)
    assert theirs.objective == pytest.approx(ours.objective, rel=1e-7)


def test_a_different_program_is_told_apart(sos_speed: ModuleType, drake: None) -> None:
    _, caught = sos_speed.run_ours(lambda: hinf_sos.theorem1(region=0.9))
    bases = [c.basis for c in caught.program.sos]
    diff, _ = sos_speed.same_program(caught, sos_speed.drake_theorem1(bases, 0.8))
    # the multiplier's term s (r^2 - |sigma|^2) |v|^2: r^2 = 0.81 against 0.64
    assert diff == pytest.approx(0.81 - 0.64)


def test_drake_build_only_runs_stop_after_one_iteration(sos_speed: ModuleType, drake: None) -> None:
    _, caught = sos_speed.run_ours(lambda: hinf_sos.theorem1(rate_margin=1e-2))
    bases = [c.basis for c in caught.program.sos]
    full = sos_speed.run_drake(lambda: sos_speed.drake_theorem1(bases, None))
    one = sos_speed.run_drake(lambda: sos_speed.drake_theorem1(bases, None), build_only=True)
    assert not one.certified and one.gram_sizes == ()
    # one iteration of the five Clarabel takes here (measured: 0.06 s against 0.3 s)
    assert 0.0 < one.solver < full.solver and one.build > 0.0


@pytest.mark.slow
def test_drake_poses_our_theorem8_in_the_units_ours_solves_in(sos_speed: ModuleType, drake: None) -> None:
    """Seed 001 solves in balanced units (satfmu.synthesis.polynomial_feedback.coordinates): Drake's program
    is posed from the same scaled plant, every product its own, and must be ours exactly."""
    gamma, alpha, beta = sos_speed._h2hinf_design()
    _, caught = sos_speed.run_ours(lambda: h2hinf_sos.theorem8(gamma, alpha, beta))
    bases = [c.basis for c in caught.program.sos]
    diff, scale = sos_speed.same_program(caught, sos_speed.drake_theorem8(bases, gamma, alpha, beta))
    assert diff <= 1e-12 * scale
