"""The closed loop: the simulated magnetic robot (the experiment's perturbed dynamic model, stepped
frame by frame: ``softrnn.magnetics.stepper``), measured by the camera model with its noise at the
frame rate, and a controller that sets the coil currents each frame (``controllers``).

``run_loop(controller, reference, config)`` returns a ``LoopResult``: the frames' times, the
measured and the true (noise-free) orientations of both magnets, the currents, the controller's
computation time per frame, and the tracking errors of the distal magnet against the reference;
``LoopResult.summary()`` its figures (``LoopSummary``).
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass

import numpy as np

from ..errors import bad, is_finite_number
from ..magnetics.camera import camera_measure
from ..magnetics.manipulator import ManipulatorSpec
from ..magnetics.plant import PLANT
from ..magnetics.stepper import ManipulatorStepper
from ..progress import Progress
from .static_inverse import DISTAL


@dataclass(frozen=True, kw_only=True)
class LoopConfig:
    """The plant and camera of the closed loop (defaults: the magnetic experiment's,
    ``softrnn.magnetics.plant.PLANT``).

    Attributes
    ----------
    rate : float
        camera frame rate and control rate [Hz]
    stiffness, remanence, damping : float
        the plant's factors over the nominal values (the experiment's
        'real robot': 1.04, 0.97, 2.0); ``robustness`` runs multiply stiffness and remanence further
    camera_noise, camera_points, polynomial_degree : float, int, int
        the camera model (``ExperimentConfig``): noise standard deviation [m], centreline points,
        degree of the fitted polynomial
    settle : float
        settling time [s] under the first currents before t = 0
    seed : int
        seeds the camera noise
    """

    rate: float = PLANT.rate
    stiffness: float = PLANT.stiffness
    remanence: float = PLANT.remanence
    damping: float = PLANT.damping
    camera_noise: float = PLANT.camera_noise
    camera_points: int = PLANT.camera_points
    polynomial_degree: int = PLANT.polynomial_degree
    settle: float = PLANT.settle
    seed: int = 0

    def __post_init__(self):
        for name in ("rate", "stiffness", "remanence", "damping"):
            v = getattr(self, name)
            if not is_finite_number(v) or v <= 0:
                raise bad(name, v, "a positive number")
        if not is_finite_number(self.camera_noise) or self.camera_noise < 0:
            raise bad("camera_noise", self.camera_noise, "a noise level >= 0 in m")

    def plant_spec(self, nominal: ManipulatorSpec | None = None) -> ManipulatorSpec:
        """The plant: ``nominal`` (None: ``ManipulatorSpec()``) scaled by the three factors."""
        nominal = ManipulatorSpec() if nominal is None else nominal
        return nominal.scaled(stiffness=self.stiffness, remanence=self.remanence, damping=self.damping)

    def to_dict(self) -> dict:
        """JSON-ready fields (``LoopConfig(**d)`` rebuilds it)."""
        return asdict(self)


@dataclass(frozen=True)
class LoopSummary:
    """The figures of a closed-loop run (``LoopResult.summary``); the tracking errors are those of the
    true (noise-free) distal orientation against the reference, None when not finite.

    Attributes
    ----------
    rms_deg, max_deg : float or None
        over both angles [deg]
    rms_deg_about, max_deg_about : dict
        {"x": ..., "y": ...} per angle [deg]
    measured_rms_deg : float
        the RMS error of the measured orientation [deg] (frames the camera lost left out)
    limit_violations, held_frames : int
        ``LoopResult``'s counts
    compute_ms_median, compute_ms_p99 : float
        the controller's CPU time per frame [ms]
    wall_ms_median, wall_ms_p99 : float
        its wall time per frame [ms]
    stable : bool
        every true error finite and below the bound
    frames : int
        frames of the run (K + 1)
    """

    rms_deg: float | None
    max_deg: float | None
    rms_deg_about: dict
    max_deg_about: dict
    measured_rms_deg: float
    limit_violations: int
    held_frames: int
    compute_ms_median: float
    compute_ms_p99: float
    wall_ms_median: float
    wall_ms_p99: float
    stable: bool
    frames: int

    def to_dict(self) -> dict:
        """JSON-ready fields, in the order above."""
        return asdict(self)


@dataclass(frozen=True, eq=False)
class LoopResult:
    """A closed-loop run of K + 1 frames (M magnets, n_c coils).

    time (K+1,) [s]; reference (K+1, 2) [rad] (about x, about y, distal magnet); measured and true
    (K+1, M, 3) [rad] orientations (camera with noise, and without); currents (K+1, n_c) [A] (row k
    applied over frame k to k+1; the last row repeats); compute_s (K,) the controller's computation
    per frame, as the CPU time of the thread that runs it (what it costs on one core, whatever else
    the machine runs); wall_s (K,) the same calls' wall time; positions (K+1, n, 3) [m] every node;
    limit_violations: frames whose currents the controller returned beyond the limit (clipped before
    they reached the coils); held: frames the controller held its last currents.
    """

    time: np.ndarray
    reference: np.ndarray
    measured: np.ndarray
    true: np.ndarray
    currents: np.ndarray
    compute_s: np.ndarray
    wall_s: np.ndarray
    positions: np.ndarray
    limit_violations: int
    held: int

    def errors_deg(self, which: str = "measured") -> np.ndarray:
        """(K+1, 2) [deg] distal orientation minus the reference, about x and about y."""
        got = (self.measured if which == "measured" else self.true)[:, DISTAL, :2]
        return np.degrees(got - self.reference)

    def summary(self, bound_deg: float = 45.0) -> LoopSummary:
        """The run's figures (``LoopSummary``): stable when every true error is below ``bound_deg``
        and finite."""
        e = self.errors_deg("true")
        m = self.errors_deg("measured")
        finite = bool(np.all(np.isfinite(e)))
        ms = 1e3 * self.compute_s
        return LoopSummary(
            rms_deg=float(np.sqrt(np.mean(e ** 2))) if finite else None,
            max_deg=float(np.max(np.abs(e))) if finite else None,
            rms_deg_about={axis: float(np.sqrt(np.mean(e[:, i] ** 2))) if finite else None
                           for i, axis in enumerate("xy")},
            max_deg_about={axis: float(np.max(np.abs(e[:, i]))) if finite else None for i, axis in enumerate("xy")},
            measured_rms_deg=float(np.sqrt(np.nanmean(m ** 2))),
            limit_violations=int(self.limit_violations), held_frames=int(self.held),
            compute_ms_median=float(np.median(ms)), compute_ms_p99=float(np.percentile(ms, 99)),
            wall_ms_median=float(np.median(1e3 * self.wall_s)),
            wall_ms_p99=float(np.percentile(1e3 * self.wall_s, 99)),
            stable=finite and float(np.max(np.abs(e))) < bound_deg,
            frames=int(self.time.size),
        )


def run_loop(controller, reference, config: LoopConfig | None = None, *, nominal: ManipulatorSpec | None = None,
             progress: Progress | None = None) -> LoopResult:
    """Close the loop over the reference's frames (see the module docstring)."""
    config = LoopConfig() if config is None else config
    nominal = ManipulatorSpec() if nominal is None else nominal
    if abs(1.0 / config.rate - (reference.times[1] - reference.times[0])) > 1e-9:
        raise bad("reference", f"frames {reference.times[1] - reference.times[0]:.6g} s apart",
                  f"a reference at the loop's rate {config.rate:g} Hz")
    spec = config.plant_spec(nominal)
    limit = spec.coils.current_limit
    rng = np.random.default_rng([config.seed, 0x6C6F6F70])
    s_nodes = np.linspace(0.0, spec.length, spec.n_nodes)
    s_magnets = np.array([m.arc_length for m in spec.magnets])

    def camera(X, noise):
        cam = camera_measure(X[None], s_nodes, s_magnets, noise, rng, points=config.camera_points,
                             degree=config.polynomial_degree)
        return cam.orientations[0]

    K = reference.times.size - 1
    I0 = np.clip(np.asarray(controller.reset(reference), float), -limit, limit)
    plant = ManipulatorStepper(spec, 1.0 / config.rate, I0, settle=config.settle)
    M, n_c = len(spec.magnets), spec.coils.n_coils
    measured, true = np.zeros((K + 1, M, 3)), np.zeros((K + 1, M, 3))
    currents, positions = np.zeros((K + 1, n_c)), np.zeros((K + 1, spec.n_nodes, 3))
    compute, wall = np.zeros(K), np.zeros(K)
    violations = 0
    for k in range(K + 1):
        X = plant.positions
        positions[k] = X
        true[k] = camera(X, 0.0)
        measured[k] = camera(X, config.camera_noise)
        if k == K:
            currents[k] = currents[k - 1] if k else I0
            break
        t0, c0 = time.perf_counter(), time.thread_time()
        I = np.asarray(controller(k, measured[k], reference), dtype=np.float64)
        compute[k], wall[k] = time.thread_time() - c0, time.perf_counter() - t0
        if I.shape != (n_c,) or not np.all(np.isfinite(I)):
            raise bad("controller output", I, f"({n_c},) finite currents in A")
        if np.max(np.abs(I)) > limit * (1 + 1e-12):
            violations += 1
            I = np.clip(I, -limit, limit)
        currents[k] = I
        plant.step(I)
        if progress is not None and (k % 30 == 0 or k == K - 1):
            progress(k + 1, K)
    return LoopResult(time=reference.times.copy(), reference=reference.angles[:, :].copy(), measured=measured,
                      true=true, currents=currents, compute_s=compute, wall_s=wall, positions=positions,
                      limit_violations=violations, held=int(getattr(controller, "held", 0)))
