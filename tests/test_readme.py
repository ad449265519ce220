"""The README's code blocks run as written, in a user's folder (issue 56 item 4).

Each fenced block is taken from README.md as it stands: the TOML blocks are read as a scenario and
a spacecraft, the Python blocks run in order in one process, the pytest block runs under pytest
(the plugin from its entry point), and the walkthrough's ``fmpy simulate`` line runs in the shell.
"""
from __future__ import annotations

import os
import re
import shlex
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

import satfmu

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()
BLOCKS = re.findall(r"^```(\w+)\n(.*?)^```", README, flags=re.S | re.M)


def _blocks(language: str) -> list[str]:
    return [text for lang, text in BLOCKS if lang == language]


@pytest.fixture(scope="module")
def user(tmp_path_factory: pytest.TempPathFactory, fmu_dir: Path) -> tuple[Path, dict[str, str]]:
    """A folder holding ``examples/`` (the README's paths are relative to the checkout), a fresh satfmu
    home whose FMU cache holds the built FMUs (building them on demand is test_examples.py's)."""
    root = tmp_path_factory.mktemp("readme")
    work = root / "work"
    shutil.copytree(ROOT / "examples", work / "examples", ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copytree(fmu_dir, root / "home" / "fmus", ignore=shutil.ignore_patterns("signal_tables"))
    env = {**os.environ, "SATFMU_HOME": str(root / "home"), "OPENBLAS_NUM_THREADS": "1", "MPLBACKEND": "Agg"}
    env.pop("SATFMU_FMU_DIR", None)
    return work, env


def _run(args: list[str], work: Path, env: dict[str, str]) -> str:
    done = subprocess.run(args, cwd=work, env=env, capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, f"{args[:3]} failed ({done.returncode}):\n{done.stdout[-3000:]}\n{done.stderr[-3000:]}"
    return done.stdout


def test_the_readme_has_the_blocks_this_test_runs() -> None:
    # a block added, removed or relabelled must be looked at here, not skipped silently
    assert [lang for lang, _ in BLOCKS] == ["toml", "python", "python", "python", "toml", "python"]


def test_the_toml_blocks_are_a_valid_scenario_and_spacecraft(tmp_path: Path) -> None:
    scenario, spacecraft = _blocks("toml")
    sc = satfmu.Scenario.from_dict(tomllib.loads(scenario))  # shortened ("# ..."), but every key valid
    assert sc.metrics[0].unit == "deg" and sc.metrics[0].scale == 1.0
    (tmp_path / "my_sat.toml").write_text(spacecraft)
    sat = satfmu.Spacecraft.from_toml(tmp_path / "my_sat.toml")
    assert sat.torque_limit == 20.0


def _script(work: Path, name: str, blocks: list[str], checks: str) -> Path:
    """The blocks as written, then the checks of what they made."""
    path = work / name
    path.write_text("".join(blocks) + "\nfrom pathlib import Path\n" + checks + "\nprint('README blocks ran')\n")
    return path


def test_the_run_blocks_run_in_order(user: tuple[Path, dict[str, str]]) -> None:
    work, env = user
    run_block, scenario_block, _gate, _design = _blocks("python")
    script = _script(work, "readme_run.py", [run_block, scenario_block], """
from matplotlib.figure import Figure
assert isinstance(fig, Figure) and Path("run.png").is_file()
assert sorted(p.name for p in Path("out").glob("*.csv")) == ["my_60deg_with_a_kick_native.csv"]
assert result.passed, [(m.name, m.value) for m in result.metrics]
""")
    assert "README blocks ran" in _run([sys.executable, str(script)], work, env)


@pytest.mark.slow
def test_the_design_block_runs(user: tuple[Path, dict[str, str]]) -> None:
    # the seed 000 design of the walkthrough's spacecraft: about 60 s of SOS programs
    work, env = user
    script = _script(work, "readme_design.py", [_blocks("python")[3]], """
assert sorted(p.suffix for p in Path("fmus").iterdir()) == [".fmu", ".fmu"]
assert "certified" in design.summary
""")
    assert "README blocks ran" in _run([sys.executable, str(script)], work, env)


def test_the_pytest_block_passes_under_pytest(user: tuple[Path, dict[str, str]]) -> None:
    work, env = user
    (work / "test_readme_gate.py").write_text(_blocks("python")[2])
    out = _run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "test_readme_gate.py"], work, env)
    assert "1 passed" in out


def test_the_fmpy_line_writes_its_csv(user: tuple[Path, dict[str, str]], fmu_dir: Path) -> None:
    work, env = user
    line = re.search(r"`(fmpy simulate [^`]+)`", README.replace("\n", " "))
    assert line is not None
    args = shlex.split(line[1])
    (work / "build").mkdir(exist_ok=True)
    if not (work / "build" / "fmus").exists():
        (work / "build" / "fmus").symlink_to(fmu_dir)  # the README's path: the checkout's build folder
    _run([str(Path(sys.executable).with_name("fmpy")), *args[1:]], work, env)
    rows = (work / "mrp.csv").read_text().splitlines()
    assert rows[0].startswith('"time"') and len(rows) > 100  # 10 s at the FMU's default step
