"""The multipliers of the robust LMIs: D-G scalings and full-block multipliers (vertex separators).

Each robust LMI of :mod:`satfmu.synthesis.robust.robust_design` (whose docstring derives both
classes) carries a dual multiplier ``Pi~ = [[Qt, St], [St^T, Rt]]`` on ``(q, p)``: D-G scalings
(``uncertainty="norm"``) or a full-block multiplier with its inequality at the box vertices
(``uncertainty="vertex"``). Here: the numeric :class:`Multiplier`, a multiplier's variables and
conditions in a program (``_multiplier_program``), the vertex inequality and the D-G structure
that a check rebuilds, and the default limit on the vertices (:data:`MAX_VERTICES`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from satfmu.synthesis.core import lmi
from satfmu.synthesis.robust.lft_plant import LFTPlant, _sym, box_vertices

MAX_VERTICES = 4096
"""Default largest number of box vertices (2^N) a vertex program may enumerate."""


def _vertex_deltas(plant: LFTPlant) -> list[np.ndarray]:
    """``Delta`` at every vertex of the box, each (n_q, n_q)."""
    return [np.diag(np.repeat(v, plant.repetitions)) for v in box_vertices(plant.n_params)]


@dataclass
class Multiplier:
    """Dual multiplier ``Pi~ = [[Q, S], [S^T, R]]`` on ``(q, p)`` of one robust LMI.

    D-G (``kind="norm"``): ``Q = blockdiag(S_k) > 0``, ``S = blockdiag(H_k)`` skew, ``R = -Q``.
    Full block (``kind="vertex"``): free, ``Q > 0`` and the vertex inequalities.

    Attributes
    ----------
    kind : {"norm", "vertex"}
        D-G scalings or full-block multiplier.
    Q : numpy.ndarray, shape (n_q, n_q)
        Block on q (positive definite).
    S : numpy.ndarray, shape (n_q, n_q)
        Coupling block of q and p.
    R : numpy.ndarray, shape (n_q, n_q)
        Block on p.
    """

    kind: str
    Q: np.ndarray
    S: np.ndarray
    R: np.ndarray


def _vertex_condition(Qt, St, Rt, D: np.ndarray):
    """``Delta Qt Delta - Delta St - St^T Delta + Rt`` (the dual multiplier inequality, <= 0)."""
    V = D @ Qt @ D - D @ St - St.T @ D + Rt
    return (V + V.T) / 2


def _blockdiag(mats: list, sizes: list[int]) -> lmi.Affine:
    return lmi.bmat([[mats[i] if i == j else np.zeros((sizes[i], sizes[j])) for j in range(len(sizes))]
                     for i in range(len(sizes))])


def _multiplier_program(prog: lmi.LMIProgram, plant: LFTPlant, uncertainty: str, deltas: list[np.ndarray], margin):
    """The ``(Qt, St, Rt)`` expressions of one multiplier, its conditions (strict by ``margin``)
    added to ``prog``, and a function returning the numeric :class:`Multiplier` after the solve."""
    reps = [int(r) for r in plant.repetitions]
    nq = sum(reps)
    if uncertainty == "norm":
        S = [prog.variable((r, r), symmetric=True) for r in reps]
        U = [prog.variable((r, r)) if r > 1 else None for r in reps]
        H = [u - u.T if u is not None else np.zeros((1, 1)) for u in U]
        for s, r in zip(S, reps):
            prog.add_psd(s - margin * np.eye(r))
        Qt, St = _blockdiag(S, reps), _blockdiag(H, reps)

        def norm_value() -> Multiplier:
            Q = sla.block_diag(*[_sym(prog.value(s)) for s in S])
            Hs = sla.block_diag(*[prog.value(h) if isinstance(h, lmi.Affine) else h for h in H])
            return Multiplier("norm", Q, Hs, -Q)

        return (Qt, St, -Qt), norm_value
    Qt = prog.variable((nq, nq), symmetric=True)
    St = prog.variable((nq, nq))
    Rt = prog.variable((nq, nq), symmetric=True)
    prog.add_psd(Qt - margin * np.eye(nq))
    for D in deltas:
        prog.add_psd(-_vertex_condition(Qt, St, Rt, D) - margin * np.eye(nq))

    def value() -> Multiplier:
        return Multiplier("vertex", _sym(prog.value(Qt)), prog.value(St), _sym(prog.value(Rt)))

    return (Qt, St, Rt), value


def _dg_structure_error(mult: Multiplier, reps: np.ndarray) -> float:
    """Largest deviation of a D-G multiplier from its structure (0 when exact)."""
    mask = sla.block_diag(*[np.ones((r, r)) for r in reps]) == 0
    return float(max(np.max(np.abs(mult.R + mult.Q)), np.max(np.abs(mult.S + mult.S.T)),
                     np.max(np.abs(mult.Q[mask]), initial=0.0), np.max(np.abs(mult.S[mask]), initial=0.0)))
