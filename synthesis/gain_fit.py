"""Gain approximation of the SDRE servo (seed 002, section 3.2) and the LQ servo baseline.

The SDRE gain K(x) (2x7) is solved on a grid over (q2, w4) with the seed's w1-free SDC
evaluated at w2 := 0 (so the gain depends on q2 and w4 only), and every entry is fitted by
a 2-D polynomial of total degree d by least squares; d is chosen by k-fold
cross-validation. The controller then evaluates polynomials instead of solving a Riccati
equation (:mod:`controllers.servo`). The LQ servo is the constant gain at the start state.
"""
from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations_with_replacement

import numpy as np

from controllers.artifact import SERVO_KIND, FORMAT, FORMAT_VERSION
from synthesis.sdre import Servo

Q2_RANGE = (0.15, 1.25)
"""Gimbal-2 angle range of the grid, rad (covers the seed's pi/18 to 1 + pi/18; substitute)."""

W4_RANGE = (-0.6, 0.6)
"""Gimbal-4 rate range of the grid, rad/s (substitute, from the runs)."""

TRACKED = [{"name": "q2", "reference": "q2_ref", "unit": "rad"}, {"name": "q4", "reference": "q4_ref", "unit": "rad"}]
RATES = [{"name": n, "unit": "rad/s"} for n in ("w1", "w2", "w4")]
OUTPUTS = [{"name": "T1", "unit": "N.m", "description": "Rotor-1 motor torque command"},
           {"name": "T2", "unit": "N.m", "description": "Gimbal-2 motor torque command"}]


def exponents(degree: int) -> list[tuple[int, int]]:
    """Monomial exponents (i, j) of q2^i w4^j with i + j <= degree, graded order."""
    out = []
    for d in range(degree + 1):
        for combo in combinations_with_replacement((0, 1), d):
            out.append((combo.count(0), combo.count(1)))
    return out


def _design(points: np.ndarray, degree: int) -> np.ndarray:
    return np.column_stack([points[:, 0] ** i * points[:, 1] ** j for i, j in exponents(degree)])


@dataclass
class GainFit:
    """Fitted gain polynomials and their accuracy on the grid.

    Attributes
    ----------
    degree : int
        Total degree chosen by cross-validation.
    coefficients : (2, 7, n_terms) array
    cv_errors : dict of int to float
        Cross-validated RMS error (relative to the largest gain entry) per degree tried.
    max_rel_error, rms_rel_error : float
        Over the grid, |K_fit - K| relative to the largest |K| entry.
    grid : (n, 2) array
        (q2, w4) points, rad and rad/s.
    gains : (n, 2, 7) array
        SDRE gains on the grid.
    """

    degree: int
    coefficients: np.ndarray
    cv_errors: dict[int, float]
    max_rel_error: float
    rms_rel_error: float
    grid: np.ndarray
    gains: np.ndarray

    def evaluate(self, points: np.ndarray) -> np.ndarray:
        """K at (q2, w4) points, shape (n, 2, 7)."""
        X = _design(np.atleast_2d(points), self.degree)
        return np.einsum("nt,ijt->nij", X, self.coefficients)


def sdre_grid(servo: Servo, n_q2: int = 23, n_w4: int = 25) -> tuple[np.ndarray, np.ndarray]:
    """Checked SDRE gains on the (q2, w4) grid: points (n, 2) and gains (n, 2, 7)."""
    q2 = np.linspace(*Q2_RANGE, n_q2)
    w4 = np.linspace(*W4_RANGE, n_w4)
    points = np.array([(a, b) for a in q2 for b in w4])
    gains = np.array([servo.gain(np.array([0.0, a, 0.0, 0.0, 0.0, b]))[0] for a, b in points])
    return points, gains


def fit(points: np.ndarray, gains: np.ndarray, degrees: range = range(1, 9), folds: int = 5,
        seed: int = 0) -> GainFit:
    """Least-squares polynomial fit of every gain entry, degree by k-fold cross-validation.

    Raises
    ------
    ValueError
        If shapes disagree or the grid has fewer points than the largest basis.
    """
    points, gains = np.asarray(points, float), np.asarray(gains, float)
    if points.ndim != 2 or points.shape[1] != 2 or gains.shape[0] != points.shape[0]:
        raise ValueError(f"points must be (n, 2) and gains (n, ...), got {points.shape} and {gains.shape}")
    n = len(points)
    if n < 2 * len(exponents(max(degrees))):
        raise ValueError(f"{n} grid points are too few for degree {max(degrees)}")
    Y = gains.reshape(n, -1)
    scale = float(np.max(np.abs(Y)))
    fold = np.random.default_rng(seed).permutation(n) % folds
    cv = {}
    for d in degrees:
        X = _design(points, d)
        err = []
        for k in range(folds):
            train, test = fold != k, fold == k
            c, *_ = np.linalg.lstsq(X[train], Y[train], rcond=None)
            err.append(X[test] @ c - Y[test])
        cv[d] = float(np.sqrt(np.mean(np.concatenate(err) ** 2)) / scale)
    best = min(cv, key=cv.get)
    X = _design(points, best)
    c, *_ = np.linalg.lstsq(X, Y, rcond=None)
    resid = X @ c - Y
    coeffs = c.T.reshape(gains.shape[1], gains.shape[2], -1)
    return GainFit(best, coeffs, cv, float(np.max(np.abs(resid)) / scale),
                   float(np.sqrt(np.mean(resid**2)) / scale), points, gains)


def _terms(coeffs: np.ndarray, degree: int) -> list[dict]:
    return [{"c": float(c), "e": list(e)} for c, e in zip(coeffs, exponents(degree)) if c != 0.0]


def _servo_data(name: str, description: str, gain: list, certificate: dict, provenance: dict,
                fit_info: dict | None = None) -> dict:
    data = {"format": FORMAT, "format_version": FORMAT_VERSION, "kind": SERVO_KIND, "name": name,
            "description": description, "plant": "vscmg", "tracked": TRACKED, "rates": RATES,
            "scheduling": ["q2", "w4"], "outputs": OUTPUTS, "gain": gain, "certificate": certificate,
            "provenance": provenance}
    if fit_info:
        data["fit"] = fit_info
    return data


def approximated_sdre_data(result: GainFit, servo: Servo, name: str = "vscmg_sdre_approx") -> dict:
    """Artifact data of the approximated SDRE servo."""
    gain = [[_terms(result.coefficients[i, j], result.degree) for j in range(7)] for i in range(2)]
    fit_info = {"degree": result.degree, "cv_rms_rel_error": {str(k): v for k, v in result.cv_errors.items()},
                "max_rel_error": result.max_rel_error, "rms_rel_error": result.rms_rel_error,
                "grid": {"q2": list(Q2_RANGE), "w4": list(W4_RANGE), "points": len(result.grid)}}
    cert = {"status": "not_verified", "proved": "nothing yet: gains fitted to checked SDRE solutions",
            "region": f"fit on q2 in {list(Q2_RANGE)} rad, w4 in {list(W4_RANGE)} rad/s",
            "numbers": {"fit_max_rel_error": result.max_rel_error, "fit_rms_rel_error": result.rms_rel_error}}
    prov = {"source": "satfmu synthesis.gain_fit (seed 002 section 3.2)", "factorization": servo.factorization,
            "freeze_w2": servo.freeze_w2, "eps": servo.eps, "Q": np.diag(servo.Q).tolist(),
            "R": np.diag(servo.R).tolist()}
    return _servo_data(name, "Approximated SDRE servo of the VSCMG (seed 002): polynomial gains in q2, w4",
                       gain, cert, prov, fit_info)


def lq_data(servo: Servo, x0: np.ndarray, name: str = "vscmg_lq_servo") -> dict:
    """Artifact data of the LQ servo designed at the plant state ``x0`` (a constant gain)."""
    K, check = servo.gain(np.asarray(x0, float))
    gain = [[[{"c": float(K[i, j]), "e": [0, 0]}] for j in range(7)] for i in range(2)]
    cert = {"status": "certified", "proved": "Riccati solution at the design state checked (residual, "
            "closed-loop eigenvalues of the linearization's SDC pair)",
            "region": f"design state q2 = {x0[1]:.6g} rad, rest",
            "numbers": {"riccati_residual": check.residual, "max_re_closed_loop": check.max_re,
                        "max_re_shifted": check.max_re_shifted}}
    prov = {"source": "satfmu synthesis.gain_fit.lq_data (substitute baseline, seed 002 section 5.1)",
            "factorization": servo.factorization, "eps": servo.eps, "x0": list(map(float, x0))}
    return _servo_data(name, "LQ servo of the VSCMG designed at the start state (seed 002 baseline)",
                       gain, cert, prov)
