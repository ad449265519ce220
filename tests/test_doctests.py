"""The examples in the docstrings of satfmu's modules run and print what they show.

Every module of the ``satfmu`` package whose source holds an example (``>>>``) is imported under
its one name (``satfmu.synthesis.core.sos``, never a bare ``synthesis.sos``, which would load it twice)
and its examples are run with :mod:`doctest`.
"""
from __future__ import annotations

import doctest
import importlib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
FOLDERS = {"satfmu": "satfmu", "fmus": "satfmu.fmus", "controllers": "satfmu.controllers",
           "synthesis": "satfmu.synthesis", "sims": "satfmu.sims"}


def _modules_with_examples() -> list[str]:
    names = []
    for folder, package in FOLDERS.items():
        for path in sorted((ROOT / folder).rglob("*.py")):
            if ">>>" in path.read_text(encoding="utf-8"):
                parts = path.relative_to(ROOT / folder).with_suffix("").parts
                names.append(".".join((package, *parts)).removesuffix(".__init__"))
    return names


MODULES = _modules_with_examples()


def test_examples_were_found() -> None:
    """The scan found the known example (synthesis/core/sos.py's)."""
    assert "satfmu.synthesis.core.sos" in MODULES


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name: str) -> None:
    result = doctest.testmod(importlib.import_module(name), optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.attempted > 0, f"{name}: no example run"
    assert result.failed == 0, f"{name}: {result.failed} of {result.attempted} examples failed (output above)"
