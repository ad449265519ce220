"""Flexible DEMETER (seed 004): exact-flow FMUs, variants and their design model, the state feedback."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from fmpy import simulate_fmu
from scipy.integrate import solve_ivp
from scipy.linalg import expm, solve_continuous_are

from satfmu.controllers import state_feedback
from satfmu.fmus.plants import demeter
from satfmu.fmus.model import Model, ModelDefinitionError, Variable, states, symbols
from satfmu.fmus.pyslave import affine_flow
from satfmu.sims.cosim.master import CoSimulation
from satfmu.synthesis.robust import demeter_variants

NOMINAL = (demeter.J0, demeter.L_SUBSTITUTE, np.full(4, demeter.ZETA_NOMINAL), np.full(4, demeter.OMEGA_NOMINAL))
STATE_NAMES = [s.variable.name for s in demeter.MODEL.states]
ROW1 = demeter_variants.Variant((1,), (1,), 1, 1)


@pytest.fixture(scope="module")
def plant(fmu_dir: Path) -> dict[str, Path]:
    return {"native": fmu_dir / "demeter_flexible.fmu", "python": fmu_dir / "demeter_flexible_py.fmu"}


def full_linear_plant(J=demeter.J0, L=demeter.L_SUBSTITUTE, zeta=NOMINAL[2], omega=NOMINAL[3]):
    """Direct 31-state model, inputs (u_c, T_d), wheel limits not reached: eq. (4) + 3 wheels."""
    A0, B0 = demeter.state_space(J, L, zeta, omega)
    n = A0.shape[0]
    Aw, _, _ = demeter.wheel_state_space()
    A = np.zeros((n + 9, n + 9))
    B = np.zeros((n + 9, 6))
    A[:n, :n] = A0
    for i in range(3):
        idx = [n + i, n + 3 + i, n + 6 + i]  # h_w, h_f, h_f_dot of wheel i
        A[np.ix_(idx, idx)] = Aw
        B[idx[0], i] = 1.0
        A[:n, idx[2]] += B0[:, i]
        B[:n, 3 + i] = B0[:, i]
    return A, B


def zoh(A: np.ndarray, B: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
    n, m = B.shape
    E = expm(np.block([[A, B], [np.zeros((m, n + m))]]) * h)
    return E[:n, :n], E[:n, n:]


def input_table(t: np.ndarray, U: np.ndarray) -> np.ndarray:
    names = [f"u_c[{i}]" for i in (1, 2, 3)] + [f"T_d[{i}]" for i in (1, 2, 3)]
    sig = np.zeros(len(t), dtype=[("time", float)] + [(n, float) for n in names])
    sig["time"] = t
    for k, n in enumerate(names):
        sig[n] = U[:, k]
    return sig


def test_affine_flow_is_the_matrix_exponential() -> None:
    # Phi = e^{A tau}, Gamma = int_0^tau e^{As} ds, from the augmented exponential; |A| tau ~ 6
    # forces 4 doublings. 1e-12: Taylor truncation is 1e-22, the doublings' rounding ~1e-15 |Phi|.
    rng = np.random.default_rng(3)
    A = rng.normal(size=(6, 6))
    A -= 2 * np.eye(6)
    tau = 0.9
    phi, gamma = affine_flow(A.tolist(), tau)
    E = expm(np.block([[A, np.eye(6)], [np.zeros((6, 12))]]) * tau)
    assert np.abs(np.array(phi) - E[:6, :6]).max() < 1e-12
    assert np.abs(np.array(gamma) - E[:6, 6:]).max() < 1e-12


def test_exact_integrator_rejects_non_affine_models() -> None:
    x = states("x", 1, "1", "state {i}")
    with pytest.raises(ModelDefinitionError, match="affine"):
        Model("bad", "x' = x^2", x, [], [], [], rhs=symbols(x).applyfunc(lambda v: v**2), integrator="exact")
    with pytest.raises(ModelDefinitionError, match="time"):
        Model("bad", "x' = t", x, [], [], [], rhs=symbols(x) * Model.t, integrator="exact")
    with pytest.raises(ModelDefinitionError, match="switch_time"):
        Model("bad", "rk4 with a switch", x, [], [Variable("k")], [], rhs=-symbols(x), switch_time=Variable("k").symbol)


@pytest.mark.parametrize("backend, step, stop", [("native", 0.5, 120.0), ("python", 2.0, 40.0)])
def test_plant_fmu_equals_the_direct_state_space(plant: dict[str, Path], backend: str, step: float,
                                                  stop: float) -> None:
    # Random piecewise-constant commands and disturbances below the wheel limits, off-nominal
    # parameters; the FMU (Schur route, generated code) against eq. (4) with a full inverse of M,
    # both exact for held inputs. Issue bound 1e-9; the two differ by rounding (~1e-15).
    rng = np.random.default_rng(7)
    J = demeter.J0 * np.diag([1.2, 0.8, 1.1]) + 0.5 * (np.ones((3, 3)) - np.eye(3))
    zeta, omega = rng.uniform(*demeter.ZETA_RANGE, 4), rng.uniform(*demeter.OMEGA_RANGE, 4)
    A, B = full_linear_plant(J, demeter.L_SUBSTITUTE, zeta, omega)
    n_steps = int(round(stop / step))
    U = rng.uniform(-1e-3, 1e-3, (n_steps + 1, 6))
    x = np.zeros(A.shape[0])
    x[0], x[4], x[6] = 0.02, -1e-3, 0.01  # theta[1], theta_dot[2], eta[1]
    Phi, Gam = zoh(A, B, step)
    ref = [x]
    for k in range(n_steps):
        ref.append(Phi @ ref[-1] + Gam @ U[k])
    ref = np.array(ref)
    start = {**demeter.parameter_values(J, demeter.L_SUBSTITUTE, zeta, omega),
             "theta_0[1]": 0.02, "theta_dot_0[2]": -1e-3, "eta_0[1]": 0.01}
    res = simulate_fmu(str(plant[backend]), stop_time=stop, output_interval=step, input=input_table(
        np.arange(n_steps + 1) * step, U), start_values=start, output=STATE_NAMES)
    got = np.column_stack([res[n] for n in STATE_NAMES])
    assert np.abs(got - ref).max() < 1e-9


def run_saturating(fmu: Path, step: float, stop: float = 40.0) -> np.ndarray:
    sig = np.zeros(2, dtype=[("time", float), ("u_c[1]", float)])
    sig["time"] = [0.0, stop]
    sig["u_c[1]"] = 0.004  # below satT: the momentum reaches satW = 0.12 N m s at t = 30 s
    res = simulate_fmu(str(fmu), stop_time=stop, output_interval=step, input=sig, start_values={"theta_0[1]": 0.01},
                       output=STATE_NAMES + ["wheel_saturated[1]"])
    return np.column_stack([res[n] for n in STATE_NAMES + ["wheel_saturated[1]"]])


def test_momentum_saturation_is_exact_for_any_step(plant: dict[str, Path]) -> None:
    # Reference: DOP853 at rtol 1e-12 with the event h_w[1] = 0.12 located, then the wheel held.
    # 1e-9: the integrator's global error at that tolerance (measured 7e-14).
    A, B = full_linear_plant()
    u = np.array([0.004, 0, 0, 0, 0, 0])
    x0 = np.zeros(A.shape[0])
    x0[0] = 0.01

    def f(t, x, held):
        dx = A @ x + B @ u
        if held:
            dx[22] = 0.0
        return dx

    hit = lambda t, x, held: x[22] - demeter.WHEEL_MOMENTUM_MAX  # noqa: E731
    hit.terminal = True
    s1 = solve_ivp(f, (0, 40), x0, args=(False,), events=hit, rtol=1e-12, atol=1e-14, method="DOP853")
    assert abs(s1.t[-1] - 30.0) < 1e-9
    s2 = solve_ivp(f, (s1.t[-1], 40), s1.y[:, -1], args=(True,), rtol=1e-12, atol=1e-14, method="DOP853")
    big = run_saturating(plant["native"], 4.0)  # the event falls inside the step 28..32 s
    small = run_saturating(plant["native"], 0.1)
    assert big[-1, -1] == 1.0 and small[-1, -1] == 1.0
    assert np.abs(big[-1, :-1] - s2.y[:, -1]).max() < 1e-9
    assert np.abs(small[::40] - big).max() < 1e-9
    assert np.abs(run_saturating(plant["python"], 4.0) - big).max() < 1e-12  # same arithmetic, both backends


def test_torque_limit_and_wheels_off(plant: dict[str, Path]) -> None:
    # satT clips the command; without wheels the command is the body torque (rigid + flexible).
    sig = np.zeros(2, dtype=[("time", float), ("u_c[2]", float)])
    sig["time"], sig["u_c[2]"] = [0.0, 10.0], 0.05
    res = simulate_fmu(str(plant["native"]), stop_time=10.0, output_interval=1.0, input=sig, output=["h_w[2]"])
    assert abs(res["h_w[2]"][-1] - demeter.WHEEL_TORQUE_MAX * 10.0) < 1e-15  # exact ramp at the limit
    res = simulate_fmu(str(plant["native"]), stop_time=10.0, output_interval=1.0, input=sig,
                       start_values={"wheels_on": False}, output=STATE_NAMES[:22] + ["wheel_torque[2]"])
    A0, B0 = demeter.state_space(*NOMINAL)
    Phi, Gam = zoh(A0, B0, 10.0)
    assert np.abs(np.array([res[n][-1] for n in STATE_NAMES[:22]]) - Gam @ [0, 0.05, 0]).max() < 1e-12
    assert np.all(res["wheel_torque[2]"] == 0.0)


def test_design_model_descriptor_equals_direct_model() -> None:
    # Every Table 1 variant: the affine descriptor solved at random deltas against eq. (4) with the
    # reduced coupling and a full inverse of M. 1e-12 relative: two solves of the same equations.
    rng = np.random.default_rng(11)
    for var in (ROW1, demeter_variants.Variant((1,), (1, 2), 1, 1), demeter_variants.Variant((1,), (1, 2, 3, 4), 2, 1),
                demeter_variants.Variant((1, 2), (1, 2), 2, 2), demeter_variants.Variant((1, 2, 3), (1, 2), 2, 2),
                demeter_variants.Variant((1, 2), (1,), 1, 1, False)):
        dm = demeter_variants.design_model(var)
        for d in dm.sample(4, rng):
            got, ref = dm.state_space(d), dm.direct(d)
            for g, r in zip(got, ref):
                assert np.abs(g - r).max() <= 1e-12 * max(1.0, np.abs(r).max())


def test_lft_at_a_sample_equals_the_direct_model() -> None:
    # The check: Delta * M evaluated at sampled deltas against eq. (4) built directly.
    # 1e-12 relative: the LFT is exact; the residual is the rounding of two linear solves.
    rng = np.random.default_rng(12)
    for var in (ROW1, demeter_variants.Variant((1, 2), (1, 2), 2, 2), demeter_variants.Variant((1, 2, 3), (1, 2), 2,
                                                                                               2)):
        dm = demeter_variants.design_model(var)
        lft = dm.lft()
        assert sum(r for _, r in lft["blocks"]) == lft["Cq"].shape[0]
        for d in dm.sample(4, rng):
            Delta = np.diag(np.concatenate([[d[k]] * r for k, (_, r) in enumerate(lft["blocks"])]))
            X = np.linalg.solve(np.eye(len(Delta)) - lft["Dqp"] @ Delta, np.hstack([lft["Cq"], lft["Dqu"], lft["Dq1"]]))
            got = np.hstack([lft["A"], lft["Bu"], lft["B1"]]) + lft["Bp"] @ Delta @ X
            ref = np.hstack(dm.direct(d))
            assert np.abs(got - ref).max() <= 1e-12 * np.abs(ref).max()


def test_uncertainty_structure_is_the_seeds() -> None:
    # Seed section 2.6: one axis, identical appendages: 3 uncertainties, a 5 x 5 block (root of J
    # twice, omega twice, zeta once); Na (Na + 1) / 2 + 2 Nf uncertainties for model_type 1.
    dm = demeter_variants.design_model(ROW1)
    assert dm.names == ["sqrtJ11", "omega", "zeta"]
    assert [np.linalg.matrix_rank(N) for N in dm.Nk] == [2, 2, 1]
    assert dm.n == 8  # theta, theta', eta_r, eta_r', xi, xw, y, y': the 8 gains of Fig. 3
    assert len(demeter_variants.design_model(demeter_variants.Variant((1, 2), (1, 2, 3), 1, 1)).parameters) == 3 + 2 * 3
    assert abs(dm.L_r[0, 0] - np.linalg.norm(demeter.L_SUBSTITUTE[0, :2])) < 1e-15  # l of eq. (8)


def test_reduced_variant_has_the_full_plants_transfer() -> None:
    # The reduction keeps the body's input-output behaviour: tau -> theta of the reduced design
    # plant equals the full 22-state plant with the variant's FMU parameters (couplings of
    # unselected axes and appendages zero). 1e-9 relative: frequency responses of two realizations.
    rng = np.random.default_rng(5)
    for var in (ROW1, demeter_variants.Variant((1, 2), (1, 2, 3, 4), 2, 1), demeter_variants.Variant((1, 2), (2, 3), 1,
                                                                                                     1)):
        dm = demeter_variants.design_model(var)
        d = dm.sample(1, rng)[0]
        v = dm.values(d)
        A_r, B_r = demeter.state_space(v["J"], dm.L_r, v["zeta"][dm.mode_group], v["omega"][dm.mode_group], pairs=False)
        A_f, B_f = demeter.state_space(*_plant_matrices(dm.fmu_parameters(d)))
        ax = [a - 1 for a in var.axes]
        for w in (0.05, 0.7, 2.5, 9.0):
            G_r = np.linalg.solve(1j * w * np.eye(len(A_r)) - A_r, B_r)[:dm.na]
            G_f = np.linalg.solve(1j * w * np.eye(len(A_f)) - A_f, B_f)[np.ix_(ax, ax)]
            assert np.abs(G_r - G_f).max() <= 1e-9 * np.abs(G_f).max()


def test_variant_errors() -> None:
    with pytest.raises(demeter_variants.VariantError, match="axes"):
        demeter_variants.Variant((4,), (1,))
    with pytest.raises(demeter_variants.VariantError, match="appendages"):
        demeter_variants.Variant((1,), (1, 1))
    with pytest.raises(demeter_variants.VariantError, match="model_type"):
        demeter_variants.Variant((1,), (1,), 3)
    with pytest.raises(demeter_variants.VariantError, match="uncertainty_type"):
        demeter_variants.Variant((1,), (1,), 1, 4)
    dm = demeter_variants.design_model(ROW1)
    with pytest.raises(demeter_variants.VariantError, match="delta"):
        dm.state_space([0.0, 1.5, 0.0])
    with pytest.raises(demeter_variants.VariantError, match="delta"):
        dm.state_space([0.0, np.nan, 0.0])
    with pytest.raises(demeter_variants.VariantError, match="K must"):
        dm.fmu_gains(np.zeros((1, 7)))
    with pytest.raises(demeter_variants.VariantError, match="L must"):
        demeter_variants.design_model(ROW1, np.zeros((3, 7)))
    with pytest.raises(KeyError, match="no such gains"):
        state_feedback.build({"K_nope[1,1]": 1.0})


def test_closed_loop_fmus_equal_the_sampled_data_reference(fmu_dir: Path) -> None:
    # A nominal LQR gain of the row-1 design model (any stabilizing gain exercises the wiring),
    # plant + state-feedback FMUs through the master; reference: the same sampled-data loop in
    # numpy (plant and controller each advanced by their exact flow, command held per step).
    # 1e-10: both are exact, they differ by rounding over 3000 steps.
    dm = demeter_variants.design_model(ROW1)
    A, Bu, _ = dm.state_space(np.zeros(3))
    P = solve_continuous_are(A, Bu, np.diag([1e2, 1e2, 1, 1, 1e-2, 10, 1e-3, 1e-5]), 1e3 * np.eye(1))
    K = -Bu.T @ P / 1e3
    gains = dm.fmu_gains(K)
    h, n_steps = 0.1, 3000
    sim = CoSimulation({"plant": fmu_dir / "demeter_flexible.fmu", "ctrl": fmu_dir / "demeter_row1_det.fmu"})
    for name in ("theta", "theta_dot", "eta", "eta_dot", "wheel_torque", "wheel_torque_rate"):
        sim.connect(f"plant.{name}", f"ctrl.{name}")
    sim.connect("ctrl.u_c", "plant.u_c")
    params = {**dm.fmu_parameters(np.zeros(3)), "wheels_on": True, "theta_0[1]": 0.01, "theta_dot_0[1]": 1e-4}
    res = sim.run(n_steps * h, h, parameters={"plant": params, "ctrl": gains},
                  record=["plant.theta[1]", "plant.eta[1]", "ctrl.u_c[1]", "ctrl.xw[1]"])
    # reference: plant 31 states, controller states (xi, xw) per axis
    Ap, Bp = full_linear_plant(*_plant_matrices(params))
    G = {k: np.array([[gains[f"{k}[{i},{j}]"] for j in range(1, state_feedback.GAIN_BLOCKS[k][1] + 1)]
                      for i in (1, 2, 3)]) for k in state_feedback.GAIN_BLOCKS}
    n = Ap.shape[0]
    Aw, _, _ = demeter.wheel_state_space()
    # measured signals y = Cy x: theta, theta', eta, eta', wheel torque, wheel torque rate
    Cy = np.zeros((28, n))
    Cy[:22, :22] = np.eye(22)
    for i in range(3):
        Cy[22 + i, 28 + i] = 1.0
        Cy[25 + i, [22 + i, 25 + i, 28 + i]] = Aw[2]
    Ky = np.hstack([G["K_theta"], G["K_theta_dot"], G["K_eta"], G["K_eta_dot"], G["K_torque"], G["K_torque_rate"]])
    Kc = np.hstack([G["K_xi"], G["K_xw"]])
    a = 1e-3
    Ac = np.block([[np.zeros((3, 3)), np.zeros((3, 3))], [Kc[:, :3], -a * np.eye(3) + Kc[:, 3:]]])
    Bc = np.vstack([np.hstack([np.eye(3), np.zeros((3, 25))]), Ky])  # xi' = theta, xw' = -a xw + u_c
    Phi_p, Gam_p = zoh(Ap, Bp, h)
    Phi_c, Gam_c = zoh(Ac, Bc, h)
    x = np.zeros(n)
    x[0], x[3] = 0.01, 1e-4
    xc = np.zeros(6)
    theta, u_hist = [x[0]], []
    for _ in range(n_steps):
        y = Cy @ x
        u = Ky @ y + Kc @ xc
        u_hist.append(u[0])
        x = Phi_p @ x + Gam_p @ np.concatenate([u, np.zeros(3)])
        xc = Phi_c @ xc + Gam_c @ y
        theta.append(x[0])
    assert np.abs(res["plant.theta[1]"] - np.array(theta)).max() < 1e-10
    assert np.abs(res["ctrl.u_c[1]"][:-1] - np.array(u_hist)).max() < 1e-10
    # the loop settles as the design model says (slowest attitude pole -0.010 1/s: about 5 % after
    # 300 s; measured 1.1 %): the FMUs are wired as the design model
    assert abs(theta[-1]) < 0.05 * abs(theta[0])


def _plant_matrices(params: dict[str, float]) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    J = np.array([[params[f"J[{min(i, j) + 1},{max(i, j) + 1}]"] for j in range(3)] for i in range(3)])
    L = np.array([[params[f"L[{i + 1},{j + 1}]"] for j in range(8)] for i in range(3)])
    return (J, L, np.array([params[f"zeta[{k}]"] for k in (1, 2, 3, 4)]),
            np.array([params[f"omega[{k}]"] for k in (1, 2, 3, 4)]))
