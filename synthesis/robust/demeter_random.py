"""Randomized design and analysis of a DEMETER variant (seed 004, sections 4.2, 5.2).

- :func:`scenario`: the scenario approach. The design LMIs of
  :func:`satfmu.synthesis.robust.demeter_design.deterministic` (one Lyapunov matrix; H-infinity ``w1 -> z1``,
  impulse-to-peak ``w2 -> z2``, pole region; objective ``1 gamma + 100 nu``) imposed at N plants
  drawn uniformly in the parameter box, N from the Campi-Garatti bound for the program's
  decision variables (:func:`satfmu.synthesis.robust.probabilistic.scenario_samples`): with confidence
  ``1 - delta`` the design violates the specs on a set of plants of probability at most epsilon.
  The program is solved in the coordinates where the nominal design's Lyapunov matrix has a unit
  diagonal (without that, Clarabel fails on this stiff loop; see the README), by constraint
  generation over the plants (:func:`satfmu.synthesis.robust.robust_design.design`: the same optimum, with a
  few hundred plants in the solver instead of thousands).
- :func:`analyse`: the probabilistic analysis of a gain: closed-loop poles, exact H-infinity
  norms and impulse-to-peak values of N sampled plants, all vectorized, with the log-over-log
  worst-case statement (N = 132 at the seed's epsilon 0.1, delta 1e-6).
- :class:`ClosedLoopSamples`: the same per-sample values as a pure, picklable task for
  :mod:`satfmu.sims.campaign.engine` (Chernoff campaigns of 1e5 samples on Dask).
- :func:`sequential_design`: the sequential randomized method
  (:func:`satfmu.synthesis.robust.sequential.sequential`) started from the deterministic design, at levels
  below its own.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from satfmu.synthesis.robust import demeter_design
from satfmu.synthesis.robust import probabilistic
from satfmu.synthesis.robust import sequential
from satfmu.synthesis.robust.demeter_variants import DesignModel, Variant, design_model
from satfmu.synthesis.robust.lft_plant import OptionError
from satfmu.synthesis.robust.robust_design import RobustDesign

SCENARIO_EPSILON, SCENARIO_DELTA = 0.1, 1e-9
"""The scenario design's violation level and confidence (docs/models.md: N = 962 for row 1)."""
ANALYSIS_EPSILON, ANALYSIS_DELTA = 0.1, 1e-6
"""The seed's ``randsettings`` for the analysis."""


def design_scale(dm: DesignModel) -> np.ndarray:
    """State scale of the randomized programs: :func:`satfmu.synthesis.robust.demeter_design.state_scale` times
    the square root of the nominal design's Lyapunov diagonal (unit diagonal at the nominal).

    Parameters
    ----------
    dm : DesignModel
        The design model of the variant.

    Returns
    -------
    numpy.ndarray, shape (n,)
        T of ``x = T x_s``, each state's scale in its own unit;
        :func:`~satfmu.synthesis.robust.demeter_design.state_scale`
        alone if the nominal design fails.
    """
    T = demeter_design.state_scale(dm)
    nominal = demeter_design.seed_design(demeter_design.scaled_lft(dm, T).at(np.zeros(len(dm.parameters))))
    return T if nominal.Y is None else T * np.sqrt(np.diag(nominal.Y))


def n_decision(dm: DesignModel) -> int:
    """Decision variables of the scenario program: Y (n(n+1)/2), W (m n), gamma and nu.

    Parameters
    ----------
    dm : DesignModel
        The design model (``n`` states, ``m = na`` inputs).
    """
    return dm.n * (dm.n + 1) // 2 + dm.na * dm.n + 2


@dataclass
class Analysis:
    """Probabilistic analysis of one gain on N sampled plants (:func:`analyse`).

    Attributes
    ----------
    n : int
        Number of plants drawn.
    seed : int
        Seed of the generator that drew them.
    max_real_pole : float
        Largest real part of a closed-loop eigenvalue over the plants, 1/s.
    min_real_pole : float
        Smallest real part of a closed-loop eigenvalue over the plants, 1/s.
    hinf : satfmu.synthesis.robust.probabilistic.WorstCase
        Worst case of the H-infinity norm of ``w1 -> z1``, rad/(N m).
    i2p : satfmu.synthesis.robust.probabilistic.WorstCase
        Worst case of the impulse-to-peak value of ``w2 -> z2``, N m s.
    seconds : float
        Wall time of the analysis, s.
    i2p_direction : {"worst", "random"}, optional
        How the impulse of w2 was taken (:data:`I2P_DIRECTIONS`).
    """

    n: int
    seed: int
    max_real_pole: float
    min_real_pole: float
    hinf: probabilistic.WorstCase
    i2p: probabilistic.WorstCase
    seconds: float
    i2p_direction: str = "worst"
    """How the impulse of w2 was taken (:data:`I2P_DIRECTIONS`)."""

    @property
    def in_region(self) -> bool:
        return self.max_real_pole < -demeter_design.ALPHA and self.min_real_pole > -demeter_design.BETA


@dataclass(frozen=True)
class BoxSampler:
    """Parameter vectors uniform in ``[-1, 1]^n_params`` (the order of
    :meth:`~satfmu.synthesis.robust.demeter_variants.DesignModel.sample`): a picklable campaign sampler.

    Called as ``sampler(rng, count)`` (a ``numpy.random.Generator`` and the number of vectors),
    it returns an array of shape (count, n_params).

    Parameters
    ----------
    n_params : int
        Number of uncertain parameters N of the design model.
    """

    n_params: int

    def __call__(self, rng: np.random.Generator, count: int) -> np.ndarray:
        return rng.uniform(-1.0, 1.0, (count, self.n_params))


@dataclass
class ClosedLoopSamples:
    """Per-sample closed-loop values of ``u = K x`` on a variant's design model: a pure task
    (picklable; deterministic in its input) mapping parameter vectors delta, shape (S, N), to
    ``max_real_pole`` (1/s), ``hinf`` (rad/(N m); inf if unstable) and ``i2p`` (N m s).

    Called with ``deltas``, it returns the dict of
    :func:`~satfmu.synthesis.robust.demeter_design.closed_loop_values`.

    Attributes
    ----------
    variant : Variant
        The model variant.
    K : numpy.ndarray, shape (na, n)
        Gain of ``u = K x`` on the design states, in physical units.
    _dm : DesignModel, optional
        Cache of the variant's design model (built on first use, not pickled); leave it None.
    """

    variant: Variant
    K: np.ndarray
    _dm: DesignModel | None = field(default=None, repr=False, compare=False)

    def design_model(self) -> DesignModel:
        """The variant's design model, built on the first call and kept."""
        if self._dm is None:
            self._dm = design_model(self.variant)
        return self._dm

    def __call__(self, deltas: np.ndarray) -> dict[str, np.ndarray]:
        return demeter_design.closed_loop_values(self.design_model(), self.K, deltas)

    def __getstate__(self) -> dict:
        return {"variant": self.variant, "K": self.K, "_dm": None}  # rebuilt in the worker


I2P_DIRECTIONS = ("worst", "random")
"""Impulse directions of the probabilistic i2p analysis: the worst unit direction of w2 per
sample (ours), or one random unit combination of w2's columns per sample (the R-RoMulOC
toolbox's ``testi2p``): a lower value, the peak of one impulse rather than of the worst."""


def analyse(variant: Variant, K: np.ndarray, *, n: int | None = None, seed: int = 1,
            epsilon: float = ANALYSIS_EPSILON, delta: float = ANALYSIS_DELTA, i2p_direction: str = "worst"
            ) -> Analysis:
    """Worst cases over ``n`` plants drawn uniformly in the box (default: the log-over-log
    count for epsilon, delta); the impulse of w2 in the worst direction of each sample, or, with
    ``i2p_direction="random"``, in one direction drawn uniformly on the unit sphere per sample
    (after the plants, from the same generator).

    Parameters
    ----------
    variant : Variant
        The model variant.
    K : numpy.ndarray, shape (na, n)
        Gain of ``u = K x`` on the design states, in physical units.
    n : int, optional
        Number of plants; default :func:`satfmu.synthesis.robust.probabilistic.worst_case_samples` of
        ``epsilon``, ``delta``.
    seed : int, optional
        Seed of the generator of the plants (and of the random directions).
    epsilon : float, optional
        Probability level of the worst-case statement.
    delta : float, optional
        One minus its confidence.
    i2p_direction : {"worst", "random"}, optional
        Impulse direction of w2 (:data:`I2P_DIRECTIONS`).

    Returns
    -------
    Analysis

    Raises
    ------
    OptionError
        If ``i2p_direction`` is not one of :data:`I2P_DIRECTIONS`.
    """
    if i2p_direction not in I2P_DIRECTIONS:
        raise OptionError(f"i2p_direction must be one of {I2P_DIRECTIONS}, got {i2p_direction!r}")
    n = probabilistic.worst_case_samples(epsilon, delta) if n is None else n
    dm = design_model(variant)
    t0 = time.perf_counter()
    rng = np.random.default_rng(seed)
    deltas = dm.sample(n, rng)
    directions = None
    if i2p_direction == "random":
        u = rng.normal(size=(n, dm.B2.shape[1]))
        directions = u / np.linalg.norm(u, axis=1, keepdims=True)
    v = demeter_design.closed_loop_values(dm, np.asarray(K, float), deltas, directions)
    return Analysis(n, seed, float(v["max_real_pole"].max()), float(v["min_real_pole"].min()),
                    probabilistic.worst_case(v["hinf"], epsilon, delta), probabilistic.worst_case(v["i2p"], epsilon,
                                                                                                  delta),
                    time.perf_counter() - t0, i2p_direction)


@dataclass
class ScenarioResult:
    """One Prob row of Table 1: scenario design, probabilistic analysis, seconds.

    Attributes
    ----------
    variant : Variant
        The model variant.
    design : RobustDesign
        The scenario design, in the coordinates ``x = T x_s`` of :func:`design_scale`.
    K : numpy.ndarray, shape (na, n), or None
        Gain of ``u = K x`` in physical units on the design states; None if no design.
    n_samples : int
        Number of sampled plants of the program.
    n_decision : int
        Decision variables of the program (:func:`n_decision`).
    epsilon : float
        Violation probability of the scenario guarantee.
    delta : float
        One minus its confidence.
    analysis : Analysis, optional
        Probabilistic analysis of the gain (None: not run, or no design).
    seconds : dict of str to float, optional
        Wall time, s, of ``"design"`` and ``"analysis"``.
    seed : int, optional
        Seed of the sampled plants of the program.
    deterministic : satfmu.synthesis.robust.demeter_design.Analysis, optional
        Deterministic analysis of the gain over the whole box (None: not run).
    check : satfmu.synthesis.robust.demeter_design.SampledCheck, optional
        The gain's loops on plants drawn afresh in the box (None: not run).
    """

    variant: Variant
    design: RobustDesign
    K: np.ndarray | None
    n_samples: int
    n_decision: int
    epsilon: float
    delta: float
    analysis: Analysis | None = None
    seconds: dict[str, float] = field(default_factory=dict)
    seed: int = 0
    deterministic: demeter_design.Analysis | None = None
    check: demeter_design.SampledCheck | None = None

    @property
    def feasible(self) -> bool:
        return self.K is not None


def scenario(variant: Variant, *, epsilon: float = SCENARIO_EPSILON, delta: float = SCENARIO_DELTA,
             n: int | None = None, seed: int = 0, analysis: bool = True, convention: str = "satfmu",
             sample_bound: str = "campi-garatti") -> ScenarioResult:
    """Scenario design of ``variant`` (module docstring).

    ``n`` overrides the sample count, otherwise :func:`satfmu.synthesis.robust.probabilistic.scenario_samples`
    with ``sample_bound`` (``"campi-garatti"``, exact; ``"romuloc"``, the toolbox's); the LMIs
    and the objective in ``convention`` (:func:`satfmu.synthesis.robust.robust_design.design`).

    Parameters
    ----------
    variant : Variant
        The model variant.
    epsilon : float, optional
        Violation probability of the scenario guarantee.
    delta : float, optional
        One minus its confidence.
    n : int, optional
        Number of sampled plants, overriding the bound.
    seed : int, optional
        Seed of the sampled plants; the analysis uses ``seed + 1``.
    analysis : bool, optional
        Run the probabilistic analysis of the gain (:func:`analyse`).
    convention : {"satfmu", "romuloc"}, optional
        How the levels enter the LMIs and the objective.
    sample_bound : {"campi-garatti", "romuloc"}, optional
        The sample count's bound when ``n`` is not given.

    Returns
    -------
    ScenarioResult

    Raises
    ------
    OptionError
        If ``n`` is below 1.
    """
    dm = design_model(variant)
    d = n_decision(dm)
    n = probabilistic.scenario_samples(d, epsilon, delta, sample_bound) if n is None else n
    if n < 1:
        raise OptionError(f"n must be >= 1, got {n!r}")
    t0 = time.perf_counter()
    T = design_scale(dm)
    P = demeter_design.scaled_lft(dm, T)
    plants = [P.at(x) for x in dm.sample(n, np.random.default_rng(seed))]
    des = demeter_design.seed_design(plants, convention=convention)
    out = ScenarioResult(variant, des, None if des.K is None else des.K / T, n, d, epsilon, delta,
                         seconds={"design": time.perf_counter() - t0}, seed=seed)
    if analysis and out.K is not None:
        out.analysis = analyse(variant, out.K, seed=seed + 1)
        out.seconds["analysis"] = out.analysis.seconds
    return out


def artifact_data(result: ScenarioResult, name: str) -> dict:
    """The controller artifact (kind ``linear_state_feedback``) of a scenario design: the FMU
    gains, the scenario guarantee, and what the deterministic analysis proved over the whole box.

    The status is ``"certified"`` when the deterministic analysis proved the impulse-to-peak
    bound over the box (a common Lyapunov matrix: stability for every parameter of the box),
    else ``"sampled"`` (the scenario guarantee and the sampled check only).

    Parameters
    ----------
    result : ScenarioResult
        A feasible result of :func:`scenario` with its sampled check (``result.check``) and,
        optionally, its deterministic analysis (``result.deterministic``).
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
    d, a = result.design, result.deterministic
    if result.K is None or d.gamma is None or d.nu is None:
        raise ValueError(f"{result.variant.label}: no design to save ({d.status})")
    if result.check is None:
        raise ValueError(f"{result.variant.label}: no sampled check to record (demeter_design.sampled_check)")
    numbers = {"design_hinf_bound": d.gamma, "design_i2p_bound": d.nu, "scenarios": result.n_samples,
               "scenario_epsilon": result.epsilon, "scenario_delta": result.delta,
               **demeter_design.checked_numbers(result.check, *((a.hinf, a.hinf_common, a.i2p) if a else ())),
               "design_seconds": result.seconds["design"]}
    forms = "satfmu's" if d.convention == "satfmu" else "the R-RoMulOC toolbox's"
    proved = (f"Scenario design ({forms} LMI forms and objective, re-verified in numpy): one Lyapunov matrix for "
              f"the Fig. 3 design model of {result.variant.label} at {result.n_samples} plants drawn uniformly in the "
              f"box (seed {result.seed}): closed-loop poles in {-demeter_design.BETA:g} < Re s < "
              f"{-demeter_design.ALPHA:g} 1/s, ||w1 -> z1||_inf < {d.gamma:.6g} rad/(N m), impulse-to-peak w2 -> z2 "
              f"< {d.nu:.6g} N m s at each. With confidence 1 - {result.delta:g}, the plants of the box where these "
              f"fail have probability at most {result.epsilon:g} (Campi-Garatti, {result.n_decision} decision "
              "variables). ")
    certified = "analysis_i2p" in numbers
    if certified:
        proved += (f"Over the whole box (deterministic analysis, re-verified): stability and impulse-to-peak "
                   f"w2 -> z2 < {numbers['analysis_i2p']:.6g} N m s"
                   + (f", ||w1 -> z1||_inf < {numbers['analysis_hinf_pdlf']:.6g} rad/(N m) (parameter-dependent "
                      "Lyapunov function)" if "analysis_hinf_pdlf" in numbers else "") + ". ")
    else:
        proved += "Not analysed over the whole box. "
    proved += f"Sampled: {result.check.n} plants, seed {result.check.seed}."
    return demeter_design.gain_artifact(
        result.variant, result.K, name, status="certified" if certified else "sampled", proved=proved,
        numbers=numbers, method="Prob", convention=d.convention,
        source="satfmu synth demeter --method Prob (satfmu.synthesis.robust.demeter_random.scenario)")


@dataclass
class SequentialDesign:
    """The sequential method started from the deterministic design, at its levels times ``scale``.

    Attributes
    ----------
    variant : Variant
        The model variant.
    deterministic : RobustDesign
        The deterministic design started from, in the coordinates of
        :func:`~satfmu.synthesis.robust.demeter_design.state_scale`.
    result : satfmu.synthesis.robust.sequential.SequentialResult
        The sequential method's outcome, in the coordinates of :func:`design_scale`.
    K : numpy.ndarray, shape (na, n), or None
        Gain of ``u = K x`` in physical units on the design states; None unless validated.
    """

    variant: Variant
    deterministic: RobustDesign
    result: sequential.SequentialResult
    K: np.ndarray | None

    @property
    def validated(self) -> bool:
        return self.result.status == "validated"


def sequential_design(variant: Variant, *, scale: float = 0.99, epsilon: float = ANALYSIS_EPSILON,
                      delta: float = ANALYSIS_DELTA, max_updates: int = 200, seed: int = 0) -> SequentialDesign:
    """Lower the deterministic design's levels (gamma, nu) by ``scale`` and look for a gain that
    meets them on all but a fraction epsilon of the plants (:func:`satfmu.synthesis.robust.sequential.sequential`,
    from the deterministic (Y, W), which meets the unscaled levels on the whole box).

    Parameters
    ----------
    variant : Variant
        The model variant.
    scale : float, optional
        Factor on the deterministic design's levels gamma and nu.
    epsilon : float, optional
        Violation probability of the validation.
    delta : float, optional
        One minus its confidence.
    max_updates : int, optional
        Updates of (Y, W) allowed before giving up.
    seed : int, optional
        Seed of the sample stream.

    Returns
    -------
    SequentialDesign

    Raises
    ------
    ValueError
        If the variant has no deterministic design to start from.
    """
    dm = design_model(variant)
    T0 = demeter_design.state_scale(dm)  # the deterministic design's own coordinates (as deterministic())
    plant = demeter_design.scaled_lft(dm, T0)
    det, _, _ = demeter_design.robust_multipliers(
        lambda kind: demeter_design.seed_design(plant, uncertainty=kind),
        demeter_design.uncertainty_kind(variant))
    if det.K is None:
        raise ValueError(f"{variant.label}: no deterministic design to start from ({det.status})")
    T = design_scale(dm)
    s = T / T0  # x_T0 = s x_T: Y and the gain carried over exactly
    Y0 = det.Y / s[:, None] / s[None, :]
    res = sequential.sequential(demeter_design.scaled_lft(dm, T), BoxSampler(len(dm.parameters)), det.gamma * scale,
                                det.nu * scale, Y0, (det.K * s) @ Y0, alpha=demeter_design.ALPHA,
                                beta=demeter_design.BETA, epsilon=epsilon, delta=delta, max_updates=max_updates,
                                seed=seed)
    return SequentialDesign(variant, det, res, res.K / T if res.status == "validated" else None)
