"""pythonfmu 0.7.0: the status functions answer in every state, from the C++ layer alone.

``fmi2GetRealStatus(fmi2LastSuccessfulTime)`` returns fmi2OK in Instantiated and
InitializationMode (the value NaN), ``fmi2GetBooleanStatus(fmi2Terminated)`` fmi2OK (fmi2False)
there too; FMI 2.0 allows the status functions only after initialization (stepComplete, stepFailed,
stepInProgress, terminated). ``fmi2GetStatus`` returns fmi2Error for every kind, where a status the
slave cannot give is fmi2Discard. None of these reaches the Python slave, so no slave can answer
otherwise.

Usage: ``python scripts/upstream/status_queries.py [FMU]``; prints, per state, the status and
value of each query.
"""
import ctypes
import sys

from fmpy.fmi2 import fmi2Boolean, fmi2Real

from common import Fmu, report

FMI2_DO_STEP_STATUS, FMI2_LAST_SUCCESSFUL_TIME, FMI2_TERMINATED = 0, 2, 3

fmu = Fmu(sys.argv[1:])
s = fmu.slave
s.component = fmu.instantiate()
steps = {"Instantiated": lambda: None,
         "InitializationMode": lambda: (s.setupExperiment(startTime=0.0), s.enterInitializationMode()),
         "StepComplete": lambda: (s.exitInitializationMode(), s.doStep(0.0, 0.5)),
         "Terminated": s.terminate}
for state, enter in steps.items():
    enter()
    real, boolean, status = fmi2Real(), fmi2Boolean(), ctypes.c_int()
    r = fmu.call("fmi2GetRealStatus", s.component, FMI2_LAST_SUCCESSFUL_TIME, ctypes.byref(real))
    b = fmu.call("fmi2GetBooleanStatus", s.component, FMI2_TERMINATED, ctypes.byref(boolean))
    g = fmu.call("fmi2GetStatus", s.component, FMI2_DO_STEP_STATUS, ctypes.byref(status))
    report(f"{state}: GetRealStatus(LastSuccessfulTime) {r} {real.value!r}; "
           f"GetBooleanStatus(Terminated) {b} {boolean.value}; GetStatus(DoStepStatus) {g}")
