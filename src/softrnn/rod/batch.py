"""Batched simulation: many independent rods of the same design advanced together.

``simulate_batch`` runs ``kernels.advance_batch``, which steps the rods in parallel (blocks of rods
on threads, ``rod.threads.over_rods``; set the thread count with ``numba.set_num_threads``). The
rods must share everything the kernel shares between them: rod spec, stress-free reference shape,
boundary node kinds and the nodes with prescribed motion, the PD-tracked nodes and their gains,
the tendons' routing and which are driven by a displacement (with their stiffness), damping and
a constant gravity. Initial shapes, nodal loads, PD targets, tendon tensions and displacements,
prescribed motions and gravities given as time functions (in every setup) may differ, and so may
the obstacles (``Setup.contact``, a meshed vessel included): each rod has its own, in every setup or
in none, with as many kernel columns (``rod.contact.kernel_arrays``) and the same contact stiffness
and damping per node. Each rod gives the same trajectory as ``simulate`` would (up to rounding in
the order of summing loads on one node), its contact loads included.

The rods share one ``LumpedRod`` (``rod.lumped``); each rod's inputs (loads, PD targets,
prescribed poses) are evaluated by its own ``SetupInputs`` chunk by chunk, and each starts as
``Simulator.run`` starts a fresh simulator (``rod.state``).
"""

import time
from collections.abc import Sequence

import numpy as np

from ..errors import bad
from ..progress import Progress
from . import kernels
from .hub import driven_hub, with_hub
from .inputs import SetupInputs
from .integrators import Explicit, choose_substeps
from .kernels import StateArrays, StepInputs
from .lumped import lumped_rod, node_kinds
from .magnetic import MagneticDipoles
from .simulation import RunConfig, Setup, Simulator, Trajectory, check_run_size, save_nodes, save_slots
from .state import SAMPLE_FIELDS, empty_samples, half_kick, initial_state
from .status import raise_for_status
from .threads import over_rods

# rod-steps per kernel call: the per-chunk input arrays hold B x K steps (ext_w alone is
# B K m 12 doubles), so the steps per chunk shrink as the batch grows
_CHUNK_ROD_STEPS = 65536


def _pd_order(inputs: SetupInputs) -> np.ndarray:
    """Canonical order of a setup's PD entries: by node, then gains."""
    g = inputs.pd_gain
    return np.lexsort((g[:, 1], g[:, 0], inputs.pd_idx)) if inputs.pd_idx.size else np.zeros(0, dtype=np.int64)


def _check_compatible(setups: list[Setup], inputs: list[SetupInputs]) -> None:
    """Raise SoftrnnInputError naming the first property in which a setup differs from setups[0]."""
    s0, ref = setups[0], inputs[0]
    kind0 = node_kinds(s0)
    order0 = _pd_order(ref)
    for b, (s, inp) in enumerate(zip(setups[1:], inputs[1:]), start=1):
        where = f"setups[{b}]"
        if s.rod != s0.rod:
            raise bad(f"{where}.rod", s.rod, f"the same RodSpec as setups[0] ({s0.rod}); "
                      f"a batch shares one rod design, run different rods in separate batches")
        if not (np.array_equal(s.reference.positions, s0.reference.positions)
                and np.array_equal(s.reference.rotations, s0.reference.rotations)):
            raise bad(f"{where}.reference", "a different reference shape",
                      "the same stress-free reference shape as setups[0] (initial shapes may differ)")
        if not np.array_equal(node_kinds(s), kind0):
            raise bad(f"{where}.boundary", s.boundary,
                      f"the same constrained nodes and kinds (Clamp/Pin) as setups[0] ({s0.boundary})")
        if not np.array_equal(inp.presc_idx, ref.presc_idx):
            raise bad(f"{where}.boundary", s.boundary,
                      f"prescribed motions on the same nodes as setups[0] "
                      f"(nodes {ref.presc_idx.tolist()}, this setup has {inp.presc_idx.tolist()})")
        order = _pd_order(inp)
        if not (np.array_equal(inp.pd_idx[order], ref.pd_idx[order0])
                and np.array_equal(inp.pd_gain[order], ref.pd_gain[order0])):
            got = [(int(a), *map(float, g)) for a, g in zip(inp.pd_idx[order], inp.pd_gain[order])]
            want = [(int(a), *map(float, g)) for a, g in zip(ref.pd_idx[order0], ref.pd_gain[order0])]
            raise bad(f"{where} PDTracking (node, stiffness, damping)", got,
                      f"the same PD-tracked nodes and gains as setups[0] {want} (targets may differ)")
        if s.damping != s0.damping:
            raise bad(f"{where}.damping", s.damping, f"the same damping as setups[0] ({s0.damping})")
        if not (np.array_equal(inp.tendon_route, ref.tendon_route) and np.array_equal(inp.tendon_end, ref.tendon_end)):
            raise bad(f"{where}.tendons", [td.name for td in s.tendons],
                      "tendons routed as in setups[0] (same offsets, routing and terminations; tensions may differ)")
        if not np.array_equal(inp.tendon_stiffness, ref.tendon_stiffness):
            raise bad(f"{where}.tendons", [td.name for td in s.tendons],
                      "tendons driven as in setups[0] (the same tendons by a displacement, with the same stiffness; "
                      "tensions and displacements may differ)")
        if _drive(s) != _drive(s0):
            raise bad(f"{where}.boundary", s.boundary, f"a hub driven as in setups[0] (node, kind, mass, inertia "
                                                       f"{_drive(s0)}; forces and torques may differ)")
        varying = callable(s.gravity)
        if varying != callable(s0.gravity) or (not varying and s.gravity != s0.gravity):
            raise bad(f"{where}.gravity", s.gravity, f"the same constant gravity as setups[0] ({s0.gravity}), "
                                                     "or a time function in every setup (they may differ)")
        _check_contact(where, inp.contact, ref.contact)


def _check_contact(where: str, contact: dict | None, first: dict | None) -> None:
    """Refuse a setup whose obstacles the batch cannot step beside setups[0]'s (``SetupInputs.contact``
    of both): obstacles in one and not the other, another number of kernel columns, another
    contact stiffness or damping."""
    if (contact is None) != (first is None):
        raise bad(f"{where}.contact", "None" if contact is None else "obstacles",
                  "obstacles in every setup of a batch or in none, as setups[0]")
    if contact is None:
        return
    o, o0 = len(contact["contact_kind"]), len(first["contact_kind"])
    if o != o0:
        raise bad(f"{where}.contact", f"{o} kernel columns", f"as many as setups[0] ({o0}; an obstacle is one, a "
                                                             "bifurcation two, self-contact one): the same number "
                                                             "of obstacles, their shapes may differ")
    if not np.array_equal(contact["contact_node"], first["contact_node"]):
        raise bad(f"{where}.contact", "another contact stiffness or damping", "the same contact stiffness and "
                                                                              "damping as setups[0]")


def _drive(setup: Setup) -> tuple | None:
    """(node, kernel kind, mass [kg], inertia [kg m^2]) of a setup's driven hub (``rod.hub``), or None."""
    found = driven_hub(setup)
    return None if found is None else (found[0], found[1].kind, found[1].mass, found[1].inertia)


def _checked(setups: Sequence[Setup], config: RunConfig) -> list[Setup]:
    """The setups as a list, or a one-line error for a wrong type or an empty batch."""
    setups = list(setups)
    if not setups:
        raise bad("setups", setups, "at least one Setup")
    for b, s in enumerate(setups):
        if not isinstance(s, Setup):
            raise bad(f"setups[{b}]", type(s).__name__, "a softrnn.rod.Setup")
        if any(isinstance(load, MagneticDipoles) for load in s.loads):
            raise bad(f"setups[{b}].loads", "MagneticDipoles", "no magnetic load in a batch (run such setups one by "
                                                               "one with Simulator)")
    if not isinstance(config, RunConfig):
        raise bad("config", type(config).__name__, "a softrnn.rod.RunConfig")
    if not isinstance(config.integrator, Explicit):
        raise bad("config.integrator", str(config.integrator),
                  "'explicit': a batch runs the explicit integrator (run stiff rods one by one with Simulator)")
    return setups


class _Batch:
    """One batch run: the shared rod, each rod's inputs mapped onto a shared load layout (the
    union of loaded nodes; the PD entries in canonical order), the stacked state and outputs."""

    def __init__(self, setups: list[Setup], rod, inputs: list[SetupInputs], h: float, substeps: int,
                 nodes: np.ndarray, n_samples: int):
        self.rod, self.inputs, self.h, self.substeps = rod, inputs, h, substeps
        self.ext_idx = np.array(sorted(set().union(*(i.ext_idx.tolist() for i in inputs))), dtype=np.int64)
        self.ext_cols = [np.searchsorted(self.ext_idx, i.ext_idx) for i in inputs]
        self.pd_orders = [_pd_order(i) for i in inputs]
        self.pd_idx = np.ascontiguousarray(inputs[0].pd_idx[self.pd_orders[0]])
        self.pd_gain = np.ascontiguousarray(inputs[0].pd_gain[self.pd_orders[0]]).reshape(-1, 2)
        states = [initial_state(s, rod, i) for s, i in zip(setups, inputs)]
        # as Simulator.run does for a fresh simulator: the half kick (rest start to second order)
        for st, i in zip(states, inputs):
            first = i.at(np.array([st.time]), h)
            if i.contact is not None:
                first = i.with_contact(first, st.contact_segment, np.zeros((0, 0, 6)))
            half_kick(rod, st, first, h)
        self.t0 = states[0].time  # fresh states all start at 0
        self.state = StateArrays(*(np.stack(a) for a in zip(*(st.arrays() for st in states))))
        B = len(setups)
        self.out = empty_samples(save_slots(rod.kind.size, nodes), n_samples, nodes.size, lead=(B,))
        self.status = np.zeros((B, 2), dtype=np.int64)
        self.tensions = np.zeros((B, n_samples, len(setups[0].tendons))) if inputs[0].displaced else None
        self.contact = None if inputs[0].contact is None else _stacked_contact(
            inputs, [st.contact_segment for st in states], n_samples, nodes.size)

    def step_inputs(self, t: np.ndarray) -> StepInputs:
        """Every rod's inputs at times t (K,) [s] in the shared layout, stacked (B, ...)."""
        B, K, q = len(self.inputs), t.size, self.inputs[0].presc_idx.size
        ext_w = np.zeros((B, K, self.ext_idx.size, 12))
        pd_target = np.zeros((B, K, self.pd_idx.size, 3))
        presc_r = np.zeros((B, K + 1, q, 3))
        presc_R = np.zeros((B, K + 1, q, 3, 3))
        tension = np.zeros((B, K, self.inputs[0].tendon_end.size))
        displacement = np.zeros((B, K, self.inputs[0].tendon_stiffness.size))
        for b, inputs in enumerate(self.inputs):
            one = inputs.at(t, self.h)
            ext_w[b][:, self.ext_cols[b]] = one.ext_w
            pd_target[b] = one.pd_target[:, self.pd_orders[b]]
            presc_r[b] = one.presc_r
            presc_R[b] = one.presc_R
            tension[b] = one.tendon_tension
            displacement[b] = one.tendon_displacement
        return StepInputs(ext_idx=self.ext_idx, ext_w=ext_w, pd_idx=self.pd_idx, pd_target=pd_target,
                          pd_gain=self.pd_gain, presc_idx=self.inputs[0].presc_idx, presc_r=presc_r,
                          presc_R=presc_R, tendon_route=self.inputs[0].tendon_route,
                          tendon_end=self.inputs[0].tendon_end, tendon_tension=tension,
                          tendon_stiffness=self.inputs[0].tendon_stiffness, tendon_rest=self.inputs[0].tendon_rest,
                          tendon_displacement=displacement, **({} if self.contact is None else self.contact))

    def advance(self, state: StateArrays, k0: int, n_steps: int) -> None:
        """Steps k0 .. k0 + n_steps - 1 of every rod; SimulationError naming the first failed rod."""
        t = self.t0 + (k0 + np.arange(n_steps)) * self.h
        self.status[:] = 0
        inputs = self.step_inputs(t)
        over_rods(kernels.advance_batch, len(self.inputs), self.rod, state, inputs, self.out, self.h, k0, n_steps,
                  self.substeps, 0, self.status)
        for b, (code, step) in enumerate(self.status):
            raise_for_status(int(code), step=int(step), t0=self.t0, h=self.h, where=f"setups[{b}]: ")
        if self.tensions is not None:  # the tensions applied at the saved steps
            k = k0 + np.arange(n_steps)
            saved = k % self.substeps == 0
            self.tensions[:, k[saved] // self.substeps] = inputs.tendon_tension[:, saved]

    def trajectories(self, times: np.ndarray, nodes: np.ndarray, wall: float) -> list[Trajectory]:
        """One ``Trajectory`` per rod (views of the batch's output buffers)."""
        loads = self.contact["contact_samples"] if self.contact is not None else None
        return [Trajectory(time=times.copy(), nodes=nodes.copy(), step=self.h, substeps=self.substeps,
                           wall_time=wall, tendon_tensions=None if self.tensions is None else self.tensions[b],
                           contact_forces=None if loads is None else loads[b, ..., :3],
                           contact_torques=None if loads is None else loads[b, ..., 3:],
                           **{name: getattr(self.out, name)[b] for name in SAMPLE_FIELDS})
                for b in range(len(self.inputs))]


def _stacked_contact(inputs: list[SetupInputs], segments: list[np.ndarray], n_samples: int, n_saved: int) -> dict:
    """The rods' contact fields of ``StepInputs``, stacked (B, ...): each rod's static ones
    (``SetupInputs.contact``), its centrelines and mesh arrays zero-padded to the longest rod's (the
    kernels reach them through contact_range only), its tracked segments (n, o) (``segments``), the
    buffer of its contact loads at the samples (S, s, 6) and its scratch (n, 6)."""
    stacked = {}
    for name in inputs[0].contact:
        arrays = [i.contact[name] for i in inputs]
        size = max(len(a) for a in arrays)
        stacked[name] = np.stack([np.concatenate([a, np.zeros((size - len(a),) + a.shape[1:], dtype=a.dtype)])
                                  for a in arrays])
    B, n = len(inputs), len(segments[0])
    return dict(stacked, contact_segment=np.stack(segments), contact_samples=np.zeros((B, n_samples, n_saved, 6)),
                contact_applied=np.zeros((B, n, 6)))


def simulate_batch(setups: Sequence[Setup], config: RunConfig,
                   progress: Progress | None = None) -> list[Trajectory]:
    """Simulate several compatible setups at once (in parallel over rods) from their initial shapes
    at rest; returns one ``Trajectory`` per setup, in order, each equal to ``simulate(setup,
    config)``. ``wall_time`` of every trajectory is the wall time of the whole batch.

    Raises SoftrnnInputError if the setups differ in anything but initial shape, loads, PD targets,
    prescribed motions and obstacles (module docstring); SimulationError (naming the setup) if a rod
    diverges.
    ``progress(samples_done, n_samples)`` is called after every chunk.
    """
    setups = _checked(setups, config)
    inputs = [SetupInputs(s) for s in setups]
    _check_compatible(setups, inputs)
    rod = with_hub(lumped_rod(setups[0]), setups[0])
    B, S = len(setups), config.n_samples
    # the rods' stable step: the rod's, with obstacles their contact springs' too (the same in every rod)
    substeps = choose_substeps(config, Simulator(setups[0]).stable_step(config.safety))
    nodes = save_nodes(setups[0], config)
    chunk = max(substeps, (_CHUNK_ROD_STEPS // B // substeps) * substeps)
    contact_bytes = 0 if inputs[0].contact is None else B * S * nodes.size * 6 * 8
    check_run_size(n_samples=S, dt=config.dt, substeps=substeps, n_saved=nodes.size, held_samples=S,
                   chunk_steps=chunk, step_bytes=max(i.step_bytes() for i in inputs), batch=B,
                   extra_bytes=contact_bytes, streamable=False, auto_substeps=config.substeps is None)
    batch = _Batch(setups, rod, inputs, config.dt / substeps, substeps, nodes, S)
    total = (S - 1) * substeps
    start = time.perf_counter()
    done = 0
    while done < total:
        k = min(chunk, total - done)
        batch.advance(batch.state, done, k)
        done += k
        if progress is not None:
            progress(min(done // substeps + 1, S), S)
    # last sample: its mid-step velocity needs one more step, taken on a copy of the state
    batch.advance(StateArrays(*(a.copy() for a in batch.state)), total, 1)
    wall = time.perf_counter() - start
    if progress is not None:
        progress(S, S)
    return batch.trajectories(batch.t0 + config.dt * np.arange(S), nodes, wall)
