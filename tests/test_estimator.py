"""The attitude estimator FMU (a multiplicative EKF) on the sensor FMUs: twins, consistency, bad input."""
from __future__ import annotations

import math
import tomllib
from pathlib import Path

import numpy as np
import pytest
from scipy import stats
from scipy.spatial.transform import Rotation

import satfmu
from satfmu.controllers import mekf
from satfmu.sims.scenario import SHIPPED_SCENARIOS

BIAS = (2e-4, -1e-4, 5e-5)
"""The gyro's constant bias in these runs, rad/s (about 40 deg/h on axis 1)."""


def _scenario(backend: str = "native", stop: float = 300.0, **parameters: dict) -> satfmu.Scenario:
    """A slowly tumbling MRP satellite read by a gyro and a star tracker, fused by the filter."""
    fmus = {"plant": satfmu.FmuSpec(model="mrp_satellite", parameters={"omega_0[1]": 0.01, "omega_0[2]": -0.005,
                                                                       "omega_0[3]": 0.002}),
            "gyro": satfmu.FmuSpec(model="rate_gyro", parameters={
                "seed": 7, **{f"bias_0[{i + 1}]": b for i, b in enumerate(BIAS)}, **parameters.get("gyro", {})}),
            "tracker": satfmu.FmuSpec(model="star_tracker", parameters={"seed": 3, **parameters.get("tracker", {})}),
            "ekf": satfmu.FmuSpec(model="attitude_mekf", backend=backend,
                                  parameters={"p0_bias": 1e-3, **parameters.get("ekf", {})})}
    connections = [("plant.omega", "gyro.omega"), ("plant.sigma", "tracker.sigma"), ("gyro.omega_m", "ekf.omega_m"),
                   ("tracker.q_m", "ekf.q_m"), ("tracker.valid", "ekf.tracker_valid"),
                   ("tracker.sample_time", "ekf.tracker_time")]
    record = ([f"ekf.q_est[{i}]" for i in (1, 2, 3, 4)]
              + [f"ekf.{v}[{i}]" for v in ("sigma_est", "omega_est", "bias_est", "attitude_std", "bias_std")
                 for i in (1, 2, 3)]
              + ["ekf.nis", "ekf.updates", "ekf.initialized"]
              + [f"plant.{v}[{i}]" for v in ("sigma", "omega") for i in (1, 2, 3)]
              + [f"gyro.bias[{i}]" for i in (1, 2, 3)])
    return satfmu.Scenario(name="estimation", stop_time=stop, step_size=0.05, fmus=fmus, connections=connections,
                           record=record)


def _columns(r: np.ndarray, base: str, n: int = 3) -> np.ndarray:
    return np.column_stack([r[f"{base}[{i}]"] for i in range(1, n + 1)])


def _errors(r: np.ndarray) -> np.ndarray:
    """The estimate's attitude error, rad, body axes: ``C_true = C(e) C_est``, the filter's error state
    (scipy's rotations are active, ``R = C^T``: ``R_true = R_est R(e)``)."""
    true = Rotation.from_mrp(_columns(r, "plant.sigma"))
    estimate = Rotation.from_quat(_columns(r, "ekf.q_est", 4))
    return (estimate.inv() * true).as_rotvec()


def test_native_and_python_filters_are_the_same_bits(fmu_dir: Path) -> None:
    native = satfmu.run(_scenario(), fmu_dir=fmu_dir).results
    python = satfmu.run(_scenario("python"), fmu_dir=fmu_dir).results
    for name in native.dtype.names:  # the C twin repeats the Python form operation for operation
        assert np.array_equal(native[name], python[name]), name


def test_the_filter_is_consistent_and_finds_the_bias(fmu_dir: Path) -> None:
    nees, nis = [], []
    for run in range(6):
        r = satfmu.run(_scenario(gyro={"seed": 10 + run}, tracker={"seed": 20 + run}), fmu_dir=fmu_dir).results
        settled = r["time"] > 60.0  # after the bias has converged (its std below 1e-6 rad/s by then)
        e, std = _errors(r)[settled], _columns(r, "ekf.attitude_std")[settled]
        nees.append(np.mean(np.sum((e / std) ** 2, axis=1)))
        new = np.diff(r["ekf.updates"], prepend=0.0) > 0
        nis.extend(r["ekf.nis"][new & settled])
        # the bias (constant plus the walk the gyro reports) within 4 sigma at the end, on every axis
        bias_error = _columns(r, "ekf.bias_est")[-1] - _columns(r, "gyro.bias")[-1]
        assert np.all(np.abs(bias_error) < 4 * _columns(r, "ekf.bias_std")[-1]), bias_error
        # the rate estimate is the gyro's white noise alone: sqrt(arw^2 / dt) = 1.34e-5 rad/s within 5 %
        rate_error = (_columns(r, "ekf.omega_est") - _columns(r, "plant.omega"))[settled]
        assert np.std(rate_error, axis=0) == pytest.approx(3e-6 / math.sqrt(0.05), rel=0.05)
        assert np.all(r["ekf.initialized"] == 1)  # from the tracker's first sample, at t = 0
    # normalized estimation error squared (3 degrees of freedom): mean 3 for a consistent filter. One run's
    # time average swings widely (2.4-4.1 measured): about the boresight the filter averages the noisy
    # roll over ~30 s, so 240 s hold ~8 independent values; over 6 runs, 3 +- 20 % (measured 2.94)
    assert abs(np.mean(nees) - 3) < 0.6, nees
    # the tracker's updates are independent: the mean NIS of n updates (a 3n-dof chi-square over n) lies
    # in its two-sided 99.9 % interval
    low, high = stats.chi2.ppf([0.0005, 0.9995], 3 * len(nis)) / len(nis)
    assert low < np.mean(nis) < high, (np.mean(nis), low, high)


def test_without_noise_the_estimate_is_the_truth(fmu_dir: Path) -> None:
    quiet = {"gyro": {"arw": 0.0, "rrw": 0.0, **{f"bias_0[{i}]": 0.0 for i in (1, 2, 3)}},
             "tracker": {"noise_cross": 0.0, "noise_boresight": 0.0}}
    r = satfmu.run(_scenario(stop=60.0, **quiet), fmu_dir=fmu_dir).results
    # what is left is the filter's model: it turns the body at the rate sampled at the step's start, while
    # the torque-free body's rate changes by ~1e-6 rad/s over a 0.05 s step (the gyroscopic coupling), a
    # ~2.5e-8 rad miss per step that the tracker's updates (weighted as 5 and 40 arcsec) pull back and the
    # bias partly absorbs: measured 4.9e-8 rad and 1.0e-7 rad/s
    assert np.max(np.linalg.norm(_errors(r), axis=1)) < 2e-7
    assert np.max(np.abs(_columns(r, "ekf.bias_est"))) < 5e-7


def test_an_outage_grows_the_uncertainty_then_the_filter_recovers(fmu_dir: Path) -> None:
    r = satfmu.run(_scenario(stop=200.0, tracker={"outage_start": 100.0, "outage_stop": 150.0}),
                   fmu_dir=fmu_dir).results
    t, std = r["time"], _columns(r, "ekf.attitude_std")
    before, during_end, after = (np.searchsorted(t, x) for x in (99.9, 149.9, 190.0))
    assert np.all(std[during_end] > 1.5 * std[before])  # 50 s on the gyro alone: arw sqrt(50 s) = 2e-5 rad
    assert np.all(std[after] < 1.2 * std[before])
    updates = r["ekf.updates"]
    assert updates[during_end] == updates[np.searchsorted(t, 100.0)]  # no update in the window
    e = _errors(r)
    assert np.all(np.abs(e[after:]) < 4 * std[after:])


def test_the_python_form_refuses_bad_values_by_name() -> None:
    good = [0.05] + [0.0] * 3 + [0.0, 0.0, 0.0, 1.0, 1.0, 0.0] + [0.0] * 6 + [1.0, 0.0] + [2.4e-5, 1.9e-4]
    good += [0.0, 0.0, 1.0, 1e-7, 3e-6, 3e-9, 1e-3, 1e-4, 0.0, 0.0, 0.0, 1.0]
    assert len(good) == len(mekf.ARGUMENTS)
    held = mekf.step(good + [0.0] * mekf.N_HELD)
    assert held[mekf.offset("q") + 3] == 1.0 and held[mekf.offset("initialized")] == 1.0  # from the tracker
    bad = list(good)
    bad[mekf.ARGUMENTS.index("omega_m[2]")] = math.nan
    with pytest.raises(ValueError, match=r"omega_m\[2\] is not finite"):
        mekf.step(bad + held)
    with pytest.raises(ValueError, match="expected"):
        mekf.step(good)
    singular = list(good)  # a tracker that claims no noise and a filter that claims no uncertainty
    for name in ("noise_cross", "noise_boresight", "p0_attitude", "p0_bias", "arw", "rrw"):
        singular[mekf.ARGUMENTS.index(name)] = 0.0
    started = mekf.step(singular + [0.0] * mekf.N_HELD)
    later = list(singular)
    later[mekf.ARGUMENTS.index("tracker_time")] = 0.2
    with pytest.raises(ValueError, match="not positive definite"):
        mekf.step(later + started)


def test_with_every_noise_at_zero_the_sensed_loop_flies_as_the_true_state_loop(fmu_dir: Path) -> None:
    data = tomllib.loads((SHIPPED_SCENARIOS / "rw4_slew_sensed_published.toml").read_text())
    data["fmus"]["gyro"]["parameters"].update({"arw": 0.0, "rrw": 0.0, "bias_0[1]": 0.0, "bias_0[2]": 0.0,
                                                 "bias_0[3]": 0.0})
    data["fmus"]["tracker"]["parameters"].update({"noise_cross": 0.0, "noise_boresight": 0.0})
    sensed = satfmu.run(satfmu.Scenario.from_dict(data), fmu_dir=fmu_dir)
    ideal = satfmu.run("rw4_slew_published", fmu_dir=fmu_dir)
    # what is left is the filter's model of the motion between samples: it turns the body at the mean of
    # two sampled rates, which misses the torque's change within a 50 ms step: measured 1.3e-5 deg of
    # knowledge error and 1.6e-5 deg of attitude difference at most during the 90 deg slew, 7e-7 deg at
    # the end (bounds 5 times those)
    value = {m.name: m.value for m in sensed.metrics}
    assert value["knowledge error"] < 7e-5
    phi = np.degrees(np.abs(sensed.results["plant.phi"] - ideal.results["plant.phi"]))
    assert phi.max() < 8e-5 and phi[-1] < 4e-6


def test_the_knowledge_error_diagnostic_measures_the_estimate_against_the_truth(fmu_dir: Path) -> None:
    r = satfmu.run("rw4_slew_sensed_published", fmu_dir=fmu_dir).results
    error = _columns(r, "knowledge.error")
    true = Rotation.from_mrp(_columns(r, "plant.sigma"))
    estimate = Rotation.from_mrp(_columns(r, "ekf.sigma_est"))
    # C_true = C(error) C_est, the filter's error state: the same rotation as scipy's (to rounding)
    assert np.max(np.abs(error - (estimate.inv() * true).as_rotvec())) < 1e-15
    assert np.allclose(r["knowledge.angle"], np.linalg.norm(error, axis=1), rtol=1e-12, atol=1e-18)
    std = _columns(r, "ekf.attitude_std")
    assert np.allclose(_columns(r, "knowledge.normalized"), error / std, rtol=1e-12)


def _magnetometer_scenario(backend: str, stop: float) -> satfmu.Scenario:
    """The filter without a tracker: a gyro and a 20 Hz magnetometer in the orbit model's field, started
    4.4 deg off the truth (``q_init``) with a 0.1 rad sigma (the cubesat's case)."""
    sigma_0 = np.array([0.1, -0.2, 0.05])
    q_init = (Rotation.from_mrp(sigma_0) * Rotation.from_rotvec(np.radians([3.0, -2.0, 2.5]))).as_quat()
    fmus = {"plant": satfmu.FmuSpec(model="mrp_satellite", parameters={
                "omega_0[1]": 0.002, "omega_0[2]": -0.001, "omega_0[3]": 0.0015,
                **{f"sigma_0[{i + 1}]": v for i, v in enumerate(sigma_0)}}),
            "orbit": satfmu.FmuSpec(model="orbit_environment"),
            "gyro": satfmu.FmuSpec(model="rate_gyro", parameters={"seed": 7, "bias_0[1]": 2e-5}),
            "mag": satfmu.FmuSpec(model="magnetometer", parameters={"seed": 5, "sample_period": 0.05, "noise": 1e-7}),
            "ekf": satfmu.FmuSpec(model="attitude_mekf", backend=backend, parameters={
                "use_tracker": False, "use_magnetometer": True, "noise_magnetometer": 1e-7, "p0_attitude": 0.1,
                "p0_bias": 1e-4, **{f"q_init[{i + 1}]": v for i, v in enumerate(q_init)}})}
    connections = [("plant.omega", "gyro.omega"), ("plant.sigma", "mag.sigma"), ("orbit.b", "mag.b"),
                   ("gyro.omega_m", "ekf.omega_m"), ("mag.b_m", "ekf.b_m"), ("orbit.b", "ekf.b_ref")]
    record = ([f"ekf.q_est[{i}]" for i in (1, 2, 3, 4)] + [f"ekf.attitude_std[{i}]" for i in (1, 2, 3)]
              + [f"plant.sigma[{i}]" for i in (1, 2, 3)] + ["ekf.nis", "ekf.updates"])
    return satfmu.Scenario(name="magnetometer_only", stop_time=stop, step_size=0.05, fmus=fmus,
                           connections=connections, record=record)


def test_the_magnetometer_alone_brings_the_estimate_in(fmu_dir: Path) -> None:
    r = satfmu.run(_magnetometer_scenario("native", 1800.0), fmu_dir=fmu_dir).results
    e = np.degrees(np.linalg.norm(_errors(r), axis=1))
    std = _columns(r, "ekf.attitude_std")
    # the field turns along the orbit, so the whole attitude becomes observable: from 4.4 deg at the start
    # to 0.0064 deg after 30 min (measured), within 4 of its sigmas on every axis
    assert e[0] > 4.0 and e[-1] < 0.02
    assert np.all(np.abs(_errors(r)[-1]) < 4 * std[-1])
    assert r["ekf.updates"][-1] == len(r) - 1  # one magnetometer update per instant after the first
    # the same bits in the pythonfmu form, magnetometer updates and all (300 s)
    native = satfmu.run(_magnetometer_scenario("native", 300.0), fmu_dir=fmu_dir).results
    python = satfmu.run(_magnetometer_scenario("python", 300.0), fmu_dir=fmu_dir).results
    for name in native.dtype.names:
        assert np.array_equal(native[name], python[name]), name
