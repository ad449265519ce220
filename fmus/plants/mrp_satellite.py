"""Plant "MRP satellite": rigid body with modified Rodrigues parameters (seed 000).

Seed: the seed 000 paper, eq. (31)-(37); cleaned up in
docs/models.md, "Seed 000". State x = [omega (rad/s), sigma (MRP, 1)]:

    J omega' = -omega x (J omega) + sat(u) + w_d
    sigma'   = (1/4) B(sigma) omega,
    B(s) = (1 - s^T s) I3 + 2 [s x] + 2 s s^T

with the full inertia tensor J (parameters ``I_x, I_y, I_z`` on the diagonal and the
products ``I_xy, I_xz, I_yz`` off it, kg m^2; defaults from the spacecraft the model is
built for, :class:`satfmu.fmus.plants.spacecraft.Spacecraft`; seed 000: diag(15, 16, 12.5)), an
optional actuator saturation ``|u_i| <= u_max`` (off by default) and optional MRP
shadow-set switching ``sigma <- -sigma / |sigma|^2`` when ``|sigma| > 1``, applied after
every integration substep (off by default: the seed does not switch, its 200 deg
case starts at ``|sigma| = 1.19``).

The SDC form x' = A(x) x + B [u; w_d] generalizes seed 000's eq. (35)-(37): with
J = D + N (diagonal D, products N), ``-omega x (J omega) = S(omega) omega - [omega x] N omega``
where S holds the seed's entries ``(I_y - I_z) omega_3`` etc., so
``A_ww = J^-1 (S(omega) - [omega x] N)`` is the seed's matrix exactly when N = 0.
"""
from __future__ import annotations

import numpy as np
import sympy as sp

from satfmu.fmus.model import Model, Output, SDCForm, Variable, saturate, states, symbols, vector
from satfmu.fmus.plants.spacecraft import PARAMETERS, SEED_000, Spacecraft

INERTIA_SEED_000 = tuple(SEED_000.inertia[i][i] for i in range(3))
"""Principal moments of inertia of seed 000, kg m^2."""
_AXES = {"I_x": "x", "I_y": "y", "I_z": "z", "I_xy": "x and y", "I_xz": "x and z", "I_yz": "y and z"}


def skew(a: sp.Matrix) -> sp.Matrix:
    """Skew-symmetric matrix [a x] with [a x] b = a x b.

    Parameters
    ----------
    a : sympy.Matrix
        A 3-vector (3 x 1 or 1 x 3).

    Returns
    -------
    sympy.Matrix
        The 3 x 3 cross-product matrix.
    """
    return sp.Matrix([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])


def mrp_kinematics_matrix(s: sp.Matrix) -> sp.Matrix:
    """B(s) of sigma' = (1/4) B(s) omega.

    Parameters
    ----------
    s : sympy.Matrix
        The MRP attitude sigma, 3 x 1 (1).

    Returns
    -------
    sympy.Matrix
        The 3 x 3 matrix ``(1 - s^T s) I3 + 2 [s x] + 2 s s^T``.
    """
    return (1 - (s.T * s)[0]) * sp.eye(3) + 2 * skew(s) + 2 * s * s.T


def inertia_parameters(spacecraft: Spacecraft, prefix: str = "") -> list[Variable]:
    """The six inertia parameters, from I_x to I_yz (kg m^2), with the spacecraft's tensor as defaults.

    Parameters
    ----------
    spacecraft : Spacecraft
        Its inertia tensor gives the defaults.
    prefix : str, optional
        Text put before each description (what the inertia is of).

    Returns
    -------
    list of Variable
        ``I_x, I_y, I_z, I_xy, I_xz, I_yz``; the moments are > 0.
    """
    return [Variable(name, "kg.m2", prefix + (f"Moment of inertia about body axis {_AXES[name]}" if i == j else
                                              f"Product of inertia (tensor entry J[{i}][{j}]) of body axes "
                                              f"{_AXES[name]}"),
                     start=spacecraft.inertia[i][j], min=1e-9 if i == j else None)
            for name, (i, j) in PARAMETERS.items()]


def shadow_parameter() -> Variable:
    """The Boolean parameter ``shadow_switching`` (off by default)."""
    return Variable("shadow_switching", "1",
                    "Switch to the MRP shadow set (sigma -> -sigma/|sigma|^2) when |sigma| > 1", 0, "Boolean")


def shadow_post(s: sp.Matrix, enabled: sp.Symbol) -> list[sp.Expr]:
    """The post-step map of the MRPs: the shadow set ``-s / |s|^2`` when ``enabled`` and ``|s| > 1``.

    Parameters
    ----------
    s : sympy.Matrix
        The MRP states, 3 x 1.
    enabled : sympy.Symbol
        The symbol of :func:`shadow_parameter`.

    Returns
    -------
    list of sympy.Expr
        The three switched MRPs.
    """
    s2 = (s.T * s)[0]
    switch = sp.And(enabled > sp.Rational(1, 2), s2 > 1)
    # Max(s2, 1) equals s2 wherever the branch is taken; it keeps the hoisted division finite.
    return [sp.Piecewise((-si / sp.Max(s2, 1), switch), (si, True)) for si in s]


def phi_output(s: sp.Matrix) -> Output:
    """The output ``phi``, the principal rotation angle ``4 atan(|s|)`` of the MRPs ``s`` (rad).

    Parameters
    ----------
    s : sympy.Matrix
        The MRP states, 3 x 1.

    Returns
    -------
    Output
        The output.
    """
    return Output(Variable("phi", "rad", "Principal rotation angle 4 atan(|sigma|) of the "
                           "attitude (exceeds pi on the long way round, |sigma| > 1)"),
                  4 * sp.atan(sp.sqrt((s.T * s)[0])))


def build(spacecraft: Spacecraft = SEED_000, omega_0: tuple[float, float, float] = (0.0, 0.0, 0.0),
          sigma_0: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> Model:
    """The symbolic MRP satellite model of ``spacecraft``.

    Parameters
    ----------
    spacecraft : satfmu.fmus.plants.spacecraft.Spacecraft
        Its inertia tensor gives the defaults of ``I_x ... I_yz`` and its torque limit (if
        any) the default of ``u_max`` (else 5 N m). The model (name ``mrp_satellite``) and
        its FMU are the same for every spacecraft up to these defaults.
    omega_0 : 3 floats
        Default initial body rate, rad/s (FMU parameters ``omega_0[i]``).
    sigma_0 : 3 floats
        Default initial MRP attitude (FMU parameters ``sigma_0[i]``).
    """
    inertia = inertia_parameters(spacecraft)
    sat_on = Variable("saturation_on", "1", "Saturate the command torque at +-u_max", 0, "Boolean")
    u_max = Variable("u_max", "N.m", "Actuator torque limit per axis (when saturation_on)",
                     spacecraft.torque_limit or 5.0, min=0.0)
    shadow = shadow_parameter()
    xw = states("omega", 3, "rad/s", "body angular rate about body axis {i}", omega_0)
    xs = states("sigma", 3, "1", "modified Rodrigues parameter {i} (body w.r.t. reference)", sigma_0)
    u = vector("u", 3, "N.m", "Commanded control torque about body axis {i}")
    wd = vector("w_d", 3, "N.m", "Disturbance torque about body axis {i}")

    w, s = symbols(xw), symbols(xs)
    uc, wdist = symbols(u), symbols(wd)
    Ix, Iy, Iz, Ixy, Ixz, Iyz = (v.symbol for v in inertia)
    J = sp.Matrix([[Ix, Ixy, Ixz], [Ixy, Iy, Iyz], [Ixz, Iyz, Iz]])
    J_inv = J.adjugate() / J.det()
    u_applied = sp.Matrix([saturate(ui, u_max.symbol, sat_on.symbol) for ui in uc])
    omega_dot = J_inv * (-w.cross(J * w) + u_applied + wdist)
    sigma_dot = mrp_kinematics_matrix(s) * w / 4

    post = sp.Matrix(list(w) + shadow_post(s, shadow.symbol))

    # SDC form (seed 000 eq. 35-37 when the products vanish): x' = A(x) x + B [u; w_d], saturation off.
    S = sp.Matrix([[0, (Iy - Iz) * w[2], 0], [0, 0, (Iz - Ix) * w[0]], [(Ix - Iy) * w[1], 0, 0]])
    N = J - sp.diag(Ix, Iy, Iz)
    A = sp.zeros(6, 6)
    A[0:3, 0:3] = J_inv * (S - skew(w) * N)
    A[3:6, 0:3] = mrp_kinematics_matrix(s) / 4
    Binv = J_inv
    B = sp.Matrix(sp.BlockMatrix([[Binv, Binv], [sp.zeros(3, 3), sp.zeros(3, 3)]]))
    sdc = SDCForm(A, B, tuple(v.name for v in u + wd), {"saturation_on": 0.0})

    outputs = [Output(v.variable, v.symbol) for v in xw + xs] + [phi_output(s)]
    return Model(
        name="mrp_satellite",
        description="Rigid satellite, MRP attitude, torque inputs (seed 000: nonlinear "
                    "H-infinity attitude control via SOS)",
        states=xw + xs, inputs=u + wd, parameters=inertia + [sat_on, u_max, shadow],
        outputs=outputs, rhs=sp.Matrix(list(omega_dot) + list(sigma_dot)), post_step=post,
        sdc=sdc, default_stop_time=120.0, default_step_size=0.05)


def mrp_from_axis_angle(axis: np.ndarray, angle_rad: float) -> np.ndarray:
    """MRP ``k tan(Phi/4)`` of a rotation by ``angle_rad`` about ``axis`` (normalized here).

    Parameters
    ----------
    axis : numpy.ndarray, shape (3,)
        Rotation axis, any non-zero length.
    angle_rad : float
        Rotation angle Phi, rad.

    Returns
    -------
    numpy.ndarray, shape (3,)
        The modified Rodrigues parameters (1).

    Raises
    ------
    ValueError
        If the axis has zero length or is not a 3-vector.
    """
    k = np.asarray(axis, float)
    if k.shape != (3,) or not np.all(np.isfinite(k)) or np.linalg.norm(k) == 0:
        raise ValueError(f"axis must be a finite non-zero 3-vector, got {axis!r}")
    return k / np.linalg.norm(k) * np.tan(angle_rad / 4)


MODEL = build()
