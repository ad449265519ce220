"""The master's step loop compiled: ``sims/cosim/c/cosim_loop.c``, built with gcc, called through ctypes.

:class:`satfmu.sims.cosim.master.CoSimulation` prepares a run in Python (instantiation, parameters,
initialization, the transfer plan, the profile values, the recorded variables) and then
steps either in Python or here, through the fmi2 function pointers of the libraries fmpy
loaded. Both loops make the same FMI calls with the same values in the same order, so
their results are identical bit for bit (tests/test_compiled_loop.py runs every shipped
scenario both ways); the Python loop stays the reference and the fallback.

The shared library is compiled on first use (``gcc -O2 -shared -fPIC``, about 0.2 s) into
``<satfmu home>/lib/cosim_loop-<digest>.so`` (:func:`satfmu.controllers.paths.home`), named by the SHA-256
of the C source and of the compile command, written whole (temporary name, then rename),
and reused by every later run; ``satfmu build`` compiles it ahead. Without a C compiler
:func:`library` returns None and the master steps in Python.

Measured on mrp_200deg (2400 steps, two native FMUs, 2 cores, ``python bench/cosim_speed.py
--repeat 7``, CPU per run, min): 1.89 ms for the whole run (reset, initialization, steps, result
array) against 29.7 ms for the Python loop, 28.3 ms for libcosim and 1.27 ms for a bare C loop
over the same FMU binaries (``bench/c/fmu_loop.c``).
"""
from __future__ import annotations

import ctypes
import hashlib
import os
import platform
import shutil
import subprocess
import sys
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Any, Callable

import numpy as np

from satfmu.fmus.atomic import write_atomically

SOURCE = Path(__file__).resolve().parent / "c" / "cosim_loop.c"
"""The C source of the loop."""
CFLAGS = ("-O2", "-shared", "-fPIC", "-std=c99", "-Wall", "-Wextra", "-Werror")
"""Compile flags of the loop's shared library (no floating-point arithmetic happens in it: the
flags cannot change a result, only copy values)."""
BLOCK = 16384
"""Steps per call into the library: between calls Python handles signals (Ctrl-C stops a long
run within a block, ~10 ms for two native FMUs)."""
CALLS = {1: "fmi2DoStep", 2: "fmi2GetReal", 3: "fmi2SetReal"}
"""Code of the failed call (``Plan.failed_call``) -> FMI function name."""

_uint_p = ctypes.POINTER(ctypes.c_uint)
_double_p = ctypes.POINTER(ctypes.c_double)
_long_p = ctypes.POINTER(ctypes.c_long)


class _Fmu(ctypes.Structure):
    _fields_ = [("instance", ctypes.c_void_p), ("do_step", ctypes.c_void_p), ("get_real", ctypes.c_void_p),
                ("set_real", ctypes.c_void_p)]


class _Transfer(ctypes.Structure):
    _fields_ = [("src", ctypes.c_int), ("dst", ctypes.c_int), ("n", ctypes.c_size_t), ("src_vr", _uint_p),
                ("dst_vr", _uint_p), ("buf", _double_p)]


class _ProfileSet(ctypes.Structure):
    _fields_ = [("fmu", ctypes.c_int), ("n", ctypes.c_size_t), ("vr", _uint_p), ("values", _double_p),
                ("buf", _double_p)]


class _RecordSet(ctypes.Structure):
    _fields_ = [("fmu", ctypes.c_int), ("n", ctypes.c_size_t), ("vr", _uint_p), ("cols", _long_p),
                ("buf", _double_p)]


class _Plan(ctypes.Structure):
    _fields_ = [("n_fmus", ctypes.c_int), ("fmus", ctypes.POINTER(_Fmu)),
                ("n_transfers", ctypes.c_int), ("transfers", ctypes.POINTER(_Transfer)),
                ("n_profiles", ctypes.c_int), ("profiles", ctypes.POINTER(_ProfileSet)),
                ("n_records", ctypes.c_int), ("records", ctypes.POINTER(_RecordSet)),
                ("times", _double_p), ("step_size", ctypes.c_double), ("n_steps", ctypes.c_long),
                ("jacobi", ctypes.c_int), ("record_every", ctypes.c_long), ("data", _double_p),
                ("n_cols", ctypes.c_long), ("row0", ctypes.c_long), ("k0", ctypes.c_long),
                ("failed_step", ctypes.c_long), ("failed_fmu", ctypes.c_int),
                ("failed_call", ctypes.c_int), ("status", ctypes.c_int)]


def library_path(cc: str = "gcc") -> Path:
    """Where the compiled loop is kept: ``<home>/lib/cosim_loop-<digest>.so``, the digest over
    the source, the compiler's name, the flags and the platform.

    Parameters
    ----------
    cc : str, optional
        Name (or path) of the C compiler. Default ``"gcc"``.
    """
    from satfmu.controllers.paths import home

    return home() / "lib" / f"cosim_loop-{_digest(cc)}.so"


@lru_cache(maxsize=None)
def _digest(cc: str) -> str:
    key = hashlib.sha256(SOURCE.read_bytes() + repr((cc, CFLAGS, platform.machine(), sys.platform)).encode())
    return key.hexdigest()[:16]


def compile_library(cc: str = "gcc") -> Path:
    """Compile the loop into :func:`library_path` (nothing to do if it is there).

    Parameters
    ----------
    cc : str, optional
        Name (or path) of the C compiler. Default ``"gcc"``.

    Returns
    -------
    Path
        The shared library.

    Raises
    ------
    FileNotFoundError
        No compiler ``cc``.
    RuntimeError
        The compiler failed (its output in the message).
    """
    dest = library_path(cc)
    if dest.is_file():
        return dest
    if shutil.which(cc) is None:
        raise FileNotFoundError(f"C compiler {cc!r} not found (install gcc): the master steps in Python")

    def build(tmp: Path) -> None:
        proc = subprocess.run([cc, *CFLAGS, "-o", str(tmp), str(SOURCE)], capture_output=True, text=True)
        if proc.returncode != 0:
            raise RuntimeError(f"compiling {SOURCE.name} failed: {proc.stderr.strip()}")

    dest.parent.mkdir(parents=True, exist_ok=True)
    return write_atomically(dest, build)


@lru_cache(maxsize=None)
def _load(path: str) -> ctypes.CDLL:
    lib = ctypes.CDLL(path)
    lib.satfmu_cosim_steps.argtypes = [ctypes.POINTER(_Plan), ctypes.c_long, ctypes.c_long]
    lib.satfmu_cosim_steps.restype = ctypes.c_int
    return lib


def library(cc: str = "gcc") -> ctypes.CDLL | None:
    """The compiled loop, compiled on first use; None without the C compiler ``cc`` or when the
    environment variable ``SATFMU_PYTHON_LOOP`` is set (the master then steps in Python).

    Parameters
    ----------
    cc : str, optional
        Name (or path) of the C compiler. Default ``"gcc"``.

    Raises
    ------
    RuntimeError
        If the compiler fails (:func:`compile_library`).
    """
    if os.environ.get("SATFMU_PYTHON_LOOP"):
        return None
    try:
        return _load(str(compile_library(cc)))
    except FileNotFoundError:
        return None


def _pointer(arr: np.ndarray, ctype: Any) -> Any:
    return arr.ctypes.data_as(ctypes.POINTER(ctype))


def _function(slave: Any, name: str) -> int:
    """Address of an FMI function in the library fmpy loaded for ``slave``."""
    address = ctypes.cast(getattr(slave.dll, name), ctypes.c_void_p).value
    assert address is not None  # a symbol the library exports (getattr raises for a missing one) is not NULL
    return address


@dataclass
class Failure:
    """The call that stopped a compiled run: step k, FMU index, FMI function, status.

    Attributes
    ----------
    step : int
        ``k`` of the failed call: the step from t_k for ``fmi2DoStep``, the communication point
        t_k for an ``fmi2GetReal`` or ``fmi2SetReal`` after a step.
    fmu : int
        Index of the FMU in the ``slaves`` of the :class:`StepPlan`.
    function : str
        The FMI function (a value of :data:`CALLS`).
    status : int
        The ``fmi2Status`` it returned, above ``fmi2Warning`` (2 discard, 3 error, 4 fatal, 5 pending).
    """

    step: int
    fmu: int
    function: str
    status: int


@dataclass
class StepPlan:
    """A run's step plan in the C loop's layout; holds every array the plan points to.

    Parameters
    ----------
    slaves : list
        fmpy ``FMU2Slave`` of each FMU, instantiated, in stepping order.
    transfers : list of (int, int, ctypes uint array, ctypes uint array, ctypes double array)
        (source FMU, target FMU, source value references, target value references, buffer),
        in propagation order.
    profiles : list of (int, ctypes uint array, ctypes double array)
        (FMU, value references, buffer); their values come with each block (:meth:`run`).
    records : list of (int, ctypes uint array, ctypes double array, ndarray)
        (FMU, value references, buffer, columns).
    n_steps : int
        Number of communication steps of the run.
    step_size : float
        s.
    jacobi : bool
        Exchange in Jacobi order (every output read before any input is set) instead of
        feedthrough order.
    record_every : int
        Record every ``record_every``-th communication point (>= 1) and the last one.
    data : ndarray
        Recorded rows x columns, C-contiguous float64, written in place: every row of the run,
        or (streamed, :meth:`run` with ``on_block``) those of one block of steps at a time.
    _keep : list, optional
        Internal, not to be given: the arrays :meth:`plan` made, kept alive while the C
        structure points to them.
    """

    slaves: list[Any]
    transfers: list[tuple[int, int, Any, Any, Any]]
    profiles: list[tuple[int, Any, Any]]
    records: list[tuple[int, Any, Any, np.ndarray]]
    n_steps: int
    step_size: float
    jacobi: bool
    record_every: int
    data: np.ndarray
    _keep: list[Any] = field(default_factory=list, repr=False)

    def plan(self) -> _Plan:
        """The C structure (its arrays kept alive by this object)."""
        fmus = (_Fmu * len(self.slaves))(*[
            _Fmu(s.component, _function(s, "fmi2DoStep"), _function(s, "fmi2GetReal"), _function(s, "fmi2SetReal"))
            for s in self.slaves])
        transfers = (_Transfer * len(self.transfers))(*[
            _Transfer(src, dst, len(buf), ctypes.cast(svr, _uint_p), ctypes.cast(dvr, _uint_p),
                      ctypes.cast(buf, _double_p)) for src, dst, svr, dvr, buf in self.transfers])
        profiles = (_ProfileSet * len(self.profiles))(*[
            _ProfileSet(fmu, len(buf), ctypes.cast(vr, _uint_p), None, ctypes.cast(buf, _double_p))
            for fmu, vr, buf in self.profiles])
        cols = [np.ascontiguousarray(c, dtype=np.int64 if ctypes.sizeof(ctypes.c_long) == 8 else np.int32)
                for *_, c in self.records]
        records = (_RecordSet * len(self.records))(*[
            _RecordSet(fmu, len(buf), ctypes.cast(vr, _uint_p), _pointer(c, ctypes.c_long),
                       ctypes.cast(buf, _double_p)) for (fmu, vr, buf, _), c in zip(self.records, cols)])
        if not (self.data.flags.c_contiguous and self.data.dtype == np.float64):
            raise ValueError("the recording array must be C-contiguous float64")
        self._keep = [fmus, transfers, profiles, cols, records]
        return _Plan(len(self.slaves), fmus, len(self.transfers), transfers, len(self.profiles), profiles,
                     len(self.records), records, None, float(self.step_size),
                     int(self.n_steps), int(self.jacobi), int(self.record_every), _pointer(self.data, ctypes.c_double),
                     self.data.shape[1] if self.data.ndim == 2 else 0, 0, 0, -1, -1, 0, 0)

    def _hold(self, plan: _Plan, first: int, times: np.ndarray, values: list[np.ndarray]) -> list[np.ndarray]:
        """Point the plan at the times and profile values of the points ``first ..``; returns the
        arrays, to be kept alive while the plan points to them."""
        times = np.ascontiguousarray(times, dtype=np.float64)
        values = [np.ascontiguousarray(v, dtype=np.float64) for v in values]
        for i, (v, (_, _, buf)) in enumerate(zip(values, self.profiles)):
            if v.shape != (len(times), len(buf)):
                raise ValueError(f"profile set {i}: values of shape {v.shape}, not {(len(times), len(buf))}")
            plan.profiles[i].values = _pointer(v, ctypes.c_double)
        plan.times, plan.k0 = _pointer(times, ctypes.c_double), int(first)
        return [times, *values]

    def run(self, lib: ctypes.CDLL, points: Callable[[int, int], tuple[int, np.ndarray, list[np.ndarray]]],
            on_block: Callable[[int, int], None] | None = None,
            rows_through: Callable[[int], int] | None = None) -> Failure | None:
        """Steps 0 .. n_steps - 1 in blocks of :data:`BLOCK`; the failure that stopped them, if any.

        Parameters
        ----------
        lib : ctypes.CDLL
            The compiled loop (:func:`library`).
        points : callable
            ``points(first, last)``: ``(k0, times, values)``, the communication times of the points
            ``k0 .. `` (covering ``first .. last``) and each profile set's values there, one row a
            point. Called once for every block with ``on_block``; else once, for every point.
        on_block : callable, optional
            Streamed recording: ``on_block(r0, r1)`` after each block, whose recorded rows
            ``r0 .. r1 - 1`` are then ``data[:r1 - r0]`` (``data`` holds a block's rows, each block
            writes over the last). Default: ``data`` holds every row.
        rows_through : callable, optional
            With ``on_block``: ``rows_through(point)``, how many recorded rows are at points up to
            ``point`` (the rule of :func:`satfmu.sims.cosim.master.recorded_steps`).

        Returns
        -------
        Failure or None
            The call that stopped the run, None if every step ran.
        """
        plan = self.plan()
        held: list[np.ndarray] = []
        for begin in range(0, self.n_steps, BLOCK):
            end = min(begin + BLOCK, self.n_steps)
            if on_block is not None or not held:
                held = self._hold(plan, *points(begin, end))
            if on_block is not None:
                assert rows_through is not None  # given with on_block
                plan.row0 = r0 = rows_through(begin)
            if lib.satfmu_cosim_steps(ctypes.byref(plan), begin, end) != 0:
                return Failure(plan.failed_step, plan.failed_fmu, CALLS[plan.failed_call], plan.status)
            if on_block is not None:
                assert rows_through is not None
                on_block(r0, rows_through(end))
        return None
