"""Shared fixtures: every FMU built once per session from the current source tree."""
from __future__ import annotations

from pathlib import Path

import pytest

from sims import catalog

ROOT = Path(__file__).resolve().parents[1]
PUBLISHED = ROOT / "controllers" / "artifacts" / "mrp_hinf_published.json"
# Seed 000, 200 deg case: s(0) = k tan(50 deg), as printed in the seed.
SIGMA_200 = {"sigma_0[1]": 0.5992, "sigma_0[2]": -0.7976, "sigma_0[3]": 0.6517}


@pytest.fixture(scope="session")
def fmu_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Folder with all four FMUs (plant and published controller, native and pythonfmu)."""
    dest = tmp_path_factory.mktemp("fmus")
    catalog.build_all(dest)
    return dest
