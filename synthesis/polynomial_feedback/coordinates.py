"""Well-conditioned coordinates for seed 001's Theorem 8: time, rate and torque units per plant.

Theorem 8's conditions are posed in the user's units (s, rad/s, N m). Between seed 000's
15 kg m^2 satellite, a 100 kg m^2 bus and a 0.01 kg m^2 cubesat, the numbers of the program
span many decades (rates of 1e-3 rad/s beside MRPs of 0.4, input matrices from 0.01 to 100),
and the interior-point solver stops short of the independent check's accuracy (residuals
~1e-6 instead of 1e-11) or reports a false infeasibility. The program is therefore solved in
scaled coordinates::

    t = time * t',  omega = rate * omega',  u = torque * u',  w = torque * w',  z = z' / sqrt(time)

(the MRPs, the polynomial variables of the SOS conditions, keep their units, so the region
``|sigma| <= r`` is the same). Every condition maps *exactly*, by a constant diagonal
congruence, onto the same condition in the user's units, with ``X2 = T X2' T``,
``Xinf = T Xinf' T``, ``F = T F' T``, ``Y = torque Y' T`` (``T = diag(rate, .., 1, ..)``),
``alpha = time alpha'``, ``beta = time beta'``, ``gamma' = torque sqrt(time) gamma`` and the same
lambda. The certificate is then checked in the user's units
(:func:`satfmu.synthesis.polynomial_feedback.h2hinf_sos.theorem8`).

The units are chosen from the plant (:meth:`Coordinates.balanced`):

- ``rate`` balances the Lyapunov matrix of the linearized plant's LQR with the design's
  weights (``X = P^-1``): the geometric mean of its rate diagonal over that of its MRP diagonal,
  square-rooted;
- ``time`` is ``sqrt(alpha beta) / 0.3``, so that the seed's scalars are 0.3 in the scaled
  program (below ~0.05 the SDP is ill-conditioned), kept between ``0.1 / rate`` and
  ``1 / rate`` (the time to turn one radian at that rate): a shorter unit makes the scaled
  state weight negligible, a longer one the closed loop's dynamics;
- ``torque`` makes the scaled control weight ``time torque^2 Rh`` of unit size.

Measured (one SOS solve each, region 0.45, ``docs/models.md``): in SI units a 100/120/80 kg m^2
bus at gamma 0.7 ends ``optimal_inaccurate`` with residuals 5e-6 (not certified, lambda 16.5)
and a 3U cubesat at gamma 5 is "infeasible" or fails numerically at most alpha; in these
coordinates both solve ``optimal`` with residuals below 1e-9, the bus at lambda 9.53.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import sympy as sp

from satfmu.synthesis.core.polynomial import PolyMatrix
from satfmu.synthesis.polynomial_feedback.split_plant import SplitPlant

SMALLEST_SCALAR = 0.3
"""Smallest ``sqrt(alpha' beta')`` of the scaled program: bounds ``time`` from above."""
SHORTEST_TIME = 0.1
"""Shortest ``time`` in units of ``1 / rate``: below it the scaled state weight ``time T Qh T``
is so small that its inverse dominates the H2 condition."""


def _geomean(values: np.ndarray) -> float:
    return float(np.exp(np.mean(np.log(np.abs(values)))))


def linearization(plant: SplitPlant) -> np.ndarray:
    """``A~(0)``, the split plant's state matrix at the origin, shape (n, n), 1/s.

    Parameters
    ----------
    plant : SplitPlant
        The split plant.
    """
    return plant.A_tilde.evaluate(np.zeros(plant.A_tilde.n_vars))


@dataclass(frozen=True)
class Coordinates:
    """Units of time, rate and torque of the scaled Theorem 8 program (see the module notes).

    Attributes
    ----------
    time : float
        Time unit, s.
    rate : float
        Rate unit of the actuated states, rad/s.
    torque : float
        Torque unit of the control and disturbance inputs, N m.
    """

    time: float
    rate: float
    torque: float

    def __post_init__(self) -> None:
        for name in ("time", "rate", "torque"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v > 0):
                raise ValueError(f"coordinates: {name} must be finite and > 0, got {v}")

    @classmethod
    def identity(cls) -> "Coordinates":
        """The user's own units (no scaling)."""
        return cls(1.0, 1.0, 1.0)

    @classmethod
    def balanced(cls, plant: SplitPlant, Qh: np.ndarray, Rh: np.ndarray, alpha: float, beta: float) -> "Coordinates":
        """The units the module notes choose for ``plant`` at the seed's scalars ``alpha``, ``beta``.

        Parameters
        ----------
        plant : SplitPlant
            The split plant (user units).
        Qh, Rh : numpy.ndarray
            The H2 weights, shapes (n, n) and (m, m).
        alpha, beta : float
            The seed's scalars of the program, s.

        Returns
        -------
        Coordinates
            The balanced units.

        Raises
        ------
        ValueError
            If the linearized plant is not stabilizable (no LQR solution).
        """
        A = linearization(plant)
        try:
            P = sla.solve_continuous_are(A, plant.Bu, Qh, Rh)
        except (np.linalg.LinAlgError, ValueError) as exc:
            raise ValueError(f"the linearized plant has no LQR solution with these weights: {exc}") from None
        X = np.diag(np.linalg.inv(P))
        rate = np.sqrt(_geomean(X[list(plant.actuated)]) / _geomean(X[list(plant.tilde)]))
        time = float(np.clip(np.sqrt(alpha * beta) / SMALLEST_SCALAR, SHORTEST_TIME / rate, 1.0 / rate))
        torque = 1.0 / np.sqrt(time * _geomean(np.linalg.eigvalsh(Rh)))
        return cls(float(time), float(rate), float(torque))

    # ------------------------------------------------------------------ user -> scaled
    def states(self, plant: SplitPlant) -> np.ndarray:
        """``diag(T)``: the unit of each state (rates: ``rate``; MRPs: 1), shape (n,).

        Parameters
        ----------
        plant : SplitPlant
            The plant in the user's units.
        """
        t = np.ones(plant.n)
        t[list(plant.actuated)] = self.rate
        return t

    def plant(self, plant: SplitPlant) -> SplitPlant:
        """``plant`` in these units: ``A' = time T^-1 A T``, ``B' = time torque T^-1 B``,
        ``C' = sqrt(time) C T``, ``Kg'(x') = Kg(T x') T / torque``.

        Parameters
        ----------
        plant : SplitPlant
            The plant in the user's units.
        """
        t = self.states(plant)
        A = PolyMatrix([[e.scale(self.time * t[j] / t[i]) for j, e in enumerate(row)]
                        for i, row in enumerate(plant.A_tilde.entries)])
        Kg = (plant.Kg.xreplace({s: float(v) * s for s, v in zip(plant.symbols, t)})
              * sp.diag(*map(float, t)) / self.torque)
        return dataclasses.replace(
            plant, A_tilde=A, Kg=Kg, Bu=self.time * self.torque * plant.Bu / t[:, None],
            Bw=self.time * self.torque * plant.Bw / t[:, None], C=np.sqrt(self.time) * plant.C * t[None, :])

    def weights(self, plant: SplitPlant, Qh: np.ndarray, Rh: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The H2 weights in these units: ``time T Qh T`` and ``time torque^2 Rh``.

        Parameters
        ----------
        plant : SplitPlant
            The plant in the user's units.
        Qh, Rh : numpy.ndarray
            The weights in the user's units, shapes (n, n) and (m, m).
        """
        t = self.states(plant)
        return self.time * Qh * np.outer(t, t), self.time * self.torque**2 * Rh

    def state(self, plant: SplitPlant, x: np.ndarray) -> np.ndarray:
        """A state in these units, ``T^-1 x``.

        Parameters
        ----------
        plant : SplitPlant
            The plant in the user's units.
        x : numpy.ndarray, shape (n,)
            The state in the user's units (rad/s, MRP).
        """
        return x / self.states(plant)

    def gamma(self, gamma: float) -> float:
        """The L2-gain bound in these units, ``torque sqrt(time) gamma``.

        Parameters
        ----------
        gamma : float
            The bound in the user's units (N m -> 1).
        """
        return float(self.torque * np.sqrt(self.time) * gamma)

    def scalar(self, a: float) -> float:
        """A seed scalar in these units, ``a / time``.

        Parameters
        ----------
        a : float
            Alpha or beta, s.
        """
        return float(a / self.time)

    # ------------------------------------------------------------------ scaled -> user
    def matrix(self, plant: SplitPlant, M: np.ndarray) -> np.ndarray:
        """``T M T``: X2, Xinf or F back in the user's units.

        Parameters
        ----------
        plant : SplitPlant
            The plant in the user's units.
        M : numpy.ndarray, shape (n, n)
            The matrix in these units.
        """
        t = self.states(plant)
        return M * np.outer(t, t)

    def gain_numerator(self, plant: SplitPlant, Y: PolyMatrix) -> PolyMatrix:
        """``torque Y T``: Theorem 8's ``Y~(x~)`` back in the user's units.

        Parameters
        ----------
        plant : SplitPlant
            The plant in the user's units.
        Y : satfmu.synthesis.core.polynomial.PolyMatrix
            ``Y~`` in these units, shape (m, n).
        """
        t = self.states(plant)
        return PolyMatrix([[e.scale(self.torque * t[j]) for j, e in enumerate(row)] for row in Y.entries])

    def h2_rows(self, plant: SplitPlant) -> np.ndarray:
        """Diagonal ``D`` of the congruence ``M2 = D M2' D`` of the H2 matrix (rows: x, x, x, u).

        Parameters
        ----------
        plant : SplitPlant
            The plant in the user's units.
        """
        t, r = self.states(plant), np.sqrt(self.time)
        return np.concatenate([t / r, t * r, t * r, np.full(plant.m, self.torque * r)])

    def hinf_rows(self, plant: SplitPlant) -> np.ndarray:
        """Diagonal ``D`` of the congruence ``Minf = D Minf' D`` (rows: x, x, w, z).

        Parameters
        ----------
        plant : SplitPlant
            The plant in the user's units.
        """
        t, r = self.states(plant), np.sqrt(self.time)
        return np.concatenate([t / r, t * r, np.full(plant.Bw.shape[1], 1.0 / (self.torque * r)),
                               np.ones(plant.C.shape[0])])
