"""Training losses of a node model: one step ahead, or K steps ahead with its predictions fed back.

All losses are mean squared errors in normalised units. ``_OneStep`` and ``_MultiStep`` (and its
``_RelativeMultiStep`` for relative inputs) share one interface: ``tensors(windows)`` gives the
tensors of a span, ``loss(module, poses, wrenches, targets, generator)`` the training loss of a
batch (``generator`` draws the augmentation; None: none) and ``evaluate(...)`` the loss over a
span without gradients.
"""

from __future__ import annotations

import numpy as np
import torch

from .data import SampleSpec, Windows
from .model import ModelConfig, NodeLSTM
from .normalizer import Normalizer


# ------------------------------------------------------------------------------------------ one step
class _OneStep:
    """Training on one-step windows: the model's output against the next position's target
    (``TrainConfig.rollout_steps`` = 1), the node's past positions offset at random when
    ``input_noise`` > 0 (``_shift_node``)."""

    def __init__(self, normalizer: Normalizer, spec: SampleSpec, input_noise: float):
        self.normalizer = normalizer
        self.input_noise = input_noise
        self.noise = _noise_scales(normalizer, spec, input_noise)

    def tensors(self, w: Windows):
        """Windows (M, H, .) -> normalised poses (M, H, P), wrenches (M, H, W) and targets (M, 3)."""
        n = self.normalizer
        return (torch.from_numpy(n.normalise_poses(w.poses)),                 # (M, H, P)
                torch.from_numpy(n.normalise_wrenches(w.wrenches)),           # (M, H, W)
                torch.from_numpy(n.normalise_targets(w.targets, w.poses)))    # (M, 3)

    def loss(self, module, poses, wrenches, targets, generator=None):
        """Mean squared normalised error of a batch: poses (b, H, P), wrenches (b, H, W), targets (b, 3)."""
        if generator is not None and self.input_noise > 0:
            poses, targets = _shift_node(poses, targets, self.noise, generator)
        y = module(poses, wrenches)                                           # (b, 3)
        return torch.mean((y - targets) ** 2)

    def evaluate(self, module, poses, wrenches, targets, chunk: int = 8192) -> float:
        """Mean squared error (normalised units) over all windows, in eval mode, without gradients."""
        return _evaluate(module, poses, wrenches, targets, chunk)


def _evaluate(module: NodeLSTM, poses: torch.Tensor, wrenches: torch.Tensor, targets: torch.Tensor,
              chunk: int = 8192) -> float:
    """Mean squared error (normalised units) over all windows."""
    module.eval()
    total = 0.0
    with torch.no_grad():
        for a in range(0, poses.shape[0], chunk):
            y = module(poses[a:a + chunk], wrenches[a:a + chunk])          # (b, 3)
            total += float(((y - targets[a:a + chunk]) ** 2).sum())
    return total / max(1, targets.numel())


def _noise_scales(normalizer: Normalizer, spec: SampleSpec, input_noise: float) -> dict:
    """The node-offset augmentation in normalised units (``_shift_node``): per pose column the
    axis it moves with (-1: none) and its shift per unit offset, and the target's shift.

    The offset's standard deviation per axis is ``input_noise`` times the node's typical step
    (``delta_std`` of its position columns)."""
    sigma = input_noise * normalizer.delta_std[0:3]                             # (3,) physical [m]
    P, per = normalizer.pose_features, spec.per_node
    axis = np.full(P, -1)                                                       # (P,)
    sign = np.zeros(P)                                                          # (P,)
    for k in range(P // per):
        if normalizer.relative and k > 0:                                       # neighbours relative to the node
            axis[k * per:k * per + 3], sign[k * per:k * per + 3] = np.arange(3), -1.0
        elif not normalizer.relative and k == 0:                                # the node itself
            axis[0:3], sign[0:3] = np.arange(3), 1.0
    pose = np.where(axis >= 0, sign * sigma[np.maximum(axis, 0)] / normalizer.pose_std, 0.0)   # (P,)
    target = np.zeros(3) if normalizer.output == "pose" else -sigma / normalizer.target_std   # (3,)
    return {"axis": torch.as_tensor(np.maximum(axis, 0)), "pose": torch.as_tensor(pose, dtype=torch.float32),
            "target": torch.as_tensor(target, dtype=torch.float32)}


def _shift_node(poses: torch.Tensor, targets: torch.Tensor, noise: dict, generator) -> tuple:
    """Offset the node's own past positions by a random vector (the same at every step of a
    window), keeping the true next position as the target: the model learns to pull a drifted
    node back (a free-running rollout's robustness). poses (b, H, P), targets (b, 3)."""
    d = torch.randn(poses.shape[0], 3, generator=generator)                    # (b, 3) offsets in sigmas
    shift = d[:, noise["axis"]] * noise["pose"]                                 # (b, P)
    return poses + shift[:, None, :], targets + d * noise["target"]


# ------------------------------------------------------------------------------------------ K steps
class _MultiStep:
    """Training on K-step free-running windows: the node's predicted positions are fed back into
    its next windows (the neighbours and wrenches stay the recorded ones) and the loss averages the
    K one-step errors, each against the true next position relative to the window it saw. This
    teaches the model to correct its own drift (``TrainConfig.rollout_steps``)."""

    def __init__(self, normalizer: Normalizer, config: ModelConfig, K: int, input_noise: float):
        self.K, self.H, self.output = K, config.history, config.output
        self.normalizer = normalizer
        def t(x):
            return torch.tensor(np.array(x, dtype=np.float32))

        self.mean, self.std = t(normalizer.pose_mean[0:3]), t(normalizer.pose_std[0:3])    # (3,), (3,)
        self.tmean, self.tstd = t(normalizer.target_mean), t(normalizer.target_std)        # (3,), (3,)
        self.sigma = t(input_noise * normalizer.delta_std[0:3] / normalizer.pose_std[0:3])  # (3,) z units

    def tensors(self, w: Windows):
        """Long windows (M, H+K-1, .) -> normalised poses, wrenches and the true node positions of
        the K predicted steps (M, K, 3) in normalised pose units."""
        n = self.normalizer
        poses = torch.from_numpy(n.normalise_poses(w.poses))                              # (M, H+K-1, P)
        wrenches = torch.from_numpy(n.normalise_wrenches(w.wrenches))                     # (M, H+K-1, W)
        nxt = np.concatenate([w.poses[:, self.H:, 0:3], w.targets[:, None, :]], axis=1)   # (M, K, 3) physical
        truth = torch.from_numpy(((nxt - n.pose_mean[0:3]) / n.pose_std[0:3]).astype(np.float32))  # (M, K, 3)
        return poses, wrenches, truth

    def _to_position(self, y, cur):
        """Model outputs (b, 3) and windows (b, H, P) -> predicted next node position (b, 3), z units."""
        raw = y * self.tstd + self.tmean                                                   # (b, 3) physical
        if self.output == "pose":
            return (raw - self.mean) / self.std
        nxt = cur[:, -1, 0:3] + raw / self.std
        if self.output == "acceleration":
            nxt = nxt + (cur[:, -1, 0:3] - cur[:, -2, 0:3])
        return nxt

    def _target(self, truth_z, cur):
        """True next node position (b, 3) in z units -> the model's target for window ``cur``."""
        if self.output == "pose":
            raw = truth_z * self.std + self.mean
        else:
            raw = (truth_z - cur[:, -1, 0:3]) * self.std
            if self.output == "acceleration":
                raw = raw - (cur[:, -1, 0:3] - cur[:, -2, 0:3]) * self.std
        return (raw - self.tmean) / self.tstd

    def loss(self, module, poses, wrenches, truth, generator=None):
        """Mean squared normalised error over the K steps. poses (b, H+K-1, P), truth (b, K, 3)."""
        H = self.H
        cur = poses[:, :H]                                                                 # (b, H, P)
        if generator is not None and bool((self.sigma > 0).any()):
            d = torch.randn(poses.shape[0], 1, 3, generator=generator) * self.sigma        # (b, 1, 3)
            cur = torch.cat([cur[:, :, 0:3] + d, cur[:, :, 3:]], dim=2)
        total = 0.0
        for s in range(self.K):
            y = module(cur, wrenches[:, s:s + H])                                          # (b, 3)
            total = total + torch.mean((y - self._target(truth[:, s], cur)) ** 2)
            if s + 1 < self.K:
                nxt = self._to_position(y, cur)                                           # (b, 3)
                row = torch.cat([nxt, poses[:, s + H, 3:]], dim=1)                         # (b, P)
                cur = torch.cat([cur[:, 1:], row[:, None, :]], dim=1)                      # (b, H, P)
        return total / self.K

    def evaluate(self, module, poses, wrenches, truth, chunk: int = 8192) -> float:
        module.eval()
        total, n = 0.0, poses.shape[0]
        with torch.no_grad():
            for a in range(0, n, chunk):
                b = min(n, a + chunk)
                total += float(self.loss(module, poses[a:b], wrenches[a:b], truth[a:b])) * (b - a)
        return total / max(1, n)


class _RelativeMultiStep(_MultiStep):
    """``_MultiStep`` for relative inputs: the windows stay in physical units, anchored at the
    node's last position of the first window (small float32 numbers), and every fed-back window is
    re-expressed relative to its own last node position before the normalisation, as
    ``Normalizer.normalise_poses`` does for a single window."""

    def __init__(self, normalizer: Normalizer, config: ModelConfig, K: int, input_noise: float):
        super().__init__(normalizer, config, K, input_noise)
        P, per = normalizer.pose_features, normalizer.per_node
        col = np.arange(P) % per
        self.is_pos = torch.tensor((col < 3).astype(np.float32))                            # (P,)
        self.axis = torch.as_tensor(np.where(col < 3, col, 0))                              # (P,)
        self.pmean = torch.tensor(normalizer.pose_mean.astype(np.float32))                 # (P,)
        self.pstd = torch.tensor(normalizer.pose_std.astype(np.float32))                   # (P,)
        self.step_std = torch.tensor((input_noise * normalizer.delta_std[0:3]).astype(np.float32))  # (3,) [m]

    def tensors(self, w: Windows):
        """Long windows -> anchored physical poses (M, H+K-1, P), normalised wrenches, and the true
        node positions of the K predicted steps (M, K, 3), anchored like the poses."""
        n, H = self.normalizer, self.H
        anchor = w.poses[:, H - 1, 0:3].astype(np.float64)                                # (M, 3)
        shift = np.where(self.is_pos.numpy() > 0, anchor[:, self.axis.numpy()], 0.0)        # (M, P)
        poses = (w.poses.astype(np.float64) - shift[:, None, :]).astype(np.float32)         # (M, H+K-1, P)
        wrenches = torch.from_numpy(n.normalise_wrenches(w.wrenches))                     # (M, H+K-1, W)
        nxt = np.concatenate([w.poses[:, H:, 0:3], w.targets[:, None, :]], axis=1)         # (M, K, 3)
        truth = (nxt.astype(np.float64) - anchor[:, None, :]).astype(np.float32)
        return torch.from_numpy(poses), wrenches, torch.from_numpy(truth)

    def _normalise(self, cur):
        """Anchored physical windows (b, H, P) -> the model's relative, normalised input."""
        last = cur[:, -1, 0:3][:, self.axis] * self.is_pos                                  # (b, P)
        return (cur - last[:, None, :] - self.pmean) / self.pstd

    def _raw_target(self, truth, cur):
        raw = truth - cur[:, -1, 0:3]
        if self.output == "acceleration":
            raw = raw - (cur[:, -1, 0:3] - cur[:, -2, 0:3])
        return raw

    def loss(self, module, poses, wrenches, truth, generator=None):
        """Mean squared normalised error over the K steps; poses anchored physical (b, H+K-1, P)."""
        H = self.H
        cur = poses[:, :H]                                                                 # (b, H, P)
        if generator is not None and bool((self.step_std > 0).any()):
            d = torch.randn(poses.shape[0], 1, 3, generator=generator) * self.step_std    # (b, 1, 3) [m]
            cur = torch.cat([cur[:, :, 0:3] + d, cur[:, :, 3:]], dim=2)
        total = 0.0
        for s in range(self.K):
            y = module(self._normalise(cur), wrenches[:, s:s + H])                         # (b, 3)
            target = (self._raw_target(truth[:, s], cur) - self.tmean) / self.tstd
            total = total + torch.mean((y - target) ** 2)
            if s + 1 < self.K:
                step = y * self.tstd + self.tmean                                          # (b, 3) [m]
                if self.output == "acceleration":
                    step = step + (cur[:, -1, 0:3] - cur[:, -2, 0:3])
                row = torch.cat([cur[:, -1, 0:3] + step, poses[:, s + H, 3:]], dim=1)      # (b, P)
                cur = torch.cat([cur[:, 1:], row[:, None, :]], dim=1)                      # (b, H, P)
        return total / self.K
