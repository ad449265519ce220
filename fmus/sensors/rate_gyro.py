"""The model "rate_gyro": a three-axis rate gyro, sampled, with the noise of a real one.

At each sample instant ``k`` (period ``dt``), the discrete model of Farrenkopf's gyro (as in
Crassidis and Junkins, Optimal Estimation of Dynamic Systems, 2nd ed., sec. 7.2.1) with the
errors of a real unit::

    beta_k  = beta_{k-1} + sigma_u sqrt(dt) n_u,k                      (rate random walk)
    w_k     = A omega(t_k) + b_0 + (beta_k + beta_{k-1}) / 2
              + sqrt(sigma_v^2 / dt + sigma_u^2 dt / 12) n_v,k           (angle random walk)
    omega_m = clip(quantize(w_k, lsb), range)

``sigma_v`` is the angle random walk (``arw``, rad/s^0.5: the Allan deviation of the rate is
``sigma_v / sqrt(tau)`` at short times), ``sigma_u`` the rate random walk (``rrw``, rad/s^1.5:
``sigma_u sqrt(tau / 3)`` at long times), ``b_0`` a constant bias, ``A = I + diag(scale) + M``
the scale-factor and misalignment matrix (:func:`satfmu.fmus.sensors.common.error_matrix`), and
``n`` independent standard normal draws of (seed, k) (:mod:`satfmu.fmus.noise`). The walk starts
at 0 at the first instant. The rate sensed is the body rate at the instant, as the plant gives it
(the communication step's input).
"""
from __future__ import annotations

import sympy as sp

from satfmu.fmus.model import Model, Output, Sampler, Variable, symbols, vector
from satfmu.fmus.sensors import common

STREAM = 200
"""First noise stream of the gyro (streams 200-205: the walk's three, the white noise's three)."""


def build() -> Model:
    """The rate gyro model.

    Returns
    -------
    Model
        Inputs ``omega[1..3]`` (rad/s, the true body rate); outputs ``omega_m[1..3]`` (the
        measured rate), ``bias[1..3]`` (the true bias: constant plus walk, for checks) and
        ``sample_time`` (s, the instant of the measurement).
    """
    period, phase, seed = common.timing(0.05, "gyro")
    arw = Variable("arw", "rad/s0.5", "Angle random walk sigma_v (white rate noise density; 1 deg/h^0.5 = "
                   "2.909e-4 rad/s^0.5)", 3e-6, min=0.0)
    rrw = Variable("rrw", "rad/s1.5", "Rate random walk sigma_u (the bias's random walk)", 3e-9, min=0.0)
    bias = vector("bias_0", 3, "rad/s", "Constant bias of axis {i}")
    scale, mis = common.error_parameters("gyro")
    lsb = Variable("quantization", "rad/s", "Output resolution (0: none)", 0.0, min=0.0)
    limit = Variable("range", "rad/s", "Largest rate measured (the output is clipped to +-range)", 1.0, min=0.0)
    omega = vector("omega", 3, "rad/s", "True body rate about body axis {i}")

    walk = vector("held_walk", 3, "rad/s", "Random-walk part of the bias of axis {i} at the last instant")
    meas = vector("held_omega_m", 3, "rad/s", "Measured rate of axis {i} at the last instant")
    held_time = Variable("held_sample_time", "s", "Instant of the held measurement", 0.0)
    k = common.sample_index(period, phase)
    dt = period.symbol
    walk_now = [w.symbol + rrw.symbol * sp.sqrt(dt) * common.gaussian(seed, k, STREAM + i) for i, w in enumerate(walk)]
    white = sp.sqrt(arw.symbol**2 / dt + rrw.symbol**2 * dt / 12)
    sensed = common.error_matrix(scale, mis) * symbols(omega)
    rate = [common.clip(common.quantize(sensed[i] + bias[i].symbol + (walk_now[i] + walk[i].symbol) / 2
                                        + white * common.gaussian(seed, k, STREAM + 3 + i), lsb), limit)
            for i in range(3)]
    sampler = Sampler(held=walk + meas + [held_time], arguments=walk_now + rate + [k * dt - phase.symbol],
                      period=period.name, phase=phase.name)
    outputs = ([Output(Variable(f"omega_m[{i + 1}]", "rad/s", f"Measured rate about body axis {i + 1}"), m.symbol)
                for i, m in enumerate(meas)]
               + [Output(Variable(f"bias[{i + 1}]", "rad/s", f"True bias of axis {i + 1} (constant plus walk; for "
                                  "checks, no gyro tells it)"), bias[i].symbol + walk[i].symbol) for i in range(3)]
               + [Output(Variable("sample_time", "s", "Instant of the measurement held"), held_time.symbol)])
    return Model(name="rate_gyro",
                 description="Three-axis rate gyro: angle and rate random walk, constant bias, scale factor, "
                             "misalignment, quantization and range, sampled with a zero-order hold; seeded noise "
                             "of (seed, sample instant)",
                 states=[], inputs=omega, driven_inputs=tuple(v.name for v in omega),
                 parameters=[period, phase, seed, arw, rrw, *bias, *scale, *mis, lsb, limit],
                 outputs=outputs, sampler=sampler, default_stop_time=60.0, default_step_size=0.05)


MODEL = build()
