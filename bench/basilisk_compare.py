"""satfmu's plant FMUs against Basilisk (``bsk``, the bench extra), the independent reference.

Each case runs the same spacecraft, initial state and command history in Basilisk and through
satfmu's native FMU in the master, and prints one row per quantity: the largest difference over
the run, its tolerance and the reason for the tolerance.

- ``wheels``: ``mrp_satellite_rw4`` (4 wheels in a pyramid, viscous and Coulomb friction, per-wheel
  motor torques held 0.5 s each, a tumbling start) against Basilisk's ``spacecraft`` hub with 4
  ``reactionWheelStateEffector`` balanced wheels, 60 s. Both integrate the same states (body rate,
  MRPs, wheel speeds) with RK4 at 0.0125 s, and the models are the same ODE written in other
  terms (Basilisk back-substitutes the hub and wheel accelerations), so the two discrete maps are
  one: they differ by rounding only.
- ``torques``: each environment torque of the wheel plant (gravity gradient, facet drag, facet solar
  radiation pressure, residual dipole) against Basilisk's ``GravityGradientEffector``,
  ``facetDragDynamicEffector``, ``facetSRPDynamicEffector`` and ``MtbEffector`` at 20 random states
  of the same spacecraft (its six facets and residual dipole).
- ``conservation``: the same spacecraft, no command, friction on: the total angular momentum in
  the inertial frame, satfmu's ``H`` output and Basilisk's ``totRotAngMomPntC_N``, each against its
  start value (internal torques only).

Basilisk's balanced wheels add no mass properties to the spacecraft (only the fully coupled
jitter model does): its hub inertia is the whole spacecraft's, wheels included, which is what
satfmu's ``I_*`` parameters are. (Adding the factory's ``Js g g^T + Jt (I - g g^T)`` to it moves
the body rate by 7e-6 rad/s within 0.5 s.) Basilisk applies a motor command read at time t over the
integration step that ends at t (its ``spacecraft`` integrates from the previous call up to the
current time): the command of the interval [t_k, t_k+1] is written before the simulation runs to
t_k+1.

    python bench/basilisk_compare.py [--case wheels] [--stop 60]
"""
from __future__ import annotations

import argparse
import math
import os
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import numpy as np

import satfmu
from satfmu.fmus.environment.constants import MU_EARTH
from satfmu.fmus.plants import wheel_spacecraft, wheels
from satfmu.sims.scenario.metrics import attitude_angle

STEP = 0.0125
"""Integration step of both simulators (and the FMU's communication step), s."""
HOLD = 0.5
"""Each motor command is held this long, s."""
HUB = ((18.0, 0.4, -0.2), (0.4, 22.0, 0.3), (-0.2, 0.3, 14.0))
"""The spacecraft's inertia about its centre of mass, wheels included, kg m^2 (Basilisk's hub
inertia with balanced wheels; products of inertia included)."""
ARRAY = wheels.pyramid(0.02, 0.1, 600.0, viscous=2e-6, coulomb=3e-4)
"""The wheels: 0.02 kg m^2, 0.1 N m, 600 rad/s, friction of a small wheel."""
OMEGA_0 = (0.02, -0.015, 0.01)
"""Initial body rate, rad/s."""
SIGMA_0 = (0.1, -0.05, 0.2)
"""Initial MRP attitude."""
WHEEL_SPEEDS_0 = (150.0, -80.0, 40.0, -220.0)
"""Initial wheel speeds relative to the body, rad/s."""


@dataclass
class Row:
    """One compared quantity.

    Parameters
    ----------
    case : str
        The case (``wheels``, ``conservation``).
    quantity : str
        What is compared, with its unit.
    difference : float
        The largest difference over the run.
    tolerance : float
        The bound it must stay within.
    reason : str
        Why that tolerance.
    """

    case: str
    quantity: str
    difference: float
    tolerance: float
    reason: str

    @property
    def passed(self) -> bool:
        """Whether the difference is within the tolerance."""
        return bool(self.difference <= self.tolerance)


def spacecraft() -> satfmu.Spacecraft:
    """The compared spacecraft: Basilisk's hub inertia (the whole spacecraft's) and the wheels."""
    return satfmu.Spacecraft("basilisk_rw4", HUB, wheels=ARRAY)


def commands(stop: float, seed: int = 7) -> np.ndarray:
    """Per-wheel motor torques held :data:`HOLD` s each, shape (n_holds, 4), N m: random within
    +-0.08 N m (inside the 0.1 N m limit, so that no clip differs in timing)."""
    return np.random.default_rng(seed).uniform(-0.08, 0.08, size=(math.ceil(stop / HOLD), len(ARRAY)))


def run_basilisk(stop: float, torques: np.ndarray | None) -> dict[str, np.ndarray]:
    """Basilisk's spacecraft with the wheel array; ``torques`` per hold (None: no command).

    Returns
    -------
    dict of str to numpy.ndarray
        ``time`` (s), ``sigma`` (n, 3), ``omega`` (n, 3, rad/s), ``Omega`` (n, 4, rad/s) and ``H``
        (n, 3, N m s, inertial), at every step from 0 to ``stop``.
    """
    from Basilisk.architecture import messaging
    from Basilisk.simulation import reactionWheelStateEffector, spacecraft as bsk_spacecraft
    from Basilisk.utilities import SimulationBaseClass, macros, simIncludeRW

    sim = SimulationBaseClass.SimBaseClass()
    proc = sim.CreateNewProcess("dyn")
    proc.addTask(sim.CreateNewTask("task", macros.sec2nano(STEP)))
    sc = bsk_spacecraft.Spacecraft()
    sc.ModelTag = "sc"
    sc.hub.IHubPntBc_B = [list(r) for r in HUB]
    sc.hub.sigma_BNInit = [[v] for v in SIGMA_0]
    sc.hub.omega_BN_BInit = [[v] for v in OMEGA_0]
    factory = simIncludeRW.rwFactory()
    for w, speed in zip(ARRAY, WHEEL_SPEEDS_0):
        rw = factory.create("custom", list(w.axis), Js=w.inertia, Omega=speed / macros.RPM, u_max=w.torque_limit,
                            Omega_max=w.speed_limit / macros.RPM, useRWfriction=True, fCoulomb=w.coulomb,
                            cViscous=w.viscous, RWModel=messaging.BalancedWheels)
        rw.omegaLimitCycle = wheel_spacecraft.OMEGA_COULOMB
    rws = reactionWheelStateEffector.ReactionWheelStateEffector()
    rws.ModelTag = "rws"
    factory.addToSpacecraft("rws", rws, sc)
    payload = messaging.ArrayMotorTorqueMsgPayload()
    payload.motorTorque = [0.0] * len(ARRAY)
    msg = messaging.ArrayMotorTorqueMsg().write(payload)
    rws.rwMotorCmdInMsg.subscribeTo(msg)
    sim.AddModelToTask("task", rws, 2)
    sim.AddModelToTask("task", sc, 1)
    state_log, speed_log = sc.scStateOutMsg.recorder(), rws.rwSpeedOutMsg.recorder()
    h_log = sc.logger(["totRotAngMomPntC_N"])
    for log in (state_log, speed_log, h_log):
        sim.AddModelToTask("task", log)
    sim.InitializeSimulation()
    n = round(stop / STEP)
    per_hold = round(HOLD / STEP)
    for k in range(n):
        if torques is not None and k % per_hold == 0:
            payload.motorTorque = [float(v) for v in torques[k // per_hold]] + [0.0] * (36 - len(ARRAY))
            msg.write(payload, macros.sec2nano(k * STEP))
        sim.ConfigureStopTime(macros.sec2nano((k + 1) * STEP))
        sim.ExecuteSimulation()
    t = state_log.times() * macros.NANO2SEC
    keep = np.concatenate([[True], np.diff(t) > 0])  # the first call logs t = 0 twice
    return {"time": t[keep], "sigma": np.asarray(state_log.sigma_BN)[keep],
            "omega": np.asarray(state_log.omega_BN_B)[keep],
            "Omega": np.asarray(speed_log.wheelSpeeds)[keep][:, :len(ARRAY)],
            "H": np.asarray(h_log.totRotAngMomPntC_N)[keep]}


def run_satfmu(stop: float, torques: np.ndarray | None, fmu_dir: Path | None = None) -> dict[str, np.ndarray]:
    """The same through the native ``mrp_satellite_rw4`` FMU in satfmu's master (per-wheel commands
    as ``previous``-interpolated table profiles)."""
    sc = spacecraft()
    params: dict[str, float | bool] = {**wheel_spacecraft.parameters(sc), "wheel_commands": True, "h_max": STEP,
                                       **{f"omega_0[{i + 1}]": v for i, v in enumerate(OMEGA_0)},
                                       **{f"sigma_0[{i + 1}]": v for i, v in enumerate(SIGMA_0)},
                                       **{f"Omega_0[{i + 1}]": v for i, v in enumerate(WHEEL_SPEEDS_0)},
                                       "shadow_switching": True}
    profiles = []
    if torques is not None:
        times = [k * HOLD for k in range(len(torques))]
        profiles = [{"to": f"plant.u_wheel[{i + 1}]", "kind": "table", "times": times,
                     "values": [float(v) for v in torques[:, i]], "interpolation": "previous"}
                    for i in range(len(ARRAY))]
    n = len(ARRAY)
    record = ([f"plant.sigma[{i}]" for i in (1, 2, 3)] + [f"plant.omega[{i}]" for i in (1, 2, 3)]
              + [f"plant.Omega[{i + 1}]" for i in range(n)] + [f"plant.H[{i}]" for i in (1, 2, 3)])
    scenario = satfmu.Scenario(name="basilisk_rw4", stop_time=stop, step_size=STEP,
                               fmus={"plant": satfmu.FmuSpec(model="mrp_satellite_rw4", parameters=params)},
                               connections=[], profiles=profiles, record=record)
    result = satfmu.run(scenario, fmu_dir=fmu_dir)
    r = result.results
    return {"time": r["time"], "sigma": np.column_stack([r[f"plant.sigma[{i}]"] for i in (1, 2, 3)]),
            "omega": np.column_stack([r[f"plant.omega[{i}]"] for i in (1, 2, 3)]),
            "Omega": np.column_stack([r[f"plant.Omega[{i + 1}]"] for i in range(n)]),
            "H": np.column_stack([r[f"plant.H[{i}]"] for i in (1, 2, 3)])}


def compare(stop: float = 60.0, fmu_dir: Path | None = None) -> list[Row]:
    """Both cases; one :class:`Row` per quantity.

    Parameters
    ----------
    stop : float
        Length of each run, s.
    fmu_dir : Path, optional
        Folder of the FMUs (default satfmu's FMU cache).

    Returns
    -------
    list of Row
        The wheel case's attitude, body rate and wheel speeds, each environment torque at 20
        random states (:func:`torque_rows`), and each simulator's momentum drift in the
        conservation case.
    """
    torques = commands(stop)
    b, s = run_basilisk(stop, torques), run_satfmu(stop, torques, fmu_dir)
    if len(b["time"]) != len(s["time"]) or np.max(np.abs(b["time"] - s["time"])) > 1e-9:
        raise RuntimeError(f"the runs' time grids differ ({len(b['time'])} and {len(s['time'])} samples)")
    w_scale = float(np.max(np.abs(b["Omega"])))
    same = ("the same RK4 map at 12.5 ms (the same states and the same ODE, written in other terms): "
            "rounding accumulated over the run")
    rows = [Row("wheels", "attitude angle between the two, rad", float(np.max(attitude_angle(b["sigma"], s["sigma"]))),
                1e-10, same + " (measured 5e-13 rad in 60 s)"),
            Row("wheels", "body rate, rad/s", float(np.max(np.abs(b["omega"] - s["omega"]))), 1e-11,
                same + " (measured 7e-14 rad/s)"),
            Row("wheels", f"wheel speeds (up to {w_scale:.0f}), rad/s", float(np.max(np.abs(b["Omega"] - s["Omega"]))),
                1e-10 * w_scale, same + " (measured 3e-12 rad/s), relative to the largest speed")]
    rows += torque_rows()
    b0, s0 = run_basilisk(stop, None), run_satfmu(stop, None, fmu_dir)
    for name, r in (("Basilisk", b0), ("satfmu", s0)):
        h = np.linalg.norm(r["H"][0])
        rows.append(Row("conservation", f"{name}: |H(t) - H(0)| / |H(0)|, inertial, friction on",
                        float(np.max(np.linalg.norm(r["H"] - r["H"][0], axis=1)) / h), 1e-11,
                        "internal torques only: RK4's error on the rotation and rounding"))
    return rows


BASILISK_SOLAR_PRESSURE = 1368.0 / 299792458.0
"""Basilisk's ``facetSRPDynamicEffector`` pressure at 1 AU, N/m^2 (its flux 1368 W/m^2 over c)."""


def basilisk_torques(sigma: np.ndarray, r: np.ndarray, v: np.ndarray, sun: np.ndarray, density: float,
                     b: np.ndarray, sc: satfmu.Spacecraft) -> dict[str, np.ndarray]:
    """Basilisk's gravity-gradient, facet drag, facet SRP and magnetic torques on ``sc`` at one state
    (the residual dipole as three body-axis torque bars of ``MtbEffector`` commanded at its components).

    Parameters
    ----------
    sigma : numpy.ndarray, shape (3,)
        MRP attitude, body from inertial.
    r, v : numpy.ndarray, shape (3,)
        Inertial position (m) and velocity (m/s); the drag's flow is ``v`` (no wind message).
    sun : numpy.ndarray, shape (3,)
        The Sun's inertial position, m (fully lit).
    density : float
        Atmospheric density, kg/m^3.
    b : numpy.ndarray, shape (3,)
        Geomagnetic field, inertial axes, T.
    sc : Spacecraft
        The inertia (the hub's) and the facets.

    Returns
    -------
    dict of str to numpy.ndarray
        ``gravity_gradient``, ``drag``, ``srp``, ``dipole`` torques in body axes, N m.
    """
    from Basilisk.architecture import messaging
    from Basilisk.simulation import (GravityGradientEffector, MtbEffector, facetDragDynamicEffector,
                                     facetSRPDynamicEffector, spacecraft as bsk_spacecraft)
    from Basilisk.utilities import SimulationBaseClass, macros, simIncludeGravBody

    sim = SimulationBaseClass.SimBaseClass()
    sim.CreateNewProcess("dyn").addTask(sim.CreateNewTask("task", macros.sec2nano(1.0)))
    body = bsk_spacecraft.Spacecraft()
    body.ModelTag = "sc"
    body.hub.IHubPntBc_B = [list(row) for row in sc.inertia]
    body.hub.sigma_BNInit = [[x] for x in sigma]
    body.hub.r_CN_NInit = [[x] for x in r]
    body.hub.v_CN_NInit = [[x] for x in v]
    grav = simIncludeGravBody.gravBodyFactory()
    earth = grav.createEarth()
    earth.isCentralBody = True
    earth.mu = MU_EARTH
    grav.addBodiesTo(body)
    gg = GravityGradientEffector.GravityGradientEffector()
    gg.ModelTag = "gg"
    gg.addPlanetName(earth.planetName)
    body.addDynamicEffector(gg)
    drag = facetDragDynamicEffector.FacetDragDynamicEffector()
    srp = facetSRPDynamicEffector.FacetSRPDynamicEffector()
    srp.setNumFacets(len(sc.facets))
    for f in sc.facets:
        drag.addFacet(f.area, f.drag_coefficient, list(f.normal), list(f.centre_of_pressure))
        srp.addFacet(f.area, np.eye(3), list(f.normal), [0.0, 0.0, 1.0], list(f.centre_of_pressure), f.diffuse,
                     f.specular)
    atmo = messaging.AtmoPropsMsgPayload()
    atmo.neutralDensity = density
    atmo_msg = messaging.AtmoPropsMsg().write(atmo)
    drag.atmoDensInMsg.subscribeTo(atmo_msg)
    sun_state = messaging.SpicePlanetStateMsgPayload()
    sun_state.PositionVector = list(sun)
    sun_msg = messaging.SpicePlanetStateMsg().write(sun_state)
    srp.sunInMsg.subscribeTo(sun_msg)
    mtb = MtbEffector.MtbEffector()
    cmd, field, config = (messaging.MTBCmdMsgPayload(), messaging.MagneticFieldMsgPayload(),
                          messaging.MTBArrayConfigMsgPayload())
    cmd.mtbDipoleCmds = list(sc.residual_dipole) + [0.0] * (36 - 3)
    field.magField_N = list(b)
    config.numMTB = 3
    config.GtMatrix_B = list(np.eye(3).ravel()) + [0.0] * (3 * 36 - 9)
    config.maxMtbDipoles = [1e9] * 3 + [0.0] * 33
    msgs = (messaging.MTBCmdMsg().write(cmd), messaging.MagneticFieldMsg().write(field),
            messaging.MTBArrayConfigMsg().write(config))
    mtb.mtbCmdInMsg.subscribeTo(msgs[0])
    mtb.magInMsg.subscribeTo(msgs[1])
    mtb.mtbParamsInMsg.subscribeTo(msgs[2])
    for effector in (drag, srp, mtb):
        body.addDynamicEffector(effector)
    for module in (body, gg, drag, srp, mtb):
        sim.AddModelToTask("task", module)
    sim.InitializeSimulation()
    drag.ReadInputs()  # the density message (read at UpdateState in a run)
    for effector in (gg, drag, srp, mtb):
        effector.computeForceTorque(0.0, 0.0)
    gg.UpdateState(0)
    return {"gravity_gradient": np.asarray(gg.gravityGradientOutMsg.read().gravityGradientTorque_B, float),
            "drag": np.asarray(drag.torqueExternalPntB_B, float).ravel(),
            "srp": np.asarray(srp.torqueExternalPntB_B, float).ravel(),
            "dipole": np.asarray(mtb.torqueExternalPntB_B, float).ravel()}


def torque_rows(n: int = 20, seed: int = 3) -> list[Row]:
    """Each environment torque of ``mrp_satellite_rw4`` against Basilisk's module, at ``n`` random
    states (attitude, 300-900 km, velocity, Sun direction, density, field): the largest difference
    relative to the torque's largest magnitude.

    Parameters
    ----------
    n : int, optional
        Random states.
    seed : int, optional
        Their seed.

    Returns
    -------
    list of Row
        One row per torque.
    """
    from satfmu.fmus import codegen

    sc = wheel_spacecraft.SMALLSAT[4]
    model = wheel_spacecraft.MODELS[4]
    gen = codegen.load_python(model)
    p = model.parameter_vector({"gravity_gradient_on": 1.0, "drag_on": 1.0, "srp_on": 1.0, "dipole_on": 1.0,
                                "solar_pressure": BASILISK_SOLAR_PRESSURE}).tolist()
    names = [o.variable.name for o in model.outputs]
    rng = np.random.default_rng(seed)
    worst = {name: (0.0, 0.0) for name in ("gravity_gradient", "drag", "srp", "dipole")}
    for _ in range(n):
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        sigma = q[1:] / (1 + abs(q[0])) * np.sign(q[0] or 1.0)
        r = rng.normal(size=3)
        r *= (6.378137e6 + rng.uniform(300e3, 900e3)) / np.linalg.norm(r)
        v = rng.normal(size=3) * 4400.0
        sun = rng.normal(size=3)
        sun *= 1.495978707e11 * rng.uniform(0.98, 1.02) / np.linalg.norm(sun)
        density = float(10 ** rng.uniform(-13, -11))
        b = rng.normal(size=3) * 3e-5
        to_sun = sun - r
        given = {**{f"r[{i + 1}]": r[i] for i in range(3)}, **{f"v_air[{i + 1}]": v[i] for i in range(3)},
                 **{f"sun[{i + 1}]": to_sun[i] / np.linalg.norm(to_sun) for i in range(3)},
                 "sun_distance": float(np.linalg.norm(to_sun)), "sunlit": 1.0, "density": density,
                 **{f"b[{i + 1}]": b[i] for i in range(3)}}
        u = [float(given.get(var.name, var.start)) for var in model.inputs]
        x = [0.0] * 3 + list(sigma) + [0.0] * 8
        y = dict(zip(names, gen.outputs(0.0, x, u, p)))
        ref = basilisk_torques(sigma, r, v, sun, density, b, sc)
        for name in worst:
            ours = np.array([y[f"tau_{name}[{i}]"] for i in (1, 2, 3)])
            dev, scale = worst[name]
            worst[name] = (max(dev, float(np.max(np.abs(ours - ref[name])))),
                           max(scale, float(np.max(np.abs(ref[name])))))
    reason = "the same formula evaluated in another order: rounding (measured up to 1.4e-15 relative)"
    return [Row("torques", f"{name.replace('_', ' ')} torque, relative to its largest ({scale:.2g} N m)",
                dev / scale, 1e-12, reason) for name, (dev, scale) in worst.items()]


def table(rows: Sequence[Row]) -> str:
    """The rows as Markdown.

    Parameters
    ----------
    rows : sequence of Row
        The compared quantities.

    Returns
    -------
    str
        One line per row: case, quantity, largest difference, tolerance, pass, reason.
    """
    out = ["| case | quantity | largest difference | tolerance | | reason |", "|---|---|---:|---:|---|---|"]
    out += [f"| {r.case} | {r.quantity} | {r.difference:.3g} | {r.tolerance:.3g} | {'pass' if r.passed else 'FAIL'} "
            f"| {r.reason} |" for r in rows]
    return "\n".join(out)


def main(argv: Sequence[str] | None = None) -> int:
    """Print the comparison table; exit 1 when a row fails.

    Parameters
    ----------
    argv : sequence of str, optional
        Command-line arguments (default ``sys.argv[1:]``).
    """
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--stop", type=float, default=60.0, help="length of each run, s")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="satfmu_basilisk_") as home:
        os.environ.setdefault("SATFMU_HOME", home)
        t0 = time.perf_counter()
        rows = compare(args.stop)
    print(table(rows))
    print(f"\n{args.stop:g} s per run; wall time {time.perf_counter() - t0:.1f} s")
    return 0 if all(r.passed for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
