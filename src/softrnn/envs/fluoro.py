"""The fluoroscopy observation of the navigation environments (``NavigateConfig(observation="image")``):
a small grayscale X-ray image, uint8 (H, W, 1), of the device in the contrast-filled lumen,
projected along a view axis (docs/guide/envs.md).

It is the look of ``softrnn animate --style fluoroscopy`` (``softrnn.figures.fluoroscopy``) cut down
to what a training loop affords:

* the lumen, drawn once per environment: a flat X-ray field (``FIELD``), darker where the X-rays
  cross more contrast (I = FIELD exp(-mu c), c the chord of the pixel's ray through the lumen,
  found from the obstacles' gaps sampled along the ray; mu such that a chord of the entry's
  diameter takes ``CONTRAST`` of the light);
* the goal: a bright dot (``GOAL``) where the target counts as reached (``goal_depth`` into the
  target branch), so that an image alone says where to go (one background per branch);
* per step the device: its segments as lines of its true width (at least ``MIN_WIRE_PIXELS``),
  radiopaque (``OPACITY`` of the light taken at full cover, anti-aliased at the edges), drawn by a
  numba kernel (``render_into``) over a copy of the background in a preallocated array.

The view: the X-rays travel along ``Fluoroscopy.view`` (default: across the plane the vessel's
centrelines lie closest to, along gravity, i.e. from above), the entry's axis points right, and the
square field of view is centred on the first fork, just wide enough to hold every branch's end.
"""

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from ..errors import bad, integer, positive

FIELD = 200.0
"""The X-ray field's grey level outside the lumen (0 black, 255 white)."""
CONTRAST = 0.5
"""The share of the light the contrast takes across the entry's full diameter."""
OPACITY = 0.85
"""The share of the light the radiopaque device takes where it covers a pixel fully."""
MIN_WIRE_PIXELS = 1.0
"""The device's line is never thinner than this [pixels], whatever its true diameter."""
GOAL = 255
"""The goal dot's grey level."""
DEPTH_SAMPLES = 24
"""Samples along each pixel's ray for the lumen's chord."""


@dataclass(frozen=True, kw_only=True)
class Fluoroscopy:
    """The image observation's settings.

    Attributes
    ----------
    size : int
        pixels per side of the square image, in [8, 512] (64)
    field : float or None
        side of the square field of view [m]; None: centred on the first fork, just wide enough to
        hold every branch's end (0.155 m for the default vessel: 2.4 mm per pixel at 64)
    view : tuple or None
        the direction the X-rays travel (3,) [-]; None: across the plane of the vessel's
        centrelines, along gravity (from above)
    """

    size: int = 64
    field: float | None = None
    view: tuple | None = None

    def __post_init__(self):
        integer("image.size", self.size, 8)
        if self.size > 512:
            raise bad("image.size", self.size, "at most 512 pixels per side")
        if self.field is not None:
            positive("image.field", self.field, "m")
        if self.view is not None:
            v = np.asarray(self.view, dtype=float)
            if v.shape != (3,) or not np.all(np.isfinite(v)) or not np.linalg.norm(v) > 0:
                raise bad("image.view", self.view, "a finite nonzero 3-vector (the X-rays' direction), or None")
            object.__setattr__(self, "view", tuple(float(c) for c in v / np.linalg.norm(v)))


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


def view_axes(view, points: np.ndarray, axis: np.ndarray, gravity) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The view's unit axes (3,) each: the X-rays' direction, the image's right and up.

    ``view`` (3,) or None (the normal of the best-fit plane of ``points`` (P, 3) [m], along
    ``gravity`` (3,), else along -z); right is the entry's ``axis`` (3,) across the view."""
    if view is None:
        centred = points - points.mean(axis=0)
        n = np.linalg.svd(centred, full_matrices=False)[2][-1]
        g = np.asarray(gravity, dtype=float)
        down = g if np.linalg.norm(g) > 0 else np.array([0.0, 0.0, -1.0])
        n = -n if n @ down < 0 else n
    else:
        n = _unit(np.asarray(view, dtype=float))
    right = axis - (axis @ n) * n
    if np.linalg.norm(right) < 1e-9:  # looking down the entry: any direction across it
        right = np.cross(n, [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0])
    right = _unit(right)
    return n, right, np.cross(-n, right)


@njit(cache=True)
def render_into(out, backgrounds, target, positions, centre, right, up, pixel, half_width, opacity, scratch):
    """out (B, H, W, 1) uint8 <- each rod's image: the background ``backgrounds[target[b]]`` (J, H, W)
    uint8 with rod b's segments (positions (B, n, 3) [m]) drawn over it, seen with the view's
    ``right`` and ``up`` (3,) from ``centre`` (3,) [m] at ``pixel`` [m] per pixel; lines of
    ``half_width`` [pixels], taking ``opacity`` of the light at full cover; a rod with a non-finite
    position is left out. scratch (n, 2): the nodes' (row, column)."""
    B, H, W = out.shape[0], out.shape[1], out.shape[2]
    n = positions.shape[1]
    for b in range(B):
        bg = backgrounds[target[b]]
        for i in range(H):
            for j in range(W):
                out[b, i, j, 0] = bg[i, j]
        finite = True
        for a in range(n):
            u = 0.0
            w = 0.0
            for c in range(3):
                d = positions[b, a, c] - centre[c]
                u += d * right[c]
                w += d * up[c]
            finite = finite and np.isfinite(u) and np.isfinite(w)
            scratch[a, 0] = 0.5 * H - 0.5 - w / pixel
            scratch[a, 1] = u / pixel + 0.5 * W - 0.5
        if not finite:
            continue
        reach = half_width + 1.0
        for a in range(n - 1):
            r0, c0, r1, c1 = scratch[a, 0], scratch[a, 1], scratch[a + 1, 0], scratch[a + 1, 1]
            i0 = max(0, int(math.floor(min(r0, r1) - reach)))
            i1 = min(H - 1, int(math.ceil(max(r0, r1) + reach)))
            j0 = max(0, int(math.floor(min(c0, c1) - reach)))
            j1 = min(W - 1, int(math.ceil(max(c0, c1) + reach)))
            dr, dc = r1 - r0, c1 - c0
            span = dr * dr + dc * dc
            for i in range(i0, i1 + 1):
                for j in range(j0, j1 + 1):
                    t = 0.0 if span <= 0.0 else min(1.0, max(0.0, ((i - r0) * dr + (j - c0) * dc) / span))
                    er, ec = i - r0 - t * dr, j - c0 - t * dc
                    cover = min(1.0, half_width + 0.5 - math.sqrt(er * er + ec * ec))
                    if cover > 0.0:
                        value = bg[i, j] * (1.0 - opacity * cover)
                        if value < out[b, i, j, 0]:
                            out[b, i, j, 0] = np.uint8(value)


class Fluoroscope:
    """The image observation of one vessel and device: its view, its backgrounds and the render.

    Parameters
    ----------
    options : Fluoroscopy
        size, field of view, view axis
    paths : softrnn.envs.track.Paths
        the vessel's branches (centrelines, forks)
    contact : softrnn.geometry.Contact
        the vessel's obstacles (their gaps give the lumen)
    entry_radius, radius : float
        the lumen's radius at the entry and the device's [m]
    goal_depth : float
        how far into the target branch past its fork the goal lies [m]
    gravity : (3,)
        [m/s^2], for the default view

    Attributes
    ----------
    view, right, up : (3,)
        the X-rays' direction and the image's right and up [-]
    centre : (3,)
        the point at the image's centre [m]
    pixel : float
        the pixel's side [m]
    backgrounds : (J, H, W) uint8
        the lumen with the goal of each branch
    """

    def __init__(self, options: Fluoroscopy, paths, contact, entry_radius: float, radius: float,
                 goal_depth: float, gravity):
        points = np.concatenate(paths.lines)
        line = paths.lines[0]
        self.view, self.right, self.up = view_axes(options.view, points, _unit(line[1] - line[0]), gravity)
        first = int(np.argmin(paths.fork))
        self.centre = point_at(paths.lines[first], paths.arc[first], paths.fork[first])
        if options.field is None:
            reach = max(float(np.max(np.abs(self._plane(p[-1:] - self.centre)))) for p in paths.lines)
            side = 2.0 * reach + 4.0 * entry_radius
        else:
            side = options.field
        self.size = options.size
        self.pixel = side / self.size
        self.half_width = max(radius / self.pixel, 0.5 * MIN_WIRE_PIXELS)
        lumen = self._lumen(contact, points, entry_radius)
        goals = [point_at(p, s, f + goal_depth) for p, s, f in zip(paths.lines, paths.arc, paths.fork)]
        self.backgrounds = np.stack([self._goal(lumen, g) for g in goals])
        self._out = np.zeros((0, self.size, self.size, 1), dtype=np.uint8)
        self._scratch = np.zeros((0, 2))

    @property
    def shape(self) -> tuple:
        """The image's shape (H, W, 1)."""
        return (self.size, self.size, 1)

    def _plane(self, d: np.ndarray) -> np.ndarray:
        """Offsets d (P, 3) [m] in the image plane (P, 2) [m]: right, up."""
        return np.stack([d @ self.right, d @ self.up], axis=1)

    def pixels(self, points) -> np.ndarray:
        """The (row, column) (P, 2) [pixels, fractional] of points (P, 3) [m] in the image."""
        uw = self._plane(np.atleast_2d(np.asarray(points, dtype=float)) - self.centre)
        h = 0.5 * self.size - 0.5
        return np.stack([h - uw[:, 1] / self.pixel, h + uw[:, 0] / self.pixel], axis=1)

    def _rays(self) -> np.ndarray:
        """The pixels' centres (H, W, 3) [m] in the plane through ``centre``."""
        k = (np.arange(self.size) + 0.5 - 0.5 * self.size) * self.pixel
        return self.centre + k[None, :, None] * self.right - k[:, None, None] * self.up

    def _lumen(self, contact, points: np.ndarray, entry_radius: float) -> np.ndarray:
        """The lumen's image (H, W) [grey level 0-255]: FIELD exp(-mu chord)."""
        depth = (points - self.centre) @ self.view
        depths = np.linspace(depth.min() - 3 * entry_radius, depth.max() + 3 * entry_radius, DEPTH_SAMPLES)
        rays = self._rays().reshape(-1, 3)
        chord = np.zeros(len(rays))
        for d in depths:
            x = rays + d * self.view
            g = contact.gaps(x, np.full(len(x), 1e-6))  # a thin probe: a zero radius divides by zero
            chord += np.all(np.isfinite(g) & (g > 0), axis=1)
        chord *= depths[1] - depths[0]
        mu = -math.log(1.0 - CONTRAST) / (2.0 * entry_radius)
        return (FIELD * np.exp(-mu * chord)).reshape(self.size, self.size)

    def _goal(self, lumen: np.ndarray, goal: np.ndarray) -> np.ndarray:
        """The background (H, W) uint8: ``lumen`` with the goal dot at ``goal`` (3,) [m]."""
        row, col = self.pixels(goal)[0]
        i, j = np.mgrid[0:self.size, 0:self.size]
        dot = np.hypot(i - row, j - col) <= 1.5
        return np.where(dot, GOAL, np.round(lumen)).astype(np.uint8)

    def render(self, positions: np.ndarray, target: np.ndarray) -> np.ndarray:
        """The images (B, H, W, 1) uint8 of the rods at positions (B, n, 3) [m], each on its target
        branch's background (target (B,) int64); a new array (the render's buffer is reused)."""
        B, n = positions.shape[:2]
        if self._out.shape[0] != B:
            self._out = np.zeros((B,) + self.shape, dtype=np.uint8)
        if self._scratch.shape[0] != n:
            self._scratch = np.zeros((n, 2))
        render_into(self._out, self.backgrounds, np.ascontiguousarray(target, dtype=np.int64),
                    np.ascontiguousarray(positions), self.centre, self.right, self.up, self.pixel, self.half_width,
                    OPACITY, self._scratch)
        return self._out.copy()


def point_at(line: np.ndarray, arc: np.ndarray, s: float) -> np.ndarray:
    """The point (3,) [m] at arc length ``s`` [m] along ``line`` (P, 3) with arc lengths ``arc`` (P,)
    (clipped to its ends)."""
    return np.array([np.interp(s, arc, line[:, c]) for c in range(3)])
