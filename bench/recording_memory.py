"""Memory of a long scenario run that records every step: the run's rows kept, or streamed.

mrp_200deg (seed 000's published controller, 10 recorded signals) run for ``--steps``
communication steps of 0.05 s, in its own process, three ways: ``satfmu.run(..., out_dir=...)``
(every row kept in memory, then written), ``satfmu.run(..., out_dir=..., stream=True)`` (the CSV
written and the metrics evaluated a block of rows at a time, only ``time`` kept) and ``satfmu run``
(which streams).
Printed: each child's peak resident memory (``ru_maxrss``), its CPU time, the CSV's size and
whether the three CSV files are identical.

    python bench/recording_memory.py [--steps 1000000] [--fmu-dir build/fmus]
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


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=1_000_000, help="communication steps of 0.05 s")
    ap.add_argument("--fmu-dir", default="build/fmus", help="folder of the built FMUs")
    args = ap.parse_args()
    fmu_dir = str(Path(args.fmu_dir).resolve())
    text = (SHIPPED_SCENARIOS / "mrp_200deg.toml").read_text()
    step = tomllib.loads(text)["step_size"]
    with tempfile.TemporaryDirectory(prefix="satfmu_recording_") as tmp:
        path = Path(tmp) / "mrp_200deg.toml"
        path.write_text(text.replace("stop_time = 120.0", f"stop_time = {args.steps * step!r}"))
        runs = {"satfmu.run, rows kept": [sys.executable, "-c", _LIBRARY, str(path), fmu_dir, f"{tmp}/kept", "keep"],
                "satfmu.run(stream=True)": [sys.executable, "-c", _LIBRARY, str(path), fmu_dir, f"{tmp}/lib",
                                            "stream"],
                "satfmu run (streams)": [sys.executable, "-m", "satfmu.sims.cli", "run", str(path), "--fmu-dir",
                                         fmu_dir, "--out", f"{tmp}/cli"]}
        print(f"mrp_200deg for {args.steps} steps of {step} s, every step recorded (10 signals)")
        digests = set()
        for (label, argv), folder in zip(runs.items(), ("kept", "lib", "cli")):
            peak, cpu = _child(argv, (0, 1) if folder == "cli" else (0,))  # satfmu run: 1 if a metric failed
            csv = Path(tmp) / folder / "mrp_200deg" / "mrp_200deg_native.csv"
            digests.add(hashlib.sha256(csv.read_bytes()).hexdigest())
            print(f"  {label:<26} peak RSS {peak:7.1f} MB  CPU {cpu:6.2f} s  CSV {csv.stat().st_size / 1e6:6.1f} MB "
                  f"({peak * 1e6 / args.steps:.0f} B per step)")
        print(f"  the three CSV files identical: {len(digests) == 1}")


if __name__ == "__main__":
    main()
