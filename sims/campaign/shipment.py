"""The files a scenario campaign's workers read, carried to them by content.

A worker of a real cluster shares no folder with the driver (another machine, an HPC node, a
container): a task that names the driver's FMU files fails there. The driver therefore sends
the bytes of every file a sample reads, each FMU of the scenario and each CSV file of its
profiles, through Dask (:func:`bundle`: the bytes scattered once, keyed by their SHA-256, and
fetched by each worker once). A worker keeps them in its own cache, ``<satfmu home>/worker/files/
<sha256>``, checking each file's SHA-256 before it first uses it, and runs the task with the
scenario pointed at its copies (:func:`localize`). Nothing a worker writes is needed again: the
driver writes the results, and a resumed campaign sends the files anew.
"""
from __future__ import annotations

import copy
import hashlib
import json
import os
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

from satfmu.fmus.atomic import write_atomically
from satfmu.fmus.errors import CampaignError

if TYPE_CHECKING:
    from satfmu.sims.campaign.scenario_task import ScenarioTask


@dataclass(frozen=True)
class Reference:
    """One file a task reads, by content.

    Parameters
    ----------
    kind : {"model", "path", "csv"}
        An FMU named by ``model`` (read from the FMU folder under ``name``), an FMU given by
        ``path``, or a profile's CSV file.
    owner : str
        The FMU instance, or ``"profiles[i]"``.
    name : str
        The file's name (an FMU folder's ``<model>.fmu``, or the file's own name).
    sha256 : str
        Its SHA-256, hex.
    """

    kind: str
    owner: str
    name: str
    sha256: str


_VERIFIED: set[str] = set()
"""Cached files this process has checked (their paths)."""


def _sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def bundle(task: ScenarioTask) -> tuple[tuple[Reference, ...], dict[str, bytes]]:
    """What a worker needs to run ``task``: the references, and the bytes by SHA-256.

    Parameters
    ----------
    task : ScenarioTask
        A scenario campaign's task, on the driver (its files readable).

    Returns
    -------
    references : tuple of Reference
    files : dict of str to bytes
        SHA-256 -> content (a file used twice is sent once).

    Raises
    ------
    CampaignError
        A file the task names cannot be read.
    """
    from satfmu.sims.scenario.provisioning import fmu_paths

    sc = task.scenario
    wanted: list[tuple[str, str, str, Path]] = []
    for inst, path in fmu_paths(sc, Path(task.fmu_dir), task.backend).items():
        wanted.append(("path" if sc.fmus[inst].path is not None else "model", inst, path.name, path))
    for i, prof in enumerate(sc.profiles):
        if prof.get("kind") == "csv" and "file" in prof:
            p = Path(prof["file"])
            wanted.append(("csv", f"profiles[{i}]", p.name, p if p.is_absolute() else sc.folder / p))
    refs, files = [], {}
    for kind, owner, name, path in wanted:
        try:
            data = path.read_bytes()
        except OSError as exc:
            raise CampaignError(f"{owner}: cannot read {path} to send it to the workers: {exc.strerror or exc}") \
                from None
        sha = _sha256(data)
        files[sha] = data
        refs.append(Reference(kind, owner, name, sha))
    return tuple(refs), files


def cache() -> Path:
    """This process's cache of shipped files: ``<satfmu home>/worker/files`` (created, private)."""
    from satfmu.controllers.paths import home

    folder = home() / "worker" / "files"
    folder.mkdir(parents=True, exist_ok=True, mode=0o700)
    return folder


def _stored(sha: str, files: dict[str, bytes]) -> Path:
    """The cached file of ``sha``: written from ``files`` when missing or wrong, checked once."""
    path = cache() / sha
    if str(path) in _VERIFIED:
        return path
    if path.is_file() and _sha256(path.read_bytes()) == sha:
        _VERIFIED.add(str(path))
        return path
    data = files.get(sha)
    if data is None or _sha256(data) != sha:
        raise CampaignError(f"the worker received no file of SHA-256 {sha[:12]}... (or other bytes): "
                            "the task cannot run")
    write_atomically(path, lambda tmp: tmp.write_bytes(data))
    _VERIFIED.add(str(path))
    return path


def localize(task: ScenarioTask, refs: tuple[Reference, ...], files: dict[str, bytes]) -> ScenarioTask:
    """``task`` reading its files from this worker's cache: each written there from ``files``
    (its SHA-256 checked), then linked under the name the task expects in a folder of this set
    of files (``<cache>/../sets/<digest>``).

    Parameters
    ----------
    task : ScenarioTask
        The task as the driver made it.
    refs : tuple of Reference
        From :func:`bundle`.
    files : dict of str to bytes
        SHA-256 -> content, from :func:`bundle` (through Dask).

    Returns
    -------
    ScenarioTask
        With ``fmu_dir`` the set's folder, ``path`` FMUs and CSV profiles pointing into it.

    Raises
    ------
    CampaignError
        A file missing from ``files`` or whose bytes do not have their SHA-256.
    """
    digest = _sha256(json.dumps([[r.kind, r.owner, r.name, r.sha256] for r in refs]).encode())[:16]
    folder = cache().parent / "sets" / digest
    folder.mkdir(parents=True, exist_ok=True, mode=0o700)
    sc = task.scenario
    fmus = dict(sc.fmus)
    profiles = [dict(p) for p in sc.profiles]
    for ref in refs:
        name = ref.name if ref.kind == "model" else f"{ref.owner}-{ref.name}"
        if ref.name in ("", ".", "..") or Path(name).name != name or len(ref.sha256) != 64:
            raise CampaignError(f"{ref.owner}: {ref.name!r} is no file name to keep a shipped file under")
        target = folder / name
        if not target.is_file() or os.stat(target).st_ino != os.stat(_stored(ref.sha256, files)).st_ino:
            _link(_stored(ref.sha256, files), target)
        if ref.kind == "path":
            fmus[ref.owner] = replace(fmus[ref.owner], path=str(target))
        elif ref.kind == "csv":
            profiles[int(ref.owner[len("profiles["):-1])]["file"] = str(target)
    scenario = copy.copy(sc)  # the declaration was validated on the driver; only its file names change
    scenario.fmus, scenario.profiles = fmus, profiles
    return replace(task, scenario=scenario, fmu_dir=str(folder))


def _link(source: Path, target: Path) -> None:
    """``target`` the same file as ``source`` (a hard link; a copy across file systems)."""
    def make(tmp: Path) -> None:
        try:
            os.link(source, tmp)
        except OSError:
            tmp.write_bytes(source.read_bytes())

    write_atomically(target, make)
