"""``fit``: train a whole-manipulator model on the training parts of a ``Split`` (files in, model out);
``prepare_training``: its model folder's checkpoint lifecycle (``softrnn.learned.checkpoints``)."""

from __future__ import annotations

import ast
from pathlib import Path

from ...errors import SoftrnnInputError, bad
from ...progress import Progress
from ...resume import Settings
from ..checkpoints import CHECKPOINT, SETTINGS, TrainingFolder, output_folder
from .artifact import FILES, load_dynamic
from .config import DynamicConfig, resolve_node_stride
from .data import Split, rod_length
from .encoding import check_compatible, make_encoding
from .training import TrainedDynamic, read_checkpoint, train_dynamic_model


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
                             prescribed=config.prescribed, obstacles=config.obstacles, contact=config.contact,
                             frame=config.frame)
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


def training_settings(config: DynamicConfig, split: Split) -> Settings:
    """What a checkpoint or a finished model must match to be resumed: the config and the data."""
    return Settings.of({"config": config.to_dict(), "data": split.describe()}, keys=("config", "data"),
                       opaque={"data": "the {name} data differ"})


def model_folder(out, *, overwrite: bool) -> Path:
    """The checked output folder ``out`` of a training (``checkpoints.output_folder``): new, empty, or
    holding only a whole-manipulator model or an unfinished training (replaced only with ``overwrite``)."""
    return output_folder(out, holds=("model.json", CHECKPOINT, SETTINGS), ours=set(FILES) | {CHECKPOINT, SETTINGS},
                         overwrite=overwrite, made_by="'softrnn dynamic train'")


def prepare_training(folder, config: DynamicConfig, split: Split, *, resume: bool) -> TrainingFolder:
    """The training run in model ``folder`` (checked by ``checkpoints.output_folder``), started: with
    ``resume``, its checkpoint checked against the settings and read (a finished model there is
    refused: a finished training is not continued); otherwise an old checkpoint removed."""
    folder = Path(folder)
    run = TrainingFolder(folder, training_settings(config, split), created=not folder.exists())
    if resume and (folder / "model.json").is_file() and not run.checkpoint.is_file():
        model = load_dynamic(folder)
        run.check_finished({"config": model.config.to_dict(), "data": model.meta.get("data")})
        raise bad("resume", True, f"a training with steps left, but {folder} holds a finished model that already "
                                  f"ran its {model.config.steps} steps (a finished training is not continued); "
                                  "train with --overwrite to start again, or choose another folder")
    run.start(resume, read_checkpoint)
    return run
