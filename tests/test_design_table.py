"""bench/design_table.py, without running any design: its Markdown table of fabricated rows, the
shortening of refusal reasons, and the "not applicable" rows (a method for the other kind of spacecraft)."""
from __future__ import annotations

import importlib
import sys
from pathlib import Path
from types import ModuleType

import pytest

BENCH = Path(__file__).resolve().parents[1] / "bench"


@pytest.fixture(scope="module")
def design_table() -> ModuleType:
    """bench/design_table.py as a module."""
    sys.path.insert(0, str(BENCH))
    try:
        return importlib.import_module("design_table")
    finally:
        sys.path.remove(str(BENCH))


def test_table_has_one_line_per_row_escaped_cells_and_times(design_table: ModuleType) -> None:
    Row = design_table.Row
    rows = [Row("hinf", "bus", "certified", "L2 gain c = 0.3242 on |sigma| <= 0.9", 41.26,
                "pass: 0.002 deg at 300 s (<= 0.1), peak 11.2 of 20 N m"),
            Row("h2hinf", "cubesat_3u", "refused", "gamma = 5: no certified slack design\non |sigma| <= 0.45", 7.04),
            Row("robust", "seed_000", "not applicable", "a rigid spacecraft", None)]
    lines = design_table.markdown(rows).split("\n")
    assert len(lines) == 2 + len(rows)
    assert lines[0] == "| method | spacecraft | outcome | numbers / reason | design time | closed loop |"
    cells = [line.strip("| ").split(" | ") for line in lines[2:]]
    assert all(len(c) == 6 for c in cells), cells  # escaped pipes split no cell
    assert cells[0] == ["000 design_hinf", "bus", "certified", "L2 gain c = 0.3242 on \\|sigma\\| <= 0.9", "41.3 s",
                        "pass: 0.002 deg at 300 s (<= 0.1), peak 11.2 of 20 N m"]
    assert cells[1][3] == "gamma = 5: no certified slack design on \\|sigma\\| <= 0.45"  # newline made a space
    assert cells[1][4] == "7.0 s" and cells[2][4] == "-"
    assert cells[2][:3] == ["004 design_demeter", "seed_000", "not applicable"]


def test_reasons_are_flattened_and_cut(design_table: ModuleType) -> None:
    short = "no certified design\n  at gamma = 0.7"
    assert design_table.shorten(short) == "no certified design at gamma = 0.7"
    long = "word " * 100
    cut = design_table.shorten(long, 50)
    assert len(cut) <= 50 and cut.endswith("...") and cut.startswith("word word")
    assert len(design_table.shorten(long)) == design_table.REASON_CHARS


def test_each_method_applies_to_its_kind_of_spacecraft(design_table: ModuleType) -> None:
    # seed 004's method needs flexible appendages and wheels; the others a rigid body
    for name in ("seed_000", "bus", "cubesat_3u"):
        row = design_table.not_applicable("robust", name)
        assert row is not None and row.outcome == "not applicable" and row.seconds is None
        assert "FlexibleSpacecraft" in row.numbers
        assert design_table.not_applicable("hinf", name) is None
    assert design_table.not_applicable("robust", "my_flex") is None
    for method in ("hinf", "h2hinf", "sdre", "periodic"):
        row = design_table.not_applicable(method, "my_flex")
        assert row is not None and "rigid body" in row.numbers
    # a design_row that does not apply runs nothing
    assert design_table.design_row("robust", "bus", full=False).outcome == "not applicable"
    assert design_table.design_row("sdre", "my_flex", full=False).outcome == "not applicable"
