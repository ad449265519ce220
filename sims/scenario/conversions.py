"""A scenario's unit conversions: recorded signals and metrics in the units the scenario asks for.

The master records every variable in its FMU's declared unit. A scenario asks for another unit
per recorded signal (``record = [{ signal = "plant.phi", unit = "deg" }]``) and per metric
(``unit = "deg"``); the factor comes from the declared unit (the FMU's own ``UnitDefinitions``
first, then :mod:`satfmu.fmus.units`), never typed by hand. The conversion is made once, where a
run is turned into what a user reads: the metrics (:func:`metric_conversion`), a run's
:class:`~satfmu.sims.scenario.result.Result` and a campaign's kept time histories
(:func:`record_conversions`).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from satfmu.fmus.errors import ScenarioError
from satfmu.fmus.units import UnitError, conversion
from satfmu.sims.cosim.master import CoSimulation
from satfmu.sims.scenario.metrics import MARGIN_KINDS, value_unit
from satfmu.sims.scenario.spec import Metric, Scenario

ANGLE_KINDS = ("attitude_difference",)
"""Metric kinds whose value is an angle computed from attitude signals, rad before conversion."""


def declared_units(sim: CoSimulation, column: str) -> tuple[str, dict[str, dict[str, float]]]:
    """A column's declared unit and its FMU's unit definitions (name -> ``BaseUnit`` attributes).

    Parameters
    ----------
    sim : CoSimulation
        The scenario's master.
    column : str
        ``instance.variable``.
    """
    comp = sim.components[column.split(".", 1)[0]]
    defs: dict[str, dict[str, float]] = {}
    for u in getattr(comp.model_description, "unitDefinitions", []) or []:
        b = getattr(u, "baseUnit", None)
        if b is not None:
            defs[u.name] = {k: float(getattr(b, k)) for k in ("kg", "m", "s", "A", "K", "mol", "cd", "rad",
                                                              "factor", "offset") if getattr(b, k, None) is not None}
    return sim.unit(column), defs


def _factor(sim: CoSimulation, column: str, unit: str, where: str) -> float:
    declared, defs = declared_units(sim, column)
    try:
        return conversion(declared, unit, defs)
    except UnitError as exc:
        raise ScenarioError(f"{where}: {column} is in {declared!r}: {exc}") from None


def record_conversions(scenario: Scenario, sim: CoSimulation, columns: list[str]) -> dict[str, tuple[float, str]]:
    """Each column's factor and unit as the run shows it: the unit the scenario's ``record`` asks
    for (an entry's ``unit``; a base name's applies to its elements), else the declared one.

    Parameters
    ----------
    scenario : Scenario
        The scenario (its ``units``).
    sim : CoSimulation
        Its master.
    columns : list of str
        ``instance.variable`` columns of the recorded array.

    Returns
    -------
    dict of str to (float, str)
        Column -> (factor from the declared unit, unit).

    Raises
    ------
    ScenarioError
        A unit the declared one does not convert to (the ``record`` entry named).
    """
    where = str(scenario.path) if scenario.path else f"scenario {scenario.name!r}"
    asked: dict[str, tuple[str, str]] = {}
    for i, entry in enumerate(scenario.record):
        if entry in scenario.units:
            comp, names = sim.resolve(entry)
            for n in names:
                asked[f"{comp.name}.{n}"] = (scenario.units[entry], f"{where}: record[{i}].unit")
    out = {}
    for c in columns:
        if c in asked:
            unit, key = asked[c]
            out[c] = (_factor(sim, c, unit, key), unit)
        else:
            out[c] = (1.0, sim.unit(c))
    return out


def converted(res: np.ndarray, factors: dict[str, tuple[float, str]]) -> np.ndarray:
    """A copy of the recorded array with each column times its factor (``time`` as it is).

    Parameters
    ----------
    res : numpy.ndarray
        Structured array: ``time`` and the columns.
    factors : dict of str to (float, str)
        :func:`record_conversions` of those columns.
    """
    if all(f == 1.0 for f, _ in factors.values()):
        return res
    out = res.copy()
    for c, (f, _) in factors.items():
        if f != 1.0:
            out[c] = res[c] * f
    return out


@dataclass(frozen=True)
class MetricConversion:
    """The factors a metric applies to its signals and the unit of its value.

    Attributes
    ----------
    signals, versus, disturbances : numpy.ndarray
        One factor per column of ``signals``, ``versus`` and ``disturbances`` (the declared
        unit to the metric's, times its ``scale``; the disturbances: 1).
    unit : str
        The unit of the metric's value (``s`` for a time, ``N2.m2.s`` for an ``integral_square``
        of torques, the ratio of units for an ``l2_ratio``; ``""`` when a hand-typed scale left
        it unknown).
    scale : float
        The factor of an ``attitude_difference``'s angle (rad to the metric's unit, times scale) and
        of a margin (its own unit to the metric's).
    """

    signals: np.ndarray
    versus: np.ndarray
    disturbances: np.ndarray
    unit: str
    scale: float = 1.0


def metric_conversion(metric: Metric, sim: CoSimulation, columns: dict[str, list[str]], where: str
                      ) -> MetricConversion:
    """How one metric converts its signals, and the unit of its value.

    With ``unit`` set, each signal is converted from its declared unit to it (``tolerance``,
    ``limit`` and the bounds of a value in that unit are in it too); a ``scale`` other than 1
    then must not convert as well (a scenario written for hand-typed scales, ``scale =
    57.29...`` with ``unit = "deg"``, is refused rather than converted twice). Without ``unit``
    the signals keep their declared unit (times ``scale``).

    Parameters
    ----------
    metric : Metric
        The metric.
    sim : CoSimulation
        The scenario's master.
    columns : dict of str to list of str
        The metric's ``signals``, ``versus`` and ``disturbances`` expanded to columns.
    where : str
        Key path of the metric (``scenario.toml: metrics[2]``), the start of every error.

    Returns
    -------
    MetricConversion

    Raises
    ------
    ScenarioError
        An unknown unit, one the signals do not convert to, or a scale that converts twice.
    """
    if metric.kind in MARGIN_KINDS:  # a figure of the loop, in its own unit: dB, deg, s or 1
        own = MARGIN_KINDS[metric.kind]
        k = _convert(own, metric.unit, f"{where}.unit", f"a {metric.kind} is in {own!r}") if metric.unit else 1.0
        return MetricConversion(np.ones(len(columns["signals"])), np.ones(0), np.ones(0), metric.unit or own,
                                k * metric.scale)
    declared = {c: sim.unit(c) for key in ("signals", "versus") for c in columns[key]}
    if metric.kind in ANGLE_KINDS:
        factor = _angle_factor(metric, where)
        ones = np.ones(len(columns["signals"]))
        return MetricConversion(ones * factor, np.ones(len(columns["versus"])) * factor,
                                np.ones(len(columns["disturbances"])), metric.unit or _unit(metric, "rad"), factor)
    if metric.unit:
        f = {c: _factor(sim, c, metric.unit, f"{where}.unit") for c in declared}
        if metric.scale != 1.0 and any(v != 1.0 for v in f.values()):
            raise ScenarioError(f"{where}: scale {metric.scale:g} and unit {metric.unit!r} would both convert "
                                f"({', '.join(sorted(set(declared.values())))} to {metric.unit!r} is done from the "
                                "declared unit): drop 'scale'")
        base = metric.unit
    else:
        f = dict.fromkeys(declared, 1.0)
        units = {declared[c] for c in columns["signals"]}
        base = _unit(metric, units.pop()) if len(units) == 1 else ""
    sig = np.array([f[c] * metric.scale for c in columns["signals"]])
    ver = np.array([f[c] * metric.scale for c in columns["versus"]])
    dist = np.ones(len(columns["disturbances"]))
    return MetricConversion(sig, ver, dist, value_unit(metric.kind, base, _disturbance_unit(sim, columns)))


def _convert(source: str, target: str, where: str, what: str) -> float:
    try:
        return conversion(source, target)
    except UnitError as exc:
        raise ScenarioError(f"{where}: {what}: {exc}") from None


def _angle_factor(metric: Metric, where: str) -> float:
    """rad -> the metric's unit, times its scale (an attitude_difference's signals are MRPs)."""
    if not metric.unit:
        return metric.scale
    f = _convert("rad", metric.unit, f"{where}.unit", f"{metric.kind} is an angle in rad")
    if metric.scale != 1.0 and f != 1.0:
        raise ScenarioError(f"{where}: scale {metric.scale:g} and unit {metric.unit!r} would both convert the "
                            "angle: drop 'scale'")
    return f * metric.scale


def _unit(metric: Metric, declared: str) -> str:
    """The declared unit when no hand-typed scale changed it, else unknown (``""``)."""
    return declared if metric.scale == 1.0 else ""


def _disturbance_unit(sim: CoSimulation, columns: dict[str, list[str]]) -> str:
    units = {sim.unit(c) for c in columns["disturbances"]}
    return units.pop() if len(units) == 1 else ""


def check(scenario: Scenario, sim: CoSimulation, expand: Any) -> None:
    """Every conversion of the scenario, made once at wiring so that a bad unit fails before a run.

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    sim : CoSimulation
        Its master, wired.
    expand : callable
        ``expand(names) -> columns``: base names to ``instance.variable`` columns.

    Raises
    ------
    ScenarioError
        Naming the ``record`` entry or the metric.
    """
    where = str(scenario.path) if scenario.path else f"scenario {scenario.name!r}"
    record_conversions(scenario, sim, expand(scenario.record))
    for i, m in enumerate(scenario.metrics):
        metric_conversion(m, sim, {k: expand(getattr(m, k)) for k in ("signals", "versus", "disturbances")},
                          f"{where}: metrics[{i}]")
