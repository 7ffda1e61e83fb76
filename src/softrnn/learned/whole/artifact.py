"""A whole-manipulator model as a folder, and loading it as a ``LoadedDynamic`` (engine + encoding).

A model folder holds two files:

=================== ============================================================================
weights.safetensors ``DynamicNet.state_dict()`` (float32; the ``fixed`` mask as uint8)
linear.safetensors  the linear baseline fitted on the same data (``TrainedDynamic.linear``)
model.json          ``{"format": "softrnn-dynamic-model", "format_version": 1, "config":
                    DynamicConfig, "encoding": {...}, "meta": {...}}``: the encoding's arrays
                    (kept nodes, reference pose, fixed nodes, steps, length) and provenance
                    (training data, held-out variants, training info)
=================== ============================================================================

Loading needs NumPy, numba and safetensors only (no PyTorch): ``load_dynamic(folder).engine`` steps it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ... import __version__
from ...errors import SoftrnnInputError, one_line
from ...files import atomic_folder
from ..artifacts import ModelFolderError, check_format, open_folder, read_json, write_json, write_tensors
from .config import DynamicConfig, linear_config
from .encoding import Encoding
from .engine import DynamicEngine
from .frame import frame_from_dict, frame_to_dict

FORMAT = "softrnn-dynamic-model"
FORMAT_VERSION = 1
FILES = ("weights.safetensors", "linear.safetensors", "model.json")

DynamicFolderError = ModelFolderError
"""A model folder that cannot be used (``softrnn.learned.artifacts.ModelFolderError``, under its former name)."""
_MADE_BY = "'softrnn dynamic train'"


@dataclass(eq=False)
class LoadedDynamic:
    """A saved model: ``config``, ``encoding``, ``engine`` (``DynamicEngine``), ``linear`` (the
    linear baseline's engine), ``meta`` and the raw ``weights`` (NumPy arrays, for
    ``DynamicNet.load_state_dict`` or export)."""

    config: DynamicConfig
    encoding: Encoding
    engine: DynamicEngine
    linear: DynamicEngine
    weights: dict
    meta: dict = field(default_factory=dict)


def encoding_to_dict(enc: Encoding) -> dict:
    """The ``Encoding`` as JSON-ready values (model.json's ``encoding``)."""
    return {"n_nodes": enc.n_nodes, "kept": enc.kept.tolist(), "model_dt": enc.model_dt, "data_dt": enc.data_dt,
            "length": enc.length, "ref_positions": enc.ref_positions.tolist(),
            "ref_quaternions": enc.ref_quaternions.tolist(), "fixed": enc.fixed.tolist(),
            "feedback": bool(enc.feedback),
            **({"drive": enc.drive, "channels": list(enc.channels)} if enc.drive != "wrench" else {}),
            **({"prescribed": enc.prescribed.tolist()} if enc.prescribed.any() else {}),
            **({"obstacles": True} if enc.obstacles else {}), **({"contact": True} if enc.contact else {}),
            **({"frame": frame_to_dict(enc.frame)} if enc.frame is not None else {})}


def encoding_from_dict(d: dict) -> Encoding:
    """The ``Encoding`` from model.json's ``encoding``."""
    return Encoding(n_nodes=int(d["n_nodes"]), kept=np.asarray(d["kept"]), model_dt=float(d["model_dt"]),
                    data_dt=float(d["data_dt"]), length=float(d["length"]),
                    ref_positions=np.asarray(d["ref_positions"]), ref_quaternions=np.asarray(d["ref_quaternions"]),
                    fixed=np.asarray(d["fixed"], dtype=bool), feedback=bool(d.get("feedback", False)),
                    drive=str(d.get("drive", "wrench")), channels=tuple(d.get("channels", ())),
                    prescribed=None if "prescribed" not in d else np.asarray(d["prescribed"], dtype=bool),
                    obstacles=bool(d.get("obstacles", False)), contact=bool(d.get("contact", False)),
                    frame=frame_from_dict(d["frame"]) if "frame" in d else None)


def save_dynamic(folder, trained, meta: dict | None = None) -> None:
    """Write a ``TrainedDynamic`` to ``folder`` atomically (an existing folder is replaced)."""
    import torch  # optional extra: learn (PyTorch)
    def tensors(net) -> dict:
        out = {k: v.detach().contiguous().clone().float() for k, v in net.state_dict().items()}
        out["fixed"] = net.fixed.detach().clone().to(dtype=torch.uint8)
        if "prescribed" in out:
            out["prescribed"] = net.prescribed.detach().clone().to(dtype=torch.uint8)
        return out

    state, linear = tensors(trained.net), tensors(trained.linear)
    doc = {"format": FORMAT, "format_version": FORMAT_VERSION, "softrnn_version": __version__,
           "config": trained.config.to_dict(), "encoding": encoding_to_dict(trained.encoding),
           "meta": {"training": trained.info, **(meta or {})}}

    def write(tmp: Path) -> None:
        write_json(tmp / "model.json", doc, indent=1)
        write_tensors(tmp / "weights.safetensors", state, metadata={"format": FORMAT})
        write_tensors(tmp / "linear.safetensors", linear, metadata={"format": FORMAT})

    atomic_folder(folder, write)


def is_dynamic_folder(folder) -> bool:
    """Whether ``folder`` holds a saved whole-manipulator model."""
    folder = Path(folder)
    return folder.is_dir() and (folder / "model.json").is_file()


def load_dynamic(folder) -> LoadedDynamic:
    """Read a model folder written by ``save_dynamic``; a missing, corrupt or foreign file is a
    one-line ``DynamicFolderError``."""
    folder = open_folder(folder, made_by=_MADE_BY, train=f"'softrnn dynamic train DATA ... -o {folder}'")
    if not (folder / "model.json").is_file():
        raise DynamicFolderError(f"{folder}: model.json is missing; this is not a whole-manipulator model "
                                 f"folder (train one with {_MADE_BY})")
    doc = check_format(folder, "model.json", read_json(folder, "model.json"), FORMAT, FORMAT_VERSION,
                       what="whole-manipulator model", made_by=_MADE_BY, unversioned=True)
    from safetensors.numpy import load_file  # optional extra: learn (safetensors)

    for name in FILES[:2]:
        if not (folder / name).is_file():
            raise DynamicFolderError(f"{folder}: {name} is missing; the model folder is incomplete, train the "
                                     "model again")
    try:
        weights = load_file(str(folder / "weights.safetensors"))
        config = DynamicConfig.from_dict(doc["config"])
        encoding = encoding_from_dict(doc["encoding"])
        engine = DynamicEngine(weights, config)
        linear = DynamicEngine(load_file(str(folder / "linear.safetensors")), linear_config(config))
    except DynamicFolderError:
        raise
    except SoftrnnInputError as err:
        raise DynamicFolderError(f"{folder}: model.json is invalid ({err}); train the model again") from None
    except Exception as err:  # noqa: BLE001 - safetensors and a damaged json raise several types
        raise DynamicFolderError(f"{folder}: the model files are corrupt or do not match "
                                 f"({one_line(err)[:160]}); train the model again") from None
    try:   # one step on a rest state: weights of another layout fail here, not in a user's loop
        engine.step(np.zeros((engine.history, engine.n_kept, 6)), np.zeros((engine.n_kept, engine.load_width)))
        linear.step(np.zeros((linear.history, linear.n_kept, 6)), np.zeros((linear.n_kept, linear.load_width)))
    except ValueError as err:
        why = one_line(err)[:100]
        raise DynamicFolderError(f"{folder}: the weights do not fit this softrnn's model layout ({why}); "
                                 "train the model again") from None
    if engine.n_kept != encoding.n_kept:
        raise DynamicFolderError(f"{folder}: weights.safetensors and model.json disagree on the node count; "
                                 "train the model again")
    _check_encoding(folder, encoding)
    meta = doc.get("meta") or {}
    if not isinstance(meta, dict):
        raise DynamicFolderError(f"{folder}: model.json's meta is a {type(meta).__name__}, expected an object; "
                                 "train the model again")
    return LoadedDynamic(config=config, encoding=encoding, engine=engine, linear=linear, weights=weights,
                         meta=meta)


def _check_encoding(folder: Path, enc: Encoding) -> None:
    """Raise ``DynamicFolderError`` unless model.json's encoding is consistent: kept node indices
    increasing in [0, n_nodes), a fixed flag per kept node, a finite reference pose per node.

    Parameters
    ----------
    folder : Path
        The model folder (named in the error).
    enc : Encoding
        The encoding read from model.json.
    """
    n, kept = enc.n_nodes, enc.kept
    shapes = {"kept": (kept.shape, (enc.n_kept,)), "fixed": (enc.fixed.shape, (enc.n_kept,)),
              "ref_positions": (enc.ref_positions.shape, (n, 3)),
              "ref_quaternions": (enc.ref_quaternions.shape, (n, 4))}
    wrong = [f"{name} has shape {have}, expected {want}" for name, (have, want) in shapes.items() if have != want]
    if not wrong and (kept.dtype.kind not in "iu" or kept.size == 0 or np.any(np.diff(kept) <= 0)
                      or kept.min() < 0 or kept.max() >= n):
        wrong = [f"kept is not increasing node indices in 0..{n - 1}"]
    if not wrong and not (np.isfinite(enc.ref_positions).all() and np.isfinite(enc.ref_quaternions).all()):
        wrong = ["the reference pose is not finite"]
    if wrong:
        raise DynamicFolderError(f"{folder}: model.json's encoding is invalid ({wrong[0]}); train the model again")


def engine_of(net) -> DynamicEngine:
    """The NumPy engine of a ``DynamicNet`` still in memory (``TrainedDynamic.net`` or ``.linear``)."""
    return DynamicEngine({k: v.detach().numpy() for k, v in net.state_dict().items()}, net.config)
