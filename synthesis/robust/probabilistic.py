"""Randomized analysis of uncertain closed loops (seed 004, section 5.2): sample-size bounds and
the probabilistic statements of sampled values.

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
  epsilon 0.1, delta 1e-9: Table 1 row 1); or, with ``bound="romuloc"``, the explicit count of
  the R-RoMulOC toolbox (its ``scensamplenb``), ``N = ceil(1.58 / epsilon (ln(1/delta) + d))``
  (1055 for the same row), a sufficient count that is larger than the exact one.

The exact values per sample come from :mod:`satfmu.synthesis.core.system_norms`, vectorized over the sample
axis: :func:`~satfmu.synthesis.core.system_norms.hinf_norm` runs the Boyd-Balakrishnan/Bruinsma-Steinbuch
iteration on every sample at once (batched Hamiltonian eigenvalues and frequency responses; a
sample leaves the batch when it converges), and :func:`~satfmu.synthesis.core.system_norms.impulse_to_peak`
propagates a stack of systems.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.stats import binom

from satfmu.synthesis.robust.lft_plant import OptionError


def _check_eps_delta(epsilon: float, delta: float) -> None:
    for name, v in (("epsilon", epsilon), ("delta", delta)):
        if not (np.isfinite(v) and 0 < v < 1):
            raise OptionError(f"{name} must be in (0, 1), got {v!r}")


def worst_case_samples(epsilon: float, delta: float) -> int:
    """Smallest N with ``N >= ln(1/delta) / ln(1/(1 - epsilon))`` (log-over-log bound).

    Parameters
    ----------
    epsilon : float
        Probability that the largest value seen is exceeded, in (0, 1).
    delta : float
        One minus the confidence, in (0, 1).

    Returns
    -------
    int
        The number of samples.

    Raises
    ------
    OptionError
        If ``epsilon`` or ``delta`` is not in (0, 1).
    """
    _check_eps_delta(epsilon, delta)
    return math.ceil(math.log(1 / delta) / math.log(1 / (1 - epsilon)))


def chernoff_samples(epsilon: float, delta: float) -> int:
    """Smallest N with ``N >= ln(2/delta) / (2 epsilon^2)`` (additive Chernoff bound).

    Parameters
    ----------
    epsilon : float
        Largest difference between the empirical and the true probability, in (0, 1).
    delta : float
        One minus the confidence, in (0, 1).

    Returns
    -------
    int
        The number of samples.

    Raises
    ------
    OptionError
        If ``epsilon`` or ``delta`` is not in (0, 1).
    """
    _check_eps_delta(epsilon, delta)
    return math.ceil(math.log(2 / delta) / (2 * epsilon**2))


def chernoff_accuracy(n: int, delta: float) -> float:
    """The epsilon that N samples guarantee at confidence ``1 - delta``: ``sqrt(ln(2/delta)/(2N))``.

    Parameters
    ----------
    n : int
        Number of samples N, >= 1.
    delta : float
        One minus the confidence, in (0, 1).

    Raises
    ------
    OptionError
        If ``n < 1`` or ``delta`` is not in (0, 1).
    """
    _check_eps_delta(0.5, delta)
    if n < 1:
        raise OptionError(f"n must be >= 1, got {n!r}")
    return math.sqrt(math.log(2 / delta) / (2 * n))


SCENARIO_BOUNDS = ("campi-garatti", "romuloc")
"""Scenario sample counts of :func:`scenario_samples`: the exact binomial one, the toolbox's."""


def scenario_samples(n_decision: int, epsilon: float, delta: float, bound: str = "campi-garatti") -> int:
    """Scenario count for ``d = n_decision`` scalar decision variables (module docstring).

    ``bound="campi-garatti"``: the smallest N with ``binom.cdf(d - 1, N, epsilon) <= delta``
    (Campi & Garatti 2008, exact); ``"romuloc"``: ``ceil(1.58 / epsilon (ln(1/delta) + d))``
    (the R-RoMulOC toolbox's ``scensamplenb``, which counts every scalar decision variable).

    Parameters
    ----------
    n_decision : int
        ``d``, the number of scalar decision variables of the convex program, >= 1.
    epsilon : float
        Violation probability, in (0, 1).
    delta : float
        One minus the confidence, in (0, 1).
    bound : {"campi-garatti", "romuloc"}, optional
        Which count (:data:`SCENARIO_BOUNDS`).

    Returns
    -------
    int
        The number of sampled constraints N.

    Raises
    ------
    OptionError
        If an argument is out of its range or ``bound`` is unknown.
    """
    _check_eps_delta(epsilon, delta)
    if not (isinstance(n_decision, (int, np.integer)) and n_decision >= 1):
        raise OptionError(f"n_decision must be an integer >= 1, got {n_decision!r}")
    if bound not in SCENARIO_BOUNDS:
        raise OptionError(f"bound must be one of {SCENARIO_BOUNDS}, got {bound!r}")
    if bound == "romuloc":
        return math.ceil(1.58 / epsilon * (math.log(1 / delta) + n_decision))
    lo, hi = n_decision, n_decision
    while binom.cdf(n_decision - 1, hi, epsilon) > delta:
        lo, hi = hi, 2 * hi
    while hi - lo > 1:  # the tail decreases with N: bisection on the first N that meets delta
        mid = (lo + hi) // 2
        lo, hi = (lo, mid) if binom.cdf(n_decision - 1, mid, epsilon) <= delta else (mid, hi)
    return hi if binom.cdf(n_decision - 1, lo, epsilon) > delta else lo


@dataclass(frozen=True)
class WorstCase:
    """Probabilistic worst case of a performance over N samples (log-over-log bound).

    Attributes
    ----------
    estimate : float
        The largest sampled value (inf when a sample failed), in the performance's unit.
    n : int
        Number of samples N.
    epsilon : float
        Probability that the estimate is exceeded, claimed.
    delta : float
        One minus the confidence of the claim.
    """

    estimate: float
    n: int
    epsilon: float
    delta: float

    @property
    def sufficient(self) -> bool:
        """N meets :func:`worst_case_samples` for (epsilon, delta)."""
        return self.n >= worst_case_samples(self.epsilon, self.delta)

    def text(self, what: str = "the performance") -> str:
        """The probabilistic statement in one sentence, flagged when N is too small for it.

        Parameters
        ----------
        what : str, optional
            Name of the performance in the sentence (``"the H-infinity norm"``).
        """
        need = worst_case_samples(self.epsilon, self.delta)
        return (f"max of {self.n} samples of {what} = {self.estimate:.6g}: P({what} > {self.estimate:.6g}) <= "
                f"{self.epsilon:g} with confidence {1 - self.delta:g}"
                + ("" if self.sufficient else f" (NOT guaranteed: needs N >= {need})"))


@dataclass(frozen=True)
class LevelProbability:
    """Empirical probability of meeting a level, with its Chernoff accuracy.

    Attributes
    ----------
    level : float
        The level, in the performance's unit.
    probability : float
        Fraction of the samples with ``value <= level``.
    n : int
        Number of samples N.
    accuracy : float
        The Chernoff accuracy epsilon of ``probability`` (:func:`chernoff_accuracy`).
    delta : float
        One minus the confidence.
    """

    level: float
    probability: float
    n: int
    accuracy: float
    delta: float

    def text(self, what: str = "the performance") -> str:
        """The probabilistic statement in one sentence.

        Parameters
        ----------
        what : str, optional
            Name of the performance in the sentence (``"the H-infinity norm"``).
        """
        return (f"P({what} <= {self.level:.6g}) = {self.probability:.6g} +- {self.accuracy:.3g} "
                f"with confidence {1 - self.delta:g} ({self.n} samples, Chernoff)")


def worst_case(values: np.ndarray, epsilon: float = 0.1, delta: float = 1e-6) -> WorstCase:
    """The largest of the sampled values (NaN counts as infinite: a failed sample).

    Parameters
    ----------
    values : numpy.ndarray
        The sampled values of the performance (any shape, flattened).
    epsilon : float, optional
        Probability of exceeding the estimate to claim, in (0, 1).
    delta : float, optional
        One minus the confidence of the claim, in (0, 1).

    Returns
    -------
    WorstCase
        The estimate and its claim (:attr:`WorstCase.sufficient` says whether N supports it).

    Raises
    ------
    OptionError
        If there are no values or ``epsilon`` or ``delta`` is not in (0, 1).
    """
    _check_eps_delta(epsilon, delta)
    v = np.asarray(values, float).ravel()
    if v.size == 0:
        raise OptionError("no samples")
    return WorstCase(float(np.max(np.where(np.isnan(v), np.inf, v))), v.size, epsilon, delta)


def level_probability(values: np.ndarray, level: float, delta: float = 1e-6) -> LevelProbability:
    """Frequency of ``value <= level`` (NaN: not met) and its Chernoff accuracy at ``1 - delta``.

    Parameters
    ----------
    values : numpy.ndarray
        The sampled values of the performance (any shape, flattened).
    level : float
        The level to meet, in the values' unit.
    delta : float, optional
        One minus the confidence, in (0, 1).

    Returns
    -------
    LevelProbability
        The frequency and its accuracy.

    Raises
    ------
    OptionError
        If there are no values or ``delta`` is not in (0, 1).
    """
    v = np.asarray(values, float).ravel()
    if v.size == 0:
        raise OptionError("no samples")
    met = np.count_nonzero(v <= level)
    return LevelProbability(float(level), met / v.size, v.size, chernoff_accuracy(v.size, delta), delta)
