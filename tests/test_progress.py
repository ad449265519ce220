"""Long designs report their stages: to a ``progress(done, total, message)`` callback (the command
line's bar) and to logging, each with its time (satfmu.synthesis.core.progress)."""
from __future__ import annotations

import logging
from types import SimpleNamespace

import pytest

from satfmu.synthesis.core.progress import Stages


def test_stages_report_in_order_with_their_time(caplog: pytest.LogCaptureFixture) -> None:
    seen: list[tuple[int, int, str]] = []
    stages = Stages(2, lambda d, t, m: seen.append((d, t, m)), logging.getLogger("satfmu.test"))
    with caplog.at_level(logging.INFO, logger="satfmu.test"):
        with stages.stage("first"):
            pass
        with stages.stage("second"):
            pass
    assert [(d, t) for d, t, _ in seen] == [(1, 2), (2, 2)]
    assert seen[0][2].startswith("first (") and seen[0][2].endswith(" s)")
    assert [r.getMessage().split(" (")[0] for r in caplog.records] == ["stage 1/2: first", "stage 2/2: second"]
    with pytest.raises(RuntimeError, match="all 2 stages already reported"):
        with stages.stage("third"):
            pass


def test_a_failed_stage_is_not_reported() -> None:
    seen: list[str] = []
    stages = Stages(1, lambda d, t, m: seen.append(m))
    with pytest.raises(ZeroDivisionError):
        with stages.stage("boom"):
            1 / 0
    assert seen == [] and stages.done == 0


@pytest.mark.parametrize("total", [0, -1, 1.5, True])
def test_stages_refuse_a_bad_total(total: object) -> None:
    with pytest.raises(ValueError, match="total must be an integer >= 1"):
        Stages(total)  # type: ignore[arg-type]


def test_the_sdre_design_reports_its_stages(monkeypatch: pytest.MonkeyPatch) -> None:
    from satfmu.synthesis.servo import gain_fit

    monkeypatch.setattr(gain_fit, "sdre_grid", lambda servo, a, b: ("points", "gains"))
    monkeypatch.setattr(gain_fit, "fit", lambda *a, **k: SimpleNamespace(degree=3))
    monkeypatch.setattr(gain_fit, "certify", lambda result, servo: {})
    monkeypatch.setattr(gain_fit, "approximated_sdre_data", lambda result, servo, checks: {})
    monkeypatch.setattr(gain_fit, "lq_data", lambda servo, start: {})
    seen: list[tuple[int, int, str]] = []
    gain_fit.synthesize(5, 6, region=False, progress=lambda d, t, m: seen.append((d, t, m.split(" (")[0])))
    assert seen == [(1, 4, "SDRE gains on the 5 x 6 grid"), (2, 4, "polynomial gain fit"),
                    (3, 4, "fit of degree 3 certified against the plant's factorization"), (4, 4, "LQ servo")]


def test_the_demeter_design_reports_its_stages(monkeypatch: pytest.MonkeyPatch) -> None:
    from satfmu.synthesis.robust import demeter_design
    from satfmu.synthesis.robust.demeter_variants import Variant

    # a design that finds no gain: one stage reported, then the result without analysis or check
    monkeypatch.setattr(demeter_design, "robust_multipliers", lambda solve, kind: (SimpleNamespace(K=None), kind, ""))
    seen: list[tuple[int, int, str]] = []
    out = demeter_design.deterministic(Variant((1,), (1,), 1, 1, True),
                                       progress=lambda d, t, m: seen.append((d, t, m.split(" (")[0])))
    assert out.K is None and seen == [(1, 3, "robust design of " + Variant((1,), (1,), 1, 1, True).label)]


def test_the_command_line_draws_the_stages(capsys: pytest.CaptureFixture) -> None:
    from satfmu.sims import cli

    cli._progress(1, 3, "robust design (2.0 s)")
    cli._progress(3, 3, "check on 100 sampled plants (1.0 s)")
    err = capsys.readouterr().err
    assert "1/3 robust design (2.0 s)" in err and err.endswith("\n") and "3/3 check on 100" in err


def test_the_mixed_design_search_reports_each_sdp_with_its_outcome_and_time(caplog: pytest.LogCaptureFixture) -> None:
    from satfmu.synthesis.polynomial_feedback import h2hinf_search

    seen: list[tuple[int, int, str]] = []
    with caplog.at_level(logging.INFO, logger=h2hinf_search.__name__):
        # frozen LMIs (~0.3 s each): the search's reporting without SOS programs
        h2hinf_search.search(0.8, "slack", bounds=(1e-4, 1e-1), max_evaluations=3, frozen=True, y_degree=0,
                             progress=lambda d, t, m: seen.append((d, t, m)))
    sdps = [m for _, _, m in seen if ": SDP " in m]
    assert [d for d, _, m in seen if ": SDP " in m] == [1, 2, 3] and all(t == 3 for _, t, _ in seen)
    assert all(m.startswith("slack, gamma = 0.8: SDP ") and " s)" in m and "lambda 2.01" in m for m in sdps), sdps
    assert seen[-1] == (3, 3, "done")
    assert len([r for r in caplog.records if ": SDP " in r.getMessage()]) == 3
