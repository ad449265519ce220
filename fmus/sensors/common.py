"""What the sensor models share: sampling, seeded noise, error matrices, quantization, quaternions.

Every sensor is an expression sampler (:class:`satfmu.fmus.model.Sampler`): its measurement is
computed at the instants ``t_k = k * sample_period - sample_phase`` and held in between. The
noise of instant ``k`` is drawn by :class:`satfmu.fmus.noise.GaussianNoise` of ``(seed, k,
stream)``, so it depends on the seed and the instant only: not on the communication step, not on
how often an importer repeats or rolls back a step.

Quaternions are scalar last, ``q = (q1, q2, q3, q4)`` with ``q4 = cos(angle / 2)``, and attitude
``q`` of the body from the inertial frame has the direction cosine matrix ``C(q)``
(``v_B = C v_N``) of the MRP ``sigma = q_v / (1 + q4)``. The product ``q_a * q_b`` is the
attitude whose matrix is ``C(q_a) C(q_b)`` (first ``q_b``, then ``q_a``).
"""
from __future__ import annotations

import math

import sympy as sp

from satfmu.fmus.model import Model, Variable, time_tolerance, vector
from satfmu.fmus.noise import GaussianNoise

ARCSEC = math.pi / 180 / 3600
"""One arcsecond, rad (the unit of the star tracker's noise)."""
SEED_MAX = 2**31 - 1
"""Largest seed (an FMU Integer)."""
MIN_PERIOD = 5e-3
"""Shortest sample period of a sensor, s (200 Hz: an attitude loop's sensors sample at 1-100 Hz).
Five times :data:`satfmu.fmus.instants.MIN_SAMPLE_PERIOD`: a pythonfmu sensor draws its noise in Python
(~20 us an instant for the gyro's six draws), so that a 100 s step at the shortest period stays
within the robustness suite's 1 s (2e4 instants)."""


def timing(period: float, what: str) -> tuple[Variable, Variable, Variable]:
    """The sample period, phase and seed parameters of a sensor.

    Parameters
    ----------
    period : float
        Default sample period, s.
    what : str
        The sensor, for the descriptions.

    Returns
    -------
    tuple of Variable
        ``sample_period`` (s), ``sample_phase`` (s: instants at ``k * period - phase``) and
        ``seed`` (Integer, 0 .. :data:`SEED_MAX`).
    """
    return (Variable("sample_period", "s", f"Sample period of the {what}; the measurement is held in between",
                     period, min=MIN_PERIOD),
            Variable("sample_phase", "s", "Phase of the sample instants: they fall at k * sample_period - "
                     "sample_phase", 0.0),
            Variable("seed", "1", "Seed of the noise: a draw depends on (seed, sample instant) only", 0,
                     "Integer", min=0, max=SEED_MAX))


def sample_index(period: Variable, phase: Variable) -> sp.Expr:
    """The index ``k`` of the current sample instant ``t = k * period - phase`` (an integer; the
    instant of a start time between two instants counts as the earlier one's index).

    A time within :func:`satfmu.fmus.model.time_tolerance` before an instant is that instant, as for
    the FMU wrappers: at ``t = 1e9 s`` the time itself is rounded to 1.2e-7 s, far more than a fixed
    fraction of a 50 ms period could absorb.

    Parameters
    ----------
    period, phase : Variable
        The sensor's ``sample_period`` and ``sample_phase``.

    Returns
    -------
    sympy.Expr
        ``floor((t + phase + time_tolerance(t)) / period)``.
    """
    t = Model.t
    return sp.floor((t + phase.symbol + time_tolerance(t)) / period.symbol)


def gaussian(seed: Variable, k: sp.Expr, stream: int) -> sp.Expr:
    """One standard normal draw of the instant ``k`` (:class:`satfmu.fmus.noise.GaussianNoise`).

    Parameters
    ----------
    seed : Variable
        The sensor's seed parameter.
    k : sympy.Expr
        The sample index (:func:`sample_index`).
    stream : int
        Which draw of the instant (distinct per axis and noise source of a sensor).

    Returns
    -------
    sympy.Expr
    """
    return GaussianNoise(seed.symbol, k, sp.Integer(stream))


def error_matrix(scale: list[Variable], misalignment: list[Variable]) -> sp.Matrix:
    """``I + diag(scale) + M``: a sensor's scale factors and the off-diagonal ``M`` of its axes'
    misalignment and cross-coupling.

    Parameters
    ----------
    scale : list of Variable
        ``scale_factor[1..3]`` (1).
    misalignment : list of Variable
        The six off-diagonal entries (:func:`error_parameters`), row by row.

    Returns
    -------
    sympy.Matrix
        3 x 3.
    """
    m = sp.eye(3)
    off = iter(misalignment)
    for i in range(3):
        m[i, i] += scale[i].symbol
        for j in range(3):
            if i != j:
                m[i, j] = next(off).symbol
    return m


def error_parameters(unit_hint: str) -> tuple[list[Variable], list[Variable]]:
    """The scale-factor and misalignment parameters of a three-axis sensor.

    Parameters
    ----------
    unit_hint : str
        What the measured axes are, for the descriptions.

    Returns
    -------
    scale, misalignment : list of Variable
        ``scale_factor[1..3]`` (1, default 0) and ``misalignment[i,j]`` for ``i != j`` (rad,
        default 0): the measured axis ``i`` reads ``misalignment[i,j]`` of body axis ``j``.
    """
    scale = vector("scale_factor", 3, "1", f"Scale factor error of {unit_hint} axis {{i}} (0: exact)")
    mis = [Variable(f"misalignment[{i + 1},{j + 1}]", "rad", f"Misalignment: the measured axis {i + 1} senses "
                    f"body axis {j + 1} by this much (small angle)", 0.0)
           for i in range(3) for j in range(3) if i != j]
    return scale, mis


def quantize(x: sp.Expr, lsb: Variable) -> sp.Expr:
    """``x`` rounded to the nearest multiple of ``lsb`` (halves up); ``x`` itself when ``lsb`` is 0.

    Parameters
    ----------
    x : sympy.Expr
        The value.
    lsb : Variable
        The quantization step parameter (>= 0).

    Returns
    -------
    sympy.Expr
    """
    step = lsb.symbol
    # Max keeps the hoisted division finite when the step is 0 (that branch is not taken then)
    return sp.Piecewise((step * sp.floor(x / sp.Max(step, sp.Float(1e-300)) + sp.Rational(1, 2)), step > 0),
                        (x, True))


def clip(x: sp.Expr, limit: Variable) -> sp.Expr:
    """``x`` clipped to ``[-limit, limit]`` (a sensor's range).

    Parameters
    ----------
    x : sympy.Expr
        The value.
    limit : Variable
        The range parameter (> 0).

    Returns
    -------
    sympy.Expr
    """
    return sp.Max(-limit.symbol, sp.Min(limit.symbol, x))


def quaternion_of_mrp(s: sp.Matrix) -> sp.Matrix:
    """The quaternion (scalar last) of the MRP ``s``.

    Parameters
    ----------
    s : sympy.Matrix
        3 x 1.

    Returns
    -------
    sympy.Matrix
        ``(2 s, 1 - s^T s) / (1 + s^T s)``, 4 x 1.
    """
    s2 = (s.T * s)[0]
    return sp.Matrix([*(2 * s / (1 + s2)), (1 - s2) / (1 + s2)])


def quaternion_of_rotation(theta: sp.Matrix) -> sp.Matrix:
    """The quaternion (scalar last) of the rotation vector ``theta`` (rad): angle ``|theta|`` about
    ``theta / |theta|``.

    Parameters
    ----------
    theta : sympy.Matrix
        3 x 1, rad.

    Returns
    -------
    sympy.Matrix
        ``(sin(a/2) theta / a, cos(a/2))``, ``a = |theta|`` (the identity at ``theta = 0``).
    """
    a = sp.sqrt((theta.T * theta)[0])
    # sin(a/2)/a -> 1/2 as a -> 0: Max keeps the quotient finite and exact there (sin x = x for tiny x)
    half = sp.sin(a / 2) / sp.Max(a, sp.Float(1e-300))
    return sp.Matrix([*(half * theta), sp.cos(a / 2)])


def quaternion_product(a: sp.Matrix, b: sp.Matrix) -> sp.Matrix:
    """``a * b``: the attitude of matrix ``C(a) C(b)`` (scalar last).

    Parameters
    ----------
    a, b : sympy.Matrix
        4 x 1 quaternions.

    Returns
    -------
    sympy.Matrix
        ``(a4 b_v + b4 a_v - a_v x b_v, a4 b4 - a_v . b_v)``, 4 x 1.
    """
    av, bv = a[:3, 0], b[:3, 0]
    vec = a[3] * bv + b[3] * av - av.cross(bv)
    return sp.Matrix([*vec, a[3] * b[3] - (av.T * bv)[0]])


def canonical(q: sp.Matrix) -> sp.Matrix:
    """``q`` or ``-q``, whichever has ``q4 >= 0`` (the same attitude).

    Parameters
    ----------
    q : sympy.Matrix
        4 x 1.

    Returns
    -------
    sympy.Matrix
        4 x 1.
    """
    sign = sp.Piecewise((-1, q[3] < 0), (1, True))
    return sign * q


def mrp_of_quaternion(q: sp.Matrix) -> sp.Matrix:
    """The MRP of a quaternion with ``q4 >= 0`` (:func:`canonical`): ``q_v / (1 + q4)``, ``|sigma| <= 1``.

    Parameters
    ----------
    q : sympy.Matrix
        4 x 1, scalar last, ``q4 >= 0``.

    Returns
    -------
    sympy.Matrix
        3 x 1.
    """
    return q[:3, 0] / (1 + q[3])


def unit(v: sp.Matrix) -> sp.Matrix:
    """``v / |v|``.

    Parameters
    ----------
    v : sympy.Matrix
        3 x 1, not 0.

    Returns
    -------
    sympy.Matrix
        3 x 1.
    """
    return v / sp.sqrt((v.T * v)[0])

