"""The uncertain plants of the robust LMI modules, their input checks and their errors.

Plant (:class:`LFTPlant`), continuous time, in linear-fractional form::

    x' = A x + Bp p + Bu u + B1 w1 + B2 w2
    q  = Cq x + Dqp p + Dqu u + Dq1 w1
    z1 = C1 x + D1p p + D1u u + D11 w1          (H-infinity channel w1 -> z1)
    z2 = C2 x                                   (impulse-to-peak channel w2 -> z2)
    p  = Delta q,   Delta = blockdiag(delta_1 I_r1, ..., delta_N I_rN),  delta_k real in [-1, 1]

The parameters range over the box ``[-1, 1]^N``; :func:`box_vertices` lists its ``2^N``
vertices. The same plant as an implicit system affine in ``delta`` (:class:`AffineDescriptor`,
``N(delta) [x'; x; v; u; w1] = 0``, :meth:`AffineDescriptor.from_lft`) is the form of the
parameter-dependent Lyapunov analysis (:mod:`satfmu.synthesis.robust.pdlf`). The robust design on the LFT is
:mod:`satfmu.synthesis.robust.robust_design`; exact norms of sampled systems are
:mod:`satfmu.synthesis.core.system_norms`.

The input errors of these four modules are defined here: :class:`RobustLMIError` (a
``ValueError``) and its subclasses :class:`PlantDataError`, :class:`DeltaError`,
:class:`TooManyVerticesError`, :class:`ProgramTooLargeError`, :class:`NotHurwitzError`,
:class:`OptionError`.
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
from satfmu.fmus.errors import (DeltaError, NotHurwitzError as NotHurwitzError, OptionError, PlantDataError,
    ProgramTooLargeError as ProgramTooLargeError, RobustLMIError as RobustLMIError, TooManyVerticesError)


def _matrix(name: str, value) -> np.ndarray:
    a = np.asarray(value, dtype=float)
    if a.ndim != 2:
        raise PlantDataError(f"{name} must be a 2-D array, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise PlantDataError(f"{name} has non-finite entries")
    return a


def _sym(a: np.ndarray) -> np.ndarray:
    return (a + a.T) / 2


def _check_delta(delta, n_params: int) -> np.ndarray:
    d = np.asarray(delta, dtype=float)
    if d.shape != (n_params,):
        raise DeltaError(f"delta must have shape ({n_params},), got {d.shape}")
    if not np.all(np.isfinite(d)):
        raise DeltaError("delta has non-finite entries")
    if np.any(np.abs(d) > 1):
        raise DeltaError(f"delta must lie in [-1, 1], got {d}")
    return d


def _check_gain(K, m: int, n: int) -> np.ndarray:
    K = _matrix("K", K)
    if K.shape != (m, n):
        raise PlantDataError(f"K must have shape ({m}, {n}), got {K.shape}")
    return K


def _check_vertices(n_params: int, max_vertices: int) -> None:
    if not (isinstance(max_vertices, (int, np.integer)) and max_vertices >= 1):
        raise OptionError(f"max_vertices must be an integer >= 1, got {max_vertices!r}")
    if 2**n_params > max_vertices:
        raise TooManyVerticesError(f"{n_params} uncertain parameters give 2^{n_params} = {2**n_params} "
                                   f"box vertices, more than max_vertices = {max_vertices}")


def _block_starts(reps: np.ndarray) -> np.ndarray:
    """Offsets of the blocks in q (and p): ``[0, r_1, r_1 + r_2, ..., n_q]``."""
    return np.cumsum(np.concatenate([[0], reps])).astype(int)


def box_vertices(n_params: int) -> np.ndarray:
    """The ``2^N`` vertices of ``[-1, 1]^N``, shape (2^N, N) (one empty vertex when N = 0).

    Parameters
    ----------
    n_params : int
        N, the number of uncertain parameters (>= 0).

    Returns
    -------
    numpy.ndarray, shape (2^N, N)
        One vertex per row, entries -1 or 1.
    """
    return np.array(list(itertools.product((-1.0, 1.0), repeat=n_params))).reshape(2**n_params, n_params)


_LFT_FIELDS = ("A", "Bp", "Bu", "B1", "B2", "Cq", "Dqp", "Dqu", "Dq1", "C1", "D1p", "D1u", "D11", "C2")


@dataclass(frozen=True)
class LFTPlant:
    """Uncertain continuous-time plant in linear-fractional form (module docstring).

    Sizes: ``n`` states, ``m`` inputs u, ``n_q`` uncertainty channels (``sum r_k``), ``m1``,
    ``p1`` for w1, z1 and ``m2``, ``p2`` for w2, z2; every channel but q has at least one
    signal (pass a zero column for an unused one). Units are the caller's (time in s).

    Parameters
    ----------
    A : ndarray, shape (n, n)
    Bp, Bu, B1, B2 : ndarray, shapes (n, n_q), (n, m), (n, m1), (n, m2)
    Cq : ndarray, shape (n_q, n)
    Dqp, Dqu, Dq1 : ndarray, shapes (n_q, n_q), (n_q, m), (n_q, m1)
    C1 : ndarray, shape (p1, n)
    D1p, D1u, D11 : ndarray, shapes (p1, n_q), (p1, m), (p1, m1)
    C2 : ndarray, shape (p2, n)
    blocks : tuple of (str, int)
        ``(name, r_k)`` per uncertain parameter, in the order of ``q`` and ``p``; empty for a
        certain plant (then ``n_q = 0``: see :meth:`without_uncertainty`).
    """

    A: np.ndarray
    Bp: np.ndarray
    Bu: np.ndarray
    B1: np.ndarray
    B2: np.ndarray
    Cq: np.ndarray
    Dqp: np.ndarray
    Dqu: np.ndarray
    Dq1: np.ndarray
    C1: np.ndarray
    D1p: np.ndarray
    D1u: np.ndarray
    D11: np.ndarray
    C2: np.ndarray
    blocks: tuple[tuple[str, int], ...] = ()

    def __post_init__(self) -> None:
        for k in _LFT_FIELDS:
            object.__setattr__(self, k, _matrix(k, getattr(self, k)))
        n, nq = self.A.shape[0], self.Cq.shape[0]
        m, m1, m2 = self.Bu.shape[1], self.B1.shape[1], self.B2.shape[1]
        p1, p2 = self.C1.shape[0], self.C2.shape[0]
        expected = {"A": (n, n), "Bp": (n, nq), "Bu": (n, m), "B1": (n, m1), "B2": (n, m2),
                    "Cq": (nq, n), "Dqp": (nq, nq), "Dqu": (nq, m), "Dq1": (nq, m1),
                    "C1": (p1, n), "D1p": (p1, nq), "D1u": (p1, m), "D11": (p1, m1), "C2": (p2, n)}
        for k, shape in expected.items():
            if getattr(self, k).shape != shape:
                raise PlantDataError(f"{k} must have shape {shape}, got {getattr(self, k).shape}")
        for name, size in (("x", n), ("u", m), ("w1", m1), ("z1", p1), ("w2", m2), ("z2", p2)):
            if size < 1:
                raise PlantDataError(f"the plant needs at least one {name} signal")
        try:
            blocks = tuple((str(name), int(r)) for name, r in self.blocks)
        except (TypeError, ValueError) as exc:
            raise PlantDataError(f"blocks must be (name, repetition) pairs, got {self.blocks!r}") from exc
        if any(r < 1 or r != rr for (_, r), (_, rr) in zip(blocks, self.blocks)):
            raise PlantDataError(f"block repetitions must be integers >= 1, got {self.blocks!r}")
        if len({b[0] for b in blocks}) != len(blocks):
            raise PlantDataError(f"block names must be unique, got {[b[0] for b in blocks]}")
        if sum(r for _, r in blocks) != nq:
            raise PlantDataError(f"block repetitions sum to {sum(r for _, r in blocks)}, Cq has {nq} rows")
        object.__setattr__(self, "blocks", blocks)

    @classmethod
    def without_uncertainty(cls, A, Bu, B1, B2, C1, D1u, D11, C2) -> LFTPlant:
        """A certain plant (no blocks, ``n_q = 0``).

        Parameters
        ----------
        A : array_like, shape (n, n)
            State matrix.
        Bu : array_like, shape (n, m)
            Control input matrix.
        B1 : array_like, shape (n, m1)
            Input matrix of the H-infinity disturbance w1.
        B2 : array_like, shape (n, m2)
            Input matrix of the impulse-to-peak disturbance w2.
        C1 : array_like, shape (p1, n)
            State to the H-infinity output z1.
        D1u : array_like, shape (p1, m)
            Control input to z1.
        D11 : array_like, shape (p1, m1)
            Feedthrough w1 to z1.
        C2 : array_like, shape (p2, n)
            State to the impulse-to-peak output z2.

        Returns
        -------
        LFTPlant
            The plant with empty uncertainty channels.
        """
        A, Bu, B1, C1 = (np.asarray(a, float) for a in (A, Bu, B1, C1))
        n, m, m1, p1 = A.shape[0], Bu.shape[1], B1.shape[1], C1.shape[0]
        z = np.zeros
        return cls(A, z((n, 0)), Bu, B1, B2, z((0, n)), z((0, 0)), z((0, m)), z((0, m1)),
                   C1, z((p1, 0)), D1u, D11, C2, ())

    @property
    def n_params(self) -> int:
        """Number N of uncertain parameters (blocks)."""
        return len(self.blocks)

    @property
    def repetitions(self) -> np.ndarray:
        """``r_k`` per block, shape (N,)."""
        return np.array([r for _, r in self.blocks], dtype=int)

    def delta_matrix(self, delta) -> np.ndarray:
        """``Delta = blockdiag(delta_k I_rk)``, shape (n_q, n_q); delta in [-1, 1]^N.

        Parameters
        ----------
        delta : array_like, shape (N,)
            The uncertain parameters, each in [-1, 1] (normalized, dimensionless).

        Raises
        ------
        DeltaError
            If ``delta`` does not have shape (N,), is not finite or leaves the box.
        """
        return np.diag(np.repeat(_check_delta(delta, self.n_params), self.repetitions))

    def evaluate(self, delta) -> tuple[np.ndarray, ...]:
        """The plant at ``delta`` (upper star product): ``(A, Bu, B1, C1, D1u, D11)``.

        ``X = Delta (I - Dqp Delta)^-1``; ``A + Bp X Cq``, ``Bu + Bp X Dqu``, ``B1 + Bp X Dq1``,
        ``C1 + D1p X Cq``, ``D1u + D1p X Dqu``, ``D11 + D1p X Dq1``.

        Parameters
        ----------
        delta : array_like, shape (N,)
            The uncertain parameters, each in [-1, 1] (normalized, dimensionless).

        Raises
        ------
        DeltaError
            If delta is not in the box, or ``I - Dqp Delta`` is singular (ill-posed loop).
        """
        D = self.delta_matrix(delta)
        M = np.eye(len(D)) - self.Dqp @ D
        if len(D) and np.linalg.cond(M) > 1e12:
            raise DeltaError(f"I - Dqp Delta is singular at delta = {np.asarray(delta)}: the LFT is ill posed")
        X = D @ np.linalg.solve(M, np.hstack([self.Cq, self.Dqu, self.Dq1]))
        n, m = self.A.shape[0], self.Bu.shape[1]
        top = np.hstack([self.A, self.Bu, self.B1]) + self.Bp @ X
        bottom = np.hstack([self.C1, self.D1u, self.D11]) + self.D1p @ X
        return top[:, :n], top[:, n:n + m], top[:, n + m:], bottom[:, :n], bottom[:, n:n + m], bottom[:, n + m:]

    def nominal(self) -> tuple[np.ndarray, ...]:
        """:meth:`evaluate` at ``delta = 0``."""
        return self.evaluate(np.zeros(self.n_params))

    def closed_loop(self, K, delta) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(A + Bu K, B1, C1 + D1u K, D11)`` at ``delta`` for ``u = K x`` (K shape (m, n)).

        Parameters
        ----------
        K : array_like, shape (m, n)
            State-feedback gain of ``u = K x``.
        delta : array_like, shape (N,)
            The uncertain parameters, each in [-1, 1].

        Raises
        ------
        PlantDataError
            If ``K`` does not have shape (m, n) or is not finite.
        DeltaError
            As :meth:`evaluate`.
        """
        A, Bu, B1, C1, D1u, D11 = self.evaluate(delta)
        K = _check_gain(K, Bu.shape[1], A.shape[0])
        return A + Bu @ K, B1, C1 + D1u @ K, D11

    def at(self, delta) -> LFTPlant:
        """The certain plant at ``delta`` (no blocks; w2, z2 unchanged).

        Parameters
        ----------
        delta : array_like, shape (N,)
            The uncertain parameters, each in [-1, 1] (normalized, dimensionless).
        """
        A, Bu, B1, C1, D1u, D11 = self.evaluate(delta)
        return LFTPlant.without_uncertainty(A, Bu, B1, self.B2, C1, D1u, D11, self.C2)

    def scale_states(self, T) -> LFTPlant:
        """The same plant in the coordinates ``x_s`` of ``x = diag(T) x_s`` (T > 0, shape (n,)).

        A gain ``K`` of this plant becomes ``K_s = K diag(T)``; a dual Lyapunov matrix ``Y``
        becomes ``Y_s = diag(T)^-1 Y diag(T)^-1``; bounds, multipliers and poles are unchanged.

        Parameters
        ----------
        T : array_like, shape (n,)
            Positive scale of each state (in the state's unit per unit of ``x_s``).

        Raises
        ------
        PlantDataError
            If ``T`` does not have shape (n,) or has an entry that is not finite and > 0.
        """
        T = np.asarray(T, dtype=float)
        if T.shape != (self.A.shape[0],) or not np.all(np.isfinite(T) & (T > 0)):
            raise PlantDataError(f"T must be {self.A.shape[0]} positive scales, got {T}")
        out = {k: getattr(self, k) for k in _LFT_FIELDS}
        out["A"] = self.A * T[None, :] / T[:, None]
        for k in ("Bp", "Bu", "B1", "B2"):
            out[k] = out[k] / T[:, None]
        for k in ("Cq", "C1", "C2"):
            out[k] = out[k] * T[None, :]
        return LFTPlant(**out, blocks=self.blocks)

    def balance_channels(self) -> LFTPlant:
        """The same plant with each uncertainty channel i scaled, ``p_i / c_i = delta (q_i / c_i)``,
        ``c_i = sqrt(|Cq_i| / |Bp_i|)``: its input and output columns get the same size (exact: a
        common factor on ``p_i`` and ``q_i`` keeps ``p = Delta q``)."""
        bp, cq = np.linalg.norm(self.Bp, axis=0), np.linalg.norm(self.Cq, axis=1)
        c = np.sqrt(np.where((bp > 0) & (cq > 0), cq / np.where(bp > 0, bp, 1.0), 1.0))
        out = {k: getattr(self, k) for k in _LFT_FIELDS}
        out["Bp"], out["D1p"] = self.Bp * c, self.D1p * c
        out["Dqp"] = self.Dqp * c[None, :] / c[:, None]
        for k in ("Cq", "Dqu", "Dq1"):
            out[k] = out[k] / c[:, None]
        return LFTPlant(**out, blocks=self.blocks)


@dataclass(frozen=True)
class AffineDescriptor:
    """Implicit plant affine in the parameters: ``N(delta) [x'; x; v; u; w1] = 0``.

    ``N(delta) = N0 + sum_k delta_k Nk[k]`` with ``n + n_v`` rows and ``2 n + n_v + m_u + m_w``
    columns in the order ``(x', x, v, u, w1)``; ``z1 = C1 x + D1u u + D11 w1``. For every
    delta in ``[-1, 1]^N`` the columns of ``x'`` and ``v`` must form a nonsingular matrix.

    Parameters
    ----------
    N0 : ndarray, shape (n + n_v, 2 n + n_v + m_u + m_w)
    Nk : ndarray, shape (N, n + n_v, 2 n + n_v + m_u + m_w)
    n, n_v, m_u, m_w : int
        Sizes of x (>= 1), v (>= 0), u (>= 1), w1 (>= 1).
    C1, D1u, D11 : ndarray, shapes (p, n), (p, m_u), (p, m_w)
    names : tuple of str
        The N parameter names.
    """

    N0: np.ndarray
    Nk: np.ndarray
    n: int
    n_v: int
    m_u: int
    m_w: int
    C1: np.ndarray
    D1u: np.ndarray
    D11: np.ndarray
    names: tuple[str, ...]

    def __post_init__(self) -> None:
        for k, low in (("n", 1), ("n_v", 0), ("m_u", 1), ("m_w", 1)):
            v = getattr(self, k)
            if not (isinstance(v, (int, np.integer)) and v >= low):
                raise PlantDataError(f"{k} must be an integer >= {low}, got {v!r}")
            object.__setattr__(self, k, int(v))
        rows, cols = self.n + self.n_v, 2 * self.n + self.n_v + self.m_u + self.m_w
        N0 = _matrix("N0", self.N0)
        Nk = np.asarray(self.Nk, dtype=float)
        if N0.shape != (rows, cols):
            raise PlantDataError(f"N0 must have shape ({rows}, {cols}), got {N0.shape}")
        if Nk.ndim != 3 or Nk.shape[1:] != (rows, cols):
            raise PlantDataError(f"Nk must have shape (N, {rows}, {cols}), got {Nk.shape}")
        if not np.all(np.isfinite(Nk)):
            raise PlantDataError("Nk has non-finite entries")
        names = tuple(self.names)
        if len(names) != Nk.shape[0] or len(set(names)) != len(names) or \
                not all(isinstance(name, str) for name in names):
            raise PlantDataError(f"names must be {Nk.shape[0]} distinct strings, got {self.names!r}")
        C1, D1u, D11 = (_matrix(k, getattr(self, k)) for k in ("C1", "D1u", "D11"))
        p = C1.shape[0]
        for k, a, shape in (("C1", C1, (p, self.n)), ("D1u", D1u, (p, self.m_u)), ("D11", D11, (p, self.m_w))):
            if a.shape != shape or p < 1:
                raise PlantDataError(f"{k} must have shape {shape} with p >= 1, got {a.shape}")
        for k, v in (("N0", N0), ("Nk", Nk), ("C1", C1), ("D1u", D1u), ("D11", D11), ("names", names)):
            object.__setattr__(self, k, v)

    @classmethod
    def from_lft(cls, plant: LFTPlant) -> AffineDescriptor:
        """The LFT as a descriptor with ``v = p``: ``x' = A x + Bp p + Bu u + B1 w1`` and
        ``p - Delta (Cq x + Dqp p + Dqu u + Dq1 w1) = 0`` (affine in delta); w2, z2 dropped.

        Parameters
        ----------
        plant : LFTPlant
            The plant, with ``D1p = 0``.

        Raises
        ------
        PlantDataError
            If ``D1p != 0`` (the descriptor's z1 cannot depend on v).
        """
        if np.any(plant.D1p != 0):
            raise PlantDataError("from_lft needs D1p = 0: the descriptor's z1 does not depend on v")
        n, nq, m, m1 = plant.A.shape[0], plant.Cq.shape[0], plant.Bu.shape[1], plant.B1.shape[1]
        N0 = np.block([[np.eye(n), -plant.A, -plant.Bp, -plant.Bu, -plant.B1],
                       [np.zeros((nq, n)), np.zeros((nq, n)), np.eye(nq), np.zeros((nq, m)), np.zeros((nq, m1))]])
        Nk = np.zeros((plant.n_params,) + N0.shape)
        start = _block_starts(plant.repetitions)
        for k in range(plant.n_params):
            Xi = np.zeros((nq, nq))
            Xi[start[k]:start[k + 1], start[k]:start[k + 1]] = np.eye(plant.repetitions[k])
            Nk[k, n:] = -Xi @ np.hstack([np.zeros((nq, n)), plant.Cq, plant.Dqp, plant.Dqu, plant.Dq1])
        return cls(N0, Nk, n, nq, m, m1, plant.C1, plant.D1u, plant.D11, tuple(b[0] for b in plant.blocks))

    @property
    def n_params(self) -> int:
        """Number N of uncertain parameters."""
        return len(self.names)

    def _slices(self) -> tuple[slice, slice, slice, slice, slice]:
        n, nv, mu = self.n, self.n_v, self.m_u
        return (slice(0, n), slice(n, 2 * n), slice(2 * n, 2 * n + nv),
                slice(2 * n + nv, 2 * n + nv + mu), slice(2 * n + nv + mu, None))

    def matrix(self, delta) -> np.ndarray:
        """``N(delta)``, shape (n + n_v, 2 n + n_v + m_u + m_w).

        Parameters
        ----------
        delta : array_like, shape (N,)
            The uncertain parameters, each in [-1, 1] (normalized, dimensionless).
        """
        d = _check_delta(delta, self.n_params)
        return self.N0 + np.tensordot(d, self.Nk, axes=1)

    def state_space(self, delta) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(A, Bu, B1)`` of ``x' = A x + Bu u + B1 w1`` at delta, solving N for ``(x', v)``.

        Parameters
        ----------
        delta : array_like, shape (N,)
            The uncertain parameters, each in [-1, 1] (normalized, dimensionless).

        Raises
        ------
        DeltaError
            If the ``(x', v)`` columns of N(delta) are singular.
        """
        Nd = self.matrix(delta)
        sd, sx, sv, su, sw = self._slices()
        E = np.hstack([Nd[:, sd], Nd[:, sv]])
        if np.linalg.cond(E) > 1e12:
            raise DeltaError(f"the (x', v) columns of N are singular at delta = {np.asarray(delta)}")
        S = -np.linalg.solve(E, np.hstack([Nd[:, sx], Nd[:, su], Nd[:, sw]]))[:self.n]
        return S[:, :self.n], S[:, self.n:self.n + self.m_u], S[:, self.n + self.m_u:]

    def scale_states(self, T) -> AffineDescriptor:
        """The same plant in the coordinates ``x_s`` of ``x = diag(T) x_s`` (T > 0, shape (n,)):
        the ``x'`` and ``x`` columns of N times T, its first n rows (the state equations, as
        :meth:`from_lft` writes them) divided by T, ``C1`` times T. A gain ``K`` becomes
        ``K diag(T)``, a Lyapunov matrix ``P`` becomes ``diag(T) P diag(T)``; the H-infinity norm
        of every loop is unchanged.

        Parameters
        ----------
        T : array_like, shape (n,)
            Positive scale of each state (in the state's unit per unit of ``x_s``).

        Raises
        ------
        PlantDataError
            If ``T`` does not have shape (n,) or has an entry that is not finite and > 0.
        """
        T = np.asarray(T, dtype=float)
        if T.shape != (self.n,) or not np.all(np.isfinite(T) & (T > 0)):
            raise PlantDataError(f"T must be {self.n} positive scales, got {T}")
        cols = np.ones(self.N0.shape[1])
        cols[:2 * self.n] = np.concatenate([T, T])
        rows = np.ones(self.N0.shape[0])
        rows[:self.n] = 1.0 / T
        return AffineDescriptor(self.N0 * rows[:, None] * cols[None, :], self.Nk * rows[None, :, None] * cols,
                                self.n, self.n_v, self.m_u, self.m_w, self.C1 * T[None, :], self.D1u, self.D11,
                                self.names)

    def loop_constraint(self, K, delta) -> np.ndarray:
        """``M(delta)`` with ``M [x'; x; v; w1] = 0`` the loop ``u = K x``: ``[N_x', N_x + N_u K, N_v, N_w]``.

        Parameters
        ----------
        K : array_like, shape (m_u, n)
            State-feedback gain of ``u = K x``.
        delta : array_like, shape (N,)
            The uncertain parameters, each in [-1, 1].

        Returns
        -------
        numpy.ndarray, shape (n + n_v, 2 n + n_v + m_w)
            The closed loop's constraint matrix.
        """
        K = _check_gain(K, self.m_u, self.n)
        Nd = self.matrix(delta)
        sd, sx, sv, su, sw = self._slices()
        return np.hstack([Nd[:, sd], Nd[:, sx] + Nd[:, su] @ K, Nd[:, sv], Nd[:, sw]])
