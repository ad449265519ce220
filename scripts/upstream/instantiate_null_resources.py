"""pythonfmu 0.7.0: fmi2Instantiate with fmuResourceLocation NULL aborts the host (SIGABRT).

The first statement of ``fmi2Instantiate`` is ``std::string(fmuResourceLocation)``, outside any
``try``: ``std::logic_error`` for NULL, then ``std::terminate``. FMI 2.0 allows no resource
location to be given only for an FMU that needs none; pythonfmu needs one, so NULL and a logged
error are expected.

Usage: ``python scripts/upstream/instantiate_null_resources.py [FMU]``; expected today: SIGABRT.
"""
import ctypes
import sys

from common import FMI2_CO_SIMULATION, Fmu, report

fmu = Fmu(sys.argv[1:])
component = fmu.slave.fmi2Instantiate(b"repro", FMI2_CO_SIMULATION, fmu.md.guid.encode(), None,
                                      ctypes.byref(fmu.callbacks), 0, 1)
report(f"fmi2Instantiate returned {'NULL' if component is None else 'an instance'}; log: {fmu.messages}")
