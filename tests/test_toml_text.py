"""satfmu.fmus.declared.toml_text: plain data as TOML text that reads back equal."""
from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pytest

from satfmu.fmus.declared import toml_text
from satfmu.sims.scenario.spec import load
from satfmu.sims.scenario import shipped_scenarios


@pytest.mark.parametrize("path", shipped_scenarios(), ids=lambda p: p.stem)
def test_every_shipped_scenario_reads_back_equal(path: Path) -> None:
    data = load(path).to_dict()
    assert tomllib.loads(toml_text(data)) == data


def test_keys_values_layout_and_comment() -> None:
    data = {"name": "x", "n": 3, "on": True, "f": np.float64(0.1), "list": [1.5, "a"],
            "t": {"short": {"a": 1}, "other": {"b": "c"}},
            "u": {"long": {f"k{i}": float(i) for i in range(20)}, "short": {"a": 1}},
            "rows": [{"from": "a.b[1,2]", "to": "c"}, {"from": "d", "to": "e"}]}
    text = toml_text(data, "line one\n\nline two")
    assert text.startswith("# line one\n#\n# line two\nname = \"x\"\n")
    assert tomllib.loads(text) == data
    assert "f = 0.1\n" in text  # a numpy float as a float, not np.float64(...)
    assert "short = { a = 1 }" in text  # a table of short tables: inline
    assert "[u.long]" in text and "[u.short]" in text  # one too long: all sections, in order
    assert text.count("[[rows]]") == 2 and 'from = "a.b[1,2]"' in text


@pytest.mark.parametrize("bad", [None, float("nan"), object()])
def test_a_value_toml_cannot_hold_is_refused_by_its_key_path(bad: object) -> None:
    with pytest.raises(ValueError, match=r"t\.v"):
        toml_text({"t": {"v": [bad]}})
