"""Exact system norms: the H-infinity norm against closed forms and an independent frequency
sweep, one system and stacks; the impulse-to-peak value against closed forms; bad input."""
from __future__ import annotations

import math

import numpy as np
import pytest

from satfmu.synthesis.robust.lft_plant import NotHurwitzError, OptionError, PlantDataError
from satfmu.synthesis.core.system_norms import hinf_norm, impulse_to_peak

TOL = 1e-9
"""hinf_norm's default tol: the value returned is an upper bound within relative 2 TOL."""


def _random_stable(rng: np.random.Generator, S: int, n: int, m: int, p: int):
    """S random systems (S, n, m, p), the slowest pole of each 0.05 to 1 1/s left of the imaginary axis."""
    A = rng.normal(size=(S, n, n))
    A -= (np.linalg.eigvals(A).real.max(axis=1) + rng.uniform(0.05, 1.0, S))[:, None, None] * np.eye(n)
    return A, rng.normal(size=(S, n, m)), rng.normal(size=(S, p, n)), rng.normal(size=(S, p, m)) * 0.3


def _sigma(A, B, C, D, ws: np.ndarray) -> np.ndarray:
    """``sigma_max(C (j w I - A)^-1 B + D)`` at the frequencies ws (rad/s), by full SVDs."""
    G = C @ np.linalg.solve(1j * ws[:, None, None] * np.eye(A.shape[0]) - A, B) + D
    return np.linalg.svd(G, compute_uv=False)[:, 0]


def _swept_peak(A, B, C, D) -> float:
    """The largest ``sigma_max(G(jw))`` found by a frequency sweep, independent of the Hamiltonian:
    ``w = 0``, 20001 frequencies log-spaced over [1e-3, 1e3] rad/s and ``||D||`` (the limit at
    infinity), then twice a grid of 2001 points over the 4 steps around the best one (spacing
    7e-4 w, then 1.4e-6 w, then 2.8e-9 w). Near a peak sigma_max is quadratic in w, so the last
    grid misses the peak by about ``(2.8e-9 w / width)^2``: below 1e-14 relative for peaks wider
    than 1e-3 w (these systems' poles are at least 0.05 1/s from the axis)."""
    ws = np.concatenate([[0.0], np.logspace(-3, 3, 20001)])
    s = _sigma(A, B, C, D, ws)
    best, w0, step = s.max(), ws[np.argmax(s)], 7e-4 * max(ws[np.argmax(s)], 1e-3)
    for _ in range(2):
        fine = np.linspace(max(w0 - 2 * step, 0.0), w0 + 2 * step, 2001)
        sf = _sigma(A, B, C, D, fine)
        best, w0, step = max(best, sf.max()), fine[np.argmax(sf)], step / 500
    return max(best, float(np.linalg.norm(D, 2)))


def test_hinf_norm_closed_forms() -> None:
    # k/(s + a): |G(jw)| = |k| / sqrt(w^2 + a^2), peak |k|/a at w = 0. The value returned is the
    # upper end of the 2 tol bracket: low = sigma(G(j0)) is the norm exactly, and g = (1 + 2 tol)
    # low is accepted at once (no crossing), so the relative error is 2 tol plus rounding.
    for k, a in ((1.0, 0.1), (-3.0, 2.0), (0.5, 50.0)):
        norm = hinf_norm([[-a]], [[1.0]], [[k]], [[0.0]])
        assert isinstance(norm, float) and norm == pytest.approx(abs(k) / a * (1 + 2 * TOL), rel=1e-14)
        assert hinf_norm([[-a]], [[1.0]], [[k]], [[0.0]], tol=1e-3) == pytest.approx(abs(k) / a * 1.002, rel=1e-14)
    # w^2 / (s^2 + 2 zeta w s + w^2): peak 1 / (2 zeta sqrt(1 - zeta^2)) at w sqrt(1 - 2 zeta^2) for
    # zeta < 1/sqrt(2); zeta = 0.001 is a resonance 500 times the static gain, 2e-3 w wide
    for zeta, w in ((0.05, 3.0), (0.3, 0.2), (0.001, 10.0)):
        A = [[0, 1], [-w**2, -2 * zeta * w]]
        peak = 1 / (2 * zeta * math.sqrt(1 - zeta**2))
        assert hinf_norm(A, [[0], [w**2]], [[1, 0]], [[0]]) == pytest.approx(peak, rel=3e-9)  # 2 tol + rounding
    # 2 + 1/(s + 1): a feedthrough, the peak 3 at w = 0
    assert hinf_norm([[-1.0]], [[1.0]], [[1.0]], [[2.0]]) == pytest.approx(3.0, rel=3e-9)
    assert hinf_norm([[-1.0]], [[1.0]], [[0.0]], [[0.0]]) == 0.0  # a zero response: exactly 0


@pytest.mark.parametrize(("n", "m", "p"), [(2, 1, 1), (5, 2, 3), (8, 1, 1)])
def test_hinf_norm_against_a_dense_frequency_sweep(n: int, m: int, p: int) -> None:
    rng = np.random.default_rng(11)
    A, B, C, D = _random_stable(rng, 12, n, m, p)
    norms = hinf_norm(A, B, C, D)
    assert norms.shape == (12,)
    for k in range(len(A)):
        swept = _swept_peak(A[k], B[k], C[k], D[k])
        # an upper bound: the sweep's sigma_max values are attained (1e-13: their rounding) ...
        assert swept <= norms[k] * (1 + 1e-13)
        # ... within 2 tol of the peak (1e-12 more: the sweep's own gap and rounding; measured <= 2.0e-9)
        assert norms[k] <= swept * (1 + 2 * TOL + 1e-12)


def test_a_stack_is_its_systems_one_at_a_time() -> None:
    rng = np.random.default_rng(3)
    A, B, C, D = _random_stable(rng, 6, 4, 2, 3)
    stack = hinf_norm(A, B, C, D)
    # one system is a stack of one: the same iteration, and numpy's stacked LAPACK and matmul
    # calls go matrix by matrix, so the numbers are the same to the bit
    assert np.array_equal(stack, [hinf_norm(a, b, c, d) for a, b, c, d in zip(A, B, C, D)])
    shared = hinf_norm(A, B[0], C[0], D[0])  # B, C, D shared by the stack (2-D)
    assert np.array_equal(shared, [hinf_norm(a, B[0], C[0], D[0]) for a in A])
    assert np.array_equal(hinf_norm(A, B, np.zeros_like(C), np.zeros_like(D)), np.zeros(6))


def test_impulse_to_peak_closed_forms() -> None:
    # first order: c e^(-a t) b peaks at t = 0 with |c b| (exact: no grid error at t = 0)
    assert impulse_to_peak([[-2.0]], [[3.0]], [[-0.5]], 5.0, 101) == pytest.approx(1.5, rel=1e-15)
    # x'' + 2 zeta w x' + w^2 x = 0, x(0) = 0, x'(0) = 1: x = e^(-zeta w t) sin(wd t) / wd peaks at
    # wd t* = arccos(zeta) with exp(-zeta arccos(zeta) / sqrt(1 - zeta^2)) / w
    zeta, w = 0.3, 2.0
    A, B, C = [[0, 1], [-w**2, -2 * zeta * w]], [[0], [1]], [[1, 0]]
    exact = math.exp(-zeta * math.acos(zeta) / math.sqrt(1 - zeta**2)) / w
    value = impulse_to_peak(A, B, C, 5.0, 50001)
    # grid spacing 1e-4 s: the sampled maximum misses the peak by <= |x''| h^2 / 8 ~ 1e-9
    assert value <= exact * (1 + 1e-12) and value == pytest.approx(exact, rel=1e-7)
    # stacks: the same numbers as one system at a time (blocked propagation, rounding only)
    rng = np.random.default_rng(5)
    As = rng.normal(size=(3, 4, 4)) - 3 * np.eye(4)
    Bs, Cs = rng.normal(size=(3, 4, 2)), rng.normal(size=(3, 3, 4))
    many = impulse_to_peak(As, Bs, Cs, 4.0, 1001)
    one = [impulse_to_peak(a, b, c, 4.0, 1001) for a, b, c in zip(As, Bs, Cs)]
    assert np.allclose(many, one, rtol=1e-13, atol=0)  # same products in the same order, batched


def test_bad_input_is_rejected() -> None:
    with pytest.raises(NotHurwitzError, match=r"A is not Hurwitz \(max Re eig 1.000e-01\)"):
        hinf_norm([[0.1]], [[1.0]], [[1.0]], [[0.0]])
    A, B, C, D = _random_stable(np.random.default_rng(2), 3, 3, 1, 1)
    A[1] += 5 * np.eye(3)
    with pytest.raises(NotHurwitzError, match=r"sample 1 is not Hurwitz .* \(1 such samples\)"):
        hinf_norm(A, B, C, D)
    with pytest.raises(PlantDataError, match="D must have shape"):
        hinf_norm([[-1.0]], [[1.0]], [[1.0]], [[0.0, 1.0]])
    with pytest.raises(PlantDataError, match="B must have shape"):
        hinf_norm(A, B[:2], C, D)
    with pytest.raises(OptionError, match="tol must be finite and > 0"):
        hinf_norm([[-1.0]], [[1.0]], [[1.0]], [[0.0]], tol=0.0)
    # the lightly damped resonance needs several iterations (the first lower bound is far below)
    with pytest.raises(RuntimeError, match="did not converge in 1 iterations for 1 samples"):
        hinf_norm([[0, 1], [-100.0, -0.02]], [[0], [100.0]], [[1, 0]], [[0]], max_iter=1)
    with pytest.raises(OptionError, match="t_end"):
        impulse_to_peak([[-1.0]], [[1.0]], [[1.0]], -1.0)
