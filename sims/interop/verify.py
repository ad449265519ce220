"""Tool-agnostic verification: a scenario run by our master is checked against other engines.

For one scenario :func:`verify`

1. writes its SSP file (:mod:`satfmu.sims.interop.ssp`: the FMUs, the profiles as signal-generator FMUs,
   connections, parameter values);
2. runs it in our master twice: in its own feedthrough order (the scenario's metrics are
   evaluated on this run) and in Jacobi order (every output read before any input is set);
3. runs the SSP file in libcosim (:mod:`satfmu.sims.interop.libcosim`, Open Simulation Platform) and in the
   ecos command-line host (a C++ program, no Python in the loop);
4. compares every Real output of every FMU with the master's Jacobi run, the exchange order
   both other engines use (measured: they agree with it to rounding).

Tolerances (:data:`TOLERANCES`), per variable ``v`` over the communication points:
``max_k |a_k - b_k| <= atol + rtol * max_k |a_k|``.

- libcosim: ``rtol`` 1e-8, ``atol`` 1e-12. The FMU binaries, the step and the exchange order
  are the same; the only difference is the time: libcosim counts integer nanoseconds and
  passes ``k h`` converted from them, our master ``t0 + h k`` in floating point, which differ
  by about 1e-16 s. A time-dependent FMU (a signal generator) sees that difference, and a long
  nonlinear run may amplify rounding (the VSCMG's stick-slip friction most: its worst
  variable uses 0.65 of the allowance, ``vscmg_seed_friction``, ``plant.w2``; 1e-9 would fail
  it); 1e-8 leaves room for that and fails any real difference (a delayed or missing
  exchange, a parameter not applied: 1e-3 or more). The absolute 1e-12 is for signals that are
  zero but for rounding (a friction term of 1e-16). libcosim's observer shows a
  direct-feedthrough output only as passed on, from the previous point's inputs, which the
  master never records: those outputs are checked through the states they drive.
- ecos: ``atol`` 1e-6. ecos writes its results with 6 decimals (rounding error 5e-7), as
  its CSV is the only way to read them (it logs the compared outputs only, through a CSV
  configuration); 1e-6 covers the rounding of the value (5e-7) plus
  a 1e-9 relative margin for values up to a few hundred. ecos 0.7.2
  cannot load pythonfmu FMUs (their ``fmi2Instantiate`` fails in it and it then crashes in
  ``fmi2_freeInstance``); a scenario with one is checked in ecos FMU by FMU instead: each
  native FMU alone, at its default parameters and inputs, against the master running it alone.

A scenario may widen both in a ``[verify]`` table (``rtol``, ``atol``, and a ``reason``), where
its model amplifies rounding (a stick-slip friction mode that flips on a 1e-17 difference).

The master's own feedthrough run differs from the others by the one-step delay of a
direct-feedthrough controller in Jacobi order; that deviation is reported, not gated (it is
a property of the exchange order, shrinking with the step).

Sampled controllers without continuous states (an FMU with held values: B-dot, the periodic
schedules; :func:`sampled_fmu`) are gated on that delay itself (:func:`sampled_order_check`): each is run
open loop by the master in Jacobi order, its inputs replayed bit for bit from the feedthrough
run, its outputs passed to the FMUs they drive in the scenario; what those receive at ``t_k+1``
must be the controller's feedthrough-order output at ``t_k``, exactly. A sampled controller that
sampled the previous step's inputs when read at a sample instant (issue 28, defect 1: B-dot then
commanded nothing in libcosim and ecos, and the three Jacobi-order engines agreed on it) fails
it; so does one that is silent where the feedthrough run commands. A sampled controller with
continuous states (the online SDRE servos' integrators) is listed, not checked: its output moves
with its own state over the step, so the relation is not exact for it.
"""
from __future__ import annotations

import json
import math
import os
import re
import subprocess
import tempfile
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

from satfmu.fmus import archive
from satfmu.fmus.atomic import write_atomically
from satfmu.sims.interop import libcosim, ssp
from satfmu.sims.scenario import shipped_scenarios
from satfmu.fmus.profiles import make as make_profile
from satfmu.sims.cosim.master import CoSimulation
from satfmu.sims.scenario.provisioning import fmu_paths
from satfmu.sims.scenario.run import check, evaluate
from satfmu.sims.scenario.spec import Scenario, load
from satfmu.sims.scenario.wiring import recorded


@dataclass(frozen=True)
class Tolerance:
    """``|a - b| <= atol + rtol * max|a|`` per variable, and why.

    Attributes
    ----------
    atol : float
        Absolute allowance, in the unit of the variable compared.
    rtol : float
        Allowance relative to the largest magnitude ``max|a|`` of the reference signal.
    reason : str
        Why these values (shown in the report).
    """

    atol: float
    rtol: float
    reason: str


TOLERANCES = {
    "libcosim": Tolerance(1e-12, 1e-8, "same FMU binaries, steps and exchange order; time in integer ns "
                                       "(differs by ~1e-16 s), rounding growth over the run, and 1e-12 for "
                                       "signals that are zero but for rounding"),
    "ecos": Tolerance(1e-6, 1e-9, "ecos writes 6 decimals (rounding 5e-7), plus a 1e-9 relative margin"),
}
"""Default :class:`Tolerance` of each engine (``"libcosim"``, ``"ecos"``) against the master's Jacobi
run; a scenario's ``[verify]`` table may widen it."""


@dataclass
class Comparison:
    """One engine against the master's Jacobi run.

    Attributes
    ----------
    engine : str
        The engine: ``"libcosim"``, ``"ecos"`` or ``"ecos (each native FMU alone)"``.
    seconds : float
        Wall time of the engine's run, s.
    max_deviation : float
        Largest ratio of deviation to allowance over the compared variables (<= 1 passes;
        ``inf`` when the engine failed or missed a variable).
    worst_variable : str
        The variable of that ratio and its deviation (``"plant.omega[1] (3.2e-13)"``).
    tolerance : Tolerance or None
        The allowance applied (the engine's :data:`TOLERANCES` entry, or the scenario's wider one).
    passed : bool
        Whether every variable is within its allowance.
    error : str, optional
        What went wrong when the engine failed or did not report a variable; empty otherwise.
    """

    engine: str
    seconds: float
    max_deviation: float
    worst_variable: str
    tolerance: Tolerance | None
    passed: bool
    error: str = ""


@dataclass
class SampledOrderCheck:
    """The Jacobi-order outputs of a scenario's sampled controllers against their
    feedthrough-order outputs one step earlier (:func:`sampled_order_check`).

    Attributes
    ----------
    controllers : list of str
        The sampled controller instances checked (those without continuous states).
    max_deviation : float
        Largest ``|received_jacobi(t_k+1) - output_feedthrough(t_k)|`` over the checked signals,
        in the unit of each signal.
    worst_variable : str
        The connection of that deviation (``"ctrl.m[1] -> plant.m[1]"``), empty if none.
    passed : bool
        Whether every deviation is within :data:`SAMPLED_ORDER_ATOL` (none) and no controller is
        silent in Jacobi order where the feedthrough run commands.
    error : str, optional
        The silent outputs, if any; empty otherwise.
    unchecked : list of str, optional
        Sampled controllers with continuous states, not checked.
    """

    controllers: list[str]
    """The sampled controller instances checked (those without continuous states)."""
    max_deviation: float
    """Largest ``|received_jacobi(t_k+1) - output_feedthrough(t_k)|`` over the checked signals."""
    worst_variable: str
    passed: bool
    error: str = ""
    unchecked: list[str] = field(default_factory=list)
    """Sampled controllers with continuous states, not checked (their output also moves with
    their own state over the step)."""


@dataclass
class ScenarioVerification:
    """Verification of one scenario.

    Attributes
    ----------
    scenario : str
        Name of the scenario.
    ssp : str
        Path of the SSP file written for it.
    n_variables : int
        Number of Real outputs compared.
    n_points : int
        Number of communication points of the run.
    master_seconds : float
        Wall time of the master's feedthrough-order run, s.
    metrics_passed : bool
        Whether every metric of the scenario passed on the feedthrough-order run.
    order_deviation : float
        Largest deviation, relative to the signal's magnitude, of the master's feedthrough run
        from its Jacobi run (information, not gated).
    comparisons : list of Comparison, optional
        One per engine.
    sampled_order : SampledOrderCheck or None, optional
        The exchange-order check of the sampled controllers (None: the scenario has none).
    """

    scenario: str
    ssp: str
    n_variables: int
    n_points: int
    master_seconds: float
    metrics_passed: bool
    order_deviation: float
    """Largest deviation, relative to the signal's magnitude, of the master's feedthrough run
    from its Jacobi run (information: the one-step delay of feedthrough loops)."""
    comparisons: list[Comparison] = field(default_factory=list)
    sampled_order: SampledOrderCheck | None = None
    """The exchange-order check of the sampled controllers (None: the scenario has none)."""

    @property
    def passed(self) -> bool:
        return (self.metrics_passed and all(c.passed for c in self.comparisons)
                and (self.sampled_order is None or self.sampled_order.passed))


def ecos_binary() -> Path:
    """Path of the ecos command-line host (wheel ``ecospy``).

    Raises
    ------
    FileNotFoundError
        If ecospy is not installed or its binary is not executable.
    """
    import importlib.util

    spec = importlib.util.find_spec("ecospy")
    if spec is None or spec.origin is None:
        raise FileNotFoundError("ecospy is not installed (pip install ecospy)")
    path = Path(spec.origin).parent / "binaries" / "ecos"
    if not os.access(path, os.X_OK):
        raise FileNotFoundError(f"{path} is missing or not executable (chmod +x; `make` does it)")
    return path


def run_ecos(ssp_path: Path, stop_time: float, step_size: float, timeout: float = 3600.0,
             alone: bool = False, variables: Sequence[str] | None = None) -> dict[str, np.ndarray]:
    """Run an SSP file (or, ``alone``, one FMU: instance ``instance``) in ecos; returns every
    column of its CSV by ``instance.variable`` (and ``time``) at t_0 ... t_n.

    ecos adds up its time in floating point and may stop one step short of ``stop_time``: it
    is asked for half a step more, and the rows beyond t_n are dropped. Its CSV separates the
    columns by ``", "`` and does not quote the names, in which a matrix entry keeps its comma
    (``ctrl::K_theta[1,2][REAL]``): the header is split on ``", "``.

    Parameters
    ----------
    ssp_path : Path
        The SSP file, or with ``alone`` an FMU file.
    stop_time : float
        End of the run, s (the run starts at 0 s).
    step_size : float
        Communication step, s.
    timeout : float, optional
        Wall time after which ecos is stopped, s. Default 3600.
    alone : bool, optional
        ``ssp_path`` is one FMU, run alone as instance ``instance`` at its default parameters
        and inputs (no parameter set applied). Default False.
    variables : sequence of str, optional
        The ``instance.variable`` names to log (an ecos CSV configuration); default every
        variable of every instance, parameters included (DEMETER's 60,000 steps: 162 MB of CSV
        and 5.8 s, against 2.6 MB and 0.9 s for three variables).

    Raises
    ------
    libcosim.EngineError
        ecos failed (exit code and output), timed out, or wrote no CSV.
    """
    with tempfile.TemporaryDirectory(prefix="satfmu_ecos_") as tmp:
        cmd = [str(ecos_binary()), "simulate", "--path", str(Path(ssp_path).resolve()),
               "--stopTime", repr(stop_time + step_size / 2),
               "--stepSize", repr(step_size), "--noParallel", "-l", "warn"]
        cmd += [] if alone else ["--parameterSet", ssp.PARAMETER_SET]
        if variables is not None:
            cmd += ["--csvConfig", str(_ecos_csv_config(variables, Path(tmp) / "csv_config.xml"))]
        try:
            # ecos extracts the SSP and its FMUs into TMPDIR (ecos_ssp_<uuid>, never removed): this folder
            proc = subprocess.run(cmd, cwd=tmp, capture_output=True, text=True, timeout=timeout,
                                  env={**os.environ, "TMPDIR": tmp})
        except subprocess.TimeoutExpired:
            raise libcosim.EngineError(f"ecos did not finish {ssp_path.name} within {timeout:g} s") from None
        files = list(Path(tmp).glob("*.csv"))
        if proc.returncode != 0 or len(files) != 1:
            text = (proc.stdout + proc.stderr).strip()[-2000:]
            raise libcosim.EngineError(f"ecos failed on {ssp_path.name} (exit code {proc.returncode}):\n{text}")
        with open(files[0]) as fh:
            header = fh.readline().rstrip("\n").split(", ")
            body = np.loadtxt(fh, delimiter=",", ndmin=2)
    body = body[:round(stop_time / step_size) + 1]
    expected = step_size * np.arange(len(body))
    if len(body) != round(stop_time / step_size) + 1 or np.max(np.abs(body[:, header.index("time")] - expected)) > 1e-6:
        raise libcosim.EngineError(f"ecos wrote {len(body)} rows not on the grid of {step_size:g} s to {stop_time:g} s")
    out = {"time": body[:, header.index("time")]}
    for j, col in enumerate(header):
        if col.endswith("[REAL]"):
            inst, var = col[:-len("[REAL]")].split("::", 1)
            out[f"{inst}.{var}"] = body[:, j]
    return out


def _ecos_csv_config(variables: Sequence[str], path: Path) -> Path:
    """Write an ecos CSV configuration logging ``variables`` (``instance.variable``) to ``path``."""
    import xml.etree.ElementTree as ET

    ns = "http://github.com/Ecos-platform/libecos/resources/schema/CsvConfig"
    ET.register_namespace("ecos", ns)
    root = ET.Element(f"{{{ns}}}CsvConfig")
    components = ET.SubElement(root, f"{{{ns}}}components")
    by_instance: dict[str, list[str]] = {}
    for q in variables:
        inst, var = q.split(".", 1)
        by_instance.setdefault(inst, []).append(var)
    for inst, names in by_instance.items():
        comp = ET.SubElement(components, f"{{{ns}}}component", name=inst)
        for var in names:
            ET.SubElement(comp, f"{{{ns}}}variable", name=var)
    ET.ElementTree(root).write(path, encoding="utf-8", xml_declaration=True)
    return path


def _deviation(ref: dict[str, np.ndarray], other: dict[str, np.ndarray], tol: Tolerance
               ) -> tuple[float, str, bool]:
    """Largest ratio of deviation to allowance, the variable, and whether all are within
    (``ref`` and ``other`` aligned sample by sample)."""
    worst, worst_name, ok = 0.0, "", True
    for q in ref:
        a, b = np.asarray(ref[q]), np.asarray(other[q])
        if a.shape != b.shape:
            return math.inf, f"{q}: {b.size} samples, expected {a.size}", False
        allow = tol.atol + tol.rtol * float(np.max(np.abs(a), initial=0.0))
        dev = float(np.max(np.abs(a - b), initial=0.0)) if np.all(np.isfinite(b)) else math.inf
        ok &= dev <= allow
        ratio = dev / allow if allow > 0 else (0.0 if dev == 0 else math.inf)
        if ratio >= worst:
            worst, worst_name = ratio, f"{q} ({dev:.3g})"
    return worst, worst_name, ok


def _ecos_alone(paths: dict[str, Path], stop_time: float, step_size: float
                ) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """Each native FMU of ``paths`` alone in ecos and in the master (default parameters and
    inputs): the master's outputs and ecos's (those ecos reported), by ``file.variable``."""
    ref: dict[str, np.ndarray] = {}
    got: dict[str, np.ndarray] = {}
    for path in sorted({p for p in paths.values() if not p.name.endswith("_py.fmu")}):
        with CoSimulation({"alone": path}) as sim:
            outs = [v.name for v in sim.components["alone"].model_description.modelVariables
                    if v.causality == "output" and v.type == "Real"]
            res = sim.run(stop_time, step_size, record=[f"alone.{v}" for v in outs])
        cols = run_ecos(path, stop_time, step_size, alone=True)
        for v in outs:
            ref[f"{path.stem}.{v}"] = res[f"alone.{v}"]
            if f"instance.{v}" in cols:  # a variable ecos did not report stays missing
                got[f"{path.stem}.{v}"] = cols[f"instance.{v}"]
    return ref, got


def feedthrough_outputs(sim: CoSimulation) -> set[str]:
    """Qualified Real outputs that depend directly on an input of their FMU (modelDescription
    ``ModelStructure``).

    Parameters
    ----------
    sim : CoSimulation
        The master holding the FMUs.

    Returns
    -------
    set of str
        The outputs as ``instance.variable``.
    """
    out = set()
    for c in sim.components.values():
        for unknown in c.model_description.outputs:
            if any(dep.causality == "input" for dep in unknown.dependencies or []):
                out.add(f"{c.name}.{unknown.variable.name}")
    return out


_SOURCE_BYTES = 16 << 20
"""The largest generated source read to tell a sampled FMU (B): satfmu's are a few kB."""


def _structure(path: Path) -> tuple[bool, int] | None:
    """Whether the satfmu FMU at ``path`` samples, and its number of continuous states: from a
    native FMU's ``sources/model.h`` (``NH`` > 0, ``NX``) or a pythonfmu FMU's generated model
    (a ``SAMPLER``, ``N_STATES``); None for an FMU satfmu did not build."""
    text = archive.read_entry(path, "sources/model.h", _SOURCE_BYTES)
    if text is not None:
        nh = re.search(rb"^#define NH (\d+)$", text, re.MULTILINE)
        nx = re.search(rb"^#define NX (\d+)$", text, re.MULTILINE)
        return (int(nh.group(1)) > 0, int(nx.group(1))) if nh and nx else None
    for name in archive.check(path).names:
        if re.fullmatch(r"resources/satfmu_gen_[^/]*\.py", name):
            text = archive.read_entry(path, name, _SOURCE_BYTES) or b""
            nx = re.search(rb"^N_STATES = (\d+)$", text, re.MULTILINE)
            sampler = re.search(rb"^SAMPLER = None$", text, re.MULTILINE) is None
            return (sampler, int(nx.group(1))) if nx else None
    return None


def sampled_fmu(path: Path) -> bool:
    """Whether the FMU at ``path`` is one of satfmu's sampled FMUs (it holds values computed at
    sample instants): a native FMU whose ``sources/model.h`` defines ``NH`` > 0, or a pythonfmu
    FMU whose generated model has a ``SAMPLER``. Any other FMU (not built by satfmu) is not.

    Parameters
    ----------
    path : Path
        The FMU file.
    """
    found = _structure(path)
    return found is not None and found[0]


def _sampled_controllers(scenario: Scenario, paths: dict[str, Path]) -> tuple[list[str], list[str]]:
    """The instances of ``scenario`` that are sampled FMUs and drive another FMU's input: those
    without continuous states (checked by :func:`sampled_order_check`), and those with (not
    checked: their outputs also move with their own state over the step, so a Jacobi-order
    reader's value at t_k+1 is not their output at t_k even when every sample is right)."""
    sources = {c["from"].split(".", 1)[0] for c in scenario.data.get("connections", [])}
    found = {inst: _structure(paths[inst]) for inst in sorted(sources) if inst in paths}
    sampled = {inst: f[1] for inst, f in found.items() if f is not None and f[0]}  # -> continuous states
    return ([inst for inst, nx in sampled.items() if nx == 0], [inst for inst, nx in sampled.items() if nx > 0])


def _inputs(sim: CoSimulation, instance: str) -> list[str]:
    """Every Real input of ``instance``, qualified."""
    return [f"{instance}.{v.name}" for v in sim.components[instance].model_description.modelVariables
            if v.causality == "input" and v.type == "Real"]


def delayed_deviation(received: np.ndarray, output: np.ndarray) -> tuple[float, bool]:
    """How far what a Jacobi-order run passed on (``received`` at t_0 ... t_n) is from the
    feedthrough-order output (``output`` at t_0 ... t_n) one step later: the largest
    ``|received[k+1] - output[k]|``, and whether the Jacobi run is silent (identically zero)
    where the feedthrough output is not.

    Parameters
    ----------
    received : numpy.ndarray
        What the Jacobi-order run passed on to the driven input, shape (n + 1,), at t_0 ... t_n.
    output : numpy.ndarray
        The controller's output in the feedthrough-order run, shape (n + 1,), at t_0 ... t_n,
        in the same unit.

    Returns
    -------
    deviation : float
        The largest ``|received[k+1] - output[k]|``, in the signal's unit.
    silent : bool
        Whether ``received`` is zero at t_1 ... t_n while ``output`` is not at some point of
        t_0 ... t_n-1.

    Raises
    ------
    ValueError
        If the two series differ in shape or have fewer than two points.
    """
    received, output = np.asarray(received, float), np.asarray(output, float)
    if received.shape != output.shape or received.size < 2:
        raise ValueError(f"expected two series of the same length >= 2, got {received.shape} and {output.shape}")
    dev = float(np.max(np.abs(received[1:] - output[:-1])))
    silent = not np.any(received[1:] != 0.0) and bool(np.any(output[:-1] != 0.0))
    return dev, silent


SAMPLED_ORDER_ATOL = 0.0
"""Allowance of :func:`sampled_order_check`: none. The replay gives the controller the
feedthrough run's input values bit for bit at the same communication points, through the same
binary: its samples are the same numbers, so what a Jacobi-order reader gets one step later is
the feedthrough output exactly; any difference is a sample from other inputs."""


def sampled_order_check(scenario: Scenario, fmu_dir: Path, backend: str, res_ft: np.ndarray,
                        controllers: Sequence[str]) -> SampledOrderCheck:
    """Check that a Jacobi-order importer gets each sampled controller's feedthrough-order output
    one communication step later (the module docstring).

    Parameters
    ----------
    scenario : Scenario
        The scenario (its connections and parameters).
    fmu_dir : Path
        Folder of the FMUs.
    backend : {"native", "python"}
        Default FMU backend of the scenario's instances.
    res_ft : numpy.ndarray
        The master's feedthrough-order run of the scenario, every communication point, recording
        every Real input and output of ``satfmu.controllers`` and the inputs they drive.
    controllers : sequence of str
        The sampled controller instances (:func:`sampled_fmu`).

    Returns
    -------
    SampledOrderCheck
    """
    d = scenario.data
    paths = fmu_paths(scenario, fmu_dir, backend)
    params = {inst: spec.get("parameters", {}) for inst, spec in d["fmus"].items()}
    worst, worst_name, silent_at = 0.0, "", []
    times = np.asarray(res_ft["time"], float)
    assert res_ft.dtype.names is not None  # a structured array: it has a "time" field
    for ctrl in controllers:
        conns = [c for c in d.get("connections", []) if c["from"].split(".", 1)[0] == ctrl]
        sinks = {c["to"].split(".", 1)[0] for c in conns} - {ctrl}
        sim = CoSimulation({ctrl: paths[ctrl]} | {s: paths[s] for s in sinks})
        try:
            pairs = []
            for c in conns:
                _, outs = sim.resolve(c["from"])
                sink, ins = sim.resolve(c["to"])
                pairs += [(f"{ctrl}.{o}", f"{sink.name}.{i}") for o, i in zip(outs, ins)]
                if sink.name != ctrl:
                    sim.connect(c["from"], c["to"])
            for q in (q for q in _inputs(sim, ctrl) if q in res_ft.dtype.names):  # the driven ones
                sim.add_profile(q, make_profile({"kind": "table", "times": times.tolist(),
                                                 "values": np.asarray(res_ft[q], float).tolist(),
                                                 "interpolation": "previous"}, f"replay of {q}"))
            res_j = sim.run(d["stop_time"], d["step_size"], d.get("start_time", 0.0),
                            {i: params.get(i, {}) for i in sim.components}, [dst for _, dst in pairs],
                            exchange_order="jacobi")
        finally:
            sim.close()
        for src, dst in pairs:
            if dst.split(".", 1)[0] == ctrl:
                continue
            dev, silent = delayed_deviation(res_j[dst], res_ft[src])
            if silent:
                silent_at.append(src)
            if dev >= worst:
                worst, worst_name = dev, f"{src} -> {dst}"
    ok = worst <= SAMPLED_ORDER_ATOL and not silent_at
    error = f"silent in Jacobi order where the feedthrough run commands: {silent_at}" if silent_at else ""
    return SampledOrderCheck(list(controllers), worst, worst_name, ok, error)


def _master(scenario: Scenario, fmu_dir: Path, backend: str, exchange: str, extra: Sequence[str] = ()
            ) -> tuple[np.ndarray, list[str], CoSimulation]:
    """A master run of the scenario as its SSP file has it (profiles as signal-generator FMUs)
    recording the scenario's variables, every Real output and the ``extra`` variables; returns
    the run, the outputs' names and the (closed) master."""
    d = scenario.data
    paths = fmu_paths(scenario, fmu_dir, backend)
    sig_paths, sig_params, sig_conns = ssp.signal_components(scenario, fmu_dir, Path(fmu_dir) / "signal_tables",
                                                             backend)
    sim = CoSimulation(paths | sig_paths)
    try:
        for c in list(d.get("connections", [])) + sig_conns:
            sim.connect(c["from"], c["to"])
        record = [f"{c.name}.{v.name}" for c in sim.components.values()
                  for v in c.model_description.modelVariables if v.causality == "output" and v.type == "Real"]
        params = {inst: spec.get("parameters", {}) for inst, spec in d["fmus"].items()} | sig_params
        res = sim.run(d["stop_time"], d["step_size"], d.get("start_time", 0.0), params,
                      list(dict.fromkeys(recorded(scenario, sim) + record + list(extra))), exchange_order=exchange)
    finally:
        sim.close()
    return res, record, sim


def verify(name_or_path: "str | Path | Scenario", fmu_dir: Path, out_dir: Path, backend: str = "native",
           engines: tuple[str, ...] = ("libcosim", "ecos"), allow_stale: bool = False) -> ScenarioVerification:
    """Verify one scenario against the other engines (see the module docstring).

    Parameters
    ----------
    name_or_path : str, Path or Scenario
        Scenario.
    fmu_dir : Path
        Folder of the FMUs; the missing ones are built, and the scenario is checked as a run
        checks it (:func:`satfmu.sims.scenario.run.check`) before its SSP file is written.
    out_dir : Path
        Receives ``<scenario>.ssp``.
    backend : {"native", "python"}
        Default FMU backend of the scenario's instances.
    engines : tuple of str
        Subset of ``("libcosim", "ecos")``.
    allow_stale : bool
        Use a stale controller FMU outside the FMU cache as it is (a warning), not an error.

    Raises
    ------
    satfmu.sims.scenario.spec.ScenarioError
        What a run refuses.
    """
    scenario = load(name_or_path)
    return _verify(scenario, check(scenario, fmu_dir, backend, allow_stale), out_dir, backend, engines)


def _verify(scenario: Scenario, fmu_dir: Path, out_dir: Path, backend: str, engines: tuple[str, ...]
            ) -> ScenarioVerification:
    """:func:`verify` of a scenario :func:`satfmu.sims.scenario.run.check` accepted."""
    d = scenario.data
    target = ssp.target(scenario, out_dir)
    target.unlink(missing_ok=True)
    ssp_path = ssp.write(scenario, fmu_dir, target, backend)
    paths = fmu_paths(scenario, fmu_dir, backend)
    sampled, stateful = _sampled_controllers(scenario, paths)
    # the sampled controllers' inputs and the inputs they drive, for the replay
    extra = [c["to"] for c in d.get("connections", []) if c["to"].split(".", 1)[0] in sampled]
    extra += [c["to"] for c in d.get("connections", []) if c["from"].split(".", 1)[0] in sampled]
    extra += [p["to"] for p in d.get("profiles", []) if p["to"].split(".", 1)[0] in sampled]
    t0 = time.perf_counter()
    res_ft, record, sim = _master(scenario, fmu_dir, backend, "feedthrough", extra)
    master_seconds = time.perf_counter() - t0
    metrics, _ = evaluate(scenario, res_ft, sim)
    res_j, _, _ = _master(scenario, fmu_dir, backend, "jacobi")
    direct = feedthrough_outputs(sim)
    order_dev = max((float(np.max(np.abs(res_ft[q] - res_j[q])) / max(1e-300, float(np.max(np.abs(res_j[q])))))
                     for q in record if np.any(res_j[q] != 0)), default=0.0)
    report = ScenarioVerification(scenario.name, str(ssp_path), len(record), len(res_j), master_seconds,
                            all(m.passed for m in metrics), order_dev)
    if sampled:
        report.sampled_order = sampled_order_check(scenario, fmu_dir, backend, res_ft, sampled)
    if stateful:
        report.sampled_order = report.sampled_order or SampledOrderCheck([], 0.0, "", True)
        report.sampled_order.unchecked = stateful
    own = d.get("verify")
    for engine in engines:
        tol = TOLERANCES[engine]
        if own:  # the scenario's own, wider tolerance (its TOML says why)
            tol = Tolerance(max(tol.atol, own.get("atol", 0.0)), max(tol.rtol, own.get("rtol", 0.0)),
                            f"scenario [verify]: {own['reason']}")
        t0 = time.perf_counter()
        try:
            if engine == "libcosim":
                other = libcosim.run(ssp_path, record, d["stop_time"], d["step_size"], d.get("start_time", 0.0))
                got = {q: other[q] for q in record}
                # libcosim samples t_1 ... t_n, and a feedthrough output only as passed on (from
                # the previous point's inputs), which the master never records: those are
                # checked through what they drive
                ref = {q: res_j[q][1:] for q in record if q not in direct}
            elif engine == "ecos" and any(p.name.endswith("_py.fmu") for p in paths.values()):
                ref, got = _ecos_alone(paths, d["stop_time"], d["step_size"])
                engine = "ecos (each native FMU alone)"
            elif engine == "ecos":
                got = run_ecos(ssp_path, d["stop_time"], d["step_size"], variables=record)
                ref = {q: res_j[q] for q in record}
            else:
                raise ValueError(f"unknown engine {engine!r}; use libcosim or ecos")
        except libcosim.EngineError as exc:
            report.comparisons.append(Comparison(engine, time.perf_counter() - t0, math.inf, "", tol, False, str(exc)))
            continue
        missing = [q for q in ref if got.get(q) is None]
        if missing:
            report.comparisons.append(Comparison(engine, time.perf_counter() - t0, math.inf, "", tol, False,
                                                 f"{engine} did not report {missing[:5]}"))
            continue
        worst, name, ok = _deviation(ref, got, tol)
        report.comparisons.append(Comparison(engine, time.perf_counter() - t0, worst, name, tol, ok))
    return report


def markdown(reports: list[ScenarioVerification]) -> str:
    """The reports as a Markdown table (one row per scenario and engine).

    Parameters
    ----------
    reports : list of ScenarioVerification
        The reports of :func:`verify`, one per scenario.
    """
    lines = ["| scenario | engine | variables x points | max deviation / allowance (worst variable) | "
             "time, s | result |", "|---|---|---|---|---|---|"]
    for r in reports:
        lines.append(f"| {r.scenario} | satfmu master (feedthrough order) | {r.n_variables} x {r.n_points} | "
                     f"{r.order_deviation:.2g} relative to Jacobi order (not gated) | {r.master_seconds:.2f} | "
                     f"metrics {'pass' if r.metrics_passed else 'FAIL'} |")
        if r.sampled_order is not None:
            so = r.sampled_order
            what = so.error or f"{so.max_deviation:.3g} ({so.worst_variable or 'no signal'})"
            if so.unchecked:
                what += f"; not checked (continuous states): {', '.join(so.unchecked)}"
            lines.append(f"| {r.scenario} | master, sampled controllers "
                         f"{', '.join(so.controllers) or '(none checked)'}: Jacobi order "
                         f"vs feedthrough order one step later | {r.n_points} points | {what} | | "
                         f"{'pass' if so.passed else 'FAIL'} |")
        for c in r.comparisons:
            what = c.error.splitlines()[0] if c.error else f"{c.max_deviation:.3g} ({c.worst_variable})"
            lines.append(f"| {r.scenario} | {c.engine} vs master (Jacobi order) | {r.n_variables} x {r.n_points} | "
                         f"{what} | {c.seconds:.2f} | {'pass' if c.passed else 'FAIL'} |")
    lines += ["", "Tolerances (per variable, |a - b| <= atol + rtol max|a|):"]
    lines += [f"- {e}: atol {t.atol:g}, rtol {t.rtol:g}: {t.reason}" for e, t in TOLERANCES.items()]
    lines += ["- sampled controllers, Jacobi order vs feedthrough order one step later: exact (the same inputs "
              "bit for bit, the same binary)"]
    lines += [f"- {r.scenario}: atol {c.tolerance.atol:g}, rtol {c.tolerance.rtol:g} ({c.engine}): "
              f"{c.tolerance.reason}" for r in reports for c in r.comparisons
              if c.tolerance and c.tolerance.reason.startswith("scenario")]
    return "\n".join(lines) + "\n"


def result_files(out_dir: Path) -> tuple[Path, Path]:
    """``verify.md`` and ``verify.json`` of ``out_dir``.

    Parameters
    ----------
    out_dir : Path
        The report folder.
    """
    return out_dir / "verify.md", out_dir / "verify.json"


def write(reports: list[ScenarioVerification], out_dir: Path) -> tuple[Path, Path]:
    """Write ``verify.md`` and ``verify.json`` into ``out_dir``, each whole or not at all.

    Parameters
    ----------
    reports : list of ScenarioVerification
        The reports of :func:`verify`, one per scenario.
    out_dir : Path
        The report folder (it must exist).

    Returns
    -------
    tuple of Path
        The Markdown and the JSON file.
    """
    md, js = result_files(out_dir)
    payload = [dict(asdict(r), passed=r.passed) for r in reports]
    for path, text in ((md, markdown(reports)), (js, json.dumps(payload, indent=2, default=str))):
        write_atomically(path, lambda tmp: tmp.write_text(text))
    return md, js


@dataclass
class VerifyRun:
    """The verifications of :func:`verify_all` and the files they were written to.

    Attributes
    ----------
    scenarios : list of ScenarioVerification
        One per scenario, in the order verified.
    md_path : Path
        The Markdown table (``verify.md``).
    json_path : Path
        The JSON results (``verify.json``).
    """

    scenarios: list[ScenarioVerification]
    md_path: Path
    json_path: Path

    @property
    def failed(self) -> list[str]:
        """The scenarios that did not pass."""
        return [r.scenario for r in self.scenarios if not r.passed]

    def text(self) -> str:
        """The table of every scenario and engine, and the tally."""
        return (markdown(self.scenarios).split("\n\n")[0] + f"\n{len(self.scenarios) - len(self.failed)}/"
                f"{len(self.scenarios)} scenarios pass; results: {self.md_path}, {self.json_path}")


def verify_all(fmu_dir: Path, out_dir: Path, names: Sequence[str | Path] = (), backend: str = "native",
               engines: tuple[str, ...] = ("libcosim", "ecos"),
               progress: Callable[[int, int, str], None] | None = None, allow_stale: bool = False) -> VerifyRun:
    """:func:`verify` of each scenario, then :func:`write` of all the reports.

    Every scenario is checked first as a run checks it (:func:`satfmu.sims.scenario.run.check`: the FMUs
    a scenario names that are missing from ``fmu_dir`` are built, each FMU and the wiring are
    checked), so a bad one stops the run before any work. The report of an earlier
    run in ``out_dir`` is removed first: a folder with a report holds a complete run.

    Parameters
    ----------
    fmu_dir : Path
        Folder of the FMUs.
    out_dir : Path
        Receives the SSP files, ``verify.md`` and ``verify.json``.
    names : sequence of str or Path
        Scenarios (default: every shipped one).
    backend : {"native", "python"}
        Default FMU backend of the scenarios' instances.
    engines : tuple of str
        Subset of ``("libcosim", "ecos")``.
    progress : callable, optional
        ``progress(done, total, message)`` before each scenario and at the end.
    allow_stale : bool
        See :func:`verify`.

    Raises
    ------
    satfmu.sims.scenario.spec.ScenarioError
        What a run refuses.
    """
    scenarios = [load(name) for name in list(names) or [p.stem for p in shipped_scenarios()]]
    for f in result_files(Path(out_dir)):
        f.unlink(missing_ok=True)
    folders = [check(scenario, fmu_dir, backend, allow_stale) for scenario in scenarios]  # before any work
    reports = []
    for i, (scenario, folder) in enumerate(zip(scenarios, folders)):
        if progress is not None:
            progress(i, len(scenarios), f"verifying {scenario.name}")
        reports.append(_verify(scenario, folder, Path(out_dir), backend, tuple(engines)))
    if progress is not None:
        progress(len(scenarios), len(scenarios), "verified")
    return VerifyRun(reports, *write(reports, Path(out_dir)))
