"""The host-level cases of issue 26 item 11: invalid arguments a host may pass to fmi2Instantiate,
fmi2SetDebugLogging and fmi2SerializeFMUstate.

Every FMU must refuse each one cleanly (fmi2Instantiate: NULL and a message; the others:
fmi2Error and a message, usable afterwards). pythonfmu 0.7.0 alone crashes the host or accepts
several of them (``scripts/upstream/``, ``docs/pythonfmu.md``); the pythonfmu FMUs' C layer
(``fmus/c/pythonfmu_shim.c``) refuses them before pythonfmu sees them. A crash would kill the
worker; the runner records it as CRASH and carries on in a new worker, so these cases come last.

An fmi2Instantiate case reports fmi2OK when it got an instance (freed at once) and fmi2Error when
it got NULL.
"""
from __future__ import annotations

import ctypes
from pathlib import Path
from typing import TYPE_CHECKING

from fmpy.fmi2 import fmi2String

from satfmu.sims.cosim import fmi_host
from satfmu.sims.robustness.instance import ERROR, FATAL, OK, Instance, Outcome, reject, recover
from satfmu.sims.robustness.target import NATIVE, PYTHONFMU

if TYPE_CHECKING:
    from satfmu.sims.robustness.table import Case

FMI2_MODEL_EXCHANGE, FMI2_CO_SIMULATION = 0, 1
WRONG_GUID = b"{00000000-0000-0000-0000-000000000000}"
MISSING_RESOURCES = b"file:///nonexistent/resources"


def _instantiate(inst: Instance, name: bytes | None = b"host case", fmu_type: int = FMI2_CO_SIMULATION,
                 guid: bytes | None = None, resources: bytes | None = None) -> Outcome:
    """A second fmi2Instantiate on the instance's library, the given argument wrong and the others
    right: fmi2OK with an instance (freed), fmi2Error with NULL."""
    n = len(inst.log)
    component = inst.slave.fmi2Instantiate(
        name, fmu_type, inst.target.guid.encode() if guid is None else guid,
        Path(inst.slave.unzipDirectory, "resources").as_uri().encode() if resources is None else resources,
        ctypes.byref(inst.callbacks.functions), 0, 0)
    if component is not None:
        inst.slave.fmi2FreeInstance(component)
    status = OK if component is not None else ERROR
    return Outcome(status=status, log=inst.text(n),
                   detail=f"fmi2Instantiate returned {'an instance' if component is not None else 'NULL'}")


def missing_resources(inst: Instance) -> Outcome:
    """fmi2Instantiate with the resource URI ``file:///nonexistent/resources``, which is no
    folder (the native FMUs read no resources and may accept it, the pythonfmu ones must refuse it).

    Parameters
    ----------
    inst : Instance
        The instance under test, freshly instantiated: its loaded library and callbacks are used.

    Returns
    -------
    Outcome
        fmi2OK if an instance was returned (and freed), fmi2Error if NULL; the log of the call.
    """
    return _instantiate(inst, resources=MISSING_RESOURCES)


def null_name(inst: Instance) -> Outcome:
    """fmi2Instantiate with a NULL instance name: must be refused (NULL and a message).

    Parameters
    ----------
    inst : Instance
        The instance under test, freshly instantiated: its loaded library and callbacks are used.

    Returns
    -------
    Outcome
        fmi2OK if an instance was returned (and freed), fmi2Error if NULL; the log of the call.
    """
    return _instantiate(inst, name=None)


def empty_name(inst: Instance) -> Outcome:
    """fmi2Instantiate with an empty instance name ``""``: must be refused (NULL and a message).

    Parameters
    ----------
    inst : Instance
        The instance under test, freshly instantiated: its loaded library and callbacks are used.

    Returns
    -------
    Outcome
        fmi2OK if an instance was returned (and freed), fmi2Error if NULL; the log of the call.
    """
    return _instantiate(inst, name=b"")


def wrong_guid(inst: Instance) -> Outcome:
    """fmi2Instantiate with an all-zero GUID, not the FMU's: must be refused (NULL and a message).

    Parameters
    ----------
    inst : Instance
        The instance under test, freshly instantiated: its loaded library and callbacks are used.

    Returns
    -------
    Outcome
        fmi2OK if an instance was returned (and freed), fmi2Error if NULL; the log of the call.
    """
    return _instantiate(inst, guid=WRONG_GUID)


def model_exchange(inst: Instance) -> Outcome:
    """fmi2Instantiate of the co-simulation FMU as fmi2ModelExchange: must be refused (NULL
    and a message).

    Parameters
    ----------
    inst : Instance
        The instance under test, freshly instantiated: its loaded library and callbacks are used.

    Returns
    -------
    Outcome
        fmi2OK if an instance was returned (and freed), fmi2Error if NULL; the log of the call.
    """
    return _instantiate(inst, fmu_type=FMI2_MODEL_EXCHANGE)


def null_category(inst: Instance) -> Outcome:
    """fmi2SetDebugLogging(c, true, 1, {NULL}) in Instantiated: must be refused, the instance usable.

    Parameters
    ----------
    inst : Instance
        The instance under test, freshly instantiated (the worker makes one per case).

    Returns
    -------
    Outcome
    """
    return reject(inst, lambda: inst.call("SetDebugLogging", 1, 1, (fmi2String * 1)(None)))


def small_buffer(inst: Instance) -> Outcome:
    """fmi2SerializeFMUstate into half the buffer fmi2SerializedFMUstateSize asks for; if that is
    accepted, what it wrote must be refused by fmi2DeSerializeFMUstate (a truncated state).

    Parameters
    ----------
    inst : Instance
        The instance under test, freshly instantiated (the worker makes one per case).

    Returns
    -------
    Outcome
    """
    inst.initialize()
    state = inst.slave.getFMUstate()
    size = ctypes.c_size_t()
    inst.need("SerializedFMUstateSize", state, ctypes.byref(size))
    half = size.value // 2
    buffer = ctypes.create_string_buffer(half)
    n = len(inst.log)
    status = inst.call("SerializeFMUstate", state, buffer, half)
    out = Outcome(status=status, log=inst.text(n), detail=f"{half} of {size.value} bytes: {status}")
    if status == OK:
        again, _ = fmi_host.attempt(inst.slave, "deSerializeFMUstate", buffer.raw)
        inst.dead = again == FATAL
        out.detail += f"; the {half} bytes written, deserialized: {fmi_host.status_name(again)}"
        if again == OK:
            out.problems.append("the truncated state was accepted by fmi2DeSerializeFMUstate")
    if not inst.dead:
        inst.slave.freeFMUstate(state)
    if status == ERROR:
        recover(inst, out)
    return out


def host_cases() -> tuple[Case, ...]:
    """The cases of this module, with their expectations (the last cases of
    :data:`satfmu.sims.robustness.table.CASES`)."""
    from satfmu.sims.robustness.table import Case, Expect, rejected

    def refused(fragment: str) -> Expect:
        return Expect((ERROR,), (fragment,), f"NULL + '{fragment}'")

    def both(expect: Expect) -> dict[str, Expect]:
        return {NATIVE: expect, PYTHONFMU: expect}

    return (
        Case("instantiate: resources no folder", f"fmi2Instantiate with the resource URI {MISSING_RESOURCES.decode()}",
             {NATIVE: Expect((OK,), (), "OK (the native FMU reads no resources)"),
              PYTHONFMU: refused("is not this FMU's resources folder")}, missing_resources),
        Case("instantiate: NULL name", "fmi2Instantiate with instanceName NULL", both(refused("missing instance name")),
             null_name),
        Case("instantiate: empty name", 'fmi2Instantiate with instanceName ""', both(refused("missing instance name")),
             empty_name),
        Case("instantiate: wrong GUID", f"fmi2Instantiate with the GUID {WRONG_GUID.decode()}",
             both(refused("does not match")), wrong_guid),
        Case("instantiate: fmi2ModelExchange", "fmi2Instantiate of this co-simulation FMU as fmi2ModelExchange",
             both(refused("co-simulation only")), model_exchange),
        Case("setDebugLogging: NULL category", "fmi2SetDebugLogging(c, fmi2True, 1, {NULL}) in Instantiated",
             both(rejected("NULL category")), null_category),
        Case("serialize: buffer too small", "fmi2SerializeFMUstate into half the size fmi2SerializedFMUstateSize "
             "gives (if accepted: the bytes written must not deserialize)", both(rejected("too small")),
             small_buffer, lambda t: None if t.can_serialize else "canSerializeFMUstate=false"),
    )
