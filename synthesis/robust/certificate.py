"""The independent check of a robust certificate: every LMI rebuilt in numpy, without the solver.

:func:`certify` rebuilds the dual robust LMIs of one plant from a returned ``K, Y``, levels and
multipliers; ``_certify_plants`` does so for the several plants of one program (judged, with a
constraint generation's subset, on the LMIs that program imposed: ``_judged_on``) and merges
their checks (``_merge_checks``).
"""
from __future__ import annotations

import itertools
from dataclasses import replace
from typing import Any

import numpy as np

from satfmu.synthesis.robust.checks import RobustCheck, _allowance, _check_convention, _finish_check
from satfmu.synthesis.robust.dual_lmis import ROBUST_LMIS, Selection, _dual_lmi, _i2p_blocks, _level, _specs, _weights
from satfmu.synthesis.robust.lft_plant import LFTPlant, PlantDataError, _block_starts, _check_gain, _matrix, _sym
from satfmu.synthesis.robust.multipliers import Multiplier, _dg_structure_error, _vertex_condition, _vertex_deltas


def certify(plant: LFTPlant, K, Y, gamma: float | None, nu: float, multipliers: dict[str, Multiplier], *,
           alpha: float, beta: float | None, sector: float | None = None, convention: str = "satfmu"
           ) -> RobustCheck:
    """Check the dual robust LMIs of :func:`~satfmu.synthesis.robust.robust_design.design` /
    :func:`~satfmu.synthesis.robust.robust_design.i2p_bound` with numpy only.

    Rebuilds, from the returned ``K, Y`` (``W = K Y``), ``gamma``, ``nu`` and multipliers: every
    robust LMI (``"hinf"`` if gamma is given, ``"alpha"``, ``"beta"`` if beta is given), the
    multiplier conditions (D-G: structure exact, ``S_k > 0``; full block: ``Qt > 0`` and the
    vertex inequality at every vertex), ``Y > 0`` and the i2p blocks.

    Parameters
    ----------
    plant : LFTPlant
        The uncertain plant the certificate is for.
    K : ndarray, shape (m, n)
        The gain of ``u = K x``.
    Y : ndarray, shape (n, n)
        The common Lyapunov matrix ``Y = P^-1``.
    gamma : float or None
        H-infinity bound (None: no H-infinity LMI, as in :func:`~satfmu.synthesis.robust.robust_design.i2p_bound`).
    nu : float
        Impulse-to-peak bound.
    multipliers : dict
        :class:`Multiplier` per robust LMI name (empty when the plant has no blocks).
    alpha, beta : float
        The pole region (beta None: no ``Re s > -beta`` LMI).
    sector : float, optional
        Half-angle (rad) of the sector ``|Im s| < tan(sector) (-Re s)`` (None: no sector LMI).
    convention : {"satfmu", "romuloc"}
        How the bounds enter the LMIs (:mod:`satfmu.synthesis.robust.robust_design`).
    """
    _check_convention(convention)
    n = plant.A.shape[0]
    K = _check_gain(K, plant.Bu.shape[1], n)
    Y = _matrix("Y", Y)
    if Y.shape != (n, n):
        raise PlantDataError(f"Y must have shape ({n}, {n}), got {Y.shape}")
    Y = _sym(Y)
    W = K @ Y
    neg: dict[str, list[np.ndarray]] = {}
    pos: dict[str, list[np.ndarray]] = {"Y": [Y]}
    structure = 0.0
    for s in _specs(plant, alpha, beta, gamma is not None, sector):
        triple = None
        if plant.n_params:
            if s.name not in multipliers:
                raise PlantDataError(f"no multiplier for the {s.name!r} LMI")
            mu = multipliers[s.name]
            triple = (mu.Q, mu.S, mu.R)
            if mu.kind == "norm":
                structure = max(structure, _dg_structure_error(mu, s.plant.repetitions))
                start = _block_starts(s.plant.repetitions)
                pos[f"{s.name}/S"] = [mu.Q[a:b, a:b] for a, b in itertools.pairwise(start)]
            else:
                pos[f"{s.name}/Q"] = [mu.Q]
                neg[f"{s.name}/vertices"] = [_vertex_condition(mu.Q, mu.S, mu.R, D)
                                             for D in _vertex_deltas(s.plant)]
        weights = None if gamma is None else _weights(convention, _level(convention, gamma))
        neg[s.name] = [_dual_lmi(s, Y, W, triple, weights, np.vstack, np.block)]
    upper, lower = _i2p_blocks(plant, Y, _weights(convention, _level(convention, nu)), np.block)
    pos["i2p/B2"] = [upper]
    neg["i2p/C2"] = [lower]
    return _finish_check(neg, pos, structure)


def _certify_plants(plants: tuple[LFTPlant, ...], K, Y, gamma, nu, multipliers: dict[str, Multiplier], *,
                   alpha: float, beta: float | None, sector: float | None, convention: str,
                   only: Selection = None) -> RobustCheck:
    """:func:`certify` at every plant, merged: the smallest margin, names prefixed as
    :func:`~satfmu.synthesis.robust.dual_lmis._key`; with ``only``, each plant's check judged on
    the robust LMIs the program imposed (:func:`_judged_on`)."""
    options: dict[str, Any] = {"alpha": alpha, "beta": beta, "sector": sector, "convention": convention}
    checks = []
    for i, plant in enumerate(plants):
        own = multipliers if len(plants) == 1 else {k.split("/", 1)[1]: v for k, v in multipliers.items()
                                                    if k.startswith(f"{i}/")}
        check = certify(plant, K, Y, gamma, nu, own, **options)
        checks.append(check if only is None else _judged_on(check, only[i]))
    return checks[0] if len(plants) == 1 else _merge_checks(checks)


def _judged_on(check: RobustCheck, names: frozenset[str]) -> RobustCheck:
    """``check`` with its margin over the robust LMIs ``names`` and the other matrices (Y, the
    i2p blocks, the multipliers' conditions) only: the LMIs a program left out are not its to
    meet. The rounding allowance stays the whole check's."""
    left_out = {s for s in ROBUST_LMIS if s not in names}
    max_eig = {k: v for k, v in check.max_eig.items() if k.split("/")[0] not in left_out}
    min_eig = {k: v for k, v in check.min_eig.items() if k.split("/")[0] not in left_out}
    allowance = _allowance(check.scale)
    top = max((float(v.max()) for v in max_eig.values()), default=-np.inf)
    low = min((float(v.min()) for v in min_eig.values()), default=np.inf)
    details = [d for d in check.details if d.split("/")[0].split(":")[0] not in left_out]
    return replace(check, margin=min(-top, low) - allowance, details=details)


def _merge_checks(checks: list[RobustCheck]) -> RobustCheck:
    """One check of several plants' (names prefixed by the plant's index)."""
    worst = min(range(len(checks)), key=lambda i: checks[i].margin)
    return RobustCheck({f"{i}/{k}": v for i, c in enumerate(checks) for k, v in c.max_eig.items()},
                       {f"{i}/{k}": v for i, c in enumerate(checks) for k, v in c.min_eig.items()},
                       checks[worst].margin, max(c.scale for c in checks),
                       max(c.structure_error for c in checks), [f"plant {worst}: {d}" for d in checks[worst].details])
