"""A scenario campaign run on Dask (or resumed), its result, and the rows its folder stores."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping, Sequence

import pandas as pd

from satfmu.fmus.atomic import write_atomically
from satfmu.sims.campaign.engine import Campaign
from satfmu.sims.campaign.envelopes import POINTS
from satfmu.sims.campaign.envelopes import envelopes as percentile_envelopes
from satfmu.sims.campaign.scenario_task import ScenarioTask, campaign, explain
from satfmu.sims.campaign.statistics import Statistics, statistics
from satfmu.sims.scenario.spec import Scenario, load
from satfmu.sims.scenario.wiring import recorded_times


@dataclass(frozen=True)
class CampaignResult:
    """A finished scenario campaign (:func:`run_campaign`).

    Attributes
    ----------
    campaign : Campaign
    folder : Path
        Its folder: ``campaign.json`` and the Parquet chunks.
    rows : pandas.DataFrame
        One row per sample (the columns of :mod:`satfmu.sims.campaign.scenario_task`, not the kept
        time histories), sorted by ``sample``.
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


def run_campaign(scenario: "str | Path | Mapping[str, Any] | Scenario", n: int, out_dir: str | Path, *,
                 seed: int = 0, chunk: int | None = None, name: str | None = None, fmu_dir: str | Path | None = None,
                 backend: str = "native", workers: int = 2, scheduler: str | None = None,
                 confidence: float = 0.95, worst: int = 5, progress: Any = None, envelopes: Sequence[str] = (),
                 points: int = POINTS, tls: Any = None) -> CampaignResult:
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
        Address of a running Dask scheduler (``tls://host:8786``, or ``tcp://`` on a trusted network)
        instead of a local cluster.
    confidence : float
        Two-sided confidence of the pass-rate intervals, in (0, 1).
    worst : int
        How many worst samples the statistics list.
    progress : callable, optional
        ``progress(done, total)`` after each chunk.
    tls : distributed.security.Security, optional
        The security of a ``tls://`` scheduler (:func:`satfmu.sims.campaign.cluster.security`).

    Returns
    -------
    CampaignResult
    """
    from satfmu.sims.campaign import engine, worker_server

    if scheduler is None:  # a local cluster: its workers' fork server imports while this checks
        worker_server.start()
    sc = load(scenario)
    camp = campaign(sc, n, seed=seed, chunk=chunk, name=name, fmu_dir=fmu_dir, backend=backend, envelopes=envelopes,
                    points=points)
    folder = Path(out_dir) / camp.name
    rows = engine.run(camp, Path(out_dir), scheduler=scheduler, n_workers=workers, progress=progress, tls=tls)
    rows, env = write_envelopes(camp, rows, folder)
    return CampaignResult(camp, folder, rows, statistics(sc, rows, confidence, worst), env)


def write_envelopes(camp: Campaign[ScenarioTask], rows: pd.DataFrame, folder: Path
                    ) -> tuple[pd.DataFrame, pd.DataFrame | None]:
    """The percentile envelopes of a finished campaign's kept time histories, written to the
    folder's ``envelopes.parquet``, and its rows without those histories.

    Parameters
    ----------
    camp : Campaign
        A scenario campaign (its task says which histories it keeps).
    rows : pandas.DataFrame
        Its rows as :func:`satfmu.sims.campaign.engine.run` returns them.
    folder : Path
        The campaign's folder.

    Returns
    -------
    rows : pandas.DataFrame
        Without the kept histories' columns.
    envelopes : pandas.DataFrame or None
        None (nothing written) if the campaign keeps none.
    """
    task: ScenarioTask = camp.task
    if not task.envelopes:
        return rows, None
    env = percentile_envelopes(rows, list(task.envelopes), recorded_times(task.scenario)[list(task.trace_steps)])
    write_atomically(folder / ENVELOPES, lambda tmp: env.to_parquet(tmp, index=False))
    return rows.drop(columns=task.trace_columns), env


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
        The row's columns (:mod:`satfmu.sims.campaign.scenario_task`), only the chunk holding it read
        and verified (:func:`satfmu.sims.campaign.chunk_files.chunk_problem`).

    Raises
    ------
    CampaignError
        Not a campaign folder.
    """
    from satfmu.sims.campaign import chunk_files, engine

    folder = Path(folder)
    record = engine.read_record(folder)
    k = int(sample) // int(record["chunk"])
    recorded = record["chunks"].get(str(k))
    path = engine.chunk_path(folder, k)
    if recorded is None or chunk_files.chunk_problem(path, recorded, engine.record_digest(record), k) is not None:
        return None
    frame = pd.read_parquet(path)
    hit = frame.loc[frame["sample"] == int(sample)]
    return None if len(hit) != 1 else hit.iloc[0]
