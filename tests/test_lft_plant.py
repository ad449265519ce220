"""The uncertain plant forms of the robust LMIs: the LFT and the affine descriptor are the same
plant, and bad plant data is refused."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from satfmu.synthesis.robust.lft_plant import AffineDescriptor, DeltaError, LFTPlant, PlantDataError, box_vertices
from tests.robust_plants import A_M, B_K, K0, M0, descriptor_plant, lft_plant, scalar_plant


def test_lft_and_descriptor_are_the_same_plant() -> None:
    plant = lft_plant()
    by_hand, converted = descriptor_plant(), AffineDescriptor.from_lft(plant)
    for d in np.random.default_rng(1).uniform(-1, 1, (20, 2)).tolist() + box_vertices(2).tolist():
        A, Bu, B1, *_ = plant.evaluate(d)
        for desc in (by_hand, converted):
            A2, Bu2, B12 = desc.state_space(d)
            # two different eliminations of the same equations: rounding of order-one numbers
            assert max(np.abs(A - A2).max(), np.abs(Bu - Bu2).max(), np.abs(B1 - B12).max()) < 1e-12
        m = M0 * (1 + A_M * d[0])
        assert Bu[2, 0] == pytest.approx(1 / m, rel=1e-14) and A[3, 1] == pytest.approx(-K0 * (1 + B_K * d[1]) / m)
    assert all(np.array_equal(a, b) for a, b in zip(plant.nominal(), plant.evaluate([0.0, 0.0])))


def test_bad_plant_data_is_rejected() -> None:
    plant = lft_plant()
    fields = {f.name: getattr(plant, f.name) for f in dataclasses.fields(plant)}
    nan = plant.A.copy()
    nan[1, 2] = np.nan
    with pytest.raises(PlantDataError, match="A has non-finite"):
        LFTPlant(**dict(fields, A=nan))
    with pytest.raises(PlantDataError, match=r"Bp must have shape \(5, 3\)"):
        LFTPlant(**dict(fields, Bp=plant.Bp[:4]))
    with pytest.raises(PlantDataError, match="must be a 2-D array"):
        LFTPlant(**dict(fields, C2=plant.C2[0]))
    with pytest.raises(PlantDataError, match="sum to 2, Cq has 3 rows"):
        LFTPlant(**dict(fields, blocks=(("mass", 1), ("stiffness", 1))))
    with pytest.raises(PlantDataError, match="unique"):
        LFTPlant(**dict(fields, blocks=(("mass", 2), ("mass", 1))))
    with pytest.raises(DeltaError, match=r"\[-1, 1\]"):
        plant.evaluate([1.2, 0.0])
    with pytest.raises(DeltaError, match="shape"):
        plant.evaluate([0.0])
    with pytest.raises(DeltaError, match="non-finite"):
        descriptor_plant().state_space([np.nan, 0.0])
    with pytest.raises(DeltaError, match="ill posed"):  # 1 - 2 delta = 0 at delta = 0.5
        scalar_plant(1.0, 2.0).evaluate([0.5])
    with pytest.raises(PlantDataError, match="K has non-finite"):
        plant.closed_loop(np.full((1, 5), np.inf), [0.0, 0.0])
    desc = descriptor_plant()
    with pytest.raises(PlantDataError, match="Nk must have shape"):
        AffineDescriptor(desc.N0, desc.Nk[:, :, :-1], 5, 1, 1, 1, desc.C1, desc.D1u, desc.D11, desc.names)
    with pytest.raises(PlantDataError, match="names must be 2 distinct"):
        AffineDescriptor(desc.N0, desc.Nk, 5, 1, 1, 1, desc.C1, desc.D1u, desc.D11, ("mass",))
    with pytest.raises(PlantDataError, match="D1p = 0"):
        AffineDescriptor.from_lft(LFTPlant(**dict(fields, D1p=np.ones((2, 3)))))
