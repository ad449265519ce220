"""Linearization from exact Jacobians, and the linear margins of the shipped MRP controllers."""
from __future__ import annotations

import math

import control
import numpy as np
import pytest

import satfmu
from satfmu.controllers import artifact as artifacts
from satfmu.controllers import polynomial
from satfmu.fmus.linearization import linearize
from satfmu.fmus.plants import mrp_satellite
from satfmu.synthesis.core import margins as loop_margins
from satfmu.sims.scenario import loops
from satfmu.sims.scenario.spec import load

CONTROLLERS = ("mrp_hinf_published", "mrp_hinf_satfmu", "mrp_h2hinf_satfmu")


def _loop(name: str) -> tuple:
    path = polynomial.ARTIFACTS / f"{name}.json"
    art = artifacts.load(path)
    K = linearize(polynomial.load_model(path))
    P = linearize(mrp_satellite.MODEL, parameters=art.provenance["design_plant"]["parameters"], inputs=K.outputs,
                  outputs=K.inputs)
    return P, K


def test_the_mrp_plant_linearizes_to_its_textbook_form() -> None:
    # at rest: omega' = J^-1 u, sigma' = omega / 4 (the MRP kinematics at sigma = 0)
    J = {"I_x": 15.0, "I_y": 16.0, "I_z": 12.5}
    lin = linearize(mrp_satellite.MODEL, parameters=J, inputs=["u[1]", "u[2]", "u[3]"],
                    outputs=[f"{v}[{i}]" for v in ("omega", "sigma") for i in (1, 2, 3)])
    A = np.zeros((6, 6))
    A[3:, :3] = np.eye(3) / 4
    B = np.vstack([np.diag([1 / 15.0, 1 / 16.0, 1 / 12.5]), np.zeros((3, 3))])
    assert np.array_equal(lin.A, A) and np.allclose(lin.B, B, rtol=1e-15, atol=0)
    assert np.array_equal(lin.C, np.eye(6)) and not lin.D.any()
    # spinning about z: the gyroscopic coupling (J_y - J_z) w_z / J_x in d(omega_x)/d(omega_y), exactly
    spin = linearize(mrp_satellite.MODEL, x0={"omega[3]": 0.1}, parameters=J, outputs=["omega[1]"])
    assert spin.A[0, 1] == pytest.approx((16.0 - 12.5) * 0.1 / 15.0, rel=1e-14)  # J w' = -w x J w
    with pytest.raises(ValueError, match="no state named 'omega\\[4\\]'"):
        linearize(mrp_satellite.MODEL, x0={"omega[4]": 1.0})
    with pytest.raises(ValueError, match="C is not finite"):  # phi = 4 atan|sigma| has no derivative at 0
        linearize(mrp_satellite.MODEL, outputs=["phi"])


@pytest.mark.parametrize("name", CONTROLLERS)
def test_python_control_margins_agree_with_our_own_sweep(name: str) -> None:
    P, K = _loop(name)
    for step in (0.0, 0.05):
        m = loop_margins.margins(P, K, step)
        assert m.closed_loop_stable
        omega = np.logspace(-4, math.log10(0.999 * math.pi / step) if step else 3, 40_000)
        for (_, L_i), loop in zip(loop_margins.channel_responses(P, K, omega, step), m.loops):
            gm, pm = loop_margins.sweep_margins(L_i, omega)
            # the same response, crossovers found by two codes on two grids: within 0.05 deg (the
            # interpolation of a 40,000-point and an 8,000-point log grid; measured < 1e-6 deg)
            assert loop.phase_margin_deg == pytest.approx(pm, abs=0.05)
            assert gm == math.inf and loop.gain_margin_db == math.inf  # no phase crossover: PD-like loops
            assert loop.delay_margin == pytest.approx(math.radians(loop.phase_margin_deg) / loop.gain_crossover)
        # a disk margin holds for every channel at once: no loop-at-a-time margin can be below it
        assert all(loop.phase_margin_deg >= m.disk_phase_margin_deg - 1e-9 for loop in m.loops)


def test_the_hold_costs_the_phase_of_half_a_step() -> None:
    # a zero-order hold delays by T/2 on average: the sampled loop loses w_c T / 2 of phase (to first order)
    P, K = _loop("mrp_h2hinf_satfmu")
    cont, samp = loop_margins.margins(P, K), loop_margins.margins(P, K, 0.05)
    for c, s in zip(cont.loops, samp.loops):
        assert c.phase_margin_deg - s.phase_margin_deg == pytest.approx(math.degrees(c.gain_crossover * 0.025),
                                                                        rel=0.05)


def test_margins_of_a_shipped_controller_and_what_has_none() -> None:
    result = satfmu.margins("mrp_hinf_published")
    assert result.plant == "mrp_satellite" and result.sample_time == 0.05
    # published seed 000 controller: measured 40.8-41.4 deg, disk 6.38 dB / 38.75 deg at the input
    assert [round(loop.phase_margin_deg, 1) for loop in result.continuous.loops] == [40.8, 41.4, 41.3]
    assert result.continuous.disk_phase_margin_deg == pytest.approx(38.75, abs=0.05)
    assert "phase margin 40.81 deg" in result.text()
    with pytest.raises(ValueError, match="sampled law"):
        satfmu.margins("cubesat_periodic_satfmu")
    with pytest.raises(ValueError, match="sample_time"):
        satfmu.margins("mrp_hinf_published", sample_time=0.0)


def test_the_loop_of_a_channel_closes_the_others() -> None:
    # two decoupled channels: channel 1's loop is its own, whatever channel 2 does
    G = control.ss(np.diag([-1.0, -2.0]), np.eye(2), np.eye(2), np.zeros((2, 2)))  # G = K P
    L1 = loop_margins.channel_response(loop_margins.response(G, np.array([0.3])), 0)
    assert complex(L1[0]) == pytest.approx(-1 / (1j * 0.3 + 1), rel=1e-12)
    # three coupled channels at one frequency: channel 2 broken, 1 and 3 closed, by hand (2 x 2 inverse)
    rng = np.random.default_rng(4)
    g = rng.normal(size=(3, 3)) + 1j * rng.normal(size=(3, 3))
    a, b, c, d = 1 - g[0, 0], -g[0, 2], -g[2, 0], 1 - g[2, 2]
    inv = np.array([[d, -b], [-c, a]]) / (a * d - b * c)  # (I - G_oo)^-1, G_oo the channels 1 and 3
    by_hand = -(g[1, 1] + np.array([g[1, 0], g[1, 2]]) @ inv @ np.array([g[0, 1], g[2, 1]]))
    assert complex(loop_margins.channel_response(g[:, :, None], 1)[0]) == pytest.approx(by_hand, rel=1e-12)


def test_the_four_wheel_loop_crosses_twice_and_its_margins_say_so() -> None:
    """The published law on the four-wheel plant at rest, axis 3 broken: the wheels' bias momentum
    leaves a zero at the origin, so |L| rises through 0 dB near 1.2e-4 rad/s with the phase at
    +90 deg, peaks at the gyroscopic mode (5.8e-4 rad/s) and falls through 0 dB at 2.6e-3 rad/s at
    -90 deg. Each crossover tolerates 90 deg of phase either way; a delay only lags, and the lag
    that reaches -1 is 90 deg at 2.6e-3 rad/s (a 600 s delay margin) but 270 deg at the first.
    Continuous and sampled agree (the sampled loop's minimal realization once dropped the first
    crossover; the continuous one's was read as a -90 deg phase margin)."""
    sc = load("rw4_slew_published")
    loop, = loops.find_loops(sc)[0]
    P, K = loops.linearize_loop(sc, loop, "origin")
    omega = np.logspace(-6, math.log10(0.999 * math.pi / sc.step_size), 40_000)
    for step in (0.0, sc.step_size):
        m = loop_margins.margins(P, K, step)
        assert m.closed_loop_stable
        (_, L3), = [c for c in loop_margins.channel_responses(P, K, omega, step) if c[0] == "u[3]"]
        mag, phase = np.abs(L3), np.degrees(np.angle(L3))
        ups = np.flatnonzero((mag[:-1] < 1) & (mag[1:] >= 1))
        downs = np.flatnonzero((mag[:-1] >= 1) & (mag[1:] < 1))
        assert len(ups) == len(downs) == 1
        # measured: up at 1.238e-4 rad/s, +89.5 deg; down at 2.634e-3 rad/s, -89.5 deg (1 % and 1 deg:
        # the grid's spacing, 0.03 %, and a hold's phase, w T / 2 < 0.004 deg, are far below)
        assert omega[ups[0]] == pytest.approx(1.238e-4, rel=0.01) and phase[ups[0]] == pytest.approx(90.0, abs=1.0)
        assert omega[downs[0]] == pytest.approx(2.634e-3, rel=0.01) and phase[downs[0]] == pytest.approx(-90.0, abs=1.0)
        lm = m.loops[2]
        assert lm.phase_margin_deg == pytest.approx(loop_margins.sweep_margins(L3, omega)[1], abs=0.05)
        assert 89.0 < lm.phase_margin_deg < 91.0
        # the delay margin is the 90 deg of lag at 2.5e-3 rad/s, not the 270 deg at 1.4e-4 rad/s
        lag = (phase[downs[0]] + 180.0) % 360.0
        assert lm.delay_margin == pytest.approx(math.radians(lag) / omega[downs[0]], rel=0.02)
