"""Seed 000 Theorem 1 by SOS: certified designs that stabilize the FMU plant model."""
from __future__ import annotations

import numpy as np
import pytest

from satfmu.controllers import artifact, polynomial
from satfmu.fmus.plants import mrp_satellite
from satfmu.fmus import reference
from satfmu.synthesis.polynomial_feedback.hinf_sos import artifact_data, theorem1
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


@pytest.mark.parametrize("kwargs,message", [
    ({"region": 1.2}, "region radius"), ({"region": float("nan")}, "region radius"),
    ({"region": 0.9, "decay_rate": -1.0}, "decay rate"), ({"coefficient_limit": 0.0}, "coefficient limit"),
    ({"q_min": -1.0}, "q_min"), ({"k_degree": 1.5}, "k_degree"),
    ({"region": 0.9, "strict_margin": 0.0}, "strict margin"),
    ({"coefficient_bounds": {(3, 0): (None, -1.0)}}, r"K\[3\]\[0\]"),
])
def test_bad_arguments_are_refused_before_a_program_is_built(kwargs: dict, message: str, monkeypatch) -> None:
    def no_program(*args, **kw):
        raise AssertionError("a program was built before the arguments were checked")

    monkeypatch.setattr("satfmu.synthesis.polynomial_feedback.hinf_sos.SOSProgram", no_program)
    with pytest.raises(ValueError, match=message):
        theorem1(**kwargs)


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
