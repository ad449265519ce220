"""Time tables: breakpoints and values of a function of time, evaluated in numpy (no sympy).

:class:`Table` is ``"linear"`` or ``"previous"``; its :meth:`Table.evaluate` is the formula the
generated Python and C of a table look-up use (:mod:`satfmu.fmus.codegen`), so a profile sampled
in process and its generator FMU agree.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from satfmu.fmus.errors import ModelDefinitionError
from satfmu.fmus.instants import time_tolerance_of

@dataclass(frozen=True)
class Table:
    """Breakpoints and values of a function of one variable (a time table), s and any unit.

    Before the first breakpoint the first value holds, after the last the last value.
    ``"previous"`` holds each value from its breakpoint on (a breakpoint within
    :func:`satfmu.fmus.model.time_tolerance` ahead counts as reached); ``"linear"`` interpolates between breakpoints.
    The numpy :meth:`evaluate`, the generated Python and the generated C use one formula.

    Attributes
    ----------
    times : tuple of float
        Breakpoints, strictly increasing (s for a time table).
    values : tuple of float
        The value at each breakpoint, in the unit of the quantity tabulated.
    interpolation : {"linear", "previous"}, optional
        Linear between breakpoints (default) or each value held from its breakpoint on.

    Raises
    ------
    ModelDefinitionError
        Unequal or empty arrays, non-finite entries, breakpoints not strictly increasing,
        unknown interpolation.
    """

    times: tuple[float, ...]
    values: tuple[float, ...]
    interpolation: Literal["previous", "linear"] = "linear"

    def __post_init__(self) -> None:
        t, v = np.asarray(self.times, float), np.asarray(self.values, float)
        if t.ndim != 1 or t.shape != v.shape or t.size == 0:
            raise ModelDefinitionError("times and values must be 1-D of equal non-zero length")
        if not (np.all(np.isfinite(t)) and np.all(np.isfinite(v))):
            raise ModelDefinitionError("times and values must be finite")
        if np.any(np.diff(t) <= 0):
            raise ModelDefinitionError("times must be strictly increasing")
        if self.interpolation not in ("previous", "linear"):
            raise ModelDefinitionError(f"interpolation must be 'linear' or 'previous', got {self.interpolation!r}")
        object.__setattr__(self, "times", tuple(map(float, t)))
        object.__setattr__(self, "values", tuple(map(float, v)))

    def evaluate(self, t: np.ndarray | float) -> np.ndarray:
        """Values at ``t`` (any shape).

        Parameters
        ----------
        t : float or numpy.ndarray
            Where to evaluate (s for a time table), any shape.

        Returns
        -------
        numpy.ndarray
            The interpolated values, same shape as ``t``.
        """
        tt, v = np.asarray(self.times), np.asarray(self.values)
        t = np.asarray(t, float)
        if self.interpolation == "previous":
            i = np.searchsorted(tt, t + time_tolerance_of(t), side="right") - 1
            return v[np.clip(i, 0, None)]
        i = np.clip(np.searchsorted(tt, t, side="right") - 1, 0, max(tt.size - 2, 0))
        if tt.size == 1:
            return np.full_like(t, v[0])
        j = i + 1
        inner = v[i] + (v[j] - v[i]) * ((t - tt[i]) / (tt[j] - tt[i]))
        return np.where(t <= tt[0], v[0], np.where(t >= tt[-1], v[-1], inner))
