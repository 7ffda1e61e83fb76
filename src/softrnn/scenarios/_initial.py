"""The ``[initial]`` table of a scenario beyond the shape kinds of ``[reference]``: given poses
(``kind = "poses"``: positions and scalar-first quaternions, inline or from a CSV file), a sample of a
softrnn dataset (``from = "dataset"``) and the static equilibrium of the scenario's own setup
(``from = "static"``, solved once the setup is built)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from ..errors import SimulationError, SoftrnnInputError
from ..io.reader import read_dataset
from ..io.summary import describe
from ..rod.shapes import RodShape
from ..rod.simulation import Setup
from ..rod.so3 import quaternion_to_matrix
from ..rod.spec import RodSpec
from ..statics.start import static_start
from ._sections import _SHAPE_KEYS, _shape
from .reading import _Ctx, _is_number, _read_csv, _Table, integer, number, rows3, string

QUATERNION_TOL = 1e-6
"""Largest accepted | |q| - 1 | of a given quaternion (it is then normalised)."""

_SOURCES = ("static", "dataset")
_KINDS = (*_SHAPE_KEYS, "poses")
_POSES_KEYS = {
    "kind": "the shape kind",
    "positions": "the node positions [[x, y, z], ...] in m, one row per node",
    "quaternions": "the node rotations [[qw, qx, qy, qz], ...], scalar first, body -> world, one row per node",
    "file": "a CSV file of x, y, z, qw, qx, qy, qz rows, one per node (instead of positions/quaternions)",
}
_FROM_KEYS = {
    "static": {"from": "\"static\" or \"dataset\"", "time": "the time in s the loads are taken at (default 0)"},
    "dataset": {"from": "\"static\" or \"dataset\"", "file": "a softrnn HDF5 dataset that saved every node",
                "sample": "the sample index (negative counts from the end; default -1, the last)",
                "group": "the trajectory of a sweep file, e.g. \"/traj-00003\""},
}


def _source(ctx: _Ctx, raw: dict) -> str | None:
    """The ``from`` of an ``[initial]`` table (None: a shape kind)."""
    if "from" not in raw:
        return None
    if "kind" in raw:
        raise ctx.error("initial", "initial: give kind (a shape) or from (static or dataset), not both")
    return _Table(ctx, {"from": raw["from"]}, "initial", {"from": ""}).get("from", string(_SOURCES))


def initial_shape(ctx: _Ctx, raw, rod: RodSpec) -> RodShape | None:
    """The ``[initial]`` table as a shape; None for ``from = "static"`` (``with_static_start`` then
    replaces the setup's initial shape, which is the reference until then)."""
    if not isinstance(raw, dict):
        return _shape(ctx, raw, "initial", rod)
    source = _source(ctx, raw)
    if source == "static":
        t = _Table(ctx, raw, "initial", _FROM_KEYS["static"])
        t.get("time", number("s"), 0.0)
        return None
    if source == "dataset":
        return _dataset(ctx, _Table(ctx, raw, "initial", _FROM_KEYS["dataset"]), rod)
    if raw.get("kind") == "poses":
        return _poses(ctx, _Table(ctx, raw, "initial", _POSES_KEYS), rod)
    if "kind" in raw and raw["kind"] not in _KINDS:
        t = _Table(ctx, {"kind": raw["kind"]}, "initial", {"kind": ""})
        t.get("kind", string(_KINDS))
    return _shape(ctx, raw, "initial", rod)


def with_static_start(ctx: _Ctx, doc: dict, setup: Setup) -> Setup:
    """``setup`` itself, or with the static equilibrium of its loads as its initial shape when the
    scenario's ``[initial]`` says ``from = "static"``."""
    raw = doc.get("initial")
    if not isinstance(raw, dict) or raw.get("from") != "static":
        return setup
    time = raw.get("time", 0.0)
    try:
        return dataclasses.replace(setup, initial=static_start(setup, float(time)))
    except (SoftrnnInputError, SimulationError) as exc:
        raise ctx.error("initial.from", f"initial.from = 'static': {exc}") from None


def _unit_rotations(ctx: _Ctx, key: str, q: np.ndarray) -> np.ndarray:
    """Rotation matrices (n, 3, 3) of the scalar-first quaternions q (n, 4), each of unit norm
    within ``QUATERNION_TOL``."""
    norm = np.linalg.norm(q, axis=1)
    off = np.abs(norm - 1.0)
    if off.max() > QUATERNION_TOL:
        i = int(np.argmax(off))
        raise ctx.invalid(key, f"a quaternion of norm {norm[i]:.6g} in row {i}",
                          f"unit quaternions [qw, qx, qy, qz] (| |q| - 1 | <= {QUATERNION_TOL:g})")
    return quaternion_to_matrix(q / norm[:, None])


def _rows4(ctx, key, x) -> np.ndarray:
    """A (K, 4) float array from a non-empty list of [qw, qx, qy, qz] rows."""
    if not isinstance(x, list) or not x or not all(
            isinstance(r, list) and len(r) == 4 and all(_is_number(c) and np.isfinite(c) for c in r) for r in x):
        raise ctx.invalid(key, x, "a list of [qw, qx, qy, qz] rows of numbers")
    return np.array(x, dtype=float)


def _poses(ctx: _Ctx, t: _Table, rod: RodSpec) -> RodShape:
    """``kind = "poses"``: positions and quaternions, inline or from a CSV file."""
    n = rod.n_nodes
    if t.has("file") == (t.has("positions") or t.has("quaternions")):
        raise ctx.error("initial", "initial: give positions and quaternions (inline) or file (CSV), not both "
                                   "and not neither, for kind = 'poses'")
    if t.has("file"):
        key = t.key("file")
        rows = _read_csv(ctx, key, t.raw["file"], 7)
        if rows.shape[0] != n:
            raise ctx.invalid(key, f"{rows.shape[0]} rows", f"{n} rows, one per node (rod.n_nodes)")
        return _shape_of(ctx, key, rows[:, :3], rows[:, 3:])
    positions = t.get("positions", rows3("m"))
    quaternions = t.get("quaternions", _rows4)
    for name, rows in (("positions", positions), ("quaternions", quaternions)):
        if rows.shape[0] != n:
            raise ctx.invalid(t.key(name), f"{rows.shape[0]} rows", f"{n} rows, one per node (rod.n_nodes)")
    return _shape_of(ctx, t.key("quaternions"), positions, quaternions)


def _shape_of(ctx: _Ctx, key: str, positions: np.ndarray, quaternions: np.ndarray) -> RodShape:
    rotations = _unit_rotations(ctx, key, quaternions)
    try:
        return RodShape(positions, rotations)
    except SoftrnnInputError as exc:
        raise ctx.wrap(key, exc) from None


def _dataset(ctx: _Ctx, t: _Table, rod: RodSpec) -> RodShape:
    """``from = "dataset"``: the poses of every node at one sample of a softrnn HDF5 dataset."""
    key = t.key("file")
    name = t.get("file", string(what="a dataset file name relative to the scenario file"))
    sample = t.get("sample", integer(), -1)
    group = t.get("group", string(what="a trajectory group of a sweep file"), None)
    if not name:
        raise ctx.invalid(key, name, "a dataset file name relative to the scenario file")
    if ctx.base is None:
        raise ctx.invalid(key, name, "inline poses (a scenario given as text has no folder for files)")
    path = Path(name) if Path(name).is_absolute() else Path(str(ctx.base.joinpath(name)))
    try:
        info = describe(path, group=group, max_nodes=1, verify=False)
    except SoftrnnInputError as exc:
        raise ctx.wrap(key, exc) from None
    total, n = info["n_samples"], rod.n_nodes
    if not -total <= sample < total:
        raise ctx.invalid(t.key("sample"), sample, f"a sample index in [-{total}, {total - 1}] (the dataset "
                                                   f"holds {total} samples)")
    if info["nodes"] != list(range(n)) or info["n_nodes_total"] != n:
        raise ctx.invalid(key, name, f"a dataset that saved every node 0..{n - 1} of a rod of {n} nodes "
                                     f"(rod.n_nodes); it saved {info['n_nodes']} of {info['n_nodes_total']} "
                                     "(save all nodes)")
    if not info["attrs"].get("has_orientations", True):
        raise ctx.invalid(key, name, "a dataset with node orientations (this one has positions only)")
    k = sample % total
    try:
        data = read_dataset(path, group=info["group"], start=k, stop=k + 1)
    except SoftrnnInputError as exc:
        raise ctx.wrap(key, exc) from None
    return _shape_of(ctx, key, data.positions[0].astype(float), data.quaternions[0].astype(float))
