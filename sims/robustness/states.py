"""The corrupted-state cases: damaged serialized FMU states must be refused (issue 26 item 3).

Each case serializes the state of an instance after :data:`~satfmu.sims.robustness.cases.STEPS` driven
steps, damages the bytes and hands them to ``fmi2DeSerializeFMUstate`` (then, if that accepts
them, to ``fmi2SetFMUstate``): a damaged state is *accepted* when both return fmi2OK. A native FMU
must refuse every damaged state with fmi2Error naming what failed and stay usable (the good state
still restores and the instance steps on), a pythonfmu FMU as a native one (its C layer,
``fmus/c/pythonfmu_shim.c``, reports the slave's refusal). An instance that answered fmi2Fatal
would be abandoned and a new one made for the next damaged state.

The native layout the forgery of "another model's state" needs (``fmus/c/satfmu_core.h``, ``Saved``):
four little-endian uint32 (magic, format, size, CRC-32 of the record with the CRC field 0), then the
16 bytes of the GUID (:func:`satfmu.fmus.codegen.guid_bytes`). The pythonfmu one
(``fmus/pyslave.py``): canonical JSON (sorted keys, no spaces) of ``model``, ``guid``, ``format``,
``content`` and ``crc32``, the CRC-32 of the canonical JSON of the other four.
"""
from __future__ import annotations

import hashlib
import json
import random
import struct
import uuid
import zlib
from collections.abc import Callable, Sequence

from satfmu.sims.cosim import fmi_host
from satfmu.sims.robustness.cases import _steps
from satfmu.sims.robustness.instance import ERROR, FATAL, OK, STATUS_NAMES, CaseBroken, Instance, Outcome, recover
from satfmu.sims.robustness.target import NATIVE

FLIP_SEED = 26
"""Seed of the sampled bit positions when a scan does not flip every bit."""
NATIVE_HEADER = struct.Struct("<4I16s")
"""magic, format, size, crc, model identity: the head of a native FMU state."""
ANOTHER_MODEL = hashlib.sha256(b"satfmu robustness: another model").digest()[:16]
"""The model identity of the forged "state of another model" (no model of the project has it)."""
MAX_LOGGED = 3
"""Refusal messages kept in an outcome's log (a scan refuses thousands)."""


def _snapshot(inst: Instance) -> bytes:
    """Initialize, :data:`STEPS` driven steps, then the serialized state."""
    inst.initialize()
    _steps(inst, 0)
    state = inst.slave.getFMUstate()
    blob = bytes(inst.slave.serializeFMUstate(state))
    inst.slave.freeFMUstate(state)
    return blob


def _offer(inst: Instance, blob: bytes) -> int:
    """``fmi2DeSerializeFMUstate`` of ``blob``, then ``fmi2SetFMUstate`` of the result; the first
    status that is not fmi2OK (fmi2OK: the state was accepted and is now the instance's)."""
    status, state = fmi_host.attempt(inst.slave, "deSerializeFMUstate", blob)
    if status != OK:
        inst.dead = status == FATAL
        return status
    status, _ = fmi_host.attempt(inst.slave, "setFMUstate", state)
    inst.dead = status == FATAL
    if not inst.dead:
        inst.slave.freeFMUstate(state)
    return status


def _scan(inst: Instance, good: bytes, damaged: Sequence[tuple[str, bytes]]) -> Outcome:
    """Offer every damaged blob of ``damaged`` (label, bytes). Outcome status: fmi2OK if any was
    accepted, else the refusal status (fmi2Error or fmi2Fatal; the first other one if they differ)."""
    counts: dict[int, int] = {}
    accepted: list[str] = []
    logs: list[str] = []
    unnamed = 0
    for label, blob in damaged:
        if inst.dead:  # pythonfmu after fmi2Fatal: a new instance at the same point
            inst.renew()
            _snapshot(inst)
        n = len(inst.log)
        status = _offer(inst, blob)
        counts[status] = counts.get(status, 0) + 1
        text = inst.text(n)
        del inst.log[n:]  # a scan refuses thousands of states: keep only a few messages
        if status == OK:
            accepted.append(label)
            if _offer(inst, good) != OK:  # the instance now holds a damaged state: back to the good one
                raise CaseBroken(f"the good state is refused after accepting {label}")
            continue
        if len(logs) < MAX_LOGGED:
            logs.append(text)
        unnamed += not ("corrupted state" in text or "not a state" in text)
    refusals = {s: k for s, k in counts.items() if s != OK}
    status = OK if accepted else next((s for s in refusals if s != ERROR), ERROR)  # the first odd one shows
    parts = ", ".join(f"{k} {STATUS_NAMES.get(s, s)}" for s, k in sorted(counts.items()))
    out = Outcome(status=status, log="\n".join(logs),
                  detail=f"{len(damaged)} damaged states of {len(good)} bytes: {parts}"
                         + (f"; accepted: {', '.join(accepted[:5])}{' ...' if len(accepted) > 5 else ''}"
                            if accepted else ""),
                  metrics={"offered": len(damaged), "accepted": len(accepted), "state_bytes": len(good)})
    if unnamed:
        out.problems.append(f"{unnamed} refusals without 'corrupted state' / 'not a state' in the message")
    return out


def _case(damage: Callable[..., list[tuple[str, bytes]]]) -> Callable[..., Outcome]:
    """A corrupted-state case: the damaged blobs of ``damage(inst, good)``, then the instance must
    still restore its good state and step on (a case's settings are ``damage``'s keywords)."""
    def case(inst: Instance, **settings: int | None) -> Outcome:
        """A corrupted-state case: the instance's serialized state after
        :data:`~satfmu.sims.robustness.cases.STEPS` driven steps, damaged by the function of the
        case (:func:`flips`, :func:`zeroed`, :func:`resized` or :func:`another_model`, which
        receives the case's settings as keywords, ``**settings``), each damaged copy offered to
        ``fmi2DeSerializeFMUstate`` and ``fmi2SetFMUstate``; then the good state must still
        restore and the instance step on.

        Parameters
        ----------
        inst : Instance
            The instance under test, freshly instantiated (the worker makes one per case).

        Returns
        -------
        Outcome
            fmi2OK if a damaged state was accepted, else the refusal status; the metrics
            ``offered``, ``accepted`` and ``state_bytes``.
        """
        good = _snapshot(inst)
        out = _scan(inst, good, damage(inst, good, **settings))
        if not inst.dead:
            if _offer(inst, good) != OK:
                out.problems.append(f"the good state is refused afterwards: {inst.text()[-200:]!r}")
            else:  # the FMU time is the snapshot's again, which inst.time still holds
                recover(inst, out)
        return out
    return case


def _flip(blob: bytes, bit: int) -> bytes:
    b = bytearray(blob)
    b[bit // 8] ^= 1 << (bit % 8)
    return bytes(b)


def flips(inst: Instance, good: bytes, flips: int | None) -> list[tuple[str, bytes]]:
    """Single-bit flips: every bit (``flips`` None), else ``flips`` bits sampled with
    :data:`FLIP_SEED`, on both backends (a pythonfmu FMU refuses one in ~0.02 ms and stays usable:
    3,376 flips of mrp_satellite_py's 422-byte state refused in 0.07 s).

    Parameters
    ----------
    inst : Instance
        The instance under test (unused: the damage depends on the bytes alone).
    good : bytes
        The serialized good state (after the driven steps).
    flips : int or None
        How many bits to flip, each in its own copy (None, or as many as the state has: every
        bit).

    Returns
    -------
    list of (str, bytes)
        A label and the damaged bytes of each state to offer.
    """
    n_bits = 8 * len(good)
    bits = (range(n_bits) if flips is None or flips >= n_bits
            else sorted(random.Random(FLIP_SEED).sample(range(n_bits), flips)))
    return [(f"bit {b}", _flip(good, b)) for b in bits]


def zeroed(inst: Instance, good: bytes) -> list[tuple[str, bytes]]:
    """The first half, the second half and all of the buffer zeroed.

    Parameters
    ----------
    inst : Instance
        The instance under test (unused: the damage depends on the bytes alone).
    good : bytes
        The serialized good state (after the driven steps).

    Returns
    -------
    list of (str, bytes)
        A label and the damaged bytes of each state to offer.
    """
    half = len(good) // 2
    return [("first half zeroed", bytes(half) + good[half:]),
            ("second half zeroed", good[:half] + bytes(len(good) - half)),
            ("all zeroed", bytes(len(good)))]


def resized(inst: Instance, good: bytes) -> list[tuple[str, bytes]]:
    """One byte short, one zero byte more, empty.

    Parameters
    ----------
    inst : Instance
        The instance under test (unused: the damage depends on the bytes alone).
    good : bytes
        The serialized good state (after the driven steps).

    Returns
    -------
    list of (str, bytes)
        A label and the damaged bytes of each state to offer.
    """
    return [("truncated by 1 byte", good[:-1]), ("extended by 1 byte", good + b"\0"), ("empty", b"")]


def another_model(inst: Instance, good: bytes) -> list[tuple[str, bytes]]:
    """A well-formed state of another model with the same layout (what the same build of another
    model with the same sizes writes): the identity of :data:`ANOTHER_MODEL` with the CRC
    recomputed. Native: its 16 bytes; pythonfmu: as the GUID, with another model name.

    Parameters
    ----------
    inst : Instance
        The instance under test (its backend decides the layout of the state).
    good : bytes
        The serialized good state (after the driven steps).

    Returns
    -------
    list of (str, bytes)
        A label and the damaged bytes of each state to offer.
    """
    if inst.target.backend == NATIVE:
        magic, fmt, size, _, _ = NATIVE_HEADER.unpack_from(good)
        record = NATIVE_HEADER.pack(magic, fmt, size, 0, ANOTHER_MODEL) + good[NATIVE_HEADER.size:]
        forged = NATIVE_HEADER.pack(magic, fmt, size, zlib.crc32(record), ANOTHER_MODEL) + good[NATIVE_HEADER.size:]
        return [("another model's identity", forged)]
    state = json.loads(good.decode())
    state.update(model="another_model", guid="{" + str(uuid.UUID(bytes=ANOTHER_MODEL)) + "}")
    del state["crc32"]
    state["crc32"] = zlib.crc32(_canonical_json(state))
    return [("another model's GUID", _canonical_json(state))]


def _canonical_json(obj: object) -> bytes:
    """JSON as ``fmus/pyslave.py`` writes an FMU state: sorted keys, no spaces."""
    return json.dumps(obj, sort_keys=True, separators=(",", ":")).encode()


bit_flips = _case(flips)
half_zeroed = _case(zeroed)
wrong_size = _case(resized)
of_another_model = _case(another_model)
