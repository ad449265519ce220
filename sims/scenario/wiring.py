"""Wiring a scenario's master: FMUs loaded, connected and fed profiles, names and start values checked.

:func:`wire` makes the master and refuses, naming the key path, what it would refuse at run time;
:func:`recorded` and :func:`recorded_times` are what a run of it records and when.
"""
from __future__ import annotations

import re
import warnings
from pathlib import Path

import numpy as np

from satfmu.fmus.errors import DesignMismatchWarning, ScenarioError
from satfmu.fmus.profiles import Profile
from satfmu.fmus.profiles import make as make_profile
from satfmu.sims.cosim.master import (CoSimulation, UnknownVariableError, WiringError, communication_times,
                                      recorded_steps, start_value)
from satfmu.sims.scenario import conversions
from satfmu.sims.scenario.metrics import MARGIN_KINDS
from satfmu.sims.scenario.provisioning import fmu_paths
from satfmu.sims.scenario.spec import Scenario


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


def _connected_to(scenario: Scenario, instance: str) -> set[str]:
    """The instances a connection links directly with ``instance`` (either way)."""
    out = set()
    for c in scenario.connections:
        src, dst = c.source.split(".", 1)[0], c.target.split(".", 1)[0]
        if src == instance:
            out.add(dst)
        if dst == instance:
            out.add(src)
    return out


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
            if pname == cname or pname not in _connected_to(scenario, cname):
                continue  # only the plants the controller is wired to: another loop's plant is not its
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
    signals and ``versus`` signals of different lengths, an input meant to be driven that
    nothing drives (:func:`undriven`; unless ``unconnected = "zero"``). A controller paired with a plant
    other than its design plant is reported by a :class:`DesignMismatchWarning` (the lines
    are in ``sim.mismatches``), or refused with ``strict``.

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    fmu_dir : Path
        Folder of the FMUs named by ``model`` (:func:`satfmu.sims.scenario.provisioning.ensure_fmus` has
        made them).
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
        driven = _wire(scenario, sim, where)
        _check_parameters(scenario, sim, where)
        if scenario.unconnected == "error":
            _check_driven(scenario, sim, where, driven)
        _check_dispersions(scenario, sim, where)
        _check_signals(scenario, sim, where)
    except BaseException:
        sim.close()
        raise
    return sim


def _wire(scenario: Scenario, sim: CoSimulation, where: str) -> set[str]:
    """Connect and feed profiles, each scalar input driven once; refuse algebraic loops. Returns
    the inputs driven (``instance.variable``)."""
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
    return set(driven)


def undriven(scenario: Scenario, sim: CoSimulation, driven: set[str]) -> dict[str, list[str]]:
    """The inputs meant to be driven that nothing drives, by instance.

    An input is meant to be driven when its FMU lists it (``VendorAnnotations``,
    :func:`satfmu.fmus.annotations.driven_inputs`: a controller's, a sensor's or an estimator's
    measurements) or declares no start value. A start value the scenario sets for it counts as
    driving it (held constant).

    Parameters
    ----------
    scenario : Scenario
        The scenario (its start values).
    sim : CoSimulation
        Its master, the FMUs loaded.
    driven : set of str
        ``instance.variable`` of every input a connection or a profile drives.

    Returns
    -------
    dict of str to list of str
        Instance -> its undriven inputs (variable names, in the description's order); only
        instances with some.
    """
    from satfmu.fmus.annotations import driven_inputs

    out = {}
    for inst, comp in sim.components.items():
        listed = set(driven_inputs((Path(comp.unzip_dir) / "modelDescription.xml").read_bytes()))
        set_here = set(scenario.fmus[inst].parameters)
        missing = [v.name for v in comp.model_description.modelVariables
                   if v.causality == "input" and (v.name in listed or v.start is None)
                   and f"{inst}.{v.name}" not in driven and v.name not in set_here]
        if missing:
            out[inst] = missing
    return out


def _check_driven(scenario: Scenario, sim: CoSimulation, where: str, driven: set[str]) -> None:
    """Refuse inputs meant to be driven that nothing drives (:func:`undriven`), naming them."""
    missing = undriven(scenario, sim, driven)
    if missing:
        lines = "; ".join(f"{inst} ({sim.components[inst].model_description.modelName}): "
                          f"{', '.join(_compact(names))}" for inst, names in missing.items())
        raise ScenarioError(f"{where}: connections: inputs meant to be driven are not connected, fed by a profile "
                            f"or given a start value: {lines}. Connect them, or set unconnected = \"zero\" at the "
                            "top of the scenario to run with their start values")


def _compact(names: list[str]) -> list[str]:
    """``omega[1], omega[2], omega[3]`` as ``omega[1..3]`` (consecutive indices of one base name)."""
    out: list[str] = []
    runs: list[tuple[str, int, int]] = []
    for n in names:
        m = re.fullmatch(r"(.+)\[(\d+)\]", n)
        if m and runs and runs[-1][0] == m[1] and runs[-1][2] + 1 == int(m[2]):
            runs[-1] = (m[1], runs[-1][1], int(m[2]))
        elif m:
            runs.append((m[1], int(m[2]), int(m[2])))
        else:
            runs.append((n, -1, -1))
    for base, lo, hi in runs:
        out.append(base if lo < 0 else f"{base}[{lo}]" if lo == hi else f"{base}[{lo}..{hi}]")
    return out


def _checked(sim: CoSimulation, name: str, where: str) -> None:
    """Resolve ``name`` in ``sim`` or raise a ScenarioError naming the key path."""
    try:
        sim.resolve(name)
    except UnknownVariableError as exc:
        raise ScenarioError(f"{where}: {exc}") from None


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
        if m.kind == "attitude_difference" and not n["signals"] == n["versus"] == 3:
            raise ScenarioError(f"{where}: metrics[{i}]: attitude_difference compares two MRPs, 3 variables "
                                f"each; got {n['signals']} in 'signals' and {n['versus']} in 'versus'")
    conversions.check(scenario, sim, lambda names: _columns(sim, names))
    margin = [(i, m) for i, m in enumerate(scenario.metrics) if m.kind in MARGIN_KINDS]
    if margin:
        from satfmu.sims.scenario.loops import find_loops

        found, notes = find_loops(scenario)
        broken = {f"{lp.plant}.{i}" for lp in found for _, i in lp.actuation}
        for i, m in margin:
            missing = [c for c in _columns(sim, m.signals) if c not in broken]
            if missing:
                raise ScenarioError(f"{where}: metrics[{i}].signals: {', '.join(missing)} is no plant input a "
                                    f"controller of the scenario drives (the loops break at: "
                                    f"{', '.join(sorted(broken)) or 'none'}{'; ' + '; '.join(notes) if notes else ''})")
