"""A scenario's declaration: a co-simulation declared in TOML, as data classes.

A scenario file names its FMUs (by built model name or path), their parameters,
the connections, the disturbance profiles, what to record and plot, and metrics
with pass/fail bounds. Example (sims/scenario/shipped/mrp_200deg.toml)::

    name = "mrp_200deg"
    stop_time = 120.0            # s
    step_size = 0.05             # communication step, s
    record = ["plant.omega", "plant.sigma", "controller.u"]

    [fmus.plant]
    model = "mrp_satellite"
    parameters = { "sigma_0[1]" = 0.5992, "sigma_0[2]" = -0.7976, "sigma_0[3]" = 0.6517 }

    [fmus.controller]
    model = "mrp_hinf_published"

    [[connections]]
    from = "plant.omega"
    to = "controller.omega"

    [[profiles]]
    to = "plant.w_d[1]"
    kind = "step"
    time = 5.0
    before = 2.0
    after = 0.0

    [[metrics]]
    name = "angle error at the end"
    kind = "final"               # final, peak, rms, settling_time, l2_ratio, time_in_saturation,
                                 # time_to_limit, integral_square, max_difference, attitude_difference
    signals = ["plant.phi"]
    unit = "deg"                 # converted from the declared rad
    max = 0.1

Metric fields: ``signals``, ``unit`` (the signals are converted to it from their FMU's
declared unit, :mod:`satfmu.sims.scenario.conversions`; bounds, ``tolerance`` and ``limit`` are
in it; the value's own unit follows from the kind: s for the times, the unit squared times s
for ``integral_square``), ``scale`` (a further factor, e.g. a weight; it may not convert units
as well), ``min``/``max`` bounds; ``tolerance`` for settling_time,
``limit`` for time_in_saturation and time_to_limit (the first time any signal reaches it, inf if
none does), ``disturbances`` (the denominator signals) for
l2_ratio, whose value is the largest ratio over T and whose curve is plotted, ``versus``
for max_difference (the largest ``|signal - versus|`` over time, signal by signal: an
approximated law against the exact one, say) and attitude_difference (the largest rotation
angle between the MRP ``signals`` and the MRP ``versus``, 3 variables each, rad converted to
``unit``: an estimator's knowledge error).
integral_square is ``integral of sum_i y_i^2 dt`` (an H2 cost with unit weights): plant
outputs by the trapezoidal rule, FMU inputs (held over each step, e.g. ``plant.u``) by the
left rectangle.

A ``record`` entry may ask for a unit too: ``record = [{ signal = "plant.phi", unit = "deg" },
"plant.omega"]`` (the CSV, the plots and a campaign's envelopes show it in deg). An input of a
controller, a sensor or an estimator that nothing drives is an error naming it, unless the
scenario says ``unconnected = "zero"`` (:func:`satfmu.sims.scenario.wiring.undriven`).

A ``[dispersions]`` table declares what each Monte Carlo sample draws (syntax:
:mod:`satfmu.sims.scenario.dispersions`); :meth:`Scenario.sample` is the scenario of one sample. A
``[campaign]`` table gives the campaign's default size and seed (what ``satfmu campaign
scenario`` runs without ``--samples`` or ``--seed``)::

    [campaign]
    samples = 1000       # the full campaign
    demo_samples = 50    # a quick look (``--demo``), at most ``samples``
    seed = 0             # the campaign seed (sample i depends on (seed, i) only)

The declaration is checked by :mod:`satfmu.sims.scenario.validation`, its FMU files are found
and built by :mod:`satfmu.sims.scenario.provisioning`, the master is wired by
:mod:`satfmu.sims.scenario.wiring`, a run is made and judged by :mod:`satfmu.sims.scenario.run`
into a :class:`~satfmu.sims.scenario.result.Result`.
"""
from __future__ import annotations

import copy
import re
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import Any, Callable, Mapping

from satfmu.fmus.declared import did_you_mean, read_toml
from satfmu.fmus.errors import ScenarioError
from satfmu.sims.scenario import SHIPPED_SCENARIOS
from satfmu.sims.scenario.dispersions import DispersionError, Dispersions, Overrides
from satfmu.sims.scenario.validation import _check_start_value, _dispersions, validate


@dataclass
class FmuSpec:
    """One FMU instance of a scenario: a built model by name, or an FMU file.

    Parameters
    ----------
    model : str, optional
        Model or controller-artifact name (``"mrp_satellite"``, ``"mrp_hinf_published"``);
        the FMU comes from the FMU folder (built on demand).
    path : str, optional
        An FMU file, relative to the scenario's folder (exactly one of ``model``, ``path``).
    backend : {"native", "python"}, optional
        This instance's backend (default: the run's).
    parameters : dict
        Start values, by variable name (Real: float, Integer: int, Boolean: bool).
    """

    model: str | None = None
    path: str | None = None
    backend: str | None = None
    parameters: dict[str, Any] = field(default_factory=dict)


@dataclass
class Connection:
    """An output of one FMU instance feeding an input of another.

    Parameters
    ----------
    source : str
        ``"instance.variable"`` output (TOML key ``from``); a base name such as
        ``plant.omega`` connects index by index.
    target : str
        ``"instance.variable"`` input (TOML key ``to``).
    """

    source: str
    target: str


@dataclass
class Metric:
    """A pass/fail figure of a run (the kinds and their fields: the module docstring).

    Parameters
    ----------
    name : str
        Label (unique within the scenario).
    kind : str
        One of ``final``, ``peak``, ``rms``, ``settling_time``, ``l2_ratio``,
        ``time_in_saturation``, ``time_to_limit``, ``integral_square``, ``max_difference``.
    signals : list of str
        ``"instance.variable"`` names (base names expand).
    scale : float
        A further factor applied to the signals (a weight); it may not convert units as well
        (give ``unit``).
    unit : str
        The unit the signals are converted to from their declared one (``"deg"`` for an angle
        in rad); bounds, ``tolerance`` and ``limit`` are in it. Default: the declared unit.
    min, max : float, optional
        Pass/fail bounds.
    tolerance : float, optional
        Band of ``settling_time``.
    limit : float, optional
        Saturation level of ``time_in_saturation``; the level of ``time_to_limit``.
    disturbances : list of str
        Denominator signals of ``l2_ratio``.
    versus : list of str
        Reference signals of ``max_difference``.
    description : str
        Free text.
    """

    name: str
    kind: str
    signals: list[str]
    scale: float = 1.0
    unit: str = ""
    min: float | None = None
    max: float | None = None
    tolerance: float | None = None
    limit: float | None = None
    disturbances: list[str] = field(default_factory=list)
    versus: list[str] = field(default_factory=list)
    description: str = ""

    @property
    def value_unit(self) -> str:
        """The unit of the metric's value as its declaration gives it (s for a time, a margin's
        own, ``N2.m2.s`` for an integral of squared torques); empty when it is the signals'
        declared unit, which only the FMU tells (a run's result has it)."""
        from satfmu.sims.scenario.metrics import value_unit

        return value_unit(self.kind, self.unit)


@dataclass
class Scenario:
    """A validated co-simulation declaration: FMUs, connections, profiles, records, metrics.

    Build one with :meth:`from_toml`, :meth:`from_dict` or directly; every construction is
    validated (:class:`ScenarioError` names the key path and suggests near misses).
    Variable names are checked against the FMUs when it runs.

    Parameters
    ----------
    name : str
        Identifier (the output folder's name).
    stop_time, step_size : float
        Stop time and communication step, s.
    fmus : dict of str to FmuSpec
        Instance name -> FMU.
    connections : list of Connection
    profiles : list of dict
        Signals of time fed to inputs: ``{"to": "plant.w_d[1]", "kind": "step", ...}``
        (kinds of :mod:`satfmu.fmus.profiles`).
    record : list of str or dict
        Variables to record (``"instance.variable"``, base names expand); an entry
        ``{"signal": "plant.phi", "unit": "deg"}`` asks for a unit, converted from the declared
        one (it goes to ``units``; ``record`` keeps the name).
    metrics : list of Metric
    start_time : float
        s.
    description, reference : str
        What the run shows and where its expected figures come from.
    plot : dict
        ``{"panels": [[signals of panel 1], ...]}`` (default: one panel per record entry).
    verify : dict
        ``{"rtol": ..., "atol": ..., "reason": ...}`` for the cross-engine comparison.
    base_dir : Path, optional
        Folder that relative FMU and CSV paths resolve against (a TOML file's folder).
    path : Path, optional
        The TOML file it was read from.
    dispersions : Dispersions or dict, optional
        What each Monte Carlo sample draws (the ``[dispersions]`` table, :mod:`satfmu.sims.scenario.dispersions`);
        :meth:`sample` gives the scenario of one sample.
    campaign : dict
        The ``[campaign]`` table: default ``samples``, ``demo_samples`` and ``seed`` of the
        scenario's Monte Carlo campaign (:data:`satfmu.sims.scenario.validation.CAMPAIGN_KEYS`); needs ``dispersions``.
    record_every : int
        Record every ``record_every``-th communication point, from the first, and the last one
        (:func:`satfmu.sims.scenario.wiring.recorded_times`); the metrics are computed on the recorded
        points. A long run keeps 8 bytes per recorded variable and recorded point.
    unconnected : {"error", "zero"}
        What an input meant to be driven (a controller's or a sensor's measurement, an input
        without a start value; :func:`satfmu.sims.scenario.wiring.undriven`) that nothing drives
        does: ``"error"`` (default) refuses the scenario naming the inputs, ``"zero"`` runs with
        their start values (an open-loop check, say).
    units : dict of str to str
        Recorded signal -> the unit it is shown in (CSV, plots, envelopes), from the ``record``
        entries that ask for one (:mod:`satfmu.sims.scenario.conversions`).
    """

    name: str
    stop_time: float
    step_size: float
    fmus: dict[str, FmuSpec]
    connections: list[Connection] = field(default_factory=list)
    profiles: list[dict[str, Any]] = field(default_factory=list)
    record: list[str] = field(default_factory=list)
    metrics: list[Metric] = field(default_factory=list)
    start_time: float = 0.0
    description: str = ""
    reference: str = ""
    plot: dict[str, Any] = field(default_factory=dict)
    verify: dict[str, Any] = field(default_factory=dict)
    base_dir: Path | None = None
    path: Path | None = None
    dispersions: Dispersions | None = None
    campaign: dict[str, int] = field(default_factory=dict)
    record_every: int = 1
    unconnected: str = "error"
    units: dict[str, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if any(isinstance(r, Mapping) for r in self.record):
            validate({**self.to_dict(), "record": list(self.record)},
                     str(self.path) if self.path else f"scenario {self.name!r}")
            self.units = {**self.units, **{r["signal"]: r["unit"] for r in self.record if isinstance(r, Mapping)}}
            self.record = [r["signal"] if isinstance(r, Mapping) else r for r in self.record]
        if isinstance(self.dispersions, Mapping):
            self.dispersions = _dispersions(self.dispersions, "scenario: dispersions", list(self.fmus),
                                            len(self.profiles))
        self.fmus = {k: v if isinstance(v, FmuSpec) else FmuSpec(**v) for k, v in self.fmus.items()}
        self.connections = [c if isinstance(c, Connection) else Connection(*c) for c in self.connections]
        self.metrics = [m if isinstance(m, Metric) else Metric(**m) for m in self.metrics]
        validate(self.to_dict(), str(self.path) if self.path else f"scenario {self.name!r}")

    @property
    def data(self) -> dict[str, Any]:
        """The declaration as plain data (the TOML file's keys)."""
        return self.to_dict()

    @property
    def folder(self) -> Path:
        """Folder that relative paths resolve against (``base_dir``, the file's, or the working one)."""
        if self.base_dir is not None:
            return Path(self.base_dir)
        return self.path.parent if self.path is not None else Path.cwd()

    def to_dict(self) -> dict[str, Any]:
        """The declaration as plain data with the TOML file's keys (defaults left out)."""
        out: dict[str, Any] = {"name": self.name, "stop_time": self.stop_time, "step_size": self.step_size}
        for key in ("start_time", "description", "reference", "plot", "verify", "record", "profiles"):
            value = getattr(self, key)
            if value not in (0.0, "", {}, []):
                out[key] = value
        if self.units:
            out["record"] = [{"signal": r, "unit": self.units[r]} if r in self.units else r for r in self.record]
        out["fmus"] = {k: {f: v for f, v in _fields(spec).items() if v not in (None, {})}
                       for k, spec in self.fmus.items()}
        if self.connections:
            out["connections"] = [{"from": c.source, "to": c.target} for c in self.connections]
        if self.metrics:
            defaults = _fields(Metric("", "", []))
            out["metrics"] = [{k: v for k, v in _fields(m).items()
                               if k in ("name", "kind", "signals") or v != defaults[k]}
                              for m in self.metrics]
        if self.dispersions is not None:
            out["dispersions"] = dict(self.dispersions.data)
        if self.campaign:
            out["campaign"] = dict(self.campaign)
        if self.record_every != 1:
            out["record_every"] = self.record_every
        if self.unconnected != "error":
            out["unconnected"] = self.unconnected
        return out

    def with_parameters(self, overrides: Overrides) -> "Scenario":
        """This scenario with start values and profile fields replaced, and no dispersions.

        Parameters
        ----------
        overrides : dict
            Instance -> parameter -> start value, and ``"profiles[i]"`` -> field -> value
            (what :meth:`Dispersions.sample` returns).

        Raises
        ------
        ScenarioError
            An unknown instance or profile, or a value the declaration refuses.
        """
        where = str(self.path) if self.path else f"scenario {self.name!r}"
        fmus = {k: replace(v, parameters=dict(v.parameters)) for k, v in self.fmus.items()}
        profs = [dict(p) for p in self.profiles]
        for owner, values in overrides.items():
            m = re.fullmatch(r"profiles\[(\d+)\]", owner)
            if m and int(m[1]) < len(profs):
                profs[int(m[1])].update(values)
            elif owner in fmus:
                fmus[owner].parameters.update(values)
            else:
                raise ScenarioError(f"{where}: overrides: no FMU instance or profile {owner!r}"
                                    f"{did_you_mean(owner, list(fmus))}")
        if all(owner in fmus for owner in overrides):  # start values only: the rest was validated
            for owner, values in overrides.items():
                for name, value in values.items():
                    _check_start_value(value, f"{where}: fmus.{owner}.parameters.{name}")
            out = copy.copy(self)
            out.fmus, out.profiles, out.dispersions, out.campaign = fmus, profs, None, {}
            return out
        return replace(self, fmus=fmus, profiles=profs, dispersions=None, campaign={})

    def sample(self, seed: int, index: int, fmu_dir: str | Path | None = None, backend: str = "native",
               nominal: Callable[[str, str], float | None] | None = None) -> "Scenario":
        """The dispersed scenario of sample ``index`` of campaign ``seed``
        (:meth:`Dispersions.sample` with the nominal values of
        :func:`satfmu.sims.scenario.provisioning.nominal_values`).

        Parameters
        ----------
        seed : int
            Campaign seed (>= 0).
        index : int
            Sample index (>= 0).
        fmu_dir : path, optional
            FMU folder the nominal start values are read from (default: the FMU cache), read
            only if a dispersion needs a value the scenario does not set.
        backend : {"native", "python"}
            Backend of those FMUs.
        nominal : callable, optional
            The nominal values (default :func:`satfmu.sims.scenario.provisioning.nominal_values` of this
            scenario, ``fmu_dir`` and ``backend``; a campaign's worker passes one for all its samples).

        Returns
        -------
        Scenario
            With the sample's start values and profile fields, and no dispersions.

        Raises
        ------
        ScenarioError
            No dispersions, or a dispersion that cannot be drawn (key path named).
        """
        from satfmu.sims.scenario.provisioning import nominal_values  # it reads the FMUs: above this module

        where = str(self.path) if self.path else f"scenario {self.name!r}"
        if self.dispersions is None:
            raise ScenarioError(f"{where}: no [dispersions] to sample")
        try:
            values = self.dispersions.sample(seed, index, nominal or nominal_values(self, fmu_dir, backend),
                                             f"{where}: dispersions")
        except DispersionError as exc:
            raise ScenarioError(str(exc)) from None
        return self.with_parameters(values)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], base_dir: str | Path | None = None, where: str = "scenario",
                  path: Path | None = None) -> "Scenario":
        """A scenario from plain data with the TOML file's keys.

        Parameters
        ----------
        data : mapping
            The declaration (the keys of the module docstring's example).
        base_dir : path, optional
            Folder that relative FMU and CSV paths resolve against (default: the working folder).
        where : str
            Where the data comes from, the first part of every error's key path.
        path : Path, optional
            The TOML file it was read from.

        Returns
        -------
        Scenario

        Raises
        ------
        ScenarioError
            Naming the key path, e.g. ``"scenario: connections[2].from: ..."``.
        """
        validate(data, where)
        d = dict(data)
        return cls(
            name=d["name"], stop_time=float(d["stop_time"]), step_size=float(d["step_size"]),
            fmus={k: FmuSpec(**v) for k, v in d["fmus"].items()},
            connections=[Connection(c["from"], c["to"]) for c in d.get("connections", [])],
            profiles=[dict(p) for p in d.get("profiles", [])], record=list(d.get("record", [])),
            metrics=[Metric(**m) for m in d.get("metrics", [])], start_time=float(d.get("start_time", 0.0)),
            description=d.get("description", ""), reference=d.get("reference", ""), plot=dict(d.get("plot", {})),
            verify=dict(d.get("verify", {})), base_dir=None if base_dir is None else Path(base_dir).resolve(),
            path=path, dispersions=_dispersions(d["dispersions"], f"{where}: dispersions", list(d["fmus"]),
                                                len(d.get("profiles", []))) if "dispersions" in d else None,
            campaign=dict(d.get("campaign", {})), record_every=d.get("record_every", 1),
            unconnected=d.get("unconnected", "error"))

    @classmethod
    def from_toml(cls, path: str | Path) -> "Scenario":
        """Read a scenario file (relative paths in it resolve against its folder).

        Parameters
        ----------
        path : path
            The TOML file.

        Returns
        -------
        Scenario

        Raises
        ------
        ScenarioError
            If the file is missing, not TOML, or its declaration is invalid.
        """
        path = Path(path).resolve()
        return cls.from_dict(read_toml(path, "scenario", ScenarioError), path.parent, str(path), path)


def _fields(obj: Any) -> dict[str, Any]:
    """A dataclass's fields, one level deep (``dataclasses.asdict`` copies recursively: ten times the
    cost, for the plain data these hold)."""
    return {f.name: (lambda v: v.copy() if isinstance(v, (dict, list)) else v)(getattr(obj, f.name))
            for f in fields(obj)}


def resolve_path(name_or_path: str | Path) -> Path:
    """A scenario file path, or the shipped scenario of that name.

    Parameters
    ----------
    name_or_path : str or Path
        A path ending in ``.toml``, or a shipped scenario's name (``"mrp_200deg"``).

    Raises
    ------
    ScenarioError
        If neither exists (with the shipped names and the closest one).
    """
    p = Path(name_or_path)
    if p.suffix == ".toml":
        if p.is_file():
            return p.resolve()
        raise ScenarioError(f"no scenario file {str(p)!r} (resolved to {p.resolve()})")
    shipped = SHIPPED_SCENARIOS / f"{name_or_path}.toml"
    if shipped.is_file():
        return shipped
    names = sorted(s.stem for s in SHIPPED_SCENARIOS.glob("*.toml"))
    raise ScenarioError(f"no scenario named {str(name_or_path)!r} (shipped scenarios: {', '.join(names)})"
                        f"{did_you_mean(str(name_or_path), names)}")


def load(scenario: "str | Path | Mapping[str, Any] | Scenario") -> Scenario:
    """A :class:`Scenario` from a shipped name, a TOML path, plain data, or itself.

    Parameters
    ----------
    scenario : Scenario, dict, str or Path
        A scenario (returned as it is), its plain data, a TOML file or a shipped scenario's name.

    Raises
    ------
    ScenarioError
    """
    if isinstance(scenario, Scenario):
        return scenario
    if isinstance(scenario, Mapping):
        return Scenario.from_dict(scenario)
    return Scenario.from_toml(resolve_path(scenario))
