"""Rod data for pictures: a dataset read for a picture (``load``), its fields checked, the samples of
a time span and of the frames, node indices resolved and described, the node of interest, and the
output suffixes.

A *dataset-like* object is anything with the attributes ``time`` (T,) [s], ``nodes`` (N,) node
indices, ``positions`` (T, N, 3) [m] and optionally ``forces`` (T, N, 3) [N] and ``attrs`` (dict);
a ``softrnn.io.Dataset`` and a ``softrnn.rod.Trajectory`` both fit.
"""

from __future__ import annotations

import math
import shutil
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from ..errors import SoftrnnInputError, bad
from ..io.reader import read_dataset, read_node
from ..io.record import read_record, scenario_name

ANIMATION_SUFFIXES = (".gif", ".mp4")
FIGURE_SUFFIXES = (".png", ".pdf", ".svg")
DEFAULT_MAX_FRAMES = 200


def _fields(data):
    """time (T,), nodes (N,), positions (T, N, 3), forces (T, N, 3) or None, attrs dict; validated."""
    try:
        time = np.asarray(data.time, dtype=float)
        positions = np.asarray(data.positions)  # float32 in files: kept, frames are converted one by one
    except AttributeError as err:
        raise SoftrnnInputError(f"data={type(data).__name__} is invalid: expected an object with time, nodes "
                                f"and positions (a softrnn dataset or trajectory)") from err
    nodes = np.asarray(getattr(data, "nodes", np.arange(positions.shape[1] if positions.ndim == 3 else 0)))
    forces = getattr(data, "forces", None)
    forces = None if forces is None else np.asarray(forces)
    attrs = dict(getattr(data, "attrs", None) or {})
    if time.ndim != 1 or time.size == 0:
        raise bad("time", f"shape {time.shape}", "a non-empty (T,) array of sample times")
    if positions.ndim != 3 or positions.shape[0] != time.size or positions.shape[2] != 3:
        raise bad("positions", f"shape {positions.shape}", f"shape (T, N, 3) with T = {time.size}")
    if nodes.shape != (positions.shape[1],):
        raise bad("nodes", f"shape {nodes.shape}", f"shape ({positions.shape[1]},) matching positions")
    if forces is not None and forces.shape != positions.shape:
        raise bad("forces", f"shape {forces.shape}", f"shape {positions.shape} matching positions")
    if not np.issubdtype(positions.dtype, np.number) or (forces is not None
                                                         and not np.issubdtype(forces.dtype, np.number)):
        raise SoftrnnInputError("positions and forces must be numeric arrays")
    if not all(np.isfinite(positions[k:k + 4096]).all() for k in range(0, positions.shape[0], 4096)):
        raise SoftrnnInputError("positions contain NaN or inf: the data is broken (a diverged run?); "
                                "re-create it")
    return time, nodes.astype(int), positions, forces, attrs


def time_span(time: np.ndarray, start=None, stop=None, names=("start", "stop")) -> tuple[int, int]:
    """Sample indices (first, last), inclusive, of the times in [start, stop] \\[s] (None: the ends)."""
    t0, t1 = float(time[0]), float(time[-1])
    eps = 1e-9 * max(abs(t0), abs(t1), 1.0)
    rng = f"a time in [{t0:g}, {t1:g}] s (the data's span)"
    for name, value in zip(names, (start, stop)):
        if value is not None and not (math.isfinite(value) and t0 - eps <= value <= t1 + eps):
            raise bad(name, value, rng)
    if start is not None and stop is not None and stop <= start:
        raise bad(names[1], stop, f"a time after {names[0]}={start!r}")
    i0 = 0 if start is None else int(np.searchsorted(time, start - eps, side="left"))
    i1 = len(time) - 1 if stop is None else int(np.searchsorted(time, stop + eps, side="right")) - 1
    if i1 < i0:
        raise SoftrnnInputError(f"start={start!r}, stop={stop!r} select no sample: the samples lie "
                                f"{(t1 - t0) / max(len(time) - 1, 1):g} s apart; widen the span")
    return i0, i1


def frame_indices(n_samples: int, *, frames: int | None = None, duration: float | None = None,
                  fps: float = 20, max_frames: int = DEFAULT_MAX_FRAMES, first: int = 0) -> np.ndarray:
    """Sample indices of the frames: evenly spaced over ``n_samples`` samples from ``first``, the first
    and the last included. ``frames`` or ``duration`` [s of playback] x ``fps`` sets the count,
    otherwise ``min(n_samples, max_frames)``; never more frames than samples."""
    if frames is not None and duration is not None:
        raise SoftrnnInputError(f"frames={frames!r} and duration={duration!r} both given: give one of them")
    if frames is not None:
        if int(frames) != frames or frames < 1:
            raise bad("frames", frames, "an integer >= 1")
        count = int(frames)
    elif duration is not None:
        if not (duration > 0 and math.isfinite(duration)):
            raise bad("duration", duration, "a playback length > 0 s")
        count = max(1, int(round(duration * fps)))
    else:
        count = max_frames
    count = min(count, n_samples)
    if count == 1:
        return np.array([first])
    return first + np.unique(np.round(np.linspace(0, n_samples - 1, count)).astype(int))


def _resolve(node, nodes: np.ndarray, attrs: dict) -> int:
    """A node index; negative ones count from the rod's end (``attrs['n_nodes_total']`` nodes, else the
    highest stored node + 1)."""
    if isinstance(node, bool) or not isinstance(node, (int, np.integer)):
        raise bad("node", node, "an integer node index")
    node = int(node)
    if node < 0:
        total = _first_int(attrs.get("n_nodes_total"))
        total = total if total is not None else (int(nodes.max()) + 1 if nodes.size else 0)
        if node + total >= 0:
            return node + total
    return node


def _column(nodes: np.ndarray, node: int, what: str = "node") -> int:
    """The column of ``node`` in ``nodes``; a node not stored is an error naming the stored ones."""
    hits = np.flatnonzero(nodes == node)
    if hits.size == 0:
        raise bad(what, node, f"a node present in the data: {describe_nodes(nodes)}")
    return int(hits[0])


def describe_nodes(nodes: np.ndarray) -> str:
    """The stored nodes for messages: a range ``a..b``, a short list, or the first ten and the count."""
    nodes = np.asarray(nodes, dtype=int)
    if nodes.size and np.array_equal(nodes, np.arange(nodes[0], nodes[0] + nodes.size)):
        return f"{nodes[0]}..{nodes[-1]}" if nodes.size > 1 else f"{nodes[0]} only"
    if nodes.size <= 12:
        return ", ".join(str(int(a)) for a in nodes)
    return ", ".join(str(int(a)) for a in nodes[:10]) + f", ... ({nodes.size} nodes, {nodes.min()}..{nodes.max()})"


def check_suffix(path, choices=ANIMATION_SUFFIXES, argument: str = "output") -> str:
    """The suffix of ``path`` in lower case, or SoftrnnInputError naming the suffix and the choices.
    ``.mp4`` needs ffmpeg on the PATH."""
    suffix = Path(path).suffix.lower()
    if suffix not in choices:
        raise bad(argument, str(path), f"the suffix {suffix or '(none)'!r} is not supported; use one of "
                  + ", ".join(choices))
    if suffix == ".mp4" and shutil.which("ffmpeg") is None:
        raise bad(argument, str(path), "writing .mp4 needs ffmpeg, which is not installed (not on the PATH); "
                  "install ffmpeg or write a .gif")
    return suffix


def node_of_interest(data, default: int | None = None) -> int | None:
    """The data's node of interest, if it names one: ``attrs['node_of_interest']``, else the first of
    the scenario's nodes of interest (its record, ``softrnn.io.record``); else ``default``,
    the caller's choice (for example the node of interest of the paper case that ``attrs['case']``
    names: the data does not hold it). Negative indices count from the rod's end."""
    attrs = dict(getattr(data, "attrs", None) or {})
    node = _first_int(attrs.get("node_of_interest"))
    record = read_record(attrs) if node is None else None
    if record is not None and record.nodes_of_interest:
        node = int(record.nodes_of_interest[0])
    if node is None and default is not None:
        node = int(default)
    if node is not None and node < 0:
        total = _first_int(attrs.get("n_nodes_total"))
        if total is None:
            rod = attrs.get("rod")
            total = _first_int(rod.get("n_nodes")) if isinstance(rod, dict) else None
        if total is None:
            nodes = np.asarray(getattr(data, "nodes", []))
            total = int(nodes.max()) + 1 if nodes.size else None
        node = None if total is None else node + total
    return node


def _first_int(value) -> int | None:
    """The first integer of ``value`` (a number or an array of them), else None."""
    try:
        arr = np.asarray(value).ravel()
        if arr.size and np.issubdtype(arr.dtype, np.integer):
            return int(arr[0])
    except (TypeError, ValueError):
        pass
    return None


def _text(value) -> str:
    """``value`` as text (bytes decoded as UTF-8); '' for anything else."""
    if isinstance(value, bytes):
        value = value.decode("utf-8", "replace")
    return value if isinstance(value, str) else ""


def _title(attrs: dict, fallback: str = "rod") -> str:
    """A short name for the data: its scenario's (``softrnn.io.record.scenario_name``), else ``name`` in
    attrs, else ``fallback``."""
    return scenario_name(attrs) or _text(attrs.get("name")) or fallback


def load(path, *, group: str | None = None, start: float | None = None, stop: float | None = None,
         node: int | None = None):
    """Read a softrnn HDF5 dataset for a picture: all stored nodes (or only ``node``), only the samples
    in [start, stop] \\[s]. Errors (missing or broken file, unknown group or node, times outside the
    record) are one-line ``SoftrnnInputError``s."""
    if node is not None:
        data = read_node(path, int(node), group=group)
        if start is None and stop is None:
            return data
        i0, i1 = time_span(data.time, start, stop, names=("--start", "--stop"))
        return _slice(data, i0, i1)
    if start is None and stop is None:
        return read_dataset(path, group=group)
    time = read_dataset(path, nodes=[], group=group).time  # the time axis only
    i0, i1 = time_span(time, start, stop, names=("--start", "--stop"))
    return read_dataset(path, group=group, start=i0, stop=i1 + 1)


def _slice(data, i0: int, i1: int):
    """Samples i0..i1 (inclusive) of dataset-like ``data``."""
    sl = slice(i0, i1 + 1)
    return SimpleNamespace(time=data.time[sl], nodes=data.nodes, positions=data.positions[sl],
                           forces=data.forces[sl] if getattr(data, "forces", None) is not None else None,
                           actuation=data.actuation[sl] if getattr(data, "actuation", None) is not None else None,
                           actuation_units=dict(getattr(data, "actuation_units", None) or {}),
                           attrs=dict(getattr(data, "attrs", None) or {}))
