"""Malicious FMU files (tests/malicious_fmus.py) x every command that opens an FMU.

Each command runs in a child process of its own (tests/untrusted_driver.py) over every class,
with TMPDIR pointing into the test's folder: every class must be refused with its reason
named, within a second, with nothing written outside a temporary folder (the zip slip targets
stay absent) and TMPDIR empty afterwards, and the process's peak memory (its own and its
children's) under 300 MB. And :mod:`satfmu.fmus.archive` itself: its limits, its messages, the
extraction folder always removed.
"""
from __future__ import annotations

import json
import os
import re
import shutil
import stat
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

from satfmu.fmus import archive
from tests import malicious_fmus as M

ROOT = Path(__file__).resolve().parents[1]

REASONS = {
    "zip slip (relative)": r"has an entry '(\.\./)+.*via_fmu_dir\.txt' that climbs out of the archive",
    "zip slip (absolute)": r"has an entry '/.*absolute\.txt' with an absolute path",
    "symlink": r"has an entry 'resources/passwd' that is a symbolic link",
    "device": r"has an entry 'resources/null' that is a device, FIFO or socket",
    "bomb in the description": r"has a modelDescription\.xml of 1073\d+ bytes, more than",
    "bomb in a resource": (r"has an entry 'resources/table\.txt' that expands \d+ bytes to 2146\d+ "
                           r"\(more than 200 times"),
    "size that lies": r"is damaged: its entry 'resources/small\.txt' fails its check \(Bad CRC-32",
    "1e5 entries": r"holds 1000\d\d entries, more than 10000",  # the FMU's own entries and 1e5
    "3e5 variables": r"has a modelDescription\.xml of 300030 variables, more than 100000",
    "entity expansion": r"has a modelDescription\.xml that declares a document type or entities",
}
"""What each class's refusal must say (the entry or the limit)."""

COMMANDS = {
    "run": ["run", "mrp_200deg", "--fmu-dir", "{fmu_dir}", "--out", "{out}"],
    "export-ssp": ["export-ssp", "mrp_200deg", "--fmu-dir", "{fmu_dir}", "--out", "{out}"],
    "verify libcosim": ["verify", "mrp_200deg", "--engines", "libcosim", "--fmu-dir", "{fmu_dir}", "--out", "{out}"],
    "verify ecos": ["verify", "mrp_200deg", "--engines", "ecos", "--fmu-dir", "{fmu_dir}", "--out", "{out}"],
    "validate": ["validate", "--fmu-dir", "{fmu_dir}"],
    "robustness": ["robustness", "--fmu", "mrp_satellite", "--cycles", "1", "--fmu-dir", "{fmu_dir}",
                   "--out", "{out}"],
    "campaign": ["campaign", "scenario", "mrp_slew_mc", "--samples", "2", "--workers", "1", "--fmu-dir",
                 "{fmu_dir}", "--out", "{out}"],
}
"""Every command that opens an FMU of a folder (``replay`` and ``report`` read the FMUs a
campaign folder names, by the same path: :func:`satfmu.fmus.archive.read_description`)."""

PEAK_MB = 300
"""The issue's bound on memory, for the command's process and its largest child."""
SECONDS = 1.0
"""A refusal's wall time: the checks read the archive's directory and at most a 32 MiB model
description; one second leaves the shared machine's noise ten times the measured ~0.1 s."""


@pytest.fixture(scope="session")
def malicious(tmp_path_factory: pytest.TempPathFactory, fmu_dir: Path) -> tuple[dict[str, Path], Path]:
    """Every class written once (about 16 MB in all), and the folder a zip slip would write to."""
    folder = tmp_path_factory.mktemp("malicious")
    escape = folder / "escape"
    escape.mkdir()
    real = fmu_dir / "mrp_satellite.fmu"
    return {name: make(real, folder / f"{i}.fmu", escape) for i, (name, make) in enumerate(M.CLASSES.items())}, escape


@pytest.mark.parametrize("command", COMMANDS)
def test_every_class_is_refused_by_every_command(command: str, malicious: tuple[dict[str, Path], Path],
                                                 fmu_dir: Path, tmp_path: Path) -> None:
    files, escape = malicious
    folder = tmp_path / "fmus"
    if command == "validate":  # fmutool and fmpy on the one file, not on the 36 good ones
        folder.mkdir()
    else:
        shutil.copytree(fmu_dir, folder)
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    job = tmp_path / "job.json"
    job.write_text(json.dumps({"argv": COMMANDS[command], "fmu_dir": str(folder), "out": str(tmp_path / "out"),
                               "tmpdir": str(tmp), "classes": {k: str(v) for k, v in files.items()}}))
    env = {**os.environ, "TMPDIR": str(tmp), "SATFMU_HOME": str(tmp_path / "home")}
    proc = subprocess.run([sys.executable, "-m", "tests.untrusted_driver", str(job)], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    report = json.loads(job.with_suffix(".out.json").read_text())
    for name, r in report["results"].items():
        said = r["stderr"] + r["stdout"]
        assert r["code"] in (1, 2), f"{name}: exit {r['code']}: {said}"
        assert re.search(REASONS[name], said), f"{name}: {said}"
        assert "Traceback" not in said, f"{name}: {said}"
        assert r["seconds"] < SECONDS, f"{name}: {r['seconds']:.2f} s"
        assert r["tmp_left"] == [], f"{name}: left in TMPDIR: {r['tmp_left']}"
    assert not [p for p in M.escape_targets(escape) if p.exists()], "a zip slip wrote outside"
    assert report["peak_mb"] < PEAK_MB and report["children_peak_mb"] < PEAK_MB, \
        {name: r["peak_mb"] for name, r in report["results"].items()} | {"children": report["children_peak_mb"]}


def _fmu(tmp_path: Path, fmu_dir: Path, name: str) -> Path:
    return M.CLASSES[name](fmu_dir / "mrp_satellite.fmu", tmp_path / "x.fmu", tmp_path)


def test_a_good_fmu_extracts_whole_and_the_folder_goes(fmu_dir: Path, tmp_path: Path,
                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr("tempfile.tempdir", str(tmp_path))
    src = fmu_dir / "mrp_satellite.fmu"
    with archive.extract(src) as x:
        assert x.folder.parent == tmp_path and stat.S_IMODE(x.folder.stat().st_mode) == 0o700
        with zipfile.ZipFile(src) as z:
            for info in z.infolist():
                if not info.is_dir():
                    assert (x.folder / info.filename).read_bytes() == z.read(info), info.filename
    assert not x.folder.exists() and list(tmp_path.iterdir()) == []


def test_a_failed_extraction_leaves_nothing(fmu_dir: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The lying entry passes the directory checks, then fails its CRC half-way through the
    extraction: the folder with what was written goes."""
    bad = _fmu(tmp_path, fmu_dir, "size that lies")
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    monkeypatch.setattr("tempfile.tempdir", str(tmp))
    archive.check(bad)  # its headers are consistent
    with pytest.raises(archive.UnsafeFmuError, match="Bad CRC-32"):
        archive.extract(bad)
    assert list(tmp.iterdir()) == []


def test_limits_come_from_the_environment(fmu_dir: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    src = fmu_dir / "mrp_satellite.fmu"
    monkeypatch.setenv("SATFMU_FMU_MAX_ENTRIES", "3")
    with pytest.raises(archive.UnsafeFmuError, match=r"holds \d entries, more than 3 \(raise SATFMU_FMU_MAX_ENTRIES"):
        archive.check(src)
    monkeypatch.setenv("SATFMU_FMU_MAX_ENTRIES", "many")
    with pytest.raises(ValueError, match="SATFMU_FMU_MAX_ENTRIES='many' is not a number"):
        archive.check(src)
    monkeypatch.delenv("SATFMU_FMU_MAX_ENTRIES")
    monkeypatch.setenv("SATFMU_FMU_MAX_DESCRIPTION_BYTES", "1000")
    with pytest.raises(archive.UnsafeFmuError, match=r"modelDescription\.xml of \d+ bytes, more than 1000"):
        archive.check(src)


def test_raised_limits_accept_a_large_description(fmu_dir: Path, tmp_path: Path) -> None:
    """A model of 300,000 variables is refused by default and read when the user allows it."""
    big = _fmu(tmp_path, fmu_dir, "3e5 variables")
    listing = archive.check(big, archive.FmuLimits(max_variables=400_000))
    assert listing.description.count(b"<ScalarVariable") == 300_030


@pytest.mark.parametrize("name, problem", [
    ("", "an entry with an empty name"),
    ("a\\..\\..\\x", "backslash"),
    ("C:/x", "absolute path"),
    ("resources/a\nb", "control character"),
    ("modelDescription.xml", "twice"),
])
def test_more_unsafe_names(name: str, problem: str, fmu_dir: Path, tmp_path: Path) -> None:
    with zipfile.ZipFile(fmu_dir / "mrp_satellite.fmu") as z:
        entries = [M.deflated(n, z.read(n)) for n in z.namelist()]
    bad = M.write_zip(tmp_path / "x.fmu", entries + [M.stored(name, b"x")])
    with pytest.raises(archive.UnsafeFmuError, match=problem):
        archive.check(bad)


def test_not_a_zip_and_not_a_file(tmp_path: Path) -> None:
    (tmp_path / "text.fmu").write_text("not a zip\n" * 10)
    with pytest.raises(archive.UnsafeFmuError, match=r"is not a zip archive"):
        archive.check(tmp_path / "text.fmu")
    with pytest.raises(FileNotFoundError, match="no such FMU"):
        archive.check(tmp_path / "missing.fmu")
    os.mkfifo(tmp_path / "fifo.fmu")
    with pytest.raises(archive.UnsafeFmuError, match="is not a regular file"):
        archive.check(tmp_path / "fifo.fmu")


def test_folders_of_killed_processes_are_swept(tmp_path: Path) -> None:
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    gone = tmp_path / f"{archive.FOLDER_PREFIX}{int(dead.stdout)}-abc"
    mine = tmp_path / f"{archive.FOLDER_PREFIX}{os.getpid()}-abc"
    other = tmp_path / "satfmu-fmu-notapid"
    for p in (gone, mine, other):
        (p / "binaries").mkdir(parents=True)
    assert archive.sweep_abandoned(tmp_path) == [gone]
    assert mine.exists() and other.exists() and not gone.exists()
