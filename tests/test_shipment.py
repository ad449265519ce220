"""The files a scenario campaign's workers read, sent by content (satfmu.sims.campaign.shipment):
what is sent, how a worker's copies are checked, and a task that runs from them alone."""
from __future__ import annotations

import hashlib
import shutil
import tomllib
from pathlib import Path

import numpy as np
import pytest

from satfmu.fmus.errors import CampaignError
from satfmu.sims.campaign import shipment
from satfmu.sims.campaign.scenario_task import campaign
from satfmu.sims.scenario import SHIPPED_SCENARIOS
from satfmu.sims.scenario.spec import Scenario


@pytest.fixture()
def task(tmp_path: Path, fmu_dir: Path):
    """mrp_eq44 for 3 s with its controller given by path and a CSV disturbance on axis 3,
    dispersed in the first axis's step."""
    data = tomllib.loads((SHIPPED_SCENARIOS / "mrp_eq44.toml").read_text())
    folder = tmp_path / "driver"
    folder.mkdir()
    shutil.copy(fmu_dir / "mrp_hinf_published.fmu", folder / "ctrl.fmu")
    t = np.linspace(0.0, 3.0, 7)
    (folder / "wind.csv").write_text("time,w\n" + "".join(f"{a},{0.1 * np.sin(a)}\n" for a in t))
    profiles = [p for p in data["profiles"] if p["to"] != "plant.w_d[3]"]
    profiles.append({"to": "plant.w_d[3]", "kind": "csv", "file": "wind.csv", "column": "w"})
    sc = {**data, "stop_time": 3.0, "profiles": profiles, "metrics": data["metrics"][:1],
          "fmus": {**data["fmus"], "controller": {"path": "ctrl.fmu"}},
          "dispersions": {"profiles[0].before": {"kind": "uniform", "low": 1.0, "high": 3.0}}}
    return campaign(Scenario.from_dict(sc, folder), 4, seed=1, fmu_dir=fmu_dir, name="ship").task


def test_the_bundle_names_every_file_by_its_content(task, fmu_dir: Path) -> None:
    refs, files = shipment.bundle(task)
    kinds = {(r.kind, r.owner, r.name) for r in refs}
    assert kinds == {("model", "plant", "mrp_satellite.fmu"), ("path", "controller", "ctrl.fmu"),
                     ("csv", f"profiles[{len(task.scenario.profiles) - 1}]", "wind.csv")}
    for r in refs:
        assert hashlib.sha256(files[r.sha256]).hexdigest() == r.sha256
    plant = next(r for r in refs if r.owner == "plant")
    assert files[plant.sha256] == (fmu_dir / "mrp_satellite.fmu").read_bytes()


def test_a_worker_runs_the_task_from_its_copies_alone(task, tmp_path: Path, monkeypatch) -> None:
    """The driver's folder removed: the localized task gives the rows the driver's task gives."""
    expected = task(np.arange(4))
    refs, files = shipment.bundle(task)
    monkeypatch.setenv("SATFMU_HOME", str(tmp_path / "worker-home"))
    shutil.rmtree(tmp_path / "driver")
    local = task.localized(refs, files)
    assert Path(local.fmu_dir).is_relative_to(tmp_path / "worker-home")
    assert Path(local.scenario.fmus["controller"].path).parent == Path(local.fmu_dir)
    got = local(np.arange(4))
    assert got.keys() == expected.keys()
    for k in expected:
        np.testing.assert_array_equal(got[k], expected[k])


def test_wrong_bytes_are_refused_and_a_damaged_copy_replaced(task, tmp_path: Path, monkeypatch) -> None:
    refs, files = shipment.bundle(task)
    monkeypatch.setenv("SATFMU_HOME", str(tmp_path / "worker-home"))
    monkeypatch.setattr(shipment, "_VERIFIED", set())
    csv = next(r for r in refs if r.kind == "csv")
    with pytest.raises(CampaignError, match=r"no file of SHA-256 .* \(or other bytes\)"):
        shipment.localize(task, refs, {**files, csv.sha256: b"time,w\n0,1\n"})
    with pytest.raises(CampaignError, match="no file of SHA-256"):
        shipment.localize(task, refs, {k: v for k, v in files.items() if k != csv.sha256})
    shipment.localize(task, refs, files)
    cached = shipment.cache() / csv.sha256
    cached.write_bytes(b"damaged")  # a copy altered on the worker's disk
    monkeypatch.setattr(shipment, "_VERIFIED", set())
    local = shipment.localize(task, refs, files)
    assert hashlib.sha256(cached.read_bytes()).hexdigest() == csv.sha256
    assert Path(local.scenario.profiles[-1]["file"]).read_bytes() == files[csv.sha256]


def test_a_file_the_driver_cannot_read_is_named(task, tmp_path: Path) -> None:
    (tmp_path / "driver" / "wind.csv").unlink()
    with pytest.raises(CampaignError, match=r"profiles\[\d\]: cannot read .*wind.csv to send it to the workers"):
        shipment.bundle(task)


def test_a_reference_cannot_name_a_file_outside_the_set(task, tmp_path: Path, monkeypatch) -> None:
    refs, files = shipment.bundle(task)
    monkeypatch.setenv("SATFMU_HOME", str(tmp_path / "worker-home"))
    for bad in ("..", "../escape.fmu", "a/b.fmu", ""):
        forged = tuple(shipment.Reference(r.kind, r.owner, bad, r.sha256) if r.kind == "model" else r for r in refs)
        with pytest.raises(CampaignError, match="is no file name"):
            shipment.localize(task, forged, files)
    assert not any((tmp_path / "worker-home").rglob("escape.fmu"))
