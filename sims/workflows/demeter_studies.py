"""Seed 004's workflows on the DEMETER satellite, each writing its files and returning its result.

- :func:`table1`: the rows of the seed's Table 1, both methods, beside the seed's numbers;
- :func:`figures`: Figs 4-5, random closed loops through the FMUs (with and without the wheel
  limits) and on the design model (:mod:`satfmu.sims.workflows.demeter_loops`);
- :func:`campaign`: closed-loop poles, exact H-infinity and impulse-to-peak of sampled plants
  under a design, on Dask (:mod:`satfmu.sims.campaign.engine`), with the worst-case and Chernoff statements.

Each result's ``text()`` is what the command line prints.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from satfmu.controllers import catalog
from satfmu.sims.workflows import demeter_loops
from satfmu.synthesis.core.progress import Progress



@dataclass
class Table1Result:
    """The rows :func:`table1` computed, the files it wrote and its wall time.

    Parameters
    ----------
    rows : list of satfmu.synthesis.robust.demeter_table.Row
        One per selected row and method (and convention, with ``convention="both"``).
    files : list of Path
        The tables written (``table1.md``, ``table1.csv``; per convention with ``"both"``).
    seconds : float, optional
        Wall time of the whole run, s.
    jobs : int, optional
        Rows run at once.
    """

    rows: list
    """:class:`satfmu.synthesis.robust.demeter_table.Row` per selected row and method."""
    files: list[Path]
    seconds: float = 0.0
    """Wall time of the whole run, s."""
    jobs: int = 1
    """Rows run at once."""

    def text(self) -> str:
        """The table in Markdown, the wall time and the files written."""
        from satfmu.synthesis.robust import demeter_table

        rows = sum(r.total_seconds for r in self.rows)
        return (demeter_table.markdown(self.rows) + f"\n{len(self.rows)} rows in {self.seconds:.0f} s of wall time "
                f"({self.jobs} at once; the rows' own times add up to {rows:.0f} s)\n"
                f"wrote {', '.join(map(str, self.files))}")


def table1(out_dir: Path, rows: Sequence[int] | None = None, *, scenarios: int | None = None,
           progress: Progress | None = None, convention: str = "satfmu", jobs: int = 1) -> Table1Result:
    """Seed 004 Table 1: the selected rows, both methods; the files are rewritten after each row,
    keeping the rows of earlier runs that this one does not redo.

    Parameters
    ----------
    out_dir : Path
        Receives ``table1.md`` and ``table1.csv``; with ``convention="both"`` each convention's
        in a sub-folder of its name, and ``table1.md`` the two side by side
        (:func:`table1_comparison`).
    rows : sequence of int, optional
        Rows 1..14 in the seed's order (default: all).
    scenarios : int, optional
        Sampled plants per Prob design (default: the Campi-Garatti count, epsilon 0.1, delta 1e-9).
    progress : callable, optional
        Called after each row.
    convention : {"satfmu", "romuloc", "both"}
        LMI forms and objective of the designs (:func:`satfmu.synthesis.robust.robust_design.design`); "both":
        every row in the toolbox's convention, then every row in ours.
    jobs : int
        Rows run at once, each in its own process (:func:`satfmu.synthesis.robust.demeter_table.run`); on this
        project's 2-core machine ``jobs=2`` runs the whole table in about half the rows' summed
        time.

    Raises
    ------
    ValueError
        If a row number is out of range or ``jobs`` is below 1.
    """
    import time

    from satfmu.synthesis.robust import demeter_table
    from satfmu.synthesis.robust.demeter_variants import SEED_TABLE1

    t0 = time.perf_counter()
    keys = list(SEED_TABLE1)
    if rows:
        bad = [r for r in rows if not 1 <= r <= len(keys)]
        if bad:
            raise ValueError(f"rows must be in 1..{len(keys)} (the seed's order), got {bad}")
        keys = [keys[r - 1] for r in rows]
    out_dir = Path(out_dir)
    options: dict[str, Any] = {"n_scenarios": scenarios, "progress": progress, "jobs": jobs}
    if convention != "both":
        found = demeter_table.run(keys, out_dir=out_dir, convention=convention, **options)
        return Table1Result(found, [out_dir / "table1.md", out_dir / "table1.csv"], time.perf_counter() - t0, jobs)
    found = []
    for conv in BOTH:
        found += demeter_table.run(keys, out_dir=out_dir / conv, convention=conv, **options)
    table1_comparison(out_dir)
    return Table1Result(found, [out_dir / "table1.md"] + [out_dir / c / f for c in BOTH
                                                          for f in ("table1.md", "table1.csv")],
                        time.perf_counter() - t0, jobs)


BOTH = ("romuloc", "satfmu")
"""The conventions of ``table1(convention="both")``, in their order and folder names."""


def table1_comparison(out_dir: Path) -> Path:
    """``out_dir/table1.md``: the rows of ``out_dir/romuloc/table1.csv`` beside those of
    ``out_dir/satfmu/table1.csv`` (:func:`satfmu.synthesis.robust.demeter_table.comparison`), without running
    anything.

    Parameters
    ----------
    out_dir : Path
        Folder of a ``table1(convention="both")`` run: holds the ``romuloc`` and ``satfmu``
        sub-folders (:data:`BOTH`) and receives ``table1.md``.

    Returns
    -------
    Path
        The Markdown file written.

    Raises
    ------
    FileNotFoundError
        If either table is missing.
    ValueError
        If one is not a Table 1 file.
    """
    from satfmu.synthesis.robust import demeter_table

    toolbox, ours = (demeter_table.read(Path(out_dir) / c / "table1.csv") for c in BOTH)
    path = Path(out_dir) / "table1.md"
    path.write_text("Seed 004 Table 1 in the R-RoMulOC toolbox's convention, ours / seed's (ratio), then the same "
                    "rows in satfmu's convention (i2p N m s, H-infinity rad/(N m), seconds on this machine)\n\n"
                    + demeter_table.comparison(toolbox, ours) + "\n")
    return path


@dataclass
class FiguresResult:
    """The loops of :func:`figures`: FMUs with wheel limits, FMUs without, the design model.

    Parameters
    ----------
    loops : dict of str to satfmu.sims.workflows.demeter_loops.RandomLoops
        ``"wheels"``, ``"linear"`` (FMUs) and ``"design"`` (the design model, exact).
    step_size : float
        Communication step of the FMU runs, s.
    files : dict of str to list of Path, optional
        The PNG files of each entry of ``loops``.
    """

    loops: dict[str, demeter_loops.RandomLoops]
    """``"wheels"``, ``"linear"`` (FMUs) and ``"design"`` (the design model, exact)."""
    step_size: float
    """Communication step of the FMU runs, s."""
    files: dict[str, list[Path]] = field(default_factory=dict)
    """The PNG files of each entry of :attr:`loops`."""

    def text(self) -> str:
        """One line per set of loops: peaks, final attitude, and the files."""
        lines = []
        for key, loops in self.loops.items():
            n, stop = len(loops.deltas), loops.time[-1]
            peaks = (f"peak |z2| {np.abs(loops.z2).max():.4g} N m s, |theta| at the end <= "
                     f"{np.abs(loops.theta[:, -1]).max():.4g} rad")
            files = ", ".join(map(str, self.files[key]))
            if key == "design":
                lines.append(f"design model, {n} loops, {stop:g} s: {peaks}; {files}")
                continue
            extra = (f"largest |theta - exact design model| {loops.linear_error:.3g} rad" if key == "linear" else
                     f"time at the momentum limit: up to {100 * loops.saturated.max():.3g} % of the run")
            lines.append(f"FMUs ({'wheel limits' if key == 'wheels' else 'no limits'}), {n} loops, {stop:g} s at "
                         f"{self.step_size:g} s: {peaks}; {extra}; {files}")
        return "\n".join(lines)


def figures(fmu_dir: Path, out_dir: Path, artifact: str | Path = "demeter_row1_det", *, samples: int = 100,
            seed: int = 0, stop_time: float = 60.0, step_size: float = 1e-3,
            linear_stop_time: float = 10000.0) -> FiguresResult:
    """Seed 004 Figs 4-5 through the FMUs (with and without wheel limits: scenario campaigns of
    :func:`satfmu.sims.workflows.demeter_loops.scenario`) and on the design model (the same plants, exactly).

    The plant and controller FMUs missing from ``fmu_dir`` are built first (:func:`satfmu.controllers.catalog.ensure`).

    Parameters
    ----------
    fmu_dir : Path
        Folder of the FMUs.
    out_dir : Path
        Receives the PNG files.
    artifact : str or Path
        DEMETER design artifact: name (:func:`satfmu.controllers.paths.find_artifact`) or ``.json`` path.
    samples : int
        Random plants.
    seed : int
        Seed of the plant samples.
    stop_time : float
        FMU horizon, s.
    step_size : float
        Communication step, s (the row-1 design needs <= 1.5 ms; :mod:`satfmu.sims.workflows.demeter_loops`).
    linear_stop_time : float
        Design-model horizon, s.
    """
    art, _ = demeter_loops.load_design(artifact)
    catalog.ensure(fmu_dir, ["demeter_flexible", art.name])
    out_dir = Path(out_dir)
    result = FiguresResult({}, step_size)
    for limits in ("wheels", "linear"):
        result.loops[limits] = demeter_loops.run(Path(fmu_dir), artifact, n=samples, seed=seed, stop_time=stop_time,
                                                 step_size=step_size, limits=limits)
    result.loops["design"] = demeter_loops.linear(artifact, deltas=result.loops["wheels"].deltas,
                                                  stop_time=linear_stop_time)  # the same plants
    result.files = {key: demeter_loops.plot(loops, out_dir) for key, loops in result.loops.items()}
    return result


@dataclass
class ProbabilisticCampaign:
    """The samples of :func:`campaign` and the statements on each result column.

    Parameters
    ----------
    name : str
        Campaign name (its folder's name).
    folder : Path
        Folder of the campaign's Parquet files.
    results : pandas.DataFrame
        The samples, one row per sampled plant.
    summaries : list of satfmu.sims.campaign.engine.Summary
        The statements on each result column (``hinf``, ``i2p``, ``max_real_pole``).
    """

    name: str
    folder: Path
    """Folder of the campaign's Parquet files."""
    results: Any
    """The samples (``pandas.DataFrame``, one row per sample)."""
    summaries: list
    """:class:`satfmu.sims.campaign.engine.Summary` of each result column."""

    def text(self) -> str:
        """The statements of every column."""
        return "\n".join(s.text() for s in self.summaries)


def campaign(out_dir: Path, artifact: str | Path = "demeter_row1_det", *, samples: int = 100_000, seed: int = 0,
             chunk: int = 5000, workers: int = 2, scheduler: str | None = None, epsilon: float = 0.1,
             delta: float = 1e-6, name: str | None = None,
             progress: Callable[[int, int], None] | None = None, tls: Any = None) -> ProbabilisticCampaign:
    """Seed 004 Monte Carlo: poles, exact H-infinity and i2p of sampled plants under a design.

    Resumable: running it again skips the chunks already written (:func:`satfmu.sims.campaign.engine.run`).

    Parameters
    ----------
    out_dir : Path
        Folder of the campaign folders.
    artifact : str or Path
        DEMETER design artifact: name (:func:`satfmu.controllers.paths.find_artifact`) or ``.json`` path.
    samples : int
        Sampled plants.
    seed : int
        Root seed (results depend only on seed, chunk and samples).
    chunk : int
        Samples per task and per Parquet file.
    workers : int
        Local Dask workers (ignored with ``scheduler``).
    scheduler : str, optional
        Address of a running Dask scheduler, ``tls://host:port`` (or ``tcp://`` on a trusted network).
    epsilon, delta : float
        Accuracy and 1 - confidence of the statements.
    name : str, optional
        Campaign (folder) name (default: ``<artifact>-n<samples>-s<seed>``).
    progress : callable, optional
        ``progress(done, total)`` in chunks.
    tls : distributed.security.Security, optional
        The security of a ``tls://`` scheduler (:func:`satfmu.sims.campaign.cluster.security`).
    """
    from satfmu.sims.campaign import engine as campaigns
    from satfmu.synthesis.robust import demeter_design
    from satfmu.synthesis.robust import demeter_random

    art, variant = demeter_loops.load_design(artifact)
    task = demeter_random.ClosedLoopSamples(variant, np.array(art.design["K"]))
    camp = campaigns.Campaign(name=name or f"{art.name}-n{samples}-s{seed}", task=task, n=samples, seed=seed,
                              chunk=chunk, sampler=demeter_random.BoxSampler(len(task.design_model().parameters)))
    df = campaigns.run(camp, Path(out_dir), scheduler=scheduler, n_workers=workers, progress=progress, tls=tls)
    numbers = art.certificate.get("numbers", {})
    levels = {"hinf": numbers.get("analysis_hinf_pdlf"), "i2p": numbers.get("analysis_i2p"),
              "max_real_pole": -demeter_design.ALPHA}
    return ProbabilisticCampaign(camp.name, Path(out_dir) / camp.name, df,
                          [campaigns.summarize(df, column, level=level, epsilon=epsilon, delta=delta)
                           for column, level in levels.items()])
