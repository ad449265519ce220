"""Randomized analysis and scenario design (seed 004 part 2): bounds, statements, DEMETER."""
from __future__ import annotations

import math
import pickle

import numpy as np
import pytest
from scipy.stats import binom

from satfmu.synthesis.robust import demeter_design
from satfmu.synthesis.robust import demeter_random
from satfmu.synthesis.robust import probabilistic
from satfmu.synthesis.robust import sequential
from satfmu.synthesis.robust.demeter_variants import Variant, design_model
from satfmu.synthesis.robust.lft_plant import OptionError

ROW1 = Variant((1,), (1,), 1, 1)


def test_sample_size_bounds() -> None:
    # docs/models.md's figures: 132 worst case and 726 Chernoff at the seed's (0.1, 1e-6); 962
    # scenarios for row 1's 46 decision variables at (0.1, 1e-9)
    assert probabilistic.worst_case_samples(0.1, 1e-6) == 132
    assert probabilistic.chernoff_samples(0.1, 1e-6) == 726
    assert probabilistic.scenario_samples(46, 0.1, 1e-9) == 962
    assert demeter_random.n_decision(design_model(ROW1)) == 46
    for d, eps, delta in ((1, 0.1, 1e-3), (10, 0.05, 1e-6), (46, 0.1, 1e-9)):
        n = probabilistic.scenario_samples(d, eps, delta)  # the smallest N meeting the binomial tail
        assert binom.cdf(d - 1, n, eps) <= delta < binom.cdf(d - 1, n - 1, eps)
    assert probabilistic.chernoff_accuracy(726, 1e-6) <= 0.1 < probabilistic.chernoff_accuracy(725, 1e-6)
    assert math.ceil(math.log(1e6) / math.log(1 / 0.9)) == 132  # the closed form itself
    for bad in (0.0, 1.0, float("nan")):
        with pytest.raises(OptionError):
            probabilistic.worst_case_samples(bad, 1e-6)
        with pytest.raises(OptionError):
            probabilistic.chernoff_samples(0.1, bad)
    with pytest.raises(OptionError):
        probabilistic.scenario_samples(0, 0.1, 1e-6)
    # the R-RoMulOC toolbox's count (scensamplenb): 1055 for row 1 (15.8 x (20.72 + 46) = 1054.2),
    # sufficient, so never below the exact one
    assert probabilistic.scenario_samples(46, 0.1, 1e-9, bound="romuloc") == 1055
    for d, eps, delta in ((1, 0.1, 1e-3), (10, 0.05, 1e-6), (46, 0.1, 1e-9), (300, 0.1, 1e-9)):
        assert probabilistic.scenario_samples(d, eps, delta, "romuloc") >= probabilistic.scenario_samples(d, eps, delta)
    with pytest.raises(OptionError, match="bound must be one of"):
        probabilistic.scenario_samples(46, 0.1, 1e-9, bound="calafiore")


def test_worst_case_and_level_statements() -> None:
    v = np.array([0.5, 2.0, np.nan, 1.0])
    wc = probabilistic.worst_case(v, 0.1, 1e-6)
    assert wc.estimate == np.inf and not wc.sufficient  # a failed sample is the worst case
    assert "NOT guaranteed: needs N >= 132" in wc.text()
    lp = probabilistic.level_probability(v, 1.0, 1e-6)
    assert lp.probability == 0.5 and lp.n == 4  # NaN does not meet the level
    assert lp.accuracy == pytest.approx(math.sqrt(math.log(2e6) / 8), rel=1e-15)
    wc = probabilistic.worst_case(np.arange(200.0))
    assert wc.sufficient and wc.estimate == 199.0 and "<= 0.1 with confidence 0.999999" in wc.text()
    with pytest.raises(OptionError):
        probabilistic.worst_case([])


@pytest.fixture(scope="module")
def scen() -> demeter_random.ScenarioResult:
    return demeter_random.scenario(ROW1, n=60, seed=0)


@pytest.mark.slow
def test_scenario_design_row1(scen) -> None:
    des = scen.design
    assert des.status == "optimal" and des.check.ok and scen.n_samples == 60
    # measured objective 500.0 (gamma 250.0, nu 2.500) against the deterministic 513.2: fewer
    # constraints than the whole box, so not more conservative; 1e-2: solver accuracy + back-off
    assert des.gamma + 100 * des.nu <= 513.2 * (1 + 1e-2)
    assert des.gamma * des.nu >= 500 * (1 - 2e-3)  # the shared-Lyapunov floor holds per sample
    # every scenario plant's closed loop is in the region (the program's constraints)
    dm = design_model(ROW1)
    A, Bu, _ = dm.state_space(dm.sample(60, np.random.default_rng(0)))
    ev = np.linalg.eigvals(A + Bu @ scen.K).real
    assert ev.max() < -demeter_design.ALPHA and ev.min() > -demeter_design.BETA
    a = scen.analysis
    assert a.n == 132 and a.hinf.sufficient
    # the analysis samples are others: the bounds need not hold there, but the loop is stable
    # (measured max Re -1.05e-4: 60 scenarios leave the region's edge uncovered)
    assert a.max_real_pole < 0 and np.isfinite(a.hinf.estimate)
    assert a.i2p.estimate <= des.nu and a.hinf.estimate <= des.gamma


def test_random_direction_i2p_is_below_the_worst_direction() -> None:
    # The toolbox's probabilistic i2p analysis takes one random unit impulse direction per
    # sample; ours the worst one. Same plants (drawn first from the same generator): per sample
    # the random direction's peak is at most the worst direction's (up to rounding, 1e-12
    # relative), and below it somewhere; the H-infinity and pole values are the same.
    dm = design_model(ROW1)
    K = demeter_design.deterministic(ROW1, n_samples=0, analysis=False).K
    worst, rand = (demeter_random.analyse(ROW1, K, n=40, seed=3, i2p_direction=d) for d in ("worst", "random"))
    assert (worst.i2p_direction, rand.i2p_direction) == ("worst", "random")
    assert rand.hinf.estimate == worst.hinf.estimate and rand.max_real_pole == worst.max_real_pole
    assert rand.i2p.estimate <= worst.i2p.estimate * (1 + 1e-12)
    rng = np.random.default_rng(3)
    deltas = dm.sample(40, rng)
    u = rng.normal(size=(40, dm.B2.shape[1]))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    per_worst = demeter_design.closed_loop_values(dm, K, deltas)["i2p"]
    per_rand = demeter_design.closed_loop_values(dm, K, deltas, u)["i2p"]
    assert np.all(per_rand <= per_worst * (1 + 1e-12)) and np.any(per_rand < 0.99 * per_worst)
    with pytest.raises(OptionError, match="i2p_direction must be one of"):
        demeter_random.analyse(ROW1, K, n=5, i2p_direction="mean")


@pytest.mark.slow
def test_closed_loop_task_is_pure_and_picklable(scen) -> None:
    task = demeter_random.ClosedLoopSamples(ROW1, scen.K)
    deltas = design_model(ROW1).sample(20, np.random.default_rng(4))
    first = task(deltas)
    clone = pickle.loads(pickle.dumps(task))
    assert clone._dm is None  # the design model is rebuilt in the worker, not shipped
    again = clone(deltas)
    for k in first:
        assert np.array_equal(first[k], again[k])  # deterministic: bit for bit
    unstable = task.__class__(ROW1, np.zeros_like(scen.K))(deltas)  # open loop: xi integrates
    assert np.all(unstable["hinf"] == np.inf) and np.all(unstable["max_real_pole"] >= 0)


def test_campaign_command_states_the_chernoff_bounds(tmp_path, capsys) -> None:
    from satfmu.sims.cli import main

    args = ["campaign", "demeter", "--samples", "300", "--chunk", "150", "--workers", "1", "--out", str(tmp_path)]
    assert main(args) == 0
    out = capsys.readouterr().out
    assert "hinf: N = 300 samples (0 NaN)" in out and "i2p: N = 300" in out and "max_real_pole: N = 300" in out
    # sqrt(ln(2e6) / 600) = 0.155503: the Chernoff half-width of 300 samples at delta 1e-6
    assert "eps_N = sqrt(ln(2/delta)/(2N)) = 0.155503" in out
    assert len(list((tmp_path / "demeter_row1_det-n300-s0").glob("chunk-*.parquet"))) == 2
    assert main(args) == 0  # resumed: nothing left to compute, same statements
    assert "hinf: N = 300 samples (0 NaN)" in capsys.readouterr().out
    assert main(["campaign", "demeter", "--artifact", "mrp_hinf_published", "--out", str(tmp_path)]) == 2


def test_campaign_of_a_design_unstable_for_some_samples(tmp_path, capsys) -> None:
    """Row 1's gain times 3 destabilizes part of the box: the campaign completes (exit 0) and
    states how many samples are unstable instead of dying on the infinite H-infinity norms."""
    import json

    from satfmu.sims.cli import main
    from satfmu.controllers.paths import SHIPPED_ARTIFACTS

    data = json.loads((SHIPPED_ARTIFACTS / "demeter_row1_det.json").read_text())
    data["name"] = "demeter_row1_k3"
    K3 = 3 * np.array(data["design"]["K"])
    data["design"]["K"], data["gains"] = K3.tolist(), design_model(ROW1).fmu_gains(K3)  # one law, both forms
    data["certificate"]["status"] = "not_verified"  # the certificate is row 1's, not this gain's
    f = tmp_path / "demeter_row1_k3.json"
    f.write_text(json.dumps(data))
    args = ["campaign", "demeter", "--artifact", str(f), "--samples", "200", "--chunk", "100", "--workers", "1",
            "--out", str(tmp_path)]
    assert main(args) == 0
    out = capsys.readouterr().out
    from satfmu.sims.campaign import engine as campaign

    df = campaign.load(tmp_path / "demeter_row1_k3-n200-s0")
    n_unstable = int((df["max_real_pole"] >= 0).sum())
    assert 0 < n_unstable < 200 and int(np.isinf(df["hinf"]).sum()) == n_unstable
    assert f"hinf: N = 200 samples (0 NaN, {n_unstable} infinite)" in out
    assert f"Worst case: unbounded, {n_unstable} of 200 samples are infinite" in out


def test_sequential_method_lowers_the_deterministic_levels() -> None:
    # ln(pi^2 / (6e-6)) / ln(1 / 0.9) = 135.85: round 1 draws 136 plants; more rounds, more
    assert sequential.validation_samples(1, 0.1, 1e-6) == 136 and sequential.validation_samples(2, 0.1, 1e-6) == 150
    with pytest.raises(OptionError):
        sequential.validation_samples(0, 0.1, 1e-6)
    same = demeter_random.sequential_design(ROW1, scale=1.0, max_updates=5)
    # the deterministic certificate holds on the whole box: every sampled LMI is negative definite;
    # updates (measured 0 or 4, by the coordinates of design_scale) only push the largest
    # eigenvalue past the method's strictness margin (1e-7)
    assert same.validated and same.result.samples >= 136
    assert all(-1e-7 < v < 0 for v in same.result.violations)
    lower = demeter_random.sequential_design(ROW1, scale=0.994, max_updates=60)
    # measured: 4 updates, 773 samples, well under a second (255.0, 2.55 against 256.6, 2.566)
    assert lower.validated and 0 < lower.result.updates <= 60
    assert lower.result.gamma < same.result.gamma and lower.result.nu < same.result.nu
    assert "P(specs violated at gamma" in lower.result.text()
    # an independent look at 300 fresh plants: stable, inside the region, below the levels
    a = demeter_random.analyse(ROW1, lower.K, n=300, seed=21)
    assert a.in_region and a.hinf.estimate <= lower.result.gamma and a.i2p.estimate <= lower.result.nu
