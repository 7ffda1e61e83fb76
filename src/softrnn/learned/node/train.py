"""Training a node model: Adam on mini-batches, chronological early stopping, per-epoch checkpoints.

The sample spans (``split``): the first ``train_fraction`` of the samples is the training span, the
rest the test span, which training never reads beyond its metadata. The training span is cut again
chronologically: its last ``validation_fraction`` is the validation span used for early stopping
(the weights of the best validation epoch are kept). Windows never straddle either cut, and the
``Normalizer`` is fitted on the fit span (the training span before the validation cut) alone.

With a separate validation recording (``validation``: another session of the same robot), every
sample of the training record is a training sample (the fit span is the whole record, there is no
test span) and the whole validation recording is the validation span; meta.json records both
files (``training_data``), so ``evaluate`` knows the model saw all of its training record.

The loss (``rollout_steps`` = K, default 4) runs the model K steps ahead on each training window,
feeding its own predicted node positions back (neighbours and wrenches stay the recorded ones),
and averages the K one-step errors, each measured against the true next position; the validation
loss is the same on the validation span. K = 1 is plain one-step training (the paper's).

Long series are subsampled: when the fit span holds more than ``max_train_windows`` windows, every
``stride``-th window is used (stride = ceil(windows / max_train_windows), the same stride for
validation); consecutive windows at 0.1 ms are nearly identical, so little is lost. The stride is
recorded in the model's meta.json.

Every finished epoch is checkpointed to ``<out_folder>/checkpoint.pt`` (module, optimiser, the
shuffling generator's state, the best weights so far, history); ``resume=True`` continues from it
exactly, so an interrupted run followed by a resumed one gives the same weights as one
uninterrupted run. The finished model replaces the checkpoint (``save_model``). ``resume=True``
with a larger budget (more epochs, or more patience after an early stop) on a finished model
trains on from its kept weights with a new optimiser (not the same as one longer run: the
optimiser's state and the last epoch's weights were not kept).
"""

from __future__ import annotations

import time
from dataclasses import asdict
from pathlib import Path

import numpy as np

from ... import __version__
from ...errors import bad
from ...progress import Progress
from ..checkpoints import Checkpoint
from ._checkpoint import epochs_left, finished_state, load_finished, nothing_left, training_settings
from ._epochs import new_module, torch_settings, train_epochs
from .artifact import NodeModel, check_replaceable, save_model
from .data import SampleSpec, node_positions_sha256, wrench_units
from .model import ModelConfig
from .normalizer import Normalizer
from .train_config import TrainConfig
from .training_data import (
    TrainingData,
    dataset_meta,
    fingerprint,
    load_training_data,
    training_tensors,
)

_FIXED = ("pose_features", "wrench_features", "history")


# ------------------------------------------------------------------------------------------ train
def train_node_model(dataset_path, spec: SampleSpec, model_config_overrides: dict | None, train: TrainConfig,
                     out_folder, *, resume: bool = False, progress: Progress | None = None, pool=None,
                     validation=None, validation_group: str | None = None, group: str | None = None,
                     refuse_done: bool = False) -> NodeModel:
    """Train one node's model on ``dataset_path`` (a file, its sweep ``group``, or a ``Dataset``) and save it.

    ``spec`` (resolved here) sets the node, neighbours, history, inputs, wrench and train fraction;
    ``model_config_overrides`` other ``ModelConfig`` fields (``{"lstm_units": 64}``); ``train`` the
    ``TrainConfig``. ``out_folder`` is new, empty, or an earlier model or unfinished training (replaced).
    ``resume`` continues from its ``checkpoint.pt`` (same settings but epochs, patience, threads) or
    trains a finished model on; ``refuse_done`` then refuses one with nothing left to train. ``pool``:
    one model shared by these nodes (windows pooled; use ``relative=True``). ``validation`` (and
    ``validation_group``): a separate validation recording, the whole training record then being
    trained on. ``progress(done, total, info)`` after every batch (``info``: epoch, epochs, loss, and
    the validation losses). The spans, pooling and resume rules: docs/guide/models.md#training.

    Returns
    -------
    NodeModel
        The best validation epoch's weights, in eval mode (also saved).
    """
    if not isinstance(spec, SampleSpec):
        raise bad("spec", type(spec).__name__, "a SampleSpec")
    if not isinstance(train, TrainConfig):
        raise bad("train", type(train).__name__, "a TrainConfig")
    overrides = dict(model_config_overrides or {})
    out_folder = Path(out_folder)
    check_replaceable(out_folder)
    t0 = time.perf_counter()
    prepared = load_training_data(dataset_path, spec, train, pool, validation=validation,
                                  validation_group=validation_group, group=group)
    config = _model_config(prepared.spec, overrides)
    normalizer = Normalizer.fit(prepared.fit, output=config.output, relative=config.relative,
                                per_node=prepared.spec.per_node,
                                wrench_units=wrench_units(prepared.data, prepared.spec))
    data_fingerprint = fingerprint(prepared.fit, prepared.validation)
    settings = training_settings(prepared.spec, config, train, data_fingerprint, prepared.pool)
    checkpoint = Checkpoint(out_folder, settings)
    finished, start = _finished(checkpoint, train, refuse_done) if resume else (None, None)
    if finished is not None and start is None:
        return finished
    objective, fit, validation = training_tensors(prepared, normalizer, config, train)
    with torch_settings(train.threads):
        module = new_module(config, normalizer, train.seed)
        if finished is not None:
            module.load_state_dict(finished.module.state_dict())
        state = train_epochs(module, objective, fit, validation, train, checkpoint, resume=resume, progress=progress,
                             start=start)
    meta = _meta(prepared, train, state, n_windows=(int(fit[0].shape[0]), int(validation[0].shape[0])),
                 data_fingerprint=data_fingerprint, seconds=time.perf_counter() - t0, start=start)
    model = NodeModel(config=config, spec=prepared.spec, normalizer=normalizer, module=module, meta=meta)
    save_model(out_folder, model)
    return model


def _finished(checkpoint: Checkpoint, train: TrainConfig, refuse_done: bool) -> tuple:
    """For a resume: (None, None) where the folder holds no finished model (or an unfinished
    training's checkpoint); (the finished model, the loop state to train on from) where ``train``
    leaves epochs to run; (the finished model, None) to return it as is (nothing left, the same
    epochs, not ``refuse_done``); else the ``nothing_left`` refusal."""
    folder = checkpoint.folder
    if checkpoint.path.exists() or not (folder / "config.json").exists():
        return None, None
    finished = load_finished(folder, checkpoint.settings)
    start = finished_state(finished.meta)
    if epochs_left(start, train):
        return finished, start
    if refuse_done or finished.meta.get("train_config", {}).get("epochs") != train.epochs:
        raise nothing_left(folder, start, train)
    return finished, None


def _model_config(spec: SampleSpec, overrides: dict) -> ModelConfig:
    """The ``ModelConfig`` of the resolved ``spec`` with the caller's ``overrides`` (which may not
    set the fields that come from the spec, ``_FIXED``; ``overrides`` loses those)."""
    for name in _FIXED:
        if name in overrides and overrides[name] != getattr(spec, name):
            raise bad(f"model_config_overrides[{name!r}]", overrides[name], "no value: it comes from the spec")
        overrides.pop(name, None)
    try:
        return ModelConfig(pose_features=spec.pose_features, wrench_features=spec.wrench_features,
                           history=spec.history, **overrides)
    except TypeError as err:
        raise bad("model_config_overrides", sorted(overrides), f"ModelConfig fields ({err})") from None


def _meta(prepared: TrainingData, train: TrainConfig, state: dict, *, n_windows: tuple[int, int],
          data_fingerprint: str, seconds: float, start: dict | None = None) -> dict:
    """The model's meta.json: the data, spans and windows trained on (``n_windows``: training and
    validation tensors), the settings, the history of the epoch loop's ``state`` and the wall time
    [s]; for a finished model trained on (``start``, its loop state), the epochs it had run
    (``continued_after_epoch``)."""
    sp, spec = prepared.spans, prepared.spec
    meta = {
        "softrnn_version": __version__,
        "dataset": dataset_meta(prepared.data, prepared.path, prepared.group),
        "node": spec.node,
        "window_nodes": list(spec.window_nodes),
        "pool": list(prepared.pool) if prepared.pool is not None else None,
        "spans": sp.to_dict(),
        "train_span": [sp.fit.start, sp.validation.stop],
        "test_span": [sp.test.start, sp.test.stop],
        "stride": prepared.stride,
        "train_windows": n_windows[0],
        "validation_windows": n_windows[1],
        "train_config": asdict(train),
        "history": state["history"],
        "epochs_run": state["epoch"],
        "early_stopped": state["epoch"] < train.epochs,
        "best_epoch": state["best_epoch"],
        "best_validation_loss": state["best_validation_loss"],
        "train_seconds": sum(h["seconds"] for h in state["history"]),
        "wall_seconds": seconds,
        "data_fingerprint": data_fingerprint,
    }
    if prepared.whole_record:
        meta["training_data"] = separate_sessions(prepared)
    if start is not None:
        meta["continued_after_epoch"] = start["epoch"]
    return meta


def separate_sessions(prepared: TrainingData) -> dict:
    """What meta.json records of training on a whole record validated on another
    (``training_data``): {span: 'whole record', train: {path (absolute), file, group, n_samples,
    node_positions_sha256}, validation: {path, file, group, n_samples}}; paths None for data passed
    in memory. ``evaluate`` finds the training data by it (``node_positions_sha256``)."""
    def entry(path, group, data) -> dict:
        return {"path": None if path is None else str(Path(path).absolute()),
                "file": None if path is None else Path(path).name, "group": group,
                "n_samples": int(np.asarray(data.time).shape[0])}

    train = entry(prepared.path, prepared.group, prepared.data)
    train["node_positions_sha256"] = node_positions_sha256(prepared.data, prepared.spec.node)
    return {"span": "whole record", "train": train,
            "validation": entry(prepared.validation_path, prepared.validation_group, prepared.validation_data)}
