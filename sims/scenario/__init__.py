"""Scenarios: a co-simulation declared in TOML, its validation, wiring, run, result and metrics.

This package's own namespace is light (the command line lists the shipped scenarios without
importing a numerical library); the scenario machinery is in its modules.
"""
from __future__ import annotations

from pathlib import Path

SHIPPED_SCENARIOS = Path(__file__).resolve().parent / "shipped"
"""Folder of the scenarios shipped with satfmu (``*.toml``)."""


def shipped_scenarios() -> list[Path]:
    """The shipped scenario files, sorted by name."""
    return sorted(SHIPPED_SCENARIOS.glob("*.toml"))
