"""Servo controllers u = -K xe (+ friction compensation): gain-scheduled and online SDRE.

Both share one model builder, :func:`servo_model`. Inputs: the tracked plant outputs,
their references and the measured rates (named as the plant's outputs, so they connect by
name); states: the integrals of the tracking errors, advanced by the FMU's integrator with
the inputs held over each step; outputs: the commands and the tracking errors
e = reference - tracked. The servo state is xe = [int e, e, rates].

- :func:`build`: the gain of a :class:`satfmu.controllers.artifact.ServoArtifact`, polynomials in
  the scheduling variables (an LQ servo is the degree-0 case, the approximated SDRE of
  seed 002 a fitted polynomial gain). Native and pythonfmu FMUs.
- :func:`build_online`: the online SDRE of seed 002. The gain is solved and checked
  (:func:`satfmu.controllers.riccati.sampled_gain`) at every control instant from the servo's
  SDC matrices (:func:`satfmu.controllers.servo_sdc.servo_matrices`, the plant's own factorization) and
  held in between; a rejected solution stops the FMU with the check's message. Native FMU:
  the C twin of the checked solve (``fmus/c/riccati.h``: Hamiltonian sign function, then
  Newton-Kleinman refinement, the same checks and messages); pythonfmu FMU (the cross-check
  backend): :func:`satfmu.controllers.riccati.sampled_gain`, scipy's ``solve_continuous_are``.

For the VSCMG (``plant == "vscmg"``) the optional friction compensation of
:func:`satfmu.fmus.plants.vscmg.friction_compensation` is added (parameter ``compensation_on``, off by
default).
"""
from __future__ import annotations

from pathlib import Path
from typing import Sequence

import sympy as sp

from satfmu.controllers import mrp_servo_sdc, riccati, servo_sdc
from satfmu.controllers.artifact import ServoArtifact, scheduling_signal
from satfmu.controllers.polynomial import sympy_polynomial
from satfmu.fmus.plants import mrp_satellite, vscmg
from satfmu.fmus.plants.spacecraft import SEED_000, Spacecraft
from satfmu.fmus.instants import MIN_SAMPLE_PERIOD
from satfmu.fmus.model import Model, Output, Sampler, State, Variable, vector


def _initial(name: str) -> str:
    """The name of the parameter holding the initial value of state ``name`` (``x`` -> ``x_0``,
    the vector element ``x[2]`` -> ``x_0[2]``)."""
    base, bracket, index = name.partition("[")
    return f"{base}_0{bracket}{index}"


def _times_second(unit: str) -> str:
    """The unit of a signal's time integral (``"rad"`` -> ``"rad.s"``, ``"1"`` -> ``"s"``)."""
    return "s" if unit == "1" else f"{unit}.s"


def servo_model(name: str, description: str, plant: str, tracked: list[dict], rates: list[dict],
                outputs: list[dict], gain: list[list[sp.Expr]], parameters: Sequence[Variable] = (),
                sampler: Sampler | None = None, extra_outputs: Sequence[Output] = ()) -> Model:
    """Symbolic servo model with the gain ``gain`` (rows: commands, columns: xe entries).

    ``gain`` may use the tracked and rate symbols (by name), ``parameters`` and the
    sampler's held values.

    Parameters
    ----------
    name : str
        The model's name (the FMU's modelIdentifier).
    description : str
        The model's description.
    plant : str
        Model name of the plant; for ``"vscmg"`` the measured inputs start at the plant's
        defaults and the friction compensation is added.
    tracked : list of dict
        The tracked plant outputs, ``{"name": str, "reference": str, "unit": str}`` each: an input
        for the measurement, one for the reference, a state for the error's integral and an
        output ``e_<name>`` each.
    rates : list of dict
        The rates fed back, ``{"name": str, "unit": str}`` each (inputs).
    outputs : list of dict
        The commands, ``{"name": str, "unit": str, "description": str}`` each (``description``
        optional), one per row of ``gain``.
    gain : list of list of sympy.Expr
        ``K``, shape (n_outputs, 2 n_tracked + n_rates): the law is ``u = -K xe``.
    parameters : sequence of Variable, optional
        Parameters the gain uses (weights, inertias, periods), besides the compensation's.
    sampler : Sampler, optional
        The sampler whose held values the gain reads (an online gain); None for none.
    extra_outputs : sequence of Output, optional
        Outputs appended after the commands and the tracking errors (monitors).

    Returns
    -------
    Model
        The servo, integrals of the tracking errors as states (the tracked unit times s).
    """
    start = vscmg.measured_defaults() if plant == vscmg.MODEL.name else {}
    tracked_v = [Variable(t["name"], t["unit"], f"Measured {t['name']}", start.get(t["name"], 0.0)) for t in tracked]
    refs = [Variable(t["reference"], t["unit"], f"Reference of {t['name']}", start.get(t["name"], 0.0))
            for t in tracked]
    rates_v = [Variable(r["name"], r["unit"], f"Measured {r['name']}", start.get(r["name"], 0.0)) for r in rates]
    integrals = [State(Variable(f"int_e_{t['name']}", _times_second(t["unit"]),
                                f"Integral of the {t['name']} tracking error"),
                       Variable(_initial(f"int_e_{t['name']}"), _times_second(t["unit"]),
                                f"Initial integral of the {t['name']} error"))
                 for t in tracked]
    e = [r.symbol - y.symbol for r, y in zip(refs, tracked_v)]
    xe = [s.symbol for s in integrals] + e + [r.symbol for r in rates_v]
    commands = [-sum((kij * xj for kij, xj in zip(row, xe)), sp.Integer(0)) for row in gain]
    parameters = list(parameters)
    if plant == vscmg.MODEL.name:
        by_name = {v.name: v.symbol for v in tracked_v + rates_v}
        errors = dict(zip([t["name"] for t in tracked], e))
        extra, comp = vscmg.friction_compensation(by_name, errors, commands)
        commands = [c + x for c, x in zip(commands, extra)]
        parameters += comp
    outs = [Output(Variable(o["name"], o["unit"], o.get("description", f"Command {o['name']}")), c)
            for o, c in zip(outputs, commands)]
    outs += [Output(Variable(f"e_{t['name']}", t["unit"], f"Tracking error {t['reference']} - {t['name']}"), ei)
             for t, ei in zip(tracked, e)]
    return Model(name=name, description=description, states=integrals, inputs=tracked_v + refs + rates_v,
                 driven_inputs=tuple(v.name for v in tracked_v + rates_v),  # a reference's default: the origin
                 parameters=parameters, outputs=outs + list(extra_outputs), rhs=sp.Matrix(e),
                 default_stop_time=15.0, default_step_size=0.01, default_h_max=0.01, sampler=sampler)


def build(artifact: ServoArtifact) -> Model:
    """Symbolic model of the gain-scheduled servo described by ``artifact``.

    Parameters
    ----------
    artifact : ServoArtifact
        The validated servo: its signals, and its gain as polynomials in the scheduling
        variables.

    Returns
    -------
    Model
        The servo of :func:`servo_model` with the gain ``K(s)`` of the artifact.
    """
    sched = []
    for entry in artifact.scheduling:
        f, signal = scheduling_signal(entry)
        v = sp.Symbol(signal, real=True)
        sched.append(getattr(sp, f)(v) if f else v)
    K = [[sympy_polynomial(entry, sched) for entry in row] for row in artifact.gain]
    return servo_model(artifact.name, artifact.description, artifact.plant, artifact.tracked, artifact.rates,
                       artifact.outputs, K)


ONLINE_VARIANTS = {"vscmg_sdre_online": ("gyro_on_w2", False), "vscmg_sdre_online_w1free": ("w1_free", True)}
"""Shipped online SDRE FMUs: name -> (SDC factorization, w2 := 0). The second is the law the
approximated SDRE fits (its closed-loop deviation measures the fit alone)."""


MRP_ONLINE = "mrp_sdre_online"
"""The online SDRE servo of the rigid MRP satellite (:func:`build_online_mrp`)."""


def build_online(name: str = "vscmg_sdre_online") -> Model:
    """Symbolic model of a shipped online SDRE servo: the VSCMG's (seed 002, eq. 5-12), one of
    :data:`ONLINE_VARIANTS`, or the MRP satellite's, :data:`MRP_ONLINE` (:func:`build_online_mrp`).

    The model's parameters (besides the plant inertias the SDC uses and the compensation's):
    ``control_period`` (s), ``Q[1..n]`` and ``R[1..m]`` (the diagonals of Qe, Re; the VSCMG's
    default the seed's) and ``riccati_eps`` (1/s). Extra outputs: the relative residual and the
    largest closed-loop real part (1/s) of the solution in use.

    Parameters
    ----------
    name : str, optional
        A key of :data:`ONLINE_VARIANTS` (the model's name, which selects the SDC factorization
        and whether w2 is frozen at 0) or :data:`MRP_ONLINE`.

    Returns
    -------
    Model
        The servo of :func:`servo_model` with the gain held by a routine sampler.

    Raises
    ------
    KeyError
        If ``name`` is none of these.
    """
    if name == MRP_ONLINE:
        return build_online_mrp()
    factorization, freeze_w2 = ONLINE_VARIANTS[name]
    Ae, Be = servo_sdc.servo_matrices(vscmg.MODEL, factorization, freeze_w2)
    sdc = factorization + (" at w2 = 0" if freeze_w2 else "")
    return _online(name, f"Online SDRE servo of the VSCMG (seed 002, {sdc} SDC): checked Riccati gain every "
                   "control period", vscmg.MODEL, Ae, Be, servo_sdc.Q_SEED.diagonal().tolist(),
                   servo_sdc.R_SEED.diagonal().tolist(), servo_sdc.EPS, "seed 002 eq. 10",
                   (servo_sdc.TRACKED, servo_sdc.RATES, servo_sdc.OUTPUTS))


def build_online_mrp(spacecraft: Spacecraft | None = None, name: str = MRP_ONLINE) -> Model:
    """Symbolic model of the MRP satellite's online SDRE servo (seed 002's method on a rigid
    spacecraft): the gain of :func:`satfmu.controllers.mrp_servo_sdc.servo_matrices` solved and
    checked every control period.

    The inertia (``I_x`` ... ``I_yz``, kg m^2) and the weights (``Q[1..9]``, ``R[1..3]``) are
    parameters: one FMU serves every spacecraft, given its ``Spacecraft.parameters()`` and
    :func:`satfmu.controllers.mrp_servo_sdc.default_weights` (or any weights).

    Parameters
    ----------
    spacecraft : Spacecraft, optional
        Whose inertia and default weights are the parameters' start values (default seed 000's
        satellite).
    name : str, optional
        The model's name. Default :data:`MRP_ONLINE`.

    Returns
    -------
    Model
        The servo of :func:`servo_model` with the gain held by a routine sampler.
    """
    spacecraft = SEED_000 if spacecraft is None else spacecraft
    plant = mrp_satellite.build(spacecraft)
    Ae, Be = mrp_servo_sdc.servo_matrices(plant)
    Q, R = mrp_servo_sdc.default_weights(spacecraft)
    return _online(name, "Online SDRE servo of the rigid MRP satellite (seed 002's method): checked Riccati "
                   "gain every control period; inertia and weights are parameters", plant, Ae, Be,
                   Q.diagonal().tolist(), R.diagonal().tolist(), mrp_servo_sdc.EPS,
                   "satfmu.controllers.mrp_servo_sdc.default_weights",
                   (mrp_servo_sdc.TRACKED, mrp_servo_sdc.RATES, mrp_servo_sdc.OUTPUTS))


def _online(name: str, description: str, plant: Model, Ae: sp.Matrix, Be: sp.Matrix, q0: Sequence[float],
            r0: Sequence[float], eps0: float, weights_from: str,
            signals: tuple[list[dict], list[dict], list[dict]]) -> Model:
    """The online SDRE servo of ``plant`` with the SDC servo matrices ``Ae``, ``Be``."""
    n, m = Be.shape
    used = set().union(*(sp.sympify(e).free_symbols for e in list(Ae) + list(Be)))
    inertias = [v for v in plant.parameters if v.symbol in used]
    q = vector("Q", n, "1", "Diagonal entry {i} of the servo state weight Qe (" + weights_from + ")",
               [float(v) for v in q0], min=0.0)
    r = vector("R", m, "1", "Diagonal entry {i} of the input weight Re (" + weights_from + ")",
               [float(v) for v in r0], min=1e-12)
    eps = Variable("riccati_eps", "1/s", "Shift of the Riccati pair (Ae - eps I, Be)", eps0, min=0.0)
    period = Variable("control_period", "s", "Gain update period (the gain is held in between)", 0.01,
                      min=MIN_SAMPLE_PERIOD)
    held = [Variable(f"K_{i + 1}_{j + 1}", "1", f"SDRE gain entry ({i + 1}, {j + 1})") for i in range(m)
            for j in range(n)]
    held += [Variable("held_residual"), Variable("held_max_re", "1/s")]
    sampler = Sampler(held=held, arguments=list(Ae) + list(Be) + [v.symbol for v in q + r] + [eps.symbol],
                      period=period.name, module=str(Path(riccati.__file__)), function="sampled_gain",
                      options={"n": n, "m": m}, c_header="riccati.h", c_function="riccati_sampled_gain")
    K = [[held[i * n + j].symbol for j in range(n)] for i in range(m)]
    monitors = [Output(Variable("riccati_residual", "1", "Relative residual of the Riccati solution in use"),
                       held[-2].symbol),
                Output(Variable("riccati_max_re", "1/s", "Largest real part of the closed-loop eigenvalues "
                                "of the SDC pair in use"), held[-1].symbol)]
    tracked, rates, outputs = signals
    return servo_model(name, description, plant.name, tracked, rates, outputs, K, inertias + q + r + [eps, period],
                       sampler, monitors)
