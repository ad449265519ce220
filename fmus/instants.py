"""Instants: when two times are one, and which sample an instant falls in (numpy, no sympy).

- :data:`TIME_TOL`, :data:`TIME_TOL_MAX`, :data:`TIME_ULPS`, :func:`time_tolerance_of`: two
  times closer than the time tolerance are one instant (the symbolic form, for models:
  :func:`satfmu.fmus.model.time_tolerance`; the generated Python and C use the same constants).
- :data:`MIN_SAMPLE_PERIOD`, :data:`INDEX_TOL`: the sampled laws' shortest period and the
  fraction of a period that rounds a sample index.
"""
from __future__ import annotations

import numpy as np

TIME_TOL = 1e-9
"""Relative time tolerance (times ``max(1, |t|)``, within the bounds of
:func:`satfmu.fmus.model.time_tolerance`): two times closer than this are one instant. Generated
C and Python use it for sample instants, table breakpoints and switching times, so an FMU driven
at ``t0 + k h`` and a master sampling ``t0 + h k`` (or adding ``h`` step by step: ~1e5 steps
drift by ``1e-9 |t|``) agree at every jump."""
TIME_TOL_MAX = 1e-6
"""The largest time tolerance, s: at Unix times (1.4e9 s) a relative 1e-9 would merge instants 1.4 s
apart; 1 us keeps every instant of a sampled FMU (control periods from 1 ms on) distinct and is
still 4 units in the last place there (double precision resolves 2.4e-7 s at 1.4e9 s)."""
TIME_ULPS = 8
"""The smallest time tolerance in units in the last place of ``|t|``: what double precision forces
(``t_{k-1} + h`` and ``t0 + k h`` differ by ~2 ulp), beyond 5.6e9 s where it exceeds 1 us."""


def time_tolerance_of(t: np.ndarray | float) -> np.ndarray:
    """:func:`satfmu.fmus.model.time_tolerance` of numbers (numpy), s.

    Parameters
    ----------
    t : float or numpy.ndarray
        Times, s (any shape).

    Returns
    -------
    numpy.ndarray
        The tolerance at each time, s, same shape as ``t``.
    """
    a = np.abs(np.asarray(t, float))
    return np.maximum(np.minimum(TIME_TOL * np.maximum(1.0, a), TIME_TOL_MAX), TIME_ULPS * 2.0**-52 * a)


MIN_SAMPLE_PERIOD = 1e-3
"""The smallest sample period the project's sampled laws declare, s: 1 kHz, ten times faster than
the fastest period they use (the online SDRE's 0.01 s), and far above the time resolution (the
instants of one FMU stay 1000 time tolerances apart at any time below 5.6e9 s, see
:data:`TIME_TOL_MAX`); a 100 s step spans 1e5 instants (a native B-dot FMU takes ~1 ms for them)."""
INDEX_TOL = 1e-6
"""Fraction of a sample period added before the floor of a sample index: an instant computed
as 899.9999999999 s counts as the one of 900 s (a periodic gain schedule's index)."""
