"""Memory of a long scenario run that records every step: the run's rows kept, or streamed.

mrp_200deg (seed 000's published controller, 10 recorded signals) run for ``--steps``
communication steps of 0.05 s, in its own process, three ways: ``satfmu.run(..., out_dir=...)``
(every row kept in memory, then written), ``satfmu.run(..., out_dir=..., stream=True)`` (the CSV
written and the metrics evaluated a block of rows at a time, no row kept) and ``satfmu run``
(which streams), for each of ``--steps``: a streamed run's peak should not grow with the steps.
Printed: each child's peak resident memory (``ru_maxrss``), its CPU time, the CSV's size and
whether the three CSV files are identical.

    python bench/recording_memory.py [--steps 100000 1000000] [--fmu-dir build/fmus]
"""
from __future__ import annotations

import argparse
import hashlib
import os
import subprocess
import sys
import tempfile
import tomllib
from pathlib import Path

from satfmu.sims.scenario import SHIPPED_SCENARIOS

_LIBRARY = r'''
import sys
import satfmu
satfmu.run(sys.argv[1], fmu_dir=sys.argv[2], out_dir=sys.argv[3], stream=sys.argv[4] == "stream")
'''


def _child(argv: list[str], allowed: tuple[int, ...]) -> tuple[float, float]:
    """Peak resident memory (MB) and CPU seconds of a child process (its exit status one of ``allowed``)."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env.setdefault("OPENBLAS_NUM_THREADS", "1")
    proc = subprocess.Popen(argv, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(proc.pid, 0)
    if os.waitstatus_to_exitcode(status) not in allowed:
        sys.exit(f"{' '.join(argv)} failed:\n{proc.stderr.read().decode()[-2000:] if proc.stderr else ''}")
    return usage.ru_maxrss / 1024, usage.ru_utime + usage.ru_stime


def _digest(path: Path) -> str:
    """SHA-256 of a file read in 1 MiB chunks: this process must stay small, since Linux carries a
    process's peak resident memory over into the children it starts (``ru_maxrss`` survives
    ``execve``), and reading a whole 124 MB CSV here showed up as the next child's peak."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, nargs="+", default=[100_000, 1_000_000],
                    help="communication steps of 0.05 s, one run each (default: 1e5 and 1e6)")
    ap.add_argument("--fmu-dir", default="build/fmus", help="folder of the built FMUs")
    args = ap.parse_args()
    fmu_dir = str(Path(args.fmu_dir).resolve())
    text = (SHIPPED_SCENARIOS / "mrp_200deg.toml").read_text()
    step = tomllib.loads(text)["step_size"]
    for steps in args.steps:
        with tempfile.TemporaryDirectory(prefix="satfmu_recording_") as tmp:
            path = Path(tmp) / "mrp_200deg.toml"
            path.write_text(text.replace("stop_time = 120.0", f"stop_time = {steps * step!r}"))
            runs = {"satfmu.run, rows kept": [sys.executable, "-c", _LIBRARY, str(path), fmu_dir, f"{tmp}/kept",
                                              "keep"],
                    "satfmu.run(stream=True)": [sys.executable, "-c", _LIBRARY, str(path), fmu_dir, f"{tmp}/lib",
                                                "stream"],
                    "satfmu run (streams)": [sys.executable, "-m", "satfmu.sims.cli", "run", str(path), "--fmu-dir",
                                             fmu_dir, "--out", f"{tmp}/cli"]}
            print(f"mrp_200deg for {steps} steps of {step} s, every step recorded (10 signals)")
            digests = set()
            for (label, argv), folder in zip(runs.items(), ("kept", "lib", "cli")):
                peak, cpu = _child(argv, (0, 1) if folder == "cli" else (0,))  # satfmu run: 1 if a metric failed
                csv = Path(tmp) / folder / "mrp_200deg" / "mrp_200deg_native.csv"
                digests.add(_digest(csv))
                print(f"  {label:<26} peak RSS {peak:7.1f} MB  CPU {cpu:6.2f} s  CSV {csv.stat().st_size / 1e6:6.1f} "
                      f"MB ({peak * 1e6 / steps:.0f} B per step)")
            print(f"  the three CSV files identical: {len(digests) == 1}")


if __name__ == "__main__":
    main()
