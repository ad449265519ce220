"""Disturbance profiles: signals of time fed to FMU inputs, declared as data.

A profile is a dict (one TOML table) with a ``kind`` and its fields; :func:`make`
validates it and returns a :class:`Profile` whose :meth:`Profile.sample`
evaluates it on the communication grid. The master holds each value over the
following communication step (zero-order hold), as the FMUs do with inputs.

Kinds (times in s, values in the target input's unit):

- ``constant``: value
- ``step``: time, before, after (``after`` from ``time`` on; the generator FMU's
  parameter is ``step_time``)
- ``table``: times, values, interpolation = "previous" | "linear"
- ``sinusoid``: amplitude, frequency_Hz, phase_rad = 0, offset = 0
- ``random``: seed, std, mean = 0, hold = communication step (Gaussian, held over ``hold``)
- ``csv``: file, column, time_column = "time", interpolation = "linear"
- ``cosine_ramp``: start, stop, before, after, derivative = 0 | 1 | 2;
  ``before`` until ``start``, then (1 - cos(pi (t - start)/(stop - start)))/2 of
  the way to ``after``, reached at ``stop`` (seed 002 eq. 24-25); ``derivative``
  gives its first or second time derivative instead (per s, per s^2)
- ``igrf``: component (1 | 2 | 3), epoch (ISO date "2020-01-01" or a TOML date),
  max_degree = 13, orbit_period, orbit_time_0, orbit_altitude,
  orbit_inclination, orbit_raan, orbit_arg_latitude_0, earth_rotation_angle_0
  (= the magnetorquer cubesat's parameters, defaulting to its start values);
  IGRF field along orbit axis ``component`` at orbit time orbit_time_0 + t, T
  (:func:`satfmu.fmus.environment.geomagnetic.igrf_orbit_field`), for the cubesat's ``b_ext[i]``
  inputs with ``field_model = 2``; give the plant the same orbit_period.
"""
from __future__ import annotations

import csv
import datetime as dt
import math
import os
import re
import stat
import warnings
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING, Any, Callable

import numpy as np

from satfmu.fmus import signal_functions
from satfmu.fmus.declared import check_keys
from satfmu.fmus.errors import ModelDefinitionError, ProfileError
from satfmu.fmus.table import Table
from satfmu.fmus.units import DIMENSIONLESS

if TYPE_CHECKING:  # the generators are sympy models, built only when one is asked for
    from satfmu.fmus.model import Model

Generator = Callable[[np.ndarray, str], tuple[Any, dict[str, float]]]
"""(communication grid (s), unit of the target input) -> the signal-generator model (a
:class:`satfmu.fmus.model.Model`) and its parameter values."""


@dataclass(frozen=True)
class Profile:
    """A validated profile: ``kind``, its fields, the sampling function and its generator.

    Built by :func:`make`, not directly.

    Attributes
    ----------
    kind : str
        The profile kind (``"constant"``, ``"step"``, ``"table"``, ...; see the module).
    spec : dict of str to object
        The declaration it was built from.
    _fn : callable
        ``_fn(t)``: the values at the times ``t`` (s), what :meth:`sample` returns.
    _generator : callable
        ``_generator(times, unit)``: the signal-generator model and its parameter values,
        what :meth:`generator` returns.
    """

    kind: str
    spec: dict[str, Any]
    _fn: Callable[[np.ndarray], np.ndarray] = field(repr=False, compare=False)
    _generator: Generator = field(repr=False, compare=False)

    def sample(self, t: np.ndarray) -> np.ndarray:
        """Values at the times ``t`` (1-D array, s).

        Parameters
        ----------
        t : numpy.ndarray, shape (n,)
            Times, s.

        Returns
        -------
        numpy.ndarray, shape (n,)
            The profile's values, in the target input's unit.
        """
        v = np.asarray(self._fn(np.asarray(t, float)), float)
        return np.broadcast_to(v, np.shape(t)).copy()

    def generator(self, times: np.ndarray, unit: str = DIMENSIONLESS) -> tuple[Model, dict[str, float]]:
        """The signal-generator model (:mod:`satfmu.fmus.signals`) and its parameter values that give
        this profile's values at ``times``, the communication grid (s), declaring ``unit`` (the
        target input's: FMI 2.0 gives each variable one fixed unit) for its output.

        The analytic kinds are the generic generators and do not depend on ``times``; the
        sampled ones are tables: ``table`` and ``csv`` their data, ``random`` its held draws over
        the hold instants up to the last time, ``igrf`` the field on ``times`` (linear).

        Parameters
        ----------
        times : numpy.ndarray, shape (n,)
            The communication grid, s.
        unit : str, optional
            Unit of the generator's output (one of :data:`satfmu.fmus.units.UNITS`). Default
            dimensionless (``"1"``).

        Returns
        -------
        model : Model
            The signal-generator model (:mod:`satfmu.fmus.signals`).
        values : dict of str to float
            Its parameter values, by name.
        """
        return self._generator(np.asarray(times, float), unit)


def _num(spec: dict, key: str, where: str, default: float | None = None) -> float:
    if key not in spec:
        if default is None:
            raise ProfileError(f"{where}: missing field {key!r}")
        return default
    v = spec[key]
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise ProfileError(f"{where}: field {key!r} must be a finite number, got {v!r}")
    return float(v)


def _table(times: Any, values: Any, mode: Any, where: str) -> tuple[Callable[[np.ndarray], np.ndarray], Generator]:
    try:
        tb = Table(times, values, mode)
    except (ModelDefinitionError, TypeError, ValueError) as exc:
        raise ProfileError(f"{where}: {exc}") from None
    return tb.evaluate, lambda grid, unit: (_signals().table(tb, unit), {})


def _generic(kind: str, params: dict[str, float]) -> tuple[Callable[[np.ndarray], np.ndarray], Generator]:
    """The analytic kind's values (:mod:`satfmu.fmus.signal_functions`, printed from its generator's
    expression: no sympy) and its generic generator."""
    function: Callable[..., np.ndarray] = signal_functions.FUNCTIONS[kind]
    declared = signal_functions.PARAMETERS[kind]
    unknown = set(params) - {name for name, _ in declared}
    if unknown:
        raise KeyError(f"signal {kind!r} has no parameter(s) {sorted(unknown)}")
    args = tuple(np.float64(params.get(name, start)) for name, start in declared)  # numpy division: inf, not an error

    def values(t: np.ndarray) -> np.ndarray:
        times = np.asarray(t, float)
        y: np.ndarray = np.asarray(function(times, *args), float)
        return np.broadcast_to(y, times.shape).copy()
    return values, (lambda grid, unit: (_signals().GENERIC[kind](unit), dict(params)))


def _signals() -> ModuleType:
    """:mod:`satfmu.fmus.signals`, imported on first use (it builds sympy models: a run that only
    samples its profiles never needs it)."""
    from satfmu.fmus import signals

    return signals


FIELDS: dict[str, tuple[str, ...]] = {
    "constant": ("value",), "step": ("time", "before", "after"), "table": ("times", "values", "interpolation"),
    "sinusoid": ("amplitude", "frequency_Hz", "phase_rad", "offset"), "random": ("seed", "std", "mean", "hold"),
    "csv": ("file", "column", "time_column", "interpolation"),
    "cosine_ramp": ("start", "stop", "before", "after", "derivative"),
    "igrf": ("component", "epoch", "max_degree", "orbit_period", "orbit_time_0", "orbit_altitude",
             "orbit_inclination", "orbit_raan", "orbit_arg_latitude_0", "earth_rotation_angle_0")}
"""Profile kind -> the fields its declaration may have besides ``kind`` (another one is an error
naming it, with the closest allowed field: a misspelt ``aftr`` is not read as a missing ``after``)."""


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
    if kind in FIELDS:  # an unknown kind is refused below, with the kinds
        check_keys(spec, ("kind", *FIELDS[kind]), where, ProfileError)
    if kind == "constant":
        fns = _generic("constant", {"value": _num(spec, "value", where)})
    elif kind == "step":
        # the profile's field "time" is the generator's parameter "step_time" (never an FMU variable "time")
        fns = _generic("step", {"step_time": _num(spec, "time", where),
                                **{k: _num(spec, k, where) for k in ("before", "after")}})
    elif kind == "table":
        fns = _table(spec.get("times", []), spec.get("values", []), spec.get("interpolation", "previous"), where)
    elif kind == "sinusoid":
        fns = _generic("sinusoid", {"amplitude": _num(spec, "amplitude", where),
                                    "frequency_Hz": _num(spec, "frequency_Hz", where),
                                    "phase_rad": _num(spec, "phase_rad", where, 0.0),
                                    "offset": _num(spec, "offset", where, 0.0)})
    elif kind == "random":
        fns = _random(spec, where, step_size)
    elif kind == "csv":
        fns = _csv(spec, where, base_dir)
    elif kind == "cosine_ramp":
        fns = _cosine_ramp(spec, where)
    elif kind == "igrf":
        fns = _igrf(spec, where)
    else:
        raise ProfileError(f"{where}: unknown kind; use constant, step, table, sinusoid, random, csv, "
                           "cosine_ramp or igrf")
    return Profile(str(kind), dict(spec), *fns)


def _cosine_ramp(spec: dict, where: str) -> tuple[Callable[[np.ndarray], np.ndarray], Generator]:
    t0, t1 = _num(spec, "start", where), _num(spec, "stop", where)
    a, b = _num(spec, "before", where), _num(spec, "after", where)
    order = spec.get("derivative", 0)
    if t1 <= t0:
        raise ProfileError(f"{where}: 'stop' must be after 'start'")
    if order not in (0, 1, 2) or isinstance(order, bool):
        raise ProfileError(f"{where}: 'derivative' must be 0, 1 or 2, got {order!r}")
    return _generic("cosine_ramp", {"start": t0, "stop": t1, "before": a, "after": b, "derivative": order})


_IGRF_ORBIT = ("orbit_period", "orbit_time_0", "orbit_altitude", "orbit_inclination", "orbit_raan",
               "orbit_arg_latitude_0", "earth_rotation_angle_0")


def _igrf(spec: dict, where: str) -> tuple[Callable[[np.ndarray], np.ndarray], Generator]:
    # satfmu.fmus.environment.geomagnetic imports ppigrf and pandas: only when this kind is used
    from satfmu.fmus.environment import geomagnetic

    unknown = sorted(set(spec) - {"kind", "component", "epoch", "max_degree", *_IGRF_ORBIT})
    if unknown:
        raise ProfileError(f"{where}: unknown field(s) {unknown}; allowed: component, epoch, max_degree, "
                           + ", ".join(_IGRF_ORBIT))
    comp = spec.get("component")
    if isinstance(comp, bool) or comp not in (1, 2, 3) or not isinstance(comp, int):
        raise ProfileError(f"{where}: 'component' must be 1, 2 or 3 (orbit axis), got {comp!r}")
    epoch = spec.get("epoch")
    if isinstance(epoch, str):
        try:
            epoch = dt.datetime.fromisoformat(epoch)
        except ValueError:
            raise ProfileError(f"{where}: 'epoch' must be an ISO date like \"2020-01-01\", got {epoch!r}") from None
    elif not isinstance(epoch, dt.date):
        raise ProfileError(f"{where}: 'epoch' must be an ISO date like \"2020-01-01\", got {epoch!r}")
    first, last = geomagnetic.igrf_validity()
    if not first <= geomagnetic.epoch_datetime(epoch) <= last:
        raise ProfileError(f"{where}: 'epoch' {epoch} is outside the IGRF coefficients "
                           f"({first:%Y-%m-%d} to {last:%Y-%m-%d})")
    degree = spec.get("max_degree", 13)
    if isinstance(degree, bool) or not isinstance(degree, int) or not 1 <= degree <= 13:
        raise ProfileError(f"{where}: 'max_degree' must be an integer in 1..13, got {degree!r}")
    defaults = geomagnetic.model_defaults()
    orbit = {k: _num(spec, k, where, defaults[k]) for k in _IGRF_ORBIT}
    if orbit["orbit_period"] <= 0:
        raise ProfileError(f"{where}: 'orbit_period' must be > 0 s")
    if orbit["orbit_altitude"] < 0:
        raise ProfileError(f"{where}: 'orbit_altitude' must be >= 0 m")
    tau0 = orbit.pop("orbit_time_0")
    key = (geomagnetic.epoch_datetime(epoch), degree, tau0, tuple(sorted(orbit.items())))

    def fn(t: np.ndarray) -> np.ndarray:
        tt = np.atleast_1d(t)
        b = _igrf_field(key, tt.astype(float).ravel().tobytes())
        return b[:, comp - 1].reshape(tt.shape) if np.ndim(t) else b[0, comp - 1]
    return fn, lambda grid, unit: _table(grid, fn(grid), "linear", where)[1](grid, unit)


@lru_cache(maxsize=4)
def _igrf_field(key: tuple, t_bytes: bytes) -> np.ndarray:
    """IGRF along the orbit at the times ``t_bytes`` (float64), cached: the three components of
    one field usually sample the same grid."""
    from satfmu.fmus.environment import geomagnetic

    epoch, degree, tau0, orbit = key
    b = geomagnetic.igrf_orbit_field(tau0 + np.frombuffer(t_bytes), epoch, dict(orbit), max_degree=degree)
    b.setflags(write=False)
    return b


def _random(spec: dict, where: str, step_size: float | None
            ) -> tuple[Callable[[np.ndarray], np.ndarray], Generator]:
    seed = spec.get("seed")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ProfileError(f"{where}: 'seed' must be a non-negative integer (runs must be reproducible)")
    std, mean = _num(spec, "std", where), _num(spec, "mean", where, 0.0)
    if std < 0:
        raise ProfileError(f"{where}: 'std' must be >= 0")
    hold = _num(spec, "hold", where, step_size)
    if hold <= 0:
        raise ProfileError(f"{where}: 'hold' must be > 0 s")

    def draws(t: np.ndarray) -> tuple[Callable[[np.ndarray], np.ndarray], Generator]:
        """The held draws over the hold instants up to the last of ``t`` (a prefix of one stream)."""
        n = int(np.floor(max(float(np.max(t, initial=0.0)), 0.0) / hold + 1e-9)) + 1
        return _table(hold * np.arange(n), np.random.default_rng(seed).normal(mean, std, n), "previous", where)

    return (lambda t: draws(t)[0](t)), (lambda grid, unit: draws(grid)[1](grid, unit))


MAX_CSV_BYTES = 512 << 20
"""The largest profile CSV file read (B): a million rows of ten columns is about 100 MB."""
_MAX_HEADER = 1 << 20
_COLUMN_NAME = re.compile(r"[A-Za-z_][\w .()\[\]/^*+-]{0,79}")


def _header_names(names: list[str]) -> str:
    """The columns of a header, for an error message: quoted only when every one looks like a
    column name (a file that is no CSV table is not echoed: its first line may be anything)."""
    if names and all(_COLUMN_NAME.fullmatch(n) for n in names) and len(names) <= 50:
        return f"it has {names}"
    return f"its first line ({len(names)} fields) is no header of column names"


def _csv_columns(path: Path, tcol: str, col: str, where: str) -> tuple[np.ndarray, np.ndarray]:
    """The columns ``tcol`` and ``col`` of the CSV file ``path`` (UTF-8, a byte order mark
    allowed, a header line of column names), read by numpy's C parser: memory holds the two
    columns, not the file."""
    try:
        info = os.stat(path)
    except OSError as exc:
        raise ProfileError(f"{where}: cannot read {path} ({exc.strerror})") from None
    if not stat.S_ISREG(info.st_mode):
        raise ProfileError(f"{where}: {path} is not a regular file (a folder, FIFO or device)")
    if info.st_size > MAX_CSV_BYTES:
        raise ProfileError(f"{where}: {path} is {info.st_size} bytes, more than the {MAX_CSV_BYTES} a profile "
                           "CSV may have")
    try:
        with open(path, newline="", encoding="utf-8-sig") as fh:
            first = fh.readline(_MAX_HEADER)
            if len(first) >= _MAX_HEADER:
                raise ProfileError(f"{where}: {path}: its first line is longer than {_MAX_HEADER} characters")
            names = [n.strip() for n in next(csv.reader([first]), [])]
            if tcol not in names or col not in names:
                raise ProfileError(f"{where}: {path} needs columns {tcol!r} and {col!r}; {_header_names(names)}")
            try:
                with warnings.catch_warnings():  # no rows: said below, not as numpy's warning
                    warnings.simplefilter("ignore", UserWarning)
                    data = np.loadtxt(fh, delimiter=",", usecols=(names.index(tcol), names.index(col)), ndmin=2,
                                      dtype=float, quotechar='"')
            except (ValueError, IndexError) as exc:
                row = re.search(r"row (\d+)", str(exc))
                line = f"line {int(row[1]) + 2}" if row else "a line"
                raise ProfileError(f"{where}: {path}: {line} has a missing or non-numeric entry in column "
                                   f"{tcol!r} or {col!r}") from None
    except UnicodeDecodeError as exc:
        raise ProfileError(f"{where}: {path} is not UTF-8 text ({exc.reason})") from None
    except OSError as exc:
        raise ProfileError(f"{where}: cannot read {path} ({exc.strerror})") from None
    if len(data) == 0:
        raise ProfileError(f"{where}: {path} has no rows after its header")
    return data[:, 0], data[:, 1]


def _csv(spec: dict, where: str, base_dir: Path | None) -> tuple[Callable[[np.ndarray], np.ndarray], Generator]:
    if "file" not in spec or "column" not in spec:
        raise ProfileError(f"{where}: needs 'file' and 'column'")
    path = Path(spec["file"])
    if not path.is_absolute() and base_dir is not None:
        path = base_dir / path
    times, values = _csv_columns(path, spec.get("time_column", "time"), spec["column"], where)
    return _table(times, values, spec.get("interpolation", "linear"), where)
