"""bench/design_table.py, without running any design: its Markdown table of fabricated rows, the
shortening of refusal reasons, and the "not offered" detection from a design function's signature."""
from __future__ import annotations

import functools
import importlib
import sys
from pathlib import Path
from types import ModuleType
from typing import Any, Callable

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
            Row("robust", "seed_000", "not offered", "not offered (issue 53 item 3)", None)]
    lines = design_table.markdown(rows).split("\n")
    assert len(lines) == 2 + len(rows)
    assert lines[0] == "| method | spacecraft | outcome | numbers / reason | design time | closed loop |"
    cells = [line.strip("| ").split(" | ") for line in lines[2:]]
    assert all(len(c) == 6 for c in cells), cells  # escaped pipes split no cell
    assert cells[0] == ["000 design_hinf", "bus", "certified", "L2 gain c = 0.3242 on \\|sigma\\| <= 0.9", "41.3 s",
                        "pass: 0.002 deg at 300 s (<= 0.1), peak 11.2 of 20 N m"]
    assert cells[1][3] == "gamma = 5: no certified slack design on \\|sigma\\| <= 0.45"  # newline made a space
    assert cells[1][4] == "7.0 s" and cells[2][4] == "-"
    assert cells[2][:3] == ["004 design_demeter", "seed_000", "not offered"]


def test_reasons_are_flattened_and_cut(design_table: ModuleType) -> None:
    short = "no certified design\n  at gamma = 0.7"
    assert design_table.shorten(short) == "no certified design at gamma = 0.7"
    long = "word " * 100
    cut = design_table.shorten(long, 50)
    assert len(cut) <= 50 and cut.endswith("...") and cut.startswith("word word")
    assert len(design_table.shorten(long)) == design_table.REASON_CHARS


def _guarded(function: Callable[..., Any]) -> Callable[..., Any]:
    """A wrapper like satfmu's ``fails_with_design_error`` (``functools.wraps``)."""
    @functools.wraps(function)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        return function(*args, **kwargs)

    return wrapper


def test_not_offered_follows_the_plant_parameter(design_table: ModuleType) -> None:
    def without(grid: tuple[int, int] = (23, 25), *, name: str = "x") -> None:
        """A design of one fixed plant."""

    def with_plant(grid: tuple[int, int] = (23, 25), plant: Any = None, *, name: str = "x") -> None:
        """A design for any spacecraft."""

    assert not design_table.offers_plant(_guarded(without))
    assert design_table.offers_plant(_guarded(with_plant))  # seen through functools.wraps
    row = design_table.not_offered("robust", "bus", _guarded(without))
    assert row is not None and row.outcome == "not offered" and row.seconds is None
    assert "issue 53 item 3" in row.numbers and row.spacecraft == "bus"
    assert design_table.not_offered("robust", "bus", _guarded(with_plant)) is None
    robust = design_table.not_offered("robust", "cubesat_3u", without)
    assert robust is not None and "issue 53 item 3" in robust.numbers


def test_the_shipped_design_functions_are_classified_by_their_signature(design_table: ModuleType) -> None:
    from satfmu.synthesis import designs

    assert design_table.offers_plant(designs.design_hinf)
    assert design_table.offers_plant(designs.design_cubesat_periodic)
    assert design_table.offers_plant(designs.design_sdre)
    for method, function in (("robust", designs.design_demeter),):
        row = design_table.not_offered(method, "bus", function)
        assert (row is None) == design_table.offers_plant(function)
        # a design_row of a method that is not offered runs nothing and takes no time
        if row is not None:
            assert design_table.design_row(method, "bus", full=False).outcome == "not offered"
