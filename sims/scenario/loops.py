"""The feedback loops of a scenario, linearized from their symbolic models, and their margins.

A loop is a controller instance and a plant instance connected both ways: controller outputs
drive plant inputs (the actuation) and plant outputs feed controller inputs (the measurement),
whatever the signals are called (DEMETER's ``u_c`` and ``theta``, the VSCMG's ``T1`` and ``q2``).
Of the two, the controller is the model that lists driven inputs (``driven_inputs`` of
:class:`satfmu.fmus.model.Model`). Both are linearized from their symbolic models
(:class:`satfmu.fmus.linearization.Linearizer`) with the scenario's parameters, at two
operating points:

- ``origin``: every state of both at 0, the controller's inputs outside the loop (references) at
  0 (the equilibrium a regulator brings the spacecraft to);
- ``start``: the plant's initial state as the scenario sets it, the controller's states at 0,
  its inputs outside the loop (a servo's references) at their values at the start time. Away
  from an equilibrium this is the frozen-point loop of the manoeuvre's first instant.

At both, the plant's inputs outside the loop (the environment) take their values at the start
(:func:`exogenous`), and the loop's torques are 0: the plants are affine in them, so the
linearization does not depend on them. The margins (:func:`satfmu.synthesis.core.margins.margins`)
are those of the loop broken at the plant inputs, continuous and sampled at the scenario's
communication step (the zero-order hold of a co-simulation).

A controller that samples (an online SDRE, B-dot, a periodic law, an estimator) has no
time-invariant loop: its loops are listed with the reason and no margins. So is an instance
given by an FMU file (no symbolic model), and a loop that runs through sensors or an estimator
(no direct pair).
"""
from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from satfmu.fmus.linearization import Linearization, Linearizer
from satfmu.fmus.model import Model
from satfmu.sims.scenario.spec import Scenario

POINTS = ("origin", "start")
"""The operating points of :func:`scenario_margins` (the module docstring)."""
@dataclass(frozen=True)
class Loop:
    """A controller instance and the plant instance it closes a loop on.

    Attributes
    ----------
    controller, plant : str
        Instance names.
    controller_model, plant_model : str
        Their model names.
    actuation : tuple of (str, str)
        (controller output, plant input) variable pairs, in the scenario's order.
    measurement : tuple of (str, str)
        (plant output, controller input) variable pairs.
    """

    controller: str
    plant: str
    controller_model: str
    plant_model: str
    actuation: tuple[tuple[str, str], ...]
    measurement: tuple[tuple[str, str], ...]

    @property
    def label(self) -> str:
        """``controller (model) on plant (model)``."""
        return f"{self.controller} ({self.controller_model}) on {self.plant} ({self.plant_model})"


@dataclass(frozen=True)
class LoopMargins:
    """The margins of one loop at one operating point.

    Attributes
    ----------
    loop : Loop
        The loop.
    point : str
        One of :data:`POINTS`.
    continuous, sampled : satfmu.synthesis.core.margins.Margins or None
        The loop in continuous time and sampled at ``sample_time``; None when ``note`` says why.
    sample_time : float
        The scenario's communication step, s.
    note : str
        Why there are no margins (a sampled law, no symbolic model); empty when there are.
    plant, controller : Linearization or None
        The linearizations the margins are of (named for
        :func:`satfmu.synthesis.core.margins.margins`); None with a note.
    """

    loop: Loop
    point: str
    continuous: Any
    sampled: Any
    sample_time: float
    note: str = ""
    plant: Linearization | None = None
    controller: Linearization | None = None


_MODELS: dict[tuple[str, str], Model] = {}
_LINEARIZERS: dict[tuple[int, tuple[str, ...], tuple[str, ...]], Linearizer] = {}


def model(name: str) -> Model:
    """The symbolic model of a model or artifact name (:func:`satfmu.controllers.catalog.source`),
    kept for the process (an artifact's by the SHA-256 of its file: a rewritten one is read anew).

    Parameters
    ----------
    name : str
        Model or artifact name.
    """
    from satfmu.controllers import catalog, paths

    try:
        digest = hashlib.sha256(paths.find_artifact(name).read_bytes()).hexdigest()
    except FileNotFoundError:
        digest = ""
    key = (name, digest)
    if key not in _MODELS:
        _MODELS[key] = catalog.source(name).model
    return _MODELS[key]


def _linearizer(m: Model, inputs: tuple[str, ...], outputs: tuple[str, ...]) -> Linearizer:
    key = (id(m), inputs, outputs)
    if key not in _LINEARIZERS:
        _LINEARIZERS[key] = Linearizer(m, inputs, outputs)
    return _LINEARIZERS[key]


def _expand(names: list[str], name: str) -> list[str]:
    """A base name's elements among ``names`` (``omega`` -> ``omega[1..3]``), or the name itself."""
    if name in names:
        return [name]
    return [n for n in names if n.startswith(f"{name}[")]


def find_loops(scenario: Scenario) -> tuple[list[Loop], list[str]]:
    """The scenario's controller-plant loops, and a note for each instance pair left out.

    Parameters
    ----------
    scenario : Scenario
        The scenario.

    Returns
    -------
    loops : list of Loop
    notes : list of str
        Why a connected pair is no loop (an FMU file, no controller among the two).
    """
    links: dict[tuple[str, str], list[tuple[str, str]]] = {}
    for c in scenario.connections:
        (src, out), (dst, inp) = c.source.split(".", 1), c.target.split(".", 1)
        links.setdefault((src, dst), []).append((out, inp))
    loops, notes = [], []
    for (a, b), forward in links.items():
        back = links.get((b, a))
        if not back or (b, a) < (a, b):
            continue  # one direction only, or the pair seen from its other side
        specs = scenario.fmus[a], scenario.fmus[b]
        if specs[0].model is None or specs[1].model is None:
            notes.append(f"{a} and {b}: an FMU file has no symbolic model to linearize")
            continue
        models = model(specs[0].model), model(specs[1].model)
        driven = [bool(m.driven_inputs) for m in models]
        if driven[0] == driven[1]:
            notes.append(f"{a} and {b}: neither or both list driven inputs, so neither is the controller")
            continue
        (ctrl, plant), (cm, pm), (act, meas) = ((a, b), models, (forward, back)) if driven[0] else \
            ((b, a), models[::-1], (back, forward))
        pairs = []
        for links_, (src_m, dst_m) in ((act, (cm, pm)), (meas, (pm, cm))):
            outs = [o.variable.name for o in src_m.outputs]
            ins = [v.name for v in dst_m.inputs]
            expanded = []
            for out, inp in links_:
                o, i = _expand(outs, out), _expand(ins, inp)
                expanded += list(zip(o, i))
            pairs.append(tuple(expanded))
        loops.append(Loop(ctrl, plant, cm.name, pm.name, pairs[0], pairs[1]))
    return loops, notes


def numbers(values: dict[str, Any]) -> dict[str, float]:
    """The numeric start values of a scenario's ``parameters`` table (switches and strings left out).

    Parameters
    ----------
    values : dict
        Name -> start value.
    """
    return {k: float(v) for k, v in values.items() if isinstance(v, (int, float))}


def _parameters(m: Model, values: dict[str, Any]) -> dict[str, float]:
    """The start values a scenario sets that are parameters of ``m`` (its inputs' are not)."""
    names = {p.name for p in m.parameters}
    return {k: v for k, v in numbers(values).items() if k in names}


def start_state(m: Model, parameters: dict[str, Any]) -> dict[str, float]:
    """A model's initial state with the scenario's start values.

    Parameters
    ----------
    m : Model
        The symbolic model.
    parameters : dict
        Start values by parameter name (a scenario's ``parameters`` table); the rest at their defaults.
    """
    params = {**{v.name: float(v.start) for v in m.parameters}, **numbers(parameters)}
    return {s.variable.name: params[s.initial.name] for s in m.states}


def outputs_at(m: Model, outputs: tuple[str, ...], state: dict[str, float], inputs: dict[str, float] | None,
               parameters: dict[str, Any], time: float) -> np.ndarray:
    """A model's outputs at a state, its inputs and parameters (inputs not given at 0).

    Parameters
    ----------
    m : Model
        The symbolic model.
    outputs : tuple of str
        Output names.
    state : dict of str to float
        State values by name.
    inputs : dict of str to float, optional
        Input values by name (None: all at 0).
    parameters : dict
        Start values by parameter name (those that are no parameters of ``m`` are ignored).
    time : float
        Time, s.
    """
    return _linearizer(m, (), outputs)(state, inputs, _parameters(m, parameters), time).y0


def exogenous(scenario: Scenario, instance: str, skip: set[str]) -> dict[str, float]:
    """The values at the start time of an instance's inputs that the loop does not drive: a start
    value the scenario sets, a profile's value, or the output at its initial state of the FMU
    connected to it (the orbit and environment model's field and air speed, say).

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    instance : str
        The instance.
    skip : set of str
        Its inputs the loop drives (left out).
    """
    from satfmu.sims.scenario.wiring import profiles

    m = model(scenario.fmus[instance].model or "")
    names = [v.name for v in m.inputs]
    out = {k: v for k, v in numbers(scenario.fmus[instance].parameters).items() if k in names and k not in skip}
    for target, prof in profiles(scenario):
        inst, var = target.split(".", 1)
        if inst == instance:
            for name in _expand(names, var):
                if name not in skip:
                    out[name] = float(np.ravel(prof.sample(np.array([scenario.start_time])))[0])
    for c in scenario.connections:
        (src, out_var), (dst, in_var) = c.source.split(".", 1), c.target.split(".", 1)
        spec = scenario.fmus[src]
        if dst != instance or spec.model is None:
            continue
        sm = model(spec.model)
        if sm.driven_inputs:
            continue  # a controller's or a sensor's output depends on its inputs: left at 0
        outs = _expand([o.variable.name for o in sm.outputs], out_var)
        targets = [n for n in _expand(names, in_var) if n not in skip]
        if not targets:
            continue
        values = outputs_at(sm, tuple(outs), start_state(sm, spec.parameters), None, spec.parameters,
                            scenario.start_time)
        out.update(zip(targets, map(float, values)))
    return out


def operating_point(scenario: Scenario, loop: Loop, point: str
                    ) -> tuple[dict[str, float], dict[str, float], dict[str, float]]:
    """The plant's state and the values of the inputs outside the loop at ``point``.

    At both points the plant's inputs outside the loop take their values at the start
    (:func:`exogenous`: the environment as it is when the run starts). At ``origin`` every state
    is 0 and so are the controller's inputs outside the loop (references: the origin); at
    ``start`` the plant's state is its initial one and the controller's inputs outside the loop
    take their start values.

    Parameters
    ----------
    scenario : Scenario
        The scenario (start values, profiles, connected FMUs).
    loop : Loop
        The loop.
    point : str
        One of :data:`POINTS`.

    Returns
    -------
    plant_state : dict of str to float
        Plant state values by name.
    plant_inputs : dict of str to float
        Values of the plant inputs not in the loop.
    controller_inputs : dict of str to float
        Values of the controller inputs not in the loop.
    """
    if point not in POINTS:
        raise ValueError(f"operating point must be one of {POINTS}, got {point!r}")
    plant_in = exogenous(scenario, loop.plant, {i for _, i in loop.actuation})
    if point == "origin":
        return {}, plant_in, {}
    state = start_state(model(loop.plant_model), scenario.fmus[loop.plant].parameters)
    return state, plant_in, exogenous(scenario, loop.controller, {i for _, i in loop.measurement})


def linearize_loop(scenario: Scenario, loop: Loop, point: str = "origin") -> tuple[Linearization, Linearization]:
    """The plant and the controller of ``loop`` linearized at ``point``, named for
    :func:`satfmu.synthesis.core.margins.margins` (the plant's inputs and outputs renamed after the
    controller outputs and inputs they connect to).

    Parameters
    ----------
    scenario : Scenario
        The scenario (its parameters and profiles).
    loop : Loop
        One of :func:`find_loops`.
    point : str
        One of :data:`POINTS`.

    Returns
    -------
    plant, controller : Linearization

    Raises
    ------
    ValueError
        A sampled law, or a Jacobian that is not finite at the point.
    """
    pm, cm = model(loop.plant_model), model(loop.controller_model)
    state, plant_in, ctrl_in = operating_point(scenario, loop, point)
    p_in = tuple(i for _, i in loop.actuation)
    p_out = tuple(o for o, _ in loop.measurement)
    c_in = tuple(i for _, i in loop.measurement)
    c_out = tuple(o for o, _ in loop.actuation)
    p_params = _parameters(pm, scenario.fmus[loop.plant].parameters)
    c_params = _parameters(cm, scenario.fmus[loop.controller].parameters)
    P = _linearizer(pm, p_in, p_out)(state, plant_in, p_params, scenario.start_time)
    # the controller reads the plant's outputs at the point (the plant's feedthrough is 0 at u = 0)
    y = {o: float(v) for o, v in zip(c_in, P.y0)}
    K = _linearizer(cm, c_in, c_out)({}, {**ctrl_in, **y}, c_params, scenario.start_time)
    return replace(P, inputs=c_out, outputs=c_in), K


def scenario_margins(scenario: Scenario, points: tuple[str, ...] = POINTS) -> tuple[list[LoopMargins], list[str]]:
    """The margins of every loop of the scenario at each operating point.

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    points : tuple of str
        Operating points, of :data:`POINTS`.

    Returns
    -------
    margins : list of LoopMargins
        Loop by loop, point by point.
    notes : list of str
        The connected pairs that are no loop, and why.
    """
    from satfmu.synthesis.core import margins as loop_margins

    loops, notes = find_loops(scenario)
    out = []
    for loop in loops:
        for point in points:
            if model(loop.controller_model).sampler is not None:
                out.append(LoopMargins(loop, point, None, None, scenario.step_size,
                                       f"{loop.controller_model} samples (its gain or output changes at sample "
                                       "instants): no linear time-invariant loop"))
                continue
            try:
                P, K = linearize_loop(scenario, loop, point)
                found = loop_margins.margins(P, K), loop_margins.margins(P, K, scenario.step_size)
            except ValueError as exc:  # a law singular there (backstepping at q2 = 0), no loop at the point
                out.append(LoopMargins(loop, point, None, None, scenario.step_size, f"no linearization here: {exc}"))
                continue
            out.append(LoopMargins(loop, point, *found, scenario.step_size, plant=P, controller=K))
    return out, notes


def margin_metric(kind: str, scenario: Scenario, signals: list[str]) -> float:
    """The value of a margin metric (:data:`~satfmu.sims.scenario.metrics.MARGIN_KINDS`): the loop
    broken at the plant inputs ``signals``, at the origin, sampled at the scenario's communication step.

    Parameters
    ----------
    kind : str
        One of :data:`~satfmu.sims.scenario.metrics.MARGIN_KINDS`.
    scenario : Scenario
        The scenario (a campaign's sample: its parameters).
    signals : list of str
        ``instance.variable`` plant inputs, expanded.

    Returns
    -------
    float
        dB, deg, s or 1 (:data:`~satfmu.sims.scenario.metrics.MARGIN_KINDS`); NaN (which fails any
        bound) when the loop has no margins (a sampled law) or no loop holds those inputs.
    """
    from satfmu.synthesis.core import margins as loop_margins

    loops, _ = find_loops(scenario)
    wanted = set(signals)
    for loop in loops:
        names = {f"{loop.plant}.{i}": o for o, i in loop.actuation}
        if not wanted <= set(names):
            continue
        if model(loop.controller_model).sampler is not None:
            return math.nan
        P, K = linearize_loop(scenario, loop, "origin")
        m = loop_margins.margins(P, K, scenario.step_size)
        channels = [lm for lm in m.loops if lm.channel in {names[s] for s in wanted}]
        if kind == "gain_margin":
            return min(lm.gain_margin_db for lm in channels)
        if kind == "phase_margin":
            return min(lm.phase_margin_deg for lm in channels)
        if kind == "delay_margin":
            return min(lm.delay_margin for lm in channels)
        return float({"disk_gain_margin": m.disk_gain_margin_db, "disk_phase_margin": m.disk_phase_margin_deg,
                      "sensitivity_peak": m.sensitivity_peak, "complementary_peak": m.complementary_peak}[kind])
    return math.nan
