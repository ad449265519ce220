"""The worker: runs cases of one FMU in a child process, reporting each as it starts and ends."""
from __future__ import annotations

import io
import json
import os
import time
from collections.abc import Sequence
from dataclasses import asdict
from pathlib import Path
from typing import Any

from satfmu.fmus import archive
from satfmu.sims.robustness.instance import NO_RESULT, CaseBroken, Instance, Outcome
from satfmu.sims.robustness.table import CASE_BY_NAME, Case, Settings
from satfmu.sims.robustness.target import Target, describe

ABORT_ENV = "SATFMU_ROBUSTNESS_ABORT"
"""Test hook: a worker calls ``os.abort()`` when it starts the case named in this variable."""


def _run_case(case: Case, target: Target, unzip: str, settings: Settings) -> Outcome:
    """Run one case on a fresh instance; Python-level failures become a FAIL outcome, not a crash."""
    try:
        inst = Instance(target, unzip)
    except Exception as exc:  # noqa: BLE001 - loading or instantiating failed: the case fails
        return Outcome(status=NO_RESULT, problems=[f"cannot instantiate: {type(exc).__name__}: {exc}"])
    started = time.perf_counter()
    try:
        out = case.run(inst, **{name: getattr(settings, name) for name in case.settings})
    except CaseBroken as exc:
        out = Outcome(status=NO_RESULT, log=inst.text(), problems=[str(exc)])
    except Exception as exc:  # noqa: BLE001 - an unexpected Python error is a FAIL of this case
        out = Outcome(status=NO_RESULT, log=inst.text(), problems=[f"{type(exc).__name__}: {exc}"])
    inst.free()
    out.metrics["case_s"] = time.perf_counter() - started
    return out


def _emit(stream: io.TextIOBase, record: dict[str, Any]) -> None:
    stream.write(json.dumps(record) + "\n")
    stream.flush()


def work(path: Path, names: Sequence[str], settings: Settings, results: Path) -> None:
    """Worker: run the cases ``names`` on the FMU ``path``, appending a JSON line to ``results``
    when each case starts and when it ends (so the parent knows which case a crash hit).

    Parameters
    ----------
    path : Path
        The FMU file (extracted once for every case, removed at the end).
    names : sequence of str
        Names of the cases to run, in order (:data:`~satfmu.sims.robustness.table.CASES`).
    settings : Settings
        Sizes of the run; each case receives the fields it names.
    results : Path
        The events file (JSON lines) the parent reads.
    """
    target = describe(path)
    extracted = archive.extract(path)
    unzip = str(extracted.folder)
    abort_on = os.environ.get(ABORT_ENV)
    try:
        with results.open("a") as stream:
            for name in names:
                _emit(stream, {"event": "start", "case": name})
                if name == abort_on:
                    os.abort()
                out = _run_case(CASE_BY_NAME[name], target, unzip, settings)
                _emit(stream, {"event": "done", "case": name, **asdict(out)})
    finally:
        extracted.close()

