"""Monte Carlo campaigns of a dispersed scenario (satfmu.sims.campaign.scenario_task) and
`satfmu campaign scenario`."""
from __future__ import annotations

import tomllib
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from distributed import Client
from scipy import stats

from satfmu.sims.campaign import engine
from satfmu.fmus.errors import DesignMismatchWarning, ScenarioError
from satfmu.sims.scenario.run import run
from satfmu.sims.scenario.spec import Scenario
from satfmu.sims.scenario.wiring import grid
from satfmu.sims.campaign.results import ENVELOPES, run_campaign
from satfmu.sims.campaign.scenario_task import campaign, default_chunk, explain, reopen
from satfmu.sims.campaign.statistics import PERCENTILES, clopper_pearson, statistics
from satfmu.sims.cli import main
from satfmu.sims.scenario import SHIPPED_SCENARIOS

SEED = 3
DISPERSIONS = {"plant.omega_0[1]": {"kind": "uniform", "low": -0.01, "high": 0.01},  # rad/s
               "inertia": {"instance": "plant", "relative": 0.1}}


def mrp(**changes: object) -> dict:
    """Shipped mrp_200deg run for 2 s (40 steps) with dispersed rate and inertia."""
    data = tomllib.loads((SHIPPED_SCENARIOS / "mrp_200deg.toml").read_text())
    return {**data, "stop_time": 2.0, "dispersions": DISPERSIONS, **changes}


def toml(path: Path, data: dict) -> Path:
    """Write scenario data as TOML (the subset these scenarios use)."""
    def value(v: object) -> str:
        if isinstance(v, dict):
            return "{ " + ", ".join(f'"{k}" = {value(x)}' for k, x in v.items()) + " }"
        if isinstance(v, list):
            return "[" + ", ".join(value(x) for x in v) + "]"
        if isinstance(v, bool):
            return "true" if v else "false"
        return f'"{v}"' if isinstance(v, str) else repr(v)

    lines = [f"{k} = {value(v)}" for k, v in data.items() if not isinstance(v, (dict, list)) or k == "record"]
    lines += [f"[plot]\npanels = {value(data['plot']['panels'])}"]
    for inst, spec in data["fmus"].items():
        lines.append(f"[fmus.{inst}]\n" + "\n".join(f"{k} = {value(v)}" for k, v in spec.items()))
    for key in ("connections", "metrics"):
        for entry in data[key]:
            lines.append(f"[[{key}]]\n" + "\n".join(f"{k} = {value(v)}" for k, v in entry.items()))
    lines.append("[dispersions]\n" + "\n".join(f'"{k}" = {value(v)}' for k, v in data["dispersions"].items()))
    path.write_text("\n".join(lines) + "\n")
    return path


def rows(tmp_path: Path, client: Client, fmu_dir: Path, data: dict, n: int, chunk: int
         ) -> tuple[engine.Campaign, pd.DataFrame]:
    """The campaign of ``data`` (seed SEED) and its rows, run in ``tmp_path/chunk<chunk>``."""
    camp = campaign(Scenario.from_dict(data), n, seed=SEED, chunk=chunk, fmu_dir=fmu_dir)
    return camp, engine.run(camp, tmp_path / f"chunk{chunk}", client=client)


def test_rows_are_the_scenario_runs_of_the_samples_whatever_the_chunks(tmp_path: Path, client: Client,
                                                                       fmu_dir: Path) -> None:
    sc = Scenario.from_dict(mrp())
    _, by2 = rows(tmp_path, client, fmu_dir, mrp(), 5, 2)
    _, by5 = rows(tmp_path, client, fmu_dir, mrp(), 5, 5)
    pd.testing.assert_frame_equal(by2, by5, check_exact=True)  # same (seed, index) -> same computation
    assert list(by2.columns[:7]) == ["sample", "attitude angle at 120 s", "settling time to 0.1 deg", "peak |u|",
                                     "RMS command", "passed", "failed"]
    for k in (1, 4):
        sampled = sc.sample(SEED, k, fmu_dir)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DesignMismatchWarning)
            res = run(sampled, fmu_dir)
        row = by2.iloc[k]
        for m in res.metrics:  # the same code path: bit for bit
            assert row[m.name] == m.value
        assert row["passed"] == float(res.passed) == 0.0  # 2 s is too short to settle
        assert row["failed"] == 0.0
        for name in ("I_x", "I_y", "I_z", "omega_0[1]"):
            assert row[f"plant.{name}"] == sampled.fmus["plant"].parameters[name]
    assert by2["plant.omega_0[1]"].nunique() == 5  # a draw per sample


def test_a_refused_sample_is_a_recorded_failure_and_the_others_run(tmp_path: Path, client: Client,
                                                                    fmu_dir: Path) -> None:
    data = mrp(dispersions={"plant.u_max": {"kind": "uniform", "low": -5.0, "high": 5.0}})  # N m, declared min 0
    camp, df = rows(tmp_path, client, fmu_dir, data, 8, 3)
    assert df["sample"].tolist() == list(range(8))
    negative = df["plant.u_max"] < 0
    assert 0 < negative.sum() < 8  # this seed draws both signs
    assert (df.loc[negative, "failed"] == 2.0).all() and (df.loc[~negative, "failed"] == 0.0).all()
    assert df.loc[negative, "peak |u|"].isna().all() and np.isfinite(df.loc[~negative, "peak |u|"]).all()
    first = int(df.loc[negative, "sample"].iloc[0])
    assert "outside its declared range" in explain(camp.task, first)
    assert explain(camp.task, int(df.loc[~negative, "sample"].iloc[0])) is None
    st = statistics(Scenario.from_dict(data), df)
    assert st.n_failed == int(negative.sum())
    assert set(st.worst["sample"][:st.n_failed]) == set(df.loc[negative, "sample"])  # failures are the worst


def test_clopper_pearson_equals_the_beta_quantiles() -> None:
    # Independent references: the exact interval's bounds are Beta quantiles (scipy.stats' beta.ppf,
    # another route than scipy.special.betaincinv; rtol 1e-9, far below any reported digit) and
    # scipy's binomtest, which finds them by root finding (rtol 1e-9: its bracketing tolerance).
    low, high = clopper_pearson(100, 100, 0.95)
    assert high == 1.0
    assert low == pytest.approx(stats.beta.ppf(0.025, 100, 1), rel=1e-9)
    assert 1 - low == pytest.approx(0.0362, abs=5e-5)  # 0 failures of 100: failure rate <= 3.62 %
    low, high = clopper_pearson(37, 100, 0.99)
    assert low == pytest.approx(stats.beta.ppf(0.005, 37, 64), rel=1e-9)
    assert high == pytest.approx(stats.beta.ppf(0.995, 38, 63), rel=1e-9)
    for k, n, confidence in ((0, 10, 0.95), (1, 1, 0.9), (37, 100, 0.99), (9999, 10000, 0.95)):
        ci = stats.binomtest(k, n).proportion_ci(confidence_level=confidence, method="exact")
        assert clopper_pearson(k, n, confidence) == pytest.approx((ci.low, ci.high), rel=1e-9, abs=1e-15)


def test_statistics_percentiles_and_worst_samples() -> None:
    sc = Scenario.from_dict(mrp())
    n = 1000
    values = np.random.default_rng(0).permutation(np.arange(n, dtype=float))  # peak |u|, N m
    df = pd.DataFrame({"sample": np.arange(n), **{m.name: np.full(n, 0.0) for m in sc.metrics},
                       "passed": np.zeros(n), "failed": np.zeros(n)})
    df["peak |u|"] = 6.1 + values / n * 0.3  # within [6.1, 6.3] except the largest 333
    df.loc[7, "failed"] = 1.0
    df.loc[7, "peak |u|"] = np.nan
    st = statistics(sc, df, confidence=0.9, k=3)
    peak = st.metrics[[m.name for m in sc.metrics].index("peak |u|")]
    finite = df["peak |u|"].dropna().to_numpy()
    # exact: the same numpy computation (linear interpolation) on the finite values
    assert [peak.percentiles[p] for p in PERCENTILES] == np.percentile(finite, PERCENTILES).tolist()
    assert peak.passes == int(((finite >= 6.1) & (finite <= 6.3)).sum())
    assert (peak.low, peak.high) == clopper_pearson(peak.passes, n, 0.9)
    assert st.overall.passes == 0 and st.n_failed == 1
    assert st.worst["sample"][0] == 7  # the failed sample first, then the largest peaks (6.3 - value)
    assert st.worst["peak |u|"][1:].tolist() == sorted(finite)[-2:][::-1]
    text = st.text()
    assert "peak |u|" in text and "p99.73" in text and "worst 3 samples" in text


def test_cli_exit_codes(tmp_path: Path, client: Client, fmu_dir: Path, capsys: pytest.CaptureFixture) -> None:
    address = client.scheduler.address
    common = ["--samples", "4", "--chunk", "2", "--scheduler", address, "--fmu-dir", str(fmu_dir), "--out",
              str(tmp_path / "out")]
    data = mrp()
    passing = toml(tmp_path / "passing.toml", {**data, "name": "pass", "metrics": [
        m for m in data["metrics"] if m["name"] == "peak |u|"]})  # 6.216 N m within [6.1, 6.3]
    failing = toml(tmp_path / "failing.toml", {**data, "name": "fail"})  # no settling within 2 s
    assert main(["campaign", "scenario", str(passing), *common]) == 0
    out = capsys.readouterr().out
    assert "4/4" in out and "peak |u|" in out
    assert main(["campaign", "scenario", str(failing), *common]) == 1
    assert "0/4" in capsys.readouterr().out
    assert main(["campaign", "scenario", "mrp_200deg", *common]) == 2  # shipped, no [dispersions]
    assert "no [dispersions]" in capsys.readouterr().err


def test_a_sampled_profile_the_scenario_refuses_is_a_recorded_failure(tmp_path: Path, client: Client,
                                                                      fmu_dir: Path) -> None:
    profile = {"to": "plant.w_d[1]", "kind": "random", "seed": 1, "std": 1e-3}  # N m
    data = mrp(profiles=[profile], dispersions={"profiles[0].std": {"kind": "uniform", "low": -1e-3, "high": 1e-3}})
    _, df = rows(tmp_path, client, fmu_dir, data, 6, 3)
    negative = df["profiles[0].std"] < 0
    assert 0 < negative.sum() < 6  # this seed draws both signs
    assert (df.loc[negative, "failed"] == 2.0).all() and (df.loc[~negative, "failed"] == 0.0).all()


def test_run_campaign_of_the_public_api_resumes_to_the_same_result(tmp_path: Path, client: Client,
                                                                   fmu_dir: Path) -> None:
    """satfmu.run_campaign: rows, statistics and failures; a second call resumes (no chunk computed
    again) and gives the same rows."""
    import satfmu

    data = mrp(dispersions={"plant.u_max": {"kind": "uniform", "low": -5.0, "high": 5.0}})  # N m, declared min 0
    first = satfmu.run_campaign(data, 6, tmp_path, seed=SEED, chunk=3, fmu_dir=fmu_dir,
                                scheduler=client.scheduler.address)
    assert first.folder == tmp_path / f"{first.campaign.name}" and (first.folder / "campaign.json").is_file()
    assert first.rows["sample"].tolist() == list(range(6)) and not first.passed
    n_failed = int((first.rows["failed"] > 0).sum())
    assert first.statistics.n == 6 and first.statistics.n_failed == n_failed > 0
    assert all("outside its declared range" in message for _, message in first.failures())
    chunks = {p: p.stat().st_mtime_ns for p in first.folder.glob("chunk-*.parquet")}
    again = satfmu.run_campaign(data, 6, tmp_path, seed=SEED, chunk=3, fmu_dir=fmu_dir,
                                scheduler=client.scheduler.address)
    pd.testing.assert_frame_equal(first.rows, again.rows, check_exact=True)
    assert {p: p.stat().st_mtime_ns for p in first.folder.glob("chunk-*.parquet")} == chunks  # resumed, not redone


@pytest.mark.slow
def test_a_campaign_killed_mid_run_resumes_to_the_same_rows_and_statistics(tmp_path: Path, client: Client,
                                                                            fmu_dir: Path) -> None:
    """`satfmu campaign scenario` SIGKILLed after its first chunks, then run again: the same rows as
    an uninterrupted campaign, none lost or duplicated, the same statistics (~30 s: two processes
    with their Dask clusters)."""
    import os
    import signal
    import subprocess
    import sys
    import time

    data = {**mrp(), "name": "killed"}
    scenario = toml(tmp_path / "killed.toml", data)
    n, out = 12, tmp_path / "out"
    argv = [sys.executable, "-m", "satfmu.sims.cli", "campaign", "scenario", str(scenario), "--samples", str(n),
            "--chunk", "1", "--workers", "1", "--seed", str(SEED), "--fmu-dir", str(fmu_dir), "--out", str(out)]
    proc = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    folder = out / f"killed-n{n}-s{SEED}"
    deadline = time.monotonic() + 120
    while len(list(folder.glob("chunk-*.parquet"))) < 3 and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGKILL)  # the driver and its Dask workers
    proc.wait()
    done = len(list(folder.glob("chunk-*.parquet")))
    assert 3 <= done < n, f"{done} chunks before the kill: the kill must interrupt the campaign"
    resumed = run_campaign(Scenario.from_toml(scenario), n, out, seed=SEED, chunk=1, fmu_dir=fmu_dir,
                           scheduler=client.scheduler.address)
    whole = run_campaign(Scenario.from_toml(scenario), n, tmp_path / "whole", seed=SEED, chunk=1,
                         fmu_dir=fmu_dir, scheduler=client.scheduler.address)
    assert resumed.rows["sample"].tolist() == list(range(n))  # none lost, none twice
    pd.testing.assert_frame_equal(resumed.rows, whole.rows, check_exact=True)
    assert resumed.statistics.text() == whole.statistics.text()


def test_the_folder_records_its_scenario_and_fmus_and_refuses_other_binaries(tmp_path: Path, client: Client,
                                                                             fmu_dir: Path) -> None:
    """campaign.json keeps the scenario and each FMU's SHA-256: reopen() gives back the same
    campaign; a resume with a changed FMU binary (one byte appended to the zip comment-free
    archive: still a loadable FMU) is refused, naming the instance."""
    import shutil

    own = tmp_path / "fmus"
    own.mkdir()
    for name in ("mrp_satellite.fmu", "mrp_hinf_published.fmu"):
        shutil.copy(fmu_dir / name, own / name)
    camp = campaign(Scenario.from_dict(mrp()), 2, seed=SEED, chunk=2, fmu_dir=own)
    engine.run(camp, tmp_path / "out", client=client)
    again = reopen(tmp_path / "out" / camp.name)
    a, b = again.identity(), camp.identity()
    assert {k: (a[k], b[k]) for k in a if a[k] != b[k]} == {}
    assert again.task == camp.task
    with open(own / "mrp_hinf_published.fmu", "ab") as fh:  # trailing bytes: zip readers ignore them
        fh.write(b"\0")
    with pytest.raises(engine.CampaignError, match=r"context differs in fmus\.controller"):
        engine.run(campaign(Scenario.from_dict(mrp()), 2, seed=SEED, chunk=2, fmu_dir=own), tmp_path / "out",
              client=client)
    with pytest.raises(engine.CampaignError, match="controller in .* are not the ones the campaign ran"):
        reopen(tmp_path / "out" / camp.name)


def test_envelopes_are_the_percentiles_of_the_sampled_runs(tmp_path: Path, client: Client, fmu_dir: Path) -> None:
    """Envelopes of plant.phi over 6 samples, 8 time points: the percentiles (numpy, independently)
    of the samples' own runs at those times; a refused sample (negative u_max) is left out; the
    table is in the folder; a signal not recorded and points < 2 are refused."""
    from satfmu.sims.campaign import envelopes

    data = mrp(dispersions={**DISPERSIONS, "plant.u_max": {"kind": "uniform", "low": -5.0, "high": 5.0}})
    res = run_campaign(data, 6, tmp_path, seed=SEED, chunk=3, fmu_dir=fmu_dir, scheduler=client.scheduler.address,
                       envelopes=["plant.phi"], points=8)
    assert not any("@" in c for c in res.rows.columns)  # the traces are not rows
    sc = Scenario.from_dict(data)
    steps = envelopes.trace_steps(41, 8)
    assert steps.tolist() == [0, 6, 11, 17, 23, 29, 34, 40]
    ran = res.rows.loc[res.rows["failed"] == 0, "sample"].tolist()
    assert 0 < len(ran) < 6
    with warnings.catch_warnings():  # the dispersed inertia is not the design's: expected
        warnings.simplefilter("ignore", DesignMismatchWarning)
        traces = np.array([run(sc.sample(SEED, i, fmu_dir), fmu_dir).results["plant.phi"][steps] for i in ran])
    env = pd.read_parquet(res.folder / ENVELOPES)
    pd.testing.assert_frame_equal(env, res.envelopes)
    assert env["time"].tolist() == grid(sc)[steps].tolist()  # the master's communication times
    for level in envelopes.LEVELS:  # the same numbers through the same numpy call: exact
        assert env[f"plant.phi:p{level:g}"].tolist() == np.percentile(traces, level, axis=0).tolist()
    assert env["plant.phi:p0"].tolist() == traces.min(axis=0).tolist()
    with pytest.raises(ScenarioError, match=r"envelopes\[1\]: plant.w_d\[1\] is not recorded"):
        campaign(data, 2, fmu_dir=fmu_dir, envelopes=["plant.phi", "plant.w_d"])
    with pytest.raises(engine.CampaignError, match="envelope points must be an integer >= 2"):
        campaign(data, 2, fmu_dir=fmu_dir, envelopes=["plant.phi"], points=1)
    with pytest.raises(engine.CampaignError, match="context differs in envelopes"):  # same folder, other envelopes
        run_campaign(data, 6, tmp_path, seed=SEED, chunk=3, fmu_dir=fmu_dir, scheduler=client.scheduler.address,
                     envelopes=["plant.phi"], points=9, name=res.campaign.name)


def test_the_default_chunk_gives_about_a_hundred_chunks_of_10_to_1000_samples(fmu_dir: Path) -> None:
    """A pure function of n (a resumed campaign finds its chunks whatever the workers)."""
    assert [default_chunk(n) for n in (1, 999, 1000, 1001, 10_000, 100_000, 10**7)] == [10, 10, 10, 11, 100,
                                                                                         1000, 1000]
    camp = campaign(Scenario.from_dict(mrp()), 10_000, seed=SEED, fmu_dir=fmu_dir)
    assert camp.chunk == 100 and camp.n_chunks == 100
