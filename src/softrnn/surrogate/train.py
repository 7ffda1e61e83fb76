"""Training a node model: Adam on mini-batches, chronological early stopping, per-epoch checkpoints.

The sample spans (``split``): the first ``train_fraction`` of the samples is the training span, the
rest the test span, which training never reads beyond its metadata. The training span is cut again
chronologically: its last ``validation_fraction`` is the validation span used for early stopping
(the weights of the best validation epoch are kept). Windows never straddle either cut, and the
``Normalizer`` is fitted on the fit span (the training span before the validation cut) alone.

The loss (``rollout_steps`` = K, default 4) runs the model K steps ahead on each training window,
feeding its own predicted node positions back (neighbours and wrenches stay the recorded ones),
and averages the K one-step errors, each measured against the true next position; the validation
loss is the same on the validation span. K = 1 is plain one-step training (the paper's).

Long series are subsampled: when the fit span holds more than ``max_train_windows`` windows, every
``stride``-th window is used (stride = ceil(windows / max_train_windows), the same stride for
validation); consecutive windows at 0.1 ms are nearly identical, so little is lost. The stride is
recorded in the model's meta.json.

Every finished epoch is checkpointed to ``<out_folder>/checkpoint.pt`` (module, optimiser, the
shuffling generator's state, the best weights so far, history); ``resume=True`` continues from it
exactly, so an interrupted run followed by a resumed one gives the same weights as one
uninterrupted run. The finished model replaces the checkpoint (``save_model``).
"""

from __future__ import annotations

import hashlib
import io
import math
import time
from contextlib import contextmanager
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np
import torch

from .. import __version__
from ..errors import SoftrnnInputError, bad
from ..files import atomic_write_bytes
from .artifact import CHECKPOINT, ModelFolderError, NodeModel, check_replaceable, load_model, save_model
from .data import Normalizer, SampleSpec, Windows, make_windows, split
from .model import ModelConfig, NodeLSTM

CHECKPOINT_VERSION = 1
_FIXED = ("pose_features", "wrench_features", "history")


def _is_int(value) -> bool:
    return isinstance(value, (int, np.integer)) and not isinstance(value, bool)


@dataclass(frozen=True, kw_only=True)
class TrainConfig:
    """How a node model is trained.

    Parameters
    ----------
    epochs : int
        Most passes over the training windows (the paper trained 25 epochs).
    batch_size : int
        Windows per Adam step. The paper used 1; 256 trains about 100x faster on a CPU and already
        reaches one-step errors far below the paper's on this project's datasets.
    learning_rate : float
        Adam's initial step size; it decays along a cosine to ``learning_rate * final_lr_fraction``
        over ``epochs``.
    final_lr_fraction : float
        Learning rate at the last epoch relative to the first (1: constant).
    patience : int
        Stop after this many epochs without a better validation loss.
    validation_fraction : float
        Chronologically last fraction of the training span used for early stopping.
    seed : int
        Seeds the initial weights and the shuffling (the same seed gives the same weights).
    max_train_windows : int
        Subsample the training (and validation) windows with a stride above this many (the
        square case's 76,798 fit windows at 0.1 ms get stride 4).
    threads : int
        Torch CPU threads while training (restored afterwards).
    input_noise : float
        Standard deviation of a random offset of the node's own past positions (the same at every
        step of a window; the target stays the true next position), in units of the node's typical
        step; 0: none. Off by default: multi-step training gave steadier rollouts.
    rollout_steps : int
        K, steps of the multi-step loss: the node's predictions are fed back into its next K-1
        windows (neighbours and wrenches recorded) and the loss averages the K one-step errors, each
        against the true next position; 1: plain one-step training. K = 4 kept the free-running
        rollouts of all three paper cases within about 1 mm of the reference over 8,000 steps, at
        about 3x the training time of K = 1 (the models of K = 1 drifted by up to 10 mm).
    """

    epochs: int = 30
    batch_size: int = 256
    learning_rate: float = 2e-3
    final_lr_fraction: float = 0.05
    patience: int = 8
    validation_fraction: float = 0.2
    seed: int = 0
    max_train_windows: int = 25_000
    threads: int = 1
    input_noise: float = 0.0
    rollout_steps: int = 4

    def __post_init__(self):
        for name, low in (("epochs", 1), ("batch_size", 1), ("patience", 1), ("max_train_windows", 1),
                          ("threads", 1), ("seed", 0), ("rollout_steps", 1)):
            value = getattr(self, name)
            if not _is_int(value) or value < low:
                raise bad(name, value, f"an integer >= {low}")
            object.__setattr__(self, name, int(value))
        if isinstance(self.input_noise, bool) or not isinstance(self.input_noise, (int, float, np.floating)) \
                or not 0.0 <= self.input_noise < math.inf:
            raise bad("input_noise", self.input_noise, "a number >= 0 (0: no noise)")
        object.__setattr__(self, "input_noise", float(self.input_noise))
        for name, lo, hi, closed in (("learning_rate", 0.0, math.inf, False), ("final_lr_fraction", 0.0, 1.0, True),
                                     ("validation_fraction", 0.0, 1.0, False)):
            value = getattr(self, name)
            ok = isinstance(value, (int, float, np.floating)) and not isinstance(value, bool) and math.isfinite(value)
            ok = ok and lo < value and (value <= hi if closed else value < hi)
            if not ok:
                raise bad(name, value, f"a number in ({lo:g}, {hi:g}{']' if closed else ')'}")
            object.__setattr__(self, name, float(value))


# ------------------------------------------------------------------------------------------ spans
@dataclass(frozen=True)
class Spans:
    """Sample spans ``range(start, stop)``: fit (normalisation and gradient steps), validation
    (early stopping), test (never read by training); fit + validation = the training span."""

    fit: range
    validation: range
    test: range

    def to_dict(self) -> dict:
        return {name: [r.start, r.stop] for name, r in
                (("fit", self.fit), ("validation", self.validation), ("test", self.test))}


def spans(n_samples: int, spec: SampleSpec, validation_fraction: float) -> Spans:
    """The chronological fit / validation / test spans of ``n_samples`` samples."""
    train_span, test_span = split(n_samples, spec)
    cut = train_span.stop
    vcut = int(math.floor(cut * (1.0 - validation_fraction)))
    need = spec.history + 1
    if min(vcut, cut - vcut) < need:
        raise bad("history", spec.history,
                  f"a history that fits the data: the training span of {cut} samples splits into {vcut} for fitting "
                  f"and {cut - vcut} for validation, and a window needs history + 1 = {need}; use a shorter "
                  f"history or a longer dataset")
    return Spans(fit=range(0, vcut), validation=range(vcut, cut), test=test_span)


def pooled_specs(spec: SampleSpec, pool) -> list[SampleSpec]:
    """The resolved ``spec`` moved to every node of ``pool`` (neighbours at the same offsets from
    the node, as ``rollout.model_inputs`` applies a shared model); None: ``[spec]``."""
    if pool is None:
        return [spec]
    offsets = [a - spec.node for a in spec.neighbours]
    return [replace(spec, node=int(a), neighbours=tuple(int(a) + o for o in offsets)) for a in pool]


def _concat(parts: list[Windows]) -> Windows:
    if len(parts) == 1:
        return parts[0]
    return Windows(poses=np.concatenate([w.poses for w in parts]), wrenches=np.concatenate([w.wrenches for w in parts]),
                   targets=np.concatenate([w.targets for w in parts]), index=np.concatenate([w.index for w in parts]))


def training_windows(dataset, spec: SampleSpec, train: TrainConfig, pool=None) -> tuple[Windows, Windows, Spans, int]:
    """The (subsampled) fit and validation windows of ``dataset`` and the spans and stride used.

    Only samples of the training span are touched: every returned window and target has a sample
    index below ``spans.test.start``. ``pool``: the windows of every node of ``pool`` (the spec
    moved there, ``pooled_specs``) are concatenated, for one model shared by those nodes; the
    stride then applies to the pooled count.
    """
    s = spans(int(np.asarray(dataset.time).shape[0]), spec, train.validation_fraction)
    specs = pooled_specs(spec, pool)
    fit = _concat([make_windows(dataset, sp, s.fit.start, s.fit.stop) for sp in specs])
    val = _concat([make_windows(dataset, sp, s.validation.start, s.validation.stop) for sp in specs])
    stride = max(1, math.ceil(len(fit) / train.max_train_windows))
    if stride > 1:
        fit, val = fit.take(slice(None, None, stride)), val.take(slice(None, None, stride))
    return fit, val, s, stride


# ------------------------------------------------------------------------------------------ helpers
@contextmanager
def _torch_settings(threads: int):
    """Deterministic algorithms and a fixed thread count inside, the caller's settings after."""
    old_threads = torch.get_num_threads()
    old_det = torch.are_deterministic_algorithms_enabled()
    old_warn = torch.is_deterministic_algorithms_warn_only_enabled()
    torch.set_num_threads(threads)
    torch.use_deterministic_algorithms(True)
    try:
        yield
    finally:
        torch.set_num_threads(old_threads)
        torch.use_deterministic_algorithms(old_det, warn_only=old_warn)


def _load_data(dataset_path, spec: SampleSpec, pool=None):
    """(resolved spec, dataset of the window nodes (of every pooled node), source description,
    the pool as absolute node indices or None)."""
    from ..io.dataset import Dataset, read_dataset

    if isinstance(dataset_path, Dataset):
        data, path = dataset_path, None
        head = data
    else:
        path = Path(dataset_path)
        head = read_dataset(path, stop=1)                             # every stored node, one sample
    total = head.attrs.get("n_nodes_total")
    resolved = spec.resolve(head.nodes, n_nodes_total=total)
    pool = _resolve_pool(pool, resolved, head.nodes, total)
    if path is not None:
        need = sorted({a for sp in pooled_specs(resolved, pool) for a in sp.window_nodes})
        data = read_dataset(path, nodes=need)                         # only the windows' columns
    return resolved, data, path, pool


def _resolve_pool(pool, spec: SampleSpec, stored, total) -> tuple[int, ...] | None:
    """Absolute pool nodes, each with its neighbours (at the spec's offsets) stored."""
    if pool is None:
        return None
    if isinstance(pool, (str, bytes)) or not hasattr(pool, "__iter__"):
        raise bad("pool", pool, "a sequence of node indices (the nodes sharing the model)")
    stored_set = {int(a) for a in np.asarray(stored).reshape(-1)}
    n = int(total) if total is not None else max(stored_set) + 1
    out = []
    for a in pool:
        if isinstance(a, bool) or not isinstance(a, (int, np.integer)):
            raise bad("pool", list(pool), "integer node indices")
        out.append(int(a) + n if a < 0 else int(a))
    if not out or len(set(out)) != len(out):
        raise bad("pool", list(pool), "distinct node indices, at least one")
    offsets = [b - spec.node for b in spec.neighbours]
    for a in out:
        missing = [a + o for o in (0, *offsets) if a + o not in stored_set]
        if missing:
            raise bad("pool", f"node {a}", f"nodes whose neighbours at offsets {offsets} are stored (node {missing[0]} "
                                           f"is not); pool interior nodes only, e.g. 1..{n - 2}")
    return tuple(out)


def _scenario_name(attrs: dict, path) -> str | None:
    for key in ("scenario_name", "case"):
        if isinstance(attrs.get(key), str) and attrs[key]:
            return attrs[key]
    text = attrs.get("scenario_text") or ""
    if text:
        import tomllib

        try:
            name = tomllib.loads(text).get("name")
            if isinstance(name, str):
                return name
        except (tomllib.TOMLDecodeError, ValueError):
            pass
    return Path(path).stem if path is not None else None


def _dataset_meta(data, path) -> dict:
    attrs = dict(data.attrs)
    rod = attrs.get("rod") if isinstance(attrs.get("rod"), dict) else None
    return {
        "path": str(path) if path is not None else None,
        "file": Path(path).name if path is not None else None,
        "scenario_name": _scenario_name(attrs, path),
        "n_samples": int(np.asarray(data.time).shape[0]),
        "dt": float(data.dt),
        "rod": rod,
        "rod_length_m": float(rod["length"]) if rod and isinstance(rod.get("length"), (int, float)) else None,
        "units": attrs.get("units"),
        "n_nodes_total": attrs.get("n_nodes_total"),
        "seed": attrs.get("seed"),
        "softrnn_version": attrs.get("softrnn_version"),
        "extra": {k: v for k, v in attrs.items() if k not in (
            "schema_version", "softrnn_version", "units", "rod", "scenario_text", "seed", "dt", "n_nodes_total")},
    }


def _fingerprint(fit: Windows, val: Windows) -> str:
    h = hashlib.sha256()
    for arr in (fit.poses, fit.wrenches, fit.targets, fit.index, val.poses, val.targets, val.index):
        h.update(np.ascontiguousarray(arr).tobytes())
    return h.hexdigest()


def _settings(spec: SampleSpec, config: ModelConfig, train: TrainConfig, fingerprint: str) -> dict:
    """What a checkpoint must match to be resumed (epochs, patience and threads may change)."""
    t = {k: v for k, v in asdict(train).items() if k not in ("epochs", "patience", "threads")}
    return {"spec": spec.to_dict(), "model": config.to_dict(), "train": t, "data": fingerprint}


def _diff(a: dict, b: dict, prefix: str = "") -> str:
    for key in sorted(set(a) | set(b), key=lambda k: (k == "data", k)):   # settings first, data last
        x, y = a.get(key), b.get(key)
        if isinstance(x, dict) and isinstance(y, dict):
            d = _diff(x, y, f"{prefix}{key}.")
            if d:
                return d
        elif x != y:
            if key == "data":
                return "the training data differ"
            return f"{prefix}{key}: {x!r} then, {y!r} now"
    return ""


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


def _clone_state(module: torch.nn.Module) -> dict:
    return {k: v.detach().clone() for k, v in module.state_dict().items()}


# ------------------------------------------------------------------------------------------ train
def train_node_model(dataset_path, spec: SampleSpec, model_config_overrides: dict | None, train: TrainConfig,
                     out_folder, *, resume: bool = False, progress=None, pool=None) -> NodeModel:
    """Train one node's model and save it to ``out_folder``.

    Parameters
    ----------
    dataset_path : str, Path or softrnn.io.Dataset
        The trajectory (only the window nodes' columns are read).
    spec : SampleSpec
        The node, neighbours, history, inputs, wrench and train fraction (resolved here).
    model_config_overrides : dict or None
        ``ModelConfig`` fields other than pose_features, wrench_features and history (which come
        from the spec), e.g. ``{"lstm_units": 64}``.
    train : TrainConfig
    out_folder : str or Path
        The model folder (new, empty, or an earlier model / unfinished training, which is replaced).
    resume : bool
        Continue from ``out_folder/checkpoint.pt`` if present (the settings must match, except
        epochs and patience); a finished model there is loaded and returned as is.
    pool : sequence of int or None
        Beyond the paper: train one model shared by these nodes (their windows pooled, the spec's
        neighbours taken at the same offsets from each; ``Manipulator.of(shared=model,
        shared_nodes=pool)`` applies it). Use ``relative=True`` inputs (``model_config_overrides``)
        so the model does not depend on where a node is; the normaliser is fitted on the pooled
        windows. The model's ``spec.node`` stays the spec's node (it is evaluated there).
    progress : callable or None
        ``progress(done, total, info)`` after every batch: done/total count batches over all epochs,
        ``info`` holds ``epoch``, ``epochs``, ``loss`` (running mean of this epoch), and, from the
        end of the first epoch, ``validation_loss`` and ``best_validation_loss``.

    Returns
    -------
    NodeModel
        The best validation epoch's weights, in eval mode (also saved).
    """
    if not isinstance(spec, SampleSpec):
        raise bad("spec", type(spec).__name__, "a SampleSpec")
    if not isinstance(train, TrainConfig):
        raise bad("train", type(train).__name__, "a TrainConfig")
    overrides = dict(model_config_overrides or {})
    out_folder = Path(out_folder)
    check_replaceable(out_folder)
    t0 = time.perf_counter()
    resolved, data, path, pool = _load_data(dataset_path, spec, pool)
    fit, val, sp, stride = training_windows(data, resolved, train, pool)
    for name in _FIXED:
        if name in overrides and overrides[name] != getattr(resolved, name):
            raise bad(f"model_config_overrides[{name!r}]", overrides[name], "no value: it comes from the spec")
        overrides.pop(name, None)
    try:
        config = ModelConfig(pose_features=resolved.pose_features, wrench_features=resolved.wrench_features,
                             history=resolved.history, **overrides)
    except TypeError as err:
        raise bad("model_config_overrides", sorted(overrides), f"ModelConfig fields ({err})") from None
    normalizer = Normalizer.fit(fit, output=config.output, relative=config.relative, per_node=resolved.per_node)
    settings = _settings(resolved, config, train, _fingerprint(fit, val))
    settings["pool"] = list(pool) if pool is not None else None
    ckpt_path = out_folder / CHECKPOINT

    if resume and not ckpt_path.exists() and (out_folder / "config.json").exists():
        model = load_model(out_folder)
        was = model.meta.get("train_config") if isinstance(model.meta.get("train_config"), dict) else {}
        done = {"spec": model.spec.to_dict(), "model": model.config.to_dict(),
                "train": {k: v for k, v in was.items() if k not in ("epochs", "patience", "threads")},
                "data": model.meta.get("data_fingerprint"), "pool": model.meta.get("pool")}
        why = _diff(done, settings)
        if why:
            raise ModelFolderError(f"{out_folder}: holds a finished model trained with other settings ({why}); "
                                   f"train without --resume to replace it, or choose another folder")
        return model

    def tensors(w: Windows):
        return (torch.from_numpy(normalizer.normalise_poses(w.poses)),                 # (M, H, P)
                torch.from_numpy(normalizer.normalise_wrenches(w.wrenches)),           # (M, H, W)
                torch.from_numpy(normalizer.normalise_targets(w.targets, w.poses)))    # (M, 3)

    K = train.rollout_steps
    if K > 1:
        if config.relative and config.output == "pose":
            raise bad("rollout_steps", K, "1 for a model with relative inputs that predicts the next position "
                                          "itself (output='pose'); or use output='increment'")
        long_spec = replace(resolved, history=resolved.history + K - 1)
        try:
            fit_l, val_l = training_windows(data, long_spec, train, pool)[:2]
        except SoftrnnInputError:
            raise bad("rollout_steps", K, f"fewer steps: history + rollout_steps = {long_spec.history + 1} samples "
                                          f"do not fit the fit and validation spans; use rollout_steps=1 or longer "
                                          f"data") from None
        multi = (_RelativeMultiStep if config.relative else _MultiStep)(normalizer, config, K, train.input_noise)
        fp, fw, fy = multi.tensors(fit_l)
        vp, vw, vy = multi.tensors(val_l)
    else:
        multi = None
        fp, fw, fy = tensors(fit)
        vp, vw, vy = tensors(val)
    noise = _noise_scales(normalizer, resolved, train.input_noise)
    M = fp.shape[0]
    n_batches = math.ceil(M / train.batch_size)

    with _torch_settings(train.threads):
        with torch.random.fork_rng(devices=[]):
            torch.manual_seed(train.seed)
            module = NodeLSTM(config)
        module.set_normalizer(normalizer)
        optimizer = torch.optim.Adam(module.parameters(), lr=train.learning_rate)
        generator = torch.Generator().manual_seed(train.seed)
        state = {"epoch": 0, "best_validation_loss": math.inf, "best_epoch": 0, "bad_epochs": 0, "history": []}
        best = _clone_state(module)
        if resume and ckpt_path.exists():
            best = _restore(ckpt_path, out_folder, settings, module, optimizer, generator, state)

        total = n_batches * train.epochs
        for epoch in range(state["epoch"], train.epochs):
            if state["bad_epochs"] >= train.patience:
                break
            e0 = time.perf_counter()
            lr = train.learning_rate * _lr_factor(epoch, train)
            for group in optimizer.param_groups:
                group["lr"] = lr
            module.train()
            perm = torch.randperm(M, generator=generator)                    # (M,)
            running = 0.0
            for b in range(n_batches):
                idx = perm[b * train.batch_size:(b + 1) * train.batch_size]  # (b,)
                if multi is not None:
                    loss = multi.loss(module, fp[idx], fw[idx], fy[idx], generator)
                else:
                    bp, by = fp[idx], fy[idx]                                # (b, H, P), (b, 3)
                    if train.input_noise > 0:
                        bp, by = _shift_node(bp, by, noise, generator)
                    y = module(bp, fw[idx])                                  # (b, 3)
                    loss = torch.mean((y - by) ** 2)
                optimizer.zero_grad(set_to_none=True)
                loss.backward()
                optimizer.step()
                running += (loss.detach().item() - running) / (b + 1)
                if progress is not None:
                    info = {"epoch": epoch + 1, "epochs": train.epochs, "loss": running}
                    if state["history"]:
                        info["validation_loss"] = state["history"][-1]["validation_loss"]
                        info["best_validation_loss"] = state["best_validation_loss"]
                    progress(epoch * n_batches + b + 1, total, info)
            val_loss = _evaluate(module, vp, vw, vy) if multi is None else multi.evaluate(module, vp, vw, vy)
            if not math.isfinite(val_loss):
                raise SoftrnnInputError(f"learning_rate={train.learning_rate!r} is invalid: training diverged "
                                        f"(validation loss {val_loss} at epoch {epoch + 1}); use a smaller "
                                        f"learning rate")
            if val_loss < state["best_validation_loss"]:
                state.update(best_validation_loss=val_loss, best_epoch=epoch + 1, bad_epochs=0)
                best = _clone_state(module)
            else:
                state["bad_epochs"] += 1
            state["epoch"] = epoch + 1
            state["history"].append({"epoch": epoch + 1, "loss": running, "validation_loss": val_loss,
                                     "learning_rate": lr, "seconds": time.perf_counter() - e0})
            _save_checkpoint(ckpt_path, settings, module, optimizer, generator, state, best)
            if progress is not None:
                progress((epoch + 1) * n_batches, total,
                         {"epoch": epoch + 1, "epochs": train.epochs, "loss": running, "validation_loss": val_loss,
                          "best_validation_loss": state["best_validation_loss"]})
        if progress is not None:
            progress(total, total, {"epoch": state["epoch"], "epochs": train.epochs, "done": True,
                                    "best_validation_loss": state["best_validation_loss"]})
        module.load_state_dict(best)
        module.eval()

    meta = {
        "softrnn_version": __version__,
        "dataset": _dataset_meta(data, path),
        "node": resolved.node,
        "window_nodes": list(resolved.window_nodes),
        "pool": list(pool) if pool is not None else None,
        "spans": sp.to_dict(),
        "train_span": [sp.fit.start, sp.validation.stop],
        "test_span": [sp.test.start, sp.test.stop],
        "stride": stride,
        "train_windows": int(fp.shape[0]),
        "validation_windows": int(vp.shape[0]),
        "train_config": asdict(train),
        "history": state["history"],
        "epochs_run": state["epoch"],
        "early_stopped": state["epoch"] < train.epochs,
        "best_epoch": state["best_epoch"],
        "best_validation_loss": state["best_validation_loss"],
        "train_seconds": sum(h["seconds"] for h in state["history"]),
        "wall_seconds": time.perf_counter() - t0,
        "data_fingerprint": settings["data"],
    }
    model = NodeModel(config=config, spec=resolved, normalizer=normalizer, module=module, meta=meta)
    save_model(out_folder, model)
    return model


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


def _lr_factor(epoch: int, train: TrainConfig) -> float:
    """Cosine decay from 1 at the first epoch to final_lr_fraction at the last."""
    if train.epochs <= 1:
        return 1.0
    f = train.final_lr_fraction
    return f + (1.0 - f) * 0.5 * (1.0 + math.cos(math.pi * epoch / (train.epochs - 1)))


def _save_checkpoint(path: Path, settings: dict, module, optimizer, generator, state: dict, best: dict) -> None:
    buf = io.BytesIO()
    torch.save({"checkpoint_version": CHECKPOINT_VERSION, "softrnn_version": __version__, "settings": settings,
                "module": module.state_dict(), "optimizer": optimizer.state_dict(),
                "generator": generator.get_state(), "state": state, "best": best}, buf)
    atomic_write_bytes(path, buf.getvalue())


def _restore(path: Path, folder: Path, settings: dict, module, optimizer, generator, state: dict) -> dict:
    """Load a checkpoint into the given objects; returns the best weights so far."""
    try:
        ckpt = torch.load(path, map_location="cpu", weights_only=True)
        if not isinstance(ckpt, dict) or ckpt.get("checkpoint_version") != CHECKPOINT_VERSION:
            raise ValueError("not a softrnn training checkpoint of this version")
    except Exception as err:  # noqa: BLE001 - torch raises many types for a corrupt file
        raise ModelFolderError(f"{folder}: {CHECKPOINT} is corrupt ({' '.join(str(err).split())[:160]}); "
                               f"delete it and train without --resume") from None
    why = _diff(ckpt.get("settings", {}), settings)
    if why:
        raise ModelFolderError(f"{folder}: {CHECKPOINT} was written with other settings ({why}); resume with the "
                               f"same settings, or train without --resume to start again")
    try:
        module.load_state_dict(ckpt["module"])
        optimizer.load_state_dict(ckpt["optimizer"])
        generator.set_state(ckpt["generator"])
        state.update(ckpt["state"])
        best = ckpt["best"]
    except (KeyError, RuntimeError, ValueError, TypeError) as err:
        raise ModelFolderError(f"{folder}: {CHECKPOINT} is corrupt ({' '.join(str(err).split())[:160]}); "
                               f"delete it and train without --resume") from None
    return best
