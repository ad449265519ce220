"""pytest on FMU outputs: fixtures and assertions for gating your designs.

Installed as a pytest plugin (entry point ``satfmu``): in any test of yours,

.. code-block:: python

    import satfmu
    from satfmu.testing import assert_metric, assert_passed

    def test_my_controller(satfmu_run):
        result = satfmu_run("my_scenario.toml")      # FMUs built (or reused, by digest) once
        assert_passed(result)                         # every metric within its bounds
        assert_metric(result, "peak torque", max=4.0) # a tighter bound of your own

Fixtures
    ``satfmu_fmu_dir`` (session): the FMU folder of the test session: ``--satfmu-fmu-dir``,
    else ``$SATFMU_FMU_DIR``, else :func:`satfmu.controllers.paths.fmu_cache`. ``satfmu_run`` (session):
    ``satfmu_run(scenario, **options) -> Result`` runs in that folder, building the FMUs the
    scenario names that are missing or out of date (by build digest) once per session.
"""
from __future__ import annotations

import math
import os
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable

import pytest

if TYPE_CHECKING:
    from satfmu.sims.scenario.result import Result

FMU_DIR_ENV = "SATFMU_FMU_DIR"


def pytest_addoption(parser: pytest.Parser) -> None:
    """The ``--satfmu-fmu-dir`` option.

    Parameters
    ----------
    parser : pytest.Parser
        pytest's command-line parser (the ``pytest_addoption`` hook).
    """
    parser.addoption("--satfmu-fmu-dir", default=None,
                     help=f"FMU folder of the satfmu fixtures (default ${FMU_DIR_ENV}, else satfmu's FMU cache)")


@pytest.fixture(scope="session")
def satfmu_fmu_dir(request: pytest.FixtureRequest) -> Path:
    """The session's FMU folder (created if missing)."""
    from satfmu.controllers.paths import fmu_cache

    chosen = request.config.getoption("--satfmu-fmu-dir") or os.environ.get(FMU_DIR_ENV)
    folder = Path(chosen).resolve() if chosen else fmu_cache()
    folder.mkdir(parents=True, exist_ok=True)
    return folder


@pytest.fixture(scope="session")
def satfmu_run(satfmu_fmu_dir: Path) -> Callable[..., "Result"]:
    """``satfmu_run(scenario, backend="native", strict=False, ...) -> Result`` in the session's
    FMU folder; each FMU is brought up to date (rebuilt if its build digest differs) once."""
    from satfmu.controllers import catalog
    from satfmu.sims.scenario.run import run as run_scenario
    from satfmu.sims.scenario.spec import load

    fresh: set[tuple[str, str]] = set()

    def run(spec: Any, backend: str = "native", **options: Any) -> "Result":
        sc = load(spec)
        wanted = [(s.model, s.backend or backend) for s in sc.fmus.values() if s.model is not None]
        for name, b in dict.fromkeys(w for w in wanted if w not in fresh):
            catalog.ensure(satfmu_fmu_dir, [name], b, rebuild_stale=True)
            fresh.add((name, b))
        return run_scenario(sc, satfmu_fmu_dir, backend, **options)

    return run


def failures(result: "Result") -> list[str]:
    """One readable line per metric outside its bounds, e.g.
    ``"angle error at the end = 0.31 deg, above its max 0.1"``.

    Parameters
    ----------
    result : Result
        A scenario run (:func:`satfmu.run`, the ``satfmu_run`` fixture).

    Returns
    -------
    list of str
        Empty when every metric is within its bounds.
    """
    out = []
    for m in result.metrics:
        if m.passed:
            continue
        if not math.isfinite(m.value):
            out.append(f"{m.name} = {m.value} {m.unit} (not finite)")
        elif m.max is not None and m.value > m.max:
            out.append(f"{m.name} = {m.value:.6g} {m.unit}, above its max {m.max:g}")
        else:
            out.append(f"{m.name} = {m.value:.6g} {m.unit}, below its min {m.min:g}")
    return out


def assert_passed(result: "Result") -> None:
    """Fail with every metric outside its bounds (and any design mismatch) listed.

    Parameters
    ----------
    result : Result
        A scenario run (:func:`satfmu.run`, the ``satfmu_run`` fixture).

    Raises
    ------
    AssertionError
        ``"my_run (native): 1 of 3 metrics fail: ..."``.
    """
    bad = failures(result)
    if bad:
        extra = f"; design mismatches: {'; '.join(result.warnings)}" if result.warnings else ""
        raise AssertionError(f"{result.name} ({result.backend}): {len(bad)} of {len(result.metrics)} metrics "
                             f"fail: {'; '.join(bad)}{extra}")


def assert_metric(result: "Result", name: str, *, max: float | None = None, min: float | None = None) -> float:
    """Assert one metric against bounds of your own (tighter or other than the scenario's).

    Parameters
    ----------
    result : Result
        A scenario run (:func:`satfmu.run`, the ``satfmu_run`` fixture).
    name : str
        The metric's name, as the scenario declares it.
    max, min : float, optional
        Bounds on the metric's value, in the metric's unit (none by default).

    Returns
    -------
    float
        The metric's value.

    Raises
    ------
    AssertionError
        With the value, unit and the bound it misses.
    KeyError
        No metric of that name (with the closest name).
    """
    m = result.metric(name)
    if not math.isfinite(m.value):
        raise AssertionError(f"{result.name}: {name} = {m.value} (not finite)")
    if max is not None and not m.value <= max:
        raise AssertionError(f"{result.name}: {name} = {m.value:.6g} {m.unit}, above {max:g}")
    if min is not None and not m.value >= min:
        raise AssertionError(f"{result.name}: {name} = {m.value:.6g} {m.unit}, below {min:g}")
    return m.value
