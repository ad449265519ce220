"""Running a scenario: its co-simulation, the evaluation of its metrics, the result.

:func:`run` checks the FMUs (:mod:`satfmu.sims.scenario.provisioning`), runs the master
:mod:`satfmu.sims.scenario.wiring` wires (:func:`simulate`), evaluates the metrics
(:func:`evaluate`, a :class:`MetricFeed` of :data:`satfmu.sims.scenario.metrics.STREAMS`) and returns a
:class:`~satfmu.sims.scenario.result.Result`.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Mapping

import numpy as np

from satfmu.fmus.atomic import write_atomically
from satfmu.fmus.errors import ScenarioError
from satfmu.sims.cosim.master import CoSimulation
from satfmu.sims.scenario.conversions import MetricConversion, converted, metric_conversion, record_conversions
from satfmu.sims.scenario.metrics import MARGIN_KINDS, MetricInput, MetricResult, metric_stream
from satfmu.sims.scenario.provisioning import ensure_fmus
from satfmu.sims.scenario.result import CsvWriter, Result, clear_outputs
from satfmu.sims.scenario.spec import Metric, Scenario, load
from satfmu.sims.scenario.wiring import _check_parameters, _columns, profiles, recorded, recorded_times, wire


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


def _execute(scenario: Scenario, sim: CoSimulation, sink: Callable[[np.ndarray], None] | None = None
             ) -> np.ndarray:
    """Run ``scenario`` through its wired master; the recorded array (none with ``sink``, which
    receives the rows as the run goes: :meth:`CoSimulation.run`)."""
    params = {inst: spec.parameters for inst, spec in scenario.fmus.items()}
    return sim.run(scenario.stop_time, scenario.step_size, scenario.start_time, params, recorded(scenario, sim),
                   record_every=scenario.record_every, sink=sink)


class _Recorder:
    """The sink of a streamed run: each block of rows handed to ``consume`` (the metrics), converted
    and written to the CSV, and ``time`` with its ``kept`` columns copied into one array of ``n_rows``
    rows (no rows when nothing is kept)."""

    def __init__(self, scenario: Scenario, sim: CoSimulation, write: CsvWriter, kept: set[str], n_rows: int,
                 consume: Callable[[np.ndarray], None]) -> None:
        self.scenario, self.sim, self.write, self.kept, self.n_rows = scenario, sim, write, kept, n_rows
        self.consume = consume
        self.out: np.ndarray | None = None
        self.done = 0
        self.shown: dict[str, tuple[float, str]] = {}
        """Every recorded column's conversion to the unit the scenario's ``record`` asks for."""

    def __call__(self, rows: np.ndarray) -> None:
        names = rows.dtype.names or ()
        if self.out is None:
            self.shown.update(record_conversions(self.scenario, self.sim, [c for c in names if c != "time"]))
            self.out = np.zeros(self.n_rows if self.kept else 0,
                                dtype=[(c, "f8") for c in names if c == "time" or c in self.kept])
        self.consume(rows)
        self.write(converted(rows, self.shown))
        for c in (self.out.dtype.names or ()) if self.kept else ():
            self.out[c][self.done:self.done + len(rows)] = rows[c]
        self.done += len(rows)


def _streamed(scenario: Scenario, fmu_dir: Path, backend: str, strict: bool, design_rtol: float | None,
              path: Path, prepare: Callable[[CoSimulation], tuple[set[str], Callable[[np.ndarray], None]]]
              ) -> tuple[np.ndarray, CoSimulation, dict[str, tuple[float, str]]]:
    """:func:`simulate` with the recording streamed: every recorded column, converted to the unit
    the scenario's ``record`` asks for, written to the CSV ``path`` block by block (whole or not
    at all: :func:`satfmu.fmus.atomic.write_atomically`), each block handed (in declared units)
    to the consumer ``prepare(sim)`` gives with the columns to keep; returned, those columns and
    ``time`` (no rows if none is kept), in their declared units, and every column's conversion."""
    sim = wire(scenario, fmu_dir, backend, strict, design_rtol)
    recorders: list[_Recorder] = []
    try:
        kept, consume = prepare(sim)

        def run_into(tmp: Path) -> None:
            with CsvWriter(tmp) as write:
                n_rows = len(recorded_times(scenario)) if kept else 0
                recorders.append(_Recorder(scenario, sim, write, kept, n_rows, consume))
                _execute(scenario, sim, recorders[-1])
        path.parent.mkdir(parents=True, exist_ok=True)
        write_atomically(path, run_into)
    finally:
        sim.close()
    (rec,) = recorders
    assert rec.out is not None  # the master hands over at least the start row
    return rec.out, sim, rec.shown


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


@dataclass(frozen=True)
class MetricPlan:
    """What evaluating one metric on a run of a wired master reads, fixed by the scenario's
    declaration and the FMUs (a campaign's samples share it; :func:`plan_metrics`).

    Attributes
    ----------
    metric : satfmu.sims.scenario.spec.Metric
        The metric's declaration.
    where : str
        Its key path (``scenario.toml: metrics[2]``), the start of every error.
    columns, versus, disturbances : list of str
        Its ``signals``, ``versus`` and ``disturbances``, expanded to recorded columns.
    conversion : satfmu.sims.scenario.conversions.MetricConversion
        How its signals convert, and the unit of its value.
    held : bool
        Every signal is held over each step (an input or a connected output).
    inputs : list of bool
        Which signals are FMU inputs the master sets.
    disturbances_held : bool
        Every disturbance is held over each step.
    """

    metric: Metric
    where: str
    columns: list[str]
    versus: list[str]
    disturbances: list[str]
    conversion: MetricConversion
    held: bool
    inputs: list[bool]
    disturbances_held: bool


def plan_metrics(scenario: Scenario, sim: CoSimulation) -> list[MetricPlan]:
    """The scenario's metrics planned on the master ``sim`` wired for it: columns, unit
    conversions and flags, computed once (a campaign plans once per worker, not per sample).

    Parameters
    ----------
    scenario : Scenario
        The scenario (a sample of it has the same metrics).
    sim : CoSimulation
        The master wired for it (:func:`satfmu.sims.scenario.wiring.wire`).

    Returns
    -------
    list of MetricPlan
        One per metric, in the scenario's order.

    Raises
    ------
    ScenarioError
        A metric whose unit its signals do not convert to (key path named).
    """
    held, inputs = sim.held_signals(), sim.input_signals()
    where = str(scenario.path) if scenario.path else f"scenario {scenario.name!r}"
    plans = []
    for i, m in enumerate(scenario.metrics):
        cols, versus, disturbances = (_columns(sim, names) for names in (m.signals, m.versus, m.disturbances))
        if m.kind in MARGIN_KINDS:  # of the loop linearized from the models, not of the run
            versus, disturbances = [], []
        key = f"{where}: metrics[{i}]"
        conv = metric_conversion(m, sim, {"signals": cols, "versus": versus, "disturbances": disturbances}, key)
        plans.append(MetricPlan(m, key, cols, versus, disturbances, conv, all(c in held for c in cols),
                                [c in inputs for c in cols], all(c in held for c in disturbances)))
    return plans


class MetricFeed:
    """The scenario's metrics evaluated on a run fed in blocks of recorded rows, in order
    (:class:`satfmu.sims.scenario.metrics.MetricStream`: what each keeps does not grow with the
    run, and the values are those of the whole run however it is cut; :func:`evaluate` feeds
    one block).

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    plans : list of MetricPlan
        :func:`plan_metrics` of the scenario on the master that runs it.
    curves : bool, optional
        Keep each ``l2_ratio``'s curve over time (8 bytes a row). Default True.
    """

    def __init__(self, scenario: Scenario, plans: list[MetricPlan], curves: bool = True) -> None:
        self.scenario, self.plans = scenario, plans
        self.streams = [None if p.metric.kind in MARGIN_KINDS else metric_stream(p.metric.kind, curves) for p in plans]

    def feed(self, rows: np.ndarray) -> None:
        """Take the next block of recorded rows (``time`` and the recorded columns, declared units).

        Parameters
        ----------
        rows : numpy.ndarray
            Structured array, as the master records it.
        """
        t = rows["time"]
        for plan, stream in zip(self.plans, self.streams):
            if stream is not None:
                conv = plan.conversion
                stream.feed(MetricInput(
                    t, _stacked(rows, plan.columns) * conv.signals, held=plan.held, inputs=plan.inputs,
                    tolerance=plan.metric.tolerance, limit=plan.metric.limit,
                    versus=_stacked(rows, plan.versus) * conv.versus if plan.versus else None,
                    disturbances=_stacked(rows, plan.disturbances) if plan.disturbances else None,
                    disturbances_held=plan.disturbances_held, scale=conv.scale))

    def results(self) -> tuple[list[MetricResult], dict[str, np.ndarray]]:
        """The metrics over every row fed, and the ``l2_ratio`` curves kept (as :func:`evaluate`)."""
        out, curves = [], {}
        for plan, stream in zip(self.plans, self.streams):
            m, conv = plan.metric, plan.conversion
            if stream is None:  # a margin: of the loop linearized from the models, not of the run
                from satfmu.sims.scenario.loops import margin_metric  # sympy: only for a margin metric

                value = margin_metric(m.kind, self.scenario, plan.columns) * conv.scale
            else:
                value, curve = stream.result()
                if curve is not None:
                    curves[m.name] = curve
            out.append(MetricResult(m.name, m.kind, value, m.min, m.max, conv.unit))
        return out, curves


def evaluate(scenario: Scenario, res: np.ndarray, sim: CoSimulation, plans: list[MetricPlan] | None = None
             ) -> tuple[list[MetricResult], dict[str, np.ndarray]]:
    """Evaluate the scenario's metrics on a recorded run (a :class:`MetricFeed` fed it whole).

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    res : numpy.ndarray
        The recorded run (:func:`simulate`): ``time`` (s) and the recorded signals.
    sim : CoSimulation
        The master that ran it (which signals are held FMU inputs, how base names expand).
    plans : list of MetricPlan, optional
        :func:`plan_metrics` of the scenario and ``sim``, made once for many runs (default: made
        here).

    Returns
    -------
    results : list of satfmu.sims.scenario.metrics.MetricResult
        One per metric, in the scenario's order, values in the metrics' units.
    curves : dict of str to numpy.ndarray
        The truncated L2 ratio over T of each ``l2_ratio`` metric, by name.
    """
    feed = MetricFeed(scenario, plan_metrics(scenario, sim) if plans is None else plans)
    feed.feed(res)
    return feed.results()


def _stacked(res: np.ndarray, columns: list[str]) -> np.ndarray:
    """The recorded ``columns`` side by side, rows x columns."""
    return np.stack([res[c] for c in columns], axis=1)


def run(scenario: "str | Path | Mapping[str, Any] | Scenario", fmu_dir: str | Path | None = None,
        backend: str = "native", out_dir: str | Path | None = None, strict: bool = False,
        design_rtol: float | None = None, allow_stale: bool = False, plots: bool = False,
        stream: bool = False) -> Result:
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
        Write the CSV, the run record and the summary (the plots with ``plots``) into
        ``out_dir/<name>/`` (:meth:`Result.write`).
    strict : bool
        Refuse (``ScenarioError``) a controller paired with a plant other than its design
        plant, instead of a :class:`satfmu.fmus.errors.DesignMismatchWarning`.
    design_rtol : float, optional
        Relative tolerance of that comparison (default 1e-3).
    allow_stale : bool
        Run a stale controller FMU outside the FMU cache as it is, with a
        :class:`satfmu.fmus.errors.StaleFmuWarning`, instead of refusing it (:func:`ensure_fmus`).
    plots : bool
        With ``out_dir``, draw the PNG plots as well (about 1 s of CPU; :meth:`Result.write`);
        :meth:`Result.plot` draws them later from the returned result.
    stream : bool
        With ``out_dir``, write the CSV as the run goes, a block of rows at a time (the same
        text), evaluate the metrics on each block as it comes (:class:`MetricFeed`: the same
        values), and keep in memory nothing of the rows (with ``plots``, the columns the plot
        shows and the ``l2_ratio`` curves): a long run's memory does not grow with its length.
        The result's ``results`` then holds those columns (no rows without ``plots``);
        ``Result.csv`` is the CSV with all of them.

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
    panels = sc.plot.get("panels") or [[r] for r in sc.record] or [m.signals for m in sc.metrics]
    csv_path = None
    if stream and out_dir is not None:
        feeds: list[MetricFeed] = []  # the metrics, fed as the run records (planned once the master is wired)

        def prepare(sim: CoSimulation) -> tuple[set[str], Callable[[np.ndarray], None]]:
            feeds.append(MetricFeed(sc, plan_metrics(sc, sim), curves=plots))
            return ({c for p in panels for c in _columns(sim, p)} if plots else set()), feeds[-1].feed
        csv_path = Path(out_dir) / sc.name / f"{sc.name}_{backend}.csv"
        res, sim, shown = _streamed(sc, folder, backend, strict, design_rtol, csv_path, prepare)
        mres, curves = feeds[0].results()
    else:
        res, sim = simulate(sc, folder, backend, strict, design_rtol)
        shown = record_conversions(sc, sim, [c for c in res.dtype.names or () if c != "time"])
        mres, curves = evaluate(sc, res, sim)
    assert res.dtype.names is not None  # the master records a structured array (time, then the signals)
    cols = [c for c in (_columns(sim, p) for p in panels) if all(n in res.dtype.names for n in c)]
    result = Result(sc.name, backend, converted(res, {c: shown[c] for c in res.dtype.names if c != "time"}), mres,
                    l2_curves=curves, units={c: unit for c, (_, unit) in shown.items()}, panels=cols,
                    title=f"{sc.name}: {sc.description}", warnings=list(sim.mismatches), scenario=sc, fmu_dir=folder,
                    csv=csv_path)
    if out_dir is not None:
        result.write(Path(out_dir) / sc.name, plots)
    return result
