"""Every public function, class and method of satfmu has a numpydoc docstring that documents each
of its parameters, and documents no parameter it does not have (numpydoc's docscrape parses them;
python-control's docstring test is the model).

Public: a module of the facade or of the four packages whose name has no leading underscore, and
in it every function or class defined there (not imported) whose name has none, with the class's
methods, static and class methods. A class documents its constructor's parameters in its own
docstring (``Parameters``, or ``Attributes`` for a dataclass's fields). Exempt: ``*args`` and
``**kwargs``, and methods that override a method of a class outside satfmu (pythonfmu's
``Fmi2Slave``, ``ast.NodeTransformer``: the base class documents the contract).
"""
from __future__ import annotations

import importlib
import inspect
import pkgutil
import warnings
from types import ModuleType
from typing import Any, Iterator

import pytest
from numpydoc.docscrape import ClassDoc, FunctionDoc

PACKAGES = ("satfmu.fmus", "satfmu.controllers", "satfmu.synthesis", "satfmu.sims")


def public_modules() -> list[str]:
    names = ["satfmu", "satfmu.testing"]
    for package in PACKAGES:
        names.append(package)
        module = importlib.import_module(package)
        for info in pkgutil.walk_packages(module.__path__, package + "."):
            if not any(part.startswith("_") for part in info.name.split(".")):
                names.append(info.name)
    return names


def overrides_foreign(cls: type, name: str) -> bool:
    """Whether ``cls.name`` overrides a method of a base class defined outside satfmu."""
    return any(name in vars(base) and not base.__module__.startswith("satfmu") for base in cls.__mro__[1:]
               if base is not object)


def documented(module: ModuleType) -> Iterator[tuple[str, Any]]:
    """(qualified name, object) of every public function, class and method defined in ``module``."""
    for name, obj in vars(module).items():
        if name.startswith("_") or getattr(obj, "__module__", None) != module.__name__:
            continue
        if inspect.isfunction(obj):
            yield name, obj
        elif inspect.isclass(obj):
            yield name, obj
            for member, raw in vars(obj).items():
                if member.startswith("_") or overrides_foreign(obj, member):
                    continue
                if inspect.isfunction(raw) or isinstance(raw, (staticmethod, classmethod)):
                    yield f"{name}.{member}", getattr(obj, member)


def parameters(obj: Any) -> list[str]:
    try:
        signature = inspect.signature(obj)
    except (TypeError, ValueError):  # a built-in without a signature
        return []
    skip = (inspect.Parameter.VAR_POSITIONAL, inspect.Parameter.VAR_KEYWORD)
    return [name for name, p in signature.parameters.items() if name not in ("self", "cls") and p.kind not in skip]


def problems(qualname: str, obj: Any) -> list[str]:
    """What is wrong with the docstring of ``obj`` (empty when nothing)."""
    if not (inspect.getdoc(obj) or "").strip():
        return [f"{qualname}: no docstring"]
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # numpydoc warns on an unknown section: a malformed docstring
        try:
            doc = ClassDoc(obj, config={"show_class_members": False}) if inspect.isclass(obj) else FunctionDoc(obj)
        except Exception as exc:
            return [f"{qualname}: numpydoc cannot parse the docstring ({exc})"]
    sections = ("Parameters", "Other Parameters") + (("Attributes",) if inspect.isclass(obj) else ())
    names = {part.strip().lstrip("*") for section in sections for entry in doc[section]
             for part in entry.name.split(",")}
    wanted = parameters(obj)
    out = [f"{qualname}: parameter {p!r} not documented" for p in wanted if p not in names]
    if not inspect.isclass(obj):  # a class's Attributes may name more than its constructor takes
        out += [f"{qualname}: documents {n!r}, which is not a parameter" for n in sorted(names - set(wanted))
                if n not in ("args", "kwargs")]
    return out


MODULES = public_modules()


@pytest.mark.parametrize("name", MODULES)
def test_every_public_function_documents_its_parameters(name: str) -> None:
    module = importlib.import_module(name)
    found = [line for qualname, obj in documented(module) for line in problems(f"{name}.{qualname}", obj)]
    assert not found, "\n".join(found)


def test_the_walk_finds_every_package_and_the_check_can_fail() -> None:
    assert len(MODULES) > 100 and "satfmu.sims.scenario.spec" in MODULES and "satfmu.synthesis.core.sos" in MODULES

    def undocumented(a: int, b: float) -> None:
        """Does something.

        Parameters
        ----------
        a : int
            One.
        c : float
            Not a parameter.
        """

    assert problems("f", undocumented) == ["f: parameter 'b' not documented", "f: documents 'c', which is not a "
                                                                              "parameter"]
    assert problems("g", lambda x: x) == ["g: no docstring"]
