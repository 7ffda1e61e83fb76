"""Export one step of a whole-manipulator model to ONNX, with a JSON sidecar holding its encoding.

The graph is ``DynamicNet.forward`` with the saved weights (float32, batch 1), so a control loop
steps the model without softrnn:

* input ``history`` (1, H, M, 6): the last H encoded states, oldest first (per kept node the
  displacement from the reference position [m], then the rotation vector from the reference
  orientation [rad], ``Encoding``);
* input ``loads`` (1, M, 6): the mean force [N] and torque [N m] over the coming model step,
  lumped onto the kept nodes (``Encoding.loads``);
* for ``memory = "lstm"`` also ``memory_h``, ``memory_c`` (1, M, W): the LSTM cell's state (zeros
  at the start of a run);
* output ``next_state`` (1, M, 6), the state one model step later (and ``memory_h_out``,
  ``memory_c_out`` for the next call with ``memory = "lstm"``).

The sidecar (``sidecar_path``: ``OUT.onnx.json``) holds what a caller needs to encode poses and
loads and to decode states to every node: the encoding's arrays (kept nodes, reference pose, fixed
nodes, steps, length), the load lumping matrix and the layouts (``describe``). ``export_onnx``
checks the graph with ONNX Runtime against the NumPy engine (``DynamicEngine``) on a random input
before anything is written, and writes both files atomically.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from torch import nn

from ...errors import SimulationError, bad
from ...files import atomic_write_bytes, atomic_write_text, json_default
from ..artifacts import export_header
from ..export import DEFAULT_OPSET, check_opset, check_target, onnx_graph
from .artifact import LoadedDynamic, encoding_to_dict
from .encoding import lumping_matrix
from .network import SCALE_KEYS, DynamicNet
from .training import Scales

FORMAT = "softrnn-dynamic-model-export"
"""Value of the ``format`` entry of the ONNX metadata and the sidecar."""

FORMAT_VERSION = 1
"""Layout version of the exported inputs, outputs and sidecar."""

TOLERANCE = 1e-5
"""Largest difference [m or rad] between the ONNX graph (float32) and the NumPy engine (float64) on
the check's random input; a larger one refuses the export."""

SIDECAR_SUFFIX = ".json"

OPSETS = range(17, 21)
"""Opsets this graph is exported to."""


@dataclass(frozen=True)
class Exported:
    """What ``export_onnx`` wrote: the ONNX file ``path``, the ``sidecar`` JSON and the largest
    difference ``max_difference`` [m or rad] between ONNX Runtime and the NumPy engine on a random
    input (next state, and the LSTM memory where there is one)."""

    path: Path
    sidecar: Path
    max_difference: float


def sidecar_path(path) -> Path:
    """The sidecar of an ONNX file: ``model.onnx`` -> ``model.onnx.json``."""
    path = Path(path)
    return path.with_name(path.name + SIDECAR_SUFFIX)


def input_names(model: LoadedDynamic) -> list[str]:
    """``history``, ``loads`` (and ``memory_h``, ``memory_c`` for ``memory = "lstm"``)."""
    return ["history", "loads"] + (["memory_h", "memory_c"] if model.config.memory == "lstm" else [])


def output_names(model: LoadedDynamic) -> list[str]:
    """``next_state`` (and ``memory_h_out``, ``memory_c_out`` for ``memory = "lstm"``)."""
    return ["next_state"] + (["memory_h_out", "memory_c_out"] if model.config.memory == "lstm" else [])


def step_net(model: LoadedDynamic) -> DynamicNet:
    """The saved weights as a ``DynamicNet`` in eval mode (float32)."""
    if not isinstance(model, LoadedDynamic):
        raise bad("model", type(model).__name__, "a LoadedDynamic (softrnn.learned.whole.load_dynamic(folder))")
    w = model.weights
    scales = Scales(**{key: np.asarray(w[key]) for key in SCALE_KEYS.values()})
    prescribed = np.asarray(w["prescribed"], dtype=bool) if "prescribed" in w else None
    contact = slice(*(int(v) for v in w["contact_columns"])) if "contact_columns" in w else None
    net = DynamicNet(model.config, np.asarray(w["node_features"]), np.asarray(w["fixed"], dtype=bool), scales,
                     prescribed, contact)
    state = {k: torch.as_tensor(np.asarray(v)) for k, v in w.items()}
    state["fixed"] = state["fixed"].to(torch.bool)
    for key, value in net.state_dict().items():     # a model saved before the envelope: not clipped
        state.setdefault(key, value)
    net.load_state_dict(state)
    return net.eval()


class OnnxStep(nn.Module):
    """One model step with the memory as explicit inputs and outputs (batch 1).

    ``forward(history (1, H, M, 6), loads (1, M, 6)[, memory_h, memory_c (1, M, W)])`` returns
    ``next_state`` (1, M, 6) (and the new memory, (1, M, W) each, for ``memory = "lstm"``).
    """

    def __init__(self, net: DynamicNet):
        super().__init__()
        self.net = net
        self.lstm = net.cell is not None

    def forward(self, history, loads, memory_h=None, memory_c=None):
        """The step (see the class)."""
        if not self.lstm:
            nxt, _ = self.net(history, loads)                                  # (1, M, 6)
            return nxt
        M = history.shape[2]
        memory = (memory_h.reshape(M, -1), memory_c.reshape(M, -1))           # (M, W) each
        nxt, (h, c) = self.net(history, loads, memory)
        return nxt, h.reshape(1, M, -1), c.reshape(1, M, -1)


def random_inputs(model: LoadedDynamic, seed: int = 0) -> dict[str, np.ndarray]:
    """A plausible random input of the graph (float32): a history whose states and velocities have
    the training data's spread (the saved scales ``sx``, ``sv``: ``network.SCALE_KEYS``), loads of the
    loads' spread (``su``), a memory in (-1, 1)."""
    rng = np.random.default_rng(seed)
    e, w = model.engine, model.weights
    H, M = e.history, e.n_kept
    x0 = rng.standard_normal((M, 6)) * np.asarray(w["sx"], dtype=np.float64)
    steps = rng.standard_normal((H, M, 6)) * np.asarray(w["sv"], dtype=np.float64)
    history = x0 + np.cumsum(steps, axis=0) - steps.sum(axis=0)               # (H, M, 6), last = x0
    history[:, e.fixed] = 0.0
    loads = rng.standard_normal((M, e.load_width)) * np.asarray(w["su"], dtype=np.float64)
    out = {"history": history[None], "loads": loads[None]}
    if model.config.memory == "lstm":
        width = model.config.width
        out["memory_h"] = np.tanh(rng.standard_normal((1, M, width)))
        out["memory_c"] = rng.standard_normal((1, M, width))
    return {k: v.astype(np.float32) for k, v in out.items()}


def max_difference(model: LoadedDynamic, onnx_bytes: bytes, seed: int = 0) -> float:
    """Largest |ONNX Runtime - ``DynamicEngine``| over every output on ``random_inputs`` [m or rad]
    (the engine is fed the same float32 values, in float64)."""
    import onnxruntime  # optional extra: learn (ONNX Runtime)

    feeds = random_inputs(model, seed)
    options = onnxruntime.SessionOptions()
    options.intra_op_num_threads = 1
    session = onnxruntime.InferenceSession(onnx_bytes, options, providers=["CPUExecutionProvider"])
    got = session.run(output_names(model), feeds)
    memory = None
    if model.config.memory == "lstm":
        memory = (feeds["memory_h"][0].astype(np.float64), feeds["memory_c"][0].astype(np.float64))
    nxt, memory = model.engine.step(feeds["history"][0].astype(np.float64), feeds["loads"][0].astype(np.float64),
                                    memory)
    want = [nxt] + ([] if memory is None else list(memory))
    return float(max(np.max(np.abs(g[0].astype(np.float64) - w)) for g, w in zip(got, want)))


def describe(model: LoadedDynamic) -> dict:
    """The sidecar's content (JSON-ready): ``format``, ``format_version``, ``softrnn_version``,
    ``config``, ``encoding`` (``n_nodes``, ``kept``, ``model_dt``, ``data_dt``, ``length``,
    ``ref_positions``, ``ref_quaternions``, ``fixed``), ``lumping`` (M, N), ``inputs`` and
    ``outputs`` (name -> shape), ``units`` and ``layout`` (how to encode and decode)."""
    c, enc = model.config, model.encoding
    H, M, W = c.history, enc.n_kept, c.width
    L = enc.load_width
    inputs = {"history": [1, H, M, 6], "loads": [1, M, L]}
    outputs = {"next_state": [1, M, 6]}
    if c.memory == "lstm":
        inputs.update(memory_h=[1, M, W], memory_c=[1, M, W])
        outputs.update(memory_h_out=[1, M, W], memory_c_out=[1, M, W])
    return {
        **export_header(FORMAT, FORMAT_VERSION), "config": c.to_dict(), "encoding": encoding_to_dict(enc),
        "lumping": lumping_matrix(enc.n_nodes, enc.kept).tolist(),
        "inputs": inputs, "outputs": outputs,
        "units": {"state": "m (columns 0-2), rad (columns 3-5)", "loads": _load_units(enc),
                  "model_dt": "s", "length": "m"},
        "layout": _LAYOUT if enc.frame is None else {**_LAYOUT, **_FRAME_LAYOUT},
    }


def _load_units(enc) -> str:
    """The loads' columns in words: the wrench's, then the actuation channels' (same at every node),
    then the prescribed nodes' path channels."""
    wrench = "N (columns 0-2), N m (columns 3-5)"
    first = 0 if enc.drive == "actuation" else 6
    act = ", ".join(f"{n} (column {first + j})" for j, n in enumerate(enc.channels))
    act = f"the mean actuation input over the model step, the same at every kept node, in its unit: {act}"
    text = wrench if enc.drive == "wrench" else act if enc.drive == "actuation" else f"{wrench}, then {act}"
    if enc.contact:
        c = enc.contact_columns
        text += (f", then the contact inputs measured on the current state (columns {c.start}-{c.stop - 1}): the "
                 "gap of the rod's surface to the nearest obstacle (m, at most the rod's length) and its unit normal")
    paths = [f"node {int(enc.kept[m])} (columns {c}-{c + 5})" for m, c in enc.prescribed_columns]
    if paths:
        text += (", then the change of each prescribed node's state over the coming model step (m, then rad; "
                 f"the same at every kept node): {', '.join(paths)}")
    return text


_LAYOUT = {
    "state": "state[m] of kept node encoding.kept[m]: r - r_ref (world frame, m), then the rotation vector "
             "log(R_ref^T R) (rad; R, R_ref from the scalar-first quaternions, body to world)",
    "history": "history[0, k] is the state k steps of model_dt apart, k = 0 the oldest, H - 1 the current one",
    "loads": "loads[0] = lumping @ (the mean over the coming model step of every node's force, torque), "
             "world frame; lumping (M, N) spreads node i's load over the kept nodes around it. With "
             "encoding.feedback, a node driven by a PD tracking law (stiffness K, damping D, target(t)) is "
             "not given its force: the caller adds K (mean target over the step - r_ref - x) - D (x - x_prev) "
             "/ model_dt to its force columns, x and x_prev the displacements of the last two history states",
    "next_state": "the state one model step (model_dt) after history[0, H - 1]; fixed nodes keep theirs, "
                  "prescribed nodes (encoding.prescribed) move by their path columns of loads",
    "memory": "memory = 'lstm' only: feed zeros at the start, then the previous call's memory_*_out",
    "decode": "every node's pose: a cubic spline (scipy CubicSpline, not-a-knot) of the states along the node "
              "index through the kept nodes, then r = r_ref + displacement, R = R_ref exp(rotation vector)",
}


_FRAME_LAYOUT = {
    "state": "encoding.frame = vessel: state[m] of kept node encoding.kept[m] in curvilinear coordinates along "
             "the vessel centreline encoding.frame.centreline (softrnn.learned.whole.frame.VesselFrame): tau - "
             "tau_ref, u - u_ref, w - w_ref (m; tau the spline parameter of the closest centreline point, u, w the "
             "offsets along the frame's normals), then the rotation vector log(Q_ref^T Q) (rad) of Q = F(tau)^T R",
    "decode": "as in the world frame, the spline through the kept nodes' states, then each node's (tau, u, w) "
              "mapped to the world by VesselFrame.world and R = F(tau) Q_ref exp(rotation vector)",
}


def _graph(model: LoadedDynamic, opset: int) -> bytes:
    """The ONNX model of one step (bytes) with ``describe``'s scalars as metadata."""
    wrapped = OnnxStep(step_net(model))
    example = tuple(torch.from_numpy(v) for v in random_inputs(model).values())
    d = describe(model)
    meta = {**export_header(FORMAT, FORMAT_VERSION),
            "history": model.config.history, "kept": d["encoding"]["kept"], "n_nodes": model.encoding.n_nodes,
            "model_dt": model.encoding.model_dt, "memory": model.config.memory, "inputs": d["inputs"],
            "outputs": d["outputs"], "sidecar": "the file's name + '.json' holds the encoding and the layouts"}
    doc = (f"softrnn whole-manipulator model: one step of {model.encoding.model_dt:g} s on "
           f"{model.encoding.n_kept} kept nodes (metadata_props and the .json sidecar describe it)")
    return onnx_graph(wrapped, example, input_names=input_names(model), output_names=output_names(model),
                      opset=opset, metadata=meta, doc=doc)


def export_onnx(model: LoadedDynamic, path, *, opset: int = DEFAULT_OPSET, seed: int = 0) -> Exported:
    """Write one step of ``model`` as an ONNX file and its sidecar (``sidecar_path``), atomically.

    Parameters
    ----------
    model : LoadedDynamic
        ``load_dynamic(folder)``.
    path : str or Path
        The ONNX file (its folder is created if needed; existing files are replaced).
    opset : int
        ONNX opset, 17 to 20.
    seed : int
        Seed of the check's random input (``random_inputs``).

    Returns
    -------
    Exported
        The paths and the check's largest difference. Raises ``SimulationError`` (nothing written)
        when the difference exceeds ``TOLERANCE``.
    """
    opset = check_opset(opset, OPSETS)
    path = check_target(path)
    data = _graph(model, opset)
    diff = max_difference(model, data, seed)
    if not diff <= TOLERANCE:
        raise SimulationError(f"the ONNX graph differs from the NumPy engine by {diff:.3g} (more than "
                              f"{TOLERANCE:g}) on a random input; nothing was written; report this with the model")
    sidecar = sidecar_path(path)
    atomic_write_text(sidecar, json.dumps(describe(model), indent=1, allow_nan=False, default=json_default) + "\n")
    try:
        atomic_write_bytes(path, data)
    except BaseException:
        sidecar.unlink(missing_ok=True)
        raise
    return Exported(path=path, sidecar=sidecar, max_difference=diff)
