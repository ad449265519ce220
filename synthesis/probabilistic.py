"""Randomized analysis of uncertain closed loops (seed 004, section 5.2): sample-size bounds,
vectorized exact performance of many samples, and the probabilistic statements.

The seed names its bounds without formulas (``randsettings``: epsilon = 0.1, delta = 1e-6); we
use the standard ones (Tempo, Calafiore & Dabbene, *Randomized Algorithms for Analysis and
Control of Uncertain Systems*, 2nd ed., Springer 2013, chapters 8 and 12):

- worst case (:func:`worst_case_samples`, the log-over-log bound): with
  ``N >= ln(1/delta) / ln(1/(1 - epsilon))`` independent samples, the largest value seen is
  exceeded with probability at most epsilon, with confidence ``1 - delta`` (N = 132 for
  epsilon 0.1, delta 1e-6);
- probability of meeting a level (:func:`chernoff_samples`): with
  ``N >= ln(2/delta) / (2 epsilon^2)`` samples the empirical frequency is within epsilon of the
  true probability, with confidence ``1 - delta`` (N = 726 for epsilon 0.1, delta 1e-6);
- scenario design (:func:`scenario_samples`, Campi & Garatti, SIAM J. Optim. 19, 2008): a
  convex program with ``d`` decision variables and N sampled constraints has a solution
  violated with probability at most epsilon, with confidence ``1 - delta``, as soon as
  ``sum_{i < d} C(N, i) epsilon^i (1 - epsilon)^(N - i) <= delta`` (N = 962 for d = 46,
  epsilon 0.1, delta 1e-9: Table 1 row 1).

The exact values per sample are vectorized over the sample axis: :func:`hinf_norms` runs the
Boyd-Balakrishnan/Bruinsma-Steinbuch iteration on every sample at once (batched Hamiltonian
eigenvalues and frequency responses; a sample leaves the batch when it converges), and the
impulse-to-peak values come from :func:`synthesis.robust_lmi.impulse_to_peak`, which
propagates a stack of systems.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.stats import binom

from synthesis.robust_lmi import NotHurwitzError, OptionError, _system_stack


def _check_eps_delta(epsilon: float, delta: float) -> None:
    for name, v in (("epsilon", epsilon), ("delta", delta)):
        if not (np.isfinite(v) and 0 < v < 1):
            raise OptionError(f"{name} must be in (0, 1), got {v!r}")


def worst_case_samples(epsilon: float, delta: float) -> int:
    """Smallest N with ``N >= ln(1/delta) / ln(1/(1 - epsilon))`` (log-over-log bound)."""
    _check_eps_delta(epsilon, delta)
    return math.ceil(math.log(1 / delta) / math.log(1 / (1 - epsilon)))


def chernoff_samples(epsilon: float, delta: float) -> int:
    """Smallest N with ``N >= ln(2/delta) / (2 epsilon^2)`` (additive Chernoff bound)."""
    _check_eps_delta(epsilon, delta)
    return math.ceil(math.log(2 / delta) / (2 * epsilon**2))


def chernoff_accuracy(n: int, delta: float) -> float:
    """The epsilon that N samples guarantee at confidence ``1 - delta``: ``sqrt(ln(2/delta)/(2N))``."""
    _check_eps_delta(0.5, delta)
    if n < 1:
        raise OptionError(f"n must be >= 1, got {n!r}")
    return math.sqrt(math.log(2 / delta) / (2 * n))


def scenario_samples(n_decision: int, epsilon: float, delta: float) -> int:
    """Smallest N with ``binom.cdf(d - 1, N, epsilon) <= delta`` (Campi & Garatti 2008)."""
    _check_eps_delta(epsilon, delta)
    if not (isinstance(n_decision, (int, np.integer)) and n_decision >= 1):
        raise OptionError(f"n_decision must be an integer >= 1, got {n_decision!r}")
    lo, hi = n_decision, n_decision
    while binom.cdf(n_decision - 1, hi, epsilon) > delta:
        lo, hi = hi, 2 * hi
    while hi - lo > 1:  # the tail decreases with N: bisection on the first N that meets delta
        mid = (lo + hi) // 2
        lo, hi = (lo, mid) if binom.cdf(n_decision - 1, mid, epsilon) <= delta else (mid, hi)
    return hi if binom.cdf(n_decision - 1, lo, epsilon) > delta else lo


def _sigma_max_at(A, B, C, D, w: np.ndarray) -> np.ndarray:
    """``sigma_max(C (j w I - A)^-1 B + D)`` for stacks (S, .) and frequencies w (S, F): (S, F)."""
    n = A.shape[-1]
    M = 1j * w[..., None, None] * np.eye(n) - A[:, None]
    G = C[:, None] @ np.linalg.solve(M, np.broadcast_to(B[:, None], M.shape[:2] + B.shape[-2:])) + D[:, None]
    return np.linalg.norm(G, ord=2, axis=(-2, -1))


def _hamiltonian_stack(A, B, C, D, g: np.ndarray) -> np.ndarray:
    """Hamiltonians of the bounded-real lemma at levels g (S,), stacked (S, 2n, 2n)."""
    m, p = D.shape[-1], D.shape[-2]
    Dt = np.swapaxes(D, -1, -2)
    Ri = np.linalg.inv(g[:, None, None] ** 2 * np.eye(m) - Dt @ D)
    Ct = np.swapaxes(C, -1, -2)
    Ah = A + B @ Ri @ Dt @ C
    top = np.concatenate([Ah, B @ Ri @ np.swapaxes(B, -1, -2)], axis=-1)
    bottom = np.concatenate([-Ct @ (np.eye(p) + D @ Ri @ Dt) @ C, -np.swapaxes(Ah, -1, -2)], axis=-1)
    return np.concatenate([top, bottom], axis=-2)


def hinf_norms(A, B, C, D, tol: float = 1e-9, max_iter: int = 200) -> np.ndarray:
    """H-infinity norms of a stack of stable systems, all iterated together.

    The same iteration, tolerance and acceptance rule as
    :func:`synthesis.robust_lmi.hinf_norm` (an upper bound within relative ``2 tol``), with
    every step batched over the samples still iterating.

    Parameters
    ----------
    A, B, C, D : ndarray
        Shapes (S, n, n), (S, n, m), (S, p, n), (S, p, m); B, C, D may be 2-D (shared).
    tol : float
        Relative accuracy (> 0).

    Returns
    -------
    ndarray, shape (S,)

    Raises
    ------
    NotHurwitzError
        If a sample's A has an eigenvalue with ``Re >= 0`` (its index is named).
    """
    A, B, C, D = _system_stack(A, B, C, D)
    if A.ndim == 2:
        A, B, C, D = A[None], B[None], C[None], D[None]
    if not (np.isfinite(tol) and tol > 0):
        raise OptionError(f"tol must be finite and > 0, got {tol!r}")
    lam = np.linalg.eigvals(A)
    bad = np.flatnonzero(lam.real.max(axis=-1) >= 0)
    if bad.size:
        raise NotHurwitzError(f"sample {bad[0]} is not Hurwitz (max Re eig {lam[bad[0]].real.max():.3e}): "
                              f"its H-infinity norm is infinite ({bad.size} such samples)")
    w0 = np.concatenate([np.zeros((len(A), 1)), np.abs(lam)], axis=1)
    low = np.maximum(_sigma_max_at(A, B, C, D, w0).max(axis=1), np.linalg.norm(D, ord=2, axis=(-2, -1)))
    out = np.where(low == 0.0, 0.0, np.nan)
    active = np.flatnonzero(low > 0)
    for _ in range(max_iter):
        if active.size == 0:
            return out
        a, b, c, d = A[active], B[active], C[active], D[active]
        g = (1 + 2 * tol) * low[active]
        H = _hamiltonian_stack(a, b, c, d, g)
        ev = np.linalg.eigvals(H)
        scale = np.maximum(1.0, np.abs(H).max(axis=(-2, -1)))
        on_axis = np.abs(ev.real) <= 1e-7 * scale[:, None]
        w = np.sort(np.where(on_axis, ev.imag, np.nan), axis=1)  # NaN last
        count = on_axis.sum(axis=1)
        mids = np.where(count[:, None] > 1, (w[:, :-1] + w[:, 1:]) / 2, np.abs(w[:, :1]))
        mids = np.where(np.isnan(mids), 0.0, np.abs(mids))  # padding: w = 0, already below low
        best = np.where(count > 0, _sigma_max_at(a, b, c, d, mids).max(axis=1), 0.0)
        done = best <= g  # no crossing, or the crossings were numerical
        out[active[done]] = g[done]
        low[active[~done]] = best[~done]
        active = active[~done]
    raise RuntimeError(f"the H-infinity iteration did not converge in {max_iter} iterations "
                       f"for {active.size} samples")


@dataclass(frozen=True)
class WorstCase:
    """Probabilistic worst case of a performance over N samples (log-over-log bound)."""

    estimate: float
    n: int
    epsilon: float
    delta: float

    @property
    def sufficient(self) -> bool:
        """N meets :func:`worst_case_samples` for (epsilon, delta)."""
        return self.n >= worst_case_samples(self.epsilon, self.delta)

    def text(self, what: str = "the performance") -> str:
        need = worst_case_samples(self.epsilon, self.delta)
        return (f"max of {self.n} samples of {what} = {self.estimate:.6g}: P({what} > {self.estimate:.6g}) <= "
                f"{self.epsilon:g} with confidence {1 - self.delta:g}"
                + ("" if self.sufficient else f" (NOT guaranteed: needs N >= {need})"))


@dataclass(frozen=True)
class LevelProbability:
    """Empirical probability of meeting a level, with its Chernoff accuracy."""

    level: float
    probability: float
    n: int
    accuracy: float
    delta: float

    def text(self, what: str = "the performance") -> str:
        return (f"P({what} <= {self.level:.6g}) = {self.probability:.6g} +- {self.accuracy:.3g} "
                f"with confidence {1 - self.delta:g} ({self.n} samples, Chernoff)")


def worst_case(values: np.ndarray, epsilon: float = 0.1, delta: float = 1e-6) -> WorstCase:
    """The largest of the sampled values (NaN counts as infinite: a failed sample)."""
    _check_eps_delta(epsilon, delta)
    v = np.asarray(values, float).ravel()
    if v.size == 0:
        raise OptionError("no samples")
    return WorstCase(float(np.max(np.where(np.isnan(v), np.inf, v))), v.size, epsilon, delta)


def level_probability(values: np.ndarray, level: float, delta: float = 1e-6) -> LevelProbability:
    """Frequency of ``value <= level`` (NaN: not met) and its Chernoff accuracy at ``1 - delta``."""
    v = np.asarray(values, float).ravel()
    if v.size == 0:
        raise OptionError("no samples")
    met = np.count_nonzero(v <= level)
    return LevelProbability(float(level), met / v.size, v.size, chernoff_accuracy(v.size, delta), delta)
