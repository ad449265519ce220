"""Linear stability margins of a controller on its plant: loop at a time, disk margins, sensitivity peaks.

The plant and the controller are linearized at an operating point from their symbolic models
(:func:`satfmu.fmus.linearization.linearize`); the controller's inputs are the plant's outputs of
the same names and its outputs the plant's inputs of the same names (as a scenario connects
them). With ``P`` the plant from those inputs to those outputs and ``K`` the controller, the loop
broken at the plant input is ``L = -K P`` (negative feedback: the loop is stable with its
nominal gain when ``I + L`` has no zeros in the right half plane).

- Loop at a time (input channel ``i``, the others closed): the loop transfer of channel ``i``,
  ``L_i = -(G_ii + G_io (I - G_oo)^-1 G_oi)`` with ``G = K P``; its gain margin (dB), phase margin
  (deg), the frequencies where they are read, and the delay margin ``PM / w_c`` (s).
- The MIMO disk margins at the plant input (balanced, skew 0): the disk-based gain margin (dB) and
  phase margin (deg) that hold for simultaneous, independent perturbations of every actuator
  channel (python-control's structured bound, through slycot). Not at the output: for state
  feedback the loop broken there has as many channels as states and the rank of the inputs
  (slycot's ``ab13md`` does not return on such a 6 x 6 loop of rank 3).
- The peaks of the largest singular value of ``S = (I + L)^-1`` and ``T = L (I + L)^-1``.

Continuous time, and sampled: the plant discretized with a zero-order hold at the communication
step (the controller's output held over it; a dynamic controller discretized likewise), which
counts the hold's half-step delay. python-control (``control``) computes the margins; the tests
hold its figures against :func:`sweep_margins`, a frequency sweep of our own.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import control
import numpy as np

from satfmu.fmus.linearization import Linearization

FREQUENCIES = np.logspace(-5, 3, 400)
"""Frequency grid of the disk margins and the sensitivity peaks, rad/s (cut at the Nyquist frequency
of a sampled loop)."""
LOWEST_CROSSOVER = 1e-6
"""Phase crossovers below this frequency are not read as gain margins, rad/s: a loop with a double
integrator reaches -180 deg only as the frequency goes to 0 (its gain unbounded there)."""
MINREAL_TOL = 1e-8
"""Tolerance of the pole-zero cancellation of a loop's realization (python-control's ``minreal``)."""
MARGIN_FREQUENCIES = np.logspace(-5, 3, 2001)
"""Frequency grid of the loop-at-a-time margins, rad/s: 250 points a decade (python-control
interpolates the crossovers between its points with a spline; its cost grows with the points)."""


@dataclass(frozen=True)
class LoopMargin:
    """The classical margins of one loop broken at a time.

    Parameters
    ----------
    channel : str
        The plant input where the loop is broken.
    gain_margin_db : float
        Gain margin, dB: the smallest gain increase that destabilizes (inf when none does). A
        double integrator under PD control crosses -180 deg only as the frequency goes to 0,
        where the gain is unbounded: no gain reduction destabilizes it either.
    lower_gain_margin_db : float
        The smallest gain reduction that destabilizes, dB (negative; -inf when none does, read at
        phase crossovers above :data:`LOWEST_CROSSOVER`).
    phase_margin_deg : float
        Phase margin, deg: the smallest rotation, lead or lag, that brings the loop to -1 at one
        of its gain crossovers (>= 0; inf when the gain never crosses 1). A loop may cross 0 dB
        with its phase above 0 (the four-wheel loop rises through 0 dB at 1.2e-4 rad/s with the
        phase of a zero at the origin, +90 deg): the phase it tolerates there is 90 deg either
        way, not the -90 deg that ``180 + phase`` wraps to. With the closed loop unstable
        (``Margins.closed_loop_stable`` false) no margin means anything.
    phase_crossover : float
        Frequency of the gain margin, rad/s (nan when none).
    gain_crossover : float
        Frequency of the phase margin, rad/s (nan when none).
    delay_margin : float
        The extra delay the loop tolerates, s: a delay only lags, so at each gain crossover
        ``w`` it takes the lag ``(180 + phase) mod 360`` deg, over ``w``; the smallest of them
        (``phase margin / gain crossover`` when the loop crosses once).
    """

    channel: str
    gain_margin_db: float
    lower_gain_margin_db: float
    phase_margin_deg: float
    phase_crossover: float
    gain_crossover: float
    delay_margin: float


@dataclass(frozen=True)
class Margins:
    """A controller's margins on its plant at one operating point, continuous or sampled.

    Parameters
    ----------
    sample_time : float
        0 for the continuous loop, else the communication step of the sampled loop, s.
    closed_loop_stable : bool
        Every pole of the closed loop's minimal realization in the open left half plane (inside the
        unit circle when sampled): the modes the loop neither moves nor sees are left out.
    loops : list of LoopMargin
        One per plant input, loop at a time.
    disk_gain_margin_db, disk_phase_margin_deg : float
        Balanced MIMO disk margins at the plant input, dB and deg.
    sensitivity_peak, complementary_peak : float
        Peaks of the largest singular value of S and T at the plant input.
    unused : tuple of str
        Controller outputs that are 0 at the point whatever the measurement (an axis a single-axis
        design leaves alone): no part of the loop.
    """

    sample_time: float
    closed_loop_stable: bool
    loops: list[LoopMargin] = field(default_factory=list)
    disk_gain_margin_db: float = math.nan
    disk_phase_margin_deg: float = math.nan
    sensitivity_peak: float = math.nan
    complementary_peak: float = math.nan
    unused: tuple[str, ...] = ()


def _ss(lin: Linearization) -> control.StateSpace:
    if lin.A.shape[0] == 0:
        return control.ss([], [], [], lin.D)
    return control.ss(lin.A, lin.B, lin.C, lin.D)


def loop_transfers(plant: Linearization, controller: Linearization, sample_time: float = 0.0
                   ) -> tuple[control.StateSpace, control.StateSpace]:
    """The loop transfers at the plant input (``-K P``) and output (``-P K``).

    Parameters
    ----------
    plant : Linearization
        The plant, its inputs the controller's outputs and its outputs the controller's inputs
        (by name, in any order).
    controller : Linearization
        The controller.
    sample_time : float, optional
        0: continuous; else both discretized with a zero-order hold at this step, s.

    Returns
    -------
    at_input, at_output : control.StateSpace
        ``m x m`` and ``p x p``.

    Raises
    ------
    ValueError
        A controller input that is no plant output, or a controller output that is no plant
        input.
    """
    missing = [n for n in controller.inputs if n not in plant.outputs]
    missing += [n for n in controller.outputs if n not in plant.inputs]
    if missing:
        raise ValueError(f"the controller's {', '.join(missing)} match no plant output or input of that name")
    rows = [plant.outputs.index(n) for n in controller.inputs]
    cols = [plant.inputs.index(n) for n in controller.outputs]
    P = control.ss(plant.A, plant.B[:, cols], plant.C[rows, :], plant.D[np.ix_(rows, cols)])
    K = _ss(controller)
    if sample_time > 0:
        P = control.c2d(P, sample_time, "zoh")
        K = control.c2d(K, sample_time, "zoh") if controller.A.shape[0] else control.ss([], [], [], controller.D,
                                                                                     sample_time)
    return -K * P, -P * K


def channel_responses(plant: Linearization, controller: Linearization, omega: np.ndarray,
                      sample_time: float = 0.0) -> list[tuple[str, np.ndarray]]:
    """The frequency responses of the loop-at-a-time transfers of each plant input channel, the
    others closed.

    Parameters
    ----------
    plant, controller : Linearization
        As :func:`loop_transfers`.
    omega : numpy.ndarray
        Frequencies, rad/s.
    sample_time : float, optional
        0: continuous; else the communication step, s.

    Returns
    -------
    list of (str, numpy.ndarray)
        The controller output (channel) and its loop's complex response at ``omega``.
    """
    L_in, _ = loop_transfers(plant, controller, sample_time)
    G = -response(L_in, omega)
    return [(name, channel_response(G, i)) for i, name in enumerate(controller.outputs)]


def channel_response(G: np.ndarray, i: int) -> np.ndarray:
    """``L_i = -(G_ii + G_io (I - G_oo)^-1 G_oi)``, channel ``i`` broken and the others closed,
    frequency by frequency from the response of ``G = K P``.

    Computed from the response, not from a realization: forming the interconnection repeats the
    plant's states, and cancelling them again (a minimal realization) mistook the rigid-body and
    wheel poles at 0 for zeros of the four-wheel loop (a spurious crossover at 1e-4 rad/s, read
    as a -90 deg phase margin).

    Parameters
    ----------
    G : numpy.ndarray
        Complex, shape ``(m, m, N)``: ``G = K P`` at N frequencies.
    i : int
        The channel.

    Returns
    -------
    numpy.ndarray
        Complex, shape ``(N,)``.
    """
    others = [j for j in range(G.shape[0]) if j != i]
    if not others:
        return -G[i, i]
    Gk = np.moveaxis(G, -1, 0)  # (N, m, m)
    g_oo = Gk[:, others][:, :, others]
    g_oi = Gk[:, others, i][:, :, None]
    g_io = Gk[:, i, others][:, None, :]
    eye = np.eye(len(others))
    return -(Gk[:, i, i] + (g_io @ np.linalg.solve(eye - g_oo, g_oi))[:, 0, 0])


def margins(plant: Linearization, controller: Linearization, sample_time: float = 0.0) -> Margins:
    """The margins of ``controller`` on ``plant`` (see the module's docstring).

    Parameters
    ----------
    plant, controller : Linearization
        As :func:`loop_transfers`.
    sample_time : float, optional
        0 for the continuous loop, else the communication step, s.

    Returns
    -------
    Margins
    """
    active = [i for i in range(len(controller.outputs))
              if np.any(controller.C[i]) or np.any(controller.D[i])]
    unused = tuple(n for i, n in enumerate(controller.outputs) if i not in active)
    if not active:
        raise ValueError("the controller's outputs are all 0 at this point: there is no loop")
    controller = restrict(controller, [controller.outputs[i] for i in active])
    L_in, _ = loop_transfers(plant, controller, sample_time)
    G = -L_in
    closed = control.feedback(control.ss([], [], [], np.eye(L_in.ninputs), L_in.dt), L_in, sign=-1)
    # the loop's own modes: a mode the loop neither moves nor sees (an axis this controller leaves
    # alone, its rigid-body poles at 0) is no part of its stability
    poles = control.minreal(closed, tol=MINREAL_TOL, verbose=False).poles()
    stable = bool(np.all(np.abs(poles) < 1 - 1e-12) if sample_time > 0 else np.all(poles.real < 0))
    omega = FREQUENCIES[FREQUENCIES < math.pi / sample_time] if sample_time > 0 else FREQUENCIES
    grid = _grid(sample_time)
    G_resp = response(G, grid)
    loops = [_loop_margin(name, channel_response(G_resp, i), grid) for i, name in enumerate(controller.outputs)]
    alpha_mu, _, _ = control.disk_margins(L_in, omega)
    S_peak, T_peak, S_half = _peaks(L_in, omega)
    # mu <= the largest singular value, so the structured margin is at least 1 / max sigma(S - I/2);
    # slycot's mu bound is below that on loops with a channel of no gain (the VSCMG's T1 at q2 = 0):
    # a numerical failure, and the unstructured margin, which holds, is kept
    alpha = max(float(alpha_mu) if np.isfinite(alpha_mu) else 0.0, 1.0 / S_half if S_half > 0 else math.inf)
    gm, pm = _disk_gain_phase(alpha)
    return Margins(sample_time, stable, loops, gm, pm, S_peak, T_peak, unused)


def _disk_gain_phase(alpha: float) -> tuple[float, float]:
    """The balanced (skew 0) disk margin ``alpha`` as a gain margin, dB, and a phase margin, deg."""
    if alpha >= 2:
        return math.inf, 90.0
    return 20 * math.log10((1 + alpha / 2) / (1 - alpha / 2)), math.degrees(2 * math.atan(alpha / 2))


def response(L: control.StateSpace, omega: np.ndarray) -> np.ndarray:
    """The frequency response of a system: ``L(j omega)``, or ``L(e^{j omega T})`` when sampled.

    Parameters
    ----------
    L : control.StateSpace
        The system (continuous, or discrete with its ``dt``).
    omega : numpy.ndarray
        Frequencies, rad/s.

    Returns
    -------
    numpy.ndarray
        Complex, shape ``(outputs, inputs, len(omega))``.
    """
    points = 1j * omega if L.dt == 0 else np.exp(1j * omega * L.dt)
    return np.asarray(L(points)).reshape(L.noutputs, L.ninputs, len(omega))


def _grid(sample_time: float) -> np.ndarray:
    """:data:`MARGIN_FREQUENCIES`, below the Nyquist frequency of a sampled loop."""
    if sample_time > 0:
        return MARGIN_FREQUENCIES[MARGIN_FREQUENCIES < 0.999 * math.pi / sample_time]
    return MARGIN_FREQUENCIES


def _loop_margin(channel: str, L: np.ndarray, omega: np.ndarray) -> LoopMargin:
    """The margins of one SISO loop from every crossover python-control finds on its frequency
    response ``L`` at ``omega`` (``frd``: its polynomial search on a sampled loop's realization met
    spurious crossovers, a 0.6 dB gain margin where the response gives none)."""
    data = control.frd(L, omega)
    gms, pms, _, wpcs, wgcs, _ = control.stability_margins(data, returnall=True)
    upper, lower, w_upper = math.inf, -math.inf, math.nan
    for gm, w in zip(np.atleast_1d(gms), np.atleast_1d(wpcs)):
        if not (np.isfinite(gm) and gm > 0 and w > LOWEST_CROSSOVER):
            continue
        db = 20 * math.log10(gm)
        if db >= 0 and db < upper:
            upper, w_upper = db, float(w)
        elif db < 0:
            lower = max(lower, db)
    pm, w_c, delay = math.inf, math.nan, math.inf
    for p, w in zip(np.atleast_1d(pms), np.atleast_1d(wgcs)):
        if not (np.isfinite(p) and np.isfinite(w) and w > 0):
            continue
        if abs(float(p)) < pm:
            pm, w_c = abs(float(p)), float(w)
        delay = min(delay, math.radians(float(p) % 360.0) / float(w))  # python-control: p = 180 + phase
    return LoopMargin(channel, upper, lower, pm, w_upper, w_c, delay)


def restrict(controller: Linearization, outputs: list[str]) -> Linearization:
    """A controller's linearization kept to some of its outputs (the channels a law uses).

    Parameters
    ----------
    controller : Linearization
        The controller.
    outputs : list of str
        The outputs kept, by name.
    """
    rows = [controller.outputs.index(n) for n in outputs]
    return replace(controller, C=controller.C[rows], D=controller.D[rows], outputs=tuple(outputs))


def sensitivities(L: control.StateSpace, omega: np.ndarray) -> np.ndarray:
    """The largest singular values of S, T and S - I/2 (the balanced disk's) at each frequency.

    Parameters
    ----------
    L : control.StateSpace
        The loop transfer at the plant input (continuous, or discrete with its ``dt``).
    omega : numpy.ndarray
        Frequencies, rad/s.

    Returns
    -------
    numpy.ndarray
        Shape ``(3, len(omega))``: the rows of S, T and S - I/2.
    """
    resp = response(L, omega)
    eye = np.eye(L.ninputs)
    out = np.empty((3, len(omega)))
    for k in range(len(omega)):
        Lk = resp[:, :, k]
        S = np.linalg.inv(eye + Lk)
        out[:, k] = np.linalg.norm(S, 2), np.linalg.norm(Lk @ S, 2), np.linalg.norm(S - eye / 2, 2)
    return out


def _peaks(L: control.StateSpace, omega: np.ndarray) -> tuple[float, float, float]:
    """Peaks over ``omega`` of :func:`sensitivities`."""
    s_max, t_max, half = sensitivities(L, omega).max(axis=1)
    return float(s_max), float(t_max), float(half)


def sweep_margins(response: np.ndarray, omega: np.ndarray) -> tuple[float, float]:
    """Gain margin (dB) and phase margin (deg) of a SISO loop from its frequency response alone: the
    crossings of -180 deg and of gain 1 found on the grid and refined by linear interpolation (in
    log frequency; a check of python-control's figures, written independently of it).

    Parameters
    ----------
    response : numpy.ndarray
        ``L(j omega)`` (or ``L(e^{j omega T})``) at ``omega``, complex.
    omega : numpy.ndarray
        Increasing frequencies, rad/s.

    Returns
    -------
    tuple of float
        The smallest gain margin over the phase crossovers (inf if none) and the smallest phase
        margin over the gain crossovers (inf if none; as
        :class:`LoopMargin`'s ``phase_margin_deg``, >= 0).
    """
    mag = np.abs(response)
    phase = np.unwrap(np.angle(response))
    gm, pm = math.inf, math.inf
    for k in range(len(omega) - 1):
        # gain crossover: |L| through 1
        if (mag[k] - 1) * (mag[k + 1] - 1) < 0:
            f = (0 - math.log(mag[k])) / (math.log(mag[k + 1]) - math.log(mag[k]))
            ph = phase[k] + f * (phase[k + 1] - phase[k])
            margin = math.degrees(ph) % 360.0 - 180.0  # the phase's offset from -180 deg, in [-180, 180)
            pm = min(pm, abs(margin))  # the rotation either way that reaches -1
        # phase crossover: the phase through -180 deg (modulo 360)
        a, b = phase[k] + math.pi, phase[k + 1] + math.pi  # 0 (mod 2 pi) at -180 deg
        turns_a, turns_b = math.floor(a / (2 * math.pi)), math.floor(b / (2 * math.pi))
        if turns_a != turns_b:
            edge = 2 * math.pi * max(turns_a, turns_b)  # the multiple of 2 pi between a and b
            f = (edge - a) / (b - a)
            g = math.exp(math.log(mag[k]) + f * (math.log(mag[k + 1]) - math.log(mag[k])))
            gm = min(gm, -20 * math.log10(g))
    return gm, pm
