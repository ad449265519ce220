"""The spacecraft's outer surface as flat facets, for the aerodynamic and solar radiation torques.

A spacecraft description holds them as ``[[facets]]`` tables
(:class:`satfmu.fmus.plants.spacecraft.Spacecraft`)::

    [[facets]]
    area = 1.5                          # m^2
    normal = [1.0, 0.0, 0.0]            # outward normal in body axes (normalized when read)
    centre_of_pressure = [0.5, 0.0, 0.02]   # m, from the centre of mass, body axes
    drag_coefficient = 2.2              # optional (default 2.2)
    specular = 0.1                      # optional: specular reflectivity (default 0)
    diffuse = 0.2                       # optional: diffuse reflectivity (default 0)

:func:`box` makes the six facets of a box. ``specular + diffuse <= 1``: the rest is absorbed.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping, Sequence

import numpy as np

from satfmu.fmus.declared import check_table, finite_number, vector3
from satfmu.fmus.errors import SpacecraftError

_KEYS = ("area", "normal", "centre_of_pressure", "drag_coefficient", "specular", "diffuse")
DRAG_COEFFICIENT = 2.2
"""The usual flat-plate drag coefficient in free molecular flow."""


def _number(raw: Any, where: str, low: float, high: float, unit: str, open_low: bool = False) -> float:
    return finite_number(raw, where, unit, SpacecraftError, low, high, open_low)


def _vector(raw: Any, where: str, unit_length: bool) -> tuple[float, float, float]:
    return vector3(raw, where, SpacecraftError, unit_length)


@dataclass(frozen=True, init=False)
class Facet:
    """One flat facet of the spacecraft's surface.

    Parameters
    ----------
    area : float
        Area, m^2, > 0.
    normal : array_like, shape (3,)
        Outward normal in body axes, any non-zero length (stored normalized).
    centre_of_pressure : array_like, shape (3,)
        The facet's centre of pressure from the spacecraft's centre of mass, body axes, m.
    drag_coefficient : float, optional
        Drag coefficient, >= 0 (default 2.2).
    specular, diffuse : float, optional
        Specular and diffuse reflectivity, each in [0, 1], their sum <= 1 (default 0: absorbing).
    where : str, optional
        Which facet this is, the prefix of error messages (keyword only).

    Raises
    ------
    SpacecraftError
        If a value is out of range.
    """

    area: float
    normal: tuple[float, float, float]
    centre_of_pressure: tuple[float, float, float]
    drag_coefficient: float = DRAG_COEFFICIENT
    specular: float = 0.0
    diffuse: float = 0.0

    def __init__(self, area: float, normal: Sequence[float], centre_of_pressure: Sequence[float],
                 drag_coefficient: float = DRAG_COEFFICIENT, specular: float = 0.0, diffuse: float = 0.0, *,
                 where: str = "facet") -> None:
        object.__setattr__(self, "area", _number(area, f"{where}: area", 0.0, math.inf, "m^2", open_low=True))
        object.__setattr__(self, "normal", _vector(normal, f"{where}: normal", True))
        object.__setattr__(self, "centre_of_pressure", _vector(centre_of_pressure, f"{where}: centre_of_pressure",
                                                               False))
        object.__setattr__(self, "drag_coefficient", _number(drag_coefficient, f"{where}: drag_coefficient", 0.0,
                                                             math.inf, "1"))
        object.__setattr__(self, "specular", _number(specular, f"{where}: specular", 0.0, 1.0, "1"))
        object.__setattr__(self, "diffuse", _number(diffuse, f"{where}: diffuse", 0.0, 1.0, "1"))
        if self.specular + self.diffuse > 1.0:
            raise SpacecraftError(f"{where}: specular + diffuse must be <= 1 (the rest is absorbed), got "
                                  f"{self.specular + self.diffuse:g}")

    def to_dict(self) -> dict[str, Any]:
        """The facet as plain data (a ``[[facets]]`` table's keys)."""
        return {"area": self.area, "normal": list(self.normal), "centre_of_pressure": list(self.centre_of_pressure),
                "drag_coefficient": self.drag_coefficient, "specular": self.specular, "diffuse": self.diffuse}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], where: str = "facet") -> "Facet":
        """A facet from a ``[[facets]]`` table.

        Parameters
        ----------
        data : mapping of str to object
            ``area`` (m^2), ``normal``, ``centre_of_pressure`` (m), optional ``drag_coefficient``,
            ``specular`` and ``diffuse``.
        where : str, optional
            Where the table comes from, the prefix of error messages.

        Returns
        -------
        Facet
            The checked facet.

        Raises
        ------
        SpacecraftError
            Unknown or missing keys, or a bad value.
        """
        check_table(data, _KEYS, _KEYS[:3], where, SpacecraftError)
        return cls(data["area"], data["normal"], data["centre_of_pressure"],
                   data.get("drag_coefficient", DRAG_COEFFICIENT), data.get("specular", 0.0),
                   data.get("diffuse", 0.0), where=where)


def box(size: Sequence[float], offset: Sequence[float] = (0.0, 0.0, 0.0), drag_coefficient: float = DRAG_COEFFICIENT,
        specular: float = 0.0, diffuse: float = 0.0) -> tuple[Facet, ...]:
    """The six facets of a box centred at ``-offset`` from the centre of mass.

    Parameters
    ----------
    size : 3 floats
        Edge lengths along body x, y, z, m, > 0.
    offset : 3 floats, optional
        The centre of mass's position from the box's centre, m: each facet's centre of pressure is
        its centre less this (a centre of mass off the geometric centre gives the torques an arm).
    drag_coefficient : float, optional
        Every facet's drag coefficient.
    specular, diffuse : float, optional
        Every facet's reflectivities.

    Returns
    -------
    tuple of Facet
        +x, -x, +y, -y, +z, -z.

    Raises
    ------
    SpacecraftError
        If a size is not finite and > 0.
    """
    s = _vector(size, "box: size", False)
    if min(s) <= 0:
        raise SpacecraftError(f"box: size must be 3 lengths > 0 m, got {list(size)!r}")
    c = np.asarray(_vector(offset, "box: offset", False))
    out = []
    for axis in range(3):
        others = [s[j] for j in range(3) if j != axis]
        for sign in (1.0, -1.0):
            n = np.zeros(3)
            n[axis] = sign
            out.append(Facet(others[0] * others[1], n.tolist(), (n * s[axis] / 2 - c).tolist(), drag_coefficient,
                             specular, diffuse,
                             where=f"box facet {'+' if sign > 0 else '-'}{'xyz'[axis]}"))
    return tuple(out)
