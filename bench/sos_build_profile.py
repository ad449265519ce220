"""Where an SOS program's time goes: build, solve and verify, per program, before and after.

Programs (``--programs``, default all):

- ``t1-global``: seed 000 Theorem 1, global (:func:`satfmu.synthesis.polynomial_feedback.hinf_sos.theorem1`);
- ``t1-regional``: the same on ``|sigma| <= 0.9``;
- ``t8-regional``: seed 001 Theorem 8, slack variant, gamma 0.7, alpha = beta = 0.3 on
  ``|sigma| <= 0.45`` (:func:`satfmu.synthesis.polynomial_feedback.h2hinf_sos.theorem8`);
- ``region-box``: seed 002's region certificate on the operating box
  (:func:`satfmu.synthesis.servo.vscmg_region.certify`, two SOS-matrix conditions);
- ``two-step``: seed 000's two-step iteration over the decay rates [0.005, 0.01] (5000
  samples; two Theorem 1 designs and about twenty L2-gain programs, plus two simulations).

Each run is one child process (the script runs itself with ``--child``)
that first solves a small SOS program (lazy imports out of the way), then times the call
of the program: *solve* is the time inside Clarabel (building its solver object and
``solve()``, every program of the call), *verify* the time inside
:func:`satfmu.synthesis.core.sos.verify`, *build* the rest of the call (polynomial algebra, bases,
coefficient matching, the conic data or cvxpy's canonicalization, reading the solution
back; for ``region-box`` and ``two-step`` also their non-SOS work: the Riccati scaling,
the simulations). Seconds; min and median over ``--repeat`` runs, the runs of every
program and checkout interleaved (the machine is shared and noisy).

``--against DIR`` runs the same programs from another checkout as well (its modules first
on ``PYTHONPATH``; e.g. ``git worktree add --detach ../base <commit>``), alternating with
this one, and prints both and the ratio of medians. ``--cvxpy`` adds this checkout with
the conic problem posed in cvxpy instead (:func:`_via_cvxpy`: the structure cvxpy compiles
fastest, one sparse affine expression of one variable vector per cone) and solved by
cvxpy's Clarabel interface with the same settings: cvxpy's canonicalization then counts
as build. Each run also prints its objective, which must agree to solver tolerance.

    python bench/sos_build_profile.py [--programs t1-global t8-regional] [--repeat 5] [--against ../base] [--cvxpy]
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import Any, Callable

PROGRAMS = ("t1-global", "t1-regional", "t8-regional", "region-box", "two-step")
HERE = Path(__file__).resolve().parents[1]


def _program(name: str) -> Callable[[], float]:
    """The call timed for ``name``; it returns the program's objective."""
    if name == "t1-global":
        from satfmu.synthesis.polynomial_feedback.hinf_sos import theorem1
        return lambda: float(theorem1().Q.trace())
    if name == "t1-regional":
        from satfmu.synthesis.polynomial_feedback.hinf_sos import theorem1
        return lambda: float(theorem1(region=0.9).Q.trace())
    if name == "t8-regional":
        from satfmu.synthesis.polynomial_feedback.h2hinf_sos import theorem8
        return lambda: theorem8(0.7, 0.3, 0.3, "slack").lam
    if name == "region-box":
        from satfmu.controllers import artifact
        from satfmu.controllers.polynomial import ARTIFACTS
        from satfmu.synthesis.servo import vscmg_region
        loop = vscmg_region.ClosedLoop.build(artifact.load(ARTIFACTS / "vscmg_sdre_approx.json"))
        return lambda: vscmg_region.certify(loop, *vscmg_region.OPERATING_BOX).eps
    if name == "two-step":
        from satfmu.synthesis.polynomial_feedback.two_step import two_step
        return lambda: two_step(decay_rates=[0.005, 0.01], n_samples=5_000).best.c
    raise SystemExit(f"unknown program {name!r}; one of {PROGRAMS}")


class _Clock:
    """Seconds spent inside wrapped callables."""

    def __init__(self) -> None:
        self.seconds = 0.0

    def wrap(self, fn: Callable[..., Any]) -> Callable[..., Any]:
        def timed(*args: Any, **kwargs: Any) -> Any:
            t0 = time.perf_counter()
            try:
                return fn(*args, **kwargs)
            finally:
                self.seconds += time.perf_counter() - t0
        return timed


class _TimedSolver:
    """A ``clarabel.DefaultSolver`` whose ``solve`` is timed (attributes forwarded)."""

    def __init__(self, clock: _Clock, solver: Any) -> None:
        self._clock, self._solver = clock, solver

    def solve(self) -> Any:
        return self._clock.wrap(self._solver.solve)()

    def __getattr__(self, name: str) -> Any:
        return getattr(self._solver, name)


def _via_cvxpy(problem: Any, **settings: Any) -> Any:
    """:func:`satfmu.synthesis.core.conic.solve_clarabel`'s work done through cvxpy: one variable vector,
    each cone's rows one sparse affine expression of it, each PSD cone the symmetric matrix
    its scaled svec rows describe; solved by cvxpy's Clarabel interface."""
    import cvxpy as cp
    import numpy as np
    import scipy.sparse as sps

    from satfmu.synthesis.core.conic import SOLVED, ConicResult, svec_indices, svec_scale

    x = cp.Variable(len(problem.q))
    A, b = sps.csr_matrix(problem.A), problem.b
    end = problem.zero + problem.nonneg
    cons = [A[: problem.zero] @ x == b[: problem.zero]] if problem.zero else []
    if problem.nonneg:
        cons.append(A[problem.zero:end] @ x <= b[problem.zero:end])
    for N in problem.psd:
        d = N * (N + 1) // 2
        i, j = svec_indices(N)
        off, unscale = i != j, 1.0 / svec_scale(N)
        U = sps.csr_matrix((np.concatenate([unscale, unscale[off]]),
                            (np.concatenate([j * N + i, (i * N + j)[off]]),
                             np.concatenate([np.arange(d), np.flatnonzero(off)]))),
                           shape=(N * N, d))  # scaled svec -> full matrix, column-major
        S = cp.reshape(U @ b[end:end + d] - (U @ A[end:end + d]) @ x, (N, N), order="F")
        cons.append((S + S.T) / 2 >> 0)
        end += d
    prob = cp.Problem(cp.Minimize(problem.q @ x), cons)
    prob.solve(solver="CLARABEL", **settings)
    status = {v: v for v in SOLVED.values()}.get(prob.status, prob.status)
    if status in SOLVED.values():
        xv = np.asarray(x.value, float)
        return ConicResult(status, xv, float(problem.q @ xv), 0.0)
    return ConicResult(status, None, float("nan"), 0.0)


def _child(name: str, route: str) -> dict[str, Any]:
    """One timed run of ``name`` in this process (``route`` "cvxpy": through :func:`_via_cvxpy`)."""
    import clarabel
    import sympy as sp

    from satfmu.synthesis.core import sos
    from satfmu.synthesis.core.polynomial import Poly

    if route == "cvxpy":
        sos.solve_clarabel = _via_cvxpy  # type: ignore[attr-defined]

    x, y = sp.symbols("x y")
    warm = sos.SOSProgram(2)
    warm.add_sos(Poly.from_sympy((x**2 - y) ** 2 + x**2 + 1, [x, y]), "warm-up")
    sos.verify(warm, warm.solve())
    call = _program(name)
    solve_clock, verify_clock = _Clock(), _Clock()
    make = clarabel.DefaultSolver
    clarabel.DefaultSolver = lambda *a, **k: _TimedSolver(solve_clock, solve_clock.wrap(make)(*a, **k))
    verify = sos.verify
    timed_verify = verify_clock.wrap(verify)
    for module in list(sys.modules.values()):  # every `from satfmu.synthesis.core.sos import verify`
        if getattr(module, "__name__", "").startswith("synthesis.") and getattr(module, "verify", None) is verify:
            module.verify = timed_verify  # type: ignore[attr-defined]
    t0 = time.perf_counter()
    objective = call()
    total = time.perf_counter() - t0
    return {"program": name, "total": total, "solve": solve_clock.seconds, "verify": verify_clock.seconds,
            "build": total - solve_clock.seconds - verify_clock.seconds, "objective": objective}


def _run(name: str, tree: Path, route: str) -> dict[str, Any]:
    """One child run of ``name`` with the modules of checkout ``tree``."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(tree), os.environ.get("PYTHONPATH", "")])}
    done = subprocess.run([sys.executable, __file__, "--child", name, "--route", route], env=env, cwd=tree,
                          capture_output=True, text=True)
    if done.returncode:
        sys.exit(f"{name} in {tree} failed:\n{done.stderr[-3000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                 formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    ap.add_argument("--programs", nargs="+", default=list(PROGRAMS), choices=PROGRAMS)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--against", type=Path, help="another checkout to time alternately with this one")
    ap.add_argument("--cvxpy", action="store_true", help="also this checkout with the conic problem posed in cvxpy")
    ap.add_argument("--child", help=argparse.SUPPRESS)
    ap.add_argument("--route", default="direct", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        print(json.dumps(_child(args.child, args.route)))
        return
    trees = {"this": (HERE, "direct")} | ({"cvxpy": (HERE, "cvxpy")} if args.cvxpy else {}) | \
        ({"against": (args.against.resolve(), "direct")} if args.against else {})
    runs: dict[tuple[str, str], list[dict[str, Any]]] = {(p, t): [] for p in args.programs for t in trees}
    for r in range(args.repeat):
        for p in args.programs:
            for t, (tree, route) in (list(trees.items()) if r % 2 == 0 else list(trees.items())[::-1]):
                runs[p, t].append(_run(p, tree, route))
    keys = ("build", "solve", "verify", "total")
    print(f"seconds, min / median of {args.repeat} interleaved runs" + (f"; against = {trees['against'][0]}"
                                                                       if args.against else ""))
    print(f"{'program':14}{'checkout':10}" + "".join(f"{k:>16}" for k in keys) + f"{'objective':>14}")
    for p in args.programs:
        for t in trees:
            rs = runs[p, t]
            cells = "".join(f"{min(r[k] for r in rs):>7.3f} /{statistics.median(r[k] for r in rs):>7.3f}" for k in keys)
            print(f"{p:14}{t:10}{cells}{rs[0]['objective']:>14.8g}")
        med = {t: {k: statistics.median(r[k] for r in runs[p, t]) for k in keys} for t in trees}
        for t in trees:
            if t != "this":
                print(f"{'median ' + t + ' / this':>24}"
                      + "".join(f"{med[t][k] / med['this'][k]:>15.2f}x" for k in keys))


if __name__ == "__main__":
    main()
