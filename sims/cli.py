"""The ``satfmu`` command line: build, validate and run.

    satfmu build [--dest build/fmus] [--backend native|python|all]
    satfmu validate [--fmu-dir build/fmus]
    satfmu run SCENARIO [SCENARIO ...] [--backend native|python] [--fmu-dir DIR] [--out results]
    satfmu list

``run`` exits with status 1 when a metric misses its bound, 2 on an error.
"""
from __future__ import annotations

import argparse
import json
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
    args = parser.parse_args(argv)
    try:
        return args.fn(args)
    except (ValueError, KeyError, RuntimeError, FileNotFoundError) as exc:
        print(f"satfmu {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
