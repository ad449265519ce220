"""The model "magnetometer": a three-axis magnetometer in the body, sampled, with noise, bias and misalignment.

At each sample instant ``k`` it reads the geomagnetic field ``b_N`` (inertial axes, the orbit and
environment model's ``b``) in the body axes of the true attitude ``sigma``::

    b_m = clip(quantize(A C(sigma) b_N + b_0 + sigma_n n_k, lsb), range)

``A = I + diag(scale) + M`` (:func:`satfmu.fmus.sensors.common.error_matrix`), ``b_0`` a constant
bias (the spacecraft's own field at the sensor, uncalibrated), ``sigma_n`` the noise (1 sigma per
axis and sample) and ``n_k`` standard normal draws of (seed, k) (:mod:`satfmu.fmus.noise`).
"""
from __future__ import annotations

from satfmu.fmus.model import Definitions, Model, Output, Sampler, Variable, symbols, vector
from satfmu.fmus.plants.wheel_spacecraft import dcm
from satfmu.fmus.sensors import common

STREAM = 300
"""First noise stream of the magnetometer (300-302)."""


def build() -> Model:
    """The magnetometer model.

    Returns
    -------
    Model
        Inputs ``b[1..3]`` (T, inertial axes) and ``sigma[1..3]`` (the true MRP attitude); outputs
        ``b_m[1..3]`` (T, body axes) and ``sample_time`` (s).
    """
    period, phase, seed = common.timing(0.1, "magnetometer")
    noise = Variable("noise", "T", "Noise of each axis, 1 sigma per sample", 1e-7, min=0.0)
    bias = vector("bias_0", 3, "T", "Constant bias of axis {i}")
    scale, mis = common.error_parameters("magnetometer")
    lsb = Variable("quantization", "T", "Output resolution (0: none)", 0.0, min=0.0)
    limit = Variable("range", "T", "Largest field measured (the output is clipped to +-range)", 1e-4, min=0.0)
    b_in = vector("b", 3, "T", "Geomagnetic field, inertial axis {i}")
    sigma = vector("sigma", 3, "1", "True attitude, MRP component {i} (body from inertial)")

    meas = vector("held_b_m", 3, "T", "Measured field of axis {i} at the last instant")
    held_time = Variable("held_sample_time", "s", "Instant of the held measurement", 0.0)
    k = common.sample_index(period, phase)
    define = Definitions()
    b_body = define.vector("d_b_body", dcm(symbols(sigma)) * symbols(b_in))
    sensed = common.error_matrix(scale, mis) * b_body
    field = [common.clip(common.quantize(sensed[i] + bias[i].symbol + noise.symbol
                                         * common.gaussian(seed, k, STREAM + i), lsb), limit) for i in range(3)]
    sampler = Sampler(held=meas + [held_time], arguments=field + [k * period.symbol - phase.symbol],
                      period=period.name, phase=phase.name)
    outputs = ([Output(Variable(f"b_m[{i + 1}]", "T", f"Measured field along body axis {i + 1}"), m.symbol)
                for i, m in enumerate(meas)]
               + [Output(Variable("sample_time", "s", "Instant of the measurement held"), held_time.symbol)])
    return Model(name="magnetometer",
                 description="Three-axis magnetometer: the inertial field in the body axes of the true attitude, "
                             "with noise, bias, scale factor, misalignment, quantization and range, sampled with a "
                             "zero-order hold; seeded noise of (seed, sample instant)",
                 states=[], inputs=b_in + sigma, driven_inputs=tuple(v.name for v in b_in + sigma),
                 parameters=[period, phase, seed, noise, *bias, *scale, *mis, lsb, limit],
                 outputs=outputs, sampler=sampler, definitions=define, default_stop_time=60.0, default_step_size=0.1)


MODEL = build()
