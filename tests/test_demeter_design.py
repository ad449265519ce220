"""Seed 004 deterministic design on the DEMETER design model (in progress: the nominal design)."""
from __future__ import annotations

import numpy as np

from synthesis import demeter_design as dd
from synthesis import demeter_variants as dv
from synthesis import robust_lmi as rl

ROW1 = dv.Variant((1,), (1,), 1, 1)


def nominal_plant(dm: dv.DesignModel, T: np.ndarray) -> rl.LFTPlant:
    P = dd.scaled_lft(dm, T)
    return rl.LFTPlant.without_uncertainty(A=P.A, Bu=P.Bu, B1=P.B1, B2=P.B2, C1=P.C1, D1u=P.D1u, D11=P.D11, C2=P.C2)


def test_shared_lyapunov_matrix_bounds_the_product_of_the_two_levels() -> None:
    # With our wiring (w1 a body torque, z1 = theta, z2 the pseudo-integrator xw) one Lyapunov
    # matrix for both specs gives gamma * nu = 1 / (2 a) = 500 at the optimum for both weightings
    # (MODELS.md's independent model measured gamma 223.6 for the seed's weights): far from the
    # seed's 22.3 * 4.7, so the seed wires or scales w1/z2 differently. Nominal row-1 model:
    dm = dv.design_model(ROW1)
    T = dd.state_scale(dm)
    A, Bu, _ = dm.state_space(np.zeros(3))
    for w_i2p, gamma_ref in ((100.0, 223.6), (1.0, 22.37)):
        des = rl.design(nominal_plant(dm, T), w_hinf=1.0, w_i2p=w_i2p, alpha=dd.ALPHA, beta=dd.BETA)
        assert des.status == "optimal" and des.check.ok
        # 2e-3: the solver's accuracy on this poorly conditioned program plus the 1e-4 back-off
        assert des.gamma * des.nu >= 500.0 * (1 - 2e-3)
        assert abs(des.gamma - gamma_ref) < 2e-3 * gamma_ref
        K = des.K / T
        Acl = A + Bu @ K
        assert np.linalg.eigvals(Acl).real.max() < -dd.ALPHA and np.linalg.eigvals(Acl).real.min() > -dd.BETA
        _, _, B1 = dm.state_space(np.zeros(3))
        assert rl.hinf_norm(Acl, B1, dm.C1, np.zeros((1, 1))) <= des.gamma
        assert rl.impulse_to_peak(Acl, dm.B2, dm.C2, 3000.0, 3001) <= des.nu
