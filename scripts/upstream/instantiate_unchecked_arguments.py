"""pythonfmu 0.7.0: fmi2Instantiate ignores the GUID and the FMU type, and passes an empty name on.

``fmi2Instantiate`` never reads ``fmuGUID`` or ``fmuType``, and the slave receives neither (only
the instance name, the resource folder, the logger and ``visible``), so no slave can refuse the
GUID of another FMU or fmi2ModelExchange for a co-simulation-only FMU. An empty instance name is
passed on to the slave; pythonfmu itself accepts it (a satfmu FMU refuses it).

Usage: ``python scripts/upstream/instantiate_unchecked_arguments.py [FMU]``; prints, per
argument, whether fmi2Instantiate returned an instance, and what it logged; expected today with
pythonfmu's own slave (no FMU given): an instance for each.
"""
import sys

from common import FMI2_MODEL_EXCHANGE, Fmu, report

fmu = Fmu(sys.argv[1:])
cases = {"wrong GUID": {"guid": b"{00000000-0000-0000-0000-000000000000}"},
         "fmi2ModelExchange": {"fmu_type": FMI2_MODEL_EXCHANGE}, "empty name": {"name": b""}}
for label, kwargs in cases.items():
    fmu.messages.clear()
    component = fmu.instantiate(**kwargs)
    report(f"{label}: {'NULL' if component is None else 'instance'}; log: {fmu.messages}")
    if component is not None:
        fmu.slave.fmi2FreeInstance(component)
