"""Seed 000's two-step iteration: state feedback by SOS, then the closed loop's L2 gain, repeat.

Seed 000 section 4 (docs/models.md, "Two-step iteration"): step 1 solves Theorem 1
with bounds on the gain coefficients; step 2 computes the L2 gain ``c`` of the closed loop
from the Hamilton-Jacobi inequality; the gains are raised while ``c`` decreases and the
response stays acceptable ("the decision to increase or decrease can be made based on the
response curve"), and the iteration stops when ``c`` stops improving.

Here the gain knob is the certified decay rate ``lambda`` of Theorem 1 on ``|sigma| <= r``
(``dV/dt <= -2 lambda V``), with every K coefficient bounded by ``coefficient_limit``
(the paper's coefficient bounds, which keep the gains the objective does not price
finite). Each iterate is judged by

- ``c``: the smallest L2 gain with an SOS certificate of ``H <= 0`` on the L2 region
  (:func:`satfmu.synthesis.polynomial_feedback.l2_gain.sos_gain`), beside the sampled and diagonal estimates;
- the response: a rest-to-rest manoeuvre (default seed 000's 200 deg start; reference loop
  of the FMUs' sampled-data RK4), whose peak torque must stay within ``torque_budget`` and
  whose attitude error must be below ``final_tolerance_deg`` at the horizon (120 s).

Every step is made for the plant passed in (default seed 000's satellite; your own with
``satfmu.fmus.plants.mrp_satellite.build(spacecraft)``): Theorem 1 on its SDC form, the L2 gain and the
response of its closed loop, and the artifact records it.

An iterate is accepted when its design and its ``c`` are certified, its response passes
and ``c`` improves. Before the first accepted iterate a too slow response or an
unverified ``c`` only means "raise the gain"; the iteration stops at an infeasible
design, a response over the torque budget, or (after an accepted iterate) at the first
rejected one (the paper's rule: stop when ``c`` stops decreasing). It returns the best
accepted iterate.
"""
from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence, cast

import numpy as np

from satfmu.controllers import polynomial
from satfmu.controllers.artifact import ControllerArtifact, parse
from satfmu.fmus.plants import mrp_satellite
from satfmu.fmus import reference
from satfmu.fmus.model import Model
from satfmu.synthesis.polynomial_feedback import hinf_sos, l2_gain
from satfmu.synthesis.core.sos import SOSError, check_numbers
from satfmu.synthesis.core.progress import Progress

LOG = logging.getLogger(__name__)

DECAY_RATES = tuple(0.0025 * np.sqrt(2.0) ** k for k in range(10))
"""Default schedule of certified decay rates lambda, 1/s (geometric, factor sqrt 2)."""
SIGMA_200 = {"sigma_0[1]": 0.5992, "sigma_0[2]": -0.7976, "sigma_0[3]": 0.6517}
"""Seed 000's 200 deg start, s(0) = k tan(200 deg / 4)."""



@dataclass
class Iterate:
    """One pass of the two steps.

    Attributes
    ----------
    index : int
        Position in the schedule of decay rates, from 0.
    decay_rate : float
        The certified decay rate lambda asked of Theorem 1, 1/s.
    design : satfmu.synthesis.polynomial_feedback.hinf_sos.Theorem1Result or None
        The state feedback of step 1; None where Theorem 1 was infeasible.
    sos : satfmu.synthesis.polynomial_feedback.l2_gain.SOSGain or None
        The certified L2 gain of step 2; None where no certificate was found or step 2 did not
        run.
    sampled : satfmu.synthesis.polynomial_feedback.l2_gain.SampledGain or None
        The sampled L2-gain estimate of step 2 (None: step 2 did not run).
    diagonal : tuple of (float, float) or None
        ``(c, kv)`` of the paper's diagonal method at its best kv (None: step 2 did not run).
    peak_torque : float
        Largest ``|u_i|`` on the judged manoeuvre, N m (nan: not simulated, inf: diverged).
    final_error_deg : float
        Attitude error at the manoeuvre's horizon, deg (nan: not simulated, inf: diverged).
    accepted : bool
        Whether the iterate was accepted (``reason`` empty).
    reason : str
        Why it was rejected; empty when accepted.
    seconds : float
        Wall time of the pass, s.
    """

    index: int
    decay_rate: float
    design: hinf_sos.Theorem1Result | None
    sos: l2_gain.SOSGain | None
    sampled: l2_gain.SampledGain | None
    diagonal: tuple[float, float] | None
    """``(c, kv)`` of the paper's diagonal method at its best kv."""
    peak_torque: float
    final_error_deg: float
    accepted: bool
    reason: str
    seconds: float

    @property
    def c(self) -> float:
        """The certified L2 gain of the iterate (inf when it has none)."""
        return self.sos.c if self.sos is not None and self.sos.certified else float("inf")

    def row(self) -> dict[str, Any]:
        """Summary table row (plain numbers; ``nan`` where a step did not produce one)."""
        nan = float("nan")
        return {"iteration": self.index, "decay_rate_1_s": self.decay_rate,
                "design_certified": bool(self.design is not None and self.design.certified),
                "c_sos": self.sos.c if self.sos else nan, "c_sos_certified": bool(self.sos and self.sos.certified),
                "kv": self.sos.kv if self.sos else nan,
                "c_sampled": self.sampled.c if self.sampled else nan,
                "c_diagonal": self.diagonal[0] if self.diagonal else nan,
                "peak_torque_N_m": self.peak_torque, "final_error_deg": self.final_error_deg,
                "accepted": self.accepted, "reason": self.reason, "seconds": self.seconds}


@dataclass
class TwoStepResult:
    """All iterates and the chosen one.

    Attributes
    ----------
    iterates : list of Iterate
        Every pass, in order of increasing decay rate.
    best : Iterate
        The accepted iterate of the smallest certified L2 gain (the last accepted).
    plant : satfmu.fmus.model.Model
        The plant the iteration designed for.
    settings : dict, optional
        The iteration's settings (regions, limits, rates, start, horizon), recorded in the
        artifact's provenance.
    """

    iterates: list[Iterate]
    best: Iterate
    plant: Model
    """The plant the iteration designed for."""
    settings: dict[str, Any] = field(default_factory=dict)

    def table(self) -> str:
        """The per-iteration summary as a fixed-width text table."""
        head = (f"{'it':>3} {'lambda 1/s':>10} {'design':>7} {'c SOS':>9} {'c sampled':>10} {'c diag':>8} "
                f"{'peak |u| N m':>13} {'err deg':>9} {'s':>6}  verdict")
        lines = [head, "-" * len(head)]
        for it in self.iterates:
            r = it.row()
            cert = "yes" if r["design_certified"] else "no"
            csos = f"{r['c_sos']:.4f}" + ("" if r["c_sos_certified"] else "?")
            lines.append(f"{r['iteration']:>3} {r['decay_rate_1_s']:>10.5f} {cert:>7} {csos:>9} "
                         f"{r['c_sampled']:>10.4f} {r['c_diagonal']:>8.4f} {r['peak_torque_N_m']:>13.3f} "
                         f"{r['final_error_deg']:>9.4f} {r['seconds']:>6.1f}  "
                         + ("accepted" if it.accepted else "rejected") + (f": {it.reason}" if it.reason else ""))
        lines.append(f"chosen: iteration {self.best.index} (lambda = {self.best.decay_rate:.5f} 1/s, "
                     f"certified L2 gain c = {self.best.c:.4f})")
        return "\n".join(lines)

    def artifact_data(self, name: str) -> dict[str, Any]:
        """Controller artifact of the chosen design, with its L2-gain certificate and the
        iteration history.

        Parameters
        ----------
        name : str
            The artifact's name, lower_snake_case (the controller FMU's modelIdentifier).

        Returns
        -------
        dict
            The artifact's JSON data (:func:`satfmu.synthesis.polynomial_feedback.hinf_sos.artifact_data` with the
            ``l2_gain`` certificate and the iterations added).
        """
        best = self.best
        assert best.design is not None and best.sos is not None and best.sampled is not None
        data = hinf_sos.artifact_data(best.design, name, self.plant)
        region = self.settings["l2_region"]
        data["description"] = (f"Seed 000 nonlinear H-infinity state feedback by the two-step iteration "
                               f"(satfmu): certified decay {2 * best.decay_rate:g} V on {best.design.region}, "
                               f"L2 gain <= {best.c:.4f} on {region.label}")
        data["certificate"]["l2_gain"] = {
            "c": best.c, "method": "SOS certificate of H(x) <= 0 (S-procedure on the region), V = kv x^T P x",
            "region": region.label, "kv": best.sos.kv, "q2": 1.0,
            "checks": check_numbers(best.sos.checks),
            "sampled_c": _json_value(best.sampled.c), "sampled_kv": best.sampled.kv,
            "sampled_points": best.sampled.n_samples,
            "diagonal_c": best.diagonal[0] if best.diagonal else None,
            "diagonal_kv": best.diagonal[1] if best.diagonal else None,
        }
        # the function that made the design, whichever entry point called it (satfmu.design_hinf from
        # Python, or satfmu synth mrp-hinf, which calls it)
        data["provenance"]["source"] = "satfmu.synthesis.polynomial_feedback.two_step (seed 000 section 4)"
        data["provenance"]["settings"] = {k: (v.to_json() if hasattr(v, "to_json") else v)
                                          for k, v in self.settings.items()}
        data["provenance"]["iterations"] = [{k: _json_value(v) for k, v in it.row().items()}
                                            for it in self.iterates]
        return data


def _json_value(v: Any) -> Any:
    """Non-finite floats as None (strict JSON has no NaN or Infinity)."""
    return None if isinstance(v, float) and not np.isfinite(v) else v


def _candidate(design: hinf_sos.Theorem1Result, plant: Model) -> ControllerArtifact:
    """The artifact of a Theorem 1 design: ``artifact_data`` writes a polynomial state feedback."""
    return cast(ControllerArtifact, parse(hinf_sos.artifact_data(design, "two_step_candidate", plant)))


def _response(design: hinf_sos.Theorem1Result, plant: Model, start: Mapping[str, float],
              horizon: float) -> tuple[float, float]:
    """Peak |u| (N m) and attitude error at ``horizon`` (deg) of the manoeuvre from ``start``
    (plant parameters, e.g. ``sigma_0[i]``), no saturation, communication step 0.05 s."""
    ctrl = polynomial.build(_candidate(design, plant))
    res = reference.closed_loop_rk4(plant, ctrl, horizon, 0.05, dict(start))
    if not np.all(np.isfinite(res.x)):
        return float("inf"), float("inf")
    err = float(np.degrees(4 * np.arctan(np.linalg.norm(res.x[-1, 3:]))))
    return float(np.max(np.abs(res.u))), err


def two_step(plant: Model | None = None, region: float = 0.9,
             l2_region: l2_gain.Region = l2_gain.Region(0.2, 0.9),
             coefficient_limit: float = 1.0, decay_rates: Sequence[float] = DECAY_RATES,
             torque_budget: float = 6.5, final_tolerance_deg: float = 0.1, n_samples: int = 20_000,
             start: Mapping[str, float] | None = None, horizon: float = 120.0,
             progress: Progress | None = None) -> TwoStepResult:
    """Run the iteration over ``decay_rates`` (increasing) and return every iterate and the best.

    Parameters
    ----------
    plant : satfmu.fmus.model.Model, optional
        The MRP satellite to design for (default seed 000's; yours:
        ``satfmu.fmus.plants.mrp_satellite.build(spacecraft)``).
    region : float
        Theorem 1 certificate region ``|sigma| <= region`` (< 1).
    l2_region : satfmu.synthesis.polynomial_feedback.l2_gain.Region
        Region on which the L2 gain is certified and sampled.
    coefficient_limit : float
        Bound on every coefficient of K (program units).
    decay_rates : sequence of float
        The certified decay rates lambda to try, 1/s, increasing, >= 0 (default
        :data:`DECAY_RATES`).
    torque_budget : float
        Largest acceptable peak ``|u_i|`` on the manoeuvre, N m (on seed 000's 200 deg
        manoeuvre the published controller needs 6.22 N m).
    final_tolerance_deg : float
        Largest acceptable attitude error at ``horizon``, deg.
    n_samples : int
        Random samples of the sampled L2 estimate per iterate.
    start : mapping, optional
        Initial state of the judged manoeuvre as plant parameters (``sigma_0[i]``,
        ``omega_0[i]``; :func:`manoeuvre` builds one from an axis and an angle). Default
        :data:`SIGMA_200`, seed 000's 200 deg start.
    horizon : float
        Length of the judged manoeuvre, s.
    progress : callable, optional
        Called as ``progress(done, total, message)`` before each step of each iteration (with
        the time into the iteration; also logged at INFO, as each iteration's verdict) and once
        at the end (``satfmu.synthesis.core.progress.Progress``).

    Returns
    -------
    TwoStepResult
        Every iterate and the best accepted one.

    Raises
    ------
    satfmu.synthesis.core.sos.SOSError
        If no iterate is accepted.
    ValueError
        If ``decay_rates`` is not increasing and >= 0, ``torque_budget`` or ``horizon`` is not
        finite and > 0, or ``start`` sets a parameter the plant does not have.
    """
    decay_rates = [float(v) for v in decay_rates]
    if not decay_rates or any(b <= a for a, b in zip(decay_rates, decay_rates[1:])) or decay_rates[0] < 0:
        raise ValueError(f"decay_rates must be a non-empty increasing sequence of rates >= 0, got {decay_rates}")
    if not (np.isfinite(torque_budget) and torque_budget > 0):
        raise ValueError(f"torque_budget must be finite and > 0 (N m), got {torque_budget}")
    if not (np.isfinite(horizon) and horizon > 0):
        raise ValueError(f"horizon must be finite and > 0 (s), got {horizon}")
    plant = mrp_satellite.MODEL if plant is None else plant
    start = dict(SIGMA_200 if start is None else start)
    known = {v.name for v in plant.parameters}
    unknown = sorted(set(start) - known)
    if unknown:
        raise ValueError(f"start sets {unknown}, which plant {plant.name!r} does not have")
    settings = {"region": region, "l2_region": l2_region, "coefficient_limit": coefficient_limit,
                "torque_budget_N_m": torque_budget, "final_tolerance_deg": final_tolerance_deg,
                "n_samples": n_samples, "decay_rates": decay_rates, "start": start, "horizon_s": horizon}
    total = len(decay_rates)
    iterates: list[Iterate] = []
    best: Iterate | None = None
    for k, lam in enumerate(decay_rates):
        t0 = time.perf_counter()

        def report(msg: str) -> None:
            text = f"iteration {k}, lambda = {lam:.5f} 1/s: {msg} (at {time.perf_counter() - t0:.1f} s)"
            LOG.info("%s", text)
            if progress is not None:
                progress(k, total, text)

        report("step 1, state feedback (Theorem 1)")
        design, sos, sampled, diagonal = None, None, None, None
        peak, err, reason = float("nan"), float("nan"), ""
        try:
            design = hinf_sos.theorem1(plant, region=region, decay_rate=lam, coefficient_limit=coefficient_limit)
        except SOSError as exc:
            reason = f"state feedback infeasible ({exc})"
        if design is not None and not design.certified:
            reason = "state feedback not certified"
        if design is not None and not reason:
            report("step 2, L2 gain (SOS, sampled, diagonal)")
            form = l2_gain.hji_form(_candidate(design, plant), plant)
            try:
                sos = l2_gain.sos_gain(form, l2_region)
            except SOSError as exc:
                reason = f"no L2 certificate ({exc})"
            sampled = l2_gain.sampled_gain(form, l2_region, n_samples=n_samples)
            diagonal = l2_gain.diagonal_gain(form)
            if sos is not None and not sos.certified:
                reason = "L2 certificate failed verification"
            report("response, manoeuvre")
            peak, err = _response(design, plant, start, horizon)
            if not reason and peak > torque_budget:
                reason = f"peak torque {peak:.2f} N m over the budget {torque_budget:g}"
            elif not reason and not err < final_tolerance_deg:
                reason = f"attitude error {err:.3g} deg at {horizon:g} s (>= {final_tolerance_deg:g})"
            elif not reason and best is not None and sos is not None and sos.c >= best.c:
                reason = f"c = {sos.c:.4f} does not improve on {best.c:.4f}"
        it = Iterate(k, lam, design, sos, sampled, diagonal, peak, err, not reason, reason,
                     time.perf_counter() - t0)
        iterates.append(it)
        LOG.info("iteration %d: %s in %.1f s", k, "accepted" if it.accepted else f"rejected: {reason}",
                 it.seconds)
        if it.accepted:
            best = it
        elif best is not None or design is None or peak > torque_budget:
            break  # gains past their best, over budget, or infeasible: raising them further cannot help
    if progress is not None:
        progress(total, total, "done")
    if best is None:
        raise SOSError("two-step iteration: no iterate accepted; " + "; ".join(
            f"lambda {it.decay_rate:g}: {it.reason}" for it in iterates))
    return TwoStepResult(iterates, best, plant, settings)


def manoeuvre(angle_deg: float, axis: Sequence[float] = (1.0, 1.0, 1.0)) -> dict[str, float]:
    """The start of a rest-to-rest manoeuvre as the MRP plant's ``sigma_0[i]`` parameters.

    For ``two_step(start=...)`` and a scenario's plant parameters (``omega_0`` stays 0).

    Parameters
    ----------
    angle_deg : float
        Rotation angle to the target attitude, deg.
    axis : 3 floats
        Rotation axis in body axes (normalized here).

    Raises
    ------
    ValueError
        If the angle is not finite or the axis is not a finite non-zero 3-vector.
    """
    if not np.isfinite(angle_deg):
        raise ValueError(f"angle must be finite (deg), got {angle_deg}")
    s = mrp_satellite.mrp_from_axis_angle(np.asarray(axis, float), np.radians(angle_deg))
    return {f"sigma_0[{i + 1}]": float(v) for i, v in enumerate(s)}
