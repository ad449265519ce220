"""SSP 1.0 export: the scenario's FMUs, connections and parameters, schema-valid, read back by fmpy."""
from __future__ import annotations

import zipfile
from pathlib import Path

import pytest
from fmpy import read_model_description
from fmpy.ssp.ssd import read_ssd
from lxml import etree

from satfmu.sims.interop import ssp
from satfmu.sims.cli import main
from satfmu.sims.scenario.run import run
from satfmu.sims.scenario.spec import ScenarioError, load


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


def test_omsimulator_finds_the_system_kind_where_it_looks(fmu_dir: Path, tmp_path: Path) -> None:
    """OMSimulator 3.0 takes a system's kind only from its own annotation (Model::getSystemType in
    its sources: ``ssd:System/ssd:Annotations/ssc:Annotation[type=org.openmodelica]/
    oms:Annotations/oms:SimulationInformation``, a child with a ``description``; without one it
    stops with ``[NewSystem] internal error``). The export carries it, prefixed as OMSimulator
    reads it (by prefixed name), with the scenario's step, and stays valid against the SSP 1.0
    schema (validated on export, and by fmpy here)."""
    path = ssp.export("mrp_200deg", fmu_dir, tmp_path)
    _, root = _ssd(path)
    notes = root.findall("ssd:System/ssd:Annotations/ssc:Annotation", ssp.NS)
    assert [n.get("type") for n in notes] == ["org.openmodelica"]
    master = notes[0].find("oms:Annotations/oms:SimulationInformation/oms:FixedStepMaster", ssp.NS)
    assert master is not None and master.prefix == "oms"
    assert (master.get("description"), master.get("stepSize")) == ("oms-ma", "0.05")
    assert read_ssd(str(path), validate=True).name == "mrp_200deg"


def test_python_backend_and_cli(fmu_dir: Path, tmp_path: Path, capsys) -> None:
    out = tmp_path / "x.ssp"
    assert main(["export-ssp", "mrp_200deg", "--backend", "python", "--fmu-dir", str(fmu_dir),
                 "--out", str(out)]) == 0
    assert "wrote" in capsys.readouterr().out
    assert "resources/mrp_satellite_py.fmu" in _ssd(out)[0]


def test_profiles_become_signal_generator_components(fmu_dir: Path, tmp_path: Path) -> None:
    # mrp_eq44: two steps and a constant on plant.w_d, as generic generators with the profile's
    # constants as parameter values, each connected to the input it drives
    # (plant.w_d is in N.m: the generators are made for N.m, signal_step__N_m)
    path = ssp.export("mrp_eq44", fmu_dir, tmp_path)
    names, root = _ssd(path)
    assert {"resources/signal_step__N_m.fmu", "resources/signal_constant__N_m.fmu"} <= set(names)
    ns = ssp.NS
    comp = root.find("ssd:System/ssd:Elements/ssd:Component[@name='signal_plant_w_d_1']", ns)
    assert comp.get("source") == "resources/signal_step__N_m.fmu"
    p = {e.get("name"): float(e[0].get("value")) for e in comp.iter(f"{{{ns['ssv']}}}Parameter")}
    # the profile's field "time" sets the parameter step_time (no FMU variable is called time)
    assert p == {"step_time": 5.0, "before": 2.0, "after": 0.0}
    cons = {(c.get("startElement"), c.get("startConnector"), c.get("endElement"), c.get("endConnector"))
            for c in root.findall("ssd:System/ssd:Connections/ssd:Connection", ns)}
    assert ("signal_plant_w_d_3", "y", "plant", "w_d[3]") in cons
    assert read_ssd(str(path), validate=True).name == "mrp_eq44"


def test_sampled_profiles_are_compiled_into_the_file(fmu_dir: Path, tmp_path: Path) -> None:
    f = _scenario(tmp_path, '[fmus.plant]\nmodel = "mrp_satellite"\n'
                            '[[profiles]]\nto = "plant.u[1]"\nkind = "random"\nseed = 1\nstd = 0.1\n')
    names, root = _ssd(ssp.export(f, fmu_dir, tmp_path / "out", ))
    tables = [n for n in names if n.startswith("resources/signal_table_")]
    assert len(tables) == 1
    # an instance name the generators need is refused
    f2 = _scenario(tmp_path, '[fmus.plant]\nmodel = "mrp_satellite"\n[fmus.signal_plant_u_1]\n'
                             'model = "mrp_satellite"\n[[profiles]]\nto = "plant.u[1]"\n'
                             'kind = "constant"\nvalue = 1.0\n')
    with pytest.raises(ssp.SspError, match="taken"):
        ssp.export(f2, fmu_dir, tmp_path / "out")


def _scenario(tmp_path: Path, text: str) -> Path:
    f = tmp_path / "s.toml"
    f.write_text('name = "s"\nstop_time = 1.0\nstep_size = 0.1\n' + text)
    return f


@pytest.mark.parametrize("body, message", [
    ('parameters = { "sigma_0[1]" = "x" }',
     r"fmus\.plant\.parameters\.sigma_0\[1\]: plant.sigma_0\[1\] is Real; got 'x'"),
    ("parameters = { nope = 1.0 }", r"fmus\.plant\.parameters\.nope: FMU instance 'plant' .*has no variable 'nope'"),
    ('[[connections]]\nfrom = "plant.u"\nto = "plant.u"', r"connections\[0\]: plant.u\[1\] is a input, not an output"),
    ("model = 'no_such_model'", r"fmus\.plant\.model: no FMU no_such_model.fmu in .*, "
                               r"and it cannot be built: no model or "
                               r"artifact named 'no_such_model'"),
], ids=["type", "unknown", "causality", "model"])
def test_bad_scenarios_fail_as_in_the_run(body: str, message: str, fmu_dir: Path, tmp_path: Path) -> None:
    """export-ssp checks a scenario as a run does (satfmu.sims.scenario.run.check), with the same message,
    before it writes anything."""
    plant = "[fmus.plant]\n" + ("" if body.startswith("model") else 'model = "mrp_satellite"\n')
    f = _scenario(tmp_path, plant + body + "\n")
    with pytest.raises(ScenarioError, match=message):
        ssp.export(f, fmu_dir, tmp_path / "out")
    with pytest.raises(ScenarioError, match=message):
        run(f, fmu_dir, out_dir=tmp_path / "out")
    assert not (tmp_path / "out").exists()


def test_schema_failures_are_reported(fmu_dir: Path) -> None:
    ssd, _ = ssp.system_structure(load("mrp_200deg"), fmu_dir)
    root = etree.fromstring(ssd)
    del root.attrib["version"]
    next(root.iter(f"{{{ssp.NS['ssv']}}}Real")).set("value", "fast")  # not a double
    with pytest.raises(ssp.SspError) as exc:
        ssp.validate(root)
    text = str(exc.value)
    assert "'version' is required" in text and "SystemStructureParameterValues.xsd" in text and "'fast'" in text


def test_signal_generators_declare_the_unit_of_the_input_they_drive(fmu_dir: Path, tmp_path: Path) -> None:
    """Issue 28, defect 5: every generator of an exported SSP declares, for its output ``y``, the
    unit its target input declares (FMI 2.0: one fixed unit per variable; a ``"1"`` output
    connected to an N.m input is a unit mismatch for a tool that checks units)."""
    path = ssp.export("mrp_eq44", fmu_dir, tmp_path)
    _, root = _ssd(path)
    ns = ssp.NS
    with zipfile.ZipFile(path) as zf:
        def description(element: str):
            source = root.find(f"ssd:System/ssd:Elements/ssd:Component[@name='{element}']", ns).get("source")
            fmu = tmp_path / Path(source).name
            fmu.write_bytes(zf.read(source))
            return read_model_description(str(fmu))

        checked = 0
        for c in root.findall("ssd:System/ssd:Connections/ssd:Connection", ns):
            if not c.get("startElement").startswith("signal_"):
                continue
            src, dst = description(c.get("startElement")), description(c.get("endElement"))
            y = next(v for v in src.modelVariables if v.name == c.get("startConnector"))
            target = next(v for v in dst.modelVariables if v.name == c.get("endConnector"))
            assert target.unit == "N.m", f"mrp_eq44 drives plant.w_d (N.m), got {target.unit!r}"
            assert y.unit == target.unit, (f"{c.get('startElement')}.y declares {y.unit!r}, the input "
                                           f"{c.get('endElement')}.{target.name} it drives {target.unit!r}")
            checked += 1
    assert checked == 3, f"mrp_eq44 has three profiles on plant.w_d[1..3], {checked} generator connections found"
