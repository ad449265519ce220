"""Timing helpers shared by the benchmark scripts (run as ``python bench/<script>.py``)."""
from __future__ import annotations

import statistics
import time
from typing import Any, Callable, Mapping, TypeVar

T = TypeVar("T")


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


def interleaved(runs: Mapping[str, Callable[[], T]], repeat: int,
                rounds: Mapping[str, int] | None = None) -> dict[str, list[T]]:
    """Call every function of ``runs`` once per round, in turn, for ``repeat`` rounds.

    Interleaving (a, b, c, a, b, c, ...) spreads a load that comes and goes on a shared
    machine over all contenders alike, where consecutive repeats (a, a, b, b, ...) would
    charge it to whichever runs at the time.

    Parameters
    ----------
    runs : mapping of str to callable
        Name to a function doing one complete run; each function times itself and returns
        its own record (so the record can split the time into phases).
    repeat : int
        Number of rounds.
    rounds : mapping of str to int, optional
        Fewer rounds for slow contenders: ``name`` takes part in the first ``rounds[name]``
        rounds only (default: all).

    Returns
    -------
    dict of str to list
        Each name's records, in the order they ran.
    """
    out: dict[str, list[T]] = {name: [] for name in runs}
    for r in range(repeat):
        for name, fn in runs.items():
            if r < (rounds or {}).get(name, repeat):
                out[name].append(fn())
    return out


def min_median(values: list[float]) -> tuple[float, float]:
    """Minimum and median of ``values`` (nan, nan when empty)."""
    if not values:
        return float("nan"), float("nan")
    return min(values), statistics.median(values)
