"""The exact integrator's flow cache (fmus/c/satfmu_core.h, fmus/pyslave.py): a step that differs from
the cached one in the last bits reuses its flow.

Importers step with ``t + h`` rounded (fmpy, fmusim): the step sizes they pass differ in the last
bits. Keyed on the exact step, the cache missed on 17 of 30 steps of demeter_flexible in fmusim
(5.2 s against 0.24 s in the Compliance Checker, 448 s against 20.6 s for the pythonfmu FMU). Here
a run whose steps alternate between h and the next double above it (h first) must give the
states of the run at a constant h bit for bit: the flow of h is reused (computed again, the flow
of the other duration would round differently).
"""
from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave

H = 1e-3
"""s, DEMETER's step."""
STEPS = 200


def _states(fmu: Path, steps: list[float]) -> np.ndarray:
    """The Real outputs after each step of a run from rest with the wheel torque held at 0.01 N m."""
    md = read_model_description(str(fmu))
    folder = extract(str(fmu), unzipdir=tempfile.mkdtemp(prefix="satfmu_flow_"))
    try:
        slave = FMU2Slave(guid=md.guid, unzipDirectory=folder, modelIdentifier=md.coSimulation.modelIdentifier,
                          instanceName="flow")
        slave.instantiate()
        slave.setupExperiment(startTime=0.0)
        slave.enterInitializationMode()
        slave.exitInitializationMode()
        refs = {v.name: v.valueReference for v in md.modelVariables}
        slave.setReal([refs["u_c[1]"]], [0.01])
        outs = [v.valueReference for v in md.modelVariables if v.causality == "output" and v.type == "Real"]
        rows, t = [], 0.0
        for h in steps:
            slave.doStep(t, h)
            t += h
            rows.append(slave.getReal(outs))
        slave.terminate()
        slave.freeInstance()
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    return np.array(rows)


@pytest.mark.parametrize("name", ["demeter_flexible", "demeter_flexible_py"])
def test_steps_that_differ_in_the_last_bits_reuse_the_flow(name: str, fmu_dir: Path) -> None:
    fmu = fmu_dir / f"{name}.fmu"
    constant = _states(fmu, [H] * STEPS)
    # the first step computes the flow, every later one reuses it (its duration 1 ulp longer or not)
    wobbly = _states(fmu, [float(np.nextafter(H, 1.0)) if k % 2 else H for k in range(STEPS)])
    assert np.abs(constant).max() > 0  # the wheel torque moves the spacecraft
    np.testing.assert_array_equal(wobbly, constant)
    # a step that really differs (1e-6 relative, far above the reuse tolerance) gets its own flow
    other = _states(fmu, [H * (1 + 1e-6)] * STEPS)
    assert not np.array_equal(other, constant)
