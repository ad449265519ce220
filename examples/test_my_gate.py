"""A pytest gate of your own on FMU outputs (run: ``pytest examples/test_my_gate.py``).

satfmu's pytest plugin gives the ``satfmu_run`` fixture (FMUs built or reused once per
session) and readable assertions.
"""
from __future__ import annotations

from pathlib import Path

from satfmu.testing import assert_metric, assert_passed

SCENARIO = Path(__file__).with_name("my_scenario.toml")


def test_my_scenario_meets_its_bounds(satfmu_run):
    assert_passed(satfmu_run(SCENARIO))


def test_disturbance_rejection_is_tight(satfmu_run):
    result = satfmu_run(SCENARIO)
    # the 0.5 N m pulse needs little torque: well inside the 5 N m of the scenario
    assert_metric(result, "peak torque", max=3.0)
