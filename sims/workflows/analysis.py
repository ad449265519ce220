"""Analyses of a design that write their files and return their result (``satfmu analyze NAME``).

- :func:`h2hinf_sweep`: the gamma-lambda trade-off of seed 001's Theorem 8, both variants
  (CSV and PNG);
- :func:`vscmg_region`: seed 002's re-posed SOS stability region of the approximated SDRE on
  one box, and the map cell by cell (JSON and PNG);
- :func:`l2`: the three L2-gain estimates of a controller's closed loop (diagonal, sampled, SOS).

Each result's ``text()`` is what the command line prints.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from satfmu.controllers import paths
from satfmu.synthesis.core.progress import Progress



@dataclass
class SweepResult:
    """What :func:`h2hinf_sweep` computed and wrote.

    Parameters
    ----------
    rows : list of satfmu.synthesis.polynomial_feedback.h2hinf_search.SweepRow
        One point of the trade-off per gamma and variant (lambda inf: none certified).
    csv : str
        The rows as CSV text.
    files : dict of str to Path, optional
        The files written: ``csv`` (``gamma_lambda.csv``) and ``png`` (``gamma_lambda.png``).
    """

    rows: list
    """:class:`satfmu.synthesis.polynomial_feedback.h2hinf_search.SweepRow` per gamma and variant (lambda inf:
    none certified)."""
    csv: str
    """The rows as CSV text (the content of ``files["csv"]``)."""
    files: dict[str, Path] = field(default_factory=dict)

    def text(self) -> str:
        """The CSV and the files written."""
        return self.csv + f"wrote {self.files['csv']} and {self.files['png']}"


def h2hinf_sweep(out_dir: Path, gammas: Sequence[float] = (1.0, 0.8, 0.7, 0.6, 0.55), *, region: float = 0.45,
                 alpha_range: tuple[float, float] | None = None, evaluations: int = 12,
                 progress: Progress | None = None) -> SweepResult:
    """The certified H2 bound lambda against the L2 bound gamma, both Theorem 8 variants.

    Parameters
    ----------
    out_dir : Path
        Receives ``gamma_lambda.csv`` and ``gamma_lambda.png``.
    gammas : sequence of float
        L2-gain bounds w -> sigma (> 0).
    region : float
        Certificate region ``|sigma| <= region`` (< 1), any rate.
    alpha_range : (float, float), optional
        Line-search interval of alpha and beta, s (default
        :func:`satfmu.synthesis.polynomial_feedback.h2hinf_search.default_bounds`).
    evaluations : int
        SDPs per line search (alpha, then beta).
    progress : callable, optional
        Called after each SDP search.
    """
    from satfmu.sims.scenario import plots
    from satfmu.synthesis.polynomial_feedback import h2hinf_search

    rows = h2hinf_search.sweep(list(gammas), bounds=None if alpha_range is None else (*alpha_range,),
                            max_evaluations=evaluations, progress=progress, region=region)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    result = SweepResult(rows, h2hinf_search.sweep_csv(rows),
                         {"csv": out_dir / "gamma_lambda.csv", "png": out_dir / "gamma_lambda.png"})
    result.files["csv"].write_text(result.csv)
    plots.tradeoff(rows, result.files["png"],
                   f"Seed 001 Theorem 8 on |sigma| <= {region:g}: certified H2 bound vs gamma")
    return result


@dataclass
class RegionResult:
    """What :func:`vscmg_region` computed and wrote.

    Parameters
    ----------
    artifact : str
        Name of the servo artifact analysed.
    box : satfmu.synthesis.servo.vscmg_region.BoxCertificate
        Certificate of the one-Y box (q2 rad, w4 rad/s).
    checks : dict of str to float
        The certificate checked on the true sin/cos model at samples of the box
        (:func:`satfmu.synthesis.servo.vscmg_region.trig_check`, empty when the box has no Lyapunov
        matrix) and the cosine enclosure's errors (:func:`satfmu.synthesis.servo.vscmg_region.cos_errors`).
    cells : list of satfmu.synthesis.servo.vscmg_region.BoxCertificate
        Certificate of each map cell.
    files : dict of str to Path, optional
        The files written: ``json`` (``region.json``) and ``png`` (``region.png``).
    """

    artifact: str
    box: Any
    """:class:`satfmu.synthesis.servo.vscmg_region.BoxCertificate` of the one-Y box."""
    checks: dict[str, float]
    """The true sin/cos model's samples on the box and the cosine enclosure's errors."""
    cells: list
    """:class:`~satfmu.synthesis.servo.vscmg_region.BoxCertificate` of each map cell."""
    files: dict[str, Path] = field(default_factory=dict)

    def text(self) -> str:
        """The box certificate, its checks, the cells certified and the files written."""
        b = self.box
        lines = [f"box q2 {b.q2} w4 {b.w4}: {b.message}; eps {b.eps:.4g}, decay bound {b.decay:.4g} 1/s, "
                 f"margin {b.margin:.4g}, {b.seconds:.0f} s"]
        lines += [f"  {k}: {v:.4g}" for k, v in self.checks.items()]
        lines.append(f"cells certified: {sum(c.certified for c in self.cells)}/{len(self.cells)}; "
                     f"wrote {self.files['json']} and {self.files['png']}")
        return "\n".join(lines)


def vscmg_region(out_dir: Path, artifact: str | Path = "vscmg_sdre_approx", *,
                 box_q2: tuple[float, float] | None = None, box_w4: tuple[float, float] | None = None,
                 q2: tuple[float, float] = (0.05, 1.52), w4: tuple[float, float] = (-1.8, 1.8),
                 cells: tuple[int, int] = (7, 6), progress: Progress | None = None) -> RegionResult:
    """Seed 002 section 4 re-posed: the SOS stability region of an approximated SDRE servo.

    Parameters
    ----------
    out_dir : Path
        Receives ``region.json`` and ``region.png``.
    artifact : str or Path
        Artifact name (:func:`satfmu.controllers.paths.find_artifact`) or ``.json`` path of a servo.
    box_q2, box_w4 : (float, float), optional
        The one-Y box, rad and rad/s (default: :data:`satfmu.synthesis.servo.vscmg_region.OPERATING_BOX`).
    q2, w4 : (float, float)
        Range of the map, rad and rad/s.
    cells : (int, int)
        Map cells over q2 and w4.
    progress : callable, optional
        Called after each cell.
    """
    from satfmu.controllers import artifact as artifacts
    from satfmu.sims.scenario import plots
    from satfmu.fmus.profiles import make
    from satfmu.synthesis.servo import vscmg_region as servo_vscmg_region
    from satfmu.synthesis.servo.sdre import SEED_REFERENCE_PROFILES, simulate_servo

    art = artifacts.load(paths.find_artifact(artifact))
    if not isinstance(art, artifacts.ServoArtifact):
        raise ValueError(f"artifact {art.name!r} is not a gain-scheduled servo (kind servo_gain_schedule)")
    loop = servo_vscmg_region.ClosedLoop.build(art)
    box_q2, box_w4 = ((*b,) if b else d for b, d in zip((box_q2, box_w4), servo_vscmg_region.OPERATING_BOX))
    box = servo_vscmg_region.certify(loop, box_q2, box_w4)
    trig = servo_vscmg_region.trig_check(loop, box) if box.Y is not None else {}
    found = servo_vscmg_region.map_region(loop, np.linspace(*q2, cells[0] + 1), np.linspace(*w4, cells[1] + 1),
                                          progress=progress)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    result = RegionResult(art.name, box, {**trig, **servo_vscmg_region.cos_errors(box.q2)}, found,
                          {"json": out_dir / "region.json", "png": out_dir / "region.png"})
    result.files["json"].write_text(json.dumps(servo_vscmg_region.region_data(loop, box, trig, found), indent=1))
    refs = [make(SEED_REFERENCE_PROFILES[n]) for n in ("q2_ref", "q4_ref")]
    run = simulate_servo(lambda x: art.gain_at(art.scheduling_values({"q2": x[1], "w4": x[5]})),
                         lambda t: np.stack([r.sample(t) for r in refs], axis=1), plant_params={"friction_on": 0})
    plots.region_map(found, result.files["png"], [box], (run.x[:, 1], run.x[:, 5]),
                     f"Seed 002 section 4 re-posed: SOS stability region of {art.name} (frozen SDC loop off p4)")
    return result


@dataclass
class L2Result:
    """The three L2-gain estimates of :func:`l2` (c: the gain w -> sigma; kv: V = kv x^T P x).

    Parameters
    ----------
    controller : str
        Name of the controller.
    region : satfmu.synthesis.polynomial_feedback.l2_gain.Region
        Region of the sampled and SOS estimates (``|omega_i| <= rate_max`` rad/s,
        ``|sigma| <= sigma_max``).
    kv : float
        kv of the diagonal check at a fixed kv.
    diagonal : (float, float)
        c at ``kv`` on the diagonal x1 = ... = x6 in [-10, 10] (seed 000's method), and kv.
    diagonal_best : (float, float)
        The smallest c over kv on the diagonal, and its kv.
    sampled : satfmu.synthesis.polynomial_feedback.l2_gain.SampledGain
        Sampled estimate on the region (a lower bound on the smallest certifiable c).
    sos : satfmu.synthesis.polynomial_feedback.l2_gain.SOSGain or None
        SOS certificate on the region (an upper bound on c), or None when none was found.
    sos_error : str, optional
        Why there is no SOS certificate (empty when there is one).
    """

    controller: str
    region: Any
    """:class:`satfmu.synthesis.polynomial_feedback.l2_gain.Region` of the sampled and SOS estimates."""
    kv: float
    """kv of the diagonal check at a fixed kv."""
    diagonal: tuple[float, float]
    """c at ``kv`` on the diagonal x1 = ... = x6 in [-10, 10] (seed 000's method), and kv."""
    diagonal_best: tuple[float, float]
    """The smallest c over kv on the diagonal, and its kv."""
    sampled: Any
    """:class:`satfmu.synthesis.polynomial_feedback.l2_gain.SampledGain` on the region."""
    sos: Any | None
    """:class:`satfmu.synthesis.polynomial_feedback.l2_gain.SOSGain` on the region, or None when no
    certificate exists."""
    sos_error: str = ""
    """Why there is no SOS certificate."""

    def text(self) -> str:
        """The three estimates, one per line."""
        (c_pub, kv_pub), (c_diag, kv_diag), smp, label = (self.diagonal, self.diagonal_best, self.sampled,
                                                          self.region.label)
        found = f"c >= {smp.c:.4f} at kv = {smp.kv:.4g}" if math.isfinite(smp.c) else "no finite c for any kv"
        lines = [f"{self.controller}: L2 gain c from the HJI inequality, V = kv x^T P x, z = sigma",
                 f"  diagonal x1=...=x6 in [-10, 10] (seed 000's method): c = {c_pub:.4f} at kv = {kv_pub:g}; "
                 f"best c = {c_diag:.4f} at kv = {kv_diag:.4g}",
                 f"  sampled on {label} ({smp.n_samples} random points + adversarial search, origin limit "
                 f"{smp.origin_c:.4g}): {found}"]
        if smp.note:
            lines.append(f"    {smp.note}; worst point x = {[float(f'{v:.3g}') for v in smp.worst_point]}")
        g = self.sos
        if g is None:
            lines.append(f"  SOS certificate of H <= 0 on {label}: none ({self.sos_error})")
        else:
            lines.append(f"  SOS certificate of H <= 0 on {label}: c <= {g.c:.4f} at kv = {g.kv:.4g} "
                         f"({'certified' if g.certified else 'NOT certified'}: min Gram eigenvalue "
                         f"{min(ch.min_eig for ch in g.checks):.2e}, residual "
                         f"{max(ch.residual for ch in g.checks):.2e}; "
                         f"{g.n_programs} SDPs, {g.timings['solve']:.1f} s)")
        return "\n".join(lines)


def l2(controller: str | Path, *, rate_max: float = 0.2, sigma_max: float = 0.9, kv: float = 1e4,
       samples: int = 200_000) -> L2Result:
    """The L2 gain of a controller's closed loop with the MRP satellite, three ways.

    Parameters
    ----------
    controller : str or Path
        Artifact name (:func:`satfmu.controllers.paths.find_artifact`) or ``.json`` path.
    rate_max : float
        Region ``|omega_i| <= rate_max``, rad/s.
    sigma_max : float
        Region ``|sigma| <= sigma_max``.
    kv : float
        kv of the diagonal check at a fixed kv (the seed's: 1e4).
    samples : int
        Random points of the sampled estimate.
    """
    from satfmu.controllers import artifact as artifacts
    from satfmu.synthesis.polynomial_feedback import l2_gain
    from satfmu.synthesis.core.sos import SOSError

    art = artifacts.load(paths.find_artifact(controller))
    if not isinstance(art, artifacts.ControllerArtifact):
        raise ValueError(f"artifact {art.name!r} is not a polynomial state-feedback controller "
                         "(kind polynomial_state_feedback)")
    form = l2_gain.hji_form(art)
    region = l2_gain.Region(rate_max, sigma_max)
    diagonal, best = l2_gain.diagonal_gain(form, kv), l2_gain.diagonal_gain(form)
    sampled = l2_gain.sampled_gain(form, region, n_samples=samples)
    try:
        return L2Result(form.controller, region, kv, diagonal, best, sampled, l2_gain.sos_gain(form, region))
    except SOSError as exc:
        return L2Result(form.controller, region, kv, diagonal, best, sampled, None, str(exc))


@dataclass(frozen=True)
class MarginsResult:
    """The margins of a controller on its design plant, continuous and sampled
    (:func:`margins`).

    Parameters
    ----------
    controller : str
        The controller (artifact name).
    plant : str
        Its design plant (model name).
    continuous, sampled : satfmu.synthesis.core.margins.Margins
        The loop in continuous time, and sampled at ``sample_time`` with a zero-order hold.
    sample_time : float
        The communication step of the sampled loop, s.
    """

    controller: str
    plant: str
    continuous: Any
    sampled: Any
    sample_time: float

    def text(self) -> str:
        """The margins as a readable table."""
        lines = [f"{self.controller} on {self.plant} at the origin (loop broken at the plant input; sampled: "
                 f"zero-order hold at {self.sample_time:g} s)"]
        for label, m in (("continuous", self.continuous), (f"sampled {self.sample_time:g} s", self.sampled)):
            lines += _margin_lines(f"  {label}", m)
        return "\n".join(lines)


def margins(controller: str | Path, sample_time: float | None = None) -> "MarginsResult | ScenarioMarginsResult":
    """The linear margins of a controller on the plant it was designed for, at the origin; or of
    every loop of a scenario, as it is wired, at the origin and at its start.

    Parameters
    ----------
    controller : str or Path
        Artifact name or ``.json`` path (a controller whose model has no sampler, on its design
        plant); or a scenario name or ``.toml`` path (:func:`satfmu.sims.scenario.loops.scenario_margins`).
    sample_time : float, optional
        Communication step of the sampled loop, s (> 0). Default: the scenario's step, 0.05 s for
        an artifact.

    Returns
    -------
    MarginsResult or ScenarioMarginsResult

    Raises
    ------
    ValueError
        A sampled or time-periodic law (no linear time-invariant loop), an artifact without a
        design plant, or a controller whose inputs and outputs are not the plant's by name.
    """
    from satfmu.controllers import artifact as artifacts
    from satfmu.controllers import catalog
    from satfmu.fmus.linearization import linearize
    from satfmu.synthesis.core import margins as loop_margins

    if _is_scenario(controller):
        return scenario_margins(controller, sample_time)
    sample_time = 0.05 if sample_time is None else sample_time
    if not (sample_time > 0 and math.isfinite(sample_time)):
        raise ValueError(f"sample_time must be a positive number of seconds, got {sample_time!r}")
    path = paths.find_artifact(controller)
    art = artifacts.load(path)
    law = catalog.artifact_source(path).model
    if law.sampler is not None:
        raise ValueError(f"{art.name} is a sampled law (its gain changes at sample instants): its loop has no "
                         "linear time-invariant margins")
    plant_name = getattr(art, "plant", None)
    if not plant_name:
        raise ValueError(f"{art.name} names no design plant")
    plant = catalog.source(plant_name).model
    params = dict(art.provenance.get("design_plant", {}).get("parameters", {}))
    K = linearize(law)
    P = linearize(plant, parameters={k: v for k, v in params.items() if k in {p.name for p in plant.parameters}},
                  inputs=K.outputs, outputs=K.inputs)
    return MarginsResult(art.name, plant_name, loop_margins.margins(P, K), loop_margins.margins(P, K, sample_time),
                         sample_time)


def _margin_lines(head: str, m: Any) -> list[str]:
    """The lines of one :class:`satfmu.synthesis.core.margins.Margins`: the loop's, then a channel's each."""
    lines = [f"{head}: closed loop {'stable' if m.closed_loop_stable else 'UNSTABLE'}; disk margins (all inputs at "
             f"once) {m.disk_gain_margin_db:.2f} dB, {m.disk_phase_margin_deg:.2f} deg; peaks |S| "
             f"{m.sensitivity_peak:.3f}, |T| {m.complementary_peak:.3f}"]
    for lm in m.loops:
        lower = f" (a reduction of {-lm.lower_gain_margin_db:.2f} dB destabilizes)" \
            if math.isfinite(lm.lower_gain_margin_db) else ""
        phase = (f"phase margin {lm.phase_margin_deg:.2f} deg at {lm.gain_crossover:.4g} rad/s, delay margin "
                 f"{lm.delay_margin:.4g} s" if math.isfinite(lm.phase_margin_deg)
                 else "no gain crossover: no phase or delay margin to read")
        lines.append(f"    loop {lm.channel}: gain margin {lm.gain_margin_db:.2f} dB{lower}, {phase}")
    if m.unused:
        lines.append(f"    not used by the law here: {', '.join(m.unused)}")
    return lines


def _is_scenario(target: str | Path) -> bool:
    """A ``.toml`` path, or the name of a shipped scenario (an artifact is a ``.json`` or a name)."""
    from satfmu.sims.scenario import shipped_scenarios

    return str(target).endswith(".toml") or str(target) in {p.stem for p in shipped_scenarios()}


@dataclass(frozen=True)
class ScenarioMarginsResult:
    """The margins of every loop of a scenario (:func:`scenario_margins`).

    Parameters
    ----------
    scenario : str
        The scenario's name.
    loops : list of satfmu.sims.scenario.loops.LoopMargins
        Loop by loop, operating point by operating point.
    notes : list of str
        Connected instance pairs that are no loop, and why.
    """

    scenario: str
    loops: list
    notes: list

    def text(self) -> str:
        """The margins as a readable table, loop by loop."""
        lines = [f"{self.scenario}: loops broken at the plant inputs; 'origin': every state 0, 'start': the "
                 "scenario's initial state (a frozen-point loop where that is no equilibrium)"]
        for r in self.loops:
            head = f"  {r.loop.label}, {r.point}"
            if r.note:
                lines.append(f"{head}: {r.note}")
                continue
            for label, m in (("continuous", r.continuous), (f"sampled {r.sample_time:g} s", r.sampled)):
                lines += _margin_lines(f"{head}, {label}", m)
        lines += [f"  not a loop: {n}" for n in self.notes]
        return "\n".join(lines)


def scenario_margins(scenario: Any, sample_time: float | None = None) -> ScenarioMarginsResult:
    """The margins of every controller-plant loop of a scenario as it is wired
    (:func:`satfmu.sims.scenario.loops.scenario_margins`).

    Parameters
    ----------
    scenario : Scenario, dict, str or Path
        A scenario, its plain data, a TOML file or a shipped scenario's name.
    sample_time : float, optional
        Communication step of the sampled loop, s (default: the scenario's).

    Returns
    -------
    ScenarioMarginsResult

    Raises
    ------
    ValueError
        A sample time that is not a positive number.
    """
    from dataclasses import replace

    from satfmu.sims.scenario import loops
    from satfmu.sims.scenario.spec import load

    sc = load(scenario)
    if sample_time is not None:
        if not (sample_time > 0 and math.isfinite(sample_time)):
            raise ValueError(f"sample_time must be a positive number of seconds, got {sample_time!r}")
        sc = replace(sc, step_size=float(sample_time), stop_time=sc.start_time + float(sample_time))
    found, notes = loops.scenario_margins(sc)
    return ScenarioMarginsResult(sc.name, found, notes)
