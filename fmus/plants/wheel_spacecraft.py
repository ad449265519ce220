"""Plant "MRP satellite with a reaction wheel array": one rigid body and N wheels, integrated together.

State ``x = [omega (rad/s), sigma (MRP, 1), Omega (wheel speeds relative to the body, rad/s),
tau_m (motor torques, N m)]``. With ``g_i`` the unit spin axes (columns of ``Gs``, normalized
from the parameters ``G_s[k,i]``), ``Js_i`` the spin inertias, ``J`` the whole spacecraft's inertia
(wheels included) and ``Jb = J - sum_i Js_i g_i g_i^T`` (the body the wheels spin in):

    h_i  = Js_i (g_i . omega + Omega_i)                     wheel spin momentum, N m s
    h_i' = tau_i + f_i                                      motor torque and friction
    Jb omega' = -omega x (Jb omega + Gs h) - Gs h' + tau_ext        (w_d and the environment's)
    Omega_i'  = h_i' / Js_i - g_i . omega'
    sigma'    = (1/4) B(sigma) omega

so the total angular momentum ``H = Jb omega + Gs h`` (body axes) changes only by ``tau_ext``: in
the reference frame ``C(sigma)^T H`` is constant when ``tau_ext = 0``. This is Basilisk's balanced
wheel model (``reactionWheelStateEffector``, ``BalancedWheels``), whose hub plus wheels has the
inertia ``J``.

The motor torques:

- commands: a body torque ``u`` (default), allocated to the wheels by the minimum-norm
  pseudo-inverse ``tau_cmd = -Gs^T (Gs Gs^T)^-1 u`` (the torque the wheels put on the body is
  ``-Gs tau``), or per-wheel commands ``u_wheel`` (parameter ``wheel_commands``);
- each command is clipped at its wheel's ``u_wheel_max`` and then cut to 0 while
  ``|Omega_i| >= Omega_max_i`` and it would spin the wheel up (``Omega_i tau_i >= 0``), Basilisk's
  rule, here checked continuously. A clipped allocation no longer gives the body torque ``u``;
- a first-order motor lag ``tau_m' = (tau_cmd - tau_m) / T`` when ``motor_time_constant`` T > 0;
  with T = 0 (default) the command acts at once (``tau_m`` then stays at its start value).

Friction (opposing the spin, continuous): ``f_i = -(c_viscous_i Omega_i + f_coulomb_i
sat(Omega_i / omega_coulomb))``, Coulomb friction linear within ``|Omega| < omega_coulomb``
(Basilisk's non-Stribeck law with its ``omegaLimitCycle``). Its reaction acts on the body.

The environment's torques (gravity gradient, drag and solar radiation pressure on the facets,
residual dipole: :mod:`satfmu.fmus.plants.environment_torques`) add to ``tau_ext`` when switched on,
from the orbit model's outputs connected to the plant's inputs ``r``, ``v_air``, ``sun``,
``sun_distance``, ``sunlit``, ``b``, ``density``; the attitude is then the body's from the inertial
frame.

Built per number of wheels and facets: :func:`build` (``mrp_satellite_rw<N>``, ``_f<M>`` added for
another number of facets than 6); shipped: 3 orthogonal wheels (``mrp_satellite_rw3``) and 4 in a
pyramid (``mrp_satellite_rw4``), with a box's six facets: the defaults of :data:`SMALLSAT`.
"""
from __future__ import annotations

from typing import Sequence

import sympy as sp

from satfmu.fmus.model import Model, Output, Variable, states, symbols, vector
from satfmu.fmus.plants import environment_torques, mrp_satellite, surface, wheels as wheel_arrays
from satfmu.fmus.plants.spacecraft import PARAMETERS, Spacecraft
from satfmu.fmus.plants.wheels import ReactionWheel

OMEGA_COULOMB = 1e-4
"""Default half-width of the Coulomb friction's linear zone, rad/s (Basilisk's default
``omegaLimitCycle``)."""

SMALLSAT_INERTIA = ((20.0, 0.0, 0.0), (0.0, 25.0, 0.0), (0.0, 0.0, 15.0))
"""Inertia of the shipped wheel plants' default spacecraft, kg m^2 (wheels included)."""
_WHEEL = dict(inertia=0.02, torque_limit=0.1, speed_limit=600.0, viscous=1e-6, coulomb=2e-4)
"""Each default wheel: 0.02 kg m^2 (12 N m s at 600 rad/s), 0.1 N m, friction of a small wheel."""
SMALLSAT_BOX = surface.box((1.0, 1.2, 1.5), offset=(0.01, -0.02, 0.05), specular=0.1, diffuse=0.2)
"""The default surface: a 1 x 1.2 x 1.5 m box whose centre of mass is 1, -2, 5 cm off its centre."""
SMALLSAT_DIPOLE = (0.05, -0.02, 0.1)
"""The default residual dipole, A m^2."""
SMALLSAT = {n: Spacecraft(f"smallsat_rw{n}", SMALLSAT_INERTIA, description=f"Shipped default: {n} wheels",
                          wheels=arr, facets=SMALLSAT_BOX, residual_dipole=SMALLSAT_DIPOLE)
            for n, arr in ((3, wheel_arrays.orthogonal(**_WHEEL)), (4, wheel_arrays.pyramid(**_WHEEL)))}
"""The default spacecraft of the shipped wheel plants, by number of wheels: 3 orthogonal, 4 in a pyramid,
the box's six facets and a residual dipole."""
FACETS = len(SMALLSAT_BOX)
"""The shipped plants' number of facets; a spacecraft with another number gets ``_f<N>`` in its model name."""


def dcm(s: sp.Matrix) -> sp.Matrix:
    """Direction cosine matrix ``C`` of the MRP ``s`` (reference to body: ``v_B = C v_N``).

    Parameters
    ----------
    s : sympy.Matrix
        The MRP sigma, 3 x 1.

    Returns
    -------
    sympy.Matrix
        ``I + (8 [s x]^2 - 4 (1 - s^T s) [s x]) / (1 + s^T s)^2``.
    """
    s2 = (s.T * s)[0]
    S = mrp_satellite.skew(s)
    return sp.eye(3) + (8 * S * S - 4 * (1 - s2) * S) / (1 + s2) ** 2


def build(spacecraft: Spacecraft, omega_0: Sequence[float] = (0.0, 0.0, 0.0),
          sigma_0: Sequence[float] = (0.0, 0.0, 0.0)) -> Model:
    """The symbolic plant of ``spacecraft`` with its wheel array (model ``mrp_satellite_rw<N>``).

    Parameters
    ----------
    spacecraft : Spacecraft
        Its inertia (wheels included) and wheel array give the parameters' defaults; the
        model is the same for every spacecraft with as many wheels, up to these defaults.
    omega_0 : 3 floats
        Default initial body rate, rad/s.
    sigma_0 : 3 floats
        Default initial MRP attitude.

    Returns
    -------
    Model
        The plant.

    Raises
    ------
    ValueError
        If the spacecraft has no wheels.
    """
    whl: tuple[ReactionWheel, ...] = spacecraft.wheels
    n = len(whl)
    if n == 0:
        raise ValueError(f"{spacecraft.name}: no reaction wheels to build the wheel plant with")
    inertia = mrp_satellite.inertia_parameters(spacecraft, "Inertia of the whole spacecraft, wheels included: ")
    axes = [Variable(f"G_s[{k + 1},{i + 1}]", "1", f"Spin axis of wheel {i + 1}, body component {k + 1} "
                     "(normalized in the model)", whl[i].axis[k]) for i in range(n) for k in range(3)]
    js = vector("J_s", n, "kg.m2", "Spin inertia of wheel {i}", [w.inertia for w in whl], min=1e-12)
    u_max = vector("u_wheel_max", n, "N.m", "Motor torque limit of wheel {i}", [w.torque_limit for w in whl],
                   min=0.0)
    om_max = vector("Omega_max", n, "rad/s", "Speed limit of wheel {i} (a torque that would spin it up is cut)",
                    [w.speed_limit for w in whl], min=1e-6)
    c_v = vector("c_viscous", n, "N.m.s/rad", "Viscous friction coefficient of wheel {i}",
                 [w.viscous for w in whl], min=0.0)
    f_c = vector("f_coulomb", n, "N.m", "Coulomb friction torque of wheel {i}", [w.coulomb for w in whl], min=0.0)
    om_c = Variable("omega_coulomb", "rad/s", "Half-width of the Coulomb friction's linear zone", OMEGA_COULOMB,
                    min=1e-12)
    lag = Variable("motor_time_constant", "s", "Time constant of the motors' first-order lag (0: none)", 0.0,
                   min=0.0)
    per_wheel = Variable("wheel_commands", "1", "Take the per-wheel commands u_wheel instead of allocating the "
                         "body torque u", 0, "Boolean")
    shadow = mrp_satellite.shadow_parameter()

    xw = states("omega", 3, "rad/s", "body angular rate about body axis {i}", omega_0)
    xs = states("sigma", 3, "1", "modified Rodrigues parameter {i} (body w.r.t. reference)", sigma_0)
    xo = states("Omega", n, "rad/s", "speed of wheel {i} relative to the body", 0.0)
    xm = states("tau_m", n, "N.m", "motor torque of wheel {i} (the lag's state)", 0.0)
    u = vector("u", 3, "N.m", "Commanded body torque about body axis {i} (allocated to the wheels)")
    uw = vector("u_wheel", n, "N.m", "Commanded motor torque of wheel {i} (when wheel_commands)")
    wd = vector("w_d", 3, "N.m", "External torque about body axis {i}")

    w, s, Om, tm = symbols(xw), symbols(xs), symbols(xo), symbols(xm)
    Ix, Iy, Iz, Ixy, Ixz, Iyz = (v.symbol for v in inertia)
    raw = sp.Matrix(3, n, lambda k, i: sp.Symbol(f"G_s[{k + 1},{i + 1}]", real=True))
    d_G = sp.Matrix(3, n, lambda k, i: sp.Symbol(f"d_G_{k}_{i}", real=True))
    defs: list[tuple[sp.Symbol, sp.Expr]] = []
    for i in range(n):
        norm = sp.sqrt(sum(raw[k, i] ** 2 for k in range(3)))
        defs += [(d_G[k, i], raw[k, i] / norm) for k in range(3)]
    Js = [v.symbol for v in js]
    J = sp.Matrix([[Ix, Ixy, Ixz], [Ixy, Iy, Iyz], [Ixz, Iyz, Iz]])
    Jb_expr = J - sum((Js[i] * d_G[:, i] * d_G[:, i].T for i in range(n)), sp.zeros(3, 3))
    d_Jb = sp.Matrix(3, 3, lambda a, b: sp.Symbol(f"d_Jb_{min(a, b)}_{max(a, b)}", real=True))
    defs += [(d_Jb[a, b], Jb_expr[a, b]) for a in range(3) for b in range(a, 3)]
    d_det = sp.Symbol("d_Jb_det", real=True)
    defs.append((d_det, d_Jb.det()))
    Jb_inv = d_Jb.adjugate() / d_det
    GGt = d_G * d_G.T
    d_GGt = sp.Matrix(3, 3, lambda a, b: sp.Symbol(f"d_GGt_{min(a, b)}_{max(a, b)}", real=True))
    defs += [(d_GGt[a, b], GGt[a, b]) for a in range(3) for b in range(a, 3)]
    d_GGt_det = sp.Symbol("d_GGt_det", real=True)
    defs.append((d_GGt_det, d_GGt.det()))
    allocated = -d_G.T * (d_GGt.adjugate() / d_GGt_det) * symbols(u)

    lag_on = lag.symbol > 0
    d_tau = [sp.Symbol(f"d_tau_{i}", real=True) for i in range(n)]  # applied motor torque
    d_hdot = [sp.Symbol(f"d_hdot_{i}", real=True) for i in range(n)]
    cmd_dots = []
    for i in range(n):
        cmd = sp.Piecewise((uw[i].symbol, per_wheel.symbol > sp.Rational(1, 2)), (allocated[i], True))
        clipped = sp.Max(-u_max[i].symbol, sp.Min(u_max[i].symbol, cmd))
        cut = sp.Piecewise((0, sp.And(sp.Abs(Om[i]) >= om_max[i].symbol, Om[i] * clipped >= 0)), (clipped, True))
        # Max keeps the hoisted division finite at T = 0, where the branch is not taken
        cmd_dots.append(sp.Piecewise(((cut - tm[i]) / sp.Max(lag.symbol, sp.Float(1e-300)), lag_on), (0, True)))
        friction = -(c_v[i].symbol * Om[i] + f_c[i].symbol * sp.Max(-1, sp.Min(1, Om[i] / om_c.symbol)))
        defs += [(d_tau[i], sp.Piecewise((tm[i], lag_on), (cut, True))), (d_hdot[i], d_tau[i] + friction)]
    h = sp.Matrix([Js[i] * ((d_G[:, i].T * w)[0] + Om[i]) for i in range(n)])
    hdot = sp.Matrix(d_hdot)
    H_body = d_Jb * w + d_G * h
    d_wdot = sp.Matrix([sp.Symbol(f"d_wdot_{k}", real=True) for k in range(3)])
    d_C = sp.Matrix(3, 3, lambda a, b: sp.Symbol(f"d_C_{a}_{b}", real=True))  # inertial -> body
    C = dcm(s)
    defs += [(d_C[a, b], C[a, b]) for a in range(3) for b in range(3)]
    env = environment_torques.build(spacecraft, d_C, J)
    defs += env.definitions
    wdot = Jb_inv * (-w.cross(H_body) - d_G * hdot + symbols(wd) + env.total)
    defs += [(d_wdot[k], wdot[k]) for k in range(3)]
    Om_dot = [d_hdot[i] / Js[i] - (d_G[:, i].T * d_wdot)[0] for i in range(n)]
    sigma_dot = mrp_satellite.mrp_kinematics_matrix(s) * w / 4

    H_ref = d_C.T * H_body
    outputs = ([Output(v.variable, v.symbol) for v in xw + xs]
               + [mrp_satellite.phi_output(s)]
               + [Output(v.variable, v.symbol) for v in xo]
               + [Output(Variable(f"h[{i + 1}]", "N.m.s", f"Spin angular momentum of wheel {i + 1} "
                                  "(Js (g . omega + Omega))"), h[i]) for i in range(n)]
               + [Output(Variable(f"tau_motor[{i + 1}]", "N.m", f"Motor torque applied to wheel {i + 1} (after "
                                  "the limits and the lag)"), d_tau[i]) for i in range(n)]
               + [Output(Variable(f"tau_wheels[{k + 1}]", "N.m", f"Torque of the wheels on the body about body "
                                  f"axis {k + 1} (-Gs h', friction included)"), -(d_G * hdot)[k]) for k in range(3)]
               + [Output(Variable(f"H[{k + 1}]", "N.m.s", f"Total angular momentum, reference axis {k + 1} "
                                  "(constant without external torque)"), H_ref[k]) for k in range(3)]
               + [Output(Variable("H_norm", "N.m.s", "Magnitude of the total angular momentum"),
                         sp.sqrt((H_body.T * H_body)[0]))]
               + env.outputs)
    post = sp.Matrix(list(w) + mrp_satellite.shadow_post(s, shadow.symbol) + list(Om) + list(tm))
    return Model(
        name=f"mrp_satellite_rw{n}" + ("" if len(spacecraft.facets) == FACETS else f"_f{len(spacecraft.facets)}"),
        description=f"Rigid satellite, MRP attitude, {n} reaction wheels integrated with the body (motor torque "
                    "and speed limits, friction, motor lag); a body torque command is allocated to the wheels by "
                    "the minimum-norm pseudo-inverse, then clipped per wheel",
        states=xw + xs + xo + xm, inputs=u + uw + wd + env.inputs,
        parameters=inertia + axes + js + u_max + om_max + c_v + f_c + [om_c, lag, per_wheel, shadow] + env.parameters,
        outputs=outputs, rhs=sp.Matrix(list(d_wdot) + list(sigma_dot) + Om_dot + cmd_dots), post_step=post,
        definitions=defs, default_stop_time=120.0, default_step_size=0.05)


def parameters(spacecraft: Spacecraft) -> dict[str, float]:
    """The wheel plant's parameters that make it ``spacecraft`` (for the shipped FMU of as many wheels).

    Parameters
    ----------
    spacecraft : Spacecraft
        A spacecraft with a wheel array.

    Returns
    -------
    dict of str to float
        ``I_x ... I_yz`` (kg m^2), ``G_s[k,i]``, ``J_s[i]`` (kg m^2), ``u_wheel_max[i]`` (N m),
        ``Omega_max[i]`` (rad/s), ``c_viscous[i]`` (N m s/rad), ``f_coulomb[i]`` (N m), the facets'
        ``facet_area[k]`` (m^2), ``facet_normal[j,k]``, ``facet_cp[j,k]`` (m), ``drag_coefficient[k]``,
        ``specular[k]``, ``diffuse[k]`` and the residual dipole ``m_res[j]`` (A m^2).

    Raises
    ------
    ValueError
        If the spacecraft has no wheels.
    """
    if not spacecraft.wheels:
        raise ValueError(f"{spacecraft.name}: no reaction wheels")
    out = {name: spacecraft.inertia[i][j] for name, (i, j) in PARAMETERS.items()}
    for i, w in enumerate(spacecraft.wheels, start=1):
        out.update({f"G_s[{k + 1},{i}]": w.axis[k] for k in range(3)})
        out.update({f"J_s[{i}]": w.inertia, f"u_wheel_max[{i}]": w.torque_limit, f"Omega_max[{i}]": w.speed_limit,
                    f"c_viscous[{i}]": w.viscous, f"f_coulomb[{i}]": w.coulomb})
    for k, f in enumerate(spacecraft.facets, start=1):
        out.update({f"facet_normal[{j + 1},{k}]": f.normal[j] for j in range(3)})
        out.update({f"facet_cp[{j + 1},{k}]": f.centre_of_pressure[j] for j in range(3)})
        out.update({f"facet_area[{k}]": f.area, f"drag_coefficient[{k}]": f.drag_coefficient,
                    f"specular[{k}]": f.specular, f"diffuse[{k}]": f.diffuse})
    out.update({f"m_res[{j + 1}]": v for j, v in enumerate(spacecraft.residual_dipole)})
    return out


MODELS = {n: build(sc) for n, sc in SMALLSAT.items()}
"""The shipped wheel plants by number of wheels: ``mrp_satellite_rw3`` and ``mrp_satellite_rw4``."""
