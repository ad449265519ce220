"""Tasks and samplers of the campaign tests, in a module of their own: the Dask workers, and the
drivers the tests start as processes, import them by name, and this module imports numpy only."""
from __future__ import annotations

import time

import numpy as np


def normal_matrices(rng: np.random.Generator, count: int) -> np.ndarray:
    """Entries (a, b, c, d) of random 2x2 matrices [[a, b], [c, d]]."""
    return rng.standard_normal((count, 4))


def abscissa(samples: np.ndarray) -> dict[str, np.ndarray]:
    """Spectral abscissa (largest real part of the eigenvalues) and trace of each matrix."""
    a, b, c, d = samples.T
    disc = ((a - d) / 2) ** 2 + b * c
    return {"abscissa": (a + d) / 2 + np.sqrt(np.maximum(disc, 0.0)), "trace": a + d}


def slow_abscissa(samples: np.ndarray) -> dict[str, np.ndarray]:
    time.sleep(0.4)
    return abscissa(samples)


def decay_time(samples: np.ndarray) -> dict[str, np.ndarray]:
    """1 / |abscissa| of a stable matrix, inf for an unstable one (a result, not a failure)."""
    alpha = abscissa(samples)["abscissa"]
    with np.errstate(divide="ignore"):
        return {"decay_time": np.where(alpha < 0, -1.0 / alpha, np.inf)}


def short_column(samples: np.ndarray) -> dict[str, np.ndarray]:
    return {"abscissa": np.zeros(len(samples) - 1)}


def matrix_column(samples: np.ndarray) -> dict[str, np.ndarray]:
    return {"grid": np.zeros((len(samples), 2))}
