"""Summaries of dataset files (``softrnn show``): layout, time axis, storage, per-node ranges, every value checked.

``describe`` returns a JSON-ready dict: ``path``, ``file_size_bytes``, ``kind``, ``groups``, ``group``,
``n_samples``, ``n_nodes``, ``n_nodes_total``, ``nodes``, ``time_start_s``, ``time_end_s``, ``duration_s``,
``dt_s``, ``dt_uniform`` (every step within 1e-6 dt of dt), ``stored_values`` (all arrays of all groups),
``bytes_per_value`` (file size / stored values), ``storage`` (per array: dtype, chunks, compression,
stored bytes), ``node_ranges`` (per summarised node: position min/max [m], max |force| [N], max |torque|
[N m], and with contact max |contact force| [N]), ``actuation`` (per channel, in column order: name,
unit, min and max; [] without actuation), ``contact`` (None without contact loads, else ``fields``
(the contact datasets), ``obstacles`` (their kinds, [] where not recorded), ``recorded`` (whether the
obstacles are stored), ``max_force_n`` and ``max_torque_nm`` over every sample and node), ``verified``
and ``attrs`` (with the obstacles' record as ``contact`` where stored).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..progress import Progress
from ._checks import _check_values, _layout, _root_info, _select
from ._h5files import _Reading
from .reader import read_dataset
from .schema import ACTUATION, CONTACT, CONTACT_FIELDS, FIELDS, TIME_CHUNK, DatasetError


def describe(path, *, group: str | None = None, max_nodes: int = 3, verify: bool = True,
             progress: Progress | None = None) -> dict:
    """Summary of a dataset file for ``softrnn show``, with ranges of ``max_nodes`` nodes (first, middle, last).

    Parameters
    ----------
    path : str or Path
        The dataset file.
    group : str or None
        Trajectory to summarise in a sweep file (default: its first).
    verify : bool
        Also read and check every value, block by block (False: the time axis and those nodes).
    progress : softrnn.progress.Progress or None
        With ``verify``: ``progress(done, n_samples)`` at the start and after each block.

    Returns
    -------
    dict (JSON-ready)
        The summary; its keys: the module docstring.
    """
    path = Path(path)
    with _Reading(path) as f:
        info = _root_info(f, path)
        if group in (None, "", "/") and info["kind"] == "sweep":
            if not info["groups"]:
                raise DatasetError(f"{path}: the sweep holds no trajectories")
            group = info["groups"][0]
        g, where = _select(f, path, group)
        T, N, attrs = _layout(g, path, where)
        units = attrs.pop("actuation_units")
        stored = g["nodes"][...]
        time = g["time"][...]
        total_values = sum(_stored_values(f[gname]) for gname in info["groups"])
        largest = _verify(g, path, where, time, stored, progress) if verify else {}
        contact = CONTACT in attrs
        arrays = ("time", "nodes") + FIELDS + ((ACTUATION,) if units else ()) + (CONTACT_FIELDS if contact else ())
        storage = {name: _storage(g[name]) for name in arrays}
        channels = _channels(g, units)
        contact = _contact(attrs[CONTACT], largest) if contact else None
    size = path.stat().st_size
    picks = sorted({0, N // 2, N - 1})[:max_nodes]
    ranges = _node_ranges(read_dataset(path, nodes=[int(stored[j]) for j in picks], group=where))
    _check_values(path, where, time, stored, {}, 0)
    dt = attrs["dt"]
    steps = np.diff(time)
    return {
        "path": str(path), "file_size_bytes": int(size), "kind": info["kind"], "groups": info["groups"],
        "group": where, "n_samples": int(T), "n_nodes": int(N), "n_nodes_total": attrs["n_nodes_total"],
        "nodes": stored.tolist(), "time_start_s": float(time[0]), "time_end_s": float(time[-1]),
        "duration_s": float(time[-1] - time[0]), "dt_s": dt,
        "dt_uniform": bool(steps.size == 0 or np.max(np.abs(steps - dt)) <= 1e-6 * dt),
        "stored_values": int(total_values), "bytes_per_value": size / max(total_values, 1),
        "storage": storage, "node_ranges": ranges, "actuation": channels, "contact": contact,
        "verified": bool(verify),
        "attrs": attrs,
    }


def _channels(g, units: dict) -> list[dict]:
    """Per actuation channel of group ``g`` (``units``: {name: unit} in column order): {name,
    unit, min, max} over the whole record, read block by block."""
    if not units:
        return []
    ds = g[ACTUATION]
    lo = np.full(len(units), np.inf)
    hi = -lo
    for a in range(0, ds.shape[0], TIME_CHUNK):
        block = ds[a:a + TIME_CHUNK].astype(np.float64)
        lo, hi = np.minimum(lo, block.min(axis=0)), np.maximum(hi, block.max(axis=0))
    return [{"name": n, "unit": u, "min": float(lo[j]), "max": float(hi[j])} for j, (n, u) in enumerate(units.items())]


def _contact(record: dict | None, largest: dict) -> dict:
    """The contact loads of a group (``record``: its stored obstacles, or None): the datasets, the
    obstacles' kinds, and the largest |contact force| [N] and |contact torque| [N m] that the check
    of every value found (``largest``; None where the values were not read)."""
    kinds = [o["kind"] for o in record["obstacles"]] if record is not None else []
    force, torque = CONTACT_FIELDS
    return {"fields": list(CONTACT_FIELDS), "obstacles": kinds, "recorded": record is not None,
            "max_force_n": largest.get(force), "max_torque_nm": largest.get(torque)}


def _stored_values(g) -> int:
    """Values stored in the arrays of trajectory group ``g``."""
    return sum(int(g[n].size) for n in ("time", "nodes") + FIELDS + (ACTUATION,) + CONTACT_FIELDS if n in g)


def _verify(g, path: Path, where: str, time, stored, progress: Progress | None = None) -> dict:
    """Read every array of group ``g`` block by block (``TIME_CHUNK`` samples: bounded memory) and
    check every value (``_check_values``); ``progress(done, T)`` at the start and after each block.
    Returns {contact field: largest norm of its vectors} for the contact fields the group holds."""
    step = max(1, TIME_CHUNK)
    T = time.shape[0]
    contact = tuple(n for n in CONTACT_FIELDS if n in g)
    largest = dict.fromkeys(contact, 0.0)
    if progress is not None:
        progress(0, T)
    for a in range(0, T, step):
        block = {name: g[name][a:a + step] for name in FIELDS + tuple(n for n in (ACTUATION,) if n in g) + contact}
        _check_values(path, where, time[a:a + step], stored, block, a)
        for name in contact:
            norms = np.sqrt((block[name].astype(np.float64) ** 2).sum(-1))
            largest[name] = max(largest[name], float(norms.max()) if norms.size else 0.0)
        if progress is not None:
            progress(min(a + step, T), T)
    return largest


def _storage(ds) -> dict:
    """How HDF5 dataset ``ds`` is stored: dtype, shape, chunks, filters and bytes on disk."""
    return {"dtype": ds.dtype.name, "shape": list(ds.shape), "chunks": list(ds.chunks) if ds.chunks else None,
            "compression": ds.compression, "compression_opts": ds.compression_opts,
            "shuffle": bool(ds.shuffle), "stored_bytes": int(ds.id.get_storage_size())}


def _node_ranges(part) -> list[dict]:
    """Per node of the ``Dataset`` ``part``: its position min/max [m] per axis (3,), and its
    largest |force| [N] and |torque| [N m]."""
    ranges = []
    for j in range(part.n_nodes):
        p = part.positions[:, j].astype(np.float64)
        ranges.append({
            "node": int(part.nodes[j]),
            "position_min_m": p.min(axis=0).tolist(), "position_max_m": p.max(axis=0).tolist(),
            "max_force_n": float(np.linalg.norm(part.forces[:, j].astype(np.float64), axis=1).max()),
            "max_torque_nm": float(np.linalg.norm(part.torques[:, j].astype(np.float64), axis=1).max()),
        })
        if part.has_contact:
            f = part.contact_forces[:, j].astype(np.float64)
            ranges[-1]["max_contact_force_n"] = float(np.linalg.norm(f, axis=1).max())
    return ranges
