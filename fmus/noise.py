"""Counter-based random numbers for sampled models: a draw is a pure function of (seed, counter, stream).

A sensor's noise at sample instant ``k`` is ``GaussianNoise(seed, k, stream)``: no generator state
advances from call to call, so a run is reproducible bit for bit whatever the communication step,
a repeated or rolled-back step draws the same numbers, and an FMU state needs nothing beyond the
held values. ``stream`` tells apart the draws of one instant (one per axis and noise source).

The generator hashes the three integers to 64 bits with the SplitMix64 finalizer (Steele, Lea
and Flood, "Fast splittable pseudorandom number generators", OOPSLA 2014), chained: the seed,
then the stream, then the counter times the golden-ratio increment, each mixed in turn. From the
hash, two further mixes give two uniform 53-bit fractions; the normal draw is Box-Muller's
``sqrt(-2 ln u1) cos(2 pi u2)``. The integer arithmetic is exact (modulo 2^64) in both languages
and the floating-point operations are the same IEEE operations and C library calls (``log``,
``sqrt``, ``cos``), so the native and pythonfmu FMUs draw the same bits.

The arguments are doubles holding integers (FMU parameters and sample counts): each is truncated
to a signed 64-bit integer, then read modulo 2^64.

:func:`uniform_noise` and :func:`gaussian_noise` are the Python forms (the generated Python embeds
their source, :data:`PYTHON_SOURCE`); :data:`C_SOURCE` is the C form; :class:`UniformNoise` and
:class:`GaussianNoise` are the sympy functions a model's expressions call.
"""
from __future__ import annotations

import inspect
import math

import sympy as sp

MASK = 0xFFFFFFFFFFFFFFFF
"""2^64 - 1: the unsigned 64-bit arithmetic of the C form."""
GOLDEN = 0x9E3779B97F4A7C15
"""SplitMix64's increment, 2^64 / golden ratio (odd)."""
MIX_1 = 0xBF58476D1CE4E5B9
MIX_2 = 0x94D049BB133111EB
"""SplitMix64's finalizer multipliers."""
LANE_1 = 0x5851F42D4C957F2D
LANE_2 = 0x14057B7EF767814F
"""Constants told apart the two uniform fractions drawn from one hash."""


def _mix(z: int) -> int:
    z = ((z ^ (z >> 30)) * MIX_1) & MASK
    z = ((z ^ (z >> 27)) * MIX_2) & MASK
    return z ^ (z >> 31)


def _fraction(z: int, lane: int, half: float) -> float:
    return ((_mix(z ^ lane) >> 11) + half) * 1.1102230246251565e-16


def _hash(seed: float, counter: float, stream: float) -> int:
    h = _mix((int(seed) + GOLDEN) & MASK)
    h = _mix(((h ^ (int(stream) & MASK)) + GOLDEN) & MASK)
    return _mix((h + (int(counter) & MASK) * GOLDEN) & MASK)


def uniform_noise(seed: float, counter: float, stream: float) -> float:
    """A uniform draw on (0, 1) of (seed, counter, stream).

    Parameters
    ----------
    seed, counter, stream : float
        Integers (as doubles): the generator's seed, the sample's count, the draw's stream.

    Returns
    -------
    float
        ``(m + 1/2) 2^-53`` for the 53-bit integer ``m`` of the hash: never 0 nor 1.
    """
    return _fraction(_hash(seed, counter, stream), LANE_1, 0.5)


def gaussian_noise(seed: float, counter: float, stream: float) -> float:
    """A standard normal draw of (seed, counter, stream) (Box-Muller).

    Parameters
    ----------
    seed, counter, stream : float
        Integers (as doubles): the generator's seed, the sample's count, the draw's stream.

    Returns
    -------
    float
        ``sqrt(-2 ln u1) cos(2 pi u2)`` with ``u1`` in (0, 1) and ``u2`` in [0, 1) from the hash.
    """
    h = _hash(seed, counter, stream)
    u1 = _fraction(h, LANE_1, 0.5)
    u2 = _fraction(h, LANE_2, 0.0)
    return math.sqrt(-2.0 * math.log(u1)) * math.cos(6.283185307179586 * u2)


class UniformNoise(sp.Function):
    """``UniformNoise(seed, counter, stream)``: :func:`uniform_noise` in a model's expressions."""

    nargs = 3


class GaussianNoise(sp.Function):
    """``GaussianNoise(seed, counter, stream)``: :func:`gaussian_noise` in a model's expressions."""

    nargs = 3


NOISE_FUNCTIONS = (UniformNoise, GaussianNoise)
"""The sympy functions of this module (what the code generators print)."""

PYTHON_SOURCE = "\n".join(
    [f"{name} = {value:#x}" for name, value in (("MASK", MASK), ("GOLDEN", GOLDEN), ("MIX_1", MIX_1),
                                                 ("MIX_2", MIX_2), ("LANE_1", LANE_1), ("LANE_2", LANE_2))]
    + ["", ""] + [inspect.getsource(f) for f in (_mix, _fraction, _hash, uniform_noise, gaussian_noise)])
"""The Python form, embedded in the generated Python of a model that draws noise (the module
imports ``math``)."""

C_SOURCE = f"""
/* satfmu.fmus.noise: counter-based draws, the twin of its Python form bit for bit */
static inline uint64_t noise_mix(uint64_t z) {{
    z = (z ^ (z >> 30)) * UINT64_C({MIX_1:#x});
    z = (z ^ (z >> 27)) * UINT64_C({MIX_2:#x});
    return z ^ (z >> 31);
}}
static inline uint64_t noise_hash(double seed, double counter, double stream) {{
    uint64_t h = noise_mix((uint64_t)(int64_t)seed + UINT64_C({GOLDEN:#x}));
    h = noise_mix((h ^ (uint64_t)(int64_t)stream) + UINT64_C({GOLDEN:#x}));
    return noise_mix(h + (uint64_t)(int64_t)counter * UINT64_C({GOLDEN:#x}));
}}
static inline double noise_fraction(uint64_t z, uint64_t lane, double half) {{
    return ((double)(noise_mix(z ^ lane) >> 11) + half) * 1.1102230246251565e-16;
}}
static inline double uniform_noise(double seed, double counter, double stream) {{
    return noise_fraction(noise_hash(seed, counter, stream), UINT64_C({LANE_1:#x}), 0.5);
}}
static inline double gaussian_noise(double seed, double counter, double stream) {{
    const uint64_t h = noise_hash(seed, counter, stream);
    const double u1 = noise_fraction(h, UINT64_C({LANE_1:#x}), 0.5);
    const double u2 = noise_fraction(h, UINT64_C({LANE_2:#x}), 0.0);
    return sqrt(-2.0 * log(u1)) * cos(6.283185307179586 * u2);
}}
"""
"""The C form, included in the generated C of a model that draws noise (``stdint.h`` and
``math.h`` are the wrapper's)."""
