"""Checked, shifted continuous-time Riccati solve: the gain of an SDRE or LQ servo.

Standalone (numpy and scipy only): the online SDRE controller FMU embeds this file, and
synthesis uses the same function, so the gain a design grid sees is the gain the FMU
computes.

Why shifted: a plant with a conserved momentum (the VSCMG's p4) has an uncontrollable
eigenvalue at 0 at every state, so the pair (A, B) is not stabilizable and
``scipy.linalg.solve_continuous_are`` either raises or returns a matrix that does not
solve the equation. Solving for (A - eps I, B) instead moves that mode to -eps, where it
is stable; the gain converges as eps -> 0. Every solution is then checked, and a failed
check raises :class:`RiccatiCheckError` naming what failed: a wrong gain is never used
silently.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import LinAlgError, solve_continuous_are
from satfmu.fmus.errors import RiccatiCheckError


@dataclass(frozen=True)
class RiccatiCheck:
    """Numbers that certify one Riccati solution (all dimensionless unless stated).

    Attributes
    ----------
    residual : float
        ``|A_s^T P + P A_s + Q - P B R^-1 B^T P|_F / max(1, |Q|_F, |P|_F)``, A_s = A - eps I.
    min_eig_P : float
        Smallest eigenvalue of the symmetric part of P (> 0 for a stabilizing solution).
    max_re_shifted : float
        Largest real part of the eigenvalues of A_s - B K, 1/s (< 0 by construction).
    max_re : float
        Largest real part of the eigenvalues of A - B K, 1/s (the unshifted closed loop;
        an uncontrollable mode of A at 0 stays at 0).
    gain_norm : float
        Largest absolute gain entry.
    """

    residual: float
    min_eig_P: float
    max_re_shifted: float
    max_re: float
    gain_norm: float


def riccati_gain(A: np.ndarray, B: np.ndarray, Q: np.ndarray, R: np.ndarray, eps: float = 1e-6,
                 residual_tol: float = 1e-8, max_re_tol: float = 1e-6, gain_limit: float = 1e6
                 ) -> tuple[np.ndarray, RiccatiCheck]:
    """Gain K = R^-1 B^T P of the Riccati equation of (A - eps I, B, Q, R), checked.

    Parameters
    ----------
    A : (n, n) array
    B : (n, m) array
    Q : (n, n) array, symmetric positive semidefinite
    R : (m, m) array, symmetric positive definite
    eps : float
        Shift, 1/s (>= 0).
    residual_tol : float
        Largest admitted relative residual.
    max_re_tol : float
        Largest admitted real part of the unshifted closed loop's eigenvalues, 1/s: a
        solution that leaves an unstable mode in A - B K is rejected.
    gain_limit : float
        Largest admitted gain entry (a barely controllable unstable mode gives huge gains).

    Returns
    -------
    K : (m, n) array
        The control is u = -K x.
    check : RiccatiCheck

    Raises
    ------
    ValueError
        On non-finite entries or inconsistent shapes.
    RiccatiCheckError
        If scipy fails or any check fails; the message names the failed check and its value.
    """
    A, B, Q, R = (np.atleast_2d(np.asarray(M, float)) for M in (A, B, Q, R))
    n, m = B.shape
    if A.shape != (n, n) or Q.shape != (n, n) or R.shape != (m, m):
        raise ValueError(f"inconsistent shapes: A {A.shape}, B {B.shape}, Q {Q.shape}, R {R.shape}")
    for name, M in (("A", A), ("B", B), ("Q", Q), ("R", R)):
        if not np.all(np.isfinite(M)):
            raise ValueError(f"{name} has non-finite entries")
    if not (np.isfinite(eps) and eps >= 0):
        raise ValueError(f"eps must be finite and >= 0, got {eps}")
    As = A - eps * np.eye(n)
    try:
        P = solve_continuous_are(As, B, Q, R)
    except (LinAlgError, ValueError) as exc:
        raise RiccatiCheckError(f"solve_continuous_are failed for the pair shifted by eps = {eps:g}: {exc}") from exc
    K = np.linalg.solve(R, B.T @ P)
    res = As.T @ P + P @ As + Q - P @ B @ K
    check = RiccatiCheck(
        residual=float(np.linalg.norm(res) / max(1.0, float(np.linalg.norm(Q)), float(np.linalg.norm(P)))),
        min_eig_P=float(np.min(np.linalg.eigvalsh((P + P.T) / 2))),
        max_re_shifted=float(np.max(np.linalg.eigvals(As - B @ K).real)),
        max_re=float(np.max(np.linalg.eigvals(A - B @ K).real)),
        gain_norm=float(np.max(np.abs(K))))
    failures = []
    if not np.isfinite(check.residual) or check.residual > residual_tol:
        failures.append(f"relative residual {check.residual:.3g} > {residual_tol:g}")
    if not check.min_eig_P > -residual_tol * max(1.0, float(np.linalg.norm(P))):
        failures.append(f"P is not positive semidefinite (min eigenvalue {check.min_eig_P:.3g})")
    if not check.max_re_shifted < 0:
        failures.append(f"shifted closed loop not stable (max Re {check.max_re_shifted:.3g} 1/s)")
    if not check.max_re <= max_re_tol:
        failures.append(f"closed loop A - B K has an unstable mode (max Re {check.max_re:.3g} 1/s > {max_re_tol:g})")
    if not check.gain_norm <= gain_limit:
        failures.append(f"gain entry {check.gain_norm:.3g} exceeds {gain_limit:g} (mode barely controllable)")
    if failures:
        raise RiccatiCheckError("Riccati solution rejected: " + "; ".join(failures))
    return K, check


def sampled_gain(values: list[float], n: int, m: int) -> list[float]:
    """Checked gain from flat data: the sample function of the online SDRE controller FMU.

    Parameters
    ----------
    values : list of float
        ``A`` (n x n, row-major), ``B`` (n x m, row-major), the diagonals of ``Q`` (n) and
        ``R`` (m), and ``eps`` (1/s): ``n*n + n*m + n + m + 1`` numbers.
    n, m : int
        State and input dimensions.

    Returns
    -------
    list of float
        ``K`` row-major (m x n), then the check's relative residual and ``max_re`` (1/s).

    Raises
    ------
    ValueError
        If ``values`` has the wrong length.
    RiccatiCheckError
        As :func:`riccati_gain`.
    """
    v = np.asarray(values, float)
    if v.shape != (n * n + n * m + n + m + 1,):
        raise ValueError(f"expected {n * n + n * m + n + m + 1} values for n = {n}, m = {m}, got {v.shape}")
    A = v[:n * n].reshape(n, n)
    B = v[n * n:n * n + n * m].reshape(n, m)
    q = v[n * n + n * m:n * n + n * m + n]
    r = v[n * n + n * m + n:-1]
    K, check = riccati_gain(A, B, np.diag(q), np.diag(r), float(v[-1]))
    return K.ravel().tolist() + [check.residual, check.max_re]
