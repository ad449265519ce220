"""Seed 003's detumbling campaigns: the linear sampled model (Fig. 2) and the nonlinear plant sweep.

- :func:`linear_campaign`: the seed's own setting. The discrete periodic rate model with
  the multiplicative noises (:func:`satfmu.synthesis.periodic.cubesat_periodic.system`), two orbits from
  w(0), seeded Monte Carlo realizations of each gain set, the exact mean square beside the
  Monte Carlo one, and the ESMS spectral radius that predicts its decay per orbit.
- :func:`sweep`: the controller FMUs on the nonlinear plant FMU through the master (the
  shipped scenario ``cubesat_detumble`` with its initial rate rescaled), for initial rates
  from small to tumbling: the final ``|w| / |w(0)|`` after two orbits and the dipole effort
  ``integral |m|^2 dt`` of each controller, and the largest initial rate each one detumbles
  (``|w|`` reduced 10x within two orbits).
- :func:`rate_scenario`: your cubesat's periodic gains beside B-dot on the nonlinear plant from
  one initial rate, as a scenario to run or gate.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

from satfmu.sims.scenario.provisioning import ensure_fmus
from satfmu.sims.scenario.run import simulate
from satfmu.fmus.plants.spacecraft import Spacecraft
from satfmu.sims.scenario.spec import Connection, FmuSpec, Metric, Scenario, load

SCENARIO = "cubesat_detumble"
CONTROLLERS = {"periodic LMI (satfmu)": ("lmi_plant", "lmi"), "periodic LMI (published)": ("pub_plant", "pub"),
               "B-dot": ("bdot_plant", "bdot")}
"""Controller label -> (plant instance, controller instance) in the scenario."""
W0_DIRECTION = np.array([0.05, -0.04, 0.03])
"""The issue's substitute initial rate, rad/s (its direction is kept in the sweep)."""
REDUCTION = 0.1
"""Detumbled: ``|w|`` at the end of two orbits at most this fraction of ``|w(0)|``."""


@dataclass
class LinearRun:
    """Monte Carlo of one gain set on the linear sampled model.

    The sample instants ``k`` are 15 min apart (the seed's dipole hold); the rate ``w`` is the
    state of the model (rad/s), the dipole ``m(k) = F(k) w(k)`` its input (A m^2).

    Parameters
    ----------
    label : str
        Name of the gain set (a key of the ``gains`` of :func:`linear_campaign`).
    spectral_radius : float
        Spectral radius of the closed loop's second-moment monodromy
        (:func:`satfmu.synthesis.periodic.periodic_hinf.ms_spectral_radius`): the asymptotic decay factor
        of the mean square per orbit; the loop is exponentially stable in mean square (ESMS) iff
        it is < 1.
    k : numpy.ndarray of int, shape (n + 1,)
        Sample indices 0..n, n = orbits times samples per orbit.
    ms_exact : numpy.ndarray, shape (n + 1,)
        Exact mean square ``E|w(k)|^2`` ((rad/s)^2), the trace of the second moment.
    ms_mc : numpy.ndarray, shape (n + 1,)
        Monte Carlo estimate of the mean square ((rad/s)^2).
    ms_se : numpy.ndarray, shape (n + 1,)
        Standard error of ``ms_mc`` ((rad/s)^2).
    rate_samples : numpy.ndarray, shape (n_runs, n + 1)
        ``|w(k)|`` of every realization (rad/s).
    dipole_samples : numpy.ndarray, shape (n_runs, n)
        ``|m(k)|`` of every realization, held from sample k to k + 1 (A m^2).
    """

    label: str
    spectral_radius: float
    k: np.ndarray
    ms_exact: np.ndarray
    ms_mc: np.ndarray
    ms_se: np.ndarray
    rate_samples: np.ndarray
    dipole_samples: np.ndarray

    def rms(self) -> np.ndarray:
        """``sqrt(E|w(k)|^2)``, exact, rad/s."""
        return np.sqrt(self.ms_exact)


def linear_campaign(gains: dict[str, np.ndarray], n_runs: int = 2000, seed: int = 0,
                    w0: np.ndarray = W0_DIRECTION, orbits: int = 2) -> list[LinearRun]:
    """Seeded Monte Carlo of the linear sampled model for each gain set (``label -> F``).

    Parameters
    ----------
    gains : dict of str to numpy.ndarray
        Label -> periodic gains ``F``, shape (N, 3, 3), one per sample of the orbit
        (A m^2 per rad/s), as held by a periodic gain artifact.
    n_runs : int, optional
        Monte Carlo realizations per gain set, at least 2.
    seed : int, optional
        Seed of the first gain set's realizations; the i-th gain set uses ``seed + i``.
    w0 : numpy.ndarray, shape (3,), optional
        Initial rate w(0) (rad/s), the same for every realization; default
        :data:`W0_DIRECTION`.
    orbits : int, optional
        Orbits simulated, at least 1.

    Returns
    -------
    list of LinearRun
        One per gain set, in the order of ``gains``.

    Raises
    ------
    ValueError
        If n_runs < 2 or orbits < 1.
    """
    from satfmu.synthesis.periodic import cubesat_periodic, periodic_hinf

    if n_runs < 2 or orbits < 1:
        raise ValueError("need n_runs >= 2 and orbits >= 1")
    sys_ = cubesat_periodic.system()
    n = orbits * sys_.dims[0]
    out = []
    for i, (label, F) in enumerate(gains.items()):
        x, u = periodic_hinf.monte_carlo(sys_, F, w0, n, n_runs, seed + i)
        sq = (x**2).sum(axis=2)
        exact = np.trace(periodic_hinf.second_moment(sys_, F, np.outer(w0, w0), n), axis1=1, axis2=2)
        out.append(LinearRun(label, periodic_hinf.ms_spectral_radius(sys_, F), np.arange(n + 1), exact, sq.mean(axis=0),
                             sq.std(axis=0) / math.sqrt(n_runs), np.linalg.norm(x, axis=2),
                             np.linalg.norm(u, axis=2)))
    return out


@dataclass
class SweepRow:
    """One controller from one initial rate, two orbits on the nonlinear plant.

    Parameters
    ----------
    controller : str
        Label of the controller (a key of :data:`CONTROLLERS`).
    w0 : float
        Initial rate ``|w(0)|`` (rad/s).
    final_ratio : float
        ``|w|`` at the end of the run over ``|w(0)|``.
    min_ratio : float
        Smallest ``|w| / |w(0)|`` over the run.
    effort : float
        Dipole effort ``integral |m|^2 dt`` of the held dipole (A^2 m^4 s).
    detumbled : bool
        Whether ``final_ratio`` is at most :data:`REDUCTION`.
    """

    controller: str
    w0: float
    final_ratio: float
    min_ratio: float
    effort: float
    detumbled: bool


def sweep(fmu_dir: Path, rates: Sequence[float], backend: str = "native",
          progress: Callable[[int, int, str], None] | None = None) -> list[SweepRow]:
    """Run the scenario from each initial rate ``|w(0)|`` (rad/s, along :data:`W0_DIRECTION`).

    The effort is ``integral of |m|^2 dt`` of the dipole held over each step (A^2 m^4 s).

    Parameters
    ----------
    fmu_dir : Path
        Folder of the scenario's FMUs (not built here: :func:`run` builds the missing ones).
    rates : sequence of float
        Initial rates ``|w(0)|`` (rad/s), each finite and > 0; one simulation each.
    backend : str, optional
        FMU backend: ``"native"`` (compiled) or ``"python"`` (pythonfmu).
    progress : callable, optional
        ``progress(done, total, message)``, called after each rate.

    Returns
    -------
    list of SweepRow
        One per rate and controller of :data:`CONTROLLERS`.

    Raises
    ------
    ValueError
        If a rate is not finite and > 0.
    """
    if not rates or any(not (math.isfinite(r) and r > 0) for r in rates):
        raise ValueError("rates must be finite and > 0 rad/s")
    base = load(SCENARIO)
    direction = W0_DIRECTION / np.linalg.norm(W0_DIRECTION)
    rows = []
    for j, rate in enumerate(rates):
        data = {**base.data, "fmus": {k: dict(v) for k, v in base.data["fmus"].items()}}
        for plant, _ in CONTROLLERS.values():
            params = dict(data["fmus"][plant].get("parameters", {}))
            params.update({f"omega_0[{i + 1}]": float(rate * d) for i, d in enumerate(direction)})
            data["fmus"][plant]["parameters"] = params
        res, _ = simulate(Scenario.from_dict(data, base.folder, base.name), fmu_dir, backend)
        dt = np.diff(res["time"])
        for label, (plant, ctrl) in CONTROLLERS.items():
            w = res[f"{plant}.rate_norm"]
            m = [res[f"{ctrl}.m[{i}]"] for i in (1, 2, 3)]
            m2 = m[0] ** 2 + m[1] ** 2 + m[2] ** 2  # held over each step
            ratio = w / w[0]
            rows.append(SweepRow(label, float(rate), float(ratio[-1]), float(ratio.min()),
                                 float(np.sum(m2[:-1] * dt)), bool(ratio[-1] <= REDUCTION)))
        if progress:
            progress(j + 1, len(rates), f"|w(0)| = {rate:.3g} rad/s")
    return rows


LAWS = ("periodic", "bdot")
"""The laws of :func:`rate_scenario`: the periodic gains and B-dot."""


def rate_scenario(spacecraft: Spacecraft, controller: str, rate: float, *, expected: str | None = None,
                  orbits: int = 2) -> Scenario:
    """A periodic gain controller and B-dot on your cubesat, each on its own copy of the nonlinear
    magnetorquer plant, from the same initial rate.

    The plant (``magnetorquer_cubesat``, seed 003's Fourier field and orbit) takes the spacecraft's
    principal moments and clips each dipole component at its ``dipole_limit`` (the plant's 0.2
    A m^2 when it has none); B-dot's gain is :func:`satfmu.controllers.magnetic.bdot_gain` with the
    spacecraft's smallest moment. The initial rate lies along :data:`W0_DIRECTION`.

    Parameters
    ----------
    spacecraft : Spacecraft
        Your cubesat, principal axes (:class:`satfmu.fmus.plants.spacecraft.Spacecraft`).
    controller : str
        The periodic gain controller (artifact and FMU name, e.g. from
        :func:`satfmu.synthesis.designs.design_cubesat_periodic`).
    rate : float
        Initial rate ``|w(0)|``, rad/s, finite and > 0.
    expected : {"periodic", "bdot"}, optional
        The law that must bring ``|w|`` to :data:`REDUCTION` of ``|w(0)|`` in the run (its metric
        gets that bound); the other law's ratio is only reported. Default: both only reported.
    orbits : int, optional
        Length of the run in orbits of the field (90 min each), at least 1.

    Returns
    -------
    Scenario
        Instances ``periodic_plant``, ``periodic``, ``bdot_plant``, ``bdot``; metrics per law:
        ``"<law>: |w(end)| / |w(0)|"`` and ``"<law>: peak dipole"`` (A m^2).

    Raises
    ------
    ValueError
        If ``rate`` is not finite and > 0, ``orbits`` < 1 or ``expected`` is not a law.
    satfmu.fmus.errors.SpacecraftError
        If the spacecraft has products of inertia.
    """
    from satfmu.controllers.magnetic import bdot_gain
    from satfmu.fmus.plants import cubesat

    if not (math.isfinite(rate) and rate > 0) or orbits < 1:
        raise ValueError(f"need a finite rate > 0 rad/s and orbits >= 1, got {rate!r} and {orbits!r}")
    if expected is not None and expected not in LAWS:
        raise ValueError(f"expected must be one of {LAWS}, got {expected!r}")
    moments = cubesat.principal_moments(spacecraft)
    direction = W0_DIRECTION / np.linalg.norm(W0_DIRECTION)
    plant: dict[str, float | bool] = {
        **{f"I_{a}": v for a, v in zip("xyz", moments)}, "saturation_on": True,
        **({} if spacecraft.dipole_limit is None else {"m_max": spacecraft.dipole_limit}),
        **{f"omega_0[{i + 1}]": float(rate * c) for i, c in enumerate(direction)}}
    models = {"periodic": (controller, "omega", {}), "bdot": ("cubesat_bdot", "b_body",
                                                             {"bdot_gain": bdot_gain(j_min=min(moments))})}
    fmus, connections, metrics = {}, [], []
    for law, (model, measured, params) in models.items():
        fmus[f"{law}_plant"] = FmuSpec(model="magnetorquer_cubesat", parameters=plant)
        fmus[law] = FmuSpec(model=model, parameters=params)
        connections += [Connection(f"{law}_plant.{measured}", f"{law}.{measured}"),
                        Connection(f"{law}.m", f"{law}_plant.m")]
        metrics += [Metric(f"{law}: |w(end)| / |w(0)|", "final", [f"{law}_plant.rate_norm"], scale=1.0 / rate,
                           max=REDUCTION if law == expected else None),  # a ratio: rad/s over rad/s
                    Metric(f"{law}: peak dipole", "peak", [f"{law}.m"], unit="A.m2")]
    return Scenario(name=f"{spacecraft.name}_{controller}_from_{rate:g}", stop_time=orbits * cubesat.ORBIT_PERIOD_SEED,
                    step_size=1.0, fmus=fmus, connections=connections, metrics=metrics,
                    description=f"{spacecraft.name}: {controller} and B-dot from |w(0)| = {rate:g} rad/s, "
                                f"{orbits} orbits, dipole clipped",
                    record=[f"{law}_plant.rate_norm" for law in LAWS] + [f"{law}.m" for law in LAWS])


def detumbled_band(rows: Sequence[SweepRow]) -> dict[str, tuple[float, float]]:
    """Per controller: the contiguous band ``(low, high)`` of swept initial rates detumbled 10x that
    ends at the largest rate detumbled; (NaN, NaN) when none is. Below the band B-dot cannot
    reach 10x: its own equilibrium spins the body with the field, about twice the orbit rate.

    Parameters
    ----------
    rows : sequence of SweepRow
        The rows of :func:`sweep`.

    Returns
    -------
    dict of str to (float, float)
        Controller label -> lowest and highest initial rate of the band (rad/s).
    """
    out = {}
    for label in dict.fromkeys(r.controller for r in rows):
        mine = sorted((r for r in rows if r.controller == label), key=lambda r: r.w0)
        ok = [i for i, r in enumerate(mine) if r.detumbled]
        if not ok:
            out[label] = (math.nan, math.nan)
            continue
        hi = lo = ok[-1]
        while lo > 0 and mine[lo - 1].detumbled:
            lo -= 1
        out[label] = (mine[lo].w0, mine[hi].w0)
    return out


def sweep_table(rows: Sequence[SweepRow]) -> str:
    """Markdown table: one row per initial rate, ratio and effort per controller.

    Parameters
    ----------
    rows : sequence of SweepRow
        The rows of :func:`sweep`, one per rate and controller.
    """
    labels = list(dict.fromkeys(r.controller for r in rows))
    head = "| |w(0)| rad/s | " + " | ".join(f"{c}: |w(2T)|/|w(0)| | {c}: effort A^2 m^4 s" for c in labels) + " |"
    lines = [head, "|" + "---|" * (1 + 2 * len(labels))]
    for rate in sorted({r.w0 for r in rows}):
        cells = []
        for c in labels:
            r = next(x for x in rows if x.w0 == rate and x.controller == c)
            cells += [f"{r.final_ratio:.3g}{' (10x)' if r.detumbled else ''}", f"{r.effort:.3g}"]
        lines.append(f"| {rate:.3g} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


DEFAULT_RATES = tuple(float(r) for r in np.geomspace(1e-4, 1.0, 17))
"""Initial rates ``|w(0)|`` of the sweep by default, rad/s."""
GAIN_SETS = {"satfmu": "cubesat_periodic_satfmu", "published": "cubesat_periodic_published"}
"""Label -> artifact of the periodic gains of the linear campaign."""


@dataclass
class DetumbleResult:
    """What :func:`run` computed and wrote: the linear campaign and the nonlinear sweep.

    Parameters
    ----------
    linear : list of LinearRun
        The linear campaign (:func:`linear_campaign`), one run per gain set of :data:`GAIN_SETS`.
    samples : int
        Monte Carlo realizations per gain set.
    sweep : list of SweepRow
        The nonlinear sweep (:func:`sweep`).
    files : dict of str to Path
        The files written, by key: ``linear_fig2``, ``sweep_md``, ``sweep_csv``, ``sweep_png``.
    """

    linear: list[LinearRun]
    samples: int
    """Monte Carlo realizations per gain set."""
    sweep: list[SweepRow]
    files: dict[str, Path]
    """``linear_fig2``, ``sweep_md``, ``sweep_csv``, ``sweep_png``."""

    def text(self) -> str:
        """Both campaigns' figures and the files written."""
        lines = [f"(a) linear sampled model, {self.samples} seeded realizations each, "
                 f"w(0) = {W0_DIRECTION.tolist()} rad/s"]
        for r in self.linear:
            n = r.k[-1] // 2
            per_orbit = r.ms_exact[2 * n] / r.ms_exact[n]
            lines.append(f"  {r.label}: ESMS spectral radius {r.spectral_radius:.4g}; RMS |w| {r.rms()[0]:.4g} -> "
                         f"{r.rms()[n]:.3g} (1 orbit) -> {r.rms()[-1]:.3g} rad/s (2 orbits); E|w|^2 orbit 2 / orbit 1 "
                         f"{per_orbit:.3g}; Monte Carlo vs exact at 2 orbits: {r.ms_mc[-1]:.3g} +- {r.ms_se[-1]:.2g} "
                         f"vs {r.ms_exact[-1]:.3g}")
        lines.append("(b) nonlinear plant through the master, two orbits:\n" + sweep_table(self.sweep).rstrip("\n"))
        for label, (low, high) in detumbled_band(self.sweep).items():
            band = f"{low:.3g} to {high:.3g} rad/s" if math.isfinite(high) else "none of the swept rates"
            lines.append(f"  {label}: |w(0)| detumbled 10x within two orbits: {band}")
        lines.append(f"wrote {', '.join(map(str, self.files.values()))}")
        return "\n".join(lines)


def run(fmu_dir: Path, out_dir: Path, *, samples: int = 2000, seed: int = 0,
        rates: Sequence[float] = DEFAULT_RATES, progress: Callable[[int, int, str], None] | None = None
        ) -> DetumbleResult:
    """Seed 003 Fig. 2 on the linear model (:func:`linear_campaign`) and the nonlinear sweep (:func:`sweep`).

    The scenario's FMUs missing from ``fmu_dir`` are built first
    (:func:`satfmu.sims.scenario.provisioning.ensure_fmus`).

    Parameters
    ----------
    fmu_dir : Path
        Folder of the FMUs.
    out_dir : Path
        Receives ``linear_fig2.png``, ``sweep.md``, ``sweep.csv`` and ``sweep.png``.
    samples : int
        Monte Carlo realizations per gain set (:data:`GAIN_SETS`).
    seed : int
        Seed of the realizations.
    rates : sequence of float
        Initial rates ``|w(0)|`` of the sweep, rad/s.
    progress : callable, optional
        Called after each rate of the sweep.
    """
    from satfmu.controllers import artifact as artifacts
    from satfmu.controllers import paths
    from satfmu.sims.scenario import plots

    def periodic_gains(name: str) -> np.ndarray:
        art = artifacts.load(paths.find_artifact(name))
        if not isinstance(art, artifacts.PeriodicArtifact):
            raise ValueError(f"artifact {name!r} is not a periodic gain schedule (kind periodic_gain_schedule)")
        return art.gains

    gains = {label: periodic_gains(name) for label, name in GAIN_SETS.items()}
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    files = {"linear_fig2": out_dir / "linear_fig2.png", "sweep_md": out_dir / "sweep.md",
             "sweep_csv": out_dir / "sweep.csv", "sweep_png": out_dir / "sweep.png"}
    runs = linear_campaign(gains, samples, seed)
    plots.detumble_linear(runs, files["linear_fig2"], "Seed 003 Fig. 2 analogue: linear periodic model with "
                          "multiplicative noises, rates and held dipoles at the 15-min samples")
    ensure_fmus(load(SCENARIO), fmu_dir, "native")
    rows = sweep(Path(fmu_dir), rates, progress=progress)
    files["sweep_md"].write_text(sweep_table(rows))
    with open(files["sweep_csv"], "w") as fh:
        fh.write("controller,w0_rad_s,final_ratio,min_ratio,effort_A2m4s,detumbled\n")
        for r in rows:
            fh.write(f"{r.controller},{r.w0:.6g},{r.final_ratio:.6g},{r.min_ratio:.6g},{r.effort:.6g},{r.detumbled}\n")
    plots.detumble_sweep(rows, files["sweep_png"], "Seed 003 on the nonlinear plant: two orbits from |w(0)| "
                         "along [0.05, -0.04, 0.03]")
    return DetumbleResult(runs, samples, rows, files)
