"""The ``satfmu`` command line: build, validate and run.

    satfmu build [--dest build/fmus] [--backend native|python|all] [--jobs N]
    satfmu validate [--fmu-dir build/fmus]
    satfmu run SCENARIO [SCENARIO ...] [--backend native|python] [--fmu-dir DIR] [--out results]
    satfmu list
    satfmu export-ssp SCENARIO [SCENARIO ...] [--backend native|python] [--fmu-dir DIR] [--out DIR]
    satfmu verify [SCENARIO ...] [--engines libcosim ecos] [--fmu-dir DIR] [--out results/verify]
    satfmu robustness [--fmu NAME ...] [--cycles 1000] [--fmu-dir DIR] [--out results/robustness]
    satfmu synth mrp-hinf [--name mrp_hinf_satfmu] [--out controllers/artifacts] [--fmu-dir DIR] ...
    satfmu synth mrp-h2hinf --gamma G [--variant slack|common] [--region 0.45] [--name ...] ...
    satfmu synth vscmg-sdre [--grid 23 25] [--max-degree 8] [--cv-tol TOL] [--out ...] [--fmu-dir DIR]
    satfmu synth cubesat-periodic [--gamma G] [--out ...] [--fmu-dir DIR]
    satfmu table1 [--rows 1 2 ...] [--scenarios N] [--out results/table1]
    satfmu figures demeter [--n 100] [--stop 60] [--step 0.001] [--out results/demeter]
    satfmu campaign demeter [--artifact demeter_row1_det] [--n 100000] [--workers 2] [--scheduler tcp://...]
    satfmu synth demeter [--axes 1] [--appendages 1] [--model-type 1] [--uncertainty-type 1] [--no-wheels]
                         [--samples 100] [--name demeter_row1_det] [--out ...] [--fmu-dir DIR]
    satfmu detumble [--runs 2000] [--seed 0] [--rates R ...] [--fmu-dir DIR] [--out results/cubesat]
    satfmu sweep mrp-h2hinf [--gammas 1 0.8 ...] [--region 0.45] [--out results/h2hinf_sweep]
    satfmu l2 CONTROLLER [--rate-max 0.2] [--sigma-max 0.9] [--samples 200000]
    satfmu region vscmg-sdre [--artifact NAME] [--box-q2 LO HI] [--box-w4 LO HI] [--cells 7 6] [--out DIR]

``run`` exits with status 1 when a metric misses its bound, 2 on an error. ``verify`` runs
scenarios (default: every shipped one) in our master, libcosim and ecos and compares them
(:mod:`sims.verify`); ``robustness`` drives every FMU through misuse cases
(:mod:`sims.robustness`); both exit with status 1 on a failure. ``synth``
runs a design (seed 000's two-step iteration, or seed 001's Theorem 8 with its alpha/beta
search and closed-loop check), writes the controller's artifact and builds its FMUs.
``sweep`` writes the gamma-lambda trade-off of both Theorem 8 variants (CSV and PNG). ``l2`` reports the three L2-gain estimates of a controller (name of a shipped
artifact or a .json path). ``region`` solves seed 002's re-posed SOS stability region on
one box and maps it cell by cell (JSON and PNG).
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

from sims import catalog, scenario


def _positive_int(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {text}")
    return value


def _build(args: argparse.Namespace) -> int:
    backends = ("native", "python") if args.backend == "all" else (args.backend,)
    start = time.perf_counter()
    report = catalog.build_all(Path(args.dest), backends, jobs=args.jobs)
    for p in report.built:
        print(f"built {p}")
    print(f"{len(report.paths)} FMUs in {args.dest}: {len(report.built)} built, "
          f"{len(report.paths) - len(report.built)} up to date ({time.perf_counter() - start:.1f} s)")
    return 0


def _validate(args: argparse.Namespace) -> int:
    fmus = sorted(Path(args.fmu_dir).glob("*.fmu"))
    if not fmus:
        print(f"no FMUs in {args.fmu_dir}; run `satfmu build` first", file=sys.stderr)
        return 2
    bad = 0
    for f, problems in zip(fmus, catalog.validate_all(fmus)):
        print(f"{'OK  ' if not problems else 'FAIL'} {f}")
        for p in problems:
            print(f"     {p}")
        bad += bool(problems)
    print(f"{len(fmus) - bad} of {len(fmus)} FMUs pass fmpy validate and fmutool -check")
    return 1 if bad else 0


def _run(args: argparse.Namespace) -> int:
    failed = 0
    summaries = []
    for name in args.scenarios:
        res = scenario.run(name, Path(args.fmu_dir), args.backend, Path(args.out))
        summaries.append(res.summary())
        print(f"{'PASS' if res.passed else 'FAIL'} {res.name} ({args.backend})")
        for m in res.metrics:
            bounds = " ".join(f"{k} {v:g}" for k, v in (("min", m.min), ("max", m.max)) if v is not None)
            print(f"     {'ok  ' if m.passed else 'FAIL'} {m.name}: {m.value:.6g} {m.unit}  [{bounds}]")
        for k, f in res.files.items():
            print(f"     {k}: {f}")
        failed += not res.passed
    print(f"{len(args.scenarios) - failed} of {len(args.scenarios)} scenarios pass ({args.backend} FMUs)")
    if args.summary:
        path = Path(args.summary)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(summaries, indent=1) + "\n")
        path.with_suffix(".md").write_text(_markdown(summaries))
    return 1 if failed else 0


def _export_ssp(args: argparse.Namespace) -> int:
    from sims import ssp

    failed = 0
    for name in args.scenarios:
        try:
            print(f"wrote {ssp.export(name, Path(args.fmu_dir), Path(args.out), args.backend)}")
        except ssp.SspError as exc:
            print(f"error: {exc}", file=sys.stderr)
            failed += 1
    return 1 if failed else 0


def _verify(args: argparse.Namespace) -> int:
    from sims import verify

    names = args.scenarios or sorted(p.stem for p in scenario.SCENARIOS.glob("*.toml"))
    reports = []
    for name in names:
        print(f"verifying {name} ...", file=sys.stderr, flush=True)
        reports.append(verify.verify(name, Path(args.fmu_dir), Path(args.out), args.backend, tuple(args.engines)))
        print(verify.markdown(reports[-1:]).split("\n\n")[0], flush=True)
    md, js = verify.write(reports, Path(args.out))
    failed = [r.scenario for r in reports if not r.passed]
    print(f"{len(reports) - len(failed)}/{len(reports)} scenarios pass; report: {md}, {js}")
    if failed:
        print(f"failed: {', '.join(failed)}", file=sys.stderr)
    return 1 if failed else 0


def _robustness(args: argparse.Namespace) -> int:
    from sims import robustness

    argv = ["--fmu-dir", args.fmu_dir, "--cycles", str(args.cycles), "--out", args.out]
    for name in args.fmu or []:
        argv += ["--fmu", name]
    return robustness.main(argv)


def _markdown(summaries: list[dict]) -> str:
    """The run summaries as a Markdown table (one row per metric)."""
    lines = ["| scenario | backend | metric | value | unit | bounds | result |", "|---|---|---|---|---|---|---|"]
    for s in summaries:
        for m in s["metrics"]:
            bounds = " ".join(f"{k} {m[k]:g}" for k in ("min", "max") if m[k] is not None)
            lines.append(f"| {s['scenario']} | {s['backend']} | {m['name']} | {m['value']:.6g} | {m['unit']} | "
                         f"{bounds} | {'pass' if m['passed'] else 'FAIL'} |")
    return "\n".join(lines) + "\n"


def _list(args: argparse.Namespace) -> int:
    for p in sorted(scenario.SCENARIOS.glob("*.toml")):
        s = scenario.load(p)
        print(f"{s.name:28s} {s.data.get('description', '')}")
    return 0


def _progress(done: int, total: int, message: str) -> None:
    """A one-line text progress bar on stderr."""
    width = 24
    fill = int(width * done / max(total, 1))
    end = "\n" if done >= total else ""
    print(f"\r[{'#' * fill}{'.' * (width - fill)}] {done}/{total} {message[:90]:<90}", end=end,
          file=sys.stderr, flush=True)


def _save_and_build(data: dict, args: argparse.Namespace) -> None:
    """Validate and write an artifact, then build its native and pythonfmu FMUs."""
    from controllers import artifact as artifacts
    from fmus import export

    art = artifacts.parse(data, where=args.name)
    out = Path(args.out) / f"{args.name}.json"
    out.parent.mkdir(parents=True, exist_ok=True)
    artifacts.save(art, out)
    print(f"wrote {out}")
    if args.fmu_dir:
        src = catalog.controller_source(art)
        for build in (export.build_native, export.build_python):
            print(f"built {build(src.model, Path(args.fmu_dir), src.resources)}")


def _synth(args: argparse.Namespace) -> int:
    from synthesis import l2_gain, two_step

    result = two_step.two_step(region=args.region, l2_region=l2_gain.Region(args.rate_max, args.sigma_max),
                               coefficient_limit=args.coefficient_limit, torque_budget=args.torque_budget,
                               n_samples=args.samples, progress=_progress)
    print(result.table())
    _save_and_build(result.artifact_data(args.name), args)
    return 0


def _synth_h2hinf(args: argparse.Namespace) -> int:
    from synthesis import h2hinf_sos

    found = h2hinf_sos.search(args.gamma, args.variant, bounds=tuple(args.alpha_range),
                              max_evaluations=args.evaluations, progress=_progress, region=args.region)
    r = found.best
    if r is None:
        raise RuntimeError(f"no certified {args.variant} design at gamma = {args.gamma:g} on |sigma| <= "
                           f"{args.region:g} ({len(found.evaluations)} SDPs; try a larger gamma or region)")
    check = h2hinf_sos.closed_loop_check(r)
    print(f"{r.proved}\n  alpha = {r.alpha:.4g}, beta = {r.beta:.4g}, {len(found.evaluations)} SDPs; "
          f"simulated J2 = {check.j2:.4f} over {check.stop_time:g} s (bound {r.lam:.4f}), max |sigma| "
          f"{check.max_tilde:.4f}, linearization max Re eig {check.max_real_eig:.4f} 1/s")
    if not check.passed:
        raise RuntimeError("the closed-loop check failed: the design is not saved")
    _save_and_build(h2hinf_sos.artifact_data(r, args.name, check), args)
    return 0


def _synth_vscmg(args: argparse.Namespace) -> int:
    from synthesis import gain_fit

    tol = {} if args.cv_tol is None else {"cv_tol": args.cv_tol if args.cv_tol > 0 else None}
    result, approx, lq = gain_fit.synthesize(*args.grid, degrees=range(1, args.max_degree + 1),
                                             region=not args.skip_region, **tol)
    print(f"certificate: {approx['certificate']['status']}: {approx['certificate']['proved']}")
    print(gain_fit.table(result, {k: v for k, v in approx["certificate"]["numbers"].items()
                                  if not k.startswith("fit_")}))
    for data in (approx, lq):
        _save_and_build(data, argparse.Namespace(**{**vars(args), "name": data["name"]}))
    return 0


def _synth_cubesat(args: argparse.Namespace) -> int:
    from synthesis import cubesat_periodic

    r = cubesat_periodic.synthesize(args.gamma)
    lo, hi, n = r.bracket
    print(f"seed 003 Theorem 2: gamma_min {r.gamma_min:.4f} (minimized); bisection bracket [{lo:.4f}, {hi:.4f}] "
          f"in {n} solves; the seed's gamma {cubesat_periodic.GAMMA_SEED:g} is "
          f"{'feasible' if r.numbers['seed_gamma_feasible'] else 'infeasible'}")
    for k, v in r.numbers.items():
        print(f"  {k}: {v:.6g}")
    print("  gains F(k) (rows m_x, m_y, m_z; columns omega_x, omega_y, omega_z), ours | published:")
    for k, (f, p) in enumerate(zip(r.design.F, cubesat_periodic.PUBLISHED_GAINS)):
        for i in range(3):
            print(f"    k={k} " + " ".join(f"{v:8.4f}" for v in f[i]) + "  | " + " ".join(f"{v:8.4f}" for v in p[i]))
    _save_and_build(r.artifact_data(args.name, r.design.F, r.design.gamma, r.design.check, "satfmu"),
                    argparse.Namespace(**vars(args)))
    if r.published is not None:
        data = r.artifact_data(args.published_name, cubesat_periodic.PUBLISHED_GAINS, r.published.gamma,
                               r.published.check, "published (seed 003, gains as printed)")
        _save_and_build(data, argparse.Namespace(**{**vars(args), "name": args.published_name}))
    return 0


def _synth_demeter(args: argparse.Namespace) -> int:
    from synthesis import demeter_design as dd
    from synthesis import demeter_table
    from synthesis.demeter_variants import Variant

    variant = Variant(tuple(args.axes), tuple(args.appendages), args.model_type, args.uncertainty_type,
                      not args.no_wheels)
    row = demeter_table.run_row(variant, "Det", n_samples=args.samples)
    print(demeter_table.markdown([row]))
    r = row.result
    if r.feasible:
        c = r.check
        common = getattr(r.analysis_hinf_common, "gamma", None)
        print(f"{c.n} sampled plants (seed {c.seed}): Re s in [{c.min_real_pole:.3g}, {c.max_real_pole:.3g}] 1/s, "
              f"largest exact H-infinity {c.hinf.max():.4g}, i2p {c.i2p.max():.4g}; H-infinity bound with one "
              f"Lyapunov matrix: {'none' if common is None else format(common, '.4g')}")
    else:
        if r.obstruction is not None and r.obstruction.proves_infeasible:
            o = r.obstruction
            print(f"infeasible for any common-Lyapunov design: at coincident omega, {o.n_free} combination(s) of "
                  f"the modes are free oscillators; over omega in [{o.omega[0]:.4g}, {o.omega[1]:.4g}] rad/s they "
                  f"need zeta > {o.required_zeta:.4g} (the box has zeta <= {o.zeta:g}); eig(A_lo A_hi) = "
                  f"{', '.join(f'{v.real:.4g}' for v in o.eigenvalues)}")
        return 1
    _save_and_build(dd.artifact_data(r, args.name), args)
    return 0


def _campaign_demeter(args: argparse.Namespace) -> int:
    import numpy as np

    from sims import campaign, demeter_loops
    from synthesis import demeter_design as dd
    from synthesis import demeter_random as dr

    art, variant = demeter_loops.load_design(args.artifact)
    task = dr.ClosedLoopSamples(variant, np.array(art.design["K"]))
    camp = campaign.Campaign(name=args.name or f"{art.name}-n{args.n}-s{args.seed}", task=task, n=args.n,
                             seed=args.seed, chunk=args.chunk,
                             sampler=dr.BoxSampler(len(task.design_model().parameters)))
    df = campaign.run(camp, Path(args.out), scheduler=args.scheduler, n_workers=args.workers,
                      progress=lambda done, total: _progress(done, total, camp.name))
    numbers = art.certificate.get("numbers", {})
    levels = {"hinf": numbers.get("analysis_hinf_pdlf"), "i2p": numbers.get("analysis_i2p"),
              "max_real_pole": -dd.ALPHA}
    for column, level in levels.items():
        print(campaign.summarize(df, column, level=level, epsilon=args.epsilon, delta=args.delta).text())
    return 0


def _table1(args: argparse.Namespace) -> int:
    from synthesis import demeter_table
    from synthesis.demeter_variants import SEED_TABLE1

    keys = list(SEED_TABLE1)
    if args.rows:
        bad = [r for r in args.rows if not 1 <= r <= len(keys)]
        if bad:
            raise ValueError(f"rows must be in 1..{len(keys)} (the seed's order), got {bad}")
        keys = [keys[r - 1] for r in args.rows]
    rows = demeter_table.run(keys, n_scenarios=args.scenarios, progress=_progress, out_dir=Path(args.out))
    print(demeter_table.markdown(rows))
    print(f"wrote {Path(args.out) / 'table1.md'}, {Path(args.out) / 'table1.csv'}")
    return 0


def _figures_demeter(args: argparse.Namespace) -> int:
    import numpy as np

    from sims import demeter_loops

    art = args.artifact
    out = Path(args.out)
    for limits in ("wheels", "linear"):
        loops = demeter_loops.run(Path(args.fmu_dir), art, n=args.n, seed=args.seed, stop_time=args.stop,
                                  step_size=args.step, limits=limits)
        paths = demeter_loops.plot(loops, out)
        extra = (f"largest |theta - exact design model| {loops.linear_error:.3g} rad" if limits == "linear" else
                 f"time at the momentum limit: up to {100 * loops.saturated.max():.3g} % of the run")
        print(f"FMUs ({'wheel limits' if limits == 'wheels' else 'no limits'}), {args.n} loops, {args.stop:g} s at "
              f"{args.step:g} s: peak |z2| {np.abs(loops.z2).max():.4g} N m s, |theta| at the end <= "
              f"{np.abs(loops.theta[:, -1]).max():.4g} rad; {extra}; {', '.join(map(str, paths))}")
    loops = demeter_loops.linear(art, n=args.n, seed=args.seed, stop_time=args.linear_stop)
    paths = demeter_loops.plot(loops, out)
    print(f"design model, {args.n} loops, {args.linear_stop:g} s: peak |z2| {np.abs(loops.z2).max():.4g} N m s, "
          f"|theta| at the end <= {np.abs(loops.theta[:, -1]).max():.4g} rad; {', '.join(map(str, paths))}")
    return 0


def _detumble(args: argparse.Namespace) -> int:
    import numpy as np

    from controllers import artifact as artifacts
    from controllers.polynomial import ARTIFACTS
    from sims import detumble, plots

    gains = {label: artifacts.load(ARTIFACTS / f"{name}.json").gains
             for label, name in (("satfmu", "cubesat_periodic_satfmu"), ("published", "cubesat_periodic_published"))}
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    runs = detumble.linear_campaign(gains, args.runs, args.seed)
    print(f"(a) linear sampled model, {args.runs} seeded realizations each, w(0) = {detumble.W0_DIRECTION.tolist()} rad/s")
    for r in runs:
        n = r.k[-1] // 2
        per_orbit = r.ms_exact[2 * n] / r.ms_exact[n]
        print(f"  {r.label}: ESMS spectral radius {r.spectral_radius:.4g}; RMS |w| {r.rms()[0]:.4g} -> "
              f"{r.rms()[n]:.3g} (1 orbit) -> {r.rms()[-1]:.3g} rad/s (2 orbits); E|w|^2 orbit 2 / orbit 1 "
              f"{per_orbit:.3g}; Monte Carlo vs exact at 2 orbits: {r.ms_mc[-1]:.3g} +- {r.ms_se[-1]:.2g} vs "
              f"{r.ms_exact[-1]:.3g}")
    plots.detumble_linear(runs, out / "linear_fig2.png", "Seed 003 Fig. 2 analogue: linear periodic model with "
                          "multiplicative noises, rates and held dipoles at the 15-min samples")
    rates = args.rates or list(np.geomspace(1e-4, 1.0, 17))
    rows = detumble.sweep(Path(args.fmu_dir), rates, progress=_progress)
    table = detumble.sweep_table(rows)
    (out / "sweep.md").write_text(table)
    with open(out / "sweep.csv", "w") as fh:
        fh.write("controller,w0_rad_s,final_ratio,min_ratio,effort_A2m4s,detumbled\n")
        for r in rows:
            fh.write(f"{r.controller},{r.w0:.6g},{r.final_ratio:.6g},{r.min_ratio:.6g},{r.effort:.6g},{r.detumbled}\n")
    plots.detumble_sweep(rows, out / "sweep.png", "Seed 003 on the nonlinear plant: two orbits from |w(0)| "
                         "along [0.05, -0.04, 0.03]")
    print("(b) nonlinear plant through the master, two orbits:\n" + table, end="")
    for label, (low, high) in detumble.detumbled_band(rows).items():
        band = f"{low:.3g} to {high:.3g} rad/s" if math.isfinite(high) else "none of the swept rates"
        print(f"  {label}: |w(0)| detumbled 10x within two orbits: {band}")
    print(f"wrote {out / 'linear_fig2.png'}, {out / 'sweep.md'}, {out / 'sweep.csv'}, {out / 'sweep.png'}")
    return 0


def _sweep(args: argparse.Namespace) -> int:
    from synthesis import h2hinf_sos
    from sims import plots

    rows = h2hinf_sos.sweep(args.gammas, bounds=tuple(args.alpha_range), max_evaluations=args.evaluations,
                            progress=_progress, region=args.region)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    with open(out / "gamma_lambda.csv", "w") as fh:
        fh.write(h2hinf_sos.sweep_csv(rows))
    plots.tradeoff(rows, out / "gamma_lambda.png",
                   f"Seed 001 Theorem 8 on |sigma| <= {args.region:g}: certified H2 bound vs gamma")
    print(h2hinf_sos.sweep_csv(rows), end="")
    print(f"wrote {out / 'gamma_lambda.csv'} and {out / 'gamma_lambda.png'}")
    return 0


def _region(args: argparse.Namespace) -> int:
    import numpy as np

    from controllers import artifact as artifacts
    from controllers.polynomial import ARTIFACTS
    from fmus.profiles import make
    from sims import plots
    from synthesis import vscmg_region
    from synthesis.sdre import SEED_REFERENCE_PROFILES, simulate_servo

    path = Path(args.artifact) if args.artifact.endswith(".json") else ARTIFACTS / f"{args.artifact}.json"
    art = artifacts.load(path)
    loop = vscmg_region.ClosedLoop.build(art)
    box_q2, box_w4 = (tuple(b) if b else d for b, d in zip((args.box_q2, args.box_w4), vscmg_region.OPERATING_BOX))
    box = vscmg_region.certify(loop, box_q2, box_w4)
    trig = vscmg_region.trig_check(loop, box) if box.Y is not None else {}
    print(f"box q2 {box.q2} w4 {box.w4}: {box.message}; eps {box.eps:.4g}, decay bound {box.decay:.4g} 1/s, "
          f"margin {box.margin:.4g}, {box.seconds:.0f} s")
    for k, v in {**trig, **vscmg_region.cos_errors(box.q2)}.items():
        print(f"  {k}: {v:.4g}")
    cells = vscmg_region.map_region(loop, np.linspace(*args.q2, args.cells[0] + 1),
                                    np.linspace(*args.w4, args.cells[1] + 1), progress=_progress)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "region.json").write_text(json.dumps(vscmg_region.region_data(loop, box, trig, cells), indent=1))
    refs = [make(SEED_REFERENCE_PROFILES[n]) for n in ("q2_ref", "q4_ref")]
    run = simulate_servo(lambda x: art.gain_at(art.scheduling_values({"q2": x[1], "w4": x[5]})),
                         lambda t: np.stack([r.sample(t) for r in refs], axis=1), plant_params={"friction_on": 0})
    plots.region_map(cells, out / "region.png", [box], (run.x[:, 1], run.x[:, 5]),
                     f"Seed 002 section 4 re-posed: SOS stability region of {art.name} (frozen SDC loop off p4)")
    print(f"cells certified: {sum(c.certified for c in cells)}/{len(cells)}; "
          f"wrote {out / 'region.json'} and {out / 'region.png'}")
    return 0


def _l2(args: argparse.Namespace) -> int:
    from controllers import artifact as artifacts
    from controllers import polynomial
    from synthesis import l2_gain
    from synthesis.sos import SOSError

    path = Path(args.controller)
    if path.suffix != ".json":
        path = polynomial.ARTIFACTS / f"{args.controller}.json"
    form = l2_gain.hji_form(artifacts.load(path))
    region = l2_gain.Region(args.rate_max, args.sigma_max)
    c_pub, kv_pub = l2_gain.diagonal_gain(form, args.kv)
    c_diag, kv_diag = l2_gain.diagonal_gain(form)
    print(f"{form.controller}: L2 gain c from the HJI inequality, V = kv x^T P x, z = sigma")
    print(f"  diagonal x1=...=x6 in [-10, 10] (seed 000's method): c = {c_pub:.4f} at kv = {kv_pub:g}; "
          f"best c = {c_diag:.4f} at kv = {kv_diag:.4g}")
    smp = l2_gain.sampled_gain(form, region, n_samples=args.samples)
    found = f"c >= {smp.c:.4f} at kv = {smp.kv:.4g}" if math.isfinite(smp.c) else "no finite c for any kv"
    print(f"  sampled on {region.label} ({smp.n_samples} random points + adversarial search, origin limit "
          f"{smp.origin_c:.4g}): {found}")
    if smp.note:
        print(f"    {smp.note}; worst point x = {[float(f'{v:.3g}') for v in smp.worst_point]}")
    try:
        g = l2_gain.sos_gain(form, region)
        print(f"  SOS certificate of H <= 0 on {region.label}: c <= {g.c:.4f} at kv = {g.kv:.4g} "
              f"({'certified' if g.certified else 'NOT certified'}: min Gram eigenvalue "
              f"{min(ch.min_eig for ch in g.checks):.2e}, residual {max(ch.residual for ch in g.checks):.2e}; "
              f"{g.n_programs} SDPs, {g.timings['solve']:.1f} s)")
    except SOSError as exc:
        print(f"  SOS certificate of H <= 0 on {region.label}: none ({exc})")
    return 0


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``satfmu`` console script."""
    parser = argparse.ArgumentParser(prog="satfmu", description="Spacecraft attitude control FMUs")
    sub = parser.add_subparsers(dest="command", required=True)
    b = sub.add_parser("build", help="build every FMU")
    b.add_argument("--dest", default=str(catalog.DEFAULT_FMU_DIR))
    b.add_argument("--backend", choices=["native", "python", "all"], default="all")
    b.add_argument("--jobs", type=_positive_int, default=None,
                   help="parallel build processes (default: one per CPU)")
    b.set_defaults(fn=_build)
    v = sub.add_parser("validate", help="fmpy validate + fmutool -check on every built FMU")
    v.add_argument("--fmu-dir", default=str(catalog.DEFAULT_FMU_DIR))
    v.set_defaults(fn=_validate)
    r = sub.add_parser("run", help="run scenarios (name of a shipped scenario or a .toml path)")
    r.add_argument("scenarios", nargs="+")
    r.add_argument("--backend", choices=sorted(scenario.BACKENDS), default="native")
    r.add_argument("--fmu-dir", default=str(catalog.DEFAULT_FMU_DIR))
    r.add_argument("--out", default="results")
    r.add_argument("--summary", help="also write all summaries to this JSON file")
    r.set_defaults(fn=_run)
    ex = sub.add_parser("export-ssp", help="write scenarios as SSP 1.0 files (FMUs, connections, parameters)")
    ex.add_argument("scenarios", nargs="+")
    ex.add_argument("--backend", choices=sorted(scenario.BACKENDS), default="native")
    ex.add_argument("--fmu-dir", default=str(catalog.DEFAULT_FMU_DIR))
    ex.add_argument("--out", default="results/ssp", help="folder (or .ssp path for one scenario)")
    ex.set_defaults(fn=_export_ssp)
    ve = sub.add_parser("verify", help="run scenarios in our master, libcosim and ecos and compare them")
    ve.add_argument("scenarios", nargs="*", help="default: every shipped scenario")
    ve.add_argument("--backend", choices=sorted(scenario.BACKENDS), default="native")
    ve.add_argument("--engines", nargs="+", choices=["libcosim", "ecos"], default=["libcosim", "ecos"])
    ve.add_argument("--fmu-dir", default=str(catalog.DEFAULT_FMU_DIR))
    ve.add_argument("--out", default="results/verify", help="folder of the SSP files and the report")
    ve.set_defaults(fn=_verify)
    rb = sub.add_parser("robustness", help="drive every FMU through misuse cases (table of cases x FMUs)")
    rb.add_argument("--fmu", action="append", help="FMU file name in --fmu-dir (repeatable; default: all)")
    rb.add_argument("--cycles", type=int, default=1000, help="instantiate/free cycles per FMU")
    rb.add_argument("--fmu-dir", default=str(catalog.DEFAULT_FMU_DIR))
    rb.add_argument("--out", default="results/robustness")
    rb.set_defaults(fn=_robustness)
    ls = sub.add_parser("list", help="list the shipped scenarios")
    ls.set_defaults(fn=_list)
    sy = sub.add_parser("synth", help="synthesize a controller, write its artifact, build its FMUs")
    designs = sy.add_subparsers(dest="design", required=True)
    out = argparse.ArgumentParser(add_help=False)
    out.add_argument("--out", default="controllers/artifacts", help="directory of the artifact")
    out.add_argument("--fmu-dir", default=str(catalog.DEFAULT_FMU_DIR),
                     help="build the controller FMUs here ('' to skip)")
    hi = designs.add_parser("mrp-hinf", parents=[out], help="seed 000: two-step nonlinear H-infinity iteration")
    hi.add_argument("--name", default="mrp_hinf_satfmu", help="artifact and FMU name")
    hi.add_argument("--region", type=float, default=0.9, help="Theorem 1 region |sigma| <= r (< 1)")
    hi.add_argument("--rate-max", type=float, default=0.2, help="L2 region |omega_i| <= rate-max, rad/s")
    hi.add_argument("--sigma-max", type=float, default=0.9, help="L2 region |sigma| <= sigma-max")
    hi.add_argument("--coefficient-limit", type=float, default=1.0, help="bound on every K coefficient")
    hi.add_argument("--torque-budget", type=float, default=6.5,
                    help="largest peak |u_i| on the 200 deg manoeuvre, N m")
    hi.add_argument("--samples", type=int, default=20_000, help="random points of the sampled L2 check")
    hi.set_defaults(fn=_synth)
    mixed = argparse.ArgumentParser(add_help=False)
    mixed.add_argument("--region", type=float, default=0.45, help="certificate region |sigma| <= r (< 1), any rate")
    mixed.add_argument("--alpha-range", type=float, nargs=2, default=(0.05, 2.0), metavar=("LOW", "HIGH"),
                       help="line-search interval of alpha and beta")
    mixed.add_argument("--evaluations", type=int, default=12, help="SDPs per line search (alpha, then beta)")
    h2 = designs.add_parser("mrp-h2hinf", parents=[out, mixed],
                            help="seed 001: mixed H2/H-infinity (Theorem 8) at one gamma")
    h2.add_argument("--gamma", type=float, required=True, help="L2-gain bound w -> sigma")
    h2.add_argument("--variant", choices=["slack", "common"], default="slack")
    h2.add_argument("--name", default="mrp_h2hinf_satfmu", help="artifact and FMU name")
    h2.set_defaults(fn=_synth_h2hinf)
    vs = designs.add_parser("vscmg-sdre", parents=[out],
                            help="seed 002: approximated SDRE (gain fit) and LQ servo artifacts")
    vs.add_argument("--grid", type=int, nargs=2, default=(23, 25), metavar=("N_Q2", "N_W4"),
                    help="SDRE grid points over q2 and w4")
    vs.add_argument("--max-degree", type=int, default=8, help="largest polynomial degree tried")
    vs.add_argument("--cv-tol", type=float, default=None,
                    help="choose the smallest degree with this cross-validated relative error "
                         "(default synthesis.gain_fit.CV_TOL; 0: the smallest error)")
    vs.add_argument("--skip-region", action="store_true",
                    help="do not solve the SOS stability region (the artifact stays 'sampled')")
    vs.set_defaults(fn=_synth_vscmg)
    cs = designs.add_parser("cubesat-periodic", parents=[out],
                            help="seed 003: periodic stochastic H-infinity gains (Theorem 2) + published gains")
    cs.add_argument("--gamma", type=float, default=None,
                    help="design level (default gamma_min (1 + synthesis.cubesat_periodic.GAMMA_MARGIN))")
    cs.add_argument("--name", default="cubesat_periodic_satfmu", help="artifact and FMU name")
    cs.add_argument("--published-name", default="cubesat_periodic_published",
                    help="artifact and FMU name of the published gains")
    cs.set_defaults(fn=_synth_cubesat)
    dm = designs.add_parser("demeter", parents=[out],
                            help="seed 004: deterministic robust state feedback of a DEMETER variant (Table 1 Det)")
    dm.add_argument("--axes", type=int, nargs="+", default=[1], help="axes, 1-based")
    dm.add_argument("--appendages", type=int, nargs="+", default=[1], help="appendages, 1-based")
    dm.add_argument("--model-type", type=int, choices=[1, 2], default=1,
                    help="1: independent appendages, 2: identical")
    dm.add_argument("--uncertainty-type", type=int, choices=[1, 2, 3], default=1,
                    help="1: norm-bounded (D-G), 2: intervals (vertices), 3: inertia norm-bounded")
    dm.add_argument("--no-wheels", action="store_true", help="design without the wheel dynamics H(s)")
    dm.add_argument("--samples", type=int, default=100, help="sampled plants of the independent check")
    dm.add_argument("--name", default="demeter_row1_det", help="artifact and FMU name")
    dm.set_defaults(fn=_synth_demeter)
    t1 = sub.add_parser("table1", help="seed 004 Table 1: every row, both methods, beside the seed's numbers")
    t1.add_argument("--rows", type=int, nargs="+", default=None,
                    help="rows 1..14 in the seed's order (default all; the 3-axis rows take hours)")
    t1.add_argument("--scenarios", type=int, default=None,
                    help="scenarios per Prob design (default: the Campi-Garatti count, epsilon 0.1, delta 1e-9)")
    t1.add_argument("--out", default="results/table1", help="folder of table1.md and table1.csv")
    t1.set_defaults(fn=_table1)
    fg = sub.add_parser("figures", help="figures of the seeds' papers from the FMUs")
    figs = fg.add_subparsers(dest="figure", required=True)
    fd = figs.add_parser("demeter", help="seed 004 Figs 4-5: random closed loops of the DEMETER FMUs")
    fd.add_argument("--artifact", default="demeter_row1_det", help="shipped artifact name or a .json path")
    fd.add_argument("--n", type=int, default=100, help="random plants")
    fd.add_argument("--seed", type=int, default=0, help="seed of the plant samples")
    fd.add_argument("--stop", type=float, default=60.0, help="FMU horizon, s")
    fd.add_argument("--step", type=float, default=1e-3,
                    help="communication step, s (the row-1 design needs <= 1.5 ms; see sims/demeter_loops.py)")
    fd.add_argument("--linear-stop", type=float, default=10000.0, help="design-model horizon, s")
    fd.add_argument("--fmu-dir", default=str(catalog.DEFAULT_FMU_DIR))
    fd.add_argument("--out", default="results/demeter", help="folder of the PNG files")
    fd.set_defaults(fn=_figures_demeter)
    ca = sub.add_parser("campaign", help="Monte Carlo campaigns on Dask (results in Parquet, resumable)")
    kinds = ca.add_subparsers(dest="kind", required=True)
    cd = kinds.add_parser("demeter", help="seed 004: closed-loop poles, exact H-infinity and i2p of sampled "
                                          "plants under a design artifact, with the Chernoff statements")
    cd.add_argument("--artifact", default="demeter_row1_det", help="shipped artifact name or a .json path")
    cd.add_argument("--n", type=int, default=100_000, help="samples")
    cd.add_argument("--chunk", type=int, default=5000, help="samples per task and per Parquet file")
    cd.add_argument("--seed", type=int, default=0, help="root seed (results depend only on seed, chunk, n)")
    cd.add_argument("--workers", type=int, default=2, help="local Dask workers (ignored with --scheduler)")
    cd.add_argument("--scheduler", default=None, help="address of a running Dask scheduler, tcp://host:port")
    cd.add_argument("--epsilon", type=float, default=0.1, help="accuracy of the statements")
    cd.add_argument("--delta", type=float, default=1e-6, help="1 - confidence of the statements")
    cd.add_argument("--name", default=None, help="campaign (folder) name; default from artifact, n, seed")
    cd.add_argument("--out", default="results/campaigns", help="folder of the campaign folders")
    cd.set_defaults(fn=_campaign_demeter)
    dt = sub.add_parser("detumble", help="seed 003: linear Monte Carlo (Fig. 2) and the nonlinear initial-rate sweep")
    dt.add_argument("--runs", type=int, default=2000, help="Monte Carlo realizations per gain set")
    dt.add_argument("--seed", type=int, default=0)
    dt.add_argument("--rates", type=float, nargs="+", help="initial rates |w(0)|, rad/s (default 17 from 1e-4 to 1)")
    dt.add_argument("--fmu-dir", default=str(catalog.DEFAULT_FMU_DIR))
    dt.add_argument("--out", default="results/cubesat")
    dt.set_defaults(fn=_detumble)
    sw = sub.add_parser("sweep", parents=[mixed], help="gamma-lambda trade-off of seed 001's Theorem 8, both variants")
    sw.add_argument("design", choices=["mrp-h2hinf"])
    sw.add_argument("--gammas", type=float, nargs="+", default=[1.0, 0.8, 0.7, 0.6, 0.55])
    sw.add_argument("--out", default="results/h2hinf_sweep", help="directory of the CSV and PNG")
    sw.set_defaults(fn=_sweep)
    rg = sub.add_parser("region", help="seed 002: SOS stability region of the approximated SDRE, box and map")
    rg.add_argument("design", choices=["vscmg-sdre"])
    rg.add_argument("--artifact", default="vscmg_sdre_approx", help="shipped artifact name or .json path")
    rg.add_argument("--box-q2", type=float, nargs=2, metavar=("LO", "HI"),
                    help="q2 interval of the one-Y box, rad (default: synthesis.vscmg_region.OPERATING_BOX)")
    rg.add_argument("--box-w4", type=float, nargs=2, metavar=("LO", "HI"),
                    help="w4 interval of the one-Y box, rad/s (default: OPERATING_BOX)")
    rg.add_argument("--q2", type=float, nargs=2, default=[0.05, 1.52], metavar=("LO", "HI"), help="map range, rad")
    rg.add_argument("--w4", type=float, nargs=2, default=[-1.8, 1.8], metavar=("LO", "HI"), help="map range, rad/s")
    rg.add_argument("--cells", type=int, nargs=2, default=[7, 6], metavar=("N_Q2", "N_W4"), help="map cells")
    rg.add_argument("--out", default="results/vscmg_region", help="directory of region.json and region.png")
    rg.set_defaults(fn=_region)
    l2 = sub.add_parser("l2", help="L2 gain of a controller's closed loop: diagonal, sampled, SOS")
    l2.add_argument("controller", help="shipped artifact name or .json path")
    l2.add_argument("--rate-max", type=float, default=0.2, help="region |omega_i| <= rate-max, rad/s")
    l2.add_argument("--sigma-max", type=float, default=0.9, help="region |sigma| <= sigma-max")
    l2.add_argument("--kv", type=float, default=1e4, help="kv of the diagonal check (seed: 1e4)")
    l2.add_argument("--samples", type=int, default=200_000)
    l2.set_defaults(fn=_l2)
    args = parser.parse_args(argv)
    try:
        return args.fn(args)
    except (ValueError, KeyError, RuntimeError, FileNotFoundError) as exc:
        print(f"satfmu {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
