"""A node model's training data: the chronological spans, the (pooled, subsampled) windows and their tensors.

The spans and the subsampling stride are explained in ``softrnn.learned.node.train``; the tensors are
those of the loss (``_losses``): one-step windows for ``rollout_steps`` = 1, windows K - 1 steps
longer for the K-step loss.
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Protocol

import numpy as np

from ...errors import SoftrnnInputError, bad
from ...io.reader import Dataset, read_dataset
from ...io.record import scenario_name
from ._losses import _MultiStep, _OneStep, _RelativeMultiStep
from .data import (
    IRREGULAR_DT_TOLERANCE,
    Normalizer,
    SampleSpec,
    Windows,
    check_spans,
    make_windows,
    regular_times,
    split,
)
from .model import ModelConfig


class _WindowSettings(Protocol):
    """What the windows read of a ``TrainConfig``."""

    validation_fraction: float
    max_train_windows: int


# ------------------------------------------------------------------------------------------ spans
@dataclass(frozen=True)
class Spans:
    """Sample spans ``range(start, stop)``: fit (normalisation and gradient steps), validation
    (early stopping), test (never read by training); fit + validation = the training span."""

    fit: range
    validation: range
    test: range

    def to_dict(self) -> dict:
        """``{"fit": [start, stop], "validation": [start, stop], "test": [start, stop]}`` (sample indices)."""
        return {name: [r.start, r.stop] for name, r in
                (("fit", self.fit), ("validation", self.validation), ("test", self.test))}


def spans(n_samples: int, spec: SampleSpec, validation_fraction: float) -> Spans:
    """The chronological fit / validation / test spans of ``n_samples`` samples."""
    train_span, test_span = split(n_samples, spec)
    cut = train_span.stop
    vcut = int(math.floor(cut * (1.0 - validation_fraction)))
    check_spans(spec, vcut, cut - vcut,
                f"the training span of {cut} samples splits into {vcut} for fitting and {cut - vcut} for validation")
    return Spans(fit=range(0, vcut), validation=range(vcut, cut), test=test_span)


def pooled_specs(spec: SampleSpec, pool) -> list[SampleSpec]:
    """The resolved ``spec`` moved to every node of ``pool`` (neighbours at the same offsets from
    the node, as ``manipulator.model_inputs`` applies a shared model); None: ``[spec]``."""
    if pool is None:
        return [spec]
    offsets = [a - spec.node for a in spec.neighbours]
    return [replace(spec, node=int(a), neighbours=tuple(int(a) + o for o in offsets)) for a in pool]


def _concat(parts: list[Windows]) -> Windows:
    if len(parts) == 1:
        return parts[0]
    return Windows(poses=np.concatenate([w.poses for w in parts]), wrenches=np.concatenate([w.wrenches for w in parts]),
                   targets=np.concatenate([w.targets for w in parts]), index=np.concatenate([w.index for w in parts]))


def whole_spans(n_samples: int, n_validation: int, spec: SampleSpec) -> Spans:
    """The spans of training on a whole record with a separate validation recording: fit = every
    sample of the training record, validation = every sample of the validation recording (its own
    indices), test = empty (``range(n_samples, n_samples)``: the training record holds none)."""
    need = spec.history + 1
    if n_samples < need:
        raise bad("history", spec.history, f"a history that fits the data: the training record has {n_samples} "
                                           f"samples and a window needs history + 1 = {need}; use a shorter "
                                           f"history or a longer record")
    if n_validation < need:
        raise bad("validate_on", f"a recording of {n_validation} samples",
                  f"a validation recording of at least history + 1 = {need} samples; record a longer "
                  f"validation session or use a shorter history")
    return Spans(fit=range(0, n_samples), validation=range(0, n_validation), test=range(n_samples, n_samples))


def training_windows(dataset, spec: SampleSpec, train: _WindowSettings,
                     pool=None, validation=None) -> tuple[Windows, Windows, Spans, int]:
    """The (subsampled) fit and validation windows of ``dataset`` and the spans and stride used.

    Only samples of the training span are touched: every returned window and target has a sample
    index below ``spans.test.start``. ``train`` is the ``TrainConfig`` (its ``validation_fraction``
    and ``max_train_windows`` are used). ``pool``: the windows of every node of ``pool`` (the spec
    moved there, ``pooled_specs``) are concatenated, for one model shared by those nodes; the
    stride then applies to the pooled count. ``validation``: a separate validation recording (a
    ``Dataset`` of the same nodes): every sample of ``dataset`` is then a training sample and the
    validation windows are those of the whole ``validation`` record (``whole_spans``).
    """
    specs = pooled_specs(spec, pool)
    if validation is None:
        s = spans(int(np.asarray(dataset.time).shape[0]), spec, train.validation_fraction)
        val = _concat([make_windows(dataset, sp, s.validation.start, s.validation.stop) for sp in specs])
    else:
        s = whole_spans(int(np.asarray(dataset.time).shape[0]), int(np.asarray(validation.time).shape[0]), spec)
        val = _concat([make_windows(validation, sp, s.validation.start, s.validation.stop) for sp in specs])
    fit = _concat([make_windows(dataset, sp, s.fit.start, s.fit.stop) for sp in specs])
    stride = max(1, math.ceil(len(fit) / train.max_train_windows))
    if stride > 1:
        fit, val = fit.take(slice(None, None, stride)), val.take(slice(None, None, stride))
    return fit, val, s, stride


# ------------------------------------------------------------------------------------------ loading
@dataclass(frozen=True, eq=False)
class TrainingData:
    """What training reads: the resolved spec, the data set of the window nodes, where it came
    from (None: passed in memory) and its group in a sweep file (``group``, None: a single
    trajectory), the pool as absolute node indices (None: one node), and the
    fit and validation windows with the spans and stride of ``training_windows``; with a separate
    validation recording, its data set (``validation_data``), where it came from
    (``validation_path``, None: passed in memory) and its group (``validation_group``)."""

    spec: SampleSpec
    data: object
    path: Path | None
    pool: tuple[int, ...] | None
    fit: Windows
    validation: Windows
    spans: Spans
    stride: int
    validation_data: object = None
    validation_path: Path | None = None
    validation_group: str | None = None
    group: str | None = None

    @property
    def whole_record(self) -> bool:
        """True when every sample of the training record is a training sample (a separate
        validation recording)."""
        return self.validation_data is not None


def load_training_data(dataset_path, spec: SampleSpec, train: _WindowSettings, pool=None, *,
                       validation=None, validation_group: str | None = None,
                       group: str | None = None) -> TrainingData:
    """Read the window nodes' columns of ``dataset_path`` (a path, read from ``group`` of a sweep
    file, or a ``Dataset``), resolve the spec and the pool against its nodes and cut the training
    windows (``training_windows``).

    ``validation``: a separate validation recording (a path, read from ``validation_group`` of a
    sweep file, or a ``Dataset``) with the same nodes, units, sample interval and actuation channels
    (``check_validation_data``): the whole of ``dataset_path`` is then trained on and the whole of
    ``validation`` validates (early stopping)."""
    resolved, data, path, pool = _load_data(dataset_path, spec, pool, group)
    val_data = val_path = None
    if validation is not None:
        need = sorted({a for sp in pooled_specs(resolved, pool) for a in sp.window_nodes})
        if isinstance(validation, Dataset):
            val_data = validation
            check_validation_data(data, val_data, resolved, need, "the validation data")
        else:
            val_path = Path(validation)
            if not val_path.is_file():
                raise bad("validate_on", str(val_path), "an existing data set file (the validation session's "
                                                        "recording)")
            head = read_dataset(val_path, group=validation_group, stop=1)
            check_validation_data(data, head, resolved, need, str(val_path))
            val_data = read_dataset(val_path, nodes=need, group=validation_group)
    fit, val, sp, stride = training_windows(data, resolved, train, pool, validation=val_data)
    return TrainingData(spec=resolved, data=data, path=path, pool=pool, fit=fit, validation=val, spans=sp,
                        stride=stride, validation_data=val_data, validation_path=val_path,
                        validation_group=validation_group if val_path is not None else None,
                        group=group if path is not None else None)


DT_TOLERANCE = 1e-3
"""Largest relative difference between the training and validation recordings' sample intervals."""


def check_validation_data(train_data, validation, spec: SampleSpec, nodes, where: str) -> None:
    """A one-line ``SoftrnnInputError`` (``validate_on=WHERE is invalid: ...``) unless the
    validation recording ``validation`` (its first sample is enough) can validate a model of the
    resolved ``spec`` trained on ``train_data``: it stores the window ``nodes``, the model's
    actuation channels in the training data's units, orientations for inputs 'poses', and the
    units, rod node count and sample interval of the training data."""
    stored = {int(a) for a in np.asarray(validation.nodes).reshape(-1)}
    missing = [a for a in nodes if int(a) not in stored]
    if missing:
        raise bad("validate_on", where, f"a recording storing the nodes the model reads ({', '.join(map(str, nodes))}),"
                                        f" but it has no node {missing[0]} (it stores "
                                        f"{', '.join(map(str, sorted(stored)[:12]))}); record the validation "
                                        f"session with the training session's markers")
    have = dict(getattr(validation, "actuation_units", None) or {})
    trained = dict(getattr(train_data, "actuation_units", None) or {})
    channels = tuple(spec.channels) if getattr(spec, "drive", "wrench") != "wrench" else ()
    for name in channels:
        if name not in have:
            raise bad("validate_on", where, f"a recording of the model's actuation channels "
                                            f"({', '.join(channels)}), but it has no channel {name!r} (it has "
                                            f"{', '.join(have) or 'none'}); validate on a session recorded "
                                            f"with the same actuation inputs")
        if name in trained and trained[name] != have[name]:
            raise bad("validate_on", where, f"actuation {name!r} in the training data's unit {trained[name]!r}, "
                                            f"but it records {have[name]!r}; convert the channel")
    if spec.inputs == "poses" and not validation.has_orientations:
        raise bad("validate_on", where, "a recording with orientations (the model reads poses); validate on a "
                                        "session that records orientations, or train with inputs 'positions'")
    units, mine = train_data.attrs.get("units"), validation.attrs.get("units")
    if isinstance(units, dict) and isinstance(mine, dict):
        for f in ("positions", "forces", "torques"):
            if f in units and f in mine and units[f] != mine[f]:
                raise bad("validate_on", where, f"{f} in the training data's unit {units[f]!r}, but it stores "
                                                f"{mine[f]!r}; convert the recording")
    total, theirs = validation.attrs.get("n_nodes_total"), train_data.attrs.get("n_nodes_total")
    if total is not None and theirs is not None and int(total) != int(theirs):
        raise bad("validate_on", where, f"a rod of {theirs} nodes like the training data, but it has {total}; "
                                        f"validate on a recording of the same rod")
    dt, their_dt = validation.attrs.get("dt"), train_data.attrs.get("dt")
    regular = regular_times(validation) and regular_times(train_data)
    if isinstance(dt, (int, float)) and isinstance(their_dt, (int, float)) and their_dt > 0 \
            and abs(dt - their_dt) > (DT_TOLERANCE if regular else IRREGULAR_DT_TOLERANCE) * their_dt:
        raise bad("validate_on", where, f"a recording sampled every {their_dt:g} s like the training data, but it "
                                        f"is sampled every {dt:g} s; resample it")


def _load_data(dataset_path, spec: SampleSpec, pool=None, group: str | None = None):
    """(resolved spec, dataset of the window nodes (of every pooled node), source description,
    the pool as absolute node indices or None); a path is read from ``group`` of a sweep file."""
    if isinstance(dataset_path, Dataset):
        data, path = dataset_path, None
        head = data
    else:
        path = Path(dataset_path)
        head = read_dataset(path, group=group, stop=1)                # every stored node, one sample
    total = head.attrs.get("n_nodes_total")
    if spec.inputs == "poses" and not head.has_orientations:   # identity placeholders are no orientations
        raise SoftrnnInputError("inputs='poses' is invalid: the data set has no orientations (has_orientations = "
                                "false, e.g. a CSV without n{i}_qw..qz columns); use inputs='positions'")
    resolved = spec.resolve(head.nodes, n_nodes_total=total).resolve_channels(head.actuation_names)
    pool = _resolve_pool(pool, resolved, head.nodes, total)
    if path is not None:
        need = sorted({a for sp in pooled_specs(resolved, pool) for a in sp.window_nodes})
        data = read_dataset(path, nodes=need, group=group)            # only the windows' columns
    return resolved, data, path, pool


def _resolve_pool(pool, spec: SampleSpec, stored, total) -> tuple[int, ...] | None:
    """Absolute pool nodes, each with its neighbours (at the spec's offsets) stored."""
    if pool is None:
        return None
    if isinstance(pool, (str, bytes)) or not hasattr(pool, "__iter__"):
        raise bad("pool", pool, "a sequence of node indices (the nodes sharing the model)")
    stored_set = {int(a) for a in np.asarray(stored).reshape(-1)}
    n = int(total) if total is not None else max(stored_set) + 1
    out = []
    for a in pool:
        if isinstance(a, bool) or not isinstance(a, (int, np.integer)):
            raise bad("pool", list(pool), "integer node indices")
        out.append(int(a) + n if a < 0 else int(a))
    if not out or len(set(out)) != len(out):
        raise bad("pool", list(pool), "distinct node indices, at least one")
    offsets = [b - spec.node for b in spec.neighbours]
    for a in out:
        missing = [a + o for o in (0, *offsets) if a + o not in stored_set]
        if missing:
            raise bad("pool", f"node {a}", f"nodes whose neighbours at offsets {offsets} are stored (node {missing[0]} "
                                           f"is not); pool interior nodes only, e.g. 1..{n - 2}")
    return tuple(out)


# ------------------------------------------------------------------------------------------ description
def _scenario_name(attrs: dict, path) -> str | None:
    """The data's scenario name (``softrnn.io.record.scenario_name``), else the file's stem."""
    name = scenario_name(attrs)
    if name is not None:
        return name
    return Path(path).stem if path is not None else None


def dataset_meta(data, path, group: str | None = None) -> dict:
    """The training data set as the model's meta.json records it (``dataset``): file, its group
    in a sweep file (only where one was read), scenario, samples, dt [s], rod, units, the actuation
    channels {name: unit} (only where the data set has any) and the data set's other attributes."""
    attrs = dict(data.attrs)
    rod = attrs.get("rod") if isinstance(attrs.get("rod"), dict) else None
    return {
        "path": str(path) if path is not None else None,
        "file": Path(path).name if path is not None else None,
        **({"group": group} if group not in (None, "/", "") else {}),
        "scenario_name": _scenario_name(attrs, path),
        "n_samples": int(np.asarray(data.time).shape[0]),
        "dt": float(data.dt),
        "rod": rod,
        "rod_length_m": float(rod["length"]) if rod and isinstance(rod.get("length"), (int, float)) else None,
        "units": attrs.get("units"),
        "n_nodes_total": attrs.get("n_nodes_total"),
        "seed": attrs.get("seed"),
        "softrnn_version": attrs.get("softrnn_version"),
        **({"actuation_units": dict(data.actuation_units)} if getattr(data, "actuation_units", None) else {}),
        "extra": {k: v for k, v in attrs.items() if k not in (
            "schema_version", "softrnn_version", "units", "rod", "scenario_text", "seed", "dt", "n_nodes_total",
            "scenario_record")},
    }


def fingerprint(fit: Windows, val: Windows) -> str:
    """SHA-256 (hex) of the fit and validation windows: a resumed run must see the same data."""
    h = hashlib.sha256()
    for arr in (fit.poses, fit.wrenches, fit.targets, fit.index, val.poses, val.targets, val.index):
        h.update(np.ascontiguousarray(arr).tobytes())
    return h.hexdigest()


# ------------------------------------------------------------------------------------------ tensors
def training_tensors(prepared: TrainingData, normalizer: Normalizer, config: ModelConfig, train) -> tuple:
    """The loss of ``train.rollout_steps`` = K steps and its fit and validation tensors.

    Returns ``(objective, (poses, wrenches, targets) of the fit span, the same of the validation
    span)``: for K = 1 the normalised one-step windows (M, H, P), (M, H, W), (M, 3); for K > 1
    windows K - 1 steps longer and the true node positions of the K steps (M, K, 3), as
    ``_MultiStep.tensors`` gives them. ``train`` is the ``TrainConfig``.
    """
    K = train.rollout_steps
    if K == 1:
        one = _OneStep(normalizer, prepared.spec, train.input_noise)
        return one, one.tensors(prepared.fit), one.tensors(prepared.validation)
    if config.relative and config.output == "pose":
        raise bad("rollout_steps", K, "1 for a model with relative inputs that predicts the next position "
                                      "itself (output='pose'); or use output='increment'")
    long_spec = replace(prepared.spec, history=prepared.spec.history + K - 1)
    try:
        fit_l, val_l = training_windows(prepared.data, long_spec, train, prepared.pool,
                                        validation=prepared.validation_data)[:2]
    except SoftrnnInputError:
        raise bad("rollout_steps", K, f"fewer steps: windows of {long_spec.history + 1} samples (the history and "
                                      f"the steps) do not fit the fit and validation spans; use rollout_steps=1 "
                                      f"or longer data") from None
    multi = (_RelativeMultiStep if config.relative else _MultiStep)(normalizer, config, K, train.input_noise)
    return multi, multi.tensors(fit_l), multi.tensors(val_l)
