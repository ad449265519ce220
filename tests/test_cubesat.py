"""The magnetorquer cubesat plant (seed 003): kinematics, field models, invariants, both FMU backends."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from fmpy import simulate_fmu

from satfmu.fmus.plants import cubesat
from satfmu.fmus.codegen import load_python

MODEL = cubesat.MODEL
INERTIA = np.array(cubesat.INERTIA_SEED_003)
ORBIT = 5400.0


@pytest.fixture(scope="module")
def plant_fmus(fmu_dir: Path) -> dict[str, Path]:
    return {"native": fmu_dir / "magnetorquer_cubesat.fmu", "python": fmu_dir / "magnetorquer_cubesat_py.fmu"}


def _stack(r: np.ndarray, base: str, n: int) -> np.ndarray:
    return np.stack([r[f"{base}[{i}]"] for i in range(1, n + 1)], axis=1)


def test_rotation_matrix_is_orthogonal_and_follows_the_seeds_kinematics() -> None:
    # With the seed's W: C' = -[w x] C for C(q) orbit->body and q' = W(w) q / 2.
    q = sp.Matrix(sp.symbols("q1:5", real=True))
    w = sp.Matrix(sp.symbols("w1:4", real=True))
    C = cubesat.quaternion_rotation(q)
    qdot = cubesat.kinematics_matrix(w) * q / 2
    Cdot = sp.Matrix(3, 3, lambda i, j: sum(sp.diff(C[i, j], qk) * dk for qk, dk in zip(q, qdot)))
    f = sp.lambdify((q, w), (C, Cdot + cubesat._skew(w) * C), "numpy")
    rng = np.random.default_rng(1)
    for _ in range(20):
        qv = rng.normal(size=4)
        qv /= np.linalg.norm(qv)
        Cv, res = f(qv, rng.normal(size=3))
        assert np.abs(Cv @ Cv.T - np.eye(3)).max() < 1e-14  # rounding of a unit quaternion
        assert np.abs(res).max() < 1e-14


def test_untilted_dipole_is_the_closed_form_orbit_frame_field() -> None:
    # Non-tilted dipole, circular orbit (Wertz): b = (M/a^3) [cos u sin i, -cos i, 2 sin u sin i].
    tau = sp.Symbol("tau")
    p = {v.name: v.start for v in MODEL.parameters}
    p.update(dipole_colatitude=0.0, orbit_inclination=1.1, orbit_arg_latitude_0=0.3)
    f = sp.lambdify(tau, cubesat.dipole_field_orbit(tau, p), "numpy")
    b0 = p["dipole_moment"] / (cubesat.EARTH_RADIUS + p["orbit_altitude"]) ** 3
    for t in np.linspace(0, ORBIT, 13):
        u = 0.3 + 2 * math.pi * t / ORBIT
        expected = b0 * np.array([math.cos(u) * math.sin(1.1), -math.cos(1.1), 2 * math.sin(u) * math.sin(1.1)])
        assert np.abs(np.ravel(f(t)) - expected).max() < 1e-18  # T: 5e-14 relative, rounding of rotations


def test_fourier_field_at_t0_is_the_seeds_constant_plus_cosines() -> None:
    gen = load_python(MODEL)
    p = MODEL.parameter_vector()
    y = dict(zip([o.variable.name for o in MODEL.outputs], gen.outputs(0.0, list(MODEL.initial_state(p)),
                                                                        [0.0] * 9, list(p))))
    for i, a in enumerate("xyz"):
        c = cubesat.FIELD_FOURIER_SEED[a]
        assert y[f"b_orbit[{i + 1}]"] == pytest.approx((c[0] + c[2] + c[4]) * 1e-6, rel=1e-14)
        assert y[f"b_body[{i + 1}]"] == pytest.approx(y[f"b_orbit[{i + 1}]"], rel=1e-14)  # q = identity


def test_external_field_and_dipole_saturation() -> None:
    gen = load_python(MODEL)
    p = MODEL.parameter_vector({"field_model": 2, "saturation_on": 1, "m_max": 0.1})
    u = [0.5, -0.05, -0.3, 0, 0, 0, 1e-5, 2e-5, 3e-5]
    y = dict(zip([o.variable.name for o in MODEL.outputs], gen.outputs(0.0, list(MODEL.initial_state(p)), u,
                                                                        list(p))))
    assert [y[f"b_orbit[{i}]"] for i in (1, 2, 3)] == [1e-5, 2e-5, 3e-5]
    assert [y[f"m_applied[{i}]"] for i in (1, 2, 3)] == [0.1, -0.05, -0.1]


def test_ten_orbits_keep_the_quaternion_unit_and_the_torque_free_invariants(plant_fmus: dict[str, Path]) -> None:
    # Tumbling at |w| = 0.07 rad/s with no dipole, 10 orbits, RK4 at h_max = 0.5 s.
    r = simulate_fmu(str(plant_fmus["native"]), stop_time=10 * ORBIT, output_interval=10.0)
    q, w = _stack(r, "q", 4), _stack(r, "omega", 3)
    assert np.abs(np.linalg.norm(q, axis=1) - 1).max() < 1e-9  # the bound; measured 2e-16
    # Largest correction a renormalization made: RK4's per-substep norm error, ~ (h |w|/2)^6 / 144 = 2e-13
    assert r["q_norm_drift"][-1] < 2e-12
    energy, momentum = 0.5 * (INERTIA * w**2).sum(axis=1), np.linalg.norm(INERTIA * w, axis=1)
    assert np.abs(energy / energy[0] - 1).max() < 1e-9  # measured 7e-10: RK4 truncation over 108000 substeps
    assert np.abs(momentum / momentum[0] - 1).max() < 1e-9
    assert np.ptp(r["attitude_angle"]) > 2.0  # it really tumbles


def test_without_renormalization_the_drift_is_rk4s_predicted_accumulation(plant_fmus: dict[str, Path]) -> None:
    # Each RK4 substep scales |q| by |R(i nu)| = 1 - nu^6/144 + ..., nu = h |w_bo| / 2: over 10 orbits
    # the accumulated drift is n_substeps * nu^6 / 144 (|w_bo| ~ |w| here).
    r = simulate_fmu(str(plant_fmus["native"]), stop_time=10 * ORBIT, output_interval=10.0,
                     start_values={"renormalize": False})
    nu = 0.5 * np.mean(r["rate_norm"]) / 2
    predicted = 10 * ORBIT / 0.5 * nu**6 / 144
    drift = abs(np.linalg.norm(_stack(r, "q", 4)[-1]) - 1)
    assert drift == pytest.approx(predicted, rel=0.2)  # 20 %: |w_bo| differs from |w| by the orbit rate
    assert r["q_norm_drift"][-1] == pytest.approx(drift, rel=1e-6)


def test_native_and_python_backends_agree_under_a_dipole(plant_fmus: dict[str, Path]) -> None:
    inputs = np.array([(0.0, 0.02, -0.01, 0.015)], dtype=[("time", float), ("m[1]", float), ("m[2]", float),
                                                          ("m[3]", float)])
    start = {"field_model": 1, "saturation_on": True, "m_max": 0.018}
    runs = [simulate_fmu(str(plant_fmus[b]), stop_time=600.0, output_interval=10.0, input=inputs,
                         start_values=start) for b in ("native", "python")]
    for name in ("omega[1]", "omega[2]", "omega[3]", "q[1]", "q[4]", "b_body[2]"):
        a, b = runs[0][name], runs[1][name]
        assert np.abs(a - b).max() <= 1e-12 * max(1.0, np.abs(a).max()), name  # same RK4, C vs Python math
    assert runs[0]["m_applied[1]"][-1] == 0.018
