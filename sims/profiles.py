"""Disturbance profiles: signals of time fed to FMU inputs, declared as data.

A profile is a dict (one TOML table) with a ``kind`` and its fields; :func:`make`
validates it and returns a :class:`Profile` whose :meth:`Profile.sample`
evaluates it on the communication grid. The master holds each value over the
following communication step (zero-order hold), as the FMUs do with inputs.

Kinds (times in s, values in the target input's unit):

``constant``  value
``step``      time, before, after            (``after`` from ``time`` on)
``table``     times, values, interpolation = "previous" | "linear"
``sinusoid``  amplitude, frequency_Hz, phase_rad = 0, offset = 0
``random``    seed, std, mean = 0, hold = communication step  (Gaussian, held over ``hold``)
``csv``       file, column, time_column = "time", interpolation = "linear"
``cosine_ramp`` start, stop, before, after, derivative = 0 | 1 | 2
              ``before`` until ``start``, then (1 - cos(pi (t - start)/(stop - start)))/2 of
              the way to ``after``, reached at ``stop`` (seed 002 eq. 24-25); ``derivative``
              gives its first or second time derivative instead (per s, per s^2)
"""
from __future__ import annotations

import csv
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import numpy as np


class ProfileError(ValueError):
    """A profile declaration is invalid; the message names the profile and the field."""


@dataclass(frozen=True)
class Profile:
    """A validated profile: ``kind``, its fields, and the sampling function."""

    kind: str
    spec: dict[str, Any]
    _fn: Callable[[np.ndarray], np.ndarray] = field(repr=False, compare=False)

    def sample(self, t: np.ndarray) -> np.ndarray:
        """Values at the times ``t`` (1-D array, s)."""
        v = np.asarray(self._fn(np.asarray(t, float)), float)
        return np.broadcast_to(v, np.shape(t)).copy()


def _num(spec: dict, key: str, where: str, default: float | None = None) -> float:
    if key not in spec:
        if default is None:
            raise ProfileError(f"{where}: missing field {key!r}")
        return default
    v = spec[key]
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise ProfileError(f"{where}: field {key!r} must be a finite number, got {v!r}")
    return float(v)


def _interp(times: np.ndarray, values: np.ndarray, mode: str, where: str) -> Callable[[np.ndarray], np.ndarray]:
    if times.ndim != 1 or times.shape != values.shape or times.size == 0:
        raise ProfileError(f"{where}: times and values must be 1-D of equal non-zero length")
    if not (np.all(np.isfinite(times)) and np.all(np.isfinite(values))):
        raise ProfileError(f"{where}: times and values must be finite")
    if np.any(np.diff(times) <= 0):
        raise ProfileError(f"{where}: times must be strictly increasing")
    if mode == "linear":
        return lambda t: np.interp(t, times, values)
    if mode == "previous":
        return lambda t: values[np.clip(np.searchsorted(times, t, side="right") - 1, 0, None)]
    raise ProfileError(f"{where}: interpolation must be 'linear' or 'previous', got {mode!r}")


def make(spec: dict[str, Any], where: str = "profile", base_dir: Path | None = None,
         step_size: float | None = None) -> Profile:
    """Validate a profile declaration and build it.

    Parameters
    ----------
    spec : dict
        The declaration (without the ``to`` key of a scenario).
    where : str
        Name used in error messages.
    base_dir : Path, optional
        Folder that relative CSV paths are resolved against.
    step_size : float, optional
        Communication step, the default ``hold`` of ``random``.

    Raises
    ------
    ProfileError
    """
    kind = spec.get("kind")
    where = f"{where} ({kind})"
    if kind == "constant":
        c = _num(spec, "value", where)
        fn: Callable[[np.ndarray], np.ndarray] = lambda t: np.full_like(t, c)
    elif kind == "step":
        t0, a, b = _num(spec, "time", where), _num(spec, "before", where), _num(spec, "after", where)
        fn = lambda t: np.where(t >= t0, b, a)
    elif kind == "table":
        fn = _interp(np.asarray(spec.get("times", []), float), np.asarray(spec.get("values", []), float),
                     spec.get("interpolation", "previous"), where)
    elif kind == "sinusoid":
        amp, f = _num(spec, "amplitude", where), _num(spec, "frequency_Hz", where)
        ph, off = _num(spec, "phase_rad", where, 0.0), _num(spec, "offset", where, 0.0)
        fn = lambda t: off + amp * np.sin(2 * np.pi * f * t + ph)
    elif kind == "random":
        fn = _random(spec, where, step_size)
    elif kind == "csv":
        fn = _csv(spec, where, base_dir)
    elif kind == "cosine_ramp":
        fn = _cosine_ramp(spec, where)
    else:
        raise ProfileError(f"{where}: unknown kind; use constant, step, table, sinusoid, random, csv "
                           "or cosine_ramp")
    return Profile(str(kind), dict(spec), fn)


def _cosine_ramp(spec: dict, where: str) -> Callable[[np.ndarray], np.ndarray]:
    t0, t1 = _num(spec, "start", where), _num(spec, "stop", where)
    a, b = _num(spec, "before", where), _num(spec, "after", where)
    order = spec.get("derivative", 0)
    if t1 <= t0:
        raise ProfileError(f"{where}: 'stop' must be after 'start'")
    if order not in (0, 1, 2) or isinstance(order, bool):
        raise ProfileError(f"{where}: 'derivative' must be 0, 1 or 2, got {order!r}")
    w = np.pi / (t1 - t0)

    def fn(t: np.ndarray) -> np.ndarray:
        inside = (t >= t0) & (t <= t1)
        x = w * (np.clip(t, t0, t1) - t0)
        if order == 0:
            return a + (b - a) * (1 - np.cos(x)) / 2
        if order == 1:
            return np.where(inside, (b - a) * w * np.sin(x) / 2, 0.0)
        return np.where(inside, (b - a) * w**2 * np.cos(x) / 2, 0.0)
    return fn


def _random(spec: dict, where: str, step_size: float | None) -> Callable[[np.ndarray], np.ndarray]:
    seed = spec.get("seed")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ProfileError(f"{where}: 'seed' must be a non-negative integer (runs must be reproducible)")
    std, mean = _num(spec, "std", where), _num(spec, "mean", where, 0.0)
    if std < 0:
        raise ProfileError(f"{where}: 'std' must be >= 0")
    hold = _num(spec, "hold", where, step_size)
    if hold <= 0:
        raise ProfileError(f"{where}: 'hold' must be > 0 s")

    def fn(t: np.ndarray) -> np.ndarray:
        k = np.floor(t / hold + 1e-9).astype(np.int64)
        k = np.clip(k, 0, None)
        draws = np.random.default_rng(seed).normal(mean, std, int(k.max()) + 1 if k.size else 1)
        return draws[k]
    return fn


def _csv(spec: dict, where: str, base_dir: Path | None) -> Callable[[np.ndarray], np.ndarray]:
    if "file" not in spec or "column" not in spec:
        raise ProfileError(f"{where}: needs 'file' and 'column'")
    path = Path(spec["file"])
    if not path.is_absolute() and base_dir is not None:
        path = base_dir / path
    try:
        with open(path, newline="") as fh:
            rows = list(csv.DictReader(fh))
    except OSError as exc:
        raise ProfileError(f"{where}: cannot read {path} ({exc.strerror})") from None
    tcol, col = spec.get("time_column", "time"), spec["column"]
    if not rows or tcol not in rows[0] or col not in rows[0]:
        have = list(rows[0]) if rows else []
        raise ProfileError(f"{where}: {path} needs columns {tcol!r} and {col!r}; it has {have}")
    try:
        times = np.array([float(r[tcol]) for r in rows])
        values = np.array([float(r[col]) for r in rows])
    except ValueError as exc:
        raise ProfileError(f"{where}: {path} has a non-numeric entry ({exc})") from None
    return _interp(times, values, spec.get("interpolation", "linear"), where)
