"""Seed 004 Figs 4-5 through the FMUs: random closed loops of the DEMETER plant and the row-1 design."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from distributed import Client, LocalCluster

from satfmu.controllers import polynomial
from satfmu.sims.workflows import demeter_loops
from satfmu.sims.scenario.spec import load
from satfmu.sims.cli import main
from satfmu.sims.scenario import SHIPPED_SCENARIOS
from satfmu.synthesis.robust.demeter_variants import THETA_WORST

ART = polynomial.ARTIFACTS / "demeter_row1_det.json"


@pytest.fixture(scope="module")
def loops(fmu_dir: Path) -> dict[str, demeter_loops.RandomLoops]:
    """Two random plants, 5 s at 1 ms, both limit settings: six scenario campaigns on one in-process
    Dask worker (the FMUs run in this process)."""
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, dashboard_address=":0") as lc, \
            Client(lc) as client:
        return {lim: demeter_loops.run(fmu_dir, ART, n=2, seed=3, stop_time=5.0, step_size=1e-3, limits=lim,
                                       points=2001,
                            client=client) for lim in ("linear", "wheels")}


def test_fmu_loops_without_limits_are_the_design_model(loops) -> None:
    lin = loops["linear"]
    # 2001 points asked of 5001 rows: 1251 (every 4th row), the largest uniform grid
    assert lin.theta.shape == (2, 1251) and lin.z2.shape == (2, 2, 1251) and lin.time[1] == pytest.approx(4e-3)
    assert lin.theta[:, 0] == pytest.approx(THETA_WORST, rel=1e-12) and lin.saturated.max() == 0.0  # 15 deg
    # the only difference is the command held over 1 ms: 9e-7 rad over 60 s (cli), less over 5 s
    assert lin.linear_error < 1e-6
    # the same plants on the design model, exactly: same start of theta to the hold's accuracy
    ref = demeter_loops.linear(ART, deltas=lin.deltas, stop_time=5.0, points=1251)
    assert np.abs(ref.theta - lin.theta).max() < 1e-6
    assert np.abs(lin.deltas).max() <= 1.0 and lin.deltas.shape == (2, 3)  # sqrtJ11, omega, zeta in the box


def test_the_scenario_disperses_the_design_box_and_bounds_z2_by_the_certificate() -> None:
    """Row 1: J[1,1] = S^2 with S uniform on the design's sqrtJ11 interval, omega[1] and zeta[1]
    uniform on theirs; the peak-|xw| bound is the artifact's impulse-to-peak bound times |w2|."""
    import json

    cert = json.loads(ART.read_text())["certificate"]["numbers"]["design_i2p_bound"]
    sc = demeter_loops.scenario(ART, start="both")
    table = sc.dispersions.data
    assert table["plant.J[1,1]"]["transform"] == "square"
    assert table["plant.J[1,1]"]["low"] ** 2 == pytest.approx(21.966, abs=1e-3)  # the artifact's range of J[1,1]
    assert table["plant.J[1,1]"]["high"] ** 2 == pytest.approx(40.794, abs=1e-3)
    assert (table["plant.omega[1]"]["low"], table["plant.zeta[1]"]["high"]) == pytest.approx((0.4 * np.pi, 0.005))
    assert sc.metrics[0].max == pytest.approx(cert * np.sqrt(2), rel=1e-15)
    assert demeter_loops.scenario(ART, start="theta").metrics[0].max == pytest.approx(cert, rel=1e-15)
    assert sc.fmus["plant"].parameters["theta_0[1]"] == THETA_WORST
    # every metric a gate: theta ends within the worst initial error, the wheels below satW, never at it
    assert [(m.name, m.max) for m in sc.metrics[1:]] == [("|theta| at the end", THETA_WORST),
                                                          ("peak wheel momentum", 0.12),
                                                          ("time at the momentum limit", 0.0)]
    assert (sc.name, demeter_loops.scenario(ART, start="rate", limits="linear").name) == ("demeter_row1_det_both",
                                                                              "demeter_row1_det_rate_linear")
    assert sc.campaign == {"samples": 100, "demo_samples": 10, "seed": 0}  # the seed's 100 loops
    with pytest.raises(ValueError, match="start must be one of theta, rate, both"):
        demeter_loops.scenario(ART, start="omega")
    assert [demeter_loops.uniform_points(n, 2001) for n in (60001, 5001, 7, 2)] == [2001, 1251, 7, 2]


def test_wheel_limits_change_the_loop(loops) -> None:
    lin, sat = loops["linear"], loops["wheels"]
    # the first command (-0.134 N m) is 27 times the torque limit: the body turns slower and the
    # pseudo-integrator, which integrates the command, winds up (measured peak |xw| 0.63 vs 0.045
    # N m s over 20 s); the momentum limit (0.12 N m s) is not reached
    assert np.abs(sat.z2).max() > 5 * np.abs(lin.z2).max()
    assert sat.saturated.max() == 0.0
    assert np.abs(sat.theta - lin.theta).max() > 1e-4


def test_design_model_loops_converge_and_plots_are_written(tmp_path: Path) -> None:
    ref = demeter_loops.linear(ART, n=3, seed=0, stop_time=10000.0, points=2001)
    # slowest closed-loop pole -3e-4 1/s: |theta| 0.262 -> below 4e-3 rad after 1e4 s (measured 3.6e-3)
    assert np.abs(ref.theta[:, -1]).max() < 4e-3 and np.abs(ref.theta[:, 0] - THETA_WORST).max() < 1e-12
    paths = demeter_loops.plot(ref, tmp_path)
    assert [p.name for p in paths] == ["fig4_design_model.png", "fig5_design_model.png"]
    assert all(p.stat().st_size > 10_000 for p in paths)


def test_bad_inputs(fmu_dir: Path) -> None:
    with pytest.raises(ValueError, match="limits"):
        demeter_loops.run(fmu_dir, ART, limits="none")
    with pytest.raises(ValueError, match="not a DEMETER"):
        demeter_loops.linear(polynomial.ARTIFACTS / "mrp_hinf_published.json")


SHIPPED = {start: f"demeter_row1_det_{start}" for start in demeter_loops.STARTS}
"""The shipped scenario of each start (sims/scenario/shipped/)."""


@pytest.mark.parametrize("start", list(SHIPPED))
def test_a_shipped_scenario_is_the_scenario_of_the_row1_design(start: str) -> None:
    """One source of truth: the shipped file is what `python -m satfmu.sims.workflows.demeter_loops` writes from
    dl.scenario(), text for text, and reads back as the same scenario."""
    path = SHIPPED_SCENARIOS / f"{SHIPPED[start]}.toml"
    assert path.read_text() == demeter_loops.scenario_text(start), \
        "regenerate it: python -m satfmu.sims.workflows.demeter_loops"
    assert load(SHIPPED[start]).to_dict() == demeter_loops.scenario("demeter_row1_det", start=start).to_dict()
    assert load(SHIPPED[start]).to_dict() == demeter_loops.shipped_scenario(start).to_dict()


def test_write_shipped_writes_one_file_per_start(tmp_path: Path) -> None:
    written = demeter_loops.write_shipped(tmp_path)
    assert sorted(p.name for p in written) == sorted(f"{name}.toml" for name in SHIPPED.values())
    assert all(p.read_text() == (SHIPPED_SCENARIOS / p.name).read_text() for p in written)


def test_satfmu_run_passes_the_metrics_of_the_shipped_scenarios(fmu_dir: Path, tmp_path: Path) -> None:
    """The nominal plant, 60 s at 1 ms (0.2 s of simulation each). Measured: peak |xw| 1.2205,
    0.02363, 0.3750 N m s (bounds 3.628, 2.566, 2.566: the certified i2p bound times |w2|);
    |theta(60 s)| 0.2367, 0.2395, 0.00411 rad (gate 0.262); peak |h_w| 0.0641, 0.0126, 0.0458 N m s
    (limit 0.12); never at the momentum limit."""
    assert main(["run", *SHIPPED.values(), "--fmu-dir", str(fmu_dir), "--out", str(tmp_path)]) == 0
    measured = {"both": (1.2205, 0.2367, 0.0641), "theta": (0.02363, 0.2395, 0.01264),
                "rate": (0.3750, 0.004110, 0.04577)}
    for start, name in SHIPPED.items():
        summary = json.loads((tmp_path / name / "summary_native.json").read_text())
        values = {m["name"]: m["value"] for m in summary["metrics"]}
        assert summary["passed"] and summary["warnings"] == []  # the design's own plant: no mismatch
        got = (values["peak |z2| = |xw|"], values["|theta| at the end"], values["peak wheel momentum"])
        # 1e-3 relative: the figures above are rounded to 4 digits
        assert got == pytest.approx(measured[start], rel=1e-3), start
        assert values["time at the momentum limit"] == 0.0
