"""Seed 001 Theorem 8 on the nonlinear MRP satellite: |sigma| <= 0.45, every rate.

Measured (one solve each, Clarabel, in the balanced units of
:mod:`satfmu.synthesis.polynomial_feedback.coordinates`): at gamma = 1, alpha = beta = 0.3 the
slack design certifies lambda = 3.521 and the common-Lyapunov one 3.689 (x0: 90 deg rest-to-rest;
in SI units the solver stopped at 3.610 and 3.771); the trajectory never leaves the region.
"""
from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from satfmu.controllers import artifact as artifacts
from satfmu.fmus.plants import mrp_satellite
from satfmu.synthesis.polynomial_feedback import h2hinf_search, h2hinf_sos, split_plant
from satfmu.synthesis.core.sos import SOSError

A_B = 0.3  # near the line search's optimum at gamma = 1


@pytest.fixture(scope="module")
def designs() -> dict[str, h2hinf_sos.Theorem8Result]:
    return {v: h2hinf_sos.theorem8(1.0, A_B, A_B, v) for v in h2hinf_sos.VARIANTS}


def _lam(gamma: float, variant: str) -> float:
    try:
        r = h2hinf_sos.theorem8(gamma, A_B, A_B, variant)
    except SOSError:
        return float("inf")
    return r.lam if r.certified else float("inf")


@pytest.mark.slow
def test_three_gammas_certified_monotone_and_slack_no_worse(designs) -> None:
    # at fixed alpha, beta the feasible set grows with gamma and contains the common variant's
    lam = {(1.0, v): designs[v].lam for v in h2hinf_sos.VARIANTS}
    lam.update({(g, v): _lam(g, v) for g in (0.8, 0.7) for v in h2hinf_sos.VARIANTS})
    slack = [lam[(g, "slack")] for g in (0.7, 0.8, 1.0)]
    assert all(np.isfinite(slack))
    assert all(b <= a * (1 + 1e-6) for a, b in zip(slack, slack[1:]))  # solver accuracy ~1e-8
    for g in (0.7, 0.8, 1.0):
        if np.isfinite(lam[(g, "common")]):
            assert lam[(g, "slack")] <= lam[(g, "common")] * (1 + 1e-6)


@pytest.mark.slow
def test_both_variants_are_certified_and_slack_is_no_worse(designs) -> None:
    for r in designs.values():
        assert r.certified, [(c.name, c.min_eig, c.residual) for c in r.checks]
        assert r.region == "|sigma| <= 0.45, any omega"
    # the seed's claim, measured: 3.521 vs 3.689; the solver's relative accuracy is ~1e-8
    assert designs["slack"].lam <= designs["common"].lam * (1 + 1e-6)
    assert designs["slack"].lam == pytest.approx(3.521, rel=2e-3)  # solver-version drift


@pytest.mark.slow
def test_h2_bound_holds_in_simulation_and_linearization_is_stable(designs) -> None:
    r = designs["slack"]
    c = h2hinf_sos.closed_loop_check(r)
    assert c.passed
    # the certificate applies along the trajectory only if it stays in |sigma| <= 0.45;
    # it starts at 0.4142 (90 deg) and must not go further out
    assert c.max_tilde == pytest.approx(np.tan(np.pi / 8), abs=1e-9)
    assert c.j2 < r.lam and c.tail < 1e-6  # 300 s: the rest of the cost is negligible
    assert c.max_real_eig < 0


@pytest.mark.slow
def test_law_cancels_the_gyroscopic_torque_and_matches_its_artifact(designs) -> None:
    r = designs["slack"]
    w = np.array([0.05, -0.03, 0.02])
    u_plus = np.array(r.law().subs(dict(zip(r.plant.symbols, [*w, 0, 0, 0]))), float).ravel()
    u_minus = np.array(r.law().subs(dict(zip(r.plant.symbols, [*-w, 0, 0, 0]))), float).ravel()
    inertia = np.diag(mrp_satellite.INERTIA_SEED_000)
    # at sigma = 0 the law is linear in x plus omega x I omega: the even part is the latter
    assert np.allclose((u_plus + u_minus) / 2, np.cross(w, inertia @ w), rtol=1e-12, atol=1e-15)
    art = artifacts.parse(h2hinf_sos.artifact_data(r, "mrp_h2hinf_test", h2hinf_sos.closed_loop_check(r,
                                                                                                      stop_time=50.0)))
    x = np.random.default_rng(1).uniform(-0.4, 0.4, size=(20, 6))
    law = sp.lambdify([r.plant.symbols], list(r.law()), "numpy")
    assert np.allclose(art.evaluate(x), np.array([law(xi) for xi in x]), rtol=1e-12, atol=1e-14)
    assert art.certificate["status"] == "certified"
    assert art.certificate["region"] == r.region


def test_split_plant_cancels_the_actuated_rows() -> None:
    p = split_plant.split(mrp_satellite.MODEL, frozen=False)
    assert p.tilde == (3, 4, 5) and p.actuated == (0, 1, 2)
    A = p.A_tilde.evaluate(np.array([0.3, -0.2, 0.1]))
    assert np.all(A[:3] == 0)  # rate rows fully cancelled
    s = sp.Matrix(p.symbols[3:])
    B = mrp_satellite.mrp_kinematics_matrix(s) / 4
    expected = np.array(B.subs(dict(zip(p.symbols[3:], [0.3, -0.2, 0.1]))), float)
    assert np.allclose(A[3:, :3], expected, atol=1e-14)


@pytest.mark.slow
def test_region_beyond_one_is_never_certified() -> None:
    # constant Lyapunov matrices cannot hold past |sigma| = 1 (module notes: the sigma-sigma
    # block of the projected condition is G(sigma) X_ws + (.)^T whatever F and Y are)
    try:
        r = h2hinf_sos.theorem8(1.0, A_B, A_B, "slack", region=1.05)
    except SOSError:
        return
    assert not r.certified


def test_model_without_sdc_form_is_refused() -> None:
    import copy

    model = copy.copy(mrp_satellite.MODEL)
    object.__setattr__(model, "sdc", None)
    with pytest.raises(ValueError, match="SDC"):
        h2hinf_sos.theorem8(1.0, A_B, A_B, model=model)


@pytest.mark.slow
def test_frozen_search_and_sweep_are_consistent(tmp_path) -> None:
    # frozen LMIs solve in ~0.1 s: the line search and sweep logic on a cheap program
    kw = {"frozen": True, "y_degree": 0, "margin": 1e-7, "x0": h2hinf_sos.X0_200}
    found = h2hinf_search.search(0.8, "slack", bounds=(1e-4, 1e-1), max_evaluations=4, **kw)
    assert found.best is not None and len(found.evaluations) <= 8
    assert found.best.lam == min(e[2] for e in found.evaluations)
    rows = h2hinf_search.sweep([1.0, 0.6], bounds=(1e-4, 1e-1), max_evaluations=3, **kw)
    lam = {(r.gamma, r.variant): r.lam for r in rows}
    assert lam[(0.6, "slack")] >= lam[(1.0, "slack")] * (1 - 1e-6)  # non-increasing in gamma
    assert all(lam[(g, "slack")] <= lam[(g, "common")] * (1 + 1e-6) for g in (1.0, 0.6))
    csv_text = h2hinf_search.sweep_csv(rows)
    assert csv_text.splitlines()[0] == "gamma,variant,lambda,alpha,beta,sdps" and len(csv_text.splitlines()) == 5
    from satfmu.sims.scenario import plots

    plots.tradeoff(rows, tmp_path / "t.png", "test")
    assert (tmp_path / "t.png").stat().st_size > 1000
    with pytest.raises(ValueError, match="gammas"):
        h2hinf_search.sweep([0.0])
    with pytest.raises(ValueError, match="bounds"):
        h2hinf_search.search(1.0, bounds=(1.0, 0.1))
