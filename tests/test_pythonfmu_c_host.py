"""A pythonfmu FMU in a host without Python: the C host of ``tests/host/fmu_host.c``.

The host loads ``binaries/linux64/<model>_py.so`` (satfmu's C layer, ``fmus/c/pythonfmu_shim.c``),
which loads pythonfmu's library beside it; pythonfmu starts its own interpreter. pythonfmu 0.7.0's
library does not link libpython, so a host without Python preloads it (as pythonfmu's README says):
the test finds this Python's shared library with ``sysconfig`` and is skipped on a static build.
"""
from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path

import pytest
import pythonfmu
from fmpy import read_model_description

from satfmu.fmus import export
from tests.test_win64 import compile_host, read_rows, run_fmpy, write_plan

MODEL = "mrp_satellite_py"


def _libpython() -> Path | None:
    """This Python's shared library, or None (a static build)."""
    name = sysconfig.get_config_var("INSTSONAME") or ""
    path = Path(sysconfig.get_config_var("LIBDIR") or "", name)
    return path if ".so" in name and path.is_file() else None


pytestmark = pytest.mark.skipif(_libpython() is None, reason="this Python has no shared libpython to preload")


@pytest.fixture(scope="module")
def setup(fmu_dir: Path, tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, dict[str, str]]:
    """The compiled host, the extracted FMU (with its plan) and the host's environment."""
    root = tmp_path_factory.mktemp("c_host")
    host = compile_host("gcc", root / "fmu_host", ("-ldl",))
    folder = root / MODEL
    with zipfile.ZipFile(fmu_dir / f"{MODEL}.fmu") as z:
        z.extractall(folder)
    write_plan(read_model_description(str(folder)), (folder / "resources").as_uri(), folder / "plan.txt")
    env = {"PATH": os.environ.get("PATH", "/usr/bin:/bin"), "TMPDIR": str(root), "LD_PRELOAD": str(_libpython()),
           "PYTHONHOME": sys.base_prefix, "PYTHONPATH": str(Path(pythonfmu.__file__).parents[1])}
    return host, folder, env


def _run(setup: tuple[Path, Path, dict[str, str]], library: str, wrapper: tuple[str, ...] = ()
         ) -> subprocess.CompletedProcess:
    host, folder, env = setup
    return subprocess.run([*wrapper, str(host), str(folder / "binaries" / "linux64" / library),
                           str(folder / "plan.txt")],
                          capture_output=True, text=True, env=env, timeout=300)


def test_c_host_gives_fmpys_outputs(setup: tuple[Path, Path, dict[str, str]]) -> None:
    """The host's rows equal fmpy's (in this Python) bit for bit: the same slave computes both, and
    the process exits with 0 (~1 s: pythonfmu starts an interpreter)."""
    proc = _run(setup, f"{MODEL}.so")
    assert proc.returncode == 0, f"the C host failed ({proc.returncode}):\n{proc.stderr[-2000:]}"
    assert read_rows(proc.stdout) == run_fmpy(setup[1])


def test_without_libpython_preloaded_the_load_fails_as_the_readme_says(
        setup: tuple[Path, Path, dict[str, str]]) -> None:
    """The README's FMU section names the requirement, the error a user sees without it and the
    command that preloads libpython; the command's Python part gives this Python's library."""
    host, folder, env = setup
    bare = {k: v for k, v in env.items() if k != "LD_PRELOAD"}
    proc = subprocess.run([str(host), str(folder / "binaries" / "linux64" / f"{MODEL}.so"), str(folder / "plan.txt")],
                          capture_output=True, text=True, env=bare, timeout=300)
    assert proc.returncode != 0 and "_Py_NoneStruct" in proc.stdout + proc.stderr
    readme = (Path(__file__).resolve().parents[1] / "README.md").read_text()
    section = readme[readme.index("## Using the FMUs in your tool"):readme.index("## Repository layout")]
    assert "_Py_NoneStruct" in section and 'needsExecutionTool="true"' in section
    code = re.search(r'LD_PRELOAD=\$\(python3 -c "([^"]+)"\) fmusim NAME_py\.fmu', section)
    assert code, "the README's preload command"
    out = subprocess.run([sys.executable, "-c", code[1]], capture_output=True, text=True, check=True).stdout.strip()
    assert Path(out) == _libpython()


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("valgrind") is None, reason="valgrind is not installed")
def test_c_host_exits_cleanly_through_satfmus_layer_only(setup: tuple[Path, Path, dict[str, str]]) -> None:
    """Under valgrind (~10 s each): the host that loads pythonfmu's library directly reads the
    freed interpreter holder at exit (pythonfmu 0.7.0's double release, unguarded in a host without
    Python before satfmu's C layer); through the C layer, valgrind finds no error."""
    wrapper = ("valgrind", "--error-exitcode=99")
    alone = _run(setup, f"{MODEL}{export.PYTHONFMU_LIBRARY_SUFFIX}.so", wrapper)
    reads = re.findall(r"Invalid read of size \d+\n==\d+== +at 0x[0-9A-F]+: finalizePythonInterpreter", alone.stderr)
    assert reads, f"pythonfmu's library alone: no invalid read at exit (pythonfmu changed?):\n{alone.stderr[-1500:]}"
    guarded = _run(setup, f"{MODEL}.so", wrapper)
    assert guarded.returncode == 0 and "ERROR SUMMARY: 0 errors" in guarded.stderr, guarded.stderr[-2000:]


ONLINE_SDRE = "vscmg_sdre_online_py"
"""The pythonfmu FMU whose sampler calls scipy (its Riccati solve, LAPACK and scipy's libgfortran)."""


def test_a_python_online_sdre_run_exits_cleanly(fmu_dir: Path, tmp_path: Path) -> None:
    """Issue 58 item 4: the FMI Compliance Checker was seen aborting at exit after a complete run of
    this FMU (``free(): corrupted unsorted chunks`` in scipy's libgfortran). Not reproduced since
    (the checker built from its sources with FMIL 2.0.3: 4 runs, exit 0; docs/pythonfmu.md), this
    guards it in our host: its 60 steps in the embedded interpreter (satfmu importable there, as in
    a user's Python), glibc's heap checks on (MALLOC_CHECK_=3 aborts at the first inconsistency),
    the process exits with 0 and no allocator message, and the rows are fmpy's bit for bit."""
    host = compile_host("gcc", tmp_path / "fmu_host", ("-ldl",))
    folder = tmp_path / ONLINE_SDRE
    with zipfile.ZipFile(fmu_dir / f"{ONLINE_SDRE}.fmu") as z:
        z.extractall(folder)
    write_plan(read_model_description(str(folder)), (folder / "resources").as_uri(), folder / "plan.txt")
    site_dir = tmp_path / "site"  # the embedded interpreter's path to this environment's packages
    site_dir.mkdir()
    packages = [p for p in sys.path if p.endswith("site-packages")]
    (site_dir / "sitecustomize.py").write_text("import site\n" + "".join(f"site.addsitedir({p!r})\n" for p in packages))
    env = {"PATH": os.environ.get("PATH", "/usr/bin:/bin"), "TMPDIR": str(tmp_path), "LD_PRELOAD": str(_libpython()),
           "PYTHONHOME": sys.base_prefix, "PYTHONPATH": f"{site_dir}:{Path(pythonfmu.__file__).parents[1]}",
           "MALLOC_CHECK_": "3"}
    proc = subprocess.run([str(host), str(folder / "binaries" / "linux64" / f"{ONLINE_SDRE}.so"),
                           str(folder / "plan.txt")], capture_output=True, text=True, env=env, timeout=600)
    assert proc.returncode == 0, f"exit {proc.returncode}:\n{proc.stderr[-2000:]}"
    assert not re.search(r"free\(\)|corrupted|double free|malloc\(\)", proc.stderr), proc.stderr[-2000:]
    assert read_rows(proc.stdout) == run_fmpy(folder)
