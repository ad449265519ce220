"""The sensor FMUs (star tracker, rate gyro, magnetometer) and their counter-based noise."""
from __future__ import annotations

import math
from pathlib import Path

import allantools
import numpy as np
import pytest
from scipy import stats
from scipy.spatial.transform import Rotation

import satfmu
from satfmu.fmus.sensors.common import ARCSEC
from satfmu.fmus import noise
from satfmu.fmus.sensors import star_tracker



def test_noise_draws_are_standard_and_independent() -> None:
    n = 200_000
    g = np.array([noise.gaussian_noise(11, k, 0) for k in range(n)])
    # mean within 5 standard errors (1/sqrt(n) = 2.2e-3), variance within 5 of its 3.2e-3; the draws are
    # deterministic, so this holds or fails for good
    assert abs(g.mean()) < 5 / math.sqrt(n) and abs(g.var() - 1) < 5 * math.sqrt(2 / n)
    assert stats.kstest(g, "norm").pvalue > 1e-3
    u = np.array([noise.uniform_noise(11, k, 1) for k in range(n)])
    assert 0 < u.min() and u.max() < 1 and stats.kstest(u, "uniform").pvalue > 1e-3
    # neighbours in counter, stream and seed are uncorrelated (|r| < 5 / sqrt(n))
    others = {"next counter": g[1:], "stream 2": np.array([noise.gaussian_noise(11, k, 2) for k in range(n)]),
              "seed 12": np.array([noise.gaussian_noise(12, k, 0) for k in range(n)])}
    for what, h in others.items():
        m = min(len(h), n - 1)
        assert abs(np.corrcoef(g[:m], h[:m])[0, 1]) < 5 / math.sqrt(m), what
    # a pure function: the same arguments, the same bits; floats holding integers read as those integers
    assert noise.gaussian_noise(3, 17, 5) == noise.gaussian_noise(3.0, 17.0, 5.0)
    assert noise.gaussian_noise(-1, 0, 0) != noise.gaussian_noise(1, 0, 0)  # negatives are their own seeds


def _scenario(step: float, backend: str = "native", stop: float = 20.0, **parameters: dict) -> satfmu.Scenario:
    """A tumbling MRP satellite on the orbit model, read by the three sensors."""
    fmus = {"plant": satfmu.FmuSpec(model="mrp_satellite", parameters={"omega_0[1]": 0.01, "omega_0[2]": -0.02,
                                                                       "omega_0[3]": 0.005, "sigma_0[1]": 0.3}),
            "orbit": satfmu.FmuSpec(model="orbit_environment"),
            "gyro": satfmu.FmuSpec(model="rate_gyro", backend=backend,
                                   parameters={"seed": 7, "sample_period": 0.1, **parameters.get("gyro", {})}),
            "tracker": satfmu.FmuSpec(model="star_tracker", backend=backend,
                                      parameters={"seed": 3, **parameters.get("tracker", {})}),
            "mag": satfmu.FmuSpec(model="magnetometer", backend=backend,
                                  parameters={"seed": 5, **parameters.get("mag", {})})}
    connections = [("plant.omega", "gyro.omega"), ("plant.sigma", "tracker.sigma"), ("plant.sigma", "mag.sigma"),
                   ("orbit.b", "mag.b")]
    record = ([f"gyro.omega_m[{i}]" for i in (1, 2, 3)] + [f"tracker.q_m[{i}]" for i in (1, 2, 3, 4)]
              + [f"tracker.sigma_m[{i}]" for i in (1, 2, 3)] + ["tracker.valid", "tracker.sample_time"]
              + [f"mag.b_m[{i}]" for i in (1, 2, 3)] + [f"orbit.b[{i}]" for i in (1, 2, 3)]
              + [f"plant.sigma[{i}]" for i in (1, 2, 3)] + [f"plant.omega[{i}]" for i in (1, 2, 3)])
    return satfmu.Scenario(name="sensors", stop_time=stop, step_size=step, fmus=fmus, connections=connections,
                           record=record)


def _run(scenario: satfmu.Scenario, fmu_dir: Path) -> np.ndarray:
    return satfmu.run(scenario, fmu_dir=fmu_dir).results


def test_native_and_python_fmus_draw_the_same_bits_whatever_the_step(fmu_dir: Path) -> None:
    tracker = {"latency": 2, "dropout_probability": 0.2}
    native = _run(_scenario(0.1, tracker=tracker), fmu_dir)
    python = _run(_scenario(0.1, "python", tracker=tracker), fmu_dir)
    for name in native.dtype.names:
        assert np.array_equal(native[name], python[name]), name  # same integer hash, same libm calls
    coarse = _run(_scenario(0.2, tracker=tracker), fmu_dir)
    fine = _run(_scenario(0.05, tracker=tracker), fmu_dir)
    # the noise of an instant depends on (seed, instant) only: the gyro (10 Hz) and the tracker (5 Hz)
    # read the same numbers at 0.05, 0.1 and 0.2 s steps, bit for bit (their inputs are the plant's
    # state at the instants, which the steps reach alike)
    for name in ("gyro.omega_m[1]", "tracker.q_m[2]", "tracker.valid", "tracker.sample_time"):
        assert np.array_equal(native[name][::2], coarse[name]), name
        assert np.array_equal(fine[name][::4], coarse[name]), name


def _error_angles(q_m: np.ndarray, sigma: np.ndarray) -> np.ndarray:
    """Small rotation vectors (rad, body axes) taking the true attitude to the measured one."""
    # scipy's rotations are active, R = C^T of the passive matrices (v_B = C v_N) the models use:
    # C_m = C(delta) C_true  <=>  R_m = R_true R(delta)  <=>  R(delta) = R_true^T R_m
    return (Rotation.from_mrp(sigma).inv() * Rotation.from_quat(q_m)).as_rotvec()


def test_star_tracker_noise_misalignment_and_latency(fmu_dir: Path) -> None:
    period = 0.2
    tracker = {"noise_cross": 6.0, "noise_boresight": 45.0, "boresight[1]": 1.0, "boresight[3]": 0.0,
               "misalignment[2]": 1e-3}
    r = _run(_scenario(period, stop=2000.0, tracker=tracker), fmu_dir)
    q = np.column_stack([r[f"tracker.q_m[{i}]"] for i in (1, 2, 3, 4)])
    sigma = np.column_stack([r[f"plant.sigma[{i}]"] for i in (1, 2, 3)])
    assert np.all(r["tracker.valid"] == 1) and np.all(q[:, 3] >= 0)
    assert np.allclose(np.linalg.norm(q, axis=1), 1, atol=1e-15)
    delta = _error_angles(q, sigma) / ARCSEC
    n = len(delta)
    # the boresight is body x: cross-axis noise on y and z (6 arcsec), roll on x (45 arcsec), and the fixed
    # misalignment of 1e-3 rad about y as the mean; standard deviations within 5 % (10,001 samples: the
    # estimate's own spread is 0.7 %), means within 5 standard errors
    assert np.std(delta, axis=0) == pytest.approx([45.0, 6.0, 6.0], rel=0.05)
    mean = np.mean(delta, axis=0)
    assert mean == pytest.approx([0.0, 1e-3 / ARCSEC, 0.0], abs=5 * 45 / math.sqrt(n))
    sigma_m = np.column_stack([r[f"tracker.sigma_m[{i}]"] for i in (1, 2, 3)])
    assert np.allclose(Rotation.from_mrp(sigma_m).as_quat(canonical=True), q, atol=1e-14)

    late = _run(_scenario(period, stop=20.0, tracker={**tracker, "latency": 3}), fmu_dir)
    now = _run(_scenario(period, stop=20.0, tracker=tracker), fmu_dir)
    # latency 3: the measurement of t - 0.6 s, bit for bit, flagged invalid (the identity) before the first
    assert np.all(late["tracker.valid"][:3] == 0) and np.all(late["tracker.q_m[4]"][:3] == 1)
    assert np.array_equal(late["tracker.q_m[1]"][3:], now["tracker.q_m[1]"][:-3])
    assert np.allclose(late["time"][3:] - late["tracker.sample_time"][3:], 0.6, atol=1e-12)


def test_star_tracker_outages_hold_the_last_valid_measurement(fmu_dir: Path) -> None:
    tracker = {"outage_start": 5.0, "outage_stop": 8.0, "dropout_probability": 0.25}
    r = _run(_scenario(0.2, stop=400.0, tracker=tracker), fmu_dir)
    t, valid = r["time"], r["tracker.valid"]
    window = (t >= 5.0 - 1e-9) & (t < 8.0 - 1e-9)
    assert np.all(valid[window] == 0)
    outside = valid[~window]
    # dropouts: 25 % of ~1985 instants, within 4 binomial standard deviations (1 %)
    assert abs(1 - outside.mean() - 0.25) < 4 * math.sqrt(0.25 * 0.75 / len(outside))
    lost = np.flatnonzero(valid == 0)
    lost = lost[lost > 0]
    # an invalid output holds the previous output, its attitude and its instant
    assert np.array_equal(r["tracker.q_m[1]"][lost], r["tracker.q_m[1]"][lost - 1])
    assert np.array_equal(r["tracker.sample_time"][lost], r["tracker.sample_time"][lost - 1])


def test_gyro_allan_deviation_gives_back_its_random_walks(fmu_dir: Path) -> None:
    # a record of 1e5 s at 20 Hz (2e6 samples, ~1 s in the compiled loop), the two walks crossing at
    # sqrt(3) N / K = 17 s
    arw, rrw = 1e-4, 1e-5
    fmus = {"gyro": satfmu.FmuSpec(model="rate_gyro", parameters={"seed": 1, "arw": arw, "rrw": rrw,
                                                                   "sample_period": 0.05})}
    scenario = satfmu.Scenario(name="allan", stop_time=100_000.0, step_size=0.05, fmus=fmus,
                               record=[f"gyro.omega_m[{i}]" for i in (1, 2, 3)], unconnected="zero")  # at rest
    r = _run(scenario, fmu_dir)
    for axis in (1, 2, 3):
        taus, adev, _, _ = allantools.oadev(r[f"gyro.omega_m[{axis}]"], rate=20.0, data_type="freq",
                                            taus=np.array([0.1, 0.5, 100.0, 300.0]))[:4]
        expected = np.sqrt(arw**2 / taus + rrw**2 * taus / 3)  # N / sqrt(tau) and K sqrt(tau / 3)
        # short times (1e6 clusters and more): within 1 % (measured 0.1 %); long times, where the rate walk
        # rules (1000 and 333 clusters, the estimator's own spread ~5-10 % for a random walk): within 10 %
        # (measured 0.96-1.05 on the three axes of two seeds)
        assert adev[:2] == pytest.approx(expected[:2], rel=0.01)
        assert adev[2:] == pytest.approx(expected[2:], rel=0.10)


def test_magnetometer_reads_the_field_in_the_body_with_its_errors(fmu_dir: Path) -> None:
    mag = {"noise": 2e-7, "bias_0[3]": 5e-7, "scale_factor[1]": 0.01, "misalignment[2,3]": 2e-3}
    r = _run(_scenario(0.1, stop=600.0, mag=mag), fmu_dir)
    b_n = np.column_stack([r[f"orbit.b[{i}]"] for i in (1, 2, 3)])
    sigma = np.column_stack([r[f"plant.sigma[{i}]"] for i in (1, 2, 3)])
    b_body = Rotation.from_mrp(sigma).inv().apply(b_n)  # C(sigma) b_N
    a = np.eye(3) + np.diag([0.01, 0, 0])
    a[1, 2] = 2e-3
    err = np.column_stack([r[f"mag.b_m[{i}]"] for i in (1, 2, 3)]) - b_body @ a.T
    n = len(err)
    assert np.std(err, axis=0) == pytest.approx(2e-7, rel=0.05)  # 6,001 samples: 0.9 % spread
    assert np.mean(err, axis=0) == pytest.approx([0.0, 0.0, 5e-7], abs=5 * 2e-7 / math.sqrt(n))


def test_zero_noise_sensors_read_the_truth(fmu_dir: Path) -> None:
    quiet = {"gyro": {"arw": 0.0, "rrw": 0.0}, "tracker": {"noise_cross": 0.0, "noise_boresight": 0.0},
             "mag": {"noise": 0.0}}
    r = _run(_scenario(0.1, **quiet), fmu_dir)
    w = np.column_stack([r[f"plant.omega[{i}]"] for i in (1, 2, 3)])
    wm = np.column_stack([r[f"gyro.omega_m[{i}]"] for i in (1, 2, 3)])
    assert np.array_equal(wm, w)  # the gyro samples at every step here: exactly the plant's rate
    sigma = np.column_stack([r[f"plant.sigma[{i}]"] for i in (1, 2, 3)])
    held = np.floor(r["time"] / 0.2 + 1e-6) * 2  # the tracker's 5 Hz instants, in rows of 0.1 s
    sm = np.column_stack([r[f"tracker.sigma_m[{i}]"] for i in (1, 2, 3)])
    assert np.allclose(sm, sigma[held.astype(int)], atol=1e-15, rtol=0)  # MRP -> quaternion -> MRP round trip


@pytest.mark.parametrize(("model", "parameter", "value"), [
    ("rate_gyro", "seed", -1), ("rate_gyro", "sample_period", 0.0), ("rate_gyro", "rrw", -1e-9),
    ("star_tracker", "latency", star_tracker.MAX_LATENCY + 1), ("star_tracker", "dropout_probability", 1.5),
    ("magnetometer", "noise", -1e-7)])
def test_bad_parameters_are_refused_by_name(fmu_dir: Path, model: str, parameter: str, value: float) -> None:
    scenario = satfmu.Scenario(name="bad", stop_time=1.0, step_size=0.1,
                               fmus={"s": satfmu.FmuSpec(model=model, parameters={parameter: value})})
    with pytest.raises(Exception, match=parameter):
        satfmu.run(scenario, fmu_dir=fmu_dir)


def test_sampled_outputs_declare_the_inputs_they_are_sampled_from() -> None:
    # the held measurement is computed from the inputs through named definitions: the dependency
    # analysis follows them, so importers (libcosim) treat the outputs as feedthrough at the instants
    from satfmu.fmus.sensors import magnetometer, rate_gyro

    assert star_tracker.MODEL.output_dependencies()["q_m[1]"] == ["sigma[1]", "sigma[2]", "sigma[3]"]
    assert magnetometer.MODEL.output_dependencies()["b_m[2]"] == ["b[1]", "b[2]", "b[3]", "sigma[1]", "sigma[2]",
                                                                  "sigma[3]"]
    assert rate_gyro.MODEL.output_dependencies()["omega_m[3]"] == ["omega[1]", "omega[2]", "omega[3]"]
