"""Gain approximation of the SDRE servo (seed 002, section 3.2) and the LQ servo baseline.

The SDRE gain K(x) (2x7) is solved on a grid over (q2, w4) with the seed's w1-free SDC
evaluated at w2 := 0 (so the gain depends on q2 and w4 only), and every entry is fitted by
a 2-D polynomial in (sin q2, w4) of total degree d by least squares; d is the smallest
degree whose k-fold cross-validated error is within :data:`CV_TOL`. The controller then
evaluates polynomials instead of solving a Riccati equation (:mod:`satfmu.controllers.servo`).
The LQ servo is the constant gain at the start state.

Why sin q2 and a tolerance rather than the best cross-validated degree: the closed loop
is then polynomial in (sin q2, cos q2, w4), which is what the SOS stability region of
:mod:`satfmu.synthesis.servo.vscmg_region` needs (the seed's section 4 variable a = sin q2), and the
fit is more accurate in sin q2 at every degree (CV error 1.4e-3 at degree 4 against
2.3e-3 in q2). Degrees beyond the tolerance buy accuracy the tracking does not need while
the SOS certificate's Gram matrices grow with the square of the degree.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import cast

import numpy as np

from satfmu.controllers import domain
from satfmu.controllers.artifact import SERVO_KIND, FORMAT, FORMAT_VERSION, design_plant_record
from satfmu.controllers.servo_sdc import OUTPUTS, RATES, TRACKED
from satfmu.fmus.plants import vscmg
from satfmu.synthesis.servo.sdre import Servo
from satfmu.fmus.errors import FitCertificationError
from satfmu.synthesis.core.progress import Progress, Stages
from satfmu.synthesis.servo.polynomial_fit import PolynomialFit, fit_gains

LOG = logging.getLogger(__name__)

Q2_RANGE = (0.15, 1.25)
"""Gimbal-2 angle range of the grid, rad (covers the seed's pi/18 to 1 + pi/18; substitute)."""

W4_RANGE = (-0.6, 0.6)
"""Gimbal-4 rate range of the grid, rad/s (substitute, from the runs)."""

SCHEDULING = ["sin(q2)", "w4"]
"""The fit's variables, as the artifact names them."""

CV_TOL = 2e-3
"""Cross-validated RMS error (relative to the largest gain entry) the chosen degree must reach."""


@dataclass
class GainFit(PolynomialFit):
    """The SDRE gain (2x7) fitted on the monomials of ``(sin q2, w4)`` over the grid
    (:class:`satfmu.synthesis.servo.polynomial_fit.PolynomialFit`: ``points`` are the grid's
    ``(sin q2, w4)``, 1 and rad/s; ``gains`` the SDRE gains there, shape (n, 2, 7)).

    Attributes
    ----------
    degree : int
        Total degree chosen by cross-validation.
    coefficients : numpy.ndarray, shape (2, 7, n_terms)
        Coefficients of each gain entry, in the order of
        ``satfmu.synthesis.servo.polynomial_fit.exponents(2, degree)``.
    cv_errors : dict of int to float
        Cross-validated RMS error (relative to the largest gain entry) per degree tried.
    max_rel_error, rms_rel_error : float
        Largest and RMS ``|K_fit - K|`` on the samples, relative to the largest ``|K|`` entry.
    points : numpy.ndarray, shape (n, 2)
        The grid's ``(sin q2, w4)`` points, 1 and rad/s.
    gains : numpy.ndarray, shape (n, 2, 7)
        The SDRE gains there.
    cv_tol : float or None
        The tolerance the degree was chosen with.
    """

    def __call__(self, x: np.ndarray) -> np.ndarray:
        """K (2x7) at the plant state x = [q1, q2, q4, w1, w2, w4] (the law of
        :func:`satfmu.synthesis.servo.sdre.simulate_servo`)."""
        return self.evaluate(np.array([[np.sin(x[1]), x[5]]]))[0]


def sdre_grid(servo: Servo, n_q2: int = 23, n_w4: int = 25) -> tuple[np.ndarray, np.ndarray]:
    """Checked SDRE gains on the (q2, w4) grid: (sin q2, w4) points (n, 2) and gains (n, 2, 7).

    Parameters
    ----------
    servo : satfmu.synthesis.servo.sdre.Servo
        The SDRE servo whose checked gain is solved at each grid point (the other states 0).
    n_q2 : int, optional
        Grid points over :data:`Q2_RANGE` (rad).
    n_w4 : int, optional
        Grid points over :data:`W4_RANGE` (rad/s).

    Returns
    -------
    points : numpy.ndarray, shape (n_q2 n_w4, 2)
        ``(sin q2, w4)`` of each grid point (1, rad/s).
    gains : numpy.ndarray, shape (n_q2 n_w4, 2, 7)
        The gain K at each point.

    Raises
    ------
    satfmu.controllers.riccati.RiccatiCheckError
        If the Riccati solution at a grid point fails a check.
    """
    q2 = np.linspace(*Q2_RANGE, n_q2)
    w4 = np.linspace(*W4_RANGE, n_w4)
    points = np.array([(a, b) for a in q2 for b in w4])
    gains = np.array([servo.gain(np.array([0.0, a, 0.0, 0.0, 0.0, b]))[0] for a, b in points])
    return np.column_stack([np.sin(points[:, 0]), points[:, 1]]), gains


def fit(points: np.ndarray, gains: np.ndarray, degrees: range = range(1, 9), folds: int = 5,
        seed: int = 0, cv_tol: float | None = CV_TOL) -> GainFit:
    """Least-squares polynomial fit of every gain entry, degree by k-fold cross-validation:
    the smallest degree whose CV error is within ``cv_tol``, else (or with ``None``) the one
    with the smallest CV error.

    Parameters
    ----------
    points : numpy.ndarray, shape (n, 2)
        ``(sin q2, w4)`` grid points (1, rad/s).
    gains : numpy.ndarray, shape (n, 2, 7)
        The gain at each point.
    degrees : range, optional
        The total degrees to try, increasing.
    folds : int, optional
        Number k of cross-validation folds.
    seed : int, optional
        Seed of the random assignment of the points to the folds.
    cv_tol : float or None, optional
        Cross-validated RMS error (relative to the largest gain entry) the chosen degree must
        reach; None: the degree of the smallest CV error.

    Returns
    -------
    GainFit
        The fit at the chosen degree.

    Raises
    ------
    ValueError
        If shapes disagree or the grid has fewer points than twice the largest basis.
    """
    points, gains = np.asarray(points, float), np.asarray(gains, float)
    if points.ndim != 2 or points.shape[1] != 2 or gains.shape[0] != points.shape[0]:
        raise ValueError(f"points must be (n, 2) and gains (n, ...), got {points.shape} and {gains.shape}")
    return GainFit(*fit_gains(points, gains, degrees, folds, seed, cv_tol), points, gains, cv_tol)


def _servo_data(name: str, description: str, gain: list, certificate: dict, provenance: dict,
                fit_info: dict | None = None) -> dict:
    data = {"format": FORMAT, "format_version": FORMAT_VERSION, "kind": SERVO_KIND, "name": name,
            "description": description, "plant": "vscmg", "tracked": TRACKED, "rates": RATES,
            "scheduling": SCHEDULING, "outputs": OUTPUTS, "gain": gain, "certificate": certificate,
            "provenance": {**provenance, "design_plant": design_plant_record(vscmg.MODEL)}}
    if fit_info:
        data["fit"] = fit_info
    return data


OFFGRID_TOL = 2e-2
"""Largest off-grid error of a fit (relative to the largest gain entry) :func:`certify` accepts.
It catches a broken fit (wrong grid, extrapolation); the closed-loop consequences of the
approximation are checked by the simulation and proved by :mod:`satfmu.synthesis.servo.vscmg_region`.
The shipped degree-4 fit's worst point, a corner at q2 = 0.22 rad, w4 = -0.58 rad/s, is 1.0e-2."""


def certify(result: GainFit, servo: Servo, max_re_tol: float = 1e-6) -> dict[str, float]:
    """Check a fitted gain independently of the least-squares fit; the numbers it measured.

    - Off-grid accuracy: the checked SDRE gain at the midpoints of the fit grid (points the
      fit never saw) against the polynomials: largest and RMS relative error.
    - Frozen closed loop: the largest real part of the eigenvalues of Ae(x) - Be(x) K_fit(x)
      at the grid points and the midpoints, 1/s. The conserved p4 keeps one eigenvalue at 0,
      so the bound is ``max_re_tol`` (as :func:`satfmu.controllers.riccati.riccati_gain`).
    - Closed-loop simulation of the fitted law on the seed's manoeuvre (frictionless plant,
      10 ms hold): errors at 15 s (rad) and peak torques (N m) against issue 11's bounds
      (``|e2| < 1 mrad``, ``|e4| < 0.1 mrad``, ``|T1| < 0.6``, ``|T2| < 2.4 N m``).

    Parameters
    ----------
    result : GainFit
        The fit to check.
    servo : satfmu.synthesis.servo.sdre.Servo
        The SDRE servo the fit approximates: its checked gain off the grid, its Ae, Be for the
        frozen closed loop and its model for the simulation.
    max_re_tol : float, optional
        Largest admitted real part of a frozen closed-loop eigenvalue, 1/s.

    Returns
    -------
    dict
        The measured numbers by name (``offgrid_max_rel_error``, ``frozen_max_re``,
        ``sim_e2_final``, ``sim_peak_T1``, ...).

    Raises
    ------
    FitCertificationError
        Naming every bound that failed.
    """
    from satfmu.fmus.profiles import make
    from satfmu.synthesis.servo.sdre import SEED_REFERENCE_PROFILES, simulate_servo

    sq = np.unique(result.points[:, 0])
    w4 = np.unique(result.points[:, 1])
    mid = np.array([(a, b) for a in (sq[1:] + sq[:-1]) / 2 for b in (w4[1:] + w4[:-1]) / 2])
    exact = np.array([servo(np.array([0.0, np.arcsin(a), 0.0, 0.0, 0.0, b])) for a, b in mid])
    err = (result.evaluate(mid) - exact).reshape(len(mid), -1)
    scale = float(np.max(np.abs(exact)))
    max_re = -np.inf
    for a, b in np.concatenate([result.points, mid]):
        x = np.array([0.0, np.arcsin(a), 0.0, 0.0, 0.0, b])
        A, B = servo.matrices(x)
        max_re = max(max_re, float(np.max(np.linalg.eigvals(A - B @ result(x)).real)))
    refs = [make(SEED_REFERENCE_PROFILES[n]) for n in ("q2_ref", "q4_ref")]
    run = simulate_servo(result, lambda t: np.stack([r.sample(t) for r in refs], axis=1),
                         plant_params={"friction_on": 0}, model=servo.model)
    e = run.errors[-1]
    numbers = {"offgrid_max_rel_error": float(np.max(np.abs(err)) / scale),
               "offgrid_rms_rel_error": float(np.sqrt(np.mean(err**2)) / scale),
               "frozen_max_re": max_re, "sim_e2_final": float(e[0]), "sim_e4_final": float(e[1]),
               "sim_peak_T1": float(np.max(np.abs(run.u[:, 0]))), "sim_peak_T2": float(np.max(np.abs(run.u[:, 1])))}
    failures = [f"{k} = {numbers[k]:.3g} exceeds {bound:g}" for k, bound in
                (("frozen_max_re", max_re_tol), ("offgrid_max_rel_error", OFFGRID_TOL))
                if not numbers[k] <= bound]
    failures += [f"|{k}| = {abs(numbers[k]):.3g} exceeds {bound:g}" for k, bound in
                 (("sim_e2_final", 1e-3), ("sim_e4_final", 1e-4), ("sim_peak_T1", 0.6), ("sim_peak_T2", 2.4))
                 if not abs(numbers[k]) < bound]
    if failures:
        raise FitCertificationError("fitted SDRE gain rejected: " + "; ".join(failures))
    return numbers


def approximated_sdre_data(result: GainFit, servo: Servo, checks: dict[str, float],
                           name: str = "vscmg_sdre_approx") -> dict:
    """Artifact data of the approximated SDRE servo; ``checks`` from :func:`certify`.

    Parameters
    ----------
    result : GainFit
        The verified fit.
    servo : satfmu.synthesis.servo.sdre.Servo
        The servo it approximates (its factorization and weights are recorded).
    checks : dict
        The numbers of :func:`certify`, recorded in the certificate.
    name : str, optional
        The artifact's name, lower_snake_case (the controller FMU's modelIdentifier).

    Returns
    -------
    dict
        The artifact's JSON data, kind ``servo_gain_schedule``, status ``sampled``.
    """
    gain = result.terms()
    fit_info = {"degree": result.degree, "scheduling": SCHEDULING, "cv_tol": result.cv_tol,
                "cv_rms_rel_error": {str(k): v for k, v in result.cv_errors.items()},
                "max_rel_error": result.max_rel_error, "rms_rel_error": result.rms_rel_error,
                "grid": {"q2": list(Q2_RANGE), "w4": list(W4_RANGE), "points": len(result.points)}}
    cert = {"status": "sampled",
            "proved": "checked by sampling, not proved: the frozen closed loop Ae - Be K_fit has no eigenvalue "
                      "right of the conserved-p4 mode at 0 on the fit grid and its midpoints; off-grid fit error; "
                      "the seed's manoeuvre tracked in closed-loop simulation (frictionless)",
            "region": f"q2 in {list(Q2_RANGE)} rad, w4 in {list(W4_RANGE)} rad/s, w2 = 0",
            "domain": [domain.interval("q2", *Q2_RANGE), domain.interval("w4", *W4_RANGE)],
            "numbers": {"fit_max_rel_error": result.max_rel_error, "fit_rms_rel_error": result.rms_rel_error,
                        **checks}}
    prov = {"source": "satfmu satfmu.synthesis.servo.gain_fit (seed 002 section 3.2)",
            "factorization": servo.factorization,
            "freeze_w2": servo.freeze_w2, "eps": servo.eps, "Q": np.diag(servo.Q).tolist(),
            "R": np.diag(servo.R).tolist()}
    return _servo_data(name, "Approximated SDRE servo of the VSCMG (seed 002): polynomial gains in sin q2, w4",
                       gain, cert, prov, fit_info)


def lq_data(servo: Servo, x0: np.ndarray, name: str = "vscmg_lq_servo") -> dict:
    """Artifact data of the LQ servo designed at the plant state ``x0`` (a constant gain).

    Parameters
    ----------
    servo : satfmu.synthesis.servo.sdre.Servo
        The servo whose checked gain at ``x0`` is the LQ gain.
    x0 : numpy.ndarray, shape (6,)
        The design state ``[q1, q2, q4, w1, w2, w4]`` (rad, rad/s).
    name : str, optional
        The artifact's name, lower_snake_case (the controller FMU's modelIdentifier).

    Returns
    -------
    dict
        The artifact's JSON data, kind ``servo_gain_schedule`` with degree-0 gains.
    """
    K, check = servo.gain(np.asarray(x0, float))
    gain = [[[{"c": float(K[i, j]), "e": [0, 0]}] for j in range(7)] for i in range(2)]
    cert = {"status": "certified", "proved": "Riccati solution at the design state checked (residual, "
            "closed-loop eigenvalues of the linearization's SDC pair)",
            "region": f"design state q2 = {x0[1]:.6g} rad, rest",
            "domain": [domain.interval("q2", x0[1], x0[1]),
                       *(domain.interval(w, 0.0, 0.0) for w in ("w1", "w2", "w4"))],
            "numbers": {"riccati_residual": check.residual, "max_re_closed_loop": check.max_re,
                        "max_re_shifted": check.max_re_shifted}}
    prov = {"source": "satfmu satfmu.synthesis.servo.gain_fit.lq_data (substitute baseline, seed 002 section 5.1)",
            "factorization": servo.factorization, "eps": servo.eps, "x0": list(map(float, x0))}
    return _servo_data(name, "LQ servo of the VSCMG designed at the start state (seed 002 baseline)",
                       gain, cert, prov)


START_STATE = np.array([0.0, np.pi / 18, 0.0, 0.0, 0.0, 0.0])
"""The seed's start state q0 = [0, pi/18, 0] at rest (design point of the LQ baseline)."""


def synthesize(n_q2: int = 23, n_w4: int = 25, degrees: range = range(1, 9), cv_tol: float | None = CV_TOL,
               region: bool = True, progress: Progress | None = None) -> tuple[GainFit, dict, dict]:
    """Seed 002's approximated SDRE and the LQ baseline: the fit and both artifacts' data.

    The approximation uses the seed's w1-free SDC with w2 := 0 (a gain in q2 and w4 only,
    fitted in sin q2 and w4 with the degree rule of :func:`fit`);
    the fit is verified by :func:`certify` with the plant's own factorization on the same
    grid before its data is returned. With ``region`` the SOS stability region of
    :mod:`satfmu.synthesis.servo.vscmg_region` is solved on its operating box and the certificate says
    what it proved (status ``certified`` only if it holds).

    Parameters
    ----------
    n_q2 : int, optional
        Grid points over :data:`Q2_RANGE` (rad).
    n_w4 : int, optional
        Grid points over :data:`W4_RANGE` (rad/s).
    degrees : range, optional
        The total degrees to try (:func:`fit`).
    cv_tol : float or None, optional
        The degree rule's tolerance (:func:`fit`).
    region : bool, optional
        Solve the SOS stability region and record it in the certificate.
    progress : callable, optional
        ``progress(done, total, message)`` after each stage (grid, fit, check, region, LQ); the
        stages are logged too (:class:`satfmu.synthesis.core.progress.Stages`).

    Returns
    -------
    fit : GainFit
        The fit.
    approximated : dict
        The approximated SDRE servo's artifact data.
    lq : dict
        The LQ servo's artifact data (at :data:`START_STATE`).

    Raises
    ------
    FitCertificationError, satfmu.controllers.riccati.RiccatiCheckError
        If the fit fails :func:`certify`, or a Riccati solution fails its checks.
    """
    stages = Stages(4 + bool(region), progress, LOG)
    servo = Servo("w1_free", freeze_w2=True)
    with stages.stage(f"SDRE gains on the {n_q2} x {n_w4} grid"):
        grid = sdre_grid(servo, n_q2, n_w4)
    with stages.stage("polynomial gain fit"):
        result = fit(*grid, degrees=degrees, cv_tol=cv_tol)
    with stages.stage(f"fit of degree {result.degree} certified against the plant's factorization"):
        checks = certify(result, servo)
    approx = approximated_sdre_data(result, servo, checks)
    if region:
        from satfmu.controllers.artifact import ServoArtifact, parse
        from satfmu.synthesis.servo import vscmg_region

        # approximated_sdre_data writes a servo_gain_schedule record, which parses to a ServoArtifact
        with stages.stage("SOS stability region of the fitted law on the operating box"):
            cert, trig = vscmg_region.certify_operating_box(cast(ServoArtifact, parse(approx)))
        approx["certificate"] = vscmg_region.artifact_certificate(approx["certificate"], cert, trig)
    with stages.stage("LQ servo"):
        lq = lq_data(Servo("gyro_on_w2"), START_STATE)
    return result, approx, lq


def table(result: GainFit, checks: dict[str, float]) -> str:
    """Cross-validation errors per degree and the verification numbers, as text.

    Parameters
    ----------
    result : GainFit
        The fit.
    checks : dict
        The numbers of :func:`certify`.
    """
    lines = ["degree  CV RMS rel. error"]
    lines += [f"{d:6d}  {e:.3e}{'  <- chosen' if d == result.degree else ''}" for d, e in result.cv_errors.items()]
    lines.append(f"on the grid: max rel. error {result.max_rel_error:.3e}, RMS {result.rms_rel_error:.3e}")
    lines += [f"{k}: {v:.4g}" for k, v in checks.items()]
    return "\n".join(lines)
