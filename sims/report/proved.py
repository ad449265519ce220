"""What was proved: the design artifact a controller FMU embeds, and its claims.

A controller FMU carries the artifact it was built from as ``resources/artifact.json``
(:func:`satfmu.controllers.artifact.resource`); it is read from the FMU's zip archive as it is (no
synthesis is run again) and validated with :func:`satfmu.controllers.artifact.parse`, which also
re-checks the claims against the numbers recorded (:mod:`satfmu.controllers.claims`). An FMU without
that file is no controller of satfmu's and has nothing to report here.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from satfmu.controllers import artifact
from satfmu.fmus import archive
from satfmu.sims.cosim import preflight
from satfmu.sims.report.folders import FmuFile

RESOURCE = "resources/artifact.json"
"""Where a controller FMU keeps its artifact."""
_SOS_SUFFIXES = (": min_eig", ": residual", ": sampled_min")


@dataclass(frozen=True)
class SosChecks:
    """Summary of a certificate's SOS checks (``"<name>: min_eig"`` and ``"<name>: residual"`` numbers).

    Parameters
    ----------
    count : int
        Checks (Gram matrices).
    min_eig : float
        Smallest Gram eigenvalue over them (>= -1e-6 for a certified claim).
    max_residual : float
        Largest coefficient-match residual (<= 1e-6 for a certified claim).
    """

    count: int
    min_eig: float
    max_residual: float


@dataclass(frozen=True)
class Claims:
    """The claims of one controller FMU's artifact.

    Parameters
    ----------
    fmu : FmuFile
        The FMU the run or campaign used (its recorded SHA-256).
    sha256 : str, optional
        SHA-256 of the file now (None: the file is gone).
    data : dict, optional
        The artifact JSON (None when the FMU embeds none, or it cannot be read).
    problem : str, optional
        Why the artifact cannot be shown, or what in it contradicts its claims.
    used_by : list of str
        ``"<folder label>: <instance>"`` of every run or campaign that used this FMU.
    """

    fmu: FmuFile
    sha256: str | None
    data: dict[str, Any] | None
    problem: str | None = None
    used_by: list[str] = field(default_factory=list)

    @property
    def same_file(self) -> bool:
        """The file now is the one that ran (same SHA-256)."""
        return self.sha256 == self.fmu.sha256

    @property
    def certificate(self) -> dict[str, Any]:
        """The artifact's ``certificate`` (status, proved, region, numbers, ...)."""
        return (self.data or {}).get("certificate", {})

    @property
    def design_plant(self) -> dict[str, Any] | None:
        """``provenance.design_plant`` (model, digest, parameters, ranges), if recorded."""
        return (self.data or {}).get("provenance", {}).get("design_plant")

    @property
    def l2_gain(self) -> dict[str, Any] | None:
        """The certificate's ``l2_gain`` record (``c``, ``method``, ``region``, ``kv``), if any."""
        l2 = self.certificate.get("l2_gain")
        return l2 if isinstance(l2, dict) else None

    @property
    def h2(self) -> dict[str, Any] | None:
        """The certificate's ``h2`` record (``lambda``: the H2 cost bound from ``x0``), if any."""
        h2 = self.certificate.get("h2")
        return h2 if isinstance(h2, dict) else None

    @property
    def numbers(self) -> dict[str, float]:
        """The certificate's numbers other than SOS checks (bounds, gains, levels)."""
        return {k: v for k, v in self.certificate.get("numbers", {}).items() if not k.endswith(_SOS_SUFFIXES)}

    @property
    def sos_checks(self) -> SosChecks | None:
        """The certificate's SOS checks, summarized (None if it records none)."""
        nums = self.certificate.get("numbers", {})
        eig = [v for k, v in nums.items() if k.endswith(": min_eig")]
        res = [v for k, v in nums.items() if k.endswith(": residual")]
        return SosChecks(len(eig), min(eig), max(res) if res else float("nan")) if eig else None


def read_artifact(path: Path) -> dict[str, Any] | None:
    """The artifact JSON an FMU embeds (None if it embeds none).

    Parameters
    ----------
    path : Path
        An FMU file.

    Raises
    ------
    ValueError
        The file is not a zip archive, or its artifact is not JSON.
    """
    try:
        text = archive.read_entry(path, RESOURCE, artifact.MAX_BYTES)
    except (OSError, archive.UnsafeFmuError) as exc:
        raise ValueError(f"{path}: not a readable FMU ({exc})") from None
    return None if text is None else artifact.decode(text, f"{path}:{RESOURCE}")


def claims(fmu: FmuFile) -> Claims | None:
    """The claims of an FMU's embedded artifact; None if the FMU embeds none (not a controller).

    Parameters
    ----------
    fmu : FmuFile

    Returns
    -------
    Claims or None
        With ``problem`` set when the file is gone, unreadable or its artifact is refused
        (the message of :func:`satfmu.controllers.artifact.parse`).
    """
    if not fmu.path.is_file():
        if fmu.model and _known_controller(fmu.model):
            return Claims(fmu, None, None, f"{fmu.path}: the FMU file is gone; its artifact cannot be read")
        return None
    sha = preflight.sha256_file(fmu.path)
    try:
        data = read_artifact(fmu.path)
    except ValueError as exc:
        return Claims(fmu, sha, None, str(exc))
    if data is None:
        return None
    try:
        artifact.parse(data, where=f"{fmu.path.name}:{RESOURCE}")
    except artifact.ArtifactError as exc:
        return Claims(fmu, sha, data, str(exc))
    return Claims(fmu, sha, data)


def _known_controller(model: str) -> bool:
    """Whether ``model`` names a controller artifact (shipped or the user's)."""
    from satfmu.controllers import paths

    try:
        paths.find_artifact(model)
    except (FileNotFoundError, ValueError):
        return False
    return True
