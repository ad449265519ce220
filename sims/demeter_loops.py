"""Seed 004 Figs 4-5: random closed loops of the DEMETER plant FMU and a design's controller FMU.

For ``n`` plants drawn uniformly in the design's parameter box, the plant FMU
(``demeter_flexible``, parameters from
:meth:`~synthesis.demeter_variants.DesignModel.fmu_parameters`) and the controller FMU of a
``linear_state_feedback`` artifact run through :class:`sims.master.CoSimulation`:

- Fig. 4: the impulse responses ``w2 -> z2``: an impulse on each column of w2 is the initial
  state ``theta(0) = 0.262 rad`` (column 1) or ``theta'(0) = 1.4e-3 rad/s`` (column 2), and z2 is
  the controller's pseudo-integrator ``xw`` (N m s);
- Fig. 5: theta and theta' from both initial values at once.

``limits="linear"`` sets the wheels' torque and momentum limits out of reach (1e9), which makes
the FMU loop the design model's linear loop (the seed's figures), up to the zero-order hold of
the command over each communication step (checked against the design model's exact
continuous solution, :attr:`RandomLoops.linear_error`); ``limits="wheels"`` keeps the plant's
limits (5e-3 N m, 0.12 N m s).

The communication step must be small: the Table 1 row-1 design feeds the wheel torque back with
a gain of 31 and puts a wheel mode at 71 rad/s, and the loop sampled with a held command is
unstable above about 1.5 ms (spectral radius 1.0074 at 5 ms). The default is 1 ms over 60 s
(the transient, where z2 peaks); :func:`linear` gives the design model's responses over the
whole horizon (the slowest pole is -3e-4 1/s) exactly, as the seed's figures do.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.linalg import expm

from controllers import artifact as artifacts
from sims import paths
from sims.master import CoSimulation
from synthesis.demeter_variants import RATE_WORST, THETA_WORST, DesignModel, Variant, design_model

MEASURED = ("theta", "theta_dot", "eta", "eta_dot", "wheel_torque", "wheel_torque_rate")
"""Plant outputs the controller reads (same names on both FMUs)."""
NO_LIMIT = 1e9
"""Torque (N m) and momentum (N m s) limits that no run reaches."""


@dataclass
class RandomLoops:
    """The responses of ``n`` sampled loops on a common time grid (s).

    ``z2[i, c]``: xw (N m s) of loop i after the impulse on w2 column c; ``theta``, ``theta_dot``
    (rad, rad/s) of loop i from both initial values; ``saturated[i]``: fraction of the time a
    wheel was at its momentum limit in that run; ``linear_error``: largest |theta - theta_linear| (rad)
    against the design model's exact solution (only meaningful with ``limits="linear"``).
    """

    time: np.ndarray
    deltas: np.ndarray
    z2: np.ndarray
    theta: np.ndarray
    theta_dot: np.ndarray
    saturated: np.ndarray
    linear_error: float
    limits: str
    axis: int
    source: str = "fmu"




def _free_response(dm: DesignModel, K: np.ndarray, delta: np.ndarray, X0: np.ndarray, t: np.ndarray) -> np.ndarray:
    """States of the design model's closed loop ``x' = (A + Bu K) x`` on the uniform grid t from
    each column of X0, exactly: shape (len(t), n, columns)."""
    A, Bu, _ = dm.state_space(delta)
    Phi = expm((A + Bu @ K) * (t[1] - t[0]))
    out, X = np.empty((len(t),) + X0.shape), X0.copy()
    for k in range(len(t)):
        out[k] = X
        X = Phi @ X
    return out


def load_design(artifact: str | Path) -> tuple[artifacts.GainArtifact, Variant]:
    """A DEMETER design artifact (a name such as ``"demeter_row1_det"``, looked up by
    :func:`sims.paths.find_artifact`, or a .json path) and its variant.

    Raises
    ------
    ValueError
        If the artifact is not a DEMETER state-feedback design: no valid ``design.variant``, or
        a ``design.K`` that is not a finite matrix of the variant's shape (inputs x states).
    """
    path = paths.find_artifact(artifact)
    art = artifacts.load(path)
    if not isinstance(art, artifacts.GainArtifact) or "variant" not in art.design:
        raise ValueError(f"{path}: not a DEMETER state-feedback design artifact (no design.variant)")
    try:
        variant = Variant.from_dict(art.design["variant"])
        K = np.array(art.design.get("K"), dtype=float)
    except (ValueError, TypeError) as exc:  # VariantError is a ValueError
        raise ValueError(f"{path}: design: {exc}") from None
    dm = design_model(variant)
    if K.shape != (dm.na, dm.n) or not np.all(np.isfinite(K)):
        raise ValueError(f"{path}: design.K: must be a finite {dm.na} x {dm.n} matrix (inputs x states of "
                         f"{variant.label}), got shape {K.shape}{'' if np.all(np.isfinite(K)) else ' with non-finite entries'}")
    return art, variant


def linear(artifact: str | Path, *, n: int = 100, seed: int = 0, stop_time: float = 10000.0, points: int = 2001
           ) -> RandomLoops:
    """The same loops as :func:`run` on the design model, exactly, over the whole horizon."""
    art, variant = load_design(artifact)
    dm, K = design_model(variant), np.array(art.design["K"])
    deltas = dm.sample(n, np.random.default_rng(seed))
    t = np.linspace(0.0, stop_time, points)
    X0 = np.column_stack([dm.B2[:, 0], dm.B2[:, dm.na], dm.B2[:, 0] + dm.B2[:, dm.na]])
    z2, theta, rate = [], [], []
    for d in deltas:
        x = _free_response(dm, K, d, X0, t)
        z2.append((dm.C2[0] @ x[:, :, :2]).T)
        theta.append(x[:, 0, 2])
        rate.append(x[:, dm.na, 2])
    return RandomLoops(t, deltas, np.array(z2), np.array(theta), np.array(rate), np.zeros(n), 0.0, "linear",
                       variant.axes[0], "design model")


def run(fmu_dir: Path, artifact: str | Path, *, n: int = 100, seed: int = 0, stop_time: float = 60.0,
        step_size: float = 1e-3, limits: str = "wheels") -> RandomLoops:
    """Run the 3 n co-simulations of Figs 4-5 (module docstring).

    Raises
    ------
    ValueError
        If the artifact is not a DEMETER state-feedback design or ``limits`` is unknown.
    """
    if limits not in ("linear", "wheels"):
        raise ValueError(f"limits must be 'linear' or 'wheels', got {limits!r}")
    art, variant = load_design(artifact)
    dm, K, axis = design_model(variant), np.array(art.design["K"]), variant.axes[0]
    deltas = dm.sample(n, np.random.default_rng(seed))
    starts = [{f"theta_0[{axis}]": THETA_WORST}, {f"theta_dot_0[{axis}]": RATE_WORST},
              {f"theta_0[{axis}]": THETA_WORST, f"theta_dot_0[{axis}]": RATE_WORST}]
    extra = {} if limits == "wheels" else {"wheel_torque_max": NO_LIMIT, "wheel_momentum_max": NO_LIMIT}
    record = [f"ctrl.xw[{axis}]", f"plant.theta[{axis}]", f"plant.theta_dot[{axis}]", f"plant.wheel_saturated[{axis}]"]
    x0 = dm.B2[:, 0] + dm.B2[:, dm.na]  # the two impulses of w2 at once
    z2, theta, rate, sat, err = [], [], [], [], 0.0
    with CoSimulation({"plant": fmu_dir / "demeter_flexible.fmu", "ctrl": fmu_dir / f"{art.name}.fmu"}) as sim:
        for name in MEASURED:
            sim.connect(f"plant.{name}", f"ctrl.{name}")
        sim.connect("ctrl.u_c", "plant.u_c")
        for d in deltas:
            base = {**dm.fmu_parameters(d), **extra}
            res = [sim.run(stop_time, step_size, parameters={"plant": {**base, **s}}, record=record) for s in starts]
            z2.append([r[f"ctrl.xw[{axis}]"] for r in res[:2]])
            theta.append(res[2][f"plant.theta[{axis}]"])
            rate.append(res[2][f"plant.theta_dot[{axis}]"])
            sat.append(float(np.mean(res[2][f"plant.wheel_saturated[{axis}]"] > 0.5)))
            exact = _free_response(dm, K, d, x0[:, None], res[2]["time"])[:, 0, 0]
            err = max(err, float(np.max(np.abs(theta[-1] - exact))))
        t = res[2]["time"]
    return RandomLoops(t, deltas, np.array(z2), np.array(theta), np.array(rate), np.array(sat), err, limits, axis)


def plot(loops: RandomLoops, out_dir: Path) -> list[Path]:
    """Fig. 4 (z2 after each impulse of w2) and Fig. 5 (theta, theta'), PNG files in ``out_dir``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out_dir.mkdir(parents=True, exist_ok=True)
    tag = "_design_model" if loops.source != "fmu" else "" if loops.limits == "wheels" else "_no_limits"
    fig4, ax = plt.subplots(1, 2, figsize=(10, 3.6), sharex=True)
    for c, label in enumerate(("theta(0) = 0.262 rad", "theta'(0) = 1.4e-3 rad/s")):
        ax[c].plot(loops.time, loops.z2[:, c].T, lw=0.6, color="tab:blue", alpha=0.5)
        ax[c].set(title=f"impulse w2 -> z2: {label}", xlabel="time (s)", ylabel="xw (N m s)")
        ax[c].grid(alpha=0.3)
    what = "design model, exact" if loops.source != "fmu" else \
        f"FMUs, step {loops.time[1] - loops.time[0]:g} s, {'wheel limits' if loops.limits == 'wheels' else 'no limits'}"
    fig4.suptitle(f"{len(loops.z2)} random closed loops ({what})")
    fig4.tight_layout()
    fig5, ax = plt.subplots(2, 1, figsize=(7, 5.5), sharex=True)
    ax[0].plot(loops.time, loops.theta.T, lw=0.6, color="tab:blue", alpha=0.5)
    ax[0].set(ylabel=f"theta[{loops.axis}] (rad)",
              title=f"from theta(0) = 0.262 rad, theta'(0) = 1.4e-3 rad/s ({what})")
    ax[1].plot(loops.time, loops.theta_dot.T, lw=0.6, color="tab:blue", alpha=0.5)
    ax[1].set(ylabel=f"theta'[{loops.axis}] (rad/s)", xlabel="time (s)")
    for a in ax:
        a.grid(alpha=0.3)
    fig5.tight_layout()
    paths = [out_dir / f"fig4{tag}.png", out_dir / f"fig5{tag}.png"]
    for fig, path in zip((fig4, fig5), paths):
        fig.savefig(path, dpi=120)
        plt.close(fig)
    return paths
