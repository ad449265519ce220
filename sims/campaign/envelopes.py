"""Percentile envelopes of a campaign's time histories.

A scenario campaign can keep, for every sample, the time history of chosen recorded signals
at ``points`` communication times spread evenly over the run (:func:`trace_steps`): they
travel as ordinary float columns of the sample's row, ``"<signal>@<i>"``
(:func:`trace_columns`), so they are checksummed, resumed and loaded like the metrics. At
the end, :func:`envelopes` turns them into one table: ``time`` (s) and, per signal, the
percentiles :data:`LEVELS` over the samples that ran (``"<signal>:p50"``), the band a
reviewer reads beside the requirement lines.
"""
from __future__ import annotations

import numpy as np
import pandas as pd

LEVELS = (0.0, 0.135, 2.5, 50.0, 97.5, 99.865, 100.0)
"""Percentiles of each envelope, %: the extremes, the 3-sigma and 2-sigma bands of a normal
distribution (0.135/99.865 and 2.5/97.5) and the median."""
POINTS = 500
"""Default number of time points kept per signal and sample."""


def trace_steps(n_rows: int, points: int) -> np.ndarray:
    """Indices of at most ``points`` recorded rows out of ``n_rows``, evenly spread, the first and
    the last included, increasing.

    Parameters
    ----------
    n_rows : int
        Recorded rows (communication points) of a run.
    points : int
        Most rows to keep, >= 2 (all of them when ``n_rows`` is smaller).

    Returns
    -------
    numpy.ndarray
        The row indices, int64.

    Raises
    ------
    ValueError
        ``points`` < 2.
    """
    if isinstance(points, bool) or not isinstance(points, (int, np.integer)) or points < 2:
        raise ValueError(f"envelope points must be an integer >= 2, got {points!r}")
    return np.unique(np.round(np.linspace(0, n_rows - 1, min(points, n_rows))).astype(np.int64))


def trace_columns(signal: str, count: int) -> list[str]:
    """The row columns of one signal's trace: ``"<signal>@0"`` ... ``"<signal>@<count - 1>"``.

    Parameters
    ----------
    signal : str
        Qualified recorded signal (``"plant.theta[3]"``).
    count : int
        Points of the trace (:func:`trace_steps`).
    """
    return [f"{signal}@{i}" for i in range(count)]


def envelopes(rows: pd.DataFrame, signals: list[str], times: np.ndarray) -> pd.DataFrame:
    """The percentile envelopes of the traces in a campaign's rows.

    Parameters
    ----------
    rows : pandas.DataFrame
        A campaign's rows with the trace columns of ``signals``; a sample that did not run has
        NaN traces and is left out.
    signals : list of str
        Qualified recorded signals (``"plant.theta[3]"``).
    times : ndarray
        The times of the trace points, s.

    Returns
    -------
    pandas.DataFrame
        ``time`` and ``"<signal>:p<level>"`` for each signal and level of :data:`LEVELS`.
    """
    out = {"time": np.asarray(times, dtype=np.float64)}
    for s in signals:
        traces = rows[trace_columns(s, len(times))].to_numpy(dtype=np.float64)
        ran = traces[~np.isnan(traces).any(axis=1)]
        for level in LEVELS:
            out[f"{s}:p{level:g}"] = (np.percentile(ran, level, axis=0) if len(ran)
                                      else np.full(len(times), np.nan))
    return pd.DataFrame(out)
