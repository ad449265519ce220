"""The model "knowledge_error": how far an attitude estimate is from the truth, and in units of its own sigma.

A diagnostic for simulations, no sensor: it reads the estimator's attitude and standard
deviations and the plant's true attitude, and gives the error the estimator's covariance
describes, the rotation vector ``e`` (rad, body axes) with ``C_true = C(e) C_est``
(:mod:`satfmu.controllers.mekf`'s error state), its angle, and ``e_i / std_i``: a consistent
estimator keeps each within +-3 all but 0.27 % of the time. No state, no sampling: the outputs
follow the inputs at every communication point.
"""
from __future__ import annotations

import sympy as sp

from satfmu.fmus.model import Definitions, Model, Output, Variable, symbols, vector
from satfmu.fmus.sensors import common


def build() -> Model:
    """The knowledge-error model.

    Returns
    -------
    Model
        Inputs ``sigma_est[1..3]``, ``sigma_true[1..3]`` (MRPs) and ``attitude_std[1..3]``
        (rad); outputs ``error[1..3]`` (rad), ``angle`` (rad) and ``normalized[1..3]``.
    """
    est = vector("sigma_est", 3, "1", "Estimated attitude, MRP component {i} (the estimator's sigma_est)")
    true = vector("sigma_true", 3, "1", "True attitude, MRP component {i} (the plant's sigma)")
    std = vector("attitude_std", 3, "rad", "Standard deviation of the attitude error about body axis {i} (the "
                 "estimator's)")
    define = Definitions()
    q_est = common.quaternion_of_mrp(symbols(est))
    q_true = common.quaternion_of_mrp(symbols(true))
    inverse = sp.Matrix([-q_est[0], -q_est[1], -q_est[2], q_est[3]])
    q_err = define.vector("d_q_err", common.canonical(common.quaternion_product(q_true, inverse)))
    norm = define("d_norm", sp.sqrt(q_err[0] ** 2 + q_err[1] ** 2 + q_err[2] ** 2))
    angle = define("d_angle", 2 * sp.atan2(norm, q_err[3]))
    # angle / |v| -> 2 as the error vanishes: Max keeps the quotient finite there (the numerator is 0 too)
    error = define.vector("d_error", sp.Matrix([angle * q_err[i] / sp.Max(norm, sp.Float(1e-300)) for i in range(3)]))
    outputs = ([Output(Variable(f"error[{i + 1}]", "rad", f"Attitude error about body axis {i + 1} (C_true = C(error) "
                                "C_est)"), error[i]) for i in range(3)]
               + [Output(Variable("angle", "rad", "Angle between the estimate and the truth"), angle)]
               + [Output(Variable(f"normalized[{i + 1}]", "1", f"Error about axis {i + 1} over its standard "
                                  "deviation (0 where that is 0)"),
                         sp.Piecewise((error[i] / sp.Max(std[i].symbol, sp.Float(1e-300)), std[i].symbol > 0),
                                      (0, True))) for i in range(3)])
    return Model(name="knowledge_error",
                 description="Diagnostic: the attitude error of an estimate against the truth, its angle, and each "
                             "component over the estimator's standard deviation",
                 states=[], inputs=est + true + std,
                 driven_inputs=tuple(v.name for v in est + true), parameters=[], outputs=outputs, definitions=define,
                 default_stop_time=60.0, default_step_size=0.05)


MODEL = build()
