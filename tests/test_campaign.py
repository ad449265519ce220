"""Monte Carlo campaigns on Dask (satfmu.sims.campaign.engine): bit-for-bit reproducibility, resume, loss of a
worker, damaged and foreign chunks, two drivers in one folder, the probabilistic bounds, and a
campaign of co-simulated FMUs."""
from __future__ import annotations

import json
import math
import os
import re
import signal
import struct
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from distributed import Client, LocalCluster
from pandas.testing import assert_frame_equal

from satfmu.controllers import artifact
from satfmu.fmus.plants import demeter
from satfmu.fmus import export
from satfmu.sims.campaign import engine
from satfmu.controllers import catalog
from satfmu.sims.campaign import chunk_files
from satfmu.sims.campaign.engine import Campaign, CampaignError, CampaignWarning
from satfmu.synthesis.robust.demeter_variants import Variant, design_model
from tests.campaign_tasks import (abscissa, decay_time, matrix_column, normal_matrices, short_column,
                                  slow_abscissa)

ROOT = Path(__file__).resolve().parents[1]
N, CHUNK, SEED = 20_000, 2_000, 2024
ROW1 = design_model(Variant((1,), (1,), 1, 1))
WIRES = [(f"plant.{n}", f"ctrl.{n}") for n in
         ("theta", "theta_dot", "eta", "eta_dot", "wheel_torque", "wheel_torque_rate")] + [("ctrl.u_c", "plant.u_c")]


# Tasks and samplers are module-level: the workers import them by name (the light ones from
# tests.campaign_tasks, so that a worker starts fast).
def uniform_delta(rng: np.random.Generator, count: int) -> np.ndarray:
    return rng.uniform(-1.0, 1.0, (count, 3))


def demeter_parameters(delta: np.ndarray) -> dict[str, dict[str, float]]:
    """The row-1 plant at ``delta``, starting at rest in attitude with a 1 mrad/s rate."""
    plant = {**ROW1.fmu_parameters(delta), "theta_dot_0[1]": 1e-3}
    plant["wheels_on"] = bool(plant["wheels_on"])
    return {"plant": plant}


def peak_theta(result: dict[str, np.ndarray]) -> float:
    return float(np.abs(result["plant.theta[1]"]).max())


def matrices(name: str = "abscissa", **changes: object) -> Campaign:
    return Campaign(**{"name": name, "task": abscissa, "n": N, "seed": SEED, "chunk": CHUNK,
                       "sampler": normal_matrices, **changes})


def serial(campaign: Campaign) -> pd.DataFrame:
    return pd.concat([engine.run_chunk(campaign, k) for k in range(campaign.n_chunks)], ignore_index=True)


@pytest.fixture(scope="module")
def cluster() -> Iterator[tuple[LocalCluster, Client]]:
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0") as lc, \
            Client(lc) as client:
        yield lc, client


@pytest.fixture(scope="module")
def reference() -> pd.DataFrame:
    return serial(matrices())


def test_chunk_samples_depend_only_on_seed_and_chunk_index(reference: pd.DataFrame) -> None:
    # Chunk 3 is drawn from SeedSequence(seed, spawn_key=(3,)) whatever n is. Exact: same draws.
    rng = np.random.default_rng(np.random.SeedSequence(SEED, spawn_key=(3,)))
    direct = abscissa(normal_matrices(rng, CHUNK))["abscissa"]
    assert np.array_equal(reference["abscissa"].to_numpy()[3 * CHUNK:4 * CHUNK], direct)
    assert_frame_equal(engine.run_chunk(matrices(n=7 * CHUNK + 5), 3), engine.run_chunk(matrices(), 3),
                       check_exact=True)
    # the last chunk is short and keeps the global sample indices
    last = engine.run_chunk(matrices(n=7 * CHUNK + 5), 7)
    assert last["sample"].tolist() == list(range(7 * CHUNK, 7 * CHUNK + 5))
    # the task is right: eigenvalues by LAPACK; 1e-12: two roundings of the same 2x2 eigenvalues
    m = normal_matrices(np.random.default_rng(0), 200)
    eig = np.linalg.eigvals(m.reshape(-1, 2, 2)).real.max(axis=1)
    assert np.abs(abscissa(m)["abscissa"] - eig).max() < 1e-12


def test_one_and_two_workers_equal_the_serial_reference(tmp_path: Path, cluster, reference) -> None:
    # Exact: the same chunk computations in any process, written and read back losslessly.
    one = engine.run(matrices(), tmp_path / "one", n_workers=1)  # the runner's own LocalCluster
    assert_frame_equal(one, reference, check_exact=True)
    two = engine.run(matrices(), tmp_path / "two", client=cluster[1])
    assert_frame_equal(two, reference, check_exact=True)
    assert reference["sample"].tolist() == list(range(N))
    assert reference["abscissa"].nunique() == N  # every sample differs: no chunk reuses a stream


def test_an_interrupted_campaign_resumes_with_the_missing_chunks_only(tmp_path: Path, cluster, reference) -> None:
    first: list[int] = []

    def stop_after_three(done: int, total: int) -> None:
        first.append(done)
        if len(first) == 3:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        engine.run(matrices(), tmp_path, client=cluster[1], progress=stop_after_three)
    folder = tmp_path / "abscissa"
    written = {f.name: f.stat().st_mtime_ns for f in folder.glob("chunk-*.parquet")}
    assert len(written) == 3  # a file is written before its progress call; the 3rd call stopped the run
    assert not list(folder.glob(".*.partial*"))  # no temporary file left behind
    second: list[tuple[int, int]] = []
    df = engine.run(matrices(), tmp_path, scheduler=cluster[0].scheduler_address,
                progress=lambda done, total: second.append((done, total)))
    assert_frame_equal(df, reference, check_exact=True)  # exact: same chunks, whichever run made them
    assert second == [(done, 10) for done in range(4, 11)]  # only the 7 missing chunks were computed
    assert {f: (folder / f).stat().st_mtime_ns for f in written} == written  # and the 3 not rewritten


@pytest.mark.slow
def test_killing_a_worker_loses_and_duplicates_no_sample(tmp_path: Path, reference) -> None:
    # 10 chunks of 0.4 s on 2 workers: about 2 s; after 2 chunks one busy worker is SIGKILLed.
    killed: list[str] = []
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0") as lc, \
            Client(lc) as client:
        pids = client.run(os.getpid)

        def kill_one(done: int, total: int) -> None:
            if done == 2:
                busy = [w for w, keys in client.processing().items() if keys and w in pids]
                assert busy  # a chunk is in flight on the worker we kill: its result is lost with it
                os.kill(pids[busy[0]], signal.SIGKILL)
                killed.append(busy[0])

        df = engine.run(matrices(task=slow_abscissa), tmp_path, client=client, progress=kill_one)
        assert killed and killed[0] not in client.scheduler_info()["workers"]  # the worker did die
    # exact: every sample once (load checks it) with the values of the serial reference
    assert_frame_equal(df, reference, check_exact=True)


def test_a_different_campaign_in_the_same_folder_is_refused(tmp_path: Path, cluster) -> None:
    small = {"n": 10, "chunk": 5}
    engine.run(matrices(**small), tmp_path, client=cluster[1])
    for change, word in (({"seed": 1}, "seed"), ({"n": 11}, "n"), ({"chunk": 4}, "chunk"),
                         ({"task": slow_abscissa}, "task")):
        with pytest.raises(CampaignError, match=f"differs in {word}"):
            engine.run(matrices(**{**small, **change}), tmp_path, client=cluster[1])
    assert len(engine.run(matrices(**small), tmp_path, client=cluster[1])) == 10  # the same campaign resumes
    meta = tmp_path / "abscissa" / "campaign.json"
    for broken, text in (('{"n": 10', "Expecting"), ('{"n": 10}', "it must hold n, seed, chunk, task, sampler"),
                         (meta.read_text().replace('"chunks": {', '"chunks": {"x": 1, '), "'chunks' must map")):
        meta.write_text(broken)
        with pytest.raises(CampaignError, match=f"campaign.json: not a campaign record .*{text}"):
            engine.run(matrices(**small), tmp_path, client=cluster[1])


def test_load_names_missing_and_duplicated_samples(tmp_path: Path, cluster) -> None:
    small = matrices(n=10, chunk=5)
    engine.run(small, tmp_path, client=cluster[1])
    folder = tmp_path / "abscissa"
    (folder / "chunk-000009.parquet").write_bytes((folder / "chunk-000001.parquet").read_bytes())
    assert len(engine.load(folder)) == 10  # a file campaign.json does not list is never read
    # a forged chunk 0 (chunk 1's rows under chunk 0's name, checksum and metadata): the sample
    # indices still tell
    record = json.loads((folder / "campaign.json").read_text())
    forged = chunk_files.chunk_bytes(engine.run_chunk(small, 1), chunk_files.identity_digest(small.identity()), 0)
    (folder / "chunk-000000.parquet").write_bytes(forged)
    record["chunks"]["0"] = chunk_files.sha256(forged)
    (folder / "campaign.json").write_text(json.dumps(record))
    with pytest.raises(CampaignError, match=r"5 missing \(first: \[0, 1, 2, 3, 4\]\); 5 duplicated \(first: \[5"):
        engine.load(folder)
    del record["chunks"]["0"]  # an incomplete campaign: chunk 0 not computed yet
    (folder / "campaign.json").write_text(json.dumps(record))
    with pytest.raises(CampaignError, match=r"5 missing \(first: \[0, 1, 2, 3, 4\]\)"):
        engine.load(folder)


def test_bad_campaigns_and_task_outputs_raise_named_errors(tmp_path: Path, cluster) -> None:
    for changes, text in (({"n": 0}, "n must be an integer >= 1"), ({"chunk": 0}, "chunk must be"),
                          ({"name": "../up"}, "not a safe folder name"), ({"seed": -1}, "seed must be")):
        with pytest.raises(CampaignError, match=text):
            matrices(**changes)
    short = r"column 'abscissa': expected a 1-D array of 2000 values, got shape \(1999,\)"
    with pytest.raises(CampaignError, match=short):
        engine.run_chunk(matrices(task=short_column), 0)
    with pytest.raises(CampaignError, match=r"column 'grid': expected a 1-D array of 5 values, got shape \(5, 2\)"):
        engine.run(matrices(task=matrix_column, n=10, chunk=5), tmp_path, client=cluster[1])  # raised by a worker


def test_infinite_samples_are_results_counted_and_reported(tmp_path: Path, cluster) -> None:
    """Unstable samples (inf) neither kill the campaign nor hide: counted, maximum inf, no finite
    worst-case bound claimed, and they fail any level."""
    df = engine.run(matrices(name="decay", task=decay_time), tmp_path, client=cluster[1])
    unstable = int(np.isinf(df["decay_time"]).sum())
    # random normal 2x2 matrices: about half are unstable; the exact count is the reference's
    assert unstable == int((serial(matrices())["abscissa"] >= 0).sum()) and 0 < unstable < N
    s = engine.summarize(df, "decay_time", level=10.0)
    assert (s.n, s.n_nan, s.n_inf, s.max) == (N, 0, unstable, np.inf)
    assert not s.worst_case_valid and s.p <= 1 - unstable / N  # inf > level: a failure
    assert f"({unstable / N * 100:.3g} %" in s.text() and f"unbounded, {unstable} of {N} samples" in s.text()


def test_summary_numbers_and_bounds() -> None:
    df = pd.DataFrame({"x": np.arange(1, 1001) / 1000})  # 0.001 .. 1.000, uniform grid
    s = engine.summarize(df, "x", level=0.25)
    # exact or 1e-12: sums of 1000 values of the grid, rounding only
    assert (s.n, s.n_nan, s.min, s.max) == (1000, 0, 0.001, 1.0)
    assert abs(s.mean - 0.5005) < 1e-12
    assert s.p == 0.25  # exact: 250 of 1000 grid values are <= 0.25
    worst = math.ceil(math.log(1 / 1e-6) / math.log(1 / 0.9))
    chernoff = math.ceil(math.log(2 / 1e-6) / (2 * 0.1 ** 2))
    assert (worst, chernoff) == (132, 726) == (s.n_worst_case, s.n_chernoff)
    assert s.eps_n == math.sqrt(math.log(2 / 1e-6) / 2000)  # exact: the same closed form
    text = s.text()
    assert "132 samples needed" in text and "N = 1000 is enough" in text and "N >= 726" in text
    assert f"eps_N = sqrt(ln(2/delta)/(2N)) = {s.eps_n:.6g}" in text and "P(value > 1)" in text
    few = engine.summarize(df.iloc[:100], "x")
    assert not few.worst_case_valid and "N = 100 is NOT enough" in few.text()
    failed = engine.summarize(pd.concat([df, pd.DataFrame({"x": [np.nan] * 10})]), "x", level=0.25)
    assert failed.n_nan == 10 and failed.p == 250 / 1010  # exact: NaN samples fail the level
    assert failed.max == 1.0 and not failed.worst_case_valid and "10 samples are NaN" in failed.text()


@pytest.fixture(scope="module")
def demeter_fmus(tmp_path_factory: pytest.TempPathFactory) -> dict[str, str]:
    """The flexible plant and the row-1 controller FMUs only (the full catalog takes minutes)."""
    dest = tmp_path_factory.mktemp("demeter_fmus")
    ctrl = catalog.controller_source(artifact.load(ROOT / "controllers" / "artifacts" / "demeter_row1_det.json"))
    return {"plant": str(export.build_native(demeter.MODEL, dest)),
            "ctrl": str(export.build_native(ctrl.model, dest, ctrl.resources))}


def test_fmu_campaign_equals_the_in_process_runs(tmp_path: Path, cluster, demeter_fmus) -> None:
    task = engine.fmu_task(demeter_fmus, WIRES, demeter_parameters, 20.0, 0.5, {"peak_theta": peak_theta},
                       ["plant.theta[1]"])
    campaign = Campaign(name="demeter", task=task, n=8, seed=4, chunk=2, sampler=uniform_delta)
    df = engine.run(campaign, tmp_path, client=cluster[1])
    # exact: the same FMU binaries and steps in a worker as in this process
    assert_frame_equal(df, serial(campaign), check_exact=True)
    assert df["peak_theta"].nunique() == 8  # the sampled plants differ
    # 1 mrad/s for 20 s drifts at most 20 mrad; the loop keeps it above 5 mrad (values 7-12 mrad)
    assert df["peak_theta"].between(0.005, 0.02).all()


SMALL = {"n": 20, "chunk": 5}
"""4 chunks of 5 samples: the damage tests."""


def _flip_a_value_bit(path: Path) -> None:
    """Flip the lowest mantissa bit of sample 6's abscissa where the file stores it (a data page)."""
    data = bytearray(path.read_bytes())
    value = pd.read_parquet(path)["abscissa"].iloc[1]
    at = bytes(data).find(struct.pack("<d", value))
    assert at > 0 and bytes(data).count(struct.pack("<d", value)) == 1
    data[at] ^= 0x01
    path.write_bytes(bytes(data))
    # Parquet itself does not notice: the file reads, with another value (what passed silently)
    assert pd.read_parquet(path)["abscissa"].iloc[1] != value


def _rewrite_valid(path: Path) -> None:
    """A valid Parquet file with the chunk's columns and other values."""
    frame = pd.read_parquet(path)
    frame["abscissa"] += 1.0
    frame.to_parquet(path, index=False)


DAMAGES = [
    ("truncated", lambda p: p.write_bytes(p.read_bytes()[: p.stat().st_size // 2]),
     r"differs from its checksum in campaign\.json \(truncated, corrupted or rewritten\)"),
    ("0-byte", lambda p: p.write_bytes(b""), r"is empty \(0 bytes\)"),
    ("bit flip in a data page", _flip_a_value_bit, r"differs from its checksum"),
    ("rewritten valid chunk", _rewrite_valid, r"differs from its checksum"),
    ("deleted", lambda p: p.unlink(), r"is recorded in campaign\.json but its file is missing"),
]


@pytest.mark.parametrize("damage,message", [(d[1], d[2]) for d in DAMAGES], ids=[d[0] for d in DAMAGES])
def test_resume_computes_a_damaged_chunk_again_and_names_it(tmp_path: Path, cluster, damage, message) -> None:
    campaign = matrices(**SMALL)
    reference = engine.run(campaign, tmp_path, client=cluster[1])
    folder = tmp_path / "abscissa"
    damage(engine.chunk_path(folder, 2))
    with pytest.raises(CampaignError, match=r"chunk 2 \(chunk-000002\.parquet\) " + message):
        engine.load(folder)  # load alone never hands out a damaged chunk
    kept = {k: engine.chunk_path(folder, k).stat().st_mtime_ns for k in (0, 1, 3)}
    computed: list[int] = []
    with pytest.warns(CampaignWarning,
                      match=r"chunk 2 \(chunk-000002\.parquet\) " + message + r".*: computing it again"):
        df = engine.run(campaign, tmp_path, client=cluster[1], progress=lambda done, total: computed.append(done))
    assert_frame_equal(df, reference, check_exact=True)  # exact: the chunk's own draws again
    assert computed == [4]  # chunk 2 only
    assert {k: engine.chunk_path(folder, k).stat().st_mtime_ns for k in (0, 1, 3)} == kept


def test_a_chunk_of_another_campaign_is_never_adopted(tmp_path: Path, cluster) -> None:
    seed0, seed1 = matrices(**SMALL), matrices(**SMALL, seed=1)
    folder = tmp_path / "abscissa"
    # campaign.json deleted, the seed-1 chunks left: a new campaign, every chunk computed again
    engine.run(seed1, tmp_path, client=cluster[1])
    (folder / "campaign.json").unlink()
    with pytest.warns(CampaignWarning) as caught:
        df = engine.run(seed0, tmp_path, client=cluster[1])
    assert_frame_equal(df, serial(seed0), check_exact=True)
    assert sorted(int(re.search(r"chunk (\d) \(", str(w.message))[1]) for w in caught) == [0, 1, 2, 3]
    assert all("is not in campaign.json (no checksum to verify it by)" in str(w.message) for w in caught)
    # a seed-1 folder whose campaign.json was edited to say seed 0: the checksums match, the
    # chunks' own metadata names the seed-1 campaign
    engine.run(seed1, tmp_path / "edited", client=cluster[1])
    meta = tmp_path / "edited" / "abscissa" / "campaign.json"
    meta.write_text(json.dumps({**json.loads(meta.read_text()), "seed": SEED}))
    with pytest.raises(CampaignError, match=r"chunk 0 \(chunk-000000\.parquet\) was written by another campaign"):
        engine.load(meta.parent)
    with pytest.warns(CampaignWarning, match="was written by another campaign"):
        assert_frame_equal(engine.run(seed0, tmp_path / "edited", client=cluster[1]), serial(seed0), check_exact=True)


DRIVER = """
import json, sys, time, warnings
from pathlib import Path
from satfmu.sims.campaign import engine as cp
from tests import campaign_tasks as ct
out, scheduler, me = Path(sys.argv[1]), sys.argv[2], sys.argv[3]
(out / f"ready-{me}").touch()
while len(list(out.glob("ready-*"))) < 2:  # start both runs at once
    time.sleep(0.005)
computed = []
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always")
    df = cp.run(cp.Campaign(name="abscissa", task=ct.abscissa, n=20, seed=int(sys.argv[4]), chunk=5,
                            sampler=ct.normal_matrices), out, scheduler=scheduler,
                progress=lambda done, total: computed.append(done))
print(json.dumps({"computed": computed, "rows": len(df),
                  "warnings": [str(w.message) for w in caught if issubclass(w.category, cp.CampaignWarning)]}))
"""


def test_two_drivers_in_one_folder_wait_for_each_other(tmp_path: Path, cluster) -> None:
    env = {**os.environ, "PYTHONPATH": str(ROOT), "OPENBLAS_NUM_THREADS": "1"}
    drivers = [subprocess.Popen([sys.executable, "-c", DRIVER, str(tmp_path), cluster[0].scheduler_address, str(i),
                                 str(SEED)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
                                cwd=ROOT) for i in range(2)]
    results = []
    for d in drivers:
        out, err = d.communicate(timeout=120)
        assert d.returncode == 0, err
        results.append(json.loads(out.splitlines()[-1]))
    first, second = sorted(results, key=lambda r: -len(r["computed"]))
    # one computed the 4 chunks, the other waited for it and found them done
    assert first["computed"] == [1, 2, 3, 4] and first["warnings"] == []
    assert second["computed"] == [] and len(second["warnings"]) == 1
    assert "is in use by another campaign driver (process" in second["warnings"][0]
    assert first["rows"] == second["rows"] == 20
    folder = tmp_path / "abscissa"
    assert_frame_equal(engine.load(folder), serial(matrices(**SMALL)), check_exact=True)
    assert sorted(p.name for p in folder.iterdir() if p.name != "campaign.json") == \
        [".campaign.lock"] + [f"chunk-{k:06d}.parquet" for k in range(4)]  # no temporary file left


def test_resume_removes_what_a_killed_driver_left(tmp_path: Path, cluster) -> None:
    """A SIGKILL between a write and its rename leaves the temporary file; the next driver, which
    holds the folder's lock, removes every one (none can be another live driver's)."""
    small = matrices("swept", n=2 * CHUNK)
    first = engine.run(small, tmp_path, client=cluster[1])
    folder = tmp_path / "swept"
    left = [folder / ".chunk-00001.4242.deadbeef.partial.parquet", folder / ".campaign.4242.cafebabe.partial.json"]
    for p in left:
        p.write_bytes(b"half a file")
    assert_frame_equal(engine.run(small, tmp_path, client=cluster[1]), first, check_exact=True)
    assert not [p for p in left if p.exists()]


def test_a_complete_campaign_reads_back_from_a_read_only_file_system(tmp_path: Path, cluster) -> None:
    """The folder's lock file cannot be created there; a campaign with nothing left to compute
    needs none (a bind mount made read-only: needs root, as `make test` has in CI)."""
    small = matrices("readonly", n=2 * CHUNK)
    first = engine.run(small, tmp_path / "rw", client=cluster[1])
    (tmp_path / "rw" / "readonly" / chunk_files.LOCK).unlink()
    ro = tmp_path / "ro"
    ro.mkdir()
    mounted = subprocess.run(["mount", "--bind", str(tmp_path / "rw"), str(ro)], capture_output=True)
    if mounted.returncode != 0:
        pytest.skip(f"no bind mount here: {mounted.stderr.decode().strip()}")
    try:
        subprocess.run(["mount", "-o", "remount,ro,bind", str(ro)], check=True, capture_output=True)
        with pytest.raises(OSError, match="Read-only file system"):
            (ro / "probe").write_text("x")
        assert_frame_equal(engine.run(small, ro, client=cluster[1]), first, check_exact=True)
    finally:
        subprocess.run(["umount", str(ro)], capture_output=True)


# ----------------------------------------------------------------------------- identity across the move
def _old_record(folder: Path, campaign: engine.Campaign, **identity: object) -> None:
    """A campaign.json as an older satfmu wrote it (``identity`` overrides the keys of today's; no
    identity_format unless given), with one chunk recorded."""
    folder.mkdir(parents=True)
    record = {"name": campaign.name, **campaign.identity(), **identity, "n_chunks": campaign.n_chunks,
              "chunks": {"0": "0" * 64}}
    (folder / "campaign.json").write_text(json.dumps(record))


def test_identity_names_satfmu_callables_without_their_module() -> None:
    """A function of satfmu is named without its module (``satfmu:builder``), so that moving it
    changes no identity; other modules keep theirs."""
    assert engine._qualified_name(catalog.builder) == "satfmu:builder"
    assert engine._qualified_name(abscissa) == "tests.campaign_tasks.abscissa"


def test_the_identity_of_a_task_object_does_not_name_module_paths(monkeypatch: pytest.MonkeyPatch) -> None:
    """A callable object's digest is of its fields: the same task under a moved class (and a moved
    satfmu function in its fields) keeps its identity; another field value changes it."""
    def task(stop_time: float) -> engine.FmuTask:
        return engine.FmuTask(fmus={"plant": Path("p.fmu")}, connections=[], parameters=catalog.builder,
                          stop_time=stop_time, step_size=0.1, metrics={}, record=[])

    before = engine._qualified_name(task(1.0))
    monkeypatch.setattr(engine.FmuTask, "__module__", "satfmu.sims.elsewhere")
    monkeypatch.setattr(catalog.builder, "__module__", "satfmu.fmus.elsewhere")
    assert engine._qualified_name(task(1.0)) == before == "satfmu:FmuTask:" + before.rpartition(":")[2]
    assert engine._qualified_name(task(2.0)) != before


def test_a_record_from_before_the_move_resumes_with_function_tasks(tmp_path: Path) -> None:
    """Records of format 2 (``sims.x.f``) and of no format (``satfmu.sims.x.f``) naming a satfmu
    function task are this campaign: their recorded chunks are kept."""
    campaign = engine.Campaign(name="moved", task=catalog.builder, n=4, seed=1, chunk=2, sampler=engine.sample_indices)
    for fmt, prefix in ((2, ""), (None, "satfmu.")):
        folder = tmp_path / f"moved{fmt}"
        _old_record(folder, campaign, task=f"{prefix}sims.catalog.builder",
                    sampler=f"{prefix}sims.campaign.sample_indices", **({"identity_format": fmt} if fmt else {}))
        record = engine._claim_folder(folder, campaign)
        assert record["chunks"] == {"0": "0" * 64}


def test_a_record_from_before_the_move_naming_another_function_is_another_campaign(tmp_path: Path) -> None:
    campaign = engine.Campaign(name="moved", task=catalog.builder, n=4, seed=1, chunk=2, sampler=engine.sample_indices)
    _old_record(tmp_path / "moved", campaign, task="sims.catalog.not_builder", identity_format=2)
    with pytest.raises(CampaignError, match="holds another campaign"):
        engine._claim_folder(tmp_path / "moved", campaign)


def test_a_record_from_before_the_move_with_a_task_object_is_refused_saying_why(tmp_path: Path) -> None:
    """A callable object's digest of format 2 pickled the old module paths: such a record cannot
    be matched, and the message says so (not merely "another campaign")."""
    task = engine.FmuTask(fmus={}, connections=[], parameters=abscissa, stop_time=1.0, step_size=0.1, metrics={},
                      record=[])
    campaign = engine.Campaign(name="obj", task=task, n=4, seed=1, chunk=2, sampler=engine.sample_indices)
    _old_record(tmp_path / "obj", campaign, task="sims.campaign.FmuTask:" + "f" * 16, identity_format=2)
    with pytest.raises(CampaignError, match=r"written by an older satfmu \(identity format 2\), whose task object"):
        engine._claim_folder(tmp_path / "obj", campaign)
