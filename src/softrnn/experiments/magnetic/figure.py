"""Fig. 12 of the paper: measured and predicted magnet orientations over the test span."""

from __future__ import annotations

import numpy as np

from ...figures.saving import subplots
from .config import AXES, MAGNETS


def plot_fig12(time_s, measured, predictions: dict, static, title: str = "", calibrated=None):
    """Like the paper's Fig. 12: measured and predicted orientation over the test span, both magnets
    (columns), about y (the bending axis) and about x (rows), plus the absolute error about y;
    LSTM one step ahead (and free running, dotted), static Cosserat model. Returns the Figure.

    Parameters
    ----------
    time_s : (T,) [s]
        Sample times.
    measured : (T, 2, 3) [rad]
        The measured orientations (rotation vectors) of the magnets, 0 proximal, 1 distal.
    predictions : dict
        Per magnet name: ``index`` (K,) the test span's sample indices, ``rnn`` (K, 3) [rad] the
        one-step predictions, ``free`` (K, 3) [rad] the free-running ones or None.
    static, calibrated : (T, 2, 3) [rad] or None
        The static model's predictions (NaN where it failed) and the calibrated dynamic Cosserat
        model's from the currents alone; None: not drawn.
    title : str
        Figure title (empty: a default).
    """
    fig, axes = subplots(3, 2, figsize=(11, 7.5), sharex=True)
    for col, name in enumerate(("distal", "proximal")):
        m = MAGNETS.index(name)
        p = predictions[name]
        idx = p["index"]
        t = time_s[idx]
        for row, c in enumerate((1, 0)):
            ax = axes[row, col]
            ax.plot(t, np.degrees(measured[idx, m, c]), color="k", lw=1.2, label="measured (camera)")
            ax.plot(t, np.degrees(p["rnn"][:, c]), color="tab:blue", lw=1.0, label="LSTM, one step ahead")
            shown = [np.degrees(measured[idx, m, c]), np.degrees(p["rnn"][:, c])]
            if static is not None:
                ax.plot(t, np.degrees(static[idx, m, c]), color="tab:red", lw=1.0, label="static Cosserat model")
                shown.append(np.degrees(static[idx, m, c]))
            if calibrated is not None:
                ax.plot(t, np.degrees(calibrated[idx, m, c]), color="tab:green", lw=1.0,
                        label="calibrated dynamic Cosserat")
                shown.append(np.degrees(calibrated[idx, m, c]))
            lo, hi = np.nanmin(np.concatenate(shown)), np.nanmax(np.concatenate(shown))
            pad = 0.15 * max(hi - lo, 1.0)
            if p["free"] is not None:                     # may drift far: keep the axis on the others
                ax.plot(t, np.degrees(p["free"][:, c]), color="tab:blue", lw=0.8, ls=":",
                        label="LSTM, free running (may leave the axis)")
            ax.set_ylim(lo - pad, hi + pad)
            ax.set_ylabel(f"{name}: about {AXES[c]} [deg]")
            ax.grid(alpha=0.3)
        ax = axes[2, col]
        ax.plot(t, np.degrees(np.abs(p["rnn"][:, 1] - measured[idx, m, 1])), color="tab:blue", lw=0.8, label="LSTM")
        if static is not None:
            ax.plot(t, np.degrees(np.abs(static[idx, m, 1] - measured[idx, m, 1])), color="tab:red", lw=0.8,
                    label="static Cosserat")
        if calibrated is not None:
            ax.plot(t, np.degrees(np.abs(calibrated[idx, m, 1] - measured[idx, m, 1])), color="tab:green", lw=0.8,
                    label="calibrated dynamic")
        ax.set_ylabel(f"{name}: |error| about y [deg]")
        ax.set_xlabel("t [s]")
        ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=7, loc="best")
    axes[2, 0].legend(fontsize=7, loc="best")
    fig.suptitle(title or "Magnet orientations over the test span (the paper's Fig. 12)", fontsize=10)
    fig.tight_layout()
    return fig
