"""Scenario campaign speed: samples/s on 1 and 2 Dask workers against one bare compiled run.

The campaign is mrp_200deg (seed 000's published controller, 120 s = 2400 steps of 0.05 s)
with its attitude uniform over the sphere and its principal moments of inertia +-20 %. The
figures:

- one bare run: :meth:`satfmu.sims.cosim.master.CoSimulation.run` of the nominal scenario through the
  compiled loop, FMU instances reused (what a campaign worker does per sample, without the
  sampling, the metrics and the row), CPU s, min and median of ``--repeat`` runs;
- per sample in one process: :class:`satfmu.sims.campaign.scenario_task.ScenarioTask` on 500 samples
  (draw the dispersions, run, evaluate the metrics, build the row), CPU s per sample, and its
  ratio to the bare run (issue 59's target <= 1.2);
- through ``satfmu campaign scenario`` (its own process, one worker), at ``--cli-samples`` and at
  a tenth of them, alternated over ``--repeat-cli`` rounds: the slope of the wall time is a
  sample's cost through the command (its ratio to the bare run: target <= 1.3), the intercept
  the driver's fixed cost (imports, checks, the cluster's start and stop, the chunk files, the
  statistics: target < 2 s);
- the campaign on 1 and on 2 workers: end to end (a local Dask cluster started, every chunk
  computed and written as a checksummed Parquet file, the rows loaded, the cluster closed,
  the statistics: what :func:`satfmu.sims.campaign.results.run_campaign` does) and the samples alone
  (:func:`satfmu.sims.campaign.engine.run` on the running cluster), wall s, samples/s, the speed-ups (target
  >= 1.8) and whether the two give the same rows (they must: samples depend on (seed, index)
  only). The two alternate over ``--repeat-campaign`` rounds (min and median);
- the campaign on an external cluster (``--external``, the default): a scheduler and 2 worker
  processes started by Dask's own CLI (``dask scheduler``, ``dask worker``) on the loopback, the
  workers with a satfmu home of their own, so the FMUs reach them by content
  (:mod:`satfmu.sims.campaign.shipment`), as on machines that share no folder with the driver;
  the samples alone, interleaved with the local 2-worker cluster's in each round, the per-sample
  wall time of each and their ratio, and whether the rows are identical.

    python bench/campaign_speed.py [--samples 10000] [--chunk 250] [--repeat 20] [--repeat-campaign 1]
                                   [--cli-samples 4000] [--repeat-cli 2] [--no-external]
"""
from __future__ import annotations

import argparse
import contextlib
import os
import socket
import statistics
import subprocess
import sys
import tempfile
import time
import tomllib
from collections.abc import Iterator
from pathlib import Path

from distributed import Client

import numpy as np
import pandas as pd

from satfmu.sims.campaign import cluster, engine, worker_server
from satfmu.controllers import catalog, paths
from satfmu.sims.scenario import SHIPPED_SCENARIOS
from satfmu.sims.scenario.spec import Scenario
from satfmu.sims.scenario.wiring import grid, recorded
from satfmu.sims.campaign.scenario_task import campaign
from satfmu.sims.campaign.statistics import statistics as campaign_statistics

DISPERSIONS = {"attitude": {"instance": "plant", "kind": "uniform"},
               "inertia": {"instance": "plant", "relative": 0.2}}


def scenario() -> Scenario:
    """mrp_200deg with dispersed attitude and inertia."""
    data = tomllib.loads((SHIPPED_SCENARIOS / "mrp_200deg.toml").read_text())
    return Scenario.from_dict({**data, "dispersions": DISPERSIONS})


@contextlib.contextmanager
def external_cluster(workers: int, home: Path) -> Iterator[str]:
    """A scheduler and ``workers`` single-threaded worker processes started with Dask's CLI on
    the loopback (the workers' satfmu home ``home``, not the driver's); yields the address."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    address = f"tcp://127.0.0.1:{port}"
    dask = str(Path(sys.executable).parent / "dask")
    quiet = {"stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL}
    procs = [subprocess.Popen([dask, "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"],
                              **quiet)]
    env = {**os.environ, **worker_server.WORKER_ENV, "SATFMU_HOME": str(home)}
    procs += [subprocess.Popen([dask, "worker", address, "--nthreads", "1", "--no-nanny", "--no-dashboard",
                                "--host", "127.0.0.1"], env=env, **quiet) for _ in range(workers)]
    try:
        yield address
    finally:
        for p in reversed(procs):
            p.terminate()
            p.wait(timeout=30)


def scenario_toml() -> str:
    """:func:`scenario` as a TOML file's text (what ``satfmu campaign scenario`` reads)."""
    text = (SHIPPED_SCENARIOS / "mrp_200deg.toml").read_text()
    for key, entry in DISPERSIONS.items():
        text += f"\n[dispersions.{key}]\n" + "".join(f"{k} = {v!r}\n".replace("'", '"') for k, v in entry.items())
    return text


def cli_campaign(path: Path, samples: int, fmu_dir: Path, out: Path) -> float:
    """Wall seconds of ``satfmu campaign scenario path --samples N --workers 1`` in its own process
    (bytecode cached, as a user's Python does)."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    argv = [sys.executable, "-m", "satfmu.sims.cli", "campaign", "scenario", str(path), "--samples", str(samples),
            "--workers", "1", "--seed", "1", "--fmu-dir", str(fmu_dir), "--out", str(out), "--name", f"cli-{samples}"]
    t0 = time.perf_counter()
    done = subprocess.run(argv, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if done.returncode not in (0, 1):  # 1: a metric failed on some sample, still a campaign
        sys.exit(f"{' '.join(argv)} failed ({done.returncode}):\n{done.stderr[-2000:]}")
    return wall


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=10_000, help="campaign size (default: 10000)")
    ap.add_argument("--chunk", type=int, default=250, help="samples per chunk (default: 250)")
    ap.add_argument("--repeat", type=int, default=20, help="bare runs timed (default: 20)")
    ap.add_argument("--repeat-campaign", type=int, default=1,
                    help="rounds of the 1- and 2-worker campaigns (default: 1)")
    ap.add_argument("--cli-samples", type=int, default=4000,
                    help="samples of the larger satfmu campaign run (the smaller: a tenth; default: 4000)")
    ap.add_argument("--repeat-cli", type=int, default=2, help="rounds of the two satfmu campaign runs (default: 2)")
    ap.add_argument("--no-external", action="store_true", help="skip the external cluster")
    ap.add_argument("--fmu-dir", type=Path, default=paths.fmu_cache(),
                    help="FMU folder, brought up to date first (default: the user's FMU cache)")
    args = ap.parse_args()
    fmu_dir = args.fmu_dir.resolve()
    catalog.build_all(fmu_dir)
    sc = scenario()
    camp = campaign(sc, args.samples, seed=1, chunk=args.chunk, fmu_dir=fmu_dir)
    task = camp.task
    sim = task.simulation()
    params = {inst: spec.parameters for inst, spec in sc.fmus.items()}
    record = recorded(sc, sim)
    bare = []
    for _ in range(args.repeat):
        t0 = time.process_time()
        sim.run(sc.stop_time, sc.step_size, sc.start_time, params, record, engine="compiled")
        bare.append(time.process_time() - t0)
    task(np.arange(10))  # warm
    n_one = 500
    t0 = time.process_time()
    task(np.arange(n_one))
    per_sample = (time.process_time() - t0) / n_one
    steps = len(grid(sc)) - 1
    print(f"campaign of {sc.name} ({steps} steps of {sc.step_size} s per sample), attitude uniform, inertia +-20 %")
    print(f"one bare compiled run: {min(bare) * 1e3:.3f} ms CPU min, {statistics.median(bare) * 1e3:.3f} ms median "
          f"({args.repeat} runs)")
    print(f"per sample in one process (draw, run, metrics, row; {n_one} samples): {per_sample * 1e3:.3f} ms CPU = "
          f"{per_sample / min(bare):.2f}x the bare run's min, {per_sample / statistics.median(bare):.2f}x its median "
          f"(target <= 1.2)")
    big, small = args.cli_samples, max(args.cli_samples // 10, 1)
    cli: dict[int, list[float]] = {big: [], small: []}
    with tempfile.TemporaryDirectory(prefix="satfmu_campaign_cli_") as tmp:
        path = Path(tmp) / "mrp_200deg_dispersed.toml"
        path.write_text(scenario_toml())
        for k in range(args.repeat_cli):
            for n in (small, big):
                cli[n].append(cli_campaign(path, n, fmu_dir, Path(tmp) / f"round{k}"))
    slope = (min(cli[big]) - min(cli[small])) / (big - small)
    fixed = min(cli[small]) - small * slope
    print(f"satfmu campaign scenario, one worker, {small} and {big} samples ({args.repeat_cli} rounds): "
          f"{min(cli[small]):.2f} s and {min(cli[big]):.2f} s wall min; a sample {slope * 1e3:.3f} ms = "
          f"{slope / min(bare):.2f}x the bare run's min, {slope / statistics.median(bare):.2f}x its median "
          f"(target <= 1.3); the driver's fixed cost {fixed:.2f} s (target < 2 s)")
    walls: dict[int, list[float]] = {1: [], 2: []}
    runs: dict[int, list[float]] = {1: [], 2: []}
    rows: dict[int, pd.DataFrame] = {}
    external: list[float] = []
    stack = contextlib.ExitStack()
    remote = None
    if not args.no_external:
        home = Path(stack.enter_context(tempfile.TemporaryDirectory(prefix="satfmu_worker_home_")))
        remote = stack.enter_context(Client(stack.enter_context(external_cluster(2, home)), timeout=60))
        remote.wait_for_workers(2, timeout=60)
    for _ in range(args.repeat_campaign):
        if remote is not None:
            with tempfile.TemporaryDirectory(prefix="satfmu_campaign_speed_") as tmp:
                t0 = time.perf_counter()
                rows[0] = engine.run(camp, Path(tmp), client=remote)
                external.append(time.perf_counter() - t0)
        for workers in (1, 2):
            with tempfile.TemporaryDirectory(prefix="satfmu_campaign_speed_") as tmp:
                t0 = time.perf_counter()
                with cluster.cluster_client(None, None, workers) as client:
                    client.run(lambda: None)  # every worker up
                    t1 = time.perf_counter()
                    rows[workers] = engine.run(camp, Path(tmp), client=client)
                    runs[workers].append(time.perf_counter() - t1)
                stats = campaign_statistics(sc, rows[workers])
                walls[workers].append(time.perf_counter() - t0)
    print("campaign wall s, min (median): end to end (cluster start, the samples, chunk files, rows loaded, "
          "cluster closed, statistics) and the samples alone (C.run on the running cluster)")
    print(f"{'workers':>8s} {'end to end':>17s} {'samples alone':>17s} {'samples/s':>10s}")
    for w in walls:
        print(f"{w:>8d} {min(walls[w]):8.2f} ({statistics.median(walls[w]):6.2f}) {min(runs[w]):8.2f} "
              f"({statistics.median(runs[w]):6.2f}) {args.samples / min(runs[w]):10.0f}")
    print(f"speed-up on 2 workers (target >= 1.8): end to end {min(walls[1]) / min(walls[2]):.2f}x, the samples "
          f"alone {min(runs[1]) / min(runs[2]):.2f}x (medians "
          f"{statistics.median(walls[1]) / statistics.median(walls[2]):.2f}x, "
          f"{statistics.median(runs[1]) / statistics.median(runs[2]):.2f}x); {args.samples} samples on 2 workers in "
          f"{min(walls[2]):.1f} s end to end (target < 120 s); rows of 1 and 2 workers identical: "
          f"{rows[1].equals(rows[2])}")
    if external:
        local, far = min(runs[2]), min(external)
        print(f"external cluster (dask scheduler + 2 dask worker processes, FMUs sent by content), the samples "
              f"alone: {far:.2f} s min ({statistics.median(external):.2f} median) = {far / args.samples * 1e3:.3f} ms "
              f"a sample, against {local / args.samples * 1e3:.3f} ms on the local 2-worker cluster: "
              f"{far / local:.2f}x (medians {statistics.median(external) / statistics.median(runs[2]):.2f}x); "
              f"rows identical: {rows[0].equals(rows[2])}")
    stack.close()
    print(f"pass rate of the campaign: {stats.overall.pass_rate:.2%}, failed to run: {stats.n_failed}")


if __name__ == "__main__":
    main()
