"""The worker side of the cases: each drives one :class:`~satfmu.sims.robustness.instance.Instance`."""
from __future__ import annotations

import math
import time
from collections.abc import Callable

from fmpy.fmi1 import FMICallException

from satfmu.sims.robustness.instance import (ERROR, FATAL, OK, STATUS_NAMES, CaseBroken, Instance, Outcome, bits,
                                      chosen, recover, reject, short)
from satfmu.sims.robustness.target import Var

HUGE = 1e300
"""A finite but huge value (no declared range of the project's inputs excludes it)."""
FAR_FACTOR = 1e4
"""The far step is this many default step sizes (slowest: the online SDRE pythonfmu controllers,
one Riccati solution per 0.01 s sample, ~5 s for this step)."""
UNKNOWN_VR = 1_000_000
"""A value reference no FMU of the project has (they number their variables from 0)."""
STEPS = 5
"""Communication steps before a snapshot and after it, in the FMU state round trip."""
DRIVE = 1e-3
"""Amplitude of the inputs' variation around their start values in the state round trip (in
each input's unit): small, since some controllers are singular away from their start (the VSCMG
controllers at gimbal angle q2 = 0) and some plants overflow for large inputs (the magnetorquer
CubeSat with 0.01 to 0.09 in every input)."""


def set_input(value: float) -> Callable[[Instance], Outcome]:
    """The case that sets the first Real input to ``value`` in StepComplete: the call must be
    refused, the input keep its value and the instance carry on.

    Parameters
    ----------
    value : float
        The value to set, in the input's unit (NaN, +inf or -inf in the case table).

    Returns
    -------
    callable
        The case, ``case(inst) -> Outcome`` (the ``run`` of a :class:`~satfmu.sims.robustness.table.Case`).
    """
    def case(inst: Instance) -> Outcome:
        var = chosen(inst.target.input)
        inst.initialize()
        return reject(inst, lambda: inst.set(var, value), var)
    return case


def set_parameter(value: float) -> Callable[[Instance], Outcome]:
    """The case that sets the first Real parameter to ``value`` in InitializationMode: the call
    must be refused, the parameter keep its value and the instance carry on.

    Parameters
    ----------
    value : float
        The value to set, in the parameter's unit (NaN, +inf or -inf in the case table).

    Returns
    -------
    callable
        The case, ``case(inst) -> Outcome`` (the ``run`` of a :class:`~satfmu.sims.robustness.table.Case`).
    """
    def case(inst: Instance) -> Outcome:
        var = chosen(inst.target.parameter)
        inst.enter()
        return reject(inst, lambda: inst.set(var, value), var)
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
        out = Outcome(status=status, log=inst.text(n), detail=f"set rejected: {short(inst.text(n), 200)}")
        if status == ERROR:
            recover(inst, out)
        return out
    if init_mode:
        inst.exit()
    return _step_and_read(inst, inst.target.step, f"'{var.name}' = {HUGE:g} accepted", finite=False)


def _read_outputs(inst: Instance) -> tuple[int, list[float]]:
    """Every Real output; stops at the first read that is not fmi2OK (returns its status)."""
    values: list[float] = []
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
    out.detail = done + (f": {short(out.log, 200)}" if out.status != OK else "")
    if out.status == ERROR:
        inst.mode = "Error"  # a step may fail after advancing part of the way: recover with fmi2Reset
        recover(inst, out)
    return out


def huge_input(inst: Instance) -> Outcome:
    """The first Real input set to :data:`HUGE` in StepComplete, then one default step and the
    outputs read (accepted, or refused with a clean message; overflowing outputs are recorded).

    Parameters
    ----------
    inst : Instance
        The instance under test, freshly instantiated (the worker makes one per case).

    Returns
    -------
    Outcome
        The status and log of the call under test, problems found afterwards.
    """
    return _huge(inst, chosen(inst.target.input), init_mode=False)


def huge_parameter(inst: Instance) -> Outcome:
    """The first Real parameter set to :data:`HUGE` in InitializationMode, then
    fmi2ExitInitializationMode, one default step and the outputs read.

    Parameters
    ----------
    inst : Instance
        The instance under test, freshly instantiated (the worker makes one per case).

    Returns
    -------
    Outcome
        The status and log of the call under test, problems found afterwards.
    """
    return _huge(inst, chosen(inst.target.parameter), init_mode=True)


def step_size(h_in_steps: float) -> Callable[[Instance], Outcome]:
    """The case of one fmi2DoStep of ``h_in_steps`` default step sizes in StepComplete (a zero or
    negative step, which must be refused).

    Parameters
    ----------
    h_in_steps : float
        The communication step size in default step sizes (0.0 and -1.0 in the case table).

    Returns
    -------
    callable
        The case, ``case(inst) -> Outcome`` (the ``run`` of a :class:`~satfmu.sims.robustness.table.Case`).
    """
    def case(inst: Instance) -> Outcome:
        inst.initialize()
        return reject(inst, lambda: inst.step(h_in_steps * inst.target.step))
    return case


def step_nan(inst: Instance) -> Outcome:
    """fmi2DoStep with a NaN communication step size in StepComplete: must be refused.

    Parameters
    ----------
    inst : Instance
        The instance under test, freshly instantiated (the worker makes one per case).

    Returns
    -------
    Outcome
        The status and log of the call under test, problems found afterwards.
    """
    inst.initialize()
    return reject(inst, lambda: inst.step(math.nan))


def step_wrong_time(inst: Instance) -> Outcome:
    """fmi2DoStep from a communication point 1 s after the FMU time (at t = 0 s): must be refused.

    Parameters
    ----------
    inst : Instance
        The instance under test, freshly instantiated (the worker makes one per case).

    Returns
    -------
    Outcome
        The status and log of the call under test, problems found afterwards.
    """
    inst.initialize()
    return reject(inst, lambda: inst.call("DoStep", inst.time + 1.0, inst.target.step, 1))


def far_step(inst: Instance, far_factor: float) -> Outcome:
    """One step of ``far_factor`` default step sizes from the default start, then the outputs read:
    accepted with finite outputs, or refused with a clean message.

    Parameters
    ----------
    inst : Instance
        The instance under test, freshly instantiated (the worker makes one per case).
    far_factor : float
        The step in default step sizes (:data:`FAR_FACTOR` unless the run's settings say
        otherwise, :class:`~satfmu.sims.robustness.table.Settings`).

    Returns
    -------
    Outcome
        The status and log of the call under test, problems found afterwards.
    """
    inst.initialize()
    return _step_and_read(inst, far_factor * inst.target.step, f"h = {far_factor:g} x {inst.target.step:g} s",
                          finite=True)


def step_before_init(inst: Instance) -> Outcome:
    """fmi2DoStep of the default step size in Instantiated: must be refused.

    Parameters
    ----------
    inst : Instance
        The instance under test, freshly instantiated (the worker makes one per case).

    Returns
    -------
    Outcome
        The status and log of the call under test, problems found afterwards.
    """
    return reject(inst, lambda: inst.step())


def get_before_init(inst: Instance) -> Outcome:
    """fmi2GetReal of the first Real output in Instantiated: must be refused.

    Parameters
    ----------
    inst : Instance
        The instance under test, freshly instantiated (the worker makes one per case).

    Returns
    -------
    Outcome
        The status and log of the call under test, problems found afterwards.
    """
    var = chosen(inst.target.outputs[0] if inst.target.outputs else None)
    return reject(inst, lambda: inst.get(var)[0])


def exit_without_enter(inst: Instance) -> Outcome:
    """fmi2ExitInitializationMode in Instantiated (no fmi2EnterInitializationMode before): must
    be refused.

    Parameters
    ----------
    inst : Instance
        The instance under test, freshly instantiated (the worker makes one per case).

    Returns
    -------
    Outcome
        The status and log of the call under test, problems found afterwards.
    """
    return reject(inst, lambda: inst.call("ExitInitializationMode"))


def exit_twice(inst: Instance) -> Outcome:
    """fmi2ExitInitializationMode a second time, in StepComplete: must be refused.

    Parameters
    ----------
    inst : Instance
        The instance under test, freshly instantiated (the worker makes one per case).

    Returns
    -------
    Outcome
        The status and log of the call under test, problems found afterwards.
    """
    inst.initialize()
    return reject(inst, lambda: inst.call("ExitInitializationMode"))


def enter_twice(inst: Instance) -> Outcome:
    """fmi2EnterInitializationMode a second time, in InitializationMode: must be refused.

    Parameters
    ----------
    inst : Instance
        The instance under test, freshly instantiated (the worker makes one per case).

    Returns
    -------
    Outcome
        The status and log of the call under test, problems found afterwards.
    """
    inst.enter()
    return reject(inst, lambda: inst.call("EnterInitializationMode"))


def setup_nan(inst: Instance) -> Outcome:
    """fmi2SetupExperiment with a NaN start time (no tolerance, no stop time): must be refused.

    Parameters
    ----------
    inst : Instance
        The instance under test, freshly instantiated (the worker makes one per case).

    Returns
    -------
    Outcome
        The status and log of the call under test, problems found afterwards.
    """
    return reject(inst, lambda: inst.call("SetupExperiment", 0, 0.0, math.nan, 0, 0.0))


def parameter_after_init(inst: Instance) -> Outcome:
    """The first non-tunable parameter set to its own value in StepComplete, where it may not be
    set: must be refused, the value kept.

    Parameters
    ----------
    inst : Instance
        The instance under test, freshly instantiated (the worker makes one per case).

    Returns
    -------
    Outcome
        The status and log of the call under test, problems found afterwards.
    """
    var = chosen(inst.target.fixed)
    inst.initialize()
    value = inst.value(var)
    # a legal value (its own) in a state where a fixed parameter may not be set
    return reject(inst, lambda: inst.set(var, value), var)


def set_after_terminate(inst: Instance) -> Outcome:
    """After one step and fmi2Terminate, the first Real input (else the first Real parameter, else
    the first non-tunable one) set to its own value: must be refused in Terminated.

    Parameters
    ----------
    inst : Instance
        The instance under test, freshly instantiated (the worker makes one per case).

    Returns
    -------
    Outcome
        The status and log of the call under test, problems found afterwards.
    """
    var = chosen(inst.target.input or inst.target.parameter or inst.target.fixed)
    inst.initialize()
    if inst.step() != OK:
        raise CaseBroken(f"a normal step failed: {inst.text()[-300:]!r}")
    inst.terminate()
    value = inst.value(var)
    return reject(inst, lambda: inst.set(var, value), var)


def step_after_terminate(inst: Instance) -> Outcome:
    """fmi2DoStep of the default step size in Terminated: must be refused.

    Parameters
    ----------
    inst : Instance
        The instance under test, freshly instantiated (the worker makes one per case).

    Returns
    -------
    Outcome
        The status and log of the call under test, problems found afterwards.
    """
    inst.initialize()
    inst.terminate()
    return reject(inst, lambda: inst.step())


def _outside(var: Var, below: bool) -> float:
    """A value outside ``var``'s declared range: one unit (or the bound's magnitude) beyond it."""
    bound = var.min if below else var.max
    assert bound is not None
    delta = 1.0 if var.type == "Integer" else max(1.0, abs(bound))
    return bound - delta if below else bound + delta


def out_of_range(below: bool) -> Callable[[Instance], Outcome]:
    """The case that sets a parameter outside its declared range in InitializationMode (one unit,
    or the bound's magnitude, beyond it): must be refused, the value kept.

    Parameters
    ----------
    below : bool
        True: the first parameter with a finite declared minimum, set below it; False: the first
        one with a finite declared maximum, set above it.

    Returns
    -------
    callable
        The case, ``case(inst) -> Outcome`` (the ``run`` of a :class:`~satfmu.sims.robustness.table.Case`).
    """
    def case(inst: Instance) -> Outcome:
        var = chosen(inst.target.below if below else inst.target.above)
        inst.enter()
        return reject(inst, lambda: inst.set(var, _outside(var, below)), var)
    return case


def real_on_non_real(inst: Instance) -> Outcome:
    """fmi2SetReal on the first Integer or Boolean parameter in InitializationMode: must be
    refused, the value kept.

    Parameters
    ----------
    inst : Instance
        The instance under test, freshly instantiated (the worker makes one per case).

    Returns
    -------
    Outcome
        The status and log of the call under test, problems found afterwards.
    """
    var = chosen(inst.target.non_real)
    inst.enter()
    return reject(inst, lambda: inst.set(var, 1.0, as_type="Real"), var)


def integer_on_real(inst: Instance) -> Outcome:
    """fmi2SetInteger on the first Real parameter in InitializationMode: must be refused, the
    value kept.

    Parameters
    ----------
    inst : Instance
        The instance under test, freshly instantiated (the worker makes one per case).

    Returns
    -------
    Outcome
        The status and log of the call under test, problems found afterwards.
    """
    var = chosen(inst.target.parameter)
    inst.enter()
    return reject(inst, lambda: inst.set(var, 1, as_type="Integer"), var)


def unknown_vr(fn: str) -> Callable[[Instance], Outcome]:
    """The case that sets or reads the Real of value reference :data:`UNKNOWN_VR`, which no FMU
    of the project has, in StepComplete: must be refused.

    Parameters
    ----------
    fn : {"set", "get"}
        ``"set"``: fmi2SetReal to 1.0; otherwise fmi2GetReal.

    Returns
    -------
    callable
        The case, ``case(inst) -> Outcome`` (the ``run`` of a :class:`~satfmu.sims.robustness.table.Case`).
    """
    def case(inst: Instance) -> Outcome:
        ghost = Var("(unknown)", UNKNOWN_VR, "Real", "input", "continuous", None, None, None)
        inst.initialize()
        return reject(inst, lambda: inst.set(ghost, 1.0) if fn == "set" else inst.get(ghost)[0])
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
        rows.append(bits(inst.outputs()))
    return rows


def state_round_trip(inst: Instance) -> Outcome:
    """Snapshot after :data:`STEPS` steps (through serialization when declared), step on, restore,
    step again with the same inputs: the outputs must repeat bit for bit.

    Parameters
    ----------
    inst : Instance
        The instance under test, freshly instantiated (the worker makes one per case).

    Returns
    -------
    Outcome
        The status and log of the call under test, problems found afterwards.
    """
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


