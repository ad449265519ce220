"""Seed 000's two-step iteration (satfmu.synthesis.polynomial_feedback.two_step) on a short decay-rate schedule.

One run over ``decay_rates = [0.005, 0.01]`` (about 25 s: two Theorem 1 designs, two SOS
L2 certificates, two 200 deg responses) is shared by the module. Its last iterate is the
design shipped as ``controllers/artifacts/mrp_hinf_satfmu.json`` (c = 0.3242).
"""
from __future__ import annotations

import json
import math
import re

import numpy as np
import pytest

from satfmu.controllers.artifact import parse
from satfmu.synthesis.core.sos import SOSError
from satfmu.synthesis.polynomial_feedback.two_step import TwoStepResult, two_step

RATES = [0.005, 0.01]


@pytest.fixture(scope="module")
def progress_log() -> list[tuple[int, int, str]]:
    """Progress reports of the shared run, in order."""
    return []


@pytest.fixture(scope="module")
def run(progress_log: list[tuple[int, int, str]]) -> TwoStepResult:
    """The shared two-step run (the sampled estimate on 5000 points, for speed)."""
    return two_step(decay_rates=RATES, n_samples=5_000,
                    progress=lambda done, total, msg: progress_log.append((done, total, msg)))


@pytest.mark.slow
def test_both_iterates_are_accepted_and_c_decreases(run: TwoStepResult) -> None:
    assert [it.index for it in run.iterates] == [0, 1]
    assert [it.decay_rate for it in run.iterates] == RATES
    assert all(it.accepted and it.reason == "" for it in run.iterates), [it.reason for it in run.iterates]
    c0, c1 = (it.c for it in run.iterates)
    assert np.isfinite(c0) and c1 < c0  # raising the gain improved the certified gain (0.432 -> 0.324)
    assert run.best is run.iterates[-1]


@pytest.mark.slow
def test_best_gain_and_response(run: TwoStepResult) -> None:
    best = run.best
    assert best.design is not None and best.design.certified
    assert best.sos is not None and best.sos.certified
    # deterministic pipeline; 2e-3 covers interior-point solver tolerance in both SOS steps
    assert best.c == pytest.approx(0.3242, abs=2e-3)
    # the sampled estimate is a lower bound of the certified upper bound (1e-6: solver accuracy)
    assert best.sampled is not None and best.sampled.c <= best.c * (1 + 1e-6)
    assert best.peak_torque <= 6.5  # the default budget, N m (measured 6.11)
    assert best.final_error_deg < 0.1  # the default final tolerance at 120 s


@pytest.mark.slow
def test_table_names_the_choice(run: TwoStepResult) -> None:
    table = run.table()
    assert "chosen: iteration 1" in table
    assert table.count("accepted") == 2 and "rejected" not in table
    assert f"c = {run.best.c:.4f}" in table


@pytest.mark.slow
def test_progress_is_reported(progress_log: list[tuple[int, int, str]], run: TwoStepResult) -> None:
    assert progress_log, "no progress reported"
    assert progress_log[-1] == (2, 2, "done")
    assert any("step 2, L2 gain" in msg for _, _, msg in progress_log)
    # each step with its time into the iteration: "... (at 3.2 s)"
    assert all(msg == "done" or re.search(r" \(at \d+\.\d s\)$", msg) for _, _, msg in progress_log), progress_log
    assert [d for d, _, _ in progress_log] == sorted(d for d, _, _ in progress_log)  # monotone


@pytest.mark.slow
def test_artifact_data_is_a_valid_certified_artifact(run: TwoStepResult) -> None:
    data = run.artifact_data("x_test")
    # strict JSON: no NaN or Infinity anywhere (non-finite values must have become null)
    text = json.dumps(data, allow_nan=False)
    art = parse(json.loads(text))
    assert art.name == "x_test"
    assert art.certificate["status"] == "certified"
    l2 = art.certificate["l2_gain"]
    assert l2["c"] == run.best.c  # copied, not recomputed: exact
    assert l2["kv"] == run.best.sos.kv
    assert l2["region"] == run.settings["l2_region"].label
    # the function that made it, not a command line the design (made from Python here) never saw
    assert art.provenance["source"] == "satfmu.synthesis.polynomial_feedback.two_step (seed 000 section 4)"
    iterations = art.provenance["iterations"]
    assert len(iterations) == 2
    for row in iterations:
        for k, v in row.items():
            assert not (isinstance(v, float) and math.isnan(v)), k
    assert [row["decay_rate_1_s"] for row in iterations] == RATES
    assert all(row["accepted"] for row in iterations)


@pytest.mark.slow
def test_torque_budget_too_small_raises() -> None:
    # the 200 deg manoeuvre needs ~6.1 N m at lambda = 0.01: 1 N m rejects the only iterate.
    # The fast suite runs this failure through the CLI (test_cli: exit 2, "over the budget 1").
    with pytest.raises(SOSError, match="budget"):
        two_step(torque_budget=1.0, decay_rates=[0.01], n_samples=2_000)


@pytest.mark.parametrize("rates", [[], [0.02, 0.01], [-1.0], [0.01, 0.01]],
                         ids=["empty", "decreasing", "negative", "repeated"])
def test_bad_decay_rates_are_refused(rates: list[float]) -> None:
    # validated before any SOS program is built: fast
    with pytest.raises(ValueError, match="decay_rates"):
        two_step(decay_rates=rates)
