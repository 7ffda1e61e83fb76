"""Trajectory datasets in HDF5 (schema 1, documented in docs/dataset-format.md).

One trajectory is a group (the file's root, or ``/traj-00000`` ... in a sweep file) holding

========== ============ ======= =====================================================
dataset    shape        dtype   meaning
========== ============ ======= =====================================================
time       (T,)         float64 sample times [s], strictly increasing
nodes      (N,)         int64   0-based rod node index of each stored column
positions  (T, N, 3)    float32 node positions [m], world frame
quaternions(T, N, 4)    float32 unit quaternions (w, x, y, z), body -> world
forces     (T, N, 3)    float32 applied external forces [N], world frame
torques    (T, N, 3)    float32 applied external torques [N m], world frame
========== ============ ======= =====================================================

and the attributes ``softrnn_schema``, ``softrnn_version``, ``dt``, ``seed`` (absent when there is
none), ``rod`` (JSON), ``scenario`` (text), ``units`` (JSON), ``n_nodes_total`` and ``attrs`` (JSON,
the caller's own metadata). The per-node arrays are chunked ``(TIME_CHUNK, 1, c)`` and compressed
(gzip level 4 with byte shuffle, Fletcher-32 checksums), so one node's series is read without
touching the other nodes' chunks.

Writes are atomic: data goes to ``<path>.tmp-XXXX`` in the same folder and is renamed onto ``path``
only when the trajectory is complete; a failed or interrupted write leaves no file at ``path`` (and
the previous file, if any, unchanged). Every problem with a file is a one-line ``DatasetError``
naming the file, what is wrong and what to do.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
import weakref
from dataclasses import asdict, dataclass, field, is_dataclass
from pathlib import Path

import h5py
import numpy as np

from .. import __version__
from ..files import umask_mode
from ..errors import SoftrnnInputError, bad

SCHEMA_VERSION = 1
"""Version of the file layout; readers refuse files with a newer one."""

TIME_CHUNK = 4096
"""Samples per HDF5 chunk along time (the simulator's chunk length; docs/dataset-format.md#size)."""

COMPRESSION = {"compression": "gzip", "compression_opts": 4, "shuffle": True, "fletcher32": True}
"""HDF5 filters of every chunked dataset: gzip level 4 after a byte shuffle, with checksums."""

POSITION_LIMIT_M = 16.0
"""Largest |coordinate| accepted [m]: float32 rounds a coordinate x by at most 2^-24 |x|, so positions
below 16 m are stored to better than 1e-6 m (1 micrometre)."""

QUATERNION_TOLERANCE = 1e-5
"""Largest accepted | |q| - 1 | of a stored quaternion (float32 rounding itself gives < 2.4e-7)."""

FIELDS = ("positions", "quaternions", "forces", "torques")
_WIDTH = {"positions": 3, "quaternions": 4, "forces": 3, "torques": 3}
UNITS = {"time": "s", "positions": "m", "quaternions": "1 (unit, scalar first w x y z, body to world)",
         "forces": "N", "torques": "N m"}
_DESCRIPTION = {
    "time": "sample times, strictly increasing",
    "nodes": "0-based rod node index of each stored column",
    "positions": "node positions, world frame",
    "quaternions": "node orientations as unit quaternions (w, x, y, z), body to world",
    "forces": "applied external forces, world frame",
    "torques": "applied external torques, world frame",
}
RESERVED_ATTRS = ("schema_version", "softrnn_version", "units", "rod", "scenario_text", "seed", "dt",
                  "n_nodes_total")
SWEEP_PREFIX = "traj-"


class DatasetError(SoftrnnInputError):
    """A dataset file (or data written to one) that cannot be used; the message is one line:
    ``<path>: what is wrong; what to do``."""


def _one_line(text) -> str:
    return " ".join(str(text).split())


def sweep_group_name(index: int) -> str:
    """Name of the ``index``-th trajectory of a sweep file: ``traj-00000``, ``traj-00001``, ..."""
    return f"{SWEEP_PREFIX}{int(index):05d}"


# ----------------------------------------------------------------------------------------- Dataset
@dataclass(frozen=True, eq=False)
class Dataset:
    """One trajectory as stored (or read back): T samples of N nodes.

    Parameters
    ----------
    time : ndarray (T,) float64
        Sample times [s], strictly increasing.
    nodes : ndarray (N,) int64
        0-based rod node index of each column.
    positions : ndarray (T, N, 3) float32
        Node positions [m], world frame.
    quaternions : ndarray (T, N, 4) float32
        Unit quaternions (w, x, y, z), body -> world. Identity placeholders where the source had
        no orientations (``attrs["has_orientations"] is False``, CSV imports).
    forces : ndarray (T, N, 3) float32
        Applied external forces [N], world frame.
    torques : ndarray (T, N, 3) float32
        Applied external torques [N m], world frame.
    attrs : dict
        ``schema_version``, ``softrnn_version``, ``units`` (dict), ``rod`` (dict or None),
        ``scenario_text``, ``seed`` (int or None), ``dt`` [s], ``n_nodes_total`` and every key the
        writer was given in ``attrs=``.

    Arrays are converted to these dtypes on construction (a copy only where needed; inputs are
    never modified); the file reader also checks finiteness and unit quaternions.
    """

    time: np.ndarray
    nodes: np.ndarray
    positions: np.ndarray
    quaternions: np.ndarray
    forces: np.ndarray
    torques: np.ndarray
    attrs: dict = field(default_factory=dict)

    def __post_init__(self):
        time = np.asarray(self.time, dtype=np.float64)
        nodes = np.asarray(self.nodes)
        if time.ndim != 1:
            raise bad("time", f"array of shape {time.shape}", "a 1-D array of sample times (T,) in s")
        if nodes.ndim != 1 or (nodes.size and not np.issubdtype(nodes.dtype, np.integer)):
            raise bad("nodes", f"{nodes.dtype} array of shape {nodes.shape}", "a 1-D array of node indices (N,)")
        object.__setattr__(self, "time", time)
        object.__setattr__(self, "nodes", nodes.astype(np.int64, copy=False))
        T, N = time.shape[0], nodes.shape[0]
        for name in FIELDS:
            value = getattr(self, name)
            arr = np.asarray(value)
            if arr.shape != (T, N, _WIDTH[name]):
                raise bad(name, f"array of shape {arr.shape}",
                          f"shape (T, N, {_WIDTH[name]}) = {(T, N, _WIDTH[name])} to match time (T={T}) "
                          f"and nodes (N={N})")
            object.__setattr__(self, name, _to_float32(arr))
        if not isinstance(self.attrs, dict):
            raise bad("attrs", type(self.attrs).__name__, "a dict")

    @property
    def n_samples(self) -> int:
        """T."""
        return int(self.time.shape[0])

    @property
    def n_nodes(self) -> int:
        """N, the stored nodes."""
        return int(self.nodes.shape[0])

    @property
    def dt(self) -> float:
        """Nominal sample interval [s]: ``attrs['dt']``, else the median step of ``time``."""
        if "dt" in self.attrs:
            return float(self.attrs["dt"])
        return float(np.median(np.diff(self.time))) if self.n_samples > 1 else 0.0

    @property
    def has_orientations(self) -> bool:
        """False where the quaternions are identity placeholders (a CSV without orientations)."""
        return bool(self.attrs.get("has_orientations", True))

    def column(self, node: int) -> int:
        """Column of rod node ``node`` (negative: counted from the rod's end, as in ``Setup``)."""
        return _columns(self.nodes, [node], self.attrs.get("n_nodes_total"), "dataset")[0]

    def rod_spec(self):
        """The ``softrnn.rod.RodSpec`` in ``attrs['rod']``, or None if absent or partial (lab data)."""
        from ..rod.spec import NodeOverride, RodSpec

        rod = self.attrs.get("rod")
        if not isinstance(rod, dict):
            return None
        try:
            values = dict(rod)
            values["overrides"] = tuple(NodeOverride(**o) for o in values.get("overrides", ()))
            return RodSpec(**values)
        except (TypeError, SoftrnnInputError):
            return None


def _to_float32(arr: np.ndarray) -> np.ndarray:
    with np.errstate(over="ignore", under="ignore", invalid="ignore"):
        return np.asarray(arr, dtype=np.float32)


# ----------------------------------------------------------------------------------------- helpers
def _columns(stored: np.ndarray, wanted, n_total, where) -> list[int]:
    """Columns of the node indices ``wanted`` in ``stored`` (negative: from the rod's end)."""
    lookup = {int(a): j for j, a in enumerate(stored)}
    total = int(n_total) if n_total is not None else (int(stored.max()) + 1 if stored.size else 0)
    cols = []
    for node in wanted:
        if isinstance(node, bool) or not isinstance(node, (int, np.integer)):
            raise bad("node", node, "an integer node index")
        a = int(node) + total if node < 0 else int(node)
        if a not in lookup:
            shown = _node_list(stored)
            raise DatasetError(f"{where}: node {int(node)} is not stored (stored nodes: {shown}); "
                               f"pass one of those node indices")
        cols.append(lookup[a])
    return cols


def _node_list(nodes) -> str:
    nodes = [int(a) for a in nodes]
    if nodes and nodes == list(range(nodes[0], nodes[-1] + 1)) and len(nodes) > 3:
        return f"{nodes[0]}..{nodes[-1]}"
    if len(nodes) > 12:
        return ", ".join(map(str, nodes[:10])) + f", ... ({len(nodes)} nodes)"
    return ", ".join(map(str, nodes))


def _short(value):
    """``value`` itself, or a shortened text of it when its repr is long (for error messages)."""
    text = repr(value.tolist() if isinstance(value, np.ndarray) else value)
    return value if len(text) <= 80 else _Text(text[:70] + " ...")


class _Text(str):
    def __repr__(self):
        return str(self)


def _json_default(value):
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    if is_dataclass(value) and not isinstance(value, type):
        return asdict(value)
    raise TypeError(f"{type(value).__name__} is not JSON serialisable")


def _to_json(argument: str, value) -> str:
    try:
        return json.dumps(value, allow_nan=False, default=_json_default)
    except (TypeError, ValueError) as err:
        raise bad(argument, value, f"JSON-serialisable values (numbers, strings, lists, dicts; "
                                   f"no NaN/inf): {_one_line(err)}") from None


def _rod_dict(rod):
    if rod is None:
        return None
    if is_dataclass(rod) and not isinstance(rod, type):
        return json.loads(_to_json("rod", asdict(rod)))
    if isinstance(rod, dict):
        return json.loads(_to_json("rod", rod))
    raise bad("rod", type(rod).__name__, "a softrnn.rod.RodSpec, a dict of rod properties, or None")


def _temp_path(path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f"{path.name}.tmp-", dir=path.parent)
    os.close(fd)
    os.chmod(tmp, umask_mode())
    return Path(tmp)


def _h5open(path, mode: str = "r") -> h5py.File:
    """Open an HDF5 file (the single place files are opened; tests count the bytes read here)."""
    return h5py.File(path, mode)


def _discard(h5file, tmp) -> None:
    try:
        if h5file is not None and h5file.id.valid:
            h5file.close()
    except Exception:  # noqa: BLE001 - best effort while discarding
        pass
    try:
        os.unlink(tmp)
    except FileNotFoundError:
        pass


# ----------------------------------------------------------------------------------------- writer
class DatasetWriter:
    """Streams one trajectory into an HDF5 file, atomically.

    Parameters
    ----------
    path : str or Path
        Output file. It is written as ``<path>.tmp-XXXX`` in the same folder and renamed onto
        ``path`` by ``close()``; an exception inside ``with``, or invalid data passed to ``append``,
        removes the temporary file and leaves ``path`` as it was.
    nodes : int or sequence of int (N,)
        0-based rod node index of each column (an int n means nodes 0..n-1), unique, in the order
        the chunks store them (``Trajectory.nodes``).
    n_samples : int
        T, the number of samples that ``append`` will receive in total (``close`` checks it).
    dt : float
        Nominal sample interval [s] (stored as the ``dt`` attribute; the real times are in ``time``).
    rod : RodSpec, dict or None
        The rod (a full ``RodSpec`` for simulations, a dict of the known properties for lab data).
    scenario_text : str
        The full text of the scenario that produced the data.
    seed : int or None
        Random seed of the scenario, if any.
    attrs : dict or None
        More metadata (JSON-serialisable; NumPy scalars and arrays become numbers and lists). Keys
        may not be one of ``RESERVED_ATTRS``.
    group : str or None
        None: ``path`` holds this one trajectory. A name (e.g. ``sweep_group_name(i)``): the
        trajectory becomes that group of the sweep file ``path``, which is created if missing; an
        existing sweep is copied to the temporary file first (cost O(file size): for large sweeps
        write a folder of files and ``merge_files`` it).

    Use as ``Simulator.run(config, sink=writer.append)`` inside ``with DatasetWriter(...) as writer``.
    """

    def __init__(self, path, *, nodes, n_samples: int, dt: float, rod=None, scenario_text: str = "",
                 seed: int | None = None, attrs: dict | None = None, group: str | None = None,
                 _softrnn_version: str | None = None):
        self.path = Path(path)
        if isinstance(nodes, (int, np.integer)) and not isinstance(nodes, bool):
            nodes = np.arange(int(nodes))
        node_arr = np.asarray(nodes)
        if node_arr.ndim != 1 or node_arr.size == 0 or not np.issubdtype(node_arr.dtype, np.integer):
            raise bad("nodes", _short(nodes), "a non-empty sequence of 0-based node indices")
        if node_arr.min() < 0 or np.unique(node_arr).size != node_arr.size:
            raise bad("nodes", _short(node_arr.tolist()), "unique node indices >= 0")
        if isinstance(n_samples, bool) or not isinstance(n_samples, (int, np.integer)) or n_samples < 1:
            raise bad("n_samples", n_samples, "an integer >= 1")
        if isinstance(dt, bool) or not isinstance(dt, (int, float, np.integer, np.floating)) \
                or not np.isfinite(dt) or dt <= 0:
            raise bad("dt", dt, "a positive sample interval in s")
        if not isinstance(scenario_text, str):
            raise bad("scenario_text", type(scenario_text).__name__, "a string")
        if seed is not None and (isinstance(seed, bool) or not isinstance(seed, (int, np.integer))
                                 or not -2 ** 63 <= int(seed) < 2 ** 63):
            raise bad("seed", seed, "an integer (64-bit) or None")
        attrs = {} if attrs is None else attrs
        if not isinstance(attrs, dict) or not all(isinstance(k, str) for k in attrs):
            raise bad("attrs", attrs, "a dict with string keys")
        clash = sorted(set(attrs) & set(RESERVED_ATTRS))
        if clash:
            raise bad("attrs", clash, f"keys other than the reserved {', '.join(RESERVED_ATTRS)} "
                                      f"(pass those as arguments)")
        user_json = _to_json("attrs", attrs)
        rod_d = _rod_dict(rod)
        n_total = int(node_arr.max()) + 1
        if rod_d is not None and isinstance(rod_d.get("n_nodes"), int):
            if node_arr.max() >= rod_d["n_nodes"]:
                raise bad("nodes", _short(node_arr.tolist()), f"node indices below rod.n_nodes={rod_d['n_nodes']}")
            n_total = rod_d["n_nodes"]
        if group is not None:
            group = _group_name(group)
        self.nodes = node_arr.astype(np.int64)
        self.n_samples = int(n_samples)
        self.group = group
        self._chunk_len = min(self.n_samples, TIME_CHUNK)
        self._meta = {
            "softrnn_schema": SCHEMA_VERSION,
            "softrnn_version": _softrnn_version or __version__,
            "dt": float(dt),
            "rod": json.dumps(rod_d),
            "scenario": scenario_text,
            "units": json.dumps(UNITS),
            "n_nodes_total": n_total,
            "attrs": user_json,
        }
        if seed is not None:
            self._meta["seed"] = int(seed)
        self._written = 0
        self._buffer: list[dict] = []
        self._buffered = 0
        self._last_time = -np.inf
        self._state = "open"
        self._h5 = None
        self._tmp = None
        self._open()

    # ------------------------------------------------------------------ file set-up
    def _open(self) -> None:
        if self.group is not None and self.path.exists():
            info = _inspect(self.path)
            if info["kind"] != "sweep":
                raise DatasetError(f"{self.path}: holds a single trajectory, not a sweep; cannot add group "
                                   f"'{self.group}' (write to a new file, or merge_files both)")
            if "/" + self.group in info["groups"]:
                raise DatasetError(f"{self.path}: group '{self.group}' already exists; choose another name")
        self._tmp = _temp_path(self.path)
        self._finalizer = weakref.finalize(self, _discard, None, str(self._tmp))
        try:
            if self.group is not None and self.path.exists():
                shutil.copyfile(self.path, self._tmp)
                self._h5 = _h5open(self._tmp, "a")
            else:
                self._h5 = _h5open(self._tmp, "w")
                if self.group is not None:
                    self._h5.attrs["softrnn_schema"] = SCHEMA_VERSION
                    self._h5.attrs["softrnn_version"] = self._meta["softrnn_version"]
                    self._h5.attrs["kind"] = "sweep"
            self._finalizer.detach()
            self._finalizer = weakref.finalize(self, _discard, self._h5, str(self._tmp))
            g = self._h5 if self.group is None else self._h5.create_group(self.group)
            if self.group is None:
                g.attrs["kind"] = "trajectory"
            for key, value in self._meta.items():
                g.attrs[key] = value
            self._create_datasets(g)
        except BaseException:
            self.abort()
            raise

    def _create_datasets(self, g: h5py.Group) -> None:
        T, N, c = self.n_samples, self.nodes.size, self._chunk_len
        self._ds = {"time": g.create_dataset("time", shape=(T,), dtype="<f8", chunks=(c,), **COMPRESSION)}
        nodes = g.create_dataset("nodes", data=self.nodes, dtype="<i8")
        nodes.attrs["description"] = _DESCRIPTION["nodes"]
        for name in FIELDS:
            w = _WIDTH[name]
            self._ds[name] = g.create_dataset(name, shape=(T, N, w), dtype="<f4", chunks=(c, 1, w), **COMPRESSION)
        for name, ds in self._ds.items():
            ds.attrs["units"] = UNITS[name]
            ds.attrs["description"] = _DESCRIPTION[name]
            if name != "time":
                ds.attrs["frame"] = "world"

    # ------------------------------------------------------------------ streaming
    def append(self, chunk) -> None:
        """Add the next k samples.

        Parameters
        ----------
        chunk : Trajectory, Dataset or any object with
            ``time`` (k,) [s], ``positions`` (k, N, 3) [m], ``quaternions`` (k, N, 4),
            ``forces`` (k, N, 3) [N] and ``torques`` (k, N, 3) [N m] (and optionally ``nodes`` (N,),
            which must equal the writer's). The arrays are copied, never modified.

        Invalid data (wrong shape, NaN/inf, times not increasing, too many samples, non-unit
        quaternions, positions beyond ``POSITION_LIMIT_M``) raises ``DatasetError`` and discards
        the file being written.
        """
        if self._state != "open":
            raise DatasetError(f"{self.path}: the writer is {self._state}; create a new DatasetWriter")
        try:
            rows = self._validate_chunk(chunk)
        except SoftrnnInputError:
            self.abort()
            raise
        k = rows["time"].shape[0]
        if k == 0:
            return
        self._buffer.append(rows)
        self._buffered += k
        self._last_time = float(rows["time"][-1])
        if self._buffered >= self._chunk_len:
            self._flush(final=False)

    def _validate_chunk(self, chunk) -> dict:
        where = f"{self.path}: cannot write"
        missing = [n for n in ("time",) + FIELDS if not hasattr(chunk, n)]
        if missing:
            raise bad("chunk", type(chunk).__name__,
                      "an object with time, positions, quaternions, forces and torques arrays "
                      f"(e.g. softrnn.rod.Trajectory); missing {', '.join(missing)}")
        nodes = getattr(chunk, "nodes", None)
        if nodes is not None and not np.array_equal(np.asarray(nodes), self.nodes):
            raise DatasetError(f"{where}: the chunk's nodes {_node_list(np.asarray(nodes))} differ from the "
                               f"writer's nodes {_node_list(self.nodes)}; pass nodes=trajectory.nodes")
        time = np.asarray(chunk.time)
        if time.ndim != 1 or not np.issubdtype(time.dtype, np.number):
            raise DatasetError(f"{where}: time has shape {time.shape}; expected a 1-D array (k,) of times in s")
        time = time.astype(np.float64, copy=True)
        k, N = time.shape[0], self.nodes.size
        if self._written + self._buffered + k > self.n_samples:
            raise DatasetError(f"{where}: {self._written + self._buffered + k} samples received but "
                               f"n_samples={self.n_samples}; pass the total sample count as n_samples")
        rows = {"time": time}
        for name in FIELDS:
            arr = np.asarray(getattr(chunk, name))
            if arr.shape != (k, N, _WIDTH[name]):
                raise DatasetError(f"{where}: {name} has shape {arr.shape} but time has k={k} samples and the "
                                   f"writer N={N} nodes; expected {(k, N, _WIDTH[name])}")
            if not np.issubdtype(arr.dtype, np.number):
                raise DatasetError(f"{where}: {name} has dtype {arr.dtype}; expected floating-point numbers")
            rows[name] = arr
        if k == 0:
            return rows
        for name, arr in rows.items():
            finite = np.isfinite(arr)
            if not finite.all():
                idx = np.argwhere(~finite)[0]
                at = f"sample {self._written + self._buffered + idx[0]}" + (
                    f", node {self.nodes[idx[1]]}" if arr.ndim > 1 else "")
                raise DatasetError(f"{where}: {name} has a non-finite value ({float(arr[tuple(idx)])}) at {at}; "
                                   f"every value must be finite")
        t_all = np.concatenate([[self._last_time], time])
        steps = np.diff(t_all)
        if np.any(steps <= 0):
            i = int(np.argmax(steps <= 0))
            at = self._written + self._buffered + i
            raise DatasetError(f"{where}: time is not strictly increasing at sample {at} "
                               f"({float(t_all[i + 1])!r} s after {float(t_all[i])!r} s); "
                               f"samples must be in increasing time order without duplicates")
        reach = float(np.abs(rows["positions"]).max())
        if reach > POSITION_LIMIT_M:
            raise DatasetError(f"{where}: a position coordinate reaches {reach:.4g} m; float32 storage keeps "
                               f"1 micrometre only below {POSITION_LIMIT_M:g} m (move the origin closer, and "
                               f"use metres)")
        norm = np.sqrt(np.sum(np.asarray(rows["quaternions"], dtype=np.float64) ** 2, axis=-1))
        off = np.abs(norm - 1.0)
        if off.max() > QUATERNION_TOLERANCE:
            idx = np.unravel_index(int(np.argmax(off)), off.shape)
            raise DatasetError(f"{where}: the quaternion at sample {self._written + self._buffered + idx[0]}, "
                               f"node {self.nodes[idx[1]]} has norm {norm[idx]:.6g}; expected unit quaternions "
                               f"(w, x, y, z) to within {QUATERNION_TOLERANCE:g}")
        for name in FIELDS:
            if name == "quaternions":
                rows[name] = _to_float32(rows[name]).copy()
                continue
            arr32 = _to_float32(rows[name])
            if not np.isfinite(arr32).all():
                raise DatasetError(f"{where}: {name} has values beyond the float32 range (|x| > 3.4e38); "
                                   f"check the units")
            rows[name] = np.array(arr32, copy=True)
        return rows

    def _flush(self, final: bool) -> None:
        if not self._buffer:
            return
        block = {n: np.concatenate([b[n] for b in self._buffer]) for n in self._buffer[0]}
        k = block["time"].shape[0]
        take = k if final else (k // self._chunk_len) * self._chunk_len
        a, b = self._written, self._written + take
        for name, ds in self._ds.items():
            ds[a:b] = block[name][:take]
        self._written = b
        rest = {n: v[take:] for n, v in block.items()}
        self._buffer = [rest] if k > take else []
        self._buffered = k - take

    def close(self) -> None:
        """Check that ``n_samples`` samples were written, then rename the file onto ``path``."""
        if self._state == "closed":
            return
        if self._state != "open":
            raise DatasetError(f"{self.path}: the writer was {self._state}; nothing was saved")
        try:
            self._flush(final=True)
            if self._written != self.n_samples:
                raise DatasetError(f"{self.path}: only {self._written} of n_samples={self.n_samples} samples were "
                                   f"written; the incomplete trajectory was not saved")
            self._h5.close()
            os.replace(self._tmp, self.path)
        except BaseException:
            self.abort()
            raise
        self._finalizer.detach()
        self._state = "closed"

    def abort(self) -> None:
        """Discard the temporary file; ``path`` is left as it was."""
        if self._state == "open":
            self._state = "aborted"
        fin = getattr(self, "_finalizer", None)
        if fin is not None and fin.alive:
            fin()
        elif self._tmp is not None and self._state != "closed":
            _discard(self._h5, str(self._tmp))

    def __enter__(self) -> "DatasetWriter":
        return self

    def __exit__(self, exc_type, exc, tb) -> bool:
        if exc_type is not None:
            self.abort()
        else:
            self.close()
        return False


def write_trajectory(path, traj, *, dt: float, rod=None, scenario_text: str = "", seed: int | None = None,
                     attrs: dict | None = None, group: str | None = None) -> None:
    """Write a whole trajectory (``softrnn.rod.Trajectory`` or ``Dataset``) to ``path`` atomically.

    Parameters are those of ``DatasetWriter``; the nodes are ``traj.nodes``.
    """
    time = np.asarray(traj.time)
    with DatasetWriter(path, nodes=np.asarray(traj.nodes), n_samples=int(time.shape[0]), dt=dt, rod=rod,
                       scenario_text=scenario_text, seed=seed, attrs=attrs, group=group) as writer:
        writer.append(traj)


def write_dataset(path, dataset: Dataset, *, group: str | None = None) -> None:
    """Write a ``Dataset`` with its own metadata (dt, rod, scenario, seed, the producing softrnn
    version and its extra attrs), e.g. one read from another file: a bit-exact copy."""
    attrs = {k: v for k, v in dataset.attrs.items() if k not in RESERVED_ATTRS and k != "schema_version"}
    with DatasetWriter(path, nodes=dataset.nodes, n_samples=dataset.n_samples, dt=dataset.dt,
                       rod=dataset.attrs.get("rod"), scenario_text=dataset.attrs.get("scenario_text", ""),
                       seed=dataset.attrs.get("seed"), attrs=attrs, group=group,
                       _softrnn_version=dataset.attrs.get("softrnn_version")) as writer:
        writer.append(dataset)


# ----------------------------------------------------------------------------------------- reading
def _group_name(group: str) -> str:
    if not isinstance(group, str) or not group.strip("/") or "/" in group.strip("/") or group.startswith("/."):
        raise bad("group", group, "a group name such as 'traj-00000' (see list_groups)")
    return group.strip("/")


class _Reading:
    """Context: open ``path`` for reading and turn every HDF5 failure into a one-line DatasetError."""

    def __init__(self, path):
        self.path = Path(path)
        self.f = None

    def __enter__(self) -> h5py.File:
        p = self.path
        if not p.exists():
            raise DatasetError(f"{p}: no such file; check the path")
        if p.is_dir():
            raise DatasetError(f"{p}: is a folder, not a dataset file; pass one .h5 file "
                               f"(or merge the folder with merge_files)")
        try:
            signature = h5py.is_hdf5(str(p))
        except OSError as err:
            raise DatasetError(f"{p}: cannot be read ({_one_line(err)})") from None
        if not signature:
            raise DatasetError(f"{p}: not an HDF5 file (no HDF5 signature); softrnn datasets are HDF5 files "
                               f"written by softrnn (DatasetWriter, 'softrnn import-csv')")
        try:
            self.f = _h5open(p, "r")
        except OSError as err:
            raise DatasetError(f"{p}: truncated or corrupt HDF5 file ({_h5_reason(err)}); re-create or "
                               f"re-copy it") from None
        return self.f

    def __exit__(self, exc_type, exc, tb):
        if self.f is not None:
            try:
                self.f.close()
            except Exception:  # noqa: BLE001 - the original error matters more
                pass
        if exc_type is not None and issubclass(exc_type, (OSError, RuntimeError, KeyError)) \
                and not issubclass(exc_type, SoftrnnInputError):
            raise DatasetError(f"{self.path}: truncated or corrupt HDF5 file ({_h5_reason(exc)}); re-create or "
                               f"re-copy it") from None
        return False


def _h5_reason(err) -> str:
    text = _one_line(err)
    for prefix in ("Unable to synchronously open file ", "Unable to open file ", "Can't synchronously read data ",
                   "Can't read data "):
        if text.startswith(prefix):
            text = text[len(prefix):].strip("()")
    return text


def _root_info(f: h5py.File, path: Path) -> dict:
    attrs = f.attrs
    if "softrnn_schema" not in attrs:
        raise DatasetError(f"{path}: not a softrnn dataset (no 'softrnn_schema' attribute); softrnn reads the "
                           f"HDF5 files it writes (DatasetWriter, 'softrnn import-csv'), see docs/dataset-format.md")
    schema = _int_attr(attrs, "softrnn_schema", path, "/")
    if schema > SCHEMA_VERSION:
        raise DatasetError(f"{path}: written with dataset schema {schema}, newer than this softrnn "
                           f"({__version__}, schema {SCHEMA_VERSION}); upgrade softrnn")
    if schema < 1:
        raise DatasetError(f"{path}: softrnn_schema={schema} is invalid; expected 1..{SCHEMA_VERSION}")
    kind = _str_attr(attrs, "kind", path, "/") if "kind" in attrs else "trajectory"
    if kind not in ("trajectory", "sweep"):
        raise DatasetError(f"{path}: kind={kind!r} is invalid; expected 'trajectory' or 'sweep'")
    if kind == "sweep":
        groups = sorted("/" + k for k, v in f.items()
                        if isinstance(v, h5py.Group) and "softrnn_schema" in v.attrs)
    else:
        groups = ["/"]
    return {"schema": schema, "kind": kind, "groups": groups}


def _inspect(path) -> dict:
    with _Reading(path) as f:
        return _root_info(f, Path(path))


def _select(f: h5py.File, path: Path, group) -> tuple[h5py.Group, str]:
    info = _root_info(f, path)
    if info["kind"] == "trajectory":
        if group not in (None, "/", ""):
            raise DatasetError(f"{path}: holds a single trajectory, there is no group {group!r}; "
                               f"omit group (or pass '/')")
        return f, "/"
    if group in (None, "/", ""):
        n = len(info["groups"])
        first = info["groups"][0] if n else "none"
        raise DatasetError(f"{path}: is a sweep of {n} trajectories; pass group= one of list_groups(path) "
                           f"(first: {first!r})")
    name = _group_name(group)
    if "/" + name not in info["groups"]:
        raise DatasetError(f"{path}: has no trajectory group '{name}' (groups: "
                           f"{', '.join(info['groups'][:5]) or 'none'}{', ...' if len(info['groups']) > 5 else ''})")
    return f[name], "/" + name


def _plain(value):
    return value.item() if isinstance(value, np.generic) else value


def _int_attr(attrs, key, path, where) -> int:
    value = attrs[key]
    if isinstance(value, np.ndarray) and value.shape == ():
        value = value[()]
    if not isinstance(value, (int, np.integer)) or isinstance(value, bool):
        raise DatasetError(f"{path}: attribute '{key}' of {where} is {_plain(value)!r}; expected an integer")
    return int(value)


def _float_attr(attrs, key, path, where) -> float:
    value = attrs[key]
    if isinstance(value, np.ndarray) and value.shape == ():
        value = value[()]
    if not isinstance(value, (int, float, np.integer, np.floating)) or isinstance(value, bool):
        raise DatasetError(f"{path}: attribute '{key}' of {where} is {_plain(value)!r}; expected a number")
    return float(value)


def _str_attr(attrs, key, path, where) -> str:
    value = attrs[key]
    if isinstance(value, bytes):
        value = value.decode("utf-8", "replace")
    if not isinstance(value, str):
        raise DatasetError(f"{path}: attribute '{key}' of {where} is {_plain(value)!r}; expected a string")
    return value


def _json_attr(attrs, key, path, where):
    text = _str_attr(attrs, key, path, where)
    try:
        return json.loads(text)
    except ValueError:
        raise DatasetError(f"{path}: attribute '{key}' of {where} is not valid JSON; the file is damaged, "
                           f"re-create it") from None


_REQUIRED_ATTRS = ("softrnn_schema", "softrnn_version", "dt", "rod", "scenario", "units", "n_nodes_total", "attrs")


def _layout(g: h5py.Group, path: Path, where: str) -> tuple[int, int, dict]:
    """Check the group's datasets (names, shapes, dtypes) and attributes; return T, N and attrs."""
    for key in _REQUIRED_ATTRS:
        if key not in g.attrs:
            raise DatasetError(f"{path}: attribute '{key}' is missing from {where}; the file was not written "
                               f"completely by softrnn, re-create it")
    expected = {"time": (1, np.float64), "nodes": (1, np.int64)}
    expected.update({name: (3, np.float32) for name in FIELDS})
    for name, (ndim, dtype) in expected.items():
        if name not in g or not isinstance(g[name], h5py.Dataset):
            raise DatasetError(f"{path}: dataset '{name}' is missing from {where}; the file is incomplete or "
                               f"not a softrnn trajectory, re-create it")
        ds = g[name]
        if ds.ndim != ndim:
            raise DatasetError(f"{path}: {name} has {ds.ndim} dimensions (shape {ds.shape}); expected {ndim}")
        if ds.dtype != dtype:
            raise DatasetError(f"{path}: {name} has dtype {ds.dtype}; expected {np.dtype(dtype).name}")
    T, N = g["time"].shape[0], g["nodes"].shape[0]
    if T < 1 or N < 1:
        raise DatasetError(f"{path}: the trajectory is empty (T={T} samples, N={N} nodes)")
    for name in FIELDS:
        want = (T, N, _WIDTH[name])
        if g[name].shape != want:
            raise DatasetError(f"{path}: {name} has shape {g[name].shape} but time has T={T} and nodes N={N}; "
                               f"expected {want}")
    attrs = {
        "schema_version": _int_attr(g.attrs, "softrnn_schema", path, where),
        "softrnn_version": _str_attr(g.attrs, "softrnn_version", path, where),
        "units": _json_attr(g.attrs, "units", path, where),
        "rod": _json_attr(g.attrs, "rod", path, where),
        "scenario_text": _str_attr(g.attrs, "scenario", path, where),
        "seed": _int_attr(g.attrs, "seed", path, where) if "seed" in g.attrs else None,
        "dt": _float_attr(g.attrs, "dt", path, where),
        "n_nodes_total": _int_attr(g.attrs, "n_nodes_total", path, where),
    }
    if not np.isfinite(attrs["dt"]) or attrs["dt"] <= 0:
        raise DatasetError(f"{path}: attribute dt={attrs['dt']!r} of {where} is invalid; expected a positive "
                           f"interval in s")
    extra = _json_attr(g.attrs, "attrs", path, where)
    if not isinstance(extra, dict):
        raise DatasetError(f"{path}: attribute 'attrs' of {where} is not a JSON object; re-create the file")
    attrs.update(extra)
    return T, N, attrs


def _check_values(path: Path, where: str, time, nodes, arrays: dict, t_offset: int) -> None:
    if np.any(nodes < 0) or np.unique(nodes).size != nodes.size:
        raise DatasetError(f"{path}: nodes of {where} are not unique non-negative indices; re-create the file")
    for name, arr in (("time", time),) + tuple(arrays.items()):
        finite = np.isfinite(arr)
        if not finite.all():
            idx = np.argwhere(~finite)[0]
            raise DatasetError(f"{path}: {name} of {where} has a non-finite value at sample {t_offset + idx[0]}"
                               f"{f', column {idx[1]}' if arr.ndim > 1 else ''}; the data is invalid, re-create it")
    if time.size > 1 and np.any(np.diff(time) <= 0):
        i = int(np.argmax(np.diff(time) <= 0))
        raise DatasetError(f"{path}: time of {where} is not strictly increasing at sample {t_offset + i + 1}; "
                           f"the data is invalid, re-create it")
    q = arrays.get("quaternions")
    if q is not None and q.size:
        off = np.abs(np.sqrt(np.sum(q.astype(np.float64) ** 2, axis=-1)) - 1.0)
        if off.max() > QUATERNION_TOLERANCE:
            idx = np.unravel_index(int(np.argmax(off)), off.shape)
            raise DatasetError(f"{path}: the quaternion of {where} at sample {t_offset + idx[0]}, column {idx[1]} "
                               f"is not unit (| |q| - 1 | = {off[idx]:.3g}); the data is invalid, re-create it")


def read_dataset(path, *, nodes=None, group: str | None = None, start: int | None = None,
                 stop: int | None = None) -> Dataset:
    """Read (part of) a trajectory, checking the layout, shapes, dtypes and values.

    Parameters
    ----------
    path : str or Path
        A softrnn HDF5 file.
    nodes : sequence of int or None
        Rod node indices to read (negative: from the rod's end), in the order wanted; only those
        columns are read from disk. None: all stored nodes.
    group : str or None
        The trajectory of a sweep file (one of ``list_groups(path)``); None or '/' for a
        single-trajectory file.
    start, stop : int or None
        Sample range ``start:stop`` (Python slice rules, negative from the end).

    Returns
    -------
    Dataset
        Arrays in the stored dtypes (time float64, nodes int64, the rest float32) and the attrs.

    Raises
    ------
    DatasetError
        One line naming the file and the problem: missing file, not HDF5, truncated or corrupt, not
        a softrnn dataset, newer schema, missing or malformed dataset/attribute, non-finite values.
    """
    path = Path(path)
    for name, value in (("start", start), ("stop", stop)):
        if value is not None and (isinstance(value, bool) or not isinstance(value, (int, np.integer))):
            raise bad(name, value, "an integer sample index or None")
    if nodes is not None and (isinstance(nodes, (int, np.integer, str)) or not hasattr(nodes, "__iter__")):
        raise bad("nodes", nodes, "a list of node indices (use read_node for one node) or None")
    with _Reading(path) as f:
        g, where = _select(f, path, group)
        T, N, attrs = _layout(g, path, where)
        stored = g["nodes"][...]
        a, b, _ = slice(start, stop).indices(T)
        b = max(a, b)
        time = g["time"][a:b]
        if nodes is None:
            cols = None
            arrays = {name: g[name][a:b] for name in FIELDS}
        else:
            cols = _columns(stored, list(nodes), attrs["n_nodes_total"], str(path))
            arrays = {}
            for name in FIELDS:
                out = np.empty((b - a, len(cols), _WIDTH[name]), dtype=np.float32)
                for j, c in enumerate(cols):
                    out[:, j] = g[name][a:b, c, :]
                arrays[name] = out
        _check_values(path, where, time, stored, arrays, a)
    sel = stored if cols is None else stored[cols]
    return Dataset(time=time, nodes=sel, attrs=attrs, **arrays)


def read_node(path, node: int, *, group: str | None = None) -> Dataset:
    """One node's whole series (N = 1), reading only that node's chunks from disk."""
    if isinstance(node, bool) or not isinstance(node, (int, np.integer)):
        raise bad("node", node, "an integer node index")
    return read_dataset(path, nodes=[int(node)], group=group)


def list_groups(path) -> list[str]:
    """The trajectories in ``path``, as values for ``group=``.

    A single-trajectory file gives ``['/']``; a sweep file gives its groups sorted by name
    (``['/traj-00000', '/traj-00001', ...]``, possibly empty). So
    ``for g in list_groups(p): read_dataset(p, group=g)`` works for both kinds.
    """
    return list(_inspect(path)["groups"])


def trajectories(path) -> list[tuple[Path, str]]:
    """Every trajectory under ``path`` as (file, group) pairs: a file (single or sweep) or a folder
    of ``*.h5`` files (sorted by name; not recursive)."""
    path = Path(path)
    files = sorted(path.glob("*.h5")) if path.is_dir() else [path]
    return [(f, g) for f in files for g in list_groups(f)]


def merge_files(paths, out_path) -> None:
    """Combine trajectory files into one sweep file, one group each (``traj-00000``, ... in order).

    Parameters
    ----------
    paths : folder, or sequence of files
        A folder means its ``*.h5`` files sorted by name. Sweep files contribute all their groups.
    out_path : str or Path
        The sweep file, written atomically (not one of the inputs).

    Every input is read and validated first; the chunks are then copied without recompression.
    """
    out_path = Path(out_path)
    if isinstance(paths, (str, os.PathLike)) and Path(paths).is_dir():
        files = sorted(Path(paths).glob("*.h5"))
        if not files:
            raise DatasetError(f"{paths}: the folder holds no *.h5 files to merge")
    elif isinstance(paths, (str, os.PathLike)):
        files = [Path(paths)]
    else:
        files = [Path(p) for p in paths]
    if not files:
        raise bad("paths", paths, "a folder of .h5 files or a non-empty list of files")
    if any(f.resolve() == out_path.resolve() for f in files):
        raise bad("out_path", str(out_path), "a file that is not one of the inputs")
    sources = []
    for f in files:
        for g in list_groups(f):
            read_dataset(f, group=g)  # full validation before anything is written
            sources.append((f, g))
    tmp = _temp_path(out_path)
    try:
        with _h5open(tmp, "w") as out:
            out.attrs["softrnn_schema"] = SCHEMA_VERSION
            out.attrs["softrnn_version"] = __version__
            out.attrs["kind"] = "sweep"
            for i, (f, g) in enumerate(sources):
                with _Reading(f) as src:
                    grp = src[g]
                    dst = out.create_group(sweep_group_name(i))
                    for key, value in grp.attrs.items():
                        if key != "kind":
                            dst.attrs[key] = value
                    for name in ("time", "nodes") + FIELDS:
                        src.copy(grp[name], dst, name=name)
        os.replace(tmp, out_path)
    except BaseException:
        if tmp.exists():
            tmp.unlink()
        raise


# ----------------------------------------------------------------------------------------- summary
def describe(path, *, group: str | None = None, max_nodes: int = 3, verify: bool = True) -> dict:
    """Summary of a dataset file for ``softrnn show``.

    Parameters
    ----------
    path : str or Path
    group : str or None
        Trajectory to summarise in a sweep file (default: its first).
    max_nodes : int
        How many nodes get per-node ranges (first, middle, last).
    verify : bool
        Also read the whole trajectory, block by block (bounded memory), and check every value
        (finite, unit quaternions, readable chunks). False: read only the time axis and the
        summarised nodes.

    Returns
    -------
    dict (JSON-ready)
        ``path``, ``file_size_bytes``, ``kind``, ``groups``, ``group``, ``n_samples``, ``n_nodes``,
        ``n_nodes_total``, ``nodes``, ``time_start_s``, ``time_end_s``, ``duration_s``, ``dt_s``,
        ``dt_uniform`` (every step within 1e-6 dt of dt), ``stored_values`` (all arrays of all groups),
        ``bytes_per_value`` (file size / stored values), ``storage`` (per array: dtype, chunks,
        compression, stored bytes), ``node_ranges`` (per summarised node: position min/max [m],
        max |force| [N], max |torque| [N m]), ``verified`` and ``attrs``.
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
        stored = g["nodes"][...]
        time = g["time"][...]
        total_values = 0
        for gname in info["groups"]:
            gg = f[gname]
            total_values += sum(int(gg[n].size) for n in ("time", "nodes") + FIELDS if n in gg)
        if verify:
            step = max(1, TIME_CHUNK)
            for a in range(0, T, step):
                block = {name: g[name][a:a + step] for name in FIELDS}
                _check_values(path, where, time[a:a + step], stored, block, a)
        storage = {}
        for name in ("time", "nodes") + FIELDS:
            ds = g[name]
            storage[name] = {"dtype": ds.dtype.name, "shape": list(ds.shape),
                             "chunks": list(ds.chunks) if ds.chunks else None,
                             "compression": ds.compression, "compression_opts": ds.compression_opts,
                             "shuffle": bool(ds.shuffle), "stored_bytes": int(ds.id.get_storage_size())}
    size = path.stat().st_size
    picks = sorted({0, N // 2, N - 1})[:max_nodes]
    part = read_dataset(path, nodes=[int(stored[j]) for j in picks], group=where)
    ranges = []
    for j in range(part.n_nodes):
        p = part.positions[:, j].astype(np.float64)
        ranges.append({
            "node": int(part.nodes[j]),
            "position_min_m": p.min(axis=0).tolist(), "position_max_m": p.max(axis=0).tolist(),
            "max_force_n": float(np.linalg.norm(part.forces[:, j].astype(np.float64), axis=1).max()),
            "max_torque_nm": float(np.linalg.norm(part.torques[:, j].astype(np.float64), axis=1).max()),
        })
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
        "storage": storage, "node_ranges": ranges, "verified": bool(verify), "attrs": attrs,
    }
