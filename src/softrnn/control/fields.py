"""The field the controllers command: a fixed magnitude along a chosen direction at the workspace
centre, made by the minimum-norm coil currents."""

from __future__ import annotations

import numpy as np

from ..magnetics.coils import unit_field_maps
from ..magnetics.manipulator import ManipulatorSpec


def field_direction(a, c) -> np.ndarray:
    """Unit field directions (..., 3) for elevation a and azimuth c [rad] (arrays of one shape):
    (cos a cos c, sin c, sin a cos c); a = c = 0 is along the rod (+x)."""
    a = np.asarray(a, float)
    c = np.asarray(c, float)
    return np.stack([np.cos(a) * np.cos(c), np.sin(c), np.sin(a) * np.cos(c)], -1)


def field_to_currents(spec: ManipulatorSpec) -> np.ndarray:
    """P (n_c, 3) [A/T]: the minimum-norm currents P b that make the field b [T] at the workspace centre."""
    beta, _ = unit_field_maps(spec.coils, np.zeros(3))
    return np.linalg.pinv(beta)


def field_magnitude(P: np.ndarray, limit: float, cap: float = 0.02) -> float:
    """The largest field magnitude B0 [T] (at most ``cap``) whose minimum-norm currents P b stay within
    95 % of the coil ``limit`` [A] for every direction of elevation in [-90, 90] deg and azimuth in
    [-30, 30] deg (a fine grid of them)."""
    a, c = np.meshgrid(np.radians(np.linspace(-90, 90, 181)), np.radians(np.linspace(-30, 30, 61)), indexing="ij")
    unit = field_direction(a, c).reshape(-1, 3)
    peak = float(np.max(np.abs(unit @ P.T)))
    return min(cap, 0.95 * limit / peak)
