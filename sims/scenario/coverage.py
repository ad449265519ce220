"""What a controller's certificate covers of a scenario, or of a campaign's samples.

A certificate holds for one plant (``provenance.design_plant``: its parameters, or the intervals
of a robust design) and one region of states (``certificate.domain``,
:mod:`satfmu.controllers.domain`). A scenario whose plant has other parameters (an inertia
dispersed by +-20 %) or starts outside the region (an attitude beyond ``|sigma| <= 0.9``) is
flown outside what was proved: it may pass, but no proof says it will. For every loop of a
scenario (:func:`satfmu.sims.scenario.loops.find_loops`) this module says which samples start
outside, and why, counted by reason:

- the certificate proves nothing (status ``not_verified``): every sample;
- a plant parameter is not its design value, or lies outside its design interval
  (:func:`satfmu.controllers.artifact.plant_mismatches`, relative tolerance
  :data:`satfmu.controllers.artifact.DESIGN_RTOL`);
- the controller's measured inputs at the start time (the plant's outputs at its initial state,
  from the symbolic model) violate a constraint of the domain.

Only the start is checked: a trajectory that starts inside may still leave the region (a
certificate's own invariance claims say when it cannot). An artifact that states its region in
words only (no ``domain``) has its parameters checked and its states not, and says so.
"""
from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from satfmu.sims.scenario import loops
from satfmu.sims.scenario.spec import Scenario


@dataclass
class Coverage:
    """What one loop's certificate covers of a set of samples.

    Attributes
    ----------
    loop : satfmu.sims.scenario.loops.Loop
        The controller and plant instances.
    status : str
        The certificate's status (``certified``, ``sampled``, ``not_verified``).
    region : str
        The certified region in words (``certificate.region``).
    samples : int
        Samples checked.
    outside : int
        Samples that start outside what the certificate covers.
    reasons : dict of str to int
        Samples per reason (a sample may have several): ``"|sigma[1..3]| > 0.9"``,
        ``"I_x is not its design value 15"``.
    notes : list of str
        What could not be checked (a region in words only, a plant without a symbolic model).
    """

    loop: loops.Loop
    status: str
    region: str
    samples: int = 0
    outside: int = 0
    reasons: dict[str, int] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)

    @property
    def fraction(self) -> float:
        """Fraction of the samples outside, in [0, 1] (NaN when none was checked)."""
        return self.outside / self.samples if self.samples else float("nan")

    @property
    def label(self) -> str:
        """The loop's label (``controller (model) on plant (model)``)."""
        return self.loop.label


def _artifact(name: str) -> Any:
    """The parsed artifact of a controller model, None when it has none (B-dot, a sensor-fed law)."""
    from satfmu.controllers import artifact, paths

    try:
        return artifact.load(paths.find_artifact(name))
    except FileNotFoundError:
        return None


def _reasons(art: Any, loop: loops.Loop, plant_values: dict[str, float], plant_in: dict[str, float],
             scenario: Scenario, notes: list[str]) -> list[str]:
    """The reasons one start (the plant's parameter and initial-state values) lies outside."""
    from satfmu.controllers import artifact, domain

    out = []
    if art.certificate["status"] == "not_verified":
        out.append("the certificate proves nothing (status not_verified)")
    for line in artifact.plant_mismatches(art, loop.plant_model, dict(plant_values)):
        name, _, rest = line.partition(" = ")
        design = rest.split("(designed for ", 1)[-1].rstrip(")")
        out.append(f"{name} outside its design interval {design}" if design.startswith("[")
                   else f"{name} is not its design value {design}")
    dom = art.certificate.get("domain")
    if dom is None:
        return out
    pm = loops.model(loop.plant_model)
    y0 = loops.outputs_at(pm, tuple(o for o, _ in loop.measurement), loops.start_state(pm, plant_values),
                          plant_in, plant_values, scenario.start_time)
    values = {i: float(v) for (_, i), v in zip(loop.measurement, y0)}
    try:
        out += [f"starts outside {label}" for label, _ in domain.violations(dom, values)]
    except KeyError as exc:
        notes.append(f"the domain names inputs the loop does not measure ({exc.args[0]}): the start is not checked")
    return out


def coverage(scenario: Scenario, rows: pd.DataFrame | None = None,
             dispersed: list[tuple[str, str]] | None = None) -> list[Coverage]:
    """What each loop's certificate covers of a scenario, or of a campaign's samples.

    Parameters
    ----------
    scenario : Scenario
        The (nominal) scenario.
    rows : pandas.DataFrame, optional
        A campaign's rows: one per sample, a column ``<instance>.<name>`` per dispersed value
        (:mod:`satfmu.sims.campaign.scenario_task`). Default: the scenario itself, one sample.
    dispersed : list of (str, str), optional
        The dispersed values' ``(instance, name)`` (the campaign task's ``dispersed``); needed with ``rows``.

    Returns
    -------
    list of Coverage
        One per loop whose controller has a design artifact, in the order of
        :func:`satfmu.sims.scenario.loops.find_loops`.
    """
    found, _ = loops.find_loops(scenario)
    out = []
    for loop in found:
        art = _artifact(loop.controller_model)
        if art is None:
            continue
        cov = Coverage(loop, art.certificate["status"], art.certificate["region"])
        if "domain" not in art.certificate and cov.status != "not_verified":
            cov.notes.append(f"the region is stated in words only ({cov.region}): the starts are not checked "
                             f"against it, the plant's parameters are")
        pm = loops.model(loop.plant_model)
        nominal = {**{v.name: float(v.start) for v in pm.parameters if v.start is not None},
                   **loops.numbers(scenario.fmus[loop.plant].parameters)}
        plant_in = loops.exogenous(scenario, loop.plant, {i for _, i in loop.actuation})
        mine = [name for owner, name in (dispersed or []) if owner == loop.plant]
        columns = [f"{loop.plant}.{name}" for name in mine]
        starts: list[tuple[Any, ...]]
        if rows is None or not mine:
            starts = [()] * (1 if rows is None else len(rows))
        else:
            starts = list(rows[columns].itertuples(index=False, name=None))
        counts: Counter[str] = Counter()
        cache: dict[tuple, list[str]] = {}
        for values in starts:
            if any(isinstance(v, float) and np.isnan(v) for v in values):
                continue  # a sample whose draw was refused: it did not start
            if values not in cache:
                cache[values] = _reasons(art, loop, {**nominal, **dict(zip(mine, map(float, values)))},
                                         plant_in, scenario, cov.notes)
            reasons = cache[values]
            cov.samples += 1
            cov.outside += bool(reasons)
            counts.update(reasons)
        cov.reasons = dict(counts.most_common())
        cov.notes = list(dict.fromkeys(cov.notes))
        out.append(cov)
    return out
