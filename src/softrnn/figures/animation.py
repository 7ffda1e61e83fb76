"""An animation of the rod over time (``animate``): the scene of reusable artists moved to each
frame, rendered by Agg blitting into a GIF (Pillow, one shared palette) or an MP4 (ffmpeg).

The rod is drawn at evenly spaced times (by default at most 200 frames covering the whole record)
with the applied forces as arrows (scale chosen automatically and given in the legend), the node of
interest and its trail marked, fixed equal-aspect axes that cover the whole motion, a flat view when
the motion is planar and a 3-D view otherwise.

With contact (``softrnn.rod.contact``; a dataset's ``contact`` attribute, docs/dataset-format.md)
the obstacles are drawn too (``draw_obstacles``): a plane as a translucent rectangle around the
rod's extent, a sphere as a translucent surface (a disc in a flat view), a cylinder as a surface
segment over the rod's extent (its shadow in a flat view), a vessel as its centreline and a
translucent tube (two wall lines in a flat view); the contact forces are arrows of their own colour
on the applied forces' scale. An obstacle with ``vessels`` (a tuple of vessels) is drawn as each
of them.

``style='fluoroscopy'`` draws instead the picture of an X-ray screen: the rod as a radiopaque
guidewire in its contrast-filled vessels (``figures.fluoroscopy``); ``style='auto'`` picks it for a
flat view of data with a vessel.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from matplotlib.animation import FFMpegWriter
from matplotlib.colors import to_rgb
from matplotlib.lines import Line2D
from matplotlib.patches import Circle, Patch, Polygon
from mpl_toolkits.mplot3d.art3d import Line3DCollection, Poly3DCollection
from PIL import Image
from scipy.spatial import ConvexHull, QhullError

from ..errors import SoftrnnInputError, bad
from ..geometry.contact import contact_from_record
from ..progress import Progress
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
    cylinder_mesh,
    force_scale,
    plane_patch,
    sphere_mesh,
    tube_mesh,
    tube_walls_2d,
    widen_to_aspect,
)
from .saving import FRAME_DPI as _DPI
from .saving import atomic_output, new_figure

DEFAULT_SIZE = (640, 560)  # pixels
_ROD, _NODE, _TRAIL, _FORCE, _GHOST = "#1f5fa8", "#d62728", "#ff9f1c", "#2ca02c", "0.72"
_CONTACT, _OBSTACLE, _ALPHA = "#9467bd", "#8c564b", 0.22


class _Scene:
    """The figure and its reusable artists; ``update(i)`` moves them to sample ``i``."""

    def __init__(self, time, nodes, positions, forces, i0, i1, frames, *, node_col, view, trail, title,
                 size, elev=22.0, azim=-50.0, arrows_min=1e-6, contact_forces=None, obstacles=()):
        self.time, self.positions, self.forces, self.cforces = time, positions, forces, contact_forces
        self.node_col, self.title, self.obstacles = node_col, title, tuple(obstacles)
        self.node_label = None if node_col is None else int(nodes[node_col])
        self.elev, self.azim = elev, azim
        span = positions[i0:i1 + 1]
        every = max(1, span.shape[0] // 2000)
        sample = np.concatenate([np.asarray(span[::every], dtype=float),
                                 np.asarray(positions[frames], dtype=float)])
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
            handles.append(Patch(facecolor=_OBSTACLE, alpha=0.4, edgecolor=_OBSTACLE,
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
        self.dynamic = [a for a in (getattr(self, "trail", None), self.rod, getattr(self, "quiver", None),
                                    getattr(self, "arrows", None), getattr(self, "cquiver", None),
                                    getattr(self, "carrows", None), getattr(self, "dot", None), self.stamp)
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
        handles.insert(0, Line2D([], [], color=_ROD, lw=2.2, label="rod"))
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
        handles.insert(0, Line2D([], [], color=_ROD, lw=2.2, label="rod"))
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
            self._move_arrows("", X, self.forces[i])
        if self.has_contact:
            self._move_arrows("c", X, self.cforces[i])
        self.stamp.set_text(f"{self.title}:  t = {self.time[i]:.{self.decimals}f} s")


def obstacles_of(contact) -> list[dict]:
    """The obstacles to draw of a contact: a ``softrnn.rod.Contact`` (or an object with its
    ``obstacles`` and ``friction``), a stored record (a dataset's ``attrs['contact']``,
    ``softrnn.io.schema.contact_record``) or None (none). One dict per obstacle as in the record
    (``kind``, geometry [m] and ``friction``: ``Obstacle.to_record``); a vessel's also has ``points``
    (P, 3) and ``radii`` (P,) [m], its dense centreline (``softrnn.geometry.Vessel.points``). A
    bifurcation (an obstacle with ``vessels``) is drawn as each of its vessels."""
    if contact is None:
        return []
    built = contact_from_record(contact) if isinstance(contact, dict) else contact
    obstacles = getattr(built, "obstacles", None)
    if obstacles is None:
        raise bad("contact", type(built).__name__, "a softrnn.rod.Contact, a stored contact record, or None")
    default = float(getattr(built, "friction", 0.0) or 0.0)
    return [entry for ob in obstacles for entry in _obstacle_entries(ob, default)]


_DRAWN = ("plane", "sphere", "cylinder", "vessel")
"""The obstacle kinds drawn as they are (``softrnn.geometry.obstacles``); a bifurcation as its vessels."""


def _obstacle_entries(ob, friction: float) -> list[dict]:
    """The drawn entries of one obstacle (see ``obstacles_of``): its record (``kind``), a vessel's with
    its dense polyline; an obstacle made of vessels (``vessels``, a bifurcation) as its vessels'."""
    kind = getattr(ob, "kind", None)
    own = getattr(ob, "friction", None)
    mu = friction if own is None else float(own)
    if getattr(ob, "vessels", None) is not None:       # a union of vessels (a Bifurcation)
        return [e for v in ob.vessels for e in _obstacle_entries(v, mu)]
    if kind not in _DRAWN:
        raise bad("contact.obstacles", type(ob).__name__, "Plane, Sphere, Cylinder or Vessel obstacles, or ones with "
                                                          "vessels (a tuple of Vessel)")
    entry = ob.to_record(mu)
    if kind == "vessel":
        entry.update(points=np.asarray(ob.points), radii=np.asarray(ob.radii))
    return [entry]


def draw_obstacles(ax, obstacles, view: str, lo, hi) -> list:
    """Draw ``obstacles`` (``obstacles_of``) on the axes ``ax`` of the view ``view`` ('xy', 'xz',
    'yz' or '3d') around the rod's extent, the box [lo, hi] (3,) [m]; returns the artists made.

    Planes are rectangles over the box, cylinders segments over its span on their axis, spheres
    whole, vessels their centreline and wall; all translucent, under the rod. In 3-D they are
    clipped to the axes' limits."""
    artists = []
    for ob in obstacles:
        kind = ob["kind"]
        if view == "3d":
            artists += _draw_3d(ax, ob, kind, lo, hi)
            continue
        a, b = _PLANES[view]
        if kind == "vessel":
            c, left, right = tube_walls_2d(ob["points"], ob["radii"], view)
            artists += ax.plot(c[:, 0], c[:, 1], color=_OBSTACLE, lw=0.8, ls="-.", zorder=0.5)
            artists += ax.plot(left[:, 0], left[:, 1], right[:, 0], right[:, 1], color=_OBSTACLE, lw=1.2, zorder=0.5)
            continue
        if kind == "sphere":
            patch = Circle((ob["center"][a], ob["center"][b]), ob["radius"])
        else:
            if kind == "plane":
                pts = plane_patch(ob["point"], ob["normal"], lo, hi)
            else:
                pts = cylinder_mesh(ob["point"], ob["axis"], ob["radius"], lo, hi).reshape(-1, 3)
            patch = Polygon(_outline(pts[:, [a, b]]), closed=True)
        patch.set(facecolor=_OBSTACLE, alpha=_ALPHA, edgecolor=_OBSTACLE, lw=1.0, zorder=0.5)
        artists.append(ax.add_patch(patch))
    return artists


def _outline(points: np.ndarray) -> np.ndarray:
    """The convex outline (k, 2) of projected points (m, 2) (a flat one: its two ends)."""
    try:
        return points[ConvexHull(points).vertices]
    except (QhullError, ValueError):  # collinear: a plane seen edge-on
        d = points - points.mean(0)
        _, _, vt = np.linalg.svd(d, full_matrices=False)
        t = d @ vt[0]
        return points[[int(np.argmin(t)), int(np.argmax(t))]]


def _draw_3d(ax, ob: dict, kind: str, lo, hi) -> list:
    """One obstacle on 3-D axes (see ``draw_obstacles``)."""
    style = dict(color=_OBSTACLE, alpha=_ALPHA, linewidth=0, shade=False, axlim_clip=True)
    if kind == "plane":
        poly = Poly3DCollection([plane_patch(ob["point"], ob["normal"], lo, hi)], facecolor=_OBSTACLE,
                                alpha=_ALPHA, edgecolor=_OBSTACLE)
        ax.add_collection3d(poly, autolim=False, axlim_clip=True)
        return [poly]
    if kind == "sphere":
        mesh = sphere_mesh(ob["center"], ob["radius"])
    elif kind == "cylinder":
        mesh = cylinder_mesh(ob["point"], ob["axis"], ob["radius"], lo, hi)
    else:
        mesh = tube_mesh(ob["points"], ob["radii"])
    out = [ax.plot_surface(mesh[..., 0], mesh[..., 1], mesh[..., 2], **style)]
    if kind == "vessel":
        c = ob["points"]
        out += ax.plot(c[:, 0], c[:, 1], c[:, 2], color=_OBSTACLE, lw=0.8, ls="-.", axlim_clip=True)
    return out


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
            style: str = "plain", progress: Progress | None = None) -> Path:
    """Write an animation of the rod to ``out_path`` (``.gif``, or ``.mp4`` with ffmpeg installed).

    Parameters
    ----------
    data : dataset-like
        time, nodes, positions, optional forces, contact_forces and attrs (with ``contact``, the
        obstacles' record) (see ``figures.data``)
    out_path : path
        the ``.gif`` or ``.mp4`` file to write
    fps : float
        frames per second of playback
    frames : int or None
        how many frames, spread evenly over the samples in [start, stop] (give at most one of
        ``frames`` and ``duration``; default ``min(samples, max_frames)``)
    duration : float or None
        seconds of playback instead (``duration * fps`` frames)
    start, stop : float or None
        the time span [s] to animate (default: the whole record)
    node : int or None
        the node of interest to mark (default: the one the data's attrs name, as
        ``figures.data.node_of_interest`` reads them, when it is stored; else none)
    trail : bool
        draw the path of the node of interest so far
    view : str
        'auto' (a flat view when the motion is planar, else 3-D), 'xy', 'xz', 'yz' or '3d'
    elev, azim : float
        the camera of the 3-D view [deg]
    title : str or None
        the name in the time stamp (default: a short name from the data's attrs)
    size : tuple of int
        (width, height) in pixels (rounded up to even numbers for .mp4)
    max_frames : int
        the default frame count's cap
    obstacles : bool, Contact or dict
        True: draw the data's obstacles (``attrs['contact']``, stored by the dataset writer), if
        any; False: none; a ``softrnn.rod.Contact`` or contact record: those (``draw_obstacles``)
    contact_forces : bool
        draw the data's contact forces (``contact_forces`` (T, N, 3) [N]) as arrows, on the scale
        of the applied forces
    style : str
        'plain': the rod, forces and obstacles on axes in metres; 'fluoroscopy': an X-ray picture of
        the rod in its vessels (``figures.fluoroscopy``); 'auto': ``pick_style``
    progress : Progress or None
        optional callable progress(done, total) per frame

    Returns
    -------
    Path
        the path written

    Notes
    -----
    Rendering: the axes, ghost shape, clamps, obstacles and legend are drawn once; each frame redraws
    only the rod, trail, node, arrows and time stamp over them. GIF frames share one palette; all frames are
    held in memory (1 byte per pixel) until the file is written, under a temporary name in the same
    folder (``saving.atomic_output``), renamed onto ``out_path`` when complete.
    """
    out_path = Path(out_path)
    suffix, width, height = _check_options(out_path, fps, view, size)
    time, nodes, positions, forces, attrs = _fields(data)
    drawn = _obstacles_to_draw(data, obstacles)
    i0, i1 = time_span(time, start, stop)
    idx = frame_indices(i1 - i0 + 1, frames=frames, duration=duration, fps=fps, max_frames=max_frames, first=i0)
    if pick_style(style, drawn, view, positions[i0:i1 + 1]) == "fluoroscopy":
        scene = FluoroScene(time, positions, i0, i1, idx, view=view, title=title or _title(attrs),
                            size=(width, height), obstacles=drawn, rod_radius=_rod_radius(attrs))
    else:
        cforces = _contact_forces(data, positions.shape) if contact_forces else None
        scene = _Scene(time, nodes, positions, forces, i0, i1, idx, node_col=_node_column(data, node, nodes, attrs),
                       view=view, trail=trail, title=title or _title(attrs), size=(width, height),
                       elev=float(elev), azim=float(azim), contact_forces=cforces, obstacles=drawn)
    _write_movie(scene, idx, out_path, suffix, fps, progress)
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
        """The shared palette from the first frame and the moving artists' colour ramps."""
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
        """Palette indices of an (H, W, 3) frame; new colours are looked up and remembered."""
        code = _pack(rgb)
        new = np.unique(code[~self.known[code]])
        for k in range(0, new.size, 2048):
            part = new[k:k + 2048]
            cols = np.stack([part >> 16, (part >> 8) & 255, part & 255], axis=1)
            self.lut[part] = ((cols[:, None, :] - self.table[None, :, :]) ** 2).sum(-1).argmin(1)
            self.known[part] = True
        return self.lut[code]

    def add(self, rgba) -> None:
        """Append one RGBA frame, mapped onto the shared palette."""
        rgb = np.asarray(rgba)[..., :3]
        if self.table is None:
            self._make_palette(rgb)
        index = np.ascontiguousarray(self._indices(rgb))
        im = Image.frombuffer("P", self.size, index, "raw", "P", 0, 1)
        im.putpalette(self.table.astype(np.uint8).ravel().tolist())
        self.frames.append(im)

    def finish(self) -> None:
        """Write the GIF to the temporary file."""
        self.frames[0].save(self.tmp, format="GIF", save_all=True, append_images=self.frames[1:],
                            duration=max(20, int(round(1000 / self.fps))), loop=0)

    def abort(self) -> None:
        """Drop the frames."""
        self.frames = []


def _pack(rgb: np.ndarray) -> np.ndarray:
    """(..., 3) uint8 colours as int64 codes r << 16 | g << 8 | b."""
    rgb = rgb.astype(np.int64)
    return (rgb[..., 0] << 16) | (rgb[..., 1] << 8) | rgb[..., 2]


class _FfmpegSink:
    """Pipes raw RGBA frames to ffmpeg (matplotlib's FFMpegWriter builds the command line)."""

    def __init__(self, tmp: str, fig, fps: float):
        self.writer = FFMpegWriter(fps=fps, codec="libx264", extra_args=["-pix_fmt", "yuv420p"])
        self.writer.setup(fig, tmp, dpi=_DPI)

    def add(self, rgba) -> None:
        """Pipe one RGBA frame to ffmpeg."""
        self.writer._proc.stdin.write(bytes(rgba))

    def finish(self) -> None:
        """Close the pipe and let ffmpeg finish the file."""
        self.writer.finish()

    def abort(self) -> None:
        """Stop ffmpeg without finishing the file."""
        proc = getattr(self.writer, "_proc", None)
        if proc is not None:  # stop ffmpeg without finishing the file
            proc.kill()
            proc.wait()


def _render(scene: _Scene, idx: np.ndarray, add, progress: Progress | None = None) -> None:
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


def _write_movie(scene, idx: np.ndarray, out_path: Path, suffix: str, fps: float, progress) -> None:
    """Render the frames ``idx`` of ``scene`` into ``out_path`` (.gif or .mp4) atomically
    (``saving.atomic_output``: nothing is left behind on error or Ctrl-C)."""
    with atomic_output(out_path) as tmp:
        if suffix == ".mp4":
            sink = _FfmpegSink(tmp, scene.fig, fps)
        else:
            w, h = (int(round(v)) for v in scene.fig.bbox.size)
            colors = getattr(scene, "colors", (_ROD, _NODE, _TRAIL, _FORCE, _CONTACT, "k"))
            sink = _GifSink(tmp, (w, h), fps, colors=colors)
        try:
            _render(scene, idx, sink.add, progress)
            sink.finish()
        except BaseException:
            sink.abort()
            raise
