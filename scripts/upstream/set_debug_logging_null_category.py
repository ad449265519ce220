"""pythonfmu 0.7.0: fmi2SetDebugLogging with a NULL category aborts the host (SIGABRT).

``fmi2SetDebugLogging`` copies each category into a ``std::string`` without a ``try``: a NULL
entry throws ``std::logic_error`` out of an ``extern "C"`` function, ``std::terminate``; a NULL
array with nCategories > 0 is dereferenced (SIGSEGV, pass ``--null-array``). FMI 2.0 gives
invalid arguments fmi2Error.

Usage: ``python scripts/upstream/set_debug_logging_null_category.py [FMU] [--null-array]``;
expected today: SIGABRT (SIGSEGV with ``--null-array``).
"""
import sys

from fmpy.fmi2 import fmi2String

from common import Fmu, report

args = [a for a in sys.argv[1:] if a != "--null-array"]
fmu = Fmu(args)
component = fmu.instantiate()
categories = None if "--null-array" in sys.argv else (fmi2String * 1)(None)
status = fmu.call("fmi2SetDebugLogging", component, 1, 1, categories)
report(f"fmi2SetDebugLogging returned {status}; log: {fmu.messages}")
