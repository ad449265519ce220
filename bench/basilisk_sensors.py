"""satfmu's sensor FMUs against Basilisk's sensor modules: the same noise parameters, the same statistics.

A spacecraft holds a fixed attitude (and, for the gyro, a fixed rate) for ``--stop`` seconds of
50 ms samples; each sensor reads it in Basilisk and as satfmu's native FMU in the master, and
the table gives, per axis, the standard deviation of the measurement error in each and their
ratio against the tolerance of two independent estimates of one standard deviation
(``5 sqrt(1 / n)`` relative: five times the spread of their ratio).

- gyro: Basilisk's ``imuSensor`` with the white noise ``PMatrixGyro = s I`` (its Gauss-Markov
  matrix ``AMatrixGyro`` 0: no walk) and the bias ``senRotBias``; satfmu's ``rate_gyro`` with the
  angle random walk ``arw = s sqrt(dt)`` (a per-sample noise of ``s``), no rate random walk, the
  same bias. Also compared: the mean (the bias).
- star tracker: Basilisk's ``starTracker`` with ``PMatrix = s I`` (rad: measured, its noise is the
  error angle per axis) and no walk; satfmu's ``star_tracker`` with ``noise_cross =
  noise_boresight = s`` (arcsec). The errors are the small rotation from the true attitude to
  the measured one, body axes.
- magnetometer: Basilisk's ``magnetometer`` with ``senNoiseStd = s`` in a centred dipole field;
  satfmu's ``magnetometer`` with ``noise = s`` on the same field (its ``b`` input the field
  Basilisk reports, its ``sigma`` the attitude).

    python bench/basilisk_sensors.py [--stop 1000]
"""
from __future__ import annotations

import argparse
import math
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import numpy as np
from scipy.spatial.transform import Rotation

import satfmu
from satfmu.fmus.sensors.common import ARCSEC

STEP = 0.05
"""Sample period of every sensor in both, s."""
SIGMA = (0.1, 0.2, -0.1)
"""The held attitude, MRP."""
OMEGA = (0.01, -0.02, 0.005)
"""The gyro's rate in both, rad/s (the Basilisk spacecraft tumbles slowly; the errors are taken
against its own true rate)."""
GYRO_NOISE = 1e-4
"""Per-sample white noise of the gyro, rad/s."""
GYRO_BIAS = (2e-4, -1e-4, 5e-5)
"""Constant gyro bias, rad/s."""
TRACKER_NOISE = 20.0
"""Star tracker noise per axis, arcsec."""
MAG_NOISE = 2e-7
"""Magnetometer noise per axis, T."""


@dataclass
class Row:
    """One compared statistic.

    Parameters
    ----------
    sensor : str
        The sensor.
    quantity : str
        What is compared, with its unit.
    basilisk, satfmu : numpy.ndarray
        The statistic per axis in each.
    expected : numpy.ndarray
        What the parameters say it is.
    tolerance : float
        Largest admitted relative difference of the two, and of each from ``expected``.
    """

    sensor: str
    quantity: str
    basilisk: np.ndarray
    satfmu: np.ndarray
    expected: np.ndarray
    tolerance: float

    @property
    def passed(self) -> bool:
        """Both within the tolerance of the expected value, and of each other."""
        scale = np.maximum(np.abs(self.expected), 1e-300)
        return bool(np.all(np.abs(self.basilisk - self.expected) <= self.tolerance * scale)
                    and np.all(np.abs(self.satfmu - self.expected) <= self.tolerance * scale)
                    and np.all(np.abs(self.basilisk - self.satfmu) <= self.tolerance * scale))


def run_basilisk(stop: float) -> dict[str, np.ndarray]:
    """Basilisk's three sensors on a slowly tumbling spacecraft.

    Returns
    -------
    dict of str to numpy.ndarray
        ``gyro`` (n, 3) measured rate and ``omega`` (n, 3) true rate, rad/s; ``q`` (n, 4) the
        tracker's quaternion (scalar last) and ``sigma`` (n, 3) the true MRP; ``b_m`` (n, 3) the
        measured and ``b_true`` (n, 3) the true field in the sensor's axes, T, and ``b_n`` (n, 3)
        the field in inertial axes.
    """
    from Basilisk.architecture import messaging
    from Basilisk.simulation import (imuSensor, magneticFieldCenteredDipole, magnetometer, spacecraft,
                                     starTracker)
    from Basilisk.utilities import SimulationBaseClass, macros, simIncludeGravBody

    sim = SimulationBaseClass.SimBaseClass()
    sim.CreateNewProcess("p").addTask(sim.CreateNewTask("t", macros.sec2nano(STEP)))
    sc = spacecraft.Spacecraft()
    sc.ModelTag = "sc"
    sc.hub.sigma_BNInit = [[v] for v in SIGMA]
    sc.hub.omega_BN_BInit = [[v] for v in OMEGA]
    sc.hub.r_CN_NInit = [[7.0e6], [0.0], [0.0]]
    sc.hub.v_CN_NInit = [[0.0], [7.546e3], [0.0]]
    grav = simIncludeGravBody.gravBodyFactory()
    earth = grav.createEarth()
    earth.isCentralBody = True
    grav.addBodiesTo(sc)
    imu = imuSensor.ImuSensor()
    imu.ModelTag = "imu"
    imu.PMatrixGyro = (np.eye(3) * GYRO_NOISE).tolist()
    imu.setAMatrixGyro(np.zeros((3, 3)).tolist())
    imu.setWalkBoundsGyro([1e9] * 3)
    imu.senRotBias = list(GYRO_BIAS)
    imu.scStateInMsg.subscribeTo(sc.scStateOutMsg)
    tracker = starTracker.StarTracker()
    tracker.ModelTag = "tracker"
    tracker.PMatrix = (np.eye(3) * TRACKER_NOISE * ARCSEC).tolist()
    tracker.setAMatrix(np.zeros((3, 3)).tolist())
    tracker.setWalkBounds([1e9] * 3)
    tracker.scStateInMsg.subscribeTo(sc.scStateOutMsg)
    field = magneticFieldCenteredDipole.MagneticFieldCenteredDipole()
    field.ModelTag = "field"
    field.g10, field.g11, field.h11 = -29404.8e-9, -1450.9e-9, 4652.5e-9
    field.planetRadius = 6371.2e3
    field.addSpacecraftToModel(sc.scStateOutMsg)
    planet = messaging.SpicePlanetStateMsgPayload()
    planet.J20002Pfix = np.eye(3).tolist()
    planet_msg = messaging.SpicePlanetStateMsg().write(planet)
    field.planetPosInMsg.subscribeTo(planet_msg)
    mag = magnetometer.Magnetometer()
    mag.ModelTag = "mag"
    mag.senNoiseStd = [MAG_NOISE] * 3
    mag.stateInMsg.subscribeTo(sc.scStateOutMsg)
    mag.magInMsg.subscribeTo(field.envOutMsgs[0])
    for module in (sc, field, imu, tracker, mag):
        sim.AddModelToTask("t", module)
    logs = {name: msg.recorder() for name, msg in (("state", sc.scStateOutMsg), ("imu", imu.sensorOutMsg),
                                                   ("tracker", tracker.sensorOutMsg), ("mag", mag.tamDataOutMsg),
                                                   ("field", field.envOutMsgs[0]))}
    for log in logs.values():
        sim.AddModelToTask("t", log)
    sim.InitializeSimulation()
    sim.ConfigureStopTime(macros.sec2nano(stop))
    sim.ExecuteSimulation()
    sigma = np.asarray(logs["state"].sigma_BN)
    q_first = np.asarray(logs["tracker"].qInrtl2Case)  # scalar first
    b_n = np.asarray(logs["field"].magField_N)
    true_b = Rotation.from_mrp(sigma).inv().apply(b_n)  # C(sigma) b_N: the sensor's axes are the body's
    return {"gyro": np.asarray(logs["imu"].AngVelPlatform), "omega": np.asarray(logs["state"].omega_BN_B),
            "q": np.column_stack([q_first[:, 1:], q_first[:, 0]]), "sigma": sigma,
            "b_m": np.asarray(logs["mag"].tam_S), "b_true": true_b, "b_n": b_n}


def run_satfmu(stop: float, b_n: np.ndarray, fmu_dir: Path | None = None) -> dict[str, np.ndarray]:
    """satfmu's three sensor FMUs on the MRP satellite tumbling from the same state, the
    magnetometer fed Basilisk's inertial field (a table profile)."""
    times = [k * STEP for k in range(len(b_n))]
    fmus = {"plant": satfmu.FmuSpec(model="mrp_satellite", parameters={
                **{f"sigma_0[{i + 1}]": v for i, v in enumerate(SIGMA)},
                **{f"omega_0[{i + 1}]": v for i, v in enumerate(OMEGA)}, "I_x": 1.0, "I_y": 1.0, "I_z": 1.0}),
            "gyro": satfmu.FmuSpec(model="rate_gyro", parameters={
                "sample_period": STEP, "seed": 1, "arw": GYRO_NOISE * math.sqrt(STEP), "rrw": 0.0, "range": 10.0,
                **{f"bias_0[{i + 1}]": v for i, v in enumerate(GYRO_BIAS)}}),
            "tracker": satfmu.FmuSpec(model="star_tracker", parameters={
                "sample_period": STEP, "seed": 2, "noise_cross": TRACKER_NOISE, "noise_boresight": TRACKER_NOISE}),
            "mag": satfmu.FmuSpec(model="magnetometer", parameters={"sample_period": STEP, "seed": 3,
                                                                     "noise": MAG_NOISE})}
    profiles = [{"to": f"mag.b[{i + 1}]", "kind": "table", "times": times, "values": b_n[:, i].tolist(),
                 "interpolation": "previous"} for i in range(3)]
    connections = [("plant.omega", "gyro.omega"), ("plant.sigma", "tracker.sigma"), ("plant.sigma", "mag.sigma")]
    record = ([f"gyro.omega_m[{i}]" for i in (1, 2, 3)] + [f"plant.omega[{i}]" for i in (1, 2, 3)]
              + [f"tracker.q_m[{i}]" for i in (1, 2, 3, 4)] + [f"plant.sigma[{i}]" for i in (1, 2, 3)]
              + [f"mag.b_m[{i}]" for i in (1, 2, 3)] + [f"mag.b[{i}]" for i in (1, 2, 3)])
    scenario = satfmu.Scenario(name="sensors", stop_time=stop, step_size=STEP, fmus=fmus, connections=connections,
                               profiles=profiles, record=record)
    r = satfmu.run(scenario, fmu_dir=fmu_dir).results

    def cols(base: str, n: int = 3) -> np.ndarray:
        return np.column_stack([r[f"{base}[{i}]"] for i in range(1, n + 1)])

    sigma = cols("plant.sigma")
    return {"gyro": cols("gyro.omega_m"), "omega": cols("plant.omega"), "q": cols("tracker.q_m", 4),
            "sigma": sigma, "b_m": cols("mag.b_m"),
            "b_true": Rotation.from_mrp(sigma).inv().apply(cols("mag.b"))}


def errors(run: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The measurement errors of a run: gyro (rad/s), tracker (arcsec, body axes), magnetometer (T)."""
    tracker = (Rotation.from_mrp(run["sigma"]).inv() * Rotation.from_quat(run["q"])).as_rotvec() / ARCSEC
    return {"gyro": run["gyro"] - run["omega"], "tracker": tracker, "mag": run["b_m"] - run["b_true"]}


def compare(stop: float = 1000.0, fmu_dir: Path | None = None) -> list[Row]:
    """The rows of the comparison (see the module's docstring).

    Parameters
    ----------
    stop : float
        Length of each record, s.
    fmu_dir : Path, optional
        Folder of the FMUs (default satfmu's FMU cache).

    Returns
    -------
    list of Row
        Per sensor: the standard deviation of the errors per axis; for the gyro also their mean.
    """
    b = run_basilisk(stop)
    s = run_satfmu(stop, b["b_n"], fmu_dir)
    eb, es = errors(b), errors(s)
    n = min(len(eb["gyro"]), len(es["gyro"])) - 1
    tol = 5 * math.sqrt(1.0 / n)
    rows = [Row("gyro", "noise, rad/s (1 sigma)", eb["gyro"][1:].std(axis=0), es["gyro"][1:].std(axis=0),
                np.full(3, GYRO_NOISE), tol),
            Row("gyro", "bias, rad/s (mean)", eb["gyro"][1:].mean(axis=0), es["gyro"][1:].mean(axis=0),
                np.array(GYRO_BIAS), 5 * GYRO_NOISE / math.sqrt(n) / min(abs(v) for v in GYRO_BIAS)),
            Row("star tracker", "noise, arcsec (1 sigma)", eb["tracker"][1:].std(axis=0),
                es["tracker"][1:].std(axis=0), np.full(3, TRACKER_NOISE), tol),
            Row("magnetometer", "noise, T (1 sigma)", eb["mag"][1:].std(axis=0), es["mag"][1:].std(axis=0),
                np.full(3, MAG_NOISE), tol)]
    return rows


def table(rows: Sequence[Row]) -> str:
    """The rows as Markdown."""
    def fmt(v: np.ndarray) -> str:
        return ", ".join(f"{x:.4g}" for x in v)

    out = ["| sensor | quantity | Basilisk | satfmu | parameters | tolerance (relative) | |",
           "|---|---|---|---|---|---:|---|"]
    out += [f"| {r.sensor} | {r.quantity} | {fmt(r.basilisk)} | {fmt(r.satfmu)} | {fmt(r.expected)} | "
            f"{r.tolerance:.3g} | {'pass' if r.passed else 'FAIL'} |" for r in rows]
    return "\n".join(out)


def main(argv: Sequence[str] | None = None) -> int:
    """Print the table; exit 1 when a row fails.

    Parameters
    ----------
    argv : sequence of str, optional
        Command-line arguments (default ``sys.argv[1:]``).
    """
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--stop", type=float, default=1000.0, help="length of each record, s")
    args = parser.parse_args(argv)
    rows = compare(args.stop)
    print(table(rows))
    return 0 if all(r.passed for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
