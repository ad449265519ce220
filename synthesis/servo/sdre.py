"""SDRE optimal servo of the VSCMG (seed 002, eq. 5-12): checked gains and the in-process loop.

The servo's signals, its augmented SDC model xe' = Ae(x) xe + Be(x) u and the seed's
weights are defined with the controllers (:mod:`satfmu.controllers.servo_sdc`), where the online
SDRE FMU uses them too. Here: :class:`Servo`, the numerical Ae, Be at a plant state and
the gain K = Re^-1 Be^T P of the shifted pair (Ae - eps I, Be)
(:func:`satfmu.controllers.riccati.riccati_gain`, checked at every call), and
:func:`simulate_servo`, a servo law in closed loop with the plant's generated code.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from satfmu.controllers.servo_sdc import EPS, Q_SEED, R_SEED, servo_matrices, servo_state
from satfmu.fmus.plants import vscmg
from satfmu.fmus.model import Model
from satfmu.synthesis.servo.sdc_servo import SdcServo


@dataclass
class Servo(SdcServo):
    """Numerical SDRE servo of the VSCMG (:class:`satfmu.synthesis.servo.sdc_servo.SdcServo`): Ae (7x7),
    Be (7x2) at a plant state ``[q1, q2, q4, w1, w2, w4]`` (rad, rad/s) and the checked gain K (2x7,
    ``[T1, T2]`` in N m per servo state).

    Parameters
    ----------
    factorization : str
        One of :data:`satfmu.fmus.plants.vscmg.FACTORIZATIONS`.
    Q, R : arrays
        Weights (default the seed's).
    eps : float
        Riccati shift, 1/s.
    freeze_w2 : bool
        Evaluate Ae with w2 := 0 (the seed's setting for the gain approximation).
    plant_params : dict
        Overrides of the plant model's parameters (inertias).
    model : satfmu.fmus.model.Model
        The VSCMG model whose symbols and parameters give Ae, Be (default the plant,
        ``satfmu.fmus.plants.vscmg.MODEL``).
    """

    factorization: str = "gyro_on_w2"
    Q: np.ndarray = field(default_factory=lambda: Q_SEED.copy())
    R: np.ndarray = field(default_factory=lambda: R_SEED.copy())
    eps: float = EPS
    freeze_w2: bool = False
    plant_params: dict = field(default_factory=dict)
    model: Model = field(default_factory=lambda: vscmg.MODEL, repr=False)

    def __post_init__(self) -> None:
        self._compile(self.model, *servo_matrices(self.model, self.factorization, self.freeze_w2), self.plant_params)
        self.Q, self.R = np.asarray(self.Q, float), np.asarray(self.R, float)
        if self.Q.shape != (7, 7) or self.R.shape != (2, 2):
            raise ValueError(f"Q must be 7x7 and R 2x2, got {self.Q.shape} and {self.R.shape}")

    @property
    def weights(self) -> tuple[np.ndarray, np.ndarray]:
        """``(Q, R)``, shapes (7, 7) and (2, 2)."""
        return self.Q, self.R

    def describe_state(self, x: np.ndarray) -> str:
        """``q2`` and the rates of the plant state ``[q1, q2, q4, w1, w2, w4]`` (rad, rad/s), and the SDC
        factorization.

        Parameters
        ----------
        x : numpy.ndarray, shape (6,)
            The plant state.
        """
        return f"q2 = {x[1]:.4g} rad, w = [{x[3]:.4g}, {x[4]:.4g}, {x[5]:.4g}] rad/s ({self.factorization} SDC)"


SEED_REFERENCE_PROFILES = {
    "q2_ref": {"kind": "cosine_ramp", "start": 4.0, "stop": 8.0, "before": float(np.pi / 18),
               "after": float(1 + np.pi / 18)},
    "q4_ref": {"kind": "cosine_ramp", "start": 4.0, "stop": 8.0, "before": 0.0, "after": 1.0},
}
"""Seed 002 eq. (24)-(25) as profile declarations (:func:`satfmu.fmus.profiles.make`; the scenarios
declare the same)."""


@dataclass
class ServoRun:
    """An in-process servo run at the control period: times (s), plant states, commands (N m).

    Attributes
    ----------
    t : numpy.ndarray, shape (n + 1,)
        Control instants, s.
    x : numpy.ndarray, shape (n + 1, 6)
        Plant state ``[q1, q2, q4, w1, w2, w4]`` at each instant (rad, rad/s).
    u : numpy.ndarray, shape (n + 1, 2)
        Commands ``[T1, T2]`` held from each instant, N m (the last repeats the one before).
    reference : numpy.ndarray, shape (n + 1, 2)
        ``[q2_ref, q4_ref]`` at each instant, rad.
    """

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
    fitted gain (:class:`satfmu.synthesis.servo.gain_fit.GainFit`). ``reference(t)`` gives
    [q2_ref, q4_ref] (rad) at the times ``t`` (s), shape (len(t), 2).

    The plant is advanced with the FMUs' RK4 (:func:`satfmu.fmus.pyslave.rk4_step`) and the
    integral of the error by e held over the period, as the controller FMU does.

    Parameters
    ----------
    gain : callable
        ``gain(x)`` -> K, shape (2, 7), at the plant state ``x`` (shape (6,)).
    reference : callable
        ``reference(t)`` -> ``[q2_ref, q4_ref]`` (rad), shape (len(t), 2), at the times ``t`` (s).
    stop_time : float, optional
        Length of the run, s.
    period : float, optional
        Control period, s: the gain is evaluated and ``u`` held over each.
    plant_params : dict, optional
        Overrides of the plant's parameter values (initial state, inertias, integrator).
    model : satfmu.fmus.model.Model, optional
        The plant (default ``satfmu.fmus.plants.vscmg.MODEL``).

    Returns
    -------
    ServoRun
        The states, commands and references at the control instants.

    Raises
    ------
    satfmu.controllers.riccati.RiccatiCheckError
        At the first state whose Riccati solution fails a check (online SDRE).
    """
    from satfmu.fmus import codegen
    from satfmu.fmus.pyslave import rk4_step, substep_count

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
