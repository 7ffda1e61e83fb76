"""Reading trajectories: the ``Dataset`` of one trajectory, and reading (part of) one from a file, checked."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import SoftrnnInputError, bad
from ..rod.materials import MaterialSection
from ..rod.spec import NodeOverride, RodSpec
from ._checks import _check_values, _inspect, _layout, _select
from ._h5files import _Reading
from .record import read_record
from .schema import (
    _WIDTH,
    ACTUATION,
    CONTACT,
    CONTACT_FIELDS,
    FIELDS,
    HUB_CHANNELS,
    DatasetError,
    _node_list,
    _to_float32,
    actuation_units,
)


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
        ``scenario_text``, ``seed`` (int or None), ``dt`` [s], ``n_nodes_total``, every key the
        writer was given in ``attrs=``, and with contact fields ``contact``: the obstacles as
        ``softrnn.io.schema.contact_record`` gives them (None where they were not recorded).
    actuation : ndarray (T, m) float32 or None
        Named actuation inputs (tendon tensions, chamber pressures, coil currents, ...), one column
        per channel of ``actuation_units``, in those units. None (the default) means no channels:
        it becomes an empty (T, 0) array, so ``actuation`` is always an array and m = 0 marks a
        trajectory without actuation (every schema-1 file).
    actuation_units : dict {str: str} or None
        The channels in column order, name -> unit (``softrnn.io.schema.ACTUATION_UNITS``), e.g.
        ``{"tendon_1": "N", "p_chamber_2": "kPa"}``; None or {}: none.
    contact_forces : ndarray (T, N, 3) float32 or None
        Contact forces of the obstacles on the nodes [N] (normal force and friction), world frame,
        not part of ``forces``; None (the default) for a trajectory without contact, as
        ``softrnn.rod.Trajectory.contact_forces``.
    contact_torques : ndarray (T, N, 3) float32 or None
        Their torques about the nodes [N m] (the friction's moment), world frame; given exactly
        when ``contact_forces`` is.

    Notes
    -----
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
    actuation: np.ndarray | None = None
    actuation_units: dict | None = None
    contact_forces: np.ndarray | None = None
    contact_torques: np.ndarray | None = None

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
        units = actuation_units(self.actuation_units)
        object.__setattr__(self, "actuation_units", units)
        act = np.zeros((T, 0), np.float32) if self.actuation is None and not units else np.asarray(self.actuation)
        if act.shape != (T, len(units)):
            raise bad("actuation", None if self.actuation is None else f"array of shape {act.shape}",
                      f"shape (T, m) = {(T, len(units))}: one column per channel of actuation_units "
                      f"({', '.join(units) or 'none'})")
        object.__setattr__(self, "actuation", _to_float32(act))
        self._set_contact(T, N)

    def _set_contact(self, T: int, N: int) -> None:
        """Check the contact fields: both None, or both (T, N, 3) (converted to float32)."""
        given = [getattr(self, name) is not None for name in CONTACT_FIELDS]
        if any(given) and not all(given):
            raise bad("contact_torques" if given[0] else "contact_forces", None,
                      "an array (T, N, 3) as well: contact_forces and contact_torques come together")
        for name in CONTACT_FIELDS if all(given) else ():
            arr = np.asarray(getattr(self, name))
            if arr.shape != (T, N, 3) or not np.issubdtype(arr.dtype, np.number):
                raise bad(name, f"{arr.dtype} array of shape {arr.shape}", f"numbers of shape (T, N, 3) = {(T, N, 3)}")
            object.__setattr__(self, name, _to_float32(arr))

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
    def n_actuation(self) -> int:
        """m, the actuation channels (0: none)."""
        return int(self.actuation.shape[1])

    @property
    def actuation_names(self) -> tuple[str, ...]:
        """The actuation channels' names, in column order (() without actuation)."""
        return tuple(self.actuation_units)

    @property
    def hub(self) -> dict:
        """The hub's channels (``softrnn.io.schema.HUB_CHANNELS``: insertion [m], rotation [rad], and a
        driven hub's force [N] and torque [N m]) present, as {name: (T,) float64}; {} without a hub."""
        return {name: np.asarray(self.actuation[:, j], dtype=np.float64)
                for j, name in enumerate(self.actuation_names) if name in HUB_CHANNELS}

    @property
    def has_contact(self) -> bool:
        """True when the trajectory has contact loads (``contact_forces`` is not None)."""
        return self.contact_forces is not None

    @property
    def contact(self) -> dict | None:
        """The obstacles (``attrs['contact']``, a ``softrnn.io.schema.contact_record``), or None."""
        return self.attrs.get(CONTACT)

    @property
    def record(self):
        """The scenario record (``softrnn.io.record.ScenarioRecord``: what drove the run), or None for
        a file without one."""
        return read_record(self.attrs)

    @property
    def has_orientations(self) -> bool:
        """False where the quaternions are identity placeholders (a CSV without orientations)."""
        return bool(self.attrs.get("has_orientations", True))

    def column(self, node: int) -> int:
        """Column of rod node ``node`` (negative: counted from the rod's end, as in ``Setup``)."""
        return _columns(self.nodes, [node], self.attrs.get("n_nodes_total"), "dataset")[0]

    def rod_spec(self):
        """The ``softrnn.rod.RodSpec`` in ``attrs['rod']``, or None if absent or partial (lab data)."""
        rod = self.attrs.get("rod")
        if not isinstance(rod, dict):
            return None
        try:
            values = dict(rod)
            values["overrides"] = tuple(NodeOverride(**o) for o in values.get("overrides", ()))
            values["sections"] = tuple(MaterialSection(**o) for o in values.get("sections", ()))
            return RodSpec(**values)
        except (TypeError, SoftrnnInputError):
            return None


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


def read_dataset(path, *, nodes=None, group: str | None = None, start: int | None = None,
                 stop: int | None = None) -> Dataset:
    """Read (part of) a trajectory, checking it (a bad file: ``DatasetError``, one line naming it).

    Parameters
    ----------
    path : str or Path
        A softrnn HDF5 file.
    nodes : sequence of int or None
        Rod node indices to read (negative: from the rod's end), in the order wanted; only those
        columns are read from disk. None: all stored nodes.
    group : str or None
        The trajectory of a sweep file (``list_groups(path)``); None or '/' for a single one.
    start, stop : int or None
        Sample range ``start:stop`` (Python slice rules, negative from the end).

    Returns
    -------
    Dataset
        The arrays in their stored dtypes, ``actuation`` every channel whatever ``nodes``, and the attrs.
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
        names = FIELDS + (CONTACT_FIELDS if CONTACT in attrs else ())
        if nodes is None:
            cols = None
            arrays = {name: g[name][a:b] for name in names}
        else:
            cols = _columns(stored, list(nodes), attrs["n_nodes_total"], str(path))
            arrays = {}
            for name in names:
                out = np.empty((b - a, len(cols), _WIDTH[name]), dtype=np.float32)
                for j, c in enumerate(cols):
                    out[:, j] = g[name][a:b, c, :]
                arrays[name] = out
        units = attrs.pop("actuation_units")
        act = g[ACTUATION][a:b] if units else None
        _check_values(path, where, time, stored, arrays if act is None else dict(arrays, actuation=act), a)
    sel = stored if cols is None else stored[cols]
    return Dataset(time=time, nodes=sel, attrs=attrs, actuation=act, actuation_units=units, **arrays)


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
