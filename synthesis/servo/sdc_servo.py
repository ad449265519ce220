"""The numerical side of an SDRE servo: its state-dependent pair ``Ae(x), Be(x)`` evaluated at a
plant state and the Riccati gain there, checked at every call.

:class:`SdcServo` is shared by seed 002's VSCMG servo (:class:`satfmu.synthesis.servo.sdre.Servo`)
and the MRP servo of a rigid spacecraft (:class:`satfmu.synthesis.servo.mrp_sdre.MRPServo`); each
gives its symbolic pair, its weights and how a plant state reads in an error message.
"""
from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Callable

import numpy as np
import sympy as sp

from satfmu.controllers.riccati import RiccatiCheck, RiccatiCheckError, riccati_gain
from satfmu.fmus.model import Model


class SdcServo(ABC):
    """An SDRE servo's ``Ae(x)``, ``Be(x)`` compiled from its symbolic SDC form, and the checked
    gain ``K = R^-1 Be^T P`` of the shifted pair ``(Ae - eps I, Be)``
    (:func:`satfmu.controllers.riccati.riccati_gain`).

    Subclasses call ``_compile`` once and give :attr:`weights`, :attr:`eps` and
    :meth:`describe_state`.
    """

    eps: float
    """Riccati shift, 1/s."""

    def _compile(self, model: Model, Ae: sp.Matrix, Be: sp.Matrix, parameters: dict[str, float] | None = None
                 ) -> None:
        """Compile ``Ae``, ``Be`` (in the model's state and parameter symbols) to numpy, with the
        model's parameter values (``parameters`` override its defaults)."""
        args = (model.state_symbols, model.parameter_symbols)
        self._state_names = [str(v) for v in model.state_symbols]
        self._A: Callable = sp.lambdify(args, Ae, "numpy", cse=True)
        self._B: Callable = sp.lambdify(args, Be, "numpy", cse=True)
        self._p = model.parameter_vector(parameters or {})

    @property
    @abstractmethod
    def weights(self) -> tuple[np.ndarray, np.ndarray]:
        """``(Q, R)``: the servo state's and the input's weights."""

    @abstractmethod
    def describe_state(self, x: np.ndarray) -> str:
        """How the plant state ``x`` reads in an error message (names, values and units).

        Parameters
        ----------
        x : numpy.ndarray
            The plant state.
        """

    def matrices(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(Ae, Be)`` at the plant state ``x``.

        Parameters
        ----------
        x : numpy.ndarray, shape (n_states,)
            The plant state, in the order of the model's states.

        Returns
        -------
        tuple of numpy.ndarray
            ``(Ae, Be)``.

        Raises
        ------
        ValueError
            If ``x`` is not as many finite values as the model has states.
        """
        x = np.array(x, float)
        n = len(self._state_names)
        if x.shape != (n,) or not np.all(np.isfinite(x)):
            raise ValueError(f"plant state must be {n} finite values [{', '.join(self._state_names)}], got {x!r}")
        return np.asarray(self._A(x, self._p), float), np.asarray(self._B(x, self._p), float)

    def gain(self, x: np.ndarray) -> tuple[np.ndarray, RiccatiCheck]:
        """The gain at the plant state ``x`` and its check; ``u = -K xe``.

        Parameters
        ----------
        x : numpy.ndarray, shape (n_states,)
            The plant state.

        Returns
        -------
        K : numpy.ndarray, shape (n_inputs, n_servo_states)
            The gain.
        check : satfmu.controllers.riccati.RiccatiCheck
            The checks of the Riccati solution.

        Raises
        ------
        satfmu.controllers.riccati.RiccatiCheckError
            If the Riccati solution at ``x`` fails a check (the message gives the state).
        """
        A, B = self.matrices(x)
        Q, R = self.weights
        try:
            return riccati_gain(A, B, Q, R, self.eps)
        except RiccatiCheckError as exc:
            raise RiccatiCheckError(f"{exc} at {self.describe_state(np.asarray(x, float))}") from exc

    def __call__(self, x: np.ndarray) -> np.ndarray:
        """The checked gain at the plant state ``x`` (a servo law in closed loop).

        Parameters
        ----------
        x : numpy.ndarray, shape (n_states,)
            The plant state.
        """
        return self.gain(x)[0]
