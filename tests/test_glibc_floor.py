"""The glibc a native FMU's Linux binary needs (issue 28, defect 6).

Every native FMU's ``binaries/linux64`` library must load on glibc :data:`FLOOR` and later (RHEL 8
has glibc 2.28): no symbol it imports may carry a newer ``GLIBC_`` version. Before the fix, the
FMUs whose model has an integer power (printed ``pow(x, 3)``) imported ``pow@GLIBC_2.29``;
``fmus/c/fmi2_cosim.c`` now binds the functions glibc 2.29 re-versioned to their base version.
"""
from __future__ import annotations

import re
import shutil
import subprocess
import zipfile
from pathlib import Path

from satfmu.fmus import export

FLOOR = (2, 14)
"""Newest glibc symbol version a native FMU may need (memcpy@GLIBC_2.14)."""
_VERSION = re.compile(r"\bGLIBC_(\d+(?:\.\d+)+)\b")


def glibc_needs(library: Path) -> dict[str, tuple[int, ...]]:
    """The ``GLIBC_`` version each symbol of the dynamic symbol table of ``library`` carries.

    Parameters
    ----------
    library : Path
        A shared library (ELF).

    Returns
    -------
    dict of str to tuple of int
        Symbol name -> its glibc version, e.g. ``{"pow": (2, 29)}``.
    """
    proc = subprocess.run(["objdump", "-T", str(library)], capture_output=True, text=True)
    assert proc.returncode == 0, f"objdump -T {library.name} failed: {proc.stderr}"
    needs = {}
    for line in proc.stdout.splitlines():
        match = _VERSION.search(line)
        if match:
            needs[line.split()[-1]] = tuple(int(part) for part in match.group(1).split("."))
    return needs


def test_native_fmus_need_at_most_the_glibc_floor(fmu_dir: Path, tmp_path: Path) -> None:
    """No symbol of any native FMU's Linux binary (FMI 2.0 ``linux64``, FMI 3.0 ``x86_64-linux``) needs
    a glibc newer than :data:`FLOOR`."""
    assert shutil.which("objdump"), "objdump (binutils, installed with gcc) is needed to read the binaries"
    native = sorted(p for p in fmu_dir.glob("*.fmu") if not p.stem.endswith(export.PYTHON_SUFFIX))
    assert len(native) >= 10, f"only {len(native)} native FMUs in {fmu_dir}: the catalog was not built"
    too_new = {}
    for fmu in native:
        with zipfile.ZipFile(fmu) as z:
            (member,) = [n for n in z.namelist() if n.startswith(("binaries/linux64/", "binaries/x86_64-linux/"))
                         and n.endswith(".so")]
            library = Path(z.extract(member, tmp_path / fmu.stem))
        needs = glibc_needs(library)
        assert needs, f"{fmu.name}: no GLIBC_ symbol version read from objdump -T (the parser, not the FMU, is wrong)"
        newer = {name: ".".join(map(str, v)) for name, v in needs.items() if v > FLOOR}
        if newer:
            too_new[fmu.name] = newer
    floor = ".".join(map(str, FLOOR))
    assert not too_new, f"native FMUs needing a glibc newer than {floor} (they do not load on older ones): {too_new}"


def test_pythonfmu_c_layer_needs_at_most_the_glibc_floor(fmu_dir: Path, tmp_path: Path) -> None:
    """The C layer of every pythonfmu FMU (``binaries/linux64/<model>_py.so``, fmus/c/pythonfmu_shim.c)
    needs no glibc newer than :data:`FLOOR` either (its dl functions bound to GLIBC_2.2.5, not
    2.34's): it adds nothing to the glibc 2.32 that pythonfmu's own library needs."""
    python = sorted(fmu_dir.glob(f"*{export.PYTHON_SUFFIX}.fmu"))
    assert len(python) >= 10, f"only {len(python)} pythonfmu FMUs in {fmu_dir}: the catalog was not built"
    too_new = {}
    for fmu in python:
        with zipfile.ZipFile(fmu) as z:
            library = Path(z.extract(f"binaries/linux64/{fmu.stem}.so", tmp_path / fmu.stem))
        needs = glibc_needs(library)
        assert "dlopen" in needs, f"{fmu.name}: the C layer does not call dlopen (not satfmu's layer?)"
        newer = {name: ".".join(map(str, v)) for name, v in needs.items() if v > FLOOR}
        if newer:
            too_new[fmu.name] = newer
    assert not too_new, f"pythonfmu C layers needing a glibc newer than the floor: {too_new}"
