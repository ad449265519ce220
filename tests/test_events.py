"""Event indicators for model exchange (:mod:`satfmu.fmus.events`): from the relations and signs
of a model's right-hand side, post-step map and definitions."""
from __future__ import annotations

import sympy as sp

from satfmu.controllers import catalog
from satfmu.fmus.events import event_indicators, sided
from satfmu.fmus.model import Model, Output, State, Variable


def _model(rhs: list, post: list | None = None, definitions: list | None = None) -> Model:
    x = sp.Symbol("x", real=True)
    return Model("m", "test", [State(Variable("x", "m"), Variable("x_0", "m")),
                               State(Variable("v", "m/s"), Variable("v_0", "m/s"))],
                 [Variable("u", "N.m")], [Variable("k"), Variable("on")],
                 [Output(Variable("y", "m"), x)], rhs=sp.Matrix(rhs),
                 post_step=None if post is None else sp.Matrix(post), definitions=definitions or [])


def test_indicators_of_the_shipped_plants() -> None:
    """The MRP shadow switch (|sigma|^2 - 1), the wheels' speed limits and the DEMETER momentum
    clamps are found from the models themselves; the quaternion renormalization switches on a
    parameter only and gives none."""
    found = {name: [str(g) for g in event_indicators(catalog.source(name).model)] for name in catalog.PLANTS}
    assert found["mrp_satellite"] == ["sigma[1]**2 + sigma[2]**2 + sigma[3]**2 - 1"]
    assert found["magnetorquer_cubesat"] == [] and found["orbit_environment"] == []
    assert "Omega_max[4] - Abs(Omega[4])" in found["mrp_satellite_rw4"]
    assert found["mrp_satellite_rw4"][-1] == found["mrp_satellite"][0]
    assert "h_w[1] - 0.999999999999*wheel_momentum_max" in found["demeter_flexible"]
    assert {"-w_band + Abs(w1)", "w1", "mode_1_tau"} <= set(found["vscmg"])  # stiction band, direction, mode torque
    assert not any("**2" in g and g.count("*") == 2 for g in found["vscmg"])  # no w**2 (never negative)


def test_what_gives_an_indicator_and_what_does_not() -> None:
    """A relation on the state gives lhs - rhs once (its mirror is the same indicator); the
    substep-start state reads as the current one; sign() gives its argument; relations on
    parameters and inputs only, on a 0/1 switch definition, and even powers give none."""
    x, v, u, k, on, t = sp.symbols("x v u k on t", real=True)
    px, pv = Model.previous("x"), Model.previous("v")
    stuck = sp.Symbol("stuck", real=True)
    m = _model(rhs=[v, sp.Piecewise((0, (stuck > sp.Rational(1, 2)) & (on > 0.5)),
                                    (-k * sp.sign(pv) + sp.Max(-1, sp.Min(u, 1)), True))],
               post=[sp.Piecewise((-x, x > 1), (x, True)), sp.Piecewise((0, px * x < 0), (v, True))],
               definitions=[(stuck, sp.Piecewise((1, sp.Abs(pv) <= 0.1), (0, True)))])
    assert event_indicators(m) == [v, x - 1, sp.Abs(v) - 0.1]
    mirrored = sp.Piecewise((1, x - 1 < 0), (0, True)) + sp.Piecewise((2, 1 - x > 0), (0, True))
    assert event_indicators(_model(rhs=[v, mirrored])) == [x - 1]  # x - 1 < 0 and 1 - x > 0: one indicator
    assert event_indicators(_model(rhs=[v, sp.Piecewise((1, t > 5), (0, True))])) == [t - 5]
    assert event_indicators(_model(rhs=[v, sp.Piecewise((1, u > k), (0, True))])) == []


def test_sided_relations_read_their_indicators_side() -> None:
    """A relation or sign that gives indicator k reads its side s[k] (mirrored relations the negated
    side); the substep-start state's relations too; relations that give no indicator are kept."""
    x, v, u, k = sp.symbols("x v u k", real=True)
    pv = Model.previous("v")
    expr = (sp.Piecewise((1, x > 1), (0, True)) + sp.Piecewise((2, 1 - x >= 0), (0, True)) - k * sp.sign(pv)
            + sp.Piecewise((3, u > k), (0, True)))
    m = _model(rhs=[v, expr])
    assert event_indicators(m) == [x - 1, v]
    s = [sp.Symbol("s[0]", real=True), sp.Symbol("s[1]", real=True)]
    (out,) = sided(m, [expr], s)
    assert out == (sp.Piecewise((1, s[0] > 0), (0, True)) + sp.Piecewise((2, -s[0] >= 0), (0, True))
                   - k * sp.sign(s[1]) + sp.Piecewise((3, u > k), (0, True)))
    for side, value in ((-1, 2), (1, 1)):  # each side gives one branch of the two relations on x
        assert out.subs({s[0]: side, s[1]: 0, u: 0, k: 1}) == value


def test_the_wheel_speed_limit_reads_its_side() -> None:
    """The wheel plant's speed-limit cut reads the side of Omega_max - |Omega|: the torque is cut
    on its - side (at or past the limit) and passes on its + side."""
    model = catalog.source("mrp_satellite_rw3").model
    found = event_indicators(model)
    limit = [str(g) for g in found].index("Omega_max[1] - Abs(Omega[1])")
    s = [sp.Symbol(f"s[{i}]", real=True) for i in range(len(found))]
    definitions = dict(zip([sym for sym, _ in model.definitions], sided(model, [e for _, e in model.definitions], s)))
    (tau,) = [e for sym, e in definitions.items() if str(sym) == "d_tau_0"]
    omega_1 = model.state_symbols[[s.variable.name for s in model.states].index("Omega[1]")]
    assert s[limit] in tau.free_symbols and omega_1 not in tau.free_symbols
