"""Model-predictive control on the dynamic simulator itself: ``PhysicsMPC``, the reference for what a
perfect model structure gives (``mpc-physics``).

The same planner as ``mpc.LearnedMPC`` (``mpc.BlockMPC``: the field direction in blocks over the
horizon, the same cost and weights, one Gauss-Newton step per frame from the shifted last plan), but
each rollout is the geometrically exact dynamic rod of ``softrnn.magnetics`` with the *nominal*
parameters (or whatever ``spec`` it is given, e.g. a calibrated one), read by the noise-free camera
model:

1. **Estimate.** A copy of the nominal simulator runs beside the plant, driven by the currents the
   controller applies (an open-loop state estimate: the camera sees the magnets' orientations only,
   not the rod's velocities). What the model cannot explain, the measured distal orientation minus
   the model's, is learned by a slow integral term (``disturbance_gain``) and added to every
   prediction (offset-free MPC).
2. **Plan.** Every rollout starts from a snapshot of that simulator. The base plan's rollout runs
   every frame; the Jacobian (one rollout per plan variable, forward differences) is refreshed
   every ``refresh`` frames and kept in between (a frozen-Jacobian Gauss-Newton step): a rollout
   of the 7-frame horizon costs about 7 x 22 ms of simulation on one core, at the 3 us solver step
   the magnets' stiffness needs.
3. **Apply** the first block's field, as the learned MPC does.

It is far from real time (about 0.1 to 1 s per frame); ``softrnn reproduce`` runs it on shorter
spans than the other controllers and compares them over the same frames.
"""

from __future__ import annotations

import numpy as np

from ..magnetics.camera import camera_measure
from ..magnetics.manipulator import ManipulatorSpec
from ..magnetics.stepper import ManipulatorStepper
from .mpc import BlockMPC
from .static_inverse import DISTAL, StaticInverse


class PhysicsMPC(BlockMPC):
    """MPC on the nominal dynamic simulator (see the module docstring).

    spec : the model the controller plans with (None: the nominal ``ManipulatorSpec()``)
    rate : the loop's frame rate [Hz]
    refresh : frames between two Jacobian refreshes (1: every frame)
    camera_points, polynomial_degree : the camera model (as ``loop.LoopConfig``), noise-free
    The other parameters are ``mpc.BlockMPC``'s, with the learned MPC's defaults.
    """

    def __init__(self, spec: ManipulatorSpec | None = None, *, rate: float = 30.0, horizon: int = 7,
                 blocks: tuple = (1, 2, 4), iterations: int = 1, move_weight: float = 0.2,
                 azimuth_weight: float = 10.0, disturbance_gain: float = 0.1, diff_step: float = 1e-4,
                 refresh: int = 10, camera_points: int = 100, polynomial_degree: int = 3, settle: float = 0.5):
        super().__init__(spec, horizon=horizon, blocks=blocks, iterations=iterations, move_weight=move_weight,
                         azimuth_weight=azimuth_weight, disturbance_gain=disturbance_gain, diff_step=diff_step)
        self.rate, self.refresh, self.settle = float(rate), max(1, int(refresh)), float(settle)
        self.camera_points, self.degree = int(camera_points), int(polynomial_degree)
        self.s_nodes = np.linspace(0.0, self.spec.length, self.spec.n_nodes)
        self.s_magnets = np.array([m.arc_length for m in self.spec.magnets])
        self._rng = np.random.default_rng(0)             # the camera's, unused without noise
        self.rollouts = 0

    def _distal(self, positions: np.ndarray) -> np.ndarray:
        """The noise-free camera's distal orientation (about x, about y) [rad] of node positions (n, 3)."""
        cam = camera_measure(positions[None], self.s_nodes, self.s_magnets, 0.0, self._rng,
                             points=self.camera_points, degree=self.degree)
        return cam.orientations[0, DISTAL, :2]

    def reset(self, reference) -> np.ndarray:
        """Start from the field the nominal static model needs for the first target; the simulator
        settles under it, as the plant does."""
        currents = self._start(StaticInverse(self.spec).solve(reference.angles[0]))
        self.sim = ManipulatorStepper(self.spec, 1.0 / self.rate, currents, settle=self.settle)
        self.disturbance = np.zeros(2)
        self.J, self.age = None, 0
        return currents

    def _predict(self, plans: np.ndarray) -> np.ndarray:
        snap = self.sim.snapshot()
        out = np.empty((plans.shape[0], self.horizon, 2))
        for b, plan in enumerate(plans.reshape(plans.shape[0], self.blocks, 2)):
            self.sim.restore(snap)
            currents = [self._currents(angles) for angles in plan]
            for i, j in enumerate(self.block_of):
                self.sim.step(currents[j])
                out[b, i] = self._distal(self.sim.positions)
            self.rollouts += 1
        self.sim.restore(snap)
        return out + self.disturbance

    def _linearise(self, x: np.ndarray, targets: np.ndarray) -> tuple:
        """Forward differences every ``refresh`` frames; in between, the base rollout and the kept J."""
        if self.J is None or self.age >= self.refresh:
            r, self.J = super()._linearise(x, targets)
            self.age = 0
            return r, self.J
        return self._residuals(x[None], targets)[0], self.J

    def __call__(self, k: int, measured, reference) -> np.ndarray:
        """The currents (n_c,) [A] for frame k, from its measurement ``measured`` (M, 3) [rad]."""
        y = np.asarray(measured, float)[DISTAL, :2]
        if np.all(np.isfinite(y)):
            self.disturbance += self.disturbance_gain * (y - self._distal(self.sim.positions) - self.disturbance)
            x = self._solve(reference.window(k, self.horizon))
            self.age += 1
            self.currents = self._currents(x[:2])
        else:
            self.held += 1
        self.sim.step(self.currents)                       # the estimate follows what the plant is given
        return self.currents
