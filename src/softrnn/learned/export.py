"""The export core of every learned model: a torch module as a checked ONNX graph with its description.

The node model exports its physical-units network (``softrnn.learned.node.export``), the
whole-manipulator model one model step (``softrnn.learned.whole.export``); both go through
``onnx_graph`` (the TorchScript-based exporter, the description as ``metadata_props``, the ONNX
checker) after ``check_target`` and ``check_opset``, and read the description back with
``onnx_metadata``. The description's values are strings: JSON for lists, numbers and objects
(``metadata_strings``).
"""

from __future__ import annotations

import io
import json
import warnings
from pathlib import Path

import numpy as np

from ..errors import SoftrnnInputError, bad

DEFAULT_OPSET = 17
"""ONNX opset written by default (ONNX Runtime >= 1.14 reads it)."""


def check_target(path) -> Path:
    """The export's file ``path`` as a Path: a file path, not a folder."""
    if not isinstance(path, (str, Path)) or not str(path):
        raise bad("path", path, "a file path")
    path = Path(path)
    if path.is_dir():
        raise bad("path", str(path), "a file path, not a folder")
    return path


def check_opset(opset, opsets: range) -> int:
    """``opset`` (None: ``DEFAULT_OPSET``) checked to be one of ``opsets``."""
    if opset is None:
        opset = DEFAULT_OPSET
    if isinstance(opset, bool) or not isinstance(opset, (int, np.integer)) or int(opset) not in opsets:
        raise bad("opset", opset, f"an ONNX opset from {opsets.start} to {opsets.stop - 1} (default {DEFAULT_OPSET})")
    return int(opset)


def metadata_strings(description: dict) -> dict[str, str]:
    """``description`` with every value a string (JSON for anything but a string)."""
    return {k: v if isinstance(v, str) else json.dumps(v) for k, v in description.items()}


def onnx_graph(module, args: tuple, *, input_names: list, output_names: list, opset: int, metadata: dict,
               doc: str, dynamic_axes: dict | None = None) -> bytes:
    """The ONNX model (bytes) of ``module`` traced on the example ``args`` (torch tensors), with
    ``metadata`` (``metadata_strings``) as ``metadata_props`` and ``doc`` as its doc string, checked."""
    import onnx  # optional extra: learn (ONNX)
    import torch  # optional extra: learn (PyTorch)

    buffer = io.BytesIO()
    with warnings.catch_warnings(), torch.no_grad():
        # the TorchScript-based exporter is deprecated in favour of the dynamo one, which needs
        # onnxscript; it warns about LSTM batch sizes, which the graph handles (initial states are zeros)
        warnings.simplefilter("ignore")
        torch.onnx.export(module, args, buffer, dynamo=False, input_names=list(input_names),
                          output_names=list(output_names), dynamic_axes=dynamic_axes, opset_version=int(opset),
                          do_constant_folding=True)
    proto = onnx.load_from_string(buffer.getvalue())
    for key, value in metadata_strings(metadata).items():
        entry = proto.metadata_props.add()
        entry.key, entry.value = key, value
    proto.doc_string = doc
    onnx.checker.check_model(proto)
    return proto.SerializeToString()


def onnx_metadata(path) -> dict[str, str]:
    """The ``metadata_props`` of an ONNX file as a dict (strings; JSON values for lists and objects)."""
    import onnx  # optional extra: learn (ONNX)

    path = Path(path)
    if not path.is_file():
        raise bad("path", str(path), "an existing ONNX file")
    try:
        proto = onnx.load(str(path), load_external_data=False)
    except Exception as err:  # noqa: BLE001 - protobuf raises several types for a foreign file
        raise SoftrnnInputError(f"path={str(path)!r} is invalid: expected an ONNX file "
                                f"({' '.join(str(err).split())[:200]})") from None
    return {p.key: p.value for p in proto.metadata_props}
