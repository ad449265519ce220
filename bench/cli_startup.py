"""Start-up cost of the `satfmu` command line: help, list and version, each as its own process.

Each command runs as ``python -m satfmu.sims.cli ...`` (so it works without the console script), the
commands interleaved and repeated; the script prints the CPU time (the child's user + system,
from ``os.wait4``) and wall time per command (min and median), and whether the median CPU time
meets the 0.5 s target of issue 25.

    python bench/cli_startup.py [--repeat 5]
"""
from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time

COMMANDS = (["--help"], ["list"], ["run", "--help"], ["synth", "--help"], ["--version"])
TARGET = 0.5
"""CPU seconds (user + system) a start-up command may take."""


def _timed(argv: list[str]) -> tuple[float, float]:
    """Wall and CPU seconds (the child's user + system) of one command."""
    t0 = time.perf_counter()
    proc = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    code = os.waitstatus_to_exitcode(status)
    with proc.stderr:
        err = proc.stderr.read().decode()
    if code != 0:
        sys.exit(f"{' '.join(argv)} failed ({code}):\n{err[-2000:]}")
    return wall, usage.ru_utime + usage.ru_stime


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                 formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    ap.add_argument("--repeat", type=int, default=5, help="runs of each command")
    args = ap.parse_args()
    labels = ["satfmu " + " ".join(c) for c in COMMANDS]
    walls: dict[str, list[float]] = {k: [] for k in labels}
    cpus: dict[str, list[float]] = {k: [] for k in labels}
    for _ in range(args.repeat):
        for label, command in zip(labels, COMMANDS):
            wall, cpu = _timed([sys.executable, "-m", "satfmu.sims.cli", *command])
            walls[label].append(wall)
            cpus[label].append(cpu)
    print(f"satfmu start-up, {args.repeat} runs each, interleaved "
          f"(python -m satfmu.sims.cli; target: CPU < {TARGET:g} s):")
    print(f"  {'command':<22} {'CPU min':>8} {'median':>7} {'wall min':>9} {'median':>7}  target")
    for k in labels:
        cpu = statistics.median(cpus[k])
        print(f"  {k:<22} {min(cpus[k]):7.3f}s {cpu:6.3f}s {min(walls[k]):8.3f}s "
              f"{statistics.median(walls[k]):6.3f}s  {'met' if cpu < TARGET else 'MISSED'}")


if __name__ == "__main__":
    main()
