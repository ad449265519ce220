"""Validation of a scenario's declaration as plain data (the TOML file's keys), key path by key path.

:func:`validate` checks every table of the declaration (:mod:`satfmu.sims.scenario.spec`'s module
docstring) before a :class:`~satfmu.sims.scenario.spec.Scenario` is made of it; variable names
are checked against the FMUs later, when the master is wired
(:func:`satfmu.sims.scenario.wiring.wire`).
"""
from __future__ import annotations

import math
from typing import Any, Mapping

from satfmu.controllers.paths import BACKENDS
from satfmu.fmus.declared import check_keys, check_safe_name, did_you_mean
from satfmu.fmus.errors import ScenarioError
from satfmu.sims.scenario.dispersions import DispersionError, Dispersions
from satfmu.sims.scenario.metrics import KINDS

_TOP = ("name", "description", "stop_time", "step_size", "start_time", "fmus", "connections",
        "profiles", "record", "metrics", "plot", "reference", "verify", "dispersions", "campaign", "record_every",
        "unconnected")
_FMU = ("model", "path", "backend", "parameters")
_METRIC = ("name", "kind", "signals", "scale", "unit", "min", "max", "tolerance", "limit",
           "disturbances", "versus", "description")

MAX_STEPS = 10_000_000
"""Most recorded communication points of one run (a typo'd stop time fails here, not in a
MemoryError)."""
UNCONNECTED = ("error", "zero")
"""Values of a scenario's ``unconnected`` key: refuse an undriven input meant to be driven, or run
with its start value (:func:`satfmu.sims.scenario.wiring.undriven`)."""
CAMPAIGN_KEYS = {"samples": 1, "demo_samples": 1, "seed": 0}
"""Keys of a scenario's ``[campaign]`` table -> the least integer each takes."""
_NEEDS = {"settling_time": "tolerance", "time_in_saturation": "limit", "time_to_limit": "limit",
          "l2_ratio": "disturbances",
          "max_difference": "versus", "attitude_difference": "versus"}


def _number(v: Any, where: str, positive: bool = False) -> float:
    """``v`` as a float; ``where`` is its key path."""
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or (positive and v <= 0):
        raise ScenarioError(f"{where}: must be a finite number{' > 0' if positive else ''}, got {v!r}")
    return float(v)


def _signal(name: Any, instances: list[str], where: str) -> None:
    """``"instance.variable"`` with a declared instance."""
    if not isinstance(name, str) or "." not in name:
        raise ScenarioError(f"{where}: must be 'instance.variable', got {name!r}")
    inst = name.split(".", 1)[0]
    if inst not in instances:
        raise ScenarioError(f"{where}: {name!r} names no FMU instance {inst!r} (instances: "
                            f"{', '.join(instances)}){did_you_mean(inst, instances)}")


def _strings(data: Mapping[str, Any], key: str, where: str, instances: list[str]) -> None:
    value = data.get(key, [])
    if not isinstance(value, list):
        raise ScenarioError(f"{where}.{key}: must be a list of 'instance.variable' names")
    for i, n in enumerate(value):
        _signal(n, instances, f"{where}.{key}[{i}]")


def validate(data: Any, where: str = "scenario") -> None:
    """Check a scenario declaration (plain data); names are checked against the FMUs at run time.

    Parameters
    ----------
    data : mapping
        The declaration (any value: a non-mapping is refused).
    where : str
        Where it comes from (a file name), the first part of every error's key path.

    Raises
    ------
    ScenarioError
        Naming the key path (``where: metrics[0].kind: ...``) and, for unknown keys and
        instance names, the closest known one.
    """
    if not isinstance(data, Mapping):
        raise ScenarioError(f"{where}: expected a table of keys, got {type(data).__name__}")
    check_keys(data, _TOP, where, ScenarioError)
    plot = data.get("plot", {})
    if not isinstance(plot, Mapping):
        raise ScenarioError(f"{where}: [plot] must be a table")
    check_keys(plot, ("panels",), f"{where}: plot", ScenarioError)
    for key in ("name", "stop_time", "step_size", "fmus"):
        if key not in data:
            raise ScenarioError(f"{where}: missing key {key!r}")
    check_safe_name(data["name"], f"{where}: name", ScenarioError)  # the name is the output folder's
    w = f"{where}: "
    stop, step = (_number(data[k], w + k, True) for k in ("stop_time", "step_size"))
    start = _number(data["start_time"], w + "start_time") if "start_time" in data else 0.0
    if step > stop - start:
        raise ScenarioError(f"{w}step_size {step:g} s exceeds the run length stop_time - start_time = "
                            f"{stop - start:g} s")
    n_float = (stop - start) / step
    every = data.get("record_every", 1)
    if isinstance(every, bool) or not isinstance(every, int) or every < 1:
        raise ScenarioError(f"{w}record_every: must be an integer >= 1, got {every!r}")
    if data.get("unconnected", "error") not in UNCONNECTED:
        raise ScenarioError(f"{w}unconnected: must be one of {', '.join(map(repr, UNCONNECTED))}, got "
                            f"{data['unconnected']!r}{did_you_mean(str(data['unconnected']), list(UNCONNECTED))}")
    if not n_float / every <= MAX_STEPS:  # an infinite count too (stop_time = 1e308)
        raise ScenarioError(f"{w}stop_time: {n_float:.3g} communication steps, {n_float / every:.3g} recorded, more "
                            f"than {MAX_STEPS:.0e} (the recorded signals alone would need "
                            f"{n_float / every * 8 / 2**30:.3g} GiB per column; record_every thins them)")
    if abs(n_float - round(n_float)) > 1e-9 * max(1.0, n_float):
        raise ScenarioError(f"{w}step_size: (stop_time - start_time) / step_size = {n_float:.12g} is not an integer")
    for key in ("connections", "profiles", "metrics", "record"):
        if key in data and not isinstance(data[key], list):
            raise ScenarioError(f"{w}{key}: must be a list (TOML array{' of tables' if key != 'record' else ''}), "
                                f"got {type(data[key]).__name__} {data[key]!r}")
    fmus = data["fmus"]
    if not isinstance(fmus, Mapping) or not fmus:
        raise ScenarioError(f"{w}fmus: must declare at least one FMU instance")
    instances = list(fmus)
    for inst, spec in fmus.items():
        ws = f"{w}fmus.{inst}"
        if not isinstance(spec, Mapping):
            raise ScenarioError(f"{ws}: must be a table with 'model' or 'path'")
        check_keys(spec, _FMU, ws, ScenarioError)
        if ("model" in spec) == ("path" in spec):
            raise ScenarioError(f"{ws}: needs exactly one of 'model' or 'path'")
        for key in ("model", "path"):
            if key in spec and (not isinstance(spec[key], str) or not spec[key]):
                raise ScenarioError(f"{ws}.{key}: must be a non-empty string, got {spec[key]!r}")
        if "model" in spec:  # the model names a file of the FMU folder
            check_safe_name(spec["model"], f"{ws}.model", ScenarioError)
        if spec.get("backend", "native") not in BACKENDS:
            raise ScenarioError(f"{ws}.backend: must be one of {sorted(BACKENDS)}, got {spec['backend']!r}"
                                f"{did_you_mean(str(spec['backend']), sorted(BACKENDS))}")
        params = spec.get("parameters", {})
        if not isinstance(params, Mapping):
            raise ScenarioError(f"{ws}.parameters: must be a table of start values")
        for k, v in params.items():
            _check_start_value(v, f"{ws}.parameters.{k}")
    for i, c in enumerate(data.get("connections", [])):
        wc = f"{w}connections[{i}]"
        if not isinstance(c, Mapping):
            raise ScenarioError(f"{wc}: must be a table with 'from' and 'to'")
        check_keys(c, ("from", "to"), wc, ScenarioError)
        for key in ("from", "to"):
            if key not in c:
                raise ScenarioError(f"{wc}: missing key {key!r}")
            _signal(c[key], instances, f"{wc}.{key}")
    for i, p in enumerate(data.get("profiles", [])):
        if not isinstance(p, Mapping) or "to" not in p:
            raise ScenarioError(f"{w}profiles[{i}]: needs a 'to' target")
        _signal(p["to"], instances, f"{w}profiles[{i}].to")
    for i, n in enumerate(data.get("record", [])):
        if isinstance(n, Mapping):
            check_keys(n, ("signal", "unit"), f"{w}record[{i}]", ScenarioError)
            if not isinstance(n.get("unit"), str) or not n["unit"] or "signal" not in n:
                raise ScenarioError(f"{w}record[{i}]: a table entry needs 'signal' and a 'unit' (a string such as "
                                    f"\"deg\"), got {dict(n)!r}")
            n = n["signal"]
        _signal(n, instances, f"{w}record[{i}]")
    ver = data.get("verify", {})
    if not isinstance(ver, Mapping) or set(ver) - {"rtol", "atol", "reason"} or ver and not ver.get("reason") or any(
            isinstance(ver.get(k, 0.0), bool) or not isinstance(ver.get(k, 0.0), (int, float))
            or not 0 <= ver.get(k, 0.0) < 1 for k in ("rtol", "atol")):
        raise ScenarioError(f"{w}verify: takes rtol and atol in [0, 1) and needs a 'reason' for them")
    for i, m in enumerate(data.get("metrics", [])):
        wm = f"{w}metrics[{i}]"
        if not isinstance(m, Mapping):
            raise ScenarioError(f"{wm}: must be a table")
        check_keys(m, _METRIC, wm, ScenarioError)
        if m.get("kind") not in KINDS:
            raise ScenarioError(f"{wm}.kind: must be one of {KINDS}, got {m.get('kind')!r}"
                                f"{did_you_mean(str(m.get('kind')), list(KINDS))}")
        if not m.get("name") or not m.get("signals"):
            raise ScenarioError(f"{wm}: needs 'name' and 'signals'")
        if m["kind"] in _NEEDS and _NEEDS[m["kind"]] not in m:
            raise ScenarioError(f"{wm}: kind {m['kind']} needs {_NEEDS[m['kind']]!r}")
        for key in ("signals", "disturbances", "versus"):
            _strings(m, key, wm, instances)
        for key in ("scale", "min", "max", "tolerance", "limit"):
            if key in m:
                _number(m[key], f"{wm}.{key}")
    if "dispersions" in data:
        _dispersions(data["dispersions"], f"{w}dispersions", instances, len(data.get("profiles", [])))
    if "campaign" in data:
        _campaign(data["campaign"], f"{w}campaign", "dispersions" in data)


def _campaign(table: Any, where: str, dispersed: bool) -> None:
    """Check a ``[campaign]`` table (:data:`CAMPAIGN_KEYS`); a :class:`ScenarioError` names the key path."""
    if not isinstance(table, Mapping):
        raise ScenarioError(f"{where}: must be a table of {', '.join(CAMPAIGN_KEYS)}, got {table!r}")
    check_keys(table, tuple(CAMPAIGN_KEYS), where, ScenarioError)
    if not dispersed:
        raise ScenarioError(f"{where}: a campaign needs a [dispersions] table (what each sample draws)")
    for key, least in CAMPAIGN_KEYS.items():
        v = table.get(key, least)
        if isinstance(v, bool) or not isinstance(v, int) or v < least:
            raise ScenarioError(f"{where}.{key}: must be an integer >= {least}, got {table[key]!r}")
    if table.get("demo_samples", 1) > table.get("samples", math.inf):
        raise ScenarioError(f"{where}.demo_samples: {table['demo_samples']} is more than samples = {table['samples']}")


def _check_start_value(v: Any, where: str) -> None:
    """A start value is a finite number, a boolean or a string."""
    if isinstance(v, float) and not math.isfinite(v):
        raise ScenarioError(f"{where}: must be finite, got {v!r}")
    if not isinstance(v, (bool, int, float, str)):
        raise ScenarioError(f"{where}: must be a number, boolean or string, got {v!r}")


def _dispersions(data: Any, where: str, instances: list[str], n_profiles: int) -> Dispersions:
    """The ``[dispersions]`` table, validated; a :class:`ScenarioError` names the key path."""
    try:
        return Dispersions.from_dict(data, where, instances, n_profiles)
    except DispersionError as exc:
        raise ScenarioError(str(exc)) from None
