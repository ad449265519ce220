"""Metrics fed block by block (satfmu.sims.scenario.metrics.MetricStream): the whole run's values,
bit for bit, however the run is cut (a streamed `satfmu run` evaluates its metrics this way)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from satfmu.sims.scenario import metrics
from satfmu.sims.scenario.metrics import STREAMS, MetricInput, metric_stream

N = 601
T = np.linspace(0.0, 30.0, N)


def _run(rng: np.random.Generator, held: bool) -> dict:
    y = rng.normal(size=(N, 3)) * np.exp(-T / 6.0)[:, None]
    w = rng.normal(size=(N, 3))
    w[:40] = 0.0  # ||w||_{2,T} = 0 at first: the l2_ratio curve starts with NaN
    return dict(t=T, y=y, held=held, inputs=[True, False, True], tolerance=0.05, limit=1.2, versus=0.01 * y[::-1],
                disturbances=w, disturbances_held=not held, scale=1.0)


def _blocks(run: dict, cuts: list[int]) -> list[MetricInput]:
    rows = [0, *cuts, N]
    sliced = ("t", "y", "versus", "disturbances")
    return [MetricInput(**{k: (v[a:b] if k in sliced else v) for k, v in run.items()})
            for a, b in zip(rows[:-1], rows[1:])]


def _same(a: metrics.Evaluation, b: metrics.Evaluation) -> bool:
    value = a[0] == b[0] or (math.isnan(a[0]) and math.isnan(b[0]))
    curve = (a[1] is None) == (b[1] is None) and (a[1] is None or a[1].tobytes() == b[1].tobytes())
    return value and curve


@pytest.mark.parametrize("held", [True, False])
@pytest.mark.parametrize("cuts", [[1], [1, 2, 3], [300], [37, 38, 250, 599, 600], list(range(1, N))])
@pytest.mark.parametrize("kind", sorted(STREAMS))
def test_a_run_cut_into_blocks_gives_the_whole_runs_value_bit_for_bit(kind: str, cuts: list[int],
                                                                      held: bool) -> None:
    run = _run(np.random.default_rng(len(cuts)), held)
    whole = metrics.EVALUATORS[kind](MetricInput(**run))
    stream = metric_stream(kind)
    for block in _blocks(run, cuts):
        stream.feed(block)
    assert _same(stream.result(), whole), (stream.result(), whole)


def test_settling_across_block_boundaries() -> None:
    y = np.zeros((10, 1))
    t = np.arange(10.0)
    cases = {  # rows outside the band -> settling time
        (): 0.0, (4,): 5.0, (2, 9): math.inf, (6,): 7.0}
    for outside, expected in cases.items():
        y[:] = 0.0
        y[list(outside)] = 1.0
        for cuts in ([], [5], [7], [5, 6, 7]):
            stream = metric_stream("settling_time")
            for d in _blocks({"t": t, "y": y.copy(), "tolerance": 0.5}, cuts) if cuts else [
                    MetricInput(t, y.copy(), tolerance=0.5)]:
                stream.feed(d)
            assert stream.result()[0] == expected, (outside, cuts)


def test_a_level_reached_in_a_later_block_and_nan_kept_across_blocks() -> None:
    t = np.arange(6.0)
    y = np.array([[0.1], [0.2], [0.3], [2.0], [0.1], [np.nan]])
    reach = metric_stream("time_to_limit")
    top = metric_stream("peak")
    for a, b in ((0, 2), (2, 5), (5, 6)):
        reach.feed(MetricInput(t[a:b], y[a:b], limit=1.0))
        top.feed(MetricInput(t[a:b], y[a:b]))
    assert reach.result()[0] == 3.0
    assert math.isnan(top.result()[0])  # a NaN is never hidden by a block without one


def test_an_l2_ratio_without_curve_keeps_nothing_of_the_rows() -> None:
    run = _run(np.random.default_rng(7), True)
    stream = metric_stream("l2_ratio", curve=False)
    for block in _blocks(run, [100, 200, 300]):
        stream.feed(block)
    value, curve = stream.result()
    assert curve is None and value == metrics.EVALUATORS["l2_ratio"](MetricInput(**run))[0]
    zero = metric_stream("l2_ratio")  # no disturbance energy at all: no finite ratio
    zero.feed(MetricInput(T, np.ones((N, 1)), disturbances=np.zeros((N, 1))))
    assert math.isnan(zero.result()[0])
