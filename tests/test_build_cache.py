"""Incremental FMU builds: digests of models and builds, no-op rebuilds, atomic writes."""
from __future__ import annotations

import dataclasses
import json
import os
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

from satfmu.fmus import build_record, codegen, description, digest, export, signals
from satfmu.fmus.model import Model, Output, Variable
from satfmu.controllers import catalog, paths

ROOT = Path(__file__).resolve().parents[1]


def _gain_model(gain: float = 2.0, unit: str = "1", name: str = "cache_gain") -> Model:
    k = Variable("k", unit, "Gain", start=gain)
    u = Variable("u", "1", "Input")
    return Model(name, "y = k u", states=[], inputs=[u], parameters=[k],
                 outputs=[Output(Variable("y", "1", "Output"), k.symbol * u.symbol)])


def test_model_digest_sees_every_field_and_nothing_else() -> None:
    base = digest.model_digest(_gain_model())
    assert digest.model_digest(_gain_model()) == base  # a new object of the same definition
    assert digest.model_digest(_gain_model(gain=3.0)) != base  # a default value
    assert digest.model_digest(_gain_model(unit="s")) != base  # a unit only (no equation changes)
    assert digest.model_digest(_gain_model(name="other")) != base
    m = _gain_model()
    m2 = dataclasses.replace(m, outputs=[Output(m.outputs[0].variable, 2 * m.outputs[0].expression)])
    assert digest.model_digest(m2) != base  # an expression
    # the GUID covers the model digest: a changed model never reuses an FMU's GUID, even where its
    # description is the same (an expression changed, no variable)
    for backend in ("native", "python"):
        assert description.fmu_guid(m2, backend) != description.fmu_guid(m, backend), \
            f"{backend}: a changed expression must change the GUID"


def test_model_digest_is_the_same_in_another_process() -> None:
    # sympy's printing order must not depend on the process's hash seed
    code = ("from satfmu.fmus import digest; from satfmu.fmus.plants import mrp_satellite, vscmg; "
            "print(digest.model_digest(mrp_satellite.MODEL), digest.model_digest(vscmg.MODEL))")
    outs = {subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT,
                           env={**os.environ, "PYTHONHASHSEED": seed}).stdout for seed in ("1", "2")}
    assert len(outs) == 1


def test_build_digest_depends_on_resources_backend_and_toolchain() -> None:
    m = _gain_model()
    d = digest.build_digest(m, "native", {"a.json": b"1"}, "gcc 12")
    assert d != digest.build_digest(m, "native", {"a.json": b"2"}, "gcc 12")
    assert d != digest.build_digest(m, "python", {"a.json": b"1"}, "gcc 12")
    assert d != digest.build_digest(m, "native", {"a.json": b"1"}, "gcc 13")
    assert d == digest.build_digest(_gain_model(), "native", {"a.json": b"1"}, "gcc 12")


def test_unchanged_model_is_not_rebuilt_and_a_changed_one_is(tmp_path: Path) -> None:
    for build in (export.build_native, export.build_python):
        fmu = build(_gain_model(), tmp_path)
        stamp = fmu.stat().st_mtime_ns
        assert build_record.built_digest(fmu) is not None
        assert build(_gain_model(), tmp_path) == fmu and fmu.stat().st_mtime_ns == stamp  # no-op
        build(_gain_model(gain=5.0), tmp_path)
        assert fmu.stat().st_mtime_ns != stamp
        with zipfile.ZipFile(fmu) as z:
            assert 'start="5.0"' in z.read("modelDescription.xml").decode()


def test_a_corrupt_or_foreign_fmu_is_rebuilt(tmp_path: Path) -> None:
    fmu = export.build_native(_gain_model(), tmp_path)
    good = fmu.read_bytes()
    fmu.write_bytes(good[: len(good) // 2])  # truncated: no zip directory
    assert build_record.built_digest(fmu) is None
    export.build_native(_gain_model(), tmp_path)
    assert fmu.read_bytes() == good  # deterministic: the same bytes again
    data = bytearray(good)
    data[100] ^= 0xFF  # a flipped byte inside a member: its CRC fails
    fmu.write_bytes(bytes(data))
    assert build_record.built_digest(fmu) is None
    with zipfile.ZipFile(fmu, "a") as z:  # an FMU some other tool wrote: no digest comment
        z.comment = b""
    assert build_record.built_digest(fmu) is None
    assert build_record.built_digest(tmp_path / "missing.fmu") is None


def test_a_failed_build_leaves_no_file(tmp_path: Path) -> None:
    # a compiler that fails (`false`): the error is raised before anything is renamed into place
    with pytest.raises(export.FmuBuildError, match="compiling cache_gain failed"):
        export.build_native(_gain_model(), tmp_path, cc="false")
    assert list(tmp_path.iterdir()) == []


def test_the_cross_compiler_is_part_of_the_digest_and_can_fail_the_build(tmp_path: Path) -> None:
    # another win64 compiler (here gcc, whose identification differs) is another build
    assert export.digest_of(_gain_model(), "native", win64_cc="gcc") != export.digest_of(_gain_model(), "native")
    with pytest.raises(export.FmuBuildError, match="compiling cache_gain failed for win64"):
        export.build_native(_gain_model(), tmp_path, win64_cc="false")
    assert list(tmp_path.iterdir()) == []


def test_lowering_is_shared_and_never_changed_by_its_users() -> None:
    m = _gain_model(gain=7.0)
    guid = description.fmu_guid(m, "native")
    first = codegen.c_source(m, guid)
    assert codegen.functions(m) == codegen.functions(_gain_model(gain=7.0))  # one lowering per digest
    assert codegen.c_source(m, guid) == first  # the C generator appends to a copy, not to the cache


def test_build_all_builds_in_parallel_then_does_nothing(tmp_path: Path, monkeypatch) -> None:
    small = [catalog.FmuSource(signals.constant(), {}, ("native",)), catalog.FmuSource(signals.step(), {}, ("native",)),
             catalog.FmuSource(_gain_model(), {"note.txt": b"resource"})]
    monkeypatch.setattr(catalog, "sources", lambda: small)
    report = catalog.build_all(tmp_path, jobs=2)  # worker processes (fork)
    names = ["signal_constant.fmu", "signal_step.fmu", "cache_gain.fmu", "cache_gain_py.fmu", "cache_gain_fmi3.fmu"]
    assert [p.name for p in report.paths] == names and report.built == report.paths
    assert all(build_record.built_digest(p) for p in report.paths)
    # the same bytes as a build in this process (the zip is deterministic)
    one = export.build_native(signals.step(), tmp_path / "serial")
    assert one.read_bytes() == (tmp_path / "signal_step.fmu").read_bytes()
    again = catalog.build_all(tmp_path)
    assert again.built == [] and again.paths == report.paths
    (tmp_path / "signal_step.fmu").unlink()
    assert [p.name for p in catalog.build_all(tmp_path, jobs=1).built] == ["signal_step.fmu"]


def test_importing_the_catalog_builds_no_model() -> None:
    code = ("import sys; from satfmu.controllers import catalog; "
            "print([m for m in ('sympy', 'satfmu.fmus.plants.vscmg') if m in sys.modules])")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                          cwd=Path(__file__).resolve().parents[1])
    assert proc.stdout.strip() == "[]"


def test_source_by_name_and_its_errors(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    assert catalog.source("signal_step").model.name == "signal_step"
    for name in (*catalog.PLANTS, *catalog.SENSORS, *catalog.GENERIC):  # the names are the models' own
        assert catalog.source(name).model.name == name
    with pytest.raises(ValueError, match="did you mean 'mrp_satellite'"):
        catalog.source("mrp_satelite")
    # a controller by artifact name: the user's artifact first, then the shipped one
    monkeypatch.setenv(paths.HOME_ENV, str(tmp_path))
    shipped = paths.SHIPPED_ARTIFACTS / "cubesat_periodic_published.json"
    assert not catalog.source("cubesat_periodic_published").model.description.startswith("the user's own copy")
    data = json.loads(shipped.read_text())
    data["description"] = "the user's own copy"
    paths.user_artifacts().mkdir(parents=True)
    (paths.user_artifacts() / shipped.name).write_text(json.dumps(data))
    with pytest.warns(paths.ShadowedArtifactWarning, match="shadows the shipped artifact"):
        assert catalog.source("cubesat_periodic_published").model.description.startswith("the user's own copy. "
                                                                                         "Designed")


def test_ensure_builds_only_the_missing_fmus(tmp_path: Path) -> None:
    built = catalog.ensure(tmp_path / "fmus", ["signal_step", "signal_constant", "signal_step"])
    assert list(built) == ["signal_step", "signal_constant"]
    assert all(p.is_file() and p.parent == tmp_path / "fmus" for p in built.values())
    stamp = built["signal_step"].stat().st_mtime_ns
    again = catalog.ensure(tmp_path / "fmus", ["signal_step"])
    assert again == {"signal_step": built["signal_step"]} and built["signal_step"].stat().st_mtime_ns == stamp
    with pytest.raises(ValueError, match="no python FMU"):
        catalog.ensure(tmp_path / "fmus", ["signal_sinusoid"], "python")
    with pytest.raises(ValueError, match="backend must be one of"):
        catalog.ensure(tmp_path / "fmus", ["signal_step"], "java")


def test_build_all_defaults_to_the_fmu_cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(paths.HOME_ENV, str(tmp_path))
    monkeypatch.setattr(catalog, "sources", lambda: [catalog.source("signal_constant")])
    report = catalog.build_all(jobs=1)
    assert report.paths == report.built == [tmp_path / "fmus" / "signal_constant.fmu",
                                            tmp_path / "fmus" / "signal_constant_fmi3.fmu"]
