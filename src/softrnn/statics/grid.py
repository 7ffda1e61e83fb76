"""The static solver's RK4 grid: every load point, magnet, tendon end and stiffness change on a grid
point, the steps spread over the intervals by weight (guide: docs/guide/statics.md)."""

import heapq
from dataclasses import dataclass

import numpy as np

from ..errors import bad
from .rod import StaticRod

_SNAP = 1e-9  # load points closer than this fraction of L share one grid point


@dataclass(frozen=True, eq=False)
class Grid:
    """RK4 grid: s (N + 1,) [m] with every load point and stiffness change on a grid point;
    h (N,) [m], kinv (N, 6) compliances and weight (N,) [kg/m] per step (see ``kernels``)."""

    s: np.ndarray
    h: np.ndarray
    kinv: np.ndarray
    weight: np.ndarray

    def index(self, s: float) -> int:
        """Grid point of the arc length s (a load point of this grid)."""
        return int(np.argmin(np.abs(self.s - s)))


def _breakpoints(rod: StaticRod, load_points) -> list[float]:
    L = rod.length
    points = [0.0, L] + [m.s for m in rod.magnets] + [p for seg in rod.rigid_segments for p in (seg.s0, seg.s1)]
    points += [rod.tendon_end(td) for td in rod.tendons]
    points += list(load_points)
    merged = []
    for p in sorted(points):
        if not merged or p - merged[-1] > _SNAP * L:
            merged.append(p)
    merged[-1] = L
    return merged


def _interval_properties(rod: StaticRod, a: float, b: float) -> tuple[np.ndarray, float, float]:
    """Compliances (6,), mass per length [kg/m] and bending stiffness EI of the interval (a, b)."""
    mid = 0.5 * (a + b)
    seg = next((g for g in rod.rigid_segments if g.s0 <= mid <= g.s1), None)
    k = rod.stiffness() if seg is None else rod.segment_stiffness(seg)
    weight = rod.weight_per_length if seg is None else k.weight
    kinv = np.array([1 / k.EI, 1 / k.EI, 1 / k.GJ, 1 / k.GA, 1 / k.GA, 1 / k.EA])
    if not rod.extensible_shearable:
        kinv[3:] = 0.0
    return kinv, weight, k.EI


def _allocate_steps(weights: list[float], n_steps: int) -> list[int]:
    """Steps per interval: one each, then greedily to the interval with the largest weight per
    step (RK4's error per step grows like h^4 / EI, so the weight is length * EI^(-1/4))."""
    counts = [1] * len(weights)
    heap = [(-w, i) for i, w in enumerate(weights)]
    heapq.heapify(heap)
    for _ in range(n_steps - len(weights)):
        _, i = heapq.heappop(heap)
        counts[i] += 1
        heapq.heappush(heap, (-weights[i] / counts[i], i))
    return counts


def build_grid(rod: StaticRod, load_points, n_steps: int) -> Grid:
    """The RK4 grid of ``n_steps`` steps over [0, L] with the magnets, the ends of the rigid
    segments, the tendons' terminations and ``load_points`` (arc lengths [m]) on grid points."""
    points = _breakpoints(rod, load_points)
    n_int = len(points) - 1
    if n_steps < n_int:
        raise bad("n_steps", n_steps, f"at least {n_int}: one RK4 step per interval between the load points, "
                                      f"stiffness changes and ends at s = {[round(p, 9) for p in points]} m")
    props = [_interval_properties(rod, a, b) for a, b in zip(points, points[1:])]
    EI = rod.stiffness().EI
    weights = [(b - a) * (EI / ei) ** 0.25 for (a, b), (_, _, ei) in zip(zip(points, points[1:]), props)]
    counts = _allocate_steps(weights, n_steps)
    s = [0.0]
    kinv, weight = [], []
    for (a, b), (ki, wi, _), c in zip(zip(points, points[1:]), props, counts):
        s.extend(a + (b - a) * np.arange(1, c + 1) / c)
        kinv.extend([ki] * c)
        weight.extend([wi] * c)
    s = np.array(s)
    s[-1] = rod.length
    return Grid(s=s, h=np.diff(s), kinv=np.array(kinv), weight=np.array(weight))
