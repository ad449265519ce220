"""pythonfmu 0.7.0: fmi2Instantiate with a resource location that is no folder crashes (SIGSEGV).

``PySlaveInstance``'s constructor reads ``<resources>/slavemodule.txt`` (an empty name when the
file does not exist), ``findClass`` returns NULL without setting a Python error, so
``handle_py_exception`` does not throw, and ``PyObject_Call(NULL, ...)`` dereferences NULL
(src/pythonfmu/PySlaveInstance.cpp). FMI 2.0 asks for NULL and a logged error.

Usage: ``python scripts/upstream/instantiate_missing_resources.py [FMU]``; expected today:
killed by SIGSEGV before printing.
"""
import sys

from common import Fmu, report

fmu = Fmu(sys.argv[1:])
component = fmu.instantiate(resources=b"file:///nonexistent/resources")
report(f"fmi2Instantiate returned {'NULL' if component is None else 'an instance'}; log: {fmu.messages}")
