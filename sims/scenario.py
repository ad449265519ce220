"""Scenarios: a co-simulation declared in TOML, run by the master, judged by metrics.

A scenario file names its FMUs (by built model name or path), their parameters,
the connections, the disturbance profiles, what to record and plot, and metrics
with pass/fail bounds. Example (sims/scenarios/mrp_200deg.toml)::

    name = "mrp_200deg"
    stop_time = 120.0            # s
    step_size = 0.05             # communication step, s
    record = ["plant.omega", "plant.sigma", "controller.u"]

    [fmus.plant]
    model = "mrp_satellite"
    parameters = { "sigma_0[1]" = 0.5992, "sigma_0[2]" = -0.7976, "sigma_0[3]" = 0.6517 }

    [fmus.controller]
    model = "mrp_hinf_published"

    [[connections]]
    from = "plant.omega"
    to = "controller.omega"

    [[profiles]]
    to = "plant.w_d[1]"
    kind = "step"
    time = 5.0
    before = 2.0
    after = 0.0

    [[metrics]]
    name = "angle error at the end"
    kind = "final"               # final, peak, rms, settling_time, l2_ratio, time_in_saturation,
                                 # integral_square, max_difference
    signals = ["plant.phi"]
    scale = 57.29577951308232    # rad -> deg
    unit = "deg"
    max = 0.1

Metric fields: ``signals``, ``scale`` (applied to signals, tolerance and limit are in
scaled units), ``unit``, ``min``/``max`` bounds; ``tolerance`` for settling_time,
``limit`` for time_in_saturation, ``disturbances`` (the denominator signals) for
l2_ratio, whose value is the largest ratio over T and whose curve is plotted, ``versus``
for max_difference (the largest ``|signal - versus|`` over time, signal by signal: an
approximated law against the exact one, say).
integral_square is ``integral of sum_i y_i^2 dt`` (an H2 cost with unit weights): plant
outputs by the trapezoidal rule, FMU inputs (held over each step, e.g. ``plant.u``) by the
left rectangle.
"""
from __future__ import annotations

import csv
import json
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from fmus.profiles import Profile
from fmus.profiles import make as make_profile
from sims import metrics as M
from sims.master import CoSimulation, communication_times

SCENARIOS = Path(__file__).resolve().parent / "scenarios"
BACKENDS = {"native": "", "python": "_py"}
_TOP = {"name", "description", "stop_time", "step_size", "start_time", "fmus", "connections",
        "profiles", "record", "metrics", "plot", "reference", "verify"}
_FMU = {"model", "path", "backend", "parameters"}
_METRIC = {"name", "kind", "signals", "scale", "unit", "min", "max", "tolerance", "limit",
           "disturbances", "versus", "description"}


class ScenarioError(ValueError):
    """A scenario file is missing, malformed, or refers to something that does not exist."""


@dataclass
class Scenario:
    """A parsed, validated scenario declaration."""

    path: Path
    data: dict[str, Any]

    @property
    def name(self) -> str:
        return self.data["name"]


@dataclass
class ScenarioResult:
    """Outcome of one scenario run."""

    name: str
    backend: str
    results: np.ndarray
    metrics: list[M.MetricResult]
    files: dict[str, Path] = field(default_factory=dict)
    l2_curves: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def passed(self) -> bool:
        return all(m.passed for m in self.metrics)

    def summary(self) -> dict[str, Any]:
        return {"scenario": self.name, "backend": self.backend, "passed": self.passed,
                "metrics": [m.to_json() for m in self.metrics],
                "files": {k: str(v) for k, v in self.files.items()}}


def resolve_path(name_or_path: str | Path) -> Path:
    """A scenario file path, or the shipped scenario of that name."""
    p = Path(name_or_path)
    if p.suffix == ".toml" and p.is_file():
        return p
    shipped = SCENARIOS / f"{name_or_path}.toml"
    if shipped.is_file():
        return shipped
    names = ", ".join(sorted(s.stem for s in SCENARIOS.glob("*.toml")))
    raise ScenarioError(f"no scenario file {name_or_path!r} (shipped scenarios: {names})")


def load(name_or_path: str | Path) -> Scenario:
    """Read and check a scenario's structure (names are checked against the FMUs at run time)."""
    path = resolve_path(name_or_path)
    try:
        data = tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{path}: invalid TOML ({exc})") from None
    where = str(path)
    unknown = set(data) - _TOP
    if unknown:
        raise ScenarioError(f"{where}: unknown keys {sorted(unknown)} (allowed: {sorted(_TOP)})")
    for key in ("name", "stop_time", "step_size", "fmus"):
        if key not in data:
            raise ScenarioError(f"{where}: missing key {key!r}")
    if not isinstance(data["fmus"], dict) or not data["fmus"]:
        raise ScenarioError(f"{where}: [fmus] must declare at least one FMU instance")
    for inst, spec in data["fmus"].items():
        if not isinstance(spec, dict) or set(spec) - _FMU or ("model" in spec) == ("path" in spec):
            raise ScenarioError(f"{where}: [fmus.{inst}] needs exactly one of 'model' or 'path', "
                                f"and only the keys {sorted(_FMU)}")
        if spec.get("backend", "native") not in BACKENDS:
            raise ScenarioError(f"{where}: [fmus.{inst}] backend must be one of {sorted(BACKENDS)}")
    for i, c in enumerate(data.get("connections", [])):
        if set(c) != {"from", "to"}:
            raise ScenarioError(f"{where}: connections[{i}] needs exactly 'from' and 'to'")
    for i, p in enumerate(data.get("profiles", [])):
        if "to" not in p:
            raise ScenarioError(f"{where}: profiles[{i}] needs a 'to' target")
    ver = data.get("verify", {})
    if not isinstance(ver, dict) or set(ver) - {"rtol", "atol", "reason"} or ver and not ver.get("reason") or any(
            isinstance(ver.get(k, 0.0), bool) or not isinstance(ver.get(k, 0.0), (int, float))
            or not 0 <= ver.get(k, 0.0) < 1 for k in ("rtol", "atol")):
        raise ScenarioError(f"{where}: [verify] takes rtol and atol in [0, 1) and needs a 'reason' for them")
    for i, m in enumerate(data.get("metrics", [])):
        w = f"{where}: metrics[{i}]"
        if set(m) - _METRIC:
            raise ScenarioError(f"{w}: unknown keys {sorted(set(m) - _METRIC)}")
        if m.get("kind") not in M.KINDS:
            raise ScenarioError(f"{w}: kind must be one of {M.KINDS}, got {m.get('kind')!r}")
        if not m.get("name") or not m.get("signals"):
            raise ScenarioError(f"{w}: needs 'name' and 'signals'")
        need = {"settling_time": "tolerance", "time_in_saturation": "limit", "l2_ratio": "disturbances",
                "max_difference": "versus"}
        if m["kind"] in need and need[m["kind"]] not in m:
            raise ScenarioError(f"{w}: kind {m['kind']} needs {need[m['kind']]!r}")
    return Scenario(path, data)


def fmu_paths(scenario: Scenario, fmu_dir: Path, backend: str) -> dict[str, Path]:
    """Instance name -> FMU file, for the chosen default backend."""
    if backend not in BACKENDS:
        raise ScenarioError(f"backend must be one of {sorted(BACKENDS)}, got {backend!r}")
    out = {}
    for inst, spec in scenario.data["fmus"].items():
        if "path" in spec:
            p = Path(spec["path"])
            out[inst] = p if p.is_absolute() else scenario.path.parent / p
        else:
            out[inst] = Path(fmu_dir) / f"{spec['model']}{BACKENDS[spec.get('backend', backend)]}.fmu"
    return out


def profiles(scenario: Scenario) -> list[tuple[str, Profile]]:
    """The scenario's disturbance profiles, built: (target ``instance.variable``, profile).

    Raises
    ------
    fmus.profiles.ProfileError
    """
    d = scenario.data
    out = []
    for i, p in enumerate(d.get("profiles", [])):
        spec = {k: v for k, v in p.items() if k != "to"}
        out.append((p["to"], make_profile(spec, f"{scenario.path.name}: profiles[{i}]", scenario.path.parent,
                                          d["step_size"])))
    return out


def grid(scenario: Scenario) -> np.ndarray:
    """The communication times of the scenario, s (as the master steps them)."""
    d = scenario.data
    t0 = d.get("start_time", 0.0)
    return communication_times(t0, d["step_size"], round((d["stop_time"] - t0) / d["step_size"]))


def recorded(scenario: Scenario, sim: CoSimulation) -> list[str]:
    """The qualified variables a run of ``scenario`` records: its ``record`` list and every
    signal its metrics read, base names expanded, each once."""
    record = list(scenario.data.get("record", []))
    for m in scenario.data.get("metrics", []):
        record += m["signals"] + m.get("disturbances", []) + m.get("versus", [])
    return list(dict.fromkeys(_columns(sim, record)))


def _columns(sim: CoSimulation, names: list[str]) -> list[str]:
    cols = []
    for n in names:
        comp, vs = sim.resolve(n)
        cols += [f"{comp.name}.{v}" for v in vs]
    return cols


def simulate(scenario: Scenario, fmu_dir: Path, backend: str = "native") -> tuple[np.ndarray, CoSimulation]:
    """Run the scenario's co-simulation; returns the recorded array and the (closed) master."""
    d = scenario.data
    sim = CoSimulation(fmu_paths(scenario, fmu_dir, backend))
    try:
        for c in d.get("connections", []):
            sim.connect(c["from"], c["to"])
        for target, prof in profiles(scenario):
            sim.add_profile(target, prof)
        record = recorded(scenario, sim)
        params = {inst: spec.get("parameters", {}) for inst, spec in d["fmus"].items()}
        res = sim.run(d["stop_time"], d["step_size"], d.get("start_time", 0.0), params, record)
    finally:
        sim.close()
    return res, sim


def evaluate(scenario: Scenario, res: np.ndarray, sim: CoSimulation
             ) -> tuple[list[M.MetricResult], dict[str, np.ndarray]]:
    """Evaluate the scenario's metrics on a recorded run."""
    t = res["time"]
    held = sim.held_signals()
    out, curves = [], {}
    for m in scenario.data.get("metrics", []):
        scale = float(m.get("scale", 1.0))
        cols = _columns(sim, m["signals"])
        y = np.stack([res[c] for c in cols], axis=1) * scale
        is_held = all(c in held for c in cols)
        kind = m["kind"]
        if kind == "final":
            value = float(np.max(np.abs(y[-1])))
        elif kind == "peak":
            value = M.peak(y)
        elif kind == "rms":
            value = M.rms(t, y, held=is_held)
        elif kind == "settling_time":
            value = M.settling_time(t, y, float(m["tolerance"]))
        elif kind == "time_in_saturation":
            value = M.time_in_saturation(t, y, float(m["limit"]), held=is_held)
        elif kind == "integral_square":
            value = M.integral_square(t, y, [c in sim.input_signals() for c in cols])
        elif kind == "max_difference":
            vcols = _columns(sim, m["versus"])
            if len(vcols) != len(cols):
                raise ScenarioError(f"metric {m['name']!r}: {len(cols)} signals but {len(vcols)} 'versus' signals")
            value = M.peak(y - np.stack([res[c] for c in vcols], axis=1) * scale)
        else:
            wcols = _columns(sim, m["disturbances"])
            w = np.stack([res[c] for c in wcols], axis=1)
            curve = M.l2_ratio_curve(t, y, w, w_held=all(c in held for c in wcols))
            curves[m["name"]] = curve
            value = float(np.nanmax(curve)) if np.any(np.isfinite(curve)) else math.nan
        out.append(M.MetricResult(m["name"], kind, value, m.get("min"), m.get("max"), m.get("unit", "")))
    return out, curves


def write_csv(res: np.ndarray, path: Path) -> None:
    """Write a structured result array as CSV (header = field names)."""
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(res.dtype.names)
        for row in res:
            w.writerow([repr(float(v)) for v in row])


def run(name_or_path: str | Path, fmu_dir: Path, backend: str = "native",
        out_dir: Path | None = None) -> ScenarioResult:
    """Load, simulate, evaluate and (if ``out_dir``) write CSV, PNG plots and summary.json."""
    from sims import plots

    scenario = load(name_or_path)
    res, sim = simulate(scenario, fmu_dir, backend)
    mres, curves = evaluate(scenario, res, sim)
    result = ScenarioResult(scenario.name, backend, res, mres, l2_curves=curves)
    if out_dir is not None:
        folder = Path(out_dir) / scenario.name
        folder.mkdir(parents=True, exist_ok=True)
        result.files["csv"] = folder / f"{scenario.name}_{backend}.csv"
        write_csv(res, result.files["csv"])
        panels = scenario.data.get("plot", {}).get("panels") or [[r] for r in scenario.data.get("record", [])]
        result.files["plot"] = folder / f"{scenario.name}_{backend}.png"
        cols = [_columns(sim, p) for p in panels]
        units = {c: sim.unit(c) for group in cols for c in group}
        plots.time_series(res, cols, result.files["plot"],
                          title=f"{scenario.name}: {scenario.data.get('description', '')}", units=units)
        if curves:
            f = folder / f"{scenario.name}_{backend}_l2_ratio.png"
            bounds = {m.name: m.max for m in mres}
            plots.l2_ratio(res["time"], {n: (c, bounds[n]) for n, c in curves.items()}, f,
                           title=f"{scenario.name}: truncated L2 ratio over T")
            result.files["l2_ratio_plot"] = f
        result.files["summary"] = folder / f"summary_{backend}.json"
        result.files["summary"].write_text(json.dumps(result.summary(), indent=1) + "\n")
    return result
