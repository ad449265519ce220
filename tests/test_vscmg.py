"""The VSCMG plant (seed 002): equations, conservation, stick-slip friction, both FMU backends."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from fmpy import simulate_fmu

from satfmu.fmus import codegen
from satfmu.fmus.plants import vscmg
from satfmu.fmus.model import Model

MODEL = vscmg.MODEL
INERTIA = vscmg.INERTIAS_ECP750
JD = INERTIA["JD"]
FS, FC, FV = (vscmg.FRICTION_TABLE_1[k] for k in ("Fs", "Fc", "Fv"))


def _inputs(T1: float = 0.0, T2: float = 0.0, Td4: float = 0.0) -> np.ndarray:
    return np.array([(0.0, T1, T2, Td4)], dtype=[("time", float), ("T1", float), ("T2", float), ("Td4", float)])


def _run(fmu: Path, stop: float, start: dict | None = None, **torques: float) -> np.ndarray:
    return simulate_fmu(str(fmu), stop_time=stop, output_interval=0.01, start_values=start or {},
                        input=_inputs(**torques))


@pytest.mark.parametrize("factorization", vscmg.FACTORIZATIONS)
def test_both_sdc_factorizations_are_exact(factorization: str) -> None:
    sdc = vscmg.model_sdc(MODEL, factorization)
    assert MODEL.sdc_residual_symbolic(sdc) == sp.zeros(6, 1)
    # Random points, inputs included: rounding only (1e-12 at rates and torques ~ 3).
    assert MODEL.sdc_residual_sampled(n_points=100, scale=3.0, sdc=sdc) < 1e-12


def test_factorizations_differ_only_in_the_gimbal_4_row_and_name_their_variables() -> None:
    w1, w2, w4, q2 = sp.symbols("w1 w2 w4 q2", real=True)
    I = vscmg.Inertias(*(sp.Float(v) for v in INERTIA.values()))
    a = vscmg.sdc_gyroscopic(q2, sp.Matrix([w1, w2, w4]), I, "w1_free")
    b = vscmg.sdc_gyroscopic(q2, sp.Matrix([w1, w2, w4]), I, "gyro_on_w2")
    assert a[:2, :] == b[:2, :]
    assert w1 not in a.free_symbols  # the seed's: coefficients in q2, w2, w4
    assert w2 not in b.free_symbols  # the other: coefficients in q2, w1, w4
    with pytest.raises(ValueError, match="unknown SDC factorization 'w2_free'"):
        vscmg.sdc_gyroscopic(q2, sp.Matrix([w1, w2, w4]), I, "w2_free")


def test_mass_matrix_and_momenta_are_the_public_model() -> None:
    # J1 = JC + JD - KC - ID = 0.0135, J2 = KA + KB + KC + ID = 0.1335 (docs/models.md).
    I = vscmg.Inertias(*INERTIA.values())
    assert I.J1 == pytest.approx(0.0135, abs=1e-12) and I.J2 == pytest.approx(0.1335, abs=1e-12)
    M = np.array(vscmg.mass_matrix(sp.pi / 6, vscmg.Inertias(*(sp.Float(v) for v in INERTIA.values()))), float)
    assert np.all(np.linalg.eigvalsh(M) > 0)
    assert M[0, 2] == pytest.approx(JD * 0.5, rel=1e-15)


def test_model_definitions_cannot_use_undeclared_symbols() -> None:
    from satfmu.fmus.model import Definitions, ModelDefinitionError, State, Variable

    d = Definitions()
    d("twice", 2 * sp.Symbol("nowhere", real=True))
    x = State(Variable("x"), Variable("x_0"))
    with pytest.raises(ModelDefinitionError, match="definition twice uses undeclared symbols"):
        Model("bad", "", [x], [], [], [], rhs=sp.Matrix([0]), definitions=d)


@pytest.fixture(scope="module")
def plant_fmus(fmu_dir: Path) -> dict[str, Path]:
    return {"native": fmu_dir / "vscmg.fmu", "python": fmu_dir / "vscmg_py.fmu"}


def test_unforced_frictionless_plant_conserves_energy_and_both_momenta(plant_fmus: dict[str, Path]) -> None:
    # Spinning rotor, moving gimbals, 60 s, RK4 at h_max = 1 ms. Issue bound 1e-9 relative;
    # measured ~1e-11 (RK4 truncation, the rotor at 30 rad/s is the fastest motion).
    start = {"friction_on": False, "w1_0": 30.0, "w2_0": 0.8, "w4_0": -0.5, "q2_0": 0.4}
    r = _run(plant_fmus["native"], 60.0, start)
    for name in ("energy", "p1", "p4"):
        v = r[name]
        assert np.max(np.abs(v - v[0])) / abs(v[0]) < 1e-9, name
    assert np.ptp(r["q2"]) > 0.1 and np.ptp(r["w4"]) > 0.5  # a real motion, not a rest state


def test_rotor_below_static_friction_stays_exactly_at_rest(plant_fmus: dict[str, Path]) -> None:
    r = _run(plant_fmus["native"], 2.0, T1=0.9 * FS[0])
    assert np.all(r["w1"] == 0.0) and np.all(r["w4"] == 0.0) and np.all(r["q1"] == 0.0)
    assert r["friction1"][-1] == pytest.approx(0.9 * FS[0], rel=1e-12)  # friction holds the torque


def test_rotor_breaks_away_above_static_friction_and_gimbal_4_stays_stuck(plant_fmus: dict[str, Path]) -> None:
    T1 = 1.1 * FS[0]
    r = _run(plant_fmus["native"], 2.0, T1=T1)
    # Sliding with gimbal 4 held: JD w1' = T1 - Fc - Fv w1 (closed form), gimbal 4 at rest.
    tau = JD / FV[0]
    expected = (T1 - FC[0]) / FV[0] * (1 - math.exp(-2.0 / tau))
    assert r["w1"][-1] == pytest.approx(expected, rel=1e-3)  # 1e-3: break-away resolved to one 1 ms substep
    assert np.all(r["w4"] == 0.0)


def test_spin_down_stops_exactly_at_the_closed_form_time(plant_fmus: dict[str, Path]) -> None:
    # JD w1' = -Fc - Fv w1 until rest: t* = (JD/Fv) ln(1 + w0 Fv / Fc). Gimbal 4 is held
    # (its holding torque sin(q2) (Fc + Fv w1) < Fs4).
    w0 = 2.0
    t_star = JD / FV[0] * math.log(1 + w0 * FV[0] / FC[0])
    r = _run(plant_fmus["native"], 3.0, {"w1_0": w0})
    stopped = r["time"][np.argmax(r["w1"] == 0.0)]
    assert 0.0 <= stopped - t_star <= 0.01 + 1e-3  # the next output point, one substep late at most
    after = r["time"] >= stopped
    assert np.all(r["w1"][after] == 0.0) and np.all(r["friction1"][after] == 0.0)


def test_large_torque_reverses_the_rotor_through_zero_without_stopping(plant_fmus: dict[str, Path]) -> None:
    r = _run(plant_fmus["native"], 1.0, {"w1_0": -0.5}, T1=0.3)
    assert r["w1"][-1] > 1.0 and np.count_nonzero(r["w1"] == 0.0) == 0


def test_pythonfmu_and_native_agree_with_friction_saturation_and_disturbance(plant_fmus: dict[str, Path]) -> None:
    start = {"w1_0": 1.0, "w2_0": -0.2, "w4_0": 0.05}
    runs = [_run(plant_fmus[b], 3.0, start, T1=0.7, T2=-0.3, Td4=0.02) for b in ("native", "python")]
    for name in ("q1", "q2", "q4", "w1", "w2", "w4", "friction1", "friction2", "friction4"):
        # Same generated expressions, same operation order, same libm: rounding only.
        assert np.max(np.abs(runs[0][name] - runs[1][name])) < 1e-12, name
    assert np.all(runs[0]["T1_applied"] == 0.6)  # T1 = 0.7 clipped at the seed's limit


def test_friction_mode_is_frozen_over_a_substep_and_matches_an_exact_integration() -> None:
    # The RK4 substep against DOP853 on the same substeps (mode frozen, post-step applied):
    # they differ by integration error only, through break-away, sliding and a stop.
    from satfmu.fmus.pyslave import rk4_step

    gen = codegen.load_python(MODEL)
    p = MODEL.parameter_vector().tolist()
    from scipy.integrate import solve_ivp

    x_rk = x_ex = [0.0, math.pi / 18, 0.0, 0.3, 0.0, 0.0]
    u = [-0.2, 0.06, 0.0]
    for k in range(1500):
        x_rk = rk4_step(gen, k * 1e-3, x_rk, u, p, 1e-3, 1)
        start = list(x_ex)
        sol = solve_ivp(lambda t, x: gen.derivatives(t, x, start, u, p), (k * 1e-3, (k + 1) * 1e-3), start,
                        method="DOP853", rtol=1e-12, atol=1e-14)
        x_ex = gen.post_step((k + 1) * 1e-3, list(sol.y[:, -1]), start, u, p)
    assert np.max(np.abs(np.subtract(x_rk, x_ex))) < 1e-9
    assert x_rk[3] < -1.0  # the rotor stopped and reversed under T1 = -0.2
