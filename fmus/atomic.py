"""Files written whole or not at all: a temporary name in the same folder, then a rename.

A reader (or a run killed half-way) never sees a partial file under the final name, and
two writers never share a temporary name (process id and a random part in it).
"""
from __future__ import annotations

import os
import uuid
from pathlib import Path
from typing import Any, Callable


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
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    # the final suffix last, so that writers that go by it (matplotlib's savefig) still can
    tmp = path.with_name(f".{path.stem}.{os.getpid()}.{uuid.uuid4().hex[:8]}.partial{path.suffix}")
    try:
        write(tmp)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    return path
