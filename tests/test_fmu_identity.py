"""FMU identity (issue 28, defect 4): GUID, modelName and version of every modelDescription.xml.

The GUID identifies the model description (:func:`satfmu.fmus.description.description_guid`): the native
and the pythonfmu FMU of one model differ, two builds of the same sources agree, and each FMU
requires its own GUID (each twin refuses the other's). modelName is the model's name for
both backends; ``version`` is ``<satfmu version>+<16 hex digits of the model digest>``
(``docs/fmus-in-your-tool.md``, "GUID, modelName and version").
"""
from __future__ import annotations

import json
import re
import subprocess
import sys
import uuid
import zipfile
from pathlib import Path
from xml.etree.ElementTree import fromstring

import pytest
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave

from satfmu.fmus import __version__, codegen, description, export, signals
from satfmu.fmus.plants import mrp_satellite
from satfmu.fmus.digest import model_digest
from satfmu.sims.cosim import fmi_host

ROOT = Path(__file__).resolve().parents[1]
VERSION = re.compile(re.escape(__version__) + r"\+[0-9a-f]{16}")
"""The documented form of the ``version`` attribute."""


def _root(fmu: Path):
    """The ``fmiModelDescription`` element of an FMU file."""
    with zipfile.ZipFile(fmu) as z:
        return fromstring(z.read("modelDescription.xml"))


def _pairs(fmu_dir: Path) -> list[tuple[Path, Path]]:
    """Every (native, pythonfmu) pair of FMUs of one model in ``fmu_dir``."""
    return [(p, p.with_name(p.stem + export.PYTHON_SUFFIX + ".fmu")) for p in sorted(fmu_dir.glob("*.fmu"))
            if (p.with_name(p.stem + export.PYTHON_SUFFIX + ".fmu")).is_file()]


def test_every_model_has_two_guids_one_name_one_version(fmu_dir: Path) -> None:
    pairs = _pairs(fmu_dir)
    assert len(pairs) >= 14, f"expected the catalog's 14 models with both backends, found {len(pairs)}"
    guids: dict[str, Path] = {}
    for native, python in pairs:
        n, p = _root(native), _root(python)
        assert n.get("guid") != p.get("guid"), f"{native.name} and {python.name} share the GUID {n.get('guid')}"
        # modelName: the model's name for both (FMI 2.0: the model's name in the generating tool)
        assert n.get("modelName") == p.get("modelName") == native.stem, f"{native.stem}: modelName differs"
        assert n.find("CoSimulation").get("modelIdentifier") == native.stem
        assert p.find("CoSimulation").get("modelIdentifier") == python.stem
        # version: one model, one satfmu: the same version on both backends
        assert VERSION.fullmatch(n.get("version") or ""), f"{native.name}: version {n.get('version')!r}"
        assert n.get("version") == p.get("version"), f"{native.stem}: the backends' versions differ"
        for fmu, root in ((native, n), (python, p)):
            guid = root.get("guid")
            assert uuid.UUID(guid).version == 5, f"{fmu.name}: {guid} is not a name-based UUID"
            assert guid not in guids, f"{fmu.name} has the GUID of {guids.get(guid)}"
            guids[guid] = fmu


def test_every_fmu_has_a_version(fmu_dir: Path) -> None:
    fmus = sorted(fmu_dir.glob("*.fmu"))
    assert fmus, f"no FMU in {fmu_dir}"
    versions = {f.name: _root(f).get("version") for f in fmus}
    missing = [f"{name}: {v!r}" for name, v in versions.items() if not VERSION.fullmatch(v or "")]
    assert not missing, f"version is not <satfmu version>+<16 hex digits>: {missing}"


def test_version_is_the_satfmu_version_and_the_model_digest(fmu_dir: Path) -> None:
    for model in (mrp_satellite.MODEL, signals.step()):
        version = _root(fmu_dir / f"{model.name}.fmu").get("version")
        assert version == f"{__version__}+{model_digest(model)[:16]}", f"{model.name}: version {version!r}"
    # a changed model gets another version; the satfmu part stays
    other = mrp_satellite.build(omega_0=(0.1, 0, 0))
    assert description.model_version(other) != description.model_version(mrp_satellite.MODEL)
    assert description.model_version(other).startswith(__version__ + "+")


def test_the_guid_identifies_the_description() -> None:
    model = mrp_satellite.MODEL
    for backend in (description.NATIVE, description.PYTHON):
        root = description.model_description(model, description.capabilities(model, backend))
        guid = root.get("guid")
        assert description.description_guid(model, root) == guid == description.fmu_guid(model, backend)
        # any change of the description changes it (here an attribute a tool shows, the description)
        root.set("description", root.get("description") + ".")
        assert description.description_guid(model, root) != guid, f"{backend}: the GUID ignores the description"
    with pytest.raises(ValueError, match="unknown backend 'java'"):
        description.capabilities(model, "java")


_BUILD = """
import sys
from pathlib import Path
from satfmu.controllers import catalog
dest = Path(sys.argv[1])
for backend in ("native", "python"):
    catalog.ensure(dest, ["mrp_satellite", "cubesat_periodic_published"], backend)
"""


def test_guids_are_stable_across_builds_from_scratch(tmp_path: Path) -> None:
    """Two builds of the same models, each in a new process into an empty folder: the same GUIDs
    (and the same files), and the native binary holds its description's GUID."""
    folders = [tmp_path / "a", tmp_path / "b"]
    for folder in folders:
        subprocess.run([sys.executable, "-c", _BUILD, str(folder)], check=True, cwd=ROOT, capture_output=True,
                       timeout=600)
    names = sorted(p.name for p in folders[0].glob("*.fmu"))
    assert names == ["cubesat_periodic_published.fmu", "cubesat_periodic_published_py.fmu",
                     "mrp_satellite.fmu", "mrp_satellite_py.fmu"]
    for name in names:
        a, b = (_root(folder / name).get("guid") for folder in folders)
        assert a == b, f"{name}: GUID {a} in one build, {b} in the other"
        assert (folders[0] / name).read_bytes() == (folders[1] / name).read_bytes(), f"{name}: the builds differ"
    for stem in ("mrp_satellite", "cubesat_periodic_published"):
        guid = _root(folders[0] / f"{stem}.fmu").get("guid")
        with zipfile.ZipFile(folders[0] / f"{stem}.fmu") as z:
            binary = z.read(f"binaries/linux64/{stem}.so")
            header = z.read(f"sources/{codegen.C_HEADER}").decode()
        assert guid.encode() in binary, f"{stem}: the binary does not hold its GUID {guid}"
        assert f'#define MODEL_GUID "{guid}"' in header
        # the FMU state's identity: the GUID's 16 bytes
        assert ", ".join(f"0x{b:02x}" for b in uuid.UUID(guid).bytes) in header
        # the pythonfmu module's GUID (its FMU states carry it) is its own FMU's
        py_guid = _root(folders[0] / f"{stem}_py.fmu").get("guid")
        with zipfile.ZipFile(folders[0] / f"{stem}_py.fmu") as z:
            module = z.read(f"resources/satfmu_gen_{stem}.py").decode()
        assert f"GUID = {py_guid!r}" in module, f"{stem}_py: the generated module holds another GUID"


def _instantiate(fmu: Path, guid: str) -> tuple[bool, str]:
    """Instantiate ``fmu`` (logging on) with ``guid``: (an instance was returned, the log)."""
    md = read_model_description(str(fmu))
    callbacks = fmi_host.Callbacks()
    slave = FMU2Slave(guid=guid, unzipDirectory=str(extract(str(fmu))),
                      modelIdentifier=md.coSimulation.modelIdentifier, instanceName="identity")
    try:
        slave.instantiate(callbacks=callbacks.functions, loggingOn=True)
    except Exception as exc:  # fmpy raises when fmi2Instantiate returns NULL
        if "Failed to instantiate" not in str(exc):
            raise
        return False, callbacks.text()
    slave.freeInstance()
    return True, callbacks.text()


def test_each_twin_refuses_the_guid_of_the_other(fmu_dir: Path) -> None:
    """The native FMU and the pythonfmu FMU of one model each instantiate with their own GUID and
    refuse the other's with NULL and the reason (the native binary and the pythonfmu FMU's C layer,
    ``fmus/c/pythonfmu_shim.c``, compare with their own GUID; pythonfmu 0.7.0 alone ignores it,
    which ``tests/test_pythonfmu_upstream.py`` tracks)."""
    native, python = fmu_dir / "mrp_satellite.fmu", fmu_dir / "mrp_satellite_py.fmu"
    guids = {native: _root(native).get("guid"), python: _root(python).get("guid")}
    assert guids[native] != guids[python], f"the twins share the GUID {guids[native]}"
    for fmu, twin in ((native, python), (python, native)):
        own, other = guids[fmu], guids[twin]
        ok, log = _instantiate(fmu, own)
        assert ok, f"{fmu.name} refused its own GUID: {log}"
        ok, log = _instantiate(fmu, other)
        assert not ok, f"{fmu.name} accepted the GUID of {twin.name}"
        assert f"GUID '{other}' does not match '{own}'" in log, f"{fmu.name}: no reason logged: {log}"


def test_states_carry_the_guid_and_the_two_backends_reject_each_others(fmu_dir: Path) -> None:
    """A pythonfmu FMU state names its FMU's GUID; a state the other backend's generated module
    would write (its GUID) is refused."""
    model = mrp_satellite.MODEL
    gen = codegen.load_python(model)
    built = _root(fmu_dir / "mrp_satellite_py.fmu").get("guid")
    assert gen.GUID == description.fmu_guid(model, description.PYTHON) == built, "the module's GUID is not its FMU's"
    state = {"model": gen.NAME, "guid": description.fmu_guid(model, description.NATIVE), "format": 1,
             "content": {}, "crc32": 0}
    from satfmu.fmus.pyslave import SatfmuSlave

    class Slave(SatfmuSlave):
        generated = gen

    problem = Slave._state_problem(json.loads(json.dumps(state)))
    assert problem is not None and "not a state of this FMU" in problem and state["guid"] in problem, problem
