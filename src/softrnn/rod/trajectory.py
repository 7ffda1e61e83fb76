"""What a run returns: the saved ``Trajectory`` (or, streamed to a sink, its ``RunStats``), built
chunk by chunk from the kernels' output buffers (``rod.simulation.Simulator.run``)."""

from dataclasses import dataclass

import numpy as np

from .kernels import Samples
from .magnetic import MagnetSamples
from .magnetic import concatenate as concatenate_magnets
from .so3 import quaternion_to_matrix
from .state import SAMPLE_FIELDS


@dataclass(frozen=True, eq=False)
class Trajectory:
    """Saved states. S samples, s saved nodes.

    time (S,) [s]; nodes (s,) 0-based node indices; positions (S, s, 3) [m];
    quaternions (S, s, 4) unit, scalar first, body -> world; velocities (S, s, 3) [m/s];
    angular_velocities (S, s, 3) [rad/s] world frame; forces (S, s, 3) [N] and torques (S, s, 3)
    [N m]: applied external loads (including PD forces) in the world frame; reaction_forces,
    reaction_torques (S, s, 3): support reactions of constrained nodes (zero for free nodes);
    energy (S, 3) [J]: kinetic, elastic, gravitational. step [s] and substeps: the solver step;
    wall_time [s] of the run. tendon_tensions (S, m) [N]: the tensions of the setup's m tendons the
    run applied at each sample, in ``Setup.tendons`` order (those of tendons driven by a displacement
    computed from the sample's configuration); None for a run without a tendon driven by a
    displacement (the tensions are then the tendons' own profiles). contact_forces, contact_torques
    (S, s, 3) [N], [N m]: the contact loads of ``Setup.contact`` on the saved nodes (normal force and
    friction, and the friction's moment about the node), world frame, applied at each sample's step
    (not part of ``forces``); None without contact. magnets: the currents and the magnets'
    quantities at each sample (``rod.magnetic.MagnetSamples``) of a setup with ``MagneticDipoles``;
    None without.
    """

    time: np.ndarray
    nodes: np.ndarray
    positions: np.ndarray
    quaternions: np.ndarray
    velocities: np.ndarray
    angular_velocities: np.ndarray
    forces: np.ndarray
    torques: np.ndarray
    reaction_forces: np.ndarray
    reaction_torques: np.ndarray
    energy: np.ndarray
    step: float
    substeps: int
    wall_time: float = 0.0
    tendon_tensions: np.ndarray | None = None
    contact_forces: np.ndarray | None = None
    contact_torques: np.ndarray | None = None
    magnets: MagnetSamples | None = None

    @property
    def n_steps(self) -> int:
        """Solver steps between the first and the last sample."""
        return max(len(self.time) - 1, 0) * self.substeps

    def rotations(self) -> np.ndarray:
        """Rotation matrices (S, s, 3, 3) from the quaternions."""
        return quaternion_to_matrix(self.quaternions)


@dataclass(frozen=True)
class RunStats:
    """What a run did: samples, solver step h [s], substeps per sample, wall time [s], nodes."""

    n_samples: int
    step: float
    substeps: int
    wall_time: float
    n_nodes: int

    @property
    def n_steps(self) -> int:
        """Solver steps between the first and the last sample."""
        return max(self.n_samples - 1, 0) * self.substeps

    @property
    def us_per_node_step(self) -> float:
        """Wall time per node and solver step [microseconds]."""
        return 1e6 * self.wall_time / max(self.n_steps * self.n_nodes, 1)


def to_trajectory(out: Samples, times: np.ndarray, nodes: np.ndarray, h: float, substeps: int,
                   tensions: np.ndarray | None = None, contact: np.ndarray | None = None,
                   magnets: MagnetSamples | None = None) -> "Trajectory":
    """A ``Trajectory`` of one chunk from the kernels' outputs (``Samples``, and the tensions, contact
    loads (rows, s, 6) and magnet samples where the setup has them) at the given times (S,) [s]."""
    loads = {} if contact is None else {"contact_forces": contact[..., :3], "contact_torques": contact[..., 3:]}
    return Trajectory(time=times, nodes=nodes, step=h, substeps=substeps, tendon_tensions=tensions, magnets=magnets,
                      **{name: getattr(out, name) for name in SAMPLE_FIELDS}, **loads)


def concatenate_chunks(chunks: list, stats: "RunStats") -> "Trajectory":
    """One ``Trajectory`` of consecutive chunks, with the step and wall time of ``stats``."""
    first = chunks[0]
    arrays = {name: np.concatenate([getattr(c, name) for c in chunks]) for name in ("time",) + SAMPLE_FIELDS}
    for name in ("tendon_tensions", "contact_forces", "contact_torques"):
        if getattr(first, name) is not None:
            arrays[name] = np.concatenate([getattr(c, name) for c in chunks])
    if first.magnets is not None:
        arrays["magnets"] = concatenate_magnets([c.magnets for c in chunks])
    return Trajectory(nodes=first.nodes, step=stats.step, substeps=stats.substeps, wall_time=stats.wall_time,
                      **arrays)
