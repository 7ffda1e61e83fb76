"""The figure of a calibration (``softrnn calibrate``): one node's recorded trajectory beside the
start's and the fitted scenario's, and the error of both over time."""

from __future__ import annotations

import numpy as np

from .saving import subplots


def moving_node(measured: np.ndarray) -> int:
    """Column of the node that moves most in ``measured`` (S, N, 3) [m] (largest range along any
    axis): a cantilever's tip, a clamped arch's middle."""
    return int(np.argmax(np.ptp(np.asarray(measured), axis=0).max(axis=1)))


def calibration_fit(time: np.ndarray, measured: np.ndarray, start: np.ndarray, fitted: np.ndarray, column: int,
                    node: int, title: str):
    """Positions (S, N, 3) [m] over ``time`` (S,) [s]: the data, the start's and the fit's; panels x,
    y, z [mm] of node ``node`` (column ``column``), and a fourth with the rms over the N nodes of the
    distance to the data [mm] per sample for both (log scale where the fit is far better)."""
    fig, axes = subplots(4, 1, figsize=(7.5, 8.0), sharex=True)
    series = (("data", measured, "k", "-", 1.3), ("start", start, "C1", "--", 1.1), ("fitted", fitted, "C0", ":", 1.6))
    for c in range(3):
        ax = axes[c]
        for label, p, color, ls, lw in series:
            ax.plot(time, p[:, column, c] * 1e3, color=color, ls=ls, lw=lw, label=label)
        shown = np.concatenate([p[:, column, c] for _, p, *_ in series]) * 1e3
        if np.ptp(shown) < 1.0:     # an axis that (nearly) does not move: +-1 mm, no offset
            mid = 0.5 * (shown.min() + shown.max())
            ax.set_ylim(mid - 1.0, mid + 1.0)
        ax.ticklabel_format(axis="y", useOffset=False)
        ax.set_ylabel(f"{'xyz'[c]} [mm]")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8, loc="upper right", ncol=3)
    axes[0].set_title(title)
    ax = axes[3]
    errors = {label: np.sqrt(np.mean(np.sum((p - measured) ** 2, axis=-1), axis=1)) * 1e3
              for label, p, *_ in series[1:]}                                     # (S,) mm
    log = 0 < float(np.max(errors["fitted"])) < 0.01 * float(np.max(errors["start"]))
    for label, _, color, ls, lw in series[1:]:
        e = errors[label]
        ax.plot(time, np.where(e > 0, e, np.nan) if log else e, color=color, ls=ls, lw=lw,
                label=f"{label} (rms {np.sqrt(np.mean(e ** 2)):.3g} mm)")
    if log:
        ax.set_yscale("log")
    ax.set_ylabel("rms error [mm]")
    ax.set_xlabel("t [s]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="upper left")
    fig.tight_layout()
    return fig
