"""The symbolic model definition and what is generated from it."""
from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from satfmu.fmus import codegen
from satfmu.fmus.plants import mrp_satellite
from satfmu.fmus.description import fmu_guid
from satfmu.fmus.model import Model, ModelDefinitionError, Output, Variable, states, symbols

MODEL = mrp_satellite.MODEL


def test_sdc_form_is_exact_symbolically() -> None:
    # A(x) x + B [u; w_d] - f(x, u) simplifies to exactly zero with saturation off.
    assert MODEL.sdc_residual_symbolic() == sp.zeros(6, 1)


def test_sdc_form_matches_rhs_at_random_points() -> None:
    # Same identity numerically: only rounding remains (states and inputs ~ N(0, 2^2)).
    assert MODEL.sdc_residual_sampled(n_points=300, scale=2.0, seed=1) < 1e-12


def test_sdc_rows_are_the_papers_eq_35_37() -> None:
    # Row 1 of A: (Iy - Iz)/Ix * x3 in column 2 (seed 000 eq. 36), B = [diag(1/I); 0].
    A, B = MODEL.sdc_functions()
    p = MODEL.parameter_defaults()
    x = np.array([0.1, -0.2, 0.3, 0.4, 0.5, -0.6])
    a = np.asarray(A(x, p), float)
    assert a[0, 1] == pytest.approx((16 - 12.5) / 15 * 0.3, rel=1e-15)
    assert a[1, 2] == pytest.approx((12.5 - 15) / 16 * 0.1, rel=1e-15)
    assert a[2, 0] == pytest.approx((15 - 16) / 12.5 * -0.2, rel=1e-15)
    b = np.asarray(B(x, p), float)
    assert np.allclose(b[:3, :3], np.diag([1 / 15, 1 / 16, 1 / 12.5]), rtol=0, atol=1e-15)
    assert not b[3:].any()


def test_generated_python_equals_lambdified_rhs() -> None:
    # Two independent printers of the same expressions agree to rounding.
    gen = codegen.load_python(MODEL)
    f = MODEL.lambdify(MODEL.rhs)
    rng = np.random.default_rng(3)
    p = MODEL.parameter_vector({"saturation_on": 1, "u_max": 0.7})
    for _ in range(50):
        x, u = rng.normal(size=6), rng.normal(size=6)
        assert np.allclose(gen.derivatives(0.0, x, x, u, p), np.ravel(f(0.0, x, u, p)), rtol=1e-13, atol=1e-14)


def test_saturation_clips_the_applied_torque() -> None:
    # With saturation on, a 10 N m command acts as u_max = 5 N m: omega1' = 5 / Ix at rest.
    gen = codegen.load_python(MODEL)
    p = MODEL.parameter_vector({"saturation_on": 1})
    dx = gen.derivatives(0.0, [0.0] * 6, [0.0] * 6, [10.0, -10.0, 1.0, 0.0, 0.0, 0.0], p)
    assert dx[:3] == pytest.approx([5 / 15, -5 / 16, 1 / 12.5], rel=1e-15)


def test_shadow_set_switching_only_when_enabled_and_outside_unit_ball() -> None:
    gen = codegen.load_python(MODEL)
    s = [0.0, 0.0, 0.0, 0.6, -0.8, 0.65]
    off = MODEL.parameter_vector()
    on = MODEL.parameter_vector({"shadow_switching": 1})
    assert gen.post_step(0.0, s, s, [0.0] * 6, off) == s  # default off: the seed's runs are unswitched
    n2 = 0.6**2 + 0.8**2 + 0.65**2
    assert gen.post_step(0.0, s, s, [0.0] * 6, on)[3:] == pytest.approx([-0.6 / n2, 0.8 / n2, -0.65 / n2], rel=1e-15)
    inside = [0.0, 0.0, 0.0, 0.1, 0.2, 0.3]
    assert gen.post_step(0.0, inside, inside, [0.0] * 6, on) == inside
    assert gen.post_step(0.0, [0.0] * 6, [0.0] * 6, [0.0] * 6, on) == [0.0] * 6  # |s| = 0: no division by zero


def test_mrp_from_axis_angle_reproduces_the_seeds_initial_attitude() -> None:
    # The seed prints s(0) = [0.5992, -0.7976, 0.6517] for 200 deg about k (4 digits).
    s = mrp_satellite.mrp_from_axis_angle(np.array([0.5028, -0.6693, 0.5469]), np.radians(200))
    assert s == pytest.approx([0.5992, -0.7976, 0.6517], abs=2e-4)
    with pytest.raises(ValueError, match="axis"):
        mrp_satellite.mrp_from_axis_angle(np.zeros(3), 1.0)


def test_parameter_vector_rejects_unknown_names() -> None:
    with pytest.raises(KeyError, match="I_q"):
        MODEL.parameter_vector({"I_q": 1.0})


def _tiny(**kw: object) -> Model:
    x = states("x", 1, "1", "state")
    base = dict(name="tiny", description="d", states=x, inputs=[], parameters=[],
                outputs=[Output(x[0].variable, x[0].symbol)], rhs=sp.Matrix([-symbols(x)[0]]))
    base.update(kw)
    return Model(**base)  # type: ignore[arg-type]


def test_model_definition_errors_are_specific() -> None:
    assert _tiny().name == "tiny"
    with pytest.raises(ModelDefinitionError, match="unknown unit 'furlong'"):
        _tiny(parameters=[Variable("k", "furlong")])
    with pytest.raises(ModelDefinitionError, match="undeclared symbols"):
        _tiny(rhs=sp.Matrix([sp.Symbol("z", real=True)]))
    with pytest.raises(ModelDefinitionError, match="duplicate"):
        _tiny(parameters=[Variable("k"), Variable("k")])
    with pytest.raises(ModelDefinitionError, match="invalid variable name"):
        _tiny(parameters=[Variable("bad name")])
    with pytest.raises(ModelDefinitionError, match="shape"):
        _tiny(rhs=sp.Matrix([1, 2]))


def test_guid_changes_with_the_equations_and_is_stable() -> None:
    for backend in ("native", "python"):
        assert fmu_guid(MODEL, backend) == fmu_guid(mrp_satellite.build(), backend), \
            f"{backend}: a new object of the same model must have the same GUID"
        assert fmu_guid(MODEL, backend) != fmu_guid(mrp_satellite.build(omega_0=(0.1, 0, 0)), backend), \
            f"{backend}: another default initial rate must change the GUID"
