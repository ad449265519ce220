"""The orbit and environment model: Kepler and J2, the Sun and the shadow, the field, the density."""
from __future__ import annotations

import datetime as dt
import math
from pathlib import Path

import numpy as np
import pytest

from satfmu.fmus import codegen
from satfmu.fmus.environment import atmosphere, orbit

MU = orbit.MU_EARTH
ISS = ("1 25544U 98067A   24001.50000000  .00016717  00000-0  10270-3 0  9005",
       "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.50000000 10001")


class Environment:
    """The generated Python of ``orbit_environment`` at chosen parameters."""

    def __init__(self, **params: float) -> None:
        self.gen = codegen.load_python(orbit.MODEL)
        self.p = orbit.MODEL.parameter_vector(params).tolist()
        self.names = [o.variable.name for o in orbit.MODEL.outputs]

    def at(self, t: float) -> dict[str, float]:
        return dict(zip(self.names, self.gen.outputs(t, [], [], self.p)))

    def vec(self, t: float, base: str) -> np.ndarray:
        y = self.at(t)
        return np.array([y[f"{base}[{i}]"] for i in (1, 2, 3)])


def test_kepler_orbit_keeps_its_energy_and_momentum_and_the_velocity_is_the_derivative() -> None:
    env = Environment(semi_major_axis=8.0e6, eccentricity=0.3, inclination=0.9, raan=1.0, arg_perigee=2.0,
                      mean_anomaly_0=0.5, j2_on=0.0)
    h0 = None
    for t in np.linspace(0.0, 20000.0, 23):
        r, v = env.vec(t, "r"), env.vec(t, "v")
        energy = v @ v / 2 - MU / np.linalg.norm(r)
        assert energy == pytest.approx(-MU / (2 * 8.0e6), rel=1e-12)  # vis-viva; Kepler solved to rounding
        h = np.cross(r, v)
        assert np.linalg.norm(h) == pytest.approx(math.sqrt(MU * 8.0e6 * (1 - 0.09)), rel=1e-12)
        h0 = h if h0 is None else h0
        assert np.allclose(h, h0, rtol=1e-12, atol=0)
        assert 8.0e6 * 0.7 * (1 - 1e-12) <= np.linalg.norm(r) <= 8.0e6 * 1.3 * (1 + 1e-12)
    # v is dr/dt: central difference at 0.01 s, error ~ |r'''| h^2 / 6 ~ 1e-7 m/s
    for t in (100.0, 4321.0):
        dr = (env.vec(t + 0.01, "r") - env.vec(t - 0.01, "r")) / 0.02
        assert np.allclose(dr, env.vec(t, "v"), rtol=0, atol=1e-5)


def test_j2_turns_a_sun_synchronous_node_once_a_year() -> None:
    # 500 km at 97.40 deg: J2's node rate is the mean Sun's, 360 deg per 365.2422 days
    env = Environment(**{k: v for k, v in orbit.circular(500e3, 97.40).items()})
    node = []
    for t in (0.0, 86400.0):
        h = np.cross(env.vec(t, "r"), env.vec(t, "v"))
        node.append(math.atan2(h[0], -h[1]))
    rate = math.degrees(node[1] - node[0])
    assert rate == pytest.approx(360.0 / 365.2422, rel=5e-3)  # the inclination to 0.01 deg
    # with the drift included, v stays the derivative of r
    dr = (env.vec(1000.01, "r") - env.vec(999.99, "r")) / 0.02
    assert np.allclose(dr, env.vec(1000.0, "v"), rtol=0, atol=1e-5)


def test_sun_is_on_the_vernal_equinox_at_the_march_equinox_and_the_shadow_is_behind_the_earth() -> None:
    # March equinox 2027: 2027-03-20 20:25 UTC (the Sun crosses the equator going north)
    epoch = orbit.seconds_since_j2000(dt.datetime(2027, 3, 20, 20, 25))
    # equatorial circular orbit at 700 km, starting on the anti-Sun side (-x) and reaching +y after a quarter
    env = Environment(semi_major_axis=orbit.EQUATORIAL_RADIUS + 700e3, inclination=0.0, mean_anomaly_0=math.pi,
                      epoch_j2000=epoch, j2_on=0.0)
    sun = env.vec(0.0, "sun")
    assert math.degrees(math.acos(sun @ [1.0, 0.0, 0.0])) < 0.03  # 0.01 deg theory + the parallax of the orbit
    assert env.at(0.0)["sunlit"] == 0.0  # deep in the umbra
    period = 2 * math.pi * math.sqrt((orbit.EQUATORIAL_RADIUS + 700e3) ** 3 / MU)
    assert env.at(period / 4)["sunlit"] == 1.0
    assert env.at(0.0)["sun_distance"] == pytest.approx(0.996 * orbit.ASTRONOMICAL_UNIT, rel=2e-3)
    # along the exit from the shadow the conical model goes 0 -> 1 monotonically through a penumbra of
    # about 9 s (the Sun's 0.53 deg seen from 7.5 km/s at 7078 km), the cylinder switches at once
    ts = np.linspace(0.0, period / 4, 2000)
    cone = np.array([env.at(t)["sunlit"] for t in ts])
    assert np.all(np.diff(cone) >= -1e-12) and cone[0] == 0.0 and cone[-1] == 1.0
    partial = ts[(cone > 0) & (cone < 1)]
    assert 4.0 < np.ptp(partial) + (ts[1] - ts[0]) < 20.0
    cyl = Environment(semi_major_axis=orbit.EQUATORIAL_RADIUS + 700e3, inclination=0.0, mean_anomaly_0=math.pi,
                      epoch_j2000=epoch, j2_on=0.0, eclipse_model=0)
    values = {cyl.at(t)["sunlit"] for t in ts}
    assert values == {0.0, 1.0}


def test_density_follows_the_exponential_models() -> None:
    for altitude, expected in ((500e3, 6.967e-13), (400e3, 3.725e-12), (1000e3, 3.019e-15)):
        env = Environment(semi_major_axis=orbit.EQUATORIAL_RADIUS + altitude, j2_on=0.0)
        assert env.at(123.0)["altitude"] == pytest.approx(altitude, rel=1e-12)
        assert env.at(123.0)["density"] == pytest.approx(expected, rel=1e-9)  # the bases of Vallado's bands
    # between bases: rho0 exp(-(h - h0) / H) of the band below (450 km band: 1.585e-12, 60.828 km)
    env = Environment(semi_major_axis=orbit.EQUATORIAL_RADIUS + 475e3, j2_on=0.0)
    assert env.at(0.0)["density"] == pytest.approx(1.585e-12 * math.exp(-25 / 60.828), rel=1e-9)
    one = Environment(semi_major_axis=orbit.EQUATORIAL_RADIUS + 550e3, j2_on=0.0, density_model=1,
                      density_0=1e-12, density_altitude_0=500e3, scale_height=50e3)
    assert one.at(0.0)["density"] == pytest.approx(1e-12 * math.exp(-1.0), rel=1e-12)
    assert len(atmosphere.VALLADO_TABLE) == 28
    # the band the model evaluates, as one exponential would need it (Basilisk's exponentialAtmosphere)
    assert atmosphere.vallado_band(500e3) == (500e3, 6.967e-13, 63.822e3)
    assert atmosphere.vallado_band(499_999.0) == (450e3, 1.585e-12, 60.828e3)  # a band is [h0, h1)
    assert atmosphere.vallado_band(-10.0)[0] == 0.0 and atmosphere.vallado_band(5e6)[0] == 1000e3
    h0, rho0, scale = atmosphere.vallado_band(475e3)
    assert env.at(0.0)["density"] == pytest.approx(rho0 * math.exp(-(475e3 - h0) / scale), rel=1e-12)


def test_dipole_field_has_its_textbook_magnitudes() -> None:
    # on the dipole's magnetic equator |b| = M / r^3; over a magnetic pole 2 M / r^3
    r0 = orbit.EQUATORIAL_RADIUS + 500e3
    pole = Environment(semi_major_axis=r0, inclination=math.pi / 2, mean_anomaly_0=math.pi / 2, j2_on=0.0,
                       dipole_colatitude=0.0)  # an untilted dipole; the orbit starts over the north pole
    assert np.linalg.norm(pole.vec(0.0, "b")) == pytest.approx(2 * orbit.DIPOLE_MOMENT / r0**3, rel=1e-12)
    assert pole.vec(0.0, "b")[2] < 0  # the field points down into the north (geographic) pole
    equator = Environment(semi_major_axis=r0, inclination=0.0, j2_on=0.0, dipole_colatitude=0.0)
    assert np.linalg.norm(equator.vec(0.0, "b")) == pytest.approx(orbit.DIPOLE_MOMENT / r0**3, rel=1e-12)


def test_elements_from_a_tle_and_a_circular_orbit() -> None:
    p = orbit.from_tle(*ISS)
    assert p["epoch_j2000"] == orbit.seconds_since_j2000(dt.datetime(2024, 1, 1, 12))
    assert math.degrees(p["inclination"]) == pytest.approx(51.6416, abs=1e-9)
    assert p["semi_major_axis"] == pytest.approx((MU / (15.5 * 2 * math.pi / 86400) ** 2) ** (1 / 3), rel=2e-4)
    env = Environment(**p)
    assert 380e3 < env.at(0.0)["altitude"] < 440e3  # the ISS's altitude band
    with pytest.raises(ValueError, match="sgp4"):
        orbit.from_tle("1 garbage", "2 garbage")
    c = orbit.circular(600e3, 98.0, raan_deg=30.0, epoch=dt.datetime(2030, 1, 1))
    assert c["semi_major_axis"] == orbit.EQUATORIAL_RADIUS + 600e3 and c["eccentricity"] == 0.0
    for bad in ((-1.0, 98.0), (math.nan, 98.0), (500e3, 181.0)):
        with pytest.raises(ValueError):
            orbit.circular(*bad)


def test_native_fmu_matches_the_generated_python_and_refuses_bad_elements(fmu_dir: Path, capfd) -> None:
    from fmpy import simulate_fmu

    start = {"eccentricity": 0.2, "semi_major_axis": 9.0e6, "inclination": 1.1}
    res = simulate_fmu(str(fmu_dir / "orbit_environment.fmu"), stop_time=3000.0, output_interval=100.0,
                       start_values=start, output=["r[1]", "v[2]", "sunlit", "density", "b[3]"])
    env = Environment(**start)
    for row in res[::7]:
        y = env.at(float(row["time"]))
        for name in ("r[1]", "v[2]", "sunlit", "density", "b[3]"):
            assert row[name] == pytest.approx(y[name], rel=1e-13, abs=1e-300)  # C and Python of one expression
    capfd.readouterr()
    for bad in ({"eccentricity": math.nan}, {"eccentricity": 0.95}, {"semi_major_axis": -7e6}):
        with pytest.raises(Exception, match="fmi2SetReal failed"):
            simulate_fmu(str(fmu_dir / "orbit_environment.fmu"), stop_time=1.0, start_values=bad)
        assert f"'{next(iter(bad))}'" in capfd.readouterr().out  # the FMU's log names the variable


def test_field_along_the_orbit_axes_is_the_cubesats_dipole_on_the_same_orbit() -> None:
    # the magnetorquer cubesat's own dipole field (field_model 1) on the same circular orbit and the same
    # Earth angle: the two differ only by the Earth rates (7.2921159e-5 vs 7.2921150e-5 rad/s: 3e-10 rad in
    # 1000 s) and rounding
    from satfmu.fmus.plants import cubesat

    altitude, inc, raan, u0 = 500e3, math.radians(87.0), 0.4, 1.1
    a = cubesat.EARTH_RADIUS + altitude
    env = Environment(semi_major_axis=a, inclination=inc, raan=raan, mean_anomaly_0=u0, j2_on=0.0)
    era0 = env.at(0.0)["earth_angle"]
    gen = codegen.load_python(cubesat.MODEL)
    p = cubesat.MODEL.parameter_vector({"field_model": 1, "orbit_altitude": altitude, "orbit_inclination": inc,
                                        "orbit_raan": raan, "orbit_arg_latitude_0": u0,
                                        "earth_rotation_angle_0": era0,
                                        "orbit_period": 2 * math.pi * math.sqrt(a**3 / MU)}).tolist()
    names = [o.variable.name for o in cubesat.MODEL.outputs]
    x0 = [s.initial.start for s in cubesat.MODEL.states]
    u = [0.0] * len(cubesat.MODEL.inputs)
    for t in (0.0, 400.0, 1000.0):
        y = dict(zip(names, gen.outputs(t, x0, u, p)))
        theirs = np.array([y[f"b_orbit[{i}]"] for i in (1, 2, 3)])
        assert np.allclose(env.vec(t, "b_orbit"), theirs, rtol=0, atol=1e-9 * np.linalg.norm(theirs))
