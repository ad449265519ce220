"""The satfmu command line: exit codes and messages a user sees."""
from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
from importlib import metadata
from pathlib import Path

import pytest

from satfmu.controllers import catalog, paths
from satfmu.sims import cli
from satfmu.sims.cli import main
from satfmu.sims.scenario import shipped_scenarios


def test_run_passes_and_writes_summary(fmu_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    code = main(["run", "mrp_eq44", "--fmu-dir", str(fmu_dir), "--out", str(tmp_path),
                 "--summary", str(tmp_path / "all.json")])
    out = capsys.readouterr().out
    assert code == 0 and "PASS mrp_eq44" in out
    summary = json.loads((tmp_path / "all.json").read_text())
    assert summary[0]["passed"] and summary[0]["metrics"][0]["value"] < 0.42
    table = (tmp_path / "all.md").read_text()
    assert "| mrp_eq44 | native | truncated L2 ratio" in table and "| pass |" in table


def test_run_fails_with_exit_1_when_a_bound_is_missed(fmu_dir: Path, tmp_path: Path,
                                                      capsys: pytest.CaptureFixture) -> None:
    src = Path(__file__).resolve().parents[1] / "sims" / "scenario" / "shipped" / "mrp_eq44.toml"
    strict = tmp_path / "strict.toml"
    strict.write_text(src.read_text().replace("max = 0.42", "max = 0.2"))  # 0.277 > 0.2
    assert main(["run", str(strict), "--fmu-dir", str(fmu_dir), "--out", str(tmp_path)]) == 1
    assert "FAIL" in capsys.readouterr().out


@pytest.mark.parametrize("backend", ["native", "python", "fmi3"])
def test_design_mismatch_is_found_in_every_backend(backend: str, fmu_dir: Path, tmp_path: Path,
                                                   capsys: pytest.CaptureFixture) -> None:
    """The controller FMU of every backend carries its artifact (resources/artifact.json): a
    plant other than its design plant is refused with --strict."""
    f = tmp_path / "own.toml"
    f.write_text('name = "own"\nstop_time = 0.1\nstep_size = 0.1\n'
                 '[fmus.plant]\nmodel = "mrp_satellite"\nparameters = { I_x = 100.0 }\n'
                 '[fmus.controller]\nmodel = "mrp_hinf_published"\n'
                 '[[connections]]\nfrom = "controller.u"\nto = "plant.u"\n')
    code = main(["run", str(f), "--backend", backend, "--strict", "--fmu-dir", str(fmu_dir), "--out", str(tmp_path)])
    err = capsys.readouterr().err
    assert code == 2 and f"{f}: design mismatch (strict): controller (mrp_hinf_published) on plant: I_x = 100 " \
                         "(designed for 15)" in err, err


def test_a_design_mismatch_names_the_plant_the_controller_is_wired_to(fmu_dir: Path, tmp_path: Path,
                                                                     capsys: pytest.CaptureFixture) -> None:
    # two independent loops: the published controller on its design plant, and a second plant of another
    # inertia with the same controller; only the second pair is a mismatch, named as wired
    f = tmp_path / "two.toml"
    f.write_text('name = "two"\nstop_time = 0.1\nstep_size = 0.1\n'
                 '[fmus.plant_a]\nmodel = "mrp_satellite"\n'
                 '[fmus.plant_b]\nmodel = "mrp_satellite"\nparameters = { I_x = 100.0 }\n'
                 '[fmus.ctrl_a]\nmodel = "mrp_hinf_published"\n[fmus.ctrl_b]\nmodel = "mrp_hinf_published"\n'
                 + "".join(f'[[connections]]\nfrom = "plant_{x}.{v}"\nto = "ctrl_{x}.{v}"\n'
                           f'[[connections]]\nfrom = "ctrl_{x}.u"\nto = "plant_{x}.u"\n'
                           for x in "ab" for v in ("omega",)))
    code = main(["run", str(f), "--strict", "--fmu-dir", str(fmu_dir), "--out", str(tmp_path)])
    err = capsys.readouterr().err
    assert code == 2 and "ctrl_b (mrp_hinf_published) on plant_b: I_x = 100" in err, err
    assert "on plant_a" not in err and "ctrl_a (" not in err


def test_errors_exit_2_with_a_message(fmu_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    assert main(["run", "no_such_scenario", "--fmu-dir", str(fmu_dir)]) == 2
    assert "no scenario named 'no_such_scenario'" in capsys.readouterr().err
    assert main(["validate", "--fmu-dir", str(tmp_path)]) == 2
    assert f"run `satfmu build --fmu-dir {tmp_path}` first" in capsys.readouterr().err


def test_validate_reports_every_fmu(fmu_dir: Path, capsys: pytest.CaptureFixture) -> None:
    # the suite's validation gate: fmpy validate and fmutool -check clean on every FMU of the build
    assert main(["validate", "--fmu-dir", str(fmu_dir)]) == 0
    present = {p.name for p in fmu_dir.glob("*.fmu")}
    catalog_fmus = {p.name for p in catalog.build_all(fmu_dir).paths}  # up to date: reads digests only
    assert len(catalog_fmus) == sum(len(s.backends) for s in catalog.sources())  # native and/or pythonfmu
    assert catalog_fmus <= present  # the folder may also hold FMUs a user built with `synth`
    assert f"{len(present)} of {len(present)} FMUs pass" in capsys.readouterr().out


def test_list_shows_shipped_scenarios(capsys: pytest.CaptureFixture) -> None:
    assert main(["list"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert [line.split()[0] for line in lines] == [p.stem for p in shipped_scenarios()]
    by_name = {line.split()[0]: line for line in lines}
    assert "Seed 000 Figs 1-3: 200 deg rest-to-rest" in by_name["mrp_200deg"]  # name, then description
    for name in ("mrp_200deg", "mrp_200deg_sat", "mrp_320deg_sat", "mrp_eq44"):
        assert name in by_name


@pytest.mark.parametrize("argv", [["--help"], ["list"]])
def test_help_and_list_import_no_numerical_library(argv: list[str]) -> None:
    # `satfmu --help` and `satfmu list` start fast: only the standard library, satfmu.controllers.paths and
    # satfmu.sims.scenario
    code = ("import sys\nfrom satfmu.sims import cli\ntry:\n    cli.main(sys.argv[1:])\nexcept SystemExit:\n    pass\n"
            "print([m for m in ('sympy', 'numpy', 'fmpy', 'scipy') if m in sys.modules])")
    proc = subprocess.run([sys.executable, "-c", code, *argv], capture_output=True, text=True, check=True,
                          cwd=Path(__file__).resolve().parents[1])
    assert proc.stdout.splitlines()[-1] == "[]"


def test_version_is_the_installed_one(capsys: pytest.CaptureFixture) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0 and capsys.readouterr().out.strip() == f"satfmu {metadata.version('satfmu')}"


def _options(parser: argparse.ArgumentParser, where: str = "satfmu") -> list[tuple[str, argparse.Action]]:
    """Every optional argument of ``parser`` and its subcommands, with the command it belongs to."""
    out = []
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, child in action.choices.items():
                out += _options(child, f"{where} {name}")
        elif action.option_strings and action.dest not in ("help", "version"):
            out.append((where, action))
    return out


def test_every_option_has_help_that_states_its_default(capsys: pytest.CaptureFixture) -> None:
    options = _options(cli.parser())
    assert len(options) > 60
    for where, action in options:
        assert action.help, f"{where} {action.option_strings[0]} has no help"
    for argv, shown in ((["run", "--help"], "(default: results)"), (["detumble", "--help"], "(default: 2000)"),
                        (["analyze", "l2", "--help"], "(default: 200000)"),
                        (["build", "--help"], "one per CPU"), (["figures", "demeter", "--help"], "(default: 100)")):
        with pytest.raises(SystemExit):
            main(argv)
        assert shown in " ".join(capsys.readouterr().out.split()), argv


def test_one_name_per_meaning() -> None:
    # the FMU folder is --fmu-dir, a sample count --samples, in every command
    names = {opt for _, action in _options(cli.parser()) for opt in action.option_strings}
    assert "--fmu-dir" in names and "--samples" in names
    assert not names & {"--dest", "--n", "--runs"}
    with pytest.raises(SystemExit):  # no abbreviation: the old --n does not become --name
        main(["campaign", "demeter", "--n", "300"])
    # every command that builds or runs FMUs defaults to the FMU cache; `report` and `replay` read the FMU
    # folder each run or campaign recorded, unless told where the files are now
    fmu_dirs = [a for where, a in _options(cli.parser()) if "--fmu-dir" in a.option_strings
                and where not in ("satfmu report", "satfmu replay")]
    assert {a.default for a in fmu_dirs} == {str(paths.fmu_cache())} and Path(fmu_dirs[0].default).is_absolute()
    assert [a.default for where, a in _options(cli.parser()) if where == "satfmu report"
            and "--fmu-dir" in a.option_strings] == [None]


def test_analyze_groups_the_analyses(capsys: pytest.CaptureFixture) -> None:
    with pytest.raises(SystemExit):
        main(["analyze", "--help"])
    out = capsys.readouterr().out
    assert all(name in out for name in ("sweep", "region", "l2"))
    for old in (["sweep", "mrp-h2hinf"], ["region", "vscmg-sdre"], ["l2", "mrp_hinf_published"]):
        with pytest.raises(SystemExit) as exc:
            main(old)
        assert exc.value.code == 2 and "invalid choice" in capsys.readouterr().err


def test_commands_without_the_demeter_plant_do_not_build_its_model() -> None:
    # a fresh process: `satfmu list` imports the whole CLI, and the DEMETER model (about 4 s of
    # sympy) is built only on first use of satfmu.fmus.plants.demeter.MODEL
    code = ("import sys; from satfmu.sims.cli import main; from satfmu.fmus.plants import demeter; "
            "rc = main(['list']); print(rc, demeter.model.cache_info().currsize)")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                          cwd=Path(__file__).resolve().parents[1])
    assert proc.stdout.split()[-2:] == ["0", "0"]


def test_l2_reports_the_three_estimates_for_the_published_controller(capsys: pytest.CaptureFixture) -> None:
    assert main(["analyze", "l2", "mrp_hinf_published", "--samples", "20000"]) == 0
    out = capsys.readouterr().out
    assert "c = 0.4200 at kv = 10000" in out  # the seed's c_min = 0.42 at kv = 1e4, 4 digits
    assert "no finite c for any kv" in out and "only semi-definite" in out
    assert "SOS certificate of H <= 0" in out and "none (" in out


def test_synth_fails_cleanly_when_no_iterate_fits_the_budget(tmp_path: Path,
                                                             capsys: pytest.CaptureFixture) -> None:
    # the 200 deg manoeuvre needs about 6.1 N m: a 1 N m budget rejects the first iterate
    code = main(["synth", "mrp-hinf", "--torque-budget", "1", "--samples", "2000", "--out", str(tmp_path),
                 "--fmu-dir", ""])
    err = capsys.readouterr().err
    assert code == 2 and "no iterate accepted" in err and "over the budget 1" in err
    assert not list(tmp_path.iterdir())  # nothing written


def test_synth_h2hinf_refuses_early_with_the_gamma_that_would_work(tmp_path: Path,
                                                                    capsys: pytest.CaptureFixture) -> None:
    # gamma = 0.3 is below what even the linearization allows (~0.5): the screen at the origin
    # (frozen LMIs, ~0.2 s each) refuses before any SOS program and names the floor
    code = main(["synth", "mrp-h2hinf", "--gamma", "0.3", "--evaluations", "1", "--out", str(tmp_path),
                 "--fmu-dir", ""])
    err = capsys.readouterr().err
    assert code == 2 and "no certified slack design at gamma = 0.3" in err
    floor = float(re.search(r"Choose gamma >= ([0-9.]+)", err)[1])
    assert 0.45 < floor < 0.6  # docs/models.md: the frozen design becomes infeasible near gamma 0.50
    assert "larger region" not in err and "SOS programs" not in err
    assert not list(tmp_path.iterdir())


def test_synth_vscmg_writes_nothing_for_a_rejected_fit(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    # Degree 1 cannot follow the SDRE gain (off-grid error > OFFGRID_TOL): rejected, nothing written.
    code = main(["synth", "vscmg-sdre", "--grid", "12", "13", "--max-degree", "1", "--out", str(tmp_path),
                 "--fmu-dir", ""])
    assert code == 2 and "fitted SDRE gain rejected: offgrid_max_rel_error" in capsys.readouterr().err
    assert not list(tmp_path.iterdir())


@pytest.mark.slow
def test_synth_vscmg_certifies_the_chosen_fit(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    code = main(["synth", "vscmg-sdre", "--grid", "12", "13", "--max-degree", "6", "--out", str(tmp_path),
                 "--fmu-dir", ""])
    assert code == 0 and "<- chosen" in capsys.readouterr().out
    approx = json.loads((tmp_path / "vscmg_sdre_approx.json").read_text())
    # the smallest degree within CV_TOL = 2e-3 (CV error 1.4e-3 at degree 4 on the 23 x 25 grid),
    # and the SOS region holds on the operating box (satfmu.synthesis.servo.vscmg_region)
    assert approx["certificate"]["status"] == "certified" and approx["fit"]["degree"] == 4
    assert approx["certificate"]["numbers"]["region_trig_max_lyapunov_eig"] < 0
    assert (tmp_path / "vscmg_lq_servo.json").is_file()
    code = main(["synth", "vscmg-sdre", "--grid", "12", "13", "--max-degree", "6", "--cv-tol", "0",
                 "--skip-region", "--out", str(tmp_path), "--fmu-dir", ""])
    approx = json.loads((tmp_path / "vscmg_sdre_approx.json").read_text())
    assert code == 0 and approx["fit"]["degree"] == 6 and approx["certificate"]["status"] == "sampled"


@pytest.mark.parametrize("argv,message", [
    (["synth", "mrp-h2hinf"], "--gamma"),
    (["synth", "mrp-h2hinf", "--gamma", "1", "--variant", "other"], "invalid choice"),
    (["analyze", "sweep", "--gammas"], "--gammas"),
])
def test_synth_and_analyze_refuse_bad_arguments(argv: list[str], message: str,
                                              capsys: pytest.CaptureFixture) -> None:
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2 and message in capsys.readouterr().err


def test_build_refuses_a_jobs_count_below_one(capsys: pytest.CaptureFixture) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["build", "--jobs", "0"])
    assert exc.value.code == 2 and "must be a positive integer" in capsys.readouterr().err


@pytest.mark.parametrize("argv, option, message", [
    (["campaign", "demeter", "--samples", "10", "--workers", "0"], "--workers", "positive"),
    (["campaign", "demeter", "--chunk", "-5"], "--chunk", "positive"),
    (["campaign", "scenario", "mrp_slew_mc", "--worst", "-1"], "--worst", "non-negative"),
    (["campaign", "scenario", "mrp_slew_mc", "--seed", "-3"], "--seed", "non-negative"),
    (["report", "x", "--worst", "-1"], "--worst", "non-negative"),
    (["robustness", "--cycles", "-1"], "--cycles", "positive"),
    (["robustness", "--flips", "-2"], "--flips", "non-negative"),
    (["replay", "x", "--sample", "-1"], "--sample", "non-negative"),
    (["detumble", "--samples", "0"], "--samples", "positive"),
    (["figures", "demeter", "--samples", "0"], "--samples", "positive"),
    (["analyze", "l2", "mrp_hinf_published", "--samples", "0"], "--samples", "positive"),
    (["table1", "--rows", "0"], "--rows", "positive"),
])
def test_counts_below_their_range_are_refused_before_any_work(argv: list[str], option: str, message: str,
                                                             capsys: pytest.CaptureFixture) -> None:
    """A count of zero workers once hung ``campaign demeter``; negative counts were accepted with
    exit 0. argparse refuses them, naming the option."""
    with pytest.raises(SystemExit) as exc:
        main(argv)
    err = capsys.readouterr().err
    assert exc.value.code == 2 and option in err and f"must be a {message} integer" in err, err


def _shipped_digest() -> dict[str, str]:
    import hashlib

    from satfmu.controllers.paths import SHIPPED_ARTIFACTS

    return {f.name: hashlib.sha256(f.read_bytes()).hexdigest() for f in sorted(SHIPPED_ARTIFACTS.glob("*.json"))}


SYNTH_DEFAULT_RUNS = [["cubesat-periodic"], ["mrp-hinf"], ["mrp-h2hinf", "--gamma", "1.0"], ["mrp-sdre"],
                      ["vscmg-sdre"], ["demeter"]]


def test_synth_writes_to_the_user_folder_by_default(tmp_path, monkeypatch):
    """Every synth command's default --out is the user's artifact folder, never the shipped one."""
    from satfmu.sims import cli
    from satfmu.controllers import paths

    monkeypatch.setenv("SATFMU_HOME", str(tmp_path))
    for argv in SYNTH_DEFAULT_RUNS:
        args = cli.parser().parse_args(["synth", *argv])
        assert Path(args.out) == tmp_path / "artifacts" and Path(args.out) != paths.SHIPPED_ARTIFACTS, argv


def _synth_with_defaults(argv: list[str], home: Path) -> None:
    import os
    import subprocess

    env = {**os.environ, "SATFMU_HOME": str(home), "OPENBLAS_NUM_THREADS": "1"}
    done = subprocess.run([sys.executable, "-m", "satfmu.sims.cli", "synth", *argv, "--fmu-dir", ""], env=env,
                          capture_output=True, text=True, timeout=3600)
    assert done.returncode == 0, done.stdout + done.stderr
    assert list((home / "artifacts").glob("*.json")), "no artifact written to the user folder"


def test_synth_with_defaults_leaves_the_shipped_artifacts_unchanged(tmp_path):
    """The quickest design, run with its defaults: its artifacts land in SATFMU_HOME, the shipped
    ones are byte for byte as before (the slow test runs every design)."""
    before = _shipped_digest()
    _synth_with_defaults(["cubesat-periodic"], tmp_path)
    assert {f.name for f in (tmp_path / "artifacts").glob("*.json")} == {
        "cubesat_periodic_satfmu.json", "cubesat_periodic_published.json"}
    assert _shipped_digest() == before


@pytest.mark.slow
@pytest.mark.parametrize("argv", SYNTH_DEFAULT_RUNS[1:], ids=lambda a: a[0])
def test_every_synth_with_defaults_leaves_the_shipped_artifacts_unchanged(argv, tmp_path):
    before = _shipped_digest()
    _synth_with_defaults(argv, tmp_path)
    assert _shipped_digest() == before


@pytest.mark.parametrize("body, message", [
    ('name = "x"\ninertia = [[1, 2, 0], [2, 1, 0], [0, 0, 1]]\n', "not positive definite"),
    ('name = "x"\ninerta = [1, 1, 1]\n', "did you mean 'inertia'"),
    ("name = [", "invalid TOML"),
])
def test_synth_refuses_a_bad_spacecraft_file(body: str, message: str, tmp_path: Path,
                                             capsys: pytest.CaptureFixture) -> None:
    """Before any program is built: exit 2 with the file and the key in the message."""
    f = tmp_path / "sat.toml"
    f.write_text(body)
    for design in (["mrp-hinf"], ["mrp-h2hinf", "--gamma", "1"]):
        assert main(["synth", *design, "--spacecraft", str(f), "--out", str(tmp_path), "--fmu-dir", ""]) == 2
        err = capsys.readouterr().err
        assert str(f) in err and message in err
    assert main(["synth", "mrp-hinf", "--spacecraft", str(tmp_path / "none.toml"), "--fmu-dir", ""]) == 2
    assert "cannot read spacecraft file" in capsys.readouterr().err


def test_synth_mrp_hinf_designs_for_the_spacecraft_file(tmp_path: Path, capsys: pytest.CaptureFixture,
                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    """The CLI passes the spacecraft, the manoeuvre (angle, axis) and the budget to the design;
    the design itself is replaced by a recorder (the real one runs in the examples' tests)."""
    from satfmu.synthesis import designs

    seen = {}

    def fake(plant, **kw):
        seen.update(plant=plant, **kw)
        return designs.Design("mrp-hinf", [], "report of the fake design")

    monkeypatch.setattr(designs, "design_hinf", fake)
    f = tmp_path / "sat.toml"
    f.write_text('name = "own"\ninertia = [[100, 2, -1], [2, 120, 0.5], [-1, 0.5, 80]]\n')
    assert main(["synth", "mrp-hinf", "--spacecraft", str(f), "--angle", "90", "--axis", "0", "0", "2",
                 "--torque-budget", "20", "--name", "own_hinf", "--out", str(tmp_path), "--fmu-dir", ""]) == 0
    assert seen["plant"].tensor[0, 1] == 2.0 and seen["name"] == "own_hinf" and seen["torque_budget"] == 20.0
    assert seen["start"] == pytest.approx({"sigma_0[1]": 0.0, "sigma_0[2]": 0.0, "sigma_0[3]": 0.41421356237})
    assert "report of the fake design" in capsys.readouterr().out


BAD_SCENARIOS = [  # (body after the header, the message); the header is a valid one-FMU scenario
    ('name = "../escape"', "name: '../escape' is not a safe folder name"),
    ('name = "/abs/olute"', "is not a safe folder name"),
    ("profiles = 5", "profiles: must be a list"),
    ("connections = 5", "connections: must be a list"),
    ("record = 5", "record: must be a list"),
    ("stop_time = 1e9", r"more than 1e\+07"),
    ("stop_time = 1e308", r"stop_time: .*inf communication steps.* more than 1e\+07"),
    ("x = " + "[" * 1000 + "]" * 1000, r"invalid TOML \(arrays or tables nested too deep to read\)"),
    ("step_size = 0.3", "is not an integer"),
    ("step_size = -0.1", "step_size: must be a finite number > 0"),
    ("stop_time = 0.0", "stop_time: must be a finite number > 0"),
    ('[[metrics]]\nname = "m"\nkind = "peak"\nsignals = ["plant.phi"]\nmax = "200"', r"metrics\[0\]\.max: must be"),
    ('[fmus.plant]\npath = "zero.fmu"', r"fmus\.plant\.path: FMU file .*zero.fmu is empty \(0 bytes\)"),
    ('[fmus.plant]\nmodel = "mrp_satellite"\nparameters = "x"', "parameters: must be a table"),
    ('[fmus.plant]\nmodel = "mrp_satelite"',
     r"fmus\.plant\.model: no FMU mrp_satelite.fmu .*did you mean 'mrp_satellite'"),
    ('[fmus.plant]\nmodel = "../mrp_satellite"', r"fmus\.plant\.model: '\.\./mrp_satellite' is not a safe folder name"),
    # refused by the master at run time before, now by the checks of run and export-ssp alike
    ('[fmus.ctrl]\nmodel = "mrp_hinf_published"\n[[connections]]\nfrom = "ctrl.u"\nto = "ctrl.omega"',
     r"connections: algebraic loop through direct feedthrough: ctrl.u\[1\] => ctrl.omega\[1\]"),
    ('[[connections]]\nfrom = "plant.omega"\nto = "plant.u"\n[[profiles]]\nto = "plant.u[2]"\n'
     'kind = "constant"\nvalue = 1.0',
     r"profiles\[0\]: input plant.u\[2\] is driven twice \(by connections\[0\] and by profiles\[0\]\)"),
    ('[[connections]]\nfrom = "plant.u"\nto = "plant.u"', r"connections\[0\]: plant.u\[1\] is a input, not an output"),
    ('[[profiles]]\nto = "plant.omega[1]"\nkind = "constant"\nvalue = 1.0',
     r"profiles\[0\]\.to: profile target plant.omega\[1\] is not a Real input"),
    ('[fmus.plant]\nmodel = "mrp_satellite"\nparameters = { n_substeps = 0 }',
     r"fmus\.plant\.parameters\.n_substeps: 0 is outside its declared range \[1, 100000\]"),
    ('[fmus.plant]\nmodel = "mrp_satellite"\nparameters = { n_substeps = 2.5 }',
     r"fmus\.plant\.parameters\.n_substeps: plant.n_substeps is Integer; got 2.5"),
    ('[fmus.plant]\nmodel = "mrp_satellite"\nparameters = { I_q = 1.0 }',
     r"fmus\.plant\.parameters\.I_q: .*has no variable 'I_q'"),
    ('record = ["plant.omega", "plant.omga"]', r"record\[1\]: .*has no variable 'omga'.*did you mean 'omega'"),
    ('record = ["plant.n_substeps"]', r"record\[0\]: plant.n_substeps is Integer; only Real variables can be recorded"),
    ('[[metrics]]\nname = "m"\nkind = "max_difference"\nsignals = ["plant.omega"]\nversus = ["plant.phi"]',
     r"metrics\[0\]\.versus: 1 variables for 3 in 'signals'"),
]
"""Malformed scenarios: (the body after a valid one-plant header, the message as a regular
expression); tests/test_cli_bad_input.py runs each through run, export-ssp and verify."""


def _bad_scenario(tmp_path: Path, body: str) -> Path:
    """A scenario whose later keys (TOML: last one wins is an error, so the header is built per case)."""
    header = {"name": 'name = "bad"', "stop_time": "stop_time = 1.0", "step_size": "step_size = 0.1"}
    lines = [v for k, v in header.items() if not body.startswith(k)]
    fmus = "" if "[fmus.plant]" in body else '\n[fmus.plant]\nmodel = "mrp_satellite"\n'
    (tmp_path / "zero.fmu").write_bytes(b"")
    f = tmp_path / "bad.toml"
    f.write_text("\n".join(lines) + "\n" + (body + "\n" + fmus if not body.startswith("[") else fmus + body) + "\n")
    return f


def test_debug_shows_the_traceback(tmp_path: Path, fmu_dir: Path) -> None:
    f = _bad_scenario(tmp_path, "profiles = 5")
    with pytest.raises(Exception, match="profiles: must be a list"):
        main(["run", str(f), "--fmu-dir", str(fmu_dir), "--debug"])


DOCTORED = [
    # (command, artifact, doctored key, value, what the one-line message says)
    (["analyze", "l2", "{file}"], "mrp_hinf_satfmu", ("certificate", "numbers", "-M - E: min_eig"), -1.0,
     "certificate.numbers['-M - E: min_eig'] = -1: status 'certified' needs >= -1e-06"),
    (["analyze", "l2", "{file}"], "mrp_hinf_satfmu", ("certificate", "numbers", "-M - E: residual"), 10.0,
     "certificate.numbers['-M - E: residual'] = 10: status 'certified' needs <= 1e-06"),
    (["campaign", "demeter", "--artifact", "{file}", "--samples", "10", "--out", "{out}"], "demeter_row1_det",
     ("design", "K", 0, 2), 5000.0, "design.K and gains disagree (largest difference 1651.74 at K_eta[1,1]"),
    (["campaign", "demeter", "--artifact", "{file}", "--samples", "10", "--out", "{out}"], "demeter_row1_det",
     ("certificate", "numbers", "sampled_max_real_pole"), 1.5, "['sampled_max_real_pole'] = 1.5: status 'certified'"),
    (["build", "--fmu-dir", "{out}", "--backend", "native"], "cubesat_periodic_satfmu",
     ("certificate", "numbers", "ms_spectral_radius"), 1.5,
     "['ms_spectral_radius'] = 1.5: status 'certified' needs < 1"),
    (["build", "--fmu-dir", "{out}", "--backend", "native"], "vscmg_lq_servo",
     ("certificate", "numbers", "riccati_residual"), 10.0,
     "['riccati_residual'] = 10: status 'certified' needs <= 1e-08"),
]


@pytest.mark.parametrize("argv,name,key,value,message", DOCTORED,
                         ids=[f"{d[0][0]} {d[1]} {'.'.join(map(str, d[2][1:]))}" for d in DOCTORED])
def test_commands_refuse_an_artifact_that_contradicts_its_claims(argv: list[str], name: str, key: tuple,
                                                                 value: float, message: str, tmp_path: Path,
                                                                 monkeypatch: pytest.MonkeyPatch,
                                                                 capsys: pytest.CaptureFixture) -> None:
    from satfmu.controllers import polynomial

    data = json.loads((paths.SHIPPED_ARTIFACTS / f"{name}.json").read_text())
    target = data
    for k in key[:-1]:
        target = target[k]
    target[key[-1]] = value
    shipped = tmp_path / "shipped"  # `build` builds the shipped artifacts: here, the doctored one
    shipped.mkdir()
    f = shipped / f"{name}.json"
    f.write_text(json.dumps(data))
    monkeypatch.setattr(polynomial, "ARTIFACTS", shipped)
    out = tmp_path / "out"
    code = main([a.format(file=f, out=out) for a in argv])
    err = capsys.readouterr().err
    assert code == 2 and "Traceback" not in err
    assert err.strip().splitlines() == [f"satfmu {argv[0]}: error: {f}: " + err.split(f"{f}: ", 1)[1].strip()]
    assert message in err
    assert not list(out.rglob("*.fmu")) and not list(out.rglob("*.parquet"))  # refused before any work


def test_synth_mrp_sdre_for_a_spacecraft_file(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    # seed 002's method on the user's rigid spacecraft (products of inertia, 20 N m), without the
    # region (52 s for this tensor; tests/test_mrp_sdre.py proves one): fit, checks, artifact
    craft = tmp_path / "bus.toml"
    craft.write_text('name = "bus"\ninertia = [[100, 2, -1], [2, 120, 0.5], [-1, 0.5, 80]]\n'
                     '[actuators]\ntorque_limit = 20.0\n')
    code = main(["synth", "mrp-sdre", "--spacecraft", str(craft), "--skip-region", "--name", "bus_sdre",
                 "--out", str(tmp_path / "art"), "--fmu-dir", ""])
    out = capsys.readouterr().out
    assert code == 0, out
    assert "fit: degree 2" in out and "frozen loops max Re -0.1" in out  # measured -0.162 1/s
    # the shipped online FMU made this servo: the bus's inertia and Bryson's R = I3 / 20^2
    assert "FMU mrp_sdre_online with the parameters I_x = 100, I_y = 120" in out and "R[1] = 0.0025" in out
    art = json.loads((tmp_path / "art" / "bus_sdre.json").read_text())
    assert art["kind"] == "servo_gain_schedule" and art["plant"] == "mrp_satellite"
    assert art["provenance"]["design_plant"]["parameters"]["I_xy"] == 2.0
    assert art["provenance"]["design_plant"]["limits"]["u_max"] == 20.0
