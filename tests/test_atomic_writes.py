"""Writers killed at every write (SIGKILL through satfmu.fmus.atomic's test hook): the files under their
final names are the previous ones or the new complete ones, never empty or partial, and the next
run detects an artifact written without the FMUs that embed it."""
from __future__ import annotations

import hashlib
import os
import shutil
import signal
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

from satfmu.fmus import build_record
from satfmu.fmus.atomic import KILL_ENV, PHASES

ROOT = Path(__file__).resolve().parents[1]
WRITER = """
import sys
from pathlib import Path
from satfmu.fmus.atomic import write_atomically
for i in range(3):
    write_atomically(Path(sys.argv[1]) / f"f{i}.txt", lambda tmp, i=i: tmp.write_text(f"new {i} " * 100))
"""


def _satfmu(home: Path, *argv: str, kill: str | None = None) -> subprocess.CompletedProcess:
    """``satfmu argv`` in a process of its own with the user's folder ``home``, killed at ``kill``."""
    env = {**os.environ, "SATFMU_HOME": str(home), "OPENBLAS_NUM_THREADS": "1",
           "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    env.pop(KILL_ENV, None)
    if kill is not None:
        env[KILL_ENV] = kill
    return subprocess.run([sys.executable, "-m", "satfmu.sims.cli", *argv], env=env, cwd=home, capture_output=True,
                          text=True, timeout=600)


def _files(folder: Path) -> dict[str, bytes]:
    """Every file under ``folder`` by relative path, except the hidden temporary ones."""
    return {str(p.relative_to(folder)): p.read_bytes() for p in folder.rglob("*")
            if p.is_file() and not p.name.startswith(".")}


def _leftovers(folder: Path) -> list[Path]:
    return [p for p in folder.rglob(".*") if p.is_file()]


@pytest.mark.parametrize("phase", PHASES)
def test_the_hook_kills_the_writer_at_the_nth_file(phase: str, tmp_path: Path) -> None:
    for i in range(3):
        (tmp_path / f"f{i}.txt").write_text(f"old {i}")
    proc = subprocess.run([sys.executable, "-c", WRITER, str(tmp_path)], cwd=ROOT, capture_output=True,
                          env={**os.environ, KILL_ENV: f"2:{phase}"})
    assert proc.returncode == -signal.SIGKILL
    texts = [(tmp_path / f"f{i}.txt").read_text() for i in range(3)]
    assert texts == ["new 0 " * 100, "new 1 " * 100 if phase == "done" else "old 1", "old 2"]
    # killed before its rename, the temporary file stays beside the old one (half of it: 'write')
    left = _leftovers(tmp_path)
    assert [p.stat().st_size for p in left] == {"write": [300], "rename": [600], "done": []}[phase]
    assert all(p.name.startswith(".f1.") and p.name.endswith(".partial.txt") for p in left)


def _pair_scenario(folder: Path) -> Path:
    """Both backends of the seed 003 design (the plant is not needed to load and step them)."""
    f = folder / "pair.toml"
    f.write_text('name = "pair"\nstop_time = 2.0\nstep_size = 1.0\n'
                 '[fmus.native]\nmodel = "cubesat_periodic_satfmu"\n'
                 '[fmus.python]\nmodel = "cubesat_periodic_satfmu"\nbackend = "python"\n'
                 '[fmus.published]\nmodel = "cubesat_periodic_published"\n')
    return f


SYNTH = ("synth", "cubesat-periodic")
WRITES = 4
"""What `synth cubesat-periodic` writes over an earlier one at another gamma: its artifact, its
two FMUs, the published gains' artifact (the same bytes; their FMUs are up to date: not written)."""


@pytest.fixture(scope="module")
def synth_states(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, bytes], dict[str, bytes]]:
    """A user folder after `synth cubesat-periodic --gamma 40`, its files, and the files a complete
    `synth cubesat-periodic` (default gamma) leaves over it."""
    root = tmp_path_factory.mktemp("synth")
    previous, new = root / "previous", root / "new"
    previous.mkdir()
    assert _satfmu(previous, *SYNTH, "--gamma", "40").returncode == 0
    shutil.copytree(previous, new)
    done = _satfmu(new, *SYNTH, kill=f"{WRITES + 1}:write")  # no such write: it completes
    assert done.returncode == 0, done.stderr
    return previous, _files(previous), _files(new)


def _sha(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


@pytest.mark.slow
@pytest.mark.parametrize("phase", PHASES)
@pytest.mark.parametrize("n", range(1, WRITES + 1))
def test_a_killed_synth_leaves_whole_files_and_the_next_run_finds_a_stale_pair(
        n: int, phase: str, synth_states, tmp_path: Path) -> None:
    previous, old, new = synth_states
    assert set(old) == set(new) and old != new
    home = tmp_path / "home"
    shutil.copytree(previous, home)
    assert _satfmu(home, *SYNTH, kill=f"{n}:{phase}").returncode == -signal.SIGKILL
    now = _files(home)
    assert set(now) == set(old)
    for name, data in now.items():  # the previous file or the new complete one, never a part
        assert data in (old[name], new[name]) and data, name
    stale = [name for name in now if name.endswith(".fmu") and "satfmu" in name
             and build_record.artifact_digest(home / name) != _sha(now["artifacts/cubesat_periodic_satfmu.json"])]
    # an artifact written without its FMUs: outside the cache a run refuses the pair ...
    copy = tmp_path / "copy"
    shutil.copytree(home / "fmus", copy)
    f = _pair_scenario(tmp_path)
    run = _satfmu(home, "run", str(f), "--fmu-dir", str(copy), "--out", str(tmp_path / "out"))
    if stale:
        assert run.returncode == 2 and "stale FMU: FMU" in run.stderr, run.stderr
        assert f"{copy / Path(stale[0]).name} embeds the artifact" in run.stderr
    else:
        assert run.returncode == 0, run.stderr
    # ... and in the cache it rebuilds the FMUs from the artifact
    run = _satfmu(home, "run", str(f), "--out", str(tmp_path / "out"))
    assert run.returncode == 0 and run.stderr.count("rebuilding the FMU in the cache") == len(stale), run.stderr
    assert all(build_record.artifact_digest(home / name) == _sha((home / "artifacts" / "cubesat_periodic_satfmu.json")
                                                           .read_bytes()) for name in stale)


BUILT = ("signal_constant.fmu", "signal_step.fmu")
"""The FMUs `satfmu build` rewrites in the kill test (the cheapest two, built in this order)."""


def _stale(fmu: bytes) -> bytes:
    """The FMU with another build digest (a valid FMU that `satfmu build` rebuilds)."""
    import io

    out = io.BytesIO(fmu)
    with zipfile.ZipFile(out, "a") as z:
        z.comment = b"satfmu-build sha256:" + b"0" * 64
    return out.getvalue()


@pytest.mark.slow
@pytest.mark.parametrize("phase", PHASES)
@pytest.mark.parametrize("n", range(1, len(BUILT) + 1))
def test_a_killed_build_leaves_whole_fmus(n: int, phase: str, fmu_dir: Path, tmp_path: Path) -> None:
    folder = tmp_path / "fmus"
    shutil.copytree(fmu_dir, folder, ignore=shutil.ignore_patterns("signal_tables"))
    new = _files(folder)
    for name in BUILT:
        (folder / name).write_bytes(_stale(new[name]))
    old = _files(folder)
    argv = ("build", "--fmu-dir", str(folder), "--backend", "native", "--jobs", "1")
    assert _satfmu(tmp_path, *argv, kill=f"{n}:{phase}").returncode == -signal.SIGKILL
    now = _files(folder)
    assert set(now) == set(new)
    for name, data in now.items():
        assert data in (old[name], new[name]), name
    assert [now[name] == new[name] for name in BUILT] == [i < n - 1 or (i == n - 1 and phase == "done")
                                                          for i in range(len(BUILT))]
    done = _satfmu(tmp_path, *argv)
    assert done.returncode == 0 and f"{len(BUILT) - n + (phase != 'done')} built" in done.stdout, done.stdout
    assert _files(folder) == new


def test_validate_skips_the_temporary_file_of_a_killed_build(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    from satfmu.sims.cli import main

    (tmp_path / ".signal_step.123.0a1b2c3d.partial.fmu").write_bytes(b"half an FMU")
    assert main(["validate", "--fmu-dir", str(tmp_path)]) == 2
    assert f"no FMUs in {tmp_path}" in capsys.readouterr().err


def test_a_full_disk_names_the_file(tmp_path: Path) -> None:
    """ENOSPC carries no file name; the error then says which file could not be written."""
    import errno

    from satfmu.fmus.atomic import write_atomically

    def full(tmp: Path) -> None:
        with open("/dev/full", "wb") as fh:  # every write to it fails with ENOSPC
            fh.write(b"x")
            fh.flush()

    with pytest.raises(OSError, match=rf"No space left on device \(writing {tmp_path / 'r.json'}\)") as exc:
        write_atomically(tmp_path / "r.json", full)
    assert exc.value.errno == errno.ENOSPC and list(tmp_path.iterdir()) == []
