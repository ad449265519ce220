"""Seed 004's robust design for a user's flexible spacecraft: the uncertainty box read from its
description, the refusals, the design model's two constructions, the plant FMU's parameters, and
the design end to end (artifact, catalog plant ``flexible_<name>``, FMU closed loop)."""
from __future__ import annotations

import json
import math
import tomllib
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

import satfmu
from satfmu.controllers import catalog, paths, state_feedback
from satfmu.fmus.plants import demeter
from satfmu.fmus.plants.flexible_spacecraft import (DEMETER, Appendage, FlexibleSpacecraft, InertiaUncertainty,
                                                    Interval, Mode, Wheels)
from satfmu.fmus.errors import ArtifactError, DesignError, VariantError
from satfmu.sims.workflows import demeter_loops
from satfmu.synthesis.robust.demeter_variants import THETA_WORST, Variant, design_model, parameters

MY_FLEX_TOML = """\
name = "my_flex"
inertia = [[60.0, 0.8, -0.3], [0.8, 52.0, 0.4], [-0.3, 0.4, 45.0]]

[inertia_uncertainty]
moment_spread = 0.1
product_spread = 0.5

[wheels]
torque_limit = 0.02
momentum_limit = 0.5

[[appendages]]
name = "solar_array"
[[appendages.modes]]
kind = "bending"
coupling = [0.35, 0.06, 0.12]
frequency = [3.0, 4.5]
damping = [1e-3, 5e-3]
[[appendages.modes]]
kind = "torsion"
coupling = [-0.05, 0.15, 0.04]
frequency = [7.0, 9.0]
damping = [1e-3, 5e-3]

[[appendages]]
name = "antenna"
frequency = [1.5, 2.5]
damping = [2e-3, 1e-2]
[[appendages.modes]]
kind = "bending"
coupling = [0.05, 0.25, 0.10]
"""
MY_FLEX = FlexibleSpacecraft.from_dict(tomllib.loads(MY_FLEX_TOML), where="my_flex.toml")
"""3 mode groups: the array's bending and torsion (each its own dynamics), the antenna's bending."""
AXES, APPENDAGES = (1,), (2,)
"""The design of the module: axis 1 with the antenna (a 3-parameter box, feasible in ~3 s)."""


def with_antenna_damping(damping: object) -> FlexibleSpacecraft:
    """MY_FLEX with the antenna's shared damping replaced (plain data: a number or an interval)."""
    data = MY_FLEX.to_dict()
    data["appendages"][1]["damping"] = damping
    return FlexibleSpacecraft.from_dict(data)


def twin_antennas() -> FlexibleSpacecraft:
    """Two appendages with the same intervals (model_type 2 admits them), one mode each."""
    return FlexibleSpacecraft(
        "twins", [[60.0, 0.8, -0.3], [0.8, 52.0, 0.4], [-0.3, 0.4, 45.0]],
        [Appendage("left", [Mode("bending", [0.05, 0.25, 0.10])], Interval(1.5, 2.5), Interval(2e-3, 1e-2)),
         Appendage("right", [Mode("bending", [0.08, -0.20, 0.12])], Interval(1.5, 2.5), Interval(2e-3, 1e-2))],
        Wheels(0.02, 0.5), InertiaUncertainty(0.1, 0.5))


# ------------------------------------------------------------------------------------------- the box
def test_the_toml_text_reads_as_the_spacecraft(tmp_path: Path) -> None:
    path = tmp_path / "my_flex.toml"
    path.write_text(MY_FLEX_TOML)
    sc = FlexibleSpacecraft.from_toml(path)
    assert sc == MY_FLEX
    # identity: groups are the array's two modes (own dynamics) then the antenna (shared)
    assert [(g.appendage, g.kind, g.columns) for g in sc.groups] == [(0, "bending", (0,)), (0, "torsion", (1,)),
                                                                    (1, None, (2,))]
    assert sc.wheels.natural_frequency == demeter.WHEEL_WN  # the default H(s), not given in the text


def test_box_comes_from_the_spacecraft_intervals() -> None:
    dm = design_model(Variant(AXES, APPENDAGES, spacecraft=MY_FLEX))
    assert dm.names == ["sqrtJ11", "omega", "zeta"]  # one design group: no suffix
    box = {p.name: (p.value(-1), p.value(1), p.nominal, p.half_width) for p in dm.parameters}
    # the root of J11 over [0.9, 1.1] x 60 kg m^2; centre and half width are (lo +- hi) / 2 of the
    # roots: a few ulps from the formula
    lo, hi = math.sqrt(0.9 * 60.0), math.sqrt(1.1 * 60.0)
    assert box["sqrtJ11"] == pytest.approx((lo, hi, (lo + hi) / 2, (hi - lo) / 2), rel=1e-14)
    # the antenna's shared intervals (rad/s and ratio): midpoints and half widths, exact to rounding
    assert box["omega"] == pytest.approx((1.5, 2.5, 2.0, 0.5), rel=1e-15)
    assert box["zeta"] == pytest.approx((2e-3, 1e-2, 6e-3, 4e-3), rel=1e-14)
    assert dm.fixed == {} and dm.members == [[2]] and dm.groups == [[2]]  # the antenna is the spacecraft's group 3
    assert [p.name for p in parameters(Variant(AXES, APPENDAGES, spacecraft=MY_FLEX))] == dm.names

    # two axes: both roots and the product J12 = 0.8 +- 0.5 kg m^2 (product_spread)
    two = {p.name: p for p in parameters(Variant((1, 2), APPENDAGES, spacecraft=MY_FLEX))}
    assert list(two) == ["sqrtJ11", "sqrtJ22", "J12", "omega", "zeta"]
    assert (two["J12"].kind, two["J12"].index) == ("Jprod", (0, 1))
    assert (two["J12"].nominal, two["J12"].half_width) == pytest.approx((0.8, 0.5), rel=1e-15)  # copied values
    assert two["sqrtJ22"].value(1) == pytest.approx(math.sqrt(1.1 * 52.0), rel=1e-14)  # ulps of (lo + hi) / 2

    # both appendages, model_type 1: the array's modes each their own group (omega1_1, omega1_2),
    # the antenna's group suffixed by its appendage (omega2)
    all_groups = design_model(Variant(AXES, (1, 2), 1, spacecraft=MY_FLEX))
    assert all_groups.names == ["sqrtJ11", "omega1_1", "zeta1_1", "omega1_2", "zeta1_2", "omega2", "zeta2"]
    assert all_groups.members == [[0], [1], [2]]
    by_name = {p.name: p for p in all_groups.parameters}
    # mode intervals in rad/s: [3, 4.5], [7, 9], [1.5, 2.5]; exact to rounding
    assert (by_name["omega1_1"].nominal, by_name["omega1_1"].half_width) == pytest.approx((3.75, 0.75), rel=1e-15)
    assert (by_name["omega1_2"].nominal, by_name["omega1_2"].half_width) == pytest.approx((8.0, 1.0), rel=1e-15)
    assert (by_name["omega2"].nominal, by_name["omega2"].half_width) == pytest.approx((2.0, 0.5), rel=1e-15)
    assert [by_name[n].index for n in ("zeta1_1", "zeta1_2", "zeta2")] == [(0,), (1,), (2,)]


def test_known_values_are_fixed_not_uncertain() -> None:
    # the antenna's damping a single number: zeta is known, kept in fixed at that value
    dm = design_model(Variant(AXES, APPENDAGES, spacecraft=with_antenna_damping(4e-3)))
    assert dm.names == ["sqrtJ11", "omega"]
    assert dm.fixed == {("zeta", (0,)): pytest.approx(4e-3, rel=1e-15)}  # (v + v) / 2 of the number
    assert dm.values(np.array([0.3, -1.0]))["zeta"] == pytest.approx([4e-3], rel=1e-15)
    # no inertia uncertainty: the root of J11 is known, the box is the antenna's omega and zeta
    certain = FlexibleSpacecraft("my_flex", MY_FLEX.inertia, MY_FLEX.appendages, MY_FLEX.wheels)
    known = design_model(Variant(AXES, APPENDAGES, spacecraft=certain))
    assert known.names == ["omega", "zeta"] and set(known.fixed) == {("sqrtJ", (0,))}
    # J11 = root squared: 60 kg m^2 to a few ulps
    assert known.values(np.zeros(2))["J"][0, 0] == pytest.approx(60.0, rel=1e-14)


# -------------------------------------------------------------------------------------- refusals
def test_refusals() -> None:
    # the array's modes and the antenna have different intervals: not identical appendages
    with pytest.raises(VariantError, match="model_type 2 treats appendages \\[1, 2\\] as identical.*"
                                           "Use model_type 1"):
        Variant(AXES, (1, 2), 2, spacecraft=MY_FLEX)
    with pytest.raises(VariantError, match=r"appendages must be distinct integers in 1\.\.2, got \(3,\)"):
        Variant(AXES, (3,), spacecraft=MY_FLEX)
    with pytest.raises(VariantError, match=r"axes must be distinct integers in 1\.\.3"):
        Variant((0,), APPENDAGES, spacecraft=MY_FLEX)
    with pytest.raises(VariantError, match="spacecraft must be a FlexibleSpacecraft"):
        Variant(AXES, APPENDAGES, spacecraft=satfmu.Spacecraft("rigid", [60.0, 52.0, 45.0]))  # type: ignore[arg-type]
    # DEMETER's appendage 3 exists, my_flex has 2
    assert Variant(AXES, (3,)).appendages == (3,)

    # nothing uncertain: no inertia box, every interval one number
    data = MY_FLEX.to_dict()
    del data["inertia_uncertainty"]
    for mode in data["appendages"][0]["modes"]:
        mode["frequency"], mode["damping"] = 4.0, 3e-3
    data["appendages"][1]["frequency"], data["appendages"][1]["damping"] = 2.0, 6e-3
    rigid_box = Variant(AXES, (1, 2), spacecraft=FlexibleSpacecraft.from_dict(data))  # the variant itself is valid
    with pytest.raises(VariantError, match="nothing is uncertain"):
        design_model(rigid_box)
    with pytest.raises(VariantError, match=r"L must be a finite 3 x 3 matrix, got shape \(3, 8\)"):
        design_model(Variant(AXES, APPENDAGES, spacecraft=MY_FLEX), L=demeter.L_SUBSTITUTE)

    # a rigid spacecraft is not a plant of this design; a bad selection is a DesignError too (cause chained)
    with pytest.raises(DesignError, match="plant must be a satfmu.FlexibleSpacecraft.*got Spacecraft"):
        satfmu.design_demeter(AXES, APPENDAGES, plant=satfmu.Spacecraft("rigid", [60.0, 52.0, 45.0]))
    with pytest.raises(DesignError, match="appendages must be distinct integers in 1..2") as info:
        satfmu.design_demeter(AXES, (3,), plant=MY_FLEX, analysis=False)
    assert isinstance(info.value.__cause__, VariantError)


@pytest.mark.parametrize("spacecraft, message", [
    ({"name": "my_flex"}, "spacecraft: missing key 'inertia'"),
    ("my_flex", "expected a table of keys, got str"),
    (None, "expected a table of keys, got NoneType"),
])
def test_variant_from_dict_refuses_a_corrupt_spacecraft(spacecraft: object, message: str) -> None:
    data = Variant(AXES, APPENDAGES, spacecraft=MY_FLEX).to_dict()
    data["spacecraft"] = spacecraft
    with pytest.raises(VariantError, match=f"not a variant: .*{message}"):
        Variant.from_dict(data)


def test_variant_from_dict_refuses_bad_entries() -> None:
    good = Variant(AXES, APPENDAGES, spacecraft=MY_FLEX).to_dict()
    bad = json.loads(json.dumps(good))
    bad["spacecraft"]["appendages"][0]["modes"][1]["frequency"] = [9.0, 7.0]
    with pytest.raises(VariantError, match=r"appendages\[1\]\.modes\[2\]\.frequency: need low <= nominal <= high"):
        Variant.from_dict(bad)
    # a selection beyond this spacecraft (valid for DEMETER)
    with pytest.raises(VariantError, match=r"appendages must be distinct integers in 1\.\.2"):
        Variant.from_dict({**good, "appendages": [4]})
    with pytest.raises(VariantError, match="not a variant"):
        Variant.from_dict({k: v for k, v in good.items() if k != "axes"})


# ------------------------------------------------------------------------------------ round trip
def test_variant_round_trip() -> None:
    for v in (Variant(AXES, APPENDAGES, spacecraft=MY_FLEX), Variant((1, 2, 3), (1, 2), 1, 2, False, MY_FLEX),
              Variant((1,), (1, 2), 2, spacecraft=twin_antennas())):
        data = v.to_dict()
        assert data["spacecraft"] == v.spacecraft.to_dict()
        assert Variant.from_dict(v.to_dict()) == v
        assert Variant.from_dict(json.loads(json.dumps(data))) == v  # the artifact's JSON: floats exact
    assert "spacecraft" not in Variant().to_dict()  # DEMETER: the seed's records unchanged
    assert Variant.from_dict(Variant().to_dict()).spacecraft == DEMETER
    assert Variant(AXES, APPENDAGES, spacecraft=MY_FLEX).label == "my_flex | axes 1 | appendages 2 | model 1 | " \
                                                                  "unc 1 | wheels 1"


# ---------------------------------------------------------------- the two constructions of the model
@pytest.mark.parametrize("axes, appendages, model_type, spacecraft", [
    ((1,), (2,), 1, MY_FLEX),
    ((1,), (1, 2), 1, MY_FLEX),
    ((1, 2), (2,), 1, MY_FLEX),
    ((1, 2, 3), (1, 2), 1, MY_FLEX),
    ((1,), (1, 2), 2, twin_antennas()),  # two coordinates reduced to one (L_r = ||L_g||)
])
@pytest.mark.parametrize("wheels", [True, False])
def test_descriptor_and_direct_constructions_agree(axes: tuple[int, ...], appendages: tuple[int, ...],
                                                   model_type: int, spacecraft: FlexibleSpacecraft,
                                                   wheels: bool) -> None:
    dm = design_model(Variant(axes, appendages, model_type, 1, wheels, spacecraft))
    rng = np.random.default_rng(7)
    deltas = np.vstack([rng.uniform(-1.0, 1.0, (4, len(dm.parameters))),
                        np.sign(rng.uniform(-1.0, 1.0, len(dm.parameters)))])  # and one vertex of the box
    for delta in deltas:
        for got, want in zip(dm.state_space(delta), dm.direct(delta)):
            # the same matrices from two exact routes (descriptor solve vs the mass matrix's
            # inverse): they differ by rounding of well-conditioned solves (measured <= 3.4e-15 of
            # the largest entry), 1e-12 leaves margin and still catches any wrong entry
            assert np.abs(got - want).max() <= 1e-12 * np.abs(want).max()
    # the comparison is not vacuous: another plant of the box differs visibly (omega, zeta and the
    # inertia move entries of A by up to tens of %)
    A1, A2 = dm.state_space(deltas[0])[0], dm.direct(-deltas[0])[0]
    assert np.abs(A1 - A2).max() > 1e-3 * np.abs(A2).max()
    # a stack of deltas is one batched solve: the same plants as one at a time (rounding)
    stack = dm.state_space(deltas)[0]
    assert stack.shape == (len(deltas), dm.n, dm.n)
    assert np.abs(stack[-1] - dm.direct(deltas[-1])[0]).max() <= 1e-12 * np.abs(stack[-1]).max()
    with pytest.raises(VariantError, match=f"delta must be {len(dm.parameters)} finite numbers in"):
        dm.state_space(np.full(len(dm.parameters), 1.5))
    with pytest.raises(VariantError, match="delta must be"):
        dm.direct(np.zeros(len(dm.parameters) + 1))


def test_design_states_follow_the_variant() -> None:
    dm = design_model(Variant(AXES, APPENDAGES, spacecraft=MY_FLEX))
    assert dm.state_names == ["theta[1]", "theta_dot[1]", "eta_r[1]", "eta_r_dot[1]", "xi[1]", "xw[1]",
                              "wheel_torque[1]", "wheel_torque_rate[1]"]
    # one axis, one coordinate: L_r is the antenna's coupling on axis 1 (copied, exact) and Q picks eta[3]
    assert dm.L_r.tolist() == [[0.05]] and dm.Q.tolist() == [[0.0, 0.0, 1.0]]
    assert dm.L.tolist() == [[0.0, 0.0, 0.05], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]]


# ------------------------------------------------------------------------------- FMU parameters
def test_fmu_parameters_set_the_design_groups_on_the_plant_fmu() -> None:
    # the array's bending frequency with a nominal value off the midpoint: the unselected group keeps it
    data = MY_FLEX.to_dict()
    data["appendages"][0]["modes"][0]["frequency"] = {"low": 3.0, "high": 4.5, "nominal": 4.0}
    sc = FlexibleSpacecraft.from_dict(data)
    dm = design_model(Variant(AXES, APPENDAGES, spacecraft=sc))
    delta = np.array([0.5, -0.8, 0.25])  # sqrtJ11, omega, zeta
    p = dm.fmu_parameters(delta)
    names = {f"{k}[{i}]" for k in ("zeta", "omega") for i in (1, 2, 3)}
    assert names <= set(p) and "omega[4]" not in p  # the FMU has one omega, zeta per mode group: 3
    # the antenna is the spacecraft's group 3 (members [[2]]): omega = 2 + 0.5 (-0.8), zeta = 6e-3 + 4e-3 / 4
    assert (p["omega[3]"], p["zeta[3]"]) == pytest.approx((1.6, 7e-3), rel=1e-14)  # rounding of nominal + half delta
    # the other groups at their declared nominal values, exactly (copied)
    assert (p["omega[1]"], p["omega[2]"], p["zeta[1]"], p["zeta[2]"]) == (4.0, 8.0, 3e-3, 3e-3)
    # J11 the square of the root; the unselected axes keep their moments, decoupled (products zero)
    root = dm.parameters[0].value(0.5)
    assert p["J[1,1]"] == pytest.approx(root ** 2, rel=1e-15)  # the same product, at most an ulp
    assert (p["J[2,2]"], p["J[3,3]"], p["J[1,2]"], p["J[1,3]"], p["J[2,3]"]) == (52.0, 45.0, 0.0, 0.0, 0.0)
    # the coupling used: the antenna on axis 1 only (exact copy)
    assert [p[f"L[{i},{j}]"] for i in (1, 2, 3) for j in (1, 2, 3)] == [0, 0, 0.05, 0, 0, 0, 0, 0, 0]
    assert p["wheels_on"] is True
    assert dm.fmu_parameters(delta) == demeter.parameter_values(
        np.diag([root ** 2, 52.0, 45.0]), dm.L, np.array([3e-3, 3e-3, p["zeta[3]"]]),
        np.array([4.0, 8.0, p["omega[3]"]]), spacecraft=sc) | {"wheels_on": True}
    with pytest.raises(VariantError, match="delta must be 3 finite numbers"):
        dm.fmu_parameters(np.array([0.0, 2.0, 0.0]))

    # per-mode groups of appendage 1 map to omega[1], omega[2]; the antenna to omega[3]
    full = design_model(Variant(AXES, (1, 2), spacecraft=MY_FLEX))
    d = np.zeros(len(full.parameters))
    d[full.names.index("omega1_2")], d[full.names.index("zeta2")] = 1.0, -1.0
    q = full.fmu_parameters(d)
    # the interval ends, within rounding of nominal + half width
    assert (q["omega[1]"], q["omega[2]"], q["omega[3]"]) == pytest.approx((3.75, 9.0, 2.0), rel=1e-15)
    assert (q["zeta[1]"], q["zeta[2]"], q["zeta[3]"]) == pytest.approx((3e-3, 3e-3, 2e-3), rel=1e-14)

    # identical appendages (model_type 2): one design group sets both FMU groups
    twins = design_model(Variant(AXES, (1, 2), 2, spacecraft=twin_antennas()))
    assert twins.names == ["sqrtJ11", "omega", "zeta"] and twins.members == [[0, 1]]
    r = twins.fmu_parameters(np.array([0.0, 1.0, -1.0]))
    assert (r["omega[1]"], r["omega[2]"], r["zeta[1]"], r["zeta[2]"]) == pytest.approx((2.5, 2.5, 2e-3, 2e-3),
                                                                                       rel=1e-14)  # rounding
    # the scenario cannot disperse one draw onto two FMU parameters: it says so
    with pytest.raises(ValueError, match=r"omega is shared by the plant's mode groups \[1, 2\]"):
        demeter_loops.fmu_parameter(twins.parameters[1], twins, twins.variant)


# ------------------------------------------------------------------------------- end to end
@pytest.fixture(scope="module")
def home(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    """A satfmu home of this module only: its artifacts are the ones this module writes (the
    session's home may hold other files' designs)."""
    root = tmp_path_factory.mktemp("flexible_design_home")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv(paths.HOME_ENV, str(root))
        mp.delenv("SATFMU_FMU_DIR", raising=False)
        yield root


@pytest.fixture(scope="module")
def design(home: Path) -> satfmu.Design:
    """The design of axis 1 with the antenna (~3 s), written to the module's home."""
    d = satfmu.design_demeter(AXES, APPENDAGES, plant=MY_FLEX, analysis=False)
    assert d.write() == [home / "artifacts" / "my_flex_robust.json"]
    return d


def test_design_is_certified_for_the_user_plant(design: satfmu.Design) -> None:
    art = design.artifact
    assert design.names == ["my_flex_robust"]  # the default name: <spacecraft>_robust
    assert art["plant"] == "flexible_my_flex"
    assert art["design"]["variant"]["spacecraft"]["name"] == "my_flex"
    assert Variant.from_dict(art["design"]["variant"]) == Variant(AXES, APPENDAGES, spacecraft=MY_FLEX)
    cert = art["certificate"]
    assert cert["status"] == "certified"
    assert "my_flex | axes 1 | appendages 2" in cert["proved"] and "analysis=False" in cert["proved"]
    # the region names the box's parameters, in its order, with the ends printed to 6 digits
    names = [part.split(" in ")[0] for part in cert["region"].split("], ")]
    assert names == ["sqrtJ11", "omega", "zeta"]
    ends = [float(x) for x in cert["region"].replace("]", "").replace("[", ",").split(",")
            if x.strip() and x.strip()[0].isdigit()]
    assert ends == pytest.approx([math.sqrt(54.0), math.sqrt(66.0), 1.5, 2.5, 2e-3, 1e-2], rel=1e-6)  # 6 digits
    n = cert["numbers"]
    # the solver's optimum (measured 2.2574 N m s and 225.60); 1 % covers solver versions and platforms
    assert n["design_i2p_bound"] == pytest.approx(2.257, rel=1e-2)
    assert n["design_hinf_bound"] == pytest.approx(225.6, rel=1e-2)
    # the sampled plants (seed 0, 100 of them) within the proved bounds, and stable
    assert n["sampled_max_hinf"] <= n["design_hinf_bound"] and n["sampled_max_i2p"] <= n["design_i2p_bound"]
    assert n["sampled_max_real_pole"] < 0.0
    # their measured values (18.14, 0.09295, [-4.86, -1.96e-4] 1/s); 5 % covers a slightly different gain
    assert n["sampled_max_hinf"] == pytest.approx(18.14, rel=5e-2)
    assert n["sampled_max_i2p"] == pytest.approx(0.09295, rel=5e-2)
    assert n["sampled_min_real_pole"] == pytest.approx(-4.86, rel=5e-2)
    assert "analysis_hinf_pdlf" not in n  # analysis=False: no deterministic analysis recorded
    assert "plant FMU: flexible_my_flex" in design.summary


def test_gains_cover_the_spacecraft_modes(design: satfmu.Design) -> None:
    art = design.artifact
    gains = art["gains"]
    eta = sorted(k for k in gains if k.startswith("K_eta["))
    assert eta == [f"K_eta[{i},{j}]" for i in (1, 2, 3) for j in (1, 2, 3)]  # 3 modes, no K_eta[1,4]
    assert "K_eta[1,4]" not in gains and "K_eta_dot[1,4]" not in gains
    K = np.array(art["design"]["K"])
    states = art["design"]["states"]
    assert K.shape == (1, 8) and states[2] == "eta_r[1]"
    # eta_r = eta[3] (Q picks the antenna, exactly): K_eta[1,3] is the design's gain on eta_r, the
    # array's modes and the other axes get exactly zero
    assert gains["K_eta[1,3]"] == K[0, 2] and gains["K_eta_dot[1,3]"] == K[0, 3]
    assert gains["K_eta[1,3]"] != 0.0
    assert [gains[f"K_eta[{i},{j}]"] for i, j in ((1, 1), (1, 2), (2, 3), (3, 3))] == [0.0] * 4
    assert gains["K_theta[1,1]"] == K[0, 0] and gains["K_theta[2,2]"] == 0.0


def test_written_artifact_loads_and_its_claims_are_checked(design: satfmu.Design, home: Path,
                                                           tmp_path: Path) -> None:
    art = satfmu.load_artifact("my_flex_robust")  # by name: found in the module's home
    assert art.plant == "flexible_my_flex" and art.name == "my_flex_robust"
    assert state_feedback.design_spacecraft(art.design) == MY_FLEX
    L = design_model(Variant(AXES, APPENDAGES, spacecraft=MY_FLEX)).L
    # the same arithmetic (K_r Q) as the design's: equal to rounding at most
    assert state_feedback.gains_of_design(art.design, L) == pytest.approx(art.gains, rel=1e-12, abs=0)
    # an edited gain no longer matches design.K: refused when loaded
    data = json.loads((home / "artifacts" / "my_flex_robust.json").read_text())
    data["gains"]["K_eta[1,3]"] *= 1.01
    bad = tmp_path / "edited.json"
    bad.write_text(json.dumps(data))
    with pytest.raises(ArtifactError, match="design.K and gains disagree.*K_eta\\[1,3\\]"):
        satfmu.load_artifact(bad)
    # a corrupt spacecraft description in design.variant: refused, the key named
    data = json.loads((home / "artifacts" / "my_flex_robust.json").read_text())
    data["design"]["variant"]["spacecraft"]["wheels"]["torque_limt"] = 1.0
    bad.write_text(json.dumps(data))
    with pytest.raises(ArtifactError, match="did you mean 'torque_limit'"):
        satfmu.load_artifact(bad)


def test_catalog_builds_the_flexible_plant_from_the_artifact(design: satfmu.Design) -> None:
    src = catalog.flexible_plant("flexible_my_flex")
    assert src is not None and src.resources == {}
    model = src.model
    assert model.name == "flexible_my_flex"
    states = [s.variable.name for s in model.states]
    assert [s for s in states if s.startswith("eta[")] == ["eta[1]", "eta[2]", "eta[3]"]
    assert "omega[3]" in {v.name for v in model.parameters} and "omega[4]" not in {v.name for v in model.parameters}
    assert model is demeter.model(MY_FLEX)  # the same spacecraft's model (cached)
    assert catalog.source("flexible_my_flex").model is model
    assert catalog.flexible_plant("flexible_nobody") is None  # no artifact made for it
    assert catalog.flexible_plant("mrp_satellite") is None  # not a flexible_* name
    with pytest.raises(ValueError, match="no model or artifact named 'flexible_nobody'"):
        catalog.source("flexible_nobody")


def test_fmu_closed_loop_passes_every_metric(design: satfmu.Design, tmp_path: Path) -> None:
    sc = demeter_loops.scenario("my_flex_robust", start="both")
    bound = design.artifact["certificate"]["numbers"]["design_i2p_bound"]
    # the scenario disperses the design's box onto the FMU parameters of the antenna's group (3)
    assert set(sc.dispersions.data) == {"plant.J[1,1]", "plant.omega[3]", "plant.zeta[3]"}
    assert sc.fmus["plant"].model == "flexible_my_flex" and sc.fmus["ctrl"].model == "my_flex_robust"
    fmu_dir = tmp_path / "fmus"
    res = satfmu.run(sc, fmu_dir=fmu_dir)
    assert sorted(p.name for p in fmu_dir.glob("*.fmu")) == ["flexible_my_flex.fmu", "my_flex_robust.fmu"]
    assert res.passed, res.metrics
    assert res.warnings == []  # the plant FMU's parameters are the design plant's: no mismatch reported
    m = {r.name: r for r in res.metrics}
    xw = m["peak |z2| = |xw|"]
    # the gate: the certified impulse-to-peak bound times |w2| = sqrt 2 (both columns), same arithmetic
    assert xw.max == pytest.approx(bound * math.sqrt(2), rel=1e-15)
    assert xw.value < xw.max
    # measured 0.4249 N m s (7.5 times below the bound); 5 % covers another solver's gain
    assert xw.value == pytest.approx(0.4249, rel=5e-2)
    theta = m["|theta| at the end"]
    assert theta.max == THETA_WORST and theta.value < THETA_WORST
    # measured 0.2500 rad after 60 s (slowest pole ~ -2e-4 1/s: theta hardly decays); 2 % as above
    assert theta.value == pytest.approx(0.2500, rel=2e-2)
    wheel = m["peak wheel momentum"]
    assert wheel.max == MY_FLEX.wheels.momentum_limit  # the spacecraft's limit, 0.5 N m s, copied
    assert wheel.value == pytest.approx(0.1012, rel=5e-2)  # measured; 5 % as above
    assert m["time at the momentum limit"].value == 0.0  # never at the limit (counted in whole steps)


def test_two_artifacts_with_different_spacecraft_of_one_name(design: satfmu.Design, home: Path,
                                                             tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    other_home = tmp_path / "home"
    folder = other_home / "artifacts"
    folder.mkdir(parents=True)
    monkeypatch.setenv(paths.HOME_ENV, str(other_home))
    original = (home / "artifacts" / "my_flex_robust.json").read_text()
    (folder / "my_flex_robust.json").write_text(original)
    # the same spacecraft under another artifact name (and another description): one plant
    same = json.loads(original)
    same["name"] = "my_flex_copy"
    same["design"]["variant"]["spacecraft"]["description"] = "the same bus, described"
    (folder / "my_flex_copy.json").write_text(json.dumps(same))
    src = catalog.flexible_plant("flexible_my_flex")
    assert src is not None and src.model is demeter.model(MY_FLEX)
    # another spacecraft named my_flex (another hub inertia): which is flexible_my_flex?
    other = json.loads(original)
    other["name"] = "my_flex_heavier"
    other["design"]["variant"]["spacecraft"]["inertia"][0][0] = 70.0
    path = folder / "my_flex_heavier.json"
    path.write_text(json.dumps(other))
    assert satfmu.load_artifact(path).plant == "flexible_my_flex"  # a valid artifact on its own
    with pytest.raises(ValueError, match="flexible_my_flex: the design artifacts .* describe different spacecraft") \
            as info:
        catalog.flexible_plant("flexible_my_flex")
    assert str(path) in str(info.value) and str(folder / "my_flex_copy.json") in str(info.value)
    with pytest.raises(ValueError, match="describe different spacecraft"):
        catalog.source("flexible_my_flex")


@pytest.mark.slow
def test_deterministic_analysis_of_the_user_design(design: satfmu.Design) -> None:
    """The parameter-dependent analysis of the same gain (~70 s): a bound between the samples and
    the design's one-Lyapunov-matrix bound."""
    analysed = satfmu.design_demeter(AXES, APPENDAGES, plant=MY_FLEX, name="my_flex_analysed")
    n = analysed.artifact["certificate"]["numbers"]
    assert analysed.artifact["certificate"]["status"] == "certified"
    # the same program: the same gain as the module's design (to the solver's reproducibility)
    assert np.allclose(analysed.artifact["design"]["K"], design.artifact["design"]["K"], rtol=1e-6, atol=0)
    # every sample below the proved bounds (claims' relative slack 1e-6: bounds are rounded solver levels)
    assert n["sampled_max_hinf"] <= n["analysis_hinf_pdlf"] * (1 + 1e-6)
    assert n["analysis_hinf_pdlf"] <= n["design_hinf_bound"] * (1 + 1e-6)
    assert "Parameter-dependent analysis" in analysed.artifact["certificate"]["proved"]


# ----------------------------------------------------------------------- the controller's shape
def test_scenario_design_for_the_user_plant(home: Path) -> None:
    # the randomized design of the same variant: 962 plants (Campi-Garatti at epsilon 0.1, delta
    # 1e-9), ~6 s; without the deterministic analysis its artifact is "sampled", never "certified"
    d = satfmu.design_demeter(AXES, APPENDAGES, plant=MY_FLEX, method="Prob", analysis=False, n_samples=50)
    art = d.artifact
    assert d.names == ["my_flex_robust_prob"] and art["plant"] == "flexible_my_flex"
    cert = art["certificate"]
    assert cert["status"] == "sampled" and "Not analysed over the whole box" in cert["proved"]
    n = cert["numbers"]
    assert n["scenarios"] == 962 and n["scenario_epsilon"] == 0.1 and n["scenario_delta"] == 1e-9
    assert "analysis_i2p" not in n and "Campi-Garatti" in cert["proved"]
    # measured 225.6 and 2.257, as the deterministic design's to 4 digits: 1 % for solver versions
    assert n["design_hinf_bound"] == pytest.approx(225.6, rel=1e-2)
    assert n["design_i2p_bound"] == pytest.approx(2.257, rel=1e-2)
    # the check draws other plants than the design's (seed 2, not 0) and stays within the bounds
    assert "50 plants, seed 2" in cert["proved"]
    assert n["sampled_max_i2p"] <= n["design_i2p_bound"] and n["sampled_max_real_pole"] < 0
    assert "scenario design on 962 plants" in d.summary
    assert art["provenance"]["seed"] == "004's method (Prob) for a user's spacecraft"
    path = d.write()[0]
    assert satfmu.load_artifact(path).certificate["status"] == "sampled"  # the claims check passes
    with pytest.raises(DesignError, match="method must be"):
        satfmu.design_demeter(AXES, APPENDAGES, plant=MY_FLEX, method="prob")
    with pytest.raises(DesignError, match="n_samples must be"):
        satfmu.design_demeter(AXES, APPENDAGES, plant=MY_FLEX, n_samples=0)


@pytest.mark.slow
def test_scenario_design_analysed_over_the_box_is_certified(home: Path) -> None:
    # with the deterministic analysis (~4 min) the i2p bound is proved over the whole box
    # (measured 0.1917 N m s, PDLF H-infinity 22.7)
    d = satfmu.design_demeter(AXES, APPENDAGES, plant=MY_FLEX, method="Prob", name="my_flex_prob_analysed")
    cert = d.artifact["certificate"]
    assert cert["status"] == "certified" and "Over the whole box" in cert["proved"]
    assert cert["numbers"]["analysis_i2p"] == pytest.approx(0.1917, rel=0.05)  # a solver's optimum


def test_state_feedback_for_three_modes() -> None:
    blocks = state_feedback.gain_blocks(3)
    assert blocks["K_eta"] == ("eta", 3, "N.m") and blocks["K_eta_dot"] == ("eta_dot", 3, "N.m.s")
    assert state_feedback.gain_blocks()["K_eta"][1] == 8  # DEMETER's default
    model = state_feedback.build(n_flex=3, name="my_flex_ctrl")
    inputs = [v.name for v in model.inputs]
    assert [n for n in inputs if n.startswith("eta")] == ["eta[1]", "eta[2]", "eta[3]", "eta_dot[1]", "eta_dot[2]",
                                                          "eta_dot[3]"]
    assert "K_eta[3,3]" in {v.name for v in model.parameters} and "K_eta[1,4]" not in {v.name for v in
                                                                                       model.parameters}
    with pytest.raises(KeyError, match=r"no such gains: \['K_eta\[1,4\]'\]"):
        state_feedback.build({"K_eta[1,4]": 1.0}, n_flex=3)

    # a design on axis 2, one reduced coordinate eta_r = Q eta over 3 modes, no wheel states
    Q = np.array([[0.6, 0.0, 0.8]])
    states = state_feedback.design_states((2,), 1, False)
    assert states == ["theta[2]", "theta_dot[2]", "eta_r[1]", "eta_r_dot[1]", "xi[2]", "xw[2]"]
    K = np.array([[-1.0, -20.0, 3.0, 5.0, -0.1, 0.01]])
    g = state_feedback.design_gains(K, (2,), False, Q)
    assert sorted(k for k in g if k.startswith("K_eta[")) == [f"K_eta[{i},{j}]" for i in (1, 2, 3) for j in (1, 2, 3)]
    # K_eta = K_r Q on axis 2's row: one product each, to an ulp
    assert [g[f"K_eta[2,{j}]"] for j in (1, 2, 3)] == pytest.approx([1.8, 0.0, 2.4], rel=1e-15)
    assert [g[f"K_eta_dot[2,{j}]"] for j in (1, 2, 3)] == pytest.approx([3.0, 0.0, 4.0], rel=1e-15)
    assert (g["K_theta[2,2]"], g["K_xw[2,2]"], g["K_torque[2,2]"]) == (-1.0, 0.01, 0.0)  # copied; no wheel states
    assert all(g[f"K_eta[{i},{j}]"] == 0.0 for i in (1, 3) for j in (1, 2, 3))  # unselected axes: no command
    with pytest.raises(ValueError, match=r"K must be a finite 1 x 6 matrix, got shape \(1, 8\)"):
        state_feedback.design_gains(np.zeros((1, 8)), (2,), False, Q)
    with pytest.raises(ValueError, match="K must be a finite"):
        state_feedback.design_gains(np.full((1, 6), np.nan), (2,), False, Q)
    assert state_feedback.flexible_groups(MY_FLEX, (1, 2), 1) == [[0], [1], [2]]
    assert state_feedback.flexible_groups(MY_FLEX, (1, 2), 2) == [[0, 1, 2]]


# ---------------------------------------------------------------------------- couplings of low rank
def test_an_appendage_not_coupled_to_the_axes_is_refused() -> None:
    # the antenna with two modes (shared dynamics) that do not couple to axis 1: they cannot enter
    # the design (no reduced coordinate), so the variant is refused, naming the modes and the axes
    data = MY_FLEX.to_dict()
    data["appendages"][1]["modes"] = [{"kind": "bending", "coupling": [0.0, 0.25, 0.1]},
                                      {"kind": "torsion", "coupling": [0.0, 0.1, 0.2]}]
    variant = Variant(AXES, APPENDAGES, spacecraft=FlexibleSpacecraft.from_dict(data))
    with pytest.raises(VariantError, match=r"antenna bending.*do not couple to axes \[1\]"):
        design_model(variant)
    # through the design function: a DesignError whose cause is that VariantError
    with pytest.raises(satfmu.DesignError) as info:
        satfmu.design_demeter(AXES, APPENDAGES, plant=FlexibleSpacecraft.from_dict(data), analysis=False)
    assert isinstance(info.value.__cause__, VariantError)


def test_collinear_couplings_reduce_to_their_rank() -> None:
    # two axes, three antenna modes coupled along one direction: one reduced coordinate (the rank),
    # Q of orthonormal rows, and the reduced model is the full one (same descriptor and direct model)
    data = MY_FLEX.to_dict()
    data["appendages"][1]["modes"] = [{"kind": f"m{k}", "coupling": [0.1 * k, 0.2 * k, 0.05]} for k in (1, 2, 3)]
    variant = Variant((1, 2), (2,), spacecraft=FlexibleSpacecraft.from_dict(data))
    dm = design_model(variant)
    assert dm.nr == 1
    assert np.allclose(dm.Q @ dm.Q.T, np.eye(1), atol=1e-12)  # an SVD direction: orthonormal to rounding
    # L_g eta = L_r Q eta for every eta: the reduction loses no coupling (rounding of one SVD)
    assert np.allclose(dm.L_r @ dm.Q, dm.L[:2], atol=1e-12)
    rng = np.random.default_rng(3)
    for delta in rng.uniform(-1, 1, (3, len(dm.parameters))):
        A, Bu, B1 = dm.state_space(delta)
        Ad, Bud, B1d = dm.direct(delta)
        # two exact constructions of the same model differ by the rounding of their solves
        assert np.abs(A - Ad).max() <= 1e-12 * np.abs(A).max()
        assert np.abs(Bu - Bud).max() <= 1e-12 * np.abs(Bu).max()
