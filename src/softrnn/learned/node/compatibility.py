"""Whether a node model can be applied to a data set (its node and neighbours stored, the units,
the rod's node count, the sample interval and the actuation channels of its training data), and
what the model's metadata says of that data (rod length, scenario, training record); each problem
is a one-line ``SoftrnnInputError``."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ...errors import SoftrnnInputError
from ...io.reader import read_dataset
from .data import IRREGULAR_DT_TOLERANCE, node_positions_sha256, regular_times
from .manipulator import _stored, describe_model, model_inputs

DT_TOLERANCE = 1e-3
"""Largest relative difference between the data set's and the model's sample interval."""


def model_dataset_meta(model) -> dict:
    """The training data set's metadata recorded in the model (``meta['dataset']``, or {})."""
    meta = getattr(model, "meta", None) or {}
    ds = meta.get("dataset") if isinstance(meta, dict) else None
    return ds if isinstance(ds, dict) else {}


def _rod_length(rod) -> float | None:
    if isinstance(rod, dict):
        value = rod.get("length")
        if isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value) and value > 0:
            return float(value)
    return None


def _n_nodes_total(d: dict) -> int | None:
    value = d.get("n_nodes_total")
    if value is None and isinstance(d.get("rod"), dict):
        value = d["rod"].get("n_nodes")
    return int(value) if isinstance(value, (int, np.integer)) and not isinstance(value, bool) else None


def rod_length(model, dataset) -> float | None:
    """The rod length [m] for percentages: the data set's (``attrs['rod']['length']``), else the
    model's training data's, else None."""
    trained = model_dataset_meta(model)
    return (_rod_length(dataset.attrs.get("rod")) or _rod_length(trained.get("rod"))
            or _rod_length({"length": trained.get("rod_length_m")}))


def check_compatible(model, dataset, where: str = "the data set", *, sampling: bool = True) -> None:
    """Raise a one-line SoftrnnInputError unless ``model`` can be applied to ``dataset``: it stores
    the model's node and neighbours, has the units, rod node count and sample interval of the
    model's training data (where the model records them; ``sampling=False`` leaves the interval
    out, for a first look at a file's first sample)."""
    node, neighbours = model_inputs(model)
    stored = set(int(a) for a in np.asarray(dataset.nodes))
    for b in (node, *neighbours):
        if b not in stored:
            what = f"node {b}" if b == node else f"node {b} (a neighbour of node {node})"
            raise SoftrnnInputError(f"{where} does not store {what}, which the model ({describe_model(model)}) "
                                    f"needs; stored nodes: {_stored(sorted(stored))}; use a data set that stores "
                                    f"the model's node and its neighbours")
    trained = model_dataset_meta(model)
    units, mine = trained.get("units"), dataset.attrs.get("units")
    if isinstance(units, dict) and isinstance(mine, dict):
        fields = ["positions", "forces", "torques"] + (["quaternions"] if model.spec.inputs == "poses" else [])
        for f in fields:
            if f in units and f in mine and units[f] != mine[f]:
                raise SoftrnnInputError(f"{where} stores {f} in {mine[f]!r} but the model was trained on "
                                        f"{units[f]!r}; convert the data set to the model's units")
    _check_channels(model, dataset, trained, where)
    total, theirs = _n_nodes_total(dataset.attrs), _n_nodes_total(trained)
    if total is not None and theirs is not None and total != theirs:
        raise SoftrnnInputError(f"{where} is a rod of {total} nodes but the model was trained on one of {theirs}: "
                                f"node {node} is another point of the rod; use data of a rod discretised "
                                f"like the training data")
    if sampling:
        _check_sampling(dataset, trained, where)


def _check_sampling(dataset, trained: dict, where: str) -> None:
    """The recording's sample interval is the model's (within ``DT_TOLERANCE``, or within
    ``IRREGULAR_DT_TOLERANCE`` of the median step where the rows come at irregular intervals)."""
    dt, their_dt = dataset.attrs.get("dt"), trained.get("dt")
    tolerance = DT_TOLERANCE if regular_times(dataset) else IRREGULAR_DT_TOLERANCE
    if isinstance(dt, (int, float)) and isinstance(their_dt, (int, float)) and their_dt > 0 \
            and abs(dt - their_dt) > tolerance * their_dt:
        raise SoftrnnInputError(f"{where} is sampled every {dt:g} s but the model predicts steps of {their_dt:g} s; "
                                f"use data sampled like the training data")


def _check_channels(model, dataset, trained: dict, where: str) -> None:
    """A model driven by actuation inputs needs each of its channels in ``dataset``, in the unit
    it was trained on (``trained['actuation_units']``, where recorded); one-line errors."""
    spec = model.spec
    if getattr(spec, "drive", "wrench") == "wrench":
        return
    have = dict(getattr(dataset, "actuation_units", None) or {})
    units = trained.get("actuation_units") or {}
    for name in spec.channels:
        if name not in have:
            raise SoftrnnInputError(f"{where} has no actuation channel {name!r}, which the model "
                                    f"({describe_model(model)}) reads (channels: {', '.join(have) or 'none'}); use "
                                    f"a data set that records the model's actuation inputs")
        if name in units and units[name] != have[name]:
            raise SoftrnnInputError(f"{where} records actuation {name!r} in {have[name]!r} but the model was trained "
                                    f"on {units[name]!r}; convert the channel to the model's unit")


def trained_on(model) -> str | None:
    """The scenario (or file) the model was trained on, as its metadata records it."""
    d = model_dataset_meta(model)
    for key in ("scenario_name", "scenario", "name", "path", "file"):
        if isinstance(d.get(key), str) and d[key]:
            return d[key]
    return None


def load_for_model(model, path, *, group: str | None = None):
    """Read from ``path`` only what ``model`` needs (its node and neighbours, every sample),
    after checking compatibility on the file's metadata. Errors are one line."""
    head = read_dataset(path, group=group, stop=1)           # stored nodes and attrs
    check_compatible(model, head, where=str(path), sampling=False)
    node, neighbours = model_inputs(model)
    data = read_dataset(path, nodes=[node, *neighbours], group=group)
    check_compatible(model, data, where=str(path))
    return data


def same_record(model, dataset, source=None) -> bool:
    """Whether ``dataset`` (read from ``source``, or None) is the model's training record: for a
    model trained on a whole record, by its node's positions (``node_positions_sha256``); else by
    the file's path, or its name and sample count."""
    sessions = (getattr(model, "meta", None) or {}).get("training_data") or {}
    digest = (sessions.get("train") or {}).get("node_positions_sha256")
    if digest:
        return node_positions_sha256(dataset, model.spec.node) == digest
    known = model_dataset_meta(model)
    if source is None or not isinstance(known.get("path"), str):
        return False
    try:
        if Path(source).resolve() == Path(known["path"]).resolve():
            return True
    except OSError:
        return False
    return Path(source).name == known.get("file") and known.get("n_samples") == int(dataset.n_samples)
