"""SOS engine speed: seed 000 Theorem 1 through satfmu vs through SumOfSquares.py, same run.

The program (docs/models.md, seed 000, "global, semi-definite + LaSalle"): constant
``Q >= I``, ``K(x)`` 3 x 6 of degree 2, ``-(A(x) Q + Q A(x)^T + B K + K^T B^T) - diag(eps I3, 0)``
an SOS matrix, minimize trace(Q). End to end = build + solve + verify (Gram minimum
eigenvalue and coefficient residual of the SOS-matrix constraint):

- satfmu: :func:`synthesis.hinf_sos.theorem1` (numpy coefficient matching, cvxpy,
  Clarabel; verification included in the call).
- SumOfSquares.py (PyPI, bench-only extra ``pip install -e '.[bench]'``): the same
  program written with its sympy/picos API (``add_matrix_sos_constraint`` with Newton
  polytope reduction), solved by CVXOPT (picos offers no Clarabel interface), then the
  same two checks on its Gram matrix.

Both are timed as the best of ``--repeat`` runs in this one process and reported as
seconds and as the ratio (the machine is shared and noisy: ratios hold, absolute
numbers drift). Prints the objective of both, which must agree.

    python bench/sos_speed.py [--repeat 3]
"""
from __future__ import annotations

import argparse
import time
from typing import Any, Callable

import numpy as np
import sympy as sp

from fmus import mrp_satellite
from synthesis.hinf_sos import theorem1

RATE_MARGIN = 1e-2


def ours() -> dict[str, Any]:
    t0 = time.perf_counter()
    res = theorem1(rate_margin=RATE_MARGIN)
    total = time.perf_counter() - t0
    main = res.checks[-1]
    return {"total": total, "build": res.timings["build"], "solve": res.timings["solve"],
            "verify": res.timings["verify"], "trace": float(np.trace(res.Q)), "basis": main.basis_size, "min_eig": main.min_eig,
            "residual": main.residual, "certified": res.certified}


def sumofsquares() -> dict[str, Any]:
    from SumOfSquares import SOSProblem, poly_variable

    t0 = time.perf_counter()
    model = mrp_satellite.MODEL
    xs = [s.symbol for s in model.states]
    subs = {v.symbol: v.start for v in model.parameters}
    A = model.sdc.A.subs(subs)  # type: ignore[union-attr]
    n, m = 6, 3
    prob = SOSProblem()
    qs = {}
    Q = sp.zeros(n, n)
    for i in range(n):
        for j in range(i, n):
            qs[i, j] = sp.Symbol(f"q_{i}_{j}")
            Q[i, j] = Q[j, i] = qs[i, j]
    K = sp.Matrix(m, n, lambda i, j: poly_variable(f"k_{i}_{j}", xs, 2))
    Bf = sp.Matrix(sp.BlockMatrix([[sp.eye(m)], [sp.zeros(n - m, m)]]))
    M = A * Q + Q * A.T + Bf * K + K.T * Bf.T
    E = sp.diag(*([RATE_MARGIN] * m + [0] * (n - m)))
    const = prob.add_matrix_sos_constraint(sp.expand(-M - E), xs, sparse=True)
    Qp = prob.sp_mat_to_picos(Q)
    prob.add_constraint(Qp - np.eye(n) >> 0)
    prob.set_objective("min", sum(prob.sym_to_var(qs[i, i]) for i in range(n)))
    build = time.perf_counter() - t0
    t1 = time.perf_counter()
    prob.solve(solver="cvxopt")
    solve = time.perf_counter() - t1
    # the same two checks: Gram eigenvalue, coefficient residual of p - b^T G b
    G = np.array(const.Qval, float)
    min_eig = float(np.linalg.eigvalsh(G).min())
    p = prob.subs_with_sol(sp.expand((sp.Matrix([const.symbols[:n]]) * (-M - E) * sp.Matrix(const.symbols[:n]))[0]))
    # SumOfSquares.py leaves coefficients of monomials outside its basis products
    # unconstrained (they never reach the solver); SOS needs them zero, so set them so
    p = p.subs({s: 0 for s in p.free_symbols - set(const.symbols)})
    b = sp.Matrix(const.b_sym)
    diff = sp.Poly(sp.expand(p - (b.T * sp.Matrix(G) * b)[0]), *const.symbols)
    residual = float(max(abs(float(c)) for c in diff.coeffs()))
    total = time.perf_counter() - t0
    trace = float(sum(prob.sym_to_var(qs[i, i]).value for i in range(n)))
    return {"total": total, "build": build, "solve": solve, "verify": total - build - solve, "trace": trace, "basis": G.shape[0],
            "min_eig": min_eig, "residual": residual, "certified": None}


def _best(fn: Callable[[], dict[str, Any]], repeat: int) -> dict[str, Any]:
    runs = [fn() for _ in range(repeat)]
    return min(runs, key=lambda r: r["total"])


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    a = _best(ours, args.repeat)
    try:
        b = _best(sumofsquares, args.repeat)
    except ImportError:
        raise SystemExit("SumOfSquares.py is not installed: pip install -e '.[bench]'") from None
    print("seed 000 Theorem 1 (global), best of", args.repeat)
    print(f"{'':16}{'build s':>10}{'solve s':>10}{'verify s':>10}{'total s':>10}{'trace Q':>12}{'Gram N':>8}{'min eig':>11}"
          f"{'residual':>11}")
    for name, r in (("satfmu", a), ("SumOfSquares", b)):
        print(f"{name:16}{r['build']:>10.3f}{r['solve']:>10.3f}{r['verify']:>10.3f}{r['total']:>10.3f}{r['trace']:>12.5f}"
              f"{r['basis']:>8d}{r['min_eig']:>11.2e}{r['residual']:>11.2e}")
    print(f"end to end: satfmu is {b['total'] / a['total']:.1f}x faster "
          f"(build {b['build'] / a['build']:.0f}x, solve {b['solve'] / a['solve']:.1f}x); "
          f"objectives differ by {abs(a['trace'] - b['trace']):.2e}")


if __name__ == "__main__":
    main()
