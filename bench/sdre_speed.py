"""Controller evaluation speed of the seed 002 VSCMG servo: online SDRE vs approximated SDRE.

The seed approximates the SDRE gain by polynomials in (q2, w4) because solving a
Riccati equation at every control instant is slow; this measures by how much. All
evaluations use the same ``--points`` random plant states x = [q1, q2, q4, w1, w2, w4]
(q2 uniform in [0.15, 1.25] rad and w4 in [-0.6, 0.6] rad/s, the fit's region; w1, w2
normal with 0.1 rad/s deviation; references q + normal 0.05 rad; fixed ``--seed``):

- online SDRE in process: :meth:`satfmu.synthesis.servo.sdre.Servo.gain` (Ae, Be, then the checked
  :func:`satfmu.controllers.riccati.riccati_gain`), the shipped ``gyro_on_w2`` law and the
  ``w1_free`` law at w2 = 0 that the approximation fits;
- approximated SDRE in process: :meth:`satfmu.controllers.artifact.ServoArtifact.gain_at` of the
  shipped ``vscmg_sdre_approx.json`` (the artifact's reference evaluator, numpy over every
  term), one call per point and one vectorized call over all points (batch);
- the generated controller code (:func:`satfmu.fmus.codegen.load_python`): the approximated
  servo's ``outputs`` (the command T = -K xe) and the online servo's sample path,
  ``sample_arguments`` then :func:`satfmu.controllers.riccati.sampled_gain`, as the pythonfmu
  FMUs call them (held values follow the parameters in ``p``);
- the FMUs through fmpy: the native approximated servo FMU and the online SDRE FMUs, native
  (the C Riccati routine, ``fmus/c/riccati.h``) and pythonfmu (scipy), ``--steps`` steps of
  0.01 s of fmi2SetReal(inputs) + fmi2GetReal(T1, T2) + fmi2DoStep, preallocated buffers as in
  :class:`satfmu.sims.cosim.master.CoSimulation`. In this order the online FMU solves one Riccati equation
  per step (the gain of the instant, with that instant's inputs); reading the outputs after
  fmi2DoStep and before setting the new inputs would make it solve a second time per step,
  with the stale inputs;
- the closed loops: the shipped scenarios ``vscmg_seed`` and ``vscmg_seed_friction`` run with
  native FMUs, the two online SDRE controllers native, then pythonfmu; the largest difference of
  the online SDRE loops' plant
  states (q2, q4, rad) and commands (T1, T2, N m) between the two, and each run's wall time.

Each timing is the best of ``--repeat`` runs, in this one process, reported as
evaluations/s, microseconds per evaluation and speed-up over the in-process online SDRE
(the machine is shared and noisy: ratios measured together hold, absolute numbers
drift). Also prints the approximation's largest gain error over the points (relative to
the largest gain entry, as :mod:`satfmu.synthesis.servo.gain_fit`) and how closely the generated code
reproduces the in-process laws.

    python bench/sdre_speed.py [--points 2000] [--steps 1500] [--repeat 3] [--seed 2] [--fmu-dir build/fmus]
"""
from __future__ import annotations

import argparse
import ctypes
import shutil
import tempfile
from pathlib import Path

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave, fmi2True

from timing import best_of

from satfmu.controllers import artifact, riccati, servo
from satfmu.fmus import codegen, export
from satfmu.fmus.model import Model
from satfmu.synthesis.servo.sdre import Servo

STEP = 0.01
ARTIFACT = Path(__file__).resolve().parents[1] / "controllers" / "artifacts" / "vscmg_sdre_approx.json"


def sample_states(n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Random plant states (n, 6) and references [q2_ref, q4_ref] (n, 2)."""
    rng = np.random.default_rng(seed)
    x = np.column_stack([rng.uniform(-np.pi, np.pi, n), rng.uniform(0.15, 1.25, n), rng.uniform(-1.0, 1.0, n),
                         rng.normal(0.0, 0.1, n), rng.normal(0.0, 0.1, n), rng.uniform(-0.6, 0.6, n)])
    return x, x[:, [1, 2]] + rng.normal(0.0, 0.05, (n, 2))


def controller_inputs(model: Model, x: np.ndarray, ref: np.ndarray) -> list[list[float]]:
    """Rows of the servo model's inputs (in ``model.inputs`` order) at the states ``x``."""
    cols = {"q2": x[:, 1], "q4": x[:, 2], "q2_ref": ref[:, 0], "q4_ref": ref[:, 1],
            "w1": x[:, 3], "w2": x[:, 4], "w4": x[:, 5]}
    return np.column_stack([cols[v.name] for v in model.inputs]).tolist()



def fmu_steps(path: Path, inputs: list[list[float]], input_names: list[str], repeat: int) -> float:
    """Best time (s) of ``len(inputs)`` steps (set inputs, get T1 and T2, do step) of the FMU ``path``."""
    md = read_model_description(str(path))
    unzip = extract(str(path))
    try:
        refs = {v.name: v.valueReference for v in md.modelVariables}
        slave = FMU2Slave(guid=md.guid, unzipDirectory=unzip, modelIdentifier=md.coSimulation.modelIdentifier,
                          instanceName=path.stem)
        slave.instantiate()
        try:
            slave.setupExperiment(startTime=0.0)
            slave.enterInitializationMode()
            slave.exitInitializationMode()
            n_in = len(input_names)
            in_vr = (ctypes.c_uint * n_in)(*[refs[n] for n in input_names])
            in_buf = (ctypes.c_double * n_in)()
            out_vr = (ctypes.c_uint * 2)(refs["T1"], refs["T2"])
            out_buf = (ctypes.c_double * 2)()
            blocks = iter((STEP * np.arange(repeat * len(inputs))).reshape(repeat, -1).tolist())

            def run() -> None:
                for t, row in zip(next(blocks), inputs):
                    in_buf[:] = row
                    slave.fmi2SetReal(slave.component, in_vr, n_in, in_buf)
                    slave.fmi2GetReal(slave.component, out_vr, 2, out_buf)
                    slave.fmi2DoStep(slave.component, t, STEP, fmi2True)

            dt, _ = best_of(run, repeat)
            slave.terminate()
        finally:
            slave.freeInstance()
    finally:
        shutil.rmtree(unzip, ignore_errors=True)
    return dt


ONLINE_LOOPS = {"online": "online_plant", "online_w1free": "online_w1free_plant"}
"""The online SDRE instances of the vscmg_seed scenarios and their plants."""


def closed_loops(fmu_dir: Path | None) -> None:
    """Run ``vscmg_seed`` and ``vscmg_seed_friction`` with native and pythonfmu FMUs; print the
    largest native - pythonfmu difference of the online loops and each run's wall time."""
    import copy
    import time

    from satfmu.sims.scenario.run import run as run_scenario
    from satfmu.sims.scenario.spec import load

    print("closed loops (native online SDRE FMUs vs pythonfmu ones, every communication point of 0.01 s):")
    for name in ("vscmg_seed", "vscmg_seed_friction"):
        runs, walls = {}, {}
        for backend in ("native", "python"):  # only the online controllers change backend
            data = copy.deepcopy(load(name).data)
            for ctrl in ONLINE_LOOPS:
                data["fmus"][ctrl]["backend"] = backend
            t0 = time.perf_counter()
            runs[backend] = run_scenario(data, fmu_dir).results
            walls[backend] = time.perf_counter() - t0
        a, b = runs["native"], runs["python"]
        for ctrl, plant in ONLINE_LOOPS.items():
            dq = max(float(np.max(np.abs(a[f"{plant}.{q}"] - b[f"{plant}.{q}"]))) for q in ("q2", "q4"))
            dt = max(float(np.max(np.abs(a[f"{ctrl}.{c}"] - b[f"{ctrl}.{c}"]))) for c in ("T1", "T2"))
            print(f"  {name:20s} {ctrl:14s} largest |q native - q python| {dq:.2e} rad, |T| {dt:.2e} N m")
        print(f"  {name:20s} whole scenario (5 loops, {len(a)} points): native online SDRE {walls['native']:.2f} s, "
              f"pythonfmu online SDRE {walls['python']:.2f} s ({walls['python'] / walls['native']:.1f}x)")


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=2000, help="plant states evaluated in process")
    ap.add_argument("--steps", type=int, default=1500, help="FMU steps of 0.01 s (at most --points)")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--seed", type=int, default=2)
    ap.add_argument("--fmu-dir", type=Path, default=None, help="FMU folder of the closed loops (default: the cache)")
    args = ap.parse_args(argv)
    if not 0 < args.steps <= args.points:
        ap.error("--steps must be between 1 and --points")
    x, ref = sample_states(args.points, args.seed)
    art = artifact.load(ARTIFACT)
    sched = art.scheduling_values({"q2": x[:, 1], "w4": x[:, 5]})
    approx, online = servo.build(art), servo.build_online()
    gen_approx, gen_online = codegen.load_python(approx), codegen.load_python(online)
    u_approx, u_online = controller_inputs(approx, x, ref), controller_inputs(online, x, ref)
    p_approx = approx.parameter_vector().tolist()
    p_online = online.parameter_vector().tolist() + [0.0] * len(online.sampler.held)  # held values follow
    n_xe, n_u = online.sampler.options["n"], online.sampler.options["m"]  # sampled_gain: K, then two checks

    timings: dict[str, float] = {}
    n = args.points
    gyro, w1_free = Servo("gyro_on_w2"), Servo("w1_free", freeze_w2=True)
    timings["online SDRE gyro_on_w2, Servo.gain"], k_gyro = best_of(lambda: [gyro.gain(s)[0] for s in x], args.repeat)
    timings["online SDRE w1_free w2:=0, Servo.gain"], k_free = best_of(lambda: [w1_free.gain(s)[0] for s in x],
                                                                     args.repeat)
    timings["approx. SDRE, gain_at per point"], k_fit = best_of(lambda: [art.gain_at(s) for s in sched], args.repeat)
    timings["approx. SDRE, gain_at batch"], _ = best_of(lambda: art.gain_at(sched), args.repeat)
    timings["generated online sample path"], k_gen = best_of(
        lambda: [riccati.sampled_gain(gen_online.sample_arguments(0.0, [0.0, 0.0], u, p_online), n_xe, n_u)[:n_xe * n_u]
                 for u in u_online], args.repeat)
    timings["generated approx. outputs"], y_gen = best_of(
        lambda: [gen_approx.outputs(0.0, [0.0, 0.0], u, p_approx) for u in u_approx], args.repeat)

    with tempfile.TemporaryDirectory(prefix="sdre_speed_") as tmp:
        native = export.build_native(approx, Path(tmp), artifact.resource(art))
        online_native = export.build_native(online, Path(tmp))
        python = export.build_python(online, Path(tmp))
        rows = u_approx[:args.steps]
        online_names = [v.name for v in online.inputs]
        fmu = {"native FMU approx., fmpy step": fmu_steps(native, rows, [v.name for v in approx.inputs], args.repeat),
               "native FMU online, fmpy step": fmu_steps(online_native, u_online[:args.steps], online_names,
                                                         args.repeat),
               "pythonfmu FMU online, fmpy step": fmu_steps(python, u_online[:args.steps], online_names,
                                                            args.repeat)}

    base = timings["online SDRE gyro_on_w2, Servo.gain"] / n
    print(f"seed 002 VSCMG servo, {n} plant states (best of {args.repeat}); "
          f"FMUs: {args.steps} steps of {STEP} s, one gain per step")
    print(f"{'method':40s} {'evals/s':>10s} {'us/eval':>10s} {'x online':>10s}")
    for label, dt, count in ([(k, v, n) for k, v in timings.items()] + [(k, v, args.steps) for k, v in fmu.items()]):
        print(f"{label:40s} {count / dt:10.0f} {1e6 * dt / count:10.2f} {base / (dt / count):10.2f}")
    native_s, online_s, python_s = fmu.values()
    print(f"FMU steps: native approximated servo is {python_s / native_s:.1f}x the pythonfmu online SDRE; "
          f"native online SDRE is {python_s / online_s:.1f}x the pythonfmu online SDRE")
    closed_loops(args.fmu_dir)

    k_free, k_fit = np.array(k_free), np.array(k_fit)
    print(f"approximation: largest |K_approx - K_w1free| / largest |K_w1free| = "
          f"{np.max(np.abs(k_fit - k_free)) / np.max(np.abs(k_free)):.2e}")
    k_gyro = np.array(k_gyro)
    xe = np.column_stack([np.zeros((n, 2)), ref - x[:, [1, 2]], x[:, 3:6]])
    t_fit = -np.einsum("nij,nj->ni", k_fit, xe)
    print(f"generated vs in process, largest difference relative to the largest entry: online gain "
          f"{np.max(np.abs(np.array(k_gen) - k_gyro.reshape(n, -1))) / np.max(np.abs(k_gyro)):.1e}, "
          f"approx. command {np.max(np.abs(np.array(y_gen)[:, :2] - t_fit)) / np.max(np.abs(t_fit)):.1e}")


if __name__ == "__main__":
    main()
