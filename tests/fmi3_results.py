"""fmpy results of FMI 3.0 FMUs seen as FMI 2.0 ones, for the tests that compare the two."""
from __future__ import annotations

import numpy as np


def flat(result: np.ndarray) -> dict[str, np.ndarray]:
    """fmpy's result columns by FMI 2.0 name (an array column as its elements ``name[i]``).

    Parameters
    ----------
    result : numpy.ndarray
        A structured array from :func:`fmpy.simulate_fmu`.

    Returns
    -------
    dict of str to numpy.ndarray
        One column per FMI 2.0 variable.
    """
    out = {}
    for name in result.dtype.names:
        column = np.asarray(result[name])
        if column.ndim == 1:
            out[name] = column
        else:
            out.update({f"{name}[{j + 1}]": column[:, j] for j in range(column.shape[1])})
    return out
