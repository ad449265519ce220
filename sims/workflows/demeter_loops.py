"""Seed 004 Figs 4-5: random closed loops of the DEMETER plant FMU and a design's controller FMU.

:func:`scenario` declares the loop as a scenario: the plant FMU (``demeter_flexible``, its
start values from :meth:`~satfmu.synthesis.robust.demeter_variants.DesignModel.fmu_parameters` at the
nominal parameters) and the controller FMU of a ``linear_state_feedback`` artifact, with the
design's uncertain parameters as ``[dispersions]`` (each uniform in its interval; a
principal inertia as the square of its uniform root, as the design model draws it), and a
metric bounding the pseudo-integrator's peak by the artifact's certified impulse-to-peak
bound. :func:`run` runs it as three scenario campaigns (:mod:`satfmu.sims.campaign.scenario_task`: the
FMUs through the compiled loop, on Dask, one Parquet file per chunk) and keeps every sample's
time histories:

- Fig. 4: the impulse responses ``w2 -> z2``: an impulse on each column of w2 is the initial
  state ``theta(0) = 0.262 rad`` (column 1) or ``theta'(0) = 1.4e-3 rad/s`` (column 2), and z2 is
  the controller's pseudo-integrator ``xw`` (N m s);
- Fig. 5: theta and theta' from both initial values at once.

``limits="linear"`` sets the wheels' torque and momentum limits out of reach (1e9), which makes
the FMU loop the design model's linear loop (the seed's figures), up to the zero-order hold of
the command over each communication step (checked against the design model's exact
continuous solution, ``linear_error`` of :class:`RandomLoops`); ``limits="wheels"`` keeps the plant's
limits (5e-3 N m, 0.12 N m s).

The communication step must be small: the Table 1 row-1 design feeds the wheel torque back with
a gain of 31 and puts a wheel mode at 71 rad/s, and the loop sampled with a held command is
unstable above about 1.5 ms (spectral radius 1.0074 at 5 ms). The default is 1 ms over 60 s
(the transient, where z2 peaks); :func:`linear` gives the design model's responses over the
whole horizon (the slowest pole is -3e-4 1/s) exactly, as the seed's figures do.

The shipped scenarios ``demeter_row1_det_both``, ``_theta`` and ``_rate`` (sims/scenario/shipped/) are
:func:`scenario` of the row-1 design with the wheel limits, one per start, written by
:func:`write_shipped` (``python -m satfmu.sims.workflows.demeter_loops``); ``satfmu run``, ``verify`` and
``export-ssp`` take them by name.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from scipy.linalg import expm

from satfmu.controllers import artifact as artifacts
from satfmu.fmus.atomic import write_atomically
from satfmu.fmus.declared import toml_text
from satfmu.fmus.plants import demeter
from satfmu.sims.campaign import envelopes
from satfmu.controllers import paths
from satfmu.sims.scenario import SHIPPED_SCENARIOS
from satfmu.sims.scenario.spec import Scenario
from satfmu.sims.scenario.wiring import recorded_times
from satfmu.synthesis.robust.demeter_variants import (RATE_WORST, THETA_WORST, DesignModel, UncertainParameter, Variant,
                                        design_model)

if TYPE_CHECKING:
    import pandas as pd

MEASURED = ("theta", "theta_dot", "eta", "eta_dot", "wheel_torque", "wheel_torque_rate")
"""Plant outputs the controller reads (same names on both FMUs)."""
NO_LIMIT = 1e9
"""Torque (N m) and momentum (N m s) limits that no run reaches."""


@dataclass
class RandomLoops:
    """The responses of ``n`` sampled loops on a common time grid (s).

    ``z2[i, c]``: xw (N m s) of loop i after the impulse on w2 column c; ``theta``, ``theta_dot``
    (rad, rad/s) of loop i from both initial values; ``saturated[i]``: fraction of the time a
    wheel was at its momentum limit in that run; ``linear_error``: largest ``|theta - theta_linear|`` (rad)
    against the design model's exact solution (only meaningful with ``limits="linear"``).

    Parameters
    ----------
    time : numpy.ndarray, shape (m,)
        The common time grid (s).
    deltas : numpy.ndarray, shape (n, p)
        The design model's parameter vector delta (in [-1, 1]) of each loop's plant.
    z2 : numpy.ndarray, shape (n, 2, m)
        ``z2[i, c]``: the pseudo-integrator xw (N m s) of loop i after the impulse on w2 column c
        (c = 0: theta(0), c = 1: theta'(0)).
    theta : numpy.ndarray, shape (n, m)
        Attitude angle of the design axis (rad) of each loop, from both initial values.
    theta_dot : numpy.ndarray, shape (n, m)
        Its rate (rad/s).
    saturated : numpy.ndarray, shape (n,)
        Fraction of the run (0 to 1) a wheel of each loop was at its momentum limit (zero for the
        design model).
    linear_error : float
        Largest ``|theta - theta_linear|`` over loops and time (rad); 0 for the design model.
    limits : {"wheels", "linear"}
        The plant's wheel limits, or none (``"linear"``).
    axis : int
        The design axis (1, 2 or 3, as the FMU variables index it).
    source : str, optional
        ``"fmu"`` (the FMU loops, :func:`run`) or ``"design model"`` (:func:`linear`).
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
    :func:`satfmu.controllers.paths.find_artifact`, or a .json path) and its variant.

    Raises
    ------
    ValueError
        If the artifact is not a DEMETER state-feedback design: no valid ``design.variant``, or
        a ``design.K`` that is not a finite matrix of the variant's shape (inputs x states).

    Parameters
    ----------
    artifact : str or Path
        Artifact name (:func:`satfmu.controllers.paths.find_artifact`) or ``.json`` path.

    Returns
    -------
    (satfmu.controllers.artifact.GainArtifact, satfmu.synthesis.robust.demeter_variants.Variant)
        The artifact and the design variant of its ``design.variant``.
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
                         f"{variant.label}), got shape {K.shape}"
                         f"{'' if np.all(np.isfinite(K)) else ' with non-finite entries'}")
    return art, variant


def linear(artifact: str | Path, *, n: int = 100, seed: int = 0, stop_time: float = 10000.0, points: int = 2001,
           deltas: np.ndarray | None = None) -> RandomLoops:
    """Loops as :func:`run`'s on the design model, exactly, over the whole horizon: the plants
    ``deltas`` (e.g. the ``deltas`` of a run's :class:`RandomLoops`), else ``n`` drawn with ``seed``.

    Parameters
    ----------
    artifact : str or Path
        DEMETER design artifact: name (:func:`satfmu.controllers.paths.find_artifact`) or ``.json`` path.
    n : int, optional
        Plants to draw (uniform in the parameter box) when ``deltas`` is not given.
    seed : int, optional
        Seed of that draw.
    stop_time : float, optional
        Horizon (s).
    points : int, optional
        Points of the uniform time grid, 0 and ``stop_time`` included.
    deltas : numpy.ndarray, shape (n, p), optional
        The plants: the design model's parameter vectors delta (in [-1, 1]); overrides ``n``
        and ``seed``.

    Returns
    -------
    RandomLoops
        With ``source="design model"``, ``limits="linear"`` and no saturation.
    """
    art, variant = load_design(artifact)
    dm, K = design_model(variant), np.array(art.design["K"])
    deltas = dm.sample(n, np.random.default_rng(seed)) if deltas is None else np.atleast_2d(np.asarray(deltas, float))
    n = len(deltas)
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


STARTS = {"theta": (True, False), "rate": (False, True), "both": (True, True)}
"""Initial state of each run: (theta(0) = 0.262 rad, theta'(0) = 1.4e-3 rad/s) on the design axis."""
CAMPAIGN = {"samples": 100, "demo_samples": 10, "seed": 0}
"""The ``[campaign]`` table of :func:`scenario`: the seed's 100 random loops of Figs 4-5, the
plants that :func:`run` draws with its defaults (``satfmu figures demeter``)."""
SHIPPED = "demeter_row1_det"
"""The design of the shipped scenarios (:func:`write_shipped`): Table 1 row 2 (Det, axis 1, appendage 1)."""


def scenario(artifact: str | Path = "demeter_row1_det", *, start: str = "both", limits: str = "wheels",
             stop_time: float = 60.0, step_size: float = 1e-3) -> Scenario:
    """The closed loop of a DEMETER design on the flexible plant FMU, as a dispersed scenario.

    Parameters
    ----------
    artifact : str or Path
        DEMETER design artifact: name (:func:`satfmu.controllers.paths.find_artifact`) or ``.json`` path.
    start : {"theta", "rate", "both"}
        Initial state (:data:`STARTS`): one column of w2 (Fig. 4) or both (Fig. 5).
    limits : {"wheels", "linear"}
        The plant's wheel limits, or none (module docstring).
    stop_time, step_size : float
        s.

    Returns
    -------
    Scenario
        Named ``<artifact>_<start>`` (``_linear`` without limits); records ``xw``, ``theta``,
        ``theta_dot``, the wheel momentum ``h_w`` and ``wheel_saturated`` of the design axis;
        metrics, each a gate: peak ``|xw|`` <= the certified impulse-to-peak bound times
        ``|w2|`` (1 or sqrt 2), ``|theta|`` at the end <= theta(0) of the worst case (0.262 rad),
        peak ``|h_w|`` <= the wheels' momentum limit (0.12 N m s, also without limits), no time
        at that limit; the ``[campaign]`` table :data:`CAMPAIGN`.

    Raises
    ------
    ValueError
        Not a DEMETER state-feedback design; ``start`` or ``limits`` unknown; a mode group of
        several appendages (one draw for several FMU parameters: not a scenario dispersion).
    """
    if start not in STARTS:
        raise ValueError(f"start must be one of {', '.join(STARTS)}, got {start!r}")
    if limits not in ("linear", "wheels"):
        raise ValueError(f"limits must be 'linear' or 'wheels', got {limits!r}")
    art, variant = load_design(artifact)
    dm, axis = design_model(variant), variant.axes[0]
    momentum_limit = variant.spacecraft.wheels.momentum_limit
    plant = {k: v for k, v in dm.fmu_parameters(np.zeros(len(dm.parameters))).items()}
    on_theta, on_rate = STARTS[start]
    plant.update({f"theta_0[{axis}]": THETA_WORST if on_theta else 0.0,
                  f"theta_dot_0[{axis}]": RATE_WORST if on_rate else 0.0})
    if limits == "linear":
        plant.update(wheel_torque_max=NO_LIMIT, wheel_momentum_max=NO_LIMIT)
    dispersions = {}
    for p in dm.parameters:
        spec = {"kind": "uniform", "low": p.nominal - p.half_width, "high": p.nominal + p.half_width}
        dispersions[fmu_parameter(p, dm, variant)] = {**spec, **({"transform": "square"} if p.kind == "sqrtJ" else {})}
    bound = float(art.certificate["numbers"]["design_i2p_bound"]) * math.hypot(float(on_theta), float(on_rate))
    xw, theta, h_w = f"ctrl.xw[{axis}]", f"plant.theta[{axis}]", f"plant.h_w[{axis}]"
    name = f"{art.name}_{start}{'_linear' if limits == 'linear' else ''}"
    return Scenario.from_dict({
        "name": name, "stop_time": stop_time, "step_size": step_size,
        "description": f"Seed 004 Fig. {5 if start == 'both' else 4}: {art.name} on the flexible plant "
                       f"({'wheel limits' if limits == 'wheels' else 'no limits'}), start {start}, random plants in "
                       "the design's parameter box",
        "reference": "docs/models.md, Seed 004; the artifact's certificate (impulse-to-peak bound w2 -> z2)",
        "record": [xw, theta, f"plant.theta_dot[{axis}]", h_w, f"plant.wheel_saturated[{axis}]"],
        "fmus": {"plant": {"model": demeter.model_name(variant.spacecraft), "parameters": plant},
                 "ctrl": {"model": art.name}},
        "connections": [{"from": f"plant.{m}", "to": f"ctrl.{m}"} for m in MEASURED]
        + [{"from": "ctrl.u_c", "to": "plant.u_c"}],
        "metrics": [
            {"name": "peak |z2| = |xw|", "kind": "peak", "signals": [xw], "unit": "N.m.s", "max": bound,
             "description": "the certified impulse-to-peak bound w2 -> z2 times |w2| (certified for the linear "
                            "loop; with the wheel limits a check)"},
            {"name": "|theta| at the end", "kind": "final", "signals": [theta], "unit": "rad", "max": THETA_WORST,
             "description": "within the worst-case initial attitude error (the loop converges slowly: slowest "
                            "pole -3e-4 1/s; a held command above ~1.5 ms diverges)"},
            {"name": "peak wheel momentum", "kind": "peak", "signals": [h_w], "unit": "N.m.s",
             "max": momentum_limit, "description": "below the wheels' momentum limit satW (the seed: momentum "
                                                   "saturation is critical)"},
            {"name": "time at the momentum limit", "kind": "time_in_saturation",
             "signals": [f"plant.wheel_saturated[{axis}]"], "limit": 0.5, "max": 0.0}],
        "dispersions": dispersions, "campaign": dict(CAMPAIGN)})


SHIPPED_NOTE = """\
Generated by `python -m satfmu.sims.workflows.demeter_loops` from
satfmu.sims.workflows.demeter_loops.scenario("{artifact}", start="{start}"): edit that function (or the artifact)
and run the command again, not this file; tests/test_demeter_loops.py checks that the two are the
same scenario.
Seed 004 Fig. {fig} from {what}.
Table 1 row 2 (Det, axis 1, appendage 1) on the flexible plant with the wheel limits (5e-3 N m,
0.12 N m s). `satfmu run` runs the nominal plant of the design; `satfmu campaign scenario` draws
the design's parameter box ([dispersions]).
Horizon 60 s at 1 ms: the peak of xw (z2) comes at 11-48 s for plants of the box (40 samples of
each start measured; nominal plant: 15.6, 23.1, 18.5 s from starts both, theta, rate), so a
shorter run would cut the transient of Fig. 4. The step stays 1 ms: the loop with the command
held over the step is unstable above ~1.5 ms (sims/workflows/demeter_loops.py). theta converges over ~1e4 s
(slowest pole -3e-4 1/s): at 60 s it is still near theta(0), and the end gate bounds it by the
worst-case initial error."""
FIGURES = {"both": (5, "theta(0) = 0.262 rad and theta'(0) = 1.4e-3 rad/s"),
           "theta": (4, "impulse on w2 column 1: theta(0) = 0.262 rad"),
           "rate": (4, "impulse on w2 column 2: theta'(0) = 1.4e-3 rad/s")}
"""Figure and initial state of each start, for the header of a shipped scenario file."""


def shipped_scenario(start: str) -> Scenario:
    """:func:`scenario` of the shipped artifact :data:`SHIPPED` (its file in
    :data:`satfmu.controllers.paths.SHIPPED_ARTIFACTS`, not a user's of that name) with the wheel limits.

    Parameters
    ----------
    start : {"theta", "rate", "both"}
        Initial state (:data:`STARTS`).
    """
    return scenario(paths.SHIPPED_ARTIFACTS / f"{SHIPPED}.json", start=start)


def scenario_text(start: str) -> str:
    """The shipped TOML file of :func:`shipped_scenario`: a header saying how it was produced,
    then the declaration (:func:`satfmu.fmus.declared.toml_text`).

    Parameters
    ----------
    start : {"theta", "rate", "both"}
        Initial state (:data:`STARTS`); also picks the header's figure (:data:`FIGURES`).
    """
    fig, what = FIGURES[start]
    note = SHIPPED_NOTE.format(artifact=SHIPPED, start=start, fig=fig, what=what)
    return toml_text(shipped_scenario(start).to_dict(), note)


def write_shipped(folder: Path = SHIPPED_SCENARIOS) -> list[Path]:
    """Write the shipped scenario files, one per start (``<name>.toml``: ``demeter_row1_det_both``,
    ``_theta``, ``_rate``); returns their paths.

    Parameters
    ----------
    folder : Path, optional
        Where to write them; default the shipped scenarios' folder
        (:data:`satfmu.sims.scenario.SHIPPED_SCENARIOS`).
    """
    out = []
    for start in STARTS:
        path = Path(folder) / f"{shipped_scenario(start).name}.toml"
        text = scenario_text(start)
        out.append(write_atomically(path, lambda tmp: tmp.write_text(text)))
    return out


def uniform_points(n_rows: int, points: int) -> int:
    """The largest count <= ``points`` of evenly spaced rows out of ``n_rows`` (first and last
    included) that fall on whole rows: a uniform grid, as the exact design-model solution needs.

    Parameters
    ----------
    n_rows : int
        Rows recorded (communication points of the run, the first and last included).
    points : int
        The most points wanted, at least 2.

    Raises
    ------
    ValueError
        If ``points`` < 2.
    """
    if points < 2:
        raise ValueError(f"points must be >= 2, got {points}")
    return next(m + 1 for m in range(min(points, n_rows) - 1, 0, -1) if (n_rows - 1) % m == 0)


def fmu_parameter(p: UncertainParameter, dm: DesignModel, variant: Variant) -> str:
    """The plant FMU parameter (``"plant.J[1,1]"``, ``"plant.omega[1]"``) that an uncertain parameter
    of the design model sets: a principal inertia (the square of ``p``'s value for ``sqrtJ``), a
    product of inertia, or the damping or frequency of the spacecraft's mode group it covers.

    Parameters
    ----------
    p : satfmu.synthesis.robust.demeter_variants.UncertainParameter
        One of the design model's uncertain parameters (``dm.parameters``).
    dm : satfmu.synthesis.robust.demeter_variants.DesignModel
        The design model of ``variant``.
    variant : satfmu.synthesis.robust.demeter_variants.Variant
        The design variant: its axes number the FMU's inertia entries.

    Raises
    ------
    ValueError
        A design group covering several of the plant's mode groups (one value for several FMU
        parameters).
    """
    if p.kind in ("sqrtJ", "Jprod"):
        i, j = sorted(variant.axes[k] for k in (p.index * 2)[:2])
        return f"plant.J[{i},{j}]"
    members = dm.members[p.index[0]]
    if len(members) != 1:
        raise ValueError(f"{variant.label}: {p.name} is shared by the plant's mode groups {[g + 1 for g in members]} "
                         f"(appendages {sorted({variant.spacecraft.groups[g].appendage + 1 for g in members})}); "
                         "a scenario dispersion draws one value per FMU parameter")
    return f"plant.{p.kind}[{members[0] + 1}]"


def deltas_of(rows: "pd.DataFrame", dm: DesignModel, variant: Variant) -> np.ndarray:
    """The design model's parameter vectors delta (in [-1, 1]) of a campaign's dispersed values.

    Parameters
    ----------
    rows : pandas.DataFrame
        A scenario campaign's results of :func:`scenario`, one row per sample, with a column per
        dispersed FMU parameter (:func:`fmu_parameter`), in the FMU's units.
    dm : satfmu.synthesis.robust.demeter_variants.DesignModel
        The design model of ``variant``.
    variant : satfmu.synthesis.robust.demeter_variants.Variant
        The design variant.

    Returns
    -------
    numpy.ndarray, shape (len(rows), p)
        One delta per row, p the design model's number of uncertain parameters.
    """
    out = np.empty((len(rows), len(dm.parameters)))
    for k, p in enumerate(dm.parameters):
        v = rows[fmu_parameter(p, dm, variant)].to_numpy()
        out[:, k] = ((np.sqrt(v) if p.kind == "sqrtJ" else v) - p.nominal) / p.half_width
    return out


def run(fmu_dir: Path, artifact: str | Path, *, n: int = 100, seed: int = 0, stop_time: float = 60.0,
        step_size: float = 1e-3, limits: str = "wheels", points: int = 2001, out_dir: Path | None = None,
        workers: int = 2, client: Any = None) -> RandomLoops:
    """Run the 3 n co-simulations of Figs 4-5 as three scenario campaigns (module docstring).

    Parameters
    ----------
    fmu_dir : Path
        Folder of the FMUs (the missing ones are built).
    artifact : str or Path
        DEMETER design artifact.
    n, seed : int
        Samples (random plants, the same in the three campaigns) and campaign seed.
    stop_time, step_size : float
        s.
    limits : {"wheels", "linear"}
        The plant's wheel limits, or none (module docstring).
    points : int
        Time points kept of each history (at most the run's communication points).
    out_dir : Path, optional
        Folder of the campaign folders (kept, resumable); default a temporary folder.
    workers : int
        Local Dask workers (without ``client``).
    client : distributed.Client, optional
        A Dask client to use instead of a local cluster.

    Raises
    ------
    ValueError
        If the artifact is not a DEMETER state-feedback design or ``limits`` is unknown.
    """
    import tempfile

    from satfmu.sims.campaign import cluster, engine
    from satfmu.sims.campaign.scenario_task import campaign

    art, variant = load_design(artifact)
    dm, K, axis = design_model(variant), np.array(art.design["K"]), variant.axes[0]
    scenarios = {start: scenario(artifact, start=start, limits=limits, stop_time=stop_time, step_size=step_size)
                 for start in STARTS}
    points = uniform_points(len(recorded_times(scenarios["both"])), points)
    keep = {"theta": [f"ctrl.xw[{axis}]"], "rate": [f"ctrl.xw[{axis}]"],
            "both": [f"plant.theta[{axis}]", f"plant.theta_dot[{axis}]", f"plant.wheel_saturated[{axis}]"]}
    with tempfile.TemporaryDirectory(prefix="satfmu_demeter_") as tmp, \
            cluster.cluster_client(None, client, workers) as active:
        rows, tasks = {}, {}
        for start, sc in scenarios.items():
            camp = campaign(sc, n, seed=seed, chunk=max(1, -(-n // (4 * workers))), fmu_dir=fmu_dir,
                            envelopes=keep[start], points=points)
            rows[start], tasks[start] = engine.run(camp, Path(out_dir or tmp), client=active), camp.task
    failed = {start: r.loc[r["failed"] > 0, "sample"].tolist() for start, r in rows.items()}
    if any(failed.values()):
        raise RuntimeError(f"DEMETER loops that did not run (sample indices): {failed}")
    steps = tasks["both"].trace_steps
    t = recorded_times(scenarios["both"])[list(steps)]

    def traces(start: str, signal: str) -> np.ndarray:
        return rows[start][envelopes.trace_columns(signal, len(steps))].to_numpy()

    deltas = deltas_of(rows["both"], dm, variant)
    theta = traces("both", f"plant.theta[{axis}]")
    sat = traces("both", f"plant.wheel_saturated[{axis}]")
    x0 = dm.B2[:, 0] + dm.B2[:, dm.na]  # the two impulses of w2 at once
    err = max(float(np.max(np.abs(th - _free_response(dm, K, d, x0[:, None], t)[:, 0, 0])))
              for d, th in zip(deltas, theta))
    z2 = np.stack([traces("theta", f"ctrl.xw[{axis}]"), traces("rate", f"ctrl.xw[{axis}]")], axis=1)
    return RandomLoops(t, deltas, z2, theta, traces("both", f"plant.theta_dot[{axis}]"),
                       np.mean(sat > 0.5, axis=1), err, limits, axis)


def plot(loops: RandomLoops, out_dir: Path) -> list[Path]:
    """Fig. 4 (z2 after each impulse of w2) and Fig. 5 (theta, theta'), PNG files in ``out_dir``.

    Parameters
    ----------
    loops : RandomLoops
        The loops of :func:`run` or :func:`linear`.
    out_dir : Path
        Folder of the files (created); the names tell the source: ``fig4.png``, ``fig5.png``
        (FMUs, wheel limits), ``_no_limits`` or ``_design_model`` appended otherwise.

    Returns
    -------
    list of Path
        The Fig. 4 and Fig. 5 files.
    """
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


if __name__ == "__main__":
    for written in write_shipped():
        print(written)
