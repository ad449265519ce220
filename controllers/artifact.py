"""Versioned JSON artifacts of controllers, validated on load.

Kinds: polynomial state feedback (below), gain-scheduled servo (:class:`ServoArtifact`),
periodic gain schedule (:class:`PeriodicArtifact`), static linear state feedback with named
gains (:class:`GainArtifact`).

An artifact is what synthesis writes and what a controller FMU is built from. It
holds the law, where it came from and what was proved about it. Two forms of the
law are accepted:

``"polynomial"``
    ``u_i = sum_k c_ik prod_j x_j^e_ikj``: for each output a list of terms
    ``{"c": coefficient, "e": [exponent per state]}``.
``"gain_times_lyapunov"``
    ``u = K(x) P x`` with ``K`` a matrix of polynomials (same term format, one list
    per entry) and ``P`` a constant symmetric matrix (seed 000, Theorem 1:
    ``P = Q^-1``).

Schema (format_version 1)::

    {"format": "satfmu-controller", "format_version": 1, "kind": "polynomial_state_feedback",
     "name": str, "description": str, "plant": str,
     "states":  [{"name": str, "unit": str}, ...],
     "outputs": [{"name": str, "unit": str, "description": str}, ...],
     "law": {"form": "polynomial", "terms": [[term, ...] per output]}
          | {"form": "gain_times_lyapunov", "K": [[[term, ...] per state] per output], "P": [[...]]},
     "lyapunov": {"Q": [[...]]}            (optional),
     "certificate": {"status": "certified" | "sampled" | "not_verified", "proved": str, "region": str,
                     "numbers": {str: float}, "domain": [...] (optional, :mod:`satfmu.controllers.domain`)},
     "provenance": {"source": str, "design_plant": {...} (see below), ...}}

Every kind records in ``provenance.design_plant`` the plant it was designed for
(:func:`design_plant_record`): ``{"model": str, "digest": "sha256:...", "parameters":
{name: value}}`` with the physical parameters the design used (a scenario that pairs the
controller with a plant whose values differ is warned about, :func:`plant_mismatches`), and
``"limits": {name: value}``, the plant's actuator limits (:data:`LIMIT_PARAMETERS`) the design
was made for: a controller FMU clips its commands at them by default.
"""
from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from satfmu.controllers import claims, domain
from satfmu.fmus.instants import INDEX_TOL
from satfmu.fmus.xml_text import xml_problem
from satfmu.fmus.errors import ArtifactError

if TYPE_CHECKING:
    from satfmu.fmus.model import Model

FORMAT = "satfmu-controller"
LIMIT_PARAMETERS = {"u_max": "N.m", "m_max": "A.m2"}
"""Plant parameters that are actuator limits (per axis): the torque limit of the MRP satellite,
the dipole limit of the magnetorquer cubesat. :func:`design_plant_record` records the plant's
values in ``design_plant.limits``."""
FORMAT_VERSION = 1
KIND = "polynomial_state_feedback"
SERVO_KIND = "servo_gain_schedule"
PERIODIC_KIND = "periodic_gain_schedule"
GAIN_KIND = "linear_state_feedback"
CERTIFICATE_STATUS = ("certified", "sampled", "not_verified")
"""certified: proved (SOS, Riccati check at the design point); sampled: checked on samples and
in simulation, no proof; not_verified: nothing checked."""
_NAME = re.compile(r"^[a-z][a-z0-9_]*$")
SCHEDULING_FUNCTIONS = {"sin": np.sin, "cos": np.cos}
"""Functions a servo's scheduling variable may apply to a measured signal (rad)."""
_SCHEDULING = re.compile(r"^(?:(?P<f>[a-z]+)\((?P<inner>\w+(?:\[\d+\])?)\)|(?P<plain>\w+(?:\[\d+\])?))$")


def scheduling_signal(entry: str) -> tuple[str | None, str]:
    """``(function, signal)`` of a scheduling entry ``"name"`` or ``"sin(name)"``/``"cos(name)"``.

    Parameters
    ----------
    entry : str
        One entry of a servo artifact's ``scheduling`` list: a signal name (``"q2"``) or a
        function of :data:`SCHEDULING_FUNCTIONS` applied to one (``"sin(q2)"``).

    Returns
    -------
    tuple of (str or None, str)
        The function's name (None for a plain signal) and the signal's name.

    Raises
    ------
    ValueError
        If ``entry`` has another form or names an unknown function.
    """
    m = _SCHEDULING.match(entry) if isinstance(entry, str) else None
    if m is None or (m["f"] is not None and m["f"] not in SCHEDULING_FUNCTIONS):
        raise ValueError(f"scheduling entry {entry!r} must be a signal name or one of "
                         f"{[f + '(name)' for f in SCHEDULING_FUNCTIONS]}")
    return (m["f"], m["inner"]) if m["f"] else (None, m["plain"])


MAX_EXPONENT = 64
"""The largest exponent of a state in a polynomial term (the shipped designs reach 4)."""
MAX_BYTES = 64 << 20
"""The largest artifact file read (B): the shipped ones hold up to 70 kB; a gain table of a
periodic design with thousands of samples stays far below."""


@dataclass(frozen=True)
class Term:
    """One monomial ``c * prod x_j^e_j``.

    Attributes
    ----------
    c : float
        The coefficient, in the unit of the output the term belongs to (per unit of the
        variables' product).
    e : tuple of int
        The exponent of each variable (a state, or a scheduling variable of a servo gain), one
        per variable, non-negative.
    """

    c: float
    e: tuple[int, ...]


def evaluate_terms(terms: list[Term], x: np.ndarray) -> np.ndarray:
    """``sum c prod x_j^e_j`` over the last axis of ``x``.

    Parameters
    ----------
    terms : list of Term
        The polynomial, one :class:`Term` per monomial (an empty list is the zero polynomial).
    x : numpy.ndarray, shape (..., n)
        Values of the variables, one per entry of the last axis (``n`` = the length of each
        term's ``e``).

    Returns
    -------
    numpy.ndarray, shape (...)
        The polynomial at each point of ``x``.
    """
    val = np.zeros(x.shape[:-1])
    for t in terms:
        val = val + t.c * np.prod(x ** np.array(t.e), axis=-1)
    return val


@dataclass
class ControllerArtifact:
    """A validated polynomial state-feedback controller artifact.

    Attributes
    ----------
    name : str
        The controller's name, lower_snake_case (it becomes the FMU's modelIdentifier).
    description : str
        One-line description of the controller.
    plant : str
        Model name of the plant it is designed for (``"mrp_satellite"``).
    states : list of dict
        The controller's inputs, the plant's states: ``{"name": str, "unit": str}`` each, in the
        order of the law's variables.
    outputs : list of dict
        The controller's outputs, the plant's command inputs: ``{"name": str, "unit": str,
        "description": str}`` each.
    terms : list of list of Term
        The law expanded to ``u_i = sum of terms``, one list per output (both forms end up here).
    law : dict
        The law as the file gives it (``{"form": "polynomial", ...}`` or ``{"form":
        "gain_times_lyapunov", ...}``), written back by :meth:`to_json`.
    certificate : dict
        What was proved: ``status`` (one of :data:`CERTIFICATE_STATUS`), ``proved``, ``region``
        and ``numbers``.
    provenance : dict
        Where the law came from: ``source`` and ``design_plant`` (:func:`design_plant_record`).
    lyapunov : dict, optional
        ``{"Q": matrix}`` of the certificate's Lyapunov function; empty when the file has none.
    """

    name: str
    description: str
    plant: str
    states: list[dict[str, str]]
    outputs: list[dict[str, str]]
    terms: list[list[Term]]
    """The law expanded to ``u_i = sum of terms`` (both forms end up here)."""
    law: dict[str, Any]
    certificate: dict[str, Any]
    provenance: dict[str, Any]
    lyapunov: dict[str, Any] = field(default_factory=dict)

    def evaluate(self, x: np.ndarray) -> np.ndarray:
        """``u(x)`` without saturation; ``x`` of shape (n_states,) or (n, n_states).

        Parameters
        ----------
        x : numpy.ndarray, shape (n_states,) or (n, n_states)
            The plant state, or ``n`` of them, in the units of ``states``.

        Returns
        -------
        numpy.ndarray, shape (n_outputs,) or (n, n_outputs)
            The commands, in the units of ``outputs``.

        Raises
        ------
        ValueError
            If the last axis of ``x`` is not one entry per state.
        """
        x = np.asarray(x, float)
        if x.shape[-1] != len(self.states):
            raise ValueError(f"artifact {self.name!r}: x has {x.shape[-1]} entries, expected {len(self.states)}")
        return np.stack([evaluate_terms(terms, x) for terms in self.terms], axis=-1)

    def to_json(self) -> dict[str, Any]:
        """The artifact as JSON-ready data (the law in its original form)."""
        data = {"format": FORMAT, "format_version": FORMAT_VERSION, "kind": KIND, "name": self.name,
                "description": self.description, "plant": self.plant, "states": self.states,
                "outputs": self.outputs, "law": self.law, "certificate": self.certificate,
                "provenance": self.provenance}
        if self.lyapunov:
            data["lyapunov"] = self.lyapunov
        return data


def new_data(plant: "Model", name: str, description: str, law: dict[str, Any], certificate: dict[str, Any],
             provenance: dict[str, Any], lyapunov: dict[str, Any] | None = None) -> dict[str, Any]:
    """JSON data of a new artifact for a state feedback of ``plant``: its states are the
    controller's inputs and its command inputs ``u[i]`` the controller's outputs; the
    provenance records ``plant`` (:func:`design_plant_record`).

    Parameters
    ----------
    plant : satfmu.fmus.model.Model
        The plant the state feedback is designed for.
    name : str
        The artifact's name, lower_snake_case (the controller FMU's modelIdentifier).
    description : str
        One-line description of the controller.
    law : dict
        The law, ``{"form": "polynomial", "terms": ...}`` or ``{"form": "gain_times_lyapunov",
        "K": ..., "P": ...}`` (the module's schema).
    certificate : dict
        ``{"status": ..., "proved": str, "region": str, "numbers": {str: float}}``.
    provenance : dict
        ``{"source": str, ...}``; ``design_plant`` is added from ``plant``.
    lyapunov : dict, optional
        ``{"Q": matrix}`` of the certificate's Lyapunov function; left out when not given.

    Returns
    -------
    dict
        The artifact's JSON data (not validated: :func:`parse` does that).
    """
    states = [{"name": s.variable.name, "unit": s.variable.unit} for s in plant.states]
    outputs = [{"name": v.name, "unit": v.unit, "description": v.description}
               for v in plant.inputs if v.base_name == "u"]
    data = {"format": FORMAT, "format_version": FORMAT_VERSION, "kind": KIND, "name": name, "plant": plant.name,
            "description": description, "states": states, "outputs": outputs, "law": law,
            "certificate": certificate, "provenance": {**provenance, "design_plant": design_plant_record(plant)}}
    if lyapunov:
        data["lyapunov"] = lyapunov
    return data


DESIGN_RTOL = 1e-3
"""Relative difference of a plant parameter from its design value beyond which a pairing is a mismatch."""


def design_plant_record(plant: "Model", names: list[str] | None = None, values: dict[str, float] | None = None,
                        ranges: dict[str, tuple[float, float]] | None = None) -> dict[str, Any]:
    """``provenance.design_plant`` of a design for ``plant``.

    Parameters
    ----------
    plant : satfmu.fmus.model.Model
        The plant the design was made for.
    names : list of str, optional
        Parameters the design depends on. Default: those of the plant's SDC form when it
        has one, else every Real parameter that is not a state's initial value or an
        integrator setting (switches and initial conditions are not part of a design).
    values : dict, optional
        Design values that differ from the plant's defaults (``start``).
    ranges : dict, optional
        ``{name: (low, high)}``: a robust design covers these intervals; a value inside is
        no mismatch.
    """
    from satfmu.fmus.digest import model_digest
    from satfmu.fmus.model import INTEGRATOR_PARAMETERS

    by_name = {v.name: v for v in plant.parameters}
    if names is None:
        if plant.sdc is not None:
            used = {str(s) for s in plant.sdc.A.free_symbols | plant.sdc.B.free_symbols}
            names = [v.name for v in plant.parameters if v.name in used]
        else:
            skip = {s.initial.name for s in plant.states} | {v.name for v in INTEGRATOR_PARAMETERS}
            names = [v.name for v in plant.parameters if v.type == "Real" and v.name not in skip]
    values, ranges = values or {}, ranges or {}
    unknown = [n for n in [*names, *values, *ranges] if n not in by_name]
    if unknown:
        raise ValueError(f"plant {plant.name!r} has no parameters {unknown}")
    record = {"model": plant.name, "digest": model_digest(plant),
              "parameters": {n: float(values.get(n, by_name[n].start)) for n in names}}
    limits = {n: float(values.get(n, by_name[n].start)) for n in LIMIT_PARAMETERS if n in by_name}
    if limits:
        record["limits"] = limits
    if ranges:
        record["ranges"] = {n: [float(lo), float(hi)] for n, (lo, hi) in ranges.items()}
    return record


def plant_mismatches(artifact: "Artifact", model: str, values: dict[str, float],
                     rtol: float = DESIGN_RTOL) -> list[str]:
    """How a plant differs from the one ``artifact`` was designed for (empty: it matches).

    Parameters
    ----------
    artifact : Artifact
        A controller artifact; one without ``provenance.design_plant`` never mismatches.
    model : str
        Model name of the plant it is paired with.
    values : dict
        That plant's parameter values (its defaults with the scenario's settings applied).
    rtol : float
        Relative tolerance: ``|value - design| > rtol max(|value|, |design|)`` is a mismatch.

    Returns
    -------
    list of str
        One line per differing parameter, e.g. ``"I_x = 100 (designed for 15)"``.
    """
    record = artifact.provenance.get("design_plant")
    if record is None or record["model"] != model:
        return []
    out = []
    for name, design in record["parameters"].items():
        v = values.get(name)
        if v is None:
            continue
        if name in record.get("ranges", {}):
            lo, hi = record["ranges"][name]
            if not lo - rtol * abs(lo) <= v <= hi + rtol * abs(hi):
                out.append(f"{name} = {v:g} (designed for [{lo:g}, {hi:g}])")
        elif abs(v - design) > rtol * max(abs(v), abs(design)):
            out.append(f"{name} = {v:g} (designed for {design:g})")
    return out


def _fail(where: str, msg: str) -> ArtifactError:
    return ArtifactError(f"{where}: {msg}")


def _get(data: dict, key: str, kind: type | tuple[type, ...], where: str) -> Any:
    if key not in data:
        raise _fail(where, f"missing key {key!r}")
    value = data[key]
    if not isinstance(value, kind) or isinstance(value, bool) and kind is not bool:
        raise _fail(where, f"{key!r} must be {getattr(kind, '__name__', kind)}, got {type(value).__name__}")
    return value


def _finite(v: Any, where: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise _fail(where, f"must be a finite number, got {v!r}")
    return float(v)


def _terms(raw: Any, n_states: int, where: str) -> list[Term]:
    if not isinstance(raw, list):
        raise _fail(where, "must be a list of terms")
    out = []
    for k, t in enumerate(raw):
        w = f"{where}[{k}]"
        if not isinstance(t, dict) or set(t) != {"c", "e"}:
            raise _fail(w, 'a term is {"c": coefficient, "e": [exponents]}')
        e = t["e"]
        if not isinstance(e, list) or len(e) != n_states:
            raise _fail(w, f"'e' must list {n_states} exponents (one per state)")
        if any(isinstance(v, bool) or not isinstance(v, int) or v < 0 for v in e):
            raise _fail(w, f"exponents must be non-negative integers, got {e}")
        if max(e, default=0) > MAX_EXPONENT:
            raise _fail(w, f"exponent {max(e)} is larger than {MAX_EXPONENT} (no controller is of that degree; "
                           "the generated C could not hold it)")
        out.append(Term(_finite(t["c"], w + ".c"), tuple(e)))
    return out


def _matrix(raw: Any, shape: tuple[int, int], where: str) -> np.ndarray:
    try:
        m = np.array(raw, dtype=float)
    except (TypeError, ValueError) as exc:
        raise _fail(where, f"not a numeric matrix ({exc})") from None
    if m.shape != shape:
        raise _fail(where, f"shape {m.shape}, expected {shape}")
    if not np.all(np.isfinite(m)):
        raise _fail(where, "contains non-finite entries")
    return m


def _multiply(a: list[Term], b: list[Term]) -> list[Term]:
    acc: dict[tuple[int, ...], float] = {}
    for s in a:
        for t in b:
            e = tuple(i + j for i, j in zip(s.e, t.e))
            acc[e] = acc.get(e, 0.0) + s.c * t.c
    return [Term(c, e) for e, c in acc.items()]


def _expand_kpx(K: list[list[list[Term]]], P: np.ndarray, n: int) -> list[list[Term]]:
    """Terms of ``u = K(x) P x``, like monomials merged."""
    linear = [[Term(float(P[j, k]), tuple(int(i == k) for i in range(n))) for k in range(n) if P[j, k] != 0]
              for j in range(n)]
    out = []
    for row in K:
        acc: dict[tuple[int, ...], float] = {}
        for j, kij in enumerate(row):
            for t in _multiply(kij, linear[j]):
                acc[t.e] = acc.get(t.e, 0.0) + t.c
        out.append([Term(c, e) for e, c in sorted(acc.items()) if c != 0.0])
    return out


def _check_named(items: list, label: str, where: str, keys: tuple[str, ...] = ("name", "unit")) -> None:
    if not items:
        raise _fail(f"{where}.{label}", "must not be empty")
    for i, s in enumerate(items):
        if not isinstance(s, dict) or any(not isinstance(s.get(k), str) for k in keys):
            raise _fail(f"{where}.{label}[{i}]", "must be {" + ", ".join(f'"{k}": str' for k in keys) + ", ...}")


def _check_texts(data: Any, where: str) -> None:
    """Refuse a string anywhere in ``data`` (keys too) holding a character that XML 1.0 cannot
    carry: an artifact's texts become the FMU's descriptions. Walked without recursion."""
    stack = [(data, where)]
    while stack:
        value, at = stack.pop()
        if isinstance(value, dict):
            for k, v in value.items():
                stack.append((k, f"{at} (a key)"))
                stack.append((v, f"{at}.{k}"))
        elif isinstance(value, list):
            stack.extend((v, f"{at}[{i}]") for i, v in enumerate(value))
        elif isinstance(value, str):
            problem = xml_problem(value)
            if problem:
                raise _fail(at, f"{problem}, a control character that an FMU's model description (XML 1.0) "
                                "cannot carry")


def parse(data: Any, where: str = "artifact") -> Artifact:
    """Validate JSON data and return the artifact.

    Beyond the schema, what the artifact claims is re-checked (:mod:`satfmu.controllers.claims`): its
    certificate status against the numbers it records and the matrices it holds, and a gain
    held twice (``design.K`` and ``gains``) for agreement.

    Parameters
    ----------
    data : Any
        The decoded JSON (a dict of one of the four kinds, anything else is refused).
    where : str, optional
        What ``data`` is called in error messages (the file's path when loaded from one).

    Returns
    -------
    Artifact
        A :class:`ControllerArtifact`, :class:`ServoArtifact`, :class:`PeriodicArtifact` or
        :class:`GainArtifact`, by the data's ``kind``.

    Raises
    ------
    ArtifactError
        Naming the offending key, e.g. ``"artifact.law.terms[0][2].e: ..."`` or
        ``"artifact.certificate.numbers['ms_spectral_radius'] = 1.5: status 'certified' needs < 1 ..."``.
    """
    artifact = _parse(data, where)
    found = claims.problems(data)
    if found:
        more = f" (and {len(found) - 1} more)" if len(found) > 1 else ""
        raise _fail(where, found[0] + more)
    return artifact


def _parse(data: Any, where: str) -> Artifact:
    """The artifact of schema-valid JSON data (:func:`parse` without the claims)."""
    if not isinstance(data, dict):
        raise _fail(where, "top level must be a JSON object")
    _check_texts(data, where)
    if data.get("format") != FORMAT:
        raise _fail(where, f"'format' must be {FORMAT!r}, got {data.get('format')!r}")
    version = data.get("format_version")
    if version != FORMAT_VERSION:
        raise _fail(where, f"format_version {version!r} is not supported (this satfmu reads {FORMAT_VERSION})")
    kinds = (KIND, SERVO_KIND, PERIODIC_KIND, GAIN_KIND)
    if data.get("kind") not in kinds:
        raise _fail(where, f"'kind' must be one of {kinds}, got {data.get('kind')!r}")
    name = _get(data, "name", str, where)
    if not _NAME.match(name):
        raise _fail(where, f"name {name!r} must be lower_snake_case (it becomes the FMU's modelIdentifier)")
    outputs = _get(data, "outputs", list, where)
    if data["kind"] == SERVO_KIND:
        _check_named(outputs, "outputs", where)
        return _parse_servo(data, where, name, outputs)
    if data["kind"] == PERIODIC_KIND:
        _check_named(outputs, "outputs", where)
        return _parse_periodic(data, where, name, outputs)
    if data["kind"] == GAIN_KIND:
        _check_named(outputs, "outputs", where)
        return _parse_gains(data, where, name, outputs)
    states = _get(data, "states", list, where)
    _check_named(states, "states", where)
    _check_named(outputs, "outputs", where)
    n = len(states)
    law = _get(data, "law", dict, where)
    form = law.get("form")
    if form == "polynomial":
        raw = _get(law, "terms", list, where + ".law")
        if len(raw) != len(outputs):
            raise _fail(where + ".law.terms", f"{len(raw)} polynomials for {len(outputs)} outputs")
        terms = [_terms(r, n, f"{where}.law.terms[{i}]") for i, r in enumerate(raw)]
    elif form == "gain_times_lyapunov":
        K = _get(law, "K", list, where + ".law")
        if len(K) != len(outputs) or any(not isinstance(r, list) or len(r) != n for r in K):
            raise _fail(where + ".law.K", f"must be {len(outputs)} x {n} polynomials")
        Kt = [[_terms(K[i][j], n, f"{where}.law.K[{i}][{j}]") for j in range(n)] for i in range(len(outputs))]
        P = _matrix(law.get("P"), (n, n), where + ".law.P")
        if not np.allclose(P, P.T, rtol=1e-12, atol=0):
            raise _fail(where + ".law.P", "must be symmetric")
        terms = _expand_kpx(Kt, P, n)
    else:
        raise _fail(where + ".law", f"'form' must be 'polynomial' or 'gain_times_lyapunov', got {form!r}")
    lyap = data.get("lyapunov", {})
    if lyap:
        Q = _matrix(lyap.get("Q"), (n, n), where + ".lyapunov.Q")
        if not np.allclose(Q, Q.T) or np.linalg.eigvalsh(Q).min() <= 0:
            raise _fail(where + ".lyapunov.Q", "must be symmetric positive definite")
    cert = _certificate(data, where)
    if "l2_gain" in cert:
        l2 = _get(cert, "l2_gain", dict, where + ".certificate")
        for key in ("c", "kv"):
            if _finite(l2.get(key), f"{where}.certificate.l2_gain.{key}") <= 0:
                raise _fail(f"{where}.certificate.l2_gain.{key}", "must be > 0")
        _get(l2, "region", str, where + ".certificate.l2_gain")
    prov = _provenance(data, where)
    return ControllerArtifact(name, _get(data, "description", str, where), _get(data, "plant", str, where),
                              states, outputs, terms, law, cert, prov, lyap)


@dataclass
class ServoArtifact:
    """A validated gain-scheduled servo: ``u = -K(s) xe`` with polynomial gain entries.

    Schema (kind ``"servo_gain_schedule"``, format_version 1)::

        {"format": "satfmu-controller", "format_version": 1, "kind": "servo_gain_schedule",
         "name": str, "description": str, "plant": str,
         "tracked":  [{"name": plant output, "reference": input name, "unit": str}, ...],
         "rates":    [{"name": plant output, "unit": str}, ...],
         "scheduling": [tracked or rate name, or "sin(name)" / "cos(name)", ...],
         "outputs":  [{"name": str, "unit": str, "description": str}, ...],
         "gain": [[[term, ...] per servo state] per output],   (exponents per scheduling variable)
         "certificate": {...}, "provenance": {...}, "fit": {...} (optional)}

    The servo state is ``xe = [int e_1 .. int e_m, e_1 .. e_m, rates]`` with
    ``e_i = reference_i - tracked_i``.

    Attributes
    ----------
    name : str
        The controller's name, lower_snake_case (the FMU's modelIdentifier).
    description : str
        One-line description of the controller.
    plant : str
        Model name of the plant it is designed for (``"vscmg"``).
    tracked : list of dict
        The tracked plant outputs, ``{"name": plant output, "reference": input name, "unit": str}``
        each.
    rates : list of dict
        The plant outputs fed back directly, ``{"name": plant output, "unit": str}`` each.
    scheduling : list of str
        The scheduling variables, each a tracked or rate name or ``"sin(name)"``/``"cos(name)"``
        (:func:`scheduling_signal`).
    outputs : list of dict
        The controller's outputs, ``{"name": str, "unit": str, "description": str}`` each.
    gain : list of list of list of Term
        ``K(s)``: per output, per servo state, a polynomial in the scheduling variables.
    certificate : dict
        What was proved: ``status``, ``proved``, ``region`` and ``numbers``.
    provenance : dict
        Where the gain came from: ``source`` and ``design_plant``.
    fit : dict, optional
        How a fitted gain was fitted (degree, scheduling, cross-validation,
        :mod:`satfmu.synthesis.servo.gain_fit`); empty when the file has none.
    """

    name: str
    description: str
    plant: str
    tracked: list[dict[str, str]]
    rates: list[dict[str, str]]
    scheduling: list[str]
    outputs: list[dict[str, str]]
    gain: list[list[list[Term]]]
    certificate: dict[str, Any]
    provenance: dict[str, Any]
    fit: dict[str, Any] = field(default_factory=dict)

    def scheduling_values(self, signals: dict[str, Any]) -> np.ndarray:
        """The scheduling variables from measured ``signals`` (name -> value or array):
        shape (n_sched,) or (n, n_sched), the argument of :meth:`gain_at`.

        Parameters
        ----------
        signals : dict
            ``{signal name: value}`` of the measured tracked and rate signals (rad, rad/s), each a
            float or an array of shape (n,); other keys are ignored.

        Returns
        -------
        numpy.ndarray, shape (n_sched,) or (n, n_sched)
            The scheduling variables, in the order of ``scheduling``.

        Raises
        ------
        KeyError
            If a signal the schedule needs is missing.
        """
        cols = []
        for entry in self.scheduling:
            f, name = scheduling_signal(entry)
            v = np.asarray(signals[name], float)
            cols.append(SCHEDULING_FUNCTIONS[f](v) if f else v)
        return np.stack(cols, axis=-1)

    def gain_at(self, s: np.ndarray) -> np.ndarray:
        """K at scheduling values ``s`` (shape (n_sched,) or (n, n_sched)) -> (..., n_out, n_servo).

        Parameters
        ----------
        s : numpy.ndarray, shape (n_sched,) or (n, n_sched)
            Scheduling variables, e.g. from :meth:`scheduling_values`.

        Returns
        -------
        numpy.ndarray, shape (n_out, n_servo) or (n, n_out, n_servo)
            The gain ``K(s)``.
        """
        s = np.asarray(s, float)
        return np.stack([np.stack([evaluate_terms(entry, s) for entry in row], axis=-1) for row in self.gain],
                        axis=-2)

    def to_json(self) -> dict[str, Any]:
        """The artifact as JSON-ready data (kind ``"servo_gain_schedule"``)."""
        data = {"format": FORMAT, "format_version": FORMAT_VERSION, "kind": SERVO_KIND, "name": self.name,
                "description": self.description, "plant": self.plant, "tracked": self.tracked,
                "rates": self.rates, "scheduling": self.scheduling, "outputs": self.outputs,
                "gain": [[[{"c": t.c, "e": list(t.e)} for t in entry] for entry in row] for row in self.gain],
                "certificate": self.certificate, "provenance": self.provenance}
        if self.fit:
            data["fit"] = self.fit
        return data


def _parse_servo(data: dict, where: str, name: str, outputs: list) -> ServoArtifact:
    tracked = _get(data, "tracked", list, where)
    rates = _get(data, "rates", list, where)
    _check_named(tracked, "tracked", where, ("name", "reference", "unit"))
    _check_named(rates, "rates", where)
    known = [t["name"] for t in tracked] + [r["name"] for r in rates]
    sched = _get(data, "scheduling", list, where)
    for v in sched:
        try:
            _, signal = scheduling_signal(v)
        except ValueError as exc:
            raise _fail(f"{where}.scheduling", str(exc)) from None
        if signal not in known:
            raise _fail(f"{where}.scheduling", f"{signal!r} is not a tracked or rate variable ({known})")
    n_servo = 2 * len(tracked) + len(rates)
    gain = _get(data, "gain", list, where)
    if len(gain) != len(outputs) or any(not isinstance(r, list) or len(r) != n_servo for r in gain):
        raise _fail(where + ".gain", f"must be {len(outputs)} x {n_servo} polynomials")
    K = [[_terms(gain[i][j], len(sched), f"{where}.gain[{i}][{j}]") for j in range(n_servo)]
         for i in range(len(outputs))]
    return ServoArtifact(name, _get(data, "description", str, where), _get(data, "plant", str, where),
                         tracked, rates, sched, outputs, K, _certificate(data, where),
                         _provenance(data, where), data.get("fit", {}))


@dataclass
class PeriodicArtifact:
    """A validated periodic gain schedule with zero-order hold: ``u = F(k) y`` held over a sample.

    Schema (kind ``"periodic_gain_schedule"``, format_version 1)::

        {"format": "satfmu-controller", "format_version": 1, "kind": "periodic_gain_schedule",
         "name": str, "description": str, "plant": str,
         "inputs":  [{"name": plant output, "unit": str}, ...],
         "outputs": [{"name": str, "unit": str, "description": str}, ...],
         "sample_period": Ts (s), "schedule_period": N * Ts (s),
         "gains": [F(0), ..., F(N-1)], each n_outputs x n_inputs,
         "certificate": {...}, "provenance": {...}, "design": {...} (optional)}

    The gain in use at orbit time ``tau`` is ``F(k)``, ``k = floor(tau / Ts) mod N``.

    Attributes
    ----------
    name : str
        The controller's name, lower_snake_case (the FMU's modelIdentifier).
    description : str
        One-line description of the controller.
    plant : str
        Model name of the plant it is designed for (``"cubesat"``).
    inputs : list of dict
        The measured plant outputs ``y``, ``{"name": plant output, "unit": str}`` each.
    outputs : list of dict
        The controller's outputs ``u``, ``{"name": str, "unit": str, "description": str}`` each.
    sample_period : float
        ``Ts``, the hold period of each gain (s).
    schedule_period : float
        ``N * Ts``, the period of the schedule (s): the orbit period.
    gains : numpy.ndarray, shape (N, n_outputs, n_inputs)
        ``F(0), ..., F(N-1)``, in the units of ``outputs`` per unit of ``inputs``.
    certificate : dict
        What was proved: ``status``, ``proved``, ``region`` and ``numbers``.
    provenance : dict
        Where the gains came from: ``source`` and ``design_plant``.
    design : dict, optional
        Data of the design (levels, analysis); empty when the file has none.
    """

    name: str
    description: str
    plant: str
    inputs: list[dict[str, str]]
    outputs: list[dict[str, str]]
    sample_period: float
    schedule_period: float
    gains: np.ndarray
    certificate: dict[str, Any]
    provenance: dict[str, Any]
    design: dict[str, Any] = field(default_factory=dict)

    @property
    def n_samples(self) -> int:
        """N, the number of gains (samples per schedule period)."""
        return len(self.gains)

    def gain_index(self, tau: np.ndarray | float) -> np.ndarray:
        """Index k of the gain in use at orbit time ``tau`` (s).

        Parameters
        ----------
        tau : float or numpy.ndarray
            Orbit time (s), a scalar or an array of any shape.

        Returns
        -------
        numpy.ndarray of int
            ``floor(tau / Ts) mod N`` (:data:`satfmu.fmus.instants.INDEX_TOL` of a sample added before
            the floor), of the shape of ``tau``.
        """
        return np.floor(np.asarray(tau, float) / self.sample_period + INDEX_TOL).astype(int) % self.n_samples

    def to_json(self) -> dict[str, Any]:
        """The artifact as JSON-ready data (kind ``"periodic_gain_schedule"``)."""
        data = {"format": FORMAT, "format_version": FORMAT_VERSION, "kind": PERIODIC_KIND, "name": self.name,
                "description": self.description, "plant": self.plant, "inputs": self.inputs,
                "outputs": self.outputs, "sample_period": self.sample_period,
                "schedule_period": self.schedule_period, "gains": self.gains.tolist(),
                "certificate": self.certificate, "provenance": self.provenance}
        if self.design:
            data["design"] = self.design
        return data


def _parse_periodic(data: dict, where: str, name: str, outputs: list) -> PeriodicArtifact:
    inputs = _get(data, "inputs", list, where)
    _check_named(inputs, "inputs", where)
    ts = _finite(data.get("sample_period"), where + ".sample_period")
    tp = _finite(data.get("schedule_period"), where + ".schedule_period")
    if ts <= 0 or tp <= 0:
        raise _fail(where, "sample_period and schedule_period must be > 0 s")
    gains = _get(data, "gains", list, where)
    n = round(tp / ts)
    if n < 1 or abs(n * ts - tp) > 1e-9 * tp:
        raise _fail(where, f"schedule_period {tp:g} s is not a whole number of sample periods {ts:g} s")
    if len(gains) != n:
        raise _fail(where + ".gains", f"{len(gains)} gains for {n} samples per schedule period")
    F = np.stack([_matrix(g, (len(outputs), len(inputs)), f"{where}.gains[{k}]") for k, g in enumerate(gains)])
    return PeriodicArtifact(name, _get(data, "description", str, where), _get(data, "plant", str, where),
                            inputs, outputs, ts, tp, F, _certificate(data, where), _provenance(data, where),
                            data.get("design", {}))


@dataclass
class GainArtifact:
    """A validated static state feedback given by named gains (the parameters of its FMU).

    Schema (kind ``"linear_state_feedback"``, format_version 1)::

        {"format": "satfmu-controller", "format_version": 1, "kind": "linear_state_feedback",
         "name": str, "description": str, "plant": str,
         "outputs": [{"name": str, "unit": str, "description": str}, ...],
         "gains": {"K_block[i,j]": float, ...},
         "certificate": {...}, "provenance": {...}, "design": {...} (optional)}

    Gains not listed are 0. Which gain names exist is the law's business
    (:func:`satfmu.controllers.state_feedback.build` rejects unknown ones).

    Attributes
    ----------
    name : str
        The controller's name, lower_snake_case (the FMU's modelIdentifier).
    description : str
        One-line description of the controller.
    plant : str
        Model name of the plant it is designed for (``"demeter"``).
    outputs : list of dict
        The controller's outputs, ``{"name": str, "unit": str, "description": str}`` each.
    gains : dict
        ``{"K_block[i,j]": value}``, the nonzero gains (in the output's unit per unit of the state).
    certificate : dict
        What was proved: ``status``, ``proved``, ``region`` and ``numbers``.
    provenance : dict
        Where the gains came from: ``source`` and ``design_plant``.
    design : dict, optional
        Data of the design (variant, states, ``K``, weights); empty when the file has none. When
        it holds ``K``, :mod:`satfmu.controllers.claims` checks that ``gains`` agree with it.
    """

    name: str
    description: str
    plant: str
    outputs: list[dict[str, str]]
    gains: dict[str, float]
    certificate: dict[str, Any]
    provenance: dict[str, Any]
    design: dict[str, Any] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        """The artifact as JSON-ready data (kind ``"linear_state_feedback"``)."""
        data = {"format": FORMAT, "format_version": FORMAT_VERSION, "kind": GAIN_KIND, "name": self.name,
                "description": self.description, "plant": self.plant, "outputs": self.outputs,
                "gains": self.gains, "certificate": self.certificate, "provenance": self.provenance}
        if self.design:
            data["design"] = self.design
        return data


_GAIN_NAME = re.compile(r"^K_[a-z_]+\[\d+,\d+\]$")


def _parse_gains(data: dict, where: str, name: str, outputs: list) -> GainArtifact:
    raw = _get(data, "gains", dict, where)
    gains = {}
    for key, value in raw.items():
        if not _GAIN_NAME.match(key):
            raise _fail(where + ".gains", f"gain name {key!r} is not of the form 'K_block[i,j]'")
        gains[key] = _finite(value, f"{where}.gains.{key}")
    return GainArtifact(name, _get(data, "description", str, where), _get(data, "plant", str, where), outputs,
                        gains, _certificate(data, where), _provenance(data, where), data.get("design", {}))


Artifact = ControllerArtifact | ServoArtifact | PeriodicArtifact | GainArtifact
"""Any artifact :func:`parse` returns."""


def _certificate(data: dict, where: str) -> dict[str, Any]:
    cert = _get(data, "certificate", dict, where)
    if cert.get("status") not in CERTIFICATE_STATUS:
        raise _fail(where + ".certificate", f"'status' must be one of {CERTIFICATE_STATUS}")
    for key in ("proved", "region"):
        _get(cert, key, str, where + ".certificate")
    for k, v in cert.get("numbers", {}).items():
        _finite(v, f"{where}.certificate.numbers.{k}")
    if "domain" in cert:
        domain.parse(cert["domain"], where + ".certificate.domain")
    return cert


def _provenance(data: dict, where: str) -> dict[str, Any]:
    prov = _get(data, "provenance", dict, where)
    _get(prov, "source", str, where + ".provenance")
    if "design_plant" in prov:
        w = where + ".provenance.design_plant"
        rec = _get(prov, "design_plant", dict, where + ".provenance")
        for key in ("model", "digest"):
            _get(rec, key, str, w)
        for k, v in _get(rec, "parameters", dict, w).items():
            _finite(v, f"{w}.parameters.{k}")
        for k, v in rec.get("ranges", {}).items():
            if not (isinstance(v, list) and len(v) == 2
                    and _finite(v[0], f"{w}.ranges.{k}") <= _finite(v[1], f"{w}.ranges.{k}")):
                raise _fail(f"{w}.ranges.{k}", "must be [low, high] with low <= high")
        for k, v in (_get(rec, "limits", dict, w) if "limits" in rec else {}).items():
            if k not in LIMIT_PARAMETERS or not _finite(v, f"{w}.limits.{k}") > 0:
                raise _fail(f"{w}.limits.{k}", f"must be one of {sorted(LIMIT_PARAMETERS)}, a number > 0")
    return prov


def resource(artifact: Artifact) -> dict[str, bytes]:
    """The artifact as a file for an FMU's ``resources/`` (traceability).

    Parameters
    ----------
    artifact : Artifact
        The artifact the FMU is built from.

    Returns
    -------
    dict
        ``{"artifact.json": bytes}``, the artifact's JSON (indented, UTF-8).
    """
    return {"artifact.json": (json.dumps(artifact.to_json(), indent=1) + "\n").encode()}


def load(path: str | Path) -> Artifact:
    """Read and validate an artifact file.

    Parameters
    ----------
    path : str or Path
        The artifact's JSON file (at most :data:`MAX_BYTES`).

    Returns
    -------
    Artifact
        The artifact, of the class its ``kind`` names (:func:`parse`).

    Raises
    ------
    ArtifactError
        If the file is missing, is not valid JSON, or violates the schema.
    """
    path = Path(path)
    try:
        if not path.is_file():
            raise ArtifactError(f"{path}: cannot read artifact ("
                                + ("not a regular file" if path.exists() else "no such file") + ")")
        size = path.stat().st_size
        if size > MAX_BYTES:
            raise ArtifactError(f"{path}: an artifact of {size} bytes, more than {MAX_BYTES}")
        text = path.read_bytes()
    except OSError as exc:
        raise ArtifactError(f"{path}: cannot read artifact ({exc.strerror})") from None
    return parse(decode(text, str(path)), where=str(path))


def decode(text: str | bytes, where: str) -> Any:
    """The JSON value of an artifact's text (``where`` names it in errors).

    Parameters
    ----------
    text : str or bytes
        The artifact's text (bytes are decoded as UTF-8).
    where : str
        What the text is called in error messages (its file's path).

    Raises
    ------
    ArtifactError
        Larger than :data:`MAX_BYTES`, not UTF-8, not JSON, or nested too deep for Python's parser.
    """
    if len(text) > MAX_BYTES:
        raise ArtifactError(f"{where}: an artifact of {len(text)} bytes, more than {MAX_BYTES}")
    try:
        return json.loads(text)
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ArtifactError(f"{where}: not valid JSON ({exc})") from None
    except RecursionError:
        raise ArtifactError(f"{where}: JSON nested too deep to read (an artifact nests a few levels)") from None


def save(artifact: Artifact, path: str | Path) -> None:
    """Write an artifact (re-validated first, so an invalid one is never written), whole or not at
    all (:func:`satfmu.fmus.atomic.write_atomically`).

    Parameters
    ----------
    artifact : Artifact
        The artifact to write.
    path : str or Path
        The JSON file to write (replaced when it exists).

    Raises
    ------
    ArtifactError
        If the artifact does not validate (:func:`parse`); nothing is written.
    """
    from satfmu.fmus.atomic import write_atomically

    data = artifact.to_json()
    parse(json.loads(json.dumps(data)), where=str(path))
    write_atomically(path, lambda tmp: tmp.write_text(json.dumps(data, indent=1) + "\n"))
