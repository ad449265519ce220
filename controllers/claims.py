"""What an artifact claims, re-checked when it is loaded (:func:`satfmu.controllers.artifact.parse`).

A certificate's status is a claim (:data:`satfmu.controllers.artifact.CERTIFICATE_STATUS`):
``certified`` claims a proof, ``sampled`` that checks on samples passed, ``not_verified``
nothing. Loading re-checks it from the numbers the artifact records and recomputes what the
artifact's own matrices allow (each recomputation costs well under a millisecond):

polynomial_state_feedback (``certified``)
    every SOS check of :func:`satfmu.synthesis.core.sos.certify` (``"<name>: min_eig"`` >=
    ``-SOS_EIG_TOL``, ``"<name>: residual"`` <= ``SOS_RES_TOL``); ``psd_margin`` >=
    ``-PSD_MARGIN_TOL`` and ``max real part of eig(Acl(0))`` < 0 when recorded. Recomputed: the
    law's ``P`` is the inverse of ``lyapunov.Q`` (``u = K(x) P x``, ``P = Q^-1``); for a mixed
    H2/H-infinity certificate the smallest eigenvalues of ``Xinf`` and of the lambda block
    ``[[lambda, x0^T], [x0, X2]]`` (``X2 = lyapunov.Q``; so the H2 level ``x0^T X2^-1 x0`` <=
    lambda), >= ``-PSD_MARGIN_TOL``.
    Any status: an ``l2_gain`` record's SOS checks, and its sampled lower bound ``sampled_c``
    <= its certified ``c``.
servo_gain_schedule
    ``certified``: ``riccati_residual`` <= ``RICCATI_RES_TOL``, ``max_re_shifted`` < 0,
    ``max_re_closed_loop`` <= ``MAX_RE_TOL`` (:func:`satfmu.controllers.riccati.riccati_gain`'s
    defaults); the SOS region's ``region_eps``, ``region_margin``, ``region_decay_bound`` > 0,
    ``region_trig_max_lyapunov_eig`` < 0 and ``region_trig_max_re_off_p4`` <=
    ``-region_trig_decay_bound``. ``certified`` or ``sampled``: ``frozen_max_re`` <= ``MAX_RE_TOL``.
periodic_gain_schedule (``certified``)
    ``ms_spectral_radius`` < 1 (mean-square stable, a discrete-time claim), ``max_block_eig``
    < 0, ``min_y_eig`` > 0, ``gamma`` > 0.
linear_state_feedback (``certified``)
    ``design_hinf_bound``, ``design_i2p_bound`` > 0, ``sampled_max_real_pole`` < 0, and no
    sampled value above a bound proved for every plant of the box: ``sampled_max_hinf`` <=
    ``design_hinf_bound``, ``analysis_hinf_pdlf``, ``analysis_hinf_common``;
    ``sampled_max_i2p`` <= ``design_i2p_bound``, ``analysis_i2p`` (relative slack
    ``BOUND_RTOL``). Any status: a ``design.K`` gives the artifact's ``gains``
    (:func:`satfmu.controllers.state_feedback.gains_of_design`, to ``GAIN_RTOL``): the campaigns
    use the first, the FMU the second.

A ``certified`` certificate that records none of its kind's numbers is refused too: nothing
would support the claim.
"""
from __future__ import annotations

import operator
from collections.abc import Callable
from typing import Any, TypeGuard

import numpy as np

SOS_EIG_TOL = 1e-6
"""Most negative admitted smallest Gram eigenvalue of a certified SOS check. :func:`satfmu.synthesis.core.sos.certify`
admits ``-1e-7 max(1, |G|)``; the Gram scale is not recorded, so this admits scales up to 10."""
SOS_RES_TOL = 1e-6
"""Largest admitted residual of a certified SOS check (``certify``: ``1e-7 max(1, |p|)``, as above)."""
PSD_MARGIN_TOL = 1e-9
"""Most negative admitted smallest eigenvalue of the Lyapunov matrices of a mixed H2/H-infinity
certificate (:attr:`satfmu.synthesis.polynomial_feedback.h2hinf_sos.Theorem8Result.certified`)."""
RICCATI_RES_TOL = 1e-8
"""Largest admitted relative Riccati residual (``residual_tol`` of :func:`satfmu.controllers.riccati.riccati_gain`)."""
MAX_RE_TOL = 1e-6
"""Largest admitted real part of a closed loop's eigenvalues, 1/s: a conserved mode sits at 0
(``max_re_tol`` of :func:`satfmu.controllers.riccati.riccati_gain`)."""
BOUND_RTOL = 1e-6
"""Relative amount by which a sampled value may exceed a proved upper bound: the exact norms of
the samples are upper bounds within 2e-9, the bounds rounded solver levels."""
INVERSE_TOL = 1e-6
"""Largest admitted entry of ``P Q - I`` (numpy's inverse of a Lyapunov matrix errs by about
``cond(Q) 1e-16``)."""
GAIN_RTOL = 1e-9
"""Largest admitted difference between a gain of ``gains`` and the one ``design.K`` gives, relative
to the largest entry of its gain block: recomputing ``K_eta = K_r Q`` elsewhere differs by
rounding (1e-15 relative), any edit by more."""

_OPS: dict[str, Callable[[float, float], bool]] = {"<": operator.lt, "<=": operator.le, ">": operator.gt,
                                                   ">=": operator.ge}
Bound = tuple[str, str, float, str]
"""(number name, comparison, limit, what the claim needs it for)."""

_SOS_CHECKS: tuple[Bound, ...] = (
    (": min_eig", ">=", -SOS_EIG_TOL, "a positive semidefinite Gram matrix"),
    (": residual", "<=", SOS_RES_TOL, "the polynomial equal to its Gram form"))
"""Bounds on the numbers of every SOS check (matched by the end of the name)."""
_FROZEN: Bound = ("frozen_max_re", "<=", MAX_RE_TOL, "no unstable frozen closed loop on the grid")
_CERTIFIED: dict[str, tuple[Bound, ...]] = {
    "polynomial_state_feedback": (
        ("psd_margin", ">=", -PSD_MARGIN_TOL, "positive definite Lyapunov matrices"),
        ("max real part of eig(Acl(0))", "<", 0.0, "a stable linearization at the origin")),
    "servo_gain_schedule": (
        ("riccati_residual", "<=", RICCATI_RES_TOL, "a solution of the Riccati equation"),
        ("max_re_shifted", "<", 0.0, "a stable shifted closed loop"),
        ("max_re_closed_loop", "<=", MAX_RE_TOL, "no unstable closed-loop mode"),
        _FROZEN,
        ("region_eps", ">", 0.0, "a strict SOS region certificate"),
        ("region_margin", ">", 0.0, "a positive SOS region margin"),
        ("region_decay_bound", ">", 0.0, "a positive decay rate on the region"),
        ("region_trig_max_lyapunov_eig", "<", 0.0, "a decreasing Lyapunov function on the samples")),
    "periodic_gain_schedule": (
        ("ms_spectral_radius", "<", 1.0, "mean-square stability of the sampled loop"),
        ("max_block_eig", "<", 0.0, "negative definite LMI blocks"),
        ("min_y_eig", ">", 0.0, "positive definite Y(k)"),
        ("gamma", ">", 0.0, "a performance level")),
    "linear_state_feedback": (
        ("design_hinf_bound", ">", 0.0, "an H-infinity bound"),
        ("design_i2p_bound", ">", 0.0, "an impulse-to-peak bound"),
        ("sampled_max_real_pole", "<", 0.0, "stable sampled closed loops")),
}
"""Bounds on the recorded numbers that status ``certified`` claims, per kind."""
_SAMPLED: dict[str, tuple[Bound, ...]] = {"servo_gain_schedule": (_FROZEN,)}
"""Bounds that status ``sampled`` claims, per kind."""
_PROVED_ABOVE: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("sampled_max_hinf", ("design_hinf_bound", "analysis_hinf_pdlf", "analysis_hinf_common")),
    ("sampled_max_i2p", ("design_i2p_bound", "analysis_i2p")))
"""A sampled maximum and the bounds proved for every plant of the box that it may not exceed."""


def problems(data: dict[str, Any]) -> list[str]:
    """What in an artifact contradicts its claims, one line each (empty: nothing).

    Parameters
    ----------
    data : dict
        Artifact JSON data whose structure :func:`satfmu.controllers.artifact.parse` has validated.

    Returns
    -------
    list of str
        ``"<key path>: <what is wrong>"``, the key path relative to the artifact, e.g.
        ``"certificate.numbers['ms_spectral_radius'] = 1.5: status 'certified' needs < 1 (...)"``.
    """
    kind, cert = data["kind"], data["certificate"]
    status, numbers = cert["status"], cert.get("numbers", {})
    out = []
    if isinstance(cert.get("l2_gain"), dict):
        out += _l2_gain(cert["l2_gain"])
    design = data.get("design")
    if kind == "linear_state_feedback" and isinstance(design, dict) and "K" in design:
        out += _design_gains(data)
    if status == "not_verified":
        return out
    bounds = _SAMPLED.get(kind, ()) if status == "sampled" else _CERTIFIED[kind]
    sos = _SOS_CHECKS if status == "certified" and kind == "polynomial_state_feedback" else ()
    out += _bounded("certificate.numbers", numbers, bounds, sos, status)
    if status != "certified":
        return out
    known = {b[0] for b in bounds} | ({name for name, _ in _PROVED_ABOVE} if kind == "linear_state_feedback" else set())
    if not any(k in known or k.endswith(tuple(s[0] for s in sos)) for k in numbers):
        out.append(f"certificate.numbers: status 'certified' but none of the numbers that support it is recorded "
                   f"(a {kind} records some of {sorted(known | {'*' + s[0] for s in sos})})")
    if kind == "linear_state_feedback":
        out += _below_proved(numbers)
    if kind == "servo_gain_schedule" and {"region_trig_max_re_off_p4", "region_trig_decay_bound"} <= set(numbers):
        top, decay = numbers["region_trig_max_re_off_p4"], numbers["region_trig_decay_bound"]
        if not top <= -decay:
            out.append(f"certificate.numbers['region_trig_max_re_off_p4'] = {top:.6g}: status 'certified' needs "
                       f"<= -region_trig_decay_bound = {-decay:.6g} (the sampled modes decay at the proved rate)")
    if kind == "polynomial_state_feedback":
        out += _lyapunov(data)
    return out


def _bounded(where: str, numbers: dict[str, float], bounds: tuple[Bound, ...], suffixed: tuple[Bound, ...],
             status: str) -> list[str]:
    """A line for each of ``numbers`` that misses its bound (by name, or by the end of its name)."""
    out = []
    for key, value in numbers.items():
        for name, op, limit, need in bounds:
            if key == name and not _OPS[op](value, limit):
                out.append(f"{where}[{key!r}] = {value:.6g}: status {status!r} needs {op} {limit:g} ({need})")
        for end, op, limit, need in suffixed:
            if key.endswith(end) and not _OPS[op](value, limit):
                out.append(f"{where}[{key!r}] = {value:.6g}: status {status!r} needs {op} {limit:g} ({need})")
    return out


def _l2_gain(l2: dict[str, Any]) -> list[str]:
    """The SOS checks of an L2-gain certificate, and its sampled lower bound below its upper bound."""
    checks = l2.get("checks", {})
    if not isinstance(checks, dict) or any(isinstance(v, bool) or not isinstance(v, (int, float))
                                           for v in checks.values()):
        return ["certificate.l2_gain.checks: must map check names to numbers"]
    out = _bounded("certificate.l2_gain.checks", checks, (), _SOS_CHECKS, "certified")
    low = l2.get("sampled_c")
    if _finite(low) and _finite(l2.get("c")) and not low <= l2["c"] * (1 + BOUND_RTOL):
        out.append(f"certificate.l2_gain.sampled_c = {low:.6g}: a sampled lower bound above the certified "
                   f"c = {l2['c']:.6g}")
    return out


def _below_proved(numbers: dict[str, float]) -> list[str]:
    """A line for each sampled maximum above a bound proved on the whole box."""
    out = []
    for sampled, bounds in _PROVED_ABOVE:
        for bound in bounds:
            if sampled in numbers and bound in numbers and not numbers[sampled] <= numbers[bound] * (1 + BOUND_RTOL):
                out.append(f"certificate.numbers[{sampled!r}] = {numbers[sampled]:.6g}: above the bound "
                           f"{bound} = {numbers[bound]:.6g} that status 'certified' claims for every plant")
    return out


def _finite(v: Any) -> TypeGuard[int | float]:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and bool(np.isfinite(v))


def _array(raw: Any, shape: tuple[int, ...]) -> np.ndarray | None:
    """``raw`` as a finite array of ``shape``, None if it is not one."""
    try:
        m = np.array(raw, dtype=float)
    except (TypeError, ValueError):
        return None
    return m if m.shape == shape and np.all(np.isfinite(m)) else None


def _lyapunov(data: dict[str, Any]) -> list[str]:
    """Recomputed: ``P = Q^-1`` of the law, and the eigenvalues and H2 level of a mixed certificate."""
    law, cert, Q = data["law"], data["certificate"], data.get("lyapunov", {}).get("Q")
    if Q is None:
        return []
    Q = np.array(Q, float)  # parse checked it: symmetric positive definite, n x n
    n, out = len(Q), []
    if law["form"] == "gain_times_lyapunov":
        err = float(np.abs(np.array(law["P"], float) @ Q - np.eye(n)).max())
        if not err <= INVERSE_TOL:
            out.append(f"law.P: not the inverse of lyapunov.Q (largest entry of P Q - I {err:.3g} > {INVERSE_TOL:g})")
    if "Xinf" in cert or "h2" in cert:
        h2 = cert.get("h2") if isinstance(cert.get("h2"), dict) else {}
        Xinf, lam, x0 = _array(cert.get("Xinf"), (n, n)), h2.get("lambda"), _array(h2.get("x0"), (n,))
        if Xinf is None or not _finite(lam) or x0 is None:
            return out + [f"certificate: Xinf ({n} x {n}) and h2 (lambda, x0 of {n}) must be recorded together"]
        block = np.block([[np.array([[lam]]), x0[None, :]], [x0[:, None], Q]])
        for key, what, low in (
                ("certificate.Xinf", "Xinf", np.linalg.eigvalsh(Xinf).min()),
                ("certificate.h2.lambda", "[[lambda, x0^T], [x0, X2]] over max(1, lambda) (x0^T X2^-1 x0 <= lambda)",
                 np.linalg.eigvalsh(block).min() / max(1.0, lam))):
            if not low >= -PSD_MARGIN_TOL:
                out.append(f"{key}: recomputed smallest eigenvalue of {what} {low:.3g}: status 'certified' "
                           f"needs >= {-PSD_MARGIN_TOL:g}")
    return out


def _design_gains(data: dict[str, Any]) -> list[str]:
    """The gains ``design.K`` gives against the artifact's ``gains``, per gain block."""
    from satfmu.controllers.state_feedback import design_spacecraft, gains_of_design

    params = data["provenance"].get("design_plant", {}).get("parameters", {})
    try:
        n_flex = len(design_spacecraft(data["design"]).modes)
    except ValueError as exc:
        return [f"design.{exc}"]
    try:
        L = np.array([[params[f"L[{i},{j}]"] for j in range(1, n_flex + 1)] for i in range(1, 4)], float)
    except KeyError as exc:
        return [f"design.K: provenance.design_plant.parameters lacks the coupling {exc.args[0]} the design used, "
                "so design.K cannot be checked against gains"]
    try:
        expected = gains_of_design(data["design"], L)
    except ValueError as exc:
        return [f"design.{exc}"]
    recorded = data["gains"]
    worst: tuple[float, str] = (0.0, "")
    for block in sorted({k.split("[")[0] for k in (*expected, *recorded)}):
        keys = [k for k in {*expected, *recorded} if k.split("[")[0] == block]
        scale = max(max(abs(expected.get(k, 0.0)), abs(recorded.get(k, 0.0))) for k in keys)
        for k in keys:
            diff = abs(expected.get(k, 0.0) - recorded.get(k, 0.0))
            if diff > GAIN_RTOL * scale and diff > worst[0]:
                worst = (diff, k)
    if not worst[1]:
        return []
    diff, k = worst
    return [f"design.K and gains disagree (largest difference {diff:.6g} at {k}: gains {recorded.get(k, 0.0):.6g}, "
            f"design.K gives {expected.get(k, 0.0):.6g}; tolerance {GAIN_RTOL:g} of the gain block's largest "
            "entry): a campaign analyses design.K, the FMU runs gains"]
