"""satfmu: spacecraft attitude control plants and controllers as FMI 2.0 co-simulation FMUs.

The public API, for scripts and tests (the implementation lives in the packages
``satfmu.fmus`` <- ``satfmu.controllers`` <- ``satfmu.synthesis`` <- ``satfmu.sims``; these are its stable names):

Your spacecraft and its plant
    :class:`Spacecraft` (name, inertia tensor, torque limit; ``Spacecraft.from_toml``),
    :data:`SEED_000` (the seed 000 paper's satellite), :func:`mrp_plant` (the MRP satellite
    model of a spacecraft), :func:`cubesat_plant` (the magnetorquer cubesat of seed 003, in
    principal axes), :func:`manoeuvre` (a rest-to-rest start by axis and angle);
    :class:`ReactionWheel` (a wheel of the spacecraft's array) and :func:`wheel_plant` (the MRP
    satellite with its reaction wheels integrated);
    :class:`FlexibleSpacecraft` (a rigid hub with flexible appendages, their modes' frequency
    and damping intervals, reaction wheels; ``FlexibleSpacecraft.from_toml``) with its parts
    :class:`Appendage`, :class:`Mode`, :class:`Interval`, :class:`Wheels`,
    :class:`InertiaUncertainty`, and :data:`DEMETER` (seed 004's satellite).
Scenarios
    :class:`Scenario` (``from_toml``, ``from_dict``, or built from :class:`FmuSpec`,
    :class:`Connection`, :class:`Metric`), :func:`run` -> :class:`Result` (metrics,
    pass/fail, the recorded array, ``.plot()``, ``.write()``), :class:`ScenarioError`,
    :class:`DesignMismatchWarning`, :class:`StaleFmuWarning`; :class:`Dispersions` (the
    ``[dispersions]`` table: ``Scenario.sample(seed, index)`` is one Monte Carlo sample's
    scenario), :class:`DispersionError`.
Dispersion campaigns
    :func:`run_campaign` (the Monte Carlo campaign of a scenario's ``[dispersions]`` on Dask,
    resumable) -> :class:`CampaignResult` (``.rows``, ``.statistics``: a :class:`Statistics`
    of pass rates with Clopper-Pearson intervals, percentiles and the worst samples);
    :func:`replay` (one sample of a finished campaign run again bit for bit, its time
    histories and plots written) -> :class:`Result`.
Reports
    :func:`write_report` (one self-contained HTML page of run and campaign folders: metrics,
    time histories with requirement and actuator-limit lines, campaign statistics and figures,
    side-by-side comparison, what each controller's artifact proved, provenance),
    :class:`ReportError`.
FMUs
    :func:`build` (every FMU, or some by name, into a folder; no-op when up to date),
    :func:`fmu_cache` (the default FMU folder).
Designs
    One per method of the five seed papers; each returns a :class:`Design` whose ``.write()``
    saves the artifact into :func:`user_artifacts` and can build its FMUs:
    :func:`design_hinf` (seed 000), :func:`design_h2hinf` (seed 001),
    :func:`design_sdre` and :func:`design_vscmg_sdre` (seed 002), :func:`design_cubesat_periodic` (seed 003),
    :func:`design_demeter` (seed 004); :class:`DesignError`.
Artifacts
    :func:`load_artifact`, :func:`find_artifact`, :func:`user_artifacts`.
Errors and warnings
    Every error satfmu raises on purpose is a :class:`SatfmuError` (each also keeps its built-in
    base: :class:`ScenarioError` is a ``ValueError``, :class:`DesignError` a ``RuntimeError``),
    every warning a :class:`SatfmuWarning`; all are exported here (:mod:`satfmu.fmus.errors`).

Names are imported on first use, so ``import satfmu`` is fast.
"""
from __future__ import annotations

import importlib
from pathlib import Path
from typing import TYPE_CHECKING, Any, Iterable, Mapping

if TYPE_CHECKING:
    from satfmu.controllers.artifact import Artifact
    from satfmu.fmus.model import Model
    from satfmu.fmus.plants.spacecraft import Spacecraft
    from satfmu.sims.scenario.result import Result
    from satfmu.sims.scenario.spec import Scenario

_EXPORTS = {
    # every error and warning satfmu raises, under SatfmuError and SatfmuWarning (satfmu.fmus.errors)
    **{name: "satfmu.fmus.errors" for name in (
        "SatfmuError", "SatfmuWarning", "ModelDefinitionError", "ProfileError", "SpacecraftError", "UnitError",
        "UnsafeFmuError",
        "FmuBuildError", "ArtifactError", "RiccatiCheckError", "LMIError", "SOSError", "SolverMemoryError",
        "SolverFailure", "FitCertificationError", "PeriodicSystemError", "RobustLMIError", "PlantDataError",
        "DeltaError", "TooManyVerticesError", "ProgramTooLargeError", "NotHurwitzError", "OptionError",
        "VariantError", "MasterError", "UnknownVariableError", "WiringError", "FmuCallError", "UnreadableFmuError",
        "EngineError", "ScenarioError", "DesignMismatchWarning", "StaleFmuWarning", "SspError", "DispersionError",
        "CampaignError", "CampaignWarning", "InsecureConnectionWarning", "DesignError", "ShadowedArtifactWarning",
        "ReportError")},
    "Spacecraft": "satfmu.fmus.plants.spacecraft", "SEED_000": "satfmu.fmus.plants.spacecraft",
    "ReactionWheel": "satfmu.fmus.plants.wheels",
    **{name: "satfmu.fmus.plants.flexible_spacecraft" for name in (
        "FlexibleSpacecraft", "Appendage", "Mode", "Interval", "Wheels", "InertiaUncertainty", "DEMETER")},
    "Scenario": "satfmu.sims.scenario.spec", "FmuSpec": "satfmu.sims.scenario.spec",
    "Connection": "satfmu.sims.scenario.spec",
    "Metric": "satfmu.sims.scenario.spec", "Result": "satfmu.sims.scenario.result",
    "Dispersions": "satfmu.sims.scenario.dispersions",
    "run_campaign": "satfmu.sims.campaign.results",
    "CampaignResult": "satfmu.sims.campaign.results",
    "Statistics": "satfmu.sims.campaign.statistics", "replay": "satfmu.sims.campaign.replay",
    "write_report": "satfmu.sims.report",
    "Design": "satfmu.synthesis.designs", "design_hinf": "satfmu.synthesis.designs",
    "design_h2hinf": "satfmu.synthesis.designs", "design_vscmg_sdre": "satfmu.synthesis.designs",
    "design_sdre": "satfmu.synthesis.designs",
    "design_cubesat_periodic": "satfmu.synthesis.designs", "design_demeter": "satfmu.synthesis.designs",
    "fmu_cache": "satfmu.controllers.paths", "user_artifacts": "satfmu.controllers.paths",
    "find_artifact": "satfmu.controllers.paths",
    "manoeuvre": "satfmu.synthesis.polynomial_feedback.two_step",
    "margins": "satfmu.sims.workflows.analysis",
}
_FUNCTIONS = {"run", "build", "mrp_plant", "wheel_plant", "cubesat_plant", "load_artifact"}
__all__ = sorted([*_EXPORTS, *_FUNCTIONS, "__version__"])


def run(scenario: "Scenario | Mapping[str, Any] | str | Path", fmu_dir: str | Path | None = None,
        backend: str = "native", out_dir: str | Path | None = None, strict: bool = False,
        design_rtol: float | None = None, allow_stale: bool = False, plots: bool = False,
        stream: bool = False) -> "Result":
    """Run a scenario and evaluate its metrics (:func:`satfmu.sims.scenario.run.run`).

    Parameters
    ----------
    scenario : Scenario, dict, str or Path
        A scenario, its plain data, a TOML file, or a shipped scenario's name.
    fmu_dir : path, optional
        FMU folder (default :func:`fmu_cache`); FMUs it lacks are built into it first.
    backend : {"native", "python"}
        Default FMU backend of the instances.
    out_dir : path, optional
        Also write the CSV, the run record and the summary into ``out_dir/<name>/``.
    strict : bool
        A controller paired with a plant other than its design plant is an error
        (default: a :class:`DesignMismatchWarning`).
    design_rtol : float, optional
        Relative tolerance of that comparison (default 1e-3).
    allow_stale : bool
        Run a controller FMU outside the FMU cache that embeds another artifact than the file
        of its name holds now, with a :class:`StaleFmuWarning` (default: refused; in the cache
        it is rebuilt).
    plots : bool
        With ``out_dir``, draw the PNG plots as well (about 1 s of CPU: matplotlib).
    stream : bool
        With ``out_dir``, write the CSV block by block as the run goes and keep only the columns
        the metrics (and plots) read: ``results`` then holds those, ``Result.csv`` is the file
        with every recorded column (a long run's memory does not grow with what it records).

    Returns
    -------
    Result
        ``.passed``, ``.metrics``, ``.results`` (structured array), ``.plot(path)``,
        ``.write(folder)``.
    """
    from satfmu.sims.scenario.run import run as run_scenario

    return run_scenario(scenario, fmu_dir, backend, out_dir, strict, design_rtol, allow_stale, plots, stream)


def build(names: Iterable[str] | None = None, fmu_dir: str | Path | None = None,
          backends: tuple[str, ...] = ("native", "python"), jobs: int | None = None) -> list[Path]:
    """Build FMUs (no-op for those whose build digest matches).

    Parameters
    ----------
    names : list of str, optional
        Model or artifact names (``"mrp_satellite"``, ``"mrp_hinf_published"``, your own
        artifact's name); default every FMU satfmu ships.
    fmu_dir : path, optional
        Destination (default :func:`fmu_cache`).
    backends : tuple of str
        ``"native"`` (C, compiled here) and/or ``"python"`` (pythonfmu).
    jobs : int, optional
        Parallel build processes when building everything (default one per CPU).

    Returns
    -------
    list of Path
        The FMU files.
    """
    from satfmu.controllers import catalog, paths

    folder = paths.fmu_cache() if fmu_dir is None else Path(fmu_dir)
    if names is None:
        return catalog.build_all(folder, tuple(backends), jobs=jobs).paths
    out = []
    for b in backends:
        out += list(catalog.ensure(folder, list(names), b).values())
    return out


def mrp_plant(spacecraft: "Spacecraft | None" = None) -> "Model":
    """The MRP satellite model (seed 000's plant) of a spacecraft.

    Parameters
    ----------
    spacecraft : Spacecraft, optional
        Default :data:`SEED_000`. Its inertia tensor (products included) and torque limit
        become the defaults of the parameters ``I_x ... I_yz`` and ``u_max``.

    Returns
    -------
    satfmu.fmus.model.Model
        The symbolic model that designs take and FMUs are generated from.
    """
    from satfmu.fmus.plants import mrp_satellite

    return mrp_satellite.MODEL if spacecraft is None else mrp_satellite.build(spacecraft)


def wheel_plant(spacecraft: "Spacecraft | None" = None, n_wheels: int = 4) -> "Model":
    """The MRP satellite with its reaction wheel array integrated (``mrp_satellite_rw<N>``).

    Parameters
    ----------
    spacecraft : Spacecraft, optional
        A spacecraft with wheels (``Spacecraft(..., wheels=[ReactionWheel(...), ...])``); its
        inertia (wheels included) and wheels become the parameters' defaults. Default: the
        shipped plant of ``n_wheels`` (3 orthogonal or 4 in a pyramid). A spacecraft with 3 or 4
        wheels runs in the shipped FMU too, with
        ``satfmu.fmus.plants.wheel_spacecraft.parameters(spacecraft)`` as its parameters.
    n_wheels : {3, 4}, optional
        The shipped plant's number of wheels, without a spacecraft.

    Returns
    -------
    satfmu.fmus.model.Model
        The symbolic model.

    Raises
    ------
    ValueError
        If the spacecraft has no wheels, or ``n_wheels`` is not 3 or 4 without one.
    """
    from satfmu.fmus.plants import wheel_spacecraft

    if spacecraft is not None:
        return wheel_spacecraft.build(spacecraft)
    if n_wheels not in wheel_spacecraft.MODELS:
        raise ValueError(f"n_wheels must be one of {sorted(wheel_spacecraft.MODELS)} without a spacecraft, "
                         f"got {n_wheels!r}")
    return wheel_spacecraft.MODELS[n_wheels]


def cubesat_plant(spacecraft: "Spacecraft | None" = None) -> "Model":
    """The magnetorquer cubesat model (seed 003's plant) of a spacecraft in principal axes.

    Parameters
    ----------
    spacecraft : Spacecraft, optional
        Default seed 003's cubesat, diag(0.005, 0.005, 0.002) kg m^2. Its three principal
        moments become the defaults of ``I_x, I_y, I_z``.

    Raises
    ------
    ValueError
        If the spacecraft has products of inertia.
    """
    from satfmu.fmus.plants import cubesat

    return cubesat.MODEL if spacecraft is None else cubesat.build(spacecraft=spacecraft)


def load_artifact(name_or_path: str | Path) -> "Artifact":
    """A controller artifact, validated.

    Parameters
    ----------
    name_or_path : str or Path
        An artifact name (looked up in :func:`user_artifacts`, then the shipped ones) or a
        ``.json`` file.

    Raises
    ------
    FileNotFoundError
        Unknown name (with the closest one) or missing file.
    satfmu.controllers.artifact.ArtifactError
        Not JSON or not a valid artifact (the message names the key).
    """
    from satfmu.controllers import artifact
    from satfmu.controllers import paths

    return artifact.load(paths.find_artifact(name_or_path))


def __getattr__(name: str) -> Any:
    if name == "__version__":
        from importlib.metadata import version

        return version("satfmu")
    if name in _EXPORTS:
        value = getattr(importlib.import_module(_EXPORTS[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'satfmu' has no attribute {name!r}")


def __dir__() -> list[str]:
    return __all__
