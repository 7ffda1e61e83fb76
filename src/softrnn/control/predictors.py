"""What the model-predictive controller (``mpc.BlockMPC``) plans with: a ``Predictor`` of the distal
magnet's orientation over the horizon for candidate plans of the field direction, from its own
estimate of the robot's state.

Two predictors implement it: ``model.NarxPredictor`` (the learned NARX network, ``mpc-learned``) and
``physics_mpc.PhysicsPredictor`` (the nominal dynamic simulator, ``mpc-physics``).

Each frame the controller calls ``observe`` with the camera's measurement; when the predictor can use
it, the controller plans (``predict`` on a batch of candidate plans) and hands the applied direction
and its currents to ``advance``; otherwise it holds its last currents and calls ``hold``.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np

DISTURBANCE_GAIN = 0.1
"""Default gain of the slow integral term that learns a predictor's remaining offset on the distal
magnet (offset-free MPC): the fraction of the innovation added per frame."""


@runtime_checkable
class Predictor(Protocol):
    """The state estimate and the rollouts the MPC plans with.

    history : frames of measurements and inputs the predictor reads to predict the next one
    """

    history: int

    def start(self, target: np.ndarray) -> np.ndarray:
        """The field angles (a, c) [rad] to hold before the first frame, for the first ``target``
        (about x, about y) [rad] of the distal magnet."""
        ...

    def reset(self, applied: np.ndarray, currents: np.ndarray) -> None:
        """Start a run: the plant settles under the field along ``applied`` (a, c) [rad], made by
        ``currents`` (n_c,) [A]."""
        ...

    def observe(self, measured: np.ndarray) -> bool:
        """Update the state estimate from the camera's orientations ``measured`` (M, 3) [rad] of this
        frame; False (and nothing updated) when the measurement cannot be used (NaN: the camera
        lost the rod)."""
        ...

    def predict(self, plans: np.ndarray, block_of: np.ndarray) -> np.ndarray:
        """The distal orientation (B, N, 2) [rad] (about x, about y) over the next N frames under each
        of B plans (B, blocks, 2) of field angles (a, c), frame i applying block ``block_of[i]``."""
        ...

    def advance(self, applied: np.ndarray, currents: np.ndarray) -> None:
        """The frame's input was chosen: the field along ``applied`` (a, c) [rad], ``currents`` (n_c,) [A]."""
        ...

    def hold(self, currents: np.ndarray) -> None:
        """No usable measurement this frame: the plant is given the last ``currents`` (n_c,) [A] again."""
        ...
