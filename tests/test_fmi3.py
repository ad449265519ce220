"""The native FMI 3.0 FMUs (``<name>_fmi3.fmu``, ``fmus/c/fmi3.c``): the FMI 2.0 FMU's model and
C code through the FMI 3.0 interface, vectors as arrays, a sampled model's sample clock.

Without event mode an FMI 3.0 FMU samples inside its steps as the FMI 2.0 one does, so fmpy's run
of both gives the same numbers bit for bit (the same C code in the same order). With event mode
the importer activates the sample clock at each instant in Event Mode, after setting the inputs
of that instant: the samples then come from the same inputs as the FMI 2.0 FMU's in feedthrough
order, so those runs agree bit for bit too.
"""
from __future__ import annotations

import math
import re
import subprocess
import zipfile
from ctypes import c_int
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave
from fmpy.fmi3 import FMU3Slave, fmi3Float64, fmi3ValueReference
from fmpy.validation import validate_fmu

from satfmu.controllers import catalog
from satfmu.fmus import archive, export
from satfmu.fmus.arrays import array_description, array_variables
from satfmu.fmus.description3 import clock_reference
from satfmu.sims.cosim import fmi_host
from tests.fmi3_results import flat
from tests.test_win64 import ALLOWED_IMPORTS, pe_tables

NATIVE_MODELS = [src.model.name for src in catalog.sources() if "fmi3" in src.backends]


@pytest.fixture(scope="module")
def fmi3_files(fmu_dir: Path) -> dict[str, Path]:
    return {name: fmu_dir / f"{name}_fmi3.fmu" for name in NATIVE_MODELS}


def test_every_native_fmu_has_an_fmi3_twin_that_fmpy_validates(fmi3_files: dict[str, Path]) -> None:
    """29 FMI 3.0 FMUs, each clean in fmpy validate (its schema and rules for FMI 3.0)."""
    assert len(fmi3_files) == len(NATIVE_MODELS) >= 29
    problems = {name: validate_fmu(str(path)) for name, path in fmi3_files.items()}
    assert {name: p for name, p in problems.items() if p} == {}


@pytest.mark.parametrize("name", NATIVE_MODELS)
def test_without_event_mode_fmpy_gives_the_fmi2_numbers_bit_for_bit(name: str, fmu_dir: Path) -> None:
    """fmpy simulate (co-simulation, no event mode) of both FMUs over 40 default steps: every output
    equal bit for bit (the same C code: only the interface differs)."""
    model = catalog.source(name).model
    stop = 40 * model.default_step_size
    fmi2 = flat(simulate_fmu(str(fmu_dir / f"{name}.fmu"), stop_time=stop))
    fmi3 = flat(simulate_fmu(str(fmu_dir / f"{name}_fmi3.fmu"), stop_time=stop))
    assert set(fmi2) == set(fmi3) and len(fmi2["time"]) >= 41
    for column, values in fmi2.items():
        np.testing.assert_array_equal(fmi3[column], values, err_msg=column)


def test_vectors_are_arrays_with_their_elements_start_values_and_one_value_reference(fmu_dir: Path) -> None:
    """cubesat_bdot: b_body[1..3] is the input array b_body, m[1..3] the output array m; time is
    value reference 0; the clock follows the arrays."""
    md = read_model_description(str(fmu_dir / "cubesat_bdot_fmi3.fmu"))
    by_name = {v.name: v for v in md.modelVariables}
    assert by_name["time"].valueReference == 0 and by_name["time"].causality == "independent"
    assert [d.start for d in by_name["b_body"].dimensions] == [3] and by_name["b_body"].causality == "input"
    assert by_name["b_body"].description == "Measured field along body axis 1..3 (magnetometer)"
    assert [d.start for d in by_name["m"].dimensions] == [3]
    clock = by_name["sample_clock"]
    assert clock.type == "Clock" and clock.causality == "input" and clock.intervalVariability == "fixed"
    assert clock.valueReference == clock_reference(catalog.source("cubesat_bdot").model) == len(md.modelVariables) - 1
    assert [v.name for v in md.outputs[0].dependencies] == ["b_body"]


def test_arrays_group_complete_runs_only() -> None:
    """Every FMI 2.0 variable is in exactly one FMI 3.0 variable, in order; demeter_flexible's
    two-index parameters (``J[1,2]``) stay scalars, its ``zeta[1..4]`` is an array; descriptions
    that differ in the element number only name the range, others are joined."""
    for src in catalog.sources():
        arrays = array_variables(src.model)
        covered = [a.first + j for a in arrays for j in range(a.size)]
        assert covered == list(range(len(src.model.variables))), src.model.name
    flexible = {a.name: a for a in array_variables(catalog.source("demeter_flexible").model)}
    assert flexible["zeta"].size == 4 and flexible["zeta"].is_array
    assert "J[1,2]" in flexible and not flexible["J[1,2]"].is_array
    assert array_description(["Rate about axis 1 (gyro)", "Rate about axis 2 (gyro)"]) == "Rate about axis 1..2 (gyro)"
    assert array_description(["Inertia x", "Product xy"]) == "Inertia x; Product xy"
    assert array_description(["Same", "Same"]) == "Same"


class Instance:
    """A co-simulation instance of an FMU file (fmpy's FMU3Slave, or FMU2Slave for ``fmi=2``),
    extracted privately; the FMU's messages in :attr:`messages`."""

    def __init__(self, path: Path, event_mode: bool, early_return: bool = False, fmi: int = 3) -> None:
        self.extracted = archive.extract(path)
        self.md = read_model_description(str(self.extracted.folder))
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.event_mode = event_mode
        self.messages: list[str] = []
        kind = FMU3Slave if fmi == 3 else FMU2Slave
        self.fmu = kind(guid=self.md.guid, unzipDirectory=str(self.extracted.folder),
                        modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName="fmi3 test")
        if fmi == 3:
            self.fmu.instantiate(eventModeUsed=event_mode, earlyReturnAllowed=early_return,
                                 logMessage=lambda env, status, category, message: self.messages.append(
                                     message.decode()))
        else:
            self.fmu.instantiate()

    def close(self) -> None:
        self.fmu.freeInstance()
        self.fmu.freeLibrary()
        self.extracted.close()

    def refused(self, call: Callable[[], object]) -> str:
        """The message of a call the FMU refuses with fmi3Error."""
        before = len(self.messages)
        with pytest.raises(FMICallException) as info:
            call()
        assert info.value.status == fmi_host.ERROR
        return " ".join(self.messages[before:])


@pytest.fixture
def open_instance() -> Iterator[Callable[..., Instance]]:
    made: list[Instance] = []

    def make(path: Path, event_mode: bool, early_return: bool = False, fmi: int = 3) -> Instance:
        made.append(Instance(path, event_mode, early_return, fmi))
        return made[-1]

    yield make
    for inst in made:
        inst.close()


def _field(t: float) -> list[float]:
    """A field rotating in the body at 0.05 rad/s (T): B-dot's input."""
    return [2e-5 * math.cos(0.05 * t), 2e-5 * math.sin(0.05 * t), 1e-5 * math.cos(0.02 * t)]


def _interval_and_shift(fmu: FMU3Slave, clock: int) -> tuple[float, int, float]:
    intervals, qualifiers, shifts = (fmi3Float64 * 1)(), (c_int * 1)(), (fmi3Float64 * 1)()
    refs = (fmi3ValueReference * 1)(clock)
    fmu.getIntervalDecimal(refs, intervals, qualifiers)
    fmu.getShiftDecimal(refs, shifts)
    return intervals[0], qualifiers[0], shifts[0]


def test_the_clock_states_the_period_and_the_first_instant(fmu_dir: Path, open_instance) -> None:
    """cubesat_bdot, control_period set to 0.5 s: interval 0.5 s, fmi3IntervalChanged (2) in Initialization
    Mode, fmi3IntervalUnchanged (1) after; shift 0.5 s from a start of 0 and from a start of 1.3 s
    (its instants count from the start, whose own sample is taken in initialization)."""
    for start, shift in ((0.0, 0.5), (1.3, 0.5)):
        inst = open_instance(fmu_dir / "cubesat_bdot_fmi3.fmu", event_mode=True)
        inst.fmu.setFloat64([inst.vr["control_period"]], [PERIOD])
        inst.fmu.enterInitializationMode(startTime=start)
        period, qualifier, first = _interval_and_shift(inst.fmu, inst.vr["sample_clock"])
        assert (period, qualifier) == (0.5, 2) and first == pytest.approx(shift, abs=1e-15)
        inst.fmu.exitInitializationMode()
        assert _interval_and_shift(inst.fmu, inst.vr["sample_clock"])[1] == 1
    # a gain schedule sampled at orbit times k * 900 s, the orbit time at t = 0 being 300 s: the
    # instants are t = k * 900 s - 300 s, the first after the start 600 s
    inst = open_instance(fmu_dir / "cubesat_periodic_satfmu_fmi3.fmu", event_mode=True)
    inst.fmu.setFloat64([inst.vr["orbit_time_0"]], [300.0])
    inst.fmu.enterInitializationMode(startTime=0.0)
    assert _interval_and_shift(inst.fmu, inst.vr["sample_clock"]) == (900.0, 2, 600.0)


def test_the_clocked_bdot_samples_where_the_importer_activates_its_clock(fmu_dir: Path, open_instance) -> None:
    """cubesat_bdot (period set to 0.5 s) stepped at 0.25 s with the field set at every communication
    point: FMI 2.0 in feedthrough order (inputs set, outputs read, step) and FMI 3.0 in event mode
    (at each clock instant: Event Mode, inputs, fmi3SetClock, fmi3UpdateDiscreteStates, whose
    nextEventTime is the next instant) give the same dipole at every point, bit for bit, over 20 s;
    the dipole changes only at the instants."""
    period, h = PERIOD, 0.25
    two = open_instance(fmu_dir / "cubesat_bdot.fmu", event_mode=False, fmi=2)
    two.fmu.setReal([two.vr["control_period"]], [period])
    two.fmu.setupExperiment(startTime=0.0)
    two.fmu.enterInitializationMode()
    two.fmu.exitInitializationMode()
    three = open_instance(fmu_dir / "cubesat_bdot_fmi3.fmu", event_mode=True)
    fmu, vr = three.fmu, three.vr
    fmu.setFloat64([vr["control_period"]], [period])
    fmu.enterInitializationMode(startTime=0.0)
    fmu.exitInitializationMode()  # Event Mode
    b_in = [two.vr[f"b_body[{i}]"] for i in (1, 2, 3)]
    m_out = [two.vr[f"m[{i}]"] for i in (1, 2, 3)]
    rows2, rows3 = [], []
    for k in range(81):
        t = k * h
        two.fmu.setReal(b_in, _field(t))
        rows2.append(two.fmu.getReal(m_out))
        if k % 2 == 0:  # the start, or an instant: the step ended at it
            if k > 0:
                fmu.enterEventMode()
            fmu.setFloat64([vr["b_body"]], _field(t))
            if k > 0:
                fmu.setClock([vr["sample_clock"]], [True])
            flags = fmu.updateDiscreteStates()
            assert flags[4] and flags[5] == pytest.approx(t + period, abs=1e-12)  # nextEventTime
            fmu.enterStepMode()
        else:
            fmu.setFloat64([vr["b_body"]], _field(t))
        rows3.append(fmu.getFloat64([vr["m"]], nValues=3))
        if k < 80:
            two.fmu.doStep(t, h)
            event, terminate, early, reached = fmu.doStep(t, h)
            assert not (event or terminate or early) and reached == pytest.approx(t + h, abs=1e-15)
    assert np.array_equal(np.array(rows3), np.array(rows2))
    changes = [k for k in range(1, 81) if rows2[k] != rows2[k - 1]]
    assert changes and all(k % 2 == 0 for k in changes)


PERIOD = 0.5
"""The sample period the clocked tests set on cubesat_bdot (its default is 1 s), s."""


def _started(inst: Instance) -> FMU3Slave:
    """Set cubesat_bdot's control_period to :data:`PERIOD`, initialize at t = 0 (and leave the
    initial Event Mode of an event-mode instance)."""
    inst.fmu.setFloat64([inst.vr["control_period"]], [PERIOD])
    inst.fmu.enterInitializationMode(startTime=0.0)
    inst.fmu.exitInitializationMode()
    if inst.event_mode:
        inst.fmu.updateDiscreteStates()
        inst.fmu.enterStepMode()
    return inst.fmu


def test_a_clocked_step_ends_at_an_instant_or_returns_early_there(fmu_dir: Path, open_instance) -> None:
    """A step of 0.75 s from 0 passes the instant at 0.5 s: refused without early return (the message
    says where to end it); with earlyReturnAllowed it returns at 0.5 s with eventHandlingNeeded. A
    step from an instant whose clock was not activated is refused, and so is an activation off the
    instants; an instance without event mode refuses fmi3SetClock (it samples by itself)."""
    path = fmu_dir / "cubesat_bdot_fmi3.fmu"
    strict = open_instance(path, event_mode=True)
    fmu = _started(strict)
    assert "passes the sample clock's activation at t = 0.5 s" in strict.refused(lambda: fmu.doStep(0.0, 0.75))
    assert fmu.doStep(0.0, 0.5) == (False, False, False, 0.5)
    assert "was due at t = 0.5 s and was not activated" in strict.refused(lambda: fmu.doStep(0.5, 0.25))

    early = open_instance(path, event_mode=True, early_return=True)
    fmu = _started(early)
    assert fmu.doStep(0.0, 0.75) == (True, False, True, 0.5)
    fmu.enterEventMode()
    fmu.setClock([early.vr["sample_clock"]], [True])
    assert fmu.getClock([early.vr["sample_clock"]]) == [True]
    fmu.updateDiscreteStates()
    assert fmu.getClock([early.vr["sample_clock"]]) == [False]  # deactivated by the update
    fmu.enterStepMode()
    assert fmu.doStep(0.5, 0.25) == (False, False, False, 0.75)
    fmu.enterEventMode()
    assert "t = 0.75 s is none (the next: 1 s)" in early.refused(lambda: fmu.setClock([early.vr["sample_clock"]],
                                                                                      [True]))
    plain = open_instance(path, event_mode=False)
    fmu = _started(plain)
    assert fmu.doStep(0.0, 0.75) == (False, False, False, 0.75)  # samples inside the step
    assert "must not be called in state StepMode" in plain.refused(
        lambda: fmu.setClock([plain.vr["sample_clock"]], [True]))
    assert "eventModeUsed = false" in plain.refused(fmu.enterEventMode)


def test_bad_calls_are_refused_and_change_nothing(fmu_dir: Path, open_instance) -> None:
    """nValues that do not count every element, the clock or time through fmi3SetFloat64, a type
    this FMU has none of, an unknown value reference: fmi3Error naming what is wrong; the values
    stay as they were."""
    inst = open_instance(fmu_dir / "cubesat_bdot_fmi3.fmu", event_mode=False)
    fmu, vr = _started(inst), inst.vr
    fmu.setFloat64([vr["b_body"]], [1e-5, 2e-5, 3e-5])
    assert "nValues = 2, but the 1 variables hold 3 values" in inst.refused(
        lambda: fmu.setFloat64([vr["b_body"]], [1.0, 2.0]))
    assert "is the sample clock" in inst.refused(lambda: fmu.setFloat64([vr["sample_clock"]], [1.0]))
    assert "independent variable 'time'" in inst.refused(lambda: fmu.setFloat64([0], [1.0]))
    assert "unknown value reference 99" in inst.refused(lambda: fmu.getFloat64([99]))
    assert "has another type" in inst.refused(lambda: fmu.setBoolean([vr["b_body"]], [True, True, True]))
    assert "no Int8 variables" in inst.refused(lambda: fmu.getInt8([vr["b_body"]]))
    assert "non-finite" in inst.refused(lambda: fmu.setFloat64([vr["b_body"]], [0.0, math.nan, 0.0]))
    assert fmu.getFloat64([vr["b_body"], 0], nValues=4) == [1e-5, 2e-5, 3e-5, 0.0]


def test_an_fmu_state_of_a_clocked_instance_restores_it_and_no_other(fmu_dir: Path, open_instance) -> None:
    """A state saved at an instant before its activation, restored after the activation and a step:
    the instant is due again (the next step is refused until the clock is activated); a state of an
    instance without event mode is refused by a clocked one."""
    path = fmu_dir / "cubesat_bdot_fmi3.fmu"
    clocked = open_instance(path, event_mode=True)
    fmu = _started(clocked)
    fmu.doStep(0.0, 0.5)
    saved = fmu.getFMUState()
    fmu.enterEventMode()
    fmu.setClock([clocked.vr["sample_clock"]], [True])
    fmu.updateDiscreteStates()
    fmu.enterStepMode()
    fmu.doStep(0.5, 0.25)
    fmu.setFMUState(saved)
    assert "was due at t = 0.5 s" in clocked.refused(lambda: fmu.doStep(0.5, 0.25))
    plain = open_instance(path, event_mode=False)
    other = _started(plain)
    blob = other.serializeFMUState(other.getFMUState())
    assert "eventModeUsed = false" in clocked.refused(lambda: fmu.deserializeFMUState(blob))


def _fmi3_functions() -> set[str]:
    """Every function of fmpy's fmi3Functions.h (all three interfaces: an FMI 3.0 binary exports them all)."""
    header = (export.fmi_headers() / "fmi3Functions.h").read_text()
    return set(re.findall(r"#define (fmi3\w+)\s+fmi3FullName\(", header))


def test_every_fmi3_fmu_carries_both_binaries_exporting_every_fmi3_function(fmi3_files: dict[str, Path],
                                                                           fmu_dir: Path, tmp_path: Path) -> None:
    """``binaries/`` holds exactly ``x86_64-linux/<id>.so`` and ``x86_64-windows/<id>.dll`` (the FMI
    3.0 platform tuples); each exports the 75 functions of fmi3Functions.h and nothing else of
    FMI's; the DLL imports only KERNEL32.dll and msvcrt.dll (as the FMI 2.0 DLLs). The plants'
    model-exchange FMUs (``_me_fmi3``) too."""
    names = _fmi3_functions()
    assert len(names) == 75
    wrong = {}
    model_exchange = {f"{src.model.name}_me": fmu_dir / f"{src.model.name}_me_fmi3.fmu"
                      for src in catalog.sources() if "me3" in src.backends}
    assert len(model_exchange) == len(catalog.PLANTS) == 7
    for name, fmu in {**fmi3_files, **model_exchange}.items():
        identifier = fmu.stem
        with zipfile.ZipFile(fmu) as z:
            binaries = sorted(n for n in z.namelist() if n.startswith("binaries/"))
            expected = [f"binaries/x86_64-linux/{identifier}.so", f"binaries/x86_64-windows/{identifier}.dll"]
            if binaries != expected:
                wrong[name] = binaries
                continue
            so, dll = (Path(z.extract(n, tmp_path / name)) for n in expected)
        symbols = subprocess.run(["nm", "-D", "--defined-only", str(so)], capture_output=True, text=True).stdout
        so_exports = {line.split()[-1] for line in symbols.splitlines() if line.split()[-1].startswith("fmi")}
        imports, dll_exports = pe_tables(dll)
        if so_exports != names or {e for e in dll_exports if e.startswith("fmi")} != names:
            wrong[name] = {"so": sorted(names ^ so_exports), "dll": sorted(names ^ dll_exports)}
        elif {i.lower() for i in imports} - ALLOWED_IMPORTS:
            wrong[name] = sorted(imports)
    assert not wrong, f"FMI 3.0 binaries not as expected: {wrong}"
