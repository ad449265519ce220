"""Gram blocks from sign symmetries: Gram sizes and solve time with and without them.

The program is a user's Lyapunov search for a rigid spacecraft's rate damping: Euler's
equations on principal axes with a damping law of linear and cubic terms,

    J w' = -w x (J w) - k w - c |w|^2 w,   J = diag(J1, J2, J3),

and ``V(w)`` a polynomial in the squares ``w_i^2`` (every exponent even; total degrees 2 to
``--degree``) with ``V - eps |w|^2`` and ``-dV/dt - eps |w|^2`` SOS. Flipping the signs of any
two rates leaves the equations unchanged, and with them ``-dV/dt``: its Gram basis splits into
four blocks by the parities of the exponents (``V``'s, all even, into one per parity pattern),
with no loss (:mod:`satfmu.synthesis.core.sign_symmetry`). The two programs (``SOSProgram(sign_symmetry=
True / False)``) are built, solved and verified end to end in interleaved rounds; printed:
every Gram matrix's size and blocks, the largest block, min and median of the build, solve,
verify and total times, and both certificates' verification (the blocks' certificate is
checked as full Gram matrices on the original program).

    python bench/sos_symmetry.py [--degree 8] [--repeat 5]
"""
from __future__ import annotations

import argparse
import time
from dataclasses import dataclass

import numpy as np
import sympy as sp

from timing import interleaved, min_median

from satfmu.synthesis.core.polynomial import Poly, monomials
from satfmu.synthesis.core.sos import SOSProgram, verify

INERTIA = (10.0, 12.0, 8.0)
"""Principal moments of inertia, kg m^2."""
DAMPING = (0.5, 0.1)
"""``k`` (N m s) and ``c`` (N m s^3) of the damping law."""
MARGIN = 1e-3
"""``eps`` of ``V - eps |w|^2`` and ``-dV/dt - eps |w|^2`` (1/s^2 scale of V per (rad/s)^2)."""


@dataclass
class Run:
    """One end-to-end run: Gram blocks per constraint, times (s) and the verification."""

    blocks: list[list[int]]
    build: float
    solve: float
    verify: float
    certified: bool
    min_eig: float

    @property
    def total(self) -> float:
        return self.build + self.solve + self.verify


def rate_damping(degree: int, sign_symmetry: bool) -> Run:
    """Build, solve and verify the rate-damping Lyapunov search (module docstring)."""
    t0 = time.perf_counter()
    w = sp.symbols("w1 w2 w3", real=True)
    J = np.diag(INERTIA)
    k, c = DAMPING
    wv = sp.Matrix(w)
    rhs = -wv.cross(sp.Matrix(J) * wv) - k * wv - c * (wv.T * wv)[0] * wv
    f = [Poly.from_sympy(sp.expand(rhs[i] / J[i, i]), list(w)) for i in range(3)]
    prog = SOSProgram(3, sign_symmetry=sign_symmetry)
    squares = monomials(3, degree // 2, 1)  # V in w_i^2: exponents 2 e, 1 <= |e| <= degree / 2
    V = prog.new_poly(2 * squares)
    r2 = Poly.from_sympy(sum(wi**2 for wi in w), list(w))
    prog.add_sos(V - MARGIN * r2, "V - eps |w|^2")
    vdot = Poly.sum([V.diff(i) * f[i] for i in range(3)])
    prog.add_sos(-vdot - MARGIN * r2, "-dV/dt - eps |w|^2")
    build = time.perf_counter() - t0
    sol = prog.solve()
    t1 = time.perf_counter()
    checks = verify(prog, sol)
    t2 = time.perf_counter()
    return Run([[len(b) for b in con.blocks] for con in prog.sos], build + sol.timings["build"],
               sol.timings["solve"], t2 - t1, all(ch.certified for ch in checks),
               min(ch.min_eig for ch in checks))


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--degree", type=int, default=8, help="largest total degree of V (even; default 8)")
    ap.add_argument("--repeat", type=int, default=5, help="interleaved rounds (default 5)")
    args = ap.parse_args(argv)
    if args.degree < 2 or args.degree % 2:
        ap.error("--degree must be even and at least 2")
    runs = {"blocks": lambda: rate_damping(args.degree, True), "one block": lambda: rate_damping(args.degree, False)}
    for fn in runs.values():  # warm-up (imports, first calls), not timed
        fn()
    out = interleaved(runs, args.repeat)
    print(f"rigid-body rate damping, V of degree {args.degree} in w_i^2, J = diag{INERTIA} kg m^2, "
          f"k = {DAMPING[0]}, c = {DAMPING[1]}; {args.repeat} interleaved rounds, min / median (s)")
    for name, records in out.items():
        r = records[-1]
        largest = max(max(b) for b in r.blocks)
        phases = "  ".join(f"{ph} {min_median([getattr(x, ph) for x in records])[0]:.3f} / "
                           f"{min_median([getattr(x, ph) for x in records])[1]:.3f}"
                           for ph in ("build", "solve", "verify", "total"))
        print(f"{name:>10}: Gram blocks {r.blocks} (largest {largest}); {phases}; "
              f"certified {all(x.certified for x in records)}, min eig {r.min_eig:.2e}")
    solve = {name: min_median([x.solve for x in records])[1] for name, records in out.items()}
    total = {name: min_median([x.total for x in records])[1] for name, records in out.items()}
    print(f"median ratio one block / blocks: solve {solve['one block'] / solve['blocks']:.2f}x, "
          f"end to end {total['one block'] / total['blocks']:.2f}x")


if __name__ == "__main__":
    main()
