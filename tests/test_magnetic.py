"""Magnetorquer laws (seed 003) and the expression sampler they run on, native and pythonfmu."""
from __future__ import annotations

import math
import shutil
from pathlib import Path
from typing import Iterator

import numpy as np
import pytest
import sympy as sp
from fmpy import extract, read_model_description, simulate_fmu
from fmpy.fmi2 import FMU2Slave

from satfmu.controllers import artifact as artifacts
from satfmu.controllers import magnetic
from satfmu.controllers.polynomial import ARTIFACTS
from satfmu.fmus.model import Model, ModelDefinitionError, Sampler, Variable

PERIODIC = "cubesat_periodic_satfmu"
ART = artifacts.load(ARTIFACTS / f"{PERIODIC}.json")
BACKENDS = {"native": "", "python": "_py"}


class Slave:
    """An instantiated FMU driven call by call (fmpy's FMU2Slave), inputs and outputs by name."""

    def __init__(self, path: Path, start: dict[str, float] | None = None) -> None:
        self.md = read_model_description(str(path))
        self.unzip = extract(str(path))
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.fmu = FMU2Slave(guid=self.md.guid, unzipDirectory=self.unzip,
                             modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName="test")
        self.fmu.instantiate()
        self.fmu.setupExperiment(startTime=0.0)
        self.fmu.enterInitializationMode()
        for k, v in (start or {}).items():
            self.set(k, v)
        self.fmu.exitInitializationMode()
        self.t = 0.0

    def set(self, name: str, value: float) -> None:
        self.fmu.setReal([self.vr[name]], [float(value)])

    def get(self, *names: str) -> np.ndarray:
        return np.array(self.fmu.getReal([self.vr[n] for n in names]))

    def step(self, h: float) -> None:
        self.fmu.doStep(currentCommunicationPoint=self.t, communicationStepSize=h)
        self.t += h

    def close(self) -> None:
        self.fmu.terminate()
        self.fmu.freeInstance()
        shutil.rmtree(self.unzip, ignore_errors=True)


@pytest.fixture
def slaves(fmu_dir: Path) -> Iterator:
    made: list[Slave] = []

    def make(name: str, backend: str, start: dict[str, float] | None = None) -> Slave:
        s = Slave(fmu_dir / f"{name}{BACKENDS[backend]}.fmu", start)
        made.append(s)
        return s

    yield make
    for s in made:
        s.close()


def _expected_periodic(t: float, w: np.ndarray, tau0: float, period: float, inputs_set: bool = True
                       ) -> tuple[np.ndarray, int]:
    """Dipole of the last instant before t, or at t once the inputs of the step from t are set
    (instants: start and tau0 + t = k * period; an instant that ends a step is sampled from the
    next step's inputs, issue 28 defect 1)."""
    instants = [0.0] + [k * period - tau0 for k in range(1, 100)
                        if 0 < k * period - tau0 <= t + 1e-9 and (inputs_set or k * period - tau0 < t - 1e-9)]
    t_inst = max(instants)
    k = int(ART.gain_index(tau0 + t_inst))
    return ART.gains[k] @ w, k


@pytest.mark.parametrize("backend", ["native", "python"])
def test_periodic_gain_follows_orbit_time_and_holds_between_instants(slaves, backend: str) -> None:
    # orbit_time_0 = 300 s: the first instant after the start is t = 600 s (orbit time 900 s, k = 1).
    s = slaves(PERIODIC, backend, {"orbit_time_0": 300.0})
    w = np.array([0.01, -0.02, 0.03])
    for i, v in enumerate(w):
        s.set(f"omega[{i + 1}]", v)
    names = ("m[1]", "m[2]", "m[3]", "gain_index")
    for _ in range(40):  # 40 x 150 s: instants fall inside communication steps too
        # read before the inputs are set (a Jacobi-order host): an instant at s.t is not sampled yet
        m, k = _expected_periodic(s.t, w, 300.0, ART.sample_period, inputs_set=s.t == 0.0)
        got = s.get(*names)
        assert np.abs(got[:3] - m).max() < 1e-15 and got[3] == k, s.t
        for i, v in enumerate(w):  # the inputs of the next step (the same values): an instant at s.t samples them
            s.set(f"omega[{i + 1}]", v)
        m, k = _expected_periodic(s.t, w, 300.0, ART.sample_period)
        got = s.get(*names)
        assert np.abs(got[:3] - m).max() < 1e-15 and got[3] == k, s.t
        s.step(150.0)


@pytest.mark.parametrize("backend", ["native", "python"])
def test_shorter_sample_period_samples_the_input_but_keeps_the_schedule(slaves, backend: str) -> None:
    s = slaves(PERIODIC, backend, {"sample_period": 60.0})
    for step in range(60):  # the input changes every 30 s; the output only at the 60 s instants
        s.set("omega[1]", 1e-3 * step)
        t_inst = 60.0 * math.floor(s.t / 60.0 + 1e-9)
        k = int(ART.gain_index(t_inst))
        assert s.get("m[2]")[0] == pytest.approx(ART.gains[k][1, 0] * 1e-3 * (t_inst / 30.0), rel=1e-14)
        s.step(30.0)


def test_bdot_gain_is_avanzini_giulietti() -> None:
    n = 2 * math.pi / 5400.0
    assert magnetic.bdot_gain() == pytest.approx(2 * n * (1 + math.sin(math.radians(87))) * 0.002, rel=1e-15)
    with pytest.raises(ValueError):
        magnetic.bdot_gain(orbit_period=0.0)


@pytest.mark.parametrize("backend", ["native", "python"])
def test_bdot_is_the_finite_difference_law_and_resampling_an_instant_is_idempotent(slaves, backend: str) -> None:
    s = slaves("cubesat_bdot", backend, {"control_period": 2.0})
    k_w, T = magnetic.bdot_gain(), 2.0

    def field(b: np.ndarray) -> np.ndarray:
        for i, v in enumerate(b):
            s.set(f"b_body[{i + 1}]", v)
        return s.get("m[1]", "m[2]", "m[3]")

    a, b, c, d = (np.array(v) * 1e-5 for v in ([3, 1, 0], [2, 2, 1], [1, 3, 1], [0, 3, 2]))
    assert np.all(field(a) == 0.0)  # first sample: no difference yet
    assert np.all(field(b) == 0.0)  # the same instant again, with another input: still the first sample
    s.step(2.0)

    def law(now: np.ndarray, before: np.ndarray) -> np.ndarray:
        u, p = now / np.linalg.norm(now), before / np.linalg.norm(before)
        return -k_w / np.linalg.norm(now) * (u - p) / T

    assert np.abs(field(c) - law(c, b)).max() < 1e-15  # the previous instant's value is b, not a
    assert np.abs(field(d) - law(d, b)).max() < 1e-15  # re-sampled at the same instant: still against b
    s.step(1.0)  # no instant at t = 3 s: the dipole is held
    s.set("b_body[1]", 7e-5)
    assert np.abs(s.get("m[1]", "m[2]", "m[3]") - law(d, b)).max() < 1e-15
    s.step(1.0)
    # the instant t = 4 s ends the step: it is sampled from the next step's inputs, not from those
    # of [3 s, 4 s) before they are set again (issue 28, defect 1): still the dipole of t = 2 s
    assert np.abs(s.get("m[1]", "m[2]", "m[3]") - law(d, b)).max() < 1e-15
    s.set("b_body[2]", 4e-5)  # the inputs of the step from 4 s: sampled at once
    assert np.abs(s.get("m[1]", "m[2]", "m[3]") - law(np.array([7e-5, 4e-5, 2e-5]), d)).max() < 1e-15
    s.step(1.0)
    s.step(1.0)  # t = 6 s: no input set, so the next fmi2DoStep samples it from the inputs as they are
    assert np.abs(s.get("m[1]", "m[2]", "m[3]") - law(np.array([7e-5, 4e-5, 2e-5]), d)).max() < 1e-15
    s.step(1.0)
    e = np.array([7e-5, 4e-5, 2e-5])
    assert np.abs(s.get("m[1]", "m[2]", "m[3]") - law(e, e)).max() < 1e-15  # sampled at 6 s: no change


@pytest.mark.parametrize("backend", ["native", "python"])
def test_bdot_without_field_commands_nothing_and_restarts_cleanly(slaves, backend: str) -> None:
    s = slaves("cubesat_bdot", backend)
    for _ in range(3):  # inputs at their default 0: no measurement, m = 0, no NaN
        assert np.all(s.get("m[1]", "m[2]", "m[3]") == 0.0)
        s.step(1.0)
    s.set("b_body[1]", 3e-5)
    assert np.all(s.get("m[1]", "m[2]", "m[3]") == 0.0)  # first valid sample: no kick from the zero field
    s.step(1.0)
    assert np.all(s.get("m[1]", "m[2]", "m[3]") == 0.0)  # same direction: zero derivative


@pytest.mark.parametrize("backend", ["native", "python"])
def test_fmu_state_restores_the_sampling_record(slaves, backend: str) -> None:
    s = slaves("cubesat_bdot", backend)
    rng = np.random.default_rng(3)
    fields = rng.normal(size=(8, 3)) * 3e-5
    for b in fields[:3]:
        for i, v in enumerate(b):
            s.set(f"b_body[{i + 1}]", v)
        s.step(0.7)  # instants inside steps
    state = s.fmu.getFMUstate()
    runs = []
    for _ in range(2):
        s.fmu.setFMUstate(state)
        s.t = 2.1
        out = []
        for b in fields[3:]:
            for i, v in enumerate(b):
                s.set(f"b_body[{i + 1}]", v)
            s.step(0.7)
            out.append(s.get("m[1]", "m[2]", "m[3]"))
        runs.append(np.array(out))
    s.fmu.freeFMUstate(state)
    assert np.array_equal(runs[0], runs[1]) and np.abs(runs[0]).max() > 0


def test_native_and_python_controllers_agree_in_closed_loop(fmu_dir: Path) -> None:
    # Plant-free check of the generated code: the same input table through both backends.
    t = np.arange(0.0, 3600.0, 50.0)
    inputs = np.array(list(zip(t, 0.05 * np.cos(t / 700), -0.04 * np.sin(t / 300), 0.03 + 0 * t)),
                      dtype=[("time", float), ("omega[1]", float), ("omega[2]", float), ("omega[3]", float)])
    runs = [simulate_fmu(str(fmu_dir / f"{PERIODIC}{sfx}.fmu"), stop_time=3600.0, output_interval=50.0,
                         input=inputs, start_values={"orbit_time_0": 123.0}) for sfx in BACKENDS.values()]
    for name in ("m[1]", "m[2]", "m[3]", "gain_index"):
        assert np.array_equal(runs[0][name], runs[1][name]), name


def test_expression_sampler_definition_is_checked() -> None:
    held = [Variable("h")]
    good = dict(name="m", description="", states=[], inputs=[Variable("y")], outputs=[],
                parameters=[Variable("period", "s", start=1.0)])
    with pytest.raises(ModelDefinitionError, match="one argument per held value"):
        Model(**good, sampler=Sampler(held, [Variable("y").symbol, sp.Integer(1)], "period"))
    with pytest.raises(ModelDefinitionError, match="both module and function"):
        Model(**good, sampler=Sampler(held, [Variable("y").symbol], "period", module=__file__))
    with pytest.raises(ModelDefinitionError, match="sampler phase 'tau0' is no parameter"):
        Model(**good, sampler=Sampler(held, [Variable("y").symbol], "period", phase="tau0"))
    Model(**good, sampler=Sampler(held, [Variable("y").symbol + held[0].symbol], "period"))  # memory is allowed


def test_periodic_artifact_schema_is_enforced() -> None:
    data = ART.to_json()
    bad = {**data, "gains": data["gains"][:-1]}
    with pytest.raises(artifacts.ArtifactError, match="5 gains for 6 samples"):
        artifacts.parse(bad)
    with pytest.raises(artifacts.ArtifactError, match="whole number of sample periods"):
        artifacts.parse({**data, "schedule_period": 5000.0})
    nan = [[row[:] for row in g] for g in data["gains"]]
    nan[2][1][0] = float("nan")
    with pytest.raises(artifacts.ArtifactError, match=r"gains\[2\].*non-finite"):
        artifacts.parse({**data, "gains": nan})
    with pytest.raises(artifacts.ArtifactError, match=r"gains\[0\].*shape"):
        artifacts.parse({**data, "gains": [np.zeros((3, 2)).tolist()] * 6})
