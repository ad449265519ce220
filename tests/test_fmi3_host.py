"""Every native FMI 3.0 FMU in satfmu's own FMI 3.0 C host (``tests/host/fmu_host3.c``), against the
FMI 2.0 FMU of the same model in fmpy, run with the same plan (``tests/test_win64.py``: 60 default
steps, the seeds' parameters, sinusoidal inputs) in the same call order.

A model without a sampler, and a sampled one run without event mode, give the FMI 2.0 numbers bit
for bit. A sampled one run with its clock (event mode: the host activates it at each instant after
setting that step's inputs, and splits a step at an instant inside it) samples from the same
inputs as the FMI 2.0 FMU, which samples an instant inside a step from that step's inputs; where
the instants fall on communication points the numbers are the same bit for bit, and inside steps
the split step's two durations differ from the FMU's own in the last bits (stated per model).
"""
from __future__ import annotations

import subprocess
import zipfile
from pathlib import Path

import pytest
from fmpy import read_model_description

from satfmu.controllers import catalog
from satfmu.fmus import export
from satfmu.fmus.arrays import array_variables
from satfmu.fmus.description3 import clock_reference
from tests.test_win64 import HOST_FLAGS, PARAMETERS, plan_values, read_rows, run_fmpy

HOST3 = Path(__file__).resolve().parent / "host" / "fmu_host3.c"
NATIVE_MODELS = [src.model.name for src in catalog.sources() if "fmi3" in src.backends]
SAMPLED = [name for name in NATIVE_MODELS if catalog.source(name).model.sampler is not None]


@pytest.fixture(scope="module")
def host3(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("host3") / "fmu_host3"
    proc = subprocess.run(["gcc", *HOST_FLAGS, f"-I{export.fmi_headers()}", "-o", str(out), str(HOST3), "-ldl", "-lm"],
                          capture_output=True, text=True)
    assert proc.returncode == 0, f"gcc could not compile the FMI 3.0 host:\n{proc.stderr}"
    return out


def _plan3(name: str, folder2: Path, folder3: Path, clocked: bool) -> Path:
    """The FMI 2.0 plan of ``name`` (:func:`tests.test_win64.plan_values`) in FMI 3.0 terms: its
    parameters set as whole arrays, its Real inputs and outputs as the arrays holding them."""
    model = catalog.source(name).model
    md2 = read_model_description(str(folder2))
    _, inputs, outputs, rows = plan_values(md2)
    arrays = array_variables(model)
    of = {model.variables[a.first + j].name: (k + 1, j) for k, a in enumerate(arrays) for j in range(a.size)}
    values = {k + 1: [model.variables[a.first + j].start for j in range(a.size)] for k, a in enumerate(arrays)}
    kinds = {}
    for fmi2_name, value in PARAMETERS.get(name, {}).items():
        vr, j = of[fmi2_name]
        values[vr][j] = float(value)
        kinds[vr] = {"Real": "real", "Integer": "integer",
                     "Boolean": "boolean"}[model.variables[arrays[vr - 1].first].type]
    by_vr2 = {v.valueReference: v.name for v in md2.modelVariables}

    def groups(vrs2: list[int]) -> list[tuple[int, int]]:
        out: list[tuple[int, int]] = []
        for vr2 in vrs2:
            vr3, j = of[by_vr2[vr2]]
            if j == 0:
                out.append((vr3, arrays[vr3 - 1].size))
            assert out and out[-1][0] == vr3, f"{name}: an array's elements are not all Real inputs/outputs"
        return out

    ins, outs = groups(inputs), groups(outputs)
    assert sum(n for _, n in ins) == len(inputs) and sum(n for _, n in outs) == len(outputs)
    md3 = read_model_description(str(folder3))
    clock = clock_reference(model) if clocked else -1
    lines = [f"token {md3.guid}", f"resources {folder3 / 'resources'}/",
             f"step {float(md2.defaultExperiment.stepSize).hex()}", f"clock {clock}", f"parameters {len(kinds)}"]
    lines += [" ".join([kinds[vr], str(vr), str(len(values[vr])), *(float(v).hex() for v in values[vr])])
              for vr in kinds]
    lines += [" ".join(["inputs", str(len(ins)), *(f"{vr} {n}" for vr, n in ins)]),
              " ".join(["outputs", str(len(outs)), *(f"{vr} {n}" for vr, n in outs)]), f"steps {len(rows)}"]
    lines += [" ".join(float(u).hex() for u in row) for row in rows]
    path = folder3 / "plan3.txt"
    path.write_text("\n".join(lines) + "\n")
    return path


def _runs(name: str, fmu_dir: Path, tmp_path: Path, host3: Path, clocked: bool) -> tuple[list, list]:
    folders = {}
    for suffix in ("", "_fmi3"):
        folders[suffix] = tmp_path / f"{name}{suffix}"
        with zipfile.ZipFile(fmu_dir / f"{name}{suffix}.fmu") as z:
            z.extractall(folders[suffix])
    plan = _plan3(name, folders[""], folders["_fmi3"], clocked)
    binary = folders["_fmi3"] / "binaries" / "x86_64-linux" / f"{name}_fmi3.so"
    proc = subprocess.run([str(host3), str(binary), str(plan)], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, f"{name}: the FMI 3.0 host failed:\n{proc.stderr[-3000:]}"
    return read_rows(proc.stdout), run_fmpy(folders[""])


@pytest.mark.parametrize("name", NATIVE_MODELS)
def test_the_fmi3_host_gives_the_fmi2_numbers_without_event_mode(name: str, fmu_dir: Path, tmp_path: Path,
                                                                 host3: Path) -> None:
    """No event mode: the FMI 3.0 FMU in our C host equals the FMI 2.0 FMU in fmpy bit for bit."""
    rows3, rows2 = _runs(name, fmu_dir, tmp_path, host3, clocked=False)
    assert len(rows3) == len(rows2) == 61 and rows3 == rows2


@pytest.mark.parametrize("name", SAMPLED)
def test_the_fmi3_host_drives_the_sample_clock(name: str, fmu_dir: Path, tmp_path: Path, host3: Path) -> None:
    """Event mode, the clock activated at each instant by the host: the FMI 2.0 numbers bit for bit."""
    rows3, rows2 = _runs(name, fmu_dir, tmp_path, host3, clocked=True)
    assert len(rows3) == len(rows2) == 61 and rows3 == rows2
