"""The per-node LSTM of paper Fig. 2A (poses only) and Fig. 2B (poses and the node's wrench).

Input I (the window's poses) goes through stacked LSTM layers; its last hidden state is the pose
summary. Input II (the wrench over the same steps), flattened, goes through tanh dense layers
(Fig. 2B). Both are concatenated and mapped by dense layers to the 3 outputs: the normalised
increment of the node's position over the next step (default), or its change, or the normalised
next position (``ModelConfig.output``; ``Normalizer`` converts to and from physical units).

Two additions to the paper's structure (both on by default, ``ModelConfig`` switches them off):

* ``differences``: each LSTM step also sees the step-to-step change of the poses, scaled to unit
  variance (``Normalizer.delta_std``), so the velocity-like signal is O(1) rather than a 1e-3
  difference of two O(1) inputs;
* ``linear_skip``: a linear map of the whole window is added to the output, so the kinematic part
  of the next step (about the last increment) is exact and the layers learn the correction.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
import torch
from torch import nn

from ...errors import SoftrnnInputError, bad, int_items, integer, is_int
from ..artifacts import from_fields
from .normalizer import OUTPUTS


def _widths(name: str, value) -> tuple[int, ...]:
    expected = "a sequence of positive layer widths (may be empty)"
    out = int_items(name, value, expected)
    if not all(is_int(a) and a >= 1 for a in out):
        raise bad(name, (value,) if is_int(value) else value, expected)
    return tuple(int(a) for a in out)


@dataclass(frozen=True, kw_only=True)
class ModelConfig:
    """Architecture of a ``NodeLSTM``.

    Parameters
    ----------
    pose_features : int
        P, values per step of input I (``SampleSpec.pose_features``).
    wrench_features : int
        W, values per step of input II (0: Fig. 2A, no wrench branch).
    history : int
        H, steps per window (paper: 2).
    lstm_layers : int
        Stacked LSTM layers on input I.
    lstm_units : int
        Hidden units of each LSTM layer (the paper's study found 20-25 best for its rod; 32 here).
    dense_units : tuple of int
        Widths of the tanh dense layers after the concatenation, before the 3 outputs.
    wrench_dense : tuple of int
        Widths of the tanh dense layers of input II (Fig. 2B; unused when W = 0). Empty: the flat
        wrench window is concatenated directly.
    output : str
        ``"increment"`` (default): the next position minus the node's last position;
        ``"acceleration"``: the change of that increment (next - 2 last + previous; needs history
        >= 2); ``"pose"``: the next position itself (as the paper, about 10x less accurate here).
    differences : bool
        Feed the normalised step-to-step pose changes to the LSTM as well.
    linear_skip : bool
        Add a linear map of the whole (normalised) window to the output.
    relative : bool
        Express the window's positions relative to the node's last position (``Normalizer``), so
        the model is invariant to translations of the node.
    """

    pose_features: int
    wrench_features: int
    history: int
    lstm_layers: int = 2
    lstm_units: int = 32
    dense_units: tuple[int, ...] = (32,)
    wrench_dense: tuple[int, ...] = (16,)
    output: str = "increment"
    differences: bool = True
    linear_skip: bool = True
    relative: bool = False

    def __post_init__(self):
        for name, low in (("pose_features", 1), ("wrench_features", 0), ("history", 1), ("lstm_layers", 1),
                          ("lstm_units", 1)):
            object.__setattr__(self, name, integer(name, getattr(self, name), low))
        object.__setattr__(self, "dense_units", _widths("dense_units", self.dense_units))
        object.__setattr__(self, "wrench_dense", _widths("wrench_dense", self.wrench_dense))
        if self.output not in OUTPUTS:
            raise bad("output", self.output, "'increment' (next minus last position), 'acceleration' (the change "
                                             "of the increment) or 'pose' (next position)")
        if self.output == "acceleration" and self.history < 2:
            raise bad("output", self.output,
                      "'increment' or 'pose' for history 1 ('acceleration' needs two past steps)")
        for name in ("differences", "linear_skip", "relative"):
            if not isinstance(getattr(self, name), (bool, np.bool_)):
                raise bad(name, getattr(self, name), "true or false")
            object.__setattr__(self, name, bool(getattr(self, name)))

    def to_dict(self) -> dict:
        """JSON-ready fields (tuples as lists)."""
        d = asdict(self)
        d["dense_units"], d["wrench_dense"] = list(self.dense_units), list(self.wrench_dense)
        return d

    @classmethod
    def from_dict(cls, d: dict) -> ModelConfig:
        """Inverse of ``to_dict``; unknown or missing keys raise SoftrnnInputError."""
        return from_fields(cls, d, "model")


def _dense(widths: tuple[int, ...], n_in: int) -> tuple[nn.Sequential, int]:
    layers = []
    for w in widths:
        layers += [nn.Linear(n_in, w), nn.Tanh()]
        n_in = w
    return nn.Sequential(*layers), n_in


class NodeLSTM(nn.Module):
    """One node's model (normalised units in and out).

    Buffers ``delta_scale`` and ``delta_shift`` (P,) turn differences of normalised poses into
    normalised differences (``set_normalizer``); they are part of the state dict.
    """

    def __init__(self, config: ModelConfig):
        super().__init__()
        if not isinstance(config, ModelConfig):
            raise bad("config", type(config).__name__, "a ModelConfig")
        self.config = config
        c = config
        P, W, H = c.pose_features, c.wrench_features, c.history
        n_lstm_in = 2 * P if c.differences else P
        self.lstm = nn.LSTM(n_lstm_in, c.lstm_units, num_layers=c.lstm_layers, batch_first=True)
        n_feat = c.lstm_units
        if W:
            self.wrench_branch, n_w = _dense(c.wrench_dense, H * W)
            n_feat += n_w
        else:
            self.wrench_branch = None
        self.head, n_head = _dense(c.dense_units, n_feat)
        self.out = nn.Linear(n_head, 3)
        self.skip = nn.Linear(H * n_lstm_in + H * W, 3, bias=False) if c.linear_skip else None
        self.register_buffer("delta_scale", torch.ones(P))
        self.register_buffer("delta_shift", torch.zeros(P))

    def set_normalizer(self, normalizer) -> None:
        """Take ``delta_scale`` and ``delta_shift`` from a fitted ``Normalizer``."""
        with torch.no_grad():
            self.delta_scale.copy_(torch.as_tensor(normalizer.pose_std / normalizer.delta_std, dtype=torch.float32))
            self.delta_shift.copy_(torch.as_tensor(normalizer.delta_mean / normalizer.delta_std, dtype=torch.float32))

    def forward(self, poses: torch.Tensor, wrenches: torch.Tensor | None = None) -> torch.Tensor:
        """poses (B, H, P), wrenches (B, H, W) normalised -> (B, 3) normalised output."""
        B = poses.shape[0]
        x = poses                                                            # (B, H, P)
        if self.config.differences:
            d = (x[:, 1:] - x[:, :-1]) * self.delta_scale - self.delta_shift  # (B, H-1, P)
            d = torch.cat([torch.zeros_like(x[:, :1]), d], dim=1)            # (B, H, P), no change before step 0
            x = torch.cat([x, d], dim=2)                                     # (B, H, 2P)
        h, _ = self.lstm(x)                                                  # (B, H, U)
        feat = h[:, -1]                                                      # (B, U)
        flat_w = None
        if self.wrench_branch is not None:
            if wrenches is None:
                raise SoftrnnInputError("wrenches=None is invalid: this model (Fig. 2B) needs the node's "
                                        "wrench window (B, H, W)")
            flat_w = wrenches.reshape(B, -1)                                 # (B, H*W)
            feat = torch.cat([feat, self.wrench_branch(flat_w)], dim=1)      # (B, U + Dw)
        y = self.out(self.head(feat))                                        # (B, 3)
        if self.skip is not None:
            parts = [x.reshape(B, -1)] + ([flat_w] if flat_w is not None else [])
            y = y + self.skip(torch.cat(parts, dim=1))                       # (B, 3)
        return y
