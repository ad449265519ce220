"""Closed-loop metrics on recorded trajectories, and their pass/fail evaluation.

:data:`EVALUATORS` is the table from a metric kind (:data:`KINDS`) to the function that
evaluates it on what the metric reads of a run (a :class:`MetricInput`).

The metric functions take the time vector ``t`` (s, increasing) and a signal matrix of
shape (len(t), n_signals). Signals of FMU *inputs* fed by the master are held
over each communication step, so their integrals use the left rectangle rule;
FMU outputs of continuous states use the trapezoidal rule.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from satfmu.fmus.units import ratio, squared_time


def _cumulative(t: np.ndarray, v2: np.ndarray, held: bool) -> np.ndarray:
    dt = np.diff(t)
    inc = v2[:-1] * dt if held else 0.5 * (v2[:-1] + v2[1:]) * dt
    return np.concatenate([[0.0], np.cumsum(inc)])


def l2_ratio_curve(t: np.ndarray, z: np.ndarray, w: np.ndarray, w_held: bool = True) -> np.ndarray:
    """Truncated L2 ratio ||z||_{2,T} / ||w||_{2,T} for every recorded T (seed 000, eq. 45).

    NaN where ||w||_{2,T} = 0.

    Parameters
    ----------
    t : numpy.ndarray, shape (n,)
        Sample times (s), increasing.
    z : numpy.ndarray, shape (n,) or (n, k)
        Performance output, one column per signal; its energy is integrated by the trapezoidal
        rule.
    w : numpy.ndarray, shape (n,) or (n, m)
        Disturbance input, one column per signal.
    w_held : bool, optional
        Whether ``w`` is held over each communication step (an FMU input fed by the master:
        left rectangle rule); else the trapezoidal rule. Default True.

    Returns
    -------
    numpy.ndarray, shape (n,)
        The ratio at every sample time (dimensionless when ``z`` and ``w`` share a unit).
    """
    nz = _cumulative(t, np.sum(np.atleast_2d(z.T).T ** 2, axis=1), held=False)
    nw = _cumulative(t, np.sum(np.atleast_2d(w.T).T ** 2, axis=1), held=w_held)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(nw > 0, np.sqrt(nz) / np.sqrt(np.where(nw > 0, nw, 1.0)), np.nan)


def settling_time(t: np.ndarray, y: np.ndarray, tolerance: float) -> float:
    """First time from which every ``|y_i| <= tolerance`` until the end; inf if never.

    Parameters
    ----------
    t : numpy.ndarray, shape (n,)
        Sample times (s), increasing.
    y : numpy.ndarray, shape (n,) or (n, k)
        Signals, one column each.
    tolerance : float
        Half-width of the band around zero, in the unit of ``y``.

    Returns
    -------
    float
        The settling time (s): ``t[0]`` if ``y`` is inside the band throughout, ``inf`` if it is
        outside at the last sample.
    """
    inside = np.all(np.abs(np.atleast_2d(y.T).T) <= tolerance, axis=1)
    if not inside[-1]:
        return math.inf
    outside = np.nonzero(~inside)[0]
    return float(t[0] if outside.size == 0 else t[outside[-1] + 1])


def peak(y: np.ndarray) -> float:
    """Largest absolute value over time and signals.

    Parameters
    ----------
    y : numpy.ndarray, shape (n,) or (n, k)
        Signals, one column each.
    """
    return float(np.max(np.abs(y)))


def rms(t: np.ndarray, y: np.ndarray, held: bool = True) -> float:
    """Largest per-signal RMS over the run.

    Parameters
    ----------
    t : numpy.ndarray, shape (n,)
        Sample times (s), increasing; the mean is taken over ``t[-1] - t[0]``.
    y : numpy.ndarray, shape (n,) or (n, k)
        Signals, one column each.
    held : bool, optional
        Whether the signals are held over each communication step (left rectangle rule); else
        the trapezoidal rule. Default True.

    Returns
    -------
    float
        The RMS, in the unit of ``y``.
    """
    y = np.atleast_2d(y.T).T
    span = t[-1] - t[0]
    return float(max(math.sqrt(_cumulative(t, y[:, i] ** 2, held)[-1] / span) for i in range(y.shape[1])))


def time_in_saturation(t: np.ndarray, y: np.ndarray, limit: float, held: bool = True,
                       rel_tol: float = 1e-9) -> float:
    """Total time (s) during which any ``|y_i|`` is at or beyond ``limit`` (within ``rel_tol``).

    Parameters
    ----------
    t : numpy.ndarray, shape (n,)
        Sample times (s), increasing.
    y : numpy.ndarray, shape (n,) or (n, k)
        Signals, one column each (e.g. actuator commands).
    limit : float
        Saturation level, in the unit of ``y``.
    held : bool, optional
        Whether the signals are held over each communication step: a step counts whole when
        saturated at its start; else a step counts half for each saturated end. Default True.
    rel_tol : float, optional
        Relative tolerance: ``|y_i| >= limit * (1 - rel_tol)`` counts as saturated.
    """
    sat = np.any(np.abs(np.atleast_2d(y.T).T) >= limit * (1 - rel_tol), axis=1)
    dt = np.diff(t)
    flags = sat[:-1] if held else 0.5 * (sat[:-1].astype(float) + sat[1:])
    return float(np.sum(flags * dt))


def time_to_limit(t: np.ndarray, y: np.ndarray, limit: float, rel_tol: float = 1e-9) -> float:
    """The first sample time (s) at which any ``|y_i|`` reaches ``limit`` (within ``rel_tol``), ``inf``
    when none does: when a wheel saturates under a momentum buildup, say.

    Parameters
    ----------
    t : numpy.ndarray, shape (n,)
        Sample times (s), increasing.
    y : numpy.ndarray, shape (n,) or (n, k)
        Signals, one column each.
    limit : float
        The level, in the unit of ``y``.
    rel_tol : float, optional
        Relative tolerance: ``|y_i| >= limit * (1 - rel_tol)`` counts as reached.

    Returns
    -------
    float
        The time, s, or ``inf``.
    """
    reached = np.any(np.abs(np.atleast_2d(y.T).T) >= limit * (1 - rel_tol), axis=1)
    return float(t[np.argmax(reached)]) if reached.any() else math.inf


def integral_square(t: np.ndarray, y: np.ndarray, held: Sequence[bool]) -> float:
    """``integral of sum_i y_i^2 dt`` over the run (e.g. an H2 cost with unit weights), each
    signal by its own rule (``held[i]``: left rectangle, else trapezoidal).

    Parameters
    ----------
    t : numpy.ndarray, shape (n,)
        Sample times (s), increasing.
    y : numpy.ndarray, shape (n,) or (n, k)
        Signals, one column each.
    held : sequence of bool
        One per column of ``y``: whether that signal is held over each communication step.

    Returns
    -------
    float
        The integral, in the unit of ``y`` squared times s.
    """
    y = np.atleast_2d(y.T).T
    return float(sum(_cumulative(t, y[:, i] ** 2, held[i])[-1] for i in range(y.shape[1])))


def attitude_angle(s1: np.ndarray, s2: np.ndarray) -> np.ndarray:
    """The rotation angle between two MRP attitudes, row by row, rad: ``2 atan2(|v|, |w|)`` of the
    relative quaternion ``(v, w) = q1^-1 q2`` (accurate near 0, where ``arccos`` of a dot product is
    not: it cannot resolve angles below ~1e-8 rad).

    Parameters
    ----------
    s1, s2 : numpy.ndarray, shape (n, 3)
        The MRPs (either set: the angle is the same for a shadow set).

    Returns
    -------
    numpy.ndarray, shape (n,)
        The angles, rad, in [0, pi].
    """
    def quaternion(s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        n2 = np.sum(s * s, axis=1, keepdims=True)
        return (1 - n2[:, 0]) / (1 + n2[:, 0]), 2 * s / (1 + n2)

    w1, v1 = quaternion(np.atleast_2d(s1))
    w2, v2 = quaternion(np.atleast_2d(s2))
    w = w1 * w2 + np.sum(v1 * v2, axis=1)
    v = w1[:, None] * v2 - w2[:, None] * v1 - np.cross(v1, v2)
    return 2 * np.arctan2(np.linalg.norm(v, axis=1), np.abs(w))


@dataclass(frozen=True)
class MetricInput:
    """What a metric reads of a recorded run, as the functions of :data:`EVALUATORS` take it.

    Attributes
    ----------
    t : numpy.ndarray, shape (n,)
        Sample times (s), increasing.
    y : numpy.ndarray, shape (n, k)
        The metric's signals, one column each, in the metric's unit (converted from the declared
        one, :func:`satfmu.sims.scenario.conversions.metric_conversion`, times its scale).
    held : bool
        Whether every signal is held over each communication step (an FMU input fed by the
        master, or a connected output).
    inputs : sequence of bool
        One per column of ``y``: whether that signal is an FMU input the master sets
        (``integral_square`` integrates it by the left rectangle rule).
    tolerance : float, optional
        Band of ``settling_time``, in the unit of ``y``.
    limit : float, optional
        Saturation level of ``time_in_saturation``, in the unit of ``y``.
    versus : numpy.ndarray, shape (n, k), optional
        Reference signals of ``max_difference``, in the unit of ``y``.
    disturbances : numpy.ndarray, shape (n, m), optional
        Denominator signals of ``l2_ratio`` (not scaled).
    disturbances_held : bool
        Whether every disturbance signal is held over each communication step.
    scale : float
        The factor ``y`` and ``versus`` were multiplied by (an ``attitude_difference`` divides
        it out to read the MRPs, and gives its angle, rad, times it).
    """

    t: np.ndarray
    y: np.ndarray
    held: bool = True
    inputs: Sequence[bool] = ()
    tolerance: float | None = None
    limit: float | None = None
    versus: np.ndarray | None = None
    disturbances: np.ndarray | None = None
    disturbances_held: bool = True
    scale: float = 1.0


Evaluation = tuple[float, np.ndarray | None]
"""What a metric function gives: the value, and its curve over time (``l2_ratio``) or None."""


def _final(d: MetricInput) -> Evaluation:
    """Largest absolute value at the last sample."""
    return float(np.max(np.abs(d.y[-1]))), None


def _peak(d: MetricInput) -> Evaluation:
    return peak(d.y), None


def _rms(d: MetricInput) -> Evaluation:
    return rms(d.t, d.y, held=d.held), None


def _settling_time(d: MetricInput) -> Evaluation:
    assert d.tolerance is not None  # validate(): settling_time needs a tolerance (_NEEDS)
    return settling_time(d.t, d.y, float(d.tolerance)), None


def _l2_ratio(d: MetricInput) -> Evaluation:
    """The largest truncated L2 ratio over T (NaN if none is finite), and the ratio over T."""
    assert d.disturbances is not None  # validate(): l2_ratio needs disturbances (_NEEDS)
    curve = l2_ratio_curve(d.t, d.y, d.disturbances, w_held=d.disturbances_held)
    return (float(np.nanmax(curve)) if np.any(np.isfinite(curve)) else math.nan), curve


def _time_in_saturation(d: MetricInput) -> Evaluation:
    assert d.limit is not None  # validate(): time_in_saturation needs a limit (_NEEDS)
    return time_in_saturation(d.t, d.y, float(d.limit), held=d.held), None


def _time_to_limit(d: MetricInput) -> Evaluation:
    assert d.limit is not None  # validate(): time_to_limit needs a limit (_NEEDS)
    return time_to_limit(d.t, d.y, float(d.limit)), None


def _integral_square(d: MetricInput) -> Evaluation:
    return integral_square(d.t, d.y, d.inputs), None


def _max_difference(d: MetricInput) -> Evaluation:
    """The largest ``|signal - versus|`` (as many versus signals as signals: checked by wire())."""
    assert d.versus is not None  # validate(): max_difference needs versus (_NEEDS)
    return peak(d.y - d.versus), None


def _attitude_difference(d: MetricInput) -> Evaluation:
    """The largest rotation angle between the MRP ``signals`` and the MRP ``versus`` (3 each: checked
    by wire()), rad times the scale."""
    assert d.versus is not None  # validate(): attitude_difference needs versus (_NEEDS)
    if d.scale == 0:
        return 0.0, None
    return float(np.max(attitude_angle(d.y / d.scale, d.versus / d.scale))) * d.scale, None


EVALUATORS: dict[str, Callable[[MetricInput], Evaluation]] = {
    "final": _final, "peak": _peak, "rms": _rms, "settling_time": _settling_time, "l2_ratio": _l2_ratio,
    "time_in_saturation": _time_in_saturation, "time_to_limit": _time_to_limit, "integral_square": _integral_square,
    "max_difference": _max_difference, "attitude_difference": _attitude_difference}
"""Metric kind -> the function that evaluates it on a :class:`MetricInput`: (value, curve or None)."""
MARGIN_KINDS: dict[str, str] = {"gain_margin": "dB", "phase_margin": "deg", "delay_margin": "s",
                                "disk_gain_margin": "dB", "disk_phase_margin": "deg", "sensitivity_peak": "1",
                                "complementary_peak": "1"}
"""Metric kinds read from a scenario's loop linearized at the origin and sampled at its communication
step (:func:`satfmu.sims.scenario.loops.margin_metric`), not from the run -> the unit of their value.
``signals`` names the plant inputs where the loop is broken: the loop-at-a-time kinds (gain, phase,
delay) give the worst of those channels, the others are of the whole loop that holds them."""
KINDS = tuple(EVALUATORS) + tuple(MARGIN_KINDS)
"""The metric kinds, in the order error messages list them."""
TIME_KINDS = ("settling_time", "time_in_saturation", "time_to_limit")
"""Metric kinds whose value is a time, s (``unit`` is then the unit of their ``tolerance`` or ``limit``)."""


def value_unit(kind: str, unit: str, disturbance_unit: str = "") -> str:
    """The unit of a metric's value from the unit of its signals.

    Parameters
    ----------
    kind : str
        The metric kind.
    unit : str
        The unit of its (converted) signals; ``""`` unknown.
    disturbance_unit : str
        The unit of an ``l2_ratio``'s disturbances.
    """
    if kind in TIME_KINDS:
        return "s"
    if kind in MARGIN_KINDS:
        return unit or MARGIN_KINDS[kind]
    if not unit:
        return ""
    if kind == "integral_square":
        return squared_time(unit)
    if kind == "l2_ratio":
        return ratio(unit, disturbance_unit) if disturbance_unit else ""
    return unit

"""The metric kinds, in the order error messages list them."""


@dataclass
class MetricResult:
    """One evaluated metric with its bounds.

    Parameters
    ----------
    name : str
        Label of the metric (the ``name`` of its :class:`satfmu.sims.scenario.spec.Metric`).
    kind : str
        Its kind, one of ``KINDS`` (``peak``, ``rms``, ``l2_ratio``, ...).
    value : float
        The value on the run, in ``unit``; NaN never passes.
    min, max : float or None
        Pass/fail bounds, in ``unit``; None: no bound.
    unit : str, optional
        Unit of the value and bounds, e.g. ``"deg"``; ``"s"`` for a time, ``"N2.m2.s"`` for an
        ``integral_square`` of torques (:func:`value_unit`).
    """

    name: str
    kind: str
    value: float
    min: float | None
    max: float | None
    unit: str = ""

    @property
    def passed(self) -> bool:
        ok = not math.isnan(self.value)
        if self.max is not None:
            ok &= self.value <= self.max
        if self.min is not None:
            ok &= self.value >= self.min
        return bool(ok)

    def to_json(self) -> dict[str, Any]:
        """The metric as plain data: name, kind, value, unit, min, max and passed."""
        return {"name": self.name, "kind": self.kind, "value": self.value, "unit": self.unit,
                "min": self.min, "max": self.max, "passed": self.passed}


def summaries_markdown(summaries: Sequence[dict[str, Any]]) -> str:
    """Scenario run summaries (``satfmu.sims.scenario.result.Result.summary()``) as a Markdown table, one row
    per metric.

    Parameters
    ----------
    summaries : sequence of dict
        Run summaries, each with ``scenario``, ``backend`` and ``metrics`` (the
        :meth:`MetricResult.to_json` of each metric).
    """
    lines = ["| scenario | backend | metric | value | unit | bounds | result |", "|---|---|---|---|---|---|---|"]
    for s in summaries:
        for m in s["metrics"]:
            bounds = " ".join(f"{k} {m[k]:g}" for k in ("min", "max") if m[k] is not None)
            lines.append(f"| {s['scenario']} | {s['backend']} | {m['name']} | {m['value']:.6g} | {m['unit']} | "
                         f"{bounds} | {'pass' if m['passed'] else 'FAIL'} |")
    return "\n".join(lines) + "\n"


def write_summaries(summaries: Sequence[dict[str, Any]], path: Path) -> tuple[Path, Path]:
    """Write the run summaries to ``path`` (JSON) and beside it as Markdown (``.md``, :func:`summaries_markdown`).

    Parameters
    ----------
    summaries : sequence of dict
        Run summaries (:meth:`satfmu.sims.scenario.result.Result.summary`).
    path : Path
        The JSON file to write (its folder is created); the Markdown goes to
        ``path.with_suffix(".md")``.

    Returns
    -------
    (Path, Path)
        The JSON and the Markdown file.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(list(summaries), indent=1) + "\n")
    md = path.with_suffix(".md")
    md.write_text(summaries_markdown(summaries))
    return path, md
