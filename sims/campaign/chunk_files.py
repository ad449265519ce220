"""The chunk files of a campaign folder: Parquet bytes that carry their campaign, checksums, a lock.

Each chunk file (``chunk-000042.parquet``) holds in its Parquet key-value metadata, under
:data:`METADATA_KEY`, ``{"identity": <digest of the campaign's identity>, "chunk": k}``; the
campaign record (``campaign.json``, :mod:`satfmu.sims.campaign.engine`) holds the SHA-256 of every chunk file
it has written. :func:`chunk_problem` says why a file cannot be used as chunk ``k`` of a
campaign. :func:`locked` gives one driver at a time a campaign folder (``.campaign.lock``, an
advisory lock of the operating system, released when the driver ends, also when it is killed).
"""
from __future__ import annotations

import contextlib
import errno
import hashlib
import json
import os
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

try:
    import fcntl
except ImportError:  # Windows
    fcntl = None  # type: ignore[assignment]  # no fcntl module: the msvcrt branches lock instead
    import msvcrt

METADATA_KEY = b"satfmu.campaign"
"""Parquet key-value metadata key of a chunk's campaign identity digest and chunk index."""
LOCK = ".campaign.lock"
"""Lock file of a campaign folder (holds the process id of the driver that has it)."""


def identity_digest(identity: dict[str, Any]) -> str:
    """SHA-256 (hex) of a campaign identity (:meth:`satfmu.sims.campaign.engine.Campaign.identity`), key order aside.

    Parameters
    ----------
    identity : dict
        Plain JSON data: ``n``, ``seed``, ``chunk``, ``task``, ``sampler`` and ``context``.
    """
    return hashlib.sha256(json.dumps(identity, sort_keys=True).encode()).hexdigest()


def chunk_bytes(frame: pd.DataFrame, digest: str, k: int) -> bytes:
    """The Parquet file of chunk ``k``'s results, its metadata naming the campaign ``digest``.

    Parameters
    ----------
    frame : pandas.DataFrame
        The chunk's results (:func:`satfmu.sims.campaign.engine.run_chunk`); its index is not stored.
    digest : str
        :func:`identity_digest` of the campaign.
    k : int
        Chunk index.

    Returns
    -------
    bytes
        The file's content (its metadata under :data:`METADATA_KEY`).
    """
    table = pa.Table.from_pandas(frame, preserve_index=False)
    mark = json.dumps({"identity": digest, "chunk": int(k)}).encode()
    table = table.replace_schema_metadata({**(table.schema.metadata or {}), METADATA_KEY: mark})
    sink = pa.BufferOutputStream()
    pq.write_table(table, sink)
    return sink.getvalue().to_pybytes()


def sha256(data: bytes) -> str:
    """SHA-256 (hex) of a file's bytes.

    Parameters
    ----------
    data : bytes
        The file's content.
    """
    return hashlib.sha256(data).hexdigest()


def chunk_problem(path: Path, recorded: str | None, digest: str, k: int) -> str | None:
    """Why ``path`` is not chunk ``k`` of the campaign ``digest`` (None: it is).

    Parameters
    ----------
    path : Path
        The chunk's file.
    recorded : str or None
        Its SHA-256 in the campaign record, None if the record has none.
    digest : str
        :func:`identity_digest` of the campaign.
    k : int
        Chunk index.

    Returns
    -------
    str or None
        E.g. ``"differs from its checksum in campaign.json (truncated, corrupted or rewritten)"``.
    """
    if not path.is_file():
        return "is recorded in campaign.json but its file is missing"
    if recorded is None:
        return "is not in campaign.json (no checksum to verify it by)"
    data = path.read_bytes()
    if not data:
        return "is empty (0 bytes)"
    if sha256(data) != recorded:
        return "differs from its checksum in campaign.json (truncated, corrupted or rewritten)"
    try:
        mark = json.loads(pq.read_schema(pa.BufferReader(data)).metadata[METADATA_KEY])
    except (pa.ArrowException, KeyError, TypeError, ValueError):
        return "carries no campaign identity in its Parquet metadata"
    if mark.get("identity") != digest:
        return "was written by another campaign (its Parquet metadata names another identity)"
    if mark.get("chunk") != k:
        return f"holds chunk {mark.get('chunk')!r}"
    return None


@contextlib.contextmanager
def locked(folder: Path, waiting: Callable[[str], None]) -> Iterator[None]:
    """Hold the folder's lock (created with the folder) for the block.

    Parameters
    ----------
    folder : Path
        Campaign folder.
    waiting : callable
        Called once with a sentence naming the holder when another process has the lock; then
        this one waits for it.
    """
    folder.mkdir(parents=True, exist_ok=True)
    try:
        fh = open(folder / LOCK, "a+")
    except OSError as exc:
        if exc.errno not in (errno.EROFS, errno.EACCES, errno.EPERM):
            raise
        # a folder that cannot be written (a read-only file system, another user's): no driver
        # can write there either, so there is nothing to guard; reading it goes on, and a write
        # that is still needed fails naming its own file
        yield
        return
    with fh:
        if not _acquire(fh, block=False):
            fh.seek(0)
            holder = fh.read().strip() or "unknown"
            waiting(f"{folder} is in use by another campaign driver (process {holder}); waiting for it to finish")
            _acquire(fh, block=True)
        fh.seek(0)
        fh.truncate()
        fh.write(f"{os.getpid()}\n")
        fh.flush()
        try:
            yield
        finally:
            fh.seek(0)
            fh.truncate()
            _release(fh)


def sweep_partials(folder: Path) -> list[Path]:
    """Remove the temporary files that writers killed in ``folder`` left (``.<name>.<pid>.<random>
    .partial<suffix>``, :func:`satfmu.fmus.atomic.write_atomically`); call it holding :func:`locked`, when
    no other driver writes there. Returns what it removed.

    Parameters
    ----------
    folder : Path
        The campaign folder.

    Returns
    -------
    list of Path
        The files removed.
    """
    removed = []
    for p in folder.glob(".*.partial*"):
        try:
            p.unlink()
        except OSError:  # gone already, or not ours to remove: the next sweep tries again
            continue
        removed.append(p)
    return removed


def _acquire(fh: Any, block: bool) -> bool:
    """Take the exclusive lock of an open file; False if another process has it and not ``block``."""
    if fcntl is not None:
        try:
            fcntl.flock(fh, fcntl.LOCK_EX | (0 if block else fcntl.LOCK_NB))
        except BlockingIOError:
            return False
        return True
    while True:  # msvcrt.locking's own blocking mode gives up after 10 s
        fh.seek(0)
        try:
            msvcrt.locking(fh.fileno(), msvcrt.LK_NBLCK, 1)
            return True
        except OSError:
            if not block:
                return False
            time.sleep(0.1)


def _release(fh: Any) -> None:
    if fcntl is not None:
        fcntl.flock(fh, fcntl.LOCK_UN)
    else:
        fh.seek(0)
        msvcrt.locking(fh.fileno(), msvcrt.LK_UNLCK, 1)
