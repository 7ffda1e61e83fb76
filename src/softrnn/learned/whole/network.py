"""``DynamicNet``: one step of the whole-manipulator model in PyTorch (training and export).

Per step, each kept node's features (channels) are its displacement and rotation vector from the
reference, its last ``history - 1`` velocities (state differences per model step), the step's mean
load and three constants (arc position, distance to a fixed node, fixed flag), each scaled by its
training standard deviation. The output is the normalised change of velocity over the step
(a second difference, as in GNS); the new state is ``x + v + dv``. Two terms are summed:

* ``linear``: a global linear map of every node's features (M*C -> M*6), fitted by ridge regression
  before training: by itself, the one-step linear model (the "linear" baseline);
* ``conv``: a 1-D convolution along the rod (one set of weights for every node; the chain graph's
  message passing) whose last layer starts at zero, so training starts from the linear model.
  By default it reads the state, the velocities and the constants but **not the loads**: by
  Newton's second law a node's acceleration is affine in a load applied to it at a given state (the
  internal forces are the nonlinear part), so the loads enter through the linear term only.
  Measured: a convolution that also read the loads learned load responses from the few load events
  of the training data and drifted after them in free runs. A tendon's load is not applied at a
  node: its force and moment follow the rod's shape, so for actuation inputs the convolution may
  read the loads too (``conv_reads = "loads"``).

With ``memory = "lstm"`` a per-node LSTM cell (shared along the rod) also carries a hidden state
from step to step and feeds the convolution. Fixed nodes keep their state.

**The envelope** (``config.envelope`` = m > 0): the training data's range [lo, hi] of each feature
the correction reads (buffers ``env_lo``, ``env_hi``, set by ``set_envelope``). A node whose
features lie inside it gets the full correction; outside, the correction fades linearly to zero
at m (hi - lo) beyond the range (``envelope_gate``), and the correction's inputs are clipped
there. So the correction is bounded, and zero wherever a node is far from anything the network
was trained on: there the model is its linear term, which extrapolates like a damped linear
system instead of like a network.
"""

from __future__ import annotations

import torch
from torch import nn

from .config import DynamicConfig, conv_channels, n_channels


def feedback_force(hist: torch.Tensor, feedback, k: int) -> torch.Tensor:
    """The PD laws' loads (B, M, 6) at step ``k`` of a free run from ``hist`` (B, H, M, 6), as
    ``Feedback.force``: stiffness (target - x) - damping (x - x_prev) / model_dt, zero torques."""
    gains, targets, dt = feedback
    x, prev = hist[:, -1, :, :3], hist[:, -2, :, :3]
    f = gains[..., :1] * (targets[:, k] - x) - gains[..., 1:] * (x - prev) / dt
    return torch.cat([f, torch.zeros_like(f)], dim=-1)


class DynamicNet(nn.Module):
    """One model step. Buffers: ``node_features`` (M, 3), ``fixed`` (M,) bool and the scales
    ``sx``, ``sv``, ``sa`` (6,) of states, velocities and velocity changes and ``su`` (L,) of the
    loads (L = 6, or m / 6 + m with actuation inputs: ``load_width``)."""

    def __init__(self, config: DynamicConfig, node_features, fixed, scales: dict):
        super().__init__()
        self.config = config
        self.register_buffer("node_features", torch.as_tensor(node_features, dtype=torch.float32))
        self.register_buffer("fixed", torch.as_tensor(fixed, dtype=torch.bool))
        for key in ("sx", "sv", "su", "sa"):
            self.register_buffer(key, torch.as_tensor(scales[key], dtype=torch.float32))
        M = int(self.node_features.shape[0])
        L = int(self.su.numel())                      # load channels: 6, or with actuation inputs m or 6 + m
        C = n_channels(config.history, L)
        self.n_kept, self.n_in, self.load_width = M, C, L
        self.linear = nn.Linear(M * C, M * 6) if config.linear else None
        self.register_buffer("conv_cols", torch.as_tensor(conv_channels(config.history, config.conv_reads, L)),
                             persistent=False)
        G = int(self.conv_cols.numel())
        if config.envelope is not None:     # no clipping until set_envelope (training) or load_state_dict
            self.register_buffer("env_lo", torch.full((G,), -torch.inf))
            self.register_buffer("env_hi", torch.full((G,), torch.inf))
            self.register_buffer("env_inv", torch.zeros(G))
        else:
            self.env_lo = self.env_hi = None
        self.cell = nn.LSTMCell(G, config.width) if config.memory == "lstm" else None
        if config.conv or self.cell is not None:
            width, pad = config.width, config.kernel // 2
            cin = G + (config.width if self.cell is not None else 0)
            layers = [nn.Conv1d(cin, width, config.kernel, padding=pad), nn.GELU(approximate="tanh")]
            for _ in range(config.layers - 1):
                layers += [nn.Conv1d(width, width, config.kernel, padding=pad), nn.GELU(approximate="tanh")]
            out = nn.Conv1d(width, 6, 1)
            nn.init.zeros_(out.weight)
            nn.init.zeros_(out.bias)
            self.conv = nn.Sequential(*layers, out)
        else:
            self.conv = None
        if self.linear is not None:
            nn.init.zeros_(self.linear.weight)
            nn.init.zeros_(self.linear.bias)

    def set_envelope(self, lo: torch.Tensor, hi: torch.Tensor) -> None:
        """The data's range [lo, hi] of the ``conv_cols`` features ((G,) each, in scaled units):
        buffers ``env_lo``, ``env_hi`` and ``env_inv`` = 1 / (m (hi - lo)), 0 for a channel that
        never varies (a constant, or a coordinate the data never move)."""
        if self.env_lo is None:
            return
        width = float(self.config.envelope) * (hi - lo)
        with torch.no_grad():
            self.env_lo.copy_(lo)
            self.env_hi.copy_(hi)
            self.env_inv.copy_(torch.where(width > 1e-9, 1.0 / torch.clamp(width, min=1e-9), 0.0))

    def envelope_gate(self, g: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """(clipped inputs (..., G), gate (..., 1)): the gate is 1 inside the data's range, falls
        linearly to 0 at m (hi - lo) outside it (the farthest channel decides), where the inputs
        are clipped."""
        over = torch.clamp(torch.maximum(self.env_lo - g, g - self.env_hi), min=0.0) * self.env_inv
        gate = torch.clamp(1.0 - over.amax(dim=-1, keepdim=True), min=0.0)
        margin = torch.where(self.env_inv > 0, 1.0 / torch.clamp(self.env_inv, min=1e-30), 0.0)
        g = torch.minimum(torch.maximum(g, self.env_lo - margin), self.env_hi + margin)
        return g, gate

    def features(self, hist: torch.Tensor, loads: torch.Tensor) -> torch.Tensor:
        """hist (B, H, M, 6) states, oldest first; loads (B, M, L) -> features (B, M, C)."""
        B = hist.shape[0]
        parts = [hist[:, -1] / self.sx]
        for j in range(self.config.history - 1):
            parts.append((hist[:, -1 - j] - hist[:, -2 - j]) / self.sv)
        parts.append(loads / self.su)
        parts.append(self.node_features.expand(B, -1, -1))
        return torch.cat(parts, dim=-1)

    def forward(self, hist: torch.Tensor, loads: torch.Tensor, memory=None):
        """hist (B, H, M, 6), loads (B, M, 6) -> (next state (B, M, 6), memory for the next step)."""
        f = self.features(hist, loads)
        B, M, C = f.shape
        a = torch.zeros(B, M, 6, dtype=f.dtype)
        if self.linear is not None:
            a = a + self.linear(f.reshape(B, M * C)).reshape(B, M, 6)
        g, gate = f[..., self.conv_cols], None
        if self.env_lo is not None:
            g, gate = self.envelope_gate(g)
        if self.cell is not None:
            if memory is None:
                z = torch.zeros(B * M, self.config.width, dtype=f.dtype)
                memory = (z, z)
            h, c = self.cell(g.reshape(B * M, g.shape[-1]), memory)
            memory = (h, c)
            g = torch.cat([g, h.reshape(B, M, -1)], dim=-1)
        if self.conv is not None:
            c = self.conv(g.transpose(1, 2)).transpose(1, 2)
            if gate is not None:
                c = c * gate
            b = self.config.bound
            a = a + (b * torch.tanh(c / b) if b > 0 else c)
        x, v = hist[:, -1], hist[:, -1] - hist[:, -2]
        nxt = x + v + a * self.sa
        nxt = torch.where(self.fixed[None, :, None], x, nxt)
        return nxt, memory

    def rollout(self, hist: torch.Tensor, loads: torch.Tensor, feedback=None) -> torch.Tensor:
        """Free run: hist (B, H, M, 6), loads (B, K, M, 6) for each step -> states (B, K, M, 6).
        ``feedback``: (gains (B, M, 2), targets (B, K, M, 3), model_dt) of PD laws applied to the
        run's own states at every step (``softrnn.learned.whole.feedback``), or None."""
        out, memory = [], None
        for k in range(loads.shape[1]):
            u = loads[:, k] if feedback is None else loads[:, k] + feedback_force(hist, feedback, k)
            nxt, memory = self.forward(hist, u, memory)
            out.append(nxt)
            hist = torch.cat([hist[:, 1:], nxt[:, None]], dim=1)
        return torch.stack(out, dim=1)
