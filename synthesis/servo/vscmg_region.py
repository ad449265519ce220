"""SOS stability region of the approximated SDRE servo's closed loop (seed 002, section 4), re-posed.

The closed loop is ``Acl(x) = Ae(x) - Be(x) K(sin q2, w4)``: ``Ae``, ``Be`` the servo's
w1-free SDC at w2 := 0 (:func:`satfmu.controllers.servo_sdc.servo_matrices`, the SDC the gain fits)
and ``K`` the artifact's polynomials. The seed's conditions (13)-(20) ask for ``P > 0`` and
``Acl P + P Acl^T < 0`` on a box, with ``cos q2 ~ 1 - sin^2 q2 / 2``. As printed they cannot
hold: the conserved gimbal-4 momentum ``p4 = m(a) . w`` (``m`` the gimbal-4 row of the mass
matrix, ``a = sin q2``) is a left null vector of ``Acl`` for every gain (docs/models.md).
Posed here so that it can hold, and without approximating the trigonometry:

- Variables ``a = sin q2`` in ``[a_lo, a_hi]`` (``a_lo > 0``) and ``w4``, scaled to
  ``s, t in [-1, 1]``; box constraints ``1 - s^2 >= 0``, ``1 - t^2 >= 0`` by S-procedure
  multipliers ``s_i(x) v^T v`` (SOS, degree ``multiplier_degree``).
- ``cos q2`` enters ``Ae`` only in the gimbal-2 row and affinely, so the condition is
  affine in ``c = cos q2``. ``sqrt(1 - a^2)`` is concave, so on the box it lies between the
  chord through the box's ends and the tangent at its centre; the condition holding at both
  lines holds for the true cosine. No approximation error enters the certificate; the
  seed's ``1 - a^2/2`` error is reported for comparison (:func:`cos_errors`).
- ``M^-1`` is cleared by ``det M(a) > 0`` (normalized to 1 at a = 0).
- The p4 direction is removed by Finsler's lemma: with a free polynomial vector
  ``lambda(x)``, ``-(Acl^T Y + Y Acl) - lambda p^T - p lambda^T - eps I`` is an SOS matrix
  on the box, ``p = [0, 0, 0, 0, m(a)]`` (so ``v^T (Acl^T Y + Y Acl) v <= -eps |v|^2`` for
  ``v`` orthogonal to ``p``).
- ``Y`` is one constant matrix for the whole box, ``I <= Y`` and ``trace Y <= trace_bound``
  in coordinates scaled by the Riccati solution of the centre's ``(Ae - 0.1 I, Be)``
  (conditioning only); ``eps`` is maximized.

What a certificate proves: at every frozen (q2, w4) of the box, every closed-loop mode
other than the conserved-p4 mode at 0 decays at least at ``eps / (2 lambda_max(Y))`` (in
the scaled coordinates), with one common Lyapunov matrix ``Y``: the seed's "robust
stability" of the frozen SDC loop. It is not a proof for the nonlinear plant (the SDC
freezes w2 := 0, and p changes with q2). Each certificate is re-checked without the solver:
Gram eigenvalues and residuals (:func:`satfmu.synthesis.core.sos.certify`), a bound turning them into a
margin on the box (``_rigorous_margin``), and the Lyapunov inequality and the decay
rate on samples of the true trigonometric model (:func:`trig_check`).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any, Callable

import numpy as np
import scipy.linalg as sla
import sympy as sp

from satfmu.controllers import domain
from satfmu.controllers.artifact import ServoArtifact
from satfmu.controllers.polynomial import sympy_polynomial
from satfmu.controllers.servo_sdc import servo_matrices
from satfmu.fmus.plants import vscmg
from satfmu.fmus.model import Model
from satfmu.synthesis.core.polynomial import Poly, PolyMatrix, monomials
from satfmu.synthesis.servo.sdre import Servo
from satfmu.synthesis.core import sos
from satfmu.synthesis.core.sos import Check, SOSError, SOSProgram

OPERATING_BOX = ((0.17, 1.24), (-0.6, 0.6))
"""(q2 rad, w4 rad/s) box of the seed's manoeuvre (docs/models.md **substitute** bounds)."""

SCALE_SHIFT = 0.1
"""Riccati shift of the coordinate scaling, 1/s (any value giving a well-conditioned P works)."""

_A, _C, _W = sp.symbols("a c w4", real=True)
_S, _T = sp.symbols("s t", real=True)


def _rational(v: float) -> sp.Rational:
    return sp.nsimplify(float(v), rational=True)


@dataclass
class ClosedLoop:
    """The approximated closed loop as polynomials, and its trigonometric evaluation.

    Attributes
    ----------
    acl : sympy Matrix (7x7)
        ``det M(a) / det M(0) * Acl`` in ``a = sin q2``, ``c = cos q2``, ``w4``.
    momentum : sympy Matrix (7x1)
        ``p(a)``: ``p . xe`` is the gimbal-4 momentum p4, kg m^2 rad/s.
    artifact : ServoArtifact
        The servo whose gain ``K`` closes the loop.
    servo : satfmu.synthesis.servo.sdre.Servo
        The numerical servo of the same SDC (w1-free, w2 := 0), evaluating ``Ae``, ``Be``
        of the trigonometric model (:meth:`ClosedLoop.matrix`) and the weights of the coordinate
        scaling.
    """

    acl: sp.Matrix
    momentum: sp.Matrix
    artifact: ServoArtifact
    servo: Servo = field(repr=False)

    @staticmethod
    def build(artifact: ServoArtifact, model: Model = vscmg.MODEL) -> "ClosedLoop":
        """From the servo artifact (scheduling ``sin(q2)``, ``w4``) and the plant model.

        Parameters
        ----------
        artifact : ServoArtifact
            The gain-scheduled servo, scheduled on ``["sin(q2)", "w4"]``.
        model : Model, optional
            The VSCMG plant (default ``satfmu.fmus.plants.vscmg.MODEL``).

        Raises
        ------
        ValueError
            If the artifact is not scheduled on ``["sin(q2)", "w4"]`` (the closed loop would
            not be polynomial in the region's variables).
        """
        if artifact.scheduling != ["sin(q2)", "w4"]:
            raise ValueError(f"the region needs a gain in sin(q2) and w4, {artifact.name!r} is scheduled on "
                             f"{artifact.scheduling}")
        Ae, Be = servo_matrices(model, "w1_free", freeze_w2=True)
        st = {s.variable.name: s.symbol for s in model.states}
        values = {k: _rational(v) for k, v in zip(model.parameter_symbols, model.parameter_vector())}
        trig = {sp.sin(st["q2"]): _A, sp.cos(st["q2"]): _C, st["w4"]: _W}
        inertias = vscmg.Inertias(*(values[p.symbol] for p in model.parameters if p.name in vscmg.INERTIAS_ECP750))
        M = vscmg.mass_matrix(sp.asin(_A), inertias).applyfunc(sp.expand)
        det = sp.expand(M.det())
        D = det / det.subs(_A, 0)
        K = sp.Matrix([[sympy_polynomial(entry, [_A, _W]) for entry in row] for row in artifact.gain])
        Ae_p = Ae.subs(values).subs(trig)
        Be_p = Be.subs(values).subs(trig)
        acl = (Ae_p * D - (Be_p * D).applyfunc(sp.cancel) * K).applyfunc(lambda e: sp.expand(sp.cancel(e)))
        for e in acl:
            if not sp.denom(sp.together(e)).is_number:
                raise ValueError(f"closed loop not polynomial after clearing det M: {e}")
        momentum = sp.Matrix([0, 0, 0, 0, *M[2, :]])
        return ClosedLoop(acl.evalf(17), momentum.evalf(17), artifact,
                          Servo("w1_free", freeze_w2=True, model=model))

    def matrix(self, q2: float, w4: float) -> np.ndarray:
        """``Acl`` (7x7) at (q2, w4) from the trigonometric model and the artifact's gain.

        Parameters
        ----------
        q2 : float
            Gimbal-2 angle, rad.
        w4 : float
            Gimbal-4 rate, rad/s.
        """
        A, B = self.servo.matrices(np.array([0.0, q2, 0.0, 0.0, 0.0, w4]))
        K = self.artifact.gain_at(self.artifact.scheduling_values({"q2": q2, "w4": w4}))
        return A - B @ K

    @cached_property
    def acl_poly(self) -> PolyMatrix:
        """``acl`` as a polynomial matrix in ``(a, c, w4)``."""
        return PolyMatrix.from_sympy(self.acl, [_A, _C, _W])

    @cached_property
    def momentum_poly(self) -> PolyMatrix:
        """``momentum`` as a polynomial matrix in ``(a, c, w4)``."""
        return PolyMatrix.from_sympy(self.momentum, [_A, _C, _W])

    def momentum_at(self, q2: float) -> np.ndarray:
        """``p`` at one gimbal-2 angle, shape (7,): its product with ``xe`` is the gimbal-4 momentum p4.

        Parameters
        ----------
        q2 : float
            Gimbal-2 angle, rad.
        """
        return np.array(self.momentum.subs(_A, np.sin(q2)), float).ravel()


@dataclass
class BoxCertificate:
    """The outcome of :func:`certify` on one box.

    ``certified``: the SOS program was solved with ``eps > 0``, every constraint passed
    :func:`satfmu.synthesis.core.sos.certify` and the rigorous margin is positive. ``Y`` is in the servo
    state's own coordinates (``V = xe^T Y xe``); ``decay`` is the guaranteed decay rate of the
    frozen modes off p4, 1/s.

    Attributes
    ----------
    q2 : tuple of (float, float)
        The box's gimbal-2 angle interval, rad.
    w4 : tuple of (float, float)
        The box's gimbal-4 rate interval, rad/s.
    certified : bool
        Whether the box is certified (above).
    message : str
        ``"certified"``, or why not (the solver's error, or the failed numbers).
    eps : float, optional
        The maximized Lyapunov margin ``eps`` in the scaled coordinates (nan if not solved).
    decay : float, optional
        Guaranteed decay rate of the frozen modes off p4, 1/s (nan if not solved).
    margin : float, optional
        ``eps`` less what the solver's inaccuracy can take away (> 0 for a certificate; nan
        if not solved).
    Y : numpy.ndarray, shape (7, 7), optional
        The Lyapunov matrix in the servo state's coordinates (None if not solved).
    checks : list of satfmu.synthesis.core.sos.Check, optional
        Independent verification of every SOS constraint.
    seconds : float, optional
        Wall time of :func:`certify`, s.
    """

    q2: tuple[float, float]
    w4: tuple[float, float]
    certified: bool
    message: str
    eps: float = float("nan")
    decay: float = float("nan")
    margin: float = float("nan")
    Y: np.ndarray | None = None
    checks: list[Check] = field(default_factory=list)
    seconds: float = 0.0

    def to_json(self) -> dict[str, Any]:
        """The certificate as a JSON-ready dict, its checks included."""
        return {"q2": list(self.q2), "w4": list(self.w4), "certified": self.certified, "message": self.message,
                "eps": self.eps, "decay": self.decay, "margin": self.margin,
                "Y": None if self.Y is None else self.Y.tolist(), "seconds": self.seconds,
                "checks": [c.to_json() for c in self.checks]}


def _box(q2: tuple[float, float], w4: tuple[float, float]) -> tuple[float, float, float, float]:
    lo, hi = q2
    if not (0.0 < lo < hi < np.pi / 2) or not w4[0] < w4[1] or not np.all(np.isfinite([*q2, *w4])):
        raise ValueError(f"box needs 0 < q2_lo < q2_hi < pi/2 and w4_lo < w4_hi, got q2 {q2}, w4 {w4}")
    return float(np.sin(lo)), float(np.sin(hi)), float(w4[0]), float(w4[1])


def cos_enclosure(a_lo: float, a_hi: float) -> tuple[sp.Expr, sp.Expr]:
    """(lower, upper) lines in ``a`` around ``sqrt(1 - a^2)`` on [a_lo, a_hi]: chord and
    tangent at the centre (the function is concave).

    Parameters
    ----------
    a_lo, a_hi : float
        The interval of ``a = sin q2``, ``0 <= a_lo < a_hi < 1``.

    Returns
    -------
    lower, upper : sympy.Expr
        The chord and the tangent, affine in the symbol ``a``.
    """
    f = lambda x: float(np.sqrt(1.0 - x * x))  # noqa: E731
    am = (a_lo + a_hi) / 2
    lower = f(a_lo) + (f(a_hi) - f(a_lo)) / (a_hi - a_lo) * (_A - a_lo)
    upper = f(am) - am / f(am) * (_A - am)
    return lower, upper


def cos_errors(q2: tuple[float, float], n: int = 2001) -> dict[str, float]:
    """On a q2 interval: the largest error of the seed's ``cos q2 ~ 1 - sin^2 q2 / 2`` and the
    width of the enclosure the certificate uses instead (both dimensionless).

    Parameters
    ----------
    q2 : tuple of (float, float)
        The gimbal-2 angle interval, rad, inside ``(0, pi/2)``.
    n : int, optional
        Number of evenly spaced angles evaluated. Default 2001.

    Raises
    ------
    AssertionError
        If the enclosure does not enclose ``cos q2`` (impossible on ``(0, pi/2)``).
    """
    q = np.linspace(*q2, n)
    a = np.sin(q)
    lower, upper = (sp.lambdify(_A, e, "numpy")(a) for e in cos_enclosure(*a[[0, -1]]))
    if np.any(lower > np.cos(q) + 1e-12) or np.any(upper < np.cos(q) - 1e-12):
        raise AssertionError("cos enclosure does not enclose cos q2")  # concavity makes this impossible
    return {"seed_cos_approx_max_error": float(np.max(np.abs(np.cos(q) - (1 - a**2 / 2)))),
            "enclosure_max_width": float(np.max(upper - lower))}


def _scaling(loop: ClosedLoop, q2: tuple[float, float], w4: tuple[float, float]) -> np.ndarray:
    """Cholesky factor L of the Riccati P of (Ae - SCALE_SHIFT I, Be) at the box centre."""
    A, B = loop.servo.matrices(np.array([0.0, sum(q2) / 2, 0.0, 0.0, 0.0, sum(w4) / 2]))
    P = sla.solve_continuous_are(A - SCALE_SHIFT * np.eye(7), B, loop.servo.Q, loop.servo.R)
    return np.linalg.cholesky((P + P.T) / 2)


def _rigorous_margin(prog: SOSProgram, checks: list[Check], sol: Any, eps: float) -> float:
    """``eps`` minus what the solver's inaccuracy can take away on the scaled box (|x| <= 1,
    |v| = 1): for each constraint ``N |min(lambda_min, 0)| + n_terms * residual`` (N the Gram
    size bounds ``|z|^2``, every monomial is at most 1), summed over all constraints
    (multipliers enter times ``g_i`` in [0, 1])."""
    lost = 0.0
    for c, chk in zip(prog.sos, checks):
        n_terms = c.poly.value(sol.y).exps.shape[0]
        lost += chk.basis_size * max(-chk.min_eig, 0.0) + n_terms * chk.residual
    return eps - lost


def certify(loop: ClosedLoop, q2: tuple[float, float], w4: tuple[float, float], multiplier_degree: int = 4,
            trace_bound: float = 100.0) -> BoxCertificate:
    """Solve and re-verify the region condition on the box ``q2`` (rad) x ``w4`` (rad/s).

    Parameters
    ----------
    loop : ClosedLoop
        The closed loop.
    q2 : tuple of (float, float)
        Gimbal-2 angle interval ``(low, high)``, rad, ``0 < low < high < pi/2``.
    w4 : tuple of (float, float)
        Gimbal-4 rate interval ``(low, high)``, rad/s, ``low < high``.
    multiplier_degree : int, optional
        Degree of the S-procedure multipliers of the box (even). Default 4.
    trace_bound : float, optional
        Bound on ``trace Y`` in the scaled coordinates (where ``Y >= I``). Default 100.

    Returns
    -------
    BoxCertificate
        The certificate, or why there is none (a solver failure is not raised).

    Raises
    ------
    ValueError
        On a box outside 0 < q2 < pi/2 or empty.
    """
    t0 = time.perf_counter()
    a_lo, a_hi, w_lo, w_hi = _box(q2, w4)
    L = _scaling(loop, q2, w4)
    # a = sin q2 and w4 in the box's scaled variables s, t in [-1, 1]
    sub = {_A: (a_lo + a_hi) / 2 + (a_hi - a_lo) / 2 * _S, _W: (w_lo + w_hi) / 2 + (w_hi - w_lo) / 2 * _T}
    xs = [_S, _T]
    a, w = Poly.from_sympy(sub[_A], xs), Poly.from_sympy(sub[_W], xs)
    prog = SOSProgram(2)
    Y = PolyMatrix(prog.new_symmetric(7))
    eps = prog.new_poly(np.zeros((1, 2), np.int64))
    prog.add_psd_constant(Y.entries, "Y >= I", margin=1.0)
    trace = sum((Y.entries[i][i].C for i in range(7)), 0 * Y.entries[0][0].C)
    prog.add_linear(-trace, np.array([trace_bound]), "ge")
    box = [Poly.from_sympy(1 - _S**2, xs), Poly.from_sympy(1 - _T**2, xs)]
    p = PolyMatrix.constant(np.linalg.inv(L), 2) @ loop.momentum_poly.substitute([a, a, w])  # no c in p
    zero = Poly.constant(0.0, 2)
    for label, c in zip(("chord", "tangent"), cos_enclosure(a_lo, a_hi)):
        acl = loop.acl_poly.substitute([a, Poly.from_sympy(c.subs(sub), xs), w])
        A = PolyMatrix.constant(L.T, 2) @ acl @ PolyMatrix.constant(np.linalg.inv(L.T), 2)
        G = A.T @ Y
        Q = -(G + G.T)
        lam = PolyMatrix([[prog.new_poly(monomials(2, max(Q.degree() - p.degree(), 0)))] for _ in range(7)])
        F = lam @ p.T
        Q = Q - F - F.T - PolyMatrix([[eps if i == j else zero for j in range(7)] for i in range(7)])
        prog.add_sos_matrix(Q, f"Lyapunov, cos q2 on the {label}", region=box, multiplier_degree=multiplier_degree,
                            label=f"q2 in {list(q2)}, w4 in {list(w4)}")
    try:
        sol = prog.solve(objective=-eps.C)
    except SOSError as exc:
        return BoxCertificate(q2, w4, False, str(exc), seconds=time.perf_counter() - t0)
    e = float(-sol.objective)
    checks = sos.certify(prog, sol)
    margin = _rigorous_margin(prog, checks, sol, e)
    Yx = Y.evaluate(np.zeros(2), sol.y)
    decay = e / (2 * float(np.linalg.eigvalsh(Yx).max()))
    ok = e > 0 and margin > 0 and all(c.certified for c in checks)
    msg = ("certified" if ok else
           f"not certified: eps = {e:.3g}, margin = {margin:.3g}, failed checks "
           f"{[c.name for c in checks if not c.certified]}")
    return BoxCertificate(q2, w4, ok, msg, e, decay, margin, L @ Yx @ L.T, checks, time.perf_counter() - t0)


def trig_check(loop: ClosedLoop, cert: BoxCertificate, n: int = 400, seed: int = 0) -> dict[str, float]:
    """The certificate on the true trigonometric model at ``n`` random points and the box's
    corners: the largest eigenvalue of ``N^T (Acl^T Y + Y Acl) N`` (N orthonormal complement of
    p; must be < 0) and the largest real part of the frozen modes off p4 against ``-decay``.

    Parameters
    ----------
    loop : ClosedLoop
        The closed loop the certificate is for.
    cert : BoxCertificate
        A solved certificate (with ``Y``).
    n : int, optional
        Number of random points in the box. Default 400.
    seed : int, optional
        Seed of the random generator. Default 0.

    Returns
    -------
    dict of str to float
        ``"samples"``, ``"max_lyapunov_eig"``, ``"max_re_off_p4"`` (1/s) and
        ``"decay_bound"`` (1/s).

    Raises
    ------
    ValueError
        If the certificate has no Lyapunov matrix.
    """
    if cert.Y is None:
        raise ValueError("no Lyapunov matrix: the box was not solved")
    rng = np.random.default_rng(seed)
    pts = np.column_stack([rng.uniform(*cert.q2, n), rng.uniform(*cert.w4, n)])
    pts = np.vstack([pts, [[a, b] for a in cert.q2 for b in cert.w4]])
    worst_lyap, worst_re = -np.inf, -np.inf
    for q2, w4 in pts:
        Acl = loop.matrix(q2, w4)
        p = loop.momentum_at(q2)
        N = sla.null_space(p[None, :])
        worst_lyap = max(worst_lyap, float(np.linalg.eigvalsh(N.T @ (Acl.T @ cert.Y + cert.Y @ Acl) @ N).max()))
        lam = np.linalg.eigvals(Acl)
        off = np.delete(lam, np.argmin(np.abs(lam)))  # the p4 mode sits at 0
        worst_re = max(worst_re, float(off.real.max()))
    return {"samples": len(pts), "max_lyapunov_eig": worst_lyap, "max_re_off_p4": worst_re,
            "decay_bound": cert.decay}


def map_region(loop: ClosedLoop, q2_edges: np.ndarray, w4_edges: np.ndarray,
               progress: Callable[[int, int, str], None] | None = None, **options: Any) -> list[BoxCertificate]:
    """:func:`certify` on every cell of the grid ``q2_edges`` x ``w4_edges`` (a map like the
    seed's Fig. 2; each cell has its own Y). ``progress(done, total, message)``. ``options`` go to
    :func:`certify` (``multiplier_degree``, ``trace_bound``).

    Parameters
    ----------
    loop : ClosedLoop
        The closed loop.
    q2_edges : numpy.ndarray
        Increasing gimbal-2 angles of the cell edges, rad, inside ``(0, pi/2)``.
    w4_edges : numpy.ndarray
        Increasing gimbal-4 rates of the cell edges, rad/s.
    progress : callable, optional
        ``progress(done, total, message)``, called after each cell.

    Returns
    -------
    list of BoxCertificate
        One per cell, q2 cells outer, w4 cells inner.
    """
    cells = [((float(a), float(b)), (float(c), float(d))) for a, b in zip(q2_edges[:-1], q2_edges[1:])
             for c, d in zip(w4_edges[:-1], w4_edges[1:])]
    out = []
    for k, (q2, w4) in enumerate(cells):
        cert = certify(loop, q2, w4, **options)
        out.append(cert)
        if progress:
            progress(k + 1, len(cells), f"q2 {q2[0]:.2f}..{q2[1]:.2f} w4 {w4[0]:+.2f}..{w4[1]:+.2f}: "
                                        f"{'certified' if cert.certified else 'not certified'} ({cert.seconds:.0f} s)")
    return out


def region_data(loop: ClosedLoop, box: BoxCertificate, trig: dict[str, float], cells: list[BoxCertificate]
                ) -> dict[str, Any]:
    """The region's JSON record: formulation, the operating box's certificate and its checks,
    the cos errors, and every cell of the map.

    Parameters
    ----------
    loop : ClosedLoop
        The closed loop (its artifact's name is recorded).
    box : BoxCertificate
        The certificate of the operating box.
    trig : dict of str to float
        Its :func:`trig_check` (empty if the box was not solved).
    cells : list of BoxCertificate
        The cells of :func:`map_region`.
    """
    return {"artifact": loop.artifact.name, "formulation": __doc__.split("What a certificate proves")[0].strip(),
            "variables": {"q2": "rad", "w4": "rad/s", "decay": "1/s"},
            "box": {**box.to_json(), "trig_check": trig, "cos": cos_errors(box.q2)},
            "cells": [c.to_json() for c in cells]}


def certify_operating_box(artifact: ServoArtifact) -> tuple[BoxCertificate, dict[str, float]]:
    """:func:`certify` on :data:`OPERATING_BOX` and its :func:`trig_check` (empty if not solved).

    Parameters
    ----------
    artifact : ServoArtifact
        The servo, scheduled on ``["sin(q2)", "w4"]``, on the default VSCMG model.
    """
    loop = ClosedLoop.build(artifact)
    cert = certify(loop, *OPERATING_BOX)
    return cert, (trig_check(loop, cert) if cert.Y is not None else {})


def artifact_certificate(fit_certificate: dict[str, Any], cert: BoxCertificate, trig: dict[str, float]
                         ) -> dict[str, Any]:
    """The artifact certificate: the fit's sampled checks plus what the region proved.

    Status ``certified`` only if the box is certified and the trigonometric samples agree
    (largest Lyapunov eigenvalue < 0, no frozen mode off p4 slower than the decay bound).

    Parameters
    ----------
    fit_certificate : dict
        The certificate of the gain fit (its ``"numbers"`` and ``"proved"`` are used).
    cert : BoxCertificate
        The region's certificate.
    trig : dict of str to float
        Its :func:`trig_check` (empty if the box was not solved).

    Returns
    -------
    dict
        The artifact's ``certificate`` entry.
    """
    sampled_ok = bool(trig) and trig["max_lyapunov_eig"] < 0 and trig["max_re_off_p4"] <= -trig["decay_bound"]
    ok = cert.certified and sampled_ok
    numbers = dict(fit_certificate["numbers"])
    numbers.update({"region_eps": cert.eps, "region_decay_bound": cert.decay, "region_margin": cert.margin,
                    **{f"region_trig_{k}": float(v) for k, v in trig.items()},
                    **{f"region_{k}": v for k, v in cos_errors(cert.q2).items()}})
    region = f"q2 in {list(cert.q2)} rad, w4 in {list(cert.w4)} rad/s (any w1, w2: the SDC freezes w2 := 0)"
    if ok:
        proved = (f"SOS certificate (satfmu.synthesis.servo.vscmg_region): on the box, "
                  f"every frozen closed loop Ae - Be K_fit "
                  f"of the w1-free SDC at w2 = 0 has its modes off the conserved-p4 mode decaying at >= "
                  f"{cert.decay:.3g} 1/s, with one common Lyapunov matrix; exact in sin/cos (enclosure), "
                  f"re-verified (Gram eigenvalues, residuals, margin {cert.margin:.3g}, "
                  f"{trig['samples']} samples of the trigonometric model). Also: {fit_certificate['proved']}")
        return {"status": "certified", "proved": proved, "region": region,
                "domain": [domain.interval("q2", *cert.q2), domain.interval("w4", *cert.w4)], "numbers": numbers}
    why = cert.message if not cert.certified else f"trigonometric samples disagree: {trig}"
    return {**fit_certificate, "proved": f"{fit_certificate['proved']}; SOS region NOT certified ({why})",
            "numbers": numbers}
