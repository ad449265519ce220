"""An importer rebuilds a native FMU from its sources/ (``fmpy compile``: fmpy's CMake, which links
no libm) and gets the FMU's outputs.

The glibc floor of satfmu's own Linux build binds pow, exp and log to their GLIBC_2.2.5 versions
(fmus/c/satfmu_core.h); without libm on the link line those versioned references did not link
(``no symbol version section for versioned symbol 'exp@GLIBC_2.2.5'``, vscmg_sdre_online and
vscmg_sdre_online_w1free). The floor is now satfmu's build's alone (``SATFMU_GLIBC_FLOOR``). The
FMI 3.0 FMUs rebuild from their ``sources/buildDescription.xml`` (the model-exchange ones with the
headers they include beside it).
"""
from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu

STOP = 0.5
"""s: a few dozen steps at each FMU's default step."""


def _outputs(fmu: Path) -> np.ndarray:
    md = read_model_description(str(fmu))
    step = md.defaultExperiment.stepSize if md.defaultExperiment and md.defaultExperiment.stepSize else 0.01
    names = [v.name for v in md.modelVariables if v.causality == "output" and v.type in ("Real", "Float64")]
    res = simulate_fmu(str(fmu), stop_time=STOP, output_interval=float(step), output=names)
    return np.column_stack([res[n] for n in names])


def _rebuilt(fmu: Path, tmp_path: Path) -> Path:
    """``fmpy compile`` of a copy, as a user types it: the binary rebuilt from sources/ replaces the
    shipped one inside the FMU."""
    copy = tmp_path / fmu.name
    shutil.copy(fmu, copy)
    proc = subprocess.run([str(Path(sys.executable).parent / "fmpy"), "compile", str(copy)], capture_output=True,
                          text=True)
    assert proc.returncode == 0, f"fmpy compile {fmu.name} failed:\n{proc.stdout[-2000:]}{proc.stderr[-2000:]}"
    return copy


def _check(fmu: Path, tmp_path: Path) -> None:
    shipped, rebuilt = _outputs(fmu), _outputs(_rebuilt(fmu, tmp_path))
    # fmpy's CMake compiles with other optimization flags: the same arithmetic up to rounding
    # (measured identical on these FMUs; 1e-12 of the largest output bounds a reordering)
    scale = max(1.0, float(np.nanmax(np.abs(shipped))))
    assert np.allclose(rebuilt, shipped, rtol=0.0, atol=1e-12 * scale, equal_nan=True), fmu.name


@pytest.mark.parametrize("name", ["vscmg_sdre_online", "vscmg_sdre_online_w1free", "mrp_satellite",
                                  "vscmg_sdre_online_fmi3", "mrp_satellite_rw3_me_fmi3"])
def test_fmpy_compile_rebuilds_the_fmus_that_call_exp_and_pow(name: str, fmu_dir: Path, tmp_path: Path) -> None:
    _check(fmu_dir / f"{name}.fmu", tmp_path)


@pytest.mark.slow
def test_fmpy_compile_rebuilds_every_native_fmu(fmu_dir: Path, tmp_path: Path) -> None:
    native = sorted(p for p in fmu_dir.glob("*.fmu") if not p.stem.endswith("_py"))
    assert len(native) >= 20
    for fmu in native:
        folder = tmp_path / fmu.stem
        folder.mkdir()
        _check(fmu, folder)
