"""The master running FMI 3.0 FMUs (:mod:`satfmu.sims.cosim.instances`): arrays as the FMI 2.0
scalars, the sampled controllers' clocks driven in Event Mode, the same rows as the FMI 2.0 run.

The FMI 3.0 FMUs run the FMI 2.0 FMUs' C code; the master passes them the same values at the same
times and activates a clock where the FMI 2.0 FMU would sample (at an instant that ends a step:
from the inputs set there; inside a step: from the step's inputs). So every comparison here is
exact: 0.0, not a tolerance.
"""
from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np
import pytest

from satfmu.fmus.errors import MasterError, SspError
from satfmu.sims.cosim.instances import scalar_description
from satfmu.sims.cosim.master import CoSimulation
from satfmu.sims.interop import ssp
from satfmu.sims.scenario.run import simulate
from satfmu.sims.scenario.spec import load

SHIPPED = sorted((Path(__file__).resolve().parents[1] / "sims" / "scenario" / "shipped").glob("*.toml"))
FAST_STEPS = 1000
"""Communication steps of each shipped scenario in the fast comparison: past the first instant of
the periodic gain schedules (900 s at 1 s steps) and the DEMETER loops' transients."""


def _largest_difference(a: np.ndarray, b: np.ndarray) -> float:
    assert a.dtype.names == b.dtype.names and len(a) == len(b)
    return max(float(np.max(np.abs(a[n] - b[n]))) for n in a.dtype.names)


def _compare_scenario(path: Path, fmu_dir: Path, steps: int | None) -> None:
    scenario = load(path)
    if steps is not None:
        n = round((scenario.stop_time - scenario.start_time) / scenario.step_size)
        scenario = dataclasses.replace(
            scenario, stop_time=scenario.start_time + min(n, steps) * scenario.step_size, metrics=[])
    fmi2, _ = simulate(scenario, fmu_dir, "native")
    fmi3, sim = simulate(scenario, fmu_dir, "fmi3")
    assert sim.fmi3 and sim.loop == "python"
    difference = _largest_difference(fmi2, fmi3)
    print(f"{path.stem}: {len(fmi3)} rows, largest |FMI 3.0 - FMI 2.0| = {difference:g}")
    assert difference == 0.0, f"{path.stem}: FMI 3.0 and FMI 2.0 runs differ by {difference:g}"


@pytest.mark.parametrize("path", SHIPPED, ids=[p.stem for p in SHIPPED])
def test_every_shipped_scenario_gives_the_fmi2_rows_with_fmi3_fmus(path: Path, fmu_dir: Path) -> None:
    """Each shipped scenario over its first 1000 steps, every instance FMI 3.0 (clocked where
    sampled), against the FMI 2.0 run: equal bit for bit (the largest difference is printed)."""
    _compare_scenario(path, fmu_dir, FAST_STEPS)


@pytest.mark.slow
@pytest.mark.parametrize("path", SHIPPED, ids=[p.stem for p in SHIPPED])
def test_every_shipped_scenario_gives_the_fmi2_rows_with_fmi3_fmus_to_its_end(path: Path, fmu_dir: Path) -> None:
    """The same over each scenario's whole run (77 s of FMI 3.0 runs in the Python loop in all)."""
    _compare_scenario(path, fmu_dir, None)


def _bdot(fmu_dir: Path, suffix: str) -> CoSimulation:
    sim = CoSimulation({"plant": fmu_dir / f"magnetorquer_cubesat{suffix}.fmu",
                        "bdot": fmu_dir / f"cubesat_bdot{suffix}.fmu"})
    sim.connect("plant.b_body", "bdot.b_body")
    sim.connect("bdot.m", "plant.m")
    return sim


def test_the_clocked_bdot_detumbles_in_jacobi_order(fmu_dir: Path) -> None:
    """cubesat_detumble's B-dot loop, two orbits at 1 s steps, every output read before any input
    is set (libcosim's order): the FMI 3.0 B-dot, its clock activated at each step's end, gives
    the FMI 2.0 rows bit for bit and takes |w| from 0.0707 rad/s below the scenario's bound,
    0.00707 rad/s."""
    runs = {}
    for suffix in ("", "_fmi3"):
        with _bdot(fmu_dir, suffix) as sim:
            runs[suffix] = sim.run(10800.0, 1.0, record=["plant.rate_norm", "bdot.m"], exchange_order="jacobi")
    assert _largest_difference(runs[""], runs["_fmi3"]) == 0.0
    rate = runs["_fmi3"]["plant.rate_norm"]
    assert rate[0] == pytest.approx(math.sqrt(0.05**2 + 0.04**2 + 0.03**2), rel=1e-12)
    assert rate[-1] < 0.00707


@pytest.mark.parametrize("order", ["feedthrough", "jacobi"])
def test_instants_inside_a_step_split_it(fmu_dir: Path, order: str) -> None:
    """B-dot sampling every 1.5 s under 1 s steps: every other instant falls inside a step, where
    the master ends a step, activates the clock with the step's inputs held and steps on; the FMI
    2.0 B-dot samples there inside its step from the same inputs. Equal bit for bit."""
    runs = {}
    for suffix in ("", "_fmi3"):
        with _bdot(fmu_dir, suffix) as sim:
            runs[suffix] = sim.run(300.0, 1.0, parameters={"bdot": {"control_period": 1.5}},
                                   record=["plant.omega", "bdot.m"], exchange_order=order)
    assert _largest_difference(runs[""], runs["_fmi3"]) == 0.0
    assert np.ptp(runs["_fmi3"]["bdot.m[1]"]) > 0  # B-dot acted


def test_fmi2_and_fmi3_fmus_run_together(fmu_dir: Path) -> None:
    """mrp_200deg with the plant as FMI 3.0 and the controller as FMI 2.0: the rows of the all-FMI
    2.0 run."""
    scenario = load(next(p for p in SHIPPED if p.stem == "mrp_200deg"))
    mixed = dataclasses.replace(scenario, fmus={name: dataclasses.replace(spec, backend="fmi3") if name == "plant"
                                                else spec for name, spec in scenario.fmus.items()})
    fmi2, _ = simulate(scenario, fmu_dir, "native")
    both, sim = simulate(mixed, fmu_dir, "native")
    assert sim.components["plant"].model_description.fmiVersion == "3.0"
    assert sim.components["controller"].model_description.fmiVersion == "2.0"
    assert _largest_difference(fmi2, both) == 0.0


def test_reused_fmi3_instances_are_reset_to_their_start_values(fmu_dir: Path) -> None:
    """A campaign's master keeps its instances and resets them (fmi3Reset): a second run, with a
    parameter of the first back at its start value, gives the rows of a fresh instance (the held
    copy of an array the master sets whole is reset with the instance)."""
    sim = CoSimulation({"plant": fmu_dir / "magnetorquer_cubesat_fmi3.fmu",
                        "bdot": fmu_dir / "cubesat_bdot_fmi3.fmu"}, reuse_instances=True)
    sim.connect("plant.b_body", "bdot.b_body")
    sim.connect("bdot.m", "plant.m")
    with sim:
        first = sim.run(50.0, 1.0, parameters={"plant": {"omega_0[2]": 0.01}}, record=["plant.omega"])
        again = sim.run(50.0, 1.0, record=["plant.omega"])
    with _bdot(fmu_dir, "_fmi3") as fresh:
        expected = fresh.run(50.0, 1.0, record=["plant.omega"])
    assert first["plant.omega[2]"][0] == 0.01
    assert _largest_difference(again, expected) == 0.0


def test_an_fmi3_fmu_steps_in_the_python_loop(fmu_dir: Path) -> None:
    """The compiled loop makes FMI 2.0 calls: asked for with an FMI 3.0 FMU it is refused; "auto"
    runs the Python loop and says so."""
    with _bdot(fmu_dir, "_fmi3") as sim:
        with pytest.raises(MasterError, match="the compiled loop runs FMI 2.0 FMUs only"):
            sim.run(10.0, 1.0, engine="compiled")
        sim.run(10.0, 1.0)
        assert sim.loop == "python"


def test_arrays_are_seen_as_their_scalars(tmp_path: Path) -> None:
    """A two-dimensional array's elements are named row-major (``J[1,1]``, ``J[1,2]``, ...) with
    their start values, an output array's elements depend on every element of its dependencies,
    and an array sized by a structural parameter is refused by name."""
    from fmpy import read_model_description

    xml = tmp_path / "modelDescription.xml"
    variables = """
    <Float64 name="time" valueReference="0" causality="independent" variability="continuous"/>
    <Float64 name="J" valueReference="1" causality="parameter" variability="fixed" start="1 2 3 4 5 6">
      <Dimension start="2"/><Dimension start="3"/></Float64>
    <Float64 name="y" valueReference="4" causality="output"><Dimension start="2"/></Float64>
    <Clock name="c" valueReference="5" causality="input" intervalVariability="fixed"/>"""
    structure = '<Output valueReference="4" dependencies="1"/>'

    def description(extra: str = "") -> object:
        xml.write_text(f"""<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="3.0" modelName="m" instantiationToken="{{x}}">
  <CoSimulation modelIdentifier="m"/>
  <ModelVariables>{variables}{extra}</ModelVariables>
  <ModelStructure>{structure}</ModelStructure>
</fmiModelDescription>""")
        return read_model_description(str(xml), validate=False)

    view = scalar_description(description())
    names = [v.name for v in view.description.modelVariables]
    assert names == ["J[1,1]", "J[1,2]", "J[1,3]", "J[2,1]", "J[2,2]", "J[2,3]", "y[1]", "y[2]"]
    assert [v.start for v in view.description.modelVariables[:6]] == ["1", "2", "3", "4", "5", "6"]
    assert [v.type for v in view.description.modelVariables] == ["Real"] * 8
    assert [v.valueReference for v in view.description.modelVariables] == list(range(8))
    assert [(e.variable.name, e.offset) for e in view.elements][4:7] == [("J", 4), ("J", 5), ("y", 0)]
    assert [u.variable.name for u in view.description.outputs] == ["y[1]", "y[2]"]
    assert [d.name for d in view.description.outputs[1].dependencies] == names[:6]
    assert [c.name for c in view.clocks] == ["c"]
    with pytest.raises(MasterError, match="'u': its size is a structural parameter's value"):
        scalar_description(description("""
    <UInt64 name="n" valueReference="2" causality="structuralParameter" variability="fixed" start="3"/>
    <Float64 name="u" valueReference="3" causality="input" start="0 0 0"><Dimension valueReference="2"/></Float64>"""))


def test_satfmu_run_with_fmi3_fmus(fmu_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    """``satfmu run --backend fmi3``: the scenario's metrics on the FMI 3.0 FMUs, its files named
    after the backend, the same values as the native run's."""
    from satfmu.sims.cli import main

    values = {}
    for backend in ("native", "fmi3"):
        assert main(["run", "mrp_slew_mc", "--backend", backend, "--fmu-dir", str(fmu_dir),
                     "--out", str(tmp_path)]) == 0
        summary = json.loads((tmp_path / "mrp_slew_mc" / f"summary_{backend}.json").read_text())
        values[backend] = [m["value"] for m in summary["metrics"]]
    assert "PASS mrp_slew_mc (fmi3)" in capsys.readouterr().out
    assert values["fmi3"] == values["native"]


def test_an_ssp_file_takes_no_fmi3_fmu(fmu_dir: Path, tmp_path: Path) -> None:
    """SSP 1.0 connects FMI 2.0 scalars: an export with FMI 3.0 FMUs is refused, naming them."""
    with pytest.raises(SspError, match=r"\['controller', 'plant'\] are FMI 3.0 FMUs"):
        ssp.export("mrp_200deg", fmu_dir, tmp_path / "x.ssp", "fmi3")
    assert not (tmp_path / "x.ssp").exists()
