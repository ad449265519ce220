"""Backstepping tracking controller of the VSCMG: the seed 002 comparison (its section 5.2).

Gimbal 4 has no motor; eliminating the rotor acceleration w1' from the plant's equations
of motion M(q2) w' + N(q2, w) = [T1, T2, 0] (:func:`satfmu.fmus.plants.vscmg.mass_matrix`,
:func:`satfmu.fmus.plants.vscmg.gyroscopic`, the plant's own definitions) leaves two outputs of relative
degree 2, q2'' = w2' driven by T2 and q4'' = w4' driven by -sin(q2) T1 / (J2 + (J1 - JD)
sin^2 q2). For each tracked angle q with reference r (and its derivatives r', r''):

    e = r - q,   alpha = r' + c1 e,   z = alpha - w,
    V = e^2 / 2 + z^2 / 2,   choose w' = r'' + c1 (z - c1 e) + e + c2 z
    =>  e' = -c1 e + z,   z' = -e - c2 z,   V' = -c1 e^2 - c2 z^2.

The torques that give the chosen (w2', w4') solve the three equations for (w1', T1, T2);
friction and the gimbal-4 disturbance are not modelled (a plain backstepping baseline, with
the optional Coulomb compensation of :func:`satfmu.fmus.plants.vscmg.friction_compensation`). The law
divides by sin q2: valid for 0 < q2 < pi, the seed's range (singular at q2 = 0, where the
rotor cannot act on gimbal 4).
"""
from __future__ import annotations

import sympy as sp

from satfmu.fmus.plants import vscmg
from satfmu.fmus.model import Definitions, Model, Output, Variable

GAINS = {"c1": 5.0, "c2": 5.0}
"""Default backstepping gains, 1/s (substitutes: the seed gives none)."""


def build(name: str = "vscmg_backstepping") -> Model:
    """Symbolic model of the backstepping controller (native and pythonfmu FMUs).

    Parameters
    ----------
    name : str, optional
        The model's name (the FMU's modelIdentifier).

    Returns
    -------
    Model
        Inputs: the measured ``q2``, ``q4`` (rad), their references and derivatives and the
        rates ``w1``, ``w2``, ``w4`` (rad/s); outputs: the torques ``T1``, ``T2`` (N m) and the tracking errors
        (rad); parameters: the plant's inertias, the gains ``c1``, ``c2`` of each angle (1/s,
        default :data:`GAINS`) and the friction compensation.
    """
    start = vscmg.measured_defaults()
    q2, q4 = (Variable(n, "rad", f"Measured {n}", start[n]) for n in ("q2", "q4"))
    rates = [Variable(f"w{a}", "rad/s", f"Measured w{a}", start[f"w{a}"]) for a in vscmg.AXES]
    refs = {}
    for q in (q2, q4):
        refs[q.name] = [Variable(f"{q.name}_ref", "rad", f"Reference of {q.name}", start[q.name]),
                        Variable(f"{q.name}_ref_dot", "rad/s", f"Time derivative of {q.name}_ref"),
                        Variable(f"{q.name}_ref_ddot", "1/s", f"Second time derivative of {q.name}_ref, rad/s^2")]
    gains = {q.name: [Variable(f"{c}_{q.name}", "1/s", f"Backstepping gain {c} of {q.name}", v, min=1e-6)
                      for c, v in GAINS.items()] for q in (q2, q4)}
    inertias = [v for v in vscmg.MODEL.parameters if v.name in vscmg.INERTIAS_ECP750]
    I = vscmg.Inertias(*(v.symbol for v in inertias))
    w = sp.Matrix([r.symbol for r in rates])
    rate_of = {"q2": w[1], "q4": w[2]}
    d = Definitions()
    errors, accel = {}, {}
    for q in (q2, q4):
        r, r_dot, r_ddot = (v.symbol for v in refs[q.name])
        c1, c2 = (v.symbol for v in gains[q.name])
        e = r - q.symbol
        z = r_dot + c1 * e - rate_of[q.name]
        errors[q.name] = e
        accel[q.name] = d(f"acc_{q.name}", r_ddot + c1 * (z - c1 * e) + e + c2 * z)
    w1_dot, T1, T2 = sp.symbols("w1_dot T1 T2", real=True)
    eqs = vscmg.mass_matrix(q2.symbol, I) * sp.Matrix([w1_dot, accel["q2"], accel["q4"]]) \
        + vscmg.gyroscopic(q2.symbol, w, I) - sp.Matrix([T1, T2, 0])
    sol = {k: sp.simplify(v) for k, v in sp.solve(list(eqs), [w1_dot, T1, T2], dict=True)[0].items()}
    by_name = {v.name: v.symbol for v in [q2, q4] + rates}
    commands = [sol[T1], sol[T2]]
    extra, comp = vscmg.friction_compensation(by_name, errors, commands)
    commands = [c + x for c, x in zip(commands, extra)]
    outputs = [Output(Variable("T1", "N.m", "Rotor-1 motor torque command"), commands[0]),
               Output(Variable("T2", "N.m", "Gimbal-2 motor torque command"), commands[1])]
    outputs += [Output(Variable(f"e_{n}", "rad", f"Tracking error {n}_ref - {n}"), e) for n, e in errors.items()]
    inputs = [q2, q4] + refs["q2"] + refs["q4"] + rates
    return Model(name=name, description="Backstepping tracking controller of the VSCMG (seed 002 comparison)",
                 states=[], inputs=inputs, driven_inputs=tuple(v.name for v in inputs),
                 parameters=inertias + gains["q2"] + gains["q4"] + comp,
                 outputs=outputs, definitions=d, default_stop_time=15.0, default_step_size=0.01)
