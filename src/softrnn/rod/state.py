"""The integrator's state and output buffers: ``RodState``, the start from the initial shape at
rest (with a half kick) and the kernels' ``Samples`` buffers."""

from dataclasses import dataclass, field

import numpy as np

from .contact import initial_segments
from .discrete import internal_loads, segment_strains
from .hub import hub_half_kick
from .inputs import SetupInputs
from .kernels import FREE, PINNED, LumpedRod, Samples, StateArrays, StepInputs, contact_wrench_into
from .magnetic import start_wrench
from .tendons import spring_tensions, tendon_lengths, tendon_resultants

SAMPLE_FIELDS = Samples._fields[1:]
"""The output fields of ``Samples`` (all but save_slot), named as in ``Trajectory``."""


@dataclass
class RodState:
    """Mutable integrator state (n nodes): rotations (n, 3, 3), positions (n, 3) [m], staggered
    velocities (n, 3) [m/s] (world) and angular_velocities (n, 3) [rad/s] (body), the previous
    strains prev_curvature, prev_shear (n - 1, 3) [1/m], [-], the time [s] and, with contact
    (``rod.contact``), contact_segment (n, o) int64: per node and kernel column (one per obstacle,
    two for a bifurcation: ``rod.contact.kernel_arrays``) the tracked closest segment of a vessel's
    polyline (0 for other obstacles; (0, 0) without contact)."""

    rotations: np.ndarray
    positions: np.ndarray
    velocities: np.ndarray
    angular_velocities: np.ndarray
    prev_curvature: np.ndarray
    prev_shear: np.ndarray
    time: float = 0.0
    contact_segment: np.ndarray = field(default_factory=lambda: np.zeros((0, 0), dtype=np.int64))

    def copy(self) -> "RodState":
        """A deep copy."""
        return RodState(self.rotations.copy(), self.positions.copy(), self.velocities.copy(),
                        self.angular_velocities.copy(), self.prev_curvature.copy(), self.prev_shear.copy(),
                        self.time, self.contact_segment.copy())

    def arrays(self) -> StateArrays:
        """The arrays as the kernels' record (the same arrays: the kernels step them in place)."""
        return StateArrays(self.rotations, self.positions, self.velocities, self.angular_velocities,
                           self.prev_curvature, self.prev_shear)


def initial_state(setup, rod: LumpedRod, inputs: SetupInputs) -> RodState:
    """A ``Setup``'s initial shape at rest at t = 0, with the prescribed nodes at their t = 0 poses
    (positions; and rotations of clamped nodes and of a hub's); the strain memory holds its strains."""
    init = setup.initial
    R = np.ascontiguousarray(init.rotations, dtype=float).copy()
    r = np.ascontiguousarray(init.positions, dtype=float).copy()
    if inputs.presc_idx.size:
        pos, rot = inputs.prescribed(np.array([0.0]))
        for j, a in enumerate(inputs.presc_idx):
            r[a] = pos[0, j]
            if rod.kind[a] != PINNED:  # clamped, or held by a hub
                R[a] = rot[0, j]
    K, G = segment_strains(R, r, rod.length)
    n = r.shape[0]
    state = RodState(R, r, np.zeros((n, 3)), np.zeros((n, 3)), K, G, 0.0)
    if setup.contact is not None:
        state.contact_segment = initial_segments(setup.contact, r)
    return state


def half_kick(rod: LumpedRod, state: RodState, inputs: StepInputs, h: float) -> None:
    """Start at rest to second order: the staggered velocities before the first
    step become v^-1 = -(h/2) f(q^0)/m and omega^-1 = -(h/2) J^-1 t(q^0), so the mid-step velocity
    at t0 is zero (plain v^-1 = 0 shifts the motion by h/2 in time, a global O(h) error).

    rod : the lumped rod; state : at rest, changed in place; inputs : ``StepInputs`` whose first
    step (ext_w[0], pd_target[0], tendon_tension[0], tendon_displacement[0]) holds the loads at the
    state's time (the tensions of tendons driven by a displacement are computed here from the
    state, as the kernel does; the contact and magnetic loads too, ``kernels.contact_wrench_into``,
    ``rod.magnetic.start_wrench``); h : solver
    step [s].
    """
    R, r = state.rotations, state.positions
    terms = None
    if inputs.tendon_end.size:
        tension = inputs.tendon_tension[0]
        if inputs.tendon_stiffness.size:
            moved = inputs.tendon_stiffness > 0
            lengths = tendon_lengths(R, r, rod.length, inputs.tendon_route, inputs.tendon_end)
            tension = np.where(moved, spring_tensions(lengths, inputs.tendon_rest, inputs.tendon_stiffness,
                                                      inputs.tendon_displacement[0]), tension)

        def terms(K, G):
            return tendon_resultants(K, G, inputs.tendon_route, inputs.tendon_end, tension)
    f, t = internal_loads(R, r, rod.length, rod.C1, rod.C2, rod.K0, rod.G0, terms)
    f += rod.mass[:, None] * rod.gravity
    ext_w = inputs.ext_w
    for j, a in enumerate(inputs.ext_idx):
        f[a] += ext_w[0, j, 0:3] + R[a] @ ext_w[0, j, 6:9]
        t[a] += R[a].T @ ext_w[0, j, 3:6] + ext_w[0, j, 9:12]
    for j, a in enumerate(inputs.pd_idx):
        f[a] += inputs.pd_gain[j, 0] * (inputs.pd_target[0, j] - r[a])
    if inputs.magnet_node is not None:  # the magnets' loads at rest (``rod.magnetic``)
        wrench = start_wrench(R, r, inputs)
        for a in np.unique(np.concatenate([inputs.magnet_node, inputs.magnet_node + 1])):
            f[a] += wrench[a, 0:3]
            t[a] += R[a].T @ wrench[a, 3:6]
    if inputs.contact_kind is not None:  # the contact loads at rest (inputs as ``SetupInputs.with_contact`` gives)
        wrench = np.zeros((len(r), 6))
        contact_wrench_into(h, R, r, state.velocities, state.angular_velocities, rod, inputs, wrench)
        f += wrench[:, :3]
        t += np.einsum("aji,aj->ai", R, wrench[:, 3:])
    free = rod.kind == FREE
    state.velocities[free] = -0.5 * h * f[free] / rod.mass[free, None]
    rot = (rod.kind == FREE) | (rod.kind == PINNED)
    state.angular_velocities[rot] = -0.5 * h * t[rot] / rod.inertia[rot]
    hub_half_kick(rod, state.velocities, state.angular_velocities, R, f, t, h)


def empty_samples(save_slot: np.ndarray, n_samples: int, n_saved: int, lead: tuple = ()) -> Samples:
    """Zeroed ``Samples`` for ``n_samples`` samples of ``n_saved`` nodes; ``save_slot`` (n,) int64:
    column of each node, -1 for nodes not saved; ``lead``: leading axes of every buffer, e.g.
    (B,) for a batch."""
    shape = tuple(lead) + (n_samples, n_saved)
    vec = {name: np.zeros(shape + (3,)) for name in SAMPLE_FIELDS}
    vec["quaternions"] = np.zeros(shape + (4,))
    vec["energy"] = np.zeros(tuple(lead) + (n_samples, 3))
    return Samples(save_slot=save_slot, **vec)
