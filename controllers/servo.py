"""Controller "gain-scheduled servo": u = -K(s) xe (+ friction compensation), from an artifact.

Built from a validated :class:`controllers.artifact.ServoArtifact` (an LQ servo is the
degree-0 case, the approximated SDRE of seed 002 a fitted polynomial gain). Inputs: the
tracked plant outputs, their references and the measured rates (named as the plant's
outputs, so they connect by name); states: the integrals of the tracking errors, advanced
by the FMU's integrator with the inputs held over each step; outputs: the commands and the
tracking errors e = reference - tracked.

For the VSCMG (``plant == "vscmg"``) the optional friction compensation of
:func:`fmus.vscmg.friction_compensation` is added (parameter ``compensation_on``, off by
default).
"""
from __future__ import annotations

import sympy as sp

from controllers.artifact import ServoArtifact
from controllers.polynomial import sympy_polynomial
from fmus import vscmg
from fmus.model import Model, Output, State, Variable


def build(artifact: ServoArtifact) -> Model:
    """Symbolic model of the servo described by ``artifact``."""
    tracked = [Variable(t["name"], t["unit"], f"Measured {t['name']}") for t in artifact.tracked]
    refs = [Variable(t["reference"], t["unit"], f"Reference of {t['name']}") for t in artifact.tracked]
    rates = [Variable(r["name"], r["unit"], f"Measured {r['name']}") for r in artifact.rates]
    integrals = [State(Variable(f"int_e_{t['name']}", "rad.s", f"Integral of the {t['name']} tracking error"),
                       Variable(f"int_e_{t['name']}_0", "rad.s", f"Initial integral of the {t['name']} error"))
                 for t in artifact.tracked]
    e = [r.symbol - y.symbol for r, y in zip(refs, tracked)]
    xe = [s.symbol for s in integrals] + e + [r.symbol for r in rates]
    by_name = {v.name: v.symbol for v in tracked + rates}
    sched = [by_name[n] for n in artifact.scheduling]
    K = [[sympy_polynomial(entry, sched) for entry in row] for row in artifact.gain]
    commands = [-sum((kij * xj for kij, xj in zip(row, xe)), sp.Integer(0)) for row in K]
    parameters: list[Variable] = []
    if artifact.plant == vscmg.MODEL.name:
        errors = dict(zip([t["name"] for t in artifact.tracked], e))
        extra, parameters = vscmg.friction_compensation(by_name, errors, commands)
        commands = [c + x for c, x in zip(commands, extra)]
    outputs = [Output(Variable(o["name"], o["unit"], o.get("description", f"Command {o['name']}")), c)
               for o, c in zip(artifact.outputs, commands)]
    outputs += [Output(Variable(f"e_{t['name']}", t["unit"], f"Tracking error {t['reference']} - {t['name']}"), ei)
                for t, ei in zip(artifact.tracked, e)]
    return Model(name=artifact.name, description=artifact.description, states=integrals,
                 inputs=tracked + refs + rates, parameters=parameters, outputs=outputs,
                 rhs=sp.Matrix(e), default_stop_time=15.0, default_step_size=0.01, default_h_max=0.01)
