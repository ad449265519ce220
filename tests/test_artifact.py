"""Controller artifacts: validation on load, the two law forms, the controller model."""
from __future__ import annotations

import copy
import inspect
import json
import time
from pathlib import Path

import numpy as np
import pytest

from satfmu.controllers import artifact, claims, polynomial, riccati
from satfmu.fmus import codegen
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


def _shipped(name: str) -> dict:
    return json.loads((polynomial.ARTIFACTS / f"{name}.json").read_text())


def _set(data: dict, path: tuple, value: object) -> None:
    for key in path[:-1]:
        data = data[key]
    data[path[-1]] = value


def _scaled_entry(path: tuple, factor: float):
    def mutate(data: dict) -> None:
        target = data
        for key in path[:-1]:
            target = target[key]
        target[path[-1]] *= factor
    return mutate


def _numbers(key: str, value: float):
    return lambda d: _set(d, ("certificate", "numbers", key), value)


DOCTORED = [
    # (artifact, what is doctored, mutation, message) for every kind: the claim each number supports
    ("mrp_hinf_satfmu", "SOS min eigenvalue -1", _numbers("-M - E: min_eig", -1.0),
     r"numbers\['-M - E: min_eig'\] = -1: status 'certified' needs >= -1e-06"),
    ("mrp_hinf_satfmu", "SOS residual 10", _numbers("-M - E: residual", 10.0),
     r"numbers\['-M - E: residual'\] = 10: status 'certified' needs <= 1e-06"),
    ("mrp_hinf_satfmu", "L2-gain SOS min eigenvalue -1",
     lambda d: _set(d, ("certificate", "l2_gain", "checks", "a - z/kv - beta b on region: min_eig"), -1.0),
     r"l2_gain\.checks\['a - z/kv - beta b on region: min_eig'\] = -1"),
    ("mrp_hinf_satfmu", "sampled L2 gain above the certified one",
     lambda d: _set(d, ("certificate", "l2_gain", "sampled_c"), 0.5), r"l2_gain\.sampled_c = 0\.5: a sampled lower"),
    ("mrp_hinf_satfmu", "law P no longer Q^-1", _scaled_entry(("law", "P", 3, 3), 1.5), r"law\.P: not the inverse"),
    ("mrp_h2hinf_satfmu", "psd_margin -1", _numbers("psd_margin", -1.0), r"numbers\['psd_margin'\] = -1"),
    ("mrp_h2hinf_satfmu", "Xinf with a negative eigenvalue (recomputed)",
     lambda d: _set(d, ("certificate", "Xinf"), (-np.eye(6)).tolist()),
     r"certificate\.Xinf: recomputed smallest eigenvalue of Xinf -1: status 'certified' needs >= -1e-09"),
    ("mrp_h2hinf_satfmu", "lambda below the H2 level (recomputed)", _scaled_entry(("certificate", "h2", "lambda"), 0.5),
     r"h2\.lambda: recomputed smallest eigenvalue of \[\[lambda, x0\^T\], \[x0, X2\]\] .* -0\.0\d+: status"),
    ("vscmg_lq_servo", "Riccati residual 10", _numbers("riccati_residual", 10.0),
     r"numbers\['riccati_residual'\] = 10: status 'certified' needs <= 1e-08"),
    ("vscmg_lq_servo", "shifted closed loop unstable", _numbers("max_re_shifted", 1.5), r"max_re_shifted'\] = 1\.5"),
    ("vscmg_sdre_approx", "Lyapunov eigenvalue 1.5 on the samples", _numbers("region_trig_max_lyapunov_eig", 1.5),
     r"region_trig_max_lyapunov_eig'\] = 1\.5: status 'certified' needs < 0"),
    ("vscmg_sdre_approx", "sampled decay slower than proved", _numbers("region_trig_max_re_off_p4", -0.1),
     r"region_trig_max_re_off_p4'\] = -0\.1: status 'certified' needs <= -region_trig_decay_bound = -0\.14746"),
    ("cubesat_periodic_satfmu", "spectral radius 1.5", _numbers("ms_spectral_radius", 1.5),
     r"numbers\['ms_spectral_radius'\] = 1\.5: status 'certified' needs < 1 \(mean-square stability"),
    ("cubesat_periodic_published", "min eigenvalue of Y(k) -1", _numbers("min_y_eig", -1.0), r"min_y_eig'\] = -1"),
    ("cubesat_periodic_satfmu", "no numbers at all", lambda d: _set(d, ("certificate", "numbers"), {}),
     "status 'certified' but none of the numbers that support it is recorded"),
    ("demeter_row1_det", "design.K changed", _scaled_entry(("design", "K", 0, 2), 1.5),
     r"design\.K and gains disagree \(largest difference 1625\.58 at K_eta\[1,1\]: gains 3251\.16, "
     r"design\.K gives 4876\.75"),
    ("demeter_row1_det", "a gain changed", lambda d: _set(d, ("gains", "K_xi[1,1]"), 0.0),
     r"largest difference 0\.000129859 at K_xi\[1,1\]: gains 0, design\.K gives -0\.000129859"),
    ("demeter_row1_det", "design states reordered", lambda d: d["design"]["states"].reverse(),
     r"design\.states: .* are not the variant's design states"),
    ("demeter_row1_det", "coupling L not recorded",
     lambda d: d["provenance"]["design_plant"]["parameters"].pop("L[1,2]"),
     r"lacks the coupling L\[1,2\] the design used"),
    ("demeter_row1_det", "sampled pole 1.5", _numbers("sampled_max_real_pole", 1.5),
     r"sampled_max_real_pole'\] = 1\.5"),
    ("demeter_row1_det", "sampled H-infinity norm above the proved bound", _numbers("sampled_max_hinf", 100.0),
     r"sampled_max_hinf'\] = 100: above the bound analysis_hinf_pdlf = 83\.2965"),
]


def test_every_shipped_artifact_loads_and_its_claims_cost_under_a_millisecond() -> None:
    files = polynomial.shipped_artifacts()
    assert len(files) == 8
    for f in files:
        artifact.load(f)
        data = json.loads(f.read_text())
        start = time.perf_counter()
        for _ in range(10):
            assert claims.problems(data) == []
        # the re-check's budget is 50 ms per artifact; measured 0.01-0.4 ms (DEMETER's gain map)
        assert (time.perf_counter() - start) / 10 < 0.05, f.name


@pytest.mark.parametrize("name,what,mutate,message", DOCTORED, ids=[f"{d[0]}: {d[1]}" for d in DOCTORED])
def test_an_artifact_whose_numbers_contradict_its_claims_is_refused(tmp_path: Path, name: str, what: str,
                                                                     mutate, message: str) -> None:
    data = _shipped(name)
    mutate(data)
    f = tmp_path / f"{name}.json"
    f.write_text(json.dumps(data))
    with pytest.raises(artifact.ArtifactError, match=message) as err:
        artifact.load(f)
    assert str(err.value).startswith(f"{f}: ") and "\n" not in str(err.value)  # the file, one line


def test_what_each_status_claims() -> None:
    # not_verified claims nothing: failing numbers are allowed (hinf_sos records a failed check so)
    data = _shipped("mrp_hinf_satfmu")
    data["certificate"]["status"] = "not_verified"
    data["certificate"]["numbers"]["-M - E: min_eig"] = -1.0
    assert artifact.parse(data).certificate["status"] == "not_verified"
    # sampled claims the sampled checks only: the SOS region's numbers may fail (gain_fit keeps
    # status sampled when the region is not certified), the frozen closed loop may not
    data = _shipped("vscmg_sdre_approx")
    data["certificate"]["status"] = "sampled"
    data["certificate"]["numbers"]["region_trig_max_lyapunov_eig"] = 1.5
    assert artifact.parse(data).certificate["status"] == "sampled"
    data["certificate"]["numbers"]["frozen_max_re"] = 1.5
    with pytest.raises(artifact.ArtifactError, match=r"frozen_max_re'\] = 1\.5: status 'sampled' needs <= 1e-06"):
        artifact.parse(data)
    # a gain held twice must agree whatever the status
    data = _shipped("demeter_row1_det")
    data["certificate"]["status"] = "not_verified"
    data["design"]["K"][0][0] = 0.0
    with pytest.raises(artifact.ArtifactError, match=r"at K_theta\[1,1\]"):
        artifact.parse(data)


def test_design_gains_agree_to_rounding_not_bitwise() -> None:
    # another machine may round K_eta = K_r Q otherwise: a few ulps pass, GAIN_RTOL (1e-9) more do not
    data = _shipped("demeter_row1_det")
    g = data["gains"]["K_eta[1,1]"]
    data["gains"]["K_eta[1,1]"] = float(np.nextafter(np.nextafter(g, np.inf), np.inf))
    artifact.parse(data)
    data["gains"]["K_eta[1,1]"] = g * (1 + 1e-8)
    with pytest.raises(artifact.ArtifactError, match=r"at K_eta\[1,1\]"):
        artifact.parse(data)


def test_claim_tolerances_are_the_verifiers_own() -> None:
    # one source: the Riccati bounds are riccati_gain's defaults
    defaults = inspect.signature(riccati.riccati_gain).parameters
    assert claims.RICCATI_RES_TOL == defaults["residual_tol"].default
    assert claims.MAX_RE_TOL == defaults["max_re_tol"].default


def test_an_exponent_beyond_any_controller_degree_is_refused() -> None:
    """10**30 is a valid JSON integer; it once passed validation and failed in gcc."""
    import json

    from satfmu.controllers import artifact as controllers_artifact
    from satfmu.controllers import paths

    data = json.loads((paths.SHIPPED_ARTIFACTS / "mrp_hinf_published.json").read_text())
    data["law"]["terms"][0][0]["e"][0] = 10 ** 30
    with pytest.raises(controllers_artifact.ArtifactError,
                       match=r"law\.terms\[0\]\[0\]: exponent 10+ is larger than 64"):
        controllers_artifact.parse(data)
