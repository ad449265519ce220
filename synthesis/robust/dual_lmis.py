"""The specifications of a robust design and their dual LMIs, as numbers for a check or in a program.

A specification (``_Spec``, built by ``_specs``) is one robust LMI: H-infinity, or the pole
region's ``Re s < -alpha``, ``Re s > -beta`` or damping sector (:data:`ROBUST_LMIS`).
``_dual_lmi`` builds its dual form (derived in :mod:`satfmu.synthesis.robust.robust_design`'s
docstring) with numpy's array functions for a check or :mod:`satfmu.synthesis.core.lmi`'s for a
program, ``_i2p_blocks`` the impulse-to-peak blocks, and ``_robust_constraints`` every LMI of the
common-Lyapunov program over several plants. The levels enter them by the convention's rule
(``_weights``, ``_level``, ``_bound``).
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from satfmu.synthesis.core import lmi
from satfmu.synthesis.robust.lft_plant import LFTPlant, _block_starts
from satfmu.synthesis.robust.multipliers import _multiplier_program, _vertex_deltas


@dataclass(frozen=True)
class _Spec:
    """One robust LMI: the loop ``x' = A x + Bu u + Bp p + Bw w`` with the q channel of
    ``plant`` and ``z = Cz x + Dzu u + Dzp p + Dzw w`` (no w, z: a Lyapunov/region condition),
    in ``copies`` copies of the state (``Y``, ``W`` enter as ``I_copies (x) Y``, ``(x) W``)."""

    name: str
    plant: LFTPlant
    A: np.ndarray
    Bu: np.ndarray
    Bp: np.ndarray
    Bw: np.ndarray
    Dqw: np.ndarray
    Cz: np.ndarray
    Dzu: np.ndarray
    Dzp: np.ndarray
    Dzw: np.ndarray
    copies: int = 1


def _region_spec(name: str, plant: LFTPlant, A, Bu, Bp, copies: int = 1) -> _Spec:
    n, nq, m = A.shape[0], plant.Cq.shape[0], Bu.shape[1]
    return _Spec(name, plant, A, Bu, Bp, np.zeros((n, 0)), np.zeros((nq, 0)), np.zeros((0, n)), np.zeros((0, m)),
                 np.zeros((0, nq)), np.zeros((0, 0)), copies)


def _sector_plant(plant: LFTPlant, theta: float) -> LFTPlant:
    """The LFT of ``M (x) A_cl(Delta)``, ``M = [[sin t, cos t], [-cos t, sin t]]``: the q channel
    doubled (``I_2 (x) Delta``), reordered so that each parameter's ``2 r_k`` channels are
    contiguous (one D-G block or vertex value per parameter); w, z unused (zeros)."""
    M = np.array([[np.sin(theta), np.cos(theta)], [-np.cos(theta), np.sin(theta)]])
    I2 = np.eye(2)
    nq, n, m = plant.Cq.shape[0], plant.A.shape[0], plant.Bu.shape[1]
    start = _block_starts(plant.repetitions)
    perm = np.concatenate([np.r_[a:b, nq + a:nq + b] for a, b in itertools.pairwise(start)]).astype(int) \
        if nq else np.zeros(0, int)
    z = np.zeros
    return LFTPlant(np.kron(M, plant.A), np.kron(M, plant.Bp)[:, perm], np.kron(M, plant.Bu), z((2 * n, 1)),
                    z((2 * n, 1)), np.kron(I2, plant.Cq)[perm], np.kron(I2, plant.Dqp)[np.ix_(perm, perm)],
                    np.kron(I2, plant.Dqu)[perm], z((2 * nq, 1)), z((1, 2 * n)), z((1, 2 * nq)), z((1, 2 * m)),
                    z((1, 1)), z((1, 2 * n)), tuple((name, 2 * r) for name, r in plant.blocks))


ROBUST_LMIS = ("hinf", "alpha", "beta", "sector")
"""Names of the robust LMIs of ``_specs``."""


def _specs(plant: LFTPlant, alpha: float, beta: float | None, hinf: bool, sector: float | None = None
           ) -> list[_Spec]:
    """The robust LMIs: "hinf" (if asked), "alpha" (``Re s < -alpha``), "beta" (``Re s > -beta``,
    if given), "sector" (``|Im s| < tan(sector) (-Re s)``, if given; Chilali & Gahinet, IEEE TAC
    41, 1996: ``He(M (x) A_cl Y) < 0``)."""
    n = plant.A.shape[0]
    out = []
    if hinf:
        out.append(_Spec("hinf", plant, plant.A, plant.Bu, plant.Bp, plant.B1, plant.Dq1, plant.C1, plant.D1u,
                         plant.D1p, plant.D11))
    out.append(_region_spec("alpha", plant, plant.A + alpha * np.eye(n), plant.Bu, plant.Bp))
    if beta is not None:
        out.append(_region_spec("beta", plant, -plant.A - beta * np.eye(n), -plant.Bu, -plant.Bp))
    if sector is not None:
        sp = _sector_plant(plant, sector)
        out.append(_region_spec("sector", sp, sp.A, sp.Bu, sp.Bp, copies=2))
    return out


Selection = tuple[frozenset[str], ...] | None
"""Per plant of a program, the names of its robust LMIs that the program imposes (``_specs``;
its i2p blocks always): a constraint generation's subset. None: every LMI of every plant."""


def _selected_specs(plants: tuple[LFTPlant, ...], alpha: float, beta: float | None, hinf: bool,
                    sector: float | None, only: Selection) -> list[list[_Spec]]:
    """:func:`_specs` of each plant, those ``only`` names (all if None)."""
    return [[s for s in _specs(p, alpha, beta, hinf, sector) if only is None or s.name in only[i]]
            for i, p in enumerate(plants)]


def _weights(convention: str, level) -> tuple:
    """``(z side, w side)`` of an H-infinity or impulse-to-peak LMI at the program's level (a
    variable or a number): ``(level, level)`` in ``"satfmu"``, ``(level, 1)`` in ``"romuloc"``."""
    return (level, level) if convention == "satfmu" else (level, 1.0)


def _level(convention: str, bound: float) -> float:
    """The program's level of a bound (gamma or nu): itself, or its square in ``"romuloc"``."""
    return bound if convention == "satfmu" else bound**2


def _bound(convention: str, level: float) -> float:
    """The bound (gamma or nu) certified by a program's level: :func:`_level` inverted."""
    return level if convention == "satfmu" else float(np.sqrt(level))


def _dual_lmi(s: _Spec, Y, W, mult, weights, stack, bmat):
    """The dual robust LMI of spec ``s`` (must be < 0), rows ``(x', q, z, w)``, built with the
    array functions given: numpy's (``np.vstack, np.block``) for a check, :mod:`satfmu.synthesis.core.lmi`'s for
    the program.

    ``mult = (Qt, St, Rt)`` (ignored when ``n_q = 0``); ``weights = (z side, w side)`` of the
    level (:func:`_weights`), unused without w, z.
    """
    plant = s.plant
    if s.copies == 2:
        Y = bmat([[Y, np.zeros(Y.shape)], [np.zeros(Y.shape), Y]])
        W = bmat([[W, np.zeros(W.shape)], [np.zeros(W.shape), W]])
    n, nq, nz, nw = s.A.shape[0], plant.Cq.shape[0], s.Cz.shape[0], s.Bw.shape[1]
    rows, gp, gw = [s.A @ Y + s.Bu @ W], [s.Bp], [s.Bw]
    if nq:
        rows.append(plant.Cq @ Y + plant.Dqu @ W)
        gp.append(plant.Dqp)
        gw.append(s.Dqw)
    if nz:
        rows.append(s.Cz @ Y + s.Dzu @ W)
        gp.append(s.Dzp)
        gw.append(s.Dzw)
    dim = n + nq + nz
    E = np.eye(dim)
    Ex, Eq, Ez = E[:, :n], E[:, n:n + nq], E[:, n + nq:]
    T = stack(rows) @ Ex.T
    L = T + T.T
    if nq:
        Qt, St, Rt = mult
        Gp = np.vstack(gp)
        U = Gp @ St.T @ Eq.T
        L = L + U + U.T - Gp @ Rt @ Gp.T - Eq @ Qt @ Eq.T
    if nz:
        L = L - weights[0] * (Ez @ Ez.T)
    if nw:
        Gw = np.vstack(gw)
        L = bmat([[L, Gw], [Gw.T, -weights[1] * np.eye(nw)]])
    return (L + L.T) / 2


def _i2p_blocks(plant: LFTPlant, Y, weights, bmat) -> tuple:
    """``[[Y, B2], [B2^T, w I]]`` (must be > 0) and ``C2 Y C2^T - z I`` (must be < 0), ``(z, w) =
    weights`` (:func:`_weights`: ``(nu, nu)``, or ``(g_i2p, 1)`` in the toolbox's form)."""
    m2, p2 = plant.B2.shape[1], plant.C2.shape[0]
    upper = bmat([[Y, plant.B2], [plant.B2.T, weights[1] * np.eye(m2)]])
    lower = plant.C2 @ Y @ plant.C2.T - weights[0] * np.eye(p2)
    return (upper + upper.T) / 2, (lower + lower.T) / 2


def _key(i: int, name: str, n_plants: int) -> str:
    """Name of a robust LMI: the spec's, prefixed by the plant's index when there are several."""
    return name if n_plants == 1 else f"{i}/{name}"


def _distinct_i2p(plants: tuple[LFTPlant, ...]) -> list[int]:
    """The index of one plant per distinct ``(B2, C2)``: the i2p blocks of the others are the same LMIs."""
    out: list[int] = []
    for i, p in enumerate(plants):
        if not any(np.array_equal(p.B2, plants[j].B2) and np.array_equal(p.C2, plants[j].C2) for j in out):
            out.append(i)
    return out


def _robust_constraints(prog: lmi.LMIProgram, plants: tuple[LFTPlant, ...], K: np.ndarray | None,
                        specs: list[list[_Spec]], uncertainty: str, margin, gamma, nu, convention: str = "satfmu"
                        ) -> tuple[lmi.Affine, lmi.Affine, dict]:
    """``(Y, W, multiplier values)`` of the common-Lyapunov program over every plant (``specs[i]``
    of plant i), its LMIs added to ``prog``, every one strict by ``margin`` (eps, or the variable
    the back-off maximizes); gamma, nu the program's levels (:func:`_level`), variables or
    constants (nu None: no impulse-to-peak LMIs). Each plant's LMIs are tagged with its index
    ``(plant index, LMI name)`` (:meth:`lmi.LMIProgram.dual_weights`; the i2p blocks
    ``(i, "i2p")`` with the plant that carries them)."""
    n, m = plants[0].A.shape[0], plants[0].Bu.shape[1]
    Y = prog.variable((n, n), symmetric=True)
    W = prog.variable((m, n)) if K is None else K @ Y
    prog.add_psd(Y - margin * np.eye(n))
    values = {}
    for i, (plant, plant_specs) in enumerate(zip(plants, specs)):
        for s in plant_specs:
            triple = None
            if plant.n_params:
                deltas = _vertex_deltas(s.plant) if uncertainty == "vertex" else []
                triple, values[_key(i, s.name, len(plants))] = _multiplier_program(
                    prog, s.plant, uncertainty, deltas, margin)
            L = _dual_lmi(s, Y, W, triple, _weights(convention, gamma), lmi.vstack, lmi.bmat)
            prog.add_psd(-L - margin * np.eye(L.shape[0]), tag=(i, s.name))
    for i in _distinct_i2p(plants) if nu is not None else ():
        upper, lower = _i2p_blocks(plants[i], Y, _weights(convention, nu), lmi.bmat)
        prog.add_psd(upper - margin * np.eye(upper.shape[0]), tag=(i, "i2p"))
        prog.add_psd(-lower - margin * np.eye(lower.shape[0]), tag=(i, "i2p"))
    return Y, W, values
