"""A free run of a whole-manipulator model as a data set of every node (``softrnn animate``), and the
checks of its span before any work (``check_window``, ``rollout_steps``, ``rollout_bytes``)."""

from __future__ import annotations

import numpy as np

from ...errors import bad
from ...io.reader import Dataset
from ...io.schema import POSITION_LIMIT_M
from ..baselines import free_run
from ..horizons import RolloutDiverged
from ..rollout import predicted_attrs, reference_columns


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
    try:
        states, diverged = free_run(model.engine, traj, None, start + 1, traj.n_steps if stop is None else stop), None
    except RolloutDiverged as exc:                      # its states: NaN from the divergence on
        states, diverged = exc.states, exc.sample - start
    ok = np.all(np.isfinite(states), axis=(1, 2))
    states = np.concatenate([traj.states[start:start + 1], states[:int(np.argmin(ok)) if not ok.all() else None]])
    positions, quaternions = enc.decode(states)
    inside = np.all(np.abs(positions) < POSITION_LIMIT_M, axis=(1, 2))
    n = int(np.argmin(inside)) if not inside.all() else len(states)
    rows = (start + np.arange(n)) * enc.stride(float(dataset.dt))
    extra = predicted_attrs(dataset.attrs, ("softrnn_version", "schema_version"), {
        "dt": enc.model_dt, "prediction": True, "rollout": "dynamic", "model_dt_s": enc.model_dt,
        "start_time_s": float(traj.time[start]), **(attrs or {})})
    ds = Dataset(time=traj.time[start:start + n], nodes=np.arange(enc.n_nodes), positions=positions[:n],
                 quaternions=quaternions[:n], attrs=extra, **reference_columns(dataset, rows))
    return ds, diverged


def check_window(time: np.ndarray, start_time, stop_time) -> None:
    """Refuse, from the data's time axis ``time`` (T,) [s] alone, a ``start_time`` or ``stop_time`` [s]
    that is not a time inside the data: a free run needs the data's loads."""
    eps = 1e-9 * max(1.0, abs(float(time[-1])))
    for name, value in (("start_time", start_time), ("stop_time", stop_time)):
        if value is not None and not (np.isfinite(value) and time[0] - eps <= value <= time[-1] + eps):
            raise bad(name, value, f"a time from the data's start ({time[0]:g} s) up to the data's end "
                                   f"({time[-1]:g} s): the model runs free on the data's loads, not past them")


def rollout_steps(time: np.ndarray, history: int, start_time, stop_time) -> tuple[int, int]:
    """Model steps ``start`` (the last data state; None: at 0.6 of the data) and ``stop`` (exclusive;
    None: the end) for the times ``start_time``, ``stop_time`` [s] on the model's step times ``time`` (S,) [s]."""
    n_steps, eps = len(time), 1e-9 * max(1.0, abs(float(time[-1])))
    t = time
    stop = n_steps if stop_time is None else int(np.searchsorted(t, stop_time + eps, side="right"))
    if stop_time is not None and not stop_time <= t[-1] + eps:
        raise bad("stop_time", stop_time, f"a time up to the data's end ({t[-1]:g} s)")
    start = int(round(0.6 * (n_steps - 1))) if start_time is None else \
        int(np.searchsorted(t, start_time + eps, side="right")) - 1
    first = history - 1
    if start < first or start > n_steps - 2:
        raise bad("start_time", start_time, f"a time from {t[first]:g} s (the model reads {history} states) to "
                                            f"{t[-2]:g} s (one model step before the end)")
    if stop < start + 2:
        raise bad("stop_time", stop_time, f"a time after the start ({t[start]:g} s) by a model step "
                                          f"({t[start + 1] - t[start]:g} s) or more")
    return start, stop


def rollout_bytes(model, axis, k: int, start: int, stop: int) -> tuple[int, int]:
    """(every array of a rollout, the data's) [bytes]: the data read whole, its encoded trajectory, the
    free run from model step ``start`` to ``stop`` and the data set written; ``axis``: the data's time
    axis (``read_dataset(..., nodes=[])``), ``k``: the model's step in data samples."""
    enc, T = model.encoding, axis.n_samples
    N, M, span = enc.n_nodes, enc.n_kept, stop - start
    data = T * (8 + 4 * (13 * N + axis.n_actuation) + 8 * 3 * N)      # float32 arrays, float64 forces copy
    encoded = ((T - 1) // k + 1) * M * (6 + enc.load_width) * 8
    run = (model.engine.history + span) * M * 6 * 8 + span * N * (7 * 8 + 13 * 4)
    return data + encoded + run, data
