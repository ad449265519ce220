"""The pythonfmu 0.7.0 defects, and satfmu's guard of each (``docs/pythonfmu.md``).

Each test runs one reproduction of ``scripts/upstream/`` in a child process (a crash must not
take pytest down), with a time limit, twice:

- on pythonfmu's own trivial FMU (``scripts/upstream/common.py``, built once in a child process;
  it uses nothing of satfmu), where it asserts the defect as pythonfmu 0.7.0 shows it today. A
  failing assertion on the trivial FMU says pythonfmu changed: the defect's entry in
  ``docs/pythonfmu.md`` (and the guard) is then to be revisited;
- on a satfmu pythonfmu FMU, where the C layer in front of pythonfmu's library
  (``fmus/c/pythonfmu_shim.c``, the FMU's ``binaries/<platform>/<model>_py.so``) guards the
  defect: it asserts the clean answer FMI 2.0 asks for, the same as the native FMU of the same
  model (the control) where the call is a host's plain mistake both refuse.
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
    """A satfmu pythonfmu FMU: pythonfmu's library behind the C layer of
    ``fmus/c/pythonfmu_shim.c``, which guards the defects below (in pythonfmu's C++ layer, before
    any slave code runs: ``python scripts/upstream/<script>`` without an FMU shows them on
    pythonfmu's trivial FMU)."""
    return fmu_dir / SATFMU_PY


SIGSEGV, SIGABRT = -signal.SIGSEGV, -signal.SIGABRT


def _shown(result: Run) -> str:
    """A short account of a run, for an assertion's message."""
    return f"exit {result.returncode}; stdout {result.stdout[-600:]!r}; stderr {result.stderr[-600:]!r}"


def _crashed(result: Run, code: int, fmu: str) -> None:
    """``result`` ended by the signal ``-code`` (pythonfmu's defect)."""
    assert result.returncode == code, f"{fmu}: expected the signal {-code} (pythonfmu changed?): {_shown(result)}"


def _refused(result: Run, message: str, fmu: str) -> None:
    """``result`` ran to its end and fmi2Instantiate returned NULL and logged ``message``."""
    assert result.returncode == 0, f"{fmu}: the reproduction did not finish: {_shown(result)}"
    assert "returned NULL" in result.stdout, f"{fmu}: fmi2Instantiate did not return NULL: {_shown(result)}"
    assert message in result.stdout, f"{fmu}: no {message!r} logged: {_shown(result)}"


def _instantiated(result: Run, fmu: str) -> None:
    """``result`` ran to its end and fmi2Instantiate returned an instance."""
    assert result.returncode == 0, f"{fmu}: the reproduction did not finish: {_shown(result)}"
    assert "returned an instance" in result.stdout, f"{fmu}: fmi2Instantiate returned no instance: {_shown(result)}"


def test_missing_resources_segfault_pythonfmu_and_are_refused_by_satfmu(trivial: Path, pythonfmu_fmu: Path,
                                                                         fmu_dir: Path, tmp_path: Path) -> None:
    """fmi2Instantiate with a resource folder that does not exist: SIGSEGV in pythonfmu (NULL class
    called); NULL and the reason from satfmu's pythonfmu FMU; an instance from the native FMU (it
    reads no resources)."""
    script = "instantiate_missing_resources.py"
    _crashed(run(script, str(trivial), tmp=tmp_path), SIGSEGV, "trivial")
    _refused(run(script, str(pythonfmu_fmu), tmp=tmp_path), "is not this FMU's resources folder", "satfmu")
    _instantiated(run(script, str(fmu_dir / SATFMU_NATIVE), tmp=tmp_path), "native")


def test_one_slash_uri_segfaults_pythonfmu_and_works_in_satfmu(trivial: Path, pythonfmu_fmu: Path,
                                                               tmp_path: Path) -> None:
    """``file:/abs/path`` (RFC 8089) is not stripped to a path by pythonfmu: the same SIGSEGV;
    satfmu's pythonfmu FMU decodes it and instantiates, logging nothing."""
    script = "instantiate_uri_one_slash.py"
    _crashed(run(script, str(trivial), tmp=tmp_path), SIGSEGV, "trivial")
    satfmu = run(script, str(pythonfmu_fmu), tmp=tmp_path)
    _instantiated(satfmu, "satfmu")
    assert satfmu.stdout.rstrip().endswith("log: []"), f"satfmu: logged on a valid URI: {_shown(satfmu)}"


@pytest.mark.parametrize("script, message", [("instantiate_null_name.py", "missing instance name"),
                                             ("instantiate_null_resources.py", "missing resource location")])
def test_null_strings_abort_pythonfmu_and_are_refused_by_satfmu(script: str, message: str, trivial: Path,
                                                                pythonfmu_fmu: Path, tmp_path: Path) -> None:
    """A NULL instance name or resource location: std::string(NULL) throws out of pythonfmu's
    fmi2Instantiate, std::terminate, SIGABRT; satfmu's pythonfmu FMU returns NULL and logs why."""
    trivial_run = run(script, str(trivial), tmp=tmp_path)
    _crashed(trivial_run, SIGABRT, "trivial")
    assert "std::logic_error" in trivial_run.stderr, f"trivial: aborted otherwise: {_shown(trivial_run)}"
    _refused(run(script, str(pythonfmu_fmu), tmp=tmp_path), message, "satfmu")


def test_native_refuses_null_name(fmu_dir: Path, tmp_path: Path) -> None:
    """The control: the native FMU returns NULL and logs why."""
    _refused(run("instantiate_null_name.py", str(fmu_dir / SATFMU_NATIVE), tmp=tmp_path), "missing instance name",
             "native")


def _instantiations(fmu: Path, tmp: Path) -> dict[str, str]:
    """What ``instantiate_unchecked_arguments.py`` printed for ``fmu``: per case, its line."""
    result = run("instantiate_unchecked_arguments.py", str(fmu), tmp=tmp)
    assert result.returncode == 0, f"{fmu.name}: the reproduction did not finish: {_shown(result)}"
    lines = dict(line.split(": ", 1) for line in result.stdout.strip().splitlines())
    assert list(lines) == ["wrong GUID", "fmi2ModelExchange", "empty name"], f"{fmu.name}: {_shown(result)}"
    return lines


def test_arguments_unchecked_by_pythonfmu_are_refused_by_satfmu(trivial: Path, pythonfmu_fmu: Path, fmu_dir: Path,
                                                               tmp_path: Path) -> None:
    """pythonfmu instantiates for a wrong GUID, for fmi2ModelExchange and for an empty name;
    satfmu's pythonfmu FMU refuses each with NULL and the native FMU's reason."""
    trivial_lines = _instantiations(trivial, tmp_path)
    for case, line in trivial_lines.items():
        assert line.startswith("instance;"), f"trivial: {case}: {line} (pythonfmu now checks it?)"
    reasons = {"wrong GUID": "does not match", "fmi2ModelExchange": "co-simulation only",
               "empty name": "missing instance name"}
    for label, fmu in (("satfmu", pythonfmu_fmu), ("native", fmu_dir / SATFMU_NATIVE)):
        for case, line in _instantiations(fmu, tmp_path).items():
            assert line.startswith("NULL;") and reasons[case] in line, f"{label}: {case}: {line}"


@pytest.mark.parametrize("flag, code", [("", SIGABRT), ("--null-array", SIGSEGV)], ids=["null entry", "null array"])
def test_null_logging_category_crashes_pythonfmu_and_is_an_error_in_satfmu(flag: str, code: int, trivial: Path,
                                                                           pythonfmu_fmu: Path, fmu_dir: Path,
                                                                           tmp_path: Path) -> None:
    """fmi2SetDebugLogging(c, true, 1, {NULL}): SIGABRT in pythonfmu (std::string(NULL)); a NULL
    array: SIGSEGV. satfmu's pythonfmu FMU and the native FMU return fmi2Error (3), "NULL category"."""
    args = [flag] if flag else []
    script = "set_debug_logging_null_category.py"
    _crashed(run(script, str(trivial), *args, tmp=tmp_path), code, "trivial")
    for label, fmu in (("satfmu", pythonfmu_fmu), ("native", fmu_dir / SATFMU_NATIVE)):
        result = run(script, str(fmu), *args, tmp=tmp_path)
        assert result.returncode == 0 and result.stdout.startswith("fmi2SetDebugLogging returned 3"), \
            f"{label}: not fmi2Error: {_shown(result)}"
        assert "NULL category" in result.stdout, f"{label}: no reason logged: {_shown(result)}"


_SERIALIZED = re.compile(r"status (\d+), (\d+) of (\d+) bytes of the state written into a buffer of (\d+); "
                         r"(\d+) of the (\d+) bytes checked past the state changed")


def _serialize(fmu: Path, tmp: Path, *args: str) -> tuple[tuple[int, ...], str]:
    """``serialize_buffer_size.py`` on ``fmu``: (status, bytes of the state written, the state's
    size, the buffer's size, bytes changed past the state, bytes checked past it), and its output."""
    result = run("serialize_buffer_size.py", str(fmu), *args, tmp=tmp)
    found = _SERIALIZED.match(result.stdout)
    assert result.returncode == 0 and found is not None, f"{fmu.name}: {_shown(result)}"
    return tuple(map(int, found.groups())), result.stdout


def test_small_serialize_buffer_is_ok_in_pythonfmu_and_an_error_in_satfmu(trivial: Path, pythonfmu_fmu: Path,
                                                                           fmu_dir: Path, tmp_path: Path) -> None:
    """Half the buffer fmi2SerializedFMUstateSize asks for: pythonfmu writes half a state and returns
    fmi2OK (0); satfmu's pythonfmu FMU and the native FMU refuse with fmi2Error (3) and write nothing."""
    (status, written, size, given, _, _), out = _serialize(trivial, tmp_path)
    assert status == 0 and given == size // 2 and written == given, f"trivial: not half a state with fmi2OK: {out}"
    for label, fmu in (("satfmu", pythonfmu_fmu), ("native", fmu_dir / SATFMU_NATIVE)):
        (status, written, size, given, _, _), out = _serialize(fmu, tmp_path)
        assert status == 3 and given == size // 2, f"{label}: not fmi2Error: {out}"
        assert "too small" in out, f"{label}: no reason logged: {out}"
        assert written < given, f"{label}: wrote the state into a buffer too small: {out}"


def test_huge_serialize_buffer_overreads_in_pythonfmu_and_gets_the_state_in_satfmu(trivial: Path,
                                                                                    pythonfmu_fmu: Path,
                                                                                    fmu_dir: Path,
                                                                                    tmp_path: Path) -> None:
    """A 1 GiB buffer (legal: larger than needed): pythonfmu copies 1 GiB from a state of a few
    bytes and runs off the heap, SIGSEGV; satfmu's pythonfmu FMU, as the native FMU, returns fmi2OK
    and writes the state's bytes, none past them."""
    _crashed(run("serialize_buffer_size.py", str(trivial), "--huge", tmp=tmp_path), SIGSEGV, "trivial")
    for label, fmu in (("satfmu", pythonfmu_fmu), ("native", fmu_dir / SATFMU_NATIVE)):
        (status, written, size, given, changed, checked), out = _serialize(fmu, tmp_path, "--huge")
        assert status == 0 and given == 1 << 30, f"{label}: not fmi2OK: {out}"
        assert written == size > 0, f"{label}: the buffer does not hold the whole state: {out}"
        assert checked == 1 << 20 and changed == 0, f"{label}: wrote past the state: {out}"


def _status_queries(fmu: Path, tmp: Path) -> dict[str, str]:
    """What ``status_queries.py`` printed for ``fmu``: per FMI state, its line."""
    result = run("status_queries.py", str(fmu), tmp=tmp)
    assert result.returncode == 0, f"{fmu.name}: the reproduction did not finish: {_shown(result)}"
    lines = dict(line.split(": ", 1) for line in result.stdout.strip().splitlines())
    assert list(lines) == ["Instantiated", "InitializationMode", "StepComplete", "Terminated"], _shown(result)
    return lines


def test_status_queries_answered_by_pythonfmu_everywhere_and_by_satfmu_as_native(trivial: Path,
                                                                                 pythonfmu_fmu: Path,
                                                                                 fmu_dir: Path,
                                                                                 tmp_path: Path) -> None:
    """pythonfmu's C++ layer answers fmi2GetRealStatus(fmi2LastSuccessfulTime) and
    fmi2GetBooleanStatus(fmi2Terminated) with fmi2OK (0) before initialization is done (NaN, false)
    and fmi2GetStatus with fmi2Error (3) everywhere. satfmu's pythonfmu FMU answers as the native
    FMU: fmi2Error before a step, then fmi2OK with the last successful time (0.5 s after a step of
    0.5 s from 0) and false, and fmi2Discard (2) for fmi2GetStatus."""
    expected = {"Instantiated": "0 nan", "InitializationMode": "0 nan", "StepComplete": "0 0.5", "Terminated": "0 0.5"}
    trivial_lines = _status_queries(trivial, tmp_path)
    for state, real in expected.items():
        assert trivial_lines[state] == (f"GetRealStatus(LastSuccessfulTime) {real}; GetBooleanStatus(Terminated) 0 0; "
                                        "GetStatus(DoStepStatus) 3"), f"trivial: {state}: {trivial_lines[state]}"
    satfmu, native = _status_queries(pythonfmu_fmu, tmp_path), _status_queries(fmu_dir / SATFMU_NATIVE, tmp_path)
    guarded = {"Instantiated": "3 0.0; GetBooleanStatus(Terminated) 3 0; GetStatus(DoStepStatus) 3",
               "InitializationMode": "3 0.0; GetBooleanStatus(Terminated) 3 0; GetStatus(DoStepStatus) 3",
               "StepComplete": "0 0.5; GetBooleanStatus(Terminated) 0 0; GetStatus(DoStepStatus) 2",
               "Terminated": "0 0.5; GetBooleanStatus(Terminated) 0 0; GetStatus(DoStepStatus) 2"}
    for state, answer in guarded.items():
        assert native[state] == f"GetRealStatus(LastSuccessfulTime) {answer}", f"native: {state}: {native[state]}"
        assert satfmu[state] == native[state], f"{state}: satfmu {satfmu[state]!r}, native {native[state]!r}"


def _invalid_reads_at_exit(fmu: Path, tmp: Path) -> int:
    """Invalid reads valgrind reports in pythonfmu's ``finalizePythonInterpreter`` when a process
    that instantiated ``fmu`` exits."""
    result = run("exit_without_reset.py", str(fmu), tmp=tmp, wrapper=("valgrind",))
    assert "exiting" in result.stdout, f"{fmu.name}: did not reach the exit: {result.stderr[-2000:]}"
    return len(re.findall(r"Invalid read of size \d+\n==\d+== +at 0x[0-9A-F]+: finalizePythonInterpreter",
                          result.stderr))


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("valgrind") is None, reason="valgrind is not installed")
def test_exit_use_after_free_in_pythonfmu_and_not_in_satfmu(trivial: Path, pythonfmu_fmu: Path,
                                                            tmp_path: Path) -> None:
    """A process that instantiated pythonfmu's trivial FMU (freed and unloaded: no help) reads the
    freed interpreter holder at exit (~10 s under valgrind); satfmu's pythonfmu FMU, whose C layer
    empties the holder through finalizePythonInterpreter from an exit handler that runs first
    (``fmus/c/pythonfmu_shim.c``), does not."""
    reads = _invalid_reads_at_exit(trivial, tmp_path)
    assert reads >= 1, "trivial: no invalid read at exit (pythonfmu changed?)"
    reads = _invalid_reads_at_exit(pythonfmu_fmu, tmp_path)
    assert reads == 0, f"satfmu: {reads} invalid read(s) in finalizePythonInterpreter at exit"
