"""Write satfmu/fmus/signal_functions.py: the generic signal generators' numpy functions.

The master's profiles evaluate the analytic kinds (constant, step, sinusoid, cosine_ramp) with
them, without importing sympy; run this after changing a generator in fmus/signals.py
(tests/test_signals.py says when the module no longer gives the generators' values).

    .venv/bin/python scripts/generate_signal_functions.py
"""
from __future__ import annotations

from pathlib import Path

from satfmu.fmus import signals

if __name__ == "__main__":
    target = Path(signals.__file__).with_name(signals.NUMPY_MODULE)
    target.write_text(signals.numpy_source())
    print(f"wrote {target}")
