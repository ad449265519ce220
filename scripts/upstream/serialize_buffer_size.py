"""pythonfmu 0.7.0: fmi2SerializeFMUstate ignores the buffer size it is given.

``SerializeFMUstate`` copies exactly ``size`` bytes from the serialized state, whatever its
length: a buffer smaller than fmi2SerializedFMUstateSize says receives a truncated state and the
call returns fmi2OK; a larger one is filled by reading past the end of the serialized bytes (a
heap over-read: 1 GiB crashes with SIGSEGV, pass ``--huge``). FMI 2.0 asks for an error when the
buffer is too small, and a larger one is legal.

Usage: ``python scripts/upstream/serialize_buffer_size.py [FMU] [--huge]``; expected today:
"status 0, <n> of <size> bytes written" for half the size; SIGSEGV with ``--huge``.
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
given = 1 << 30 if huge else size.value // 2
buffer = ctypes.create_string_buffer(given)
status = fmu.call("fmi2SerializeFMUstate", component, state, buffer, given)
report(f"status {status}, {given} of {size.value} bytes written; log: {fmu.messages}")
