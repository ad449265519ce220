"""The flexible spacecraft description and the plant built from it (seed 004 for any spacecraft)."""
from __future__ import annotations

import hashlib
import json
import re
import tomllib
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from fmpy import simulate_fmu
from scipy.linalg import expm

from satfmu.fmus import codegen, export
from satfmu.fmus.declared import toml_text
from satfmu.fmus.errors import SpacecraftError
from satfmu.fmus.model import Model
from satfmu.fmus.plants import demeter, flexible_spacecraft
from satfmu.fmus.plants.flexible_spacecraft import (DEMETER, Appendage, FlexibleSpacecraft, InertiaUncertainty,
                                                    Interval, Mode, Wheels)

HZ = 2 * np.pi
SAT = FlexibleSpacecraft(
    "bus50",
    [[50.0, 0.5, -0.3], [0.5, 45.0, 0.2], [-0.3, 0.2, 40.0]],
    [Appendage("solar_array", [Mode("bending", [0.25, 0.04, 0.10], Interval(0.8 * HZ, 1.2 * HZ), Interval(1e-3, 5e-3)),
                               Mode("torsion", [-0.05, 0.20, 0.03], Interval(1.5 * HZ, 2.0 * HZ, 1.6 * HZ),
                                    Interval(2e-3, 2e-3))]),
     Appendage("boom", [Mode("bending", [0.02, -0.08, 0.15])], Interval(2.5 * HZ, 3.5 * HZ), Interval(5e-4, 5e-3))],
    Wheels(0.02, 0.4), InertiaUncertainty(0.1, 1.0), "50 kg m^2 bus, a solar array and a boom")
"""A user spacecraft: 2 appendages, 3 modes; the array's modes have their own dynamics, the boom's shared."""


def fingerprint(model: Model) -> str:
    """SHA-256 of the model's variables (name, unit, description, start, type, range, in order) and
    of the exact sympy form (``srepr``) of every expression."""
    def var(v):
        return [v.name, v.unit, v.description, repr(float(v.start)), v.type, repr(v.min), repr(v.max)]
    text = json.dumps({
        "head": [model.name, model.description, model.default_stop_time, model.default_step_size, model.integrator],
        "states": [var(s.variable) + var(s.initial) for s in model.states],
        "inputs": [var(v) for v in model.inputs], "parameters": [var(v) for v in model.parameters],
        "outputs": [var(o.variable) + [sp.srepr(o.expression)] for o in model.outputs],
        "definitions": [[sp.srepr(s), sp.srepr(e)] for s, e in model.definitions],
        "rhs": sp.srepr(model.rhs), "post": sp.srepr(model.post_step), "switch": sp.srepr(model.switch_time)})
    return hashlib.sha256(text.encode()).hexdigest()


DEMETER_FINGERPRINT = "7dfe5526f1f8ceb37691d225ae340004e03ab8f0b30b7adbd2f9a0030dc3c313"
"""``fingerprint`` of the model the hard-coded DEMETER ``build()`` made before the plant took a
:class:`FlexibleSpacecraft` (computed with that code, which also gave the same
:func:`satfmu.fmus.digest.model_digest`). A deliberate change of the DEMETER model changes it."""


def test_demeter_model_is_unchanged() -> None:
    # Identity, no tolerance: same variables in the same order (names, units, descriptions,
    # starts, ranges) and structurally identical expressions (srepr).
    assert demeter.model() is demeter.MODEL and demeter.model(SAT) is demeter.model(SAT)
    assert demeter.MODEL.name == "demeter_flexible"
    assert fingerprint(demeter.MODEL) == DEMETER_FINGERPRINT  # MODEL is build() with no argument


def test_demeter_constants_are_the_seeds() -> None:
    # The public names of demeter.py read from DEMETER, with the values of docs/models.md (exact:
    # the same decimal literals).
    assert demeter.J0.tolist() == [[31.38, -1.11, -0.26], [-1.11, 21.19, -0.78], [-0.26, -0.78, 35.70]]
    assert demeter.L_SUBSTITUTE.shape == (3, 8) and demeter.L_SUBSTITUTE[1, 4] == 0.28
    assert demeter.OMEGA_RANGE == (0.2 * 2 * np.pi, 0.6 * 2 * np.pi) and demeter.ZETA_RANGE == (5e-4, 5e-3)
    assert (demeter.N_APPENDAGES, demeter.N_FLEX) == (4, 8)
    assert (demeter.WHEEL_TORQUE_MAX, demeter.WHEEL_MOMENTUM_MAX, demeter.WHEEL_ZETA) == (5e-3, 0.12, 0.7)
    assert demeter.WHEEL_WN == 2 * np.pi * 2.0
    assert DEMETER.inertia_uncertainty == InertiaUncertainty(0.3, 3.0)
    assert [g.columns for g in DEMETER.groups] == [(0, 1), (2, 3), (4, 5), (6, 7)]
    assert demeter.parameter_values() == demeter.parameter_values(spacecraft=DEMETER)
    # per-group values through ``groups`` are the per-appendage ``pairs``: the same arithmetic, bit for bit
    rng = np.random.default_rng(1)
    zeta, omega = rng.uniform(*demeter.ZETA_RANGE, 4), rng.uniform(*demeter.OMEGA_RANGE, 4)
    for got, want in zip(demeter.state_space(demeter.J0, demeter.L_SUBSTITUTE, zeta, omega, groups=DEMETER.mode_group),
                         demeter.state_space(demeter.J0, demeter.L_SUBSTITUTE, zeta, omega)):
        assert np.array_equal(got, want)


def test_toml_round_trip(tmp_path: Path) -> None:
    for sc in (DEMETER, SAT):
        path = tmp_path / f"{sc.name}.toml"
        path.write_text(toml_text(sc.to_dict()))
        back = FlexibleSpacecraft.from_toml(path)
        assert back == sc and back.description == sc.description
        assert FlexibleSpacecraft.from_dict(sc.to_dict()) == sc
    assert SAT.to_dict()["appendages"][0]["modes"][1]["frequency"] == {"low": 1.5 * HZ, "high": 2.0 * HZ,
                                                                        "nominal": 1.6 * HZ}


def test_module_example_reads() -> None:
    doc = flexible_spacecraft.__doc__ or ""
    text = doc.split("A TOML file::", 1)[1].split("\nAn interval is", 1)[0]
    sc = FlexibleSpacecraft.from_dict(tomllib.loads(re.sub(r"(?m)^    ", "", text)))
    assert sc.name == "my_sat" and len(sc.modes) == 2 and len(sc.groups) == 2
    assert sc.groups[1].damping == Interval(2e-3, 2e-3)
    assert sc.groups[1].frequency.nominal == 11.0 and sc.wheels.natural_frequency == 12.566


def mutated(path: str, value: object) -> dict:
    """SAT's plain data with the entry at ``path`` (keys and 0-based indices, '/'-separated) set."""
    data = SAT.to_dict()
    *head, last = path.split("/")
    node = data
    for key in head:
        node = node[int(key)] if key.isdigit() else node[key]
    node[int(last) if last.isdigit() else last] = value
    return data


@pytest.mark.parametrize("path, value, message", [
    ("appendages/0/modes/0/coupling/1", float("nan"), r"appendages\[1\]\.modes\[1\]: coupling: must be a finite"),
    ("appendages/0/modes/0/frequency", [9.0, 5.0], r"modes\[1\]\.frequency: need low <= nominal <= high"),
    ("appendages/0/modes/1/frequency", {"low": 9.0, "high": 12.0, "nominal": 13.0}, "low <= nominal <= high"),
    ("appendages/0/modes/0/damping", [-1e-3, 1e-3], r"damping: must be an Interval within \[0, 10\]"),
    ("appendages/1/frequency", [0.0, 1.0], r"boom: frequency: must be an Interval within \[1e-06, inf\] rad/s"),
    ("inertia/0/1", 0.6, r"bus50: inertia: not symmetric"),
    ("inertia", [1.0, 1.0, 3.0], "triangle inequality"),
    ("appendages/0/modes/0/frequncy", [5.0, 7.0], "unknown key 'frequncy'; did you mean 'frequency'?"),
    ("wheels/torque_limt", 1.0, "did you mean 'torque_limit'?"),
    ("appendages", [], "must be a non-empty list of appendages"),
    ("appendages/0/modes", [], "modes: must be a non-empty list"),
    ("appendages/1/name", "solar_array", r"names must be distinct, \['solar_array'\] appear twice"),
    ("wheels/momentum_limit", -0.1, r"wheels: momentum_limit: must be > 0 N.m.s"),
    ("wheels/damping", True, "damping: must be a finite number"),
    ("inertia_uncertainty/moment_spread", 1.0, r"must be in \[0, 1\)"),
    ("name", "bus 50; system()", "is not a name"),
    ("appendages/1/modes/0/kind", "bend\"ing", "is not a name"),
    ("appendages/0/modes/0/coupling", [0.1, 0.2], "must be 3 numbers"),
    ("appendages/0/modes/0/coupling/2", 11.0, r"within \+-10"),
    ("appendages/1/modes/0/damping", [1e-3, 2e-3], "either for the appendage"),
])
def test_bad_input_is_refused_with_its_place(path: str, value: object, message: str) -> None:
    with pytest.raises(SpacecraftError, match=message):
        FlexibleSpacecraft.from_dict(mutated(path, value), where="sat.toml")


def test_missing_keys_and_bad_files(tmp_path: Path) -> None:
    data = SAT.to_dict()
    del data["wheels"]["torque_limit"]
    with pytest.raises(SpacecraftError, match="sat: wheels: missing key 'torque_limit'"):
        FlexibleSpacecraft.from_dict(data, where="sat")
    data = SAT.to_dict()
    del data["appendages"][1]["damping"]
    with pytest.raises(SpacecraftError, match="gives both frequency and damping"):
        FlexibleSpacecraft.from_dict(data)
    (tmp_path / "bad.toml").write_text("name = \n")
    with pytest.raises(SpacecraftError, match="invalid TOML"):
        FlexibleSpacecraft.from_toml(tmp_path / "bad.toml")


def test_user_spacecraft_model_matches_its_state_space() -> None:
    # The generated code's Jacobian (wheels off: the command is the body torque) against eq. (4)
    # with a full inverse of M, both at the spacecraft's nominal values. 1e-12 relative to the
    # largest entry: two routes to the same matrices (Schur complement vs np.linalg.solve),
    # M's condition number ~1e2, so the rounding is ~1e-14.
    model = demeter.model(SAT)
    assert model.name == "flexible_bus50" and "bus50" in model.description
    assert SAT.description not in model.description  # free text never enters the model
    assert [v.name for v in model.parameters[:12]][-6:] == ["L[1,1]", "L[1,2]", "L[1,3]", "L[2,1]", "L[2,2]",
                                                            "L[2,3]"]
    names = [v.name for v in model.parameters]
    assert [n for n in names if n.startswith(("zeta", "omega"))] == ["zeta[1]", "zeta[2]", "zeta[3]", "omega[1]",
                                                                     "omega[2]", "omega[3]"]
    descriptions = {v.name: v.description for v in model.parameters}
    assert descriptions["omega[2]"] == "Natural frequency of appendage 1 torsion"
    assert descriptions["omega[3]"] == "Natural frequency of appendage 2"
    A, B = demeter.state_space(SAT.tensor, SAT.coupling, SAT.nominal_damping, SAT.nominal_frequency,
                               groups=SAT.mode_group)
    n = A.shape[0]
    assert n == 2 * (3 + 3)
    gen = codegen.load_python(model)
    p = model.parameter_vector({"wheels_on": 0})
    ns = len(model.states)
    zero = [0.0] * ns
    jac = np.array(gen.jacobian(0.0, zero, zero, [0.0] * 6, p)).reshape(ns, ns)
    assert np.abs(jac[:n, :n] - A).max() < 1e-12 * np.abs(A).max()
    for k in range(3):  # u_c[k] and T_d[k] both act as body torque with the wheels off
        for u in (np.eye(6)[k], np.eye(6)[3 + k]):
            dx = np.array(gen.derivatives(0.0, zero, zero, list(u), p))
            assert np.abs(dx[:n] - B[:, k]).max() < 1e-12 * np.abs(B).max()
    starts = {v.name: v.start for v in model.parameters}
    assert all(starts[k] == v for k, v in demeter.parameter_values(spacecraft=SAT).items())


def test_user_spacecraft_fmu_runs(tmp_path: Path) -> None:
    # The native FMU, wheels off, a held torque on axis 2 for 10 s from rest: exact flow, so the
    # states equal the zero-order-hold solution of the direct model; 1e-12 absolute (states
    # ~1e-3, the exponential's rounding ~1e-16 relative to |A| t ~ 1e2).
    model = demeter.model(SAT)
    fmu = export.build_native(model, tmp_path)
    names = [s.variable.name for s in model.states]
    sig = np.zeros(2, dtype=[("time", float), ("u_c[2]", float)])
    sig["time"], sig["u_c[2]"] = [0.0, 10.0], 0.01
    res = simulate_fmu(str(fmu), stop_time=10.0, output_interval=1.0, input=sig, start_values={"wheels_on": False},
                       output=names + ["wheel_torque[2]"])
    got = np.array([res[n][-1] for n in names[:12]])
    A, B = demeter.state_space(SAT.tensor, SAT.coupling, SAT.nominal_damping, SAT.nominal_frequency,
                               groups=SAT.mode_group)
    E = expm(np.block([[A, B], [np.zeros((3, 15))]]) * 10.0)
    assert np.all(np.isfinite([res[n] for n in names]))
    assert np.abs(got - E[:12, 12:] @ [0.0, 0.01, 0.0]).max() < 1e-12
    # with the wheels: the command is below satT = 0.02 N m, the momentum ramps 0.01 N m x 10 s < satW
    res = simulate_fmu(str(fmu), stop_time=10.0, output_interval=1.0, input=sig, output=["h_w[2]", "theta[2]"])
    assert abs(res["h_w[2]"][-1] - 0.01 * 10.0) < 1e-15 and np.all(np.isfinite(res["theta[2]"]))
