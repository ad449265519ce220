"""Seed 004 Figs 4-5 through the FMUs: random closed loops of the DEMETER plant and the row-1 design."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from controllers import polynomial
from sims import demeter_loops as dl
from synthesis.demeter_variants import THETA_WORST

ART = polynomial.ARTIFACTS / "demeter_row1_det.json"


@pytest.fixture(scope="module")
def loops(fmu_dir: Path) -> dict[str, dl.RandomLoops]:
    return {lim: dl.run(fmu_dir, ART, n=2, seed=3, stop_time=5.0, step_size=1e-3, limits=lim)
            for lim in ("linear", "wheels")}


def test_fmu_loops_without_limits_are_the_design_model(loops) -> None:
    lin = loops["linear"]
    assert lin.theta.shape == (2, 5001) and lin.z2.shape == (2, 2, 5001)
    assert lin.theta[:, 0] == pytest.approx(THETA_WORST, rel=1e-12) and lin.saturated.max() == 0.0  # 15 deg
    # the only difference is the command held over 1 ms: 9e-7 rad over 60 s (cli), less over 5 s
    assert lin.linear_error < 1e-6
    # the same plants on the design model, exactly: same start of theta to the hold's accuracy
    ref = dl.linear(ART, n=2, seed=3, stop_time=5.0, points=5001)
    assert np.abs(ref.theta - lin.theta).max() < 1e-6
    assert np.array_equal(ref.deltas, lin.deltas)


def test_wheel_limits_change_the_loop(loops) -> None:
    lin, sat = loops["linear"], loops["wheels"]
    # the first command (-0.134 N m) is 27 times the torque limit: the body turns slower and the
    # pseudo-integrator, which integrates the command, winds up (measured peak |xw| 0.63 vs 0.045
    # N m s over 20 s); the momentum limit (0.12 N m s) is not reached
    assert np.abs(sat.z2).max() > 5 * np.abs(lin.z2).max()
    assert sat.saturated.max() == 0.0
    assert np.abs(sat.theta - lin.theta).max() > 1e-4


def test_design_model_loops_converge_and_plots_are_written(tmp_path: Path) -> None:
    ref = dl.linear(ART, n=3, seed=0, stop_time=10000.0, points=2001)
    # slowest closed-loop pole -3e-4 1/s: |theta| 0.262 -> below 4e-3 rad after 1e4 s (measured 3.6e-3)
    assert np.abs(ref.theta[:, -1]).max() < 4e-3 and np.abs(ref.theta[:, 0] - THETA_WORST).max() < 1e-12
    paths = dl.plot(ref, tmp_path)
    assert [p.name for p in paths] == ["fig4_design_model.png", "fig5_design_model.png"]
    assert all(p.stat().st_size > 10_000 for p in paths)


def test_bad_inputs(fmu_dir: Path) -> None:
    with pytest.raises(ValueError, match="limits"):
        dl.run(fmu_dir, ART, limits="none")
    with pytest.raises(ValueError, match="not a DEMETER"):
        dl.linear(polynomial.ARTIFACTS / "mrp_hinf_published.json")
