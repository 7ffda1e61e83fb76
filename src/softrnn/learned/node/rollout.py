"""Free-running rollouts of per-node surrogates: one node, or the whole manipulator (paper Fig. 2C).

A ``Manipulator`` is a set of node models, each predicting one node's next position from the last
``history`` samples of its own and its neighbours' poses (and the wrenches on it). Several nodes may
share one model object (beyond the paper: one model applied to every interior node, its neighbours
taken at the same offsets as in its ``spec``). ``rollout`` steps them together:

* **Seed.** The ``history`` samples before ``start`` are copied from the reference data set.
* **Step k.** Every modelled node's input window is gathered from the state (rows k-H .. k-1),
  every model predicts, and only then are the new positions written to row k: a synchronous
  (Jacobi) update, so the order of the models does not matter and every node sees its neighbours'
  *predictions* of the previous steps, never the reference's. Trained ``NodeModel`` s run in the
  compiled inference engine (``softrnn.learned.node.engine``): the models of one architecture are
  stacked and the whole span runs inside one call. Other model objects (anything with ``spec``
  and ``predict``) get one batched ``predict`` per distinct model and step.
* **Nodes without a model** follow the reference data set (``unmodelled="reference"``, default):
  for clamped boundary nodes this is exactly their boundary condition, for any other node the
  rollout is then driven by that node's recorded motion. ``unmodelled="hold"`` instead keeps them
  at their last seed pose (a clamp's boundary condition, using no reference data after the seed);
  it is only meaningful when every moving node is modelled.
* **Inputs the models do not predict** come from the reference: the wrenches (forces/torques are
  inputs of the system, known in advance) and, for models with ``inputs="poses"``, the
  quaternions of every node (the models predict positions only; this uses reference orientations
  during the free run, and the written file's orientations are the reference's too).

The window layout mirrors ``softrnn.learned.node.data.make_windows``: for a target at sample k the
pose features of step j (rows k-H .. k-1) are the positions (``inputs="poses"``: position then
quaternion) of ``[node, *neighbours]`` concatenated; the wrench features are the node's own force
(``wrench="force"``) or force then torque (``"wrench"``) at the same rows. ``tests/
test_surrogate_eval.py`` checks that the two agree on reference data.

The state is float32, like the data sets and the models' training windows, so a rollout driven by
a perfect model reproduces the reference bit for bit.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...errors import SimulationError, bad
from ...io.reader import Dataset
from ...io.schema import RESERVED_ATTRS
from ...io.writer import write_trajectory
from ...progress import Progress
from .. import spans
from ..horizons import DIVERGED_M
from ..rollout import predicted_attrs, reference_columns
from ..threads import torch_threads
from .engine import engine_rollout, group_by_architecture
from .manipulator import (
    UNMODELLED,
    _as_manipulator,
    _column_lookup,
    _compiled,
    _diverged,
    _stored,
    bind,
    describe_model,
)


# --------------------------------------------------------------------------------------- rollout
@dataclass(frozen=True, eq=False)
class Rollout:
    """A free-running prediction of every stored node (``time``, ``nodes`` and ``positions`` as in
    ``softrnn.io.Dataset``)."""

    time: np.ndarray
    """Sample times (T,) [s], float64: the reference's samples ``first .. stop-1``."""
    nodes: np.ndarray
    """The reference's stored nodes (N,), int64."""
    positions: np.ndarray
    """Positions (T, N, 3) [m], float32: rows ``0 .. seed-1`` are the reference (the seed history),
    later rows of the modelled nodes are predictions, and the unmodelled nodes follow the reference
    (or hold their last seed pose, ``unmodelled="hold"``)."""
    first: int
    """Reference sample index of row 0 (``start - seed``)."""
    seed: int
    """Rows of seed history (the manipulator's longest history)."""
    modelled: tuple
    """The predicted nodes (int)."""
    unmodelled: str
    """'reference' or 'hold'."""

    @property
    def start(self) -> int:
        """Reference sample index of the first predicted row."""
        return self.first + self.seed

    @property
    def stop(self) -> int:
        """Reference sample index one past the last row."""
        return self.first + int(self.time.shape[0])

    def node_positions(self, node: int, predicted_only: bool = True) -> np.ndarray:
        """(T', 3) [m] float64 positions of ``node``: the predicted rows only (default), or all."""
        hits = np.flatnonzero(self.nodes == int(node))
        if hits.size == 0:
            raise bad("node", node, f"a stored node: {_stored(self.nodes)}")
        p = self.positions[self.seed if predicted_only else 0:, int(hits[0])]
        return p.astype(np.float64)


def check_span(n_samples: int, history: int, start, stop, where: str = "the data set") -> tuple[int, int]:
    """Validated (start, stop) of the predicted samples: start >= history (the seed lies before
    it), stop <= n_samples, at least one sample; None: start = history, stop = n_samples
    (``softrnn.learned.spans``, in a rollout's words)."""
    spans.check_length(n_samples, history, where)
    start = history if start is None else start
    stop = n_samples if stop is None else stop
    return spans.check_span(n_samples, history, start, stop, wording=spans.SEEDS)


def rollout(models, dataset, start: int | None = None, stop: int | None = None, *,
            unmodelled: str = "reference", threads: int | None = 1, progress: Progress | None = None,
            engine: bool = True) -> Rollout:
    """Free-running prediction of samples ``start .. stop-1`` of ``dataset`` by node models.

    ``models``: a ``Manipulator``, a ``NodeModel`` or a list of them (each predicts its ``spec.node``).
    ``dataset`` gives the seed history (rows ``start-H .. start-1``), the wrenches, quaternions and the
    unmodelled nodes, which follow it (``unmodelled="reference"``) or hold their last seed pose (``"hold"``).
    ``start``, ``stop``: sample indices (defaults H and T). ``engine``: trained models run in the
    compiled engine (``softrnn.learned.node.engine``), else ``predict`` per model and step
    under ``threads`` torch threads. ``progress(done, total)`` every 256 steps (4096 with the engine);
    the update scheme: the module docstring, docs/guide/models.md#the-whole-manipulator-paper-fig-2c.

    Returns
    -------
    Rollout
        Rows ``start-H .. stop-1`` (H = ``manipulator.history``); positions (T', N, 3) float32 [m].
        A non-finite predicted position, or one beyond ``DIVERGED_M``, raises ``RolloutDiverged``.
    """
    manip = _as_manipulator(models)
    if unmodelled not in UNMODELLED:
        raise bad("unmodelled", unmodelled, "'reference' or 'hold'")
    groups = bind(manip, dataset)
    H = manip.history
    start, stop = check_span(dataset.n_samples, H, start, stop)
    first = start - H
    state, quats, forces, torques = _seeded_state(dataset, groups, H, first, stop, unmodelled)
    act = getattr(dataset, "actuation", None)
    act = None if act is None else act[first:stop]           # (T', m) the actuation inputs, as recorded
    step = _engine_steps if engine and all(_compiled(g.model) for g in groups) else _python_steps
    step(groups, state, quats, forces, torques, H=H, total=stop - start, time=dataset.time, first=first,
         threads=threads, progress=progress, actuation=act)
    return Rollout(time=np.asarray(dataset.time[first:stop], dtype=np.float64), nodes=np.asarray(dataset.nodes),
                   positions=state, first=first, seed=H, modelled=manip.nodes, unmodelled=unmodelled)


def _seeded_state(dataset, groups, H: int, first: int, stop: int, unmodelled: str) -> tuple:
    """The rollout's state (T', N, 3) float32 [m], seeded with the reference's rows ``first ..
    first+H-1``, the modelled nodes' later rows NaN (written step by step; a read before the write
    would show), the unmodelled nodes' later rows the reference's (or their last seed pose,
    ``"hold"``); and the reference's quaternions (T', N, 4), forces and torques (T', N, 3) of the
    span, which the models do not predict."""
    state = np.array(dataset.positions[first:stop], dtype=np.float32, copy=True)   # (T', N, 3)
    quats = dataset.quaternions[first:stop]
    if unmodelled == "hold":
        quats = np.array(quats, dtype=np.float32, copy=True)
    forces, torques = dataset.forces[first:stop], dataset.torques[first:stop]
    modelled_cols = np.concatenate([g.target_cols for g in groups])
    if unmodelled == "hold":
        others = np.setdiff1d(np.arange(state.shape[1]), modelled_cols)
        state[H:, others] = state[H - 1, others]
        quats[H:, others] = quats[H - 1, others]
    state[H:, modelled_cols] = np.nan   # written step by step; a read before the write would show
    return state, quats, forces, torques


def _engine_steps(groups, state, quats, forces, torques, *, H: int, total: int, time, first: int,
                  threads, progress, actuation=None) -> None:
    """Rows ``H .. H+total-1`` of ``state`` predicted in place by the compiled engine, in chunks of
    4096 steps so progress is reported during long rollouts (``threads`` is not used)."""
    bound = group_by_architecture(groups)
    done = 0
    while done < total:
        k0 = H + done
        k1 = min(H + total, k0 + 4096)
        status, node, k = engine_rollout(bound, state, quats, forces, torques, k0, k1, DIVERGED_M, actuation)
        if status:
            _diverged(node, float(time[first + k]), first + k)
        done = k1 - H
        if progress is not None:
            progress(done, total)


def _python_steps(groups, state, quats, forces, torques, *, H: int, total: int, time, first: int,
                  threads, progress, actuation=None) -> None:
    """Rows ``H .. H+total-1`` of ``state`` predicted in place by one batched ``predict`` per
    model and step, a synchronous update (every window is read before any row is written)."""
    with torch_threads(threads):
        for k in range(H, H + total):
            outputs = [_predict_group(g, state, quats, forces, torques, k, time, first, actuation) for g in groups]
            for g, pred in zip(groups, outputs):   # synchronous update: all windows were read first
                state[k, g.target_cols] = pred
            if progress is not None and ((k - H + 1) % 256 == 0 or k == H + total - 1):
                progress(k - H + 1, total)


def _predict_group(g, state, quats, forces, torques, k: int, time, first: int, actuation=None) -> np.ndarray:
    """The next positions (n, 3) float64 [m] of group ``g``'s n nodes at row ``k``, checked for
    shape and divergence (``actuation`` (T', m): the span's actuation inputs)."""
    poses, wrenches = g.gather(state, quats, forces, torques, k, actuation)
    pred = np.asarray(g.model.predict(poses, wrenches), dtype=np.float64)
    if pred.shape != (g.nodes.size, 3):
        raise SimulationError(f"model ({describe_model(g.model)}) returned shape {pred.shape} for "
                              f"{g.nodes.size} nodes; expected ({g.nodes.size}, 3)")
    ok = np.isfinite(pred).all(axis=1) & (np.abs(pred) <= DIVERGED_M).all(axis=1)
    if not ok.all():
        _diverged(int(g.nodes[np.flatnonzero(~ok)[0]]), float(time[first + k]), first + k)
    return pred


# --------------------------------------------------------------------------------------- output
_COPIED = ("rod", "scenario_text", "seed", "dt", "n_nodes_total", "units", "softrnn_version",
           "scenario_record")
"""The reference's attributes a node rollout's data set keeps as they are (the writer's own arguments)."""


def rollout_dataset(result: Rollout, reference, *, models: list[str] | None = None, source: str = ""):
    """The rollout as a ``Dataset`` (same nodes and times as the reference's rows ``first .. stop-1``):
    positions predicted, quaternions, forces, torques and actuation copied from the reference. Its attrs mark
    it as a prediction (``prediction``, ``models``, ``modelled_nodes``, ``first_predicted_sample``,
    ``predicted_from_s``, ``unmodelled``, ``orientations``, ``reference``), keep the reference's
    extra metadata and append ' (predicted)' to its ``scenario_name``."""
    sl = slice(result.first, result.stop)
    name = reference.attrs.get("scenario_name") or "data"
    keep = predicted_attrs(reference.attrs, RESERVED_ATTRS, {
        "scenario_name": f"{name} (predicted)",
        "prediction": True,
        "models": list(models or []),
        "modelled_nodes": [int(a) for a in result.modelled],
        "first_predicted_sample": int(result.seed),
        "predicted_from_s": float(result.time[result.seed]),
        "reference_first_sample": int(result.first),
        "unmodelled": result.unmodelled,
        "orientations": "copied from the reference (the models predict positions only)",
        "reference": str(source),
    })
    if "node_of_interest" not in keep or int(keep.get("node_of_interest", -1)) not in result.modelled:
        keep["node_of_interest"] = int(result.modelled[0])
    for key in _COPIED:
        if key in reference.attrs:
            keep[key] = reference.attrs[key]
    return Dataset(time=result.time, nodes=result.nodes, positions=result.positions,
                   quaternions=reference.quaternions[sl], attrs=keep, **reference_columns(reference, sl))


def write_rollout(path, result: Rollout, reference, *, models: list[str] | None = None, source: str = "") -> Path:
    """Write the rollout to ``path`` in the data set format (atomically; see ``rollout_dataset``),
    so ``softrnn animate`` and ``softrnn plot`` show it like the reference."""
    ds = rollout_dataset(result, reference, models=models, source=source)
    extra = {k: v for k, v in ds.attrs.items() if k not in _COPIED}
    seed = reference.attrs.get("seed")
    write_trajectory(path, ds, dt=reference.dt, rod=reference.attrs.get("rod"),
                     scenario_text=reference.attrs.get("scenario_text", "") or "",
                     seed=None if seed is None else int(seed), attrs=extra)
    return Path(path)


def max_error_mm(result: Rollout, reference) -> dict:
    """{node: largest |predicted - reference| over the predicted rows, per axis [mm] (3,)} for every
    modelled node."""
    out = {}
    ref = reference.positions[result.start:result.stop]
    lookup = _column_lookup(reference)
    for a in result.modelled:
        j = lookup[int(a)]
        err = np.abs(result.positions[result.seed:, j].astype(np.float64) - ref[:, j].astype(np.float64))
        out[int(a)] = err.max(axis=0) * 1e3
    return out
