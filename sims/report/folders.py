"""The folders a report reads: a scenario run (``satfmu run --out``) or a scenario campaign.

A run folder holds, per backend, what :meth:`satfmu.sims.scenario.result.Result.write` writes:
``summary_<backend>.json`` (metrics, pass/fail), ``<name>_<backend>.csv`` (the recorded
signals) and ``scenario_<backend>.json`` (the scenario's declaration, its FMU files with their
SHA-256 and the unit of every recorded column). A campaign folder holds ``campaign.json`` and
the Parquet chunks of :mod:`satfmu.sims.campaign.engine`; it is read back with
:func:`satfmu.sims.campaign.scenario_task.reopen` (which checks that its FMU files are the ones that ran),
:func:`satfmu.sims.campaign.engine.load` and
:func:`satfmu.sims.campaign.statistics.statistics`. A campaign folder
may also hold ``envelopes.parquet``: column ``time`` (s) and one column
``<signal>:p<percentile>`` per recorded signal and percentile (the signal's percentile over
the samples at each time, in the signal's unit).
"""
from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd

from satfmu.sims.scenario import metrics as scenario_metrics
from satfmu.sims.cosim import preflight
from satfmu.sims.scenario.provisioning import fmu_paths
from satfmu.sims.scenario.spec import Scenario
from satfmu.sims.campaign.engine import Campaign, CampaignError
from satfmu.sims.campaign.scenario_task import ScenarioTask
from satfmu.sims.campaign.statistics import Statistics
from satfmu.fmus.errors import ReportError, ScenarioError

ENVELOPES = "envelopes.parquet"
"""File name of a campaign's percentile envelopes (optional)."""
_ENVELOPE_COLUMN = re.compile(r"^(?P<signal>[A-Za-z_][\w.]*(?:\[\d+(?:,\d+)*\])?):p(?P<p>\d+(?:\.\d+)?)$")


@dataclass(frozen=True)
class FmuFile:
    """One FMU instance of a run or campaign: the file it ran and where that file is now.

    Parameters
    ----------
    instance : str
        The scenario's instance name (``"controller"``).
    model : str
        The scenario's ``model`` (or the file name of a ``path`` FMU).
    path : Path
        Where the FMU file is looked for now.
    sha256 : str
        SHA-256 of the file that ran (hex), as the run or campaign recorded it.
    """

    instance: str
    model: str
    path: Path
    sha256: str

    def current_sha256(self) -> str | None:
        """SHA-256 of the file at ``path`` now (hex), None if there is no such file."""
        return preflight.sha256_file(self.path) if self.path.is_file() else None


@dataclass(frozen=True)
class RunFolder:
    """One scenario run of a run folder (one backend).

    Attributes
    ----------
    folder : Path
    backend : str
    scenario : Scenario
        As it ran (its declaration, relative paths resolved as then).
    metrics : list of satfmu.sims.scenario.metrics.MetricResult
        Value, unit, bounds and pass/fail of each metric, from the summary.
    results : pandas.DataFrame
        The recorded signals: ``time`` (s) and one column per ``instance.variable``.
    units : dict of str to str
        Unit of each recorded column.
    fmus : dict of str to FmuFile
    warnings : list of str
        Design mismatches the run reported.
    """

    folder: Path
    backend: str
    scenario: Scenario
    metrics: list[scenario_metrics.MetricResult]
    results: pd.DataFrame
    units: dict[str, str]
    fmus: dict[str, FmuFile]
    warnings: list[str]

    @property
    def label(self) -> str:
        """``<scenario> (<backend>)``."""
        return f"{self.scenario.name} ({self.backend})"

    @property
    def passed(self) -> bool:
        """Every metric within its bounds."""
        return all(m.passed for m in self.metrics)


@dataclass(frozen=True)
class CampaignFolder:
    """A scenario campaign's folder, read back.

    Attributes
    ----------
    folder : Path
    campaign : Campaign
        As :func:`satfmu.sims.campaign.scenario_task.reopen` gives it (``task.scenario``, ``context``).
    rows : pandas.DataFrame
        One row per sample (:mod:`satfmu.sims.campaign.scenario_task`'s columns).
    statistics : Statistics
    envelopes : pandas.DataFrame, optional
        ``envelopes.parquet`` when the folder holds one.
    fmus : dict of str to FmuFile
    """

    folder: Path
    campaign: Campaign[ScenarioTask]
    rows: pd.DataFrame
    statistics: Statistics
    envelopes: pd.DataFrame | None
    fmus: dict[str, FmuFile]

    @property
    def scenario(self) -> Scenario:
        """The campaign's (nominal) scenario."""
        return self.campaign.task.scenario

    @property
    def label(self) -> str:
        """The campaign's name."""
        return self.campaign.name

    @property
    def dispersed(self) -> list[str]:
        """The dispersed value columns of the rows (``plant.I_x``, ``profiles[0].after``)."""
        return [f"{owner}.{name}" for owner, name in self.campaign.task.dispersed]

    @property
    def backend(self) -> str:
        """The campaign's default FMU backend."""
        return self.campaign.task.backend


Folder = RunFolder | CampaignFolder
"""What :func:`read_folder` returns."""


def read_folder(path: str | Path, fmu_dir: str | Path | None = None, confidence: float = 0.95,
                worst: int = 5) -> list[Folder]:
    """The runs (one per backend) or the campaign a folder holds.

    Parameters
    ----------
    path : path
        A run folder (``summary_<backend>.json``) or a scenario campaign's folder (``campaign.json``).
    fmu_dir : path, optional
        Where the FMU files are now (default: the folder the run or campaign used).
    confidence : float
        Two-sided confidence of a campaign's pass-rate intervals, in (0, 1).
    worst : int
        How many worst samples of a campaign to list, >= 0.

    Returns
    -------
    list of RunFolder or CampaignFolder

    Raises
    ------
    ReportError
        A missing folder, a folder that is neither, a corrupt summary, scenario record, CSV,
        ``campaign.json``, chunk or ``envelopes.parquet`` (one line naming the file).
    """
    folder = Path(path)
    if not folder.is_dir():
        raise ReportError(f"{folder}: no such folder" if not folder.exists() else f"{folder}: not a folder")
    if (folder / "campaign.json").is_file():
        return [_campaign(folder, fmu_dir, confidence, worst)]
    summaries = sorted(folder.glob("summary_*.json"))
    if summaries:
        return [_run(folder, f, fmu_dir) for f in summaries]
    inside = sorted(p.name for p in folder.iterdir() if p.is_dir() and (
        (p / "campaign.json").is_file() or any(p.glob("summary_*.json"))))
    hint = f"; it holds run or campaign folders, name them: {', '.join(inside)}" if inside else ""
    raise ReportError(f"{folder}: neither a run folder (summary_<backend>.json, as `satfmu run --out` writes) "
                      f"nor a scenario campaign folder (campaign.json){hint}")


def _json(path: Path) -> Any:
    try:
        return json.loads(path.read_text())
    except FileNotFoundError:
        raise ReportError(f"{path}: missing") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ReportError(f"{path}: not readable JSON ({exc})") from None


def _run(folder: Path, summary_file: Path, fmu_dir: str | Path | None) -> RunFolder:
    """The run whose summary is ``summary_file``."""
    backend = summary_file.stem[len("summary_"):]
    summary = _json(summary_file)
    try:
        name, metrics = summary["scenario"], [
            scenario_metrics.MetricResult(m["name"], m["kind"], _float(m["value"]), m["min"], m["max"], m["unit"])
            for m in summary["metrics"]]
        warnings = [str(w) for w in summary.get("warnings", [])]
    except (TypeError, KeyError, ValueError) as exc:
        raise ReportError(f"{summary_file}: not a run summary of satfmu (missing or bad {exc})") from None
    record_file = folder / f"scenario_{backend}.json"
    if not record_file.is_file():
        raise ReportError(f"{folder}: no {record_file.name} beside {summary_file.name} (a run folder of an older "
                          "satfmu): run the scenario again with `satfmu run SCENARIO --out DIR`")
    record = _json(record_file)
    try:
        scenario = Scenario.from_dict(record["scenario"], record["base_dir"], str(record_file),
                                      None if record.get("path") is None else Path(record["path"]))
        units = {str(k): str(v) for k, v in record["units"].items()}
        fmus = _fmu_files(scenario, Path(fmu_dir or record["fmu_dir"]), record["backend"], record["fmus"])
    except (TypeError, KeyError, ScenarioError) as exc:
        raise ReportError(f"{record_file}: not a scenario record of satfmu ({exc})") from None
    if scenario.name != name:
        raise ReportError(f"{record_file}: scenario {scenario.name!r}, but {summary_file.name} is of {name!r}")
    csv = folder / f"{name}_{backend}.csv"
    try:
        results = pd.read_csv(csv)
    except FileNotFoundError:
        raise ReportError(f"{csv}: missing (the run's recorded signals)") from None
    except (OSError, ValueError, pd.errors.ParserError) as exc:
        raise ReportError(f"{csv}: not readable CSV ({exc})") from None
    if "time" not in results.columns or len(results) == 0:
        raise ReportError(f"{csv}: no 'time' column or no rows")
    return RunFolder(folder, backend, scenario, metrics, results, units, fmus, warnings)


def _float(v: Any) -> float:
    return math.nan if v is None else float(v)


def _campaign(folder: Path, fmu_dir: str | Path | None, confidence: float, worst: int) -> CampaignFolder:
    from satfmu.sims.campaign import engine
    from satfmu.sims.campaign.scenario_task import reopen
    from satfmu.sims.campaign.statistics import statistics as campaign_statistics

    try:
        camp = reopen(folder, fmu_dir)
        rows = engine.load(folder)
        statistics = campaign_statistics(camp.task.scenario, rows, confidence, worst)
    except (CampaignError, ScenarioError) as exc:
        raise ReportError(f"cannot report on {folder}: {exc}") from None
    envelopes = None
    if (folder / ENVELOPES).is_file():
        envelopes = read_envelopes(folder / ENVELOPES)
    fmus = _fmu_files(camp.task.scenario, Path(camp.task.fmu_dir), camp.task.backend, camp.context["fmus"])
    return CampaignFolder(folder, camp, rows, statistics, envelopes, fmus)


def read_envelopes(path: Path) -> pd.DataFrame:
    """A campaign's ``envelopes.parquet``, checked: a ``time`` column and ``<signal>:p<percentile>`` columns.

    Parameters
    ----------
    path : Path

    Raises
    ------
    ReportError
        Not Parquet, no ``time`` column, or a column of another form.
    """
    try:
        df = pd.read_parquet(path)
    except Exception as exc:  # pyarrow raises its own error kinds for a damaged file
        raise ReportError(f"{path}: not a readable Parquet file ({type(exc).__name__}: {exc})") from None
    bad = [c for c in df.columns if c != "time" and not _ENVELOPE_COLUMN.match(str(c))]
    if "time" not in df.columns or bad or len(df.columns) < 2:
        raise ReportError(f"{path}: envelopes need a 'time' column and '<signal>:p<percentile>' columns, got "
                          f"{list(df.columns)}")
    return df


def envelope_signals(df: pd.DataFrame) -> dict[str, dict[float, str]]:
    """Signal -> percentile (%) -> column of an envelopes table (:func:`read_envelopes`).

    Parameters
    ----------
    df : pandas.DataFrame
        The envelopes table: ``time`` and ``<signal>:p<percentile>`` columns (others are
        skipped).

    Returns
    -------
    dict of str to dict of float to str
        Percentiles sorted increasing per signal.
    """
    out: dict[str, dict[float, str]] = {}
    for c in df.columns:
        m = _ENVELOPE_COLUMN.match(str(c))
        if m:
            out.setdefault(m["signal"], {})[float(m["p"])] = c
    return {s: dict(sorted(p.items())) for s, p in out.items()}


def _fmu_files(scenario: Scenario, fmu_dir: Path, backend: str, recorded: dict[str, Any]) -> dict[str, FmuFile]:
    """The FMU of each instance: where it is now, with the SHA-256 recorded when it ran."""
    paths = fmu_paths(scenario, fmu_dir, backend)
    out = {}
    for inst, spec in scenario.fmus.items():
        rec = recorded[inst]
        path = paths[inst] if Path(rec["file"]).name == paths[inst].name else paths[inst].with_name(rec["file"])
        out[inst] = FmuFile(inst, spec.model or Path(spec.path or rec["file"]).name, path, str(rec["sha256"]))
    return out
