"""The multiplicative extended Kalman filter of a spacecraft's attitude and gyro bias, one sample at a time.

Standalone (the standard library only): the estimator FMU embeds this file as its sampler's
Python form, and its C form, ``fmus/c/mekf.h``, performs the same operations in the same order
(plain loops, no BLAS), so the two give the same bits.

The filter (Markley and Crassidis, Fundamentals of Spacecraft Attitude Determination and Control,
2014, sec. 6.2; Crassidis and Junkins, Optimal Estimation of Dynamic Systems, sec. 7.2):

- state: the attitude quaternion ``q`` (scalar last, body from inertial, the conventions of
  :mod:`satfmu.fmus.sensors.common`) and the gyro bias ``b`` (rad/s); error state ``(da, db)``
  with ``C_true = C(da) C(q)`` (body axes) and covariance ``P`` (6 x 6);
- propagation over the sample period ``dt`` with the mean of the previous and the current gyro
  rates less the bias, ``w = (omega_m,k-1 + omega_m,k) / 2 - b``: ``q <- q(w dt) * q`` and
  ``P <- Phi P Phi^T + Q`` with the exact transition of the error state and Farrenkopf's discrete
  process noise (``arw`` sigma_v, ``rrw`` sigma_u). The mean, not the previous rate alone: a body
  turning faster by ``a`` rad/s^2 would otherwise be propagated ``a dt^2 / 2`` short every step
  (9e-5 rad at 0.07 rad/s^2 and 50 ms), which the filter takes for a bias of ``a dt / 2``;
- star tracker update (a new valid measurement: its ``sample_time`` later than the last one
  used): residual ``2 vec(q_m * q^-1)``, ``H = [I 0]``, ``R = s_c^2 I + (s_b^2 - s_c^2) e e^T``
  (``e`` the boresight);
- magnetometer update: residual ``b_m - C(q) b_N``, ``H = [[C(q) b_N x] 0]``, ``R = s_m^2 I``;
- each update in Joseph form, the quaternion corrected multiplicatively (``q <- q(da) * q``,
  normalized), the bias additively;
- initialization at the first valid tracker measurement (``q = q_m``, ``b = 0``,
  ``P = diag(p0_attitude^2 I, p0_bias^2 I)``), or, without a tracker, from ``q_init`` at the
  first instant.

:func:`step` is the sampler function: flat arguments (:data:`ARGUMENTS`) in, the held values
(:data:`HELD`) out.
"""
from __future__ import annotations

import math

ARGUMENTS = ("dt", "omega_m[1]", "omega_m[2]", "omega_m[3]", "q_m[1]", "q_m[2]", "q_m[3]", "q_m[4]",
             "tracker_valid", "tracker_time", "b_m[1]", "b_m[2]", "b_m[3]", "b_ref[1]", "b_ref[2]", "b_ref[3]",
             "use_tracker", "use_magnetometer", "noise_cross", "noise_boresight", "boresight[1]",
             "boresight[2]", "boresight[3]", "noise_magnetometer", "arw", "rrw", "p0_attitude", "p0_bias",
             "q_init[1]", "q_init[2]", "q_init[3]", "q_init[4]")
"""The sampler's arguments before the previous held values, in order (units: s, rad/s, 1, T, rad,
rad/s^0.5, rad/s^1.5, rad/s)."""
HELD = (("q", 4), ("bias", 3), ("P", 21), ("omega_prev", 3), ("tracker_time", 1), ("initialized", 1),
        ("omega_est", 3), ("nis", 1), ("updates", 1))
"""The held values: name and count, in order: ``P`` its upper triangle, row by row; ``nis`` the
normalized innovation squared of the instant's tracker update (else its magnetometer update);
``updates`` the measurement updates made so far."""
N_HELD = sum(n for _, n in HELD)
"""Number of held values."""
TIME_TOLERANCE = 1e-9
"""A tracker measurement is new when its instant is later than the last one used by this much, s."""


def offset(name: str) -> int:
    """Position of the held value ``name`` (its first entry) among :data:`HELD`.

    Parameters
    ----------
    name : str
        A name of :data:`HELD` (``"q"``, ``"P"``, ...).

    Returns
    -------
    int

    Raises
    ------
    KeyError
        If no held value has that name.
    """
    offset = 0
    for held, n in HELD:
        if held == name:
            return offset
        offset += n
    raise KeyError(name)


def _cross(a: list[float], b: list[float]) -> list[float]:
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def _product(a: list[float], b: list[float]) -> list[float]:
    """``a * b``: the quaternion of ``C(a) C(b)`` (scalar last)."""
    c = _cross(a, b)
    return [a[3] * b[0] + b[3] * a[0] - c[0], a[3] * b[1] + b[3] * a[1] - c[1], a[3] * b[2] + b[3] * a[2] - c[2],
            a[3] * b[3] - (a[0] * b[0] + a[1] * b[1] + a[2] * b[2])]


def _rotation(v: list[float]) -> list[float]:
    """The quaternion of the rotation vector ``v`` (rad)."""
    angle = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    half = 0.5 if angle == 0.0 else math.sin(0.5 * angle) / angle
    return [half * v[0], half * v[1], half * v[2], math.cos(0.5 * angle)]


def _normalized(q: list[float]) -> list[float]:
    """``q / |q|`` with ``q4 >= 0``."""
    norm = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    if q[3] < 0.0:
        norm = -norm
    return [q[0] / norm, q[1] / norm, q[2] / norm, q[3] / norm]


def _dcm(q: list[float]) -> list[list[float]]:
    """``C(q)``: inertial to body (``v_B = C v_N``)."""
    x, y, z, w = q
    return [[w * w + x * x - y * y - z * z, 2.0 * (x * y + w * z), 2.0 * (x * z - w * y)],
            [2.0 * (x * y - w * z), w * w - x * x + y * y - z * z, 2.0 * (y * z + w * x)],
            [2.0 * (x * z + w * y), 2.0 * (y * z - w * x), w * w - x * x - y * y + z * z]]


def _matmul(a: list[list[float]], b: list[list[float]]) -> list[list[float]]:
    n, m, p = len(a), len(b), len(b[0])
    out = [[0.0] * p for _ in range(n)]
    for i in range(n):
        for j in range(p):
            s = 0.0
            for k in range(m):
                s += a[i][k] * b[k][j]
            out[i][j] = s
    return out


def _transpose(a: list[list[float]]) -> list[list[float]]:
    return [[a[i][j] for i in range(len(a))] for j in range(len(a[0]))]


def _inverse3(s: list[list[float]]) -> list[list[float]]:
    """The inverse of a 3 x 3 matrix (adjugate over determinant); ValueError when singular."""
    c00 = s[1][1] * s[2][2] - s[1][2] * s[2][1]
    c01 = s[1][2] * s[2][0] - s[1][0] * s[2][2]
    c02 = s[1][0] * s[2][1] - s[1][1] * s[2][0]
    det = s[0][0] * c00 + s[0][1] * c01 + s[0][2] * c02
    if not (math.isfinite(det) and det > 0.0):
        raise ValueError(f"innovation covariance not positive definite (determinant {det:.3g})")
    adj = [[c00, s[0][2] * s[2][1] - s[0][1] * s[2][2], s[0][1] * s[1][2] - s[0][2] * s[1][1]],
           [c01, s[0][0] * s[2][2] - s[0][2] * s[2][0], s[0][2] * s[1][0] - s[0][0] * s[1][2]],
           [c02, s[0][1] * s[2][0] - s[0][0] * s[2][1], s[0][0] * s[1][1] - s[0][1] * s[1][0]]]
    return [[adj[i][j] / det for j in range(3)] for i in range(3)]


def _skew(v: list[float]) -> list[list[float]]:
    return [[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]]


def _unpack(p: list[float]) -> list[list[float]]:
    out = [[0.0] * 6 for _ in range(6)]
    k = 0
    for i in range(6):
        for j in range(i, 6):
            out[i][j] = p[k]
            out[j][i] = p[k]
            k += 1
    return out


def _pack(m: list[list[float]]) -> list[float]:
    """The upper triangle of ``(m + m^T) / 2``, row by row."""
    return [0.5 * (m[i][j] + m[j][i]) for i in range(6) for j in range(i, 6)]


def _propagate(q: list[float], P: list[list[float]], w: list[float], dt: float, arw: float, rrw: float
               ) -> tuple[list[float], list[list[float]]]:
    """Attitude and covariance ``dt`` later at the body rate ``w``."""
    q = _normalized(_product(_rotation([w[0] * dt, w[1] * dt, w[2] * dt]), q))
    rate = math.sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2])
    W = _skew(w)
    W2 = _matmul(W, W)
    if rate * dt > 1e-4:  # the closed forms; their series below (relative error < 1e-17)
        a = math.sin(rate * dt) / rate
        b = (1.0 - math.cos(rate * dt)) / (rate * rate)
        c = (rate * dt - math.sin(rate * dt)) / (rate * rate * rate)
    else:
        t2 = dt * dt
        r2 = rate * rate
        a = dt * (1.0 - r2 * t2 / 6.0)
        b = t2 * (0.5 - r2 * t2 / 24.0)
        c = t2 * dt * (1.0 / 6.0 - r2 * t2 / 120.0)
    phi = [[0.0] * 6 for _ in range(6)]
    for i in range(3):
        for j in range(3):
            eye = 1.0 if i == j else 0.0
            phi[i][j] = eye - a * W[i][j] + b * W2[i][j]
            phi[i][j + 3] = b * W[i][j] - eye * dt - c * W2[i][j]
            phi[i + 3][j + 3] = eye
    P = _matmul(_matmul(phi, P), _transpose(phi))
    v2, u2 = arw * arw, rrw * rrw
    for i in range(3):
        P[i][i] += v2 * dt + u2 * dt * dt * dt / 3.0
        P[i][i + 3] -= 0.5 * u2 * dt * dt
        P[i + 3][i] -= 0.5 * u2 * dt * dt
        P[i + 3][i + 3] += u2 * dt
    return q, P


def _update(q: list[float], bias: list[float], P: list[list[float]], y: list[float], H: list[list[float]],
            R: list[list[float]]) -> tuple[list[float], list[float], list[list[float]], float]:
    """One three-component measurement: the corrected state and covariance, and the NIS."""
    Ht = _transpose(H)
    PHt = _matmul(P, Ht)
    S = _matmul(H, PHt)
    for i in range(3):
        for j in range(3):
            S[i][j] += R[i][j]
    Si = _inverse3(S)
    K = _matmul(PHt, Si)
    dx = [K[i][0] * y[0] + K[i][1] * y[1] + K[i][2] * y[2] for i in range(6)]
    nis = 0.0
    for i in range(3):
        for j in range(3):
            nis += y[i] * Si[i][j] * y[j]
    q = _normalized(_product(_rotation(dx[:3]), q))
    bias = [bias[i] + dx[3 + i] for i in range(3)]
    KH = _matmul(K, H)
    A = [[(1.0 if i == j else 0.0) - KH[i][j] for j in range(6)] for i in range(6)]
    P = _matmul(_matmul(A, P), _transpose(A))
    KR = _matmul(_matmul(K, R), _transpose(K))
    P = [[P[i][j] + KR[i][j] for j in range(6)] for i in range(6)]
    return q, bias, P, nis


def step(values: list[float]) -> list[float]:
    """One sample instant of the filter: the sampler function of the estimator FMU.

    Parameters
    ----------
    values : list of float
        :data:`ARGUMENTS` then the previous instant's held values (:data:`HELD`).

    Returns
    -------
    list of float
        The held values of this instant (:data:`HELD`).

    Raises
    ------
    ValueError
        On the wrong number of values, a non-finite argument or held value, or a measurement
        whose innovation covariance is not positive definite.
    """
    n_args = len(ARGUMENTS)
    if len(values) != n_args + N_HELD:
        raise ValueError(f"expected {n_args + N_HELD} values, got {len(values)}")
    for i, v in enumerate(values):
        if not math.isfinite(v):
            name = ARGUMENTS[i] if i < n_args else f"held value {i - n_args}"
            raise ValueError(f"{name} is not finite ({v!r})")
    a = dict(zip(ARGUMENTS, values))
    held = list(values[n_args:])
    dt = a["dt"]
    omega_m = [a["omega_m[1]"], a["omega_m[2]"], a["omega_m[3]"]]
    q_m = [a["q_m[1]"], a["q_m[2]"], a["q_m[3]"], a["q_m[4]"]]
    use_tracker = a["use_tracker"] > 0.5
    fresh = use_tracker and a["tracker_valid"] > 0.5
    i_q, i_b, i_p, i_w = offset("q"), offset("bias"), offset("P"), offset("omega_prev")
    i_t, i_init, i_nis, i_n = offset("tracker_time"), offset("initialized"), offset("nis"), offset("updates")
    nis, updates = held[i_nis], held[i_n]
    if held[i_init] < 0.5:
        if fresh or not use_tracker:
            q = _normalized(q_m if fresh else [a["q_init[1]"], a["q_init[2]"], a["q_init[3]"], a["q_init[4]"]])
            bias = [0.0, 0.0, 0.0]
            P = [[0.0] * 6 for _ in range(6)]
            for i in range(3):
                P[i][i] = a["p0_attitude"] * a["p0_attitude"]
                P[i + 3][i + 3] = a["p0_bias"] * a["p0_bias"]
            out = q + bias + _pack(P) + omega_m + [a["tracker_time"] if fresh else 0.0, 1.0]
            return out + [omega_m[0], omega_m[1], omega_m[2], 0.0, 0.0]
        waiting = [0.0] * N_HELD  # no estimate yet: the identity, everything else 0
        waiting[i_q + 3] = 1.0
        return waiting
    q = held[i_q:i_q + 4]
    bias = held[i_b:i_b + 3]
    P = _unpack(held[i_p:i_p + 21])
    w_prev = held[i_w:i_w + 3]
    q, P = _propagate(q, P, [0.5 * (w_prev[i] + omega_m[i]) - bias[i] for i in range(3)], dt, a["arw"], a["rrw"])
    last = held[i_t]
    if fresh and a["tracker_time"] > last + TIME_TOLERANCE:
        dq = _product(q_m, [-q[0], -q[1], -q[2], q[3]])
        sign = -2.0 if dq[3] < 0.0 else 2.0
        y = [sign * dq[0], sign * dq[1], sign * dq[2]]
        e = [a["boresight[1]"], a["boresight[2]"], a["boresight[3]"]]
        norm = math.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])
        e = [e[0] / norm, e[1] / norm, e[2] / norm]
        sc2, sb2 = a["noise_cross"] * a["noise_cross"], a["noise_boresight"] * a["noise_boresight"]
        R = [[sc2 * (1.0 if i == j else 0.0) + (sb2 - sc2) * e[i] * e[j] for j in range(3)] for i in range(3)]
        H = [[1.0 if i == j else 0.0 for j in range(6)] for i in range(3)]
        q, bias, P, nis = _update(q, bias, P, y, H, R)
        last = a["tracker_time"]
        updates += 1.0
        tracked = True
    else:
        tracked = False
    b_ref = [a["b_ref[1]"], a["b_ref[2]"], a["b_ref[3]"]]
    if a["use_magnetometer"] > 0.5 and b_ref != [0.0, 0.0, 0.0]:
        C = _dcm(q)
        predicted = [C[i][0] * b_ref[0] + C[i][1] * b_ref[1] + C[i][2] * b_ref[2] for i in range(3)]
        y = [a["b_m[1]"] - predicted[0], a["b_m[2]"] - predicted[1], a["b_m[3]"] - predicted[2]]
        S = _skew(predicted)
        H = [[S[i][j] for j in range(3)] + [0.0, 0.0, 0.0] for i in range(3)]
        m2 = a["noise_magnetometer"] * a["noise_magnetometer"]
        R = [[m2 if i == j else 0.0 for j in range(3)] for i in range(3)]
        q, bias, P, nis_m = _update(q, bias, P, y, H, R)
        updates += 1.0
        if not tracked:  # the NIS shown is the tracker's when it updated at this instant
            nis = nis_m
    estimate = [omega_m[i] - bias[i] for i in range(3)]
    return q + bias + _pack(P) + omega_m + [last, 1.0] + estimate + [nis, updates]
