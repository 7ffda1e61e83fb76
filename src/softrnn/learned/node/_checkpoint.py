"""Training checkpoints: the per-epoch ``checkpoint.pt``, resuming from it, and the settings a resumed run must match.

Every finished epoch is saved to ``<out_folder>/checkpoint.pt`` (module, optimiser, the shuffling
generator's state, the best weights so far, the loop's state and history). A resumed run must use
the same settings (``training_settings``, a ``softrnn.resume.Settings``; epochs, patience and
threads may change) and data; a folder that already holds the finished model is returned as is
when it was trained with the same settings and epochs (``load_finished``).
"""

from __future__ import annotations

import io
from dataclasses import asdict, dataclass
from pathlib import Path

import torch

from ... import __version__
from ...files import atomic_write_bytes
from ...resume import REFUSE, Difference, Settings, check
from .artifact import CHECKPOINT, ModelFolderError, NodeModel, load_model
from .data import SampleSpec
from .model import ModelConfig

CHECKPOINT_VERSION = 1
RESUMABLE = ("train.epochs", "train.patience", "train.threads")
"""The ``TrainConfig`` fields a run may change when it resumes an unfinished training."""
FINISHED = ("train.patience", "train.threads")
"""The fields a run may change when it asks for a finished model: its epochs are what it ran."""
_DATA = {"data": "the training data differ"}


def training_settings(spec: SampleSpec, config: ModelConfig, train, data_fingerprint: str, pool, *,
                      may_differ=RESUMABLE) -> Settings:
    """What a checkpoint (or, with ``may_differ=FINISHED``, a finished model) must match to be
    resumed: the spec, the model config, the ``TrainConfig`` ``train`` (but ``may_differ``), the
    data's fingerprint and the pool."""
    settings = {"spec": spec.to_dict(), "model": config.to_dict(), "train": asdict(train), "data": data_fingerprint,
                "pool": list(pool) if pool is not None else None}
    return Settings.of(settings, may_differ=may_differ, opaque=_DATA)


def load_finished(folder: Path, settings: Settings) -> NodeModel:
    """The finished model in ``folder``, after checking that it was trained with ``settings``
    (``training_settings(..., may_differ=FINISHED)``); raises ``ModelFolderError`` otherwise (a
    finished training is never continued, so other epochs are refused too)."""
    model = load_model(folder)
    done = {"spec": model.spec.to_dict(), "model": model.config.to_dict(), "train": model.meta.get("train_config"),
            "data": model.meta.get("data_fingerprint"), "pool": model.meta.get("pool")}

    def refuse(diff: Difference) -> ModelFolderError:
        if diff.key == "train.epochs":
            return ModelFolderError(f"{folder}: holds a finished model whose training of {diff.old!r} epochs "
                                    f"already ended ({diff}); a finished training is not continued: train without "
                                    f"--resume to replace it, or choose another folder")
        return ModelFolderError(f"{folder}: holds a finished model trained with other settings ({diff}); "
                                f"train without --resume to replace it, or choose another folder")

    check(done, settings, otherwise=REFUSE, refuse=refuse)
    return model


@dataclass(frozen=True)
class Checkpoint:
    """The checkpoint of a training run in model folder ``folder`` with ``settings``
    (``training_settings``; stored as ``Settings.to_json``)."""

    folder: Path
    settings: Settings

    @property
    def path(self) -> Path:
        """``<folder>/checkpoint.pt``."""
        return self.folder / CHECKPOINT

    def save(self, module, optimizer, generator, state: dict, best: dict) -> None:
        """Write the checkpoint atomically: the module's and optimiser's state dicts, the
        generator's state, the loop's ``state`` and the ``best`` weights so far."""
        buf = io.BytesIO()
        torch.save({"checkpoint_version": CHECKPOINT_VERSION, "softrnn_version": __version__,
                    "settings": self.settings.to_json(), "module": module.state_dict(),
                    "optimizer": optimizer.state_dict(),
                    "generator": generator.get_state(), "state": state, "best": best}, buf)
        atomic_write_bytes(self.path, buf.getvalue())

    def restore(self, module, optimizer, generator, state: dict) -> dict:
        """Load the checkpoint into the given objects (``state`` updated in place); returns the
        best weights so far. Raises ``ModelFolderError`` for a corrupt checkpoint or one written
        with other settings."""
        try:
            ckpt = torch.load(self.path, map_location="cpu", weights_only=True)
            if not isinstance(ckpt, dict) or ckpt.get("checkpoint_version") != CHECKPOINT_VERSION:
                raise ValueError("not a softrnn training checkpoint of this version")
        except Exception as err:  # noqa: BLE001 - torch raises many types for a corrupt file
            raise self._corrupt(err) from None
        check(ckpt.get("settings"), self.settings, otherwise=REFUSE, refuse=self._other_settings)
        try:
            module.load_state_dict(ckpt["module"])
            optimizer.load_state_dict(ckpt["optimizer"])
            generator.set_state(ckpt["generator"])
            state.update(ckpt["state"])
            best = ckpt["best"]
        except (KeyError, RuntimeError, ValueError, TypeError) as err:
            raise self._corrupt(err) from None
        return best

    def _other_settings(self, diff: Difference) -> ModelFolderError:
        return ModelFolderError(f"{self.folder}: {CHECKPOINT} was written with other settings ({diff}); resume "
                                f"with the same settings, or train without --resume to start again")

    def _corrupt(self, err) -> ModelFolderError:
        return ModelFolderError(f"{self.folder}: {CHECKPOINT} is corrupt ({' '.join(str(err).split())[:160]}); "
                                f"delete it and train without --resume")
