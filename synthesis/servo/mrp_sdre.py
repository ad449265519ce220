"""Approximated SDRE servo of a rigid spacecraft on the MRP plant, with an SOS stability region.

Seed 002's method (docs/models.md "Seed 002": an SDRE optimal servo, a least-squares polynomial
fit of its gain over an operating box, and an SOS-certified stability region of the fitted
law), applied to the user's rigid spacecraft on satfmu's MRP satellite plant
(:mod:`satfmu.fmus.plants.mrp_satellite`) instead of the VSCMG
(:mod:`satfmu.synthesis.servo.gain_fit`, :mod:`satfmu.synthesis.servo.vscmg_region`).

Stages (:func:`synthesize`):

1. :class:`MRPServo`: ``Ae(x)``, ``Be(x)`` of :func:`satfmu.controllers.mrp_servo_sdc.servo_matrices`
   lambdified, and the checked gain ``K(x)`` (:func:`satfmu.controllers.riccati.riccati_gain`).
2. :func:`sdre_samples`: the gain at quasi-random (Sobol) points of the operating box
   ``|sigma_i| <= s_max``, ``|omega_i| <= w_max`` (:func:`default_box`).
3. :func:`fit`: every gain entry a polynomial of total degree ``d`` in the six plant states
   (``omega``, ``sigma``), least squares; ``d`` the smallest degree whose k-fold
   cross-validated error is within :data:`CV_TOL` (degrees up to 2, so that the closed loop
   stays of degree 4 and the SOS program small).
4. :func:`check_fit`: independent of the fit: the SDRE gain at fresh points against the
   polynomials, the frozen closed loops ``Ae - Be K_fit`` at those points, and a closed-loop
   simulation (:func:`simulate`, scipy ``solve_ivp`` on the plant's own right-hand side) of
   a 90 deg rest-to-rest manoeuvre.
5. :func:`certify_region`: at ``sigma_ref = 0`` the closed loop ``xe' = (Ae - Be K_fit) xe`` is
   polynomial in ``xe``; the largest level ``c`` of ``V = xe^T P0 xe`` (``P0`` the Riccati
   solution at the origin) with ``-V' - eps |y|^2 + l (V - c)`` SOS (``l`` SOS, S-procedure,
   ``y = L^T xe`` with ``P0 = L L^T``) is found by bisection; every solution is re-checked
   by :func:`satfmu.synthesis.core.sos.certify` and on samples of the region.
6. :func:`artifact_data`: a ``servo_gain_schedule`` artifact for plant ``mrp_satellite`` whose
   ``provenance.design_plant`` is the user's plant.

What the region proves: for the fitted law (the polynomials the FMU evaluates, no
approximation) on the unsaturated plant with a constant reference ``sigma_ref = 0``, every
trajectory starting in ``{xe : xe^T P0 xe <= c}`` stays there and converges to the
reference (``V`` decreases strictly). It says nothing about actuator saturation.
"""
from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np
import sympy as sp

from satfmu.controllers.artifact import FORMAT, FORMAT_VERSION, SERVO_KIND, design_plant_record
from satfmu.controllers.mrp_servo_sdc import (EPS, OUTPUTS, RATES, SCHEDULING, SIGMA_90DEG, TRACKED,
                                              default_weights, servo_matrices, servo_state, slew_rate)
from satfmu.controllers.riccati import riccati_gain
from satfmu.fmus.errors import FitCertificationError, SOSError
from satfmu.fmus.model import Model
from satfmu.fmus.plants.spacecraft import PARAMETERS, Spacecraft
from satfmu.synthesis.core import sos
from satfmu.synthesis.core.polynomial import Poly, monomials
from satfmu.synthesis.core.progress import Progress, Stages
from satfmu.synthesis.servo.sdc_servo import SdcServo
from satfmu.synthesis.servo.polynomial_fit import PolynomialFit, exponents, fit_gains

LOG = logging.getLogger(__name__)

CV_TOL = 5e-3
"""Cross-validated RMS fit error (relative to the largest gain entry) the chosen degree must reach."""
MAX_DEGREE = 2
"""Highest total degree of the fitted gain: the closed loop is then of degree 4 in xe and the
region's SOS program has a 54-monomial Gram basis."""
OFFGRID_TOL = 0.25
"""Largest off-sample fit error (relative to the largest gain entry) :func:`check_fit` accepts. The
degree-2 fit's worst points are box corners (``|sigma| = 0.72``, a 130 deg rotation, every rate at
w_max), where the SDRE gain bends most: measured 0.17 for seed 000's satellite (RMS 0.017). It
catches a broken fit; the closed-loop consequences are checked by the frozen loops, the
simulation and the SOS region."""
OFFGRID_RMS_TOL = 0.03
"""Largest off-sample RMS fit error (relative to the largest gain entry); measured 0.017 (seed 000)."""
EPS_FRACTION = 0.01
"""``eps`` of the region condition as a fraction of the origin's decay ``lambda_min(L^-1 (Q + K^T R K) L^-T)``:
the certified decrease ``V' <= -eps |y|^2`` is 1 % of the LQ loop's at the origin."""


def _finite_positive(value: float, name: str) -> float:
    v = float(value)
    if not (math.isfinite(v) and v > 0):
        raise ValueError(f"{name} must be finite and > 0, got {value!r}")
    return v


def default_box(spacecraft: Spacecraft) -> tuple[float, float]:
    """The default operating box ``(s_max, w_max)``: ``|sigma_i| <= s_max``, ``|omega_i| <= w_max``.

    ``s_max = tan(90 deg / 4)`` (a 90 deg rotation about a body axis) and ``w_max`` the peak
    rate of a torque-limited 90 deg slew (:func:`satfmu.controllers.mrp_servo_sdc.slew_rate`).

    Parameters
    ----------
    spacecraft : Spacecraft
        The spacecraft (inertia kg m^2, torque limit N m).

    Returns
    -------
    tuple of float
        ``(s_max (1), w_max (rad/s))``.
    """
    return SIGMA_90DEG, slew_rate(spacecraft)


def spacecraft_of(model: Model) -> Spacecraft:
    """The spacecraft an MRP plant model was built for (its inertia and ``u_max`` defaults).

    Parameters
    ----------
    model : Model
        An MRP satellite model of :func:`satfmu.fmus.plants.mrp_satellite.build`.

    Returns
    -------
    Spacecraft
        Named ``"design_plant"``, with the model's inertia tensor (kg m^2) and ``u_max`` (N m)
        as its torque limit.
    """
    p = {v.name: float(v.start) for v in model.parameters}
    J = np.zeros((3, 3))
    for name, (i, j) in PARAMETERS.items():
        J[i, j] = J[j, i] = p[name]
    return Spacecraft("design_plant", J, p.get("u_max"))


def _check_weights(Q: np.ndarray, R: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    Q, R = np.asarray(Q, float), np.asarray(R, float)
    if Q.shape != (9, 9) or R.shape != (3, 3):
        raise ValueError(f"Q must be 9x9 and R 3x3, got {Q.shape} and {R.shape}")
    for name, M in (("Q", Q), ("R", R)):
        if not np.all(np.isfinite(M)) or not np.allclose(M, M.T):
            raise ValueError(f"{name} must be finite and symmetric")
    if np.linalg.eigvalsh(Q).min() <= 0 or np.linalg.eigvalsh(R).min() <= 0:
        raise ValueError("weights must be positive definite (Q > 0 for the region's V = xe^T P0 xe, R > 0)")
    return Q, R


@dataclass
class MRPServo(SdcServo):
    """Numerical SDRE servo of the MRP plant (:class:`satfmu.synthesis.servo.sdc_servo.SdcServo`):
    Ae (9x9), Be (9x3) at a plant state ``[omega, sigma]`` (rad/s, 1) and the checked gain K (3x9,
    ``u = -K xe`` in N m).

    Parameters
    ----------
    model : Model
        The MRP satellite model of the user's spacecraft (its symbols and parameter defaults).
    Q : numpy.ndarray, shape (9, 9), optional
        State weight of ``xe``; default :func:`satfmu.controllers.mrp_servo_sdc.default_weights`.
    R : numpy.ndarray, shape (3, 3), optional
        Input weight, 1/(N m)^2; default as ``Q``.
    eps : float, optional
        Riccati shift, 1/s.

    Raises
    ------
    ValueError
        If the weights are not 9x9 and 3x3, symmetric and positive definite.
    """

    model: Model = field(repr=False)
    Q: np.ndarray | None = None
    R: np.ndarray | None = None
    eps: float = EPS

    def __post_init__(self) -> None:
        Ae, Be = servo_matrices(self.model)
        if self.Q is None or self.R is None:
            Q0, R0 = default_weights(spacecraft_of(self.model))
            self.Q = Q0 if self.Q is None else self.Q
            self.R = R0 if self.R is None else self.R
        self.Q, self.R = _check_weights(self.Q, self.R)
        self._compile(self.model, Ae, Be)

    @property
    def weights(self) -> tuple[np.ndarray, np.ndarray]:
        """``(Q, R)``, shapes (9, 9) and (3, 3)."""
        assert self.Q is not None and self.R is not None
        return self.Q, self.R

    def describe_state(self, x: np.ndarray) -> str:
        """The rates and MRPs of the plant state ``[omega, sigma]`` (rad/s, 1).

        Parameters
        ----------
        x : numpy.ndarray, shape (6,)
            The plant state.
        """
        return f"omega = {x[:3]} rad/s, sigma = {x[3:]}"

    def riccati_at_origin(self) -> np.ndarray:
        """The Riccati solution ``P0`` (9x9) of the LQ servo at the origin (``V = xe^T P0 xe``)."""
        from scipy.linalg import solve_continuous_are

        A, B = self.matrices(np.zeros(6))
        Q, R = self.weights
        P = solve_continuous_are(A - self.eps * np.eye(9), B, Q, R)
        return (P + P.T) / 2

    def __call__(self, x: np.ndarray) -> np.ndarray:
        """The checked gain K (3x9) at the plant state ``x`` (6 values: rad/s, 1)."""
        return self.gain(x)[0]


def check_box(s_max: float, w_max: float) -> tuple[float, float]:
    """Validate an operating box.

    Parameters
    ----------
    s_max : float
        Bound on every MRP component, 0 < s_max <= 1.
    w_max : float
        Bound on every body rate, rad/s, > 0.

    Returns
    -------
    tuple of float
        ``(s_max, w_max)`` as floats.

    Raises
    ------
    ValueError
        On a NaN, infinite or non-positive bound, or ``s_max > 1``.
    """
    s, w = _finite_positive(s_max, "s_max"), _finite_positive(w_max, "w_max (rad/s)")
    if s > 1:
        raise ValueError(f"s_max must be <= 1 (|sigma| <= 1 is the MRP's unique range), got {s_max!r}")
    return s, w


def box_points(n: int, s_max: float, w_max: float, seed: int = 0) -> np.ndarray:
    """``n`` scrambled-Sobol points of the box, plant-state order ``[omega, sigma]``.

    Parameters
    ----------
    n : int
        Number of points.
    s_max : float
        MRP bound (1).
    w_max : float
        Rate bound, rad/s.
    seed : int, optional
        Seed of the scrambling.

    Returns
    -------
    numpy.ndarray, shape (n, 6)
        The points (rad/s, 1).
    """
    from scipy.stats import qmc

    u = qmc.Sobol(6, seed=seed).random(n)
    return (2 * u - 1) * np.array([w_max] * 3 + [s_max] * 3)


def sdre_samples(servo: MRPServo, s_max: float, w_max: float, n: int = 256, seed: int = 0
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Checked SDRE gains at ``n`` Sobol points of the box.

    Parameters
    ----------
    servo : MRPServo
        The servo.
    s_max : float
        MRP bound (1).
    w_max : float
        Rate bound, rad/s.
    n : int, optional
        Number of points (a power of 2 keeps the Sobol sequence balanced).
    seed : int, optional
        Seed of the Sobol scrambling.

    Returns
    -------
    points : numpy.ndarray, shape (n, 6)
        The plant states ``[omega, sigma]`` (rad/s, 1).
    gains : numpy.ndarray, shape (n, 3, 9)
        The gains.

    Raises
    ------
    satfmu.controllers.riccati.RiccatiCheckError
        If a Riccati solution fails its checks.
    """
    points = box_points(n, s_max, w_max, seed)
    return points, np.array([servo(x) for x in points])


@dataclass
class GainFit(PolynomialFit):
    """The SDRE servo's gain (3x9) fitted on the monomials of the plant state (an instance of
    :class:`satfmu.synthesis.servo.polynomial_fit.PolynomialFit`: ``points`` are the sampled states
    ``[omega, sigma]``, rad/s and 1; ``gains`` the SDRE gains there, shape (n, 3, 9)).

    Attributes
    ----------
    degree : int
        Total degree chosen by cross-validation.
    coefficients : numpy.ndarray, shape (3, 9, n_terms)
        Coefficients of each gain entry, in the order of
        ``satfmu.synthesis.servo.polynomial_fit.exponents(6, degree)``.
    cv_errors : dict of int to float
        Cross-validated RMS error (relative to the largest gain entry) per degree tried.
    max_rel_error, rms_rel_error : float
        Largest and RMS ``|K_fit - K|`` on the samples, relative to the largest ``|K|`` entry.
    points : numpy.ndarray, shape (n, 6)
        The sampled plant states ``[omega, sigma]``, rad/s and 1.
    gains : numpy.ndarray, shape (n, 3, 9)
        The SDRE gains there.
    cv_tol : float or None
        The tolerance the degree was chosen with.
    """

    def __call__(self, x: np.ndarray) -> np.ndarray:
        """K (3x9) at the plant state ``x`` (6 values: rad/s, 1)."""
        return self.evaluate(x)[0]


def fit(points: np.ndarray, gains: np.ndarray, degrees: range = range(0, MAX_DEGREE + 1), folds: int = 5,
        seed: int = 0, cv_tol: float | None = CV_TOL) -> GainFit:
    """Least-squares polynomial fit of every gain entry; degree by k-fold cross-validation:
    the smallest degree whose CV error is within ``cv_tol``, else (or with None) the one with
    the smallest CV error.

    Parameters
    ----------
    points : numpy.ndarray, shape (n, 6)
        Plant states ``[omega, sigma]`` (rad/s, 1).
    gains : numpy.ndarray, shape (n, 3, 9)
        The gain at each point.
    degrees : range, optional
        Total degrees to try, increasing, within ``0 .. MAX_DEGREE``.
    folds : int, optional
        Number k of cross-validation folds, >= 2.
    seed : int, optional
        Seed of the random assignment of points to folds.
    cv_tol : float or None, optional
        Relative CV error the chosen degree must reach; None: the smallest CV error.

    Returns
    -------
    GainFit
        The fit at the chosen degree.

    Raises
    ------
    ValueError
        On wrong shapes, non-finite data, degrees outside ``0 .. MAX_DEGREE``, fewer than 2
        folds, or fewer points than twice the largest basis.
    """
    points, gains = np.asarray(points, float), np.asarray(gains, float)
    if points.ndim != 2 or points.shape[1] != 6 or gains.shape != (len(points), 3, 9):
        raise ValueError(f"points must be (n, 6) and gains (n, 3, 9), got {points.shape} and {gains.shape}")
    if not (np.all(np.isfinite(points)) and np.all(np.isfinite(gains))):
        raise ValueError("points and gains must be finite")
    degrees = range(degrees.start, degrees.stop, degrees.step)
    if len(degrees) == 0 or min(degrees) < 0 or max(degrees) > MAX_DEGREE:
        raise ValueError(f"degrees must lie in 0 .. {MAX_DEGREE} (the region's SOS program), got {degrees}")
    if folds < 2:
        raise ValueError(f"folds must be >= 2, got {folds}")
    return GainFit(*fit_gains(points, gains, degrees, folds, seed, cv_tol), points, gains, cv_tol)


@dataclass
class Run:
    """A closed-loop simulation of the plant and a servo law.

    Attributes
    ----------
    t : numpy.ndarray, shape (n,)
        Times, s.
    x : numpy.ndarray, shape (n, 6)
        Plant state ``[omega (rad/s), sigma (1)]``.
    integrals : numpy.ndarray, shape (n, 3)
        Integrals of the MRP errors, s.
    u : numpy.ndarray, shape (n, 3)
        Commands, N m.
    reference : numpy.ndarray, shape (3,)
        The constant reference MRPs (1).
    """

    t: np.ndarray
    x: np.ndarray
    integrals: np.ndarray
    u: np.ndarray
    reference: np.ndarray

    @property
    def angle_error(self) -> np.ndarray:
        """Principal angle between attitude and reference, rad, shape (n,) (MRP composition)."""
        r = self.reference
        s = self.x[:, 3:6]
        # relative MRP of sigma w.r.t. sigma_ref (Schaub & Junkins' subtraction)
        rr, ss = float(r @ r), np.sum(s * s, axis=1)
        num = (1 - rr) * s - (1 - ss)[:, None] * r + 2 * np.cross(s, r)
        den = 1 + rr * ss + 2 * (s @ r)
        return 4 * np.arctan(np.linalg.norm(num, axis=1) / den)


def simulate(model: Model, gain: Callable[[np.ndarray], np.ndarray], x0: np.ndarray,
             reference: np.ndarray | None = None, stop_time: float = 60.0, saturate: bool = False,
             n_out: int = 601) -> Run:
    """Plant and servo ``u = -K(x) xe`` with scipy ``solve_ivp`` (RK45, rtol 1e-8) on the plant's
    own right-hand side (``model.rhs``, not its SDC form).

    Parameters
    ----------
    model : Model
        The MRP satellite model (parameter defaults: the spacecraft).
    gain : callable
        ``gain(x)`` -> K, shape (3, 9), at the plant state ``x`` (6 values).
    x0 : numpy.ndarray, shape (6,)
        Initial plant state ``[omega (rad/s), sigma (1)]``; the integrals start at 0.
    reference : numpy.ndarray, shape (3,), optional
        The constant reference MRPs (default 0).
    stop_time : float, optional
        s.
    saturate : bool, optional
        Saturate the torque at the plant's ``u_max`` (the plant's ``saturation_on``).
    n_out : int, optional
        Number of output times.

    Returns
    -------
    Run
        The trajectory.
    """
    from scipy.integrate import solve_ivp

    ref = np.zeros(3) if reference is None else np.asarray(reference, float)
    names = [v.name for v in model.parameters]
    p = model.parameter_vector()
    p[names.index("saturation_on")] = 1.0 if saturate else 0.0
    f = sp.lambdify((model.state_symbols, model.input_symbols, model.parameter_symbols), model.rhs, "numpy",
                    cse=True)

    def command(z: np.ndarray) -> np.ndarray:
        return -gain(z[:6]) @ servo_state(z[:6], z[6:9], ref)

    def rhs(_t: float, z: np.ndarray) -> np.ndarray:
        u = command(z)
        dx = np.asarray(f(z[:6], np.concatenate([u, np.zeros(3)]), p), float).ravel()
        return np.concatenate([dx, ref - z[3:6]])

    t = np.linspace(0.0, stop_time, n_out)
    sol = solve_ivp(rhs, (0.0, stop_time), np.concatenate([np.asarray(x0, float), np.zeros(3)]), t_eval=t,
                    rtol=1e-8, atol=1e-10)
    if not sol.success:
        raise RuntimeError(f"closed-loop simulation failed: {sol.message}")
    z = sol.y.T
    u = np.array([command(zi) for zi in z])
    if saturate:
        u = np.clip(u, -p[names.index("u_max")], p[names.index("u_max")])
    return Run(sol.t, z[:, :6], z[:, 6:9], u, ref)


START_AXIS = np.array([1.0, 1.0, 1.0]) / math.sqrt(3.0)
"""Axis of the 90 deg rest-to-rest check manoeuvre (all three body axes excited)."""


def rest_to_rest_start(angle: float = math.pi / 2, axis: np.ndarray = START_AXIS) -> np.ndarray:
    """Plant state at rest rotated by ``angle`` (rad) about ``axis`` from the reference 0.

    Parameters
    ----------
    angle : float, optional
        rad (default 90 deg).
    axis : numpy.ndarray, shape (3,), optional
        Rotation axis (normalized here).

    Returns
    -------
    numpy.ndarray, shape (6,)
        ``[omega = 0, sigma = axis tan(angle / 4)]``.
    """
    k = np.asarray(axis, float)
    return np.concatenate([np.zeros(3), k / np.linalg.norm(k) * math.tan(angle / 4)])


def check_fit(result: GainFit, servo: MRPServo, s_max: float, w_max: float, n: int = 128, seed: int = 1,
              stop_time: float = 60.0) -> dict[str, float]:
    """Check a fitted gain independently of the least squares; the numbers it measured.

    - Off-sample accuracy: the checked SDRE gain at ``n`` fresh Sobol points (another
      scrambling) against the polynomials (largest and RMS relative error).
    - Frozen closed loop: the largest real part of the eigenvalues of ``Ae(x) - Be(x) K_fit(x)``
      at the samples and the fresh points, 1/s.
    - Simulation: the fitted law from a 90 deg rest-to-rest start (:func:`rest_to_rest_start`)
      on the unsaturated plant: the angle error at ``stop_time`` (deg) and the peak torque (N m).

    Parameters
    ----------
    result : GainFit
        The fit.
    servo : MRPServo
        The SDRE servo it approximates.
    s_max : float
        MRP bound of the box (1).
    w_max : float
        Rate bound of the box, rad/s.
    n : int, optional
        Number of fresh points.
    seed : int, optional
        Seed of their scrambling (differs from the fit's).
    stop_time : float, optional
        Length of the simulation, s.

    Returns
    -------
    dict of str to float
        ``offgrid_max_rel_error``, ``offgrid_rms_rel_error``, ``frozen_max_re`` (1/s),
        ``sim_final_angle_deg``, ``sim_peak_torque`` (N m), ``sim_stop_time`` (s).

    Raises
    ------
    FitCertificationError
        If the off-sample error exceeds :data:`OFFGRID_TOL` (RMS: :data:`OFFGRID_RMS_TOL`), a
        frozen loop is not stable, or the simulation ends more than 1 deg from the reference.
    """
    fresh = box_points(n, s_max, w_max, seed)
    exact = np.array([servo(x) for x in fresh])
    err = (result.evaluate(fresh) - exact).reshape(n, -1)
    scale = float(np.max(np.abs(exact)))
    max_re = -np.inf
    for x in np.concatenate([result.points, fresh]):
        A, B = servo.matrices(x)
        max_re = max(max_re, float(np.max(np.linalg.eigvals(A - B @ result(x)).real)))
    run = simulate(servo.model, result, rest_to_rest_start(), stop_time=stop_time)
    numbers = {"offgrid_max_rel_error": float(np.max(np.abs(err)) / scale),
               "offgrid_rms_rel_error": float(np.sqrt(np.mean(err**2)) / scale),
               "frozen_max_re": max_re, "sim_final_angle_deg": float(np.degrees(run.angle_error[-1])),
               "sim_peak_torque": float(np.max(np.abs(run.u))), "sim_stop_time": float(stop_time)}
    failures = []
    if not numbers["offgrid_max_rel_error"] <= OFFGRID_TOL:
        failures.append(f"off-sample error {numbers['offgrid_max_rel_error']:.3g} > {OFFGRID_TOL:g}")
    if not numbers["offgrid_rms_rel_error"] <= OFFGRID_RMS_TOL:
        failures.append(f"off-sample RMS error {numbers['offgrid_rms_rel_error']:.3g} > {OFFGRID_RMS_TOL:g}")
    if not max_re < 0:
        failures.append(f"frozen closed loop unstable (max Re {max_re:.3g} 1/s)")
    if not numbers["sim_final_angle_deg"] < 1.0:
        failures.append(f"90 deg manoeuvre ends {numbers['sim_final_angle_deg']:.3g} deg from the reference")
    if failures:
        hint = ""
        if numbers["offgrid_max_rel_error"] > OFFGRID_TOL or numbers["offgrid_rms_rel_error"] > OFFGRID_RMS_TOL:
            hint = (f" (the SDRE gain varies more over |sigma_i| <= {s_max:.3g}, |omega_i| <= {w_max:.3g} rad/s than "
                    f"polynomials of degree <= {MAX_DEGREE} follow: a smaller box, s_max and w_max, brings the fit "
                    f"closer)")
        raise FitCertificationError("fitted SDRE gain rejected: " + "; ".join(failures) + hint)
    return numbers


@dataclass
class RegionCertificate:
    """The SOS stability region of the fitted law at ``sigma_ref = 0``.

    Attributes
    ----------
    certified : bool
        A level ``c > 0`` was found whose program passed :func:`satfmu.synthesis.core.sos.certify`
        and the sampled check.
    level : float
        The certified level ``c`` of ``V = xe^T P0 xe`` (0 if none).
    P0 : numpy.ndarray, shape (9, 9)
        The Lyapunov matrix (Riccati solution of the LQ servo at the origin).
    eps : float
        Certified decrease: ``V' <= -eps |L^T xe|^2`` on the region.
    sigma_max : float
        Largest ``|e_i|`` (= ``|sigma_i|``) on the region, ``sqrt(c (P0^-1)_ii)`` minimized over i (1).
    angle_deg : float
        ``4 atan(sigma_max)``, deg: every rotation about a body axis up to this angle (at rest,
        zero integrals) lies in the region if its MRP component satisfies it along all axes;
        see ``rest_angle_deg`` for the exact rest-start bound.
    rest_angle_deg : float
        Largest rest-to-rest angle (deg), about the worst axis, whose start (omega = 0,
        integrals 0) lies in the region.
    omega_max : float
        Largest ``|omega_i|`` on the region, rad/s (minimum over i).
    checks : list of satfmu.synthesis.core.sos.Check
        The re-checks of the certified program.
    sampled_max_vdot : float
        Largest ``V' / |y|^2`` at random points of the region (must be < 0).
    levels : list of tuple of (float, bool)
        Every level tried and whether it was certified.
    seconds : float
        Wall time, s.
    message : str
        ``"certified"`` or why not.
    capped : bool
        The level is the cap where the region reaches ``|sigma_i| = 1`` (the MRP's unique
        range), not the limit of the condition.
    """

    certified: bool
    level: float
    P0: np.ndarray
    eps: float
    sigma_max: float
    angle_deg: float
    rest_angle_deg: float
    omega_max: float
    checks: list[sos.Check]
    sampled_max_vdot: float
    levels: list[tuple[float, bool]]
    seconds: float
    message: str
    capped: bool = False


def closed_loop_polynomial(result: GainFit, servo: MRPServo) -> tuple[sp.Matrix, list[sp.Symbol]]:
    """``f(xe) = (Ae - Be K_fit) xe`` at ``sigma_ref = 0`` (so ``sigma = -e``) as polynomials in ``xe``.

    Parameters
    ----------
    result : GainFit
        The fit.
    servo : MRPServo
        The servo (its model's symbols and parameter defaults).

    Returns
    -------
    f : sympy.Matrix, shape (9, 1)
        The closed-loop vector field.
    z : list of sympy.Symbol
        The 9 symbols of ``xe``.
    """
    model = servo.model
    z = list(sp.symbols("z1:10", real=True))
    Ae, Be = servo_matrices(model)
    values = dict(zip(model.parameter_symbols, model.parameter_vector().tolist()))
    st = model.state_symbols
    sub = {**values, **{st[i]: z[6 + i] for i in range(3)}, **{st[3 + i]: -z[3 + i] for i in range(3)}}
    plant_vars = [z[6], z[7], z[8], -z[3], -z[4], -z[5]]
    E = exponents(6, result.degree)
    mons = [sp.Mul(*[v**k for v, k in zip(plant_vars, e)]) for e in E]
    K = sp.Matrix(3, 9, lambda i, j: sum((float(c) * m for c, m in zip(result.coefficients[i, j], mons)),
                                         sp.Integer(0)))
    xe = sp.Matrix(z)
    f = (Ae.subs(sub) * xe - Be.subs(sub) * (K * xe)).applyfunc(sp.expand)
    return f, z


def certify_region(result: GainFit, servo: MRPServo, iterations: int = 8, eps_fraction: float = EPS_FRACTION,
                   multiplier_degree: int = 2, n_samples: int = 2000, seed: int = 0) -> RegionCertificate:
    """The largest level ``c`` (by bisection) with ``V' < 0`` on ``{V <= c}`` for the fitted law.

    ``V = xe^T P0 xe``, ``P0 = L L^T``, ``y = L^T xe``; for each trial ``c`` the program
    ``-2 y^T g(y) - eps |y|^2 + l(y) (|y|^2 - c)`` SOS, ``l`` SOS of degree ``multiplier_degree``
    (``g`` the closed loop in ``y``) is solved and re-checked. The first level tried is the cap
    ``c_top`` at which the region's projection reaches ``|sigma_i| = 1`` (beyond it the MRP
    attitude is no longer unique); if it fails, ``iterations`` bisection steps on a log scale
    (the first at ``c_top / 4``).

    Parameters
    ----------
    result : GainFit
        The fit (degree <= :data:`MAX_DEGREE`).
    servo : MRPServo
        The servo (``P0`` from its weights at the origin).
    iterations : int, optional
        Number of bisection steps.
    eps_fraction : float, optional
        ``eps`` as a fraction of the origin's decay (:data:`EPS_FRACTION`).
    multiplier_degree : int, optional
        Degree of ``l`` (even).
    n_samples : int, optional
        Random points of the region at which ``V'`` is evaluated from the polynomials.
    seed : int, optional
        Seed of the samples.

    Returns
    -------
    RegionCertificate
        The certificate (``certified`` False and level 0 if no level was proved).

    Raises
    ------
    ValueError
        If the fit's degree exceeds :data:`MAX_DEGREE` or ``iterations`` < 1.
    """
    t0 = time.perf_counter()
    if result.degree > MAX_DEGREE:
        raise ValueError(f"the region needs a fit of degree <= {MAX_DEGREE}, got {result.degree}")
    if iterations < 1:
        raise ValueError(f"iterations must be >= 1, got {iterations}")
    P0 = servo.riccati_at_origin()
    L = np.linalg.cholesky(P0)
    Linv = np.linalg.inv(L)
    f, z = closed_loop_polynomial(result, servo)
    y = list(sp.symbols("y1:10", real=True))
    zy = Linv.T @ np.array(y, dtype=object)  # xe = L^-T y
    g = L.T @ np.array(list(f.subs(dict(zip(z, zy)))), dtype=object)
    vdot = sp.expand(2 * sum(yi * gi for yi, gi in zip(y, g)))
    Vdot = Poly.from_sympy(vdot, y)
    A0, B0 = servo.matrices(np.zeros(6))
    Q, R = servo.weights
    K0 = riccati_gain(A0, B0, Q, R, servo.eps)[0]
    decay0 = float(np.linalg.eigvalsh(Linv @ (Q + K0.T @ R @ K0) @ Linv.T).min())
    eps = eps_fraction * decay0
    yy = Poly.from_sympy(sp.Add(*[v**2 for v in y]), y)
    Pinv = np.linalg.inv(P0)
    c_top = 1.0 / float(np.max(np.diag(Pinv)[3:6]))  # |sigma_i| reaches 1 at the boundary

    f_num = sp.lambdify([y], vdot, "numpy")

    def attempt(c: float) -> tuple[bool, list[sos.Check], str]:
        prog = sos.SOSProgram(9)
        lm = prog.new_poly(monomials(9, multiplier_degree))
        prog.add_sos(lm, "multiplier l", "global")
        p = -Vdot - yy.scale(eps) + lm * (yy - c)
        prog.add_sos(p, "-V' - eps |y|^2 + l (V - c)", f"V <= {c:.6g}")
        try:
            sol = prog.solve()
        except SOSError as exc:
            return False, [], str(exc)
        checks = sos.certify(prog, sol, sample_radius=math.sqrt(c))
        ok = all(ch.certified for ch in checks)
        return ok, checks, "certified" if ok else f"failed checks {[ch.name for ch in checks if not ch.certified]}"

    levels: list[tuple[float, bool]] = []
    lo, hi, best_checks, msg = 0.0, c_top, [], "no level certified"
    ok, checks, why = attempt(hi)
    levels.append((hi, ok))
    if ok:
        lo, best_checks = hi, checks
    else:
        msg = why
        for _ in range(iterations):
            mid = math.sqrt(lo * hi) if lo > 0 else hi / 4
            ok, checks, why = attempt(mid)
            levels.append((mid, ok))
            if ok:
                lo, best_checks = mid, checks
            else:
                hi, msg = mid, why
    rng = np.random.default_rng(seed)
    worst = -np.inf
    if lo > 0:
        d = rng.normal(size=(n_samples, 9))
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        pts = d * (math.sqrt(lo) * rng.random(n_samples) ** (1 / 9))[:, None]
        vals = np.array([float(f_num(p)) for p in pts]) / np.sum(pts**2, axis=1)
        worst = float(vals.max())
    certified = lo > 0 and worst < 0
    sig = math.sqrt(lo * float(np.min(np.diag(Pinv)[3:6])))
    om = math.sqrt(lo * float(np.min(np.diag(Pinv)[6:9])))
    # rest start xe = [0, e, 0]: V = e^T P_ee e <= c for |e| <= sqrt(c / lambda_max(P_ee))
    rest = math.sqrt(lo / float(np.linalg.eigvalsh(P0[3:6, 3:6]).max()))
    if certified:
        msg = "certified" + (" (capped: the region reaches |sigma_i| = 1, the MRP's unique range)"
                             if lo == c_top else "")
    return RegionCertificate(certified, lo if certified else 0.0, P0, eps, sig, math.degrees(4 * math.atan(sig)),
                             math.degrees(4 * math.atan(rest)), om, best_checks, worst, levels,
                             time.perf_counter() - t0, msg, lo == c_top)


def artifact_data(result: GainFit, servo: MRPServo, checks: dict[str, float], region: RegionCertificate | None,
                  box: tuple[float, float], name: str = "mrp_sdre_servo") -> dict[str, Any]:
    """The ``servo_gain_schedule`` artifact data of the fitted servo for plant ``mrp_satellite``.

    Status ``certified`` when the region is certified (the claims: the frozen loops on the
    samples and the SOS region), else ``sampled``.

    Parameters
    ----------
    result : GainFit
        The checked fit.
    servo : MRPServo
        The servo (its model is the design plant; its weights are recorded).
    checks : dict of str to float
        The numbers of :func:`check_fit`.
    region : RegionCertificate or None
        The region of :func:`certify_region`, or None if not solved.
    box : tuple of float
        ``(s_max (1), w_max (rad/s))`` of the fit.
    name : str, optional
        The artifact's name, lower_snake_case (the controller FMU's modelIdentifier).

    Returns
    -------
    dict
        The artifact's JSON data (validate with :func:`satfmu.controllers.artifact.parse`).
    """
    s_max, w_max = box
    gain = result.terms()
    fit_info = {"degree": result.degree, "scheduling": SCHEDULING, "cv_tol": result.cv_tol,
                "cv_rms_rel_error": {str(k): v for k, v in result.cv_errors.items()},
                "max_rel_error": result.max_rel_error, "rms_rel_error": result.rms_rel_error,
                "box": {"sigma_max": s_max, "omega_max_rad_s": w_max, "points": len(result.points)}}
    numbers = {"fit_max_rel_error": result.max_rel_error, "fit_rms_rel_error": result.rms_rel_error, **checks}
    sampled = (f"checked by sampling: the frozen closed loop Ae - Be K_fit is stable at {len(result.points)} "
               f"box samples and fresh points; off-sample fit error; a 90 deg rest-to-rest manoeuvre reaches the "
               f"reference in closed-loop simulation (unsaturated)")
    box_text = f"|sigma_i| <= {s_max:.6g}, |omega_i| <= {w_max:.6g} rad/s"
    if region is not None:
        numbers.update({"region_level": region.level, "region_eps": region.eps if region.certified else 0.0,
                        "region_sigma_max": region.sigma_max, "region_angle_deg": region.angle_deg,
                        "region_rest_angle_deg": region.rest_angle_deg, "region_omega_max": region.omega_max,
                        "region_level_capped": float(region.capped),
                        "region_sampled_max_vdot": region.sampled_max_vdot if np.isfinite(region.sampled_max_vdot)
                        else 0.0, "region_seconds": region.seconds,
                        **{f"region_{k}": v for k, v in sos.check_numbers(region.checks).items()}})
    if region is not None and region.certified:
        status = "certified"
        cap = " (capped at |sigma_i| = 1)" if region.capped else ""
        proved = (f"SOS certificate (satfmu.synthesis.servo.mrp_sdre): with sigma_ref = 0 and no saturation, "
                  f"V = xe^T P0 xe (P0 the Riccati solution at the origin) decreases along the closed loop of the "
                  f"fitted polynomial law (exact, no approximation) by at least {region.eps:.3g} |L^T xe|^2 on "
                  f"V <= {region.level:.6g}{cap}, so every trajectory starting there converges to the reference; "
                  f"re-verified (Gram eigenvalues, residuals, {len(region.checks)} constraints, V' < 0 at "
                  f"samples of the region). Also: {sampled}")
        region_text = (f"V = xe^T P0 xe <= {region.level:.6g} (|sigma_i| <= {region.sigma_max:.4g}, i.e. "
                       f"{region.angle_deg:.3g} deg about a body axis; rest starts up to {region.rest_angle_deg:.3g} "
                       f"deg about any axis; |omega_i| <= {region.omega_max:.4g} rad/s); fit on {box_text}")
    else:
        status = "sampled"
        why = "" if region is None else f"; SOS region NOT certified ({region.message})"
        proved = sampled + why
        region_text = f"fit box {box_text}"
    Q, R = servo.weights
    prov = {"source": "satfmu satfmu.synthesis.servo.mrp_sdre (seed 002 method on the MRP plant)",
            "eps": servo.eps, "Q": np.diag(Q).tolist(), "R": np.diag(R).tolist(),
            "design_plant": design_plant_record(servo.model)}
    return {"format": FORMAT, "format_version": FORMAT_VERSION, "kind": SERVO_KIND, "name": name,
            "description": "Approximated SDRE servo of a rigid spacecraft (seed 002 method, MRP plant): "
                           "polynomial gains in omega, sigma",
            "plant": servo.model.name, "tracked": TRACKED, "rates": RATES, "scheduling": SCHEDULING,
            "outputs": OUTPUTS, "gain": gain,
            "certificate": {"status": status, "proved": proved, "region": region_text, "numbers": numbers},
            "provenance": prov, "fit": fit_info}


@dataclass
class Result:
    """What :func:`synthesize` produced.

    Attributes
    ----------
    servo : MRPServo
        The SDRE servo.
    fit : GainFit
        The fitted gain.
    checks : dict of str to float
        The numbers of :func:`check_fit`.
    region : RegionCertificate or None
        The SOS region (None when not asked for).
    box : tuple of float
        ``(s_max (1), w_max (rad/s))``.
    artifact : dict
        The artifact data.
    seconds : dict of str to float
        Wall time per stage, s.
    """

    servo: MRPServo
    fit: GainFit
    checks: dict[str, float]
    region: RegionCertificate | None
    box: tuple[float, float]
    artifact: dict[str, Any]
    seconds: dict[str, float]


def synthesize(model: Model, *, s_max: float | None = None, w_max: float | None = None,
               degrees: range = range(0, MAX_DEGREE + 1), cv_tol: float | None = CV_TOL,
               Q: np.ndarray | None = None, R: np.ndarray | None = None, n_samples: int = 256,
               region: bool = True, iterations: int = 8, name: str = "mrp_sdre_servo",
               progress: Progress | None = None) -> Result:
    """The approximated SDRE servo of the spacecraft of ``model``, checked, with its SOS region.

    The default weights and box come from the spacecraft the model's parameter defaults
    describe (:func:`spacecraft_of`): its inertia tensor and ``u_max`` (the spacecraft's torque
    limit, or the plant's 5 N m default when it has none).

    Parameters
    ----------
    model : Model
        The MRP satellite model of the user's spacecraft (:func:`satfmu.fmus.plants.mrp_satellite.build`).
    s_max : float, optional
        MRP bound of the operating box (1); default :func:`default_box`.
    w_max : float, optional
        Rate bound of the box, rad/s; default :func:`default_box`.
    degrees : range, optional
        Fit degrees to try (:func:`fit`).
    cv_tol : float or None, optional
        The degree rule's tolerance (:func:`fit`).
    Q : numpy.ndarray, shape (9, 9), optional
        State weight; default :func:`satfmu.controllers.mrp_servo_sdc.default_weights`.
    R : numpy.ndarray, shape (3, 3), optional
        Input weight, 1/(N m)^2; default as ``Q``.
    n_samples : int, optional
        Number of SDRE samples of the box.
    region : bool, optional
        Solve the SOS region (:func:`certify_region`).
    iterations : int, optional
        Bisection steps of the region.
    name : str, optional
        The artifact's name.
    progress : callable, optional
        ``progress(done, total, message)`` after each stage (:class:`satfmu.synthesis.core.progress.Stages`).

    Returns
    -------
    Result
        The servo, fit, checks, region and artifact data.

    Raises
    ------
    ValueError
        On a bad box or weights.
    FitCertificationError, satfmu.controllers.riccati.RiccatiCheckError
        If the fit fails :func:`check_fit`, or a Riccati solution fails its checks.
    """
    d_s, d_w = default_box(spacecraft_of(model))
    box = check_box(d_s if s_max is None else s_max, d_w if w_max is None else w_max)
    servo = MRPServo(model, Q, R)
    stages = Stages(3 + bool(region), progress, LOG)
    seconds = {}
    t = time.perf_counter()
    with stages.stage(f"SDRE gains at {n_samples} points of the box"):
        samples = sdre_samples(servo, *box, n=n_samples)
    seconds["samples"] = time.perf_counter() - t
    t = time.perf_counter()
    with stages.stage("polynomial gain fit"):
        result = fit(*samples, degrees=degrees, cv_tol=cv_tol)
    seconds["fit"] = time.perf_counter() - t
    t = time.perf_counter()
    with stages.stage(f"fit of degree {result.degree} checked (fresh points, frozen loops, simulation)"):
        checks = check_fit(result, servo, *box)
    seconds["check"] = time.perf_counter() - t
    reg = None
    if region:
        t = time.perf_counter()
        with stages.stage("SOS stability region of the fitted law"):
            reg = certify_region(result, servo, iterations=iterations)
        seconds["region"] = time.perf_counter() - t
    return Result(servo, result, checks, reg, box, artifact_data(result, servo, checks, reg, box, name), seconds)
