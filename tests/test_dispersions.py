"""Dispersions: the distributions' statistics, attitude and inertia draws, determinism,
validation with key paths, and a dispersed scenario run (sims/scenario/dispersions.py)."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy import stats
from scipy.spatial.transform import Rotation

from satfmu.fmus.plants.spacecraft import SEED_000, Spacecraft
from satfmu.fmus.errors import ScenarioError
from satfmu.sims.scenario.run import check, run
from satfmu.sims.scenario.spec import Scenario
from satfmu.sims.scenario.dispersions import DispersionError, Dispersions
from tests.conftest import SIGMA_200

Z = 5.0
"""Statistical tolerances are 5 standard errors: a correct sampler fails one with p < 1e-6."""


def draws(table: dict, n: int, nominal=None, seed: int = 2026) -> list[dict]:
    d = Dispersions.from_dict(table)
    return [d.sample(seed, i, nominal) for i in range(n)]


def values(table: dict, n: int, nominal=None) -> np.ndarray:
    (key,) = table
    inst, name = key.split(".", 1)
    return np.array([s[inst][name] for s in draws(table, n, nominal)])


def lookup(params: dict[str, dict[str, float]]):
    """A nominal-value function over plain data (None for a parameter the 'plant' lacks)."""
    return lambda inst, name: params.get(inst, {}).get(name)


def test_normal_mean_and_std_with_the_nominal_value_as_default_mean() -> None:
    n, std = 20_000, 0.5
    x = values({"plant.I_x": {"kind": "normal", "std": std}}, n, lookup({"plant": {"I_x": 15.0}}))
    assert abs(x.mean() - 15.0) < Z * std / math.sqrt(n)
    # SE of the sample std of a normal: std / sqrt(2 (n - 1))
    assert abs(x.std(ddof=1) - std) < Z * std / math.sqrt(2 * (n - 1))


def test_truncated_normal_moments_and_bounds() -> None:
    # 3,000 samples, not 20,000: scipy's truncnorm costs ~0.2 ms per single draw
    n, mean, std, low, high = 3_000, 1.0, 2.0, 0.0, 3.0
    x = values({"plant.u_max": {"kind": "truncated_normal", "mean": mean, "std": std, "low": low,
                                "high": high}}, n)
    ref = stats.truncnorm((low - mean) / std, (high - mean) / std, loc=mean, scale=std)
    assert x.min() >= low and x.max() <= high  # exact: the support
    assert abs(x.mean() - ref.mean()) < Z * ref.std() / math.sqrt(n)
    # SE of the sample variance: sqrt((mu4 - sigma^4) / n), mu4 from the distribution
    mu4 = ref.expect(lambda v: (v - ref.mean()) ** 4)
    assert abs(x.var(ddof=1) - ref.var()) < Z * math.sqrt((mu4 - ref.var() ** 2) / n)


def test_uniform() -> None:
    n = 20_000
    x = values({"plant.omega_0[1]": {"kind": "uniform", "low": -0.01, "high": 0.03}}, n)
    assert x.min() >= -0.01 and x.max() <= 0.03
    assert abs(x.mean() - 0.01) < Z * (0.04 / math.sqrt(12)) / math.sqrt(n)  # std of U(a, b): (b - a)/sqrt(12)


def test_square_transform_sets_the_square_of_the_uniform_root() -> None:
    """J = S^2 with S uniform on [4, 6] (seed 004's sqrtJ parameters): the roots are uniform and
    the values their squares (exactly: the same draw)."""
    n = 20_000
    x = values({"plant.I_x": {"kind": "uniform", "low": 4.0, "high": 6.0, "transform": "square"}}, n)
    plain = values({"plant.I_x": {"kind": "uniform", "low": 4.0, "high": 6.0}}, n)
    assert np.array_equal(x, plain * plain)  # same generator, same draw, squared
    assert x.min() >= 16.0 and x.max() <= 36.0
    assert abs(np.sqrt(x).mean() - 5.0) < Z * (2.0 / math.sqrt(12)) / math.sqrt(n)


def test_log_uniform() -> None:
    n = 20_000
    y = values({"plant.k": {"kind": "log_uniform", "low": 0.1, "high": 10.0}}, n)
    assert y.min() >= 0.1 and y.max() <= 10.0
    ly = np.log(y)  # uniform on [ln 0.1, ln 10]
    assert abs(ly.mean()) < Z * (math.log(100) / math.sqrt(12)) / math.sqrt(n)


def test_choice_frequencies_follow_the_weights() -> None:
    n = 20_000
    x = values({"plant.mode": {"kind": "choice", "values": [1, 2, 3], "weights": [1.0, 2.0, 1.0]}}, n)
    assert set(x.tolist()) == {1, 2, 3}
    for v, p in ((1, 0.25), (2, 0.5), (3, 0.25)):
        assert abs(np.mean(x == v) - p) < Z * math.sqrt(p * (1 - p) / n)  # binomial SE


def test_profile_seed_and_field() -> None:
    s = draws({"profiles[1].seed": {"kind": "seed"}, "profiles[0].after": {"kind": "uniform", "low": 1, "high": 2}},
              200)
    seeds = [x["profiles[1]"]["seed"] for x in s]
    assert all(isinstance(v, int) and 0 <= v < 2**31 for v in seeds)
    assert len(set(seeds)) == 200  # 200 of 2^31 values: a collision has probability ~1e-5
    assert all(1 <= x["profiles[0]"]["after"] <= 2 for x in s)


def test_uniform_rotation_mean_matrix_is_zero_and_mrp_is_the_shadow_set() -> None:
    n = 5_000
    s = draws({"attitude": {"instance": "plant", "kind": "uniform", "mrp": "sigma_0"}}, n)
    sig = np.array([[x["plant"][f"sigma_0[{i}]"] for i in (1, 2, 3)] for x in s])
    assert np.all(np.linalg.norm(sig, axis=1) <= 1 + 1e-12)  # shadow set; 1e-12: rounding
    mats = Rotation.from_mrp(sig).as_matrix()
    # every entry of a Haar rotation matrix has mean 0 and variance 1/3
    assert np.max(np.abs(mats.mean(axis=0))) < Z * math.sqrt(1 / 3 / n)


def test_cone_stays_within_the_half_angle_of_the_nominal_attitude() -> None:
    nominal = lookup({"plant": SIGMA_200})
    s = draws({"attitude": {"instance": "plant", "kind": "cone", "half_angle_deg": 10.0}}, 2_000, nominal)
    r0 = Rotation.from_mrp([SIGMA_200[f"sigma_0[{i}]"] for i in (1, 2, 3)])
    sig = np.array([[x["plant"][f"sigma_0[{i}]"] for i in (1, 2, 3)] for x in s])
    angle = np.degrees((Rotation.from_mrp(sig) * r0.inv()).magnitude())
    assert angle.max() <= 10.0 + 1e-9  # exact up to rounding of the MRP conversions
    assert angle.max() > 9.5  # cos(theta) uniform: P(theta < 9.5 deg for all 2000) ~ (0.90)^2000
    # cos(theta) is uniform on [cos 10 deg, 1]
    c = np.cos(np.radians(angle))
    lo = math.cos(math.radians(10.0))
    assert abs(c.mean() - (1 + lo) / 2) < Z * ((1 - lo) / math.sqrt(12)) / math.sqrt(len(c))


def test_cone_on_a_quaternion_plant_is_detected_from_its_parameters() -> None:
    q0 = {"q_0[1]": 0.0, "q_0[2]": 0.0, "q_0[3]": math.sin(0.5), "q_0[4]": math.cos(0.5)}
    s = draws({"attitude": {"instance": "plant", "kind": "cone", "half_angle_deg": 30.0}}, 500,
              lookup({"plant": q0}))
    q = np.array([[x["plant"][f"q_0[{i}]"] for i in (1, 2, 3, 4)] for x in s])
    assert np.allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-12)  # unit quaternions up to rounding
    angle = np.degrees((Rotation.from_quat(q) * Rotation.from_quat(list(q0.values())).inv()).magnitude())
    assert angle.max() <= 30.0 + 1e-9


def test_inertia_samples_are_rigid_bodies_within_the_relative_range() -> None:
    nominal = lookup({"plant": SEED_000.parameters()})
    s = draws({"inertia": {"instance": "plant", "relative": 0.2, "axis_rotation_deg": 5.0}}, 1_000, nominal)
    m0 = SEED_000.principal_moments
    for x in s:
        sc = Spacecraft("sample", [[x["plant"]["I_x"], x["plant"]["I_xy"], x["plant"]["I_xz"]],
                                   [x["plant"]["I_xy"], x["plant"]["I_y"], x["plant"]["I_yz"]],
                                   [x["plant"]["I_xz"], x["plant"]["I_yz"], x["plant"]["I_z"]]])
        m = sc.principal_moments  # k-th smallest scaled moment is within the k-th nominal's range
        assert np.all(m >= m0 * 0.8 * (1 - 1e-12)) and np.all(m <= m0 * 1.2 * (1 + 1e-12))  # rounding
    assert max(abs(x["plant"]["I_xy"]) for x in s) > 0.01  # the axes turned (products appear)


def test_inertia_redraws_until_the_triangle_inequality_holds() -> None:
    # moments (1, 1, 1.9): +-20 % breaks I_1 + I_2 >= I_3 in a large share of the raw draws
    nominal = lookup({"plant": {"I_x": 1.0, "I_y": 1.0, "I_z": 1.9}})
    s = draws({"inertia": {"instance": "plant", "relative": 0.2}}, 500, nominal)
    assert all(set(x["plant"]) == {"I_x", "I_y", "I_z"} for x in s)  # no products on this plant
    m = np.array([sorted(x["plant"].values()) for x in s])
    assert np.all(m[:, 0] + m[:, 1] >= m[:, 2])
    with pytest.raises(DispersionError, match="principal moments only"):
        draws({"inertia": {"instance": "plant", "relative": 0.2, "axis_rotation_deg": 1.0}}, 1, nominal)


TABLE = {"plant.I_x": {"kind": "normal", "mean": 15.0, "std": 0.5},
         "attitude": {"instance": "plant", "kind": "uniform", "mrp": "sigma_0"},
         "plant.mode": {"kind": "choice", "values": ["a", "b"]}}


def test_samples_depend_on_seed_and_index_only() -> None:
    d = Dispersions.from_dict(TABLE)
    at_once = [d.sample(11, i) for i in range(100)]
    one_by_one = {i: d.sample(11, i) for i in reversed(range(100))}
    assert at_once == [one_by_one[i] for i in range(100)]  # exact: the same generator streams
    assert d.sample(12, 0) != at_once[0]
    assert len({s["plant"]["I_x"] for s in at_once}) == 100


@pytest.mark.parametrize("table, message", [
    ({"plant.I_x": {"kind": "normall", "std": 1.0}}, r'dispersions."plant.I_x".kind: .*did you mean \'normal\''),
    ({"plant.I_x": {"kind": "uniform", "low": 2.0, "high": 1.0}}, r'"plant.I_x": low 2 must be < high 1'),
    ({"plant.I_x": {"kind": "normal", "std": 0.0}}, r'"plant.I_x".std: must be > 0'),
    ({"plant.I_x": {"kind": "log_uniform", "low": 0.0, "high": 1.0}}, r"low: must be > 0"),
    ({"plant.I_x": {"kind": "uniform", "low": 0.0}}, r"needs 'high'"),
    ({"plant.I_x": {"kind": "normal", "std": 1.0, "sdt": 1}}, r"sdt"),
    ({"plnt.I_x": {"kind": "normal", "std": 1.0}}, r"no FMU instance 'plnt'.*did you mean 'plant'"),
    ({"profiles[3].seed": {"kind": "seed"}}, r"has 1 profile\(s\), no profiles\[3\]"),
    ({"atitude": {"instance": "plant", "kind": "uniform"}}, r"did you mean 'attitude'"),
    ({"attitude": {"instance": "plant", "kind": "cone"}}, r"dispersions.attitude: kind cone needs 'half_angle_deg'"),
    ({"inertia": {"instance": "plant", "relative": 1.5}}, r"dispersions.inertia.relative: must be in \(0, 1\)"),
    ({"plant.I_x": {"kind": "normal", "std": 1.0}, "inertia": {"instance": "plant", "relative": 0.1}},
     r"plant.I_x is dispersed twice"),
    ({"plant.I_x": {"kind": "uniform", "low": 1.0, "high": 2.0, "transform": "cube"}},
     r"dispersions.\"plant.I_x\".transform: must be one of square, got 'cube'"),
    ({"plant.I_x": {"kind": "normal", "std": 1.0, "transform": "square"}},
     r"dispersions.\"plant.I_x\".mean: must be given with a transform"),
    ({"profiles[0].seed": {"kind": "seed", "transform": "square"}}, r"unknown key 'transform'"),
])
def test_validation_names_the_key_path(table: dict, message: str) -> None:
    data = {"name": "bad", "stop_time": 1.0, "step_size": 0.5, "fmus": {"plant": {"model": "mrp_satellite"}},
            "profiles": [{"to": "plant.w_d[1]", "kind": "constant", "value": 0.0}], "dispersions": table}
    with pytest.raises(ScenarioError, match=message):
        Scenario.from_dict(data, where="bad.toml")


SCENARIO = '''
name = "dispersed"
stop_time = 2.0
step_size = 0.1
record = ["plant.sigma", "plant.omega"]

[fmus.plant]
model = "mrp_satellite"
parameters = { "sigma_0[1]" = 0.5992, "sigma_0[2]" = -0.7976, "sigma_0[3]" = 0.6517 }

[[profiles]]
to = "plant.w_d[1]"
kind = "random"
seed = 1
std = 0.1

[dispersions]
"plant.omega_0[1]" = { kind = "uniform", low = -0.01, high = 0.01 }
"profiles[0].seed" = { kind = "seed" }
attitude = { instance = "plant", kind = "cone", half_angle_deg = 10.0 }
inertia = { instance = "plant", relative = 0.2, axis_rotation_deg = 2.0 }
'''


def test_a_dispersed_sample_runs(tmp_path: Path, fmu_dir: Path) -> None:
    (tmp_path / "dispersed.toml").write_text(SCENARIO)
    sc = Scenario.from_toml(tmp_path / "dispersed.toml")
    assert Scenario.from_dict(sc.to_dict()).dispersions == sc.dispersions  # round trip
    one = sc.sample(5, 0, fmu_dir)
    assert one.dispersions is None and sc.fmus["plant"].parameters["sigma_0[1]"] == 0.5992  # nominal kept
    p = one.fmus["plant"].parameters
    assert p["I_x"] != SEED_000.parameters()["I_x"] and one.profiles[0]["seed"] != 1
    res = run(one, fmu_dir).results
    # the run starts from the sample's values (start values are written exactly)
    assert res["plant.sigma[1]"][0] == p["sigma_0[1]"] and res["plant.omega[1]"][0] == p["omega_0[1]"]


def test_a_dispersed_parameter_the_fmu_lacks_is_refused_at_check(tmp_path: Path, fmu_dir: Path) -> None:
    (tmp_path / "bad.toml").write_text(SCENARIO.replace('"plant.omega_0[1]"', '"plant.omega_9[1]"'))
    sc = Scenario.from_toml(tmp_path / "bad.toml")
    with pytest.raises(ScenarioError, match=r'bad.toml: dispersions.plant.omega_9\[1\]: .*no variable'):
        check(sc, fmu_dir)


def test_a_draw_without_its_nominal_value_names_the_key() -> None:
    d = Dispersions.from_dict({"plant.I_x": {"kind": "normal", "std": 1.0}})
    with pytest.raises(DispersionError, match=r"dispersions.plant.I_x.mean: not given, and plant.I_x has no nominal"):
        d.sample(0, 0)
    with pytest.raises(DispersionError, match="index must be a non-negative integer"):
        d.sample(0, -1, lookup({"plant": {"I_x": 1.0}}))


def test_with_parameters_refuses_an_unknown_instance() -> None:
    sc = Scenario.from_dict({"name": "x", "stop_time": 1.0, "step_size": 0.5,
                             "fmus": {"plant": {"model": "mrp_satellite"}}})
    assert sc.with_parameters({"plant": {"I_x": 3.0}}).fmus["plant"].parameters == {"I_x": 3.0}
    assert sc.fmus["plant"].parameters == {}  # the original is unchanged
    with pytest.raises(ScenarioError, match="no FMU instance or profile 'plnt'.*did you mean 'plant'"):
        sc.with_parameters({"plnt": {"I_x": 3.0}})
