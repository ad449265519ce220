"""SDRE optimal servo of the VSCMG (seed 002, eq. 5-12): augmented SDC model and checked gains.

Servo state (7, matching the seed's Qe) xe = [int e2, int e4, e2, e4, w1, w2, w4] with
e = q_ref - q and the reference held constant in the design model:

    xe' = Ae(x) xe + Be(x) u,   u = [T1, T2],
    Ae = [[0, I2, 0], [0, 0, -S], [0, 0, A_ww(x)]],   Be = [0; 0; B_w(x)],

S picking (w2, w4) out of w, and A_ww = -M^-1 N_sdc, B_w = M^-1 G from the plant's SDC
form (:func:`fmus.vscmg.sdc_form`; frictionless, unsaturated). The law is u = -K(x) xe,
K = Re^-1 Be^T P from the Riccati equation of the shifted pair (Ae - eps I, Be)
(:func:`controllers.riccati.riccati_gain`, checked at every call).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np
import sympy as sp

from controllers.riccati import RiccatiCheck, RiccatiCheckError, riccati_gain
from fmus import vscmg
from fmus.model import Model

SERVO_STATES = ("int_e2", "int_e4", "e2", "e4", "w1", "w2", "w4")
"""Servo state names; int_e* in rad s, e* in rad, w* in rad/s."""

Q_SEED = np.diag([3.0, 30.0, 1.0, 25.0, 0.01, 0.1, 0.1])
"""Seed 002 eq. (10) state weight Qe."""

R_SEED = np.diag([10.2, 0.3])
"""Seed 002 eq. (10) input weight Re."""

EPS = 1e-6
"""Riccati shift, 1/s (docs/models.md: the gain converges to 4 digits as eps -> 0)."""

PLANT_STATES = ("q1", "q2", "q4", "w1", "w2", "w4")


def servo_matrices(model: Model = vscmg.MODEL, factorization: str = "gyro_on_w2", freeze_w2: bool = False
                   ) -> tuple[sp.Matrix, sp.Matrix]:
    """Symbolic Ae(x) (7x7) and Be(x) (7x2) in the plant's state and parameter symbols
    (with ``freeze_w2``, evaluated at w2 = 0: the seed's setting for the approximation)."""
    sdc = vscmg.model_sdc(model, factorization)
    Ae = sp.zeros(7, 7)
    Ae[0, 2] = Ae[1, 3] = 1
    Ae[2, 5] = Ae[3, 6] = -1
    Ae[4:7, 4:7] = sdc.A[3:6, 3:6]
    Be = sp.zeros(7, 2)
    Be[4:7, :] = sdc.B[3:6, 0:2]
    if freeze_w2:
        w2 = {s.variable.name: s.symbol for s in model.states}["w2"]
        Ae, Be = Ae.subs(w2, 0), Be.subs(w2, 0)
    return Ae, Be


def servo_state(x: np.ndarray, integrals: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """xe from the plant state x = [q1, q2, q4, w1, w2, w4], int e and q_ref = [q2_ref, q4_ref]."""
    x = np.asarray(x, float)
    e = np.asarray(reference, float) - x[[1, 2]]
    return np.concatenate([np.asarray(integrals, float), e, x[3:6]])


@dataclass
class Servo:
    """Numerical SDRE servo: Ae, Be at a plant state and the checked gain.

    Parameters
    ----------
    factorization : str
        One of :data:`fmus.vscmg.FACTORIZATIONS`.
    Q, R : arrays
        Weights (default the seed's).
    eps : float
        Riccati shift, 1/s.
    freeze_w2 : bool
        Evaluate Ae with w2 := 0 (the seed's setting for the gain approximation).
    plant_params : dict
        Overrides of the plant model's parameters (inertias).
    """

    factorization: str = "gyro_on_w2"
    Q: np.ndarray = field(default_factory=lambda: Q_SEED.copy())
    R: np.ndarray = field(default_factory=lambda: R_SEED.copy())
    eps: float = EPS
    freeze_w2: bool = False
    plant_params: dict = field(default_factory=dict)
    model: Model = field(default_factory=lambda: vscmg.MODEL, repr=False)

    def __post_init__(self) -> None:
        Ae, Be = servo_matrices(self.model, self.factorization, self.freeze_w2)
        args = (self.model.state_symbols, self.model.parameter_symbols)
        self._A: Callable = sp.lambdify(args, Ae, "numpy", cse=True)
        self._B: Callable = sp.lambdify(args, Be, "numpy", cse=True)
        self._p = self.model.parameter_vector(self.plant_params)
        self.Q, self.R = np.asarray(self.Q, float), np.asarray(self.R, float)
        if self.Q.shape != (7, 7) or self.R.shape != (2, 2):
            raise ValueError(f"Q must be 7x7 and R 2x2, got {self.Q.shape} and {self.R.shape}")

    def matrices(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Ae (7x7) and Be (7x2) at the plant state ``x`` (6 values)."""
        x = np.array(x, float)
        if x.shape != (6,) or not np.all(np.isfinite(x)):
            raise ValueError(f"plant state must be 6 finite values {PLANT_STATES}, got {x!r}")
        return np.asarray(self._A(x, self._p), float), np.asarray(self._B(x, self._p), float)

    def gain(self, x: np.ndarray) -> tuple[np.ndarray, RiccatiCheck]:
        """K (2x7) at the plant state ``x`` and its check; u = -K xe.

        Raises
        ------
        controllers.riccati.RiccatiCheckError
            If the Riccati solution at ``x`` fails a check (the message gives the state).
        """
        A, B = self.matrices(x)
        try:
            return riccati_gain(A, B, self.Q, self.R, self.eps)
        except RiccatiCheckError as exc:
            raise RiccatiCheckError(f"{exc} at q2 = {x[1]:.4g} rad, w = [{x[3]:.4g}, {x[4]:.4g}, {x[5]:.4g}] "
                                    f"rad/s ({self.factorization} SDC)") from exc

    def __call__(self, x: np.ndarray) -> np.ndarray:
        """The checked gain K (2x7) at the plant state ``x`` (the law of :func:`simulate_servo`)."""
        return self.gain(x)[0]


SEED_REFERENCE_PROFILES = {
    "q2_ref": {"kind": "cosine_ramp", "start": 4.0, "stop": 8.0, "before": float(np.pi / 18),
               "after": float(1 + np.pi / 18)},
    "q4_ref": {"kind": "cosine_ramp", "start": 4.0, "stop": 8.0, "before": 0.0, "after": 1.0},
}
"""Seed 002 eq. (24)-(25) as profile declarations (:func:`fmus.profiles.make`; the scenarios
declare the same)."""


@dataclass
class ServoRun:
    """An in-process servo run at the control period: times (s), plant states, commands (N m)."""

    t: np.ndarray
    x: np.ndarray
    u: np.ndarray
    reference: np.ndarray

    @property
    def errors(self) -> np.ndarray:
        """[e2, e4] = q_ref - q, rad."""
        return self.reference - self.x[:, [1, 2]]


def simulate_servo(gain: Callable[[np.ndarray], np.ndarray], reference: Callable[[np.ndarray], np.ndarray],
                   stop_time: float = 15.0, period: float = 0.01, plant_params: dict | None = None,
                   model: Model = vscmg.MODEL) -> ServoRun:
    """A servo u = -K(x) xe on the plant's generated code, u held over each control period.

    ``gain(x)`` gives K (2x7) at the plant state x: a :class:`Servo` (online SDRE) or a
    fitted gain (:class:`synthesis.gain_fit.GainFit`). ``reference(t)`` gives
    [q2_ref, q4_ref] (rad) at the times ``t`` (s), shape (len(t), 2).

    The plant is advanced with the FMUs' RK4 (:func:`fmus.pyslave.rk4_step`) and the
    integral of the error by e held over the period, as the controller FMU does.

    Raises
    ------
    controllers.riccati.RiccatiCheckError
        At the first state whose Riccati solution fails a check (online SDRE).
    """
    from fmus import codegen
    from fmus.pyslave import rk4_step, substep_count

    gen = codegen.load_python(model)
    p = model.parameter_vector(plant_params)
    names = [v.name for v in model.parameters]
    n_sub = substep_count(period, p[names.index("n_substeps")], p[names.index("h_max")])
    n = int(round(stop_time / period))
    t = period * np.arange(n + 1)
    ref = np.asarray(reference(t), float)
    x = model.initial_state(p).tolist()
    integrals = np.zeros(2)
    xs, us = [x], []
    for k in range(n):
        K = gain(np.array(x))
        xe = servo_state(np.array(x), integrals, ref[k])
        u = -K @ xe
        us.append(u)
        x = rk4_step(gen, float(t[k]), x, [u[0], u[1], 0.0], p.tolist(), period, n_sub)
        integrals = integrals + xe[2:4] * period
        xs.append(x)
    us.append(us[-1])
    return ServoRun(t, np.array(xs), np.array(us), ref)
