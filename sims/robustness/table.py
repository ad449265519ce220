"""The case table: every case, what it does, what each backend must answer, when it is n/a."""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from satfmu.sims.robustness import cases as worker_cases
from satfmu.sims.robustness.cases import FAR_FACTOR, STEPS, UNKNOWN_VR
from satfmu.sims.robustness.host_cases import host_cases
from satfmu.sims.robustness.instance import ERROR, OK, Outcome
from satfmu.sims.robustness.memory import RSS_PER_CYCLE_KIB, RSS_SLACK_KIB, cycles
from satfmu.sims.robustness.target import BACKENDS, NATIVE, PYTHONFMU, Target

CYCLES_CASE = "instantiate/free cycles"
FAR_CASE = "doStep far beyond default"
FLIPS_CASE = "FMU state: single-bit flips"
HUGE_CASES = ("doStep huge h", "doStep huge h, minimum period")
FULL_SCAN_BITS = 8 * 4096
"""Bits of a full bit-flip scan for its time limit (the largest native state: demeter_flexible's,
~2.4 KiB)."""


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


def rejected(*fragments: str) -> Expect:
    """A rejected call: fmi2Error with a message holding one of ``fragments``, the instance still
    usable."""
    return Expect((ERROR,), fragments, f"Error + '{fragments[0]}', usable after")


def ok_or_clean_error(*fragments: str) -> Expect:
    """Accepted, or rejected with one of ``fragments`` (usable afterwards); never a crash."""
    return Expect((OK, ERROR), fragments, f"OK or Error + '{' / '.join(fragments)}'")


def _same(fn: Callable[[str], Expect]) -> dict[str, Expect]:
    return {b: fn(b) for b in BACKENDS}


def _both(expect: Expect) -> dict[str, Expect]:
    return {b: expect for b in BACKENDS}


def _needs(attr: str, why: str) -> Callable[[Target], str | None]:
    """Applicability test: the target must have the variable ``attr`` (else "n/a: why")."""
    return lambda t: None if getattr(t, attr) else why


def always_applies(target: Target) -> str | None:
    """Applicability test of the cases that need no particular variable: never n/a.

    Parameters
    ----------
    target : Target
        The FMU under test.

    Returns
    -------
    None
        Never a reason to skip the case.
    """
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
        named in ``settings``; returns an :class:`~satfmu.sims.robustness.instance.Outcome`.
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
    flips : int or None
        Single-bit flips of a native FMU state per FMU (a seeded sample); None flips every bit.
    """

    cycles: int = 1000
    far_factor: float = FAR_FACTOR
    flips: int | None = None


NON_FINITE = "non-finite"
HUGE_FRAGMENTS: dict[str, tuple[str, ...]] = {
    NATIVE: ("non-finite", "outside its range", "substeps (limit", "sample at")}
"""Clean error messages of a huge value or step: overflow, range, substep limit, failed sample.
pythonfmu also raises Python's OverflowError where C gives inf (``x**2`` of 1e300 in the model
code), which pythonfmu reports with the exception's name."""
HUGE_FRAGMENTS[PYTHONFMU] = HUGE_FRAGMENTS[NATIVE] + ("OverflowError",)
NO_INPUT, NO_PARAMETER = "no Real input", "no Real parameter"


def _cases() -> tuple[Case, ...]:
    cases = []
    for label, value in (("nan", math.nan), ("+inf", math.inf), ("-inf", -math.inf)):
        cases.append(Case(f"input = {label}", f"setReal of the first Real input to {label} in StepComplete",
                          _both(rejected(NON_FINITE)), worker_cases.set_input(value), _needs("input", NO_INPUT)))
    cases.append(Case("input = 1e300", "setReal of the first Real input to 1e300, then a default step",
                      _same(lambda b: ok_or_clean_error(*HUGE_FRAGMENTS[b])), worker_cases.huge_input,
                      _needs("input", NO_INPUT)))
    for label, value in (("nan", math.nan), ("+inf", math.inf), ("-inf", -math.inf)):
        cases.append(Case(f"parameter = {label}", f"setReal of the first Real parameter to {label} in "
                          "InitializationMode", _both(rejected(NON_FINITE)), worker_cases.set_parameter(value),
                          _needs("parameter", NO_PARAMETER)))
    cases.append(Case("parameter = 1e300", "setReal of the first Real parameter to 1e300 in InitializationMode, "
                      "then a default step", _same(lambda b: ok_or_clean_error(*HUGE_FRAGMENTS[b])),
                      worker_cases.huge_parameter, _needs("parameter", NO_PARAMETER)))
    step_msg = "communicationStepSize must be finite and > 0"
    cases += [
        Case("doStep h = 0", "fmi2DoStep with a zero step", _both(rejected(step_msg)), worker_cases.step_size(0.0)),
        Case("doStep h < 0", "fmi2DoStep with minus the default step", _both(rejected(step_msg)),
             worker_cases.step_size(-1.0)),
        Case("doStep h = nan", "fmi2DoStep with a NaN step", _both(rejected(step_msg)), worker_cases.step_nan),
        Case("doStep at wrong time", "fmi2DoStep from t = 1 s while the FMU is at 0 s",
             _both(rejected("differs from the FMU time")), worker_cases.step_wrong_time),
        Case(FAR_CASE, "one step of `far_factor` (default 1e4) default step sizes from the default start; "
             "outputs finite if OK", _same(lambda b: ok_or_clean_error(*HUGE_FRAGMENTS[b])), worker_cases.far_step,
             settings=("far_factor",)),
        Case("doStep before init", "fmi2DoStep in Instantiated",
             _both(rejected("must not be called in state Instantiated")), worker_cases.step_before_init),
        Case("getReal before init", "fmi2GetReal of an output in Instantiated",
             _both(rejected("must not be called in state Instantiated")), worker_cases.get_before_init,
             _needs("outputs", "no Real output")),
        Case("exitInit without enter", "fmi2ExitInitializationMode in Instantiated",
             _both(rejected("must not be called in state Instantiated")), worker_cases.exit_without_enter),
        Case("exitInit twice", "fmi2ExitInitializationMode in StepComplete",
             _both(rejected("must not be called in state StepComplete")), worker_cases.exit_twice),
        Case("enterInit twice", "fmi2EnterInitializationMode in InitializationMode",
             _both(rejected("must not be called in state InitializationMode")), worker_cases.enter_twice),
        Case("setupExperiment start = nan", "fmi2SetupExperiment with a NaN start time",
             _both(rejected("non-finite startTime")), worker_cases.setup_nan),
        Case("fixed parameter after init", "setting a non-tunable parameter (to its own value) in StepComplete",
             _both(rejected("cannot be set in state StepComplete")), worker_cases.parameter_after_init,
             _needs("fixed", "no non-tunable parameter")),
        Case("set after terminate", "setting an input (else a parameter) to its own value in Terminated",
             _both(rejected("cannot be set in state Terminated")), worker_cases.set_after_terminate),
        Case("doStep after terminate", "fmi2DoStep in Terminated",
             _both(rejected("must not be called in state Terminated")), worker_cases.step_after_terminate),
        Case("parameter < min", "a parameter with a declared min set below it in InitializationMode",
             _both(rejected("outside its range")), worker_cases.out_of_range(below=True),
             _needs("below", "no parameter with a min")),
        Case("parameter > max", "a parameter with a declared max set above it in InitializationMode",
             _both(rejected("outside its range")), worker_cases.out_of_range(below=False),
             _needs("above", "no parameter with a max")),
        # pythonfmu checks the type and the value reference itself: only its own exception text
        Case("setReal on Integer/Boolean", "fmi2SetReal on an Integer or Boolean parameter",
             _both(rejected("has another type")),
             worker_cases.real_on_non_real, _needs("non_real", "no Integer/Boolean parameter")),
        Case("setInteger on Real", "fmi2SetInteger on a Real parameter",
             _both(rejected("has another type")),
             worker_cases.integer_on_real, _needs("parameter", NO_PARAMETER)),
        Case("setReal unknown vr", f"fmi2SetReal of value reference {UNKNOWN_VR}",
             _both(rejected(f"unknown value reference {UNKNOWN_VR}")), worker_cases.unknown_vr("set")),
        Case("getReal unknown vr", f"fmi2GetReal of value reference {UNKNOWN_VR}",
             _both(rejected(f"unknown value reference {UNKNOWN_VR}")), worker_cases.unknown_vr("get")),
        Case("FMU state round trip", f"get (and serialize/deserialize) the state after {STEPS} driven steps, "
             f"step {STEPS} more, restore, repeat: identical outputs",
             _same(lambda b: Expect((OK,), (), "OK, outputs identical bit for bit")), worker_cases.state_round_trip,
             _needs_state),
        Case(CYCLES_CASE, "instantiate, initialize, one step, terminate, free; RSS before and after",
             {b: Expect((OK,), (), f"OK, RSS growth <= {RSS_SLACK_KIB} + {RSS_PER_CYCLE_KIB[b]:g} KiB/cycle")
              for b in BACKENDS}, cycles, settings=("cycles",)),
    ]
    return tuple(cases)


# ============================================================================= issue 26 items 2, 3, 9, 10
# The native FMUs' limits (fmus/c/satfmu_core.h): bounded work per step, checked FMU states, exact
# time, FMI 2.0 statuses, no non-finite output with fmi2OK. The pythonfmu FMUs meet the same
# expectations: their C layer (fmus/c/pythonfmu_shim.c) guards pythonfmu 0.7.0's C++ layer.
STATE_FRAGMENTS = ("corrupted state", "not a state of this FMU")
HUGE_STEP_FRAGMENTS = ("sample instants", "integration substeps", "time resolution", "non-finite",
                       "does not reach a finite later time")
"""Native refusals of a huge step: the work bounds, the time resolution, an overflow of the state."""
def _error_state_applies(target: Target) -> str | None:
    """Applicability of the error-state cases: decided by running them, not by the model
    description (n/a when none of :data:`limits.ERROR_TRIGGERS` reaches the error state,
    :func:`limits.reach_error`)."""
    return None


def _needs_serialize(target: Target) -> str | None:
    return None if target.can_serialize else "canSerializeFMUstate=false"


def _issue26_cases() -> tuple[Case, ...]:
    from satfmu.sims.robustness import limits as lim
    from satfmu.sims.robustness import states

    cases = []
    refused = rejected(*STATE_FRAGMENTS)
    cases += [
        Case(FLIPS_CASE, "every bit of the serialized state flipped in turn (`--flips N`: a "
             "seeded sample), each deserialized and set: none accepted",
             _both(refused), states.bit_flips, _needs_serialize,
             settings=("flips",)),
        Case("FMU state: half zeroed", "the first half, the second half, all of the serialized state zeroed",
             _both(refused), states.half_zeroed, _needs_serialize),
        Case("FMU state: wrong size", "the serialized state one byte short, one byte longer, empty",
             _both(rejected("not a state of this FMU")), states.wrong_size,
             _needs_serialize),
        Case("FMU state: of another model", "a well-formed state of another model (another model identity with a "
             "valid checksum)", _both(rejected("not a state of this FMU")),
             states.of_another_model, _needs_serialize),
    ]
    huge = {NATIVE: ok_or_clean_error(*HUGE_STEP_FRAGMENTS),
            PYTHONFMU: ok_or_clean_error(*HUGE_STEP_FRAGMENTS, *HUGE_FRAGMENTS[PYTHONFMU])}
    cases += [
        Case(HUGE_CASES[0], "one step of h = 1e9, 1e12, 1e30, DBL_MAX s (each on a new instance): finite outputs "
             f"or refused, each within {lim.STEP_TIME_LIMIT_S:g} s of CPU", huge, lim.huge_steps),
        Case(HUGE_CASES[1], "as doStep huge h (and h = 100 s) with the sample period at its "
             "declared minimum", huge, lim.huge_steps_minimum_period, lim.needs_period),
        Case("start time 1e9, 1.4e9", f"{STEPS} driven steps from t0 = 1e9 and 1.4e9 s (time-origin parameters moved "
             "with t0) against the same from 0: equal outputs",
             _same(lambda b: Expect((OK,), (), "OK, outputs as from t0 = 0")), lim.large_start),
        Case("doStep 1e-3..1 s off at 1e9", "fmi2DoStep from 1e-3, 1e-2, 0.1, 1 s off the FMU time at t = 1e9 s",
             _both(rejected("differs from the FMU time")), lim.offset_point),
    ]
    for state in lim.STATUS_STATES:
        native = Expect((OK,), (), "as FMI 2.0: Error outside StepComplete/Terminated, else OK (provided) or "
                        "Discard" if state in ("StepComplete", "Terminated") else "as FMI 2.0: every query Error")
        cases.append(Case(f"status queries in {state}", f"fmi2Get{{,Real,Integer,Boolean,String}}Status with each "
                          f"fmi2StatusKind in {state}", _both(native), lim.status_queries(state),
                          _error_state_applies if state == "Error" else always_applies))
    cases += [
        Case("terminate in Error", "fmi2Terminate in the error state (reached by a failing computation)",
             _both(rejected("must not be called in state Error")), lim.terminate_in_error, _error_state_applies),
        Case("start at DBL_MAX", "initialize at t = DBL_MAX s and read the outputs: finite or refused",
             _both(ok_or_clean_error("non-finite", "cannot be counted exactly")), lim.start_at_max),
        Case("time parameters equal", "every unranged time parameter equal (ramp start = stop, ...), "
             f"{STEPS} steps: outputs finite or refused", _both(ok_or_clean_error("non-finite")),
             lim.time_parameters_equal, lim.needs_two_times),
    ]
    return tuple(cases)


CASES = _cases() + _issue26_cases() + host_cases()  # host-level cases (item 11): sims/robustness/host_cases.py
"""Every case of the suite, in the order they run on each FMU and appear in the report: the misuse
cases, the limit cases of issue 26 (corrupted states, huge steps, large start times, status
queries, extreme times) and the host-level cases (:func:`~satfmu.sims.robustness.host_cases.host_cases`)."""
CASE_BY_NAME = {c.name: c for c in CASES}

