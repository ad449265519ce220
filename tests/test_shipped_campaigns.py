"""The shipped campaign scenarios: sims/scenario/shipped/*.toml with [dispersions] and a [campaign] table."""
from __future__ import annotations

import tomllib
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from satfmu.sims.scenario.provisioning import nominal_values
from satfmu.sims.scenario.run import check
from satfmu.sims.scenario.spec import Scenario, load
from satfmu.sims.campaign.scenario_task import campaign, campaign_size, explain
from satfmu.sims.scenario.dispersions import Attitude, Distribution, Inertia
from satfmu.sims.scenario import shipped_scenarios
from satfmu.sims.workflows import sensing

CAMPAIGNS = [p.stem for p in shipped_scenarios() if "dispersions" in tomllib.loads(p.read_text())]
"""Every shipped scenario with [dispersions]: a shipped campaign."""
GROUPS = {"mrp_slew_mc": ["mrp_slew_mc", "mrp_slew_mc_synth", "mrp_slew_mc_h2hinf"],
          "cubesat_detumble_mc": ["cubesat_detumble_mc_bdot", "cubesat_detumble_mc_periodic"],
          "vscmg_friction_mc": ["vscmg_friction_mc_online", "vscmg_friction_mc_approx"],
          "demeter_row1_det": ["demeter_row1_det_both", "demeter_row1_det_theta", "demeter_row1_det_rate"],
          "rw4_slew_mc": ["rw4_slew_mc", "rw4_slew_mc_synth", "rw4_slew_mc_h2hinf"],
          "rw4_slew_sensed_mc": ["rw4_slew_sensed_mc", "rw4_slew_sensed_mc_synth", "rw4_slew_sensed_mc_h2hinf"],
          "cubesat_detumble_mc_bdot_sensed": ["cubesat_detumble_mc_bdot_sensed"]}
"""Campaigns that differ only in the controller, or (seed 004's Figs 4-5) only in the initial state:
the same draws for sample i, compared side by side."""
STARTS = {"demeter_row1_det": {"theta_0[1]", "theta_dot_0[1]"}}
"""The plant start values in which the campaigns of a group differ (the initial states of Figs 4-5)."""
STEPS = 200
"""Communication steps the test runs of a campaign (a cut stop time: 10 s of the MRP slews, 200 s of
the detumbling, 2 s of the VSCMG manoeuvre, so that the pythonfmu SDRE servo takes ~0.5 s a sample)."""


def test_the_shipped_campaigns_are_the_documented_ones() -> None:
    assert sorted(CAMPAIGNS) == sorted(n for group in GROUPS.values() for n in group)
    catalog = (Path(__file__).resolve().parents[1] / "docs" / "catalog.md").read_text()
    for name in CAMPAIGNS:
        assert f"`{name}`" in catalog, f"{name} is not in docs/catalog.md"


@pytest.mark.parametrize("name", CAMPAIGNS)
def test_a_shipped_campaign_loads_checks_and_runs_two_samples(name: str, fmu_dir: Path) -> None:
    """Declared sizes, the nominal scenario checked against its FMUs, and samples 0 and 1 run as a
    campaign runs them (its task, cut to STEPS steps): both run, every dispersed value is within its
    declared distribution, and the two samples differ."""
    sc = load(name)
    assert sc.dispersions is not None
    size = sc.campaign
    assert set(size) == {"samples", "demo_samples", "seed"} and size["demo_samples"] < size["samples"]
    assert campaign_size(sc) == (size["samples"], size["seed"])
    assert campaign_size(sc, demo=True) == (size["demo_samples"], size["seed"])
    check(sc, fmu_dir)
    data = {k: v for k, v in sc.to_dict().items() if k != "campaign"}
    cut = Scenario.from_dict({**data, "stop_time": sc.start_time + STEPS * sc.step_size}, sc.folder, name)
    camp = campaign(cut, 2, seed=size["seed"], chunk=2, fmu_dir=fmu_dir)
    rows = camp.task(np.arange(2))
    assert rows["failed"].tolist() == [0.0, 0.0], [explain(camp.task, i) for i in range(2)]
    for m in sc.metrics:  # a value for every metric (inf is one: a settling time not reached)
        assert not np.isnan(rows[m.name]).any(), m.name
    columns = [c for c in camp.task.columns if c.startswith(("plant.", "profiles["))]
    for entry in sc.dispersions.entries:
        if isinstance(entry, Distribution) and entry.kind == "uniform":
            v = rows[entry.target]
            if entry.spec.get("transform") == "square":  # the draw is the root of the value set
                v = np.sqrt(v)
            assert ((entry.spec["low"] <= v) & (v <= entry.spec["high"])).all(), entry.target
        elif isinstance(entry, Attitude) and entry.mrp:  # the shadow set
            sigma = np.stack([rows[f"plant.{entry.mrp}[{i}]"] for i in (1, 2, 3)])
            assert (np.linalg.norm(sigma, axis=0) <= 1.0 + 1e-12).all()  # 1e-12: rounding of as_mrp
        elif isinstance(entry, Attitude):  # a unit quaternion, scalar last
            q = np.stack([rows[f"plant.{entry.quaternion}[{i}]"] for i in (1, 2, 3, 4)])
            assert np.allclose(np.linalg.norm(q, axis=0), 1.0, rtol=0, atol=1e-12)  # rounding of as_quat
        elif isinstance(entry, Inertia):
            nominal = nominal_values(sc, fmu_dir)
            for k in ("I_x", "I_y", "I_z"):  # principal axes kept: each moment scaled within +-relative
                ratio = rows[f"plant.{k}"] / nominal("plant", k)
                assert ((1 - entry.relative <= ratio) & (ratio <= 1 + entry.relative)).all(), k
    assert all(rows[c][0] != rows[c][1] for c in columns if not c.endswith(("I_xy", "I_xz", "I_yz")))


@pytest.mark.parametrize("group", list(GROUPS))
def test_the_campaigns_of_a_group_draw_the_same_samples(group: str, fmu_dir: Path) -> None:
    """Same seed, same [dispersions]: sample i of each campaign of a group is the same draw, so
    their statistics compare sample by sample; only the controller (or the initial state) differs."""
    scenarios = [load(n) for n in GROUPS[group]]
    assert len({sc.campaign["seed"] for sc in scenarios}) == 1
    assert all(sc.dispersions.data == scenarios[0].dispersions.data for sc in scenarios)
    starts = STARTS.get(group, set())
    plants = [replace(p, parameters={k: v for k, v in p.parameters.items() if k not in starts})
              for p in (sc.fmus["plant"] for sc in scenarios)]
    assert all(p == plants[0] for p in plants)
    seed = scenarios[0].campaign["seed"]
    for i in (0, 7):
        draws = [sc.dispersions.sample(seed, i, nominal_values(sc, fmu_dir)) for sc in scenarios]
        assert all(d == draws[0] for d in draws)


@pytest.mark.parametrize("controller", list(sensing.PAIRS))
def test_a_sensed_campaign_draws_the_samples_of_its_true_state_twin(controller: str, fmu_dir: Path) -> None:
    """The sensed campaign declares its twin's dispersions first, in the same order, then its
    sensors': sample i is the same spacecraft, manoeuvre and environment in both (what lets
    satfmu.sims.workflows.sensing compare them sample for sample)."""
    ideal, sensed = (load(n) for n in sensing.PAIRS[controller])
    assert ideal.campaign["seed"] == sensed.campaign["seed"]
    shared = list(ideal.dispersions.data)
    assert list(sensed.dispersions.data)[:len(shared)] == shared
    assert all(sensed.dispersions.data[k] == ideal.dispersions.data[k] for k in shared)
    extra = list(sensed.dispersions.data)[len(shared):]
    assert extra and all(not k.startswith(("plant.", "orbit.")) for k in extra)  # the sensors' draws only
    seed = ideal.campaign["seed"]
    for i in (0, 7):
        a = ideal.dispersions.sample(seed, i, nominal_values(ideal, fmu_dir))
        b = sensed.dispersions.sample(seed, i, nominal_values(sensed, fmu_dir))
        assert all(b[instance] == values for instance, values in a.items())
