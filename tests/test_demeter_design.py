"""Seed 004 deterministic design on the DEMETER design model: nominal, Table 1 row 1, the infeasible row 3."""
from __future__ import annotations

import cvxpy as cp
import numpy as np
import pytest
from scipy.linalg import null_space

from satfmu.controllers import artifact as artifacts
from satfmu.controllers import polynomial, state_feedback
from satfmu.synthesis.robust import demeter_design
from satfmu.synthesis.robust import demeter_variants
from satfmu.synthesis.robust.lft_plant import LFTPlant
from satfmu.synthesis.robust.pdlf import PDLF_BISECTION_TOL
from satfmu.synthesis.robust.robust_design import design, certify
from satfmu.synthesis.core.system_norms import hinf_norm, impulse_to_peak

ROW1 = demeter_variants.Variant((1,), (1,), 1, 1)


def nominal_plant(dm: demeter_variants.DesignModel, T: np.ndarray) -> LFTPlant:
    P = demeter_design.scaled_lft(dm, T)
    return LFTPlant.without_uncertainty(A=P.A, Bu=P.Bu, B1=P.B1, B2=P.B2, C1=P.C1, D1u=P.D1u, D11=P.D11, C2=P.C2)


def test_shared_lyapunov_matrix_bounds_the_product_of_the_two_levels() -> None:
    # With our wiring (w1 a body torque, z1 = theta, z2 the pseudo-integrator xw) one Lyapunov
    # matrix for both specs gives gamma * nu = 1 / (2 a) = 500 at the optimum for both weightings
    # (docs/models.md's independent model measured gamma 223.6 for the seed's weights): far from the
    # seed's 22.3 * 4.7, so the seed wires or scales w1/z2 differently. Nominal row-1 model:
    dm = demeter_variants.design_model(ROW1)
    T = demeter_design.state_scale(dm)
    A, Bu, _ = dm.state_space(np.zeros(3))
    for w_i2p, gamma_ref in ((100.0, 223.6), (1.0, 22.37)):
        des = design(nominal_plant(dm, T), w_hinf=1.0, w_i2p=w_i2p, alpha=demeter_design.ALPHA,
                     beta=demeter_design.BETA)
        assert des.status == "optimal" and des.check.ok
        # 2e-3: the solver's accuracy on this poorly conditioned program plus the 1e-4 back-off
        assert des.gamma * des.nu >= 500.0 * (1 - 2e-3)
        assert abs(des.gamma - gamma_ref) < 2e-3 * gamma_ref
        K = des.K / T
        Acl = A + Bu @ K
        poles = np.linalg.eigvals(Acl).real
        assert poles.max() < -demeter_design.ALPHA and poles.min() > -demeter_design.BETA
        _, _, B1 = dm.state_space(np.zeros(3))
        assert hinf_norm(Acl, B1, dm.C1, np.zeros((1, 1))) <= des.gamma
        assert impulse_to_peak(Acl, dm.B2, dm.C2, 3000.0, 3001) <= des.nu


def test_toolbox_convention_bounds_the_peak_alone() -> None:
    # In the R-RoMulOC toolbox's convention (w1's Gramian with weight 1, squared levels on the z
    # side, objective gamma^2 + 100 nu^2) the shared Lyapunov matrix must exceed the slow
    # momentum mode's Gramian 1 / (2 a) = 500 (w1 at the body torque excites it) and z2 = xw
    # reads it with unit gain: nu^2 >= 500 whatever gamma, i.e. nu = 22.36 N m s, the seed's
    # 22.3-22.7 in every feasible row; gamma is then free to fall to 1.96 (ours: 223.6 at nu 2.24).
    # A certificate of one convention does not hold in the other: gamma nu = 43.9 < 500.
    dm = demeter_variants.design_model(ROW1)
    T = demeter_design.state_scale(dm)
    plant = nominal_plant(dm, T)
    des = design(plant, w_hinf=1.0, w_i2p=100.0, alpha=demeter_design.ALPHA, beta=demeter_design.BETA,
                 convention="romuloc")
    assert des.status == "optimal" and des.check.ok
    # 2e-3: solver accuracy on this poorly conditioned program plus the back-off (1e-4 on nu^2)
    assert des.nu == pytest.approx(np.sqrt(500.0), rel=2e-3)
    assert des.nu**2 >= 500.0 * (1 - 2e-3)
    # measured 1.897 (solved in the satfmu design's coordinates; 1.964 in these): the objective
    # weighs gamma^2 1/100 of nu^2, so the solver's stopping point moves it most
    assert 1.85 < des.gamma < 2.1
    options = {"alpha": demeter_design.ALPHA, "beta": demeter_design.BETA}
    assert not certify(plant, des.K, des.Y, des.gamma, des.nu, {}, convention="satfmu", **options).ok
    A, Bu, B1 = dm.state_space(np.zeros(3))
    Acl = A + Bu @ (des.K / T)
    assert hinf_norm(Acl, B1, dm.C1, np.zeros((1, 1))) <= des.gamma
    assert impulse_to_peak(Acl, dm.B2, dm.C2, 3000.0, 3001) <= des.nu


@pytest.fixture(scope="module")
def row1() -> demeter_design.DeterministicResult:
    return demeter_design.deterministic(ROW1, n_samples=100, seed=0)


@pytest.mark.slow
def test_row1_robust_design_is_verified(row1) -> None:
    des = row1.design
    assert des.status == "optimal" and des.check.ok and row1.obstruction is None
    # measured 256.59 / 2.5655 (objective 513.2, nominal 447.3): the robust price is 15 %.
    # 1e-2: Clarabel's accuracy on the rescaled program and the back-off
    assert des.gamma == pytest.approx(256.6, rel=1e-2) and des.nu == pytest.approx(2.5655, rel=1e-2)
    assert des.state_scaling is not None  # the first coordinates do not verify (documented)
    K = row1.K
    assert K.shape == (1, 8) and np.all(np.isfinite(K))


@pytest.mark.slow
def test_row1_analysis_bounds_the_sampled_loops(row1) -> None:
    ck = row1.check
    assert ck.n == 100 and ck.in_region  # measured Re in [-4.88, -3.2e-4]
    h, hc, i2p = row1.analysis_hinf, row1.analysis_hinf_common, row1.analysis_i2p
    assert h.status == hc.status == i2p.status == "optimal"
    assert h.check.ok and hc.check.ok and i2p.check.ok
    # every bound is above every sampled exact value (measured: 79.67 < 83.3 PDLF < 106.3 common
    # < 256.6 design; i2p 0.058 < 0.199 analysis < 2.57 design)
    assert ck.hinf.max() <= h.gamma <= hc.gamma * (1 + PDLF_BISECTION_TOL) <= row1.design.gamma
    assert ck.i2p.max() <= i2p.nu <= row1.design.nu
    # the parameter-dependent bound is within 10 % of the worst sampled norm (measured 4.5 %)
    assert h.gamma <= 1.1 * ck.hinf.max()


@pytest.mark.slow
def test_row1_design_gains_drive_the_controller_fmu_parameters(row1) -> None:
    dm = demeter_variants.design_model(ROW1)
    gains = dm.fmu_gains(row1.K)
    assert gains["K_theta[1,1]"] == pytest.approx(row1.K[0, 0], rel=1e-15)
    assert gains["K_xi[1,1]"] == pytest.approx(row1.K[0, 4], rel=1e-15)
    assert gains["K_theta[2,2]"] == 0.0  # axes not designed stay open
    data = demeter_design.artifact_data(row1, "demeter_test")  # it says in which convention it was designed
    assert data["design"]["convention"] == "satfmu" and "satfmu's LMI forms" in data["certificate"]["proved"]
    assert artifacts.parse(data).design["convention"] == "satfmu"


ROW3 = demeter_variants.Variant((1,), (1, 2), 1, 1)


def test_row3_coincident_modes_prove_infeasibility() -> None:
    obs = demeter_design.coincident_modes(ROW3)
    assert obs is not None and obs.proves_infeasible and obs.n_free == 1
    assert obs.required_zeta == pytest.approx(1 / np.sqrt(3), rel=1e-12)  # omega 3:1
    assert obs.zeta < obs.required_zeta / 100
    # independent of the closed form: the oscillator pair has no common Lyapunov matrix (LMI)
    Y = cp.Variable((2, 2), symmetric=True)
    A = [demeter_design.oscillator(w, obs.zeta) for w in obs.omega]
    cons = [Y >> np.eye(2)] + [a @ Y + Y @ a.T << -np.eye(2) for a in A]
    prob = cp.Problem(cp.Minimize(0), cons)
    prob.solve(solver=cp.CLARABEL)
    assert prob.status == cp.INFEASIBLE
    # the quotient: at coincident parameters, C A_cl = A_osc C for any gain (C constant)
    dm = demeter_variants.design_model(ROW3)
    N = null_space(dm.L_r)
    assert N.shape == (2, 1)
    C = np.zeros((2, dm.n))
    C[0, 2:2 + dm.nr] = N[:, 0]
    C[1, 2 + dm.nr:2 + 2 * dm.nr] = N[:, 0]
    rng = np.random.default_rng(3)
    names = dm.names
    for _ in range(3):
        d = rng.uniform(-1, 1, len(names))
        d[names.index("omega2")], d[names.index("zeta2")] = d[names.index("omega1")], d[names.index("zeta1")]
        A_, Bu, _ = dm.state_space(d)
        K = rng.normal(size=(1, dm.n)) * 10
        w, z = (dm.parameters[names.index(k)].value(d[names.index(k)]) for k in ("omega1", "zeta1"))
        assert np.allclose(C @ (A_ + Bu @ K), demeter_design.oscillator(w, z) @ C, atol=1e-12 * np.abs(K).max())
    assert demeter_design.coincident_modes(ROW1) is None
    assert demeter_design.coincident_modes(demeter_variants.Variant((1,), (1, 2, 3, 4), 2,
                                                                    1)) is None  # identical: reduced to 1


def test_row3_design_program_does_not_claim_a_design() -> None:
    res = demeter_design.deterministic(ROW3, analysis=False)
    assert res.K is None and res.design.status in ("infeasible", "unverified")
    assert res.obstruction is not None and res.obstruction.proves_infeasible


@pytest.mark.slow
def test_shipped_row1_artifact_is_this_design(row1) -> None:
    art = artifacts.load(polynomial.ARTIFACTS / "demeter_row1_det.json")
    assert isinstance(art, artifacts.GainArtifact) and art.plant == "demeter_flexible"
    assert art.certificate["status"] == "certified"
    nums = art.certificate["numbers"]
    # a fresh design on this machine: the same bounds to the solver's accuracy (1e-2, as above)
    assert nums["design_hinf_bound"] == pytest.approx(row1.design.gamma, rel=1e-2)
    assert nums["design_i2p_bound"] == pytest.approx(row1.design.nu, rel=1e-2)
    # the shipped gains themselves, checked independently on 100 other plants (seed 7)
    dm = demeter_variants.design_model(ROW1)
    K = np.array(art.design["K"])
    assert dm.fmu_gains(K) == art.gains
    ck = demeter_design.sampled_check(dm, K, 100, seed=7)
    assert ck.in_region and ck.hinf.max() <= nums["analysis_hinf_pdlf"] and ck.i2p.max() <= nums["analysis_i2p"]
    # the controller FMU's defaults are the artifact's gains
    model = state_feedback.build(art.gains, name=art.name)
    defaults = {p.name: p.start for p in model.parameters}
    assert all(defaults[k] == v for k, v in art.gains.items())
    with pytest.raises(artifacts.ArtifactError, match="K_block"):
        artifacts.parse({**art.to_json(), "gains": {"gain": 1.0}})
    with pytest.raises(artifacts.ArtifactError, match="finite"):
        artifacts.parse({**art.to_json(), "gains": {"K_theta[1,1]": float("nan")}})


def test_vertex_program_too_large_for_memory_falls_back_to_dg_scalings(monkeypatch) -> None:
    """One axis on intervals: its vertex design program is estimated at 10.1 MB
    (satfmu.synthesis.core.lmi.LMIProgram.solver_bytes). Under a 10 MB limit the design is the D-G
    one, named so, and still verified. The vertex design can only be as good or better (D-G
    scalings are a sufficient condition for the vertex inequality), within the solver's accuracy
    (1e-3 relative); the two bounds differ by 6.4e-3 relative on this box (nu 2.580 against 2.563
    with Clarabel 0.11.1, cvxpy 1.9.3), so they are held within 1 %."""
    from satfmu.synthesis.core import lmi

    v = demeter_variants.Variant((1,), (1,), 1, 2)
    vertex = demeter_design.deterministic(v, n_samples=0, analysis=False)
    assert vertex.uncertainty == "vertex" and vertex.note == ""
    monkeypatch.setattr(lmi, "MAX_SOLVER_BYTES", 10_000_000)
    dg = demeter_design.deterministic(v, n_samples=0, analysis=False)
    assert dg.uncertainty == "norm" and dg.design.status == "optimal" and dg.design.check.ok
    assert "design: D-G scalings, the vertex program is too large" in dg.note and "> max_bytes = 0.01 GB" in dg.note
    assert vertex.design.nu <= dg.design.nu * (1 + 1e-3) and dg.design.nu == pytest.approx(vertex.design.nu, rel=1e-2)
