"""Every FMU the project builds: the plant models and one controller per shipped artifact."""
from __future__ import annotations

import functools
import multiprocessing
import os
import subprocess
import sys
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from typing import Callable, TypeVar
from pathlib import Path

from controllers import artifact as artifacts
from controllers import backstepping, magnetic, polynomial, servo, state_feedback
from fmus import cubesat, demeter, export, mrp_satellite, signals, vscmg
from fmus.model import Model

DEFAULT_FMU_DIR = Path("build/fmus")
T = TypeVar("T")
R = TypeVar("R")


@dataclass(frozen=True)
class FmuSource:
    """A model to export and the resources its FMUs carry."""

    model: Model
    resources: dict[str, bytes]
    backends: tuple[str, ...] = ("native", "python")
    """FMU backends the model supports (a model with a Python sampler: pythonfmu only)."""


def sources() -> list[FmuSource]:
    """Plants first, then the controllers of the shipped artifacts (the DEMETER state feedback
    of Table 1 row 1 among them, every gain a parameter), then the designs without an artifact
    (online SDRE, backstepping, B-dot), then the generic signal generators (native only: a
    scenario's profiles as FMUs, :mod:`fmus.signals`)."""
    out = [FmuSource(mrp_satellite.MODEL, {}), FmuSource(vscmg.MODEL, {}), FmuSource(cubesat.MODEL, {}),
           FmuSource(demeter.MODEL, {})]
    out += [controller_source(artifacts.load(path)) for path in polynomial.shipped_artifacts()]
    out += [FmuSource(servo.build_online(name), {}, ("python",)) for name in servo.ONLINE_VARIANTS]
    out += [FmuSource(backstepping.build(), {}), FmuSource(magnetic.build_bdot(), {})]
    return out + [FmuSource(build(), {}, ("native",)) for build in signals.GENERIC.values()]


def controller_source(art: artifacts.Artifact) -> FmuSource:
    """The controller model of an artifact (by its kind) and the artifact as its resource."""
    if isinstance(art, artifacts.ServoArtifact):
        model = servo.build(art)
    elif isinstance(art, artifacts.PeriodicArtifact):
        model = magnetic.build_periodic(art)
    elif isinstance(art, artifacts.GainArtifact):
        model = state_feedback.build(art.gains, name=art.name, description=art.description)
    else:
        model = polynomial.build(art)
    return FmuSource(model, artifacts.resource(art))


_BUILDERS = {"native": export.build_native, "python": export.build_python}
_PENDING: list[tuple[FmuSource, str]] = []
"""The builds the worker processes of :func:`build_all` take by index (inherited on fork)."""


@dataclass(frozen=True)
class BuildReport:
    """What :func:`build_all` did."""

    paths: list[Path]
    """Every FMU of the catalog, in catalog order."""
    built: list[Path]
    """The FMUs built by this call (the others already recorded their build's digest)."""


def _build_one(index: int, dest: Path) -> Path:
    src, backend = _PENDING[index]
    return _BUILDERS[backend](src.model, dest, src.resources)


def _fork_map(fn: Callable[[T], R], items: list[T], jobs: int | None) -> list[R]:
    """``[fn(x) for x in items]`` in ``jobs`` forked worker processes (default: one per CPU);
    in this process for one job or on a platform without ``fork``."""
    jobs = min(jobs or os.cpu_count() or 1, len(items))
    if jobs <= 1 or "fork" not in multiprocessing.get_all_start_methods():
        return [fn(x) for x in items]
    with ProcessPoolExecutor(jobs, mp_context=multiprocessing.get_context("fork")) as pool:
        return list(pool.map(fn, items))


def build_all(dest: Path = DEFAULT_FMU_DIR, backends: tuple[str, ...] = ("native", "python"),
              jobs: int | None = None) -> BuildReport:
    """Build every FMU into ``dest``, in parallel processes.

    An FMU whose file already records its build's digest is not rebuilt
    (:func:`fmus.export.built_digest`), so a second call on unchanged models only reads digests.

    Parameters
    ----------
    dest : Path
        Folder of the FMUs.
    backends : tuple of {"native", "python"}
    jobs : int, optional
        Worker processes (default: the number of CPUs); 1, or a platform without ``fork``,
        builds in this process.
    """
    plan = [(src, b) for src in sources() for b in ("native", "python") if b in backends and b in src.backends]
    paths = [export.fmu_path(src.model, dest, b) for src, b in plan]
    todo = [i for i, ((src, b), path) in enumerate(zip(plan, paths))
            if export.built_digest(path) != export.digest_of(src.model, b, src.resources)]
    _PENDING[:] = plan  # the workers, forked from here, read it by index
    try:
        _fork_map(functools.partial(_build_one, dest=Path(dest)), todo, jobs)
    finally:
        _PENDING.clear()
    return BuildReport(paths, [paths[i] for i in todo])


def validate(fmu: Path) -> list[str]:
    """Problems reported by ``fmpy validate`` and ``fmutool -check`` (empty list: clean)."""
    from fmpy.validation import validate_fmu

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
    in the order of ``fmus``."""
    return _fork_map(validate, list(fmus), jobs)
