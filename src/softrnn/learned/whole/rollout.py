"""A free run of a whole-manipulator model as a data set of every node (``softrnn animate``)."""

from __future__ import annotations

import numpy as np

from ...io.reader import Dataset
from ...io.schema import POSITION_LIMIT_M
from .evaluation import free_run


def rollout_dataset(model, dataset, start: int, stop: int | None = None, attrs: dict | None = None):
    """Run ``model`` (``load_dynamic``) free on ``dataset`` from model step ``start`` to ``stop``
    (exclusive; default: the end) with the data's loads.

    Returns (``Dataset``, diverged step or None): every node at the model's step times, the start
    state first, positions and unit quaternions decoded from the states, the data's forces and
    torques at those times. A run that diverges, or leaves the data format's position range, ends
    there. The data's metadata (rod, scenario, seed, its extra attrs) is kept, with ``dt`` the
    model's step, so ``write_dataset`` writes it as is; ``attrs`` are added."""
    enc = model.encoding
    traj = enc.trajectory(dataset)
    states, diverged = free_run(model.engine, traj, start, stop)
    ok = np.all(np.isfinite(states), axis=(1, 2))
    states = np.concatenate([traj.states[start:start + 1], states[:int(np.argmin(ok)) if not ok.all() else None]])
    positions, quaternions = enc.decode(states)
    inside = np.all(np.abs(positions) < POSITION_LIMIT_M, axis=(1, 2))
    n = int(np.argmin(inside)) if not inside.all() else len(states)
    rows = (start + np.arange(n)) * enc.stride(float(dataset.dt))
    extra = {key: v for key, v in dataset.attrs.items() if key not in ("softrnn_version", "schema_version")}
    extra.update(dt=enc.model_dt, prediction=True, rollout="dynamic", model_dt_s=enc.model_dt,
                 start_time_s=float(traj.time[start]), **(attrs or {}))
    ds = Dataset(time=traj.time[start:start + n], nodes=np.arange(enc.n_nodes), positions=positions[:n],
                 quaternions=quaternions[:n], forces=dataset.forces[rows], torques=dataset.torques[rows], attrs=extra,
                 actuation=dataset.actuation[rows], actuation_units=dataset.actuation_units)
    return ds, diverged
