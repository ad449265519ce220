"""Matplotlib figures of co-simulation results (written as PNG, no display needed).

Every figure is a bare :class:`matplotlib.figure.Figure`, drawn by the Agg canvas its
``savefig`` picks for PNG: pyplot (its figure manager, its backend selection, half a second of
imports) is never imported, and a figure is freed with its last reference.
"""
from __future__ import annotations

import textwrap
from pathlib import Path
from typing import Mapping, Sequence

import matplotlib
import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure


def time_series(res: np.ndarray, panels: Sequence[Sequence[str]], path: Path | None = None, title: str = "",
                units: Mapping[str, str] | None = None) -> Figure:
    """One panel per group of recorded columns, against time; y label = the columns' unit.

    Columns of different FMU instances in one panel are overlaid: one colour per
    component, one line style per instance (solid for the first, dashed for the second...).
    A panel with one column per instance (one signal compared across controllers) gives
    each instance its own colour as well.

    Parameters
    ----------
    res : numpy.ndarray
        Recorded run: a structured array with a ``time`` field (s) and one field per column
        (``"instance.variable"``), as :func:`satfmu.sims.scenario.run.simulate` returns it.
    panels : sequence of sequence of str
        The columns of each panel, top to bottom.
    path : Path, optional
        The PNG file to write (default: none written).
    title : str, optional
        Figure title (wrapped at 100 characters).
    units : mapping of str to str, optional
        Column -> unit, for the y labels; a column without one is labelled ``1``.

    Returns
    -------
    matplotlib.figure.Figure
        The figure, outside pyplot's figure manager (nothing to close; a notebook shows it,
        ``fig.axes`` draws on it, ``fig.savefig`` writes it again).
    """
    styles = ["-", "--", ":", "-."]
    fig = Figure(figsize=(8, 2.2 * len(panels) + 0.6))
    axes = fig.subplots(len(panels), 1, sharex=True, squeeze=False)
    for ax, cols in zip(axes[:, 0], panels):
        instances = list(dict.fromkeys(c.split(".", 1)[0] for c in cols))
        rank: dict[str, int] = {}
        by_instance = len(instances) == len(cols)
        for c in cols:
            inst = c.split(".", 1)[0]
            k = rank[inst] = rank.get(inst, -1) + 1
            if by_instance:
                k = instances.index(inst)
            ax.plot(res["time"], res[c], label=c, color=f"C{k % 10}",
                    ls=styles[instances.index(inst) % len(styles)])
        ax.grid(True, alpha=0.3)
        ax.legend(loc="upper right", fontsize=7, ncol=min(3, len(cols)))
        found = sorted({(units or {}).get(c) or "1" for c in cols})
        ax.set_ylabel(", ".join(found))
    axes[-1, 0].set_xlabel("time (s)")
    fig.suptitle(textwrap.fill(title, 100), fontsize=9)
    fig.tight_layout()
    if path is not None:
        fig.savefig(path, dpi=110)
    return fig


def l2_ratio(t: np.ndarray, curves: Mapping[str, tuple[np.ndarray, float | None]], path: Path,
             title: str = "") -> None:
    """Truncated L2 ratio over T of each named curve, with its bound dashed in the same colour
    (seed 000, Fig. 9).

    Parameters
    ----------
    t : numpy.ndarray, shape (n,)
        The horizon T of each sample (s).
    curves : mapping of str to (numpy.ndarray, float or None)
        Metric name -> its ratio curve, shape (n,) (:func:`satfmu.sims.scenario.metrics.l2_ratio_curve`),
        and its upper bound (None: no bound drawn).
    path : Path
        The PNG file to write.
    title : str, optional
        Figure title.
    """
    fig = Figure(figsize=(7, 3.2))
    ax = fig.subplots()
    for k, (name, (ratio, bound)) in enumerate(curves.items()):
        ax.plot(t, ratio, color=f"C{k}", label=name)
        if bound is not None:
            ax.axhline(bound, ls="--", color=f"C{k}", label=f"bound {bound:g}")
    _finish(fig, ax, path, "T (s)", "||z||_2,T / ||w||_2,T", textwrap.fill(title, 90), legend_size=7)


def tradeoff(rows: Sequence, path: Path, title: str = "") -> None:
    """Certified lambda against gamma, one line per variant (rows with ``gamma``, ``variant``,
    ``lam``; an infinite lambda, no certified design, is left out).

    Parameters
    ----------
    rows : sequence of satfmu.synthesis.polynomial_feedback.h2hinf_search.SweepRow
        The points of the trade-off (:func:`satfmu.synthesis.polynomial_feedback.h2hinf_search.sweep`).
    path : Path
        The PNG file to write.
    title : str, optional
        Figure title.
    """
    fig = Figure(figsize=(6, 3.6))
    ax = fig.subplots()
    for k, variant in enumerate(dict.fromkeys(r.variant for r in rows)):
        pts = sorted((r.gamma, r.lam) for r in rows if r.variant == variant and np.isfinite(r.lam))
        if pts:
            g, lam = zip(*pts)
            ax.plot(g, lam, "o-", color=f"C{k}", label=variant)
    _finish(fig, ax, path, "gamma (L2 gain bound w -> sigma)", "lambda (certified H2 bound)",
            textwrap.fill(title, 70), legend_size=8)


def _finish(fig: Figure, ax: Axes, path: Path, xlabel: str, ylabel: str, title: str,
            legend_size: int) -> None:
    """Labels, grid, legend and title of a one-axes figure; write it as PNG."""
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=legend_size)
    ax.set_title(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def region_map(cells: Sequence, path: Path, boxes: Sequence = (),
               trajectory: tuple[np.ndarray, np.ndarray] | None = None,
               title: str = "") -> None:
    """A stability-region map over (q2, w4) like seed 002's Fig. 2: certified cells (objects
    with ``q2``, ``w4`` intervals and ``certified``, ``decay``) shaded by their decay bound,
    failed cells hatched; ``boxes`` (same objects) outlined; ``trajectory`` (q2, w4) drawn.

    Parameters
    ----------
    cells : sequence of satfmu.synthesis.servo.vscmg_region.BoxCertificate
        The map's cells: ``q2`` (rad) and ``w4`` (rad/s) intervals, ``certified``, ``decay``
        (1/s); they set the axis limits.
    path : Path
        The PNG file to write.
    boxes : sequence of satfmu.synthesis.servo.vscmg_region.BoxCertificate, optional
        Boxes to outline (red when certified, black when not).
    trajectory : (numpy.ndarray, numpy.ndarray), optional
        q2 (rad) and w4 (rad/s) along a manoeuvre, same length.
    title : str, optional
        Figure title.
    """
    from matplotlib.patches import Rectangle

    fig = Figure(figsize=(6.4, 4.4))
    ax = fig.subplots()
    decays = [c.decay for c in cells if c.certified]
    top = max(decays, default=1.0)
    cmap = matplotlib.colormaps["Greens"]
    for c in cells:
        (q0, q1), (w0, w1) = c.q2, c.w4
        if c.certified:
            ax.add_patch(Rectangle((q0, w0), q1 - q0, w1 - w0, facecolor=cmap(0.25 + 0.65 * c.decay / top),
                                   edgecolor="white", lw=0.8))
        else:
            ax.add_patch(Rectangle((q0, w0), q1 - q0, w1 - w0, facecolor="0.92", edgecolor="0.6", hatch="xx", lw=0.5))
    for k, b in enumerate(boxes):
        (q0, q1), (w0, w1) = b.q2, b.w4
        ax.add_patch(Rectangle((q0, w0), q1 - q0, w1 - w0, fill=False, edgecolor="C3" if b.certified else "k", lw=2,
                               label=(f"box {'certified' if b.certified else 'NOT certified'} (one Y)" if k == 0
                                      else None)))
    if trajectory is not None:
        ax.plot(*trajectory, color="C0", lw=1.5, label="seed manoeuvre (q2, w4)")
    ax.plot([], [], "s", color=cmap(0.6), label="cell certified (shade: decay bound)")
    ax.plot([], [], "s", color="0.85", label="cell not certified")
    q = [v for c in cells for v in c.q2] or [0, 1]
    w = [v for c in cells for v in c.w4] or [-1, 1]
    ax.set_xlim(min(q), max(q))
    ax.set_ylim(min(w), max(w))
    secax = ax.secondary_xaxis("top", functions=(np.sin, np.arcsin))
    secax.set_xlabel("a = sin q2", fontsize=8)
    _finish(fig, ax, path, "q2 (rad)", "w4 (rad/s)", textwrap.fill(title, 80), legend_size=7)


def detumble_linear(runs: Sequence, path: Path, title: str = "") -> None:
    """Seed 003 Fig. 2 analogue: rates and dipoles at the sampling instants of the linear model.

    ``runs`` are :class:`satfmu.sims.workflows.detumble.LinearRun`: per gain set, the exact RMS rate, the Monte
    Carlo one, the 10-90 % band of ``|w(k)|`` and the median ``|m(k)|``, against orbit time (min).

    Parameters
    ----------
    runs : sequence of satfmu.sims.workflows.detumble.LinearRun
        One per gain set (:func:`satfmu.sims.workflows.detumble.linear_campaign`).
    path : Path
        The PNG file to write.
    title : str, optional
        Figure title.
    """
    fig = Figure(figsize=(8, 6))
    ax_w, ax_m = fig.subplots(2, 1, sharex=True)
    for i, r in enumerate(runs):
        color = f"C{i}"
        t = r.k * 15.0
        ax_w.semilogy(t, r.rms(), "-", color=color, label=f"{r.label}: exact RMS (rho = {r.spectral_radius:.3g})")
        ax_w.semilogy(t, np.sqrt(r.ms_mc), "o", color=color, ms=4, label=f"{r.label}: Monte Carlo RMS")
        lo, hi = np.percentile(r.rate_samples, [10, 90], axis=0)
        ax_w.fill_between(t, lo, hi, color=color, alpha=0.2, step=None)
        ax_m.step(t[:-1], np.median(r.dipole_samples, axis=0), where="post", color=color, label=r.label)
    ax_w.set_ylabel("|w| at the samples, rad/s")
    ax_w.legend(fontsize=7)
    ax_m.set_ylabel("median |m| held, A m^2")
    ax_m.set_xlabel("orbit time, min (samples every 15 min)")
    ax_m.legend(fontsize=7)
    for ax in (ax_w, ax_m):
        ax.grid(True, alpha=0.3)
    fig.suptitle("\n".join(textwrap.wrap(title, 90)), fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def detumble_sweep(rows: Sequence, path: Path, title: str = "") -> None:
    """``|w(2 orbits)| / |w(0)|`` and dipole effort against ``|w(0)|`` per controller
    (:class:`satfmu.sims.workflows.detumble.SweepRow`).

    Parameters
    ----------
    rows : sequence of satfmu.sims.workflows.detumble.SweepRow
        The rows of :func:`satfmu.sims.workflows.detumble.sweep`.
    path : Path
        The PNG file to write.
    title : str, optional
        Figure title.
    """
    fig = Figure(figsize=(8, 6))
    ax_r, ax_e = fig.subplots(2, 1, sharex=True)
    for label in dict.fromkeys(r.controller for r in rows):
        mine = sorted((r for r in rows if r.controller == label), key=lambda r: r.w0)
        w0 = [r.w0 for r in mine]
        ax_r.loglog(w0, [r.final_ratio for r in mine], "o-", label=label)
        ax_e.loglog(w0, [max(r.effort, 1e-30) for r in mine], "o-", label=label)
    ax_r.axhline(0.1, color="k", lw=0.8, ls="--", label="10x reduction")
    ax_r.set_ylabel("|w| after 2 orbits / |w(0)|")
    ax_e.set_ylabel("integral |m|^2 dt, A^2 m^4 s")
    ax_e.set_xlabel("|w(0)|, rad/s")
    for ax in (ax_r, ax_e):
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle("\n".join(textwrap.wrap(title, 90)), fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
