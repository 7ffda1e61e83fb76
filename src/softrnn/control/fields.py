"""The field the controllers command: a fixed magnitude along a chosen direction at the workspace
centre, made by the minimum-norm coil currents."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..magnetics.coils import unit_field_maps
from ..magnetics.manipulator import ManipulatorSpec

A_RANGE = (-math.pi / 2, math.pi / 2)
"""The field's elevation a [rad] the controllers command: [-90, 90] deg."""
C_RANGE = (-math.pi / 6, math.pi / 6)
"""The field's azimuth c [rad] the controllers command: [-30, 30] deg."""


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


@dataclass(frozen=True, eq=False)
class FieldCommand:
    """The field a controller commands on a manipulator: ``magnitude`` B0 [T] (``field_magnitude``)
    along the direction of elevation a and azimuth c, made by the minimum-norm currents ``P`` (n_c, 3)
    [A/T] (``field_to_currents``)."""

    P: np.ndarray
    magnitude: float

    @classmethod
    def of(cls, spec: ManipulatorSpec) -> FieldCommand:
        """The command of ``spec``'s coils: the largest magnitude that keeps every direction within
        95 % of the coil limit (at most 20 mT)."""
        P = field_to_currents(spec)
        return cls(P=P, magnitude=field_magnitude(P, spec.coils.current_limit))

    def currents(self, angles) -> np.ndarray:
        """The currents (n_c,) [A] of the field along ``angles`` (a, c) [rad]."""
        return self.P @ (self.magnitude * field_direction(angles[0], angles[1]))
