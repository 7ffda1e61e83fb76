"""Model-predictive control of the magnetic rod on the learned NARX model (``model``): ``LearnedMPC``.

Every frame, from the camera's measurement:

1. **Estimate.** The model's one-frame prediction and the measurement are blended (a fixed-gain
   observer, ``observer_gain``: the camera's noise is large at the distal magnet, about 1 deg), and
   a slow integral term (``disturbance_gain``) learns the model's remaining offset on the distal
   magnet, so a constant model error does not become a constant tracking error.
2. **Plan.** The field direction (elevation a, azimuth c; fixed magnitude) over a horizon of
   ``horizon`` frames (7) is held in ``blocks`` (lengths 1, 2, 4 frames by default: the rod answers
   a new field within a frame or two, so the first move must be free to change at the very frame a
   step of the reference comes; 2 x 3 unknowns). One Gauss-Newton step per frame (``iterations``;
   the "real-time iteration" of nonlinear MPC: the plan is refined frame after frame, not solved
   to the end every frame) minimises sum over the horizon |distal orientation - reference|^2 +
   ``move_weight`` times the squared changes of (a, c) from block to block (and from the last
   applied one), those of the azimuth c ``azimuth_weight`` times more (the out-of-plane angle is
   read from the camera with its largest noise, and a planar target needs c = 0); the Jacobian by
   forward differences: the 2 x blocks + 1 rollouts run as one batch of the NumPy network. The
   plan starts from the last one, shifted by a frame; the angles stay within the static
   controller's grid. (``BlockMPC`` holds this part; ``physics_mpc.PhysicsMPC`` plans the same
   way on the simulator.)
3. **Apply** the first block's direction: the minimum-norm currents for that field at the
   workspace centre, within the coil limit by construction (the magnitude is chosen so that every
   direction is).

A measurement with a NaN (the camera lost the rod) is not used: the last currents are held and
the frame counted (``held``).
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import bad
from ..magnetics.manipulator import ManipulatorSpec
from .fields import field_direction, field_magnitude, field_to_currents
from .model import HISTORY, NarxModel, state_of

A_RANGE = (-math.pi / 2, math.pi / 2)
C_RANGE = (-math.pi / 6, math.pi / 6)


class BlockMPC:
    """What the learned and the physics MPC share: the plan of field directions in blocks, the
    cost, one Gauss-Newton step per frame on it, and the currents of the first block.

    A subclass gives ``_predict(plans (B, 2 blocks)) -> (B, N, 2)``: the distal magnet's orientation
    [rad] over the horizon under each plan, from the current estimate of the state, offset by the
    estimated disturbance.
    """

    def __init__(self, spec: ManipulatorSpec | None, *, horizon: int, blocks: tuple, iterations: int,
                 move_weight: float, azimuth_weight: float, disturbance_gain: float, diff_step: float):
        self.spec = ManipulatorSpec() if spec is None else spec
        self.P = field_to_currents(self.spec)
        self.field = field_magnitude(self.P, self.spec.coils.current_limit)
        sizes = [int(b) for b in blocks]
        if any(b < 1 for b in sizes) or sum(sizes) != int(horizon):
            raise bad("blocks", blocks, f"block lengths >= 1 that add up to the horizon {horizon}")
        if int(iterations) < 1:
            raise bad("iterations", iterations, "at least 1 Gauss-Newton step per frame")
        self.horizon, self.blocks, self.iterations = int(horizon), len(sizes), int(iterations)
        self.move_weight = float(move_weight)
        self.move_scale = np.sqrt(self.move_weight * np.array([1.0, float(azimuth_weight)]))   # on (a, c) changes
        self.disturbance_gain, self.h = float(disturbance_gain), float(diff_step)
        self.lo = np.tile([A_RANGE[0], C_RANGE[0]], self.blocks)
        self.hi = np.tile([A_RANGE[1], C_RANGE[1]], self.blocks)
        self.block_of = np.repeat(np.arange(self.blocks), sizes)                    # (N,) block of each frame
        self.held = 0

    def _currents(self, angles) -> np.ndarray:
        return self.P @ (self.field * field_direction(angles[0], angles[1]))

    def _start(self, applied) -> np.ndarray:
        """Reset the plan to hold ``applied`` (a, c) [rad]; returns its currents."""
        self.applied = np.asarray(applied, float)
        self.plan = np.tile(self.applied, self.blocks)
        self.currents = self._currents(self.applied)
        self.held = 0
        return self.currents

    def _predict(self, plans: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def _residuals(self, plans: np.ndarray, targets: np.ndarray) -> np.ndarray:
        """(B, 2 N + 2 blocks) residuals of B plans (B, 2 blocks)."""
        B = plans.shape[0]
        track = (self._predict(plans) - targets[None]).reshape(B, -1)
        steps = np.diff(np.concatenate([np.broadcast_to(self.applied, (B, 1, 2)),
                                        plans.reshape(B, self.blocks, 2)], 1), axis=1) * self.move_scale
        return np.concatenate([track, steps.reshape(B, -1)], 1)

    def _linearise(self, x: np.ndarray, targets: np.ndarray) -> tuple:
        """(r (R,), J (R, n)): the residuals at plan x and their Jacobian by forward differences, the
        n + 1 rollouts in one batch."""
        batch = np.concatenate([x[None], x[None] + self.h * np.eye(x.size)], 0)
        r = self._residuals(batch, targets)
        return r[0], (r[1:] - r[0]).T / self.h

    def _solve(self, targets: np.ndarray) -> np.ndarray:
        """The new plan (2 blocks,): ``iterations`` Gauss-Newton steps from the last plan shifted by a
        frame, clipped to the angle ranges; kept as ``plan``, its first block as ``applied``."""
        x = np.concatenate([self.plan[2:], self.plan[-2:]])                          # shifted warm start
        for _ in range(self.iterations):
            r, J = self._linearise(x, targets)
            step = np.linalg.solve(J.T @ J + 1e-6 * np.eye(x.size), -J.T @ r)
            x = np.clip(x + step, self.lo, self.hi)
        self.plan = x
        self.applied = x[:2].copy()
        return x


class LearnedMPC(BlockMPC):
    """MPC on a trained ``NarxModel`` (see the module docstring)."""

    def __init__(self, model: NarxModel, spec: ManipulatorSpec | None = None, *, horizon: int = 7,
                 blocks: tuple = (1, 2, 4), iterations: int = 1, move_weight: float = 0.2,
                 azimuth_weight: float = 10.0, observer_gain: float = 0.15, disturbance_gain: float = 0.1,
                 diff_step: float = 1e-4):
        super().__init__(spec, horizon=horizon, blocks=blocks, iterations=iterations, move_weight=move_weight,
                         azimuth_weight=azimuth_weight, disturbance_gain=disturbance_gain, diff_step=diff_step)
        self.model = model
        self.observer_gain = float(observer_gain)

    def _settled_direction(self, target) -> np.ndarray:
        """The field angles (a, 0) whose steady state under the model (a 2 s rollout from the state
        the model settles to under that field) is closest to ``target`` (about x, about y) [rad]."""
        a = np.linspace(A_RANGE[0], A_RANGE[1], 91)
        u = field_direction(a, np.zeros_like(a))                                      # (B, 3)
        B, H, N = a.size, HISTORY, int(2.0 * 30)
        y = np.zeros((B, H, 4))
        y[:] = np.array([0.0, target[1], 0.0, target[1]])                            # a rough start
        us = np.repeat(u[:, None], N, 1)
        for _ in range(2):                                                           # settle twice from the end
            out = self.model.rollout(y, us[:, :H - 1], us)
            y = out[:, -H:]
        err = np.sum((out[:, -1, 2:] - np.asarray(target)) ** 2, axis=1)
        return np.array([a[int(np.argmin(err))], 0.0])

    def reset(self, reference) -> np.ndarray:
        """Start from the field direction whose settled pose under the model is nearest the first target."""
        currents = self._start(self._settled_direction(reference.angles[0]))
        self.ys = None                              # (H, 4) estimated states
        self.us = np.tile(field_direction(*self.applied), (HISTORY, 1))
        self.predicted = None
        self.disturbance = np.zeros(4)
        return currents

    def _estimate(self, y_meas: np.ndarray) -> None:
        if self.ys is None:
            self.ys = np.tile(y_meas, (HISTORY, 1))
            return
        pred = self.predicted + self.disturbance
        innovation = y_meas - pred
        self.disturbance[2:] += self.disturbance_gain * innovation[2:]
        est = pred + self.observer_gain * innovation
        self.ys = np.concatenate([self.ys[1:], est[None]], 0)

    def _predict(self, plans: np.ndarray) -> np.ndarray:
        B = plans.shape[0]
        ang = plans.reshape(B, self.blocks, 2)[:, self.block_of]                   # (B, N, 2)
        future = field_direction(ang[..., 0], ang[..., 1])                          # (B, N, 3)
        ys = np.broadcast_to(self.ys, (B,) + self.ys.shape)
        us = np.broadcast_to(self.us[1:], (B,) + self.us[1:].shape)
        return self.model.rollout(ys, us, future)[..., 2:] + self.disturbance[2:]  # (B, N, 2) distal

    def __call__(self, k: int, measured, reference) -> np.ndarray:
        """The currents (n_c,) [A] for frame k, from its measurement ``measured`` (M, 3) [rad]."""
        y_meas = state_of(measured)
        if not np.all(np.isfinite(y_meas)):
            self.held += 1
            return self.currents
        self._estimate(y_meas)
        x = self._solve(reference.window(k, self.horizon))                           # (N, 2) (about x, about y)
        self.us = np.concatenate([self.us[1:], field_direction(x[0], x[1])[None]], 0)
        self.predicted = self.model.step(self.ys[None], self.us[None])[0]
        self.currents = self._currents(x[:2])
        return self.currents
