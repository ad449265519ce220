"""The compiled step loop (satfmu.sims.cosim.compiled_loop, sims/cosim/c/cosim_loop.c) against the master's Python loop.

Both loops make the same FMI calls with the same values in the same order, so every
comparison here is exact (bytes of the result arrays, NaN payloads included): any
difference is a defect, not round-off.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from satfmu.fmus.profiles import make
from satfmu.sims.cosim import compiled_loop
from satfmu.fmus.errors import ScenarioError
from satfmu.sims.scenario.result import write_csv
from satfmu.sims.scenario.run import run
from satfmu.sims.scenario.spec import Scenario, load
from satfmu.sims.scenario.validation import MAX_STEPS
from satfmu.sims.scenario.wiring import recorded, recorded_times, wire
from satfmu.sims.cosim.master import CoSimulation, FmuCallError, MasterError, recorded_steps
from satfmu.sims.scenario import shipped_scenarios

SHORT = {"vscmg_seed": 1.5, "vscmg_seed_friction": 1.5, "vscmg_friction_mc_online": 1.5}
"""Stop time of the fast test for the scenarios with pythonfmu online SDRE controllers, s (2.3 s
of CPU per full run; the full runs are the slow test's)."""


def _runs(scenario: Scenario, fmu_dir: Path, stop_time: float) -> dict[str, np.ndarray]:
    """The scenario run by each loop in each exchange order, fresh and reused instances."""
    params = {inst: spec.parameters for inst, spec in scenario.fmus.items()}
    out = {}
    with wire(scenario, fmu_dir) as fresh, wire(scenario, fmu_dir) as reused:
        reused.reuse_instances = True
        record = recorded(scenario, fresh)
        for order in ("feedthrough", "jacobi"):
            for engine in ("python", "compiled"):
                out[f"{order} {engine}"] = fresh.run(stop_time, scenario.step_size, scenario.start_time, params,
                                                     record, order, engine=engine)
            for i in range(2):  # reset between runs: as a new instance
                out[f"{order} compiled reused {i}"] = reused.run(stop_time, scenario.step_size, scenario.start_time,
                                                                 params, record, order, engine="compiled")
    return out


def _assert_identical(runs: dict[str, np.ndarray]) -> None:
    for order in ("feedthrough", "jacobi"):
        ref = runs[f"{order} python"]
        assert len(ref) > 1 and len(ref.dtype.names) > 1
        for label, res in runs.items():
            if label.startswith(order):
                assert res.dtype == ref.dtype and res.tobytes() == ref.tobytes(), label


@pytest.mark.parametrize("path", shipped_scenarios(), ids=lambda p: p.stem)
def test_every_shipped_scenario_runs_bit_for_bit_in_both_loops(path: Path, fmu_dir: Path) -> None:
    """Compiled == Python, feedthrough and Jacobi order, fresh and reset instances; the vscmg
    scenarios (python SDRE FMUs that log through the host's callback) to SHORT s."""
    sc = load(path)
    _assert_identical(_runs(sc, fmu_dir, SHORT.get(sc.name, sc.stop_time)))


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(SHORT))
def test_the_python_controller_scenarios_run_bit_for_bit_to_their_stop_time(name: str, fmu_dir: Path) -> None:
    """As the fast test, over the whole manoeuvre (~20 s of CPU each)."""
    sc = load(name)
    _assert_identical(_runs(sc, fmu_dir, sc.stop_time))


def _diverging(fmu_dir: Path) -> CoSimulation:
    """A plant whose disturbance torque jumps to 1e300 N m at 1 s: its state overflows in the step
    from t = 1 s, and fmi2DoStep returns fmi2Error."""
    sim = CoSimulation({"plant": fmu_dir / "mrp_satellite.fmu"}, reuse_instances=True)
    sim.add_profile("plant.w_d[1]", make({"kind": "step", "time": 1.0, "before": 0.0, "after": 1e300}))
    return sim


@pytest.mark.parametrize("order", ["feedthrough", "jacobi"])
def test_a_failing_call_raises_the_same_error_in_both_loops_and_the_instance_runs_again(fmu_dir: Path,
                                                                                       order: str) -> None:
    messages = {}
    for engine in ("python", "compiled"):
        with _diverging(fmu_dir) as sim:
            with pytest.raises(FmuCallError) as info:
                sim.run(5.0, 0.05, record=["plant.omega"], exchange_order=order, engine=engine)
            messages[engine] = str(info.value)
            sim.profiles.clear()  # reset from the error state, then a quiet run
            res = sim.run(5.0, 0.05, record=["plant.omega"], exchange_order=order, engine=engine)
            assert np.all(res["plant.omega[1]"] == 0.0)  # rest, no torque: exactly zero
    assert messages["python"] == messages["compiled"]
    assert "fmi2DoStep failed with status 3 (error)" in messages["compiled"]
    assert "non-finite in the step from t = 1 s" in messages["compiled"]


@pytest.mark.parametrize("every", [1, 7, 2400, 5000])
def test_record_every_keeps_the_rows_of_the_full_run_at_those_steps_and_the_last(fmu_dir: Path, every: int) -> None:
    sc = load("mrp_200deg")
    params = {inst: spec.parameters for inst, spec in sc.fmus.items()}
    with wire(sc, fmu_dir) as sim:
        record = recorded(sc, sim)
        full = sim.run(sc.stop_time, sc.step_size, 0.0, params, record)
        steps = recorded_steps(len(full) - 1, every)
        for engine in ("python", "compiled"):
            part = sim.run(sc.stop_time, sc.step_size, 0.0, params, record, engine=engine, record_every=every)
            assert part.tobytes() == full[steps].tobytes(), engine
    assert steps[0] == 0 and steps[-1] == 2400 and len(steps) == -(-2400 // every) + 1


def test_bad_engine_and_record_every_are_refused(fmu_dir: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    with CoSimulation({"plant": fmu_dir / "mrp_satellite.fmu"}) as sim:
        for bad in (0, -1, 1.5, True, "2"):
            with pytest.raises(ValueError, match="record_every must be an integer >= 1"):
                sim.run(1.0, 0.05, record_every=bad)
        with pytest.raises(ValueError, match="engine must be one of auto, compiled, python"):
            sim.run(1.0, 0.05, engine="cython")
    monkeypatch.setenv("SATFMU_PYTHON_LOOP", "1")
    with CoSimulation({"plant": fmu_dir / "mrp_satellite.fmu"}) as sim:
        with pytest.raises(MasterError, match="compiled loop is not available"):
            sim.run(1.0, 0.05, engine="compiled")
        assert len(sim.run(1.0, 0.05, engine="auto", record=["plant.omega"])) == 21  # the Python loop


def test_the_library_is_compiled_once_into_the_home_folder_named_by_its_digest(tmp_path: Path,
                                                                               monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("SATFMU_HOME", str(tmp_path))
    path = compiled_loop.compile_library()
    assert path.parent == tmp_path / "lib" and path.name.startswith("cosim_loop-") and path.suffix == ".so"
    mtime = path.stat().st_mtime_ns
    assert compiled_loop.compile_library() == path and path.stat().st_mtime_ns == mtime  # reused
    assert [p.name for p in path.parent.iterdir()] == [path.name]  # no temporary file left
    with pytest.raises(FileNotFoundError, match="C compiler 'no-such-cc' not found"):
        compiled_loop.compile_library("no-such-cc")
    assert compiled_loop.library("no-such-cc") is None  # the master then steps in Python


def test_result_csv_reads_back_to_the_same_floats(tmp_path: Path) -> None:
    """The vectorized CSV writer: every float64 back bit for bit (Python's float() is exact),
    special values included, and a header name that needs quoting."""
    import csv

    values = np.array([0.05, 0.1 + 0.2, 1e-310, 5e-324, -0.0, np.nan, np.inf, -np.inf, 1e16, 123456.789e10,
                       np.nextafter(1.0, 2.0), -2.5e-8])
    res = np.zeros(len(values), dtype=[("time", "f8"), ("a[1,2]", "f8")])
    res["time"], res["a[1,2]"] = np.arange(len(values)) * 0.05, values
    write_csv(res, tmp_path / "r.csv")
    with open(tmp_path / "r.csv", newline="") as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["time", "a[1,2]"] and len(rows) == len(values) + 1
    back = np.array([[float(v) for v in row] for row in rows[1:]])
    assert back[:, 0].tobytes() == res["time"].tobytes()
    assert back[:, 1].tobytes() == values.tobytes()  # NaN, signed zero and subnormals included


def test_a_scenario_records_every_nth_point_and_its_metrics_read_them(fmu_dir: Path, tmp_path: Path) -> None:
    """record_every = 8 on mrp_200deg: 301 rows, those of the full run at steps 0, 8, ..., 2400;
    the final-value metric is the full run's (the last point is always recorded); the CSV has
    the thinned rows; a bad value is refused with its key; a run of more than MAX_STEPS points
    is refused unless thinned."""
    import csv
    import tomllib

    from satfmu.sims.scenario import SHIPPED_SCENARIOS

    data = tomllib.loads((SHIPPED_SCENARIOS / "mrp_200deg.toml").read_text())
    full = run(Scenario.from_dict(data), fmu_dir)
    thin_sc = Scenario.from_dict({**data, "record_every": 8})
    assert (thin_sc.to_dict()["record_every"] == 8
            and recorded_times(thin_sc).tolist() == full.results["time"][::8].tolist())
    thin = run(thin_sc, fmu_dir, out_dir=tmp_path)
    assert len(thin.results) == 301 and thin.results.tobytes() == full.results[::8].tobytes()
    assert thin.metric("attitude angle at 120 s").value == full.metric("attitude angle at 120 s").value
    with open(thin.files["csv"], newline="") as fh:
        assert len(list(csv.reader(fh))) == 302
    for bad in (0, 1.5, True):
        with pytest.raises(ScenarioError, match=r"record_every: must be an integer >= 1"):
            Scenario.from_dict({**data, "record_every": bad})
    long = {**data, "stop_time": 0.05 * (MAX_STEPS + 8)}
    with pytest.raises(ScenarioError, match=r"stop_time: .* communication steps, .* recorded, more than 1e\+07"):
        Scenario.from_dict(long)
    assert Scenario.from_dict({**long, "record_every": 2}).record_every == 2  # thinned: accepted


@pytest.mark.parametrize("record_every", [1, 7])
def test_a_streamed_recording_is_the_returned_one_block_by_block(fmu_dir: Path, record_every: int) -> None:
    """``sink``: the rows handed over, block after block, are exactly those a run returns (bytes,
    both loops, several blocks of the compiled loop and a last point off the record_every grid),
    the first block the initial point alone, no block over BLOCK // record_every + 1 rows."""
    sc = load("mrp_200deg")
    n_steps = 2 * compiled_loop.BLOCK + 123
    stop = sc.step_size * n_steps
    params = {inst: spec.parameters for inst, spec in sc.fmus.items()}
    with wire(sc, fmu_dir) as sim:
        record = recorded(sc, sim)
        whole = sim.run(stop, sc.step_size, sc.start_time, params, record, engine="compiled",
                        record_every=record_every)
        assert len(whole) == len(recorded_steps(n_steps, record_every))
        for engine in ("compiled", "python"):
            blocks: list[np.ndarray] = []
            empty = sim.run(stop, sc.step_size, sc.start_time, params, record, engine=engine,
                            record_every=record_every, sink=blocks.append)
            assert len(empty) == 0 and empty.dtype == whole.dtype
            assert len(blocks[0]) == 1 and len(blocks) == 1 + -(-n_steps // compiled_loop.BLOCK), engine
            assert max(len(b) for b in blocks) <= compiled_loop.BLOCK // record_every + 1
            assert np.concatenate(blocks).tobytes() == whole.tobytes(), engine


def test_a_streamed_recording_holds_one_block(fmu_dir: Path) -> None:
    """Memory: a run of 1e5 steps recording 10 signals at every step peaks at its rows (1e5 x 11
    doubles, twice: the recording and the returned array, 17.6 MB); streamed, at one block of
    them plus the communication times (0.8 MB): asserted below a quarter of the first."""
    import tracemalloc

    sc = load("mrp_200deg")
    n_steps = 100_000
    params = {inst: spec.parameters for inst, spec in sc.fmus.items()}
    with wire(sc, fmu_dir) as sim:
        record = recorded(sc, sim)
        peaks = {}
        for label, sink in (("whole", None), ("streamed", lambda rows: None)):
            tracemalloc.start()
            sim.run(sc.step_size * n_steps, sc.step_size, sc.start_time, params, record, engine="compiled", sink=sink)
            peaks[label] = tracemalloc.get_traced_memory()[1]
            tracemalloc.stop()
    assert peaks["whole"] > n_steps * 11 * 8 * 2, peaks  # the check can fail: it sees the rows
    assert peaks["streamed"] < peaks["whole"] / 4, peaks


@pytest.mark.parametrize("name,changes", [
    ("mrp_eq44", {}),  # an l2_ratio metric (disturbances, versus curves)
    ("mrp_200deg", {"record_every": 7, "record": [{"signal": "plant.phi", "unit": "deg"}, "plant.omega",
                                                   "plant.sigma", "controller.u"]}),  # units, a thinned record
])
def test_a_streamed_scenario_run_writes_the_same_files(name: str, changes: dict, fmu_dir: Path, tmp_path: Path,
                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    """run(..., stream=True): the CSV written block by block is the kept run's byte for byte, the
    metrics fed block by block are equal to the kept run's bit for bit, the result keeps no rows
    (with plots, the plot's columns and the l2_ratio curves, equal too), and writing the result
    elsewhere copies the streamed CSV."""
    import tomllib

    data = {**tomllib.loads((shipped_scenarios()[0].parent / f"{name}.toml").read_text()), **changes}
    sc = Scenario.from_dict(data)
    kept = run(sc, fmu_dir, out_dir=tmp_path / "kept")
    monkeypatch.setattr(compiled_loop, "BLOCK", 97)  # many blocks: the metrics carry their state across them
    streamed = run(sc, fmu_dir, out_dir=tmp_path / "streamed", stream=True)
    assert streamed.csv == streamed.files["csv"] and kept.csv is None
    assert streamed.files["csv"].read_bytes() == kept.files["csv"].read_bytes()
    assert [(m.name, m.value, m.unit) for m in streamed.metrics] == [(m.name, m.value, m.unit) for m in kept.metrics]
    assert streamed.results.dtype.names == ("time",) and len(streamed.results) == 0 and not streamed.l2_curves
    plotted = run(sc, fmu_dir, out_dir=tmp_path / "plotted", stream=True, plots=True)
    assert plotted.files["plot"].is_file() and plotted.panels == kept.panels
    for c in plotted.results.dtype.names:
        assert plotted.results[c].tobytes() == kept.results[c].tobytes(), c
    assert plotted.l2_curves.keys() == kept.l2_curves.keys()
    for k, curve in kept.l2_curves.items():
        assert plotted.l2_curves[k].tobytes() == curve.tobytes(), k
    again = streamed.write(tmp_path / "elsewhere", plots=False)
    assert again["csv"].read_bytes() == kept.files["csv"].read_bytes()


@pytest.mark.parametrize("engine", ["compiled", "python"])
def test_streamed_blocks_hold_their_own_times_and_profile_values(engine: str, fmu_dir: Path,
                                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    """A streamed run computes the communication times and the profiles' values a block of steps
    at a time (its memory does not grow with its length): a held random draw, a table and a
    sinusoid give the rows of the run that computes them whole, byte for byte."""
    import tomllib

    data = tomllib.loads((shipped_scenarios()[0].parent / "mrp_eq44.toml").read_text())
    data["profiles"] = [
        {"to": "plant.w_d[1]", "kind": "random", "seed": 3, "std": 0.5, "hold": 0.35},
        {"to": "plant.w_d[2]", "kind": "table", "times": [0.0, 7.3, 21.0, 60.0], "values": [0.0, 1.0, -0.5, 0.2],
         "interpolation": "linear"},
        {"to": "plant.w_d[3]", "kind": "sinusoid", "amplitude": 0.3, "frequency_Hz": 0.05}]
    sc = Scenario.from_dict(data)
    sim = wire(sc, fmu_dir)
    try:
        args = (sc.stop_time, sc.step_size, sc.start_time, {}, recorded(sc, sim))
        whole = sim.run(*args, engine=engine)
        monkeypatch.setattr(compiled_loop, "BLOCK", 61)  # 20 blocks
        blocks: list[np.ndarray] = []
        sim.run(*args, engine=engine, sink=blocks.append)
    finally:
        sim.close()
    assert len(blocks) == 1 + -(-(len(whole) - 1) // 61)  # the start row alone, then one a block of steps
    streamed = np.concatenate(blocks)
    assert streamed.tobytes() == whole.tobytes()
