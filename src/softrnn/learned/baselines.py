"""Baselines reported beside every learned model: persistence, constant velocity and a linear
autoregressive (ridge) model, one step ahead, free running and by prediction horizon.

House rule: a learned model is always reported beside these baselines and free running, never one
step ahead alone. Persistence is what a model must beat one step ahead at a fine sample interval;
constant velocity is exact for uniform motion; the linear model (``LinearAR``) gets the inputs of
the learned node models (paper Fig. 2B: the last ``history`` samples of the node's and its
neighbours' positions and the node's wrenches) and predicts the increment, so it is exact for a
linear system (a damped mass-spring chain) and strong for small motions of a rod; it lives in
``softrnn.learned.linear`` (and is importable from here).

Arrays are time first, like the data sets (``softrnn.io``): positions ``(T, N, 3)`` [m] of
N stored nodes, called *columns* here (for a ``Dataset`` the order of ``dataset.nodes``); wrenches
``(T, N, W)`` with W = 6 (force [N], then torque [N m]; ``dataset_wrenches``) or W = 3 (force only),
or None. A window ``(H, N, 3)`` holds the H samples before the predicted one, oldest first.

Every baseline is a small final class behind ``AbstractBaseline`` (``history`` and ``step``), so
``one_step``, ``free_run`` and ``horizon_errors`` treat them alike. Both kinds of learned model
use these baselines: the whole-manipulator model (``softrnn.learned.whole``) steps its encoded state
with the same ``Persistence`` and ``ConstantVelocity`` behind ``StateBaseline``. NumPy only: no PyTorch, so the
baselines work without the 'learn' extra. Float64 throughout; fits and predictions are
deterministic (closed-form ridge by one SVD per fit, no random numbers).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Protocol, final, runtime_checkable

import numpy as np

from ..errors import bad, is_int
from ._arrays import _checked, _columns, _history, _indices, _positions, _window, _wrenches
from .horizons import DIVERGED_M, HORIZONS, RolloutDiverged, free_steps
from .linear import ALPHAS as ALPHAS  # re-exported: the linear model's names, where they used to be
from .linear import MAX_MANIPULATOR_FEATURES as MAX_MANIPULATOR_FEATURES
from .linear import MODES as MODES
from .linear import LinearAR, LinearARConfig
from .spans import WINDOWS, check_span, check_step_start

_BATCH = 1024


# ------------------------------------------------------------------------------------- interface
class AbstractBaseline(Protocol):
    """What ``one_step``, ``free_run`` and ``horizon_errors`` need of a predictor."""

    @property
    def history(self) -> int:
        """H, past samples a prediction reads."""

    def step(self, window_positions, window_wrenches=None, next_wrench=None) -> np.ndarray:
        """Next positions (N, 3) [m] from a window (H, N, 3) [m], its wrenches (H, N, W) and the
        wrench at the predicted sample (N, W) (each may carry a leading batch axis B)."""


# ------------------------------------------------------------------------------------- simple baselines
@final
@dataclass(frozen=True)
class Persistence:
    """Next position = current position (history 1); the wrenches are not used."""

    history: int = field(default=1, init=False)

    def step(self, window_positions, window_wrenches=None, next_wrench=None) -> np.ndarray:
        """Positions (N, 3) [m]: the window's last row (``window_positions`` (H, N, 3) [m], or
        (B, H, N, 3) -> (B, N, 3))."""
        return self.advance(_window(window_positions, self.history, None))

    @staticmethod
    def advance(window: np.ndarray) -> np.ndarray:
        """The window's last row, a copy: ``window`` (..., H, N, C) -> (..., N, C), any C (positions,
        or a whole-manipulator model's encoded states); not validated."""
        return window[..., -1, :, :].copy()


@final
@dataclass(frozen=True)
class ConstantVelocity:
    """Next position = current + (current - previous) (history 2); the wrenches are not used."""

    history: int = field(default=2, init=False)

    def step(self, window_positions, window_wrenches=None, next_wrench=None) -> np.ndarray:
        """Positions (N, 3) [m]: 2 r[-1] - r[-2] of the window (``window_positions`` (H, N, 3) [m],
        H >= 2, or (B, H, N, 3) -> (B, N, 3))."""
        return self.advance(_window(window_positions, self.history, None))

    @staticmethod
    def advance(window: np.ndarray) -> np.ndarray:
        """2 r[-1] - r[-2] of ``window`` (..., H, N, C) -> (..., N, C), H >= 2, any C (positions, or a
        whole-manipulator model's encoded states); not validated."""
        return 2.0 * window[..., -1, :, :] - window[..., -2, :, :]


@final
@dataclass(frozen=True)
class StateBaseline:
    """``Persistence`` or ``ConstantVelocity`` stepping a whole-manipulator model's encoded state
    (``softrnn.learned.whole``): a predictor of ``free_run`` over a ``Trajectory``.

    Attributes
    ----------
    baseline : Persistence or ConstantVelocity
        Whose ``advance`` predicts the next state.
    history : int
        Seed states a free run starts from: 2 for both, so every whole-model predictor starts at
        the same model step.
    """

    baseline: Persistence | ConstantVelocity
    history: int = field(default=2, init=False)

    def __post_init__(self):
        if not isinstance(self.baseline, (Persistence, ConstantVelocity)):
            raise bad("baseline", type(self.baseline).__name__, "Persistence() or ConstantVelocity()")

    def step(self, hist, loads=None, memory=None) -> tuple[np.ndarray, None]:
        """(next state (M, C), None): ``hist`` (H, M, C) float64 advanced by the baseline; the loads
        and the memory are not used."""
        return self.baseline.advance(hist), None


# ------------------------------------------------------------------------------------- running
def one_step(baseline: AbstractBaseline, positions, wrenches, start: int, stop: int) -> np.ndarray:
    """One-step-ahead predictions (stop - start, N, 3) [m] of samples ``start .. stop-1``, each from
    the reference window before it (``positions`` (T, N, 3) [m], ``wrenches`` (T, N, W) or None;
    start >= history)."""
    P = _positions("positions", positions)
    Wr = _wrenches("wrenches", wrenches, P.shape[:2], 0)   # any width: the baseline checks its own
    H = _history(baseline.history)
    start, stop = check_span(P.shape[0], H, start, stop, wording=WINDOWS)
    view = np.lib.stride_tricks.sliding_window_view
    win = view(P[start - H:stop - 1], H, axis=0).transpose(0, 3, 1, 2)           # (M, H, N, 3)
    wr = None if Wr is None else view(Wr[start - H:stop - 1], H, axis=0).transpose(0, 3, 1, 2)
    parts = []
    for i in range(0, stop - start, _BATCH):
        sl = slice(i, i + _BATCH)
        pred = baseline.step(win[sl], None if wr is None else wr[sl], None if Wr is None else Wr[start:stop][sl])
        parts.append(_checked(pred, win[sl].shape[:1] + P.shape[1:]))
    return np.concatenate(parts)


@runtime_checkable
class StateTrajectory(Protocol):
    """What ``free_run`` steps a whole-manipulator model over (``learned.whole.encoding.Trajectory``):
    encoded states (S, M, 6) and times (S,) [s], the loads of a step given the run's own history
    (feedback laws applied to it), the prescribed nodes put on their path, and states moved out of
    the data's obstacles."""

    states: np.ndarray
    time: np.ndarray

    def inputs(self, history: np.ndarray, step: int) -> np.ndarray:
        """The loads of model step ``step`` with the feedback laws applied to the run's own
        ``history`` of states."""

    def follow(self, nxt: np.ndarray, last: np.ndarray, loads: np.ndarray) -> np.ndarray:
        """``nxt`` with the prescribed nodes put on their recorded path (in place)."""

    def projected(self, states: np.ndarray) -> np.ndarray:
        """``states`` moved out of the data's obstacles."""


def free_run(baseline: AbstractBaseline, positions, wrenches, start: int, stop: int, *,
             modelled=None) -> np.ndarray:
    """Free-running prediction (stop - start, N, 3) [m] of samples ``start .. stop-1`` (history <=
    start < stop <= T) by the fitted ``baseline`` from the reference ``positions`` (T, N, 3) [m] and
    ``wrenches`` (T, N, W) or None [N, N m]: the window before ``start`` is the reference's, every
    later one holds the baseline's own predictions for the ``modelled`` columns (default every
    column) and the reference for the others; the wrenches are always the reference's. Where
    ``positions`` is a whole-manipulator model's ``Trajectory`` (a ``StateTrajectory``), the
    predictor (a ``DynamicEngine``, ``StateBaseline``, ...) steps its encoded states instead
    (``_free_run_states``; ``wrenches`` None). The loop is ``horizons.free_steps``. A coordinate
    beyond ``DIVERGED_M`` or not finite raises ``RolloutDiverged`` (``node``: the column,
    ``sample``: the row's index, ``states``: the run, NaN from there on)."""
    if isinstance(positions, StateTrajectory):                  # a whole-manipulator model's Trajectory
        return _free_run_states(baseline, positions, int(start), int(stop))
    P = _positions("positions", positions)
    Wr = _wrenches("wrenches", wrenches, P.shape[:2], 0)   # any width: the baseline checks its own
    H = _history(baseline.history)
    start, stop = check_span(P.shape[0], H, start, stop, wording=WINDOWS)
    cols = _columns("modelled", modelled, P.shape[1])
    state = P[start - H:stop].copy()                                            # (H + L, N, 3)
    loads = None if Wr is None else Wr[start - H:stop]
    bad_column = []

    def step(k: int, window: np.ndarray) -> np.ndarray | None:
        pred = baseline.step(window, None if loads is None else loads[k - H:k], None if loads is None else loads[k])
        new = _checked(pred, P.shape[1:])[cols]
        bad_rows = ~(np.isfinite(new).all(axis=1) & (np.abs(new) <= DIVERGED_M).all(axis=1))
        if bad_rows.any():
            bad_column.append(int(cols[np.flatnonzero(bad_rows)[0]]))
            return None
        row = state[k].copy()                  # the reference, for the columns not modelled
        row[cols] = new
        return row

    with np.errstate(under="ignore"):
        k = free_steps(step, state, H)
    if k is not None:
        state[k:] = np.nan
        raise RolloutDiverged(f"the baseline's free run diverged: column {bad_column[0]} left {DIVERGED_M:g} m (or "
                              f"became not finite) at sample {start - H + k}; report it as diverged or use a shorter "
                              "span", node=bad_column[0], sample=start - H + k, time=float("nan"), states=state[H:])
    return state[H:]


def _free_run_states(predictor, traj, start: int, stop: int) -> np.ndarray:
    """``free_run`` of a whole-manipulator ``predictor`` (``history``, ``step(hist, loads, memory)``)
    from the states of ``traj`` before model step ``start`` (history <= start < stop <= S): states
    (stop - start, M, 6) of steps start .. stop-1. The loads are the data's, with the trajectory's
    feedback laws applied to the run's own states (``Trajectory.inputs``); prescribed nodes follow
    their recorded path whatever the predictor (``Trajectory.follow``). The states returned are
    moved out of the data's obstacles (``Trajectory.projected``); the run steps on the unprojected
    ones. A state beyond ``DIVERGED_M`` or not finite raises ``RolloutDiverged`` (``sample``: its step)."""
    H = int(predictor.history)
    check_step_start(start - 1, H, stop)
    state = np.full((H + stop - start,) + traj.states.shape[1:], np.nan)
    state[:H] = traj.states[start - H:start]
    memory, last = None, []

    def step(k: int, hist: np.ndarray) -> np.ndarray | None:
        nonlocal memory
        u = traj.inputs(hist, start - 1 + k - H)
        nxt, memory = predictor.step(hist, u, memory)
        traj.follow(nxt, hist[-1], u)        # prescribed nodes on their path, for a baseline too
        if np.all(np.abs(nxt) < DIVERGED_M):
            return nxt
        last.append(nxt)
        return None

    k = free_steps(step, state, H)
    states = traj.projected(state[H:])
    if k is not None:
        node = int(np.flatnonzero(~np.all(np.abs(last[0]) < DIVERGED_M, axis=-1))[0])
        at = start - H + k
        raise RolloutDiverged(f"the free run diverged: node {node} left {DIVERGED_M:g} m (or became not finite) at "
                              f"model step {at}", node=node, sample=at, time=float(traj.time[at]), states=states)
    return states


def horizon_errors(pred_fn: Callable, positions, wrenches, starts, horizons=HORIZONS, *,
                   stop: int | None = None, nodes=None) -> dict[int, dict]:
    """Free-running errors at ``horizons`` h [samples] (the error at sample start + h - 1) from each of
    ``starts``: ``pred_fn(positions, wrenches, start, stop) -> (stop - start, N, 3)`` [m] is a causal
    predictor seeded from the reference before ``start`` (e.g. ``partial(free_run, baseline)``; it
    may raise ``RolloutDiverged``), ``positions`` (T, N, 3) [m] the reference. A horizon is used
    from a start only where start + h <= ``stop`` (default T); the errors are taken over ``nodes``
    (default every column). Returns {h: {'max_abs_m', 'mean_abs_m': largest and mean |predicted -
    reference| over the nodes, axes and starts [m] (None where a run diverged before h),
    'n_starts', 'diverged': runs that diverged before h}}, for the horizons that fit a start."""
    P = _positions("positions", positions)
    Wr = _wrenches("wrenches", wrenches, P.shape[:2], 0)   # any width: the baseline checks its own
    T = P.shape[0]
    stop = T if stop is None else stop
    if not is_int(stop) or not 1 <= stop <= T:
        raise bad("stop", stop, f"a sample index in 1..{T}")
    starts = _indices("starts", starts, 0, int(stop) - 1)
    hs = sorted(set(_indices("horizons", horizons, 1, None)))
    cols = _columns("nodes", nodes, P.shape[1])
    errors: dict[int, list] = {h: [] for h in hs}
    diverged = dict.fromkeys(hs, 0)
    for s in starts:
        fit = [h for h in hs if s + h <= stop]
        if not fit:
            continue
        run = _run_until_diverged(pred_fn, P, Wr, s, s + fit[-1])
        for h in fit:
            if h <= run.shape[0]:
                errors[h].append(np.abs(run[h - 1, cols] - P[s + h - 1, cols]))
            else:
                diverged[h] += 1
    return {h: _horizon_summary(errors[h], diverged[h]) for h in hs if errors[h] or diverged[h]}



def _run_until_diverged(pred_fn, P, Wr, start: int, stop: int) -> np.ndarray:
    """The rows (L, N, 3) of ``pred_fn``'s run that precede a divergence (all of them if none)."""
    try:
        run = _checked(pred_fn(P, Wr, start, stop), (stop - start,) + P.shape[1:])
    except RolloutDiverged as exc:
        if exc.sample <= start:
            return np.zeros((0,) + P.shape[1:])
        return _run_until_diverged(pred_fn, P, Wr, start, exc.sample)
    ok = np.isfinite(run).all(axis=(1, 2))
    return run if ok.all() else run[:int(np.argmin(ok))]


def _horizon_summary(errors: list, diverged: int) -> dict:
    n = len(errors) + diverged
    if diverged:
        return {"max_abs_m": None, "mean_abs_m": None, "n_starts": n, "diverged": diverged}
    e = np.stack(errors)                                                        # (S, n, 3)
    return {"max_abs_m": float(e.max()), "mean_abs_m": float(e.mean()), "n_starts": n, "diverged": 0}


# ------------------------------------------------------------------------------------- helpers
def dataset_wrenches(dataset, *, torques: bool = True) -> np.ndarray:
    """A ``Dataset``'s wrenches (T, N, 6) float64: forces [N] then torques [N m] (``torques=False``:
    forces only, (T, N, 3)), in the columns of ``dataset.nodes``."""
    forces = np.asarray(dataset.forces, dtype=np.float64)
    if not torques:
        return forces.copy()
    return np.concatenate([forces, np.asarray(dataset.torques, dtype=np.float64)], axis=-1)


def standard_baselines(positions, wrenches, start: int, stop: int, *, config: LinearARConfig | None = None,
                       modelled=None) -> dict[str, AbstractBaseline]:
    """{'persistence', 'constant velocity', 'linear'}: the baselines to report beside a learned
    model, the linear one fitted on the training span ``[start, stop)`` with ``config`` (default
    ``LinearARConfig()``: per node, history 2, the learned models' inputs)."""
    linear = LinearAR.fit(config or LinearARConfig(), positions, wrenches, start, stop, modelled=modelled)
    return {"persistence": Persistence(), "constant velocity": ConstantVelocity(), "linear": linear}


__all__ = ["AbstractBaseline", "ConstantVelocity", "Persistence", "StateBaseline", "dataset_wrenches", "free_run",
           "horizon_errors", "one_step", "standard_baselines"]
