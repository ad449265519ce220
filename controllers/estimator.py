"""The model "attitude_mekf": the attitude estimator FMU, a multiplicative EKF sampled with a zero-order hold.

A routine sampler (:class:`satfmu.fmus.model.Sampler`): at each instant ``k * sample_period`` the
filter of :mod:`satfmu.controllers.mekf` (its Python form in pythonfmu FMUs and in process, its C
twin ``fmus/c/mekf.h`` in native FMUs, the same bits) propagates the attitude and the gyro bias
with the gyro's rate, then takes the star tracker's new measurement (``tracker_time`` later than
the last one used, ``tracker_valid``) and, with ``use_magnetometer``, the magnetometer's. Wire
the sensors of :mod:`satfmu.fmus.sensors`: ``gyro.omega_m`` to ``omega_m``, ``tracker.q_m``,
``tracker.valid`` and ``tracker.sample_time`` to ``q_m``, ``tracker_valid`` and
``tracker_time``, ``mag.b_m`` to ``b_m`` and the orbit model's ``b`` to ``b_ref``. Give the
filter the sensors' noise (``noise_cross``, ``noise_boresight``, ``boresight``, ``arw``, ``rrw``,
``noise_magnetometer``): what it assumes, which a campaign may set apart from what they have.
"""
from __future__ import annotations

from pathlib import Path

import sympy as sp

from satfmu.controllers import mekf
from satfmu.fmus.instants import MIN_SAMPLE_PERIOD
from satfmu.fmus.model import Model, Output, Sampler, Variable, symbols, vector
from satfmu.fmus.sensors import common

NAME = "attitude_mekf"
"""The model's name."""


def _packed(i: int) -> int:
    """Index of the diagonal entry ``(i, i)`` of ``P`` in its packed upper triangle."""
    return i * 6 - i * (i - 1) // 2


def build() -> Model:
    """The estimator model.

    Returns
    -------
    Model
        Inputs ``omega_m[1..3]`` (rad/s), ``q_m[1..4]``, ``tracker_valid``, ``tracker_time`` (s),
        ``b_m[1..3]`` (T, body), ``b_ref[1..3]`` (T, inertial); outputs the estimate
        ``q_est[1..4]`` (scalar last), ``sigma_est[1..3]``, ``omega_est[1..3]`` (rad/s),
        ``bias_est[1..3]`` (rad/s), the standard deviations ``attitude_std[1..3]`` (rad, body
        axes) and ``bias_std[1..3]`` (rad/s), ``initialized``, ``nis`` and ``updates``.
    """
    period = Variable("sample_period", "s", "Sample period of the filter (the gyro's, normally)", 0.05,
                      min=MIN_SAMPLE_PERIOD)
    use_tracker = Variable("use_tracker", "1", "Take the star tracker's measurements (and start from its first)",
                           1, "Boolean")
    use_mag = Variable("use_magnetometer", "1", "Take the magnetometer's measurements", 0, "Boolean")
    cross = Variable("noise_cross", "arcsec", "The tracker's cross-axis noise the filter assumes, 1 sigma", 5.0,
                     min=1e-6)
    roll = Variable("noise_boresight", "arcsec", "The tracker's boresight noise the filter assumes, 1 sigma", 40.0,
                    min=1e-6)
    bore = vector("boresight", 3, "1", "The tracker's boresight the filter assumes, body component {i}",
                  [0.0, 0.0, 1.0])
    mag_noise = Variable("noise_magnetometer", "T", "The magnetometer's noise the filter assumes, 1 sigma", 1e-7,
                         min=1e-15)
    arw = Variable("arw", "rad/s0.5", "The gyro's angle random walk the filter assumes", 3e-6, min=0.0)
    rrw = Variable("rrw", "rad/s1.5", "The gyro's rate random walk the filter assumes", 3e-9, min=0.0)
    p0_att = Variable("p0_attitude", "rad", "Initial attitude uncertainty, 1 sigma per axis", 1e-3, min=0.0)
    p0_bias = Variable("p0_bias", "rad/s", "Initial gyro bias uncertainty, 1 sigma per axis", 1e-4, min=0.0)
    q_init = vector("q_init", 4, "1", "Initial attitude without a tracker, quaternion component {i} (scalar last)",
                    [0.0, 0.0, 0.0, 1.0])
    omega_m = vector("omega_m", 3, "rad/s", "Measured body rate about body axis {i} (the gyro)")
    q_m = vector("q_m", 4, "1", "Measured attitude, quaternion component {i} (the star tracker)",
                 [0.0, 0.0, 0.0, 1.0])
    valid = Variable("tracker_valid", "1", "1 when the tracker's measurement is valid")
    t_m = Variable("tracker_time", "s", "Instant of the tracker's measurement")
    b_m = vector("b_m", 3, "T", "Measured field along body axis {i} (the magnetometer)")
    b_ref = vector("b_ref", 3, "T", "Reference field, inertial axis {i} (the orbit model's b)")

    held = [Variable(f"held_{name}[{i + 1}]" if n > 1 else f"held_{name}", "1", f"Filter value {name}"
                     + (f" {i + 1}" if n > 1 else "")) for name, n in mekf.HELD for i in range(n)]
    values = {"dt": period.symbol, "noise_cross": cross.symbol * common.ARCSEC,
              "noise_boresight": roll.symbol * common.ARCSEC,
              "tracker_valid": valid.symbol, "tracker_time": t_m.symbol, "use_tracker": use_tracker.symbol,
              "use_magnetometer": use_mag.symbol, "noise_magnetometer": mag_noise.symbol, "arw": arw.symbol,
              "rrw": rrw.symbol, "p0_attitude": p0_att.symbol, "p0_bias": p0_bias.symbol}
    values.update({v.name: v.symbol for v in omega_m + q_m + b_m + b_ref + bore + q_init})
    arguments = [values[name] for name in mekf.ARGUMENTS] + [h.symbol for h in held]
    sampler = Sampler(held=held, arguments=arguments, period=period.name, module=str(Path(mekf.__file__)),
                      function="step", c_header="mekf.h", c_function="mekf_step")

    def at(name: str, i: int = 0) -> Variable:
        offset = 0
        for h, n in mekf.HELD:
            if h == name:
                return held[offset + i]
            offset += n
        raise KeyError(name)

    def std(i: int) -> sp.Expr:
        """The square root of the diagonal entry ``(i, i)`` of ``P``."""
        return sp.sqrt(sp.Max(0, at("P", _packed(i)).symbol))

    q = symbols([at("q", i) for i in range(4)])
    outputs = ([Output(Variable(f"q_est[{i + 1}]", "1", f"Estimated attitude, quaternion component {i + 1} "
                                "(scalar last)"), q[i]) for i in range(4)]
               + [Output(Variable(f"sigma_est[{i + 1}]", "1", f"Estimated attitude, MRP component {i + 1}"), s)
                  for i, s in enumerate(common.mrp_of_quaternion(q))]
               + [Output(Variable(f"omega_est[{i + 1}]", "rad/s", f"Estimated body rate about axis {i + 1} "
                                  "(measured minus estimated bias)"), at("omega_est", i).symbol) for i in range(3)]
               + [Output(Variable(f"bias_est[{i + 1}]", "rad/s", f"Estimated gyro bias of axis {i + 1}"),
                         at("bias", i).symbol) for i in range(3)]
               + [Output(Variable(f"attitude_std[{i + 1}]", "rad", f"Standard deviation of the attitude error "
                                  f"about body axis {i + 1}"), std(i)) for i in range(3)]
               + [Output(Variable(f"bias_std[{i + 1}]", "rad/s", f"Standard deviation of the bias error of axis "
                                  f"{i + 1}"), std(i + 3)) for i in range(3)]
               + [Output(Variable("initialized", "1", "1 once the filter has started"), at("initialized").symbol),
                  Output(Variable("nis", "1", "Normalized innovation squared of the instant's tracker update (else "
                                  "its magnetometer update; chi-square with 3 degrees of freedom)"),
                         at("nis").symbol),
                  Output(Variable("updates", "1", "Measurement updates made"), at("updates").symbol)])
    return Model(name=NAME,
                 description="Multiplicative extended Kalman filter of the attitude and the gyro bias: gyro "
                             "propagation, star tracker and magnetometer updates, sampled with a zero-order hold",
                 states=[], inputs=omega_m + q_m + [valid, t_m] + b_m + b_ref,
                 driven_inputs=tuple(v.name for v in omega_m),  # the tracker's and the field only if used
                 parameters=[period, use_tracker, use_mag, cross, roll, *bore, mag_noise, arw, rrw, p0_att, p0_bias,
                             *q_init],
                 outputs=outputs, sampler=sampler, default_stop_time=60.0, default_step_size=0.05)
