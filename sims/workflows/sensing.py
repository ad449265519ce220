"""What each controller loses to sensing: its true-state campaign beside the same campaign flown on sensors.

Each pair of shipped campaigns (:data:`PAIRS`) disperses the same spacecraft, manoeuvre and
environment, in the same order, so sample ``i`` of both is the same draw; the sensed one then
also draws its sensors' noise seeds, biases and misalignments (after those, which leaves the
shared draws untouched: :func:`compare` checks it column by column). The pass rates come with
their Clopper-Pearson intervals, and the samples that pass on the true state but fail on
estimates (and the reverse) are counted.

    python -m satfmu.sims.workflows.sensing [--samples N] [--out results/sensing] [--workers 2]
"""
from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import numpy as np

from satfmu.sims.campaign.results import run_campaign
from satfmu.sims.campaign.scenario_task import campaign_size

PAIRS: dict[str, tuple[str, str]] = {
    "seed 000 published (`mrp_hinf_published`)": ("rw4_slew_mc", "rw4_slew_sensed_mc"),
    "seed 000 synthesized (`mrp_hinf_satfmu`)": ("rw4_slew_mc_synth", "rw4_slew_sensed_mc_synth"),
    "seed 001 mixed (`mrp_h2hinf_satfmu`)": ("rw4_slew_mc_h2hinf", "rw4_slew_sensed_mc_h2hinf"),
    "B-dot (`cubesat_bdot`)": ("cubesat_detumble_mc_bdot", "cubesat_detumble_mc_bdot_sensed")}
"""Controller -> (true-state campaign, the same flown on sensors): shipped campaigns."""


@dataclass(frozen=True)
class SensingLoss:
    """One controller's pass rates on the true state and on sensors, over the same samples.

    Parameters
    ----------
    controller : str
        The controller (a key of :data:`PAIRS`).
    ideal, sensed : str
        The two campaigns.
    n : int
        Samples of each.
    ideal_passes, sensed_passes : int
        Samples meeting every bound.
    ideal_interval, sensed_interval : tuple of float
        Clopper-Pearson bounds of the pass probabilities, at 95 % confidence.
    lost, gained : int
        Samples passing on the true state and failing on sensors, and the reverse.
    metric : str
        The first metric of the true-state campaign (the one the manoeuvre is judged by).
    unit : str
        Its unit.
    ideal_p50, sensed_p50, ideal_worst, sensed_worst : float
        Its median and its 99.73rd percentile in each campaign, in ``unit``.
    """

    controller: str
    ideal: str
    sensed: str
    n: int
    ideal_passes: int
    sensed_passes: int
    ideal_interval: tuple[float, float]
    sensed_interval: tuple[float, float]
    lost: int
    gained: int
    metric: str
    unit: str
    ideal_p50: float
    sensed_p50: float
    ideal_worst: float
    sensed_worst: float


def compare(controller: str, samples: int | None = None, out_dir: Path = Path("results/sensing"),
            fmu_dir: Path | None = None, workers: int = 2) -> SensingLoss:
    """Run (or resume) a pair of :data:`PAIRS` and compare it sample for sample.

    Parameters
    ----------
    controller : str
        A key of :data:`PAIRS`.
    samples : int, optional
        Samples of each campaign (default: the true-state campaign's declared size).
    out_dir : Path, optional
        Folder of the campaign folders.
    fmu_dir : Path, optional
        Folder of the FMUs (default satfmu's FMU cache), built if missing.
    workers : int, optional
        Processes of the local Dask cluster.

    Returns
    -------
    SensingLoss

    Raises
    ------
    KeyError
        If ``controller`` is no key of :data:`PAIRS`.
    ValueError
        If a value both campaigns disperse differs in some sample (they would not be the same
        samples).
    """
    ideal, sensed = PAIRS[controller]
    n, seed = campaign_size(ideal, samples)
    a = run_campaign(ideal, n, out_dir, seed=seed, fmu_dir=fmu_dir, workers=workers)
    b = run_campaign(sensed, n, out_dir, seed=seed, fmu_dir=fmu_dir, workers=workers)
    shared = [c for c in a.rows.columns if c in b.rows.columns and c.startswith(("plant.", "orbit.", "profiles["))]
    for column in shared:
        if not np.array_equal(a.rows[column].to_numpy(), b.rows[column].to_numpy()):
            raise ValueError(f"{ideal} and {sensed} draw {column} differently: not the same samples")
    ok_a, ok_b = a.rows["passed"].to_numpy() == 1.0, b.rows["passed"].to_numpy() == 1.0
    first_a, first_b = a.statistics.metrics[0], b.statistics.metrics[0]
    return SensingLoss(controller, ideal, sensed, n, int(ok_a.sum()), int(ok_b.sum()),
                       (a.statistics.overall.low, a.statistics.overall.high),
                       (b.statistics.overall.low, b.statistics.overall.high), int(np.sum(ok_a & ~ok_b)),
                       int(np.sum(ok_b & ~ok_a)), first_a.name, first_a.unit, first_a.percentiles[50.0],
                       first_b.percentiles[50.0], first_a.percentiles[99.73], first_b.percentiles[99.73])


def table(losses: Sequence[SensingLoss]) -> str:
    """The comparisons as a Markdown table.

    Parameters
    ----------
    losses : sequence of SensingLoss
        One per controller.

    Returns
    -------
    str
        A row per controller: both pass rates with their intervals, the samples lost and gained,
        and the first metric's median and 99.73rd percentile in both.
    """
    def rate(k: int, n: int, interval: tuple[float, float]) -> str:
        return f"{k}/{n} = {100 * k / n:.1f} % [{100 * interval[0]:.1f}, {100 * interval[1]:.1f}]"

    out = ["| controller (campaigns) | pass, true state [95 % CI] | pass, on sensors [95 % CI] | lost / gained | "
           "first metric: p50 and p99.73, true state -> sensors |", "|---|---|---|---|---|"]
    for x in losses:
        out.append(f"| {x.controller} (`{x.ideal}`, `{x.sensed}`) | {rate(x.ideal_passes, x.n, x.ideal_interval)} | "
                   f"{rate(x.sensed_passes, x.n, x.sensed_interval)} | {x.lost} / {x.gained} | {x.metric}: "
                   f"{x.ideal_p50:.4g} -> {x.sensed_p50:.4g}, {x.ideal_worst:.4g} -> {x.sensed_worst:.4g} "
                   f"{x.unit} |")
    return "\n".join(out)


def main(argv: Sequence[str] | None = None) -> int:
    """Run every pair and print the table.

    Parameters
    ----------
    argv : sequence of str, optional
        Command-line arguments (default ``sys.argv[1:]``).
    """
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=None, help="samples of each campaign (default: declared)")
    parser.add_argument("--out", type=Path, default=Path("results/sensing"), help="folder of the campaigns")
    parser.add_argument("--fmu-dir", type=Path, default=None, help="folder of the FMUs (default: the cache)")
    parser.add_argument("--workers", type=int, default=2, help="processes of the local Dask cluster")
    args = parser.parse_args(argv)
    print(table([compare(c, args.samples, args.out, args.fmu_dir, args.workers) for c in PAIRS]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
