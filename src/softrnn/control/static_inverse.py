"""``StaticInverse`` is the conventional approach: the nominal static Cosserat model inverted for the
field that holds the target. The currents are the minimum-norm ones for a field b of fixed
magnitude at the workspace centre, b = B0 (cos a cos c, sin c, sin a cos c); the static model's
distal orientation over a grid of the field's elevation a and azimuth c is computed once
(``softrnn.magnetics.static``), and each frame a few Gauss-Newton steps on its cubic
spline find the (a, c) whose predicted orientation is the target (warm-started from the last
frame; clipped to the grid). It is feedforward: the measurement is not used, so the robot's
perturbation and dynamics show up as tracking error.
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import RectBivariateSpline

from ..errors import SimulationError, bad
from ..magnetics.manipulator import ManipulatorSpec
from ..magnetics.static import static_predictions
from .fields import field_direction, field_magnitude, field_to_currents

DISTAL = 1
"""Index of the distal magnet (the tracked one) in the camera's (M, 3) orientations."""


class StaticInverse:
    """The nominal static model inverted (see the module docstring).

    Parameters
    ----------
    spec : ManipulatorSpec or None
        the nominal manipulator (None: ``ManipulatorSpec()``)
    field : float or None
        field magnitude B0 [T] (None: the largest that keeps every direction of the grid within
        95 % of the coil limit, at most 20 mT)
    elevations, azimuths : int
        grid sizes over a in [-90, 90] deg and c in [-30, 30] deg
    """

    def __init__(self, spec: ManipulatorSpec | None = None, *, field: float | None = None, elevations: int = 37,
                 azimuths: int = 7):
        self.spec = ManipulatorSpec() if spec is None else spec
        self.P = field_to_currents(self.spec)
        self.a = np.radians(np.linspace(-90.0, 90.0, int(elevations)))
        self.c = np.radians(np.linspace(-30.0, 30.0, int(azimuths)))
        A, C = np.meshgrid(self.a, self.c, indexing="ij")
        unit = field_direction(A, C).reshape(-1, 3)
        peak = float(np.max(np.abs(unit @ self.P.T)))
        limit = self.spec.coils.current_limit
        self.field = field_magnitude(self.P, limit) if field is None else float(field)
        if not (0 < self.field and self.field * peak <= limit):
            raise bad("field", field, f"a field magnitude in (0, {limit / peak:.4g}] T (within the coil limit)")
        pred = static_predictions(self.field * unit @ self.P.T, spec=self.spec, max_failures=0.5)
        theta = pred.orientations[:, DISTAL, :2].reshape(A.shape + (2,))          # (na, nc, 2) [rad]
        keep = _solved_range(np.all(np.isfinite(theta), axis=(1, 2)))
        self.a = self.a[keep]
        theta = theta[keep]
        self.splines = [RectBivariateSpline(self.a, self.c, theta[..., i], kx=3, ky=3) for i in range(2)]
        self.table_failures = len(pred.failures)
        self.x = np.zeros(2)
        self.currents = np.zeros(self.P.shape[0])
        self.held = 0

    def _orientation(self, x) -> tuple:
        """(theta (2,) [rad] about x and y, d theta / d (a, c) (2, 2)) from the splines."""
        a, c = x
        th = np.array([float(s.ev(a, c)) for s in self.splines])
        J = np.array([[float(s.ev(a, c, dx=1)), float(s.ev(a, c, dy=1))] for s in self.splines])
        return th, J

    def _currents(self, x) -> np.ndarray:
        return self.P @ (self.field * field_direction(*x))

    def solve(self, target) -> np.ndarray:
        """The field angles (a, c) [rad] whose static orientation is ``target`` (about x, about y) [rad]."""
        x = self.x.copy()
        lo = np.array([self.a[0], self.c[0]])
        hi = np.array([self.a[-1], self.c[-1]])
        for _ in range(6):
            th, J = self._orientation(x)
            step, *_ = np.linalg.lstsq(J, np.asarray(target) - th, rcond=1e-6)
            x = np.clip(x + step, lo, hi)
            if np.max(np.abs(step)) < 1e-7:
                break
        return x

    def reset(self, reference) -> np.ndarray:
        """Before the first frame: the currents (n_c,) [A] for the reference's first target."""
        self.x = self.solve(reference.angles[0])
        self.currents = self._currents(self.x)
        self.held = 0
        return self.currents

    def __call__(self, k: int, measured, reference) -> np.ndarray:
        """The currents (n_c,) [A] for frame k + 1's target (``measured`` is not used)."""
        self.x = self.solve(reference.window(k, 1)[0])
        self.currents = self._currents(self.x)
        return self.currents


def _solved_range(ok: np.ndarray) -> slice:
    """The longest run of consecutive True in ``ok`` (elevations where the static model solved every
    azimuth) as a slice: where it fails, the planar pose is no static solution, and the controller
    never commands a field there."""
    best, start = (0, 0), None
    for i, v in enumerate(list(ok) + [False]):
        if v and start is None:
            start = i
        elif not v and start is not None:
            if i - start > best[1] - best[0]:
                best = (start, i)
            start = None
    if best[1] - best[0] < 4:
        raise SimulationError("the static model failed on most field directions; lower the field")
    return slice(*best)
