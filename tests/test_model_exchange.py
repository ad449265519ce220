"""The plants' model-exchange FMUs, FMI 2.0 (``<plant>_me.fmu``, ``fmus/c/fmi2_me.c``) and FMI 3.0
(``<plant>_me_fmi3.fmu``, ``fmus/c/fmi3_me.c``), integrated by fmpy's CVODE against the co-simulation
FMU of the same model, and the FMI 3.0 one against the FMI 2.0 one (bit for bit: the same C and the
same solver). Where a law slides (the wheels at their speed limit, the VSCMG's stick-slip), the
co-simulation FMU's chattering converges to the model-exchange FMU's sliding mode at first order.

The two integrate the same right-hand side differently: CVODE (BDF, relative tolerance 1e-10,
stopping at the event indicators' zero crossings) and the co-simulation FMU's fixed RK4 substeps
(here h_max small enough that its error is below CVODE's) or exact flow. Each case states its
tolerance and why; each one drives the model through its switching (the MRP shadow set, the
momentum clamp), so a missed or misplaced event fails it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu
from fmpy.fmi2 import FMU2Model
from fmpy.fmi3 import FMU3Model, FMU3Slave, fmi3Float64, fmi3ValueReference
from fmpy.validation import validate_fmu

from satfmu.controllers import catalog
from satfmu.fmus.events import event_indicators
from tests.fmi3_results import flat

PLANTS = [name for name, make in catalog.PLANTS.items() if "me" in make().backends]
SUFFIXES = {"2.0": "_me", "3.0": "_me_fmi3"}
"""The model-exchange FMU's file-name suffix of each FMI version."""
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
    # the wheels spun up by a body torque command beyond their limit: wheel 1 (wheels 1 to 3 of the
    # pyramid) reaches 600 rad/s at 120 s and is held there, sliding, while the others spin on. The
    # co-simulation FMU chatters at the limit, within one substep's spin-up (u_max / Js h_max = 2.5e-3
    # rad/s at h_max = 5e-4 s) of it: the bound; the difference is first order in h_max (test below)
    **{name: Case(name, 200.0, 1.0, {"shadow_switching": True}, {"u[1]": 0.2, "u[2]": 0.05, "u[3]": 0.0},
                  {"h_max": 5e-4}, ("omega[1]", "omega[2]", "omega[3]", "Omega[1]", "Omega[2]", "Omega[3]", "phi"),
                  2.5e-3) for name in ("mrp_satellite_rw3", "mrp_satellite_rw4")},
    # rotor and gimbal 2 driven past their stiction, gimbal 4 sticking and slipping under their
    # reaction: every stop and breakaway is an event here, resolved to one substep by the
    # co-simulation FMU. Measured 7.5e-5 rad/s (w2) at h_max = 1e-5 s, first order in h_max
    "vscmg": Case("vscmg", 5.0, 0.05, {}, {"T1": 0.3, "T2": 0.2}, {"h_max": 1e-5},
                  ("q1", "q2", "q4", "w1", "w2", "w4"), 2e-4),
}
SLIDING = {"mrp_satellite_rw3": (1e-3, 2.0, ("phi",)), "mrp_satellite_rw4": (1e-3, 2.0, ("phi",)),
           "vscmg": (1e-4, 10.0, ("q1", "q2", "q4"))}
"""The plants whose laws slide: the co-simulation FMU's coarser substep bound h_max (s), its ratio to
the case's one, and the angles whose convergence is measured (integrals of the chattering rates: the
rates themselves are sampled at a phase of the chattering that varies from step to step)."""


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


def _runs(case: Case, fmu_dir: Path, h_max: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The model-exchange run and the co-simulation one (its substep bound ``h_max`` if given)."""
    me = simulate_fmu(str(fmu_dir / f"{case.plant}_me.fmu"), stop_time=case.stop, output_interval=case.interval,
                      solver="CVode", relative_tolerance=case.rtol, start_values=case.start, input=_input(case),
                      output=list(case.compare))
    cs_start = {**case.start, **case.cs_start, **({"h_max": h_max} if h_max is not None else {})}
    cs = simulate_fmu(str(fmu_dir / f"{case.plant}.fmu"), stop_time=case.stop, step_size=case.interval,
                      output_interval=case.interval, start_values=cs_start, input=_input(case),
                      output=list(case.compare))
    return me, cs


def _largest(me: np.ndarray, cs: np.ndarray, names: tuple[str, ...]) -> dict[str, float]:
    return {n: float(np.max(np.abs(me[n] - cs[n]))) for n in names}


def test_every_plant_has_a_case() -> None:
    """Every plant has a model-exchange FMU in both FMI versions and a case here."""
    assert sorted(CASES) == sorted(PLANTS) == sorted(catalog.PLANTS)
    assert all("me3" in catalog.PLANTS[name]().backends for name in PLANTS)


@pytest.mark.parametrize("version", sorted(SUFFIXES))
def test_every_model_exchange_fmu_is_valid(version: str, fmu_dir: Path) -> None:
    """fmpy validate clean; the description's event indicators and continuous states are the model's."""
    for name in PLANTS:
        path = fmu_dir / f"{name}{SUFFIXES[version]}.fmu"
        assert validate_fmu(str(path)) == [], name
        md = read_model_description(str(path))
        assert md.fmiVersion == version
        assert md.modelExchange is not None and md.coSimulation is None
        model = catalog.source(name).model
        assert md.numberOfEventIndicators == len(event_indicators(model))
        assert md.numberOfContinuousStates == len(model.states)


@pytest.mark.parametrize("name", sorted(CASES))
def test_cvode_integrates_the_plant_as_the_cosimulation_fmu_does(name: str, fmu_dir: Path) -> None:
    case = CASES[name]
    me, cs = _runs(case, fmu_dir)
    me = _on_grid(me, cs["time"])
    worst = _largest(me, cs, case.compare)
    print(f"{name}: largest |ME - CS| {max(worst.values()):.3g} ({max(worst, key=worst.get)})")
    assert max(worst.values()) <= case.tolerance, worst


@pytest.mark.parametrize("name", sorted(SLIDING))
def test_a_sliding_law_is_the_limit_of_the_cosimulation_fmus_chattering(name: str, fmu_dir: Path) -> None:
    """Where a law slides (a wheel held at its speed limit, the VSCMG's axes sticking and slipping),
    the model-exchange FMU follows the sliding mode (Filippov) with a few events (fmpy's CVODE met an
    endless train of them before: 1.2e5 in the VSCMG's first 0.25 s, no progress past a wheel's
    limit), and the co-simulation FMU's substep-by-substep chattering converges to it at first order:
    the largest difference in the angles shrinks with h_max by its ratio (within 30 %). A wheel at
    its limit stays there to the solver's precision."""
    case = CASES[name]
    coarse, ratio, angles = SLIDING[name]
    me, cs_fine = _runs(case, fmu_dir)
    _, cs_coarse = _runs(case, fmu_dir, coarse)
    extra_rows = len(me) - len(cs_fine)  # fmpy records both sides of each event
    on_grid = _on_grid(me, cs_fine["time"])
    fine = max(_largest(on_grid, cs_fine, angles).values())
    rough = max(_largest(on_grid, cs_coarse, angles).values())
    print(f"{name}: largest |ME - CS| {rough:.3g} at h_max {coarse:g} s, {fine:.3g} at {coarse / ratio:g} s "
          f"(ratio {rough / fine:.2f}, expected {ratio:g}); {extra_rows // 2} events")
    assert 0.7 * ratio <= rough / fine <= 1.3 * ratio
    assert extra_rows // 2 <= 500  # a few per second, each a stop, a breakaway or a limit reached
    if name.startswith("mrp_satellite_rw"):
        held = np.abs(me["Omega[1]"])
        assert held.max() <= 600.0 + 1e-6 and held[me["time"] > 130.0].min() >= 600.0 - 1e-6


@pytest.mark.parametrize("name", sorted(CASES))
def test_fmi3_model_exchange_gives_the_fmi2_rows(name: str, fmu_dir: Path) -> None:
    """The FMI 3.0 model-exchange FMU, arrays and all, gives the FMI 2.0 one's rows bit for bit (the
    same generated C, the same CVODE steps and events); its inputs set as arrays. Printed: the
    largest difference (0)."""
    case = CASES[name]
    vectors: dict[str, list[float]] = {}
    for key, value in {**case.start, **case.inputs}.items():
        base, _, index = key.partition("[")
        if index:
            vectors.setdefault(base, []).append(value)  # the cases list a vector's elements in order
        else:
            vectors[base] = value  # type: ignore[assignment]
    runs = {}
    for version, start in (("2.0", {**case.start, **case.inputs}), ("3.0", vectors)):
        runs[version] = flat(simulate_fmu(str(fmu_dir / f"{name}{SUFFIXES[version]}.fmu"), stop_time=case.stop,
                                          output_interval=case.interval, solver="CVode",
                                          relative_tolerance=case.rtol, start_values=start))
    assert len(runs["3.0"]["time"]) == len(runs["2.0"]["time"])
    worst = max(float(np.max(np.abs(runs["3.0"][n] - runs["2.0"][n]))) for n in runs["2.0"])
    print(f"{name}: largest |FMI 3.0 - FMI 2.0| {worst:.3g} over {len(runs['2.0'])} columns")
    assert set(runs["3.0"]) == set(runs["2.0"]) and worst == 0.0


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


def test_fmi3_model_exchange_state_machine_and_variables(fmu_dir: Path) -> None:
    """FMI 3.0: co-simulation instantiation refused (a file of its own); the continuous states and
    their count; derivatives read as the variables der(omega), der(sigma) equal
    fmi3GetContinuousStateDerivatives, the event_indicators variable fmi3GetEventIndicators;
    out-of-order calls, a wrong count and a non-finite state refused with a message."""
    import ctypes

    from fmpy.fmi1 import FMICallException

    from satfmu.sims.cosim import fmi_host

    path = fmu_dir / "mrp_satellite_me_fmi3.fmu"
    md, unzip = fmi_host.open_fmu(path)
    callbacks = fmi_host.Callbacks()
    refs = {v.name: v.valueReference for v in md.modelVariables}
    assert md.modelExchange is not None and md.modelExchange.modelIdentifier == "mrp_satellite_me_fmi3"
    fmu = FMU3Model(guid=md.guid, unzipDirectory=unzip, modelIdentifier=md.modelExchange.modelIdentifier,
                    instanceName="me3")
    fmu.instantiate(loggingOn=True, logMessage=callbacks.fmi3_logger("me3"))

    def refused(fn, *args) -> str:
        since = len(callbacks.log)
        with pytest.raises(FMICallException):
            fn(*args)
        return callbacks.text(since)

    def array(values: list[float]) -> ctypes.Array:
        return (fmi3Float64 * len(values))(*values)

    dx = array([0.0] * 6)
    assert "must not be called in state Instantiated" in refused(fmu.getContinuousStateDerivatives, dx, 6)
    fmu.enterInitializationMode(startTime=0.0)
    fmu.setFloat64([refs["omega_0"], refs["sigma_0"]], [0.3, -0.2, 0.25, 0.9, 0.3, 0.2])
    fmu.exitInitializationMode()
    assert "must not be called in state EventMode" in refused(fmu.setContinuousStates, array([0.0] * 6), 6)
    fmu.updateDiscreteStates()
    fmu.enterContinuousTimeMode()
    n_z = fmu.getNumberOfEventIndicators()
    assert (fmu.getNumberOfContinuousStates(), n_z) == (6, md.numberOfEventIndicators) and n_z >= 1
    x = array([0.0] * 6)
    fmu.getContinuousStates(x, 6)
    assert list(x) == [0.3, -0.2, 0.25, 0.9, 0.3, 0.2]
    fmu.getContinuousStateDerivatives(dx, 6)
    assert fmu.getFloat64([refs["der(omega)"], refs["der(sigma)"]], nValues=6) == list(dx)
    assert any(d != 0.0 for d in dx)
    g = array([0.0] * n_z)
    fmu.getEventIndicators(g, n_z)
    assert fmu.getFloat64([refs["event_indicators"]], nValues=n_z) == list(g)
    # |sigma|^2 - 1 < 0 at |sigma| = 0.97, plus its hysteresis offset: the solver sees it negative
    assert min(g) < 0.0
    assert "5 values for 6" in refused(fmu.setContinuousStates, array([0.0] * 5), 5)
    assert "non-finite" in refused(fmu.setContinuousStates, array([0.0, 0.0, math.nan, 0.0, 0.0, 0.0]), 6)
    assert "is a state or its derivative" in refused(fmu.setFloat64, [refs["der(omega)"]], [0.0, 0.0, 0.0])
    vr = (fmi3ValueReference * 1)(refs["omega"])
    assert "nValues = 2" in refused(fmu.fmi3GetFloat64, fmu.component, vr, 1, array([0.0, 0.0]), 2)
    fmu.terminate()
    fmu.freeInstance()
    fmu.freeLibrary()

    slave = FMU3Slave(guid=md.guid, unzipDirectory=unzip, modelIdentifier=md.modelExchange.modelIdentifier,
                      instanceName="cs")
    since = len(callbacks.log)
    with pytest.raises(Exception, match="instantiate"):
        slave.instantiate(loggingOn=True, logMessage=callbacks.fmi3_logger("cs"))
    assert "supports model exchange only" in callbacks.text(since)
    slave.freeLibrary()
