"""Closed-loop metrics on recorded trajectories, and their pass/fail evaluation.

All functions take the time vector ``t`` (s, increasing) and a signal matrix of
shape (len(t), n_signals). Signals of FMU *inputs* fed by the master are held
over each communication step, so their integrals use the left rectangle rule;
FMU outputs of continuous states use the trapezoidal rule.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

import numpy as np


def _cumulative(t: np.ndarray, v2: np.ndarray, held: bool) -> np.ndarray:
    dt = np.diff(t)
    inc = v2[:-1] * dt if held else 0.5 * (v2[:-1] + v2[1:]) * dt
    return np.concatenate([[0.0], np.cumsum(inc)])


def l2_ratio_curve(t: np.ndarray, z: np.ndarray, w: np.ndarray, w_held: bool = True) -> np.ndarray:
    """Truncated L2 ratio ||z||_{2,T} / ||w||_{2,T} for every recorded T (seed 000, eq. 45).

    NaN where ||w||_{2,T} = 0.
    """
    nz = _cumulative(t, np.sum(np.atleast_2d(z.T).T ** 2, axis=1), held=False)
    nw = _cumulative(t, np.sum(np.atleast_2d(w.T).T ** 2, axis=1), held=w_held)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(nw > 0, np.sqrt(nz) / np.sqrt(np.where(nw > 0, nw, 1.0)), np.nan)


def settling_time(t: np.ndarray, y: np.ndarray, tolerance: float) -> float:
    """First time from which every ``|y_i| <= tolerance`` until the end; inf if never."""
    inside = np.all(np.abs(np.atleast_2d(y.T).T) <= tolerance, axis=1)
    if not inside[-1]:
        return math.inf
    outside = np.nonzero(~inside)[0]
    return float(t[0] if outside.size == 0 else t[outside[-1] + 1])


def peak(y: np.ndarray) -> float:
    """Largest absolute value over time and signals."""
    return float(np.max(np.abs(y)))


def rms(t: np.ndarray, y: np.ndarray, held: bool = True) -> float:
    """Largest per-signal RMS over the run."""
    y = np.atleast_2d(y.T).T
    span = t[-1] - t[0]
    return float(max(math.sqrt(_cumulative(t, y[:, i] ** 2, held)[-1] / span) for i in range(y.shape[1])))


def time_in_saturation(t: np.ndarray, y: np.ndarray, limit: float, held: bool = True,
                       rel_tol: float = 1e-9) -> float:
    """Total time (s) during which any ``|y_i|`` is at or beyond ``limit`` (within ``rel_tol``)."""
    sat = np.any(np.abs(np.atleast_2d(y.T).T) >= limit * (1 - rel_tol), axis=1)
    dt = np.diff(t)
    flags = sat[:-1] if held else 0.5 * (sat[:-1].astype(float) + sat[1:])
    return float(np.sum(flags * dt))


def integral_square(t: np.ndarray, y: np.ndarray, held: Sequence[bool]) -> float:
    """``integral of sum_i y_i^2 dt`` over the run (e.g. an H2 cost with unit weights), each
    signal by its own rule (``held[i]``: left rectangle, else trapezoidal)."""
    y = np.atleast_2d(y.T).T
    return float(sum(_cumulative(t, y[:, i] ** 2, held[i])[-1] for i in range(y.shape[1])))


KINDS = ("final", "peak", "rms", "settling_time", "l2_ratio", "time_in_saturation", "integral_square",
         "max_difference")


@dataclass
class MetricResult:
    """One evaluated metric with its bounds."""

    name: str
    kind: str
    value: float
    min: float | None
    max: float | None
    unit: str = ""

    @property
    def passed(self) -> bool:
        ok = not math.isnan(self.value)
        if self.max is not None:
            ok &= self.value <= self.max
        if self.min is not None:
            ok &= self.value >= self.min
        return bool(ok)

    def to_json(self) -> dict[str, Any]:
        return {"name": self.name, "kind": self.kind, "value": self.value, "unit": self.unit,
                "min": self.min, "max": self.max, "passed": self.passed}


def summaries_markdown(summaries: Sequence[dict[str, Any]]) -> str:
    """Scenario run summaries (``satfmu.sims.scenario.Result.summary()``) as a Markdown table, one row per metric."""
    lines = ["| scenario | backend | metric | value | unit | bounds | result |", "|---|---|---|---|---|---|---|"]
    for s in summaries:
        for m in s["metrics"]:
            bounds = " ".join(f"{k} {m[k]:g}" for k in ("min", "max") if m[k] is not None)
            lines.append(f"| {s['scenario']} | {s['backend']} | {m['name']} | {m['value']:.6g} | {m['unit']} | "
                         f"{bounds} | {'pass' if m['passed'] else 'FAIL'} |")
    return "\n".join(lines) + "\n"


def write_summaries(summaries: Sequence[dict[str, Any]], path: Path) -> tuple[Path, Path]:
    """Write the run summaries to ``path`` (JSON) and beside it as Markdown (``.md``, :func:`summaries_markdown`).

    Returns
    -------
    (Path, Path)
        The JSON and the Markdown file.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(list(summaries), indent=1) + "\n")
    md = path.with_suffix(".md")
    md.write_text(summaries_markdown(summaries))
    return path, md
