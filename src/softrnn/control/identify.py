"""System identification for the learned MPC: the robot driven open loop by random field directions
(the magnitude fixed, as the controllers command it), measured by the camera with its noise, and
the NARX model (``model``) trained on that record.

The excitation holds a random direction for a random 0.1-1.0 s, elevation uniform in [-90, 90]
deg and azimuth in [-30, 30] deg, so the record holds both steps (the dynamics) and holds (the
settled poses) over the whole range the controllers use. It is what one would run on the real
robot before closing the loop: the model learns the robot, not the nominal parameters.
"""

from __future__ import annotations

import math

import numpy as np

from ..magnetics.manipulator import ManipulatorSpec
from ..progress import Progress
from .fields import field_direction, field_magnitude, field_to_currents
from .loop import LoopConfig, run_loop
from .model import NarxModel, state_of, train_narx
from .references import Reference


class Excitation:
    """An open-loop 'controller' that plays a random piecewise-constant field direction."""

    def __init__(self, frames: int, rate: float, seed: int, spec: ManipulatorSpec | None = None):
        spec = ManipulatorSpec() if spec is None else spec
        self.P = field_to_currents(spec)
        self.field = field_magnitude(self.P, spec.coils.current_limit)
        rng = np.random.default_rng([seed, 0x6964])
        angles, k = [], 0
        while k < frames:
            hold = int(rng.integers(max(1, int(0.1 * rate)), int(1.0 * rate) + 1))
            a = rng.uniform(-math.pi / 2, math.pi / 2)
            c = rng.uniform(-math.pi / 6, math.pi / 6)
            angles += [(a, c)] * hold
            k += hold
        self.angles = np.array(angles[:frames])                                    # (K, 2) [rad]
        self.directions = field_direction(self.angles[:, 0], self.angles[:, 1])   # (K, 3)
        self.held = 0

    def reset(self, reference) -> np.ndarray:
        """The first direction's currents."""
        return self.P @ (self.field * self.directions[0])

    def __call__(self, k: int, measured, reference) -> np.ndarray:
        """Frame k's currents (the measurement is not used)."""
        return self.P @ (self.field * self.directions[k])


def identification_run(seconds: float, *, config: LoopConfig | None = None, seed: int = 0,
                       progress: Progress | None = None) -> tuple:
    """(y (K, 4) [rad] measured states, u (K, 3) field directions, u[k] applied over frame k) of an
    open-loop excitation of the plant of ``config`` lasting ``seconds``; ``progress``: the loop's
    (frames done of ``identification_frames(seconds, config)``)."""
    config = LoopConfig() if config is None else config
    K = int(round(seconds * config.rate)) + 1
    excitation = Excitation(K, config.rate, seed)
    times = np.arange(K) / config.rate
    dummy = Reference(name="identification", times=times, angles=np.zeros((K, 2)))
    result = run_loop(excitation, dummy, LoopConfig(**{**config.to_dict(), "seed": seed}), progress=progress)
    return state_of(result.measured), excitation.directions


def identification_frames(seconds: float, config: LoopConfig | None = None) -> int:
    """The closed-loop frames (controller calls) of an ``identification_run`` lasting ``seconds``."""
    config = LoopConfig() if config is None else config
    return int(round(seconds * config.rate))


def identified_model(*, seconds: float = 90.0, segments: int = 3, config: LoopConfig | None = None, seed: int = 0,
                     steps: int = 2000, progress: Progress | None = None) -> NarxModel:
    """Identify the plant of ``config`` (``segments`` runs of ``seconds / segments`` each, seeds
    derived from ``seed``) and train the NARX model on them. ``progress(done, total, {"stage": ...})``
    counts the identification frames of every run, then the training steps, as one total (stage
    ``"identify"``, then ``"train"``)."""
    frames = identification_frames(seconds / segments, config)
    total = segments * frames + steps

    def part(offset: int, stage: str):
        if progress is None:
            return None
        return lambda done, _total, info=None: progress(offset + done, total, {"stage": stage})

    runs = [identification_run(seconds / segments, config=config, seed=seed * 1000 + i,
                               progress=part(i * frames, "identify")) for i in range(segments)]
    model = train_narx(runs, steps=steps, seed=seed, progress=part(segments * frames, "train"))
    model.meta.update({"identification_seconds": float(seconds), "segments": int(segments)})
    return model
