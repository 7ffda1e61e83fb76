"""The trials of a fit: ``run_trial`` (one simulation, its failure caught), ``InProcess`` (runs a batch
of them in this process) and ``_Trials`` (every trial's prediction, from memory, the resume folder or
a batch of simulations)."""

from __future__ import annotations

import hashlib
import io
from pathlib import Path

import numpy as np

from ..errors import SimulationError, SoftrnnInputError
from ..files import atomic_write_bytes, atomic_write_text


class InProcess:
    """Runs a fit's simulations one after the other in this process (the default evaluator; a
    ``softrnn.calibration.parallel.Evaluator`` runs them on Dask)."""

    workers = 1

    def map(self, fn, model, values: list) -> list:
        """[fn(model, v) for v in values], in order."""
        return [fn(model, v) for v in values]


def run_trial(model, values: tuple) -> tuple:
    """(prediction or None, message): ``model(values)``, with a failure caught (runs on a worker)."""
    try:
        pred = np.asarray(model(tuple(float(v) for v in values)), dtype=np.float64).ravel()
    except (SimulationError, FloatingPointError, ZeroDivisionError) as err:
        return None, str(err).splitlines()[0] if str(err) else type(err).__name__
    except SoftrnnInputError as err:          # e.g. a trial value the model's own checks refuse
        return None, str(err)
    if not np.all(np.isfinite(pred)):
        return None, "the prediction is not finite"
    return pred, ""


class _Trials:
    """The predictions of every x tried, from memory, the cache folder or a batch of simulations."""

    def __init__(self, model, parameters, evaluator, cache_dir, fingerprint: str, progress, budget: int):
        self.model, self.parameters, self.evaluator = model, parameters, evaluator
        self.cache_dir = None if cache_dir is None else Path(cache_dir)
        self.fingerprint = fingerprint
        self.progress, self.budget = progress, budget
        self.names = tuple(p.name for p in parameters)
        self.memory: dict = {}            # the most recent trials (a bounded number, oldest dropped first)
        self.kept: dict = {}              # trials kept for the whole fit (the start)
        self.held: dict = {}              # the best point's trials (replaced when a better one comes)
        self.limit = 4 * (len(parameters) + 1)
        self.trials = self.failed = self.cached = 0
        self.last_message = ""

    def keep(self, x) -> None:
        """Hold the trial of ``x`` for the whole fit (the memory forgets old trials)."""
        key = np.asarray(x, np.float64).tobytes()
        self.kept[key] = self.memory[key]

    def hold(self, points) -> None:
        """Hold the trials of ``points`` (those in memory) until the next call."""
        keys = (np.asarray(x, np.float64).tobytes() for x in points)
        self.held = {k: self.memory[k] for k in keys if k in self.memory}

    def values(self, x: np.ndarray) -> tuple:
        return tuple(p.from_x(float(v)) for p, v in zip(self.parameters, x))

    def _file(self, key: bytes) -> Path:
        digest = hashlib.sha256(self.fingerprint.encode() + key).hexdigest()[:24]
        return self.cache_dir / f"trial-{digest}.npy"

    def _from_cache(self, key: bytes):
        if self.cache_dir is None:
            return False, None
        path = self._file(key)
        failed = path.with_suffix(".failed")
        if failed.exists():
            return True, (None, failed.read_text(encoding="utf-8"))
        if path.exists():
            try:
                return True, (np.load(path), "")
            except (OSError, ValueError):
                path.unlink(missing_ok=True)
        return False, None

    def _to_cache(self, key: bytes, pred, message: str) -> None:
        if self.cache_dir is None:
            return

        self.cache_dir.mkdir(parents=True, exist_ok=True)
        path = self._file(key)
        if pred is None:
            atomic_write_text(path.with_suffix(".failed"), message)
        else:
            buf = io.BytesIO()
            np.save(buf, pred)
            atomic_write_bytes(path, buf.getvalue())

    def get(self, points: list) -> list:
        """The (prediction or None, message) of every x in ``points`` (new ones simulated as one batch)."""
        todo = []
        for x in points:
            key = np.asarray(x, np.float64).tobytes()
            if key in self.memory or key in self.kept or key in self.held or any(key == k for k, _ in todo):
                continue
            hit, entry = self._from_cache(key)
            if hit:
                self.memory[key] = entry
                self.trials += 1
                self.cached += 1
                self.failed += entry[0] is None
            else:
                todo.append((key, x))
        if todo:
            results = self.evaluator.map(run_trial, self.model, [self.values(x) for _, x in todo])
            for (key, _), (pred, message) in zip(todo, results):
                self.memory[key] = (pred, message)
                self._to_cache(key, pred, message)
                self.trials += 1
                if pred is None:
                    self.failed += 1
                    self.last_message = message
        if self.progress is not None:
            self.progress(min(self.trials, self.budget), self.budget, {"trials": self.trials, "failed": self.failed})
        found = [self.kept.get(k) or self.held.get(k) or self.memory[k]
                 for k in (np.asarray(x, np.float64).tobytes() for x in points)]
        while len(self.memory) > max(self.limit, len(points)):
            self.memory.pop(next(iter(self.memory)))
        return found
