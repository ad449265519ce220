"""Robustness suite over every built FMU: misuse cases x FMUs, each FMU in a child process.

Every ``*.fmu`` of a folder is driven through fmpy's low-level FMI 2.0 API
(``fmpy.fmi2.FMU2Slave``, raw ``fmi2*`` calls so the exact status is seen) with
non-finite and huge values, bad step sizes, calls outside the co-simulation state
machine, out-of-range and wrong-type sets, unknown value references, an FMU state
round trip and many instantiate/free cycles (:data:`CASES`). The variables a case
abuses are chosen from ``modelDescription.xml`` (:func:`describe`); a case whose
variable does not exist (no input, no ranged parameter, ...) is "n/a".

The cases of one FMU run in a child process (``python -m sims.robustness --worker``),
which reports each case as it starts and ends. If the child dies (segfault, abort)
the case it was running is recorded as CRASH and the remaining cases continue in a
new child; a case that does not finish within its time limit is killed and FAILs.

Expected behaviour per backend (measured; see ``tests/test_fmu_robustness.py`` for the
detailed checks of four FMUs):

* native FMUs (``fmus/c/fmi2_cosim.c``) reject a bad call with fmi2Error and a message
  naming the function or variable (logged whether or not logging is on), store
  nothing, and stay usable: the suite checks that the abused value is unchanged and
  that the normal sequence up to a completed ``fmi2DoStep`` still works (after
  ``fmi2Reset`` when the instance is Terminated or in the error state);
* pythonfmu FMUs (``fmus/pyslave.py`` in pythonfmu 0.7.0) return **fmi2Fatal** for every
  rejected call (pythonfmu turns any Python exception into fmi2Fatal), log only with
  logging on (so the suite instantiates them with ``loggingOn``), and report unknown
  value references and wrong types with pythonfmu's own exception text. FMI 2.0
  allows no call after fmi2Fatal, so such an instance is abandoned, never freed.

Measured differences between the backends (``docs/robustness.md``):

* a huge finite value (1e300) is accepted by both (no declared maximum excludes it); where
  the native model code overflows to inf (and the state check reports it, or an output is
  +-inf/NaN with fmi2OK), Python may raise OverflowError instead, which pythonfmu reports as
  fmi2Fatal naming the exception (``cubesat_bdot_py``, ``mrp_hinf_satfmu_py``);
* the FMU state round trip repeats the outputs bit for bit on both backends (pythonfmu
  serializes the state as JSON with repr floats, which round-trip exactly).

Memory: pythonfmu 0.7.0's ``fmi2Instantiate`` leaks on every call: its ``findClass``
(``src/pythonfmu/PySlaveInstance.cpp``) re-executes the slave script, which creates a new
class object, and never releases the ``PySequence_List`` of that class's ``__mro__`` (so
the class is never freed) nor the ``repr`` strings it builds; it also inserts the resources
folder into ``sys.path`` once more. Measured 2.6 to 4.3 KiB per instantiate/free cycle
(1000 cycles), hence the pythonfmu bound of :func:`rss_bound_kib`. The slave objects
themselves are freed (checked exactly, :func:`live_slaves`). Native FMUs: 0 KiB.
"""
from __future__ import annotations

import argparse
import csv
import gc
import io
import json
import math
import os
import shutil
import signal
import struct
import subprocess
import sys
import tempfile
import time
import zipfile
from collections.abc import Callable, Iterator, Sequence
from dataclasses import asdict, dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from fmpy import calloc, extract, free, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import (
    FMU2Slave,
    fmi2Boolean,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
    fmi2Integer,
    fmi2Real,
    fmi2ValueReference,
)

NATIVE, PYTHONFMU = "native", "pythonfmu"
BACKENDS = (NATIVE, PYTHONFMU)
PYTHONFMU_MARKER = "resources/slavemodule.txt"
"""File every pythonfmu FMU carries (read by pythonfmu's fmi2Instantiate): tells the backends apart."""

OK, WARNING, DISCARD, ERROR, FATAL = 0, 1, 2, 3, 4
NO_RESULT = -1
"""Outcome status of a case that failed before or without the call under test."""
STATUS_NAMES = {OK: "OK", WARNING: "Warning", DISCARD: "Discard", ERROR: "Error", FATAL: "Fatal", 5: "Pending",
                NO_RESULT: "-"}
REJECTED = {NATIVE: ERROR, PYTHONFMU: FATAL}
"""Status of a rejected call per backend (pythonfmu 0.7.0 returns fmi2Fatal for any exception)."""

HUGE = 1e300
"""A finite but huge value (no declared range of the project's inputs excludes it)."""
FAR_FACTOR = 1e4
"""The far step is this many default step sizes (slowest: the online SDRE pythonfmu controllers,
one Riccati solution per 0.01 s sample, ~5 s for this step)."""
UNKNOWN_VR = 1_000_000
"""A value reference no FMU of the project has (they number their variables from 0)."""
WARMUP_CYCLES = 20
"""Instantiate/free cycles before the RSS baseline (allocator pools, ctypes and fmpy caches)."""
STEPS = 5
"""Communication steps before a snapshot and after it, in the FMU state round trip."""
DRIVE = 1e-3
"""Amplitude of the inputs' variation around their start values in the state round trip (in
each input's unit): small, since some controllers are singular away from their start (the VSCMG
controllers at gimbal angle q2 = 0) and some plants overflow for large inputs (the magnetorquer
CubeSat with 0.01 to 0.09 in every input)."""

CASE_TIMEOUT_S = 120.0
"""Time limit of one case in s (the cases other than the far step and the cycles take < 2 s)."""
CYCLE_TIMEOUT_S = 0.5
"""Extra time limit per instantiate/free cycle in s (slowest measured: 47 ms, demeter_flexible_py)."""
FAR_TIMEOUT_S = 0.05
"""Extra time limit of the far step per default step size in s (slowest measured: 0.5 ms, the
online SDRE pythonfmu controllers; 8 ms before their inputs started at the plant's initial state)."""
ABORT_ENV = "SATFMU_ROBUSTNESS_ABORT"
"""Test hook: a worker calls ``os.abort()`` when it starts the case named in this variable."""

CYCLES_CASE = "instantiate/free cycles"
FAR_CASE = "doStep far beyond default"

# RSS bounds of the instantiate/free case, in KiB: SLACK + PER_CYCLE * cycles.
RSS_SLACK_KIB = 512
"""Allocator granularity: glibc's malloc grows and trims its heap in 128 KiB steps and
pymalloc takes 1 MiB arenas page by page, so even a leak-free loop can move RSS by a few
hundred KiB."""
RSS_PER_CYCLE_KIB = {NATIVE: 1.5, PYTHONFMU: 8.0}
"""Allowed growth per cycle in KiB. native: 512 + 1.5 * 1000 < 2 MiB for 1000 cycles (the
issue's bound; measured: 0 KiB); leaking one native instance per cycle (~0.4 KiB) would stay
within it (``tests/test_fmu_robustness.py`` checks the malloc heap for that).
pythonfmu: pythonfmu 0.7.0 leaks per fmi2Instantiate (see the module docstring), measured
2.6 to 4.3 KiB per cycle over 1000 cycles; 8 KiB is about twice that. Leaking the slave object
itself is caught exactly, by counting live slaves (:func:`live_slaves`)."""


# ----------------------------------------------------------------------------- model description
@dataclass(frozen=True)
class Var:
    """One scalar variable of ``modelDescription.xml``.

    Attributes
    ----------
    name, type, causality, variability : str
    vr : int
        Value reference.
    start : float or None
        Declared start value (in the variable's unit).
    min, max : float or None
        Declared range (in the variable's unit), None when not declared.
    """

    name: str
    vr: int
    type: str
    causality: str
    variability: str
    start: float | None
    min: float | None
    max: float | None


@dataclass(frozen=True)
class Target:
    """An FMU under test and the variables the cases use (None: no such variable, case n/a).

    Attributes
    ----------
    path : Path
    name : str
        File name without ``.fmu``.
    backend : str
        :data:`NATIVE` or :data:`PYTHONFMU`.
    guid, model_identifier : str
    step : float
        Default communication step size in s (``DefaultExperiment stepSize``; 0.01 s if absent).
    can_state, can_serialize : bool
        Declared ``canGetAndSetFMUstate`` and ``canSerializeFMUstate``.
    inputs, outputs : tuple of Var
        The Real inputs and outputs.
    parameter : Var or None
        The first Real parameter.
    fixed : Var or None
        The first parameter that is not tunable.
    below, above : Var or None
        The first parameter with a finite declared minimum (maximum).
    non_real : Var or None
        The first Integer or Boolean parameter.
    """

    path: Path
    name: str
    backend: str
    guid: str
    model_identifier: str
    step: float
    can_state: bool
    can_serialize: bool
    inputs: tuple[Var, ...]
    outputs: tuple[Var, ...]
    parameter: Var | None
    fixed: Var | None
    below: Var | None
    above: Var | None
    non_real: Var | None

    @property
    def input(self) -> Var | None:
        """The Real input the input cases abuse (the first one)."""
        return self.inputs[0] if self.inputs else None


def _number(text: str | None) -> float | None:
    return None if text is None else float(text)


def _var(v: Any) -> Var:
    return Var(v.name, int(v.valueReference), v.type, v.causality, v.variability or "",
               _number(v.start) if v.type in ("Real", "Integer") else None, _number(v.min), _number(v.max))


def _first(variables: Sequence[Var], pred: Callable[[Var], bool]) -> Var | None:
    return next((v for v in variables if pred(v)), None)


def backend_of(path: Path) -> str:
    """:data:`PYTHONFMU` if the FMU carries pythonfmu's slave module file, else :data:`NATIVE`."""
    with zipfile.ZipFile(path) as z:
        return PYTHONFMU if PYTHONFMU_MARKER in z.namelist() else NATIVE


def describe(path: Path) -> Target:
    """Read ``path``'s model description and choose the variables of the cases."""
    md = read_model_description(str(path))
    variables = [_var(v) for v in md.modelVariables]
    params = [v for v in variables if v.causality == "parameter"]
    real_params = [v for v in params if v.type == "Real"]
    exp = md.defaultExperiment
    step = float(exp.stepSize) if exp is not None and exp.stepSize is not None else 0.01
    cs = md.coSimulation
    return Target(
        path=path, name=path.stem, backend=backend_of(path), guid=md.guid, model_identifier=cs.modelIdentifier,
        step=step, can_state=bool(cs.canGetAndSetFMUstate), can_serialize=bool(cs.canSerializeFMUstate),
        inputs=tuple(v for v in variables if v.causality == "input" and v.type == "Real"),
        outputs=tuple(v for v in variables if v.causality == "output" and v.type == "Real"),
        parameter=real_params[0] if real_params else None,
        fixed=_first(params, lambda v: v.variability != "tunable"),
        below=_first(params, lambda v: v.type in ("Real", "Integer") and v.min is not None and math.isfinite(v.min)),
        above=_first(params, lambda v: v.type in ("Real", "Integer") and v.max is not None and math.isfinite(v.max)),
        non_real=_first(params, lambda v: v.type in ("Integer", "Boolean")))


def discover(fmu_dir: Path, names: Sequence[str] | None = None) -> list[Path]:
    """The FMUs to test: every ``*.fmu`` in ``fmu_dir``, or those named (with or without ``.fmu``)."""
    if names is None:
        return sorted(fmu_dir.glob("*.fmu"))
    paths = [fmu_dir / (n if n.endswith(".fmu") else n + ".fmu") for n in names]
    missing = [str(p) for p in paths if not p.is_file()]
    if missing:
        raise FileNotFoundError(f"no such FMU: {', '.join(missing)}")
    return paths


# ----------------------------------------------------------------------------- FMU instances (worker)
class CaseBroken(Exception):
    """A call the case needed (not the one under test) failed: the case FAILs with this message."""


_ABANDONED: list[Any] = []
"""Instances that returned fmi2Fatal: kept alive with their callbacks and never called again."""


class Instance:
    """One FMU instance with a logger that records ``(status, message)`` and a tracked FMI state.

    Parameters
    ----------
    target : Target
    unzip : str
        The FMU's extracted folder.
    """

    def __init__(self, target: Target, unzip: str) -> None:
        self.target = target
        self.log: list[tuple[int, str]] = []
        self.dead = False  # returned fmi2Fatal: no further call
        self.mode = "Instantiated"  # FMI state after the successful calls made so far
        self.time = 0.0  # FMU time in s after those calls

        def logger(env: Any, name: bytes, status: int, category: bytes, message: bytes) -> None:
            self.log.append((status, (message or b"").decode(errors="replace")))

        self._logger = logger
        self.callbacks = fmi2CallbackFunctions()
        self.callbacks.logger = fmi2CallbackLoggerTYPE(logger)
        self.callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        self.callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        self.slave = FMU2Slave(guid=target.guid, unzipDirectory=unzip, modelIdentifier=target.model_identifier,
                               instanceName="robustness")
        self.instantiate()

    def instantiate(self) -> None:
        """fmi2Instantiate (pythonfmu logs only with logging on, so it is on for pythonfmu)."""
        self.slave.instantiate(callbacks=self.callbacks, loggingOn=self.target.backend == PYTHONFMU)
        self.mode, self.time = "Instantiated", 0.0

    def free(self) -> None:
        """fmi2FreeInstance, unless the instance returned fmi2Fatal (then it is abandoned)."""
        if self.dead:
            _ABANDONED.append(self)
        else:
            self.slave.fmi2FreeInstance(self.slave.component)

    def text(self, since: int = 0) -> str:
        """The log messages from index ``since`` on, one per line."""
        return "\n".join(m for _, m in self.log[since:])

    def call(self, fn: str, *args: Any) -> int:
        """Call ``fmi2<fn>(component, *args)``; returns its status (fmi2Fatal marks the instance dead)."""
        try:
            status = getattr(self.slave, "fmi2" + fn)(self.slave.component, *args)
        except FMICallException as exc:
            status = exc.status
        if status == FATAL:
            self.dead = True
        return status

    def need(self, fn: str, *args: Any) -> None:
        """:meth:`call` that must return fmi2OK, else :class:`CaseBroken`."""
        status = self.call(fn, *args)
        if status != OK:
            raise CaseBroken(f"fmi2{fn} returned {STATUS_NAMES.get(status, status)}: {self.text()[-300:]!r}")

    def set(self, var: Var, value: float, as_type: str | None = None) -> int:
        """Set ``var`` to ``value`` with the setter of ``as_type`` (default: its own type); returns the status."""
        kind = as_type or var.type
        ctype, cast = {"Real": (fmi2Real, float), "Integer": (fmi2Integer, int), "Boolean": (fmi2Boolean, bool)}[kind]
        return self.call("Set" + kind, (fmi2ValueReference * 1)(var.vr), 1, (ctype * 1)(cast(value)))

    def get(self, var: Var) -> tuple[int, float]:
        """Read ``var`` with the getter of its type; returns (status, value as float)."""
        ctype = {"Real": fmi2Real, "Integer": fmi2Integer, "Boolean": fmi2Boolean}[var.type]
        out = (ctype * 1)()
        status = self.call("Get" + var.type, (fmi2ValueReference * 1)(var.vr), 1, out)
        return status, float(out[0])

    def value(self, var: Var) -> float:
        """:meth:`get` that must succeed."""
        status, value = self.get(var)
        if status != OK:
            raise CaseBroken(f"get '{var.name}' returned {STATUS_NAMES.get(status, status)}")
        return value

    def outputs(self) -> list[float]:
        """Every Real output (they must be readable)."""
        return [self.value(v) for v in self.target.outputs]

    def enter(self) -> None:
        """fmi2SetupExperiment at t = 0 s and fmi2EnterInitializationMode."""
        self.need("SetupExperiment", 0, 0.0, 0.0, 0, 0.0)
        self.need("EnterInitializationMode")
        self.mode = "InitializationMode"

    def exit(self) -> None:
        """fmi2ExitInitializationMode."""
        self.need("ExitInitializationMode")
        self.mode = "StepComplete"

    def initialize(self) -> None:
        """From Instantiated to StepComplete with the default values."""
        self.enter()
        self.exit()

    def step(self, h: float | None = None) -> int:
        """fmi2DoStep of ``h`` s (default: the default step size) from the tracked FMU time."""
        h = self.target.step if h is None else h
        status = self.call("DoStep", self.time, h, 1)
        if status == OK:
            self.time += h
        return status

    def terminate(self) -> None:
        """fmi2Terminate."""
        self.need("Terminate")
        self.mode = "Terminated"

    def carry_on(self) -> None:
        """After a rejected call: the normal sequence from the tracked state (fmi2Reset first when
        Terminated or in the error state) up to a completed step with finite outputs, or :class:`CaseBroken`."""
        if self.mode in ("Terminated", "Error"):
            self.need("Reset")
            self.mode, self.time = "Instantiated", 0.0
        if self.mode == "Instantiated":
            self.enter()
        if self.mode == "InitializationMode":
            self.exit()
        status = self.step()
        if status != OK:
            raise CaseBroken(f"not usable afterwards: a normal fmi2DoStep returned {STATUS_NAMES.get(status)}: "
                             f"{self.text()[-300:]!r}")
        bad = [v.name for v, y in zip(self.target.outputs, self.outputs()) if not math.isfinite(y)]
        if bad:
            raise CaseBroken(f"not usable afterwards: non-finite outputs {bad} after a normal step")


@dataclass
class Outcome:
    """What a case observed (in the worker), judged by the parent against the case's expectation.

    Attributes
    ----------
    status : int
        Status of the call under test (for a case of several calls: the first one that was not OK).
    log : str
        Log text of the call under test.
    detail : str
        Measured facts (what happened, values).
    problems : list of str
        Violations found by the case itself (value changed, not usable afterwards, ...).
    metrics : dict of str to float
        Measured quantities, e.g. ``rss_growth_kib``.
    """

    status: int = OK
    log: str = ""
    detail: str = ""
    problems: list[str] = field(default_factory=list)
    metrics: dict[str, float] = field(default_factory=dict)


def _bits(values: Sequence[float]) -> bytes:
    """The IEEE 754 bit patterns of ``values`` (NaN and -0.0 compare exactly)."""
    return struct.pack(f"<{len(values)}d", *values)


def _recover(inst: Instance, out: Outcome) -> None:
    """After a native fmi2Error: the instance must carry on normally (else a problem of ``out``)."""
    try:
        inst.carry_on()
    except CaseBroken as exc:
        out.problems.append(str(exc))


def _reject(inst: Instance, fn: Callable[[], int], probe: Var | None = None) -> Outcome:
    """Make the call under test ``fn`` on ``inst``; if it was rejected by a native FMU, check that
    ``probe`` (if given) kept its value and that the instance carries on normally."""
    before = inst.value(probe) if probe is not None else None
    n = len(inst.log)
    status = fn()
    out = Outcome(status=status, log=inst.text(n))
    if inst.target.backend == NATIVE and status == ERROR:
        if probe is not None:
            after = inst.value(probe)
            if _bits([after]) != _bits([before]):
                out.problems.append(f"'{probe.name}' changed from {before!r} to {after!r}")
        _recover(inst, out)
    return out


def _chosen(var: Var | None) -> Var:
    if var is None:  # the parent does not run a case whose variable is missing
        raise CaseBroken("no variable for this case")
    return var


# ----------------------------------------------------------------------------- cases (worker side)
def _set_input(value: float) -> Callable[[Instance], Outcome]:
    def case(inst: Instance) -> Outcome:
        var = _chosen(inst.target.input)
        inst.initialize()
        return _reject(inst, lambda: inst.set(var, value), var)
    return case


def _set_parameter(value: float) -> Callable[[Instance], Outcome]:
    def case(inst: Instance) -> Outcome:
        var = _chosen(inst.target.parameter)
        inst.enter()
        return _reject(inst, lambda: inst.set(var, value), var)
    return case


def _huge(inst: Instance, var: Var, init_mode: bool) -> Outcome:
    """Set ``var`` to :data:`HUGE` (in initialization or step mode), step, read the outputs
    (which may overflow: recorded, not a failure)."""
    if init_mode:
        inst.enter()
    else:
        inst.initialize()
    n = len(inst.log)
    status = inst.set(var, HUGE)
    if status != OK:
        out = Outcome(status=status, log=inst.text(n), detail=f"set rejected: {_short(inst.text(n), 200)}")
        if inst.target.backend == NATIVE and status == ERROR:
            _recover(inst, out)
        return out
    if init_mode:
        inst.exit()
    return _step_and_read(inst, inst.target.step, f"'{var.name}' = {HUGE:g} accepted", finite=False)


def _read_outputs(inst: Instance) -> tuple[int, list[float]]:
    """Every Real output; stops at the first read that is not fmi2OK (returns its status)."""
    values = []
    for var in inst.target.outputs:
        status, value = inst.get(var)
        if status != OK:
            return status, values
        values.append(value)
    return OK, values


def _step_and_read(inst: Instance, h: float, what: str, finite: bool) -> Outcome:
    """One step of ``h`` s, then the outputs are read; the first call that is not fmi2OK is the
    outcome. Non-finite outputs are a problem if ``finite``. Native: usable after an error."""
    n = len(inst.log)
    started = time.perf_counter()
    status = inst.step(h)
    took = time.perf_counter() - started
    out = Outcome(status=status, metrics={"step_s": took})
    done = f"{what}; step of {h:g} s {STATUS_NAMES.get(status)} in {took:.2f} s"
    if status == OK:
        status, ys = _read_outputs(inst)
        out.status = status
        bad = [v.name for v, y in zip(inst.target.outputs, ys) if not math.isfinite(y)]
        out.metrics["non_finite_outputs"] = len(bad)
        done += f"; reading the outputs: {STATUS_NAMES.get(status)}" if status != OK else (
            f"; non-finite outputs {bad}" if bad else "; outputs finite")
        if bad and finite:
            out.problems.append(f"non-finite outputs {bad}")
    out.log = inst.text(n)
    out.detail = done + (f": {_short(out.log, 200)}" if out.status != OK else "")
    if inst.target.backend == NATIVE and out.status == ERROR:
        inst.mode = "Error"  # a step may fail after advancing part of the way: recover with fmi2Reset
        _recover(inst, out)
    return out


def _huge_input(inst: Instance) -> Outcome:
    return _huge(inst, _chosen(inst.target.input), init_mode=False)


def _huge_parameter(inst: Instance) -> Outcome:
    return _huge(inst, _chosen(inst.target.parameter), init_mode=True)


def _step_size(h_in_steps: float) -> Callable[[Instance], Outcome]:
    def case(inst: Instance) -> Outcome:
        inst.initialize()
        return _reject(inst, lambda: inst.step(h_in_steps * inst.target.step))
    return case


def _step_nan(inst: Instance) -> Outcome:
    inst.initialize()
    return _reject(inst, lambda: inst.step(math.nan))


def _step_wrong_time(inst: Instance) -> Outcome:
    inst.initialize()
    return _reject(inst, lambda: inst.call("DoStep", inst.time + 1.0, inst.target.step, 1))


def _far_step(inst: Instance, far_factor: float) -> Outcome:
    inst.initialize()
    return _step_and_read(inst, far_factor * inst.target.step, f"h = {far_factor:g} x {inst.target.step:g} s",
                          finite=True)


def _step_before_init(inst: Instance) -> Outcome:
    return _reject(inst, lambda: inst.step())


def _get_before_init(inst: Instance) -> Outcome:
    var = _chosen(inst.target.outputs[0] if inst.target.outputs else None)
    return _reject(inst, lambda: inst.get(var)[0])


def _exit_without_enter(inst: Instance) -> Outcome:
    return _reject(inst, lambda: inst.call("ExitInitializationMode"))


def _exit_twice(inst: Instance) -> Outcome:
    inst.initialize()
    return _reject(inst, lambda: inst.call("ExitInitializationMode"))


def _enter_twice(inst: Instance) -> Outcome:
    inst.enter()
    return _reject(inst, lambda: inst.call("EnterInitializationMode"))


def _setup_nan(inst: Instance) -> Outcome:
    return _reject(inst, lambda: inst.call("SetupExperiment", 0, 0.0, math.nan, 0, 0.0))


def _parameter_after_init(inst: Instance) -> Outcome:
    var = _chosen(inst.target.fixed)
    inst.initialize()
    value = inst.value(var)
    # a legal value (its own) in a state where a fixed parameter may not be set
    return _reject(inst, lambda: inst.set(var, value), var)


def _set_after_terminate(inst: Instance) -> Outcome:
    var = _chosen(inst.target.input or inst.target.parameter or inst.target.fixed)
    inst.initialize()
    if inst.step() != OK:
        raise CaseBroken(f"a normal step failed: {inst.text()[-300:]!r}")
    inst.terminate()
    value = inst.value(var)
    return _reject(inst, lambda: inst.set(var, value), var)


def _step_after_terminate(inst: Instance) -> Outcome:
    inst.initialize()
    inst.terminate()
    return _reject(inst, lambda: inst.step())


def _outside(var: Var, below: bool) -> float:
    """A value outside ``var``'s declared range: one unit (or the bound's magnitude) beyond it."""
    bound = var.min if below else var.max
    assert bound is not None
    delta = 1.0 if var.type == "Integer" else max(1.0, abs(bound))
    return bound - delta if below else bound + delta


def _out_of_range(below: bool) -> Callable[[Instance], Outcome]:
    def case(inst: Instance) -> Outcome:
        var = _chosen(inst.target.below if below else inst.target.above)
        inst.enter()
        return _reject(inst, lambda: inst.set(var, _outside(var, below)), var)
    return case


def _real_on_non_real(inst: Instance) -> Outcome:
    var = _chosen(inst.target.non_real)
    inst.enter()
    return _reject(inst, lambda: inst.set(var, 1.0, as_type="Real"), var)


def _integer_on_real(inst: Instance) -> Outcome:
    var = _chosen(inst.target.parameter)
    inst.enter()
    return _reject(inst, lambda: inst.set(var, 1, as_type="Integer"), var)


def _unknown_vr(fn: str) -> Callable[[Instance], Outcome]:
    def case(inst: Instance) -> Outcome:
        ghost = Var("(unknown)", UNKNOWN_VR, "Real", "input", "continuous", None, None, None)
        inst.initialize()
        return _reject(inst, lambda: inst.set(ghost, 1.0) if fn == "set" else inst.get(ghost)[0])
    return case


def _drive(inst: Instance, k: int) -> None:
    """Inputs as a fixed function of the step index ``k``: :data:`DRIVE` around their start values
    (inside any declared range)."""
    for i, var in enumerate(inst.target.inputs):
        value = (var.start or 0.0) + DRIVE * math.sin(0.7 * k + i)
        lo = -math.inf if var.min is None else var.min
        hi = math.inf if var.max is None else var.max
        if inst.set(var, min(max(value, lo), hi)) != OK:
            raise CaseBroken(f"setting input '{var.name}' failed: {inst.text()[-300:]!r}")


def _steps(inst: Instance, k0: int) -> list[bytes]:
    """:data:`STEPS` driven steps from step index ``k0``; the outputs' bits after each."""
    rows = []
    for k in range(k0, k0 + STEPS):
        _drive(inst, k)
        if inst.step() != OK:
            raise CaseBroken(f"a normal step failed: {inst.text()[-300:]!r}")
        rows.append(_bits(inst.outputs()))
    return rows


def _state_round_trip(inst: Instance) -> Outcome:
    """Snapshot after :data:`STEPS` steps (through serialization when declared), step on, restore,
    step again with the same inputs: the outputs must repeat bit for bit."""
    inst.initialize()
    _steps(inst, 0)
    t_snap = inst.time
    try:
        state = inst.slave.getFMUstate()
        if inst.target.can_serialize:
            blob = inst.slave.serializeFMUstate(state)
            inst.slave.freeFMUstate(state)
            state = inst.slave.deSerializeFMUstate(blob)
        first = _steps(inst, STEPS)
        inst.slave.setFMUstate(state)
        inst.time = t_snap
        again = _steps(inst, STEPS)
        inst.slave.freeFMUstate(state)
    except FMICallException as exc:
        inst.dead = exc.status == FATAL
        return Outcome(status=exc.status, log=inst.text(), detail=f"{exc}")
    varying = len(set(first)) > 1
    out = Outcome(detail=f"{STEPS} steps replayed from the snapshot: "
                         f"{'identical' if again == first else 'DIFFERENT'} outputs"
                         f" ({'varying' if varying else 'constant'} over the steps"
                         f"{', serialized' if inst.target.can_serialize else ''})")
    if again != first:
        diff = next(i for i, (a, b) in enumerate(zip(first, again)) if a != b)
        out.problems.append(f"outputs after the restore differ from step {diff + 1} on")
    return out


def rss_kib() -> int:
    """This process's resident set size in KiB (``VmRSS`` of ``/proc/self/status``)."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1])
    raise RuntimeError("no VmRSS in /proc/self/status")


def rss_bound_kib(backend: str, cycles: int) -> float:
    """Allowed RSS growth in KiB over ``cycles`` instantiate/free cycles (see :data:`RSS_PER_CYCLE_KIB`)."""
    return RSS_SLACK_KIB + RSS_PER_CYCLE_KIB[backend] * cycles


def _cycle(inst: Instance) -> None:
    """One instance life: instantiate, initialize, one default step, terminate, free."""
    inst.instantiate()
    inst.initialize()
    if inst.step() != OK:
        raise CaseBroken(f"a normal step failed: {inst.text()[-300:]!r}")
    inst.terminate()
    inst.slave.fmi2FreeInstance(inst.slave.component)
    if inst.target.backend == PYTHONFMU:
        # a freed pythonfmu slave is a reference cycle (getters bound to the slave): garbage until
        # the cyclic collector runs; collected now so RSS shows what is never released, not how
        # much garbage piled up (a pile of large slaves fragments the heap for good)
        gc.collect()


def live_slaves() -> int:
    """pythonfmu slave objects alive in this process (they live in the host's interpreter)."""
    return sum(1 for o in gc.get_objects() if any(c.__name__ == "Fmi2Slave" for c in type(o).__mro__))


def _cycles(inst: Instance, cycles: int) -> Outcome:
    """``cycles`` instance lives after :data:`WARMUP_CYCLES`; RSS before and after them."""
    inst.free()  # one FMU2Slave (one loaded library) for every cycle
    for _ in range(WARMUP_CYCLES):
        _cycle(inst)
    gc.collect()
    slaves0, rss0, started = live_slaves(), rss_kib(), time.perf_counter()
    for _ in range(cycles):
        _cycle(inst)
    took = time.perf_counter() - started
    gc.collect()
    growth, slaves = rss_kib() - rss0, live_slaves() - slaves0
    inst.instantiate()  # the runner frees the instance it made
    bound = rss_bound_kib(inst.target.backend, cycles)
    per_cycle_ms = took / max(cycles, 1) * 1e3
    out = Outcome(detail=f"{cycles} cycles in {took:.1f} s ({per_cycle_ms:.2f} ms each); RSS {rss0} -> "
                         f"{rss0 + growth} KiB: {growth:+d} KiB (bound {bound:g} KiB); "
                         f"{slaves:+d} live pythonfmu slaves",
                  metrics={"rss_growth_kib": growth, "rss_bound_kib": bound, "cycle_ms": per_cycle_ms})
    if growth > bound:
        out.problems.append(f"RSS grew by {growth} KiB > {bound:g} KiB")
    if slaves:  # exact: every freed slave must be collectable
        out.problems.append(f"{slaves} pythonfmu slave objects more alive after the cycles")
    errors = [m for s, m in inst.log if s >= ERROR]
    if errors:
        out.problems.append(f"errors logged during the cycles: {errors[:3]}")
    return out


# ----------------------------------------------------------------------------- case table
@dataclass(frozen=True)
class Expect:
    """The expected result of a case on one backend.

    Attributes
    ----------
    statuses : tuple of int
        Accepted statuses of the call under test.
    fragments : tuple of str
        When the status is not fmi2OK, the log must contain one of these (empty: any text).
    text : str
        Human-readable form for the report.
    """

    statuses: tuple[int, ...]
    fragments: tuple[str, ...]
    text: str


def rejected(backend: str, *fragments: str) -> Expect:
    """A rejected call: fmi2Error (native, then still usable) or fmi2Fatal (pythonfmu), with a message."""
    status = REJECTED[backend]
    usable = ", usable after" if backend == NATIVE else ""
    return Expect((status,), fragments, f"{STATUS_NAMES[status]} + '{fragments[0]}'{usable}")


def ok_or_clean_error(backend: str, *fragments: str) -> Expect:
    """Accepted, or rejected with one of ``fragments`` (native: usable afterwards); never a crash."""
    status = REJECTED[backend]
    return Expect((OK, status), fragments, f"OK or {STATUS_NAMES[status]} + '{' / '.join(fragments)}'")


def _same(fn: Callable[[str], Expect]) -> dict[str, Expect]:
    return {b: fn(b) for b in BACKENDS}


def _needs(attr: str, why: str) -> Callable[[Target], str | None]:
    """Applicability test: the target must have the variable ``attr`` (else "n/a: why")."""
    return lambda t: None if getattr(t, attr) else why


def always_applies(target: Target) -> str | None:
    """Applicability test of the cases that need no particular variable: never n/a."""
    return None


def _needs_state(target: Target) -> str | None:
    return None if target.can_state else "canGetAndSetFMUstate=false"


@dataclass(frozen=True)
class Case:
    """One robustness case.

    Attributes
    ----------
    name : str
    what : str
        What the case does.
    expect : dict of str to Expect
        Expected result per backend.
    run : callable
        The worker's function: ``run(instance, **settings)`` with the :class:`Settings` fields
        named in ``settings``; returns an :class:`Outcome`.
    applies : callable
        ``Target -> None`` or the reason the case is n/a.
    settings : tuple of str
        Fields of :class:`Settings` the case takes.
    """

    name: str
    what: str
    expect: dict[str, Expect]
    run: Callable[..., Outcome]
    applies: Callable[[Target], str | None] = always_applies
    settings: tuple[str, ...] = ()


@dataclass(frozen=True)
class Settings:
    """Sizes of a run.

    Attributes
    ----------
    cycles : int
        Instantiate/free cycles of the memory case.
    far_factor : float
        The far step in default step sizes.
    """

    cycles: int = 1000
    far_factor: float = FAR_FACTOR


NON_FINITE = "non-finite"
HUGE_FRAGMENTS = {NATIVE: ("non-finite", "outside its range", "substeps (limit", "sample at")}
"""Clean error messages of a huge value or step: overflow, range, substep limit, failed sample.
pythonfmu also raises Python's OverflowError where C gives inf (``x**2`` of 1e300 in the model
code), which pythonfmu reports with the exception's name."""
HUGE_FRAGMENTS[PYTHONFMU] = HUGE_FRAGMENTS[NATIVE] + ("OverflowError",)
NO_INPUT, NO_PARAMETER = "no Real input", "no Real parameter"


def _cases() -> tuple[Case, ...]:
    cases = []
    for label, value in (("nan", math.nan), ("+inf", math.inf), ("-inf", -math.inf)):
        cases.append(Case(f"input = {label}", f"setReal of the first Real input to {label} in StepComplete",
                          _same(lambda b: rejected(b, NON_FINITE)), _set_input(value), _needs("input", NO_INPUT)))
    cases.append(Case("input = 1e300", "setReal of the first Real input to 1e300, then a default step",
                      _same(lambda b: ok_or_clean_error(b, *HUGE_FRAGMENTS[b])), _huge_input,
                      _needs("input", NO_INPUT)))
    for label, value in (("nan", math.nan), ("+inf", math.inf), ("-inf", -math.inf)):
        cases.append(Case(f"parameter = {label}", f"setReal of the first Real parameter to {label} in "
                          "InitializationMode", _same(lambda b: rejected(b, NON_FINITE)), _set_parameter(value),
                          _needs("parameter", NO_PARAMETER)))
    cases.append(Case("parameter = 1e300", "setReal of the first Real parameter to 1e300 in InitializationMode, "
                      "then a default step", _same(lambda b: ok_or_clean_error(b, *HUGE_FRAGMENTS[b])),
                      _huge_parameter, _needs("parameter", NO_PARAMETER)))
    step_msg = "communicationStepSize must be finite and > 0"
    cases += [
        Case("doStep h = 0", "fmi2DoStep with a zero step", _same(lambda b: rejected(b, step_msg)), _step_size(0.0)),
        Case("doStep h < 0", "fmi2DoStep with minus the default step", _same(lambda b: rejected(b, step_msg)),
             _step_size(-1.0)),
        Case("doStep h = nan", "fmi2DoStep with a NaN step", _same(lambda b: rejected(b, step_msg)), _step_nan),
        Case("doStep at wrong time", "fmi2DoStep from t = 1 s while the FMU is at 0 s",
             _same(lambda b: rejected(b, "differs from the FMU time")), _step_wrong_time),
        Case(FAR_CASE, "one step of `far_factor` (default 1e4) default step sizes from the default start; "
             "outputs finite if OK", _same(lambda b: ok_or_clean_error(b, *HUGE_FRAGMENTS[b])), _far_step,
             settings=("far_factor",)),
        Case("doStep before init", "fmi2DoStep in Instantiated",
             _same(lambda b: rejected(b, "must not be called in state Instantiated")), _step_before_init),
        Case("getReal before init", "fmi2GetReal of an output in Instantiated",
             _same(lambda b: rejected(b, "must not be called in state Instantiated")), _get_before_init,
             _needs("outputs", "no Real output")),
        Case("exitInit without enter", "fmi2ExitInitializationMode in Instantiated",
             _same(lambda b: rejected(b, "must not be called in state Instantiated")), _exit_without_enter),
        Case("exitInit twice", "fmi2ExitInitializationMode in StepComplete",
             _same(lambda b: rejected(b, "must not be called in state StepComplete")), _exit_twice),
        Case("enterInit twice", "fmi2EnterInitializationMode in InitializationMode",
             _same(lambda b: rejected(b, "must not be called in state InitializationMode")), _enter_twice),
        Case("setupExperiment start = nan", "fmi2SetupExperiment with a NaN start time",
             _same(lambda b: rejected(b, "non-finite startTime")), _setup_nan),
        Case("fixed parameter after init", "setting a non-tunable parameter (to its own value) in StepComplete",
             _same(lambda b: rejected(b, "cannot be set in state StepComplete")), _parameter_after_init,
             _needs("fixed", "no non-tunable parameter")),
        Case("set after terminate", "setting an input (else a parameter) to its own value in Terminated",
             _same(lambda b: rejected(b, "cannot be set in state Terminated")), _set_after_terminate),
        Case("doStep after terminate", "fmi2DoStep in Terminated",
             _same(lambda b: rejected(b, "must not be called in state Terminated")), _step_after_terminate),
        Case("parameter < min", "a parameter with a declared min set below it in InitializationMode",
             _same(lambda b: rejected(b, "outside its range")), _out_of_range(below=True),
             _needs("below", "no parameter with a min")),
        Case("parameter > max", "a parameter with a declared max set above it in InitializationMode",
             _same(lambda b: rejected(b, "outside its range")), _out_of_range(below=False),
             _needs("above", "no parameter with a max")),
        # pythonfmu checks the type and the value reference itself: only its own exception text
        Case("setReal on Integer/Boolean", "fmi2SetReal on an Integer or Boolean parameter",
             {NATIVE: rejected(NATIVE, "has another type"), PYTHONFMU: rejected(PYTHONFMU, "is not of type Real")},
             _real_on_non_real, _needs("non_real", "no Integer/Boolean parameter")),
        Case("setInteger on Real", "fmi2SetInteger on a Real parameter",
             {NATIVE: rejected(NATIVE, "has another type"), PYTHONFMU: rejected(PYTHONFMU, "is not of type Integer")},
             _integer_on_real, _needs("parameter", NO_PARAMETER)),
        Case("setReal unknown vr", f"fmi2SetReal of value reference {UNKNOWN_VR}",
             {NATIVE: rejected(NATIVE, f"unknown value reference {UNKNOWN_VR}"),
              PYTHONFMU: rejected(PYTHONFMU, str(UNKNOWN_VR))}, _unknown_vr("set")),
        Case("getReal unknown vr", f"fmi2GetReal of value reference {UNKNOWN_VR}",
             {NATIVE: rejected(NATIVE, f"unknown value reference {UNKNOWN_VR}"),
              PYTHONFMU: rejected(PYTHONFMU, str(UNKNOWN_VR))}, _unknown_vr("get")),
        Case("FMU state round trip", f"get (and serialize/deserialize) the state after {STEPS} driven steps, "
             f"step {STEPS} more, restore, repeat: identical outputs",
             _same(lambda b: Expect((OK,), (), "OK, outputs identical bit for bit")), _state_round_trip,
             _needs_state),
        Case(CYCLES_CASE, "instantiate, initialize, one step, terminate, free; RSS before and after",
             {b: Expect((OK,), (), f"OK, RSS growth <= {RSS_SLACK_KIB} + {RSS_PER_CYCLE_KIB[b]:g} KiB/cycle")
              for b in BACKENDS}, _cycles, settings=("cycles",)),
    ]
    return tuple(cases)


CASES = _cases()
CASE_BY_NAME = {c.name: c for c in CASES}


# ----------------------------------------------------------------------------- worker
def _extract(path: Path) -> str:
    return str(extract(str(path)))


def _run_case(case: Case, target: Target, unzip: str, settings: Settings) -> Outcome:
    """Run one case on a fresh instance; Python-level failures become a FAIL outcome, not a crash."""
    try:
        inst = Instance(target, unzip)
    except Exception as exc:  # noqa: BLE001 - loading or instantiating failed: the case fails
        return Outcome(status=NO_RESULT, problems=[f"cannot instantiate: {type(exc).__name__}: {exc}"])
    try:
        out = case.run(inst, **{name: getattr(settings, name) for name in case.settings})
    except CaseBroken as exc:
        out = Outcome(status=NO_RESULT, log=inst.text(), problems=[str(exc)])
    except Exception as exc:  # noqa: BLE001 - an unexpected Python error is a FAIL of this case
        out = Outcome(status=NO_RESULT, log=inst.text(), problems=[f"{type(exc).__name__}: {exc}"])
    inst.free()
    return out


def _emit(stream: io.TextIOBase, record: dict[str, Any]) -> None:
    stream.write(json.dumps(record) + "\n")
    stream.flush()


def work(path: Path, names: Sequence[str], settings: Settings, results: Path) -> None:
    """Worker: run the cases ``names`` on the FMU ``path``, appending a JSON line to ``results``
    when each case starts and when it ends (so the parent knows which case a crash hit)."""
    target = describe(path)
    unzip = _extract(path)
    abort_on = os.environ.get(ABORT_ENV)
    try:
        with results.open("a") as stream:
            for name in names:
                _emit(stream, {"event": "start", "case": name})
                if name == abort_on:
                    os.abort()
                out = _run_case(CASE_BY_NAME[name], target, unzip, settings)
                _emit(stream, {"event": "done", "case": name, **asdict(out)})
    finally:
        shutil.rmtree(unzip, ignore_errors=True)


# ----------------------------------------------------------------------------- parent
@dataclass
class Row:
    """One cell of the report: a case on an FMU.

    Attributes
    ----------
    fmu, backend, case : str
    expected : str
        The expectation on this backend.
    got : str
        Status of the call under test (``-`` when not run, ``CRASH``, ``TIMEOUT``).
    log_found : bool or None
        The expected log fragment was found (None when no text was required).
    verdict : str
        ``pass``, ``fail``, ``crash`` or ``n/a``.
    detail : str
        What happened (measured facts, problems, crash signal and output).
    metrics : dict of str to float
        Measured quantities (``rss_growth_kib`` of the cycles case, ``step_s``, ...).
    """

    fmu: str
    backend: str
    case: str
    expected: str
    got: str
    log_found: bool | None
    verdict: str
    detail: str
    metrics: dict[str, float] = field(default_factory=dict)

    @property
    def cell(self) -> str:
        """The Markdown table cell: ok / FAIL: ... / CRASH / n/a (with a short measured note)."""
        if self.verdict == "n/a":
            return "n/a"
        if self.verdict == "crash":
            return "CRASH"
        if self.verdict == "fail":
            return "FAIL: " + _short(self.detail, 80)
        if self.case == CYCLES_CASE:
            return f"ok ({self.metrics.get('rss_growth_kib', 0):+.0f} KiB)"
        if self.got != "OK" and self.expected.startswith("OK or"):
            return f"ok ({self.got})"
        if self.metrics.get("non_finite_outputs"):
            return "ok (inf/nan out)"
        return "ok"


def judge(case: Case, target: Target, out: Outcome) -> Row:
    """The row of ``case`` on ``target`` from the worker's outcome."""
    expect = case.expect[target.backend]
    problems = list(out.problems)
    if out.status == NO_RESULT:  # the case could not make its call: a failure whatever the reason
        problems = problems or ["no result"]
    elif out.status not in expect.statuses:
        problems.insert(0, f"status {STATUS_NAMES.get(out.status, out.status)}, expected {expect.text}")
    found = None
    if out.status not in (OK, NO_RESULT) and expect.fragments:
        found = any(f in out.log for f in expect.fragments)
        if not found:
            problems.append(f"log lacks {' / '.join(map(repr, expect.fragments))}: {_short(out.log, 200)!r}")
    detail = "; ".join(problems + ([out.detail] if out.detail else [])) or _short(out.log, 200)
    return Row(target.name, target.backend, case.name, expect.text, STATUS_NAMES.get(out.status, str(out.status)),
               found, "fail" if problems else "pass", detail, dict(out.metrics))


def _short(text: str, n: int) -> str:
    text = " ".join(text.split())
    return text if len(text) <= n else text[:n - 3] + "..."


def _signal_name(code: int) -> str:
    if code >= 0:
        return f"exit code {code}"
    try:
        return f"{signal.Signals(-code).name} (exit code {code})"
    except ValueError:
        return f"signal {-code}"


def _timeout(case: str, settings: Settings) -> float:
    """Time limit of ``case`` in s."""
    if case == CYCLES_CASE:
        return CASE_TIMEOUT_S + CYCLE_TIMEOUT_S * (settings.cycles + WARMUP_CYCLES)
    if case == FAR_CASE:
        return CASE_TIMEOUT_S + FAR_TIMEOUT_S * settings.far_factor
    return CASE_TIMEOUT_S


def _read_events(path: Path, seen: int) -> list[dict[str, Any]]:
    """Complete JSON lines of ``path`` after the first ``seen``."""
    if not path.exists():
        return []
    lines = path.read_text().split("\n")[:-1]  # the last element is "" or a partial line
    return [json.loads(line) for line in lines[seen:]]


ONE_BLAS_THREAD = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
"""Workers run one BLAS thread each: a worker's spinning BLAS thread pool beside other processes
(a parallel test run, say) oversubscribes the CPUs (measured: two online SDRE workers side by
side 5x slower with OpenBLAS's default threads than with one each)."""


def _start_worker(target: Target, names: list[str], settings: Settings, results: Path, output: Path
                  ) -> subprocess.Popen:
    """``python -m sims.robustness --worker`` on ``names``: events to ``results``, its stdout and
    stderr to ``output``; its FMU extraction goes next to them (removed by the parent even if the
    worker crashes)."""
    results.unlink(missing_ok=True)
    argv = [sys.executable, "-m", "sims.robustness", "--worker", str(target.path), "--results", str(results),
            "--cycles", str(settings.cycles), "--far-factor", repr(settings.far_factor), *names]
    with output.open("w") as log:
        return subprocess.Popen(argv, stdout=log, stderr=subprocess.STDOUT,
                                env={**os.environ, **ONE_BLAS_THREAD, "TMPDIR": str(results.parent)})


def _child(target: Target, names: list[str], settings: Settings, workdir: Path
           ) -> Iterator[tuple[str, Outcome | Row]]:
    """Run a worker on ``names``; yields (case, Outcome) per finished case, and (case, Row) for the
    case a crash or time-out ended it in (the worker is gone then)."""
    results, output = workdir / "results.jsonl", workdir / "output.txt"
    proc = _start_worker(target, names, settings, results, output)
    seen, running, started = 0, None, time.monotonic()
    try:
        while True:
            code = proc.poll()
            for event in _read_events(results, seen):
                seen += 1
                if event["event"] == "start":
                    running, started = event["case"], time.monotonic()
                else:
                    running = None
                    yield event["case"], Outcome(**{k: v for k, v in event.items() if k not in ("event", "case")})
            if code is not None:
                break
            if running is not None and time.monotonic() - started > _timeout(running, settings):
                proc.kill()
                proc.wait()
                limit = _timeout(running, settings)
                yield running, _bad_row(target, running, "TIMEOUT", "fail", f"no result within {limit:g} s (killed)")
                return
            time.sleep(0.05)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    if code != 0 or seen < 2 * len(names):
        yield _crash(target, names, running, code, results, output)


def _crash(target: Target, names: list[str], running: str | None, code: int, results: Path, output: Path
           ) -> tuple[str, Row]:
    """The CRASH row of a dead worker: the case it was running, else the first one it did not finish
    (it died between cases), else the last one (it died on exit, after every case)."""
    done = {e["case"] for e in _read_events(results, 0) if e["event"] == "done"}
    victim = running or next((n for n in names if n not in done), None)
    when = "during this case" if running else "before this case started" if victim else "on exit after all cases"
    victim = victim or names[-1]
    tail = _short(output.read_text(errors="replace")[-600:], 400)
    return victim, _bad_row(target, victim, "CRASH", "crash", f"worker died ({_signal_name(code)}) {when}; "
                                                              f"output: {tail!r}")


def _bad_row(target: Target, case: str, got: str, verdict: str, detail: str) -> Row:
    return Row(target.name, target.backend, case, CASE_BY_NAME[case].expect[target.backend].text, got, None,
               verdict, detail)


def run_fmu(target: Target, settings: Settings, workdir: Path) -> list[Row]:
    """Every case on one FMU: n/a rows for the inapplicable ones, the rest in as many workers as
    crashes and time-outs require (each restarts with the cases not yet done)."""
    rows: dict[str, Row] = {}
    todo = []
    for case in CASES:
        why = case.applies(target)
        if why:
            rows[case.name] = Row(target.name, target.backend, case.name, case.expect[target.backend].text, "-",
                                  None, "n/a", why)
        else:
            todo.append(case.name)
    while todo:
        for name, result in _child(target, todo, settings, workdir):
            rows[name] = result if isinstance(result, Row) else judge(CASE_BY_NAME[name], target, result)
        todo = [n for n in todo if n not in rows]
    return [rows[c.name] for c in CASES]


@dataclass
class Report:
    """Results of a run.

    Attributes
    ----------
    rows : list of Row
        One per case and FMU, FMU by FMU in the order of :data:`CASES`.
    settings : Settings
    wall_s : float
        Wall time of the run in s.
    """

    rows: list[Row]
    settings: Settings
    wall_s: float

    @property
    def fmus(self) -> list[str]:
        """The FMUs tested, in order."""
        return list(dict.fromkeys(r.fmu for r in self.rows))

    @property
    def failures(self) -> list[Row]:
        """Rows with verdict ``fail``."""
        return [r for r in self.rows if r.verdict == "fail"]

    @property
    def crashes(self) -> list[Row]:
        """Rows with verdict ``crash``."""
        return [r for r in self.rows if r.verdict == "crash"]

    @property
    def ok(self) -> bool:
        """No failure and no crash."""
        return not self.failures and not self.crashes

    def count(self, verdict: str) -> int:
        """Number of rows with ``verdict``."""
        return sum(r.verdict == verdict for r in self.rows)

    def rss_growth_kib(self, backend: str) -> dict[str, float]:
        """RSS growth of the cycles case in KiB per FMU of ``backend`` (FMUs where it ran)."""
        return {r.fmu: r.metrics["rss_growth_kib"] for r in self.rows
                if r.case == CYCLES_CASE and r.backend == backend and "rss_growth_kib" in r.metrics}

    def summary(self) -> str:
        """One paragraph: counts, crashes, RSS growth per backend and wall time."""
        parts = [(f"{len(self.fmus)} FMUs x {len(CASES)} cases: {self.count('pass')} pass, "
                  f"{self.count('fail')} fail, {self.count('crash')} crash, {self.count('n/a')} n/a")]
        for backend in BACKENDS:
            growth = self.rss_growth_kib(backend)
            if growth:
                worst = max(growth, key=growth.get)
                bound = rss_bound_kib(backend, self.settings.cycles)
                parts.append(f"max RSS growth over {self.settings.cycles} cycles, {backend}: "
                             f"{growth[worst]:+.0f} KiB ({worst}; bound {bound:g} KiB)")
        parts.append(f"wall time {self.wall_s:.0f} s")
        return "; ".join(parts) + "."


def run(fmu_dir: Path, fmus: list[str] | None = None, cycles: int = 1000, out: Path | None = None, *,
        far_factor: float = FAR_FACTOR) -> Report:
    """Run every case on every FMU of ``fmu_dir`` (or on ``fmus``), each FMU in child processes.

    Parameters
    ----------
    fmu_dir : Path
        Folder of the FMUs; every ``*.fmu`` in it is tested unless ``fmus`` is given.
    fmus : list of str, optional
        FMU names (with or without ``.fmu``) to test instead.
    cycles : int
        Instantiate/free cycles of the memory case (RSS bound scaled with it).
    out : Path, optional
        Write ``<out>.md`` and ``<out>.csv`` (atomically).
    far_factor : float
        The far step in default step sizes (smaller: faster, for quick checks).

    Returns
    -------
    Report
    """
    settings = Settings(cycles, far_factor)
    started = time.monotonic()
    rows: list[Row] = []
    with tempfile.TemporaryDirectory(prefix="satfmu_robustness_") as tmp:
        for path in discover(Path(fmu_dir), fmus):
            rows += _run_path(path, settings, Path(tmp))
    report = Report(rows, settings, time.monotonic() - started)
    if out is not None:
        write(report, Path(out))
    return report


def _run_path(path: Path, settings: Settings, workdir: Path) -> list[Row]:
    """:func:`run_fmu` on the FMU file ``path``; an unreadable FMU fails every case."""
    try:
        target = describe(path)
    except Exception as exc:  # noqa: BLE001 - an unreadable FMU fails every case
        return [Row(path.stem, "?", c.name, "-", "-", None, "fail",
                    f"cannot read the FMU: {type(exc).__name__}: {exc}") for c in CASES]
    return run_fmu(target, settings, workdir)


# ----------------------------------------------------------------------------- output
def _md_table(header: list[str], body: list[list[str]]) -> list[str]:
    esc = [[c.replace("|", "\\|") for c in row] for row in [header] + body]
    lines = ["| " + " | ".join(esc[0]) + " |", "|" + "---|" * len(header)]
    return lines + ["| " + " | ".join(row) + " |" for row in esc[1:]]


def markdown(report: Report) -> str:
    """The report as Markdown: expectations, one cases x FMUs table per backend, measurements, failures."""
    by = {(r.fmu, r.case): r for r in report.rows}
    generated = (f"Generated by `python -m sims.robustness` ({report.settings.cycles} instantiate/free cycles, "
                 f"far step {report.settings.far_factor:g} x default) on {datetime.now(UTC):%Y-%m-%d %H:%M} UTC; "
                 "the module docstring of `sims/robustness.py` describes the cases and the two backends.")
    lines = ["# Robustness of the satfmu FMUs", "", generated, "", report.summary(), "",
             "## Cases and expectations", ""]
    lines += _md_table(["case", "what", "native", "pythonfmu"],
                       [[c.name, c.what, c.expect[NATIVE].text, c.expect[PYTHONFMU].text] for c in CASES])
    for backend in BACKENDS:
        fmus = [f for f in report.fmus if by[(f, CASES[0].name)].backend == backend]
        if fmus:
            lines += ["", f"## Results: {backend} FMUs", ""]
            lines += _md_table(["case"] + fmus, [[c.name] + [by[(f, c.name)].cell for f in fmus] for c in CASES])
    lines += ["", "## Measured", ""]
    for name in (FAR_CASE, "input = 1e300", "parameter = 1e300", "FMU state round trip",
                 CYCLES_CASE):
        lines += [f"### {name}", ""]
        lines += [f"- `{r.fmu}`: {_short(r.detail, 300)}" for r in report.rows if r.case == name
                  and r.verdict != "n/a"] + [""]
    bad = report.failures + report.crashes
    lines += ["## Failures and crashes", ""]
    lines += [f"- `{r.fmu}` / {r.case}: **{r.verdict.upper()}** {r.detail}" for r in bad] or ["None."]
    return "\n".join(lines) + "\n"


def csv_text(report: Report) -> str:
    """The report as CSV, one row per case and FMU (metrics as JSON)."""
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(["fmu", "backend", "case", "expected", "got", "log_found", "verdict", "detail", "metrics"])
    for r in report.rows:
        writer.writerow([r.fmu, r.backend, r.case, r.expected, r.got, "" if r.log_found is None else r.log_found,
                         r.verdict, r.detail, json.dumps(r.metrics, sort_keys=True) if r.metrics else ""])
    return buf.getvalue()


def _write_atomic(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(text)
    os.replace(tmp, path)


def write(report: Report, out: Path) -> tuple[Path, Path]:
    """Write ``<out>.md`` and ``<out>.csv``, each atomically (temporary file, then rename)."""
    md, csv_path = out.with_name(out.name + ".md"), out.with_name(out.name + ".csv")
    _write_atomic(md, markdown(report))
    _write_atomic(csv_path, csv_text(report))
    return md, csv_path


# ----------------------------------------------------------------------------- command line
def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m sims.robustness", description=__doc__.splitlines()[0])
    p.add_argument("--fmu-dir", type=Path, default=Path("build/fmus"), help="folder of the FMUs (every *.fmu)")
    p.add_argument("--fmu", action="append", help="test only this FMU (repeatable; name with or without .fmu)")
    p.add_argument("--cycles", type=int, default=1000, help="instantiate/free cycles of the memory case")
    p.add_argument("--out", type=Path, help="write OUT.md and OUT.csv")
    p.add_argument("--far-factor", type=float, default=FAR_FACTOR, help="far step in default step sizes")
    p.add_argument("--worker", type=Path, help=argparse.SUPPRESS)
    p.add_argument("--results", type=Path, help=argparse.SUPPRESS)
    p.add_argument("cases", nargs="*", help=argparse.SUPPRESS)
    return p


def main(argv: list[str] | None = None) -> int:
    """Command line: run the suite and print the report; exit code 0 if every case passed (or is
    n/a), 1 on any failure or crash, 2 if there is no FMU to test."""
    args = _parser().parse_args(argv)
    if args.worker is not None:
        work(args.worker, args.cases, Settings(args.cycles, args.far_factor), args.results)
        return 0
    try:
        if not discover(args.fmu_dir, args.fmu):
            raise FileNotFoundError(f"no *.fmu in {args.fmu_dir}; run `satfmu build` first")
        report = run(args.fmu_dir, args.fmu, args.cycles, args.out, far_factor=args.far_factor)
    except FileNotFoundError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(markdown(report))
    return 0 if report.ok else 1


if __name__ == "__main__":
    sys.exit(main())
