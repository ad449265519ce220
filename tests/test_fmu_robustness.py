"""Robustness of the four FMUs against misuse, through fmpy's low-level FMI 2.0 API.

Each case drives ``FMU2Slave`` directly and collects the FMU's log through its own
``fmi2CallbackFunctions.logger``, so it can check the returned status *and* the text.

Every FMU rejects a bad call with fmi2Error, logs a message naming the variable or
function (whether or not logging is on), changes nothing, and stays usable: the native
FMUs (``fmus/c/fmi2_cosim.c``) and the pythonfmu FMUs alike (``fmus/pyslave.py`` behind
satfmu's C layer, ``fmus/c/pythonfmu_shim.c``, in front of pythonfmu 0.7.0's library). The
pythonfmu FMUs' setter messages lack the native ``fmi2SetReal:`` prefix, and a get in
Instantiated is reported per variable. An instance that answered fmi2Fatal is never called
again (``Instance.free``).
"""
from __future__ import annotations

import ctypes
import math
import random
import shutil
import struct
import subprocess
import sys
import textwrap
import time
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterator

import pytest
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave, fmi2Error, fmi2Fatal, fmi2FMUstate

from satfmu.sims.cosim import fmi_host


PLANT, PLANT_PY = "mrp_satellite.fmu", "mrp_satellite_py.fmu"
CTRL, CTRL_PY = "mrp_hinf_published.fmu", "mrp_hinf_published_py.fmu"
ALL = (PLANT, PLANT_PY, CTRL, CTRL_PY)
NATIVE = (PLANT, CTRL)
PYTHON = (PLANT_PY, CTRL_PY)
# (input to abuse, output to watch) per model
IO = {"mrp_satellite": ("u[1]", "omega[1]"), "mrp_hinf_published": ("omega[1]", "u[1]")}
STATE_MAGIC, STATE_FORMAT = 0x73746655, 4  # satfmu_core.h: the head of every native FMU state
HEADER = struct.Struct("<4I16s")  # satfmu_core.h Saved: magic, format, size, CRC-32, model identity
TIME_AT = HEADER.size  # Saved.d.time, the first field of the instance data
BLOW_UP = {"h_max": 1e6, "omega_0[1]": 1e3, "omega_0[2]": 1e3, "omega_0[3]": 1e3}


@dataclass
class Fmu:
    """One built FMU, extracted once per session."""

    file: str
    path: Path
    md: Any
    unzip: str  # fmpy.extract's folder (a str or a Path, depending on the fmpy version)
    is_python: bool

    @property
    def model(self) -> str:
        return self.md.modelName

    @property
    def input(self) -> str:
        return IO[self.model][0]

    @property
    def output(self) -> str:
        return IO[self.model][1]


class Instance:
    """An FMU2Slave with a logger that records ``(status, category, message)``."""

    def __init__(self, fmu: Fmu, guid: str | None = None, logging_on: bool | None = None,
                 instantiate: bool = True) -> None:
        self.fmu = fmu
        self.vars = {v.name: v for v in fmu.md.modelVariables}
        self.callbacks = fmi_host.Callbacks()
        self.log = self.callbacks.log
        self.dead = False  # returned fmi2Fatal: no further calls
        self.live = False
        # every FMU logs its errors regardless of loggingOn
        self.logging_on = bool(logging_on)

        self.slave = FMU2Slave(guid=guid or fmu.md.guid, unzipDirectory=fmu.unzip,
                               modelIdentifier=fmu.md.coSimulation.modelIdentifier, instanceName="robust")
        if instantiate:
            self.instantiate()

    def instantiate(self) -> None:
        self.slave.instantiate(callbacks=self.callbacks.functions, loggingOn=self.logging_on)
        self.live = True

    def vr(self, name: str) -> int:
        return self.vars[name].valueReference

    def text(self, since: int = 0) -> str:
        return self.callbacks.text(since)

    def ok(self, fn: str, *args: Any) -> Any:
        """Call ``FMU2Slave.<fn>``; it must succeed (fmpy raises on fmi2Error/fmi2Fatal)."""
        return getattr(self.slave, fn)(*args)

    def attempt(self, fn: str, *args: Any) -> tuple[int, str]:
        """Call ``FMU2Slave.<fn>``; return its status and the log lines it produced."""
        n = len(self.log)
        status, _ = fmi_host.attempt(self.slave, fn, *args)
        if status == fmi2Fatal:
            self.dead = True
        return status, self.text(n)

    def rejected(self, fn: str, *args: Any, contains: tuple[str, ...] = ()) -> str:
        """Call ``fn``, which must be rejected with fmi2Error and log every string of ``contains``."""
        status, text = self.attempt(fn, *args)
        # fmi2Error: the FMU stays usable (fmi2Fatal would end the instance)
        assert status == fmi2Error, f"{fn}{args}: status {status}, log: {text!r}"
        for part in contains:
            # the message must say what was wrong: the variable, the function or the state
            assert part in text, f"{part!r} not in the log of {fn}{args}: {text!r}"
        return text

    def get(self, names: list[str]) -> list[float]:
        return self.ok("getReal", [self.vr(n) for n in names])

    def outputs(self) -> list[float]:
        return self.get([v.name for v in self.fmu.md.modelVariables if v.causality == "output"])

    def set_value(self, name: str, value: Any) -> None:
        vtype = self.vars[name].type
        if vtype == "Integer":
            self.ok("setInteger", [self.vr(name)], [int(value)])
        elif vtype == "Boolean":
            self.ok("setBoolean", [self.vr(name)], [bool(value)])
        else:
            self.ok("setReal", [self.vr(name)], [float(value)])

    def initialize(self, params: dict[str, Any] | None = None, exit_init: bool = True) -> None:
        self.ok("setupExperiment", None, 0.0)
        self.ok("enterInitializationMode")
        for name, value in (params or {}).items():
            self.set_value(name, value)
        if exit_init:
            self.ok("exitInitializationMode")

    def free(self) -> None:
        """fmi2FreeInstance, unless the instance returned fmi2Fatal (after which FMI 2.0 allows
        no call at all). The library stays loaded (as in satfmu.sims.cosim.master)."""
        if self.dead:
            fmi_host.abandon(self)
        elif self.live:
            self.slave.fmi2FreeInstance(self.slave.component)
        self.live = False


@pytest.fixture(scope="session")
def fmus(fmu_dir: Path) -> Iterator[dict[str, Fmu]]:
    """The four FMUs, extracted once per session.

    ``fmu_dir`` (tests/conftest.py) is the session's ``satfmu.controllers.catalog.build_all`` output in a
    pytest tmp dir, built from the current tree and shared with the other test modules.
    """
    out = {}
    for name in ALL:
        path = fmu_dir / name
        out[name] = Fmu(name, path, read_model_description(str(path)), extract(str(path)),
                        path.stem.endswith("_py"))
    yield out
    for fmu in out.values():  # loaded libraries stay mapped; only the files go
        shutil.rmtree(fmu.unzip, ignore_errors=True)


@pytest.fixture
def make(fmus: dict[str, Fmu]):
    """Factory of :class:`Instance` objects, freed at teardown."""
    made: list[Instance] = []

    def _make(file: str, **kwargs: Any) -> Instance:
        inst = Instance(fmus[file], **kwargs)
        made.append(inst)
        return inst

    yield _make
    for inst in made:
        inst.free()


# ----------------------------------------------------------------------------- 1. inputs
@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf], ids=["nan", "+inf", "-inf"])
@pytest.mark.parametrize("file", ALL)
def test_non_finite_input_is_rejected_and_old_value_kept(make, file: str, bad: float) -> None:
    """A non-finite input value is refused and changes nothing."""
    inst = make(file)
    name = inst.fmu.input
    inst.initialize()
    inst.ok("setReal", [inst.vr(name)], [0.25])
    before = inst.outputs()
    inst.rejected("setReal", [inst.vr(name)], [bad], contains=(f"'{name}'", "non-finite"))
    # each FMU validates before storing: the previous value is still there, bit for bit
    assert inst.get([name]) == [0.25]
    # the rejected call did not touch the inputs, so the outputs are unchanged exactly
    assert inst.outputs() == before
    inst.ok("doStep", 0.0, 0.1)
    inst.ok("doStep", 0.1, 0.1)
    if inst.fmu.model == "mrp_satellite":
        # only u[1] = 0.25 N.m acts on a body at rest: omega[1]' = u / I_x with I_x = 15 kg m^2 and
        # omega[2] = omega[3] = 0 (no gyroscopic coupling), a constant derivative that RK4
        # integrates exactly up to the rounding of ~20 substeps: rel 1e-12 is ~1e4 ulp of margin
        assert inst.get(["omega[1]"])[0] == pytest.approx(0.25 / 15.0 * 0.2, rel=1e-12)
    else:
        # the controller is static (no states): same inputs give the same outputs, exactly
        assert inst.outputs() == before


# ----------------------------------------------------------------------------- 2. ranges
RANGE_CASES = [(PLANT, "I_x", -1.0), (PLANT, "h_max", 2e6), (PLANT, "n_substeps", 0), (CTRL, "u_max", -1.0)]
RANGE_CASES += [(f.replace(".fmu", "_py.fmu"), n, v) for f, n, v in RANGE_CASES]


@pytest.mark.parametrize("file,name,value", RANGE_CASES, ids=lambda x: str(x))
def test_out_of_range_parameter_is_rejected(make, file: str, name: str, value: float) -> None:
    """A parameter outside its declared [min, max] is refused (set via setReal or setInteger)."""
    inst = make(file)
    inst.initialize(exit_init=False)
    var = inst.vars[name]
    fn = "setInteger" if var.type == "Integer" else "setReal"
    inst.rejected(fn, [inst.vr(name)], [value], contains=(f"'{name}'", "outside its range"))
    start = float(var.start)
    getter = "getInteger" if var.type == "Integer" else "getReal"
    # the rejected value was not stored: the parameter still has its declared start value
    assert inst.ok(getter, [inst.vr(name)]) == [start]
    inst.ok("exitInitializationMode")
    inst.ok("doStep", 0.0, 0.1)


# ----------------------------------------------------------------------------- 3. types
TYPE_CASES = [(PLANT, "n_substeps"), (PLANT, "saturation_on"), (CTRL, "saturation_on")]
TYPE_CASES += [(f.replace(".fmu", "_py.fmu"), n) for f, n in TYPE_CASES]


@pytest.mark.parametrize("file,name", TYPE_CASES, ids=lambda x: str(x))
def test_set_real_on_integer_or_boolean_is_rejected(make, file: str, name: str) -> None:
    """fmi2SetReal on the value reference of an Integer or Boolean variable is refused, naming it
    (the pythonfmu FMU checks the type itself, before pythonfmu's own check would raise)."""
    inst = make(file)
    inst.initialize(exit_init=False)
    vr = inst.vr(name)
    inst.rejected("setReal", [vr], [1.0], contains=("fmi2SetReal", f"'{name}'", "another type"))
    if inst.vars[name].type == "Integer":
        # unchanged: n_substeps keeps its start value 4
        assert inst.ok("getInteger", [vr]) == [4]
    else:
        # unchanged: saturation_on keeps its start value false
        assert inst.ok("getBoolean", [vr]) == [False]
    inst.ok("exitInitializationMode")
    inst.ok("doStep", 0.0, 0.1)


# ----------------------------------------------------------------------------- 4. value references
@pytest.mark.parametrize("fn", ["setReal", "getReal"])
@pytest.mark.parametrize("file", ALL)
def test_unknown_value_reference_is_rejected(make, file: str, fn: str) -> None:
    """Value reference 10**6 (no such variable) is refused for set and get."""
    inst = make(file)
    inst.initialize()
    args = ([10**6], [1.0]) if fn == "setReal" else ([10**6],)
    inst.rejected(fn, *args, contains=(f"fmi2{fn[0].upper()}{fn[1:]}", "unknown value reference 1000000"))
    inst.ok("doStep", 0.0, 0.1)


# ----------------------------------------------------------------------------- 5. doStep arguments
STEP_CASES = {
    "h=0": ((0.1, 0.0), "communicationStepSize"),
    "h<0": ((0.1, -0.1), "communicationStepSize"),
    "h=nan": ((0.1, math.nan), "communicationStepSize"),
    "t behind": ((0.0, 0.1), "currentCommunicationPoint"),
    "t ahead": ((0.2, 0.1), "currentCommunicationPoint"),
}


@pytest.mark.parametrize("case", list(STEP_CASES))
@pytest.mark.parametrize("file", ALL)
def test_bad_do_step_is_rejected_and_fmu_still_steps(make, file: str, case: str) -> None:
    """doStep with a step size that is not finite and > 0, or at a communication point
    other than the FMU time (0.1 s here, after one step), is refused."""
    inst = make(file)
    inst.initialize()
    inst.ok("doStep", 0.0, 0.1)
    args, what = STEP_CASES[case]
    inst.rejected("doStep", *args, contains=("fmi2DoStep", what))
    # nothing advanced: the FMU time is still 0.1 s, so steps from there succeed
    inst.ok("doStep", 0.1, 0.1)
    inst.ok("doStep", 0.2, 0.1)


# ----------------------------------------------------------------------------- 6. call order
def _order_case(inst: Instance, case: str) -> str:
    """Bring ``inst`` to the state of ``case``, make the illegal call and recover (native)."""
    name = inst.fmu.input
    if case == "doStep before initialization":
        text = inst.rejected("doStep", 0.0, 0.1, contains=("fmi2DoStep", "Instantiated"))
    elif case == "getReal in Instantiated":
        text = inst.rejected("getReal", [inst.vr(inst.fmu.output)],
                             contains=("must not be called in state Instantiated",))
    elif case == "exit without enter":
        text = inst.rejected("exitInitializationMode", contains=("fmi2ExitInitializationMode", "Instantiated"))
    elif case == "fixed parameter after init":
        inst.initialize()
        text = inst.rejected("setReal", [inst.vr("u_max")], [1.0], contains=("'u_max'", "fixed", "StepComplete"))
    else:  # setReal after terminate
        inst.initialize()
        inst.ok("doStep", 0.0, 0.1)
        inst.ok("terminate")
        text = inst.rejected("setReal", [inst.vr(name)], [0.5], contains=(f"'{name}'", "Terminated"))
    return text


ORDER_CASES = ["doStep before initialization", "getReal in Instantiated", "exit without enter",
               "fixed parameter after init", "setReal after terminate"]


@pytest.mark.parametrize("case", ORDER_CASES)
@pytest.mark.parametrize("file", ALL)
def test_illegal_call_order_is_rejected(make, file: str, case: str) -> None:
    """Calls outside the FMI 2.0 co-simulation state machine are refused, naming the function
    (native) or the state, and the instance is unchanged (pythonfmu: getReal in Instantiated is
    reported per variable, ``get 'omega[1]' must not be called in state Instantiated``).
    """
    inst = make(file)
    text = _order_case(inst, case)
    if case == "getReal in Instantiated" and not inst.fmu.is_python:
        # native messages start with the FMI function's name
        assert text.startswith("fmi2GetReal")
    if case == "fixed parameter after init":
        # the refused value was not stored: u_max still has its start value 5 N.m
        assert inst.get(["u_max"]) == [5.0]
        inst.ok("doStep", 0.0, 0.1)
        return
    if case == "setReal after terminate":
        inst.ok("reset")
    # the refused call changed no state: the normal sequence still works from here
    inst.initialize()
    inst.ok("doStep", 0.0, 0.1)


@pytest.mark.parametrize("file", ALL)
def test_bad_setup_experiment_is_rejected(make, file: str) -> None:
    """fmi2SetupExperiment with a non-finite start time is refused."""
    inst = make(file)
    inst.rejected("setupExperiment", None, math.nan, contains=("fmi2SetupExperiment", "non-finite startTime"))
    # still in Instantiated: a correct set-up and initialization follow
    inst.initialize()
    inst.ok("doStep", 0.0, 0.1)


@pytest.mark.parametrize("file", ALL)
def test_errors_logged_whether_or_not_logging_is_on(make, file: str) -> None:
    """With loggingOn = false every FMU still logs its errors (only fmi2OK messages are filtered;
    the pythonfmu FMU's C layer applies the host's setting, pythonfmu logging everything to it)."""
    inst = make(file, logging_on=False)
    inst.initialize()
    text = inst.rejected("setReal", [inst.vr(inst.fmu.input)], [math.nan])
    assert f"'{inst.fmu.input}'" in text


# ----------------------------------------------------------------------------- 7. error state
@pytest.mark.parametrize("file", [PLANT, PLANT_PY])
def test_non_finite_state_enters_error_state_until_reset(make, file: str) -> None:
    """A step whose state overflows leaves the plant in the error state: doStep and setReal are
    refused, outputs can still be read (native), and fmi2SetFMUstate or fmi2Reset recover."""
    inst = make(file)
    inst.initialize(BLOW_UP)
    before = inst.ok("getFMUstate")
    inst.rejected("doStep", 0.0, 1e3, contains=("fmi2DoStep", "non-finite"))
    # the wrapper advanced its time to 1000 s before detecting the overflow; any doStep is refused
    inst.rejected("doStep", 1e3, 1.0, contains=("fmi2DoStep must not be called in state Error",))
    inst.rejected("setReal", [inst.vr("u[1]")], [0.0], contains=("'u[1]'", "state Error"))
    # reading is allowed in the error state for diagnosis: the values are delivered, the status is
    # fmi2Error (no non-finite output comes with fmi2OK); the state is what overflowed
    omega = (ctypes.c_double * 3)()
    vrs = (ctypes.c_uint * 3)(*[inst.vr(f"omega[{i}]") for i in (1, 2, 3)])
    status = fmi_host.call(inst.slave, "GetReal", vrs, 3, omega)
    if inst.fmu.is_python:
        # the Python slave keeps the state from before the failed step: finite outputs, fmi2OK
        assert status == 0 and all(math.isfinite(v) for v in omega), (status, list(omega))
    else:
        assert status == fmi2Error and not all(math.isfinite(v) for v in omega)
        assert "output 'omega[1]' is non-finite" in inst.text()
    # recovery 1: the snapshot taken before the step (omega = 1e3 rad/s, h_max = 1e6 s)
    inst.ok("setFMUstate", before)
    # a 1 ms step (4 RK4 substeps of 0.25 ms) stays finite from 1e3 rad/s
    inst.ok("doStep", 0.0, 1e-3)
    # back to normal computation: every output of that step is finite again
    assert all(math.isfinite(v) for v in inst.outputs())
    inst.ok("freeFMUstate", before)
    # from these rates a 1000 s step (4 substeps of 250 s) overflows again: back in the error state
    inst.rejected("doStep", 1e-3, 1e3, contains=("non-finite",))
    # FMI 2.0: an instance in the error state is reset or freed, not terminated
    inst.rejected("terminate", contains=("fmi2Terminate must not be called in state Error",))
    # recovery 2: reset goes back to Instantiated with the declared start values
    inst.ok("reset")
    inst.initialize()
    inst.ok("doStep", 0.0, 0.05)
    # defaults: omega_0 = sigma_0 = 0 and u = w_d = 0, an equilibrium: every output stays exactly 0
    assert inst.outputs() == [0.0] * 7


def test_an_overflowing_unused_term_is_no_error_in_either_backend(make) -> None:
    """In a single 1000 s substep the state stays finite (|sigma| ~ 1e163) although a term the
    model does not use when shadow switching is off overflows: both backends step on with the same
    outputs (squares are products in both, so Python overflows to inf as C does, where ``x**2``
    raised OverflowError)."""
    outputs = []
    for plant in (PLANT, PLANT_PY):
        inst = make(plant)
        inst.initialize({**BLOW_UP, "n_substeps": 1})
        inst.ok("doStep", 0.0, 1e3)
        outputs.append(inst.outputs())
    assert outputs[0] == outputs[1] and all(math.isfinite(v) for v in outputs[0])


# ----------------------------------------------------------------------------- 8. FMU state
def _drive(inst: Instance, t: float) -> None:
    """Inputs as a deterministic function of time, so two runs from one state are identical."""
    if inst.fmu.model == "mrp_satellite":
        inst.ok("setReal", [inst.vr(n) for n in ("u[1]", "u[2]", "u[3]")],
                [0.5 * math.sin(t), 0.3 * math.cos(2 * t), -0.2])
    else:
        inst.ok("setReal", [inst.vr(n) for n in ("omega[1]", "omega[2]", "sigma[3]")],
                [0.1 * math.sin(t), -0.05 * t, 0.3 * math.cos(t)])


def _run(inst: Instance, t: float, n: int, h: float = 0.05) -> tuple[float, list[list[float]]]:
    rows = []
    for _ in range(n):
        _drive(inst, t)
        inst.ok("doStep", t, h)
        t += h
        rows.append(inst.outputs())
    return t, rows


PLANT_INIT = {"omega_0[1]": 0.1, "omega_0[2]": -0.2, "omega_0[3]": 0.3,
              "sigma_0[1]": 0.2, "sigma_0[2]": 0.1, "sigma_0[3]": -0.3}


def _start(inst: Instance) -> tuple[float, Any]:
    """Initialize, take 10 steps, snapshot; returns (time, state)."""
    inst.initialize(PLANT_INIT if inst.fmu.model == "mrp_satellite" else None)
    t, _ = _run(inst, 0.0, 10)
    return t, inst.ok("getFMUstate")


@pytest.mark.parametrize("file", ALL)
def test_fmu_state_round_trip_is_exact(make, file: str) -> None:
    """get/set and serialize/deserialize FMU state: replaying from a snapshot gives the
    same outputs bit for bit (both backends declare canGetAndSetFMUstate and
    canSerializeFMUstate; pythonfmu serializes satfmu's state dict as JSON)."""
    inst = make(file)
    caps = inst.fmu.md.coSimulation
    if not (caps.canGetAndSetFMUstate and caps.canSerializeFMUstate):
        pytest.skip("FMU does not declare FMU state support")
    t10, state = _start(inst)
    t20, first = _run(inst, t10, 10)
    inst.ok("setFMUstate", state)
    # doStep checks currentCommunicationPoint against the FMU time: stepping from t10 works only
    # if the snapshot restored the time; the same arithmetic on the same data is deterministic
    t_again, again = _run(inst, t10, 10)
    assert again == first  # exact: identical state, inputs and operations
    assert t_again == t20  # same float additions from the same t10
    blob = inst.ok("serializeFMUstate", state)
    copy = inst.ok("deSerializeFMUstate", blob)
    # a round trip through bytes reproduces the same serialization (native: memcpy; pythonfmu: JSON
    # with repr floats, which round-trip exactly)
    assert inst.ok("serializeFMUstate", copy) == blob
    inst.ok("setFMUstate", copy)
    _, replay = _run(inst, t10, 10)
    assert replay == first  # exact, as above
    inst.ok("freeFMUstate", state)
    inst.ok("freeFMUstate", copy)


def _resealed(record: bytes) -> bytes:
    """``record`` with its CRC-32 recomputed (as satfmu_core.h computes it: the record with the CRC
    field 0): a damage the checksum cannot see, so the range checks behind it must."""
    magic, fmt, size, _, ident = HEADER.unpack_from(record)
    body = record[HEADER.size:]
    crc = zlib.crc32(HEADER.pack(magic, fmt, size, 0, ident) + body)
    return HEADER.pack(magic, fmt, size, crc, ident) + body


def _corrupt(kind: str, good: bytes, marker: float) -> tuple[bytes, str]:
    """A damaged copy of the native serialized state ``good`` and the expected log text."""
    if kind == "truncated":
        return good[:-1], "expected"
    if kind == "extended":
        return good + b"\0", "expected"
    if kind == "empty":
        return b"", "expected"
    if kind == "zeros":
        return bytes(len(good)), "not a state of this FMU"
    if kind == "random":
        # the magic number matches random bytes with probability 2**-32
        return random.Random(1).randbytes(len(good)), "not a state of this FMU"
    if kind == "half zeroed":
        return good[:len(good) // 2] + bytes(len(good) - len(good) // 2), "checksum"
    if kind == "another model":  # another identity, checksum valid: the state of another model
        magic, fmt, size, _, _ = HEADER.unpack_from(good)
        return _resealed(HEADER.pack(magic, fmt, size, 0, bytes(16)) + good[HEADER.size:]), "another model"
    if kind == "time":  # Data.time = NaN behind a valid checksum
        return _resealed(good[:TIME_AT] + struct.pack("<d", math.nan) + good[TIME_AT + 8:]), "corrupted state (time"
    if kind == "future":  # Data.time = 1e39 s (the bit flip), start 0 s, no stop: still a time
        # of this experiment, so the checksum (without resealing) is what refuses it
        return good[:TIME_AT] + struct.pack("<d", 1e39) + good[TIME_AT + 8:], "checksum"
    # kind == "parameter": the parameter set to ``marker`` becomes -1, below its minimum, resealed
    old = struct.pack("<d", marker)
    # the marker value occurs once, so exactly that parameter is damaged
    assert good.count(old) == 1
    return _resealed(good.replace(old, struct.pack("<d", -1.0))), "corrupted state (variable"


CORRUPTIONS = ["truncated", "extended", "empty", "zeros", "random", "half zeroed", "another model", "time",
               "future", "parameter"]


@pytest.mark.parametrize("kind", CORRUPTIONS)
@pytest.mark.parametrize("file", NATIVE)
def test_native_corrupted_serialized_state_is_rejected(make, file: str, kind: str) -> None:
    """fmi2DeSerializeFMUstate refuses a buffer of the wrong size, of another model or with damaged
    content (checksum; behind a valid checksum the time and parameter ranges), and the instance
    keeps working."""
    inst = make(file)
    marker, param = (15.125, "I_x") if inst.fmu.model == "mrp_satellite" else (4.875, "u_max")
    inst.initialize({param: marker})
    inst.ok("doStep", 0.0, 0.1)
    state = inst.ok("getFMUstate")
    good = inst.ok("serializeFMUstate", state)
    # layout check of satfmu_core.h's Saved header before damaging fields: the size is the buffer's
    # and the CRC is zlib's CRC-32 of the record with the CRC field 0
    magic, fmt, size, crc, ident = HEADER.unpack_from(good)
    assert (magic, fmt, size) == (STATE_MAGIC, STATE_FORMAT, len(good))
    assert crc == zlib.crc32(HEADER.pack(magic, fmt, size, 0, ident) + good[HEADER.size:])
    # the identity is the bytes of this FMU's GUID (satfmu.fmus.codegen.guid_bytes)
    assert ident.hex() == inst.fmu.md.guid.strip("{}").replace("-", "")
    assert struct.unpack_from("<d", good, TIME_AT)[0] == 0.1  # the FMU time after the step
    bad, what = _corrupt(kind, good, marker)
    inst.rejected("deSerializeFMUstate", bad, contains=("fmi2DeSerializeFMUstate", what))
    if kind == "parameter":
        # the message names the damaged variable
        assert f"'{param}'" in inst.text()
    # the good snapshot still restores and the FMU steps on from its time, 0.1 s
    inst.ok("setFMUstate", state)
    inst.ok("doStep", 0.1, 0.1)
    inst.ok("freeFMUstate", state)


def test_native_state_every_single_bit_flip_is_refused(make) -> None:
    """Every one of the 3,008 single-bit flips of the plant's serialized state is refused (the
    issue measured 22.5 % accepted): CRC-32 detects every error burst of up to 32 bits. ~0.1 s."""
    inst = make(PLANT)
    inst.initialize(PLANT_INIT)
    _run(inst, 0.0, 5)
    state = inst.ok("getFMUstate")
    good = inst.ok("serializeFMUstate", state)
    accepted = []
    for bit in range(8 * len(good)):
        bad = bytearray(good)
        bad[bit // 8] ^= 1 << (bit % 8)
        if fmi_host.attempt(inst.slave, "deSerializeFMUstate", bytes(bad))[0] != fmi2Error:
            accepted.append(bit)
        inst.log.clear()
    assert accepted == []
    inst.ok("setFMUstate", state)  # still usable: the good state restores
    inst.ok("freeFMUstate", state)


def test_native_state_of_another_fmu_of_the_same_layout_is_refused(make, fmu_dir: Path) -> None:
    """The two H-infinity controllers are one model structure with other gains: their states have
    one size, so only the model identity tells them apart (one magic number for every FMU let one
    FMU take the other's state)."""
    other = Fmu("mrp_hinf_satfmu.fmu", fmu_dir / "mrp_hinf_satfmu.fmu",
                read_model_description(str(fmu_dir / "mrp_hinf_satfmu.fmu")),
                extract(str(fmu_dir / "mrp_hinf_satfmu.fmu")), False)
    try:
        a, b = make(CTRL), Instance(other)
        for inst in (a, b):
            inst.initialize()
            inst.ok("doStep", 0.0, 0.1)
        foreign = b.ok("serializeFMUstate", b.ok("getFMUstate"))
        own = a.ok("serializeFMUstate", a.ok("getFMUstate"))
        assert len(foreign) == len(own)  # the same layout
        a.rejected("deSerializeFMUstate", foreign, contains=("not a state of this FMU", "another model"))
        a.ok("doStep", 0.1, 0.1)  # unchanged and usable
        b.free()
    finally:
        shutil.rmtree(other.unzip, ignore_errors=True)


@pytest.mark.parametrize("file", NATIVE)
def test_native_set_null_fmu_state_is_rejected(make, file: str) -> None:
    """fmi2SetFMUstate(NULL) is refused with an error, not dereferenced."""
    inst = make(file)
    inst.initialize()
    inst.rejected("setFMUstate", fmi2FMUstate(), contains=("fmi2SetFMUstate", "not a state of this FMU"))
    inst.ok("doStep", 0.0, 0.1)


@pytest.mark.parametrize("kind", ["truncated", "garbage"])
@pytest.mark.parametrize("file", PYTHON)
def test_pythonfmu_corrupted_serialized_state_is_rejected(make, file: str, kind: str) -> None:
    """The pythonfmu FMU decodes the buffer as UTF-8 JSON: a truncated or garbage buffer is refused
    with fmi2Error naming the decoder's exception, and the instance keeps working (its good state
    restores)."""
    inst = make(file)
    t, state = _start(inst)
    good = inst.ok("serializeFMUstate", state)
    if kind == "truncated":
        bad, error = good[:-5], "JSONDecodeError"
    else:
        bad, error = b"\xff" * len(good), "UnicodeDecodeError"
    inst.rejected("deSerializeFMUstate", bad, contains=("fmi2DeSerializeFMUstate", "not a state of this FMU", error))
    inst.ok("setFMUstate", state)
    inst.ok("doStep", t, 0.05)
    inst.ok("freeFMUstate", state)


# ----------------------------------------------------------------------------- 9. memory
def _rss_kib() -> int:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1])
    raise RuntimeError("no VmRSS in /proc/self/status")


def _heap_bytes() -> int | None:
    """Bytes in use on glibc's malloc heap (mallinfo2, glibc >= 2.33), or None."""
    try:
        libc = ctypes.CDLL("libc.so.6")
        fn = libc.mallinfo2
    except (OSError, AttributeError):
        return None

    class Mallinfo2(ctypes.Structure):
        _fields_ = [(n, ctypes.c_size_t) for n in
                    ("arena", "ordblks", "smblks", "hblks", "hblkhd", "usmblks", "fsmblks", "uordblks",
                     "fordblks", "keepcost")]

    fn.restype = Mallinfo2
    return fn().uordblks


def test_native_instantiate_free_cycles_do_not_leak(make) -> None:
    """1000 fmi2Instantiate/fmi2FreeInstance cycles of the native plant (each with an
    initialization, a step and an FMU state get/serialize/deserialize/free) in-process.
    Takes well under a second, so it is not marked slow."""
    inst = make(PLANT)
    slave = inst.slave

    def cycle() -> None:
        slave.fmi2FreeInstance(slave.component)
        inst.instantiate()
        inst.initialize()
        slave.doStep(0.0, 0.1)
        state = slave.getFMUstate()
        copy = slave.deSerializeFMUstate(slave.serializeFMUstate(state))
        slave.freeFMUstate(state)
        slave.freeFMUstate(copy)
        slave.terminate()

    for _ in range(50):  # warm-up: allocator pools, ctypes caches, fmpy's lazily built objects
        cycle()
    rss0, heap0 = _rss_kib(), _heap_bytes()
    for _ in range(1000):
        cycle()
    # the brief's bound: 5 MiB = 5 KiB per cycle; an instance is ~0.4 KiB, so RSS alone would not
    # see a one-instance-per-cycle leak (hence the heap check below)
    assert _rss_kib() - rss0 < 5 * 1024
    if heap0 is not None:
        # malloc'd bytes in use: leaking one FMU state (~290 B) or one instance (~370 B with its
        # name) per cycle would add >= 290 KB; 128 KiB leaves room for Python/ctypes allocations
        assert _heap_bytes() - heap0 < 128 * 1024
    # no error was logged in any cycle
    assert inst.log == []


# ----------------------------------------------------------------------------- 10. GUID
@pytest.mark.parametrize("file", ALL)
def test_wrong_guid(make, file: str) -> None:
    """Every FMU refuses a GUID that is not its own (fmi2Instantiate returns NULL and logs both
    GUIDs; the pythonfmu FMU's C layer checks it, pythonfmu 0.7.0 alone ignores it)."""
    wrong = "{00000000-0000-0000-0000-000000000000}"
    inst = make(file, guid=wrong, instantiate=False)
    # fmpy raises this when fmi2Instantiate returns NULL
    with pytest.raises(Exception, match="Failed to instantiate"):
        inst.instantiate()
    # one error naming both the GUID given and the FMU's own
    assert [m.status for m in inst.log] == [fmi2Error]
    assert "GUID" in inst.text() and wrong in inst.text() and inst.fmu.md.guid in inst.text()


# ----------------------------------------------------------------------------- pythonfmu after a refusal
def test_pythonfmu_free_after_refusal_does_not_crash(fmus: dict[str, Fmu]) -> None:
    """A host that frees a pythonfmu instance after a rejected call (satfmu.sims.cosim.master does, in its
    ``finally``) must not crash. pythonfmu 0.7.0 releases the instance's Python objects on the
    exception and again in fmi2FreeInstance; fmus/pyslave.py balances that for the calls it
    rejects (which the C layer reports as fmi2Error). 30 cycles in a child process (a segfault
    must not take pytest down): before the balance the child died with SIGSEGV within ~5 cycles."""
    fmu = fmus[PLANT_PY]
    code = textwrap.dedent(f"""
        import gc, math
        from fmpy.fmi1 import FMICallException
        from fmpy.fmi2 import FMU2Slave
        for k in range(30):
            s = FMU2Slave(guid={fmu.md.guid!r}, unzipDirectory={str(fmu.unzip)!r},
                          modelIdentifier={fmu.md.coSimulation.modelIdentifier!r}, instanceName="x")
            s.instantiate()
            s.setupExperiment(startTime=0.0)
            s.enterInitializationMode()
            try:
                s.setReal([0], [-1.0])  # I_x below its minimum
            except FMICallException as e:
                assert e.status == 3, e.status  # fmi2Error
            else:
                raise SystemExit("not rejected")
            s.fmi2FreeInstance(s.component)
            gc.collect()
        print("survived")
    """)
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    # exit code 0 and the last line printed: all 30 refusal + free cycles ran (SIGSEGV gives -11)
    assert proc.returncode == 0 and "survived" in proc.stdout, (proc.returncode, proc.stderr[-2000:])


# ----------------------------------------------------------------------------- 11. limits (issue 26)
BDOT, RAMP, SINE = "cubesat_bdot.fmu", "signal_cosine_ramp.fmu", "signal_sinusoid.fmu"
DBL_MAX = sys.float_info.max


@pytest.fixture
def native(built):
    """Factory of native :class:`Instance` objects of any FMU of the build (:func:`built`)."""
    return built


@pytest.mark.parametrize("file", [PLANT, CTRL, BDOT, SINE])
def test_native_huge_steps_finish_or_are_refused_at_once(native, file: str) -> None:
    """h = 1e9, 1e12, 1e30 and DBL_MAX s: each step returns within 0.5 s (B-dot took 30 s at 1e9 and
    never returned at 1e30), with finite outputs or refused with the bound it would pass."""
    for h in (1e9, 1e12, 1e30, DBL_MAX):
        inst = native(file)
        inst.initialize()
        started = time.process_time()  # CPU time: other processes on the machine do not count
        status, text = inst.attempt("doStep", 0.0, h)
        # the bounds (1e6 instants, 1e6 substeps) cost ~0.7 s at most, these steps < 0.1 s
        assert time.process_time() - started < 0.5
        if status == fmi2Error:
            assert any(w in text for w in ("sample instants", "integration substeps", "time resolution")), text
            inst.ok("doStep", 0.0, 1.0)  # refused before any change: the FMU steps on from 0 s
        else:
            assert status == 0 and all(math.isfinite(v) for v in inst.outputs())


def test_native_bdot_step_at_minimum_period_is_bounded(native) -> None:
    """control_period at its declared minimum (1 ms): a 100 s step spans 1e5 instants and finishes
    (the issue: > 10 s at 1e-6 s); 2000 s spans 2e6 > 1e6 and is refused naming the count."""
    inst = native(BDOT)
    assert float(inst.vars["control_period"].min) == 1e-3  # satfmu.fmus.instants.MIN_SAMPLE_PERIOD
    inst.initialize({"control_period": 1e-3})
    started = time.process_time()
    inst.ok("doStep", 0.0, 100.0)
    # 1e5 instants at ~12 ns each (measured): ~1 ms of CPU; 0.1 s allows the clock's granularity
    assert time.process_time() - started < 0.1
    inst.rejected("doStep", 100.0, 2000.0, contains=("spans 2000000 sample instants", "limit 1000000"))


@pytest.mark.parametrize("period", [1.0, 0.1])
def test_native_bdot_from_unix_time_repeats_the_run_from_zero(native, period: float) -> None:
    """B-dot from t0 = 1.4e9 s (GPS/Unix seconds) against the same run from 0: the sample instants
    are counted (t0 + k period), so the outputs are equal (the issue: 100 % different at 1e9)."""
    runs = {}
    for t0 in (0.0, 1.4e9):
        inst = native(BDOT)
        inst.ok("setupExperiment", None, t0)
        inst.ok("enterInitializationMode")
        inst.set_value("control_period", period)
        inst.ok("exitInitializationMode")
        rows = []
        for k in range(20):
            b = [2e-5 * math.cos(0.3 * k), 2e-5 * math.sin(0.3 * k), 1e-5]
            inst.ok("setReal", [inst.vr(f"b_body[{i}]") for i in (1, 2, 3)], b)
            # the dipole of the instant t0 + k s from this field (a master's feedthrough read)
            rows.append(inst.outputs())
            inst.ok("doStep", t0 + k * 1.0, 1.0)
        runs[t0] = rows
    # the law reads no time: the same instants give the same dipoles; rel 1e-12 only allows for the
    # rounding of instants t0 + k 0.1 (7 of 10 are inexact at 1.4e9), which do not enter the law
    flat = {t0: [v for row in rows for v in row] for t0, rows in runs.items()}
    assert flat[1.4e9] == pytest.approx(flat[0.0], rel=1e-12, abs=0.0)
    assert max(map(abs, flat[0.0])) > 0  # the dipole really varies


@pytest.mark.parametrize("file", [PLANT, BDOT])
def test_native_communication_point_off_at_unix_time_is_refused(native, file: str) -> None:
    """At t = 1e9 s a currentCommunicationPoint 1 ms .. 1 s off the FMU time is refused (the issue:
    up to 1 s accepted and the time jumped); one 8 ulp off (what t0 + k h rounding gives) is not."""
    inst = native(file)
    inst.ok("setupExperiment", None, 1e9)
    inst.ok("enterInitializationMode")
    inst.ok("exitInitializationMode")
    h = float(inst.fmu.md.defaultExperiment.stepSize)
    inst.ok("doStep", 1e9, h)
    for delta in (1e-3, 1e-2, 0.1, 1.0):
        inst.rejected("doStep", 1e9 + h + delta, h, contains=("differs from the FMU time",))
    # 8 ulp of 1e9 s = 1.9e-6 s: a master's t0 + (k + 1) h may differ from the FMU's t0 + k h + h
    inst.ok("doStep", 1e9 + h + 4 * math.ulp(1e9), h)


STATUS_KINDS = range(4)  # fmi2DoStepStatus, fmi2PendingStatus, fmi2LastSuccessfulTime, fmi2Terminated
STATUS_FUNCTIONS = {"GetStatus": ctypes.c_int, "GetRealStatus": ctypes.c_double, "GetIntegerStatus": ctypes.c_int,
                    "GetBooleanStatus": ctypes.c_int, "GetStringStatus": ctypes.c_char_p}


def _statuses(inst: Instance) -> dict[tuple[str, int], tuple[int, Any]]:
    out = {}
    for fn, ctype in STATUS_FUNCTIONS.items():
        for kind in STATUS_KINDS:
            value = ctype()
            out[(fn, kind)] = (fmi_host.call(inst.slave, fn, kind, ctypes.byref(value)), value.value)
    return out


@pytest.mark.parametrize("file", NATIVE)
def test_native_status_queries_follow_fmi2(make, file: str) -> None:
    """FMI 2.0: the status functions are for stepComplete and terminated: fmi2Error in Instantiated,
    InitializationMode and Error (the issue: fmi2OK); there fmi2LastSuccessfulTime is the FMU
    time, fmi2Terminated false, and every other status fmi2Discard (not Error: "cannot be
    retrieved"). fmi2Terminate in the error state is refused."""
    inst = make(file)
    assert {s for s, _ in _statuses(inst).values()} == {fmi2Error}  # Instantiated
    inst.initialize(exit_init=False)
    assert {s for s, _ in _statuses(inst).values()} == {fmi2Error}  # InitializationMode
    inst.ok("exitInitializationMode")
    inst.ok("doStep", 0.0, 0.25)
    for label in ("StepComplete", "Terminated"):
        got = _statuses(inst)
        # fmi2OK only for the two provided statuses, with the time of the last step (0.25 s) and false
        assert got.pop(("GetRealStatus", 2)) == (0, 0.25)
        assert got.pop(("GetBooleanStatus", 3)) == (0, 0)
        assert {s for s, _ in got.values()} == {2}, label  # fmi2Discard
        if label == "StepComplete":
            inst.ok("terminate")
    assert "not provided" in inst.text()
    if inst.fmu.model != "mrp_satellite":  # the published controller's outputs stay finite for any input
        return
    inst.ok("reset")
    inst.initialize(BLOW_UP)
    inst.rejected("doStep", 0.0, 1e3, contains=("non-finite",))
    assert {s for s, _ in _statuses(inst).values()} == {fmi2Error}  # Error
    inst.rejected("terminate", contains=("must not be called in state Error",))


@pytest.mark.parametrize("derivative", [0, 1, 2])
def test_native_cosine_ramp_of_no_duration_is_a_step(native, derivative: int) -> None:
    """signal_cosine_ramp with start = stop (the issue: NaN with fmi2OK) is a step at start; its
    derivatives are 0 (the impulse has no finite value). A ramp so short that its second derivative
    overflows is refused with fmi2Error, never returned as inf with fmi2OK."""
    inst = native(RAMP)
    inst.initialize({"start": 0.5, "stop": 0.5, "before": 1.0, "after": 3.0, "derivative": derivative})
    values = []
    for k in range(4):
        values += inst.outputs()
        inst.ok("doStep", 0.25 * k, 0.25)
    # t = 0, 0.25 (before), 0.5 (the step), 0.75: exactly the step's values, or 0
    assert values == ([1.0, 1.0, 3.0, 3.0] if derivative == 0 else [0.0] * 4)
    if derivative == 2:
        short = native(RAMP)  # 1e-160 s: (after - before) (pi / 1e-160)^2 / 2 overflows
        short.initialize({"start": 0.0, "stop": 1e-160, "derivative": 2})
        short.rejected("getReal", [short.vr("y")], contains=("output 'y' is non-finite",))


def test_native_sinusoid_at_the_largest_time_is_finite(native) -> None:
    """signal_sinusoid at t = DBL_MAX (the issue: NaN with fmi2OK): the argument is reduced to one
    period where 2 pi f t would overflow; at 1 Hz f t = DBL_MAX is a whole number of periods, so
    y = offset + amplitude sin(phase) exactly."""
    inst = native(SINE)
    inst.ok("setupExperiment", None, DBL_MAX)
    inst.ok("enterInitializationMode")
    inst.set_value("phase_rad", 0.5)
    inst.ok("exitInitializationMode")
    assert inst.outputs() == [math.sin(0.5)]
    # no later finite time: a step from DBL_MAX is refused, the FMU stays at its time
    inst.rejected("doStep", DBL_MAX, 1.0, contains=("does not reach a finite later time",))


# ----------------------------------------------------------------------------- 9. singular controller outputs
BACKSTEPPING, BACKSTEPPING_PY = "vscmg_backstepping.fmu", "vscmg_backstepping_py.fmu"


@pytest.fixture
def built(fmu_dir: Path):
    """Factory of :class:`Instance` objects of any FMU of the build (native or pythonfmu, by its
    file name), extracted per test."""
    made: list[tuple[Instance, str]] = []

    def _make(file: str) -> Instance:
        path = fmu_dir / file
        fmu = Fmu(file, path, read_model_description(str(path)), extract(str(path)), path.stem.endswith("_py"))
        inst = Instance(fmu)
        made.append((inst, fmu.unzip))
        return inst

    yield _make
    for inst, unzip in made:
        inst.free()
        shutil.rmtree(unzip, ignore_errors=True)


@pytest.mark.parametrize("file", [BACKSTEPPING, BACKSTEPPING_PY])
def test_backstepping_output_at_q2_zero_is_refused_naming_it(built, file: str) -> None:
    """At gimbal angle q2 = 0 the backstepping law divides by sin q2 (issue 28, defect 2: T1 came
    back as -inf). fmi2GetReal of T1 is refused with a message naming 'T1', on both backends, and
    never returns a non-finite value with fmi2OK; the FMU is in the error state and fmi2Reset
    recovers it (pythonfmu: the native message, Python's ZeroDivisionError evaluated in C's IEEE
    arithmetic to find the non-finite output).
    """
    inst = built(file)
    inst.initialize()
    t1 = inst.vr("T1")
    # the start values (q2 = pi/18) are away from the singularity: finite torques
    assert all(math.isfinite(v) for v in inst.get(["T1", "T2"])), "T1, T2 at the seed's start must be finite"
    # q2 = 0 with a gimbal-4 rate error: sin q2 = 0 divides a non-zero torque demand
    inst.ok("setReal", [inst.vr("q2"), inst.vr("w4"), inst.vr("q4_ref_dot")], [0.0, 0.2, 0.5])
    text = inst.rejected("getReal", [t1], contains=("fmi2GetReal: output 'T1' is non-finite", "at t = 0 s"))
    assert "ZeroDivisionError" not in text, f"the refusal must name the output, not Python's exception: {text!r}"
    # the error state; every further read of an output is refused the same way
    inst.rejected("getReal", [inst.vr("T2")], contains=("output 'T1' is non-finite",))
    inst.rejected("doStep", 0.0, 0.01, contains=("fmi2DoStep must not be called in state Error",))
    inst.ok("reset")
    inst.initialize()
    # after the reset the inputs are back at their start values: finite torques, and a step works
    assert all(math.isfinite(v) for v in inst.get(["T1", "T2"])), "fmi2Reset must give a usable FMU again"
    inst.ok("doStep", 0.0, 0.01)
    assert all(math.isfinite(v) for v in inst.outputs()), "the step after the reset must give finite outputs"
