"""Matplotlib figures of co-simulation results (written as PNG, no display needed)."""
from __future__ import annotations

import textwrap
from pathlib import Path
from typing import Mapping, Sequence

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def time_series(res: np.ndarray, panels: Sequence[Sequence[str]], path: Path, title: str = "",
                units: Mapping[str, str] | None = None) -> None:
    """One panel per group of recorded columns, against time; y label = the columns' unit."""
    fig, axes = plt.subplots(len(panels), 1, sharex=True, figsize=(8, 2.2 * len(panels) + 0.6), squeeze=False)
    for ax, cols in zip(axes[:, 0], panels):
        for c in cols:
            ax.plot(res["time"], res[c], label=c)
        ax.grid(True, alpha=0.3)
        ax.legend(loc="upper right", fontsize=7, ncol=min(3, len(cols)))
        found = sorted({(units or {}).get(c) or "1" for c in cols})
        ax.set_ylabel(", ".join(found))
    axes[-1, 0].set_xlabel("time (s)")
    fig.suptitle(textwrap.fill(title, 100), fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def l2_ratio(t: np.ndarray, ratio: np.ndarray, bound: float | None, path: Path, title: str = "") -> None:
    """Truncated L2 ratio over T, with the certified bound as a dashed line (seed 000, Fig. 9)."""
    fig, ax = plt.subplots(figsize=(7, 3.2))
    ax.plot(t, ratio, label="||z||_2,T / ||w||_2,T")
    if bound is not None:
        ax.axhline(bound, ls="--", color="k", label=f"bound {bound:g}")
    ax.set_xlabel("T (s)")
    ax.grid(True, alpha=0.3)
    ax.legend()
    ax.set_title(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
