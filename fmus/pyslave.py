"""Runtime of satfmu's pythonfmu FMUs, and the Python RK4 shared with reference simulations.

This file is copied verbatim into every pythonfmu FMU (as ``resources/satfmu_pyslave.py``)
next to the generated model module (:func:`fmus.codegen.python_source`), so at run
time it may import only the standard library and pythonfmu. It implements the same
behaviour as the generic C wrapper ``fmus/c/fmi2_cosim.c``: RK4 with held inputs,
``max(n_substeps, ceil(h / h_max))`` substeps (or the exact flow of an affine model,
:class:`ExactFlow`), the post-step map, value checks
(finite, in range, right causality), the co-simulation call order, and FMU state.

A model with a sampler (:class:`fmus.model.Sampler`) also holds values computed at the
start and at the instants ``k * period - phase`` (``t0 + k * period`` without a phase): a
step is integrated in segments between instants. The values of an instant at a communication
point are computed from the inputs set at that point, when first needed (an output
read or the next step), and again if an input changes there.

pythonfmu 0.7.0 writes parameters without variability and omits the
ModelStructure's InitialUnknowns; :meth:`SatfmuSlave.to_xml` therefore returns
satfmu's own model description (the same one the native FMU carries).
"""
from __future__ import annotations

import ctypes
import functools
import importlib
import math
import os
import sys
from types import ModuleType
from typing import Any, Callable, Sequence
from xml.etree.ElementTree import Element, parse

from pythonfmu import Boolean, Fmi2Causality, Fmi2Slave, Fmi2Variability, Integer, Real
from pythonfmu.enums import Fmi2Status

KIND_PARAMETER, KIND_INPUT, KIND_OUTPUT = 0, 1, 2
DESCRIPTION_FILE = "satfmu_description.xml"
MAX_SUBSTEPS = 10_000_000


def substep_count(h: float, n_substeps: float, h_max: float) -> int:
    """Number of RK4 substeps for a communication step of ``h`` seconds."""
    return int(max(n_substeps, math.ceil(h / h_max)))


TAYLOR_TERMS = 18
MAX_SWITCHES = 64


def _matmul(a: list[list[float]], b: list[list[float]]) -> list[list[float]]:
    bt = list(zip(*b))
    return [[sum(x * y for x, y in zip(row, col)) for col in bt] for row in a]


def affine_flow(A: list[list[float]], tau: float) -> tuple[list[list[float]], list[list[float]]]:
    """``Phi = e^{A tau}`` and ``Gamma = integral_0^tau e^{A s} ds`` as the C wrapper computes them.

    Taylor series of Gamma at ``tau / 2^s`` with ``|A|_inf tau / 2^s <= 1/2`` (18 terms), then
    ``s`` doublings ``Gamma <- (I + Phi) Gamma``, ``Phi <- Phi^2``.
    """
    n = len(A)
    eye = [[1.0 if i == j else 0.0 for j in range(n)] for i in range(n)]
    norm = max((sum(abs(v) for v in row) for row in A), default=0.0) * tau
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
        W = _matmul(phi, gamma)
        gamma = [[g + w for g, w in zip(rg, rw)] for rg, rw in zip(gamma, W)]
        phi = _matmul(phi, phi)
    return phi, gamma


class ExactFlow:
    """The exact integrator of an affine model (``INTEGRATOR == "exact"``), with the C wrapper's
    cache of ``(Phi, Gamma)`` for the last ``(A, tau)``."""

    def __init__(self, gen: ModuleType) -> None:
        self.gen = gen
        self.key: tuple | None = None
        self.flow: tuple[list[list[float]], list[list[float]]] | None = None

    def segment(self, t: float, x: list[float], u: Sequence[float], p: Sequence[float], tau: float) -> list[float]:
        """Exact flow over ``tau`` seconds with the law frozen at ``x``, then the post-step map."""
        n = len(x)
        flat = self.gen.jacobian(t, x, x, u, p)
        b = self.gen.derivatives(t, [0.0] * n, x, u, p)
        key = (tau, tuple(flat))
        if key != self.key:
            self.flow = affine_flow([list(flat[i * n:(i + 1) * n]) for i in range(n)], tau)
            self.key = key
        phi, gamma = self.flow  # type: ignore[misc]
        xt = [sum(f * v for f, v in zip(phi[i], x)) + sum(g * v for g, v in zip(gamma[i], b)) for i in range(n)]
        return self.gen.post_step(t + tau, xt, x, u, p)

    def step(self, t: float, x: Sequence[float], u: Sequence[float], p: Sequence[float], h: float, t_end: float
             ) -> list[float]:
        """Advance ``h`` seconds from ``t`` to ``t_end``, cut at the switch instants of the piecewise
        law (an uncut step uses ``h`` itself, so a constant step size reuses the cached flow)."""
        x = list(x)
        t_start = t
        for _ in range(MAX_SWITCHES):
            ts = self.gen.switch_time(t, x, u, p)[0]
            if not ts > self.gen.TIME_TOL * max(1.0, abs(t_end)) or ts >= t_end - t:
                break
            x = self.segment(t, x, u, p, ts)
            t += ts
        return self.segment(t, x, u, p, h if t == t_start else t_end - t)


def rk4_step(gen: ModuleType, t: float, x: Sequence[float], u: Sequence[float], p: Sequence[float],
             h: float, n: int) -> list[float]:
    """Advance the generated model ``gen`` by ``h`` seconds in ``n`` RK4 substeps, ``u`` held.

    The arithmetic is written in the same order as the C wrapper's, so both
    backends agree to rounding.
    """
    f = gen.derivatives
    post = gen.post_step
    hs = h / n
    x = list(x)
    nx = len(x)
    for k in range(n):
        k1 = f(t, x, x, u, p)
        xt = [x[i] + 0.5 * hs * k1[i] for i in range(nx)]
        k2 = f(t + 0.5 * hs, xt, x, u, p)
        xt = [x[i] + 0.5 * hs * k2[i] for i in range(nx)]
        k3 = f(t + 0.5 * hs, xt, x, u, p)
        xt = [x[i] + hs * k3[i] for i in range(nx)]
        k4 = f(t + hs, xt, x, u, p)
        xt = [x[i] + hs / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]) for i in range(nx)]
        x = post(t + hs, xt, x, u, p)
        t = t + hs
    return x


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


class FmuCallError(RuntimeError):
    """An FMI call was rejected (bad value, wrong call order); the message names the variable."""


class SatfmuSlave(Fmi2Slave):
    """pythonfmu slave of a generated satfmu model; subclasses set :attr:`generated`."""

    generated: ModuleType

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        _compensate_pythonfmu_refcount(type(self).__module__)
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
        if smp is not None and smp["module"] is not None:
            fn = getattr(importlib.import_module(smp["module"]), smp["function"])
            self._sample_fn = functools.partial(fn, **smp["options"])
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
        self.p += [0.0] * (self._sampler["n_held"] if self._sampler else 0)  # held values follow
        self.start_time = 0.0
        self.next_instant = 0.0  # the first sample instant after the FMU time
        self.held_prev = [0.0] * (self._sampler["n_held"] if self._sampler else 0)  # previous instant's
        self.at_instant = True  # the FMU time is a sample instant
        self.sample_due = self._sampler is not None  # the held values of that instant are stale
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
            if self.sample_due:
                self._sample()
            self.y = self.generated.outputs(self.time, self.x, self.u, self.p)
            self.outputs_valid = True
        return self._slot(row)[row["index"]]

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

    def _reject(self, message: str) -> None:
        """Log ``message`` and fail the call (pythonfmu 0.7.0 returns fmi2Fatal for any exception).

        On an exception pythonfmu's ``handle_py_exception`` releases its references to this
        instance, its class and its log queue without forgetting them, and releases them
        again in fmi2FreeInstance (or fmi2Reset): a host that frees the instance after the
        fmi2Fatal (as :class:`sims.master.CoSimulation` does) crashed. One extra reference
        each keeps the count balanced; an instance that is never freed stays alive.
        """
        self.log(message, Fmi2Status.error, "logStatusError")
        for obj in (self, type(self), self.log_queue):
            ctypes.pythonapi.Py_IncRef(ctypes.py_object(obj))
        raise FmuCallError(message)

    def _sample(self) -> None:
        """Compute the held values at the current time, state, inputs and parameters."""
        n_held = self._sampler["n_held"]
        p = self.p[:len(self.p) - n_held] + self.held_prev  # expressions read the previous instant's values
        args = self.generated.sample_arguments(self.time, self.x, self.u, p)
        try:
            held = [float(v) for v in self._sample_fn(args)]
        except Exception as exc:  # the sampler's own message names what failed
            self.mode = "Error"
            self._reject(f"sample at t = {self.time:g} s failed: {type(exc).__name__}: {exc}")
        if len(held) != self._sampler["n_held"] or not all(math.isfinite(v) for v in held):
            self.mode = "Error"
            self._reject(f"sample at t = {self.time:g} s returned {held!r}, expected "
                         f"{self._sampler['n_held']} finite values")
        self.p[len(self.p) - len(held):] = held
        self.sample_due = False
        self.outputs_valid = False

    def _require(self, fn: str, *modes: str) -> None:
        if self.mode not in modes:
            self._reject(f"{fn} must not be called in state {self.mode}")

    # ------------------------------------------------------------ FMI
    def setup_experiment(self, start_time: float, stop_time: float | None, tolerance: float | None) -> None:
        self._require("fmi2SetupExperiment", "Instantiated")
        if not math.isfinite(start_time):
            self._reject("fmi2SetupExperiment: non-finite startTime")
        if stop_time is not None and not stop_time >= start_time:
            self._reject(f"fmi2SetupExperiment: stopTime {stop_time:g} before startTime {start_time:g}")
        self.time = float(start_time)
        self.start_time = self.time

    def enter_initialization_mode(self) -> None:
        self._require("fmi2EnterInitializationMode", "Instantiated")
        self.mode = "InitializationMode"
        self.outputs_valid = False

    def exit_initialization_mode(self) -> None:
        self._require("fmi2ExitInitializationMode", "InitializationMode")
        self.x = [self.p[i] for i in self.generated.STATE_INITIAL]
        self.mode = "StepComplete"
        self.outputs_valid = False
        self.at_instant = True
        self.sample_due = self._sampler is not None
        if self._sampler is not None:
            self.next_instant = self._instant_after(self.time)

    def do_step(self, current_time: float, step_size: float) -> bool:
        self._require("fmi2DoStep", "StepComplete")
        h = float(step_size)
        if not (math.isfinite(h) and h > 0.0):
            self._reject(f"fmi2DoStep: communicationStepSize must be finite and > 0, got {h:g}")
        if not math.isfinite(current_time) or abs(current_time - self.time) > 1e-9 * max(1.0, abs(self.time)):
            self._reject(f"fmi2DoStep: currentCommunicationPoint {current_time!r} differs from the FMU time {self.time!r}")
        t_end = current_time + h
        if self._sampler is None:
            self._integrate(current_time, h)
        else:
            self._step_sampled(current_time, t_end)
        self.time = t_end
        self.outputs_valid = False
        return True

    def _instant_after(self, t: float) -> float:
        """The first sample instant later than ``t`` (by more than the time tolerance)."""
        period = self.p[self._sampler["period_index"]]
        if not (math.isfinite(period) and period > 0.0):
            self._reject(f"sample period {period!r} must be finite and > 0 s")
        i_phase = self._sampler["phase_index"]
        phase = -self.start_time if i_phase is None else self.p[i_phase]
        k = math.floor((t + phase) / period) + 1
        if k * period - phase <= t + self.generated.TIME_TOL * max(1.0, abs(t)):
            k += 1
        return k * period - phase

    def _new_instant(self) -> None:
        """The FMU time reached a new instant: what is held becomes the previous instant's values."""
        self.held_prev = self.p[len(self.p) - self._sampler["n_held"]:]

    def _step_sampled(self, t: float, t_end: float) -> None:
        """Integrate to ``t_end`` in segments between sample instants, sampling at each."""
        tol = self.generated.TIME_TOL * max(1.0, abs(t_end))
        if self.sample_due:
            self._sample()
        while True:
            t_next = self.next_instant
            if t_next < t_end - tol:
                self._integrate(t, t_next - t)
                t = self.time = t_next
                self.next_instant = self._instant_after(t)
                self._new_instant()
                self._sample()
                continue
            self._integrate(t, t_end - t)
            self.at_instant = abs(t_next - t_end) <= tol
            if self.at_instant:
                self.next_instant = self._instant_after(t_next)
                self._new_instant()
            self.sample_due = self.at_instant
            return

    def _integrate(self, t: float, h: float) -> None:
        """Advance the state by ``h`` seconds from ``t`` (inputs and held values constant)."""
        if not self.generated.N_STATES:
            return
        n_sub = self.p[self._i_nsub] if self._i_nsub >= 0 else 1.0
        h_max = self.p[self._i_hmax] if self._i_hmax >= 0 else math.inf
        n = substep_count(h, n_sub, h_max)
        if n > MAX_SUBSTEPS:
            self._reject(f"fmi2DoStep: step {h:g} s would need {n} RK4 substeps (limit {MAX_SUBSTEPS}); raise h_max")
        try:
            if self._flow is not None:
                x = self.x
                for k in range(n):
                    x = self._flow.step(t + k * h / n, x, self.u, self.p, h / n,
                                        t + h if k + 1 == n else t + (k + 1) * h / n)
            else:
                x = rk4_step(self.generated, t, self.x, self.u, self.p, h, n)
        except ArithmeticError:  # float ** overflows with OverflowError where C gives inf
            x = [math.inf]
        if not all(math.isfinite(v) for v in x):
            self.mode = "Error"
            self._reject(f"fmi2DoStep: the state became non-finite in the step from t = {t:g} s "
                         f"with h = {h:g} s ({n} substeps); reduce the step or h_max, or restore an FMU state")
        self.x = x

    def terminate(self) -> None:
        self._require("fmi2Terminate", "StepComplete", "Error")
        self.mode = "Terminated"

    def _get_fmu_state(self) -> dict[str, Any]:
        return {"mode": self.mode, "time": self.time, "x": list(self.x), "u": list(self.u),
                "p": list(self.p), "y": list(self.y), "outputs_valid": self.outputs_valid,
                "start_time": self.start_time, "next_instant": self.next_instant, "held_prev": list(self.held_prev),
                "at_instant": self.at_instant, "sample_due": self.sample_due}

    def _set_fmu_state(self, state: dict[str, Any]) -> None:
        for key in ("mode", "time", "outputs_valid", "start_time", "next_instant", "at_instant", "sample_due"):
            setattr(self, key, state[key])
        for key in ("x", "u", "p", "y", "held_prev"):
            setattr(self, key, list(state[key]))

    def to_xml(self, model_options: dict[str, str] | None = None) -> Element:
        """satfmu's model description of this model (written at build time next to this file)."""
        return parse(os.path.join(self.resources, DESCRIPTION_FILE)).getroot()
