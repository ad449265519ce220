"""Inputs meant to be driven: a controller left unconnected is refused, not run open loop (issue 56 item 4)."""
from __future__ import annotations

import zipfile
from pathlib import Path

import pytest

import satfmu
from satfmu.fmus.annotations import driven_inputs
from satfmu.fmus.errors import ScenarioError
from satfmu.fmus.model import Model, ModelDefinitionError, Output, Variable
from satfmu.sims.scenario import wiring

LOOP = {"name": "loop", "stop_time": 1.0, "step_size": 0.05,
        "fmus": {"plant": {"model": "mrp_satellite"}, "controller": {"model": "mrp_hinf_published"}},
        "connections": [{"from": "plant.sigma", "to": "controller.sigma"},
                        {"from": "controller.u", "to": "plant.u"}],
        "record": ["plant.phi"]}


def _wire(data: dict, fmu_dir: Path) -> None:
    wiring.wire(satfmu.Scenario.from_dict(data), fmu_dir).close()


def test_the_fmu_lists_its_driven_inputs(fmu_dir: Path) -> None:
    with zipfile.ZipFile(fmu_dir / "mrp_hinf_published.fmu") as z:
        listed = driven_inputs(z.read("modelDescription.xml"))
    assert sorted(listed) == sorted(f"{v}[{i}]" for v in ("sigma", "omega") for i in (1, 2, 3))
    with zipfile.ZipFile(fmu_dir / "mrp_satellite.fmu") as z:  # a plant's torques may stay at their start
        assert driven_inputs(z.read("modelDescription.xml")) == []


def test_a_controller_input_left_unconnected_is_an_error_naming_it(fmu_dir: Path) -> None:
    with pytest.raises(ScenarioError, match=r"controller \(mrp_hinf_published\): omega\[1\.\.3\]\. Connect them, "
                                            r"or set unconnected = \"zero\""):
        _wire(LOOP, fmu_dir)


def test_connected_profiled_or_given_a_start_value_it_runs(fmu_dir: Path) -> None:
    closed = {**LOOP, "connections": LOOP["connections"] + [{"from": "plant.omega", "to": "controller.omega"}]}
    _wire(closed, fmu_dir)
    profiled = {**LOOP, "profiles": [{"to": f"controller.omega[{i}]", "kind": "constant", "value": 0.0}
                                     for i in (1, 2, 3)]}
    _wire(profiled, fmu_dir)
    held = {**LOOP, "fmus": {**LOOP["fmus"], "controller": {"model": "mrp_hinf_published", "parameters": {
        f"omega[{i}]": 0.0 for i in (1, 2, 3)}}}}
    _wire(held, fmu_dir)
    with pytest.raises(ScenarioError, match=r"omega\[3\]\."):  # one index left: named alone
        _wire({**held, "fmus": {**held["fmus"], "controller": {"model": "mrp_hinf_published", "parameters": {
            f"omega[{i}]": 0.0 for i in (1, 2)}}}}, fmu_dir)


def test_unconnected_zero_runs_with_the_start_values(fmu_dir: Path) -> None:
    # the open-loop check a user asks for on purpose: the rate feedback is 0, the law still acts on sigma
    result = satfmu.run({**LOOP, "unconnected": "zero"}, fmu_dir=fmu_dir)
    assert result.results["plant.phi"].shape == (21,)
    with pytest.raises(ScenarioError, match=r"unconnected: must be one of 'error', 'zero', got 'zeros'.*'zero'"):
        satfmu.Scenario.from_dict({**LOOP, "unconnected": "zeros"})
    assert satfmu.Scenario.from_dict({**LOOP, "unconnected": "zero"}).to_dict()["unconnected"] == "zero"


def test_a_driven_input_must_be_an_input() -> None:
    u = Variable("u", "N.m", "torque")
    with pytest.raises(ModelDefinitionError, match=r"driven_inputs \['v'\] are not inputs"):
        Model("m", "d", states=[], inputs=[u], parameters=[], outputs=[Output(Variable("y", "N.m", "y"), u.symbol)],
              driven_inputs=("v",))


def test_result_plot_returns_the_figure(fmu_dir: Path, tmp_path: Path) -> None:
    closed = {**LOOP, "connections": LOOP["connections"] + [{"from": "plant.omega", "to": "controller.omega"}],
              "plot": {"panels": [["plant.phi"]]}}
    result = satfmu.run(closed, fmu_dir=fmu_dir)
    fig = result.plot()
    line = fig.axes[0].get_lines()[0]
    assert list(line.get_ydata()) == list(result.results["plant.phi"])  # the recorded values, unscaled
    fig.axes[0].axhline(0.1)  # a user draws on it
    fig = result.plot(tmp_path / "sub" / "run.png")
    assert (tmp_path / "sub" / "run.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert len(fig.axes) == 1
