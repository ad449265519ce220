"""What satfmu's pythonfmu FMUs guard (``fmus/pyslave.py`` behind ``fmus/c/pythonfmu_shim.c``):
the instance name and the integrity of FMU states (issue 26 items 3 and 11).

A refused call returns fmi2Error and the instance stays usable (the slave logs its reason and
raises; the C layer reports fmi2Error instead of pythonfmu's fmi2Fatal). These tests drive the
FMUs in this process.
"""
from __future__ import annotations

import ctypes
import json
import math
import shutil
import zlib
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave

from satfmu.sims.cosim import fmi_host

PLANT, CONTROLLER, BDOT = "mrp_satellite_py", "mrp_hinf_published_py", "cubesat_bdot_py"


class Fmu:
    """An extracted FMU: its model description and folder."""

    def __init__(self, path: Path) -> None:
        self.md = read_model_description(str(path))
        self.unzip = str(extract(str(path)))

    def slave(self, name: str = "slave") -> tuple[FMU2Slave, fmi_host.Callbacks]:
        """A new instance (logging on)."""
        callbacks = fmi_host.Callbacks()
        slave = FMU2Slave(guid=self.md.guid, unzipDirectory=self.unzip,
                          modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName=name)
        slave.instantiate(callbacks=callbacks.functions, loggingOn=True)
        return slave, callbacks


@pytest.fixture(scope="module")
def fmus(fmu_dir: Path) -> Iterator[dict[str, Fmu]]:
    out = {name: Fmu(fmu_dir / f"{name}.fmu") for name in (PLANT, CONTROLLER, BDOT)}
    yield out
    for fmu in out.values():
        shutil.rmtree(fmu.unzip, ignore_errors=True)


@pytest.fixture
def stepped(fmus: dict[str, Fmu]) -> Iterator[Callable[..., tuple[FMU2Slave, fmi_host.Callbacks]]]:
    """Factory: an instance of ``name`` after initialization at ``start`` s and ``steps`` steps of
    ``h`` s; freed at teardown unless it returned fmi2Fatal (then abandoned)."""
    made: list[tuple[FMU2Slave, fmi_host.Callbacks]] = []

    def make(name: str, start: float = 0.0, steps: int = 3, h: float = 0.1) -> tuple[FMU2Slave, fmi_host.Callbacks]:
        slave, callbacks = fmus[name].slave()
        made.append((slave, callbacks))
        slave.setupExperiment(startTime=start)
        slave.enterInitializationMode()
        slave.exitInitializationMode()
        t = start
        for _ in range(steps):
            slave.doStep(t, h)
            t += h
        return slave, callbacks

    yield make
    for slave, callbacks in made:
        if any(m.status == fmi_host.FATAL for m in callbacks.log):
            fmi_host.abandon((slave, callbacks))
        else:
            slave.fmi2FreeInstance(slave.component)


def serialized(slave: FMU2Slave) -> dict[str, Any]:
    """The instance's FMU state, serialized and decoded (JSON)."""
    state = slave.getFMUstate()
    blob = bytes(slave.serializeFMUstate(state))
    slave.freeFMUstate(state)
    return json.loads(blob)


def canonical(obj: Any) -> bytes:
    """JSON as the slave writes it: sorted keys, no spaces."""
    return json.dumps(obj, sort_keys=True, separators=(",", ":")).encode()


def with_checksum(state: dict[str, Any]) -> bytes:
    """``state`` serialized with its CRC-32 (of every field but itself) recomputed, in canonical
    form (what a faulty writer that knows the format would produce): only the range checks can
    refuse it."""
    return canonical({**state, "crc32": zlib.crc32(canonical({k: v for k, v in state.items() if k != "crc32"}))})


def refused(slave: FMU2Slave, callbacks: fmi_host.Callbacks, blob: bytes) -> str:
    """Offer ``blob`` to fmi2DeSerializeFMUstate, which must return fmi2Error; the log text."""
    n = len(callbacks.log)
    status, _ = fmi_host.attempt(slave, "deSerializeFMUstate", blob)
    # the slave's refusal (a RefusedState the C layer reads), reported as fmi2Error
    assert status == fmi_host.ERROR, callbacks.text(n)
    return callbacks.text(n)


def test_empty_instance_name_is_refused(fmus: dict[str, Fmu]) -> None:
    """fmi2Instantiate with "" returns NULL with one fmi2Error message (the C layer's)."""
    fmu = fmus[PLANT]
    callbacks = fmi_host.Callbacks()
    slave = FMU2Slave(guid=fmu.md.guid, unzipDirectory=fmu.unzip, modelIdentifier=fmu.md.coSimulation.modelIdentifier,
                      instanceName="")
    resources = Path(fmu.unzip, "resources").as_uri().encode()
    component = slave.fmi2Instantiate(b"", 1, fmu.md.guid.encode(), resources, ctypes.byref(callbacks.functions), 0, 1)
    assert component is None
    assert [m.status for m in callbacks.log] == [fmi_host.ERROR]
    assert "fmi2Instantiate: missing instance name" in callbacks.text()


def test_round_trip_through_bytes_is_exact(stepped) -> None:
    """A sampled FMU from a large start time: the state restored from its bytes gives the same
    outputs bit for bit (JSON writes repr floats, which round-trip exactly; the sample index is an
    integer)."""
    slave, _ = stepped(BDOT, start=1e9, steps=3)
    state = slave.getFMUstate()
    blob = slave.serializeFMUstate(state)
    t = 1e9 + 0.1 + 0.1 + 0.1  # the times the fixture stepped to, added in the same order
    outputs = [v.valueReference for v in read_model_description_outputs(slave)]
    slave.doStep(t, 0.1)
    first = slave.getReal(outputs)
    slave.setFMUstate(slave.deSerializeFMUstate(blob))
    slave.doStep(t, 0.1)
    assert slave.getReal(outputs) == first
    slave.freeFMUstate(state)


def read_model_description_outputs(slave: FMU2Slave) -> list[Any]:
    """The Real outputs of ``slave``'s FMU."""
    md = read_model_description(str(Path(slave.unzipDirectory, "modelDescription.xml")))
    return [v for v in md.modelVariables if v.causality == "output" and v.type == "Real"]


def test_changed_value_fails_the_checksum(stepped) -> None:
    """One number changed in the serialized text (the time, 0.3 -> 0.4): the CRC-32 differs."""
    slave, callbacks = stepped(PLANT)
    good = canonical(serialized(slave))
    bad = good.replace(b'"time":0.30000000000000004', b'"time":0.4')
    assert bad != good  # the fixture's three steps of 0.1 s give this time
    assert "fmi2DeSerializeFMUstate: corrupted state (checksum 0x" in refused(slave, callbacks, bad)


def test_same_values_written_otherwise_are_refused(stepped) -> None:
    """The same state with spaces after the separators: every value and the checksum agree, but the
    bytes are not what the slave writes (as a bit flip of 'e' to 'E' in 1e-05), so they are refused."""
    slave, callbacks = stepped(PLANT)
    spaced = json.dumps(serialized(slave), sort_keys=True).encode()
    assert "corrupted state (not the canonical serialization" in refused(slave, callbacks, spaced)


@pytest.mark.parametrize("damage, message", [
    (lambda c: c["p"].__setitem__(0, -1.0), "corrupted state (variable 'I_x' = -1)"),
    (lambda c: c["u"].__setitem__(0, 1e300), None),  # the inputs have no range: accepted (checked below)
    (lambda c: c.__setitem__("mode", "Error"), "corrupted state (invalid model state 'Error')"),
    (lambda c: c.__setitem__("time", -1.0), "corrupted state (time -1 s outside [start 0 s, stop inf s])"),
    (lambda c: c.__setitem__("x", c["x"][:-1]), "corrupted state (x: expected 6 numbers)"),
    (lambda c: c.__setitem__("at_instant", 1), "corrupted state (flags (1, False, False))"),
    (lambda c: c.pop("held_prev"), "corrupted state (fields)"),
], ids=["parameter below min", "huge input", "mode", "time before start", "state length", "flag type",
        "missing field"])
def test_range_checks(stepped, damage: Callable[[dict], None], message: str | None) -> None:
    """A state whose checksum is right but whose content is not (a faulty writer): each field is
    checked as the native FMU checks its record, and the message names the field."""
    slave, callbacks = stepped(PLANT)
    state = serialized(slave)
    damage(state["content"])
    if message is None:  # a legal value: restored
        slave.setFMUstate(slave.deSerializeFMUstate(with_checksum(state)))
        return
    assert message in refused(slave, callbacks, with_checksum(state))


def test_sample_index_must_match_the_time(stepped) -> None:
    """A sampled FMU's state whose sample index does not belong to its time is refused."""
    slave, callbacks = stepped(BDOT)
    state = serialized(slave)
    state["content"]["next_k"] += 1
    assert "corrupted state (sample index" in refused(slave, callbacks, with_checksum(state))


def test_state_of_another_model_is_refused(stepped) -> None:
    """The controller's serialized state offered to the plant: refused by the model identity from
    bytes, and the state object itself by fmi2SetFMUstate (not a state of that instance)."""
    plant, plant_log = stepped(PLANT)
    controller, _ = stepped(CONTROLLER)
    foreign = controller.getFMUstate()
    blob = bytes(controller.serializeFMUstate(foreign))
    assert "not a state of this FMU (the state of model 'mrp_hinf_published'" in refused(plant, plant_log, blob)
    other, other_log = stepped(PLANT)
    status, _ = fmi_host.attempt(other, "setFMUstate", foreign)
    assert status == fmi_host.ERROR
    assert "fmi2SetFMUstate: not an FMU state of this instance" in other_log.text()
    controller.freeFMUstate(foreign)


@pytest.mark.parametrize("blob, message", [
    (lambda b: b[: len(b) // 2], "JSONDecodeError"),  # what a too small buffer gives (docs/pythonfmu.md)
    (lambda b: b"\xff" + b[1:], "UnicodeDecodeError"),
    (lambda b: b.replace(b'"start_time":0.0', b'"start_time":NaN'), "non-finite number NaN"),
    (lambda b: b"[" * 100_000, "RecursionError"),
    (lambda b: b"{}", "not a satfmu FMU state"),
], ids=["half", "not utf-8", "NaN", "deep nesting", "empty object"])
def test_undecodable_buffers_are_refused(stepped, blob: Callable[[bytes], bytes], message: str) -> None:
    """Buffers that are no JSON state at all: refused with the decoder's reason, no crash."""
    slave, callbacks = stepped(PLANT)
    good = canonical(serialized(slave))
    assert blob(good) != good  # each damage changes the buffer
    assert "fmi2DeSerializeFMUstate: not a state of this FMU" in (log := refused(slave, callbacks, blob(good)))
    assert message in log


def test_format_version_is_checked(stepped) -> None:
    """A state of another layout version (a future or an older satfmu) is refused by name."""
    slave, callbacks = stepped(PLANT)
    state = serialized(slave)
    state["format"] = 0
    assert "not a state of this FMU (format 0, expected 2)" in refused(slave, callbacks, with_checksum(state))


def test_state_holds_no_non_finite_number(stepped) -> None:
    """The serialized state is strict JSON: every number finite (no NaN or Infinity tokens)."""
    slave, _ = stepped(BDOT)
    state = serialized(slave)
    numbers = [v for key in ("x", "u", "p", "held_prev") for v in state["content"][key]]
    assert numbers and all(math.isfinite(v) for v in numbers)
