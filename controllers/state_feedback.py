"""Static state feedback on a flexible spacecraft's design-model states (seed 004, Fig. 3), as a native FMU.

The law's own states are the designer's blocks of Fig. 3: the attitude-error integrator
``xi' = theta`` (rad s) and the input pseudo-integrator ``xw' = -a xw + u_c`` (N m s, the
wheel-momentum proxy, a = 1e-3 1/s). The command is linear in the plant's measured states and
these::

    u_c = K_theta theta + K_theta_dot theta' + K_eta eta + K_eta_dot eta'
          + K_xi xi + K_xw xw + K_torque y + K_torque_rate y'

with y, y' the wheel torque and its rate (the wheel states of the design model). The gains
are FMU parameters (3 x 3 blocks, 3 x nf for the plant's nf flexible coordinates: 8 for
DEMETER), so one FMU runs every design of a spacecraft: a design on reduced flexible
coordinates ``eta_r = Q eta`` enters as ``K_eta = K_r Q``
(:meth:`satfmu.synthesis.robust.demeter_variants.DesignModel.fmu_gains`). The inputs carry the names of the
plant's outputs, so the master connects them by name. The law is affine in its states and the
FMU steps it exactly (``integrator="exact"``).

A design's gain ``u = K x`` on the design model's states (:func:`design_states`) and the FMU's
gains are one law: :func:`design_gains` maps the one onto the other, and
:func:`gains_of_design` does it from an artifact's ``design`` record, so that loading an
artifact can check that its ``design.K`` and its ``gains`` agree (the campaigns use the first,
the FMU the second).
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import sympy as sp
from scipy.linalg import sqrtm

from satfmu.fmus.errors import SpacecraftError
from satfmu.fmus.plants import demeter
from satfmu.fmus.plants.flexible_spacecraft import DEMETER, FlexibleSpacecraft
from satfmu.fmus.model import Model, Output, Variable, states, symbols, vector

def gain_blocks(n_flex: int = demeter.N_FLEX) -> dict[str, tuple[str, int, str]]:
    """The law's gain blocks for a plant with ``n_flex`` flexible coordinates.

    Parameters
    ----------
    n_flex : int, optional
        Number of the plant's flexible coordinates (modes); default DEMETER's 8.

    Returns
    -------
    dict of str to (str, int, str)
        Gain block name -> (the signal it multiplies, the signal's length, the gain's unit).
    """
    return {"K_theta": ("theta", 3, "N.m/rad"), "K_theta_dot": ("theta_dot", 3, "N.m.s/rad"),
            "K_eta": ("eta", n_flex, "N.m"), "K_eta_dot": ("eta_dot", n_flex, "N.m.s"),
            "K_xi": ("xi", 3, "N.m/(rad.s)"), "K_xw": ("xw", 3, "1/s"),
            "K_torque": ("wheel_torque", 3, "1"), "K_torque_rate": ("wheel_torque_rate", 3, "s")}


GAIN_BLOCKS = gain_blocks()
"""Gain block name -> (signal, its length, unit of the gain), for DEMETER's 8 flexible coordinates."""


def build(gains: dict[str, float] | None = None, name: str = "demeter_state_feedback",
          description: str = "State feedback on the DEMETER design model (seed 004, Fig. 3)",
          n_flex: int = demeter.N_FLEX) -> Model:
    """The controller model; ``gains`` (``"K_theta[1,1]"``: value, ...) set the parameter defaults.

    Parameters
    ----------
    gains : dict, optional
        ``{"K_block[i,j]": value}`` of blocks of :func:`gain_blocks`, in the block's unit; the
        gains not given default to 0 (so does every gain without ``gains``).
    name : str, optional
        The model's name (the FMU's modelIdentifier).
    description : str, optional
        The model's description.
    n_flex : int, optional
        Number of the plant's flexible coordinates (the inputs ``eta``, ``eta_dot``); default
        DEMETER's 8 (:func:`design_spacecraft` gives a design's plant).

    Returns
    -------
    Model
        Inputs: the measured plant signals; states: ``xi[1..3]`` (rad s) and ``xw[1..3]``
        (N m s); outputs: ``u_c[1..3]`` (N m) and the states; parameters: every gain and
        ``pseudo_integrator_pole`` (1/s).

    Raises
    ------
    KeyError
        If ``gains`` names no gain of the law.
    """
    gains = dict(gains or {})
    meas = {"theta": vector("theta", 3, "rad", "Measured attitude angle about axis {i}"),
            "theta_dot": vector("theta_dot", 3, "rad/s", "Measured attitude rate about axis {i}"),
            "eta": vector("eta", n_flex, "1", "Measured flexible coordinate {i}"),
            "eta_dot": vector("eta_dot", n_flex, "1/s", "Measured rate of flexible coordinate {i}"),
            "wheel_torque": vector("wheel_torque", 3, "N.m", "Measured wheel torque about axis {i}"),
            "wheel_torque_rate": vector("wheel_torque_rate", 3, "N.m/s", "Measured wheel torque rate about axis {i}")}
    x_xi = states("xi", 3, "rad.s", "integral of the attitude error about axis {i}")
    x_xw = states("xw", 3, "N.m.s", "pseudo-integral 1/(s + a) of the command about axis {i}")
    a = Variable("pseudo_integrator_pole", "1/s", "a of the input pseudo-integrator 1/(s + a)", 1e-3, min=0.0)
    signals = {**{k: symbols(v) for k, v in meas.items()}, "xi": symbols(x_xi), "xw": symbols(x_xw)}
    params, law = [], sp.zeros(3, 1)
    for block, (signal, n, unit) in gain_blocks(n_flex).items():
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
                 driven_inputs=tuple(v.name for vs in meas.values() for v in vs),
                 rhs=rhs, default_stop_time=600.0, default_step_size=0.1, integrator="exact")


def flexible_groups(spacecraft: FlexibleSpacecraft, appendages: Sequence[int], model_type: int) -> list[list[int]]:
    """Plant flexible coordinates (0-based columns of L) of each group sharing omega and zeta.

    ``model_type`` 1: the spacecraft's own mode groups of the selected appendages
    (:attr:`~satfmu.fmus.plants.flexible_spacecraft.FlexibleSpacecraft.groups`: an appendage whose
    modes share their dynamics, as each of DEMETER's bending and torsion pairs, or a single
    mode); ``model_type`` 2: one group of every selected appendage's modes (identical appendages).

    Parameters
    ----------
    spacecraft : FlexibleSpacecraft
        The plant's spacecraft (its appendages' modes are the flexible coordinates).
    appendages : sequence of int
        Selected appendages, 1-based.
    model_type : {1, 2}
        The design model's type: 1, the spacecraft's mode groups; 2, one group of all.

    Returns
    -------
    list of list of int
        The coordinates of each group.
    """
    chosen = {a - 1 for a in appendages}
    cols = [list(g.columns) for g in spacecraft.groups if g.appendage in chosen]
    return [sum(cols, [])] if model_type == 2 else cols


COUPLING_RANK_TOL = 1e-9
"""Singular values of a group's coupling below this times the largest are zero (:func:`reduce_coupling`)."""


def reduce_coupling(L_g: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Reduced coupling and projection of one group: ``(L_r, Q)`` with ``L_g eta = L_r (Q eta)``
    and Q of orthonormal rows. With no more coordinates than axes, ``(L_g, I)``; with more and
    ``L_g`` of full row rank, ``L_r = (L_g L_g^T)^(1/2)``, ``Q = L_r^-1 L_g`` (the seed's
    section 2.6); with more and a lower rank r (couplings along fewer directions than axes),
    the r leading singular directions ``L_g = U S V^T``: ``L_r = U_r S_r``, ``Q = V_r^T``. The
    other combinations of the coordinates do not reach the body.

    Parameters
    ----------
    L_g : numpy.ndarray, shape (n_axes, n_coords)
        Coupling of the group's flexible coordinates to the selected axes (dimensionless).

    Returns
    -------
    L_r : numpy.ndarray, shape (n_axes, n_reduced)
        Reduced coupling: ``n_reduced = n_coords`` up to ``n_axes``, else the rank of ``L_g``
        (0 for a group that does not couple to the axes).
    Q : numpy.ndarray, shape (n_reduced, n_coords)
        Projection onto the reduced coordinates.
    """
    na, nc = L_g.shape
    if nc <= na:
        return L_g.copy(), np.eye(nc)
    U, sv, Vt = np.linalg.svd(L_g, full_matrices=False)
    rank = int(np.sum(sv > COUPLING_RANK_TOL * sv[0])) if sv[0] > 0 else 0
    if rank == na:
        L_r = np.real(sqrtm(L_g @ L_g.T))
        return L_r, np.linalg.solve(L_r, L_g)
    return U[:, :rank] * sv[:rank], Vt[:rank]


def reduction(axes: Sequence[int], groups: list[list[int]], L: np.ndarray
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The reduced flexible coordinates ``eta_r = Q eta`` of a design on ``axes`` (1-based).

    Parameters
    ----------
    axes : sequence of int
        Selected axes, 1-based.
    groups : list of list of int
        :func:`flexible_groups`.
    L : ndarray, shape (3, nf)
        Coupling of the plant's nf flexible coordinates to the body, 1 (only the rows of
        ``axes`` and the columns of ``groups`` are used).

    Returns
    -------
    L_r : ndarray, shape (n_axes, n_reduced)
        Reduced coupling.
    Q : ndarray, shape (n_reduced, nf)
        Projection onto the reduced coordinates.
    mode_group : ndarray of int, shape (n_reduced,)
        Group of each reduced coordinate.
    """
    ax = [a - 1 for a in axes]
    blocks_L, blocks_Q, mode_group = [], [], []
    for g, cols in enumerate(groups):
        L_r, Q = reduce_coupling(L[np.ix_(ax, cols)])
        Qf = np.zeros((Q.shape[0], L.shape[1]))
        Qf[:, cols] = Q
        blocks_L.append(L_r)
        blocks_Q.append(Qf)
        mode_group += [g] * L_r.shape[1]
    return np.hstack(blocks_L), np.vstack(blocks_Q), np.array(mode_group, int)


def design_states(axes: Sequence[int], n_reduced: int, wheels: bool) -> list[str]:
    """Names of the design model's states, in order: per axis theta, theta', then the reduced
    flexible coordinates eta_r and their rates, then per axis xi, xw (and the wheel's y, y').

    Parameters
    ----------
    axes : sequence of int
        Selected axes, 1-based.
    n_reduced : int
        Number of reduced flexible coordinates (rows of ``Q`` of :func:`reduction`).
    wheels : bool
        The design model has the wheel states (torque and its rate per axis).

    Returns
    -------
    list of str
        ``theta[a]``, ``theta_dot[a]``, ``eta_r[j]``, ``eta_r_dot[j]``, ``xi[a]``, ``xw[a]`` and,
        with ``wheels``, ``wheel_torque[a]``, ``wheel_torque_rate[a]``.
    """
    names = ([f"theta[{a}]" for a in axes] + [f"theta_dot[{a}]" for a in axes]
             + [f"eta_r[{j + 1}]" for j in range(n_reduced)] + [f"eta_r_dot[{j + 1}]" for j in range(n_reduced)]
             + [f"xi[{a}]" for a in axes] + [f"xw[{a}]" for a in axes])
    if wheels:
        names += [f"wheel_torque[{a}]" for a in axes] + [f"wheel_torque_rate[{a}]" for a in axes]
    return names


def design_gains(K: np.ndarray, axes: Sequence[int], wheels: bool, Q: np.ndarray) -> dict[str, float]:
    """The FMU's gains (every name of :func:`gain_blocks`) of ``u = K x`` on the design states.

    Parameters
    ----------
    K : ndarray, shape (n_axes, n)
        Gain on :func:`design_states`, in the units of the FMU's gains (N m per state unit).
    axes : sequence of int
        Selected axes, 1-based (the other axes get zero command).
    wheels : bool
        The design model has the wheel states.
    Q : ndarray, shape (n_reduced, nf)
        :func:`reduction`: a gain on ``eta_r`` enters as ``K_eta = K_r Q`` (nf the plant's
        flexible coordinates).

    Raises
    ------
    ValueError
        If K does not have the shape of the design or is not finite.
    """
    K = np.asarray(K, float)
    na, nr = len(axes), Q.shape[0]
    n = len(design_states(axes, nr, wheels))
    if K.shape != (na, n) or not np.all(np.isfinite(K)):
        raise ValueError(f"K must be a finite {na} x {n} matrix, got shape {K.shape}")
    ax = [a - 1 for a in axes]
    base = 2 * na + 2 * nr
    full = {name: np.zeros((3, size)) for name, (_, size, _) in gain_blocks(Q.shape[1]).items()}
    blocks = {"K_theta": 0, "K_theta_dot": na, "K_xi": base, "K_xw": base + na}
    if wheels:
        blocks.update(K_torque=base + 2 * na, K_torque_rate=base + 3 * na)
    for name, start in blocks.items():
        full[name][np.ix_(ax, ax)] = K[:, start:start + na]
    full["K_eta"][ax] = K[:, 2 * na:2 * na + nr] @ Q
    full["K_eta_dot"][ax] = K[:, 2 * na + nr:base] @ Q
    return {f"{name}[{i + 1},{j + 1}]": float(G[i, j]) for name, G in full.items()
            for i in range(G.shape[0]) for j in range(G.shape[1])}


def design_spacecraft(design: dict[str, Any]) -> FlexibleSpacecraft:
    """The spacecraft of an artifact's ``design`` record: its ``variant.spacecraft`` description,
    DEMETER when the record has none (the seed's designs).

    Parameters
    ----------
    design : dict
        ``{"variant": {..., "spacecraft": {...} (optional)}, ...}``.

    Returns
    -------
    FlexibleSpacecraft

    Raises
    ------
    ValueError
        If ``variant`` is not an object or its spacecraft is not a valid description (the
        message names the key).
    """
    variant = design.get("variant")
    if not isinstance(variant, dict):
        raise ValueError("variant: missing or not an object")
    if "spacecraft" not in variant:
        return DEMETER
    try:
        return FlexibleSpacecraft.from_dict(variant["spacecraft"], where="variant.spacecraft")
    except SpacecraftError as exc:
        raise ValueError(str(exc)) from None


def gains_of_design(design: dict[str, Any], L: np.ndarray) -> dict[str, float]:
    """:func:`design_gains` of an artifact's ``design`` record (``variant``, ``states``, ``K``).

    Parameters
    ----------
    design : dict
        ``{"variant": {"axes": [...], "appendages": [...], "model_type": 1 | 2, "wheels": bool,
        "spacecraft": {...} (optional, default DEMETER), ...}, "states": [...], "K": [[...]], ...}``.
    L : ndarray, shape (3, nf)
        The coupling the design used (its design plant's ``L[i,j]``, nf the spacecraft's modes).

    Raises
    ------
    ValueError
        Naming the key of the record that is malformed or does not match the variant
        (``states`` must be :func:`design_states` of the variant).
    """
    spacecraft = design_spacecraft(design)
    variant = design["variant"]
    axes, appendages = variant.get("axes"), variant.get("appendages")
    for key, sel, top in (("axes", axes, demeter.N_AXES), ("appendages", appendages, len(spacecraft.appendages))):
        if (not isinstance(sel, list) or not sel or len(set(sel)) != len(sel)
                or any(isinstance(i, bool) or not isinstance(i, int) or not 1 <= i <= top for i in sel)):
            raise ValueError(f"variant.{key}: must be distinct integers in 1..{top}, got {sel!r}")
    assert isinstance(axes, list) and isinstance(appendages, list)  # the loop above checked both
    if variant.get("model_type") not in (1, 2) or not isinstance(variant.get("wheels"), bool):
        raise ValueError(f"variant: model_type must be 1 or 2 and wheels true or false, got {variant!r}")
    L = np.asarray(L, float)
    if L.shape != (demeter.N_AXES, len(spacecraft.modes)):
        raise ValueError(f"variant.spacecraft: {spacecraft.name} has {len(spacecraft.modes)} modes, the coupling "
                         f"L has shape {L.shape}")
    _, Q, _ = reduction(axes, flexible_groups(spacecraft, appendages, variant["model_type"]), L)
    expected = design_states(axes, Q.shape[0], variant["wheels"])
    if design.get("states") != expected:
        raise ValueError(f"states: {design.get('states')!r} are not the variant's design states {expected}")
    try:
        K = np.array(design.get("K"), dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"K: not a numeric matrix ({exc})") from None
    try:
        return design_gains(K, axes, variant["wheels"], Q)
    except ValueError as exc:
        raise ValueError(f"K: {exc}") from None
