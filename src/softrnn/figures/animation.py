"""An animation of the rod over time (``animate``): the scene of reusable artists moved to each
frame, rendered by Agg blitting into a GIF (Pillow, one shared palette) or an MP4 (ffmpeg).

The rod is drawn at evenly spaced times (by default at most 200 frames covering the whole record)
with the applied forces as arrows (scale chosen automatically and given in the legend), the node of
interest and its trail marked, fixed equal-aspect axes that cover the whole motion, a flat view when
the motion is planar and a 3-D view otherwise.

With contact (``softrnn.rod.contact``; a dataset's ``contact`` attribute, docs/dataset-format.md)
the obstacles are drawn too (``figures.obstacles``); the contact forces are arrows of their own
colour on the applied forces' scale. The frames are rendered and written by ``figures._movie``.

``style='fluoroscopy'`` draws instead the picture of an X-ray screen: the rod as a radiopaque
guidewire in its contrast-filled vessels (``figures.fluoroscopy``); ``style='auto'`` picks it for a
flat view of data with a vessel.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from mpl_toolkits.mplot3d.art3d import Line3DCollection

from ..errors import SoftrnnInputError, bad
from ..progress import Progress
from ._movie import write_movie
from .data import (
    DEFAULT_MAX_FRAMES,
    _column,
    _fields,
    _resolve,
    _title,
    check_suffix,
    frame_indices,
    node_of_interest,
    time_span,
)
from .fluoroscopy import FluoroScene
from .geometry import (
    _PLANES,
    VIEWS,
    _arrow_segments,
    _bounds,
    _fixed_nodes,
    _fmt,
    _max_norm,
    choose_view,
    force_scale,
    vessel_plane,
    widen_to_aspect,
)
from .obstacles import OBSTACLE_COLOR, draw_obstacles, obstacles_of
from .overlay import reference_positions
from .saving import FRAME_DPI as _DPI
from .saving import new_figure

DEFAULT_SIZE = (640, 560)  # pixels
_ROD, _NODE, _TRAIL, _FORCE, _GHOST = "#1f5fa8", "#d62728", "#ff9f1c", "#2ca02c", "0.72"
_CONTACT = "#9467bd"
_REFERENCE = "0.62"  # the data a prediction is drawn over: grey, dashed, under the prediction


class _Scene:
    """The figure and its reusable artists; ``update(i)`` moves them to sample ``i``."""

    def __init__(self, time, nodes, positions, forces, i0, i1, frames, *, node_col, view, trail, title,
                 size, elev=22.0, azim=-50.0, arrows_min=1e-6, contact_forces=None, obstacles=(), reference=None):
        self.time, self.positions, self.forces, self.cforces = time, positions, forces, contact_forces
        self.reference = reference          # (T, N, 3) [m]: the data a prediction is drawn over, or None
        self.tip_col, self.tip = int(np.argmax(nodes)), int(np.max(nodes))
        self.node_col, self.title, self.obstacles = node_col, title, tuple(obstacles)
        self.node_label = None if node_col is None else int(nodes[node_col])
        self.elev, self.azim = elev, azim
        span = positions[i0:i1 + 1]
        every = max(1, span.shape[0] // 2000)
        sample = np.concatenate([np.asarray(span[::every], dtype=float),
                                 np.asarray(positions[frames], dtype=float)]
                                + ([] if reference is None else [reference[i0:i1 + 1:every], reference[frames]]))
        lo, hi = sample.reshape(-1, 3).min(0), sample.reshape(-1, 3).max(0)
        self.extent = extent = max(float((hi - lo).max()), 1e-3)
        self.rod_box = _bounds(sample.reshape(-1, 3))
        self.view = choose_view(sample) if view == "auto" else view
        # forces: the scale from the largest (applied or contact) force in the span; arrows where
        # |F| > arrows_min * fmax
        self.fmax = 0.0 if forces is None else _max_norm(forces[i0:i1 + 1])
        self.cmax = 0.0 if contact_forces is None else _max_norm(contact_forces[i0:i1 + 1])
        self.has_forces, self.has_contact = self.fmax > 0, self.cmax > 0
        box = sample.reshape(-1, 3)
        if self.has_forces or self.has_contact:
            self.k, self.fref, self.lref = force_scale(max(self.fmax, self.cmax), extent)
            self.fthreshold = arrows_min * max(self.fmax, self.cmax)
            at = np.concatenate([np.arange(i0, i1 + 1, every), frames])
            for F in (f for f in (forces, contact_forces) if f is not None):
                tips = np.asarray(positions[at], dtype=float) + self.k * np.asarray(F[at], dtype=float)
                box = np.concatenate([box, tips.reshape(-1, 3)])
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

        self.fig = fig = new_figure(figsize=(size[0] / _DPI, size[1] / _DPI), dpi=_DPI)
        self._build(fig, positions[i0], forces, lo, hi)

    def _build(self, fig, first, forces, lo, hi):
        """The axes, the static artists, the legend and the time stamp; lists the moving artists."""
        handles = []
        first = np.asarray(first, dtype=float)
        if self.view == "3d":
            self._init_3d(fig, lo, hi, first, handles)
        else:
            self._init_2d(fig, lo, hi, first, handles)
        self._init_arrows()
        if self.obstacles:
            draw_obstacles(self.ax, self.obstacles, self.view, *self.rod_box)
            handles.append(Patch(facecolor=OBSTACLE_COLOR, alpha=0.4, edgecolor=OBSTACLE_COLOR,
                                 label=f"obstacle{'s' if len(self.obstacles) > 1 else ''}"))
        scale = f"{_fmt(self.fref)} N = {_fmt(self.lref)} m" if self.has_forces or self.has_contact else ""
        if self.has_forces:
            handles.append(Line2D([], [], color=_FORCE, lw=2, label=f"force: {scale}"))
        if self.has_contact:
            handles.append(Line2D([], [], color=_CONTACT, lw=2,
                                  label="contact force" + ("" if self.has_forces else f": {scale}")))
        if not self.has_forces and forces is not None:
            handles.append(Line2D([], [], color="none", label="no applied forces"))
        # the legend stays clear of the moving rod: the top-left corner of a 3-D picture, below a flat one
        if self.view == "3d":
            fig.legend(handles=handles, loc="upper left", fontsize=7, framealpha=0.85,
                       bbox_to_anchor=(0.01, 0.99))
        else:
            fig.legend(handles=handles, loc="lower center", fontsize=7, ncol=3, frameon=False,
                       bbox_to_anchor=(0.5, 0.0))
        self.stamp = fig.suptitle(" ", fontsize=11)
        self.dynamic = [a for a in (getattr(self, "trail", None), getattr(self, "ref", None), self.rod,
                                    getattr(self, "quiver", None), getattr(self, "arrows", None),
                                    getattr(self, "cquiver", None), getattr(self, "carrows", None),
                                    getattr(self, "dot", None), self.stamp)
                        if a is not None]

    def _init_arrows(self):
        """The arrows of the applied and contact forces (a quiver in 2-D, line strokes in 3-D)."""
        n = self.positions.shape[1]
        for on, color, name in ((self.has_forces, _FORCE, ""), (self.has_contact, _CONTACT, "c")):
            if not on:
                continue
            if self.view == "3d":
                artist = Line3DCollection([], colors=color, linewidths=2.0)
                self.ax.add_collection3d(artist, autolim=False)
                setattr(self, f"{name}arrows", artist)
            else:
                setattr(self, f"{name}quiver", self.ax.quiver(
                    np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n), angles="xy", scale_units="xy",
                    scale=1.0 / self.k, color=color, width=0.006, minlength=0, zorder=7))

    def _rod_handles(self, handles) -> None:
        """The legend's first entries: the rod, or the prediction and its reference."""
        if self.reference is None:
            handles.insert(0, Line2D([], [], color=_ROD, lw=2.2, label="rod"))
            return
        handles[:0] = [Line2D([], [], color=_ROD, lw=2.2, label="prediction"),
                       Line2D([], [], color=_REFERENCE, lw=2.6, ls="--", label="reference (data)")]

    def _node_handle(self):
        """The legend entry of the node of interest."""
        return Line2D([], [], color=_NODE, marker="o", ls="-" if self.trail_idx is not None else "none",
                      ms=5, lw=1, label=f"node {self.node_label}")

    # -- 2-D (planar motion)
    def _init_2d(self, fig, lo, hi, first, handles):
        """A flat view of the plane ``self.view`` with equal scales on both axes."""
        a, b = self.axes = _PLANES[self.view]
        ax = self.ax = fig.add_subplot()
        fig.subplots_adjust(left=0.12, right=0.96, bottom=0.2, top=0.92)
        # widen the narrower range so that one metre is as long on both axes of the fixed box
        box = ax.get_position()
        aspect = (box.width * fig.get_figwidth()) / (box.height * fig.get_figheight())
        xl, xh, yl, yh = widen_to_aspect(lo[a], hi[a], lo[b], hi[b], aspect)
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
        self._rod_handles(handles)
        if self.reference is not None:
            (self.ref,) = ax.plot([], [], color=_REFERENCE, lw=2.6, ls="--", zorder=2)
        if self.trail_idx is not None:
            (self.trail,) = ax.plot([], [], color=_TRAIL, lw=1.0, alpha=0.9, zorder=2)
        if self.node_col is not None:
            (self.dot,) = ax.plot([], [], "o", color=_NODE, ms=6, zorder=6)
            handles.append(self._node_handle())

    # -- 3-D
    def _init_3d(self, fig, lo, hi, first, handles):
        """A 3-D view from ``elev``, ``azim`` with equal scales on the three axes."""
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
        self._rod_handles(handles)
        if self.reference is not None:
            (self.ref,) = ax.plot([], [], [], color=_REFERENCE, lw=2.6, ls="--")
        if self.trail_idx is not None:
            (self.trail,) = ax.plot([], [], [], color=_TRAIL, lw=1.0, alpha=0.9)
        if self.node_col is not None:
            (self.dot,) = ax.plot([], [], [], "o", color=_NODE, ms=6)
            handles.append(self._node_handle())

    def _move_arrows(self, name: str, X: np.ndarray, forces) -> None:
        """Set the arrows ``name`` ('': applied, 'c': contact) to the forces (N, 3) [N] at X (N, 3) [m]."""
        F = np.asarray(forces, dtype=float)
        on = np.sqrt((F ** 2).sum(-1)) > self.fthreshold
        if self.view == "3d":
            getattr(self, f"{name}arrows").set_segments(
                _arrow_segments(X[on], self.k * F[on], self.view_dir, self.extent))
        else:
            a, b = self.axes
            F = np.where(on[:, None], F, 0.0)
            quiver = getattr(self, f"{name}quiver")
            quiver.set_offsets(np.column_stack([X[:, a], X[:, b]]))
            quiver.set_UVC(F[:, a], F[:, b])

    def update(self, i: int) -> None:
        """Move the rod, trail, node, arrows and time stamp to sample ``i``."""
        X = np.asarray(self.positions[i], dtype=float)
        lines = [(self.rod, X)] + ([] if self.reference is None else [(self.ref, self.reference[i])])
        a, b = getattr(self, "axes", (0, 1))
        for line, P in lines:
            if self.view == "3d":
                line.set_data_3d(P[:, 0], P[:, 1], P[:, 2])
            else:
                line.set_data(P[:, a], P[:, b])
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
            self._move_arrows("", X, self.forces[i])
        if self.has_contact:
            self._move_arrows("c", X, self.cforces[i])
        stamp = f"{self.title}:  t = {self.time[i]:.{self.decimals}f} s"
        if self.reference is not None:
            error = float(np.linalg.norm(X[self.tip_col] - self.reference[i, self.tip_col])) * 1e3
            stamp += f",  tip (node {self.tip}) error {error:.3g} mm"
        self.stamp.set_text(stamp)


def _obstacles_to_draw(data, obstacles) -> list[dict]:
    """``animate``'s obstacles: True the data's own (``attrs['contact']``), False none, else those given."""
    if obstacles is False:
        return []
    source = dict(getattr(data, "attrs", None) or {}).get("contact") if obstacles is True else obstacles
    try:
        return obstacles_of(source)
    except SoftrnnInputError as err:
        raise bad("obstacles", "the data's contact record" if obstacles is True else "the given obstacles",
                  f"a softrnn.rod.Contact or a stored contact record ({err})") from None


def _check_options(out_path: Path, fps, view, size) -> tuple[str, int, int]:
    """``animate``'s suffix, width and height [pixels], after checking its options."""
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
    return suffix, width, height


def animate(data, out_path, *, fps: float = 20, frames: int | None = None, duration: float | None = None,
            start: float | None = None, stop: float | None = None, node: int | None = None,
            trail: bool = True, view: str = "auto", elev: float = 22.0, azim: float = -50.0,
            title: str | None = None, size: tuple[int, int] = DEFAULT_SIZE,
            max_frames: int = DEFAULT_MAX_FRAMES, obstacles=True, contact_forces: bool = True,
            style: str = "plain", progress: Progress | None = None, reference=None) -> Path:
    """Write an animation of the rod to ``out_path`` (``.gif``, or ``.mp4`` with ffmpeg installed).

    ``data`` is dataset-like (``figures.data``): time (T,) [s], nodes, positions (T, N, 3) [m],
    optional forces and contact_forces (T, N, 3) [N], attrs. It shows ``frames`` frames, or
    ``duration`` s of playback at ``fps``, spread evenly from ``start`` to ``stop`` [s] (default
    ``min(samples, max_frames)`` over the whole record); marks ``node`` (default: the one the data
    names) and its ``trail``; in the ``view`` 'auto', 'xy', 'xz', 'yz' or '3d' (camera ``elev``,
    ``azim`` [deg]; 'auto': the plane of a flat vessel drawn, else ``choose_view``) at ``size``
    (width, height) [pixels]. ``reference``: dataset-like data that ``data`` predicts, drawn
    dashed under it with the tip's error (``figures.overlay``; the plain style). ``obstacles``:
    True the data's, False none, or a Contact or contact record (``figures.obstacles``); ``style``:
    one of ``STYLES`` (``pick_style``); ``progress(done, total)`` per frame. The file appears
    complete or not at all (docs/guide/datasets.md#pictures).

    Returns
    -------
    Path
        the path written
    """
    out_path = Path(out_path)
    suffix, width, height = _check_options(out_path, fps, view, size)
    time, nodes, positions, forces, attrs = _fields(data)
    drawn = _obstacles_to_draw(data, obstacles)
    if view == "auto":
        view = vessel_plane(drawn) or "auto"       # a rod in a flat vessel: seen along the plane's normal
    ref = None if reference is None else reference_positions(data, reference)
    if ref is not None and style == "fluoroscopy":
        raise bad("style", style, "'plain' or 'auto' with a reference drawn under the prediction")
    i0, i1 = time_span(time, start, stop)
    idx = frame_indices(i1 - i0 + 1, frames=frames, duration=duration, fps=fps, max_frames=max_frames, first=i0)
    if pick_style(style, drawn, view, positions[i0:i1 + 1]) == "fluoroscopy" and ref is None:
        scene = FluoroScene(time, positions, i0, i1, idx, view=view, title=title or _title(attrs),
                            size=(width, height), obstacles=drawn, rod_radius=_rod_radius(attrs))
    else:
        cforces = _contact_forces(data, positions.shape) if contact_forces else None
        scene = _Scene(time, nodes, positions, forces, i0, i1, idx, node_col=_node_column(data, node, nodes, attrs),
                       view=view, trail=trail, title=title or _title(attrs), size=(width, height),
                       elev=float(elev), azim=float(azim), contact_forces=cforces, obstacles=drawn, reference=ref)
    write_movie(scene, idx, out_path, suffix, fps, progress,
                colors=(_ROD, _NODE, _TRAIL, _FORCE, _CONTACT, "k") + (() if ref is None else (_REFERENCE,)))
    return out_path


def _node_column(data, node: int | None, nodes: np.ndarray, attrs: dict) -> int | None:
    """The column in ``nodes`` of the node of interest: ``node``'s, or else the one the data names
    if stored."""
    if node is not None:
        return _column(nodes, _resolve(node, nodes, attrs))
    node = node_of_interest(data)
    return None if node is None or node not in set(nodes.tolist()) else _column(nodes, node)


STYLES = ("auto", "plain", "fluoroscopy")
"""The looks of ``animate``."""


def pick_style(style: str, obstacles: list, view: str, positions: np.ndarray) -> str:
    """The look of an animation.

    Parameters
    ----------
    style : str
        one of ``STYLES``
    obstacles : list of dict
        the obstacles drawn (``obstacles_of``)
    view : str
        the view asked for ('auto', 'xy', 'xz', 'yz' or '3d')
    positions : (T, N, 3)
        the rod's positions [m] over the span shown (for the 'auto' view)

    Returns
    -------
    str
        'plain' or 'fluoroscopy': ``style`` itself, or for 'auto' 'fluoroscopy' when a vessel is
        drawn and the view is a flat one ('auto': a planar motion), else 'plain'
    """
    if style not in STYLES:
        raise bad("style", style, "one of " + ", ".join(STYLES))
    if style != "auto":
        return style
    vessel = any(o["kind"] == "vessel" for o in obstacles)
    flat = view in _PLANES or (view == "auto" and choose_view(np.asarray(positions, dtype=float)) != "3d")
    return "fluoroscopy" if vessel and flat else "plain"


def _rod_radius(attrs: dict) -> float | None:
    """The rod's radius [m] that the data's ``attrs['rod']`` records, or None."""
    rod = attrs.get("rod")
    value = rod.get("radius") if isinstance(rod, dict) else None
    return float(value) if isinstance(value, (int, float)) and not isinstance(value, bool) and value > 0 else None


def _contact_forces(data, shape: tuple) -> np.ndarray | None:
    """The data's contact forces (T, N, 3) [N] (``contact_forces``), or None without them."""
    value = getattr(data, "contact_forces", None)
    if value is None:
        return None
    arr = np.asarray(value)
    if arr.shape != shape or not np.issubdtype(arr.dtype, np.number):
        raise bad("contact_forces", f"shape {arr.shape}", f"numbers of shape {shape} matching positions")
    return arr
