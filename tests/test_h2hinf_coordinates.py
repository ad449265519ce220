"""Seed 001's Theorem 8 in balanced units: the congruence is exact, the certificate is checked in
the user's units, and the screen at the origin refuses early with the gamma that would work.

Spacecraft: seed 000's (15/16/12.5 kg m^2), a 100/120/80 kg m^2 bus with products of inertia and
a 3U cubesat (0.01/0.05/0.05 kg m^2).
"""
from __future__ import annotations

import numpy as np
import pytest

from satfmu.fmus.plants import mrp_satellite
from satfmu.fmus.plants.spacecraft import SEED_000, Spacecraft
from satfmu.synthesis.core.sos import SOSError, SOSProgram
from satfmu.synthesis.core.polynomial import Poly
from satfmu.synthesis.polynomial_feedback import h2hinf_search, h2hinf_sos, split_plant
from satfmu.synthesis.polynomial_feedback.coordinates import Coordinates

BUS = Spacecraft("bus", [[100.0, 2.0, -1.0], [2.0, 120.0, 0.5], [-1.0, 0.5, 80.0]])
CUBESAT = Spacecraft("cubesat", [0.01, 0.05, 0.05])


def _plant(sc: Spacecraft, frozen: bool = False) -> split_plant.SplitPlant:
    return split_plant.split(mrp_satellite.build(sc), frozen)


@pytest.mark.parametrize("sc, rate", [(SEED_000, 0.5266), (BUS, 0.2014), (CUBESAT, 11.696)])
def test_balanced_rate_follows_the_plant(sc, rate):
    # the rate unit balances the LQR Lyapunov matrix: slow for the heavy bus, fast for the cubesat
    # (4 digits: the values the bench table and the docs quote)
    plant = _plant(sc, frozen=True)
    c = Coordinates.balanced(plant, np.eye(6), np.eye(3), 0.3, 0.3)
    assert c.rate == pytest.approx(rate, rel=1e-3)
    # time = sqrt(alpha beta) / 0.3 = 1 s, clipped to [0.1, 1] / rate
    assert c.time == pytest.approx(float(np.clip(1.0, 0.1 / c.rate, 1.0 / c.rate)), rel=1e-12)
    assert c.torque == pytest.approx(1 / np.sqrt(c.time), rel=1e-12)


def test_every_condition_maps_exactly_onto_the_user_units():
    # for any decision values (not only a solution), the user-unit constraint polynomial equals the
    # scaled one at v' = D v: p_u(x, v) = p_s(x, D v). Random y, random points: equal to round-off
    plant = _plant(BUS)
    coords = Coordinates(0.4, 0.2, 3.0)
    kw = dict(variant="slack", region=0.45, y_degree=1, multiplier_degree=0, frozen=False)
    Qh, Rh, x0, e = np.eye(6), np.eye(3), h2hinf_sos.X0_90, 1e-6
    Qs, Rs = coords.weights(plant, Qh, Rh)
    m2 = e * np.concatenate([np.ones(6), np.full(6, coords.scalar(0.3)), np.ones(9)])
    minf = e * np.concatenate([np.ones(6), np.full(6, coords.scalar(0.2)), np.ones(6)])
    scaled = h2hinf_sos._program(coords.plant(plant), coords.gamma(0.7), coords.scalar(0.3), coords.scalar(0.2),
                                 Qs, Rs, coords.state(plant, x0), (m2, minf, np.full(6, e)), np.ones(21),
                                 np.ones(18), **kw)
    d2, dinf = coords.h2_rows(plant), coords.hinf_rows(plant)
    t = coords.states(plant)
    user = h2hinf_sos._program(plant, 0.7, 0.3, 0.2, Qh, Rh, x0, (d2**2 * m2, dinf**2 * minf, t**2 * e), d2**2,
                               dinf**2, **kw)
    rng = np.random.default_rng(0)
    y = rng.normal(size=scaled.prog.n_decision)
    grams = {f"{k}:{c.name}": np.eye(len(c.basis)) for k, c in enumerate(scaled.prog.sos)}
    from satfmu.synthesis.core.sos import SOSSolution
    mapped = h2hinf_sos._in_user_units(scaled, user, SOSSolution(y, grams, "optimal", "test", 0.0), coords, plant,
                                       (d2, dinf))
    for cs, cu in zip(scaled.prog.sos, user.prog.sos):
        nx = scaled.prog.n_vars
        pts = rng.uniform(-0.5, 0.5, size=(50, cs.poly.n_vars))
        ps, pu = cs.poly.value(y), cu.poly.value(mapped.y)
        if cs.poly.n_vars > nx:  # SOS matrix in (x, v)
            d = d2 if cs.name == "-M_H2" else dinf
            scaled_pts = np.hstack([pts[:, :nx], pts[:, nx:] * d])
        else:
            scaled_pts = pts
        expected = ps.evaluate(scaled_pts)
        assert np.allclose(pu.evaluate(pts), expected, rtol=1e-9, atol=1e-9 * np.abs(expected).max()), cs.name


def test_frozen_design_is_the_same_in_any_units_where_both_solve():
    # seed 000's satellite solves accurately in SI units too: the congruence is exact, so lambda
    # agrees up to the solver's accuracy and the margin 1e-6 (mapped to other user-unit margins)
    own = h2hinf_sos.theorem8(0.7, 0.3, 0.2, frozen=True, coordinates=Coordinates.identity())
    balanced = h2hinf_sos.theorem8(0.7, 0.3, 0.2, frozen=True)
    assert own.certified and balanced.certified
    assert balanced.coordinates != Coordinates.identity()
    assert balanced.lam == pytest.approx(own.lam, rel=1e-4)


def test_frozen_bus_is_accurate_in_balanced_units():
    # measured: in SI units the bus's frozen LMIs end with Gram eigenvalues -1.3e-7 (not certified)
    # and lambda 5.1867; balanced, residuals ~1e-13 and lambda 5.1707 (the optimum: scaling the
    # rates by 0.3 or time by 3 by hand gives 5.1710 and 5.1740)
    model = mrp_satellite.build(BUS)
    own = h2hinf_sos.theorem8(0.7, 0.3, 0.2, frozen=True, model=model, coordinates=Coordinates.identity())
    balanced = h2hinf_sos.theorem8(0.7, 0.3, 0.2, frozen=True, model=model)
    assert balanced.certified and max(c.residual for c in balanced.checks) < 1e-10
    assert balanced.lam <= own.lam * (1 + 1e-9)
    assert balanced.lam == pytest.approx(5.1707, rel=1e-4)


@pytest.mark.slow
def test_heavy_bus_certifies_in_balanced_units_only():
    # measured: in SI units Clarabel ends optimal_inaccurate with residuals ~5e-6 (not certified,
    # lambda 16.5); in balanced units optimal, residuals < 1e-9, lambda 9.53
    model = mrp_satellite.build(BUS)
    r = h2hinf_sos.theorem8(0.7, 0.3, 0.2, model=model)
    assert r.certified and r.solution.status.startswith("optimal")
    assert max(c.residual for c in r.checks) < 1e-8
    assert r.lam == pytest.approx(9.5315, rel=1e-3)
    assert h2hinf_sos.closed_loop_check(r, model=model).passed


def test_screen_refuses_a_gamma_the_linearization_cannot_reach():
    # the cubesat's disturbance enters through J^-1 = 100 1/(kg m^2): the frozen LMIs need gamma
    # well above 1e-3; the screen says so without an SOS solve
    model = mrp_satellite.build(CUBESAT)
    found = h2hinf_search.search(1e-3, model=model)
    assert found.best is None and found.evaluations == []
    s = found.screen
    assert s is not None and not s.feasible and s.gamma_floor is not None and s.gamma_floor > 1e-3
    reason = found.reason()
    assert f"Choose gamma >= {s.gamma_floor:.4g}" in reason and "region cannot help" in reason
    assert "larger region" not in reason
    # the floor is right: feasible just above it at its alpha, infeasible a factor 1.2 below
    assert h2hinf_search._frozen_lam(s.gamma_floor, s.floor_alpha, "slack", {"model": model}) < np.inf
    assert h2hinf_search._frozen_lam(s.gamma_floor / 1.2, s.floor_alpha, "slack", {"model": model}) == np.inf


def test_default_bounds_follow_the_plant_time_scale():
    lo, hi = h2hinf_search.default_bounds()
    assert (lo, hi) == pytest.approx((0.01 / 0.5266, 1 / 0.5266), rel=1e-3)
    lo_c, hi_c = h2hinf_search.default_bounds(mrp_satellite.build(CUBESAT))
    assert hi_c == pytest.approx(1 / 11.696, rel=1e-3) and lo_c == pytest.approx(hi_c / 100)


def test_coordinates_and_weights_are_checked():
    with pytest.raises(ValueError, match="time"):
        Coordinates(0.0, 1.0, 1.0)
    with pytest.raises(ValueError, match="torque"):
        Coordinates(1.0, 1.0, float("nan"))
    prog = SOSProgram(1)
    p = prog.new_poly(np.array([[0]]))
    M = h2hinf_sos.PolyMatrix([[p, p], [p, p]])
    region = [Poly.constant(1.0, 1)]
    with pytest.raises(SOSError, match="multiplier_weights"):
        prog.add_sos_matrix(M, "m", region=region, multiplier_degree=0, multiplier_weights=[1.0, -1.0])
    with pytest.raises(SOSError, match="multiplier_weights"):
        prog.add_sos_matrix(M, "m", region=region, multiplier_degree=0, multiplier_weights=[1.0])
