"""The ``satfmu`` command line: build, validate, run, synthesize, analyze.

Usage::

    satfmu --version
    satfmu build [--fmu-dir DIR] [--backend native|python|all] [--fmi 2|3|both] [--jobs N]
    satfmu validate [--fmu-dir DIR]
    satfmu list
    satfmu run SCENARIO [SCENARIO ...] [--backend native|python|fmi3] [--fmu-dir DIR] [--strict] [--allow-stale]
                                       [--out results] [--summary FILE] [--plot]
    satfmu export-ssp SCENARIO [SCENARIO ...] [--backend native|python] [--fmu-dir DIR] [--allow-stale]
                                              [--out results/ssp]
    satfmu verify [SCENARIO ...] [--engines libcosim ecos] [--fmu-dir DIR] [--allow-stale] [--out results/verify]
    satfmu robustness [--fmu NAME ...] [--cycles 1000] [--flips N] [--fmu-dir DIR] [--out results/robustness]
    satfmu synth mrp-hinf [--name mrp_hinf_satfmu] [--samples 20000] [--out controllers/artifacts] [--fmu-dir DIR] ...
    satfmu synth mrp-h2hinf --gamma G [--variant slack|common] [--region 0.45] [--name ...] ...
    satfmu synth mrp-sdre [--spacecraft FILE] [--s-max S] [--w-max W] [--max-degree 2] [--skip-region] [--name ...]
    satfmu synth vscmg-sdre [--grid 23 25] [--max-degree 8] [--cv-tol TOL] [--out ...] [--fmu-dir DIR]
    satfmu synth cubesat-periodic [--gamma G] [--out ...] [--fmu-dir DIR]
    satfmu synth demeter [--spacecraft FILE] [--method Det|Prob] [--axes 1] [--appendages 1] [--model-type 1]
                         [--uncertainty-type 1] [--no-wheels] [--samples 100] [--skip-analysis] [--name ...]
                         [--convention satfmu|romuloc] [--out ...] [--fmu-dir DIR]
    satfmu table1 [--rows 1 2 ...] [--scenarios N] [--convention satfmu|romuloc|both] [--compare] [--out results/table1]
    satfmu figures demeter [--artifact demeter_row1_det] [--samples 100] [--stop 60] [--step 0.001] [--fmu-dir DIR]
                           [--out results/demeter]
    satfmu campaign demeter [--artifact demeter_row1_det] [--samples 100000] [--workers 2 | --scheduler tls://...]
    satfmu campaign scenario SCENARIO [--samples N | --demo] [--workers 2 | --scheduler tls://...] [--seed S]
                             [--chunk C] [--envelope SIGNAL ...] [--points 500] [--fmu-dir DIR]
                             [--out results/campaigns]
        (with --scheduler: [--tls-ca-file PEM] [--tls-cert PEM] [--tls-key PEM], default Dask's config)
    satfmu replay CAMPAIGN_DIR --sample K [--out results/replay] [--fmu-dir DIR]
    satfmu report DIR [DIR ...] [--out results/report.html] [--fmu-dir DIR] [--confidence 0.95] [--worst 5]
                  [--no-histories]
    satfmu detumble [--samples 2000] [--seed 0] [--rates R ...] [--fmu-dir DIR] [--out results/cubesat]
    satfmu analyze sweep [--gammas 1 0.8 ...] [--region 0.45] [--out results/h2hinf_sweep]
    satfmu analyze region [--artifact vscmg_sdre_approx] [--box-q2 LO HI] [--box-w4 LO HI] [--cells 7 6] [--out DIR]
    satfmu analyze l2 CONTROLLER [--rate-max 0.2] [--sigma-max 0.9] [--samples 200000]
    satfmu analyze margins ARTIFACT|SCENARIO [--step S]

``--fmu-dir`` defaults to the user's FMU cache (:func:`satfmu.controllers.paths.fmu_cache`, under
``$SATFMU_HOME``); ``run``, ``export-ssp``, ``verify``, ``figures`` and ``detumble`` build the
FMUs missing there (:func:`satfmu.controllers.catalog.ensure`), ``satfmu build`` brings every FMU up to date
and compiles the co-simulation loop
(:mod:`satfmu.sims.cosim.compiled_loop`).
A controller is named by its artifact (the user's artifacts first, then the shipped ones) or a
``.json`` path.

Exit status: 0 done, 1 a requirement failed (``run``: a metric missed its bound), 2 an error,
printed as one line ``satfmu COMMAND: error: FILE: KEY: ...`` (``--debug``: the traceback).
``run``, ``export-ssp`` and ``verify`` check a scenario alike before any work
(:func:`satfmu.sims.scenario.run.check`: its file, its FMU files, its wiring and parameters) and write
nothing for one they refuse; a stale controller FMU (embedding another artifact than the file
of its name) is rebuilt in the FMU cache and refused elsewhere unless ``--allow-stale``
(:func:`satfmu.sims.scenario.provisioning.ensure_fmus`).

``verify`` runs scenarios (default: every shipped one) in our master, libcosim and ecos and
compares them (:mod:`satfmu.sims.interop.verify`); ``robustness`` drives every FMU through misuse cases
(:mod:`satfmu.sims.robustness`); both exit with status 1 on a failure. ``synth`` runs a design,
writes the controller's artifact and builds its FMUs. ``analyze sweep`` writes the
gamma-lambda trade-off of both Theorem 8 variants of seed 001 (CSV and PNG), ``analyze l2``
the three L2-gain estimates of a controller, ``analyze region`` seed 002's re-posed SOS
stability region of the approximated SDRE on one box and cell by cell (JSON and PNG)
(:mod:`satfmu.sims.workflows.analysis`). ``table1``, ``figures demeter`` and ``campaign demeter`` are seed 004's
(:mod:`satfmu.sims.workflows.demeter_studies`), ``detumble`` seed 003's (:mod:`satfmu.sims.workflows.detumble`).
``campaign scenario`` runs the Monte Carlo samples of a scenario's ``[dispersions]`` and
prints their statistics (:mod:`satfmu.sims.campaign.statistics`); it exits with status 1 when a
sample misses a metric's bound or fails to run. ``report`` writes one self-contained HTML page
of run and campaign folders (:mod:`satfmu.sims.report`). ``replay`` runs one sample of a scenario campaign again
(:func:`satfmu.sims.campaign.replay.replay`: the same FMU files, the same metrics bit for bit) and
writes its CSV and plots; it exits as ``run`` does.

This module imports only the standard library and :mod:`satfmu.controllers.paths` at start (``satfmu
--help`` and ``satfmu list`` stay fast); each handler imports what it needs.
"""
from __future__ import annotations

import argparse
import sys
import time
import tomllib
from pathlib import Path
from typing import Any

from satfmu.fmus.errors import SatfmuError
from satfmu.controllers import paths


class _Formatter(argparse.ArgumentDefaultsHelpFormatter):
    """Help that states each option's default; a help text that states it already is kept as it is."""

    def _get_help_string(self, action: argparse.Action) -> str | None:
        if "default" in (action.help or ""):
            return action.help
        return super()._get_help_string(action)


def _positive_int(text: str) -> int:
    """A count of at least one (``--samples``, ``--workers``)."""
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {text}")
    return value


def _nonnegative_int(text: str) -> int:
    """A count that may be zero, an index or a seed (``--worst``, ``--sample``, ``--seed``)."""
    value = int(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be a non-negative integer, got {text}")
    return value


def _build(args: argparse.Namespace) -> int:
    from satfmu.controllers import catalog
    from satfmu.sims.cosim import compiled_loop

    backends = tuple(b for b in ("native", "python") if args.fmi in ("2", "both") and args.backend in (b, "all"))
    if args.fmi in ("2", "both") and args.backend in ("native", "all"):
        backends += ("me",)  # the plants' model-exchange FMUs (FMI 2.0, native)
    if args.fmi in ("3", "both") and args.backend in ("native", "all"):
        backends += ("fmi3", "me3")  # native only: pythonfmu has no FMI 3.0; me3: the plants' model exchange
    start = time.perf_counter()
    try:
        print(f"co-simulation loop: {compiled_loop.compile_library()}")
    except (FileNotFoundError, RuntimeError) as exc:
        print(f"warning: the co-simulation loop is not compiled ({exc}); runs step in Python", file=sys.stderr)
    report = catalog.build_all(Path(args.fmu_dir), backends, jobs=args.jobs)
    for p in report.built:
        print(f"built {p}")
    print(f"{len(report.paths)} FMUs in {args.fmu_dir}: {len(report.built)} built, "
          f"{len(report.paths) - len(report.built)} up to date ({time.perf_counter() - start:.1f} s)")
    return 0


def _validate(args: argparse.Namespace) -> int:
    # not the hidden temporary file a killed build may leave (satfmu.fmus.atomic)
    fmus = sorted(f for f in Path(args.fmu_dir).glob("*.fmu") if not f.name.startswith("."))
    if not fmus:
        print(f"no FMUs in {args.fmu_dir}: run `satfmu build --fmu-dir {args.fmu_dir}` first, or pass "
              f"--fmu-dir with the folder of your FMUs", file=sys.stderr)
        return 2
    from satfmu.controllers import catalog

    bad = 0
    for f, problems in zip(fmus, catalog.validate_all(fmus)):
        print(f"{'OK  ' if not problems else 'FAIL'} {f}")
        for p in problems:
            print(f"     {p}")
        bad += bool(problems)
    print(f"{len(fmus) - bad} of {len(fmus)} FMUs pass fmpy validate and fmutool -check")
    return 1 if bad else 0


def _run(args: argparse.Namespace) -> int:
    import os
    import warnings

    # the co-simulation runs on one thread (the master limits BLAS to one around its loop): BLAS
    # threads started by numpy's import would only spin, 0.1 s of CPU per run
    for name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(name, "1")

    from satfmu.sims.scenario import metrics
    from satfmu.fmus.errors import DesignMismatchWarning
    from satfmu.sims.scenario.run import run as run_scenario
    from satfmu.sims.scenario.spec import load

    failed = 0
    summaries = []
    warnings.simplefilter("ignore", DesignMismatchWarning)  # printed below, with the run
    for sc in [load(name) for name in args.scenarios]:  # every file read before any run
        res = run_scenario(sc, Path(args.fmu_dir), args.backend, Path(args.out), strict=args.strict,
                           allow_stale=args.allow_stale, plots=args.plot, stream=True)
        summaries.append(res.summary())
        print(f"{'PASS' if res.passed else 'FAIL'} {res.name} ({args.backend})")
        _print_result(res)
        failed += not res.passed
    print(f"{len(args.scenarios) - failed} of {len(args.scenarios)} scenarios pass ({args.backend} FMUs)")
    if args.summary:
        metrics.write_summaries(summaries, Path(args.summary))
    return 1 if failed else 0


def _print_result(res) -> None:
    """The design mismatches, metrics (value, unit, bounds, pass/fail) and files of a run."""
    for line in res.warnings:
        print(f"     warning: design mismatch: {line}")
    for m in res.metrics:
        bounds = " ".join(f"{k} {v:g}" for k, v in (("min", m.min), ("max", m.max)) if v is not None)
        print(f"     {'ok  ' if m.passed else 'FAIL'} {m.name}: {m.value:.6g} {m.unit}  [{bounds}]")
    for k, f in res.files.items():
        print(f"     {k}: {f}")


def _replay(args: argparse.Namespace) -> int:
    import json
    import warnings

    from satfmu.fmus.errors import DesignMismatchWarning
    from satfmu.sims.campaign.replay import replay

    warnings.simplefilter("ignore", DesignMismatchWarning)  # printed below, with the run
    res = replay(args.campaign, args.sample, Path(args.out), args.fmu_dir)
    print(f"{'PASS' if res.passed else 'FAIL'} {args.campaign} sample {args.sample}: {res.name} ({res.backend})")
    dispersed = json.loads(res.files["sample"].read_text())["dispersed"]
    print("     dispersed: " + ", ".join(f"{k} = {v:.6g}" if isinstance(v, float) else f"{k} = {v}"
                                       for k, v in dispersed.items()))
    _print_result(res)
    return 0 if res.passed else 1


def _export_ssp(args: argparse.Namespace) -> int:
    from satfmu.sims.scenario.spec import load
    from satfmu.sims.interop import ssp

    for sc in [load(name) for name in args.scenarios]:  # every file read before any export
        print(f"wrote {ssp.export(sc, Path(args.fmu_dir), Path(args.out), args.backend, args.allow_stale)}")
    return 0


def _verify(args: argparse.Namespace) -> int:
    from satfmu.sims.interop import verify

    run = verify.verify_all(Path(args.fmu_dir), Path(args.out), args.scenarios, args.backend, tuple(args.engines),
                            progress=_progress, allow_stale=args.allow_stale)
    print(run.text())
    if run.failed:
        print(f"failed: {', '.join(run.failed)}", file=sys.stderr)
    return 1 if run.failed else 0


def _robustness(args: argparse.Namespace) -> int:
    from satfmu.sims import robustness

    argv = ["--fmu-dir", args.fmu_dir, "--cycles", str(args.cycles), "--out", args.out]
    for name in args.fmu or []:
        argv += ["--fmu", name]
    if args.flips is not None:
        argv += ["--flips", str(args.flips)]
    return robustness.main(argv)


def _list(args: argparse.Namespace) -> int:
    from satfmu.sims.scenario import shipped_scenarios

    for p in shipped_scenarios():
        with open(p, "rb") as fh:
            data = tomllib.load(fh)
        print(f"{data.get('name', p.stem):28s} {data.get('description', '')}")
    return 0


_PROGRESS = {"open": False}
"""Whether a progress line is on stderr without its newline (an error message then starts a line)."""


def _progress(done: int, total: int, message: str) -> None:
    """A one-line text progress bar on stderr."""
    width = 24
    fill = int(width * done / max(total, 1))
    _PROGRESS["open"] = done < total
    print(f"\r[{'#' * fill}{'.' * (width - fill)}] {done}/{total} {message[:90]:<90}",
          end="" if _PROGRESS["open"] else "\n", file=sys.stderr, flush=True)


def _progress_eta(unit: str) -> Any:
    """A progress callback ``(done, total)`` (called after each chunk) whose bar also gives the
    rate and the time left, estimated from the chunks done since the callback was made (chunks
    resumed from disk are not speed: the first call counts one new chunk)."""
    start: dict[str, float] = {"t": time.perf_counter()}

    def report(done: int, total: int) -> None:
        now = time.perf_counter()
        start.setdefault("done", done - 1)
        rate = (done - start["done"]) / max(now - start["t"], 1e-9)
        left = (total - done) / rate if rate > 0 else float("inf")
        eta = f"{int(left // 60)} min {int(left % 60):02d} s" if left < float("inf") else "?"
        _progress(done, total, f"{unit}, {rate:.2f}/s, {eta} left")
    return report


def _write_design(design, args: argparse.Namespace) -> int:
    """Print a design's report, write its artifacts (and build their FMUs unless ``--fmu-dir ''``)."""
    print(design.summary)
    for f in design.write(args.out, args.fmu_dir or None):
        print(f"{'wrote' if f.suffix == '.json' else 'built'} {f}")
    return 0


def _spacecraft(args: argparse.Namespace):
    """The ``--spacecraft FILE`` description, or None (the seed's satellite)."""
    from satfmu.fmus.plants.spacecraft import Spacecraft

    return Spacecraft.from_toml(args.spacecraft) if args.spacecraft else None


def _synth_hinf(args: argparse.Namespace) -> int:
    from satfmu.synthesis import designs
    from satfmu.synthesis.polynomial_feedback import two_step

    start = two_step.manoeuvre(args.angle, args.axis) if args.angle is not None else None
    return _write_design(designs.design_hinf(
        _spacecraft(args), name=args.name, start=start, torque_budget=args.torque_budget, horizon=args.horizon,
        region=args.region, rate_max=args.rate_max, sigma_max=args.sigma_max,
        coefficient_limit=args.coefficient_limit, n_samples=args.samples, progress=_progress), args)


def _synth_h2hinf(args: argparse.Namespace) -> int:
    from satfmu.synthesis import designs

    return _write_design(designs.design_h2hinf(
        args.gamma, _spacecraft(args), name=args.name, variant=args.variant, region=args.region,
        alpha_range=None if args.alpha_range is None else tuple(args.alpha_range), evaluations=args.evaluations,
        progress=_progress), args)


def _synth_sdre(args: argparse.Namespace) -> int:
    from satfmu.synthesis import designs

    return _write_design(designs.design_sdre(_spacecraft(args), name=args.name, s_max=args.s_max, w_max=args.w_max,
                                             max_degree=args.max_degree, region=not args.skip_region,
                                             progress=_progress), args)


def _synth_vscmg(args: argparse.Namespace) -> int:
    from satfmu.synthesis import designs

    return _write_design(designs.design_vscmg_sdre(tuple(args.grid), args.max_degree, args.cv_tol,
                                                   not args.skip_region, progress=_progress), args)


def _synth_cubesat(args: argparse.Namespace) -> int:
    from satfmu.synthesis import designs

    return _write_design(designs.design_cubesat_periodic(args.gamma, _spacecraft(args), name=args.name,
                                                         published_name=args.published_name), args)


def _synth_demeter(args: argparse.Namespace) -> int:
    from satfmu.fmus.plants.flexible_spacecraft import FlexibleSpacecraft
    from satfmu.synthesis import designs

    plant = FlexibleSpacecraft.from_toml(args.spacecraft) if args.spacecraft else None
    try:
        design = designs.design_demeter(args.axes, args.appendages, args.model_type, args.uncertainty_type,
                                        not args.no_wheels, plant=plant, name=args.name, method=args.method,
                                        n_samples=args.samples,
                                        convention=args.convention, analysis=not args.skip_analysis,
                                        progress=_progress)
    except designs.DesignError as exc:
        if exc.__cause__ is not None:  # bad input or an error of a step: exit 2 as any other
            raise
        print(exc)  # the variant is infeasible: exit 1
        return 1
    return _write_design(design, args)


def _table1(args: argparse.Namespace) -> int:
    from satfmu.sims.workflows import demeter_studies

    if args.compare:
        try:
            print(f"wrote {demeter_studies.table1_comparison(Path(args.out))}")
        except (OSError, ValueError) as exc:
            print(exc)
            return 1
        return 0
    print(demeter_studies.table1(Path(args.out), args.rows, scenarios=args.scenarios, progress=_progress,
                                 convention=args.convention, jobs=args.jobs).text())
    return 0


def _figures_demeter(args: argparse.Namespace) -> int:
    from satfmu.sims.workflows import demeter_studies

    print(demeter_studies.figures(Path(args.fmu_dir), Path(args.out), args.artifact, samples=args.samples,
                                  seed=args.seed, stop_time=args.stop, step_size=args.step,
                                  linear_stop_time=args.linear_stop).text())
    return 0


def _campaign_demeter(args: argparse.Namespace) -> int:
    from satfmu.sims.workflows import demeter_studies

    report = demeter_studies.campaign(Path(args.out), args.artifact, samples=args.samples, seed=args.seed,
                                      chunk=args.chunk, workers=args.workers, scheduler=args.scheduler,
                                      epsilon=args.epsilon, delta=args.delta, name=args.name,
                                      progress=_progress_eta("chunks"), tls=_tls(args))
    print(report.text())
    return 0


def _tls(args: argparse.Namespace) -> Any:
    """The TLS security of ``--tls-*`` (None without them: Dask's configuration then applies)."""
    from satfmu.sims.campaign import cluster

    files = (args.tls_ca_file, args.tls_cert, args.tls_key)
    return cluster.security(*files) if any(files) else None


def _cluster_options(parser: argparse.ArgumentParser) -> None:
    """The options of the cluster a campaign runs on."""
    parser.add_argument("--workers", type=_positive_int, default=2,
                        help="local Dask workers, on 127.0.0.1 (ignored with --scheduler)")
    parser.add_argument("--scheduler", default=None,
                        help="address of a running Dask scheduler: tls://host:port, or tcp://host:port on a trusted "
                             "network (warned off this host: unauthenticated); default: a local cluster")
    parser.add_argument("--tls-ca-file", default=None, metavar="PEM",
                        help="certificate authority of a tls:// scheduler (default: Dask's config, "
                             "distributed.comm.tls.ca-file)")
    parser.add_argument("--tls-cert", default=None, metavar="PEM",
                        help="this client's certificate (default: distributed.comm.tls.client.cert)")
    parser.add_argument("--tls-key", default=None, metavar="PEM",
                        help="this client's private key (default: distributed.comm.tls.client.key)")


def _campaign_scenario(args: argparse.Namespace) -> int:
    if args.scheduler is None:  # a local cluster: its workers' fork server imports while this one does
        from satfmu.sims.campaign import worker_server

        worker_server.start()
    from satfmu.sims.scenario.spec import load
    from satfmu.sims.campaign.results import run_campaign
    from satfmu.sims.campaign.scenario_task import campaign_size

    sc = load(args.scenario)
    samples, seed = campaign_size(sc, args.samples, args.seed, args.demo)
    result = run_campaign(
        sc, samples, args.out, seed=seed, chunk=args.chunk, name=args.name,
        fmu_dir=args.fmu_dir, backend=args.backend, workers=args.workers, scheduler=args.scheduler,
        confidence=args.confidence, worst=args.worst, progress=_progress_eta("chunks"), envelopes=args.envelope or (),
        points=args.points, tls=_tls(args))
    print(result.statistics.text())
    for index, message in result.failures():
        print(f"sample {index}: {message}")
    print(f"results: {result.folder}")
    return 0 if result.passed else 1


def _report(args: argparse.Namespace) -> int:
    from satfmu.sims import report

    out = report.write_report(args.folders, args.out, fmu_dir=args.fmu_dir, confidence=args.confidence,
                              worst=args.worst, histories=not args.no_histories)
    print(f"wrote {out}")
    return 0


def _detumble(args: argparse.Namespace) -> int:
    from satfmu.sims.workflows import detumble

    rates = args.rates or detumble.DEFAULT_RATES
    print(detumble.run(Path(args.fmu_dir), Path(args.out), samples=args.samples, seed=args.seed, rates=rates,
                       progress=_progress).text())
    return 0


def _analyze_sweep(args: argparse.Namespace) -> int:
    from satfmu.sims.workflows import analysis

    alpha_range = None if args.alpha_range is None else tuple(args.alpha_range)
    print(analysis.h2hinf_sweep(Path(args.out), args.gammas, region=args.region, alpha_range=alpha_range,
                                evaluations=args.evaluations, progress=_progress).text())
    return 0


def _analyze_region(args: argparse.Namespace) -> int:
    from satfmu.sims.workflows import analysis

    print(analysis.vscmg_region(Path(args.out), args.artifact, box_q2=args.box_q2, box_w4=args.box_w4,
                                q2=tuple(args.q2), w4=tuple(args.w4), cells=tuple(args.cells),
                                progress=_progress).text())
    return 0


def _analyze_margins(args: argparse.Namespace) -> int:
    from satfmu.sims.workflows import analysis

    print(analysis.margins(args.target, sample_time=args.step).text())
    return 0


def _analyze_l2(args: argparse.Namespace) -> int:
    from satfmu.sims.workflows import analysis

    print(analysis.l2(args.controller, rate_max=args.rate_max, sigma_max=args.sigma_max, kv=args.kv,
                      samples=args.samples).text())
    return 0


ALLOW_STALE = ("use a stale controller FMU (one embedding another artifact than the artifact file of its name) "
               "outside the FMU cache as it is, with a warning; by default it is an error (the cache's are rebuilt)")


def _fmu_dir(parser: argparse.ArgumentParser, help: str = "folder of the FMUs") -> None:
    """Add ``--fmu-dir`` (default: the user's FMU cache, an absolute path) to ``parser``."""
    parser.add_argument("--fmu-dir", default=str(paths.fmu_cache()), help=help)


class _Version(argparse.Action):
    """``--version``: the installed distribution's version, read when asked (importlib.metadata
    costs 40 ms of every command's start otherwise)."""

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace, values: Any,
                 option_string: str | None = None) -> None:
        from importlib import metadata

        print(f"satfmu {metadata.version('satfmu')}")
        parser.exit()


def parser() -> argparse.ArgumentParser:
    """The ``satfmu`` argument parser: every command, every option with its help and default."""
    top = argparse.ArgumentParser(prog="satfmu", description="Spacecraft attitude control FMUs",
                                  formatter_class=_Formatter, allow_abbrev=False)
    top.add_argument("--version", action=_Version, nargs=0, help="show the installed satfmu's version and exit")
    top.add_argument("--debug", action="store_true", default=False, help="show the traceback of an error")
    sub = top.add_subparsers(dest="command", required=True, metavar="COMMAND")

    def command(parent: argparse._SubParsersAction, name: str, help: str, **kw) -> argparse.ArgumentParser:
        # no abbreviations: a retired option (--n, --runs) must fail, not match another (--name)
        p = parent.add_parser(name, help=help, description=help, formatter_class=_Formatter, allow_abbrev=False,
                              **kw)
        p.add_argument("--debug", action="store_true", default=argparse.SUPPRESS, help="show the traceback of an error")
        return p

    backends = sorted(paths.BACKENDS)
    b = command(sub, "build", "build every FMU (only those whose model changed) and the compiled co-simulation loop")
    _fmu_dir(b, "folder the FMUs are built into")
    b.add_argument("--backend", choices=["native", "python", "all"], default="all", help="FMU kind")
    b.add_argument("--fmi", choices=["2", "3", "both"], default="both",
                   help="FMI version: 2 (<name>.fmu, <name>_py.fmu, a plant's model exchange <name>_me.fmu), "
                        "3 (native, <name>_fmi3.fmu, a plant's model exchange <name>_me_fmi3.fmu) or both "
                        "(default)")
    b.add_argument("--jobs", type=_positive_int, default=None, help="parallel build processes (default: one per CPU)")
    b.set_defaults(fn=_build)
    v = command(sub, "validate", "fmpy validate + fmutool -check on every FMU of a folder")
    _fmu_dir(v)
    v.set_defaults(fn=_validate)
    ls = command(sub, "list", "list the shipped scenarios")
    ls.set_defaults(fn=_list)
    scenarios = argparse.ArgumentParser(add_help=False)  # the options of run and export-ssp
    scenarios.add_argument("scenarios", nargs="+", metavar="SCENARIO", help="shipped scenario name or .toml path")
    _fmu_dir(scenarios)
    scenarios.add_argument("--allow-stale", action="store_true", help=ALLOW_STALE)
    r = command(sub, "run", "run scenarios (name of a shipped scenario or a .toml path)", parents=[scenarios])
    r.add_argument("--backend", choices=backends, default="native",
                   help="FMU kind of the instances (fmi3: the native FMUs as FMI 3.0)")
    r.add_argument("--out", default="results", help="folder of the result files (relative: to the working folder)")
    r.add_argument("--plot", action="store_true",
                   help="draw the recorded signals as PNG too (about 1 s of CPU per scenario)")
    r.add_argument("--strict", action="store_true",
                   help="a controller paired with a plant other than its design plant is an error, not a warning")
    r.add_argument("--summary", default=None,
                   help="also write all summaries to this JSON file and beside it as .md (default: none)")
    r.set_defaults(fn=_run)
    ex = command(sub, "export-ssp", "write scenarios as SSP 1.0 files (FMUs, connections, parameters)",
                 parents=[scenarios])
    ex.add_argument("--backend", choices=paths.FMI2_BACKENDS, default="native", help="FMU kind of the instances")
    ex.add_argument("--out", default="results/ssp", help="folder (or .ssp path for one scenario)")
    ex.set_defaults(fn=_export_ssp)
    ve = command(sub, "verify", "run scenarios in our master, libcosim and ecos and compare them")
    ve.add_argument("scenarios", nargs="*", metavar="SCENARIO", help="scenarios (default: every shipped scenario)")
    ve.add_argument("--backend", choices=paths.FMI2_BACKENDS, default="native", help="FMU kind of the instances")
    ve.add_argument("--engines", nargs="+", choices=["libcosim", "ecos"], default=["libcosim", "ecos"],
                    help="engines compared with our master")
    _fmu_dir(ve, "folder of the FMUs (the missing ones are built)")
    ve.add_argument("--allow-stale", action="store_true", help=ALLOW_STALE)
    ve.add_argument("--out", default="results/verify", help="folder of the SSP files and the report")
    ve.set_defaults(fn=_verify)
    rb = command(sub, "robustness", "drive every FMU through misuse cases (table of cases x FMUs)")
    rb.add_argument("--fmu", action="append", help="FMU file name in --fmu-dir (repeatable; default: all)")
    rb.add_argument("--cycles", type=_positive_int, default=1000, help="instantiate/free cycles per FMU")
    rb.add_argument("--flips", type=_nonnegative_int, help="single-bit flips per native FMU state, a seeded sample "
                    "(default: every bit)")
    _fmu_dir(rb)
    rb.add_argument("--out", default="results/robustness", help="folder of the report")
    rb.set_defaults(fn=_robustness)
    sy = command(sub, "synth", "synthesize a controller, write its artifact, build its FMUs")
    designs = sy.add_subparsers(dest="design", required=True, metavar="NAME")
    out = argparse.ArgumentParser(add_help=False)
    out.add_argument("--out", default=str(paths.user_artifacts()),
                     help="folder of the artifact (default: the user's artifact folder, $SATFMU_HOME/artifacts or "
                          f"{paths.user_artifacts()}; scenarios find artifacts there by name)")
    _fmu_dir(out, "build the controller FMUs here ('' to skip)")
    craft = argparse.ArgumentParser(add_help=False)
    craft.add_argument("--spacecraft", metavar="FILE", default=None,
                       help="spacecraft TOML file (name, inertia tensor, [actuators] torque_limit, dipole_limit) to "
                            "design for (default: the seed's own spacecraft; cubesat-periodic: principal moments only)")
    hi = command(designs, "mrp-hinf", "seed 000: two-step nonlinear H-infinity iteration", parents=[out, craft])
    hi.add_argument("--name", default="mrp_hinf_satfmu", help="artifact and FMU name")
    hi.add_argument("--angle", type=float, default=None,
                    help="angle of the rest-to-rest manoeuvre each iterate is judged on, deg "
                         "(default: seed 000's 200 deg start)")
    hi.add_argument("--axis", type=float, nargs=3, default=(1.0, 1.0, 1.0), metavar=("X", "Y", "Z"),
                    help="axis of that manoeuvre, body axes (with --angle)")
    hi.add_argument("--horizon", type=float, default=120.0, help="length of the manoeuvre, s")
    hi.add_argument("--region", type=float, default=0.9, help="Theorem 1 region |sigma| <= r (< 1)")
    hi.add_argument("--rate-max", type=float, default=0.2, help="L2 region |omega_i| <= rate-max, rad/s")
    hi.add_argument("--sigma-max", type=float, default=0.9, help="L2 region |sigma| <= sigma-max")
    hi.add_argument("--coefficient-limit", type=float, default=1.0, help="bound on every K coefficient")
    hi.add_argument("--torque-budget", type=float, default=None,
                    help="largest peak |u_i| on the manoeuvre, N m (default: the --spacecraft's torque_limit, "
                         "else 6.5)")
    hi.add_argument("--samples", type=_positive_int, default=20_000, help="random points of the sampled L2 check")
    hi.set_defaults(fn=_synth_hinf)
    mixed = argparse.ArgumentParser(add_help=False)
    mixed.add_argument("--region", type=float, default=0.45, help="certificate region |sigma| <= r (< 1), any rate")
    mixed.add_argument("--alpha-range", type=float, nargs=2, default=None, metavar=("LOW", "HIGH"),
                       help="line-search interval of alpha and beta, s (default: 0.01 to 1 times the plant's "
                            "time to turn one radian)")
    mixed.add_argument("--evaluations", type=_positive_int, default=12, help="SDPs per line search (alpha, then beta)")
    h2 = command(designs, "mrp-h2hinf", "seed 001: mixed H2/H-infinity (Theorem 8) at one gamma",
                 parents=[out, craft, mixed])
    h2.add_argument("--gamma", type=float, required=True, help="L2-gain bound w -> sigma (required)")
    h2.add_argument("--variant", choices=["slack", "common"], default="slack", help="Theorem 8 variant")
    h2.add_argument("--name", default="mrp_h2hinf_satfmu", help="artifact and FMU name")
    h2.set_defaults(fn=_synth_h2hinf)
    sd = command(designs, "mrp-sdre", "seed 002's method for your rigid spacecraft: SDRE servo, gain fit, SOS region",
                 parents=[out, craft])
    sd.add_argument("--s-max", type=float, default=None, help="MRP bound of the fitted box (default a 90 deg turn)")
    sd.add_argument("--w-max", type=float, default=None,
                    help="rate bound of the fitted box, rad/s (default from the torque limit and inertia)")
    sd.add_argument("--max-degree", type=int, choices=[0, 1, 2], default=2, help="largest fit degree tried")
    sd.add_argument("--skip-region", action="store_true", help="do not solve the SOS stability region")
    sd.add_argument("--name", default="mrp_sdre_servo", help="artifact and FMU name")
    sd.set_defaults(fn=_synth_sdre)
    vs = command(designs, "vscmg-sdre", "seed 002: approximated SDRE (gain fit) and LQ servo artifacts",
                 parents=[out])
    vs.add_argument("--grid", type=_positive_int, nargs=2, default=(23, 25), metavar=("N_Q2", "N_W4"),
                    help="SDRE grid points over q2 and w4")
    vs.add_argument("--max-degree", type=_positive_int, default=8, help="largest polynomial degree tried")
    vs.add_argument("--cv-tol", type=float, default=None,
                    help="choose the smallest degree with this cross-validated relative error "
                         "(default satfmu.synthesis.servo.gain_fit.CV_TOL; 0: the smallest error)")
    vs.add_argument("--skip-region", action="store_true",
                    help="do not solve the SOS stability region (the artifact stays 'sampled')")
    vs.set_defaults(fn=_synth_vscmg)
    cs = command(designs, "cubesat-periodic",
                 "seed 003: periodic stochastic H-infinity gains (Theorem 2) + published gains", parents=[out, craft])
    cs.add_argument("--gamma", type=float, default=None,
                    help="design level (default gamma_min (1 + "
                         "satfmu.synthesis.periodic.cubesat_periodic.GAMMA_MARGIN))")
    cs.add_argument("--name", default="cubesat_periodic_satfmu", help="artifact and FMU name")
    cs.add_argument("--published-name", default="cubesat_periodic_published",
                    help="artifact and FMU name of the published gains")
    cs.set_defaults(fn=_synth_cubesat)
    dm = command(designs, "demeter", "seed 004: robust (Det) or scenario (Prob) state feedback of a variant of "
                                     "DEMETER or of your flexible spacecraft (Table 1)", parents=[out])
    dm.add_argument("--spacecraft", metavar="FILE", default=None,
                    help="flexible spacecraft TOML file (hub inertia and its uncertainty, appendages with their "
                         "modes' coupling, frequency and damping intervals, wheel limits; docs/models.md) to design "
                         "for (default: DEMETER, the seed's)")
    dm.add_argument("--axes", type=_positive_int, nargs="+", default=[1], help="axes, 1-based")
    dm.add_argument("--appendages", type=_positive_int, nargs="+", default=[1], help="appendages, 1-based")
    dm.add_argument("--model-type", type=int, choices=[1, 2], default=1,
                    help="1: independent appendages, 2: identical")
    dm.add_argument("--uncertainty-type", type=int, choices=[1, 2, 3], default=1,
                    help="1: norm-bounded (D-G), 2: intervals (vertices), 3: inertia norm-bounded")
    dm.add_argument("--no-wheels", action="store_true", help="design without the wheel dynamics H(s)")
    dm.add_argument("--samples", type=_positive_int, default=100, help="sampled plants of the independent check")
    dm.add_argument("--method", choices=("Det", "Prob"), default="Det",
                    help="Det: deterministic robust design, certified over the box (default); Prob: scenario design "
                         "on sampled plants (certified when the analysis proves its i2p bound over the box)")
    dm.add_argument("--skip-analysis", action="store_true",
                    help="skip the deterministic analysis of the gain (the design's certificate does not need it; "
                         "minutes for a box of 5 or more parameters)")
    dm.add_argument("--name", default=None,
                    help="artifact and FMU name (default demeter_row1_det or _prob; with --spacecraft "
                         "<spacecraft>_robust or _robust_prob)")
    dm.add_argument("--convention", choices=("satfmu", "romuloc"), default="satfmu",
                    help="LMI forms and objective: ours or the R-RoMulOC toolbox's (default: satfmu)")
    dm.set_defaults(fn=_synth_demeter)
    t1 = command(sub, "table1", "seed 004 Table 1: every row, both methods, beside the seed's numbers")
    t1.add_argument("--rows", type=_positive_int, nargs="+", default=None,
                    help="rows 1..14 in the seed's order (default all)")
    t1.add_argument("--scenarios", type=_positive_int, default=None,
                    help="scenarios per Prob design (default: the Campi-Garatti count, epsilon 0.1, delta 1e-9)")
    t1.add_argument("--convention", choices=("satfmu", "romuloc", "both"), default="satfmu",
                    help="LMI forms and objective of the designs: ours, the R-RoMulOC toolbox's, or both side by "
                         "side in sub-folders (default: satfmu)")
    t1.add_argument("--jobs", type=_positive_int, default=1,
                    help="rows run at once, each in its own process (default 1; 2 on a 2-core machine halves the "
                         "wall time)")
    t1.add_argument("--compare", action="store_true",
                    help="run nothing: write OUT/table1.md from OUT/romuloc/table1.csv and OUT/satfmu/table1.csv")
    t1.add_argument("--out", default="results/table1", help="folder of table1.md and table1.csv")
    t1.set_defaults(fn=_table1)
    fg = command(sub, "figures", "figures of the seeds' papers from the FMUs")
    figs = fg.add_subparsers(dest="figure", required=True, metavar="NAME")
    fd = command(figs, "demeter", "seed 004 Figs 4-5: random closed loops of the DEMETER FMUs")
    fd.add_argument("--artifact", default="demeter_row1_det", help="artifact name or a .json path")
    fd.add_argument("--samples", type=_positive_int, default=100, help="random plants")
    fd.add_argument("--seed", type=_nonnegative_int, default=0, help="seed of the plant samples")
    fd.add_argument("--stop", type=float, default=60.0, help="FMU horizon, s")
    fd.add_argument("--step", type=float, default=1e-3,
                    help="communication step, s (the row-1 design needs <= 1.5 ms; see "
                         "sims/workflows/demeter_loops.py)")
    fd.add_argument("--linear-stop", type=float, default=10000.0, help="design-model horizon, s")
    _fmu_dir(fd, "folder of the FMUs (the missing ones are built)")
    fd.add_argument("--out", default="results/demeter", help="folder of the PNG files")
    fd.set_defaults(fn=_figures_demeter)
    ca = command(sub, "campaign", "Monte Carlo campaigns on Dask (results in Parquet, resumable)")
    kinds = ca.add_subparsers(dest="kind", required=True, metavar="NAME")
    cd = command(kinds, "demeter", "seed 004: closed-loop poles, exact H-infinity and i2p of sampled "
                                   "plants under a design artifact, with the Chernoff statements")
    cd.add_argument("--artifact", default="demeter_row1_det", help="artifact name or a .json path")
    cd.add_argument("--samples", type=_positive_int, default=100_000, help="sampled plants")
    cd.add_argument("--chunk", type=_positive_int, default=5000, help="samples per task and per Parquet file")
    cd.add_argument("--seed", type=_nonnegative_int, default=0,
                    help="root seed (results depend only on seed, chunk, samples)")
    _cluster_options(cd)
    cd.add_argument("--epsilon", type=float, default=0.1, help="accuracy of the statements")
    cd.add_argument("--delta", type=float, default=1e-6, help="1 - confidence of the statements")
    cd.add_argument("--name", default=None,
                    help="campaign (folder) name (default: <artifact>-n<samples>-s<seed>)")
    cd.add_argument("--out", default="results/campaigns", help="folder of the campaign folders")
    cd.set_defaults(fn=_campaign_demeter)
    cs = command(kinds, "scenario", "Monte Carlo campaign of a scenario's [dispersions]: per metric the pass rate "
                                    "(Clopper-Pearson interval), percentiles and the worst samples")
    cs.add_argument("scenario", help="scenario name or .toml file (with a [dispersions] table)")
    size = cs.add_mutually_exclusive_group()
    size.add_argument("--samples", type=_positive_int, default=None,
                      help="number of samples (default: the scenario's [campaign] samples, the full size)")
    size.add_argument("--demo", action="store_true",
                      help="run the scenario's [campaign] demo_samples, a quick look (default: the full size)")
    cs.add_argument("--seed", type=_nonnegative_int, default=None,
                    help="root seed, sample i depends only on seed and i (default: the scenario's [campaign] seed, "
                         "else 0)")
    cs.add_argument("--chunk", type=_positive_int, default=None,
                    help="samples per task and per Parquet file (default: about 100 chunks, 10 to 1000 samples each)")
    _cluster_options(cs)
    cs.add_argument("--backend", choices=backends, default="native", help="default FMU backend")
    cs.add_argument("--confidence", type=float, default=0.95, help="two-sided confidence of the pass-rate intervals")
    cs.add_argument("--worst", type=_nonnegative_int, default=5, help="worst samples listed")
    cs.add_argument("--envelope", action="append", metavar="SIGNAL",
                    help="a recorded signal (base names expand) whose percentile envelope over the samples is kept in "
                         "envelopes.parquet; repeat for more (default: none)")
    cs.add_argument("--points", type=_positive_int, default=500,
                    help="time points of each envelope (default: 500, at most the run's communication points)")
    cs.add_argument("--name", default=None, help="campaign (folder) name (default: <scenario>-n<samples>-s<seed>)")
    _fmu_dir(cs, "folder of the FMUs (the missing ones are built; the workers read them there)")
    cs.add_argument("--out", default="results/campaigns", help="folder of the campaign folders")
    cs.set_defaults(fn=_campaign_scenario)
    rp = command(sub, "report", "one self-contained HTML page of run and scenario campaign folders: metrics, "
                                "time histories with requirement and actuator-limit lines, campaign statistics and "
                                "figures, side-by-side comparison, what each controller's artifact proved, provenance")
    rp.add_argument("folders", nargs="+", metavar="DIR",
                    help="run folders (satfmu run --out: summary_<backend>.json) and scenario campaign folders "
                         "(satfmu campaign scenario --out: campaign.json)")
    rp.add_argument("--out", default="results/report.html", help="the HTML file written")
    rp.add_argument("--fmu-dir", default=None,
                    help="where the FMU files are now (default: the folder each run or campaign used)")
    rp.add_argument("--confidence", type=float, default=0.95, help="two-sided confidence of the pass-rate intervals")
    rp.add_argument("--worst", type=_nonnegative_int, default=5, help="worst samples listed per campaign")
    rp.add_argument("--no-histories", action="store_true",
                    help="do not replay the worst samples to draw their time histories (about 0.5 s a sample)")
    rp.set_defaults(fn=_report)
    ry = command(sub, "replay", "run one sample of a scenario campaign again, bit for bit, and write its time "
                                "histories (CSV) and plots")
    ry.add_argument("campaign", metavar="CAMPAIGN_DIR", help="campaign folder (--out/NAME of campaign scenario)")
    ry.add_argument("--sample", type=_nonnegative_int, required=True,
                    help="sample index, 0 .. samples - 1 (the rows' sample column; required, no default)")
    ry.add_argument("--out", default="results/replay",
                    help="folder of the replays; the run goes to OUT/<campaign>-sample<K>/ (default: results/replay)")
    ry.add_argument("--fmu-dir", default=None,
                    help="folder of the campaign's FMU files, whose SHA-256 must be the ones it ran (default: the "
                         "folder the campaign ran them from, recorded in its campaign.json)")
    ry.set_defaults(fn=_replay)
    dt = command(sub, "detumble", "seed 003: linear Monte Carlo (Fig. 2) and the nonlinear initial-rate sweep")
    dt.add_argument("--samples", type=_positive_int, default=2000, help="Monte Carlo realizations per gain set")
    dt.add_argument("--seed", type=_nonnegative_int, default=0, help="seed of the realizations")
    dt.add_argument("--rates", type=float, nargs="+",
                    help="initial rates |w(0)|, rad/s (default 17 from 1e-4 to 1)")
    _fmu_dir(dt, "folder of the FMUs (the missing ones are built)")
    dt.add_argument("--out", default="results/cubesat", help="folder of the figures and tables")
    dt.set_defaults(fn=_detumble)
    an = command(sub, "analyze", "analyses of a design: L2 gain, SOS region, trade-off sweep")
    analyses = an.add_subparsers(dest="analysis", required=True, metavar="NAME")
    sw = command(analyses, "sweep", "seed 001: gamma-lambda trade-off of Theorem 8 (mrp-h2hinf), both variants",
                 parents=[mixed])
    sw.add_argument("--gammas", type=float, nargs="+", default=[1.0, 0.8, 0.7, 0.6, 0.55],
                    help="L2-gain bounds w -> sigma")
    sw.add_argument("--out", default="results/h2hinf_sweep", help="directory of the CSV and PNG")
    sw.set_defaults(fn=_analyze_sweep)
    rg = command(analyses, "region", "seed 002: SOS stability region of the approximated SDRE (vscmg-sdre), "
                                     "box and map")
    rg.add_argument("--artifact", default="vscmg_sdre_approx", help="artifact name or .json path")
    rg.add_argument("--box-q2", type=float, nargs=2, metavar=("LO", "HI"),
                    help="q2 interval of the one-Y box, rad (default: "
                         "satfmu.synthesis.servo.vscmg_region.OPERATING_BOX)")
    rg.add_argument("--box-w4", type=float, nargs=2, metavar=("LO", "HI"),
                    help="w4 interval of the one-Y box, rad/s (default: OPERATING_BOX)")
    rg.add_argument("--q2", type=float, nargs=2, default=[0.05, 1.52], metavar=("LO", "HI"), help="map range, rad")
    rg.add_argument("--w4", type=float, nargs=2, default=[-1.8, 1.8], metavar=("LO", "HI"), help="map range, rad/s")
    rg.add_argument("--cells", type=_positive_int, nargs=2, default=[7, 6], metavar=("N_Q2", "N_W4"), help="map cells")
    rg.add_argument("--out", default="results/vscmg_region", help="directory of region.json and region.png")
    rg.set_defaults(fn=_analyze_region)
    l2 = command(analyses, "l2", "L2 gain of a controller's closed loop: diagonal, sampled, SOS")
    l2.add_argument("controller", metavar="CONTROLLER", help="artifact name or .json path")
    l2.add_argument("--rate-max", type=float, default=0.2, help="region |omega_i| <= rate-max, rad/s")
    l2.add_argument("--sigma-max", type=float, default=0.9, help="region |sigma| <= sigma-max")
    l2.add_argument("--kv", type=float, default=1e4, help="kv of the diagonal check (the seed's: 1e4)")
    l2.add_argument("--samples", type=_positive_int, default=200_000, help="random points of the sampled estimate")
    l2.set_defaults(fn=_analyze_l2)
    mg = command(analyses, "margins", "linear margins of a controller on its design plant, or of every loop of a "
                 "scenario as wired: loop at a time, disk, sensitivity peaks; continuous and sampled")
    mg.add_argument("target", metavar="ARTIFACT|SCENARIO", help="artifact name or .json path; scenario name or "
                    ".toml path")
    mg.add_argument("--step", type=float, default=None, help="communication step of the sampled loop, s (default: "
                    "the scenario's; 0.05 for an artifact)")
    mg.set_defaults(fn=_analyze_margins)
    return top


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``satfmu`` console script: the command's exit status (0 done, 1 a
    metric missed its bound or a check failed, 2 an error, each error one line on stderr).

    Parameters
    ----------
    argv : list of str, optional
        The arguments after ``satfmu`` (``["run", "mrp_200deg"]``); default ``sys.argv[1:]``.

    Returns
    -------
    int
        The exit status.
    """
    import warnings

    args = parser().parse_args(argv)
    _PROGRESS["open"] = False  # a bar left open by an earlier call in this process is not this one's

    def one_line(message: Warning | str, category: type[Warning], filename: str, lineno: int, file: Any = None,
                 line: str | None = None) -> None:
        print(f"satfmu {args.command}: warning: {message}", file=sys.stderr)

    with warnings.catch_warnings():
        warnings.showwarning = one_line
        try:
            return args.fn(args)
        except Exception as exc:  # every user error: one line, exit 2 (1 means a metric missed its bound)
            if getattr(args, "debug", False):
                raise
            expected = isinstance(exc, (SatfmuError, ValueError, KeyError, RuntimeError, OSError))
            detail = "" if expected else f"{type(exc).__name__}: "
            hint = "" if expected else " (--debug shows the traceback)"
            newline, _PROGRESS["open"] = "\n" if _PROGRESS["open"] else "", False
            print(f"{newline}satfmu {args.command}: error: {detail}{exc}{hint}", file=sys.stderr)
            return 2


if __name__ == "__main__":
    sys.exit(main())
