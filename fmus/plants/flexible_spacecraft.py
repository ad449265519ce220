"""A flexible spacecraft description: rigid hub, appendages with their modes, reaction wheels.

The flexible plant (:func:`satfmu.fmus.plants.demeter.build`, eq. (4) of seed 004) takes one, so
that the robust design of seed 004 can be made for *your* spacecraft. A TOML file::

    name = "my_sat"                      # letters, digits, '_' (names the plant model)
    description = "50 kg m^2 bus, one solar array"
    inertia = [[50.0, 0.5, 0.0],         # kg m^2, hub inertia tensor (body axes), symmetric
               [0.5, 45.0, 0.2],         # positive definite, or 3 principal moments
               [0.0, 0.2, 40.0]]

    [inertia_uncertainty]                # optional (the robust design's inertia box)
    moment_spread = 0.1                  # relative: J_ii in [(1 - 0.1) J_ii, (1 + 0.1) J_ii]
    product_spread = 1.0                 # kg m^2: J_ij in [J_ij - 1, J_ij + 1]

    [wheels]                             # one reaction wheel per body axis
    torque_limit = 0.01                  # N m
    momentum_limit = 0.5                 # N m s
    natural_frequency = 12.566           # rad/s, wheel dynamics H(s) (optional)
    damping = 0.7                        # damping ratio of H(s) (optional)

    [[appendages]]
    name = "solar_array"
    [[appendages.modes]]
    kind = "bending"
    coupling = [0.30, 0.05, 0.14]        # column of L (axes 1-3)
    frequency = [5.03, 7.54]             # rad/s, [low, high]; nominal = midpoint
    damping = [5e-4, 5e-3]               # damping ratio, [low, high]
    [[appendages.modes]]
    kind = "torsion"
    coupling = [-0.06, 0.12, 0.04]
    frequency = { low = 9.42, high = 12.57, nominal = 11.0 }
    damping = 2e-3                       # a single number: known exactly

An interval is ``[low, high]`` (nominal the midpoint), a table ``{ low, high, nominal }``, or
one number. An appendage may give ``frequency`` and ``damping`` itself instead of per mode:
its modes then share one natural frequency and one damping ratio (one FMU parameter each),
as in seed 004 where bending and torsion of an appendage share ``omega_k`` and ``zeta_k``
(``Z = diag(zeta_k I2)``, ``W = diag(omega_k I2)``).

The coupling ``l`` of a mode is its column of the matrix L of eq. (4), where the hub-mode
block of the mass matrix is ``J^(1/2) L`` and the modal coordinate ``eta`` is mass-normalized
(sqrt(kg m^2)): L is dimensionless in that normalization (the FMU's unit "1").
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

import numpy as np
from numpy.typing import ArrayLike

from satfmu.fmus.declared import check_keys, read_toml
from satfmu.fmus.errors import SpacecraftError
from satfmu.fmus.plants.spacecraft import Spacecraft

NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]{0,63}")
"""A spacecraft, appendage or mode-kind name: it goes into model names and descriptions."""
COUPLING_MAX = 10.0
"""Largest ``|L_ij|`` (the range of the FMU's coupling parameters)."""
DAMPING_MAX = 10.0
"""Largest damping ratio of a mode (the range of the FMU's ``zeta`` parameters)."""
FREQUENCY_MIN = 1e-6
"""Smallest natural frequency of a mode or of the wheel dynamics, rad/s (the FMU's range)."""
WHEEL_WN = 2 * np.pi * 2.0
"""Default natural frequency of the wheel dynamics H(s), rad/s (seed 004's **substitute**)."""
WHEEL_ZETA = 0.7
"""Default damping ratio of the wheel dynamics H(s) (seed 004's **substitute**)."""
_KEYS = ("name", "description", "inertia", "inertia_uncertainty", "wheels", "appendages")
_UNCERTAINTY_KEYS = ("moment_spread", "product_spread")
_WHEEL_KEYS = ("torque_limit", "momentum_limit", "natural_frequency", "damping")
_APPENDAGE_KEYS = ("name", "frequency", "damping", "modes")
_MODE_KEYS = ("kind", "coupling", "frequency", "damping")
_INTERVAL_KEYS = ("low", "high", "nominal")


def _number(value: Any, what: str) -> float:
    """``value`` as a float; refused unless a finite real number (not a bool)."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)) \
            or not math.isfinite(value):
        raise SpacecraftError(f"{what}: must be a finite number, got {value!r}")
    return float(value)


def _name(value: Any, what: str) -> str:
    if not isinstance(value, str) or not NAME.fullmatch(value):
        raise SpacecraftError(f"{what}: {value!r} is not a name (a letter, then letters, digits or '_'; "
                              f"at most 64 characters)")
    return value


@dataclass(frozen=True, init=False)
class Interval:
    """A closed interval of an uncertain parameter and its nominal value (in the parameter's unit).

    Parameters
    ----------
    low, high : float
        The bounds, ``low <= high``, in the unit of the parameter (rad/s for a frequency, 1 for
        a damping ratio).
    nominal : float, optional
        The nominal value, ``low <= nominal <= high``; default the midpoint.

    Raises
    ------
    SpacecraftError
        If a value is not a finite number or the order is violated.
    """

    low: float
    high: float
    nominal: float

    def __init__(self, low: float, high: float, nominal: float | None = None) -> None:
        lo, hi = _number(low, "low"), _number(high, "high")
        mid = (lo + hi) / 2 if nominal is None else _number(nominal, "nominal")
        if not lo <= mid <= hi:
            raise SpacecraftError(f"need low <= nominal <= high, got low {lo:g}, nominal {mid:g}, high {hi:g}")
        object.__setattr__(self, "low", lo)
        object.__setattr__(self, "high", hi)
        object.__setattr__(self, "nominal", mid)

    @classmethod
    def from_value(cls, raw: Any) -> "Interval":
        """An interval from plain data: one number, ``[low, high]`` or ``{low, high, nominal}``.

        Parameters
        ----------
        raw : float, list of 2 floats or mapping
            The declared interval (in the parameter's unit); one number is a known value.

        Returns
        -------
        Interval
        """
        if isinstance(raw, Mapping):
            check_keys(raw, _INTERVAL_KEYS, "interval", SpacecraftError)
            if "low" not in raw or "high" not in raw:
                raise SpacecraftError(f"an interval table needs 'low' and 'high', got {dict(raw)!r}")
            return cls(raw["low"], raw["high"], raw.get("nominal"))
        if isinstance(raw, (list, tuple)):
            if len(raw) != 2:
                raise SpacecraftError(f"an interval is [low, high], got {list(raw)!r}")
            return cls(raw[0], raw[1])
        value = _number(raw, "value")
        return cls(value, value)

    def to_value(self) -> list[float] | dict[str, float]:
        """Plain data :meth:`from_value` reads back equal: ``[low, high]`` when the nominal
        value is the midpoint, else ``{low, high, nominal}``."""
        if self.nominal == (self.low + self.high) / 2:
            return [self.low, self.high]
        return {"low": self.low, "high": self.high, "nominal": self.nominal}


def _checked_interval(value: Interval | None, what: str, low: float, high: float, unit: str) -> Interval | None:
    """``value`` (None kept) if inside ``[low, high]`` (in ``unit``)."""
    if value is not None and not (isinstance(value, Interval) and low <= value.low and value.high <= high):
        raise SpacecraftError(f"{what}: must be an Interval within [{low:g}, {high:g}] {unit}, got {value!r}")
    return value


@dataclass(frozen=True, init=False)
class Mode:
    """One flexible mode of an appendage (a column of L, a flexible coordinate eta_k).

    Parameters
    ----------
    kind : str
        What the mode is (``"bending"``, ``"torsion"``, ...): a name (:data:`NAME`).
    coupling : array_like, shape (3,)
        Its column of the coupling matrix L of eq. (4), one entry per body axis (dimensionless,
        eta mass-normalized in sqrt(kg m^2)); each ``|l_i| <= COUPLING_MAX``.
    frequency : Interval, optional
        Natural frequency, rad/s (``>= FREQUENCY_MIN``); None when the appendage gives it.
    damping : Interval, optional
        Damping ratio (in ``[0, DAMPING_MAX]``); None when the appendage gives it.

    Raises
    ------
    SpacecraftError
        A bad name, coupling or interval.
    """

    kind: str
    coupling: tuple[float, float, float]
    frequency: Interval | None = None
    damping: Interval | None = None

    def __init__(self, kind: str, coupling: ArrayLike, frequency: Interval | None = None,
                 damping: Interval | None = None) -> None:
        object.__setattr__(self, "kind", _name(kind, "kind"))
        if not isinstance(coupling, (list, tuple, np.ndarray)) or len(coupling) != 3:
            raise SpacecraftError(f"coupling: must be 3 numbers (axes 1-3), got {coupling!r}")
        values = tuple(_number(c, "coupling") for c in coupling)
        if max(abs(c) for c in values) > COUPLING_MAX:
            raise SpacecraftError(f"coupling: entries must be within +-{COUPLING_MAX:g}, got {list(values)}")
        object.__setattr__(self, "coupling", values)
        object.__setattr__(self, "frequency", _checked_interval(frequency, "frequency", FREQUENCY_MIN, math.inf,
                                                                "rad/s"))
        object.__setattr__(self, "damping", _checked_interval(damping, "damping", 0.0, DAMPING_MAX, "(ratio)"))


@dataclass(frozen=True, init=False)
class Appendage:
    """A flexible appendage (solar array, boom, antenna): its modes.

    Either the appendage gives ``frequency`` and ``damping``, shared by all its modes (one
    parameter each, as seed 004's appendages), or every mode gives its own.

    Parameters
    ----------
    name : str
        Identifier (:data:`NAME`).
    modes : sequence of Mode
        Its modes, at least one, in the order of the flexible coordinates.
    frequency : Interval, optional
        Natural frequency shared by the modes, rad/s (``>= FREQUENCY_MIN``).
    damping : Interval, optional
        Damping ratio shared by the modes (in ``[0, DAMPING_MAX]``).

    Raises
    ------
    SpacecraftError
        A bad name, no mode, or frequency and damping given neither once for the appendage nor
        for every mode.
    """

    name: str
    modes: tuple[Mode, ...]
    frequency: Interval | None = None
    damping: Interval | None = None

    def __init__(self, name: str, modes: tuple[Mode, ...] | list[Mode], frequency: Interval | None = None,
                 damping: Interval | None = None) -> None:
        object.__setattr__(self, "name", _name(name, "name"))
        if not isinstance(modes, (list, tuple)) or not modes or not all(isinstance(m, Mode) for m in modes):
            raise SpacecraftError(f"{name}: modes: must be a non-empty list of modes, got {modes!r}")
        object.__setattr__(self, "modes", tuple(modes))
        object.__setattr__(self, "frequency", _checked_interval(frequency, f"{name}: frequency", FREQUENCY_MIN,
                                                                math.inf, "rad/s"))
        object.__setattr__(self, "damping", _checked_interval(damping, f"{name}: damping", 0.0, DAMPING_MAX,
                                                              "(ratio)"))
        shared = frequency is not None or damping is not None
        for k, m in enumerate(self.modes):
            own = (m.frequency is not None, m.damping is not None)
            if own != ((False, False) if shared else (True, True)):
                raise SpacecraftError(
                    f"{name}: mode {k + 1} ({m.kind}): give frequency and damping either for the appendage "
                    "(shared by its modes) or for every mode, both each time")
        if shared and (frequency is None or damping is None):
            raise SpacecraftError(f"{name}: an appendage that shares its modes' dynamics gives both frequency "
                                  "and damping")


@dataclass(frozen=True)
class Wheels:
    """Three reaction wheels, one per body axis: limits and dynamics.

    Parameters
    ----------
    torque_limit : float
        Torque limit satT of each wheel, N m (> 0).
    momentum_limit : float
        Momentum limit satW of each wheel, N m s (> 0).
    natural_frequency : float, optional
        Natural frequency of the wheel dynamics H(s) = wn^2 / (s^2 + 2 zw wn s + wn^2), rad/s
        (``>= FREQUENCY_MIN``); default :data:`WHEEL_WN`.
    damping : float, optional
        Damping ratio zw of H(s) (>= 0); default :data:`WHEEL_ZETA`.

    Raises
    ------
    SpacecraftError
        A value not finite or out of range.
    """

    torque_limit: float
    momentum_limit: float
    natural_frequency: float = WHEEL_WN
    damping: float = WHEEL_ZETA

    def __post_init__(self) -> None:
        for key, unit in (("torque_limit", "N.m"), ("momentum_limit", "N.m.s")):
            value = _number(getattr(self, key), key)
            if value <= 0:
                raise SpacecraftError(f"{key}: must be > 0 {unit}, got {value!r}")
            object.__setattr__(self, key, value)
        wn = _number(self.natural_frequency, "natural_frequency")
        if wn < FREQUENCY_MIN:
            raise SpacecraftError(f"natural_frequency: must be >= {FREQUENCY_MIN:g} rad/s, got {wn!r}")
        object.__setattr__(self, "natural_frequency", wn)
        damping = _number(self.damping, "damping")
        if damping < 0:
            raise SpacecraftError(f"damping: must be >= 0, got {damping!r}")
        object.__setattr__(self, "damping", damping)


@dataclass(frozen=True)
class InertiaUncertainty:
    """The box of hub inertias a robust design covers (seed 004: +-30 % moments, +-3 kg m^2 products).

    Parameters
    ----------
    moment_spread : float
        Relative half-width of each principal-axis moment: ``J_ii`` in
        ``[(1 - s) J_ii, (1 + s) J_ii]``; in ``[0, 1)``.
    product_spread : float
        Half-width of each product of inertia, kg m^2: ``J_ij`` in ``[J_ij - p, J_ij + p]``; >= 0.

    Raises
    ------
    SpacecraftError
        A value not finite or out of range.
    """

    moment_spread: float
    product_spread: float

    def __post_init__(self) -> None:
        s = _number(self.moment_spread, "moment_spread")
        p = _number(self.product_spread, "product_spread")
        if not 0 <= s < 1:
            raise SpacecraftError(f"moment_spread: must be in [0, 1) (relative), got {s!r}")
        if p < 0:
            raise SpacecraftError(f"product_spread: must be >= 0 kg m^2, got {p!r}")
        object.__setattr__(self, "moment_spread", s)
        object.__setattr__(self, "product_spread", p)


@dataclass(frozen=True)
class ModeGroup:
    """Modes sharing one natural frequency and one damping ratio (one FMU parameter each).

    Attributes
    ----------
    appendage : int
        Index of the appendage, 0-based.
    kind : str or None
        The mode's kind for a single mode with its own dynamics, None for an appendage's shared ones.
    columns : tuple of int
        The modes' columns of L (flexible coordinates), 0-based.
    frequency : Interval
        Natural frequency, rad/s.
    damping : Interval
        Damping ratio.
    """

    appendage: int
    kind: str | None
    columns: tuple[int, ...]
    frequency: Interval
    damping: Interval


@dataclass(frozen=True, init=False)
class FlexibleSpacecraft:
    """A spacecraft with a rigid hub, flexible appendages and three reaction wheels (seed 004's plant).

    Parameters
    ----------
    name : str
        Identifier (:data:`NAME`), used for the plant model's name and in messages.
    inertia : array_like
        Hub inertia tensor about the centre of mass in body axes, kg m^2 (3 x 3, symmetric
        positive definite, triangle inequality), or 3 principal moments; checked as
        :class:`satfmu.fmus.plants.spacecraft.Spacecraft` checks it.
    appendages : sequence of Appendage
        At least one (a rigid spacecraft is a :class:`~satfmu.fmus.plants.spacecraft.Spacecraft`),
        with distinct names; their modes, in order, are the flexible coordinates.
    wheels : Wheels
        The reaction wheels' limits and dynamics.
    inertia_uncertainty : InertiaUncertainty, optional
        The inertia box of a robust design; None: the inertia is known.
    description : str, optional
        Free text (not compared, never written into a model).

    Raises
    ------
    SpacecraftError
        A bad name, tensor, appendage list or wheel set (the message names the key).
    """

    name: str
    inertia: tuple[tuple[float, float, float], ...]
    appendages: tuple[Appendage, ...]
    wheels: Wheels
    inertia_uncertainty: InertiaUncertainty | None = None
    description: str = field(default="", compare=False)

    def __init__(self, name: str, inertia: ArrayLike, appendages: tuple[Appendage, ...] | list[Appendage],
                 wheels: Wheels, inertia_uncertainty: InertiaUncertainty | None = None,
                 description: str = "") -> None:
        object.__setattr__(self, "name", _name(name, "name"))
        object.__setattr__(self, "inertia", Spacecraft(name, inertia).inertia)
        if not isinstance(appendages, (list, tuple)) or not appendages \
                or not all(isinstance(a, Appendage) for a in appendages):
            raise SpacecraftError(f"{name}: appendages: must be a non-empty list of appendages (a rigid "
                                  f"spacecraft is a Spacecraft), got {appendages!r}")
        names = [a.name for a in appendages]
        twice = sorted({n for n in names if names.count(n) > 1})
        if twice:
            raise SpacecraftError(f"{name}: appendages: names must be distinct, {twice} appear twice")
        object.__setattr__(self, "appendages", tuple(appendages))
        if not isinstance(wheels, Wheels):
            raise SpacecraftError(f"{name}: wheels: must be Wheels, got {wheels!r}")
        object.__setattr__(self, "wheels", wheels)
        if inertia_uncertainty is not None and not isinstance(inertia_uncertainty, InertiaUncertainty):
            raise SpacecraftError(f"{name}: inertia_uncertainty: must be an InertiaUncertainty, "
                                  f"got {inertia_uncertainty!r}")
        object.__setattr__(self, "inertia_uncertainty", inertia_uncertainty)
        if not isinstance(description, str):
            raise SpacecraftError(f"{name}: description: must be a string, got {description!r}")
        object.__setattr__(self, "description", description)

    @property
    def tensor(self) -> np.ndarray:
        """The hub inertia tensor as a 3 x 3 array, kg m^2."""
        return np.array(self.inertia)

    @property
    def modes(self) -> list[tuple[int, Mode]]:
        """Every mode with its appendage's index (0-based), in the order of the flexible coordinates."""
        return [(a, m) for a, app in enumerate(self.appendages) for m in app.modes]

    @property
    def coupling(self) -> np.ndarray:
        """The coupling matrix L of eq. (4), shape (3, number of modes), dimensionless."""
        return np.array([m.coupling for _, m in self.modes], dtype=float).T

    @property
    def groups(self) -> list[ModeGroup]:
        """The mode groups (shared dynamics: one per appendage, else one per mode), in order."""
        out: list[ModeGroup] = []
        column = 0
        for a, app in enumerate(self.appendages):
            if app.frequency is not None and app.damping is not None:
                out.append(ModeGroup(a, None, tuple(range(column, column + len(app.modes))), app.frequency,
                                     app.damping))
            else:
                out += [ModeGroup(a, m.kind, (column + k,), m.frequency, m.damping)  # type: ignore[arg-type]
                        for k, m in enumerate(app.modes)]
            column += len(app.modes)
        return out

    @property
    def mode_group(self) -> np.ndarray:
        """Index of the group (:attr:`groups`) of each mode, shape (number of modes,)."""
        out = np.zeros(len(self.modes), dtype=int)
        for g, group in enumerate(self.groups):
            out[list(group.columns)] = g
        return out

    @property
    def nominal_frequency(self) -> np.ndarray:
        """Nominal natural frequency of each group, rad/s."""
        return np.array([g.frequency.nominal for g in self.groups])

    @property
    def nominal_damping(self) -> np.ndarray:
        """Nominal damping ratio of each group."""
        return np.array([g.damping.nominal for g in self.groups])

    def to_dict(self) -> dict[str, Any]:
        """The description as plain data (the TOML file's keys); :meth:`from_dict` reads it back equal."""
        data: dict[str, Any] = {"name": self.name}
        if self.description:
            data["description"] = self.description
        data["inertia"] = [list(r) for r in self.inertia]
        if self.inertia_uncertainty is not None:
            data["inertia_uncertainty"] = {"moment_spread": self.inertia_uncertainty.moment_spread,
                                           "product_spread": self.inertia_uncertainty.product_spread}
        w = self.wheels
        data["wheels"] = {"torque_limit": w.torque_limit, "momentum_limit": w.momentum_limit,
                          "natural_frequency": w.natural_frequency, "damping": w.damping}
        data["appendages"] = [_appendage_dict(a) for a in self.appendages]
        return data

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], where: str = "spacecraft") -> "FlexibleSpacecraft":
        """A flexible spacecraft from plain data with the TOML file's keys (the module's example).

        Parameters
        ----------
        data : mapping of str to object
            ``name``, ``inertia`` (kg m^2), ``wheels`` (``torque_limit`` N m, ``momentum_limit``
            N m s, optional ``natural_frequency`` rad/s and ``damping``), ``appendages`` (each
            ``name``, ``modes`` and optionally shared ``frequency`` rad/s and ``damping``; each
            mode ``kind``, ``coupling``, and its own ``frequency``, ``damping`` unless shared),
            optional ``inertia_uncertainty`` (``moment_spread`` relative, ``product_spread``
            kg m^2) and ``description``.
        where : str, optional
            Where the data comes from (a file name), the prefix of error messages. Default
            ``"spacecraft"``.

        Returns
        -------
        FlexibleSpacecraft
            The checked spacecraft.

        Raises
        ------
        SpacecraftError
            Unknown keys (with the closest known key), missing keys, or a bad value; the
            message names its place (``<where>: appendages[1].modes[2].frequency: ...``).
        """
        top = _table(data, where)
        check_keys(top, _KEYS, where, SpacecraftError)
        _require(top, ("name", "inertia", "wheels", "appendages"), where)
        unc = None
        if "inertia_uncertainty" in top:
            at = f"{where}: inertia_uncertainty"
            raw = _table(top["inertia_uncertainty"], at)
            check_keys(raw, _UNCERTAINTY_KEYS, at, SpacecraftError)
            _require(raw, _UNCERTAINTY_KEYS, at)
            unc = _at(at, lambda: InertiaUncertainty(raw["moment_spread"], raw["product_spread"]))
        at = f"{where}: wheels"
        raw = _table(top["wheels"], at)
        check_keys(raw, _WHEEL_KEYS, at, SpacecraftError)
        _require(raw, ("torque_limit", "momentum_limit"), at)
        wheels = _at(at, lambda: Wheels(**raw))
        if not isinstance(top["appendages"], list):
            raise SpacecraftError(f"{where}: appendages: expected a list of tables, got "
                                  f"{type(top['appendages']).__name__}")
        appendages = [_appendage(raw, f"{where}: appendages[{k + 1}]") for k, raw in enumerate(top["appendages"])]
        return _at(where, lambda: cls(top["name"], top["inertia"], appendages, wheels, unc,
                                      top.get("description", "")))

    @classmethod
    def from_toml(cls, path: str | Path) -> "FlexibleSpacecraft":
        """Read a flexible spacecraft TOML file.

        Parameters
        ----------
        path : str or Path
            The TOML file (keys as in the module's example).

        Returns
        -------
        FlexibleSpacecraft
            The checked spacecraft.

        Raises
        ------
        SpacecraftError
            If the file is missing, not TOML, or its description is invalid.
        """
        return cls.from_dict(read_toml(Path(path), "spacecraft", SpacecraftError), where=str(path))


def _table(raw: Any, where: str) -> Mapping[str, Any]:
    if not isinstance(raw, Mapping):
        raise SpacecraftError(f"{where}: expected a table of keys, got {type(raw).__name__}")
    return raw


def _require(raw: Mapping[str, Any], keys: tuple[str, ...], where: str) -> None:
    for key in keys:
        if key not in raw:
            raise SpacecraftError(f"{where}: missing key {key!r}")


def _at(where: str, make: Any) -> Any:
    """``make()``, a :class:`SpacecraftError` prefixed with ``where``."""
    try:
        return make()
    except SpacecraftError as exc:
        raise SpacecraftError(f"{where}: {exc}") from None


def _interval(raw: Mapping[str, Any], key: str, where: str) -> Interval | None:
    return _at(f"{where}.{key}", lambda: Interval.from_value(raw[key])) if key in raw else None


def _appendage(raw: Any, where: str) -> Appendage:
    raw = _table(raw, where)
    check_keys(raw, _APPENDAGE_KEYS, where, SpacecraftError)
    _require(raw, ("name", "modes"), where)
    if not isinstance(raw["modes"], list):
        raise SpacecraftError(f"{where}: modes: expected a list of tables, got {type(raw['modes']).__name__}")
    modes = []
    for k, m in enumerate(raw["modes"]):
        at = f"{where}.modes[{k + 1}]"
        m = _table(m, at)
        check_keys(m, _MODE_KEYS, at, SpacecraftError)
        _require(m, ("kind", "coupling"), at)
        freq, damp = _interval(m, "frequency", at), _interval(m, "damping", at)
        modes.append(_at(at, lambda: Mode(m["kind"], m["coupling"], freq, damp)))
    freq, damp = _interval(raw, "frequency", where), _interval(raw, "damping", where)
    return _at(where, lambda: Appendage(raw["name"], modes, freq, damp))


def _appendage_dict(app: Appendage) -> dict[str, Any]:
    out: dict[str, Any] = {"name": app.name}
    if app.frequency is not None and app.damping is not None:
        out["frequency"], out["damping"] = app.frequency.to_value(), app.damping.to_value()
    modes = []
    for m in app.modes:
        mode: dict[str, Any] = {"kind": m.kind, "coupling": list(m.coupling)}
        if m.frequency is not None and m.damping is not None:
            mode["frequency"], mode["damping"] = m.frequency.to_value(), m.damping.to_value()
        modes.append(mode)
    out["modes"] = modes
    return out


_L_DEMETER = ((0.30, -0.06, 0.26, 0.05, 0.10, 0.04, 0.08, -0.03),
              (0.05, 0.12, -0.04, 0.11, 0.28, -0.05, 0.24, 0.06),
              (0.14, 0.04, 0.12, -0.04, 0.06, 0.12, 0.05, 0.10))

DEMETER = FlexibleSpacecraft(
    "demeter",
    [[31.38, -1.11, -0.26], [-1.11, 21.19, -0.78], [-0.26, -0.78, 35.70]],
    [Appendage(f"a{a + 1}", [Mode(kind, [row[2 * a + k] for row in _L_DEMETER])
                             for k, kind in enumerate(("bending", "torsion"))],
               Interval(0.2 * 2 * np.pi, 0.6 * 2 * np.pi), Interval(5e-4, 5e-3))
     for a in range(4)],
    Wheels(5e-3, 0.12, WHEEL_WN, WHEEL_ZETA),
    InertiaUncertainty(0.3, 3.0),
    "DEMETER (seed 004): nominal inertia of section 2.3, 4 appendages x (bending, torsion) sharing "
    "omega_k in [0.2, 0.6] x 2 pi rad/s and zeta_k in [5e-4, 5e-3]; the coupling L (3 x 8) and the "
    "wheel dynamics H(s) are substitutes (docs/models.md, 'Seed 004').")
"""Seed 004's DEMETER satellite: the plant :func:`satfmu.fmus.plants.demeter.build` builds by default."""
