"""The fluoroscopy look of the rod animation (``animate(..., style='fluoroscopy')``): the picture an
interventional X-ray screen shows while a guidewire is pushed through a contrast-filled vessel.

Everything is a flat projection on one of the planes 'xy', 'xz' or 'yz', in shades of grey:

- the background: a grey X-ray field, brighter in the middle (vignetting), with fixed soft-tissue
  mottle and fine quantum noise from a seeded random generator (the same picture on every run);
- the vessels' lumen: each tube's true radius projected onto the view plane, filled with contrast,
  darker toward the centreline where the X-rays cross more of it (vessels that share a lumen, like
  the trunk of a branching vessel, are one lumen), its walls a fine outline;
- the rod as a thin, nearly black (radiopaque) line of its true diameter (at least
  ``MIN_WIRE_PIXELS`` wide), its distal ``TIP_LENGTH`` darker and thicker: the radiopaque tip;
- a scale bar in mm, the time stamp and the data's name; no axes, ticks or legend.

The frame follows the rod's tip (its last stored node): the box of the tip's path over the animated
span, with a margin of a few vessel diameters, widened to the frame's aspect. The rod's base and the
vessel's far ends may lie outside it, as they lie outside the field of an X-ray image.
"""

from __future__ import annotations

import math

import numpy as np
from matplotlib.patches import Rectangle
from scipy.ndimage import binary_erosion, distance_transform_edt

from ..errors import bad
from .geometry import _PLANES, _nice, choose_view, widen_to_aspect
from .saving import FRAME_DPI as _DPI
from .saving import new_figure

TIP_LENGTH = 0.03  # m: the radiopaque distal part of a guidewire
MIN_WIRE_PIXELS = 1.6  # the rod's line is never thinner than this, whatever its true diameter
DEFAULT_SEED = 20261127  # the background's noise
_FIELD = 0.66  # the background's grey in the middle of the field (0 black, 1 white)
_CONTRAST = 0.5  # the share of the field's brightness the contrast takes at a lumen's centreline
_WALL = 0.75  # the lumen's outline: its edge pixels this much darker
_WIRE, _TIP, _TEXT = "0.12", "0.0", "0.93"
COLORS = ("0.0", "0.12", "0.93", "1.0")
"""The moving artists' colours (the GIF palette keeps their ramps exact)."""


def fluoroscopy_view(view: str, positions: np.ndarray) -> str:
    """The projection plane of a fluoroscopy picture.

    Parameters
    ----------
    view : str
        'auto', 'xy', 'xz' or 'yz' ('3d' is refused: an X-ray image is a projection)
    positions : (T, N, 3)
        the rod's positions [m] over the span shown

    Returns
    -------
    str
        'xy', 'xz' or 'yz': the given plane, or for 'auto' the plane of a planar motion, else the
        plane across the axis along which the rod moves least
    """
    if view in _PLANES:
        return view
    if view != "auto":
        raise bad("view", view, "'auto', 'xy', 'xz' or 'yz' with the fluoroscopy style (a projection, not 3-D)")
    pts = np.asarray(positions, dtype=float).reshape(-1, 3)
    chosen = choose_view(pts)
    if chosen != "3d":
        return chosen
    return ("yz", "xz", "xy")[int(np.argmin(pts.max(0) - pts.min(0)))]


def frame_box(tip: np.ndarray, margin: float, aspect: float) -> tuple[float, float, float, float]:
    """The region a fluoroscopy frame shows.

    Parameters
    ----------
    tip : (k, 2)
        the tip's projected path [m]
    margin : float
        the least margin around it [m] (a few vessel diameters)
    aspect : float
        the frame's width over its height

    Returns
    -------
    tuple of float
        (left, right, bottom, top) [m]: the path's box with a margin of ``margin`` or 15 % of its
        size, whichever is larger, widened to ``aspect``
    """
    lo, hi = tip.min(0), tip.max(0)
    pad = max(0.15 * float((hi - lo).max()), margin)
    (x0, y0), (x1, y1) = lo - pad, hi + pad
    x0, x1, y0, y1 = widen_to_aspect(x0, x1, y0, y1, aspect)
    return float(x0), float(x1), float(y0), float(y1)


def xray_background(width: int, height: int, seed: int = DEFAULT_SEED) -> np.ndarray:
    """The grey field of an X-ray image.

    Parameters
    ----------
    width, height : int
        its size in pixels
    seed : int
        the seed of its noise (the same seed, the same picture)

    Returns
    -------
    np.ndarray
        (height, width) greys in [0, 1], quantised to 1/255 (the first row is the top): vignetting
        from ``_FIELD`` in the middle to about 60 % of it in the corners, a soft mottle of 3 % and a
        fine noise of 1.5 %
    """
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:height, 0:width].astype(float)
    half = max(width, height) / 2
    r2 = ((x - width / 2) / half) ** 2 + ((y - height / 2) / half) ** 2
    field = _FIELD * (1.0 - 0.2 * r2)
    coarse = rng.normal(0.0, 1.0, (6, 6))  # bilinear over the field
    rows = np.array([np.interp(np.linspace(0, 5, width), np.arange(6), c) for c in coarse])
    gy = np.linspace(0, 5, height)
    i = np.minimum(gy.astype(int), 4)
    f = (gy - i)[:, None]
    mottle = rows[i] * (1 - f) + rows[i + 1] * f
    image = field + 0.03 * mottle + 0.015 * rng.normal(0.0, 1.0, (height, width))
    return np.round(np.clip(image, 0.0, 1.0) * 255) / 255


def lumen_depth(vessels, view: str, box, width: int, height: int) -> np.ndarray:
    """The contrast agent a vessel picture shows: its depth along the X-rays at each pixel, the chord
    sqrt(1 - (d / r)^2) of the tube at a distance d from its projected centreline (to half a pixel),
    the largest of the vessels' (their union: a shared trunk is one lumen).

    Parameters
    ----------
    vessels, view : list of dict, str
        ``obstacles.obstacles_of`` entries of kind 'vessel' (``points`` (P, 3), ``radii`` (P,) [m]);
        the plane, 'xy', 'xz' or 'yz'
    box : tuple of float
        (left, right, bottom, top) [m] of the picture (``frame_box``)
    width, height : int
        the picture's size in pixels

    Returns
    -------
    np.ndarray
        (height, width) in [0, 1], the first row the top
    """
    x0, x1, y0, y1 = box
    px = (x1 - x0) / width
    a, b = _PLANES[view]
    depth = np.zeros((height, width))
    for ob in vessels:
        c, r = np.asarray(ob["points"], dtype=float)[:, [a, b]], np.asarray(ob["radii"], dtype=float) / px
        pad = int(math.ceil(r.max())) + 2
        s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(c, axis=0), axis=1))]) / px
        t = np.linspace(0.0, s[-1], min(max(2, int(s[-1] / 0.3) + 2), 4_000_000))  # every 0.3 pixel
        i = np.round((y1 - np.interp(t, s, c[:, 1])) / px - 0.5 + pad).astype(np.int64)
        j = np.round((np.interp(t, s, c[:, 0]) - x0) / px - 0.5 + pad).astype(np.int64)
        keep = (i >= 0) & (i < height + 2 * pad) & (j >= 0) & (j < width + 2 * pad)
        if not keep.any():
            continue
        far = np.ones((height + 2 * pad, width + 2 * pad), dtype=bool)
        size = np.zeros(far.shape)
        far[i[keep], j[keep]] = False
        size[i[keep], j[keep]] = np.interp(t, s, r)[keep]
        d, (ii, jj) = distance_transform_edt(far, return_indices=True)
        chord = np.sqrt(np.clip(1.0 - (d / size[ii, jj]) ** 2, 0.0, 1.0))
        depth = np.maximum(depth, chord[pad:pad + height, pad:pad + width])
    return depth


def xray_picture(field: np.ndarray, depth: np.ndarray) -> np.ndarray:
    """The static picture: the field darkened by the contrast, the lumen's outline (the walls) a pixel wide.

    Parameters
    ----------
    field : (H, W)
        the X-ray field's greys in [0, 1] (``xray_background``)
    depth : (H, W)
        the contrast's depth in [0, 1] (``lumen_depth``)

    Returns
    -------
    np.ndarray
        (H, W) greys in [0, 1], quantised to 1/255: ``field`` times 1 - ``_CONTRAST`` x depth, and
        the lumen's edge pixels ``_WALL`` times darker
    """
    image = field * (1.0 - _CONTRAST * depth)
    inside = depth > 0
    image[inside & ~binary_erosion(inside, border_value=1)] *= _WALL
    return np.round(np.clip(image, 0.0, 1.0) * 255) / 255


def _tip_start(first: np.ndarray) -> int:
    """The first node (column) of the radiopaque tip: the last ``TIP_LENGTH`` of the rod's length
    (at most a fifth of it, at least its last segment), measured on ``first`` (N, 3) [m]."""
    seg = np.linalg.norm(np.diff(first, axis=0), axis=1)
    from_tip = np.concatenate([np.cumsum(seg[::-1])[::-1], [0.0]])
    tip = min(TIP_LENGTH, float(from_tip[0]) / 5) * (1 + 1e-9)
    return int(min(np.flatnonzero(from_tip <= tip)[0], len(first) - 2)) if len(first) > 1 else 0


class FluoroScene:
    """A fluoroscopy picture of the rod (see the module's description); ``update(i)`` moves the
    rod to sample ``i``.

    Parameters
    ----------
    time : (T,)
        the sample times [s]
    positions : (T, N, 3)
        the stored nodes' positions [m], ordered along the rod (the last one is the tip)
    i0, i1 : int
        the first and last sample of the span shown (inclusive)
    frames : (F,) int
        the samples shown
    view : str
        'auto', 'xy', 'xz' or 'yz' (``fluoroscopy_view``)
    title : str
        the data's name, written in the top-left corner
    size : tuple of int
        (width, height) in pixels
    obstacles : list of dict
        ``obstacles.obstacles_of`` entries; the vessels are drawn (an X-ray image shows no walls
        or planes)
    rod_radius : float or None
        the rod's radius [m] (its line's width); None: ``MIN_WIRE_PIXELS``
    seed : int
        the seed of the background's noise
    """

    colors = COLORS

    def __init__(self, time, positions, i0, i1, frames, *, view, title, size, obstacles=(), rod_radius=None,
                 seed=DEFAULT_SEED):
        self.time, self.positions = time, positions
        span = np.asarray(positions[i0:i1 + 1], dtype=float)
        self.view = fluoroscopy_view(view, span)
        a, b = self.axes = _PLANES[self.view]
        vessels = [o for o in obstacles if o["kind"] == "vessel"]
        radius = max((float(np.max(o["radii"])) for o in vessels), default=0.0)
        w, h = (int(v) for v in size)
        x0, x1, y0, y1 = frame_box(span[:, -1][:, [a, b]], max(4 * radius, 0.01), w / h)
        px = (x1 - x0) / w  # metres per pixel
        self.fig = fig = new_figure(figsize=(w / _DPI, h / _DPI), dpi=_DPI)
        ax = self.ax = fig.add_axes((0.0, 0.0, 1.0, 1.0))
        ax.set_axis_off()
        ax.set_xlim(x0, x1)
        ax.set_ylim(y0, y1)
        ax.set_autoscale_on(False)
        picture = xray_picture(xray_background(w, h, seed), lumen_depth(vessels, self.view, (x0, x1, y0, y1), w, h))
        ax.imshow(picture, cmap="gray", vmin=0.0, vmax=1.0, extent=(x0, x1, y0, y1), origin="upper",
                  interpolation="nearest", aspect="auto", zorder=0)
        wire = max(2 * rod_radius / px if rod_radius else 0.0, MIN_WIRE_PIXELS) * 72.0 / _DPI
        (self.wire,) = ax.plot([], [], color=_WIRE, lw=wire, solid_capstyle="round", zorder=3)
        (self.tip,) = ax.plot([], [], color=_TIP, lw=1.5 * wire, solid_capstyle="round", zorder=4)
        self.tip_start = _tip_start(span[0])
        fs = min(16.0, max(6.0, 10.0 * h / 560))
        self._scale_bar(ax, (x0, x1, y0, y1), px, fs)
        ax.text(0.02, 0.97, title, transform=ax.transAxes, ha="left", va="top", color=_TEXT, fontsize=fs)
        self.stamp = ax.text(0.98, 0.97, " ", transform=ax.transAxes, ha="right", va="top", color=_TEXT,
                             fontsize=fs, family="monospace")
        self.dynamic = [self.wire, self.tip, self.stamp]
        dt_frame = (time[frames[-1]] - time[frames[0]]) / max(len(frames) - 1, 1)
        self.decimals = max(0, min(6, -math.floor(math.log10(dt_frame)) + 1)) if dt_frame > 0 else 3

    @staticmethod
    def _scale_bar(ax, box, px: float, fs: float) -> None:
        """A bar of a round length in mm (about a fifth of the width) in the bottom-right corner."""
        x0, x1, y0, y1 = box
        length = _nice(0.2 * (x1 - x0))
        right, bottom = x1 - 0.04 * (x1 - x0), y0 + 0.05 * (y1 - y0)
        ax.add_patch(Rectangle((right - length, bottom), length, 3 * px, facecolor=_TEXT, edgecolor="none",
                               zorder=5))
        ax.text(right - length / 2, bottom + 6 * px, f"{length * 1e3:g} mm", ha="center", va="bottom",
                color=_TEXT, fontsize=fs, zorder=5)

    def update(self, i: int) -> None:
        """Move the rod and the time stamp to sample ``i``."""
        a, b = self.axes
        X = np.asarray(self.positions[i], dtype=float)
        self.wire.set_data(X[:, a], X[:, b])
        self.tip.set_data(X[self.tip_start:, a], X[self.tip_start:, b])
        self.stamp.set_text(f"t = {self.time[i]:.{self.decimals}f} s")
