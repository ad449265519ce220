"""Where satfmu reads and writes: shipped data, the user's folder, the FMU cache.

Nothing here depends on the working directory. The user's folder holds the artifacts
that ``satfmu synth`` writes (``<home>/artifacts``) and the FMUs built on demand
(``<home>/fmus``); ``<home>`` is ``$SATFMU_HOME`` when set, else the platform's user
data folder (``~/.local/share/satfmu`` on Linux, ``%LOCALAPPDATA%\\satfmu`` on Windows).
This module imports nothing heavy: the command line reads it before anything else.
"""
from __future__ import annotations

import os
from pathlib import Path

from satfmu.fmus.declared import did_you_mean
from satfmu.fmus.errors import ShadowedArtifactWarning

SHIPPED_ARTIFACTS = Path(__file__).resolve().parent / "artifacts"
"""Folder of the controller artifacts shipped with satfmu (``*.json``); never written by synthesis."""
BACKENDS = {"native": "", "python": "_py", "fmi3": "_fmi3"}
"""FMU backend -> file-name suffix (``mrp_satellite.fmu``, ``mrp_satellite_py.fmu``, and the native
FMU as FMI 3.0 ``mrp_satellite_fmi3.fmu``)."""
FMI2_BACKENDS = ("native", "python")
"""The backends whose FMUs are FMI 2.0: the ones an SSP 1.0 file (``satfmu export-ssp``) and the
engines ``satfmu verify`` compares with (libcosim, ecos) take."""
HOME_ENV = "SATFMU_HOME"


def home() -> Path:
    """The user's satfmu folder (absolute): ``$SATFMU_HOME`` or the platform's user data folder."""
    env = os.environ.get(HOME_ENV)
    if env:
        return Path(env).expanduser().resolve()
    import platformdirs

    return Path(platformdirs.user_data_dir("satfmu", appauthor=False)).resolve()


def user_artifacts() -> Path:
    """Folder where ``satfmu synth`` writes artifacts by default (``<home>/artifacts``)."""
    return home() / "artifacts"


def fmu_cache() -> Path:
    """Folder of the FMUs built on demand (``<home>/fmus``), the default ``--fmu-dir``."""
    return home() / "fmus"


def artifact_folders() -> list[Path]:
    """Where an artifact is looked up by name, first match wins: the user's, then the shipped."""
    return [user_artifacts(), SHIPPED_ARTIFACTS]


def find_artifact(name_or_path: str | Path) -> Path:
    """The file of an artifact given by path (``.json``) or by name (user folder, then shipped).

    Parameters
    ----------
    name_or_path : str or Path
        An artifact name (``"mrp_hinf_published"``) or a ``.json`` file.

    Warns
    -----
    ShadowedArtifactWarning
        A user's artifact found by name where a shipped one of that name holds other bytes
        (once per process and file).

    Raises
    ------
    FileNotFoundError
        If no such file exists; the message lists the folders searched and the names found.
    """
    p = Path(name_or_path)
    if p.suffix == ".json":
        if p.is_file():
            return p.resolve()
        raise FileNotFoundError(f"no artifact file {str(p)!r}")
    for folder in artifact_folders():
        found = folder / f"{p.name}.json"
        if found.is_file():
            shipped = SHIPPED_ARTIFACTS / found.name
            if (folder != SHIPPED_ARTIFACTS and found not in _SHADOWS_REPORTED and shipped.is_file()
                    and not _same_bytes(found, shipped)):
                import warnings

                _SHADOWS_REPORTED.add(found)
                warnings.warn(f"the artifact {found} shadows the shipped artifact {shipped} of the same name "
                              "(the user's is used; rename it to keep both)", ShadowedArtifactWarning, stacklevel=2)
            return found
    names = artifact_names()
    raise FileNotFoundError(f"no artifact named {str(name_or_path)!r} in {', '.join(map(str, artifact_folders()))} "
                            f"(known: {', '.join(names)})" + did_you_mean(str(name_or_path), names))


_SHADOWS_REPORTED: set[Path] = set()
"""The user's artifacts already reported as shadowing a shipped one (once per process each)."""


def _same_bytes(a: Path, b: Path) -> bool:
    try:
        return a.stat().st_size == b.stat().st_size and a.read_bytes() == b.read_bytes()
    except OSError:
        return False


def artifact_names() -> list[str]:
    """The names of every artifact in :func:`artifact_folders`, sorted, each once (hidden files,
    e.g. the temporary file of a killed writer, are none)."""
    return sorted({f.stem for d in artifact_folders() if d.is_dir() for f in d.glob("*.json")
                   if not f.name.startswith(".")})

