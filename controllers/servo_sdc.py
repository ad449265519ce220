"""The SDRE servo of the VSCMG (seed 002, eq. 5-10): its signals, its augmented SDC model and weights.

Servo state (7, matching the seed's Qe) xe = [int e2, int e4, e2, e4, w1, w2, w4] with
e = q_ref - q and the reference held constant in the design model:

    xe' = Ae(x) xe + Be(x) u,   u = [T1, T2],
    Ae = [[0, I2, 0], [0, 0, -S], [0, 0, A_ww(x)]],   Be = [0; 0; B_w(x)],

S picking (w2, w4) out of w, and A_ww = -M^-1 N_sdc, B_w = M^-1 G from the plant's SDC
form (:func:`satfmu.fmus.plants.vscmg.sdc_form`; frictionless, unsaturated). The law is u = -K(x) xe,
K = Re^-1 Be^T P from the Riccati equation of the shifted pair (Ae - eps I, Be)
(:func:`satfmu.controllers.riccati.riccati_gain`).

One definition for both sides: the online SDRE FMU (:func:`satfmu.controllers.servo.build_online`)
solves its gain from these matrices and weights, and the design side
(:mod:`satfmu.synthesis.servo.sdre`, :mod:`satfmu.synthesis.servo.gain_fit`,
:mod:`satfmu.synthesis.servo.vscmg_region`) grids,
fits and certifies the same law; the servo artifacts carry the same signals.
"""
from __future__ import annotations

import numpy as np
import sympy as sp

from satfmu.fmus.plants import vscmg
from satfmu.fmus.model import Model

SERVO_STATES = ("int_e2", "int_e4", "e2", "e4", "w1", "w2", "w4")
"""Servo state names; int_e* in rad s, e* in rad, w* in rad/s."""

Q_SEED = np.diag([3.0, 30.0, 1.0, 25.0, 0.01, 0.1, 0.1])
"""Seed 002 eq. (10) state weight Qe."""

R_SEED = np.diag([10.2, 0.3])
"""Seed 002 eq. (10) input weight Re."""

EPS = 1e-6
"""Riccati shift, 1/s (docs/models.md: the gain converges to 4 digits as eps -> 0)."""

PLANT_STATES = ("q1", "q2", "q4", "w1", "w2", "w4")

TRACKED = [{"name": "q2", "reference": "q2_ref", "unit": "rad"}, {"name": "q4", "reference": "q4_ref", "unit": "rad"}]
RATES = [{"name": n, "unit": "rad/s"} for n in ("w1", "w2", "w4")]
OUTPUTS = [{"name": "T1", "unit": "N.m", "description": "Rotor-1 motor torque command"},
           {"name": "T2", "unit": "N.m", "description": "Gimbal-2 motor torque command"}]


def servo_matrices(model: Model = vscmg.MODEL, factorization: str = "gyro_on_w2", freeze_w2: bool = False
                   ) -> tuple[sp.Matrix, sp.Matrix]:
    """Symbolic Ae(x) (7x7) and Be(x) (7x2) in the plant's state and parameter symbols
    (with ``freeze_w2``, evaluated at w2 = 0: the seed's setting for the approximation).

    Parameters
    ----------
    model : Model, optional
        A VSCMG model of :func:`satfmu.fmus.plants.vscmg.build` (default: the plant,
        ``satfmu.fmus.plants.vscmg.MODEL``): its symbols appear in the matrices.
    factorization : {"gyro_on_w2", "w1_free"}, optional
        The SDC factorization of the gyroscopic torques (:func:`satfmu.fmus.plants.vscmg.model_sdc`).
    freeze_w2 : bool, optional
        Substitute w2 = 0 in both matrices.

    Returns
    -------
    tuple of sympy.Matrix
        ``(Ae, Be)``, shapes (7, 7) and (7, 2), for the servo state :data:`SERVO_STATES` and
        ``u = [T1, T2]`` (N m).
    """
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
    """xe from the plant state x = [q1, q2, q4, w1, w2, w4], int e and q_ref = [q2_ref, q4_ref].

    Parameters
    ----------
    x : numpy.ndarray, shape (6,)
        The plant state ``[q1, q2, q4, w1, w2, w4]`` (rad, rad/s).
    integrals : numpy.ndarray, shape (2,)
        The integrals of the tracking errors ``[int e2, int e4]`` (rad s).
    reference : numpy.ndarray, shape (2,)
        The references ``[q2_ref, q4_ref]`` (rad).

    Returns
    -------
    numpy.ndarray, shape (7,)
        ``xe = [int e2, int e4, e2, e4, w1, w2, w4]`` with ``e = q_ref - q``.
    """
    x = np.asarray(x, float)
    e = np.asarray(reference, float) - x[[1, 2]]
    return np.concatenate([np.asarray(integrals, float), e, x[3:6]])
