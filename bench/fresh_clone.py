"""`make demo` and `make test` on fresh clones, timed as a new user meets them.

For each target, the committed HEAD of this repository is cloned into a new temporary folder
(uncommitted changes are not included) and `make TARGET` runs there from nothing: a new
`.venv`, the install (from pip's cache when it is warm), the FMU build, then the target's
stages. The script prints the wall and CPU time of the whole command, the number of lines it
printed, and each stage's wall and CPU time from the clone's `build/logs/stages.tsv`
(written by `scripts/stage.sh`).

    python bench/fresh_clone.py [--targets demo test] [--keep]
"""
from __future__ import annotations

import argparse
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _run_target(target: str, keep: bool) -> None:
    tmp = Path(tempfile.mkdtemp(prefix=f"satfmu_fresh_{target}_"))
    clone = tmp / "satfmu"
    subprocess.run(["git", "clone", "--quiet", str(ROOT), str(clone)], check=True)
    head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=clone, capture_output=True,
                          text=True).stdout.strip()
    env = {k: v for k, v in os.environ.items() if k not in ("VIRTUAL_ENV", "PYTHONPATH")}
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(["make", target], cwd=clone, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    output = proc.stdout + proc.stderr
    (tmp / f"make_{target}.log").write_text(output)
    status = "ok" if proc.returncode == 0 else f"FAILED (exit {proc.returncode})"
    print(f"make {target} on a fresh clone of {head}: {status}, {wall:.0f} s wall ({wall / 60:.1f} min), "
          f"{cpu:.0f} s CPU, {len(output.splitlines())} lines printed")
    stages = clone / "build" / "logs" / "stages.tsv"
    if stages.is_file():
        print(f"  {'stage':<18} {'wall':>8} {'CPU':>8}")
        for line in stages.read_text().splitlines():
            label, stage_wall, stage_cpu, rc = line.split("\t")
            mark = "" if rc == "0" else f"  exit {rc}"
            print(f"  {label:<18} {float(stage_wall):7.1f}s {float(stage_cpu):7.1f}s{mark}")
    if proc.returncode != 0:
        print("  last lines:\n" + "\n".join("    " + s for s in output.splitlines()[-30:]))
    if keep:
        print(f"  kept {clone} and {tmp / f'make_{target}.log'}")
    else:
        shutil.rmtree(tmp, ignore_errors=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--targets", nargs="+", default=["demo", "test"], choices=["demo", "test", "test-all"])
    ap.add_argument("--keep", action="store_true", help="keep the clones and the make logs")
    args = ap.parse_args()
    print(f"{os.cpu_count()} CPUs; load average {os.getloadavg()[0]:.2f} at the start", flush=True)
    for target in args.targets:
        _run_target(target, args.keep)
        sys.stdout.flush()


if __name__ == "__main__":
    main()
