"""Seed 000 Theorem 1 by SOS: certified designs that stabilize the FMU plant model."""
from __future__ import annotations

import numpy as np
import pytest

from controllers import artifact, polynomial
from fmus import mrp_satellite
from sims import reference
from synthesis.hinf_sos import artifact_data, theorem1
from tests.conftest import SIGMA_200


@pytest.fixture(scope="module")
def global_design():
    return theorem1()


def test_global_design_is_certified_and_says_what_it_proved(global_design) -> None:
    assert global_design.certified
    assert "LaSalle" in global_design.proved and global_design.region == "global"
    assert np.linalg.eigvalsh(global_design.Q).min() >= 1.0 - 1e-6  # Q >= q_min I, solver accuracy


def test_global_design_converges_from_200deg_and_V_decreases(global_design) -> None:
    a = artifact.parse(artifact_data(global_design, "mrp_hinf_satfmu"))
    assert a.certificate["status"] == "certified"
    ctrl = polynomial.build(a)
    res = reference.closed_loop_rk4(mrp_satellite.MODEL, ctrl, 120.0, 0.05, SIGMA_200)
    phi_deg = np.degrees(4 * np.arctan(np.linalg.norm(res.x[:, 3:], axis=1)))
    assert phi_deg[-1] < 0.1  # converged by 120 s, like the published law
    P = np.linalg.inv(global_design.Q)
    V = np.einsum("ti,ij,tj->t", res.x, P, res.x)
    # sampled-data loop (u held 0.05 s): V may rise by O(step^2); allow 1e-6 relative
    assert np.all(np.diff(V) <= 1e-6 * V[0])


def test_regional_strict_design_is_certified_on_its_ball() -> None:
    r = theorem1(region=0.9)
    assert r.certified and r.region == "|sigma| <= 0.9" and "strict" in r.proved


def test_bad_region_is_refused() -> None:
    with pytest.raises(ValueError, match="region radius"):
        theorem1(region=1.2)


def test_decay_rate_and_coefficient_limit_are_honoured() -> None:
    r = theorem1(region=0.9, decay_rate=0.01, coefficient_limit=1.0)
    assert r.certified and "- 0.02 V" in r.proved
    inertia = np.array([15.0, 16.0, 12.5])
    # torque gains are diag(I) K: every K coefficient within the limit (solver feasibility 1e-7)
    assert max(float(np.abs(p.c0).max()) / inertia[i] for i, row in enumerate(r.K) for p in row) <= 1.0 + 1e-7
    # dV/dt <= -2 lambda V on the ball, checked on the nonlinear closed loop at sampled points
    a = artifact.parse(artifact_data(r, "check"))
    P = np.linalg.inv(r.Q)
    rng = np.random.default_rng(1)
    x = rng.normal(size=(2000, 6)) * [0.2, 0.2, 0.2, 0.4, 0.4, 0.4]
    x = x[np.linalg.norm(x[:, 3:], axis=1) <= 0.9]
    f = mrp_satellite.MODEL.lambdify(mrp_satellite.MODEL.rhs)
    p = mrp_satellite.MODEL.parameter_vector()
    for xi in x[:300]:
        u = a.evaluate(xi)
        dx = np.ravel(f(0.0, xi, np.r_[u, 0.0, 0.0, 0.0], p))
        vdot, v = 2 * xi @ P @ dx, xi @ P @ xi
        assert vdot <= -0.02 * v + 1e-9 * v  # rounding of the Gram identity, relative


def test_coefficient_bounds_are_checked() -> None:
    with pytest.raises(ValueError, match=r"K\[3\]\[0\]"):
        theorem1(coefficient_bounds={(3, 0): (None, -1.0)})
    with pytest.raises(ValueError, match="decay rate"):
        theorem1(region=0.9, decay_rate=-1.0)
