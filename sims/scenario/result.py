"""The result of a scenario run: its recorded signals, metrics and pass/fail, and the files it writes."""
from __future__ import annotations

import csv
import io
import json
import shutil
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from satfmu.fmus.atomic import write_atomically
from satfmu.fmus.declared import did_you_mean
from satfmu.sims.scenario.metrics import MetricResult

if TYPE_CHECKING:
    from matplotlib.figure import Figure
from satfmu.sims.scenario.spec import Scenario


class Metrics(list):
    """The metric results of a run, in the scenario's order, also indexed by name:
    ``result.metrics[0]`` and ``result.metrics["peak torque"]`` are both a
    :class:`~satfmu.sims.scenario.metrics.MetricResult` (``.value``, ``.passed``, ...).

    Parameters
    ----------
    iterable : iterable of MetricResult, optional
        The results (as ``list`` takes them).
    """

    def __getitem__(self, key: Any) -> Any:
        if isinstance(key, str):
            for m in self:
                if m.name == key:
                    return m
            names = [m.name for m in self]
            raise KeyError(f"no metric {key!r} (metrics: {names}){did_you_mean(key, names)}")
        return super().__getitem__(key)

    def names(self) -> list[str]:
        """The metrics' names, in order."""
        return [m.name for m in self]


@dataclass
class Result:
    """Outcome of one scenario run: the recorded signals, the metrics, pass/fail.

    Attributes
    ----------
    name : str
        The scenario's name.
    backend : str
        Default FMU backend of the run.
    results : numpy structured array
        One row per communication time: ``time`` (s) and every recorded
        ``instance.variable`` (its unit: ``units``).
    metrics : Metrics
        Name, value, unit, bounds and pass/fail of each metric, in order and by name
        (``result.metrics["peak torque"].value``).
    files : dict of str to Path
        What :meth:`write` wrote (csv, plot, summary, l2_ratio_plot).
    l2_curves : dict of str to ndarray
        The truncated L2 ratio over T of each ``l2_ratio`` metric.
    units : dict of str to str
        Unit of each recorded column.
    panels : list of list of str
        Columns of each plot panel.
    title : str
        Plot title.
    warnings : list of str
        Design mismatches found (a controller paired with a plant it was not designed for).
    scenario : Scenario, optional
        The scenario that ran (:meth:`write` records its declaration and FMU files).
    fmu_dir : Path, optional
        The FMU folder of the run.
    csv : Path, optional
        The CSV a streamed run wrote as it went (:func:`satfmu.sims.scenario.run.run` with
        ``stream``): every recorded column is there, and ``results`` holds only those its
        metrics and plot read.
    """

    name: str
    backend: str
    results: np.ndarray
    metrics: "Metrics | list[MetricResult]"  # a list becomes Metrics (__post_init__)
    files: dict[str, Path] = field(default_factory=dict)
    l2_curves: dict[str, np.ndarray] = field(default_factory=dict)
    units: dict[str, str] = field(default_factory=dict)
    panels: list[list[str]] = field(default_factory=list)
    title: str = ""
    warnings: list[str] = field(default_factory=list)
    scenario: Scenario | None = None
    fmu_dir: Path | None = None
    csv: Path | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.metrics, Metrics):
            self.metrics = Metrics(self.metrics)

    @property
    def passed(self) -> bool:
        """Whether every metric is within its bounds."""
        return all(m.passed for m in self.metrics)

    def metric(self, name: str) -> MetricResult:
        """The metric of that name.

        Parameters
        ----------
        name : str
            The metric's ``name`` in the scenario.

        Returns
        -------
        satfmu.sims.scenario.metrics.MetricResult

        Raises
        ------
        KeyError
            With the names there are and the closest one.
        """
        for m in self.metrics:
            if m.name == name:
                return m
        names = [m.name for m in self.metrics]
        raise KeyError(f"{self.name}: no metric {name!r} (metrics: {names}){did_you_mean(name, names)}")

    def summary(self) -> dict[str, Any]:
        """Scenario, backend, pass/fail, every metric and the files written, as plain data."""
        return {"scenario": self.name, "backend": self.backend, "passed": self.passed,
                "metrics": [m.to_json() for m in self.metrics],
                "files": {k: str(v) for k, v in self.files.items()}, "warnings": self.warnings}

    def plot(self, path: str | Path | None = None) -> Figure:
        """The recorded signals against time, one panel per group of the scenario's ``[plot]``.

        Parameters
        ----------
        path : path, optional
            A PNG file to write it to as well (its folder is created if missing).

        Returns
        -------
        matplotlib.figure.Figure
            The figure to draw on or show (``fig.axes[0]`` is the top panel); it is not held
            by pyplot, so nothing needs closing.
        """
        from satfmu.sims.scenario import plots

        if path is not None:
            Path(path).parent.mkdir(parents=True, exist_ok=True)
        return plots.time_series(self.results, self.panels, None if path is None else Path(path), title=self.title,
                                 units=self.units)

    def write(self, folder: str | Path, plots: bool = True) -> dict[str, Path]:
        """Write ``<name>_<backend>.csv``, the plot(s), ``scenario_<backend>.json`` and
        ``summary_<backend>.json`` into ``folder``; returns (and records in ``files``) what
        was written.

        ``scenario_<backend>.json`` (written when ``scenario`` is known) holds what a report
        of the run needs beside the summary: the scenario's declaration
        (:meth:`Scenario.to_dict`), the folder its relative paths resolve against, the backend,
        the FMU folder and each FMU file's name and SHA-256
        (:func:`satfmu.sims.scenario.provisioning.context`), and the unit of every recorded column.

        The files of an earlier run of the same scenario and backend are removed first, every
        file is written whole (temporary name, then rename) and the summary comes last: a
        folder with a summary holds a complete run, one without it no run that looks complete.

        Parameters
        ----------
        folder : path
            The output folder (created if missing).
        plots : bool, optional
            Draw the PNG plots (default): ``<name>_<backend>.png`` (:meth:`plot`) and, with an L2
            ratio metric, ``<name>_<backend>_l2_ratio.png``. Drawing them costs about 1 s of CPU
            (matplotlib's imports and rendering), most of a short run: without them the files
            hold every recorded value all the same.

        Returns
        -------
        dict of str to Path
            ``csv``, ``plot``, ``l2_ratio_plot``, ``scenario``, ``summary`` (those written), and
            any file recorded before (``sample`` of a replay).
        """
        folder = Path(folder)
        stem = f"{self.name}_{self.backend}"
        files = {"csv": folder / f"{stem}.csv"}
        streamed_here = self.csv is not None and self.csv.resolve() == files["csv"].resolve()
        clear_outputs(folder, self.name, self.backend, keep_csv=streamed_here)
        if self.csv is None:
            write_atomically(files["csv"], lambda tmp: write_csv(self.results, tmp))
        elif not streamed_here:  # a streamed run's CSV holds the columns results lacks
            csv_file = self.csv
            write_atomically(files["csv"], lambda tmp: shutil.copyfile(csv_file, tmp))
        if plots and self.panels:  # a run that records nothing has nothing to plot
            files["plot"] = write_atomically(folder / f"{stem}.png", self.plot)
        if plots and self.l2_curves:
            from satfmu.sims.scenario import plots as figures

            files["l2_ratio_plot"] = folder / f"{stem}_l2_ratio.png"
            bounds = {m.name: m.max for m in self.metrics}
            write_atomically(files["l2_ratio_plot"], lambda tmp: figures.l2_ratio(
                self.results["time"], {n: (c, bounds[n]) for n, c in self.l2_curves.items()}, tmp,
                title=f"{self.name}: truncated L2 ratio over T"))
        if self.scenario is not None and self.fmu_dir is not None:
            from satfmu.sims.scenario.provisioning import context

            files["scenario"] = folder / f"scenario_{self.backend}.json"
            record = {**context(self.scenario, self.fmu_dir, self.backend), "units": self.units}
            write_atomically(files["scenario"], lambda tmp: tmp.write_text(json.dumps(record, indent=1) + "\n"))
        files["summary"] = folder / f"summary_{self.backend}.json"
        self.files.update(files)
        write_atomically(files["summary"], lambda tmp: tmp.write_text(json.dumps(self.summary(), indent=1) + "\n"))
        return dict(self.files)


def clear_outputs(folder: Path, name: str, backend: str, keep_csv: bool = False) -> None:
    """Remove the result files of an earlier run of ``name`` with ``backend`` from ``folder``.

    Parameters
    ----------
    folder : Path
        The run's output folder.
    name : str
        The scenario's name.
    backend : str
        The run's backend (``"native"`` or ``"python"``).
    keep_csv : bool, optional
        Leave the CSV (a streamed run's, just written). Default False.
    """
    for f in ((f"{name}_{backend}.csv",) if not keep_csv else ()) + (
            f"{name}_{backend}.png", f"{name}_{backend}_l2_ratio.png", f"scenario_{backend}.json",
            f"summary_{backend}.json"):
        (Path(folder) / f).unlink(missing_ok=True)


def write_csv(res: np.ndarray, path: Path) -> None:
    """Write a structured result array as CSV: a header of the field names, then one line per row
    (:class:`CsvWriter` given every row at once).

    Parameters
    ----------
    res : numpy.ndarray
        Structured array, one field per column.
    path : Path
        The CSV file (overwritten).

    Raises
    ------
    ValueError
        ``res`` has no named fields.
    """
    with CsvWriter(path) as write:
        write(res)


class CsvWriter:
    """A CSV file of recorded rows written as they come: the header of the first block's field
    names, then one line per row of each block (``writer(rows)``), the same text for any split.

    Each number is the shortest text that reads back as the same float64 (``0.05``, ``1e-310``,
    ``-0``, ``nan``, ``inf``), written by Arrow's CSV writer in C++ (about 5x faster than a Python
    loop of ``repr``); the header is quoted where a name needs it (``a[1,2]``). A context
    manager: the file is closed at exit.

    Parameters
    ----------
    path : Path
        The CSV file (overwritten).
    """

    def __init__(self, path: Path) -> None:
        self._file = open(path, "wb")
        self._names: tuple[str, ...] | None = None

    def __call__(self, rows: np.ndarray) -> None:
        """Append ``rows`` (a structured array, the first block's fields in the same order).

        Raises
        ------
        ValueError
            ``rows`` has no named fields, or not those of the first block.
        """
        import pyarrow as pa
        from pyarrow import csv as pa_csv

        names = rows.dtype.names
        if names is None:
            raise ValueError(f"a CSV of recorded rows needs a structured array (named fields), got dtype {rows.dtype}")
        if self._names is None:
            self._names = names
            header = io.StringIO()
            csv.writer(header, lineterminator="\n").writerow(names)
            self._file.write(header.getvalue().encode())
        elif names != self._names:
            raise ValueError(f"a block's fields {list(names)} are not the file's {list(self._names)}")
        if len(rows) == 0:
            return
        # from the columns' buffers: pa.array(numpy) imports pandas (~0.5 s), for a type check
        columns = [np.ascontiguousarray(rows[n], dtype=np.float64) for n in names]
        table = pa.Table.from_arrays([pa.Array.from_buffers(pa.float64(), len(c), [None, pa.py_buffer(c)])
                                      for c in columns], names=[f"c{i}" for i in range(len(names))])
        pa_csv.write_csv(table, self._file, pa_csv.WriteOptions(include_header=False))

    def __enter__(self) -> "CsvWriter":
        return self

    def __exit__(self, *exc: object) -> None:
        self._file.close()
