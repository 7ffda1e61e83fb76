"""The checkpoint lifecycle of every trainable model (the node LSTMs and the whole-manipulator model).

A training writes into its model folder: a checkpoint (``CHECKPOINT``) while it runs, which a run
with ``resume`` continues from, and the finished model, which replaces it. ``output_folder``
checks the folder before any work (new, empty, or holding only a model or an unfinished training of
the same kind; refused without ``overwrite`` or ``resume``). ``save_state`` and ``load_state``
write and read a checkpoint's plain values (tensors, dicts, lists, numbers) without running code of
the file. ``TrainingFolder`` is the lifecycle of a run whose settings are recorded beside its
checkpoint (``SETTINGS``, the whole model's): start afresh or check what a resume continues,
discard what a failed start left, tell what an interruption kept, refuse a finished model of other
settings. The node model keeps its settings inside its checkpoint (``softrnn.learned.node._checkpoint``).
Errors name the library's arguments (``resume``, ``out``); the command line names its options.
"""

from __future__ import annotations

import io
import json
from dataclasses import dataclass
from pathlib import Path

from .. import __version__
from ..errors import FileFault, bad
from ..files import KEPT, atomic_write_bytes, atomic_write_text, json_default, prepare_output
from ..resume import REFUSE, Difference, Settings, check
from .artifacts import ModelFolderError

CHECKPOINT = "checkpoint.pt"
"""A training's checkpoint in its model folder, there only while the training is unfinished."""

SETTINGS = "checkpoint.json"
"""The settings a checkpoint was written with (``TrainingFolder``), beside it."""

CHECKPOINT_VERSION = 1
"""Layout version of a ``Checkpoint``'s file."""

RESTART = "train with --overwrite to start again"
"""What to do about a checkpoint that cannot be resumed."""


def output_folder(out, *, holds, overwrite: bool, ours=None, made_by: str = "") -> Path:
    """The checked output folder of a training: new, empty, or holding one of ``holds`` (a model or an
    unfinished training, replaced only with ``overwrite``); with ``ours`` (every name such a folder may
    hold), a folder holding other files is refused whatever ``overwrite`` says."""
    folder = prepare_output(out, "-o", kind="folder", overwrite=overwrite, holds=tuple(holds),
                            fix="pass --overwrite to replace it or --resume to continue it")
    foreign = [] if ours is None or not folder.is_dir() else \
        sorted(p.name for p in folder.iterdir() if not p.name.startswith(".") and p.name not in set(ours))
    if foreign:
        raise bad("-o", str(folder), f"a new or empty folder, or one {made_by} wrote, but it holds other files "
                                     f"({', '.join(foreign[:3])}); choose another folder")
    return folder


def save_state(path: Path, state: dict) -> None:
    """Write a checkpoint's ``state`` (tensors, dicts, lists, numbers) to ``path`` atomically
    (``torch.save``). A full disk (``FileFault``) keeps the checkpoint of the last finished epoch
    and says so (resume with ``--resume``); without one, a folder this call made is removed."""
    import torch  # optional extra: learn (PyTorch)

    buf = io.BytesIO()
    torch.save(state, buf)
    made = not path.parent.exists()
    try:
        atomic_write_bytes(path, buf.getvalue())
    except FileFault as err:
        if path.is_file():
            raise FileFault(str(err).replace(KEPT, f"the last finished epoch is kept in {path}: run the same "
                                                   f"command with --resume to continue")) from None
        if made and path.parent.is_dir() and not any(path.parent.iterdir()):
            path.parent.rmdir()
        raise


def load_state(path: Path, allowed=()):
    """The checkpoint at ``path`` read with ``weights_only`` (no code of the file runs; ``allowed``:
    classes of earlier releases' files that may be rebuilt too). Raises what ``torch.load`` raises."""
    import torch  # optional extra: learn (PyTorch)

    with torch.serialization.safe_globals(list(allowed)):
        return torch.load(path, weights_only=True, map_location="cpu")


@dataclass(frozen=True)
class TrainingFolder:
    """A training's model ``folder``, run with ``settings`` (recorded in ``SETTINGS`` beside the
    checkpoint); ``created``: this run made the folder."""

    folder: Path
    settings: Settings
    created: bool = False

    @property
    def checkpoint(self) -> Path:
        """``<folder>/checkpoint.pt``."""
        return self.folder / CHECKPOINT

    def start(self, resume: bool, read=None) -> None:
        """Check a checkpoint to resume against the settings and ``read`` it (a damaged or foreign file
        is refused here, before any work); or, starting afresh, remove an old one and record the settings."""
        saved = self.folder / SETTINGS
        if resume and self.checkpoint.is_file():
            try:
                then = json.loads(saved.read_text())
            except (OSError, ValueError):
                raise bad("resume", True, f"a checkpoint with its settings, but {saved} is missing or unreadable; "
                                          f"{RESTART}") from None
            check(then, self.settings, otherwise=REFUSE, refuse=lambda why: bad(
                "resume", True, f"the settings of the checkpoint in {self.folder} ({why}); resume with the same "
                                f"settings, or {RESTART}"))
            if read is not None:
                read(self.checkpoint)
            return
        self.checkpoint.unlink(missing_ok=True)
        atomic_write_text(saved, json.dumps(self.settings.to_json(), indent=1, default=json_default) + "\n")

    def discard(self) -> None:
        """After a failed start: remove the settings of a checkpoint that never came, and the folder if
        this run created it and it is empty again (no partial output)."""
        if not self.checkpoint.exists():
            (self.folder / SETTINGS).unlink(missing_ok=True)
            if self.created and self.folder.is_dir() and not any(self.folder.iterdir()):
                self.folder.rmdir()

    def kept(self) -> bool:
        """After an interruption: ``discard``, then whether a checkpoint is kept to resume from."""
        self.discard()
        return self.checkpoint.is_file()

    def check_finished(self, done: dict) -> None:
        """Refuse the finished model in the folder unless ``done`` (its settings) match the run's."""
        check(done, self.settings, otherwise=REFUSE, refuse=lambda why: bad(
            "resume", True, f"the settings of the finished model in {self.folder} ({why}); train with --overwrite "
                            "to replace it, or choose another folder"))


@dataclass(frozen=True)
class Checkpoint:
    """The checkpoint of a training run in model folder ``folder`` with ``settings`` stored inside it
    (``Settings.to_json``; the node model's ``training_settings``): the module, optimiser, generator,
    the loop's state and the best weights so far, written after every epoch."""

    folder: Path
    settings: Settings

    @property
    def path(self) -> Path:
        """``<folder>/checkpoint.pt``."""
        return self.folder / CHECKPOINT

    def save(self, module, optimizer, generator, state: dict, best: dict) -> None:
        """Write the checkpoint atomically: the module's and optimiser's state dicts, the
        generator's state, the loop's ``state`` and the ``best`` weights so far."""
        save_state(self.path, {"checkpoint_version": CHECKPOINT_VERSION, "softrnn_version": __version__,
                               "settings": self.settings.to_json(), "module": module.state_dict(),
                               "optimizer": optimizer.state_dict(), "generator": generator.get_state(),
                               "state": state, "best": best})

    def restore(self, module, optimizer, generator, state: dict) -> dict:
        """Load the checkpoint into the given objects (``state`` updated in place); returns the
        best weights so far. Raises ``ModelFolderError`` for a corrupt checkpoint or one written
        with other settings."""
        try:
            ckpt = load_state(self.path)
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
                                f"with the same settings, or {RESTART} (instead of --resume)")

    def _corrupt(self, err) -> ModelFolderError:
        return ModelFolderError(f"{self.folder}: {CHECKPOINT} is corrupt ({' '.join(str(err).split())[:160]}); "
                                f"{RESTART} (instead of --resume)")
