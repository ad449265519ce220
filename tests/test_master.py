"""The co-simulation master: bad scenarios and wiring fail with specific, named errors."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from satfmu.fmus.profiles import make
from satfmu.fmus.errors import ScenarioError
from satfmu.sims.scenario.run import run
from satfmu.sims.scenario.spec import load
from satfmu.sims.cosim.master import WiringError, CoSimulation, FmuCallError


def _write(tmp: Path, body: str) -> Path:
    p = tmp / "s.toml"
    p.write_text(body)
    return p


PLANT = '{ model = "mrp_satellite" }'
CONTROLLER = '{ model = "mrp_hinf_published" }'
BASE = f"""
name = "t"
stop_time = 1.0
step_size = 0.1
fmus = {{ plant = {PLANT}, controller = {CONTROLLER} }}
"""


def _run(tmp_path: Path, fmu_dir: Path, extra: str):
    return run(_write(tmp_path, BASE + extra), fmu_dir)


def test_unknown_variable_in_connection_names_it(tmp_path: Path, fmu_dir: Path) -> None:
    # the key path of the scenario, the FMU's variables and the closest one
    with pytest.raises(ScenarioError,
                       match=r"connections\[0\]\.from: .*has no variable 'omegaa'.*did you mean 'omega'\?"):
        _run(tmp_path, fmu_dir, '[[connections]]\nfrom = "plant.omegaa"\nto = "controller.omega"\n')


def test_unknown_instance_and_parameter_named(tmp_path: Path, fmu_dir: Path) -> None:
    with pytest.raises(ScenarioError, match=r"record\[0\]: 'plnt.omega' names no FMU instance 'plnt'.*"
                                                     r"did you mean 'plant'\?"):
        _run(tmp_path, fmu_dir, 'record = ["plnt.omega"]\n')
    with pytest.raises(ScenarioError, match=r"s.toml: fmus\.plant\.parameters\.I_q: .*no variable 'I_q'"):
        run(_write(tmp_path, BASE.replace(PLANT, '{ model = "mrp_satellite", parameters = { I_q = 1.0 } }')),
            fmu_dir)


@pytest.mark.filterwarnings("ignore::satfmu.sims.scenario.wiring.DesignMismatchWarning")  # I_x = -3 is also a mismatch
def test_wrong_parameter_type_and_bad_value(tmp_path: Path, fmu_dir: Path) -> None:
    body = BASE.replace(CONTROLLER, '{ model = "mrp_hinf_published", parameters = { saturation_on = 1.5 } }')
    with pytest.raises(ScenarioError, match=r"fmus\.controller\.parameters\.saturation_on: .*is Boolean"):
        run(_write(tmp_path, body), fmu_dir)
    # outside the range the FMU declares: refused before the FMU is instantiated (the FMU itself
    # would reject it too: tests/test_fmu_robustness.py)
    body = BASE.replace(PLANT, '{ model = "mrp_satellite", parameters = { I_x = -3.0 } }')
    with pytest.raises(ScenarioError, match=r"fmus\.plant\.parameters\.I_x: -3.0 is outside its declared "
                                                     r"range \[1e-09, inf\] \(mrp_satellite.fmu\)"):
        run(_write(tmp_path, body), fmu_dir)


def test_pythonfmu_error_is_reported_and_the_host_survives(fmu_dir: Path) -> None:
    # a refused call of a pythonfmu FMU is fmi2Error, as a native FMU's (its C layer reports the
    # slave's refusal): the master reports the FMU's own message (naming I_x), and the instance,
    # still usable, runs again with valid parameters (no torque on a body at rest: omega stays 0)
    for _ in range(3):  # repeated: a use-after-free in the FMU would crash here
        with CoSimulation({"plant": fmu_dir / "mrp_satellite_py.fmu"}) as sim:
            with pytest.raises(FmuCallError, match="I_x"):
                sim.run(1.0, 0.1, parameters={"plant": {"I_x": -1.0}})
            res = sim.run(1.0, 0.1, record=["plant.omega"])
            assert np.all(res["plant.omega[1]"] == 0.0) and len(res["plant.omega[1]"]) == 11


def test_causality_and_double_drive(tmp_path: Path, fmu_dir: Path) -> None:
    with pytest.raises(ScenarioError, match=r"connections\[0\]: plant.u\[1\] is a input, not an output"):
        _run(tmp_path, fmu_dir, '[[connections]]\nfrom = "plant.u"\nto = "controller.omega"\n')
    twice = ('[[connections]]\nfrom = "controller.u"\nto = "plant.u"\n'
             '[[profiles]]\nto = "plant.u[1]"\nkind = "constant"\nvalue = 1.0\n')
    with pytest.raises(ScenarioError,
                       match=r"profiles\[0\]: input plant.u\[1\] is driven twice "
                             r"\(by connections\[0\] and by profiles\[0\]\)"):
        _run(tmp_path, fmu_dir, twice)


def test_scenario_file_errors(tmp_path: Path) -> None:
    with pytest.raises(ScenarioError, match="no scenario named 'mrp_200dge'.*did you mean 'mrp_200deg'"):
        load("mrp_200dge")
    with pytest.raises(ScenarioError, match="no scenario file"):
        load(tmp_path / "none.toml")
    with pytest.raises(ScenarioError, match="unknown key 'stoptime'; did you mean 'stop_time'"):
        load(_write(tmp_path, BASE + "stoptime = 3\n"))
    with pytest.raises(ScenarioError, match="invalid TOML"):
        load(_write(tmp_path, "name = \n"))
    with pytest.raises(ScenarioError, match=r"metrics\[0\]\.kind: must be one of"):
        load(_write(tmp_path, BASE + '[[metrics]]\nname = "x"\nkind = "maximum"\nsignals = ["plant.phi"]\n'))
    with pytest.raises(ScenarioError, match="needs 'tolerance'"):
        load(_write(tmp_path, BASE + '[[metrics]]\nname = "x"\nkind = "settling_time"\n'
                                              'signals = ["plant.phi"]\n'))
    with pytest.raises(ScenarioError, match="needs 'versus'"):
        load(_write(tmp_path, BASE + '[[metrics]]\nname = "x"\nkind = "max_difference"\n'
                                              'signals = ["plant.phi"]\n'))


def test_missing_fmu_file(tmp_path: Path) -> None:
    """A model no FMU folder has and satfmu cannot build, and an FMU file that is not there."""
    body = BASE.replace(PLANT, '{ model = "mrp_satelite" }')
    with pytest.raises(ScenarioError, match=r"fmus.plant.model: no FMU mrp_satelite.fmu in .*empty, and it "
                                                     r"cannot be built: .*did you mean 'mrp_satellite'"):
        run(_write(tmp_path, body), tmp_path / "empty")
    body = BASE.replace(PLANT, '{ path = "nowhere/plant.fmu" }')
    with pytest.raises(ScenarioError, match=r"fmus.plant.path: FMU file .*nowhere/plant.fmu does not exist"):
        run(_write(tmp_path, body), tmp_path / "empty")


def test_time_grid_checks(fmu_dir: Path) -> None:
    with CoSimulation({"plant": fmu_dir / "mrp_satellite.fmu"}) as sim:
        with pytest.raises(ValueError, match="not an integer"):
            sim.run(1.0, 0.3)
        with pytest.raises(ValueError, match="step_size must be > 0"):
            sim.run(1.0, 0.0)
        with pytest.raises(ValueError, match="finite"):
            sim.run(float("nan"), 0.1)


def test_algebraic_loop_is_refused(fmu_dir: Path) -> None:
    # Two direct-feedthrough controllers feeding each other: u depends on omega, omega on u.
    fmu = fmu_dir / "mrp_hinf_published.fmu"
    with CoSimulation({"a": fmu, "b": fmu}) as sim:
        sim.connect("a.u", "b.omega")
        sim.connect("b.u", "a.omega")
        with pytest.raises(WiringError, match="algebraic loop"):
            sim.run(1.0, 0.1)


def test_initial_outputs_propagate_before_the_first_step(fmu_dir: Path) -> None:
    # At t = 0 the recorded command is already the law at the initial state (6.216 N m on u2).
    with CoSimulation({"plant": fmu_dir / "mrp_satellite.fmu",
                       "controller": fmu_dir / "mrp_hinf_published.fmu"}) as sim:
        sim.connect("plant.omega", "controller.omega")
        sim.connect("plant.sigma", "controller.sigma")
        sim.connect("controller.u", "plant.u")
        params = {"plant": {"sigma_0[1]": 0.5992, "sigma_0[2]": -0.7976, "sigma_0[3]": 0.6517}}
        res = sim.run(0.2, 0.1, parameters=params, record=["controller.u", "plant.sigma"])
        assert res["controller.u[2]"][0] == pytest.approx(6.2161, abs=1e-4)  # eq. 38 at s(0)
        # the same master can run again with other parameters (library stays loaded)
        res2 = sim.run(0.2, 0.1, record=["controller.u"])
        assert np.all(res2["controller.u[2]"] == 0.0)


def test_profile_reaches_the_input(fmu_dir: Path) -> None:
    # Open loop: a constant 1.5 N m on axis 1 gives omega1(T) = 1.5 T / Ix exactly (RK4 is exact here).
    with CoSimulation({"plant": fmu_dir / "mrp_satellite.fmu"}) as sim:
        sim.add_profile("plant.w_d[1]", make({"kind": "constant", "value": 1.5}))
        res = sim.run(2.0, 0.1, record=["plant.omega[1]", "plant.w_d[1]"])
    assert res["plant.omega[1]"][-1] == pytest.approx(1.5 * 2.0 / 15.0, rel=1e-13)
    assert np.all(res["plant.w_d[1]"] == 1.5)


def test_a_failed_rerun_leaves_nothing_that_looks_complete(tmp_path: Path, fmu_dir: Path, monkeypatch) -> None:
    """A passing run writes CSV, plot and summary (summary last); a re-run that fails, in the FMU
    or in plotting, removes them first: no old summary saying "passed" beside new data."""
    from satfmu.sims.scenario import plots

    open_loop = 'unconnected = "zero"\nrecord = ["plant.phi"]\n'  # the controller's inputs at their start values
    ok = _write(tmp_path, BASE + open_loop)
    out = tmp_path / "out"
    files = run(ok, fmu_dir, out_dir=out, plots=True).files
    assert all(files[k].is_file() for k in ("csv", "plot", "summary"))
    folder = files["csv"].parent
    blow_up = '{ h_max = 1e6, "omega_0[1]" = 1e3, "omega_0[2]" = 1e3, "omega_0[3]" = 1e3 }'  # in range
    with pytest.raises(FmuCallError, match="the state became non-finite"):
        run(_write(tmp_path, BASE.replace(PLANT, f'{{ model = "mrp_satellite", parameters = {blow_up} }}')
                   + open_loop), fmu_dir, out_dir=out)
    ok = _write(tmp_path, BASE + open_loop)
    assert sorted(p.name for p in folder.iterdir()) == []
    run(ok, fmu_dir, out_dir=out, plots=True)

    def broken(*args, **kwargs):
        raise RuntimeError("no display")

    monkeypatch.setattr(plots, "time_series", broken)
    with pytest.raises(RuntimeError, match="no display"):
        run(ok, fmu_dir, out_dir=out, plots=True)
    left = sorted(p.name for p in folder.iterdir())
    assert left == [files["csv"].name], left  # the new data only: no plot, no summary, no temporary file


def test_fmus_run_with_one_blas_thread_and_the_limits_are_restored(fmu_dir: Path, monkeypatch) -> None:
    """While the FMUs run, every BLAS/OpenMP pool of the host has one thread (many small solves:
    a pool costs CPU, see satfmu.sims.cosim.master.ONE_THREAD); afterwards the original sizes are back."""
    import threadpoolctl

    from satfmu.sims.cosim import master

    seen: list[list[int]] = []
    limit = threadpoolctl.ThreadpoolController.limit

    def recording(self, **kwargs):
        limiter = limit(self, **kwargs)
        seen.append([lib["num_threads"] for lib in threadpoolctl.threadpool_info()])
        return limiter

    monkeypatch.setattr(master.ThreadpoolController, "limit", recording)
    before = [(lib["filepath"], lib["num_threads"]) for lib in threadpoolctl.threadpool_info()]
    with CoSimulation({"plant": fmu_dir / "mrp_satellite_py.fmu"}) as sim:  # loads the host's numpy
        sim.run(0.1, 0.05, record=["plant.omega"])
    assert len(seen) == 1 and seen[0] and set(seen[0]) == {1}, seen
    after = {(lib["filepath"], lib["num_threads"]) for lib in threadpoolctl.threadpool_info()}
    assert set(before) <= after  # libraries loaded during the run keep their own (limited) pools
