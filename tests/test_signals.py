"""Signal-generator FMUs (fmus/signals.py) against the master's profiles (fmus/profiles.py).

Every profile kind is built as its generator FMU (native), stepped by the master alone, and
its output compared with :meth:`Profile.sample` on the communication grid. Both come from one
definition (the generator's expression or table), so the tolerance is rounding: 1e-12
relative to the signal's magnitude covers the C library's sin/cos against numpy's (1 ulp) and
the linear interpolation's one rounding.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description

from satfmu.fmus import export, signals
from satfmu.fmus.model import ModelDefinitionError, Table
from satfmu.fmus.profiles import ProfileError, make
from satfmu.sims.cosim.master import CoSimulation, communication_times

STOP, STEP = 10.0, 0.05
GRID = communication_times(0.0, STEP, round(STOP / STEP))

CASES = {
    "constant": {"kind": "constant", "value": -1.5},
    "step": {"kind": "step", "time": 5.0, "before": 2.0, "after": -1.0},
    "step_between_points": {"kind": "step", "time": 3.33, "before": 0.0, "after": 1.0},
    "table_previous": {"kind": "table", "times": [0.0, 2.5, 7.0], "values": [1.0, -2.0, 3.0]},
    "table_linear": {"kind": "table", "times": [1.0, 2.5, 7.0], "values": [1.0, -2.0, 3.0],
                     "interpolation": "linear"},
    "sinusoid": {"kind": "sinusoid", "amplitude": 0.3, "frequency_Hz": 0.7, "phase_rad": 0.2, "offset": 0.1},
    "random": {"kind": "random", "seed": 7, "std": 0.5, "mean": 0.1, "hold": 0.2},
    "cosine_ramp": {"kind": "cosine_ramp", "start": 4.0, "stop": 8.0, "before": 0.1, "after": 1.1},
    "cosine_ramp_d1": {"kind": "cosine_ramp", "start": 4.0, "stop": 8.0, "before": 0.1, "after": 1.1,
                       "derivative": 1},
    "cosine_ramp_d2": {"kind": "cosine_ramp", "start": 4.0, "stop": 8.0, "before": 0.1, "after": 1.1,
                       "derivative": 2},
}


@pytest.mark.parametrize("case", list(CASES))
def test_generator_fmu_reproduces_the_profile_on_the_grid(case: str, tmp_path: Path, fmu_dir: Path) -> None:
    prof = make(dict(CASES[case]), case, step_size=STEP)
    model, params = prof.generator(GRID)
    path = export.build_native(model, tmp_path) if model.tables else fmu_dir / f"{model.name}.fmu"
    with CoSimulation({"g": path}) as sim:
        res = sim.run(STOP, STEP, parameters={"g": params}, record=["g.y"])
    want = prof.sample(GRID)
    scale = max(1.0, float(np.max(np.abs(want))))
    np.testing.assert_allclose(res["g.y"], want, rtol=0, atol=1e-12 * scale)
    assert np.ptp(want) > 0 or case == "constant"  # the case really varies


def test_step_at_a_communication_point_jumps_there_despite_rounding() -> None:
    # 0.1 * 3 = 0.30000000000000004 and 3 * 0.1 vs 0.3: the jump must land on the point whose
    # time rounds either side of 0.3 (time tolerance 1e-9 s there, satfmu.fmus.model.time_tolerance)
    prof = make({"kind": "step", "time": 0.3, "before": 0.0, "after": 1.0})
    assert prof.sample(np.array([0.1 * 3, 0.3 - 1e-15, 0.3 - 1e-6]))[:2].tolist() == [1.0, 1.0]
    assert prof.sample(np.array([0.3 - 1e-6]))[0] == 0.0


def test_random_table_is_a_prefix_of_one_stream() -> None:
    # the generator's table over a short horizon equals the profile's values on a longer one
    prof = make({"kind": "random", "seed": 3, "std": 1.0, "hold": 0.5})
    long = prof.sample(np.arange(0.0, 20.0, 0.5))
    model, _ = prof.generator(np.arange(0.0, 5.0, 0.5))
    assert model.tables[0].values == tuple(long[:10])


def test_table_generator_name_is_a_hash_of_its_data() -> None:
    a = signals.table(Table((0.0, 1.0), (1.0, 2.0), "linear"))
    b = signals.table(Table((0.0, 1.0), (1.0, 2.0), "linear"))
    c = signals.table(Table((0.0, 1.0), (1.0, 2.0), "previous"))
    assert a.name == b.name != c.name and a.name.startswith("signal_table_")


@pytest.mark.parametrize("times,values,mode,message", [
    ([], [], "linear", "non-zero length"),
    ([0.0, 1.0], [1.0], "linear", "equal"),
    ([0.0, 0.0], [1.0, 2.0], "linear", "strictly increasing"),
    ([0.0, math.nan], [1.0, 2.0], "linear", "finite"),
    ([0.0, 1.0], [1.0, 2.0], "cubic", "interpolation"),
])
def test_bad_tables_are_refused(times: list, values: list, mode: str, message: str) -> None:
    with pytest.raises(ModelDefinitionError, match=message):
        Table(tuple(times), tuple(values), mode)
    with pytest.raises(ProfileError, match=message):
        make({"kind": "table", "times": times, "values": values, "interpolation": mode}, "p")


def test_table_lookup_index_is_checked() -> None:
    from satfmu.fmus.model import Model, Output, TableLookup, Variable

    with pytest.raises(ModelDefinitionError, match="reads no table"):
        Model("bad", "", [], [], [], [Output(Variable("y"), TableLookup(1, Model.t))],
              tables=[Table((0.0,), (1.0,))])


def test_no_fmu_of_the_catalog_has_a_variable_named_time(fmu_dir: Path) -> None:
    """Issue 28, defect 5: a variable ``time`` (signal_step's step time was one) duplicates the
    ``time`` column of fmusim's and the FMI Compliance Checker's result files and clashes with
    Modelica's ``time``; no FMU of the catalog may declare one but as the FMI 3.0 independent
    variable (FMI 3.0 declares the time so, and the importers' time column is that variable)."""
    fmus = sorted(fmu_dir.glob("*.fmu"))
    assert any(f.name == "signal_step.fmu" for f in fmus), "the catalog's signal_step.fmu must be checked"
    clashes = [f"{f.name}: {v.name}" for f in fmus for v in read_model_description(str(f)).modelVariables
               if v.name.lower() == "time" and v.causality != "independent"]
    assert not clashes, f"variables named time: {clashes}"


# Times at and around each kind's switching instants (exactly, within and beyond the time
# tolerance), far out (1e9 s, where the tolerance is 1 us; 1e302 s, where the sinusoid reduces
# its argument) and negative; the parameters put every Piecewise branch in reach.
_TIMES = np.array([-1e302, -5.0, 0.0, 1e-12, 0.3 - 1e-15, 0.3, 0.3 + 1e-10, 1.0 - 1e-9, 1.0, 2.0 + 5e-10, 4.0, 5.0,
                   7.999999999, 8.0, 8.0 + 2e-9, 10.0, 1e9, 1e9 + 5e-7, 1e302, math.inf, -math.inf, math.nan])
_PARAMETERS = {
    "constant": [{"value": -1.5}, {"value": 0.0}],
    "step": [{"step_time": 0.3, "before": 2.0, "after": -1.0}, {"step_time": 1e9, "before": 0.0, "after": 1.0}],
    "sinusoid": [{"amplitude": 0.3, "frequency_Hz": 0.7, "phase_rad": 0.2, "offset": 0.1},
                 {"amplitude": 1.0, "frequency_Hz": 1e-300, "phase_rad": 0.0, "offset": 0.0}],
    "cosine_ramp": [{"start": 4.0, "stop": 8.0, "before": 0.1, "after": 1.1, "derivative": d} for d in (0, 1, 2)]
    + [{"start": 2.0, "stop": 2.0, "before": 0.1, "after": 1.1, "derivative": d} for d in (0, 1, 2)],
}


@pytest.mark.parametrize("kind", list(signals.GENERIC))
def test_signal_functions_give_the_generators_values_bit_for_bit(kind: str) -> None:
    """The profiles evaluate the analytic kinds with satfmu.fmus.signal_functions (no sympy import);
    it must give exactly what the generator's expression gives (sympy.lambdify of it), NaN where
    it gives NaN. A change to a generator in fmus/signals.py without regenerating the module fails
    here: run scripts/generate_signal_functions.py."""
    from satfmu.fmus import signal_functions

    model = signals.GENERIC[kind]()
    assert signal_functions.PARAMETERS[kind] == tuple((v.name, float(v.start)) for v in model.parameters)
    for params in _PARAMETERS[kind]:
        args = [np.float64(params[name]) for name, _ in signal_functions.PARAMETERS[kind]]  # as lambdify passes them
        with np.errstate(all="ignore"):  # inf and NaN times: both sides give what numpy gives
            want = signals.evaluate(model, params, _TIMES)
            got = np.broadcast_to(signal_functions.FUNCTIONS[kind](_TIMES, *args), _TIMES.shape)
        assert np.array_equal(got, want, equal_nan=True), (kind, params, got - want)
        if not (kind == "cosine_ramp" and params["stop"] <= params["start"]):  # a profile refuses that ramp
            spec = {"kind": kind, **params} if kind != "step" else {
                "kind": "step", "time": params["step_time"], "before": params["before"], "after": params["after"]}
            with np.errstate(all="ignore"):
                assert np.array_equal(make(spec, kind).sample(_TIMES), want, equal_nan=True)


def test_signal_functions_module_is_the_printed_text() -> None:
    """Under the sympy that printed it, the module is exactly numpy_source()'s text (another
    sympy may print the same expressions otherwise: the values test above holds either way)."""
    import sympy

    from satfmu.fmus import signal_functions

    text = Path(signal_functions.__file__).read_text()
    if sympy.__version__ != signal_functions.SYMPY_VERSION:
        pytest.skip(f"printed by sympy {signal_functions.SYMPY_VERSION}, this is {sympy.__version__}")
    assert text == signals.numpy_source(), "fmus/signal_functions.py is stale: run scripts/generate_signal_functions.py"
