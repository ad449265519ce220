"""Controller artifacts: validation on load, the two law forms, the controller model."""
from __future__ import annotations

import copy
import json
from pathlib import Path

import numpy as np
import pytest

from controllers import artifact, polynomial
from fmus import codegen
from tests.conftest import PUBLISHED


@pytest.fixture()
def raw() -> dict:
    return json.loads(PUBLISHED.read_text())


def test_published_law_matches_eq_38_at_the_200deg_start() -> None:
    # docs/models.md: peak |u_i| = 6.216 N m, reached at t = 0 on u2 (omega = 0, s = s(0)).
    a = artifact.load(PUBLISHED)
    u = a.evaluate(np.array([0, 0, 0, 0.5992, -0.7976, 0.6517]))
    s2 = 0.5992**2 + 0.7976**2 + 0.6517**2
    # eq. 38 by hand: u2 = -3.2208 s2 - 3.2204 s2 |s|^2 (omega = 0); exact arithmetic, rounding only.
    assert u[1] == pytest.approx(-3.2208 * -0.7976 - 3.2204 * -0.7976 * s2, rel=1e-14)
    assert abs(u[1]) == pytest.approx(6.216, abs=5e-4)


def test_gain_times_lyapunov_form_expands_to_the_same_law(raw: dict) -> None:
    # K(x) P x with P = diag(p) and K entries chosen so that K P x reproduces a known polynomial.
    n = 6
    P = np.diag([2.0, 4.0, 1.0, 0.5, 0.25, 8.0])
    K = [[[] for _ in range(n)] for _ in range(3)]
    K[0][0] = [{"c": -1.0, "e": [0] * n}]                                  # -x1 * 2
    K[0][3] = [{"c": 3.0, "e": [0, 0, 0, 0, 2, 0]}]                         # 3 x5^2 * 0.5 x4
    K[1][1] = [{"c": 1.0, "e": [0, 0, 1, 0, 0, 0]}]                         # x3 * 4 x2
    K[2][5] = [{"c": -0.5, "e": [0] * n}]                                   # -0.5 * 8 x6
    raw["law"] = {"form": "gain_times_lyapunov", "K": K, "P": P.tolist()}
    a = artifact.parse(raw)
    x = np.array([0.3, -0.2, 0.7, 0.1, -0.4, 0.9])
    expected = [-2 * x[0] + 1.5 * x[4] ** 2 * x[3], 4 * x[2] * x[1], -4 * x[5]]
    assert a.evaluate(x) == pytest.approx(expected, rel=1e-14)


def test_controller_model_evaluates_like_the_artifact() -> None:
    # Generated code of the controller model == the artifact's own polynomial evaluation.
    a = artifact.load(PUBLISHED)
    m = polynomial.build(a)
    gen = codegen.load_python(m)
    p = m.parameter_vector()
    rng = np.random.default_rng(0)
    for _ in range(20):
        x = rng.normal(size=6)
        assert gen.outputs(0.0, [], list(x), p) == pytest.approx(a.evaluate(x), rel=1e-13, abs=1e-14)
    sat = m.parameter_vector({"saturation_on": 1, "u_max": 0.5})
    x = np.array([0, 0, 0, 0.5992, -0.7976, 0.6517])
    assert gen.outputs(0.0, [], list(x), sat) == pytest.approx(np.clip(a.evaluate(x), -0.5, 0.5), rel=1e-15)


def _mutations() -> list[tuple[str, object, str]]:
    return [
        ("format", "other", "'format' must be"),
        ("format_version", 99, "format_version 99 is not supported"),
        ("kind", "lqr", "'kind' must be"),
        ("name", "Bad Name", "lower_snake_case"),
        ("states", [], "must not be empty"),
        ("certificate", {"status": "maybe", "proved": "", "region": ""}, "'status' must be one of"),
        ("provenance", {}, "missing key 'source'"),
    ]


@pytest.mark.parametrize("key,value,message", _mutations())
def test_corrupt_artifacts_are_rejected_with_the_key_named(raw: dict, key: str, value: object, message: str) -> None:
    bad = copy.deepcopy(raw)
    bad[key] = value
    with pytest.raises(artifact.ArtifactError, match=message):
        artifact.parse(bad)


def test_corrupt_terms_are_rejected(raw: dict) -> None:
    cases = [
        (lambda d: d["law"]["terms"][0][0].update(c=float("nan")), r"terms\[0\]\[0\]\.c: must be a finite number"),
        (lambda d: d["law"]["terms"][0][0].update(e=[1, 0]), "6 exponents"),
        (lambda d: d["law"]["terms"][1][2].update(e=[0, 0, 0, -1, 0, 0]), "non-negative integers"),
        (lambda d: d["law"]["terms"].pop(), "2 polynomials for 3 outputs"),
        (lambda d: d["law"].update(form="magic"), "'form' must be"),
        (lambda d: d["lyapunov"].update(Q=[[1.0]]), r"lyapunov\.Q: shape"),
        (lambda d: d["lyapunov"].update(Q=(-np.eye(6)).tolist()), "positive definite"),
    ]
    for mutate, message in cases:
        bad = copy.deepcopy(raw)
        mutate(bad)
        with pytest.raises(artifact.ArtifactError, match=message):
            artifact.parse(bad)


def test_l2_gain_record_is_validated(raw: dict) -> None:
    good = {"c": 0.3, "kv": 12.0, "region": "|sigma| <= 0.9"}
    cases = [({**good, "c": float("inf")}, r"l2_gain\.c: must be a finite number"),
             ({**good, "kv": -1.0}, r"l2_gain\.kv: must be > 0"),
             ({k: v for k, v in good.items() if k != "region"}, "missing key 'region'"),
             ("0.3", "l2_gain")]
    ok = copy.deepcopy(raw)
    ok["certificate"]["l2_gain"] = good
    assert artifact.parse(ok).certificate["l2_gain"]["c"] == 0.3
    for value, message in cases:
        bad = copy.deepcopy(raw)
        bad["certificate"]["l2_gain"] = value
        with pytest.raises(artifact.ArtifactError, match=message):
            artifact.parse(bad)


def test_shipped_synthesized_artifact_states_its_proof_and_region() -> None:
    a = artifact.load(polynomial.ARTIFACTS / "mrp_hinf_satfmu.json")
    cert = a.certificate
    assert cert["status"] == "certified" and cert["region"] == "|sigma| <= 0.9"
    assert cert["proved"].startswith("strict on |sigma| <= 0.9") and "V" in cert["proved"]
    assert cert["l2_gain"]["region"] == "|omega_i| <= 0.2 rad/s, |sigma| <= 0.9"
    # the sampled lower bound never exceeds the certified upper bound
    assert cert["l2_gain"]["sampled_c"] <= cert["l2_gain"]["c"] * (1 + 1e-9)
    # every recorded Gram matrix is PSD to solver accuracy (verify()'s tolerance, scale ~1)
    assert min(v for k, v in cert["numbers"].items() if k.endswith("min_eig")) > -1e-6
    assert len(a.provenance["iterations"]) >= 2


def test_unreadable_files(tmp_path: Path) -> None:
    with pytest.raises(artifact.ArtifactError, match="cannot read artifact"):
        artifact.load(tmp_path / "missing.json")
    broken = tmp_path / "broken.json"
    broken.write_text('{"format": "satfmu-controller", ')
    with pytest.raises(artifact.ArtifactError, match="not valid JSON"):
        artifact.load(broken)


def test_save_round_trip_and_refuses_invalid(tmp_path: Path) -> None:
    a = artifact.load(PUBLISHED)
    artifact.save(a, tmp_path / "a.json")
    b = artifact.load(tmp_path / "a.json")
    assert b.terms == a.terms and b.certificate == a.certificate
    a.certificate = {"status": "proved-by-vibes", "proved": "", "region": ""}
    with pytest.raises(artifact.ArtifactError):
        artifact.save(a, tmp_path / "bad.json")
    assert not (tmp_path / "bad.json").exists()
