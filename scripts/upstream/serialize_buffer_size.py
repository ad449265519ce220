"""pythonfmu 0.7.0: fmi2SerializeFMUstate ignores the buffer size it is given.

``SerializeFMUstate`` copies exactly ``size`` bytes from the serialized state, whatever its
length: a buffer smaller than fmi2SerializedFMUstateSize says receives a truncated state and the
call returns fmi2OK; a larger one is filled by reading past the end of the serialized bytes (a
heap over-read: 1 GiB crashes with SIGSEGV, pass ``--huge``). FMI 2.0 asks for an error when the
buffer is too small, and a larger one is legal.

Usage: ``python scripts/upstream/serialize_buffer_size.py [FMU] [--huge]``; prints the status,
how many leading bytes of the state the buffer received and how many bytes past the state (up to
1 MiB of them) the call changed; expected today: "status 0, <n> of <2 n> bytes of the state
written ..." for half the size; SIGSEGV with ``--huge``.
"""
import ctypes
import sys

from common import Fmu, report

huge = "--huge" in sys.argv
fmu = Fmu([a for a in sys.argv[1:] if a != "--huge"])
component = fmu.ready()
state = fmu.slave.getFMUstate()
size = ctypes.c_size_t()
fmu.call("fmi2SerializedFMUstateSize", component, state, ctypes.byref(size))
exact = ctypes.create_string_buffer(size.value)  # the state's bytes, serialized into a buffer of its size
fmu.call("fmi2SerializeFMUstate", component, state, exact, size.value)
given = 1 << 30 if huge else size.value // 2
buffer = ctypes.create_string_buffer(given)
checked = min(given, size.value + (1 << 20))  # the state's part of the buffer and up to 1 MiB past it
ctypes.memset(buffer, 0xA5, checked)
status = fmu.call("fmi2SerializeFMUstate", component, state, buffer, given)
got = ctypes.string_at(buffer, checked)
written = next((i for i, (a, b) in enumerate(zip(got, exact.raw)) if a != b), min(len(got), size.value))
past = got[size.value:]
changed = len(past) - past.count(0xA5)
report(f"status {status}, {written} of {size.value} bytes of the state written into a buffer of {given}; "
       f"{changed} of the {len(past)} bytes checked past the state changed; log: {fmu.messages}")
