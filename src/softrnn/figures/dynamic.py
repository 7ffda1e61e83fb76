"""Figures of a learned whole-manipulator model (``softrnn.learned.whole``): the largest error over the
rod's nodes against time, the model beside its baselines, as ``softrnn reproduce`` draws them."""

from __future__ import annotations

import numpy as np

from .saving import subplots

_STYLE = {"model": ("k", "-", 1.4), "persistence": ("C0", ":", 1.0), "constant_velocity": ("C1", "--", 1.0),
          "linear": ("C2", "-.", 1.0)}
_LABELS = {"model": "learned model", "persistence": "persistence", "constant_velocity": "constant velocity",
           "linear": "linear"}


def _curve(ax, t: np.ndarray, err: np.ndarray, name: str) -> None:
    """One predictor's error (% of L) against time; a diverged run (inf) ends where it diverged."""
    err = np.asarray(err, dtype=float)
    ok = np.isfinite(err)
    color, ls, lw = _STYLE.get(name, ("C3", "-", 1.0))
    label = _LABELS.get(name, name)
    if ok.all():
        label += f" (max {err.max():.3g} %)"
    else:
        stop = int(np.argmin(ok))
        label += f" (diverged at {t[stop]:.3g} s)" if stop < len(t) else " (diverged)"
    shown = np.where(ok & (err > 0), err, np.nan)
    ax.plot(t, shown, color=color, ls=ls, lw=lw, label=label)


def error_over_time(panels: list, title: str):
    """The largest position error over all nodes [% of rod length] against time, one panel per run.

    Parameters
    ----------
    panels : list of tuple
        (title, times, errors) or (title, times, errors, goal): the panel's title (str), times
        (K,) [s], {predictor: errors (K,) [% of L]} and optionally a goal [% of L] drawn as a
        horizontal line; predictors ``model``, ``persistence``, ``constant_velocity``
        and ``linear`` get fixed styles; ``inf`` marks a run that diverged (its curve stops there).
    title : str
        The figure's title.

    Returns
    -------
    matplotlib.figure.Figure
        The figure, one panel per run.
    """
    fig, axes = subplots(len(panels), 1, figsize=(7.5, 3.0 * len(panels) + 0.5), squeeze=False)
    for ax, (name, t, series, *goal) in zip(axes[:, 0], panels):
        for key, err in series.items():
            _curve(ax, np.asarray(t, dtype=float), err, key)
        if goal and goal[0] is not None:
            ax.axhline(goal[0], color="0.4", lw=0.8, ls=(0, (1, 3)), label=f"goal {goal[0]:g} %")
        ax.set_yscale("log")
        ax.set_ylabel("max error over nodes [% of L]")
        ax.set_title(name, fontsize=9)
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=7, loc="best")
    axes[-1, 0].set_xlabel("t [s]")
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return fig
