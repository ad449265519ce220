"""Progress of a long design: its stages reported to a callback and to ``logging``, each with
the time it took.

A design function takes ``progress(done, total, message)`` (the command line draws it as a bar,
as it does a campaign's chunks) and logs each stage at INFO on its module's logger, so a script
sees the stages with ``logging.basicConfig(level=logging.INFO)``.
"""
from __future__ import annotations

import logging
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager

Progress = Callable[[int, int, str], None]
"""``progress(done, total, message)``: called after each step of a design."""


class Stages:
    """The stages of one design run, ``total`` of them, reported as each ends.

    Parameters
    ----------
    total : int
        Number of stages the run will report (>= 1).
    progress : callable, optional
        ``progress(done, total, message)`` after each stage; the message names the stage and
        its time, s.
    logger : logging.Logger, optional
        Where the stages are logged (start at DEBUG, end at INFO); default this module's.
    """

    def __init__(self, total: int, progress: Progress | None = None, logger: logging.Logger | None = None) -> None:
        if isinstance(total, bool) or not isinstance(total, int) or total < 1:
            raise ValueError(f"total must be an integer >= 1, got {total!r}")
        self.total = total
        self.done = 0
        self.progress = progress
        self.log = logger or logging.getLogger(__name__)

    @contextmanager
    def stage(self, name: str) -> Iterator[None]:
        """Run one stage: logged when it starts, reported (and logged) when it ends.

        Parameters
        ----------
        name : str
            What the stage does (``"gain fit"``).
        """
        if self.done >= self.total:
            raise RuntimeError(f"stage {name!r}: all {self.total} stages already reported")
        self.log.debug("%s ...", name)
        t0 = time.perf_counter()
        yield
        self.done += 1
        message = f"{name} ({time.perf_counter() - t0:.1f} s)"
        self.log.info("stage %d/%d: %s", self.done, self.total, message)
        if self.progress is not None:
            self.progress(self.done, self.total, message)
