"""Type-check satfmu with mypy: zero errors outside the modules pyproject.toml hides, and no hidden
count growing.

The repository's layer folders install as ``satfmu.fmus`` ... ``satfmu.sims`` (setuptools'
package-dir), a mapping mypy cannot follow through the editable install's import hook. This
script lays the package out as it installs, as links in ``build/typecheck/satfmu`` (so the
modules are checked under their one name), runs mypy once with pyproject.toml's ``[tool.mypy]``
options but without its ``ignore_errors`` override, and counts the errors of every module:

- a module outside that override must have none;
- a module inside it must have no more than ``[tool.satfmu.typecheck] hidden`` records for it
  (the override and that table list the same modules); a count that fell is reported, to be
  lowered in pyproject.toml.

Prints mypy's errors of unhidden modules, then one line per hidden module and the total.

    .venv/bin/python scripts/typecheck.py          # the check of `make test`
    .venv/bin/python scripts/typecheck.py --all    # every error, hidden ones included
"""
from __future__ import annotations

import argparse
import collections
import os
import re
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TREE = ROOT / "build" / "typecheck"
LAYERS = ("fmus", "controllers", "synthesis", "sims")
ERROR = re.compile(r"^(?P<path>satfmu/[^:]+\.py):\d+: error: ")


def link_tree() -> None:
    """``build/typecheck/satfmu``: the facade's modules and the four layer folders, linked."""
    pkg = TREE / "satfmu"
    if pkg.exists():
        shutil.rmtree(pkg)
    pkg.mkdir(parents=True)
    for f in (ROOT / "satfmu").glob("*.py"):
        (pkg / f.name).symlink_to(f)
    for layer in LAYERS:
        (pkg / layer).symlink_to(ROOT / layer, target_is_directory=True)


def ini_value(value: object) -> str:
    if isinstance(value, bool):
        return "True" if value else "False"
    if isinstance(value, list):
        return ", ".join(map(str, value))
    return str(value)


def config(mypy: dict, hidden: set[str]) -> Path:
    """pyproject.toml's mypy options as an INI file, without the override that hides ``hidden``."""
    lines = ["[mypy]"] + [f"{k} = {ini_value(v)}" for k, v in mypy.items() if k != "overrides"]
    for override in mypy.get("overrides", []):
        modules = override["module"] if isinstance(override["module"], list) else [override["module"]]
        options = {k: v for k, v in override.items() if k != "module"}
        if options.get("ignore_errors") and set(modules) <= hidden:
            continue
        lines += [f"[mypy-{','.join(modules)}]"] + [f"{k} = {ini_value(v)}" for k, v in options.items()]
    path = TREE / "mypy.ini"
    path.write_text("\n".join(lines) + "\n")
    return path


def module_of(path: str) -> str:
    name = path.removesuffix(".py").replace("/", ".")
    return name.removesuffix(".__init__")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--all", action="store_true", help="print every error, those of hidden modules too")
    args = parser.parse_args(argv)
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())
    mypy = project["tool"]["mypy"]
    recorded: dict[str, int] = project["tool"]["satfmu"]["typecheck"]["hidden"]
    ignored = {m for o in mypy.get("overrides", []) if o.get("ignore_errors")
               for m in (o["module"] if isinstance(o["module"], list) else [o["module"]])}
    if ignored != set(recorded):
        print(f"pyproject.toml: the ignore_errors override and [tool.satfmu.typecheck] hidden list different "
              f"modules: {sorted(ignored ^ set(recorded))}")
        return 1
    link_tree()
    done = subprocess.run([sys.executable, "-m", "mypy", "--config-file", str(config(mypy, ignored)),
                           "--cache-dir", ".mypy_cache", "--no-error-summary", "-p", "satfmu"],
                          cwd=TREE, capture_output=True, text=True, env={**os.environ, "MYPY_FORCE_COLOR": "0"})
    if done.returncode not in (0, 1) or (done.returncode == 1 and not done.stdout):
        print(done.stdout + done.stderr)
        print(f"mypy failed (exit {done.returncode})")
        return 1
    counts: collections.Counter[str] = collections.Counter()
    shown = []
    for line in done.stdout.splitlines():
        m = ERROR.match(line)
        if m:
            module = module_of(m["path"])
            counts[module] += 1
            if args.all or module not in ignored:
                shown.append(line)
        elif args.all or (shown and line.startswith(shown[-1].split(":", 1)[0])):
            shown.append(line)  # a note belonging to a shown error
    print("\n".join(shown))
    failed = False
    for module in sorted(ignored):
        n, limit = counts[module], recorded[module]
        verdict = "more than recorded" if n > limit else ("fewer: lower it in pyproject.toml" if n < limit else "")
        failed |= n > limit
        print(f"hidden: {module:<42} {n:3d} errors (recorded {limit}){'  ' + verdict if verdict else ''}")
    unhidden = sum(n for module, n in counts.items() if module not in ignored)
    checked = sum(len(list((ROOT / folder).rglob("*.py"))) for folder in ("satfmu", *LAYERS))
    print(f"mypy: {unhidden} errors in the checked modules, {sum(counts[m] for m in ignored)} hidden in "
          f"{len(ignored)} modules (pyproject.toml); {checked} modules")
    return 1 if failed or unhidden else 0


if __name__ == "__main__":
    sys.exit(main())
