"""pythonfmu 0.7.0: fmi2Instantiate with instanceName NULL aborts the host (SIGABRT).

``fmi2Instantiate`` constructs ``std::string`` from the name outside its ``try`` (the logger's
constructor), which throws ``std::logic_error`` for NULL; the exception leaves an ``extern "C"``
function: ``std::terminate``. FMI 2.0 asks for NULL (a missing name is an error).

Usage: ``python scripts/upstream/instantiate_null_name.py [FMU]``; expected today: "terminate
called after throwing an instance of 'std::logic_error'" on stderr, SIGABRT.
"""
import sys

from common import Fmu, report

fmu = Fmu(sys.argv[1:])
component = fmu.instantiate(name=None)
report(f"fmi2Instantiate returned {'NULL' if component is None else 'an instance'}; log: {fmu.messages}")
