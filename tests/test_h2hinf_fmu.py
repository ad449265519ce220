"""The shipped mixed H2/H-infinity controller (seed 001) as an FMU in closed loop.

The artifact (controllers/artifacts/mrp_h2hinf_satfmu.json) certifies, on |sigma| <= 0.45
for every rate, J2 <= lambda from x0 (90 deg rest-to-rest) and an L2 gain w -> sigma below
gamma = 0.7; these tests hold the FMU outputs to those numbers.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from satfmu.controllers import artifact as artifacts
from satfmu.controllers import polynomial
from satfmu.fmus.plants import mrp_satellite
from satfmu.fmus import reference
from satfmu.sims.scenario.result import Result
from satfmu.sims.scenario.run import run

ARTIFACT = artifacts.load(polynomial.ARTIFACTS / "mrp_h2hinf_satfmu.json")
NUMBERS = ARTIFACT.certificate["numbers"]
STATE = [f"plant.omega[{i}]" for i in (1, 2, 3)] + [f"plant.sigma[{i}]" for i in (1, 2, 3)]


@pytest.fixture(scope="module")
def h2_runs(fmu_dir: Path) -> dict[str, Result]:
    return {b: run("mrp_90deg_h2", fmu_dir, backend=b) for b in ("native", "python")}


def _metric(result: Result, prefix: str) -> float:
    return next(m.value for m in result.metrics if m.name.startswith(prefix))


def test_artifact_is_certified_with_its_numbers() -> None:
    cert = ARTIFACT.certificate
    assert cert["status"] == "certified" and cert["region"] == "|sigma| <= 0.45, any omega"
    assert NUMBERS["gamma"] == 0.7
    assert NUMBERS["max real part of eig(Acl(0))"] < 0
    assert NUMBERS["simulated J2 over 300 s"] < cert["h2"]["lambda"]


def test_simulated_h2_cost_is_below_lambda(h2_runs: dict) -> None:
    res = h2_runs["native"]
    j2 = _metric(res, "H2 cost")
    lam = ARTIFACT.certificate["h2"]["lambda"]
    assert j2 < lam
    # the FMU loop holds u over 0.05 s; the artifact's J2 is the continuous-time loop:
    # measured 2.5716 vs 2.5501 (0.85 %), so 2 % leaves room for nothing but the hold
    assert j2 == pytest.approx(NUMBERS["simulated J2 over 300 s"], rel=0.02)
    # the trajectory never leaves the certified region (it starts on its largest |sigma|)
    sig = np.stack([res.results[c] for c in STATE[3:]], axis=1)
    assert np.linalg.norm(sig, axis=1).max() <= 0.45


def test_fmu_loop_matches_reference_and_backends_agree(h2_runs: dict) -> None:
    # DOP853 at rtol 1e-10 of the same sampled-data loop; the FMUs' RK4 (h = 12.5 ms) on this
    # slow loop agrees to ~1e-11 (bound 1e-6, as for the seed 000 loop)
    sigma0 = {f"sigma_0[{i}]": v for i, v in zip((1, 2, 3), ARTIFACT.certificate["h2"]["x0"][3:])}
    ref = reference.closed_loop_solve_ivp(mrp_satellite.MODEL, polynomial.build(ARTIFACT), 300.0, 0.05, sigma0)
    native = np.stack([h2_runs["native"].results[c] for c in STATE], axis=1)
    python = np.stack([h2_runs["python"].results[c] for c in STATE], axis=1)
    assert np.max(np.abs(native - ref.x)) < 1e-6
    assert np.max(np.abs(native - python)) < 1e-12  # same generated expressions, same RK4


def test_eq44_l2_ratio_is_below_gamma_and_state_stays_in_region(fmu_dir: Path) -> None:
    res = run("mrp_eq44_h2hinf", fmu_dir)
    ratio = _metric(res, "mixed H2/Hinf: truncated L2 ratio")
    assert ratio < NUMBERS["gamma"]
    assert ratio == pytest.approx(0.1556, abs=1e-3)  # measured; a drift means the law changed
    sig = np.stack([res.results[c] for c in STATE[3:]], axis=1)
    assert np.linalg.norm(sig, axis=1).max() <= 0.45  # the certificate applies along the run


def test_200deg_outside_the_region_still_converges(fmu_dir: Path) -> None:
    res = run("mrp_200deg_h2hinf", fmu_dir)
    assert res.passed
    phi = np.degrees(res.results["plant.phi"])
    assert phi[0] == pytest.approx(200.0, abs=0.05) and phi[-1] < 0.5
    # monotone decay of the angle (no overshoot past rest, unlike seed 000's controllers)
    assert np.all(np.diff(phi) <= 1e-9)
