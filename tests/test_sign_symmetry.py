"""Sign symmetries over GF(2) and the Gram blocks they allow (synthesis/core/sign_symmetry.py)."""
from __future__ import annotations

import numpy as np
import pytest

from satfmu.synthesis.core.polynomial import monomials
from satfmu.synthesis.core.sign_symmetry import gf2_null_space, sign_symmetries, symmetry_blocks


def test_null_space_is_exact_and_complete() -> None:
    rng = np.random.default_rng(3)
    for _ in range(200):
        m, n = rng.integers(0, 7), rng.integers(1, 9)
        a = rng.integers(0, 4, (m, n))
        basis = gf2_null_space(a)
        assert np.all((a @ basis.T.astype(int)) % 2 == 0)  # every vector is a null vector
        rank = basis.shape[0]
        if rank:  # independent: the GF(2) span has 2^rank distinct members
            span = {tuple(((np.array(c) @ basis.astype(int)) % 2)) for c in np.ndindex(*(2,) * rank)}
            assert len(span) == 2 ** rank
        # complete: brute force over GF(2)^n
        count = sum(1 for r in np.ndindex(*(2,) * n) if np.all((a @ np.array(r)) % 2 == 0))
        assert count == 2 ** rank


def test_separable_square_sum_splits_per_variable() -> None:
    # x^2 + y^2: flipping x or y alone leaves it unchanged; basis (x, y) -> two 1x1 blocks
    support = np.array([[2, 0], [0, 2]])
    assert sign_symmetries(support).shape[0] == 2
    blocks = symmetry_blocks(np.array([[1, 0], [0, 1]]), support)
    assert [b.tolist() for b in blocks] == [[0], [1]]


def test_cross_term_joins_the_block() -> None:
    # x^2 + x y + y^2: only the joint flip (1, 1) survives; x and y share a block
    support = np.array([[2, 0], [1, 1], [0, 2]])
    assert sign_symmetries(support).tolist() == [[1, 1]]
    assert [b.tolist() for b in symmetry_blocks(np.array([[1, 0], [0, 1]]), support)] == [[0, 1]]


def test_even_quartic_separates_constant_from_odd_and_even() -> None:
    # p(x, y) even in each variable (degree <= 4): basis of degree <= 2 splits into the sign classes
    # {1, x^2, y^2, ...}, {x}, {y}, {x y}
    support = monomials(2, 4)
    support = support[np.all(support % 2 == 0, axis=1)]
    basis = monomials(2, 2)
    blocks = symmetry_blocks(basis, support)
    classes = sorted(tuple(sorted(map(tuple, basis[b].tolist()))) for b in blocks)
    assert classes == sorted([((0, 0), (0, 2), (2, 0)), ((1, 0),), ((0, 1),), ((1, 1),)])
    assert sum(len(b) for b in blocks) == len(basis)


def test_no_symmetry_gives_one_block_and_bad_shapes_are_refused() -> None:
    support = np.array([[1, 0], [0, 1], [2, 0], [0, 2]])  # x + y + ...: no flip keeps it
    assert sign_symmetries(support).shape[0] == 0
    assert [b.tolist() for b in symmetry_blocks(monomials(2, 1), support)] == [[0, 1, 2]]
    assert symmetry_blocks(np.zeros((0, 2), int), support) == []
    with pytest.raises(ValueError, match="same variables"):
        symmetry_blocks(np.array([[1, 0, 0]]), support)
    with pytest.raises(ValueError, match="2-D exponent table"):
        sign_symmetries(np.array([1, 2]))


def _coefficients(basis: np.ndarray, G: np.ndarray) -> dict[tuple[int, ...], float]:
    """Coefficients of z^T G z by monomial."""
    out: dict[tuple[int, ...], float] = {}
    for i, j in np.ndindex(*G.shape):
        key = tuple((basis[i] + basis[j]).tolist())
        out[key] = out.get(key, 0.0) + G[i, j]
    return out


def test_block_restriction_of_any_gram_is_a_gram_of_the_same_polynomial() -> None:
    # p is even in x but one of its Gram matrices is not block-diagonal: the entries (x, y) and
    # (1, x y) both make x y and cancel. Zeroing every entry across the blocks (the average over the
    # flip x -> -x) keeps p's coefficients and positive semidefiniteness: nothing is lost.
    rng = np.random.default_rng(0)
    basis = monomials(2, 2)  # 1, x, y, x^2, x y, y^2 in some order
    D = np.diag((-1.0) ** basis[:, 0])
    R = rng.normal(size=(6, 6))
    G = R @ R.T + np.eye(6)
    G_sym = (G + D @ G @ D) / 2
    E = np.zeros((6, 6))
    idx = {tuple(b): k for k, b in enumerate(basis.tolist())}
    for (a, b), sign in ((((1, 0), (0, 1)), 1.0), (((0, 0), (1, 1)), -1.0)):
        E[idx[a], idx[b]] = E[idx[b], idx[a]] = sign
    G_full = G_sym + 0.3 * E
    assert np.linalg.eigvalsh(G_full).min() > 0  # a valid Gram matrix, not block-diagonal
    coeffs = _coefficients(basis, G_full)
    support = np.array([k for k, v in coeffs.items() if abs(v) > 1e-12])
    blocks = symmetry_blocks(basis, support)
    assert sorted(len(b) for b in blocks) == [2, 4]  # x-odd {x, x y}, x-even {1, y, x^2, y^2}
    mask = np.zeros((6, 6), bool)
    for b in blocks:
        mask[np.ix_(b, b)] = True
    G_block = np.where(mask, G_full, 0.0)
    assert np.linalg.eigvalsh(G_block).min() > 0
    restricted = _coefficients(basis, G_block)
    assert all(abs(restricted.get(k, 0.0) - v) < 1e-12 for k, v in coeffs.items())  # same p, to rounding
