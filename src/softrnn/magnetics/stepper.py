"""The magnetic manipulator stepped frame by frame, for closed loops: a controller sets the coil
currents once per frame and they are held over it (zero-order hold, as a current amplifier driven
at the camera rate does); the state carries over from frame to frame.

``ManipulatorStepper(spec, dt, currents0)`` settles the rod at rest under ``currents0`` (heavy drag
for ``settle`` s, as ``simulate_manipulator`` does), then ``step(currents)`` advances one frame of
``dt`` s and ``positions``/``rotations`` give the state at the frame's end. With the same currents
held throughout, K steps reproduce ``simulate_manipulator``'s K + 1 samples exactly. An advancing
base (``ManipulatorSpec.advance``) follows its profile in the frames' time, as in a batch run.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import bad
from ..rod.simulation import Damping
from .manipulator import (
    SETTLE_DAMPING,
    CurrentSchedule,
    ManipulatorRun,
    ManipulatorSpec,
    check_manipulator_run,
    manipulator_simulator,
)


class ManipulatorStepper:
    """A manipulator run one frame at a time (see the module docstring).

    Parameters
    ----------
    spec : ManipulatorSpec
        The manipulator.
    dt : float
        Frame length [s] (e.g. 1/30 for a 30 Hz camera).
    currents0 : (n_c,) [A]
        Currents held while settling, and the state's starting currents.
    substeps : int or None
        Solver steps per frame (None: the fewest that are stable).
    settle : float
        Settling time [s] before t = 0 with ``settle_damping``.

    Attributes
    ----------
    time : float
        time of the state [s] (0 after settling)
    frames : int
        frames stepped
    currents : (n_c,) [A]
        the currents of the last frame
    """

    def __init__(self, spec: ManipulatorSpec, dt: float, currents0, *, substeps: int | None = None,
                 settle: float = 0.5, settle_damping: Damping = SETTLE_DAMPING):
        if not isinstance(spec, ManipulatorSpec):
            raise bad("spec", type(spec).__name__, "a ManipulatorSpec")
        run = ManipulatorRun(dt=dt, n_samples=2, substeps=substeps, settle=settle, settle_damping=settle_damping)
        self.spec = spec
        self.dt = float(dt)
        self.substeps = check_manipulator_run(spec, run)
        self.h = self.dt / self.substeps
        self.currents = self._checked(currents0)
        n_settle = int(math.ceil(settle / self.h)) if settle > 0 else 0
        held = CurrentSchedule(np.array([-n_settle * self.h, 0.0]) if n_settle else np.zeros(1),
                               np.stack([self.currents] * (2 if n_settle else 1)))
        self._sim = manipulator_simulator(spec, held, self.h, settle=settle, settle_damping=settle_damping)
        self._sim.start(self.h)  # at rest under currents0 (settled: already started)
        self.time = 0.0
        self.frames = 0

    def _checked(self, currents) -> np.ndarray:
        I = self.spec.coils.check_currents(currents)
        if I.shape != (self.spec.coils.n_coils,):
            raise bad("currents.shape", I.shape, f"({self.spec.coils.n_coils},): one current per coil")
        return np.array(I, dtype=np.float64)

    def step(self, currents) -> None:
        """Advance one frame with ``currents`` (n_c,) [A] held (refused beyond the coil limit)."""
        self.currents = self._checked(currents)
        magnetic = self._sim.inputs.magnetic
        self._sim.inputs.magnetic = magnetic.with_currents(np.array([self.time, self.time + self.dt]),
                                                           np.stack([self.currents, self.currents]))
        self._sim.state.time = self.time
        self._sim.advance(self.substeps, self.h)
        self.frames += 1
        self.time = self.frames * self.dt

    def snapshot(self) -> tuple:
        """The state to come back to with ``restore`` (a deep copy): a planner's rollouts branch from it."""
        return self._sim.state.copy(), self.time, self.frames, self.currents.copy()

    def restore(self, snapshot: tuple) -> None:
        """Return to a ``snapshot`` (copied again, so one snapshot serves many rollouts)."""
        state, self.time, self.frames, currents = snapshot
        self._sim.state = state.copy()
        self.currents = currents.copy()

    @property
    def positions(self) -> np.ndarray:
        """Node positions (n, 3) [m] at ``time`` (a copy)."""
        return np.array(self._sim.state.positions, dtype=np.float64)

    @property
    def rotations(self) -> np.ndarray:
        """Node rotations (n, 3, 3) body -> world at ``time`` (a copy)."""
        return np.array(self._sim.state.rotations, dtype=np.float64)
