"""Model-predictive control on the dynamic simulator itself: ``PhysicsPredictor``, the reference for
what a perfect model structure gives (``mpc-physics``).

The same planner as ``mpc-learned`` (``mpc.BlockMPC``: the field direction in blocks over the
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
   every ``PHYSICS_OPTIONS.refresh`` frames and kept in between (a frozen-Jacobian Gauss-Newton
   step): each rollout steps the simulator over the whole horizon at the small solver step the
   magnets' stiffness needs.
3. **Apply** the first block's field, as the learned MPC does.

It is far from real time; ``softrnn reproduce`` runs it on shorter spans than the other controllers
and compares them over the same frames.
"""

from __future__ import annotations

import numpy as np

from ..errors import bad, is_finite_number
from ..magnetics.camera import camera_measure
from ..magnetics.manipulator import ManipulatorSpec
from ..magnetics.stepper import ManipulatorStepper
from .fields import FieldCommand
from .loop import LoopConfig
from .mpc import MPCOptions
from .predictors import DISTURBANCE_GAIN
from .static_inverse import DISTAL, StaticInverse

PHYSICS_OPTIONS = MPCOptions(refresh=10)
"""The planner's options for ``mpc-physics``: the learned MPC's, with the Jacobian refreshed every
10 frames (each refresh costs one rollout of the simulator per plan variable)."""


class PhysicsPredictor:
    """The nominal dynamic simulator as the MPC's ``predictors.Predictor`` (see the module docstring).

    Parameters
    ----------
    spec : ManipulatorSpec or None
        the model the controller plans with (None: the nominal ``ManipulatorSpec()``)
    config : LoopConfig or None
        the loop's frame rate, camera model (noise-free here) and settling time (None: ``LoopConfig()``)
    disturbance_gain : float
        gain of the integral term that learns the offset of the measured distal
        orientation from the simulator's
    """

    history = 1

    def __init__(self, spec: ManipulatorSpec | None = None, config: LoopConfig | None = None, *,
                 disturbance_gain: float = DISTURBANCE_GAIN):
        config = LoopConfig() if config is None else config
        if not is_finite_number(disturbance_gain) or not 0.0 <= disturbance_gain <= 1.0:
            raise bad("disturbance_gain", disturbance_gain, "a gain in [0, 1]")
        self.spec = ManipulatorSpec() if spec is None else spec
        self.command = FieldCommand.of(self.spec)
        self.rate, self.settle = float(config.rate), float(config.settle)
        self.camera_points, self.degree = int(config.camera_points), int(config.polynomial_degree)
        self.disturbance_gain = float(disturbance_gain)
        self.s_nodes = np.linspace(0.0, self.spec.length, self.spec.n_nodes)
        self.s_magnets = np.array([m.arc_length for m in self.spec.magnets])
        self._rng = np.random.default_rng(0)             # the camera's, unused without noise
        self.sim = None                                  # the simulator beside the plant, from ``reset``
        self.disturbance = np.zeros(2)
        self.rollouts = 0

    def _distal(self, positions: np.ndarray) -> np.ndarray:
        """The noise-free camera's distal orientation (about x, about y) [rad] of node positions (n, 3)."""
        cam = camera_measure(positions[None], self.s_nodes, self.s_magnets, 0.0, self._rng,
                             points=self.camera_points, degree=self.degree)
        return cam.orientations[0, DISTAL, :2]

    def start(self, target) -> np.ndarray:
        """The field angles the nominal static model needs for ``target`` (``StaticInverse``)."""
        return StaticInverse(self.spec).solve(target)

    def reset(self, applied, currents) -> None:
        """The simulator settles under ``currents``, as the plant does; the offset is forgotten."""
        self.sim = ManipulatorStepper(self.spec, 1.0 / self.rate, currents, settle=self.settle)
        self.disturbance = np.zeros(2)

    def observe(self, measured) -> bool:
        """Integrate the measured distal orientation minus the simulator's; False for a NaN."""
        y = np.asarray(measured, float)[DISTAL, :2]
        if not np.all(np.isfinite(y)):
            return False
        self.disturbance += self.disturbance_gain * (y - self._distal(self.sim.positions) - self.disturbance)
        return True

    def predict(self, plans: np.ndarray, block_of: np.ndarray) -> np.ndarray:
        """One rollout of the simulator per plan from a snapshot of its state, plus the learned offset."""
        snap = self.sim.snapshot()
        out = np.empty((plans.shape[0], block_of.size, 2))
        for b, plan in enumerate(plans):
            self.sim.restore(snap)
            currents = [self.command.currents(angles) for angles in plan]
            for i, j in enumerate(block_of):
                self.sim.step(currents[j])
                out[b, i] = self._distal(self.sim.positions)
            self.rollouts += 1
        self.sim.restore(snap)
        return out + self.disturbance

    def advance(self, applied, currents) -> None:
        """The simulator follows what the plant is given."""
        self.sim.step(currents)

    def hold(self, currents) -> None:
        """The simulator follows what the plant is given, measured or not."""
        self.sim.step(currents)
