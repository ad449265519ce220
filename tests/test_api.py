"""The public API: ``import satfmu`` is cheap, ``help(satfmu)`` lists it, every name is documented."""
from __future__ import annotations

import inspect
import pydoc
import subprocess
import sys

import pytest

import satfmu


def test_import_is_cheap():
    """``import satfmu`` loads no implementation package (names are imported on first use)."""
    code = ("import sys, satfmu; print(sorted(m for m in ('sympy', 'numpy', 'fmpy', 'sims', 'fmus') "
            "if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_help_lists_the_public_api():
    text = pydoc.render_doc(satfmu, renderer=pydoc.plaintext)
    for name in satfmu.__all__:
        assert (satfmu.__version__ if name == "__version__" else name) in text, name


@pytest.mark.parametrize("name", [n for n in satfmu.__all__ if n != "__version__"])
def test_every_public_name_has_a_numpydoc_docstring(name):
    """A summary line, and for a callable with parameters a Parameters section (numpydoc)."""
    obj = getattr(satfmu, name)
    if not (inspect.isclass(obj) or inspect.isfunction(obj)):
        return  # a constant (SEED_000): documented in the module docstring
    doc = inspect.getdoc(obj)
    assert doc and doc.splitlines()[0].strip(), f"{name} has no summary line"
    if inspect.isclass(obj) and issubclass(obj, BaseException):
        return
    params = [p for p in inspect.signature(obj).parameters if p not in ("self", "args", "kwargs")]
    if params:
        sections = ("Parameters\n----------", "Attributes\n----------")
        assert any(s in doc for s in sections), f"{name}: no numpydoc Parameters (or Attributes) section"
        for p in params:
            assert p in doc, f"{name}: parameter {p!r} is not documented"


def test_version_and_unknown_name():
    assert satfmu.__version__.count(".") >= 1
    with pytest.raises(AttributeError, match="no attribute 'Scenaro'"):
        satfmu.Scenaro


def test_names_are_the_implementations():
    from satfmu.sims.scenario.result import Result
    from satfmu.sims.scenario.spec import Scenario

    assert satfmu.Scenario is Scenario and satfmu.Result is Result


def test_result_metrics_are_in_order_and_by_name(fmu_dir) -> None:
    result = satfmu.run("examples/my_scenario.toml", fmu_dir=fmu_dir)
    assert [m.name for m in result.metrics] == ["angle error at the end", "peak torque"]  # a list, in order
    assert result.metrics["peak torque"] is result.metrics[1]  # and a lookup by name
    assert result.metrics["peak torque"].value < 5.0  # the scenario's bound (measured 0.72 N m)
    with pytest.raises(KeyError, match="did you mean 'peak torque'"):
        result.metrics["peak torqe"]
