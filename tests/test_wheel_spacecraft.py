"""The spacecraft with a reaction wheel array: its description and its plant, in process and as FMUs."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from satfmu.fmus import codegen
from satfmu.fmus.errors import SpacecraftError
from satfmu.fmus.plants import wheel_spacecraft
from satfmu.fmus.plants import wheels
from satfmu.fmus.plants.spacecraft import Spacecraft
from satfmu.fmus.pyslave import rk4_step

RW4 = wheel_spacecraft.MODELS[4]


class Plant:
    """The generated Python of a wheel plant, stepped by the FMUs' RK4 (:func:`rk4_step`)."""

    def __init__(self, model=RW4, **params: float) -> None:
        self.model, self.gen = model, codegen.load_python(model)
        self.p = model.parameter_vector(params).tolist()
        self.n = (len(model.states) - 6) // 2
        self.outputs = [o.variable.name for o in model.outputs]

    def inputs(self, u=(0.0, 0.0, 0.0), u_wheel=None, w_d=(0.0, 0.0, 0.0), **env: float) -> list[float]:
        """The inputs in the model's order: the commands, then the environment's (by name, default their starts)."""
        given = {**{f"u[{i + 1}]": v for i, v in enumerate(u)}, **{f"w_d[{i + 1}]": v for i, v in enumerate(w_d)},
                 **{f"u_wheel[{i + 1}]": v for i, v in enumerate(u_wheel or [])}, **env}
        return [float(given.get(v.name, v.start)) for v in self.model.inputs]

    def run(self, x: list[float], ui: list[float], stop: float, h: float = 0.05, substeps: int = 4) -> list[float]:
        for k in range(round(stop / h)):
            x = rk4_step(self.gen, k * h, x, ui, self.p, h, substeps)
        return x

    def y(self, x: list[float], ui: list[float], name: str) -> float:
        return float(self.gen.outputs(0.0, x, ui, self.p)[self.outputs.index(name)])

    def ys(self, x: list[float], ui: list[float], base: str, n: int = 3) -> np.ndarray:
        return np.array([self.y(x, ui, f"{base}[{i + 1}]") for i in range(n)])


def _start(n: int, omega=(0.01, -0.02, 0.015), sigma=(0.1, 0.05, -0.1), speeds=None) -> list[float]:
    return [*omega, *sigma, *(speeds if speeds is not None else [100.0 * (i + 1) for i in range(n)]), *[0.0] * n]


# ------------------------------------------------------------------------------------------ description
def test_description_reads_writes_and_checks_a_wheel_array(tmp_path: Path) -> None:
    sc = wheel_spacecraft.SMALLSAT[4]
    assert Spacecraft.from_dict(sc.to_dict()) == sc  # round trip through the TOML keys
    G = wheels.spin_axes(sc.wheels)
    assert np.allclose(np.linalg.norm(G, axis=0), 1.0, atol=1e-15)
    assert np.allclose(G @ G.T, 4 / 3 * np.eye(3), atol=1e-12)  # the usual pyramid: isotropic
    assert np.allclose(sc.body_inertia, sc.tensor - 0.02 * G @ G.T, atol=1e-15)
    text = """name = "toml_sat"
inertia = [10.0, 12.0, 8.0]
[[wheels]]
axis = [2.0, 0.0, 0.0]
inertia = 0.01
torque_limit = 0.05
speed_limit = 500.0
[[wheels]]
axis = [0.0, 1.0, 0.0]
inertia = 0.01
torque_limit = 0.05
speed_limit = 500.0
viscous = 1e-6
[[wheels]]
axis = [0.0, 0.0, 1.0]
inertia = 0.01
torque_limit = 0.05
speed_limit = 500.0
coulomb = 1e-4
"""
    (tmp_path / "sat.toml").write_text(text)
    sc = Spacecraft.from_toml(tmp_path / "sat.toml")
    assert sc.wheels[0].axis == (1.0, 0.0, 0.0) and sc.wheels[1].viscous == 1e-6 and sc.wheels[2].coulomb == 1e-4
    assert sc.wheels[0].momentum_limit == pytest.approx(5.0, rel=1e-15)


@pytest.mark.parametrize("change, message", [
    ({"axis": [0.0, 0.0, 0.0]}, "zero vector"),
    ({"axis": [1.0, math.nan, 0.0]}, "finite"),
    ({"axis": [1.0, 0.0]}, "3 finite numbers"),
    ({"inertia": 0.0}, "inertia: must be a finite number > 0"),
    ({"torque_limit": -1.0}, "torque_limit"),
    ({"speed_limit": 0.0}, "speed_limit"),
    ({"viscous": -1e-6}, "viscous"),
    ({"coulomb": math.inf}, "coulomb"),
    ({"spin": 1.0}, "spin"),
])
def test_a_bad_wheel_is_refused_with_its_key(change: dict, message: str) -> None:
    wheel = {**wheel_spacecraft.SMALLSAT[3].wheels[0].to_dict(), **change}
    with pytest.raises(SpacecraftError, match=message):
        Spacecraft.from_dict({"name": "s", "inertia": [10.0, 10.0, 10.0],
                              "wheels": [wheel, *[w.to_dict() for w in wheel_spacecraft.SMALLSAT[3].wheels[1:]]]})


def test_an_array_that_cannot_torque_every_axis_or_outweighs_the_body_is_refused() -> None:
    w = wheels.orthogonal(0.02, 0.1, 600.0)
    with pytest.raises(SpacecraftError, match="at least 3"):
        Spacecraft("s", [10.0, 10.0, 10.0], wheels=w[:2])
    planar = [wheels.ReactionWheel(a, 0.02, 0.1, 600.0) for a in ([1, 0, 0], [0, 1, 0], [1, 1, 0])]
    with pytest.raises(SpacecraftError, match="do not span"):
        Spacecraft("s", [10.0, 10.0, 10.0], wheels=planar)
    with pytest.raises(SpacecraftError, match="not positive definite"):  # spin inertia above the body's
        Spacecraft("s", [0.05, 0.05, 0.05], wheels=wheels.orthogonal(0.06, 0.1, 600.0))
    with pytest.raises(SpacecraftError, match="elevation"):
        wheels.pyramid(0.02, 0.1, 600.0, elevation_deg=90.0)
    with pytest.raises(SpacecraftError, match="list of tables"):
        Spacecraft.from_dict({"name": "s", "inertia": [1.0, 1.0, 1.0], "wheels": {"axis": [1, 0, 0]}})
    with pytest.raises(ValueError, match="no reaction wheels"):
        wheel_spacecraft.build(Spacecraft("s", [1.0, 1.0, 1.0]))


# ------------------------------------------------------------------------------------------ dynamics
@pytest.mark.parametrize("n", [3, 4])
def test_total_momentum_is_conserved_while_the_wheels_slew_the_body(n: int) -> None:
    # A body torque command (within every limit) with friction on: every torque is internal, so the
    # reference-frame momentum stays constant. 100 s of RK4 at 12.5 ms: the drift is the integration
    # error of the rotation (measured 1e-12 N m s of |H| ~ 10): 1e-10 relative leaves 100x margin.
    plant = Plant(wheel_spacecraft.MODELS[n])
    x, ui = _start(n), plant.inputs(u=(0.05, -0.03, 0.02))
    H0 = plant.ys(x, ui, "H")
    x = plant.run(x, ui, 100.0)
    assert np.max(np.abs(plant.ys(x, ui, "H") - H0)) < 1e-10 * np.linalg.norm(H0)
    assert plant.y(x, ui, "H_norm") == pytest.approx(np.linalg.norm(H0), rel=1e-10)
    # the wheels' torque on the body is the command, less the friction's reaction (~1e-4 N m)
    assert np.allclose(plant.ys(x, ui, "tau_wheels"), [0.05, -0.03, 0.02], atol=2e-3)


def test_the_command_reaches_the_body_without_friction_and_splits_by_the_pseudo_inverse() -> None:
    plant = Plant(**{f"c_viscous[{i}]": 0.0 for i in range(1, 5)}, **{f"f_coulomb[{i}]": 0.0 for i in range(1, 5)})
    x, ui = _start(4), plant.inputs(u=(0.05, -0.03, 0.02))
    assert np.allclose(plant.ys(x, ui, "tau_wheels"), [0.05, -0.03, 0.02], rtol=0, atol=1e-15)
    G = wheels.spin_axes(wheel_spacecraft.SMALLSAT[4].wheels)
    tau = plant.ys(x, ui, "tau_motor", 4)
    assert np.allclose(tau, -np.linalg.pinv(G) @ [0.05, -0.03, 0.02], rtol=0, atol=1e-15)  # minimum norm


def test_limits_clip_each_wheel_and_the_speed_limit_cuts_spin_up_only() -> None:
    plant = Plant()
    big = plant.inputs(u=(0.5, 0.0, 0.0))  # 0.5 N m about x: each wheel asked for 0.31 N m > 0.1
    assert np.allclose(np.abs(plant.ys(_start(4), big, "tau_motor", 4)), 0.1, rtol=0, atol=1e-15)
    # per-wheel commands; wheel 1 at its speed limit (600 rad/s)
    per_wheel = [p for p in plant.model.parameters if p.name == "wheel_commands"]
    assert per_wheel and per_wheel[0].start == 0
    plant.p[[p.name for p in plant.model.parameters].index("wheel_commands")] = 1.0
    at_limit = _start(4, speeds=[600.0, -600.0, 100.0, 0.0])
    spin_up = plant.inputs(u_wheel=[0.05, -0.05, 0.05, 0.2])
    assert np.allclose(plant.ys(at_limit, spin_up, "tau_motor", 4), [0.0, 0.0, 0.05, 0.1], rtol=0, atol=0)
    spin_down = plant.inputs(u_wheel=[-0.05, 0.05, 0.0, 0.0])
    assert np.allclose(plant.ys(at_limit, spin_down, "tau_motor", 4), [-0.05, 0.05, 0.0, 0.0], rtol=0, atol=0)


def test_friction_is_viscous_plus_a_linearized_coulomb_term_and_its_reaction_acts_on_the_body() -> None:
    cv, fc, zone = 2e-6, 3e-4, 1e-4
    plant = Plant(**{f"c_viscous[{i}]": cv for i in range(1, 5)}, **{f"f_coulomb[{i}]": fc for i in range(1, 5)},
                  omega_coulomb=zone)
    G = wheels.spin_axes(wheel_spacecraft.SMALLSAT[4].wheels)
    for speed, f in ((200.0, -(cv * 200.0 + fc)), (-50.0, cv * 50.0 + fc), (zone / 2, -(cv * zone / 2 + fc / 2))):
        x = _start(4, omega=(0.0, 0.0, 0.0), speeds=[speed, 0.0, 0.0, 0.0])
        # h1' = f (no command), the body feels -g1 f
        assert np.allclose(plant.ys(x, plant.inputs(), "tau_wheels"), -G[:, 0] * f, rtol=1e-12, atol=0)


def test_the_motor_lag_is_first_order() -> None:
    # tau_m' = (cmd - tau_m) / T: after T, 1 - 1/e of the step (RK4 at T/100: error ~1e-11)
    plant = Plant(motor_time_constant=0.2, wheel_commands=1.0)
    ui = plant.inputs(u_wheel=[0.05, 0.0, 0.0, 0.0])
    x = plant.run(_start(4), ui, 0.2, h=0.002, substeps=1)
    assert plant.y(x, ui, "tau_motor[1]") == pytest.approx(0.05 * (1 - math.exp(-1)), rel=1e-9)


def test_external_torque_changes_the_momentum_by_its_impulse() -> None:
    # body at rest in the reference frame (sigma = 0, omega = 0), wheels idle, friction off: the torque
    # is in body axes, which turn by 4 |sigma| ~ 5e-5 rad within the second, so H(1 s) = w_d (1 s) to
    # that fraction (measured 2.5e-6 relative)
    plant = Plant(**{f"c_viscous[{i}]": 0.0 for i in range(1, 5)}, **{f"f_coulomb[{i}]": 0.0 for i in range(1, 5)})
    ui = plant.inputs(w_d=(1e-3, -2e-3, 5e-4))
    x = plant.run(_start(4, omega=(0.0, 0.0, 0.0), sigma=(0.0, 0.0, 0.0), speeds=[0.0] * 4), ui, 1.0)
    assert np.linalg.norm(x[3:6]) * 4 < 6e-5
    assert np.allclose(plant.ys(x, ui, "H"), [1e-3, -2e-3, 5e-4], rtol=6e-5, atol=0)


# ------------------------------------------------------------------------------------------ FMUs
def test_native_fmu_matches_the_generated_python_and_refuses_bad_parameters(fmu_dir: Path, capfd) -> None:
    from fmpy import simulate_fmu

    start = {"omega_0[1]": 0.01, "sigma_0[2]": 0.2, "Omega_0[1]": 150.0, "Omega_0[3]": -80.0}
    inputs = np.array([(0.0, 0.05, -0.03, 0.02)], dtype=[("time", float), ("u[1]", float), ("u[2]", float),
                                                         ("u[3]", float)])
    res = simulate_fmu(str(fmu_dir / "mrp_satellite_rw4.fmu"), stop_time=20.0, output_interval=0.05,
                       start_values=start, input=inputs, output=["sigma[1]", "Omega[1]", "H_norm"])
    plant = Plant()
    names = [s.initial.name for s in RW4.states]
    x = [start.get(nm, 0.0) for nm in names]
    x = plant.run(x, plant.inputs(u=(0.05, -0.03, 0.02)), 20.0)
    # the same expressions and the same RK4 arithmetic (C and Python): agreement to rounding
    assert res["sigma[1]"][-1] == pytest.approx(x[3], rel=1e-12, abs=1e-15)
    assert res["Omega[1]"][-1] == pytest.approx(x[6], rel=1e-12)
    capfd.readouterr()
    for bad in ({"Omega_max[2]": 0.0}, {"J_s[1]": -0.01}, {"u_wheel_max[3]": math.nan}):
        with pytest.raises(Exception, match="fmi2SetReal failed"):
            simulate_fmu(str(fmu_dir / "mrp_satellite_rw4.fmu"), stop_time=1.0, start_values=bad)
        assert f"variable '{next(iter(bad))}'" in capfd.readouterr().out  # the FMU's log names it


def test_your_array_runs_in_the_shipped_plant_through_its_parameters() -> None:
    import satfmu

    from satfmu.fmus.plants import surface

    mine = Spacecraft("mine", [[30.0, 1.0, 0.0], [1.0, 40.0, -0.5], [0.0, -0.5, 25.0]],
                      wheels=wheels.pyramid(0.05, 0.2, 400.0, viscous=3e-6, coulomb=1e-4, elevation_deg=30.0),
                      facets=surface.box((1.5, 1.0, 2.0), offset=(0.1, 0.0, -0.05)), residual_dipole=(0.3, 0.0, 0.1))
    own = Plant(satfmu.wheel_plant(mine))
    shipped = Plant(satfmu.wheel_plant(), **wheel_spacecraft.parameters(mine))
    assert own.model.name == shipped.model.name == "mrp_satellite_rw4"
    x, ui = _start(4), own.inputs(u=(0.1, -0.2, 0.05))
    # the same model up to its defaults: the same numbers bit for bit
    assert own.run(x, ui, 5.0) == shipped.run(x, ui, 5.0)
    assert satfmu.wheel_plant(n_wheels=3).name == "mrp_satellite_rw3"
    with pytest.raises(ValueError, match="n_wheels"):
        satfmu.wheel_plant(n_wheels=5)
    with pytest.raises(ValueError, match="no reaction wheels"):
        wheel_spacecraft.parameters(Spacecraft("s", [1.0, 1.0, 1.0]))
    # another number of facets is another model
    assert wheel_spacecraft.build(Spacecraft("bare", [30.0, 40.0, 25.0], wheels=mine.wheels)).name == \
        "mrp_satellite_rw4_f0"
