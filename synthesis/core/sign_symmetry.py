"""Sign symmetries of a polynomial and the block-diagonal Gram matrices they allow.

A *sign symmetry* of ``p(x)`` is a set of variables whose joint sign flip leaves ``p``
unchanged: a vector ``r`` in GF(2)^n with ``r . a = 0 (mod 2)`` for every exponent ``a`` in
the support of ``p``. The symmetries form the null space of the support matrix over GF(2).

If ``p = z^T G z`` with ``G >= 0``, averaging ``G`` over the group of these flips gives another
PSD Gram matrix of ``p`` (each flip maps the decomposition to one of the same ``p``) whose entry
``(i, j)`` is zero unless ``z_i`` and ``z_j`` have the same *signature* ``(r_k . b_i mod 2)_k``.
So ``p`` is SOS if and only if it is SOS with ``G`` block-diagonal over the signature classes:
the reduction loses nothing (Löfberg, "Pre- and post-processing sum-of-squares programs in
practice", IEEE TAC 54(5), 2009), and each block is a smaller semidefinite constraint.
"""
from __future__ import annotations

import numpy as np


def gf2_null_space(rows: np.ndarray) -> np.ndarray:
    """A basis of ``{r : rows @ r = 0 (mod 2)}``.

    Parameters
    ----------
    rows : (m, n) integer array
        Only the parities of the entries matter.

    Returns
    -------
    (k, n) uint8 array
        Independent null vectors, one per row (``k = 0`` when only ``r = 0`` qualifies).
    """
    a = (np.asarray(rows) % 2).astype(np.uint8)
    m, n = a.shape if a.ndim == 2 else (0, a.shape[0] if a.ndim else 0)
    a = a.reshape(m, n).copy()
    pivots: list[int] = []
    r = 0
    for c in range(n):  # reduced row echelon form over GF(2)
        hit = np.nonzero(a[r:, c])[0] if r < m else np.zeros(0, int)
        if hit.size == 0:
            continue
        p = r + hit[0]
        a[[r, p]] = a[[p, r]]
        others = np.nonzero(a[:, c])[0]
        others = others[others != r]
        a[others] ^= a[r]
        pivots.append(c)
        r += 1
        if r == m:
            break
    free = [c for c in range(n) if c not in pivots]
    basis = np.zeros((len(free), n), np.uint8)
    for k, f in enumerate(free):
        basis[k, f] = 1
        for i, c in enumerate(pivots):  # pivot variable c = sum of the free ones in its row
            basis[k, c] = a[i, f]
    return basis


def sign_symmetries(support: np.ndarray) -> np.ndarray:
    """The sign symmetries of a polynomial with exponent rows ``support`` (GF(2) basis, one per
    row): flipping the signs of the variables marked in a row leaves every monomial unchanged.

    Parameters
    ----------
    support : numpy.ndarray
        Exponent table of the polynomial's monomials, shape (m, n) for n variables.

    Returns
    -------
    numpy.ndarray
        The symmetries as 0/1 rows of a GF(2) basis, shape (s, n).
    """
    support = np.asarray(support)
    if support.ndim != 2:
        raise ValueError(f"support must be a 2-D exponent table, got shape {support.shape}")
    return gf2_null_space(support)


def symmetry_blocks(basis: np.ndarray, support: np.ndarray) -> list[np.ndarray]:
    """The Gram blocks of ``p = z(x)^T G z(x)`` that the sign symmetries of ``p`` allow.

    Parameters
    ----------
    basis : (N, n) integer array
        Exponents of the monomial basis ``z``.
    support : (m, n) integer array
        Every exponent ``p`` may have (for a polynomial with decision-variable coefficients:
        every monomial any choice of the decision variables can produce).

    Returns
    -------
    list of int arrays
        Indices into ``basis``, one array per block, blocks ordered by their first index; a
        single block ``arange(N)`` when ``p`` has no symmetry that separates the basis.
    """
    basis = np.asarray(basis)
    if basis.shape[0] == 0:
        return []
    if basis.ndim != 2 or np.asarray(support).ndim != 2 or basis.shape[1] != np.asarray(support).shape[1]:
        raise ValueError(f"basis {basis.shape} and support {np.asarray(support).shape} must be exponent tables "
                         "over the same variables")
    sym = sign_symmetries(support)
    if sym.shape[0] == 0:
        return [np.arange(basis.shape[0])]
    signature = (basis.astype(np.int64) @ sym.T.astype(np.int64)) % 2
    _, label = np.unique(signature, axis=0, return_inverse=True)
    label = np.asarray(label).ravel()
    blocks = [np.flatnonzero(label == k) for k in range(label.max() + 1)]
    return sorted(blocks, key=lambda b: int(b[0]))
