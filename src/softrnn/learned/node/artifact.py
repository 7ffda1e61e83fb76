"""A trained node model as a folder, and the loaded model in physical units.

A model folder holds four files:

=================== ============================================================================
weights.safetensors the module's state dict (float32 tensors, safetensors format)
config.json         ``{"format": "softrnn-node-model", "format_version": 1, "model": ModelConfig,
                    "spec": SampleSpec}``
normalizer.json     the ``Normalizer`` statistics (fitted on the training span only)
meta.json           provenance: the dataset's metadata (file, scenario, rod, units, dt, softrnn
                    versions), the train/validation/test spans and the training history
=================== ============================================================================

``save_model`` writes them into a temporary folder next to the target and renames it into place;
``load_model`` checks every file and reports a missing, corrupt or foreign one as a one-line
``ModelFolderError`` naming the folder and the file.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import torch

from ...errors import SoftrnnInputError, bad, one_line
from ...files import atomic_folder
from ..artifacts import (
    ModelFolderError,
    check_format,
    foreign_files,
    open_folder,
    read_json,
    write_json,
    write_tensors,
)
from ..checkpoints import CHECKPOINT
from .data import SampleSpec
from .model import ModelConfig, NodeLSTM
from .normalizer import Normalizer

FORMAT = "softrnn-node-model"
"""Value of ``format`` in config.json."""

FORMAT_VERSION = 1
"""Layout version of the folder; readers refuse newer ones."""

FILES = ("weights.safetensors", "config.json", "normalizer.json", "meta.json")
"""The files of a model folder; ``CHECKPOINT`` (``softrnn.learned.checkpoints``) is there only while a
training is unfinished. ``ModelFolderError`` is ``softrnn.learned.artifacts``'."""

_OURS = set(FILES) | {CHECKPOINT}


@dataclass
class NodeModel:
    """A trained node model, ready to predict in physical units.

    Attributes
    ----------
    config : ModelConfig
        The network's architecture.
    spec : SampleSpec
        Resolved (absolute node indices, neighbours filled in).
    normalizer : Normalizer
        The z-score statistics of the inputs and targets.
    module : NodeLSTM
        In eval mode.
    meta : dict
        Provenance (see the module docstring): ``dataset`` (path, scenario name, rod, units, dt,
        n_samples, softrnn version that wrote it), ``softrnn_version``, ``spans`` (train,
        validation, test sample ranges as [start, stop]), ``train_config``, ``history`` (per epoch:
        loss, validation loss, seconds), ``best_epoch``, ``best_validation_loss``, ``train_seconds``.
    """

    config: ModelConfig
    spec: SampleSpec
    normalizer: Normalizer
    module: NodeLSTM
    meta: dict = field(default_factory=dict)

    def predict(self, poses, wrenches=None) -> np.ndarray:
        """The node's next position from windows of physical inputs.

        Parameters
        ----------
        poses : array (B, H, P)
            Input I [m, 1] in ``spec.window_nodes`` order (``data.pose_rows`` layout).
        wrenches : array (B, H, W) or None
            Input II [N, N m]; None or (B, H, 0) when the model takes none.

        Returns
        -------
        ndarray (B, 3) float64
            The node's position at the step after each window [m].
        """
        c = self.config
        poses = np.asarray(poses)
        if poses.ndim != 3 or poses.shape[1:] != (c.history, c.pose_features):
            raise bad("poses", f"array of shape {poses.shape}",
                      f"shape (B, {c.history}, {c.pose_features}) (B windows, history, pose features)")
        B = poses.shape[0]
        if wrenches is None:
            if c.wrench_features:
                raise bad("wrenches", None, f"an array (B, {c.history}, {c.wrench_features}): this model takes "
                                            f"the node's {self.spec.wrench}"
                                            + (" and actuation inputs" if self.spec.drive != "wrench" else ""))
            wrenches = np.zeros((B, c.history, 0), np.float32)
        wrenches = np.asarray(wrenches)
        if wrenches.shape != (B, c.history, c.wrench_features):
            raise bad("wrenches", f"array of shape {wrenches.shape}", f"shape {(B, c.history, c.wrench_features)}")
        z = torch.from_numpy(self.normalizer.normalise_poses(poses))          # (B, H, P)
        w = torch.from_numpy(self.normalizer.normalise_wrenches(wrenches))    # (B, H, W)
        with torch.inference_mode():
            y = self.module(z, w).numpy()                                     # (B, 3)
        return self.normalizer.denormalise_outputs(y, poses)                  # (B, 3) float64


# ------------------------------------------------------------------------------------------ save
def is_model_folder(folder) -> bool:
    """True if ``folder`` is empty or holds only softrnn model files (a model or an unfinished
    training), i.e. may be replaced by ``save_model``."""
    folder = Path(folder)
    if not folder.exists():
        return True
    if not folder.is_dir() or foreign_files(folder, _OURS):
        return False
    if (folder / "config.json").exists():
        try:
            return json.loads((folder / "config.json").read_text()).get("format") == FORMAT
        except (OSError, ValueError, AttributeError):
            return False
    return True


def check_replaceable(folder) -> None:
    """Raise ModelFolderError unless ``folder`` may be (re)written as a model folder."""
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():
        raise ModelFolderError(f"{folder}: exists and is not a folder; choose another output folder")
    if not is_model_folder(folder):
        raise ModelFolderError(f"{folder}: exists and holds files that are not a softrnn model's; choose an "
                               f"empty or new output folder (nothing was changed)")


def save_model(folder, model: NodeModel) -> None:
    """Write ``model`` to ``folder`` atomically.

    The files go to a temporary folder beside ``folder``, which is then renamed onto it; an
    existing model folder (or an unfinished training's) is replaced, anything else is refused.
    """
    folder = Path(folder)
    check_replaceable(folder)
    if not model.spec.resolved:
        raise bad("model.spec", model.spec, "a resolved SampleSpec (spec.resolve(dataset.nodes))")

    def write(tmp: Path) -> None:
        state = {k: v.detach().to(torch.float32).contiguous().clone() for k, v in model.module.state_dict().items()}
        write_tensors(tmp / "weights.safetensors", state, metadata={"format": FORMAT,
                                                                    "format_version": str(FORMAT_VERSION)})
        config = {"format": FORMAT, "format_version": FORMAT_VERSION, "model": model.config.to_dict(),
                  "spec": model.spec.to_dict()}
        write_json(tmp / "config.json", config)
        write_json(tmp / "normalizer.json", model.normalizer.to_dict())
        write_json(tmp / "meta.json", model.meta)

    atomic_folder(folder, write)


# ------------------------------------------------------------------------------------------ load
def load_model(folder) -> NodeModel:
    """Read and check a model folder written by ``save_model``.

    Raises
    ------
    ModelFolderError
        One line naming the folder and the missing, corrupt, foreign or inconsistent file.
    """
    folder = open_folder(folder, made_by="'softrnn train'", train=f"'softrnn train DATA.h5 --node N -o {folder}'")
    if not (folder / "config.json").exists() and (folder / CHECKPOINT).exists():
        raise ModelFolderError(f"{folder}: holds an unfinished training (config.json is missing, {CHECKPOINT} is "
                               f"there); finish it with 'softrnn train ... -o {folder} --resume'")
    if not (folder / "config.json").exists():
        raise ModelFolderError(f"{folder}: config.json is missing; this is not a softrnn model folder (one written "
                               f"by 'softrnn train')")
    config = check_format(folder, "config.json", read_json(folder, "config.json"), FORMAT, FORMAT_VERSION,
                          what="node model", made_by="'softrnn train'")
    try:
        model_config = ModelConfig.from_dict(config.get("model"))
        spec = SampleSpec.from_dict(config.get("spec"))
    except SoftrnnInputError as err:
        raise ModelFolderError(f"{folder}: config.json is invalid ({err}); train the model again") from None
    if not spec.resolved:
        raise ModelFolderError(f"{folder}: config.json is invalid (spec.neighbours is missing); train the model again")
    if (spec.pose_features, spec.wrench_features, spec.history) != \
            (model_config.pose_features, model_config.wrench_features, model_config.history):
        raise ModelFolderError(f"{folder}: config.json is inconsistent (the spec gives P={spec.pose_features}, "
                               f"W={spec.wrench_features}, H={spec.history}, the model "
                               f"{model_config.pose_features}, {model_config.wrench_features}, "
                               f"{model_config.history}); train the model again")
    try:
        normalizer = Normalizer.from_dict(read_json(folder, "normalizer.json"))
    except ModelFolderError:
        raise
    except SoftrnnInputError as err:
        raise ModelFolderError(f"{folder}: normalizer.json is invalid ({err}); train the model again") from None
    have = (normalizer.pose_features, normalizer.wrench_features, normalizer.output, normalizer.relative,
            normalizer.per_node)
    want = (model_config.pose_features, model_config.wrench_features, model_config.output, model_config.relative,
            spec.per_node)
    if have != want:
        raise ModelFolderError(f"{folder}: normalizer.json does not match config.json (P, W, output, relative, "
                               f"per node = {have} vs {want}); train the model again")
    meta = read_json(folder, "meta.json")
    if not isinstance(meta, dict):
        raise ModelFolderError(f"{folder}: meta.json is invalid (a {type(meta).__name__}, expected an object); "
                               f"train the model again")
    module = NodeLSTM(model_config)
    module.load_state_dict(_read_weights(folder, module), strict=True)
    module.eval()
    return NodeModel(config=model_config, spec=spec, normalizer=normalizer, module=module, meta=meta)


def _read_weights(folder: Path, module: NodeLSTM) -> dict:
    path = folder / "weights.safetensors"
    if not path.is_file():
        raise ModelFolderError(f"{folder}: weights.safetensors is missing; the model folder is incomplete, "
                               f"train the model again")
    from safetensors.torch import load_file  # optional extra: learn (safetensors)

    try:
        state = load_file(str(path))
    except Exception as err:  # noqa: BLE001 - safetensors raises several types for corrupt files
        raise ModelFolderError(f"{folder}: weights.safetensors is corrupt ({one_line(err)[:200]}); "
                               f"train the model again") from None
    expected = module.state_dict()
    missing = sorted(set(expected) - set(state))
    extra = sorted(set(state) - set(expected))
    if missing or extra:
        what = f"missing {missing[:3]}" if missing else f"unexpected {extra[:3]}"
        raise ModelFolderError(f"{folder}: weights.safetensors does not match config.json ({what} tensors); "
                               f"train the model again")
    for name, ref in expected.items():
        t = state[name]
        if tuple(t.shape) != tuple(ref.shape):
            raise ModelFolderError(f"{folder}: weights.safetensors does not match config.json ({name} has shape "
                                   f"{tuple(t.shape)}, expected {tuple(ref.shape)}); train the model again")
        if not torch.isfinite(t).all():
            raise ModelFolderError(f"{folder}: weights.safetensors holds non-finite values in {name}; "
                                   f"train the model again")
        state[name] = t.to(ref.dtype)
    return state
