"""The implementation packages are layered fmus <- controllers <- synthesis <- sims, all under
the one import package ``satfmu`` (``satfmu.fmus`` ... ``satfmu.sims``; the repository keeps them as
top-level folders, pyproject.toml's package-dir installs them there).

A module may import only from its own package or a lower one (:data:`LAYERS`, lowest first).
Every import is checked, wherever it stands (module level, inside a function, under
``if TYPE_CHECKING:``): ``import a.b``, ``from a import b`` and relative imports. The ``satfmu``
facade, tests/, bench/, examples/ and scripts/ are not layers. No Python file of the repository
imports a layer by its bare folder name (``import sims``): a module would then be loaded twice,
under two names.
"""
from __future__ import annotations

import ast
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

PACKAGE = "satfmu"
LAYERS = ("fmus", "controllers", "synthesis", "sims")
"""The implementation packages (``satfmu.<layer>``, folders of the repository), lowest first."""
PYTHON_FOLDERS = (PACKAGE, *LAYERS, "tests", "bench", "examples", "scripts")
"""The repository's folders of Python files."""


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
            if name in ("", PACKAGE):
                found += [(node.lineno, f"{name}.{a.name}".lstrip(".")) for a in node.names]
            else:
                found += [(node.lineno, name)]
    return found


def layer(name: str) -> str | None:
    """The layer of the absolute module name ``name`` (``satfmu.sims.cli``: sims), or None."""
    parts = name.split(".")
    return parts[1] if len(parts) > 1 and parts[0] == PACKAGE and parts[1] in LAYERS else None


def violations(source: str, module: str, where: str, is_package: bool = False) -> list[str]:
    """``where:line: import`` for every import in ``source`` (the text of ``module``, a dotted
    name ``satfmu.<layer>...`` or any other) of a layer above the module's own, and of a layer by
    its bare name."""
    own = layer(module)
    tree = ast.parse(source, filename=where)
    lines = source.splitlines()
    out = []
    for lineno, name in imported_modules(tree, module, is_package):
        text = lines[lineno - 1].strip()
        if name.split(".")[0] in LAYERS:
            out.append(f"{where}:{lineno}: {text} (imports {name.split('.')[0]} by its bare name: import it as "
                       f"{PACKAGE}.{name})")
        elif own is not None and layer(name) is not None and LAYERS.index(layer(name)) > LAYERS.index(own):
            out.append(f"{where}:{lineno}: {text} ({module} imports {layer(name)}, a higher layer)")
    return out


def module_name(rel: Path) -> tuple[str, bool]:
    """The import name of the repository file ``rel`` and whether it is a package's __init__.py."""
    is_package = rel.name == "__init__.py"
    parts = rel.parent.parts if is_package else rel.with_suffix("").parts
    return ".".join((PACKAGE, *parts) if parts[0] in LAYERS else parts), is_package


def tree_violations(root: Path = ROOT, folders: tuple[str, ...] = LAYERS) -> list[str]:
    """:func:`violations` of every .py file of ``folders`` under ``root``."""
    out = []
    for folder in folders:
        for path in sorted((root / folder).rglob("*.py")):
            rel = path.relative_to(root)
            module, is_package = module_name(rel)
            out += violations(path.read_text(encoding="utf-8"), module, str(rel), is_package)
    return out


def test_no_module_imports_a_higher_layer() -> None:
    assert sum(1 for layer in LAYERS for _ in (ROOT / layer).rglob("*.py")) > 50  # the tree was found
    found = tree_violations()
    assert not found, "imports of a higher layer:\n" + "\n".join(found)


BARE_IN_TEXT = re.compile(r"(?:^|[\"';]\s*|\\n)\s*(?:from|import) (?:fmus|controllers|synthesis|sims)\b")
"""A bare import of a layer in a string (code run by ``python -c`` or written to a file)."""


def text_violations(root: Path = ROOT, folders: tuple[str, ...] = PYTHON_FOLDERS) -> list[str]:
    """``where:line`` of every bare layer import inside a string of a Python file (the AST check
    cannot see those; a child run in the repository's folder would import the folder itself)."""
    out = []
    for folder in folders:
        for path in sorted((root / folder).rglob("*.py")):
            if path.name == "test_layering.py":
                continue  # its examples
            for lineno, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
                if ('"' in line or "'" in line) and BARE_IN_TEXT.search(line):
                    out.append(f"{path.relative_to(root)}:{lineno}: {line.strip()}")
    return out


def test_no_file_imports_a_layer_by_its_bare_name() -> None:
    """Every Python file of the repository imports the layers as ``satfmu.<layer>``, in its code
    and in the code it runs from strings."""
    found = tree_violations(folders=PYTHON_FOLDERS) + text_violations()
    assert sum(1 for f in PYTHON_FOLDERS for _ in (ROOT / f).rglob("*.py")) > 150  # the tree was found
    assert not found, "bare imports of a layer:\n" + "\n".join(found)


def test_the_checker_catches_every_kind_of_import(tmp_path: Path) -> None:
    source = """\
from __future__ import annotations
import numpy
from typing import TYPE_CHECKING
from satfmu.fmus import model
import satfmu.controllers.riccati
from satfmu.controllers.artifact import parse
from . import polynomial
import satfmu
if TYPE_CHECKING:
    from satfmu.sims.cosim.master import CoSimulation
def f():
    import satfmu.synthesis.core.sos as sos
    from ..sims import cli
    from .. import synthesis
"""
    found = violations(source, "satfmu.controllers.law", "controllers/law.py")
    assert [v.split(" (")[0] for v in found] == [
        "controllers/law.py:10: from satfmu.sims.cosim.master import CoSimulation",
        "controllers/law.py:12: import satfmu.synthesis.core.sos as sos",
        "controllers/law.py:13: from ..sims import cli",
        "controllers/law.py:14: from .. import synthesis"]
    # relative imports resolve from a package's __init__.py, and the lowest layer imports nothing
    assert violations("from .sub import x\nfrom ..controllers import y\n", "satfmu.fmus", "fmus/__init__.py",
                      is_package=True) == ["fmus/__init__.py:2: from ..controllers import y "
                                           "(satfmu.fmus imports controllers, a higher layer)"]
    assert violations("from ..synthesis import sos\n", "satfmu.sims.scenarios.x", "sims/scenarios/x.py") == []
    # a bare layer name is refused everywhere, the facade and tests included
    assert [v.split(" (")[0] for v in violations("import sims\nfrom fmus.model import Model\nimport satfmu.sims\n",
                                                 "tests.test_x", "tests/test_x.py")] == [
        "tests/test_x.py:1: import sims", "tests/test_x.py:2: from fmus.model import Model"]
    # on a tree: every offending file and line is listed, the top layer is free
    for rel, text in {"fmus/a.py": "import os\n\ndef g():\n    from satfmu.controllers import servo\n",
                      "fmus/c/b.py": "from satfmu.sims.cli import main\n",
                      "controllers/ok.py": "from satfmu.fmus import model\n",
                      "sims/top.py": "from satfmu import synthesis, controllers, fmus\n"}.items():
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).write_text(text)
    (tmp_path / "synthesis").mkdir()
    assert [v.split(" (")[0] for v in tree_violations(tmp_path)] == [
        "fmus/a.py:4: from satfmu.controllers import servo", "fmus/c/b.py:1: from satfmu.sims.cli import main"]


CORES = ("satfmu.sims.cosim", "satfmu.synthesis.core")
"""Subpackages that are the base of their layer: they import nothing else of it (the master runs
FMUs without knowing scenarios; the SOS and LMI machinery knows no design method)."""


def core_violations(root: Path = ROOT) -> list[str]:
    """``where:line: import`` of every module of a :data:`CORES` subpackage that imports another
    subpackage or module of its own layer."""
    out = []
    for core in CORES:
        folder = root.joinpath(*core.split(".")[1:])
        for path in sorted(folder.rglob("*.py")):
            rel = path.relative_to(root)
            module, is_package = module_name(rel)
            lines = path.read_text(encoding="utf-8").splitlines()
            for lineno, name in imported_modules(ast.parse("\n".join(lines)), module, is_package):
                if layer(name) == layer(core) and name != core and not name.startswith(core + "."):
                    out.append(f"{rel}:{lineno}: {lines[lineno - 1].strip()} ({core} imports {name})")
    return out


def test_the_core_subpackages_import_nothing_else_of_their_layer() -> None:
    assert sum(1 for core in CORES for _ in ROOT.joinpath(*core.split(".")[1:]).rglob("*.py")) >= 10
    found = core_violations()
    assert not found, "a core subpackage imports its layer's other subpackages:\n" + "\n".join(found)


def test_the_core_checker_catches_an_import_of_the_layer(tmp_path: Path) -> None:
    (tmp_path / "sims" / "cosim").mkdir(parents=True)
    (tmp_path / "synthesis" / "core").mkdir(parents=True)
    (tmp_path / "sims" / "cosim" / "m.py").write_text("from satfmu.sims.cosim import fmi_host\n"
                                                       "from satfmu.fmus import model\n"
                                                       "from satfmu.sims.scenario import spec\n")
    (tmp_path / "synthesis" / "core" / "s.py").write_text("from ..robust import lft_plant\nfrom . import lmi\n")
    assert [v.split(" (")[0] for v in core_violations(tmp_path)] == [
        "sims/cosim/m.py:3: from satfmu.sims.scenario import spec",
        "synthesis/core/s.py:1: from ..robust import lft_plant"]
