"""The implementation packages are layered fmus <- controllers <- synthesis <- sims.

A module may import only from its own package or a lower one (:data:`LAYERS`, lowest first).
Every import is checked, wherever it stands (module level, inside a function, under
``if TYPE_CHECKING:``): ``import a.b``, ``from a import b`` and relative imports. Other
top-level packages (a ``satfmu`` facade, tests/, bench/, examples/) are not layers and are
not checked.
"""
from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

LAYERS = ("fmus", "controllers", "synthesis", "sims")
"""The implementation packages, lowest first."""


def imported_modules(tree: ast.AST, package: str, is_package: bool) -> list[tuple[int, str]]:
    """(line, absolute module name) of every import in ``tree``, relative ones resolved.

    ``package`` is the dotted name of the module (of the package, for an ``__init__.py``,
    with ``is_package``)."""
    parts = package.split(".")
    if not is_package:
        parts = parts[:-1]
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = parts[:len(parts) - node.level + 1]
                name = ".".join(base + ([node.module] if node.module else []))
            else:
                name = node.module or ""
            # ``from .. import synthesis`` names the imported modules only in its aliases
            found += [(node.lineno, name)] if name else [(node.lineno, a.name) for a in node.names]
    return found


def violations(source: str, module: str, where: str, is_package: bool = False) -> list[str]:
    """``where:line: import`` for every import in ``source`` (the text of ``module``, a dotted
    name whose first part is one of :data:`LAYERS`) of a layer above the module's own."""
    own = LAYERS.index(module.split(".")[0])
    tree = ast.parse(source, filename=where)
    lines = source.splitlines()
    out = []
    for lineno, name in imported_modules(tree, module, is_package):
        top = name.split(".")[0]
        if top in LAYERS and LAYERS.index(top) > own:
            out.append(f"{where}:{lineno}: {lines[lineno - 1].strip()} ({module} imports {top}, a higher layer)")
    return out


def tree_violations(root: Path = ROOT) -> list[str]:
    """:func:`violations` of every .py file of the four packages under ``root``."""
    out = []
    for layer in LAYERS:
        for path in sorted((root / layer).rglob("*.py")):
            rel = path.relative_to(root)
            is_package = path.name == "__init__.py"
            module = ".".join(rel.parent.parts if is_package else rel.with_suffix("").parts)
            out += violations(path.read_text(encoding="utf-8"), module, str(rel), is_package)
    return out


def test_no_module_imports_a_higher_layer() -> None:
    assert sum(1 for layer in LAYERS for _ in (ROOT / layer).rglob("*.py")) > 50  # the tree was found
    found = tree_violations()
    assert not found, "imports of a higher layer:\n" + "\n".join(found)


def test_the_checker_catches_every_kind_of_import(tmp_path: Path) -> None:
    source = """\
from __future__ import annotations
import numpy
from typing import TYPE_CHECKING
from fmus import model
import controllers.riccati
from controllers.artifact import parse
from . import polynomial
import satfmu
if TYPE_CHECKING:
    from sims.master import CoSimulation
def f():
    import synthesis.sos as sos
    from ..sims import cli
    from .. import synthesis
"""
    found = violations(source, "controllers.law", "controllers/law.py")
    assert [v.split(" (")[0] for v in found] == [
        "controllers/law.py:10: from sims.master import CoSimulation",
        "controllers/law.py:12: import synthesis.sos as sos",
        "controllers/law.py:13: from ..sims import cli",
        "controllers/law.py:14: from .. import synthesis"]
    # relative imports resolve from a package's __init__.py, and the lowest layer imports nothing
    assert violations("from .sub import x\nfrom ..controllers import y\n", "fmus", "fmus/__init__.py",
                      is_package=True) == ["fmus/__init__.py:2: from ..controllers import y "
                                           "(fmus imports controllers, a higher layer)"]
    assert violations("from ..synthesis import sos\n", "sims.scenarios.x", "sims/scenarios/x.py") == []
    # on a tree: every offending file and line is listed, the top layer is free
    for rel, text in {"fmus/a.py": "import os\n\ndef g():\n    from controllers import servo\n",
                      "fmus/c/b.py": "from sims.cli import main\n",
                      "controllers/ok.py": "from fmus import model\n",
                      "sims/top.py": "import synthesis, controllers, fmus\n"}.items():
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).write_text(text)
    (tmp_path / "synthesis").mkdir()
    assert [v.split(" (")[0] for v in tree_violations(tmp_path)] == [
        "fmus/a.py:4: from controllers import servo", "fmus/c/b.py:1: from sims.cli import main"]
