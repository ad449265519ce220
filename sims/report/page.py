"""The report page: runs, campaigns, their comparison, what was proved and the provenance,
as one self-contained HTML file (inline CSS and SVG figures; no script, no external URL).

The page is rendered from the Jinja2 template ``page.html.j2`` beside this module (autoescaped;
only the SVG figures, which matplotlib writes, are inserted as they are). Every number of a
table also sits, unrounded, in its cell's ``data-value`` attribute (``repr`` of the float),
for scripts and tests that read the page.
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

import jinja2
import numpy as np
import pandas as pd
from markupsafe import Markup
from scipy.spatial.transform import Rotation

from satfmu.fmus.atomic import write_atomically
from satfmu.fmus.errors import (CampaignError, CampaignWarning, DesignMismatchWarning, MasterError, ProfileError,
                                ScenarioError)
from satfmu.sims.scenario import metrics as scenario_metrics
from satfmu.sims.scenario.spec import Metric, Scenario
from satfmu.sims.report import figures, limits, proved
from satfmu.sims.report.folders import (CampaignFolder, Folder, ReportError, RunFolder, envelope_signals, read_folder)
from satfmu.sims.report.provenance import Provenance, collect
from satfmu.sims.campaign import replay
from satfmu.sims.campaign.scenario_task import FAILURES
from satfmu.sims.campaign.statistics import PERCENTILES, MetricStatistics


def number(value: Any) -> str:
    """A value as the page prints it: 6 significant digits, ``inf``, ``NaN``, empty for None.

    Parameters
    ----------
    value : float or None
        Any number (converted with ``float``), in its own unit.
    """
    if value is None:
        return ""
    v = float(value)
    if math.isnan(v):
        return "NaN"
    if math.isinf(v):
        return "inf" if v > 0 else "-inf"
    return f"{v:.6g}"


def percent(value: float) -> str:
    """A fraction as the page prints it: ``87.50 %``.

    Parameters
    ----------
    value : float
        The fraction, 1 for 100 %.
    """
    return f"{100.0 * float(value):.2f} %"


def exact(value: Any) -> str:
    """The unrounded value of a cell (``data-value``): ``repr`` of the float, empty for None.

    Parameters
    ----------
    value : float or None
        Any number (converted with ``float``).
    """
    return "" if value is None else repr(float(value))


def bounds(metric: Metric | scenario_metrics.MetricResult) -> str:
    """``min 6.1, max 6.3``, in the metric's unit (empty: no bound).

    Parameters
    ----------
    metric : Metric or MetricResult
        A scenario's metric (:class:`satfmu.sims.scenario.spec.Metric`) or a run's
        (:class:`satfmu.sims.scenario.metrics.MetricResult`): its ``min`` and ``max``.
    """
    return ", ".join(f"{k} {v:g}" for k, v in (("min", metric.min), ("max", metric.max)) if v is not None)


@dataclass(frozen=True)
class StatisticsRow:
    """A row of a campaign's statistics table (:class:`satfmu.sims.campaign.statistics.MetricStatistics`).

    Parameters
    ----------
    statistics : MetricStatistics
    bounds : str
        The metric's bounds (empty for the ``passed`` row).
    """

    statistics: MetricStatistics
    bounds: str

    @property
    def percentiles(self) -> list[float | None]:
        """The metric's value at each of :data:`~satfmu.sims.campaign.statistics.PERCENTILES`
        (None: no finite value)."""
        return [self.statistics.percentiles.get(p) for p in PERCENTILES]


@dataclass
class Comparison:
    """Side-by-side figures of several campaigns: metrics matched by name.

    Attributes
    ----------
    campaigns : list of CampaignFolder
    metrics : list of str
        Every metric name of the campaigns, in order of first appearance.
    figures : dict of str to Markup
        Metric name -> the campaigns' samples side by side (metrics two or more campaigns share).
    """

    campaigns: list[CampaignFolder]
    metrics: list[str]
    figures: dict[str, Markup] = field(default_factory=dict)

    def statistics(self, campaign: CampaignFolder, name: str) -> MetricStatistics | None:
        """The campaign's statistics of metric ``name`` (None: the scenario has no such metric).

        Parameters
        ----------
        campaign : CampaignFolder
            One of the compared campaigns.
        name : str
            The metric's name.
        """
        return next((s for s in campaign.statistics.metrics if s.name == name), None)

    def worst(self, campaign: CampaignFolder, name: str) -> tuple[float, int] | None:
        """The worst value of metric ``name`` over the samples that ran, and its sample (:func:`worst_value`).

        Parameters
        ----------
        campaign : CampaignFolder
            One of the compared campaigns.
        name : str
            The metric's name.

        Returns
        -------
        (float, int) or None
            The value in the metric's unit and the sample index; None when the campaign's
            scenario has no such metric or no sample ran.
        """
        metric = next((m for m in campaign.scenario.metrics if m.name == name), None)
        return None if metric is None else worst_value(campaign.rows, metric)


def worst_value(rows: Any, metric: Metric) -> tuple[float, int] | None:
    """The worst value of a metric over a campaign's samples that ran, and its sample index.

    Worst is the largest value for a metric with a ``max`` (or no bound), the smallest for a
    metric with only a ``min``; infinite values count (a settling time never reached).

    Parameters
    ----------
    rows : pandas.DataFrame
        A campaign's rows.
    metric : Metric

    Returns
    -------
    (float, int) or None
        None when no sample ran.
    """
    values = rows[metric.name].to_numpy(dtype=float)
    ran = ~np.isnan(values)
    if not ran.any():
        return None
    pick = np.where(ran, values, -np.inf if metric.max is not None or metric.min is None else np.inf)
    k = int(np.argmin(pick) if metric.max is None and metric.min is not None else np.argmax(pick))
    return float(values[k]), int(rows["sample"].iloc[k])


def _run_view(run: RunFolder) -> dict[str, Any]:
    lim = limits.actuator_limits(run.scenario, run.fmus)
    shown = {limits.base(c): u for c, u in run.units.items()}
    declared = _units(run, list(shown))
    figure = figures.time_histories(run.results, run.units, lambda s: limits.signal_lines(
        run.scenario, s, lim, shown.get(s, ""), declared.get(s, "")), title=f"{run.scenario.name} ({run.backend})")
    return {"kind": "run", "run": run, "figure": Markup(figure), "limits": lim, "coverage": _coverage(run.scenario)}


def _coverage(scenario: Scenario, rows: pd.DataFrame | None = None,
              dispersed: Sequence[tuple[str, str]] | None = None) -> list[Any]:
    """What each loop's certificate covers of a run or a campaign's samples
    (:func:`satfmu.sims.scenario.coverage.coverage`); a model the catalog no longer has covers nothing to say."""
    from satfmu.sims.scenario import coverage

    try:
        return coverage.coverage(scenario, rows, list(dispersed) if dispersed is not None else None)
    except (ValueError, OSError) as exc:  # a model the catalog no longer has, an unreadable artifact
        return [f"not checked: {exc}"]


@dataclass
class WorstSamples:
    """A campaign's worst samples as the page lists them.

    Parameters
    ----------
    rows : pandas.DataFrame
        The statistics' worst rows, with the rotation angle of each dispersed attitude (deg)
        beside its components.
    columns : list of (str, str)
        Each column shown and its unit (empty: none to show).
    anchor : str
        The id prefix of the samples' time histories (``<anchor>-sample-<k>``).
    histories : dict of int to Markup
        Sample -> its replayed time histories (an ``<svg>``).
    notes : dict of int to str
        Sample -> why it has no time histories, or how its replay differed from its row.
    """

    rows: Any
    columns: list[tuple[str, str]]
    anchor: str
    histories: dict[int, Markup] = field(default_factory=dict)
    notes: dict[int, str] = field(default_factory=dict)


ANGLE = " attitude angle"
"""Suffix of the column of a dispersed attitude's rotation angle from the identity (deg), after its instance."""


def _worst(camp: CampaignFolder, anchor: str, replay: bool) -> WorstSamples:
    """The worst samples with their attitudes' angles, units, and (``replay``) their time histories."""
    rows = camp.statistics.worst.copy()
    dispersed = list(camp.dispersed)
    for inst, cols, kind in (camp.scenario.dispersions.attitudes(dispersed) if camp.scenario.dispersions else []):
        values = rows[cols].to_numpy(dtype=float)
        ok = np.isfinite(values).all(axis=1)
        angle = np.full(len(rows), np.nan)
        if ok.any():
            rot = Rotation.from_mrp(values[ok]) if kind == "mrp" else Rotation.from_quat(values[ok])
            angle[ok] = np.degrees(rot.magnitude())
        rows[inst + ANGLE] = angle
        dispersed.insert(dispersed.index(cols[-1]) + 1, inst + ANGLE)
    declared = _units(camp, [d for d in dispersed if not d.endswith(ANGLE)])
    units = {m.name: m.value_unit for m in camp.scenario.metrics}
    units.update({d: "deg" if d.endswith(ANGLE) else declared[d] if not d.startswith("profiles[") else ""
                  for d in dispersed})
    columns = [(c, units.get(c, "")) for c in ["sample", "passed", "failed", *[m.name for m in camp.scenario.metrics],
                                                *dispersed]]
    out = WorstSamples(rows, [(c, "" if u == "1" else u) for c, u in columns], anchor)
    if replay:
        for k in rows["sample"].astype(int):
            _history(camp, int(k), out)
    return out


def _history(camp: CampaignFolder, sample: int, out: WorstSamples) -> None:
    """Replay one sample (:func:`satfmu.sims.campaign.replay.replay`, the campaign's own FMU
    files) and draw its time histories into ``out``; a sample that cannot be replayed gets a note."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        warnings.simplefilter("ignore", DesignMismatchWarning)  # the page says so once, in its coverage
        try:
            res = replay.replay(camp.folder, sample, fmu_dir=camp.campaign.task.fmu_dir)
        except (CampaignError, ScenarioError, ProfileError, MasterError, OSError) as exc:
            out.notes[sample] = f"not replayed: {exc}"
            return
    differed = [str(w.message) for w in caught if issubclass(w.category, CampaignWarning)]
    if differed:
        out.notes[sample] = differed[0]
    df = pd.DataFrame(res.results)
    shown = {limits.base(c): u for c, u in res.units.items()}
    declared = _units(camp, list(shown))
    lim = limits.actuator_limits(camp.scenario, camp.fmus)
    out.histories[sample] = Markup(figures.time_histories(df, res.units, lambda s: limits.signal_lines(
        camp.scenario, s, lim, shown.get(s, ""), declared.get(s, "")), title=res.title))


def _campaign_view(camp: CampaignFolder, anchor: str, replay: bool) -> dict[str, Any]:
    st, sc = camp.statistics, camp.scenario
    rows = [StatisticsRow(st.overall, "")] + [StatisticsRow(s, bounds(m)) for s, m in zip(st.metrics, sc.metrics)]
    view: dict[str, Any] = {"kind": "campaign", "campaign": camp, "rows": rows, "metrics": sc.metrics,
                            "worst": _worst(camp, anchor, replay),
                            "coverage": _coverage(camp.scenario, camp.rows, camp.campaign.task.dispersed),
                            "failures": {int(c): FAILURES[int(c)] for c in sorted(set(camp.rows["failed"]))
                                         if int(c) in FAILURES and c > 0},
                            "histograms": Markup(figures.histograms(camp.rows, sc.metrics, camp.label))}
    # a value every sample shares (a product of inertia the dispersion keeps at 0) or a metric
    # without a finite value has nothing to scatter: the caption names them
    varied = [d for d in camp.dispersed if camp.rows[d].nunique(dropna=True) > 1]
    view["constant"] = {d: camp.rows[d].dropna().iloc[0] if camp.rows[d].notna().any() else None
                        for d in camp.dispersed if d not in varied}
    plotted = [m for m in sc.metrics if np.isfinite(camp.rows[m.name].to_numpy(dtype=float)).any()]
    view["unplotted"] = [m.name for m in sc.metrics if m not in plotted]
    if varied and plotted:
        view["strongest"] = Markup(figures.strongest_scatter(camp.rows, plotted, varied, _units(camp, varied),
                                                             camp.label))
        ranked = [d for m in plotted for d, _ in figures.influence(camp.rows, m.name, varied)[:SCATTER_TOP]]
        view["scatter_columns"] = list(dict.fromkeys(ranked))[:SCATTER_COLUMNS]
        view["scatter"] = Markup(figures.scatter(camp.rows, plotted, view["scatter_columns"], camp.label))
    if camp.envelopes is not None:
        signals = envelope_signals(camp.envelopes)
        lim = limits.actuator_limits(sc, camp.fmus)
        declared = _units(camp, list(signals))
        units = _shown_units(sc, declared)
        view["envelopes"] = Markup(figures.envelopes(
            camp.envelopes, signals, units,
            lambda s: limits.signal_lines(sc, s, lim, units.get(s, ""), declared.get(s, "")), camp.label))
    return view


SCATTER_TOP = 3
"""The dispersed values each metric's full scatter grid keeps: its most influential ones (rank correlation)."""
SCATTER_COLUMNS = 8
"""Most columns of the full scatter grid (a campaign may disperse 40 values: a grid of 40 x 6 panels
is unreadable and takes a minute to draw)."""


def _units(folder: Folder, signals: list[str]) -> dict[str, str]:
    """Declared unit of each ``instance.variable`` (from its FMU's model description; ``"1"`` if unknown)."""
    from satfmu.fmus import archive

    out, mds = {}, {}
    for s in signals:
        inst, _, name = s.partition(".")
        f = folder.fmus.get(inst)
        if f is not None and inst not in mds and f.path.is_file():
            try:
                mds[inst] = {v.name: v for v in archive.read_description(f.path).modelVariables}
            except (OSError, archive.UnsafeFmuError):  # unreadable: its units are unknown ("1")
                mds[inst] = {}
        v = mds.get(inst, {}).get(name) or next((w for n, w in mds.get(inst, {}).items()
                                                 if limits.base(n) == name), None)
        unit = getattr(v, "unit", None) or getattr(getattr(v, "declaredType", None), "unit", None)
        out[s] = unit or "1"
    return out


def _shown_units(scenario: Scenario, declared: dict[str, str]) -> dict[str, str]:
    """Each signal's unit as recorded: the one the scenario's ``record`` asks for (an entry for
    its base name applies to its elements), else its declared one."""
    asked = scenario.units
    return {s: asked.get(s) or asked.get(limits.base(s)) or u for s, u in declared.items()}


def _comparison(camps: list[CampaignFolder]) -> Comparison:
    names = list(dict.fromkeys(m.name for c in camps for m in c.scenario.metrics))
    comp = Comparison(camps, names)
    for name in names:
        having = [(c, next(m for m in c.scenario.metrics if m.name == name)) for c in camps
                  if any(m.name == name for m in c.scenario.metrics)]
        if len(having) > 1 and any(np.isfinite(c.rows[name].to_numpy(dtype=float)).any() for c, _ in having):
            comp.figures[name] = Markup(figures.compare_strips(
                {c.label: c.rows[name].to_numpy(dtype=float) for c, _ in having}, having[0][1]))
    return comp


def _claims(folders: Sequence[Folder]) -> list[proved.Claims]:
    """The claims of every controller FMU the folders used, each file once."""
    found: dict[tuple[Path, str], proved.Claims] = {}
    for f in folders:
        for inst, fmu in f.fmus.items():
            key = (fmu.path, fmu.sha256)
            if key not in found:
                c = proved.claims(fmu)
                if c is None:
                    continue
                found[key] = c
            found[key].used_by.append(f"{f.label}: {inst}")
    return list(found.values())


@dataclass
class MarginsView:
    """The margins of one scenario's loops as the page shows them.

    Parameters
    ----------
    scenario : str
        The scenario's name.
    used_by : list of str
        The runs and campaigns of the page that ran it.
    loops : list of satfmu.sims.scenario.loops.LoopMargins
        Loop by loop, point by point.
    notes : list of str
        Connected pairs that are no loop, or why no margins could be computed.
    figure : Markup, optional
        The frequency responses of the loops at the origin (empty when none has margins).
    """

    scenario: str
    used_by: list[str]
    loops: list = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    figure: Markup = field(default_factory=lambda: Markup(""))


def _margins(folders: Sequence[Folder]) -> list[MarginsView]:
    """The linear margins of the loops of every scenario the folders ran (each scenario once: a
    campaign's nominal one), from the symbolic models (:func:`satfmu.sims.scenario.loops.scenario_margins`)."""
    from satfmu.sims.scenario import loops

    views: dict[str, MarginsView] = {}
    for f in folders:
        sc = f.scenario
        if sc.name in views:
            views[sc.name].used_by.append(f.label)
            continue
        view = views[sc.name] = MarginsView(sc.name, [f.label])
        try:
            view.loops, view.notes = loops.scenario_margins(sc)
        except (ValueError, OSError) as exc:  # a model the catalog no longer has, an unreadable artifact
            view.notes = [f"no margins: {exc}"]
            continue
        drawn = [lm for lm in view.loops if lm.point == "origin" and lm.sampled is not None]
        if drawn:
            view.figure = Markup(figures.frequency_responses(drawn, f"{sc.name}: loops at the origin, sampled at "
                                                                      f"{sc.step_size:g} s"))
    return list(views.values())


def _environment() -> jinja2.Environment:
    env = jinja2.Environment(loader=jinja2.FileSystemLoader(Path(__file__).parent), autoescape=True,
                             undefined=jinja2.StrictUndefined, trim_blocks=True, lstrip_blocks=True)
    env.filters.update(number=number, percent=percent, exact=exact, bounds=bounds)
    env.globals.update(PERCENTILES=PERCENTILES)
    return env


def build_report(folders: Sequence[str | Path], fmu_dir: str | Path | None = None, confidence: float = 0.95,
                 worst: int = 5, provenance: Provenance | None = None, histories: bool = True) -> str:
    """The report page of run and campaign folders, as HTML text.

    Parameters
    ----------
    folders : list of path
        Run folders (``satfmu run --out``) and scenario campaign folders (``satfmu campaign
        scenario --out``), in the order the page shows them; two or more campaigns (or runs)
        are also compared side by side.
    fmu_dir : path, optional
        Where the FMU files are now (default: the folder each run or campaign used).
    confidence : float
        Two-sided confidence of the campaigns' pass-rate intervals, in (0, 1).
    worst : int
        How many worst samples of each campaign to list, >= 0.
    provenance : Provenance, optional
        Default :func:`satfmu.sims.report.provenance.collect` (now, this process).
    histories : bool
        Replay each campaign's worst samples (:func:`satfmu.sims.campaign.replay.replay`: the
        campaign's FMU files, bit for bit; about half a second each) and draw their time histories,
        linked from the worst-samples table.

    Returns
    -------
    str

    Raises
    ------
    ReportError
        No folder, a bad confidence or count, or a folder :func:`~satfmu.sims.report.folders.read_folder` refuses.
    """
    if not folders:
        raise ReportError("no folder to report on")
    if not 0.0 < confidence < 1.0:
        raise ReportError(f"confidence must be in (0, 1), got {confidence!r}")
    if isinstance(worst, bool) or int(worst) != worst or worst < 0:
        raise ReportError(f"worst must be an integer >= 0, got {worst!r}")
    items: list[Folder] = []
    for path in dict.fromkeys(Path(f).resolve() for f in folders):
        items += read_folder(path, fmu_dir, confidence, int(worst))
    runs = [f for f in items if isinstance(f, RunFolder)]
    camps = [f for f in items if isinstance(f, CampaignFolder)]
    template = _environment().get_template("page.html.j2")
    views = [_run_view(f) if isinstance(f, RunFolder) else _campaign_view(f, f"item-{k}", histories)
             for k, f in enumerate(items, 1)]
    return template.render(
        items=items, views=views, run_comparison=runs if len(runs) > 1 else None,
        run_metrics=list(dict.fromkeys(m.name for r in runs for m in r.metrics)),
        comparison=_comparison(camps) if len(camps) > 1 else None, claims=_claims(items), margins=_margins(items),
        provenance=provenance or collect(), confidence=confidence)


def write_report(folders: Sequence[str | Path], out: str | Path, fmu_dir: str | Path | None = None,
                 confidence: float = 0.95, worst: int = 5, histories: bool = True) -> Path:
    """Write the report page of run and campaign folders (:func:`build_report`) to one HTML file.

    The page is self-contained: inline CSS and SVG figures, no script and no external URL,
    so it opens offline in any browser and can be mailed or archived as one file.

    Parameters
    ----------
    folders : list of path
        Run folders and scenario campaign folders.
    out : path
        The HTML file (its folder is created; written whole or not at all).
    fmu_dir : path, optional
        Where the FMU files are now (default: the folder each run or campaign used).
    confidence : float
        Two-sided confidence of the campaigns' pass-rate intervals, in (0, 1).
    worst : int
        How many worst samples of each campaign to list, >= 0.
    histories : bool
        Replay the worst samples and draw their time histories (:func:`build_report`).

    Returns
    -------
    Path
        ``out``.

    Raises
    ------
    ReportError
        What :func:`build_report` refuses.
    """
    html = build_report(folders, fmu_dir, confidence, worst, histories=histories)
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    write_atomically(out, lambda tmp: tmp.write_text(html, encoding="utf-8"))
    return out
