"""Units: the FMI 2.0 unit algebra of satfmu's declared units and the units a user asks for.

A unit is what FMI 2.0 calls a ``BaseUnit``: exponents of the SI base units (``kg``, ``m``, ``s``,
``A``, ``K``, ``mol``, ``cd``) and ``rad``, and a ``factor`` (a value ``v`` in the unit is
``factor * v`` in the base units). Two units convert into each other when their exponents agree,
by the ratio of their factors (no offsets: no unit here has one).

- :data:`UNITS`: the units satfmu's models declare, each spelt one way (FMI's
  Modelica syntax: ``N.m``, ``kg.m2``, ``rad/s``).
- :data:`DISPLAY`: further units a scenario may ask a metric or a recorded signal to be
  converted to (``deg``, ``deg/s``, ``mrad``, ``mN.m``, ``min``, ``nT``, ...).
- :func:`conversion`: the factor from one unit to another, the first one read from an FMU's own
  ``UnitDefinitions`` when it declares it (a third-party FMU), else from these tables.
- :func:`squared_time` and :func:`ratio`: the units of an integral of squares over time and of a
  ratio of signals, spelt as the tables spell units.
"""
from __future__ import annotations

import math
import re
from typing import Mapping

from satfmu.fmus.declared import did_you_mean
from satfmu.fmus.errors import UnitError

DIMENSIONLESS = "1"
"""The unit of a dimensionless quantity (and of the catalog's generic signal generators, ``signal_<kind>``)."""

UNITS: dict[str, dict[str, float] | None] = {
    "1": {},
    "s": {"s": 1},
    "rad": {"rad": 1},
    "rad/s": {"rad": 1, "s": -1},
    "N.m": {"kg": 1, "m": 2, "s": -2},
    "kg.m2": {"kg": 1, "m": 2},
    "N.m.s": {"kg": 1, "m": 2, "s": -1},
    "N.m/s": {"kg": 1, "m": 2, "s": -3},
    "N.m/rad": {"kg": 1, "m": 2, "s": -2, "rad": -1},
    "N.m/(rad.s)": {"kg": 1, "m": 2, "s": -3, "rad": -1},
    "N.m.s/rad": {"kg": 1, "m": 2, "s": -1, "rad": -1},
    "J": {"kg": 1, "m": 2, "s": -2},
    "rad.s": {"rad": 1, "s": 1},
    "1/s": {"s": -1},
    "m": {"m": 1},
    "m/s": {"m": 1, "s": -1},
    "kg/m3": {"kg": 1, "m": -3},
    "m2": {"m": 2},
    "N/m2": {"kg": 1, "m": -1, "s": -2},
    "T": {"kg": 1, "s": -2, "A": -1},
    "A.m2": {"A": 1, "m": 2},
    "T.m3": {"kg": 1, "m": 3, "s": -2, "A": -1},
    "arcsec": {"rad": 1, "factor": 4.84813681109536e-06},
    "rad/s0.5": None,
    "rad/s1.5": None,
}
"""SI units the project declares, as FMI 2.0 BaseUnit exponents (and ``factor``: the unit is that many
of the base unit's); None for a unit with no base unit of integer exponents (a noise density). Each
is spelt one way (FMI's Modelica syntax).
"""

BASE = ("kg", "m", "s", "A", "K", "mol", "cd", "rad")
"""FMI 2.0's ``BaseUnit`` exponents, in its order."""

DISPLAY: dict[str, dict[str, float]] = {
    "deg": {"rad": 1, "factor": math.pi / 180},
    "mrad": {"rad": 1, "factor": 1e-3},
    "urad": {"rad": 1, "factor": 1e-6},
    "arcmin": {"rad": 1, "factor": math.pi / 10800},
    "deg/s": {"rad": 1, "s": -1, "factor": math.pi / 180},
    "mrad/s": {"rad": 1, "s": -1, "factor": 1e-3},
    "deg/h": {"rad": 1, "s": -1, "factor": math.pi / 180 / 3600},
    "rpm": {"rad": 1, "s": -1, "factor": 2 * math.pi / 60},
    "ms": {"s": 1, "factor": 1e-3},
    "min": {"s": 1, "factor": 60.0},
    "h": {"s": 1, "factor": 3600.0},
    "km": {"m": 1, "factor": 1e3},
    "mN.m": {"kg": 1, "m": 2, "s": -2, "factor": 1e-3},
    "uN.m": {"kg": 1, "m": 2, "s": -2, "factor": 1e-6},
    "mN.m.s": {"kg": 1, "m": 2, "s": -1, "factor": 1e-3},
    "nT": {"kg": 1, "s": -2, "A": -1, "factor": 1e-9},
    "uT": {"kg": 1, "s": -2, "A": -1, "factor": 1e-6},
}
"""Units a scenario may ask for beyond :data:`satfmu.fmus.units.UNITS`, as FMI ``BaseUnit`` exponents
and factor."""

KNOWN: dict[str, dict[str, float] | None] = {**UNITS, **DISPLAY, "dB": None}
"""Every unit satfmu spells: the declared ones, :data:`DISPLAY`, and ``dB`` (a gain margin's: a
logarithm, no base unit)."""


def base_unit(unit: str, declared: Mapping[str, Mapping[str, float]] | None = None) -> dict[str, float]:
    """The ``BaseUnit`` of a unit: exponents (zeros left out) and ``factor``.

    Parameters
    ----------
    unit : str
        A unit of :data:`KNOWN`, or one of ``declared``.
    declared : mapping, optional
        An FMU's own unit definitions (name -> its ``BaseUnit`` attributes), which take precedence.

    Raises
    ------
    UnitError
        An unknown unit (with the closest known spelling), or one without a ``BaseUnit``.
    """
    if declared and unit in declared:
        base = dict(declared[unit])
    elif unit in KNOWN:
        found = KNOWN[unit]
        if found is None:
            raise UnitError(f"unit {unit!r} has no base unit of integer exponents: it converts to nothing else")
        base = dict(found)
    else:
        hint = did_you_mean(_spelling(unit), list(KNOWN))
        listed = ", ".join(k for k in KNOWN if KNOWN[k] is not None)
        raise UnitError(f"unknown unit {unit!r}" + (hint or f" (units: {listed})"))
    if base.get("offset", 0.0):
        raise UnitError(f"unit {unit!r} has an offset: satfmu converts by factors only")
    return {k: float(v) for k, v in base.items() if k != "offset" and (k == "factor" or v)}


def _spelling(unit: str) -> str:
    """A near miss in FMI's spelling: ``N m`` and ``N*m`` as ``N.m``, ``m^2`` as ``m2``."""
    return re.sub(r"\^", "", re.sub(r"\s*[ *·]\s*", ".", unit.strip()))


def conversion(source: str, target: str, declared: Mapping[str, Mapping[str, float]] | None = None) -> float:
    """The factor ``k`` such that a value ``v`` in ``source`` is ``k * v`` in ``target``.

    Parameters
    ----------
    source : str
        The declared unit (an FMU variable's).
    target : str
        The unit asked for.
    declared : mapping, optional
        The FMU's own unit definitions (name -> ``BaseUnit`` attributes): they define ``source``
        when they hold it.

    Returns
    -------
    float
        1.0 when the two are the same unit.

    Raises
    ------
    UnitError
        An unknown unit, or two of different dimensions (``rad`` to ``N.m``).
    """
    if source == target:
        return 1.0
    a, b = base_unit(source, declared), base_unit(target)
    if {k: v for k, v in a.items() if k != "factor"} != {k: v for k, v in b.items() if k != "factor"}:
        raise UnitError(f"cannot convert {source!r} ({_dimension(a)}) to {target!r} ({_dimension(b)})")
    return a.get("factor", 1.0) / b.get("factor", 1.0)


def _dimension(base: Mapping[str, float]) -> str:
    text = ".".join(f"{k}{'' if v == 1 else f'{v:g}'}" for k in BASE if (v := base.get(k, 0.0)))
    return text or "dimensionless"


def _factors(unit: str) -> list[tuple[str, int]]:
    """A unit's factors as (symbol, exponent), the ones after ``/`` negated (``N.m/(rad.s)``)."""
    num, _, den = unit.partition("/")
    out = []
    for part, sign in ((num, 1), (den.strip("()"), -1)):
        for f in filter(None, part.split(".")):
            m = re.fullmatch(r"([A-Za-z]+)(-?\d+)?", f)
            if m and m[1] != "1":
                out.append((m[1], sign * int(m[2] or 1)))
            elif not m and f != "1":
                out.append((f, sign))
    return out


def _spelt(factors: Mapping[str, int]) -> str:
    """Factors -> a unit spelt as :data:`satfmu.fmus.units.UNITS` are (``kg.m2/s``)."""
    pos = [f"{s}{'' if e == 1 else e}" for s, e in factors.items() if e > 0]
    neg = [f"{s}{'' if e == -1 else -e}" for s, e in factors.items() if e < 0]
    text = ".".join(pos) or "1"
    if neg:
        text += "/" + (neg[0] if len(neg) == 1 else f"({'.'.join(neg)})")
    return text


def _combine(*units: tuple[str, int]) -> str:
    """The product of units raised to powers, spelt by :func:`_spelt`."""
    total: dict[str, int] = {}
    for unit, power in units:
        for sym, exp in _factors(unit):
            total[sym] = total.get(sym, 0) + exp * power
    return _spelt({s: e for s, e in total.items() if e})


def squared_time(unit: str) -> str:
    """The unit of ``integral of sum y_i^2 dt`` for ``y`` in ``unit`` (``N.m`` -> ``N2.m2.s``).

    Parameters
    ----------
    unit : str
        The signals' unit.
    """
    return _combine((unit, 2), ("s", 1))


def ratio(numerator: str, denominator: str) -> str:
    """The unit of ``numerator / denominator`` (``1`` when they are the same unit).

    Parameters
    ----------
    numerator, denominator : str
        The two units.
    """
    return "1" if numerator == denominator else _combine((numerator, 1), (denominator, -1))
