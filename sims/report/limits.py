"""Requirement and actuator-limit lines of a plotted signal.

A metric's bounds apply to a signal it measures, in the metric's scaled unit (``scale``:
rad -> deg); drawn on the signal, they are divided by the scale:

- ``final``: ``|y(T)| <= max`` (and ``>= min``), a level over the last part of the run;
- ``peak``: ``|y| <= max`` everywhere (``min``: the peak must reach it);
- ``settling_time``: the band ``|y| <= tolerance``, and the time ``max`` by which the signal
  must have entered it for good;
- ``time_in_saturation``: the saturation level ``limit``.

The other kinds (``rms``, ``l2_ratio``, ``integral_square``, ``max_difference``) bound a
functional of the signal, not its values: they draw nothing.

An actuator limit is an FMU parameter ``<x>_max`` whose description says it is a limit
(``u_max``: "Actuator torque limit per axis", ``m_max``: "Magnetorquer dipole limit")
on the instance's variable ``<x>``; it is drawn on that variable and on every signal
connected to it, with the value the scenario sets, else the FMU's declared start, and marked
inactive when the instance's ``saturation_on`` switch is off.
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Mapping, Sequence

from satfmu.sims.scenario.metrics import MARGIN_KINDS
from satfmu.sims.scenario.spec import Scenario
from satfmu.sims.report.folders import FmuFile

_INDEX = re.compile(r"\[[\d,]+\]$")


def base(signal: str) -> str:
    """``instance.variable`` without its index: ``plant.omega[2]`` -> ``plant.omega``.

    Parameters
    ----------
    signal : str
        A qualified signal, indexed (``plant.omega[2]``, ``plant.C[1,2]``) or not.
    """
    return _INDEX.sub("", signal)


@dataclass(frozen=True)
class Line:
    """A reference line of a plot.

    Parameters
    ----------
    kind : {"requirement", "actuator"}
        A metric's bound, or an actuator limit.
    axis : {"level", "time"}
        A level of the signal (horizontal, in the signal's unit) or a time (vertical, s).
    value : float
        The level or the time.
    symmetric : bool
        A level drawn at ``+value`` and ``-value`` (a bound on ``|y|``).
    label : str
        What it is, with the value in the metric's (or parameter's) own unit.
    span : (float, float)
        Part of the time axis a level covers, as fractions (``final``: the end of the run).
    active : bool
        False for an actuator limit whose saturation is switched off (drawn fainter).
    """

    kind: str
    axis: str
    value: float
    symmetric: bool
    label: str
    span: tuple[float, float] = (0.0, 1.0)
    active: bool = True


@dataclass(frozen=True)
class ActuatorLimit:
    """A limit parameter of an FMU instance and the variable it limits.

    Parameters
    ----------
    instance : str
    parameter : str
        ``<x>_max``.
    target : str
        ``instance.<x>`` (a base name).
    value : float
        The scenario's start value, else the FMU's declared start, in ``unit``.
    unit : str
    active : bool
        False when the instance's ``saturation_on`` is off (true when it has no such switch).
    """

    instance: str
    parameter: str
    target: str
    value: float
    unit: str
    active: bool

    @property
    def label(self) -> str:
        """``plant.u_max = 5 N.m`` (with ``, saturation off`` when inactive)."""
        return f"{self.instance}.{self.parameter} = {self.value:g} {self.unit}" + (
            "" if self.active else " (saturation off)")


def actuator_limits(scenario: Scenario, fmus: Mapping[str, FmuFile]) -> list[ActuatorLimit]:
    """The actuator limits of a scenario's FMU instances (read from their model descriptions).

    Parameters
    ----------
    scenario : Scenario
        Its start values override the FMUs' declared starts.
    fmus : dict of str to FmuFile
        The instances' FMU files; one that is gone or unreadable contributes nothing.

    Returns
    -------
    list of ActuatorLimit
    """
    from satfmu.fmus import archive

    out = []
    for inst, f in fmus.items():
        try:
            md = archive.read_description(f.path)
        except (OSError, archive.UnsafeFmuError):  # gone or unreadable: the report's FMU sections say so
            continue
        variables = {v.name: v for v in md.modelVariables}
        bases = {_INDEX.sub("", n) for n in variables}
        given = scenario.fmus[inst].parameters

        def start(name: str) -> float | None:
            if name in given and isinstance(given[name], (bool, int, float)):
                return float(given[name])
            v = variables.get(name)
            if v is None or v.start is None:
                return None
            text = str(v.start).strip().lower()
            return 1.0 if text == "true" else 0.0 if text == "false" else float(text)

        switch = start("saturation_on")
        for name, v in variables.items():
            m = re.fullmatch(r"(\w+)_max", name)
            if (m is None or v.causality != "parameter" or "limit" not in (v.description or "").lower()
                    or m[1] not in bases):
                continue
            value = start(name)
            if value is not None:
                unit = getattr(v, "unit", None) or getattr(getattr(v, "declaredType", None), "unit", None) or ""
                out.append(ActuatorLimit(inst, name, f"{inst}.{m[1]}", value, unit, switch is None or switch != 0.0))
    return out


def _connected(scenario: Scenario, signal: str) -> set[str]:
    """``signal`` (a base name) and the base names connected to it, either way."""
    out = {signal}
    for c in scenario.connections:
        a, b = base(c.source), base(c.target)
        if signal in (a, b):
            out |= {a, b}
    return out


def _scaled(scale: float) -> str:
    """How a tolerance or limit relates to the signal when a hand-typed ``scale`` weighs it."""
    return "" if scale == 1.0 else f" (signal × {scale:g})"


def _factor(source: str, target: str) -> float | None:
    """``k`` with ``v`` in ``source`` = ``k v`` in ``target``; None when the two do not convert."""
    from satfmu.fmus.errors import UnitError
    from satfmu.fmus.units import conversion

    if not source or not target or source == target:
        return 1.0
    try:
        return conversion(source, target)
    except UnitError:
        return None


def signal_lines(scenario: Scenario, signal: str, limits: Sequence[ActuatorLimit] = (), unit: str = "",
                 declared: str = "") -> list[Line]:
    """The requirement and actuator-limit lines of a recorded signal, in the unit it is drawn in.

    Parameters
    ----------
    scenario : Scenario
        Its metrics give the requirement lines (module docstring).
    signal : str
        ``instance.variable``, a base name (``plant.omega``, every index) or one column.
    limits : list of ActuatorLimit
        :func:`actuator_limits` of the scenario.
    unit : str, optional
        The unit the signal is drawn in (a ``record`` entry's, else its declared one); a bound
        in a metric's unit (``deg``) is converted to it. Default: the declared one.
    declared : str, optional
        The signal's declared unit (that of a metric without ``unit``). Default: ``unit``.

    Returns
    -------
    list of Line
        In the signal's unit (levels) or s (times); a bound whose unit does not convert to the
        signal's is left out.
    """
    b = base(signal)
    declared = declared or unit
    shown = unit or declared
    out = []
    for m in scenario.metrics:
        if not any(base(s) == b for s in m.signals) or m.kind in MARGIN_KINDS:
            continue
        factor = _factor(shown, m.unit or declared)
        if factor is None:
            continue
        scale = (abs(m.scale) or 1.0) * factor
        unit_text = f" {m.unit or declared}" if (m.unit or declared) else ""
        if m.kind in ("final", "peak"):
            span = (0.85, 1.0) if m.kind == "final" else (0.0, 1.0)
            what = "|y(T)|" if m.kind == "final" else "|y|"
            for bound, op in ((m.max, "≤"), (m.min, "≥")):
                if bound is not None:
                    label = f"{m.name}: {what} {op} {bound:g}{unit_text}" if m.kind == "final" or op == "≤" else \
                        f"{m.name}: peak {op} {bound:g}{unit_text}"
                    out.append(Line("requirement", "level", bound / scale, True, label, span))
        elif m.kind == "settling_time":
            if m.tolerance is not None:
                out.append(Line("requirement", "level", float(m.tolerance) / scale, True,
                                f"{m.name}: band |y| ≤ {m.tolerance:g}{unit_text}{_scaled(m.scale)}"))
            if m.max is not None:
                out.append(Line("requirement", "time", float(m.max), False, f"{m.name}: settled by {m.max:g} s"))
        elif m.kind == "time_in_saturation" and m.limit is not None:
            out.append(Line("actuator", "level", float(m.limit) / scale, True,
                            f"{m.name}: saturation level {m.limit:g}{unit_text}{_scaled(m.scale)}"))
        elif m.kind == "time_to_limit" and m.limit is not None:
            out.append(Line("actuator", "level", float(m.limit) / scale, True,
                            f"{m.name}: level {m.limit:g}{unit_text}{_scaled(m.scale)}"))
    for lim in limits:
        factor = _factor(lim.unit, shown)
        if b in _connected(scenario, lim.target) and factor is not None:
            out.append(Line("actuator", "level", lim.value * factor, True, lim.label, active=lim.active))
    return out
