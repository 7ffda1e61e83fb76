"""Batched simulation: many independent rods of the same design advanced together.

``simulate_batch`` runs ``kernels.advance_batch``, which steps the rods in parallel (numba
``prange``, one rod per iteration; set the thread count with ``numba.set_num_threads``). The
rods must share everything the kernel shares between them: rod spec, stress-free reference shape,
boundary node kinds and the nodes with prescribed motion, the PD-tracked nodes and their gains,
damping and gravity. Initial shapes, nodal loads, PD targets and prescribed motions may differ.
Each rod gives the same trajectory as ``simulate`` would (up to rounding in the order of summing
loads on one node).

The per-rod inputs (loads, PD targets, prescribed poses) are evaluated by ordinary ``Simulator``
instances chunk by chunk, exactly as in ``Simulator.run``.
"""

import time
from collections.abc import Callable, Sequence

import numpy as np

from ..errors import SimulationError, bad
from . import kernels
from .simulation import RunConfig, Setup, Simulator, Trajectory, _raise_on_status, check_run_size

_OUT_VECTORS = ("r", "v", "w", "f", "t", "rf", "rt")
# rod-steps per kernel call: the per-chunk input arrays hold B x K steps (ext_w alone is
# B K m 12 doubles), so the steps per chunk shrink as the batch grows
_CHUNK_ROD_STEPS = 65536


def _pd_order(sim: Simulator) -> np.ndarray:
    """Canonical order of a simulator's PD entries: by node, then gains."""
    g = sim.pd_gain
    return np.lexsort((g[:, 1], g[:, 0], sim.pd_idx)) if sim.pd_idx.size else np.zeros(0, dtype=np.int64)


def _check_compatible(sims: list[Simulator]) -> None:
    """Raise SoftrnnInputError naming the first property in which a setup differs from setups[0]."""
    ref = sims[0]
    s0 = ref.setup
    order0 = _pd_order(ref)
    for b, sim in enumerate(sims[1:], start=1):
        s = sim.setup
        where = f"setups[{b}]"
        if s.rod != s0.rod:
            raise bad(f"{where}.rod", s.rod, f"the same RodSpec as setups[0] ({s0.rod}); "
                      f"a batch shares one rod design, run different rods in separate batches")
        if not (np.array_equal(s.reference.positions, s0.reference.positions)
                and np.array_equal(s.reference.rotations, s0.reference.rotations)):
            raise bad(f"{where}.reference", "a different reference shape",
                      "the same stress-free reference shape as setups[0] (initial shapes may differ)")
        if not np.array_equal(sim.kind, ref.kind):
            raise bad(f"{where}.boundary", s.boundary,
                      f"the same constrained nodes and kinds (Clamp/Pin) as setups[0] ({s0.boundary})")
        if not np.array_equal(sim.presc_idx, ref.presc_idx):
            raise bad(f"{where}.boundary", s.boundary,
                      f"prescribed motions on the same nodes as setups[0] "
                      f"(nodes {ref.presc_idx.tolist()}, this setup has {sim.presc_idx.tolist()})")
        order = _pd_order(sim)
        if not (np.array_equal(sim.pd_idx[order], ref.pd_idx[order0])
                and np.array_equal(sim.pd_gain[order], ref.pd_gain[order0])):
            got = [(int(a), *map(float, g)) for a, g in zip(sim.pd_idx[order], sim.pd_gain[order])]
            want = [(int(a), *map(float, g)) for a, g in zip(ref.pd_idx[order0], ref.pd_gain[order0])]
            raise bad(f"{where} PDTracking (node, stiffness, damping)", got,
                      f"the same PD-tracked nodes and gains as setups[0] {want} (targets may differ)")
        if s.damping != s0.damping:
            raise bad(f"{where}.damping", s.damping, f"the same damping as setups[0] ({s0.damping})")
        if s.gravity != s0.gravity:
            raise bad(f"{where}.gravity", s.gravity, f"the same gravity as setups[0] ({s0.gravity})")


def simulate_batch(setups: Sequence[Setup], config: RunConfig,
                   progress: Callable[[int, int], None] | None = None) -> list[Trajectory]:
    """Simulate several compatible setups at once (in parallel over rods) from their initial shapes
    at rest; returns one ``Trajectory`` per setup, in order, each equal to ``simulate(setup,
    config)``. ``wall_time`` of every trajectory is the wall time of the whole batch.

    Raises SoftrnnInputError if the setups differ in anything but initial shape, loads, PD targets
    and prescribed motions; SimulationError (naming the setup) if a rod diverges.
    ``progress(samples_done, n_samples)`` is called after every chunk.
    """
    setups = list(setups)
    if not setups:
        raise bad("setups", setups, "at least one Setup")
    for b, s in enumerate(setups):
        if not isinstance(s, Setup):
            raise bad(f"setups[{b}]", type(s).__name__, "a softrnn.rod.Setup")
    if not isinstance(config, RunConfig):
        raise bad("config", type(config).__name__, "a softrnn.rod.RunConfig")
    sims = [Simulator(s) for s in setups]
    _check_compatible(sims)
    ref = sims[0]
    B = len(sims)

    substeps = ref.resolve_substeps(config)
    h = config.dt / substeps
    n = ref.setup.rod.n_nodes
    nodes = np.arange(n) if config.save_nodes is None else np.array(
        [ref.setup.node_index(a, "save_nodes") for a in config.save_nodes], dtype=np.int64)
    chunk = max(substeps, (_CHUNK_ROD_STEPS // B // substeps) * substeps)
    check_run_size(n_samples=config.n_samples, dt=config.dt, substeps=substeps, n_saved=nodes.size,
                   held_samples=config.n_samples, chunk_steps=chunk,
                   step_bytes=max(sim.step_input_bytes() for sim in sims), batch=B,
                   streamable=False, auto_substeps=config.substeps is None)
    slot = np.full(n, -1, dtype=np.int64)
    slot[nodes] = np.arange(nodes.size)
    S, s = config.n_samples, nodes.size
    out = {name: np.zeros((B, S, s, 3)) for name in _OUT_VECTORS}
    out_q = np.zeros((B, S, s, 4))
    out_e = np.zeros((B, S, 3))

    # shared load layout: the union of loaded nodes; each rod's columns go to their place
    ext_idx = np.array(sorted(set().union(*(sim.ext_idx.tolist() for sim in sims))), dtype=np.int64)
    ext_cols = [np.searchsorted(ext_idx, sim.ext_idx) for sim in sims]
    pd_orders = [_pd_order(sim) for sim in sims]
    pd_idx = np.ascontiguousarray(ref.pd_idx[pd_orders[0]])
    pd_gain = np.ascontiguousarray(ref.pd_gain[pd_orders[0]]).reshape(-1, 2)

    # as Simulator.run does for a fresh simulator: the half kick (rest start to second order)
    for sim in sims:
        if sim.steps_done == 0:
            sim._half_kick(h)
    state = {
        "R": np.stack([sim.state.rotations for sim in sims]),
        "r": np.stack([sim.state.positions for sim in sims]),
        "v": np.stack([sim.state.velocities for sim in sims]),
        "w": np.stack([sim.state.angular_velocities for sim in sims]),
        "Kp": np.stack([sim.state.prev_curvature for sim in sims]),
        "Gp": np.stack([sim.state.prev_shear for sim in sims]),
    }
    t0 = ref.state.time  # fresh simulators all start at 0
    status = np.zeros((B, 2), dtype=np.int64)

    def advance(st, k0, n_steps):
        t = t0 + (k0 + np.arange(n_steps)) * h
        q = ref.presc_idx.size
        ext_w = np.zeros((B, n_steps, ext_idx.size, 12))
        pd_target = np.zeros((B, n_steps, pd_idx.size, 3))
        presc_r = np.zeros((B, n_steps + 1, q, 3))
        presc_R = np.zeros((B, n_steps + 1, q, 3, 3))
        for b, sim in enumerate(sims):
            e, p, pr, pR = sim._chunk_inputs(t, h)
            ext_w[b][:, ext_cols[b]] = e
            pd_target[b] = p[:, pd_orders[b]]
            presc_r[b] = pr
            presc_R[b] = pR
        status[:] = 0
        kernels.advance_batch(
            st["R"], st["r"], st["v"], st["w"], st["Kp"], st["Gp"],
            ref.seg_length, ref.C1, ref.C2, ref.D1, ref.D2, ref.K0, ref.G0, ref.mass, ref.inertia,
            ref.ct, ref.cr, ref.gravity, ref.kind, ref.setup.damping.kelvin_voigt > 0,
            h, k0, n_steps, substeps, 0,
            ext_idx, ext_w, pd_idx, pd_target, pd_gain, ref.presc_idx, presc_r, presc_R,
            slot, out["r"], out_q, out["v"], out["w"], out["f"], out["t"], out["rf"], out["rt"], out_e,
            status)
        for b in range(B):
            try:
                _raise_on_status(int(status[b, 0]), int(status[b, 1]), t0, h)
            except SimulationError as exc:
                raise SimulationError(f"setups[{b}]: {exc}") from None

    total = (S - 1) * substeps
    start = time.perf_counter()
    done = 0
    while done < total:
        k = min(chunk, total - done)
        advance(state, done, k)
        done += k
        if progress is not None:
            progress(min(done // substeps + 1, S), S)
    # last sample: its mid-step velocity needs one more step, taken on a copy of the state
    probe = {key: a.copy() for key, a in state.items()}
    advance(probe, total, 1)
    wall = time.perf_counter() - start
    if progress is not None:
        progress(S, S)

    times = t0 + config.dt * np.arange(S)
    trajs = []
    for b in range(B):
        trajs.append(Trajectory(
            time=times.copy(), nodes=nodes.copy(), positions=out["r"][b], quaternions=out_q[b],
            velocities=out["v"][b], angular_velocities=out["w"][b], forces=out["f"][b], torques=out["t"][b],
            reaction_forces=out["rf"][b], reaction_torques=out["rt"][b], energy=out_e[b], step=h,
            substeps=substeps, wall_time=wall))
    return trajs
