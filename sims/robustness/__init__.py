"""Robustness suite over every built FMU: misuse cases x FMUs, each FMU in a child process.

Modules: :mod:`.target` (the FMU and the variables a case abuses), :mod:`.instance` (one FMU
instance in a worker), :mod:`.cases`, :mod:`.memory`, :mod:`.states` (corrupted FMU states) and
:mod:`.limits` (huge steps, large start times, status queries, extreme times) and
:mod:`.host_cases` (invalid fmi2Instantiate, fmi2SetDebugLogging and fmi2SerializeFMUstate
arguments) (what each case does), :mod:`.table` (the cases and their expectations per backend),
:mod:`.worker` (the child
process), :mod:`.runner` (the parent: workers, crashes, time-outs, :class:`SuiteResult`),
:mod:`.results` (Markdown and CSV), :mod:`.command` (the command line).

Every FMI 2.0 co-simulation ``*.fmu`` of a folder (:func:`.target.discover`: not the FMI 3.0 and
model-exchange ones) is driven through fmpy's low-level FMI 2.0 API
(``fmpy.fmi2.FMU2Slave``, raw ``fmi2*`` calls so the exact status is seen) with
non-finite and huge values, bad step sizes, calls outside the co-simulation state
machine, out-of-range and wrong-type sets, unknown value references, an FMU state
round trip and many instantiate/free cycles (:data:`.table.CASES`, run by the functions of
:mod:`.cases` and :mod:`.memory`). The variables a case
abuses are chosen from ``modelDescription.xml`` (:func:`.target.describe`); a case whose
variable does not exist (no input, no ranged parameter, ...) is "n/a".

The limit cases of issue 26 (the second block of :data:`.table.CASES`): every single-bit flip of
a serialized state (``--flips N``: a seeded sample), a half-zeroed, resized or foreign
state; steps of 1e9, 1e12, 1e30 and DBL_MAX s (also at the minimum sample period) within a CPU
time and a short time limit; start times of 1e9 and 1.4e9 s against the same run from 0 and
communication points 1 ms to 1 s off at 1e9 s; the five status functions with each
``fmi2StatusKind`` in each FMI state and ``fmi2Terminate`` in the error state (FMI 2.0:
:func:`.limits.required_status`); outputs at t = DBL_MAX and with equal time parameters. The
host-level cases (the last block): fmi2Instantiate with a resource URI that is no folder, a NULL
or empty instance name, a wrong GUID, fmi2ModelExchange; fmi2SetDebugLogging with a NULL
category; fmi2SerializeFMUstate into too small a buffer.

Verdicts: ``pass``, ``fail``, ``crash`` and ``n/a``.

The cases of one FMU run in a child process (``python -m satfmu.sims.robustness --worker``, :mod:`.worker`),
which reports each case as it starts and ends. If the child dies (segfault, abort)
the case it was running is recorded as CRASH and the remaining cases continue in a
new child; a case that does not finish within its time limit is killed and FAILs.

Expected behaviour per backend (measured; see ``tests/test_fmu_robustness.py`` for the
detailed checks of four FMUs):

* native FMUs (``fmus/c/fmi2_cosim.c``) reject a bad call with fmi2Error and a message
  naming the function or variable (logged whether or not logging is on), store
  nothing, and stay usable: the suite checks that the abused value is unchanged and
  that the normal sequence up to a completed ``fmi2DoStep`` still works (after
  ``fmi2Reset`` when the instance is Terminated or in the error state);
* pythonfmu FMUs (``fmus/pyslave.py`` behind satfmu's C layer, ``fmus/c/pythonfmu_shim.c``, in
  front of pythonfmu 0.7.0's library) meet the same expectations: the layer refuses the invalid
  host arguments pythonfmu alone crashes on, answers the status functions by the slave's state
  and reports the slave's refusals as fmi2Error (``docs/pythonfmu.md``). An instance that
  answered fmi2Fatal would be abandoned, never freed.

Measured differences between the backends (``docs/robustness.md``):

* a huge finite value (1e300) is accepted by both (no declared maximum excludes it); where
  the native model code overflows to inf (and the state check reports it, or an output is
  +-inf/NaN with fmi2OK), Python may raise OverflowError instead, which the pythonfmu FMU
  reports as fmi2Error naming the exception (``cubesat_bdot_py``, ``mrp_hinf_satfmu_py``);
* the FMU state round trip repeats the outputs bit for bit on both backends (pythonfmu
  serializes the state as JSON with repr floats, which round-trip exactly).

Memory: pythonfmu 0.7.0's ``fmi2Instantiate`` leaks on every call: its ``findClass``
(``src/pythonfmu/PySlaveInstance.cpp``) re-executes the slave script, which creates a new
class object, and never releases the ``PySequence_List`` of that class's ``__mro__`` (so
the class is never freed) nor the ``repr`` strings it builds; it also inserts the resources
folder into ``sys.path`` once more. Measured 2.6 to 4.3 KiB per instantiate/free cycle
(1000 cycles), hence the pythonfmu bound of :func:`.memory.rss_bound_kib`. The slave objects
themselves are freed (checked exactly, :func:`.memory.live_slaves`). Native FMUs: 0 KiB.
"""
from __future__ import annotations

from satfmu.sims.robustness.command import main
from satfmu.sims.robustness.memory import rss_bound_kib
from satfmu.sims.robustness.runner import SuiteResult, Row, run
from satfmu.sims.robustness.table import CASES, CYCLES_CASE, FAR_CASE, Case, Settings, always_applies
from satfmu.sims.robustness.target import BACKENDS, NATIVE, PYTHONFMU
from satfmu.sims.robustness.worker import ABORT_ENV

__all__ = ["ABORT_ENV", "BACKENDS", "CASES", "CYCLES_CASE", "FAR_CASE", "NATIVE", "PYTHONFMU", "Case", "Row",
           "Settings", "SuiteResult", "always_applies", "main", "rss_bound_kib", "run"]
