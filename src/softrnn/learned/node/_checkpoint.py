"""Training checkpoints: the per-epoch ``checkpoint.pt``, resuming from it, and the settings a resumed run must match.

Every finished epoch is saved to ``<out_folder>/checkpoint.pt`` (module, optimiser, the shuffling
generator's state, the best weights so far, the loop's state and history). A resumed run must use
the same settings (``training_settings``; epochs, patience and threads may change) and data; a
folder that already holds the finished model is returned as is (``load_finished``).
"""

from __future__ import annotations

import io
from dataclasses import asdict, dataclass
from pathlib import Path

import torch

from ... import __version__
from ...files import atomic_write_bytes
from .artifact import CHECKPOINT, ModelFolderError, NodeModel, load_model
from .data import SampleSpec
from .model import ModelConfig

CHECKPOINT_VERSION = 1
_MAY_CHANGE = ("epochs", "patience", "threads")


def training_settings(spec: SampleSpec, config: ModelConfig, train, data_fingerprint: str, pool) -> dict:
    """What a checkpoint must match to be resumed: the spec, the model config, the ``TrainConfig``
    ``train`` (but its epochs, patience and threads), the data's fingerprint and the pool."""
    t = {k: v for k, v in asdict(train).items() if k not in _MAY_CHANGE}
    settings = {"spec": spec.to_dict(), "model": config.to_dict(), "train": t, "data": data_fingerprint}
    settings["pool"] = list(pool) if pool is not None else None
    return settings


def _diff(a: dict, b: dict, prefix: str = "") -> str:
    for key in sorted(set(a) | set(b), key=lambda k: (k == "data", k)):   # settings first, data last
        x, y = a.get(key), b.get(key)
        if isinstance(x, dict) and isinstance(y, dict):
            d = _diff(x, y, f"{prefix}{key}.")
            if d:
                return d
        elif x != y:
            if key == "data":
                return "the training data differ"
            return f"{prefix}{key}: {x!r} then, {y!r} now"
    return ""


def load_finished(folder: Path, settings: dict) -> NodeModel:
    """The finished model in ``folder``, after checking that it was trained with ``settings``
    (``training_settings``); raises ``ModelFolderError`` otherwise."""
    model = load_model(folder)
    was = model.meta.get("train_config") if isinstance(model.meta.get("train_config"), dict) else {}
    done = {"spec": model.spec.to_dict(), "model": model.config.to_dict(),
            "train": {k: v for k, v in was.items() if k not in _MAY_CHANGE},
            "data": model.meta.get("data_fingerprint"), "pool": model.meta.get("pool")}
    why = _diff(done, settings)
    if why:
        raise ModelFolderError(f"{folder}: holds a finished model trained with other settings ({why}); "
                               f"train without --resume to replace it, or choose another folder")
    return model


@dataclass(frozen=True)
class Checkpoint:
    """The checkpoint of a training run in model folder ``folder`` with ``settings``
    (``training_settings``)."""

    folder: Path
    settings: dict

    @property
    def path(self) -> Path:
        """``<folder>/checkpoint.pt``."""
        return self.folder / CHECKPOINT

    def save(self, module, optimizer, generator, state: dict, best: dict) -> None:
        """Write the checkpoint atomically: the module's and optimiser's state dicts, the
        generator's state, the loop's ``state`` and the ``best`` weights so far."""
        buf = io.BytesIO()
        torch.save({"checkpoint_version": CHECKPOINT_VERSION, "softrnn_version": __version__,
                    "settings": self.settings, "module": module.state_dict(), "optimizer": optimizer.state_dict(),
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
        why = _diff(ckpt.get("settings", {}), self.settings)
        if why:
            raise ModelFolderError(f"{self.folder}: {CHECKPOINT} was written with other settings ({why}); resume "
                                   f"with the same settings, or train without --resume to start again")
        try:
            module.load_state_dict(ckpt["module"])
            optimizer.load_state_dict(ckpt["optimizer"])
            generator.set_state(ckpt["generator"])
            state.update(ckpt["state"])
            best = ckpt["best"]
        except (KeyError, RuntimeError, ValueError, TypeError) as err:
            raise self._corrupt(err) from None
        return best

    def _corrupt(self, err) -> ModelFolderError:
        return ModelFolderError(f"{self.folder}: {CHECKPOINT} is corrupt ({' '.join(str(err).split())[:160]}); "
                                f"delete it and train without --resume")
