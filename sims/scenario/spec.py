"""Scenarios: a co-simulation declared in TOML, run by the master, judged by metrics.

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
                                 # integral_square, max_difference
    signals = ["plant.phi"]
    scale = 57.29577951308232    # rad -> deg
    unit = "deg"
    max = 0.1

Metric fields: ``signals``, ``scale`` (applied to signals, tolerance and limit are in
scaled units), ``unit``, ``min``/``max`` bounds; ``tolerance`` for settling_time,
``limit`` for time_in_saturation, ``disturbances`` (the denominator signals) for
l2_ratio, whose value is the largest ratio over T and whose curve is plotted, ``versus``
for max_difference (the largest ``|signal - versus|`` over time, signal by signal: an
approximated law against the exact one, say).
integral_square is ``integral of sum_i y_i^2 dt`` (an H2 cost with unit weights): plant
outputs by the trapezoidal rule, FMU inputs (held over each step, e.g. ``plant.u``) by the
left rectangle.

A ``[dispersions]`` table declares what each Monte Carlo sample draws (syntax:
:mod:`satfmu.sims.scenario.dispersions`); :meth:`Scenario.sample` is the scenario of one sample. A
``[campaign]`` table gives the campaign's default size and seed (what ``satfmu campaign
scenario`` runs without ``--samples`` or ``--seed``)::

    [campaign]
    samples = 1000       # the full campaign
    demo_samples = 50    # a quick look (``--demo``), at most ``samples``
    seed = 0             # the campaign seed (sample i depends on (seed, i) only)
"""
from __future__ import annotations

import copy
import csv
import json
import math
import re
import warnings
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import Any, Callable, Mapping

import numpy as np

from satfmu.fmus.atomic import write_atomically
from satfmu.fmus.declared import check_keys, check_safe_name, did_you_mean, read_toml
from satfmu.fmus.profiles import Profile
from satfmu.fmus.profiles import make as make_profile
from satfmu.sims.scenario import metrics as M
from satfmu.sims.cosim import preflight
from satfmu.sims.scenario.dispersions import DispersionError, Dispersions, Overrides
from satfmu.sims.cosim.master import (CoSimulation, UnknownVariableError, WiringError, communication_times,
                                      recorded_steps,
                         start_value)
from satfmu.controllers.paths import BACKENDS
from satfmu.sims.scenario import SHIPPED_SCENARIOS
from satfmu.fmus.errors import DesignMismatchWarning, ScenarioError, StaleFmuWarning

_TOP = ("name", "description", "stop_time", "step_size", "start_time", "fmus", "connections",
        "profiles", "record", "metrics", "plot", "reference", "verify", "dispersions", "campaign", "record_every")
_FMU = ("model", "path", "backend", "parameters")
_METRIC = ("name", "kind", "signals", "scale", "unit", "min", "max", "tolerance", "limit",
           "disturbances", "versus", "description")

MAX_STEPS = 10_000_000
"""Most recorded communication points of one run (a typo'd stop time fails here, not in a
MemoryError)."""
CAMPAIGN_KEYS = {"samples": 1, "demo_samples": 1, "seed": 0}
"""Keys of a scenario's ``[campaign]`` table -> the least integer each takes."""
_NEEDS = {"settling_time": "tolerance", "time_in_saturation": "limit", "l2_ratio": "disturbances",
          "max_difference": "versus"}


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
        ``time_in_saturation``, ``integral_square``, ``max_difference``.
    signals : list of str
        ``"instance.variable"`` names (base names expand).
    scale : float
        Factor applied to the signals (rad -> deg: 57.2958); bounds, ``tolerance`` and
        ``limit`` are in scaled units.
    unit : str
        Unit of the scaled value.
    min, max : float, optional
        Pass/fail bounds.
    tolerance : float, optional
        Band of ``settling_time``.
    limit : float, optional
        Saturation level of ``time_in_saturation``.
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
    record : list of str
        Variables to record (``"instance.variable"``, base names expand).
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
        scenario's Monte Carlo campaign (:data:`CAMPAIGN_KEYS`); needs ``dispersions``.
    record_every : int
        Record every ``record_every``-th communication point, from the first, and the last one
        (:func:`recorded_times`); the metrics are computed on the recorded points. A long run
        keeps 8 bytes per recorded variable and recorded point.
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

    def __post_init__(self) -> None:
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
        (:meth:`Dispersions.sample` with the nominal values of :func:`nominal_values`).

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
            The nominal values (default :func:`nominal_values` of this scenario, ``fmu_dir`` and
            ``backend``; a campaign's worker passes one for all its samples).

        Returns
        -------
        Scenario
            With the sample's start values and profile fields, and no dispersions.

        Raises
        ------
        ScenarioError
            No dispersions, or a dispersion that cannot be drawn (key path named).
        """
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
            campaign=dict(d.get("campaign", {})), record_every=d.get("record_every", 1))

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


@dataclass
class Result:
    """Outcome of one scenario run: the recorded signals, the metrics, pass/fail.

    Attributes
    ----------
    name : str
        The scenario's name.
    backend : str
        Default FMU backend of the run.
    results : numpy structured array
        One row per communication time: ``time`` (s) and every recorded
        ``instance.variable`` (its unit: ``units``).
    metrics : list of satfmu.sims.scenario.metrics.MetricResult
        Name, value, unit, bounds and pass/fail of each metric.
    files : dict of str to Path
        What :meth:`write` wrote (csv, plot, summary, l2_ratio_plot).
    l2_curves : dict of str to ndarray
        The truncated L2 ratio over T of each ``l2_ratio`` metric.
    units : dict of str to str
        Unit of each recorded column.
    panels : list of list of str
        Columns of each plot panel.
    title : str
        Plot title.
    warnings : list of str
        Design mismatches found (a controller paired with a plant it was not designed for).
    scenario : Scenario, optional
        The scenario that ran (:meth:`write` records its declaration and FMU files).
    fmu_dir : Path, optional
        The FMU folder of the run.
    """

    name: str
    backend: str
    results: np.ndarray
    metrics: list[M.MetricResult]
    files: dict[str, Path] = field(default_factory=dict)
    l2_curves: dict[str, np.ndarray] = field(default_factory=dict)
    units: dict[str, str] = field(default_factory=dict)
    panels: list[list[str]] = field(default_factory=list)
    title: str = ""
    warnings: list[str] = field(default_factory=list)
    scenario: Scenario | None = None
    fmu_dir: Path | None = None

    @property
    def passed(self) -> bool:
        """Whether every metric is within its bounds."""
        return all(m.passed for m in self.metrics)

    def metric(self, name: str) -> M.MetricResult:
        """The metric of that name.

        Parameters
        ----------
        name : str
            The metric's ``name`` in the scenario.

        Returns
        -------
        satfmu.sims.scenario.metrics.MetricResult

        Raises
        ------
        KeyError
            With the names there are and the closest one.
        """
        for m in self.metrics:
            if m.name == name:
                return m
        names = [m.name for m in self.metrics]
        raise KeyError(f"{self.name}: no metric {name!r} (metrics: {names}){did_you_mean(name, names)}")

    def summary(self) -> dict[str, Any]:
        """Scenario, backend, pass/fail, every metric and the files written, as plain data."""
        return {"scenario": self.name, "backend": self.backend, "passed": self.passed,
                "metrics": [m.to_json() for m in self.metrics],
                "files": {k: str(v) for k, v in self.files.items()}, "warnings": self.warnings}

    def plot(self, path: str | Path) -> Path:
        """Plot the recorded signals (the scenario's panels) to a PNG file; returns its path.

        Parameters
        ----------
        path : path
            The PNG file (its folder is created if missing).
        """
        from satfmu.sims.scenario import plots

        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        plots.time_series(self.results, self.panels, path, title=self.title, units=self.units)
        return path

    def write(self, folder: str | Path) -> dict[str, Path]:
        """Write ``<name>_<backend>.csv``, the plot(s), ``scenario_<backend>.json`` and
        ``summary_<backend>.json`` into ``folder``; returns (and records in ``files``) what
        was written.

        ``scenario_<backend>.json`` (written when ``scenario`` is known) holds what a report
        of the run needs beside the summary: the scenario's declaration
        (:meth:`Scenario.to_dict`), the folder its relative paths resolve against, the backend,
        the FMU folder and each FMU file's name and SHA-256
        (:func:`satfmu.sims.campaign.scenario_campaign.context`), and the unit of every recorded column.

        The files of an earlier run of the same scenario and backend are removed first, every
        file is written whole (temporary name, then rename) and the summary comes last: a
        folder with a summary holds a complete run, one without it no run that looks complete.

        Parameters
        ----------
        folder : path
            The output folder (created if missing).

        Returns
        -------
        dict of str to Path
            ``csv``, ``plot``, ``l2_ratio_plot``, ``scenario``, ``summary`` (those written), and
            any file recorded before (``sample`` of a replay).
        """
        folder = Path(folder)
        clear_outputs(folder, self.name, self.backend)
        stem = f"{self.name}_{self.backend}"
        files = {"csv": folder / f"{stem}.csv"}
        write_atomically(files["csv"], lambda tmp: write_csv(self.results, tmp))
        if self.panels:  # a run that records nothing has nothing to plot
            files["plot"] = write_atomically(folder / f"{stem}.png", self.plot)
        if self.l2_curves:
            from satfmu.sims.scenario import plots

            files["l2_ratio_plot"] = folder / f"{stem}_l2_ratio.png"
            bounds = {m.name: m.max for m in self.metrics}
            write_atomically(files["l2_ratio_plot"], lambda tmp: plots.l2_ratio(
                self.results["time"], {n: (c, bounds[n]) for n, c in self.l2_curves.items()}, tmp,
                title=f"{self.name}: truncated L2 ratio over T"))
        if self.scenario is not None and self.fmu_dir is not None:
            from satfmu.sims.campaign.scenario_campaign import context

            files["scenario"] = folder / f"scenario_{self.backend}.json"
            record = {**context(self.scenario, self.fmu_dir, self.backend), "units": self.units}
            write_atomically(files["scenario"], lambda tmp: tmp.write_text(json.dumps(record, indent=1) + "\n"))
        files["summary"] = folder / f"summary_{self.backend}.json"
        self.files.update(files)
        write_atomically(files["summary"], lambda tmp: tmp.write_text(json.dumps(self.summary(), indent=1) + "\n"))
        return dict(self.files)


def _fields(obj: Any) -> dict[str, Any]:
    """A dataclass's fields, one level deep (``dataclasses.asdict`` copies recursively: ten times the
    cost, for the plain data these hold)."""
    return {f.name: (lambda v: v.copy() if isinstance(v, (dict, list)) else v)(getattr(obj, f.name))
            for f in fields(obj)}


def clear_outputs(folder: Path, name: str, backend: str) -> None:
    """Remove the result files of an earlier run of ``name`` with ``backend`` from ``folder``.

    Parameters
    ----------
    folder : Path
        The run's output folder.
    name : str
        The scenario's name.
    backend : str
        The run's backend (``"native"`` or ``"python"``).
    """
    for f in (f"{name}_{backend}.csv", f"{name}_{backend}.png", f"{name}_{backend}_l2_ratio.png",
              f"scenario_{backend}.json", f"summary_{backend}.json"):
        (Path(folder) / f).unlink(missing_ok=True)


def _number(v: Any, where: str, positive: bool = False) -> float:
    """``v`` as a float; ``where`` is its key path."""
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or (positive and v <= 0):
        raise ScenarioError(f"{where}: must be a finite number{' > 0' if positive else ''}, got {v!r}")
    return float(v)


def _signal(name: Any, instances: list[str], where: str) -> None:
    """``"instance.variable"`` with a declared instance."""
    if not isinstance(name, str) or "." not in name:
        raise ScenarioError(f"{where}: must be 'instance.variable', got {name!r}")
    inst = name.split(".", 1)[0]
    if inst not in instances:
        raise ScenarioError(f"{where}: {name!r} names no FMU instance {inst!r} (instances: "
                            f"{', '.join(instances)}){did_you_mean(inst, instances)}")


def _strings(data: Mapping[str, Any], key: str, where: str, instances: list[str]) -> None:
    value = data.get(key, [])
    if not isinstance(value, list):
        raise ScenarioError(f"{where}.{key}: must be a list of 'instance.variable' names")
    for i, n in enumerate(value):
        _signal(n, instances, f"{where}.{key}[{i}]")


def validate(data: Any, where: str = "scenario") -> None:
    """Check a scenario declaration (plain data); names are checked against the FMUs at run time.

    Parameters
    ----------
    data : mapping
        The declaration (any value: a non-mapping is refused).
    where : str
        Where it comes from (a file name), the first part of every error's key path.

    Raises
    ------
    ScenarioError
        Naming the key path (``where: metrics[0].kind: ...``) and, for unknown keys and
        instance names, the closest known one.
    """
    if not isinstance(data, Mapping):
        raise ScenarioError(f"{where}: expected a table of keys, got {type(data).__name__}")
    check_keys(data, _TOP, where, ScenarioError)
    for key in ("name", "stop_time", "step_size", "fmus"):
        if key not in data:
            raise ScenarioError(f"{where}: missing key {key!r}")
    check_safe_name(data["name"], f"{where}: name", ScenarioError)  # the name is the output folder's
    w = f"{where}: "
    stop, step = (_number(data[k], w + k, True) for k in ("stop_time", "step_size"))
    start = _number(data["start_time"], w + "start_time") if "start_time" in data else 0.0
    if step > stop - start:
        raise ScenarioError(f"{w}step_size {step:g} s exceeds the run length stop_time - start_time = "
                            f"{stop - start:g} s")
    n_float = (stop - start) / step
    every = data.get("record_every", 1)
    if isinstance(every, bool) or not isinstance(every, int) or every < 1:
        raise ScenarioError(f"{w}record_every: must be an integer >= 1, got {every!r}")
    if not n_float / every <= MAX_STEPS:  # an infinite count too (stop_time = 1e308)
        raise ScenarioError(f"{w}stop_time: {n_float:.3g} communication steps, {n_float / every:.3g} recorded, more "
                            f"than {MAX_STEPS:.0e} (the recorded signals alone would need "
                            f"{n_float / every * 8 / 2**30:.3g} GiB per column; record_every thins them)")
    if abs(n_float - round(n_float)) > 1e-9 * max(1.0, n_float):
        raise ScenarioError(f"{w}step_size: (stop_time - start_time) / step_size = {n_float:.12g} is not an integer")
    for key in ("connections", "profiles", "metrics", "record"):
        if key in data and not isinstance(data[key], list):
            raise ScenarioError(f"{w}{key}: must be a list (TOML array{' of tables' if key != 'record' else ''}), "
                                f"got {type(data[key]).__name__} {data[key]!r}")
    fmus = data["fmus"]
    if not isinstance(fmus, Mapping) or not fmus:
        raise ScenarioError(f"{w}fmus: must declare at least one FMU instance")
    instances = list(fmus)
    for inst, spec in fmus.items():
        ws = f"{w}fmus.{inst}"
        if not isinstance(spec, Mapping):
            raise ScenarioError(f"{ws}: must be a table with 'model' or 'path'")
        check_keys(spec, _FMU, ws, ScenarioError)
        if ("model" in spec) == ("path" in spec):
            raise ScenarioError(f"{ws}: needs exactly one of 'model' or 'path'")
        for key in ("model", "path"):
            if key in spec and (not isinstance(spec[key], str) or not spec[key]):
                raise ScenarioError(f"{ws}.{key}: must be a non-empty string, got {spec[key]!r}")
        if "model" in spec:  # the model names a file of the FMU folder
            check_safe_name(spec["model"], f"{ws}.model", ScenarioError)
        if spec.get("backend", "native") not in BACKENDS:
            raise ScenarioError(f"{ws}.backend: must be one of {sorted(BACKENDS)}, got {spec['backend']!r}"
                                f"{did_you_mean(str(spec['backend']), sorted(BACKENDS))}")
        params = spec.get("parameters", {})
        if not isinstance(params, Mapping):
            raise ScenarioError(f"{ws}.parameters: must be a table of start values")
        for k, v in params.items():
            _check_start_value(v, f"{ws}.parameters.{k}")
    for i, c in enumerate(data.get("connections", [])):
        wc = f"{w}connections[{i}]"
        if not isinstance(c, Mapping):
            raise ScenarioError(f"{wc}: must be a table with 'from' and 'to'")
        check_keys(c, ("from", "to"), wc, ScenarioError)
        for key in ("from", "to"):
            if key not in c:
                raise ScenarioError(f"{wc}: missing key {key!r}")
            _signal(c[key], instances, f"{wc}.{key}")
    for i, p in enumerate(data.get("profiles", [])):
        if not isinstance(p, Mapping) or "to" not in p:
            raise ScenarioError(f"{w}profiles[{i}]: needs a 'to' target")
        _signal(p["to"], instances, f"{w}profiles[{i}].to")
    for i, n in enumerate(data.get("record", [])):
        _signal(n, instances, f"{w}record[{i}]")
    ver = data.get("verify", {})
    if not isinstance(ver, Mapping) or set(ver) - {"rtol", "atol", "reason"} or ver and not ver.get("reason") or any(
            isinstance(ver.get(k, 0.0), bool) or not isinstance(ver.get(k, 0.0), (int, float))
            or not 0 <= ver.get(k, 0.0) < 1 for k in ("rtol", "atol")):
        raise ScenarioError(f"{w}verify: takes rtol and atol in [0, 1) and needs a 'reason' for them")
    for i, m in enumerate(data.get("metrics", [])):
        wm = f"{w}metrics[{i}]"
        if not isinstance(m, Mapping):
            raise ScenarioError(f"{wm}: must be a table")
        check_keys(m, _METRIC, wm, ScenarioError)
        if m.get("kind") not in M.KINDS:
            raise ScenarioError(f"{wm}.kind: must be one of {M.KINDS}, got {m.get('kind')!r}"
                                f"{did_you_mean(str(m.get('kind')), list(M.KINDS))}")
        if not m.get("name") or not m.get("signals"):
            raise ScenarioError(f"{wm}: needs 'name' and 'signals'")
        if m["kind"] in _NEEDS and _NEEDS[m["kind"]] not in m:
            raise ScenarioError(f"{wm}: kind {m['kind']} needs {_NEEDS[m['kind']]!r}")
        for key in ("signals", "disturbances", "versus"):
            _strings(m, key, wm, instances)
        for key in ("scale", "min", "max", "tolerance", "limit"):
            if key in m:
                _number(m[key], f"{wm}.{key}")
    if "dispersions" in data:
        _dispersions(data["dispersions"], f"{w}dispersions", instances, len(data.get("profiles", [])))
    if "campaign" in data:
        _campaign(data["campaign"], f"{w}campaign", "dispersions" in data)


def _campaign(table: Any, where: str, dispersed: bool) -> None:
    """Check a ``[campaign]`` table (:data:`CAMPAIGN_KEYS`); a :class:`ScenarioError` names the key path."""
    if not isinstance(table, Mapping):
        raise ScenarioError(f"{where}: must be a table of {', '.join(CAMPAIGN_KEYS)}, got {table!r}")
    check_keys(table, tuple(CAMPAIGN_KEYS), where, ScenarioError)
    if not dispersed:
        raise ScenarioError(f"{where}: a campaign needs a [dispersions] table (what each sample draws)")
    for key, least in CAMPAIGN_KEYS.items():
        v = table.get(key, least)
        if isinstance(v, bool) or not isinstance(v, int) or v < least:
            raise ScenarioError(f"{where}.{key}: must be an integer >= {least}, got {table[key]!r}")
    if table.get("demo_samples", 1) > table.get("samples", math.inf):
        raise ScenarioError(f"{where}.demo_samples: {table['demo_samples']} is more than samples = {table['samples']}")


def _check_start_value(v: Any, where: str) -> None:
    """A start value is a finite number, a boolean or a string."""
    if isinstance(v, float) and not math.isfinite(v):
        raise ScenarioError(f"{where}: must be finite, got {v!r}")
    if not isinstance(v, (bool, int, float, str)):
        raise ScenarioError(f"{where}: must be a number, boolean or string, got {v!r}")


def _dispersions(data: Any, where: str, instances: list[str], n_profiles: int) -> Dispersions:
    """The ``[dispersions]`` table, validated; a :class:`ScenarioError` names the key path."""
    try:
        return Dispersions.from_dict(data, where, instances, n_profiles)
    except DispersionError as exc:
        raise ScenarioError(str(exc)) from None


def nominal_values(scenario: Scenario, fmu_dir: str | Path | None = None, backend: str = "native"
                   ) -> Callable[[str, str], float | None]:
    """The nominal value of a parameter or profile field: the scenario's start value, else the
    FMU's (its model description, read on first need; the FMUs are ensured by
    :func:`ensure_fmus`); None when the instance has no such parameter or the profile no such
    field.

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    fmu_dir : path, optional
        Folder of the FMUs named by ``model`` (default :func:`satfmu.controllers.paths.fmu_cache`).
    backend : {"native", "python"}
        Default backend of the instances (an instance's own ``backend`` overrides it).

    Returns
    -------
    callable
        (instance or ``"profiles[i]"``, name) -> float or None.
    """
    from satfmu.fmus import archive

    starts: dict[str, dict[str, float]] = {}

    def value(owner: str, name: str) -> float | None:
        m = re.fullmatch(r"profiles\[(\d+)\]", owner)
        if m:
            v = scenario.profiles[int(m[1])].get(name)
            return None if v is None else float(v)
        given = scenario.fmus[owner].parameters
        if name in given:
            return float(given[name])
        if owner not in starts:
            folder = ensure_fmus(scenario, fmu_dir, backend)
            md = archive.read_description(fmu_paths(scenario, folder, backend)[owner])
            starts[owner] = {v.name: float(v.start) for v in md.modelVariables
                             if v.causality in ("parameter", "input") and v.type in ("Real", "Integer")
                             and v.start is not None}
        return starts[owner].get(name)

    return value


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


def fmu_paths(scenario: Scenario, fmu_dir: Path, backend: str) -> dict[str, Path]:
    """Instance name -> FMU file, for the chosen default backend (``path`` entries resolve
    against the scenario's folder, ``model`` entries name files in ``fmu_dir``).

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    fmu_dir : Path
        Folder of the FMUs named by ``model``.
    backend : {"native", "python"}
        Default backend of the instances (an instance's own ``backend`` overrides it).

    Raises
    ------
    ScenarioError
        An unknown backend.
    """
    if backend not in BACKENDS:
        raise ScenarioError(f"backend must be one of {sorted(BACKENDS)}, got {backend!r}"
                            f"{did_you_mean(str(backend), sorted(BACKENDS))}")
    out = {}
    for inst, spec in scenario.fmus.items():
        if spec.path is not None:
            p = Path(spec.path)
            out[inst] = p if p.is_absolute() else scenario.folder / p
        else:
            out[inst] = Path(fmu_dir) / f"{spec.model}{BACKENDS[spec.backend or backend]}.fmu"
    return out


def profiles(scenario: Scenario) -> list[tuple[str, Profile]]:
    """The scenario's disturbance profiles, built: (target ``instance.variable``, profile).

    Parameters
    ----------
    scenario : Scenario
        The scenario.

    Raises
    ------
    satfmu.fmus.profiles.ProfileError
    """
    where = scenario.path.name if scenario.path else scenario.name
    return [(p["to"], make_profile({k: v for k, v in p.items() if k != "to"}, f"{where}: profiles[{i}]",
                                   scenario.folder, scenario.step_size))
            for i, p in enumerate(scenario.profiles)]


def grid(scenario: Scenario) -> np.ndarray:
    """The communication times of the scenario, s (as the master steps them).

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    """
    t0 = scenario.start_time
    return communication_times(t0, scenario.step_size, round((scenario.stop_time - t0) / scenario.step_size))


def recorded_times(scenario: Scenario) -> np.ndarray:
    """The communication times a run of the scenario records, s (every ``record_every``-th of
    :func:`grid`, and the last).

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    """
    t = grid(scenario)
    return t[recorded_steps(len(t) - 1, scenario.record_every)]


def recorded(scenario: Scenario, sim: CoSimulation) -> list[str]:
    """The qualified variables a run of ``scenario`` records: its ``record`` list and every
    signal its metrics read, base names expanded, each once.

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    sim : CoSimulation
        The scenario's master (:func:`wire`).
    """
    record = list(scenario.record)
    for m in scenario.metrics:
        record += m.signals + m.disturbances + m.versus
    return list(dict.fromkeys(_columns(sim, record)))


def _columns(sim: CoSimulation, names: list[str]) -> list[str]:
    cols = []
    for n in names:
        comp, vs = sim.resolve(n)
        cols += [f"{comp.name}.{v}" for v in vs]
    return cols


def design_mismatches(scenario: Scenario, sim: CoSimulation, rtol: float | None = None) -> list[str]:
    """Controllers of the scenario paired with a plant whose parameters differ from the plant
    they were designed for (the artifact each controller FMU carries in its resources).

    Parameters
    ----------
    scenario : Scenario
        The scenario (its start values override the plants' declared ones).
    sim : CoSimulation
        The scenario's master, its FMUs loaded.
    rtol : float, optional
        Relative tolerance (default :data:`satfmu.controllers.artifact.DESIGN_RTOL`).

    Returns
    -------
    list of str
        One line per controller and plant instance, e.g. ``"controller (mrp_hinf_published)
        on plant: I_x = 100 (designed for 15), ..."``.
    """
    from satfmu.controllers import artifact as artifacts

    out = []
    for cname, comp in sim.components.items():
        f = Path(comp.unzip_dir) / "resources" / "artifact.json"
        if not f.is_file():
            continue
        art = artifacts.load(f)
        for pname, plant in sim.components.items():
            if pname == cname:
                continue
            values = {v.name: float(v.start) for v in plant.model_description.modelVariables
                      if v.causality == "parameter" and v.type == "Real" and v.start is not None}
            values.update({k: float(v) for k, v in scenario.fmus[pname].parameters.items()
                           if isinstance(v, (int, float)) and not isinstance(v, bool)})
            lines = artifacts.plant_mismatches(art, plant.model_description.modelName, values,
                                               artifacts.DESIGN_RTOL if rtol is None else rtol)
            if lines:
                out.append(f"{cname} ({art.name}) on {pname}: {', '.join(lines)}")
    return out


def wire(scenario: Scenario, fmu_dir: Path, backend: str = "native", strict: bool = False,
         design_rtol: float | None = None) -> CoSimulation:
    """The scenario's master with its FMUs loaded and wired, not run: everything the master
    would refuse at run time is refused here, naming the key path.

    That is: a name no FMU has (connections, profiles, record, metrics), a connection from
    something other than an output or into something other than an input, an input driven
    twice, an algebraic loop, a parameter of the wrong type or outside its declared range
    (``n_substeps = 0``), a recorded or measured variable that is not Real, ``max_difference``
    signals and ``versus`` signals of different lengths. A controller paired with a plant
    other than its design plant is reported by a :class:`DesignMismatchWarning` (the lines
    are in ``sim.mismatches``), or refused with ``strict``.

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    fmu_dir : Path
        Folder of the FMUs named by ``model`` (:func:`ensure_fmus` has made them).
    backend : {"native", "python"}
        Default backend of the instances (an instance's own ``backend`` overrides it).
    strict : bool
        Refuse a design mismatch (:class:`ScenarioError`) instead of warning.
    design_rtol : float, optional
        Relative tolerance of the design comparison (:func:`design_mismatches`).

    Returns
    -------
    CoSimulation
        Open: the caller closes it.

    Raises
    ------
    ScenarioError
    """
    where = str(scenario.path) if scenario.path else f"scenario {scenario.name!r}"
    sim = CoSimulation(fmu_paths(scenario, fmu_dir, backend))
    try:
        sim.mismatches = design_mismatches(scenario, sim, design_rtol)
        for line in sim.mismatches:
            if strict:
                raise ScenarioError(f"{where}: design mismatch (strict): {line}")
            warnings.warn(f"{where}: {line}", DesignMismatchWarning, stacklevel=3)
        _wire(scenario, sim, where)
        _check_parameters(scenario, sim, where)
        _check_dispersions(scenario, sim, where)
        _check_signals(scenario, sim, where)
    except BaseException:
        sim.close()
        raise
    return sim


def _wire(scenario: Scenario, sim: CoSimulation, where: str) -> None:
    """Connect and feed profiles, each scalar input driven once; refuse algebraic loops."""
    driven: dict[str, str] = {}

    def drive(key: str, targets: list[str]) -> None:
        for dst in targets:
            if dst in driven:
                raise ScenarioError(f"{where}: {key}: input {dst} is driven twice (by {driven[dst]} and by {key})")
            driven[dst] = key

    for i, c in enumerate(scenario.connections):
        for key, name in (("from", c.source), ("to", c.target)):
            _checked(sim, name, f"{where}: connections[{i}].{key}")
        n = len(sim.connections)
        try:
            sim.connect(c.source, c.target)
        except WiringError as exc:
            raise ScenarioError(f"{where}: connections[{i}]: {exc}") from None
        drive(f"connections[{i}]", [dst for _, dst in sim.connections[n:]])
    for i, (target, prof) in enumerate(profiles(scenario)):
        _checked(sim, target, f"{where}: profiles[{i}].to")
        n = len(sim.profiles)
        try:
            sim.add_profile(target, prof)
        except WiringError as exc:
            raise ScenarioError(f"{where}: profiles[{i}].to: {exc}") from None
        drive(f"profiles[{i}]", [dst for dst, _ in sim.profiles[n:]])
    try:
        sim.check_wiring()  # the master's own analysis: an input driven twice, an algebraic loop
    except WiringError as exc:
        raise ScenarioError(f"{where}: connections: {exc}") from None


def _check_parameters(scenario: Scenario, sim: CoSimulation, where: str) -> None:
    """Each start value: a parameter or input of its FMU, of its type, within its declared range."""
    for inst, spec in scenario.fmus.items():
        comp = sim.components[inst]
        for name, value in spec.parameters.items():
            key = f"{where}: fmus.{inst}.parameters.{name}"
            try:
                var, value = start_value(comp, name, value)
            except (UnknownVariableError, WiringError) as exc:
                raise ScenarioError(f"{key}: {exc}") from None
            low, high = (float(b) if b is not None else None for b in (var.min, var.max))
            if not isinstance(value, bool) and (low is not None and value < low or high is not None and value > high):
                raise ScenarioError(f"{key}: {value!r} is outside its declared range [{var.min or '-inf'}, "
                                    f"{var.max or 'inf'}] ({comp.path.name})")


def _check_dispersions(scenario: Scenario, sim: CoSimulation, where: str) -> None:
    """Each dispersed FMU parameter: a parameter or input of its instance."""
    if scenario.dispersions is None:
        return
    for key, inst, name in scenario.dispersions.parameter_targets():
        try:
            var = sim.components[inst].variable(name)
        except UnknownVariableError as exc:
            raise ScenarioError(f"{where}: dispersions.{key}: {exc}") from None
        if var.causality not in ("parameter", "input"):
            raise ScenarioError(f"{where}: dispersions.{key}: {inst}.{name} is a {var.causality}; only "
                                "parameters and inputs can be dispersed")


def _check_signals(scenario: Scenario, sim: CoSimulation, where: str) -> None:
    """Record entries and metric signals: names of Real variables; ``versus`` as long as ``signals``."""
    def real(name: str, key: str) -> list[str]:
        _checked(sim, name, key)
        comp, names = sim.resolve(name)
        for n in names:
            if comp.variable(n).type != "Real":
                raise ScenarioError(f"{key}: {comp.name}.{n} is {comp.variable(n).type}; only Real variables "
                                    "can be recorded")
        return names

    for i, name in enumerate(scenario.record):
        real(name, f"{where}: record[{i}]")
    for i, m in enumerate(scenario.metrics):
        n = {key: sum(len(real(name, f"{where}: metrics[{i}].{key}[{j}]")) for j, name in enumerate(getattr(m, key)))
             for key in ("signals", "disturbances", "versus")}
        if m.kind == "max_difference" and n["versus"] != n["signals"]:
            raise ScenarioError(f"{where}: metrics[{i}].versus: {n['versus']} variables for {n['signals']} "
                                "in 'signals'")


def simulate(scenario: Scenario, fmu_dir: Path, backend: str = "native", strict: bool = False,
             design_rtol: float | None = None) -> tuple[np.ndarray, CoSimulation]:
    """Run the scenario's co-simulation (wired and checked by :func:`wire`); returns the
    recorded array and the (closed) master.

    Parameters
    ----------
    scenario, fmu_dir, backend, strict, design_rtol
        As :func:`wire`.

    Returns
    -------
    res : numpy.ndarray
        Structured array: ``time`` (s) and every recorded ``instance.variable`` (:func:`recorded`),
        one row per recorded communication point.
    sim : CoSimulation
        The master, closed (its components' units and signals can still be read).

    Raises
    ------
    ScenarioError
        What :func:`wire` refuses.
    satfmu.sims.cosim.master.MasterError
        An FMU call failed (its log lines in the message).
    """
    sim = wire(scenario, fmu_dir, backend, strict, design_rtol)
    try:
        res = _execute(scenario, sim)
    finally:
        sim.close()
    return res, sim


def _execute(scenario: Scenario, sim: CoSimulation) -> np.ndarray:
    """Run ``scenario`` through its wired master; the recorded array."""
    params = {inst: spec.parameters for inst, spec in scenario.fmus.items()}
    return sim.run(scenario.stop_time, scenario.step_size, scenario.start_time, params, recorded(scenario, sim),
                   record_every=scenario.record_every)


def resimulate(scenario: Scenario, sim: CoSimulation) -> np.ndarray:
    """Run ``scenario`` through a master that :func:`wire` made for a scenario of the same FMUs,
    connections, records and metrics, differing in start values and profile fields only (a
    sample of its dispersions, :meth:`Scenario.sample`): the master's profiles are replaced by
    the scenario's and its start values checked, then it runs as :func:`simulate` runs it. With
    ``sim.reuse_instances`` the FMU instances are reset, not created again (a campaign's worker).

    Parameters
    ----------
    scenario : Scenario
        The scenario to run (a sample of the wired one).
    sim : CoSimulation
        The open master :func:`wire` made for the wired scenario; its profiles are replaced.

    Returns
    -------
    numpy.ndarray
        The recorded array, as :func:`simulate` returns it.

    Raises
    ------
    ScenarioError
        A start value of the wrong type or outside its declared range.
    satfmu.fmus.profiles.ProfileError
        A profile field its kind refuses.
    satfmu.sims.cosim.master.MasterError
        An FMU call failed.
    """
    where = str(scenario.path) if scenario.path else f"scenario {scenario.name!r}"
    built = profiles(scenario)
    wired = [t for t, _ in sim.profiles]
    sim.profiles = []
    for target, prof in built:
        sim.add_profile(target, prof)
    if [t for t, _ in sim.profiles] != wired:
        raise ScenarioError(f"{where}: its profiles drive other inputs than the wired scenario's ({wired})")
    _check_parameters(scenario, sim, where)
    return _execute(scenario, sim)


def check(scenario: Scenario, fmu_dir: str | Path | None = None, backend: str = "native",
          allow_stale: bool = False) -> Path:
    """Everything a run checks before its first step, without running: the FMU files
    (:func:`ensure_fmus`, which builds the missing ones) and the wiring (:func:`wire`).
    ``satfmu export-ssp`` and ``verify`` check a scenario with it.

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    fmu_dir : path, optional
        Folder of the FMUs named by ``model`` (default :func:`satfmu.controllers.paths.fmu_cache`).
    backend : {"native", "python"}
        Default backend of the instances (an instance's own ``backend`` overrides it).
    allow_stale : bool
        Accept a stale controller FMU outside the FMU cache (:func:`ensure_fmus`).

    Returns
    -------
    Path
        The FMU folder.

    Raises
    ------
    ScenarioError
    """
    folder = ensure_fmus(scenario, fmu_dir, backend, allow_stale)
    wire(scenario, folder, backend).close()
    return folder


def _checked(sim: CoSimulation, name: str, where: str) -> None:
    """Resolve ``name`` in ``sim`` or raise a ScenarioError naming the key path."""
    try:
        sim.resolve(name)
    except UnknownVariableError as exc:
        raise ScenarioError(f"{where}: {exc}") from None


def evaluate(scenario: Scenario, res: np.ndarray, sim: CoSimulation
             ) -> tuple[list[M.MetricResult], dict[str, np.ndarray]]:
    """Evaluate the scenario's metrics on a recorded run.

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    res : numpy.ndarray
        The recorded run (:func:`simulate`): ``time`` (s) and the recorded signals.
    sim : CoSimulation
        The master that ran it (which signals are held FMU inputs, how base names expand).

    Returns
    -------
    results : list of satfmu.sims.scenario.metrics.MetricResult
        One per metric, in the scenario's order, values in the metrics' units.
    curves : dict of str to numpy.ndarray
        The truncated L2 ratio over T of each ``l2_ratio`` metric, by name.
    """
    t = res["time"]
    held = sim.held_signals()
    out, curves = [], {}
    for m in scenario.metrics:
        scale = m.scale
        cols = _columns(sim, m.signals)
        y = np.stack([res[c] for c in cols], axis=1) * scale
        is_held = all(c in held for c in cols)
        kind = m.kind
        if kind == "final":
            value = float(np.max(np.abs(y[-1])))
        elif kind == "peak":
            value = M.peak(y)
        elif kind == "rms":
            value = M.rms(t, y, held=is_held)
        elif kind == "settling_time":
            assert m.tolerance is not None  # validate(): settling_time needs a tolerance (_NEEDS)
            value = M.settling_time(t, y, float(m.tolerance))
        elif kind == "time_in_saturation":
            assert m.limit is not None  # validate(): time_in_saturation needs a limit (_NEEDS)
            value = M.time_in_saturation(t, y, float(m.limit), held=is_held)
        elif kind == "integral_square":
            value = M.integral_square(t, y, [c in sim.input_signals() for c in cols])
        elif kind == "max_difference":  # as many versus signals as signals: checked by wire()
            value = M.peak(y - np.stack([res[c] for c in _columns(sim, m.versus)], axis=1) * scale)
        else:
            wcols = _columns(sim, m.disturbances)
            w = np.stack([res[c] for c in wcols], axis=1)
            curve = M.l2_ratio_curve(t, y, w, w_held=all(c in held for c in wcols))
            curves[m.name] = curve
            value = float(np.nanmax(curve)) if np.any(np.isfinite(curve)) else math.nan
        out.append(M.MetricResult(m.name, kind, value, m.min, m.max, m.unit))
    return out, curves


def write_csv(res: np.ndarray, path: Path) -> None:
    """Write a structured result array as CSV: a header of the field names, then one line per row.

    Each number is the shortest text that reads back as the same float64 (``0.05``, ``1e-310``,
    ``-0``, ``nan``, ``inf``), written by Arrow's CSV writer in C++ (about 5x faster than a Python
    loop of ``repr``); the header is quoted where a name needs it (``a[1,2]``).

    Parameters
    ----------
    res : numpy.ndarray
        Structured array, one field per column.
    path : Path
        The CSV file (overwritten).

    Raises
    ------
    ValueError
        ``res`` has no named fields.
    """
    import pyarrow as pa
    from pyarrow import csv as pa_csv

    names = res.dtype.names
    if names is None:
        raise ValueError(f"write_csv needs a structured array (named fields), got dtype {res.dtype}")
    with open(path, "w", newline="") as fh:
        csv.writer(fh, lineterminator="\n").writerow(names)
    table = pa.table({f"c{i}": np.ascontiguousarray(res[n], dtype=np.float64) for i, n in enumerate(names)})
    with open(path, "ab") as fh:
        pa_csv.write_csv(table, fh, pa_csv.WriteOptions(include_header=False))


def run(scenario: "str | Path | Mapping[str, Any] | Scenario", fmu_dir: str | Path | None = None,
        backend: str = "native", out_dir: str | Path | None = None, strict: bool = False,
        design_rtol: float | None = None, allow_stale: bool = False) -> Result:
    """Run a scenario and evaluate its metrics.

    Parameters
    ----------
    scenario : Scenario, dict, str or Path
        A scenario, its plain data, a TOML file or a shipped scenario's name.
    fmu_dir : path, optional
        Folder of the FMUs named by ``model`` (default :func:`satfmu.controllers.paths.fmu_cache`); FMUs
        missing there are built into it first (:func:`ensure_fmus`).
    backend : {"native", "python"}
        Default backend of the instances.
    out_dir : path, optional
        Write the CSV, plots and summary into ``out_dir/<name>/`` (:meth:`Result.write`).
    strict : bool
        Refuse (``ScenarioError``) a controller paired with a plant other than its design
        plant, instead of a :class:`DesignMismatchWarning`.
    design_rtol : float, optional
        Relative tolerance of that comparison (default 1e-3).
    allow_stale : bool
        Run a stale controller FMU outside the FMU cache as it is, with a
        :class:`StaleFmuWarning`, instead of refusing it (:func:`ensure_fmus`).

    Returns
    -------
    Result

    Raises
    ------
    ScenarioError
        An invalid scenario (key path named), an unusable or stale FMU, a name no FMU has,
        a wiring the master refuses, a strict mismatch.
    satfmu.sims.cosim.master.MasterError
        An FMU call failed (its log lines in the message).
    """
    sc = load(scenario)
    if out_dir is not None:  # a failed run must not leave the last run's files looking current
        clear_outputs(Path(out_dir) / sc.name, sc.name, backend)
    folder = ensure_fmus(sc, fmu_dir, backend, allow_stale)
    res, sim = simulate(sc, folder, backend, strict, design_rtol)
    assert res.dtype.names is not None  # the master records a structured array (time, then the signals)
    mres, curves = evaluate(sc, res, sim)
    panels = sc.plot.get("panels") or [[r] for r in sc.record] or [m.signals for m in sc.metrics]
    cols = [_columns(sim, p) for p in panels]
    result = Result(sc.name, backend, res, mres, l2_curves=curves,
                    units={c: sim.unit(c) for c in res.dtype.names if c != "time"}, panels=cols,
                    title=f"{sc.name}: {sc.description}", warnings=list(sim.mismatches), scenario=sc, fmu_dir=folder)
    if out_dir is not None:
        result.write(Path(out_dir) / sc.name)
    return result


def ensure_fmus(scenario: Scenario, fmu_dir: str | Path | None, backend: str, allow_stale: bool = False) -> Path:
    """The FMU folder of a run, with every FMU the scenario names present and usable.

    An FMU named by ``model`` and missing is built into the folder (plants by model name,
    controllers from their artifact, found in the user's folder before the shipped ones).
    An FMU present is checked (:mod:`satfmu.sims.cosim.preflight`): a readable FMI 2.0 co-simulation FMU
    of that model with a binary for this platform and, for a controller, embedding the
    artifact file of its name as that file is now. In the FMU cache
    (:func:`satfmu.controllers.paths.fmu_cache`, satfmu's own folder) an FMU failing that is rebuilt, with
    a :class:`StaleFmuWarning`; in any other folder it is an error (files there are the
    user's, never replaced), or, for a stale controller with ``allow_stale``, a
    :class:`StaleFmuWarning` and the FMU is used as it is. An FMU named by ``path`` is
    checked alike (not its model name or artifact), and never rebuilt.

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    fmu_dir : path or None
        The FMU folder; None for the FMU cache (:func:`satfmu.controllers.paths.fmu_cache`).
    backend : {"native", "python"}
        Default backend of the instances (an instance's own ``backend`` overrides it).
    allow_stale : bool
        Use a stale controller FMU outside the cache as it is, with a warning.

    Returns
    -------
    Path
        The FMU folder, resolved.

    Raises
    ------
    ScenarioError
        Naming the key (``fmus.<instance>.model`` or ``.path``) and the file: a missing
        ``path`` FMU, an unknown model name (with the closest one), an artifact that cannot
        be built, an unusable or stale FMU outside the cache.
    """
    from satfmu.controllers import catalog
    from satfmu.controllers.paths import fmu_cache

    folder = fmu_cache() if fmu_dir is None else Path(fmu_dir).resolve()
    cache = folder == fmu_cache()
    where = str(scenario.path) if scenario.path else f"scenario {scenario.name!r}"
    for inst, p in fmu_paths(scenario, folder, backend).items():
        spec = scenario.fmus[inst]
        if spec.path is not None:
            problem = preflight.fmu_problem(p) if p.is_file() else "does not exist"
            if problem:
                raise ScenarioError(f"{where}: fmus.{inst}.path: FMU file {p} {problem}")
            continue
        key = f"{where}: fmus.{inst}.model"
        assert spec.model is not None  # validate(): exactly one of model and path
        if p.is_file():
            problem = preflight.fmu_problem(p, spec.model)
            stale = None if problem else preflight.stale_artifact(p, spec.model)
            if problem is None and stale is None:
                continue
            if stale and allow_stale and not cache:
                warnings.warn(f"{key}: stale FMU run as it is (allow_stale): {stale}", StaleFmuWarning, stacklevel=2)
                continue
            if not cache:
                raise ScenarioError(f"{key}: stale FMU: {stale} (remove the FMU to have it built from the artifact, "
                                    "or pass --allow-stale to run it as it is)" if stale else
                                    f"{key}: FMU file {p} {problem} (remove it to have it built anew)")
            warnings.warn(f"{key}: rebuilding the FMU in the cache: {stale or f'FMU file {p} {problem}'}",
                          StaleFmuWarning, stacklevel=2)
            p.unlink()
        try:
            catalog.ensure(folder, [spec.model], spec.backend or backend)
        except (ValueError, FileNotFoundError) as exc:
            raise ScenarioError(f"{key}: no FMU {p.name} in {folder}, and it cannot be built: {exc}") from None
    return folder
