"""Runtime of satfmu's pythonfmu FMUs, and the Python RK4 shared with reference simulations.

This file is copied verbatim into every pythonfmu FMU (as ``resources/satfmu_pyslave.py``)
next to the generated model module (:func:`satfmu.fmus.codegen.python_source`), so at run
time it may import only the standard library and pythonfmu. It implements the same
behaviour as the native FMU's C code (``fmus/c/satfmu_core.h``), in the same arithmetic order (both
give the same outputs bit for bit, ``tests/test_pythonfmu_parity.py``): RK4 with held inputs,
``max(n_substeps, ceil(h / h_max))`` substeps (or the exact flow of an affine model,
:class:`ExactFlow`), the post-step map, value checks
(finite, in range, right causality), the co-simulation call order, and FMU state.

A model with a sampler (:class:`satfmu.fmus.model.Sampler`) also holds values computed at the
start and at the instants ``t_k = k * period - phase`` (``t0 + k * period`` without a phase), ``k``
an integer count, never an accumulated time (:class:`Instants`): a step is integrated in segments
between instants. Every sample is taken from the inputs set for the step being taken: an instant
inside a step, or at its start, from that step's inputs; an instant at which a step ends belongs to
the next step, so its values are computed from the inputs set there, when first needed after one is
set (an output read) or else by the next step, and again if an input changes there. Until an input
is set at that point (``inputs_stale``) an output read shows the values held from the previous
instant: a Jacobi-order importer sees the feedthrough-order outputs one step later, never a sample
of the previous step's inputs (``fmus/c/satfmu_core.h`` states the rule in full).

Time and work, as the C wrapper: a step ends at ``currentCommunicationPoint + h``; a
communication point more than 8 ulp (of the larger of 1 s, ``|t|`` and the start time) off the
FMU time is refused, as is a step that does not advance the time or passes a defined stopTime;
two times closer than the generated ``time_tolerance(t)`` are one instant; a step is refused
before anything changes when it spans more than :data:`MAX_STEP_INSTANTS` sample instants
(:data:`MAX_STEP_PYTHON_SAMPLES` for a Python sampler) or needs more
than :data:`MAX_STEP_SUBSTEPS` substeps; no output is returned non-finite (the call is refused).

pythonfmu 0.7.0 writes parameters without variability and omits the
ModelStructure's InitialUnknowns; :meth:`SatfmuSlave.to_xml` therefore returns
satfmu's own model description (the same one the native FMU carries).

Every FMI call reaches this class through satfmu's C layer in front of pythonfmu 0.7.0's library
(``fmus/c/pythonfmu_shim.c``, the FMU's binary), which guards what pythonfmu's C++ layer does
wrong before any Python runs (``docs/pythonfmu.md``). This class keeps its side of that layer's
contract: a refused call logs its reason with fmi2Error and raises (``SatfmuSlave._reject``,
which keeps the instance usable; the layer returns fmi2Error); every value reference and type is
checked here, not by pythonfmu (whose own exceptions cannot be balanced); two value references no
model declares report the FMI state and the time to that layer (:data:`SHIM_VR_MODE`,
:data:`SHIM_VR_TIME`); and bytes that are no state of this FMU deserialize to a
:class:`RefusedState`, which serializes as a NUL byte and the reason. A serialized FMU state
carries the model's name and this FMU's GUID, a format version and a CRC-32, must be the
canonical bytes this class writes, and every restored state is checked field by field
(``SatfmuSlave._state_problem``).
"""
from __future__ import annotations

import ast
import ctypes
import functools
import importlib
import json
import math
import operator
import os
import sys
import zlib
from dataclasses import dataclass
from types import ModuleType
from typing import Any, Callable, NoReturn, Sequence
from xml.etree.ElementTree import Element, parse

from pythonfmu import Boolean, Fmi2Causality, Fmi2Slave, Fmi2Variability, Integer, Real, String
from pythonfmu.enums import Fmi2Status

KIND_PARAMETER, KIND_INPUT, KIND_OUTPUT = 0, 1, 2
DESCRIPTION_FILE = "satfmu_description.xml"
MAX_STEP_INSTANTS = 1_000_000
"""Most sample instants one fmi2DoStep may span (as ``fmus/c/satfmu_core.h``); a longer step is
refused before anything changes."""
MAX_STEP_SUBSTEPS = 1_000_000
"""Most integration substeps one fmi2DoStep may take (as ``fmus/c/satfmu_core.h``)."""
MAX_STEP_PYTHON_SAMPLES = 10_000
"""Most sample instants one fmi2DoStep may span when the sampler is a Python function: the online
SDRE solves a Riccati equation per instant (~0.5 to 5 ms, so at most ~5 to 50 s per step); the far
step of the robustness suite (1e4 default steps, one instant each) is the longest the project
takes. The native FMU of such a model (its C routine) has the same bound
(``satfmu.fmus.codegen.MAX_STEP_ROUTINE_SAMPLES``)."""
INDEX_LIMIT = 2 ** 52
"""Sample counts stay below this: exact integers in a double, as the native FMU keeps them."""
STATE_FORMAT = 2
"""Version of the FMU state's layout (``SatfmuSlave._get_fmu_state``; 1 had no ``inputs_stale``); a
state of another layout is refused."""
STATE_MODES = ("Instantiated", "InitializationMode", "StepComplete", "Terminated")
"""The states of the FMI state machine an FMU state may hold (after fmi2Fatal no call is allowed)."""
MODES = STATE_MODES + ("Error",)
"""The FMI states of an instance, in the order of their numbers at :data:`SHIM_VR_MODE`."""
SHIM_VR_MODE = 0xFFFFFFFE
"""Value reference (Integer) at which the C layer reads the FMI state (its index in :data:`MODES`);
no model declares it and the layer refuses a host's call that names it."""
SHIM_VR_TIME = 0xFFFFFFFF
"""Value reference (Real) at which the C layer reads the FMU time, s (as :data:`SHIM_VR_MODE`)."""


def ieee(op: Callable[..., Any], *args: Any) -> Any:
    """``op(*args)`` with the IEEE 754 result C gives where Python raises instead.

    Python raises ZeroDivisionError for ``x / 0.0``, ``x % 0.0`` and ``0.0 ** -n``,
    OverflowError for a float ``**`` or a ``math`` function past DBL_MAX, and ValueError for a
    ``math`` function outside its domain; C's ``/``, ``fmod``, ``pow`` and ``<math.h>`` return
    an infinity or NaN there. A complex power of a negative base (C: NaN) is NaN too.

    Parameters
    ----------
    op : callable
        An ``operator`` function (``truediv``, ``floordiv``, ``mod``, ``pow``) or a
        ``math`` function.
    *args
        Its arguments.

    Returns
    -------
    float
        The result, an infinity or NaN where Python raised.
    """
    try:
        value = op(*args)
    except ZeroDivisionError:
        a = float(args[0])
        if op is operator.pow:
            value = math.inf  # pow(0, negative)
        elif op is operator.mod or a == 0.0 or math.isnan(a):
            value = math.nan  # fmod(x, 0), 0 / 0
        else:
            value = math.copysign(math.inf, a) * math.copysign(1.0, float(args[1]))
    except OverflowError:
        negative = op is operator.pow and args[0] < 0 and float(args[1]).is_integer() and args[1] % 2 == 1
        value = -math.inf if negative else math.inf
    except ValueError:
        value = math.nan
    return math.nan if isinstance(value, complex) else value


class _IeeeArithmetic(ast.NodeTransformer):
    """Rewrites generated code so that division, ``%``, ``**`` and ``math.<f>(...)`` go
    through :func:`ieee` (``a / b`` becomes ``_ieee(_operator.truediv, a, b)``)."""

    OPERATORS = {ast.Div: "truediv", ast.FloorDiv: "floordiv", ast.Mod: "mod", ast.Pow: "pow"}

    def visit_BinOp(self, node: ast.BinOp) -> ast.AST:
        self.generic_visit(node)
        name = self.OPERATORS.get(type(node.op))
        if name is None:
            return node
        op = ast.Attribute(ast.Name("_operator", ast.Load()), name, ast.Load())
        return ast.copy_location(ast.Call(ast.Name("_ieee", ast.Load()), [op, node.left, node.right], []), node)

    def visit_Call(self, node: ast.Call) -> ast.AST:
        self.generic_visit(node)
        f = node.func
        if isinstance(f, ast.Attribute) and isinstance(f.value, ast.Name) and f.value.id == "math" \
                and not node.keywords:
            return ast.copy_location(ast.Call(ast.Name("_ieee", ast.Load()), [f, *node.args], []), node)
        return node


def ieee_function(gen: ModuleType, name: str) -> Callable[..., list[Any]] | None:
    """The generated function ``name`` of ``gen`` rewritten to C's IEEE 754 arithmetic
    (:func:`ieee`), from the module's source file; None when the module has no source file.

    Used only after the plain function raised: it tells which results are non-finite, so a
    refusal names the variable as the native FMU's does (the plain function stays the fast
    path, bit for bit the C results where it does not raise).

    Parameters
    ----------
    gen : types.ModuleType
        The generated model module (:func:`satfmu.fmus.codegen.python_source`).
    name : str
        The function's name (``"outputs"``, ``"derivatives"``, ...).

    Returns
    -------
    callable or None
        The rewritten function, with the same arguments; None also when ``gen`` defines no
        function ``name``.
    """
    path = getattr(gen, "__file__", None)
    if not path or not os.path.isfile(path):
        return None
    with open(path, encoding="utf-8") as fh:
        tree = ast.parse(fh.read(), filename=path)
    defs = [n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name == name]
    if not defs:
        return None
    module = ast.fix_missing_locations(ast.Module([_IeeeArithmetic().visit(defs[0])], []))
    namespace = dict(vars(gen), _ieee=ieee, _operator=operator)
    exec(compile(module, path, "exec"), namespace)  # noqa: S102 (the FMU's own generated code)
    return namespace[name]


def substep_count(h: float, n_substeps: float, h_max: float) -> int:
    """Number of RK4 substeps for a communication step of ``h`` seconds.

    Parameters
    ----------
    h : float
        The communication step, s.
    n_substeps : float
        The model's ``n_substeps`` parameter: the least number of substeps.
    h_max : float
        The model's ``h_max`` parameter: the largest substep, s.

    Returns
    -------
    int
        ``max(n_substeps, ceil(h / h_max))``.
    """
    return int(max(n_substeps, math.ceil(h / h_max)))


TAYLOR_TERMS = 18
MAX_SWITCHES = 64


def _matmul(a: list[list[float]], b: list[list[float]]) -> list[list[float]]:
    """``a b``, each entry summed term by term from 0 as the C wrapper does (not with ``sum``,
    which Python 3.12 compensates, so both backends round alike on every Python)."""
    bt = list(zip(*b))
    out = []
    for row in a:
        entries = []
        for col in bt:
            acc = 0.0
            for x, y in zip(row, col):
                acc += x * y
            entries.append(acc)
        out.append(entries)
    return out


def _doubling(phi: list[list[float]], gamma: list[list[float]]) -> tuple[list[list[float]], list[list[float]]]:
    """``(Phi Gamma, Phi Phi)`` in one pass over the rows of ``Phi`` (as :func:`_matmul` each)."""
    gt, pt = list(zip(*gamma)), list(zip(*phi))
    w_rows, p_rows = [], []
    for row in phi:
        w, q = [], []
        for gc, pc in zip(gt, pt):
            s1 = s2 = 0.0
            for x, g, y in zip(row, gc, pc):
                s1 += x * g
                s2 += x * y
            w.append(s1)
            q.append(s2)
        w_rows.append(w)
        p_rows.append(q)
    return w_rows, p_rows


def _finite(m: list[list[float]]) -> bool:
    return all(math.isfinite(v) for row in m for v in row)


def affine_flow(A: list[list[float]], tau: float) -> tuple[list[list[float]], list[list[float]]]:
    """``Phi = e^{A tau}`` and ``Gamma = integral_0^tau e^{A s} ds`` as the C wrapper computes them.

    Taylor series of Gamma at ``tau / 2^s`` with ``|A|_inf tau / 2^s <= 1/2`` (18 terms), then
    ``s`` doublings ``Gamma <- (I + Phi) Gamma``, ``Phi <- Phi^2``. Once an entry is not finite
    the result is returned as it is: further doublings keep it non-finite (the state the caller
    computes from it is then refused, as in C), and a huge ``tau`` (s up to 1000) would cost
    seconds of pure Python for nothing.

    Parameters
    ----------
    A : list of list of float
        The state matrix (n x n, rows), 1/s.
    tau : float
        The duration, s.

    Returns
    -------
    Phi : list of list of float
        ``e^{A tau}`` (n x n).
    Gamma : list of list of float
        ``integral_0^tau e^{A s} ds`` (n x n), s.
    """
    n = len(A)
    eye = [[1.0 if i == j else 0.0 for j in range(n)] for i in range(n)]
    norm = 0.0
    for row in A:
        acc = 0.0
        for v in row:
            acc += abs(v)
        if acc > norm:  # fmax: a NaN row is ignored
            norm = acc
    norm *= tau
    s = 0
    while norm > 0.5 and s < 1000:
        norm *= 0.5
        s += 1
    dt = math.ldexp(tau, -s)
    T = eye
    for k in range(TAYLOR_TERMS, 0, -1):
        W = _matmul(A, T)
        T = [[W[i][j] * dt / (k + 1) + eye[i][j] for j in range(n)] for i in range(n)]
    gamma = [[dt * v for v in row] for row in T]
    phi = _matmul(A, gamma)
    for i in range(n):
        phi[i][i] += 1.0
    for _ in range(s):
        if not (_finite(phi) and _finite(gamma)):
            break
        W, phi = _doubling(phi, gamma)
        gamma = [[g + w for g, w in zip(rg, rw)] for rg, rw in zip(gamma, W)]
    return phi, gamma


FLOW_TAU_RTOL = 1e-9
"""A duration within this fraction of the cached one reuses its flow, as in the C wrapper: an
importer whose steps differ in the last bits (``t + h`` rounded) would recompute it every step."""


class ExactFlow:
    """The exact integrator of an affine model (``INTEGRATOR == "exact"``), with the C wrapper's
    cache of ``(Phi, Gamma)`` for the last ``(A, tau)`` (a ``tau`` within :data:`FLOW_TAU_RTOL`
    of it reusing them).

    Parameters
    ----------
    gen : types.ModuleType
        The generated model module; its ``jacobian``, ``derivatives``, ``post_step`` and
        ``switch_time`` are used.
    """

    def __init__(self, gen: ModuleType) -> None:
        self.gen = gen
        self.key: tuple | None = None
        self.tau = 0.0
        self.flow: tuple[list[list[float]], list[list[float]]] | None = None

    def segment(self, t: float, x: list[float], u: Sequence[float], p: Sequence[float], tau: float) -> list[float]:
        """Exact flow over ``tau`` seconds with the law frozen at ``x``, then the post-step map.

        Parameters
        ----------
        t : float
            Time at the segment's start, s.
        x : list of float
            State at the segment's start (also the frozen substep-start state).
        u : sequence of float
            Inputs, held over the segment.
        p : sequence of float
            Parameters, then the held values of a sampler (if any).
        tau : float
            Duration of the segment, s.

        Returns
        -------
        list of float
            The state at ``t + tau``, after the post-step map.
        """
        n = len(x)
        flat = self.gen.jacobian(t, x, x, u, p)
        b = self.gen.derivatives(t, [0.0] * n, x, u, p)
        key = tuple(flat)
        if key != self.key or abs(self.tau - tau) > FLOW_TAU_RTOL * self.tau:
            self.flow = affine_flow([list(flat[i * n:(i + 1) * n]) for i in range(n)], tau)
            self.key, self.tau = key, tau
        phi, gamma = self.flow  # type: ignore[misc]
        # one sum per row over both products, in the C wrapper's order (the same rounding)
        xt = []
        for i in range(n):
            acc = 0.0
            for f, v, g, w in zip(phi[i], x, gamma[i], b):
                acc += f * v + g * w
            xt.append(acc)
        return self.gen.post_step(t + tau, xt, x, u, p)

    def step(self, t: float, x: Sequence[float], u: Sequence[float], p: Sequence[float], h: float) -> list[float]:
        """Advance ``h`` seconds from ``t``, cut at the switch instants of the piecewise law.

        The cuts are durations from ``t`` (a switch within ``TIME_TOL max(1 s, h)``, 1e-9 of it, is
        that start's own), so the flow is the same at any absolute time; an uncut step uses ``h``
        itself, so a constant step size reuses the cached flow.

        Parameters
        ----------
        t : float
            Time at the step's start, s.
        x : sequence of float
            State at the step's start.
        u : sequence of float
            Inputs, held over the step.
        p : sequence of float
            Parameters, then the held values of a sampler (if any).
        h : float
            Duration of the step, s.

        Returns
        -------
        list of float
            The state at ``t + h``.
        """
        x = list(x)
        elapsed, now = 0.0, t
        for _ in range(MAX_SWITCHES):
            ts = self.gen.switch_time(now, x, u, p)[0]
            if not ts > self.gen.TIME_TOL * max(1.0, h) or ts >= h - elapsed:
                break
            x = self.segment(now, x, u, p, ts)
            elapsed += ts
            now = t + elapsed
        return self.segment(now, x, u, p, h - elapsed if elapsed > 0.0 else h)


def rk4_step(gen: ModuleType, t: float, x: Sequence[float], u: Sequence[float], p: Sequence[float],
             h: float, n: int) -> list[float]:
    """Advance the generated model ``gen`` by ``h`` seconds in ``n`` RK4 substeps, ``u`` held.

    The arithmetic is written in the same order as the C wrapper's, so both
    backends agree to rounding.

    Parameters
    ----------
    gen : types.ModuleType
        The generated model module (:func:`satfmu.fmus.codegen.python_source`).
    t : float
        Time at the step's start, s.
    x : sequence of float
        State at the step's start.
    u : sequence of float
        Inputs, held over the step.
    p : sequence of float
        Parameters, then the held values of a sampler (if any).
    h : float
        Duration of the step, s.
    n : int
        Number of substeps (:func:`substep_count`); the post-step map follows each.

    Returns
    -------
    list of float
        The state at ``t + h``.
    """
    f = gen.derivatives
    post = gen.post_step
    hs = h / n
    state = list(x)
    nx = len(state)
    for k in range(n):
        k1 = f(t, state, state, u, p)
        xt = [state[i] + 0.5 * hs * k1[i] for i in range(nx)]
        k2 = f(t + 0.5 * hs, xt, state, u, p)
        xt = [state[i] + 0.5 * hs * k2[i] for i in range(nx)]
        k3 = f(t + 0.5 * hs, xt, state, u, p)
        xt = [state[i] + hs * k3[i] for i in range(nx)]
        k4 = f(t + hs, xt, state, u, p)
        xt = [state[i] + hs / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]) for i in range(nx)]
        state = post(t + hs, xt, state, u, p)
        t = t + hs
    return state


def _compensate_pythonfmu_refcount(module_name: str) -> None:
    """Balance a reference pythonfmu 0.7.0 releases too often.

    pythonfmu's ``findClass`` (src/pythonfmu/PySlaveInstance.cpp, run by every
    fmi2Instantiate) calls ``Py_DECREF`` on the borrowed ``PyModule_GetDict`` of the slave
    script's module. A script whose module dict has few other owners (ours defines no
    functions) is freed by the second fmi2Instantiate in a process, and the host crashes.
    The generated script holds one reference to its own namespace (so the first release
    does not free it), and each instance gives back the reference ``findClass`` took, so
    the count stays balanced however many instances a process creates. Outside pythonfmu
    (the builder, tests) the extra reference only keeps that namespace alive.
    """
    module = sys.modules.get(module_name)
    if module is not None:
        ctypes.pythonapi.Py_IncRef(ctypes.py_object(module.__dict__))


def _canonical_json(obj: Any) -> str:
    """``obj`` as JSON with sorted keys, no spaces and exact (repr) floats; NaN and inf refused."""
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), allow_nan=False)


def _checksum(state: dict[str, Any]) -> int:
    """CRC-32 (IEEE 802.3, :func:`zlib.crc32`) of the canonical JSON of an FMU state without its
    ``crc32`` field, as the native FMU takes of its whole record: every error burst of up to 32
    bits is detected."""
    return zlib.crc32(_canonical_json({k: v for k, v in state.items() if k != "crc32"}).encode())


def _refuse_constant(name: str) -> float:
    raise ValueError(f"non-finite number {name} (never written by this FMU)")


class CallRefused(RuntimeError):
    """Raised inside the FMU when it refuses an FMI call (bad value, wrong call order); the message
    names the variable. The FMU's C layer turns it into fmi2Error; a host never sees this class
    (satfmu's master raises :class:`satfmu.fmus.errors.FmuCallError`)."""


def point_tolerance(ulps: int, t: float, start: float) -> float:
    """The largest difference of a currentCommunicationPoint from the FMU time ``t``, s:
    ``ulps`` (the generated ``TIME_ULPS``) units in the last place of the larger of 1 s, ``|t|``
    and ``|start|`` (the start time, s), what double precision forces when a master computes
    ``t0 + k h`` and the FMU ``t_{k-1} + h`` (as ``point_tol`` of ``fmus/c/satfmu_core.h``).

    Parameters
    ----------
    ulps : int
        Units in the last place allowed (the generated module's ``TIME_ULPS``).
    t : float
        The FMU time, s.
    start : float
        The experiment's start time, s.

    Returns
    -------
    float
        The tolerance, s.
    """
    return ulps * 2.0 ** -52 * max(1.0, abs(t), abs(start))


def _ceil(v: float) -> float:
    """``ceil`` in floating point, as C's: infinity stays infinite."""
    return float(math.ceil(v)) if math.isfinite(v) else v


@dataclass(frozen=True)
class Instants:
    """The sample instants of a sampler: ``t_k = k * period - phase`` (``start + k * period``
    without a phase parameter), ``k`` an integer count (never an accumulated time).

    Attributes
    ----------
    period : float
        s.
    phase : float or None
        s; None when the model has no phase parameter (the instants start at ``start``).
    start : float
        The experiment's start time, s.
    tolerance : callable
        ``t -> s``: two times closer than this at ``t`` are one instant (the generated module's
        ``time_tolerance``, :func:`satfmu.fmus.model.time_tolerance`).
    """

    period: float
    phase: float | None
    start: float
    tolerance: Callable[[float], float]

    def tol(self, t: float) -> float:
        """Two times closer than this are one instant at ``t``, s.

        Parameters
        ----------
        t : float
            The time, s.

        Returns
        -------
        float
            The tolerance, s.
        """
        return self.tolerance(t)

    def time(self, k: int) -> float:
        """The instant of index ``k``, s.

        Parameters
        ----------
        k : int
            The instant's index (a count of periods).

        Returns
        -------
        float
            ``k * period - phase``, or ``start + k * period`` without a phase, s.
        """
        return k * self.period - self.phase if self.phase is not None else self.start + k * self.period

    @property
    def origin(self) -> float:
        """``t_k - k * period``, s."""
        return -self.phase if self.phase is not None else self.start

    def first_after(self, t: float) -> int | None:
        """The index of the first instant later than ``t`` by more than :meth:`tol`; None when the
        period is not > 0 or the index is not below :data:`INDEX_LIMIT`.

        Parameters
        ----------
        t : float
            The time, s.

        Returns
        -------
        int or None
            The index ``k`` of that instant (:meth:`time`).
        """
        q = (t - self.origin) / self.period if self.period > 0.0 else math.nan
        if not (math.isfinite(q) and abs(math.floor(q) + 1) < INDEX_LIMIT):
            return None
        k = math.floor(q) + 1
        tol = self.tol(t)
        for _ in range(4):  # the rounding of the quotient, either way
            if self.time(k - 1) > t + tol:
                k -= 1
        for _ in range(4):
            if self.time(k) <= t + tol:
                k += 1
        return k


def _unsigned(vrs: Sequence[int]) -> list[int]:
    """The value references ``vrs`` as unsigned 32-bit integers (pythonfmu passes them as C ints)."""
    return [vr & 0xFFFFFFFF for vr in vrs]


@dataclass(frozen=True)
class RefusedState:
    """What bytes that are no state of this FMU deserialize to: the reason, which the C layer
    reports with fmi2Error (no FMU state is made); ``SatfmuSlave._set_fmu_state`` refuses it
    too.

    Attributes
    ----------
    reason : str
        Why the bytes are no state of this FMU.
    """

    reason: str


class SatfmuSlave(Fmi2Slave):
    """pythonfmu slave of a generated satfmu model; subclasses set ``generated``."""

    generated: ModuleType

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        _compensate_pythonfmu_refcount(type(self).__module__)
        if not self.instance_name:  # fmi2Instantiate then returns NULL (the log holds this text)
            raise ValueError("fmi2Instantiate: missing instance name")
        gen = self.generated
        self.modelName = type(self).__name__
        self._table = gen.VARIABLES
        self._np = sum(1 for v in self._table if v["kind"] == KIND_PARAMETER)
        self._nu = sum(1 for v in self._table if v["kind"] == KIND_INPUT)
        self._ny = sum(1 for v in self._table if v["kind"] == KIND_OUTPUT)
        pnames = [v["name"] for v in self._table if v["kind"] == KIND_PARAMETER]
        self._i_nsub = pnames.index("n_substeps") if "n_substeps" in pnames else -1
        self._i_hmax = pnames.index("h_max") if "h_max" in pnames else -1
        self._flow = ExactFlow(gen) if gen.INTEGRATOR == "exact" else None
        smp = gen.SAMPLER
        self._sampler = smp
        self._nh = smp["n_held"] if smp else 0
        if smp is not None and smp["module"] is not None:
            fn = getattr(importlib.import_module(smp["module"]), smp["function"])
            self._sample_fn: Callable[[list[float]], Sequence[float]] = functools.partial(fn, **smp["options"])
        elif smp is not None:  # an expression sampler holds its arguments
            self._sample_fn = list
        self._defaults()
        for row in self._table:
            self.register_variable(self._make_variable(row), nested=False)

    # ------------------------------------------------------------ data
    def _defaults(self) -> None:
        self.mode = "Instantiated"
        self.time = 0.0
        self.p = [float(v["start"]) for v in self._table if v["kind"] == KIND_PARAMETER]
        self.p += [0.0] * self._nh  # held values follow
        self.start_time = 0.0
        self.stop_time = math.inf  # no stopTime defined
        self.next_k = 0  # index of the first sample instant after the FMU time
        self.held_prev = [0.0] * self._nh  # the held values of the previous instant
        self.at_instant = True  # the FMU time is a sample instant
        self.sample_due = self._sampler is not None  # the held values of that instant are stale
        self.inputs_stale = False  # a step ended at that instant and no input has been set since
        self.u = [float(v["start"]) for v in self._table if v["kind"] == KIND_INPUT]
        self.y = [0.0] * self._ny
        self.x = [0.0] * self.generated.N_STATES
        self.outputs_valid = False

    def _make_variable(self, row: dict) -> Any:
        cls = {"Real": Real, "Integer": Integer, "Boolean": Boolean}[row["type"]]
        causality = {KIND_PARAMETER: Fmi2Causality.parameter, KIND_INPUT: Fmi2Causality.input,
                     KIND_OUTPUT: Fmi2Causality.output}[row["kind"]]
        variability = Fmi2Variability.fixed if row["kind"] == KIND_PARAMETER else Fmi2Variability.continuous
        cast: Callable[[float], Any] = {"Real": float, "Integer": int, "Boolean": bool}[row["type"]]
        return cls(row["name"], causality=causality, variability=variability,
                   getter=lambda r=row, c=cast: c(self._get(r)),
                   setter=lambda value, r=row: self._set(r, value))

    def _slot(self, row: dict) -> list[float]:
        return {KIND_PARAMETER: self.p, KIND_INPUT: self.u, KIND_OUTPUT: self.y}[row["kind"]]

    def _get(self, row: dict) -> float:
        if self.mode == "Instantiated":
            self._reject(f"get '{row['name']}' must not be called in state Instantiated")
        if row["kind"] == KIND_OUTPUT and not self.outputs_valid:
            if self.mode in ("Instantiated", "InitializationMode"):
                self.x = [self.p[i] for i in self.generated.STATE_INITIAL]
            if self.sample_due and not self.inputs_stale:  # an instant that ended a step waits for its inputs
                self._sample()
            self._update_outputs(f"fmi2Get{row['type']}")
        return self._slot(row)[row["index"]]

    def _update_outputs(self, fn: str) -> None:
        """The outputs at the FMU time; a non-finite one is refused and the error state entered (as
        the native FMU: no non-finite output is ever returned with fmi2OK)."""
        args = (self.time, self.x, self.u, self.p)
        failure: str = "a complex result"
        try:
            self.y = self.generated.outputs(*args)
            plain = not any(isinstance(v, complex) for v in self.y)
        except (ArithmeticError, ValueError) as exc:  # 1 / 0.0, float ** overflow, math domain: C gives inf, NaN
            plain, failure = False, f"{type(exc).__name__}: {exc}"
        if not plain:  # C's values (an infinity or NaN where Python raised), to name the output
            fn_ieee = self._ieee_outputs()
            if fn_ieee is None:
                self.mode = "Error"
                self._reject(f"{fn}: an output is non-finite ({failure}) at "
                             f"t = {self.time:.17g} s")
            self.y = fn_ieee(*args)
        for out in self._table:
            if out["kind"] == KIND_OUTPUT and not math.isfinite(self.y[out["index"]]):
                self.mode = "Error"
                self._reject(f"{fn}: output '{out['name']}' is non-finite ({self.y[out['index']]:g}) at "
                             f"t = {self.time:.17g} s")
        self.outputs_valid = True

    def _ieee_outputs(self) -> Callable[..., list[Any]] | None:
        """The generated ``outputs`` in C's arithmetic (:func:`ieee_function`), made once per class."""
        cls = type(self)
        if "_ieee_outputs_fn" not in cls.__dict__:
            cls._ieee_outputs_fn = ieee_function(self.generated, "outputs")
        return cls.__dict__["_ieee_outputs_fn"]

    def _set(self, row: dict, value: Any) -> None:
        name = row["name"]
        if row["kind"] == KIND_OUTPUT:
            self._reject(f"variable '{name}' is an output and cannot be set")
        if row["kind"] == KIND_PARAMETER and self.mode not in ("Instantiated", "InitializationMode"):
            self._reject(f"parameter '{name}' has variability fixed and cannot be set in state {self.mode}")
        if self.mode not in ("Instantiated", "InitializationMode", "StepComplete"):
            self._reject(f"'{name}' cannot be set in state {self.mode}")
        v = float(value)
        if not math.isfinite(v):
            self._reject(f"variable '{name}' set to non-finite value {v}")
        lo = -math.inf if row["min"] is None else row["min"]
        hi = math.inf if row["max"] is None else row["max"]
        if not lo <= v <= hi:
            self._reject(f"variable '{name}' = {v:g} is outside its range [{lo:g}, {hi:g}]")
        self._slot(row)[row["index"]] = v
        self.outputs_valid = False
        self.sample_due = self._sampler is not None and self.at_instant
        self.inputs_stale = False

    def _reject(self, message: str) -> NoReturn:
        """Log ``message`` with fmi2Error and fail the call: the FMU's C layer
        (``fmus/c/pythonfmu_shim.c``) returns fmi2Error for it, and the instance stays usable.

        On an exception pythonfmu 0.7.0's ``handle_py_exception`` releases its references to this
        instance, its class and its log queue without forgetting them (and returns fmi2Fatal,
        which the C layer turns into fmi2Error after this logged error); they are released again
        by later calls and by fmi2FreeInstance. One extra reference each keeps the count balanced.
        """
        self.log(message, Fmi2Status.error, "logStatusError")
        for obj in (self, type(self), self.log_queue):
            ctypes.pythonapi.Py_IncRef(ctypes.py_object(obj))
        raise CallRefused(message)

    # ------------------------------------------------------------ value access
    # pythonfmu's own get_*/set_* raise KeyError or TypeError on an unknown reference or a wrong
    # type, which cannot be balanced as _reject balances its refusals: the references and types
    # are checked here, with the native FMU's messages. pythonfmu passes each fmi2ValueReference (an
    # unsigned 32-bit integer) as a C int: those from 2^31 on arrive negative (_unsigned).
    def _variables(self, fn: str, vrs: Sequence[int], kind: type) -> list[Any]:
        found = []
        for vr in _unsigned(vrs):
            var = self.vars.get(vr)
            if var is None:
                self._reject(f"{fn}: unknown value reference {vr}")
            if not isinstance(var, kind):
                self._reject(f"{fn}: variable '{var.name}' (value reference {vr}) has another type")
            found.append(var)
        return found

    def get_real(self, vrs: Sequence[int]) -> list[float]:
        if _unsigned(vrs) == [SHIM_VR_TIME]:
            return [self.time]
        return [float(v.getter()) for v in self._variables("fmi2GetReal", vrs, Real)]

    def get_integer(self, vrs: Sequence[int]) -> list[int]:
        if _unsigned(vrs) == [SHIM_VR_MODE]:
            return [MODES.index(self.mode)]
        return [int(v.getter()) for v in self._variables("fmi2GetInteger", vrs, Integer)]

    def get_boolean(self, vrs: Sequence[int]) -> list[bool]:
        return [bool(v.getter()) for v in self._variables("fmi2GetBoolean", vrs, Boolean)]

    def get_string(self, vrs: Sequence[int]) -> list[str]:
        return [str(v.getter()) for v in self._variables("fmi2GetString", vrs, String)]

    def set_real(self, vrs: Sequence[int], values: Sequence[float]) -> None:
        for var, value in zip(self._variables("fmi2SetReal", vrs, Real), values):
            var.setter(value)

    def set_integer(self, vrs: Sequence[int], values: Sequence[int]) -> None:
        for var, value in zip(self._variables("fmi2SetInteger", vrs, Integer), values):
            var.setter(value)

    def set_boolean(self, vrs: Sequence[int], values: Sequence[bool]) -> None:
        for var, value in zip(self._variables("fmi2SetBoolean", vrs, Boolean), values):
            var.setter(value)

    def set_string(self, vrs: Sequence[int], values: Sequence[str]) -> None:
        for var, value in zip(self._variables("fmi2SetString", vrs, String), values):
            var.setter(value)

    def _require(self, fn: str, *modes: str) -> None:
        if self.mode not in modes:
            self._reject(f"{fn} must not be called in state {self.mode}")

    # ------------------------------------------------------------ sampling
    @classmethod
    def _instants(cls, p: Sequence[float], start_time: float) -> Instants:
        """The sample instants with the parameters ``p`` and the start time ``start_time`` (s)."""
        smp = cls.generated.SAMPLER
        phase = None if smp["phase_index"] is None else p[smp["phase_index"]]
        return Instants(p[smp["period_index"]], phase, start_time, cls.generated.time_tolerance)

    def _sample(self) -> None:
        """Compute the held values at the current time, state, inputs and parameters."""
        p = self.p[:self._np] + self.held_prev  # expressions read the previous instant's values
        args = self.generated.sample_arguments(self.time, self.x, self.u, p)
        try:
            held = [float(v) for v in self._sample_fn(args)]
        except Exception as exc:  # the sampler's own message names what failed
            self.mode = "Error"
            self._reject(f"sample at t = {self.time:g} s failed: {type(exc).__name__}: {exc}")
        if len(held) != self._nh or not all(math.isfinite(v) for v in held):
            self.mode = "Error"
            self._reject(f"sample at t = {self.time:g} s returned {held!r}, expected {self._nh} finite values")
        self.p[self._np:] = held
        self.sample_due = False
        self.outputs_valid = False

    def _new_instant(self) -> None:
        """The FMU time reached a new instant: what is held becomes the previous instant's values."""
        self.held_prev = self.p[self._np:]

    # ------------------------------------------------------------ FMI
    def setup_experiment(self, start_time: float, stop_time: float | None, tolerance: float | None) -> None:
        self._require("fmi2SetupExperiment", "Instantiated")
        if not math.isfinite(start_time):
            self._reject("fmi2SetupExperiment: non-finite startTime")
        if stop_time is not None and not (math.isfinite(stop_time) and stop_time >= start_time):
            self._reject(f"fmi2SetupExperiment: stopTime {stop_time:g} is not a finite time from startTime "
                         f"{start_time:g} on")
        self.time = float(start_time)
        self.start_time = self.time
        self.stop_time = math.inf if stop_time is None else float(stop_time)

    def enter_initialization_mode(self) -> None:
        self._require("fmi2EnterInitializationMode", "Instantiated")
        self.mode = "InitializationMode"
        self.outputs_valid = False

    def exit_initialization_mode(self) -> None:
        self._require("fmi2ExitInitializationMode", "InitializationMode")
        k = 0
        if self._sampler is not None:
            instants = self._instants(self.p, self.start_time)
            first = instants.first_after(self.time)
            if first is None:
                self._reject(f"fmi2ExitInitializationMode: the sample instants k * {instants.period:g} s from the "
                             f"origin {instants.origin:g} s cannot be counted exactly at t = {self.time:g} s")
            k = first
        self.x = [self.p[i] for i in self.generated.STATE_INITIAL]
        self.mode = "StepComplete"
        self.outputs_valid = False
        self.at_instant = True
        self.sample_due = self._sampler is not None
        self.inputs_stale = False
        self.next_k = k

    def do_step(self, current_time: float, step_size: float) -> bool:
        self._require("fmi2DoStep", "StepComplete")
        h, t = float(step_size), float(current_time)
        if not (math.isfinite(h) and h > 0.0):
            self._reject(f"fmi2DoStep: communicationStepSize must be finite and > 0, got {h:g}")
        tol = (point_tolerance(self.generated.TIME_ULPS, max(abs(t), abs(self.time)), self.start_time)
               if math.isfinite(t) else 0.0)
        if not math.isfinite(t) or abs(t - self.time) > tol:
            self._reject(f"fmi2DoStep: currentCommunicationPoint {t:.17g} differs from the FMU time "
                         f"{self.time:.17g} by {t - self.time:g} s (tolerance {tol:g} s)")
        t_end = t + h
        if not (math.isfinite(t_end) and t_end > t):
            self._reject(f"fmi2DoStep: h = {h:g} s from t = {t:.17g} s does not reach a finite later time")
        if t_end > self.stop_time + self.generated.time_tolerance(self.stop_time):
            self._reject(f"fmi2DoStep: the step to t = {t_end:.17g} s passes stopTime {self.stop_time:.17g} s")
        k_end = self._plan_step(h, t_end)
        if self._sampler is None:
            self._integrate(h, t_end)
        else:
            self._step_sampled(t_end, k_end)
        self.outputs_valid = False
        return True

    def _substeps(self, h: float) -> float:
        """Substeps of an integration over ``h`` s: ``max(n_substeps, ceil(h / h_max))`` (1 without
        these parameters, 0 without states); may be huge or infinite (:meth:`_plan_step` checks)."""
        if not self.generated.N_STATES:
            return 0.0
        n = self.p[self._i_nsub] if self._i_nsub >= 0 else 1.0
        if self._i_hmax >= 0:
            n = max(n, _ceil(h / self.p[self._i_hmax]))
        return n

    def _plan_step(self, h: float, t_end: float) -> int:
        """The work of a step of ``h`` s to ``t_end`` counted before anything changes: the index of
        the last sample instant it reaches (0 without a sampler), its substeps within
        :data:`MAX_STEP_SUBSTEPS` and its instants within :data:`MAX_STEP_INSTANTS`, or the step
        is rejected."""
        k_end = 0
        if self._sampler is not None:
            instants = self._instants(self.p, self.start_time)
            period, tol = instants.period, instants.tol(t_end)
            if not period > 2.0 * tol:
                self._reject(f"fmi2DoStep: the sample period {period:g} s is below the time resolution at "
                             f"t = {t_end:.17g} s (instants closer than {tol:g} s are one)")
            k_after = instants.first_after(t_end)
            if k_after is None:
                self._reject(f"fmi2DoStep: h = {h:g} s: the sample instants up to t = {t_end:g} s cannot be counted "
                             "exactly (limit 2^52 periods)")
            k_end = k_after - 1
            count = k_end - self.next_k + 1
            limit = MAX_STEP_INSTANTS if self._sampler["module"] is None else MAX_STEP_PYTHON_SAMPLES
            if count > limit:
                self._reject(f"fmi2DoStep: h = {h:g} s spans {count} sample instants of {period:g} s "
                             f"(limit {limit}); take shorter communication steps")
            # each of the count + 1 segments between instants lasts at most min(h, period), one
            # more substep each for the rounding of its length
            n_sub = (count + 1) * (self._substeps(min(h, period)) + (1.0 if self.generated.N_STATES else 0.0))
        else:
            n_sub = self._substeps(h)
        if not n_sub <= MAX_STEP_SUBSTEPS:
            self._reject(f"fmi2DoStep: h = {h:g} s would need {n_sub:g} integration substeps (limit "
                         f"{MAX_STEP_SUBSTEPS}); take shorter communication steps or raise h_max")
        return k_end

    def _step_sampled(self, t_end: float, k_end: int) -> None:
        """Integrate to ``t_end`` in segments between the instants ``next_k .. k_end``, sampling at each."""
        instants = self._instants(self.p, self.start_time)
        tol = instants.tol(t_end)
        if self.sample_due:
            self._sample()
        while self.next_k <= k_end:
            t_k = instants.time(self.next_k)
            if t_k >= t_end - tol:  # the step ends at this instant
                break
            self._integrate(t_k - self.time, t_k)
            self.next_k += 1
            self._new_instant()
            self._sample()
        self._integrate(t_end - self.time, t_end)
        self.at_instant = self.next_k <= k_end
        if self.at_instant:
            self.next_k = k_end + 1
            self._new_instant()
        self.sample_due = self.at_instant
        # sampled from the inputs set for the next step
        self.inputs_stale = self.at_instant and len(self.u) > 0

    def _integrate(self, h: float, t_end: float) -> None:
        """Advance the state by ``h`` seconds from the FMU time, which ends at ``t_end`` (inputs and
        held values constant; the substeps are within bounds, :meth:`_plan_step`)."""
        t0 = self.time
        if not self.generated.N_STATES:
            self.time = t_end
            return
        n = int(self._substeps(h))
        try:
            if self._flow is not None:
                hs, t, x = h / n, t0, self.x
                for k in range(n):
                    x = self._flow.step(t, x, self.u, self.p, hs)
                    t = t_end if k + 1 == n else t0 + (k + 1) * hs
            else:
                x = rk4_step(self.generated, t0, self.x, self.u, self.p, h, n)
        except ArithmeticError:  # float ** overflows with OverflowError where C gives inf
            x = [math.inf]
        if not all(math.isfinite(v) for v in x):
            self.mode = "Error"
            self._reject(f"fmi2DoStep: the state became non-finite in the step from t = {t0:g} s "
                         f"with h = {h:g} s ({n} substeps); reduce the step or h_max, or restore an FMU state")
        self.x = x
        self.time = t_end

    def terminate(self) -> None:
        # FMI 2.0: from stepComplete only (an instance in the error state is reset or freed)
        self._require("fmi2Terminate", "StepComplete")
        self.mode = "Terminated"

    # ------------------------------------------------------------ FMU state
    def _get_fmu_state(self) -> dict[str, Any]:
        """The FMU state: the model's identity (name, this FMU's GUID), the layout version,
        the content (what a restore sets; the outputs are recomputed from it) and the CRC-32 of
        all of them."""
        content = {"mode": self.mode, "time": self.time, "start_time": self.start_time,
                   "stop_time": None if math.isinf(self.stop_time) else self.stop_time,
                   "x": list(self.x), "u": list(self.u), "p": list(self.p), "held_prev": list(self.held_prev),
                   "next_k": self.next_k, "at_instant": self.at_instant, "sample_due": self.sample_due,
                   "inputs_stale": self.inputs_stale}
        state = {"model": self.generated.NAME, "guid": self.generated.GUID, "format": STATE_FORMAT,
                 "content": content}
        return {**state, "crc32": _checksum(state)}

    def _set_fmu_state(self, state: Any) -> None:
        problem = self._state_problem(state)
        if problem is not None:
            self._reject(f"fmi2SetFMUstate: {problem}")
        content = state["content"]
        for key in ("mode", "at_instant", "sample_due", "inputs_stale", "next_k"):
            setattr(self, key, content[key])
        for key in ("time", "start_time"):
            setattr(self, key, float(content[key]))
        self.stop_time = math.inf if content["stop_time"] is None else float(content["stop_time"])
        for key in ("x", "u", "p", "held_prev"):
            setattr(self, key, [float(v) for v in content[key]])
        self.outputs_valid = False

    @staticmethod
    def _fmu_state_to_bytes(state: dict[str, Any] | RefusedState) -> bytes:
        """The serialized state: its canonical JSON; a NUL byte and the reason for a
        :class:`RefusedState` (the C layer reads it and refuses the deserialization)."""
        if isinstance(state, RefusedState):
            return b"\0" + state.reason.encode("utf-8", "replace")
        return _canonical_json(state).encode()

    @classmethod
    def _fmu_state_from_bytes(cls, data: bytes) -> dict[str, Any] | RefusedState:
        """Decode and check a serialized FMU state; a buffer that is not a valid state of this
        model gives a :class:`RefusedState` with the reason (a class method cannot refuse with
        :meth:`_reject`: it has no instance whose references to balance)."""
        try:
            state = json.loads(data.decode("utf-8"), parse_constant=_refuse_constant)
        except (UnicodeDecodeError, ValueError, RecursionError) as exc:  # json.JSONDecodeError is a ValueError
            return RefusedState(f"fmi2DeSerializeFMUstate: not a state of this FMU ({type(exc).__name__}: {exc})")
        problem = cls._state_problem(state)
        if problem is None and cls._fmu_state_to_bytes(state) != data:  # e.g. 1e-05 written 1E-05
            problem = "corrupted state (not the canonical serialization this FMU writes)"
        if problem is not None:
            return RefusedState(f"fmi2DeSerializeFMUstate: {problem}")
        return state

    @classmethod
    def _state_problem(cls, state: Any) -> str | None:
        """What makes ``state`` unfit to restore (as the native FMU checks its records: identity,
        layout, checksum, then every field's range), or None."""
        gen = cls.generated
        if not (isinstance(state, dict) and set(state) == {"model", "guid", "format", "content", "crc32"}):
            return "not a state of this FMU (not a satfmu FMU state)"
        if state["guid"] != gen.GUID or state["model"] != gen.NAME:
            return (f"not a state of this FMU (the state of model {state['model']!r} with GUID {state['guid']!r}; "
                    f"this FMU is {gen.NAME!r} with GUID {gen.GUID})")
        if state["format"] != STATE_FORMAT:
            return f"not a state of this FMU (format {state['format']!r}, expected {STATE_FORMAT})"
        try:
            crc = _checksum(state)
        except (TypeError, ValueError):  # a value JSON cannot hold, e.g. NaN in a state made in memory
            return "corrupted state (a value is not finite)"
        if state["crc32"] != crc:
            given = state["crc32"]
            shown = f"0x{given:08x}" if _is_real(given) and isinstance(given, int) else repr(given)
            return f"corrupted state (checksum {shown}, computed 0x{crc:08x})"
        content = state["content"]
        if not (isinstance(content, dict) and set(content) == STATE_FIELDS):
            return "corrupted state (fields)"
        return cls._content_problem(content)

    @classmethod
    def _content_problem(cls, c: dict[str, Any]) -> str | None:
        """The range checks of a state's content (one with a valid checksum: written by this
        FMU's code, so they guard against a faulty build of the same model)."""
        gen = cls.generated
        nh = gen.SAMPLER["n_held"] if gen.SAMPLER else 0
        table = gen.VARIABLES
        n_p = sum(1 for v in table if v["kind"] == KIND_PARAMETER)
        n_u = sum(1 for v in table if v["kind"] == KIND_INPUT)
        if c["mode"] not in STATE_MODES:
            return f"corrupted state (invalid model state {c['mode']!r})"
        flags = (c["at_instant"], c["sample_due"], c["inputs_stale"])
        if (not all(isinstance(f, bool) for f in flags) or (nh == 0 and (c["sample_due"] or c["inputs_stale"]))
                or (c["inputs_stale"] and not c["at_instant"])):
            return f"corrupted state (flags {flags!r})"
        lengths = {"x": gen.N_STATES, "u": n_u, "p": n_p + nh, "held_prev": nh}
        for key, n in lengths.items():
            if not (isinstance(c[key], list) and len(c[key]) == n and all(_is_real(v) for v in c[key])):
                return f"corrupted state ({key}: expected {n} numbers)"
        times = (c["time"], c["start_time"]) + (() if c["stop_time"] is None else (c["stop_time"],))
        if not all(_is_real(v) for v in times):
            return "corrupted state (times)"
        start, t = float(c["start_time"]), float(c["time"])
        stop = math.inf if c["stop_time"] is None else float(c["stop_time"])
        tol = gen.time_tolerance(t)
        if not (math.isfinite(start) and math.isfinite(t) and stop >= start and start - tol <= t <= stop + tol):
            return f"corrupted state (time {t:g} s outside [start {start:g} s, stop {stop:g} s])"
        if not all(math.isfinite(v) for v in c["x"]):
            return "corrupted state (non-finite continuous state)"
        if not all(math.isfinite(v) for v in c["held_prev"] + c["p"][n_p:]):
            return "corrupted state (held values)"
        for row in table:
            if row["kind"] == KIND_OUTPUT:
                continue
            value = float((c["p"] if row["kind"] == KIND_PARAMETER else c["u"])[row["index"]])
            lo = -math.inf if row["min"] is None else row["min"]
            hi = math.inf if row["max"] is None else row["max"]
            if not (math.isfinite(value) and lo <= value <= hi):
                return f"corrupted state (variable '{row['name']}' = {value:g})"
        if not (isinstance(c["next_k"], int) and not isinstance(c["next_k"], bool) and abs(c["next_k"]) < INDEX_LIMIT):
            return f"corrupted state (sample index {c['next_k']!r})"
        if nh and c["mode"] in ("StepComplete", "Terminated"):
            expected = cls._instants([float(v) for v in c["p"]], start).first_after(t)
            if c["next_k"] != expected:
                return f"corrupted state (sample index {c['next_k']}, the time {t:.17g} s gives {expected})"
        return None

    def to_xml(self, model_options: dict[str, str] | None = None) -> Element:
        """satfmu's model description of this model (written at build time next to this file)."""
        return parse(os.path.join(self.resources, DESCRIPTION_FILE)).getroot()


STATE_FIELDS = {"mode", "time", "start_time", "stop_time", "x", "u", "p", "held_prev", "next_k", "at_instant",
                "sample_due", "inputs_stale"}
"""The fields of an FMU state's content (``SatfmuSlave._get_fmu_state``)."""


def _is_real(v: Any) -> bool:
    """A JSON number (int or float, not a bool)."""
    return isinstance(v, (int, float)) and not isinstance(v, bool)
