"""Pictures of rod data: an animation of the rod over time and a node's trajectory per axis.

Every function takes a *dataset-like* object: anything with the attributes ``time`` (T,) [s],
``nodes`` (N,) node indices, ``positions`` (T, N, 3) [m] and optionally ``forces`` (T, N, 3) [N]
and ``attrs`` (dict). A ``softrnn.io.dataset.Dataset`` and a ``softrnn.rod.Trajectory`` both fit.

``animate(data, "rod.gif")`` draws the rod at evenly spaced times (by default at most 200 frames
covering the whole record) with the applied forces as arrows (scale chosen automatically and given
in the legend), the node of interest and its trail marked, fixed equal-aspect axes that cover the
whole motion, a flat view when the motion is planar and a 3-D view otherwise. ``.gif`` is written
with Pillow, ``.mp4`` with ffmpeg (when installed). ``plot_node(data, 30, "node30.png")`` draws one
node's x, y, z in mm against time, with the forces on that node in a fourth panel.

Output files are written under a temporary name in the same folder and renamed at the end, so an
error or Ctrl-C never leaves a partial file. Bad input raises ``SoftrnnInputError`` (one line).
"""

from __future__ import annotations

import math
import os
import shutil
import tempfile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402

from ..errors import SoftrnnInputError, bad  # noqa: E402

ANIMATION_SUFFIXES = (".gif", ".mp4")
FIGURE_SUFFIXES = (".png", ".pdf", ".svg")
VIEWS = ("auto", "xy", "xz", "yz", "3d")
DEFAULT_MAX_FRAMES = 200
DEFAULT_SIZE = (640, 560)  # pixels
_DPI = 100
_PLANES = {"xy": (0, 1), "xz": (0, 2), "yz": (1, 2)}
_FLAT = 0.01  # an axis whose range is below 1 % of the largest range counts as flat
_ARROW = 0.2  # the largest force is drawn about this fraction of the motion's extent
_ROD, _NODE, _TRAIL, _FORCE, _GHOST = "#1f5fa8", "#d62728", "#ff9f1c", "#2ca02c", "0.72"


# ---------------------------------------------------------------------------------------------- input


def _fields(data):
    """time (T,), nodes (N,), positions (T, N, 3), forces (T, N, 3) or None, attrs dict; validated."""
    try:
        time = np.asarray(data.time, dtype=float)
        positions = np.asarray(data.positions)  # float32 in files: kept, frames are converted one by one
    except AttributeError as err:
        raise SoftrnnInputError(f"data={type(data).__name__} is invalid: expected an object with time, nodes "
                                f"and positions (a softrnn dataset or trajectory)") from err
    nodes = np.asarray(getattr(data, "nodes", np.arange(positions.shape[1] if positions.ndim == 3 else 0)))
    forces = getattr(data, "forces", None)
    forces = None if forces is None else np.asarray(forces)
    attrs = dict(getattr(data, "attrs", None) or {})
    if time.ndim != 1 or time.size == 0:
        raise bad("time", f"shape {time.shape}", "a non-empty (T,) array of sample times")
    if positions.ndim != 3 or positions.shape[0] != time.size or positions.shape[2] != 3:
        raise bad("positions", f"shape {positions.shape}", f"shape (T, N, 3) with T = {time.size}")
    if nodes.shape != (positions.shape[1],):
        raise bad("nodes", f"shape {nodes.shape}", f"shape ({positions.shape[1]},) matching positions")
    if forces is not None and forces.shape != positions.shape:
        raise bad("forces", f"shape {forces.shape}", f"shape {positions.shape} matching positions")
    if not np.issubdtype(positions.dtype, np.number) or (forces is not None
                                                         and not np.issubdtype(forces.dtype, np.number)):
        raise SoftrnnInputError("positions and forces must be numeric arrays")
    if not all(np.isfinite(positions[k:k + 4096]).all() for k in range(0, positions.shape[0], 4096)):
        raise SoftrnnInputError("positions contain NaN or inf: the data is broken (a diverged run?); "
                                "re-create it")
    return time, nodes.astype(int), positions, forces, attrs


def time_span(time: np.ndarray, start=None, stop=None, names=("start", "stop")) -> tuple[int, int]:
    """Sample indices (first, last), inclusive, of the times in [start, stop] [s] (None: the ends)."""
    t0, t1 = float(time[0]), float(time[-1])
    eps = 1e-9 * max(abs(t0), abs(t1), 1.0)
    rng = f"a time in [{t0:g}, {t1:g}] s (the data's span)"
    for name, value in zip(names, (start, stop)):
        if value is not None and not (math.isfinite(value) and t0 - eps <= value <= t1 + eps):
            raise bad(name, value, rng)
    if start is not None and stop is not None and stop <= start:
        raise bad(names[1], stop, f"a time after {names[0]}={start!r}")
    i0 = 0 if start is None else int(np.searchsorted(time, start - eps, side="left"))
    i1 = len(time) - 1 if stop is None else int(np.searchsorted(time, stop + eps, side="right")) - 1
    if i1 < i0:
        raise SoftrnnInputError(f"start={start!r}, stop={stop!r} select no sample: the samples lie "
                                f"{(t1 - t0) / max(len(time) - 1, 1):g} s apart; widen the span")
    return i0, i1


def frame_indices(n_samples: int, *, frames: int | None = None, duration: float | None = None,
                  fps: float = 20, max_frames: int = DEFAULT_MAX_FRAMES, first: int = 0) -> np.ndarray:
    """Sample indices of the frames: evenly spaced over ``n_samples`` samples from ``first``, the first
    and the last included. ``frames`` or ``duration`` [s of playback] x ``fps`` sets the count,
    otherwise ``min(n_samples, max_frames)``; never more frames than samples."""
    if frames is not None and duration is not None:
        raise SoftrnnInputError(f"frames={frames!r} and duration={duration!r} both given: give one of them")
    if frames is not None:
        if int(frames) != frames or frames < 1:
            raise bad("frames", frames, "an integer >= 1")
        count = int(frames)
    elif duration is not None:
        if not (duration > 0 and math.isfinite(duration)):
            raise bad("duration", duration, "a playback length > 0 s")
        count = max(1, int(round(duration * fps)))
    else:
        count = max_frames
    count = min(count, n_samples)
    if count == 1:
        return np.array([first])
    return first + np.unique(np.round(np.linspace(0, n_samples - 1, count)).astype(int))


def _resolve(node, nodes: np.ndarray, attrs: dict) -> int:
    """A node index; negative ones count from the rod's end (``attrs['n_nodes_total']`` nodes, else the
    highest stored node + 1)."""
    if isinstance(node, bool) or not isinstance(node, (int, np.integer)):
        raise bad("node", node, "an integer node index")
    node = int(node)
    if node < 0:
        total = _first_int(attrs.get("n_nodes_total"))
        total = total if total is not None else (int(nodes.max()) + 1 if nodes.size else 0)
        if node + total >= 0:
            return node + total
    return node


def _column(nodes: np.ndarray, node: int, what: str = "node") -> int:
    hits = np.flatnonzero(nodes == node)
    if hits.size == 0:
        raise bad(what, node, f"a node present in the data: {describe_nodes(nodes)}")
    return int(hits[0])


def describe_nodes(nodes: np.ndarray) -> str:
    nodes = np.asarray(nodes, dtype=int)
    if nodes.size and np.array_equal(nodes, np.arange(nodes[0], nodes[0] + nodes.size)):
        return f"{nodes[0]}..{nodes[-1]}" if nodes.size > 1 else f"{nodes[0]} only"
    if nodes.size <= 12:
        return ", ".join(str(int(a)) for a in nodes)
    return ", ".join(str(int(a)) for a in nodes[:10]) + f", ... ({nodes.size} nodes, {nodes.min()}..{nodes.max()})"


def check_suffix(path, choices=ANIMATION_SUFFIXES, argument: str = "output") -> str:
    """The suffix of ``path`` in lower case, or SoftrnnInputError naming the suffix and the choices.
    ``.mp4`` needs ffmpeg on the PATH."""
    suffix = Path(path).suffix.lower()
    if suffix not in choices:
        raise bad(argument, str(path), f"the suffix {suffix or '(none)'!r} is not supported; use one of "
                  + ", ".join(choices))
    if suffix == ".mp4" and shutil.which("ffmpeg") is None:
        raise bad(argument, str(path), "writing .mp4 needs ffmpeg, which is not installed (not on the PATH); "
                  "install ffmpeg or write a .gif")
    return suffix


def node_of_interest(data) -> int | None:
    """The data's node of interest, if it names one: ``attrs['node_of_interest']``, else the first of
    ``nodes_of_interest`` in the scenario text (``attrs['scenario_text']``, TOML), else that of the
    paper case ``attrs['case']``. Negative indices count from the rod's end."""
    attrs = dict(getattr(data, "attrs", None) or {})
    node = _first_int(attrs.get("node_of_interest"))
    if node is None:
        run = _scenario(attrs).get("run", {})
        node = _first_int(run.get("nodes_of_interest") if isinstance(run, dict) else None)
    if node is None:
        name = _text(attrs.get("case"))
        if name:
            from ..scenarios.cases import CASE_NAMES, build_case
            if name in CASE_NAMES:
                node = build_case(name).node_of_interest
    if node is not None and node < 0:
        total = _first_int(attrs.get("n_nodes_total"))
        if total is None:
            rod = attrs.get("rod")
            total = _first_int(rod.get("n_nodes")) if isinstance(rod, dict) else None
        if total is None:
            nodes = np.asarray(getattr(data, "nodes", []))
            total = int(nodes.max()) + 1 if nodes.size else None
        node = None if total is None else node + total
    return node


def _first_int(value) -> int | None:
    try:
        arr = np.asarray(value).ravel()
        if arr.size and np.issubdtype(arr.dtype, np.integer):
            return int(arr[0])
    except (TypeError, ValueError):
        pass
    return None


def _text(value) -> str:
    if isinstance(value, bytes):
        value = value.decode("utf-8", "replace")
    return value if isinstance(value, str) else ""


def _scenario(attrs: dict) -> dict:
    """The scenario TOML of ``attrs['scenario_text']`` as a dict ({} if absent or unreadable)."""
    text = _text(attrs.get("scenario_text"))
    if not text.strip():
        return {}
    import tomllib
    try:
        return tomllib.loads(text)
    except (tomllib.TOMLDecodeError, ValueError):
        return {}


def _title(attrs: dict, fallback: str = "rod") -> str:
    """A short name for the data: ``case``, ``scenario_name`` or ``name`` in attrs, or the scenario's."""
    for key in ("case", "scenario_name", "name"):
        if _text(attrs.get(key)):
            return _text(attrs.get(key))
    name = _scenario(attrs).get("name")
    return name if isinstance(name, str) and name else fallback


def load(path, *, group: str | None = None, start: float | None = None, stop: float | None = None,
         node: int | None = None):
    """Read a softrnn HDF5 dataset for a picture: all stored nodes (or only ``node``), only the samples
    in [start, stop] [s]. Errors (missing or broken file, unknown group or node, times outside the
    record) are one-line ``SoftrnnInputError``s."""
    from ..io.dataset import read_dataset, read_node

    if node is not None:
        data = read_node(path, int(node), group=group)
        if start is None and stop is None:
            return data
        i0, i1 = time_span(data.time, start, stop, names=("--start", "--stop"))
        return _slice(data, i0, i1)
    if start is None and stop is None:
        return read_dataset(path, group=group)
    time = read_dataset(path, nodes=[], group=group).time  # the time axis only
    i0, i1 = time_span(time, start, stop, names=("--start", "--stop"))
    return read_dataset(path, group=group, start=i0, stop=i1 + 1)


def _slice(data, i0: int, i1: int):
    from types import SimpleNamespace

    sl = slice(i0, i1 + 1)
    return SimpleNamespace(time=data.time[sl], nodes=data.nodes, positions=data.positions[sl],
                           forces=data.forces[sl] if getattr(data, "forces", None) is not None else None,
                           attrs=dict(getattr(data, "attrs", None) or {}))


# ---------------------------------------------------------------------------------------------- geometry


def _nice(x: float) -> float:
    """The largest 1, 2 or 5 x 10^k not above x (x > 0)."""
    k = math.floor(math.log10(x))
    for m in (5, 2, 1):
        if m * 10.0**k <= x * (1 + 1e-9):
            return m * 10.0**k
    return 10.0**k


def _fmt(x: float) -> str:
    return f"{x:.3g}"


def force_scale(fmax: float, extent: float) -> tuple[float, float, float]:
    """(metres per newton, reference force [N], its arrow length [m]) for forces up to ``fmax``
    drawn on a picture ``extent`` metres across: the largest force gets about 20 % of the extent,
    rounded down to a 1-2-5 scale so the legend reads e.g. "1 N = 0.1 m"."""
    fmax = max(fmax, 1e-300)
    k = _nice(_ARROW * extent / fmax)
    ref = _nice(fmax)
    return k, ref, ref * k


def choose_view(positions: np.ndarray) -> str:
    """'xy', 'xz' or 'yz' when the motion stays in such a plane (one axis' range below 1 % of the
    largest), '3d' otherwise."""
    pts = positions.reshape(-1, 3)
    ranges = pts.max(0) - pts.min(0)
    big = float(ranges.max())
    if big <= 0:
        return "xy"
    for plane, flat in (("xy", 2), ("xz", 1), ("yz", 0)):
        if ranges[flat] <= _FLAT * big:
            return plane
    return "3d"


def _bounds(points: np.ndarray, pad: float = 0.06, min_fraction: float = 0.15):
    """Per-axis (lo, hi) covering points (k, 3) with a margin, every axis at least ``min_fraction`` of
    the largest range (centred), so equal-aspect boxes never collapse."""
    lo, hi = points.min(0), points.max(0)
    size = max(float((hi - lo).max()), 1e-3)
    half = np.maximum((hi - lo) / 2, min_fraction * size / 2) + pad * size
    mid = (lo + hi) / 2
    return mid - half, mid + half


def _max_norm(vectors: np.ndarray, chunk: int = 4096) -> float:
    """Largest |v| of (T, N, 3) vectors, in chunks of samples (no full-size temporaries); NaN -> error."""
    best = 0.0
    for k in range(0, vectors.shape[0], chunk):
        v = np.asarray(vectors[k:k + chunk], dtype=float)
        if v.size:
            m = float(np.sqrt((v * v).sum(-1)).max())
            if not math.isfinite(m):
                raise SoftrnnInputError("forces contain NaN or inf: the data is broken; re-create it")
            best = max(best, m)
    return best


def _fixed_nodes(positions: np.ndarray, extent: float) -> np.ndarray:
    """Columns whose position never changes (clamped or pinned ends)."""
    if positions.shape[0] < 2:
        return np.zeros(0, dtype=int)
    moved = np.abs(positions - positions[:1]).max(axis=(0, 2))
    return np.flatnonzero(moved <= 1e-9 * max(extent, 1e-12))


def _arrow_segments(tails: np.ndarray, vectors: np.ndarray, view_dir: np.ndarray, extent: float):
    """3-D arrows as line segments: a shaft and two head strokes in the plane facing the camera."""
    segs = []
    for p, v in zip(tails, vectors):
        length = float(np.linalg.norm(v))
        if length <= 0:
            continue
        u = v / length
        w = np.cross(u, view_dir)
        if np.linalg.norm(w) < 1e-6:
            w = np.cross(u, [1.0, 0.0, 0.0] if abs(u[0]) < 0.9 else [0.0, 1.0, 0.0])
        w /= np.linalg.norm(w)
        tip = p + v
        head = min(0.3 * length, 0.04 * extent)
        back = tip - head * 0.9 * u
        segs += [(p, tip), (tip, back + 0.45 * head * w), (tip, back - 0.45 * head * w)]
    return segs


# ---------------------------------------------------------------------------------------------- animation


class _Scene:
    """The figure and its reusable artists; ``update(i)`` moves them to sample ``i``."""

    def __init__(self, time, nodes, positions, forces, i0, i1, frames, *, node_col, view, trail, title,
                 size, elev=22.0, azim=-50.0, arrows_min=1e-6):
        self.time, self.positions, self.forces = time, positions, forces
        self.node_col, self.title = node_col, title
        self.node_label = None if node_col is None else int(nodes[node_col])
        self.elev, self.azim = elev, azim
        span = positions[i0:i1 + 1]
        every = max(1, span.shape[0] // 2000)
        sample = np.concatenate([np.asarray(span[::every], dtype=float),
                                 np.asarray(positions[frames], dtype=float)])
        lo, hi = sample.reshape(-1, 3).min(0), sample.reshape(-1, 3).max(0)
        self.extent = extent = max(float((hi - lo).max()), 1e-3)
        self.view = choose_view(sample) if view == "auto" else view
        # forces: the scale from the largest force in the span; arrows where |F| > arrows_min * fmax
        self.fmax = 0.0
        if forces is not None:
            self.fmax = _max_norm(forces[i0:i1 + 1])
        self.has_forces = self.fmax > 0
        if self.has_forces:
            self.k, self.fref, self.lref = force_scale(self.fmax, extent)
            self.fthreshold = arrows_min * self.fmax
            at = np.concatenate([np.arange(i0, i1 + 1, every), frames])
            tips = np.asarray(positions[at], dtype=float) + self.k * np.asarray(forces[at], dtype=float)
            box = np.concatenate([sample.reshape(-1, 3), tips.reshape(-1, 3)])
        else:
            box = sample.reshape(-1, 3)
        lo, hi = _bounds(box)
        self.fixed = _fixed_nodes(sample, extent)
        # trail of the node of interest at up to ~4000 points
        if node_col is not None and trail:
            step = max(1, span.shape[0] // 4000)
            self.trail_idx = np.arange(i0, i1 + 1, step)
            self.trail_pts = np.asarray(positions[self.trail_idx, node_col], dtype=float)
        else:
            self.trail_idx = None
        dt_frame = (time[frames[-1]] - time[frames[0]]) / max(len(frames) - 1, 1)
        self.decimals = max(0, min(6, -math.floor(math.log10(dt_frame)) + 1)) if dt_frame > 0 else 3

        self.fig = fig = plt.figure(figsize=(size[0] / _DPI, size[1] / _DPI), dpi=_DPI)
        try:
            self._build(fig, positions[i0], forces, lo, hi)
        except BaseException:
            plt.close(fig)
            raise

    def _build(self, fig, first, forces, lo, hi):
        handles = []
        first = np.asarray(first, dtype=float)
        if self.view == "3d":
            self._init_3d(fig, lo, hi, first, handles)
        else:
            self._init_2d(fig, lo, hi, first, handles)
        if self.has_forces:
            handles.append(Line2D([], [], color=_FORCE, lw=2,
                                  label=f"force: {_fmt(self.fref)} N = {_fmt(self.lref)} m"))
        elif forces is not None:
            handles.append(Line2D([], [], color="none", label="no applied forces"))
        # the legend stays clear of the moving rod: the top-left corner of a 3-D picture, below a flat one
        if self.view == "3d":
            fig.legend(handles=handles, loc="upper left", fontsize=7, framealpha=0.85,
                       bbox_to_anchor=(0.01, 0.99))
        else:
            fig.legend(handles=handles, loc="lower center", fontsize=7, ncol=3, frameon=False,
                       bbox_to_anchor=(0.5, 0.0))
        self.stamp = fig.suptitle(" ", fontsize=11)
        self.dynamic = [a for a in (getattr(self, "trail", None), self.rod, getattr(self, "quiver", None),
                                    getattr(self, "arrows", None), getattr(self, "dot", None), self.stamp)
                        if a is not None]

    def _node_handle(self):
        return Line2D([], [], color=_NODE, marker="o", ls="-" if self.trail_idx is not None else "none",
                      ms=5, lw=1, label=f"node {self.node_label}")

    # -- 2-D (planar motion)
    def _init_2d(self, fig, lo, hi, first, handles):
        a, b = self.axes = _PLANES[self.view]
        ax = self.ax = fig.add_subplot()
        fig.subplots_adjust(left=0.12, right=0.96, bottom=0.2, top=0.92)
        # widen the narrower range so that one metre is as long on both axes of the fixed box
        box = ax.get_position()
        aspect = (box.width * fig.get_figwidth()) / (box.height * fig.get_figheight())
        (xl, xh), (yl, yh) = (lo[a], hi[a]), (lo[b], hi[b])
        if (xh - xl) / (yh - yl) < aspect:
            grow = ((yh - yl) * aspect - (xh - xl)) / 2
            xl, xh = xl - grow, xh + grow
        else:
            grow = ((xh - xl) / aspect - (yh - yl)) / 2
            yl, yh = yl - grow, yh + grow
        ax.set_xlim(xl, xh)
        ax.set_ylim(yl, yh)
        ax.set_aspect("equal", adjustable="box")
        ax.set_autoscale_on(False)
        ax.set_xlabel(f"{'xyz'[a]} [m]")
        ax.set_ylabel(f"{'xyz'[b]} [m]")
        ax.grid(alpha=0.25)
        ax.plot(first[:, a], first[:, b], color=_GHOST, lw=1, ls="--", zorder=1)
        handles.append(Line2D([], [], color=_GHOST, lw=1, ls="--", label=f"t = {self.time[0]:g} s"))
        if self.fixed.size:
            ax.plot(first[self.fixed, a], first[self.fixed, b], "ks", ms=6, zorder=5)
            handles.append(Line2D([], [], color="k", marker="s", ls="none", ms=5, label="fixed"))
        (self.rod,) = ax.plot([], [], color=_ROD, lw=2.2, zorder=3)
        handles.insert(0, Line2D([], [], color=_ROD, lw=2.2, label="rod"))
        if self.trail_idx is not None:
            (self.trail,) = ax.plot([], [], color=_TRAIL, lw=1.0, alpha=0.9, zorder=2)
        if self.node_col is not None:
            (self.dot,) = ax.plot([], [], "o", color=_NODE, ms=6, zorder=6)
            handles.append(self._node_handle())
        if self.has_forces:
            n = self.positions.shape[1]
            self.quiver = ax.quiver(np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n), angles="xy",
                                    scale_units="xy", scale=1.0 / self.k, color=_FORCE, width=0.006,
                                    minlength=0, zorder=7)

    # -- 3-D
    def _init_3d(self, fig, lo, hi, first, handles):
        ax = self.ax = fig.add_subplot(projection="3d", computed_zorder=False)
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        ax.set_zlim(lo[2], hi[2])
        fig.subplots_adjust(left=0.0, right=0.86, bottom=0.0, top=0.97)
        ax.set_box_aspect(hi - lo, zoom=1.02)
        ax.view_init(elev=self.elev, azim=self.azim)
        ax.set_autoscale_on(False)
        for name in "xyz":
            getattr(ax, f"set_{name}label")(f"{name} [m]")
        ax.tick_params(labelsize=7)
        e, z = np.radians(ax.elev), np.radians(ax.azim)
        self.view_dir = np.array([np.cos(e) * np.cos(z), np.cos(e) * np.sin(z), np.sin(e)])
        ax.plot(first[:, 0], first[:, 1], first[:, 2], color=_GHOST, lw=1, ls="--")
        handles.append(Line2D([], [], color=_GHOST, lw=1, ls="--", label=f"t = {self.time[0]:g} s"))
        if self.fixed.size:
            ax.plot(first[self.fixed, 0], first[self.fixed, 1], first[self.fixed, 2], "ks", ms=6)
            handles.append(Line2D([], [], color="k", marker="s", ls="none", ms=5, label="fixed"))
        (self.rod,) = ax.plot([], [], [], color=_ROD, lw=2.2)
        handles.insert(0, Line2D([], [], color=_ROD, lw=2.2, label="rod"))
        if self.trail_idx is not None:
            (self.trail,) = ax.plot([], [], [], color=_TRAIL, lw=1.0, alpha=0.9)
        if self.node_col is not None:
            (self.dot,) = ax.plot([], [], [], "o", color=_NODE, ms=6)
            handles.append(self._node_handle())
        if self.has_forces:
            from mpl_toolkits.mplot3d.art3d import Line3DCollection
            self.arrows = Line3DCollection([], colors=_FORCE, linewidths=2.0)
            ax.add_collection3d(self.arrows, autolim=False)

    def update(self, i: int) -> None:
        X = np.asarray(self.positions[i], dtype=float)
        if self.view == "3d":
            self.rod.set_data_3d(X[:, 0], X[:, 1], X[:, 2])
        else:
            a, b = self.axes
            self.rod.set_data(X[:, a], X[:, b])
        if self.trail_idx is not None:
            m = int(np.searchsorted(self.trail_idx, i, side="right"))
            T = np.concatenate([self.trail_pts[:m], X[self.node_col][None]])
            if self.view == "3d":
                self.trail.set_data_3d(T[:, 0], T[:, 1], T[:, 2])
            else:
                self.trail.set_data(T[:, a], T[:, b])
        if self.node_col is not None:
            p = X[self.node_col]
            if self.view == "3d":
                self.dot.set_data_3d([p[0]], [p[1]], [p[2]])
            else:
                self.dot.set_data([p[a]], [p[b]])
        if self.has_forces:
            F = np.asarray(self.forces[i], dtype=float)
            on = np.sqrt((F ** 2).sum(-1)) > self.fthreshold
            if self.view == "3d":
                self.arrows.set_segments(_arrow_segments(X[on], self.k * F[on], self.view_dir, self.extent))
            else:
                F = np.where(on[:, None], F, 0.0)
                self.quiver.set_offsets(np.column_stack([X[:, a], X[:, b]]))
                self.quiver.set_UVC(F[:, a], F[:, b])
        self.stamp.set_text(f"{self.title}:  t = {self.time[i]:.{self.decimals}f} s")


def animate(data, out_path, *, fps: float = 20, frames: int | None = None, duration: float | None = None,
            start: float | None = None, stop: float | None = None, node: int | None = None,
            trail: bool = True, view: str = "auto", elev: float = 22.0, azim: float = -50.0,
            title: str | None = None,
            size: tuple[int, int] = DEFAULT_SIZE, max_frames: int = DEFAULT_MAX_FRAMES,
            progress=None) -> Path:
    """Write an animation of the rod to ``out_path`` (``.gif``, or ``.mp4`` with ffmpeg installed).

    data: dataset-like (time, nodes, positions, optional forces and attrs; see the module docstring).
    fps: frames per second of playback. frames / duration [s of playback]: how many frames (give at
    most one; default ``min(samples, max_frames)``), spread evenly over the samples in
    [start, stop] [s] (default: the whole record). node: the node of interest to mark (default: the
    data's ``attrs['node_of_interest']`` or its case's, if any; None marks none). trail: draw the
    path of the node of interest so far. view: 'auto' (a flat view when the motion is planar, else
    3-D), 'xy', 'xz', 'yz' or '3d'; elev, azim [deg]: the camera of the 3-D view. size: (width,
    height) in pixels (rounded up to even numbers for .mp4). max_frames: the default frame count's
    cap. progress: optional callable progress(done, total) per frame. Returns the path written.

    Rendering: the axes, ghost shape, clamps and legend are drawn once; each frame redraws only the
    rod, trail, node, arrows and time stamp over them (about 5-10 ms a frame at 640x560). GIF frames
    share one palette; all frames are held in memory (1 byte per pixel) until the file is written.
    """
    out_path = Path(out_path)
    suffix = check_suffix(out_path)
    if not (fps > 0 and math.isfinite(fps)):
        raise bad("fps", fps, "a number of frames per second > 0")
    if view not in VIEWS:
        raise bad("view", view, "one of " + ", ".join(VIEWS))
    width, height = (int(v) for v in size)
    if width < 64 or height < 64 or width > 4096 or height > 4096:
        raise bad("size", tuple(size), "(width, height) in pixels, each between 64 and 4096")
    if suffix == ".mp4":  # H.264 wants even sizes
        width, height = width + width % 2, height + height % 2
    time, nodes, positions, forces, attrs = _fields(data)
    i0, i1 = time_span(time, start, stop)
    idx = frame_indices(i1 - i0 + 1, frames=frames, duration=duration, fps=fps, max_frames=max_frames, first=i0)
    if node is None:
        node = node_of_interest(data)
        node_col = None if node is None or node not in set(nodes.tolist()) else _column(nodes, node)
    else:
        node_col = _column(nodes, _resolve(node, nodes, attrs))
    scene = _Scene(time, nodes, positions, forces, i0, i1, idx, node_col=node_col, view=view, trail=trail,
                   title=title or _title(attrs), size=(width, height), elev=float(elev), azim=float(azim))
    try:
        _write_movie(scene, idx, out_path, suffix, fps, progress)
    finally:
        plt.close(scene.fig)
    return out_path


def _publish(tmp: str, path: Path) -> None:
    """Give the finished temporary file the usual permissions (mkstemp makes it 0600) and rename it."""
    mask = os.umask(0)
    os.umask(mask)
    os.chmod(tmp, 0o666 & ~mask)
    os.replace(tmp, path)


class _GifSink:
    """Collects frames as 8-bit palette images (a quarter of the memory of RGBA) and writes one GIF.

    One palette serves all frames: a median cut of the first frame (which holds every static colour)
    plus gradients from the backgrounds to each moving artist's colour, each entry set to the
    commonest exact colour of its box (so white stays 255, not 252). Frames are mapped onto it by
    exact nearest colour through a lookup table filled as new colours appear (a few ms a frame)."""

    def __init__(self, tmp: str, size: tuple[int, int], fps: float, colors=()):
        self.tmp, self.size, self.fps, self.frames = tmp, size, fps, []
        self.colors = colors
        self.table = None  # (256, 3) palette
        self.lut = None  # packed RGB -> palette index
        self.known = None

    def _make_palette(self, first: np.ndarray) -> None:
        from matplotlib.colors import to_rgb
        from PIL import Image

        h, w, _ = first.shape
        grounds = [np.array([255.0, 255.0, 255.0]), first[h // 2, w // 2], first[h // 3, w // 3]]
        ramp = np.linspace(0.0, 1.0, 32)[:, None]
        strips = [(1 - ramp) * g + ramp * 255 * np.array(to_rgb(c)) for c in self.colors for g in grounds]
        swatch = np.concatenate(strips).round().astype(np.uint8)
        # repeated so that median cut (which splits by pixel count) gives the ramps about a third
        # of the palette instead of lumping them with the static colours
        reps = max(1, (h * w) // (2 * len(swatch)))
        swatch = np.repeat(swatch, reps, axis=0)
        rows = -(-len(swatch) // w)
        pad = np.full((rows * w - len(swatch), 3), 255, dtype=np.uint8)
        extra = np.concatenate([swatch, pad]).reshape(rows, w, 3)
        sheet = np.concatenate([first, extra])
        pal = Image.fromarray(sheet).quantize(colors=256, method=Image.Quantize.MEDIANCUT,
                                              dither=Image.Dither.NONE)
        idx = np.asarray(pal, dtype=np.int64).ravel()
        code = _pack(sheet).ravel()
        table = np.zeros((256, 3), dtype=np.int64)
        given = np.array(pal.getpalette() or [], dtype=np.int64)[:768]
        table.ravel()[:given.size] = given
        pairs, counts = np.unique(idx * (1 << 24) + code, return_counts=True)
        order = np.lexsort((-counts, pairs >> 24))
        firsts = np.unique(pairs[order] >> 24, return_index=True)[1]
        for pair in pairs[order][firsts]:
            k, c = int(pair >> 24), int(pair & 0xFFFFFF)
            table[k] = (c >> 16, (c >> 8) & 255, c & 255)
        self.table = table
        self.lut = np.zeros(1 << 24, dtype=np.uint8)
        self.known = np.zeros(1 << 24, dtype=bool)

    def _indices(self, rgb: np.ndarray) -> np.ndarray:
        code = _pack(rgb)
        new = np.unique(code[~self.known[code]])
        for k in range(0, new.size, 2048):
            part = new[k:k + 2048]
            cols = np.stack([part >> 16, (part >> 8) & 255, part & 255], axis=1)
            self.lut[part] = ((cols[:, None, :] - self.table[None, :, :]) ** 2).sum(-1).argmin(1)
            self.known[part] = True
        return self.lut[code]

    def add(self, rgba) -> None:
        from PIL import Image

        rgb = np.asarray(rgba)[..., :3]
        if self.table is None:
            self._make_palette(rgb)
        index = np.ascontiguousarray(self._indices(rgb))
        im = Image.frombuffer("P", self.size, index, "raw", "P", 0, 1)
        im.putpalette(self.table.astype(np.uint8).ravel().tolist())
        self.frames.append(im)

    def finish(self) -> None:
        self.frames[0].save(self.tmp, format="GIF", save_all=True, append_images=self.frames[1:],
                            duration=max(20, int(round(1000 / self.fps))), loop=0)

    def abort(self) -> None:
        self.frames = []


def _pack(rgb: np.ndarray) -> np.ndarray:
    """(..., 3) uint8 colours as int64 codes r << 16 | g << 8 | b."""
    rgb = rgb.astype(np.int64)
    return (rgb[..., 0] << 16) | (rgb[..., 1] << 8) | rgb[..., 2]


class _FfmpegSink:
    """Pipes raw RGBA frames to ffmpeg (matplotlib's FFMpegWriter builds the command line)."""

    def __init__(self, tmp: str, fig, fps: float):
        from matplotlib.animation import FFMpegWriter

        self.writer = FFMpegWriter(fps=fps, codec="libx264", extra_args=["-pix_fmt", "yuv420p"])
        self.writer.setup(fig, tmp, dpi=_DPI)

    def add(self, rgba) -> None:
        self.writer._proc.stdin.write(bytes(rgba))

    def finish(self) -> None:
        self.writer.finish()

    def abort(self) -> None:
        proc = getattr(self.writer, "_proc", None)
        if proc is not None:  # stop ffmpeg without finishing the file
            proc.kill()
            proc.wait()


def _render(scene: _Scene, idx: np.ndarray, add, progress=None) -> None:
    """Draw the static parts once, then per frame only the moving artists over a copy of them (Agg
    blitting) and hand the RGBA buffer to ``add``."""
    fig = scene.fig
    canvas = fig.canvas
    for artist in scene.dynamic:
        artist.set_animated(True)
    canvas.draw()
    background = canvas.copy_from_bbox(fig.bbox)
    for n, i in enumerate(idx):
        canvas.restore_region(background)
        scene.update(int(i))
        for artist in scene.dynamic:
            if hasattr(artist, "do_3d_projection"):
                artist.do_3d_projection()
            fig.draw_artist(artist)
        add(canvas.buffer_rgba())
        if progress is not None:
            progress(n + 1, len(idx))


def _write_movie(scene: _Scene, idx: np.ndarray, out_path: Path, suffix: str, fps: float, progress) -> None:
    out_path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{out_path.stem}.", suffix=f".tmp{suffix}", dir=out_path.parent)
    os.close(fd)
    sink = None
    try:
        w, h = (int(round(v)) for v in scene.fig.bbox.size)
        if suffix == ".mp4":
            sink = _FfmpegSink(tmp, scene.fig, fps)
        else:
            sink = _GifSink(tmp, (w, h), fps, colors=(_ROD, _NODE, _TRAIL, _FORCE, "k"))
        _render(scene, idx, sink.add, progress)
        sink.finish()
        _publish(tmp, out_path)
    except BaseException:
        if sink is not None:
            sink.abort()
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


# ---------------------------------------------------------------------------------------------- node plot


def plot_node(data, node: int, out_path=None, *, start: float | None = None, stop: float | None = None,
              forces: bool = True, title: str | None = None):
    """Figure of one node's x, y, z [mm] against time [s], with the forces on it [N] in a fourth panel
    (when ``forces`` and the data has non-zero forces on that node). Saved atomically to ``out_path``
    (.png, .pdf, .svg) when given; returns the path, else returns the Figure."""
    from .plots import node_trajectory_with_forces

    if out_path is not None:
        check_suffix(out_path, FIGURE_SUFFIXES)
    time, nodes, positions, F, attrs = _fields(data)
    col = _column(nodes, _resolve(node, nodes, attrs))
    i0, i1 = time_span(time, start, stop)
    sl = slice(i0, i1 + 1)
    f = F[sl, col] if forces and F is not None else None
    if f is not None and not np.any(f):
        f = None
    fig = node_trajectory_with_forces(time[sl], positions[sl, col], f,
                                      title or f"{_title(attrs)}: node {int(nodes[col])}")
    if out_path is None:
        return fig
    save_figure(fig, out_path)
    return Path(out_path)


def save_figure(fig, path, dpi: int = 110) -> None:
    """Save ``fig`` to ``path`` atomically (temporary name in the same folder, then rename; nothing is
    left behind on error) and close it."""
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=f".tmp{path.suffix}", dir=path.parent)
        os.close(fd)
        try:
            fig.savefig(tmp, dpi=dpi)
            _publish(tmp, path)
        except BaseException:
            if os.path.exists(tmp):
                os.unlink(tmp)
            raise
    finally:
        plt.close(fig)
