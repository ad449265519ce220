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
        L_in, _ = loop_margins.loop_transfers(P, K, step)
        omega = np.logspace(-4, math.log10(0.999 * math.pi / step) if step else 3, 40_000)
        for i, loop in enumerate(m.loops):
            L_i = loop_margins._channel_loop(-L_in, i)
            gm, pm = loop_margins.sweep_margins(loop_margins.response(L_i, omega)[0, 0], omega)
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
    L1 = loop_margins._channel_loop(G, 0)
    assert complex(np.asarray(L1(1j * 0.3)).ravel()[0]) == pytest.approx(-1 / (1j * 0.3 + 1), rel=1e-12)
