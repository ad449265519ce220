"""Tool-agnostic verification (sims/interop/verify.py, sims/interop/libcosim.py): our master against libcosim
and ecos on the scenario's SSP file, and the pieces that make them comparable."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from satfmu.sims.interop import libcosim, verify
from satfmu.sims.cli import main
from satfmu.sims.cosim.master import CoSimulation, communication_times
from satfmu.sims.scenario.spec import ScenarioError, load


def test_communication_times_are_libcosims_nanosecond_grid() -> None:
    t = communication_times(0.0, 0.01, 1500)
    # libcosim passes (k * 10_000_000 ns) / 1e9, correctly rounded; 0.01 * k is not always that
    assert all(t[k] == (k * 10_000_000) / 1e9 for k in range(1501))
    assert any(0.01 * k != (k * 10_000_000) / 1e9 for k in range(1501))
    # a step that is no whole number of nanoseconds: t0 + h k
    np.testing.assert_array_equal(communication_times(0.0, 1e-10 / 3, 3), 1e-10 / 3 * np.arange(4))


def test_jacobi_order_delays_a_feedthrough_controller_by_one_step(fmu_dir: Path) -> None:
    sc = load("mrp_200deg")
    d = sc.data
    runs = {}
    for order in ("feedthrough", "jacobi"):
        with CoSimulation({"plant": fmu_dir / "mrp_satellite.fmu", "controller": fmu_dir / "mrp_hinf_published.fmu"}
                          ) as sim:
            for c in d["connections"]:
                sim.connect(c["from"], c["to"])
            params = {i: s.get("parameters", {}) for i, s in d["fmus"].items()}
            runs[order] = sim.run(1.0, 0.05, parameters=params, record=["plant.sigma[1]"], exchange_order=order)
    ft, jac = runs["feedthrough"]["plant.sigma[1]"], runs["jacobi"]["plant.sigma[1]"]
    # the first step uses the initial exchange (identical); from the second on the torques differ
    assert ft[1] == jac[1] and abs(ft[2] - jac[2]) > 1e-7
    with CoSimulation({"plant": fmu_dir / "mrp_satellite.fmu"}) as sim, pytest.raises(ValueError, match="exchange"):
        sim.run(1.0, 0.05, exchange_order="gauss")


def test_scenario_with_profiles_passes_in_libcosim_and_ecos(fmu_dir: Path, tmp_path: Path,
                                                           monkeypatch: pytest.MonkeyPatch) -> None:
    tmp = tmp_path / "tmp"  # the temporary folder of this process and of the engines' processes
    tmp.mkdir()
    monkeypatch.setattr("tempfile.tempdir", str(tmp))
    monkeypatch.setenv("TMPDIR", str(tmp))
    report = verify.verify("mrp_eq44", fmu_dir, tmp_path / "out")
    assert report.metrics_passed and report.passed
    # nothing left behind: the master's extracted FMUs, ecos's ecos_ssp_<uuid>, libcosim's folders
    assert list(tmp.iterdir()) == []
    by = {c.engine: c for c in report.comparisons}
    assert set(by) == {"libcosim", "ecos"}
    # libcosim: the same binaries in the same order, so rounding only (measured 3e-14 on sigma)
    assert by["libcosim"].max_deviation < 1e-3
    # ecos: its 6-decimal CSV, so about half the 1e-6 allowance
    assert 0.2 < by["ecos"].max_deviation <= 1.0
    # the master's own order is a real difference that the tolerance would catch
    assert report.order_deviation > 1e-2


def test_libcosim_returns_every_point_of_a_long_run(fmu_dir: Path, tmp_path: Path) -> None:
    # libcosim's time-series observer keeps 10,000 samples unless told otherwise: 12,000 steps
    ssp = verify.ssp.export("mrp_200deg", fmu_dir, tmp_path)
    res = libcosim.run(ssp, ["plant.sigma[1]"], 60.0, 0.005)
    assert len(res) == 12_000 and res["time"][0] == 0.005 and res["time"][-1] == 60.0
    # the same values as the master's Jacobi run at the same step (rounding only)
    with CoSimulation({"plant": fmu_dir / "mrp_satellite.fmu", "controller": fmu_dir / "mrp_hinf_published.fmu"}
                      ) as sim:
        sc = load("mrp_200deg").data
        for c in sc["connections"]:
            sim.connect(c["from"], c["to"])
        params = {i: s.get("parameters", {}) for i, s in sc["fmus"].items()}
        ours = sim.run(60.0, 0.005, parameters=params, record=["plant.sigma[1]"], exchange_order="jacobi")
    np.testing.assert_allclose(res["plant.sigma[1]"], ours["plant.sigma[1]"][1:], rtol=0, atol=1e-12)


def test_deviation_catches_an_exchange_order_difference(fmu_dir: Path) -> None:
    sc = load("mrp_eq44")
    ft, record, _ = verify._master(sc, fmu_dir, "native", "feedthrough")
    jac, _, _ = verify._master(sc, fmu_dir, "native", "jacobi")
    ref = {q: jac[q] for q in record}
    _, name, ok = verify._deviation(ref, {q: ft[q] for q in record}, verify.TOLERANCES["libcosim"])
    assert not ok and name
    _, _, ok = verify._deviation(ref, {q: jac[q].copy() for q in record}, verify.TOLERANCES["libcosim"])
    assert ok


def test_libcosim_errors_are_reported_not_crashes(tmp_path: Path) -> None:
    with pytest.raises(libcosim.EngineError, match="nanoseconds"):
        libcosim.run(tmp_path / "x.ssp", [], 1.0, 1e-10 / 3)
    with pytest.raises(libcosim.EngineError, match="libcosim failed"):
        libcosim.run(tmp_path / "missing.ssp", ["plant.omega[1]"], 1.0, 0.1)


def test_scenario_verify_table_needs_a_reason(tmp_path: Path) -> None:
    f = tmp_path / "s.toml"
    f.write_text('name = "s"\nstop_time = 1.0\nstep_size = 0.1\n[fmus.plant]\nmodel = "mrp_satellite"\n'
                 '[verify]\nrtol = 1e-2\n')
    with pytest.raises(ScenarioError, match="reason"):
        load(f)


def test_cli_writes_the_report(fmu_dir: Path, tmp_path: Path, capsys) -> None:
    assert main(["verify", "mrp_200deg", "--engines", "libcosim", "--fmu-dir", str(fmu_dir),
                 "--out", str(tmp_path)]) == 0
    assert "1/1 scenarios pass" in capsys.readouterr().out
    (row,) = json.loads((tmp_path / "verify.json").read_text())
    assert row["passed"] and row["comparisons"][0]["engine"] == "libcosim"
    assert (tmp_path / "mrp_200deg.ssp").exists() and "libcosim vs master" in (tmp_path / "verify.md").read_text()


def test_ecos_reads_matrix_names_and_logs_only_what_it_is_asked(fmu_dir: Path) -> None:
    """ecos separates its CSV columns by ", " and leaves a matrix entry's comma in the name
    (``instance::K_theta[1,2][REAL]``): the DEMETER controller alone, every variable logged, then two."""
    fmu = fmu_dir / "demeter_row1_det.fmu"
    every = verify.run_ecos(fmu, 0.01, 1e-3, alone=True)
    assert len(every["time"]) == 11 and "instance.K_theta[1,2]" in every and "instance.K_xw[3,1]" in every
    with CoSimulation({"alone": fmu}) as sim:
        gain = float(sim.components["alone"].variable("K_theta[1,1]").start)
    assert every["instance.K_theta[1,1]"] == pytest.approx(gain, abs=5e-7)  # ecos's 6 decimals
    two = verify.run_ecos(fmu, 0.01, 1e-3, alone=True, variables=["instance.u_c[1]", "instance.K_eta[1,2]"])
    assert set(two) == {"time", "instance.u_c[1]", "instance.K_eta[1,2]"}
    np.testing.assert_array_equal(two["instance.K_eta[1,2]"], every["instance.K_eta[1,2]"])


def test_the_demeter_scenario_passes_verify_in_libcosim_and_ecos(fmu_dir: Path, tmp_path: Path) -> None:
    """Seed 004's flexible plant and row-1 controller (49 outputs, matrix-named parameters in the
    SSP file) cut to 2 s (2000 steps; the shipped 60 s: test_every_scenario_passes_verify, 21 s a
    start, 17 s of it libcosim's)."""
    sc = load("demeter_row1_det_both")
    cut = sc.from_dict({**sc.to_dict(), "stop_time": 2.0}, sc.folder, "demeter cut to 2 s")
    report = verify.verify(cut, fmu_dir, tmp_path)
    # the engines agree; the metrics gate the 60 s run (at 2 s theta is still rising past theta(0))
    assert report.n_variables == 49 and report.n_points == 2001
    by = {c.engine: c for c in report.comparisons}
    assert set(by) == {"libcosim", "ecos"} and all(c.passed for c in by.values())
    # libcosim: the same binaries in the same order, rounding only (measured 0.005 of the allowance over 60 s)
    assert by["libcosim"].max_deviation < 0.1
    # ecos: its 6-decimal CSV, up to half the 1e-6 allowance (measured 0.5)
    assert 0.2 < by["ecos"].max_deviation <= 1.0


@pytest.mark.slow
def test_every_scenario_passes_verify(fmu_dir: Path, tmp_path: Path) -> None:
    # 24 scenarios, about 85 s in all (the three DEMETER ones about 60 s of it, mostly libcosim's
    # 60,000 steps each): in `make test-all`
    from satfmu.sims.scenario import SHIPPED_SCENARIOS as SCENARIOS

    reports = [verify.verify(p.stem, fmu_dir, tmp_path) for p in sorted(SCENARIOS.glob("*.toml"))]
    assert all(r.passed for r in reports), verify.markdown([r for r in reports if not r.passed])


def test_sampled_fmus_are_recognized_in_both_backends(fmu_dir: Path) -> None:
    for name in ("cubesat_bdot", "cubesat_periodic_satfmu"):
        assert verify.sampled_fmu(fmu_dir / f"{name}.fmu") and verify.sampled_fmu(fmu_dir / f"{name}_py.fmu")
    # a routine sampler: the C Riccati routine (native) and its Python twin
    assert (verify.sampled_fmu(fmu_dir / "vscmg_sdre_online.fmu")
            and verify.sampled_fmu(fmu_dir / "vscmg_sdre_online_py.fmu"))
    # its servo integrators are continuous states: listed, not checked
    sc = load("vscmg_seed")
    assert verify._sampled_controllers(sc, verify.fmu_paths(sc, fmu_dir, "native")) == (
        [], ["online", "online_w1free"])
    for name in ("mrp_satellite", "mrp_hinf_published", "magnetorquer_cubesat"):
        assert not verify.sampled_fmu(fmu_dir / f"{name}.fmu") and not verify.sampled_fmu(fmu_dir / f"{name}_py.fmu")


def test_delayed_deviation_flags_a_silent_jacobi_run() -> None:
    output = np.array([0.0, 1.0, -2.0, 3.0])
    assert verify.delayed_deviation(np.array([0.0, 0.0, 1.0, -2.0]), output) == (0.0, False)
    dev, silent = verify.delayed_deviation(np.zeros(4), output)
    assert silent and dev == 2.0
    assert verify.delayed_deviation(np.zeros(4), np.zeros(4)) == (0.0, False)  # nothing commanded: not silence
    assert verify.delayed_deviation(output, output)[0] == 5.0  # no delay is a deviation too: |3 - (-2)|
    with pytest.raises(ValueError):
        verify.delayed_deviation(np.zeros(3), np.zeros(4))


def _detumble_feedthrough(fmu_dir: Path) -> tuple[object, list[str], np.ndarray]:
    sc = load("cubesat_detumble")
    controllers, stateful = verify._sampled_controllers(sc, verify.fmu_paths(sc, fmu_dir, "native"))
    assert stateful == []
    conns = sc.data["connections"]
    extra = [c["to"] for c in conns if c["to"].split(".")[0] in controllers or c["from"].split(".")[0] in controllers]
    res_ft, _, _ = verify._master(sc, fmu_dir, "native", "feedthrough", extra)
    return sc, controllers, res_ft


def test_sampled_controllers_pass_on_their_output_one_step_later_in_jacobi_order(fmu_dir: Path) -> None:
    """cubesat_detumble's three sampled laws (B-dot every 1 s, the periodic schedules every
    900 s, step 1 s): a Jacobi-order reader gets each one's feedthrough-order output one step
    later, exactly (issue 28, defect 1: B-dot's was identically zero)."""
    sc, controllers, res_ft = _detumble_feedthrough(fmu_dir)
    assert controllers == ["bdot", "lmi", "pub"]
    got = verify.sampled_order_check(sc, fmu_dir, "native", res_ft, controllers)
    assert got.passed and got.max_deviation == 0.0 and not got.error
    assert np.max(np.abs(res_ft["bdot.m[1]"])) > 1e-3  # the check compared commands, not zeros
    # the check fails a run whose outputs are not the replayed inputs' (here: B-dot's commands
    # one more step late, as if the controller sampled stale inputs)
    late = res_ft.copy()
    for i in (1, 2, 3):
        late[f"bdot.m[{i}]"][1:] = res_ft[f"bdot.m[{i}]"][:-1]
    bad = verify.sampled_order_check(sc, fmu_dir, "native", late, ["bdot"])
    assert not bad.passed and bad.max_deviation > 1e-4 and bad.worst_variable.startswith("bdot.m")
    report = verify.ScenarioVerification("x", "x.ssp", 1, 1, 0.0, True, 0.0, [], bad)
    assert not report.passed and "FAIL" in verify.markdown([report])
