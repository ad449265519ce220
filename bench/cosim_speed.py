"""Closed-loop co-simulation speed: native FMUs vs pythonfmu FMUs vs an in-process RK4 loop.

All three run the seed 000 200 deg loop (plant + published controller, 0.05 s
communication step, 4 RK4 substeps) for 120 s = 2400 steps; each is timed as the best
of ``--repeat`` runs, in this one process, and reported as steps/s and as ratios
(the machine is shared and noisy: ratios measured together hold, absolute numbers drift).

    python bench/cosim_speed.py [--repeat 3] [--fmu-dir build/fmus]
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from timing import best_of

from controllers import polynomial
from fmus import mrp_satellite, reference
from sims import catalog, paths
from sims.master import CoSimulation

STOP, STEP = 120.0, 0.05
SIGMA_200 = {"sigma_0[1]": 0.5992, "sigma_0[2]": -0.7976, "sigma_0[3]": 0.6517}
ARTIFACT = Path(__file__).resolve().parents[1] / "controllers" / "artifacts" / "mrp_hinf_published.json"


def _fmu_loop(fmu_dir: Path, suffix: str) -> CoSimulation:
    sim = CoSimulation({"plant": fmu_dir / f"mrp_satellite{suffix}.fmu",
                        "controller": fmu_dir / f"mrp_hinf_published{suffix}.fmu"})
    sim.connect("plant.omega", "controller.omega")
    sim.connect("plant.sigma", "controller.sigma")
    sim.connect("controller.u", "plant.u")
    return sim



def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--fmu-dir", type=Path, default=paths.fmu_cache(),
                    help="FMU folder, brought up to date first (default: the user's FMU cache, sims.paths.fmu_cache())")
    args = ap.parse_args()
    fmu_dir = args.fmu_dir
    catalog.build_all(fmu_dir)  # nothing to do when `satfmu build` ran on this tree
    n = int(round(STOP / STEP))
    record = ["plant.sigma"]
    params = {"plant": SIGMA_200}
    timings, finals = {}, {}
    for label, suffix in (("native FMUs", ""), ("pythonfmu FMUs", "_py")):
        with _fmu_loop(fmu_dir, suffix) as sim:
            dt, res = best_of(lambda: sim.run(STOP, STEP, parameters=params, record=record), args.repeat)
        timings[label] = dt
        finals[label] = np.array([res[f"plant.sigma[{i}]"][-1] for i in (1, 2, 3)])
    ctrl = polynomial.load_model(ARTIFACT)
    dt, res = best_of(lambda: reference.closed_loop_rk4(mrp_satellite.MODEL, ctrl, STOP, STEP, SIGMA_200),
                    args.repeat)
    timings["in-process RK4 loop"] = dt
    finals["in-process RK4 loop"] = res.x[-1, 3:]
    base = timings["pythonfmu FMUs"]
    print(f"closed loop, seed 000 200 deg case, {n} communication steps of {STEP} s (best of {args.repeat})")
    print(f"{'engine':24s} {'seconds':>9s} {'steps/s':>10s} {'x pythonfmu':>12s}")
    for label, dt in timings.items():
        print(f"{label:24s} {dt:9.4f} {n / dt:10.0f} {base / dt:12.2f}")
    spread = max(np.max(np.abs(v - finals["native FMUs"])) for v in finals.values())
    print(f"largest difference of final sigma between the three: {spread:.2e}")


if __name__ == "__main__":
    main()
