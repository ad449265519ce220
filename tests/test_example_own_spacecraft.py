"""examples/own_spacecraft.py and its pytest gate, as a user runs them (see test_examples.py):
the seed 000 design for a spacecraft with products of inertia, certified, flown through the
FMUs from 90 deg, and the published controller flagged on that plant."""
from __future__ import annotations

import sys

from tests.test_examples import _run, user  # noqa: F401  (the module fixture)


def test_design_for_your_own_spacecraft_and_its_gate(user):  # noqa: F811
    work, env = user
    out = _run([sys.executable, "own_spacecraft.py"], work, env).stdout
    assert "certificate: certified" in out
    assert "ok   angle error at 120 s" in out and "ok   peak torque" in out
    assert "I_x = 100 (designed for 15)" in out  # the mismatch warning on the published controller
    gate = _run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "test_own_spacecraft.py"],
                work, env).stdout
    assert "3 passed" in gate
