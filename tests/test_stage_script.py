"""scripts/stage.sh: one line per stage of `make demo`/`make test`, the output kept in a log."""
from __future__ import annotations

import subprocess
from pathlib import Path

STAGE = Path(__file__).resolve().parents[1] / "scripts" / "stage.sh"


def _stage(tmp_path: Path, *argv: str) -> subprocess.CompletedProcess:
    return subprocess.run([str(STAGE), *argv], cwd=tmp_path, capture_output=True, text=True)


def test_a_stage_prints_one_line_and_logs_its_output(tmp_path: Path) -> None:
    proc = _stage(tmp_path, "say hello", "sh", "-c", "echo noise; echo noise >&2; echo the last line")
    assert proc.returncode == 0
    [line] = proc.stdout.splitlines()
    assert line.startswith("say hello") and " s wall " in line and " s CPU " in line and line.endswith("the last line")
    assert (tmp_path / "build/logs/say_hello.log").read_text().count("noise") == 2
    label, wall, cpu, rc = (tmp_path / "build/logs/stages.tsv").read_text().strip().split("\t")
    assert label == "say hello" and float(wall) >= 0 and float(cpu) >= 0 and rc == "0"


def test_a_failed_stage_shows_the_log_tail_and_keeps_the_exit_code(tmp_path: Path) -> None:
    proc = _stage(tmp_path, "broken", "sh", "-c", "echo what went wrong; exit 3")
    assert proc.returncode == 3
    assert "broken" in proc.stdout and "FAILED (exit 3)" in proc.stdout and "what went wrong" in proc.stdout
    assert (tmp_path / "build/logs/stages.tsv").read_text().strip().endswith("\t3")


def test_show_passes_the_output_through(tmp_path: Path) -> None:
    proc = _stage(tmp_path, "--show", "tests", "sh", "-c", "echo 3 passed in 0.1s")
    assert proc.returncode == 0 and proc.stdout.splitlines()[0] == "3 passed in 0.1s"

