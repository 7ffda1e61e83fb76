"""The magnetic manipulator's physics calibrated to the camera's record: the dynamic
Cosserat model (``softrnn.magnetics``) with the rod's Young's modulus, the magnets' remanence and
the damping scaled by fitted factors, driven by the recorded coil currents, read by the same
camera model without noise, fitted to the measured magnet orientations (and positions, where the
record has them) of the training span (``softrnn.fitting``, the calibration core). The calibrated
model then predicts the test span from the currents alone.

Residuals: per channel (a magnet's orientation component about x or y, or a position component),
model minus measurement, divided by that channel's noise level, estimated from the measurement's
fourth differences (``noise_levels``: the motion is band-limited far below the camera rate, so the
differences hold noise only). The orientation about z is identically zero by the paper's definition
and is left out.
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass

import numpy as np

from ...errors import bad
from ...fitting import FitOptions, Parameter, fit
from ...magnetics.camera import camera_measure
from ...magnetics.manipulator import ManipulatorRun, ManipulatorSpec, resolve_substeps, simulate_manipulator

FACTORS = ("stiffness", "remanence", "damping")
"""The fitted factors, in order: Young's modulus, magnet remanence and damping over the nominal values."""

BOUNDS = {"stiffness": (0.8, 1.25), "remanence": (0.8, 1.25), "damping": (0.25, 4.0)}
"""Search bounds of each factor (the start is 1, the nominal model). A modulus or remanence more than
20 % off its data sheet is a different material; damping is known to a factor of a few at best."""

NOISE_DIFFERENCE = 4
"""Order of the differences ``noise_levels`` estimates the noise from (var of the 4th difference of
white noise = 70 sigma^2)."""


def noise_levels(readings: np.ndarray) -> np.ndarray:
    """Per-channel noise standard deviation (k,) of ``readings`` (T, k), from the fourth differences
    along time: sqrt(mean(d4^2) / 70). Channels without variation get the median level (or 1)."""
    y = np.asarray(readings, dtype=np.float64)
    d = np.diff(y, n=NOISE_DIFFERENCE, axis=0)
    c = math.comb(2 * NOISE_DIFFERENCE, NOISE_DIFFERENCE)                        # 70
    with np.errstate(invalid="ignore"):
        sigma = np.sqrt(np.nanmean(d ** 2, axis=0) / c)
    good = np.isfinite(sigma) & (sigma > 0)
    fill = float(np.median(sigma[good])) if good.any() else 1.0
    return np.where(good, sigma, fill)


def readings(orientations, positions=None) -> np.ndarray:
    """The calibrated quantities (T, k): each magnet's orientation about x and y [rad], then (if
    given) each magnet's position [m]; (T, M, 3) inputs."""
    o = np.asarray(orientations, dtype=np.float64)
    parts = [o[:, :, :2].reshape(o.shape[0], -1)]
    if positions is not None:
        p = np.asarray(positions, dtype=np.float64)
        parts.append(p.reshape(p.shape[0], -1))
    return np.concatenate(parts, axis=1)


@dataclass(frozen=True, eq=False)
class MagneticModel:
    """The calibration's simulator (picklable, for Dask workers): ``model((stiffness, remanence,
    damping))`` runs ``spec.scaled(...)`` from rest after ``settle`` s, driven by ``currents``
    (S, n_c) [A] at t = k dt, with a fixed number of ``substeps`` (stable at the largest stiffness
    in the bounds, so the step does not jump between trials), reads it with the noise-free camera
    model (``points``, ``degree``) and returns ``readings`` (S, k) flattened."""

    spec: ManipulatorSpec
    currents: np.ndarray
    dt: float
    settle: float
    substeps: int
    points: int
    degree: int
    with_positions: bool = True

    def trajectory(self, factors, n_samples: int | None = None, progress=None):
        """The scaled manipulator's run (``ManipulatorTrajectory``) over ``n_samples`` (None: all);
        ``progress`` as for ``simulate_manipulator`` (samples simulated)."""
        stiffness, remanence, damping = (float(f) for f in factors)
        robot = self.spec.scaled(stiffness=stiffness, remanence=remanence, damping=damping)
        S = self.currents.shape[0] if n_samples is None else int(n_samples)
        run = ManipulatorRun(dt=self.dt, n_samples=S, substeps=self.substeps, settle=self.settle)
        return simulate_manipulator(robot, self.currents[:S], run, progress=progress)

    def camera(self, factors, n_samples: int | None = None, progress=None):
        """(orientations (S, M, 3) [rad], positions (S, M, 3) [m]) the noise-free camera reads;
        ``progress`` as for ``simulate_manipulator`` (samples simulated)."""
        traj = self.trajectory(factors, n_samples, progress)
        s_nodes = np.linspace(0.0, self.spec.length, self.spec.n_nodes)
        s_magnets = np.array([m.arc_length for m in self.spec.magnets])
        cam = camera_measure(np.asarray(traj.positions, np.float64), s_nodes, s_magnets, 0.0, None,
                             points=self.points, degree=self.degree)
        return cam.orientations, cam.positions

    def __call__(self, factors) -> np.ndarray:
        o, p = self.camera(factors)
        return readings(o, p if self.with_positions else None).ravel()


def fixed_substeps(spec: ManipulatorSpec, dt: float, settle: float) -> int:
    """Solver steps per sample, stable for every trial (the stiffest rod in ``BOUNDS``)."""
    stiffest = spec.scaled(stiffness=BOUNDS["stiffness"][1])
    return resolve_substeps(stiffest, ManipulatorRun(dt=dt, n_samples=2, settle=settle))


def calibrate_manipulator(currents, orientations, positions=None, *, dt: float, settle: float, points: int,
                          degree: int, spec: ManipulatorSpec | None = None, evaluator=None,
                          options: FitOptions | None = None, progress=None, cache_dir=None):
    """Fit the stiffness, remanence and damping factors of ``spec`` (None: the nominal manipulator)
    to a record of S samples ``dt`` [s] apart: ``currents`` (S, n_c) [A], the measured
    ``orientations`` (S, M, 3) [rad] and, if known, ``positions`` (S, M, 3) [m] of the magnets.
    Returns (``FitResult``, ``MagneticModel`` over the record's span)."""
    spec = ManipulatorSpec() if spec is None else spec
    I = np.asarray(currents, dtype=np.float64)
    o = np.asarray(orientations, dtype=np.float64)
    if I.ndim != 2 or o.ndim != 3 or o.shape[0] != I.shape[0] or o.shape[1:] != (len(spec.magnets), 3):
        raise bad("currents, orientations", (I.shape, o.shape),
                  f"(S, {spec.coils.n_coils}) and (S, {len(spec.magnets)}, 3) for the same S samples")
    y = readings(o, positions)
    sigma = noise_levels(y)
    model = MagneticModel(spec=spec, currents=I, dt=float(dt), settle=float(settle),
                          substeps=fixed_substeps(spec, dt, settle), points=int(points), degree=int(degree),
                          with_positions=positions is not None)
    params = [Parameter(name, 1.0, *BOUNDS[name]) for name in FACTORS]
    weights = np.broadcast_to(1.0 / sigma, y.shape)
    fingerprint = hashlib.sha256(b"".join(np.ascontiguousarray(a).tobytes() for a in (I, y))
                                 + repr((dt, settle, points, degree, repr(spec))).encode()).hexdigest()
    result = fit(model, y.ravel(), params, weights=weights.ravel(), evaluator=evaluator, options=options,
                 progress=progress, cache_dir=cache_dir, fingerprint=fingerprint)
    return result, model
