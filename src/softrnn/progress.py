"""The progress protocol: how every long-running part of softrnn (rod runs, sweeps, animations,
training, rollouts, studies, benchmarks, the magnetic experiment, ``softrnn reproduce``) reports
how far it is.

A part that takes a ``progress`` argument calls it as ``progress(done, total)`` after each unit of
its work (a chunk of samples, a trajectory, a batch, a frame...), or as ``progress(done, total,
info)`` when it has details to give: ``info`` is a dict, e.g. training's ``epoch``, ``epochs``,
``loss``, ``validation_loss`` and ``done``, or the magnetic experiment's ``stage``. ``total`` may
change between calls (a new stage starts counting again). The library never prints: the default
is None (silent), and the command line passes a progress bar (``softrnn.cli._progress.Bar``).

A pipeline of several parts (``softrnn reproduce``) takes a ``ProgressFactory`` instead:
``progress_factory(description)`` returns the ``Progress`` for the part so described (e.g.
``"train semicircle"``), one bar per part.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol


class Progress(Protocol):
    """A progress callback: called with ``done`` of ``total`` units of work finished, and with
    ``info`` (a dict of details, or nothing) when the reporting part has any. Every callback accepts
    both forms: give ``info`` the default None."""

    def __call__(self, done: int, total: int, info: dict | None = None) -> None:
        ...


ProgressFactory = Callable[[str], Progress]
"""``progress_factory(description) -> Progress``: a new callback for each part of a pipeline."""


class Ticks:
    """Counts finished units of work: each call ``ticks()`` adds one and reports
    ``progress(done, total)`` (nothing where ``progress`` is None)."""

    def __init__(self, progress: Progress | None, total: int):
        self.progress = progress
        self.total = total
        self.done = 0

    def __call__(self) -> None:
        self.done += 1
        if self.progress is not None:
            self.progress(self.done, self.total)
