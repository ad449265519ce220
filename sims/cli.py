"""The ``satfmu`` command line: build, validate and run.

    satfmu build [--dest build/fmus] [--backend native|python|all]
    satfmu validate [--fmu-dir build/fmus]
    satfmu run SCENARIO [SCENARIO ...] [--backend native|python] [--fmu-dir DIR] [--out results]
    satfmu list
    satfmu synth mrp-hinf [--name mrp_hinf_satfmu] [--out controllers/artifacts] [--fmu-dir DIR] ...
    satfmu l2 CONTROLLER [--rate-max 0.2] [--sigma-max 0.9] [--samples 200000]

``run`` exits with status 1 when a metric misses its bound, 2 on an error. ``synth``
runs seed 000's two-step iteration, writes the chosen controller's artifact and builds its
FMUs. ``l2`` reports the three L2-gain estimates of a controller (name of a shipped
artifact or a .json path).
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

from sims import catalog, scenario


def _build(args: argparse.Namespace) -> int:
    backends = ("native", "python") if args.backend == "all" else (args.backend,)
    for p in catalog.build_all(Path(args.dest), backends):
        print(f"built {p}")
    return 0


def _validate(args: argparse.Namespace) -> int:
    fmus = sorted(Path(args.fmu_dir).glob("*.fmu"))
    if not fmus:
        print(f"no FMUs in {args.fmu_dir}; run `satfmu build` first", file=sys.stderr)
        return 2
    bad = 0
    for f in fmus:
        problems = catalog.validate(f)
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
    if args.summary:
        path = Path(args.summary)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(summaries, indent=1) + "\n")
        path.with_suffix(".md").write_text(_markdown(summaries))
    return 1 if failed else 0


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


def _synth(args: argparse.Namespace) -> int:
    from controllers import artifact as artifacts
    from controllers import polynomial
    from fmus import export
    from synthesis import l2_gain, two_step

    result = two_step.two_step(region=args.region, l2_region=l2_gain.Region(args.rate_max, args.sigma_max),
                               coefficient_limit=args.coefficient_limit, torque_budget=args.torque_budget,
                               n_samples=args.samples, progress=_progress)
    print(result.table())
    art = artifacts.parse(result.artifact_data(args.name), where=args.name)
    out = Path(args.out) / f"{args.name}.json"
    out.parent.mkdir(parents=True, exist_ok=True)
    artifacts.save(art, out)
    print(f"wrote {out}")
    if args.fmu_dir:
        model = polynomial.build(art)
        for build in (export.build_native, export.build_python):
            print(f"built {build(model, Path(args.fmu_dir), polynomial.artifact_resource(art))}")
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
    ls = sub.add_parser("list", help="list the shipped scenarios")
    ls.set_defaults(fn=_list)
    sy = sub.add_parser("synth", help="synthesize a controller (mrp-hinf: seed 000 two-step iteration)")
    sy.add_argument("design", choices=["mrp-hinf"])
    sy.add_argument("--name", default="mrp_hinf_satfmu", help="artifact and FMU name")
    sy.add_argument("--out", default="controllers/artifacts", help="directory of the artifact")
    sy.add_argument("--fmu-dir", default=str(catalog.DEFAULT_FMU_DIR),
                    help="build the controller FMUs here ('' to skip)")
    sy.add_argument("--region", type=float, default=0.9, help="Theorem 1 region |sigma| <= r (< 1)")
    sy.add_argument("--rate-max", type=float, default=0.2, help="L2 region |omega_i| <= rate-max, rad/s")
    sy.add_argument("--sigma-max", type=float, default=0.9, help="L2 region |sigma| <= sigma-max")
    sy.add_argument("--coefficient-limit", type=float, default=1.0, help="bound on every K coefficient")
    sy.add_argument("--torque-budget", type=float, default=6.5,
                    help="largest peak |u_i| on the 200 deg manoeuvre, N m")
    sy.add_argument("--samples", type=int, default=20_000, help="random points of the sampled L2 check")
    sy.set_defaults(fn=_synth)
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
