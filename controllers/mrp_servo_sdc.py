"""The SDRE servo of a rigid spacecraft on the MRP satellite plant: signals, augmented SDC model, weights.

Seed 002's SDRE optimal servo (docs/models.md "Seed 002", eq. 5-10) re-posed for the MRP
satellite of seed 000 (:mod:`satfmu.fmus.plants.mrp_satellite`) instead of the VSCMG. Servo
state (9) ``xe = [int e (3), e (3), omega (3)]`` with ``e = sigma_ref - sigma`` and the
reference held constant in the design model:

    int e' = e
    e'     = -sigma' = -(1/4) B(sigma) omega
    omega' = A_ww(omega) omega + B_u u          (the plant's own SDC rows, saturation off)

so ``xe' = Ae(x) xe + Be(x) u`` with

    Ae = [[0, I3, 0], [0, 0, -(1/4) B(sigma)], [0, 0, A_ww(omega)]],   Be = [0; 0; J^-1].

The law is ``u = -K(x) xe``, ``K = R^-1 Be^T P`` of the Riccati equation of ``(Ae, Be, Q, R)``
(:func:`satfmu.controllers.riccati.riccati_gain`; the pair is stabilizable at every state since
``B(sigma) B(sigma)^T = (1 + |sigma|^2)^2 I3``, so no shift is needed, :data:`EPS` = 0).

Signal names: the servo's inputs are named as the plant's outputs (``sigma[i]``, ``omega[i]``)
and its commands as the plant's inputs (``u[i]``, N m), so a scenario connects the vectors by
name (:func:`plant_connections`); the references are ``sigma_ref[i]``.

One definition for both sides: the design (:mod:`satfmu.synthesis.servo.mrp_sdre`) grids, fits and
certifies the law of these matrices and weights, and an online SDRE FMU of the MRP plant would
solve its gain from the same :func:`servo_matrices`.
"""
from __future__ import annotations

import math

import numpy as np
import sympy as sp

from satfmu.fmus.model import Model
from satfmu.fmus.plants.spacecraft import Spacecraft

N_AXES = 3
SERVO_STATES = tuple([f"int_e_{i}" for i in (1, 2, 3)] + [f"e_{i}" for i in (1, 2, 3)]
                     + [f"omega_{i}" for i in (1, 2, 3)])
"""Servo state names: integrals of the MRP errors (s), MRP errors (1), body rates (rad/s)."""

PLANT_STATES = ("omega[1]", "omega[2]", "omega[3]", "sigma[1]", "sigma[2]", "sigma[3]")
"""The MRP plant's states, in its order: body rates (rad/s), then the MRPs (1)."""

EPS = 0.0
"""Riccati shift, 1/s: none is needed, the servo pair is stabilizable at every state."""

TRACKED = [{"name": f"sigma[{i}]", "reference": f"sigma_ref[{i}]", "unit": "1"} for i in (1, 2, 3)]
"""The tracked MRPs (the plant's ``sigma[i]``) and their references."""
RATES = [{"name": f"omega[{i}]", "unit": "rad/s"} for i in (1, 2, 3)]
"""The measured body rates (from the plant's ``omega[i]``)."""
OUTPUTS = [{"name": f"u[{i}]", "unit": "N.m", "description": f"Commanded control torque about body axis {i}"}
           for i in (1, 2, 3)]
"""The commands, named as the plant's torque inputs."""
SCHEDULING = [r["name"] for r in RATES] + [t["name"] for t in TRACKED]
"""The fitted gain's variables, in the plant's state order (omega, then sigma)."""

SIGMA_90DEG = math.tan(math.pi / 8)
"""MRP magnitude of a 90 deg rotation, tan(90 deg / 4) = 0.414."""
Q_INT_RATIO = 0.04
"""q_int / q_e, 1/s^2: the integral action's weight relative to the error's (a 5 s integral time)."""


def plant_connections(plant: str = "plant", controller: str = "controller") -> list[tuple[str, str]]:
    """The scenario connections between the MRP plant and this servo, ``(source, target)`` each.

    Parameters
    ----------
    plant : str, optional
        Instance name of the ``mrp_satellite`` plant.
    controller : str, optional
        Instance name of the servo.

    Returns
    -------
    list of tuple of (str, str)
        ``plant.sigma -> controller.sigma``, ``plant.omega -> controller.omega`` and
        ``controller.u -> plant.u`` (the vectors by name).
    """
    return [(f"{plant}.{v}", f"{controller}.{v}") for v in ("sigma", "omega")] + [(f"{controller}.u", f"{plant}.u")]


def servo_matrices(model: Model) -> tuple[sp.Matrix, sp.Matrix]:
    """Symbolic Ae(x) (9x9) and Be(x) (9x3) in the plant's state and parameter symbols.

    Parameters
    ----------
    model : Model
        An MRP satellite model of :func:`satfmu.fmus.plants.mrp_satellite.build` (any
        spacecraft): its SDC form gives ``A_ww``, ``B(sigma)/4`` and ``J^-1``.

    Returns
    -------
    tuple of sympy.Matrix
        ``(Ae, Be)`` for the servo state :data:`SERVO_STATES` and ``u = [u1, u2, u3]`` (N m).

    Raises
    ------
    ValueError
        If ``model`` has no SDC form of the MRP plant's shape (6 states, inputs ``u`` first).
    """
    sdc = model.sdc
    if sdc is None or sdc.A.shape != (6, 6) or sdc.B.shape[0] != 6 or sdc.B.shape[1] < 3 \
            or [s.variable.name for s in model.states] != list(PLANT_STATES):
        raise ValueError(f"model {model.name!r} is not an MRP satellite with an SDC form (states {PLANT_STATES})")
    Ae = sp.zeros(9, 9)
    Ae[0:3, 3:6] = sp.eye(3)
    Ae[3:6, 6:9] = -sdc.A[3:6, 0:3]
    Ae[6:9, 6:9] = sdc.A[0:3, 0:3]
    Be = sp.zeros(9, 3)
    Be[6:9, :] = sdc.B[0:3, 0:3]
    return Ae, Be


def servo_state(x: np.ndarray, integrals: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """xe from the plant state, the integrals of the errors and the reference.

    Parameters
    ----------
    x : numpy.ndarray, shape (6,)
        The plant state ``[omega (rad/s), sigma (1)]``.
    integrals : numpy.ndarray, shape (3,)
        The integrals of the MRP errors, s.
    reference : numpy.ndarray, shape (3,)
        The reference MRPs ``sigma_ref`` (1).

    Returns
    -------
    numpy.ndarray, shape (9,)
        ``xe = [int e, e, omega]`` with ``e = sigma_ref - sigma``.
    """
    x = np.asarray(x, float)
    return np.concatenate([np.asarray(integrals, float), np.asarray(reference, float) - x[3:6], x[0:3]])


def reference_torque(spacecraft: Spacecraft) -> float:
    """The torque the weights are scaled by: the spacecraft's torque limit, else 1 N m.

    Parameters
    ----------
    spacecraft : Spacecraft
        The spacecraft.

    Returns
    -------
    float
        N m.
    """
    return float(spacecraft.torque_limit) if spacecraft.torque_limit is not None else 1.0


def slew_rate(spacecraft: Spacecraft, angle: float = math.pi / 2) -> float:
    """Peak body rate of a bang-bang rest-to-rest slew by ``angle`` about the largest inertia axis, rad/s.

    ``sqrt(angle u_ref / I_max)`` with ``u_ref`` of :func:`reference_torque` and ``I_max`` the
    largest principal moment: the fastest rate a torque-limited slew reaches.

    Parameters
    ----------
    spacecraft : Spacecraft
        The spacecraft.
    angle : float, optional
        Slew angle, rad (default 90 deg).

    Returns
    -------
    float
        rad/s.
    """
    i_max = float(np.linalg.eigvalsh(np.array(spacecraft.inertia, float)).max())
    return math.sqrt(angle * reference_torque(spacecraft) / i_max)


def default_weights(spacecraft: Spacecraft) -> tuple[np.ndarray, np.ndarray]:
    """Bryson weights of the servo: ``Q = diag(q_int I3, q_e I3, q_w I3)`` (9x9), ``R`` (3x3).

    - ``R = I3 / u_ref^2`` (1/(N m)^2), ``u_ref`` the torque limit (Bryson's rule: a command
      at the limit costs 1), or 1 N m without one.
    - ``q_e = 1 / sigma_90^2`` with ``sigma_90 = tan(90 deg / 4)``: a 90 deg error costs 1.
    - ``q_w = 1 / w_slew^2`` (s^2/rad^2), ``w_slew`` of :func:`slew_rate`: the peak rate of a
      torque-limited 90 deg slew costs 1.
    - ``q_int = Q_INT_RATIO q_e`` (1/s^2): integral action with a 5 s integral time.

    The closed loop's speed then follows the spacecraft's agility (the slew rate): the LQ
    servo at the origin has its slowest eigenvalue at -0.225 1/s for seed 000's satellite
    (diag(15, 16, 12.5) kg m^2, 5 N m) and -0.235 1/s for a 100/120/80 kg m^2 bus with
    products of inertia and 20 N m. The fitted SDRE servo brings a 90 deg rest-to-rest slew
    (about [1, 1, 1]) to within 1 deg in 24 s (peak command 4.7 N m, inside the limit) and
    26 s (peak 21.5 N m, 7 % over the limit for a moment: the saturated run is unchanged to
    1e-6 deg) (``tests/test_mrp_sdre.py``, :func:`satfmu.synthesis.servo.mrp_sdre.simulate`).

    Parameters
    ----------
    spacecraft : Spacecraft
        Its inertia tensor (kg m^2) and torque limit (N m, optional).

    Returns
    -------
    Q : numpy.ndarray, shape (9, 9)
        State weight of ``xe = [int e, e, omega]``.
    R : numpy.ndarray, shape (3, 3)
        Input weight of ``u`` (N m).
    """
    u_ref = reference_torque(spacecraft)
    q_e = 1.0 / SIGMA_90DEG**2
    q_w = 1.0 / slew_rate(spacecraft) ** 2
    Q = np.diag([Q_INT_RATIO * q_e] * 3 + [q_e] * 3 + [q_w] * 3)
    return Q, np.eye(3) / u_ref**2
