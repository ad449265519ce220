"""The command line's campaign progress bar: rate and time left."""
from __future__ import annotations

import time

import pytest

from satfmu.sims import cli


def test_the_bar_gives_the_rate_and_the_time_left_from_the_new_chunks(capsys: pytest.CaptureFixture,
                                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    """Clock stubbed: made at t = 0; a campaign resumed at 4 of 10 chunks completes its 5th at 2 s
    and its 6th at 4 s: 2 new chunks in 4 s = 0.5/s, 4 left = 8 s (the 4 resumed chunks are not speed)."""
    clock = iter([0.0, 2.0, 4.0])
    monkeypatch.setattr(time, "perf_counter", lambda: next(clock))
    report = cli._progress_eta("chunks")
    report(5, 10)
    report(6, 10)
    err = capsys.readouterr().err
    assert err.endswith("6/10 chunks, 0.50/s, 0 min 08 s left" + " " * (90 - len("chunks, 0.50/s, 0 min 08 s left")))
    assert "5/10 chunks, 0.50/s, 0 min 10 s left" in err  # first call: 1 new chunk in 2 s
