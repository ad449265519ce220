"""Declarations read from TOML or plain data (spacecraft, scenarios): reading a file and
checking its keys, with the closest known name for a near miss."""
from __future__ import annotations

import difflib
import json
import math
import os
import re
import stat
import tomllib
from pathlib import Path
from typing import Any, Iterable, Mapping


SAFE_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]{0,99}")
"""A name that is also a safe file or folder name: no separator, no ``..``, no leading dot."""


def check_safe_name(name: Any, where: str, error: type[Exception]) -> str:
    """``name`` if it is a safe folder name (:data:`SAFE_NAME`), else raise ``error``.

    Parameters
    ----------
    name : object
        The declared name; anything but a ``str`` is refused.
    where : str
        Where the name comes from (``"campaign name"``, ``"<file>: name"``), the message's prefix.
    error : type of Exception
        The exception class raised with the message (``ScenarioError``, ``CampaignError``, ...).

    Returns
    -------
    str
        ``name``, unchanged.
    """
    if not isinstance(name, str) or not SAFE_NAME.fullmatch(name) or ".." in name:
        raise error(f"{where}: {name!r} is not a safe folder name (letters, digits, '.', '_', '-'; first a "
                    f"letter or digit; no '..'; at most 100 characters)")
    return name


def did_you_mean(word: str, choices: Iterable[str]) -> str:
    """``"; did you mean 'x'?"`` for the closest of ``choices`` to ``word``, or ``""``.

    Parameters
    ----------
    word : str
        The unknown word (a misspelled key or name).
    choices : iterable of str
        The known words (``difflib.get_close_matches`` picks the closest).

    Returns
    -------
    str
        The hint, to append to an error message, or ``""`` when no choice is close.
    """
    close = difflib.get_close_matches(word, list(choices), n=1)
    return f"; did you mean {close[0]!r}?" if close else ""


def check_keys(data: Mapping[str, Any], keys: Iterable[str], where: str, error: type[Exception]) -> None:
    """Raise ``error`` naming the first key of ``data`` not in ``keys`` (with the closest one, or the list).

    Parameters
    ----------
    data : mapping of str to object
        The declared table (a TOML table or its plain-data equivalent).
    keys : iterable of str
        The keys allowed in it.
    where : str
        Where the table comes from, the message's prefix.
    error : type of Exception
        The exception class raised with the message.
    """
    keys = list(keys)
    for k in data:
        if k not in keys:
            raise error(f"{where}: unknown key {k!r}" + (did_you_mean(k, keys) or f" (allowed: {', '.join(keys)})"))


def check_table(data: Any, keys: Iterable[str], required: Iterable[str], where: str,
                error: type[Exception]) -> Mapping[str, Any]:
    """``data`` as a declared table: a mapping whose keys are all known and the required ones present.

    Parameters
    ----------
    data : object
        The declared table (a TOML table or its plain-data equivalent).
    keys : iterable of str
        The keys allowed in it.
    required : iterable of str
        The keys it must have.
    where : str
        Where the table comes from, the message's prefix.
    error : type of Exception
        The exception class raised with the message.

    Returns
    -------
    mapping of str to object
        ``data``.
    """
    if not isinstance(data, Mapping):
        raise error(f"{where}: expected a table, got {type(data).__name__}")
    check_keys(data, keys, where, error)
    for key in required:
        if key not in data:
            raise error(f"{where}: missing key {key!r}")
    return data


def finite_number(raw: Any, where: str, unit: str, error: type[Exception], low: float = -math.inf,
                  high: float = math.inf, open_low: bool = False) -> float:
    """``raw`` as a float: a finite number (not a Boolean) within ``[low, high]`` (``(low, high]`` with
    ``open_low``).

    Parameters
    ----------
    raw : object
        The declared value.
    where : str
        Which value it is, the message's prefix.
    unit : str
        Its unit, in the message.
    error : type of Exception
        The exception class raised with the message.
    low, high : float, optional
        The bounds.
    open_low : bool, optional
        Exclude ``low`` itself.

    Returns
    -------
    float
        The value.
    """
    ok = not isinstance(raw, bool) and isinstance(raw, (int, float)) and math.isfinite(raw)
    if not ok or raw < low or (open_low and raw == low) or raw > high:
        bounds = ([f"> {low:g}" if open_low else f">= {low:g}"] if low > -math.inf else []) + \
            ([f"<= {high:g}"] if high < math.inf else [])
        raise error(f"{where}: must be a finite number{' ' + ' and '.join(bounds) if bounds else ''} ({unit}), "
                    f"got {raw!r}")
    return float(raw)


def vector3(raw: Any, where: str, error: type[Exception], unit_length: bool = False) -> tuple[float, float, float]:
    """``raw`` as 3 finite floats; with ``unit_length``, a direction: not zero, and normalized unless it
    is a unit vector already (then kept as given, so that a round trip is exact).

    Parameters
    ----------
    raw : object
        The declared value.
    where : str
        Which value it is, the message's prefix.
    error : type of Exception
        The exception class raised with the message.
    unit_length : bool, optional
        Read a direction.

    Returns
    -------
    tuple of 3 float
        The vector.
    """
    import numpy as np

    try:
        v = np.asarray(raw, dtype=float)
    except (TypeError, ValueError):
        raise error(f"{where}: must be 3 numbers, got {raw!r}") from None
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise error(f"{where}: must be 3 finite numbers, got {raw!r}")
    if unit_length:
        norm = float(np.linalg.norm(v))
        if norm == 0.0:
            raise error(f"{where}: must not be the zero vector")
        if abs(norm - 1.0) > 4 * np.finfo(float).eps:
            v = v / norm
    return (float(v[0]), float(v[1]), float(v[2]))


MAX_TOML_BYTES = 16 << 20
"""The largest declaration file read (B): a scenario or spacecraft file is a few kB."""


def read_toml(path: Path, what: str, error: type[Exception]) -> dict[str, Any]:
    """The data of a TOML file; ``error`` says why it cannot be read (``what``: "scenario", ...):
    not a regular file (a FIFO would block, a device never end), larger than
    :data:`MAX_TOML_BYTES`, not UTF-8, not TOML, or nested too deep for the parser.

    Parameters
    ----------
    path : Path
        The TOML file.
    what : str
        What the file declares (``"scenario"``, ``"spacecraft"``, ...), named in the message.
    error : type of Exception
        The exception class raised when the file cannot be read.

    Returns
    -------
    dict of str to object
        The parsed document (``tomllib.loads``).
    """
    try:
        info = os.stat(path)
        if not stat.S_ISREG(info.st_mode):
            raise error(f"{path}: cannot read {what} file (not a regular file: a folder, FIFO or device)")
        if info.st_size > MAX_TOML_BYTES:
            raise error(f"{path}: a {what} file of {info.st_size} bytes, more than {MAX_TOML_BYTES}")
        return tomllib.loads(Path(path).read_text(encoding="utf-8"))
    except OSError as exc:
        raise error(f"{path}: cannot read {what} file ({exc.strerror})") from None
    except UnicodeDecodeError as exc:
        raise error(f"{path}: {what} file is not UTF-8 text ({exc.reason})") from None
    except tomllib.TOMLDecodeError as exc:
        raise error(f"{path}: invalid TOML ({exc})") from None
    except RecursionError:
        raise error(f"{path}: invalid TOML (arrays or tables nested too deep to read)") from None


_BARE_KEY = re.compile(r"[A-Za-z0-9_-]+")
INLINE_WIDTH = 100
"""Longest inline table (characters) :func:`toml_text` writes; a longer one becomes a section."""


def _toml_key(key: str) -> str:
    """A TOML key: bare when it can be, else a basic string (JSON's escapes are TOML's)."""
    return key if _BARE_KEY.fullmatch(key) else json.dumps(key)


def _toml_value(value: Any, where: str) -> str:
    """A TOML value: string, boolean, integer, float, array or (one-line) inline table."""
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if not math.isfinite(value):
            raise ValueError(f"{where}: {value!r} is not finite")
        return repr(float(value))  # a numpy float's repr is np.float64(...)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml_value(v, where) for v in value) + "]"
    if isinstance(value, Mapping):
        return "{ " + ", ".join(f"{_toml_key(k)} = {_toml_value(v, f'{where}.{k}')}" for k, v in value.items()) + " }"
    raise ValueError(f"{where}: cannot write {type(value).__name__} {value!r} as TOML")


def _is_table_array(value: Any) -> bool:
    return isinstance(value, list) and bool(value) and all(isinstance(v, Mapping) for v in value)


def _toml_table(data: Mapping[str, Any], path: list[str], header: str) -> list[str]:
    """The lines of one table: ``header`` and its plain keys, then its sub-tables and arrays of
    tables. Its tables are inline when each is a short table of scalars, else all sections (in
    their order)."""
    tables = [k for k, v in data.items() if isinstance(v, Mapping)]
    inline = bool(path) and all(all(not isinstance(x, (Mapping, list)) for x in data[k].values())
                                and len(_toml_value(data[k], k)) <= INLINE_WIDTH for k in tables)
    plain: list[str] = []
    nested: list[str] = []
    for k, v in data.items():
        (nested if (isinstance(v, Mapping) and not inline) or _is_table_array(v) else plain).append(k)
    lines = ([header] if header and (plain or not nested) else []) + \
        [f"{_toml_key(k)} = {_toml_value(data[k], '.'.join(path + [k]))}" for k in plain]
    for k in nested:
        sub, name = data[k], ".".join(_toml_key(p) for p in path + [k])
        for item in sub if isinstance(sub, list) else [sub]:
            if lines:
                lines.append("")
            lines += _toml_table(item, path + [k], f"[[{name}]]" if isinstance(sub, list) else f"[{name}]")
    return lines


def toml_text(data: Mapping[str, Any], comment: str = "") -> str:
    """``data`` (plain data as :func:`read_toml` returns it) as TOML text that reads back equal.

    The top-level tables are sections; below them the tables of one table are written inline
    when each is a table of scalars of at most :data:`INLINE_WIDTH` characters, else all as
    sections; a list of tables is an array of tables.

    Parameters
    ----------
    data : mapping
        Strings, booleans, integers, finite floats, lists and mappings of those.
    comment : str, optional
        Text of a header comment (each line prefixed with ``#`` and a space); default none.

    Raises
    ------
    ValueError
        A value TOML cannot hold (None, a non-finite float), naming its key path.
    """
    head = [f"# {line}".rstrip() for line in comment.splitlines()]
    return "\n".join(head + _toml_table(data, [], "")) + "\n"
