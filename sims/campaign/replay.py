"""Replaying one sample of a scenario campaign: run again as the campaign ran it, with its time histories."""
from __future__ import annotations

import json
import math
import warnings
from pathlib import Path

import numpy as np

from satfmu.fmus.atomic import write_atomically
from satfmu.sims.campaign.engine import CampaignError
from satfmu.sims.campaign.results import campaign_row
from satfmu.sims.campaign.scenario_task import ScenarioTask, _value, reopen
from satfmu.sims.scenario.result import Result, clear_outputs
from satfmu.sims.scenario.run import run


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
           fmu_dir: str | Path | None = None) -> Result:
    """Run one sample of a scenario campaign again, as the campaign ran it (bit for bit), with
    its time histories.

    The campaign is read back from ``campaign.json`` (:func:`reopen`: its scenario declaration,
    seed, backend, and FMU files whose SHA-256 must be the ones the campaign ran); sample
    ``sample`` is ``scenario.sample(seed, sample)`` run by :func:`satfmu.sims.scenario.run.run`, the path of
    the campaign's own runs, so its metrics equal the campaign row's exactly. When the chunk that
    holds the row is recorded, the replay is compared with it: a metric or dispersed value that
    differs (e.g. other numpy/scipy versions drawing other dispersed values) is reported by a
    :class:`satfmu.sims.campaign.engine.CampaignWarning` naming the columns.

    A sample the campaign recorded as failed fails the same way: the same exception, with the
    message :func:`satfmu.sims.campaign.scenario_task.explain` gives.

    Parameters
    ----------
    folder : path
        The campaign folder (``--out/<name>`` of ``satfmu campaign scenario``).
    sample : int
        Global sample index, ``0 <= sample < n`` (the row's ``sample`` column).
    out_dir : path, optional
        Write the run into ``out_dir/<campaign name>-sample<sample>/`` (:func:`replay_folder`):
        the time histories as CSV, the plots and the summary as :meth:`satfmu.sims.scenario.result.Result.write`
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
        clear_outputs(target, task.scenario.name, task.backend)
        (target / "sample.json").unlink(missing_ok=True)
    sampled = task.scenario.sample(task.seed, int(sample), task.fmu_dir, task.backend)
    result = run(sampled, task.fmu_dir, task.backend)
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
