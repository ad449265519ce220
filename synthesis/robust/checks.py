"""The solver-independent check of a certificate: its record, rounding allowance, tolerances, conventions.

:class:`RobustCheck` holds the extreme eigenvalues of the matrices that a check rebuilds in numpy
(:func:`~satfmu.synthesis.robust.certificate.certify`, :func:`~satfmu.synthesis.robust.pdlf.certify_pdlf`)
and the margin they leave over the rounding allowance. Here too: the tolerances the robust LMIs
are solved and checked with (:data:`ABS_MARGIN`, :data:`EPS`) and the conventions that put the
levels into them (:data:`CONVENTIONS`), with their option checks.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from satfmu.synthesis.robust.lft_plant import OptionError

ABS_MARGIN = 1e-9
"""Smallest eigenvalue margin accepted as strict (the solver is asked for ``eps``, default
1e-7; numpy's eigenvalue error is about 1e-16 times the largest entry)."""

CONVENTIONS = ("satfmu", "romuloc")
"""How the levels enter the LMIs (:mod:`satfmu.synthesis.robust.robust_design`): ours, or the R-RoMulOC toolbox's."""

EPS = 1e-7
"""Default strictness of the LMIs in the solver."""


def _check_convention(convention: str) -> None:
    if convention not in CONVENTIONS:
        raise OptionError(f"convention must be one of {CONVENTIONS}, got {convention!r}")


def _check_eps(eps: float) -> None:
    if not (np.isfinite(eps) and eps > 0):
        raise OptionError(f"eps must be finite and > 0, got {eps!r}")


@dataclass
class RobustCheck:
    """Solver-independent check of a certificate (every LMI rebuilt in numpy).

    ``max_eig[name]``: largest eigenvalue of each matrix that must be negative definite (an
    array: one per vertex where the LMI is imposed per vertex); ``min_eig[name]``: smallest
    eigenvalue of each matrix that must be positive definite (Y, the i2p block, the
    scalings ``S_k`` or ``Qt``, ``P(delta_v)``). ``structure_error``: the largest deviation
    from the D-G structure (``Rt = -Qt``, ``St = -St^T``, both block diagonal), which must be
    exactly 0. ``margin``: the smaller of ``-max(max_eig)`` and ``min(min_eig)`` less the
    rounding allowance ``max(ABS_MARGIN, 1000 eps_machine scale)`` (``scale``: the largest entry
    of the matrices checked).

    Attributes
    ----------
    max_eig : dict of str to numpy.ndarray
        Largest eigenvalues of the matrices that must be negative definite, by name (``"hinf"``,
        ``"alpha"``, ``"hinf/vertices"``, ``"i2p/C2"``, ...).
    min_eig : dict of str to numpy.ndarray
        Smallest eigenvalues of the matrices that must be positive definite, by name (``"Y"``,
        ``"i2p/B2"``, ``"hinf/S"``, ...).
    margin : float
        The certificate's margin less the rounding allowance; > 0 when every matrix has the
        right sign.
    scale : float
        Largest absolute entry of the matrices checked.
    structure_error : float, optional
        Largest deviation from the D-G structure (0: exact).
    details : list of str, optional
        One line per matrix whose extreme eigenvalue misses the rounding allowance, and one for
        a violated D-G structure; empty when the check passes.
    """

    max_eig: dict[str, np.ndarray]
    min_eig: dict[str, np.ndarray]
    margin: float
    scale: float
    structure_error: float = 0.0
    details: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return self.margin > 0 and self.structure_error == 0


def _allowance(scale: float) -> float:
    """The rounding allowance of a check whose largest matrix entry is ``scale``."""
    return max(ABS_MARGIN, 1e3 * np.finfo(float).eps * scale)


def _finish_check(neg: dict[str, list[np.ndarray]], pos: dict[str, list[np.ndarray]],
                  structure_error: float = 0.0) -> RobustCheck:
    scale = max(float(np.max(np.abs(m))) for mats in (*neg.values(), *pos.values()) for m in mats if m.size)
    max_eig = {k: np.array([np.linalg.eigvalsh(m)[-1] for m in v]) for k, v in neg.items()}
    min_eig = {k: np.array([np.linalg.eigvalsh(m)[0] for m in v]) for k, v in pos.items()}
    allowance = _allowance(scale)
    top = max(float(v.max()) for v in max_eig.values())
    low = min(float(v.min()) for v in min_eig.values())
    details = [f"{k}: max eig {v.max():.3e}" for k, v in max_eig.items() if v.max() > -allowance]
    details += [f"{k}: min eig {v.min():.3e}" for k, v in min_eig.items() if v.min() < allowance]
    if structure_error:
        details.append(f"D-G structure violated by {structure_error:.3e}")
    return RobustCheck(max_eig, min_eig, min(-top, low) - allowance, scale, structure_error, details)
