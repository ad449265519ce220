"""A scenario of your own, built in Python: your satellite, a manoeuvre, a disturbance, metrics.

    python examples/own_scenario.py [OUT_FOLDER]     # writes CSV, plot and summary there

It starts from the TOML scenario next to this file, changes it in Python (a second
manoeuvre angle, a small sinusoidal disturbance), runs both through the FMUs and writes the
results.
"""
from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

import satfmu


def main(out: Path) -> int:
    base = satfmu.Scenario.from_toml(Path(__file__).with_name("my_scenario.toml"))
    plant = dataclasses.replace(base.fmus["plant"], parameters={
        **satfmu.SEED_000.parameters(), **satfmu.manoeuvre(120.0, axis=(0.0, 0.0, 1.0))})
    bigger = dataclasses.replace(
        base, name="my_120deg_with_a_wobble", description="120 deg about z, 0.01 N m sinusoid on y",
        fmus={**base.fmus, "plant": plant},
        profiles=[{"to": "plant.w_d[2]", "kind": "sinusoid", "amplitude": 0.01, "frequency_Hz": 0.05}])
    failed = 0
    for sc in (base, bigger):
        result = satfmu.run(sc, out_dir=out, plots=True)
        print(f"{'PASS' if result.passed else 'FAIL'} {sc.name}: " + "; ".join(
            f"{m.name} {m.value:.4g} {m.unit}" for m in result.metrics))
        print("  wrote", ", ".join(str(p) for p in result.files.values()))
        failed += not result.passed
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main(Path(sys.argv[1] if len(sys.argv) > 1 else "my_results")))
