"""The FMU files of a scenario: where they are, built or checked before a run, their nominal values.

:func:`fmu_paths` is each instance's file, :func:`ensure_fmus` builds the missing ones and checks
the others before a run, :func:`nominal_values` reads the start values they declare.
"""
from __future__ import annotations

import re
import warnings
from pathlib import Path
from typing import Any, Callable

from satfmu.controllers.paths import BACKENDS
from satfmu.fmus.declared import did_you_mean
from satfmu.fmus.errors import ScenarioError, StaleFmuWarning
from satfmu.sims.cosim import preflight
from satfmu.sims.scenario.spec import Scenario


def fmu_paths(scenario: Scenario, fmu_dir: Path, backend: str) -> dict[str, Path]:
    """Instance name -> FMU file, for the chosen default backend (``path`` entries resolve
    against the scenario's folder, ``model`` entries name files in ``fmu_dir``).

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    fmu_dir : Path
        Folder of the FMUs named by ``model``.
    backend : {"native", "python"}
        Default backend of the instances (an instance's own ``backend`` overrides it).

    Raises
    ------
    ScenarioError
        An unknown backend.
    """
    if backend not in BACKENDS:
        raise ScenarioError(f"backend must be one of {sorted(BACKENDS)}, got {backend!r}"
                            f"{did_you_mean(str(backend), sorted(BACKENDS))}")
    out = {}
    for inst, spec in scenario.fmus.items():
        if spec.path is not None:
            p = Path(spec.path)
            out[inst] = p if p.is_absolute() else scenario.folder / p
        else:
            out[inst] = Path(fmu_dir) / f"{spec.model}{BACKENDS[spec.backend or backend]}.fmu"
    return out


def context(scenario: Scenario, fmu_dir: Path, backend: str) -> dict[str, Any]:
    """What ``campaign.json`` keeps of a scenario campaign (part of its identity): the scenario's
    declaration, the folder its relative paths resolve against, the backend, the FMU folder, and
    each FMU file's name and SHA-256 (another binary is another campaign).

    Parameters
    ----------
    scenario : Scenario
        The campaign's (or run's) scenario.
    fmu_dir : Path
        The FMU folder the FMUs are read from.
    backend : {"native", "python"}
        Default backend of the instances.

    Returns
    -------
    dict
        Plain JSON data: ``scenario``, ``base_dir``, ``path``, ``backend``, ``fmu_dir`` and
        ``fmus`` (instance -> ``{"file": ..., "sha256": ...}``).
    """
    fmus = {inst: {"file": p.name, "sha256": preflight.sha256_file(p)}
            for inst, p in fmu_paths(scenario, Path(fmu_dir), backend).items()}
    return {"scenario": scenario.to_dict(), "base_dir": str(scenario.folder),
            "path": None if scenario.path is None else str(scenario.path), "backend": backend,
            "fmu_dir": str(fmu_dir), "fmus": fmus}


def ensure_fmus(scenario: Scenario, fmu_dir: str | Path | None, backend: str, allow_stale: bool = False) -> Path:
    """The FMU folder of a run, with every FMU the scenario names present and usable.

    An FMU named by ``model`` and missing is built into the folder (plants by model name,
    controllers from their artifact, found in the user's folder before the shipped ones).
    An FMU present is checked (:mod:`satfmu.sims.cosim.preflight`): a readable FMI 2.0 co-simulation FMU
    of that model with a binary for this platform and, for a controller, embedding the
    artifact file of its name as that file is now. In the FMU cache
    (:func:`satfmu.controllers.paths.fmu_cache`, satfmu's own folder) an FMU failing that is rebuilt, with
    a :class:`StaleFmuWarning`; in any other folder it is an error (files there are the
    user's, never replaced), or, for a stale controller with ``allow_stale``, a
    :class:`StaleFmuWarning` and the FMU is used as it is. An FMU named by ``path`` is
    checked alike (not its model name or artifact), and never rebuilt.

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    fmu_dir : path or None
        The FMU folder; None for the FMU cache (:func:`satfmu.controllers.paths.fmu_cache`).
    backend : {"native", "python"}
        Default backend of the instances (an instance's own ``backend`` overrides it).
    allow_stale : bool
        Use a stale controller FMU outside the cache as it is, with a warning.

    Returns
    -------
    Path
        The FMU folder, resolved.

    Raises
    ------
    ScenarioError
        Naming the key (``fmus.<instance>.model`` or ``.path``) and the file: a missing
        ``path`` FMU, an unknown model name (with the closest one), an artifact that cannot
        be built, an unusable or stale FMU outside the cache.
    """
    from satfmu.controllers import catalog
    from satfmu.controllers.paths import fmu_cache

    folder = fmu_cache() if fmu_dir is None else Path(fmu_dir).resolve()
    cache = folder == fmu_cache()
    where = str(scenario.path) if scenario.path else f"scenario {scenario.name!r}"
    for inst, p in fmu_paths(scenario, folder, backend).items():
        spec = scenario.fmus[inst]
        if spec.path is not None:
            problem = preflight.fmu_problem(p) if p.is_file() else "does not exist"
            if problem:
                raise ScenarioError(f"{where}: fmus.{inst}.path: FMU file {p} {problem}")
            continue
        key = f"{where}: fmus.{inst}.model"
        assert spec.model is not None  # validate(): exactly one of model and path
        if p.is_file():
            problem = preflight.fmu_problem(p, spec.model)
            stale = None if problem else preflight.stale_artifact(p, spec.model)
            if problem is None and stale is None:
                continue
            if stale and allow_stale and not cache:
                warnings.warn(f"{key}: stale FMU run as it is (allow_stale): {stale}", StaleFmuWarning, stacklevel=2)
                continue
            if not cache:
                raise ScenarioError(f"{key}: stale FMU: {stale} (remove the FMU to have it built from the artifact, "
                                    "or pass --allow-stale to run it as it is)" if stale else
                                    f"{key}: FMU file {p} {problem} (remove it to have it built anew)")
            warnings.warn(f"{key}: rebuilding the FMU in the cache: {stale or f'FMU file {p} {problem}'}",
                          StaleFmuWarning, stacklevel=2)
            p.unlink()
        try:
            catalog.ensure(folder, [spec.model], spec.backend or backend)
        except (ValueError, FileNotFoundError) as exc:
            raise ScenarioError(f"{key}: no FMU {p.name} in {folder}, and it cannot be built: {exc}") from None
    return folder


def nominal_values(scenario: Scenario, fmu_dir: str | Path | None = None, backend: str = "native"
                   ) -> Callable[[str, str], float | None]:
    """The nominal value of a parameter or profile field: the scenario's start value, else the
    FMU's (its model description, read on first need; the FMUs are ensured by
    :func:`ensure_fmus`); None when the instance has no such parameter or the profile no such
    field.

    Parameters
    ----------
    scenario : Scenario
        The scenario.
    fmu_dir : path, optional
        Folder of the FMUs named by ``model`` (default :func:`satfmu.controllers.paths.fmu_cache`).
    backend : {"native", "python"}
        Default backend of the instances (an instance's own ``backend`` overrides it).

    Returns
    -------
    callable
        (instance or ``"profiles[i]"``, name) -> float or None.
    """
    from satfmu.fmus import archive

    starts: dict[str, dict[str, float]] = {}

    def value(owner: str, name: str) -> float | None:
        m = re.fullmatch(r"profiles\[(\d+)\]", owner)
        if m:
            v = scenario.profiles[int(m[1])].get(name)
            return None if v is None else float(v)
        given = scenario.fmus[owner].parameters
        if name in given:
            return float(given[name])
        if owner not in starts:
            folder = ensure_fmus(scenario, fmu_dir, backend)
            md = archive.read_description(fmu_paths(scenario, folder, backend)[owner])
            starts[owner] = {v.name: float(v.start) for v in md.modelVariables
                             if v.causality in ("parameter", "input") and v.type in ("Real", "Integer")
                             and v.start is not None}
        return starts[owner].get(name)

    return value
