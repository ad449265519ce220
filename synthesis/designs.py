"""One function per design method of the five seed papers, each returning a :class:`Design` and
failing with :class:`DesignError` only.

A design is made for a plant (seed 000 and 001: any spacecraft, via
:class:`satfmu.fmus.plants.spacecraft.Spacecraft`), re-verified independently of its solver by the
synthesis module, and returned with its artifacts (JSON data, validated) and a text
summary. :meth:`Design.write` saves the artifacts, by default into the user's folder
(:func:`satfmu.controllers.paths.user_artifacts`, never the shipped artifacts), and optionally builds
their controller FMUs. ``satfmu synth NAME`` is a thin layer over :data:`DESIGNS`.
"""
from __future__ import annotations

import dataclasses
import functools
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, ParamSpec, Sequence

import numpy as np

from satfmu.fmus.model import Model
from satfmu.fmus.plants.flexible_spacecraft import DEMETER, FlexibleSpacecraft
from satfmu.fmus.plants.spacecraft import Spacecraft
from satfmu.fmus.errors import DesignError, SatfmuError
from satfmu.synthesis.core.progress import Progress

_P = ParamSpec("_P")


def fails_with_design_error(design: Callable[_P, "Design"]) -> Callable[_P, "Design"]:
    """``design`` failing with :class:`DesignError` only: any other exception it raises (bad input,
    a solver's or a check's error) becomes one with the same message, the original chained as its
    ``__cause__`` (for a class outside satfmu's errors the message starts with the class name).

    Parameters
    ----------
    design : callable
        A design function returning a :class:`Design`.

    Returns
    -------
    callable
        The function with the same signature and docstring.
    """
    @functools.wraps(design)
    def guarded(*args: _P.args, **kwargs: _P.kwargs) -> Design:
        try:
            return design(*args, **kwargs)
        except DesignError:
            raise
        except Exception as exc:
            detail = str(exc) if isinstance(exc, SatfmuError) else f"{type(exc).__name__}: {exc}"
            raise DesignError(detail) from exc

    return guarded


@dataclass
class Design:
    """A certified design: its artifacts and the method's summary.

    Attributes
    ----------
    method : str
        Registry name (``"mrp-hinf"``, ...).
    artifacts : list of dict
        Controller artifacts (format of :mod:`satfmu.controllers.artifact`), validated.
    summary : str
        The method's summary (tables, certificate, checks), as the CLI prints it.
    result : object
        The synthesis module's full result (iterates, solver data, checks).
    """

    method: str
    artifacts: list[dict[str, Any]]
    summary: str
    result: Any = field(repr=False, default=None)

    @property
    def artifact(self) -> dict[str, Any]:
        """The (first) artifact's data."""
        return self.artifacts[0]

    @property
    def names(self) -> list[str]:
        """Artifact (and controller FMU) names."""
        return [a["name"] for a in self.artifacts]

    def write(self, folder: str | Path | None = None, fmu_dir: str | Path | None = None,
              backends: Sequence[str] = ("native", "python")) -> list[Path]:
        """Save the artifacts as ``<folder>/<name>.json`` and, with ``fmu_dir``, build their FMUs.

        Parameters
        ----------
        folder : path, optional
            Default :func:`satfmu.controllers.paths.user_artifacts` (scenarios find artifacts there by
            name before the shipped ones).
        fmu_dir : path, optional
            Build the controller FMUs (``backends``) here.
        backends : sequence of {"native", "python"}, optional
            The FMU backends built into ``fmu_dir``. Default both.

        Returns
        -------
        list of Path
            The artifact files, then the FMUs built.
        """
        from satfmu.controllers import artifact as artifacts
        from satfmu.controllers import catalog, paths

        out_dir = paths.user_artifacts() if folder is None else Path(folder)
        out_dir.mkdir(parents=True, exist_ok=True)
        written = []
        for data in self.artifacts:
            art = artifacts.parse(json.loads(json.dumps(data)), where=data["name"])
            f = out_dir / f"{art.name}.json"
            artifacts.save(art, f)
            written.append(f)
            if fmu_dir is not None:
                src = catalog.artifact_source(f)
                written += [catalog.builder(b)(src.model, Path(fmu_dir), src.resources) for b in backends]
        return written


def _mrp_plant(plant: Model | Spacecraft | None) -> Model:
    from satfmu.fmus.plants import mrp_satellite

    if plant is None:
        return mrp_satellite.MODEL
    if isinstance(plant, Spacecraft):
        return mrp_satellite.build(plant)
    if not isinstance(plant, Model) or plant.name != mrp_satellite.MODEL.name:
        raise DesignError(f"plant must be a satfmu.Spacecraft or an MRP satellite model (satfmu.mrp_plant), "
                          f"got {plant!r:.80}")
    return plant


SEED_TORQUE_BUDGET = 6.5
"""Default peak-torque budget of :func:`design_hinf` without a spacecraft torque limit, N m."""


@fails_with_design_error
def design_hinf(plant: Model | Spacecraft | None = None, *, name: str = "mrp_hinf_satfmu",
                start: dict[str, float] | None = None, torque_budget: float | None = None, horizon: float = 120.0,
                region: float = 0.9, rate_max: float = 0.2, sigma_max: float = 0.9,
                coefficient_limit: float = 1.0, decay_rates: Sequence[float] | None = None,
                n_samples: int = 20_000, progress: Progress | None = None) -> Design:
    """Seed 000: nonlinear H-infinity state feedback by the two-step iteration (SOS, then L2 gain).

    Parameters
    ----------
    plant : Spacecraft or satfmu.fmus.model.Model, optional
        Your spacecraft (its inertia tensor, products included) or an MRP satellite model;
        default seed 000's satellite.
    name : str
        Artifact and controller FMU name.
    start : dict, optional
        Start of the manoeuvre each iterate is judged on, as plant parameters
        (:func:`satfmu.synthesis.polynomial_feedback.two_step.manoeuvre` builds one from an axis and an angle); default
        seed 000's 200 deg start.
    torque_budget : float, optional
        Largest acceptable peak ``|u_i|`` on that manoeuvre, N m. Default the spacecraft's
        torque limit when ``plant`` is a :class:`Spacecraft` that has one, else
        :data:`SEED_TORQUE_BUDGET` (seed 000's manoeuvre needs about 6.1 N m).
    horizon : float
        Length of the manoeuvre; the attitude error must be < 0.1 deg at its end, s.
    region : float
        Theorem 1's certificate region ``|sigma| <= region`` (< 1).
    rate_max, sigma_max : float
        L2-gain region ``|omega_i| <= rate_max`` (rad/s), ``|sigma| <= sigma_max``.
    coefficient_limit : float
        Bound on every gain coefficient (program units).
    decay_rates : sequence of float, optional
        The iteration's schedule of certified decay rates, 1/s (default
        :data:`satfmu.synthesis.polynomial_feedback.two_step.DECAY_RATES`; fewer rates are faster).
    n_samples : int
        Random points of the sampled L2 estimate per iterate.
    progress : callable, optional
        ``progress(done, total, message)`` after each step.

    Raises
    ------
    DesignError
        If no iterate is accepted, or on bad input (the cause chained).
    """
    from satfmu.synthesis.polynomial_feedback import l2_gain, two_step

    model = _mrp_plant(plant)
    if torque_budget is None:
        limit = plant.torque_limit if isinstance(plant, Spacecraft) else None
        torque_budget = SEED_TORQUE_BUDGET if limit is None else limit
    result = two_step.two_step(model, region=region, l2_region=l2_gain.Region(rate_max, sigma_max),
                               coefficient_limit=coefficient_limit, torque_budget=torque_budget,
                               decay_rates=two_step.DECAY_RATES if decay_rates is None else decay_rates,
                               n_samples=n_samples, start=start, horizon=horizon, progress=progress)
    return Design("mrp-hinf", [result.artifact_data(name)], result.table(), result)


@fails_with_design_error
def design_h2hinf(gamma: float, plant: Model | Spacecraft | None = None, *, name: str = "mrp_h2hinf_satfmu",
                  variant: str = "slack", region: float = 0.45, alpha_range: tuple[float, float] | None = None,
                  evaluations: int = 12, weights: tuple[np.ndarray, np.ndarray] | None = None,
                  progress: Progress | None = None) -> Design:
    """Seed 001: mixed H2/H-infinity state feedback (Theorem 8) at one L2-gain bound ``gamma``.

    Each SOS program is solved in units balanced for the plant and its certificate checked in
    the user's (:mod:`satfmu.synthesis.polynomial_feedback.coordinates`). Before any of them,
    the conditions are screened at the origin (~2 s): a ``gamma`` that even the linearization
    cannot certify is refused there, with the smallest ``gamma`` it can.

    Parameters
    ----------
    gamma : float
        L2-gain bound w -> sigma to certify (N m -> 1).
    plant : Spacecraft or satfmu.fmus.model.Model, optional
        Default seed 000's satellite (seed 001 uses the same plant).
    name : str
        Artifact and controller FMU name.
    variant : {"slack", "common"}
        Separate Lyapunov matrices and slack (the seed's design) or one common matrix.
    region : float
        Certificate region ``|sigma| <= region`` (< 1), any rate.
    alpha_range : (float, float), optional
        Line-search interval of the seed's scalars alpha and beta, s (default
        :func:`satfmu.synthesis.polynomial_feedback.h2hinf_search.default_bounds`: the plant's time scale).
    evaluations : int
        SDPs per line search.
    weights : (numpy.ndarray, numpy.ndarray), optional
        The H2 weights ``(Qh, Rh)``, 6 x 6 on ``(omega, sigma)`` and 3 x 3 on ``u``. Default
        ``Qh = I6`` and, for a :class:`Spacecraft` with a torque limit, Bryson's rule on the
        input, ``Rh = I3 / torque_limit^2`` (N^-2 m^-2), so that the law's torque is weighed
        against what the actuators give; else the seed's ``Rh = I3``.
    progress : callable, optional
        ``progress(done, total, message)`` after each step.

    Raises
    ------
    DesignError
        If no design is certified at ``gamma`` (why, and what would change it), the closed-loop
        check fails, or on bad input (the cause chained).
    """
    from satfmu.synthesis.polynomial_feedback import h2hinf_search, h2hinf_sos

    model = _mrp_plant(plant)
    limit = plant.torque_limit if isinstance(plant, Spacecraft) else None
    if weights is None:
        weights = (np.eye(6), np.eye(3) / (1.0 if limit is None else limit**2))
    found = h2hinf_search.search(gamma, variant, bounds=None if alpha_range is None else (*alpha_range,),
                              max_evaluations=evaluations, progress=progress, region=region, model=model,
                              Qh=np.asarray(weights[0], float), Rh=np.asarray(weights[1], float))
    r = found.best
    if r is None:
        raise DesignError(f"no certified {variant} design at gamma = {gamma:g} on |sigma| <= {region:g}: "
                          f"{found.reason()}")
    check = h2hinf_sos.closed_loop_check(r, model=model)
    c = r.coordinates
    screen = found.screen
    summary = (f"{r.proved}\n  alpha = {r.alpha:.4g} s, beta = {r.beta:.4g} s, {len(found.evaluations)} SDPs"
               + (f" after the screen at the origin ({screen.seconds:.1f} s, frozen lambda >= "
                  f"{np.min(screen.lam):.4f})" if screen is not None else "")
               + f"; solved in units of {c.time:.3g} s, {c.rate:.3g} rad/s, {c.torque:.3g} N m, checked in SI"
               f"\n  simulated J2 = {check.j2:.4f} over {check.stop_time:g} s (bound {r.lam:.4f}), max |sigma| "
               f"{check.max_tilde:.4f}, linearization max Re eig {check.max_real_eig:.4f} 1/s"
               f"\n  peak |u_i| {check.peak_torque:.4g} N m from the H2 start"
               + ("" if limit is None else f" ({'within' if check.peak_torque <= limit else 'ABOVE'} the torque limit "
                                           f"{limit:g} N m; Rh = {r.Rh[0, 0]:.4g} I3)"))
    if not check.passed:
        raise DesignError(f"{summary}\nthe closed-loop check failed: the design is not saved")
    return Design("mrp-h2hinf", [h2hinf_sos.artifact_data(r, name, check, model)], summary, r)


@fails_with_design_error
def design_vscmg_sdre(grid: tuple[int, int] = (23, 25), max_degree: int = 8, cv_tol: float | None = None,
                      region: bool = True, progress: Progress | None = None) -> Design:
    """Seed 002: the approximated SDRE servo (polynomial gain fit, SOS stability region) and the
    LQ servo, for seed 002's VSCMG plant (its parameters as published).

    Parameters
    ----------
    grid : (int, int)
        SDRE grid points over q2 and w4.
    max_degree : int
        Largest polynomial degree of the fit tried.
    cv_tol : float, optional
        Choose the smallest degree with this cross-validated relative error (default
        :data:`satfmu.synthesis.servo.gain_fit.CV_TOL`; 0: the smallest error).
    region : bool
        Solve the SOS stability region (without it the artifact stays "sampled").
    progress : callable, optional
        ``progress(done, total, message)`` after each stage (grid, fit, check, region, LQ).

    Raises
    ------
    DesignError
        If the fit fails its check against the plant's own factorization
        (:class:`satfmu.fmus.errors.FitCertificationError` chained), or on bad input.
    """
    from satfmu.synthesis.servo import gain_fit

    if (not isinstance(grid, (tuple, list)) or len(grid) != 2
            or not all(isinstance(n, int) and not isinstance(n, bool) and n >= 2 for n in grid)):
        raise DesignError(f"grid must be two integers >= 2 (SDRE grid points over q2 and w4), got {grid!r:.80}")
    tol: dict[str, Any] = {} if cv_tol is None else {"cv_tol": cv_tol if cv_tol > 0 else None}
    result, approx, lq = gain_fit.synthesize(*grid, degrees=range(1, max_degree + 1), region=region,
                                             progress=progress, **tol)
    cert = approx["certificate"]
    summary = (f"certificate: {cert['status']}: {cert['proved']}\n"
              + gain_fit.table(result, {k: v for k, v in cert["numbers"].items() if not k.startswith("fit_")}))
    return Design("vscmg-sdre", [approx, lq], summary, result)


@fails_with_design_error
def design_sdre(plant: Model | Spacecraft | None = None, *, name: str = "mrp_sdre_servo",
                s_max: float | None = None, w_max: float | None = None, max_degree: int = 2,
                weights: tuple[np.ndarray, np.ndarray] | None = None, region: bool = True,
                progress: Progress | None = None) -> Design:
    """Seed 002's method for your rigid spacecraft: the SDRE servo of the MRP satellite, a
    least-squares polynomial fit of its gain over the operating box, checked, and the SOS
    stability region of the fitted law (:mod:`satfmu.synthesis.servo.mrp_sdre`).

    Parameters
    ----------
    plant : Spacecraft or satfmu.fmus.model.Model, optional
        Your spacecraft (inertia tensor, torque limit) or an MRP satellite model; default seed
        000's satellite.
    name : str
        Artifact and controller FMU name.
    s_max : float, optional
        MRP bound of the operating box the gain is fitted on (1); default
        :func:`satfmu.synthesis.servo.mrp_sdre.default_box` (a 90 deg rotation).
    w_max : float, optional
        Rate bound of the box, rad/s; default from the spacecraft's torque limit and inertia.
    max_degree : int
        Largest polynomial degree of the fit tried (at most 2: the region's SOS program).
    weights : (numpy.ndarray, numpy.ndarray), optional
        The servo weights ``(Q, R)``, 9 x 9 on ``[int e, e, omega]`` and 3 x 3 on ``u``; default
        :func:`satfmu.controllers.mrp_servo_sdc.default_weights` (``R = I3 / torque_limit^2``).
    region : bool
        Solve the SOS stability region (without it the artifact records the sampled checks only).
    progress : callable, optional
        ``progress(done, total, message)`` after each stage (samples, fit, check, region).

    Raises
    ------
    DesignError
        If the fit fails its checks, a Riccati solution fails its own, or on bad input (the cause
        chained).
    """
    from satfmu.synthesis.servo import mrp_sdre

    if isinstance(max_degree, bool) or not isinstance(max_degree, int) or not 0 <= max_degree <= mrp_sdre.MAX_DEGREE:
        raise DesignError(f"max_degree must be an integer in 0..{mrp_sdre.MAX_DEGREE}, got {max_degree!r:.40}")
    Q, R = (None, None) if weights is None else (np.asarray(weights[0], float), np.asarray(weights[1], float))
    r = mrp_sdre.synthesize(_mrp_plant(plant), s_max=s_max, w_max=w_max, degrees=range(0, max_degree + 1), Q=Q, R=R,
                            region=region, name=name, progress=progress)
    cert = r.artifact["certificate"]
    n = cert["numbers"]
    summary = (f"certificate: {cert['status']}: {cert['proved']}\n  region: {cert['region']}\n"
               f"  fit: degree {r.fit.degree}, off-sample error max {n['offgrid_max_rel_error']:.3g}, RMS "
               f"{n['offgrid_rms_rel_error']:.3g} (relative to the largest gain entry); frozen loops max Re "
               f"{n['frozen_max_re']:.4g} 1/s; 90 deg slew (simulated, unsaturated): {n['sim_final_angle_deg']:.3g} "
               f"deg at {n['sim_stop_time']:g} s, peak torque {n['sim_peak_torque']:.4g} N m\n  stages: "
               + ", ".join(f"{k} {v:.1f} s" for k, v in r.seconds.items())
               + _online_line(r.servo))
    return Design("mrp-sdre", [r.artifact], summary, r)


def _online_line(servo: Any) -> str:
    Q, R = servo.weights
    if np.count_nonzero(Q - np.diag(np.diagonal(Q))) or np.count_nonzero(R - np.diag(np.diagonal(R))):
        return "\n  the online SDRE FMU mrp_sdre_online takes diagonal weights only: not this servo's"
    return ("\n  the online SDRE of this servo: FMU mrp_sdre_online with the parameters "
            + ", ".join(f"{k} = {v:.6g}" for k, v in sdre_online_parameters(servo).items()))


def sdre_online_parameters(servo: Any) -> dict[str, float]:
    """The parameters that make the shipped online SDRE FMU ``mrp_sdre_online`` the servo ``servo``
    of a design (:func:`design_sdre`): the plant's inertia (kg m^2) and the weights' diagonals.

    Parameters
    ----------
    servo : satfmu.synthesis.servo.mrp_sdre.MRPServo
        The design's servo (``Design.result.servo``).

    Returns
    -------
    dict of str to float
        ``I_x ... I_yz``, ``Q[1..9]``, ``R[1..3]`` (the diagonals: the FMU takes diagonal weights).
    """
    from satfmu.fmus.plants.spacecraft import PARAMETERS

    values = {v.name: float(v.start) for v in servo.model.parameters if v.name in PARAMETERS}
    Q, R = servo.weights
    values.update({f"Q[{i + 1}]": float(q) for i, q in enumerate(np.diagonal(Q))})
    values.update({f"R[{i + 1}]": float(x) for i, x in enumerate(np.diagonal(R))})
    return values


@fails_with_design_error
def design_cubesat_periodic(gamma: float | None = None, plant: Spacecraft | None = None, *,
                            name: str = "cubesat_periodic_satfmu",
                            published_name: str = "cubesat_periodic_published") -> Design:
    """Seed 003: periodic stochastic H-infinity magnetorquer gains (Theorem 2), and the
    analysis of the published gains.

    Parameters
    ----------
    gamma : float, optional
        Design level (default ``gamma_min (1 + GAMMA_MARGIN)``).
    plant : Spacecraft, optional
        Your cubesat, in principal axes (three moments; default seed 003's). The published
        gains are then only analysed on it (their artifact is seed 003's alone). Its
        ``dipole_limit`` is recorded as the design plant's ``m_max`` (else the plant's 0.2 A m^2),
        and the summary states the rates up to which the gains stay within it.
    name, published_name : str
        Artifact names of the design and of the published gains.

    Raises
    ------
    DesignError
        If Theorem 2 is infeasible at ``gamma``, or the spacecraft has products of inertia (the
        cause chained).
    """
    from satfmu.fmus.plants import cubesat
    from satfmu.synthesis.periodic import cubesat_periodic

    r = cubesat_periodic.synthesize(gamma, inertia=None if plant is None else cubesat.principal_moments(plant))
    if plant is not None and plant.dipole_limit is not None:
        r = dataclasses.replace(r, parameters={**r.parameters, "m_max": plant.dipole_limit})
    m_max = r.parameters.get("m_max", next(v.start for v in cubesat.MODEL.parameters if v.name == "m_max"))
    row = float(np.max(np.linalg.norm(r.design.F, axis=2)))  # largest |F_k[i, :]|, A m^2 s/rad
    lo, hi, n = r.bracket
    lines = [f"seed 003 Theorem 2: gamma_min {r.gamma_min:.4f} (minimized); bisection bracket [{lo:.4f}, "
             f"{hi:.4f}] in {n} solves; the seed's gamma {cubesat_periodic.GAMMA_SEED:g} is "
             f"{'feasible' if r.numbers['seed_gamma_feasible'] else 'infeasible'}"]
    lines += [f"  {k}: {v:.6g}" for k, v in r.numbers.items()]
    lines.append(f"  dipole limit {m_max:g} A m^2 per axis: the gains command at most that for |omega| <= "
                 f"{m_max / row:.3g} rad/s (largest gain row {row:.4g} A m^2 per rad/s); faster, the "
                 "magnetorquers clip, which the design's linear model leaves out")
    lines.append("  gains F(k) (rows m_x, m_y, m_z; columns omega_x, omega_y, omega_z), ours | published:")
    for k, (f, p) in enumerate(zip(r.design.F, cubesat_periodic.PUBLISHED_GAINS)):
        lines += [f"    k={k} " + " ".join(f"{v:8.4f}" for v in f[i]) + "  | " + " ".join(f"{v:8.4f}" for v in p[i])
                  for i in range(3)]
    data = [r.artifact_data(name, r.design.F, r.design.gamma, r.design.check, "satfmu")]
    if r.published is not None and plant is None:
        data.append(r.artifact_data(published_name, cubesat_periodic.PUBLISHED_GAINS, r.published.gamma,
                                    r.published.check,
                                    "published (seed 003, gains as printed)"))
    return Design("cubesat-periodic", data, "\n".join(lines), r)


@fails_with_design_error
def design_demeter(axes: Sequence[int] = (1,), appendages: Sequence[int] = (1,), model_type: int = 1,
                   uncertainty_type: int = 1, wheels: bool = True, *, plant: FlexibleSpacecraft | None = None,
                   name: str | None = None, method: str = "Det", n_samples: int = 100, convention: str = "satfmu",
                   analysis: bool = True, progress: Progress | None = None) -> Design:
    """Seed 004: robust state feedback of a variant of DEMETER or of your flexible spacecraft
    (Table 1), deterministic or randomized, with its deterministic and randomized analyses.

    Parameters
    ----------
    axes, appendages : sequence of int
        The variant's axes and appendages, 1-based.
    model_type : {1, 2}
        1: each appendage (mode group) its own frequency and damping, 2: identical appendages.
    uncertainty_type : {1, 2, 3}
        1: norm-bounded (D-G), 2: intervals (vertices), 3: inertia norm-bounded.
    wheels : bool
        Design with the wheel dynamics H(s).
    plant : FlexibleSpacecraft, optional
        Your spacecraft (:class:`satfmu.fmus.plants.flexible_spacecraft.FlexibleSpacecraft`): its
        hub inertia and inertia box, its appendages' modes with their frequency and damping
        intervals, its wheels' limits and dynamics. Default DEMETER (the seed's).
    name : str, optional
        Artifact and controller FMU name; default ``"demeter_row1_det"`` (``"demeter_row1_prob"``)
        for DEMETER, else ``"<spacecraft>_robust"`` (``"<spacecraft>_robust_prob"``).
    method : {"Det", "Prob"}
        ``"Det"``: the deterministic robust design, certified over the whole box (one Lyapunov
        matrix). ``"Prob"``: the scenario design on the Campi-Garatti number of plants drawn in
        the box (epsilon 0.1, confidence 1 - 1e-9); its artifact is ``"certified"`` when the
        deterministic analysis proves its impulse-to-peak bound over the whole box, else
        ``"sampled"``.
    n_samples : int
        Sampled plants of the independent check (at least 1).
    convention : {"satfmu", "romuloc"}
        LMI forms and objective of the design (:func:`satfmu.synthesis.robust.robust_design.design`); the
        artifact records it.
    analysis : bool
        Run the deterministic analysis of the gain (parameter-dependent H-infinity bound,
        impulse-to-peak bound). The design's own certificate (one Lyapunov matrix over the whole
        box) does not need it; it takes seconds for DEMETER's Table 1 rows and minutes for a box
        of 5 or more parameters. Default True.
    progress : callable, optional
        ``progress(done, total, message)`` after each stage (design, analysis, sampled check).

    Raises
    ------
    DesignError
        If the variant is infeasible (with the obstruction when one is proved), or on bad input
        (the cause chained).
    """
    from satfmu.fmus.plants import demeter
    from satfmu.synthesis.robust import demeter_design, demeter_random
    from satfmu.synthesis.robust import demeter_table
    from satfmu.synthesis.robust.demeter_variants import Variant

    if plant is not None and not isinstance(plant, FlexibleSpacecraft):
        raise DesignError(f"plant must be a satfmu.FlexibleSpacecraft (a rigid hub with flexible appendages and "
                          f"reaction wheels), got {type(plant).__name__}")
    if method not in ("Det", "Prob"):
        raise DesignError(f"method must be 'Det' (deterministic robust) or 'Prob' (scenario), got {method!r}")
    if isinstance(n_samples, bool) or not isinstance(n_samples, int) or n_samples < 1:
        raise DesignError(f"n_samples must be an integer >= 1 (the independent check), got {n_samples!r}")
    spacecraft = DEMETER if plant is None else plant
    if name is None:
        default = {"Det": "demeter_row1_det", "Prob": "demeter_row1_prob"} if spacecraft == DEMETER else {
            "Det": f"{spacecraft.name}_robust", "Prob": f"{spacecraft.name}_robust_prob"}
        name = default[method]
    variant = Variant(tuple(axes), tuple(appendages), model_type, uncertainty_type, wheels, spacecraft)
    row = demeter_table.run_row(variant, method, n_samples=n_samples, convention=convention, progress=progress,
                                analysis=analysis)
    lines = [demeter_table.markdown([row])]
    r = row.result
    assert isinstance(r, (demeter_design.DeterministicResult, demeter_random.ScenarioResult))
    if not r.feasible:
        o = demeter_design.coincident_modes(variant)
        if o is not None and o.proves_infeasible:
            lines.append(f"infeasible for any common-Lyapunov design: at coincident omega, {o.n_free} combination(s) "
                         f"of the modes are free oscillators; over omega in [{o.omega[0]:.4g}, {o.omega[1]:.4g}] "
                         f"rad/s they need zeta > {o.required_zeta:.4g} (the box has zeta <= {o.zeta:g}); "
                         f"eig(A_lo A_hi) = {', '.join(f'{v.real:.4g}' for v in o.eigenvalues)}")
        raise DesignError("\n".join(lines))
    c = r.check
    assert c is not None  # a feasible row with n_samples > 0 is checked
    if isinstance(r, demeter_design.DeterministicResult):
        common = getattr(r.analysis_hinf_common, "gamma", None)
        data = demeter_design.artifact_data(r, name)
    else:
        common = getattr(r.deterministic.hinf_common, "gamma", None) if r.deterministic else None
        lines.append(f"scenario design on {r.n_samples} plants: with confidence 1 - {r.delta:g} it violates its "
                     f"bounds on a set of plants of probability <= {r.epsilon:g}")
        data = demeter_random.artifact_data(r, name)
    lines.append(f"{c.n} sampled plants (seed {c.seed}): Re s in [{c.min_real_pole:.3g}, {c.max_real_pole:.3g}] 1/s, "
                 f"largest exact H-infinity {c.hinf.max():.4g}, i2p {c.i2p.max():.4g}; H-infinity bound with one "
                 f"Lyapunov matrix: {'none' if common is None else format(common, '.4g')}")
    if spacecraft != DEMETER:
        lines.append(f"plant FMU: {demeter.model_name(spacecraft)} (built from the artifact's "
                     "design.variant.spacecraft; scenarios name it as a model)")
    return Design("demeter", [data], "\n".join(lines), r)


DESIGNS: dict[str, Callable[..., Design]] = {
    "mrp-hinf": design_hinf, "mrp-h2hinf": design_h2hinf, "mrp-sdre": design_sdre, "vscmg-sdre": design_vscmg_sdre,
    "cubesat-periodic": design_cubesat_periodic, "demeter": design_demeter,
}
"""``satfmu synth NAME`` -> its design function."""
