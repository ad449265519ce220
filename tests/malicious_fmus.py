"""Malicious FMU files, each a real FMU (``mrp_satellite.fmu``) with one hostile change.

The archives are written here byte by byte (local headers, central directory, ZIP64 end records
when needed) rather than with :mod:`zipfile`, which refuses to write some of them and would
take seconds to deflate a gigabyte: a zip bomb's data is one deflate block of 1 MiB of spaces
ended by a full flush, repeated (each such block decodes alone, so N copies decode to N MiB),
with the CRC-32 of the whole uncompressed text, so every archive is a valid zip file that an
extractor without limits (libzip in libcosim, fmpy, Python's ``extractall``) would expand in
full.

``CLASSES`` maps each class name to the function that writes it; :func:`escape_targets` are the
files a zip slip would create (a test checks they stay absent).
"""
from __future__ import annotations

import stat
import struct
import zipfile
import zlib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

_MIB = 1 << 20
_SPACES = b" " * _MIB


@dataclass(frozen=True)
class Raw:
    """One entry as it goes into the archive: its name, compressed bytes and header fields."""

    name: str
    method: int
    data: bytes
    size: int
    crc: int
    mode: int = stat.S_IFREG | 0o644


def stored(name: str, data: bytes, mode: int = stat.S_IFREG | 0o644) -> Raw:
    """An entry stored uncompressed."""
    return Raw(name, zipfile.ZIP_STORED, data, len(data), zlib.crc32(data), mode)


def deflated(name: str, data: bytes) -> Raw:
    """An entry compressed with raw deflate."""
    co = zlib.compressobj(6, zlib.DEFLATED, -15)
    return Raw(name, zipfile.ZIP_DEFLATED, co.compress(data) + co.flush(), len(data), zlib.crc32(data))


def spaces_after(name: str, head: bytes, mib: int) -> Raw:
    """An entry ``head`` followed by ``mib`` MiB of spaces, deflated to about a thousandth."""
    co = zlib.compressobj(9, zlib.DEFLATED, -15)
    first = co.compress(head) + co.flush(zlib.Z_FULL_FLUSH)
    block = co.compress(_SPACES) + co.flush(zlib.Z_FULL_FLUSH)
    crc = zlib.crc32(head)
    for _ in range(mib):
        crc = zlib.crc32(_SPACES, crc)
    return Raw(name, zipfile.ZIP_DEFLATED, first + block * mib + co.flush(), len(head) + mib * _MIB, crc)


def write_zip(path: Path, entries: list[Raw]) -> Path:
    """Write ``entries`` as a zip archive at ``path`` (names taken as given, made on Unix)."""
    local, central = bytearray(), bytearray()
    for e in entries:
        name = e.name.encode()
        offset = len(local)
        local += struct.pack("<IHHHHHIIIHH", 0x04034B50, 20, 0x800, e.method, 0, 0x21, e.crc,
                             len(e.data), e.size, len(name), 0) + name + e.data
        central += struct.pack("<IHHHHHHIIIHHHHHII", 0x02014B50, (3 << 8) | 20, 20, 0x800, e.method, 0, 0x21,
                               e.crc, len(e.data), e.size, len(name), 0, 0, 0, 0, e.mode << 16, offset) + name
    n, cd_offset = len(entries), len(local)
    tail = bytearray()
    if n > 0xFFFF:  # ZIP64 end record and its locator
        z64 = cd_offset + len(central)
        tail += struct.pack("<IQHHIIQQQQ", 0x06064B50, 44, 45, 45, 0, 0, n, n, len(central), cd_offset)
        tail += struct.pack("<IIQI", 0x07064B50, 0, z64, 1)
    short = min(n, 0xFFFF)
    tail += struct.pack("<IHHHHIIH", 0x06054B50, 0, 0, short, short, len(central), cd_offset, 0)
    path.write_bytes(bytes(local) + bytes(central) + bytes(tail))
    return path


def _base(fmu: Path, replace: dict[str, bytes] | None = None) -> list[Raw]:
    """The entries of a real FMU, re-deflated (``replace`` swaps some contents)."""
    with zipfile.ZipFile(fmu) as z:
        return [deflated(n, (replace or {}).get(n, z.read(n))) for n in z.namelist()]


def escape_targets(escape: Path) -> list[Path]:
    """The files that the zip slip classes would write outside any extraction folder."""
    return [escape / "via_fmu_dir.txt", escape / "absolute.txt"]


def _description(fmu: Path) -> bytes:
    with zipfile.ZipFile(fmu) as z:
        return z.read("modelDescription.xml")


def slip_relative(fmu: Path, out: Path, escape: Path) -> Path:
    """An entry that climbs far enough (``../`` x 40) to reach ``escape`` from any folder."""
    name = "../" * 40 + str(escape).lstrip("/") + "/via_fmu_dir.txt"
    return write_zip(out, _base(fmu) + [stored(name, b"written by a zip slip\n")])


def slip_absolute(fmu: Path, out: Path, escape: Path) -> Path:
    """An entry with an absolute path into ``escape``."""
    return write_zip(out, _base(fmu) + [stored(str(escape / "absolute.txt"), b"written by a zip slip\n")])


def symlink(fmu: Path, out: Path, escape: Path) -> Path:
    """A symbolic link entry ``resources/passwd -> /etc/passwd``."""
    return write_zip(out, _base(fmu) + [stored("resources/passwd", b"/etc/passwd", stat.S_IFLNK | 0o777)])


def device(fmu: Path, out: Path, escape: Path) -> Path:
    """A character device entry ``resources/null``."""
    return write_zip(out, _base(fmu) + [stored("resources/null", b"", stat.S_IFCHR | 0o666)])


def bomb_description(fmu: Path, out: Path, escape: Path) -> Path:
    """A ``modelDescription.xml`` padded with 1 GiB of spaces (about 1 MB compressed)."""
    entries = [e for e in _base(fmu) if e.name != "modelDescription.xml"]
    return write_zip(out, [spaces_after("modelDescription.xml", _description(fmu), 1024)] + entries)


def bomb_resource(fmu: Path, out: Path, escape: Path) -> Path:
    """A 2 GiB resource of spaces (about 2 MB compressed)."""
    return write_zip(out, _base(fmu) + [spaces_after("resources/table.txt", b"", 2047)])


def lying_size(fmu: Path, out: Path, escape: Path) -> Path:
    """A 64 MiB resource whose headers declare 1 kB (and the CRC of the 64 MiB)."""
    real = spaces_after("resources/small.txt", b"", 64)
    return write_zip(out, _base(fmu) + [Raw(real.name, real.method, real.data, 1000, real.crc)])


def many_entries(fmu: Path, out: Path, escape: Path) -> Path:
    """100,000 empty entries beside the FMU's own."""
    return write_zip(out, _base(fmu) + [stored(f"resources/f{i}", b"") for i in range(100_000)])


def many_variables(fmu: Path, out: Path, escape: Path) -> Path:
    """A model description with 300,000 more variables."""
    text = _description(fmu)
    extra = b"".join(b'<ScalarVariable name="x%d" valueReference="%d" causality="local"><Real/></ScalarVariable>'
                     % (i, 100_000 + i) for i in range(300_000))
    text = text.replace(b"</ModelVariables>", extra + b"</ModelVariables>", 1)
    return write_zip(out, _base(fmu, {"modelDescription.xml": text}))


def entity_expansion(fmu: Path, out: Path, escape: Path) -> Path:
    """A model description whose DTD nests entities ten deep ("billion laughs")."""
    dtd = b'<!DOCTYPE fmiModelDescription [<!ENTITY a0 "lol">' + b"".join(
        b'<!ENTITY a%d "%s">' % (i, b"&a%d;" % (i - 1) * 10) for i in range(1, 10)) + b"]>\n"
    text = _description(fmu)
    head, _, body = text.partition(b"?>")
    text = head + b"?>\n" + dtd + body.replace(b'description="', b'description="&a9;', 1)
    return write_zip(out, _base(fmu, {"modelDescription.xml": text}))


CLASSES: dict[str, Callable[[Path, Path, Path], Path]] = {
    "zip slip (relative)": slip_relative,
    "zip slip (absolute)": slip_absolute,
    "symlink": symlink,
    "device": device,
    "bomb in the description": bomb_description,
    "bomb in a resource": bomb_resource,
    "size that lies": lying_size,
    "1e5 entries": many_entries,
    "3e5 variables": many_variables,
    "entity expansion": entity_expansion,
}
"""Each class: ``make(real_fmu, out_file, escape_folder) -> out_file``."""
