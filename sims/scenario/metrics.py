"""Closed-loop metrics on recorded trajectories, and their pass/fail evaluation.

:data:`STREAMS` is the table from a metric kind (:data:`KINDS`) to its :class:`MetricStream`, which
evaluates it on what the metric reads of a run (a :class:`MetricInput`) fed in blocks of rows as
the run records them; :data:`EVALUATORS` feeds a whole run as one block (one implementation).

The metric functions take the time vector ``t`` (s, increasing) and a signal matrix of
shape (len(t), n_signals). Signals of FMU *inputs* fed by the master are held
over each communication step, so their integrals use the left rectangle rule;
FMU outputs of continuous states use the trapezoidal rule.
"""
from __future__ import annotations

import functools
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Protocol, Sequence

import numpy as np

from satfmu.fmus.units import ratio, squared_time


def _signals(y: np.ndarray) -> np.ndarray:
    """``y`` as rows x signals (a vector is one signal)."""
    return np.atleast_2d(np.asarray(y, float).T).T


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
    """What a metric reads of a recorded run, or of a block of its rows, as a :class:`MetricStream`
    takes it.

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
"""What a metric gives: the value, and its curve over time (``l2_ratio``) or None."""
REL_TOL = 1e-9
"""Relative tolerance of a level: ``|y| >= limit (1 - REL_TOL)`` counts as reaching it."""


class MetricStream(Protocol):
    """One metric evaluated on a run fed in blocks of consecutive rows, in order (the whole run is
    one block): what it keeps between blocks does not grow with the run (an ``l2_ratio``'s
    curve aside, when kept), and the value is the same, bit for bit, however the run is cut."""

    def feed(self, d: MetricInput) -> None:
        """Take the next block of rows.

        Parameters
        ----------
        d : MetricInput
            The block: its rows follow those fed before, its other fields are the metric's.
        """

    def result(self) -> Evaluation:
        """The value (and curve) over every row fed."""


class _Integral:
    """The integral over time of each column, fed block by block: the left rectangle rule on the
    columns ``held`` marks, the trapezoidal rule on the others. The steps' areas are added one
    by one, in order, so the integral at each row does not depend on how the run is cut."""

    def __init__(self) -> None:
        self.total: np.ndarray | None = None
        """The integral at the last row fed, per column."""
        self._t = 0.0
        self._v = np.zeros(0)

    def feed(self, t: np.ndarray, v: np.ndarray, held: bool | np.ndarray) -> np.ndarray:
        """The integral at each row of the block, shape ``v.shape`` (zero at the run's first row)."""
        if self.total is None:
            tt, vv, start = t, v, np.zeros(v.shape[1])
        else:  # the step from the last row of the block before
            tt, vv, start = np.concatenate([[self._t], t]), np.vstack([self._v, v]), self.total
        dt = np.diff(tt)[:, None]
        left = vv[:-1] * dt
        inc = left if np.all(held) else np.where(held, left, 0.5 * (vv[:-1] + vv[1:]) * dt)
        cum = np.cumsum(np.vstack([start[None, :], inc]), axis=0)
        out = cum if self.total is None else cum[1:]
        self.total, self._t, self._v = cum[-1], float(t[-1]), v[-1]
        return out


class _Final:
    """Largest absolute value at the last sample."""

    def __init__(self) -> None:
        self.last = np.full(1, math.nan)

    def feed(self, d: MetricInput) -> None:
        self.last = d.y[-1]

    def result(self) -> Evaluation:
        return float(np.max(np.abs(self.last))), None


class _Peak:
    """Largest absolute value over time and signals (NaN if any is)."""

    def __init__(self) -> None:
        self.value = -math.inf

    def values(self, d: MetricInput) -> np.ndarray:
        return d.y

    def feed(self, d: MetricInput) -> None:
        self.value = float(np.max([self.value, np.max(np.abs(self.values(d)))]))

    def result(self) -> Evaluation:
        return self.value, None


class _MaxDifference(_Peak):
    """The largest ``|signal - versus|`` (as many versus signals as signals: checked by wire())."""

    def values(self, d: MetricInput) -> np.ndarray:
        assert d.versus is not None  # validate(): max_difference needs versus (_NEEDS)
        return d.y - d.versus


class _Rms:
    """Largest per-signal RMS over the run (the mean over its span)."""

    def __init__(self) -> None:
        self.integral = _Integral()
        self.span = (math.nan, math.nan)

    def feed(self, d: MetricInput) -> None:
        self.span = (float(d.t[0]) if self.integral.total is None else self.span[0], float(d.t[-1]))
        self.integral.feed(d.t, d.y ** 2, d.held)

    def result(self) -> Evaluation:
        assert self.integral.total is not None  # a run has at least its start row
        span = self.span[1] - self.span[0]
        return float(max(math.sqrt(v / span) for v in self.integral.total)), None


class _IntegralSquare:
    """``integral of sum_i y_i^2 dt``, each signal by its own rule (an FMU input: left rectangle)."""

    def __init__(self) -> None:
        self.integral = _Integral()

    def feed(self, d: MetricInput) -> None:
        self.integral.feed(d.t, d.y ** 2, np.asarray(d.inputs, bool))

    def result(self) -> Evaluation:
        assert self.integral.total is not None  # a run has at least its start row
        return float(sum(self.integral.total)), None


class _SettlingTime:
    """First time from which every ``|y_i| <= tolerance`` until the end; inf if outside at the end."""

    def __init__(self) -> None:
        self.settled: float | None = None
        """The time of the row after the last one outside the band (the first row's time if none
        is); None while the last row fed is outside."""
        self.started = False

    def feed(self, d: MetricInput) -> None:
        assert d.tolerance is not None  # validate(): settling_time needs a tolerance (_NEEDS)
        inside = np.all(np.abs(d.y) <= d.tolerance, axis=1)
        outside = np.nonzero(~inside)[0]
        if not self.started:
            self.settled, self.started = float(d.t[0]), True
        if outside.size:
            last = int(outside[-1])
            self.settled = float(d.t[last + 1]) if last + 1 < len(d.t) else None
        elif self.settled is None:  # the block before ended outside
            self.settled = float(d.t[0])

    def result(self) -> Evaluation:
        return (math.inf if self.settled is None else self.settled), None


class _L2Ratio:
    """The largest truncated L2 ratio ``||z||_{2,T} / ||w||_{2,T}`` over T (NaN if none is finite),
    and with ``curve`` the ratio at every row (seed 000, eq. 45; NaN where ``||w||_{2,T} = 0``)."""

    def __init__(self, curve: bool = True) -> None:
        self.z, self.w = _Integral(), _Integral()
        self.keep = curve
        self.curve: list[np.ndarray] = []
        self.best = -math.inf
        self.finite = False

    def feed(self, d: MetricInput) -> None:
        assert d.disturbances is not None  # validate(): l2_ratio needs disturbances (_NEEDS)
        nz = self.z.feed(d.t, np.sum(d.y ** 2, axis=1)[:, None], False)[:, 0]
        nw = self.w.feed(d.t, np.sum(d.disturbances ** 2, axis=1)[:, None], d.disturbances_held)[:, 0]
        with np.errstate(invalid="ignore", divide="ignore"):
            ratio_t = np.where(nw > 0, np.sqrt(nz) / np.sqrt(np.where(nw > 0, nw, 1.0)), np.nan)
        self.finite |= bool(np.any(np.isfinite(ratio_t)))
        if not np.all(np.isnan(ratio_t)):
            self.best = max(self.best, float(np.nanmax(ratio_t)))
        if self.keep:
            self.curve.append(ratio_t)

    def result(self) -> Evaluation:
        return (self.best if self.finite else math.nan), (np.concatenate(self.curve) if self.keep else None)


class _TimeInSaturation:
    """Total time during which any ``|y_i|`` is at or beyond ``limit``: with held signals a step
    counts whole when saturated at its start, else half for each saturated end."""

    def __init__(self, rel_tol: float = REL_TOL) -> None:
        self.rel_tol = rel_tol
        self.total = 0.0
        self._last: tuple[float, bool] | None = None

    def feed(self, d: MetricInput) -> None:
        assert d.limit is not None  # validate(): time_in_saturation needs a limit (_NEEDS)
        sat = np.any(np.abs(d.y) >= d.limit * (1 - self.rel_tol), axis=1)
        t = d.t
        if self._last is not None:  # the step from the last row of the block before
            t, sat = np.concatenate([[self._last[0]], t]), np.concatenate([[self._last[1]], sat])
        dt = np.diff(t)
        flags = sat[:-1] if d.held else 0.5 * (sat[:-1].astype(float) + sat[1:])
        self.total = float(np.cumsum(np.concatenate([[self.total], flags * dt]))[-1])  # in order, as _Integral
        self._last = (float(t[-1]), bool(sat[-1]))

    def result(self) -> Evaluation:
        return self.total, None


class _TimeToLimit:
    """The first sample time at which any ``|y_i|`` reaches ``limit``; inf if none does."""

    def __init__(self, rel_tol: float = REL_TOL) -> None:
        self.rel_tol = rel_tol
        self.reached_at = math.inf

    def feed(self, d: MetricInput) -> None:
        assert d.limit is not None  # validate(): time_to_limit needs a limit (_NEEDS)
        if self.reached_at == math.inf:
            reached = np.any(np.abs(d.y) >= d.limit * (1 - self.rel_tol), axis=1)
            if reached.any():
                self.reached_at = float(d.t[np.argmax(reached)])

    def result(self) -> Evaluation:
        return self.reached_at, None


class _AttitudeDifference:
    """The largest rotation angle between the MRP ``signals`` and the MRP ``versus`` (3 each:
    checked by wire()), rad times the scale."""

    def __init__(self) -> None:
        self.angle = -math.inf
        self.scale = 1.0

    def feed(self, d: MetricInput) -> None:
        assert d.versus is not None  # validate(): attitude_difference needs versus (_NEEDS)
        self.scale = d.scale
        if d.scale != 0:
            self.angle = float(np.max([self.angle, np.max(attitude_angle(d.y / d.scale, d.versus / d.scale))]))

    def result(self) -> Evaluation:
        return (0.0 if self.scale == 0 else self.angle * self.scale), None


STREAMS: dict[str, Callable[[], MetricStream]] = {
    "final": _Final, "peak": _Peak, "rms": _Rms, "settling_time": _SettlingTime, "l2_ratio": _L2Ratio,
    "time_in_saturation": _TimeInSaturation, "time_to_limit": _TimeToLimit, "integral_square": _IntegralSquare,
    "max_difference": _MaxDifference, "attitude_difference": _AttitudeDifference}
"""Metric kind -> a new :class:`MetricStream` of it."""


def metric_stream(kind: str, curve: bool = True) -> MetricStream:
    """A new stream of the metric ``kind`` (one of :data:`STREAMS`).

    Parameters
    ----------
    kind : str
        The metric kind.
    curve : bool, optional
        Keep an ``l2_ratio``'s curve over time (8 bytes a row). Default True.
    """
    return _L2Ratio(curve) if kind == "l2_ratio" else STREAMS[kind]()


def _whole(stream: MetricStream, d: MetricInput) -> Evaluation:
    """``stream`` fed the whole run ``d`` as one block."""
    stream.feed(d)
    return stream.result()


def _evaluate(make: Callable[[], MetricStream], d: MetricInput) -> Evaluation:
    return _whole(make(), d)


EVALUATORS: dict[str, Callable[[MetricInput], Evaluation]] = {
    kind: functools.partial(_evaluate, make) for kind, make in STREAMS.items()}
"""Metric kind -> the function that evaluates it on a whole run (its stream fed one block)."""


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
    curve = _whole(_L2Ratio(), MetricInput(t, _signals(z), disturbances=_signals(w), disturbances_held=w_held))[1]
    assert curve is not None  # kept
    return curve


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
    return _whole(_SettlingTime(), MetricInput(t, _signals(y), tolerance=tolerance))[0]


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
    return _whole(_Rms(), MetricInput(t, _signals(y), held=held))[0]


def time_in_saturation(t: np.ndarray, y: np.ndarray, limit: float, held: bool = True,
                       rel_tol: float = REL_TOL) -> float:
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
    return _whole(_TimeInSaturation(rel_tol), MetricInput(t, _signals(y), held=held, limit=limit))[0]


def time_to_limit(t: np.ndarray, y: np.ndarray, limit: float, rel_tol: float = REL_TOL) -> float:
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
    return _whole(_TimeToLimit(rel_tol), MetricInput(t, _signals(y), limit=limit))[0]


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
    return _whole(_IntegralSquare(), MetricInput(t, _signals(y), inputs=list(held)))[0]


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
