"""A reaction wheel array as a spacecraft carries it: spin axes, spin inertias and limits.

One :class:`ReactionWheel` per wheel; a spacecraft description holds them as ``[[wheels]]``
tables (:class:`satfmu.fmus.plants.spacecraft.Spacecraft`)::

    [[wheels]]
    axis = [1.0, 0.0, 0.0]    # spin axis in body axes (normalized when read)
    inertia = 0.05            # kg m^2, about the spin axis
    torque_limit = 0.2        # N m, motor torque limit
    speed_limit = 600.0       # rad/s: the motor torque is cut at this speed if it would spin the wheel up
    viscous = 1e-5            # N m s/rad, viscous friction (optional, default 0)
    coulomb = 5e-4            # N m, Coulomb friction (optional, default 0)

:func:`orthogonal` and :func:`pyramid` make the two usual arrays.

The Coulomb friction is linear in the speed within ``|Omega| < COULOMB_ZONE`` (rad/s), continuous
at the zone's edge: ``f = viscous Omega + coulomb sat(Omega / COULOMB_ZONE)`` opposes the spin. This
is Basilisk's ``reactionWheelStateEffector`` law without its Stribeck term (its
``omegaLimitCycle``); the zone is a plant parameter.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping, Sequence

import numpy as np

from satfmu.fmus.declared import check_table, finite_number, vector3
from satfmu.fmus.errors import SpacecraftError

_KEYS = ("axis", "inertia", "torque_limit", "speed_limit", "viscous", "coulomb")


def _positive(value: Any, where: str, unit: str) -> float:
    return finite_number(value, where, unit, SpacecraftError, 0.0, open_low=True)


def _non_negative(value: Any, where: str, unit: str) -> float:
    return finite_number(value, where, unit, SpacecraftError, 0.0)


@dataclass(frozen=True, init=False)
class ReactionWheel:
    """One reaction wheel: its spin axis, spin inertia, motor and speed limits and friction.

    Parameters
    ----------
    axis : array_like, shape (3,)
        Spin axis in body axes, any non-zero length (stored normalized).
    inertia : float
        Spin inertia about the axis, kg m^2, > 0.
    torque_limit : float
        Motor torque limit, N m, > 0.
    speed_limit : float
        Wheel speed (relative to the body) at which a torque that would spin it up is cut,
        rad/s, > 0.
    viscous : float, optional
        Viscous friction coefficient, N m s/rad, >= 0 (default 0).
    coulomb : float, optional
        Coulomb friction torque, N m, >= 0 (default 0).
    where : str, optional
        Which wheel this is, the prefix of error messages (keyword only).

    Raises
    ------
    SpacecraftError
        If the axis is not 3 finite numbers with a non-zero length, or a value is out of range.
    """

    axis: tuple[float, float, float]
    inertia: float
    torque_limit: float
    speed_limit: float
    viscous: float = 0.0
    coulomb: float = 0.0

    def __init__(self, axis: Sequence[float], inertia: float, torque_limit: float, speed_limit: float,
                 viscous: float = 0.0, coulomb: float = 0.0, *, where: str = "wheel") -> None:
        object.__setattr__(self, "axis", vector3(axis, f"{where}: axis", SpacecraftError, unit_length=True))
        object.__setattr__(self, "inertia", _positive(inertia, f"{where}: inertia", "kg m^2"))
        object.__setattr__(self, "torque_limit", _positive(torque_limit, f"{where}: torque_limit", "N.m"))
        object.__setattr__(self, "speed_limit", _positive(speed_limit, f"{where}: speed_limit", "rad/s"))
        object.__setattr__(self, "viscous", _non_negative(viscous, f"{where}: viscous", "N m s/rad"))
        object.__setattr__(self, "coulomb", _non_negative(coulomb, f"{where}: coulomb", "N.m"))

    @property
    def momentum_limit(self) -> float:
        """``inertia * speed_limit``: the spin momentum at the speed limit (body at rest), N m s."""
        return self.inertia * self.speed_limit

    def to_dict(self) -> dict[str, Any]:
        """The wheel as plain data (a ``[[wheels]]`` table's keys)."""
        return {"axis": list(self.axis), "inertia": self.inertia, "torque_limit": self.torque_limit,
                "speed_limit": self.speed_limit, "viscous": self.viscous, "coulomb": self.coulomb}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], where: str = "wheel") -> "ReactionWheel":
        """A wheel from a ``[[wheels]]`` table.

        Parameters
        ----------
        data : mapping of str to object
            ``axis``, ``inertia`` (kg m^2), ``torque_limit`` (N m), ``speed_limit`` (rad/s) and
            optional ``viscous`` (N m s/rad) and ``coulomb`` (N m).
        where : str, optional
            Where the table comes from, the prefix of error messages.

        Returns
        -------
        ReactionWheel
            The checked wheel.

        Raises
        ------
        SpacecraftError
            Unknown or missing keys, or a bad value.
        """
        check_table(data, _KEYS, _KEYS[:4], where, SpacecraftError)
        return cls(data["axis"], data["inertia"], data["torque_limit"], data["speed_limit"],
                   data.get("viscous", 0.0), data.get("coulomb", 0.0), where=where)


def spin_axes(wheels: Sequence[ReactionWheel]) -> np.ndarray:
    """The spin axes as the columns of ``Gs``, shape (3, N).

    Parameters
    ----------
    wheels : sequence of ReactionWheel
        The array.

    Returns
    -------
    numpy.ndarray, shape (3, N)
        Column i: the unit spin axis of wheel i in body axes.
    """
    return np.array([w.axis for w in wheels], float).T.reshape(3, len(wheels))


def check_array(wheels: Sequence[ReactionWheel], where: str) -> tuple[ReactionWheel, ...]:
    """An array that can put a torque on the body about every axis.

    Parameters
    ----------
    wheels : sequence of ReactionWheel
        The array, at least 3 wheels.
    where : str
        The prefix of error messages.

    Returns
    -------
    tuple of ReactionWheel
        The wheels.

    Raises
    ------
    SpacecraftError
        If there are fewer than 3 wheels or their axes do not span the body axes.
    """
    wheels = tuple(wheels)
    if not all(isinstance(w, ReactionWheel) for w in wheels):
        raise SpacecraftError(f"{where}: expected ReactionWheel items")
    if len(wheels) < 3:
        raise SpacecraftError(f"{where}: {len(wheels)} wheel(s); an array needs at least 3 to torque every axis")
    s = np.linalg.svd(spin_axes(wheels), compute_uv=False)
    if s[-1] < 1e-6 * s[0]:
        raise SpacecraftError(f"{where}: the spin axes do not span the body axes (smallest singular value of Gs "
                              f"{s[-1]:.3g}): the array cannot torque the body about every axis")
    return wheels


def orthogonal(inertia: float, torque_limit: float, speed_limit: float, viscous: float = 0.0,
               coulomb: float = 0.0) -> tuple[ReactionWheel, ...]:
    """Three identical wheels along the body axes x, y, z.

    Parameters
    ----------
    inertia : float
        Spin inertia of each wheel, kg m^2.
    torque_limit : float
        Motor torque limit, N m.
    speed_limit : float
        Speed limit, rad/s.
    viscous : float, optional
        Viscous friction coefficient, N m s/rad.
    coulomb : float, optional
        Coulomb friction torque, N m.

    Returns
    -------
    tuple of ReactionWheel
        The three wheels.
    """
    return tuple(ReactionWheel(np.eye(3)[i], inertia, torque_limit, speed_limit, viscous, coulomb,
                               where=f"wheel {i + 1}") for i in range(3))


PYRAMID_ELEVATION = math.degrees(math.atan(1 / math.sqrt(2)))
"""Elevation of the usual pyramid's axes above the plane normal to its axis, deg (35.26: the
four axes then make equal angles with the body axes, and each body axis gets the same
torque)."""


def pyramid(inertia: float, torque_limit: float, speed_limit: float, viscous: float = 0.0, coulomb: float = 0.0,
            elevation_deg: float = PYRAMID_ELEVATION) -> tuple[ReactionWheel, ...]:
    """Four identical wheels in a pyramid about the body z axis: axis k is
    ``(cos e cos a_k, cos e sin a_k, sin e)`` with ``a_k = 45 + 90 k`` deg.

    Parameters
    ----------
    inertia : float
        Spin inertia of each wheel, kg m^2.
    torque_limit : float
        Motor torque limit, N m.
    speed_limit : float
        Speed limit, rad/s.
    viscous : float, optional
        Viscous friction coefficient, N m s/rad.
    coulomb : float, optional
        Coulomb friction torque, N m.
    elevation_deg : float, optional
        Elevation ``e`` of the axes above the body x-y plane, deg, in (0, 90); default
        :data:`PYRAMID_ELEVATION`.

    Returns
    -------
    tuple of ReactionWheel
        The four wheels.

    Raises
    ------
    SpacecraftError
        If the elevation is not in (0, 90) deg.
    """
    if not (0.0 < elevation_deg < 90.0):
        raise SpacecraftError(f"pyramid: elevation_deg must lie in (0, 90) deg, got {elevation_deg!r}")
    e = math.radians(elevation_deg)
    return tuple(ReactionWheel((math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)), inertia,
                               torque_limit, speed_limit, viscous, coulomb, where=f"wheel {k + 1}")
                 for k, a in enumerate(math.radians(45.0 + 90.0 * k) for k in range(4)))
