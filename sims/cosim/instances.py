"""The FMU instance behind a component of the master: FMI 2.0 or FMI 3.0 co-simulation, one interface.

The master (:mod:`satfmu.sims.cosim.master`) addresses scalar variables by name and value
reference, as FMI 2.0 has them (``sigma[1]``). :class:`Fmi2Instance` is fmpy's ``FMU2Slave``
with that interface. :class:`Fmi3Instance` gives an FMI 3.0 co-simulation FMU the same one:

- its description is seen as FMI 2.0 scalars (:func:`scalar_description`): an array ``sigma``
  of 3 elements is ``sigma[1]`` .. ``sigma[3]`` (a two-dimensional one ``J[1,1]`` ..
  ``J[3,3]``, row-major as FMI 3.0 serializes it), each with a value reference of its own (the
  element's index in the elements of :class:`ScalarDescription`); Float64 is ``Real``, Int32
  ``Integer``;
- an array input is set whole: the master's values go into a copy of the array held here (its
  start values at first) and the array is passed to ``fmi3SetFloat64`` as one;
- its periodic input clocks (a sampled controller's ``sample_clock``) are driven in Event Mode
  (``eventModeUsed``): their interval and shift are read in Initialization Mode; a step that
  contains an instant is split there; at an instant the master enters Event Mode before it sets
  the inputs of that communication point, activates the clocks (:meth:`Fmi3Instance.activate`)
  before it reads an output, then updates the discrete states and returns to Step Mode
  (:meth:`Fmi3Instance.leave_event`). The instance then samples from the inputs of the instant,
  as an FMI 2.0 one does with the same wiring (the same rows, bit for bit).

Both raise fmpy's ``FMICallException`` for a call that returns fmi2Error/fmi3Error or worse.
"""
from __future__ import annotations

import copy
import ctypes
import math
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave
from fmpy.fmi3 import FMU3Slave, fmi3Float64, fmi3ValueReference

from satfmu.fmus.errors import MasterError
from satfmu.sims.cosim import fmi_host

TYPES = {"Float64": "Real", "Int32": "Integer", "Boolean": "Boolean"}
"""FMI 3.0 type -> the FMI 2.0 type the master handles it as; other types keep their FMI 3.0 name
(they cannot be set, connected or recorded)."""

_DTYPES = {"Real": np.float64, "Integer": np.int32, "Boolean": np.bool_}


def instant_tolerance(t: float) -> float:
    """Two times closer than this are one clock instant, s: 1e-9 of ``|t|``, at least 1e-9 s.

    Parameters
    ----------
    t : float
        The time, s.
    """
    return 1e-9 * max(1.0, abs(t))


@dataclass(frozen=True)
class Element:
    """One scalar of an FMI 3.0 variable, as the master addresses it.

    Attributes
    ----------
    variable : fmpy.model_description.ModelVariable
        The FMI 3.0 variable (array or scalar).
    offset : int
        The element's index in the variable's values (row-major).
    """

    variable: Any
    offset: int


@dataclass
class ScalarDescription:
    """An FMI 3.0 model description seen as FMI 2.0 scalars.

    Attributes
    ----------
    description : fmpy.model_description.ModelDescription
        A copy of fmpy's description whose ``modelVariables`` are the scalars (fmpy's variable
        objects copied, each with the element's name, value reference, FMI 2.0 type and start
        value) and whose ``outputs`` name them: an output element depends on every element of
        the inputs its array depends on. The independent variable ``time`` and the clocks are
        not among the scalars.
    elements : list of Element
        The FMI 3.0 variable and offset of each scalar, indexed by its value reference.
    clocks : list of fmpy.model_description.ModelVariable
        The FMU's clock variables.
    """

    description: Any
    elements: list[Element]
    clocks: list[Any]


def _size(var: Any) -> list[int]:
    """The dimensions of ``var`` ([] for a scalar), each a fixed size."""
    sizes = []
    for d in var.dimensions:
        if d.start is None:
            raise MasterError(f"FMI 3.0 variable {var.name!r}: its size is a structural parameter's value "
                              "(a <Dimension valueReference=...>); the master handles arrays of fixed size only")
        sizes.append(int(d.start))
    return sizes


def _names(var: Any) -> list[str]:
    """The FMI 2.0 names of the elements of ``var``, row-major."""
    sizes = _size(var)
    if not sizes:
        return [var.name]
    index = np.stack(np.unravel_index(np.arange(math.prod(sizes)), sizes), axis=1) + 1
    return [f"{var.name}[{','.join(str(i) for i in row)}]" for row in index]


def scalar_description(md: Any) -> ScalarDescription:
    """``md``, an FMI 3.0 model description as fmpy reads it, seen as FMI 2.0 scalars.

    Parameters
    ----------
    md : fmpy.model_description.ModelDescription
        The FMI 3.0 description.

    Returns
    -------
    ScalarDescription

    Raises
    ------
    MasterError
        An array whose size is given by a structural parameter.
    """
    elements: list[Element] = []
    scalars = []
    of_variable: dict[str, list[Any]] = {}
    clocks = []
    for var in md.modelVariables:
        if var.type == "Clock":
            clocks.append(var)
            continue
        if var.causality == "independent":
            continue
        starts = var.start.split() if isinstance(var.start, str) and var.dimensions else None
        of_variable[var.name] = []
        for offset, name in enumerate(_names(var)):
            scalar = copy.copy(var)
            scalar.name = name
            scalar.valueReference = len(elements)
            scalar.type = TYPES.get(var.type, var.type)
            scalar.dimensions = []
            if starts is not None:
                scalar.start = starts[offset] if offset < len(starts) else starts[-1]
            elements.append(Element(var, offset))
            scalars.append(scalar)
            of_variable[var.name].append(scalar)
    outputs = []
    for unknown in md.outputs:
        for scalar in of_variable.get(unknown.variable.name, []):
            out = copy.copy(unknown)
            out.variable = scalar
            if unknown.dependencies is not None:
                out.dependencies = [s for d in unknown.dependencies for s in of_variable.get(d.name, [])]
            outputs.append(out)
    view = copy.copy(md)
    view.modelVariables = scalars
    view.outputs = outputs
    return ScalarDescription(view, elements, clocks)


class Instance(ABC):
    """An FMU instance as the master drives it: scalar value references, one call per step.

    Attributes
    ----------
    slave : fmpy.fmi2.FMU2Slave or fmpy.fmi3.FMU3Slave
        fmpy's handle of the FMU's library and instance.
    description : fmpy.model_description.ModelDescription
        The model description as FMI 2.0 scalars.
    clocked : bool
        Whether it has input clocks the master drives in Event Mode.
    """

    slave: Any
    description: Any
    clocked: bool = False

    @abstractmethod
    def instantiate(self, callbacks: fmi_host.Callbacks) -> None:
        """Instantiate it for co-simulation with logging on.

        Parameters
        ----------
        callbacks : satfmu.sims.cosim.fmi_host.Callbacks
            Receives its log messages.
        """

    @abstractmethod
    def initialize(self, start: float, stop: float) -> None:
        """Set up the experiment and enter Initialization Mode.

        Parameters
        ----------
        start, stop : float
            Start and stop time, s.
        """

    @abstractmethod
    def set_values(self, kind: str, refs: list[int], values: list[Any]) -> None:
        """Set parameters or inputs of one type.

        Parameters
        ----------
        kind : {"Real", "Integer", "Boolean"}
            Their FMI 2.0 type.
        refs : list of int
            Their scalar value references.
        values : list
            The values, in order.
        """

    @abstractmethod
    def get_reals(self, refs: Any, buf: Any) -> None:
        """Read Real variables.

        Parameters
        ----------
        refs : ctypes array of unsigned int
            Their scalar value references.
        buf : ctypes array of double
            Receives their values (as long as ``refs``).
        """

    @abstractmethod
    def set_reals(self, refs: Any, buf: Any) -> None:
        """Set Real inputs.

        Parameters
        ----------
        refs : ctypes array of unsigned int
            Their scalar value references.
        buf : ctypes array of double
            The values (as long as ``refs``).
        """

    @abstractmethod
    def exit_initialization(self) -> None:
        """Leave Initialization Mode (for a clocked FMU, also the Event Mode that follows)."""

    @abstractmethod
    def step(self, t: float, h: float) -> None:
        """One communication step.

        Parameters
        ----------
        t : float
            The current communication point, s.
        h : float
            The step, s.
        """

    def terminate(self) -> None:
        """End the simulation (``fmi2Terminate``, ``fmi3Terminate``)."""
        self.slave.terminate()

    def reset(self) -> None:
        """Back to the instantiated state, every variable at its start value."""
        self.slave.reset()

    @abstractmethod
    def free(self) -> None:
        """Free the instance."""

    def unload(self) -> None:
        """Unload the FMU's library."""
        self.slave.freeLibrary()


class Fmi2Instance(Instance):
    """An FMI 2.0 co-simulation FMU (fmpy's ``FMU2Slave``) with the master's interface.

    Parameters
    ----------
    md : fmpy.model_description.ModelDescription
        Its model description.
    unzip_dir : str
        The extracted FMU.
    name : str
        The instance name.

    Attributes
    ----------
    slave : fmpy.fmi2.FMU2Slave
        fmpy's handle (the compiled loop calls its functions directly).
    description : fmpy.model_description.ModelDescription
        ``md``.
    clocked : bool
        False: an FMI 2.0 FMU samples inside its steps.
    """

    def __init__(self, md: Any, unzip_dir: str, name: str) -> None:
        self.description = md
        self.slave = FMU2Slave(guid=md.guid, unzipDirectory=unzip_dir,
                               modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)

    def instantiate(self, callbacks: fmi_host.Callbacks) -> None:
        self.slave.instantiate(callbacks=callbacks.functions, loggingOn=True)

    def initialize(self, start: float, stop: float) -> None:
        self.slave.setupExperiment(None, start, stop)
        self.slave.enterInitializationMode()

    def set_values(self, kind: str, refs: list[int], values: list[Any]) -> None:
        getattr(self.slave, f"set{kind}")(refs, values)

    def get_reals(self, refs: Any, buf: Any) -> None:
        self.slave.fmi2GetReal(self.slave.component, refs, len(buf), buf)

    def set_reals(self, refs: Any, buf: Any) -> None:
        self.slave.fmi2SetReal(self.slave.component, refs, len(buf), buf)

    def exit_initialization(self) -> None:
        self.slave.exitInitializationMode()

    def step(self, t: float, h: float) -> None:
        self.slave.doStep(t, h)

    def free(self) -> None:
        self.slave.fmi2FreeInstance(self.slave.component)


@dataclass
class _Plan:
    """How a list of scalar value references maps onto the FMI 3.0 variables' values."""

    refs: Any  # ctypes array of the variables' value references
    values: Any  # ctypes double array of all their values, in order
    positions: np.ndarray  # each scalar's index in values
    variables: list[Any] = field(default_factory=list)
    spans: list[tuple[int, int]] = field(default_factory=list)  # each variable's slice of values


class Fmi3Instance(Instance):
    """An FMI 3.0 co-simulation FMU with the master's interface (see the module docstring).

    Parameters
    ----------
    md : fmpy.model_description.ModelDescription
        Its FMI 3.0 model description.
    unzip_dir : str
        The extracted FMU.
    name : str
        The instance name.

    Attributes
    ----------
    slave : fmpy.fmi3.FMU3Slave
        fmpy's handle.
    description : fmpy.model_description.ModelDescription
        The description as FMI 2.0 scalars (:func:`scalar_description`).
    clocked : bool
        It has input clocks, driven in Event Mode.

    Raises
    ------
    MasterError
        A clock the master cannot drive: one that is not an input, or whose interval is not
        known in Initialization Mode (a triggered or countdown clock).
    """

    def __init__(self, md: Any, unzip_dir: str, name: str) -> None:
        self.name = name
        view = scalar_description(md)
        self.description = view.description
        self._elements = view.elements
        for clock in view.clocks:
            if clock.causality != "input" or clock.intervalVariability not in ("constant", "fixed", "tunable"):
                raise MasterError(
                    f"FMU instance {name!r}: clock {clock.name!r} ({clock.causality}, interval "
                    f"{clock.intervalVariability}) is not a periodic input clock; the master drives those only")
        self._clocks = (fmi3ValueReference * len(view.clocks))(*[c.valueReference for c in view.clocks])
        self.clocked = bool(view.clocks)
        self._schedule: list[tuple[float, float, int]] = []  # per clock: (first instant, interval, count done)
        self._start = 0.0
        self._plans: dict[bytes, _Plan] = {}
        self._shadow: dict[int, np.ndarray] = {}
        self._reset_shadow()
        self.slave = FMU3Slave(guid=md.guid, unzipDirectory=unzip_dir,
                               modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)

    # ------------------------------------------------------------------ values
    def _reset_shadow(self) -> None:
        """The held copy of each variable the master may set: its start values."""
        self._shadow = {}
        for e in self._elements:
            var = e.variable
            kind = TYPES.get(var.type)
            if var.causality not in ("parameter", "input") or kind is None or var.valueReference in self._shadow:
                continue
            n = math.prod(_size(var)) if var.dimensions else 1
            tokens = var.start.split() if isinstance(var.start, str) else []
            values: np.ndarray = np.zeros(n, dtype=_DTYPES[kind])
            for i, tok in enumerate(tokens[:n]):
                values[i] = tok.lower() == "true" if kind == "Boolean" else float(tok)
            if len(tokens) == 1 and n > 1:
                values[:] = values[0]
            self._shadow[var.valueReference] = values

    def _plan(self, refs: Any) -> _Plan:
        key = bytes(refs)
        plan = self._plans.get(key)
        if plan is None:
            variables: list[Any] = []
            for r in refs:
                var = self._elements[r].variable
                if all(v is not var for v in variables):
                    variables.append(var)
            spans, start = [], 0
            for var in variables:
                n = math.prod(_size(var)) if var.dimensions else 1
                spans.append((start, start + n))
                start += n
            first = {id(v): s[0] for v, s in zip(variables, spans)}
            positions = np.array([first[id(self._elements[r].variable)] + self._elements[r].offset for r in refs],
                                 dtype=np.intp)
            plan = _Plan((fmi3ValueReference * len(variables))(*[v.valueReference for v in variables]),
                         (ctypes.c_double * start)(), positions, variables, spans)
            self._plans[key] = plan
        return plan

    def get_reals(self, refs: Any, buf: Any) -> None:
        plan = self._plan(refs)
        self.slave.fmi3GetFloat64(self.slave.component, plan.refs, len(plan.refs), plan.values, len(plan.values))
        np.frombuffer(buf, dtype=np.float64)[:] = np.frombuffer(plan.values, dtype=np.float64)[plan.positions]

    def set_reals(self, refs: Any, buf: Any) -> None:
        plan = self._plan(refs)
        values = np.frombuffer(plan.values, dtype=np.float64)
        for var, (a, b) in zip(plan.variables, plan.spans):
            values[a:b] = self._shadow[var.valueReference]
        values[plan.positions] = np.frombuffer(buf, dtype=np.float64)
        self.slave.fmi3SetFloat64(self.slave.component, plan.refs, len(plan.refs), plan.values, len(plan.values))
        for var, (a, b) in zip(plan.variables, plan.spans):
            self._shadow[var.valueReference][:] = values[a:b]

    def set_values(self, kind: str, refs: list[int], values: list[Any]) -> None:
        touched: list[Any] = []
        for r, value in zip(refs, values):
            e = self._elements[r]
            self._shadow[e.variable.valueReference][e.offset] = value
            if all(v is not e.variable for v in touched):
                touched.append(e.variable)
        setter = {"Real": self.slave.setFloat64, "Integer": self.slave.setInt32, "Boolean": self.slave.setBoolean}[kind]
        for var in touched:
            setter([var.valueReference], self._shadow[var.valueReference].tolist())

    # ------------------------------------------------------------------ life cycle
    def instantiate(self, callbacks: fmi_host.Callbacks) -> None:
        self.slave.instantiate(loggingOn=True, eventModeUsed=self.clocked, earlyReturnAllowed=False,
                               logMessage=callbacks.fmi3_logger(self.name))
        self._reset_shadow()

    def initialize(self, start: float, stop: float) -> None:
        self.slave.enterInitializationMode(startTime=start, stopTime=stop)
        self._start = start
        self._schedule = []
        if self.clocked:
            n = len(self._clocks)
            intervals, qualifiers, shifts = (fmi3Float64 * n)(), (ctypes.c_int * n)(), (fmi3Float64 * n)()
            self.slave.getIntervalDecimal(self._clocks, intervals, qualifiers)
            self.slave.getShiftDecimal(self._clocks, shifts)
            for i in range(n):
                if not (intervals[i] > 0.0 and math.isfinite(intervals[i]) and math.isfinite(shifts[i])):
                    raise MasterError(f"FMU instance {self.name!r}: clock {i} has interval {intervals[i]} s and "
                                      f"shift {shifts[i]} s; the master needs a finite interval > 0")
                self._schedule.append((start + shifts[i], intervals[i], 0))

    def exit_initialization(self) -> None:
        self.slave.exitInitializationMode()
        if self.clocked:
            self._schedule = [(first, interval, max(0, math.floor((self._start - first) / interval) + 1)
                               if first <= self._start + instant_tolerance(self._start) else 0)
                              for first, interval, _ in self._schedule]
            self.leave_event()

    def _next_instant(self) -> float:
        return min((first + n * interval for first, interval, n in self._schedule), default=math.inf)

    def instant_at(self, t: float) -> bool:
        """Whether a clock of this instance ticks at ``t`` (within :func:`instant_tolerance`).

        Parameters
        ----------
        t : float
            A communication point, s.
        """
        return self.clocked and abs(self._next_instant() - t) <= instant_tolerance(t)

    def enter_event(self) -> None:
        """``fmi3EnterEventMode``."""
        self.slave.enterEventMode()

    def activate(self) -> None:
        """``fmi3SetClock`` of the clocks that tick at the FMU's time (Event Mode)."""
        t = self._next_instant()
        due = []
        for i, (first, interval, n) in enumerate(self._schedule):
            if abs(first + n * interval - t) <= instant_tolerance(t):
                due.append(self._clocks[i])
                self._schedule[i] = (first, interval, n + 1)
        refs = (fmi3ValueReference * len(due))(*due)
        self.slave.fmi3SetClock(self.slave.component, refs, len(due), (ctypes.c_bool * len(due))(*[True] * len(due)))

    def leave_event(self) -> None:
        """``fmi3UpdateDiscreteStates`` (once: these FMUs need no iteration) and ``fmi3EnterStepMode``.

        Raises
        ------
        MasterError
            If the FMU asks for another update or to terminate.
        """
        need = ctypes.c_bool()
        terminate = ctypes.c_bool()
        flags = [ctypes.c_bool() for _ in range(3)]
        next_time = fmi3Float64()
        self.slave.fmi3UpdateDiscreteStates(self.slave.component, ctypes.byref(need), ctypes.byref(terminate),
                                            *[ctypes.byref(f) for f in flags], ctypes.byref(next_time))
        if need.value or terminate.value:
            raise MasterError(f"FMU instance {self.name!r} asks for "
                              f"{'another discrete update' if need.value else 'the end of the simulation'} in Event "
                              "Mode; the master updates once")
        self.slave.enterStepMode()

    def step(self, t: float, h: float) -> None:
        # an instant inside the step ends a step there; the clocks tick with the step's inputs held
        now, end = t, t + h
        while self.clocked and self._next_instant() < end - instant_tolerance(end):
            instant = self._next_instant()
            self._do_step(now, instant - now)
            now = instant
            self.enter_event()
            self.activate()
            self.leave_event()
        self._do_step(now, h if now == t else end - now)

    def _do_step(self, t: float, h: float) -> None:
        event, terminate, early = ctypes.c_bool(), ctypes.c_bool(), ctypes.c_bool()
        reached = fmi3Float64()
        self.slave.fmi3DoStep(self.slave.component, t, h, True, ctypes.byref(event), ctypes.byref(terminate),
                              ctypes.byref(early), ctypes.byref(reached))
        if early.value or terminate.value:
            raise FMICallException(function="fmi3DoStep", status=fmi_host.ERROR)

    def reset(self) -> None:
        self.slave.reset()
        self._reset_shadow()  # the held copies back at the start values, as the instance's

    def free(self) -> None:
        self.slave.fmi3FreeInstance(self.slave.component)


def open_instance(md: Any, unzip_dir: str, name: str) -> Instance:
    """The instance for ``md``'s FMI version.

    Parameters
    ----------
    md : fmpy.model_description.ModelDescription
        The FMU's description.
    unzip_dir : str
        The extracted FMU.
    name : str
        The instance name.

    Raises
    ------
    MasterError
        An FMU without co-simulation, of another FMI version, or with a clock the master cannot drive.
    """
    if md.coSimulation is None:
        raise MasterError(f"FMU instance {name!r}: {md.modelName} has no co-simulation interface "
                          "(the master runs co-simulation FMUs)")
    if md.fmiVersion == "2.0":
        return Fmi2Instance(md, unzip_dir, name)
    if md.fmiVersion.startswith("3."):
        return Fmi3Instance(md, unzip_dir, name)
    raise MasterError(f"FMU instance {name!r}: FMI {md.fmiVersion} is not supported (FMI 2.0 and 3.0 are)")
