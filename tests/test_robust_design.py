"""Robust multi-objective state feedback by LMIs (R-ROMULOC seed): designs checked on sampled
plants, the dual certificates turned back into the primal, the scenario programs, bad options."""
from __future__ import annotations

import dataclasses

import cvxpy as cp
import numpy as np
import pytest

from satfmu.synthesis.core import lmi
from satfmu.synthesis.robust import certificate, constraint_generation, rescaling, robust_design, solve_strategy
from satfmu.synthesis.robust.lft_plant import LFTPlant, OptionError, PlantDataError, TooManyVerticesError
from satfmu.synthesis.robust.robust_design import BACKOFFS, EPS, Multiplier, RobustDesign, design, i2p_bound, certify
from satfmu.synthesis.core.system_norms import hinf_norm, impulse_to_peak
from tests.robust_plants import ALPHA, BETA, lft_plant, sampled_loops, samples, scalar_plant


ROBUST_MODULES = (certificate, solve_strategy, rescaling, constraint_generation, robust_design)
"""The modules of the robust design whose functions look up each other's names (each imports them by name)."""


def objective(d: RobustDesign, w_hinf: float = 1.0, w_i2p: float = 100.0) -> float:
    return w_hinf * d.gamma + w_i2p * d.nu


def patch(monkeypatch, name: str, value) -> None:
    """Set ``name`` in every module of :data:`ROBUST_MODULES` that has it: where it is defined and
    wherever it is imported, so that every call or read sees ``value``."""
    holders = [m for m in ROBUST_MODULES if hasattr(m, name)]
    assert holders, name
    for module in holders:
        monkeypatch.setattr(module, name, value)


@pytest.fixture(scope="module")
def plant() -> LFTPlant:
    return lft_plant()


@pytest.fixture(scope="module")
def designs(plant: LFTPlant) -> dict[str, RobustDesign]:
    return {u: design(plant, alpha=ALPHA, beta=BETA, uncertainty=u) for u in ("norm", "vertex")}


# ---------------------------------------------------------------------------------------------
# Designs


@pytest.mark.parametrize("uncertainty", ["norm", "vertex"])
def test_design_holds_on_samples(plant, designs, uncertainty: str) -> None:
    d = designs[uncertainty]
    assert d.status == "optimal" and d.check.ok and d.K.shape == (1, 5)
    # measured: norm gamma 9.870, nu 0.1565; vertex gamma 8.190, nu 0.1457 (solves ~0.1 s)
    assert d.check.min_eig["Y"].min() > 0 and d.check.margin > 1e-8
    assert d.n_multipliers == (6 if uncertainty == "norm" else 3)
    assert d.n_vertices == (0 if uncertainty == "norm" else 4)
    deltas = samples(2)
    Acl, B1, C1, D11 = sampled_loops(plant, d.K, deltas)
    poles = np.linalg.eigvals(Acl)
    assert np.all(poles.real < -ALPHA) and np.all(poles.real > -BETA)
    norms = hinf_norm(Acl, B1, C1, D11)
    # hinf_norm is an upper bound within 2e-9 relative; gamma is certified: no solver slack needed
    assert norms.max() <= d.gamma  # measured max 2.69 (norm), 2.65 (vertex)
    peaks = impulse_to_peak(Acl, plant.B2, plant.C2, 100.0, 4001)
    assert peaks.max() <= d.nu  # measured max 0.059: the grid value is below the supremum


def test_vertex_separator_is_no_worse_than_dg(designs) -> None:
    # Full-block multipliers contain the D-G ones (on the boundary of the strict vertex
    # conditions): the vertex optimum is no larger up to eps and solver accuracy (1e-3).
    # Measured: 22.76 (vertex) against 25.51 (norm): here the box matters.
    assert objective(designs["vertex"]) <= objective(designs["norm"]) * (1 + 1e-3)


def _primal_hinf(plant: LFTPlant, d: RobustDesign, delta_list: np.ndarray) -> tuple[float, float]:
    """Largest eigenvalue of the primal full-block S-procedure LMI built from P = Y^-1 and
    Pi = Pi~^-1, and the smallest of [I; Delta]^T Pi [I; Delta] over the deltas given."""
    mu = d.multipliers["hinf"]
    P = np.linalg.inv(d.Y)
    Pi = np.linalg.inv(np.block([[mu.Q, mu.S], [mu.S.T, mu.R]]))
    n, nq, m1, p1 = plant.A.shape[0], plant.Cq.shape[0], plant.B1.shape[1], plant.C1.shape[0]
    K, g = d.K, d.gamma
    z = np.zeros
    # signals (x, x', q, p, w, z) as functions of (x, p, w)
    T = np.block([[np.eye(n), z((n, nq)), z((n, m1))],
                  [plant.A + plant.Bu @ K, plant.Bp, plant.B1],
                  [plant.Cq + plant.Dqu @ K, plant.Dqp, plant.Dq1],
                  [z((nq, n)), np.eye(nq), z((nq, m1))],
                  [z((m1, n)), z((m1, nq)), np.eye(m1)],
                  [plant.C1 + plant.D1u @ K, plant.D1p, plant.D11]])
    M = np.zeros((2 * n + 2 * nq + m1 + p1,) * 2)
    M[:n, n:2 * n] = M[n:2 * n, :n] = P
    M[2 * n:2 * n + 2 * nq, 2 * n:2 * n + 2 * nq] = Pi
    M[2 * n + 2 * nq:2 * n + 2 * nq + m1, 2 * n + 2 * nq:2 * n + 2 * nq + m1] = -g * np.eye(m1)
    M[-p1:, -p1:] = np.eye(p1) / g
    L = T.T @ M @ T
    top = np.linalg.eigvalsh((L + L.T) / 2)[-1]
    low = min(np.linalg.eigvalsh(np.vstack([np.eye(nq), plant.delta_matrix(dl)]).T @ Pi
                                 @ np.vstack([np.eye(nq), plant.delta_matrix(dl)]))[0] for dl in delta_list)
    return float(top), float(low)


@pytest.mark.parametrize("uncertainty", ["norm", "vertex"])
def test_dual_certificate_gives_the_textbook_primal(plant, designs, uncertainty: str) -> None:
    """The dualization, checked independently: the inverse multiplier and P = Y^-1 satisfy the
    primal full-block S-procedure (Scherer 2001) and the primal multiplier condition."""
    d = designs[uncertainty]
    top, low = _primal_hinf(plant, d, samples(2, seed=9))
    assert top < 0
    # [I; Delta]^T Pi [I; Delta] >= 0 on the box; 0 at the D-G vertices (delta^2 = 1), so rounding
    # of the inverses (1e-9 of their size) is allowed
    assert low >= -1e-9
    if uncertainty == "norm":  # the inverse of a dual D-G multiplier is a primal D-G one: J Pi J = -Pi
        mu = d.multipliers["hinf"]
        Pi = np.linalg.inv(np.block([[mu.Q, mu.S], [mu.S.T, mu.R]]))
        J = np.kron(np.array([[0, 1], [1, 0]]), np.eye(3))
        assert np.abs(J @ Pi @ J + Pi).max() < 1e-9 * np.abs(Pi).max()  # inversion rounding


def _full_plant() -> LFTPlant:
    """A random LFT with every uncertainty channel used (D1p, Dqp, Dqu, Dq1 nonzero), fixed seed."""
    rng = np.random.default_rng(2)
    n, nq, m, m1, p1 = 3, 3, 1, 2, 2

    def g(*shape: int, s: float = 1.0) -> np.ndarray:
        return s * rng.normal(size=shape)

    return LFTPlant(g(n, n), g(n, nq, s=0.5), g(n, m), g(n, m1), g(n, 1), g(nq, n, s=0.5), g(nq, nq, s=0.2),
                    g(nq, m, s=0.3), g(nq, m1, s=0.3), g(p1, n), g(p1, nq, s=0.3), np.array([[0.0], [0.3]]),
                    np.zeros((p1, m1)), g(1, n), (("a", 2), ("b", 1)))


@pytest.mark.parametrize("uncertainty", ["norm", "vertex"])
def test_every_channel_of_the_lft(uncertainty: str) -> None:
    plant = _full_plant()
    d = design(plant, alpha=0.1, beta=50.0, uncertainty=uncertainty)
    assert d.status == "optimal"
    deltas = samples(2)[:100]
    Acl, B1, C1, D11 = sampled_loops(plant, d.K, deltas)
    poles = np.linalg.eigvals(Acl).real
    assert poles.max() < -0.1 and poles.min() > -50.0
    assert hinf_norm(Acl, B1, C1, D11).max() <= d.gamma  # certified bound, exact norms
    assert impulse_to_peak(Acl, plant.B2, plant.C2, 50.0, 2001).max() <= d.nu
    top, low = _primal_hinf(plant, d, samples(2, seed=9))
    assert top < 0 and low >= -1e-9  # as in test_dual_certificate_gives_the_textbook_primal


@pytest.mark.parametrize("d", [0.5, -0.5])
@pytest.mark.parametrize("uncertainty", ["norm", "vertex"])
def test_one_real_scalar_is_exact(uncertainty: str, d: float) -> None:
    # A(delta) ranges over [-1 - a/(1 + d), -1 + a/(1 - d)]: decay rate alpha for the whole box
    # iff a < (1 - alpha)(1 - d). One scalar P and one scalar multiplier are lossless there.
    alpha = 0.1
    a_star = (1 - alpha) * (1 - d)
    inside = i2p_bound(scalar_plant(0.99 * a_star, d), np.zeros((1, 1)), alpha=alpha, uncertainty=uncertainty)
    assert inside.status == "optimal"
    assert inside.nu == pytest.approx(1.0, rel=2e-4)  # peak |c b| = 1 at t = 0; back-off 1e-4
    outside = i2p_bound(scalar_plant(1.01 * a_star, d), np.zeros((1, 1)), alpha=alpha, uncertainty=uncertainty)
    assert outside.status == "infeasible" and outside.K is None


def _certain_plant() -> LFTPlant:
    """Position, velocity, integral of position; u and w1 forces; z1 = (x, 0.1 u); z2 = x."""
    A = np.array([[0, 1, 0], [0, 0, 0], [1, 0, 0.0]])
    Bu = np.array([[0], [1], [0.0]])
    return LFTPlant.without_uncertainty(A, Bu, Bu, 0.5 * Bu, np.array([[1, 0, 0], [0, 0, 0.0]]),
                                        np.array([[0], [0.1]]), np.zeros((2, 1)), np.array([[1, 0, 0.0]]))


def _matrices(plant: LFTPlant) -> tuple[np.ndarray, ...]:
    """A, Bu, B1, B2, C1, D1u, D11, C2 of a certain plant."""
    return plant.A, plant.Bu, plant.B1, plant.B2, plant.C1, plant.D1u, plant.D11, plant.C2


def _plain_lmi(plant: LFTPlant, alpha: float, beta: float, w_i2p: float, eps: float = EPS) -> float:
    """The nominal problem written directly (bounded-real lemma in Y, i2p, region)."""
    A, Bu, B1, B2, C1, D1u, D11, C2 = _matrices(plant)
    n = A.shape[0]
    Y, W = cp.Variable((n, n), symmetric=True), cp.Variable((1, n))
    g, nu = cp.Variable(), cp.Variable()
    AY = A @ Y + Bu @ W
    CY = C1 @ Y + D1u @ W
    brl = cp.bmat([[AY + AY.T, B1, CY.T], [B1.T, -g * np.eye(1), D11.T], [CY, D11, -g * np.eye(2)]])
    ip = cp.bmat([[Y, B2], [B2.T, nu * np.eye(1)]])
    I = np.eye(n)
    cons = [Y >> eps * I, (brl + brl.T) / 2 << -eps * np.eye(n + 3), AY + AY.T + 2 * alpha * Y << -eps * I,
            -(AY + AY.T) - 2 * beta * Y << -eps * I, (ip + ip.T) / 2 >> eps * np.eye(n + 1),
            C2 @ Y @ C2.T - nu * np.eye(1) << -eps * np.eye(1)]
    prob = cp.Problem(cp.Minimize(g + w_i2p * nu), cons)
    prob.solve(solver=cp.CLARABEL)
    return float(prob.value)


def test_nominal_design_is_the_plain_lmi_and_weights_trade_off() -> None:
    plant = _certain_plant()
    d = design(plant, alpha=0.1, beta=10.0)
    assert d.status == "optimal" and d.n_multipliers == 0 and d.multipliers == {}
    plain = _plain_lmi(plant, 0.1, 10.0, 100.0)
    assert d.solver_objective == pytest.approx(plain, rel=1e-6)  # the same program: solver accuracy
    assert d.backoff == BACKOFFS[0]  # a well-conditioned program verifies at the first back-off
    assert objective(d) <= plain * (1 + 2 * d.backoff)  # certified levels: the back-off
    cheap, dear = (design(plant, alpha=0.1, beta=10.0, w_i2p=w) for w in (1.0, 1000.0))
    # measured: w_i2p 1: gamma 0.166, nu 0.142; 100: 1.71, 0.0338; 1000: 7.03, 0.0179
    assert dear.nu < cheap.nu and dear.gamma > cheap.gamma
    poles = np.linalg.eigvals(plant.A + plant.Bu @ d.K)
    assert np.all(poles.real < -0.1) and np.all(poles.real > -10.0)


def _toolbox_lmi(plant: LFTPlant, alpha: float, beta: float, w_i2p: float, eps: float = EPS) -> float:
    """The nominal problem in the R-RoMulOC toolbox's own forms, written directly: H-infinity
    ``[He(A P + Bu S) + Bw Bw^T, P Cz^T + S^T Dzu^T + Bw Dzw^T; *, -g_inf I + Dzw Dzw^T] < 0``,
    impulse-to-peak ``P >= B2 B2^T``, ``[-g_i2p I, C2 P; *, -P] < 0``, the region, objective
    ``g_inf + w_i2p g_i2p``."""
    A, Bu, B1, B2, C1, D1u, D11, C2 = _matrices(plant)
    n = A.shape[0]
    P, S = cp.Variable((n, n), symmetric=True), cp.Variable((1, n))
    g_inf, g_i2p = cp.Variable(), cp.Variable()
    AP = A @ P + Bu @ S
    CP = C1 @ P + D1u @ S
    hinf = cp.bmat([[AP + AP.T + B1 @ B1.T, CP.T + B1 @ D11.T], [CP + D11 @ B1.T, -g_inf * np.eye(2) + D11 @ D11.T]])
    peak = cp.bmat([[-g_i2p * np.eye(1), C2 @ P], [P @ C2.T, -P]])
    I = np.eye(n)
    cons = [P >> eps * I, (hinf + hinf.T) / 2 << -eps * np.eye(n + 2), AP + AP.T + 2 * alpha * P << -eps * I,
            -(AP + AP.T) - 2 * beta * P << -eps * I, P - B2 @ B2.T >> eps * I,
            (peak + peak.T) / 2 << -eps * np.eye(n + 1)]
    prob = cp.Problem(cp.Minimize(g_inf + w_i2p * g_i2p), cons)
    prob.solve(solver=cp.CLARABEL)
    return float(prob.value)


def test_toolbox_convention_is_the_toolbox_lmis() -> None:
    # convention="romuloc" through the dual multiplier machinery (levels (g, 1) on the z and w
    # sides) poses the toolbox's LMIs: the same optimum as those written directly. The two
    # programs' strictness margins differ in shape (ours on [[Y, B2], [B2^T, 1]], the direct one
    # on P - B2 B2^T, ...): measured 6.6e-5 apart at eps 1e-7, 1.0e-6 at 1e-9, 4e-7 at 1e-10, so
    # eps 1e-9 and 1e-5. The bounds are sqrt(g), and they hold on the closed loop.
    plant = _certain_plant()
    d = design(plant, alpha=0.1, beta=10.0, convention="romuloc", eps=1e-9)
    assert d.status == "optimal" and d.convention == "romuloc"
    assert d.solver_objective == pytest.approx(_toolbox_lmi(plant, 0.1, 10.0, 100.0, eps=1e-9), rel=1e-5)
    assert d.gamma**2 + 100 * d.nu**2 <= d.solver_objective * (1 + 2 * d.backoff)  # the back-off on g
    Acl = plant.A + plant.Bu @ d.K
    assert hinf_norm(Acl, plant.B1, plant.C1 + plant.D1u @ d.K, plant.D11) <= d.gamma
    assert impulse_to_peak(Acl, plant.B2, plant.C2, 60.0, 6001) <= d.nu
    ours = design(plant, alpha=0.1, beta=10.0)
    assert (ours.gamma, ours.nu) != pytest.approx((d.gamma, d.nu), rel=1e-2)  # another trade-off


def test_a_certificate_is_checked_in_its_own_convention() -> None:
    # Both conventions at once (H-infinity and impulse-to-peak with one Y) give different
    # certificates; each verifies in its own convention, and certify() rejects a convention it
    # does not know.
    plant = _certain_plant()
    for c in ("satfmu", "romuloc"):
        d = design(plant, alpha=0.1, beta=10.0, convention=c)
        assert d.status == "optimal"
        options = {"alpha": 0.1, "beta": 10.0}
        assert certify(plant, d.K, d.Y, d.gamma, d.nu, {}, convention=c, **options).ok
    with pytest.raises(OptionError, match="convention must be one of"):
        certify(plant, d.K, d.Y, d.gamma, d.nu, {}, alpha=0.1, beta=10.0, convention="matlab")
    with pytest.raises(OptionError, match="convention must be one of"):
        design(plant, convention="ROMULOC")


def test_infeasible_designs_are_reported() -> None:
    A = np.diag([1.0, -1.0])  # the unstable mode is not controlled
    Bu = np.array([[0.0], [1.0]])
    c = np.array([[1.0, 1.0]])
    plant = LFTPlant.without_uncertainty(A, Bu, Bu, Bu, c, np.zeros((1, 1)), np.zeros((1, 1)), c)
    d = design(plant)
    assert d.status == "infeasible" and d.K is None and d.gamma is None and d.check is None
    stable = dataclasses.replace(plant, A=np.diag([-1.0, -1.0]))  # mode -1 fixed: Re s < -2 impossible
    assert design(stable, alpha=0.5).status == "optimal"
    assert design(stable, alpha=2.0, beta=10.0).status == "infeasible"


def test_fixed_gain_analysis_and_impulse_bound(plant, designs) -> None:
    d = designs["norm"]
    a = design(plant, d.K, alpha=ALPHA, beta=BETA)
    assert a.status == "optimal" and a.fixed_gain and np.array_equal(a.K, d.K)
    # the design's own certificate is feasible for the analysis: both back-offs, plus solver accuracy
    assert objective(a) <= objective(d) * (1 + a.backoff + d.backoff + BACKOFFS[0])
    b = i2p_bound(plant, d.K, uncertainty="vertex")
    assert b.status == "optimal" and b.gamma is None
    assert b.nu <= d.nu * (1 + b.backoff + d.backoff)  # fewer constraints than the design (measured 0.081)
    deltas = samples(2, seed=4)
    Acl = sampled_loops(plant, d.K, deltas)[0]
    peaks = impulse_to_peak(Acl, plant.B2, plant.C2, 100.0, 2001)
    assert peaks.max() <= b.nu


# ---------------------------------------------------------------------------------------------
# Independent checks reject wrong certificates; bad input


def test_verify_rejects_wrong_certificates(plant, designs) -> None:
    d = designs["norm"]
    kw = {"alpha": ALPHA, "beta": BETA}
    assert certify(plant, d.K, d.Y, d.gamma, d.nu, d.multipliers, **kw).ok
    assert not certify(plant, 3 * d.K, d.Y, d.gamma, d.nu, d.multipliers, **kw).ok  # another gain
    assert not certify(plant, d.K, d.Y, 0.5 * d.gamma, d.nu, d.multipliers, **kw).ok  # level too low
    assert not certify(plant, d.K, d.Y, d.gamma, 0.5 * d.nu, d.multipliers, **kw).ok
    mu = d.multipliers["hinf"]
    bent = dict(d.multipliers, hinf=Multiplier("norm", mu.Q, mu.S + 1e-3 * np.eye(3), mu.R))
    check = certify(plant, d.K, d.Y, d.gamma, d.nu, bent, **kw)
    assert not check.ok and check.structure_error == pytest.approx(2e-3)  # S + S^T on the diagonal


def test_no_program_is_minimized_twice(plant, monkeypatch) -> None:
    """With every certificate rejected, the rescalings and back-offs each minimize a new program
    once (the solver is deterministic: the same program again gives the same answer), and the
    status names every solve made."""
    programs: list[bytes] = []
    minimize, verify_plants = solve_strategy._minimize, certificate._certify_plants

    def counted(plants, K, **options):
        programs.append(np.concatenate([plants[0].A.ravel(), plants[0].Bu.ravel()]).tobytes())
        return minimize(plants, K, **options)

    def rejected(*args, **kwargs):
        return dataclasses.replace(verify_plants(*args, **kwargs), margin=-1.0)

    patch(monkeypatch, "_minimize", counted)
    patch(monkeypatch, "_certify_plants", rejected)
    d = design(plant, alpha=ALPHA, beta=BETA)
    assert d.status == "unverified" and d.K is None
    assert len(programs) == rescaling.RESCALE_DEPTH + 1 == len(set(programs))  # one per coordinates
    # each level: its back-off at 1e-4; the deepest, then each level up: the larger back-offs
    assert d.solver_status.count("back-off 0.0001") == rescaling.RESCALE_DEPTH + 1
    assert d.solver_status.count("back-off 0.01") == rescaling.RESCALE_DEPTH + 1


def test_a_well_scaled_minimizer_tries_the_larger_back_offs_before_rescaling(plant, monkeypatch) -> None:
    """With diag(Y) within RESCALE_SPREAD, a minimizer that fails at back-off 1e-4 and verifies
    at 1e-3 is the answer: no second program (DEMETER row 12: 71 s instead of 226 s); with
    every Y taken as ill-scaled, the rescaled program comes first."""
    found: list = []
    minimize, verify_plants = solve_strategy._minimize, certificate._certify_plants

    def counted(plants, K, **options):
        found.append(minimize(plants, K, **options))
        return found[-1]

    def tight(plants, K, Y, gamma, nu, *args, **kwargs):  # rejects levels below 1 + 5e-4 times the last minimizer's
        check = verify_plants(plants, K, Y, gamma, nu, *args, **kwargs)
        return check if nu > found[-1].nu * (1 + 5e-4) else dataclasses.replace(check, margin=-1.0)

    patch(monkeypatch, "_minimize", counted)
    patch(monkeypatch, "_certify_plants", tight)
    d = design(plant, alpha=ALPHA, beta=BETA)
    diag = np.diag(found[0].Y)
    assert diag.max() / diag.min() < rescaling.RESCALE_SPREAD  # the case under test
    assert d.status == "optimal" and len(found) == 1 and d.backoff == 1e-3
    assert d.solver_status.endswith("the minimizer verified at back-off 0.001")
    found.clear()
    patch(monkeypatch, "RESCALE_SPREAD", 1.0)
    d = design(plant, alpha=ALPHA, beta=BETA)
    # each rescaled minimizer fails at 1e-4 too: the deepest verifies at 1e-3
    assert d.status == "optimal" and len(found) == rescaling.RESCALE_DEPTH + 1 and "rescaled" in d.solver_status


def test_too_many_vertices_is_raised_before_building(plant, monkeypatch) -> None:
    def forbidden(*args, **kwargs):
        raise AssertionError("a program was built")

    patch(monkeypatch, "_minimize", forbidden)
    with pytest.raises(TooManyVerticesError, match=r"2 uncertain parameters give 2\^2 = 4 .* max_vertices = 2"):
        design(plant, uncertainty="vertex", max_vertices=2)
    with pytest.raises(TooManyVerticesError):
        i2p_bound(plant, np.zeros((1, 5)), uncertainty="vertex", max_vertices=3)
    # 13 parameters: 8192 vertices > 4096 (the default)
    n = 1
    one, z = np.ones((1, 1)), np.zeros
    big = LFTPlant(-one, z((n, 13)), one, one, one, z((13, n)), z((13, 13)), z((13, 1)), z((13, 1)), one,
                   z((1, 13)), z((1, 1)), z((1, 1)), one, tuple((f"d{k}", 1) for k in range(13)))
    with pytest.raises(TooManyVerticesError, match="13 uncertain parameters give 2\\^13 = 8192 .* 4096"):
        design(big, uncertainty="vertex")


def test_bad_options_are_rejected(plant) -> None:
    with pytest.raises(PlantDataError, match=r"K must have shape \(1, 5\)"):
        design(plant, np.zeros((5, 1)))
    with pytest.raises(OptionError, match="beta must be finite and > alpha"):
        design(plant, alpha=2.0, beta=1.0)
    with pytest.raises(OptionError, match="alpha must be"):
        design(plant, alpha=-1.0)
    with pytest.raises(OptionError, match="uncertainty must be"):
        design(plant, uncertainty="polytope")
    with pytest.raises(OptionError, match="at least one of w_hinf, w_i2p"):
        design(plant, w_hinf=0.0, w_i2p=0.0)


def test_sector_region_bounds_the_damping(plant, designs) -> None:
    # Without a sector the designs have |Im s| / -Re s up to 1.60 (norm) and 1.84 (vertex) on
    # the samples; a 45 deg sector (damping >= 0.707) is proved and holds on every sample
    # (measured 0.78, 0.88), at a price in the objective (25.5 -> 75.2, 22.8 -> 61.8).
    deltas = samples(plant.n_params, 3)
    for u in ("norm", "vertex"):
        free = np.linalg.eigvals(sampled_loops(plant, designs[u].K, deltas)[0])
        assert (np.abs(free.imag) / -free.real).max() > 1.0  # the sector is active
        d = design(plant, alpha=ALPHA, beta=BETA, sector=np.pi / 4, uncertainty=u)
        assert d.status == "optimal" and d.check.ok and "sector" in d.check.max_eig
        ev = np.linalg.eigvals(sampled_loops(plant, d.K, deltas)[0])
        assert (np.abs(ev.imag) / -ev.real).max() < 1.0 and ev.real.max() < -ALPHA and ev.real.min() > -BETA
        assert objective(d) > objective(designs[u])
    with pytest.raises(OptionError, match="sector"):
        design(plant, sector=np.pi / 2)


def test_many_scenarios_are_solved_by_constraint_generation(plant, monkeypatch) -> None:
    rng = np.random.default_rng(5)
    plants = [plant.at(d) for d in rng.uniform(-1, 1, (260, plant.n_params))]
    solves, cones = [], []
    solve = lmi.LMIProgram.solve

    def counted(self, *a, **k):
        solves.append(1)
        cones.append(len(self._psd))
        return solve(self, *a, **k)

    monkeypatch.setattr(lmi.LMIProgram, "solve", counted)
    gen = design(plants, alpha=ALPHA, beta=BETA)
    # measured: every LMI of 10 plants (hinf, alpha, beta each; 31 with Y and the shared i2p
    # blocks), then the 6 LMIs that bind and 36 violated ones of 25 more plants; the second
    # minimizer verifies on all 260, so two solves in all (the rounds before the last take one
    # each). The second program holds 42 of the 29 plants' 87 robust LMIs: a subset of LMIs, not
    # of plants
    assert gen.status == "optimal" and gen.active_plants <= 50 and len(solves) <= 3
    assert cones[0] == 3 * 10 + 3 and cones[-1] < 3 * gen.active_plants  # + Y and the two i2p blocks
    # the certificate is checked on every plant, not only the active ones
    assert {k.split("/")[0] for k in gen.check.max_eig} == {str(i) for i in range(len(plants))} and gen.check.ok
    patch(monkeypatch, "SCENARIO_BATCH", len(plants))  # the whole program in one solve
    full = design(plants, alpha=ALPHA, beta=BETA)
    assert full.status == "optimal" and full.active_plants is None
    # same optimum: the subset's is a lower bound of the whole program's, and both are reported at
    # optimum x (1 + back-off); the solver's 1e-8 gap leaves ~1e-6 relative on either
    assert gen.solver_objective == pytest.approx(full.solver_objective, rel=1e-5)
    assert gen.gamma == pytest.approx(full.gamma, rel=2e-3) and gen.nu == pytest.approx(full.nu, rel=2e-3)


def test_a_subset_is_judged_on_its_own_lmis(plant, designs) -> None:
    """A program of some LMIs of a plant is judged on those (and Y, the i2p blocks): a gain with a
    failing alpha LMI passes a check of its H-infinity LMI alone, not one that holds alpha."""
    d = designs["norm"]
    bad = certify(plant, d.K, d.Y, d.gamma, d.nu, d.multipliers, alpha=ALPHA + 50.0, beta=BETA)
    assert not bad.ok and bad.max_eig["alpha"].max() > 0 and bad.max_eig["hinf"].max() < 0
    assert certificate._judged_on(bad, frozenset({"hinf", "beta"})).ok
    assert not certificate._judged_on(bad, frozenset({"hinf", "alpha"})).ok
    # the multiplier conditions of a left-out LMI go with it
    assert certificate._judged_on(bad, frozenset({"hinf"})).margin >= bad.margin


def test_scenario_minimizer_is_checked_at_every_back_off(plant, monkeypatch) -> None:
    """When only plants of the subset fail at back-off 1e-4, the minimizer at 1e-3 is checked
    before any back-off solve (DEMETER row 13: 170 to 310 s a solve)."""
    rng = np.random.default_rng(5)
    plants = [plant.at(d) for d in rng.uniform(-1, 1, (120, plant.n_params))]
    found: list = []
    minimize, real_verify = solve_strategy._minimize, certificate.certify

    def counted(subset, K, **options):
        found.append(minimize(subset, K, **options))
        return found[-1]

    def tight(p, K, Y, gamma, nu, *args, **kwargs):  # rejects levels below 1 + 5e-4 times the minimizer's
        check = real_verify(p, K, Y, gamma, nu, *args, **kwargs)
        return check if nu > found[-1].nu * (1 + 5e-4) else dataclasses.replace(check, margin=-1.0)

    patch(monkeypatch, "SCENARIO_FIRST", len(plants))  # every plant in the first subset
    patch(monkeypatch, "_minimize", counted)
    patch(monkeypatch, "certify", tight)
    d = design(plants, alpha=ALPHA, beta=BETA)
    assert d.status == "optimal" and len(found) == 1 and d.backoff == 1e-3 and d.check.ok
    assert d.solver_status.endswith("the minimizer verified at back-off 0.001")
    assert d.nu == pytest.approx(found[0].nu * (1 + 1e-3), rel=1e-12)  # satfmu: the bound is the level


def test_plants_left_out_come_back_when_the_smaller_subset_fails(plant, monkeypatch) -> None:
    """The round after plants are left out (their LMIs do not bind) gives no answer (a solver
    error, as DEMETER row 7's 24-plant subset): they are put back and the next round solves."""
    rng = np.random.default_rng(5)
    plants = [plant.at(d) for d in rng.uniform(-1, 1, (260, plant.n_params))]
    sizes: list[int] = []
    minimize = solve_strategy._minimize

    def failing_second(subset, *a, **k):
        sizes.append(len(subset))
        res = minimize(subset, *a, **k)
        if len(sizes) != 2:
            return res
        return RobustDesign("unverified", None, None, None, None, {}, None, None, uncertainty="norm", n_vertices=0,
                            n_multipliers=0, fixed_gain=False, solver_status="solver error: NumericalError",
                            solve_seconds=0.0, build_seconds=0.0)

    patch(monkeypatch, "_minimize", failing_second)
    gen = design(plants, alpha=ALPHA, beta=BETA)
    # measured (the test above): every LMI of 10 plants (31 with the shared i2p blocks), 6 of
    # them bind, 36 LMIs of 25 more plants join; the failed 42 LMIs of 29 plants become 67 of 35
    # (the 25 left out back)
    assert sizes[:3] == [10, 29, 35] and "42 LMIs of 29 plants: solver error" in gen.solver_status
    assert "the 25 left out put back; 67 LMIs of 35 plants" in gen.solver_status
    assert gen.status == "optimal" and gen.check.ok


def test_an_infeasible_scenario_subset_ends_the_generation(monkeypatch) -> None:
    patch(monkeypatch, "SCENARIO_BATCH", 3)
    patch(monkeypatch, "SCENARIO_FIRST", 3)
    Bu = np.array([[0.0], [1.0]])
    c = np.array([[1.0, 1.0]])
    # the first mode is fixed at a: infeasible with alpha = 0.5 as soon as one plant has a > -0.5
    plants = [LFTPlant.without_uncertainty(np.diag([a, -1.0]), Bu, Bu, Bu, c, np.zeros((1, 1)),
                                           np.zeros((1, 1)), c) for a in np.linspace(-3.0, -0.2, 8)]
    res = design(plants[::-1], alpha=0.5, beta=10.0)
    assert res.status == "infeasible" and res.active_plants == 3 and res.K is None
    assert design(plants[:5], alpha=0.5, beta=10.0).status == "optimal"  # a < -0.5 for these five
