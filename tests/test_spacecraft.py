"""Spacecraft descriptions, the full-tensor MRP plant, and the design-plant record of artifacts."""
from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from satfmu.controllers import artifact as artifacts
from satfmu.fmus.plants import mrp_satellite
from satfmu.fmus.plants.spacecraft import SEED_000, Spacecraft, SpacecraftError
from satfmu.synthesis.polynomial_feedback import hinf_sos

OWN = [[100.0, 2.0, -1.0], [2.0, 120.0, 0.5], [-1.0, 0.5, 80.0]]


def test_toml_round_trip(tmp_path):
    f = tmp_path / "sat.toml"
    f.write_text('name = "own"\ninertia = [[100, 2, -1], [2, 120, 0.5], [-1, 0.5, 80]]\n'
                 '[actuators]\ntorque_limit = 20.0\n')
    sc = Spacecraft.from_toml(f)
    assert sc.tensor.tolist() == OWN
    assert sc.parameters() == {"I_x": 100.0, "I_y": 120.0, "I_z": 80.0, "I_xy": 2.0, "I_xz": -1.0, "I_yz": 0.5,
                               "u_max": 20.0}
    assert Spacecraft.from_dict(sc.to_dict()) == sc


def test_principal_moments_accepted():
    assert Spacecraft("p", [15, 16, 12.5]).tensor.tolist() == np.diag([15.0, 16.0, 12.5]).tolist()


@pytest.mark.parametrize("inertia, match", [
    ([[100, 2, -1], [3, 120, 0.5], [-1, 0.5, 80]], r"not symmetric: \[0\]\[1\] = 2 but \[1\]\[0\] = 3"),
    ([[1, 2, 0], [2, 1, 0], [0, 0, 1]], "not positive definite"),
    ([1, 1, 3], "triangle inequality"),
    ([1, float("nan"), 1], "finite"),
    ([[1, 0], [0, 1]], "shape"),
    ("heavy", "numbers"),
])
def test_bad_inertia_is_refused(inertia, match):
    with pytest.raises(SpacecraftError, match=match):
        Spacecraft("bad", inertia)


@pytest.mark.parametrize("data, match", [
    ({"name": "a", "inertia": [1, 1, 1], "inerta": 3}, "unknown key 'inerta'; did you mean 'inertia'"),
    ({"name": "a"}, "missing key 'inertia'"),
    ({"name": "a", "inertia": [1, 1, 1], "actuators": {"torque_limit": -1}}, "torque_limit"),
    ({"name": "a", "inertia": [1, 1, 1], "actuators": {"torque_limt": 1}}, "did you mean 'torque_limit'"),
    ({"name": "", "inertia": [1, 1, 1]}, "name"),
])
def test_bad_description_names_the_key(data, match):
    with pytest.raises(SpacecraftError, match=match):
        Spacecraft.from_dict(data)


def test_missing_and_corrupt_files(tmp_path):
    with pytest.raises(SpacecraftError, match="cannot read"):
        Spacecraft.from_toml(tmp_path / "none.toml")
    (tmp_path / "bad.toml").write_text("name = [")
    with pytest.raises(SpacecraftError, match="invalid TOML"):
        Spacecraft.from_toml(tmp_path / "bad.toml")


def _numeric(model, expr, values):
    subs = {v.symbol: v.start for v in model.parameters}
    subs[sp.Symbol("saturation_on", real=True)] = 0
    return np.array(expr.subs(subs).subs(values), dtype=float).ravel()


def test_full_tensor_dynamics_and_sdc_form():
    """Euler's equation with the full tensor, and the SDC form reproduces it (both to rounding, 1e-12)."""
    model = mrp_satellite.build(Spacecraft("own", OWN))
    rng = np.random.default_rng(1)
    J = np.array(OWN)
    x = [s.symbol for s in model.states]
    uw = [v.symbol for v in model.inputs]
    for _ in range(3):
        xv, uv = rng.uniform(-0.5, 0.5, 6), rng.uniform(-2, 2, 6)
        values = dict(zip(x + uw, [*xv, *uv]))
        w = xv[:3]
        expected = np.linalg.solve(J, -np.cross(w, J @ w) + uv[:3] + uv[3:])
        rhs = _numeric(model, model.rhs, values)
        np.testing.assert_allclose(rhs[:3], expected, rtol=1e-12, atol=1e-15)
        sdc = _numeric(model, model.sdc.A * sp.Matrix(x) + model.sdc.B * sp.Matrix(uw), values)
        np.testing.assert_allclose(sdc, rhs, rtol=1e-12, atol=1e-15)


def test_diagonal_tensor_gives_the_seed_sdc_matrix():
    """With no products of inertia the SDC matrix is seed 000's eq. (35) entry by entry."""
    model = mrp_satellite.build(SEED_000)
    A = model.sdc.A.subs({v.symbol: v.start for v in model.parameters})
    w = [s.symbol for s in model.states[:3]]
    expected = sp.Matrix([[0, (16 - 12.5) / 15 * w[2], 0], [0, 0, (12.5 - 15) / 16 * w[0]],
                          [(15 - 16) / 12.5 * w[1], 0, 0]])
    assert all(abs(float(sp.Poly(A[i, j] - expected[i, j], *w).max_norm())) < 1e-15
               for i in range(3) for j in range(3))


def test_theorem1_for_a_full_tensor_decreases_v_along_the_true_dynamics():
    """Certified for the full tensor, and an independent check: dV/dt = grad V . f(x, u(x)) < 0
    at random points of the certified region (sympy rhs with products of inertia, not the SDC)."""
    model = mrp_satellite.build(Spacecraft("own", OWN))
    r = hinf_sos.theorem1(model, region=0.5, decay_rate=0.005, coefficient_limit=1.0)
    assert r.certified
    art = artifacts.parse(hinf_sos.artifact_data(r, "own_t1", model))
    assert art.provenance["design_plant"]["parameters"]["I_xy"] == 2.0
    P = np.linalg.inv(r.Q)
    x = [s.symbol for s in model.states]
    u = [v.symbol for v in model.inputs[:3]]
    wd = [v.symbol for v in model.inputs[3:]]
    f = sp.lambdify(x + u, model.rhs.subs({v.symbol: v.start for v in model.parameters}
                                          ).subs({v: 0 for v in wd}), "numpy")
    rng = np.random.default_rng(0)
    for _ in range(200):
        s = rng.normal(size=3)
        xv = np.concatenate([rng.uniform(-0.3, 0.3, 3), s / np.linalg.norm(s) * rng.uniform(0.01, 0.5)])
        dv = 2 * xv @ P @ np.asarray(f(*xv, *art.evaluate(xv)), float).ravel()
        assert dv < 0


def test_plant_mismatch_lines():
    rec = artifacts.design_plant_record(mrp_satellite.MODEL)
    assert rec["model"] == "mrp_satellite" and rec["parameters"]["I_x"] == 15.0
    art = artifacts.load(artifacts.__file__.replace("artifact.py", "artifacts/mrp_hinf_published.json"))
    assert artifacts.plant_mismatches(art, "mrp_satellite", Spacecraft("own", OWN).parameters()) == [
        "I_x = 100 (designed for 15)", "I_y = 120 (designed for 16)", "I_z = 80 (designed for 12.5)",
        "I_xy = 2 (designed for 0)", "I_xz = -1 (designed for 0)", "I_yz = 0.5 (designed for 0)"]
    # within the relative tolerance (1e-3) is no mismatch; another model is not compared
    assert artifacts.plant_mismatches(art, "mrp_satellite", {"I_x": 15.01}) == []
    assert artifacts.plant_mismatches(art, "vscmg", {"I_x": 100.0}) == []


def test_robust_design_range_is_no_mismatch():
    art = artifacts.load(artifacts.__file__.replace("artifact.py", "artifacts/demeter_row1_det.json"))
    rec = art.provenance["design_plant"]
    name, (lo, hi) = next(iter(rec["ranges"].items()))
    assert artifacts.plant_mismatches(art, rec["model"], {name: (lo + hi) / 2}) == []
    assert artifacts.plant_mismatches(art, rec["model"], {name: hi * 1.5 if hi > 0 else lo * 1.5}) != []


def test_every_shipped_artifact_records_its_design_plant():
    from satfmu.controllers.paths import SHIPPED_ARTIFACTS

    for f in sorted(SHIPPED_ARTIFACTS.glob("*.json")):
        rec = artifacts.load(f).provenance.get("design_plant")
        assert rec and rec["parameters"] and len(rec["digest"]) == 64, f.name


def test_bad_design_plant_record_is_refused():
    import json

    from satfmu.controllers.paths import SHIPPED_ARTIFACTS

    data = json.loads((SHIPPED_ARTIFACTS / "mrp_hinf_published.json").read_text())
    data["provenance"]["design_plant"]["parameters"]["I_x"] = "heavy"
    with pytest.raises(artifacts.ArtifactError, match=r"design_plant.parameters.I_x"):
        artifacts.parse(data)


def test_controller_fmu_carries_its_design_plant(fmu_dir):
    """In its description and, whole, in resources/artifact.json."""
    import json
    import zipfile

    from fmpy import read_model_description

    fmu = fmu_dir / "mrp_hinf_published.fmu"
    assert "Designed for mrp_satellite (I_x = 15, I_y = 16, I_z = 12.5" in read_model_description(str(fmu)).description
    with zipfile.ZipFile(fmu) as z:
        rec = json.loads(z.read("resources/artifact.json"))["provenance"]["design_plant"]
    assert rec["parameters"]["I_z"] == 12.5 and rec["model"] == "mrp_satellite"


def test_seed_003_design_for_your_own_cubesat():
    """Theorem 2 for a cubesat of other principal moments: certified (the LMIs re-checked in
    numpy), the noises at the seed's relative size, the artifact records that plant; the
    published gains get no artifact for it. Products of inertia are refused (principal axes)."""
    from satfmu.synthesis import designs

    d = designs.design_cubesat_periodic(plant=Spacecraft("cube6u", [0.01, 0.012, 0.004], dipole_limit=0.05))
    assert [a["name"] for a in d.artifacts] == ["cubesat_periodic_satfmu"]
    art = artifacts.parse(d.artifact)
    assert art.certificate["status"] == "certified"
    rec = art.provenance["design_plant"]["parameters"]
    assert (rec["I_x"], rec["I_y"], rec["I_z"]) == (0.01, 0.012, 0.004)
    # the dipole limit is the design plant's m_max, and the summary says up to which rate the gains respect it
    assert art.provenance["design_plant"]["limits"] == {"m_max": 0.05}
    row = float(np.max(np.linalg.norm(d.result.design.F, axis=2)))
    assert f"dipole limit 0.05 A m^2 per axis: the gains command at most that for |omega| <= {0.05 / row:.3g} rad/s" \
        in d.summary
    # 6.67 on 1/0.005 = 200: the same 3.3 % of 1/0.01 = 100 is 3.335
    assert art.provenance["sigma"][0] == pytest.approx(3.335)
    with pytest.raises(designs.DesignError, match="principal axes") as refused:
        designs.design_cubesat_periodic(plant=Spacecraft("skewed", [[0.01, 0.001, 0], [0.001, 0.012, 0],
                                                                    [0, 0, 0.004]]))
    assert isinstance(refused.value.__cause__, SpacecraftError)  # the cubesat model's refusal, chained
    assert not str(refused.value).startswith("ValueError")  # satfmu's own error: its message as it is


# ----------------------------------------------------------------------------- limits reach the controller
def test_the_design_plant_records_its_actuator_limits() -> None:
    from satfmu.fmus.plants import cubesat

    assert artifacts.design_plant_record(mrp_satellite.build(Spacecraft("own", OWN, torque_limit=20.0)))[
        "limits"] == {"u_max": 20.0}
    assert artifacts.design_plant_record(cubesat.MODEL)["limits"] == {"m_max": 0.2}  # the plant's default, A m^2


def _with_limits(limits: object) -> dict:
    data = artifacts.load(artifacts.__file__.replace("artifact.py", "artifacts/mrp_hinf_published.json")).to_json()
    data["provenance"]["design_plant"]["limits"] = limits
    return data


@pytest.mark.parametrize("limits, match", [
    ({"u_max": -1.0}, r"design_plant\.limits\.u_max: must be one of"),
    ({"u_max": float("nan")}, r"design_plant\.limits\.u_max: must be a finite number"),
    ({"thrust": 1.0}, r"design_plant\.limits\.thrust: must be one of \['m_max', 'u_max'\]"),
    ([20.0], r"'limits' must be dict")])
def test_bad_limits_are_refused(limits: object, match: str) -> None:
    with pytest.raises(artifacts.ArtifactError, match=match):
        artifacts.parse(_with_limits(limits))


def test_the_controller_fmu_clips_at_the_design_plants_torque_limit_by_default() -> None:
    from satfmu.controllers import polynomial

    def u_max(art: artifacts.Artifact) -> float:
        return next(v.start for v in polynomial.build(art).parameters if v.name == "u_max")

    assert u_max(artifacts.parse(_with_limits({"u_max": 20.0}))) == 20.0
    # an artifact that records no limit (every shipped one) keeps seed 000's 5 N m
    shipped = artifacts.load(artifacts.__file__.replace("artifact.py", "artifacts/mrp_hinf_published.json"))
    assert "limits" not in shipped.provenance["design_plant"] and u_max(shipped) == polynomial.DEFAULT_U_MAX == 5.0


@pytest.mark.parametrize("plant, budget", [(Spacecraft("own", OWN, torque_limit=20.0), 20.0),
                                           (Spacecraft("own", OWN), 6.5), (None, 6.5)])
def test_design_hinf_takes_the_spacecrafts_torque_limit_as_its_budget(monkeypatch: pytest.MonkeyPatch,
                                                                      plant: Spacecraft | None,
                                                                      budget: float) -> None:
    from satfmu.synthesis import designs
    from satfmu.synthesis.polynomial_feedback import two_step

    class Stop(Exception):
        pass

    def fake(model: object, **kw: object) -> None:
        raise Stop(kw["torque_budget"])

    monkeypatch.setattr(two_step, "two_step", fake)
    with pytest.raises(designs.DesignError) as exc:
        designs.design_hinf(plant)
    assert isinstance(exc.value.__cause__, Stop) and exc.value.__cause__.args == (budget,)


def test_the_dipole_limit_is_read_checked_and_written(tmp_path) -> None:
    f = tmp_path / "cube.toml"
    f.write_text('name = "cube"\ninertia = [0.01, 0.05, 0.05]\n[actuators]\ndipole_limit = 0.2\n')
    sc = Spacecraft.from_toml(f)
    assert sc.dipole_limit == 0.2 and sc.torque_limit is None
    assert Spacecraft.from_dict(sc.to_dict()) == sc and sc.to_dict()["actuators"] == {"dipole_limit": 0.2}
    assert "m_max" not in sc.parameters()  # the MRP plant's parameters: inertia and u_max only
    refused = r"cube: actuators\.dipole_limit: must be a finite number > 0 \(A m\^2\)"
    for bad in (0.0, -1.0, float("inf"), True, "0.2"):
        with pytest.raises(SpacecraftError, match=refused):
            Spacecraft("cube", [0.01, 0.05, 0.05], dipole_limit=bad)
    f.write_text('name = "cube"\ninertia = [0.01, 0.05, 0.05]\n[actuators]\ndipole_limt = 0.2\n')
    with pytest.raises(SpacecraftError, match="dipole_limit"):  # the closest known key
        Spacecraft.from_toml(f)
