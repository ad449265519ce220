"""The SDC plant split as seed 001's Theorem 8 needs it: unactuated states, the cancelling gain.

For ``x' = A(x) x + Bu u + Bw w`` the states whose rows of ``[Bu Bw]`` vanish (``x~``, the MRPs
of the satellite) are separated from the actuated ones (the rates). The feedback
``Kg(x) = -(Bu^T Bu)^-1 Bu^T A(x)`` cancels the actuated rows of ``A`` (for the MRP satellite
the gyroscopic torque), so Theorem 8's conditions involve ``A~ = A + Bu Kg``, a function of
``x~`` only, and hold for every rate.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import sympy as sp

from satfmu.fmus.model import Model
from satfmu.synthesis.core.polynomial import PolyMatrix


@dataclass(frozen=True)
class SplitPlant:
    """The SDC plant split as Theorem 8 needs it (parameters at their defaults).

    ``x~`` (``tilde``) are the states whose rows of ``[Bu Bw]`` are zero, the others are
    ``actuated``. ``Kg(x) = -(Bu^T Bu)^-1 Bu^T A(x)`` cancels the actuated rows of A (for
    the MRP satellite: the gyroscopic torque, ``Kg x = omega x I omega``), so with
    ``Y = Y~(x~) + Kg F`` the conditions only involve ``A~ = A + Bu Kg``, a function of x~.

    Attributes
    ----------
    symbols : tuple of sympy.Symbol
        The model's state symbols ``x``, in state order (n of them).
    tilde : tuple of int
        Indices in ``x`` of the unactuated states ``x~`` (the MRPs).
    actuated : tuple of int
        Indices in ``x`` of the other states (the body rates).
    A_tilde : satfmu.synthesis.core.polynomial.PolyMatrix
        ``A + Bu Kg``, shape (n, n), as polynomials in ``x~`` (below).
    Kg : sympy.Matrix
        The cancelling feedback gain, shape (m, n), in the state symbols (below).
    Bu : numpy.ndarray, shape (n, m)
        Input matrix of the control torque ``u`` (N m).
    Bw : numpy.ndarray, shape (n, m)
        Input matrix of the disturbance torque ``w`` (N m).
    C : numpy.ndarray, shape (len(tilde), n)
        Performance output matrix (below).
    """

    symbols: tuple[sp.Symbol, ...]
    tilde: tuple[int, ...]
    actuated: tuple[int, ...]
    A_tilde: PolyMatrix
    """``A + Bu Kg`` as polynomials in x~."""
    Kg: sp.Matrix
    """The cancelling feedback gain, in the state symbols."""
    Bu: np.ndarray
    Bw: np.ndarray
    C: np.ndarray
    """``z = C x = x~`` (seed 001: the MRPs)."""

    @property
    def n(self) -> int:
        return len(self.symbols)

    @property
    def m(self) -> int:
        return self.Bu.shape[1]

    @property
    def tilde_symbols(self) -> list[sp.Symbol]:
        return [self.symbols[i] for i in self.tilde]

    @property
    def tilde_name(self) -> str:
        return _base(self.symbols[self.tilde[0]])

    @property
    def actuated_name(self) -> str:
        return _base(self.symbols[self.actuated[0]])


def _base(s: sp.Symbol) -> str:
    return str(s).split("[", 1)[0]


CANCEL_TOL = 1e-12
"""Relative size of a coefficient of ``A + Bu Kg`` taken as round-off of the cancellation."""


def split(model: Model, frozen: bool = False) -> SplitPlant:
    """The SDC form of ``model`` split for Theorem 8, parameters at their defaults.

    Parameters
    ----------
    model : Model
        A plant with an SDC form whose input columns are ``[u w]`` (control, then disturbance).
    frozen : bool, optional
        Freeze ``A(x)`` at ``x = 0`` (the linearization). Default False.

    Returns
    -------
    SplitPlant
        The split plant.

    Raises
    ------
    ValueError
        If the model has no SDC form, or ``A + Bu Kg`` depends on more than ``x~``.
    """
    xs = [s.symbol for s in model.states]
    subs = {v.symbol: v.start for v in model.parameters}
    sdc = model.sdc
    if sdc is None:
        raise ValueError(f"model {model.name!r} has no SDC form")
    A = sp.Matrix(sdc.A.subs(subs))
    if frozen:
        A = A.subs({x: 0 for x in xs})
    B = sp.Matrix(sdc.B.subs(subs))
    m = B.shape[1] // 2
    Bu = B[:, :m]
    tilde = tuple(i for i in range(len(xs)) if all(B[i, j] == 0 for j in range(B.shape[1])))
    actuated = tuple(i for i in range(len(xs)) if i not in tilde)
    Kg = sp.simplify(-(Bu.T * Bu).inv() * Bu.T * A)
    # with products of inertia the cancellation leaves round-off (1e-17 omega): drop it
    scale = max([abs(float(f)) for f in A.atoms(sp.Float)] + [1.0])
    A_tilde = sp.expand(A + Bu * Kg).applyfunc(
        lambda e: e.xreplace({f: 0 for f in e.atoms(sp.Float) if abs(f) < CANCEL_TOL * scale}))
    xt = [xs[i] for i in tilde]
    if not A_tilde.free_symbols <= set(xt):
        raise ValueError(f"model {model.name!r}: A + Bu Kg depends on "
                         f"{sorted(map(str, A_tilde.free_symbols - set(xt)))}, not only on x~")
    C = np.zeros((len(tilde), len(xs)))
    C[np.arange(len(tilde)), list(tilde)] = 1.0
    Bn = np.array(B, float)
    return SplitPlant(tuple(xs), tilde, actuated, PolyMatrix.from_sympy(A_tilde, xt), Kg,
                      Bn[:, :m], Bn[:, m:], C)
