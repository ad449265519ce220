"""The pytest gate of ``own_spacecraft.py``'s design (run: ``pytest examples/test_own_spacecraft.py``).

It uses satfmu's pytest plugin: ``satfmu_run`` runs a scenario in the session's FMU folder
(building what is missing), ``assert_passed``/``assert_metric`` fail with readable lines.
The design is the one ``own_spacecraft.py`` saved in your satfmu folder; made here if absent.
"""
from __future__ import annotations

import pytest

import satfmu
from satfmu.testing import assert_metric, assert_passed

import own_spacecraft as example


@pytest.fixture(scope="module")
def artifact():
    try:
        return satfmu.load_artifact(example.CONTROLLER)
    except FileNotFoundError:
        example.design().write()
        return satfmu.load_artifact(example.CONTROLLER)


def test_design_is_certified_for_my_spacecraft(artifact):
    assert artifact.certificate["status"] == "certified"
    assert artifact.provenance["design_plant"]["parameters"]["I_xy"] == 2.0


def test_manoeuvre_meets_the_spec(artifact, satfmu_run):
    result = satfmu_run(example.scenario())
    assert_passed(result)
    assert result.warnings == []
    # a tighter bound of our own than the scenario's 20 N m
    assert_metric(result, "peak torque", max=18.0)


def test_published_controller_is_flagged_on_my_spacecraft(satfmu_run):
    with pytest.warns(satfmu.DesignMismatchWarning, match=r"I_x = 100 \(designed for 15\)"):
        satfmu_run(example.scenario("mrp_hinf_published"))
    with pytest.raises(satfmu.ScenarioError, match="design mismatch"):
        satfmu_run(example.scenario("mrp_hinf_published"), strict=True)
