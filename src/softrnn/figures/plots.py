"""Figures of rod runs, predictions and errors: functions take data and return a matplotlib
``Figure`` (made by ``saving``, without pyplot); callers save it with ``saving.save_figure``."""

import numpy as np
from matplotlib import colormaps

from .saving import new_figure, subplots


def node_trajectory(time: np.ndarray, positions: np.ndarray, title: str):
    """Positions (T, 3) [m] of one node against time (T,) [s], one panel per axis, in mm."""
    fig, axes = subplots(3, 1, figsize=(7, 6), sharex=True)
    for c, ax in enumerate(axes):
        ax.plot(time, positions[:, c] * 1e3, lw=0.8)
        ax.set_ylabel(f"{'xyz'[c]} [mm]")
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("t [s]")
    axes[0].set_title(title)
    fig.tight_layout()
    return fig


def rod_snapshots(times: np.ndarray, shapes: np.ndarray, title: str, node: int | None = None,
                  forces: np.ndarray | None = None):
    """Rod centrelines shapes (k, n, 3) [m] at times (k,) [s] in 3-D, the node of interest marked;
    optional applied forces (k, n, 3) [N] drawn as arrows (scaled to 10% of the rod's extent)."""
    fig = new_figure(figsize=(7, 6))
    ax = fig.add_subplot(projection="3d")
    colors = colormaps["viridis"](np.linspace(0, 1, len(times)))
    extent = float(np.ptp(shapes.reshape(-1, 3), axis=0).max()) or 1.0
    fmax = float(np.abs(forces).max()) if forces is not None else 0.0
    for k, (t, X) in enumerate(zip(times, shapes)):
        ax.plot(X[:, 0], X[:, 1], X[:, 2], color=colors[k], lw=1.5, label=f"t = {t:.2f} s")
        if node is not None:
            ax.scatter(*X[node], color=colors[k], s=12)
        if forces is not None and fmax > 0:
            F = forces[k]
            on = np.linalg.norm(F, axis=1) > 1e-12
            s = 0.1 * extent / fmax
            ax.quiver(X[on, 0], X[on, 1], X[on, 2], s * F[on, 0], s * F[on, 1], s * F[on, 2], color="red")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")
    lo, hi = shapes.reshape(-1, 3).min(0), shapes.reshape(-1, 3).max(0)
    mid, half = (lo + hi) / 2, (hi - lo).max() / 2 + 1e-3
    ax.set_xlim(mid[0] - half, mid[0] + half)
    ax.set_ylim(mid[1] - half, mid[1] + half)
    ax.set_zlim(mid[2] - half, mid[2] + half)
    if hi[2] - lo[2] < 1e-3 * (hi - lo).max():
        ax.view_init(elev=90, azim=-90)  # planar motion in the xy-plane: look from +z
    ax.set_title(title)
    ax.legend(fontsize=7, loc="upper left")
    fig.tight_layout()
    return fig


def energy(time: np.ndarray, energy: np.ndarray, title: str):
    """Kinetic, elastic, gravitational and total energy (T, 3) [J] against time."""
    fig, ax = subplots(figsize=(7, 3.5))
    for c, name in enumerate(("kinetic", "elastic", "gravitational")):
        ax.plot(time, energy[:, c], lw=0.8, label=name)
    ax.plot(time, energy.sum(1), "k", lw=1.0, label="total")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("energy [J]")
    ax.set_title(title)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    return fig


def node_trajectory_with_forces(time: np.ndarray, positions: np.ndarray, forces: np.ndarray | None,
                                title: str):
    """Positions (T, 3) [m] of one node against time (T,) [s], one panel per axis in mm, and, when
    ``forces`` (T, 3) [N] is given, a fourth panel with the force components and magnitude on it."""
    return node_panels(time, positions, forces=forces, title=title)


def node_panels(time: np.ndarray, positions: np.ndarray, *, title: str, forces: np.ndarray | None = None,
                inputs: np.ndarray | None = None, units: dict | None = None, reference: np.ndarray | None = None,
                start: float | None = None):
    """One node against time (T,) [s]: its positions (T, 3) [m] one panel per axis in mm; with
    ``reference`` (T, 3) [m] that drawn dashed under them (the positions are then a prediction,
    solid) and a panel of the error |positions - reference| [mm], ``start`` [s] marking where the
    prediction starts; with ``forces`` (T, 3) [N] a panel of the force components and magnitude;
    with ``inputs`` (T, m) a panel per unit of ``units`` ({channel: unit}, m entries, in column
    order) with those channels (tendon tensions, displacements, currents)."""
    groups = _unit_groups(units or {}) if inputs is not None and np.size(inputs) else []
    rows = 3 + (reference is not None) + (forces is not None) + len(groups)
    fig, axes = subplots(rows, 1, figsize=(7, 1.9 * rows + 0.6), sharex=True)
    for c in range(3):
        ax = axes[c]
        y = positions[:, c] * 1e3
        shown = y if reference is None else np.concatenate([y, reference[:, c] * 1e3])
        if reference is not None:
            ax.plot(time, reference[:, c] * 1e3, lw=1.4, color="0.45", ls="--", label="reference (data)")
        ax.plot(time, y, lw=0.9 if reference is None else 1.2, color=f"C{c}" if reference is None else "C0",
                label=None if reference is None else "prediction")
        ax.ticklabel_format(axis="y", useOffset=False)
        if shown.size and np.ptp(shown) < 1.0:  # an axis that (nearly) does not move: show +-1 mm, no offset
            mid = 0.5 * (shown.min() + shown.max())
            ax.set_ylim(mid - 1.0, mid + 1.0)
        ax.set_ylabel(f"{'xyz'[c]} [mm]")
        ax.grid(alpha=0.3)
    k = 3
    if reference is not None:
        axes[0].legend(fontsize=7, ncol=2, loc="upper right")
        _error_panel(axes[k], time, positions, reference, start)
        k += 1
    if forces is not None:
        ax = axes[k]
        for c in range(3):
            ax.plot(time, forces[:, c], lw=0.9, color=f"C{c}", label=f"F{'xyz'[c]}")
        ax.plot(time, np.sqrt((forces ** 2).sum(-1)), lw=0.8, color="k", ls="--", label="|F|")
        ax.set_ylabel("force [N]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, ncol=4, loc="upper right")
        k += 1
    for ax, (unit, columns) in zip(axes[k:], groups):
        for n, (j, name) in enumerate(columns):
            ax.plot(time, inputs[:, j], lw=0.9, color=f"C{n % 10}", label=name)
        ax.set_ylabel(f"input [{unit}]" if unit else "input")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, ncol=min(4, len(columns)), loc="upper right")
    axes[-1].set_xlabel("t [s]")
    axes[0].set_title(title)
    fig.tight_layout()
    return fig


def _unit_groups(units: dict) -> list[tuple[str, list[tuple[int, str]]]]:
    """The actuation channels grouped by unit, in column order: [(unit, [(column, name), ...]), ...]."""
    groups: dict[str, list] = {}
    for j, (name, unit) in enumerate(units.items()):
        groups.setdefault(str(unit), []).append((j, str(name)))
    return list(groups.items())


def _error_panel(ax, time: np.ndarray, positions: np.ndarray, reference: np.ndarray, start: float | None) -> None:
    """The error |positions - reference| [mm] (T, 3 each, [m]) against time, its largest and last value
    in the legend, a line where the prediction starts."""
    d = (np.asarray(positions, dtype=float) - np.asarray(reference, dtype=float)) * 1e3
    err = np.sqrt((d * d).sum(-1))
    ax.plot(time, err, lw=0.9, color="C3",
            label=f"|error|: largest {err.max():.3g} mm, last {err[-1]:.3g} mm" if err.size else "|error|")
    if start is not None and time.size and time[0] <= start <= time[-1]:
        ax.axvline(start, color="0.3", lw=0.8, ls=":", label=f"prediction from t = {start:g} s")
    ax.set_ylabel("|error| [mm]")
    ax.set_ylim(0.0, 1.35 * float(err.max()) if err.size and err.max() > 0 else 1.0)  # room for the legend
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="upper left")


def prediction_vs_reference(time: np.ndarray, reference: np.ndarray, predictions: dict, title: str):
    """A node's reference positions (T, 3) [m] and one or more predictions {label: (T, 3) [m]} of
    the same samples against time (T,) [s], one panel per axis in mm (like the paper's Fig. 3D, 5B,
    8B)."""
    fig, axes = subplots(3, 1, figsize=(7.5, 6.5), sharex=True)
    styles = [("C1", "--"), ("C3", ":"), ("C2", "-."), ("C4", "--")]
    for c, ax in enumerate(axes):
        ax.plot(time, np.asarray(reference)[:, c] * 1e3, color="k", lw=1.2, label="reference")
        for k, (label, pred) in enumerate(predictions.items()):
            color, ls = styles[k % len(styles)]
            ax.plot(time, np.asarray(pred)[:, c] * 1e3, color=color, ls=ls, lw=1.1, label=label)
        shown = np.concatenate([np.asarray(reference)[:, c]] + [np.asarray(p)[:, c] for p in predictions.values()])
        if shown.size and np.ptp(shown) * 1e3 < 1.0:  # an axis that (nearly) does not move: +-1 mm, no offset
            mid = 0.5 * (shown.min() + shown.max()) * 1e3
            ax.set_ylim(mid - 1.0, mid + 1.0)
        ax.ticklabel_format(axis="y", useOffset=False)
        ax.set_ylabel(f"{'xyz'[c]} [mm]")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8, loc="upper right", ncol=1 + len(predictions))
    axes[-1].set_xlabel("t [s]")
    axes[0].set_title(title)
    fig.tight_layout()
    return fig


def rmse_over_time(time: np.ndarray, series: dict, title: str, log: bool = False):
    """RMSE(t) of paper Eq. 2, {label: (T,) [mm]} against time (T,) [s] (like Fig. 3E, 5C);
    ``log``: logarithmic error axis (zeros are left out)."""
    fig, ax = subplots(figsize=(7.5, 3.2))
    for k, (label, values) in enumerate(series.items()):
        v = np.asarray(values, dtype=float)
        if log:
            v = np.where(v > 0, v, np.nan)
        ax.plot(time, v, lw=0.9, color=f"C{k}", label=f"{label} (max {np.nanmax(np.r_[v, 0.0]):.3g} mm)")
    if log:
        ax.set_yscale("log")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("RMSE(t) [mm]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(title)
    fig.tight_layout()
    return fig


def predicted_shapes(times: np.ndarray, reference: np.ndarray, predicted: np.ndarray, title: str,
                     modelled: np.ndarray | None = None):
    """Rod centrelines at a few times (k,) [s]: reference (k, N, 3) [m] solid and predicted
    (k, N, 3) [m] dashed, in mm, projected on the plane of the shape's two largest extents and,
    when the axis along which the reference moves most is not one of them, also on the plane of
    the largest extent and that axis; ``modelled`` (N,) bool marks the predicted nodes."""
    ref, pred = np.asarray(reference, dtype=float), np.asarray(predicted, dtype=float)
    extent = np.ptp(ref.reshape(-1, 3), axis=0)
    a, b = sorted(int(i) for i in np.argsort(extent)[-2:])
    moving = int(np.argmax(np.ptp(ref, axis=0).max(axis=0)))         # largest motion of any node
    planes = [(a, b)] + ([(int(np.argmax(extent)), moving)] if moving not in (a, b) else [])
    fig, axes = subplots(len(planes), 1, figsize=(6.5, 4.2 * len(planes) + 0.6), squeeze=False)
    colors = colormaps["viridis"](np.linspace(0, 0.9, len(times)))
    m = None if modelled is None else np.asarray(modelled, dtype=bool)
    for ax, (u, v) in zip(axes[:, 0], planes):
        for k, t in enumerate(times):
            ax.plot(ref[k, :, u] * 1e3, ref[k, :, v] * 1e3, color=colors[k], lw=1.4, label=f"t = {t:.3g} s")
            ax.plot(pred[k, :, u] * 1e3, pred[k, :, v] * 1e3, color=colors[k], lw=1.2, ls="--")
            if m is not None:
                ax.plot(pred[k, m, u] * 1e3, pred[k, m, v] * 1e3, ls="none", marker=".", ms=3, color=colors[k])
        ax.plot([], [], color="0.3", lw=1.4, label="reference")
        ax.plot([], [], color="0.3", lw=1.2, ls="--", label="predicted")
        ax.set_xlabel(f"{'xyz'[u]} [mm]")
        ax.set_ylabel(f"{'xyz'[v]} [mm]")
        if (u, v) == planes[0]:
            ax.set_aspect("equal", adjustable="datalim")
        ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=7, loc="best")
    axes[0, 0].set_title(title)
    fig.tight_layout()
    return fig
