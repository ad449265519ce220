"""The one safe way to open an FMU file: its zip archive is untrusted data.

Every path of satfmu that reads or unpacks an FMU a user hands it (the co-simulation master,
the preflight checks, ``validate``, ``export-ssp``, ``verify`` before libcosim or ecos see the
file, the robustness suite, the report) goes through :func:`check` (the archive's directory
and model description, nothing extracted) or :func:`extract` (the same checks, then the files
into a private temporary folder that :meth:`Extracted.close` removes).

What is refused, with the entry named:

- an entry whose name is absolute (``/x``, ``C:x``, ``\\\\host\\x``), holds a ``..`` component,
  a backslash, a NUL or another control character, or repeats an earlier entry's name;
- an entry that is a symbolic link, a device, a FIFO or a socket (Unix mode bits of the entry);
- encrypted entries and compression methods Python's ``zipfile`` cannot read;
- more entries, more uncompressed bytes in all, a larger ``modelDescription.xml``, a higher
  compression ratio of a large entry or more model variables than :class:`FmuLimits` allows;
- a model description that is not UTF-8 or declares a document type or entities (an FMI 2.0
  model description needs neither; this rules out entity expansion before any XML parser
  sees the text).

The number of entries is read from the archive's end record before Python builds its
directory (a million entries would otherwise cost seconds and hundreds of megabytes), and
extraction streams each entry in 1 MiB pieces, never beyond its declared size, so memory stays
bounded whatever the file holds. The limits (:class:`FmuLimits`) have defaults far above any
FMU satfmu builds and above the large FMUs that Modelica tools export; each can be raised with
an environment variable (``SATFMU_FMU_MAX_ENTRIES`` ...) or by passing ``limits=``.

Folders are named ``satfmu-fmu-<pid>-<random>`` in the system's temporary folder; one left by
a process that was killed (SIGKILL leaves no chance to clean up) is removed by the next
process that extracts an FMU, once its process id no longer runs.
"""
from __future__ import annotations

import contextlib
import dataclasses
import io
import os
import re
import shutil
import stat
import struct
import tempfile
import zipfile
import zlib
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any, Iterator
from satfmu.fmus.errors import UnsafeFmuError

DESCRIPTION = "modelDescription.xml"
FOLDER_PREFIX = "satfmu-fmu-"
_CHUNK = 1 << 20
_EOCD = b"PK\x05\x06"
_EOCD64_LOCATOR = b"PK\x06\x07"
_EOCD64 = b"PK\x06\x06"
_CONTROL = re.compile(r"[\x00-\x1f\x7f]")
_DRIVE = re.compile(r"^[A-Za-z]:")
_UNIX = 3  # ZipInfo.create_system of an archive made on Unix: external_attr >> 16 holds st_mode


@dataclass(frozen=True)
class FmuLimits:
    """Bounds on what an FMU archive may hold.

    Attributes
    ----------
    max_entries : int
        Entries (files and folders) in the archive.
    max_bytes : int
        Uncompressed bytes of all entries together (B).
    max_description_bytes : int
        Uncompressed size of ``modelDescription.xml`` (B).
    max_ratio : float
        Uncompressed over compressed size of any entry larger than ``ratio_floor_bytes``.
    ratio_floor_bytes : int
        Entries up to this size (B) are not held to ``max_ratio`` (a small file of zeros or
        spaces compresses a thousandfold and harms nothing).
    max_variables : int
        ``ScalarVariable`` elements in the model description.

    Each field can be set from the environment by :meth:`from_environment`: the variable is
    ``SATFMU_FMU_`` followed by the field's name in capitals (``SATFMU_FMU_MAX_BYTES``).
    """

    max_entries: int = 10_000
    max_bytes: int = 1 << 30
    max_description_bytes: int = 32 << 20
    max_ratio: float = 200.0
    ratio_floor_bytes: int = 1 << 20
    max_variables: int = 100_000

    @classmethod
    def from_environment(cls) -> FmuLimits:
        """The defaults, with each field overridden by ``SATFMU_FMU_<FIELD>`` where it is set.

        Raises
        ------
        ValueError
            A variable that is not a positive number (named in the message).
        """
        values: dict[str, Any] = {}
        for field in dataclasses.fields(cls):
            env = "SATFMU_FMU_" + field.name.upper()
            text = os.environ.get(env)
            if text is None:
                continue
            kind = float if field.type in ("float", float) else int
            try:
                value = kind(text)
            except ValueError:
                raise ValueError(f"{env}={text!r} is not a number") from None
            if not value > 0:
                raise ValueError(f"{env}={text!r} must be positive")
            values[field.name] = value
        return cls(**values)


def _refuse(path: Path, problem: str) -> UnsafeFmuError:
    return UnsafeFmuError(path, problem)


def _end_record_entries(fh: Any, size: int) -> int:
    """The number of entries an archive's end of central directory record declares (ZIP64 as
    well), read from the file's tail, before Python's :mod:`zipfile` builds its directory.

    Raises
    ------
    zipfile.BadZipFile
        No end record (not a zip archive).
    """
    tail = min(size, 22 + 0xFFFF)
    fh.seek(size - tail)
    data = fh.read(tail)
    at = data.rfind(_EOCD)
    if at < 0 or len(data) - at < 22:
        raise zipfile.BadZipFile("no end of central directory record (not a zip archive)")
    entries = struct.unpack("<H", data[at + 10:at + 12])[0]
    if entries == 0xFFFF and at >= 20 and data[at - 20:at - 16] == _EOCD64_LOCATOR:
        offset = struct.unpack("<Q", data[at - 12:at - 4])[0]
        if offset + 56 <= size:
            fh.seek(offset)
            record = fh.read(56)
            if record[:4] == _EOCD64:
                entries = struct.unpack("<Q", record[32:40])[0]
    return entries


def _entry_problem(info: zipfile.ZipInfo) -> str | None:
    """What makes one entry unsafe to extract anywhere, or None."""
    name = info.filename
    if not name:
        return "has an entry with an empty name"
    if _CONTROL.search(name):
        return f"has an entry {name!r} with a control character in its name"
    if "\\" in name:
        return f"has an entry {name!r} with a backslash in its name (zip names use '/')"
    if name.startswith("/") or _DRIVE.match(name):
        return f"has an entry {name!r} with an absolute path"
    if ".." in name.split("/"):
        return f"has an entry {name!r} that climbs out of the archive ('..')"
    if info.create_system == _UNIX:
        mode = info.external_attr >> 16
        kind = stat.S_IFMT(mode)
        if kind == stat.S_IFLNK:
            return f"has an entry {name!r} that is a symbolic link"
        if kind not in (0, stat.S_IFREG, stat.S_IFDIR):
            return f"has an entry {name!r} that is a device, FIFO or socket (mode {oct(mode)})"
    if info.flag_bits & 0x1:
        return f"has an entry {name!r} that is encrypted"
    if info.compress_type not in (zipfile.ZIP_STORED, zipfile.ZIP_DEFLATED, zipfile.ZIP_BZIP2,
                                  zipfile.ZIP_LZMA):
        return f"has an entry {name!r} compressed by method {info.compress_type}, which satfmu cannot read"
    return None


def _description_problem(text: bytes, limits: FmuLimits) -> str | None:
    """What makes a model description's bytes unsafe to hand to an XML parser, or None."""
    if text.startswith(b"\xef\xbb\xbf"):
        text = text[3:]
    try:
        decoded = text.decode("utf-8")
    except UnicodeDecodeError as exc:
        return f"has a {DESCRIPTION} that is not UTF-8 (byte {exc.start}), as FMI 2.0 requires"
    if "<!DOCTYPE" in decoded or "<!ENTITY" in decoded:
        return (f"has a {DESCRIPTION} that declares a document type or entities, "
                "which an FMI model description never needs")
    n = decoded.count("<ScalarVariable")
    if n > limits.max_variables:
        return (f"has a {DESCRIPTION} of {n} variables, more than {limits.max_variables} "
                "(raise SATFMU_FMU_MAX_VARIABLES to accept it)")
    return None


@dataclass(frozen=True)
class Listing:
    """An FMU archive that passed :func:`check`.

    Attributes
    ----------
    path : Path
        The file.
    names : tuple of str
        Its entries, in archive order.
    description : bytes
        Its ``modelDescription.xml``.
    total_bytes : int
        Uncompressed bytes of all entries (B).
    """

    path: Path
    names: tuple[str, ...]
    description: bytes
    total_bytes: int


def _checked(path: Path, z: zipfile.ZipFile, limits: FmuLimits) -> Listing:
    """The checks of :func:`check` on an open archive."""
    infos = z.infolist()
    if len(infos) > limits.max_entries:  # an end record that understated its count
        raise _refuse(path, f"holds {len(infos)} entries, more than {limits.max_entries}")
    seen: set[str] = set()
    total = 0
    for info in infos:
        problem = _entry_problem(info)
        if problem is None and info.filename.rstrip("/") in seen:
            problem = f"has the entry {info.filename!r} twice"
        if problem is not None:
            raise _refuse(path, problem)
        seen.add(info.filename.rstrip("/"))
        if info.filename == DESCRIPTION and info.file_size > limits.max_description_bytes:
            raise _refuse(path, f"has a {DESCRIPTION} of {info.file_size} bytes, more than "
                                f"{limits.max_description_bytes} (raise SATFMU_FMU_MAX_DESCRIPTION_BYTES to accept it)")
        if (info.file_size > limits.ratio_floor_bytes
                and info.file_size > limits.max_ratio * max(info.compress_size, 1)):
            raise _refuse(path, f"has an entry {info.filename!r} that expands {info.compress_size} bytes to "
                                f"{info.file_size} (more than {limits.max_ratio:g} times: a zip bomb? raise "
                                "SATFMU_FMU_MAX_RATIO to accept it)")
        total += info.file_size
        if total > limits.max_bytes:
            raise _refuse(path, f"expands to more than {limits.max_bytes} bytes (entries up to {info.filename!r}; "
                                "raise SATFMU_FMU_MAX_BYTES to accept it)")
    if DESCRIPTION not in seen:
        raise _refuse(path, f"has no {DESCRIPTION}")
    description = z.read(DESCRIPTION)
    problem = _description_problem(description, limits)
    if problem is not None:
        raise _refuse(path, problem)
    return Listing(path, tuple(i.filename for i in infos), description, total)


@contextlib.contextmanager
def _open_zip(path: Path, limits: FmuLimits) -> Iterator[zipfile.ZipFile]:
    """``path`` as a zip archive whose end record declares no more entries than allowed."""
    if not path.is_file():
        if not path.exists():
            raise FileNotFoundError(f"no such FMU: {path}")
        raise _refuse(path, "is not a regular file")
    size = path.stat().st_size
    if size == 0:
        raise _refuse(path, "is empty (0 bytes)")
    with open(path, "rb") as fh:
        entries = _end_record_entries(fh, size)
        if entries > limits.max_entries:
            raise _refuse(path, f"holds {entries} entries, more than {limits.max_entries} "
                                "(raise SATFMU_FMU_MAX_ENTRIES to accept it)")
        fh.seek(0)
        with zipfile.ZipFile(fh) as z:
            yield z


def _unreadable(path: Path, exc: BaseException) -> UnsafeFmuError:
    return _refuse(path, f"is not a zip archive (truncated, or another kind of file: {exc})")


_READ_ERRORS = (zipfile.BadZipFile, zlib.error, EOFError, NotImplementedError, RuntimeError, struct.error,
                OverflowError)


def check(path: str | Path, limits: FmuLimits | None = None, crc: bool = False) -> Listing:
    """Check an FMU archive's entries and model description without extracting anything.

    Parameters
    ----------
    path : path
        The FMU file.
    limits : FmuLimits, optional
        Default: :meth:`FmuLimits.from_environment`.
    crc : bool
        Also read every entry (in pieces, up to its declared size) and check its CRC-32: a
        damaged or forged entry is refused, at the cost of reading the whole archive.

    Returns
    -------
    Listing

    Raises
    ------
    FileNotFoundError
        No such file.
    UnsafeFmuError
        Not a zip archive, or what the module's docstring lists.
    """
    with _opened(Path(path), limits) as (z, listing):
        for info in z.infolist() if crc else ():
            _read_whole(listing.path, z, info)
        return listing


@contextlib.contextmanager
def _opened(path: Path, limits: FmuLimits | None) -> Iterator[tuple[zipfile.ZipFile, Listing]]:
    """The open archive and what :func:`_checked` found in it; a read error (in the block too)
    becomes :class:`UnsafeFmuError`."""
    limits = limits or FmuLimits.from_environment()
    try:
        with _open_zip(path, limits) as z:
            yield z, _checked(path, z, limits)
    except _READ_ERRORS as exc:
        raise _unreadable(path, exc) from None


def _read_whole(path: Path, z: zipfile.ZipFile, info: zipfile.ZipInfo) -> None:
    """Read one entry to its end, which makes :mod:`zipfile` compare its CRC-32."""
    try:
        with z.open(info) as src:
            while src.read(_CHUNK):
                pass
    except _READ_ERRORS as exc:
        raise _refuse(path, f"is damaged: its entry {info.filename!r} fails its check ({exc})") from None


class Extracted:
    """An FMU extracted by :func:`extract` into a private temporary folder.

    Use it as a context manager, or call :meth:`close`, which removes the folder.

    Attributes
    ----------
    listing : Listing
        What :func:`check` found.
    folder : Path
        The extracted files (``folder / "modelDescription.xml"``, ``folder / "binaries"``, ...).
    """

    def __init__(self, listing: Listing, folder: Path) -> None:
        self.listing = listing
        self.folder = folder

    def close(self) -> None:
        """Remove the extracted folder (again: nothing)."""
        shutil.rmtree(self.folder, ignore_errors=True)

    def __enter__(self) -> Extracted:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's live process
        return True
    return True


_swept = False


def sweep_abandoned(base: str | Path | None = None) -> list[Path]:
    """Remove the extraction folders of processes that no longer run (killed before they could
    clean up) from ``base`` (default: the system's temporary folder); returns what it removed.

    Parameters
    ----------
    base : str or Path, optional
        The folder to sweep, where the ``satfmu-fmu-<pid>-<random>`` folders are; default: the
        system's temporary folder (``tempfile.gettempdir()``).

    Returns
    -------
    list of Path
        The folders removed.
    """
    base = Path(base or tempfile.gettempdir())
    removed: list[Path] = []
    try:
        candidates = [p for p in base.iterdir() if p.name.startswith(FOLDER_PREFIX)]
    except OSError:
        return removed
    for p in candidates:
        pid = p.name[len(FOLDER_PREFIX):].split("-", 1)[0]
        if pid.isdigit() and int(pid) != os.getpid() and not _pid_alive(int(pid)):
            shutil.rmtree(p, ignore_errors=True)
            removed.append(p)
    return removed


def private_folder() -> Path:
    """A new folder only this user can enter, in the system's temporary folder, named with this
    process id so that :func:`sweep_abandoned` can remove it after a kill."""
    global _swept
    if not _swept:
        _swept = True
        sweep_abandoned()
    return Path(tempfile.mkdtemp(prefix=f"{FOLDER_PREFIX}{os.getpid()}-"))


def _write_entry(z: zipfile.ZipFile, info: zipfile.ZipInfo, folder: Path) -> None:
    """Stream one checked entry under ``folder``."""
    target = folder.joinpath(*[p for p in info.filename.split("/") if p])
    if info.is_dir():
        target.mkdir(parents=True, exist_ok=True)
        return
    target.parent.mkdir(parents=True, exist_ok=True)
    written = 0
    fd = os.open(target, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0), 0o600)
    with os.fdopen(fd, "wb") as out, z.open(info) as src:
        while chunk := src.read(_CHUNK):
            written += len(chunk)
            if written > info.file_size:  # zipfile stops at the declared size; never trust that alone
                raise zipfile.BadZipFile(f"entry {info.filename!r} holds more than its declared {info.file_size} bytes")
            out.write(chunk)


def extract(path: str | Path, limits: FmuLimits | None = None) -> Extracted:
    """Check an FMU archive (:func:`check`) and extract it into a private temporary folder.

    Parameters
    ----------
    path : path
        The FMU file.
    limits : FmuLimits, optional
        Default: :meth:`FmuLimits.from_environment`.

    Returns
    -------
    Extracted
        Close it (or use it as a context manager) to remove the folder.

    Raises
    ------
    FileNotFoundError
        No such file.
    UnsafeFmuError
        What :func:`check` refuses, a damaged entry (its CRC, its size), or a file that cannot
        be written (the disk full: the message names the entry); nothing is left behind.
    """
    path = Path(path)
    folder = private_folder()
    try:
        with _opened(path, limits) as (z, listing):
            for info in z.infolist():
                try:
                    _write_entry(z, info, folder)
                except _READ_ERRORS as exc:
                    raise _refuse(path, f"is damaged: its entry {info.filename!r} fails its check ({exc})") from None
                except OSError as exc:
                    raise _refuse(path, f"has an entry {info.filename!r} that cannot be extracted to {folder} "
                                        f"({exc.strerror or exc})") from None
        return Extracted(listing, folder)
    except BaseException:
        shutil.rmtree(folder, ignore_errors=True)
        raise


def read_description(path: str | Path, limits: FmuLimits | None = None) -> Any:
    """fmpy's model description of an FMU, parsed from the bytes :func:`check` accepted.

    Parameters
    ----------
    path : path
        The FMU file.
    limits : FmuLimits, optional
        Default: :meth:`FmuLimits.from_environment`.

    Returns
    -------
    fmpy.model_description.ModelDescription

    Raises
    ------
    FileNotFoundError
        No such file.
    UnsafeFmuError
        What :func:`check` refuses, or a model description fmpy cannot read (its message).
    """
    listing = check(path, limits)
    return parse_description(listing.path, listing.description)


def parse_description(path: Path, text: bytes) -> Any:
    """fmpy's model description of the checked ``modelDescription.xml`` bytes ``text`` of the FMU
    ``path`` (named in errors).

    Parameters
    ----------
    path : Path
        The FMU file the description comes from; only named in the error message.
    text : bytes
        The ``modelDescription.xml`` of that FMU, already checked (:func:`check`).

    Returns
    -------
    fmpy.model_description.ModelDescription
        What fmpy's ``read_model_description`` reads from it: one object per distinct text in a
        process (the run's preflight check and its instance read the same description, a
        campaign's samples too), shared, so not to be changed (:mod:`satfmu.sims.cosim.instances`
        works on copies).

    Raises
    ------
    UnsafeFmuError
        If fmpy refuses the description (schema, attribute or XML error).
    """
    try:
        return _parsed(text)
    except Exception as exc:  # fmpy raises schema, attribute and XML errors of its own
        raise _refuse(Path(path), f"has an invalid {DESCRIPTION} ({type(exc).__name__}: {exc})") from None


@lru_cache(maxsize=64)
def _parsed(text: bytes) -> Any:
    """fmpy's reading of a ``modelDescription.xml`` (6-12 ms for one of ours), once per text."""
    from fmpy import read_model_description

    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as z:
        z.writestr(DESCRIPTION, text)
    buffer.seek(0)
    return read_model_description(buffer)


def read_entry(path: str | Path, name: str, max_bytes: int, limits: FmuLimits | None = None) -> bytes | None:
    """One entry of a checked FMU archive (:func:`check`), or None if it has none of that name.

    Parameters
    ----------
    path : path
        The FMU file.
    name : str
        The entry (``"resources/artifact.json"``).
    max_bytes : int
        Refuse an entry larger than this (B): what the caller can hold in memory.
    limits : FmuLimits, optional
        Default: :meth:`FmuLimits.from_environment`.

    Raises
    ------
    FileNotFoundError
        No such file.
    UnsafeFmuError
        What :func:`check` refuses, an entry larger than ``max_bytes`` or damaged.
    """
    with _opened(Path(path), limits) as (z, listing):
        if name not in listing.names:
            return None
        info = z.getinfo(name)
        if info.file_size > max_bytes:
            raise _refuse(listing.path, f"has an entry {name!r} of {info.file_size} bytes, more than the "
                                        f"{max_bytes} such a file may hold")
        return z.read(info)
