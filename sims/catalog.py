"""Every FMU the project builds: the plant models and one controller per shipped artifact."""
from __future__ import annotations

import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

from controllers import artifact as artifacts
from controllers import backstepping, magnetic, polynomial, servo, state_feedback
from fmus import cubesat, demeter, export, mrp_satellite, signals, vscmg
from fmus.model import Model

DEFAULT_FMU_DIR = Path("build/fmus")


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


def build_all(dest: Path = DEFAULT_FMU_DIR, backends: tuple[str, ...] = ("native", "python")) -> list[Path]:
    """Build every FMU into ``dest``; returns the FMU paths."""
    built = []
    for src in sources():
        if "native" in backends and "native" in src.backends:
            built.append(export.build_native(src.model, dest, src.resources))
        if "python" in backends and "python" in src.backends:
            built.append(export.build_python(src.model, dest, src.resources))
    return built


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
