"""Validation of stored files: the root's schema and kind, a trajectory group's layout and attributes, its values."""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np

from .. import __version__
from ..errors import SoftrnnInputError
from ._h5files import _Reading
from .record import RECORD, ScenarioRecord
from .schema import (
    _REQUIRED_ATTRS,
    _WIDTH,
    ACTUATION,
    CONTACT,
    CONTACT_FIELDS,
    CONTACT_SCHEMA,
    FIELDS,
    QUATERNION_TOLERANCE,
    DatasetError,
    _group_name,
    actuation_units,
    contact_from_record,
)


def _root_info(f: h5py.File, path: Path) -> dict:
    attrs = f.attrs
    if "softrnn_schema" not in attrs:
        raise DatasetError(f"{path}: not a softrnn dataset (no 'softrnn_schema' attribute); softrnn reads the "
                           f"HDF5 files it writes (DatasetWriter, 'softrnn import-csv'), see docs/dataset-format.md")
    schema = _int_attr(attrs, "softrnn_schema", path, "/")
    if schema > CONTACT_SCHEMA:
        raise DatasetError(f"{path}: written with dataset schema {schema}, newer than this softrnn "
                           f"({__version__}, schema {CONTACT_SCHEMA}); upgrade softrnn")
    if schema < 1:
        raise DatasetError(f"{path}: softrnn_schema={schema} is invalid; expected 1..{CONTACT_SCHEMA}")
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
    attrs["actuation_units"] = _actuation_layout(g, path, where, T)
    if any(name in g for name in CONTACT_FIELDS) or CONTACT in g.attrs:
        attrs[CONTACT] = _contact_layout(g, path, where, (T, N, 3))
    if RECORD in g.attrs:
        attrs[RECORD] = _record_attr(g, path, where)
    return T, N, attrs


def _record_attr(g: h5py.Group, path: Path, where: str) -> dict:
    """The group's scenario record (the ``scenario_record`` attribute, ``softrnn.io.record``), checked
    by rebuilding it."""
    record = _json_attr(g.attrs, RECORD, path, where)
    try:
        ScenarioRecord.from_record(record)
    except SoftrnnInputError as err:
        raise DatasetError(f"{path}: the scenario record of {where} is invalid ({err}); re-create the "
                           f"file") from None
    return record


def _contact_layout(g: h5py.Group, path: Path, where: str, shape: tuple) -> dict | None:
    """The group's stored obstacles (the ``contact`` attribute: a record of
    ``schema.contact_record``, or None where the writer was not given them) after checking that
    the contact datasets ``contact_forces`` and ``contact_torques`` are both there, float32 of
    ``shape`` (T, N, 3), with the attribute."""
    for name in CONTACT_FIELDS:
        ds = g.get(name)
        if not isinstance(ds, h5py.Dataset) or ds.shape != shape or ds.dtype != np.float32:
            found = "missing" if ds is None else f"shape {getattr(ds, 'shape', None)}, {getattr(ds, 'dtype', None)}"
            raise DatasetError(f"{path}: {name} of {where} is {found}; a trajectory with contact has "
                               f"contact_forces and contact_torques, float32 {shape}, re-create the file")
    if CONTACT not in g.attrs:
        raise DatasetError(f"{path}: attribute 'contact' of {where} is missing beside its contact datasets; "
                           f"re-create the file")
    record = _json_attr(g.attrs, CONTACT, path, where)
    if record is not None:
        try:
            contact_from_record(record)
        except SoftrnnInputError as err:
            raise DatasetError(f"{path}: the contact obstacles of {where} are invalid ({err}); re-create the "
                               f"file") from None
    return record


def _actuation_layout(g: h5py.Group, path: Path, where: str, T: int) -> dict[str, str]:
    """The group's actuation channels {name: unit} in column order, after checking the optional
    ``actuation`` dataset (shape (T, m), float32, attributes ``names`` and ``units``: JSON lists of
    m strings); {} when the group has none (schema 1 files never do)."""
    if ACTUATION not in g:
        return {}
    ds = g[ACTUATION]
    if not isinstance(ds, h5py.Dataset) or ds.ndim != 2 or ds.dtype != np.float32 or ds.shape[0] != T:
        shape = getattr(ds, "shape", None)
        raise DatasetError(f"{path}: actuation of {where} has shape {shape} and dtype {getattr(ds, 'dtype', None)}; "
                           f"expected float32 (T, m) with T={T}, re-create the file")
    lists = []
    for key in ("names", "units"):
        if key not in ds.attrs:
            raise DatasetError(f"{path}: attribute '{key}' of actuation of {where} is missing; re-create the file")
        value = _json_attr(ds.attrs, key, path, f"actuation of {where}")
        distinct = key == "units" or len(set(map(str, value))) == len(value)    # channels may share a unit
        if not isinstance(value, list) or len(value) != ds.shape[1] or not distinct:
            what = "distinct strings" if key == "names" else "strings"
            raise DatasetError(f"{path}: attribute '{key}' of actuation of {where} is not a list of {ds.shape[1]} "
                               f"{what} (one per column); re-create the file")
        lists.append(value)
    try:
        return actuation_units(dict(zip(*lists)), "actuation")
    except SoftrnnInputError as err:
        raise DatasetError(f"{path}: the actuation channels of {where} are invalid ({err}); re-create the "
                           f"file") from None


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
