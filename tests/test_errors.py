"""One error hierarchy: every exception and warning satfmu defines lives in satfmu.fmus.errors under
SatfmuError or SatfmuWarning, keeps its built-in base, is the same object under the module that
raises it and in the facade; every public design function fails with DesignError only."""
from __future__ import annotations

import ast
import inspect
from pathlib import Path
from typing import Callable

import pytest

import satfmu
from satfmu.fmus import errors
from satfmu.synthesis import designs

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("fmus", "controllers", "synthesis", "sims", "satfmu")
# the one exception class defined elsewhere: it is raised inside a pythonfmu FMU, whose Python
# runtime has no satfmu package to import (the FMU's C layer turns it into fmi2Error)
INSIDE_THE_FMU = {("fmus/pyslave.py", "CallRefused")}
INTERNAL = {"CaseBroken"}  # the robustness suite's own signal: not in the facade


def classes() -> dict[str, type]:
    return {name: obj for name, obj in vars(errors).items()
            if inspect.isclass(obj) and obj.__module__ == errors.__name__}


def test_every_class_is_under_one_base_and_keeps_its_builtin_base() -> None:
    found = classes()
    assert len(found) >= 40
    for name, cls in found.items():
        assert issubclass(cls, (errors.SatfmuError, errors.SatfmuWarning)), name
        assert not (issubclass(cls, errors.SatfmuError) and issubclass(cls, Warning)), name
    # what `except ValueError` / `except RuntimeError` / `except KeyError` caught before still is caught
    for cls in (errors.ScenarioError, errors.SspError, errors.ArtifactError, errors.SpacecraftError,
                errors.UnsafeFmuError, errors.DeltaError, errors.VariantError):
        assert issubclass(cls, ValueError), cls
    for cls in (errors.DesignError, errors.SOSError, errors.FmuCallError, errors.FmuBuildError):
        assert issubclass(cls, RuntimeError), cls
    assert issubclass(errors.UnknownVariableError, KeyError) and issubclass(errors.SolverMemoryError, MemoryError)
    assert str(errors.UnknownVariableError("no FMU 'x'")) == "no FMU 'x'"  # not quoted as KeyError's


def test_the_facade_exports_every_public_class_as_the_same_object() -> None:
    public = {name for name in classes() if name not in INTERNAL}
    exported = {name for name in satfmu.__all__
                if inspect.isclass(obj := getattr(satfmu, name)) and issubclass(obj, (Exception, Warning))}
    assert exported == public
    for name in public:
        assert getattr(satfmu, name) is getattr(errors, name)


def test_no_exception_class_is_defined_outside_the_errors_module() -> None:
    """An AST scan of every module: a class whose base names an Error, Warning or Exception is
    defined in satfmu.fmus.errors only (so FmuCallError, once defined twice, exists once)."""
    outside = set()
    for package in PACKAGES:
        for path in (ROOT / package).rglob("*.py"):
            rel = path.relative_to(ROOT).as_posix()
            if rel == "fmus/errors.py":
                continue
            for node in ast.walk(ast.parse(path.read_text(), rel)):
                if isinstance(node, ast.ClassDef) and any(
                        any(word in ast.unparse(b) for word in ("Error", "Warning", "Exception", "Failure"))
                        for b in node.bases):
                    outside.add((rel, node.name))
    assert outside == INSIDE_THE_FMU


def test_modules_that_raise_a_class_re_export_the_same_object() -> None:
    from satfmu.sims.cosim import master
    from satfmu.sims.scenario import spec as scenario
    from satfmu.synthesis.robust import lft_plant
    from satfmu.synthesis.core import sos

    assert scenario.ScenarioError is errors.ScenarioError and master.FmuCallError is errors.FmuCallError
    assert sos.SOSError is errors.SOSError and lft_plant.DeltaError is errors.DeltaError
    assert designs.DesignError is errors.DesignError


BAD_DESIGNS: list[tuple[str, Callable[[], object], str, type | None]] = [
    # (case, call, message, the chained cause's class or None when the design refuses it itself)
    ("hinf, a plant that is no spacecraft", lambda: designs.design_hinf(plant=42), "plant must be", None),
    ("h2hinf, a cubesat model as plant",
     lambda: designs.design_h2hinf(1.0, plant=satfmu.cubesat_plant()), "MRP satellite model", None),
    ("vscmg, a spacecraft as grid", lambda: designs.design_vscmg_sdre(satfmu.SEED_000), "grid must be", None),
    ("sdre, a fit degree the region cannot take", lambda: designs.design_sdre(max_degree=3),
     r"max_degree must be an integer in 0\.\.2", None),
    ("sdre, a NaN box", lambda: designs.design_sdre(s_max=float("nan")), "s_max", ValueError),
    ("cubesat, a negative gamma", lambda: designs.design_cubesat_periodic(gamma=-1.0),
     "gamma must be finite and > 0", ValueError),
    ("demeter, an axis that does not exist", lambda: designs.design_demeter(axes=(7,)),
     "axes must be distinct integers in 1..3", errors.VariantError),
]


@pytest.mark.parametrize("case, call, message, cause", BAD_DESIGNS, ids=[c[0] for c in BAD_DESIGNS])
def test_every_design_function_fails_with_design_error(case: str, call: Callable[[], object], message: str,
                                                       cause: type | None) -> None:
    with pytest.raises(designs.DesignError, match=message) as refused:
        call()
    if cause is None:
        assert refused.value.__cause__ is None
    else:
        assert isinstance(refused.value.__cause__, cause)


def test_the_guard_keeps_a_design_error_and_chains_any_other() -> None:
    own = designs.DesignError("no certified design")

    @designs.fails_with_design_error
    def refuses() -> designs.Design:
        raise own

    @designs.fails_with_design_error
    def breaks() -> designs.Design:
        raise ZeroDivisionError("division by zero")

    with pytest.raises(designs.DesignError) as kept:
        refuses()
    assert kept.value is own
    with pytest.raises(designs.DesignError, match="^ZeroDivisionError: division by zero$") as wrapped:
        breaks()
    assert isinstance(wrapped.value.__cause__, ZeroDivisionError)
    for name in ("design_hinf", "design_h2hinf", "design_sdre", "design_vscmg_sdre", "design_cubesat_periodic",
                 "design_demeter"):
        assert getattr(satfmu, name).__wrapped__.__name__ == name  # guarded, signature and docstring kept
