"""The win64 binary every native FMU carries (issue 28, items 1 and 5).

``satfmu build`` cross-compiles each native FMU's sources with MinGW-w64 into
``binaries/win64/<model>.dll`` beside ``binaries/linux64/<model>.so``. The DLL must load on a bare
Windows (it imports only ``KERNEL32.dll`` and ``msvcrt.dll``) and export every fmi2 function of the
interface its model description declares.
"""
from __future__ import annotations

import re
import subprocess
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import pytest
from fmpy import read_model_description

from fmus import export

OBJDUMP = "x86_64-w64-mingw32-objdump"
"""MinGW-w64's objdump (binutils-mingw-w64-x86-64, installed with the cross compiler)."""
ALLOWED_IMPORTS = {"kernel32.dll", "msvcrt.dll"}
"""The DLLs every Windows has; Windows compares DLL names without case."""
COMMON = ("GetTypesPlatform", "GetVersion", "SetDebugLogging", "Instantiate", "FreeInstance", "SetupExperiment",
          "EnterInitializationMode", "ExitInitializationMode", "Terminate", "Reset", "GetReal", "GetInteger",
          "GetBoolean", "GetString", "SetReal", "SetInteger", "SetBoolean", "SetString", "GetFMUstate",
          "SetFMUstate", "FreeFMUstate", "SerializedFMUstateSize", "SerializeFMUstate", "DeSerializeFMUstate",
          "GetDirectionalDerivative")
"""FMI 2.0 functions of both interfaces (standard, section 2.1): an FMU exports all of them."""
COSIMULATION = ("SetRealInputDerivatives", "GetRealOutputDerivatives", "DoStep", "CancelStep", "GetStatus",
                "GetRealStatus", "GetIntegerStatus", "GetBooleanStatus", "GetStringStatus")
"""FMI 2.0 functions of the co-simulation interface (section 4.2)."""
MODEL_EXCHANGE = ("EnterEventMode", "NewDiscreteStates", "EnterContinuousTimeMode", "CompletedIntegratorStep",
                  "SetTime", "SetContinuousStates", "GetDerivatives", "GetEventIndicators", "GetContinuousStates",
                  "GetNominalsOfContinuousStates")
"""FMI 2.0 functions of the model-exchange interface (section 3.2)."""

def _native_fmus(fmu_dir: Path) -> list[Path]:
    native = sorted(p for p in fmu_dir.glob("*.fmu") if not p.stem.endswith(export.PYTHON_SUFFIX))
    assert len(native) >= 10, f"only {len(native)} native FMUs in {fmu_dir}: the catalog was not built"
    return native


def pe_tables(dll: Path) -> tuple[set[str], set[str]]:
    """The DLLs a PE file imports and the names it exports, read with MinGW-w64's objdump.

    Parameters
    ----------
    dll : Path

    Returns
    -------
    tuple of (set of str, set of str)
        The imported DLL names (as written in the file) and the exported function names.
    """
    proc = subprocess.run([OBJDUMP, "-p", str(dll)], capture_output=True, text=True)
    assert proc.returncode == 0, f"{OBJDUMP} -p {dll.name} failed: {proc.stderr}"
    imports = set(re.findall(r"^\s*DLL Name: (\S+)\s*$", proc.stdout, re.MULTILINE))
    exports = set(re.findall(r"^\s*\[\s*\d+\]\s+([A-Za-z_]\w*)\s*$", proc.stdout, re.MULTILINE))
    return imports, exports


def needed_functions(description: bytes) -> set[str]:
    """The fmi2 functions an FMU whose ``modelDescription.xml`` is ``description`` must export:
    the common ones and those of each interface it declares."""
    root = ET.fromstring(description)
    names = list(COMMON)
    if root.find("CoSimulation") is not None:
        names += COSIMULATION
    if root.find("ModelExchange") is not None:
        names += MODEL_EXCHANGE
    return {"fmi2" + n for n in names}


@pytest.fixture(scope="module")
def unpacked(fmu_dir: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Every native FMU extracted, by model name."""
    root = tmp_path_factory.mktemp("win64_fmus")
    out = {}
    for fmu in _native_fmus(fmu_dir):
        with zipfile.ZipFile(fmu) as z:
            z.extractall(root / fmu.stem)
        out[fmu.stem] = root / fmu.stem
    return out


def test_every_native_fmu_carries_both_binaries(fmu_dir: Path) -> None:
    """``binaries/`` holds exactly ``linux64/<model>.so`` and ``win64/<model>.dll``, named by the
    model identifier, in every native FMU."""
    wrong = {}
    for fmu in _native_fmus(fmu_dir):
        with zipfile.ZipFile(fmu) as z:
            identifier = read_model_description(str(fmu)).coSimulation.modelIdentifier
            binaries = sorted(n for n in z.namelist() if n.startswith("binaries/"))
        expected = [f"binaries/linux64/{identifier}.so", f"binaries/win64/{identifier}.dll"]
        if binaries != expected:
            wrong[fmu.name] = binaries
    assert not wrong, f"native FMUs without exactly a linux64 and a win64 binary: {wrong}"


def test_dlls_import_only_kernel32_and_msvcrt(unpacked: dict[str, Path]) -> None:
    """No DLL needs a library a bare Windows lacks (libgcc, libwinpthread, a newer C runtime)."""
    extra = {}
    for name, folder in unpacked.items():
        imports, _ = pe_tables(folder / "binaries" / "win64" / f"{name}.dll")
        assert imports, f"{name}: no import read from objdump -p (the parser, not the DLL, is wrong)"
        if {i.lower() for i in imports} - ALLOWED_IMPORTS:
            extra[name] = sorted(imports)
    assert not extra, f"DLLs importing more than KERNEL32.dll and msvcrt.dll: {extra}"


def test_dlls_export_every_fmi2_function_the_description_needs(unpacked: dict[str, Path]) -> None:
    """Each DLL exports every function of the interfaces its model description declares (the
    wrapper's FMI2_Export is dllexport under _WIN32), and nothing but fmi2 functions."""
    wrong = {}
    for name, folder in unpacked.items():
        _, exports = pe_tables(folder / "binaries" / "win64" / f"{name}.dll")
        needed = needed_functions((folder / "modelDescription.xml").read_bytes())
        missing, foreign = needed - exports, {e for e in exports if not e.startswith("fmi2")}
        if missing or foreign:
            wrong[name] = {"missing": sorted(missing), "not fmi2": sorted(foreign)}
    assert not wrong, f"DLL exports not those of the model description's interfaces: {wrong}"
