"""Units: metrics and records converted from the FMU's declared unit, one spelling (issue 56 item 3)."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import satfmu
from satfmu.fmus import units
from satfmu.fmus.errors import ScenarioError, UnitError
from satfmu.fmus.units import UNITS

SLEW = {"name": "slew", "stop_time": 20.0, "step_size": 0.05,
        "fmus": {"plant": {"model": "mrp_satellite", "parameters": {"sigma_0[1]": 0.3}},
                 "controller": {"model": "mrp_hinf_published"}},
        "connections": [{"from": "plant.sigma", "to": "controller.sigma"},
                        {"from": "plant.omega", "to": "controller.omega"},
                        {"from": "controller.u", "to": "plant.u"}]}


def _metric(**fields: object) -> dict:
    return {**SLEW, "metrics": [{"name": "m", "kind": "final", "signals": ["plant.phi"], **fields}]}


def test_conversions_are_the_ratio_of_the_base_unit_factors() -> None:
    # exact to the last bit where the old hand-typed factor was 180/pi: the pass/fail of every shipped
    # scenario is unchanged by dropping `scale = 57.29577951308232`
    assert units.conversion("rad", "deg") == 57.29577951308232 == math.degrees(1.0)
    assert units.conversion("rad/s", "deg/s") == 57.29577951308232
    assert units.conversion("rad", "mrad") == 1000.0
    assert units.conversion("arcsec", "rad") == pytest.approx(math.pi / 648000, rel=1e-15)
    assert units.conversion("N.m", "mN.m") == 1000.0
    assert units.conversion("s", "min") == pytest.approx(1 / 60, rel=1e-15)
    assert units.conversion("rad/s0.5", "rad/s0.5") == 1.0  # a unit without a base unit converts to itself only
    # a third-party FMU's own definition of its unit is what counts
    assert units.conversion("mm", "km", {"mm": {"m": 1, "factor": 1e-3}}) == pytest.approx(1e-6, rel=1e-15)


@pytest.mark.parametrize("source, target, message", [
    ("rad", "N.m", r"cannot convert 'rad' \(rad\) to 'N.m' \(kg.m2.s-2\)"),
    ("N.m", "N m", r"unknown unit 'N m'; did you mean 'N.m'\?"),
    ("A.m2", "A m^2", r"did you mean 'A.m2'\?"),
    ("rad", "furlong", r"unknown unit 'furlong' \(units: 1, s, rad"),
    ("rad/s0.5", "rad/s", r"no base unit"),
    ("degC", "K", r"has an offset"),
])
def test_impossible_conversions_say_why(source: str, target: str, message: str) -> None:
    declared = {"degC": {"K": 1, "offset": 273.15}}
    with pytest.raises(UnitError, match=message):
        units.conversion(source, target, declared)


def test_derived_units_are_spelt_as_the_declared_ones() -> None:
    assert units.squared_time("N.m") == "N2.m2.s"
    assert units.squared_time("A.m2") == "A2.m4.s"
    assert units.squared_time("rad") == "rad2.s"
    assert units.ratio("rad", "rad") == "1"
    assert units.ratio("1", "N.m") == "1/(N.m)"
    assert set(UNITS) <= set(units.KNOWN) and not set(UNITS) & set(units.DISPLAY)  # one spelling each


def test_a_metric_in_deg_is_the_declared_rad_converted(fmu_dir: Path) -> None:
    rad = satfmu.run(_metric(), fmu_dir=fmu_dir).metrics[0]
    deg = satfmu.run(_metric(unit="deg"), fmu_dir=fmu_dir).metrics[0]
    assert rad.unit == "rad" and deg.unit == "deg"  # without `unit`: the declared one
    assert deg.value == rad.value * (180 / math.pi)  # the same product as the old scale, bit for bit
    settle = [satfmu.run({**SLEW, "metrics": [{"name": "s", "kind": "settling_time", "signals": ["plant.phi"],
                                              **fields}]}, fmu_dir=fmu_dir).metrics[0]
              for fields in ({"unit": "deg", "tolerance": 20.0}, {"tolerance": math.radians(20.0)})]
    assert settle[0].unit == settle[1].unit == "s"  # the tolerance in the asked unit, the value in s
    assert 0 < settle[0].value == settle[1].value < 20
    h2 = satfmu.run({**SLEW, "metrics": [{"name": "h2", "kind": "integral_square", "signals": ["plant.u"]}]},
                    fmu_dir=fmu_dir).metrics[0]
    assert h2.unit == "N2.m2.s"


@pytest.mark.parametrize("fields, message", [
    ({"unit": "deg", "scale": 57.29577951308232}, r"metrics\[0\]: scale 57.2958 and unit 'deg' would both convert"),
    ({"unit": "N.m"}, r"metrics\[0\]\.unit: plant.phi is in 'rad': cannot convert 'rad'"),
    ({"unit": "N m"}, r"did you mean 'N.m'"),
])
def test_a_unit_that_cannot_be_is_refused_before_the_run(fields: dict, message: str, fmu_dir: Path) -> None:
    with pytest.raises(ScenarioError, match=message):
        satfmu.run(_metric(**fields), fmu_dir=fmu_dir)


def test_a_hand_typed_settling_unit_of_s_is_refused_not_misread(fmu_dir: Path) -> None:
    # the old spelling (scale to deg, unit "s" for the value) names the signal's unit now
    old = {**SLEW, "metrics": [{"name": "s", "kind": "settling_time", "signals": ["plant.phi"],
                                "scale": 57.29577951308232, "tolerance": 1.0, "unit": "s"}]}
    with pytest.raises(ScenarioError, match=r"plant.phi is in 'rad': cannot convert 'rad' \(rad\) to 's'"):
        satfmu.run(old, fmu_dir=fmu_dir)


def test_a_record_entry_asks_for_its_unit(fmu_dir: Path, tmp_path: Path) -> None:
    data = {**SLEW, "record": [{"signal": "plant.phi", "unit": "deg"}, "plant.omega"]}
    sc = satfmu.Scenario.from_dict(data)
    assert sc.record == ["plant.phi", "plant.omega"] and sc.units == {"plant.phi": "deg"}
    assert satfmu.Scenario.from_dict(sc.to_dict()).units == sc.units  # the declaration round-trips
    shown = satfmu.run(data, fmu_dir=fmu_dir)
    plain = satfmu.run({**SLEW, "record": ["plant.phi"]}, fmu_dir=fmu_dir)
    np.testing.assert_array_equal(shown.results["plant.phi"], plain.results["plant.phi"] * (180 / math.pi))
    assert shown.units["plant.phi"] == "deg" and shown.units["plant.omega[1]"] == "rad/s"
    files = shown.write(tmp_path)
    header = files["csv"].read_text().splitlines()[0]
    assert "plant.phi" in header
    with pytest.raises(ScenarioError, match=r"record\[0\]\.unit: plant.phi is in 'rad': cannot convert"):
        satfmu.run({**SLEW, "record": [{"signal": "plant.phi", "unit": "s"}]}, fmu_dir=fmu_dir)
    with pytest.raises(ScenarioError, match=r"record\[0\]: unknown key 'units'.*'unit'"):
        satfmu.Scenario.from_dict({**SLEW, "record": [{"signal": "plant.phi", "units": "deg"}]})


def test_a_campaign_labels_each_value_in_its_own_unit() -> None:
    # a campaign's statistics and report read the declaration only: a settling time asked in deg is
    # a time, a margin has its own unit, an integral of squared torques its derived one
    unit = {kind: satfmu.Metric("m", kind, ["plant.phi"], unit=u).value_unit
            for kind, u in (("settling_time", "deg"), ("final", "deg"), ("phase_margin", ""),
                            ("integral_square", "N.m"), ("peak", ""))}
    assert unit == {"settling_time": "s", "final": "deg", "phase_margin": "deg", "integral_square": "N2.m2.s",
                    "peak": ""}
