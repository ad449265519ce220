"""Co-simulation speed: satfmu's compiled loop vs its Python loop vs libcosim vs a bare C loop.

The four engines run the same scenario through the same native FMUs (parameters, connections,
profiles, recorded variables):

- ``compiled loop``: :meth:`satfmu.sims.cosim.master.CoSimulation.run` with ``engine="compiled"``, timed
  whole (``fmi2Reset`` of the instances kept from the previous run, parameters,
  initialization, profiles sampled, the steps, the result array);
- ``Python loop``: the same with ``engine="python"`` (the master's reference loop);
- ``libcosim``: libcosimpy (Open Simulation Platform) on the scenario's SSP export, in this
  process, ``step(n)`` with a time-series observer of the recorded variables (as libcosim's
  own tools drive it); only the steps are timed (loading the SSP and initialization are not);
- ``C loop``: ``bench/c/fmu_loop.c``, compiled here with gcc -O2, dlopen-ing the FMUs' binaries
  that fmpy extracted and making the master's calls with nothing around them; only its step
  loop is timed (by itself, CPU clock).

Each repetition runs every engine once, in turn (interleaved: load on the shared machine hits
them alike); the figures are CPU seconds per run (process time, so a thread pool counts in
full), min and median over the repetitions, as steps/s and as ratios. The compiled loop, the
Python loop and the C loop make the same calls with the same values: their final recorded rows
must be identical (checked, printed); libcosim exchanges in Jacobi order (compared with the
master's Jacobi run).

    python bench/cosim_speed.py [--repeat 5] [--scenarios mrp_200deg cubesat_detumble] [--fmu-dir DIR]
"""
from __future__ import annotations

import argparse
import statistics
import subprocess
import tempfile
import time
from pathlib import Path
from typing import Callable

import numpy as np

from satfmu.controllers import catalog, paths
from satfmu.sims.interop import ssp
from satfmu.sims.scenario.spec import Scenario, load
from satfmu.sims.scenario.wiring import grid, recorded, wire
from satfmu.sims.cosim.master import CoSimulation

HERE = Path(__file__).resolve().parent


def c_loop_binary(folder: Path) -> Path:
    """``bench/c/fmu_loop.c`` compiled into ``folder``."""
    exe = folder / "fmu_loop"
    subprocess.run(["gcc", "-O2", "-o", str(exe), str(HERE / "c" / "fmu_loop.c"), "-ldl"], check=True)
    return exe


def write_plan(sc: Scenario, sim: CoSimulation, record: list[str], folder: Path, repeat: int) -> Path:
    """The C loop's plan (format in ``bench/c/fmu_loop.c``) for one run of ``sc`` through ``sim``'s FMUs."""
    comps = list(sim.components.values())
    index = {c.name: i for i, c in enumerate(comps)}
    lines = [str(len(comps))]
    kinds = {"Real": "r", "Integer": "i", "Boolean": "b"}
    for c in comps:
        lib = Path(c.unzip_dir) / "binaries" / "linux64" / f"{c.model_description.coSimulation.modelIdentifier}.so"
        uri = (Path(c.unzip_dir) / "resources").as_uri()
        params = sc.fmus[c.name].parameters
        lines.append(f"{lib} {c.model_description.guid} {uri} {c.name} {len(params)}")
        for name, value in params.items():
            var = c.variable(name)
            lines.append(f"{kinds[var.type]} {var.valueReference} {float(value)!r}")
    transfers = sim._transfers()
    lines.append(str(len(transfers)))
    for t in transfers:
        lines += [f"{index[t.src.name]} {index[t.dst.name]} {t.n}", " ".join(map(str, t.src_vr)),
                  " ".join(map(str, t.dst_vr))]
    groups: dict[str, list[int]] = {}
    for q in c_columns(record):
        c, v = q.split(".", 1)
        groups.setdefault(c, []).append(sim.components[c].variable(v).valueReference)
    lines.append(str(len(groups)))
    lines += [f"{index[c]} {len(vrs)} {' '.join(map(str, vrs))}" for c, vrs in groups.items()]
    times = grid(sc)
    prof: dict[str, list[tuple[int, np.ndarray]]] = {}
    for target, p in sim.profiles:
        c, v = target.split(".", 1)
        prof.setdefault(c, []).append((sim.components[c].variable(v).valueReference, p.sample(times)))
    lines.append(str(len(prof)))
    lines += [f"{index[c]} {len(g)} {' '.join(str(vr) for vr, _ in g)}" for c, g in prof.items()]
    values = [times] + ([np.stack([v for g in prof.values() for _, v in g], axis=1).ravel()] if prof else [])
    np.concatenate(values).astype("<f8").tofile(folder / "values.bin")
    lines.append(f"{folder / 'values.bin'} {sc.step_size!r} {len(times) - 1} 0 {repeat}")
    plan = folder / "plan.txt"
    plan.write_text("\n".join(lines) + "\n")
    return plan


def c_columns(record: list[str]) -> list[str]:
    """The C loop's column order: the recorded variables grouped by FMU, in order of first appearance."""
    groups: dict[str, list[str]] = {}
    for q in record:
        groups.setdefault(q.split(".")[0], []).append(q)
    return [q for g in groups.values() for q in g]


def cpu(fn: Callable[[], object]) -> tuple[float, object]:
    t0 = time.process_time()
    out = fn()
    return time.process_time() - t0, out


def libcosim_run(ssp_path: Path, record: list[str], n_steps: int, step_size: float) -> tuple[float, dict]:
    """CPU seconds of libcosim's ``step(n_steps)`` with a time-series observer on ``record``, and the
    last samples."""
    from libcosimpy.CosimEnums import CosimVariableType
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver

    log_output_level(CosimLogLevel.ERROR)
    ex = CosimExecution.from_ssp_file(str(ssp_path), step_size=round(step_size * 1e9))
    obs = CosimObserver.create_time_series(buffer_size=n_steps + 1)
    ex.add_observer(obs)
    refs = {}
    for q in record:
        inst, var = q.split(".", 1)
        idx = ex.slave_index_from_instance_name(inst)
        ref = {v.name.decode(): v.reference for v in ex.slave_variables(idx)}[var]
        obs.start_time_series(idx, ref, CosimVariableType.REAL)
        refs[q] = (idx, ref)
    dt, ok = cpu(lambda: ex.step(n_steps))
    if not ok:
        raise RuntimeError("libcosim: step failed")
    last = {q: obs.time_series_real_samples(idx, ref, from_step=n_steps, sample_count=1)[2][0]
            for q, (idx, ref) in refs.items()}
    return dt, last


def bench(name: str, fmu_dir: Path, repeat: int, exe: Path, tmp: Path) -> dict[str, list[float]]:
    sc = load(name)
    n_steps = len(grid(sc)) - 1
    params = {inst: spec.parameters for inst, spec in sc.fmus.items()}
    ssp_path = ssp.write(sc, fmu_dir, tmp / f"{name}.ssp")
    times: dict[str, list[float]] = {k: [] for k in ("compiled loop", "Python loop", "libcosim", "C loop")}
    with wire(sc, fmu_dir) as sim:
        sim.reuse_instances = True
        record = recorded(sc, sim)
        plan = write_plan(sc, sim, record, tmp, 1)
        last: dict[str, np.ndarray] = {}
        for _ in range(repeat):
            for engine in ("compiled", "python"):
                dt, res = cpu(lambda: sim.run(sc.stop_time, sc.step_size, sc.start_time, params, record, engine=engine))
                times[f"{'compiled' if engine == 'compiled' else 'Python'} loop"].append(dt)
                last[engine] = np.array(res[-1].tolist()[1:])
            dt, cos_last = libcosim_run(ssp_path, record, n_steps, sc.step_size)
            times["libcosim"].append(dt)
            out = subprocess.run([str(exe), str(plan)], capture_output=True, text=True, check=True).stdout.split("\n")
            times["C loop"].append(float(out[0].split()[1]))
            c_last = dict(zip(c_columns(record), map(float, out[1].split()[1:])))
            last["C loop"] = np.array([c_last[q] for q in record])
        jacobi = sim.run(sc.stop_time, sc.step_size, sc.start_time, params, record, "jacobi")
        states = [q for q in record if not sim.components[q.split(".")[0]].feedthrough().get(q.split(".", 1)[1], {1})]
    same = all(last[k].tobytes() == last["compiled"].tobytes() for k in last)
    diff = max(abs(cos_last[q] - jacobi[q][-1]) for q in states)
    print(f"\n{name}: {n_steps} communication steps of {sc.step_size} s, {len(sim.components)} FMUs, "
          f"{len(record)} recorded variables; CPU s per run over {repeat} interleaved repetitions")
    print(f"{'engine':16s} {'min s':>9s} {'median s':>9s} {'steps/s (min)':>14s} {'x libcosim':>11s} {'x C loop':>9s}")
    ref_cos, ref_c = min(times["libcosim"]), min(times["C loop"])
    for label, ts in times.items():
        best = min(ts)
        print(f"{label:16s} {best:9.5f} {statistics.median(ts):9.5f} {n_steps / best:14,.0f} {ref_cos / best:11.2f} "
              f"{ref_c / best:9.2f}")
    c_min, p_min = min(times["compiled loop"]), min(times["Python loop"])
    print(f"compiled loop: {ref_cos / c_min:.1f}x libcosim (target >= 10), {c_min / ref_c:.2f}x the C loop's time "
          f"(target <= 2), {p_min / c_min:.1f}x faster than the Python loop (min); medians: "
          f"{statistics.median(times['libcosim']) / statistics.median(times['compiled loop']):.1f}x, "
          f"{statistics.median(times['compiled loop']) / statistics.median(times['C loop']):.2f}x")
    print(f"final rows of the compiled, Python and C loops identical: {same}; libcosim (Jacobi order) vs the "
          f"master's Jacobi run, largest final difference of the outputs without feedthrough ({len(states)}): "
          f"{diff:.2e}")
    return times


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5, help="interleaved repetitions (default: 5)")
    ap.add_argument("--scenarios", nargs="+", default=["mrp_200deg", "cubesat_detumble"],
                    help="shipped scenarios with native FMUs only (default: mrp_200deg cubesat_detumble)")
    ap.add_argument("--fmu-dir", type=Path, default=paths.fmu_cache(),
                    help="FMU folder, brought up to date first (default: the user's FMU cache, "
                         "satfmu.controllers.paths.fmu_cache())")
    args = ap.parse_args()
    fmu_dir = args.fmu_dir.resolve()
    catalog.build_all(fmu_dir)  # nothing to do when `satfmu build` ran on this tree
    print("closed loop co-simulation speed: compiled loop, Python loop, libcosim, bare C loop (same FMUs)")
    with tempfile.TemporaryDirectory(prefix="satfmu_cosim_speed_") as tmp:
        exe = c_loop_binary(Path(tmp))
        for name in args.scenarios:
            bench(name, fmu_dir, args.repeat, exe, Path(tmp))


if __name__ == "__main__":
    main()
