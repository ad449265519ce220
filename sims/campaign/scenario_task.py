"""The Monte Carlo campaign of a scenario's ``[dispersions]``: its task, size and identity.

The task runs and evaluates sample ``i``; :func:`campaign_size` gives the samples and seed a
campaign runs, :func:`context` its identity beside them, :func:`reopen` the campaign a folder holds.

:func:`campaign` makes a :class:`~satfmu.sims.campaign.engine.Campaign` whose samples are the global
sample indices (:func:`satfmu.sims.campaign.engine.sample_indices`): sample ``i`` runs
``scenario.sample(seed, i)`` through :func:`satfmu.sims.scenario.run.simulate` and
:func:`satfmu.sims.scenario.run.evaluate`, the path of :func:`satfmu.sims.scenario.run.run`, so its row depends on
``(seed, i)`` only, not on the chunk size, the workers or the order of the chunks. A worker
process wires the scenario's :class:`~satfmu.sims.cosim.master.CoSimulation` once
(:meth:`ScenarioTask.simulation`) and runs every sample through it
(:func:`satfmu.sims.scenario.run.resimulate`): the FMU instances are reset between samples, the step
loop is the compiled one (:mod:`satfmu.sims.cosim.compiled_loop`), and a row equals that of
:func:`satfmu.sims.scenario.run.run` of the sampled scenario bit for bit.

Columns of a row (all float64, as every campaign chunk): ``sample`` (global index), one per
metric (its value in the metric's unit, NaN for a sample that did not run; an infinite
value is a result, e.g. a settling time never reached), ``passed`` (1 if every
metric is within its bounds, else 0), ``failed`` (a code of :data:`FAILURES`, 0 when the
sample ran) and one per dispersed value (``plant.I_x``, ``profiles[0].after``; in the
parameter's unit). A failed sample is a row like any other: the campaign goes on. Its
message is not stored (chunk columns are numbers); as a sample is a pure function of
``(seed, index)``, :func:`explain` runs it again and returns it.

The statistics of the rows: :mod:`satfmu.sims.campaign.statistics`; a campaign run on Dask and its
result: :mod:`satfmu.sims.campaign.results`; one sample run again: :mod:`satfmu.sims.campaign.replay`.
"""
from __future__ import annotations

import atexit
import hashlib
import json
import math
import pickle
import socket
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from satfmu.fmus.errors import DesignMismatchWarning, ScenarioError
from satfmu.fmus.profiles import ProfileError
from satfmu.sims.campaign.engine import Campaign, CampaignError, sample_indices
from satfmu.sims.campaign.envelopes import POINTS, trace_columns, trace_steps
from satfmu.sims.campaign.shipment import Reference, bundle, localize
from satfmu.sims.cosim.master import CoSimulation, MasterError, UnknownVariableError
from satfmu.sims.scenario.conversions import record_conversions
from satfmu.sims.scenario.provisioning import context, nominal_values
from satfmu.sims.scenario.run import check, evaluate, plan_metrics, resimulate
from satfmu.sims.scenario.spec import Scenario, load
from satfmu.sims.scenario.wiring import recorded, recorded_times, wire

FAILURES = {0: "ran", 1: "an FMU call or the master failed (satfmu.sims.cosim.master.MasterError)",
            2: "the sampled scenario was refused (ScenarioError or ProfileError, e.g. a start value outside "
               "its declared range, a profile field its kind refuses)",
            3: "a recorded signal is not finite (NaN or infinite: the run diverged)"}
"""Code of the ``failed`` column -> what it means."""
_RESERVED = ("sample", "passed", "failed")


@dataclass(frozen=True)
class ScenarioTask:
    """Campaign task: sample ``i`` of the scenario's dispersions, run and evaluated.

    Built by :func:`campaign`; picklable (workers receive the scenario and the FMU folder's
    path, which they must be able to read).

    Parameters
    ----------
    scenario : Scenario
        With ``[dispersions]``.
    seed : int
        Campaign seed (>= 0).
    fmu_dir : str
        FMU folder, every FMU of the scenario present (:func:`satfmu.sims.scenario.run.check`).
    backend : {"native", "python"}
    dispersed : tuple of (str, str)
        (instance or ``"profiles[i]"``, parameter or field) of each dispersed value column.
    envelopes : tuple of str
        Recorded scalar signals whose time history each row keeps (:mod:`satfmu.sims.campaign.envelopes`),
        in the unit the scenario's ``record`` asks for (else the declared one).
    trace_steps : tuple of int
        The recorded rows (communication points) of those histories.
    """

    scenario: Scenario
    seed: int
    fmu_dir: str
    backend: str
    dispersed: tuple[tuple[str, str], ...]
    envelopes: tuple[str, ...] = ()
    trace_steps: tuple[int, ...] = ()

    @property
    def columns(self) -> list[str]:
        """The task's columns, in order: metrics, ``passed``, ``failed``, dispersed values."""
        return ([m.name for m in self.scenario.metrics] + ["passed", "failed"]
                + [f"{owner}.{name}" for owner, name in self.dispersed] + self.trace_columns)

    @property
    def trace_columns(self) -> list[str]:
        """The columns of the kept time histories (:func:`satfmu.sims.campaign.envelopes.trace_columns`)."""
        return [c for s in self.envelopes for c in trace_columns(s, len(self.trace_steps))]

    def shipment(self) -> tuple[tuple[Reference, ...], dict[str, bytes]]:
        """The files a worker needs, by content (:func:`satfmu.sims.campaign.shipment.bundle`)."""
        return bundle(self)

    def localized(self, refs: tuple[Reference, ...], files: dict[str, bytes]) -> "ScenarioTask":
        """This task on a worker, reading the shipped files from its cache
        (:func:`satfmu.sims.campaign.shipment.localize`).

        Parameters
        ----------
        refs : tuple of Reference
            What :meth:`shipment` names.
        files : dict of str to bytes
            SHA-256 -> content.
        """
        return localize(self, refs, files)

    def worker_info(self) -> dict[str, str]:
        """Where this process ran the task's samples: its host name and the master's loop
        (``compiled``, or ``python`` on a worker without a C compiler: the same rows)."""
        return {"host": socket.gethostname(), "loop": self.simulation().loop or "python"}

    def __call__(self, samples: np.ndarray) -> dict[str, np.ndarray]:
        """One value per column and sample index of ``samples``."""
        sim = self.simulation()
        rows = [self.run_sample(int(i), sim)[0] for i in samples]
        return {col: np.array([row[col] for row in rows], dtype=np.float64) for col in self.columns}

    def run_sample(self, index: int, sim: CoSimulation | None = None) -> tuple[dict[str, float], str | None]:
        """The row of sample ``index`` and, if it failed, its message (run through ``sim``, by
        default :meth:`simulation`).

        Parameters
        ----------
        index : int
            Global sample index (>= 0).
        sim : CoSimulation, optional
            This task's wired master (default: :meth:`simulation`); wired anew by the next
            sample when an FMU returned fmi2Fatal.

        Returns
        -------
        row : dict of str to float
            The task's columns (:attr:`columns`), NaN for the metrics of a sample that did not run.
        message : str or None
            Why the sample failed (the ``failed`` code is not 0), else None.
        """
        row = dict.fromkeys(self.columns, math.nan)
        sim = self.simulation() if sim is None else sim
        try:
            sampled = self.scenario.sample(self.seed, index, self.fmu_dir, self.backend, _NOMINAL[id(sim)])
        except ScenarioError as exc:
            return {**row, "passed": 0.0, "failed": 2.0}, str(exc)
        for owner, name in self.dispersed:
            row[f"{owner}.{name}"] = float(_value(sampled, owner, name))
        try:
            res = resimulate(sampled, sim)
            results, _ = evaluate(sampled, res, sim, _PLANS[id(sim)])
        except (MasterError, ScenarioError, ProfileError) as exc:
            if any(c.fatal for c in sim.components.values()):  # no further call allowed: wire anew
                _discard(sim)
            code = 1.0 if isinstance(exc, MasterError) else 2.0
            return {**row, "passed": 0.0, "failed": code}, str(exc)
        for m in results:
            row[m.name] = m.value
        steps = np.asarray(self.trace_steps, dtype=np.int64)
        # each kept history in the unit the scenario's record asks for (the declared one if none)
        shown = record_conversions(sampled, sim, list(self.envelopes)) if self.envelopes else {}
        for signal in self.envelopes:
            row.update(zip(trace_columns(signal, len(steps)), (res[signal][steps] * shown[signal][0]).tolist()))
        assert res.dtype.names is not None  # the master records a structured array
        bad = [c for c in res.dtype.names if not np.all(np.isfinite(res[c]))]
        row["passed"] = 0.0 if bad else float(all(m.passed for m in results))
        row["failed"] = 3.0 if bad else 0.0
        return row, (f"sample {index}: recorded signal(s) not finite: {', '.join(bad)}" if bad else None)

    def simulation(self) -> CoSimulation:
        """This process's master of the scenario, wired once and kept (``_WIRED``): its FMU
        instances are reset between samples (``reuse_instances``), not created again."""
        key = hashlib.sha256(pickle.dumps(self, protocol=4)).hexdigest()
        sim = _WIRED.pop(key, None)
        if sim is None:
            with warnings.catch_warnings():  # shown once, by the check of the nominal scenario
                warnings.simplefilter("ignore", DesignMismatchWarning)
                sim = wire(self.scenario, Path(self.fmu_dir), self.backend)
            sim.reuse_instances = True
            _NOMINAL[id(sim)] = nominal_values(self.scenario, self.fmu_dir, self.backend)
            _PLANS[id(sim)] = plan_metrics(self.scenario, sim)
            while len(_WIRED) >= _KEEP:
                _close(_WIRED.pop(next(iter(_WIRED))))
        _WIRED[key] = sim  # most recently used last
        return sim


_KEEP = 2
"""Wired masters a process keeps (two campaigns of one worker in turn)."""
_WIRED: dict[str, CoSimulation] = {}
"""This process's wired masters by task digest, least recently used first."""
_NOMINAL: dict[int, Any] = {}
"""The nominal values (:func:`satfmu.sims.scenario.provisioning.nominal_values`) of each kept master's scenario, read
once, by ``id`` of the master."""
_PLANS: dict[int, Any] = {}
"""The metrics of each kept master's scenario planned on it (:func:`satfmu.sims.scenario.run.plan_metrics`), by
``id`` of the master: a sample has its scenario's metrics."""


def _close(sim: CoSimulation) -> None:
    _NOMINAL.pop(id(sim), None)
    _PLANS.pop(id(sim), None)
    sim.close()


def _discard(sim: CoSimulation) -> None:
    """Drop a kept master (an FMU returned fmi2Fatal); the next sample wires a new one."""
    for key in [k for k, v in _WIRED.items() if v is sim]:
        _close(_WIRED.pop(key))


@atexit.register
def _close_wired() -> None:
    """Free the kept FMU instances and unload their libraries before the interpreter ends."""
    while _WIRED:
        _close(_WIRED.popitem()[1])


def _value(sampled: Scenario, owner: str, name: str) -> Any:
    """A dispersed value of a sampled scenario: a profile field or an FMU start value."""
    if owner.startswith("profiles["):
        return sampled.profiles[int(owner[len("profiles["):-1])][name]
    return sampled.fmus[owner].parameters[name]


def campaign(scenario: "str | Path | Mapping[str, Any] | Scenario", n: int, seed: int = 0, chunk: int | None = None,
             name: str | None = None, fmu_dir: str | Path | None = None, backend: str = "native",
             envelopes: Sequence[str] = (), points: int = POINTS) -> Campaign[ScenarioTask]:
    """The Monte Carlo campaign of a scenario's ``[dispersions]`` (run it with :func:`satfmu.sims.campaign.engine.run`).

    The nominal scenario is checked first (:func:`satfmu.sims.scenario.run.check`: its FMUs are built
    when missing, its wiring and start values checked), so a sample can fail only by its
    dispersed values or its run.

    Parameters
    ----------
    scenario : Scenario, dict, str or Path
        A scenario with ``[dispersions]``, its data, a TOML file or a shipped scenario's name.
    n : int
        Number of samples, >= 1.
    seed : int
        Campaign seed, >= 0.
    chunk : int, optional
        Samples per task and per Parquet file (the rows do not depend on it); default
        :func:`default_chunk` of ``n``.
    name : str, optional
        Campaign (folder) name; default ``<scenario>-n<n>-s<seed>``.
    fmu_dir : path, optional
        FMU folder (default: the FMU cache); the workers read the FMUs from it.
    backend : {"native", "python"}
    envelopes : sequence of str
        Recorded signals (base names expand) whose time history every row keeps at ``points``
        times, for percentile envelopes (:mod:`satfmu.sims.campaign.envelopes`).
    points : int
        Time points kept per signal and sample, >= 2 (at most the run's communication points).

    Returns
    -------
    Campaign
        Its task is a :class:`ScenarioTask`, its sampler :func:`satfmu.sims.campaign.engine.sample_indices`.

    Raises
    ------
    ScenarioError
        The scenario has no dispersions, names a column twice (a metric called ``sample``,
        ``passed`` or ``failed``), an envelope signal it does not record, or
        :func:`satfmu.sims.scenario.run.check` refuses it.
    satfmu.sims.campaign.engine.CampaignError
        An invalid n, seed, chunk, name or points.
    """
    sc = _canonical(load(scenario))
    where = str(sc.path) if sc.path else f"scenario {sc.name!r}"
    if sc.dispersions is None:
        raise ScenarioError(f"{where}: no [dispersions]: a campaign needs a scenario with dispersions")
    clash = [m.name for m in sc.metrics if m.name in _RESERVED]
    if clash:
        raise ScenarioError(f"{where}: metrics: the names {clash} are campaign columns; rename the metric(s)")
    folder = check(sc, fmu_dir, backend)
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise CampaignError(f"campaign of {where}: seed must be an integer >= 0, got {seed!r}")
    first = sc.dispersions.sample(int(seed), 0, nominal_values(sc, folder, backend), f"{where}: dispersions")
    dispersed = tuple((owner, p) for owner, values in first.items() for p in values)
    signals = _envelope_signals(sc, folder, backend, envelopes, where)
    try:
        steps = tuple(int(k) for k in trace_steps(len(recorded_times(sc)), points)) if signals else ()
    except ValueError as exc:
        raise CampaignError(f"campaign of {where}: {exc}") from None
    task = ScenarioTask(sc, int(seed), str(folder), backend, dispersed, signals, steps)
    ctx = context(sc, folder, backend)
    if signals:
        ctx["envelopes"] = {"signals": list(signals), "points": int(points)}
    return Campaign(name=name or f"{sc.name}-n{n}-s{seed}", task=task, n=n, seed=int(seed),
                    chunk=default_chunk(n) if chunk is None else chunk,
                    sampler=sample_indices, context=ctx)


def default_chunk(n: int) -> int:
    """Samples per chunk of a campaign of ``n`` samples when none is given: about 100 chunks, at
    least 10 and at most 1000 samples each. Per chunk the driver writes a Parquet file and the
    campaign record and Dask schedules a task (milliseconds each); a chunk is also what an
    interruption loses. A pure function of ``n``, so a resumed campaign finds its chunks whatever
    the number of workers.

    Parameters
    ----------
    n : int
        Number of samples of the campaign (a value that is not an integer gives 10: the
        campaign refuses it itself).
    """
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)):
        return 10  # the campaign refuses the count itself, naming it
    return int(min(1000, max(10, -(-int(n) // 100))))


def _envelope_signals(scenario: Scenario, folder: Path, backend: str, envelopes: Sequence[str], where: str
                      ) -> tuple[str, ...]:
    """The scalar signals of ``envelopes`` (base names expanded), each recorded by the scenario."""
    if isinstance(envelopes, str):
        raise ScenarioError(f"{where}: envelopes must be a list of signals, got the string {envelopes!r}")
    if not envelopes:
        return ()
    with wire(scenario, folder, backend) as sim:
        kept = recorded(scenario, sim)
        out: list[str] = []
        for i, name in enumerate(envelopes):
            try:
                comp, names = sim.resolve(name)
            except UnknownVariableError as exc:
                raise ScenarioError(f"{where}: envelopes[{i}]: {exc}") from None
            for n in names:
                q = f"{comp.name}.{n}"
                if q not in kept:
                    raise ScenarioError(f"{where}: envelopes[{i}]: {q} is not recorded by the scenario (add it "
                                        "to its record list)")
                if q not in out:
                    out.append(q)
    return tuple(out)


def _canonical(scenario: Scenario) -> Scenario:
    """The scenario as :func:`reopen` reads it back from ``campaign.json`` (its declaration, its
    folder and file), so that a reopened campaign's task is the one that ran. Its ``[campaign]``
    table (default sizes and seed, not what a sample computes) is left out, so that editing a
    default does not make a folder another campaign."""
    where = str(scenario.path) if scenario.path else f"scenario {scenario.name!r}"
    data = {k: v for k, v in scenario.to_dict().items() if k != "campaign"}
    return Scenario.from_dict(json.loads(json.dumps(data)), scenario.folder, where, scenario.path)


def reopen(folder: str | Path, fmu_dir: str | Path | None = None) -> Campaign[ScenarioTask]:
    """The scenario campaign a folder holds, as :func:`campaign` made it (to replay a sample or
    report on it).

    Parameters
    ----------
    folder : path
        A campaign folder (``campaign.json`` of a scenario campaign).
    fmu_dir : path, optional
        Where its FMUs are now (default: the folder the campaign ran them from).

    Raises
    ------
    CampaignError
        Not a scenario campaign's folder, or its FMUs are not the files it ran (another SHA-256:
        a replay would not be the campaign's run).
    """
    from satfmu.sims.campaign.engine import read_record

    folder = Path(folder)
    record = read_record(folder)
    ctx = record.get("context") or {}
    if "scenario" not in ctx:
        raise CampaignError(f"{folder}: not the folder of a scenario campaign (campaign.json holds no scenario)")
    path = None if ctx.get("path") is None else Path(ctx["path"])
    sc = Scenario.from_dict(ctx["scenario"], ctx["base_dir"],
                            str(path) if path else f"scenario {ctx['scenario']['name']!r}",
                            path)
    task_dir = fmu_dir if fmu_dir is not None else ctx["fmu_dir"]
    env = ctx.get("envelopes") or {}
    camp = campaign(sc, int(record["n"]), seed=int(record["seed"]), chunk=int(record["chunk"]), name=record["name"],
                    fmu_dir=task_dir, backend=ctx["backend"], envelopes=env.get("signals", ()),
                    points=env.get("points", POINTS))
    changed = [inst for inst, f in ctx["fmus"].items() if camp.context["fmus"].get(inst) != f]
    if changed:
        raise CampaignError(f"{folder}: the FMU files of {', '.join(changed)} in {camp.task.fmu_dir} are not the ones "
                            "the campaign ran (SHA-256 differs); rebuild them from the same sources or give the "
                            "folder holding the campaign's FMUs")
    return camp


def explain(task: ScenarioTask, index: int) -> str | None:
    """Why sample ``index`` failed (its message, the sample run again), None if it ran.

    Parameters
    ----------
    task : ScenarioTask
        The campaign's task (``campaign.task``).
    index : int
        Global sample index.
    """
    return task.run_sample(int(index))[1]


def campaign_size(scenario: "str | Path | Mapping[str, Any] | Scenario", samples: int | None = None,
                  seed: int | None = None, demo: bool = False) -> tuple[int, int]:
    """The number of samples and the seed of a scenario's campaign: those given, else its
    ``[campaign]`` table's (``samples``, or ``demo_samples`` with ``demo``; ``seed``, else 0).

    Parameters
    ----------
    scenario : Scenario, dict, str or Path
        A scenario, its data, a TOML file or a shipped scenario's name.
    samples : int, optional
        Number of samples (overrides the table).
    seed : int, optional
        Campaign seed (overrides the table).
    demo : bool
        Take the table's ``demo_samples`` (a quick look) instead of ``samples`` (the full size).

    Returns
    -------
    (int, int)
        Samples and seed.

    Raises
    ------
    ScenarioError
        No ``samples`` given and none declared (the key path named), or both ``samples`` and
        ``demo``.
    """
    sc = load(scenario)
    where = str(sc.path) if sc.path else f"scenario {sc.name!r}"
    key = "demo_samples" if demo else "samples"
    if samples is not None and demo:
        raise ScenarioError(f"{where}: give the number of samples or ask for the demo size, not both")
    if samples is None:
        samples = sc.campaign.get(key)
        if samples is None:
            raise ScenarioError(f"{where}: campaign.{key}: not declared (no [campaign] {key}); give the number "
                                "of samples (--samples N)")
    return int(samples), int(sc.campaign.get("seed", 0) if seed is None else seed)
