"""Every FMU the project builds: the plant models and one controller per shipped artifact.

Importing this module is cheap: the model modules (sympy, each building its model at import)
are imported by the function that needs them. :func:`source` builds one model by name,
:func:`ensure` builds only the FMUs missing from a folder, :func:`build_all` the whole catalog.
"""
from __future__ import annotations

import functools
import importlib
import multiprocessing
import os
import subprocess
import sys
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from typing import TYPE_CHECKING, Callable, Iterable, TypeVar
from pathlib import Path

from satfmu.controllers import paths

if TYPE_CHECKING:
    from satfmu.controllers.artifact import Artifact
    from satfmu.fmus.model import Model

T = TypeVar("T")
R = TypeVar("R")


COSIMULATION_BACKENDS = ("native", "python", "fmi3")
"""The co-simulation FMU backends: FMI 2.0 native and pythonfmu, FMI 3.0 native."""
ALL_BACKENDS = (*COSIMULATION_BACKENDS, "me", "me3")
"""Every FMU backend, in build order."""
PLANT_BACKENDS = ALL_BACKENDS
"""A plant's FMUs: co-simulation in every backend and model exchange (FMI 2.0 and FMI 3.0)."""


@dataclass(frozen=True)
class FmuSource:
    """A model to export and the resources its FMUs carry.

    Attributes
    ----------
    model : Model
        The model (:class:`satfmu.fmus.model.Model`).
    resources : dict of str to bytes
        File name -> content of the files its FMUs carry under ``resources/`` (a controller's
        ``artifact.json``); empty for a plant.
    backends : tuple of str, optional
        FMU backends the model supports, among ``"native"`` (FMI 2.0), ``"python"`` (pythonfmu,
        FMI 2.0), ``"fmi3"`` (native FMI 3.0), ``"me"`` and ``"me3"`` (native FMI 2.0 and FMI 3.0
        model exchange, the plants'). Default the first three.
    """

    model: Model
    resources: dict[str, bytes]
    backends: tuple[str, ...] = COSIMULATION_BACKENDS
    """FMU backends the model supports (every model has the first three but the generic signal
    generators, native only: FMI 2.0 and FMI 3.0; the plants also model exchange)."""


def _plant(module: str, backends: tuple[str, ...] = PLANT_BACKENDS) -> Callable[[], FmuSource]:
    """The source of the model ``module.MODEL`` (the module builds it when first imported): a plant's
    backends by default."""
    return lambda: FmuSource(importlib.import_module(module).MODEL, {}, backends)


def _wheel_plant(n: int) -> FmuSource:
    from satfmu.fmus.plants import wheel_spacecraft

    return FmuSource(wheel_spacecraft.MODELS[n], {}, PLANT_BACKENDS)


def _online_sdre(name: str) -> FmuSource:
    from satfmu.controllers import servo

    return FmuSource(servo.build_online(name), {})


def _backstepping() -> FmuSource:
    from satfmu.controllers import backstepping

    return FmuSource(backstepping.build(), {})


def _bdot() -> FmuSource:
    from satfmu.controllers import magnetic

    return FmuSource(magnetic.build_bdot(), {})


def _estimator() -> FmuSource:
    from satfmu.controllers import estimator

    return FmuSource(estimator.build(), {})


def _signal(kind: str) -> FmuSource:
    from satfmu.fmus import signals

    return FmuSource(signals.GENERIC[kind](), {}, ("native", "fmi3"))


PLANTS: dict[str, Callable[[], FmuSource]] = {
    "mrp_satellite": _plant("satfmu.fmus.plants.mrp_satellite"),
    "vscmg": _plant("satfmu.fmus.plants.vscmg"),
    "magnetorquer_cubesat": _plant("satfmu.fmus.plants.cubesat"),
    "demeter_flexible": _plant("satfmu.fmus.plants.demeter"),
    "mrp_satellite_rw3": functools.partial(_wheel_plant, 3), "mrp_satellite_rw4": functools.partial(_wheel_plant, 4),
    "orbit_environment": _plant("satfmu.fmus.environment.orbit")}
"""Plant model name -> its source (built on call); the orbit and environment model among them."""
SENSORS: dict[str, Callable[[], FmuSource]] = {
    name: _plant(f"satfmu.fmus.sensors.{name}", COSIMULATION_BACKENDS)
    for name in ("star_tracker", "rate_gyro", "magnetometer", "knowledge_error")}
"""Sensor model name -> its source (:mod:`satfmu.fmus.sensors`; ``knowledge_error`` the diagnostic of an
estimate against the truth)."""
SIGNALS = ("signal_constant", "signal_step", "signal_sinusoid", "signal_cosine_ramp")
"""Model names of the generic signal generators (:data:`satfmu.fmus.signals.GENERIC`, ``signal_<kind>``)."""
GENERIC: dict[str, Callable[[], FmuSource]] = {
    "vscmg_sdre_online": functools.partial(_online_sdre, "vscmg_sdre_online"),
    "vscmg_sdre_online_w1free": functools.partial(_online_sdre, "vscmg_sdre_online_w1free"),
    "mrp_sdre_online": functools.partial(_online_sdre, "mrp_sdre_online"),
    "vscmg_backstepping": _backstepping, "cubesat_bdot": _bdot, "attitude_mekf": _estimator,
    **{name: functools.partial(_signal, name.removeprefix("signal_")) for name in SIGNALS}}
"""Model name -> source of the designs without an artifact (online SDRE, backstepping, B-dot), of the
attitude estimator (:mod:`satfmu.controllers.estimator`) and of the generic signal generators (native
only: a scenario's profiles as FMUs)."""


def sources() -> list[FmuSource]:
    """Plants and sensors first, then the controllers of the shipped artifacts (the DEMETER state feedback
    of Table 1 row 1 among them, every gain a parameter), then :data:`GENERIC`."""
    from satfmu.controllers import polynomial

    out = [make() for make in (*PLANTS.values(), *SENSORS.values())]
    out += [artifact_source(path) for path in polynomial.shipped_artifacts()]
    return out + [make() for make in GENERIC.values()]


def source(name: str) -> FmuSource:
    """The source of one model by name, building only that model.

    Parameters
    ----------
    name : str
        A plant, sensor or generic model name (:data:`PLANTS`, :data:`SENSORS`, :data:`GENERIC`),
        the flexible plant of a user's spacecraft that a design artifact was made for (:func:`flexible_plant`), or the
        name of a controller artifact, looked up by :func:`satfmu.controllers.paths.find_artifact`
        (the user's artifacts first, then the shipped ones).

    Raises
    ------
    ValueError
        If no model or artifact has that name (the message suggests the closest name).
    """
    make = PLANTS.get(name) or SENSORS.get(name) or GENERIC.get(name)
    if make is not None:
        return make()
    flexible = flexible_plant(name)
    if flexible is not None:
        return flexible
    try:
        path = paths.find_artifact(name)
    except FileNotFoundError:
        models = sorted({*PLANTS, *SENSORS, *GENERIC})
        raise ValueError(f"no model or artifact named {name!r} (models: {', '.join(models)}; artifacts in "
                         f"{', '.join(map(str, paths.artifact_folders()))})"
                         + paths.did_you_mean(name, models + paths.artifact_names())) from None
    return artifact_source(path)


def flexible_plant(name: str) -> FmuSource | None:
    """The flexible plant ``flexible_<spacecraft>`` of a user's spacecraft, from the design
    artifacts made for it (the spacecraft's description is their ``design.variant.spacecraft``),
    or None if the name is not of that form or no artifact was made for such a plant.

    Parameters
    ----------
    name : str
        A model name (:func:`satfmu.fmus.plants.demeter.model_name`).

    Raises
    ------
    ValueError
        If artifacts made for that plant describe different spacecraft (two files, one name).
    """
    from satfmu.controllers import artifact as artifacts
    from satfmu.controllers import state_feedback
    from satfmu.fmus.plants import demeter

    if not name.startswith("flexible_"):
        return None
    found: dict[object, Path] = {}
    for folder in paths.artifact_folders():
        for path in sorted(folder.glob("*.json")) if folder.is_dir() else []:
            if path.name.startswith("."):
                continue
            try:
                art = artifacts.load(path)
            except artifacts.ArtifactError:
                continue  # not this function's to report: a run names the broken artifact it uses
            if not isinstance(art, artifacts.GainArtifact) or art.plant != name or not art.design:
                continue
            try:
                spacecraft = state_feedback.design_spacecraft(art.design)
            except ValueError:
                continue
            if demeter.model_name(spacecraft) == name:
                found.setdefault(spacecraft, path)
    if len(found) > 1:
        raise ValueError(f"{name}: the design artifacts {', '.join(map(str, found.values()))} describe different "
                         "spacecraft of that name; rename one (its description's name) or remove it")
    return next((FmuSource(demeter.model(sc), {}) for sc in found), None)


def ensure(fmu_dir: Path, names: Iterable[str], backend: str = "native", rebuild_stale: bool = False
           ) -> dict[str, Path]:
    """The FMU of each model name in ``fmu_dir``, building only those missing there.

    An FMU already in the folder is taken as it is (``satfmu build --fmu-dir DIR`` rebuilds
    the stale ones), unless ``rebuild_stale``: then it is rebuilt when its build digest
    differs from its model's (a changed artifact, say); a missing one is built from
    :func:`source` into the folder.

    Parameters
    ----------
    fmu_dir : Path
        Folder of the FMUs (created when needed).
    names : iterable of str
        Model names (see :func:`source`).
    backend : {"native", "python", "fmi3"}
        FMU kind.
    rebuild_stale : bool
        Compare the build digest of FMUs present (costs building each model).

    Returns
    -------
    dict of str to Path
        Model name -> FMU file, in the order of ``names`` (duplicates once).

    Raises
    ------
    ValueError
        If a name is unknown, the backend is unknown, or the model has no FMU of that backend.
    """
    if backend not in paths.BACKENDS:
        raise ValueError(f"backend must be one of {sorted(paths.BACKENDS)}, got {backend!r}")
    out = {}
    for name in dict.fromkeys(names):
        path = Path(fmu_dir) / f"{name}{paths.BACKENDS[backend]}.fmu"
        if rebuild_stale or not path.is_file():
            src = source(name)
            if backend not in src.backends:
                raise ValueError(f"{name} has no {backend} FMU (it has: {', '.join(src.backends)})")
            path = builder(backend)(src.model, Path(fmu_dir), src.resources)
        out[name] = path
    return out


def artifact_source(path: Path) -> FmuSource:
    """The controller of the artifact file ``path``: its FMUs embed the file's own bytes as
    ``resources/artifact.json`` and record their SHA-256 (:func:`satfmu.fmus.build_record.artifact_digest`),
    which a run compares with the file (:mod:`satfmu.sims.cosim.preflight`).

    Parameters
    ----------
    path : Path
        The artifact file (JSON).

    Raises
    ------
    satfmu.controllers.artifact.ArtifactError
        If the file is missing, not JSON, or not a valid artifact.
    """
    from satfmu.controllers import artifact as artifacts

    path = Path(path)
    # the bytes first: a file replaced before it is loaded leaves a recorded digest that is not
    # the file's, and the next run rebuilds the FMU (a missing file: load's error)
    data = path.read_bytes() if path.is_file() else None
    return controller_source(artifacts.load(path), data)


def controller_source(art: Artifact, data: bytes | None = None) -> FmuSource:
    """The controller model of an artifact (by its kind) and the artifact as its resource
    (``data``, the bytes of its file, or its JSON form); the model's description (the FMU's)
    ends with the plant it was designed for.

    Parameters
    ----------
    art : satfmu.controllers.artifact.Artifact
        The artifact: a servo, periodic (magnetic), gain (state feedback) or polynomial one.
    data : bytes, optional
        The bytes of its file, embedded as ``resources/artifact.json``; None: the artifact's
        JSON form.
    """
    from satfmu.controllers import artifact as artifacts
    from satfmu.controllers import magnetic, polynomial, servo, state_feedback

    if isinstance(art, artifacts.ServoArtifact):
        model = servo.build(art)
    elif isinstance(art, artifacts.PeriodicArtifact):
        model = magnetic.build_periodic(art)
    elif isinstance(art, artifacts.GainArtifact):
        n_flex = len(state_feedback.design_spacecraft(art.design).modes) if art.design else None
        model = state_feedback.build(art.gains, name=art.name, description=art.description,
                                     **({} if n_flex is None else {"n_flex": n_flex}))
    else:
        model = polynomial.build(art)
    record = art.provenance.get("design_plant")
    if record is not None:
        values = ", ".join(f"{k} = {v:g}" for k, v in list(record["parameters"].items())[:8])
        more = "" if len(record["parameters"]) <= 8 else f" and {len(record['parameters']) - 8} more"
        model.description = (f"{model.description}. Designed for {record['model']} ({values}{more}; "
                             f"resources/artifact.json: provenance.design_plant)")
    return FmuSource(model, artifacts.resource(art) if data is None else {"artifact.json": data})


def builder(backend: str) -> Callable[..., Path]:
    """``satfmu.fmus.export.build_native``, ``build_python``, ``build_fmi3``, ``build_me`` or ``build_me3``.

    Parameters
    ----------
    backend : {"native", "python", "fmi3", "me", "me3"}
        The FMU backend.

    Returns
    -------
    callable
        ``build(model, dest, resources)``, returning the FMU file.
    """
    from satfmu.fmus import export

    return {"native": export.build_native, "python": export.build_python, "fmi3": export.build_fmi3,
            "me": export.build_me, "me3": export.build_me3}[backend]


_PENDING: list[tuple[FmuSource, str]] = []
"""The builds the worker processes of :func:`build_all` take by index (inherited on fork)."""


@dataclass(frozen=True)
class BuildResult:
    """What :func:`build_all` did.

    Attributes
    ----------
    paths : list of Path
        Every FMU of the catalog, in catalog order.
    built : list of Path
        The FMUs built by this call (the others already recorded their build's digest).
    """

    paths: list[Path]
    """Every FMU of the catalog, in catalog order."""
    built: list[Path]
    """The FMUs built by this call (the others already recorded their build's digest)."""


def _build_one(index: int, dest: Path) -> Path:
    src, backend = _PENDING[index]
    return builder(backend)(src.model, dest, src.resources)


def _fork_map(fn: Callable[[T], R], items: list[T], jobs: int | None) -> list[R]:
    """``[fn(x) for x in items]`` in ``jobs`` forked worker processes (default: one per CPU);
    in this process for one job or on a platform without ``fork``."""
    jobs = min(jobs or os.cpu_count() or 1, len(items))
    if jobs <= 1 or "fork" not in multiprocessing.get_all_start_methods():
        return [fn(x) for x in items]
    with ProcessPoolExecutor(jobs, mp_context=multiprocessing.get_context("fork")) as pool:
        return list(pool.map(fn, items))


def build_all(dest: Path | None = None, backends: tuple[str, ...] = ALL_BACKENDS,
              jobs: int | None = None) -> BuildResult:
    """Build every FMU into ``dest``, in parallel processes.

    An FMU whose file already records its build's digest is not rebuilt
    (:func:`satfmu.fmus.build_record.built_digest`), so a second call on unchanged models only reads digests.

    Parameters
    ----------
    dest : Path, optional
        Folder of the FMUs (default: :func:`satfmu.controllers.paths.fmu_cache`).
    backends : tuple of {"native", "python", "fmi3", "me", "me3"}, optional
        The FMU backends to build (default all; a model without one is skipped for it).
    jobs : int, optional
        Worker processes (default: the number of CPUs); 1, or a platform without ``fork``,
        builds in this process.
    """
    from satfmu.fmus import build_record, export

    dest = paths.fmu_cache() if dest is None else Path(dest)
    plan = [(src, b) for src in sources() for b in ALL_BACKENDS if b in backends and b in src.backends]
    files = [export.fmu_path(src.model, dest, b) for src, b in plan]
    todo = [i for i, ((src, b), path) in enumerate(zip(plan, files))
            if build_record.built_digest(path) != export.digest_of(src.model, b, src.resources)]
    _PENDING[:] = plan  # the workers, forked from here, read it by index
    try:
        _fork_map(functools.partial(_build_one, dest=dest), todo, jobs)
    finally:
        _PENDING.clear()
    return BuildResult(files, [files[i] for i in todo])


def validate(fmu: Path) -> list[str]:
    """Problems reported by ``fmpy validate`` and ``fmutool -check`` (empty list: clean); a file
    that :func:`satfmu.fmus.archive.check` refuses is not handed to either (its one problem is why).

    Parameters
    ----------
    fmu : Path
        The FMU file.

    Returns
    -------
    list of str
        One line per problem, prefixed with the tool that reported it.
    """
    from fmpy.validation import validate_fmu

    from satfmu.fmus import archive

    try:
        archive.check(fmu, crc=True)
    except (OSError, archive.UnsafeFmuError) as exc:
        return [f"satfmu: {exc}"]
    problems = [f"fmpy: {p}" for p in validate_fmu(str(fmu))]
    tool = Path(sys.executable).with_name("fmutool")
    proc = subprocess.run([str(tool), "-input", str(fmu), "-check"], capture_output=True, text=True)
    text = proc.stdout + proc.stderr
    if proc.returncode != 0:
        problems.append(f"fmutool: exit code {proc.returncode}: {text.strip()[-500:]}")
    for line in text.splitlines():
        if ("ERROR" in line or "WARNING" in line) and "Modified FMU is not saved" not in line:
            problems.append(f"fmutool: {line.strip()}")
    if "No semantic error" not in text:
        problems.append("fmutool: semantic check did not report 'No semantic error'")
    return problems


def validate_all(fmus: list[Path], jobs: int | None = None) -> list[list[str]]:
    """:func:`validate` of each FMU, in parallel processes (default: one per CPU); the problems
    in the order of ``fmus``.

    Parameters
    ----------
    fmus : list of Path
        The FMU files.
    jobs : int, optional
        Worker processes (default: the number of CPUs); 1, or a platform without ``fork``,
        validates in this process.

    Returns
    -------
    list of list of str
        The problems of each FMU (:func:`validate`).
    """
    return _fork_map(validate, list(fmus), jobs)
