"""Dispersions: random start values of a scenario, drawn as a pure function of (seed, index).

A scenario's ``[dispersions]`` table declares, in order, what each Monte Carlo sample
changes. Keys with a dot name a target and take a distribution::

    [dispersions]
    "plant.I_x" = { kind = "normal", std = 0.5 }                  # kg m^2; mean: the nominal
    "plant.omega_0[1]" = { kind = "uniform", low = -0.01, high = 0.01 }      # rad/s
    "plant.u_max" = { kind = "truncated_normal", mean = 5.0, std = 0.5, low = 4.0, high = 6.0 }
    "plant.k" = { kind = "log_uniform", low = 0.1, high = 10.0 }
    "plant.mode" = { kind = "choice", values = [1, 2, 3], weights = [0.5, 0.25, 0.25] }
    "profiles[0].after" = { kind = "uniform", low = 0.5, high = 1.5 }   # field of profile 0
    "profiles[1].seed" = { kind = "seed" }         # a fresh seed of a ``random`` profile
    attitude = { instance = "plant", kind = "cone", half_angle_deg = 10.0 }
    inertia = { instance = "plant", relative = 0.2, axis_rotation_deg = 2.0 }

Targets: ``"instance.parameter"`` (an FMU start value, indexed names as the FMU spells
them) or ``"profiles[i].field"`` (a field of the scenario's i-th ``[[profiles]]`` table).

Distributions (``normal`` and ``truncated_normal`` default ``mean`` to the nominal value,
the scenario's start value or else the FMU's):

``normal``            mean, std > 0
``truncated_normal``  mean, std > 0, low < high (normal conditioned on [low, high])
``uniform``           low < high
``log_uniform``       0 < low < high (log of the value uniform)
``choice``            values (non-empty list), weights (as many, >= 0, summing to > 0)
``seed``              an integer in [0, 2**31 - 1], for the ``seed`` of a random profile

The numeric kinds take ``transform = "square"``: the value set is the square of the draw
(a moment of inertia whose square root is uniform, as seed 004's uncertainty model draws
``J``; ``low``, ``high``, ``mean`` and ``std`` are then those of the root, and ``mean`` must
be given).

``attitude`` writes the plant's initial attitude: ``mrp = "sigma_0"`` (the MRP
``sigma_0[1..3]``, the shadow set with ``|sigma| <= 1``) or ``quaternion = "q_0"``
(``q_0[1..4]``, scalar last); without either, the plant's parameters decide (``sigma_0``
first). ``kind = "uniform"`` is a uniformly distributed rotation (Haar measure);
``kind = "cone"`` with ``half_angle_deg`` is the nominal attitude turned by a rotation
about a uniformly random axis whose angle theta has ``cos theta`` uniform on
``[cos half_angle, 1]``: each body axis perpendicular to the rotation axis is then
uniform over the spherical cap of that half-angle, and the sampled attitude is always
within ``half_angle_deg`` of the nominal one.

``inertia`` scales each nominal principal moment by an independent factor uniform on
``[1 - relative, 1 + relative]`` and, with ``axis_rotation_deg > 0``, turns the principal
axes by a cone rotation of that half-angle (the plant must then have products of inertia
``I_xy, I_xz, I_yz``). A draw that is not a rigid body (:class:`satfmu.fmus.plants.spacecraft.Spacecraft`:
symmetric positive definite, triangle inequality) is drawn again from the same generator,
so it stays deterministic. It writes ``I_x, I_y, I_z`` and, when the plant has them, the
products.

Determinism: sample ``index`` of campaign ``seed`` draws from one generator,
``numpy.random.default_rng(SeedSequence(seed, spawn_key=(index,)))``, the dispersions in
their declared order: the values depend on (seed, index, declaration) only, not on which
other samples are drawn, in what order or by which worker.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Callable, Mapping, Sequence

import numpy as np

from satfmu.fmus.declared import check_keys, did_you_mean
from satfmu.fmus.plants.spacecraft import PARAMETERS as INERTIA_PARAMETERS
from satfmu.fmus.plants.spacecraft import Spacecraft, SpacecraftError
from satfmu.fmus.errors import DispersionError

if TYPE_CHECKING:  # scipy.spatial costs ~0.4 s to import: loaded by the draws that use it
    from scipy.spatial.transform import Rotation

Nominal = Callable[[str, str], "float | None"]
"""(instance or ``"profiles[i]"``, parameter or field) -> its nominal value, or None if it has none."""
Overrides = dict[str, dict[str, Any]]
"""Instance (or ``"profiles[i]"``) -> parameter (or field) -> sampled value."""

KINDS = {"normal": ("mean", "std"), "truncated_normal": ("mean", "std", "low", "high"),
         "uniform": ("low", "high"), "log_uniform": ("low", "high"), "choice": ("values", "weights"),
         "seed": ()}
"""Distribution kind -> its fields."""
TRANSFORMS = {"square": lambda v: v * v}
"""``transform`` of a numeric distribution -> the function of the draw that is set."""
ATTITUDE_KINDS = ("uniform", "cone")
SEED_MAX = 2**31 - 1
"""Largest ``seed`` drawn (a non-negative 32-bit signed integer, valid for any FMU Integer)."""
MAX_REDRAWS = 1000
"""Inertia draws tried before giving up (a relative spread that rarely makes a rigid body)."""
_PROFILE = re.compile(r"profiles\[(\d+)\]\.([A-Za-z_][A-Za-z0-9_]*)")
_ATTITUDE = ("instance", "kind", "half_angle_deg", "mrp", "quaternion")
_INERTIA = ("instance", "relative", "axis_rotation_deg")


def _number(v: Any, where: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise DispersionError(f"{where}: must be a finite number, got {v!r}")
    return float(v)


@dataclass(frozen=True)
class Distribution:
    """One dispersed scalar: a target and its distribution.

    Parameters
    ----------
    target : str
        ``"instance.parameter"`` or ``"profiles[i].field"``.
    kind : str
        One of :data:`KINDS`.
    spec : dict
        The distribution's fields (``mean``, ``std``, ``low``, ``high``, ``values``,
        ``weights``), in the target's unit.
    """

    target: str
    kind: str
    spec: dict[str, Any] = field(default_factory=dict)

    @property
    def owner(self) -> str:
        """The instance name, or ``"profiles[i]"``."""
        return self.target.rsplit(".", 1)[0] if self.target.startswith("profiles[") else self.target.split(".", 1)[0]

    @property
    def name(self) -> str:
        """The parameter (or profile field) name."""
        return self.target[len(self.owner) + 1:]

    def draw(self, rng: np.random.Generator, nominal: Nominal | None, where: str) -> Any:
        """One value from ``rng`` (``nominal`` gives the default ``mean``), transformed.

        Parameters
        ----------
        rng : numpy.random.Generator
            The sample's generator (:meth:`Dispersions.sample`).
        nominal : callable or None
            (instance or ``"profiles[i]"``, name) -> nominal value or None (:data:`Nominal`);
            gives the ``mean`` of a ``normal`` or ``truncated_normal`` that has none (None: no
            FMU to ask).
        where : str
            Key path of the entry, named in errors.

        Returns
        -------
        float, int or object
            The value, in the target's unit: an int for ``seed``, one of the ``values`` for
            ``choice``.

        Raises
        ------
        DispersionError
            If the mean is needed and neither given nor nominal.
        """
        value = self._draw(rng, nominal, where)
        transform = self.spec.get("transform")
        return value if transform is None else TRANSFORMS[transform](value)

    def _draw(self, rng: np.random.Generator, nominal: Nominal | None, where: str) -> Any:
        s = self.spec
        if self.kind == "seed":
            return int(rng.integers(0, SEED_MAX, endpoint=True))
        if self.kind == "uniform":
            return float(rng.uniform(s["low"], s["high"]))
        if self.kind == "log_uniform":
            return float(math.exp(rng.uniform(math.log(s["low"]), math.log(s["high"]))))
        if self.kind == "choice":
            w = np.asarray(s.get("weights", np.ones(len(s["values"]))), float)
            return s["values"][int(rng.choice(len(s["values"]), p=w / w.sum()))]
        mean = s.get("mean")
        if mean is None:
            mean = nominal(self.owner, self.name) if nominal is not None else None
            if mean is None:
                raise DispersionError(f"{where}.mean: not given, and {self.target} has no nominal value")
        if self.kind == "normal":
            return float(rng.normal(mean, s["std"]))
        from scipy import stats  # 0.6 s and about 70 MB of imports: only for a truncated normal

        a, b = (s["low"] - mean) / s["std"], (s["high"] - mean) / s["std"]
        return float(stats.truncnorm.rvs(a, b, loc=mean, scale=s["std"], random_state=rng))


@dataclass(frozen=True)
class Attitude:
    """A dispersed initial attitude written into the plant's MRP or quaternion parameters.

    Parameters
    ----------
    instance : str
        The plant instance.
    kind : {"uniform", "cone"}
        Uniform over all rotations, or within ``half_angle_deg`` of the nominal attitude.
    half_angle_deg : float, optional
        Cone half-angle, deg (``cone`` only; in (0, 180]).
    mrp, quaternion : str, optional
        Base name of the plant's MRP (3 components) or quaternion (4, scalar last)
        parameters; at most one (default: ``sigma_0`` if the plant has it, else ``q_0``).
    """

    instance: str
    kind: str
    half_angle_deg: float | None = None
    mrp: str | None = None
    quaternion: str | None = None

    def draw(self, rng: np.random.Generator, nominal: Nominal | None, where: str) -> dict[str, float]:
        """The attitude parameters of one sample (``nominal`` gives the nominal attitude of a
        cone and the parameters the plant has).

        Parameters
        ----------
        rng : numpy.random.Generator
            The sample's generator (:meth:`Dispersions.sample`).
        nominal : callable or None
            (instance or ``"profiles[i]"``, name) -> nominal value or None (:data:`Nominal`);
            tells which attitude parameters the plant has and gives a cone's nominal attitude
            (None: no FMU to ask).
        where : str
            Key path of the entry, named in errors.

        Returns
        -------
        dict of str to float
            ``sigma_0[1..3]`` (MRP) or ``q_0[1..4]`` (quaternion, scalar last), or the named base's.

        Raises
        ------
        DispersionError
            If the parameter base cannot be told, or a cone lacks its nominal attitude.
        """
        mrp, quat = self.mrp, self.quaternion
        if mrp is None and quat is None:
            if nominal is None:
                raise DispersionError(f"{where}: name 'mrp' or 'quaternion' (no FMU to tell which it has)")
            if nominal(self.instance, "sigma_0[1]") is not None:
                mrp = "sigma_0"
            elif nominal(self.instance, "q_0[1]") is not None:
                quat = "q_0"
            else:
                raise DispersionError(f"{where}: {self.instance} has neither sigma_0[1..3] nor q_0[1..4]; name "
                                      "its attitude parameters with 'mrp' or 'quaternion'")
        base, n = (mrp, 3) if mrp is not None else (quat, 4)
        names = [f"{base}[{i}]" for i in range(1, n + 1)]
        from scipy.spatial.transform import Rotation

        if self.kind == "uniform":
            r = Rotation.random(random_state=rng)
        else:
            values = [nominal(self.instance, k) if nominal is not None else None for k in names]
            if any(v is None for v in values):
                raise DispersionError(f"{where}: a cone needs the nominal attitude {self.instance}.{base}[1..{n}]")
            if self.half_angle_deg is None:
                raise DispersionError(f"{where}: a cone needs 'half_angle_deg'")
            r0 = Rotation.from_mrp(values) if mrp is not None else Rotation.from_quat(values)
            r = cone_rotation(rng, self.half_angle_deg) * r0
        v = r.as_mrp() if mrp is not None else r.as_quat()
        return dict(zip(names, (float(x) for x in v)))


@dataclass(frozen=True)
class Inertia:
    """A dispersed inertia tensor: principal moments scaled, principal axes turned.

    Parameters
    ----------
    instance : str
        The plant instance (parameters ``I_x, I_y, I_z`` and possibly ``I_xy, I_xz, I_yz``).
    relative : float
        Each principal moment is scaled by a factor uniform on ``[1 - relative, 1 + relative]``
        (0 < relative < 1).
    axis_rotation_deg : float
        Half-angle of the cone rotation of the principal axes, deg (0: none).
    """

    instance: str
    relative: float
    axis_rotation_deg: float = 0.0

    def draw(self, rng: np.random.Generator, nominal: Nominal | None, where: str) -> dict[str, float]:
        """The inertia parameters of one sample, kg m^2.

        Parameters
        ----------
        rng : numpy.random.Generator
            The sample's generator (:meth:`Dispersions.sample`).
        nominal : callable or None
            (instance or ``"profiles[i]"``, name) -> nominal value or None (:data:`Nominal`);
            gives the plant's nominal ``I_x, I_y, I_z`` and products; None raises.
        where : str
            Key path of the entry, named in errors.

        Returns
        -------
        dict of str to float
            ``I_x, I_y, I_z`` and, when the plant has them, ``I_xy, I_xz, I_yz`` (kg m^2).

        Raises
        ------
        DispersionError
            Without ``nominal`` or the plant's moments, or when no draw of :data:`MAX_REDRAWS` is a
            rigid body.
        """
        if nominal is None:
            raise DispersionError(f"{where}: needs the nominal inertia of {self.instance} (no FMU given)")
        values = {k: nominal(self.instance, k) for k in INERTIA_PARAMETERS}
        if any(values[k] is None for k in ("I_x", "I_y", "I_z")):
            raise DispersionError(f"{where}: {self.instance} has no parameters I_x, I_y, I_z")
        products = all(values[k] is not None for k in ("I_xy", "I_xz", "I_yz"))
        if self.axis_rotation_deg > 0 and not products:
            raise DispersionError(f"{where}.axis_rotation_deg: {self.instance} has principal moments only "
                                  "(no I_xy, I_xz, I_yz): its axes cannot turn")
        J0 = np.zeros((3, 3))
        for k, (i, j) in INERTIA_PARAMETERS.items():
            J0[i, j] = J0[j, i] = values[k] or 0.0
        moments, axes = np.linalg.eigh(J0)
        for _ in range(MAX_REDRAWS):
            m = moments * rng.uniform(1 - self.relative, 1 + self.relative, 3)
            R = axes if self.axis_rotation_deg == 0 else cone_rotation(rng, self.axis_rotation_deg).as_matrix() @ axes
            try:
                sc = Spacecraft("dispersed", R @ np.diag(m) @ R.T)
            except SpacecraftError:
                continue
            names = list(INERTIA_PARAMETERS) if products else ["I_x", "I_y", "I_z"]
            return {k: sc.inertia[INERTIA_PARAMETERS[k][0]][INERTIA_PARAMETERS[k][1]] for k in names}
        raise DispersionError(f"{where}: no rigid body in {MAX_REDRAWS} draws (relative = {self.relative:g} "
                              f"about principal moments {moments.tolist()} kg m^2)")


def cone_rotation(rng: np.random.Generator, half_angle_deg: float) -> Rotation:
    """A rotation about a uniformly random axis by an angle theta with ``cos theta`` uniform
    on ``[cos half_angle, 1]`` (theta <= ``half_angle_deg``, deg).

    Parameters
    ----------
    rng : numpy.random.Generator
        The generator to draw from (the axis, then the angle).
    half_angle_deg : float
        Largest rotation angle, deg.

    Returns
    -------
    scipy.spatial.transform.Rotation
    """
    from scipy.spatial.transform import Rotation

    axis = rng.normal(size=3)
    theta = math.acos(rng.uniform(math.cos(math.radians(half_angle_deg)), 1.0))
    return Rotation.from_rotvec(theta * axis / np.linalg.norm(axis))


@dataclass(frozen=True)
class Dispersions:
    """A scenario's ``[dispersions]`` table: what each Monte Carlo sample draws, in order.

    Build one with :meth:`from_dict` (the syntax: the module docstring).

    Parameters
    ----------
    entries : tuple
        :class:`Distribution`, :class:`Attitude` and :class:`Inertia` entries, in declared order.
    data : dict
        The declaration as given (the TOML table).
    """

    entries: tuple[Distribution | Attitude | Inertia, ...]
    data: dict[str, Any] = field(default_factory=dict, compare=False)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], where: str = "dispersions",
                  instances: list[str] | None = None, n_profiles: int | None = None) -> "Dispersions":
        """Validate a ``[dispersions]`` table.

        Parameters
        ----------
        data : dict
            Key -> declaration table.
        where : str
            Key path of the table in messages.
        instances : list of str, optional
            The scenario's FMU instances (targets must name one).
        n_profiles : int, optional
            How many profiles the scenario has (``profiles[i]`` must exist).

        Raises
        ------
        DispersionError
            Naming the key path (``where."plant.I_x".std: ...``).
        """
        if not isinstance(data, Mapping):
            raise DispersionError(f"{where}: must be a table of dispersions, got {type(data).__name__}")
        entries: list[Distribution | Attitude | Inertia] = []
        for key, spec in data.items():
            wk = f"{where}.{key}" if key in ("attitude", "inertia") else f'{where}."{key}"'
            if not isinstance(spec, Mapping):
                raise DispersionError(f"{wk}: must be a table with a 'kind', got {spec!r}")
            if key == "attitude":
                entries.append(_attitude(spec, wk, instances))
            elif key == "inertia":
                entries.append(_inertia(spec, wk, instances))
            else:
                entries.append(_distribution(key, spec, wk, instances, n_profiles))
        targets = [k for e in entries for k in _targets(e)]
        for t in targets:
            if targets.count(t) > 1:
                raise DispersionError(f"{where}: {t} is dispersed twice (by two entries)")
        return cls(tuple(entries), dict(data))

    def sample(self, seed: int, index: int, nominal: Nominal | None = None, where: str = "dispersions"
               ) -> Overrides:
        """The values of sample ``index`` of campaign ``seed``.

        Parameters
        ----------
        seed : int
            Campaign seed (>= 0).
        index : int
            Sample index (>= 0).
        nominal : callable, optional
            (instance or ``"profiles[i]"``, name) -> nominal value or None if there is no such
            parameter; needed by a ``normal`` without ``mean``, a cone, an inertia and an
            attitude without a parameter base (:func:`satfmu.sims.scenario.provisioning.nominal_values`).
        where : str, optional
            Key path of the table, named in errors.

        Returns
        -------
        dict
            Instance (or ``"profiles[i]"``) -> parameter (or field) -> value.

        Raises
        ------
        DispersionError
        """
        for name, v in (("seed", seed), ("index", index)):
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 0:
                raise DispersionError(f"{where}: {name} must be a non-negative integer, got {v!r}")
        rng = np.random.default_rng(np.random.SeedSequence(int(seed), spawn_key=(int(index),)))
        out: Overrides = {}
        for key, e in zip(self.data, self.entries):
            wk = f"{where}.{key}"
            if isinstance(e, Distribution):
                out.setdefault(e.owner, {})[e.name] = e.draw(rng, nominal, wk)
            else:
                out.setdefault(e.instance, {}).update(e.draw(rng, nominal, wk))
        return out

    def attitudes(self, columns: Sequence[str]) -> list[tuple[str, list[str], str]]:
        """The dispersed attitudes among a campaign's value columns.

        Parameters
        ----------
        columns : sequence of str
            ``instance.parameter`` columns (a campaign's dispersed values).

        Returns
        -------
        list of (str, list of str, str)
            Per :class:`Attitude` entry: its instance, its component columns in order, and
            ``"mrp"`` or ``"quaternion"`` (scalar last).
        """
        out = []
        for e in self.entries:
            if not isinstance(e, Attitude):
                continue
            bases = [(e.mrp, 3, "mrp")] if e.mrp else [(e.quaternion, 4, "quaternion")] if e.quaternion else \
                [("sigma_0", 3, "mrp"), ("q_0", 4, "quaternion")]
            for base, n, kind in bases:
                cols = [f"{e.instance}.{base}[{i}]" for i in range(1, n + 1)]
                if all(c in columns for c in cols):
                    out.append((e.instance, cols, kind))
                    break
        return out

    def parameter_targets(self) -> list[tuple[str, str, str]]:
        """(key, instance, parameter) of every FMU parameter a sample may write (the
        attitude's only when its base is named)."""
        out = []
        for key, e in zip(self.data, self.entries):
            if isinstance(e, Distribution) and not e.owner.startswith("profiles["):
                out.append((key, e.owner, e.name))
            elif isinstance(e, Inertia):
                out += [(key, e.instance, k) for k in ("I_x", "I_y", "I_z")]
            elif isinstance(e, Attitude) and (e.mrp or e.quaternion):
                base, n = (e.mrp, 3) if e.mrp else (e.quaternion, 4)
                out += [(key, e.instance, f"{base}[{i}]") for i in range(1, n + 1)]
        return out


def _targets(e: Distribution | Attitude | Inertia) -> list[str]:
    """The ``instance.parameter`` names ``e`` may write (two entries must not share one)."""
    if isinstance(e, Distribution):
        return [e.target]
    if isinstance(e, Inertia):
        return [f"{e.instance}.{k}" for k in INERTIA_PARAMETERS]
    bases = [(e.mrp, 3)] if e.mrp else [(e.quaternion, 4)] if e.quaternion else [("sigma_0", 3), ("q_0", 4)]
    return [f"{e.instance}.{b}[{i}]" for b, n in bases for i in range(1, n + 1)]


def _instance(spec: Mapping[str, Any], where: str, instances: list[str] | None) -> str:
    inst = spec.get("instance")
    if not isinstance(inst, str):
        raise DispersionError(f"{where}.instance: must name the plant instance, got {inst!r}")
    if instances is not None and inst not in instances:
        raise DispersionError(f"{where}.instance: no FMU instance {inst!r} (instances: {', '.join(instances)})"
                              f"{did_you_mean(inst, instances)}")
    return inst


def _attitude(spec: Mapping[str, Any], where: str, instances: list[str] | None) -> Attitude:
    check_keys(spec, _ATTITUDE, where, DispersionError)
    inst = _instance(spec, where, instances)
    kind = spec.get("kind")
    if kind not in ATTITUDE_KINDS:
        raise DispersionError(f"{where}.kind: must be one of {ATTITUDE_KINDS}, got {kind!r}"
                              f"{did_you_mean(str(kind), ATTITUDE_KINDS)}")
    half = None
    if kind == "cone":
        if "half_angle_deg" not in spec:
            raise DispersionError(f"{where}: kind cone needs 'half_angle_deg'")
        half = _number(spec["half_angle_deg"], f"{where}.half_angle_deg")
        if not 0 < half <= 180:
            raise DispersionError(f"{where}.half_angle_deg: must be in (0, 180] deg, got {half:g}")
    elif "half_angle_deg" in spec:
        raise DispersionError(f"{where}.half_angle_deg: only for kind cone")
    if "mrp" in spec and "quaternion" in spec:
        raise DispersionError(f"{where}: give at most one of 'mrp' and 'quaternion'")
    for key in ("mrp", "quaternion"):
        if key in spec and (not isinstance(spec[key], str) or not spec[key]):
            raise DispersionError(f"{where}.{key}: must be a parameter base name, got {spec[key]!r}")
    return Attitude(inst, kind, half, spec.get("mrp"), spec.get("quaternion"))


def _inertia(spec: Mapping[str, Any], where: str, instances: list[str] | None) -> Inertia:
    check_keys(spec, _INERTIA, where, DispersionError)
    inst = _instance(spec, where, instances)
    if "relative" not in spec:
        raise DispersionError(f"{where}: missing key 'relative'")
    rel = _number(spec["relative"], f"{where}.relative")
    if not 0 < rel < 1:
        raise DispersionError(f"{where}.relative: must be in (0, 1), got {rel:g}")
    rot = _number(spec.get("axis_rotation_deg", 0.0), f"{where}.axis_rotation_deg")
    if not 0 <= rot <= 180:
        raise DispersionError(f"{where}.axis_rotation_deg: must be in [0, 180] deg, got {rot:g}")
    return Inertia(inst, rel, rot)


def _distribution(key: str, spec: Mapping[str, Any], where: str, instances: list[str] | None,
                  n_profiles: int | None) -> Distribution:
    m = _PROFILE.fullmatch(key)
    if m:
        if n_profiles is not None and int(m[1]) >= n_profiles:
            raise DispersionError(f"{where}: the scenario has {n_profiles} profile(s), no profiles[{m[1]}]")
    elif "." not in key or key.startswith("profiles"):
        raise DispersionError(f"{where}: must be 'instance.parameter', 'profiles[i].field', 'attitude' or "
                              f"'inertia'{did_you_mean(key, ['attitude', 'inertia'])}")
    elif instances is not None and key.split(".", 1)[0] not in instances:
        inst = key.split(".", 1)[0]
        raise DispersionError(f"{where}: no FMU instance {inst!r} (instances: {', '.join(instances)})"
                              f"{did_you_mean(inst, instances)}")
    kind = spec.get("kind")
    if kind not in KINDS:
        raise DispersionError(f"{where}.kind: must be one of {', '.join(KINDS)}, got {kind!r}"
                              f"{did_you_mean(str(kind), KINDS)}")
    numeric = kind not in ("choice", "seed")
    check_keys(spec, ("kind", *KINDS[kind], *(("transform",) if numeric else ())), where, DispersionError)
    fields = {k: v for k, v in spec.items() if k not in ("kind", "transform")}
    transform = spec.get("transform")
    if transform is not None and transform not in TRANSFORMS:
        raise DispersionError(f"{where}.transform: must be one of {', '.join(TRANSFORMS)}, got {transform!r}")
    if transform is not None and "mean" in KINDS[kind] and "mean" not in fields:
        raise DispersionError(f"{where}.mean: must be given with a transform (the nominal value is not the "
                              "transformed draw's mean)")
    if kind == "choice":
        values, weights = fields.get("values"), fields.get("weights")
        if not isinstance(values, list) or not values:
            raise DispersionError(f"{where}.values: must be a non-empty list, got {values!r}")
        if weights is not None:
            if not isinstance(weights, list) or len(weights) != len(values):
                raise DispersionError(f"{where}.weights: must be a list of {len(values)} numbers, got {weights!r}")
            w = [_number(x, f"{where}.weights[{i}]") for i, x in enumerate(weights)]
            if min(w) < 0 or sum(w) <= 0:
                raise DispersionError(f"{where}.weights: must be >= 0 with a positive sum, got {weights!r}")
        return Distribution(key, kind, fields)
    needed = [k for k in KINDS[kind] if k != "mean"]
    for k in needed:
        if k not in fields:
            raise DispersionError(f"{where}: kind {kind} needs {k!r}")
    fields = {k: _number(v, f"{where}.{k}") for k, v in fields.items()}
    if "std" in fields and fields["std"] <= 0:
        raise DispersionError(f"{where}.std: must be > 0, got {fields['std']:g}")
    if "low" in fields and fields["low"] >= fields["high"]:
        raise DispersionError(f"{where}: low {fields['low']:g} must be < high {fields['high']:g}")
    if kind == "log_uniform" and fields["low"] <= 0:
        raise DispersionError(f"{where}.low: must be > 0 for log_uniform, got {fields['low']:g}")
    return Distribution(key, kind, {**fields, **({"transform": transform} if transform else {})})
