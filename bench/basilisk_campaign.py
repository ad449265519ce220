"""A sample of the campaign rw4_slew_mc against the same closed loop in Basilisk: cost and agreement.

Every sample ``i`` of the shipped campaign ``rw4_slew_mc`` (seed 000's published controller slewing
seed 000's spacecraft through 4 pyramid wheels on a 500 km orbit, every environment torque on;
slew, inertia, wheel friction, centres of pressure, epoch and orbit phase dispersed) runs twice,
interleaved:

- satfmu: :meth:`satfmu.sims.campaign.scenario_task.ScenarioTask.run_sample`, what a campaign
  worker does per sample (draw the dispersions, run the compiled loop of the three native FMUs,
  evaluate the metrics, build the row), the FMU instances reused;
- Basilisk 2.12 (``bsk``, the bench extra), the same closed loop built for the sample's values: a
  ``spacecraft`` hub (its translation integrated under point-mass gravity from the orbit model's
  position and velocity at t = 0) with 4 ``reactionWheelStateEffector`` balanced wheels (the same
  friction), ``GravityGradientEffector``, ``facetDragDynamicEffector`` (density from
  ``exponentialAtmosphere`` with the orbit model's band of Vallado's table, wind from
  ``zeroWindModel``), ``facetSRPDynamicEffector`` (shadow from ``eclipse``), the residual dipole as
  ``MtbEffector`` in ``magneticFieldCenteredDipole``'s field (the orbit model's tilted dipole as
  Gauss coefficients); the controller's law as a Python module (satfmu's generated Python code of
  the same artifact), allocated by Basilisk's ``rwMotorTorque``. Dynamics at the FMU's RK4 substep
  (12.5 ms), the law, the allocation and the environment at the communication step (50 ms), as in
  satfmu. Timed twice: building the simulation and running it.

Each figure is CPU time per sample (``time.process_time``), min and median over the samples; the
ratios are Basilisk's over satfmu's. The law's own share of Basilisk's run (its Python module) is
timed inside the module and printed, so the C++ modules' cost alone can be read off.

Agreement: the final attitude angle (deg) and the peak wheel speed (rad/s) of each sample, the two
simulators' largest difference over the samples. The models differ in what is stated:
the orbit (Kepler with J2's secular drift in satfmu, point-mass gravity integrated in Basilisk:
~0.1 km apart after 120 s), the Earth's rotation (the field's dipole turns with the Earth in
satfmu, Basilisk's stays at its t = 0 orientation: 0.5 deg in 120 s), the Sun (fixed at its t = 0
position in Basilisk), the solar flux (1361 W/m^2 in satfmu, Basilisk's 1368) and the environment
inputs' hold (satfmu's plant holds the orbit model's outputs over the 50 ms step, Basilisk's
effectors read the integrated position at every substep). These move torques of ~1e-5 N m by
~1 %: far below the controller's torques.

    python bench/basilisk_campaign.py [--samples 20]
"""
from __future__ import annotations

import argparse
import functools
import math
import statistics
import sys
import time
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from satfmu.controllers import polynomial
from satfmu.fmus import codegen
from satfmu.fmus.environment import atmosphere, orbit
from satfmu.fmus.environment.constants import EQUATORIAL_RADIUS, ERA_RATE, MU_EARTH
from satfmu.fmus.plants import wheel_spacecraft
from satfmu.sims.campaign.scenario_task import campaign
from satfmu.fmus.plants.environment_torques import TORQUES
from satfmu.sims.scenario import SHIPPED_SCENARIOS
from satfmu.sims.scenario.spec import Scenario

SCENARIO = "rw4_slew_mc"
"""The compared campaign (shipped)."""
WHEELS = 4
STEP = 0.05
"""Communication step of the scenario: the law's, the allocation's and the environment's rate, s."""
SUBSTEP = 0.0125
"""The plant FMU's RK4 substep (its ``h_max``): Basilisk's dynamics rate, s."""
LAW = "mrp_hinf_published"
"""The scenario's controller."""

Values = dict[str, dict[str, float]]
"""Instance -> parameter -> value of one sample."""


@dataclass
class Outcome:
    """One sample in one simulator.

    Parameters
    ----------
    build : float
        CPU time to build the simulation, s (0 for satfmu: its instances are reused).
    run : float
        CPU time of the run, s (satfmu: the whole campaign sample).
    law : float
        CPU time inside the control law's Python module, s (Basilisk only).
    final_angle : float
        Attitude angle at the end, deg.
    peak_speed : float
        Largest wheel speed at the communication points, rad/s.
    """

    build: float
    run: float
    law: float
    final_angle: float
    peak_speed: float


def sample_values(sampled: Scenario) -> Values:
    """Every parameter of the sampled scenario's plant and orbit: the sample's value, else the
    model's start value.

    Parameters
    ----------
    sampled : Scenario
        One sample of the campaign (:meth:`satfmu.sims.scenario.spec.Scenario.sample`).

    Returns
    -------
    dict
        ``"plant"`` and ``"orbit"`` -> every parameter of the model -> value.
    """
    models = {"plant": wheel_spacecraft.MODELS[WHEELS], "orbit": orbit.MODEL}
    values: dict[str, dict[str, float]] = {}
    for instance, model in models.items():
        given = {k: float(v) for k, v in sampled.fmus[instance].parameters.items()}
        values[instance] = dict(zip((v.name for v in model.parameters), model.parameter_vector(given).tolist()))
    return values


def start_environment(orbit_values: dict[str, float]) -> dict[str, Any]:
    """The orbit model's outputs at t = 0 for the sample (satfmu's generated Python code of the
    same model as the FMU).

    Parameters
    ----------
    orbit_values : dict of str to float
        The sample's orbit parameters (:func:`sample_values`).

    Returns
    -------
    dict
        ``r``, ``v`` (m, m/s), ``sun_position`` (the Sun from the Earth's centre, m),
        ``earth_angle`` (rad), ``density_band`` (h0 m, rho0 kg/m^3, H m: Vallado's band at the
        start altitude).
    """
    model = orbit.MODEL
    gen = codegen.load_python(model)
    p = [orbit_values[v.name] for v in model.parameters]
    y = dict(zip((o.variable.name for o in model.outputs), gen.outputs(0.0, [], [], p)))
    r = np.array([y[f"r[{i}]"] for i in (1, 2, 3)])
    sun = np.array([y[f"sun[{i}]"] for i in (1, 2, 3)]) * y["sun_distance"]
    return {"r": r, "v": np.array([y[f"v[{i}]"] for i in (1, 2, 3)]), "sun_position": r + sun,
            "earth_angle": y["earth_angle"], "density_band": atmosphere.vallado_band(y["altitude"])}


def gauss_coefficients(orbit_values: dict[str, float]) -> tuple[float, float, float]:
    """The orbit model's tilted dipole as the Gauss coefficients g10, g11, h11 of Basilisk's
    centred dipole at the equatorial radius, T (the north geomagnetic pole is
    ``-(g11, h11, g10) / B0`` in Earth-fixed axes)."""
    b0 = orbit_values["dipole_moment"] / EQUATORIAL_RADIUS**3
    colat, lon = orbit_values["dipole_colatitude"], orbit_values["dipole_longitude"]
    return (-b0 * math.cos(colat), -b0 * math.sin(colat) * math.cos(lon), -b0 * math.sin(colat) * math.sin(lon))


def run_basilisk(values: Values, law: Callable[[list[float]], list[float]], stop: float,
                 torques: Sequence[str] = TORQUES) -> Outcome:
    """The sample's closed loop in Basilisk.

    Parameters
    ----------
    values : dict
        The sample's parameters (:func:`sample_values`).
    law : callable
        ``[omega(3), sigma(3)] -> u(3)``, N m: the controller.
    stop : float
        Length of the run, s.
    torques : sequence of str, optional
        The environment's torques applied (of :data:`satfmu.fmus.plants.environment_torques.TORQUES`;
        default all).

    Returns
    -------
    Outcome
    """
    from Basilisk.architecture import messaging
    from Basilisk.fswAlgorithms import rwMotorTorque
    from Basilisk.simulation import (GravityGradientEffector, MtbEffector, eclipse, exponentialAtmosphere,
                                     facetDragDynamicEffector, facetSRPDynamicEffector, magneticFieldCenteredDipole,
                                     reactionWheelStateEffector, spacecraft as bsk_spacecraft, zeroWindModel)
    from Basilisk.utilities import SimulationBaseClass, macros, simIncludeGravBody, simIncludeRW

    t_build = time.process_time()
    plant = values["plant"]
    env = start_environment(values["orbit"])
    sim = SimulationBaseClass.SimBaseClass()
    dyn = sim.CreateNewProcess("dyn", 2)  # first at every instant: the state at t, then the law reads it
    dyn.addTask(sim.CreateNewTask("dynamics", macros.sec2nano(SUBSTEP)))
    fsw = sim.CreateNewProcess("fsw", 1)
    fsw.addTask(sim.CreateNewTask("sampled", macros.sec2nano(STEP)))
    sc = bsk_spacecraft.Spacecraft()
    sc.ModelTag = "sc"
    sc.hub.IHubPntBc_B = [[plant["I_x"], plant["I_xy"], plant["I_xz"]], [plant["I_xy"], plant["I_y"], plant["I_yz"]],
                          [plant["I_xz"], plant["I_yz"], plant["I_z"]]]
    sc.hub.sigma_BNInit = [[plant[f"sigma_0[{i}]"]] for i in (1, 2, 3)]
    sc.hub.omega_BN_BInit = [[plant[f"omega_0[{i}]"]] for i in (1, 2, 3)]
    sc.hub.r_CN_NInit = [[x] for x in env["r"]]
    sc.hub.v_CN_NInit = [[x] for x in env["v"]]
    grav = simIncludeGravBody.gravBodyFactory()
    earth = grav.createEarth()
    earth.isCentralBody = True
    earth.mu = MU_EARTH
    grav.addBodiesTo(sc)

    factory = simIncludeRW.rwFactory()
    gs = []
    for i in range(1, WHEELS + 1):
        axis = np.array([plant[f"G_s[{k},{i}]"] for k in (1, 2, 3)])
        axis /= np.linalg.norm(axis)
        gs.append(axis)
        rw = factory.create("custom", list(axis), Js=plant[f"J_s[{i}]"], Omega=plant[f"Omega_0[{i}]"] / macros.RPM,
                            u_max=plant[f"u_wheel_max[{i}]"], Omega_max=plant[f"Omega_max[{i}]"] / macros.RPM,
                            useRWfriction=True, fCoulomb=plant[f"f_coulomb[{i}]"], cViscous=plant[f"c_viscous[{i}]"],
                            RWModel=messaging.BalancedWheels)
        rw.omegaLimitCycle = plant["omega_coulomb"]
    rws = reactionWheelStateEffector.ReactionWheelStateEffector()
    rws.ModelTag = "rws"
    factory.addToSpacecraft("rws", rws, sc)

    earth_state = messaging.SpicePlanetStateMsgPayload()
    earth_state.PlanetName = "earth"
    c, s = math.cos(env["earth_angle"]), math.sin(env["earth_angle"])
    earth_state.J20002Pfix = [[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]]
    sun_state = messaging.SpicePlanetStateMsgPayload()
    sun_state.PlanetName = "sun"
    sun_state.PositionVector = list(env["sun_position"])
    msgs = [messaging.SpicePlanetStateMsg().write(earth_state), messaging.SpicePlanetStateMsg().write(sun_state)]
    earth_msg, sun_msg = msgs

    modules: list[tuple[str, object, int]] = []
    shadow = eclipse.Eclipse()
    shadow.ModelTag = "eclipse"
    shadow.sunInMsg.subscribeTo(sun_msg)
    shadow.addPlanetToModel(earth_msg)
    shadow.rEqCustom = EQUATORIAL_RADIUS
    shadow.addSpacecraftToModel(sc.scStateOutMsg)
    h0, rho0, scale = env["density_band"]
    air = exponentialAtmosphere.ExponentialAtmosphere()
    air.ModelTag = "atmosphere"
    air.planetRadius = EQUATORIAL_RADIUS
    air.baseDensity = rho0 * math.exp(h0 / scale)
    air.scaleHeight = scale
    air.addSpacecraftToModel(sc.scStateOutMsg)
    wind = zeroWindModel.ZeroWindModel()
    wind.ModelTag = "wind"
    wind.setPlanetOmega_N([0.0, 0.0, ERA_RATE])
    wind.planetPosInMsg.subscribeTo(earth_msg)
    wind.addSpacecraftToModel(sc.scStateOutMsg)
    field = magneticFieldCenteredDipole.MagneticFieldCenteredDipole()
    field.ModelTag = "field"
    field.g10, field.g11, field.h11 = gauss_coefficients(values["orbit"])
    field.planetRadius = EQUATORIAL_RADIUS
    field.planetPosInMsg.subscribeTo(earth_msg)
    field.addSpacecraftToModel(sc.scStateOutMsg)
    modules += [("sampled", m, 10) for m in (shadow, air, wind, field)]

    gg = GravityGradientEffector.GravityGradientEffector()
    gg.ModelTag = "gg"
    gg.addPlanetName(earth.planetName)
    drag = facetDragDynamicEffector.FacetDragDynamicEffector()
    drag.ModelTag = "drag"
    srp = facetSRPDynamicEffector.FacetSRPDynamicEffector()
    srp.ModelTag = "srp"
    n_facets = sum(1 for name in plant if name.startswith("facet_area["))
    srp.setNumFacets(n_facets)
    for k in range(1, n_facets + 1):
        normal = np.array([plant[f"facet_normal[{j},{k}]"] for j in (1, 2, 3)])
        normal /= np.linalg.norm(normal)
        cp = [plant[f"facet_cp[{j},{k}]"] for j in (1, 2, 3)]
        area = plant[f"facet_area[{k}]"]
        drag.addFacet(area, plant[f"drag_coefficient[{k}]"], list(normal), cp)
        srp.addFacet(area, np.eye(3), list(normal), [0.0, 0.0, 1.0], cp, plant[f"diffuse[{k}]"],
                     plant[f"specular[{k}]"])
    drag.atmoDensInMsg.subscribeTo(air.envOutMsgs[0])
    drag.windVelInMsg.subscribeTo(wind.envOutMsgs[0])
    srp.sunInMsg.subscribeTo(sun_msg)
    srp.sunEclipseInMsg.subscribeTo(shadow.eclipseOutMsgs[0])
    mtb = MtbEffector.MtbEffector()
    mtb.ModelTag = "dipole"
    cmd, config = messaging.MTBCmdMsgPayload(), messaging.MTBArrayConfigMsgPayload()
    cmd.mtbDipoleCmds = [plant[f"m_res[{i}]"] for i in (1, 2, 3)] + [0.0] * 33
    config.numMTB = 3
    config.GtMatrix_B = list(np.eye(3).ravel()) + [0.0] * (3 * 36 - 9)
    config.maxMtbDipoles = [1e9] * 3 + [0.0] * 33
    msgs += [messaging.MTBCmdMsg().write(cmd), messaging.MTBArrayConfigMsg().write(config)]
    mtb.mtbCmdInMsg.subscribeTo(msgs[-2])
    mtb.mtbParamsInMsg.subscribeTo(msgs[-1])
    mtb.magInMsg.subscribeTo(field.envOutMsgs[0])
    effectors = dict(zip(TORQUES, (gg, drag, srp, mtb)))
    for name in torques:
        sc.addDynamicEffector(effectors[name])
        modules.append(("dynamics", effectors[name], 1))
    modules += [("dynamics", rws, 3), ("dynamics", sc, 2)]

    controller = _law_module_class()(law, sc.scStateOutMsg)
    alloc = rwMotorTorque.rwMotorTorque()
    alloc.ModelTag = "allocation"
    alloc.controlAxes_B = list(np.eye(3).ravel())
    array = messaging.RWArrayConfigMsgPayload()
    array.numRW = WHEELS
    array.GsMatrix_B = [float(x) for g in gs for x in g] + [0.0] * (3 * 36 - 3 * WHEELS)
    array.JsList = [plant[f"J_s[{i}]"] for i in range(1, WHEELS + 1)] + [0.0] * (36 - WHEELS)
    array.uMax = [plant[f"u_wheel_max[{i}]"] for i in range(1, WHEELS + 1)] + [0.0] * (36 - WHEELS)
    msgs.append(messaging.RWArrayConfigMsg().write(array))
    alloc.rwParamsInMsg.subscribeTo(msgs[-1])
    alloc.vehControlInMsg.subscribeTo(controller.out_msg)
    rws.rwMotorCmdInMsg.subscribeTo(alloc.rwMotorTorqueOutMsg)
    modules += [("sampled", controller, 5), ("sampled", alloc, 4)]
    for task, module, priority in modules:
        sim.AddModelToTask(task, module, priority)
    state_log = sc.scStateOutMsg.recorder(macros.sec2nano(STEP))
    speed_log = rws.rwSpeedOutMsg.recorder(macros.sec2nano(STEP))
    for log in (state_log, speed_log):
        sim.AddModelToTask("sampled", log)
    sim.InitializeSimulation()
    sim.ConfigureStopTime(macros.sec2nano(stop))
    t_run = time.process_time()
    sim.ExecuteSimulation()
    t_end = time.process_time()
    sigma = np.asarray(state_log.sigma_BN)[-1]
    speeds = np.asarray(speed_log.wheelSpeeds)[:, :WHEELS]
    return Outcome(build=t_run - t_build, run=t_end - t_run, law=controller.seconds,
                   final_angle=math.degrees(4 * math.atan(float(np.linalg.norm(sigma)))),
                   peak_speed=float(np.max(np.abs(speeds))))


@functools.cache
def _law_module_class() -> type:
    """Basilisk's Python module class of the control law (defined once, when first needed: Basilisk
    is imported then)."""
    from Basilisk.architecture import messaging, sysModel

    class LawModule(sysModel.SysModel):  # type: ignore[misc]
        """The controller: reads the spacecraft's state, writes the body torque it asks for; keeps
        the CPU time of its calls (``seconds``)."""

        def __init__(self, law: Callable[[list[float]], list[float]], state_msg: object) -> None:
            super().__init__()
            self.ModelTag = "law"
            self.law = law
            self.state_in = messaging.SCStatesMsgReader()
            self.state_in.subscribeTo(state_msg)
            self.out_msg = messaging.CmdTorqueBodyMsg()
            self.payload = messaging.CmdTorqueBodyMsgPayload()
            self.seconds = 0.0

        def UpdateState(self, current_sim_nanos: int) -> None:
            t0 = time.process_time()
            state = self.state_in()
            self.payload.torqueRequestBody = self.law(list(state.omega_BN_B) + list(state.sigma_BN))
            self.out_msg.write(self.payload, current_sim_nanos, self.moduleID)
            self.seconds += time.process_time() - t0

    return LawModule


def law_function() -> Callable[[list[float]], list[float]]:
    """The scenario's controller as ``[omega, sigma] -> u``: satfmu's generated Python code of the
    artifact's model (the same the pythonfmu backend runs)."""
    model = polynomial.load_model(polynomial.ARTIFACTS / f"{LAW}.json")
    gen = codegen.load_python(model)
    params = [float(v.start) for v in model.parameters]
    order = [v.name for v in model.inputs]
    want = [f"omega[{i}]" for i in (1, 2, 3)] + [f"sigma[{i}]" for i in (1, 2, 3)]
    index = [want.index(n) for n in order]
    return lambda x: list(gen.outputs(0.0, [], [x[i] for i in index], params))[:3]


def compare(samples: int, torques: Sequence[str] = TORQUES, fmu_dir: Path | None = None
            ) -> tuple[list[Outcome], list[Outcome]]:
    """Samples ``0 .. samples - 1`` of the campaign, each in satfmu then in Basilisk.

    Parameters
    ----------
    samples : int
        Number of samples.
    torques : sequence of str, optional
        The environment's torques on in both (default all).
    fmu_dir : Path, optional
        Folder of the FMUs (default satfmu's FMU cache), built if missing.

    Returns
    -------
    satfmu, basilisk : list of Outcome
        Per sample.
    """
    scenario: str | Scenario = SCENARIO
    if set(torques) != set(TORQUES):
        data = tomllib.loads((SHIPPED_SCENARIOS / f"{SCENARIO}.toml").read_text())
        data["fmus"]["plant"]["parameters"].update({f"{name}_on": name in torques for name in TORQUES})
        scenario = Scenario.from_dict(data)
    task = campaign(scenario, samples, fmu_dir=fmu_dir).task
    sim = task.simulation()
    task.run_sample(0, sim)  # warm: the libraries loaded, the instances made
    law = law_function()
    run_basilisk(sample_values(task.scenario.sample(task.seed, 0, task.fmu_dir, task.backend)), law, 1.0,
                 torques)  # warm: Basilisk's modules imported
    ours: list[Outcome] = []
    theirs: list[Outcome] = []
    for i in range(samples):
        values = sample_values(task.scenario.sample(task.seed, i, task.fmu_dir, task.backend))
        t0 = time.process_time()
        row, message = task.run_sample(i, sim)
        seconds = time.process_time() - t0
        if message:
            raise RuntimeError(message)
        ours.append(Outcome(0.0, seconds, 0.0, row["attitude angle at 120 s"], row["peak wheel speed"]))
        theirs.append(run_basilisk(values, law, task.scenario.stop_time, torques))
    return ours, theirs


def agreement(ours: Sequence[Outcome], theirs: Sequence[Outcome]) -> tuple[float, float]:
    """The largest differences over the samples: final attitude angle (deg) and peak wheel speed
    (rad/s)."""
    return (max(abs(o.final_angle - t.final_angle) for o, t in zip(ours, theirs)),
            max(abs(o.peak_speed - t.peak_speed) for o, t in zip(ours, theirs)))


def main(argv: Sequence[str] | None = None) -> int:
    """Print the per-sample costs, their ratio and the agreement.

    Parameters
    ----------
    argv : sequence of str, optional
        Command-line arguments (default ``sys.argv[1:]``).
    """
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=20, help="samples, each run in both (default 20)")
    parser.add_argument("--torques", nargs="*", choices=TORQUES, default=list(TORQUES),
                        help="the environment's torques on in both (default all; none: the loops then agree to "
                             "rounding)")
    args = parser.parse_args(argv)
    _report(*compare(args.samples, args.torques))
    return 0


def _report(ours: list[Outcome], theirs: list[Outcome]) -> None:
    def mm(values: list[float]) -> str:
        return f"{min(values) * 1e3:8.2f} {statistics.median(values) * 1e3:8.2f}"

    n = len(ours)
    s_run = [o.run for o in ours]
    b_build, b_run = [o.build for o in theirs], [o.run for o in theirs]
    b_law = [o.law for o in theirs]
    b_total = [a + b for a, b in zip(b_build, b_run)]
    print(f"{SCENARIO}: {n} samples, each in satfmu and in Basilisk in turn; CPU ms per sample, min and median")
    print(f"{'':44s} {'min':>8s} {'median':>8s}")
    print(f"{'satfmu campaign sample (draw, run, metrics)':44s} {mm(s_run)}")
    print(f"{'Basilisk: build the simulation':44s} {mm(b_build)}")
    print(f"{'Basilisk: run':44s} {mm(b_run)}")
    print(f"{'  of which the law (Python module)':44s} {mm(b_law)}")
    print(f"{'Basilisk: build and run':44s} {mm(b_total)}")
    ratio = [b / s for b, s in zip(b_total, s_run)]
    c_only = [b - law for b, law in zip(b_run, b_law)]
    print(f"Basilisk / satfmu per sample: build and run {min(b_total) / min(s_run):.1f}x (min), "
          f"{statistics.median(ratio):.1f}x (median of the per-sample ratios); the run alone without the law's "
          f"Python module {min(c_only) / min(s_run):.1f}x (min)")
    angle, speed = agreement(ours, theirs)
    print(f"agreement over the samples: final attitude angle {angle:.2e} deg (of up to "
          f"{max(o.final_angle for o in ours):.3g}), peak wheel speed {speed:.2e} rad/s (of up to "
          f"{max(o.peak_speed for o in ours):.4g})")


if __name__ == "__main__":
    sys.exit(main())
