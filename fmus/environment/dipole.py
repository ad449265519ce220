"""The tilted-dipole geomagnetic field in inertial axes: one expression, shared by the magnetorquer
cubesat (:mod:`satfmu.fmus.plants.cubesat`) and the orbit and environment model
(:mod:`satfmu.fmus.environment.orbit`)."""
from __future__ import annotations

import sympy as sp


def dipole_field(r_hat: sp.Matrix, radius: sp.Expr, earth_angle: sp.Expr, moment: sp.Expr, colatitude: sp.Expr,
                 longitude: sp.Expr) -> sp.Matrix:
    """The tilted dipole's field in inertial axes, T.

    ``b = (M / |r|^3) (3 (m . r_hat) r_hat - m)``. The moment ``m`` points from the north
    geomagnetic pole to the south one; the pole (at ``colatitude`` and east ``longitude`` on the
    Earth) turns with the Earth, by ``earth_angle``
    about the inertial z axis.

    Parameters
    ----------
    r_hat : sympy.Matrix
        Unit position vector (3 x 1) in inertial axes.
    radius : sympy.Expr
        Distance from the Earth's centre, m.
    earth_angle : sympy.Expr
        Rotation angle of the Earth-fixed frame from the inertial one about z, rad.
    moment : sympy.Expr
        Dipole constant M, T m^3.
    colatitude, longitude : sympy.Expr
        Colatitude and east longitude of the north geomagnetic pole, rad.

    Returns
    -------
    sympy.Matrix
        The field (3 x 1) in inertial axes, T.
    """
    lon = longitude + earth_angle
    m_hat = -sp.Matrix([sp.sin(colatitude) * sp.cos(lon), sp.sin(colatitude) * sp.sin(lon), sp.cos(colatitude)])
    return moment / radius**3 * (3 * (m_hat.T * r_hat)[0] * r_hat - m_hat)
