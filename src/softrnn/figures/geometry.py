"""The geometry of a rod picture: the view (a flat plane or 3-D), the bounds of the fixed axes, the
force arrows' scale and their 3-D strokes, and the nodes that never move."""

from __future__ import annotations

import math

import numpy as np

from ..errors import SoftrnnInputError

VIEWS = ("auto", "xy", "xz", "yz", "3d")
_PLANES = {"xy": (0, 1), "xz": (0, 2), "yz": (1, 2)}
_FLAT = 0.01  # an axis whose range is below 1 % of the largest range counts as flat
_ARROW = 0.2  # the largest force is drawn about this fraction of the motion's extent


def _nice(x: float) -> float:
    """The largest 1, 2 or 5 x 10^k not above x (x > 0)."""
    k = math.floor(math.log10(x))
    for m in (5, 2, 1):
        if m * 10.0**k <= x * (1 + 1e-9):
            return m * 10.0**k
    return 10.0**k


def _fmt(x: float) -> str:
    """``x`` to 3 significant digits."""
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
