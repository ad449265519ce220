"""Plant "magnetorquer cubesat": rigid body, quaternion attitude, magnetic torquers (seed 003).

Seed: the seed 003 paper, eq. (5)-(6); cleaned up in docs/models.md,
"Seed 003". State x = [omega (rad/s), q (1), q_norm_drift (1)]:

    I omega' = -omega x (I omega) + m_applied x b_body + T_d
    q'       = (1/2) W(omega_bo) q,      omega_bo = omega - C(q) [0, -n, 0]^T
    b_body   = C(q) b_orbit(tau),        tau = orbit_time_0 + t

``omega`` is the inertial body rate in body axes, ``q = [q1 q2 q3 q4]`` (q4 scalar) the
attitude of the body with respect to the orbit frame, ``W`` the seed's matrix, ``C(q)`` the
orbit-to-body rotation and ``n = 2 pi / orbit_period`` the orbit rate. The orbit frame is
o1 along the velocity, o2 against the orbit normal, o3 to nadir (a circular orbit rotates
it about -o2 at rate n). The dipole is clipped per axis at ``m_max`` when ``saturation_on``.

The quaternion is renormalized after every integration substep (``renormalize``, on by
default); the state ``q_norm_drift`` keeps the largest ``| |q| - 1 |`` met before a
renormalization (with it off: the accumulated drift), and the output of the same name
reports it.

Field ``b_orbit`` (T, orbit frame), by the Integer parameter ``field_model``:

0. the seed's Fourier fit in orbit time (period ``orbit_period``), coefficients
   ``field_x[1..5]`` etc. for [1, sin, cos, sin 2, cos 2] of ``2 pi tau / orbit_period``,
   defaulting to the seed's values with the by constant read as -3.4927 uT (the seed prints
   -34927: a misplaced decimal, an inference; docs/models.md). A Fourier fit of another field
   (IGRF, :func:`satfmu.fmus.environment.geomagnetic.fourier_fit`) loads into the same parameters.
1. a tilted dipole, ``b = (M / r^3) (3 (m.r) r - m)``, on a circular orbit of the given
   altitude, inclination, RAAN and initial argument of latitude, with the Earth rotating
   under it (:func:`dipole_field_orbit`).
2. external: the inputs ``b_ext[1..3]`` (an IGRF profile from :mod:`satfmu.fmus.environment.geomagnetic`
   through the master, or any measured field).

Inertia diag(0.005, 0.005, 0.002) kg m^2 (the seed's).
"""
from __future__ import annotations

import sympy as sp

from typing import TYPE_CHECKING

from satfmu.fmus.model import Model, Output, State, Variable, saturate, states, symbols, vector
from satfmu.fmus.environment.dipole import dipole_field
from satfmu.fmus.errors import SpacecraftError

if TYPE_CHECKING:
    from satfmu.fmus.plants.spacecraft import Spacecraft

INERTIA_SEED_003 = (0.005, 0.005, 0.002)
"""Principal moments of inertia of seed 003, kg m^2."""

FIELD_FOURIER_SEED = {
    "x": (10.7150, 2.4674, 4.1390, -9.7118, 11.5496),
    "y": (-3.4927, 5.9779, 42.7726, -1.8465, 1.0177),
    "z": (1.2491, 48.5761, 20.594, -3.7489, 11.5496),
}
"""Seed 003's Fourier fit of the field in the orbit frame, uT, for [1, S1, C1, S2, C2]; the by
constant read as -3.4927 (printed -34927)."""

FOURIER_TERMS = ("constant", "sin(2 pi tau/T)", "cos(2 pi tau/T)", "sin(4 pi tau/T)", "cos(4 pi tau/T)")

ORBIT_PERIOD_SEED = 5400.0
"""The seed's field period, s (90 min)."""

EARTH_RADIUS = 6371.2e3
"""Reference radius of the geomagnetic field models, m (IGRF)."""

EARTH_RATE = 7.2921159e-5
"""Earth's sidereal rotation rate, rad/s."""

DIPOLE_MOMENT = 7.69e15
"""Dipole constant M of b = (M/r^3)(3 (m.r) r - m), T m^3 (**substitute**, docs/models.md)."""

DIPOLE_POLE = (0.1641, -1.2686)
"""Colatitude and longitude of the north geomagnetic pole, rad (IGRF-13 at 2020: 80.6 N,
72.7 W); the dipole moment points the other way (**substitute**: the seed gives no tilt)."""

INCLINATION_SEED = 1.5184364492350666
"""The seed's orbit inclination, 87 deg in rad."""


def quaternion_rotation(q: sp.Matrix) -> sp.Matrix:
    """Rotation matrix C(q) (orbit to body) of the quaternion ``[q1 q2 q3 q4]``, q4 scalar.

    For a unit quaternion C is orthogonal; with the seed's W, ``dC/dt = -[omega_bo x] C``.

    Parameters
    ----------
    q : sympy.Matrix
        The quaternion ``[q1, q2, q3, q4]`` (4 elements, 1), vector part first, q4 scalar.

    Returns
    -------
    sympy.Matrix
        The 3 x 3 orbit-to-body rotation matrix (equal to the rotation for a unit quaternion).
    """
    v, s = sp.Matrix(q[:3]), q[3]
    return (s**2 - (v.T * v)[0]) * sp.eye(3) + 2 * v * v.T - 2 * s * _skew(v)


def kinematics_matrix(w: sp.Matrix) -> sp.Matrix:
    """The seed's W(omega) of q' = (1/2) W(omega) q (eq. 6).

    Parameters
    ----------
    w : sympy.Matrix
        The body rate ``omega`` relative to the orbit frame, 3 components in body axes, rad/s.

    Returns
    -------
    sympy.Matrix
        The 4 x 4 matrix W(omega).
    """
    wx, wy, wz = w
    return sp.Matrix([[0, wz, -wy, wx], [-wz, 0, wx, wy], [wy, -wx, 0, wz], [-wx, -wy, -wz, 0]])


def _skew(a: sp.Matrix) -> sp.Matrix:
    return sp.Matrix([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])


def _rot1(a: sp.Expr) -> sp.Matrix:
    """Frame rotation about axis 1 by ``a``: the components of a fixed vector in the new frame."""
    return sp.Matrix([[1, 0, 0], [0, sp.cos(a), sp.sin(a)], [0, -sp.sin(a), sp.cos(a)]])


def _rot3(a: sp.Expr) -> sp.Matrix:
    return sp.Matrix([[sp.cos(a), sp.sin(a), 0], [-sp.sin(a), sp.cos(a), 0], [0, 0, 1]])


def orbit_frame(u: sp.Expr, inclination: sp.Expr, raan: sp.Expr) -> tuple[sp.Matrix, sp.Matrix]:
    """Unit position and the orbit-frame rotation of a circular orbit at argument of latitude ``u``.

    Returns ``(r_hat, C_oi)``: the position direction in inertial (ECI) axes and the matrix
    whose rows are the orbit axes o1 (velocity), o2 (-normal), o3 (nadir) in ECI.

    Parameters
    ----------
    u : sympy.Expr
        Argument of latitude (angle from the ascending node along the orbit), rad.
    inclination : sympy.Expr
        Orbit inclination, rad.
    raan : sympy.Expr
        Right ascension of the ascending node, rad.

    Returns
    -------
    r_hat : sympy.Matrix
        Unit position vector (3 x 1) in ECI axes.
    C_oi : sympy.Matrix
        3 x 3 rotation from ECI to the orbit frame.
    """
    to_eci = (_rot1(inclination) * _rot3(raan)).T  # perifocal-like orbit plane -> ECI
    r_hat = to_eci * sp.Matrix([sp.cos(u), sp.sin(u), 0])
    v_hat = to_eci * sp.Matrix([-sp.sin(u), sp.cos(u), 0])
    h_hat = to_eci * sp.Matrix([0, 0, 1])
    return r_hat, sp.Matrix.vstack(v_hat.T, -h_hat.T, -r_hat.T)


def dipole_field_orbit(tau: sp.Expr, p: dict[str, sp.Expr]) -> sp.Matrix:
    """Tilted-dipole field in the orbit frame, T, at orbit time ``tau`` (s).

    ``p`` maps the names ``dipole_moment, dipole_colatitude, dipole_longitude,
    orbit_altitude, orbit_inclination, orbit_raan, orbit_arg_latitude_0,
    earth_rotation_angle_0, orbit_period`` to expressions (symbols or numbers). The pole
    direction rotates with the Earth (angle ``earth_rotation_angle_0 + EARTH_RATE tau`` about
    the ECI z axis); the moment points from the north geomagnetic pole to the south one.

    Parameters
    ----------
    tau : sympy.Expr
        Orbit time (``orbit_time_0 + t``), s.
    p : dict of str to sympy.Expr
        The orbit and dipole parameters named above: ``dipole_moment`` (T m^3),
        ``dipole_colatitude``, ``dipole_longitude`` (rad), ``orbit_altitude`` (m),
        ``orbit_inclination``, ``orbit_raan``, ``orbit_arg_latitude_0``,
        ``earth_rotation_angle_0`` (rad) and ``orbit_period`` (s).

    Returns
    -------
    sympy.Matrix
        The field (3 x 1) along the orbit axes o1, o2, o3, T.
    """
    n = 2 * sp.pi / p["orbit_period"]
    u = p["orbit_arg_latitude_0"] + n * tau
    r_hat, C_oi = orbit_frame(u, p["orbit_inclination"], p["orbit_raan"])
    b_eci = dipole_field(r_hat, EARTH_RADIUS + p["orbit_altitude"], p["earth_rotation_angle_0"] + EARTH_RATE * tau,
                         p["dipole_moment"], p["dipole_colatitude"], p["dipole_longitude"])
    return C_oi * b_eci


def principal_moments(spacecraft: "Spacecraft | None") -> tuple[float, float, float]:
    """``(I_x, I_y, I_z)`` of a spacecraft whose body axes are principal (default seed 003's), kg m^2.

    Parameters
    ----------
    spacecraft : Spacecraft or None
        The spacecraft (:class:`satfmu.fmus.plants.spacecraft.Spacecraft`); None gives seed 003's
        :data:`INERTIA_SEED_003`.

    Returns
    -------
    tuple of float
        The three principal moments of inertia, kg m^2.

    Raises
    ------
    satfmu.fmus.errors.SpacecraftError
        If the spacecraft has products of inertia: this model is written in principal axes.
    """
    if spacecraft is None:
        return INERTIA_SEED_003
    J = spacecraft.inertia
    if any(J[i][j] != 0.0 for i in range(3) for j in range(3) if i != j):
        raise SpacecraftError(f"{spacecraft.name}: the magnetorquer cubesat model is written in principal axes; "
                         f"give the inertia as three principal moments (no products of inertia)")
    return (J[0][0], J[1][1], J[2][2])


def build(omega_0: tuple[float, float, float] = (0.05, -0.04, 0.03), spacecraft: "Spacecraft | None" = None
          ) -> Model:
    """The symbolic magnetorquer cubesat model.

    Parameters
    ----------
    omega_0 : 3 floats
        Default initial body rate, rad/s (the issue's **substitute** tumbling rate; the seed
        gives none).
    spacecraft : satfmu.fmus.plants.spacecraft.Spacecraft, optional
        Its principal moments (no products of inertia) give the defaults of ``I_x, I_y,
        I_z`` (default seed 003's); its torque limit does not apply (the actuators are
        magnetorquers, limited by ``m_max``).
    """
    inertia = [Variable(f"I_{a}", "kg.m2", f"Principal moment of inertia about body axis {a}", start=v, min=1e-9)
               for a, v in zip("xyz", principal_moments(spacecraft))]
    field_model = Variable("field_model", "1", "Field model: 0 Fourier fit (field_x/y/z), 1 tilted dipole, "
                           "2 external inputs b_ext", 0, "Integer", min=0, max=2)
    fourier = {a: vector(f"field_{a}", 5, "T", f"Fourier coefficient {{i}} of b_orbit {a} (terms "
                         + ", ".join(FOURIER_TERMS) + ")", [c * 1e-6 for c in FIELD_FOURIER_SEED[a]])
               for a in "xyz"}
    orbit = [
        Variable("orbit_period", "s", "Orbit period T (orbit rate n = 2 pi / T); the Fourier field's period",
                 ORBIT_PERIOD_SEED, min=1.0),
        Variable("orbit_time_0", "s", "Orbit time at t = 0 (phase of the field and of the orbit)", 0.0),
        Variable("orbit_altitude", "m", "Altitude of the circular orbit above 6371.2 km (dipole field)",
                 500e3, min=0.0),
        Variable("orbit_inclination", "rad", "Orbit inclination (dipole field)", INCLINATION_SEED),
        Variable("orbit_raan", "rad", "Right ascension of the ascending node (dipole field)", 0.0),
        Variable("orbit_arg_latitude_0", "rad", "Argument of latitude at orbit time 0 (dipole field)", 0.0),
        Variable("earth_rotation_angle_0", "rad", "Earth rotation angle (ECEF vs ECI) at orbit time 0", 0.0),
        Variable("dipole_moment", "T.m3", "Dipole constant M of b = M/r^3 (3 (m.r) r - m)", DIPOLE_MOMENT, min=0.0),
        Variable("dipole_colatitude", "rad", "Colatitude of the north geomagnetic pole (dipole tilt)",
                 DIPOLE_POLE[0]),
        Variable("dipole_longitude", "rad", "East longitude of the north geomagnetic pole", DIPOLE_POLE[1]),
    ]
    sat_on = Variable("saturation_on", "1", "Clip each dipole component at +-m_max", 0, "Boolean")
    m_max = Variable("m_max", "A.m2", "Magnetorquer dipole limit per axis (when saturation_on)", 0.2, min=0.0)
    renorm = Variable("renormalize", "1", "Renormalize the quaternion after every integration substep",
                      1, "Boolean")
    xw = states("omega", 3, "rad/s", "inertial body rate about body axis {i}", omega_0)
    xq = states("q", 4, "1", "attitude quaternion component {i} (body w.r.t. orbit frame, q4 scalar)",
                (0.0, 0.0, 0.0, 1.0))
    xd = [State(Variable("q_norm_drift", "1", "Largest | |q| - 1 | before a renormalization"),
                Variable("q_norm_drift_0", "1", "Initial value of the quaternion norm drift record", 0.0,
                         min=0.0))]
    m_in = vector("m", 3, "A.m2", "Commanded magnetic dipole along body axis {i}")
    td = vector("T_d", 3, "N.m", "Disturbance torque about body axis {i}")
    b_ext = vector("b_ext", 3, "T", "External field along orbit axis {i} (used when field_model = 2)")

    w, q, drift = symbols(xw), symbols(xq), xd[0].symbol
    P = {v.name: v.symbol for v in orbit}
    tau = P["orbit_time_0"] + Model.t
    phase = 2 * sp.pi * tau / P["orbit_period"]
    basis = [1, sp.sin(phase), sp.cos(phase), sp.sin(2 * phase), sp.cos(2 * phase)]
    b_fourier = sp.Matrix([sum(c.symbol * f for c, f in zip(fourier[a], basis)) for a in "xyz"])
    b_dipole = dipole_field_orbit(tau, P)
    fm = field_model.symbol
    b_orbit = sp.Matrix([sp.Piecewise((bf, fm < sp.Rational(1, 2)), (bd, fm < sp.Rational(3, 2)), (be, True))
                         for bf, bd, be in zip(b_fourier, b_dipole, symbols(b_ext))])
    C = quaternion_rotation(q)
    b_body = C * b_orbit
    m_applied = sp.Matrix([saturate(mi, m_max.symbol, sat_on.symbol) for mi in symbols(m_in)])
    J = sp.diag(*(v.symbol for v in inertia))
    torque = m_applied.cross(b_body)
    omega_dot = J.inv() * (-w.cross(J * w) + torque + symbols(td))
    n = 2 * sp.pi / P["orbit_period"]
    w_bo = w - C * sp.Matrix([0, -n, 0])
    q_dot = kinematics_matrix(w_bo) * q / 2

    norm = sp.sqrt((q.T * q)[0])
    on = renorm.symbol > sp.Rational(1, 2)
    post = sp.Matrix(list(w) + [sp.Piecewise((qi / norm, on), (qi, True)) for qi in q]
                     + [sp.Max(drift, sp.Abs(norm - 1))])

    outputs = ([Output(v.variable, v.symbol) for v in xw + xq + xd]
               + [Output(Variable(f"b_body[{i + 1}]", "T", f"Field along body axis {i + 1} (magnetometer)"),
                         b_body[i]) for i in range(3)]
               + [Output(Variable(f"b_orbit[{i + 1}]", "T", f"Field along orbit axis {i + 1}"), b_orbit[i])
                  for i in range(3)]
               + [Output(Variable(f"m_applied[{i + 1}]", "A.m2", f"Applied dipole along body axis {i + 1}"),
                         m_applied[i]) for i in range(3)]
               + [Output(Variable(f"omega_bo[{i + 1}]", "rad/s", f"Body rate relative to the orbit frame, axis "
                                  f"{i + 1}"), w_bo[i]) for i in range(3)]
               + [Output(Variable("rate_norm", "rad/s", "|omega|"), sp.sqrt((w.T * w)[0])),
                  Output(Variable("attitude_angle", "rad", "Rotation angle of the body from the orbit frame"),
                         2 * sp.acos(sp.Min(1, sp.Abs(q[3]) / norm)))])
    return Model(
        name="magnetorquer_cubesat",
        description="Cubesat with three magnetorquers, quaternion attitude w.r.t. the orbit frame, "
                    "Fourier / tilted-dipole / external field (seed 003: periodic H-infinity detumbling)",
        states=xw + xq + xd, inputs=m_in + td + b_ext,
        parameters=inertia + [field_model] + fourier["x"] + fourier["y"] + fourier["z"] + orbit
        + [sat_on, m_max, renorm],
        outputs=outputs, rhs=sp.Matrix(list(omega_dot) + list(q_dot) + [0]), post_step=post,
        default_stop_time=2 * ORBIT_PERIOD_SEED, default_step_size=1.0, default_h_max=0.5)


MODEL = build()
