"""Plant "VSCMG": the ECP Model 750 control moment gyroscope with gimbal 3 locked (seed 002).

Seed: the seed 002 paper; its equation of motion is missing from the
text, this is the public Abbas et al. model cleaned up in docs/models.md, "Seed 002".
Rotor 1 spins (angle q1, torque T1), gimbal 2 is driven (q2, torque T2), gimbal 4 is
unactuated and moves by the rotor's gyroscopic and reaction torques (q4):

    M(q2) w' + N(q2, w) + F = G [T1 T2]^T + [0 0 Td4]^T,   q' = w,
    M = [[JD, 0, JD s], [0, IC + ID, 0], [JD s, 0, J2 + J1 s^2]],   s = sin q2, c = cos q2,
    N = [JD c w2 w4, -c w4 (JD w1 + J1 s w4), c w2 (JD w1 + 2 J1 s w4)],
    J1 = JC + JD - KC - ID,   J2 = KA + KB + KC + ID,

with the state ordered x = [q1, q2, q4, w1, w2, w4]. Unforced and without friction it
conserves the kinetic energy (1/2) w^T M w, the rotor momentum p1 = JD (w1 + s w4) and the
gimbal-4 momentum p4 = JD s w1 + (J2 + J1 s^2) w4 (gimbal 4 has no actuator, so p4 is
uncontrollable at every rest state).

Friction (seed eq. 26, Table 1) on each axis i in (rotor 1, gimbal 2, gimbal 4): Coulomb +
viscous ``Fc_i sgn(w_i) + Fv_i w_i`` while the axis slides, and stiction: an axis at rest
stays at rest while the torque needed to hold it there is at most ``Fs_i``. Method
(stick-slip with exact sticking and a mode frozen over each integration substep):

- An axis is *at rest* when ``|w_i| <= w_band`` (default 1e-6 rad/s). The holding torques
  are computed from the coupled equations with the resting axes' accelerations set to zero
  (rotor and gimbal 4 are coupled through M[0, 2] = JD s; gimbal 2 is decoupled). The
  hypotheses are tried in the order both-stuck, gimbal-4-stuck, rotor-stuck, none; the
  first consistent one holds. An axis that breaks away slides in the direction of its own
  applied torque.
- The mode (which axes stick, the Coulomb signs) is decided at the start of each RK4
  substep and frozen over it, so RK4 integrates a smooth field inside a substep (no
  chattering of sgn(w) between stages, no false equilibria).
- The post-step map (after every substep) sets the velocity of an axis to exactly 0 when
  it came to rest or crossed zero inside the substep and the torque needed to hold it is
  at most ``Fs_i``; otherwise the axis slides on (a reversal).

The timing of a stop is resolved to one RK4 substep (``h_max``, default 1 ms).
Actuator limits ``|T1| <= 0.6`` N m, ``|T2| <= 2.4`` N m are applied inside the plant
(``saturation_on``, on by default). Inertias: the public ECP-750 parameter set
(**substitute**, not in the seed).
"""
from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from satfmu.fmus.model import Definitions, Model, Output, SDCForm, State, Variable, is_set, saturate

INERTIAS_ECP750 = {"KA": 0.0670, "KB": 0.0297, "IC": 0.0092, "JC": 0.0230, "KC": 0.0220,
                   "ID": 0.0148, "JD": 0.0273}
"""Public ECP Model 750 inertias, kg m^2 (**substitute**; the seed prints none)."""

FRICTION_TABLE_1 = {"Fs": (0.045600, 0.050800, 0.030819), "Fc": (0.045465, 0.050556, 0.031900),
                    "Fv": (0.0002983, 0.0543675, 0.0009627)}
"""Seed 002 Table 1 (rotor 1, gimbal 2, gimbal 4): static, Coulomb (N m), viscous (N m s/rad)."""

TORQUE_LIMITS = (0.6, 2.4)
"""Seed 002 actuator limits ``|T1|``, ``|T2|``, N m."""

AXES = ("1", "2", "4")
"""Axis labels of the seed: rotor 1, gimbal 2, gimbal 4."""

FACTORIZATIONS = ("gyro_on_w2", "w1_free")
"""SDC factorizations of N(q2, w) = N_sdc w, see :func:`sdc_gyroscopic`."""


@dataclass(frozen=True)
class Inertias:
    """Inertia symbols (or numbers) of the ECP-750 and the combinations J1, J2, kg m^2.

    Attributes
    ----------
    KA, KB : sympy.Expr
        Inertias of gimbal 4 (``KA``) and gimbal 3 (``KB``) about the gimbal-4 axis, kg m^2 (seed
        002 section 2: "Moment of inertia of Gimbal3 and Gimbal4"); gimbal 3 is locked, so both
        turn with gimbal 4 and enter only ``J2``.
    IC, JC, KC : sympy.Expr
        Inertias of body C (turned by gimbal 2, it carries the rotor) about its three axes,
        kg m^2.
    ID, JD : sympy.Expr
        Inertias of the rotor D, kg m^2: ``JD`` about its spin axis, ``ID`` about the
        gimbal-2 axis.
    """

    KA: sp.Expr
    KB: sp.Expr
    IC: sp.Expr
    JC: sp.Expr
    KC: sp.Expr
    ID: sp.Expr
    JD: sp.Expr

    @property
    def J1(self) -> sp.Expr:
        return self.JC + self.JD - self.KC - self.ID

    @property
    def J2(self) -> sp.Expr:
        return self.KA + self.KB + self.KC + self.ID


def mass_matrix(q2: sp.Expr, I: Inertias) -> sp.Matrix:
    """M(q2) of the gimbal-3-locked CMG, kg m^2 (rows/columns rotor 1, gimbal 2, gimbal 4).

    Parameters
    ----------
    q2 : sympy.Expr
        Gimbal-2 angle, rad.
    I : Inertias
        The ECP-750 inertias (symbols or numbers), kg m^2.

    Returns
    -------
    sympy.Matrix
        The 3 x 3 mass matrix, kg m^2.
    """
    s = sp.sin(q2)
    return sp.Matrix([[I.JD, 0, I.JD * s], [0, I.IC + I.ID, 0], [I.JD * s, 0, I.J2 + I.J1 * s**2]])


def gyroscopic(q2: sp.Expr, w: sp.Matrix, I: Inertias) -> sp.Matrix:
    """N(q2, w), N m: Coriolis and gyroscopic torques.

    Parameters
    ----------
    q2 : sympy.Expr
        Gimbal-2 angle, rad.
    w : sympy.Matrix
        Axis rates ``[w1, w2, w4]`` (rotor 1, gimbal 2, gimbal 4), 3 x 1, rad/s.
    I : Inertias
        The ECP-750 inertias (symbols or numbers), kg m^2.

    Returns
    -------
    sympy.Matrix
        The 3 x 1 torques on rotor 1, gimbal 2, gimbal 4, N m.
    """
    s, c = sp.sin(q2), sp.cos(q2)
    w1, w2, w4 = w
    return sp.Matrix([I.JD * c * w2 * w4,
                      -c * w4 * (I.JD * w1 + I.J1 * s * w4),
                      c * w2 * (I.JD * w1 + 2 * I.J1 * s * w4)])


def sdc_gyroscopic(q2: sp.Expr, w: sp.Matrix, I: Inertias, factorization: str) -> sp.Matrix:
    """A matrix N_sdc(q2, w) with N(q2, w) = N_sdc w exactly.

    ``"w1_free"`` is the seed's choice (coefficients in q2, w2, w4 only): its gimbal-4 row
    puts JD c w2 on the w1 column, which vanishes with w2. ``"gyro_on_w2"`` puts the whole
    gimbal-4 gyroscopic torque c (JD w1 + 2 J1 s w4) on the w2 column (coefficients in q2,
    w1, w4). Both share the rotor and gimbal-2 rows.

    Parameters
    ----------
    q2 : sympy.Expr
        Gimbal-2 angle, rad.
    w : sympy.Matrix
        Axis rates ``[w1, w2, w4]`` (rotor 1, gimbal 2, gimbal 4), 3 x 1, rad/s.
    I : Inertias
        The ECP-750 inertias (symbols or numbers), kg m^2.
    factorization : {"gyro_on_w2", "w1_free"}
        Which factorization (:data:`FACTORIZATIONS`).

    Returns
    -------
    sympy.Matrix
        The 3 x 3 matrix N_sdc, N m s/rad.

    Raises
    ------
    ValueError
        If ``factorization`` is not one of :data:`FACTORIZATIONS`.
    """
    s, c = sp.sin(q2), sp.cos(q2)
    w1, w2, w4 = w
    top = [[0, I.JD * c * w4, 0], [-I.JD * c * w4, 0, -I.J1 * s * c * w4]]
    if factorization == "w1_free":
        last = [I.JD * c * w2, 0, 2 * I.J1 * s * c * w2]
    elif factorization == "gyro_on_w2":
        last = [0, c * (I.JD * w1 + 2 * I.J1 * s * w4), 0]
    else:
        raise ValueError(f"unknown SDC factorization {factorization!r}; choose one of {FACTORIZATIONS}")
    return sp.Matrix(top + [last])


@dataclass(frozen=True)
class FrictionMode:
    """The discrete state of the stick-slip model: Coulomb signs and stuck hypotheses (0/1 flags).

    Built by :func:`friction_mode`; the symbols are definitions of the model
    (:class:`satfmu.fmus.model.Definitions`).

    Attributes
    ----------
    direction : list of sympy.Symbol
        Coulomb sign (-1, 0, 1) of rotor 1, gimbal 2 and gimbal 4.
    gimbal2_stuck : sympy.Symbol
        Flag: gimbal 2 sticks (it is decoupled from the other two axes).
    both_stuck : sympy.Symbol
        Flag: rotor 1 and gimbal 4 both stick.
    gimbal4_only : sympy.Symbol
        Flag: gimbal 4 sticks, the rotor slides.
    rotor_only : sympy.Symbol
        Flag: the rotor sticks, gimbal 4 slides.
    """

    direction: list[sp.Symbol]
    gimbal2_stuck: sp.Symbol
    both_stuck: sp.Symbol
    gimbal4_only: sp.Symbol
    rotor_only: sp.Symbol

    @property
    def stuck(self) -> list[sp.Basic]:
        """Conditions: rotor, gimbal 2, gimbal 4 stuck."""
        return [sp.Or(is_set(self.both_stuck), is_set(self.rotor_only)), is_set(self.gimbal2_stuck),
                sp.Or(is_set(self.both_stuck), is_set(self.gimbal4_only))]


def _sliding(Fc: list[sp.Expr], Fv: list[sp.Expr], direction: list[sp.Expr], w: sp.Matrix) -> list[sp.Expr]:
    return [Fc[i] * direction[i] + Fv[i] * w[i] for i in range(3)]


def friction_mode(d: Definitions, prefix: str, M: sp.Matrix, tau: sp.Matrix, w: sp.Matrix,
                  sliding_direction: list[sp.Expr], resting: list[sp.Basic], Fs: list[sp.Expr],
                  Fc: list[sp.Expr], Fv: list[sp.Expr]) -> FrictionMode:
    """Which axes stick, and the Coulomb sign of those that slide (stick-slip friction).

    Every quantity is recorded in ``d`` as a definition named ``prefix`` + name.

    Parameters
    ----------
    d : Definitions
        The model's definitions, extended here.
    prefix : str
        Prefix of the definitions' names (``"mode_"``, ``"post_"``), one per use.
    M : 3x3 sympy.Matrix
        Mass matrix (M[0, 2] = M[2, 0] the only coupling), kg m^2.
    tau : 3x1 sympy.Matrix
        Applied generalized torques without friction, G T + Td - N, N m.
    w : 3x1 sympy.Matrix
        Axis rates, rad/s.
    sliding_direction : list of 3 expressions
        Coulomb sign of an axis that is not at rest (the sign of its rate).
    resting : list of 3 sympy booleans
        Whether each axis is at rest (a candidate for sticking); an axis at rest that
        breaks away slides in the direction of its own applied torque.
    Fs, Fc, Fv : lists of 3 expressions
        Static, Coulomb (N m) and viscous (N m s/rad) coefficients.
    """
    n = [prefix + a for a in AXES]
    tau = [d(f"{n[i]}_tau", tau[i]) for i in range(3)]
    rest = [d.flag(f"{n[i]}_resting", resting[i]) for i in range(3)]
    holds = [d.flag(f"{n[i]}_holds", sp.Abs(tau[i]) <= Fs[i]) for i in range(3)]
    direction = [d(f"{n[i]}_direction", sp.Piecewise((sp.sign(tau[i]), is_set(rest[i])), (sliding_direction[i], True)))
                 for i in range(3)]
    F = _sliding(Fc, Fv, direction, w)
    # Gimbal 2 (index 1) is decoupled; rotor (0) and gimbal 4 (2) are coupled through M[0, 2].
    gimbal2 = d.flag(f"{n[1]}_stuck", sp.And(is_set(rest[1]), is_set(holds[1])))
    both = d.flag(f"{prefix}both_stuck", sp.And(*(is_set(f) for f in (rest[0], rest[2], holds[0], holds[2]))))
    hold_g4 = tau[2] - M[0, 2] * (tau[0] - F[0]) / M[0, 0]   # gimbal 4 held, rotor sliding
    g4_only = d.flag(f"{n[2]}_only_stuck", sp.And(is_set(rest[2]), sp.Abs(hold_g4) <= Fs[2],
                                                  sp.Or(sp.Not(is_set(rest[0])), sp.Not(is_set(holds[0])))))
    hold_r = tau[0] - M[0, 2] * (tau[2] - F[2]) / M[2, 2]    # rotor held, gimbal 4 sliding
    rotor_only = d.flag(f"{n[0]}_only_stuck", sp.And(is_set(rest[0]), sp.Abs(hold_r) <= Fs[0],
                                                     sp.Or(sp.Not(is_set(rest[2])), sp.Not(is_set(holds[2]))),
                                                     sp.Not(is_set(g4_only))))
    return FrictionMode(direction, gimbal2, both, g4_only, rotor_only)


def friction_dynamics(d: Definitions, prefix: str, M: sp.Matrix, tau: sp.Matrix, w: sp.Matrix,
                      mode: FrictionMode, Fc: list[sp.Expr], Fv: list[sp.Expr]
                      ) -> tuple[list[sp.Symbol], list[sp.Symbol]]:
    """Accelerations (rad/s^2) and friction torques (N m, opposing each axis) in a given mode.

    A stuck axis has zero acceleration and its friction is the torque that holds it.

    Parameters
    ----------
    d : Definitions
        The model's definitions; every quantity is recorded there as ``prefix`` + name.
    prefix : str
        Prefix of the definitions' names (``"rhs_"``).
    M : 3x3 sympy.Matrix
        Mass matrix (M[0, 2] = M[2, 0] the only coupling), kg m^2.
    tau : 3x1 sympy.Matrix
        Applied generalized torques without friction, G T + Td - N, N m.
    w : 3x1 sympy.Matrix
        Axis rates, rad/s.
    mode : FrictionMode
        Which axes stick and the Coulomb signs (:func:`friction_mode`).
    Fc, Fv : lists of 3 expressions
        Coulomb (N m) and viscous (N m s/rad) coefficients of rotor 1, gimbal 2, gimbal 4.

    Returns
    -------
    acc : list of sympy.Symbol
        Accelerations of the three axes, rad/s^2.
    friction : list of sympy.Symbol
        Friction torques opposing the three axes, N m.
    """
    n = [prefix + a for a in AXES]
    tau = [d(f"{n[i]}_tau", tau[i]) for i in range(3)]
    F = [d(f"{n[i]}_sliding", f) for i, f in enumerate(_sliding(Fc, Fv, mode.direction, w))]
    g2 = is_set(mode.gimbal2_stuck)
    a2 = sp.Piecewise((0, g2), ((tau[1] - F[1]) / M[1, 1], True))
    f2 = sp.Piecewise((tau[1], g2), (F[1], True))
    m = M[0, 2]
    det = M[0, 0] * M[2, 2] - m**2
    r0, r4 = tau[0] - F[0], tau[2] - F[2]
    a0_g4, a4_r = r0 / M[0, 0], r4 / M[2, 2]
    cases = (is_set(mode.both_stuck), is_set(mode.gimbal4_only), is_set(mode.rotor_only), True)
    a0 = sp.Piecewise(*zip((0, a0_g4, 0, (M[2, 2] * r0 - m * r4) / det), cases))
    a4 = sp.Piecewise(*zip((0, 0, a4_r, (M[0, 0] * r4 - m * r0) / det), cases))
    f0 = sp.Piecewise(*zip((tau[0], F[0], tau[0] - m * a4_r, F[0]), cases))
    f4 = sp.Piecewise(*zip((tau[2], tau[2] - m * a0_g4, F[2], F[2]), cases))
    acc = [d(f"{n[i]}_acc", a) for i, a in zip(range(3), (a0, a2, a4))]
    friction = [d(f"{n[i]}_friction", f) for i, f in zip(range(3), (f0, f2, f4))]
    return acc, friction


def build(q2_0: float = float(sp.pi / 18)) -> Model:
    """The symbolic VSCMG model.

    Parameters
    ----------
    q2_0 : float
        Default initial gimbal-2 angle, rad (the seed starts at pi/18: at q2 = 0 the rotor
        cannot act on gimbal 4).
    """
    inertia_vars = [Variable(k, "kg.m2", f"ECP-750 inertia {k}", v, min=1e-9) for k, v in INERTIAS_ECP750.items()]
    I = Inertias(*(v.symbol for v in inertia_vars))
    friction_on = Variable("friction_on", "1", "Apply the stick-slip friction of seed 002 Table 1", 1, "Boolean")
    coeffs = {kind: [Variable(f"{kind}{a}", unit, f"{label} friction of axis {a}", value, min=0.0)
                     for a, value in zip(AXES, FRICTION_TABLE_1[kind])]
              for kind, unit, label in (("Fs", "N.m", "Static"), ("Fc", "N.m", "Coulomb"),
                                        ("Fv", "N.m.s/rad", "Viscous"))}
    w_band = Variable("w_band", "rad/s", "An axis with |w| <= w_band is at rest (stiction test)", 1e-6,
                      min=0.0, max=1.0)
    sat_on = Variable("saturation_on", "1", "Clip T1, T2 at +-T1_max, +-T2_max", 1, "Boolean")
    limits = [Variable(f"T{a}_max", "N.m", f"Torque limit of motor {a} (when saturation_on)", v, min=0.0)
              for a, v in zip("12", TORQUE_LIMITS)]
    names = ("rotor 1", "gimbal 2", "gimbal 4")
    q_states = [State(Variable(f"q{a}", "rad", f"Angle of {n}"), Variable(f"q{a}_0", "rad", f"Initial angle of {n}", v))
                for a, n, v in zip(AXES, names, (0.0, q2_0, 0.0))]
    w_states = [State(Variable(f"w{a}", "rad/s", f"Rate of {n}"), Variable(f"w{a}_0", "rad/s", f"Initial rate of {n}"))
                for a, n in zip(AXES, names)]
    T = [Variable("T1", "N.m", "Commanded rotor-1 motor torque"),
         Variable("T2", "N.m", "Commanded gimbal-2 motor torque")]
    Td4 = Variable("Td4", "N.m", "Disturbance torque on gimbal 4")

    d = Definitions()
    q2 = q_states[1].symbol
    w = sp.Matrix([s.symbol for s in w_states])
    M = mass_matrix(q2, I)
    T_applied = [d(f"T{a}_applied", saturate(t.symbol, lim.symbol, sat_on.symbol))
                 for a, t, lim in zip("12", T, limits)]
    on = friction_on.symbol > sp.Rational(1, 2)
    Fs, Fc, Fv = ([v.symbol for v in coeffs[k]] for k in ("Fs", "Fc", "Fv"))

    def applied(angle: sp.Expr, rates: sp.Matrix) -> sp.Matrix:
        return sp.Matrix([T_applied[0], T_applied[1], Td4.symbol]) - gyroscopic(angle, rates, I)

    # Right-hand side: the friction mode is decided at the substep's start (frozen over it).
    band = w_band.symbol
    q2_prev = Model.previous("q2")
    w_prev = sp.Matrix([Model.previous(s.variable.name) for s in w_states])
    mode = friction_mode(d, "mode_", mass_matrix(q2_prev, I), applied(q2_prev, w_prev), w_prev,
                         [sp.sign(v) for v in w_prev], [sp.And(on, sp.Abs(v) <= band) for v in w_prev],
                         Fs, Fc, Fv)
    acc, friction = friction_dynamics(d, "rhs_", M, applied(q2, w), w, mode, Fc, Fv)
    frictionless = M.LUsolve(applied(q2, w))
    w_dot = [sp.Piecewise((acc[i], on), (frictionless[i], True)) for i in range(3)]

    # Post-step: stop an axis that came to rest (or crossed zero) and cannot break away.
    stopping = [d.flag(f"post_{a}_stopping", sp.And(on, sp.Or(sp.Abs(w[i]) <= band, w[i] * w_prev[i] < 0)))
                for i, a in enumerate(AXES)]
    w_stop = sp.Matrix([d(f"post_{a}_w", sp.Piecewise((0, is_set(stopping[i])), (w[i], True)))
                        for i, a in enumerate(AXES)])
    stop_mode = friction_mode(d, "post_", M, applied(q2, w_stop), w_stop, [sp.sign(v) for v in w_stop],
                              [is_set(f) for f in stopping], Fs, Fc, Fv)
    post = sp.Matrix([s.symbol for s in q_states]
                     + [sp.Piecewise((0, stop_mode.stuck[i]), (w[i], True)) for i in range(3)])

    s = sp.sin(q2)
    p1 = I.JD * (w[0] + s * w[2])
    p4 = I.JD * s * w[0] + (I.J2 + I.J1 * s**2) * w[2]
    energy = (w.T * M * w)[0] / 2
    outputs = ([Output(st.variable, st.symbol) for st in q_states + w_states]
               + [Output(Variable("p1", "N.m.s", "Rotor angular momentum JD (w1 + sin(q2) w4)"), p1),
                  Output(Variable("p4", "N.m.s", "Gimbal-4 angular momentum JD sin(q2) w1 + (J2 + J1 sin^2 q2) w4 "
                                  "(conserved without gimbal-4 torque)"), p4),
                  Output(Variable("energy", "J", "Kinetic energy (1/2) w^T M(q2) w"), energy),
                  Output(Variable("T1_applied", "N.m", "Rotor torque after saturation"), T_applied[0]),
                  Output(Variable("T2_applied", "N.m", "Gimbal-2 torque after saturation"), T_applied[1])]
               + [Output(Variable(f"friction{a}", "N.m", f"Friction torque opposing axis {a}"),
                         sp.Piecewise((friction[i], on), (0, True))) for i, a in enumerate(AXES)])

    return Model(
        name="vscmg",
        description="ECP Model 750 control moment gyroscope, gimbal 3 locked, stick-slip friction "
                    "(seed 002: SDRE tracking)",
        states=q_states + w_states, inputs=T + [Td4],
        parameters=inertia_vars + [friction_on] + coeffs["Fs"] + coeffs["Fc"] + coeffs["Fv"]
        + [w_band, sat_on] + limits,
        outputs=outputs, rhs=sp.Matrix([*w, *w_dot]), post_step=post,
        sdc=sdc_form(q2, w, I, "gyro_on_w2"), definitions=d,
        default_stop_time=15.0, default_step_size=0.01, default_h_max=1e-3)


def sdc_form(q2: sp.Expr, w: sp.Matrix, I: Inertias, factorization: str) -> SDCForm:
    """SDC form x' = A(x) x + B(x) [T1, T2, Td4] of the frictionless, unsaturated plant.

    Parameters
    ----------
    q2 : sympy.Expr
        Gimbal-2 angle, rad.
    w : sympy.Matrix
        Axis rates ``[w1, w2, w4]`` (rotor 1, gimbal 2, gimbal 4), 3 x 1, rad/s.
    I : Inertias
        The ECP-750 inertias (symbols or numbers), kg m^2.
    factorization : {"gyro_on_w2", "w1_free"}
        Which SDC factorization of the gyroscopic torques (:data:`FACTORIZATIONS`,
        :func:`sdc_gyroscopic`).

    Returns
    -------
    SDCForm
        A (6 x 6) and B (6 x 3) in the state ``[q1, q2, q4, w1, w2, w4]``, valid with
        ``friction_on = 0`` and ``saturation_on = 0``.
    """
    M = mass_matrix(q2, I)
    Minv = M.inv()
    A = sp.zeros(6, 6)
    A[0:3, 3:6] = sp.eye(3)
    A[3:6, 3:6] = -Minv * sdc_gyroscopic(q2, w, I, factorization)
    B = sp.zeros(6, 3)
    B[3:6, :] = Minv
    return SDCForm(A, B, ("T1", "T2", "Td4"), {"friction_on": 0.0, "saturation_on": 0.0})


def model_sdc(model: Model, factorization: str) -> SDCForm:
    """The SDC form of ``model`` (built by :func:`build`) with another factorization.

    Parameters
    ----------
    model : Model
        A VSCMG model of :func:`build`: its inertia parameters and states give the symbols.
    factorization : {"gyro_on_w2", "w1_free"}
        Which SDC factorization of the gyroscopic torques (:data:`FACTORIZATIONS`,
        :func:`sdc_gyroscopic`).

    Returns
    -------
    SDCForm
        The form of :func:`sdc_form` in the model's symbols.
    """
    syms = {v.name: v.symbol for v in model.parameters}
    I = Inertias(*(syms[k] for k in INERTIAS_ECP750))
    states = {s.variable.name: s.symbol for s in model.states}
    return sdc_form(states["q2"], sp.Matrix([states["w1"], states["w2"], states["w4"]]), I, factorization)


MODEL = build()


def measured_defaults() -> dict[str, float]:
    """Default initial value of each plant state by name (rad, rad/s): the start values of a
    controller's measured inputs and references, so that a host reading the controller before
    it sets the inputs (libcosim's initialization) evaluates the law at the plant's start
    (zero error, q2 = pi/18, away from the sin(q2) = 0 singularity of the backstepping law)."""
    return {s.variable.name: s.initial.start for s in MODEL.states}


def friction_compensation(measured: dict[str, sp.Symbol], errors: dict[str, sp.Expr],
                          command: list[sp.Expr]) -> tuple[list[sp.Expr], list[Variable]]:
    """Coulomb friction compensation torques [dT1, dT2] for a servo of this plant, N m.

    Gimbal 4 has no motor: its friction is countered through the rotor's reaction torque.
    Eliminating w1' from the rotor row of the equations of motion gives
    (J2 + (J1 - JD) s^2) w4' = -s (T1 - F1 - N1) - N3 - F4, so a gimbal-4 torque F4 needs
    dT1 = -F4 / s (s = sin q2, bounded below by 0.05 here). Each estimate is a smoothed
    Coulomb torque ``Fc_hat tanh(v / delta)`` in the direction v of the wanted motion:
    v = w + lambda e for the gimbals (motion, or the error while at rest), and for the rotor
    v = w1 + kappa T1 (its motion, or the commanded torque while at rest).

    Parameters
    ----------
    measured : dict
        Symbols of the measured ``q2``, ``w1``, ``w2``, ``w4``.
    errors : dict
        Tracking errors ``q2`` and ``q4`` (reference - measured), rad.
    command : list of 2 expressions
        The servo's own [T1, T2], N m.

    Returns
    -------
    torques : list of 2 expressions
        Added to [T1, T2] when the parameter ``compensation_on`` is true.
    parameters : list of Variable
        ``compensation_on`` (off by default), ``comp_lambda`` (1/s), ``comp_delta``
        (rad/s), ``comp_kappa`` (rad/s per N m) and the estimates ``Fc{1,2,4}_hat`` (N m,
        default Table 1).
    """
    on = Variable("compensation_on", "1", "Add the Coulomb friction compensation torques", 0, "Boolean")
    lam = Variable("comp_lambda", "1", "Weight (1/s) of the error in a gimbal's wanted-motion direction w + lambda e",
                   2.0, min=0.0)
    delta = Variable("comp_delta", "rad/s", "Smoothing width of the compensation's tanh sign", 1e-3, min=1e-9)
    kappa = Variable("comp_kappa", "1", "Weight (rad/s per N m) of the commanded T1 in the rotor's direction",
                     0.1, min=0.0)
    fc = [Variable(f"Fc{a}_hat", "N.m", f"Estimated Coulomb friction of axis {a}", v, min=0.0)
          for a, v in zip(AXES, FRICTION_TABLE_1["Fc"])]
    F1, F2, F4 = (v.symbol for v in fc)
    m = measured
    sign = lambda v: sp.tanh(v / delta.symbol)  # noqa: E731
    gimbal4 = -F4 * sign(m["w4"] + lam.symbol * errors["q4"]) / sp.Max(sp.sin(m["q2"]), sp.Rational(1, 20))
    rotor = F1 * sign(m["w1"] + kappa.symbol * (command[0] + gimbal4))
    gimbal2 = F2 * sign(m["w2"] + lam.symbol * errors["q2"])
    enabled = on.symbol > sp.Rational(1, 2)
    torques = [sp.Piecewise((gimbal4 + rotor, enabled), (0, True)), sp.Piecewise((gimbal2, enabled), (0, True))]
    return torques, [on, lam, delta, kappa] + fc
