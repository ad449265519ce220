"""Bad input to the command line: every malformed scenario, FMU file and artifact, through each
command that reads it, exits 2 with one line on stderr naming the file and the key, no
traceback, no file in ``--out``, and nothing written anywhere else (the test's folder, with the
user's folder and the temporary folder in it, and the FMU folder are listed before and after).

Stale controller FMUs (an artifact replaced after its FMU was built) are refused outside the
FMU cache and rebuilt in it.
"""
from __future__ import annotations

import hashlib
import json
import math
import re
import shutil
import tempfile
import zipfile
from pathlib import Path
from typing import Callable

import pytest

from satfmu.fmus import build_record
from satfmu.controllers import paths
from satfmu.sims.cosim import preflight
from satfmu.sims.cli import main
from tests.test_cli import BAD_SCENARIOS, _bad_scenario

SHIPPED = paths.SHIPPED_ARTIFACTS


@pytest.fixture
def home(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """The user's folder (with an empty artifact folder) and the temporary folder, in tmp_path."""
    h = tmp_path / "home"
    (h / "artifacts").mkdir(parents=True)
    monkeypatch.setenv(paths.HOME_ENV, str(h))
    (tmp_path / "tmp").mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path / "tmp"))  # where fmpy extracts FMUs
    return h


def _listing(roots: list[Path], skip: Path) -> dict[str, tuple[int, int]]:
    """Every file (size, modification time) and folder under ``roots``, except under ``skip``."""
    out = {}
    for root in roots:
        for p in root.rglob("*"):
            if p != skip and skip not in p.parents:
                out[str(p)] = (p.stat().st_size, p.stat().st_mtime_ns) if p.is_file() else (-1, 0)
    return out


def _fails(argv: list[str], message: str, tmp_path: Path, capsys: pytest.CaptureFixture,
           watched: tuple[Path, ...] = (), warned: str | None = None) -> str:
    """Run ``satfmu argv`` (its ``--out`` is tmp_path/out): exit 2, one line matching
    ``message`` (after a warning line matching ``warned``, if given), no traceback, no file in
    --out, nothing changed in tmp_path or ``watched``."""
    out = tmp_path / "out"
    before = _listing([tmp_path, *watched], out)
    code = main([str(a) for a in argv])
    err = capsys.readouterr().err
    if warned is not None:
        first, _, err = err.partition("\n")
        assert re.search(warned, first), first
    assert code == 2, err
    assert re.search(message, err), err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1, err
    assert not out.exists() or not [p for p in out.rglob("*") if p.is_file()], "a refused input wrote a result"
    assert _listing([tmp_path, *watched], out) == before, "a refused input wrote outside --out"
    return err


def _scenario_argv(command: str, scenario: Path, fmu_dir: Path, out: Path) -> list:
    argv = [command, scenario, "--fmu-dir", fmu_dir, "--out", out]
    return argv + ["--engines", "libcosim"] if command == "verify" else argv


SCENARIO_COMMANDS = ["run", "export-ssp", "verify"]


# ----------------------------------------------------------------------------- scenarios
@pytest.mark.parametrize("body, message", BAD_SCENARIOS, ids=[m[:24] for _, m in BAD_SCENARIOS])
@pytest.mark.parametrize("command", SCENARIO_COMMANDS)
def test_malformed_scenario(command: str, body: str, message: str, tmp_path: Path, home: Path, fmu_dir: Path,
                            capsys: pytest.CaptureFixture) -> None:
    f = _bad_scenario(tmp_path, body)
    err = _fails(_scenario_argv(command, f, fmu_dir, tmp_path / "out"), message, tmp_path, capsys, (fmu_dir,))
    assert err.startswith(f"satfmu {command}: error: {f}: "), err  # the file, then the key


# ----------------------------------------------------------------------------- FMU files
def _rezip(fmu: bytes, keep: Callable[[str], bool] = lambda name: True,
           edit: Callable[[str, bytes], bytes] = lambda name, data: data) -> bytes:
    """The FMU ``fmu`` with only the members ``keep`` accepts, each passed through ``edit``."""
    import io

    src, dst = io.BytesIO(fmu), io.BytesIO()
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(dst, "w", zipfile.ZIP_DEFLATED) as zout:
        for name in zin.namelist():
            if keep(name):
                zout.writestr(name, edit(name, zin.read(name)))
    return dst.getvalue()


BAD_FMUS: dict[str, tuple[Callable[[Path], bytes], str]] = {
    "empty": (lambda d: b"", r"is empty \(0 bytes\)"),
    "not a zip": (lambda d: b"not an FMU, a text file\n" * 40, r"is not a zip archive \(truncated, or another kind"),
    "truncated": (lambda d: (d / "mrp_satellite.fmu").read_bytes()[:20_000], r"is not a zip archive"),
    "no modelDescription": (lambda d: _rezip((d / "mrp_satellite.fmu").read_bytes(),
                                             keep=lambda n: n != "modelDescription.xml"),
                            r"has no modelDescription.xml"),
    "FMI 1.0": (lambda d: _rezip((d / "mrp_satellite.fmu").read_bytes(), edit=lambda n, b: b.replace(
        b'fmiVersion="2.0"', b'fmiVersion="1.0"') if n == "modelDescription.xml" else b),
                r"is an FMI 1.0 FMU; satfmu runs FMI 2.0 and 3.0 co-simulation FMUs"),
    "no binary": (lambda d: _rezip((d / "mrp_satellite.fmu").read_bytes(),
                                   keep=lambda n: not n.startswith("binaries/")),
                  r"has no binary for this platform \(binaries/linux64/mrp_satellite.so; its binaries: none\)"),
    "another model": (lambda d: (d / "vscmg.fmu").read_bytes(), r"holds the model 'vscmg', not 'mrp_satellite'"),
}
"""An unusable ``mrp_satellite.fmu``: how to make it from the built FMUs, and the message."""


@pytest.mark.parametrize("kind", BAD_FMUS)
@pytest.mark.parametrize("command", SCENARIO_COMMANDS)
def test_unusable_fmu_file(command: str, kind: str, tmp_path: Path, home: Path, fmu_dir: Path,
                           capsys: pytest.CaptureFixture) -> None:
    make, message = BAD_FMUS[kind]
    folder = tmp_path / "fmus"
    folder.mkdir()
    (folder / "mrp_satellite.fmu").write_bytes(make(fmu_dir))
    f = _bad_scenario(tmp_path, "")  # a valid scenario: the plant only
    fmu = folder / "mrp_satellite.fmu"
    _fails(_scenario_argv(command, f, folder, tmp_path / "out"),
           rf"{re.escape(str(f))}: fmus\.plant\.model: FMU file {re.escape(str(fmu))} {message}.*"
           r"\(remove it to have it built anew\)", tmp_path, capsys)


def test_an_unusable_fmu_in_the_cache_is_rebuilt(tmp_path: Path, home: Path, capsys: pytest.CaptureFixture) -> None:
    """The FMU cache is satfmu's own: an unusable file there is replaced, with a warning."""
    cached = paths.fmu_cache() / "signal_constant.fmu"
    cached.parent.mkdir(parents=True)
    cached.write_bytes(b"")
    f = tmp_path / "s.toml"
    f.write_text('name = "s"\nstop_time = 1.0\nstep_size = 0.5\n[[metrics]]\nname = "y"\nkind = "final"\n'
                 'signals = ["sig.y"]\nmin = 2.5\nmax = 2.5\n[fmus.sig]\nmodel = "signal_constant"\n'
                 'parameters = { value = 2.5 }\n')
    assert main(["run", str(f), "--out", str(tmp_path / "out")]) == 0  # the metric: y = 2.5 exactly
    err = capsys.readouterr().err
    assert re.fullmatch(rf"satfmu run: warning: {re.escape(str(f))}: fmus\.sig\.model: rebuilding the FMU in the "
                        rf"cache: FMU file {re.escape(str(cached))} is empty \(0 bytes\)\n", err), err
    assert preflight.fmu_problem(cached, "signal_constant") is None


# ----------------------------------------------------------------------------- artifacts
def _set(data: dict, path: tuple, value) -> dict:
    node = data
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = value
    return data


def _artifact(base: str, change: Callable[[dict], object]) -> str:
    """The text of the shipped artifact ``base`` changed by ``change`` (which returns the new
    data, or the text itself)."""
    data = change(json.loads((SHIPPED / f"{base}.json").read_text()))
    return data if isinstance(data, str) else json.dumps(data, indent=1)


# each kind: (the artifact text from a base (None: no file), the message); the base is
# mrp_hinf_published (polynomial law) or, for a campaign, demeter_row1_det (state feedback)
BAD_ARTIFACTS: dict[str, Callable[[str], tuple[str | None, str]]] = {
    "missing file": lambda base: (None, r"no (model or )?artifact named 'bad_ctrl'"),
    "not JSON": lambda base: ('{"format": "satfmu-controller", ', r"bad_ctrl\.json: not valid JSON"),
    "wrong shape": lambda base: ("[1, 2, 3]", r"bad_ctrl\.json: top level must be a JSON object"),
    "unknown kind": lambda base: (_artifact(base, lambda d: _set(d, ("kind",), "neural_network")),
                                  r"bad_ctrl\.json: 'kind' must be one of .*got 'neural_network'"),
    "wrong matrix shape": lambda base: (
        _artifact(base, lambda d: _set(d, ("lyapunov", "Q"), [[1.0] * 5] * 5)), r"bad_ctrl\.json\.lyapunov\.Q: shape "
        r"\(5, 5\), expected \(6, 6\)") if base == "mrp_hinf_published" else (
        _artifact(base, lambda d: _set(d, ("design", "K"), [[1.0, 2.0, 3.0]])),
        r"bad_ctrl\.json: design\.K: .*must be a finite 1 x 8 matrix.* got shape \(1, 3\)"),
    "NaN in a gain": lambda base: (
        _artifact(base, lambda d: _set(d, ("law", "terms", 0, 0, "c"), math.nan)),
        r"bad_ctrl\.json\.law\.terms\[0\]\[0\]\.c: must be a finite number, got nan") if base == "mrp_hinf_published"
    else (_artifact(base, lambda d: _set(d, ("gains", "K_theta[1,1]"), math.nan)),
          r"bad_ctrl\.json\.gains\.K_theta\[1,1\]: must be a finite number, got nan"),
    "format version": lambda base: (_artifact(base, lambda d: _set(d, ("format_version",), 2)),
                                    r"bad_ctrl\.json: format_version 2 is not supported"),
    "nested 1e5 deep": lambda base: ("[" * 100_000 + "]" * 100_000,
                                     r"bad_ctrl\.json: JSON nested too deep to read"),
    "a control character": lambda base: (_artifact(base, lambda d: _set(d, ("description",), "a\x00b")),
                                         r"bad_ctrl\.json\.description: holds U\+0000"),
}


def _scenario_with_controller(tmp_path: Path, fmu_dir: Path) -> tuple[Path, Path]:
    """A scenario of the plant and the controller ``bad_ctrl``; a folder with the plant's FMU only."""
    folder = tmp_path / "fmus"
    folder.mkdir()
    shutil.copy(fmu_dir / "mrp_satellite.fmu", folder)
    f = tmp_path / "ctrl.toml"
    f.write_text('name = "ctrl"\nstop_time = 1.0\nstep_size = 0.1\n[fmus.plant]\nmodel = "mrp_satellite"\n'
                 '[fmus.controller]\nmodel = "bad_ctrl"\n')
    return f, folder


ARTIFACT_COMMANDS = ["run", "export-ssp", "verify", "l2", "campaign"]


@pytest.mark.parametrize("kind", BAD_ARTIFACTS)
@pytest.mark.parametrize("command", ARTIFACT_COMMANDS)
def test_bad_artifact(command: str, kind: str, tmp_path: Path, home: Path, fmu_dir: Path,
                      capsys: pytest.CaptureFixture) -> None:
    text, message = BAD_ARTIFACTS[kind]("demeter_row1_det" if command == "campaign" else "mrp_hinf_published")
    if text is not None:
        (home / "artifacts" / "bad_ctrl.json").write_text(text)
    out = tmp_path / "out"
    if command == "l2":
        argv = ["analyze", "l2", "bad_ctrl", "--samples", "100"]
    elif command == "campaign":
        argv = ["campaign", "demeter", "--artifact", "bad_ctrl", "--samples", "10", "--chunk", "10", "--workers", "1",
                "--out", out]
    else:
        f, folder = _scenario_with_controller(tmp_path, fmu_dir)
        argv = _scenario_argv(command, f, folder, out)
        message = (rf"{re.escape(str(f))}: fmus\.controller\.model: no FMU bad_ctrl.fmu in {re.escape(str(folder))}, "
                   rf"and it cannot be built: .*{message}")
    err = _fails(argv, message, tmp_path, capsys)
    if text is not None:
        assert str(home / "artifacts" / "bad_ctrl.json") in err


# ----------------------------------------------------------------------------- stale pairs
def _stale_setup(tmp_path: Path, home: Path, fmu_dir: Path, folder: Path) -> tuple[Path, Path, Path]:
    """The plant and the published controller's FMUs in ``folder``, and a user artifact of that
    name (a changed description) that shadows the shipped one the FMU embeds; a scenario of both."""
    folder.mkdir(parents=True, exist_ok=True)
    for name in ("mrp_satellite.fmu", "mrp_hinf_published.fmu"):
        shutil.copy(fmu_dir / name, folder)
    art = home / "artifacts" / "mrp_hinf_published.json"
    art.write_text(_artifact("mrp_hinf_published", lambda d: _set(d, ("description",), "the user's copy")))
    f = tmp_path / "pair.toml"
    f.write_text('name = "pair"\nstop_time = 1.0\nstep_size = 0.1\n'
                 '[fmus.plant]\nmodel = "mrp_satellite"\n[fmus.controller]\nmodel = "mrp_hinf_published"\n'
                 '[[connections]]\nfrom = "plant.sigma"\nto = "controller.sigma"\n'
                 '[[connections]]\nfrom = "plant.omega"\nto = "controller.omega"\n'
                 '[[connections]]\nfrom = "controller.u"\nto = "plant.u"\n')
    return f, folder / "mrp_hinf_published.fmu", art


def _shadow(command: str, art: Path) -> str:
    """The warning that the user's artifact ``art`` shadows the shipped one of its name."""
    return (rf"^satfmu {command}: warning: the artifact {re.escape(str(art))} shadows the shipped artifact "
            rf"{re.escape(str(SHIPPED / art.name))} of the same name")


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_fmus_record_the_artifact_they_embed(fmu_dir: Path) -> None:
    """Both backends embed the artifact file's own bytes and record their SHA-256 beside the build digest."""
    shipped = SHIPPED / "mrp_hinf_published.json"
    for fmu in (fmu_dir / "mrp_hinf_published.fmu", fmu_dir / "mrp_hinf_published_py.fmu"):
        with zipfile.ZipFile(fmu) as z:
            assert z.read("resources/artifact.json") == shipped.read_bytes()
            assert z.comment == (f"satfmu-build sha256:{build_record.built_digest(fmu)} "
                                 f"artifact sha256:{_sha(shipped)}").encode()
        assert (build_record.artifact_digest(fmu) == _sha(shipped)
                and preflight.stale_artifact(fmu, "mrp_hinf_published") is None)
    assert build_record.artifact_digest(fmu_dir / "mrp_satellite.fmu") is None  # a plant embeds no artifact


@pytest.mark.parametrize("command", SCENARIO_COMMANDS)
def test_a_stale_controller_fmu_is_refused_outside_the_cache(command: str, tmp_path: Path, home: Path,
                                                              fmu_dir: Path, capsys: pytest.CaptureFixture) -> None:
    f, fmu, art = _stale_setup(tmp_path, home, fmu_dir, tmp_path / "fmus")
    _fails(_scenario_argv(command, f, tmp_path / "fmus", tmp_path / "out"),
           rf"{re.escape(str(f))}: fmus\.controller\.model: stale FMU: FMU {re.escape(str(fmu))} embeds the artifact "
           rf"sha256:{_sha(SHIPPED / 'mrp_hinf_published.json')[:12]}\.\.\., but the artifact {re.escape(str(art))} is "
           rf"sha256:{_sha(art)[:12]}\.\.\. \(remove the FMU to have it built from the artifact, or pass --allow-stale",
           tmp_path, capsys, warned=_shadow(command, art))


def test_allow_stale_runs_the_fmu_as_it_is(tmp_path: Path, home: Path, fmu_dir: Path,
                                           capsys: pytest.CaptureFixture) -> None:
    f, fmu, art = _stale_setup(tmp_path, home, fmu_dir, tmp_path / "fmus")
    before = fmu.read_bytes()
    assert main(["run", str(f), "--fmu-dir", str(tmp_path / "fmus"), "--out", str(tmp_path / "out"),
                 "--allow-stale"]) == 0
    shadow, _, err = capsys.readouterr().err.partition("\n")
    assert re.search(_shadow("run", art), shadow), shadow
    assert re.fullmatch(r"satfmu run: warning: .*fmus\.controller\.model: stale FMU run as it is \(allow_stale\): "
                        r"FMU .* embeds the artifact sha256:.*\n", err), err
    assert fmu.read_bytes() == before and (tmp_path / "out" / "pair" / "summary_native.json").is_file()


def test_a_stale_controller_fmu_in_the_cache_is_rebuilt(tmp_path: Path, home: Path, fmu_dir: Path,
                                                        capsys: pytest.CaptureFixture) -> None:
    f, fmu, art = _stale_setup(tmp_path, home, fmu_dir, paths.fmu_cache())
    assert main(["run", str(f), "--out", str(tmp_path / "out")]) == 0
    shadow, _, err = capsys.readouterr().err.partition("\n")
    assert re.search(_shadow("run", art), shadow), shadow
    assert re.fullmatch(rf"satfmu run: warning: {re.escape(str(f))}: fmus\.controller\.model: rebuilding the FMU in "
                        rf"the cache: FMU {re.escape(str(fmu))} embeds the artifact sha256:.*, but the artifact "
                        rf"{re.escape(str(art))} is sha256:{_sha(art)[:12]}\.\.\.\n", err), err
    with zipfile.ZipFile(fmu) as z:  # now built from the user's artifact
        assert z.read("resources/artifact.json") == art.read_bytes()
    assert build_record.artifact_digest(fmu) == _sha(art)
    assert main(["run", str(f), "--out", str(tmp_path / "out")]) == 0 and capsys.readouterr().err == ""
