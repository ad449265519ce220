"""Statistics of a scenario campaign's rows: pass rates and their intervals, percentiles, worst samples.

:func:`statistics` gives per metric the pass rate with its Clopper-Pearson interval, the
percentiles :data:`PERCENTILES` and the worst samples with their dispersed values (the rows'
columns: :mod:`satfmu.sims.campaign.scenario_task`).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

import numpy as np
import pandas as pd

from satfmu.sims.campaign.engine import CampaignError
from satfmu.sims.campaign.scenario_task import _RESERVED
from satfmu.sims.scenario.metrics import MetricResult
from satfmu.sims.scenario.spec import Scenario, load

PERCENTILES = (50.0, 95.0, 99.0, 99.73)
"""Percentiles of each metric, % (99.73: the 3-sigma level of a normal distribution)."""


@dataclass(frozen=True)
class MetricStatistics:
    """Pass rate and percentiles of one metric over a campaign (values in ``unit``).

    ``passes`` counts the samples within the metric's bounds (a failed sample is not);
    ``low`` and ``high`` bound the pass probability (Clopper-Pearson, at the campaign's
    confidence); the percentiles are over the samples with a finite value.

    Attributes
    ----------
    name : str
        The metric's name (``"all metrics (passed)"`` for the overall pass rate).
    unit : str
        The metric's unit.
    n : int
        Samples of the campaign, failed ones included.
    passes : int
        Samples within the metric's bounds.
    low, high : float
        Clopper-Pearson bounds of the pass probability, in [0, 1].
    percentiles : dict of float to float
        Percentile (%, :data:`PERCENTILES`) -> value in ``unit``; empty when no sample has a
        finite value.
    """

    name: str
    unit: str
    n: int
    passes: int
    low: float
    high: float
    percentiles: dict[float, float]

    @property
    def pass_rate(self) -> float:
        """Fraction of the samples within the bounds."""
        return self.passes / self.n


@dataclass(frozen=True)
class Statistics:
    """What a scenario campaign shows: pass rates with their intervals, percentiles, worst samples.

    Attributes
    ----------
    scenario : str
    n, n_failed : int
        Samples, and those that did not run (``failed`` > 0).
    confidence : float
        Two-sided confidence of the intervals, in (0, 1).
    overall : MetricStatistics
        Every metric within its bounds (``passed``), no percentiles.
    metrics : list of MetricStatistics
    worst : pandas.DataFrame
        The ``k`` worst samples (failed ones first, then by the smallest margin to a bound,
        in the metrics' units, over the metrics with bounds): their rows.
    """

    scenario: str
    n: int
    n_failed: int
    confidence: float
    overall: MetricStatistics
    metrics: list[MetricStatistics]
    worst: pd.DataFrame

    def text(self) -> str:
        """The statistics as a readable table."""
        pct = "  ".join(f"{'p' + format(p, 'g'):>10}" for p in PERCENTILES)
        lines = [f"{self.scenario}: {self.n} samples, {self.n_failed} failed to run; pass rates with "
                 f"Clopper-Pearson intervals at {100 * self.confidence:g} % confidence",
                 f"{'metric':<32} {'pass':>9} {'rate':>7} {'interval':>17}  {pct}  unit"]
        for s in [self.overall, *self.metrics]:
            values = "  ".join(f"{s.percentiles[p]:>10.4g}" if p in s.percentiles else f"{'':>10}" for p in PERCENTILES)
            lines.append(f"{s.name[:32]:<32} {s.passes:>4}/{s.n:<4} {s.pass_rate:>7.2%} "
                         f"[{s.low:>6.2%}, {s.high:>7.2%}]  {values}  {s.unit}")
        if len(self.worst):
            lines.append(f"worst {len(self.worst)} samples:")
            lines.append(self.worst.to_string(index=False, float_format=lambda v: f"{v:.6g}"))
        return "\n".join(lines)


def clopper_pearson(successes: int, n: int, confidence: float = 0.95) -> tuple[float, float]:
    """Exact (Clopper-Pearson) two-sided interval of a binomial probability.

    Parameters
    ----------
    successes, n : int
        Successes of ``n`` >= 1 trials.
    confidence : float
        In (0, 1).

    Returns
    -------
    (float, float)
        Lower and upper bound: the Beta quantiles that define the interval,
        ``B^-1(alpha/2; k, n - k + 1)`` and ``B^-1(1 - alpha/2; k + 1, n - k)`` with ``alpha = 1 -
        confidence`` (0 for no success, 1 for no failure), from ``scipy.special.betaincinv``
        (scipy.stats, whose ``binomtest`` finds the same bounds by root finding, costs 1 s more
        of imports).
    """
    from scipy.special import betaincinv

    k, n = int(successes), int(n)
    alpha = (1.0 - confidence) / 2
    low = 0.0 if k == 0 else float(betaincinv(k, n - k + 1, alpha))
    high = 1.0 if k == n else float(betaincinv(k + 1, n - k, 1.0 - alpha))
    return low, high


def _metric_statistics(name: str, unit: str, passed: np.ndarray, values: np.ndarray | None,
                       confidence: float) -> MetricStatistics:
    passes = int(passed.sum())
    finite = values[np.isfinite(values)] if values is not None else np.array([])
    pct = dict(zip(PERCENTILES, map(float, np.percentile(finite, PERCENTILES)))) if finite.size else {}
    return MetricStatistics(name, unit, int(passed.size), passes, *clopper_pearson(passes, passed.size, confidence),
                            pct)


def statistics(scenario: "str | Path | Mapping[str, Any] | Scenario", df: pd.DataFrame, confidence: float = 0.95,
               k: int = 5) -> Statistics:
    """The statistics of a scenario campaign's rows (:func:`satfmu.sims.campaign.engine.load`).

    Parameters
    ----------
    scenario : Scenario, dict, str or Path
        The campaign's scenario (its metrics' names, units and bounds).
    df : pandas.DataFrame
        The campaign's rows (the columns of :mod:`satfmu.sims.campaign.scenario_task`'s docstring).
    confidence : float
        Two-sided confidence of the pass-rate intervals, in (0, 1).
    k : int
        How many worst samples to list, >= 0.

    Raises
    ------
    CampaignError
        No rows, a metric column missing, or a confidence not in (0, 1).
    """
    sc = load(scenario)
    if not 0.0 < confidence < 1.0:
        raise CampaignError(f"confidence must be in (0, 1), got {confidence!r}")
    missing = [c for c in [m.name for m in sc.metrics] + list(_RESERVED) if c not in df.columns]
    if len(df) == 0 or missing:
        raise CampaignError(f"not the rows of a campaign of {sc.name!r}: "
                            + (f"columns {missing} missing" if missing else "no rows"))
    failed = df["failed"].to_numpy() > 0
    per_metric, margin = [], np.full(len(df), np.inf)
    for m in sc.metrics:
        values = df[m.name].to_numpy(dtype=np.float64)
        passed = np.array([MetricResult(m.name, m.kind, float(v), m.min, m.max, m.value_unit).passed
                           for v in values])
        per_metric.append(_metric_statistics(m.name, m.value_unit, passed, values, confidence))
        for bound, sign in ((m.max, 1.0), (m.min, -1.0)):
            if bound is not None:
                margin = np.fmin(margin, sign * (bound - values))
    margin[np.isnan(margin)] = -np.inf
    overall = _metric_statistics("all metrics (passed)", "", df["passed"].to_numpy() == 1.0, None, confidence)
    order = np.lexsort((margin, ~failed))[:max(int(k), 0)]  # failed first, then by margin (stable)
    return Statistics(sc.name, len(df), int(failed.sum()), confidence, overall, per_metric,
                      df.iloc[order].reset_index(drop=True))
