"""Seed 003's instance of Theorem 2: the cubesat's rate subsystem, sampled every 15 min.

The design model comes from the plant's own definition (``satfmu.fmus.plants.cubesat.MODEL``, of
:func:`satfmu.fmus.plants.cubesat.build`):
``B(t) = d omega' / d m`` at ``q = [0 0 0 1]``, ``omega = 0``, the Fourier field, saturation
off (seed eq. 7: rows ``[0, 200 bz, -200 by]``, ...). With a dipole held over each sample
``[k Ts, (k+1) Ts]`` and A = 0 (the gyroscopic term is quadratic), the exact discretization is

    omega(k+1) = omega(k) + (integral of B over the hold) m(k).

Noises (docs/models.md, "Checked numerically"): the coefficients ``1/I_l`` (200, 200, 500) are
perturbed by ``sigma_l xi_l`` (seed: 6.67, 6.67, 11.67): ``B2_l = sigma_l`` times the
integral of the unit-coefficient pattern ``e_l e_l^T I B(t)``; the disturbance enters
through ``B1_l = 1e-2 B2_l`` for every l = 0..3. Quality output ``z = [W1 omega; W2 m]``.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import sympy as sp

from satfmu.controllers.artifact import FORMAT, FORMAT_VERSION, PERIODIC_KIND, design_plant_record
from satfmu.fmus.plants import cubesat
from satfmu.synthesis.periodic.periodic_hinf import (LMICheck, PeriodicDesign, PeriodicSystem, analyze, bisect_gamma,
                                                     design,
                                     gamma_min, ms_spectral_radius)

TS_SEED = 900.0
"""The seed's sample period, s (15 min)."""
N_SEED = 6
SIGMA_SEED = (6.67, 6.67, 11.67)
"""Standard deviations of the noises on 1/I_x, 1/I_y, 1/I_z, 1/(kg m^2) (as printed; the seed's
own +-10 %, 3-sigma rule gives 16.67 for the third)."""
W1_SEED, W2_SEED, GAMMA_SEED = 100.0, 1.0, 0.5
DISTURBANCE_SCALE = 1e-2
"""The disturbance enters through 1e-2 times the control matrices (seed)."""

PUBLISHED_GAINS = np.array([
    [[-.0001, .00301, -.0011], [-.0225, .0001, .0776], [.0006, -.0415, 0]],
    [[0, .0467, -.0021], [-.0467, 0, .0017], [.0008, -.0007, 0]],
    [[-.0009, .0438, -.0031], [-.0345, .0009, .0308], [.0016, -.0157, 0]],
    [[-.0059, -.0403, .0117], [.0213, .0059, .0410], [-.0100, -.0352, 0]],
    [[-.0022, -.0505, .0299], [.0484, .0022, -.0188], [-.0108, .068, 0]],
    [[-.0080, -.0435, .0159], [.0302, .0079, .0336], [-.0113, -.0240, 0]],
])
"""The seed's gains F(k) (rate columns; rows m_x, m_y, m_z), A m^2 per rad/s, at t = 0, 15, ..., 75
min (its quaternion columns are zero)."""


def input_matrix(parameters: dict[str, float] | None = None):
    """Numpy function ``B(t)`` (3 x 3, rad/s^2 per A m^2) of the plant linearized at rest, orbit
    time t (s); ``parameters`` override the plant's defaults (field model 0 is used).

    Parameters
    ----------
    parameters : dict, optional
        Values of the cubesat's parameters by name (``I_x``, ...) overriding the plant's
        defaults (``satfmu.fmus.plants.cubesat.MODEL``); the field model is always 0 (Fourier).

    Returns
    -------
    callable
        ``B(t)``: the orbit time t (s) -> numpy.ndarray, shape (3, 3).
    """
    model = cubesat.MODEL
    values = {v.symbol: float(v.start) for v in model.parameters}
    values.update({sp.Symbol(k, real=True): float(v) for k, v in (parameters or {}).items()})
    values[sp.Symbol("field_model", real=True)] = 0.0
    values[sp.Symbol("saturation_on", real=True)] = 0.0
    values[sp.Symbol("orbit_time_0", real=True)] = 0.0
    rest = {s.symbol: 0.0 for s in model.states[:3]}
    rest.update({s.symbol: v for s, v in zip(model.states[3:7], (0.0, 0.0, 0.0, 1.0))})
    rest[model.states[7].symbol] = 0.0
    rates = sp.Matrix(model.rhs[:3]).xreplace(values)
    jac = rates.jacobian(sp.Matrix(model.input_symbols[:3])).xreplace(rest)
    jac = jac.xreplace({s: 0.0 for s in model.input_symbols})
    return sp.lambdify(model.t, jac, modules="numpy")


def held_integrals(Ts: float = TS_SEED, N: int = N_SEED, parameters: dict[str, float] | None = None,
                   n_nodes: int = 24) -> np.ndarray:
    """``integral of B(t) dt`` over each hold ``[k Ts, (k+1) Ts]``, shape (N, 3, 3), by Gauss-Legendre.

    The integrand is a trigonometric polynomial of period >= T_orbit / 2; 24 nodes per hold
    of up to a sixth of the orbit are exact to rounding.

    Parameters
    ----------
    Ts : float, optional
        The hold (sample) period, s (default the seed's 900 s).
    N : int, optional
        Number of holds, from orbit time 0.
    parameters : dict, optional
        Values of the cubesat's parameters by name (``I_x``, ...) overriding the plant's
        defaults (``satfmu.fmus.plants.cubesat.MODEL``); the field model is always 0 (Fourier).
    n_nodes : int, optional
        Gauss-Legendre nodes per hold.

    Returns
    -------
    numpy.ndarray, shape (N, 3, 3)
        The integrals, rad/s per A m^2.
    """
    B = input_matrix(parameters)
    nodes, weights = np.polynomial.legendre.leggauss(n_nodes)
    out = np.zeros((N, 3, 3))
    for k in range(N):
        t = k * Ts + (nodes + 1) * Ts / 2
        out[k] = sum(w * np.asarray(B(ti), float) for w, ti in zip(weights, t)) * Ts / 2
    return out


def system(Ts: float = TS_SEED, N: int = N_SEED, sigma: tuple[float, float, float] = SIGMA_SEED,
           W1: float = W1_SEED, W2: float = W2_SEED, parameters: dict[str, float] | None = None,
           time_unit: float = 1.0) -> PeriodicSystem:
    """The seed's periodic system (rate subsystem), r = 3 noises.

    ``time_unit`` (s) divides the hold integrals: 60 integrates B(t) with t in minutes (the
    seed's field is printed with t in minutes; docs/models.md suspects its design did so).

    Parameters
    ----------
    Ts : float, optional
        The hold (sample) period, s (default the seed's 900 s).
    N : int, optional
        The period of the system in samples (default the seed's 6: one orbit).
    sigma : tuple of 3 float, optional
        Standard deviations of the noises on 1/I_x, 1/I_y, 1/I_z, 1/(kg m^2), each >= 0.
    W1 : float, optional
        Weight of the rates in the quality output ``z = [W1 omega; W2 m]``, per rad/s.
    W2 : float, optional
        Weight of the dipole in ``z``, per A m^2.
    parameters : dict, optional
        Values of the cubesat's parameters by name (``I_x``, ...) overriding the plant's
        defaults (``satfmu.fmus.plants.cubesat.MODEL``); the field model is always 0 (Fourier).
    time_unit : float, optional
        Divisor of the hold integrals, s (1: time in seconds; 60: in minutes).

    Returns
    -------
    PeriodicSystem
        ``A = I``, ``B1 = 1e-2 B2``, ``B2`` the held integrals with their noise patterns, and
        ``C``, ``D`` of ``z``.

    Raises
    ------
    ValueError
        If Ts, N, W1, W2, time_unit are not positive or a sigma is negative.
    """
    if not (Ts > 0 and N >= 1 and W1 > 0 and W2 > 0 and time_unit > 0) or len(sigma) != 3 \
            or any(not s >= 0 for s in sigma):
        raise ValueError("need Ts, W1, W2, time_unit > 0, N >= 1 and three sigma >= 0")
    inertia = np.array([float(v.start) for v in cubesat.MODEL.parameters[:3]])
    if parameters:
        inertia = np.array([parameters.get(f"I_{a}", i) for a, i in zip("xyz", inertia)])
    Bd = held_integrals(Ts, N, parameters) / time_unit
    B2 = np.zeros((N, 4, 3, 3))
    B2[:, 0] = Bd
    for l in range(3):  # unit-coefficient pattern of row l, times its noise's standard deviation
        B2[:, l + 1, l] = sigma[l] * inertia[l] * Bd[:, l]
    A = np.zeros((N, 4, 3, 3))
    A[:, 0] = np.eye(3)
    C = np.tile(np.vstack([W1 * np.eye(3), np.zeros((3, 3))]), (N, 1, 1))
    D = np.tile(np.vstack([np.zeros((3, 3)), W2 * np.eye(3)]), (N, 1, 1))
    return PeriodicSystem(A, DISTURBANCE_SCALE * B2, B2, C, D)


GAMMA_MARGIN = 0.02
"""Default design level: gamma_min (1 + GAMMA_MARGIN), away from the boundary of feasibility."""

INPUTS = [{"name": f"omega[{i}]", "unit": "rad/s"} for i in (1, 2, 3)]
OUTPUTS = [{"name": f"m[{i}]", "unit": "A.m2", "description": f"Commanded dipole along body axis {i}"}
           for i in (1, 2, 3)]
REGION = ("the linear sampled rate model of seed 003 (eq. 7, q = identity, |omega| small, dipole held "
          "15 min, Fourier field), with the multiplicative noises of the inverse inertias; not the "
          "nonlinear plant")


@dataclass
class Synthesis:
    """Seed 003's design and the analysis of the published gains, all numbers re-verified.

    Attributes
    ----------
    system : PeriodicSystem
        The design system (:func:`system`).
    gamma_min : float
        The smallest level Theorem 2 certifies (direct minimization).
    bracket : tuple of (float, float, int)
        ``(infeasible, feasible, n_solves)`` of the bisection on gamma; ``(nan, nan, 0)``
        without it.
    design : PeriodicDesign
        The design at the chosen level.
    published : PeriodicDesign or None
        The analysis of the seed's :data:`PUBLISHED_GAINS` (None: Theorem 2 certifies no level
        for them).
    numbers : dict
        The figures of the design and the analysis by name (``gamma_min``, ``gamma_design``,
        ``ms_spectral_radius``, ...).
    parameters : dict, optional
        Plant parameters of the design that differ from seed 003's cubesat (its own inertia).
    sigma : tuple of 3 float, optional
        Standard deviations of the noises on 1/I_x, 1/I_y, 1/I_z, 1/(kg m^2).
    """

    system: PeriodicSystem
    gamma_min: float
    bracket: tuple[float, float, int]
    design: PeriodicDesign
    published: PeriodicDesign | None
    numbers: dict[str, float]
    parameters: dict[str, float] = field(default_factory=dict)
    """Plant parameters of the design that differ from seed 003's cubesat (its own inertia)."""
    sigma: tuple[float, float, float] = SIGMA_SEED
    """Standard deviations of the noises on 1/I_x, 1/I_y, 1/I_z, 1/(kg m^2)."""

    def artifact_data(self, name: str, F: np.ndarray, gamma: float, check: LMICheck, source: str) -> dict:
        """Artifact (kind periodic_gain_schedule) of the gains ``F`` proved at ``gamma``.

        Parameters
        ----------
        name : str
            The artifact's name, lower_snake_case (the controller FMU's modelIdentifier).
        F : numpy.ndarray, shape (N, 3, 3)
            The gains ``F(k)``, A m^2 per rad/s (rows: dipole axes, columns: rates).
        gamma : float
            The level at which Theorem 2 holds with these gains.
        check : LMICheck
            The solver-independent check of the LMIs at ``gamma``, recorded in the certificate.
        source : str
            Where the gains come from (``"satfmu"``, ``"published (seed 003, gains as printed)"``), in
            the description and provenance.

        Returns
        -------
        dict
            The artifact's JSON data (:class:`satfmu.controllers.artifact.PeriodicArtifact`).
        """
        rho = ms_spectral_radius(self.system, F)
        proved = (f"Theorem 2 (seed 003) LMIs hold at gamma = {gamma:.6g} with these gains: every block's "
                  f"largest eigenvalue <= {check.block_max_eig.max():.3e}, Y(k) >= {check.y_min_eig.min():.3e} "
                  f"(numpy, scaled coordinates, no solver); mean-square stable: second-moment monodromy "
                  f"spectral radius {rho:.4g} < 1")
        return {"format": FORMAT, "format_version": FORMAT_VERSION, "kind": PERIODIC_KIND, "name": name,
                "description": f"Periodic magnetorquer gains, seed 003 Theorem 2 ({source}), dipole held "
                               f"{TS_SEED / 60:g} min, N = {N_SEED}",
                "plant": cubesat.MODEL.name, "inputs": INPUTS, "outputs": OUTPUTS,
                "sample_period": TS_SEED, "schedule_period": TS_SEED * N_SEED, "gains": np.asarray(F).tolist(),
                "certificate": {"status": "certified", "proved": proved, "region": REGION,
                                "numbers": {"gamma": gamma, "ms_spectral_radius": rho,
                                            "max_block_eig": float(check.block_max_eig.max()),
                                            "min_y_eig": float(check.y_min_eig.min())}},
                "provenance": {"source": source, "sigma": list(self.sigma), "W1": W1_SEED, "W2": W2_SEED,
                               "disturbance_scale": DISTURBANCE_SCALE,
                               "design_plant": design_plant_record(cubesat.MODEL, values=self.parameters)}}


def synthesize(gamma: float | None = None, bisect: bool = True,
               inertia: tuple[float, float, float] | None = None) -> Synthesis:
    """gamma_min (direct and, with ``bisect``, by bisection), the design at ``gamma`` (default
    gamma_min (1 + GAMMA_MARGIN)) and the analysis of the published gains.

    Parameters
    ----------
    gamma : float, optional
        Design level.
    bisect : bool
        Also bracket gamma_min by bisection (a check of the direct minimization).
    inertia : 3 floats, optional
        Principal moments of your cubesat, kg m^2 (default seed 003's). The noises keep the
        seed's relative size: ``sigma_l = SIGMA_SEED_l I_seed_l / I_l`` on ``1/I_l``.

    Raises
    ------
    RuntimeError
        If no level is found, or the design at ``gamma`` is infeasible (the message gives
        gamma_min).
    """
    parameters: dict[str, float] = {}
    sigma = SIGMA_SEED
    if inertia is not None:
        if len(inertia) != 3 or not all(np.isfinite(v) and v > 0 for v in inertia):
            raise ValueError(f"inertia must be three finite moments > 0 (kg m^2), got {inertia}")
        parameters = {f"I_{a}": float(v) for a, v in zip("xyz", inertia)}
        sx, sy, sz = (float(s * i0 / i) for s, i0, i in zip(SIGMA_SEED, cubesat.INERTIA_SEED_003, inertia))
        sigma = (sx, sy, sz)
    sys_ = system(sigma=sigma, parameters=parameters)
    best = gamma_min(sys_)
    if best is None:
        raise RuntimeError("Theorem 2 has no verified solution at any gamma for this system")
    bracket = bisect_gamma(sys_, best.gamma / 2, best.gamma * 1.05) if bisect else (np.nan, np.nan, 0)
    level = best.gamma * (1 + GAMMA_MARGIN) if gamma is None else gamma
    found = design(sys_, level)
    if found is None:
        raise RuntimeError(f"Theorem 2 is infeasible at gamma = {level:g} (gamma_min = {best.gamma:.4g})")
    pub = analyze(sys_, PUBLISHED_GAINS)
    minutes = gamma_min(system(sigma=sigma, parameters=parameters, time_unit=60.0))
    numbers = {
        "gamma_min": best.gamma, "gamma_design": level,
        "seed_gamma_feasible": float(design(sys_, GAMMA_SEED) is not None),
        "gamma_min_t_in_minutes": minutes.gamma if minutes else np.nan,
        "max_block_eig": float(found.check.block_max_eig.max()), "min_y_eig": float(found.check.y_min_eig.min()),
        "ms_spectral_radius": ms_spectral_radius(sys_, found.F), "max_abs_gain": float(np.abs(found.F).max()),
        "ms_spectral_radius_negated": ms_spectral_radius(sys_, -found.F),
        "published_ms_spectral_radius": ms_spectral_radius(sys_, PUBLISHED_GAINS),
        "published_gamma": pub.gamma if pub else np.nan,
        "published_max_abs_gain": float(np.abs(PUBLISHED_GAINS).max()), "solve_seconds": found.solve_seconds}
    return Synthesis(sys_, best.gamma, bracket, found, pub, numbers, parameters, sigma)
