"""The robustness suite of ``satfmu.sims.robustness`` over every built FMU, and that it reports failures.

The suite runs each FMU's cases in child processes; these tests check its verdicts (0 failures
and 0 crashes on the FMUs built from the current tree) and that a broken FMU, an FMU that
violates its own model description, and a worker that dies are reported as such.
"""
from __future__ import annotations

import re
import shutil
import zipfile
from pathlib import Path

import pytest

from satfmu.sims import robustness
from satfmu.sims.robustness import CASES, CYCLES_CASE, NATIVE, PYTHONFMU, SuiteResult, rss_bound_kib
from satfmu.sims.robustness.target import discover

FAST_CYCLES = 100
"""Instantiate/free cycles of the fast run (1000 take ~2 min more, mostly demeter_flexible_py at
48 ms per cycle); the RSS bound scales with them (rss_bound_kib)."""
PLANT = "mrp_satellite.fmu"


def _check_clean(report: SuiteResult, fmus: list[str], cycles: int) -> None:
    """Every FMU of ``satfmu.fmus`` ran every case, with no failure, no crash and RSS within bound."""
    bad = [f"{r.fmu} / {r.case}: {r.verdict} {r.detail}" for r in report.failures + report.crashes]
    assert not bad, "\n".join(bad)
    # discovery: every FMU asked for is covered, each with one row per case
    assert sorted(report.fmus) == sorted(fmus)
    assert len(report.rows) == len(report.fmus) * len(CASES)
    for backend in (NATIVE, PYTHONFMU):
        growth = report.rss_growth_kib(backend)
        # the cycles case ran on every FMU of the backend (it is never n/a) ...
        assert set(growth) == {r.fmu for r in report.rows if r.backend == backend}
        # ... and the suite's verdict already includes the bound; checked here explicitly too
        assert max(growth.values()) <= rss_bound_kib(backend, cycles)
    # cases that need no particular variable are never n/a (n/a only means "no such variable")
    unconditional = {c.name for c in CASES if c.applies is robustness.always_applies}
    assert not [r for r in report.rows if r.verdict == "n/a" and r.case in unconditional]


FAST_FMUS = ["mrp_satellite", "mrp_satellite_py", "cubesat_bdot", "vscmg_sdre_online", "vscmg_sdre_online_py",
             "demeter_flexible"]
"""The fast run's FMUs: each backend, an expression sampler, a routine sampler (C and Python), the
exact integrator."""


FAST_FLIPS = 8
"""Bit flips per FMU state in the fast run (a seeded sample; the full run flips every bit of each
FMU state: ~1 s for the largest native one, demeter_flexible's 10,368 bits)."""


def test_suite_over_one_fmu_of_each_kind(fmu_dir: Path, tmp_path: Path) -> None:
    """All cases, 100 cycles, 8 bit flips, on :data:`FAST_FMUS` (24 s alone, 45 s beside another test
    process on 2 CPUs; a third of it the online SDRE's far step): no failure, no crash."""
    report = robustness.run(fmu_dir, FAST_FMUS, cycles=FAST_CYCLES, out=tmp_path / "robustness", flips=FAST_FLIPS)
    _check_clean(report, FAST_FMUS, FAST_CYCLES)
    table = (tmp_path / "robustness.md").read_text()
    assert "| case |" in table and "FAIL" not in table and "| CRASH |" not in table
    # one CSV line per row plus the header
    assert len((tmp_path / "robustness.csv").read_text().splitlines()) == len(report.rows) + 1
    # pythonfmu 0.7.0 alone crashes in three host-level cases (docs/pythonfmu.md): the pythonfmu
    # FMUs' C layer refuses them as the native FMUs do
    host = ("instantiate: resources no folder", "instantiate: NULL name", "setDebugLogging: NULL category")
    assert all(r.verdict == "pass" and r.got == "Error" for r in report.rows if r.case in host[1:])
    assert all(r.verdict == "pass" for r in report.rows if r.case == host[0])


@pytest.mark.slow
def test_suite_over_every_fmu(fmu_dir: Path, tmp_path: Path) -> None:
    """All cases on all FMUs of the session's build, 100 cycles, every bit of each FMU state flipped:
    no failure, no crash (~7 min on 2 loaded CPUs, most of it the refused bit flips)."""
    report = robustness.run(fmu_dir, cycles=FAST_CYCLES, out=tmp_path / "robustness")
    _check_clean(report, [p.stem for p in discover(fmu_dir)], FAST_CYCLES)


@pytest.mark.slow
def test_suite_over_every_fmu_full(fmu_dir: Path, tmp_path: Path) -> None:
    """The issue's run: 1,000 instantiate/free cycles per FMU (489 s for docs/robustness.md)."""
    report = robustness.run(fmu_dir, cycles=1000, out=tmp_path / "robustness")
    _check_clean(report, [p.stem for p in discover(fmu_dir)], 1000)


def _copy_fmu(src: Path, dest: Path, edit: dict[str, bytes]) -> Path:
    """A copy of the FMU ``src`` at ``dest`` with the archive members of ``edit`` replaced."""
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(dest, "w", zipfile.ZIP_DEFLATED) as zout:
        for item in zin.infolist():
            zout.writestr(item, edit.get(item.filename, zin.read(item.filename)))
    return dest


def test_broken_binary_fails_every_case(fmu_dir: Path, tmp_path: Path) -> None:
    """A native FMU whose shared library is garbage cannot be loaded: every case that applies FAILs
    (none passes, none is a crash: loading fails with an exception, caught per case)."""
    src = fmu_dir / PLANT
    with zipfile.ZipFile(src) as z:
        binary = next(n for n in z.namelist() if n.startswith("binaries/linux64/"))
    broken = _copy_fmu(src, tmp_path / "broken_plant.fmu", {binary: b"\x7fELF garbage" * 100})
    # 5 cycles and a far step of 1 default step: these tests are about the verdicts, not the sizes
    report = robustness.run(tmp_path, cycles=5, far_factor=1.0)
    assert report.fmus == ["broken_plant"]  # discovered by its file name alone
    # every case that applies to mrp_satellite fails (n/a: no sample period, fewer than two time
    # parameters, decided from the model description alone)
    ran = [r for r in report.rows if r.verdict != "n/a"]
    assert {r.verdict for r in ran} == {"fail"} and len(ran) >= len(report.rows) - 2
    assert all("cannot instantiate" in r.detail for r in ran)
    assert robustness.main(["--fmu-dir", str(tmp_path), "--cycles", "5", "--far-factor", "1"]) == 1
    assert broken.exists()


def test_fmu_violating_its_description_fails(fmu_dir: Path, tmp_path: Path) -> None:
    """An FMU whose modelDescription.xml declares a maximum its binary does not enforce: the
    binary accepts the out-of-range value, so "parameter > max" FAILs (status OK, not Error)."""
    src = fmu_dir / PLANT
    with zipfile.ZipFile(src) as z:
        xml = z.read("modelDescription.xml").decode()
    # I_x (the first parameter, start 15) gets max = 20 kg m^2; the C code still allows up to +inf
    edited, n = re.subn(r'(name="I_x".*?<Real\b)', r'\1 max="20.0"', xml, count=1, flags=re.DOTALL)
    assert n == 1
    _copy_fmu(src, tmp_path / "lying_plant.fmu", {"modelDescription.xml": edited.encode()})
    report = robustness.run(tmp_path, cycles=5, far_factor=1.0)
    rows = {r.case: r for r in report.rows}
    assert rows["parameter > max"].verdict == "fail"
    assert rows["parameter > max"].got == "OK" and "expected Error" in rows["parameter > max"].detail
    # everything else still passes: the failure is that one case, not a broken run
    assert [r.case for r in report.failures] == ["parameter > max"] and not report.crashes


def test_worker_crash_is_reported_and_the_rest_runs(fmu_dir: Path, tmp_path: Path,
                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    """A worker that dies (os.abort through the test hook) in one case: that case is a CRASH with the
    signal, and every other case still runs, in a new worker, and passes."""
    victim = "doStep h < 0"  # in the middle of the list: cases before and after it must run
    monkeypatch.setenv(robustness.ABORT_ENV, victim)
    fmus = tmp_path / "fmus"
    fmus.mkdir()
    shutil.copy(fmu_dir / PLANT, fmus)
    report = robustness.run(fmus, cycles=5, out=tmp_path / "rob", far_factor=1.0)
    rows = {r.case: r for r in report.rows}
    assert rows[victim].verdict == "crash" and rows[victim].got == "CRASH"
    assert "SIGABRT" in rows[victim].detail and "during this case" in rows[victim].detail
    assert [r.case for r in report.crashes] == [victim] and not report.failures
    assert {r.verdict for c, r in rows.items() if c != victim} == {"pass", "n/a"}
    assert rows[CYCLES_CASE].metrics["rss_growth_kib"] <= rss_bound_kib(NATIVE, 5)  # the last case ran
    assert "| doStep h < 0 | CRASH |" in (tmp_path / "rob.md").read_text()
    assert not list(tmp_path.glob("*.tmp"))  # written atomically: no temporary file left
    assert robustness.main(["--fmu-dir", str(fmus), "--cycles", "5", "--far-factor", "1"]) == 1


def test_the_suite_drives_fmi2_cosimulation_fmus_only(fmu_dir: Path, capsys: pytest.CaptureFixture) -> None:
    """Its cases are FMI 2.0 co-simulation calls: the FMI 3.0 and model-exchange FMUs of a folder are
    left out, and naming one is refused with the reason (exit 2)."""
    from satfmu.sims.robustness.command import main

    found = {p.name for p in discover(fmu_dir)}
    assert "mrp_satellite.fmu" in found and "mrp_satellite_py.fmu" in found
    assert not {n for n in found if n.endswith(("_fmi3.fmu", "_me.fmu"))}
    assert main(["--fmu-dir", str(fmu_dir), "--fmu", "mrp_satellite_me", "--fmu", "cubesat_bdot_fmi3"]) == 2
    err = capsys.readouterr().err
    assert "mrp_satellite_me.fmu is a model-exchange FMU; cubesat_bdot_fmi3.fmu is an FMI 3.0 FMU" in err
