"""The model "orbit_environment": a spacecraft's orbit and what its environment is along it, as FMU outputs.

No state: every output is a closed-form function of the time. From the mean elements at the
epoch (``t = 0``), a Keplerian orbit whose node, perigee and mean anomaly drift at J2's secular
rates (``j2_on``):

    n = sqrt(mu / a^3), p = a (1 - e^2), k = J2 (R_E / p)^2
    raan'  = -3/2 n k cos i
    argp'  =  3/4 n k (5 cos^2 i - 1)
    M'     =  n (1 + 3/4 k sqrt(1 - e^2) (3 cos^2 i - 1))

Kepler's equation is solved by Newton's method from Danby's start (``E0 = M + 0.85 e sign(sin M)``),
:data:`KEPLER_ITERATIONS` steps (machine precision for ``e <= 0.9``, the parameter's bound). The
velocity is the exact time derivative of the position, drift included. Outputs, in the inertial
frame (the mean equator and equinox of J2000, to this model's accuracy):

- ``r``, ``v`` (m, m/s) and ``v_air`` (m/s): the velocity relative to an atmosphere turning with the
  Earth, ``v - omega_E z x r``;
- ``sun`` (unit vector from the spacecraft to the Sun) and ``sun_distance`` (m), from the Astronomical
  Almanac's low-precision solar coordinates (0.01 deg from 1950 to 2050);
- ``sunlit`` (1 lit, 0 in the umbra): a cylindrical shadow (``eclipse_model`` 0) or a conical one
  with the penumbra's fraction of the solar disc (1);
- ``b`` (T): the tilted-dipole geomagnetic field (:func:`satfmu.fmus.environment.dipole.dipole_field`),
  turning with the Earth rotation angle ``earth_angle`` (rad, from the epoch as UT1), and ``b_orbit``
  (T) along the orbit axes of the magnetorquer cubesat (its ``b_ext`` inputs, ``field_model = 2``);
- ``density`` (kg/m^3) at ``altitude`` (m, above a sphere of the equatorial radius): Vallado's
  piecewise exponential model (``density_model`` 0) or one exponential (1,
  :mod:`satfmu.fmus.environment.atmosphere`).

The epoch is ``epoch_j2000``: the seconds from 2000-01-01 12:00:00 UTC to the simulation time
``epoch_time`` (default 0, so the elements are those of ``t = 0``), UTC, taken as UT1 for the
Earth's rotation (within 0.9 s) and as TT for the Sun (69 s early: 0.0008 deg). A simulation that
starts at ``t0`` with the elements of its start sets ``epoch_time = t0``.
:func:`seconds_since_j2000`, :func:`circular` and :func:`from_tle` give the parameters.
"""
from __future__ import annotations

import datetime as _dt
import math
import sympy as sp

from satfmu.fmus.environment import atmosphere
from satfmu.fmus.environment.constants import (ASTRONOMICAL_UNIT, EQUATORIAL_RADIUS, ERA_RATE, J2, MU_EARTH,
                                               SUN_RADIUS)
from satfmu.fmus.environment.dipole import dipole_field
from satfmu.fmus.model import Model, Output, Variable

KEPLER_ITERATIONS = 8
"""Newton steps on Kepler's equation: from Danby's start, 8 reach machine precision up to e = 0.9."""
J2000 = _dt.datetime(2000, 1, 1, 12, 0, 0, tzinfo=_dt.timezone.utc)
"""The J2000 epoch, 2000-01-01 12:00:00 (taken as UTC)."""
DIPOLE_MOMENT = 7.69e15
"""Default dipole constant M, T m^3 (the magnetorquer cubesat's)."""
DIPOLE_POLE = (0.1641, -1.2686)
"""Default colatitude and east longitude of the north geomagnetic pole, rad (80.6 N, 72.7 W)."""


def seconds_since_j2000(when: _dt.datetime) -> float:
    """The ``epoch_j2000`` parameter of an instant: seconds from 2000-01-01 12:00:00 UTC.

    Parameters
    ----------
    when : datetime.datetime
        The instant; a naive datetime is taken as UTC.

    Returns
    -------
    float
        Seconds (leap seconds not counted).
    """
    if when.tzinfo is None:
        when = when.replace(tzinfo=_dt.timezone.utc)
    return (when - J2000).total_seconds()


DEFAULT_EPOCH = seconds_since_j2000(_dt.datetime(2027, 1, 1))
"""The default epoch, 2027-01-01 00:00:00 UTC, s from J2000."""


def circular(altitude: float, inclination_deg: float, raan_deg: float = 0.0, arg_latitude_deg: float = 0.0,
             epoch: _dt.datetime | None = None) -> dict[str, float]:
    """The parameters of a circular orbit.

    Parameters
    ----------
    altitude : float
        Altitude above the equatorial radius, m, > 0.
    inclination_deg : float
        Inclination, deg, in [0, 180].
    raan_deg : float, optional
        Right ascension of the ascending node, deg.
    arg_latitude_deg : float, optional
        Argument of latitude at the epoch, deg (the mean anomaly, with a perigee at the node).
    epoch : datetime.datetime, optional
        The epoch (default 2027-01-01 00:00:00 UTC).

    Returns
    -------
    dict of str to float
        ``semi_major_axis``, ``eccentricity``, ``inclination``, ``raan``, ``arg_perigee``,
        ``mean_anomaly_0`` and ``epoch_j2000``.

    Raises
    ------
    ValueError
        If the altitude or inclination is out of range or not finite.
    """
    if not (math.isfinite(altitude) and altitude > 0) or not (0.0 <= inclination_deg <= 180.0):
        raise ValueError(f"need an altitude > 0 m and an inclination in [0, 180] deg, got {altitude!r}, "
                         f"{inclination_deg!r}")
    return {"semi_major_axis": EQUATORIAL_RADIUS + altitude, "eccentricity": 0.0,
            "inclination": math.radians(inclination_deg), "raan": math.radians(raan_deg), "arg_perigee": 0.0,
            "mean_anomaly_0": math.radians(arg_latitude_deg),
            "epoch_j2000": DEFAULT_EPOCH if epoch is None else seconds_since_j2000(epoch)}


def from_tle(line1: str, line2: str) -> dict[str, float]:
    """The parameters from a two-line element set, read by ``sgp4`` (its epoch, its mean elements).

    The TLE's elements are SGP4's mean (Brouwer) elements; this model propagates them as
    Keplerian elements with J2's secular drift, which departs from SGP4 by kilometres per day:
    enough for the environment's torques, not for navigation.

    Parameters
    ----------
    line1, line2 : str
        The two lines.

    Returns
    -------
    dict of str to float
        As :func:`circular`.

    Raises
    ------
    ValueError
        If ``sgp4`` cannot read the lines.
    """
    from sgp4.api import Satrec

    if not (isinstance(line1, str) and isinstance(line2, str)):
        raise ValueError("a TLE is two lines of text")
    sat = Satrec.twoline2rv(line1, line2)
    if sat.error:
        raise ValueError(f"sgp4 cannot read the TLE (error {sat.error})")
    n = sat.no_kozai / 60.0  # rad/min -> rad/s
    if not (n > 0 and 0.0 <= sat.ecco < 0.9):
        raise ValueError(f"TLE: mean motion {n!r} rad/s and eccentricity {sat.ecco!r} out of this model's range")
    jd = sat.jdsatepoch + sat.jdsatepochF
    return {"semi_major_axis": (MU_EARTH / n**2) ** (1 / 3), "eccentricity": float(sat.ecco),
            "inclination": float(sat.inclo), "raan": float(sat.nodeo), "arg_perigee": float(sat.argpo),
            "mean_anomaly_0": float(sat.mo), "epoch_j2000": (jd - 2451545.0) * 86400.0}


def _rz(a: sp.Expr) -> sp.Matrix:
    return sp.Matrix([[sp.cos(a), -sp.sin(a), 0], [sp.sin(a), sp.cos(a), 0], [0, 0, 1]])


def _rx(a: sp.Expr) -> sp.Matrix:
    return sp.Matrix([[1, 0, 0], [0, sp.cos(a), -sp.sin(a)], [0, sp.sin(a), sp.cos(a)]])


def _norm(v: sp.Matrix) -> sp.Expr:
    return sp.sqrt((v.T * v)[0])


def _disc_overlap(a: sp.Expr, b: sp.Expr, c: sp.Expr) -> sp.Expr:
    """Fraction of a disc of angular radius ``a`` (the Sun) hidden by one of radius ``b`` (the
    Earth) at angular distance ``c`` (Montenbruck and Gill, Satellite Orbits, 3.4.2), for
    ``|a - b| < c < a + b``."""
    x = (c**2 + a**2 - b**2) / (2 * c)
    y = sp.sqrt(sp.Max(a**2 - x**2, 0))
    area = a**2 * sp.acos(sp.Max(-1, sp.Min(1, x / a))) + b**2 * sp.acos(sp.Max(-1, sp.Min(1, (c - x) / b))) - c * y
    return area / (sp.pi * a**2)


def build() -> Model:
    """The orbit and environment model (``orbit_environment``).

    Returns
    -------
    Model
        Parameters: the mean elements at the epoch, the epoch, ``j2_on``, the eclipse, dipole and
        density models; outputs as in the module's docstring.
    """
    t_epoch = Variable("epoch_time", "s", "Simulation time of the epoch, at which the mean elements and epoch_j2000 "
                       "hold (0: the elements are those of t = 0)", 0.0)
    t = Model.t - t_epoch.symbol  # time from the epoch
    a = Variable("semi_major_axis", "m", "Mean semi-major axis at the epoch", EQUATORIAL_RADIUS + 500e3, min=1.0)
    e = Variable("eccentricity", "1", "Mean eccentricity", 0.0, min=0.0, max=0.9)
    inc = Variable("inclination", "rad", "Inclination to the J2000 equator", math.radians(97.4), min=0.0, max=math.pi)
    raan = Variable("raan", "rad", "Right ascension of the ascending node at the epoch", 0.0)
    argp = Variable("arg_perigee", "rad", "Argument of perigee at the epoch", 0.0)
    m0 = Variable("mean_anomaly_0", "rad", "Mean anomaly at the epoch", 0.0)
    epoch = Variable("epoch_j2000", "s", "Epoch (t = epoch_time): seconds from 2000-01-01 12:00:00 UTC", DEFAULT_EPOCH)
    j2_on = Variable("j2_on", "1", "Drift the node, perigee and mean anomaly at J2's secular rates", 1, "Boolean")
    eclipse = Variable("eclipse_model", "1", "Shadow: 0 cylindrical, 1 conical with penumbra", 1, "Integer",
                       min=0, max=1)
    dip = [Variable("dipole_moment", "T.m3", "Dipole constant M of b = M/r^3 (3 (m.r) r - m)", DIPOLE_MOMENT,
                    min=0.0),
           Variable("dipole_colatitude", "rad", "Colatitude of the north geomagnetic pole", DIPOLE_POLE[0]),
           Variable("dipole_longitude", "rad", "East longitude of the north geomagnetic pole", DIPOLE_POLE[1])]
    dens_model = Variable("density_model", "1", "Density: 0 Vallado's piecewise exponential, 1 one exponential",
                          0, "Integer", min=0, max=1)
    dens = [Variable("density_0", "kg/m3", "Density at density_altitude_0 (density_model 1)", 6.967e-13, min=0.0),
            Variable("density_altitude_0", "m", "Base altitude of density_model 1", 500e3),
            Variable("scale_height", "m", "Scale height of density_model 1", 63.822e3, min=1.0)]

    A, E, I, W0, w0, M0 = (v.symbol for v in (a, e, inc, raan, argp, m0))
    n = sp.sqrt(MU_EARTH / A**3)
    k = j2_on.symbol * J2 * (EQUATORIAL_RADIUS / (A * (1 - E**2))) ** 2
    ci = sp.cos(I)
    raan_dot = -sp.Rational(3, 2) * n * k * ci
    argp_dot = sp.Rational(3, 4) * n * k * (5 * ci**2 - 1)
    m_dot = n * (1 + sp.Rational(3, 4) * k * sp.sqrt(1 - E**2) * (3 * ci**2 - 1))
    d = {name: sp.Symbol(f"d_{name}", real=True) for name in ("M", "raan_dot", "argp_dot", "m_dot")}
    defs: list[tuple[sp.Symbol, sp.Expr]] = [(d["raan_dot"], raan_dot), (d["argp_dot"], argp_dot),
                                             (d["m_dot"], m_dot)]
    M = M0 + d["m_dot"] * t
    defs.append((d["M"], sp.atan2(sp.sin(M), sp.cos(M))))  # in (-pi, pi]
    Ek = [sp.Symbol(f"d_E{j}", real=True) for j in range(KEPLER_ITERATIONS + 1)]
    defs.append((Ek[0], d["M"] + sp.Float(0.85) * E * sp.sign(sp.sin(d["M"]))))
    for j in range(KEPLER_ITERATIONS):
        defs.append((Ek[j + 1], Ek[j] - (Ek[j] - E * sp.sin(Ek[j]) - d["M"]) / (1 - E * sp.cos(Ek[j]))))
    En = Ek[-1]
    root = sp.sqrt(1 - E**2)
    e_dot = d["m_dot"] / (1 - E * sp.cos(En))
    Q = _rz(W0 + d["raan_dot"] * t) * _rx(I) * _rz(w0 + d["argp_dot"] * t)
    r_vec = Q * sp.Matrix([A * (sp.cos(En) - E), A * root * sp.sin(En), 0])
    rs = sp.Matrix([sp.Symbol(f"d_r{j}", real=True) for j in range(3)])
    defs += [(rs[j], r_vec[j]) for j in range(3)]
    z = sp.Matrix([0, 0, 1])
    h_hat = Q * z
    v_vec = (Q * sp.Matrix([-A * sp.sin(En) * e_dot, A * root * sp.cos(En) * e_dot, 0])
             + d["raan_dot"] * z.cross(rs) + d["argp_dot"] * h_hat.cross(rs))
    vs = sp.Matrix([sp.Symbol(f"d_v{j}", real=True) for j in range(3)])
    defs += [(vs[j], v_vec[j]) for j in range(3)]
    radius = sp.Symbol("d_radius", real=True)
    defs.append((radius, _norm(rs)))

    days = (epoch.symbol + t) / 86400
    era = 2 * sp.pi * (sp.Float("0.7790572732640") + sp.Float("1.00273781191135448") * days)
    deg = sp.pi / 180
    L = (sp.Float(280.460) + sp.Float(0.9856474) * days) * deg
    g = (sp.Float(357.528) + sp.Float(0.9856003) * days) * deg
    lam = L + (sp.Float(1.915) * sp.sin(g) + sp.Float(0.020) * sp.sin(2 * g)) * deg
    eps = (sp.Float(23.439) - sp.Float(4e-7) * days) * deg
    dist = (sp.Float(1.00014) - sp.Float(0.01671) * sp.cos(g) - sp.Float(0.00014) * sp.cos(2 * g)) * ASTRONOMICAL_UNIT
    sun_e = sp.Matrix([sp.Symbol(f"d_sun{j}", real=True) for j in range(3)])  # Earth -> Sun, m
    defs += [(sun_e[j], x) for j, x in enumerate(dist * sp.Matrix([sp.cos(lam), sp.cos(eps) * sp.sin(lam),
                                                                   sp.sin(eps) * sp.sin(lam)]))]
    to_sun = sun_e - rs
    sun_dist = sp.Symbol("d_sun_dist", real=True)
    defs.append((sun_dist, _norm(to_sun)))

    # cylindrical shadow: behind the Earth (r . s < 0) within its radius of the Earth-Sun line
    s_hat = sun_e / _norm(sun_e)
    along = (rs.T * s_hat)[0]
    cylinder = sp.Piecewise((0, sp.And(along < 0, (rs.T * rs)[0] - along**2 < EQUATORIAL_RADIUS**2)), (1, True))
    # conical: apparent radii of the Sun (a) and the Earth (b), their angular separation (c)
    a_s = sp.asin(sp.Min(1, SUN_RADIUS / sun_dist))
    b_e = sp.asin(sp.Min(1, EQUATORIAL_RADIUS / radius))
    cos_c = -(rs.T * to_sun)[0] / (radius * sun_dist)
    c_sep = sp.acos(sp.Max(-1, sp.Min(1, cos_c)))
    cone = sp.Piecewise((1, c_sep >= a_s + b_e),
                        (0, c_sep <= b_e - a_s),
                        (1 - (b_e / a_s) ** 2, c_sep <= a_s - b_e),  # annular: the Earth inside the solar disc
                        (1 - _disc_overlap(a_s, b_e, sp.Max(c_sep, sp.Float(1e-300))), True))
    sunlit = sp.Piecewise((cone, eclipse.symbol > sp.Rational(1, 2)), (cylinder, True))

    b_vec = dipole_field(rs / radius, radius, era, *(v.symbol for v in dip))
    alt = sp.Symbol("d_altitude", real=True)
    defs.append((alt, radius - EQUATORIAL_RADIUS))
    rho = sp.Piecewise((atmosphere.single_exponential(alt, *(v.symbol for v in dens)),
                        dens_model.symbol > sp.Rational(1, 2)), (atmosphere.vallado(alt), True))
    v_air = vs - ERA_RATE * z.cross(rs)

    def vec(base: str, unit: str, what: str, values: sp.Matrix) -> list[Output]:
        return [Output(Variable(f"{base}[{j + 1}]", unit, f"{what}, inertial axis {j + 1}"), values[j])
                for j in range(3)]

    # the orbit frame of the magnetorquer cubesat (o3 nadir, o2 against the orbit normal, o1 = o2 x o3:
    # the velocity's direction on a circular orbit), and the field along its axes
    o3 = -rs / radius
    h_vec = rs.cross(vs)
    o2 = -h_vec / _norm(h_vec)
    b_orbit = sp.Matrix([(o.T * b_vec)[0] for o in (o2.cross(o3), o2, o3)])
    outputs = (vec("r", "m", "Position", rs) + vec("v", "m/s", "Velocity", vs)
               + vec("v_air", "m/s", "Velocity relative to the atmosphere turning with the Earth", v_air)
               + vec("sun", "1", "Unit vector from the spacecraft to the Sun", to_sun / sun_dist)
               + [Output(Variable("sun_distance", "m", "Distance to the Sun"), sun_dist),
                  Output(Variable("sunlit", "1", "Fraction of the solar disc seen (0 umbra, 1 lit)"), sunlit)]
               + vec("b", "T", "Geomagnetic field (tilted dipole)", b_vec)
               + [Output(Variable(f"b_orbit[{j + 1}]", "T", f"Geomagnetic field along orbit axis {j + 1} (o1 "
                                  "along the velocity, o2 against the orbit normal, o3 nadir)"), b_orbit[j])
                  for j in range(3)]
               + [Output(Variable("density", "kg/m3", "Atmospheric density"), rho),
                  Output(Variable("altitude", "m", "Altitude above the equatorial radius"), alt),
                  Output(Variable("earth_angle", "rad", "Earth rotation angle (ECEF from inertial about z)"),
                         era)])
    return Model(name="orbit_environment",
                 description="Keplerian orbit with J2 secular drift, the Sun and the Earth's shadow, a tilted-dipole "
                             "geomagnetic field and an exponential atmosphere, in inertial axes",
                 states=[], inputs=[], parameters=[a, e, inc, raan, argp, m0, epoch, t_epoch, j2_on, eclipse, *dip,
                                                   dens_model, *dens],
                 outputs=outputs, definitions=defs, default_stop_time=5400.0, default_step_size=1.0)


MODEL = build()
