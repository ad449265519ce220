"""Gain approximation of the SDRE servo (seed 002 section 3.2), the LQ baseline, the servo controller model."""
from __future__ import annotations

import numpy as np
import pytest

from satfmu.controllers import artifact, servo
from satfmu.fmus import codegen
from satfmu.synthesis.servo import gain_fit, sdre


@pytest.fixture(scope="module")
def approx() -> tuple[gain_fit.GainFit, artifact.ServoArtifact]:
    s = sdre.Servo("w1_free", freeze_w2=True)
    result = gain_fit.fit(*gain_fit.sdre_grid(s, n_q2=12, n_w4=13), degrees=range(1, 7))
    return result, artifact.parse(gain_fit.approximated_sdre_data(result, s, gain_fit.certify(result, s)))


def test_fit_accuracy_improves_with_degree_and_the_artifact_evaluates_the_fit(approx) -> None:
    result, art = approx
    cv = [result.cv_errors[d] for d in sorted(result.cv_errors)]
    assert all(b < a for a, b in zip(cv, cv[1:]))  # smooth gains: every degree helps
    # The degree is the smallest within CV_TOL; the grid error is then ~7x the CV error
    # (the shipped 23 x 25, degree-4 fit: CV 1.4e-3, grid max 1.0e-2).
    assert result.cv_errors[result.degree] <= gain_fit.CV_TOL
    assert all(result.cv_errors[d] > gain_fit.CV_TOL for d in result.cv_errors if d < result.degree)
    assert result.max_rel_error < gain_fit.OFFGRID_TOL
    # The artifact's polynomials are the fit (JSON round trip at 17 digits: rounding only).
    pts = result.points
    assert np.max(np.abs(art.gain_at(pts) - result.evaluate(pts))) < 1e-9


def test_servo_controller_model_computes_minus_K_xe(approx) -> None:
    _, art = approx
    model = servo.build(art)
    gen = codegen.load_python(model)
    names = [v.name for v in model.inputs]
    u = dict(q2=0.7, q4=0.2, q2_ref=0.75, q4_ref=0.25, w1=1.5, w2=-0.1, w4=0.3)
    y = gen.outputs(0.0, [0.01, -0.02], [u[n] for n in names], model.parameter_vector().tolist())
    xe = np.array([0.01, -0.02, 0.05, 0.05, 1.5, -0.1, 0.3])
    K = art.gain_at(art.scheduling_values({"q2": 0.7, "w4": 0.3}))
    assert art.scheduling == ["sin(q2)", "w4"]
    assert np.array_equal(K, art.gain_at(np.array([np.sin(0.7), 0.3])))
    assert np.allclose(y[:2], -K @ xe, rtol=1e-12, atol=1e-14)
    assert y[2:] == pytest.approx([0.05, 0.05], abs=1e-15)  # the tracking errors


def test_lq_servo_is_the_checked_gain_at_the_start_state() -> None:
    x0 = np.array([0.0, np.pi / 18, 0.0, 0.0, 0.0, 0.0])
    s = sdre.Servo("gyro_on_w2")
    art = artifact.parse(gain_fit.lq_data(s, x0))
    assert np.allclose(art.gain_at(np.array([1.0, 0.5])), s.gain(x0)[0], rtol=0, atol=0)
    assert art.certificate["numbers"]["riccati_residual"] < 1e-8


def test_fit_rejects_bad_shapes_and_too_small_grids() -> None:
    with pytest.raises(ValueError, match="points must be"):
        gain_fit.fit(np.zeros((10, 3)), np.zeros((10, 2, 7)))
    with pytest.raises(ValueError, match="too few for degree"):
        gain_fit.fit(np.random.default_rng(0).normal(size=(10, 2)), np.zeros((10, 2, 7)), degrees=range(1, 5))


def test_verification_measures_the_fit_and_rejects_a_wrong_gain(approx) -> None:
    result, art = approx
    numbers = art.certificate["numbers"]
    assert art.certificate["status"] == "sampled"
    # Off the grid the fit of a 12 x 13 grid stays within OFFGRID_TOL of the SDRE (the
    # shipped 23 x 25, degree-4 fit: 1.0e-2); the frozen loop keeps only the p4 mode at 0.
    assert numbers["offgrid_max_rel_error"] < gain_fit.OFFGRID_TOL
    assert numbers["frozen_max_re"] < 1e-6
    assert abs(numbers["sim_e4_final"]) < 1e-4  # issue 11 bound, frictionless
    import dataclasses

    flipped = dataclasses.replace(result, coefficients=-result.coefficients)  # positive feedback
    with pytest.raises(gain_fit.FitCertificationError, match="frozen_max_re = .* exceeds 1e-06"):
        gain_fit.certify(flipped, sdre.Servo("w1_free", freeze_w2=True))


def test_scheduling_entries_are_parsed_and_bad_ones_rejected(approx) -> None:
    _, art = approx
    assert artifact.scheduling_signal("sin(q2)") == ("sin", "q2")
    assert artifact.scheduling_signal("w4") == (None, "w4")
    data = art.to_json()
    for bad, match in (("tan(q2)", "must be a signal name"), ("sin(q3)", "'q3' is not a tracked or rate"),
                       ("sin(q2", "must be a signal name")):
        with pytest.raises(artifact.ArtifactError, match=match):
            artifact.parse({**data, "scheduling": [bad, "w4"]})
    with pytest.raises(KeyError):
        art.scheduling_values({"w4": 0.1})
