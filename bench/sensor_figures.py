"""The figures of docs/estimation.md: the gyro FMU's Allan deviation against its parameters, and the
estimator's normalized estimation error squared (NEES) against its chi-square bounds.

- ``gyro_allan.png``: the overlapping Allan deviation (computed by ``allantools``, the test extra)
  of a 1e5 s record of the native ``rate_gyro`` at 20 Hz, its three axes, with the lines of its
  parameters, ``arw / sqrt(tau)``, ``rrw sqrt(tau / 3)`` and their quadrature sum.
- ``mekf_nees.png``: the NEES (3 degrees of freedom) of ``attitude_mekf`` over time, averaged over
  ``--runs`` independent runs of the slowly tumbling spacecraft of ``tests/test_estimator.py``
  (gyro and tracker seeds changed per run), with the two-sided 95 % interval of such an average
  for a consistent filter (the chi-square with 3 x runs degrees of freedom, over runs), and the
  fraction of time it stays inside.

    python bench/sensor_figures.py [--out docs/estimation] [--runs 20]
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Sequence

import allantools
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from scipy import stats  # noqa: E402
from scipy.spatial.transform import Rotation  # noqa: E402

import satfmu  # noqa: E402

ARW, RRW = 1e-4, 1e-5
"""The gyro's angle random walk (rad/s^0.5) and rate random walk (rad/s^1.5) in the Allan figure."""


def allan_figure(path: Path, fmu_dir: Path | None = None) -> float:
    """Write the Allan deviation figure; return the largest ratio of the measured deviation to the
    parameters' curve over ``tau <= 300 s`` (1 is perfect)."""
    fmus = {"gyro": satfmu.FmuSpec(model="rate_gyro", parameters={"seed": 1, "arw": ARW, "rrw": RRW})}
    scenario = satfmu.Scenario(name="allan", stop_time=100_000.0, step_size=0.05, fmus=fmus,
                               record=[f"gyro.omega_m[{i}]" for i in (1, 2, 3)])
    r = satfmu.run(scenario, fmu_dir=fmu_dir).results
    taus = np.logspace(np.log10(0.05), np.log10(10_000.0), 40)
    fig, ax = plt.subplots(figsize=(7, 4.5))
    worst = 0.0  # the largest |log| of the ratio
    for axis in (1, 2, 3):
        t, adev, _, _ = allantools.oadev(r[f"gyro.omega_m[{axis}]"], rate=20.0, data_type="freq", taus=taus)[:4]
        ax.loglog(t, adev, ".", ms=4, label=f"rate_gyro FMU, axis {axis}")
        model = np.sqrt(ARW**2 / t + RRW**2 * t / 3)
        short = t <= 300.0
        worst = max(worst, float(np.max(np.abs(np.log(adev[short] / model[short])))))
    ax.loglog(taus, ARW / np.sqrt(taus), "k--", lw=1, label=f"arw / sqrt(tau), arw = {ARW:g} rad/s^0.5")
    ax.loglog(taus, RRW * np.sqrt(taus / 3), "k:", lw=1, label=f"rrw sqrt(tau / 3), rrw = {RRW:g} rad/s^1.5")
    ax.loglog(taus, np.sqrt(ARW**2 / taus + RRW**2 * taus / 3), "k-", lw=1, label="both")
    ax.set_xlabel("tau, s")
    ax.set_ylabel("Allan deviation of the rate, rad/s")
    ax.set_title("rate_gyro: 1e5 s at 20 Hz (overlapping Allan deviation by allantools)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return float(np.exp(worst))


def _scenario(run: int, stop: float) -> satfmu.Scenario:
    """The estimator on the slowly tumbling spacecraft of tests/test_estimator.py, seeds of ``run``."""
    fmus = {"plant": satfmu.FmuSpec(model="mrp_satellite", parameters={"omega_0[1]": 0.01, "omega_0[2]": -0.005,
                                                                       "omega_0[3]": 0.002}),
            "gyro": satfmu.FmuSpec(model="rate_gyro", parameters={"seed": 100 + run, "bias_0[1]": 2e-4,
                                                                   "bias_0[2]": -1e-4, "bias_0[3]": 5e-5}),
            "tracker": satfmu.FmuSpec(model="star_tracker", parameters={"seed": 200 + run}),
            "ekf": satfmu.FmuSpec(model="attitude_mekf", parameters={"p0_bias": 1e-3})}
    connections = [("plant.omega", "gyro.omega"), ("plant.sigma", "tracker.sigma"), ("gyro.omega_m", "ekf.omega_m"),
                   ("tracker.q_m", "ekf.q_m"), ("tracker.valid", "ekf.tracker_valid"),
                   ("tracker.sample_time", "ekf.tracker_time")]
    record = ([f"ekf.q_est[{i}]" for i in (1, 2, 3, 4)] + [f"ekf.attitude_std[{i}]" for i in (1, 2, 3)]
              + [f"plant.sigma[{i}]" for i in (1, 2, 3)])
    return satfmu.Scenario(name="nees", stop_time=stop, step_size=0.05, fmus=fmus, connections=connections,
                           record=record)


def nees_figure(path: Path, runs: int, stop: float = 300.0, fmu_dir: Path | None = None) -> tuple[float, float]:
    """Write the NEES figure; return the time average of the run-averaged NEES after 60 s and the
    fraction of those instants inside the 95 % interval."""
    curves = []
    for run in range(runs):
        r = satfmu.run(_scenario(run, stop), fmu_dir=fmu_dir).results
        true = Rotation.from_mrp(np.column_stack([r[f"plant.sigma[{i}]"] for i in (1, 2, 3)]))
        est = Rotation.from_quat(np.column_stack([r[f"ekf.q_est[{i}]"] for i in (1, 2, 3, 4)]))
        e = (est.inv() * true).as_rotvec()
        std = np.column_stack([r[f"ekf.attitude_std[{i}]"] for i in (1, 2, 3)])
        curves.append(np.sum((e / std) ** 2, axis=1))
        t = r["time"]
    mean = np.mean(curves, axis=0)
    low, high = stats.chi2.ppf([0.025, 0.975], 3 * runs) / runs
    settled = t > 60.0
    inside = float(np.mean((mean[settled] > low) & (mean[settled] < high)))
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.plot(t, mean, lw=0.6, label=f"NEES averaged over {runs} runs")
    ax.axhline(3.0, color="k", lw=1, label="3 (consistent)")
    ax.axhspan(low, high, color="g", alpha=0.15, label=f"95 % interval of a {runs}-run average")
    ax.set_xlabel("t, s")
    ax.set_ylabel("NEES (3 degrees of freedom)")
    ax.set_title(f"attitude_mekf: time average after 60 s {np.mean(mean[settled]):.2f}, {100 * inside:.0f} % inside")
    ax.set_ylim(0, max(8.0, float(np.percentile(mean, 99.5))))
    ax.legend(fontsize=8, loc="upper right")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return float(np.mean(mean[settled])), inside


def main(argv: Sequence[str] | None = None) -> int:
    """Write both figures and print their figures of merit.

    Parameters
    ----------
    argv : sequence of str, optional
        Command-line arguments (default ``sys.argv[1:]``).
    """
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("docs/estimation"), help="folder of the figures")
    parser.add_argument("--runs", type=int, default=20, help="runs averaged in the NEES figure")
    parser.add_argument("--fmu-dir", type=Path, default=None, help="folder of the FMUs (default: the cache)")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    ratio = allan_figure(args.out / "gyro_allan.png", args.fmu_dir)
    print(f"{args.out / 'gyro_allan.png'}: the measured Allan deviation is within a factor {ratio:.3f} of the "
          "parameters' curve for tau <= 300 s")
    average, inside = nees_figure(args.out / "mekf_nees.png", args.runs, fmu_dir=args.fmu_dir)
    print(f"{args.out / 'mekf_nees.png'}: NEES averaged over {args.runs} runs and 240 s: {average:.3f} (3 expected); "
          f"{100 * inside:.1f} % of the instants inside the 95 % interval")
    return 0


if __name__ == "__main__":
    sys.exit(main())
