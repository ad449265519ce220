"""The report's figures, drawn with matplotlib and returned as inline SVG (``<svg>...</svg>``).

Scatter points are rasterized inside the SVG (an embedded PNG image), so a campaign of many
samples stays a page of reasonable size; axes and lines stay vector, and text stays text
(``<text>`` elements, not glyph outlines: it can be searched and copied, and its size on screen
can be measured; the page's browser test holds it at 8 px or more).
"""
from __future__ import annotations

import io
import math
import textwrap
from typing import Any, Callable, Mapping, Sequence

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from satfmu.sims.scenario.spec import Metric
from satfmu.sims.report.limits import Line, base  # noqa: E402

REQUIREMENT = "#c0392b"
"""Colour of requirement lines (a metric's bounds)."""
ACTUATOR = "#222222"
"""Colour of actuator-limit lines."""
FAILED = "#d62728"
"""Colour of the samples that miss a metric's bound."""


def svg(fig: plt.Figure, tight: bool = False) -> str:
    """The figure as an inline ``<svg>`` element (no XML prolog), the figure closed.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure to render (closed afterwards, also on an error).
    tight : bool
        Crop to the bounding box of everything drawn (legends outside the axes), at the cost of
        one more draw; else the figure's own size.
    """
    buf = io.StringIO()
    try:
        with matplotlib.rc_context({"svg.fonttype": "none"}):
            fig.savefig(buf, format="svg", bbox_inches="tight" if tight else None)
    finally:
        plt.close(fig)
    text = buf.getvalue()
    return text[text.index("<svg"):]


def _draw_lines(ax: plt.Axes, lines: Sequence[Line]) -> None:
    """Requirement (dashed) and actuator-limit (dash-dot) lines, one legend entry each."""
    for ln in lines:
        colour = REQUIREMENT if ln.kind == "requirement" else ACTUATOR
        style: dict[str, Any] = dict(color=colour, lw=1.1, ls="--" if ln.kind == "requirement" else "-.",
                                     alpha=1.0 if ln.active else 0.4)
        if ln.axis == "time":
            ax.axvline(ln.value, label=ln.label, **style)
            continue
        ax.axhline(ln.value, xmin=ln.span[0], xmax=ln.span[1], label=ln.label, **style)
        if ln.symmetric and ln.value != 0.0:
            ax.axhline(-ln.value, xmin=ln.span[0], xmax=ln.span[1], **style)


def _legend(ax: plt.Axes, outside: bool = False) -> None:
    handles, labels = ax.get_legend_handles_labels()
    if handles and outside:
        ax.legend(fontsize=6.5, loc="upper left", bbox_to_anchor=(1.01, 1.0), framealpha=0.85)
    elif handles:
        ax.legend(fontsize=6.5, loc="best", ncol=1 if len(handles) < 5 else 2, framealpha=0.85)


ZOOM = 0.02
"""A signal's panel is repeated, zoomed to its requirement band, when a level line is below this
fraction of the signal's largest magnitude (a 0.1 deg settling band on a 200 deg manoeuvre)."""


def time_histories(results: pd.DataFrame, units: Mapping[str, str], lines: Callable[[str], list[Line]],
                   title: str = "") -> str:
    """One panel per recorded signal (all its indices), against time, with its reference lines.

    A signal whose requirement or limit levels are too small to see beside its largest value
    (below :data:`ZOOM` of it) gets a second panel zoomed to three times its largest such level.

    Parameters
    ----------
    results : pandas.DataFrame
        ``time`` (s) and one column per ``instance.variable``.
    units : dict of str to str
        Unit of each column.
    lines : callable
        Base name (``plant.omega``) -> its :class:`~satfmu.sims.report.limits.Line` list.
    title : str

    Returns
    -------
    str
        An ``<svg>`` element.
    """
    groups: dict[str, list[str]] = {}
    for c in results.columns:
        if c != "time":
            groups.setdefault(base(c), []).append(c)
    panels: list[tuple[str, list[str], list[Line], float | None]] = []
    for name, cols in groups.items():
        found = lines(name)
        panels.append((name, cols, found, None))
        top = float(np.nanmax(np.abs(results[cols].to_numpy(dtype=float)), initial=0.0))
        small = [abs(ln.value) for ln in found if ln.axis == "level" and 0.0 < abs(ln.value) < ZOOM * top]
        if small:
            panels.append((name, cols, found, 3.0 * max(small)))
    fig, axes = plt.subplots(len(panels), 1, sharex=True, figsize=(8.5, 2.1 * len(panels) + 0.5), squeeze=False)
    t = results["time"].to_numpy()
    for ax, (name, cols, found, zoom) in zip(axes[:, 0], panels):
        for k, c in enumerate(cols):
            ax.plot(t, results[c].to_numpy(), color=f"C{k % 10}", lw=1.2, label=c)
        _draw_lines(ax, found)
        unit = ", ".join(sorted({units.get(c) or "1" for c in cols}))
        if zoom is not None:
            ax.set_ylim(-zoom, zoom)
        ax.set_ylabel(f"{name}\n({unit})" + (", zoomed" if zoom is not None else ""), fontsize=8)
        ax.grid(True, alpha=0.3)
        _legend(ax, outside=True)
    axes[-1, 0].set_xlabel("time (s)")
    if title:
        fig.suptitle(textwrap.fill(title, 110), fontsize=9)
    fig.tight_layout()
    return svg(fig, tight=True)


def _finite(values: np.ndarray) -> tuple[np.ndarray, str]:
    """The finite values and a note on the others (``"2 inf"``, ``"1 not run"``)."""
    finite = values[np.isfinite(values)]
    notes = [f"{int(np.sum(values == np.inf))} inf" if np.any(values == np.inf) else "",
             f"{int(np.sum(values == -np.inf))} -inf" if np.any(values == -np.inf) else "",
             f"{int(np.sum(np.isnan(values)))} not run" if np.any(np.isnan(values)) else ""]
    return finite, ", ".join(n for n in notes if n)


def _bound_lines(ax: plt.Axes, metric: Metric, vertical: bool, span: tuple[float, float] | None = None) -> None:
    """A metric's bounds, dashed. With ``span`` (the data's range along the bound's axis), a bound
    far outside it is not drawn to scale (the data would shrink to a sliver): the axis keeps the
    data's range and an arrow at its edge names the bound."""
    lo, hi = span if span is not None else (-math.inf, math.inf)
    width = hi - lo if span is not None and hi > lo else 0.0
    for bound, label in ((metric.min, "min"), (metric.max, "max")):
        if bound is None:
            continue
        if span is None or lo - width <= bound <= hi + width:
            (ax.axvline if vertical else ax.axhline)(bound, color=REQUIREMENT, ls="--", lw=1.1,
                                                     label=f"{label} {bound:g}")
            continue
        side = 1.0 if bound > hi else 0.0
        text = f"{label} {bound:g} {'→' if side else '←'}" if vertical else f"{label} {bound:g} {'↑' if side else '↓'}"
        xy = (side, 0.9) if vertical else (0.98, side)
        ax.annotate(text, xy=xy, xycoords="axes fraction", ha="right" if side or not vertical else "left",
                    va="top" if vertical or side else "bottom", fontsize=8, color=REQUIREMENT)


def _grid(n: int, columns: int) -> tuple[int, int]:
    cols = max(1, min(columns, n))
    return math.ceil(n / cols), cols


def histograms(rows: pd.DataFrame, metrics: Sequence[Metric], title: str = "") -> str:
    """A histogram per metric over a campaign's samples, with its bounds (dashed).

    Parameters
    ----------
    rows : pandas.DataFrame
        A campaign's rows (a column per metric, in its unit).
    metrics : list of Metric
        The scenario's metrics (names, units, bounds).
    title : str

    Returns
    -------
    str
        An ``<svg>`` element; a metric without a finite value gets an empty panel saying so.
    """
    nr, nc = _grid(len(metrics), 2)
    fig, axes = plt.subplots(nr, nc, figsize=(4.3 * nc, 2.8 * nr), squeeze=False)
    for ax in axes.flat[len(metrics):]:
        ax.set_visible(False)
    for ax, m in zip(axes.flat, metrics):
        finite, note = _finite(rows[m.name].to_numpy(dtype=float))
        span = None
        if finite.size:
            ax.hist(finite, bins=min(50, max(5, int(np.sqrt(finite.size)) + 1)), color="C0", alpha=0.8)
            span = (float(finite.min()), float(finite.max()))
        else:
            ax.text(0.5, 0.5, "no finite value", ha="center", va="center", transform=ax.transAxes)
        _bound_lines(ax, m, vertical=True, span=span)
        ax.set_title(textwrap.fill(m.name, 45) + (f"\n({note})" if note else ""), fontsize=8)
        ax.set_xlabel(m.value_unit or "1", fontsize=8)
        ax.set_ylabel("samples", fontsize=8)
        ax.grid(True, alpha=0.3)
        _legend(ax)
    if title:
        fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    return svg(fig)


def scatter(rows: pd.DataFrame, metrics: Sequence[Metric], dispersed: Sequence[str], title: str = "") -> str:
    """Each metric against each dispersed value, samples that miss the metric's bounds marked.

    Parameters
    ----------
    rows : pandas.DataFrame
        A campaign's rows.
    metrics : list of Metric
    dispersed : list of str
        The dispersed value columns.
    title : str

    Returns
    -------
    str
        An ``<svg>`` element: a row of panels per metric, a column per dispersed value.
    """
    from satfmu.sims.scenario import metrics as scenario_metrics

    fig, axes = plt.subplots(len(metrics), len(dispersed), figsize=(max(6.5, 2.6 * len(dispersed) + 0.8),
                                                                    2.3 * len(metrics) + 0.4),
                             squeeze=False, sharex="col", sharey="row")
    for i, m in enumerate(metrics):
        y = rows[m.name].to_numpy(dtype=float)
        ok = np.array([scenario_metrics.MetricResult(m.name, m.kind, float(v), m.min, m.max,
                                                     m.value_unit).passed for v in y], bool)
        _, note = _finite(y)
        for j, d in enumerate(dispersed):
            ax = axes[i, j]
            x = rows[d].to_numpy(dtype=float)
            shown = np.isfinite(x) & np.isfinite(y)
            ax.scatter(x[shown & ok], y[shown & ok], s=9, color="C0", label="within bounds", rasterized=True)
            ax.scatter(x[shown & ~ok], y[shown & ~ok], s=16, marker="x", color=FAILED, label="misses a bound",
                       rasterized=True)
            _bound_lines(ax, m, vertical=False)
            ax.grid(True, alpha=0.3)
            ax.tick_params(labelsize=7)
            if i == len(metrics) - 1:
                ax.set_xlabel(d, fontsize=8)
            if j == 0:
                ax.set_ylabel(textwrap.fill(f"{m.name} ({m.value_unit or '1'})", 28) + (f"\n{note}" if note else ""),
                              fontsize=7)
    handles, labels = axes[0, 0].get_legend_handles_labels()  # the markers; each panel's bounds are dashed red
    fig.legend(handles[:2], labels[:2], loc="upper right", fontsize=7, ncol=2)
    if title:
        fig.suptitle(title, fontsize=9, x=0.02, ha="left")
    fig.tight_layout(rect=(0, 0, 1, 1.0 - 0.45 / fig.get_figheight()))  # room for the title and legend
    return svg(fig)


def influence(rows: pd.DataFrame, metric: str, dispersed: Sequence[str]) -> list[tuple[str, float]]:
    """The dispersed values ranked by how strongly the metric follows them: Spearman's rank
    correlation over the samples where both are finite, largest magnitude first.

    Parameters
    ----------
    rows : pandas.DataFrame
        A campaign's rows.
    metric : str
        The metric's column.
    dispersed : list of str
        The dispersed value columns.

    Returns
    -------
    list of (str, float)
        Column and rank correlation (NaN, ranked last, where it is undefined: a constant column).
    """
    from scipy import stats

    y = rows[metric].to_numpy(dtype=float)
    out = []
    for d in dispersed:
        x = rows[d].to_numpy(dtype=float)
        ok = np.isfinite(x) & np.isfinite(y)
        rho = math.nan
        if ok.sum() > 2 and np.ptp(x[ok]) > 0 and np.ptp(y[ok]) > 0:
            rho = float(stats.spearmanr(x[ok], y[ok]).statistic)
        out.append((d, rho))
    return sorted(out, key=lambda item: -abs(item[1]) if math.isfinite(item[1]) else math.inf)


def strongest_scatter(rows: pd.DataFrame, metrics: Sequence[Metric], dispersed: Sequence[str],
                      units: Mapping[str, str] | None = None, title: str = "") -> str:
    """Each metric against the dispersed value it follows most (:func:`influence`), one readable
    panel per metric, samples that miss the metric's bounds marked.

    Parameters
    ----------
    rows : pandas.DataFrame
        A campaign's rows.
    metrics : list of Metric
    dispersed : list of str
        The dispersed value columns (varied ones).
    units : dict of str to str, optional
        Unit of each dispersed column.
    title : str

    Returns
    -------
    str
        An ``<svg>`` element, two panels a row.
    """
    from satfmu.sims.scenario import metrics as scenario_metrics

    nr, nc = _grid(len(metrics), 2)
    fig, axes = plt.subplots(nr, nc, figsize=(4.6 * nc, 3.1 * nr + 0.5), squeeze=False)
    for ax in axes.flat[len(metrics):]:
        ax.set_visible(False)
    for ax, m in zip(axes.flat, metrics):
        d, rho = influence(rows, m.name, dispersed)[0]
        y = rows[m.name].to_numpy(dtype=float)
        x = rows[d].to_numpy(dtype=float)
        ok = np.array([scenario_metrics.MetricResult(m.name, m.kind, float(v), m.min, m.max).passed for v in y], bool)
        shown = np.isfinite(x) & np.isfinite(y)
        ax.scatter(x[shown & ok], y[shown & ok], s=12, color="C0", label="within bounds", rasterized=True)
        ax.scatter(x[shown & ~ok], y[shown & ~ok], s=20, marker="x", color=FAILED, label="misses a bound",
                   rasterized=True)
        finite = y[shown]
        _bound_lines(ax, m, vertical=False, span=(float(finite.min()), float(finite.max())) if finite.size else None)
        unit = (units or {}).get(d)
        ax.set_xlabel(f"{d}" + (f" ({unit})" if unit else ""), fontsize=9)
        ax.set_ylabel(f"{m.value_unit or '1'}", fontsize=9)
        corr = f"rank correlation {rho:+.2f}" if math.isfinite(rho) else "no rank correlation"
        ax.set_title(textwrap.fill(f"{m.name}: against {d}, {corr}", 52), fontsize=9)
        ax.grid(True, alpha=0.3)
        ax.tick_params(labelsize=8)
    handles, labels = axes.flat[0].get_legend_handles_labels()
    fig.legend(handles[:2], labels[:2], loc="upper right", fontsize=8, ncol=2)
    if title:
        fig.suptitle(title, fontsize=10, x=0.02, ha="left")
    fig.tight_layout(rect=(0, 0, 1, 1.0 - 0.45 / fig.get_figheight()))
    return svg(fig)


TRANSIENT = 0.02
"""A signal's transient ends when its median stays within this fraction of its range of its final
value; the envelopes add a panel zoomed on the transients when they end before :data:`ZOOM_TIME`
of the run."""
ZOOM_TIME = 0.4
"""Fraction of the run before which the transients must end for the envelopes' zoomed column."""


def transient_end(t: np.ndarray, median: np.ndarray) -> float:
    """The last time the median leaves a band of :data:`TRANSIENT` times its range around its final
    value (``t[0]`` for a constant signal), s.

    Parameters
    ----------
    t : numpy.ndarray
        Times, s.
    median : numpy.ndarray
        The signal's median over the samples at each time.
    """
    finite = np.isfinite(median)
    if not finite.any():
        return float(t[-1])
    m, tt = median[finite], t[finite]
    span = float(np.ptp(m))
    if span == 0.0:
        return float(tt[0])
    outside = np.nonzero(np.abs(m - m[-1]) > TRANSIENT * span)[0]
    return float(tt[min(outside[-1] + 1, len(tt) - 1)]) if outside.size else float(tt[0])


def envelopes(df: pd.DataFrame, signals: Mapping[str, Mapping[float, str]], units: Mapping[str, str],
              lines: Callable[[str], list[Line]], title: str = "") -> str:
    """Percentile envelopes of recorded signals over a campaign's samples, with reference lines.

    Parameters
    ----------
    df : pandas.DataFrame
        ``time`` (s) and ``<signal>:p<percentile>`` columns.
    signals : dict
        Signal -> percentile (%) -> column (:func:`satfmu.sims.report.folders.envelope_signals`).
    units : dict of str to str
        Unit of each signal.
    lines : callable
        Base name -> its :class:`~satfmu.sims.report.limits.Line` list.
    title : str

    Returns
    -------
    str
        An ``<svg>`` element: a panel per signal, each pair of percentiles (lowest and highest,
        then inward) a shaded band, the median a line, one legend for the figure; a second column
        zoomed on the transients when they end early in the run (:func:`transient_end`).
    """
    t = df["time"].to_numpy()
    medians = {}
    for name, pcts in signals.items():
        ps = sorted(pcts)
        mid = min(ps, key=lambda p: abs(p - 50.0))
        medians[name] = (mid, df[pcts[mid]].to_numpy(dtype=float))
    end = max(transient_end(t, m) for _, m in medians.values())
    zoom = t[0] + 1.5 * (end - t[0]) if end - t[0] < ZOOM_TIME * (t[-1] - t[0]) else None
    cols = 2 if zoom is not None else 1
    fig, axes = plt.subplots(len(signals), cols, figsize=(5.2 * cols + 1.0, 2.3 * len(signals) + 0.9),
                             squeeze=False, sharex="col")
    seen: dict[str, Any] = {}
    for row, (name, pcts) in enumerate(signals.items()):
        ps = sorted(pcts)
        mid, median = medians[name]
        for c in range(cols):
            ax = axes[row, c]
            pairs = [(ps[i], ps[-1 - i]) for i in range(len(ps) // 2) if ps[i] < mid < ps[-1 - i]]
            for k, (lo, hi) in enumerate(pairs):
                ax.fill_between(t, df[pcts[lo]], df[pcts[hi]], color="C0", alpha=0.15 + 0.2 * k, lw=0,
                                label=f"p{lo:g} to p{hi:g}")
            ax.plot(t, median, color="C0", lw=1.3, label=f"p{mid:g}" + (" (median)" if mid == 50 else ""))
            _draw_lines(ax, lines(base(name)))
            ax.grid(True, alpha=0.3)
            ax.tick_params(labelsize=8)
            if c == 1:
                ax.set_xlim(t[0], zoom)
            for h, label in zip(*ax.get_legend_handles_labels()):
                seen.setdefault(label, h)
        axes[row, 0].set_ylabel(f"{name}\n({units.get(name) or '1'})", fontsize=9)
    axes[-1, 0].set_xlabel("time (s)", fontsize=9)
    if zoom is not None:
        axes[0, 1].set_title(f"the first {zoom - t[0]:.3g} s (the transients)", fontsize=9)
        axes[-1, 1].set_xlabel("time (s)", fontsize=9)
        axes[0, 0].set_title("the whole run", fontsize=9)
    fig.legend(list(seen.values()), list(seen), loc="lower center", fontsize=8,
               ncol=min(3, len(seen)), bbox_to_anchor=(0.5, 0.0), framealpha=0.9)
    rows_of_legend = math.ceil(len(seen) / 3)
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout(rect=(0, (0.25 * rows_of_legend + 0.1) / fig.get_figheight(), 1, 1))
    return svg(fig)


def compare_strips(series: Mapping[str, np.ndarray], metric: Metric) -> str:
    """One metric over several campaigns side by side: a row per campaign, a dot per sample
    (a red cross where it misses the bounds), the quartiles as a box, the bounds dashed.

    Parameters
    ----------
    series : dict of str to ndarray
        Campaign label -> the metric's values (in the metric's unit).
    metric : Metric
        Names the axis and gives the bounds (the first campaign's).

    Returns
    -------
    str
        An ``<svg>`` element. Non-finite values (a settling time never reached, a sample that
        did not run) are counted in the row's label, not drawn.
    """
    from satfmu.sims.scenario import metrics as scenario_metrics

    labels = list(series)
    fig, ax = plt.subplots(figsize=(8.5, 0.75 * len(labels) + 1.1))
    jitter = np.random.default_rng(0)  # vertical spread of the dots only: a fixed seed, the same page each time
    ticks = []
    for k, label in enumerate(labels):
        values = np.asarray(series[label], float)
        finite, note = _finite(values)
        ticks.append(label + (f"\n({note})" if note else ""))
        if finite.size:
            ax.boxplot(finite, positions=[k], vert=False, widths=0.5, showfliers=False, manage_ticks=False,
                       medianprops={"color": f"C{k % 10}"})
            ok = np.array([scenario_metrics.MetricResult(metric.name, metric.kind, float(v), metric.min,
                                                         metric.max).passed
                           for v in finite], bool)
            y = k + jitter.uniform(-0.18, 0.18, finite.size)
            ax.scatter(finite[ok], y[ok], s=10, color=f"C{k % 10}", alpha=0.8, rasterized=True, zorder=3)
            ax.scatter(finite[~ok], y[~ok], s=18, marker="x", color=FAILED, rasterized=True, zorder=3)
    _bound_lines(ax, metric, vertical=True)
    ax.set_yticks(range(len(labels)), ticks, fontsize=8)
    ax.set_ylim(len(labels) - 0.5, -0.5)
    ax.set_xlabel(f"{metric.name} ({metric.value_unit or '1'})", fontsize=8)
    ax.grid(True, axis="x", alpha=0.3)
    _legend(ax)
    fig.tight_layout()
    return svg(fig)


def frequency_responses(loops: Sequence[Any], title: str = "") -> str:
    """The loop-at-a-time gains and the singular values of S and T of linearized loops, one row each.

    Parameters
    ----------
    loops : sequence of satfmu.sims.scenario.loops.LoopMargins
        Loops with their linearizations (``plant``, ``controller``), drawn sampled at their
        ``sample_time`` up to the Nyquist frequency.
    title : str
        Figure title.
    """
    from satfmu.synthesis.core import margins as loop_margins

    fig, axes = plt.subplots(len(loops), 2, figsize=(9.5, 2.9 * len(loops) + 0.5), squeeze=False)
    for (ax_l, ax_s), lm in zip(axes, loops):
        step = lm.sample_time
        omega = np.logspace(-4, math.log10(0.999 * math.pi / step), 600)
        for k, (name, resp) in enumerate(loop_margins.channel_responses(lm.plant, lm.controller, omega, step)):
            if name in lm.sampled.unused:
                continue
            mag = np.abs(resp)
            ax_l.semilogx(omega, 20 * np.log10(np.maximum(mag, 1e-300)), color=f"C{k % 10}", lw=1.1, label=name)
        ax_l.axhline(0.0, color="#888888", lw=0.8)
        ax_l.set_ylabel("|L_i| (dB)", fontsize=9)
        ax_l.set_title(textwrap.fill(f"{lm.loop.label}: loop at a time, others closed", 70), fontsize=9)
        active = [n for n in lm.controller.outputs if n not in lm.sampled.unused]
        L_in, _ = loop_margins.loop_transfers(lm.plant, loop_margins.restrict(lm.controller, active), step)
        s_max, t_max, _ = loop_margins.sensitivities(L_in, omega)
        ax_s.semilogx(omega, 20 * np.log10(s_max), color="C0", lw=1.1, label="largest singular value of S")
        ax_s.semilogx(omega, 20 * np.log10(t_max), color="C3", lw=1.1, label="largest singular value of T")
        ax_s.axhline(6.0, color=REQUIREMENT, lw=0.9, ls="--", label="6 dB (|S| peak 2)")
        ax_s.set_ylabel("dB", fontsize=9)
        ax_s.set_title(f"sensitivity and complementary sensitivity, sampled {step:g} s", fontsize=9)
        for ax in (ax_l, ax_s):
            ax.grid(True, which="both", alpha=0.25)
            ax.tick_params(labelsize=8)
            ax.legend(fontsize=8, loc="best", framealpha=0.85)
        ax_l.set_xlabel("frequency (rad/s)", fontsize=9)
        ax_s.set_xlabel("frequency (rad/s)", fontsize=9)
    if title:
        fig.suptitle(textwrap.fill(title, 110), fontsize=10)
    fig.tight_layout()
    return svg(fig)

