"""Names: no one- or two-letter alias of a satfmu import, and one meaning each for "report" (the
HTML report page of runs and campaigns, ``satfmu report``) and "verify" (a scenario run by other
engines and compared, ``satfmu verify``)."""
from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
LAYERS = ("fmus", "controllers", "synthesis", "sims")
PYTHON_FOLDERS = ("satfmu", *LAYERS, "tests", "bench", "examples", "scripts", "docs")
MEANINGS = {
    "report": ("sims/report/", "sims/cli.py"),
    "verif": ("sims/interop/verify.py", "sims/cli.py", "sims/scenario/spec.py"),
}
"""Word -> the only files that may define a public name holding it (a module, class, function,
method or class attribute): the report page and its command; the verification, its command and a
scenario's ``[verify]`` table. A synthesis result re-checked independently of its solver is
*certified* (``satfmu.synthesis.core.sos.certify``)."""
ALLOWED = {"ReportError"}
"""Public names holding a word outside its files: the report page's error, defined with every
other error in satfmu.fmus.errors."""


def short_aliases(source: str, where: str) -> list[str]:
    """``where:line: statement`` of every import of satfmu bound to a name of one or two letters."""
    out = []
    for node in ast.walk(ast.parse(source, filename=where)):
        if isinstance(node, ast.ImportFrom) and node.level == 0 and (node.module or "").split(".")[0] == "satfmu":
            bad = [a for a in node.names if a.asname and len(a.asname) <= 2]
        elif isinstance(node, ast.Import):
            bad = [a for a in node.names if a.name.split(".")[0] == "satfmu" and a.asname and len(a.asname) <= 2]
        else:
            continue
        out += [f"{where}:{node.lineno}: {a.name} as {a.asname}" for a in bad]
    return out


def public_names(source: str, where: str) -> list[tuple[int, str]]:
    """(line, name) of the module's public classes, functions and assignments, and of their
    public methods and attributes."""
    out = []

    def visit(body: list[ast.stmt]) -> None:
        for node in body:
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                if not node.name.startswith("_"):
                    out.append((node.lineno, node.name))
                    if isinstance(node, ast.ClassDef):
                        visit(node.body)
            elif isinstance(node, (ast.Assign, ast.AnnAssign)):
                targets = node.targets if isinstance(node, ast.Assign) else [node.target]
                out.extend((node.lineno, t.id) for t in targets if isinstance(t, ast.Name) and not t.id.startswith("_"))

    visit(ast.parse(source, filename=where).body)
    return out


def misnamed(root: Path = ROOT) -> list[str]:
    """``where:line: name`` of every module file or public name holding a word of :data:`MEANINGS`
    outside the files that word belongs to."""
    out = []
    for layer in LAYERS:
        for path in sorted((root / layer).rglob("*.py")):
            rel = path.relative_to(root).as_posix()
            for word, homes in MEANINGS.items():
                if rel.startswith(homes):
                    continue
                if word in path.stem.lower():
                    out.append(f"{rel}: the module's name holds {word!r}")
                out += [f"{rel}:{line}: {name}" for line, name in public_names(path.read_text(encoding="utf-8"), rel)
                        if word in name.lower() and name not in ALLOWED]
    return out


def test_no_satfmu_import_has_a_one_or_two_letter_alias() -> None:
    files = [p for f in PYTHON_FOLDERS for p in sorted((ROOT / f).rglob("*.py"))]
    assert len(files) > 200  # the tree was found
    found = [v for p in files for v in short_aliases(p.read_text(encoding="utf-8"), str(p.relative_to(ROOT)))]
    assert not found, "short aliases of satfmu imports (name the module):\n" + "\n".join(found)


def test_report_and_verify_have_one_meaning_each() -> None:
    found = misnamed()
    assert not found, "names of another meaning:\n" + "\n".join(found)


def test_the_checkers_find_what_they_look_for(tmp_path: Path) -> None:
    assert short_aliases("import numpy as np\nfrom satfmu.sims import cli as c\nimport satfmu.fmus.model as M\n"
                         "from satfmu.fmus.model import Model as Mo\nfrom satfmu import run\n", "x.py") == [
        "x.py:2: cli as c", "x.py:3: satfmu.fmus.model as M", "x.py:4: Model as Mo"]
    (tmp_path / "sims" / "report").mkdir(parents=True)
    (tmp_path / "synthesis").mkdir()
    (tmp_path / "sims" / "report" / "page.py").write_text("def write_report(): ...\n")
    (tmp_path / "synthesis" / "sweep_report.py").write_text(
        "class Result:\n    report: str\n    def _report(self): ...\n\ndef verify(): ...\nVERIFIED = 1\n_verify = 2\n")
    assert misnamed(tmp_path) == [
        "synthesis/sweep_report.py: the module's name holds 'report'", "synthesis/sweep_report.py:2: report",
        "synthesis/sweep_report.py:5: verify", "synthesis/sweep_report.py:6: VERIFIED"]
