"""The real-robot benchmark's figure: the recorded tip over a validation session beside the
free runs of the models and baselines, and their Euclidean error row by row."""

from __future__ import annotations

import numpy as np

from .saving import subplots


def benchmark_figure(recorded: np.ndarray, predictions: dict, rows: np.ndarray | None = None, title: str = ""):
    """A Figure: x, y, z [mm] of ``recorded`` (T, 3) [m] and of each prediction ``{name: (T, 3) [m]}``
    over the row number (``rows``, default 0..T-1), and the Euclidean error [mm] of each."""
    rows = np.arange(len(recorded)) if rows is None else rows
    fig, axes = subplots(4, 1, figsize=(9.0, 9.5), sharex=True)
    for a, label in enumerate("xyz"):
        ax = axes[a]
        ax.plot(rows, recorded[:, a] * 1e3, color="black", lw=2.0, label="recorded")
        for name, pred in predictions.items():
            ax.plot(rows, pred[:, a] * 1e3, lw=1.0, label=name)
        ax.set_ylabel(f"tip {label} [mm]")
    for name, pred in predictions.items():
        e = np.linalg.norm(pred - recorded, axis=1) * 1e3
        axes[3].plot(rows, e, lw=1.0, label=f"{name} (RMSE {np.sqrt(np.mean(e ** 2)):.1f} mm)")
    axes[3].set_ylabel("tip error [mm]")
    axes[3].set_xlabel("row of the validation session")
    axes[0].legend(loc="upper right", fontsize=7, ncol=3)
    axes[3].legend(loc="upper right", fontsize=7)
    if title:
        axes[0].set_title(title)
    fig.tight_layout()
    return fig
