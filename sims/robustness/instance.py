"""One FMU instance in a worker: the FMI calls of the cases, the tracked FMI state, the outcome."""
from __future__ import annotations

import math
import struct
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

from fmpy.fmi2 import FMU2Slave, fmi2Boolean, fmi2Integer, fmi2Real, fmi2ValueReference

from satfmu.sims.cosim import fmi_host
from satfmu.sims.cosim.fmi_host import ERROR, FATAL, OK, STATUS_NAMES as _FMI_STATUS_NAMES
from satfmu.sims.robustness.target import Target, Var
from satfmu.fmus.errors import CaseBroken

NO_RESULT = -1
"""Outcome status of a case that failed before or without the call under test."""
STATUS_NAMES = {**_FMI_STATUS_NAMES, NO_RESULT: "-"}


def short(text: str, n: int) -> str:
    """``text`` on one line, cut to ``n`` characters.

    Parameters
    ----------
    text : str
        Any text (a log, several lines).
    n : int
        Most characters of the result (a cut text ends with ``...``).
    """
    text = " ".join(text.split())
    return text if len(text) <= n else text[:n - 3] + "..."


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
        self.callbacks = fmi_host.Callbacks()
        self.log = self.callbacks.log
        self.dead = False  # returned fmi2Fatal: no further call
        self.mode = "Instantiated"  # FMI state after the successful calls made so far
        self.time = 0.0  # FMU time in s after those calls

        self.slave = FMU2Slave(guid=target.guid, unzipDirectory=unzip, modelIdentifier=target.model_identifier,
                               instanceName="robustness")
        self.instantiate()

    def instantiate(self) -> None:
        """fmi2Instantiate, logging off (both backends log every refusal)."""
        self.slave.instantiate(callbacks=self.callbacks.functions, loggingOn=False)
        self.mode, self.time = "Instantiated", 0.0

    def free(self) -> None:
        """fmi2FreeInstance, unless the instance returned fmi2Fatal (then it is abandoned)."""
        if self.dead:
            fmi_host.abandon(self)
        else:
            self.slave.fmi2FreeInstance(self.slave.component)

    def text(self, since: int = 0) -> str:
        """The log messages from index ``since`` on, one per line.

        Parameters
        ----------
        since : int
            Index of the first message (``len(inst.log)`` before the calls of interest).
        """
        return self.callbacks.text(since)

    def call(self, fn: str, *args: Any) -> int:
        """Call ``fmi2<fn>(component, *args)``; returns its status (fmi2Fatal marks the instance dead).

        Parameters
        ----------
        fn : str
            The FMI 2.0 function without its ``fmi2`` prefix (``"DoStep"``); its arguments after
            the component follow as ``*args`` (ctypes values).
        """
        status = fmi_host.call(self.slave, fn, *args)
        if status == FATAL:
            self.dead = True
        return status

    def need(self, fn: str, *args: Any) -> None:
        """:meth:`call` that must return fmi2OK, else :class:`CaseBroken`.

        Parameters
        ----------
        fn : str
            The FMI 2.0 function without its ``fmi2`` prefix; its arguments follow as ``*args``.
        """
        status = self.call(fn, *args)
        if status != OK:
            raise CaseBroken(f"fmi2{fn} returned {STATUS_NAMES.get(status, status)}: {self.text()[-300:]!r}")

    def set(self, var: Var, value: float, as_type: str | None = None) -> int:
        """Set ``var`` to ``value`` with the setter of ``as_type`` (default: its own type); returns the status.

        Parameters
        ----------
        var : Var
            The variable (its value reference is used).
        value : float
            The value, in the variable's unit; cast to the setter's type (float, int or bool).
        as_type : {"Real", "Integer", "Boolean"}, optional
            Which fmi2Set function to call (default: that of ``var.type``).
        """
        kind = as_type or var.type
        ctype, cast = {"Real": (fmi2Real, float), "Integer": (fmi2Integer, int), "Boolean": (fmi2Boolean, bool)}[kind]
        return self.call("Set" + kind, (fmi2ValueReference * 1)(var.vr), 1, (ctype * 1)(cast(value)))

    def get(self, var: Var) -> tuple[int, float]:
        """Read ``var`` with the getter of its type; returns (status, value as float).

        Parameters
        ----------
        var : Var
            The variable to read.
        """
        ctype = {"Real": fmi2Real, "Integer": fmi2Integer, "Boolean": fmi2Boolean}[var.type]
        out = (ctype * 1)()
        status = self.call("Get" + var.type, (fmi2ValueReference * 1)(var.vr), 1, out)
        return status, float(out[0])

    def value(self, var: Var) -> float:
        """:meth:`get` that must succeed (else :class:`CaseBroken`); returns the value.

        Parameters
        ----------
        var : Var
            The variable to read.
        """
        status, value = self.get(var)
        if status != OK:
            raise CaseBroken(f"get '{var.name}' returned {STATUS_NAMES.get(status, status)}")
        return value

    def outputs(self) -> list[float]:
        """Every Real output (they must be readable)."""
        return [self.value(v) for v in self.target.outputs]

    def enter(self, start_time: float = 0.0) -> None:
        """fmi2SetupExperiment at ``start_time`` (s, no stop time) and fmi2EnterInitializationMode.

        Parameters
        ----------
        start_time : float
            Start time of the experiment, s.
        """
        self.need("SetupExperiment", 0, 0.0, start_time, 0, 0.0)
        self.need("EnterInitializationMode")
        self.mode, self.time = "InitializationMode", start_time

    def exit(self) -> None:
        """fmi2ExitInitializationMode."""
        self.need("ExitInitializationMode")
        self.mode = "StepComplete"

    def initialize(self, start_time: float = 0.0) -> None:
        """From Instantiated to StepComplete with the default values, from ``start_time`` (s).

        Parameters
        ----------
        start_time : float
            Start time of the experiment, s.
        """
        self.enter(start_time)
        self.exit()

    def renew(self) -> None:
        """A fresh instance in Instantiated: this one freed (abandoned after fmi2Fatal) and
        instantiated again on the same loaded library."""
        self.free()
        self.dead = False
        self.instantiate()

    def step(self, h: float | None = None) -> int:
        """fmi2DoStep of ``h`` s (default: the default step size) from the tracked FMU time.

        Parameters
        ----------
        h : float, optional
            Communication step size, s (default: the target's default step size); the tracked
            time advances by it when the step returns fmi2OK.
        """
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
    not_applicable : str
        Non-empty: the case found it cannot apply to this FMU (the reason; the row is n/a).
    """

    status: int = OK
    log: str = ""
    detail: str = ""
    problems: list[str] = field(default_factory=list)
    metrics: dict[str, float] = field(default_factory=dict)
    not_applicable: str = ""


def bits(values: Sequence[float]) -> bytes:
    """The IEEE 754 bit patterns of ``values`` (NaN and -0.0 compare exactly).

    Parameters
    ----------
    values : sequence of float
        The values (outputs, in their units).
    """
    return struct.pack(f"<{len(values)}d", *values)


def recover(inst: Instance, out: Outcome) -> None:
    """After a native fmi2Error: the instance must carry on normally (else a problem of ``out``).

    Parameters
    ----------
    inst : Instance
        The instance that refused a call (:meth:`Instance.carry_on` is run on it).
    out : Outcome
        The outcome of the case; a failure to carry on is appended to its ``problems``.
    """
    try:
        inst.carry_on()
    except CaseBroken as exc:
        out.problems.append(str(exc))


def reject(inst: Instance, fn: Callable[[], int], probe: Var | None = None) -> Outcome:
    """Make the call under test ``fn`` on ``inst``; if it was rejected (fmi2Error), check that
    ``probe`` (if given) kept its value and that the instance carries on normally.

    Parameters
    ----------
    inst : Instance
        The instance under test.
    fn : callable
        The call under test, ``fn() -> status``.
    probe : Var, optional
        The variable the call tried to set: read before and after, it must be unchanged (bit
        for bit) when the call was refused.

    Returns
    -------
    Outcome
        The call's status and log, and the problems found.
    """
    before = inst.value(probe) if probe is not None else None
    n = len(inst.log)
    status = fn()
    out = Outcome(status=status, log=inst.text(n))
    if status == ERROR:
        if probe is not None and before is not None:  # before is probe's value
            after = inst.value(probe)
            if bits([after]) != bits([before]):
                out.problems.append(f"'{probe.name}' changed from {before!r} to {after!r}")
        recover(inst, out)
    return out


def chosen(var: Var | None) -> Var:
    """The variable a case abuses, which must exist.

    Parameters
    ----------
    var : Var or None
        The target's variable for the case (:class:`~satfmu.sims.robustness.target.Target`), None
        when the FMU has none.

    Raises
    ------
    CaseBroken
        ``var`` is None (the parent does not run such a case: it is n/a).
    """
    if var is None:  # the parent does not run a case whose variable is missing
        raise CaseBroken("no variable for this case")
    return var

