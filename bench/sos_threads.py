"""Clarabel's thread count on SOS programs: wall and CPU time of one thread against every core.

The Clarabel wheel factors its KKT systems with faer, on every core by default
(``max_threads`` 0). On a small program the threads buy no wall time and cost CPU (a campaign
of designs, or a second worker, pays for it); on a large one they shorten the solve.
:func:`satfmu.synthesis.core.conic.solve_clarabel` therefore gives Clarabel one thread below
:data:`satfmu.synthesis.core.conic.THREADED_FROM` (the side of the largest PSD cone) and every
core from there on. This bench measures what that rule rests on:

- the conic problems of the bench programs (``bench/sos_speed.py``: seed 000's Theorem 1
  global and regional, seed 001's Theorem 8, and with ``--vscmg`` seed 002's region
  certificate, about 50 s a solve), caught from the public functions as a user calls them;
- a scan of single SOS programs: the largest lower bound of a random sum of squares of
  degree 4 in ``n`` variables (one Gram matrix of side ``(n + 1)(n + 2) / 2``: 21 to 78 for
  ``n`` = 5 to 11).

Each problem is solved by Clarabel as ``solve_clarabel`` calls it, with ``max_threads`` 1 and 0,
interleaved (the machine is shared and noisy); printed: iterations, min and median wall time,
median process CPU time, the ratios of medians every-core / one-thread and the thread count
the rule picks.

    python bench/sos_threads.py [--repeat 5] [--scan 5 6 7 8 9 10 11] [--vscmg]
"""
from __future__ import annotations

import argparse
import os
import time
from dataclasses import dataclass
from typing import Callable

import numpy as np

from satfmu.synthesis.core.conic import THREADED_FROM, ConicProblem, solve_clarabel, threads_for
from satfmu.synthesis.core.polynomial import Poly, monomials
from satfmu.synthesis.core.sos import SOSProgram
from sos_speed import programs, run_ours
from timing import interleaved, min_median


@dataclass
class Solve:
    """One solve: wall and process CPU time, s, and Clarabel's iterations."""

    wall: float
    cpu: float
    iterations: int


def lower_bound_problem(n_vars: int, seed: int = 0) -> ConicProblem:
    """``max t`` such that ``p - t`` is SOS, for ``p = z^T G z`` with a random positive definite
    ``G`` on all monomials ``z`` of degree <= 2 in ``n_vars`` variables (one dense Gram block)."""
    rng = np.random.default_rng(seed)
    z = monomials(n_vars, 2)
    R = rng.normal(size=(len(z), len(z)))
    G = R @ R.T / len(z)
    i, j = np.triu_indices(len(z))
    p = Poly.numeric(z[i] + z[j], np.where(i == j, 1.0, 2.0) * G[i, j])
    prog = SOSProgram(n_vars)
    t = prog.new_poly(np.zeros((1, n_vars), np.int64))
    prog.add_sos(p - t, "p - t")
    return prog.conic_problem(objective=-t.C)


def caught_problem(fn: Callable[[], object]) -> tuple[ConicProblem, dict[str, float]]:
    """The conic problem a public function solves, with the settings it asks for."""
    _, caught = run_ours(fn)
    return caught.program.conic_problem(caught.objective), caught.settings


def timed(problem: ConicProblem, settings: dict[str, float], threads: int) -> Solve:
    """One solve by :func:`solve_clarabel` with ``max_threads`` = ``threads``."""
    w0, c0 = time.perf_counter(), time.process_time()
    result = solve_clarabel(problem, max_threads=threads, **settings)
    wall, cpu = time.perf_counter() - w0, time.process_time() - c0
    if result.status not in ("optimal", "optimal_inaccurate"):
        raise RuntimeError(f"Clarabel: {result.status}")
    return Solve(wall, cpu, result.iterations)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5, help="interleaved rounds (default: 5)")
    ap.add_argument("--scan", type=int, nargs="*", default=[5, 6, 7, 8, 9, 10, 11],
                    help="variables of the lower-bound programs (default: 5 to 11)")
    ap.add_argument("--vscmg", action="store_true", help="also seed 002's region certificate (~50 s a solve)")
    args = ap.parse_args(argv)
    problems: dict[str, tuple[ConicProblem, dict[str, float]]] = {}
    for prog in programs():
        if prog.key != "vscmg-box" or args.vscmg:
            problems[prog.key] = caught_problem(prog.ours)
    for n in args.scan:
        problems[f"lower bound n={n}"] = (lower_bound_problem(n), {})
    print(f"{os.cpu_count()} cores; THREADED_FROM = {THREADED_FROM} (largest PSD cone side from which every core "
          f"is used); {args.repeat} interleaved rounds\n")
    print(f"{'program':22}{'PSD sides':>18}{'iter':>5}  {'wall 1 thread':>16}{'wall all':>16}  "
          f"{'CPU 1':>7}{'CPU all':>8}  {'wall all/1':>10}{'CPU all/1':>10}  {'rule':>5}")
    print(f"{'':52}{'(min / median s)':>18}")
    for name, (problem, settings) in problems.items():
        runs = {"1": lambda p=problem, s=settings: timed(p, s, 1), "all": lambda p=problem, s=settings: timed(p, s, 0)}
        out = interleaved(runs, args.repeat)
        wall = {k: min_median([r.wall for r in rs]) for k, rs in out.items()}
        cpu = {k: min_median([r.cpu for r in rs])[1] for k, rs in out.items()}
        sides = sorted(problem.psd, reverse=True)
        shown = ",".join(map(str, sides[:3])) + (",..." if len(sides) > 3 else "")
        rule = threads_for(problem)
        print(f"{name:22}{shown:>18}{out['1'][0].iterations:5d}  "
              f"{wall['1'][0]:7.3f} /{wall['1'][1]:7.3f}{wall['all'][0]:7.3f} /{wall['all'][1]:7.3f}  "
              f"{cpu['1']:7.3f}{cpu['all']:8.3f}  {wall['all'][1] / wall['1'][1]:10.2f}{cpu['all'] / cpu['1']:10.2f}"
              f"  {'all' if rule == 0 else rule:>5}")


if __name__ == "__main__":
    main()
