"""The epoch loop of training: Adam on shuffled mini-batches, validation, early stopping, checkpoints and progress.

The learning rate decays along a cosine (``_lr_factor``); after every epoch the validation loss
decides whether the weights are the best so far, and the run is checkpointed (``_checkpoint``).
A run stops after ``TrainConfig.patience`` epochs without a better validation loss and ends with
the best epoch's weights in the module, in eval mode.
"""

from __future__ import annotations

import math
import time
from contextlib import contextmanager

import torch

from ...errors import SoftrnnInputError
from ...progress import Progress
from ..checkpoints import Checkpoint
from ..threads import torch_threads
from .model import ModelConfig, NodeLSTM
from .normalizer import Normalizer


@contextmanager
def torch_settings(threads: int):
    """Deterministic algorithms and a fixed thread count inside, the caller's settings after."""
    old_det = torch.are_deterministic_algorithms_enabled()
    old_warn = torch.is_deterministic_algorithms_warn_only_enabled()
    torch.use_deterministic_algorithms(True)
    try:
        with torch_threads(threads):
            yield
    finally:
        torch.use_deterministic_algorithms(old_det, warn_only=old_warn)


def new_module(config: ModelConfig, normalizer: Normalizer, seed: int) -> NodeLSTM:
    """A network of ``config`` with initial weights drawn from ``seed`` (the global torch random
    state is left as it was) and ``normalizer`` embedded."""
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(seed)
        module = NodeLSTM(config)
    module.set_normalizer(normalizer)
    return module


def _lr_factor(epoch: int, train) -> float:
    """Cosine decay from 1 at the first epoch to final_lr_fraction at the last."""
    if train.epochs <= 1:
        return 1.0
    f = train.final_lr_fraction
    return f + (1.0 - f) * 0.5 * (1.0 + math.cos(math.pi * epoch / (train.epochs - 1)))


def _clone_state(module: torch.nn.Module) -> dict:
    return {k: v.detach().clone() for k, v in module.state_dict().items()}


def train_epochs(module: NodeLSTM, objective, fit: tuple, validation: tuple, train, checkpoint: Checkpoint, *,
                 resume: bool, progress: Progress | None = None, start: dict | None = None) -> dict:
    """Train ``module`` on the ``fit`` tensors (poses, wrenches, targets) with the loss ``objective``
    (``_losses``) until ``train.epochs`` (a ``TrainConfig``) or early stopping, continuing from
    ``checkpoint`` when ``resume`` and it exists. Leaves the best validation epoch's weights in
    ``module``, in eval mode, and returns the loop's state: ``epoch`` (epochs run),
    ``best_validation_loss``, ``best_epoch``, ``bad_epochs`` and ``history`` (per epoch: ``epoch``,
    ``loss``, ``validation_loss``, ``learning_rate``, ``seconds``). ``progress`` is that of
    ``train_node_model``. ``start``: the state to go on from (``_checkpoint.finished_state`` of a
    finished model whose weights ``module`` holds), with a new optimiser and the shuffling seeded
    by ``train.seed`` plus the epochs already run."""
    optimizer = torch.optim.Adam(module.parameters(), lr=train.learning_rate)
    generator = torch.Generator().manual_seed(train.seed + (start["epoch"] if start else 0))
    state = {"epoch": 0, "best_validation_loss": math.inf, "best_epoch": 0, "bad_epochs": 0, "history": []}
    if start:
        state.update(start, history=list(start["history"]))
    best = _clone_state(module)
    if resume and checkpoint.path.exists():
        best = checkpoint.restore(module, optimizer, generator, state)
    n_batches = math.ceil(fit[0].shape[0] / train.batch_size)
    total = n_batches * train.epochs
    for epoch in range(state["epoch"], train.epochs):
        if state["bad_epochs"] >= train.patience:
            break
        e0 = time.perf_counter()
        lr = train.learning_rate * _lr_factor(epoch, train)
        for group in optimizer.param_groups:
            group["lr"] = lr
        report = _batch_progress(progress, state, train, epoch, n_batches, total)
        running = _one_epoch(module, objective, optimizer, generator, fit, train.batch_size, report)
        val_loss = _validate(module, objective, validation, train, epoch)
        if val_loss < state["best_validation_loss"]:
            state.update(best_validation_loss=val_loss, best_epoch=epoch + 1, bad_epochs=0)
            best = _clone_state(module)
        else:
            state["bad_epochs"] += 1
        state["epoch"] = epoch + 1
        state["history"].append({"epoch": epoch + 1, "loss": running, "validation_loss": val_loss,
                                 "learning_rate": lr, "seconds": time.perf_counter() - e0})
        checkpoint.save(module, optimizer, generator, state, best)
        if progress is not None:
            progress((epoch + 1) * n_batches, total,
                     {"epoch": epoch + 1, "epochs": train.epochs, "loss": running, "validation_loss": val_loss,
                      "best_validation_loss": state["best_validation_loss"]})
    if progress is not None:
        progress(total, total, {"epoch": state["epoch"], "epochs": train.epochs, "done": True,
                                "best_validation_loss": state["best_validation_loss"]})
    module.load_state_dict(best)
    module.eval()
    return state


def _one_epoch(module: NodeLSTM, objective, optimizer, generator, fit: tuple, batch_size: int, report) -> float:
    """One pass over the shuffled ``fit`` tensors in Adam steps of ``batch_size`` windows;
    ``report(b, running)`` after batch b. Returns the running mean of the batch losses."""
    poses, wrenches, targets = fit
    M = poses.shape[0]
    module.train()
    perm = torch.randperm(M, generator=generator)                        # (M,)
    running = 0.0
    for b in range(math.ceil(M / batch_size)):
        idx = perm[b * batch_size:(b + 1) * batch_size]                  # (b,)
        loss = objective.loss(module, poses[idx], wrenches[idx], targets[idx], generator)
        optimizer.zero_grad(set_to_none=True)
        loss.backward()
        optimizer.step()
        running += (loss.detach().item() - running) / (b + 1)
        report(b, running)
    return running


def _batch_progress(progress, state: dict, train, epoch: int, n_batches: int, total: int):
    """``report(b, running)`` for ``_one_epoch``: calls ``progress`` (None: nothing) with the
    batches done over all epochs and this epoch's running loss, and from the end of the first
    epoch the last and best validation losses."""
    def report(b: int, running: float) -> None:
        if progress is None:
            return
        info = {"epoch": epoch + 1, "epochs": train.epochs, "loss": running}
        if state["history"]:
            info["validation_loss"] = state["history"][-1]["validation_loss"]
            info["best_validation_loss"] = state["best_validation_loss"]
        progress(epoch * n_batches + b + 1, total, info)

    return report


def _validate(module: NodeLSTM, objective, validation: tuple, train, epoch: int) -> float:
    """The validation loss after ``epoch``; a non-finite one (training diverged) is an error."""
    val_loss = objective.evaluate(module, *validation)
    if not math.isfinite(val_loss):
        raise SoftrnnInputError(f"learning_rate={train.learning_rate!r} is invalid: training diverged "
                                f"(validation loss {val_loss} at epoch {epoch + 1}); use a smaller "
                                f"learning rate")
    return val_loss
