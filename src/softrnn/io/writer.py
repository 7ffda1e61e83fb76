"""Writing trajectories to HDF5 files, atomically: streamed (``DatasetWriter``) or whole (``write_trajectory``)."""

from __future__ import annotations

import json
import os
import shutil
import weakref
from dataclasses import asdict, is_dataclass
from pathlib import Path

import h5py
import numpy as np

from .. import __version__
from ..errors import SoftrnnInputError, bad, one_line
from ..files import json_default, temporary_path, write_fault
from ._checks import _inspect
from ._h5files import _discard, _h5open, write_errno
from .reader import Dataset
from .record import RECORD, ScenarioRecord
from .schema import (
    _DESCRIPTION,
    _WIDTH,
    ACTUATION,
    COMPRESSION,
    CONTACT,
    CONTACT_DESCRIPTION,
    CONTACT_FIELDS,
    CONTACT_SCHEMA,
    CONTACT_UNITS,
    FIELDS,
    POSITION_LIMIT_M,
    QUATERNION_TOLERANCE,
    RESERVED_ATTRS,
    SCHEMA_VERSION,
    TIME_CHUNK,
    UNITS,
    DatasetError,
    _group_name,
    _node_list,
    _short,
    _to_float32,
    check_trajectory_room,
    contact_record,
)
from .schema import actuation_units as _channels


def _to_json(argument: str, value) -> str:
    try:
        return json.dumps(value, allow_nan=False, default=json_default)
    except (TypeError, ValueError) as err:
        raise bad(argument, value, f"JSON-serialisable values (numbers, strings, lists, dicts; "
                                   f"no NaN/inf): {one_line(err)}") from None


def _record_json(record) -> str:
    """A scenario record (``ScenarioRecord`` or its stored dict, checked by rebuilding it) as JSON."""
    if isinstance(record, dict):
        ScenarioRecord.from_record(record)
    elif isinstance(record, ScenarioRecord):
        record = record.to_record()
    else:
        raise bad("record", type(record).__name__, "a softrnn.io.record.ScenarioRecord, a stored record, or None")
    return _to_json("record", record)


def _rod_dict(rod):
    if rod is None:
        return None
    if is_dataclass(rod) and not isinstance(rod, type):
        return json.loads(_to_json("rod", asdict(rod)))
    if isinstance(rod, dict):
        return json.loads(_to_json("rod", rod))
    raise bad("rod", type(rod).__name__, "a softrnn.rod.RodSpec, a dict of rod properties, or None")


def _node_array(nodes) -> np.ndarray:
    """The writer's ``nodes`` argument (an int n: nodes 0..n-1) as a checked array (N,) of unique
    node indices >= 0."""
    if isinstance(nodes, (int, np.integer)) and not isinstance(nodes, bool):
        nodes = np.arange(int(nodes))
    node_arr = np.asarray(nodes)
    if node_arr.ndim != 1 or node_arr.size == 0 or not np.issubdtype(node_arr.dtype, np.integer):
        raise bad("nodes", _short(nodes), "a non-empty sequence of 0-based node indices")
    if node_arr.min() < 0 or np.unique(node_arr).size != node_arr.size:
        raise bad("nodes", _short(node_arr.tolist()), "unique node indices >= 0")
    return node_arr


def _check_arguments(*, n_samples, dt, scenario_text, seed) -> None:
    """Check the writer's scalar arguments (see ``DatasetWriter``)."""
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


def _attrs_json(attrs) -> str:
    """The caller's extra metadata (None: none) as JSON, its keys checked against ``RESERVED_ATTRS``."""
    attrs = {} if attrs is None else attrs
    if not isinstance(attrs, dict) or not all(isinstance(k, str) for k in attrs):
        raise bad("attrs", attrs, "a dict with string keys")
    clash = sorted(set(attrs) & set(RESERVED_ATTRS))
    if clash:
        raise bad("attrs", clash, f"keys other than the reserved {', '.join(RESERVED_ATTRS)} "
                                  f"(pass those as arguments)")
    return _to_json("attrs", attrs)


def _n_nodes_total(node_arr: np.ndarray, rod_d: dict | None) -> int:
    """The rod's node count: ``rod_d["n_nodes"]`` where the rod gives it (every stored node must
    lie below it), else one past the largest stored node."""
    n_total = int(node_arr.max()) + 1
    if rod_d is not None and isinstance(rod_d.get("n_nodes"), int):
        if node_arr.max() >= rod_d["n_nodes"]:
            raise bad("nodes", _short(node_arr.tolist()), f"node indices below rod.n_nodes={rod_d['n_nodes']}")
        n_total = rod_d["n_nodes"]
    return n_total


class DatasetWriter:
    """Streams one trajectory into an HDF5 file, atomically.

    Parameters
    ----------
    path : str or Path
        Output file. It is written as ``.STEM.XXXX.tmp.h5`` in the same folder and renamed onto
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
    actuation_units : dict {str: str} or None
        The actuation channels, name -> unit, in column order (e.g. ``{"tendon_1": "N",
        "tendon_2": "N"}``; names ``softrnn.io.schema.ACTUATION_NAME``, units
        ``ACTUATION_UNITS``). Every chunk then brings their values (k, m) (``append``), stored as
        the ``actuation`` dataset. None or {}: no actuation (nothing is stored).
    contact : softrnn.rod.Contact, dict or None
        The obstacles of the run (``Setup.contact``, or a stored record such as ``Dataset.contact``),
        stored as the JSON attribute ``contact`` (``schema.contact_record``); every chunk must then
        bring its contact loads (``contact_forces``, ``contact_torques`` (k, N, 3)). None: the
        chunks decide; if the first brings contact loads they are stored, with the attribute
        ``contact`` = null (obstacles not recorded); else none is stored and the file is exactly
        that of a run without contact.
    record : ScenarioRecord, dict or None
        What drove the run (``softrnn.io.record``; ``Scenario.record`` for a simulated scenario, or a
        stored record such as ``Dataset.attrs["scenario_record"]``), stored as the JSON attribute
        ``scenario_record``; None: none is stored.

    Notes
    -----
    Use as ``Simulator.run(config, sink=writer.append)`` inside ``with DatasetWriter(...) as writer``.
    A trajectory with contact loads is written as schema ``CONTACT_SCHEMA`` (3), one without as
    ``SCHEMA_VERSION`` (2).
    """

    def __init__(self, path, *, nodes, n_samples: int, dt: float, rod=None, scenario_text: str = "",
                 seed: int | None = None, attrs: dict | None = None, group: str | None = None,
                 actuation_units: dict | None = None, contact=None, record=None,
                 _softrnn_version: str | None = None):
        self.path = Path(path)
        node_arr = _node_array(nodes)
        self._contact_record = contact_record(contact)
        self.has_contact = False
        self.actuation_units = _channels(actuation_units)
        _check_arguments(n_samples=n_samples, dt=dt, scenario_text=scenario_text, seed=seed)
        user_json = _attrs_json(attrs)
        rod_d = _rod_dict(rod)
        n_total = _n_nodes_total(node_arr, rod_d)
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
        if record is not None:
            self._meta[RECORD] = _record_json(record)
        self._written = 0
        self._buffer: list[dict] = []
        self._buffered = 0
        self._last_time = -np.inf
        self._state = "open"
        self._h5 = None
        self._tmp = None
        check_trajectory_room(self.path, self.n_samples, self.nodes.size, len(self.actuation_units),
                              self._contact_record is not None)
        self._open()
        if self._contact_record is not None:
            self._start_contact(self._contact_record)

    # ------------------------------------------------------------------ file set-up
    def _open(self) -> None:
        if self.group is not None and self.path.exists():
            info = _inspect(self.path)
            if info["kind"] != "sweep":
                raise DatasetError(f"{self.path}: holds a single trajectory, not a sweep; cannot add group "
                                   f"'{self.group}' (write to a new file, or merge_files both)")
            if "/" + self.group in info["groups"]:
                raise DatasetError(f"{self.path}: group '{self.group}' already exists; choose another name")
        try:
            self._tmp = temporary_path(self.path)
        except OSError as err:     # an unwritable or vanished folder
            self._state = "aborted"
            raise (write_fault(err, self.path) if err.errno else err) from None
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
            g = self._group = self._h5 if self.group is None else self._h5.create_group(self.group)
            if self.group is None:
                g.attrs["kind"] = "trajectory"
            for key, value in self._meta.items():
                g.attrs[key] = value
            self._create_datasets(g)
        except (OSError, RuntimeError) as err:     # a full disk
            self._failed(err)
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
        m = len(self.actuation_units)
        if m:
            ds = g.create_dataset(ACTUATION, shape=(T, m), dtype="<f4", chunks=(c, m), **COMPRESSION)
            ds.attrs["names"] = json.dumps(list(self.actuation_units))
            ds.attrs["units"] = json.dumps(list(self.actuation_units.values()))
            ds.attrs["description"] = "actuation inputs, one column per channel (names and units in order)"
            self._ds[ACTUATION] = ds

    def _start_contact(self, record: dict | None) -> None:
        """Make this a trajectory with contact (schema ``CONTACT_SCHEMA``): the ``contact`` attribute
        (``record``, None: null), the contact units and datasets (T, N, 3), a sweep root's schema."""
        try:
            g, (T, N, c) = self._group, (self.n_samples, self.nodes.size, self._chunk_len)
            g.attrs["softrnn_schema"] = CONTACT_SCHEMA
            g.attrs["units"] = json.dumps(dict(UNITS, **CONTACT_UNITS))
            g.attrs[CONTACT] = json.dumps(record)
            if self.group is not None and int(self._h5.attrs["softrnn_schema"]) < CONTACT_SCHEMA:
                self._h5.attrs["softrnn_schema"] = CONTACT_SCHEMA
            for name in CONTACT_FIELDS:
                ds = g.create_dataset(name, shape=(T, N, 3), dtype="<f4", chunks=(c, 1, 3), **COMPRESSION)
                ds.attrs["units"] = CONTACT_UNITS[name]
                ds.attrs["description"] = CONTACT_DESCRIPTION[name]
                ds.attrs["frame"] = "world"
                self._ds[name] = ds
        except BaseException:
            self.abort()
            raise
        self.has_contact = True

    # ------------------------------------------------------------------ streaming
    def append(self, chunk, actuation=None) -> None:
        """Add the next k samples. Invalid data (wrong shape, NaN/inf, times not increasing, too many
        samples, non-unit quaternions, positions beyond ``POSITION_LIMIT_M``) raises ``DatasetError``
        and discards the file being written.

        Parameters
        ----------
        chunk : Trajectory, Dataset or any object with
            ``time`` (k,) [s], ``positions`` (k, N, 3) [m], ``quaternions`` (k, N, 4),
            ``forces`` (k, N, 3) [N] and ``torques`` (k, N, 3) [N m] (and optionally ``nodes`` (N,),
            which must equal the writer's, and ``contact_forces`` (k, N, 3) [N] and
            ``contact_torques`` (k, N, 3) [N m], None without contact). The arrays are copied.
        actuation : ndarray (k, m) or None
            The actuation channels' values in the writer's ``actuation_units`` (column order);
            None: the chunk's own ``actuation`` attribute. Required when the writer has channels.
        """
        if self._state != "open":
            raise DatasetError(f"{self.path}: the writer is {self._state}; create a new DatasetWriter")
        try:
            rows = self._validate_chunk(chunk, actuation)
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
            try:
                self._flush(final=False)
            except (OSError, RuntimeError) as err:     # a full disk
                self._failed(err)

    def _validate_chunk(self, chunk, actuation=None) -> dict:
        """The chunk's arrays, checked, as float64 times (k,) and float32 copies of the rest."""
        rows = self._chunk_rows(chunk)
        self._actuation_rows(rows, chunk, actuation)
        self._contact_rows(rows, chunk)
        if rows["time"].shape[0] == 0:
            return rows
        self._check_rows(rows)
        return _float32_rows(rows, f"{self.path}: cannot write")

    def _chunk_rows(self, chunk) -> dict:
        """The chunk's arrays (time as a float64 copy), after checking that it has them all, in the
        writer's shapes and nodes, and no more samples than ``n_samples`` allows."""
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
        return rows

    def _actuation_rows(self, rows: dict, chunk, actuation) -> None:
        """Add the chunk's actuation values (k, m) to ``rows`` (``actuation``, else the chunk's
        attribute) after checking their shape against the writer's channels."""
        where = f"{self.path}: cannot write"
        value = getattr(chunk, "actuation", None) if actuation is None else actuation
        k, m = rows["time"].shape[0], len(self.actuation_units)
        if value is None or (m and np.shape(value)[-1:] == (0,)):
            if m:
                raise DatasetError(f"{where}: the chunk has no actuation values but the writer has {m} channels "
                                   f"({', '.join(self.actuation_units)}); pass append(chunk, actuation=(k, m) array)")
            return
        arr = np.asarray(value)
        if arr.shape != (k, m) or not np.issubdtype(arr.dtype, np.number):
            fix = ("pass actuation_units={name: unit, ...} to the writer" if not m else
                   f"one column per channel {', '.join(self.actuation_units)}")
            raise DatasetError(f"{where}: actuation has shape {arr.shape} ({arr.dtype}) but the chunk has k={k} "
                               f"samples and the writer m={m} actuation channels; expected {(k, m)} numbers ({fix})")
        if m:
            rows[ACTUATION] = arr

    def _contact_rows(self, rows: dict, chunk) -> None:
        """Add the chunk's contact loads (k, N, 3) to ``rows`` after checking them against the
        writer's; the first chunk of a writer without ``contact`` that brings them starts the
        contact datasets (``_start_contact``)."""
        where = f"{self.path}: cannot write"
        values = [getattr(chunk, name, None) for name in CONTACT_FIELDS]
        if values[0] is None and values[1] is None:
            if self.has_contact:
                raise DatasetError(f"{where}: the chunk has no contact_forces/contact_torques but the writer stores "
                                   f"contact loads; pass chunks of a run with contact (or contact=None)")
            return
        k, N = rows["time"].shape[0], self.nodes.size
        for name, value in zip(CONTACT_FIELDS, values):
            arr = None if value is None else np.asarray(value)
            if arr is None or arr.shape != (k, N, 3) or not np.issubdtype(arr.dtype, np.number):
                found = "missing" if arr is None else f"shape {arr.shape} ({arr.dtype})"
                raise DatasetError(f"{where}: {name} is {found} but the chunk has k={k} samples and the writer "
                                   f"N={N} nodes; expected {(k, N, 3)} numbers (both contact fields, or neither)")
            rows[name] = arr
        if not self.has_contact:
            if self._written + self._buffered:
                raise DatasetError(f"{where}: the chunk has contact loads but earlier chunks had none; every "
                                   f"chunk of a trajectory with contact brings them")
            self._start_contact(None)

    def _check_rows(self, rows: dict) -> None:
        """Check the values of a non-empty chunk: finite, times increasing after the last written
        one, positions within ``POSITION_LIMIT_M``, unit quaternions."""
        where = f"{self.path}: cannot write"
        first = self._written + self._buffered
        for name, arr in rows.items():
            finite = np.isfinite(arr)
            if not finite.all():
                idx = np.argwhere(~finite)[0]
                at = f"sample {first + idx[0]}" + (f", node {self.nodes[idx[1]]}" if arr.ndim > 2 else "")
                if name == ACTUATION:
                    at += f", channel {list(self.actuation_units)[idx[1]]}"
                raise DatasetError(f"{where}: {name} has a non-finite value ({float(arr[tuple(idx)])}) at {at}; "
                                   f"every value must be finite")
        t_all = np.concatenate([[self._last_time], rows["time"]])
        steps = np.diff(t_all)
        if np.any(steps <= 0):
            i = int(np.argmax(steps <= 0))
            raise DatasetError(f"{where}: time is not strictly increasing at sample {first + i} "
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
            raise DatasetError(f"{where}: the quaternion at sample {first + idx[0]}, "
                               f"node {self.nodes[idx[1]]} has norm {norm[idx]:.6g}; expected unit quaternions "
                               f"(w, x, y, z) to within {QUATERNION_TOLERANCE:g}")

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
            self._h5.flush()      # a full disk fails here, where the file can still be closed (``_failed``)
            self._h5.close()
            os.replace(self._tmp, self.path)
        except (OSError, RuntimeError) as err:     # a full disk
            self._failed(err)
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

    def _failed(self, err: Exception):
        """A write into the file failed (a full disk, a vanished folder): discard the file without
        writing into it again (``_h5files._discard(..., failed=True)``: an HDF5 file whose write
        failed cannot be closed otherwise, and crashes the process at exit), then raise
        ``files.write_fault`` naming ``path`` (``err`` itself where it has no error number and the
        folder is still there: HDF5 gives none when the folder vanishes while the file is made)."""
        self._state = "aborted"
        fin = getattr(self, "_finalizer", None)
        if fin is not None:
            fin.detach()
        if self._tmp is not None:
            _discard(self._h5, str(self._tmp), failed=True)
        code = write_errno(err, self.path)
        if code is None:
            raise err
        raise write_fault(OSError(code, os.strerror(code)), self.path) from None

    def __enter__(self) -> DatasetWriter:
        return self

    def __exit__(self, exc_type, exc, tb) -> bool:
        if exc_type is not None:
            self.abort()
        else:
            self.close()
        return False


def _float32_rows(rows: dict, where: str) -> dict:
    """``rows`` with float32 copies of the per-node arrays (time stays float64); values beyond the
    float32 range are an error."""
    for name in FIELDS + tuple(n for n in (ACTUATION,) + CONTACT_FIELDS if n in rows):
        if name == "quaternions":
            rows[name] = _to_float32(rows[name]).copy()
            continue
        arr32 = _to_float32(rows[name])
        if not np.isfinite(arr32).all():
            raise DatasetError(f"{where}: {name} has values beyond the float32 range (|x| > 3.4e38); "
                               f"check the units")
        rows[name] = np.array(arr32, copy=True)
    return rows


def write_trajectory(path, traj, *, dt: float, rod=None, scenario_text: str = "", seed: int | None = None,
                     attrs: dict | None = None, group: str | None = None, actuation_units: dict | None = None,
                     actuation=None, contact=None, record=None) -> None:
    """Write a whole trajectory (``softrnn.rod.Trajectory`` or ``Dataset``) to ``path`` atomically.

    Parameters are those of ``DatasetWriter``; the nodes are ``traj.nodes``. ``actuation_units``
    None takes ``traj.actuation_units`` where the trajectory has them (a ``Dataset``), else none;
    ``actuation`` (T, m) None takes ``traj.actuation``. The contact loads are the trajectory's own
    (``traj.contact_forces``, ``traj.contact_torques``; None: none); ``contact`` (the run's
    ``Setup.contact``) None takes ``traj.contact`` where the trajectory has it (a ``Dataset``);
    ``record`` None takes ``traj.attrs["scenario_record"]`` where it has one.
    """
    if record is None:
        record = (getattr(traj, "attrs", None) or {}).get(RECORD)
    time = np.asarray(traj.time)
    if actuation_units is None:
        actuation_units = getattr(traj, "actuation_units", None)
    if contact is None and getattr(traj, "contact_forces", None) is not None:
        contact = getattr(traj, "contact", None)
    with DatasetWriter(path, nodes=np.asarray(traj.nodes), n_samples=int(time.shape[0]), dt=dt, rod=rod,
                       scenario_text=scenario_text, seed=seed, attrs=attrs, group=group,
                       actuation_units=actuation_units, contact=contact, record=record) as writer:
        writer.append(traj, actuation)


def write_dataset(path, dataset: Dataset, *, group: str | None = None) -> None:
    """Write a ``Dataset`` with its own metadata (dt, rod, scenario, seed, the producing softrnn
    version and its extra attrs), e.g. one read from another file: a bit-exact copy."""
    attrs = {k: v for k, v in dataset.attrs.items() if k not in RESERVED_ATTRS and k != "schema_version"}
    with DatasetWriter(path, nodes=dataset.nodes, n_samples=dataset.n_samples, dt=dataset.dt,
                       rod=dataset.attrs.get("rod"), scenario_text=dataset.attrs.get("scenario_text", ""),
                       seed=dataset.attrs.get("seed"), attrs=attrs, group=group,
                       actuation_units=dataset.actuation_units,
                       contact=dataset.contact if dataset.has_contact else None,
                       record=dataset.attrs.get(RECORD),
                       _softrnn_version=dataset.attrs.get("softrnn_version")) as writer:
        writer.append(dataset)
