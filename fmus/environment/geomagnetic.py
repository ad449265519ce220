"""IGRF field along the cubesat's circular orbit, in the orbit frame, and its Fourier fit.

The orbit geometry is the magnetorquer cubesat's own (:func:`satfmu.fmus.plants.cubesat.orbit_frame`,
lambdified here, never re-derived): argument of latitude ``u = orbit_arg_latitude_0 +
2 pi tau / orbit_period`` at orbit time ``tau`` (s), the Earth turned by ``earth_rotation_angle_0
+ EARTH_RATE tau`` about the ECI z axis, orbit axes o1 (velocity), o2 (-normal), o3 (nadir).

The field is IGRF through ppigrf (its default coefficient file, IGRF-14: 1900-2030, the last
five years a secular-variation forecast), evaluated GEOCENTRICALLY on a spherical Earth:
radius ``EARTH_RADIUS + orbit_altitude`` (6371.2 km, the IGRF reference radius, plus the
altitude), no ellipsoid. The coefficients are taken at the fixed ``epoch`` for the whole
arc (secular variation is ~0.01 nT per orbit). ``earth_rotation_angle_0`` is a free
parameter: it is NOT derived from the epoch (set it to the Greenwich sidereal angle of the
epoch for a real ground track).

A least-squares fit of one orbit of field (:func:`fourier_fit`) gives the cubesat's
``field_x/y/z[1..5]`` parameters (``field_model = 0``); the profile kind ``igrf`` of
:mod:`satfmu.fmus.profiles` feeds the field itself to the ``b_ext`` inputs (``field_model = 2``).
"""
from __future__ import annotations

import datetime as _dt
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from functools import cache

import numpy as np
import sympy as sp

from satfmu.fmus.plants.cubesat import (
    EARTH_RADIUS,
    EARTH_RATE,
    FIELD_FOURIER_SEED,
    MODEL,
    orbit_frame,
)

ORBIT_PARAMETERS = ("orbit_period", "orbit_altitude", "orbit_inclination", "orbit_raan",
                    "orbit_arg_latitude_0", "earth_rotation_angle_0")
"""The cubesat parameters that define the orbit geometry (orbit time ``tau`` is separate)."""

FOURIER_AXES = "xyz"
_CHUNK = 10_000  # points per ppigrf call: its design matrices are (points x 390) doubles
_POLE_GUARD_DEG = 1e-10  # colatitude kept this far from the poles (ppigrf divides B_phi by sin(theta)):
# ~2e-12 rad: a relative field error of ~3e-12 exactly over a pole, none elsewhere


def model_defaults() -> dict[str, float]:
    """Start values of every cubesat parameter, by name (SI units, as in ``satfmu.fmus.plants.cubesat.MODEL``)."""
    return {v.name: float(v.start) for v in MODEL.parameters}


def orbit_parameters(params: Mapping[str, float] | None = None) -> dict[str, float]:
    """The orbit parameters (:data:`ORBIT_PARAMETERS`), the model's defaults overridden by ``params``.

    Parameters
    ----------
    params : mapping, optional
        Cubesat parameter names to values (s, m, rad). Other cubesat parameters (e.g.
        ``orbit_time_0``) are accepted and ignored; names the model does not have are rejected.

    Raises
    ------
    ValueError
        Unknown name, non-finite value, ``orbit_period <= 0`` or ``orbit_altitude < 0``.
    """
    defaults = model_defaults()
    params = dict(params or {})
    unknown = sorted(set(params) - set(defaults))
    if unknown:
        raise ValueError(f"unknown cubesat parameter(s) {unknown}; orbit parameters are {list(ORBIT_PARAMETERS)}")
    out = {}
    for name in ORBIT_PARAMETERS:
        v = params.get(name, defaults[name])
        if isinstance(v, bool) or not isinstance(v, (int, float, np.floating, np.integer)) or not np.isfinite(v):
            raise ValueError(f"{name} must be a finite number, got {v!r}")
        out[name] = float(v)
    if out["orbit_period"] <= 0:
        raise ValueError(f"orbit_period must be > 0 s, got {out['orbit_period']}")
    if out["orbit_altitude"] < 0:
        raise ValueError(f"orbit_altitude must be >= 0 m, got {out['orbit_altitude']}")
    return out


@cache
def _orbit_frame_numeric() -> Callable[..., list]:
    """``satfmu.fmus.plants.cubesat.orbit_frame`` lambdified in (tau, orbit parameters): 3 + 9 expressions."""
    tau = sp.Symbol("tau", real=True)
    p = {name: sp.Symbol(name, real=True) for name in ORBIT_PARAMETERS}
    u = p["orbit_arg_latitude_0"] + 2 * sp.pi * tau / p["orbit_period"]  # as in dipole_field_orbit
    r_hat, c_oi = orbit_frame(u, p["orbit_inclination"], p["orbit_raan"])
    return sp.lambdify([tau, *p.values()], list(r_hat) + list(c_oi), "numpy")


def _as_tau(tau: np.ndarray | float) -> np.ndarray:
    t = np.atleast_1d(np.asarray(tau, float))
    if t.ndim != 1:
        raise ValueError(f"tau must be a scalar or a 1-D array, got shape {t.shape}")
    if not np.all(np.isfinite(t)):
        raise ValueError("tau must be finite")
    return t


def orbit_geometry(tau: np.ndarray | float, params: Mapping[str, float] | None = None
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Position direction and orbit-frame rotation of the cubesat's circular orbit.

    Parameters
    ----------
    tau : float or (n,) array
        Orbit times, s.
    params : mapping, optional
        Cubesat parameters (see :func:`orbit_parameters`); defaults are the model's.

    Returns
    -------
    r_hat : (n, 3) array
        Unit position vector in ECI axes, 1.
    c_oi : (n, 3, 3) array
        ECI-to-orbit rotation: rows o1 (velocity), o2 (-orbit normal), o3 (nadir) in ECI, 1.
    """
    t = _as_tau(tau)
    p = orbit_parameters(params)
    vals = _orbit_frame_numeric()(t, *(p[name] for name in ORBIT_PARAMETERS))
    flat = np.stack([np.broadcast_to(np.asarray(v, float), t.shape) for v in vals], axis=-1)
    return flat[:, :3], flat[:, 3:].reshape(-1, 3, 3)


def _rot3(angle: np.ndarray) -> np.ndarray:
    """Frame rotations about z by ``angle`` (n,): ECI components -> ECEF components, (n, 3, 3)."""
    c, s = np.cos(angle), np.sin(angle)
    z, o = np.zeros_like(angle), np.ones_like(angle)
    return np.stack([np.stack([c, s, z], -1), np.stack([-s, c, z], -1), np.stack([z, z, o], -1)], -2)


def epoch_datetime(epoch: _dt.datetime | _dt.date) -> _dt.datetime:
    """``epoch`` as a naive UTC datetime (a date: its midnight; an aware datetime: converted).

    Parameters
    ----------
    epoch : datetime.datetime or datetime.date
        The epoch of the field coefficients; a naive datetime is taken as UTC.

    Returns
    -------
    datetime.datetime
        The naive UTC datetime.

    Raises
    ------
    ValueError
        If ``epoch`` is neither a datetime nor a date.
    """
    if isinstance(epoch, _dt.datetime):
        if epoch.tzinfo is not None:
            epoch = epoch.astimezone(_dt.UTC).replace(tzinfo=None)
        return epoch
    if isinstance(epoch, _dt.date):
        return _dt.datetime(epoch.year, epoch.month, epoch.day)
    raise ValueError(f"epoch must be a datetime or a date, got {epoch!r}")


@cache
def igrf_validity() -> tuple[_dt.datetime, _dt.datetime]:
    """First and last epoch of ppigrf's default IGRF coefficient file."""
    from ppigrf import ppigrf as _ppigrf

    g, _ = _ppigrf.read_shc(_ppigrf.shc_fn)
    return g.index[0].to_pydatetime(), g.index[-1].to_pydatetime()


def igrf_orbit_field(tau: np.ndarray | float, epoch: _dt.datetime | _dt.date,
                     params: Mapping[str, float] | None = None, max_degree: int = 13) -> np.ndarray:
    """IGRF field along the circular orbit, in the orbit frame.

    Parameters
    ----------
    tau : float or (n,) array
        Orbit times, s.
    epoch : datetime or date
        Date of the IGRF coefficients (UTC; time-zone aware values are converted), held for the
        whole arc. Must lie within :func:`igrf_validity`.
    params : mapping, optional
        Cubesat orbit parameters (see :func:`orbit_parameters`); defaults are the model's.
    max_degree : int
        Highest spherical-harmonic degree, 1..13 (1: the centred tilted dipole).

    Returns
    -------
    (n, 3) array
        Field along o1, o2, o3, T. Geocentric, spherical Earth of radius ``EARTH_RADIUS``.

    Raises
    ------
    ValueError
        Bad ``tau``, parameters, ``max_degree`` or an epoch outside the coefficient file.
    """
    from ppigrf import igrf_gc

    t = _as_tau(tau)
    p = orbit_parameters(params)
    if isinstance(max_degree, bool) or not isinstance(max_degree, (int, np.integer)) or not 1 <= max_degree <= 13:
        raise ValueError(f"max_degree must be an integer in 1..13, got {max_degree!r}")
    date = epoch_datetime(epoch)
    first, last = igrf_validity()
    if not first <= date <= last:
        raise ValueError(f"epoch {date:%Y-%m-%d} is outside the IGRF coefficients "
                         f"({first:%Y-%m-%d} to {last:%Y-%m-%d})")

    r_hat, c_oi = orbit_geometry(t, p)
    to_ecef = _rot3(p["earth_rotation_angle_0"] + EARTH_RATE * t)
    x = np.einsum("nij,nj->ni", to_ecef, r_hat)  # ECEF unit position
    theta = np.clip(np.degrees(np.arctan2(np.hypot(x[:, 0], x[:, 1]), x[:, 2])), _POLE_GUARD_DEG, 180 - _POLE_GUARD_DEG)
    phi = np.degrees(np.arctan2(x[:, 1], x[:, 0]))
    radius_km = (EARTH_RADIUS + p["orbit_altitude"]) / 1e3
    sph = np.empty((t.size, 3))  # (B_r, B_theta (south), B_phi (east)), nT
    for k in range(0, t.size, _CHUNK):
        sl = slice(k, k + _CHUNK)
        sph[sl] = np.stack([b[0] for b in igrf_gc(radius_km, theta[sl], phi[sl], date, max_degree=max_degree)], -1)
    th, ph = np.radians(theta), np.radians(phi)
    st, ct, sp_, cp = np.sin(th), np.cos(th), np.sin(ph), np.cos(ph)
    e_r = np.stack([st * cp, st * sp_, ct], -1)
    e_theta = np.stack([ct * cp, ct * sp_, -st], -1)
    e_phi = np.stack([-sp_, cp, np.zeros_like(ph)], -1)
    b_ecef = 1e-9 * (sph[:, :1] * e_r + sph[:, 1:2] * e_theta + sph[:, 2:] * e_phi)
    b_eci = np.einsum("nji,nj->ni", to_ecef, b_ecef)
    return np.einsum("nij,nj->ni", c_oi, b_eci)


def fourier_basis(tau: np.ndarray, period: float) -> np.ndarray:
    """The cubesat's Fourier terms [1, sin, cos, sin 2, cos 2] of ``2 pi tau / period``, (n, 5).

    Parameters
    ----------
    tau : numpy.ndarray, shape (n,)
        Orbit times, s.
    period : float
        Period of the terms, s (the cubesat's ``orbit_period``).

    Returns
    -------
    numpy.ndarray, shape (n, 5)
        The five terms at each time.
    """
    w = 2 * np.pi * np.asarray(tau, float) / period
    return np.stack([np.ones_like(w), np.sin(w), np.cos(w), np.sin(2 * w), np.cos(2 * w)], -1)


@dataclass(frozen=True)
class FourierFit:
    """Least-squares fit of a field to the cubesat's Fourier terms.

    Attributes
    ----------
    coefficients : (3, 5) array
        Rows x, y, z (orbit axes); columns [1, S1, C1, S2, C2]; T.
    period : float
        Period of the terms, s (the cubesat's ``orbit_period``).
    rms_residual : float
        Root mean square of the residual vector's magnitude over the samples, T.
    max_residual : float
        Largest residual vector magnitude, T.
    """

    coefficients: np.ndarray
    period: float
    rms_residual: float
    max_residual: float

    def evaluate(self, tau: np.ndarray | float) -> np.ndarray:
        """The fitted field at orbit times ``tau`` (s), (n, 3), T.

        Parameters
        ----------
        tau : float or numpy.ndarray, shape (n,)
            Orbit times, s (a scalar is one time).

        Returns
        -------
        numpy.ndarray, shape (n, 3)
            The field along the orbit axes, T.
        """
        return fourier_basis(_as_tau(tau), self.period) @ self.coefficients.T

    def fmu_parameters(self, with_period: bool = True) -> dict[str, float]:
        """Cubesat FMU parameter overrides ``{"field_x[1]": ..., "field_z[5]": ...}`` (T).

        With ``with_period`` (default) also ``orbit_period``: the coefficients hold only with
        the period they were fitted for. Use with ``field_model = 0``.

        Parameters
        ----------
        with_period : bool, optional
            Include ``orbit_period`` (s), the fit's period. Default True.

        Returns
        -------
        dict of str to float
            The 15 coefficients (T), and the period (s) with ``with_period``.
        """
        out = {f"field_{a}[{i + 1}]": float(self.coefficients[k, i])
               for k, a in enumerate(FOURIER_AXES) for i in range(5)}
        if with_period:
            out["orbit_period"] = float(self.period)
        return out


def fourier_fit(tau: np.ndarray, b: np.ndarray, period: float) -> FourierFit:
    """Fit each field component to [1, sin, cos, sin 2, cos 2] of ``2 pi tau / period``.

    Parameters
    ----------
    tau : (n,) array
        Orbit times, s; at least 5 samples that determine all five terms.
    b : (n, 3) array
        Field in the orbit frame, T.
    period : float
        Period of the terms, s (> 0).

    Returns
    -------
    FourierFit

    Raises
    ------
    ValueError
        Non-finite data, wrong shapes, fewer than 5 samples, ``period <= 0``, or samples that
        do not determine the five terms (rank-deficient design, e.g. all at one phase).
    """
    t = np.asarray(tau, float)
    bb = np.asarray(b, float)
    if t.ndim != 1:
        raise ValueError(f"tau must be 1-D, got shape {t.shape}")
    if bb.shape != (t.size, 3):
        raise ValueError(f"b must have shape (len(tau), 3) = ({t.size}, 3), got {bb.shape}")
    if t.size < 5:
        raise ValueError(f"need at least 5 samples for 5 Fourier terms, got {t.size}")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(bb))):
        raise ValueError("tau and b must be finite (no NaN or inf)")
    if (isinstance(period, bool) or not isinstance(period, (int, float, np.integer, np.floating))
            or not np.isfinite(period) or period <= 0):
        raise ValueError(f"period must be a finite number > 0 s, got {period!r}")
    a = fourier_basis(t, float(period))
    coef, _, rank, _ = np.linalg.lstsq(a, bb, rcond=None)
    if rank < 5:
        raise ValueError(f"the samples determine only {rank} of the 5 Fourier terms (spread them over the period)")
    res = np.linalg.norm(bb - a @ coef, axis=1)
    return FourierFit(coef.T.copy(), float(period), float(np.sqrt(np.mean(res**2))), float(res.max()))


def seed_fourier_coefficients() -> np.ndarray:
    """Seed 003's Fourier coefficients (:data:`satfmu.fmus.plants.cubesat.FIELD_FOURIER_SEED`), (3, 5), T."""
    return 1e-6 * np.array([FIELD_FOURIER_SEED[a] for a in FOURIER_AXES], float)
