"""The parent: every FMU's cases in child workers, crashes and time-outs recorded, the report."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from satfmu.fmus import archive
from satfmu.sims.robustness.cases import FAR_FACTOR
from satfmu.sims.robustness.instance import NO_RESULT, OK, STATUS_NAMES, Outcome, short
from satfmu.sims.robustness.memory import WARMUP_CYCLES, rss_bound_kib
from satfmu.sims.robustness.results import write
from satfmu.sims.robustness.table import (CASE_BY_NAME, CASES, CYCLES_CASE, FAR_CASE, FLIPS_CASE, FULL_SCAN_BITS,
                                   HUGE_CASES, Case, Settings)
from satfmu.sims.robustness.target import BACKENDS, Target, describe, discover

CASE_TIMEOUT_S = 120.0
"""Time limit of one case in s (the cases other than the far step, the cycles and the bit-flip scans
take < 2 s)."""
HUGE_TIMEOUT_S = 3.0
"""Time limit of a huge-step case in s: 4 or 5 steps of at most ~0.7 s each on a native FMU by its
work bounds (measured: 0.3 s at most, demeter_flexible's DBL_MAX step), so a case still running
after 3 s hangs."""
FLIP_TIMEOUT_S = 1e-3
"""Extra time limit per bit of a full bit-flip scan in s (measured: ~0.03 ms per flip, native)."""
CYCLE_TIMEOUT_S = 0.5
"""Extra time limit per instantiate/free cycle in s (slowest measured: 47 ms, demeter_flexible_py)."""
FAR_TIMEOUT_S = 0.05
"""Extra time limit of the far step per default step size in s (slowest measured: 0.5 ms, the
online SDRE pythonfmu controllers; 8 ms before their inputs started at the plant's initial state)."""


# ----------------------------------------------------------------------------- parent
@dataclass
class Row:
    """One cell of the report: a case on an FMU.

    Attributes
    ----------
    fmu, backend, case : str
    expected : str
        The expectation on this backend.
    got : str
        Status of the call under test (``-`` when not run, ``CRASH``, ``TIMEOUT``).
    log_found : bool or None
        The expected log fragment was found (None when no text was required).
    verdict : str
        ``pass``, ``fail``, ``crash`` or ``n/a``.
    detail : str
        What happened (measured facts, problems, crash signal and output).
    metrics : dict of str to float
        Measured quantities (``rss_growth_kib`` of the cycles case, ``step_s``, ...).
    """

    fmu: str
    backend: str
    case: str
    expected: str
    got: str
    log_found: bool | None
    verdict: str
    detail: str
    metrics: dict[str, float] = field(default_factory=dict)

    @property
    def cell(self) -> str:
        """The Markdown table cell: ok / FAIL: ... / CRASH / n/a (with a short measured note)."""
        if self.verdict == "n/a":
            return "n/a"
        if self.verdict == "crash":
            return "CRASH"
        if self.verdict == "fail":
            return "FAIL: " + short(self.detail, 80)
        if self.case == CYCLES_CASE:
            return f"ok ({self.metrics.get('rss_growth_kib', 0):+.0f} KiB)"
        if self.got != "OK" and self.expected.startswith("OK or"):
            return f"ok ({self.got})"
        if self.metrics.get("non_finite_outputs"):
            return "ok (inf/nan out)"
        return "ok"


def judge(case: Case, target: Target, out: Outcome) -> Row:
    """The row of ``case`` on ``target`` from the worker's outcome: ``fail`` on any deviation from the
    expectation.

    Parameters
    ----------
    case : Case
        The case that ran (its expectation on the target's backend).
    target : Target
        The FMU it ran on.
    out : Outcome
        What the worker observed.

    Returns
    -------
    Row
        Verdict ``pass``, ``fail`` or ``n/a`` (the case found it cannot apply).
    """
    expect = case.expect[target.backend]
    if out.not_applicable:
        return Row(target.name, target.backend, case.name, expect.text, "-", None, "n/a", out.not_applicable)
    problems = list(out.problems)
    if out.status == NO_RESULT:  # the case could not make its call: a failure whatever the reason
        problems = problems or ["no result"]
    elif out.status not in expect.statuses:
        why = f"status {STATUS_NAMES.get(out.status, out.status)}, expected {expect.text}"
        problems.insert(0, why)
    found = None
    if out.status not in (OK, NO_RESULT) and out.status in expect.statuses and expect.fragments:
        found = any(f in out.log for f in expect.fragments)
        if not found:
            problems.append(f"log lacks {' / '.join(map(repr, expect.fragments))}: {short(out.log, 200)!r}")
    detail = "; ".join(problems + ([out.detail] if out.detail else [])) or short(out.log, 200)
    verdict = "fail" if problems else "pass"
    return Row(target.name, target.backend, case.name, expect.text, STATUS_NAMES.get(out.status, str(out.status)),
               found, verdict, detail, dict(out.metrics))


def _signal_name(code: int) -> str:
    if code >= 0:
        return f"exit code {code}"
    try:
        return f"{signal.Signals(-code).name} (exit code {code})"
    except ValueError:
        return f"signal {-code}"


def _timeout(case: str, settings: Settings) -> float:
    """Time limit of ``case`` in s."""
    if case == CYCLES_CASE:
        return CASE_TIMEOUT_S + CYCLE_TIMEOUT_S * (settings.cycles + WARMUP_CYCLES)
    if case == FAR_CASE:
        return CASE_TIMEOUT_S + FAR_TIMEOUT_S * settings.far_factor
    if case in HUGE_CASES:
        return HUGE_TIMEOUT_S
    if case == FLIPS_CASE:
        return CASE_TIMEOUT_S + FLIP_TIMEOUT_S * (settings.flips if settings.flips is not None else FULL_SCAN_BITS)
    return CASE_TIMEOUT_S


def _read_events(path: Path, seen: int) -> list[dict[str, Any]]:
    """Complete JSON lines of ``path`` after the first ``seen``."""
    if not path.exists():
        return []
    lines = path.read_text().split("\n")[:-1]  # the last element is "" or a partial line
    return [json.loads(line) for line in lines[seen:]]


ONE_BLAS_THREAD = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
"""Workers run one BLAS thread each: a worker's spinning BLAS thread pool beside other processes
(a parallel test run, say) oversubscribes the CPUs (measured: two online SDRE workers side by
side 5x slower with OpenBLAS's default threads than with one each)."""


def _start_worker(target: Target, names: list[str], settings: Settings, results: Path, output: Path
                  ) -> subprocess.Popen:
    """``python -m satfmu.sims.robustness --worker`` on ``names``: events to ``results``, its stdout and
    stderr to ``output``; its FMU extraction goes next to them (removed by the parent even if the
    worker crashes)."""
    results.unlink(missing_ok=True)
    argv = [sys.executable, "-m", "satfmu.sims.robustness", "--worker", str(target.path), "--results", str(results),
            "--cycles", str(settings.cycles), "--far-factor", repr(settings.far_factor),
            *(["--flips", str(settings.flips)] if settings.flips is not None else []), *names]
    with output.open("w") as log:
        return subprocess.Popen(argv, stdout=log, stderr=subprocess.STDOUT,
                                env={**os.environ, **ONE_BLAS_THREAD, "TMPDIR": str(results.parent)})


def _child(target: Target, names: list[str], settings: Settings, workdir: Path
           ) -> Iterator[tuple[str, Outcome | Row]]:
    """Run a worker on ``names``; yields (case, Outcome) per finished case, and (case, Row) for the
    case a crash or time-out ended it in (the worker is gone then)."""
    results, output = workdir / "results.jsonl", workdir / "output.txt"
    proc = _start_worker(target, names, settings, results, output)
    seen, running, started = 0, None, time.monotonic()
    try:
        while True:
            code = proc.poll()
            for event in _read_events(results, seen):
                seen += 1
                if event["event"] == "start":
                    running, started = event["case"], time.monotonic()
                else:
                    running = None
                    yield event["case"], Outcome(**{k: v for k, v in event.items() if k not in ("event", "case")})
            if code is not None:
                break
            if running is not None and time.monotonic() - started > _timeout(running, settings):
                proc.kill()
                proc.wait()
                limit = _timeout(running, settings)
                yield running, _bad_row(target, running, "TIMEOUT", "fail", f"no result within {limit:g} s (killed)")
                return
            time.sleep(0.05)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    if code != 0 or seen < 2 * len(names):
        yield _crash(target, names, running, code, results, output)


def _crash(target: Target, names: list[str], running: str | None, code: int, results: Path, output: Path
           ) -> tuple[str, Row]:
    """The CRASH row of a dead worker: the case it was running, else the first one it did not finish
    (it died between cases), else the last one (it died on exit, after every case)."""
    done = {e["case"] for e in _read_events(results, 0) if e["event"] == "done"}
    victim = running or next((n for n in names if n not in done), None)
    when = "during this case" if running else "before this case started" if victim else "on exit after all cases"
    victim = victim or names[-1]
    tail = short(output.read_text(errors="replace")[-600:], 400)
    return victim, _bad_row(target, victim, "CRASH", "crash", f"worker died ({_signal_name(code)}) {when}; "
                                                              f"output: {tail!r}")


def _bad_row(target: Target, case: str, got: str, verdict: str, detail: str) -> Row:
    """A row without an outcome (a crash or a time-out)."""
    expect = CASE_BY_NAME[case].expect[target.backend]
    return Row(target.name, target.backend, case, expect.text, got, None, verdict, detail)


def run_fmu(target: Target, settings: Settings, workdir: Path) -> list[Row]:
    """Every case on one FMU: n/a rows for the inapplicable ones, the rest in as many workers as
    crashes and time-outs require (each restarts with the cases not yet done).

    Parameters
    ----------
    target : Target
        The FMU under test.
    settings : Settings
        Sizes of the run (cycles, far step, bit flips; the time limits scale with them).
    workdir : Path
        Folder of the workers' event files, output and FMU extractions.

    Returns
    -------
    list of Row
        One per case, in the order of :data:`~satfmu.sims.robustness.table.CASES`.
    """
    rows: dict[str, Row] = {}
    todo = []
    for case in CASES:
        why = case.applies(target)
        if why:
            rows[case.name] = Row(target.name, target.backend, case.name, case.expect[target.backend].text, "-",
                                  None, "n/a", why)
        else:
            todo.append(case.name)
    while todo:
        for name, result in _child(target, todo, settings, workdir):
            rows[name] = result if isinstance(result, Row) else judge(CASE_BY_NAME[name], target, result)
        todo = [n for n in todo if n not in rows]
    return [rows[c.name] for c in CASES]


@dataclass
class SuiteResult:
    """Results of a run.

    Attributes
    ----------
    rows : list of Row
        One per case and FMU, FMU by FMU in the order of :data:`~satfmu.sims.robustness.table.CASES`.
    settings : Settings
    wall_s : float
        Wall time of the run in s.
    """

    rows: list[Row]
    settings: Settings
    wall_s: float

    @property
    def fmus(self) -> list[str]:
        """The FMUs tested, in order."""
        return list(dict.fromkeys(r.fmu for r in self.rows))

    @property
    def failures(self) -> list[Row]:
        """Rows with verdict ``fail``."""
        return [r for r in self.rows if r.verdict == "fail"]

    @property
    def crashes(self) -> list[Row]:
        """Rows with verdict ``crash``."""
        return [r for r in self.rows if r.verdict == "crash"]

    @property
    def ok(self) -> bool:
        """No failure and no crash."""
        return not self.failures and not self.crashes

    def count(self, verdict: str) -> int:
        """Number of rows with ``verdict``.

        Parameters
        ----------
        verdict : {"pass", "fail", "crash", "n/a"}
            The verdict to count.
        """
        return sum(r.verdict == verdict for r in self.rows)

    def rss_growth_kib(self, backend: str) -> dict[str, float]:
        """RSS growth of the cycles case in KiB per FMU of ``backend`` (FMUs where it ran).

        Parameters
        ----------
        backend : {"native", "pythonfmu"}
            :data:`~satfmu.sims.robustness.target.NATIVE` or
            :data:`~satfmu.sims.robustness.target.PYTHONFMU`.
        """
        return {r.fmu: r.metrics["rss_growth_kib"] for r in self.rows
                if r.case == CYCLES_CASE and r.backend == backend and "rss_growth_kib" in r.metrics}

    def summary(self) -> str:
        """One paragraph: counts, crashes, RSS growth per backend and wall time."""
        parts = [(f"{len(self.fmus)} FMUs x {len(CASES)} cases: {self.count('pass')} pass, "
                  f"{self.count('fail')} fail, {self.count('crash')} crash, {self.count('n/a')} n/a")]
        for backend in BACKENDS:
            growth = self.rss_growth_kib(backend)
            if growth:
                worst = max(growth, key=growth.__getitem__)
                bound = rss_bound_kib(backend, self.settings.cycles)
                parts.append(f"max RSS growth over {self.settings.cycles} cycles, {backend}: "
                             f"{growth[worst]:+.0f} KiB ({worst}; bound {bound:g} KiB)")
        parts.append(f"wall time {self.wall_s:.0f} s")
        return "; ".join(parts) + "."


def run(fmu_dir: Path, fmus: list[str] | None = None, cycles: int = 1000, out: Path | None = None, *,
        far_factor: float = FAR_FACTOR, flips: int | None = None) -> SuiteResult:
    """Run every case on every FMU of ``fmu_dir`` (or on ``fmus``), each FMU in child processes.

    Parameters
    ----------
    fmu_dir : Path
        Folder of the FMUs; every ``*.fmu`` in it is tested unless ``fmus`` is given.
    fmus : list of str, optional
        FMU names (with or without ``.fmu``) to test instead.
    cycles : int
        Instantiate/free cycles of the memory case (RSS bound scaled with it).
    out : Path, optional
        Write ``<out>.md`` and ``<out>.csv`` (atomically).
    far_factor : float
        The far step in default step sizes (smaller: faster, for quick checks).
    flips : int, optional
        Single-bit flips of each native FMU state, a seeded sample (default: every bit).

    Returns
    -------
    SuiteResult
    """
    settings = Settings(cycles, far_factor, flips)
    started = time.monotonic()
    rows: list[Row] = []
    with tempfile.TemporaryDirectory(prefix="satfmu_robustness_") as tmp:
        for path in discover(Path(fmu_dir), fmus):
            rows += _run_path(path, settings, Path(tmp))
    report = SuiteResult(rows, settings, time.monotonic() - started)
    if out is not None:
        write(report, Path(out))
    return report


def _run_path(path: Path, settings: Settings, workdir: Path) -> list[Row]:
    """:func:`run_fmu` on the FMU file ``path``; an unreadable FMU (:func:`satfmu.fmus.archive.check`, every
    entry's CRC included, since the workers extract it) fails every case."""
    try:
        archive.check(path, crc=True)
        target = describe(path)
    except Exception as exc:  # noqa: BLE001 - an unreadable FMU fails every case
        return [Row(path.stem, "?", c.name, "-", "-", None, "fail",
                    f"cannot read the FMU: {type(exc).__name__}: {exc}") for c in CASES]
    return run_fmu(target, settings, workdir)


