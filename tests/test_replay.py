"""`satfmu replay` and :func:`satfmu.sims.campaign.replay.replay`: one sample of a scenario campaign run
again, bit for bit, with its time histories; bad input refused with one line and nothing written."""
from __future__ import annotations

import csv
import json
import re
import shutil
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from distributed import Client

from satfmu.sims.campaign import engine
from satfmu.fmus.errors import DesignMismatchWarning, ScenarioError
from satfmu.sims.scenario.spec import Scenario
from satfmu.sims.campaign.replay import replay
from satfmu.sims.campaign.scenario_task import campaign, explain
from satfmu.sims.cli import main
from tests.test_scenario_campaign import SEED, mrp

U_MAX = {"plant.u_max": {"kind": "uniform", "low": -5.0, "high": 5.0}}  # N m; declared min 0: < 0 is refused


def ran(tmp_path: Path, client: Client, fmu_dir: Path, data: dict, n: int, chunk: int = 2
        ) -> tuple[engine.Campaign, pd.DataFrame, Path]:
    """A finished campaign of ``data`` (seed SEED) in ``tmp_path/campaigns``: campaign, rows, folder."""
    camp = campaign(Scenario.from_dict(data), n, seed=SEED, chunk=chunk, fmu_dir=fmu_dir)
    rows = engine.run(camp, tmp_path / "campaigns", client=client)
    return camp, rows, tmp_path / "campaigns" / camp.name


def files_under(folder: Path) -> list[str]:
    """Every file and folder under ``folder`` (none if it does not exist)."""
    return sorted(str(p) for p in folder.rglob("*")) if folder.exists() else []


def test_a_replayed_sample_is_the_campaign_row_bit_for_bit(tmp_path: Path, client: Client, fmu_dir: Path) -> None:
    """Metrics and dispersed values equal the row exactly (==: the same computation on the same
    FMU files), and the written CSV is the replayed time history."""
    camp, rows, folder = ran(tmp_path, client, fmu_dir, mrp(), 5)  # 2 s, rate and inertia dispersed
    out = tmp_path / "replays"
    for k in (0, 3, 4):  # chunks 0, 1 and the last, short one
        with warnings.catch_warnings():
            warnings.simplefilter("error", engine.CampaignWarning)  # no difference from the row
            warnings.simplefilter("ignore", DesignMismatchWarning)  # the inertia is dispersed
            res = replay(folder, k, out_dir=out)
        row = rows.iloc[k]
        assert row["sample"] == k and row["failed"] == 0.0
        assert {m.name: m.value for m in res.metrics} == {m.name: row[m.name] for m in res.metrics}
        assert row["passed"] == float(res.passed) == 0.0  # 2 s is too short to settle
        target = out / f"{camp.name}-sample{k}"
        info = json.loads((target / "sample.json").read_text())
        assert info["sample"] == k and info["seed"] == SEED and info["name"] == camp.name
        dispersed = [c for c in rows.columns if c.startswith("plant.")]
        assert set(info["dispersed"]) == set(dispersed)
        assert all(info["dispersed"][c] == row[c] for c in dispersed)
        # the sampled scenario's declaration: the same start values as the row
        assert info["scenario"]["fmus"]["plant"]["parameters"]["omega_0[1]"] == row["plant.omega_0[1]"]
        with open(target / f"{camp.task.scenario.name}_native.csv", newline="") as fh:
            table = list(csv.reader(fh))
        assert table[0] == list(res.results.dtype.names)
        assert len(table) - 1 == len(res.results) == 41  # 2 s in steps of 0.05 s, both ends
        written = np.array(table[1:], dtype=float)  # repr() of each float: exact
        assert np.array_equal(written, np.array(res.results.tolist()))
        assert (target / f"{camp.task.scenario.name}_native.png").stat().st_size > 0
        summary = json.loads((target / "summary_native.json").read_text())
        assert summary["files"]["sample"] == str(target / "sample.json")
    assert rows["plant.omega_0[1]"].nunique() == 5  # a draw per sample: the rows are not all alike


def test_a_replay_that_differs_from_the_row_is_reported(tmp_path: Path, client: Client, fmu_dir: Path,
                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    """A stored row one ulp away from the replay (what other numpy/scipy versions would give) is
    named in a CampaignWarning."""
    _, rows, folder = ran(tmp_path, client, fmu_dir, mrp(), 2)
    stored = rows.iloc[1].copy()
    stored["peak |u|"] = np.nextafter(stored["peak |u|"], np.inf)
    monkeypatch.setattr("satfmu.sims.campaign.replay.campaign_row", lambda f, k: stored)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DesignMismatchWarning)
        with pytest.warns(engine.CampaignWarning, match=r"sample 1 replayed differently .* in peak \|u\|"):
            replay(folder, 1)


def test_a_failed_sample_replays_to_the_same_refusal(tmp_path: Path, client: Client, fmu_dir: Path,
                                                     capsys: pytest.CaptureFixture) -> None:
    """A sample refused in the campaign (failed = 2: a negative u_max) is refused again with the
    message `explain` gives; the command exits 2 with that line and writes nothing."""
    camp, rows, folder = ran(tmp_path, client, fmu_dir, mrp(dispersions=U_MAX), 6, chunk=3)
    refused = rows.loc[rows["failed"] == 2.0, "sample"].astype(int).tolist()
    assert 0 < len(refused) < 6 and (rows.loc[rows["plant.u_max"] < 0, "failed"] == 2.0).all()
    k = refused[0]
    message = explain(camp.task, k)
    assert "fmus.plant.parameters.u_max" in message and "outside its declared range" in message
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DesignMismatchWarning)
        with pytest.raises(ScenarioError) as exc:
            replay(folder, k, out_dir=tmp_path / "lib")
    assert str(exc.value) == message
    assert files_under(tmp_path / "lib") == []
    out = tmp_path / "out"
    assert main(["replay", str(folder), "--sample", str(k), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err == f"satfmu replay: error: {message}\n"  # one line, no traceback
    assert files_under(out) == []


def test_the_command_writes_the_run_and_exits_as_run_does(tmp_path: Path, client: Client, fmu_dir: Path,
                                                          capsys: pytest.CaptureFixture) -> None:
    """Exit 1 for a sample that misses a bound (2 s is too short to settle), 0 for one within them;
    the dispersed values and every metric printed."""
    data = mrp()
    passing = {**data, "name": "peak_only", "metrics": [m for m in data["metrics"] if m["name"] == "peak |u|"]}
    for scenario, code in ((data, 1), (passing, 0)):
        _, rows, folder = ran(tmp_path / scenario["name"], client, fmu_dir, scenario, 2)
        out = tmp_path / "out"
        assert main(["replay", str(folder), "--sample", "1", "--out", str(out)]) == code
        text = capsys.readouterr().out
        assert f"plant.omega_0[1] = {rows.loc[1, 'plant.omega_0[1]']:.6g}" in text
        assert all(m["name"] in text for m in scenario["metrics"])
        assert (out / f"{folder.name}-sample1" / "summary_native.json").is_file()


def bad(argv: list[str], message: str, out: Path, capsys: pytest.CaptureFixture) -> None:
    """``satfmu replay ARGV --out OUT``: exit 2, one line on stderr matching ``message``, no
    traceback, nothing written to OUT."""
    code = main(["replay", *map(str, argv), "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2, err
    assert err.count("\n") == 1 and err.startswith("satfmu replay: error: ") and "Traceback" not in err, err
    assert re.search(message, err), err
    assert files_under(out) == []


def test_bad_input_exits_2_with_one_line_and_writes_nothing(tmp_path: Path, client: Client, fmu_dir: Path,
                                                            capsys: pytest.CaptureFixture) -> None:
    own = tmp_path / "fmus"  # the campaign's FMU files, copied so that one can be changed
    own.mkdir()
    for name in ("mrp_satellite.fmu", "mrp_hinf_published.fmu"):
        shutil.copy(fmu_dir / name, own / name)
    _, _, folder = ran(tmp_path, client, own, mrp(), 3)
    out = tmp_path / "out"
    bad([folder, "--sample", 3], r"sample 3 is not a sample .* 0\.\.2", out, capsys)
    bad([tmp_path / "fmus", "--sample", 0], r"fmus is not a campaign folder \(no campaign\.json\)", out, capsys)
    bad([tmp_path / "nowhere", "--sample", 0], r"nowhere is not a campaign folder", out, capsys)
    with open(own / "mrp_hinf_published.fmu", "ab") as fh:  # trailing bytes: still a loadable FMU
        fh.write(b"\0")
    bad([folder, "--sample", 0], r"FMU files of controller in .* are not the ones the campaign ran", out, capsys)
    # the campaign's binaries elsewhere (the build folder holds the same files): replayed from there
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DesignMismatchWarning)
        assert main(["replay", str(folder), "--sample", "0", "--fmu-dir", str(fmu_dir), "--out", str(out)]) == 1
    assert (out / f"{folder.name}-sample0" / "summary_native.json").is_file()


def test_a_demeter_campaign_folder_is_refused(tmp_path: Path, client: Client, capsys: pytest.CaptureFixture) -> None:
    """A campaign folder of `campaign demeter` (no scenario in its campaign.json) is not replayed."""
    from satfmu.sims.workflows import demeter_studies

    report = demeter_studies.campaign(tmp_path / "campaigns", samples=20, chunk=10,
                                      scheduler=client.scheduler.address, name="demeter")
    assert report is not None and (tmp_path / "campaigns" / "demeter" / "campaign.json").is_file()
    bad([tmp_path / "campaigns" / "demeter", "--sample", 0], r"not the folder of a scenario campaign",
        tmp_path / "out", capsys)


def test_the_public_api_names_the_implementation() -> None:
    import satfmu

    assert satfmu.replay is replay
