"""docs/design.md lists every subpackage of the four code folders, one line each, and nothing else."""
from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
LAYERS = ("fmus", "controllers", "synthesis", "sims")


def documented(text: str) -> list[str]:
    """The folders of the design document's subpackage list (``- `sims/cosim/`: ...``), in order."""
    block = text.split("<!-- subpackages -->", 1)[1].split("<!-- /subpackages -->", 1)[0]
    return re.findall(r"^- `([\w/]+)/`:", block, flags=re.M)


def packages(root: Path = ROOT) -> list[str]:
    """Every Python package of the code folders (a folder with ``__init__.py``), sorted."""
    return sorted(str(p.parent.relative_to(root)) for layer in LAYERS for p in (root / layer).rglob("__init__.py"))


def test_the_design_document_lists_every_subpackage_once() -> None:
    listed = documented((ROOT / "docs" / "design.md").read_text(encoding="utf-8"))
    assert len(listed) == len(set(listed)), listed
    found = packages()
    assert len(found) >= 15  # the tree was found
    assert sorted(listed) == found


def test_the_list_reader_finds_the_entries() -> None:
    text = "x\n<!-- subpackages -->\n- `a/`: one\n  more\n- `a/b/`: two\n<!-- /subpackages -->\n- `c/`: no\n"
    assert documented(text) == ["a", "a/b"]
