"""Integer keys of monomial exponent rows: merging and matching by index arithmetic.

A table of exponent rows (k x n non-negative integers) whose column ``j`` stays below
``bound[j]`` is encoded in that mixed radix: ``key(e) = sum_j e_j w_j`` with
``w_j = prod_{l > j} bound[l]``. The keys are ordered as the rows lexicographically, equal
exactly when the rows are, and additive: ``key(e + f) = key(e) + key(f)`` when the bounds
cover the sums, so the exponents of a product are the sum of two keys. Merging equal rows
is then ``np.unique`` of integers, and finding the rows of one table in another a
``searchsorted`` of keys computed for both tables together.
"""
from __future__ import annotations

import numpy as np

LIMIT = 2**62
"""Keys stay below this (int64 with room for one addition)."""


def weights(bound: np.ndarray, prefix: int = 1) -> np.ndarray | None:
    """Mixed-radix weights of rows with column ``j`` in ``[0, bound[j])``, or None.

    Parameters
    ----------
    bound : ndarray of int
        Exclusive upper bound of each column (>= 1).
    prefix : int
        Number of distinct values of a leading index the caller puts above the row
        (``key = index * prod(bound) + row @ w``); it must fit too.

    Returns
    -------
    ndarray of int64 or None
        ``w`` with ``key = row @ w``, or None when ``prefix * prod(bound)`` reaches
        :data:`LIMIT` (then use :func:`keys`, which compresses as it goes).
    """
    w = np.empty(len(bound), np.int64)
    span = 1
    for j in range(len(bound) - 1, -1, -1):
        w[j] = span
        span *= int(bound[j])
        if span * prefix >= LIMIT:
            return None
    return w


def keys(rows: np.ndarray) -> np.ndarray:
    """Integer keys of the rows of a non-negative integer table (k x n).

    Equal exactly when the rows are equal and ordered as the rows lexicographically,
    for any size: the radix code is replaced by its rank among the rows (``np.unique``)
    whenever the next column would overflow it.

    Parameters
    ----------
    rows : numpy.ndarray
        Non-negative integer table, shape (k, n).

    Returns
    -------
    numpy.ndarray
        One int64 key per row, shape (k,).
    """
    code = np.zeros(rows.shape[0], np.int64)
    span = 1
    for j in range(rows.shape[1]):
        col = rows[:, j].astype(np.int64, copy=False)
        radix = int(col.max(initial=0)) + 1
        if span * radix >= LIMIT:
            uniq, code = np.unique(code, return_inverse=True)
            span = len(uniq)
        code = code * radix + col
        span *= radix
    return code

