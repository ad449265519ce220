"""Seed 003's Theorem 2: the periodic system from the plant, the LMIs, their independent checks, ESMS."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad

from satfmu.controllers import artifact as artifacts
from satfmu.controllers.polynomial import ARTIFACTS
from satfmu.fmus.plants import cubesat
from satfmu.synthesis.periodic import cubesat_periodic
from satfmu.synthesis.periodic import periodic_hinf


@pytest.fixture(scope="module")
def system() -> periodic_hinf.PeriodicSystem:
    return cubesat_periodic.system()


@pytest.fixture(scope="module")
def designed(system: periodic_hinf.PeriodicSystem) -> periodic_hinf.PeriodicDesign:
    d = periodic_hinf.design(system, 26.0)
    assert d is not None
    return d


def test_input_matrix_is_the_seeds_eq_7_from_the_plant() -> None:
    B = cubesat_periodic.input_matrix()
    for t in (0.0, 1234.0, 4000.0):
        ph_ = 2 * math.pi * t / 5400.0
        basis = np.array([1, math.sin(ph_), math.cos(ph_), math.sin(2 * ph_), math.cos(2 * ph_)])
        bx, by, bz = (1e-6 * np.dot(cubesat.FIELD_FOURIER_SEED[a], basis) for a in "xyz")
        expected = np.array([[0, 200 * bz, -200 * by], [-200 * bz, 0, 200 * bx], [500 * by, -500 * bx, 0]])
        assert np.abs(np.asarray(B(t), float) - expected).max() < 1e-15  # rounding: 500 x sums of 5e-5 T terms


def test_held_integrals_match_adaptive_quadrature() -> None:
    B = cubesat_periodic.input_matrix()
    Bd = cubesat_periodic.held_integrals()
    for k in (0, 3, 5):
        for i, j in ((0, 1), (1, 2), (2, 0)):
            ref = quad(lambda t: float(np.asarray(B(t), float)[i, j]), k * 900.0, (k + 1) * 900.0,
                       epsabs=0, epsrel=1e-13)[0]
            assert Bd[k, i, j] == pytest.approx(ref, rel=1e-12)  # Gauss-Legendre on a trig polynomial


def test_noise_terms_are_sigma_times_the_unit_coefficient_patterns(system: periodic_hinf.PeriodicSystem) -> None:
    N, r, n, m1, m2, p = system.dims
    assert (N, r, n, m1, m2, p) == (6, 3, 3, 3, 3, 6)
    for l, (sigma, inertia) in enumerate(zip(cubesat_periodic.SIGMA_SEED, cubesat.INERTIA_SEED_003)):
        expected = np.zeros_like(system.B2[:, 0])
        expected[:, l] = sigma * inertia * system.B2[:, 0, l]
        assert np.abs(system.B2[:, l + 1] - expected).max() < 1e-15
    assert np.array_equal(system.B1, 1e-2 * system.B2)


def test_gamma_min_matches_the_independent_model_and_the_bisection(system: periodic_hinf.PeriodicSystem) -> None:
    best = periodic_hinf.gamma_min(system)
    # docs/models.md (independent cvxpy + Clarabel model): gamma_min = 25.6; 1e-3: solver accuracy
    assert best.gamma == pytest.approx(25.61, rel=1e-3)
    lo, hi, n = periodic_hinf.bisect_gamma(system, 20.0, 30.0, rel_tol=1e-3)
    assert lo < best.gamma <= hi * (1 + 1e-6) and n < 20
    assert periodic_hinf.design(system, cubesat_periodic.GAMMA_SEED) is None  # the seed's gamma = 0.5 is infeasible
    # A solver-free lower bound (docs/models.md): from the first output step, W1 * 1e-2 * ||[B2_0; B2_l]||
    stacked = np.vstack([system.B2[0, l] for l in range(4)])
    assert best.gamma > cubesat_periodic.W1_SEED * 1e-2 * np.linalg.norm(stacked, 2) * 0.99


def test_minutes_reading_explains_the_seeds_gamma() -> None:
    # B(t) integrated with t in minutes (60x smaller): gamma_min falls to ~0.43, below the seed's 0.5.
    best = periodic_hinf.gamma_min(cubesat_periodic.system(time_unit=60.0))
    assert best.gamma == pytest.approx(0.427, rel=1e-2)


def test_design_is_verified_and_its_gains_have_the_seeds_structure(system, designed) -> None:
    assert designed.check.ok and designed.check.block_max_eig.max() < -1e-4
    assert designed.F.shape == (6, 3, 3)
    # docs/models.md: max |F| 0.142 at gamma 26 (published: 0.078)
    assert np.abs(designed.F).max() == pytest.approx(0.142, rel=0.02)
    Y, Z = designed.Y, designed.Z
    assert np.abs(np.stack([np.linalg.solve(Y[k], Z[k]).T for k in range(6)]) - designed.F).max() < 1e-12


def test_verify_rejects_a_wrong_certificate(system, designed) -> None:
    assert not periodic_hinf.certify(system, -designed.Y, designed.Z, 26.0).ok  # Y < 0
    assert not periodic_hinf.certify(system, designed.Y, 3 * designed.Z, 26.0).ok  # other gains
    assert not periodic_hinf.certify(system, designed.Y, designed.Z, 20.0).ok  # below gamma_min


def test_mean_square_stability_designed_published_and_perturbed(system, designed) -> None:
    assert periodic_hinf.ms_spectral_radius(system, designed.F) < 1e-4
    # docs/models.md: the published gains are ESMS on this model with radius 0.141
    assert periodic_hinf.ms_spectral_radius(system, cubesat_periodic.PUBLISHED_GAINS) == pytest.approx(0.1408, rel=1e-3)
    assert periodic_hinf.ms_spectral_radius(system, -designed.F) > 1  # positive feedback
    assert periodic_hinf.ms_spectral_radius(system, 3 * designed.F) > 1  # over-corrected holds


def test_published_gains_analysis_gives_their_level(system) -> None:
    a = periodic_hinf.analyze(system, cubesat_periodic.PUBLISHED_GAINS)
    assert a is not None and a.check.ok
    assert a.gamma == pytest.approx(87.1, rel=2e-3)  # docs/models.md: gamma ~ 87
    assert np.abs(a.F - cubesat_periodic.PUBLISHED_GAINS).max() < 1e-12


def test_monte_carlo_mean_square_follows_the_exact_second_moment(system) -> None:
    F = cubesat_periodic.PUBLISHED_GAINS
    x0 = np.array([0.05, -0.04, 0.03])
    exact = np.trace(periodic_hinf.second_moment(system, F, np.outer(x0, x0), 24), axis1=1, axis2=2)
    x, u = periodic_hinf.monte_carlo(system, F, x0, 24, 4000, seed=7)
    sq = (x**2).sum(axis=2)
    mc, se = sq.mean(axis=0), sq.std(axis=0) / math.sqrt(len(sq))
    # 5 standard errors (a 1e-6 false-alarm rate), plus rounding where x(0) is deterministic
    assert np.all(np.abs(mc - exact) <= 5 * se + 1e-12 * exact)
    # Over whole periods the exact mean square decays at the monodromy's spectral radius.
    rho = periodic_hinf.ms_spectral_radius(system, F)
    assert exact[24] / exact[18] == pytest.approx(rho, rel=0.05)  # 5 %: the second eigenvalue's remnant
    assert np.abs(u[:, 0] - x[:, 0] @ F[0].T).max() < 1e-18


def test_bad_input_is_rejected(system) -> None:
    with pytest.raises(periodic_hinf.PeriodicSystemError, match="A must have shape"):
        periodic_hinf.PeriodicSystem(np.zeros((6, 4, 3)), system.B1, system.B2, system.C, system.D)
    with pytest.raises(periodic_hinf.PeriodicSystemError, match="B2 must have shape"):
        periodic_hinf.PeriodicSystem(system.A, system.B1, system.B2[:, :3], system.C, system.D)
    nan = system.A.copy()
    nan[2, 0, 1, 1] = np.nan
    with pytest.raises(periodic_hinf.PeriodicSystemError, match="A has non-finite"):
        periodic_hinf.PeriodicSystem(nan, system.B1, system.B2, system.C, system.D)
    with pytest.raises(periodic_hinf.PeriodicSystemError, match="gains must be finite"):
        system.closed_loop(np.zeros((5, 3, 3)))
    with pytest.raises(ValueError, match="gamma must be finite"):
        periodic_hinf.design(system, -1.0)
    with pytest.raises(ValueError, match="is feasible: lower lo"):
        periodic_hinf.bisect_gamma(system, 30.0, 40.0)
    with pytest.raises(ValueError, match="need Ts"):
        cubesat_periodic.system(Ts=-1.0)
    with pytest.raises(ValueError):
        periodic_hinf.monte_carlo(system, cubesat_periodic.PUBLISHED_GAINS, np.zeros(3), 0, 10, seed=1)


@pytest.mark.parametrize("name", ["cubesat_periodic_satfmu", "cubesat_periodic_published"])
def test_shipped_artifacts_are_what_they_claim(system, name: str) -> None:
    art = artifacts.load(ARTIFACTS / f"{name}.json")
    numbers = art.certificate["numbers"]
    assert art.certificate["status"] == "certified"
    assert periodic_hinf.ms_spectral_radius(system, art.gains) == pytest.approx(numbers["ms_spectral_radius"], rel=1e-6)
    a = periodic_hinf.analyze(system, art.gains)  # re-proved from the gains alone
    assert a is not None and a.gamma <= numbers["gamma"] * (1 + 1e-4)
