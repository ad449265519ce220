"""The win64 binary every native FMU carries (issue 28, items 1 and 5).

``satfmu build`` cross-compiles each native FMU's sources with MinGW-w64 into
``binaries/win64/<model>.dll`` beside ``binaries/linux64/<model>.so``. The DLL must load on a bare
Windows (it imports only ``KERNEL32.dll`` and ``msvcrt.dll``), export every fmi2 function of the
interface its model description declares, and compute what the Linux binary computes: our own host
(``tests/host/fmu_host.c``, one source compiled natively and with MinGW-w64) runs the same plan on
the DLL under wine and on the ``.so``, and the Linux host runs it as fmpy does.
"""
from __future__ import annotations

import math
import os
import re
import shutil
import subprocess
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import pytest
from fmpy import read_model_description
from fmpy.fmi2 import FMU2Slave
from fmpy.model_description import ModelDescription

from satfmu.fmus import codegen, export
from satfmu.fmus.description3 import FMI3_SUFFIX
from satfmu.fmus.description_me import ME_SUFFIX
from satfmu.sims.cosim import fmi_host

HOST = Path(__file__).resolve().parent / "host" / "fmu_host.c"
HOST_FLAGS = ("-std=c99", "-O2", "-Wall", "-Wextra", "-Werror")
"""The host's compiler flags on both platforms (the FMU build's warnings-as-errors)."""
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

STEPS = 60
"""Communication steps of a plan, each the FMU's default step (0.6 s to 15 h of simulated time)."""
DRIVE = 0.1
"""Relative amplitude of an input's sinusoid: this times its start value, or its unit's scale."""
UNIT_SCALE = {"T": 5e-5, "N.m": 1e-3}
"""Scale of an input whose start value is 0, by unit (default 1): the geomagnetic field is ~50 uT; a
torque of 1 mN m turns the 2 g m2 cubesat by ~1 rad/s at most in the plan (0.1 N m would spin its
RK4 substeps out of stability)."""
PARAMETERS = {
    "mrp_satellite": {"sigma_0[1]": 0.5992, "sigma_0[2]": -0.7976, "sigma_0[3]": 0.6517, "omega_0[2]": 0.02,
                      "saturation_on": True, "shadow_switching": True, "n_substeps": 7},
    "mrp_hinf_published": {"saturation_on": True, "u_max": 0.5},
    "magnetorquer_cubesat": {"saturation_on": True},
    "vscmg": {"q4_0": 0.3},
    "vscmg_backstepping": {"compensation_on": True},
    "vscmg_lq_servo": {"compensation_on": True},
    "vscmg_sdre_approx": {"compensation_on": True},
    "demeter_flexible": {"wheels_on": False},
    "signal_constant": {"value": 0.25},
    "signal_sinusoid": {"frequency_Hz": 0.3, "phase_rad": 0.5},
    "signal_cosine_ramp": {"derivative": 1},
}
"""Parameter values a plan sets (the seeds' 200 deg attitude, saturation, friction compensation,
...), so that the comparison also covers the parameter calls and the branches they select."""
RTOL_WINE = 2.0 ** -51
"""Tolerance of win64 under wine against linux64 (~4.4e-16, 2 ulp), relative to the larger of the
value and its output's largest magnitude in the run. Both binaries run the same C with SSE2 doubles
(gcc -O2, no FMA contraction on baseline x86-64); only the libm functions differ: the DLL carries
MinGW-w64's (x87 fsin and fcos, its atan, pow, exp and log), which round some results an ulp away
from glibc's, and whose sin and cos lose relative accuracy near their zeros (x87's 66-bit pi:
sin(pi) is 1.22460635e-16, glibc's 1.22464680e-16, 4e-21 apart), values that are rounding noise of
their output. Measured: 15 of 20 native FMUs identical; mrp_satellite and magnetorquer_cubesat 3
values each 1 ulp apart (<= 2.0e-16 of the value); signal_cosine_ramp's derivative at the ramp's
end (sin(pi) there) 6.4e-21 apart, 4.0e-21 of its output's magnitude; the same in both
:data:`X87_MODES`."""
ITERATIVE_RTOL = 1e-9
"""Tolerance, relative to the output's largest magnitude in the run, of an FMU whose sampler solves
an equation at run time (its ``sources/`` carry the sampler's C routine beside ``model.h``: the
native online SDRE's ``riccati.h``). Both builds converge to the same unique Riccati solution, but
their iterates part at the first libm rounding that differs (exp and log of the sign iteration's
determinant scaling), so they stop at other points within the solve's accuracy (relative residual
checked <= 1e-8; gains within 6.2e-9 of scipy's). Measured: the commands 1.3e-11 (x87 0x37F) and
8.8e-11 (x87 0x27F) of their magnitude apart at most, the tracking errors e_q2, e_q4 identical."""
NOISE_ATOL = {"riccati_residual": 1e-14, "riccati_max_re": 1e-14}
"""Absolute tolerance of outputs that are rounding noise of an exact 0 here: the Riccati solution's
relative residual (1) and the real part (1/s) of the uncontrollable mode at 0, sums of a few ulp
of the matrices' entries (~1). Measured: at most 2.0e-15 apart (their checks: 1e-8 and 1e-6)."""


def _native_fmus(fmu_dir: Path) -> list[Path]:
    """The native FMI 2.0 FMUs of the folder (the FMI 3.0 ones: tests/test_fmi3.py)."""
    native = sorted(p for p in fmu_dir.glob("*.fmu") if not p.stem.endswith((export.PYTHON_SUFFIX, FMI3_SUFFIX)))
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
            md = read_model_description(str(fmu))
            identifier = (md.coSimulation or md.modelExchange).modelIdentifier
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


def plan_values(md: ModelDescription) -> tuple[dict, list[int], list[int], list[list[float]]]:
    """The run of :data:`STEPS` steps a plan gives ``md``'s FMU.

    Returns
    -------
    tuple
        The parameters set (value reference -> (type, value)) from :data:`PARAMETERS`, the Real
        input and output value references, and per step the inputs: ``start + a sin(0.7 k + i)``
        for input i at step k, a = :data:`DRIVE` times ``|start|`` or the unit's scale, kept
        within the declared range.
    """
    variables = {v.name: v for v in md.modelVariables}
    parameters = {variables[n].valueReference: (variables[n].type, value)
                  for n, value in PARAMETERS.get(md.modelName, {}).items()}
    inputs = [v for v in md.modelVariables if v.causality == "input" and v.type == "Real"]
    outputs = [v.valueReference for v in md.modelVariables if v.causality == "output" and v.type == "Real"]
    rows = []
    for k in range(STEPS):
        row = []
        for i, v in enumerate(inputs):
            start = float(v.start or 0.0)
            value = start + DRIVE * (abs(start) or UNIT_SCALE.get(v.unit or "", 1.0)) * math.sin(0.7 * k + i)
            low = float(v.min) if v.min is not None else -math.inf
            high = float(v.max) if v.max is not None else math.inf
            row.append(min(max(value, low), high))
        rows.append(row)
    return parameters, [v.valueReference for v in inputs], outputs, rows


def write_plan(md: ModelDescription, resources_uri: str, path: Path) -> None:
    """Write the plan of ``md``'s FMU (:func:`plan_values`) in the host's format (its header
    comment, ``tests/host/fmu_host.c``), every number exact (hexadecimal floating form)."""
    parameters, inputs, outputs, rows = plan_values(md)
    lines = [f"guid {md.guid}", f"resources {resources_uri}", f"step {float(md.defaultExperiment.stepSize).hex()}",
             f"parameters {len(parameters)}"]
    lines += [f"{kind.lower()} {vr} {float(value).hex()}" for vr, (kind, value) in parameters.items()]
    lines += [" ".join(["inputs", str(len(inputs)), *map(str, inputs)]),
              " ".join(["outputs", str(len(outputs)), *map(str, outputs)]), f"steps {len(rows)}"]
    lines += [" ".join(float(u).hex() for u in row) for row in rows]
    path.write_text("\n".join(lines) + "\n")


def read_rows(text: str) -> list[list[float]]:
    """The host's output: per communication point the time and every output (CRLF or LF lines)."""
    return [[float(x) for x in line.split()] for line in text.splitlines() if line.strip()]


def compile_host(cc: str, out: Path, extra: tuple[str, ...]) -> Path:
    """Compile :data:`HOST` with ``cc`` into ``out`` (``extra``: the platform's flags and libraries)."""
    proc = subprocess.run([cc, *HOST_FLAGS, f"-I{export.fmi_headers()}", "-o", str(out), str(HOST), *extra],
                          capture_output=True, text=True)
    assert proc.returncode == 0, f"{cc} could not compile the host:\n{proc.stderr}"
    return out


def run_linux_host(host: Path, folder: Path, name: str) -> list[list[float]]:
    """The native host's rows for the model ``name`` extracted in ``folder`` (its ``plan.txt``)."""
    md = read_model_description(str(folder))
    write_plan(md, (folder / "resources").as_uri(), folder / "plan.txt")
    proc = subprocess.run([str(host), str(folder / "binaries" / "linux64" / f"{name}.so"), str(folder / "plan.txt")],
                          capture_output=True, text=True)
    assert proc.returncode == 0, f"{name}: the linux64 host failed:\n{proc.stderr}"
    return read_rows(proc.stdout)


def run_fmpy(folder: Path) -> list[list[float]]:
    """The rows fmpy gives for the plan of the FMU extracted in ``folder``: the host's calls, in
    its order (parameters, experiment set-up, initialization, then per step inputs, outputs, step)."""
    md = read_model_description(str(folder))
    parameters, inputs, outputs, plan_rows = plan_values(md)
    h = float(md.defaultExperiment.stepSize)
    slave = FMU2Slave(guid=md.guid, unzipDirectory=str(folder), modelIdentifier=md.coSimulation.modelIdentifier,
                      instanceName="host")
    callbacks = fmi_host.Callbacks()
    slave.instantiate(callbacks=callbacks.functions)
    for vr, (kind, value) in parameters.items():
        {"Real": slave.setReal, "Integer": slave.setInteger, "Boolean": slave.setBoolean}[kind]([vr], [value])
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    slave.exitInitializationMode()
    rows = []
    for k, u in enumerate(plan_rows):
        if inputs:
            slave.setReal(inputs, u)
        rows.append([k * h, *slave.getReal(outputs)])
        status, _ = fmi_host.attempt(slave, "doStep", k * h, h)
        assert status == fmi_host.OK, f"{md.modelName}: step {k} refused: {callbacks.text()}"
    rows.append([len(plan_rows) * h, *slave.getReal(outputs)])
    slave.terminate()
    slave.freeInstance()
    return rows


@pytest.fixture(scope="module")
def linux_host(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The host compiled natively (dlopen)."""
    return compile_host("gcc", tmp_path_factory.mktemp("host") / "fmu_host", ("-ldl",))


def _cosimulation(unpacked: dict[str, Path]) -> dict[str, Path]:
    """The co-simulation FMUs among ``unpacked`` (the host is a co-simulation host; the plants'
    model exchange: tests/test_model_exchange.py)."""
    return {name: folder for name, folder in unpacked.items() if not name.endswith(ME_SUFFIX)}


def test_linux_host_gives_fmpys_outputs(unpacked: dict[str, Path], linux_host: Path) -> None:
    """On every native co-simulation FMU, the host and fmpy, making the same calls on the same linux64
    binary, give the same outputs bit for bit (the host reads its plan and prints %.17g exactly), not
    all 0."""
    for name, folder in _cosimulation(unpacked).items():
        host_rows = run_linux_host(linux_host, folder, name)
        fmpy_rows = run_fmpy(folder)
        assert len(host_rows) == STEPS + 1, f"{name}: {len(host_rows)} rows from the host, {STEPS + 1} expected"
        assert host_rows == fmpy_rows, f"{name}: the linux64 host and fmpy give other outputs on the same plan"
        assert any(y != 0.0 for row in host_rows for y in row[1:]), (f"{name}: every output is 0: "
                                                                      "the plan proves nothing")


def tolerances(folder: Path) -> list[tuple[float, float]]:
    """(rtol, atol) of each column of the host's output (the time, then every Real output) for the
    FMU extracted in ``folder``: :data:`ITERATIVE_RTOL` for an FMU whose ``sources/`` carry a
    sampler's C routine, else :data:`RTOL_WINE`; :data:`NOISE_ATOL` for the outputs it names."""
    md = read_model_description(str(folder))
    iterative = any(h.name != codegen.C_HEADER for h in (folder / "sources").glob("*.h"))
    rtol = ITERATIVE_RTOL if iterative else RTOL_WINE
    names = [v.name for v in md.modelVariables if v.causality == "output" and v.type == "Real"]
    return [(RTOL_WINE, 0.0)] + [(rtol, NOISE_ATOL.get(name, 0.0)) for name in names]


def excess(got: list[list[float]], expected: list[list[float]], allowed: list[tuple[float, float]]) -> float:
    """The largest difference of ``got`` from ``expected`` (rows of the host's output) over what
    ``allowed`` (:func:`tolerances`) allows it: ``max(rtol m, atol)``, m the larger of the two values
    and of the column's largest magnitude in ``expected``; 0.0 when they are identical, at most 1 when
    they agree."""
    scale = [max(abs(x) for x in column) for column in zip(*expected)]
    return max((abs(a - b) / max(allowed[j][0] * max(abs(a), abs(b), scale[j]), allowed[j][1])
                for row, ref in zip(got, expected) for j, (a, b) in enumerate(zip(row, ref)) if a != b),
               default=0.0)


def _wine() -> str | None:
    """The 64-bit wine loader: ``wine64`` on PATH, or Debian's ``/usr/lib/wine/wine64``."""
    found = shutil.which("wine64")
    return found or ("/usr/lib/wine/wine64" if os.access("/usr/lib/wine/wine64", os.X_OK) else None)


X87_MODES = {"x87 0x37F": (), "x87 0x27F": ("--x87-53",)}
"""The win64 host's runs: as MinGW-w64's start-up code leaves the x87 control word (64-bit
precision, a MinGW-built tool) and with the Windows x64 default (53-bit, an MSVC-built tool)."""


@pytest.mark.slow
@pytest.mark.skipif(_wine() is None, reason="wine64 is not installed (Debian's wine64: `make wine-deps`)")
def test_win64_under_wine_gives_linux64s_outputs(unpacked: dict[str, Path], linux_host: Path,
                                                 tmp_path: Path) -> None:
    """On every native FMU, the win64 host and DLL under wine (in both :data:`X87_MODES`) and the
    linux64 host and ``.so`` give the same outputs on the same plan, within :func:`tolerances`
    (5 to 9 s measured: wine's first start in a fresh prefix 4 to 5 s, each run ~0.05 s)."""
    windows_host = compile_host(export.WIN64_CC, tmp_path / "fmu_host.exe", ("-static-libgcc",))
    # headless, no Mono/Gecko installer, the prefix and wineserver's socket folder (TMPDIR) in tmp_path
    env = {**{k: v for k, v in os.environ.items() if k != "DISPLAY"}, "WINEPREFIX": str(tmp_path / "wine"),
           "TMPDIR": str(tmp_path), "WINEDEBUG": "-all", "WINEDLLOVERRIDES": "mscoree,mshtml="}
    wineserver = [shutil.which("wineserver") or str(Path(_wine()).with_name("wineserver")), "-k"]
    worst = {}
    try:
        for name, folder in _cosimulation(unpacked).items():
            expected = run_linux_host(linux_host, folder, name)
            windows_uri = "file:///Z:" + (folder / "resources").as_uri().removeprefix("file://")  # wine's Z: is /
            write_plan(read_model_description(str(folder)), windows_uri, folder / "plan_win64.txt")
            allowed = tolerances(folder)
            for mode, flags in X87_MODES.items():
                # into files, not pipes: wine's background processes inherit the pipes and hold them
                # open for seconds after the host ends (2.3 s a run instead of 0.05 s)
                with open(folder / "out.txt", "w") as out, open(folder / "err.txt", "w") as err:
                    code = subprocess.run([_wine(), str(windows_host), rf"binaries\win64\{name}.dll",
                                           "plan_win64.txt", *flags], cwd=folder, env=env, stdout=out, stderr=err,
                                          timeout=300).returncode
                assert code == 0, (f"{name} ({mode}): the win64 host failed under wine:\n"
                                   f"{(folder / 'err.txt').read_text()}")
                got = read_rows((folder / "out.txt").read_text())
                assert len(got) == len(expected), f"{name} ({mode}): {len(got)} rows, {len(expected)} on linux64"
                worst[f"{name} ({mode})"] = excess(got, expected, allowed)
    finally:  # this test's own wine prefix: its wineserver, not another one
        subprocess.run(wineserver, env=env, capture_output=True)
    off = {run: f"{w:.3g}" for run, w in worst.items() if w > 1.0}
    assert not off, f"win64 outputs farther from linux64's than their tolerance, by these factors: {off}"


def test_pythonfmu_c_layer_dlls_export_every_fmi2_function(fmu_dir: Path, tmp_path: Path) -> None:
    """The win64 C layer of every pythonfmu FMU (``binaries/win64/<model>_py.dll``) imports only
    KERNEL32.dll and msvcrt.dll and exports every co-simulation fmi2 function and nothing else;
    pythonfmu's own DLL lies beside it (``<model>_py_pythonfmu.dll``)."""
    python = sorted(fmu_dir.glob(f"*{export.PYTHON_SUFFIX}.fmu"))
    assert len(python) >= 10, f"only {len(python)} pythonfmu FMUs in {fmu_dir}: the catalog was not built"
    wrong = {}
    for fmu in python:
        with zipfile.ZipFile(fmu) as z:
            names = set(z.namelist())
            dll = Path(z.extract(f"binaries/win64/{fmu.stem}.dll", tmp_path / fmu.stem))
            description = z.read("modelDescription.xml")
        imports, exports = pe_tables(dll)
        problems = []
        if f"binaries/win64/{fmu.stem}{export.PYTHONFMU_LIBRARY_SUFFIX}.dll" not in names:
            problems.append("no pythonfmu DLL beside it")
        if not imports or {i.lower() for i in imports} - ALLOWED_IMPORTS:
            problems.append(f"imports {sorted(imports)}")
        missing, foreign = needed_functions(description) - exports, {e for e in exports if not e.startswith("fmi2")}
        if missing or foreign:
            problems.append(f"missing {sorted(missing)}, not fmi2 {sorted(foreign)}")
        if problems:
            wrong[fmu.name] = problems
    assert not wrong, f"pythonfmu C layer DLLs: {wrong}"
