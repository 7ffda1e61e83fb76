"""Training a whole-manipulator model: ridge start, unrolled multi-step loss, noise injection.

1. Scales: the standard deviation of every state, velocity, load and velocity-change channel over
   the training trajectories (shared by all nodes, so the weights stay shared along the rod).
2. The linear term is fitted by ridge regression to the one-step velocity changes. If that linear
   model is unstable (spectral radius of its state map above 1), the penalty is raised tenfold
   until it is not: a free run must not start from an exploding model.
3. Adam on every weight, on windows drawn at random from the training trajectories: the model runs
   free for ``unroll`` steps from a (noised) history and the loss is the mean squared state error
   over those steps, in units of the velocity scale. The unroll grows from 1 step to ``unroll``
   over the first half of training (a curriculum), and the history gets random-walk noise
   (``noise``), so the model learns to pull a perturbed state back onto the data.

A checkpoint is written every ``CHECKPOINT_EVERY`` steps; a run given the same folder resumes from
it with the same result as an uninterrupted one.
"""

from __future__ import annotations

import math
import pickle
import re
import time
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import final

import numpy as np
import torch
from scipy.sparse.linalg import ArpackError, ArpackNoConvergence, eigs

from ...errors import SoftrnnInputError
from ...progress import Progress
from ..baselines import free_run
from ..checkpoints import RESTART, load_state, save_state
from ..horizons import RolloutDiverged
from ..threads import torch_threads
from .artifact import engine_of
from .config import DynamicConfig, linear_config, load_channels
from .encoding import Encoding, Trajectory
from .network import DynamicNet, contact_inputs, feedback_force

CHECKPOINT_EVERY = 100
VALIDATION_STEPS = 1000
STABLE_RADIUS = 1.001
RIDGE_TRIES = 10
_FLOOR = 1e-12
SCALE_FLOOR = 0.1
START_STEPS = 10
"""With ``config.start_fraction``: the windows whose history begins within this many model steps
of a trajectory's first sample count as starts."""
BASELINE_RIDGE = 1e-6
"""Where the linear baseline's penalty ladder starts (``DynamicConfig.ridge``'s default; ``_start``)."""


@dataclass(eq=False)
class TrainedDynamic:
    """A trained model: ``net`` (``DynamicNet``), its ``encoding`` and ``config``, ``linear``: the
    one-step ridge model on the same inputs (the "linear" baseline, a ``DynamicNet`` with the
    linear term only, config ``linear_config(config)``), and ``info`` (losses, the ridge penalty
    used and the linear model's spectral radius, seconds, windows)."""

    net: DynamicNet
    encoding: Encoding
    config: DynamicConfig
    linear: DynamicNet
    info: dict = field(default_factory=dict)


@final
@dataclass(frozen=True)
class Scales:
    """The training data's per-channel standard deviations that scale ``DynamicNet``'s inputs and
    outputs (``scales``); the field names are the keys of the saved weights (``network.SCALE_KEYS``).
    State channels: displacement [m] (0-2) and rotation vector [rad] (3-5) of ``Encoding``.

    Attributes
    ----------
    sx : numpy.ndarray
        (6,) of the states [m, rad].
    sv : numpy.ndarray
        (6,) of the velocities, the states' change over one model step [m, rad].
    su : numpy.ndarray
        (L,) of the loads' channels (wrench [N, N m] and / or actuation, in the data's units).
    sa : numpy.ndarray
        (6,) of the velocity changes over one model step [m, rad]; 0 for a channel that never moves.
    """

    sx: np.ndarray
    sv: np.ndarray
    su: np.ndarray
    sa: np.ndarray


def scales(trajectories: list[Trajectory], wrench: bool = True) -> Scales:
    """Per-channel standard deviations (6,) of states ``sx``, velocities ``sv``, loads ``su`` (L,) and
    velocity changes ``sa`` over ``trajectories``; the inputs' floored within each kind
    (``_group_floor``). An input channel that never varies gets 1; a
    state channel that never moves (planar data: the out-of-plane ones) gets ``sa = 0``, so the
    model's output cannot move it either (a scale of 1 would turn a tiny output into metres).
    ``wrench``: the loads begin with the 6 wrench channels (False: actuation inputs only, each
    channel its own kind, not floored)."""
    X = [t.states for t in trajectories]
    out = {
        "sx": np.concatenate([x.reshape(-1, 6) for x in X]),
        "sv": np.concatenate([np.diff(x, axis=0).reshape(-1, 6) for x in X]),
        "su": np.concatenate([t.forced_loads().reshape(-1, t.loads.shape[-1]) for t in trajectories]),
        "sa": np.concatenate([np.diff(x, 2, axis=0).reshape(-1, 6) for x in X]),
    }
    res = {}
    for key, rows in out.items():
        s = rows.std(axis=0)
        if key != "sa" and (key != "su" or wrench):
            s = _group_floor(s)
        res[key] = np.where(s > _FLOOR, s, 1.0)
    moving = out["sv"].std(axis=0) > _FLOOR
    res["sa"] = np.where(moving, res["sa"], 0.0)
    return Scales(**res)


def _group_floor(s: np.ndarray) -> np.ndarray:
    """Input scales (6,) with each moving channel raised to at least ``SCALE_FLOOR`` times the
    largest of its kind (displacements 0-2, rotations 3-5): a channel that barely moves in the data
    (the twist of a bending rod, about 1e-3 of the bending angles) would otherwise turn a physically
    negligible error of a free run into an input far outside the training range."""
    out = s.copy()
    for g in (slice(0, 3), slice(3, 6)):    # the actuation channels after a wrench (6 + m loads) stay as they are
        moving = s[g] > _FLOOR
        if moving.any():
            out[g] = np.where(moving, np.maximum(s[g], SCALE_FLOOR * s[g][moving].max()), s[g])
    return out


def _windows(trajectories: list[Trajectory], length: int) -> np.ndarray:
    """(n, 2) int64 (trajectory, first index) of every window of ``length`` states."""
    rows = [np.stack([np.full(t.n_steps - length + 1, i), np.arange(t.n_steps - length + 1)], 1)
            for i, t in enumerate(trajectories) if t.n_steps >= length]
    if not rows:
        raise SoftrnnInputError(f"training data: every trajectory is shorter than {length} model steps "
                                "(history + 1); give longer trajectories or a smaller model_dt")
    return np.concatenate(rows)


def _batch(trajectories, picks: np.ndarray, H: int, K: int):
    """hist (B, H, M, 6), loads (B, K, M, L), future (B, K, M, 6) as float32 tensors and the
    feedback laws (gains (B, M, 2), targets (B, K, M, 3), model_dt) for ``DynamicNet.rollout``, or
    None when no picked trajectory has any."""
    hist, loads, future, gains, targets = [], [], [], [], []
    M = trajectories[0].states.shape[1]
    dts = {trajectories[i].feedback.model_dt for i, _ in picks if trajectories[i].feedback is not None}
    for i, s in picks:
        t = trajectories[i]
        hist.append(t.states[s:s + H])
        loads.append(t.loads[s + H - 1:s + H - 1 + K])
        future.append(t.states[s + H:s + H + K])
        if dts:          # zero gains where a trajectory has no law
            fb = t.feedback
            gains.append(np.zeros((M, 2)) if fb is None else fb.gains)
            targets.append(np.zeros((K, M, 3)) if fb is None else fb.targets[s + H - 1:s + H - 1 + K])
    as_t = lambda a: torch.as_tensor(np.asarray(a), dtype=torch.float32)  # noqa: E731
    feedback = (as_t(gains), as_t(targets), dts.pop()) if dts else None
    return as_t(hist), as_t(loads), as_t(future), feedback


def _first_loads(hist, loads, feedback) -> torch.Tensor:
    """The first step's loads (B, M, 6) with the feedback laws applied to ``hist`` (teacher forcing)."""
    return loads[:, 0] if feedback is None else loads[:, 0] + feedback_force(hist, feedback, 0, loads.shape[-1])


def _normal_equations(net: DynamicNet, trajectories) -> tuple[tuple, tuple]:
    """((G, b, feature means, target means), (feature minima, maxima) (C,) each) of the one-step
    least squares for the linear term: features (teacher-forced loads) against the scaled velocity
    changes, centred; and the features' range over the data (the envelope, ``set_envelope``)."""
    H = net.config.history
    win = _windows(trajectories, H + 1)
    F, A = [], []
    with torch.no_grad():
        for chunk in np.array_split(win, max(1, len(win) // 4096)):
            hist, loads, future, fb = _batch(trajectories, chunk, H, 1)
            f = net.features(hist, _first_loads(hist, loads, fb))
            F.append(f.reshape(len(chunk), -1).double().numpy())
            a = (future[:, 0] - 2 * hist[:, -1] + hist[:, -2]) / torch.where(net.dv_scale > 0, net.dv_scale, 1.0)
            A.append(a.reshape(len(chunk), -1).double().numpy())
    F, A = np.concatenate(F), np.concatenate(A)
    fm, am = F.mean(axis=0), A.mean(axis=0)
    per_node = F.reshape(len(F) * net.n_kept, net.n_in)
    Fc = F - fm
    return (Fc.T @ Fc, Fc.T @ (A - am), fm, am), (per_node.min(axis=0), per_node.max(axis=0))


def damping_prior(net: DynamicNet) -> np.ndarray:
    """The linear map (M C, M 6) the ridge fit is shrunk toward: every moving coordinate of a free
    node relaxes to the reference pose as a critically damped oscillator with time constant
    ``config.prior_tau`` = tau [s] (per step, with r = model_dt / tau: velocity change
    -r^2 x - 2 r v), independently of the others. In a direction the data excite the data decide;
    in one they never excite this prior does. Shrinking toward zero instead (no force) leaves such
    a direction ballistic (a double eigenvalue 1), which a long free run turns into a drift."""
    M, C = net.n_kept, net.n_in
    W0 = np.zeros((M * C, M * 6))
    tau = net.config.prior_tau
    if tau is None:
        return W0
    r = net.config.model_dt / tau
    sx, sv, sa = (getattr(net, k).double().numpy() for k in ("state_scale", "velocity_scale", "dv_scale"))
    for i in np.flatnonzero(~net.held.numpy()):
        for c in np.flatnonzero(sa > 0):
            W0[i * C + c, i * 6 + c] = -r * r * sx[c] / sa[c]
            W0[i * C + 6 + c, i * 6 + c] = -2.0 * r * sv[c] / sa[c]
    return W0


def _penalties(net: DynamicNet, ridge: float) -> np.ndarray:
    """The ridge penalty of each linear input (M C,): ``ridge``, and ``config.load_ridge`` (when
    set) on the load channels."""
    pen = np.full(net.n_kept * net.n_in, float(ridge))
    if net.config.load_ridge is not None:
        cut = load_channels(net.config.history, net.load_width)
        pen.reshape(net.n_kept, net.n_in)[:, cut] = float(net.config.load_ridge)
    return pen


def _ridge_fit(net: DynamicNet, normal: tuple, ridge: float, prior: np.ndarray | None = None) -> None:
    """Set the linear term to the ridge solution of the one-step velocity changes (``normal``:
    ``_normal_equations``; the penalty is ``ridge`` times the mean feature variance, on the loads
    ``config.load_ridge`` times it when set), shrunk toward ``prior`` (default:
    ``damping_prior(net)``)."""
    G, b, fm, am = normal
    prior = damping_prior(net) if prior is None else prior
    if net.contact_columns is not None:         # the linear term does not read the contact inputs
        keep = np.ones((net.n_kept, net.n_in), dtype=bool)
        keep[:, net.contact_feature_columns] = False
        keep = np.flatnonzero(keep)
        G, b, fm, W = G[np.ix_(keep, keep)], b[keep], fm[keep], np.zeros_like(prior)
        lam = _penalties(net, ridge)[keep] * max(float(np.trace(G)) / G.shape[0], _FLOOR)
        W[keep] = np.linalg.solve(G + np.diag(lam), b + lam[:, None] * prior[keep])
        _set_linear(net, W, am - fm @ W[keep])
        return
    lam = _penalties(net, ridge) * max(float(np.trace(G)) / G.shape[0], _FLOOR)
    W = np.linalg.solve(G + np.diag(lam), b + lam[:, None] * prior)
    _set_linear(net, W, am - fm @ W)


def _set_linear(net: DynamicNet, W: np.ndarray, bias: np.ndarray) -> None:
    """The linear term's weights from W (M C, M 6) and its bias (M 6,)."""
    with torch.no_grad():
        net.linear.weight.copy_(torch.as_tensor(W.T, dtype=torch.float32))
        net.linear.bias.copy_(torch.as_tensor(bias, dtype=torch.float32))


def spectral_radius(net: DynamicNet) -> float:
    """Largest |eigenvalue| of the model's state map with no load, linearised at the reference
    (exact for the linear term alone), over the coordinates that move: a fixed node holds its state
    and a channel that never moves in the data (``sa`` 0) keeps its velocity whatever the model,
    so both only add eigenvalues 1 that nothing else feeds (the map is block triangular)."""
    H, M = net.config.history, net.n_kept
    n = H * M * 6
    with torch.no_grad():
        base = torch.zeros(1, H, M, 6)
        basis = torch.eye(n).reshape(n, H, M, 6) * 1e-3
        hist = torch.cat([base, basis])
        loads = torch.zeros(n + 1, M, net.load_width)
        nxt, _ = net.forward(hist, loads)
        J = ((nxt[1:] - nxt[:1]) / 1e-3).reshape(n, M * 6).double().numpy().T   # d next / d hist
    companion = np.zeros((n, n))
    companion[:-M * 6, M * 6:] = np.eye(n - M * 6)       # shift: old states move one slot back
    companion[-M * 6:, :] = J
    moving = ((~net.held.numpy())[:, None] & (net.dv_scale.numpy() > 0)[None, :]).reshape(-1)
    keep = np.flatnonzero(np.tile(moving, H))
    if keep.size == 0:
        return 1.0
    companion = companion[np.ix_(keep, keep)]

    v0 = np.random.default_rng(0).standard_normal(len(keep))   # a fixed start: the same radius (and ridge) every run
    try:   # the largest eigenvalue only (ARPACK): a full eigvals of a few hundred rows is slow on a busy machine
        return float(np.max(np.abs(eigs(companion, k=1, which="LM", return_eigenvectors=False, tol=1e-8, v0=v0))))
    except (ArpackNoConvergence, ArpackError, ValueError):
        return float(np.max(np.abs(np.linalg.eigvals(companion))))


def _fit_linear(net: DynamicNet, normal: tuple, ridge: float, validation=()) -> dict:
    """The ridge fit of the linear term; returns {ridge, linear_radius, ridge_validation}.

    Without ``validation`` the penalty is raised tenfold from ``ridge`` until the linear model is
    stable (spectral radius of its state map at most ``STABLE_RADIUS``). With ``validation``
    trajectories, every penalty of that ladder is tried and the one whose free runs on them have
    the smallest error is kept (``validation_error``): a one-step fit says little about a long free
    run, and with feedback laws (``softrnn.learned.whole.feedback``) the open-loop radius does not
    describe the closed loop either. ``normal``: ``_normal_equations``' first part."""
    lam, tried, prior = ridge, [], damping_prior(net)       # the same prior on every rung
    for _ in range(RIDGE_TRIES):
        _ridge_fit(net, normal, lam, prior)
        rho = spectral_radius(net)
        if not validation:
            if rho <= STABLE_RADIUS:
                return {"ridge": lam, "linear_radius": rho, "ridge_validation": []}
        else:
            tried.append((validation_error(net, validation), lam, rho))
        lam = max(lam * 10.0, 1e-8)
    if not validation:    # still above STABLE_RADIUS: TrainedDynamic.info["linear_stable"] says so
        return {"ridge": lam / 10.0, "linear_radius": rho, "ridge_validation": []}
    err, lam, rho = min(tried, key=lambda r: (r[0], r[1]))
    _ridge_fit(net, normal, lam, prior)
    return {"ridge": lam, "linear_radius": rho,
            "ridge_validation": [[p, None if not math.isfinite(e) else e] for e, p, _ in tried]}


def _unroll_at(config: DynamicConfig, step: int) -> int:
    ramp = max(1, config.steps // 2)
    return 1 + int((config.unroll - 1) * min(1.0, step / ramp))


def _lr_at(config: DynamicConfig, step: int) -> float:
    frac = step / max(1, config.steps)
    return config.lr * (0.05 + 0.95 * 0.5 * (1 + math.cos(math.pi * frac)))


CHECKPOINT_FORMAT = "softrnn-whole-training-checkpoint"
"""The ``format`` entry of a training checkpoint (``_save_checkpoint``)."""

_FIX = RESTART


def _why(err) -> str:
    """The gist of a failed ``torch.load`` on one line: what a weights-only load refused (not
    PyTorch's advice to load the file unsafely), or the error's first 120 characters."""
    text = " ".join(str(err).split())
    if text.startswith("Weights only load failed"):
        found = re.search(r"((?:Unsupported|Trying to load unsupported) .*?)\.?(?: Check the documentation|$)", text)
        return "it holds more than tensors and plain values" + (f": {found.group(1)[:100]}" if found else "")
    return text[:120] or f"{type(err).__name__}: it ends early"


@final
@dataclass(frozen=True)
class TrainingCheckpoint:
    """A whole-model training checkpoint as plain values (``read_checkpoint``).

    Attributes
    ----------
    net : dict
        The network's ``state_dict`` (name: tensor).
    opt : dict
        The optimiser's ``state_dict``.
    gen : torch.Tensor
        The random generator's state (``torch.Generator.get_state``).
    loop : _Loop
        The training loop's state: step, losses, linear fit, validation errors, best weights, average.
    """

    net: dict
    opt: dict
    gen: torch.Tensor
    loop: _Loop


def read_checkpoint(path) -> TrainingCheckpoint:
    """The training checkpoint at ``path`` as plain values, read without running any code of the file.

    Parameters
    ----------
    path : str or Path
        A checkpoint written by ``_save_checkpoint``: a ``torch.save`` file of tensors, dicts,
        lists and numbers, loaded with ``weights_only=True``. One of earlier releases, whose
        ``loop`` entry is a pickled ``_Loop``, is read too (``_Loop`` alone allowed besides).

    Returns
    -------
    TrainingCheckpoint
        ``net``, ``opt`` (state dicts), ``gen`` (the generator's state) and ``loop`` (``_Loop``).

    Raises
    ------
    SoftrnnInputError
        One line naming ``path`` and the fix where the file is damaged or not such a checkpoint.
    """
    path = Path(path)
    try:
        state = load_state(path, allowed=[_Loop])
    except (OSError, EOFError, RuntimeError, ValueError, TypeError, KeyError, AttributeError, ImportError,
            IndexError, pickle.UnpicklingError) as err:
        raise SoftrnnInputError(f"{path}: the training checkpoint is damaged or not one written by softrnn "
                                f"({_why(err)}); {_FIX}") from None
    loop = state.get("loop") if isinstance(state, dict) else None
    if isinstance(loop, dict) and set(loop) == {f.name for f in fields(_Loop)}:
        loop = _Loop(**loop)
    known = isinstance(state, dict) and state.get("format", CHECKPOINT_FORMAT) == CHECKPOINT_FORMAT
    if not (known and isinstance(loop, _Loop) and all(isinstance(state.get(k), dict) for k in ("net", "opt"))
            and isinstance(state.get("gen"), torch.Tensor)):
        raise SoftrnnInputError(f"{path}: is not a softrnn whole-model training checkpoint; {_FIX}")
    return TrainingCheckpoint(net=state["net"], opt=state["opt"], gen=state["gen"], loop=loop)


def _restore_checkpoint(path: Path, net, opt, gen) -> _Loop:
    """Load the checkpoint at ``path`` into ``net``, ``opt`` and ``gen`` and return its loop state; a
    damaged or foreign file is a one-line ``SoftrnnInputError`` naming it.

    Parameters
    ----------
    path : Path
        The checkpoint written by ``_save_checkpoint`` (read by ``read_checkpoint``).
    net : DynamicNet
        The network whose weights are restored.
    opt : torch.optim.Optimizer
        The optimiser whose state is restored.
    gen : torch.Generator
        The generator whose state is restored.
    """
    state = read_checkpoint(path)
    try:
        net.load_state_dict(state.net)
        opt.load_state_dict(state.opt)
        gen.set_state(state.gen)
    except (RuntimeError, ValueError, TypeError, KeyError, IndexError) as err:
        raise SoftrnnInputError(f"{path}: the training checkpoint does not fit this model "
                                f"({' '.join(str(err).split())[:120]}); {_FIX}") from None
    return state.loop


def _save_checkpoint(path: Path, net, opt, gen, loop) -> None:
    """Write the training's state to ``path`` atomically as plain tensors, dicts, lists and numbers
    (``read_checkpoint`` loads it with ``weights_only=True``)."""
    save_state(path, {"format": CHECKPOINT_FORMAT, "net": net.state_dict(), "opt": opt.state_dict(),
                      "gen": gen.get_state(), "loop": {f.name: getattr(loop, f.name) for f in fields(_Loop)}})


def validation_error(net: DynamicNet, validation: list[Trajectory], max_steps: int = VALIDATION_STEPS) -> float:
    """The mean over ``validation`` of each free run's largest position error [m] over the kept
    nodes (from the first full history, up to ``max_steps``); inf where a run diverges."""
    engine, H, errors = engine_of(net), net.config.history, []
    for traj in validation:
        stop = min(traj.n_steps, H + max_steps)
        if stop <= H:
            continue
        try:
            states = free_run(engine, traj, None, H, stop)
        except RolloutDiverged:
            return math.inf
        errors.append(float(np.linalg.norm(states[..., :3] - traj.states[H:stop, :, :3], axis=-1).max()))
    return float(np.mean(errors)) if errors else 0.0


def _optimizer(net: DynamicNet, config: DynamicConfig) -> torch.optim.Optimizer:
    lin = [p for n, p in net.named_parameters() if n.startswith("linear.")]
    rest = [p for n, p in net.named_parameters() if not n.startswith("linear.")]
    groups = [{"params": rest, "scale": 1.0}] if rest else []
    if lin:
        groups.append({"params": lin, "scale": config.linear_lr})
    return torch.optim.Adam(groups, lr=config.lr)


def _loss(net: DynamicNet, trajectories, windows, config: DynamicConfig, gen, step: int) -> torch.Tensor:
    """One batch's unrolled loss: mean squared state error in units of ``sv`` over the free nodes."""
    H, K = config.history, _unroll_at(config, step)
    picks = windows[torch.randint(len(windows), (config.batch,), generator=gen).numpy()]
    n_start = int(round(config.start_fraction * config.batch))
    if n_start:                          # some windows begin where a trajectory begins (from rest)
        starts = np.flatnonzero(windows[:, 1] < START_STEPS)
        picks[:n_start] = windows[starts[torch.randint(len(starts), (n_start,), generator=gen).numpy()]]
    hist, loads, future, feedback = _batch(trajectories, picks, H, K)
    mask = (~net.held).float()[None, None, :, None]
    if config.noise > 0:
        sigma = config.noise * net.velocity_scale * (net.dv_scale > 0) / math.sqrt(H)
        eps = torch.randn(hist.shape, generator=gen) * sigma
        hist = hist + torch.cumsum(eps, dim=1) * mask
    contact = contact_inputs(trajectories, picks)
    err = (net.rollout(hist, loads, feedback, contact) - future) / net.velocity_scale * mask
    return (err ** 2).sum() / (float(mask.sum()) * 6 * config.batch * K)


@dataclass
class _Loop:
    step: int = 0
    losses: list = field(default_factory=list)
    fit: dict = field(default_factory=dict)
    validation: list = field(default_factory=list)
    best: tuple = (math.inf, -1, None)           # (error, step, state dict)
    ema: dict = field(default_factory=dict)      # running average of the weights (config.ema)


def _validate(net, loop: _Loop, validation, shadow=None) -> None:
    """Free runs of the current weights and, with ``shadow`` (a net holding the running average
    ``loop.ema``), of the averaged ones: the better becomes ``loop.best`` if it beats it."""
    if not validation:
        return
    candidates = [(validation_error(net, validation), net)]
    if shadow is not None and loop.ema:
        shadow.load_state_dict(loop.ema)
        candidates.append((validation_error(shadow, validation), shadow))
    err, which = min(candidates, key=lambda c: c[0])
    loop.validation.append((loop.step, err))
    if err < loop.best[0]:
        loop.best = (err, loop.step, {k: v.detach().clone() for k, v in which.state_dict().items()})


def _average(loop: _Loop, net, decay: float) -> None:
    """``loop.ema`` <- decay ``loop.ema`` + (1 - decay) weights (buffers copied)."""
    with torch.no_grad():
        state = net.state_dict()
        if not loop.ema:
            loop.ema = {k: v.detach().clone() for k, v in state.items()}
            return
        for k, v in state.items():
            if v.is_floating_point():
                loop.ema[k].mul_(decay).add_(v.detach(), alpha=1.0 - decay)
            else:
                loop.ema[k].copy_(v)


def _start(net, trajectories, encoding, config, sc, validation=()):
    """``net``'s linear term fitted by ridge from ``config.ridge`` up (its penalty chosen on
    ``validation`` free runs, if any), ``net``'s envelope set to the data's feature range, and the
    linear baseline: (baseline, fit info). The baseline is that same fit unless ``config.ridge`` is
    above ``BASELINE_RIDGE``; then it gets its own ladder from ``BASELINE_RIDGE`` up, so it stays the
    best linear model on validation wherever the network starts (a network may start from a stiffer
    fit without weakening the baseline it is measured against). Fit info: ``ridge``,
    ``linear_radius`` and ``ridge_validation`` of the network's start; ``baseline_ridge``."""
    baseline = DynamicNet.of(linear_config(config), encoding, sc)
    normal, (lo, hi) = _normal_equations(baseline, trajectories)
    cols = net.conv_cols.numpy()
    net.set_envelope(torch.as_tensor(lo[cols], dtype=torch.float32), torch.as_tensor(hi[cols], dtype=torch.float32))
    start = baseline
    if config.load_ridge is not None:       # the network's start has its own penalty on the loads
        start = DynamicNet.of(replace(linear_config(config), load_ridge=config.load_ridge), encoding, sc)
    fit = _fit_linear(start, normal, config.ridge, validation)
    if net.linear is not None:
        net.linear.load_state_dict(start.linear.state_dict())
    fit["baseline_ridge"] = fit["ridge"]
    if config.ridge > BASELINE_RIDGE or start is not baseline:
        fit["baseline_ridge"] = _fit_linear(baseline, normal, BASELINE_RIDGE, validation)["ridge"]
    baseline.eval()
    return baseline, fit


def train_dynamic_model(trajectories: list[Trajectory], encoding: Encoding, config: DynamicConfig, *,
                        validation: list[Trajectory] = (), progress: Progress | None = None, checkpoint=None,
                        threads: int | None = None) -> TrainedDynamic:
    """Train on encoded ``trajectories`` (``Encoding.trajectory``).

    ``validation``: trajectories never trained on; every ``CHECKPOINT_EVERY`` steps (and before the
    first) the model runs free on them and the weights with the smallest largest error are kept
    (model selection on long free runs; without validation the last weights are kept).
    ``checkpoint``: a file path to save to every ``CHECKPOINT_EVERY`` steps and resume from.
    ``threads``: PyTorch's threads while training (None: as set; the caller's count is restored after).
    ``progress(step, steps, {"loss", "unroll"})`` after every step."""
    with torch_threads(threads):
        return _train(trajectories, encoding, config, validation, progress, checkpoint)


def _train(trajectories, encoding, config, validation, progress, checkpoint) -> TrainedDynamic:
    torch.manual_seed(config.seed)
    windows = _windows(trajectories, config.history + config.unroll)
    sc = scales(trajectories, wrench=encoding.drive != "actuation")
    net = DynamicNet.of(config, encoding, sc)
    start = time.perf_counter()
    baseline, fit = _start(net, trajectories, encoding, config, sc, validation)
    opt, gen = _optimizer(net, config), torch.Generator().manual_seed(config.seed)
    loop = _Loop(fit=fit)
    path = Path(checkpoint) if checkpoint is not None else None
    if path is not None and path.is_file():
        loop = _restore_checkpoint(path, net, opt, gen)
    shadow = None
    if config.ema > 0:
        shadow = DynamicNet.of(config, encoding, sc)
    if loop.step == 0:
        _validate(net, loop, validation)
    while loop.step < config.steps:
        for group in opt.param_groups:
            group["lr"] = _lr_at(config, loop.step) * group["scale"]
        loss = _loss(net, trajectories, windows, config, gen, loop.step)
        opt.zero_grad()
        loss.backward()
        torch.nn.utils.clip_grad_norm_(net.parameters(), 1.0)
        opt.step()
        if config.ema > 0:
            _average(loop, net, config.ema)
        loop.step += 1
        loop.losses.append(loss.item())
        if progress is not None:
            progress(loop.step, config.steps, {"loss": loop.losses[-1], "unroll": _unroll_at(config, loop.step - 1)})
        if loop.step % CHECKPOINT_EVERY == 0 or loop.step == config.steps:
            _validate(net, loop, validation, shadow)
            if path is not None:
                _save_checkpoint(path, net, opt, gen, loop)
    if loop.best[2] is not None:
        net.load_state_dict(loop.best[2])
    elif loop.ema:        # no validation: the averaged weights
        net.load_state_dict(loop.ema)
    net.eval()
    info = {"ridge": loop.fit["ridge"], "baseline_ridge": loop.fit.get("baseline_ridge", loop.fit["ridge"]),
            "linear_radius": loop.fit["linear_radius"],
            "ridge_validation": loop.fit.get("ridge_validation", []),
            "linear_stable": bool(loop.fit["linear_radius"] <= STABLE_RADIUS),
            "final_loss": loop.losses[-1] if loop.losses else None,
            "losses": loop.losses[::max(1, len(loop.losses) // 200)], "train_seconds": time.perf_counter() - start,
            "windows": int(len(windows)), "trajectories": len(trajectories),
            "validation": [[s, (None if not math.isfinite(e) else e)] for s, e in loop.validation],
            "selected_step": loop.best[1] if loop.best[2] is not None else loop.step}
    return TrainedDynamic(net=net, encoding=encoding, config=config, linear=baseline, info=info)
