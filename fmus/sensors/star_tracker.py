"""The model "star_tracker": a star tracker's attitude, sampled, noisy, misaligned, late and at times lost.

At each sample instant ``k`` the tracker measures the body attitude ``q`` (from the plant's MRP)
turned by its fixed misalignment ``m`` (a rotation vector, body axes) and by a noise rotation of
independent normal angles about its two cross axes (``noise_cross``, 1 sigma) and its boresight
(``noise_boresight``; trackers see roll about the boresight several times worse)::

    q_k = canonical(q(n_k) * q(m) * q(sigma(t_k))),  n_k = sigma_c (n1 e1 + n2 e2) + sigma_b n3 b

with ``b`` the boresight (body axes, normalized) and ``e1 = unit(a x b)``, ``e2 = b x e1`` (``a``
the body x axis, or y when the boresight is within 25.8 deg of x). Quaternions are scalar last
(:mod:`satfmu.fmus.sensors.common`).

The output is the measurement of ``latency`` instants before (0 to :data:`MAX_LATENCY`), with its
instant (``sample_time``) and a validity flag. A measurement is invalid in the outage window
``[outage_start, outage_stop)`` (the Sun or the Earth in the field of view, say) and, at random,
with probability ``dropout_probability`` (a uniform draw of the instant). While the output is
invalid, the last valid attitude is held (the identity before the first one) and ``valid`` is 0.
"""
from __future__ import annotations


import sympy as sp

from satfmu.fmus.model import Definitions, Model, Output, Sampler, Variable, symbols, vector
from satfmu.fmus.noise import UniformNoise
from satfmu.fmus.sensors import common

STREAM = 100
"""First noise stream of the tracker (100-102: the noise angles; 103: the dropout draw)."""
MAX_LATENCY = 8
"""Largest latency, in sample instants (the model holds that many past measurements)."""
AXIS_SWITCH = 0.9
"""The cross axes are built from the body x axis unless ``|b_x|`` exceeds this (then from y)."""


def build() -> Model:
    """The star tracker model.

    Returns
    -------
    Model
        Inputs ``sigma[1..3]`` (the true MRP attitude); outputs ``q_m[1..4]`` (scalar last,
        ``q_m[4] >= 0``), ``sigma_m[1..3]`` (its MRP), ``valid`` (1 or 0) and ``sample_time`` (s,
        the instant measured).
    """
    period, phase, seed = common.timing(0.2, "star tracker")
    cross = Variable("noise_cross", "arcsec", "Noise about each cross axis, 1 sigma", 5.0, min=0.0)
    roll = Variable("noise_boresight", "arcsec", "Noise about the boresight, 1 sigma", 40.0, min=0.0)
    bore = vector("boresight", 3, "1", "Boresight, body component {i} (normalized in the model)", [0.0, 0.0, 1.0])
    mis = vector("misalignment", 3, "rad", "Fixed misalignment, rotation vector component {i} (body axes)")
    latency = Variable("latency", "1", f"Delay of the output, in sample instants (0 to {MAX_LATENCY})", 0,
                       "Integer", min=0, max=MAX_LATENCY)
    out_start = Variable("outage_start", "s", "Start of the outage window (no valid measurement)", 0.0)
    out_stop = Variable("outage_stop", "s", "End of the outage window (none when not after its start)", 0.0)
    dropout = Variable("dropout_probability", "1", "Probability that a measurement is lost", 0.0, min=0.0, max=1.0)
    sigma = vector("sigma", 3, "1", "True attitude, MRP component {i} (body from inertial)")

    slots = [[Variable(f"held_q{j}[{i + 1}]", "1", f"Quaternion component {i + 1} measured {j} instants ago")
              for i in range(4)]
             + [Variable(f"held_valid{j}", "1", f"Validity of the measurement of {j} instants ago"),
                Variable(f"held_time{j}", "s", f"Instant of the measurement of {j} instants ago")]
             for j in range(MAX_LATENCY + 1)]
    shown = [Variable(f"held_out[{i + 1}]", "1", f"Quaternion component {i + 1} of the output") for i in range(4)]
    any_valid = Variable("held_any_valid", "1", "1 once a valid measurement has been output")
    shown_valid = Variable("held_out_valid", "1", "Validity of the output")
    shown_time = Variable("held_out_time", "s", "Instant of the output's measurement")

    define = Definitions()
    k = define("d_k", common.sample_index(period, phase))
    t_k = k * period.symbol - phase.symbol
    b = define.vector("d_boresight", common.unit(symbols(bore)))
    a = sp.Matrix([sp.Piecewise((0, sp.Abs(b[0]) > AXIS_SWITCH), (1, True)),
                   sp.Piecewise((1, sp.Abs(b[0]) > AXIS_SWITCH), (0, True)), 0])
    e1 = define.vector("e1", common.unit(a.cross(b)))
    e2 = define.vector("e2", b.cross(e1))
    draws = [common.gaussian(seed, k, STREAM + i) for i in range(3)]
    noise = define.vector("d_noise", cross.symbol * common.ARCSEC * (draws[0] * e1 + draws[1] * e2)
                          + roll.symbol * common.ARCSEC * draws[2] * b)
    q_true = define.vector("d_q_true", common.quaternion_of_mrp(symbols(sigma)))
    q_mis = define.vector("d_q_mis", common.quaternion_of_rotation(symbols(mis)))
    q_noise = define.vector("d_q_noise", common.quaternion_of_rotation(noise))
    q_new = common.canonical(define.vector("d_q_raw", common.quaternion_product(
        q_noise, define.vector("d_q_misaligned", common.quaternion_product(q_mis, q_true)))))
    in_outage = sp.And(t_k >= out_start.symbol, t_k < out_stop.symbol)
    lost = UniformNoise(seed.symbol, k, sp.Integer(STREAM + 3)) < dropout.symbol
    valid_new = sp.Piecewise((0, sp.Or(in_outage, lost)), (1, True))

    fresh = [define(f"d_q_new_{i}", q_new[i]) for i in range(4)] + [define("d_valid_new", valid_new),
                                                                   define("d_t_k", t_k)]
    shifted = [fresh] + [[v.symbol for v in slot] for slot in slots[:-1]]
    arguments: list[sp.Expr] = [x for slot in shifted for x in slot]

    def delayed(position: int) -> sp.Symbol:
        """Entry ``position`` of the slot the latency selects (this instant's, after the shift)."""
        return define(f"d_delayed_{position}", sp.Piecewise(
            *[(shifted[j][position], sp.Eq(latency.symbol, j)) for j in range(MAX_LATENCY)],
            (shifted[MAX_LATENCY][position], True)))

    chosen = [delayed(i) for i in range(6)]
    is_valid = chosen[4] > sp.Rational(1, 2)
    seen = any_valid.symbol > sp.Rational(1, 2)
    identity = (0, 0, 0, 1)  # before the first valid measurement (the held values start at 0)
    arguments += [sp.Piecewise((chosen[i], is_valid), (shown[i].symbol, seen), (identity[i], True)) for i in range(4)]
    arguments += [chosen[4], sp.Piecewise((chosen[5], is_valid), (shown_time.symbol, True)),
                  sp.Piecewise((1, is_valid), (any_valid.symbol, True))]
    held = [v for slot in slots for v in slot] + shown + [shown_valid, shown_time, any_valid]
    sampler = Sampler(held=held, arguments=arguments, period=period.name, phase=phase.name)
    q_out = symbols(shown)
    outputs = ([Output(Variable(f"q_m[{i + 1}]", "1", f"Measured attitude, quaternion component {i + 1} (scalar "
                                "last; the last valid measurement while invalid)"), q_out[i]) for i in range(4)]
               + [Output(Variable(f"sigma_m[{i + 1}]", "1", f"Measured attitude, MRP component {i + 1}"), s)
                  for i, s in enumerate(common.mrp_of_quaternion(q_out))]
               + [Output(Variable("valid", "1", "1 when the measurement output now is valid, else 0"),
                         shown_valid.symbol),
                  Output(Variable("sample_time", "s", "Instant of the (last valid) measurement output"),
                         shown_time.symbol)])
    return Model(name="star_tracker",
                 description="Star tracker: attitude quaternion with noise about the cross axes and the "
                             "boresight, a fixed misalignment, latency in samples, an outage window and random "
                             "dropouts, sampled with a zero-order hold; seeded noise of (seed, sample instant)",
                 states=[], inputs=sigma, driven_inputs=tuple(v.name for v in sigma),
                 parameters=[period, phase, seed, cross, roll, *bore, *mis, latency, out_start, out_stop, dropout],
                 outputs=outputs, sampler=sampler, definitions=define, default_stop_time=60.0,
                 default_step_size=0.2)


MODEL = build()
