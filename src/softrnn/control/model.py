"""The learned model the MPC plans with: a NARX network of the magnets' measured orientations.

State y (4,) [rad]: the proximal and distal magnets' orientations about x and y (the camera's). Input
u (3,): the unit direction of the commanded field (the currents are the minimum-norm ones for a
field of fixed magnitude along u, as ``static_inverse.StaticInverse`` commands). The network predicts
the next frame's change from the last ``HISTORY`` frames:

    y[k+1] = y[k] + W2 tanh(W1 z[k] + b1) + b2,   z[k] = normalised (y[k-H+1..k], u[k-H+1..k])

It is trained (PyTorch) on an identification run of the robot (``identify``: random smooth field
directions held frame by frame, the camera with its noise), with a loss over ``UNROLL``-frame
free runs from every start (the model's own predictions fed back), which keeps its long-horizon
predictions honest. The trained weights are plain NumPy arrays (``NarxModel``), so the MPC runs
without PyTorch: a batch of B rollouts is a few small matrix products per frame.

Why not the experiment's magnet LSTMs: their input II is the magnet wrench computed from the
*measured* pose, not a command, so a planner would have to predict poses to form its own inputs;
and a recurrent state is awkward to differentiate through a horizon. A NARX network on the
commanded field is what MPC needs.

``NarxPredictor`` is the network as the MPC's ``predictors.Predictor``: a fixed-gain observer blends
its one-frame prediction with the measurement, and a slow integral term learns its remaining offset
on the distal magnet.
"""

from __future__ import annotations

import io
import json
import math
import pickle
import time
import zipfile
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..errors import bad, is_finite_number
from ..files import atomic_write_bytes
from ..progress import Progress
from .fields import A_RANGE, field_direction
from .predictors import DISTURBANCE_GAIN

HISTORY = 2
"""Frames of history the network reads."""

UNROLL = 15
"""Frames of the free runs in the training loss (half a second at 30 Hz; the MPC's horizon)."""

STATE = 4
INPUT = 3


def state_of(orientations) -> np.ndarray:
    """The model's state (..., 4) [rad] from camera orientations (..., 2, 3): (proximal x, y, distal x, y)."""
    o = np.asarray(orientations, float)
    return o[..., :, :2].reshape(o.shape[:-2] + (STATE,))


@dataclass(frozen=True, eq=False)
class NarxModel:
    """Trained NARX weights (NumPy): mean, std (H (4 + 3),) normalisation of the inputs; W1 (m, H (4 + 3)),
    b1 (m,), W2 (4, m), b2 (4,); ``meta`` says how it was trained."""

    mean: np.ndarray
    std: np.ndarray
    W1: np.ndarray
    b1: np.ndarray
    W2: np.ndarray
    b2: np.ndarray
    meta: dict

    @cached_property
    def _folded(self) -> tuple:
        """(Wy (m, H 4), Wu (m, H 3), b (m,)): the first layer with the normalisation folded in."""
        W = self.W1 / self.std
        n = self.mean.size - HISTORY * INPUT
        return np.ascontiguousarray(W[:, :n]), np.ascontiguousarray(W[:, n:]), self.b1 - W @ self.mean

    def step(self, ys: np.ndarray, us: np.ndarray) -> np.ndarray:
        """Next states (B, 4) from histories ys (B, H, 4) [rad] and us (B, H, 3)."""
        Wy, Wu, b = self._folded
        B = ys.shape[0]
        return ys[:, -1] + np.tanh(ys.reshape(B, -1) @ Wy.T + us.reshape(B, -1) @ Wu.T + b) @ self.W2.T + self.b2

    def rollout(self, ys: np.ndarray, us_past: np.ndarray, us_future: np.ndarray) -> np.ndarray:
        """States (B, N, 4) of N frames ahead, from histories ys (B, H, 4), the applied inputs us_past
        (B, H - 1, 3) and the planned ones us_future (B, N, 3) (applied over frames k, k + 1, ...)."""
        B, N = us_future.shape[:2]
        H = ys.shape[1]
        y = np.empty((B, H + N, STATE))                 # the known history, then the predictions
        y[:, :H] = ys
        u = np.concatenate([us_past, us_future], 1)      # (B, H - 1 + N, 3)
        Wy, Wu, b = self._folded
        W2T = self.W2.T
        for i in range(N):
            pre = y[:, i:i + H].reshape(B, -1) @ Wy.T + u[:, i:i + H].reshape(B, -1) @ Wu.T + b
            y[:, H + i] = y[:, H + i - 1] + np.tanh(pre) @ W2T + self.b2
        return y[:, H:]

    def save(self, path) -> None:
        """Write the weights and ``meta`` to an ``.npz`` file (atomically)."""
        buf = io.BytesIO()
        np.savez(buf, mean=self.mean, std=self.std, W1=self.W1, b1=self.b1, W2=self.W2, b2=self.b2,
                 meta=np.array(json.dumps(self.meta)))
        atomic_write_bytes(path, buf.getvalue())

    @classmethod
    def load(cls, path) -> NarxModel:
        """Read ``save``'s file; a missing or foreign file is a one-line error naming ``--model``."""
        try:
            with np.load(path) as f:
                return cls(mean=f["mean"], std=f["std"], W1=f["W1"], b1=f["b1"], W2=f["W2"], b2=f["b2"],
                           meta=json.loads(str(f["meta"])))
        except (OSError, KeyError, ValueError, EOFError, zipfile.BadZipFile, pickle.UnpicklingError) as err:
            raise bad("--model", str(path), f"a control model file written by softrnn control ({err})") from None


def windows(y: np.ndarray, u: np.ndarray, length: int) -> tuple:
    """Training windows of a run (y (K, 4), u (K, 3), u[k] applied over frame k to k + 1): histories
    (W, H, 4) and (W, H, 3) ending at frame k, the future inputs (W, length, 3) and the targets
    (W, length, 4) of frames k + 1 .. k + length, for every k that fits."""
    H = HISTORY
    ks = np.arange(H - 1, y.shape[0] - length)
    hy = np.stack([y[k - H + 1:k + 1] for k in ks])
    hu = np.stack([u[k - H + 1:k + 1] for k in ks])
    fu = np.stack([u[k:k + length] for k in ks])
    ty = np.stack([y[k + 1:k + 1 + length] for k in ks])
    return hy, hu, fu, ty


def train_narx(runs: list, *, hidden: int = 48, steps: int = 2000, unroll: int = UNROLL, seed: int = 0,
               lr: float = 1e-2, progress: Progress | None = None) -> NarxModel:
    """Train the NARX network on identification runs [(y (K, 4) [rad], u (K, 3)), ...] with the
    ``unroll``-frame free-run loss (Adam, full batch of every window). Deterministic for a seed.
    ``progress(done, steps, {"stage": "train"})`` is called every 1 % of the steps and after the last."""
    import torch  # optional extra: learn (PyTorch)

    torch.manual_seed(seed)
    parts = [windows(y, u, unroll) for y, u in runs]
    hy, hu, fu, ty = (np.concatenate([p[i] for p in parts]) for i in range(4))
    zin = np.concatenate([hy.reshape(len(hy), -1), hu.reshape(len(hu), -1)], 1)
    mean, std = zin.mean(0), zin.std(0) + 1e-6
    step_scale = float(np.std(np.diff(ty, axis=1))) + 1e-9
    T = {k: torch.tensor(v, dtype=torch.float32) for k, v in
         dict(hy=hy, hu=hu, fu=fu, ty=ty, mean=mean, std=std).items()}
    H, D = HISTORY, zin.shape[1]
    W1 = torch.nn.Parameter(torch.randn(hidden, D, dtype=torch.float32) / math.sqrt(D))
    b1 = torch.nn.Parameter(torch.zeros(hidden, dtype=torch.float32))
    W2 = torch.nn.Parameter(torch.zeros(STATE, hidden, dtype=torch.float32))
    b2 = torch.nn.Parameter(torch.zeros(STATE, dtype=torch.float32))
    opt = torch.optim.Adam([W1, b1, W2, b2], lr=lr)
    sched = torch.optim.lr_scheduler.CosineAnnealingLR(opt, steps)
    t0 = time.perf_counter()
    every = max(1, steps // 100)
    for step in range(steps):
        ys, us = T["hy"], T["hu"]
        loss = 0.0
        for i in range(unroll):
            z = (torch.cat([ys.reshape(len(ys), -1), us.reshape(len(us), -1)], 1) - T["mean"]) / T["std"]
            nxt = ys[:, -1] + torch.tanh(z @ W1.T + b1) @ W2.T + b2
            loss = loss + torch.mean(((nxt - T["ty"][:, i]) / step_scale) ** 2)
            ys = torch.cat([ys[:, 1:], nxt[:, None]], 1)
            if i + 1 < unroll:
                us = torch.cat([us[:, 1:], T["fu"][:, i + 1:i + 2]], 1)
        opt.zero_grad()
        (loss / unroll).backward()
        opt.step()
        sched.step()
        if progress is not None and ((step + 1) % every == 0 or step + 1 == steps):
            progress(step + 1, steps, {"stage": "train"})
    meta = {"history": H, "hidden": hidden, "steps": steps, "unroll": unroll, "seed": seed, "lr": lr,
            "windows": int(len(hy)), "frames": int(sum(len(y) for y, _ in runs)),
            "final_loss": float(loss.detach()) / unroll,
            "seconds": time.perf_counter() - t0}
    weights = {k: v.detach().numpy().astype(np.float64) for k, v in dict(W1=W1, b1=b1, W2=W2, b2=b2).items()}
    return NarxModel(mean=mean, std=std, meta=meta, **weights)


def _gain(name: str, value) -> float:
    """``value`` as a gain in [0, 1], or a one-line ``SoftrnnInputError`` naming ``name``."""
    if not is_finite_number(value) or not 0.0 <= value <= 1.0:
        raise bad(name, value, "a gain in [0, 1]")
    return float(value)


class NarxPredictor:
    """A trained ``NarxModel`` as the MPC's ``predictors.Predictor``.

    Parameters
    ----------
    model : NarxModel
        the network
    observer_gain : float
        weight of the measurement against the one-frame prediction in the state estimate
        (the camera's noise is large at the distal magnet, about 1 deg)
    disturbance_gain : float
        gain of the integral term that learns the model's offset on the distal magnet,
        so a constant model error does not become a constant tracking error
    """

    history = HISTORY

    def __init__(self, model: NarxModel, *, observer_gain: float = 0.15, disturbance_gain: float = DISTURBANCE_GAIN):
        self.model = model
        self.observer_gain = _gain("observer_gain", observer_gain)
        self.disturbance_gain = _gain("disturbance_gain", disturbance_gain)
        self.ys = None                                  # (H, 4) estimated states; None before the first frame
        self.us = np.zeros((HISTORY, INPUT))            # (H, 3) applied field directions
        self.predicted = None                           # (4,) the model's prediction of the next frame
        self.disturbance = np.zeros(STATE)

    def start(self, target) -> np.ndarray:
        """The field angles (a, 0) whose steady state under the model (a 2 s rollout from the state
        the model settles to under that field) is closest to ``target`` (about x, about y) [rad]."""
        a = np.linspace(A_RANGE[0], A_RANGE[1], 91)
        u = field_direction(a, np.zeros_like(a))                                      # (B, 3)
        B, H, N = a.size, HISTORY, int(2.0 * 30)
        y = np.zeros((B, H, 4))
        y[:] = np.array([0.0, target[1], 0.0, target[1]])                            # a rough start
        us = np.repeat(u[:, None], N, 1)
        for _ in range(2):                                                           # settle twice from the end
            out = self.model.rollout(y, us[:, :H - 1], us)
            y = out[:, -H:]
        err = np.sum((out[:, -1, 2:] - np.asarray(target)) ** 2, axis=1)
        return np.array([a[int(np.argmin(err))], 0.0])

    def reset(self, applied, currents) -> None:
        """Forget the run: the history holds ``applied``; the state is taken from the first measurement."""
        self.ys = None
        self.us = np.tile(field_direction(*applied), (HISTORY, 1))
        self.predicted = None
        self.disturbance = np.zeros(STATE)

    def observe(self, measured) -> bool:
        """Blend the measured state with the prediction (the first frame: the measurement held over
        the history) and integrate the distal innovation; False for a measurement with a NaN."""
        y_meas = state_of(measured)
        if not np.all(np.isfinite(y_meas)):
            return False
        if self.ys is None:
            self.ys = np.tile(y_meas, (HISTORY, 1))
            return True
        pred = self.predicted + self.disturbance
        innovation = y_meas - pred
        self.disturbance[2:] += self.disturbance_gain * innovation[2:]
        est = pred + self.observer_gain * innovation
        self.ys = np.concatenate([self.ys[1:], est[None]], 0)
        return True

    def predict(self, plans: np.ndarray, block_of: np.ndarray) -> np.ndarray:
        """The distal orientations (B, N, 2) [rad]: one batch of rollouts of the network, plus the
        learned offset."""
        B = plans.shape[0]
        ang = plans[:, block_of]                                                     # (B, N, 2)
        future = field_direction(ang[..., 0], ang[..., 1])                          # (B, N, 3)
        ys = np.broadcast_to(self.ys, (B,) + self.ys.shape)
        us = np.broadcast_to(self.us[1:], (B,) + self.us[1:].shape)
        return self.model.rollout(ys, us, future)[..., 2:] + self.disturbance[2:]  # (B, N, 2) distal

    def advance(self, applied, currents) -> None:
        """Append the applied direction to the history and predict the next frame."""
        self.us = np.concatenate([self.us[1:], field_direction(applied[0], applied[1])[None]], 0)
        self.predicted = self.model.step(self.ys[None], self.us[None])[0]

    def hold(self, currents) -> None:
        """Nothing to do: the estimate waits for the next usable measurement."""
