"""Monte Carlo analysis speed (seed 004): vectorized vs per-sample, and 1 vs 2 Dask workers.

1. The closed-loop values of the shipped DEMETER row-1 design (poles, exact H-infinity norm,
   impulse-to-peak) on ``--batch`` sampled plants: :class:`satfmu.synthesis.robust.demeter_random.ClosedLoopSamples`
   (every step batched over the samples) against a per-sample loop of the same functions
   (:func:`satfmu.synthesis.core.system_norms.hinf_norm`, ``impulse_to_peak`` on one system); samples/s of
   each, best of ``--repeat``, the values compared.
2. The Chernoff campaign of ``--n`` samples (default 1e5) on an in-process LocalCluster with 1
   and with 2 workers (``satfmu.sims.campaign.engine``): wall time, speed-up, and whether the two result
   tables are equal bit for bit (they must be: every value depends only on seed, chunk, n).

    python bench/montecarlo_speed.py [--batch 500] [--repeat 3] [--n 100000] [--chunk 5000]
"""
from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from timing import best_of

from satfmu.controllers import artifact as artifacts
from satfmu.controllers import polynomial
from satfmu.sims.campaign import engine as campaign
from satfmu.synthesis.robust import demeter_design
from satfmu.synthesis.robust import demeter_random
from satfmu.synthesis.robust.demeter_variants import Variant
from satfmu.synthesis.core.system_norms import hinf_norm, impulse_to_peak

ROW1 = Variant((1,), (1,), 1, 1)


def _per_sample(task: demeter_random.ClosedLoopSamples, deltas: np.ndarray) -> dict[str, np.ndarray]:
    """The same values one plant at a time (no batching)."""
    dm = task.design_model()
    out: dict[str, list[float]] = {"max_real_pole": [], "hinf": [], "i2p": []}
    for d in deltas:
        A, Bu, B1 = dm.state_space(d)
        Acl = A + Bu @ task.K
        out["max_real_pole"].append(np.linalg.eigvals(Acl).real.max())
        out["hinf"].append(hinf_norm(Acl, B1, dm.C1, np.zeros((1, 1))))
        out["i2p"].append(impulse_to_peak(Acl, dm.B2, dm.C2, demeter_design.I2P_HORIZON, demeter_design.I2P_POINTS))
    return {k: np.array(v) for k, v in out.items()}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--batch", type=int, default=500, help="samples of the vectorized/per-sample comparison")
    ap.add_argument("--repeat", type=int, default=3, help="runs of each, best taken")
    ap.add_argument("--n", type=int, default=100_000, help="samples of the Dask campaign")
    ap.add_argument("--chunk", type=int, default=5000, help="samples per campaign task")
    args = ap.parse_args()
    art = artifacts.load(polynomial.ARTIFACTS / "demeter_row1_det.json")
    task = demeter_random.ClosedLoopSamples(ROW1, np.array(art.design["K"]))
    deltas = task.design_model().sample(args.batch, np.random.default_rng(0))
    t_vec, vec = best_of(lambda: task(deltas), args.repeat)
    t_loop, loop = best_of(lambda: _per_sample(task, deltas), args.repeat)
    diff = max(float(np.max(np.abs(vec[k] - loop[k]) / np.abs(loop[k]))) for k in loop)
    print(f"{args.batch} closed loops (poles, exact H-infinity, impulse-to-peak), best of {args.repeat}:")
    print(f"  vectorized {args.batch / t_vec:9.0f} samples/s")
    print(f"  per sample {args.batch / t_loop:9.0f} samples/s")
    print(f"  ratio {t_loop / t_vec:.1f}x; largest relative difference of the values {diff:.1e}")

    camp = campaign.Campaign(name="chernoff", task=task, n=args.n, seed=0, chunk=args.chunk,
                             sampler=demeter_random.BoxSampler(len(task.design_model().parameters)))
    frames, seconds = {}, {}
    for workers in (1, 2):
        with tempfile.TemporaryDirectory() as out:
            t0 = time.perf_counter()
            frames[workers] = campaign.run(camp, Path(out), n_workers=workers)
            seconds[workers] = time.perf_counter() - t0
    same = frames[1].equals(frames[2])
    print(f"Chernoff campaign, {args.n} samples in chunks of {args.chunk} (LocalCluster, cluster start included):")
    for workers in (1, 2):
        print(f"  {workers} worker{'s' if workers > 1 else ' '}: {seconds[workers]:7.1f} s "
              f"({args.n / seconds[workers]:7.0f} samples/s)")
    print(f"  speed-up 2 vs 1 workers: {seconds[1] / seconds[2]:.2f}x; results identical bit for bit: {same}")
    print(campaign.summarize(frames[2], "hinf", level=art.certificate["numbers"]["analysis_hinf_pdlf"]).text())


if __name__ == "__main__":
    main()
