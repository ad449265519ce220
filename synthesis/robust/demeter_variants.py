"""DEMETER model variants (seed 004, section 2.6) and the state-feedback design model (Fig. 3).

A :class:`Variant` selects the axes, the appendages, ``model_type`` (1: each appendage has its
own omega, zeta; 2: all identical), ``uncertainty_type`` (1: norm-bounded, 2: intervals,
3: inertia norm-bounded, the rest uniform in intervals) and the wheels. :func:`design_model`
returns the uncertain design model in two exact forms built from the same equations:

- an **affine descriptor** ``N(delta) [x'; x; v; u; w1] = 0``, ``N = N0 + sum delta_k N_k``,
  with auxiliaries ``v`` that make every parameter enter affinely (the inertia through its
  root S: ``c = S theta''`` and ``S (c + L_r eta'') + J_off theta'' = tau``; the modes through
  ``g = omega eta + 2 zeta eta'`` and ``L_r^T c + eta'' + omega g = 0``), used by the
  parameter-dependent Lyapunov analysis;
- the **LFT** ``p = Delta q`` obtained from it by factoring each ``N_k = U_k V_k`` (the
  repetition of ``delta_k`` is the rank of ``N_k``: the root of each J_ii twice, each omega
  twice, each zeta once, each product of inertia twice, as in the seed), used by the design.

Parameters are normalized to ``delta`` in [-1, 1]: ``sqrt(J_ii)`` in [sqrt(0.7 J0_ii),
sqrt(1.3 J0_ii)] (the seed's LFT of the root, section 2.4), ``J_ij = J0_ij + 3 delta``,
omega in [0.2, 0.6] 2 pi rad/s, zeta in [5e-4, 5e-3]. Flexible coordinates sharing omega and
zeta (an appendage's bending and torsion; with ``model_type`` 2 every selected appendage)
are reduced to ``min(n_axes, n_coordinates)`` coordinates ``eta_r = Q eta`` with the
coupling ``L_r = (L_g L_g^T)^(1/2)``, ``Q = L_r^-1 L_g``: the rest is decoupled from the
body (section 2.6 (a), (c); one axis, one appendage: eq. 8 with l = ||L[axis, columns]||).

Design model (Fig. 3; the wiring is **ours**, the seed does not define it): per axis the
attitude error integrator ``xi' = theta``, the input pseudo-integrator ``xw' = -a xw + u_c``
(a = 1e-3 1/s, the wheel-momentum proxy), and the wheel ``y = H(s) u_c`` with states
``(y, y')`` (y: the wheel torque on the body). ``w1``: torque disturbance added to the body
torque (N m); ``z1 = theta`` (rad). ``w2``: an impulse whose response is the worst-case initial
state of the seed, 0.262 rad on theta and 1.4e-3 rad/s on theta' (one column each per axis);
``z2 = xw`` (N m s). Design states per axis, in order: theta, theta', (eta_r, eta_r' of all
reduced coordinates after all axes), xi, xw, y, y'.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from satfmu.controllers import state_feedback
from satfmu.fmus.plants import demeter
from satfmu.fmus.errors import SpacecraftError, VariantError
from satfmu.fmus.plants.flexible_spacecraft import DEMETER, FlexibleSpacecraft, Wheels

PSEUDO_INTEGRATOR_POLE = 1e-3
"""a of the input pseudo-integrator 1/(s + a), 1/s (seed section 3)."""
THETA_WORST = 15 * np.pi / 180
"""Worst-case initial attitude error, rad (seed: 15 deg)."""
RATE_WORST = 0.08 * np.pi / 180
"""Worst-case initial rate, rad/s (seed: 0.08 deg/s)."""
LFT_ROUNDING = 1e-13
"""Entries of an LFT matrix below this times its largest entry are rounding residue, set to 0."""


SEED_TABLE1_COLUMNS = ("design_i2p", "design_hinf", "det_i2p", "det_hinf", "prob_i2p", "prob_hinf", "seconds")
"""Columns of the seed's Table 1: design bounds, deterministic analysis, probabilistic analysis
(i2p then H-infinity each), seconds."""


@dataclass(frozen=True)
class Variant:
    """One of the seed's model variants (section 2.6, the arguments of demeterPerformance).

    Parameters
    ----------
    axes : tuple of int
        Selected axes, 1-based, e.g. ``(1,)`` or ``(1, 2)``.
    appendages : tuple of int
        Selected appendages, 1-based, subset of 1..4.
    model_type : {1, 2}
        1: independent omega, zeta per appendage; 2: identical appendages.
    uncertainty_type : {1, 2, 3}
        1: norm-bounded; 2: intervals; 3: inertia norm-bounded, the rest uniform in intervals.
    wheels : bool
        Reaction-wheel dynamics H(s) in the model.
    spacecraft : FlexibleSpacecraft, optional
        The spacecraft whose axes and appendages are selected: its inertia, modes, their
        intervals (the uncertainty box), wheel limits and dynamics. Default the seed's
        :data:`~satfmu.fmus.plants.flexible_spacecraft.DEMETER`.

    Raises
    ------
    VariantError
        A selection outside the spacecraft, an unknown type, or ``model_type`` 2 (identical
        appendages) over appendages whose modes' intervals differ.
    """

    axes: tuple[int, ...] = (1,)
    appendages: tuple[int, ...] = (1,)
    model_type: int = 1
    uncertainty_type: int = 1
    wheels: bool = True
    spacecraft: FlexibleSpacecraft = DEMETER

    def __post_init__(self) -> None:
        if not isinstance(self.spacecraft, FlexibleSpacecraft):
            raise VariantError(f"spacecraft must be a FlexibleSpacecraft, got {self.spacecraft!r}")
        for name, sel, top in (("axes", self.axes, demeter.N_AXES),
                               ("appendages", self.appendages, len(self.spacecraft.appendages))):
            if not sel or len(set(sel)) != len(sel) or any(
                    isinstance(i, bool) or not isinstance(i, (int, np.integer)) or not 1 <= i <= top for i in sel):
                raise VariantError(f"{name} must be distinct integers in 1..{top}, got {sel!r}")
            object.__setattr__(self, name, tuple(sorted(int(i) for i in sel)))
        if self.model_type not in (1, 2):
            raise VariantError(f"model_type must be 1 or 2, got {self.model_type!r}")
        if self.uncertainty_type not in (1, 2, 3):
            raise VariantError(f"uncertainty_type must be 1, 2 or 3, got {self.uncertainty_type!r}")
        if self.model_type == 2:
            dynamics = {(g.frequency, g.damping) for g in self.spacecraft.groups
                        if g.appendage + 1 in self.appendages}
            if len(dynamics) > 1:
                raise VariantError(
                    f"model_type 2 treats appendages {list(self.appendages)} as identical (one frequency and one "
                    f"damping ratio), but their modes' intervals differ: "
                    + "; ".join(f"frequency {f.to_value()} rad/s, damping {d.to_value()}" for f, d in sorted(
                        dynamics, key=lambda fd: (fd[0].low, fd[0].high, fd[1].low)))
                    + ". Use model_type 1 (each appendage its own)")

    def to_dict(self) -> dict:
        """JSON form (a design artifact's ``design.variant``; the spacecraft's description
        unless it is DEMETER); :meth:`from_dict` reads it back."""
        out = {"axes": list(self.axes), "appendages": list(self.appendages), "model_type": self.model_type,
               "uncertainty_type": self.uncertainty_type, "wheels": self.wheels}
        if self.spacecraft != DEMETER:
            out["spacecraft"] = self.spacecraft.to_dict()
        return out

    @classmethod
    def from_dict(cls, data: dict) -> Variant:
        """The variant of a :meth:`to_dict` form (a design artifact's ``design.variant``).

        Parameters
        ----------
        data : dict
            ``axes`` and ``appendages`` (lists of int, 1-based), ``model_type``,
            ``uncertainty_type`` (int), ``wheels`` (bool) and optionally ``spacecraft`` (a
            :meth:`~satfmu.fmus.plants.flexible_spacecraft.FlexibleSpacecraft.to_dict` form; default
            DEMETER), as written by :meth:`to_dict`.

        Returns
        -------
        Variant

        Raises
        ------
        VariantError
            If a key is missing or a value is not valid for :class:`Variant`.
        """
        try:
            spacecraft = (FlexibleSpacecraft.from_dict(data["spacecraft"], where="spacecraft")
                          if "spacecraft" in data else DEMETER)
            if not isinstance(data["wheels"], bool):
                raise VariantError(f"not a variant: wheels must be true or false, got {data['wheels']!r}")
            return cls(tuple(data["axes"]), tuple(data["appendages"]), data["model_type"], data["uncertainty_type"],
                       data["wheels"], spacecraft)
        except (KeyError, TypeError) as exc:
            raise VariantError(f"not a variant: {data!r}") from exc
        except SpacecraftError as exc:
            raise VariantError(f"not a variant: {exc}") from None

    @property
    def label(self) -> str:
        """One line naming the selection (and the spacecraft unless it is DEMETER)."""
        craft = "" if self.spacecraft == DEMETER else f"{self.spacecraft.name} | "
        return (f"{craft}axes {','.join(map(str, self.axes))} | appendages {','.join(map(str, self.appendages))} | "
                f"model {self.model_type} | unc {self.uncertainty_type} | wheels {int(self.wheels)}")


@dataclass(frozen=True)
class UncertainParameter:
    """A real parameter ``nominal + half_width * delta``, delta in [-1, 1].

    ``kind``: "sqrtJ" (root of a principal inertia, axis index), "Jprod" (product of inertia,
    axis pair), "omega" / "zeta" (mode group index); ``distribution``: "norm-bounded" or
    "uniform" (how the randomized methods of part 2 sample it).

    Attributes
    ----------
    name : str
        Name in the order of delta, e.g. ``"sqrtJ11"``, ``"J12"``, ``"omega"``, ``"zeta2"``
        (:func:`parameters`).
    kind : {"sqrtJ", "Jprod", "omega", "zeta"}
        What the parameter is (above).
    index : tuple of int
        0-based: ``(k,)`` the position of the axis among the selected ones (``"sqrtJ"``),
        ``(k1, k2)`` the pair of selected axes (``"Jprod"``), ``(g,)`` the mode group
        (``"omega"``, ``"zeta"``).
    nominal : float
        Centre of the interval: sqrt(kg m^2) for ``"sqrtJ"``, kg m^2 for ``"Jprod"``, rad/s for
        ``"omega"``, dimensionless for ``"zeta"``.
    half_width : float
        Half the width of the interval, same unit as ``nominal``.
    distribution : {"norm-bounded", "uniform"}
        How the randomized methods sample it.
    """

    name: str
    kind: str
    index: tuple[int, ...]
    nominal: float
    half_width: float
    distribution: str

    def value(self, delta: float) -> float:
        """The physical value ``nominal + half_width * delta`` (unit of ``nominal``).

        Parameters
        ----------
        delta : float
            Normalized value, in [-1, 1] for the box (not checked here).
        """
        return self.nominal + self.half_width * delta


@dataclass
class DesignModel:
    """The uncertain design model of a variant (see the module docstring for the forms).

    Built by :func:`design_model`. Below, ``na`` is the number of selected axes, ``nr`` of
    reduced flexible coordinates, ``N`` of uncertain parameters.

    Attributes
    ----------
    variant : Variant
        The variant modelled.
    parameters : list of UncertainParameter
        The uncertain parameters, in the order of delta (:func:`parameters`).
    state_names : list of str
        Names of the ``n`` design states, in order (theta, theta', eta_r, eta_r', xi, xw, and
        the wheel's y, y' with wheels).
    groups : list of list of int
        Plant flexible coordinates (0-based columns of L) of each group sharing omega, zeta.
    L : numpy.ndarray, shape (3, nf)
        Coupling used (dimensionless; columns of unselected appendages and rows of unselected
        axes zero; nf the spacecraft's modes, 8 for DEMETER).
    Q : numpy.ndarray, shape (nr, nf)
        Reduced flexible coordinates from the plant's: ``eta_r = Q eta``.
    L_r : numpy.ndarray, shape (na, nr)
        Reduced coupling.
    mode_group : numpy.ndarray, shape (nr,)
        Group index of each reduced coordinate.
    N0 : numpy.ndarray, shape (n + n_v, 2 n + n_v + 2 na)
        Constant part of the affine descriptor ``N(delta)``, columns ``x', x, v, u, w1``.
    Nk : numpy.ndarray, shape (N, n + n_v, 2 n + n_v + 2 na)
        Coefficient ``N_k`` of each ``delta_k`` in ``N(delta)``.
    n : int
        Number of design states.
    n_v : int
        Number of auxiliaries ``v`` of the descriptor (``na + nr``).
    C1 : numpy.ndarray, shape (na, n)
        Output ``z1 = theta`` (rad).
    B2 : numpy.ndarray, shape (n, 2 na)
        Input of the impulse ``w2``: per axis, :data:`THETA_WORST` on theta and
        :data:`RATE_WORST` on theta'.
    C2 : numpy.ndarray, shape (na, n)
        Output ``z2 = xw`` (N m s).
    members : list of list of int, optional
        The spacecraft's mode groups (:attr:`~satfmu.fmus.plants.flexible_spacecraft.FlexibleSpacecraft.groups`,
        0-based: the plant FMU's ``zeta[g]``, ``omega[g]``) that each design group covers.
    fixed : dict, optional
        The known parameters (an interval of zero width), ``(kind, index)`` -> value, keyed as
        :class:`UncertainParameter`'s ``kind`` and ``index``, in the unit of its ``nominal``.
    meta : dict, optional
        Free-form annotations; empty by default (satfmu sets and reads none).
    """

    variant: Variant
    parameters: list[UncertainParameter]
    state_names: list[str]
    groups: list[list[int]]
    """Plant flexible coordinates (0-based columns of L) of each group sharing omega, zeta."""
    L: np.ndarray
    """Coupling used, 3 x nf (columns of unselected appendages zero)."""
    Q: np.ndarray
    """Reduced flexible coordinates from the plant's: eta_r = Q eta, shape (nr, nf)."""
    L_r: np.ndarray
    """Reduced coupling, (na, nr)."""
    mode_group: np.ndarray
    """Group index of each reduced coordinate, shape (nr,)."""
    N0: np.ndarray
    Nk: np.ndarray
    n: int
    n_v: int
    C1: np.ndarray
    B2: np.ndarray
    C2: np.ndarray
    members: list[list[int]] = field(default_factory=list)
    fixed: dict[tuple[str, tuple[int, ...]], float] = field(default_factory=dict)
    meta: dict = field(default_factory=dict)

    @property
    def na(self) -> int:
        return len(self.variant.axes)

    @property
    def nr(self) -> int:
        return self.L_r.shape[1]

    @property
    def names(self) -> list[str]:
        return [p.name for p in self.parameters]

    # -------------------------------------------------------------- evaluation
    def values(self, delta: np.ndarray) -> dict[str, np.ndarray]:
        """Physical values at ``delta``: J (na x na), S (diag root), zeta, omega per group.

        Parameters
        ----------
        delta : numpy.ndarray, shape (N,)
            Normalized parameters in [-1, 1], in the order of ``parameters``.

        Returns
        -------
        dict of str to numpy.ndarray
            ``"J"`` (na, na), kg m^2; ``"S"`` (na, na), the diagonal of roots, sqrt(kg m^2);
            ``"zeta"`` and ``"omega"`` (rad/s), one per mode group.

        Raises
        ------
        VariantError
            If ``delta`` is not ``N`` finite numbers in [-1, 1].
        """
        delta = self._check_delta(delta)
        na = self.na
        S = np.zeros((na, na))
        J = np.zeros((na, na))
        ng = len(self.groups)
        zeta, omega = np.zeros(ng), np.zeros(ng)
        values = [*((kind, index, v) for (kind, index), v in self.fixed.items()),
                  *((p.kind, p.index, p.value(d)) for p, d in zip(self.parameters, delta))]
        for kind, index, v in values:
            if kind == "sqrtJ":
                S[index[0], index[0]] = v
            elif kind == "Jprod":
                J[index] = J[index[::-1]] = v
            elif kind == "omega":
                omega[index[0]] = v
            else:
                zeta[index[0]] = v
        J += S @ S
        return {"J": J, "S": S, "zeta": zeta, "omega": omega}

    def _check_delta(self, delta: np.ndarray, stack: bool = False) -> np.ndarray:
        """delta as shape (N,), or (S, N) with ``stack``; finite and in the box."""
        d = np.asarray(delta, float)
        d = d.reshape(-1, len(self.parameters)) if stack and d.ndim == 2 else d.reshape(-1)
        if (d.shape[-1:] != (len(self.parameters),) or not np.all(np.isfinite(d))
                or np.abs(d).max(initial=0) > 1 + 1e-12):
            raise VariantError(f"delta must be {len(self.parameters)} finite numbers in [-1, 1]"
                               f"{' per row' if stack and np.ndim(delta) == 2 else ''}, got shape {np.shape(delta)}")
        return d

    def N(self, delta: np.ndarray) -> np.ndarray:
        """``N(delta) = N0 + sum delta_k N_k``.

        Parameters
        ----------
        delta : numpy.ndarray, shape (N,)
            Normalized parameters in [-1, 1], in the order of ``parameters``.
        """
        return self.N0 + np.tensordot(self._check_delta(delta), self.Nk, axes=1)

    def state_space(self, delta: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``x' = A x + Bu u + B1 w1`` at ``delta``, solved from the descriptor; ``delta`` of
        shape (S, N) gives stacks (S, n, .) (one batched solve).

        Parameters
        ----------
        delta : numpy.ndarray, shape (N,) or (S, N)
            Normalized parameters in [-1, 1] (one plant, or one per row).

        Returns
        -------
        A, Bu, B1 : numpy.ndarray
            Shapes (n, n), (n, na), (n, na), each with a leading S for a stack.
        """
        d = self._check_delta(delta, stack=True)
        Nd = self.N0 + np.tensordot(d, self.Nk, axes=([-1], [0]))
        n, nv = self.n, self.n_v
        lhs = np.concatenate([Nd[..., :n], Nd[..., 2 * n:2 * n + nv]], axis=-1)
        rhs = -np.concatenate([Nd[..., n:2 * n], Nd[..., 2 * n + nv:]], axis=-1)
        sol = np.linalg.solve(lhs, rhs)[..., :n, :]
        m = self.na
        return sol[..., :n], sol[..., n:n + m], sol[..., n + m:]

    def direct(self, delta: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The same design model built the direct way: eq. (4) by :func:`satfmu.fmus.plants.demeter.second_order`
        with the reduced coupling, a full inverse of M, then the augmentation (the check of the
        descriptor and the LFT).

        Parameters
        ----------
        delta : numpy.ndarray, shape (N,)
            Normalized parameters in [-1, 1], in the order of ``parameters``.

        Returns
        -------
        A, Bu, B1 : numpy.ndarray
            Shapes (n, n), (n, na), (n, na), as :meth:`state_space`.
        """
        v = self.values(delta)
        A0, B0 = demeter.state_space(v["J"], self.L_r, v["zeta"][self.mode_group], v["omega"][self.mode_group],
                                     pairs=False)
        return _augment(A0, B0, self.na, self.nr, self.variant.spacecraft.wheels if self.variant.wheels else None)

    def sample(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """``n`` parameter vectors delta, uniform in the box (shape (n, N)).

        Parameters
        ----------
        n : int
            Number of vectors.
        rng : numpy.random.Generator
            Source of the draws.
        """
        return rng.uniform(-1.0, 1.0, (n, len(self.parameters)))

    def fmu_parameters(self, delta: np.ndarray) -> dict[str, float | bool]:
        """Parameters of the spacecraft's plant FMU (:func:`satfmu.fmus.plants.demeter.build`) that
        make it this variant at ``delta``: unselected axes decoupled (their products of inertia
        and rows of L zero), unselected appendages removed (their columns of L zero).

        Parameters
        ----------
        delta : numpy.ndarray, shape (N,)
            Normalized parameters in [-1, 1], in the order of ``parameters``.

        Returns
        -------
        dict of str to float or bool
            The FMU's inertia, coupling, damping and frequency parameters by name, and
            ``"wheels_on"``.
        """
        v = self.values(delta)
        sc = self.variant.spacecraft
        J = np.diag(np.diag(sc.tensor)).astype(float)
        ax = [a - 1 for a in self.variant.axes]
        J[np.ix_(ax, ax)] = v["J"]
        zeta, omega = sc.nominal_damping.copy(), sc.nominal_frequency.copy()
        for g, members in enumerate(self.members):
            zeta[members], omega[members] = v["zeta"][g], v["omega"][g]
        out = demeter.parameter_values(J, self.L, zeta, omega, spacecraft=sc)
        out["wheels_on"] = bool(self.variant.wheels)
        return out


    def lft(self) -> dict[str, Any]:
        """The LFT of the design model (matrices of :class:`satfmu.synthesis.robust.lft_plant.LFTPlant`).

        Each ``N_k = U_k V_k`` (SVD, rank ``r_k``) gives the channel ``p_k = delta_k q_k``,
        ``q_k = V_k xi``; solving ``N0 xi + sum U_k p_k = 0`` for ``(x', v)`` gives
        ``x' = A x + Bp p + Bu u + B1 w1`` and ``q = Cq x + Dqp p + Dqu u + Dq1 w1``.
        """
        n, nv, m = self.n, self.n_v, self.na
        U_parts, V_parts, blocks = [], [], []
        for p, Nk in zip(self.parameters, self.Nk):
            U, sv, Vt = np.linalg.svd(Nk)
            r = int(np.sum(sv > 1e-12 * sv[0])) if sv[0] > 0 else 0
            U_parts.append(U[:, :r] * sv[:r])
            V_parts.append(Vt[:r])
            blocks.append((p.name, r))
        Uall, Vall = np.hstack(U_parts), np.vstack(V_parts)
        ycols = np.r_[0:n, 2 * n:2 * n + nv]
        kcols = np.r_[n:2 * n, 2 * n + nv:2 * n + nv + 2 * m]
        sol = -np.linalg.solve(self.N0[:, ycols], np.hstack([self.N0[:, kcols], Uall]))
        Yk, Yp = sol[:, :len(kcols)], sol[:, len(kcols):]
        Qk = Vall[:, ycols] @ Yk + Vall[:, kcols]
        x, u, w = slice(0, n), slice(n, n + m), slice(n + m, n + 2 * m)
        nz = np.zeros
        out = {"A": Yk[:n, x], "Bp": Yp[:n], "Bu": Yk[:n, u], "B1": Yk[:n, w], "B2": self.B2,
               "Cq": Qk[:, x], "Dqp": Vall[:, ycols] @ Yp, "Dqu": Qk[:, u], "Dq1": Qk[:, w],
               "C1": self.C1, "D1p": nz((m, Yp.shape[1])), "D1u": nz((m, m)), "D11": nz((m, m)), "C2": self.C2}
        for k, v in out.items():  # rounding residue of the solves (1e-18 where the exact value is 0)
            v[np.abs(v) < LFT_ROUNDING * np.abs(v).max(initial=0.0)] = 0.0
        return {**out, "blocks": tuple(blocks)}

    def fmu_gains(self, K: np.ndarray) -> dict[str, float]:
        """Parameters of the state-feedback FMU (:mod:`satfmu.controllers.state_feedback`) for the gain
        ``u = K x`` on this design model's states (unselected axes: zero command).

        Parameters
        ----------
        K : numpy.ndarray, shape (na, n)
            Gain on the design states (``state_names``), N m per state unit.

        Raises
        ------
        VariantError
            If K does not have shape (n_axes, n) or is not finite.
        """
        try:
            return state_feedback.design_gains(K, self.variant.axes, self.variant.wheels, self.Q)
        except ValueError as exc:
            raise VariantError(str(exc)) from None


def _augment(A0: np.ndarray, B0: np.ndarray, na: int, nr: int, wheels: Wheels | None
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Plant (theta, theta', eta_r, eta_r') + xi, xw (+ y, y' of ``wheels``, None: no wheel
    dynamics): the design model's A, Bu, B1."""
    npl = A0.shape[0]
    nw = 2 * na if wheels is not None else 0
    n = npl + 2 * na + nw
    A = np.zeros((n, n))
    Bu = np.zeros((n, na))
    A[:npl, :npl] = A0
    B1 = np.zeros((n, na))
    B1[:npl] = B0
    xi, xw = npl, npl + na
    A[xi:xi + na, :na] = np.eye(na)
    A[xw:xw + na, xw:xw + na] = -PSEUDO_INTEGRATOR_POLE * np.eye(na)
    Bu[xw:xw + na] = np.eye(na)
    if wheels is not None:
        y, yd = xw + na, xw + 2 * na
        wn2, c = _wheel_coefficients(wheels)
        A[:npl, y:y + na] = B0
        A[y:y + na, yd:yd + na] = np.eye(na)
        A[yd:yd + na, y:y + na] = -wn2 * np.eye(na)
        A[yd:yd + na, yd:yd + na] = -c * np.eye(na)
        Bu[yd:yd + na] = wn2 * np.eye(na)
    else:
        A_u = np.zeros((n, na))
        A_u[:npl] = B0
        Bu = Bu + A_u
    return A, Bu, B1


def _wheel_coefficients(wheels: Wheels) -> tuple[float, float]:
    """``(wn^2, 2 zw wn)`` of the wheel ``y'' = wn^2 (u_c - y) - 2 zw wn y'`` (the plant's H(s))."""
    Aw, _, _ = demeter.wheel_state_space(wheels.natural_frequency, wheels.damping)
    return -Aw[2, 1], -Aw[2, 2]


def _group_tag(spacecraft: FlexibleSpacecraft, g: int) -> str:
    """The suffix naming the spacecraft's mode group ``g`` (0-based): the appendage's number for
    shared dynamics (``"2"``), else the appendage's and the mode's (``"2_1"``)."""
    group = spacecraft.groups[g]
    if group.kind is None:
        return f"{group.appendage + 1}"
    first = sum(len(a.modes) for a in spacecraft.appendages[:group.appendage])
    return f"{group.appendage + 1}_{group.columns[0] - first + 1}"


def _members(spacecraft: FlexibleSpacecraft, groups: list[list[int]]) -> list[list[int]]:
    """The spacecraft's mode groups (0-based) that each design group's coordinates cover."""
    return [[k for k, g in enumerate(spacecraft.groups) if set(g.columns) <= set(cols)] for cols in groups]


def _box(variant: Variant) -> tuple[list[UncertainParameter], dict[tuple[str, tuple[int, ...]], float]]:
    """The uncertain parameters of a variant in the order of delta, and the known ones (an
    interval of zero width) by ``(kind, index)``."""
    sc = variant.spacecraft
    ax = [a - 1 for a in variant.axes]
    unc = sc.inertia_uncertainty
    spread, product = (0.0, 0.0) if unc is None else (unc.moment_spread, unc.product_spread)
    inertia = "norm-bounded" if variant.uncertainty_type in (1, 3) else "uniform"
    modes = "norm-bounded" if variant.uncertainty_type == 1 else "uniform"
    out: list[UncertainParameter] = []
    fixed: dict[tuple[str, tuple[int, ...]], float] = {}

    def add(name: str, kind: str, index: tuple[int, ...], centre: float, half: float, distribution: str) -> None:
        if half > 0:
            out.append(UncertainParameter(name, kind, index, centre, half, distribution))
        else:
            fixed[(kind, index)] = centre

    def interval(lo: float, hi: float) -> tuple[float, float]:
        return (lo + hi) / 2, (hi - lo) / 2

    for k, i in enumerate(ax):
        add(f"sqrtJ{i + 1}{i + 1}", "sqrtJ", (k,), *interval(float(np.sqrt((1 - spread) * sc.tensor[i, i])),
                                                            float(np.sqrt((1 + spread) * sc.tensor[i, i]))), inertia)
    for k1 in range(len(ax)):
        for k2 in range(k1 + 1, len(ax)):
            i, j = ax[k1], ax[k2]
            add(f"J{i + 1}{j + 1}", "Jprod", (k1, k2), float(sc.tensor[i, j]), product, inertia)
    groups = state_feedback.flexible_groups(sc, variant.appendages, variant.model_type)
    for g, members in enumerate(_members(sc, groups)):
        tag = "" if len(groups) == 1 else _group_tag(sc, members[0])
        first = sc.groups[members[0]]  # model_type 2: every member has the same intervals (Variant checks)
        add(f"omega{tag}", "omega", (g,), *interval(first.frequency.low, first.frequency.high), modes)
        add(f"zeta{tag}", "zeta", (g,), *interval(first.damping.low, first.damping.high), modes)
    return out, fixed


def parameters(variant: Variant) -> list[UncertainParameter]:
    """The uncertain parameters of a variant, in the order of delta.

    The box comes from the variant's spacecraft: the roots of the principal inertias of the
    selected axes over ``[(1 - s) J_ii, (1 + s) J_ii]`` and their products over ``J_ij +- p``
    (its :class:`~satfmu.fmus.plants.flexible_spacecraft.InertiaUncertainty`; DEMETER: 30 %,
    3 kg m^2), the natural frequency and damping ratio of each mode group over their
    intervals. A parameter whose interval has zero width is known and not in the list.

    Parameters
    ----------
    variant : Variant
        The model variant: its axes give the inertia parameters, its appendages and
        ``model_type`` the mode groups, its ``uncertainty_type`` their distributions.

    Returns
    -------
    list of UncertainParameter
        Roots of the principal inertias, products of inertia, then omega and zeta of each group.
    """
    return _box(variant)[0]


def design_model(variant: Variant, L: np.ndarray | None = None) -> DesignModel:
    """The uncertain design model of ``variant`` (coupling ``L``, default the spacecraft's).

    Parameters
    ----------
    variant : Variant
        The model variant.
    L : numpy.ndarray, shape (3, nf), optional
        Coupling of the 3 axes with the spacecraft's nf flexible coordinates (dimensionless);
        default the spacecraft's own (DEMETER: :data:`satfmu.fmus.plants.demeter.L_SUBSTITUTE`).

    Returns
    -------
    DesignModel

    Raises
    ------
    VariantError
        If ``L`` is not a finite 3 x nf matrix, or nothing in the variant is uncertain (a
        robust design needs a box: give the spacecraft an inertia uncertainty or a mode an
        interval).
    """
    sc = variant.spacecraft
    L_full = sc.coupling if L is None else np.asarray(L, float)
    if L_full.shape != (demeter.N_AXES, len(sc.modes)) or not np.all(np.isfinite(L_full)):
        raise VariantError(f"L must be a finite 3 x {len(sc.modes)} matrix, got shape {np.shape(L_full)}")
    params, fixed = _box(variant)
    if not params:
        raise VariantError(f"{variant.label}: nothing is uncertain (every interval has zero width): a robust design "
                           f"needs a box; give {sc.name} an [inertia_uncertainty] or its modes' frequency or damping "
                           "an interval")
    ax = [a - 1 for a in variant.axes]
    groups = state_feedback.flexible_groups(sc, variant.appendages, variant.model_type)
    L_used = np.zeros_like(L_full)
    L_used[np.ix_(ax, sum(groups, []))] = L_full[np.ix_(ax, sum(groups, []))]
    L_r, Q, mode_group = state_feedback.reduction(variant.axes, groups, L_full)
    for g, cols in enumerate(groups):
        if not np.any(L_full[np.ix_(ax, cols)]) or g not in mode_group:
            modes = [f"{sc.appendages[a].name} {m.kind}" for c in cols for a, m in [sc.modes[c]]]
            raise VariantError(f"{variant.label}: the modes {modes} do not couple to axes {list(variant.axes)} "
                               "(their coupling L there is zero): they do not enter the design; leave their "
                               "appendage out of the variant or select the axes it couples to")
    dm = _assemble(variant, params, fixed, groups, L_used, Q, L_r, mode_group)
    dm.members = _members(sc, groups)
    return dm


def _assemble(variant: Variant, params: list[UncertainParameter], fixed: dict[tuple[str, tuple[int, ...]], float],
              groups: list[list[int]], L_used: np.ndarray, Q: np.ndarray, L_r: np.ndarray,
              mode_group: np.ndarray) -> DesignModel:
    """The affine descriptor of the design model (columns x', x, v, u, w1)."""
    na, nr = L_r.shape
    wheels = variant.wheels
    # state layout
    th, thd = np.arange(na), na + np.arange(na)
    eta, etad = 2 * na + np.arange(nr), 2 * na + nr + np.arange(nr)
    base = 2 * na + 2 * nr
    xi, xw = base + np.arange(na), base + na + np.arange(na)
    y, yd = base + 2 * na + np.arange(na), base + 3 * na + np.arange(na)
    n = base + (4 if wheels else 2) * na
    # auxiliaries: c = S theta'' (na), g = omega eta + 2 zeta eta' (nr)
    c_v, g_v = np.arange(na), na + np.arange(nr)
    n_v = na + nr
    cols = 2 * n + n_v + 2 * na
    XD, X, V, U, W = 0, n, 2 * n, 2 * n + n_v, 2 * n + n_v + na
    rows = n + n_v
    N0 = np.zeros((rows, cols))
    Nk = np.zeros((len(params), rows, cols))

    def coef(kind: str, index: tuple[int, ...]) -> tuple[float, float, int | None]:
        for k, p in enumerate(params):
            if p.kind == kind and p.index == index:
                return p.nominal, p.half_width, k
        return fixed[(kind, index)], 0.0, None

    r = 0

    def add(row: int, col: int, const: float, k: int | None = None, width: float = 0.0) -> None:
        N0[row, col] += const
        if k is not None:
            Nk[k, row, col] += width

    # kinematic rows: theta' = theta_dot ; eta' = eta_dot
    for i in range(na):
        add(r, XD + th[i], 1.0)
        add(r, X + thd[i], -1.0)
        r += 1
    for j in range(nr):
        add(r, XD + eta[j], 1.0)
        add(r, X + etad[j], -1.0)
        r += 1
    # c_i - S_i theta''_i = 0
    for i in range(na):
        s0, sw, k = coef("sqrtJ", (i,))
        add(r, V + c_v[i], 1.0)
        add(r, XD + thd[i], -s0, k, -sw)
        r += 1
    # rigid: S_i (c_i + sum_j L_r[i,j] eta''_j) + sum_{l != i} J_il theta''_l - tau_i - w1_i = 0
    for i in range(na):
        s0, sw, k = coef("sqrtJ", (i,))
        add(r, V + c_v[i], s0, k, sw)
        for j in range(nr):
            add(r, XD + etad[j], s0 * L_r[i, j], k, sw * L_r[i, j])
        for l in range(na):
            if l != i:
                p0, pw, kp = coef("Jprod", (min(i, l), max(i, l)))
                add(r, XD + thd[l], p0, kp, pw)
        if wheels:
            add(r, X + y[i], -1.0)
        else:
            add(r, U + i, -1.0)
        add(r, W + i, -1.0)
        r += 1
    # g_j - omega eta_j - 2 zeta eta'_j = 0
    for j in range(nr):
        w0, ww, kw = coef("omega", (int(mode_group[j]),))
        z0, zw, kz = coef("zeta", (int(mode_group[j]),))
        add(r, V + g_v[j], 1.0)
        add(r, X + eta[j], -w0, kw, -ww)
        add(r, X + etad[j], -2 * z0, kz, -2 * zw)
        r += 1
    # flex: sum_i L_r[i,j] c_i + eta''_j + omega g_j = 0
    for j in range(nr):
        w0, ww, kw = coef("omega", (int(mode_group[j]),))
        for i in range(na):
            add(r, V + c_v[i], L_r[i, j])
        add(r, XD + etad[j], 1.0)
        add(r, V + g_v[j], w0, kw, ww)
        r += 1
    # integrator, pseudo-integrator, wheel
    for i in range(na):
        add(r, XD + xi[i], 1.0)
        add(r, X + th[i], -1.0)
        r += 1
    for i in range(na):
        add(r, XD + xw[i], 1.0)
        add(r, X + xw[i], PSEUDO_INTEGRATOR_POLE)
        add(r, U + i, -1.0)
        r += 1
    if wheels:
        wn2, cw = _wheel_coefficients(variant.spacecraft.wheels)
        for i in range(na):
            add(r, XD + y[i], 1.0)
            add(r, X + yd[i], -1.0)
            r += 1
        for i in range(na):
            add(r, XD + yd[i], 1.0)
            add(r, X + y[i], wn2)
            add(r, X + yd[i], cw)
            add(r, U + i, -wn2)
            r += 1
    assert r == rows, (r, rows)
    names = state_feedback.design_states(variant.axes, nr, wheels)
    C1 = np.zeros((na, n))
    C1[:, th] = np.eye(na)
    B2 = np.zeros((n, 2 * na))
    for i in range(na):
        B2[th[i], 2 * i] = THETA_WORST
        B2[thd[i], 2 * i + 1] = RATE_WORST
    C2 = np.zeros((na, n))
    C2[:, xw] = np.eye(na)
    return DesignModel(variant, params, names, groups, L_used, Q, L_r, mode_group, N0, Nk, n, n_v, C1, B2, C2,
                       fixed=dict(fixed))


_INF = float("inf")
SEED_TABLE1: dict[tuple[Variant, str], tuple[float, ...] | None] = {
    (Variant((1,), (1,), 1, 1), "Prob"): (22.3, 2.9, 0.36, 1.5, 0.13, 1.01, 160.0),
    (Variant((1,), (1,), 1, 1), "Det"): (22.3, 4.7, 0.41, 1.5, 0.16, 1.16, 1.0),
    (Variant((1,), (1, 2), 1, 1), "Prob"): None,
    (Variant((1,), (1, 2), 1, 1), "Det"): None,
    (Variant((1,), (1, 2, 3, 4), 2, 1), "Prob"): (22.5, 3.0, 0.42, 1.3, 0.14, 0.84, 520.0),
    (Variant((1,), (1, 2, 3, 4), 2, 1), "Det"): (22.5, 3.0, 0.43, 1.3, 0.13, 0.99, 1.3),
    (Variant((1, 2), (1, 2, 3, 4), 2, 1), "Prob"): None,
    (Variant((1, 2), (1, 2, 3, 4), 2, 1), "Det"): None,
    (Variant((1, 2), (1, 2), 2, 1), "Prob"): (22.4, 2.8, 0.67, _INF, 0.2, 0.06, 2215.0),
    (Variant((1, 2), (1, 2), 2, 1), "Det"): (22.7, 5.0, _INF, _INF, 0.16, 0.5, 142.0),
    (Variant((1, 2), (1, 2), 2, 2), "Prob"): (22.46, 2.69, 0.7, 1.38, 0.19, 0.08, 1750.0),
    (Variant((1, 2), (1, 2), 2, 2), "Det"): (22.6, 4.24, 0.75, 1.03, 0.19, 0.14, 46.0),
    (Variant((1, 2, 3), (1, 2), 2, 2), "Prob"): (22.5, 3.3, _INF, _INF, 0.23, 0.66, 16387.0),
    (Variant((1, 2, 3), (1, 2), 2, 2), "Det"): (22.7, 8.1, _INF, _INF, 0.2, 1.34, 14111.0),
}
"""The seed's Table 1 in its order, (variant, method) -> the values of
:data:`SEED_TABLE1_COLUMNS`, None where the seed reports the variant infeasible."""
