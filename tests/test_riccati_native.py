"""The native online SDRE's Riccati solver (fmus/c/riccati.h) against its Python twin
(satfmu.controllers.riccati, scipy's solve_continuous_are): same gains, same checks, same refusals.

The header is compiled here with the FMU build's flags (warnings are errors) into a small
library with a two-function shim, for the seed 002 servo's dimensions (n = 7, m = 2) and a
2-state toy (n = 2, m = 1) whose refusals are easy to construct.
"""
from __future__ import annotations

import ctypes
import subprocess
from pathlib import Path

import numpy as np
import pytest

from satfmu.controllers import riccati, servo
from satfmu.fmus import codegen, export
from satfmu.synthesis.servo import sdre

HEADER_DIR = Path(export.__file__).resolve().parent / "c"
_SHIM = """#define SAMPLER_N {n}
#define SAMPLER_M {m}
#include "riccati.h"
#define EXPORT __attribute__((visibility("default"))) /* the FMU flags hide everything else */
EXPORT int gain(const double *v, double *held, char *message, int size) {{
    return riccati_sampled_gain(v, held, message, (size_t)size);
}}
EXPORT void real_parts(const double *a, double *lo, double *hi) {{ ric_real_parts(a, lo, hi); }}
"""
_D = ctypes.POINTER(ctypes.c_double)


class Solver:
    """The compiled header for one (n, m)."""

    def __init__(self, folder: Path, n: int, m: int) -> None:
        self.n, self.m = n, m
        src, lib = folder / f"shim_{n}_{m}.c", folder / f"shim_{n}_{m}.so"
        src.write_text(_SHIM.format(n=n, m=m))
        subprocess.run(["gcc", *export.C_FLAGS, "-shared", f"-I{HEADER_DIR}", "-o", str(lib), str(src), "-lm"],
                       check=True, capture_output=True, text=True)
        self.lib = ctypes.CDLL(str(lib))

    def gain(self, values: np.ndarray) -> tuple[bool, np.ndarray, str]:
        v = np.ascontiguousarray(values, float)
        held = np.zeros(self.n * self.m + 2)
        message = ctypes.create_string_buffer(512)
        ok = self.lib.gain(v.ctypes.data_as(_D), held.ctypes.data_as(_D), message, 512)
        return bool(ok), held, message.value.decode()

    def real_parts(self, a: np.ndarray) -> tuple[float, float]:
        a = np.ascontiguousarray(a, float)
        lo, hi = ctypes.c_double(), ctypes.c_double()
        self.lib.real_parts(a.ctypes.data_as(_D), ctypes.byref(lo), ctypes.byref(hi))
        return lo.value, hi.value


@pytest.fixture(scope="module")
def servo7(tmp_path_factory: pytest.TempPathFactory) -> Solver:
    return Solver(tmp_path_factory.mktemp("riccati"), 7, 2)


@pytest.fixture(scope="module")
def toy2(tmp_path_factory: pytest.TempPathFactory) -> Solver:
    return Solver(tmp_path_factory.mktemp("riccati"), 2, 1)


def _manoeuvre_arguments(name: str) -> np.ndarray:
    """The online servo's sample arguments (Ae, Be, Q, R, eps) at every 10th state of the seed 002
    manoeuvre (the in-process SDRE closed loop, no friction, 15 s) and at 300 random states of the
    approximation's operating box."""
    online = servo.build_online(name)
    gen = codegen.load_python(online)
    names = [v.name for v in online.inputs]
    p = online.parameter_vector().tolist() + [0.0] * len(online.sampler.held)
    refs = [sdre.SEED_REFERENCE_PROFILES[r] for r in ("q2_ref", "q4_ref")]
    from satfmu.fmus.profiles import make

    run = sdre.simulate_servo(sdre.Servo(), lambda t: np.stack([make(r).sample(t) for r in refs], axis=1),
                              plant_params={"friction_on": 0})
    rng = np.random.default_rng(7)
    box = np.column_stack([rng.uniform(-np.pi, np.pi, 300), rng.uniform(0.15, 1.25, 300), rng.uniform(-1, 1, 300),
                           rng.normal(0, 0.1, 300), rng.normal(0, 0.1, 300), rng.uniform(-0.6, 0.6, 300)])
    states = np.vstack([run.x[::10, :6], box])
    rows = []
    for x in states:
        u = dict(q2=x[1], q4=x[2], w1=x[3], w2=x[4], w4=x[5], q2_ref=x[1] + 0.01, q4_ref=x[2] - 0.01)
        rows.append(gen.sample_arguments(0.0, [0.0, 0.0], [u[k] for k in names], p))
    return np.array(rows)


@pytest.mark.parametrize("name", sorted(servo.ONLINE_VARIANTS))
def test_gain_agrees_with_scipy_over_the_seed_002_manoeuvre(servo7: Solver, name: str) -> None:
    args = _manoeuvre_arguments(name)
    worst_k = worst_re = worst_res = 0.0
    for v in args:
        ok, held, message = servo7.gain(v)
        assert ok, message
        ref = np.array(riccati.sampled_gain(v.tolist(), 7, 2))
        worst_k = max(worst_k, float(np.max(np.abs(held[:14] - ref[:14])) / np.max(np.abs(ref[:14]))))
        worst_re = max(worst_re, abs(held[15] - ref[15]))
        worst_res = max(worst_res, held[14])
    # The shifted pair has a mode at -eps = -1e-6 (the conserved p4), which makes P ill-conditioned:
    # scipy's own relative residual reaches 1.3e-9 there, the C solution's (refined by Newton steps)
    # stays below 1e-14. Measured: gains agree to 6.2e-9 of the largest entry, max Re eig(A - B K)
    # (about 0: the uncontrollable mode) to 2.4e-14 1/s.
    assert worst_k < 5e-8
    assert worst_re < 1e-12
    assert worst_res < 1e-12


def test_eigenvalue_real_parts_match_numpy(servo7: Solver) -> None:
    # Hessenberg reduction and Francis double-shift steps: backward stable, so the extreme real
    # parts agree with LAPACK's to a few ulp of |a| (measured 4.5e-15 relative over 2000 matrices:
    # triangular, symmetric, complex pairs, scales 1e-3 to 1e3).
    rng = np.random.default_rng(0)
    for i in range(600):
        a = rng.normal(size=(7, 7)) * (1e-3, 1.0, 1e3)[i % 3]
        if i % 4 == 1:
            a = np.triu(a)
        elif i % 4 == 2:
            a = a + a.T
        ev = np.linalg.eigvals(a).real
        lo, hi = servo7.real_parts(a)
        scale = np.linalg.norm(a)
        assert abs(lo - ev.min()) <= 1e-13 * scale and abs(hi - ev.max()) <= 1e-13 * scale
    lo, hi = servo7.real_parts(np.diag([-3.0, 2.0, 0.0, 1.0, 5.0, -1.0, 4.0])[::-1, ::-1])
    assert (lo, hi) == (-3.0, 5.0)  # diagonal: exact


def _toy(a: list[list[float]], b: list[float], q=(1.0, 1.0), r=1.0, eps=0.0) -> np.ndarray:
    return np.array([*np.ravel(a), *b, *q, r, eps], float)


def test_toy_solution_is_the_closed_form(toy2: Solver) -> None:
    # Double integrator, Q = I, R = 1: P = [[sqrt 3, 1], [1, sqrt 3]], K = [1, sqrt 3].
    ok, held, message = toy2.gain(_toy([[0, 1], [0, 0]], [0, 1]))
    assert ok, message
    np.testing.assert_allclose(held[:2], [1.0, np.sqrt(3.0)], rtol=1e-14)  # a well-conditioned case: ulps
    assert held[2] < 1e-15 and held[3] == pytest.approx(-np.sqrt(3.0) / 2, rel=1e-14)


@pytest.mark.parametrize(("case", "values", "message"), [
    ("NaN in A", _toy([[0, np.nan], [0, 0]], [0, 1]), "A has non-finite entries"),
    ("inf in B", _toy([[0, 1], [0, 0]], [0, np.inf]), "B has non-finite entries"),
    ("NaN in Q", _toy([[0, 1], [0, 0]], [0, 1], q=(np.nan, 1.0)), "Q has non-finite entries"),
    ("negative shift", _toy([[0, 1], [0, 0]], [0, 1], eps=-1.0), "eps must be finite and >= 0, got -1"),
    ("R not positive", _toy([[0, 1], [0, 0]], [0, 1], r=0.0), "R is not positive definite"),
    # the second state is an uncontrollable mode at 0 and weighted: no stabilizing solution unshifted
    ("uncontrollable mode at 0", _toy([[-1, 0], [0, 0]], [1, 0]), "no stabilizing Riccati solution"),
    ("uncontrollable unstable mode", _toy([[-1, 0], [0, 0.5]], [1, 0], eps=1e-6), "no stabilizing Riccati solution"),
    # an uncontrollable unstable mode that the shift moves to the left half-plane: solved, then refused
    ("unstable mode hidden by the shift", _toy([[-1, 0], [0, 5e-4]], [1, 0], eps=1e-3),
     "closed loop A - B K has an unstable mode (max Re 0.0005 1/s > 1e-06)"),
    # a barely controllable unstable mode needs a huge gain
    ("barely controllable", _toy([[1, 0], [0, -1]], [1e-7, 1], eps=1e-6),
     "gain entry 2.41e+07 exceeds 1e+06 (mode barely controllable)"),
])
def test_refusals_name_the_failure(toy2: Solver, case: str, values: np.ndarray, message: str) -> None:
    ok, held, text = toy2.gain(values)
    assert not ok and message in text, (case, text)
    # the Python twin refuses too (its message may name scipy's failure instead)
    with pytest.raises((ValueError, riccati.RiccatiCheckError)):
        riccati.sampled_gain(values.tolist(), 2, 1)


def test_shifted_uncontrollable_mode_is_solved_like_scipy(toy2: Solver) -> None:
    # The VSCMG's situation in miniature: a conserved mode at 0, shifted to -eps.
    v = _toy([[-1, 0], [0, 0]], [1, 0], eps=1e-6)
    ok, held, message = toy2.gain(v)
    assert ok, message
    ref = riccati.sampled_gain(v.tolist(), 2, 1)
    np.testing.assert_allclose(held[:2], ref[:2], rtol=1e-9, atol=1e-12)  # K = [sqrt 2 - 1 - eps..., 0]
    assert abs(held[3] - ref[3]) < 1e-12  # max Re eig(A - B K) = 0 (the conserved mode)
