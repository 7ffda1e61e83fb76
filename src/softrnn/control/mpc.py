"""Model-predictive control of the magnetic rod: ``BlockMPC``, the one planner, on any
``predictors.Predictor`` (``model.NarxPredictor`` for ``mpc-learned``, ``physics_mpc.PhysicsPredictor``
for ``mpc-physics``), with its options in ``MPCOptions``.

Every frame, from the camera's measurement:

1. **Estimate.** The predictor updates its estimate of the robot's state from the measurement
   (``Predictor.observe``); the learned one blends its one-frame prediction with the measurement
   (a fixed-gain observer) and learns its remaining offset on the distal magnet with a slow
   integral term, so a constant model error does not become a constant tracking error.
2. **Plan.** The field direction (elevation a, azimuth c; fixed magnitude) over a horizon of
   ``horizon`` frames (7) is held in ``blocks`` (lengths 1, 2, 4 frames by default: the rod answers
   a new field within a frame or two, so the first move must be free to change at the very frame a
   step of the reference comes; 2 x 3 unknowns). One Gauss-Newton step per frame (``iterations``;
   the "real-time iteration" of nonlinear MPC: the plan is refined frame after frame, not solved
   to the end every frame) minimises sum over the horizon |distal orientation - reference|^2 +
   ``move_weight`` times the squared changes of (a, c) from block to block (and from the last
   applied one), those of the azimuth c ``azimuth_weight`` times more (the out-of-plane angle is
   read from the camera with its largest noise, and a planar target needs c = 0); the Jacobian by
   forward differences: the 2 x blocks + 1 rollouts are one batch of ``Predictor.predict``
   (refreshed every ``refresh`` frames and kept in between, for a costly predictor). The plan
   starts from the last one, shifted by a frame; the angles stay within the static controller's
   grid.
3. **Apply** the first block's direction: the minimum-norm currents for that field at the
   workspace centre, within the coil limit by construction (the magnitude is chosen so that every
   direction is).

A measurement the predictor cannot use (a NaN: the camera lost the rod) is not used: the last
currents are held and the frame counted (``held``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import bad, is_finite_number, is_int
from ..magnetics.manipulator import ManipulatorSpec
from .fields import A_RANGE, C_RANGE, FieldCommand
from .predictors import Predictor


@dataclass(frozen=True, kw_only=True)
class MPCOptions:
    """The planner's options (see the module docstring).

    Attributes
    ----------
    horizon : int
        frames planned ahead
    blocks : tuple of int
        lengths [frames] of the blocks the field direction is held over; they add up to ``horizon``
    iterations : int
        Gauss-Newton steps per frame
    move_weight : float
        weight of the squared changes of (a, c) between blocks against the tracking error
    azimuth_weight : float
        how many times more the changes of the azimuth c weigh
    diff_step : float
        forward-difference step [rad] of the Jacobian
    refresh : int
        frames between two Jacobian refreshes (1: a fresh Jacobian at every Gauss-Newton step)
    """

    horizon: int = 7
    blocks: tuple = (1, 2, 4)
    iterations: int = 1
    move_weight: float = 0.2
    azimuth_weight: float = 10.0
    diff_step: float = 1e-4
    refresh: int = 1

    def __post_init__(self):
        for name in ("horizon", "iterations", "refresh"):
            value = getattr(self, name)
            if not is_int(value) or value < 1:
                raise bad(name, value, {"horizon": "at least 1 frame", "iterations": "at least 1 Gauss-Newton "
                                        "step per frame", "refresh": "at least 1 frame"}[name])
        try:
            sizes = tuple(int(b) for b in self.blocks if is_int(b))
        except TypeError:
            sizes = ()
        if len(sizes) == 0 or len(sizes) != len(self.blocks) or any(b < 1 for b in sizes) \
                or sum(sizes) != self.horizon:
            raise bad("blocks", self.blocks, f"block lengths >= 1 that add up to the horizon {self.horizon}")
        for name in ("move_weight", "azimuth_weight"):
            if not is_finite_number(getattr(self, name)) or getattr(self, name) < 0:
                raise bad(name, getattr(self, name), "a finite weight >= 0")
        if not is_finite_number(self.diff_step) or self.diff_step <= 0:
            raise bad("diff_step", self.diff_step, "a positive finite step in rad")
        for name in ("horizon", "iterations", "refresh"):
            object.__setattr__(self, name, int(getattr(self, name)))
        object.__setattr__(self, "blocks", sizes)
        for name in ("move_weight", "azimuth_weight", "diff_step"):
            object.__setattr__(self, name, float(getattr(self, name)))


class BlockMPC:
    """The model-predictive controller: plans the field direction in blocks with ``predictor`` and
    applies the first block's currents (see the module docstring).

    Parameters
    ----------
    predictor : Predictor
        what it plans with (a ``predictors.Predictor``)
    spec : ManipulatorSpec or None
        the manipulator whose coils make the field (None: ``ManipulatorSpec()``)
    options : MPCOptions or None
        the planner's options (None: ``MPCOptions()``)
    """

    def __init__(self, predictor: Predictor, spec: ManipulatorSpec | None = None, *,
                 options: MPCOptions | None = None):
        if not isinstance(predictor, Predictor):
            raise bad("predictor", type(predictor).__name__, "a softrnn.control.predictors.Predictor")
        self.predictor = predictor
        self.options = MPCOptions() if options is None else options
        if not isinstance(self.options, MPCOptions):
            raise bad("options", type(self.options).__name__, "a softrnn.control.mpc.MPCOptions")
        self.spec = ManipulatorSpec() if spec is None else spec
        self.command = FieldCommand.of(self.spec)
        opts = self.options
        self.blocks = len(opts.blocks)
        self.move_scale = np.sqrt(opts.move_weight * np.array([1.0, opts.azimuth_weight]))  # on (a, c) changes
        self.lo = np.tile([A_RANGE[0], C_RANGE[0]], self.blocks)
        self.hi = np.tile([A_RANGE[1], C_RANGE[1]], self.blocks)
        self.block_of = np.repeat(np.arange(self.blocks), opts.blocks)             # (N,) block of each frame
        self.applied = np.zeros(2)                                                  # (a, c) [rad] applied
        self.plan = np.zeros(2 * self.blocks)                                       # (a, c) of each block
        self.currents = np.zeros(self.command.P.shape[0])
        self.held = 0
        self._J, self._age = None, 0                                                # the kept Jacobian

    def reset(self, reference) -> np.ndarray:
        """Before the first frame: hold the predictor's start for the reference's first target; returns
        its currents (n_c,) [A]."""
        self.applied = np.asarray(self.predictor.start(reference.angles[0]), float)
        self.plan = np.tile(self.applied, self.blocks)
        self.currents = self.command.currents(self.applied)
        self.held = 0
        self._J, self._age = None, 0
        self.predictor.reset(self.applied, self.currents)
        return self.currents

    def __call__(self, k: int, measured, reference) -> np.ndarray:
        """The currents (n_c,) [A] for frame k, from its measurement ``measured`` (M, 3) [rad]."""
        if not self.predictor.observe(measured):
            self.held += 1
            self.predictor.hold(self.currents)
            return self.currents
        x = self._solve(reference.window(k, self.options.horizon))                  # (N, 2) (about x, about y)
        self._age += 1
        self.currents = self.command.currents(x[:2])
        self.predictor.advance(x[:2], self.currents)
        return self.currents

    def _residuals(self, plans: np.ndarray, targets: np.ndarray) -> np.ndarray:
        """(B, 2 N + 2 blocks) residuals of B plans (B, 2 blocks)."""
        B = plans.shape[0]
        blocks = plans.reshape(B, self.blocks, 2)
        track = (self.predictor.predict(blocks, self.block_of) - targets[None]).reshape(B, -1)
        steps = np.diff(np.concatenate([np.broadcast_to(self.applied, (B, 1, 2)), blocks], 1),
                        axis=1) * self.move_scale
        return np.concatenate([track, steps.reshape(B, -1)], 1)

    def _linearise(self, x: np.ndarray, targets: np.ndarray) -> tuple:
        """(r (R,), J (R, n)): the residuals at plan x and their Jacobian by forward differences, the
        n + 1 rollouts in one batch; with ``refresh`` > 1, the kept Jacobian until it is that many
        frames old (only the base rollout runs)."""
        refresh = self.options.refresh
        if refresh > 1 and self._J is not None and self._age < refresh:
            return self._residuals(x[None], targets)[0], self._J
        h = self.options.diff_step
        batch = np.concatenate([x[None], x[None] + h * np.eye(x.size)], 0)
        r = self._residuals(batch, targets)
        self._J, self._age = (r[1:] - r[0]).T / h, 0
        return r[0], self._J

    def _solve(self, targets: np.ndarray) -> np.ndarray:
        """The new plan (2 blocks,): ``iterations`` Gauss-Newton steps from the last plan shifted by a
        frame, clipped to the angle ranges; kept as ``plan``, its first block as ``applied``."""
        x = np.concatenate([self.plan[2:], self.plan[-2:]])                          # shifted warm start
        for _ in range(self.options.iterations):
            r, J = self._linearise(x, targets)
            step = np.linalg.solve(J.T @ J + 1e-6 * np.eye(x.size), -J.T @ r)
            x = np.clip(x + step, self.lo, self.hi)
        self.plan = x
        self.applied = x[:2].copy()
        return x
