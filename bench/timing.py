"""Timing helper shared by the benchmark scripts (run as ``python bench/<script>.py``)."""
from __future__ import annotations

import time
from typing import Any, Callable


def best_of(fn: Callable[[], Any], repeat: int) -> tuple[float, Any]:
    """Shortest wall time (s) of ``repeat`` calls of ``fn`` and the last call's result.

    The best of several runs is the figure least disturbed by other load on a shared machine.
    """
    best, out = float("inf"), None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out
