"""Plant "flexible DEMETER": rigid body with flexible appendages and reaction wheels (seed 004).

Seed: the seed 004 paper, eq. (4) and section 3; cleaned up in
docs/models.md, "Seed 004". Linearized attitude theta (3 axes, rad) and 2 nf flexible
coordinates eta (nf = 4 appendages x bending, torsion; appendage-major)::

    [ J        S L ] [theta'']   [ 0  0       ] [theta']   [ 0  0   ] [theta]   [ I ]
    [ L^T S    I   ] [eta''  ] + [ 0  2 Z W   ] [eta'  ] + [ 0  W^2 ] [eta  ] = [ 0 ] tau

with S = J^(1/2) taken, as the seed does, as diag(sqrt(J_ii)) (:func:`sqrt_inertia` also
gives the exact root), Z = diag(zeta_k I2), W = diag(omega_k I2). ``tau`` is the torque
applied to the body: the wheels' torque plus the disturbance ``T_d``.

Reaction wheels, per axis (section 3, ``u = s H(s) satW((1/s) satT(uc))``): the command
``u_c`` is clipped at ``wheel_torque_max`` and integrated into the momentum ``h_w``, which
stops at ``+-wheel_momentum_max`` (the integrator holds at the bound while the command
pushes outwards: a wheel at its speed limit); the wheel dynamics H(s) = wn^2 / (s^2 + 2 zw
wn s + wn^2) (a **substitute**: the seed gives no H) filter the momentum into ``h_f``, and
the applied torque is ``h_f'``. With ``wheels_on`` false the command is the body torque.

The model is linear apart from the wheel limits, whose law is frozen per integration
substep; the FMUs step it with the exact flow (``integrator="exact"``) and cut a step where
a wheel reaches its momentum bound, so any communication step is exact (no RK4 error).

Any spacecraft of this kind: :func:`build` takes a
:class:`~satfmu.fmus.plants.flexible_spacecraft.FlexibleSpacecraft` (hub inertia, appendages
with any number of modes, wheel limits and dynamics; default
:data:`~satfmu.fmus.plants.flexible_spacecraft.DEMETER`, the model ``demeter_flexible`` with the
seed's numbers); eta then has one coordinate per mode, and Z, W hold one ``zeta``, ``omega``
parameter per mode group (an appendage whose modes share them, as the seed's, or a single mode).

The matrices come from one function, :func:`second_order`, used with sympy symbols for the
FMU (solved through the Schur complement of the identity block, a 3 x 3 inverse) and with
numbers for :func:`state_space` (the direct model with a full inverse of M), which the tests
compare with the FMU.
"""
from __future__ import annotations

import itertools
from functools import lru_cache

import numpy as np
import sympy as sp

from satfmu.fmus.model import Definitions, Model, Output, Variable, states, symbols, vector
from satfmu.fmus.plants.flexible_spacecraft import (COUPLING_MAX, DAMPING_MAX, DEMETER, FREQUENCY_MIN,
                                                     FlexibleSpacecraft)

N_AXES = 3
N_APPENDAGES = len(DEMETER.appendages)
N_FLEX = len(DEMETER.modes)

J0 = DEMETER.tensor
"""Nominal inertia, kg m^2 (seed section 2.3)."""

L_SUBSTITUTE = DEMETER.coupling
"""Coupling matrix L (3 x 8), a **substitute** (the seed's reference value is not published):
columns [a1 bending, a1 torsion, a2 bending, ..., a4 torsion], every appendage coupled to every
axis; sigma_max = 0.51 (docs/models.md)."""

OMEGA_RANGE = (DEMETER.groups[0].frequency.low, DEMETER.groups[0].frequency.high)
"""Interval of the appendages' natural frequencies, rad/s."""
ZETA_RANGE = (DEMETER.groups[0].damping.low, DEMETER.groups[0].damping.high)
"""Interval of the appendages' damping ratios."""
OMEGA_NOMINAL = sum(OMEGA_RANGE) / 2
ZETA_NOMINAL = sum(ZETA_RANGE) / 2

WHEEL_TORQUE_MAX = DEMETER.wheels.torque_limit
"""satT, N m."""
WHEEL_MOMENTUM_MAX = DEMETER.wheels.momentum_limit
"""satW, N m s."""
WHEEL_WN = DEMETER.wheels.natural_frequency
"""Natural frequency of the substitute wheel dynamics H(s), rad/s."""
WHEEL_ZETA = DEMETER.wheels.damping
"""Damping of the substitute wheel dynamics H(s) (Re of its poles -zw wn = -8.8 rad/s, inside
the design's pole region Re > -10)."""

TINY = 1e-300
SNAP = 1e-12
"""Relative distance to the momentum bound under which a wheel is put on the bound (rounding of
the step that ends exactly at the bound)."""


def sqrt_inertia(J: np.ndarray, exact: bool = False) -> np.ndarray:
    """The root S of J in eq. (4): diag(sqrt(J_ii)) as in the seed, or the symmetric root.

    Parameters
    ----------
    J : numpy.ndarray, shape (3, 3)
        Inertia matrix of the body, kg m^2 (any square size is accepted).
    exact : bool, optional
        Return the symmetric positive definite root ``V diag(sqrt(w)) V^T`` instead of the
        seed's ``diag(sqrt(J_ii))``. Default False.

    Returns
    -------
    numpy.ndarray, shape (3, 3)
        The root S, kg^(1/2) m.

    Raises
    ------
    ValueError
        If J is not a finite symmetric positive definite matrix.
    """
    J = np.asarray(J, float)
    if J.ndim != 2 or J.shape[0] != J.shape[1] or not np.all(np.isfinite(J)) or not np.allclose(J, J.T):
        raise ValueError(f"J must be a finite symmetric square matrix, got {J!r}")
    w, V = np.linalg.eigh(J)
    if w.min() <= 0:
        raise ValueError(f"J is not positive definite (smallest eigenvalue {w.min():g} kg m^2)")
    return (V * np.sqrt(w)) @ V.T if exact else np.diag(np.sqrt(np.diag(J)))


def second_order(J: np.ndarray, S: np.ndarray, L: np.ndarray, zeta: np.ndarray, omega: np.ndarray,
                 pairs: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``M q'' + C q' + K q = F tau`` of eq. (4), q = (theta, eta): numbers or sympy objects.

    Parameters
    ----------
    J, S : array, shape (na, na)
        Inertia (kg m^2) and its root.
    L : array, shape (na, nf)
        Coupling of the flexible coordinates (bending, torsion of each appendage, appendage-major).
    zeta, omega : array, shape (nf / 2,), or (nf,) with ``pairs=False``
        Damping ratio and natural frequency (rad/s) of each appendage (bending and torsion
        share them), or of each coordinate.
    pairs : bool, optional
        ``zeta`` and ``omega`` give one value per appendage, repeated for its two coordinates
        (default True); False: one value per flexible coordinate.

    Returns
    -------
    M, C, K : arrays, shape (na + 2 nm, na + 2 nm)
    F : array, shape (na + 2 nm, na)
    """
    J, S, L = (np.asarray(a) for a in (J, S, L))
    na, nf = L.shape
    z = np.repeat(np.asarray(zeta), 2 if pairs else 1)
    w = np.repeat(np.asarray(omega), 2 if pairs else 1)
    if J.shape != (na, na) or S.shape != (na, na) or z.shape != (nf,) or w.shape != (nf,):
        raise ValueError(f"inconsistent shapes: J {J.shape}, S {S.shape}, L {L.shape}, "
                         f"zeta {np.shape(zeta)}, omega {np.shape(omega)}")
    SL = S @ L
    zero_a = np.zeros((na, na), dtype=SL.dtype)
    zero_af = np.zeros((na, nf), dtype=SL.dtype)
    M = np.block([[J, SL], [SL.T, np.eye(nf, dtype=SL.dtype)]])
    C = np.block([[zero_a, zero_af], [zero_af.T, np.diag(2 * z * w)]])
    K = np.block([[zero_a, zero_af], [zero_af.T, np.diag(w * w)]])
    F = np.vstack([np.eye(na, dtype=SL.dtype), zero_af.T])
    return M, C, K, F


def state_space(J: np.ndarray, L: np.ndarray, zeta: np.ndarray, omega: np.ndarray, *,
                exact_root: bool = False, pairs: bool = True,
                groups: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Direct first-order model ``x' = A x + B tau``, x = (theta, theta', eta, eta').

    Built with a full inverse of M (independent of the FMU's Schur-complement route);
    ``zeta``, ``omega`` as in :func:`second_order`, or per mode group with ``groups``. For a
    flexible spacecraft ``sc`` at its nominal values: ``state_space(sc.tensor, sc.coupling,
    sc.nominal_damping, sc.nominal_frequency, groups=sc.mode_group)``.

    Parameters
    ----------
    J : numpy.ndarray, shape (na, na)
        Inertia matrix, kg m^2.
    L : numpy.ndarray, shape (na, nf)
        Coupling of the flexible coordinates (appendage-major: bending, torsion of each).
    zeta : numpy.ndarray, shape (nf / 2,), or (nf,) with ``pairs=False``
        Damping ratio of each appendage (or coordinate).
    omega : numpy.ndarray, shape (nf / 2,), or (nf,) with ``pairs=False``
        Natural frequency of each appendage (or coordinate), rad/s.
    exact_root : bool, optional
        Use the symmetric root of J for S instead of the seed's ``diag(sqrt(J_ii))``
        (:func:`sqrt_inertia`). Default False.
    pairs : bool, optional
        One ``zeta``, ``omega`` per appendage (default True) or per coordinate.
    groups : numpy.ndarray of int, shape (nf,), optional
        The group of each flexible coordinate
        (:attr:`~satfmu.fmus.plants.flexible_spacecraft.FlexibleSpacecraft.mode_group`): ``zeta``,
        ``omega`` then hold one value per group and ``pairs`` is ignored.

    Returns
    -------
    A : numpy.ndarray, shape (2 (na + nf), 2 (na + nf))
        State matrix, states ordered (theta, theta', eta, eta').
    B : numpy.ndarray, shape (2 (na + nf), na)
        Input matrix of the body torque ``tau`` (N m).
    """
    if groups is not None:
        zeta, omega, pairs = np.asarray(zeta)[groups], np.asarray(omega)[groups], False
    M, C, K, F = second_order(J, sqrt_inertia(J, exact_root), L, zeta, omega, pairs)
    n = M.shape[0]
    MinvKCF = np.linalg.solve(M, np.hstack([K, C, F]))
    na = F.shape[1]
    A = np.zeros((2 * n, 2 * n))
    B = np.zeros((2 * n, na))
    # order (theta, theta', eta, eta') from q = (theta, eta), q' = (theta', eta')
    order = list(range(na)) + list(range(n, n + na)) + list(range(na, n)) + list(range(n + na, 2 * n))
    A[:n, n:] = np.eye(n)
    A[n:, :n] = -MinvKCF[:, :n]
    A[n:, n:] = -MinvKCF[:, n:2 * n]
    B[n:] = MinvKCF[:, 2 * n:]
    P = np.eye(2 * n)[order]
    return P @ A @ P.T, P @ B


def wheel_state_space(wn: float = WHEEL_WN, zw: float = WHEEL_ZETA) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One wheel without limits, states (h_w, h_f, h_f'): ``x' = A x + B u_c``, torque ``C x``.

    Parameters
    ----------
    wn : float, optional
        Natural frequency of the wheel dynamics H(s), rad/s; default :data:`WHEEL_WN`.
    zw : float, optional
        Damping ratio of H(s); default :data:`WHEEL_ZETA`.

    Returns
    -------
    A : numpy.ndarray, shape (3, 3)
    B : numpy.ndarray, shape (3, 1)
        Input matrix of the torque command ``u_c`` (N m).
    C : numpy.ndarray, shape (1, 3)
        Output matrix of the applied torque ``h_f'`` (N m).
    """
    A = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [wn**2, -wn**2, -2 * zw * wn]])
    return A, np.array([[1.0], [0.0], [0.0]]), np.array([[0.0, 0.0, 1.0]])


def parameter_values(J: np.ndarray | None = None, L: np.ndarray | None = None,
                     zeta: np.ndarray | None = None, omega: np.ndarray | None = None, *,
                     spacecraft: FlexibleSpacecraft = DEMETER) -> dict[str, float]:
    """FMU parameter names and values of a concrete plant (defaults: the spacecraft's nominal
    values; for ``DEMETER`` the nominal J0, substitute L, interval midpoints).

    Parameters
    ----------
    J : numpy.ndarray, shape (3, 3), optional
        Inertia matrix, kg m^2 (its upper triangle is used); default the spacecraft's.
    L : numpy.ndarray, shape (3, nf), optional
        Coupling matrix (nf modes; 3 x 8 for DEMETER); default the spacecraft's.
    zeta : numpy.ndarray, shape (ng,), optional
        Damping ratio of each mode group (each appendage for DEMETER, ng = 4); default the
        nominal values.
    omega : numpy.ndarray, shape (ng,), optional
        Natural frequency of each mode group, rad/s; default the nominal values.
    spacecraft : FlexibleSpacecraft, optional
        The plant's spacecraft (its modes and mode groups give the shapes); default ``DEMETER``.

    Returns
    -------
    dict of str to float
        Values by FMU parameter name (``"J[1,2]"``, ``"L[2,5]"``, ``"zeta[3]"``, ``"omega[4]"``).

    Raises
    ------
    ValueError
        If a matrix or vector has the wrong shape.
    """
    J = spacecraft.tensor if J is None else np.asarray(J, float)
    L = spacecraft.coupling if L is None else np.asarray(L, float)
    zeta = spacecraft.nominal_damping if zeta is None else np.asarray(zeta, float)
    omega = spacecraft.nominal_frequency if omega is None else np.asarray(omega, float)
    nf, ng = len(spacecraft.modes), len(spacecraft.groups)
    if J.shape != (3, 3) or L.shape != (3, nf) or zeta.shape != (ng,) or omega.shape != (ng,):
        raise ValueError(f"J must be 3x3, L 3x{nf}, zeta and omega {ng} values each")
    out = {f"J[{i + 1},{j + 1}]": float(J[i, j]) for i, j in _upper()}
    out.update({f"L[{i + 1},{j + 1}]": float(L[i, j]) for i in range(3) for j in range(nf)})
    out.update({f"zeta[{k + 1}]": float(zeta[k]) for k in range(ng)})
    out.update({f"omega[{k + 1}]": float(omega[k]) for k in range(ng)})
    return out


def _upper() -> list[tuple[int, int]]:
    return [(i, i) for i in range(3)] + [(i, j) for i, j in itertools.combinations(range(3), 2)]


def model_name(spacecraft: FlexibleSpacecraft) -> str:
    """The name of the plant model of ``spacecraft``: ``"demeter_flexible"`` for ``DEMETER``, else
    ``"flexible_<name>"`` (the spacecraft checks its name: a letter, then letters, digits, '_').

    Parameters
    ----------
    spacecraft : FlexibleSpacecraft
        The spacecraft.

    Returns
    -------
    str
        The model name (the FMU's modelIdentifier).
    """
    return "demeter_flexible" if spacecraft == DEMETER else f"flexible_{spacecraft.name}"


def build(spacecraft: FlexibleSpacecraft = DEMETER) -> Model:
    """The symbolic flexible plant of ``spacecraft`` (3 axes, its appendages, 3 reaction wheels).

    Parameters
    ----------
    spacecraft : FlexibleSpacecraft, optional
        Its inertia (kg m^2), couplings, nominal mode frequencies (rad/s) and damping ratios and
        wheel limits (N m, N m s) and dynamics are the parameters' defaults; its modes give the
        flexible coordinates, its mode groups the ``zeta[g]``, ``omega[g]`` parameters. Default
        :data:`~satfmu.fmus.plants.flexible_spacecraft.DEMETER` (the model ``demeter_flexible``);
        another spacecraft gives a model named by :func:`model_name`.

    Returns
    -------
    Model
        The plant, states (theta, theta_dot, eta, eta_dot, h_w, h_f, h_f_dot), inputs
        (u_c, T_d).
    """
    J0s, Ls, w = spacecraft.tensor, spacecraft.coupling, spacecraft.wheels
    nf, groups = Ls.shape[1], spacecraft.groups
    jvars = {(i, j): Variable(f"J[{i + 1},{j + 1}]", "kg.m2",
                              f"Inertia {'moment' if i == j else 'product'} J{i + 1}{j + 1}",
                              start=float(J0s[i, j]), min=1e-6 if i == j else None)
             for i, j in _upper()}
    lvars = [[Variable(f"L[{i + 1},{j + 1}]", "1",
                       f"Coupling of flexible coordinate {j + 1} (appendage {a + 1} {mode.kind}) with axis {i + 1}",
                       start=float(Ls[i, j]), min=-COUPLING_MAX, max=COUPLING_MAX)
              for j, (a, mode) in enumerate(spacecraft.modes)] for i in range(3)]
    labels = [f"appendage {g.appendage + 1}" + ("" if g.kind is None else f" {g.kind}") for g in groups]
    zvars = [Variable(f"zeta[{k + 1}]", "1", f"Damping ratio of {label}", g.damping.nominal, min=0.0,
                      max=DAMPING_MAX) for k, (g, label) in enumerate(zip(groups, labels))]
    wvars = [Variable(f"omega[{k + 1}]", "rad/s", f"Natural frequency of {label}", g.frequency.nominal,
                      min=FREQUENCY_MIN) for k, (g, label) in enumerate(zip(groups, labels))]
    wheels_on = Variable("wheels_on", "1", "Reaction wheels between the command and the body "
                         "(false: the command is the body torque)", 1, "Boolean")
    t_max = Variable("wheel_torque_max", "N.m", "Wheel torque limit satT", w.torque_limit, min=1e-12)
    h_max = Variable("wheel_momentum_max", "N.m.s", "Wheel momentum limit satW", w.momentum_limit, min=1e-12)
    wn = Variable("wheel_wn", "rad/s", "Natural frequency of the wheel dynamics H(s)", w.natural_frequency,
                  min=1e-6)
    zw = Variable("wheel_zeta", "1", "Damping ratio of the wheel dynamics H(s)", w.damping, min=0.0)

    x_th = states("theta", 3, "rad", "attitude angle about axis {i}")
    x_thd = states("theta_dot", 3, "rad/s", "attitude rate about axis {i}")
    x_eta = states("eta", nf, "1", "flexible coordinate {i} (mass-normalized, sqrt(kg m^2))")
    x_etad = states("eta_dot", nf, "1/s", "rate of flexible coordinate {i}")
    x_hw = states("h_w", 3, "N.m.s", "momentum of wheel {i} (integrated clipped command, limited)")
    x_hf = states("h_f", 3, "N.m.s", "momentum of wheel {i} through the wheel dynamics H(s)")
    x_hfd = states("h_f_dot", 3, "N.m", "torque of wheel {i} on the body (derivative of h_f)")
    uc = vector("u_c", 3, "N.m", "Commanded wheel torque about axis {i}")
    td = vector("T_d", 3, "N.m", "Disturbance torque on the body about axis {i}")

    d = Definitions()
    Jsym = np.empty((3, 3), dtype=object)
    for (i, j), v in jvars.items():
        Jsym[i, j] = Jsym[j, i] = v.symbol
    S = np.diag([d(f"sqrt_J{i + 1}", sp.sqrt(Jsym[i, i])) for i in range(3)])
    L = np.array([[v.symbol for v in row] for row in lvars], dtype=object)
    group = spacecraft.mode_group
    M, C, K, F = (sp.Matrix(a) for a in second_order(Jsym, S, L, np.array([v.symbol for v in zvars])[group],
                                                      np.array([v.symbol for v in wvars])[group], pairs=False))
    na = 3
    M11, M12 = M[:na, :na], M[:na, na:]
    if M[na:, na:] != sp.eye(nf) or C[:na, :] != sp.zeros(na, C.shape[1]) or K[:na, :] != sp.zeros(na, K.shape[1]):
        raise AssertionError("second_order no longer has the identity block the Schur route assumes")
    # Schur complement of the identity block: Jr theta'' = tau + M12 (C22 eta' + K22 eta)
    Jr = M11 - M12 * M12.T
    jr = sp.Matrix(3, 3, lambda i, j: 0)
    for i, j in _upper():
        jr[i, j] = jr[j, i] = d(f"Jr{i + 1}{j + 1}", Jr[i, j])
    det = d("Jr_det", jr.det())
    adj = jr.adjugate()
    jinv = sp.Matrix(3, 3, lambda i, j: 0)
    for i, j in _upper():
        jinv[i, j] = jinv[j, i] = d(f"Jr_inv{i + 1}{j + 1}", adj[i, j] / det)

    th, thd, eta, etad = (symbols(v) for v in (x_th, x_thd, x_eta, x_etad))
    hw, hf, hfd = symbols(x_hw), symbols(x_hf), symbols(x_hfd)
    on = wheels_on.symbol > sp.Rational(1, 2)
    Tm, Hm, wns, zws = t_max.symbol, h_max.symbol, wn.symbol, zw.symbol
    r = [sp.Max(-Tm, sp.Min(Tm, v.symbol)) for v in uc]
    hw_prev = [Model.previous(s.variable.name) for s in x_hw]
    pushing = [sp.Or(sp.And(hp >= Hm, ri > 0), sp.And(hp <= -Hm, ri < 0)) for hp, ri in zip(hw_prev, r)]
    hw_dot = [sp.Piecewise((0, push), (ri, True)) for push, ri in zip(pushing, r)]
    hf_ddot = [wns**2 * (hw[i] - hf[i]) - 2 * zws * wns * hfd[i] for i in range(3)]
    tau = sp.Matrix([sp.Piecewise((hfd[i], on), (uc[i].symbol, True)) + td[i].symbol for i in range(3)])
    flex = C[na:, na:] * etad + K[na:, na:] * eta
    th_dd = jinv * (tau + M12 * flex)
    eta_dd = -M12.T * th_dd - flex
    rhs = sp.Matrix(list(thd) + list(th_dd) + list(etad) + list(eta_dd) + hw_dot + list(hfd) + hf_ddot)

    def reach(h: sp.Expr, ri: sp.Expr) -> sp.Expr:
        # the guarded denominators keep the divisions that code generation hoists finite at ri = 0
        return sp.Piecewise(((Hm - h) / sp.Max(ri, TINY), sp.And(ri > 0, h < Hm)),
                            ((-Hm - h) / sp.Min(ri, -TINY), sp.And(ri < 0, h > -Hm)), (sp.oo, True))

    switch = sp.Piecewise((sp.Min(*[reach(hw[i], r[i]) for i in range(3)]), on), (sp.oo, True))
    snap = [sp.Piecewise((Hm, h >= Hm * (1 - SNAP)), (-Hm, h <= -Hm * (1 - SNAP)), (h, True)) for h in hw]
    post = sp.Matrix([s.symbol for s in x_th + x_thd + x_eta + x_etad] + snap + list(hf) + list(hfd))

    all_states = x_th + x_thd + x_eta + x_etad + x_hw + x_hf + x_hfd
    outputs = [Output(s.variable, s.symbol) for s in all_states]
    # 0 without wheels rather than the command: no direct feedthrough (a loop through a controller)
    outputs += [Output(Variable(f"wheel_torque[{i + 1}]", "N.m", f"Torque of wheel {i + 1} on the body "
                                "(0 without wheels)"), sp.Piecewise((hfd[i], on), (0, True))) for i in range(3)]
    outputs += [Output(Variable(f"wheel_torque_rate[{i + 1}]", "N.m/s", f"Rate of the wheel torque about axis "
                                f"{i + 1} (0 without wheels)"), sp.Piecewise((hf_ddot[i], on), (0, True)))
                for i in range(3)]
    outputs += [Output(Variable(f"wheel_saturated[{i + 1}]", "1", f"Wheel {i + 1} at its momentum limit "
                                "(1) or not (0)"), sp.Piecewise((1, sp.And(on, sp.Abs(hw[i]) >= Hm)), (0, True)))
                for i in range(3)]
    params = (list(jvars.values()) + [v for row in lvars for v in row] + zvars + wvars
              + [wheels_on, t_max, h_max, wn, zw])
    if spacecraft == DEMETER:
        description = ("DEMETER satellite, linearized attitude with 4 flexible appendages and 3 reaction "
                       "wheels (seed 004: robust and randomized LMI design)")
    else:
        description = (f"Flexible spacecraft {spacecraft.name}, linearized attitude with "
                       f"{len(spacecraft.appendages)} flexible appendage(s) ({nf} modes) and 3 reaction wheels "
                       "(the plant of seed 004, eq. (4))")
    return Model(
        name=model_name(spacecraft),
        description=description,
        states=all_states, inputs=uc + td, parameters=params, outputs=outputs, rhs=rhs, post_step=post,
        definitions=list(d), default_stop_time=600.0, default_step_size=0.1, integrator="exact",
        switch_time=switch)



@lru_cache(maxsize=None)
def model(spacecraft: FlexibleSpacecraft = DEMETER) -> Model:
    """The plant model of ``spacecraft`` (default ``DEMETER``), built on first use (about 2 s of
    sympy for DEMETER in a fresh process, 0.5 s once sympy is warm), then shared.

    Parameters
    ----------
    spacecraft : FlexibleSpacecraft, optional
        The spacecraft (:func:`build`). Default ``DEMETER``.

    Returns
    -------
    Model
        :func:`build` of ``spacecraft``.
    """
    return build(spacecraft)


def __getattr__(name: str) -> Model:
    """``satfmu.fmus.plants.demeter.MODEL``: :func:`model` (so importing this module costs nothing)."""
    if name == "MODEL":
        return model()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
