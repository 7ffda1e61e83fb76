"""The one check of a span of predicted samples (or model steps), shared by both kinds of learned
model: a span must leave room for the history before it, lie inside the record, and (for a
whole-manipulator model's test span) lie beyond the samples the model was trained on.

Each caller keeps its own words for the errors (``SpanWording``); the rules are written once here.
Errors are one-line ``SoftrnnInputError`` (``softrnn.errors.bad``). NumPy only.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import final

from ..errors import SoftrnnInputError, bad, is_int


@final
@dataclass(frozen=True)
class SpanWording:
    """How a span check words what it expected, as ``str.format`` templates."""

    start: str
    """For a bad ``start``; fields ``lo``, ``hi`` (the allowed range) and ``history``."""
    stop: str
    """For a bad ``stop``; fields ``lo``, ``hi``, ``start`` and ``targets``."""


WINDOWS = SpanWording(
    start="a sample index in {lo}..{hi}: the history = {history} samples before it are the first window",
    stop="a sample index in {lo}..{hi} (at least {targets} predicted sample(s) after start={start})")
"""The baselines' wording (``softrnn.learned.baselines``)."""

SEEDS = SpanWording(
    start="a sample index in [{lo}, {hi}]: the {history} samples before it seed the history",
    stop="a sample index in [{lo}, {hi}] (after start={start})")
"""A node-model rollout's wording (``softrnn.learned.node.rollout``)."""

LONGER_OR_SHORTER = "use a longer record or a shorter history"
"""``check_length``'s advice where the history can be changed."""


def check_length(n_samples: int, history: int, where: str = "the data set", advice: str = LONGER_OR_SHORTER) -> None:
    """A record of ``n_samples`` holds the ``history`` samples and one to predict, else a one-line
    SoftrnnInputError naming ``where`` and giving ``advice``."""
    if n_samples <= history:
        raise SoftrnnInputError(
            f"{where} has {n_samples} samples but the model's history is {history}: it needs at least "
            f"{history + 1} (the history and one sample to predict); {advice}")


def check_span(n_samples: int, history: int, start, stop, *, targets: int = 1,
               wording: SpanWording = WINDOWS) -> tuple[int, int]:
    """Validated (start, stop) of predicted samples [start, stop): integers, ``history`` samples
    before ``start`` (history <= start < n_samples) and at least ``targets`` samples up to
    ``stop`` <= n_samples; errors worded by ``wording``."""
    for name, value in (("start", start), ("stop", stop)):
        if not is_int(value):
            raise bad(name, value, "a sample index (integer)")
    start, stop = int(start), int(stop)
    if not history <= start < n_samples:
        raise bad("start", start, wording.start.format(lo=history, hi=n_samples - 1, history=history))
    if not start + targets <= stop <= n_samples:
        raise bad("stop", stop, wording.stop.format(lo=start + targets, hi=n_samples, start=start, targets=targets))
    return start, stop


def check_fit_span(n_samples: int, history: int, start, stop, targets: int) -> tuple[int, int]:
    """Validated training span [start, stop) of a fitted baseline: sample indices in 0..n_samples
    holding ``history`` + ``targets`` samples at least."""
    for name, value in (("start", start), ("stop", stop)):
        if not is_int(value) or not 0 <= value <= n_samples:
            raise bad(name, value, f"a sample index in 0..{n_samples}")
    need = history + targets
    if stop - start < need:
        why = "a target to fit and one to choose alpha on" if targets > 1 else "one target"
        raise bad("stop", stop, f"a training span [start, stop) = [{start}, {stop}) of at least history + "
                                f"{targets} = {need} samples ({why}); use a longer span or a shorter history")
    return int(start), int(stop)


def check_step_start(start: int, history: int, stop: int) -> int:
    """A free run's first model step: the last of its ``history`` seed states, with one step to
    predict before ``stop`` (history - 1 <= start <= stop - 2)."""
    if start < history - 1 or start >= stop - 1:
        raise bad("start", start, f"a model step in [{history - 1}, {stop - 2}] (history {history}, {stop} steps)")
    return start


def start_of_test_span(first: int, n_steps: int, fraction: float) -> int:
    """The first model step of a test span that starts at ``fraction`` of a trajectory of
    ``n_steps`` model steps, and not before step ``first`` (where every predictor can start)."""
    return max(first, int(round(fraction * (n_steps - 1))))


def check_beyond_trained(start: int, stride: int, trained_stop: int, n_steps: int, *, fraction: float,
                         path) -> None:
    """The first predicted state of a test span from model step ``start`` (every ``stride``-th
    sample) lies beyond the trained samples 0 .. ``trained_stop`` - 1, else a one-line error on
    ``--test-start`` naming ``path`` and the smallest fraction that would do."""
    if (start + 1) * stride < trained_stop:
        first = (-(-trained_stop // stride) - 1) / max(1, n_steps - 1)   # first start whose next state is unseen
        raise bad("--test-start", fraction, f"a start after the trained part of {path} (its first "
                                            f"{trained_stop} samples): a fraction >= {first:.3g}")
