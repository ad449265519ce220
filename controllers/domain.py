"""Where a certificate holds, in numbers: an artifact's ``certificate.domain``.

``certificate.region`` says in words where a controller's claim was proved; ``domain`` says
it so a program can check a run against it (:mod:`satfmu.sims.scenario.coverage`: which
samples of a campaign start outside the certified region). It is a list of constraints on the
controller's inputs (the measured states the law reads, by their input names), every one of
which must hold::

    "domain": [{"inputs": ["sigma[1]", "sigma[2]", "sigma[3]"], "norm_max": 0.9},
               {"inputs": ["q2"], "min": 0.17, "max": 1.24}]

- ``norm_max``: the Euclidean norm of the inputs' values is at most this (a ball, ``|sigma| <= 0.9``);
- ``min`` and ``max`` (one input, either or both): an interval, in the input's unit.

An empty list is a claim that holds for every state (a global certificate; the plant's
parameters may still be bounded, by ``provenance.design_plant``). An artifact without
``domain`` states its region in words only: nothing can be checked against it.
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from satfmu.fmus.errors import ArtifactError

TOL = 1e-9
"""Relative slack of a constraint (a value on the boundary, up to rounding, is inside)."""


def ball(inputs: Sequence[str], radius: float) -> dict[str, Any]:
    """The constraint ``|x| <= radius`` on the inputs ``x``.

    Parameters
    ----------
    inputs : sequence of str
        Controller input names (``"sigma[1]"``, ...).
    radius : float
        The ball's radius, in the inputs' unit, > 0.
    """
    return {"inputs": list(inputs), "norm_max": float(radius)}


def interval(name: str, low: float | None = None, high: float | None = None) -> dict[str, Any]:
    """The constraint ``low <= x <= high`` on one input.

    Parameters
    ----------
    name : str
        Controller input name.
    low, high : float, optional
        Bounds in the input's unit (None: unbounded on that side).
    """
    out: dict[str, Any] = {"inputs": [name]}
    if low is not None:
        out["min"] = float(low)
    if high is not None:
        out["max"] = float(high)
    return out


def parse(domain: Any, where: str) -> list[dict[str, Any]]:
    """Check a ``certificate.domain`` as read from JSON.

    Parameters
    ----------
    domain : object
        The value of ``certificate.domain``.
    where : str
        Its key path, for messages (``"artifact.certificate.domain"``).

    Returns
    -------
    list of dict
        The constraints, unchanged.

    Raises
    ------
    ArtifactError
        Not a list of constraints as the module docstring says (key path and reason).
    """
    if not isinstance(domain, list):
        raise ArtifactError(f"{where}: must be a list of constraints, got {type(domain).__name__}")
    for k, c in enumerate(domain):
        w = f"{where}[{k}]"
        if not isinstance(c, dict):
            raise ArtifactError(f"{w}: must be a table, got {type(c).__name__}")
        unknown = sorted(set(c) - {"inputs", "norm_max", "min", "max"})
        if unknown:
            raise ArtifactError(f"{w}: unknown keys {unknown} (a constraint has inputs and norm_max, or min/max)")
        names = c.get("inputs")
        if not (isinstance(names, list) and names and all(isinstance(n, str) and n for n in names)):
            raise ArtifactError(f"{w}.inputs: must be a non-empty list of input names")
        bounds = {key: c[key] for key in ("norm_max", "min", "max") if key in c}
        for key, v in bounds.items():
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise ArtifactError(f"{w}.{key}: must be a finite number, got {v!r}")
        if "norm_max" in c:
            if "min" in c or "max" in c:
                raise ArtifactError(f"{w}: norm_max (a ball) and min/max (an interval) do not mix")
            if not c["norm_max"] > 0:
                raise ArtifactError(f"{w}.norm_max: must be > 0, got {c['norm_max']!r}")
        else:
            if len(names) != 1:
                raise ArtifactError(f"{w}: an interval (min/max) bounds one input, got {len(names)}")
            if not bounds:
                raise ArtifactError(f"{w}: no bound (norm_max, min or max)")
            if "min" in c and "max" in c and not c["min"] <= c["max"]:
                raise ArtifactError(f"{w}: min {c['min']!r} > max {c['max']!r}")
    return domain


def describe(constraint: Mapping[str, Any]) -> str:
    """A constraint in words (``"|sigma[1..3]| <= 0.9"``, ``"0.17 <= q2 <= 1.24"``).

    Parameters
    ----------
    constraint : mapping
        One constraint of a domain.
    """
    names = list(constraint["inputs"])
    if "norm_max" in constraint:
        base = {n.split("[")[0] for n in names}
        label = f"{base.pop()}[{names[0].split('[')[-1][:-1]}..{names[-1].split('[')[-1][:-1]}]" \
            if len(base) == 1 and all("[" in n for n in names) and len(names) > 1 else ", ".join(names)
        return f"|{label}| <= {constraint['norm_max']:g}"
    lo, hi = constraint.get("min"), constraint.get("max")
    if lo is not None and hi is not None:
        return f"{names[0]} = {lo:g}" if lo == hi else f"{lo:g} <= {names[0]} <= {hi:g}"
    return f"{names[0]} >= {lo:g}" if lo is not None else f"{names[0]} <= {hi:g}"


def violations(domain: Sequence[Mapping[str, Any]], values: Mapping[str, float]) -> list[tuple[str, float]]:
    """The constraints a state violates.

    Parameters
    ----------
    domain : sequence of mapping
        A parsed domain (:func:`parse`).
    values : mapping of str to float
        The controller inputs' values (every input the domain names), in their units.

    Returns
    -------
    list of (str, float)
        Each violated constraint in words (:func:`describe`) and the state's value it bounds
        (the norm of a ball's inputs, an interval's input); empty when the state is inside.
        A NaN value violates its constraint.

    Raises
    ------
    KeyError
        A value the domain needs is missing (named).
    """
    out = []
    for c in domain:
        missing = [n for n in c["inputs"] if n not in values]
        if missing:
            raise KeyError(f"the domain constrains {missing}, which have no value")
        if "norm_max" in c:
            x = math.sqrt(sum(float(values[n]) ** 2 for n in c["inputs"]))
            inside = x <= c["norm_max"] * (1 + TOL)
        else:
            x = float(values[c["inputs"][0]])
            slack = TOL * max(1.0, abs(x))
            inside = c.get("min", -math.inf) - slack <= x <= c.get("max", math.inf) + slack
        if not inside:
            out.append((describe(c), x))
    return out
