"""Margins through a scenario's wiring and as metrics a pytest gate holds (issue 56 item 1)."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import satfmu
from satfmu.fmus.errors import ScenarioError
from satfmu.fmus.linearization import Linearizer, linearize
from satfmu.fmus.plants import wheel_spacecraft
from satfmu.sims.scenario import loops
from satfmu.sims.scenario.spec import load
from satfmu.sims.workflows import analysis
from satfmu.synthesis.core import margins as loop_margins

LOOP = {"name": "gate", "stop_time": 0.1, "step_size": 0.05,
        "fmus": {"plant": {"model": "mrp_satellite"}, "controller": {"model": "mrp_hinf_published"}},
        "connections": [{"from": "plant.sigma", "to": "controller.sigma"},
                        {"from": "plant.omega", "to": "controller.omega"},
                        {"from": "controller.u", "to": "plant.u"}]}


def test_definitions_are_chained_not_substituted() -> None:
    # the four-wheel plant has 140 definitions; chained numerically they give the substituted
    # Jacobian's numbers (a wheel speed's effect on the body rate: the gyroscopic coupling)
    model = wheel_spacecraft.MODELS[4]
    point = {"omega[2]": 0.01, "Omega[1]": 100.0}
    flying = {"v_air[1]": 7600.0, "density": 1e-12, "r[1]": 6.9e6, "sun[1]": 1.0, "sun_distance": 1.496e11,
              "sunlit": 1.0}  # in orbit: |v|, |r| and the Sun direction have no derivative at 0
    lin = Linearizer(model, outputs=["omega[1]"])(point, flying)
    assert lin.A.shape == (len(model.states), len(model.states)) and np.all(np.isfinite(lin.A))
    assert lin.y0[0] == 0.0  # omega[1] is 0 at the point
    again = linearize(model, x0=point, u0=flying, outputs=["omega[1]"])
    np.testing.assert_array_equal(lin.A, again.A)
    with pytest.raises(ValueError, match="A is not finite at the operating point"):
        linearize(model, x0=point)


def test_the_loop_is_found_whatever_the_signals_are_called() -> None:
    found, notes = loops.find_loops(load("vscmg_seed"))
    assert notes == []
    lq = next(lp for lp in found if lp.controller == "lq")
    assert lq.plant == "lq_plant" and lq.actuation == (("T1", "T1"), ("T2", "T2"))
    assert ("q2", "q2") in lq.measurement and ("w4", "w4") in lq.measurement
    dem, _ = loops.find_loops(load("demeter_row1_det_both"))
    assert dem[0].actuation == tuple((f"u_c[{i}]", f"u_c[{i}]") for i in (1, 2, 3))
    assert len(dem[0].measurement) == 28  # theta, rates, 8 modal coordinates and rates, wheel torques


def test_scenario_margins_match_the_artifacts_at_the_origin() -> None:
    # the same loop two ways: the artifact on its design plant, and the scenario's wiring of it
    by_artifact = analysis.margins("mrp_hinf_published")
    by_scenario = analysis.margins("mrp_200deg")
    origin = next(r for r in by_scenario.loops if r.point == "origin")
    for a, b in ((by_artifact.continuous, origin.continuous), (by_artifact.sampled, origin.sampled)):
        assert [lm.phase_margin_deg for lm in a.loops] == pytest.approx([lm.phase_margin_deg for lm in b.loops],
                                                                         rel=1e-9)
        assert a.disk_gain_margin_db == pytest.approx(b.disk_gain_margin_db, rel=1e-9)
    start = next(r for r in by_scenario.loops if r.point == "start")  # 200 deg away: a frozen-point loop
    assert start.continuous.sensitivity_peak > origin.continuous.sensitivity_peak
    assert "frozen-point loop" in by_scenario.text()


def test_a_single_axis_design_leaves_the_other_axes_out_of_its_loop() -> None:
    r = next(r for r in analysis.margins("demeter_row1_det_both").loops if r.point == "origin")
    m = r.sampled
    assert m.unused == ("u_c[2]", "u_c[3]") and [lm.channel for lm in m.loops] == ["u_c[1]"]
    assert m.closed_loop_stable  # the free axes' rigid-body poles at 0 are no part of it
    # the scenario's own note: "a held command above ~1.5 ms diverges": the delay margin is of that order
    assert 0.5e-3 < m.loops[0].delay_margin < 3e-3


def test_sampled_and_singular_laws_say_why_they_have_no_margins() -> None:
    text = analysis.margins("vscmg_seed").text()
    assert "vscmg_sdre_online samples" in text
    assert "bs (vscmg_backstepping) on bs_plant (vscmg), origin: no linearization here" in text  # sin q2 = 0
    assert "bs (vscmg_backstepping) on bs_plant (vscmg), start, continuous: closed loop stable" in text


def test_disk_margins_are_the_balanced_disk_of_the_sensitivity() -> None:
    # our own check of python-control's figure on one channel: alpha = 1 / max |S - 1/2|, the gain
    # margin (1 + alpha/2) / (1 - alpha/2) and the phase margin 2 atan(alpha/2) of the same disk
    r = analysis.margins("mrp_hinf_satfmu").continuous
    b = math.tan(math.radians(r.disk_phase_margin_deg) / 2)
    assert r.disk_gain_margin_db == pytest.approx(20 * math.log10((1 + b) / (1 - b)), rel=1e-12)
    assert all(lm.phase_margin_deg >= r.disk_phase_margin_deg - 1e-9 for lm in r.loops)


def test_margin_metrics_gate_a_design(fmu_dir: Path) -> None:
    metrics = [{"name": "gain margin", "kind": "gain_margin", "signals": ["plant.u"], "min": 6.0},
               {"name": "phase margin", "kind": "phase_margin", "signals": ["plant.u"], "min": 30.0},
               {"name": "phase margin, axis 2, rad", "kind": "phase_margin", "signals": ["plant.u[2]"],
                "unit": "rad"},
               {"name": "disk", "kind": "disk_phase_margin", "signals": ["plant.u"], "min": 30.0},
               {"name": "S peak", "kind": "sensitivity_peak", "signals": ["plant.u"], "max": 2.0}]
    result = satfmu.run({**LOOP, "metrics": metrics}, fmu_dir=fmu_dir)
    ref = analysis.margins("mrp_hinf_published").sampled  # the scenario's step is the artifact default's
    m = result.metrics
    assert m["gain margin"].value == math.inf and m["gain margin"].unit == "dB"
    assert m["phase margin"].value == pytest.approx(min(lm.phase_margin_deg for lm in ref.loops), rel=1e-9)
    assert m["phase margin, axis 2, rad"].value == pytest.approx(math.radians(ref.loops[1].phase_margin_deg),
                                                                  rel=1e-9)
    assert m["disk"].value == pytest.approx(ref.disk_phase_margin_deg, rel=1e-9)
    assert m["S peak"].unit == "1" and result.passed
    strict = {**LOOP, "metrics": [{**metrics[1], "min": 45.0}]}  # 40.4 deg: fails a 45 deg requirement
    assert not satfmu.run(strict, fmu_dir=fmu_dir).passed


def test_a_margin_metric_on_no_loop_is_refused(fmu_dir: Path) -> None:
    bad = {**LOOP, "metrics": [{"name": "gm", "kind": "gain_margin", "signals": ["plant.w_d"]}]}
    with pytest.raises(ScenarioError, match=r"metrics\[0\]\.signals: plant.w_d\[1\].* no plant input a controller "
                                            r"of the scenario drives \(the loops break at: plant.u\[1\]"):
        satfmu.run(bad, fmu_dir=fmu_dir)


def test_loop_margins_refuse_a_loop_with_no_controller_output() -> None:
    P = linearize(loops.model("mrp_satellite"), inputs=["u[1]"], outputs=["omega[1]"])
    K = linearize(loops.model("mrp_hinf_published"), inputs=["omega[1]"], outputs=["u[1]"])
    zero = type(K)(K.A, K.B, K.C, 0 * K.D, K.states, K.inputs, K.outputs, K.x0, K.u0, K.y0)
    with pytest.raises(ValueError, match="no loop"):
        loop_margins.margins(P, zero)


@pytest.mark.parametrize("scenario, controller, point", [("vscmg_seed", "lq", "start"),
                                                         ("demeter_row1_det_both", "ctrl", "origin")])
def test_python_control_agrees_with_our_sweep_on_the_scenario_loops(scenario: str, controller: str,
                                                                    point: str) -> None:
    # the loops whose signals are not their plant's by name: the same check as the artifacts'
    # (tests/test_margins.py), on a 40,000-point grid of our own against python-control's
    sc = load(scenario)
    r = next(r for r in loops.scenario_margins(sc, (point,))[0] if r.loop.controller == controller)
    omega = np.logspace(-4, math.log10(0.999 * math.pi / sc.step_size), 40_000)
    for (name, L), lm in zip([c for c in loop_margins.channel_responses(r.plant, r.controller, omega, sc.step_size)
                              if c[0] not in r.sampled.unused], r.sampled.loops):
        gm, pm = loop_margins.sweep_margins(L, omega)
        assert lm.channel == name
        assert pm == pytest.approx(lm.phase_margin_deg, abs=0.05) or pm == lm.phase_margin_deg == math.inf
        # our sweep gives the smallest over every phase crossover: the lower margin where there is one
        expected = lm.lower_gain_margin_db if math.isfinite(lm.lower_gain_margin_db) else lm.gain_margin_db
        assert gm == pytest.approx(expected, abs=0.05) or gm == expected == math.inf
