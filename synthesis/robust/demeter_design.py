"""Deterministic robust design and analysis of a DEMETER variant (seed 004, sections 4.1, 5.1).

:func:`deterministic` runs the seed's pipeline on one :class:`~satfmu.synthesis.robust.demeter_variants.Variant`:

1. the design model's LFT (:meth:`~satfmu.synthesis.robust.demeter_variants.DesignModel.lft`) in scaled
   coordinates ``x = T x_s`` (:func:`state_scale`: the states' sizes, balanced, so the LMIs'
   entries are of comparable size; gains, bounds and poles do not depend on T);
2. :func:`satfmu.synthesis.robust.robust_design.design`: one Lyapunov matrix for H-infinity ``w1 -> z1``,
   impulse-to-peak ``w2 -> z2`` and the pole region ``-10 < Re s < -1e-4``, objective
   ``1 gamma + 100 nu``; D-G scalings for norm-bounded parameters (uncertainty types 1, 3),
   vertex separators for intervals (type 2), or D-G scalings there too when the vertex program
   is too large for the solver's memory (:func:`robust_multipliers`; three axes: 256 vertices);
3. deterministic analysis of the closed loop: H-infinity bound with a parameter-dependent
   Lyapunov function on the affine descriptor (:func:`satfmu.synthesis.robust.pdlf.pdlf_hinf`) and
   the impulse-to-peak bound with a common one (:func:`satfmu.synthesis.robust.robust_design.i2p_bound`);
4. an independent sampled check: ``n`` plants drawn in the box, closed-loop poles, exact
   H-infinity norms and impulse-to-peak values against the bounds.
"""
from __future__ import annotations

import logging
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.linalg import matrix_balance

from satfmu.controllers.artifact import design_plant_record
from satfmu.fmus.plants import demeter
from satfmu.fmus.plants.flexible_spacecraft import DEMETER
from satfmu.synthesis.core import solve_policy
from satfmu.synthesis.core.progress import Progress, Stages
from satfmu.synthesis.robust.demeter_variants import RATE_WORST, THETA_WORST, DesignModel, Variant, design_model
from satfmu.synthesis.robust.lft_plant import AffineDescriptor, LFTPlant, ProgramTooLargeError
from satfmu.synthesis.robust.pdlf import PDLFResult, pdlf_hinf
from satfmu.synthesis.robust.robust_design import RobustDesign, design, i2p_bound
from satfmu.synthesis.core.system_norms import hinf_norm, impulse_to_peak

LOG = logging.getLogger(__name__)

ALPHA = 1e-4
"""Pole region: Re s < -ALPHA, 1/s (seed: region('plane', -1e-4))."""
BETA = 10.0
"""Pole region: Re s > -BETA, 1/s (seed: region('plane', -10, pi))."""
W_HINF, W_I2P = 1.0, 100.0
"""The seed's objective weights, "+1*hinfty(usysIW1) +100*i2p(usysIW2)"."""



def seed_design(plant: LFTPlant | Sequence[LFTPlant], **kwargs: Any) -> RobustDesign:
    """:func:`~satfmu.synthesis.robust.robust_design.design` with the seed's objective weights and
    pole region (:data:`W_HINF`, :data:`W_I2P`, :data:`ALPHA`, :data:`BETA`).

    Parameters
    ----------
    plant : LFTPlant or sequence of LFTPlant
        The uncertain plant, or certain plants (a scenario design).
    **kwargs
        The other keyword arguments of :func:`~satfmu.synthesis.robust.robust_design.design`
        (``uncertainty``, ``convention``, ...).

    Returns
    -------
    RobustDesign
        The design.
    """
    return design(plant, w_hinf=W_HINF, w_i2p=W_I2P, alpha=ALPHA, beta=BETA, **kwargs)

def state_scale(dm: DesignModel) -> np.ndarray:
    """T of ``x = T x_s``: the states' sizes, balanced.

    Starts from the sizes in the seed's worst-case manoeuvre (rad for theta (15 deg), rad/s for
    theta' (0.08 deg/s), modal coordinates 0.1, their rates 0.01, xi 10 rad s, xw 0.1 N m s, wheel
    torque the wheels' torque limit satT (DEMETER: 5e-3 N m), its rate 10 satT per second), then
    balances the magnitudes of the open-loop
    couplings ``|A| + |Bp| |Cq|`` (:func:`scipy.linalg.matrix_balance`, powers of 2), so that no
    path of the loop is 10^3 times another: the slow momentum mode (-a) and the stiff flexible
    coupling then stay within the solver's relative accuracy (without this, the robust row-1
    program stalls in Clarabel).

    Parameters
    ----------
    dm : DesignModel
        The design model of the variant.

    Returns
    -------
    numpy.ndarray, shape (n,)
        T, each state's scale in its own unit (rad, rad/s, rad s, N m s, N m, ...) per unit of
        the scaled state.
    """
    na, nr = dm.na, dm.nr
    parts = [np.full(na, THETA_WORST), np.full(na, RATE_WORST), np.full(nr, 0.1), np.full(nr, 0.01),
             np.full(na, 10.0), np.full(na, 0.1)]
    if dm.variant.wheels:
        sat = dm.variant.spacecraft.wheels.torque_limit
        parts += [np.full(na, sat), np.full(na, 10 * sat)]
    T0 = np.concatenate(parts)
    L = dm.lft()
    coupling = np.abs(L["A"]) + np.abs(L["Bp"]) @ np.abs(L["Cq"])
    _, (s, _) = matrix_balance(coupling * T0[None, :] / T0[:, None], permute=False, separate=True)
    return T0 * s


def scaled_lft(dm: DesignModel, T: np.ndarray) -> LFTPlant:
    """The design model's LFT in the coordinates ``x_s = T^-1 x``, each uncertainty channel
    balanced (:meth:`satfmu.synthesis.robust.lft_plant.LFTPlant.balance_channels`).

    Parameters
    ----------
    dm : DesignModel
        The design model of the variant.
    T : numpy.ndarray, shape (n,)
        State scale of ``x = T x_s``, usually :func:`state_scale`.

    Returns
    -------
    LFTPlant
    """
    return LFTPlant(**dm.lft()).scale_states(T).balance_channels()


@dataclass
class CoincidentModes:
    """Why common-Lyapunov designs of a variant are infeasible: a free oscillator that no gain
    reaches, whose frequency sweeps the whole omega interval.

    When two mode groups with their own omega, zeta (``model_type`` 1) have the same values, a
    combination of their reduced coordinates (``n_r - n_axes`` of them) is decoupled from the
    body: ``L_r^T c`` drives every coordinate of a group along the coupling, and at equal
    frequencies the combinations orthogonal to the columns of ``L_r`` obey
    ``e'' + 2 zeta omega e' + omega^2 e = 0`` for every gain K. Its state ``C x`` is a quotient of
    the closed loop: ``C A_cl = A_osc C`` with C constant. A common Lyapunov matrix Y of the loop
    over the box (what D-G scalings and vertex separators certify) gives one of the oscillator,
    ``C Y C^T``, over ``omega`` in ``[omega_lo, omega_hi]``. Two stable 2 x 2 matrices have one iff
    ``A_lo A_hi`` and ``A_lo A_hi^-1`` have no negative real eigenvalue (Shorten & Narendra, Int.
    J. Adaptive Control Signal Process. 16, 2002), which needs
    ``zeta > (omega_hi - omega_lo) / (2 sqrt(omega_lo omega_hi))``: the largest zeta of the box
    is far below, so no gain exists, whatever L.

    Attributes
    ----------
    omega : tuple of float
        ``(omega_lo, omega_hi)``, the ends of the omega interval, rad/s.
    zeta : float
        Damping ratio at which the oscillators are compared: the largest of the box.
    required_zeta : float
        ``(omega_hi - omega_lo) / (2 sqrt(omega_lo omega_hi))``, the damping ratio a common
        Lyapunov matrix of the two ends would need.
    eigenvalues : numpy.ndarray, shape (2,)
        Eigenvalues of ``A_lo A_hi`` at the largest zeta.
    n_free : int
        Decoupled combinations at coincidence, ``n_r - n_axes``.
    """

    omega: tuple[float, float]
    zeta: float
    required_zeta: float
    eigenvalues: np.ndarray
    """Eigenvalues of ``A_lo A_hi`` at the largest zeta."""
    n_free: int
    """Decoupled combinations at coincidence, ``n_r - n_axes``."""

    @property
    def proves_infeasible(self) -> bool:
        ev = self.eigenvalues
        return bool(np.any((ev.real < 0) & (np.abs(ev.imag) <= 1e-9 * np.abs(ev))))


def oscillator(omega: float, zeta: float) -> np.ndarray:
    """``[[0, 1], [-omega^2, -2 zeta omega]]`` (omega in rad/s).

    Parameters
    ----------
    omega : float
        Natural frequency, rad/s.
    zeta : float
        Damping ratio.

    Returns
    -------
    numpy.ndarray, shape (2, 2)
        State matrix of ``e'' + 2 zeta omega e' + omega^2 e = 0`` in ``(e, e')``.
    """
    return np.array([[0.0, 1.0], [-omega**2, -2.0 * zeta * omega]])


def coincident_modes(variant: Variant) -> CoincidentModes | None:
    """The obstruction of :class:`CoincidentModes`, or None if the variant's groups cannot
    leave a coordinate undriven (one group, no more reduced coordinates than axes, groups
    whose frequency or damping intervals differ, or a known frequency: no sweep).

    Parameters
    ----------
    variant : Variant
        The model variant (its design model is built with the spacecraft's coupling; the
        obstruction does not depend on L).
    """
    dm = design_model(variant)
    if len(dm.groups) < 2 or dm.nr <= dm.na:
        return None
    spacecraft = variant.spacecraft
    if len({(spacecraft.groups[m[0]].frequency, spacecraft.groups[m[0]].damping) for m in dm.members}) > 1:
        return None
    omega = [p for p in dm.parameters if p.kind == "omega"]
    if not omega:
        return None
    zeta = [p for p in dm.parameters if p.kind == "zeta"]
    lo, hi = omega[0].value(-1.0), omega[0].value(1.0)
    z = zeta[0].value(1.0) if zeta else dm.fixed[("zeta", (0,))]
    ev = np.linalg.eigvals(oscillator(lo, z) @ oscillator(hi, z))
    return CoincidentModes((lo, hi), z, (hi - lo) / (2 * np.sqrt(lo * hi)), ev, dm.nr - dm.na)


@dataclass
class SampledCheck:
    """Closed loops of ``n`` plants drawn uniformly in the parameter box.

    Attributes
    ----------
    n : int
        Number of plants drawn.
    seed : int
        Seed of the generator (``numpy.random.default_rng``) that drew them.
    max_real_pole : float
        Largest real part of a closed-loop eigenvalue over the plants, 1/s.
    min_real_pole : float
        Smallest real part of a closed-loop eigenvalue over the plants, 1/s.
    hinf : numpy.ndarray, shape (n,)
        Exact H-infinity norm of ``w1 -> z1`` per plant, rad/(N m) (inf if unstable).
    i2p : numpy.ndarray, shape (n,)
        Impulse-to-peak value of ``w2 -> z2`` per plant (worst unit impulse direction), N m s
        (inf if unstable).
    """

    n: int
    seed: int
    max_real_pole: float
    min_real_pole: float
    hinf: np.ndarray
    i2p: np.ndarray

    @property
    def in_region(self) -> bool:
        return self.max_real_pole < -ALPHA and self.min_real_pole > -BETA


I2P_HORIZON, I2P_POINTS = 2000.0, 4001
"""Impulse-to-peak grid of the sampled checks: 2000 s, 0.5 s apart (the pseudo-integrator peaks
within the first few hundred seconds; the slowest closed-loop modes are near -3e-4 1/s)."""


def closed_loop_values(dm: DesignModel, K: np.ndarray, deltas: np.ndarray,
                       i2p_directions: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """Per plant of ``deltas`` (shape (S, N)), batched: ``max_real_pole``, ``min_real_pole`` (1/s),
    exact ``hinf`` of ``w1 -> z1`` (rad/(N m); inf if unstable) and ``i2p`` of ``w2 -> z2`` (N m s):
    the peak over the worst unit impulse direction of w2, or, with ``i2p_directions`` (S, m2),
    along each sample's own direction (the R-RoMulOC toolbox's probabilistic i2p analysis).

    Parameters
    ----------
    dm : DesignModel
        The design model.
    K : numpy.ndarray, shape (na, n)
        Gain of ``u = K x`` on the design states, in physical units.
    deltas : numpy.ndarray, shape (S, N)
        Normalized parameters of the plants, one per row, in [-1, 1].
    i2p_directions : numpy.ndarray, shape (S, m2), optional
        Unit impulse direction of w2 for each sample (``m2 = 2 na``); default the worst
        direction of each.

    Returns
    -------
    dict of str to numpy.ndarray
        ``"max_real_pole"``, ``"min_real_pole"``, ``"hinf"``, ``"i2p"``, each of shape (S,).
    """
    A, Bu, B1 = dm.state_space(np.reshape(deltas, (-1, len(dm.parameters))))
    Acl = A + Bu @ K
    re = np.linalg.eigvals(Acl).real
    stable = re.max(axis=1, initial=-np.inf) < 0
    hinf, i2p = np.full(len(Acl), np.inf), np.full(len(Acl), np.inf)
    if stable.any():
        hinf[stable] = hinf_norm(Acl[stable], B1[stable], dm.C1, np.zeros((dm.C1.shape[0], B1.shape[-1])))
        B2 = dm.B2 if i2p_directions is None else (dm.B2 @ np.asarray(i2p_directions, float)[stable, :, None])
        i2p[stable] = impulse_to_peak(Acl[stable], B2, dm.C2, I2P_HORIZON, I2P_POINTS)
    return {"max_real_pole": re.max(axis=1, initial=-np.inf), "min_real_pole": re.min(axis=1, initial=np.inf),
            "hinf": hinf, "i2p": i2p}


def sampled_check(dm: DesignModel, K: np.ndarray, n: int = 100, seed: int = 0) -> SampledCheck:
    """Poles, exact H-infinity norm ``w1 -> z1`` and impulse-to-peak ``w2 -> z2`` of ``n`` sampled loops.

    Parameters
    ----------
    dm : DesignModel
        The design model.
    K : numpy.ndarray, shape (na, n)
        Gain of ``u = K x`` on the design states, in physical units.
    n : int, optional
        Number of plants, drawn uniformly in the box (:meth:`DesignModel.sample`).
    seed : int, optional
        Seed of the generator that draws them.

    Returns
    -------
    SampledCheck
    """
    v = closed_loop_values(dm, K, dm.sample(n, np.random.default_rng(seed)))
    return SampledCheck(n, seed, float(v["max_real_pole"].max(initial=-np.inf)),
                        float(v["min_real_pole"].min(initial=np.inf)), v["hinf"], v["i2p"])


@dataclass
class DeterministicResult:
    """One Det row of Table 1: design bounds, analysis bounds, sampled check, seconds.

    Attributes
    ----------
    variant : Variant
        The model variant.
    uncertainty : {"norm", "vertex"}
        Multipliers of the design: D-G scalings or vertex separators (:func:`robust_multipliers`).
    design : RobustDesign
        The robust design, in the scaled coordinates ``x = T x_s`` (:func:`state_scale`).
    K : numpy.ndarray, shape (na, n), or None
        Gain of ``u = K x`` in physical units on the design states; None if no design.
    analysis_hinf : PDLFResult, optional
        H-infinity bound with a parameter-dependent Lyapunov function (None: not run or
        skipped).
    analysis_hinf_common : PDLFResult, optional
        The same with a common Lyapunov function.
    analysis_i2p : RobustDesign, optional
        Impulse-to-peak bound of the gain
        (:func:`satfmu.synthesis.robust.robust_design.i2p_bound`).
    analysis_skipped : str, optional
        Why the H-infinity analysis was skipped (empty if it ran).
    check : SampledCheck, optional
        The sampled check of the gain.
    seconds : dict of str to float, optional
        Wall time, s, of ``"design"``, ``"analysis"`` and ``"sampled check"``.
    obstruction : CoincidentModes, optional
        Set when the variant is provably infeasible for any common-Lyapunov design.
    note : str, optional
        Set when the design or the i2p analysis used D-G scalings in place of vertex separators.
    """

    variant: Variant
    uncertainty: str
    design: RobustDesign
    K: np.ndarray | None
    analysis_hinf: PDLFResult | None = None
    analysis_hinf_common: PDLFResult | None = None
    analysis_i2p: RobustDesign | None = None
    analysis_skipped: str = ""
    check: SampledCheck | None = None
    seconds: dict[str, float] = field(default_factory=dict)
    obstruction: CoincidentModes | None = None
    """Set when the variant is provably infeasible for any common-Lyapunov design."""
    note: str = ""
    """Set when the design or the i2p analysis used D-G scalings in place of vertex separators."""

    @property
    def feasible(self) -> bool:
        return self.K is not None


def uncertainty_kind(variant: Variant) -> str:
    """"vertex" for interval parameters (type 2), "norm" otherwise.

    Parameters
    ----------
    variant : Variant
        The model variant (its ``uncertainty_type``).
    """
    return "vertex" if variant.uncertainty_type == 2 else "norm"


def robust_multipliers(program, kind: str):
    """``program(kind)`` (a design or an analysis over the box with ``uncertainty=kind``), and
    the multipliers it used with a note: vertex separators, or D-G scalings when the vertex
    program exceeds the solver's memory (:class:`~satfmu.synthesis.robust.lft_plant.ProgramTooLargeError`).
    D-G scalings certify the same box for real parameters (also time-varying), with a smaller
    program (one LMI per specification instead of one per vertex) and more conservatism.

    Parameters
    ----------
    program : callable
        ``program(kind)`` runs the design or analysis with ``uncertainty=kind`` and returns
        its result.
    kind : {"norm", "vertex"}
        The multipliers asked for.

    Returns
    -------
    tuple
        ``(result, kind used, note)``; the note is empty unless D-G scalings replaced the
        vertex separators.

    Raises
    ------
    ProgramTooLargeError
        If the program is too large with ``kind="norm"`` (no smaller program to fall back on).
    """
    try:
        return program(kind), kind, ""
    except ProgramTooLargeError as exc:
        if kind != "vertex":
            raise
        return program("norm"), "norm", f"D-G scalings, the vertex program is too large: {exc}"


@dataclass
class Analysis:
    """Deterministic analysis of one gain over the whole box (:func:`analyse`); the H-infinity
    bounds are None when their program is too large (``skipped`` says why).

    Attributes
    ----------
    hinf : PDLFResult or None
        H-infinity bound of ``w1 -> z1`` with a parameter-dependent Lyapunov function.
    hinf_common : PDLFResult or None
        The same with a common Lyapunov function.
    i2p : RobustDesign
        Impulse-to-peak bound of ``w2 -> z2`` (:func:`satfmu.synthesis.robust.robust_design.i2p_bound`).
    seconds : float
        Wall time of the analysis, s.
    skipped : str, optional
        Why the H-infinity bounds are None (empty if they ran).
    i2p_note : str, optional
        Set when the i2p bound used D-G scalings in place of vertex separators (:func:`robust_multipliers`).
    """

    hinf: PDLFResult | None
    hinf_common: PDLFResult | None
    i2p: RobustDesign
    seconds: float
    skipped: str = ""
    i2p_note: str = ""
    """Set when the i2p bound used D-G scalings in place of vertex separators (:func:`robust_multipliers`)."""


def analyse(dm: DesignModel, K: np.ndarray, T: np.ndarray | None = None) -> Analysis:
    """H-infinity bounds with a parameter-dependent and with a common Lyapunov function (on the
    LFT's descriptor; skipped above :data:`satfmu.synthesis.robust.pdlf.PDLF_MAX_ENTRIES`) and the
    impulse-to-peak bound of ``u = K x`` (physical units), in the coordinates ``x = T x_s``
    (default :func:`state_scale`).

    Parameters
    ----------
    dm : DesignModel
        The design model.
    K : numpy.ndarray, shape (na, n)
        Gain of ``u = K x`` on the design states, in physical units.
    T : numpy.ndarray, shape (n,), optional
        State scale of the coordinates the programs are solved in; default :func:`state_scale`.

    Returns
    -------
    Analysis
    """
    t0 = time.perf_counter()
    T = state_scale(dm) if T is None else T
    plant = scaled_lft(dm, T)
    Ks = np.asarray(K, float) * T
    desc = AffineDescriptor.from_lft(plant)
    i2p, _, i2p_note = robust_multipliers(lambda kind: i2p_bound(plant, Ks, alpha=0.0, uncertainty=kind),
                                          uncertainty_kind(dm.variant))
    try:
        rungs = solve_policy.RungMemory()  # both programs of the same loop: the same rung solves
        hinf, common, skipped = pdlf_hinf(desc, Ks, ladder=rungs), pdlf_hinf(desc, Ks, common=True, ladder=rungs), ""
    except ProgramTooLargeError as exc:
        hinf, common, skipped = None, None, f"H-infinity analysis skipped: {exc}"
    return Analysis(hinf, common, i2p, time.perf_counter() - t0, skipped, i2p_note and f"i2p analysis: {i2p_note}")


def deterministic(variant: Variant, *, n_samples: int = 100, seed: int = 0, analysis: bool = True,
                  convention: str = "satfmu", progress: Progress | None = None) -> DeterministicResult:
    """Design, analyse and check one variant (see the module docstring); the design's LMIs and
    objective in ``convention`` (:func:`satfmu.synthesis.robust.robust_design.design`: ours, or the R-RoMulOC
    toolbox's); the analysis does not depend on it.

    Parameters
    ----------
    variant : Variant
        The model variant.
    n_samples : int, optional
        Plants of the sampled check (:func:`sampled_check`).
    seed : int, optional
        Seed of the sampled check.
    analysis : bool, optional
        Run the deterministic analysis of the gain (:func:`analyse`).
    convention : {"satfmu", "romuloc"}, optional
        How the levels enter the design's LMIs and objective.
    progress : callable, optional
        ``progress(done, total, message)`` after each stage (design, analysis, sampled check);
        the stages are logged too (:class:`satfmu.synthesis.core.progress.Stages`).

    Returns
    -------
    DeterministicResult
        With ``K`` None (and no analysis or check) when no design is found.
    """
    dm = design_model(variant)
    T = state_scale(dm)
    plant = scaled_lft(dm, T)
    stages = Stages(2 + bool(analysis), progress, LOG)
    t0 = time.perf_counter()
    with stages.stage(f"robust design of {variant.label}"):
        des, kind, note = robust_multipliers(lambda kind: seed_design(plant, uncertainty=kind, convention=convention),
                                             uncertainty_kind(variant))
    out = DeterministicResult(variant, kind, des, None if des.K is None else des.K / T,
                              seconds={"design": time.perf_counter() - t0}, obstruction=coincident_modes(variant),
                              note=note and f"design: {note}")
    if out.K is None:
        return out
    if analysis:
        if des.state_scaling is not None:  # the design's own well-conditioned coordinates
            T = T * des.state_scaling
        with stages.stage("analysis of the gain (PDLF H-infinity, impulse-to-peak)"):
            a = analyse(dm, out.K, T)
        out.analysis_hinf, out.analysis_hinf_common, out.analysis_i2p = a.hinf, a.hinf_common, a.i2p
        out.analysis_skipped = a.skipped
        out.note = "; ".join(n for n in (out.note, a.i2p_note) if n)
        out.seconds["analysis"] = a.seconds
    else:
        out.analysis_skipped = "Deterministic analysis not run (analysis=False)"
    t0 = time.perf_counter()
    with stages.stage(f"check on {n_samples} sampled plants"):
        out.check = sampled_check(dm, out.K, n_samples, seed)
    out.seconds["sampled check"] = time.perf_counter() - t0
    return out


def design_record(dm: DesignModel) -> dict:
    """``provenance.design_plant`` of a design over ``dm``'s box: the spacecraft's plant FMU's
    parameters at the box centre, with the interval each uncertain one spans over the box.

    Parameters
    ----------
    dm : DesignModel
        The design model whose box the design covers.

    Returns
    -------
    dict
        The record of :func:`satfmu.controllers.artifact.design_plant_record`.
    """
    n = len(dm.parameters)
    centre, lows, highs = (dm.fmu_parameters(np.full(n, d)) for d in (0.0, -1.0, 1.0))
    real = {k: float(v) for k, v in centre.items() if not isinstance(v, bool)}
    ranges = {k: (min(lows[k], highs[k]), max(lows[k], highs[k])) for k in real if lows[k] != highs[k]}
    return design_plant_record(demeter.model(dm.variant.spacecraft), list(real), real, ranges)


def artifact_data(result: DeterministicResult, name: str) -> dict:
    """The controller artifact (kind ``linear_state_feedback``) of a feasible design: the FMU
    gains, what was proved and on which box, the measured checks.

    Parameters
    ----------
    result : DeterministicResult
        A feasible result of :func:`deterministic` (with its sampled check).
    name : str
        Name of the controller artifact.

    Returns
    -------
    dict
        The artifact's data (format ``satfmu-controller``, version 1).

    Raises
    ------
    ValueError
        If the result has no gain or no sampled check.
    """
    d = result.design
    if result.K is None or d.gamma is None or d.nu is None:  # not result.feasible
        raise ValueError(f"{result.variant.label}: no design to save ({d.status})")
    if result.check is None:
        raise ValueError(f"{result.variant.label}: no sampled check to record (deterministic() makes it)")
    numbers = {"design_hinf_bound": d.gamma, "design_i2p_bound": d.nu,
               **checked_numbers(result.check, result.analysis_hinf, result.analysis_hinf_common, result.analysis_i2p),
               "design_seconds": result.seconds["design"]}
    forms = "satfmu's" if d.convention == "satfmu" else "the R-RoMulOC toolbox's"
    proved = (f"One Lyapunov matrix (quadratic stability, {d.uncertainty} multipliers, {forms} LMI forms and "
              f"objective, re-verified in numpy) "
              f"for the Fig. 3 design model of {result.variant.label}: closed-loop poles in "
              f"{-BETA:g} < Re s < {-ALPHA:g} 1/s, ||w1 -> z1||_inf < {d.gamma:.6g} rad/(N m), "
              f"impulse-to-peak w2 -> z2 < {d.nu:.6g} N m s, for every parameter in the box (also "
              f"time-varying). " + (f"Parameter-dependent analysis: ||w1 -> z1||_inf < "
                                    f"{numbers['analysis_hinf_pdlf']:.6g}. " if "analysis_hinf_pdlf" in numbers
                                    else f"{result.analysis_skipped}. ")
              + f"Sampled: {result.check.n} plants, seed {result.check.seed}.")
    return gain_artifact(result.variant, result.K, name, status="certified", proved=proved, numbers=numbers,
                         method="Det", convention=d.convention,
                         source="satfmu synth demeter (satfmu.synthesis.robust.demeter_design.deterministic)")


def checked_numbers(check: SampledCheck, hinf: PDLFResult | None = None, hinf_common: PDLFResult | None = None,
                    i2p: RobustDesign | None = None) -> dict[str, float]:
    """The certificate numbers of a gain's sampled check and of its deterministic analysis.

    Parameters
    ----------
    check : SampledCheck
        The gain's loops on sampled plants (:func:`sampled_check`).
    hinf, hinf_common : PDLFResult, optional
        Its H-infinity bounds over the box, parameter-dependent and common Lyapunov function.
    i2p : RobustDesign, optional
        Its impulse-to-peak bound over the box.

    Returns
    -------
    dict of str to float
        ``sampled_max_hinf`` (rad/(N m)), ``sampled_max_i2p`` (N m s), ``sampled_max_real_pole``,
        ``sampled_min_real_pole`` (1/s), and each analysis bound that was proved:
        ``analysis_hinf_pdlf``, ``analysis_hinf_common``, ``analysis_i2p``.
    """
    numbers = {"sampled_max_hinf": float(check.hinf.max()), "sampled_max_i2p": float(check.i2p.max()),
               "sampled_max_real_pole": check.max_real_pole, "sampled_min_real_pole": check.min_real_pole}
    for key, res, attr in (("analysis_hinf_pdlf", hinf, "gamma"), ("analysis_hinf_common", hinf_common, "gamma"),
                           ("analysis_i2p", i2p, "nu")):
        if res is not None and res.status == "optimal":
            numbers[key] = getattr(res, attr)
    return numbers


def gain_artifact(variant: Variant, K: np.ndarray, name: str, *, status: str, proved: str,
                  numbers: dict[str, float], method: str, convention: str, source: str) -> dict:
    """The controller artifact (kind ``linear_state_feedback``) of a gain on a variant's design
    model: the FMU gains, the certificate, the box, the design plant and the design record.

    Parameters
    ----------
    variant : Variant
        The model variant (its spacecraft names the plant and is recorded unless DEMETER).
    K : numpy.ndarray, shape (na, n)
        Gain of ``u = K x`` on the design states, physical units.
    name : str
        Name of the controller artifact.
    status : {"certified", "sampled"}
        The certificate's status.
    proved : str
        What was proved (or checked), in words with the numbers.
    numbers : dict of str to float
        The certificate's numbers.
    method : {"Det", "Prob"}
        The design method (Table 1's): deterministic robust or scenario design.
    convention : {"satfmu", "romuloc"}
        The LMI forms of the design.
    source : str
        The function that made it.

    Returns
    -------
    dict
        The artifact's data (format ``satfmu-controller``, version 1).
    """
    dm = design_model(variant)
    box = ", ".join(f"{p.name} in [{p.value(-1):.6g}, {p.value(1):.6g}]" for p in dm.parameters)
    sc = variant.spacecraft
    seed = sc == DEMETER
    what = {"Det": "deterministic robust", "Prob": "scenario (randomized)"}[method]
    return {"format": "satfmu-controller", "format_version": 1, "kind": "linear_state_feedback", "name": name,
            "description": f"{'Seed 004' if seed else 'Seed 004 method,'} {what} state feedback, {variant.label}",
            "plant": demeter.model_name(sc),
            "outputs": [{"name": f"u_c[{i + 1}]", "unit": "N.m", "description": f"Commanded wheel torque, axis {i + 1}"}
                        for i in range(3)],
            "gains": dm.fmu_gains(K),
            # a linear loop: the claims hold for every state; the box bounds the plant (design_plant.ranges)
            "certificate": {"status": status, "proved": proved, "region": box, "domain": [], "numbers": numbers},
            "provenance": {"source": source, "seed": f"004, Table 1 {method}" if seed
                           else f"004's method ({method}) for a user's spacecraft",
                           "coupling_L": "substitute (docs/models.md)" if seed
                           else f"the spacecraft description ({sc.name}, design.variant.spacecraft)",
                           "design_plant": design_record(dm)},
            "design": {"variant": variant.to_dict(), "states": dm.state_names, "K": np.asarray(K).tolist(),
                       "weights": {"hinf": W_HINF, "i2p": W_I2P}, "convention": convention}}
