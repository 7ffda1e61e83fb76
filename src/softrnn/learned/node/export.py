"""Export a trained node model, normalisation included, to ONNX and TorchScript for control loops.

``PhysicalNodeModel`` wraps a ``NodeModel``'s ``NodeLSTM`` with the ``Normalizer`` transforms as
float32 graph operations, so the exported file maps physical input windows straight to the node's
physical next position:

* input ``poses`` (B, H, P) float32: input I [m, 1], the ``data.pose_rows`` layout (per step the
  node first, then its neighbours in ``spec.neighbours`` order; per node x y z [m], then
  quaternion w x y z for ``inputs="poses"``), oldest step first;
* input ``wrenches`` (B, H, W) float32: input II [N, N m] (force x y z, then torque x y z for
  ``wrench="wrench"``); absent from the graph when W = 0 (Fig. 2A);
* output ``next_position`` (B, 3) float32: the node's position at the step after the window [m].

``export_onnx`` writes an ONNX file with the model's description in ``metadata_props`` (see
``describe``); ``export_torchscript`` a TorchScript file with the same description as the extra
file ``softrnn.json``. Both files are written atomically.

Precision: ``NodeModel.predict`` normalises in float64 and rounds to float32 before the network;
the graph does the same arithmetic in float32 (means split into two float32 parts, ``_split``).
The two differ by float32 roundings, amplified where the network differences near-equal
z-scores: on windows of a 0.5 m rod, typically 1e-8 m and at most 1.4e-6 m (next-position output,
random weights); tests/learned/test_export.py requires 1e-5 m.
"""

from __future__ import annotations

import io
import json
import warnings
from pathlib import Path

import numpy as np
import torch
from torch import nn

from ...errors import bad
from ...files import atomic_write_bytes
from ..artifacts import export_header
from ..export import DEFAULT_OPSET, check_opset, check_target, metadata_strings, onnx_graph, onnx_metadata  # noqa: F401
from .artifact import NodeModel
from .normalizer import NODE_POSITION

FORMAT = "softrnn-node-model-export"
"""Value of the ``format`` metadata entry of an exported file."""

FORMAT_VERSION = 1
"""Layout version of the exported inputs, output and metadata."""

INPUT_NAMES = ("poses", "wrenches")
OUTPUT_NAME = "next_position"

OPSETS = range(11, 21)
"""Opsets the (TorchScript-based) ONNX exporter of torch writes for this graph."""

TORCHSCRIPT_EXTRA_FILE = "softrnn.json"
"""Name of the metadata entry (``describe``) inside an exported TorchScript file."""


def _const(values) -> torch.Tensor:
    """float32 tensor of ``values`` (a copy)."""
    with np.errstate(under="ignore"):
        return torch.from_numpy(np.array(values, dtype=np.float32))


def _split(values) -> tuple[torch.Tensor, torch.Tensor]:
    """float64 ``values`` as float32 ``hi + lo`` (hi rounded, lo the rounding error): subtracting
    both in turn keeps a mean's digits that float32 alone would lose (a 0.3 m mean is off by up to
    1.5e-8 m in float32, which a 1e-4 m standard deviation turns into a 1.5e-4 error of the z-score)."""
    v = np.asarray(values, dtype=np.float64)
    with np.errstate(under="ignore"):
        hi = v.astype(np.float32)
        lo = (v - hi.astype(np.float64)).astype(np.float32)
    return torch.from_numpy(hi), torch.from_numpy(lo)


class PhysicalNodeModel(nn.Module):
    """A node model in physical units: ``Normalizer`` + ``NodeLSTM`` as one float32 graph.

    Parameters
    ----------
    model : NodeModel
        A loaded model (``load_model``); its module is used as is (put in eval mode), not copied.

    Notes
    -----
    The forward pass reproduces ``NodeModel.predict`` (``Normalizer.normalise_poses``,
    ``normalise_wrenches``, the module, ``denormalise_outputs``) for ``relative`` on or off and
    every ``output`` mode, computing in float32.
    """

    def __init__(self, model: NodeModel):
        super().__init__()
        if not isinstance(model, NodeModel):
            raise bad("model", type(model).__name__, "a NodeModel (softrnn.learned.node.load_model(folder))")
        norm, c = model.normalizer, model.config
        self.net = model.module.eval()
        self.history, self.pose_features, self.wrench_features = c.history, c.pose_features, c.wrench_features
        self.per_node, self.relative, self.output = norm.per_node, norm.relative, norm.output
        pose_hi, pose_lo = _split(norm.pose_mean)
        wrench_hi, wrench_lo = _split(norm.wrench_mean)
        self.register_buffer("pose_mean", pose_hi)                           # (P,) [m, 1]
        self.register_buffer("pose_mean_lo", pose_lo)                        # (P,) rounding error of pose_mean
        self.register_buffer("pose_std", _const(norm.pose_std))              # (P,)
        self.register_buffer("wrench_mean", wrench_hi)                       # (W,) [N, N m]
        self.register_buffer("wrench_mean_lo", wrench_lo)                    # (W,)
        self.register_buffer("wrench_std", _const(norm.wrench_std))          # (W,)
        self.register_buffer("target_mean", _const(norm.target_mean))        # (3,) [m]
        self.register_buffer("target_std", _const(norm.target_std))          # (3,) [m]

    def _in_frame(self, poses: torch.Tensor) -> torch.Tensor:
        """(B, H, P) -> (B, H, P): every node's position minus the node's last position if relative."""
        if not self.relative:
            return poses
        H, P, n = self.history, self.pose_features, self.per_node
        nodes = poses.reshape(-1, H, P // n, n)                               # (B, H, K, n)
        last = poses[:, -1, NODE_POSITION].reshape(-1, 1, 1, 3)              # (B, 1, 1, 3)
        parts = [nodes[..., 0:3] - last] + ([nodes[..., 3:]] if n > 3 else [])
        return torch.cat(parts, dim=3).reshape(-1, H, P)                     # (B, H, P)

    def forward(self, poses: torch.Tensor, wrenches: torch.Tensor | None = None) -> torch.Tensor:
        """poses (B, H, P) [m, 1], wrenches (B, H, W) [N, N m] (None when W = 0) -> (B, 3) next position [m]."""
        z = (self._in_frame(poses) - self.pose_mean - self.pose_mean_lo) / self.pose_std    # (B, H, P)
        w = None
        if self.wrench_features:
            w = (wrenches - self.wrench_mean - self.wrench_mean_lo) / self.wrench_std      # (B, H, W)
        y = self.net(z, w) * self.target_std + self.target_mean               # (B, 3)
        if self.output == "pose":
            return y
        last = poses[:, -1, NODE_POSITION]                                     # (B, 3)
        if self.output == "increment":
            return y + last
        return y + 2.0 * last - poses[:, -2, NODE_POSITION]                    # acceleration


# ------------------------------------------------------------------------------------ metadata
def describe(model: NodeModel) -> dict[str, str]:
    """The description stored in an exported file, as string keys and values (ONNX
    ``metadata_props``; JSON-encoded lists and objects).

    Keys: ``format``, ``format_version``, ``softrnn_version``, ``node``, ``neighbours``,
    ``window_nodes``, ``history``, ``inputs``, ``per_node``, ``pose_features``, ``wrench``,
    ``wrench_features``, ``output``, ``relative``, ``dt``, ``scenario_name``, ``units``,
    ``input_names``, ``output_name``, ``pose_layout``, ``wrench_layout``, ``output_layout``,
    ``precision``.
    """
    spec, c = model.spec, model.config
    dataset = model.meta.get("dataset") if isinstance(model.meta.get("dataset"), dict) else {}
    quat = ", qw, qx, qy, qz [1]" if spec.per_node == 7 else ""
    nodes = ", ".join(map(str, spec.window_nodes))
    pose_layout = (f"poses[b, k, :] is step k of window b (k = 0 oldest, H-1 = the current step); per step "
                   f"{len(spec.window_nodes)} nodes ({nodes}: the node, then its neighbours) x {spec.per_node} "
                   f"values (x, y, z [m]{quat}); column = {spec.per_node} * node slot + value")
    wrench_layout = {"none": "no wrench input (Fig. 2A)",
                     "force": "wrenches[b, k, :] = the node's applied force fx, fy, fz [N] at step k",
                     "wrench": "wrenches[b, k, :] = the node's applied force fx, fy, fz [N], then torque tx, ty, "
                               "tz [N m] at step k"}[spec.wrench]
    if getattr(spec, "drive", "wrench") != "wrench":
        act_units = dataset.get("actuation_units") or {}
        act = ", ".join(f"{n} [{act_units.get(n, '?')}]" for n in spec.channels)
        wrench_layout = (f"wrenches[b, k, :] = the actuation inputs {act} at step k" if spec.wrench == "none" else
                         wrench_layout + f", then the actuation inputs {act}")
    names = list(INPUT_NAMES[:2 if c.wrench_features else 1])
    d = {**export_header(FORMAT, FORMAT_VERSION),
         "node": spec.node, "neighbours": list(spec.neighbours), "window_nodes": list(spec.window_nodes),
         "history": c.history, "inputs": spec.inputs, "per_node": spec.per_node, "pose_features": c.pose_features,
         "wrench": spec.wrench, "wrench_features": c.wrench_features, "output": c.output, "relative": c.relative,
         "dt": dataset.get("dt"), "scenario_name": dataset.get("scenario_name"),
         "units": {"poses": "m (positions), 1 (quaternions w x y z)", "wrenches": "N (force), N m (torque)",
                   OUTPUT_NAME: "m", "dt": "s"},
         "input_names": names, "output_name": OUTPUT_NAME,
         "pose_layout": pose_layout, "wrench_layout": wrench_layout,
         "output_layout": f"{OUTPUT_NAME}[b, :] = the node's x, y, z [m] at the step after window b",
         "precision": "float32 inputs, arithmetic and output (normalisation included)"}
    return metadata_strings(d)


# ------------------------------------------------------------------------------------ export
def _example(model: NodeModel, batch: int) -> tuple[torch.Tensor, ...]:
    """Realistic example inputs (the normaliser's means) of batch ``batch``."""
    c, norm = model.config, model.normalizer
    poses = np.broadcast_to(norm.pose_mean, (batch, c.history, c.pose_features)).astype(np.float32)
    args = (torch.from_numpy(np.ascontiguousarray(poses)),)
    if c.wrench_features:
        w = np.broadcast_to(norm.wrench_mean, (batch, c.history, c.wrench_features)).astype(np.float32)
        args += (torch.from_numpy(np.ascontiguousarray(w)),)
    return args


def export_onnx(model: NodeModel, path, *, opset: int | None = None, dynamic_batch: bool = True) -> Path:
    """Write ``model`` with its normalisation as an ONNX file (atomically).

    Parameters
    ----------
    model : NodeModel
        The node model to export.
    path : str or Path
        The ONNX file; its folder is created if needed; an existing file is replaced.
    opset : int or None
        ONNX opset, one of ``OPSETS`` (default ``DEFAULT_OPSET``).
    dynamic_batch : bool
        True: any batch size B; False: B = 1 fixed.

    Returns
    -------
    Path
        ``path``. The graph's inputs are ``poses`` (B, H, P) and, for W > 0, ``wrenches`` (B, H, W),
        its output ``next_position`` (B, 3), all float32; ``metadata_props`` holds ``describe(model)``.
    """
    wrapped = PhysicalNodeModel(model)
    path = check_target(path)
    opset = check_opset(opset, OPSETS)
    if not isinstance(dynamic_batch, (bool, np.bool_)):
        raise bad("dynamic_batch", dynamic_batch, "true or false")
    args = _example(model, 1)
    names = list(INPUT_NAMES[:len(args)])
    axes = {name: {0: "batch"} for name in names + [OUTPUT_NAME]} if dynamic_batch else None
    doc = (f"softrnn node model: node {model.spec.node}'s next position [m] from its window of "
           f"{model.config.history} steps (metadata_props describe the inputs)")
    data = onnx_graph(wrapped, args, input_names=names, output_names=[OUTPUT_NAME], opset=opset,
                      metadata=describe(model), doc=doc, dynamic_axes=axes)
    atomic_write_bytes(path, data)
    return path


def export_torchscript(model: NodeModel, path) -> Path:
    """Write ``model`` with its normalisation as a traced TorchScript file (atomically).

    The module's ``forward(poses, wrenches)`` (just ``forward(poses)`` when W = 0) takes float32
    tensors (B, H, P) and (B, H, W) and returns (B, 3) [m], any B. ``describe(model)`` is stored as
    the extra file ``softrnn.json`` (``torch.jit.load(path, _extra_files={"softrnn.json": ""})``).
    """
    wrapped = PhysicalNodeModel(model)
    path = check_target(path)
    buffer = io.BytesIO()
    with warnings.catch_warnings(), torch.no_grad():
        # tracer notes on the LSTM (the traced graph is batch-generic) and torch 2.13's deprecation
        # of TorchScript in favour of torch.export (libtorch still loads these files)
        warnings.simplefilter("ignore")
        traced = torch.jit.trace(wrapped, _example(model, 2), check_trace=False)
        torch.jit.save(traced, buffer, _extra_files={TORCHSCRIPT_EXTRA_FILE: json.dumps(describe(model))})
    atomic_write_bytes(path, buffer.getvalue())
    return path
