"""``DynamicNet``: one step of the whole-manipulator model in PyTorch (training and export).

Per step, each kept node's features (channels, ``DynamicNet.features``) are its displacement and
rotation vector from the reference, its last ``history - 1`` velocities (state differences per
model step), the step's mean load and three constants (arc position, distance to a fixed node,
fixed flag), each scaled by its training standard deviation. The model predicts the scaled change
of velocity over the step (a second difference, as in GNS)::

    next = x + v + dv_scale (linear_term + correction)        (fixed nodes keep x)

A prescribed node (a clamp moved along a known path, ``Encoding.prescribed``) is not predicted:
its next state is x plus its change over the step, read from its load channels.

* ``linear_term``: a global linear map of every node's features (M*C -> M*6), fitted by ridge
  regression before training: by itself, the one-step linear model (the "linear" baseline);
* ``correction``: a 1-D convolution along the rod (one set of weights for every node; the chain
  graph's message passing) whose last layer starts at zero, so training starts from the linear
  model. By default it reads the state, the velocities and the constants but **not the loads**
  (``correction_inputs``): by Newton's second law a node's acceleration is affine in a load applied
  to it at a given state (the internal forces are the nonlinear part), so the loads enter through
  the linear term only; a convolution that also reads the loads learns load responses from the few
  load events of the training data and drifts after them in free runs. A tendon's load is not
  applied at a node: its force and moment follow the rod's shape, so for actuation inputs the
  convolution may read the loads too (``conv_reads = "loads"``). With ``bound`` > 0 the correction
  is limited to +-bound by a tanh.

**Contact inputs** (``contact``: each kept node's gap to the nearest obstacle and its normal, 4
load channels, ``softrnn.learned.whole.obstacles.ContactFeatures``): the correction reads them, the
linear term never does (their weights stay zero: a gap is not linear in the state). In a free run
they are measured on the run's own state at every step (``rollout``'s ``contact``). The envelope
clips them to the data's range widened by its margin but does not fade the correction on them: the
correction is needed most where a node has gone deeper into a wall than the data ever did.

With ``memory = "lstm"`` a per-node LSTM cell (shared along the rod, ``lstm_step``) also carries a
hidden state from step to step and feeds the convolution.

**The envelope** (``config.envelope`` = m > 0): the training data's range [lo, hi] of each feature
the correction reads (buffers ``env_lo``, ``env_hi``, set by ``set_envelope``). A node whose
features lie inside it gets the full correction; outside, the correction fades linearly to zero
at m (hi - lo) beyond the range (``envelope_gate``), and the correction's inputs are clipped
there. So the correction is bounded, and zero wherever a node is far from anything the network
was trained on: there the model is its linear term, which extrapolates like a damped linear
system instead of like a network.
"""

from __future__ import annotations

import numpy as np
import torch
from torch import nn

from .config import DynamicConfig, conv_channels, n_channels, path_columns

SCALE_KEYS = {"state_scale": "sx", "velocity_scale": "sv", "load_scale": "su", "dv_scale": "sa"}
"""The scale buffers of ``DynamicNet`` and their keys in its ``state_dict``, in a model folder's
weights.safetensors (docs/dynamic-model-format.md) and the fields of ``training.Scales``: the saved
format keeps the short keys."""


def feedback_force(hist: torch.Tensor, feedback, k: int, width: int = 6) -> torch.Tensor:
    """The PD laws' loads (B, M, ``width``) at step ``k`` of a free run from ``hist`` (B, H, M, 6),
    as ``Feedback.force``: stiffness (target - x) - damping (x - x_prev) / model_dt in the force
    channels, zero in the torques and in any channel after them."""
    gains, targets, dt = feedback
    x, prev = hist[:, -1, :, :3], hist[:, -2, :, :3]
    f = gains[..., :1] * (targets[:, k] - x) - gains[..., 1:] * (x - prev) / dt
    return torch.cat([f, torch.zeros(f.shape[:-1] + (width - 3,), dtype=f.dtype)], dim=-1)


def contact_inputs(trajectories, picks: np.ndarray):
    """The contact inputs of the picked windows' trajectories for ``DynamicNet.rollout``: a function
    of states (B, M, 6) (a tensor) giving (B, M, 4), one call per set of obstacles; None without."""
    if trajectories[int(picks[0, 0])].contact is None:
        return None
    groups = {}
    for row, (i, _) in enumerate(picks):
        features = trajectories[int(i)].contact
        groups.setdefault(features.key, (features, []))[1].append(row)

    def measure(states: torch.Tensor) -> torch.Tensor:
        x = states.double().numpy()
        out = np.empty(x.shape[:-1] + (4,))
        for features, rows in groups.values():
            out[rows] = features(x[rows])
        return torch.as_tensor(out, dtype=torch.float32)
    return measure


def _conv_stack(n_in: int, config: DynamicConfig) -> nn.Sequential:
    """The convolution along the rod: ``layers`` convolutions of ``width`` channels and kernel
    ``kernel``, each followed by a GELU, then a 1 x 1 convolution to the 6 outputs whose weights
    start at zero (so training starts from the linear term)."""
    width, pad = config.width, config.kernel // 2
    layers = [nn.Conv1d(n_in, width, config.kernel, padding=pad), nn.GELU(approximate="tanh")]
    for _ in range(config.layers - 1):
        layers += [nn.Conv1d(width, width, config.kernel, padding=pad), nn.GELU(approximate="tanh")]
    out = nn.Conv1d(width, 6, 1)
    nn.init.zeros_(out.weight)
    nn.init.zeros_(out.bias)
    return nn.Sequential(*layers, out)


class DynamicNet(nn.Module):
    """One model step: next = x + v + dv_scale (linear term + correction), fixed nodes held,
    prescribed nodes on their path.

    Buffers: ``node_features`` (M, 3), ``fixed`` (M,) bool, ``prescribed`` (M,) bool (in the
    ``state_dict`` only when a node is prescribed) and the training data's standard
    deviations (``SCALE_KEYS``): ``state_scale``, ``velocity_scale``, ``dv_scale`` (6,) of the
    states, velocities and velocity changes, ``load_scale`` (L,) of the loads (L = 6, or m / 6 + m
    with actuation inputs: ``load_width``); with an envelope also ``env_lo``, ``env_hi``, ``env_inv``.
    ``scales`` (a ``training.Scales``) holds the four standard deviations as fields named by their saved
    keys (``training.scales``).
    """

    def __init__(self, config: DynamicConfig, node_features, fixed, scales, prescribed=None, contact=None):
        super().__init__()
        self.config = config
        self.register_buffer("node_features", torch.as_tensor(node_features, dtype=torch.float32))
        self.register_buffer("fixed", torch.as_tensor(fixed, dtype=torch.bool))
        presc = torch.zeros_like(self.fixed) if prescribed is None else torch.as_tensor(prescribed, dtype=torch.bool)
        self.register_buffer("prescribed", presc, persistent=False)
        for name, key in SCALE_KEYS.items():
            self.register_buffer(name, torch.as_tensor(getattr(scales, key), dtype=torch.float32))
        M = int(self.node_features.shape[0])
        L = int(self.load_scale.numel())              # load channels: 6, or with actuation inputs m or 6 + m
        C = n_channels(config.history, L)
        self.n_kept, self.n_in, self.load_width = M, C, L
        self.prescribed_columns = path_columns(presc.tolist(), L)
        self.contact_columns = None if contact is None else slice(int(contact.start), int(contact.stop))
        self.linear = nn.Linear(M * C, M * 6) if config.linear else None
        self.register_buffer("conv_cols", torch.as_tensor(conv_channels(config.history, config.conv_reads, L,
                                                                        self.contact_columns)), persistent=False)
        G = int(self.conv_cols.numel())
        if config.envelope is not None:     # no clipping until set_envelope (training) or load_state_dict
            self.register_buffer("env_lo", torch.full((G,), -torch.inf))
            self.register_buffer("env_hi", torch.full((G,), torch.inf))
            self.register_buffer("env_inv", torch.zeros(G))
        else:
            self.env_lo = self.env_hi = None
        self.cell = nn.LSTMCell(G, config.width) if config.memory == "lstm" else None
        if config.conv or self.cell is not None:
            self.conv = _conv_stack(G + (config.width if self.cell is not None else 0), config)
        else:
            self.conv = None
        if self.linear is not None:
            nn.init.zeros_(self.linear.weight)
            nn.init.zeros_(self.linear.bias)
            if self.contact_columns is not None:     # the linear term never reads the contact inputs
                keep = torch.ones(M, C)
                keep[:, self.contact_feature_columns] = 0.0
                keep = keep.reshape(1, -1)
                self.linear.weight.register_hook(lambda grad: grad * keep)

    @property
    def contact_feature_columns(self) -> slice | None:
        """Where the contact inputs sit among a node's features (C,), or None."""
        if self.contact_columns is None:
            return None
        first = 6 * self.config.history
        return slice(first + self.contact_columns.start, first + self.contact_columns.stop)

    @classmethod
    def of(cls, config: DynamicConfig, encoding, scales) -> DynamicNet:
        """A net of ``config`` on ``encoding``'s nodes (an ``Encoding``), scaled by ``scales``."""
        return cls(config, encoding.node_features(), encoding.fixed, scales, encoding.prescribed,
                   encoding.contact_columns)

    # ---------------------------------------------------------------- saved keys of the scales
    def _save_to_state_dict(self, destination, prefix, keep_vars):
        """As ``nn.Module``'s, with the scale buffers under their saved keys (``SCALE_KEYS``) and
        ``prescribed`` where a node is prescribed."""
        own = {}
        super()._save_to_state_dict(own, prefix, keep_vars)
        for key, value in own.items():
            name = key[len(prefix):]
            destination[prefix + SCALE_KEYS.get(name, name)] = value
        if self.prescribed_columns:
            destination[prefix + "prescribed"] = self.prescribed if keep_vars else self.prescribed.detach()
        if self.contact_columns is not None:
            destination[prefix + "contact_columns"] = torch.tensor([self.contact_columns.start,
                                                                    self.contact_columns.stop])

    def _load_from_state_dict(self, state_dict, prefix, *args, **kwargs):
        """As ``nn.Module``'s, reading the scale buffers from their saved keys (``SCALE_KEYS``); a
        saved ``prescribed`` mask and ``contact_columns`` must be the net's own."""
        for name, key in SCALE_KEYS.items():
            if prefix + key in state_dict:
                state_dict[prefix + name] = state_dict.pop(prefix + key)
        saved = state_dict.pop(prefix + "prescribed", None)
        if saved is not None and not torch.equal(saved.to(torch.bool), self.prescribed):
            raise ValueError("the saved prescribed nodes differ from the network's")
        saved = state_dict.pop(prefix + "contact_columns", None)
        own = None if self.contact_columns is None else [self.contact_columns.start, self.contact_columns.stop]
        if (None if saved is None else [int(v) for v in saved.tolist()]) != own:
            raise ValueError("the saved contact inputs differ from the network's")
        super()._load_from_state_dict(state_dict, prefix, *args, **kwargs)

    # ---------------------------------------------------------------------------- the envelope
    def set_envelope(self, lo: torch.Tensor, hi: torch.Tensor) -> None:
        """The data's range [lo, hi] of the ``conv_cols`` features ((G,) each, in scaled units):
        buffers ``env_lo``, ``env_hi`` and ``env_inv`` = 1 / (m (hi - lo)), 0 for a channel that
        never varies (a constant, or a coordinate the data never move). The contact inputs get
        ``env_inv`` 0 and their range widened by m (hi - lo): clipped there, never fading."""
        if self.env_lo is None:
            return
        width = float(self.config.envelope) * (hi - lo)
        inv = torch.where(width > 1e-9, 1.0 / torch.clamp(width, min=1e-9), 0.0)
        if self.contact_columns is not None:
            cols = self.contact_feature_columns
            ungated = (self.conv_cols >= cols.start) & (self.conv_cols < cols.stop)
            lo, hi = torch.where(ungated, lo - width, lo), torch.where(ungated, hi + width, hi)
            inv = torch.where(ungated, 0.0, inv)
        with torch.no_grad():
            self.env_lo.copy_(lo)
            self.env_hi.copy_(hi)
            self.env_inv.copy_(inv)

    def envelope_gate(self, g: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """(clipped inputs (..., G), gate (..., 1)): the gate is 1 inside the data's range, falls
        linearly to 0 at m (hi - lo) outside it (the farthest channel decides), where the inputs
        are clipped."""
        over = torch.clamp(torch.maximum(self.env_lo - g, g - self.env_hi), min=0.0) * self.env_inv
        gate = torch.clamp(1.0 - over.amax(dim=-1, keepdim=True), min=0.0)
        margin = torch.where(self.env_inv > 0, 1.0 / torch.clamp(self.env_inv, min=1e-30), 0.0)
        g = torch.minimum(torch.maximum(g, self.env_lo - margin), self.env_hi + margin)
        return g, gate

    # -------------------------------------------------------------------------- one model step
    def features(self, hist: torch.Tensor, loads: torch.Tensor) -> torch.Tensor:
        """hist (B, H, M, 6) states, oldest first; loads (B, M, L) -> features (B, M, C): the
        state, the H - 1 velocities, the loads (each over its scale) and the node constants."""
        B = hist.shape[0]
        parts = [hist[:, -1] / self.state_scale]
        for j in range(self.config.history - 1):
            parts.append((hist[:, -1 - j] - hist[:, -2 - j]) / self.velocity_scale)
        parts.append(loads / self.load_scale)
        parts.append(self.node_features.expand(B, -1, -1))
        return torch.cat(parts, dim=-1)

    def linear_term(self, features: torch.Tensor) -> torch.Tensor:
        """The global linear map of every node's features (B, M, C) -> (B, M, 6) (zeros without it)."""
        B, M, C = features.shape
        dv = torch.zeros(B, M, 6, dtype=features.dtype)
        if self.linear is not None:
            dv = dv + self.linear(features.reshape(B, M * C)).reshape(B, M, 6)
        return dv

    def correction_inputs(self, features: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor | None]:
        """(the features the convolution reads (B, M, G), ``conv_cols``, clipped to the envelope;
        the envelope gate (B, M, 1), or None without an envelope)."""
        inputs = features[..., self.conv_cols]
        if self.env_lo is None:
            return inputs, None
        return self.envelope_gate(inputs)

    def lstm_step(self, inputs: torch.Tensor, memory) -> tuple[torch.Tensor, tuple]:
        """One step of the per-node LSTM cell (shared along the rod) from ``memory`` (h, c)
        (B M, W) each (None: zeros): (the inputs with the new hidden state appended (B, M, G + W),
        the new memory)."""
        B, M, G = inputs.shape
        if memory is None:
            z = torch.zeros(B * M, self.config.width, dtype=inputs.dtype)
            memory = (z, z)
        h, c = self.cell(inputs.reshape(B * M, G), memory)
        return torch.cat([inputs, h.reshape(B, M, -1)], dim=-1), (h, c)

    def correction(self, features: torch.Tensor, memory) -> tuple[torch.Tensor, tuple | None]:
        """The convolution's correction (B, M, 6) to the scaled velocity change, times the envelope
        gate and limited to +-bound by a tanh (bound > 0), and the LSTM memory for the next step."""
        inputs, gate = self.correction_inputs(features)
        if self.cell is not None:
            inputs, memory = self.lstm_step(inputs, memory)
        out = self.conv(inputs.transpose(1, 2)).transpose(1, 2)
        if gate is not None:
            out = out * gate
        b = self.config.bound
        return (b * torch.tanh(out / b) if b > 0 else out), memory

    @property
    def held(self) -> torch.Tensor:
        """(M,) bool: the nodes the model does not predict (fixed or prescribed)."""
        return self.fixed | self.prescribed

    def next_state(self, hist: torch.Tensor, dv: torch.Tensor, loads: torch.Tensor | None = None) -> torch.Tensor:
        """x + v + dv ``dv_scale`` from the latest state x and velocity v of ``hist`` and the scaled
        velocity change ``dv`` (B, M, 6); fixed nodes keep their state, prescribed ones move by the
        change their ``loads`` (B, M, L) channels give."""
        x, v = hist[:, -1], hist[:, -1] - hist[:, -2]
        nxt = torch.where(self.fixed[None, :, None], x, x + v + dv * self.dv_scale)
        if not self.prescribed_columns:
            return nxt
        rows = [nxt[:, m] for m in range(self.n_kept)]
        for m, c in self.prescribed_columns:
            rows[m] = x[:, m] + loads[:, m, c:c + 6]
        return torch.stack(rows, dim=1)

    def forward(self, hist: torch.Tensor, loads: torch.Tensor, memory=None):
        """hist (B, H, M, 6), loads (B, M, L) -> (next state (B, M, 6), memory for the next step)."""
        features = self.features(hist, loads)
        dv = self.linear_term(features)
        if self.conv is not None:
            correction, memory = self.correction(features, memory)
            dv = dv + correction
        return self.next_state(hist, dv, loads), memory

    def rollout(self, hist: torch.Tensor, loads: torch.Tensor, feedback=None, contact=None) -> torch.Tensor:
        """Free run: hist (B, H, M, 6), loads (B, K, M, L) for each step -> states (B, K, M, 6).
        ``feedback``: (gains (B, M, 2), targets (B, K, M, 3), model_dt) of PD laws applied to the
        run's own states at every step (``softrnn.learned.whole.feedback``), or None. ``contact``:
        a function of the latest states (B, M, 6) giving their contact inputs (B, M, 4), which
        replace the loads' ``contact_columns`` at every step (no gradient flows through them), or None."""
        out, memory = [], None
        for k in range(loads.shape[1]):
            u = loads[:, k] if feedback is None else loads[:, k] + feedback_force(hist, feedback, k, loads.shape[-1])
            if contact is not None:
                c = self.contact_columns
                u = torch.cat([u[..., :c.start], contact(hist[:, -1].detach()), u[..., c.stop:]], dim=-1)
            nxt, memory = self.forward(hist, u, memory)
            out.append(nxt)
            hist = torch.cat([hist[:, 1:], nxt[:, None]], dim=1)
        return torch.stack(out, dim=1)
