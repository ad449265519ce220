"""Every error and warning of satfmu, under one base of each: catch
:class:`~satfmu.fmus.errors.SatfmuError` for any refusal satfmu states (bad input, a design that
cannot be certified, an FMU that fails), and filter :class:`~satfmu.fmus.errors.SatfmuWarning` for
any of its warnings.

Each class also keeps the built-in base it had (``ValueError`` for bad input, ``RuntimeError`` for a
failed computation, ``KeyError``, ``MemoryError``), so ``except ValueError`` still catches what it
caught. The modules that raise a class re-export it under their own name (``satfmu.sims.scenario.spec.
ScenarioError`` is this module's :class:`ScenarioError`), and the facade ``satfmu`` exports them all.
"""
from __future__ import annotations

from pathlib import Path


class SatfmuError(Exception):
    """Base class of every error satfmu raises on purpose; the message says what and where."""


class SatfmuWarning(UserWarning):
    """Base class of every warning satfmu issues."""


# ------------------------------ fmus: FMU models, archives and builds
class ModelDefinitionError(SatfmuError, ValueError):
    """A model definition is inconsistent (names, units, shapes, symbols)."""


class ProfileError(SatfmuError, ValueError):
    """A profile declaration is invalid; the message names the profile and the field."""


class SpacecraftError(SatfmuError, ValueError):
    """A spacecraft description is missing, malformed or not physical; the message names the key."""


class UnitError(SatfmuError, ValueError):
    """A unit satfmu does not know, or two units that do not convert into each other
    (:mod:`satfmu.fmus.units`)."""


class UnsafeFmuError(SatfmuError, ValueError):
    """An FMU file that satfmu refuses to read: not a zip archive, an unsafe entry, or beyond
    a limit of :class:`satfmu.fmus.archive.FmuLimits`. The message names the file, the entry and
    the limit.

    Attributes
    ----------
    path : Path
        The file.
    problem : str
        The message without the file, a phrase to follow its name (``"has no modelDescription.xml"``).
    """

    def __init__(self, path: Path, problem: str) -> None:
        super().__init__(f"{path} {problem}")
        self.path = path
        self.problem = problem


class FmuBuildError(SatfmuError, RuntimeError):
    """Compiling or packaging an FMU failed."""


# ------------------------------ controllers: controllers and artifacts
class ArtifactError(SatfmuError, ValueError):
    """An artifact file is missing, not JSON, or violates the schema; the message says where."""


class RiccatiCheckError(SatfmuError, RuntimeError):
    """The Riccati solve failed or its solution does not pass the checks."""


# ------------------------------ synthesis: conic programs, SOS, LMIs and design methods
class LMIError(SatfmuError, ValueError):
    """A non-affine operation, mismatched shapes, or a value asked before a solve."""


class SOSError(SatfmuError, RuntimeError):
    """The program is infeasible, the solver failed, or the input is invalid."""


class SolverMemoryError(SatfmuError, MemoryError):
    """Clarabel ran out of the memory allowed to it (``memory_limit`` of
    :func:`satfmu.synthesis.core.conic.solve_clarabel`)."""


class SolverFailure(SatfmuError, RuntimeError):
    """A solver stopped without a status (a numerical error): the next rung is tried."""


class FitCertificationError(SatfmuError, RuntimeError):
    """The fitted gain failed a check made independently of the fit."""


class PeriodicSystemError(SatfmuError, ValueError):
    """A periodic system or gain sequence has wrong shapes or non-finite entries."""


class RobustLMIError(SatfmuError, ValueError):
    """Base class of the input errors of the robust LMI modules (see
    :mod:`satfmu.synthesis.robust.lft_plant`)."""


class PlantDataError(RobustLMIError):
    """A plant, descriptor, gain or system has wrong shapes or non-finite entries."""


class DeltaError(RobustLMIError):
    """A parameter vector has the wrong length, is not finite, is outside [-1, 1], or the
    system is ill posed (singular) there."""


class TooManyVerticesError(RobustLMIError):
    """The box has more vertices than ``max_vertices``."""


class ProgramTooLargeError(RobustLMIError):
    """A program's estimated size exceeds its limit (checked before the solver runs)."""


class NotHurwitzError(RobustLMIError):
    """The H-infinity norm was asked for an unstable system."""


class OptionError(RobustLMIError):
    """A design option (weights, region, eps, uncertainty kind) is invalid."""


class VariantError(SatfmuError, ValueError):
    """A variant selects axes, appendages or types that do not exist."""


# ------------------------------ sims: co-simulation, scenarios, campaigns and reports
class MasterError(SatfmuError, RuntimeError):
    """Base class of co-simulation errors."""


class UnknownVariableError(MasterError, KeyError):
    """A name refers to no FMU or no variable; the message names it and what exists."""

    def __str__(self) -> str:  # KeyError would quote the message
        return str(self.args[0])


class WiringError(MasterError):
    """A connection or profile target is invalid (types, causality, driven twice, loops)."""


class FmuCallError(MasterError):
    """An FMU returned fmi2Error/fmi2Fatal; the message holds the FMU's own log lines."""


class UnreadableFmuError(SatfmuError, ValueError):
    """A file that is not a readable FMU (not a zip, no or a broken model description, an unsafe
    archive that :mod:`satfmu.fmus.archive` refuses, ...)."""


class EngineError(SatfmuError, RuntimeError):
    """libcosim failed, or its process ended abnormally; the message holds its output."""


class ScenarioError(SatfmuError, ValueError):
    """A scenario is missing, malformed, or refers to something that does not exist; the message
    names the key path (``mine.toml: connections[2].from: ...``)."""


class DesignMismatchWarning(SatfmuWarning):
    """A scenario pairs a controller with a plant whose parameters differ from its design plant."""


class StaleFmuWarning(SatfmuWarning):
    """A controller FMU embeds another artifact than the file of its name holds now (rebuilt in
    the FMU cache; run as it is elsewhere with ``allow_stale``), or an unusable FMU in the FMU
    cache was rebuilt."""


class SspError(ScenarioError):
    """The scenario cannot be written as an SSP file, or the file fails the SSP schema."""


class DispersionError(SatfmuError, ValueError):
    """A dispersion declaration is invalid or cannot be drawn; the message names the key path."""


class CampaignError(SatfmuError, ValueError):
    """Invalid campaign, task output or result folder; the message says what and where."""


class CampaignWarning(SatfmuWarning):
    """A chunk of a campaign folder is recomputed (the message names it and says why), or the
    folder is in use by another driver and this one waits."""


class InsecureConnectionWarning(SatfmuWarning):
    """A campaign connects to a Dask scheduler off this host over plain TCP: unauthenticated and
    unencrypted (use ``tls://``)."""


class DesignError(SatfmuError, RuntimeError):
    """A design could not be made or failed its independent check; nothing is saved."""


class ShadowedArtifactWarning(SatfmuWarning):
    """A user's artifact has the name of a shipped one (and other contents): it is the one used."""


class ReportError(SatfmuError, ValueError):
    """A folder a report cannot be made from; the message names the folder or file and why."""


class CaseBroken(SatfmuError):
    """The robustness suite's own signal, caught by it (not exported by ``satfmu``): a call the case
    needed (not the one under test) failed, so the case FAILs with this message."""
