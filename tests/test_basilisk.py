"""satfmu's plant FMUs against Basilisk, the independent reference (bench/basilisk_compare.py; the
bench extra, skipped without it)."""
from __future__ import annotations

import importlib
import sys
from pathlib import Path

import pytest

pytest.importorskip("Basilisk", reason="Basilisk (bsk) is in the bench extra: make test-all installs it")
BENCH = Path(__file__).resolve().parents[1] / "bench"


@pytest.mark.slow
def test_wheel_plant_and_environment_torques_agree_with_basilisk(fmu_dir: Path) -> None:
    # 20 s of bench/basilisk_compare.py's cases (60 s there): the tolerances and their reasons are the
    # bench's (the same RK4 map: rounding only; measured 5e-13 rad, 7e-14 rad/s, 3e-12 rad/s in 60 s)
    sys.path.insert(0, str(BENCH))
    try:
        bench = importlib.import_module("basilisk_compare")
    finally:
        sys.path.remove(str(BENCH))
    rows = bench.compare(stop=20.0, fmu_dir=fmu_dir)
    assert len(rows) == 9  # 3 wheel-case quantities, 4 environment torques, 2 conservation checks
    failed = [r for r in rows if not r.passed]
    assert not failed, bench.table(failed)
    attitude = next(r for r in rows if r.quantity.startswith("attitude"))
    assert attitude.difference < 1e-11  # far inside the bound: a regression shows as orders of magnitude
