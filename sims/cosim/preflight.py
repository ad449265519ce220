"""Checks of the FMU files a scenario names, made before the master loads them.

:func:`fmu_problem` says what makes a file unusable here: empty, not a zip archive (another
kind of file, or truncated), an archive :func:`satfmu.fmus.archive.check` refuses (unsafe entries,
beyond its size limits), a damaged member, no ``modelDescription.xml``, another FMI
version than 2.0 and 3.0, no co-simulation interface, no binary for this platform, or another model
than the one the scenario names. :func:`stale_artifact` says when a controller FMU embeds
another artifact than the file of its name (:func:`satfmu.controllers.paths.find_artifact`) holds now: the
FMU records the SHA-256 of the artifact it was built from (:func:`satfmu.fmus.build_record.artifact_digest`),
and a synthesis or an edit that replaced the artifact afterwards leaves a stale pair.
:func:`satfmu.sims.scenario.provisioning.ensure_fmus` acts on both (rebuild in the FMU cache, error elsewhere).
"""
from __future__ import annotations

import hashlib
from pathlib import Path
from xml.etree import ElementTree

from satfmu.fmus import archive, build_record
from satfmu.controllers import catalog, paths

FMI_VERSIONS = ("2.0", "3.0")
"""The FMI versions the master runs (co-simulation)."""


def fmu_problem(path: Path, model: str | None = None) -> str | None:
    """What makes ``path`` unusable as an FMI 2.0 or 3.0 co-simulation FMU (of ``model``) here.

    Parameters
    ----------
    path : Path
        An existing file.
    model : str, optional
        The model name the FMU must declare (``modelName``); None: any.

    Returns
    -------
    str or None
        The problem as a phrase to follow the file name (``"is empty (0 bytes)"``), or None.
    """
    from fmpy import platform, platform_tuple, sharedLibraryExtension

    try:
        listing = archive.check(path, crc=True)
    except archive.UnsafeFmuError as exc:
        return exc.problem
    try:
        version = ElementTree.fromstring(listing.description).get("fmiVersion")
    except ElementTree.ParseError as exc:
        return f"has a modelDescription.xml that is not XML ({exc})"
    if version not in FMI_VERSIONS:
        return f"is an FMI {version} FMU; satfmu runs FMI {' and '.join(FMI_VERSIONS)} co-simulation FMUs"
    try:
        md = archive.parse_description(path, listing.description)
    except archive.UnsafeFmuError as exc:
        return exc.problem
    names = set(listing.names)
    if md.coSimulation is None:
        return "has no co-simulation interface (model exchange only)"
    folder = platform if version == "2.0" else platform_tuple
    binary = f"binaries/{folder}/{md.coSimulation.modelIdentifier}{sharedLibraryExtension}"
    if binary not in names:
        found = sorted({n.split("/")[1] for n in names if n.startswith("binaries/") and n.count("/") > 1})
        return f"has no binary for this platform ({binary}; its binaries: {', '.join(found) or 'none'})"
    if model is not None and md.modelName != model:
        return f"holds the model {md.modelName!r}, not {model!r}"
    return None


def sha256_file(path: Path) -> str:
    """Hex SHA-256 of a file's bytes (read in pieces: memory stays small whatever its size).

    Parameters
    ----------
    path : Path
        The file.
    """
    with open(path, "rb") as fh:
        return hashlib.file_digest(fh, "sha256").hexdigest()


def stale_artifact(fmu: Path, model: str) -> str | None:
    """Why the controller FMU ``fmu`` of the artifact named ``model`` does not embed that
    artifact as its file is now, or None (it does, or no artifact file has that name).

    Parameters
    ----------
    fmu : Path
        The controller FMU file.
    model : str
        Its model name, which is the artifact's name (:func:`satfmu.controllers.paths.find_artifact`);
        a plant or generic model has no artifact (None).

    Returns
    -------
    str or None
        E.g. ``"FMU .../x.fmu embeds the artifact sha256:1a2b3c4d5e6f..., but
        .../artifacts/x.json is sha256:9f8e7d6c5b4a..."``.
    """
    if any(model in group for group in (catalog.PLANTS, catalog.SENSORS, catalog.GENERIC)):  # no artifact: own models
        return None
    try:
        artifact = paths.find_artifact(model)
    except FileNotFoundError:  # built from a file elsewhere: nothing to compare with
        return None
    now = sha256_file(artifact)
    recorded = build_record.artifact_digest(fmu)
    if recorded == now:
        return None
    embeds = "records no artifact digest" if recorded is None else f"embeds the artifact sha256:{recorded[:12]}..."
    return f"FMU {fmu} {embeds}, but the artifact {artifact} is sha256:{now[:12]}..."
