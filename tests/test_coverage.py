"""What a certificate covers: an artifact's ``certificate.domain`` (satfmu.controllers.domain) and
the samples of a scenario or a campaign that start outside it (satfmu.sims.scenario.coverage).

The expected counts are computed here independently: a sample's MRP norm and inertia against
the shipped artifacts' regions and design plants, with plain numpy.
"""
from __future__ import annotations

import copy
import json
import math
import re

import numpy as np
import pandas as pd
import pytest

from satfmu.controllers import artifact, domain
from satfmu.controllers.paths import SHIPPED_ARTIFACTS
from satfmu.fmus.errors import ArtifactError
from satfmu.sims.scenario import coverage, spec

SIGMA = [f"sigma[{i}]" for i in (1, 2, 3)]


@pytest.mark.parametrize("bad, match", [
    ({"inputs": SIGMA, "norm_max": 0.9, "min": 0.0}, r"domain\[0\]: norm_max .* do not mix"),
    ({"inputs": SIGMA, "norm_max": 0.0}, r"domain\[0\]\.norm_max: must be > 0"),
    ({"inputs": SIGMA, "norm_max": float("nan")}, r"domain\[0\]\.norm_max: must be a finite number"),
    ({"inputs": SIGMA, "min": 0.0}, r"domain\[0\]: an interval .* one input, got 3"),
    ({"inputs": ["q2"]}, r"domain\[0\]: no bound"),
    ({"inputs": ["q2"], "min": 1.0, "max": 0.5}, r"domain\[0\]: min 1.0 > max 0.5"),
    ({"inputs": [], "max": 1.0}, r"domain\[0\]\.inputs: must be a non-empty list"),
    ({"inputs": ["q2"], "max": True}, r"domain\[0\]\.max: must be a finite number"),
    ({"inputs": ["q2"], "max": 1.0, "radius": 2.0}, r"domain\[0\]: unknown keys \['radius'\]"),
    ("|sigma| <= 0.9", r"domain\[0\]: must be a table"),
])
def test_a_bad_domain_is_refused_naming_its_key(bad: object, match: str) -> None:
    with pytest.raises(ArtifactError, match=match):
        domain.parse([bad], "a.certificate.domain")
    with pytest.raises(ArtifactError, match=r"a.certificate.domain: must be a list"):
        domain.parse({"inputs": SIGMA}, "a.certificate.domain")


def test_an_artifact_with_a_bad_domain_does_not_load() -> None:
    data = json.loads((SHIPPED_ARTIFACTS / "mrp_hinf_satfmu.json").read_text())
    assert artifact.parse(copy.deepcopy(data)).certificate["domain"] == [domain.ball(SIGMA, 0.9)]
    data["certificate"]["domain"] = [{"inputs": SIGMA, "norm_max": -1.0}]
    with pytest.raises(ArtifactError, match=r"certificate\.domain\[0\]\.norm_max: must be > 0"):
        artifact.parse(data)


def test_violations_of_a_ball_and_an_interval() -> None:
    dom = [domain.ball(SIGMA, 0.9), domain.interval("q2", 0.17, 1.24)]
    inside = {"sigma[1]": 0.9, "sigma[2]": 0.0, "sigma[3]": 0.0, "q2": 0.17}  # on both boundaries: inside
    assert domain.violations(dom, inside) == []
    out = domain.violations(dom, {**inside, "sigma[2]": 0.1, "q2": 1.3})
    assert [label for label, _ in out] == ["|sigma[1..3]| <= 0.9", "0.17 <= q2 <= 1.24"]
    assert out[0][1] == pytest.approx(math.hypot(0.9, 0.1), rel=1e-15) and out[1][1] == 1.3
    assert domain.violations(dom, {**inside, "q2": float("nan")})[0][0] == "0.17 <= q2 <= 1.24"  # NaN is outside
    with pytest.raises(KeyError, match=r"\['q2'\]"):
        domain.violations(dom, {k: v for k, v in inside.items() if k != "q2"})
    assert domain.describe(domain.interval("w1", 0.0, 0.0)) == "w1 = 0"
    assert domain.describe(domain.interval("w4", high=0.6)) == "w4 <= 0.6"


def test_every_shipped_domain_is_the_region_its_text_states() -> None:
    """Each bound of a shipped artifact's domain appears in its region in words (the two were
    written from one set of numbers by the synthesis; the shipped files were given theirs since)."""
    seen = 0
    for path in sorted(SHIPPED_ARTIFACTS.glob("*.json")):
        cert = artifact.load(path).certificate
        if "domain" not in cert:
            continue
        words = cert["region"]
        numbers = [float(x) for x in re.findall(r"-?\d+(?:\.\d+)?(?:e-?\d+)?", words)]
        for c in cert["domain"]:
            for key in ("norm_max", "min", "max"):
                if key in c and c[key] != 0.0:
                    assert any(math.isclose(c[key], x, rel_tol=1e-5) for x in numbers), (path.name, c, words)
            seen += 1
    assert seen >= 8  # the MRP balls, the VSCMG boxes and design point


def _rows(sigma: np.ndarray, inertia: np.ndarray) -> pd.DataFrame:
    cols = {f"plant.sigma_0[{i + 1}]": sigma[:, i] for i in range(3)}
    cols.update({f"plant.I_{a}": inertia[:, k] for k, a in enumerate("xyz")})
    return pd.DataFrame(cols)


DISPERSED = [("plant", f"sigma_0[{i}]") for i in (1, 2, 3)] + [("plant", f"I_{a}") for a in "xyz"]


def test_campaign_samples_outside_the_ball_and_off_the_design_inertia() -> None:
    """mrp_slew_mc_synth: |sigma| <= 0.9 and the design inertia (15, 16, 12.5 kg m^2). Samples
    drawn here with known answers: the counts are exact."""
    rng = np.random.default_rng(1)
    n = 200
    sigma = rng.uniform(-0.7, 0.7, (n, 3))
    inertia = np.tile([15.0, 16.0, 12.5], (n, 1))
    off = rng.random(n) < 0.3
    inertia[off, 0] *= 1.1  # I_x 10 % off in about 30 % of the samples
    inertia[5, 1] *= 1 + 0.5 * artifact.DESIGN_RTOL  # within the design tolerance: not off
    cov, = coverage.coverage(spec.load("mrp_slew_mc_synth"), _rows(sigma, inertia), DISPERSED)
    outside_ball = np.linalg.norm(sigma, axis=1) > 0.9
    assert cov.status == "certified" and cov.samples == n
    assert cov.reasons == {k: v for k, v in [("I_x is not its design value 15", int(off.sum())),
                                             ("starts outside |sigma[1..3]| <= 0.9", int(outside_ball.sum()))] if v}
    assert cov.outside == int((off | outside_ball).sum()) and 0 < cov.outside < n
    assert cov.fraction == cov.outside / n and cov.notes == []


def test_a_sample_that_did_not_start_is_not_counted() -> None:
    sigma = np.array([[0.1, 0.0, 0.0], [np.nan, np.nan, np.nan]])
    cov, = coverage.coverage(spec.load("mrp_slew_mc_synth"), _rows(sigma, np.tile([15.0, 16.0, 12.5], (2, 1))),
                             DISPERSED)
    assert (cov.samples, cov.outside) == (1, 0)


def test_a_scenario_and_its_loops() -> None:
    """One sample: the scenario itself. The 200 deg start lies outside |sigma| <= 0.9; the published
    law proves nothing; the VSCMG servos start at their design points; seed 003's periodic gains
    state their region in words only."""
    synth, published = coverage.coverage(spec.load("mrp_200deg_synth"))
    assert (synth.samples, synth.outside) == (1, 1)
    assert synth.reasons == {"starts outside |sigma[1..3]| <= 0.9": 1}
    assert published.reasons == {"the certificate proves nothing (status not_verified)": 1}
    assert all(c.outside == 0 for c in coverage.coverage(spec.load("vscmg_seed")))
    periodic = coverage.coverage(spec.load("cubesat_detumble"))
    assert periodic and all(c.outside == 0 and "stated in words only" in c.notes[0] for c in periodic)
    assert coverage.coverage(spec.load("demeter_row1_det_both"))[0].outside == 0  # the nominal plant, any state
