"""The shared gain fit: its monomial basis, the fit of a known polynomial gain, its artifact terms."""
from __future__ import annotations

import math

import numpy as np
import pytest

from satfmu.synthesis.servo.polynomial_fit import PolynomialFit, exponents, fit_gains, monomials


def test_basis_is_graded_and_complete() -> None:
    for n_vars, degree in ((1, 0), (2, 3), (6, 2)):
        E = exponents(n_vars, degree)
        assert len(E) == math.comb(n_vars + degree, degree) == len(set(E))
        assert [sum(e) for e in E] == sorted(sum(e) for e in E)  # graded
    assert exponents(2, 2) == [(0, 0), (1, 0), (0, 1), (2, 0), (1, 1), (0, 2)]
    pts = np.array([[2.0, 3.0], [-1.0, 0.5]])
    assert np.array_equal(monomials(pts, 2), np.array([[1, 2, 3, 4, 6, 9], [1, -1, 0.5, 1, -0.5, 0.25]]))


def test_a_polynomial_gain_is_recovered_and_stored_as_terms() -> None:
    rng = np.random.default_rng(3)
    pts = rng.uniform(-1, 1, size=(60, 2))
    # K(x) (1x2): [1 + 2 x0 x1, -x1^2]; degree 2 fits it exactly, the CV error ~ rounding
    gains = np.stack([1 + 2 * pts[:, 0] * pts[:, 1], -pts[:, 1] ** 2], axis=1)[:, None, :]
    fit = PolynomialFit(*fit_gains(pts, gains, range(0, 4), 5, 0, 1e-9), pts, gains, 1e-9)
    assert fit.degree == 2 and fit.max_rel_error < 1e-12  # least squares of an exact fit: rounding only
    assert np.allclose(fit.evaluate([0.5, -0.5]), [[[1 - 0.5, -0.25]]], atol=1e-12)
    terms = fit.terms()
    assert [(t["e"], round(t["c"], 9)) for t in terms[0][0] if abs(t["c"]) > 1e-9] == [([0, 0], 1.0), ([1, 1], 2.0)]
    assert [(t["e"], round(t["c"], 9)) for t in terms[0][1] if abs(t["c"]) > 1e-9] == [([0, 2], -1.0)]
    with pytest.raises(ValueError, match="too few for degree 3"):
        fit_gains(pts[:15], gains[:15], range(0, 4), 5, 0, None)  # 15 < 2 x 10 terms
