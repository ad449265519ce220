"""Fixed cost of ``satfmu run`` on a shipped scenario, its FMUs built: end to end, and where it goes.

1. End to end: ``python -m satfmu.sims.cli run SCENARIO --fmu-dir DIR --out TMP`` as its own
   process, the scenarios interleaved and repeated; the child's CPU time (user + system, from
   ``os.wait4``) and wall time, min and median, against issue 59's target (CPU < 0.5 s). Python
   writes its bytecode cache (``PYTHONDONTWRITEBYTECODE`` is dropped for the children): a warm run.
2. Where it goes, in one child per scenario: the CPU time (``time.process_time``) of the
   interpreter's start (``python -c pass``), the imports of the run path, loading the scenario, and
   the phases of :func:`satfmu.sims.scenario.run.run` (FMU provisioning and preflight, the
   co-simulation, the metrics, and each file :meth:`satfmu.sims.scenario.result.Result.write`
   writes), each phase timed by wrapping its function (min over the repeats); then what
   ``--plot`` adds (matplotlib's imports and the figure), drawn after the run.

    python bench/run_overhead.py [--fmu-dir build/fmus] [--repeat 5] [mrp_200deg cubesat_detumble ...]
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

TARGET = 0.5
"""CPU seconds (user + system) a warm ``satfmu run`` of a shipped scenario may take (issue 59)."""
SCENARIOS = ("mrp_200deg", "cubesat_detumble", "rw4_slew_published")
"""Default scenarios: the rigid MRP loop, the magnetorquer B-dot, the four-wheel slew."""

_PHASES = r'''
import json, os, sys, time
for name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):  # as satfmu run sets them
    os.environ.setdefault(name, "1")
t0 = time.process_time()
import satfmu.sims.scenario.run as run_module
from satfmu.sims.scenario import result as result_module, provisioning
from satfmu.sims.cosim import master
from satfmu.sims.scenario.spec import load
timings = {"imports": time.process_time() - t0}

def timed(owner, name, label):
    original = getattr(owner, name)
    def wrapper(*args, **kwargs):
        start = time.process_time()
        try:
            return original(*args, **kwargs)
        finally:
            timings[label] = timings.get(label, 0.0) + time.process_time() - start
    setattr(owner, name, wrapper)

timed(run_module, "ensure_fmus", "FMU provisioning and preflight")
timed(master.CoSimulation, "run", "co-simulation")
timed(run_module, "evaluate", "metrics")
timed(result_module, "write_csv", "CSV")
timed(result_module.Result, "write", "all files")
t1 = time.process_time()
scenario = load(sys.argv[1])
timings["load scenario"] = time.process_time() - t1
t2 = time.process_time()
result = run_module.run(scenario, sys.argv[2], "native", sys.argv[3])
timings["run (all phases)"] = time.process_time() - t2
t3 = time.process_time()
result.plot(os.path.join(sys.argv[3], "plot.png"))
timings["the plot (satfmu run --plot)"] = time.process_time() - t3
print(json.dumps(timings))
'''


def _child_env() -> dict[str, str]:
    env = dict(os.environ)
    env.pop("PYTHONDONTWRITEBYTECODE", None)  # a user's Python caches bytecode
    return env


def _run_child(argv: list[str]) -> tuple[float, float, str]:
    """Wall and CPU seconds of a child and its output, the CPU read with wait4 before reaping."""
    t0 = time.perf_counter()
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err:
        proc = subprocess.Popen(argv, stdout=out, stderr=err, env=_child_env())
        _, status, usage = os.wait4(proc.pid, 0)
        wall = time.perf_counter() - t0
        proc.returncode = os.waitstatus_to_exitcode(status)
        out.seek(0)
        err.seek(0)
        text, problems = out.read().decode(), err.read().decode()
    if proc.returncode not in (0, 1):  # 1: a scenario failed its metrics, still a run
        sys.exit(f"{' '.join(argv)} failed ({proc.returncode}):\n{problems[-2000:]}")
    return wall, usage.ru_utime + usage.ru_stime, text


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                 formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    ap.add_argument("scenarios", nargs="*", default=list(SCENARIOS), help="shipped scenarios")
    ap.add_argument("--fmu-dir", default="build/fmus", help="folder of the built FMUs")
    ap.add_argument("--repeat", type=int, default=5, help="runs of each scenario")
    args = ap.parse_args()
    fmu_dir = str(Path(args.fmu_dir).resolve())
    with tempfile.TemporaryDirectory(prefix="satfmu_bench_") as tmp:
        cpus: dict[str, list[float]] = {s: [] for s in args.scenarios}
        walls: dict[str, list[float]] = {s: [] for s in args.scenarios}
        phases: dict[str, list[dict[str, float]]] = {s: [] for s in args.scenarios}
        starts: list[float] = []
        for _ in range(args.repeat):
            starts.append(_run_child([sys.executable, "-c", "pass"])[1])
            for s in args.scenarios:
                wall, cpu, _ = _run_child([sys.executable, "-m", "satfmu.sims.cli", "run", s, "--fmu-dir", fmu_dir,
                                           "--out", tmp])
                cpus[s].append(cpu)
                walls[s].append(wall)
                out = _run_child([sys.executable, "-c", _PHASES, s, fmu_dir, tmp])[2]
                phases[s].append(json.loads(out.strip().splitlines()[-1]))
    load = os.getloadavg()
    print(f"satfmu run, warm (FMUs built in {args.fmu_dir}, bytecode cached), {args.repeat} runs each, interleaved; "
          f"load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} on {os.cpu_count()} CPUs")
    print(f"  {'scenario':<20} {'CPU min':>8} {'median':>7} {'wall min':>9} {'median':>7}  target CPU < {TARGET:g} s")
    for s in args.scenarios:
        cpu = statistics.median(cpus[s])
        print(f"  {s:<20} {min(cpus[s]):7.3f}s {cpu:6.3f}s {min(walls[s]):8.3f}s {statistics.median(walls[s]):6.3f}s"
              f"  {'met' if cpu < TARGET else 'MISSED'}")
    print(f"\nwhere the CPU goes (min over {args.repeat} runs, s; python -c pass: {min(starts):.3f} s):")
    labels = list(dict.fromkeys(k for s in args.scenarios for p in phases[s] for k in p))
    print(f"  {'phase':<32}" + "".join(f" {s[:14]:>14}" for s in args.scenarios))
    for label in labels:
        row = [min(p.get(label, 0.0) for p in phases[s]) for s in args.scenarios]
        print(f"  {label:<32}" + "".join(f" {v:14.3f}" for v in row))


if __name__ == "__main__":
    main()
