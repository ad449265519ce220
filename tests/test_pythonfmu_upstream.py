"""The pythonfmu 0.7.0 defects satfmu cannot guard, as today's behaviour (``docs/pythonfmu.md``).

Each test runs one reproduction of ``scripts/upstream/`` in a child process (a crash must not
take pytest down), with a time limit, on a satfmu pythonfmu FMU (and on pythonfmu's own trivial
FMU, built once in a child process, where the satfmu slave behaves otherwise), and asserts what
pythonfmu 0.7.0 does today: a test that fails here says pythonfmu changed, and the defect's entry
in ``docs/pythonfmu.md`` is then to be revisited. The native FMU of the same model runs as the
control where the call is a host's plain mistake: it must refuse the call cleanly.
"""
from __future__ import annotations

import os
import re
import shutil
import signal
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SCRIPTS = ROOT / "scripts" / "upstream"
TIMEOUT_S = 120.0
"""Time limit of one reproduction, s (each takes ~1 s: Python, fmpy and the FMU's interpreter)."""
SATFMU_PY, SATFMU_NATIVE = "mrp_satellite_py.fmu", "mrp_satellite.fmu"


@dataclass(frozen=True)
class Run:
    """What a reproduction did: its exit code (minus the signal that killed it) and output."""

    returncode: int
    stdout: str
    stderr: str


def run(script: str, *args: str, tmp: Path, wrapper: tuple[str, ...] = ()) -> Run:
    """``python scripts/upstream/<script> *args`` in a child process, its temporary files in ``tmp``."""
    proc = subprocess.run([*wrapper, sys.executable, str(SCRIPTS / script), *args], capture_output=True,
                          text=True, timeout=TIMEOUT_S, env={**os.environ, "TMPDIR": str(tmp)})
    return Run(proc.returncode, proc.stdout, proc.stderr)


@pytest.fixture(scope="module")
def trivial(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """pythonfmu's trivial FMU (``scripts/upstream/common.py``), built in a child process."""
    folder = tmp_path_factory.mktemp("trivial")
    proc = subprocess.run([sys.executable, str(SCRIPTS / "common.py"), str(folder)], capture_output=True,
                          text=True, timeout=TIMEOUT_S, env={**os.environ, "TMPDIR": str(folder)})
    assert proc.returncode == 0, proc.stderr[-2000:]
    return Path(proc.stdout.strip().splitlines()[-1])


@pytest.fixture
def pythonfmu_fmu(fmu_dir: Path) -> Path:
    """A satfmu pythonfmu FMU. The defects below are in pythonfmu's C++ layer, before any slave
    code runs, so every pythonfmu FMU shows them (``python scripts/upstream/<script>`` without an
    FMU shows them on pythonfmu's trivial FMU)."""
    return fmu_dir / SATFMU_PY


SIGSEGV, SIGABRT = -signal.SIGSEGV, -signal.SIGABRT


def test_instantiate_missing_resources_segfaults(pythonfmu_fmu: Path, fmu_dir: Path, tmp_path: Path) -> None:
    """fmi2Instantiate with a resource folder that does not exist: SIGSEGV in pythonfmu (NULL class
    called), an instance from the native FMU (it reads no resources)."""
    assert run("instantiate_missing_resources.py", str(pythonfmu_fmu), tmp=tmp_path).returncode == SIGSEGV
    native = run("instantiate_missing_resources.py", str(fmu_dir / SATFMU_NATIVE), tmp=tmp_path)
    assert native.returncode == 0 and "returned an instance" in native.stdout


def test_instantiate_one_slash_uri_segfaults(pythonfmu_fmu: Path, tmp_path: Path) -> None:
    """``file:/abs/path`` (RFC 8089) is not stripped to a path: the same SIGSEGV."""
    assert run("instantiate_uri_one_slash.py", str(pythonfmu_fmu), tmp=tmp_path).returncode == SIGSEGV


@pytest.mark.parametrize("script", ["instantiate_null_name.py", "instantiate_null_resources.py"])
def test_instantiate_null_string_aborts(script: str, pythonfmu_fmu: Path, tmp_path: Path) -> None:
    """A NULL instance name or resource location: std::string(NULL) throws out of fmi2Instantiate,
    std::terminate, SIGABRT."""
    result = run(script, str(pythonfmu_fmu), tmp=tmp_path)
    assert result.returncode == SIGABRT and "std::logic_error" in result.stderr


def test_native_refuses_null_name(fmu_dir: Path, tmp_path: Path) -> None:
    """The control: the native FMU returns NULL and logs why."""
    result = run("instantiate_null_name.py", str(fmu_dir / SATFMU_NATIVE), tmp=tmp_path)
    assert result.returncode == 0 and "returned NULL" in result.stdout and "missing instance name" in result.stdout


def test_instantiate_arguments_unchecked(trivial: Path, fmu_dir: Path, tmp_path: Path) -> None:
    """pythonfmu instantiates for a wrong GUID, for fmi2ModelExchange and for an empty name; satfmu's
    slave refuses the empty name (the only one of the three it receives); the native FMU refuses all."""
    lines = {"trivial": run("instantiate_unchecked_arguments.py", str(trivial), tmp=tmp_path).stdout,
             "satfmu": run("instantiate_unchecked_arguments.py", str(fmu_dir / SATFMU_PY), tmp=tmp_path).stdout,
             "native": run("instantiate_unchecked_arguments.py", str(fmu_dir / SATFMU_NATIVE), tmp=tmp_path).stdout}
    assert lines["trivial"].split("\n")[:3] == ["wrong GUID: instance", "fmi2ModelExchange: instance",
                                                "empty name: instance"]
    assert lines["satfmu"].split("\n")[:3] == ["wrong GUID: instance", "fmi2ModelExchange: instance",
                                               "empty name: NULL"]
    assert lines["native"].split("\n")[:3] == ["wrong GUID: NULL", "fmi2ModelExchange: NULL", "empty name: NULL"]


@pytest.mark.parametrize("flag, code", [("", SIGABRT), ("--null-array", SIGSEGV)], ids=["null entry", "null array"])
def test_set_debug_logging_null_category_crashes(flag: str, code: int, pythonfmu_fmu: Path, fmu_dir: Path,
                                                 tmp_path: Path) -> None:
    """fmi2SetDebugLogging(c, true, 1, {NULL}): SIGABRT (std::string(NULL)); a NULL array: SIGSEGV.
    The native FMU returns fmi2Error (3) for both."""
    args = [flag] if flag else []
    assert run("set_debug_logging_null_category.py", str(pythonfmu_fmu), *args, tmp=tmp_path).returncode == code
    native = run("set_debug_logging_null_category.py", str(fmu_dir / SATFMU_NATIVE), *args, tmp=tmp_path)
    assert native.returncode == 0 and native.stdout.startswith("fmi2SetDebugLogging returned 3")


def test_serialize_into_small_buffer_is_ok(pythonfmu_fmu: Path, fmu_dir: Path, tmp_path: Path) -> None:
    """Half the buffer fmi2SerializedFMUstateSize asks for: pythonfmu writes half a state and returns
    fmi2OK (0); the native FMU refuses with fmi2Error (3)."""
    result = run("serialize_buffer_size.py", str(pythonfmu_fmu), tmp=tmp_path)
    written = re.match(r"status (\d+), (\d+) of (\d+) bytes written", result.stdout)
    assert result.returncode == 0 and written is not None, result
    status, given, size = map(int, written.groups())
    assert status == 0 and given == size // 2
    native = run("serialize_buffer_size.py", str(fmu_dir / SATFMU_NATIVE), tmp=tmp_path)
    assert native.returncode == 0 and native.stdout.startswith("status 3")


def test_serialize_into_huge_buffer_overreads(pythonfmu_fmu: Path, tmp_path: Path) -> None:
    """A 1 GiB buffer (legal: larger than needed): pythonfmu copies 1 GiB from a state of a few
    hundred bytes and runs off the heap, SIGSEGV."""
    assert run("serialize_buffer_size.py", str(pythonfmu_fmu), "--huge", tmp=tmp_path).returncode == SIGSEGV


def test_status_queries_answered_in_every_state(pythonfmu_fmu: Path, tmp_path: Path) -> None:
    """pythonfmu's C++ layer answers fmi2GetRealStatus(fmi2LastSuccessfulTime) and
    fmi2GetBooleanStatus(fmi2Terminated) with fmi2OK (0) before initialization is done (NaN, false)
    and fmi2GetStatus with fmi2Error (3) everywhere; after a step of 0.5 s from 0 the last
    successful time is 0.5 s exactly (0.0 + 0.5)."""
    result = run("status_queries.py", str(pythonfmu_fmu), tmp=tmp_path)
    assert result.returncode == 0, result
    expected = {"Instantiated": "0 nan", "InitializationMode": "0 nan", "StepComplete": "0 0.5", "Terminated": "0 0.5"}
    lines = dict(line.split(": ", 1) for line in result.stdout.strip().splitlines())
    for state, real in expected.items():
        assert lines[state] == (f"GetRealStatus(LastSuccessfulTime) {real}; GetBooleanStatus(Terminated) 0 0; "
                                "GetStatus(DoStepStatus) 3")


def _invalid_reads_at_exit(fmu: Path, tmp: Path) -> int:
    """Invalid reads valgrind reports in pythonfmu's ``finalizePythonInterpreter`` when a process
    that instantiated ``fmu`` exits."""
    result = run("exit_without_reset.py", str(fmu), tmp=tmp, wrapper=("valgrind",))
    assert "exiting" in result.stdout, result.stderr[-2000:]
    return len(re.findall(r"Invalid read of size \d+\n==\d+== +at 0x[0-9A-F]+: finalizePythonInterpreter",
                          result.stderr))


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("valgrind") is None, reason="valgrind is not installed")
def test_exit_use_after_free(trivial: Path, fmu_dir: Path, tmp_path: Path) -> None:
    """A process that instantiated pythonfmu's trivial FMU (freed and unloaded: no help) reads the
    freed interpreter holder at exit (~10 s under valgrind); satfmu's FMU, whose slave resets the
    holder from an atexit handler (``fmus/pyslave.py``, ``_guard_exit``), does not."""
    assert _invalid_reads_at_exit(trivial, tmp_path) >= 1
    assert _invalid_reads_at_exit(fmu_dir / SATFMU_PY, tmp_path) == 0
