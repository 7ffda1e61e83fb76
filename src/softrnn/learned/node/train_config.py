"""A node model's training settings (``TrainConfig``), without PyTorch, so that other parts (the
lab's node family) can hold them; ``train`` runs them."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...errors import bad, integer


@dataclass(frozen=True, kw_only=True)
class TrainConfig:
    """How a node model is trained.

    Parameters
    ----------
    epochs : int
        Most passes over the training windows (the paper trained 25 epochs).
    batch_size : int
        Windows per Adam step. The paper used 1; 256 takes far fewer optimiser steps per epoch
        and already reaches one-step errors far below the paper's on this project's datasets.
    learning_rate : float
        Adam's initial step size; it decays along a cosine to ``learning_rate * final_lr_fraction``
        over ``epochs``.
    final_lr_fraction : float
        Learning rate at the last epoch relative to the first (1: constant).
    patience : int
        Stop after this many epochs without a better validation loss.
    validation_fraction : float
        Chronologically last fraction of the training span used for early stopping.
    seed : int
        Seeds the initial weights and the shuffling (the same seed gives the same weights).
    max_train_windows : int
        Subsample the training (and validation) windows with a stride above this many (the
        square case's 76,798 fit windows at 0.1 ms get stride 4).
    threads : int
        Torch CPU threads while training (restored afterwards).
    input_noise : float
        Standard deviation of a random offset of the node's own past positions (the same at every
        step of a window; the target stays the true next position), in units of the node's typical
        step; 0: none. Off by default: multi-step training gave steadier rollouts.
    rollout_steps : int
        K, steps of the multi-step loss: the node's predictions are fed back into its next K-1
        windows (neighbours and wrenches recorded) and the loss averages the K one-step errors, each
        against the true next position; 1: plain one-step training. K = 4 kept the free-running
        rollouts of all three paper cases within about 1 mm of the reference over 8,000 steps (the
        models of K = 1 drifted by up to 10 mm); each window costs K forward passes.
    """

    epochs: int = 30
    batch_size: int = 256
    learning_rate: float = 2e-3
    final_lr_fraction: float = 0.05
    patience: int = 8
    validation_fraction: float = 0.2
    seed: int = 0
    max_train_windows: int = 25_000
    threads: int = 1
    input_noise: float = 0.0
    rollout_steps: int = 4

    def __post_init__(self):
        for name, low in (("epochs", 1), ("batch_size", 1), ("patience", 1), ("max_train_windows", 1),
                          ("threads", 1), ("seed", 0), ("rollout_steps", 1)):
            object.__setattr__(self, name, integer(name, getattr(self, name), low))
        if isinstance(self.input_noise, bool) or not isinstance(self.input_noise, (int, float, np.floating)) \
                or not 0.0 <= self.input_noise < math.inf:
            raise bad("input_noise", self.input_noise, "a number >= 0 (0: no noise)")
        object.__setattr__(self, "input_noise", float(self.input_noise))
        for name, lo, hi, closed in (("learning_rate", 0.0, math.inf, False), ("final_lr_fraction", 0.0, 1.0, True),
                                     ("validation_fraction", 0.0, 1.0, False)):
            value = getattr(self, name)
            ok = isinstance(value, (int, float, np.floating)) and not isinstance(value, bool) and math.isfinite(value)
            ok = ok and lo < value and (value <= hi if closed else value < hi)
            if not ok:
                raise bad(name, value, f"a number in ({lo:g}, {hi:g}{']' if closed else ')'}")
            object.__setattr__(self, name, float(value))
