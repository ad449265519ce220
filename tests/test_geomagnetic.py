"""IGRF along the cubesat's orbit (satfmu.fmus.environment.geomagnetic), its Fourier fit and the ``igrf``
profile kind."""
from __future__ import annotations

import datetime as dt
import math
import subprocess
import sys
import tomllib

import numpy as np
import pytest
import sympy as sp
from ppigrf import igrf_gc

from satfmu.fmus.plants import cubesat
from satfmu.fmus.environment.geomagnetic import (
    ORBIT_PARAMETERS,
    fourier_basis,
    fourier_fit,
    igrf_orbit_field,
    model_defaults,
    orbit_geometry,
    seed_fourier_coefficients,
)
from satfmu.fmus.profiles import ProfileError, make

EPOCH = dt.datetime(2020, 1, 1)
T = cubesat.ORBIT_PERIOD_SEED
DEFAULTS = model_defaults()


def _dipole_numeric() -> callable:
    """``satfmu.fmus.plants.cubesat.dipole_field_orbit`` lambdified in (tau, every cubesat parameter)."""
    tau = sp.Symbol("tau", real=True)
    p = {name: sp.Symbol(name, real=True) for name in DEFAULTS}
    f = sp.lambdify([tau, *p.values()], list(cubesat.dipole_field_orbit(tau, p)), "numpy")

    def field(t: np.ndarray, params: dict[str, float]) -> np.ndarray:
        vals = f(t, *(params[k] for k in DEFAULTS))
        return np.stack([np.broadcast_to(np.asarray(v, float), np.shape(t)) for v in vals], -1)
    return field


DIPOLE = _dipole_numeric()


def igrf_dipole(epoch: dt.datetime) -> tuple[float, float, float]:
    """Degree-1 IGRF as the cubesat's dipole parameters: (M in T m^3, north pole colatitude, longitude, rad).

    The Gauss coefficients come from ppigrf itself, evaluated with max_degree = 1 on the reference
    sphere r = R_E at the equator, where B_r = 2 (g11 cos phi + h11 sin phi) and B_theta = g10.
    """
    r_e = cubesat.EARTH_RADIUS / 1e3
    br, bt, _ = igrf_gc(r_e, np.array([90.0, 90.0]), np.array([0.0, 90.0]), epoch, max_degree=1)
    g10, g11, h11 = 1e-9 * bt[0, 0], 1e-9 * br[0, 0] / 2, 1e-9 * br[0, 1] / 2
    g = math.sqrt(g10**2 + g11**2 + h11**2)
    # V = R_E^3 (m'.r_hat)/r^2 with m' = (g11, h11, g10): the moment points along m' (south, g10 < 0);
    # cubesat.py takes the NORTH geomagnetic pole, i.e. the direction -m'.
    return cubesat.EARTH_RADIUS**3 * g, math.acos(-g10 / g), math.atan2(-h11, -g11)


def test_degree_1_coefficients_are_the_shc_file_values_at_2020() -> None:
    # 2020.0 is a DGRF epoch of the IGRF-14 file: g10, g11, h11 = -29403.41, -1451.37, 4653.35 nT.
    m, colat, lon = igrf_dipole(EPOCH)
    g = math.sqrt(29403.41**2 + 1451.37**2 + 4653.35**2) * 1e-9
    assert m == pytest.approx(cubesat.EARTH_RADIUS**3 * g, rel=1e-12)  # round-off of the Legendre evaluation
    assert math.degrees(colat) == pytest.approx(9.41, abs=0.01)  # the 2020 geomagnetic pole: 80.59 N
    assert math.degrees(lon) == pytest.approx(-72.68, abs=0.01)  # ... at 72.68 W
    # The model's substitute dipole is this one to the digits it carries.
    assert cubesat.DIPOLE_MOMENT == pytest.approx(m, rel=0.003)
    assert (cubesat.DIPOLE_POLE[0] == pytest.approx(colat, abs=0.003)
            and cubesat.DIPOLE_POLE[1] == pytest.approx(lon, abs=1e-3))


ORBITS = {
    "seed orbit": {},
    # Exactly polar with raan 0: tau = T/4 passes the pole exactly (colatitude 0, ppigrf's B_phi
    # divides by sin(theta)); off-default phases exercise every term of the geometry.
    "polar over the pole": {"orbit_inclination": math.pi / 2, "orbit_raan": 0.0, "orbit_arg_latitude_0": 0.0,
                            "earth_rotation_angle_0": 1.1, "orbit_altitude": 700e3, "orbit_period": 5925.0},
    "inclined 51.6 deg": {"orbit_inclination": math.radians(51.6), "orbit_raan": 2.0,
                          "orbit_arg_latitude_0": -0.7, "earth_rotation_angle_0": 4.0},
}


@pytest.mark.parametrize("epoch", [EPOCH, dt.datetime(2023, 7, 19, 6)])
@pytest.mark.parametrize("orbit", ORBITS, ids=list(ORBITS))
def test_igrf_of_degree_1_is_the_cubesat_tilted_dipole(orbit: str, epoch: dt.datetime) -> None:
    """IGRF truncated at degree 1 IS a centred tilted dipole: substituted into the cubesat's own
    dipole_field_orbit it must give the same orbit-frame field everywhere on the orbit. This checks the
    frames, the Earth rotation and the pole/moment sign conventions of both modules at once."""
    params = dict(DEFAULTS, **ORBITS[orbit])
    m, colat, lon = igrf_dipole(epoch)
    params.update(dipole_moment=m, dipole_colatitude=colat, dipole_longitude=lon)
    period = params["orbit_period"]
    tau = np.linspace(0.0, 2 * period, 801)  # two orbits (the Earth turns 0.8 rad more); contains T/4
    b_igrf = igrf_orbit_field(tau, epoch, params, max_degree=1)
    b_dip = DIPOLE(tau, params)
    assert np.all(np.isfinite(b_igrf))
    err = np.max(np.linalg.norm(b_igrf - b_dip, axis=1)) / np.max(np.linalg.norm(b_dip, axis=1))
    print(f"\n{orbit}, {epoch:%Y-%m-%d}: degree-1 IGRF vs cubesat dipole, max relative error {err:.2e}")
    # Two double-precision evaluations of one closed form (Legendre recursion vs the explicit
    # dipole): round-off is ~1e-15 (2.6e-12 over the pole, where the colatitude is held 1e-10 deg
    # off it for ppigrf); any frame, rotation or sign slip would be O(1).
    assert err < 1e-9
    # The check has teeth: with the pole and the moment confused, the field flips sign.
    flipped = DIPOLE(tau, dict(params, dipole_colatitude=math.pi - colat, dipole_longitude=lon + math.pi))
    assert np.max(np.linalg.norm(b_igrf - flipped, axis=1)) / np.max(np.linalg.norm(b_dip, axis=1)) > 1.0


def test_orbit_geometry_is_orthonormal_and_turns_at_the_orbit_rate() -> None:
    tau = np.linspace(0.0, T, 91)
    r_hat, c_oi = orbit_geometry(tau)
    # Orthonormal rows and r_hat = -o3 to round-off (1e-14: a few ulps of unit-sized entries).
    assert np.max(np.abs(np.einsum("nij,nkj->nik", c_oi, c_oi) - np.eye(3))) < 1e-14
    assert np.max(np.abs(np.linalg.det(c_oi) - 1)) < 1e-14
    assert np.max(np.abs(r_hat + c_oi[:, 2])) < 1e-15
    # d r_hat / d tau = n o1 (velocity axis). Central difference at h = 1 s: error ~ n^3 h^2 / 6 ~ 2e-10.
    h = 1.0
    (rp, _), (rm, _) = orbit_geometry(tau + h), orbit_geometry(tau - h)
    assert np.max(np.abs((rp - rm) / (2 * h) - 2 * np.pi / T * c_oi[:, 0])) < 1e-9


def test_full_igrf_at_500_km_is_plausible_and_near_the_dipole_at_the_equator() -> None:
    tau = np.linspace(0.0, T, 541)  # the default orbit: 500 km, 87 deg
    b = igrf_orbit_field(tau, EPOCH)
    mag = np.linalg.norm(b, axis=1)
    print(f"\nIGRF |b| along the 87 deg, 500 km orbit at 2020-01-01: {mag.min() * 1e6:.2f} .. {mag.max() * 1e6:.2f} uT")
    # Surface field 22-67 uT, times (6371/6871)^3 = 0.80 at 500 km: ~18-54 uT.
    assert 18e-6 < mag.min() and mag.max() < 60e-6
    # Equator (ascending node, 0 deg E at tau = 0 by default) against the model's default dipole.
    # There the field is horizontal, along o1 for a near-polar orbit, and dipolar to first order:
    # the non-dipole terms change the horizontal intensity by up to ~35 % with longitude (weak over
    # the South Atlantic, strong over SE Asia; 0.85-1.35 x the dipole over 24 crossings), 7 % here.
    # The small vertical part is NOT compared: the dip equator lies ~10 deg N at 0 deg E, so IGRF
    # has b3 = -10.9 uT where the dipole gives +2.3 uT.
    b0, d0 = b[0], DIPOLE(np.array([0.0]), DEFAULTS)[0]
    assert b0[0] == pytest.approx(d0[0], rel=0.25)
    assert np.linalg.norm(b0) == pytest.approx(np.linalg.norm(d0), rel=0.25)


COEF = 1e-6 * np.array([[3.0, -1.0, 20.0, 0.5, -2.0], [-4.0, 2.0, 1.0, -0.7, 0.3], [1.0, 44.0, 4.0, -6.0, 5.0]])


@pytest.mark.parametrize("grid", ["uniform", "random"])
def test_fourier_fit_recovers_known_coefficients(grid: str) -> None:
    rng = np.random.default_rng(3)
    tau = np.linspace(0.0, T, 90, endpoint=False) if grid == "uniform" else np.sort(rng.uniform(-2 * T, 3 * T, 40))
    w = 2 * np.pi * tau / T
    basis = np.stack([np.ones_like(w), np.sin(w), np.cos(w), np.sin(2 * w), np.cos(2 * w)], -1)
    fit = fourier_fit(tau, basis @ COEF.T, T)
    # Noise-free data in a well-conditioned 5-column basis: the solve is exact to round-off (~1e-16).
    assert np.max(np.abs(fit.coefficients - COEF)) < 1e-12 * np.max(np.abs(COEF))
    assert fit.rms_residual < 1e-12 * 1e-6 and fit.max_residual < 1e-12 * 1e-6
    assert np.max(np.abs(fit.evaluate(tau) - basis @ COEF.T)) < 1e-12 * 1e-6
    pars = fit.fmu_parameters()
    assert pars["field_y[3]"] == pytest.approx(1e-6, rel=1e-12) and pars["orbit_period"] == T
    assert set(pars) <= set(DEFAULTS) and len(pars) == 16  # the cubesat's own parameter names


def test_fourier_fit_loads_into_the_cubesat_fourier_field() -> None:
    """The overrides, substituted into the model's own b_orbit outputs (field_model 0), give the fit."""
    tau = np.linspace(0.0, 2 * T, 33)
    fit = fourier_fit(tau, fourier_basis(tau, 2 * T) @ COEF.T, 2 * T)  # a non-default period too
    outputs = {o.variable.name: o.expression for o in cubesat.MODEL.outputs}
    subs = {sp.Symbol(k, real=True): v for k, v in {**DEFAULTS, **fit.fmu_parameters(), "field_model": 0,
                                                     "orbit_time_0": 700.0}.items()}
    for t in (0.0, 1234.0):
        model = [float(outputs[f"b_orbit[{i}]"].subs(subs).subs(sp.Symbol("t", real=True), t)) for i in (1, 2, 3)]
        # Same 15 numbers in the same terms, evaluated by sympy vs numpy: round-off only.
        assert model == pytest.approx(fit.evaluate(700.0 + t)[0], rel=1e-12, abs=1e-20)


@pytest.mark.parametrize("tau, b, period, match", [
    (np.arange(10.0), np.full((10, 3), np.nan), T, "finite"),
    (np.r_[np.arange(9.0), np.inf], np.zeros((10, 3)), T, "finite"),
    (np.arange(10.0), np.zeros((10, 2)), T, "shape"),
    (np.arange(10.0), np.zeros(10), T, "shape"),
    (np.zeros((5, 2)), np.zeros((10, 3)), T, "1-D"),
    (np.arange(4.0), np.zeros((4, 3)), T, "at least 5"),
    (np.arange(10.0), np.zeros((10, 3)), 0.0, "period"),
    (np.arange(10.0), np.zeros((10, 3)), -T, "period"),
    (np.arange(10.0), np.zeros((10, 3)), math.nan, "period"),
    (np.arange(10.0) * T / 2, np.zeros((10, 3)), T, "determine only"),  # every sine term is 0
])
def test_fourier_fit_rejects_bad_input(tau: np.ndarray, b: np.ndarray, period: float, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        fourier_fit(tau, b, period)


def test_fourier_fit_of_one_orbit_of_igrf_next_to_the_seed() -> None:
    tau = np.linspace(0.0, T, 540, endpoint=False)
    b = igrf_orbit_field(tau, EPOCH)
    fit = fourier_fit(tau, b, T)
    seed = seed_fourier_coefficients()
    mean = np.mean(np.linalg.norm(b, axis=1))
    print(f"\nFourier fit of one orbit of IGRF (2020-01-01, default orbit): rms residual "
          f"{fit.rms_residual * 1e6:.3f} uT,"
          f" max {fit.max_residual * 1e6:.3f} uT (mean |b| {mean * 1e6:.2f} uT)")
    print("uT      " + " ".join(f"{n:>16s}" for n in ("1", "S1", "C1", "S2", "C2")))
    for k, a in enumerate("xyz"):
        print(f"b{a} fit  " + " ".join(f"{v * 1e6:16.4f}" for v in fit.coefficients[k]))
        print(f"b{a} seed " + " ".join(f"{v * 1e6:16.4f}" for v in seed[k]))
    # Two harmonics of the orbit rate carry a near-polar orbit's dipole field; what they miss
    # (Earth-rotation sidebands, degree >= 2) is measured at ~5 uT rms: a frame error would not fit.
    assert fit.rms_residual < 0.25 * mean
    # The seed's fit is for an unknown epoch and orbit phase: compare only the |b| span, which
    # must be the same order of magnitude (the seed's by constant read as -34927 uT would give mT).
    grid = np.linspace(0.0, T, 541)
    span_fit = np.linalg.norm(fit.evaluate(grid), axis=1)
    w = 2 * np.pi * grid / T
    span_seed = np.linalg.norm(np.stack([np.ones_like(w), np.sin(w), np.cos(w), np.sin(2 * w), np.cos(2 * w)], -1)
                               @ seed.T, axis=1)
    print(f"|b| of the fit {span_fit.min() * 1e6:.1f} .. {span_fit.max() * 1e6:.1f} uT, of the seed's fit "
          f"{span_seed.min() * 1e6:.1f} .. {span_seed.max() * 1e6:.1f} uT")
    assert 0.5 < span_seed.max() / span_fit.max() < 2 and 0.25 < span_seed.min() / span_fit.min() < 4


def test_geomagnetic_rejects_bad_arguments() -> None:
    with pytest.raises(ValueError, match="outside the IGRF"):
        igrf_orbit_field(0.0, dt.datetime(2031, 1, 1))
    with pytest.raises(ValueError, match="max_degree"):
        igrf_orbit_field(0.0, EPOCH, max_degree=14)
    with pytest.raises(ValueError, match="unknown cubesat parameter"):
        igrf_orbit_field(0.0, EPOCH, {"orbit_inclinaton": 1.0})
    with pytest.raises(ValueError, match="orbit_period"):
        orbit_geometry(0.0, {"orbit_period": 0.0})
    with pytest.raises(ValueError, match="tau must be finite"):
        orbit_geometry(np.array([0.0, np.nan]))


SCENARIO = """
[[profiles]]
to = "plant.b_ext[{c}]"
kind = "igrf"
component = {c}
epoch = {epoch}
orbit_time_0 = 1234.5
orbit_inclination = 1.2
orbit_raan = 0.4
earth_rotation_angle_0 = 2.5
max_degree = 10
"""


@pytest.mark.parametrize("epoch", ['"2020-01-01"', "2020-01-01"])  # an ISO string or a TOML date
def test_igrf_profile_is_the_orbit_field_at_orbit_time(epoch: str) -> None:
    t = np.array([0.0, 1.0, 600.0, 5000.0])
    params = {"orbit_inclination": 1.2, "orbit_raan": 0.4, "earth_rotation_angle_0": 2.5}
    want = igrf_orbit_field(1234.5 + t, EPOCH, params, max_degree=10)
    for c in (1, 2, 3):
        p = tomllib.loads(SCENARIO.format(c=c, epoch=epoch))["profiles"][0]
        prof = make({k: v for k, v in p.items() if k != "to"}, step_size=1.0)  # as satfmu.sims.scenario.wiring does
        # The same function on the same orbit times: equal to round-off of tau0 + t.
        assert prof.sample(t) == pytest.approx(want[:, c - 1], rel=1e-14, abs=1e-20)


@pytest.mark.parametrize("change, field", [
    ({"component": 0}, "component"), ({"component": 4}, "component"), ({"component": True}, "component"),
    ({"component": 1.0}, "component"), ({"component": None}, "component"),
    ({"epoch": None}, "epoch"), ({"epoch": "first of May"}, "epoch"), ({"epoch": 2020}, "epoch"),
    ({"epoch": "1899-12-31"}, "epoch"), ({"epoch": "2040-01-01"}, "epoch"),
    ({"max_degree": 0}, "max_degree"), ({"max_degree": 14}, "max_degree"), ({"max_degree": 2.0}, "max_degree"),
    ({"orbit_period": 0.0}, "orbit_period"), ({"orbit_period": "90 min"}, "orbit_period"),
    ({"orbit_altitude": -1.0}, "orbit_altitude"), ({"orbit_raan": math.nan}, "orbit_raan"),
    ({"orbit_time_0": True}, "orbit_time_0"), ({"orbit_inclinaton": 1.0}, "orbit_inclinaton"),
])
def test_igrf_profile_rejects_bad_fields(change: dict, field: str) -> None:
    spec = {"kind": "igrf", "component": 1, "epoch": "2020-01-01", **change}
    spec = {k: v for k, v in spec.items() if v is not None}
    with pytest.raises(ProfileError, match=f"igrf.*{field}"):
        make(spec, "scenario.toml: profiles[0]")


def test_profile_kinds_do_not_import_pandas_until_igrf_is_used() -> None:
    code = "import sys, satfmu.fmus.profiles; print('pandas' in sys.modules or 'ppigrf' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_orbit_parameters_are_the_cubesat_ones() -> None:
    assert set(ORBIT_PARAMETERS) <= set(DEFAULTS)
    assert DEFAULTS["orbit_altitude"] == 500e3 and DEFAULTS["orbit_period"] == T


def test_long_arcs_are_evaluated_in_chunks_with_the_same_result() -> None:
    tau = np.linspace(0.0, 2 * T, 10_801)  # two orbits at 0.5 s: two ppigrf calls
    b = igrf_orbit_field(tau, EPOCH)
    pick = [0, 9_999, 10_000, 10_800]
    # Per-point arithmetic is identical whichever call a point falls in: equal to round-off.
    assert igrf_orbit_field(tau[pick], EPOCH) == pytest.approx(b[pick], rel=1e-13, abs=1e-20)
