"""The plants' FMI 2.0 model-exchange FMUs (``<plant>_me.fmu``, ``fmus/c/fmi2_me.c``), integrated by
fmpy's CVODE against the co-simulation FMU of the same model.

The two integrate the same right-hand side differently: CVODE (BDF, relative tolerance 1e-10,
stopping at the event indicators' zero crossings) and the co-simulation FMU's fixed RK4 substeps
(here h_max small enough that its error is below CVODE's) or exact flow. Each case states its
tolerance and why; each one drives the model through its switching (the MRP shadow set, the
momentum clamp), so a missed or misplaced event fails it.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu
from fmpy.fmi2 import FMU2Model
from fmpy.validation import validate_fmu

from satfmu.controllers import catalog
from satfmu.fmus.events import event_indicators

PLANTS = [name for name, make in catalog.PLANTS.items() if "me" in make().backends]
RTOL = 1e-10
"""CVODE's relative tolerance in every case."""


@dataclass(frozen=True)
class Case:
    """A model-exchange run against the co-simulation FMU.

    Attributes
    ----------
    plant : str
        The model name.
    stop : float
        Stop time, s.
    interval : float
        Output interval (and the co-simulation's communication step), s.
    start : dict
        Start values of both runs.
    inputs : dict
        Constant inputs.
    cs_start : dict
        Extra start values of the co-simulation run (its substep bound).
    compare : tuple of str
        The outputs compared.
    tolerance : float
        Largest absolute difference allowed, in the outputs' units.
    rtol : float
        CVODE's relative tolerance.
    """

    plant: str
    stop: float
    interval: float
    start: dict = field(default_factory=dict)
    inputs: dict = field(default_factory=dict)
    cs_start: dict = field(default_factory=dict)
    compare: tuple[str, ...] = ()
    tolerance: float = 0.0
    rtol: float = RTOL


CASES = {
    # a free tumble at 0.4 rad/s crosses |sigma| = 1 about every 8 s: the MRP set switches to its shadow
    # at the event; omega and the principal angle are independent of the set. Measured: omega 8e-11,
    # phi 6.2e-8 rad (CVODE's global error; RK4 at 1 ms is far below it)
    "mrp_satellite": Case("mrp_satellite", 60.0, 0.5,
                          {"shadow_switching": True, "omega_0[1]": 0.3, "omega_0[2]": -0.2, "omega_0[3]": 0.25,
                           "sigma_0[1]": 0.3, "sigma_0[2]": 0.2, "sigma_0[3]": 0.1}, {},
                          {"h_max": 1e-3}, ("omega[1]", "omega[2]", "omega[3]", "phi"), 5e-7),
    # a constant 5 mN m command fills the wheels' 0.12 N m s in about 30 s; the momentum is then
    # clamped (the post-step map at the event) and the torque cut; the co-simulation flow is exact
    "demeter_flexible": Case("demeter_flexible", 100.0, 0.5, {}, {"u_c[1]": 0.005, "u_c[2]": -0.004, "u_c[3]": 0.003},
                             {}, ("theta[1]", "theta[2]", "theta[3]", "h_w[1]", "h_w[2]", "h_w[3]"), 1e-7),
    # the default tumble under a constant dipole over a quarter orbit (no switching: the quaternion's
    # norm is kept by CVODE's tolerance instead of renormalization). The difference is CVODE's global
    # error: 6.5e-6 at rtol 1e-10, 1.7e-7 at 1e-12 (the co-simulation FMU's, halving h_max: 1e-11)
    "magnetorquer_cubesat": Case("magnetorquer_cubesat", 1350.0, 5.0, {}, {"m[1]": 0.1, "m[2]": -0.05, "m[3]": 0.02},
                                 {"h_max": 0.01}, ("omega[1]", "omega[2]", "omega[3]", "q[1]", "q[4]"), 1e-6,
                                 rtol=1e-12),
    # no state: the orbit and environment as functions of time, equal to the last bit
    "orbit_environment": Case("orbit_environment", 5400.0, 60.0, {}, {}, {}, ("r[1]", "r[2]", "r[3]", "b[1]"), 0.0),
}


def _input(case: Case) -> np.ndarray | None:
    if not case.inputs:
        return None
    rows = np.zeros(2, dtype=[("time", "f8")] + [(n, "f8") for n in case.inputs])
    rows["time"] = [0.0, case.stop]
    for n, v in case.inputs.items():
        rows[n] = v
    return rows


def _on_grid(result: np.ndarray, times: np.ndarray) -> np.ndarray:
    """The rows of a model-exchange result at ``times`` (fmpy also records each event's two sides;
    at an event on the grid, the row after it)."""
    index = [int(np.flatnonzero(np.abs(result["time"] - t) <= 1e-9 * max(1.0, abs(t)))[-1]) for t in times]
    return result[index]


def _runs(case: Case, fmu_dir: Path) -> tuple[np.ndarray, np.ndarray]:
    me = simulate_fmu(str(fmu_dir / f"{case.plant}_me.fmu"), stop_time=case.stop, output_interval=case.interval,
                      solver="CVode", relative_tolerance=case.rtol, start_values=case.start, input=_input(case),
                      output=list(case.compare))
    cs = simulate_fmu(str(fmu_dir / f"{case.plant}.fmu"), stop_time=case.stop, step_size=case.interval,
                      output_interval=case.interval, start_values={**case.start, **case.cs_start},
                      input=_input(case), output=list(case.compare))
    return me, cs


def test_every_plant_has_a_case() -> None:
    """Every plant but the three whose laws slide (catalog.SLIDING_PLANTS) has a model-exchange FMU
    and a case here."""
    assert sorted(CASES) == sorted(PLANTS) and len(PLANTS) == 4
    assert set(PLANTS) | set(catalog.SLIDING_PLANTS) == set(catalog.PLANTS)


def test_every_model_exchange_fmu_is_valid(fmu_dir: Path) -> None:
    """fmpy validate clean; the description's event indicators are the model's."""
    for name in PLANTS:
        path = fmu_dir / f"{name}_me.fmu"
        assert validate_fmu(str(path)) == [], name
        md = read_model_description(str(path))
        assert md.modelExchange is not None and md.coSimulation is None
        assert md.numberOfEventIndicators == len(event_indicators(catalog.source(name).model))
        assert len(md.derivatives) == len(catalog.source(name).model.states)


@pytest.mark.parametrize("name", sorted(CASES))
def test_cvode_integrates_the_plant_as_the_cosimulation_fmu_does(name: str, fmu_dir: Path) -> None:
    case = CASES[name]
    me, cs = _runs(case, fmu_dir)
    me = _on_grid(me, cs["time"])
    worst = {n: float(np.max(np.abs(me[n] - cs[n]))) for n in case.compare}
    print(f"{name}: largest |ME - CS| {max(worst.values()):.3g} ({max(worst, key=worst.get)})")
    assert max(worst.values()) <= case.tolerance, worst


def test_the_mrp_set_switches_at_the_event(fmu_dir: Path) -> None:
    """In the free tumble the co-simulation FMU's MRP set reaches |sigma| up to 1 + its last substep's
    growth before switching; the model-exchange one switches where |sigma|^2 - 1 crosses zero, located
    by CVODE: |sigma| never exceeds 1 by more than CVODE's root tolerance, and it switched."""
    case = CASES["mrp_satellite"]
    res = simulate_fmu(str(fmu_dir / "mrp_satellite_me.fmu"), stop_time=case.stop, output_interval=0.01,
                       solver="CVode", relative_tolerance=RTOL, start_values=case.start,
                       output=["sigma[1]", "sigma[2]", "sigma[3]"])
    cs = simulate_fmu(str(fmu_dir / "mrp_satellite.fmu"), stop_time=case.stop, step_size=0.01,
                      start_values={**case.start, **case.cs_start}, output=["sigma[1]", "sigma[2]", "sigma[3]"])

    def switches(r: np.ndarray) -> int:  # a switch flips the set: sigma jumps by about 2 |sigma| = 2
        step = np.sqrt(sum(np.diff(r[f"sigma[{i}]"]) ** 2 for i in (1, 2, 3)))
        return int((step > 1.0).sum())

    norm = np.sqrt(res["sigma[1]"] ** 2 + res["sigma[2]"] ** 2 + res["sigma[3]"] ** 2)
    assert norm.max() <= 1.0 + 1e-6
    assert switches(res) == switches(cs) >= 3


def test_calls_out_of_order_and_bad_arrays_are_refused(fmu_dir: Path) -> None:
    """The model-exchange state machine: derivatives before initialization, continuous states in
    Event Mode, a wrong count and a non-finite state are refused with fmi2Error and a message."""
    import ctypes

    from fmpy.fmi1 import FMICallException

    from satfmu.sims.cosim import fmi_host

    path = fmu_dir / "mrp_satellite_me.fmu"
    md, unzip = fmi_host.open_fmu(path)
    callbacks = fmi_host.Callbacks()
    fmu = FMU2Model(guid=md.guid, unzipDirectory=unzip, modelIdentifier=md.modelExchange.modelIdentifier,
                    instanceName="me")
    fmu.instantiate(callbacks=callbacks.functions, loggingOn=True)

    def refused(fn, *args) -> str:
        since = len(callbacks.log)
        with pytest.raises(FMICallException):
            fn(*args)
        return callbacks.text(since)

    dx = (ctypes.c_double * 6)()
    assert "must not be called in state Instantiated" in refused(fmu.getDerivatives, dx, 6)
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    assert "must not be called in state EventMode" in refused(fmu.setContinuousStates,
                                                              (np.ctypeslib.as_ctypes(np.zeros(6))), 6)
    fmu.newDiscreteStates()
    fmu.enterContinuousTimeMode()
    x = np.zeros(5)
    assert "5 values for 6" in refused(fmu.setContinuousStates, np.ctypeslib.as_ctypes(x), 5)
    bad = np.array([0.0, 0.0, np.nan, 0.0, 0.0, 0.0])
    assert "non-finite" in refused(fmu.setContinuousStates, np.ctypeslib.as_ctypes(bad), 6)
    assert "5 values for 6" in refused(fmu.getDerivatives, dx, 5)
    fmu.terminate()
    fmu.freeInstance()
    fmu.freeLibrary()
