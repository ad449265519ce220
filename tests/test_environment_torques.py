"""The environment's torques in the wheel plant: each against its formula, switched, and fed to the body."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from satfmu.fmus.environment.constants import ASTRONOMICAL_UNIT, EQUATORIAL_RADIUS, MU_EARTH
from satfmu.fmus.errors import SpacecraftError
from satfmu.fmus.plants import surface, wheel_spacecraft
from satfmu.fmus.plants.environment_torques import SOLAR_PRESSURE
from satfmu.fmus.plants.spacecraft import Spacecraft
from tests.test_wheel_spacecraft import Plant

SC = wheel_spacecraft.SMALLSAT[4]
ON = {"gravity_gradient_on": 1.0, "drag_on": 1.0, "srp_on": 1.0, "dipole_on": 1.0}
REST = [0.0] * 6 + [0.0] * 8  # body at rest, aligned with the inertial axes (C = I), wheels idle
QUARTER_Z = [0.0] * 3 + [0.0, 0.0, math.tan(math.pi / 8)] + [0.0] * 8  # body turned +90 deg about z


def _facet(axis: str) -> surface.Facet:
    return next(f for f, name in zip(SC.facets, ("+x", "-x", "+y", "-y", "+z", "-z")) if name == axis)


def test_gravity_gradient_is_3_mu_over_r5_r_cross_J_r_in_body_axes() -> None:
    plant = Plant(**ON)
    J = SC.tensor
    r = np.array([4.0e6, 3.0e6, 5.0e6])
    for x, C in ((REST, np.eye(3)), (QUARTER_Z, np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]))):
        ui = plant.inputs(**{f"r[{i + 1}]": v for i, v in enumerate(r)})
        rb = C @ r
        expected = 3 * MU_EARTH / np.linalg.norm(rb) ** 5 * np.cross(rb, J @ rb)
        assert np.allclose(plant.ys(x, ui, "tau_gravity_gradient"), expected, rtol=1e-13, atol=0)


def test_drag_and_radiation_pressure_push_the_facets_that_face_the_flow_and_the_sun() -> None:
    plant = Plant(**ON)
    rho, speed = 1e-12, 7500.0
    ui = plant.inputs(**{"v_air[1]": speed, "density": rho, "sun[1]": 1.0, "sun[2]": 0.0, "sun[3]": 0.0,
                         "sunlit": 1.0, "sun_distance": ASTRONOMICAL_UNIT})
    f = _facet("+x")  # the only facet facing +x (the flow and the Sun)
    drag = -0.5 * rho * speed**2 * f.drag_coefficient * f.area * np.array([1.0, 0.0, 0.0])
    assert np.allclose(plant.ys(REST, ui, "tau_drag"), np.cross(f.centre_of_pressure, drag), rtol=1e-12, atol=0)
    # normal incidence: F = -P A ((1 - rho_s) s + 2 (rho_s + rho_d / 3) n), s = n = +x
    srp = -SOLAR_PRESSURE * f.area * ((1 - f.specular) + 2 * (f.specular + f.diffuse / 3)) * np.array([1.0, 0, 0])
    assert np.allclose(plant.ys(REST, ui, "tau_srp"), np.cross(f.centre_of_pressure, srp), rtol=1e-12, atol=0)
    shadow = plant.inputs(**{"sun[1]": 1.0, "sunlit": 0.0})
    assert np.all(plant.ys(REST, shadow, "tau_srp") == 0.0)
    far = plant.inputs(**{"sun[1]": 1.0, "sunlit": 1.0, "sun_distance": 2 * ASTRONOMICAL_UNIT})
    assert np.allclose(plant.ys(REST, far, "tau_srp"), np.cross(f.centre_of_pressure, srp) / 4, rtol=1e-12)
    # oblique: the Sun at 60 deg from +x in the x-y plane lights +x (cos 1/2) and +y (cos sqrt(3)/2)
    s = np.array([0.5, math.sqrt(3) / 2, 0.0])
    ui = plant.inputs(**{f"sun[{i + 1}]": v for i, v in enumerate(s)}, sunlit=1.0)
    total = np.zeros(3)
    for fac in (_facet("+x"), _facet("+y")):
        n, cos = np.array(fac.normal), float(np.array(fac.normal) @ s)
        force = -SOLAR_PRESSURE * fac.area * cos * ((1 - fac.specular) * s + 2 * (fac.specular * cos
                                                                                   + fac.diffuse / 3) * n)
        total += np.cross(fac.centre_of_pressure, force)
    assert np.allclose(plant.ys(REST, ui, "tau_srp"), total, rtol=1e-12, atol=0)


def test_residual_dipole_torque_and_the_switches() -> None:
    b = np.array([2e-5, -1e-5, 3e-5])
    on, off = Plant(**ON), Plant()
    ui = on.inputs(**{f"b[{i + 1}]": v for i, v in enumerate(b)})
    assert np.allclose(on.ys(REST, ui, "tau_dipole"), np.cross(wheel_spacecraft.SMALLSAT_DIPOLE, b), rtol=1e-14)
    for name in ("gravity_gradient", "drag", "srp", "dipole"):  # off by default: today's plant
        assert np.all(off.ys(REST, ui, f"tau_{name}") == 0.0)


def test_the_torques_turn_the_body() -> None:
    # omega' with every torque on differs from omega' with them off by Jb^-1 (sum of the torques)
    on, off = Plant(**ON), Plant()
    env = {"r[1]": EQUATORIAL_RADIUS + 500e3, "r[2]": 1e6, "v_air[2]": 7600.0, "density": 6e-13, "sun[3]": 1.0,
           "sun[1]": 0.0, "sunlit": 1.0, "b[1]": 3e-5}
    ui = on.inputs(**env)
    x = [0.01, 0.02, -0.01, 0.1, 0.2, -0.1] + [50.0] * 4 + [0.0] * 4
    dw = np.array(on.gen.derivatives(0.0, x, x, ui, on.p)[:3]) - np.array(off.gen.derivatives(0.0, x, x, ui, off.p)[:3])
    total = sum(on.ys(x, ui, f"tau_{n}") for n in ("gravity_gradient", "drag", "srp", "dipole"))
    assert np.linalg.norm(total) > 1e-7  # every torque is there (~1e-5 N m)
    assert np.allclose(SC.body_inertia @ dw, total, rtol=1e-9, atol=1e-20)


def test_the_surface_in_the_description_and_bad_facets() -> None:
    sc = Spacecraft.from_dict(SC.to_dict())
    assert sc.facets == SC.facets and sc.residual_dipole == SC.residual_dipole
    assert sum(f.area for f in surface.box((1.0, 2.0, 3.0))) == pytest.approx(22.0, rel=1e-15)
    for change, message in (({"area": 0.0}, "area"), ({"normal": [0, 0, 0]}, "zero vector"),
                            ({"specular": 0.7, "diffuse": 0.5}, "specular \\+ diffuse"),
                            ({"drag_coefficient": -1.0}, "drag_coefficient"), ({"colour": "red"}, "colour")):
        with pytest.raises(SpacecraftError, match=message):
            surface.Facet.from_dict({**_facet("+x").to_dict(), **change})
    with pytest.raises(SpacecraftError, match="residual_dipole"):
        Spacecraft("s", [1.0, 1.0, 1.0], residual_dipole=(1.0, math.nan, 0.0))
    with pytest.raises(SpacecraftError, match="size"):
        surface.box((1.0, 0.0, 1.0))


def test_fmu_refuses_a_facet_without_area(fmu_dir: Path, capfd) -> None:
    from fmpy import simulate_fmu

    capfd.readouterr()
    with pytest.raises(Exception, match="fmi2SetReal failed"):
        simulate_fmu(str(fmu_dir / "mrp_satellite_rw4.fmu"), stop_time=1.0, start_values={"facet_area[3]": 0.0})
    assert "'facet_area[3]'" in capfd.readouterr().out
