"""Static state feedback on the DEMETER design model's states (seed 004, Fig. 3), as a native FMU.

The law's own states are the designer's blocks of Fig. 3: the attitude-error integrator
``xi' = theta`` (rad s) and the input pseudo-integrator ``xw' = -a xw + u_c`` (N m s, the
wheel-momentum proxy, a = 1e-3 1/s). The command is linear in the plant's measured states and
these::

    u_c = K_theta theta + K_theta_dot theta' + K_eta eta + K_eta_dot eta'
          + K_xi xi + K_xw xw + K_torque y + K_torque_rate y'

with y, y' the wheel torque and its rate (the wheel states of the design model). The gains
are FMU parameters (3 x 3 blocks, 3 x 8 for the flexible coordinates), so one FMU runs every
design: a design on reduced flexible coordinates ``eta_r = Q eta`` enters as ``K_eta = K_r Q``
(:meth:`synthesis.demeter_variants.DesignModel.fmu_gains`). The inputs carry the names of the
plant's outputs, so the master connects them by name. The law is affine in its states and the
FMU steps it exactly (``integrator="exact"``).
"""
from __future__ import annotations

import sympy as sp

from fmus import demeter
from fmus.model import Model, Output, Variable, states, symbols, vector

GAIN_BLOCKS = {"K_theta": ("theta", 3, "N.m/rad"), "K_theta_dot": ("theta_dot", 3, "N.m.s/rad"),
               "K_eta": ("eta", demeter.N_FLEX, "N.m"), "K_eta_dot": ("eta_dot", demeter.N_FLEX, "N.m.s"),
               "K_xi": ("xi", 3, "N.m/(rad.s)"), "K_xw": ("xw", 3, "1/s"),
               "K_torque": ("wheel_torque", 3, "1"), "K_torque_rate": ("wheel_torque_rate", 3, "s")}
"""Gain block name -> (signal, its length, unit of the gain)."""

def build(gains: dict[str, float] | None = None, name: str = "demeter_state_feedback",
          description: str = "State feedback on the DEMETER design model (seed 004, Fig. 3)") -> Model:
    """The controller model; ``gains`` (``"K_theta[1,1]"``: value, ...) set the parameter defaults.

    Raises
    ------
    KeyError
        If ``gains`` names no gain of the law.
    """
    gains = dict(gains or {})
    meas = {"theta": vector("theta", 3, "rad", "Measured attitude angle about axis {i}"),
            "theta_dot": vector("theta_dot", 3, "rad/s", "Measured attitude rate about axis {i}"),
            "eta": vector("eta", demeter.N_FLEX, "1", "Measured flexible coordinate {i}"),
            "eta_dot": vector("eta_dot", demeter.N_FLEX, "1/s", "Measured rate of flexible coordinate {i}"),
            "wheel_torque": vector("wheel_torque", 3, "N.m", "Measured wheel torque about axis {i}"),
            "wheel_torque_rate": vector("wheel_torque_rate", 3, "N.m/s", "Measured wheel torque rate about axis {i}")}
    x_xi = states("xi", 3, "rad.s", "integral of the attitude error about axis {i}")
    x_xw = states("xw", 3, "N.m.s", "pseudo-integral 1/(s + a) of the command about axis {i}")
    a = Variable("pseudo_integrator_pole", "1/s", "a of the input pseudo-integrator 1/(s + a)", 1e-3, min=0.0)
    signals = {**{k: symbols(v) for k, v in meas.items()}, "xi": symbols(x_xi), "xw": symbols(x_xw)}
    params, law = [], sp.zeros(3, 1)
    for block, (signal, n, unit) in GAIN_BLOCKS.items():
        for i in range(3):
            for j in range(n):
                pname = f"{block}[{i + 1},{j + 1}]"
                v = Variable(pname, unit, f"Gain from {signal}[{j + 1}] to u_c[{i + 1}], {unit}",
                             float(gains.pop(pname, 0.0)))
                params.append(v)
                law[i] += v.symbol * signals[signal][j]
    if gains:
        raise KeyError(f"no such gains: {sorted(gains)}")
    rhs = sp.Matrix(list(signals["theta"]) + [-a.symbol * signals["xw"][i] + law[i] for i in range(3)])
    outputs = ([Output(Variable(f"u_c[{i + 1}]", "N.m", f"Commanded wheel torque about axis {i + 1}"), law[i])
                for i in range(3)] + [Output(s.variable, s.symbol) for s in x_xi + x_xw])
    return Model(name=name, description=description, states=x_xi + x_xw,
                 inputs=[v for vs in meas.values() for v in vs], parameters=params + [a], outputs=outputs,
                 rhs=rhs, default_stop_time=600.0, default_step_size=0.1, integrator="exact")
