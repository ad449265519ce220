"""Command line of the suite (``satfmu robustness``, ``python -m satfmu.sims.robustness``)."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from satfmu.sims.robustness.cases import FAR_FACTOR
from satfmu.sims.robustness.runner import run
from satfmu.sims.robustness.results import markdown
from satfmu.sims.robustness.table import Settings
from satfmu.sims.robustness.target import discover
from satfmu.sims.robustness.worker import work


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m satfmu.sims.robustness",
                                description="Drive every FMU through misuse cases "
                                            "(cases x FMUs, each FMU in a child process).")
    p.add_argument("--fmu-dir", type=Path, default=Path("build/fmus"), help="folder of the FMUs (every *.fmu)")
    p.add_argument("--fmu", action="append", help="test only this FMU (repeatable; name with or without .fmu)")
    p.add_argument("--cycles", type=int, default=1000, help="instantiate/free cycles of the memory case")
    p.add_argument("--out", type=Path, help="write OUT.md and OUT.csv")
    p.add_argument("--far-factor", type=float, default=FAR_FACTOR, help="far step in default step sizes")
    p.add_argument("--flips", type=int, help="single-bit flips per native FMU state, a seeded sample "
                   "(default: every bit)")
    p.add_argument("--worker", type=Path, help=argparse.SUPPRESS)
    p.add_argument("--results", type=Path, help=argparse.SUPPRESS)
    p.add_argument("cases", nargs="*", help=argparse.SUPPRESS)
    return p


def main(argv: list[str] | None = None) -> int:
    """Command line: run the suite and print the report; exit code 0 if every case passed (or is
    n/a), 1 on any failure or crash, 2 if there is no FMU to test.

    Parameters
    ----------
    argv : list of str, optional
        The arguments (default: ``sys.argv[1:]``): ``--fmu-dir``, ``--fmu``, ``--cycles``,
        ``--out``, ``--far-factor``, ``--flips``; with ``--worker FMU --results FILE CASE ...``
        it runs as a worker (:func:`~satfmu.sims.robustness.worker.work`) and returns 0.

    Returns
    -------
    int
        The exit code.
    """
    args = _parser().parse_args(argv)
    if args.worker is not None:
        work(args.worker, args.cases, Settings(args.cycles, args.far_factor, args.flips), args.results)
        return 0
    try:
        if not discover(args.fmu_dir, args.fmu):
            raise FileNotFoundError(f"no FMI 2.0 co-simulation *.fmu in {args.fmu_dir}; run `satfmu build` first")
        report = run(args.fmu_dir, args.fmu, args.cycles, args.out, far_factor=args.far_factor, flips=args.flips)
    except (FileNotFoundError, ValueError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(markdown(report))
    return 0 if report.ok else 1

