"""Monte Carlo campaigns of a scenario with ``[dispersions]``, and their statistics.

:func:`campaign` makes a :class:`~satfmu.sims.campaign.engine.Campaign` whose samples are the global
sample indices (:func:`satfmu.sims.campaign.engine.sample_indices`): sample ``i`` runs
``scenario.sample(seed, i)`` through :func:`satfmu.sims.scenario.spec.simulate` and
:func:`satfmu.sims.scenario.spec.evaluate`, the path of :func:`satfmu.sims.scenario.spec.run`, so its row depends on
``(seed, i)`` only, not on the chunk size, the workers or the order of the chunks. A worker
process wires the scenario's :class:`~satfmu.sims.cosim.master.CoSimulation` once
(:meth:`ScenarioTask.simulation`) and runs every sample through it
(:func:`satfmu.sims.scenario.spec.resimulate`): the FMU instances are reset between samples, the step
loop is the compiled one (:mod:`satfmu.sims.cosim.compiled_loop`), and a row equals that of
:func:`satfmu.sims.scenario.spec.run` of the sampled scenario bit for bit.

Columns of a row (all float64, as every campaign chunk): ``sample`` (global index), one per
metric (its value in the metric's unit, NaN for a sample that did not run; an infinite
value is a result, e.g. a settling time never reached), ``passed`` (1 if every
metric is within its bounds, else 0), ``failed`` (a code of :data:`FAILURES`, 0 when the
sample ran) and one per dispersed value (``plant.I_x``, ``profiles[0].after``; in the
parameter's unit). A failed sample is a row like any other: the campaign goes on. Its
message is not stored (chunk columns are numbers); as a sample is a pure function of
``(seed, index)``, :func:`explain` runs it again and returns it.

:func:`statistics` gives per metric the pass rate with its Clopper-Pearson interval, the
percentiles :data:`PERCENTILES` and the worst samples with their dispersed values.
"""
from __future__ import annotations

import atexit
import hashlib
import json
import math
import pickle
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
import pandas as pd
from scipy import stats

from satfmu.fmus.atomic import write_atomically
from satfmu.fmus.profiles import ProfileError
from satfmu.sims.campaign import envelopes as E
from satfmu.sims.scenario import metrics as M
from satfmu.sims.cosim import preflight
from satfmu.sims.scenario import spec as S
from satfmu.sims.campaign.engine import Campaign, CampaignError, sample_indices
from satfmu.sims.cosim.master import CoSimulation, MasterError, UnknownVariableError

FAILURES = {0: "ran", 1: "an FMU call or the master failed (satfmu.sims.cosim.master.MasterError)",
            2: "the sampled scenario was refused (ScenarioError or ProfileError, e.g. a start value outside "
               "its declared range, a profile field its kind refuses)",
            3: "a recorded signal is not finite (NaN or infinite: the run diverged)"}
"""Code of the ``failed`` column -> what it means."""
PERCENTILES = (50.0, 95.0, 99.0, 99.73)
"""Percentiles of each metric, % (99.73: the 3-sigma level of a normal distribution)."""
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
        FMU folder, every FMU of the scenario present (:func:`satfmu.sims.scenario.spec.check`).
    backend : {"native", "python"}
    dispersed : tuple of (str, str)
        (instance or ``"profiles[i]"``, parameter or field) of each dispersed value column.
    envelopes : tuple of str
        Recorded scalar signals whose time history each row keeps (:mod:`satfmu.sims.campaign.envelopes`).
    trace_steps : tuple of int
        The recorded rows (communication points) of those histories.
    """

    scenario: S.Scenario
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
        return [c for s in self.envelopes for c in E.trace_columns(s, len(self.trace_steps))]

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
        except S.ScenarioError as exc:
            return {**row, "passed": 0.0, "failed": 2.0}, str(exc)
        for owner, name in self.dispersed:
            row[f"{owner}.{name}"] = float(_value(sampled, owner, name))
        try:
            res = S.resimulate(sampled, sim)
            results, _ = S.evaluate(sampled, res, sim)
        except (MasterError, S.ScenarioError, ProfileError) as exc:
            if any(c.fatal for c in sim.components.values()):  # no further call allowed: wire anew
                _discard(sim)
            code = 1.0 if isinstance(exc, MasterError) else 2.0
            return {**row, "passed": 0.0, "failed": code}, str(exc)
        for m in results:
            row[m.name] = m.value
        steps = np.asarray(self.trace_steps, dtype=np.int64)
        for signal in self.envelopes:
            row.update(zip(E.trace_columns(signal, len(steps)), res[signal][steps].tolist()))
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
                warnings.simplefilter("ignore", S.DesignMismatchWarning)
                sim = S.wire(self.scenario, Path(self.fmu_dir), self.backend)
            sim.reuse_instances = True
            _NOMINAL[id(sim)] = S.nominal_values(self.scenario, self.fmu_dir, self.backend)
            while len(_WIRED) >= _KEEP:
                _close(_WIRED.pop(next(iter(_WIRED))))
        _WIRED[key] = sim  # most recently used last
        return sim


_KEEP = 2
"""Wired masters a process keeps (two campaigns of one worker in turn)."""
_WIRED: dict[str, CoSimulation] = {}
"""This process's wired masters by task digest, least recently used first."""
_NOMINAL: dict[int, Any] = {}
"""The nominal values (:func:`satfmu.sims.scenario.spec.nominal_values`) of each kept master's scenario, read
once, by ``id`` of the master."""


def _close(sim: CoSimulation) -> None:
    _NOMINAL.pop(id(sim), None)
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


def _value(sampled: S.Scenario, owner: str, name: str) -> Any:
    """A dispersed value of a sampled scenario: a profile field or an FMU start value."""
    if owner.startswith("profiles["):
        return sampled.profiles[int(owner[len("profiles["):-1])][name]
    return sampled.fmus[owner].parameters[name]


def campaign(scenario: "str | Path | Mapping[str, Any] | S.Scenario", n: int, seed: int = 0, chunk: int | None = None,
             name: str | None = None, fmu_dir: str | Path | None = None, backend: str = "native",
             envelopes: Sequence[str] = (), points: int = E.POINTS) -> Campaign[ScenarioTask]:
    """The Monte Carlo campaign of a scenario's ``[dispersions]`` (run it with :func:`satfmu.sims.campaign.engine.run`).

    The nominal scenario is checked first (:func:`satfmu.sims.scenario.spec.check`: its FMUs are built
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
        :func:`satfmu.sims.scenario.spec.check` refuses it.
    satfmu.sims.campaign.engine.CampaignError
        An invalid n, seed, chunk, name or points.
    """
    sc = _canonical(S.load(scenario))
    where = str(sc.path) if sc.path else f"scenario {sc.name!r}"
    if sc.dispersions is None:
        raise S.ScenarioError(f"{where}: no [dispersions]: a campaign needs a scenario with dispersions")
    clash = [m.name for m in sc.metrics if m.name in _RESERVED]
    if clash:
        raise S.ScenarioError(f"{where}: metrics: the names {clash} are campaign columns; rename the metric(s)")
    folder = S.check(sc, fmu_dir, backend)
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise CampaignError(f"campaign of {where}: seed must be an integer >= 0, got {seed!r}")
    first = sc.dispersions.sample(int(seed), 0, S.nominal_values(sc, folder, backend), f"{where}: dispersions")
    dispersed = tuple((owner, p) for owner, values in first.items() for p in values)
    signals = _envelope_signals(sc, folder, backend, envelopes, where)
    try:
        steps = tuple(int(k) for k in E.trace_steps(len(S.recorded_times(sc)), points)) if signals else ()
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


def _envelope_signals(scenario: S.Scenario, folder: Path, backend: str, envelopes: Sequence[str], where: str
                      ) -> tuple[str, ...]:
    """The scalar signals of ``envelopes`` (base names expanded), each recorded by the scenario."""
    if isinstance(envelopes, str):
        raise S.ScenarioError(f"{where}: envelopes must be a list of signals, got the string {envelopes!r}")
    if not envelopes:
        return ()
    with S.wire(scenario, folder, backend) as sim:
        recorded = S.recorded(scenario, sim)
        out: list[str] = []
        for i, name in enumerate(envelopes):
            try:
                comp, names = sim.resolve(name)
            except UnknownVariableError as exc:
                raise S.ScenarioError(f"{where}: envelopes[{i}]: {exc}") from None
            for n in names:
                q = f"{comp.name}.{n}"
                if q not in recorded:
                    raise S.ScenarioError(f"{where}: envelopes[{i}]: {q} is not recorded by the scenario (add it "
                                          "to its record list)")
                if q not in out:
                    out.append(q)
    return tuple(out)


def _canonical(scenario: S.Scenario) -> S.Scenario:
    """The scenario as :func:`reopen` reads it back from ``campaign.json`` (its declaration, its
    folder and file), so that a reopened campaign's task is the one that ran. Its ``[campaign]``
    table (default sizes and seed, not what a sample computes) is left out, so that editing a
    default does not make a folder another campaign."""
    where = str(scenario.path) if scenario.path else f"scenario {scenario.name!r}"
    data = {k: v for k, v in scenario.to_dict().items() if k != "campaign"}
    return S.Scenario.from_dict(json.loads(json.dumps(data)), scenario.folder, where, scenario.path)


def context(scenario: S.Scenario, fmu_dir: Path, backend: str) -> dict[str, Any]:
    """What ``campaign.json`` keeps of a scenario campaign (part of its identity): the scenario's
    declaration, the folder its relative paths resolve against, the backend, the FMU folder, and
    each FMU file's name and SHA-256 (another binary is another campaign).

    Parameters
    ----------
    scenario : Scenario
        The campaign's (or run's) scenario.
    fmu_dir : Path
        The FMU folder the FMUs are read from.
    backend : {"native", "python"}
        Default backend of the instances.

    Returns
    -------
    dict
        Plain JSON data: ``scenario``, ``base_dir``, ``path``, ``backend``, ``fmu_dir`` and
        ``fmus`` (instance -> ``{"file": ..., "sha256": ...}``).
    """
    fmus = {inst: {"file": p.name, "sha256": preflight.sha256_file(p)}
            for inst, p in S.fmu_paths(scenario, Path(fmu_dir), backend).items()}
    return {"scenario": scenario.to_dict(), "base_dir": str(scenario.folder),
            "path": None if scenario.path is None else str(scenario.path), "backend": backend,
            "fmu_dir": str(fmu_dir), "fmus": fmus}


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
    sc = S.Scenario.from_dict(ctx["scenario"], ctx["base_dir"],
                              str(path) if path else f"scenario {ctx['scenario']['name']!r}",
                              path)
    task_dir = fmu_dir if fmu_dir is not None else ctx["fmu_dir"]
    env = ctx.get("envelopes") or {}
    camp = campaign(sc, int(record["n"]), seed=int(record["seed"]), chunk=int(record["chunk"]), name=record["name"],
                    fmu_dir=task_dir, backend=ctx["backend"], envelopes=env.get("signals", ()),
                    points=env.get("points", E.POINTS))
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


@dataclass(frozen=True)
class MetricStatistics:
    """Pass rate and percentiles of one metric over a campaign (values in ``unit``).

    ``passes`` counts the samples within the metric's bounds (a failed sample is not);
    ``low`` and ``high`` bound the pass probability (Clopper-Pearson, at the campaign's
    confidence); the percentiles are over the samples with a finite value.

    Attributes
    ----------
    name : str
        The metric's name (``"all metrics (passed)"`` for the overall pass rate).
    unit : str
        The metric's unit.
    n : int
        Samples of the campaign, failed ones included.
    passes : int
        Samples within the metric's bounds.
    low, high : float
        Clopper-Pearson bounds of the pass probability, in [0, 1].
    percentiles : dict of float to float
        Percentile (%, :data:`PERCENTILES`) -> value in ``unit``; empty when no sample has a
        finite value.
    """

    name: str
    unit: str
    n: int
    passes: int
    low: float
    high: float
    percentiles: dict[float, float]

    @property
    def pass_rate(self) -> float:
        """Fraction of the samples within the bounds."""
        return self.passes / self.n


@dataclass(frozen=True)
class Statistics:
    """What a scenario campaign shows: pass rates with their intervals, percentiles, worst samples.

    Attributes
    ----------
    scenario : str
    n, n_failed : int
        Samples, and those that did not run (``failed`` > 0).
    confidence : float
        Two-sided confidence of the intervals, in (0, 1).
    overall : MetricStatistics
        Every metric within its bounds (``passed``), no percentiles.
    metrics : list of MetricStatistics
    worst : pandas.DataFrame
        The ``k`` worst samples (failed ones first, then by the smallest margin to a bound,
        in the metrics' units, over the metrics with bounds): their rows.
    """

    scenario: str
    n: int
    n_failed: int
    confidence: float
    overall: MetricStatistics
    metrics: list[MetricStatistics]
    worst: pd.DataFrame

    def text(self) -> str:
        """The statistics as a readable table."""
        pct = "  ".join(f"{'p' + format(p, 'g'):>10}" for p in PERCENTILES)
        lines = [f"{self.scenario}: {self.n} samples, {self.n_failed} failed to run; pass rates with "
                 f"Clopper-Pearson intervals at {100 * self.confidence:g} % confidence",
                 f"{'metric':<32} {'pass':>9} {'rate':>7} {'interval':>17}  {pct}  unit"]
        for s in [self.overall, *self.metrics]:
            values = "  ".join(f"{s.percentiles[p]:>10.4g}" if p in s.percentiles else f"{'':>10}" for p in PERCENTILES)
            lines.append(f"{s.name[:32]:<32} {s.passes:>4}/{s.n:<4} {s.pass_rate:>7.2%} "
                         f"[{s.low:>6.2%}, {s.high:>7.2%}]  {values}  {s.unit}")
        if len(self.worst):
            lines.append(f"worst {len(self.worst)} samples:")
            lines.append(self.worst.to_string(index=False, float_format=lambda v: f"{v:.6g}"))
        return "\n".join(lines)


def clopper_pearson(successes: int, n: int, confidence: float = 0.95) -> tuple[float, float]:
    """Exact (Clopper-Pearson) two-sided interval of a binomial probability.

    Parameters
    ----------
    successes, n : int
        Successes of ``n`` >= 1 trials.
    confidence : float
        In (0, 1).

    Returns
    -------
    (float, float)
        Lower and upper bound.
    """
    ci = stats.binomtest(int(successes), int(n)).proportion_ci(confidence_level=confidence, method="exact")
    return float(ci.low), float(ci.high)


def _metric_statistics(name: str, unit: str, passed: np.ndarray, values: np.ndarray | None,
                       confidence: float) -> MetricStatistics:
    passes = int(passed.sum())
    finite = values[np.isfinite(values)] if values is not None else np.array([])
    pct = dict(zip(PERCENTILES, map(float, np.percentile(finite, PERCENTILES)))) if finite.size else {}
    return MetricStatistics(name, unit, int(passed.size), passes, *clopper_pearson(passes, passed.size, confidence),
                            pct)


def statistics(scenario: "str | Path | Mapping[str, Any] | S.Scenario", df: pd.DataFrame, confidence: float = 0.95,
               k: int = 5) -> Statistics:
    """The statistics of a scenario campaign's rows (:func:`satfmu.sims.campaign.engine.load`).

    Parameters
    ----------
    scenario : Scenario, dict, str or Path
        The campaign's scenario (its metrics' names, units and bounds).
    df : pandas.DataFrame
        The campaign's rows (the columns of this module's docstring).
    confidence : float
        Two-sided confidence of the pass-rate intervals, in (0, 1).
    k : int
        How many worst samples to list, >= 0.

    Raises
    ------
    CampaignError
        No rows, a metric column missing, or a confidence not in (0, 1).
    """
    sc = S.load(scenario)
    if not 0.0 < confidence < 1.0:
        raise CampaignError(f"confidence must be in (0, 1), got {confidence!r}")
    missing = [c for c in [m.name for m in sc.metrics] + list(_RESERVED) if c not in df.columns]
    if len(df) == 0 or missing:
        raise CampaignError(f"not the rows of a campaign of {sc.name!r}: "
                            + (f"columns {missing} missing" if missing else "no rows"))
    failed = df["failed"].to_numpy() > 0
    per_metric, margin = [], np.full(len(df), np.inf)
    for m in sc.metrics:
        values = df[m.name].to_numpy(dtype=np.float64)
        passed = np.array([M.MetricResult(m.name, m.kind, float(v), m.min, m.max, m.unit).passed for v in values])
        per_metric.append(_metric_statistics(m.name, m.unit, passed, values, confidence))
        for bound, sign in ((m.max, 1.0), (m.min, -1.0)):
            if bound is not None:
                margin = np.fmin(margin, sign * (bound - values))
    margin[np.isnan(margin)] = -np.inf
    overall = _metric_statistics("all metrics (passed)", "", df["passed"].to_numpy() == 1.0, None, confidence)
    order = np.lexsort((margin, ~failed))[:max(int(k), 0)]  # failed first, then by margin (stable)
    return Statistics(sc.name, len(df), int(failed.sum()), confidence, overall, per_metric,
                      df.iloc[order].reset_index(drop=True))


@dataclass(frozen=True)
class CampaignResult:
    """A finished scenario campaign (:func:`run_campaign`).

    Attributes
    ----------
    campaign : Campaign
    folder : Path
        Its folder: ``campaign.json`` and the Parquet chunks.
    rows : pandas.DataFrame
        One row per sample (the columns of the module docstring, not the kept time
        histories), sorted by ``sample``.
    statistics : Statistics
    envelopes : pandas.DataFrame or None
        The percentile envelopes of the kept time histories (:func:`satfmu.sims.campaign.envelopes.envelopes`;
        also in the folder's ``envelopes.parquet``), None if the campaign keeps none.
    """

    campaign: Campaign[ScenarioTask]
    folder: Path
    rows: pd.DataFrame
    statistics: Statistics
    envelopes: pd.DataFrame | None = None

    @property
    def passed(self) -> bool:
        """Every sample ran and met every metric's bounds."""
        return bool((self.rows["passed"] == 1.0).all())

    def failures(self, count: int = 3) -> list[tuple[int, str | None]]:
        """The first ``count`` samples that failed to run, with their messages (run again).

        Parameters
        ----------
        count : int
            Most samples to run again (each takes a run's time).

        Returns
        -------
        list of (int, str or None)
            Sample index and message (:func:`explain`).
        """
        failed = self.rows.loc[self.rows["failed"] > 0, "sample"].to_numpy(dtype=int)
        return [(int(i), explain(self.campaign.task, int(i))) for i in failed[:count]]


def run_campaign(scenario: "str | Path | Mapping[str, Any] | S.Scenario", n: int, out_dir: str | Path, *,
                 seed: int = 0, chunk: int | None = None, name: str | None = None, fmu_dir: str | Path | None = None,
                 backend: str = "native", workers: int = 2, scheduler: str | None = None,
                 confidence: float = 0.95, worst: int = 5, progress: Any = None, envelopes: Sequence[str] = (),
                 points: int = E.POINTS) -> CampaignResult:
    """Run (or resume) the Monte Carlo campaign of a scenario's ``[dispersions]`` on Dask.

    Parameters
    ----------
    scenario : Scenario, dict, str or Path
        A scenario with ``[dispersions]``, its data, a TOML file or a shipped scenario's name.
    n : int
        Number of samples, >= 1.
    out_dir : path
        Folder of the campaign folders; the campaign's is ``out_dir/<name>``.
    seed, chunk, name, fmu_dir, backend, envelopes, points
        As :func:`campaign`.
    workers : int
        Processes of the local Dask cluster (ignored with ``scheduler``).
    scheduler : str, optional
        Address of a running Dask scheduler (``tcp://host:8786``) instead of a local cluster.
    confidence : float
        Two-sided confidence of the pass-rate intervals, in (0, 1).
    worst : int
        How many worst samples the statistics list.
    progress : callable, optional
        ``progress(done, total)`` after each chunk.

    Returns
    -------
    CampaignResult
    """
    from satfmu.sims.campaign import engine as C

    sc = S.load(scenario)
    camp = campaign(sc, n, seed=seed, chunk=chunk, name=name, fmu_dir=fmu_dir, backend=backend, envelopes=envelopes,
                    points=points)
    folder = Path(out_dir) / camp.name
    rows = C.run(camp, Path(out_dir), scheduler=scheduler, n_workers=workers, progress=progress)
    task: ScenarioTask = camp.task
    env = None
    if task.envelopes:
        env = E.envelopes(rows, list(task.envelopes), S.recorded_times(task.scenario)[list(task.trace_steps)])
        write_atomically(folder / ENVELOPES, lambda tmp: env.to_parquet(tmp, index=False))
        rows = rows.drop(columns=task.trace_columns)
    return CampaignResult(camp, folder, rows, statistics(sc, rows, confidence, worst), env)


ENVELOPES = "envelopes.parquet"
"""File of a campaign folder with the percentile envelopes of its kept time histories."""


def campaign_row(folder: str | Path, sample: int) -> pd.Series | None:
    """The row of sample ``sample`` as the campaign folder stores it, or None when the chunk that
    holds it is not recorded yet (an interrupted campaign) or its file is not the one recorded.

    Parameters
    ----------
    folder : path
        A campaign folder (``campaign.json`` and its chunk files).
    sample : int
        Global sample index, ``0 <= sample < n``.

    Returns
    -------
    pandas.Series or None
        The row's columns (:func:`campaign` module docstring), only the chunk holding it read
        and verified (:func:`satfmu.sims.campaign.chunk_files.chunk_problem`).

    Raises
    ------
    CampaignError
        Not a campaign folder.
    """
    from satfmu.sims.campaign import engine as C
    from satfmu.sims.campaign import chunk_files

    folder = Path(folder)
    record = C.read_record(folder)
    k = int(sample) // int(record["chunk"])
    recorded = record["chunks"].get(str(k))
    path = C.chunk_path(folder, k)
    if recorded is None or chunk_files.chunk_problem(path, recorded, C.record_digest(record), k) is not None:
        return None
    frame = pd.read_parquet(path)
    hit = frame.loc[frame["sample"] == int(sample)]
    return None if len(hit) != 1 else hit.iloc[0]


def replay_folder(campaign_name: str, sample: int) -> str:
    """Name of the folder :func:`replay` writes sample ``sample`` of a campaign into (inside
    ``out_dir``): ``<campaign name>-sample<sample>``.

    Parameters
    ----------
    campaign_name : str
        The campaign's name.
    sample : int
        Global sample index.
    """
    return f"{campaign_name}-sample{int(sample)}"


def replay(folder: str | Path, sample: int, out_dir: str | Path | None = None,
           fmu_dir: str | Path | None = None) -> S.Result:
    """Run one sample of a scenario campaign again, as the campaign ran it (bit for bit), with
    its time histories.

    The campaign is read back from ``campaign.json`` (:func:`reopen`: its scenario declaration,
    seed, backend, and FMU files whose SHA-256 must be the ones the campaign ran); sample
    ``sample`` is ``scenario.sample(seed, sample)`` run by :func:`satfmu.sims.scenario.spec.run`, the path of
    the campaign's own runs, so its metrics equal the campaign row's exactly. When the chunk that
    holds the row is recorded, the replay is compared with it: a metric or dispersed value that
    differs (e.g. other numpy/scipy versions drawing other dispersed values) is reported by a
    :class:`satfmu.sims.campaign.engine.CampaignWarning` naming the columns.

    A sample the campaign recorded as failed fails the same way: the same exception, with the
    message :func:`explain` gives.

    Parameters
    ----------
    folder : path
        The campaign folder (``--out/<name>`` of ``satfmu campaign scenario``).
    sample : int
        Global sample index, ``0 <= sample < n`` (the row's ``sample`` column).
    out_dir : path, optional
        Write the run into ``out_dir/<campaign name>-sample<sample>/`` (:func:`replay_folder`):
        the time histories as CSV, the plots and the summary as :meth:`satfmu.sims.scenario.spec.Result.write`
        writes them, and ``sample.json`` (campaign, seed, sample, dispersed values and the
        sampled scenario's declaration). Default: nothing written.
    fmu_dir : path, optional
        Folder of the campaign's FMU files (default: the folder the campaign ran them from).

    Returns
    -------
    Result
        The replayed run: recorded signals (``time`` in s, each variable in its unit), metrics.

    Raises
    ------
    CampaignError
        Not a scenario campaign's folder, a sample index outside ``0 .. n - 1``, or FMU files
        other than the campaign's (another SHA-256).
    ScenarioError
        The sampled scenario is refused (a dispersed value outside its declared range, ...):
        the campaign's failure code 2.
    satfmu.sims.cosim.master.MasterError
        An FMU call failed (failure code 1).
    """
    from satfmu.sims.campaign.engine import CampaignWarning

    folder = Path(folder)
    camp = reopen(folder, fmu_dir)
    if isinstance(sample, bool) or not isinstance(sample, (int, np.integer)) or not 0 <= sample < camp.n:
        raise CampaignError(f"{folder}: sample {sample!r} is not a sample of the campaign {camp.name!r} "
                            f"(its samples are 0..{camp.n - 1})")
    task: ScenarioTask = camp.task
    target = None if out_dir is None else Path(out_dir) / replay_folder(camp.name, int(sample))
    if target is not None:  # a failed replay must not leave an earlier replay's files looking current
        S.clear_outputs(target, task.scenario.name, task.backend)
        (target / "sample.json").unlink(missing_ok=True)
    sampled = task.scenario.sample(task.seed, int(sample), task.fmu_dir, task.backend)
    result = S.run(sampled, task.fmu_dir, task.backend)
    dispersed = {f"{owner}.{name}": _value(sampled, owner, name) for owner, name in task.dispersed}
    result.title = f"{camp.name}, sample {int(sample)}: {sampled.description}"
    row = campaign_row(folder, int(sample))
    if row is not None:
        replayed = {m.name: m.value for m in result.metrics}
        replayed.update({k: float(v) for k, v in dispersed.items()})
        differ = [k for k, v in replayed.items() if not (row[k] == v or (math.isnan(row[k]) and math.isnan(v)))]
        if differ:
            warnings.warn(f"{folder}: sample {int(sample)} replayed differently from the campaign's row in "
                          + ", ".join(f"{k} ({replayed[k]!r}, row {row[k]!r})" for k in differ), CampaignWarning,
                          stacklevel=2)
    if target is not None:
        info = {"campaign": str(folder.resolve()), "name": camp.name, "seed": camp.seed, "sample": int(sample),
                "backend": task.backend, "fmu_dir": task.fmu_dir, "dispersed": dispersed,
                "scenario": sampled.to_dict(), "base_dir": str(sampled.folder)}
        text = json.dumps(info, indent=1) + "\n"
        result.files["sample"] = write_atomically(target / "sample.json", lambda tmp: tmp.write_text(text))
        result.write(target)  # the summary last: it lists sample.json too
    return result


def campaign_size(scenario: "str | Path | Mapping[str, Any] | S.Scenario", samples: int | None = None,
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
    sc = S.load(scenario)
    where = str(sc.path) if sc.path else f"scenario {sc.name!r}"
    key = "demo_samples" if demo else "samples"
    if samples is not None and demo:
        raise S.ScenarioError(f"{where}: give the number of samples or ask for the demo size, not both")
    if samples is None:
        samples = sc.campaign.get(key)
        if samples is None:
            raise S.ScenarioError(f"{where}: campaign.{key}: not declared (no [campaign] {key}); give the number "
                                  "of samples (--samples N)")
    return int(samples), int(sc.campaign.get("seed", 0) if seed is None else seed)
