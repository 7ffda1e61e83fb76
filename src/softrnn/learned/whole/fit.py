"""``fit``: train a whole-manipulator model on the training parts of a ``Split`` (files in, model out)."""

from __future__ import annotations

import ast

from ...errors import SoftrnnInputError
from ...progress import Progress
from .config import DynamicConfig, resolve_node_stride
from .data import Split, rod_length
from .encoding import check_compatible, make_encoding
from .training import TrainedDynamic, train_dynamic_model


def fit(split: Split, config: DynamicConfig, *, progress: Progress | None = None, checkpoint=None,
        threads: int | None = None) -> tuple[TrainedDynamic, dict]:
    """Read ``split.train``, build the encoding (reference pose: the first part's first sample) and
    train. Returns the trained model and the ``meta`` a model folder records (``{"data": ...}``)."""
    datasets = [part.read() for part in split.train]
    if not datasets:
        raise SoftrnnInputError("data: nothing to train on (every input was held out); give more variants "
                                "or a smaller --heldout")
    first = datasets[0]
    encoding = make_encoding(datasets, model_dt=config.model_dt,
                             node_stride=resolve_node_stride(config.node_stride, first.n_nodes),
                             length=rod_length(first), feedback=config.feedback, drive=config.drive,
                             prescribed=config.prescribed, obstacles=config.obstacles)
    trajectories = [encoding.trajectory(d, name=f"{p.path}:{p.group}") for d, p in zip(datasets, split.train)]
    validation = []
    for p in split.validation:
        data = p.read()
        if p in split.validate_on:        # a separate recording: it must be one the model can read
            where = p.path + ("" if p.group == "/" else f":{p.group}")
            try:
                check_compatible(encoding, data, "validate_on")
            except SoftrnnInputError as err:
                raise SoftrnnInputError(f"validate_on={where!r} is invalid: {_reason(err)}") from None
        validation.append(encoding.trajectory(data, name=f"{p.path}:{p.group}"))
    trained = train_dynamic_model(trajectories, encoding, config, validation=validation, progress=progress,
                                  checkpoint=checkpoint, threads=threads)
    return trained, {"data": split.describe()}


def _reason(err: SoftrnnInputError) -> str:
    """'VALUE; give EXPECTED' of a ``name=VALUE is invalid: EXPECTED`` error (the text otherwise)."""
    head, sep, expected = str(err).partition(" is invalid: ")
    if not sep:
        return str(err)
    try:
        value = ast.literal_eval(head.partition("=")[2])
    except (ValueError, SyntaxError):
        value = head.partition("=")[2]
    return f"it is {value}; give {expected}"
