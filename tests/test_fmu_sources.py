"""An FMU's ``sources/`` rebuilt the ways an importing tool does (issue 28, defect 3).

A tool without Python rebuilds a native FMU for its platform from ``sources/``: some compile
every ``.c`` file there, one by one, and link the objects; others (fmpy, FMI tools honouring the
model description) compile the files ``<SourceFiles>`` lists. Both must work: every ``.c`` file an
FMU ships compiles on its own, with the build's warnings-as-errors flags
(:data:`satfmu.fmus.export.C_FLAGS`), and the library linked from them gives the shipped binary's
outputs bit for bit (same compiler, same flags).
"""
from __future__ import annotations

import math
import shutil
import subprocess
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import pytest
from fmpy import read_model_description
from fmpy.fmi2 import FMU2Slave

from satfmu.fmus import export
from satfmu.sims.cosim import fmi_host

MODELS = ("mrp_satellite", "mrp_hinf_published", "signal_sinusoid")
"""A plant (RK4), a controller (an expression sampler, integer powers) and a signal generator."""
STEPS = 40
"""Communication steps of the comparison run, each the FMU's default step."""
DRIVE = 0.1
"""Relative amplitude of the inputs' variation (each input's start value, or 1, times this)."""


def _unzip(fmu: Path, dest: Path) -> Path:
    """Extract ``fmu`` into ``dest`` (created) and return it."""
    with zipfile.ZipFile(fmu) as z:
        z.extractall(dest)
    return dest


def _declared_sources(unzipped: Path) -> list[str]:
    """The file names ``<CoSimulation><SourceFiles>`` of the FMU's model description lists."""
    root = ET.parse(unzipped / "modelDescription.xml").getroot()
    return [f.attrib["name"] for f in root.iterfind("CoSimulation/SourceFiles/File")]


def _rebuild(unzipped: Path, sources: list[Path]) -> None:
    """Compile each of ``sources`` on its own (``gcc -c``, the build's flags, ``sources/`` and the
    FMI headers on the include path), link the objects into the FMU's linux64 library in
    ``unzipped`` (replacing the shipped one) and fail the test with gcc's message on an error."""
    src = unzipped / "sources"
    objects = []
    for c_file in sources:
        obj = unzipped / f"{c_file.stem}.o"
        proc = subprocess.run(["gcc", *export.C_FLAGS, f"-I{export.fmi_headers()}", f"-I{src}", "-c",
                               str(c_file), "-o", str(obj)], capture_output=True, text=True)
        assert proc.returncode == 0, f"{c_file.name} does not compile on its own:\n{proc.stderr}"
        objects.append(str(obj))
    (library,) = (unzipped / "binaries" / "linux64").glob("*.so")
    library.unlink()
    proc = subprocess.run(["gcc", "-shared", "-o", str(library), *objects, "-lm"], capture_output=True, text=True)
    assert proc.returncode == 0, f"linking {', '.join(s.name for s in sources)} failed:\n{proc.stderr}"


def _run(unzipped: Path) -> list[list[float]]:
    """Every Real output at every point of a :data:`STEPS`-step run at the default step, every
    Real input driven around its start value (within its declared range)."""
    md = read_model_description(str(unzipped))
    slave = FMU2Slave(guid=md.guid, unzipDirectory=str(unzipped),
                      modelIdentifier=md.coSimulation.modelIdentifier, instanceName="sources")
    callbacks = fmi_host.Callbacks()
    slave.instantiate(callbacks=callbacks.functions, loggingOn=True)
    inputs = [v for v in md.modelVariables if v.causality == "input" and v.type == "Real"]
    outputs = [v.valueReference for v in md.modelVariables if v.causality == "output" and v.type == "Real"]
    h = float(md.defaultExperiment.stepSize)
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    slave.exitInitializationMode()
    rows = []
    for k in range(STEPS):
        values = []
        for i, v in enumerate(inputs):
            start = float(v.start or 0.0)
            value = start + DRIVE * (abs(start) or 1.0) * math.sin(0.7 * k + i)
            values.append(min(max(value, float(v.min) if v.min is not None else -math.inf),
                              float(v.max) if v.max is not None else math.inf))
        if inputs:
            slave.setReal([v.valueReference for v in inputs], values)
        rows.append(slave.getReal(outputs))
        status, _ = fmi_host.attempt(slave, "doStep", k * h, h)
        assert status == fmi_host.OK, f"{md.modelName}: step {k} refused: {callbacks.text()}"
    rows.append(slave.getReal(outputs))
    slave.terminate()
    slave.freeInstance()
    return rows


@pytest.fixture(scope="module")
def shipped(fmu_dir: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, tuple[Path, list[list[float]]]]:
    """Per model of :data:`MODELS`: the FMU extracted, and the outputs of its shipped binary."""
    out = {}
    for model in MODELS:
        unzipped = _unzip(fmu_dir / f"{model}.fmu", tmp_path_factory.mktemp(f"{model}_shipped"))
        out[model] = (unzipped, _run(unzipped))
    return out


@pytest.mark.parametrize("model", MODELS)
def test_source_files_lists_every_c_file(shipped: dict, model: str) -> None:
    """``<SourceFiles>`` names exactly the ``.c`` files under ``sources/``: the two ways of
    rebuilding compile the same files, and every file listed is there."""
    unzipped, _ = shipped[model]
    declared = _declared_sources(unzipped)
    c_files = sorted(str(p.relative_to(unzipped / "sources")) for p in (unzipped / "sources").rglob("*.c"))
    assert declared, "the model description lists no source file: fmpy compile has nothing to build"
    assert sorted(declared) == c_files, (f"<SourceFiles> lists {declared} but sources/ holds the .c files "
                                         f"{c_files}: a tool compiling every .c file builds something else")


@pytest.mark.parametrize("way", ["every .c file", "SourceFiles"])
@pytest.mark.parametrize("model", MODELS)
def test_sources_rebuild_gives_shipped_outputs(shipped: dict, model: str, way: str,
                                               tmp_path: Path) -> None:
    """Compiling each ``.c`` file under ``sources/`` (or each file ``<SourceFiles>`` lists) on its
    own and linking the objects gives a library whose outputs equal the shipped binary's bit for
    bit on a driven run."""
    unzipped_shipped, expected = shipped[model]
    unzipped = tmp_path / "fmu"
    shutil.copytree(unzipped_shipped, unzipped)
    src = unzipped / "sources"
    if way == "every .c file":
        sources = sorted(src.rglob("*.c"))
    else:
        sources = [src / name for name in _declared_sources(unzipped)]
    assert sources, f"no source file to compile ({way})"
    _rebuild(unzipped, sources)
    rebuilt = _run(unzipped)
    assert any(y != 0.0 for row in expected for y in row), "the run drives no output: the comparison proves nothing"
    assert rebuilt == expected, (f"{model}: the library rebuilt from sources/ ({way}) gives other outputs "
                                 "than the shipped one")
