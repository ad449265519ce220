"""Least-squares polynomial fits of a gain over sampled states, the degree chosen by k-fold
cross-validation: shared by the SDRE gain fits of seed 002's VSCMG
(:mod:`satfmu.synthesis.servo.gain_fit`) and of a rigid spacecraft
(:mod:`satfmu.synthesis.servo.mrp_sdre`).
"""
from __future__ import annotations

from typing import Callable, Sequence

import numpy as np


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
