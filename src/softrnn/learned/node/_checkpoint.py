"""A node training's resume rules: the settings a resumed run must match, and a finished model trained on.

Every finished epoch is saved to ``<out_folder>/checkpoint.pt`` (``softrnn.learned.checkpoints.Checkpoint``:
module, optimiser, the shuffling generator's state, the best weights so far, the loop's state and
history). A resumed run must use
the same settings (``training_settings``, a ``softrnn.resume.Settings``; epochs, patience and
threads may change) and data. A folder that already holds the finished model (``load_finished``)
is trained on from its weights where the new budget leaves epochs to run (``epochs_left``), and
otherwise returned as is (the same epochs) or refused (``nothing_left``).
"""

from __future__ import annotations

from dataclasses import asdict
from pathlib import Path

from ...resume import REFUSE, Difference, Settings, check
from ..artifacts import ModelFolderError
from .artifact import NodeModel, load_model
from .data import SampleSpec
from .model import ModelConfig

RESUMABLE = ("train.epochs", "train.patience", "train.threads")
"""The ``TrainConfig`` fields a run may change when it resumes an unfinished training."""
_DATA = {"data": "the training data differ"}


def training_settings(spec: SampleSpec, config: ModelConfig, train, data_fingerprint: str, pool, *,
                      may_differ=RESUMABLE) -> Settings:
    """What a checkpoint or a finished model must match to be resumed: the spec, the model config,
    the ``TrainConfig`` ``train`` (but ``may_differ``), the data's fingerprint and the pool."""
    settings = {"spec": spec.to_dict(), "model": config.to_dict(), "train": asdict(train), "data": data_fingerprint,
                "pool": list(pool) if pool is not None else None}
    return Settings.of(settings, may_differ=may_differ, opaque=_DATA)


def load_finished(folder: Path, settings: Settings) -> NodeModel:
    """The finished model in ``folder``, after checking that it was trained with ``settings``
    (``training_settings``: epochs, patience and threads may differ); raises ``ModelFolderError``
    otherwise."""
    model = load_model(folder)
    done = {"spec": model.spec.to_dict(), "model": model.config.to_dict(), "train": model.meta.get("train_config"),
            "data": model.meta.get("data_fingerprint"), "pool": model.meta.get("pool")}

    def refuse(diff: Difference) -> ModelFolderError:
        return ModelFolderError(f"{folder}: holds a finished model trained with other settings ({diff}); "
                                f"train with --overwrite instead of --resume to replace it, or choose another folder")

    check(done, settings, otherwise=REFUSE, refuse=refuse)
    return model


def finished_state(meta: dict) -> dict:
    """The epoch loop's state (``_epochs.train_epochs``) at the end of a finished model's training,
    from its meta.json: epochs run, the best epoch and its validation loss, the epochs since it
    (``bad_epochs``) and the history."""
    history = [dict(h) for h in meta.get("history") or []]
    done = int(meta.get("epochs_run", len(history)))
    best = int(meta.get("best_epoch", done))
    return {"epoch": done, "best_validation_loss": float(meta.get("best_validation_loss", "inf")), "best_epoch": best,
            "bad_epochs": done - best, "history": history}


def epochs_left(state: dict, train) -> bool:
    """Whether the ``TrainConfig`` ``train`` leaves epochs to run after the loop's ``state``: fewer
    epochs ran than ``train.epochs`` and early stopping (``train.patience``) has not ended it."""
    return state["epoch"] < train.epochs and state["bad_epochs"] < train.patience


def nothing_left(folder: Path, state: dict, train) -> ModelFolderError:
    """The one-line refusal of a resume that leaves a finished model nothing to train."""
    done, bad_epochs = state["epoch"], state["bad_epochs"]
    if done < train.epochs:       # stopped early: the patience is spent
        return ModelFolderError(f"{folder}: holds a finished model whose training stopped early after {done} epochs "
                                f"({bad_epochs} without a better validation loss, --patience {train.patience}); "
                                f"nothing is left to train: pass --patience above {bad_epochs} to train on, or train "
                                f"with --overwrite instead of --resume to start again")
    ran = f"{done} epoch{'s' * (done != 1)}"
    return ModelFolderError(f"{folder}: holds a finished model that already ran {ran}, and --epochs {train.epochs} "
                            f"leaves nothing to train: pass --epochs above {done} to train on from it, or train "
                            f"with --overwrite instead of --resume to start again")
