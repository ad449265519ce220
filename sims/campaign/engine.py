"""Monte Carlo campaigns: a pure task evaluated on N random samples, on Dask distributed.

A campaign draws its samples chunk by chunk.  Chunk ``k`` covers the sample indices
``[k * chunk, min((k + 1) * chunk, n))`` and draws them with its own generator,
``default_rng(SeedSequence(seed, spawn_key=(k,)))``, so every value depends only on
``(seed, chunk, n)``: never on the number of workers or on the order in which chunks
complete.  With the :func:`sample_indices` sampler the samples are the global indices and
the task draws sample ``i`` from ``(seed, i)`` itself: its values do not depend on the chunk
size either (:mod:`satfmu.sims.campaign.scenario_task`).  The task is vectorized (one call per chunk) and
returns one column per metric.

:func:`run` submits the chunks to a Dask cluster and, in the driver, writes each completed
chunk to its own Parquet file (``chunk-000042.parquet``, whole or not at all:
:func:`satfmu.fmus.atomic.write_atomically`), then its SHA-256 into the campaign record
``campaign.json`` (also written whole).  The record holds the campaign's identity (n, seed,
chunk, task, sampler) and a chunk file's Parquet metadata the digest of that identity and its
chunk index (:mod:`satfmu.sims.campaign.chunk_files`).  An interrupted campaign is resumed by running it again:
a chunk is used as it is only if the record has its checksum, its file has that checksum and
its metadata names this campaign and this chunk; any other chunk is computed (again), with a
:class:`CampaignWarning` naming the chunk and why when a file or a record entry was there
(missing, empty, truncated, corrupted or rewritten file; a file the record does not know, e.g.
after ``campaign.json`` was deleted: such a file is never adopted, whatever it holds).  A folder
whose ``campaign.json`` is missing is a new campaign: every chunk is computed.  One driver at a
time works in a folder: a second one waits for the first (``.campaign.lock``), then finds the
chunks done.  A worker that dies mid-task makes Dask run the task again elsewhere; as only the
driver writes, and each chunk has one file name, no sample is lost or duplicated.

:func:`summarize` turns one result column into the probabilistic statements of the seeds
(the worst case by the log-over-log bound, a probability by the Chernoff-Hoeffding bound).
"""
from __future__ import annotations

import dataclasses
import functools
import hashlib
import json
import math
import os
import pickle
import uuid
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Generic, TypeVar

import numpy as np
import pandas as pd
from distributed import Client, as_completed
from distributed.security import Security

from satfmu.fmus.atomic import write_atomically
from satfmu.sims.campaign.cluster import cluster_client
from satfmu.fmus.declared import check_safe_name
from satfmu.sims.campaign import chunk_files
from satfmu.fmus.errors import CampaignError, CampaignWarning

Task = Callable[[np.ndarray], dict[str, np.ndarray]]
Sampler = Callable[[np.random.Generator, int], np.ndarray]
Progress = Callable[[int, int], None]
_T = TypeVar("_T", bound=Task)

_META = "campaign.json"
_IDENTITY = ("n", "seed", "chunk", "task", "sampler", "context")
IDENTITY_FORMAT = 3
"""Version of the identity a record holds. 3 names satfmu's own tasks and samplers without their
module (``satfmu:ScenarioTask``) and digests a callable object's fields, not its pickle
(``_qualified_name``), so that moving a module inside satfmu changes no campaign's identity.
Older records named the module (2: ``sims.scenario_campaign.ScenarioTask``, from 0.1.0; none: with
the ``satfmu.`` prefix before it): a function still matches by its qualified name
(``_same_name``); an object's digest of its pickle cannot be matched, and is refused saying why."""


@dataclass(frozen=True, kw_only=True)
class Campaign(Generic[_T]):
    """A pure task evaluated on ``n`` random samples drawn chunk by chunk.

    Parameters
    ----------
    name : str
        Folder name of the results: letters, digits, ``.``, ``_``, ``-`` (at most 100).
    task : callable
        ``task(samples) -> {column: 1-D float array of len(samples)}``; module-level (it is
        pickled by reference to the workers) and pure.
    n : int
        Number of samples, >= 1.
    seed : int
        Root seed, >= 0.
    chunk : int
        Samples per chunk (per task call and per result file), >= 1.
    sampler : callable
        ``sampler(rng, count) -> array`` whose first axis has ``count`` samples; module-level;
        or :func:`sample_indices` (the samples are the global indices).
    context : dict, optional
        Plain JSON data that is part of the campaign's identity and kept in ``campaign.json``
        (a scenario campaign: the scenario's declaration and the SHA-256 of each FMU file, so
        a folder is never resumed with another scenario or other FMU binaries, and
        ``satfmu replay`` and ``satfmu report`` can read the campaign back).

    Raises
    ------
    CampaignError
        If a field is invalid.
    """

    name: str
    task: _T
    n: int
    seed: int
    chunk: int = 1000
    sampler: Sampler | Callable[..., np.ndarray]  # or sample_indices (keyword start)
    context: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        check_safe_name(self.name, "campaign name", CampaignError)
        try:  # stored as JSON, compared as read back: tuples become lists, keys strings
            object.__setattr__(self, "context", json.loads(json.dumps(self.context, allow_nan=False)))
        except (TypeError, ValueError) as exc:
            raise CampaignError(f"campaign {self.name!r}: context must be plain JSON data: {exc}") from None
        for label, value, least in (("n", self.n, 1), ("chunk", self.chunk, 1), ("seed", self.seed, 0)):
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < least:
                raise CampaignError(f"campaign {self.name!r}: {label} must be an integer >= {least}, got {value!r}")
        for label, fn in (("task", self.task), ("sampler", self.sampler)):
            if not callable(fn):
                raise CampaignError(f"campaign {self.name!r}: {label} must be callable, got {fn!r}")

    @property
    def n_chunks(self) -> int:
        """Number of chunks, ``ceil(n / chunk)``."""
        return -(-self.n // self.chunk)

    def identity(self) -> dict[str, Any]:
        """What makes two campaigns the same: n, seed, chunk, the task's and sampler's names and
        the context."""
        return {"n": int(self.n), "seed": int(self.seed), "chunk": int(self.chunk),
                "task": _qualified_name(self.task), "sampler": _qualified_name(self.sampler),
                "context": self.context}


def _qualified_name(fn: Callable) -> str:
    """The name of a task or sampler in a campaign's identity.

    A function (or class) is ``module.qualname``, but satfmu's own are ``satfmu:qualname``:
    their modules may move between releases. A callable object is its class's name plus a
    digest of its fields (:func:`_canonical`; two tasks of one class with other settings are
    other campaigns)."""
    if hasattr(fn, "__qualname__"):
        return _plain_name(fn)
    digest = hashlib.sha256(json.dumps(_canonical(fn), sort_keys=True).encode()).hexdigest()[:16]
    return f"{_plain_name(type(fn))}:{digest}"


def _plain_name(fn: Callable) -> str:
    module, qualname = fn.__module__, fn.__qualname__
    return f"satfmu:{qualname}" if module.split(".")[0] == "satfmu" else f"{module}.{qualname}"


def _canonical(obj: Any) -> Any:
    """A JSON image of ``obj`` that names no satfmu module path: dataclasses and plain objects
    field by field with their class's :func:`_plain_name`, functions by their name, arrays by
    their dtype, shape and bytes; anything else by the digest of its pickle."""
    if isinstance(obj, type) or callable(obj) and hasattr(obj, "__qualname__"):
        return _plain_name(obj)
    if dataclasses.is_dataclass(obj):
        return {"class": _plain_name(type(obj)),
                **{f.name: _canonical(getattr(obj, f.name)) for f in dataclasses.fields(obj)}}
    if isinstance(obj, dict):
        return {"dict": [[_canonical(k), _canonical(v)] for k, v in obj.items()]}
    if isinstance(obj, (list, tuple)):
        return [_canonical(v) for v in obj]
    if isinstance(obj, (set, frozenset)):
        return {"set": sorted((_canonical(v) for v in obj), key=lambda v: json.dumps(v, sort_keys=True))}
    if isinstance(obj, np.ndarray):
        return {"array": obj.dtype.str, "shape": list(obj.shape),
                "sha256": hashlib.sha256(np.ascontiguousarray(obj).tobytes()).hexdigest()}
    if isinstance(obj, np.generic):
        return _canonical(obj.item())
    if isinstance(obj, float):
        return repr(obj)  # every bit, and nan and inf as text
    if obj is None or isinstance(obj, (str, int, bool)):
        return obj
    if isinstance(obj, os.PathLike):
        return os.fspath(obj)
    if isinstance(obj, functools.partial):
        return {"partial": _canonical(obj.func), "args": _canonical(obj.args), "keywords": _canonical(obj.keywords)}
    if hasattr(obj, "__dict__"):
        return {"class": _plain_name(type(obj)), **{k: _canonical(v) for k, v in sorted(vars(obj).items())}}
    return {"pickle": hashlib.sha256(pickle.dumps(obj, protocol=4)).hexdigest()}


def _same_name(stored: Any, now: str, stored_format: int) -> bool:
    """Whether a task or sampler name of a record of ``stored_format`` names ``now``: equal, or
    for a record before format 3, a satfmu function by its module path (``sims.campaign.f`` or
    ``satfmu.sims.campaign.f`` for ``satfmu:f``)."""
    if stored == now:
        return True
    return (stored_format < 3 and isinstance(stored, str) and now.startswith("satfmu:") and ":" not in stored
            and ":" not in now[7:] and stored.endswith("." + now[7:])
            and stored.split(".")[0] in ("satfmu", "fmus", "controllers", "synthesis", "sims"))


def chunk_range(campaign: Campaign, k: int) -> range:
    """Global sample indices of chunk ``k``.

    Parameters
    ----------
    campaign : Campaign
        The campaign.
    k : int
        Chunk index, ``0 <= k < campaign.n_chunks``.

    Returns
    -------
    range
        ``k * chunk`` up to ``min((k + 1) * chunk, n)`` (excluded).

    Raises
    ------
    CampaignError
        If ``k`` is not in ``0 .. n_chunks - 1``.
    """
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or not 0 <= k < campaign.n_chunks:
        raise CampaignError(f"campaign {campaign.name!r}: chunk {k!r} is not in 0..{campaign.n_chunks - 1}")
    return range(k * campaign.chunk, min((k + 1) * campaign.chunk, campaign.n))


def sample_indices(rng: np.random.Generator | None, count: int, *, start: int) -> np.ndarray:
    """The sampler whose samples are the chunk's global indices ``start`` to ``start + count - 1``
    (int64; no generator is used): for a task that draws sample ``i`` from ``(seed, i)`` itself,
    so that its values do not depend on the chunk size either. :func:`run_chunk` passes
    ``start``.

    Parameters
    ----------
    rng : numpy.random.Generator or None
        Ignored (the signature of a sampler, ``sampler(rng, count)``).
    count : int
        Number of samples of the chunk.
    start : int
        Global index of the chunk's first sample (keyword only).

    Returns
    -------
    numpy.ndarray
        Shape ``(count,)``, int64.
    """
    return np.arange(start, start + count, dtype=np.int64)


def run_chunk(campaign: Campaign, k: int, refs: Any = None, files: dict[str, bytes] | None = None) -> pd.DataFrame:
    """Draw the samples of chunk ``k`` and evaluate the task on them (with the
    :func:`sample_indices` sampler: the chunk's global indices).

    Parameters
    ----------
    campaign : Campaign
        The campaign.
    k : int
        Chunk index, ``0 <= k < campaign.n_chunks``; its generator is
        ``default_rng(SeedSequence(seed, spawn_key=(k,)))``.
    refs, files : optional
        What the task's ``shipment()`` gave on the driver (the files it reads, by content): the
        task then runs as its ``localized(refs, files)`` (a scenario task reads its FMUs from this
        worker's cache, :mod:`satfmu.sims.campaign.shipment`).

    Returns
    -------
    pandas.DataFrame
        Column ``sample`` (int64 global index), then the task's columns (float64).

    Raises
    ------
    CampaignError
        If ``k`` is out of range, the sampler returns the wrong number of samples, or the task
        output is not a dict of 1-D real arrays of the chunk's length. Infinite values are
        results (the H-infinity norm of an unstable closed loop), NaN marks a failed sample.
    """
    if refs is not None:
        campaign = dataclasses.replace(campaign, task=campaign.task.localized(refs, files or {}))
    indices = chunk_range(campaign, k)
    if campaign.sampler is sample_indices:
        samples = sample_indices(None, len(indices), start=indices.start)
    else:
        rng = np.random.default_rng(np.random.SeedSequence(int(campaign.seed), spawn_key=(int(k),)))
        samples = np.asarray(campaign.sampler(rng, len(indices)))
    if samples.ndim == 0 or samples.shape[0] != len(indices):
        raise CampaignError(f"campaign {campaign.name!r}: sampler returned shape {samples.shape} for "
                            f"{len(indices)} samples (first axis must be the samples)")
    output = campaign.task(samples)
    columns = _checked_columns(campaign.name, output, len(indices))
    df = pd.DataFrame({"sample": np.arange(indices.start, indices.stop, dtype=np.int64), **columns})
    info = getattr(campaign.task, "worker_info", None)
    if callable(info):
        df.attrs["worker"] = info()  # for the record, not the chunk file
    return df


def _checked_columns(name: str, output: Any, count: int) -> dict[str, np.ndarray]:
    """The task output as float64 columns, after checking types, shapes and values."""
    if not isinstance(output, dict) or not output:
        raise CampaignError(f"campaign {name!r}: the task must return a non-empty dict of column -> array, "
                            f"got {type(output).__name__}")
    columns = {}
    for col, values in output.items():
        where = f"campaign {name!r}, task column {col!r}"
        if not isinstance(col, str) or col == "sample":
            raise CampaignError(f"{where}: column names must be strings other than 'sample'")
        arr = np.asarray(values)
        if arr.ndim != 1 or arr.shape[0] != count:
            raise CampaignError(f"{where}: expected a 1-D array of {count} values, got shape {arr.shape}")
        if arr.dtype.kind not in "biuf":
            raise CampaignError(f"{where}: expected real numbers, got dtype {arr.dtype}")
        columns[col] = arr.astype(np.float64)
    return columns


def chunk_path(folder: Path, k: int) -> Path:
    """Result file of chunk ``k`` in a campaign folder.

    Parameters
    ----------
    folder : Path
        The campaign folder (``out_dir / campaign.name``).
    k : int
        Chunk index.

    Returns
    -------
    Path
        ``folder / "chunk-<k, 6 digits>.parquet"``.
    """
    return Path(folder) / f"chunk-{k:06d}.parquet"


def run(campaign: Campaign, out_dir: Path, *, scheduler: str | None = None, n_workers: int = 2,
        threads_per_worker: int = 1, progress: Progress | None = None,
        client: Client | None = None, tls: Security | None = None) -> pd.DataFrame:
    """Run (or resume) a campaign on Dask and return all its results.

    Resuming uses a chunk as it is only if ``campaign.json`` records its checksum and its file
    has it (and names this campaign and chunk); every other chunk is computed, with a
    :class:`CampaignWarning` when its file or record entry was wrong (module docstring). Another
    driver working in the same folder is waited for (:class:`CampaignWarning`).

    Parameters
    ----------
    campaign : Campaign
    out_dir : Path
        Results go to ``out_dir / campaign.name``: ``campaign.json`` and one Parquet file per chunk.
    scheduler : str, optional
        Address of a running scheduler (``"tls://host:port"``, or ``"tcp://host:port"`` on a
        trusted network: :func:`satfmu.sims.campaign.cluster.check_address`).  Default: a
        ``LocalCluster`` of ``n_workers`` processes with ``threads_per_worker`` threads on the
        loopback, closed at the end (also on an error or Ctrl-C).
    n_workers, threads_per_worker : int
        Size of the local cluster (ignored with ``scheduler`` or ``client``).
    progress : callable, optional
        Called as ``progress(done_chunks, total_chunks)`` after each chunk file is written.
    client : distributed.Client, optional
        Client to use as is (not closed).
    tls : distributed.security.Security, optional
        The security of a ``tls://`` scheduler (default: Dask's configuration,
        :func:`satfmu.sims.campaign.cluster.security`).

    Returns
    -------
    pandas.DataFrame
        :func:`load` of the campaign folder.

    Raises
    ------
    CampaignError
        If the folder holds a different campaign or an unreadable ``campaign.json``, a task
        fails its output check, or a sample is missing or duplicated at the end.
    """
    folder = Path(out_dir) / campaign.name
    with chunk_files.locked(folder, lambda why: warnings.warn(why, CampaignWarning, stacklevel=5)):
        chunk_files.sweep_partials(folder)  # a killed driver's half-written chunk or record
        record = _claim_folder(folder, campaign)
        todo = _todo(folder, campaign, record)
        if todo:
            with cluster_client(scheduler, client, n_workers, threads_per_worker, tls) as active:
                _compute(active, campaign, folder, record, todo, progress)
        return load(folder)


def _claim_folder(folder: Path, campaign: Campaign) -> dict[str, Any]:
    """The record of the folder (``campaign.json``, created if missing) after checking that it
    holds this campaign; its ``chunks`` maps each recorded chunk index (str) to its SHA-256."""
    meta = folder / _META
    record = {"name": campaign.name, **campaign.identity(), "identity_format": IDENTITY_FORMAT,
              "n_chunks": campaign.n_chunks, "chunks": {}}
    if not meta.exists():
        _write_record(folder, record)
        return record
    stored = read_record(folder)
    stored_format = stored.get("identity_format", 1)
    differ = [key for key in _IDENTITY if stored.get(key) != record[key]
              and not (key in ("task", "sampler") and _same_name(stored.get(key), record[key], stored_format))]
    objects = [k for k in differ if k in ("task", "sampler") and ":" in record[k]
               and str(stored.get(k)).rpartition(":")[0].endswith(record[k].rpartition(":")[0].removeprefix("satfmu:"))]
    if differ and objects == differ and stored_format < IDENTITY_FORMAT:
        raise CampaignError(f"{folder} holds a campaign written by an older satfmu (identity format {stored_format}), "
                            f"whose {' and '.join(objects)} object was named by its module path and its pickle: "
                            "whether it is this campaign cannot be told; run it in another folder (another name "
                            "or out_dir) or delete this one")
    if differ:
        shown = [k for k in differ if k != "context"]
        parts = ([f"stored { {k: stored.get(k) for k in shown} }, now { {k: record[k] for k in shown} }"]
                 if shown else [])
        if "context" in differ:
            old, new = stored.get("context") or {}, record["context"]
            keys = [f"{k}.{sub}" if isinstance(old.get(k), dict) and isinstance(new.get(k), dict) else k
                    for k in sorted(set(old) | set(new)) if old.get(k) != new.get(k)
                    for sub in (sorted(s for s in set(old[k]) | set(new[k]) if old[k].get(s) != new[k].get(s))
                                if isinstance(old.get(k), dict) and isinstance(new.get(k), dict) else [None])]
            parts.append(f"context differs in {', '.join(keys) or 'its type'}")
        raise CampaignError(f"{folder} holds another campaign (differs in {', '.join(differ)}: {'; '.join(parts)}); "
                            "use another name or out_dir, or delete the folder")
    kept = {"workers": stored["workers"]} if isinstance(stored.get("workers"), dict) else {}
    return {**record, "chunks": stored["chunks"], **kept}


def read_record(folder: Path) -> dict[str, Any]:
    """``campaign.json`` of a folder, its ``chunks`` checked (a record without one has none).

    Parameters
    ----------
    folder : Path
        The campaign folder.

    Returns
    -------
    dict
        The record: the campaign's name and identity (``n``, ``seed``, ``chunk``, ``task``,
        ``sampler``, ``context``), ``chunks``, chunk index (str) -> SHA-256 of its file, and for a
        task that says so (a scenario campaign's) ``workers``, chunk index -> where it ran
        (``host``, ``loop``: the compiled or the Python co-simulation loop).

    Raises
    ------
    CampaignError
        If it is missing or not a campaign record.
    """
    meta = folder / _META
    if not meta.is_file():
        raise CampaignError(f"{folder} is not a campaign folder (no {_META})")
    try:
        stored = json.loads(meta.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise CampaignError(f"{meta}: not a campaign record ({exc}); delete it to compute the campaign "
                            "again") from None
    if not isinstance(stored, dict) or any(key not in stored for key in _IDENTITY):
        raise CampaignError(f"{meta}: not a campaign record (it must hold {', '.join(_IDENTITY)}); delete it "
                            "to compute the campaign again")
    chunks = stored.get("chunks", {})  # a record of satfmu 0.1 has none: its chunks are computed again
    if not isinstance(chunks, dict) or not all(isinstance(k, str) and k.isdigit() and isinstance(v, str)
                                               for k, v in chunks.items()):
        raise CampaignError(f"{meta}: not a campaign record ('chunks' must map chunk indices to SHA-256 "
                            "digests); delete it to compute the campaign again")
    return {**stored, "chunks": chunks}


def _write_record(folder: Path, record: dict[str, Any]) -> None:
    write_atomically(folder / _META, lambda tmp: tmp.write_text(json.dumps(record, indent=1) + "\n"))


def record_digest(record: dict[str, Any]) -> str:
    """Digest of the campaign identity a record holds (what each chunk file's metadata names).

    Parameters
    ----------
    record : dict
        A campaign record (:func:`read_record`).

    Returns
    -------
    str
        SHA-256, hex (:func:`satfmu.sims.campaign.chunk_files.identity_digest`).
    """
    return chunk_files.identity_digest({key: record[key] for key in _IDENTITY})


def _todo(folder: Path, campaign: Campaign, record: dict[str, Any]) -> list[int]:
    """The chunks to compute: those not computed yet and those whose file or record entry is not
    right (warned about and dropped from ``record``)."""
    digest, todo = record_digest(record), []
    for k in range(campaign.n_chunks):
        path, recorded = chunk_path(folder, k), record["chunks"].get(str(k))
        if recorded is None and not path.exists():
            todo.append(k)
            continue
        problem = chunk_files.chunk_problem(path, recorded, digest, k)
        if problem is not None:
            warnings.warn(f"{folder}: chunk {k} ({path.name}) {problem}: computing it again", CampaignWarning,
                          stacklevel=3)
            record["chunks"].pop(str(k), None)
            todo.append(k)
    return todo


def _content(data: bytes) -> bytes:
    """A shipped file's bytes, as the task holding them gives them (on a worker)."""
    return data


def _compute(client: Client, campaign: Campaign, folder: Path, record: dict[str, Any], todo: list[int],
             progress: Progress | None) -> None:
    """Submit the chunks ``todo``; write each result as it completes, then its checksum into the record."""
    # One key per chunk and per call: a chunk is never computed twice at once, and the keys of an
    # interrupted call (cancelled below, asynchronously) are never those of its resumption.
    run_id = uuid.uuid4().hex[:12]
    # the files the task reads go by content (a worker need not see the driver's folders): one task
    # per file under its SHA-256, whose result each worker fetches once however many chunks it runs;
    # the bytes are in the task itself, so a worker lost with them costs a recomputation, not the data
    shipment = getattr(campaign.task, "shipment", None)
    refs, files = shipment() if callable(shipment) else (None, {})
    shipped = {sha: client.submit(_content, data, key=f"satfmu-file-{sha}", pure=False) for sha, data in files.items()}
    futures = {client.submit(run_chunk, campaign, k, refs, shipped or None, key=f"{campaign.name}-chunk-{k}-{run_id}",
                             retries=2): k for k in todo}
    done, digest = campaign.n_chunks - len(todo), record_digest(record)
    try:
        for future in as_completed(list(futures)):
            k = futures.pop(future)
            result = future.result()
            worker = result.attrs.pop("worker", None)
            if worker is not None:
                record.setdefault("workers", {})[str(k)] = worker
            data = chunk_files.chunk_bytes(result, digest, k)
            write_atomically(chunk_path(folder, k), lambda tmp: tmp.write_bytes(data))
            record["chunks"][str(k)] = chunk_files.sha256(data)
            _write_record(folder, record)
            future.release()
            done += 1
            if progress is not None:
                progress(done, campaign.n_chunks)
    finally:
        client.cancel(list(futures))


def load(path: Path) -> pd.DataFrame:
    """The chunks ``campaign.json`` records, each verified, concatenated and sorted by ``sample``.

    A chunk file the record does not list is not read.

    Parameters
    ----------
    path : Path
        The campaign folder (``out_dir / campaign.name``).

    Returns
    -------
    pandas.DataFrame
        Column ``sample`` (int64), then the task's columns (float64); one row per sample.

    Raises
    ------
    CampaignError
        If ``campaign.json`` is missing, a recorded chunk's file is missing or not the one
        recorded (checksum, campaign identity, chunk index: run the campaign again to compute
        it again), the chunk files have different columns, or a sample index of ``0 .. n - 1``
        is missing or appears more than once.
    """
    folder = Path(path)
    record = read_record(folder)
    n, digest = int(record["n"]), record_digest(record)
    files = [chunk_path(folder, int(k)) for k in sorted(record["chunks"], key=int)]
    if not files:
        raise CampaignError(f"{folder}: no chunk recorded in {_META}; missing all {n} samples")
    for f, k in zip(files, sorted(record["chunks"], key=int)):
        problem = chunk_files.chunk_problem(f, record["chunks"][k], digest, int(k))
        if problem is not None:
            raise CampaignError(f"{folder}: chunk {k} ({f.name}) {problem}; run the campaign again to compute it again")
    frames = [pd.read_parquet(f) for f in files]
    columns = list(frames[0].columns)
    for f, frame in zip(files, frames):
        if list(frame.columns) != columns:
            raise CampaignError(f"{f}: columns {list(frame.columns)} differ from {columns}")
    df = pd.concat(frames, ignore_index=True).sort_values("sample", kind="stable", ignore_index=True)
    _check_indices(folder, df["sample"].to_numpy(), n)
    return df


def _check_indices(folder: Path, samples: np.ndarray, n: int) -> None:
    """Raise CampaignError unless ``samples`` holds each of ``0 .. n - 1`` exactly once."""
    outside = samples[(samples < 0) | (samples >= n)]
    counts = np.bincount(samples[(samples >= 0) & (samples < n)], minlength=n)
    missing, duplicated = np.flatnonzero(counts == 0), np.flatnonzero(counts > 1)
    problems = [f"{len(idx)} {what} (first: {idx[:10].tolist()})"
                for what, idx in (("missing", missing), ("duplicated", duplicated), ("out of range", outside))
                if len(idx)]
    if problems:
        raise CampaignError(f"{folder}: sample indices of 0..{n - 1}: " + "; ".join(problems))


@dataclass
class Summary:
    """Statistics of one result column and the probabilistic statements they support.

    ``n`` counts every sample, NaN (failed) and infinite ones included; mean, minimum and
    maximum are over the non-NaN samples (an infinite sample makes the maximum infinite).
    Units are those of the column.

    Attributes
    ----------
    column : str
        The result column.
    n : int
        Samples, NaN and infinite ones included.
    n_nan : int
        NaN samples (failed).
    n_inf : int
        Infinite samples (results, e.g. the H-infinity norm of an unstable closed loop).
    mean, min, max : float
        Over the non-NaN samples, in the column's unit (NaN when every sample is NaN).
    epsilon, delta : float
        Accuracy and 1 - confidence of the statements, both in (0, 1).
    n_worst_case : int
        Samples needed by the log-over-log bound, ``ceil(ln(1/delta) / ln(1/(1-epsilon)))``.
    level : float or None
        Threshold of the probability statement, in the column's unit (None: no such statement).
    p : float or None
        Fraction of samples with value <= ``level`` (NaN samples count as failures).
    eps_n : float or None
        Chernoff-Hoeffding half-width ``sqrt(ln(2/delta) / (2 n))`` of ``p``.
    n_chernoff : int or None
        Samples needed for ``eps_n <= epsilon``, ``ceil(ln(2/delta) / (2 epsilon^2))``.
    """

    column: str
    n: int
    n_nan: int
    n_inf: int
    """Infinite samples: results, e.g. the H-infinity norm of an unstable closed loop."""
    mean: float
    min: float
    max: float
    epsilon: float
    delta: float
    n_worst_case: int
    """Samples needed by the log-over-log bound, ``ceil(ln(1/delta) / ln(1/(1-epsilon)))``."""
    level: float | None = None
    p: float | None = None
    """Fraction of samples with value <= level (NaN samples count as failures)."""
    eps_n: float | None = None
    """Chernoff-Hoeffding half-width ``sqrt(ln(2/delta) / (2 n))``."""
    n_chernoff: int | None = None
    """Samples needed for ``eps_n <= epsilon``, ``ceil(ln(2/delta) / (2 epsilon^2))``."""

    @property
    def worst_case_valid(self) -> bool:
        """The log-over-log statement holds: enough samples, none NaN, the maximum finite."""
        return self.n >= self.n_worst_case and self.n_nan == 0 and self.n_inf == 0

    def text(self) -> str:
        """The statistics and statements as sentences with their numbers."""
        inf = f", {self.n_inf} infinite" if self.n_inf else ""
        lines = [(f"{self.column}: N = {self.n} samples ({self.n_nan} NaN{inf}), mean {self.mean:.6g}, "
                  f"min {self.min:.6g}, max {self.max:.6g}.")]
        need = (f"ln(1/delta)/ln(1/(1-epsilon)) = {self.n_worst_case} samples needed for epsilon = "
                f"{self.epsilon:g}, delta = {self.delta:g}")
        if self.n_nan:
            lines.append(f"Worst case: not estimated, {self.n_nan} samples are NaN (failed) ({need}).")
        elif self.n_inf:
            lines.append(f"Worst case: unbounded, {self.n_inf} of {self.n} samples are infinite "
                         f"({100 * self.n_inf / self.n:.3g} %; e.g. an unstable closed loop) ({need}).")
        elif self.n < self.n_worst_case:
            lines.append(f"Worst case: N = {self.n} is NOT enough for P(value > {self.max:.6g}) <= "
                         f"{self.epsilon:g} with confidence 1 - {self.delta:g} ({need}).")
        else:
            lines.append(f"Worst case: P(value > {self.max:.6g}) <= {self.epsilon:g} with confidence "
                         f"1 - {self.delta:g}; N = {self.n} is enough ({need}).")
        if self.level is not None:
            lines.append(f"Level: p = {self.p:.6g} of the samples have value <= {self.level:.6g} "
                         f"({self.n_nan} NaN counted as failures); |P(value <= {self.level:.6g}) - p| <= "
                         f"eps_N = sqrt(ln(2/delta)/(2N)) = {self.eps_n:.6g} with confidence 1 - {self.delta:g} "
                         f"(eps_N <= {self.epsilon:g} needs N >= {self.n_chernoff}).")
        return "\n".join(lines)


def summarize(df: pd.DataFrame, column: str, *, level: float | None = None, epsilon: float = 0.1,
              delta: float = 1e-6) -> Summary:
    """Statistics of ``df[column]`` with the worst-case and (given ``level``) probability bounds.

    Parameters
    ----------
    df : pandas.DataFrame
        Campaign results (one row per sample).
    column : str
        Result column (any unit).
    level : float, optional
        Threshold, in the column's unit, of the probability ``P(value <= level)``.
    epsilon, delta : float
        Accuracy and 1 - confidence of the statements, both in (0, 1).

    Raises
    ------
    CampaignError
        If the column is missing or empty, or epsilon or delta is not in (0, 1).
    """
    if column not in df.columns:
        raise CampaignError(f"no column {column!r}; columns are {list(df.columns)}")
    for label, value in (("epsilon", epsilon), ("delta", delta)):
        if not 0.0 < value < 1.0:
            raise CampaignError(f"{label} must be in (0, 1), got {value!r}")
    from satfmu.synthesis.robust import probabilistic

    values = df[column].to_numpy(dtype=np.float64)
    if values.size == 0:
        raise CampaignError(f"column {column!r} has no samples")
    ok = values[~np.isnan(values)]
    with np.errstate(invalid="ignore"):  # inf - inf in the mean of +-inf samples
        stats = (float(ok.mean()), float(ok.min()), float(ok.max())) if ok.size else (math.nan,) * 3
    summary = Summary(column, int(values.size), int(values.size - ok.size), int(np.isinf(ok).sum()), *stats,
                      epsilon, delta, probabilistic.worst_case_samples(epsilon, delta))
    if level is not None:
        summary.level = float(level)
        summary.p = float(np.mean(values <= level))
        summary.eps_n = probabilistic.chernoff_accuracy(values.size, delta)
        summary.n_chernoff = probabilistic.chernoff_samples(epsilon, delta)
    return summary


@dataclass(frozen=True)
class FmuTask:
    """Campaign task that runs one co-simulation per sample and reduces it to metrics.

    Built by :func:`fmu_task`; picklable when ``parameters`` and the metrics are
    module-level functions.

    Attributes
    ----------
    fmus : dict of str to str
        Instance name -> FMU path (readable by the workers).
    connections : list of (str, str)
        Output -> input pairs (``("plant.theta", "ctrl.theta")``).
    parameters : callable
        ``parameters(row) -> {instance: {variable: value}}`` for one sample row.
    stop_time, step_size : float
        Stop time and communication step of each run, s.
    metrics : dict of str to callable
        Column name -> ``metric(result) -> float``.
    record : list of str
        Variables to record (base names expand to every index).
    """

    fmus: dict[str, str]
    connections: list[tuple[str, str]]
    parameters: Callable[[np.ndarray], dict[str, dict[str, float]]]
    stop_time: float
    step_size: float
    metrics: dict[str, Callable[[dict[str, np.ndarray]], float]]
    record: list[str]

    def __call__(self, samples: np.ndarray) -> dict[str, np.ndarray]:
        """One value per metric and sample row (NaN for every metric where an FMU failed)."""
        out = {name: np.full(len(samples), np.nan) for name in self.metrics}
        for i, row in enumerate(samples):
            result = self._simulate(row)
            for name, metric in self.metrics.items():
                out[name][i] = np.nan if result is None else float(metric(result))
        return out

    def _simulate(self, row: np.ndarray) -> dict[str, np.ndarray] | None:
        """Recorded signals (plus ``time``, s) of one fresh co-simulation, None if an FMU failed."""
        from satfmu.sims.cosim.master import CoSimulation, FmuCallError

        with CoSimulation(self.fmus) as sim:
            for source, target in self.connections:
                sim.connect(source, target)
            try:
                res = sim.run(self.stop_time, self.step_size, parameters=self.parameters(row), record=self.record)
            except FmuCallError:
                return None
        assert res.dtype.names is not None  # CoSimulation.run records a structured array
        return {name: res[name] for name in res.dtype.names}


def fmu_task(fmus: dict[str, str], connections: list[tuple[str, str]],
             parameters: Callable[[np.ndarray], dict[str, dict[str, float]]], stop_time: float,
             step_size: float, metrics: dict[str, Callable[[dict[str, np.ndarray]], float]],
             record: list[str]) -> FmuTask:
    """A campaign task that co-simulates FMUs once per sample.

    Parameters
    ----------
    fmus : dict of str to str
        Instance name -> FMU path (readable by the workers).
    connections : list of (str, str)
        ``("plant.theta", "ctrl.theta")``: output -> input, as
        :meth:`~satfmu.sims.cosim.master.CoSimulation.connect`.
    parameters : callable
        ``parameters(row) -> {instance: {variable: value}}`` for one sample row; module-level.
    stop_time, step_size : float
        s; ``stop_time / step_size`` must be an integer.
    metrics : dict of str to callable
        Column name -> ``metric(result) -> float``, where ``result`` maps each recorded
        qualified name (``"plant.theta[1]"``) and ``"time"`` to its array; module-level.
    record : list of str
        Variables to record (base names expand to every index).

    Returns
    -------
    FmuTask
        ``task(samples) -> {metric: array}``; a sample whose run raises
        :class:`~satfmu.sims.cosim.master.FmuCallError` gets NaN for every metric.
    """
    return FmuTask({k: str(v) for k, v in fmus.items()}, [(*c,) for c in connections], parameters,
                   float(stop_time), float(step_size), dict(metrics), list(record))
