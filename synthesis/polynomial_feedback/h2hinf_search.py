"""Seed 001, Theorem 8: the search over the seed's scalars alpha and beta, and the gamma sweep.

:func:`search` minimizes the certified lambda of
:func:`satfmu.synthesis.polynomial_feedback.h2hinf_sos.theorem8` over alpha and beta at one gamma,
after :func:`screen` has checked the conditions' necessary part at the origin (frozen LMIs,
~0.2 s each), which refuses a gamma out of reach before any SOS program; :func:`sweep` runs the
search over gammas for both variants (the gamma-lambda trade-off of docs/models.md, "Seed 001").
"""
from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.optimize import minimize_scalar

from satfmu.fmus.model import Model
from satfmu.fmus.plants import mrp_satellite
from satfmu.synthesis.core.progress import Progress
from satfmu.synthesis.core.sos import SOSError
from satfmu.synthesis.polynomial_feedback.coordinates import Coordinates
from satfmu.synthesis.polynomial_feedback.h2hinf_sos import VARIANTS, Theorem8Result, _psd_margin, theorem8
from satfmu.synthesis.polynomial_feedback.split_plant import split

LOG = logging.getLogger(__name__)

_REJECTED = 1e12
"""Objective given to the line search for an infeasible or uncertified point."""


SCREEN_POINTS = 7
"""Values of ``alpha = beta`` of the screen (:func:`screen`), log-spaced over the search bounds."""
FLOOR_STEPS = 8
"""Quadruplings of gamma the screen tries to find the linearization's gamma floor."""


@dataclass
class Screen:
    """Theorem 8 at the origin (A frozen, LMIs) before any SOS solve: a necessary condition.

    At ``x~ = 0`` every SOS-matrix condition of
    :func:`satfmu.synthesis.polynomial_feedback.h2hinf_sos.theorem8` reduces to the frozen LMIs with
    the same margins (the multiplier terms are positive semidefinite there), so where the frozen
    program is infeasible so is the SOS program, on every region. Each frozen solve takes ~0.2 s.

    Attributes
    ----------
    gamma : float
        The L2-gain bound screened (N m -> 1).
    alphas : numpy.ndarray
        The values of ``alpha = beta`` tried, s.
    lam : numpy.ndarray
        The frozen lambda at each (inf: infeasible): a lower bound of the SOS design's lambda.
    gamma_floor : float or None
        When no alpha is feasible: the smallest gamma found feasible at the origin (within a
        factor 4^(1/32)), None if none up to ``gamma 4^FLOOR_STEPS``.
    floor_alpha : float or None
        The alpha = beta of that floor, s.
    seconds : float
        Time taken, s.
    """

    gamma: float
    alphas: np.ndarray
    lam: np.ndarray
    gamma_floor: float | None
    floor_alpha: float | None
    seconds: float

    @property
    def feasible(self) -> bool:
        """Some alpha passed the necessary condition."""
        return bool(np.isfinite(self.lam).any())

    def bounds(self) -> tuple[float, float]:
        """The alpha range worth searching: the feasible alphas widened by one grid step, s."""
        ok = np.flatnonzero(np.isfinite(self.lam))
        lo, hi = max(ok.min() - 1, 0), min(ok.max() + 1, len(self.alphas) - 1)
        return float(self.alphas[lo]), float(self.alphas[hi])

    def reason(self) -> str:
        """Why no design can be certified (the screen failed), with what would change it."""
        tried = (f"alpha = beta in [{self.alphas[0]:.3g}, {self.alphas[-1]:.3g}] s "
                 f"({len(self.alphas)} values)")
        head = (f"Theorem 8 fails at the origin: its linearization (A frozen at x = 0, a necessary "
                f"condition of the SOS conditions on any region) is infeasible at gamma = {self.gamma:g} for {tried}")
        if self.gamma_floor is None:
            return (f"{head}, and still at gamma = {self.gamma * 4**FLOOR_STEPS:g}: the plant or the weights "
                    f"do not suit Theorem 8")
        return (f"{head}; it is feasible from gamma = {self.gamma_floor:.4g} "
                f"(alpha = beta = {self.floor_alpha:.3g} s). Choose gamma >= {self.gamma_floor:.4g}; "
                f"a smaller region cannot help")


def _frozen_lam(gamma: float, a: float, variant: str, kwargs: dict[str, Any]) -> float:
    try:
        r = theorem8(gamma, a, a, variant, **{**kwargs, "frozen": True, "y_degree": 0})
    except SOSError:
        return float("inf")
    return r.lam if r.certified else float("inf")


def screen(gamma: float, variant: str = "slack", bounds: tuple[float, float] | None = None,
           points: int = SCREEN_POINTS, **kwargs: Any) -> Screen:
    """Check Theorem 8's necessary condition at the origin over the alpha range (:class:`Screen`).

    Parameters
    ----------
    gamma : float
        L2-gain bound (N m -> 1).
    variant : {"slack", "common"}, optional
        The design variant. Default ``"slack"``.
    bounds : tuple of (float, float), optional
        The alpha range, s (default :func:`default_bounds`).
    points : int, optional
        Values of ``alpha = beta`` tried, log-spaced. Default :data:`SCREEN_POINTS`.
    **kwargs
        Passed to :func:`satfmu.synthesis.polynomial_feedback.h2hinf_sos.theorem8`
        (``model``, ``Qh``, ``Rh``, ``x0``, ``margin``; ``frozen`` and
        ``y_degree`` are set here, ``region`` and ``multiplier_degree`` unused).

    Returns
    -------
    Screen
        The frozen lambda per alpha and, if none is feasible, the gamma floor.
    """
    t0 = time.perf_counter()
    kw = {k: v for k, v in kwargs.items() if k not in ("frozen", "y_degree", "multiplier_degree")}
    bounds = default_bounds(kw.get("model"), kw.get("Qh"), kw.get("Rh")) if bounds is None else bounds
    alphas = np.logspace(np.log10(bounds[0]), np.log10(bounds[1]), points)
    lam = np.array([_frozen_lam(gamma, a, variant, kw) for a in alphas])
    floor = floor_alpha = None
    if not np.isfinite(lam).any():
        low = gamma
        for _ in range(FLOOR_STEPS):
            g = low * 4
            feasible = [a for a in alphas if np.isfinite(_frozen_lam(g, a, variant, kw))]
            if feasible:
                floor_alpha, high = feasible[0], g
                for _ in range(5):  # bisection in log gamma at that alpha: within 4^(1/32)
                    mid = float(np.sqrt(low * high))
                    low, high = (low, mid) if np.isfinite(_frozen_lam(mid, floor_alpha, variant, kw)) else (mid, high)
                floor = float(high)
                break
            low = g
    return Screen(float(gamma), alphas, lam, floor, None if floor_alpha is None else float(floor_alpha),
                  time.perf_counter() - t0)


def default_bounds(model: Model | None = None, Qh: np.ndarray | None = None,
                   Rh: np.ndarray | None = None) -> tuple[float, float]:
    """The default range of alpha and beta for ``model``: ``(0.01, 1) / rate``, s.

    ``rate`` is the plant's balanced rate unit (:meth:`Coordinates.balanced`): ``1 / rate`` is
    the time its LQR turns one radian in, so the range follows the plant's time scale (seed
    000's satellite: 0.019 to 1.9 s; a 0.01 kg m^2 cubesat: 0.00085 to 0.085 s).

    Parameters
    ----------
    model : Model, optional
        The plant (default the MRP satellite).
    Qh, Rh : numpy.ndarray, optional
        The H2 weights (default identities).

    Returns
    -------
    tuple of (float, float)
        ``(low, high)``, s.
    """
    plant = split(mrp_satellite.MODEL if model is None else model, frozen=True)
    Qh = np.eye(plant.n) if Qh is None else np.asarray(Qh, float)
    Rh = np.eye(plant.m) if Rh is None else np.asarray(Rh, float)
    rate = Coordinates.balanced(plant, Qh, Rh, 1.0, 1.0).rate
    return 0.01 / rate, 1.0 / rate


def _failed_check(r: Theorem8Result) -> str:
    """The first check ``r`` failed, with its numbers."""
    bad = [c for c in r.checks if not c.certified]
    if bad:
        return f"{bad[0].name}: min eig {bad[0].min_eig:.1e}, residual {bad[0].residual:.1e}"
    return f"PSD margin {_psd_margin(r):.1e}"


@dataclass
class SearchResult:
    """Best design over alpha, beta at one gamma, with every evaluated point.

    Attributes
    ----------
    best : Theorem8Result or None
        The certified design of smallest lambda (None: no evaluation gave one).
    evaluations : list of tuple of (float, float, float)
        Every SDP solved (below).
    screen : Screen or None
        The screen at the origin run first (None when skipped).
    notes : list of str
        Per evaluation: ``"certified"``, ``"infeasible"`` or why the solution was not certified.
    """

    best: Theorem8Result | None
    evaluations: list[tuple[float, float, float]]
    """``(alpha, beta, lambda)`` per SDP (lambda inf where infeasible or not certified)."""
    screen: Screen | None = None
    notes: list[str] = field(default_factory=list)

    def reason(self) -> str:
        """Why no design was certified, and what would change it (empty when one was)."""
        if self.best is not None:
            return ""
        if self.screen is not None and not self.screen.feasible:
            return self.screen.reason()
        uncertified = [n for n in self.notes if n.startswith("not certified")]
        text = (f"{len(self.evaluations)} SOS programs over alpha, beta: "
                f"{self.notes.count('infeasible')} infeasible, {len(uncertified)} solved but not certified"
                + (f" ({uncertified[0]})" if uncertified else ""))
        if self.screen is not None:
            k = int(np.argmin(self.screen.lam))
            text += (f"; they hold at the origin (frozen lambda {self.screen.lam[k]:.4g} at alpha = "
                     f"{self.screen.alphas[k]:.3g} s), so the region is what fails: a smaller region or a larger "
                     f"gamma may be certified")
        return text


def search(gamma: float, variant: str = "slack", bounds: tuple[float, float] | None = None,
           xatol: float = 0.1, max_evaluations: int = 20, progress: Progress | None = None,
           screened: bool = True, **kwargs: Any) -> SearchResult:
    """Minimize the certified lambda over alpha and beta (one SDP per evaluation).

    First the screen at the origin (:func:`screen`, ~0.2 s per point): where it fails no SOS
    program is solved and the result says why (:meth:`SearchResult.reason`); otherwise the
    search runs over the alphas it passed (widened by a grid step). Then golden section (Brent,
    bounded) on ``log10 alpha`` with ``beta = alpha``, then on ``log10 beta`` at the best alpha;
    ``xatol`` in decades. Infeasible, failed and uncertified SDPs count as rejected. ``kwargs``
    go to :func:`satfmu.synthesis.polynomial_feedback.h2hinf_sos.theorem8`.

    Parameters
    ----------
    gamma : float
        L2-gain bound to certify (N m -> 1), as in :func:`satfmu.synthesis.polynomial_feedback.h2hinf_sos.theorem8`.
    variant : {"slack", "common"}, optional
        The design variant (:func:`satfmu.synthesis.polynomial_feedback.h2hinf_sos.theorem8`). Default ``"slack"``.
    bounds : tuple of (float, float), optional
        ``(low, high)`` range of alpha and of beta, ``0 < low < high``, s. Default
        :func:`default_bounds` of the plant.
    xatol : float, optional
        Tolerance of each line search in ``log10`` of alpha or beta (decades). Default 0.1.
    max_evaluations : int, optional
        Most SDPs solved, both line searches together. Default 20.
    progress : callable, optional
        ``progress(done, total, message)``: after the screen and after each SDP (its alpha,
        beta, outcome and time, and the best lambda so far; also logged at INFO), and once at
        the end.
    screened : bool, optional
        Run :func:`screen` first (False: search the whole range). Default True.
    **kwargs
        Passed to :func:`satfmu.synthesis.polynomial_feedback.h2hinf_sos.theorem8`.

    Returns
    -------
    SearchResult
        The best certified design and every evaluation.

    Raises
    ------
    ValueError
        If ``bounds`` is not ``0 < low < high``.
    """
    if bounds is None:
        bounds = default_bounds(kwargs.get("model"), kwargs.get("Qh"), kwargs.get("Rh"))
    if not (0 < bounds[0] < bounds[1] and np.all(np.isfinite(bounds))):
        raise ValueError(f"bounds must satisfy 0 < low < high, got {bounds}")
    evaluations: list[tuple[float, float, float]] = []
    notes: list[str] = []
    best: list[Theorem8Result] = []
    checked = None
    head = f"{variant}, gamma = {gamma:g}"

    def report(message: str) -> None:
        LOG.info("%s: %s", head, message)
        if progress is not None:
            progress(len(evaluations), max_evaluations, f"{head}: {message}")

    if screened and not kwargs.get("frozen", False):
        checked = screen(gamma, variant, bounds, **kwargs)
        if not checked.feasible:
            report(f"screen at the origin failed ({checked.seconds:.1f} s)")
            return SearchResult(None, [], checked, [])
        bounds = checked.bounds()
        report(f"screen at the origin passed ({checked.seconds:.1f} s): alpha in [{bounds[0]:.3g}, "
               f"{bounds[1]:.3g}] s")

    def solve(a: float, b: float) -> float:
        if len(evaluations) >= max_evaluations:
            return _REJECTED
        t0 = time.perf_counter()
        try:
            r: Theorem8Result | None = theorem8(gamma, a, b, variant, **kwargs)
            notes.append("certified")
        except SOSError:
            r = None
            notes.append("infeasible")
        if r is not None and not r.certified:
            notes[-1] = f"not certified: {_failed_check(r)}"
            r = None
        evaluations.append((a, b, r.lam if r is not None else float("inf")))
        if r is not None and (not best or r.lam < best[0].lam):
            best[:] = [r]
        outcome = f"lambda {r.lam:.4g}" if r is not None else notes[-1]
        report(f"SDP {len(evaluations)}: alpha = {a:.3g} s, beta = {b:.3g} s: {outcome} "
               f"({time.perf_counter() - t0:.1f} s)" + (f"; best lambda {best[0].lam:.4g}" if best else ""))
        return r.lam if r is not None else _REJECTED

    lo, hi = np.log10(bounds)
    opts = {"xatol": xatol, "maxiter": max_evaluations}
    minimize_scalar(lambda t: solve(10**t, 10**t), bounds=(lo, hi), method="bounded", options=opts)
    if best:
        a = best[0].alpha
        minimize_scalar(lambda t: solve(a, 10**t), bounds=(lo, hi), method="bounded", options=opts)
    if progress is not None:
        progress(max_evaluations, max_evaluations, "done")
    return SearchResult(best[0] if best else None, evaluations, checked, notes)


@dataclass(frozen=True)
class SweepRow:
    """One point of the gamma-lambda trade-off (lambda inf: no certified design).

    Attributes
    ----------
    gamma : float
        The L2-gain bound (N m -> 1).
    variant : {"slack", "common"}
        The design variant.
    lam : float
        The smallest certified H2 bound lambda (inf if none).
    alpha, beta : float
        The seed's scalars of that design (nan if none).
    n_sdps : int
        SDPs solved by the search.
    """

    gamma: float
    variant: str
    lam: float
    alpha: float
    beta: float
    n_sdps: int


def sweep(gammas: list[float], bounds: tuple[float, float] | None = None, max_evaluations: int = 12,
          progress: Progress | None = None, **kwargs: Any) -> list[SweepRow]:
    """:func:`search` at every gamma for both variants (``kwargs`` go to
    :func:`satfmu.synthesis.polynomial_feedback.h2hinf_sos.theorem8`).

    Parameters
    ----------
    gammas : list of float
        The L2-gain bounds (N m -> 1), each finite and > 0; searched from the largest down.
    bounds : tuple of (float, float), optional
        ``(low, high)`` range of alpha and beta, s (:func:`search`). Default
        :func:`default_bounds` of the plant.
    max_evaluations : int, optional
        Most SDPs per search. Default 12.
    progress : callable, optional
        ``progress(done, total, message)`` over all the searches.

    Returns
    -------
    list of SweepRow
        One row per gamma (decreasing) and variant.

    Raises
    ------
    ValueError
        If ``gammas`` is empty or holds a value that is not finite and > 0.
    """
    if not gammas or any(not (np.isfinite(g) and g > 0) for g in gammas):
        raise ValueError(f"gammas must be finite and > 0, got {gammas}")
    rows = []
    jobs = [(g, v) for g in sorted(gammas, reverse=True) for v in VARIANTS]
    for k, (g, v) in enumerate(jobs):
        def report(done: int, total: int, msg: str, k: int = k) -> None:
            if progress is not None:
                progress(k * total + done, len(jobs) * total, msg)
        found = search(g, v, bounds, max_evaluations=max_evaluations, progress=report, **kwargs)
        b = found.best
        rows.append(SweepRow(g, v, b.lam if b else float("inf"), b.alpha if b else float("nan"),
                             b.beta if b else float("nan"), len(found.evaluations)))
    return rows


def sweep_csv(rows: list[SweepRow]) -> str:
    """The sweep as CSV text (``lambda`` empty where no design was certified).

    Parameters
    ----------
    rows : list of SweepRow
        The points of :func:`sweep`, written in their order.
    """
    lines = ["gamma,variant,lambda,alpha,beta,sdps"]
    for r in rows:
        lam = f"{r.lam:.6f}" if np.isfinite(r.lam) else ""
        ab = f"{r.alpha:.4g},{r.beta:.4g}" if np.isfinite(r.lam) else ","
        lines.append(f"{r.gamma:g},{r.variant},{lam},{ab},{r.n_sdps}")
    return "\n".join(lines) + "\n"
