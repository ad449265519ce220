"""Declarations read from TOML or plain data (spacecraft, scenarios): reading a file and
checking its keys, with the closest known name for a near miss."""
from __future__ import annotations

import difflib
import re
import tomllib
from pathlib import Path
from typing import Any, Iterable, Mapping


SAFE_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]{0,99}")
"""A name that is also a safe file or folder name: no separator, no ``..``, no leading dot."""


def check_safe_name(name: Any, where: str, error: type[Exception]) -> str:
    """``name`` if it is a safe folder name (:data:`SAFE_NAME`), else raise ``error``."""
    if not isinstance(name, str) or not SAFE_NAME.fullmatch(name) or ".." in name:
        raise error(f"{where}: {name!r} is not a safe folder name (letters, digits, '.', '_', '-'; first a "
                    f"letter or digit; no '..'; at most 100 characters)")
    return name


def did_you_mean(word: str, choices: Iterable[str]) -> str:
    """``"; did you mean 'x'?"`` for the closest of ``choices`` to ``word``, or ``""``."""
    close = difflib.get_close_matches(word, list(choices), n=1)
    return f"; did you mean {close[0]!r}?" if close else ""


def check_keys(data: Mapping[str, Any], keys: Iterable[str], where: str, error: type[Exception]) -> None:
    """Raise ``error`` naming the first key of ``data`` not in ``keys`` (with the closest one, or the list)."""
    keys = list(keys)
    for k in data:
        if k not in keys:
            raise error(f"{where}: unknown key {k!r}" + (did_you_mean(k, keys) or f" (allowed: {', '.join(keys)})"))


def read_toml(path: Path, what: str, error: type[Exception]) -> dict[str, Any]:
    """The data of a TOML file; ``error`` says why it cannot be read (``what``: "scenario", ...)."""
    try:
        return tomllib.loads(Path(path).read_text())
    except OSError as exc:
        raise error(f"{path}: cannot read {what} file ({exc.strerror})") from None
    except tomllib.TOMLDecodeError as exc:
        raise error(f"{path}: invalid TOML ({exc})") from None
