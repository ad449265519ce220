"""The uncertain test plants of the robust LMI tests (test_lft_plant, test_robust_design, test_pdlf).

Two masses m (uncertain, the same for both: a block repeated twice) joined by a spring k
(uncertain), force u on mass 1, disturbance force w1 on mass 2, and the integral of x2.
m = M0 (1 + A_M delta_m), k = K0 (1 + B_K delta_k). States (x1, x2, v1, v2, xi).
"""
from __future__ import annotations

import numpy as np

from satfmu.synthesis.robust.lft_plant import AffineDescriptor, LFTPlant, box_vertices

M0, K0, A_M, B_K, RHO = 1.0, 1.0, 0.2, 0.5, 0.1
ALPHA, BETA = 0.05, 20.0
"""The pole region of the designs, 1/s."""
N_SAMPLES = 200


def lft_plant() -> LFTPlant:
    """The plant as an LFT: acc_i = y_i / (1 + A_M delta_m) is q_i = y_i - A_M p_i, acc_i = q_i."""
    n = 5
    A = np.zeros((n, n))
    A[0, 2] = A[1, 3] = A[4, 1] = 1
    A[2, :2] = [-K0 / M0, K0 / M0]
    A[3, :2] = [K0 / M0, -K0 / M0]
    Bp = np.zeros((n, 3))
    Bp[2] = [-A_M, 0, -K0 * B_K / M0]
    Bp[3] = [0, -A_M, K0 * B_K / M0]
    Bu, B1, B2 = np.zeros((n, 1)), np.zeros((n, 1)), np.zeros((n, 2))
    Bu[2, 0] = B1[3, 0] = 1 / M0
    B2[2, 0] = B2[3, 1] = 0.1  # impulses on the velocities (0.1 m/s)
    Cq = np.vstack([A[2], A[3], [1, -1, 0, 0, 0]])
    Dqp = np.vstack([Bp[2], Bp[3], np.zeros(3)])
    Dqu, Dq1 = np.array([[1 / M0], [0], [0]]), np.array([[0], [1 / M0], [0]])
    C1 = np.array([[0, 1, 0, 0, 0], [0, 0, 0, 0, 0.0]])
    D1u = np.array([[0], [RHO]])
    C2 = np.array([[0, 1, 0, 0, 0.0]])
    return LFTPlant(A, Bp, Bu, B1, B2, Cq, Dqp, Dqu, Dq1, C1, np.zeros((2, 3)), D1u, np.zeros((2, 1)), C2,
                       (("mass", 2), ("stiffness", 1)))


def descriptor_plant() -> AffineDescriptor:
    """The same plant written directly, affine in delta: m(delta) v' = forces, v = k(delta)(x1 - x2)."""
    n, nv = 5, 1
    xd, x, v, u, w = 0, n, 2 * n, 2 * n + nv, 2 * n + nv + 1
    N0, Nk = np.zeros((n + nv, w + 1)), np.zeros((2, n + nv, w + 1))
    N0[0, [xd + 0, x + 2]] = [1, -1]  # x1' = v1
    N0[1, [xd + 1, x + 3]] = [1, -1]  # x2' = v2
    N0[2, [xd + 2, v, u]] = [M0, 1, -1]  # m v1' = -k (x1 - x2) + u
    Nk[0, 2, xd + 2] = M0 * A_M
    N0[3, [xd + 3, v, w]] = [M0, -1, -1]  # m v2' = k (x1 - x2) + w1
    Nk[0, 3, xd + 3] = M0 * A_M
    N0[4, [xd + 4, x + 1]] = [1, -1]  # xi' = x2
    N0[5, [v, x + 0, x + 1]] = [1, -K0, K0]  # v = k (x1 - x2)
    Nk[1, 5, [x + 0, x + 1]] = [-K0 * B_K, K0 * B_K]
    C1 = np.array([[0, 1, 0, 0, 0], [0, 0, 0, 0, 0.0]])
    return AffineDescriptor(N0, Nk, n, nv, 1, 1, C1, np.array([[0], [RHO]]), np.zeros((2, 1)),
                               ("mass", "stiffness"))


def samples(n_params: int, seed: int = 0) -> np.ndarray:
    """N_SAMPLES points of the box, its vertices first."""
    d = np.random.default_rng(seed).uniform(-1, 1, (N_SAMPLES, n_params))
    d[:2**n_params] = box_vertices(n_params)
    return d


def sampled_loops(plant: LFTPlant, K: np.ndarray, deltas: np.ndarray) -> tuple[np.ndarray, ...]:
    """Stacks (A_cl, B1, C1_cl, D11) at the deltas."""
    return tuple(np.stack(a) for a in zip(*(plant.closed_loop(K, d) for d in deltas)))


def scalar_plant(a: float, d: float) -> LFTPlant:
    """x' = (-1 + a delta / (1 - d delta)) x: one real scalar, an offset image of the box."""
    one, zero = np.ones((1, 1)), np.zeros((1, 1))
    return LFTPlant(-one, a * one, one, one, one, one, d * one, zero, zero, one, zero, zero, zero, one,
                       (("k", 1),))
