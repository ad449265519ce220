"""L2 gain of a polynomial closed loop from the Hamilton-Jacobi inequality (seed 000, step 2).

For the plant ``x' = f(x, u, w)`` closed by a polynomial law ``u(x)`` (saturation off,
``w`` the disturbance torque) and ``V = kv x^T P x`` (``P`` from the controller's
Lyapunov certificate), the closed loop has L2 gain ``<= c`` from ``w`` to
``z = C1 x`` (``C1 = q2 [0 I3]``: the MRP attitude) on a region where

::

    H(x) = V_x f(x, u(x), 0) + 1/(4 c^2) |B1^T V_x^T|^2 + |C1 x|^2 <= 0,   B1 = df/dw

(seed 000 eq. 40 with the inequality of eq. 43). Write ``V0 = x^T P x`` and

::

    a(x) = -dV0/dx f        (decay of V0),
    b(x) = |B1^T dV0/dx^T|^2,
    z(x) = |C1 x|^2,

then ``H <= 0`` is ``kv a - z >= kv^2 b / (4 c^2)``, i.e. at each point ``x``
``c >= c(x; kv) = kv sqrt(b / (4 (kv a - z)))`` (infinite where ``kv a <= z``, ``b > 0``).
Three estimates of ``c_min = min_kv max_x c(x; kv)``:

- :func:`diagonal_gain`: the paper's method, ``x_1 = ... = x_6 = t`` for ``t`` in
  [-10, 10] on 2e4 points. A lower bound (a line, not the region).
- :func:`sampled_gain`: dense uniform sampling of a declared :class:`Region` plus local
  maximization of ``c(x; kv)`` from the worst samples. A lower bound, region-wide.
- :func:`sos_gain`: with ``alpha = 1/kv``, ``beta = kv / (4 c^2)`` the inequality
  ``a - alpha z - beta b >= 0`` on the region is linear in ``(alpha, beta)``; for each
  ``alpha`` the largest ``beta`` is one SOS program (S-procedure on the region), and
  ``c = 1 / (2 sqrt(alpha beta))`` is minimized over ``alpha`` by golden section. An upper
  bound, certified (independently verified) when it exists.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np
import scipy.sparse as sps
import sympy as sp
from scipy.optimize import minimize, minimize_scalar

from satfmu.controllers.artifact import ControllerArtifact
from satfmu.fmus.plants import mrp_satellite
from satfmu.fmus.model import Model
from satfmu.synthesis.core.polynomial import Poly
from satfmu.synthesis.core.sos import Check, SOSError, SOSProgram, certify

KV_GRID = np.logspace(-2, 9, 111)
"""Default kv search grid (log-spaced; refined by a bounded scalar search)."""


@dataclass(frozen=True)
class Region:
    """Box ``|omega_i| <= rate_max`` (rad/s) times ball ``|sigma| <= sigma_max`` (MRP, 1).

    Attributes
    ----------
    rate_max : float
        Bound on each body rate ``|omega_i|``, rad/s (finite, > 0).
    sigma_max : float
        Bound on the MRP norm ``|sigma|``, dimensionless (finite, > 0).

    Raises
    ------
    ValueError
        If a bound is not finite and > 0.
    """

    rate_max: float
    sigma_max: float

    def __post_init__(self) -> None:
        for name in ("rate_max", "sigma_max"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v > 0):
                raise ValueError(f"Region.{name} must be finite and > 0, got {v}")

    @property
    def label(self) -> str:
        """The region in words, e.g. ``"|omega_i| <= 0.1 rad/s, |sigma| <= 0.5"``."""
        return f"|omega_i| <= {self.rate_max:g} rad/s, |sigma| <= {self.sigma_max:g}"

    def polys(self) -> list[Poly]:
        """Region as ``g_k(x) >= 0`` in x = (omega, sigma)."""
        n = 6
        out = []
        for i in range(3):
            e = np.zeros((2, n), np.int64)
            e[1, i] = 2
            out.append(Poly.numeric(e, np.array([self.rate_max**2, -1.0])))
        e = np.zeros((4, n), np.int64)
        for k, i in enumerate((3, 4, 5)):
            e[k + 1, i] = 2
        out.append(Poly.numeric(e, np.array([self.sigma_max**2, -1.0, -1.0, -1.0])))
        return out

    def sample(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """``n`` points uniform in the region, shape (n, 6).

        Parameters
        ----------
        n : int
            Number of points.
        rng : numpy.random.Generator
            The random generator drawn from.

        Returns
        -------
        numpy.ndarray, shape (n, 6)
            The points ``x = (omega, sigma)``, rates in rad/s.
        """
        w = rng.uniform(-self.rate_max, self.rate_max, size=(n, 3))
        s = rng.normal(size=(n, 3))
        s *= (self.sigma_max * rng.random(n) ** (1 / 3) / np.linalg.norm(s, axis=1))[:, None]
        return np.hstack([w, s])

    def to_json(self) -> dict[str, Any]:
        """The region as a JSON-ready dict: the two bounds and :attr:`label`."""
        return {"rate_max_rad_s": self.rate_max, "sigma_max": self.sigma_max, "label": self.label}


@dataclass
class HJIForm:
    """The polynomials ``a``, ``b``, ``z`` of the Hamilton-Jacobi inequality of one closed loop.

    In the state ``x = (omega, sigma)`` (rad/s, MRP), with ``V0 = x^T P x`` (module docstring).

    Attributes
    ----------
    a : satfmu.synthesis.core.polynomial.Poly
        ``a(x) = -dV0/dx f``, the decay of ``V0`` along the closed loop without disturbance.
    b : satfmu.synthesis.core.polynomial.Poly
        ``b(x) = |B1^T dV0/dx^T|^2``, the disturbance term.
    z : satfmu.synthesis.core.polynomial.Poly
        ``z(x) = |C1 x|^2``, the squared performance output.
    controller : str
        Name of the controller artifact closing the loop.
    """

    a: Poly
    b: Poly
    z: Poly
    controller: str

    def values(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``a``, ``b``, ``z`` at the points ``X`` (shape (m, n)).

        Parameters
        ----------
        X : numpy.ndarray, shape (m, n) or (n,)
            The states ``x = (omega, sigma)`` (rad/s, MRP), one per row.
        """
        X = np.atleast_2d(X)
        return self.a.evaluate(X), self.b.evaluate(X), self.z.evaluate(X)

    def point(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(a, b, z)`` at one point and their gradients (3 x n), from compiled code.

        Parameters
        ----------
        x : numpy.ndarray, shape (n,)
            The state ``(omega, sigma)`` (rad/s, MRP).
        """
        if "_compiled" not in self.__dict__:
            xs = sp.symbols(f"x0:{self.a.n_vars}", real=True)
            exprs = [p.to_sympy(xs) for p in (self.a, self.b, self.z)]
            grads = [[sp.diff(e, v) for v in xs] for e in exprs]
            self.__dict__["_compiled"] = (sp.lambdify([xs], exprs, "numpy", cse=True),
                                          sp.lambdify([xs], grads, "numpy", cse=True))
        f, g = self.__dict__["_compiled"]
        return np.array(f(x), float), np.array(g(x), float)

    def origin_c(self, kv: float) -> float:
        """``lim sup c(x; kv)`` as ``x -> 0``: from the quadratic parts ``a_2, b_2, z_2``,
        ``kv^2/4 * lambda_max(B_2, kv A_2 - Z_2)`` (inf unless ``kv A_2 - Z_2 > 0``).

        Parameters
        ----------
        kv : float
            Scale of the storage function ``V = kv V0`` (> 0).
        """
        A2, B2, Z2 = (quadratic_part(p) for p in (self.a, self.b, self.z))
        try:
            L = np.linalg.cholesky(kv * A2 - Z2)
        except np.linalg.LinAlgError:
            return float("inf")
        Li = np.linalg.inv(L)
        lam = float(np.linalg.eigvalsh(Li @ B2 @ Li.T).max())
        return float(kv * np.sqrt(max(lam, 0.0) / 4.0))

    def c_at(self, X: np.ndarray, kv: float) -> np.ndarray:
        """Pointwise least ``c`` with ``H <= 0`` (0 where any c works, inf where none does).

        Parameters
        ----------
        X : numpy.ndarray, shape (m, n) or (n,)
            The states ``x = (omega, sigma)`` (rad/s, MRP), one per row.
        kv : float
            Scale of the storage function ``V = kv V0`` (> 0).

        Returns
        -------
        numpy.ndarray, shape (m,)
            ``c(x; kv)`` at each point.
        """
        return _c_from(*self.values(X), kv)

    def c_max(self, X: np.ndarray, kv: float) -> float:
        """``max_x c(x; kv)`` over the points ``X``.

        Parameters
        ----------
        X : numpy.ndarray, shape (m, n) or (n,)
            The states ``x = (omega, sigma)`` (rad/s, MRP), one per row.
        kv : float
            Scale of the storage function ``V = kv V0`` (> 0).
        """
        return float(np.max(self.c_at(X, kv)))


def _c_from(a: np.ndarray, b: np.ndarray, z: np.ndarray, kv: float) -> np.ndarray:
    num = kv * a - z
    with np.errstate(divide="ignore", invalid="ignore"):
        c = kv * np.sqrt(b / (4.0 * num))
    c = np.where(num > 0, c, np.inf)
    return np.where(b > 0, c, np.where(num >= 0, 0.0, np.inf))


def hji_form(artifact: ControllerArtifact, plant: Model | None = None, q2: float = 1.0,
             lyapunov_P: np.ndarray | None = None) -> HJIForm:
    """Build ``a``, ``b``, ``z`` for ``plant`` closed by ``artifact``'s law (saturation off).

    ``P`` is the inverse of the artifact's Lyapunov ``Q`` unless ``lyapunov_P`` is given.

    Parameters
    ----------
    artifact : satfmu.controllers.artifact.ControllerArtifact
        The polynomial state feedback; its states must be the plant's, in order.
    plant : Model, optional
        The plant, with command inputs ``u`` and disturbance inputs ``w_d`` entering affinely
        (default the MRP satellite, ``satfmu.fmus.plants.mrp_satellite.MODEL``).
    q2 : float, optional
        Weight of the MRPs in the performance output, ``z = q2 sigma``. Default 1.
    lyapunov_P : numpy.ndarray, shape (n, n), optional
        The matrix ``P`` of ``V0 = x^T P x``; default the inverse of the artifact's ``Q``.

    Raises
    ------
    ValueError
        If the artifact has no Lyapunov matrix, its states differ from the plant's, or the
        disturbance does not enter affinely with a constant input matrix.
    """
    plant = mrp_satellite.MODEL if plant is None else plant
    names = [s.variable.name for s in plant.states]
    if [s["name"] for s in artifact.states] != names:
        raise ValueError(f"controller {artifact.name!r} measures {[s['name'] for s in artifact.states]}, "
                         f"plant {plant.name!r} has states {names}")
    if lyapunov_P is None:
        if "Q" not in artifact.lyapunov:
            raise ValueError(f"controller {artifact.name!r} records no Lyapunov matrix Q; pass lyapunov_P")
        lyapunov_P = np.linalg.inv(np.asarray(artifact.lyapunov["Q"], float))
    P = sp.Matrix(np.asarray(lyapunov_P, float))
    x = sp.Matrix([s.symbol for s in plant.states])
    subs = {v.symbol: v.start for v in plant.parameters}
    subs[sp.Symbol("saturation_on", real=True)] = 0
    u_syms = [v.symbol for v in plant.inputs if v.base_name == "u"]
    w_syms = [v.symbol for v in plant.inputs if v.base_name == "w_d"]
    law = [sp.Add(*[sp.Float(t.c, 17) * sp.Mul(*[xi ** e for xi, e in zip(x, t.e)]) for t in terms])
           for terms in artifact.terms]
    rhs = plant.rhs.subs(subs)
    B1 = rhs.jacobian(w_syms)
    if any(sp.simplify(e).free_symbols for e in B1):
        raise ValueError("the disturbance input matrix depends on the state; expected constant B1")
    f = rhs.subs(dict(zip(u_syms, law))).subs({w: 0 for w in w_syms})
    grad = 2 * P * x                       # dV0/dx^T
    n = len(names)
    m = len(w_syms)
    C1 = sp.Matrix(sp.BlockMatrix([[sp.zeros(n - m, m), q2 * sp.eye(n - m)]]))
    xs = list(x)
    bw = B1.T * grad
    cz = C1 * x
    a, b, z = (_drop_rounding(Poly.from_sympy(e, xs))
               for e in (-(grad.T * f)[0], (bw.T * bw)[0], (cz.T * cz)[0]))
    return HJIForm(a, b, z, artifact.name)


def _drop_rounding(p: Poly, rel: float = 1e-14) -> Poly:
    """Drop coefficients below ``rel`` times the largest: products of round-off (e.g. the
    1e-17 off-diagonal of a numerically inverted diagonal Q) that would only enlarge the
    Gram basis. The change is below double-precision resolution of the polynomial."""
    keep = np.abs(p.c0) > rel * np.max(np.abs(p.c0), initial=0.0)
    return Poly.numeric(p.exps[keep], p.c0[keep])


def best_kv(c_of_kv: Callable[[float], float], grid: np.ndarray = KV_GRID) -> tuple[float, float]:
    """``(kv, c)`` minimizing ``c_of_kv`` over the log grid, refined by a bounded scalar search.

    Parameters
    ----------
    c_of_kv : callable
        ``c_of_kv(kv) -> float``, the gain estimate at one scale ``kv`` of ``V`` (inf where
        none exists).
    grid : numpy.ndarray, optional
        Increasing positive kv values, log-spaced (default :data:`KV_GRID`); the search
        refines between the neighbours of the best one.
    """
    vals = np.array([c_of_kv(k) for k in grid])
    i = int(np.argmin(vals))
    if not np.isfinite(vals[i]):
        return float(grid[i]), float("inf")
    lo, hi = np.log10(grid[max(i - 1, 0)]), np.log10(grid[min(i + 1, len(grid) - 1)])
    res = minimize_scalar(lambda t: c_of_kv(10.0**t), bounds=(lo, hi), method="bounded",
                          options={"xatol": 1e-4})
    if res.fun < vals[i]:
        return float(10.0**res.x), float(res.fun)
    return float(grid[i]), float(vals[i])


def diagonal_points(t_max: float = 10.0, n_points: int = 20_000, n_states: int = 6) -> np.ndarray:
    """The paper's diagonal ``x_i = t`` (every i), ``t`` in [-t_max, t_max] (t = 0 left out).

    Parameters
    ----------
    t_max : float, optional
        End of the diagonal, in the units of every state (rad/s for the rates, 1 for the
        MRPs). Default 10.
    n_points : int, optional
        Number of values of ``t``, evenly spaced (before ``t = 0`` is dropped). Default 20000.
    n_states : int, optional
        Number of states ``n``. Default 6.

    Returns
    -------
    numpy.ndarray, shape (n_points, n_states) or (n_points - 1, n_states)
        One point per row.
    """
    t = np.linspace(-t_max, t_max, n_points)
    t = t[t != 0.0]
    return np.repeat(t[:, None], n_states, axis=1)


def diagonal_gain(form: HJIForm, kv: float | None = None, t_max: float = 10.0,
                  n_points: int = 20_000) -> tuple[float, float]:
    """Seed 000's graphical method: ``(max_t c(t 1; kv), kv)`` along the diagonal.

    With ``kv=None`` kv is chosen to minimize that maximum.

    Parameters
    ----------
    form : HJIForm
        The closed loop's inequality.
    kv : float, optional
        Scale of ``V = kv V0``; None: chosen by :func:`best_kv`.
    t_max : float, optional
        End of the diagonal, ``t`` in [-t_max, t_max] (:func:`diagonal_points`). Default 10.
    n_points : int, optional
        Number of values of ``t``. Default 20000.

    Returns
    -------
    c : float
        The largest ``c(t 1; kv)`` on the diagonal, the L2-gain estimate from ``w`` (N m)
        to ``z``.
    kv : float
        The scale used.
    """
    abz = form.values(diagonal_points(t_max, n_points, form.a.n_vars))
    if kv is None:
        kv, c = best_kv(lambda k: float(np.max(_c_from(*abz, k))))
        return c, kv
    return float(np.max(_c_from(*abz, kv))), float(kv)


@dataclass
class SampledGain:
    """Region-wide sampled estimate (a lower bound on the true c_min for that region).

    Attributes
    ----------
    c : float
        Largest ``c(x; kv)`` found, the limit at the origin included: the L2-gain estimate
        from ``w`` (N m) to ``z`` (inf: no finite gain from this V on this region).
    kv : float
        The scale of ``V = kv V0`` used.
    c_random : float
        Largest ``c`` over the random points (below).
    n_samples : int
        Number of random points (those at the origin left out).
    worst_point : list of float
        The state ``(omega, sigma)`` (rad/s, MRP) where ``c`` is largest, or where the decay
        fails when ``c`` is infinite.
    violated_fraction : float
        Share of the points with no finite ``c`` (below).
    origin_c : float
        Limit of ``c`` at the origin (below).
    note : str, optional
        Why ``c`` is infinite, empty otherwise.
    """

    c: float
    kv: float
    c_random: float
    """Before the local maximization."""
    n_samples: int
    worst_point: list[float]
    violated_fraction: float
    """Share of the points (random and adversarial) where ``kv a <= z`` (no finite c at this kv)."""
    origin_c: float
    """The limit of ``c(x; kv)`` at the origin (quadratic parts), part of ``c``."""
    note: str = ""

    def to_json(self) -> dict[str, Any]:
        """The estimate as a JSON-ready dict of its fields."""
        return dict(self.__dict__)


def sampled_gain(form: HJIForm, region: Region, kv: float | None = None, n_samples: int = 200_000,
                 n_starts: int = 8, rounds: int = 6, seed: int = 0) -> SampledGain:
    """Dense random plus adversarial (local optimizer) estimate of ``max_x c(x; kv)`` on ``region``,
    together with the exact limit at the origin (:meth:`HJIForm.origin_c`), where sampling
    cannot reach.

    Each round: choose kv minimizing the maximum over the current points (unless ``kv``
    is given; never below ``1 / alpha_limit``, under which ``H > 0`` next to the origin),
    then from the ``n_starts`` worst points run SLSQP (region as constraints) twice: to
    minimize the decay margin ``(kv a - z)/|x|^2`` (negative: no finite c at all) and to
    maximize ``c(x; kv)``. Points that beat the sample maximum join the set and the next
    round re-chooses kv; the loop ends when the optimizer finds nothing worse.

    Parameters
    ----------
    form : HJIForm
        The closed loop's inequality.
    region : Region
        The region sampled and searched.
    kv : float, optional
        Scale of ``V = kv V0``; None: chosen in each round and for the final point set.
    n_samples : int, optional
        Number of uniform random points. Default 200000.
    n_starts : int, optional
        Number of worst points the local optimizer starts from in each round. Default 8.
    rounds : int, optional
        Most rounds of local search. Default 6.
    seed : int, optional
        Seed of the random generator. Default 0.
    """
    rng = np.random.default_rng(seed)
    X = region.sample(n_samples, rng)
    X = X[np.linalg.norm(X, axis=1) > 1e-9]
    n_random = len(X)
    a_lim = alpha_limit(form)
    # below 1/alpha_limit H > 0 next to the origin: search kv from just above it
    grid = np.geomspace(1.0 / a_lim * (1 + 1e-6), 1e6 / a_lim, 81) if a_lim > 0 else KV_GRID
    cons = [{"type": "ineq", "fun": lambda x: region.sigma_max**2 - x[3:] @ x[3:]}]
    bounds = [(-region.rate_max, region.rate_max)] * 3 + [(None, None)] * 3

    def inside(x: np.ndarray) -> bool:
        return bool(np.linalg.norm(x) > 1e-6 and x[3:] @ x[3:] <= region.sigma_max**2 * (1 + 1e-9))

    def search(starts: np.ndarray, objective: Callable[[np.ndarray], tuple[float, np.ndarray]]
               ) -> list[np.ndarray]:
        found = []
        for x0 in starts:
            res = minimize(objective, x0, jac=True, method="SLSQP", bounds=bounds, constraints=cons,
                           options={"maxiter": 200, "ftol": 1e-14})
            if inside(res.x):
                found.append(res.x)
        return found

    abz = form.values(X)

    def c_of_kv(q: float) -> float:
        return max(float(np.max(_c_from(*abz, q))), form.origin_c(q))

    c_random = float("nan")
    k = float(kv) if kv is not None else float(grid[0])
    witness = None
    for r in range(rounds):
        if kv is None:
            k_new, c_new = best_kv(c_of_kv, grid)
            if np.isfinite(c_new) or r == 0:
                k = k_new
        c = _c_from(*abz, k)
        if r == 0:
            c_random = float(c[:n_random].max())
        c_max = float(c.max())
        starts = X[np.argsort(c)[-n_starts:]]

        def decay_margin(x: np.ndarray) -> tuple[float, np.ndarray]:
            # (kv a - z) / |x|^2 and its gradient
            (a, _, z), (ga, _, gz) = form.point(x)
            xx = float(x @ x)
            num = k * a - z
            return num / xx, (k * ga - gz) / xx - 2 * num * x / xx**2

        def inv_c2(x: np.ndarray) -> tuple[float, np.ndarray]:
            # 1/c(x)^2 = 4 (kv a - z) / (kv^2 b), minimized to find the largest c
            (a, b, z), (ga, gb, gz) = form.point(x)
            if b <= 0:
                return 1e300, np.zeros_like(x)
            num = k * a - z
            return 4 * num / (k**2 * b), 4 * ((k * ga - gz) * b - num * gb) / (k**2 * b**2)

        found = [x for x in search(starts, decay_margin) if decay_margin(x)[0] < 0]
        if found:
            witness = min(found, key=lambda x: decay_margin(x)[0])
        elif np.isfinite(c_max):
            found = [x for x in search(starts, inv_c2) if form.c_max(x, k) > c_max * (1 + 1e-9)]
        if not found:
            break
        X = np.vstack([X] + found)
        abz = form.values(X)
    if kv is None:  # kv best for the final point set (the adversarial points included)
        k_new, c_new = best_kv(c_of_kv, grid)
        if np.isfinite(c_new):
            k = k_new
    c = _c_from(*abz, k)
    c_max = max(float(c.max()), form.origin_c(k))
    worst = X[int(np.argmax(c))] if np.isfinite(c_max) or witness is None else witness
    note = ""
    if not np.isfinite(c_max):
        note = ("H > 0 for every c at the worst point (kv a < |z|^2: the decay of V does not dominate "
                "the performance output there); no finite gain from this V on this region")
        if a_lim == 0:
            note += "; the decay of V is only semi-definite (singular quadratic part), so no kv helps"
    return SampledGain(c_max, float(k), c_random, n_random, worst.tolist(), float(np.mean(~np.isfinite(c))),
                       form.origin_c(k), note)


@dataclass
class SOSGain:
    """A certified upper bound on c for the region (``H <= 0`` proved by SOS).

    Attributes
    ----------
    c : float
        The bound ``1 / (2 sqrt(alpha beta))`` on the L2 gain from ``w`` (N m) to ``z``.
    kv : float
        The scale ``1 / alpha`` of ``V = kv V0`` of the certificate.
    beta : float
        ``kv / (4 c^2)`` of the certificate.
    checks : list of satfmu.synthesis.core.sos.Check
        Independent verification of the certificate's SOS constraints.
    n_programs : int
        SOS programs solved, the search over alpha included.
    timings : dict of str to float, optional
        ``"build"`` and ``"solve"`` times summed over the programs, s.
    """

    c: float
    kv: float
    beta: float
    checks: list[Check]
    n_programs: int
    timings: dict[str, float] = field(default_factory=dict)

    @property
    def certified(self) -> bool:
        """Every SOS constraint of the certificate passed its independent check."""
        return all(ch.certified for ch in self.checks)

    def to_json(self) -> dict[str, Any]:
        """The bound as a JSON-ready dict, its checks included."""
        return {"c": self.c, "kv": self.kv, "beta": self.beta, "certified": self.certified,
                "n_programs": self.n_programs, "timings_s": self.timings,
                "checks": [ch.to_json() for ch in self.checks]}


def _scaled(p: Poly, d: np.ndarray) -> Poly:
    """``p(D x)`` for ``D = diag(d)``."""
    return Poly.numeric(p.exps, p.c0 * np.prod(d[None, :] ** p.exps, axis=1))


def _beta_program(form: HJIForm, region: Region, alpha: float,
                  multiplier_degree: int) -> tuple[SOSProgram, np.ndarray, float]:
    """``a - alpha z - beta b >= 0`` on ``region``, in variables scaled to the unit region and
    divided by the size of ``a`` (conditioning). Returns the program, the index of the
    scaled ``beta~`` and the factor with ``beta = beta~ * factor``."""
    d = np.array([region.rate_max] * 3 + [region.sigma_max] * 3)
    a, z, b = (_scaled(p, d) for p in (form.a, form.z, form.b))
    na, nb = np.abs(a.c0).max(), np.abs(b.c0).max()
    unit = Region(1.0, 1.0)
    prog = SOSProgram(form.a.n_vars)
    beta = prog.new_variables(1)
    bterm = Poly(b.exps, np.zeros(len(b.c0)), sps.csr_matrix((b.c0 / nb)[:, None] * prog.selector(beta).toarray()))
    p = a.scale(1 / na) - z.scale(alpha / na) - bterm
    prog.add_sos_on_region(p, "a - z/kv - beta b on region", unit.polys(), multiplier_degree, region.label)
    return prog, beta, na / nb


def quadratic_part(p: Poly) -> np.ndarray:
    """Symmetric matrix ``S`` of the degree-2 terms of ``p`` (``p_2(x) = x^T S x``).

    Parameters
    ----------
    p : satfmu.synthesis.core.polynomial.Poly
        Numeric polynomial in n variables.

    Returns
    -------
    numpy.ndarray, shape (n, n)
    """
    n = p.n_vars
    S = np.zeros((n, n))
    for c, e in zip(p.c0, p.exps):
        if e.sum() != 2:
            continue
        i = np.nonzero(e)[0]
        if len(i) == 1:
            S[i[0], i[0]] += c
        else:
            S[i[0], i[1]] += c / 2
            S[i[1], i[0]] += c / 2
    return S


def alpha_limit(form: HJIForm) -> float:
    """Largest ``alpha = 1/kv`` with ``a_2 - alpha z_2 >= 0`` (quadratic parts): near the
    origin ``H <= 0`` needs it, so no certificate exists for larger alpha (0 if none).

    Parameters
    ----------
    form : HJIForm
        The closed loop's inequality; 0 is returned unless the quadratic part of ``a`` is
        positive definite.
    """
    A2, Z2 = quadratic_part(form.a), quadratic_part(form.z)
    if np.linalg.eigvalsh(A2).min() <= 1e-12 * max(1.0, np.abs(A2).max()):
        return 0.0
    # A2 > 0: a_2 - alpha z_2 >= 0  <=>  alpha <= 1 / lambda_max(A2^-1/2 Z2 A2^-1/2)
    L = np.linalg.cholesky(A2)
    Li = np.linalg.inv(L)
    return float(1.0 / np.linalg.eigvalsh(Li @ Z2 @ Li.T).max())


def sos_gain(form: HJIForm, region: Region, kv: float | None = None, multiplier_degree: int = 2,
             backoff: float = 1e-3) -> SOSGain:
    """Smallest ``c`` with an SOS certificate of ``H <= 0`` on ``region`` (fixed V and u).

    ``alpha = 1/kv`` is searched in ``(0, alpha_limit)`` (golden section on ``log alpha``)
    unless ``kv`` is given. The optimum of each program sits on the boundary of the SOS
    cone, so the certificate is re-solved at ``alpha (1 - backoff)`` with ``beta`` fixed to
    ``(1 - backoff)`` times its optimum: a strictly feasible point the verification
    (:func:`satfmu.synthesis.core.sos.certify`) can check with margin. ``c`` is reported for that point.

    Parameters
    ----------
    form : HJIForm
        The closed loop's inequality.
    region : Region
        The region ``H <= 0`` is proved on (S-procedure).
    kv : float, optional
        Scale of ``V = kv V0``; None: searched (``alpha = 1/kv`` below :func:`alpha_limit`).
    multiplier_degree : int, optional
        Degree of the S-procedure multipliers (even). Default 2.
    backoff : float, optional
        Relative back-off of alpha and beta from the optimum. Default 1e-3.

    Raises
    ------
    satfmu.synthesis.core.sos.SOSError
        If no ``kv`` admits a certificate, e.g. the decay of ``V`` is only semi-definite
        (``H = |z|^2 > 0`` where ``dV/dt = 0``, for every c).
    """
    n_programs = 0
    timings = {"build": 0.0, "solve": 0.0}

    def solve(alpha: float, beta_fixed: float | None = None) -> tuple[float, SOSProgram, Any]:
        nonlocal n_programs
        n_programs += 1
        prog, beta, factor = _beta_program(form, region, alpha, multiplier_degree)
        if beta_fixed is not None:
            prog.add_linear(prog.selector(beta), np.array([-beta_fixed / factor]), kind="eq")
        sol = prog.solve(objective=None if beta_fixed is not None else -prog.selector(beta))
        timings["build"] += sol.timings["build"]
        timings["solve"] += sol.timings["solve"]
        return float(sol.y[beta[0]]) * factor, prog, sol

    def neg_log_ab(log_alpha: float) -> float:
        try:
            b, _, _ = solve(10.0**log_alpha)
        except SOSError:
            return np.inf
        return np.inf if b <= 0 else -(log_alpha + np.log10(b))

    if kv is None:
        a_max = alpha_limit(form)
        if a_max <= 0:
            raise SOSError("the decay of V is not positive definite near the origin (quadratic part "
                           "singular): H > 0 close to x = 0 for every c, no certificate exists")
        res = minimize_scalar(neg_log_ab, bounds=(np.log10(a_max) - 6, np.log10(a_max)), method="bounded",
                              options={"xatol": 1e-3})
        if not np.isfinite(res.fun):
            raise SOSError(f"no SOS certificate of H <= 0 on {region.label} for alpha = 1/kv below {a_max:g}")
        alpha = 10.0**float(res.x)
    else:
        alpha = 1.0 / kv
    try:
        beta_opt, _, _ = solve(alpha)
    except SOSError as exc:
        raise SOSError(f"no SOS certificate of H <= 0 on {region.label} at kv = {1 / alpha:g}: {exc}") from None
    if beta_opt <= 0:
        raise SOSError(f"no SOS certificate of H <= 0 on {region.label} at kv = {1 / alpha:g} (beta <= 0)")
    alpha *= 1 - backoff
    beta = beta_opt * (1 - backoff)
    _, prog, sol = solve(alpha, beta)
    checks = certify(prog, sol, sample_radius=float(np.sqrt(4.0)))  # unit box x unit ball
    c = 1.0 / (2.0 * np.sqrt(alpha * beta))
    return SOSGain(float(c), float(1 / alpha), float(beta), checks, n_programs, timings)
