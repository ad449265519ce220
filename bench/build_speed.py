"""`satfmu build` from scratch (parallel and one process) and the rebuild of unchanged models.

Each build runs as its own `satfmu build` process, as a user runs it (imports and model
construction included), into a new temporary folder; the three kinds are interleaved and
repeated, and the script prints wall and CPU time (min and median) per kind:

- ``cold, --jobs N``: every FMU generated and compiled, N processes (default: the CPUs);
- ``cold, --jobs 1``: the same in one process;
- ``no-op``: the same folder again; every FMU already records its build's digest.

    python bench/build_speed.py [--repeat 2]
"""
from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

SATFMU = Path(sys.executable).with_name("satfmu")


def _timed(argv: list[str]) -> tuple[float, float, str]:
    """Wall and CPU seconds (the child's user + system) of one command, and its last line."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(argv, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        sys.exit(f"{' '.join(argv)} failed:\n{proc.stdout[-2000:]}{proc.stderr[-2000:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu, proc.stdout.strip().splitlines()[-1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    args = ap.parse_args()
    kinds = [f"cold, --jobs {args.jobs}", "cold, --jobs 1", "no-op"]
    walls: dict[str, list[float]] = {k: [] for k in kinds}
    cpus: dict[str, list[float]] = {k: [] for k in kinds}
    last = ""
    for _ in range(args.repeat):
        with tempfile.TemporaryDirectory(prefix="satfmu_bench_build_") as a, \
                tempfile.TemporaryDirectory(prefix="satfmu_bench_build_") as b:
            runs = [(kinds[0], [str(SATFMU), "build", "--fmu-dir", a, "--jobs", str(args.jobs)]),
                    (kinds[1], [str(SATFMU), "build", "--fmu-dir", b, "--jobs", "1"]),
                    (kinds[2], [str(SATFMU), "build", "--fmu-dir", a])]
            for kind, argv in runs:
                wall, cpu, line = _timed(argv)
                walls[kind].append(wall)
                cpus[kind].append(cpu)
                last = line if kind == kinds[0] else last
    print(f"satfmu build, {args.repeat} runs each, interleaved ({last.split(':')[0]}):")
    print(f"  {'kind':<16} {'wall min':>9} {'median':>8} {'CPU min':>9} {'median':>8}")
    for k in kinds:
        print(f"  {k:<16} {min(walls[k]):8.1f}s {statistics.median(walls[k]):7.1f}s "
              f"{min(cpus[k]):8.1f}s {statistics.median(cpus[k]):7.1f}s")
    speedup = statistics.median(walls[kinds[1]]) / statistics.median(walls[kinds[0]])
    print(f"  parallel speed-up (median wall, --jobs 1 / --jobs {args.jobs}): {speedup:.2f}x")


if __name__ == "__main__":
    main()
