"""The examples run as a user runs them: copied into a folder of their own, satfmu's folder
fresh (``SATFMU_HOME``), FMUs built on demand, the pytest plugin from its entry point."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


@pytest.fixture(scope="module")
def user(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, str]]:
    """A user's folder holding copies of the examples, and an environment with a fresh satfmu home."""
    root = tmp_path_factory.mktemp("user")
    work = root / "work"
    shutil.copytree(EXAMPLES, work, ignore=shutil.ignore_patterns("__pycache__"))
    env = {**os.environ, "SATFMU_HOME": str(root / "satfmu_home"), "OPENBLAS_NUM_THREADS": "1"}
    env.pop("SATFMU_FMU_DIR", None)
    return work, env


def _run(args: list[str], cwd: Path, env: dict[str, str]) -> subprocess.CompletedProcess:
    done = subprocess.run(args, cwd=cwd, env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, f"{args} failed ({done.returncode}):\n{done.stdout}\n{done.stderr}"
    return done


def test_own_scenario_in_python_writes_its_results(user):
    work, env = user
    out = _run([sys.executable, "own_scenario.py", "results"], work, env).stdout
    assert "PASS my_60deg_with_a_kick" in out and "my_120deg_with_a_wobble" in out
    for name in ("my_60deg_with_a_kick", "my_120deg_with_a_wobble"):
        assert (work / "results" / name / f"{name}_native.csv").is_file()
        assert (work / "results" / name / f"{name}_native.png").is_file()


def test_gate_of_your_own_passes(user):
    work, env = user
    out = _run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "test_my_gate.py"], work, env).stdout
    assert "2 passed" in out


def test_plain_fmpy_drives_one_fmu(user):
    work, env = user
    out = _run([sys.executable, "plain_fmpy.py"], work, env).stdout
    assert "largest difference" in out


def test_satfmu_run_works_from_any_folder(user, tmp_path):
    """A relative scenario path from another working directory; results land in that directory."""
    work, env = user
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    rel = os.path.relpath(work / "my_scenario.toml", elsewhere)
    out = _run([sys.executable, "-m", "satfmu.sims.cli", "run", rel], elsewhere, env).stdout
    assert "PASS my_60deg_with_a_kick" in out
