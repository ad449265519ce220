"""The record a build here leaves in an FMU: its zip archive's comment.

``satfmu-build sha256:<build digest>[ artifact sha256:<artifact digest>]``: the digest of what
the build read (:func:`satfmu.fmus.digest.build_digest`), which :mod:`satfmu.fmus.export` compares
to skip a build that is up to date, and, for a controller FMU, the SHA-256 of the artifact it
embeds (``resources/artifact.json``), which a run compares with the artifact file of its name
(:mod:`satfmu.sims.cosim.preflight`). Reading a record needs neither sympy nor the generators: a
run checks its FMUs without importing them.
"""
from __future__ import annotations

import hashlib
import zipfile
import zlib
from pathlib import Path

from satfmu.fmus import archive

PREFIX = b"satfmu-build sha256:"
"""How the comment of an FMU built here begins (then the build digest, hex)."""
ARTIFACT_FIELD = b" artifact sha256:"
"""What precedes the artifact digest (hex) in a controller FMU's comment."""
ARTIFACT = "artifact.json"
"""Name, in ``resources/``, of the controller artifact a controller FMU embeds."""


def comment(digest: str, resources: dict[str, bytes] | None) -> bytes:
    """The archive comment of a build.

    Parameters
    ----------
    digest : str
        The build digest, hex (:func:`satfmu.fmus.digest.build_digest`).
    resources : dict of str to bytes, optional
        The files the FMU carries in ``resources/``; with :data:`ARTIFACT` among them (a
        controller), its SHA-256 is recorded too.

    Returns
    -------
    bytes
        The comment.
    """
    text = PREFIX + digest.encode()
    if resources and ARTIFACT in resources:
        text += ARTIFACT_FIELD + hashlib.sha256(resources[ARTIFACT]).hexdigest().encode()
    return text


def _recorded(fmu: Path) -> tuple[str, str | None] | None:
    """The build digest and the artifact digest (or None) an FMU built here records; None for
    no file, an archive :func:`satfmu.fmus.archive.check` refuses (not a zip archive, a member failing
    its CRC, unsafe entries, beyond its limits), or an FMU built elsewhere."""
    try:
        archive.check(fmu, crc=True)
        with zipfile.ZipFile(fmu) as z:
            text = z.comment
    except (OSError, EOFError, zipfile.BadZipFile, zlib.error, archive.UnsafeFmuError):  # unreadable or corrupt
        return None
    if not text.startswith(PREFIX):
        return None
    build, _, artifact = text[len(PREFIX):].partition(ARTIFACT_FIELD)
    return build.decode(), artifact.decode() or None


def built_digest(fmu: Path) -> str | None:
    """The build digest an FMU built here records, or None (no file, not a zip archive, built
    elsewhere).

    Parameters
    ----------
    fmu : Path
        The FMU file (it need not exist).

    Returns
    -------
    str or None
        The hex digest (:func:`satfmu.fmus.digest.build_digest`) in the archive's comment.
    """
    recorded = _recorded(fmu)
    return None if recorded is None else recorded[0]


def artifact_digest(fmu: Path) -> str | None:
    """The SHA-256 (hex) of the artifact a controller FMU built here embeds (the bytes of
    ``resources/artifact.json``, those of the artifact file it was built from), or None (not a
    controller, not built here, unreadable).

    Parameters
    ----------
    fmu : Path
        The controller FMU file (it need not exist).

    Returns
    -------
    str or None
        The hex digest in the archive's comment.
    """
    recorded = _recorded(fmu)
    return None if recorded is None else recorded[1]
