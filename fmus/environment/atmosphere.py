"""Atmospheric density above a spherical Earth: exponential models as sympy expressions.

- :data:`VALLADO_TABLE`: the piecewise exponential model of Vallado (Fundamentals of
  Astrodynamics and Applications, Table 8-4): in each altitude band ``[h0, h1)`` the density is
  ``rho0 exp(-(h - h0) / H)``; below 0 km the first band's law, above 1000 km the last one's.
- :func:`single_exponential`: one band, ``rho0 exp(-(h - h0) / H)`` at every altitude
  (Basilisk's ``exponentialAtmosphere``).

Both are mean-solar-activity models: the thermosphere's density varies several-fold with solar
and geomagnetic activity, which these do not follow (NRLMSIS does).
"""
from __future__ import annotations

import sympy as sp

VALLADO_TABLE = (
    (0.0, 1.225, 7.249), (25.0, 3.899e-2, 6.349), (30.0, 1.774e-2, 6.682), (40.0, 3.972e-3, 7.554),
    (50.0, 1.057e-3, 8.382), (60.0, 3.206e-4, 7.714), (70.0, 8.770e-5, 6.549), (80.0, 1.905e-5, 5.799),
    (90.0, 3.396e-6, 5.382), (100.0, 5.297e-7, 5.877), (110.0, 9.661e-8, 7.263), (120.0, 2.438e-8, 9.473),
    (130.0, 8.484e-9, 12.636), (140.0, 3.845e-9, 16.149), (150.0, 2.070e-9, 22.523), (180.0, 5.464e-10, 29.740),
    (200.0, 2.789e-10, 37.105), (250.0, 7.248e-11, 45.546), (300.0, 2.418e-11, 53.628), (350.0, 9.518e-12, 53.298),
    (400.0, 3.725e-12, 58.515), (450.0, 1.585e-12, 60.828), (500.0, 6.967e-13, 63.822), (600.0, 1.454e-13, 71.835),
    (700.0, 3.614e-14, 88.667), (800.0, 1.170e-14, 124.64), (900.0, 5.245e-15, 181.05), (1000.0, 3.019e-15, 268.00),
)
"""Vallado's exponential model: (base altitude, km; density there, kg/m^3; scale height, km) per band."""


def single_exponential(h: sp.Expr, rho0: sp.Expr, h0: sp.Expr, scale_height: sp.Expr) -> sp.Expr:
    """``rho0 exp(-(h - h0) / scale_height)``, kg/m^3.

    Parameters
    ----------
    h : sympy.Expr
        Altitude, m.
    rho0 : sympy.Expr
        Density at ``h0``, kg/m^3.
    h0 : sympy.Expr
        Base altitude, m.
    scale_height : sympy.Expr
        Scale height, m.

    Returns
    -------
    sympy.Expr
        The density, kg/m^3.
    """
    return rho0 * sp.exp(-(h - h0) / scale_height)


def vallado(h: sp.Expr) -> sp.Expr:
    """The density of :data:`VALLADO_TABLE` at altitude ``h`` (m), kg/m^3: the band's base altitude,
    density and scale height chosen by Piecewise, then one exponential (whose argument stays small:
    no constant beyond double range).

    Parameters
    ----------
    h : sympy.Expr
        Altitude, m (a symbol, or an expression evaluated once).

    Returns
    -------
    sympy.Expr
        The density, kg/m^3.
    """
    def band(column: int, scale: float) -> sp.Expr:
        pieces = [(sp.Float(row[column] * scale), h < sp.Float(nxt[0] * 1e3))
                  for row, nxt in zip(VALLADO_TABLE, VALLADO_TABLE[1:])]
        return sp.Piecewise(*pieces, (sp.Float(VALLADO_TABLE[-1][column] * scale), True))

    return single_exponential(h, band(1, 1.0), band(0, 1e3), band(2, 1e3))


def vallado_band(h: float) -> tuple[float, float, float]:
    """The band of :data:`VALLADO_TABLE` that holds altitude ``h``, in SI units: what
    :func:`vallado` evaluates there (and what one exponential, such as Basilisk's
    ``exponentialAtmosphere``, needs to give the same density in that band).

    Parameters
    ----------
    h : float
        Altitude, m.

    Returns
    -------
    tuple of float
        The band's base altitude (m), its density there (kg/m^3) and its scale height (m).
    """
    row = VALLADO_TABLE[0]
    for candidate in VALLADO_TABLE[1:]:
        if h < candidate[0] * 1e3:
            break
        row = candidate
    return row[0] * 1e3, row[1], row[2] * 1e3
