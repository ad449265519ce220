"""The FMI host harness over fmpy: status names, log capture, calls that return a status.

One harness for every host in the project (the co-simulation master :mod:`satfmu.sims.cosim.master`, the
robustness suite :mod:`satfmu.sims.robustness` and the FMU tests): the logger callback records each
message an FMU passes with the instance name, status and category (:class:`Callbacks`);
:func:`attempt` calls one of fmpy's ``FMU2Slave`` methods and returns the FMI status instead of
raising; :func:`call` makes a raw ``fmi2*`` call with the instance's component; :func:`abandon`
keeps an instance that returned fmi2Fatal alive, since FMI 2.0 allows no further call to it (not
even ``fmi2FreeInstance``); :func:`open_fmu` reads and extracts an FMU file or says which file is
not one.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from fmpy import calloc, free
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import (FMU2Slave, fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                       fmi2CallbackFunctions, fmi2CallbackLoggerTYPE)

from satfmu.fmus import archive
from satfmu.fmus.errors import UnreadableFmuError

OK, WARNING, DISCARD, ERROR, FATAL, PENDING = 0, 1, 2, 3, 4, 5
STATUS_NAMES = {OK: "OK", WARNING: "Warning", DISCARD: "Discard", ERROR: "Error", FATAL: "Fatal",
                PENDING: "Pending"}


def status_name(status: int) -> str:
    """``"OK"``, ``"Warning"``, ... for an fmi2Status (the number itself if it is none of them).

    Parameters
    ----------
    status : int
        The fmi2Status, 0 (OK) to 5 (Pending).
    """
    return STATUS_NAMES.get(status, str(status))


@dataclass(frozen=True)
class Message:
    """One message an FMU passed to the logger callback.

    Attributes
    ----------
    instance : str
        The instance name the FMU gave.
    status : int
        The fmi2Status of the message.
    category : str
        The message category the FMU gave (e.g. ``"logStatusError"``).
    text : str
        The message.
    """

    instance: str
    status: int
    category: str
    text: str

    def line(self) -> str:
        """``[Status] text``."""
        return f"[{status_name(self.status)}] {self.text}"


def _decode(raw: bytes | None) -> str:
    return (raw or b"").decode(errors="replace")


class Callbacks:
    """``fmi2CallbackFunctions`` whose logger records every message; holds the ctypes callbacks
    alive as long as it lives (an FMU may log until it is freed).

    Parameters
    ----------
    sink : callable, optional
        Receives each :class:`Message`; by default it is appended to ``log``.

    Attributes
    ----------
    functions : fmi2CallbackFunctions
        What ``FMU2Slave.instantiate(callbacks=...)`` takes.
    log : list of Message
        The messages, in order (when no ``sink`` is given).
    """

    def __init__(self, sink: Callable[[Message], None] | None = None) -> None:
        self.log: list[Message] = []
        receive = sink or self.log.append

        def logger(env: Any, instance: bytes, status: int, category: bytes, message: bytes) -> None:
            receive(Message(_decode(instance), int(status), _decode(category), _decode(message)))

        self._logger = logger
        self._receive = receive
        self.functions = fmi2CallbackFunctions()
        self.functions.logger = fmi2CallbackLoggerTYPE(logger)
        self.functions.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        self.functions.freeMemory = fmi2CallbackFreeMemoryTYPE(free)

    def fmi3_logger(self, instance: str) -> Callable[[Any, int, bytes, bytes], None]:
        """An FMI 3.0 ``logMessage`` callback (a Python function for fmpy's ``FMU3Slave.instantiate``)
        that records each message as this object's FMI 2.0 logger does, under ``instance``: FMI 3.0
        passes no instance name, only the instance environment.

        Parameters
        ----------
        instance : str
            The instance name the messages are recorded under.
        """
        def log_message(env: Any, status: int, category: bytes, message: bytes) -> None:
            self._receive(Message(instance, int(status), _decode(category), _decode(message)))

        return log_message

    def text(self, since: int = 0) -> str:
        """The texts of the messages from index ``since`` on, one per line.

        Parameters
        ----------
        since : int, optional
            Index in ``log`` of the first message (default 0: all of them).
        """
        return "\n".join(m.text for m in self.log[since:])


def attempt(slave: FMU2Slave, method: str, *args: Any) -> tuple[int, Any]:
    """Call fmpy's ``slave.<method>(*args)`` (e.g. ``"doStep"``); returns (status, result).

    fmpy raises ``FMICallException`` for fmi2Error and fmi2Fatal; its status is returned instead
    (the result is then None).

    Parameters
    ----------
    slave : fmpy.fmi2.FMU2Slave
        The FMU.
    method : str
        Name of the ``FMU2Slave`` method (``"doStep"``, ``"setReal"``, ...).
    *args
        Its arguments.

    Returns
    -------
    status : int
        ``OK``, or the fmi2Status of the exception.
    result : object
        What the method returned, None if it raised.
    """
    try:
        return OK, getattr(slave, method)(*args)
    except FMICallException as exc:
        return exc.status, None


def call(slave: FMU2Slave, fn: str, *args: Any) -> int:
    """The raw ``fmi2<fn>(component, *args)`` (e.g. ``"DoStep"``); returns its fmi2Status.

    Parameters
    ----------
    slave : fmpy.fmi2.FMU2Slave
        The FMU, instantiated (its ``component`` is the first argument).
    fn : str
        The FMI function without its ``fmi2`` prefix (``"DoStep"``, ``"SetReal"``, ...).
    *args
        The arguments after the component, as the C function takes them (ctypes values).
    """
    try:
        return getattr(slave, "fmi2" + fn)(slave.component, *args)
    except FMICallException as exc:
        return exc.status


_ABANDONED: list[Any] = []


def abandon(owner: Any) -> None:
    """Keep ``owner`` (an instance that returned fmi2Fatal, with its callbacks) alive for the
    life of the process and never call it again, as FMI 2.0 requires.

    Parameters
    ----------
    owner : object
        What holds the instance and its callbacks: a tuple ``(slave, callbacks)`` of an
        ``FMU2Slave`` and its :class:`Callbacks`, or an object owning both.
    """
    _ABANDONED.append(owner)


def open_fmu(path: str | Path) -> tuple[Any, str]:
    """Check ``path``'s archive (:func:`satfmu.fmus.archive.extract`), extract it into a private
    temporary folder and read its model description from there.

    Parameters
    ----------
    path : str or Path
        The FMU file.

    Returns
    -------
    model_description : fmpy.model_description.ModelDescription
    unzip_dir : str
        The extracted folder (the caller removes it).

    Raises
    ------
    FileNotFoundError
        If ``path`` does not exist.
    UnreadableFmuError
        If it is not a readable FMU; the message names the file and what was found.
    """
    try:
        extracted = archive.extract(path)
    except archive.UnsafeFmuError as exc:
        raise UnreadableFmuError(str(exc)) from None
    try:
        return archive.parse_description(extracted.listing.path, extracted.listing.description), str(extracted.folder)
    except archive.UnsafeFmuError as exc:
        extracted.close()
        raise UnreadableFmuError(str(exc)) from None
