"""Magnetorquer laws (seed 003): the periodic gain schedule and the B-dot baseline.

Both are sampled laws: an expression sampler (:class:`satfmu.fmus.model.Sampler`) computes the
dipole at the sample instants and holds it in between (zero-order hold), so both are
native FMUs.

- :func:`build_periodic`: ``m = F(k) y`` from a
  :class:`satfmu.controllers.artifact.PeriodicArtifact`, sampled every ``sample_period`` at the
  orbit times ``k * sample_period`` (the phase is the parameter ``orbit_time_0``, the orbit
  time at ``t = 0``, as in the plant). The gain in use is the one of the orbit time of the
  instant: ``k = floor(tau / Ts) mod N`` with the artifact's Ts, whatever the sample
  period; a shorter sample period holds each dipole for less time with the same schedule.
- :func:`build_bdot`: the B-dot law in the form of Avanzini and Giulietti (2012),
  ``m = -(k_w / |b|) d(b/|b|)/dt``, with their gain ``k_w = 2 n (1 + sin xi) J_min``
  (:func:`bdot_gain`). The derivative is the finite difference of the unit field
  direction between the last two samples of the magnetometer (the inputs ``b_body``), the
  dipole held until the next sample; the first sample (and any sample with no field
  measured, ``|b|`` below ``b_min``) gives m = 0.
"""
from __future__ import annotations

import math

import sympy as sp

from satfmu.controllers.artifact import PeriodicArtifact
from satfmu.fmus.plants import cubesat
from satfmu.fmus.instants import INDEX_TOL, MIN_SAMPLE_PERIOD as MIN_PERIOD
from satfmu.fmus.model import Model, Output, Sampler, Variable, symbols, vector


def build_periodic(artifact: PeriodicArtifact) -> Model:
    """Symbolic model of the periodic gain schedule described by ``artifact``.

    Parameters
    ----------
    artifact : PeriodicArtifact
        The validated schedule: its ``inputs`` (the measured plant outputs) become the model's
        inputs, its ``outputs`` (the dipoles, A m^2) the model's outputs, its gains the law.

    Returns
    -------
    Model
        The sampled law, with parameters ``sample_period`` (s, default the artifact's) and
        ``orbit_time_0`` (s), and the output ``gain_index``.
    """
    inputs = [Variable(v["name"], v["unit"], f"Measured {v['name']}") for v in artifact.inputs]
    period = Variable("sample_period", "s", "Sample period of the zero-order hold (the schedule keeps the "
                      f"design's {artifact.sample_period:g} s per gain)", artifact.sample_period, min=MIN_PERIOD)
    phase = Variable("orbit_time_0", "s", "Orbit time at t = 0 (the schedule's phase; set it as the plant's)",
                     0.0)
    tau = phase.symbol + Model.t
    n = artifact.n_samples
    count = sp.floor(tau / artifact.sample_period + INDEX_TOL)
    k = count - n * sp.floor(count / n)  # count mod N, the same in C and Python for negative counts
    y = symbols(inputs)
    law = [sp.Piecewise(*[(sum(sp.Float(F[i, j], 17) * y[j] for j in range(len(y))), sp.Eq(k, idx))
                          for idx, F in enumerate(artifact.gains[:-1])],
                        (sum(sp.Float(artifact.gains[-1][i, j], 17) * y[j] for j in range(len(y))), True))
           for i in range(len(artifact.outputs))]
    held = [Variable(f"held_{o['name'].replace('[', '_').rstrip(']')}", o["unit"], f"Held {o['name']}")
            for o in artifact.outputs] + [Variable("held_gain_index", "1", "Index k of the gain in use")]
    sampler = Sampler(held=held, arguments=law + [k], period=period.name, phase=phase.name)
    outputs = [Output(Variable(o["name"], o["unit"], o.get("description", f"Command {o['name']}")), h.symbol)
               for o, h in zip(artifact.outputs, held)]
    outputs.append(Output(Variable("gain_index", "1", "Index k of the gain in use (0 .. N-1)"), held[-1].symbol))
    return Model(name=artifact.name, description=artifact.description, states=[], inputs=inputs,
                 driven_inputs=tuple(v.name for v in inputs),
                 parameters=[period, phase], outputs=outputs, sampler=sampler,
                 default_stop_time=2 * artifact.schedule_period, default_step_size=artifact.sample_period)


def bdot_gain(orbit_period: float = cubesat.ORBIT_PERIOD_SEED, inclination: float = cubesat.INCLINATION_SEED,
              j_min: float = min(cubesat.INERTIA_SEED_003)) -> float:
    """Avanzini-Giulietti B-dot gain ``k_w = 2 n (1 + sin xi) J_min``, kg m^2/s.

    Parameters
    ----------
    orbit_period : float
        Orbit period, s (n = 2 pi / orbit_period).
    inclination : float
        Inclination of the orbit with respect to the geomagnetic equator xi, rad (the seed's
        87 deg orbit inclination stands for it).
    j_min : float
        Smallest principal moment of inertia, kg m^2.
    """
    if not (orbit_period > 0 and j_min > 0 and math.isfinite(inclination)):
        raise ValueError("orbit_period and j_min must be > 0 and the inclination finite")
    return 2 * (2 * math.pi / orbit_period) * (1 + math.sin(inclination)) * j_min


def build_bdot(name: str = "cubesat_bdot") -> Model:
    """Symbolic model of the sampled B-dot law (inputs ``b_body[1..3]``, outputs ``m[1..3]``).

    Parameters
    ----------
    name : str, optional
        The model's name (the FMU's modelIdentifier).

    Returns
    -------
    Model
        Inputs ``b_body[1..3]`` (T), outputs ``m[1..3]`` (A m^2), parameters ``bdot_gain``
        (N m s, default :func:`bdot_gain`), ``control_period`` (s) and ``b_min`` (T).
    """
    b_in = vector("b_body", 3, "T", "Measured field along body axis {i} (magnetometer)")
    gain = Variable("bdot_gain", "N.m.s", "Gain k_w of m = -(k_w/|b|) d(b/|b|)/dt (default: 2 n (1 + sin i) "
                    "J_min of the seed's cubesat and orbit)", bdot_gain(), min=0.0)
    period = Variable("control_period", "s", "Magnetometer sample period; the dipole is held in between", 1.0,
                      min=MIN_PERIOD)
    b_min = Variable("b_min", "T", "Smallest field magnitude taken as a measurement (below it m = 0)", 1e-9,
                     min=0.0)
    b = symbols(b_in)
    norm = sp.sqrt((b.T * b)[0])
    valid = norm > b_min.symbol
    # Equal to |b| wherever a branch uses it; keeps a division hoisted out of the branch finite.
    safe = sp.Max(norm, b_min.symbol, sp.Float(1e-30))
    unit = [sp.Piecewise((bi / safe, valid), (0, True)) for bi in b]
    prev = vector("held_b_hat", 3, "1", "Unit field direction at the previous sample, axis {i}")
    count = Variable("held_count", "1", "Valid consecutive samples, up to 2")
    m_held = vector("held_m", 3, "A.m2", "Held dipole along body axis {i}")
    has_prev = sp.And(valid, count.symbol > sp.Rational(1, 2))
    m = [sp.Piecewise((-gain.symbol / safe * (u - p.symbol) / period.symbol, has_prev), (0, True))
         for u, p in zip(unit, prev)]
    arguments = unit + [sp.Piecewise((sp.Min(count.symbol + 1, 2), valid), (0, True))] + m
    sampler = Sampler(held=prev + [count] + m_held, arguments=arguments, period=period.name)
    outputs = [Output(Variable(f"m[{i + 1}]", "A.m2", f"Commanded dipole along body axis {i + 1}"), h.symbol)
               for i, h in enumerate(m_held)]
    return Model(name=name, description="B-dot detumbling law m = -(k_w/|b|) d(b/|b|)/dt (Avanzini-Giulietti "
                 "gain), sampled magnetometer, zero-order hold", states=[], inputs=b_in,
                 driven_inputs=tuple(v.name for v in b_in),
                 parameters=[gain, period, b_min], outputs=outputs, sampler=sampler,
                 default_stop_time=2 * cubesat.ORBIT_PERIOD_SEED, default_step_size=1.0)
