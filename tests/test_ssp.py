"""SSP 1.0 export: the scenario's FMUs, connections and parameters, schema-valid, read back by fmpy."""
from __future__ import annotations

import zipfile
from pathlib import Path

import pytest
from fmpy.ssp.ssd import read_ssd
from lxml import etree

from sims import ssp
from sims.cli import main
from sims.master import UnknownVariableError, WiringError
from sims.scenario import load


def _ssd(path: Path):
    with zipfile.ZipFile(path) as zf:
        return zf.namelist(), etree.fromstring(zf.read("SystemStructure.ssd"))


def test_export_holds_the_scenario(fmu_dir: Path, tmp_path: Path) -> None:
    path = ssp.export("mrp_200deg", fmu_dir, tmp_path)
    assert path == tmp_path / "mrp_200deg.ssp" and not list(tmp_path.glob("*.part"))
    names, root = _ssd(path)
    assert sorted(names) == ["SystemStructure.ssd", "resources/mrp_hinf_published.fmu", "resources/mrp_satellite.fmu"]
    ns = ssp.NS
    # 3 connections of 3-vectors in the TOML: 9 scalar connections, each end a declared connector
    cons = root.findall("ssd:System/ssd:Connections/ssd:Connection", ns)
    assert len(cons) == 9
    assert ("plant", "sigma[2]", "controller", "sigma[2]") in {
        (c.get("startElement"), c.get("startConnector"), c.get("endElement"), c.get("endConnector")) for c in cons}
    plant = root.find("ssd:System/ssd:Elements/ssd:Component[@name='plant']", ns)
    kinds = {c.get("name"): c.get("kind") for c in plant.findall("ssd:Connectors/ssd:Connector", ns)}
    assert kinds["u[1]"] == "input" and kinds["omega[3]"] == "output" and len(kinds) == 9
    # parameter values typed as the FMU declares them, the doubles written to read back exactly
    p = {e.get("name"): e[0] for e in plant.iter(f"{{{ns['ssv']}}}Parameter")}
    assert p["sigma_0[1]"].tag == f"{{{ns['ssv']}}}Real" and float(p["sigma_0[1]"].get("value")) == 0.5992
    ctrl = root.find("ssd:System/ssd:Elements/ssd:Component[@name='controller']", ns)
    sat = next(ctrl.iter(f"{{{ns['ssv']}}}Parameter"))
    assert sat.get("name") == "saturation_on" and sat[0].tag.endswith("Boolean") and sat[0].get("value") == "false"
    algo = root.find("ssd:DefaultExperiment/ssd:Annotations/ssc:Annotation/osp:Algorithm/osp:FixedStepAlgorithm", ns)
    assert algo.get("baseStepSize") == "0.05" and root.find("ssd:DefaultExperiment", ns).get("stopTime") == "120.0"
    # an independent reader with schema validation (fmpy's)
    desc = read_ssd(str(path), validate=True)
    assert desc.name == "mrp_200deg" and len(desc.system.connections) == 9


def test_python_backend_and_cli(fmu_dir: Path, tmp_path: Path, capsys) -> None:
    out = tmp_path / "x.ssp"
    assert main(["export-ssp", "mrp_200deg", "--backend", "python", "--fmu-dir", str(fmu_dir),
                 "--out", str(out)]) == 0
    assert "wrote" in capsys.readouterr().out
    assert "resources/mrp_satellite_py.fmu" in _ssd(out)[0]
    # a scenario with profiles is refused by name, and nothing is written for it
    assert main(["export-ssp", "mrp_eq44", "--fmu-dir", str(fmu_dir), "--out", str(tmp_path)]) == 1
    err = capsys.readouterr().err
    assert "disturbance profiles (plant.w_d[1], plant.w_d[2], plant.w_d[3])" in err
    assert not (tmp_path / "mrp_eq44.ssp").exists()


def _scenario(tmp_path: Path, text: str) -> Path:
    f = tmp_path / "s.toml"
    f.write_text('name = "s"\nstop_time = 1.0\nstep_size = 0.1\n' + text)
    return f


def test_bad_scenarios_fail_as_in_the_master(fmu_dir: Path, tmp_path: Path) -> None:
    plant = '[fmus.plant]\nmodel = "mrp_satellite"\n'
    with pytest.raises(WiringError, match="sigma_0.1. is Real; got 'x'"):
        ssp.export(_scenario(tmp_path, plant + 'parameters = { "sigma_0[1]" = "x" }\n'), fmu_dir, tmp_path)
    with pytest.raises(UnknownVariableError, match="no variable 'nope'"):
        ssp.export(_scenario(tmp_path, plant + 'parameters = { nope = 1.0 }\n'), fmu_dir, tmp_path)
    with pytest.raises(WiringError, match="not an output"):
        ssp.export(_scenario(tmp_path, plant + '[[connections]]\nfrom = "plant.u"\nto = "plant.u"\n'),
                   fmu_dir, tmp_path)
    with pytest.raises(FileNotFoundError, match="not found"):
        ssp.export(_scenario(tmp_path, '[fmus.plant]\nmodel = "no_such_model"\n'), fmu_dir, tmp_path)
    assert not list(tmp_path.glob("*.ssp*"))


def test_schema_failures_are_reported(fmu_dir: Path) -> None:
    ssd, _ = ssp.system_structure(load("mrp_200deg"), fmu_dir)
    root = etree.fromstring(ssd)
    del root.attrib["version"]
    next(root.iter(f"{{{ssp.NS['ssv']}}}Real")).set("value", "fast")  # not a double
    with pytest.raises(ssp.SspError) as exc:
        ssp.validate(root)
    text = str(exc.value)
    assert "'version' is required" in text and "SystemStructureParameterValues.xsd" in text and "'fast'" in text
