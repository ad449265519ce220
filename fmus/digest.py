"""Content digests: of a symbolic model, of the code generators, of a built FMU's inputs.

A digest is the SHA-256 of a canonical text of everything that defines a thing, so two
processes (or two sessions) that build the same model compute the same digest, and any change
to an expression, a variable's unit or range, a table, a sampler's module file or the
generators themselves changes it. :mod:`satfmu.fmus.export` skips a build whose FMU already carries
the digest of its inputs; :mod:`satfmu.fmus.codegen` lowers a model once per digest; the GUID is
derived from the model digest.
"""
from __future__ import annotations

import dataclasses
import hashlib
import json
from functools import lru_cache
from pathlib import Path
from typing import Any

import sympy as sp

from satfmu.fmus.model import Model, Sampler

HERE = Path(__file__).resolve().parent

GENERATOR_FILES = ("annotations.py", "arrays.py", "build_record.py", "codegen.py", "description.py", "description3.py",
                   "description_me.py", "digest.py", "events.py", "export.py", "instants.py", "model.py", "pyslave.py",
                   "table.py",
                   "c/satfmu_core.h", "c/satfmu_me.h", "c/fmi2_common.h", "c/fmi2_cosim.c", "c/fmi2_me.c",
                   "c/fmi3_common.h", "c/fmi3.c", "c/fmi3_me.c", "c/pythonfmu_shim.c")
"""The files (relative to :mod:`satfmu.fmus`) whose text shapes a generated FMU."""


def sha256(data: bytes) -> str:
    """Hex SHA-256 of ``data``.

    Parameters
    ----------
    data : bytes
        The bytes to hash.

    Returns
    -------
    str
        The 64 hex digits of the digest.
    """
    return hashlib.sha256(data).hexdigest()


def _canonical(obj: Any) -> Any:
    """A JSON-able image of ``obj`` that two equal definitions share (dataclasses field by
    field, sympy objects by :func:`sympy.srepr`, which keeps symbol assumptions)."""
    if isinstance(obj, (sp.Basic, sp.MatrixBase)):
        return sp.srepr(obj)
    if isinstance(obj, Sampler):
        fields = {f.name: _canonical(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
        if obj.module is not None:  # the file's text, not only its path
            fields["module_text"] = sha256(Path(obj.module).read_bytes())
        if obj.c_header_path is not None:
            fields["c_header_text"] = sha256(obj.c_header_path.read_bytes())
        return fields
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return {f.name: _canonical(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
    if isinstance(obj, dict):
        return {str(k): _canonical(v) for k, v in sorted(obj.items(), key=lambda kv: str(kv[0]))}
    if isinstance(obj, (list, tuple)):
        return [_canonical(v) for v in obj]
    if isinstance(obj, float):
        return repr(obj)  # every bit of the value
    if obj is None or isinstance(obj, (str, int, bool)):
        return obj
    raise TypeError(f"no canonical form for {type(obj).__name__}")


def model_digest(model: Model) -> str:
    """Hex SHA-256 of every field of ``model`` (expressions, variables, tables, sampler).

    Cached on the model object, which is never changed after construction.

    Parameters
    ----------
    model : Model
        The model; its sampler's module and C header files count by their content.

    Returns
    -------
    str
        The 64 hex digits of the digest.
    """
    cached = model.__dict__.get("_digest")
    if cached is None:
        text = json.dumps(_canonical(model), sort_keys=True, separators=(",", ":"))
        cached = model.__dict__["_digest"] = sha256(text.encode())
    return cached


@lru_cache(maxsize=None)
def generator_digest() -> str:
    """Hex SHA-256 of the generator files (:data:`GENERATOR_FILES`) and the versions of the
    packages whose files go into an FMU (fmpy's FMI headers, pythonfmu's runtime)."""
    from importlib.metadata import version

    h = hashlib.sha256()
    for name in GENERATOR_FILES:
        h.update(name.encode() + b"\0" + (HERE / name).read_bytes() + b"\0")
    for package in ("fmpy", "pythonfmu"):
        h.update(f"{package}=={version(package)}\0".encode())
    return h.hexdigest()


def build_digest(model: Model, backend: str, resources: dict[str, bytes] | None, toolchain: str = "") -> str:
    """Hex SHA-256 of everything a build of ``model``'s FMU on ``backend`` reads.

    Parameters
    ----------
    model : Model
    backend : {"native", "python"}
    resources : dict of str to bytes, optional
        The files the FMU carries in ``resources/``.
    toolchain : str
        Identification of the compilers (name and version) of the build's binaries.
    """
    payload = {"model": model_digest(model), "backend": backend, "generator": generator_digest(),
               "toolchain": toolchain,
               "resources": {k: sha256(v) for k, v in sorted((resources or {}).items())}}
    return sha256(json.dumps(payload, sort_keys=True).encode())
