"""Sequential randomized design: subgradient updates and probabilistic validation (seed 004, 4.2).

The same specs as :func:`satfmu.synthesis.robust.robust_design.design` at fixed levels (gamma, nu): one
Lyapunov matrix, the dual LMIs of H-infinity ``w1 -> z1``, of the pole region and of the
impulse-to-peak bound, in the variables ``x = (Y, W)``, ``K = W Y^-1``. For a plant at delta
let ``v(x, delta)`` be the largest eigenvalue over those LMIs (each written as ``L(x) < 0``)
plus a strictness margin. The algorithm (Calafiore & Polyak, IEEE TAC 46, 2001; Tempo,
Calafiore & Dabbene, *Randomized Algorithms for Analysis and Control of Uncertain Systems*,
2nd ed. 2013, ch. 11) alternates:

1. validation: draw ``N_k = ceil(ln(pi^2 k^2 / (6 delta)) / ln(1 / (1 - epsilon)))`` plants
   (round k); if none violates, stop: with confidence ``1 - delta`` the probability that the
   returned (Y, W) violates the specs is at most epsilon (the ``pi^2 k^2 / 6`` splits delta
   over the rounds);
2. update on the most violated plant: ``x <- x - (v + r) g / |g|^2`` (Polyak's step, g a
   subgradient of the largest eigenvalue: ``u^T (dL/dx) u`` with u its eigenvector; r a small
   overshoot into the interior), then Y projected onto ``Y >= margin I``.

Every LMI is affine in x, so the subgradient is computed exactly from the LMI's linear part
applied to a basis of x (numpy only; no solver in the loop).
"""
from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from satfmu.synthesis.robust.lft_plant import LFTPlant, OptionError, _sym
from satfmu.synthesis.robust.dual_lmis import _dual_lmi, _i2p_blocks, _specs, _weights

Sampler = Callable[[np.random.Generator, int], np.ndarray]


def validation_samples(k: int, epsilon: float, delta: float) -> int:
    """``N_k = ceil(ln(pi^2 k^2 / (6 delta)) / ln(1 / (1 - epsilon)))`` of validation round k >= 1.

    Parameters
    ----------
    k : int
        The validation round, from 1.
    epsilon : float
        Violation probability, in (0, 1).
    delta : float
        One minus the confidence, in (0, 1), split over the rounds.

    Returns
    -------
    int
        The number of plants to draw in round ``k``.

    Raises
    ------
    OptionError
        If ``k < 1`` or ``epsilon`` or ``delta`` is not in (0, 1).
    """
    if not (0 < epsilon < 1 and 0 < delta < 1) or k < 1:
        raise OptionError(f"need k >= 1 and epsilon, delta in (0, 1), got {k!r}, {epsilon!r}, {delta!r}")
    return math.ceil(math.log(math.pi**2 * k**2 / (6 * delta)) / math.log(1 / (1 - epsilon)))


@dataclass
class SequentialResult:
    """Outcome of :func:`sequential`.

    ``status``: ``"validated"`` (a round drew no violating plant) or ``"not_validated"``
    (``max_updates`` reached). ``violations``: the violation of each update (before it).

    Attributes
    ----------
    status : {"validated", "not_validated"}
        Whether the last validation round drew no violating plant.
    K : numpy.ndarray, shape (m, n)
        The state-feedback gain ``K = W Y^-1`` of the last iterate.
    Y : numpy.ndarray, shape (n, n)
        The dual Lyapunov matrix of the last iterate.
    gamma : float
        The H-infinity level the specs were checked at.
    nu : float
        The impulse-to-peak level the specs were checked at.
    updates : int
        Subgradient updates made.
    rounds : int
        Validation rounds drawn (the last one included).
    samples : int
        Plants drawn in all rounds.
    epsilon : float
        The violation probability of the validation.
    delta : float
        One minus the confidence of the validation.
    seconds : float
        Wall time of the run, s.
    violations : list of float, optional
        The largest eigenvalue of the most violated plant before each update.
    """

    status: str
    K: np.ndarray
    Y: np.ndarray
    gamma: float
    nu: float
    updates: int
    rounds: int
    samples: int
    epsilon: float
    delta: float
    seconds: float
    violations: list[float] = field(default_factory=list)

    def text(self) -> str:
        """One sentence: the probabilistic statement, or that there is none."""
        if self.status != "validated":
            return (f"not validated after {self.updates} updates ({self.samples} samples): no probabilistic "
                    "statement")
        return (f"validated after {self.updates} updates, {self.rounds} rounds, {self.samples} samples: "
                f"P(specs violated at gamma {self.gamma:.6g}, nu {self.nu:.6g}) <= {self.epsilon:g} with "
                f"confidence {1 - self.delta:g}")


class _LMIs:
    """The numpy LMIs ``L_j(x) < 0`` of one certain plant at levels (gamma, nu), x = (Y, W)."""

    def __init__(self, plant: LFTPlant, gamma: float, nu: float, alpha: float, beta: float | None) -> None:
        self.plant, self.gamma, self.nu = plant, gamma, nu
        self.specs = _specs(plant, alpha, beta, True)

    def __call__(self, Y: np.ndarray, W: np.ndarray) -> list[np.ndarray]:
        out = [_dual_lmi(s, Y, W, None, _weights("satfmu", self.gamma), np.vstack, np.block) for s in self.specs]
        upper, lower = _i2p_blocks(self.plant, Y, _weights("satfmu", self.nu), np.block)
        return out + [-upper, lower]


def _basis(n: int, m: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """A basis of x = (Y symmetric, W): unit symmetric Y entries, then unit W entries."""
    out = []
    for i in range(n):
        for j in range(i, n):
            E = np.zeros((n, n))
            E[i, j] = E[j, i] = 1.0
            out.append((E, np.zeros((m, n))))
    for i in range(m):
        for j in range(n):
            E = np.zeros((m, n))
            E[i, j] = 1.0
            out.append((np.zeros((n, n)), E))
    return out


def _worst(lmis: _LMIs, Y: np.ndarray, W: np.ndarray) -> tuple[float, int, np.ndarray]:
    """Largest eigenvalue over the LMIs, which LMI, and its eigenvector."""
    best = (-np.inf, -1, np.zeros(0))
    for j, L in enumerate(lmis(Y, W)):
        w, V = np.linalg.eigh(L)
        if w[-1] > best[0]:
            best = (float(w[-1]), j, V[:, -1])
    return best


def sequential(plant: LFTPlant, sampler: Sampler, gamma: float, nu: float, Y0: np.ndarray, W0: np.ndarray, *,
               alpha: float = 1e-4, beta: float | None = 10.0, epsilon: float = 0.1, delta: float = 1e-6,
               margin: float = 1e-7, overshoot: float = 1e-3, max_updates: int = 2000, seed: int = 0
               ) -> SequentialResult:
    """Find (Y, W) meeting the specs at (gamma, nu) for all but a fraction epsilon of the plants.

    Parameters
    ----------
    plant : LFTPlant
        The uncertain plant; ``plant.at(delta)`` is the plant of a sample.
    sampler : callable
        ``sampler(rng, count)`` -> parameter vectors, shape (count, N), in the box.
    gamma, nu : float
        H-infinity and impulse-to-peak levels (fixed).
    Y0, W0 : ndarray
        Starting point (e.g. the nominal design's), shapes (n, n) and (m, n).
    alpha, beta : float
        Pole region, 1/s.
    epsilon, delta : float
        Violation probability and 1 - confidence of the validation.
    margin : float
        Strictness: a plant violates when an LMI's largest eigenvalue exceeds ``-margin``.
    overshoot : float
        r of the Polyak step, relative to the violation scale (steps a little past the boundary).
    max_updates : int
        Updates allowed before giving up.
    seed : int
        Seed of the sample stream.
    """
    n, m = plant.A.shape[0], plant.Bu.shape[1]
    Y, W = _sym(np.asarray(Y0, float)), np.asarray(W0, float).reshape(m, n)
    basis = _basis(n, m)
    rng = np.random.default_rng(seed)
    t0 = time.perf_counter()
    updates, rounds, samples, history = 0, 0, 0, []
    while True:
        rounds += 1
        deltas = sampler(rng, validation_samples(rounds, epsilon, delta))
        samples += len(deltas)
        worst = None
        for d in deltas:
            lmis = _LMIs(plant.at(d), gamma, nu, alpha, beta)
            v, j, u = _worst(lmis, Y, W)
            if v > -margin and (worst is None or v > worst[0]):
                worst = (v, j, u, lmis)
        if worst is None:
            status = "validated"
            break
        if updates >= max_updates:
            status = "not_validated"
            break
        v, j, u, lmis = worst
        history.append(v)
        zero = lmis(np.zeros((n, n)), np.zeros((m, n)))[j]
        g = np.array([u @ (lmis(Ei, Fi)[j] - zero) @ u for Ei, Fi in basis])
        step = (v + margin + overshoot * abs(v)) / float(g @ g)
        x = -step * g
        for (Ei, Fi), c in zip(basis, x):
            Y = Y + c * Ei
            W = W + c * Fi
        w, V = np.linalg.eigh(Y)
        Y = (V * np.maximum(w, margin)) @ V.T
        updates += 1
    K = np.linalg.solve(Y, W.T).T
    return SequentialResult(status, K, Y, gamma, nu, updates, rounds, samples, epsilon, delta,
                            time.perf_counter() - t0, history)
