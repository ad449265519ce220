"""The limit cases of issue 26 (items 2, 9, 10): huge steps, large start times, status queries in
every state, fmi2Terminate in the error state, outputs at extreme times and degenerate times.

Each case drives one :class:`~satfmu.sims.robustness.instance.Instance`; the parent judges the outcome
against :data:`satfmu.sims.robustness.table.CASES`.
"""
from __future__ import annotations

import ctypes
import math
import sys
import time
from collections.abc import Callable, Sequence

from fmpy.fmi2 import fmi2Boolean, fmi2Integer, fmi2Real, fmi2String

from satfmu.sims.cosim.fmi_host import DISCARD
from satfmu.sims.robustness.cases import STEPS, _drive, _read_outputs
from satfmu.sims.robustness.instance import (ERROR, NO_RESULT, OK, STATUS_NAMES, CaseBroken, Instance, Outcome,
                                      recover, short)
from satfmu.sims.robustness.target import TIME_ORIGINS, TIME_OUTPUTS, Target

DBL_MAX = sys.float_info.max
HUGE_STEPS = (1e9, 1e12, 1e30, DBL_MAX)
"""Step sizes of the huge-step case, s (issue 26 item 2: B-dot took ~30 s at 1e9, never returned at 1e30)."""
MIN_PERIOD_STEPS = (100.0,) + HUGE_STEPS
"""Step sizes at the minimum sample period, s (100 s took > 10 s at 1e-6 s)."""
STEP_TIME_LIMIT_S = 1.0
"""Longest accepted CPU time of one huge step, s (CPU time of the worker, so other processes on the
machine do not count): the native work bounds (MAX_STEP_INSTANTS, MAX_STEP_SUBSTEPS of
fmus/c/satfmu_core.h) allow ~0.7 s at most on the machine that measured them."""
LARGE_STARTS = (1e9, 1.4e9)
"""Large start times, s (Unix and GPS seconds are 1.4e9 to 1.7e9)."""
OFFSETS = (1e-3, 1e-2, 0.1, 1.0)
"""Communication points off the FMU time at t = 1e9 s, s (issue 26 item 9: 1 s was accepted)."""
OUTPUT_REL = 1e-12
"""Relative agreement of the outputs of a run from a large start time with the run from 0, to the
largest output: rounding only (a time-invariant FMU repeats them exactly)."""
TIME_ULPS = 64
"""A time-dependent output at t0 + x can only be as exact as the time itself: its difference may
reach this many units in the last place of t0 times its rate of change (measured on the run
from 0 as the largest step-to-step change over the step). The times differ by ~2 ulp (the master
computes t0 + k h, the FMU t_{k-1} + h) and the orbit-time parameter shifted by -t0 adds rounding
to every evaluation of the orbit time."""
STATUS_KINDS = {0: "fmi2DoStepStatus", 1: "fmi2PendingStatus", 2: "fmi2LastSuccessfulTime", 3: "fmi2Terminated"}
STATUS_FUNCTIONS = {"GetStatus": ctypes.c_int, "GetRealStatus": fmi2Real, "GetIntegerStatus": fmi2Integer,
                    "GetBooleanStatus": fmi2Boolean, "GetStringStatus": fmi2String}
PROVIDED = {("GetRealStatus", 2), ("GetBooleanStatus", 3)}
"""The statuses the native FMUs provide (fmi2LastSuccessfulTime, fmi2Terminated); every other pair
is not provided: fmi2Discard."""
STATUS_STATES = ("Instantiated", "InitializationMode", "StepComplete", "Terminated", "Error")
"""The FMI states of the status-query cases, one case each (:func:`status_queries`)."""


# ----------------------------------------------------------------------------- huge steps
def _huge(inst: Instance, steps: Sequence[float], minimum_period: bool) -> Outcome:
    """One fresh instance per step size of ``steps``: initialize (the sample period at its declared
    minimum if ``minimum_period``), one step, read the outputs. The outcome's status is the first
    one that is not fmi2OK; each step must take at most :data:`STEP_TIME_LIMIT_S`."""
    out = Outcome()
    notes, logs = [], []
    for i, h in enumerate(steps):
        if i:
            inst.renew()
        inst.enter()
        if minimum_period:
            period = inst.target.period
            assert period is not None and period.min is not None  # the parent runs the case only then
            if inst.set(period, period.min) != OK:
                raise CaseBroken(f"setting '{period.name}' to its minimum {period.min:g} s failed: "
                                 f"{inst.text()[-200:]!r}")
        inst.exit()
        n = len(inst.log)
        started = time.process_time()
        status = inst.step(h)
        took = time.process_time() - started
        if status == OK:
            status, ys = _read_outputs(inst)
            bad = [v.name for v, y in zip(inst.target.outputs, ys) if not math.isfinite(y)]
            if bad:
                out.problems.append(f"h = {h:g} s: non-finite outputs {bad} with fmi2OK")
        notes.append(f"h = {h:g} s: {STATUS_NAMES.get(status)} in {took * 1e3:.1f} ms CPU")
        out.metrics[f"step_ms_{h:g}"] = took * 1e3
        if took > STEP_TIME_LIMIT_S:
            out.problems.append(f"h = {h:g} s took {took:.2f} s > {STEP_TIME_LIMIT_S:g} s")
        if status != OK:
            logs.append(inst.text(n))
            notes[-1] += f" ({short(inst.text(n), 120)})"
            if out.status == OK:
                out.status = status
            if status == ERROR:
                inst.mode = "Error"  # a refused step changes nothing, a failed one leaves the error state
                recover(inst, out)
    out.log = "\n".join(logs)
    out.detail = "; ".join(notes)
    return out


def huge_steps(inst: Instance) -> Outcome:
    """One step of each of :data:`HUGE_STEPS` (1e9 s to DBL_MAX s), each on a new instance from
    the default start: finite outputs or a clean refusal, each step within
    :data:`STEP_TIME_LIMIT_S` of CPU time.

    Parameters
    ----------
    inst : Instance
        The instance under test, freshly instantiated (the worker makes one per case).

    Returns
    -------
    Outcome
        The first status that is not fmi2OK; the CPU time of each step in ``step_ms_<h>`` (ms).
    """
    return _huge(inst, HUGE_STEPS, minimum_period=False)


def huge_steps_minimum_period(inst: Instance) -> Outcome:
    """As :func:`huge_steps`, with the steps of :data:`MIN_PERIOD_STEPS` and the sample-period
    parameter set to its declared minimum (the most sample instants per step).

    Parameters
    ----------
    inst : Instance
        The instance under test, freshly instantiated (the worker makes one per case).

    Returns
    -------
    Outcome
        The first status that is not fmi2OK; the CPU time of each step in ``step_ms_<h>`` (ms).
    """
    return _huge(inst, MIN_PERIOD_STEPS, minimum_period=True)


def needs_period(target: Target) -> str | None:
    """Applicability: a sample-period parameter with a declared minimum.

    Parameters
    ----------
    target : Target
        The FMU under test.

    Returns
    -------
    str or None
        None if the case applies, else why not.
    """
    p = target.period
    return None if p is not None and p.min is not None else "no sample period parameter"


# ----------------------------------------------------------------------------- start time
def _run_from(inst: Instance, t0: float) -> list[list[float]]:
    """Initialize at ``t0`` with the time-origin parameters (:data:`TIME_ORIGINS`) moved with it,
    then :data:`STEPS` driven default steps (times t0 + k h, as a master computes them); the
    outputs before each (after its inputs are set) and after the last."""
    inst.enter(t0)
    for var in inst.target.parameters:
        sign = TIME_ORIGINS.get(var.name)
        if sign is not None and var.type == "Real":
            if inst.set(var, (var.start or 0.0) + sign * t0) != OK:
                raise CaseBroken(f"moving '{var.name}' by {sign * t0:g} s failed: {inst.text()[-200:]!r}")
    inst.exit()
    h, rows = inst.target.step, []
    for k in range(STEPS):
        _drive(inst, k)
        rows.append(inst.outputs())  # at t0 + k h with the inputs set there (a master's feedthrough read)
        status = inst.call("DoStep", t0 + k * h, h, 1)
        if status != OK:
            raise CaseBroken(f"step {k} from t0 = {t0:g} s returned {STATUS_NAMES.get(status)}: {inst.text()[-300:]!r}")
    rows.append(inst.outputs())
    return rows


def large_start(inst: Instance) -> Outcome:
    """The same :data:`~satfmu.sims.robustness.cases.STEPS` driven steps from t0 = 0 and from each
    of :data:`LARGE_STARTS`: the outputs must agree to :data:`OUTPUT_REL` of the largest output
    plus :data:`TIME_ULPS` ulp(t0) times each output's rate of change (an instant,
    :data:`~satfmu.sims.robustness.target.TIME_OUTPUTS`, less t0).

    Parameters
    ----------
    inst : Instance
        The instance under test, freshly instantiated (the worker makes one per case).

    Returns
    -------
    Outcome
    """
    ref = _run_from(inst, 0.0)
    h = inst.target.step
    scale = max([abs(y) for row in ref for y in row] + [0.0])
    rate = [max([abs(b[j] - a[j]) for a, b in zip(ref, ref[1:])] + [0.0]) / h for j in range(len(inst.target.outputs))]
    out = Outcome()
    notes = []
    for t0 in LARGE_STARTS:
        inst.renew()
        rows = _run_from(inst, t0)
        shifted = [j for j, var in enumerate(inst.target.outputs) if var.name in TIME_OUTPUTS]
        rows = [[y - t0 if j in shifted else y for j, y in enumerate(row)] for row in rows]
        worst, where = 0.0, ""
        for k, (a, b) in enumerate(zip(ref, rows)):
            for j, (ya, yb) in enumerate(zip(a, b)):
                tol = OUTPUT_REL * scale + TIME_ULPS * math.ulp(t0) * rate[j]
                excess = abs(yb - ya) - tol
                if excess > 0 and (not where or excess > worst):
                    worst, where = excess, f"'{inst.target.outputs[j].name}' at step {k + 1}: {yb!r} vs {ya!r}"
        same = all(a == b for a, b in zip(ref, rows))
        notes.append(f"t0 = {t0:g} s: {'identical' if same else 'within tolerance' if not where else 'DIFFERENT'}")
        if where:
            out.problems.append(f"outputs differ from the run from t0 = 0 at t0 = {t0:g} s: {where}")
    out.detail = f"{STEPS} steps of {h:g} s; " + "; ".join(notes)
    return out


def offset_point(inst: Instance) -> Outcome:
    """At t = 1e9 s (after one step), fmi2DoStep from points :data:`OFFSETS` off the FMU time: each
    must be refused (native: the time unchanged, a correct step still works).

    Parameters
    ----------
    inst : Instance
        The instance under test, freshly instantiated (the worker makes one per case).

    Returns
    -------
    Outcome
        The first status that is not fmi2Error (fmi2Error if every one was refused).
    """
    t0 = LARGE_STARTS[0]
    inst.initialize(t0)
    if inst.step() != OK:
        raise CaseBroken(f"a normal step at t = {t0:g} s failed: {inst.text()[-300:]!r}")
    out, notes, logs, statuses = Outcome(), [], [], []
    for delta in OFFSETS:
        if inst.dead:
            inst.renew()
            inst.initialize(t0)
        n = len(inst.log)
        status = inst.call("DoStep", inst.time + delta, inst.target.step, 1)
        if status == OK:
            inst.time += delta + inst.target.step  # the FMU took the communication point as its time
        notes.append(f"{delta:g} s off: {STATUS_NAMES.get(status)}")
        logs.append(inst.text(n))
        statuses.append(status)
    out.status = next((st for st in statuses if st != ERROR), ERROR)  # the first that is not a refusal
    out.log = "\n".join(logs)
    out.detail = f"at t = {t0:g} s: " + "; ".join(notes)
    if out.status == ERROR:
        recover(inst, out)
    return out


# ----------------------------------------------------------------------------- status queries
def _query(inst: Instance, fn: str, kind: int) -> tuple[int, object]:
    value = STATUS_FUNCTIONS[fn]()
    status = inst.call(fn, kind, ctypes.byref(value))
    return status, value.value


def required_status(state: str, fn: str, kind: int) -> int:
    """The status FMI 2.0 requires of a native FMU for ``fmi2<fn>(kind)`` in ``state``: fmi2Error
    outside stepComplete and terminated (the co-simulation state table), there fmi2OK for the
    statuses the FMU provides (:data:`PROVIDED`) and fmi2Discard ("cannot be retrieved") for the
    others.

    Parameters
    ----------
    state : {"Instantiated", "InitializationMode", "StepComplete", "Terminated", "Error"}
        The FMI state of the instance (:data:`STATUS_STATES`).
    fn : str
        The status function without its ``fmi2`` prefix (``"GetRealStatus"``).
    kind : int
        The ``fmi2StatusKind``: 0 fmi2DoStepStatus, 1 fmi2PendingStatus, 2 fmi2LastSuccessfulTime,
        3 fmi2Terminated.

    Returns
    -------
    int
        The required status (fmi2OK, fmi2Discard or fmi2Error).
    """
    if state not in ("StepComplete", "Terminated"):
        return ERROR
    return OK if (fn, kind) in PROVIDED else DISCARD


def _reach(inst: Instance, state: str) -> str:
    """Bring ``inst`` to ``state``; returns "" or why it cannot (the case is then n/a)."""
    if state == "Instantiated":
        return ""
    if state == "Error":
        return reach_error(inst)
    inst.enter()
    if state == "InitializationMode":
        return ""
    inst.exit()
    if inst.step() != OK:
        raise CaseBroken(f"a normal step failed: {inst.text()[-300:]!r}")
    if state == "Terminated":
        inst.terminate()
    return ""


def status_queries(state: str) -> Callable[[Instance], Outcome]:
    """Every status function with every fmi2StatusKind in ``state``; the outcome's status is OK when
    each returned what :func:`required_status` says (and fmi2LastSuccessfulTime the FMU time,
    fmi2Terminated false), else the first wrong status.

    Parameters
    ----------
    state : {"Instantiated", "InitializationMode", "StepComplete", "Terminated", "Error"}
        The FMI state the case brings the instance to before the queries (:data:`STATUS_STATES`;
        the error state by :func:`reach_error`, n/a when it cannot be reached).

    Returns
    -------
    callable
        The case, ``case(inst) -> Outcome``.
    """
    def case(inst: Instance) -> Outcome:
        why = _reach(inst, state)
        if why:
            return Outcome(status=NO_RESULT, not_applicable=why)
        out, wrong, seen = Outcome(), [], {}
        for fn in STATUS_FUNCTIONS:
            for kind, kind_name in STATUS_KINDS.items():
                if inst.dead:  # fmi2Fatal: no further call is allowed (the rest is not asked)
                    wrong.append(f"{fn}({kind_name}) not asked after fmi2Fatal")
                    continue
                status, value = _query(inst, fn, kind)
                want = required_status(state, fn, kind)
                seen[f"{fn}({kind_name})"] = STATUS_NAMES.get(status, str(status))
                if status != want:
                    wrong.append(f"{fn}({kind_name}) {STATUS_NAMES.get(status, status)}, required "
                                 f"{STATUS_NAMES.get(want)}")
                    if out.status == OK:
                        out.status = status
                elif status == OK and kind == 2 and value != inst.time:
                    out.problems.append(f"{fn}({kind_name}) = {value!r}, FMU time {inst.time!r}")
                elif status == OK and kind == 3 and value:
                    out.problems.append(f"{fn}({kind_name}) = true: the FMU asks to terminate")
        out.log = inst.text()
        out.metrics["wrong"] = len(wrong)
        groups: dict[str, list[str]] = {}
        for call, status_name in seen.items():
            groups.setdefault(status_name, []).append(call)
        out.detail = (f"in {state}: " + "; ".join(f"{s}: {len(c)}" for s, c in sorted(groups.items()))
                      + (f"; wrong: {', '.join(wrong[:6])}{' ...' if len(wrong) > 6 else ''}" if wrong else ""))
        return out
    return case


# ----------------------------------------------------------------------------- the error state
ERROR_TRIGGERS = ("every Real input = 1e300, one default step", "every Real parameter = 1e300 it accepts, one step",
                  "a step of DBL_MAX s")
"""How :func:`reach_error` drives an FMU into the error state, tried in this order."""


def _in_error(inst: Instance) -> bool:
    """Whether the instance is in the error state: a correct fmi2DoStep is refused as "in state Error"."""
    n = len(inst.log)
    status = inst.call("DoStep", inst.time, inst.target.step, 1)
    if status == OK:
        inst.time += inst.target.step
    return status == ERROR and "state Error" in inst.text(n)


def reach_error(inst: Instance) -> str:
    """Drive an instance into the error state (the first of :data:`ERROR_TRIGGERS` that does);
    returns "" or why it cannot.

    Parameters
    ----------
    inst : Instance
        The instance; made anew (:meth:`~satfmu.sims.robustness.instance.Instance.renew`) before
        each trigger.
    """
    for trigger in range(len(ERROR_TRIGGERS)):
        inst.renew()
        inst.enter()
        if trigger == 1:
            for var in inst.target.parameters:
                if var.type == "Real":
                    inst.set(var, 1e300)
        inst.exit()
        if trigger == 0:
            for var in inst.target.inputs:
                inst.set(var, 1e300)
        status = inst.step(DBL_MAX if trigger == 2 else None)
        if status == OK:
            _read_outputs(inst)
        if _in_error(inst):
            inst.mode = "Error"
            return ""
    return f"none of {len(ERROR_TRIGGERS)} triggers reaches the error state (no computation of it can fail)"


def terminate_in_error(inst: Instance) -> Outcome:
    """fmi2Terminate in the error state must be refused (FMI 2.0: reset or free it).

    Parameters
    ----------
    inst : Instance
        The instance under test, freshly instantiated (the worker makes one per case).

    Returns
    -------
    Outcome
        n/a when no trigger of :func:`reach_error` reaches the error state.
    """
    why = reach_error(inst)
    if why:
        return Outcome(status=NO_RESULT, not_applicable=why)
    n = len(inst.log)
    status = inst.call("Terminate")
    out = Outcome(status=status, log=inst.text(n), detail=f"fmi2Terminate in Error: {STATUS_NAMES.get(status)}")
    if status == ERROR:
        recover(inst, out)
    return out


# ----------------------------------------------------------------------------- non-finite outputs
def _finite_or_error(inst: Instance, what: str) -> Outcome:
    """Read every output: each read is fmi2OK with a finite value, or (native) fmi2Error."""
    n = len(inst.log)
    status, ys = _read_outputs(inst)
    out = Outcome(status=status, log=inst.text(n))
    bad = [v.name for v, y in zip(inst.target.outputs, ys) if not math.isfinite(y)]
    if status == OK and bad:
        out.problems.append(f"non-finite outputs {bad} with fmi2OK")
    out.detail = f"{what}: reading the outputs {STATUS_NAMES.get(status)}" + (
        f", non-finite {bad}" if bad else f" {short(out.log, 160)}" if status != OK else ", finite")
    if status == ERROR:
        inst.mode = "Error"
        recover(inst, out)
    return out


def start_at_max(inst: Instance) -> Outcome:
    """Start at t = DBL_MAX s (the largest time): the outputs there are finite or refused (or the
    start itself is, by fmi2ExitInitializationMode: sample instants that cannot be counted).

    Parameters
    ----------
    inst : Instance
        The instance under test, freshly instantiated (the worker makes one per case).

    Returns
    -------
    Outcome
    """
    inst.enter(DBL_MAX)
    n = len(inst.log)
    status = inst.call("ExitInitializationMode")
    if status != OK:
        out = Outcome(status=status, log=inst.text(n),
                      detail=f"fmi2ExitInitializationMode at DBL_MAX: {STATUS_NAMES.get(status)}: "
                             f"{short(inst.text(n), 160)}")
        if status == ERROR:
            inst.mode = "Error"  # refused in InitializationMode: carry on from a reset
            recover(inst, out)
        return out
    inst.mode = "StepComplete"
    return _finite_or_error(inst, "start at DBL_MAX")


def time_parameters_equal(inst: Instance) -> Outcome:
    """Every Real parameter in s without a declared range set to the first one's start value (a ramp
    with start = stop, a step at the start time), then :data:`~satfmu.sims.robustness.cases.STEPS`
    default steps: every output finite or refused after each.

    Parameters
    ----------
    inst : Instance
        The instance under test, freshly instantiated (the worker makes one per case).

    Returns
    -------
    Outcome
    """
    times = [v for v in inst.target.parameters if v.unit == "s" and v.type == "Real" and v.min is None
             and v.max is None]
    value = times[0].start or 0.0
    inst.enter()
    for var in times:
        if inst.set(var, value) != OK:
            raise CaseBroken(f"setting '{var.name}' = {value:g} s failed: {inst.text()[-200:]!r}")
    inst.exit()
    for k in range(STEPS):
        out = _finite_or_error(inst, f"{', '.join(v.name for v in times)} = {value:g} s, step {k}")
        if out.status != OK or out.problems:
            return out
        if inst.step() != OK:
            raise CaseBroken(f"a normal step failed: {inst.text()[-300:]!r}")
    return _finite_or_error(inst, f"{', '.join(v.name for v in times)} = {value:g} s, {STEPS} steps")


def needs_two_times(target: Target) -> str | None:
    """Applicability of :func:`time_parameters_equal`: two unranged Real parameters in s.

    Parameters
    ----------
    target : Target
        The FMU under test.

    Returns
    -------
    str or None
        None if the case applies, else why not.
    """
    times = [v for v in target.parameters if v.unit == "s" and v.type == "Real" and v.min is None and v.max is None]
    return None if len(times) >= 2 else "fewer than two time parameters"

