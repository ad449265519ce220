"""Where a report comes from: satfmu's version and commit, the machine, Python and libraries."""
from __future__ import annotations

import datetime
import os
import platform
import subprocess
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path

LIBRARIES = ("numpy", "scipy", "pandas", "pyarrow", "matplotlib", "sympy", "fmpy", "pythonfmu", "dask",
             "distributed", "cvxpy", "clarabel", "jinja2")
"""Distributions whose versions a report lists (those installed)."""


@dataclass(frozen=True)
class Provenance:
    """The software and machine a report was made with.

    Parameters
    ----------
    satfmu : str
        ``satfmu.__version__`` (the installed distribution's version).
    commit : str, optional
        Git commit of the checkout satfmu runs from, with ``+ uncommitted changes`` when its
        tracked files differ; None if satfmu is not in a git checkout.
    date : str
        When the report was made, ISO 8601, UTC.
    platform : str
        ``platform.platform()``.
    cpus : int
        Logical CPUs (``os.cpu_count()``).
    python : str
        Python version and implementation.
    libraries : dict of str to str
        Distribution -> version, of :data:`LIBRARIES` that are installed.
    """

    satfmu: str
    commit: str | None
    date: str
    platform: str
    cpus: int
    python: str
    libraries: dict[str, str]


def git_commit(folder: Path) -> str | None:
    """The commit checked out in the git work tree holding ``folder`` (None: not one, or no git).

    Parameters
    ----------
    folder : Path

    Returns
    -------
    str or None
        The full hash, followed by ``" + uncommitted changes"`` when tracked files differ from it.
    """
    def git(*args: str) -> str | None:
        try:
            done = subprocess.run(["git", "-C", str(folder), *args], capture_output=True, text=True, timeout=10)
        except (OSError, subprocess.SubprocessError):
            return None
        return done.stdout.strip() if done.returncode == 0 else None

    # only satfmu's own checkout: a git repository that merely contains an installed copy
    # (a virtual environment inside some project) is another project's commit
    top = git("rev-parse", "--show-toplevel")
    if top is None or not (Path(top) / "pyproject.toml").is_file() or not (Path(top) / "sims").is_dir():
        return None
    head = git("rev-parse", "HEAD")
    if head is None:
        return None
    dirty = git("status", "--porcelain", "--untracked-files=no")
    return head + (" + uncommitted changes" if dirty else "")


def collect() -> Provenance:
    """The provenance of a report made now, in this process.

    Returns
    -------
    Provenance
    """
    from satfmu import sims

    versions = {}
    for name in LIBRARIES:
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            continue
    return Provenance(
        satfmu=metadata.version("satfmu"), commit=git_commit(Path(sims.__file__).resolve().parent),
        date=datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        platform=platform.platform(), cpus=os.cpu_count() or 1,
        python=f"{platform.python_implementation()} {platform.python_version()}", libraries=versions)
