"""Files written whole or not at all: a temporary name in the same folder, then a rename.

A reader (or a run killed half-way) never sees a partial file under the final name, and
two writers never share a temporary name (process id and a random part in it).

For the tests that kill a writer, ``$SATFMU_TEST_KILL_AT`` (:data:`KILL_ENV`) makes the
process kill itself (SIGKILL) at one point of one write; unset, it costs one lookup per file.
"""
from __future__ import annotations

import os
import signal
import uuid
from pathlib import Path
from typing import Any, Callable

KILL_ENV = "SATFMU_TEST_KILL_AT"
"""``"N:PHASE"``: at the N-th file this process writes with :func:`write_atomically` (from 1),
SIGKILL itself: PHASE ``write`` with the temporary file half written, ``rename`` with it
complete and not yet renamed, ``done`` right after the rename. A test hook."""
PHASES = ("write", "rename", "done")
_written = 0
"""Files this process has begun to write with :func:`write_atomically` (for :data:`KILL_ENV`)."""


def _kill_point(phase: str, tmp: Path) -> None:
    """SIGKILL this process if :data:`KILL_ENV` names this file and ``phase``."""
    spec = os.environ.get(KILL_ENV)
    if not spec:
        return
    n, _, at = spec.partition(":")
    if int(n) != _written or at != phase:
        return
    if phase == "write":  # the state a kill part-way through the writer leaves: half a file
        with open(tmp, "r+b") as fh:
            fh.truncate(tmp.stat().st_size // 2)
    os.kill(os.getpid(), signal.SIGKILL)


def write_atomically(path: str | Path, write: Callable[[Path], Any]) -> Path:
    """Call ``write(tmp)`` on a temporary path beside ``path``, then rename it onto ``path``.

    Parameters
    ----------
    path : path
        The final file (its folder is created).
    write : callable
        Writes the whole file to the path it is given.

    Returns
    -------
    Path
        ``path``. If ``write`` raises, nothing is left under either name.
    """
    global _written
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    # the final suffix last, so that writers that go by it (matplotlib's savefig) still can
    tmp = path.with_name(f".{path.stem}.{os.getpid()}.{uuid.uuid4().hex[:8]}.partial{path.suffix}")
    _written += 1
    try:
        write(tmp)
        _kill_point("write", tmp)
        _kill_point("rename", tmp)
        os.replace(tmp, path)
        _kill_point("done", path)
    except OSError as exc:
        if exc.filename is not None:
            raise
        # a full disk or a quota says "No space left on device" with no file: name the file
        raise OSError(exc.errno, f"{exc.strerror or exc} (writing {path})", str(path)) from None
    finally:
        tmp.unlink(missing_ok=True)
    return path
