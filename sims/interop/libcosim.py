"""libcosim (Open Simulation Platform, PyPI ``libcosimpy``) as a second co-simulation engine.

:func:`run` loads an SSP file (:mod:`satfmu.sims.interop.ssp`) into libcosim and records variables at every
communication point. libcosim runs in a child process (:func:`run`): it is C++ behind ctypes,
and an error inside a pythonfmu FMU's step, or a malformed file, ends the whole process, which
must not be ours. The child is this module (``python -m satfmu.sims.interop.libcosim``), which writes the
samples to an ``.npz`` file. The child drives libcosim as libcosim's own tools do: all steps in
one ``step(n)`` call, the variables recorded by a time-series observer inside libcosim, so
no Python runs between two steps.

Times in libcosim are integer nanoseconds: the step size is rounded to 1 ns, and a step that
is not a whole number of nanoseconds is refused. libcosim's fixed-step algorithm exchanges
data after each step in Jacobi order (every output is read, then every input set), so
:meth:`satfmu.sims.cosim.master.CoSimulation.run` with ``exchange_order="jacobi"`` is the run to compare with.
The observer samples each point right after the step, before the exchange: an input shows the
value used over the step that ended (:func:`run` shifts inputs back to the master's
convention), and a direct-feedthrough output the value it passes on, computed from the
previous point's inputs (the master records it from the new inputs; :mod:`satfmu.sims.interop.verify`
aligns the two).
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Sequence

import numpy as np
from satfmu.fmus.errors import EngineError

NS_PER_S = 1_000_000_000


def nanoseconds(seconds: float, what: str) -> int:
    """``seconds`` as integer ns.

    Parameters
    ----------
    seconds : float
        A time, s.
    what : str
        Its name in the error message (``"step_size"``, which must also be positive).

    Raises
    ------
    EngineError
        If it is not a whole number of nanoseconds (to 1e-6 ns), or ``what`` is ``"step_size"``
        and it is not positive.
    """
    ns = round(seconds * NS_PER_S)
    if ns <= 0 and what == "step_size" or abs(ns - seconds * NS_PER_S) > 1e-6 * max(1.0, abs(ns)):
        raise EngineError(f"libcosim needs {what} as a whole positive number of nanoseconds, got {seconds!r} s")
    return ns


def _simulate(ssp: Path, record: Sequence[str], stop_time: float, step_size: float, start_time: float
              ) -> dict[str, np.ndarray]:
    """Run in this process (the child): samples at t_1 ... t_n, by qualified name.

    libcosim runs every step in one call (``step(n)``) and a time-series observer records the
    variables inside libcosim, so no Python runs between steps; the samples are read at the end,
    one call per variable.
    """
    from libcosimpy.CosimEnums import CosimVariableCausality, CosimVariableType
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver

    log_output_level(CosimLogLevel.WARNING)
    step_ns = nanoseconds(step_size, "step_size")
    n_steps = round((stop_time - start_time) / step_size)
    if start_time != 0.0:
        raise EngineError("the SSP default experiment starts at 0 s in libcosim; start_time must be 0")
    ex = CosimExecution.from_ssp_file(str(ssp), step_size=step_ns)
    obs = CosimObserver.create_time_series(buffer_size=n_steps + 1)  # the default keeps 10,000 samples
    ex.add_observer(obs)
    refs: dict[str, tuple[int, int]] = {}
    inputs = []
    for q in record:
        inst, var = q.split(".", 1)
        idx = ex.slave_index_from_instance_name(inst)
        if idx is None or idx < 0:
            raise EngineError(f"libcosim has no instance {inst!r}")
        found = {v.name.decode(): v for v in ex.slave_variables(idx)}
        if var not in found:
            raise EngineError(f"libcosim: instance {inst!r} has no variable {var!r}")
        if found[var].causality == CosimVariableCausality.INPUT.value:
            inputs.append(q)
        refs[q] = (idx, found[var].reference)
        if not obs.start_time_series(idx, found[var].reference, CosimVariableType.REAL):
            raise EngineError(f"libcosim cannot observe {q!r}")
    if not ex.step(n_steps):
        raise EngineError(f"libcosim: a step of {n_steps} failed")
    data: dict[str, np.ndarray] = {}
    for q, (idx, vr) in refs.items():
        times, steps, values = obs.time_series_real_samples(idx, vr, from_step=1, sample_count=n_steps)
        if list(steps) != list(range(1, n_steps + 1)):
            raise EngineError(f"libcosim recorded steps {steps[:3]}...{steps[-3:]} of {q!r}, "
                              f"expected 1 ... {n_steps}")
        data[q] = np.asarray(values, float)
        data.setdefault("time", np.asarray(times, np.int64) / NS_PER_S)
    if not refs:
        data["time"] = step_size * np.arange(1, n_steps + 1)
    data["__inputs__"] = np.array(inputs, dtype=str)
    return data


def run(ssp: Path, record: Sequence[str], stop_time: float, step_size: float, start_time: float = 0.0,
        timeout: float = 3600.0) -> np.ndarray:
    """Run ``ssp`` in libcosim (child process) and return the recorded variables.

    Parameters
    ----------
    ssp : Path
        The SSP file.
    record : sequence of str
        Qualified Real variables ``instance.variable`` (no base names).
    stop_time, step_size, start_time : float
        s; the step a whole number of nanoseconds.
    timeout : float
        s, for the child process.

    Returns
    -------
    numpy.ndarray
        Structured array (``time`` and one field per variable) at t_1 ... t_n; each recorded
        input holds the value set at that time, as the master records it (libcosim's observer
        shows it one step later; the last one is therefore NaN).

    Raises
    ------
    EngineError
        libcosim's error, a crash of its process (with the exit code and output), a timeout.
    """
    nanoseconds(step_size, "step_size")
    with tempfile.TemporaryDirectory(prefix="satfmu_libcosim_") as tmp:
        out = Path(tmp) / "samples.npz"
        spec = json.dumps({"ssp": str(Path(ssp).resolve()), "record": list(record), "stop_time": stop_time,
                           "step_size": step_size, "start_time": start_time, "out": str(out)})
        try:
            # libcosim extracts the FMUs into TMPDIR: this folder, removed whatever happens
            proc = subprocess.run([sys.executable, "-m", "satfmu.sims.interop.libcosim", spec], capture_output=True,
                                  text=True,
                                  timeout=timeout, env={**os.environ, "TMPDIR": tmp})
        except subprocess.TimeoutExpired:
            raise EngineError(f"libcosim did not finish {Path(ssp).name} within {timeout:g} s") from None
        if proc.returncode != 0 or not out.exists():
            text = (proc.stdout + proc.stderr).strip()[-2000:]
            raise EngineError(f"libcosim failed on {Path(ssp).name} (exit code {proc.returncode}):\n{text}")
        with np.load(out) as z:
            data = {k: z[k] for k in z.files}
    inputs = set(data.pop("__inputs__").tolist())
    res = np.zeros(len(data["time"]), dtype=[("time", "f8")] + [(q, "f8") for q in record])
    res["time"] = data["time"]
    for q in record:
        res[q] = np.append(data[q][1:], np.nan) if q in inputs else data[q]
    return res


def main(argv: list[str] | None = None) -> int:
    """Child process: run the JSON job of ``argv[0]`` and write its samples.

    Parameters
    ----------
    argv : list of str, optional
        The command-line arguments: one JSON object with ``ssp``, ``record``, ``stop_time``,
        ``step_size``, ``start_time`` and ``out`` (the ``.npz`` file to write); default
        ``sys.argv[1:]``.

    Returns
    -------
    int
        The exit code: 0, or 1 after libcosim's error (printed to stderr).
    """
    parser = argparse.ArgumentParser(prog="python -m satfmu.sims.interop.libcosim")
    parser.add_argument("job", help="JSON: ssp, record, stop_time, step_size, start_time, out")
    job = json.loads(parser.parse_args(argv).job)
    try:
        data = _simulate(Path(job["ssp"]), job["record"], job["stop_time"], job["step_size"], job["start_time"])
    except EngineError as exc:
        print(exc, file=sys.stderr)
        return 1
    np.savez(job["out"], allow_pickle=True, **data)  # numpy's default, named: the arrays are the other keywords
    return 0


if __name__ == "__main__":
    sys.exit(main())
