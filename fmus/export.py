"""Turn a :class:`satfmu.fmus.model.Model` into co-simulation FMUs: native C (FMI 2.0 and FMI 3.0)
and pythonfmu (FMI 2.0).

The native FMU carries ``sources/`` (the interface's wrapper, ``fmi2_cosim.c``, its one ``.c`` file
and the only file ``<SourceFiles>`` lists, the model-independent ``satfmu_core.h`` and the
generated model header, :data:`satfmu.fmus.codegen.C_HEADER`) so other platforms can rebuild it
(``fmpy compile``, or a tool compiling every ``.c`` file under ``sources/``), and two binaries
compiled here against the FMI headers that fmpy ships, concurrently:
``binaries/linux64/<model>.so`` (gcc) and ``binaries/win64/<model>.dll`` (the MinGW-w64 cross
compiler, :data:`WIN64_CC`). The FMI 3.0 FMU (:func:`build_fmi3`, ``<model>_fmi3.fmu``) is the
same model through ``fmi3.c``, its sources listed in ``sources/buildDescription.xml`` and its
binaries under ``binaries/x86_64-linux`` and ``binaries/x86_64-windows``. The
pythonfmu FMU embeds the generated Python module and :mod:`satfmu.fmus.pyslave`; its binaries are
satfmu's C layer (``c/pythonfmu_shim.c``, compiled here for both platforms) in front of
pythonfmu's library, which lies beside them as ``<model>_py_pythonfmu.so`` (``.dll``).

Builds are incremental: every FMU records, as its zip archive's comment, the digest of what
its build read (:func:`satfmu.fmus.digest.build_digest`: the model, the resources, the generators,
the compilers), and a build whose destination already carries that digest does nothing. A
controller FMU also records there the SHA-256 of the artifact it embeds
(``resources/artifact.json``; :mod:`satfmu.fmus.build_record` reads both), which a run compares with the
artifact file of its name (:mod:`satfmu.sims.cosim.preflight`). The comment reads
``satfmu-build sha256:<build digest>[ artifact sha256:<artifact digest>]``. An FMU is written
under a temporary name and renamed into place, so an interrupted build never leaves a partial
file under the FMU's name.
"""
from __future__ import annotations

import shutil
import subprocess
import sys
import tempfile
import zipfile
from functools import lru_cache
from pathlib import Path
from satfmu.fmus import codegen
from satfmu.fmus.atomic import write_atomically
from satfmu.fmus.build_record import built_digest, comment
from satfmu.fmus.description import (NATIVE, PYTHON, PYTHON_SUFFIX, WRAPPER_SOURCE, capabilities, model_description,
                              to_xml_bytes)
from satfmu.fmus.description3 import FMI3_SUFFIX, WRAPPER3_SOURCE, build_description, model_description3
from satfmu.fmus.description_me import (ME_SUFFIX, WRAPPER3_ME_SOURCE, WRAPPER_ME_SOURCE, model_description3_me,
                                       model_description_me)
from satfmu.fmus.digest import build_digest
from satfmu.fmus.model import Model
from satfmu.fmus.errors import FmuBuildError

HERE = Path(__file__).resolve().parent
WRAPPER = HERE / "c" / WRAPPER_SOURCE
WRAPPER3 = HERE / "c" / WRAPPER3_SOURCE
WRAPPER_ME = HERE / "c" / WRAPPER_ME_SOURCE
WRAPPER3_ME = HERE / "c" / WRAPPER3_ME_SOURCE
CORE = HERE / "c" / "satfmu_core.h"
"""The model-independent part of a native FMU that every interface's wrapper includes."""
FMI3 = "fmi3"
"""The backend of the native FMI 3.0 FMU (beside :data:`satfmu.fmus.description.NATIVE` and
:data:`satfmu.fmus.description.PYTHON`)."""
ME = "me"
"""The backend of the native FMI 2.0 model-exchange FMU of a plant (:func:`build_me`)."""
ME3 = "me3"
"""The backend of the native FMI 3.0 model-exchange FMU of a plant (:func:`build_me3`)."""
HEADERS = {NATIVE: ("fmi2_common.h",), ME: ("fmi2_common.h", "satfmu_me.h"), FMI3: ("fmi3_common.h",),
           ME3: ("fmi3_common.h", "satfmu_me.h")}
"""The headers under ``fmus/c/`` a native backend's wrapper includes beside :data:`CORE`: what the
FMI version's interfaces share, and the model-exchange part."""
FMI3_PLATFORMS = {"linux64": "x86_64-linux", "win64": "x86_64-windows"}
"""The FMI 3.0 platform tuple (folder under ``binaries/``) of each FMI 2.0 platform."""
PYSLAVE = HERE / "pyslave.py"
SHIM = HERE / "c" / "pythonfmu_shim.c"
"""satfmu's C layer in front of pythonfmu's library: the pythonfmu FMU's binaries."""
SHIM_HEADER = "shim_model.h"
PYTHONFMU_LIBRARY_SUFFIX = "_pythonfmu"
"""What pythonfmu's library is renamed to in a pythonfmu FMU: ``<model>_py`` + this + ``.so``."""
_ZIP_DATE = (2020, 1, 1, 0, 0, 0)


C_FLAGS = ("-std=c99", "-O2", "-fPIC", "-fvisibility=hidden", "-Wall", "-Wextra", "-Werror")
"""gcc flags of a native FMU's sources on every platform (compiling; linking adds
:data:`LINK_FLAGS` and ``-lm``): warnings are errors."""

WIN64_CC = "x86_64-w64-mingw32-gcc"
"""The MinGW-w64 cross compiler of the win64 binary (Debian's gcc-mingw-w64-x86-64-posix or
-win32)."""
DEFINES = {"linux64": ("-DSATFMU_GLIBC_FLOOR",), "win64": ()}
"""Preprocessor definitions of satfmu's own build of a native FMU, per platform: the glibc floor
of the Linux binary (``fmus/c/fmi2_cosim.c``), which an importer's rebuild from ``sources/`` leaves
out."""
LINK_FLAGS = {
    # NODELETE: the pythonfmu FMU's C layer registers an exit handler (fmus/c/pythonfmu_shim.c); the
    # native FMU's library has nothing that unloading would need
    "linux64": ("-shared", "-Wl,-z,nodelete"),
    # libgcc linked in (the DLL imports only KERNEL32.dll and msvcrt.dll); no time stamp and the
    # fixed image base 0x180000000 (still relocatable), so that the same sources give the same bytes;
    # stripped of the debug sections MinGW-w64's static runtime brings (a quarter of the size)
    "win64": ("-shared", "-static-libgcc", "-s", "-Wl,--no-insert-timestamp,--disable-auto-image-base"),
}
"""Link flags of a native FMU's binary per platform (its folder under ``binaries/``)."""
SUFFIX = {"linux64": ".so", "win64": ".dll"}
"""File name extension of a native FMU's binary per platform."""
# what to install when a compiler is missing (toolchain's message; gcc by default)
_INSTALL = {WIN64_CC: "install Debian's gcc-mingw-w64-x86-64-posix or -win32 (make system-deps)"}
# the macros of a compiler's headers that name the C library version (part of toolchain)
_RUNTIME_MACROS = ("__GLIBC__", "__GLIBC_MINOR__", "__MINGW64_VERSION_MAJOR", "__MINGW64_VERSION_MINOR",
                   "__MINGW64_VERSION_BUGFIX")


def fmi_headers() -> Path:
    """Folder of the FMI 2.0 headers shipped with fmpy."""
    import fmpy

    path = Path(fmpy.__file__).parent / "c-code"
    if not (path / "fmi2Functions.h").is_file():
        raise FmuBuildError(f"FMI 2.0 headers not found in {path}")
    return path


def _zip_dir(src: Path, dest: Path, comment: bytes) -> None:
    """Deterministic zip of a directory tree (sorted entries, fixed timestamps), with ``comment``
    (:func:`satfmu.fmus.build_record.comment`) as the archive comment, written to a temporary name and renamed onto
    ``dest``."""
    def write(partial: Path) -> None:
        with zipfile.ZipFile(partial, "w", zipfile.ZIP_DEFLATED) as z:
            for f in sorted(p for p in src.rglob("*") if p.is_file()):
                info = zipfile.ZipInfo(str(f.relative_to(src)), _ZIP_DATE)
                info.compress_type = zipfile.ZIP_DEFLATED
                info.external_attr = 0o644 << 16
                z.writestr(info, f.read_bytes())
            z.comment = comment

    write_atomically(dest, write)


@lru_cache(maxsize=None)
def toolchain(cc: str) -> str:
    """The C compiler's identification, part of a native build's digest: ``cc --version``'s first
    line and the version of the C library its headers declare (glibc, or the MinGW-w64 runtime,
    whose math functions are linked into the win64 DLL).

    Parameters
    ----------
    cc : str
        The compiler's command (``"gcc"``, :data:`WIN64_CC`).

    Returns
    -------
    str
        ``"<cc>: <first line of --version>; <C library version macros>"``.

    Raises
    ------
    FmuBuildError
        If the compiler is not found.
    """
    if shutil.which(cc) is None:
        raise FmuBuildError(f"C compiler {cc!r} not found ({_INSTALL.get(cc, 'install gcc')})")
    proc = subprocess.run([cc, "--version"], capture_output=True, text=True)
    macros = subprocess.run([cc, "-E", "-dM", "-x", "c", "-"], input="#include <stdio.h>\n",
                            capture_output=True, text=True).stdout
    defined = dict(line.split(None, 2)[1:] for line in macros.splitlines() if len(line.split(None, 2)) == 3)
    runtime = " ".join(f"{m}={defined[m]}" for m in _RUNTIME_MACROS if m in defined)
    return f"{cc}: {proc.stdout.splitlines()[0] if proc.stdout else proc.returncode}; {runtime}"


def fmu_path(model: Model, dest_dir: Path, backend: str) -> Path:
    """Where the FMU of ``model`` on ``backend`` (``"native"`` or ``"python"``) goes in ``dest_dir``.

    Parameters
    ----------
    model : Model
        The model of the FMU.
    dest_dir : Path
        The folder of the FMUs.
    backend : {"native", "python", "fmi3", "me", "me3"}
        The backend; a pythonfmu FMU's name ends in ``_py``, an FMI 3.0 FMU's in ``_fmi3``, a
        model-exchange FMU's in ``_me`` (FMI 3.0: ``_me_fmi3``).

    Returns
    -------
    Path
        ``<dest_dir>/<model.name>.fmu``, ``<model.name>_py.fmu``, ``<model.name>_fmi3.fmu``,
        ``<model.name>_me.fmu`` or ``<model.name>_me_fmi3.fmu``.
    """
    return Path(dest_dir) / f"{model.name}{_SUFFIXES.get(backend, '')}.fmu"


_SUFFIXES = {PYTHON: PYTHON_SUFFIX, FMI3: FMI3_SUFFIX, ME: ME_SUFFIX, ME3: ME_SUFFIX + FMI3_SUFFIX}


def digest_of(model: Model, backend: str, resources: dict[str, bytes] | None = None, cc: str = "gcc",
              win64_cc: str = WIN64_CC) -> str:
    """The build digest of ``model``'s FMU on ``backend`` (``"native"``, its compilers' identification
    included, or ``"python"``).

    Parameters
    ----------
    model : Model
        The model of the FMU.
    backend : {"native", "python"}
        The FMU's backend.
    resources : dict of str to bytes, optional
        Extra files for ``resources/`` (e.g. the controller artifact JSON), by name.
    cc : str, optional
        C compiler of the linux64 binary. Default ``"gcc"``.
    win64_cc : str, optional
        C cross compiler of the win64 binary. Default :data:`WIN64_CC`.

    Returns
    -------
    str
        The hex digest (:func:`satfmu.fmus.digest.build_digest`), the compilers' identification
        (:func:`toolchain`) included.

    Raises
    ------
    FmuBuildError
        If a compiler is not found.
    """
    return build_digest(model, backend, resources, f"{toolchain(cc)}\n{toolchain(win64_cc)}")


def build_native(model: Model, dest_dir: Path, resources: dict[str, bytes] | None = None,
                 cc: str = "gcc", win64_cc: str = WIN64_CC) -> Path:
    """Generate, compile and package the native FMU ``<dest_dir>/<model.name>.fmu``.

    Parameters
    ----------
    model : Model
        The model; it must have a C form (no Python sampler).
    dest_dir : Path
        The folder the FMU is written to.
    resources : dict of str to bytes, optional
        Extra files for ``resources/`` (e.g. the controller artifact JSON).
    cc : str, optional
        C compiler of the linux64 binary. Default ``"gcc"``.
    win64_cc : str, optional
        C cross compiler of the win64 binary (MinGW-w64). Default :data:`WIN64_CC`.

    Returns
    -------
    Path
        The FMU. Nothing is built when it already records this build's digest.

    Raises
    ------
    FmuBuildError
        If the model has no C form (a Python sampler), or a compiler is missing or reports an
        error or a warning.
    """
    return _build_c(model, dest_dir, resources, cc, win64_cc, NATIVE)


def build_fmi3(model: Model, dest_dir: Path, resources: dict[str, bytes] | None = None,
               cc: str = "gcc", win64_cc: str = WIN64_CC) -> Path:
    """Generate, compile and package the native FMI 3.0 FMU ``<dest_dir>/<model.name>_fmi3.fmu``.

    The same model and C code as :func:`build_native`'s FMI 2.0 FMU through the FMI 3.0 wrapper
    ``fmus/c/fmi3.c`` (arrays for vectors, a sampled model's clock:
    :mod:`satfmu.fmus.description3`).

    Parameters
    ----------
    model : Model
        The model; it must have a C form (no Python sampler).
    dest_dir : Path
        The folder the FMU is written to.
    resources : dict of str to bytes, optional
        Extra files for ``resources/`` (e.g. the controller artifact JSON).
    cc : str, optional
        C compiler of the x86_64-linux binary. Default ``"gcc"``.
    win64_cc : str, optional
        C cross compiler of the x86_64-windows binary (MinGW-w64). Default :data:`WIN64_CC`.

    Returns
    -------
    Path
        The FMU. Nothing is built when it already records this build's digest.

    Raises
    ------
    FmuBuildError
        As :func:`build_native`, and for a model with a variable named ``time`` or
        ``sample_clock`` (the FMI 3.0 description's own).
    """
    return _build_c(model, dest_dir, resources, cc, win64_cc, FMI3)


def build_me(model: Model, dest_dir: Path, resources: dict[str, bytes] | None = None,
             cc: str = "gcc", win64_cc: str = WIN64_CC) -> Path:
    """Generate, compile and package the FMI 2.0 model-exchange FMU ``<dest_dir>/<model.name>_me.fmu``.

    The model's states, derivatives and event indicators (:mod:`satfmu.fmus.events`) through the
    wrapper ``fmus/c/fmi2_me.c``, for an importer that integrates the plant with its own solver
    (:mod:`satfmu.fmus.description_me`).

    Parameters
    ----------
    model : Model
        The model; it must have a C form and no sampler (a plant).
    dest_dir : Path
        The folder the FMU is written to.
    resources : dict of str to bytes, optional
        Extra files for ``resources/``.
    cc : str, optional
        C compiler of the linux64 binary. Default ``"gcc"``.
    win64_cc : str, optional
        C cross compiler of the win64 binary (MinGW-w64). Default :data:`WIN64_CC`.

    Returns
    -------
    Path
        The FMU. Nothing is built when it already records this build's digest.

    Raises
    ------
    FmuBuildError
        As :func:`build_native`, and for a model with a sampler (sampled laws are co-simulation's).
    """
    return _build_c(model, dest_dir, resources, cc, win64_cc, ME)


def build_me3(model: Model, dest_dir: Path, resources: dict[str, bytes] | None = None,
              cc: str = "gcc", win64_cc: str = WIN64_CC) -> Path:
    """Generate, compile and package the FMI 3.0 model-exchange FMU ``<dest_dir>/<model.name>_me_fmi3.fmu``.

    :func:`build_me`'s states, derivatives and event indicators through the FMI 3.0 wrapper
    ``fmus/c/fmi3_me.c``: the variables as arrays, each state vector's derivative an array
    (:func:`satfmu.fmus.description_me.model_description3_me`).

    Parameters
    ----------
    model : Model
        The model; it must have a C form, no sampler, and states that form FMI 3.0 variables
        (:func:`satfmu.fmus.arrays.state_arrays`).
    dest_dir : Path
        The folder the FMU is written to.
    resources : dict of str to bytes, optional
        Extra files for ``resources/``.
    cc : str, optional
        C compiler of the x86_64-linux binary. Default ``"gcc"``.
    win64_cc : str, optional
        C cross compiler of the x86_64-windows binary (MinGW-w64). Default :data:`WIN64_CC`.

    Returns
    -------
    Path
        The FMU. Nothing is built when it already records this build's digest.

    Raises
    ------
    FmuBuildError
        As :func:`build_me`, and for states that do not form FMI 3.0 variables or a variable
        named as one of the description's own.
    """
    return _build_c(model, dest_dir, resources, cc, win64_cc, ME3)


def _build_c(model: Model, dest_dir: Path, resources: dict[str, bytes] | None, cc: str, win64_cc: str,
             backend: str) -> Path:
    """The native FMU of ``model`` on ``backend`` (:data:`NATIVE`, FMI 2.0, :data:`FMI3`, :data:`ME` or
    :data:`ME3`)."""
    try:
        codegen.require_c_form(model)
    except ValueError as exc:  # a model the C code cannot express (a Python sampler)
        raise FmuBuildError(str(exc)) from None
    if backend in (ME, ME3) and model.sampler is not None:
        raise FmuBuildError(f"{model.name}: a model with a sampler has no model-exchange FMU (its samples are "
                            "taken at instants a co-simulation step or an FMI 3.0 clock gives)")
    dest = fmu_path(model, dest_dir, backend)
    digest = digest_of(model, backend, resources, cc, win64_cc)
    if built_digest(dest) == digest:
        return dest
    identifier = dest.stem
    if backend == FMI3:
        try:
            desc = model_description3(model, identifier)
        except ValueError as exc:
            raise FmuBuildError(str(exc)) from None
        token, wrapper, folders = desc.attrib["instantiationToken"], WRAPPER3, FMI3_PLATFORMS
    elif backend == ME3:
        try:
            desc = model_description3_me(model, identifier)
        except ValueError as exc:
            raise FmuBuildError(str(exc)) from None
        token, wrapper, folders = desc.attrib["instantiationToken"], WRAPPER3_ME, FMI3_PLATFORMS
    elif backend == ME:
        desc = model_description_me(model)
        token, wrapper, folders = desc.attrib["guid"], WRAPPER_ME, None
    else:
        desc = model_description(model, capabilities(model, NATIVE))
        token, wrapper, folders = desc.attrib["guid"], WRAPPER, None  # FMI 2.0: the platforms' own names
    # the binary requires this description's GUID (token)
    model_h = codegen.c_source(model, token, events=backend in (ME, ME3))
    with tempfile.TemporaryDirectory(prefix="satfmu_") as tmp:
        root = Path(tmp)
        src = root / "sources"
        src.mkdir()
        (src / codegen.C_HEADER).write_text(model_h)
        headers = [HERE / "c" / name for name in HEADERS[backend]]
        for file in (wrapper, CORE, *headers, *codegen.c_headers(model)):  # a sampler's routine: model.h's
            shutil.copy(file, src / file.name)
        if backend in (FMI3, ME3):
            (src / "buildDescription.xml").write_bytes(to_xml_bytes(build_description(identifier, wrapper.name)))
        (root / "modelDescription.xml").write_bytes(to_xml_bytes(desc))
        _compile(identifier, root, {"linux64": cc, "win64": win64_cc}, src / wrapper.name, folders=folders)
        _write_resources(root / "resources", resources)
        _zip_dir(root, dest, comment(digest, resources))
    return dest


def _compile(name: str, root: Path, compilers: dict[str, str], source: Path, include: Path | None = None,
             folders: dict[str, str] | None = None) -> None:
    """Compile ``source`` into ``root/binaries/<folder>/<name><suffix>`` for each platform
    (``compilers``: platform -> C compiler; ``folders``: platform -> its folder, the platform's
    name by default), the compilers running concurrently; ``include`` holds its generated header
    (``root/sources`` by default).

    Raises
    ------
    FmuBuildError
        If a compiler reports an error or a warning; every compiler's messages are given.
    """
    src = root / "sources"
    include = include or src
    running = {}
    for platform, cc in compilers.items():
        binary = root / "binaries" / (folders or {}).get(platform, platform) / f"{name}{SUFFIX[platform]}"
        binary.parent.mkdir(parents=True, exist_ok=True)
        cmd = [cc, *C_FLAGS, *DEFINES[platform], *LINK_FLAGS[platform], f"-I{fmi_headers()}", f"-I{include}",
               "-o", str(binary), str(source), "-lm"]
        running[platform] = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    messages = {platform: proc.communicate()[1] for platform, proc in running.items()}
    failed = [f"{platform} ({compilers[platform]}):\n{messages[platform]}" for platform, proc in running.items()
              if proc.returncode != 0]
    if failed:
        raise FmuBuildError(f"compiling {name} failed for " + "\n".join(failed))


def _write_resources(folder: Path, resources: dict[str, bytes] | None) -> None:
    """Write ``resources`` (file name -> bytes) into ``folder`` (created)."""
    if resources:
        folder.mkdir(exist_ok=True)
        for name, data in resources.items():
            (folder / name).write_bytes(data)


SLAVE_SCRIPT = '''{docstring}
import {generated} as _generated
from satfmu_pyslave import SatfmuSlave

# A reference of this module's namespace to itself: pythonfmu 0.7.0 releases one reference
# to it per fmi2Instantiate before SatfmuSlave.__init__ gives it back (see satfmu_pyslave).
_NAMESPACE = globals()


class {cls}(SatfmuSlave):
    {description}

    generated = _generated
'''


def build_python(model: Model, dest_dir: Path, resources: dict[str, bytes] | None = None,
                 cc: str = "gcc", win64_cc: str = WIN64_CC) -> Path:
    """Generate and package the pythonfmu FMU ``<dest_dir>/<model.name>_py.fmu``.

    The FMU needs, in the importing tool's Python, only pythonfmu's runtime (which
    it embeds) and the standard library; a model with a Python sampler also needs what its
    module imports (numpy and scipy for the online SDRE). Its binaries are satfmu's C layer
    (:data:`SHIM`, compiled with ``cc`` and ``win64_cc``) in front of pythonfmu's library.
    Nothing is built when the FMU already records this build's digest.

    Parameters
    ----------
    model : Model
        The model; a Python sampler's module file is embedded too.
    dest_dir : Path
        The folder the FMU is written to.
    resources : dict of str to bytes, optional
        Extra files for ``resources/`` (e.g. the controller artifact JSON), by name.
    cc : str, optional
        C compiler of the linux64 binary (the C layer). Default ``"gcc"``.
    win64_cc : str, optional
        C cross compiler of the win64 binary (MinGW-w64). Default :data:`WIN64_CC`.

    Returns
    -------
    Path
        The FMU.
    """
    from pythonfmu.builder import FmuBuilder

    cls = model.name + PYTHON_SUFFIX
    dest = fmu_path(model, dest_dir, "python")
    digest = digest_of(model, "python", resources, cc, win64_cc)
    if built_digest(dest) == digest:
        return dest
    generated = f"satfmu_gen_{model.name}"
    with tempfile.TemporaryDirectory(prefix="satfmu_py_") as tmp:
        root = Path(tmp)
        proj = root / "project"
        proj.mkdir()
        desc = model_description(model, capabilities(model, PYTHON))
        (proj / f"{generated}.py").write_text(codegen.python_source(model, desc.attrib["guid"]))
        shutil.copy(PYSLAVE, proj / "satfmu_pyslave.py")
        sampler_file = None if model.sampler is None or model.sampler.is_expression else model.sampler.module
        python_sampler = sampler_file is not None
        if sampler_file is not None:
            shutil.copy(sampler_file, proj / f"{codegen.sampler_module_name(model)}.py")
        description = to_xml_bytes(desc)
        (proj / "satfmu_description.xml").write_bytes(description)
        _write_resources(proj, resources)  # pythonfmu puts the project files in resources/
        script = root / f"{cls}.py"
        # the texts as Python literals (repr): a description holding quotes, backslashes or
        # newlines stays a string, never code
        script.write_text(SLAVE_SCRIPT.format(
            docstring=repr(f"pythonfmu slave of the satfmu model {model.name!r} (generated; do not edit)."),
            generated=generated, cls=cls, description=repr(model.description)))
        out = root / "out"
        files = [p for p in proj.iterdir()]
        sys.path.insert(0, str(proj))
        try:
            fmu = FmuBuilder.build_FMU(script, dest=out, project_files=files)
        finally:
            sys.path.remove(str(proj))
            sampler = [codegen.sampler_module_name(model)] if python_sampler else []
            for mod in [cls, generated, "satfmu_pyslave"] + sampler:
                sys.modules.pop(mod, None)
        _repack(Path(fmu), dest, comment(digest, resources), description,
                {"linux64": cc, "win64": win64_cc}, desc.attrib["guid"])
    return dest


def _repack(src: Path, dest: Path, comment: bytes, description: bytes, compilers: dict[str, str],
            guid: str) -> None:
    """Rewrite pythonfmu's zip deterministically (stable timestamps and order), with satfmu's
    own ``modelDescription.xml`` bytes (pythonfmu writes the same description through minidom,
    which leaves a line break in an attribute unescaped: it would read back as a space), and with
    satfmu's C layer (:data:`SHIM`, for the FMU's ``guid``) as the binaries in front of
    pythonfmu's, which are renamed ``<model>_py_pythonfmu.so`` (``.dll``)."""
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp) / "fmu"
        with zipfile.ZipFile(src) as z:
            z.extractall(root)
        (root / "modelDescription.xml").write_bytes(description)
        name = src.stem
        for platform in compilers:
            binary = root / "binaries" / platform / f"{name}{SUFFIX[platform]}"
            binary.rename(binary.with_name(f"{name}{PYTHONFMU_LIBRARY_SUFFIX}{SUFFIX[platform]}"))
        library = f"{name}{PYTHONFMU_LIBRARY_SUFFIX}"
        (Path(tmp) / SHIM_HEADER).write_text(
            f'#define SHIM_GUID "{guid}"\n#ifdef _WIN32\n#define SHIM_LIBRARY "{library}{SUFFIX["win64"]}"\n'
            f'#else\n#define SHIM_LIBRARY "{library}{SUFFIX["linux64"]}"\n#endif\n')
        _compile(name, root, compilers, SHIM, Path(tmp))
        _zip_dir(root, dest, comment)
