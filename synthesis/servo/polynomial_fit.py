"""Least-squares polynomial fits of a gain over sampled states, the degree chosen by k-fold
cross-validation: shared by the SDRE gain fits of seed 002's VSCMG
(:mod:`satfmu.synthesis.servo.gain_fit`) and of a rigid spacecraft
(:mod:`satfmu.synthesis.servo.mrp_sdre`).

- :func:`exponents` and :func:`monomials`: the graded monomial basis and its values at points.
- :func:`cross_validated_fit`: the fit of any basis, the degree by cross-validation.
- :class:`PolynomialFit` and :func:`fit_gains`: a matrix gain fitted entry by entry on the
  monomial basis, its accuracy, its values and its terms as an artifact stores them.
"""
from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations_with_replacement
from typing import Callable, Sequence

import numpy as np


def exponents(n_vars: int, degree: int) -> list[tuple[int, ...]]:
    """Monomial exponents of total degree <= ``degree`` in ``n_vars`` variables, graded order.

    Parameters
    ----------
    n_vars : int
        Number of variables, >= 1.
    degree : int
        Total degree, >= 0.

    Returns
    -------
    list of tuple of int
        ``binomial(n_vars + degree, degree)`` exponent tuples, by increasing total degree.
    """
    out = []
    for d in range(degree + 1):
        for combo in combinations_with_replacement(range(n_vars), d):
            out.append(tuple(combo.count(i) for i in range(n_vars)))
    return out


def monomials(points: np.ndarray, degree: int) -> np.ndarray:
    """The monomials of :func:`exponents` at the points.

    Parameters
    ----------
    points : numpy.ndarray, shape (n, n_vars)
        The points.
    degree : int
        Total degree, >= 0.

    Returns
    -------
    numpy.ndarray, shape (n, n_terms)
        Row k: every monomial at point k.
    """
    E = np.array(exponents(points.shape[1], degree))
    return np.prod(points[:, None, :] ** E[None, :, :], axis=2)


def cross_validated_fit(design: Callable[[np.ndarray, int], np.ndarray], points: np.ndarray, Y: np.ndarray,
                        degrees: Sequence[int], folds: int, seed: int, cv_tol: float | None
                        ) -> tuple[int, np.ndarray, dict[int, float], float, float]:
    """Least-squares fit of the columns of ``Y`` on the polynomial basis ``design(points, d)``, the
    degree ``d`` chosen by k-fold cross-validation: the smallest whose CV error is within
    ``cv_tol``, else (or with None) the one with the smallest CV error. Errors are RMS values
    relative to the largest ``|Y|`` entry.

    Parameters
    ----------
    design : callable
        ``design(points, degree)``: the basis monomials at the points, shape (n, n_terms).
    points : numpy.ndarray, shape (n, n_vars)
        The sample points.
    Y : numpy.ndarray, shape (n, n_out)
        The values to fit at each point.
    degrees : sequence of int
        The total degrees to try, increasing.
    folds : int
        Number k of cross-validation folds.
    seed : int
        Seed of the random assignment of the points to the folds.
    cv_tol : float or None
        The CV error the chosen degree must reach; None: the smallest CV error.

    Returns
    -------
    degree : int
        The chosen degree.
    coefficients : numpy.ndarray, shape (n_terms, n_out)
        The fit at that degree on all the points.
    cv_errors : dict of int to float
        The CV error per degree tried.
    max_rel_error, rms_rel_error : float
        The fit's largest and RMS error on the points.
    """
    scale = float(np.max(np.abs(Y)))
    n = len(points)
    fold = np.random.default_rng(seed).permutation(n) % folds
    cv = {}
    for d in degrees:
        X = design(points, d)
        err = []
        for k in range(folds):
            train, test = fold != k, fold == k
            c, *_ = np.linalg.lstsq(X[train], Y[train], rcond=None)
            err.append(X[test] @ c - Y[test])
        cv[d] = float(np.sqrt(np.mean(np.concatenate(err) ** 2)) / scale)
    within = [d for d in degrees if cv_tol is not None and cv[d] <= cv_tol]
    best = within[0] if within else min(cv, key=cv.__getitem__)
    X = design(points, best)
    c, *_ = np.linalg.lstsq(X, Y, rcond=None)
    resid = X @ c - Y
    return best, c, cv, float(np.max(np.abs(resid)) / scale), float(np.sqrt(np.mean(resid**2)) / scale)


@dataclass
class PolynomialFit:
    """A matrix gain fitted entry by entry on the monomials of its variables, and its accuracy on
    the samples.

    Attributes
    ----------
    degree : int
        Total degree chosen by cross-validation.
    coefficients : numpy.ndarray, shape (rows, cols, n_terms)
        Coefficients of each gain entry, in the order of ``exponents(n_vars, degree)``.
    cv_errors : dict of int to float
        Cross-validated RMS error (relative to the largest gain entry) per degree tried.
    max_rel_error : float
        Largest ``|K_fit - K|`` on the samples, relative to the largest ``|K|`` entry.
    rms_rel_error : float
        RMS of the same.
    points : numpy.ndarray, shape (n, n_vars)
        The samples of the fit's variables.
    gains : numpy.ndarray, shape (n, rows, cols)
        The gains at the samples.
    cv_tol : float or None
        The tolerance the degree was chosen with.
    """

    degree: int
    coefficients: np.ndarray
    cv_errors: dict[int, float]
    max_rel_error: float
    rms_rel_error: float
    points: np.ndarray
    gains: np.ndarray
    cv_tol: float | None = None

    def evaluate(self, points: np.ndarray) -> np.ndarray:
        """The fitted gain at points of the fit's variables.

        Parameters
        ----------
        points : numpy.ndarray, shape (n, n_vars) or (n_vars,)
            The points.

        Returns
        -------
        numpy.ndarray, shape (n, rows, cols)
            The fitted gain at each point (a single point gives n = 1).
        """
        X = monomials(np.atleast_2d(np.asarray(points, float)), self.degree)
        return np.einsum("nt,ijt->nij", X, self.coefficients)

    def terms(self) -> list[list[list[dict]]]:
        """Each entry's nonzero terms as an artifact stores them: ``{"c": coefficient, "e":
        exponents}``, rows of columns."""
        E = exponents(self.points.shape[1], self.degree)
        return [[[{"c": float(c), "e": list(e)} for c, e in zip(entry, E) if c != 0.0] for entry in row]
                for row in self.coefficients]


def fit_gains(points: np.ndarray, gains: np.ndarray, degrees: Sequence[int], folds: int, seed: int,
              cv_tol: float | None) -> tuple[int, np.ndarray, dict[int, float], float, float]:
    """Fit every entry of a gain sampled at points on the monomials (:func:`cross_validated_fit`).

    Parameters
    ----------
    points : numpy.ndarray, shape (n, n_vars)
        The samples of the variables.
    gains : numpy.ndarray, shape (n, rows, cols)
        The gain at each sample.
    degrees : sequence of int
        The total degrees to try, increasing.
    folds : int
        Number k of cross-validation folds.
    seed : int
        Seed of the random assignment of the points to the folds.
    cv_tol : float or None
        The CV error the chosen degree must reach; None: the smallest CV error.

    Returns
    -------
    tuple
        ``(degree, coefficients (rows, cols, n_terms), cv_errors, max_rel_error, rms_rel_error)``:
        the first five fields of :class:`PolynomialFit`.

    Raises
    ------
    ValueError
        If there are fewer points than twice the largest basis.
    """
    n = len(points)
    if n < 2 * len(exponents(points.shape[1], max(degrees))):
        raise ValueError(f"{n} points are too few for degree {max(degrees)}")
    best, c, cv, max_err, rms_err = cross_validated_fit(monomials, points, gains.reshape(n, -1), degrees, folds,
                                                        seed, cv_tol)
    return best, c.T.reshape(gains.shape[1], gains.shape[2], -1), cv, max_err, rms_err
