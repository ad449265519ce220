"""A spacecraft description: name, inertia tensor, actuator limits (TOML, dict or Python).

The plant builders (:func:`satfmu.fmus.plants.mrp_satellite.build`) and every design of the MRP
satellite take one, so that a controller is designed for *your* spacecraft. A TOML file::

    name = "my_sat"
    description = "200 kg bus with a deployed boom"
    inertia = [[100.0, 2.0, -1.0],      # kg m^2, the inertia tensor about the centre of mass
               [2.0, 120.0, 0.5],       # in body axes; off-diagonal entries are the tensor's
               [-1.0, 0.5, 80.0]]       # (J_xy = -integral of x y dm), symmetric
    [actuators]
    torque_limit = 5.0                  # N m per body axis (optional)
    dipole_limit = 0.2                  # A m^2 per magnetorquer axis (optional)
    [[wheels]]                          # a reaction wheel array (optional, at least 3 wheels)
    axis = [1.0, 0.0, 0.0]              # one table per wheel: satfmu.fmus.plants.wheels
    inertia = 0.05
    torque_limit = 0.2
    speed_limit = 600.0
    residual_dipole = [0.1, 0.0, -0.05]  # A m^2, body axes (optional)
    [[facets]]                          # the outer surface for drag and radiation (optional)
    area = 1.5                          # one table per facet: satfmu.fmus.plants.surface
    normal = [1.0, 0.0, 0.0]
    centre_of_pressure = [0.5, 0.0, 0.02]

``inertia`` may also be three principal moments ``[I_x, I_y, I_z]``. The tensor is
checked: finite, symmetric, positive definite, and its principal moments satisfy the
triangle inequality ``I_1 + I_2 >= I_3`` of every rigid body. It is the whole spacecraft's,
wheels included; with the wheels' spin inertias taken out (``J - sum Js g g^T``, the body that
the wheel plant integrates) it must stay positive definite.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike

from satfmu.fmus.declared import check_keys, finite_number, read_toml, vector3
from satfmu.fmus.errors import SpacecraftError
from satfmu.fmus.plants.surface import Facet
from satfmu.fmus.plants.wheels import ReactionWheel, check_array, spin_axes

SYMMETRY_RTOL = 1e-9
"""Largest ``|J - J^T|`` relative to ``max |J|`` accepted as symmetric (rounding of a CAD export)."""
PARAMETERS = {"I_x": (0, 0), "I_y": (1, 1), "I_z": (2, 2), "I_xy": (0, 1), "I_xz": (0, 2), "I_yz": (1, 2)}
"""Plant parameter name -> entry of the inertia tensor it holds."""
_KEYS = ("name", "description", "inertia", "actuators", "wheels", "facets", "residual_dipole")
_ACTUATOR_KEYS = ("torque_limit", "dipole_limit")


@dataclass(frozen=True, init=False)
class Spacecraft:
    """A rigid spacecraft: its inertia tensor and actuator limits.

    Parameters
    ----------
    name : str
        Identifier, used in artifact provenance and messages.
    inertia : array_like
        3 x 3 inertia tensor about the centre of mass in body axes, kg m^2 (symmetric
        positive definite, products of inertia off the diagonal), or 3 principal moments.
    torque_limit : float, optional
        Actuator torque limit per body axis, N m (the MRP plant's ``u_max``).
    description : str
        Free text.
    dipole_limit : float, optional
        Magnetorquer dipole limit per body axis, A m^2 (the cubesat plant's ``m_max``).
    wheels : sequence of ReactionWheel, optional
        Its reaction wheel array (:mod:`satfmu.fmus.plants.wheels`), at least 3 wheels whose
        axes span the body axes; default none.
    facets : sequence of Facet, optional
        Its outer surface as flat facets (:mod:`satfmu.fmus.plants.surface`), for the drag and
        solar radiation torques; default none.
    residual_dipole : 3 floats, optional
        Its residual magnetic dipole in body axes, A m^2 (default zero).

    Raises
    ------
    SpacecraftError
        If the tensor is not 3 x 3 (or 3 moments), not finite, not symmetric, not positive
        definite or violates the triangle inequality, a limit is not positive, or the wheel
        array cannot torque every axis or leaves no positive definite body inertia.
    """

    name: str
    inertia: tuple[tuple[float, float, float], ...]
    torque_limit: float | None = None
    description: str = field(default="", compare=False)
    dipole_limit: float | None = None
    wheels: tuple[ReactionWheel, ...] = ()
    facets: tuple[Facet, ...] = ()
    residual_dipole: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __init__(self, name: str, inertia: ArrayLike, torque_limit: float | None = None,
                 description: str = "", *, dipole_limit: float | None = None,
                 wheels: Sequence[ReactionWheel] = (), facets: Sequence[Facet] = (),
                 residual_dipole: Sequence[float] = (0.0, 0.0, 0.0)) -> None:
        if not isinstance(name, str) or not name:
            raise SpacecraftError(f"name: must be a non-empty string, got {name!r}")
        object.__setattr__(self, "name", name)
        object.__setattr__(self, "inertia", _tensor(inertia, f"{name}: inertia"))
        object.__setattr__(self, "torque_limit", _limit(torque_limit, f"{name}: actuators.torque_limit", "N.m"))
        object.__setattr__(self, "description", description)
        object.__setattr__(self, "dipole_limit", _limit(dipole_limit, f"{name}: actuators.dipole_limit", "A m^2"))
        object.__setattr__(self, "wheels", check_array(wheels, f"{name}: wheels") if len(wheels) else ())
        if not all(isinstance(f, Facet) for f in facets):
            raise SpacecraftError(f"{name}: facets: expected Facet items")
        object.__setattr__(self, "facets", tuple(facets))
        object.__setattr__(self, "residual_dipole", vector3(residual_dipole, f"{name}: residual_dipole (A m^2)",
                                                            SpacecraftError))
        if self.wheels:
            body = self.body_inertia
            if not np.linalg.eigvalsh(body)[0] > 0:
                raise SpacecraftError(f"{name}: the inertia less the wheels' spin inertias (J - sum Js g g^T) is not "
                                      f"positive definite (eigenvalues {np.linalg.eigvalsh(body).tolist()} kg m^2): "
                                      "give the whole spacecraft's inertia, wheels included")

    @property
    def tensor(self) -> np.ndarray:
        """The inertia tensor as a 3 x 3 array, kg m^2."""
        return np.array(self.inertia)

    @property
    def body_inertia(self) -> np.ndarray:
        """The inertia less the wheels' spin inertias, ``J - sum_i Js_i g_i g_i^T``, kg m^2 (3 x 3):
        the body whose rate the wheel plant integrates beside the wheels' spin momenta."""
        G = spin_axes(self.wheels) if self.wheels else np.zeros((3, 0))
        return self.tensor - G @ np.diag([w.inertia for w in self.wheels]) @ G.T

    @property
    def principal_moments(self) -> np.ndarray:
        """Principal moments of inertia, ascending, kg m^2."""
        return np.linalg.eigvalsh(self.tensor)

    def parameters(self) -> dict[str, float]:
        """The plant parameters this spacecraft sets: ``I_x ... I_yz`` (kg m^2) and, with a
        torque limit, ``u_max`` (N m)."""
        out = {name: self.inertia[i][j] for name, (i, j) in PARAMETERS.items()}
        if self.torque_limit is not None:
            out["u_max"] = self.torque_limit
        return out

    def to_dict(self) -> dict[str, Any]:
        """The description as plain data (the TOML file's keys)."""
        data: dict[str, Any] = {"name": self.name, "inertia": [list(r) for r in self.inertia]}
        if self.description:
            data["description"] = self.description
        limits = {"torque_limit": self.torque_limit, "dipole_limit": self.dipole_limit}
        if any(v is not None for v in limits.values()):
            data["actuators"] = {k: v for k, v in limits.items() if v is not None}
        if self.wheels:
            data["wheels"] = [w.to_dict() for w in self.wheels]
        if self.facets:
            data["facets"] = [f.to_dict() for f in self.facets]
        if any(self.residual_dipole):
            data["residual_dipole"] = list(self.residual_dipole)
        return data

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], where: str = "spacecraft") -> "Spacecraft":
        """A spacecraft from plain data with the TOML file's keys.

        Parameters
        ----------
        data : mapping of str to object
            ``name``, ``inertia`` (kg m^2), optional ``description`` and an optional
            ``actuators`` table with ``torque_limit`` (N m) and ``dipole_limit`` (A m^2), and an
            optional ``wheels`` list of tables (:meth:`satfmu.fmus.plants.wheels.ReactionWheel.from_dict`),
            an optional ``facets`` list of tables (:meth:`satfmu.fmus.plants.surface.Facet.from_dict`) and
            an optional ``residual_dipole`` (A m^2), as in the module's example.
        where : str, optional
            Where the data comes from (a file name), the prefix of error messages. Default
            ``"spacecraft"``.

        Returns
        -------
        Spacecraft
            The checked spacecraft.

        Raises
        ------
        SpacecraftError
            Unknown or missing keys (with the closest known key), or a bad value.
        """
        if not isinstance(data, Mapping):
            raise SpacecraftError(f"{where}: expected a table of keys, got {type(data).__name__}")
        check_keys(data, _KEYS, where, SpacecraftError)
        for key in ("name", "inertia"):
            if key not in data:
                raise SpacecraftError(f"{where}: missing key {key!r}")
        act = data.get("actuators", {})
        if not isinstance(act, Mapping):
            raise SpacecraftError(f"{where}: actuators: expected a table, got {type(act).__name__}")
        check_keys(act, _ACTUATOR_KEYS, f"{where}: actuators", SpacecraftError)
        raw_wheels = data.get("wheels", [])
        if not isinstance(raw_wheels, list):
            raise SpacecraftError(f"{where}: wheels: expected a list of tables ([[wheels]]), got "
                                  f"{type(raw_wheels).__name__}")
        wheels = [ReactionWheel.from_dict(w, f"{where}: wheels[{k + 1}]") for k, w in enumerate(raw_wheels)]
        raw_facets = data.get("facets", [])
        if not isinstance(raw_facets, list):
            raise SpacecraftError(f"{where}: facets: expected a list of tables ([[facets]]), got "
                                  f"{type(raw_facets).__name__}")
        facets = [Facet.from_dict(f, f"{where}: facets[{k + 1}]") for k, f in enumerate(raw_facets)]
        try:
            return cls(data["name"], data["inertia"], act.get("torque_limit"), data.get("description", ""),
                       dipole_limit=act.get("dipole_limit"), wheels=wheels, facets=facets,
                       residual_dipole=data.get("residual_dipole", (0.0, 0.0, 0.0)))
        except SpacecraftError as exc:
            raise SpacecraftError(f"{where}: {exc}") from None

    @classmethod
    def from_toml(cls, path: str | Path) -> "Spacecraft":
        """Read a spacecraft TOML file.

        Parameters
        ----------
        path : str or Path
            The TOML file (keys as in the module's example).

        Returns
        -------
        Spacecraft
            The checked spacecraft.

        Raises
        ------
        SpacecraftError
            If the file is missing, not TOML, or its description is invalid.
        """
        return cls.from_dict(read_toml(Path(path), "spacecraft", SpacecraftError), where=str(path))


def _limit(value: Any, where: str, unit: str) -> float | None:
    """``value`` as a float, None kept; refused unless a finite number > 0."""
    return None if value is None else finite_number(value, where, unit, SpacecraftError, 0.0, open_low=True)


def _tensor(raw: Any, where: str) -> tuple[tuple[float, float, float], ...]:
    try:
        J = np.array(raw, dtype=float)
    except (TypeError, ValueError):
        raise SpacecraftError(f"{where}: must be 3 numbers or a 3 x 3 table of numbers, got {raw!r}") from None
    if J.shape == (3,):
        J = np.diag(J)
    if J.shape != (3, 3):
        raise SpacecraftError(f"{where}: must be 3 principal moments or a 3 x 3 tensor, got shape {J.shape}")
    if not np.all(np.isfinite(J)):
        raise SpacecraftError(f"{where}: entries must be finite, got {J.tolist()}")
    scale = float(np.max(np.abs(J)))
    i, j = np.unravel_index(np.argmax(np.abs(J - J.T)), J.shape)
    if abs(J[i, j] - J[j, i]) > SYMMETRY_RTOL * scale:
        raise SpacecraftError(f"{where}: not symmetric: [{i}][{j}] = {J[i, j]:g} but [{j}][{i}] = {J[j, i]:g}")
    J = (J + J.T) / 2
    moments = np.linalg.eigvalsh(J)
    if not moments[0] > 0:
        raise SpacecraftError(f"{where}: not positive definite (principal moments {moments.tolist()} kg m^2)")
    if moments[0] + moments[1] < moments[2] * (1 - 1e-12):
        raise SpacecraftError(f"{where}: principal moments {moments.tolist()} kg m^2 violate the triangle "
                              f"inequality I_1 + I_2 >= I_3 of a rigid body")
    return tuple((float(row[0]), float(row[1]), float(row[2])) for row in J)


SEED_000 = Spacecraft("seed_000", (15.0, 16.0, 12.5), torque_limit=5.0,
                      description="The rigid satellite of the seed 000 paper (principal axes)")
"""Seed 000's satellite: diag(15, 16, 12.5) kg m^2; 5 N m is the torque limit of its saturated runs."""
