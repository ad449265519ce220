"""Exact system norms of stable continuous systems, one system or a stack of them at once.

- :func:`hinf_norm`: the H-infinity norm ``sup_w sigma_max(C (j w I - A)^-1 B + D)`` by the
  Boyd-Balakrishnan / Bruinsma-Steinbuch iteration (Boyd, Balakrishnan & Kabamba, MCSS 2,
  1989; Bruinsma & Steinbuch, Syst. Control Lett. 14, 1990), batched over a leading sample
  axis: every step (Hamiltonian eigenvalues, frequency responses) runs on all the systems still
  iterating, and a system leaves the batch when it converges; one system is a stack of one.
- :func:`impulse_to_peak`: ``max_t sigma_max(C e^(A t) B)`` on a time grid, by exact
  propagation, batched the same way.

They are the independent checks of the LMI bounds of :mod:`satfmu.synthesis.robust.robust_design` and
:mod:`satfmu.synthesis.robust.pdlf` on sampled plants, and the per-sample values of the randomized analysis
(:mod:`satfmu.synthesis.robust.probabilistic`). Bad input raises the errors of :mod:`satfmu.synthesis.robust.lft_plant`.
"""
from __future__ import annotations

import numpy as np
import scipy.linalg as sla

from satfmu.fmus.errors import NotHurwitzError, OptionError, PlantDataError


def _system_stack(A, B, C, D=None) -> tuple[np.ndarray, ...]:
    """Validate (n, n), (n, m), (p, n)[, (p, m)] arrays, or a stack of A (leading axis S) with
    B, C, D either stacked too or 2-D (then shared by every system)."""
    arrays = [np.asarray(a, dtype=float) for a in ((A, B, C) if D is None else (A, B, C, D))]
    if arrays[0].ndim not in (2, 3):
        raise PlantDataError(f"A must have shape (n, n) or (S, n, n), got {arrays[0].shape}")
    lead = arrays[0].shape[:-2]
    for k, (name, a) in enumerate(zip("ABCD", arrays)):
        if not np.all(np.isfinite(a)):
            raise PlantDataError(f"{name} has non-finite entries")
        if a.ndim == 2 and lead:
            arrays[k] = np.broadcast_to(a, lead + a.shape)
    A, B, C = arrays[:3]
    n, m, p = A.shape[-1], B.shape[-1], C.shape[-2]
    shapes = [(n, n), (n, m), (p, n)] + ([] if D is None else [(p, m)])
    for name, a, shape in zip("ABCD", arrays, shapes, strict=False):
        if a.shape != lead + shape:
            raise PlantDataError(f"{name} must have shape {lead + shape}, got {a.shape}")
    return tuple(arrays)


def _sigma_max_at(A, B, C, D, w: np.ndarray) -> np.ndarray:
    """``sigma_max(C (j w I - A)^-1 B + D)`` for stacks (S, .) and frequencies w (S, F): (S, F)."""
    n = A.shape[-1]
    M = 1j * w[..., None, None] * np.eye(n) - A[:, None]
    G = C[:, None] @ np.linalg.solve(M, np.broadcast_to(B[:, None], M.shape[:2] + B.shape[-2:])) + D[:, None]
    return np.linalg.norm(G, ord=2, axis=(-2, -1))


def _hamiltonian_stack(A, B, C, D, g: np.ndarray) -> np.ndarray:
    """Hamiltonians of the bounded-real lemma at levels g (S,), stacked (S, 2n, 2n)."""
    m, p = D.shape[-1], D.shape[-2]
    Dt = np.swapaxes(D, -1, -2)
    Ri = np.linalg.inv(g[:, None, None] ** 2 * np.eye(m) - Dt @ D)
    Ct = np.swapaxes(C, -1, -2)
    Ah = A + B @ Ri @ Dt @ C
    top = np.concatenate([Ah, B @ Ri @ np.swapaxes(B, -1, -2)], axis=-1)
    bottom = np.concatenate([-Ct @ (np.eye(p) + D @ Ri @ Dt) @ C, -np.swapaxes(Ah, -1, -2)], axis=-1)
    return np.concatenate([top, bottom], axis=-2)


def hinf_norm(A, B, C, D, tol: float = 1e-9, max_iter: int = 200):
    """H-infinity norm of a stable continuous system ``(A, B, C, D)``, or of a stack of them.

    Boyd-Balakrishnan / Bruinsma-Steinbuch iteration (module docstring), on every system of the
    stack at once: a lower bound ``low`` achieved at a frequency (the largest of ``||D||`` and
    ``sigma_max(G(jw))`` at ``w = 0`` and at the moduli of the eigenvalues of A);
    ``g = (1 + 2 tol) low`` is tested by the imaginary-axis eigenvalues of the Hamiltonian of
    the bounded-real lemma; if there are any, ``low`` becomes the largest ``sigma_max(G(jw))``
    at the midpoints of the crossing frequencies (quadratic convergence). The value returned is
    that final ``g``: an upper bound, within relative ``2 tol`` of the norm. Eigenvalues with
    ``|Re| <= 1e-7 max(1, max|H_ij|)`` count as imaginary; a spurious one is harmless: it only
    adds a midpoint, and if no midpoint exceeds ``g`` the crossings were numerical and ``g`` is
    returned (a genuine band where ``sigma_max > g`` always contains a midpoint).

    Parameters
    ----------
    A, B, C, D : ndarray
        Shapes (n, n), (n, m), (p, n), (p, m); or A with a leading sample axis S, and B, C, D
        with it or shared (2-D).
    tol : float
        Relative accuracy (> 0).
    max_iter : int
        Iterations allowed before a system that has not converged raises RuntimeError.

    Returns
    -------
    float or ndarray of shape (S,)
        The norm (units of the outputs per unit of the inputs): a float for one system, one per
        sample for a stack; 0.0 for a system whose response is identically zero.

    Raises
    ------
    NotHurwitzError
        If (any) A has an eigenvalue with ``Re >= 0`` (for a stack, the first such sample's
        index is named).
    OptionError
        If tol is not finite and > 0.
    PlantDataError
        If the shapes do not match or an entry is not finite.
    """
    A, B, C, D = _system_stack(A, B, C, D)
    if not (np.isfinite(tol) and tol > 0):
        raise OptionError(f"tol must be finite and > 0, got {tol!r}")
    single = A.ndim == 2
    if single:
        A, B, C, D = A[None], B[None], C[None], D[None]
    lam = np.linalg.eigvals(A)
    bad = np.flatnonzero(lam.real.max(axis=-1) >= 0)
    if bad.size:
        top = lam[bad[0]].real.max()
        raise NotHurwitzError(f"A is not Hurwitz (max Re eig {top:.3e}): the H-infinity norm is infinite" if single
                              else f"sample {bad[0]} is not Hurwitz (max Re eig {top:.3e}): its H-infinity norm is "
                              f"infinite ({bad.size} such samples)")
    w0 = np.concatenate([np.zeros((len(A), 1)), np.abs(lam)], axis=1)
    low = np.maximum(_sigma_max_at(A, B, C, D, w0).max(axis=1), np.linalg.norm(D, ord=2, axis=(-2, -1)))
    out = np.where(low == 0.0, 0.0, np.nan)
    active = np.flatnonzero(low > 0)
    for _ in range(max_iter):
        if active.size == 0:
            break
        a, b, c, d = A[active], B[active], C[active], D[active]
        g = (1 + 2 * tol) * low[active]
        H = _hamiltonian_stack(a, b, c, d, g)
        ev = np.linalg.eigvals(H)
        scale = np.maximum(1.0, np.abs(H).max(axis=(-2, -1)))
        on_axis = np.abs(ev.real) <= 1e-7 * scale[:, None]
        w = np.sort(np.where(on_axis, ev.imag, np.nan), axis=1)  # NaN last
        count = on_axis.sum(axis=1)
        mids = np.where(count[:, None] > 1, (w[:, :-1] + w[:, 1:]) / 2, np.abs(w[:, :1]))
        mids = np.where(np.isnan(mids), 0.0, np.abs(mids))  # padding: w = 0, already below low
        best = np.where(count > 0, _sigma_max_at(a, b, c, d, mids).max(axis=1), 0.0)
        done = best <= g  # no crossing, or the crossings were numerical
        out[active[done]] = g[done]
        low[active[~done]] = best[~done]
        active = active[~done]
    if active.size:
        raise RuntimeError(f"the H-infinity iteration did not converge in {max_iter} iterations "
                           f"for {active.size} samples")
    return float(out[0]) if single else out


PEAK_BLOCK = 64
"""Grid points per block in :func:`impulse_to_peak` (``C Phi^j`` kept for j < PEAK_BLOCK)."""


def impulse_to_peak(A, B, C, t_end: float, n_points: int = 2001):
    """``max_k sigma_max(C e^(A t_k) B)`` on the grid ``t_k = k t_end / (n_points - 1)``.

    The largest ``|z(t_k)|`` over unit-norm impulses ``w = w0 delta_Dirac`` (``x(0+) = B w0``).
    Exact propagation: ``Phi = expm(A dt)`` once, then repeated multiplication, in blocks:
    ``C Phi^j`` for ``j < PEAK_BLOCK`` and ``X_(i+1) = Phi^PEAK_BLOCK X_i`` from ``X_0 = B``.
    A lower estimate of the supremum over all t (the grid may miss the peak or end before it).

    Parameters
    ----------
    A, B, C : ndarray
        Shapes (n, n), (n, m), (p, n); or A with a leading sample axis S, and B, C with it or
        shared (2-D).
    t_end : float
        Horizon, s (> 0).
    n_points : int
        Grid points (>= 2), t = 0 included.

    Returns
    -------
    float or ndarray of shape (S,)
    """
    A, B, C = _system_stack(A, B, C)
    if not (np.isfinite(t_end) and t_end > 0):
        raise OptionError(f"t_end must be finite and > 0, got {t_end!r}")
    if not (isinstance(n_points, (int, np.integer)) and n_points >= 2):
        raise OptionError(f"n_points must be an integer >= 2, got {n_points!r}")
    Phi = sla.expm(A * (t_end / (n_points - 1)))
    powers = [C]  # C Phi^j, j < PEAK_BLOCK, by repeated multiplication
    for _ in range(min(PEAK_BLOCK, n_points) - 1):
        powers.append(powers[-1] @ Phi)
    CPhi = np.stack(powers, axis=-3)  # (..., b, p, n)
    b = CPhi.shape[-3]
    step = np.linalg.matrix_power(Phi, b)
    X = B.copy()
    peak = np.zeros(A.shape[:-2])
    for start in range(0, n_points, b):
        count = min(b, n_points - start)
        Z = CPhi[..., :count, :, :] @ X[..., None, :, :]  # C Phi^(start + j) B
        peak = np.maximum(peak, _sigma_max_stack(Z).max(axis=-1))
        X = step @ X
    return peak if A.ndim == 3 else float(peak)


def _sigma_max_stack(Z: np.ndarray) -> np.ndarray:
    """Largest singular value of every matrix of a stack (..., p, m)."""
    p, m = Z.shape[-2:]
    if min(p, m) == 1:  # a row or column: the Euclidean norm
        return np.sqrt(np.sum(Z * Z, axis=(-2, -1)))
    G = np.swapaxes(Z, -1, -2) @ Z if m <= p else Z @ np.swapaxes(Z, -1, -2)
    return np.sqrt(np.maximum(np.linalg.eigvalsh(G)[..., -1], 0.0))
