"""Baselines reported beside every learned model: persistence, constant velocity and a linear
autoregressive (ridge) model, one step ahead, free running and by prediction horizon.

House rule: a learned model is always reported beside these baselines and free running, never one
step ahead alone. Persistence is what a model must beat one step ahead at a fine sample interval;
constant velocity is exact for uniform motion; the linear model (``LinearAR``) gets the inputs of
the learned node models (paper Fig. 2B: the last ``history`` samples of the node's and its
neighbours' positions and the node's wrenches) and predicts the increment, so it is exact for a
linear system (a damped mass-spring chain) and strong for small motions of a rod.

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

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Protocol, final

import numpy as np

from ..errors import bad, is_finite_number, is_int
from .horizons import DIVERGED_M, HORIZONS, RolloutDiverged, free_steps
from .spans import WINDOWS, check_fit_span, check_span

MODES = ("node", "manipulator")
"""``LinearAR`` variants: one ridge model per node, or one for the whole manipulator."""

ALPHAS = tuple(float(a) for a in np.logspace(-8, 2, 11))
"""Ridge penalties tried on the validation part of the training span (``LinearARConfig.alphas``)."""

MAX_MANIPULATOR_FEATURES = 4096
"""Most features of the whole-manipulator model (varying node coordinates x history, plus the varying
load components x (history + 1)); a few hundred nodes at history 2."""

STD_RELATIVE_FLOOR = 1e-3
"""Smallest feature standard deviation kept, relative to the largest of its kind (absolute positions,
displacements, wrenches): a nearly constant feature is centred, not blown up from rounding noise."""

_ABSOLUTE, _DISPLACEMENT, _WRENCH = 0, 1, 2
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


# ------------------------------------------------------------------------------------- validation
def _shape_text(value) -> str:
    return f"array of shape {np.shape(value)}"


def _array(name: str, value, ndims: tuple[int, ...], last: tuple[int, ...] | None, expected: str) -> np.ndarray:
    """``value`` as a finite float64 array with one of ``ndims`` and a last axis in ``last`` (None:
    any length >= 1)."""
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise bad(name, type(value).__name__, f"{expected} ({err})") from None
    if arr.ndim not in ndims or (arr.shape[-1] not in last if last is not None else arr.shape[-1] < 1) \
            or 0 in arr.shape[:-1]:
        raise bad(name, _shape_text(arr), expected)
    if not np.isfinite(arr).all():
        raise bad(name, "values with NaN or inf", f"finite values: {expected}")
    return arr


def _positions(name: str, value) -> np.ndarray:
    """(T, N, 3) float64 [m]."""
    return _array(name, value, (3,), (3,), "positions of shape (T, N, 3) in m, T >= 1, N >= 1")


def _wrenches(name: str, value, lead: tuple[int, ...], width: int | None = None) -> np.ndarray | None:
    """None, or (T, N, W) float64 with (T, N) = ``lead``: W = 3 (force) or 6 (force, torque), or
    with ``width`` (a learned model's input II with actuation inputs; 0: any) exactly that."""
    if value is None:
        return None
    if width is None:
        expected = f"None or forces (and torques) of shape {(*lead, 6)} (or {(*lead, 3)}) in N (and N m)"
    else:
        expected = f"None or loads of shape {(*lead, width or 'W')} (forces, torques, actuation inputs)"
    arr = _array(name, value, (len(lead) + 1,), (3, 6) if width is None else ((width,) if width else None), expected)
    if arr.shape[:-1] != tuple(lead):
        raise bad(name, _shape_text(arr), expected)
    return arr


def _columns(name: str, value, n_nodes: int) -> np.ndarray:
    """Column indices (n,) int64, distinct, in [0, n_nodes); None: every column."""
    if value is None:
        return np.arange(n_nodes, dtype=np.int64)
    items = [value] if is_int(value) else list(value) if isinstance(value, (Sequence, np.ndarray)) else None
    if not items or not all(is_int(a) and 0 <= a < n_nodes for a in items) or len(set(items)) != len(items):
        raise bad(name, value, f"None or distinct column indices in 0..{n_nodes - 1} (positions of the nodes "
                               f"in the arrays' node axis)")
    return np.array([int(a) for a in items], dtype=np.int64)


def _history(value) -> int:
    if not is_int(value) or value < 1:
        raise bad("history", value, "an integer >= 1 (past samples per prediction)")
    return int(value)


# ------------------------------------------------------------------------------------- windows
def _window(value, history: int, n_nodes: int | None) -> np.ndarray:
    """Window positions (..., H', N, 3) float64 with H' >= history (and N = ``n_nodes``)."""
    w = _array("window_positions", value, (3, 4), (3,),
               f"positions of shape (H, N, 3) or (B, H, N, 3) in m with H >= history = {history}")
    if w.shape[-3] < history or (n_nodes is not None and w.shape[-2] != n_nodes):
        nodes = "N" if n_nodes is None else str(n_nodes)
        raise bad("window_positions", _shape_text(w), f"shape (H, {nodes}, 3) or (B, H, {nodes}, 3) with "
                                                      f"H >= history = {history}")
    return w


def _window_loads(window_wrenches, next_wrench, shape: tuple[int, ...], width: int, need_next: bool):
    """(window wrenches (..., H', N, W), next wrench (..., N, W) or None) checked against the
    window's ``shape`` and the fitted width ``width``."""
    wr = _wrenches("window_wrenches", window_wrenches, shape[:-1], 0)
    if wr is None or wr.shape[-1] != width:
        got = None if wr is None else _shape_text(wr)
        raise bad("window_wrenches", got, f"wrenches of shape {(*shape[:-1], width)}, the width the model was "
                                          f"fitted with")
    if not need_next:
        return wr, None
    nxt = _wrenches("next_wrench", next_wrench, shape[:-3] + shape[-2:-1], 0)
    if nxt is None or nxt.shape[-1] != width:
        got = None if nxt is None else _shape_text(nxt)
        raise bad("next_wrench", got, f"the wrench at the predicted sample, shape {(*shape[:-3], shape[-2], width)}"
                                      f" (the model was fitted with next_wrench=True)")
    return wr, nxt


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
    (``softrnn.learned.whole``): the predictor interface of ``whole.evaluation.free_run``.

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


# ------------------------------------------------------------------------------------- LinearAR config
@dataclass(frozen=True, kw_only=True)
class LinearARConfig:
    """How a ``LinearAR`` is built and fitted.

    Parameters
    ----------
    history : int
        H, past samples in a window (the learned models' ``history``; paper: 2).
    mode : str
        ``"node"``: one ridge model per modelled node from its own and its neighbours' windows and
        its own wrenches (the paper's node model); ``"manipulator"``: one model of every modelled
        node from every node's window and every varying load (refused above
        ``MAX_MANIPULATOR_FEATURES`` features). Node models are fitted one step ahead, each on
        reference neighbours: free running with the neighbours from the reference they are strong,
        but run together (every node free, a whole-manipulator rollout) they can be unstable where
        one ``"manipulator"`` model is not; report both.
    neighbours : int or tuple of int
        ``"node"`` mode: column offsets of the neighbours (an int r: -r..-1, 1..r; paper: 1), those
        outside the arrays dropped (one neighbour at an end).
    relative : bool
        Positions before the window's last row as displacements from the same node's last position
        (velocity-like), and in ``"node"`` mode the neighbours' last positions relative to the
        node's (strain-like); the node's own last position stays absolute. An invertible linear
        change of the features, so with a tiny ``alpha`` the model is the same; the ridge penalty
        and the standardisation then see the small motions at their own scale.
    next_wrench : bool
        Also use the wrench at the predicted sample (a known input). False gives the learned models'
        inputs exactly.
    wrench_width : int or None
        None: the wrenches have 3 (force) or 6 (force, torque) columns. An int W: they are a node
        model's input II of W columns (its force or wrench, then actuation inputs, the same in every
        column; ``evaluate.node_arrays``).
    alpha : float or None
        Ridge penalty on standardised features, per sample (mean squared error + alpha |w|^2); None:
        the one of ``alphas`` with the smallest one-step error on the last ``validation_fraction``
        of the training targets (ties: the larger alpha).
    alphas : tuple of float
        Candidates for ``alpha=None``.
    validation_fraction : float
        Chronological tail of the training targets held out to choose alpha.
    """

    history: int = 2
    mode: str = "node"
    neighbours: int | tuple[int, ...] = 1
    relative: bool = True
    next_wrench: bool = False
    alpha: float | None = None
    alphas: tuple[float, ...] = ALPHAS
    validation_fraction: float = 0.2
    wrench_width: int | None = None

    def __post_init__(self):
        object.__setattr__(self, "history", _history(self.history))
        if self.wrench_width is not None and not (is_int(self.wrench_width) and self.wrench_width >= 1):
            raise bad("wrench_width", self.wrench_width, "None (3 or 6 wrench columns) or a width >= 1")
        if self.mode not in MODES:
            raise bad("mode", self.mode, "'node' (a model per node) or 'manipulator' (one model of every node)")
        object.__setattr__(self, "neighbours", _offsets(self.neighbours))
        for name in ("relative", "next_wrench"):
            if not isinstance(getattr(self, name), (bool, np.bool_)):
                raise bad(name, getattr(self, name), "true or false")
            object.__setattr__(self, name, bool(getattr(self, name)))
        if self.alpha is not None and not (is_finite_number(self.alpha) and self.alpha > 0):
            raise bad("alpha", self.alpha, "a positive ridge penalty, or None to choose one of alphas")
        alphas = tuple(self.alphas) if isinstance(self.alphas, (Sequence, np.ndarray)) else ()
        if not alphas or not all(is_finite_number(a) and a > 0 for a in alphas):
            raise bad("alphas", self.alphas, "a non-empty sequence of positive ridge penalties")
        object.__setattr__(self, "alphas", tuple(float(a) for a in alphas))
        f = self.validation_fraction
        if isinstance(f, bool) or not isinstance(f, (int, float, np.floating)) or not 0.0 < float(f) < 1.0:
            raise bad("validation_fraction", f, "a fraction strictly between 0 and 1 (e.g. 0.2)")
        object.__setattr__(self, "validation_fraction", float(f))


def _offsets(value) -> tuple[int, ...]:
    if is_int(value) and value >= 0:
        return tuple(range(-int(value), 0)) + tuple(range(1, int(value) + 1))
    items = list(value) if isinstance(value, (Sequence, np.ndarray)) and not isinstance(value, str) else None
    if items is None or not all(is_int(a) and a != 0 for a in items) or len(set(items)) != len(items):
        raise bad("neighbours", value, "a radius r >= 0 (offsets -r..-1, 1..r) or distinct non-zero column offsets")
    return tuple(int(a) for a in items)


# ------------------------------------------------------------------------------------- design
@final
@dataclass(frozen=True, eq=False)
class _Design:
    """Which values form the features of each of G groups (a node in ``"node"`` mode, the whole
    manipulator in ``"manipulator"`` mode), over a window's rows (H, N*3) flattened node-major.

    Features of a group, in order: positions (H rows oldest first x P slots), wrenches (H x Q slots),
    then the next wrench (Q slots, with ``next_wrench``). Invalid (padding) slots are zero.
    """

    history: int
    relative: bool
    next_wrench: bool
    targets: np.ndarray           # (G, D/3) columns each group predicts
    position_slots: np.ndarray    # (G, P) flat index node*3 + axis into a row of positions
    position_refs: np.ndarray     # (G, P) flat index the last row is taken relative to, -1: absolute
    position_valid: np.ndarray    # (G, P) bool
    wrench_slots: np.ndarray      # (G, Q) flat index node*W + component into a row of wrenches
    wrench_valid: np.ndarray      # (G, Q) bool

    @property
    def n_features(self) -> int:
        P, Q = self.position_slots.shape[1], self.wrench_slots.shape[1]
        return self.history * P + (self.history + int(self.next_wrench)) * Q

    def kinds(self) -> np.ndarray:
        """(F,) feature kind: absolute position, displacement or wrench (for the std floors)."""
        P, H = self.position_slots.shape[1], self.history
        rows = np.full((H, P), _DISPLACEMENT if self.relative else _ABSOLUTE)
        rows[-1] = _ABSOLUTE
        return np.concatenate([rows.reshape(-1), np.full(self.n_features - H * P, _WRENCH)])

    def features(self, win, wr, nxt, groups=slice(None)) -> np.ndarray:
        """(B, G', F) features of windows ``win`` (B, H, N*3) [m], ``wr`` (B, H, N*W) or None,
        ``nxt`` (B, N*W) or None, for the groups selected by ``groups``."""
        idx, ref, ok = self.position_slots[groups], self.position_refs[groups], self.position_valid[groups]
        B = win.shape[0]
        x = win[:, :, idx]                                                      # (B, H, G, P)
        if self.relative:
            last = x[:, -1]                                                     # (B, G, P)
            origin = np.where(ref >= 0, win[:, -1][:, np.maximum(ref, 0)], 0.0)   # (B, G, P)
            x = np.concatenate([x[:, :-1] - last[:, None], (last - origin)[:, None]], axis=1)
        x = np.where(ok, x, 0.0)
        parts = [x.transpose(0, 2, 1, 3).reshape(B, idx.shape[0], -1)]          # (B, G, H*P)
        widx, wok = self.wrench_slots[groups], self.wrench_valid[groups]
        if widx.shape[1]:
            w = np.where(wok, wr[:, :, widx], 0.0)                              # (B, H, G, Q)
            parts.append(w.transpose(0, 2, 1, 3).reshape(B, widx.shape[0], -1))  # (B, G, H*Q)
            if self.next_wrench:
                parts.append(np.where(wok, nxt[:, widx], 0.0))                  # (B, G, Q)
        return np.concatenate(parts, axis=2)


def _node_design(config: LinearARConfig, cols: np.ndarray, n_nodes: int, width: int) -> _Design:
    """One group per modelled column: its window (the node, then its neighbours) padded to the
    largest window; its own wrench."""
    windows = [[n] + [n + o for o in config.neighbours if 0 <= n + o < n_nodes] for n in cols]
    K = max(len(w) for w in windows)
    slots = np.zeros((cols.size, K, 3), np.int64)
    refs = np.full((cols.size, K, 3), -1, np.int64)
    valid = np.zeros((cols.size, K, 3), bool)
    for g, w in enumerate(windows):
        slots[g, :len(w)] = np.array(w)[:, None] * 3 + np.arange(3)
        refs[g, 1:len(w)] = w[0] * 3 + np.arange(3)
        valid[g, :len(w)] = True
    wslots = cols[:, None] * width + np.arange(width)                           # (G, W)
    return _Design(history=config.history, relative=config.relative, next_wrench=config.next_wrench,
                   targets=cols[:, None], position_slots=slots.reshape(cols.size, -1),
                   position_refs=refs.reshape(cols.size, -1), position_valid=valid.reshape(cols.size, -1),
                   wrench_slots=wslots, wrench_valid=np.ones(wslots.shape, bool))


def _manipulator_design(config: LinearARConfig, cols: np.ndarray, P: np.ndarray, Wr: np.ndarray | None,
                        start: int, stop: int) -> _Design:
    """One group: every node coordinate and load component that varies over ``[start, stop)``
    (constant ones carry nothing a fit could use). Refused above ``MAX_MANIPULATOR_FEATURES``."""
    T, N = stop - start, P.shape[1]
    moving = np.flatnonzero(np.ptp(P[start:stop].reshape(T, N * 3), axis=0) > 0)
    loaded = (np.zeros(0, np.int64) if Wr is None
              else np.flatnonzero(np.ptp(Wr[start:stop].reshape(T, -1), axis=0) > 0))
    H = config.history
    F = H * moving.size + (H + int(config.next_wrench)) * loaded.size
    if F > MAX_MANIPULATOR_FEATURES:
        raise bad("mode", "manipulator", f"at most {MAX_MANIPULATOR_FEATURES} features, but {moving.size} moving "
                                         f"node coordinates x history {H} plus {loaded.size} load components give "
                                         f"{F}; use mode='node', fewer nodes or a shorter history")
    return _Design(history=H, relative=config.relative, next_wrench=config.next_wrench, targets=cols[None, :],
                   position_slots=moving[None, :], position_refs=np.full((1, moving.size), -1, np.int64),
                   position_valid=np.ones((1, moving.size), bool), wrench_slots=loaded[None, :],
                   wrench_valid=np.ones((1, loaded.size), bool))


# ------------------------------------------------------------------------------------- ridge
def _std(X: np.ndarray, kinds: np.ndarray) -> np.ndarray:
    """(F,) standard deviations floored at ``STD_RELATIVE_FLOOR`` x the largest of their kind."""
    s = X.std(axis=0)
    for kind in np.unique(kinds):
        mine = kinds == kind
        s[mine] = np.maximum(s[mine], STD_RELATIVE_FLOOR * s[mine].max())
    return s


def _ridge_solutions(X, Y, kinds, alphas) -> list[tuple[np.ndarray, np.ndarray]]:
    """Ridge fits of targets ``Y`` (M, D) on features ``X`` (M, F), one (weights (F, D), intercept
    (D,)) in physical units per alpha: minimise mean |Z w - y|^2 + alpha |w|^2 over standardised
    features Z, by one SVD. Features constant over the M rows get weight 0."""
    M, F = X.shape
    keep = np.ptp(X, axis=0) > 0
    ym = Y.mean(axis=0)
    if not keep.any():
        return [(np.zeros((F, Y.shape[1])), ym.copy()) for _ in alphas]
    Xk = X[:, keep]
    mu, sd = Xk.mean(axis=0), _std(Xk, kinds[keep])
    U, s, Vt = np.linalg.svd((Xk - mu) / sd, full_matrices=False)
    UtY = U.T @ (Y - ym)                                                        # (r, D)
    out = []
    for alpha in alphas:
        wz = Vt.T @ ((s / (s * s + alpha * M))[:, None] * UtY)                   # (Fk, D) standardised
        w = np.zeros((F, Y.shape[1]))
        w[keep] = wz / sd[:, None]
        out.append((w, ym - mu @ w[keep]))
    return out


def _ridge(X, Y, kinds, config: LinearARConfig) -> tuple[np.ndarray, np.ndarray, float]:
    """(weights (F, D), intercept (D,), alpha): ``config.alpha``, or the candidate with the
    smallest one-step error on the chronological validation tail (ties: the larger alpha)."""
    alpha = config.alpha
    if alpha is None:
        n_val = max(1, int(round(config.validation_fraction * X.shape[0])))
        fits = _ridge_solutions(X[:-n_val], Y[:-n_val], kinds, config.alphas)
        err = np.array([np.mean((X[-n_val:] @ w + b - Y[-n_val:]) ** 2) for w, b in fits])
        best = np.flatnonzero(err <= err.min() * (1.0 + 1e-9))
        alpha = config.alphas[int(best[np.argmax(np.asarray(config.alphas)[best])])]
    w, b = _ridge_solutions(X, Y, kinds, (alpha,))[0]
    return w, b, float(alpha)


def _rows(P: np.ndarray, Wr: np.ndarray | None, start: int, stop: int, H: int):
    """Windows of every target k in ``[start+H, stop)``: positions (M, H, N*3) (a strided view),
    wrenches (M, H, N*W) and next wrenches (M, N*W), or None."""
    T, N = P.shape[0], P.shape[1]
    flat = P.reshape(T, N * 3)
    win = np.lib.stride_tricks.sliding_window_view(flat[start:stop - 1], H, axis=0).transpose(0, 2, 1)
    if Wr is None:
        return win, None, None
    wflat = Wr.reshape(T, -1)
    wr = np.lib.stride_tricks.sliding_window_view(wflat[start:stop - 1], H, axis=0).transpose(0, 2, 1)
    return win, wr, wflat[start + H:stop]


# ------------------------------------------------------------------------------------- LinearAR
@final
@dataclass(frozen=True, eq=False)
class LinearAR:
    """A linear autoregressive model of the increment, fitted by ridge regression (``fit``).

    For a group (a node, or the whole manipulator) the predicted increment r[k] - r[k-1] of its
    nodes is ``features @ weights[g] + intercept[g]``; the features of sample k are the window rows
    k-H .. k-1 of positions (see ``LinearARConfig.relative``) and wrenches, and optionally the
    wrench at k (``feature_names`` lists them). Columns not in ``modelled`` are returned at their
    last window position (pass ``modelled=model.modelled`` to ``free_run``).

    Attributes
    ----------
    config : LinearARConfig
        The configuration it was fitted with.
    n_nodes : int
        N, columns of the arrays it was fitted on.
    wrench_width : int
        W of the fitted wrenches (0 without wrenches, 3 or 6).
    modelled : tuple of int
        The predicted columns, in group order.
    weights : ndarray (G, F, D) float64
        Coefficients in physical units (m per m, m per N, m per N m); D = 3 per node (node mode)
        or 3 x modelled nodes (manipulator mode, node-major).
    intercept : ndarray (G, D) float64
        [m].
    alpha : ndarray (G,) float64
        The ridge penalty of each group.
    """

    config: LinearARConfig
    n_nodes: int
    wrench_width: int
    modelled: tuple[int, ...]
    design: _Design
    weights: np.ndarray
    intercept: np.ndarray
    alpha: np.ndarray

    @property
    def history(self) -> int:
        """H, past samples a prediction reads."""
        return self.config.history

    @classmethod
    def fit(cls, config: LinearARConfig, positions, wrenches=None, start: int = 0, stop: int | None = None, *,
            modelled=None) -> LinearAR:
        """Fit on the samples ``[start, stop)`` (every window and target inside the span, like
        ``data.make_windows``; pass the learned model's training span, ``data.split``).

        Parameters
        ----------
        config : LinearARConfig
            How it is built and fitted.
        positions : array-like (T, N, 3)
            Reference positions [m].
        wrenches : array-like (T, N, 6), (T, N, 3) or None
            Forces [N] (and torques [N m]) applied at the nodes.
        start, stop : int
            Training span (default stop: T). It needs history + 1 samples, history + 2 when alpha
            is chosen on the validation tail.
        modelled : sequence of int or None
            Columns to predict (default: every column).

        Raises
        ------
        SoftrnnInputError
            One line naming the argument: shapes, a span that does not fit, or too large a
            whole-manipulator model.
        """
        if not isinstance(config, LinearARConfig):
            raise bad("config", type(config).__name__, "a LinearARConfig")
        P = _positions("positions", positions)
        Wr = _wrenches("wrenches", wrenches, P.shape[:2], config.wrench_width)
        T, N, H = P.shape[0], P.shape[1], config.history
        start, stop = check_fit_span(T, H, start, T if stop is None else stop, 1 if config.alpha is not None else 2)
        cols = _columns("modelled", modelled, N)
        width = 0 if Wr is None else Wr.shape[-1]
        design = (_node_design(config, cols, N, width) if config.mode == "node"
                  else _manipulator_design(config, cols, P, Wr, start, stop))
        with np.errstate(under="ignore"):
            fits = cls._fit_groups(config, design, P, Wr, start, stop)
        return cls(config=config, n_nodes=N, wrench_width=width, modelled=tuple(int(c) for c in cols),
                   design=design, weights=np.stack([f[0] for f in fits]), intercept=np.stack([f[1] for f in fits]),
                   alpha=np.array([f[2] for f in fits]))

    @staticmethod
    def _fit_groups(config, design: _Design, P, Wr, start: int, stop: int) -> list:
        """[(weights (F, D), intercept (D,), alpha)] per group."""
        H = config.history
        win, wr, nxt = _rows(P, Wr, start, stop, H)
        kinds = design.kinds()
        fits = []
        for g, cols in enumerate(design.targets):
            X = design.features(win, wr, nxt, slice(g, g + 1))[:, 0]               # (M, F)
            Y = (P[start + H:stop, cols] - P[start + H - 1:stop - 1, cols]).reshape(X.shape[0], -1)  # (M, D)
            fits.append(_ridge(X, Y, kinds, config))
        return fits

    def step(self, window_positions, window_wrenches=None, next_wrench=None) -> np.ndarray:
        """Next positions (N, 3) [m] from ``window_positions`` (H', N, 3) [m] (H' >= history; the last
        ``history`` rows are used), ``window_wrenches`` (H', N, W) [N, N m] (ignored by a model
        fitted without wrenches) and ``next_wrench`` (N, W) (used with ``next_wrench=True``). A
        leading batch axis B on every argument gives (B, N, 3)."""
        H, N = self.history, self.n_nodes
        w = _window(window_positions, H, N)
        batch = w.shape[:-3]
        B = int(np.prod(batch, dtype=np.int64))
        win = w[..., -H:, :, :].reshape(B, H, N * 3)
        wr = nxt = None
        if self.wrench_width:
            wr, nxt = _window_loads(window_wrenches, next_wrench, w.shape, self.wrench_width,
                                    self.config.next_wrench)
            wr = wr[..., -H:, :, :].reshape(B, H, -1)
            nxt = None if nxt is None else nxt.reshape(B, -1)
        with np.errstate(under="ignore"):
            X = self.design.features(win, wr, nxt)                                 # (B, G, F)
            inc = np.matmul(X.transpose(1, 0, 2), self.weights) + self.intercept[:, None]  # (G, B, D)
        out = win[:, -1].reshape(B, N, 3).copy()
        out[:, list(self.modelled)] += inc.transpose(1, 0, 2).reshape(B, len(self.modelled), 3)
        return out.reshape(*batch, N, 3)

    def coefficients(self, column: int) -> tuple[np.ndarray, np.ndarray]:
        """(weights (F, 3), intercept (3,)) of the increment of modelled ``column``, in physical
        units; rows follow ``feature_names(column)``."""
        if column not in self.modelled:
            raise bad("column", column, f"a modelled column: {list(self.modelled)}")
        i = self.modelled.index(column)
        if self.config.mode == "node":
            return self.weights[i].copy(), self.intercept[i].copy()
        return self.weights[0][:, 3 * i:3 * i + 3].copy(), self.intercept[0][3 * i:3 * i + 3].copy()

    def feature_names(self, column: int) -> list[str]:
        """The F feature names of the group predicting ``column``: ``'position k-1 col 4 x'``,
        ``'displacement k-2 col 4 x'`` (col 4's position at k-1 minus that at k-2), ``'position
        k-1 col 5 x - col 4 x'`` (a neighbour relative to the node), ``'force k-1 col 4 z'``,
        ``'torque k col 4 x'``, ``'padding'`` (a missing neighbour at an end; always 0)."""
        if column not in self.modelled:
            raise bad("column", column, f"a modelled column: {list(self.modelled)}")
        d, H = self.design, self.history
        g = self.modelled.index(column) if self.config.mode == "node" else 0
        names = []
        for j in range(H):
            for q, ref, ok in zip(d.position_slots[g], d.position_refs[g], d.position_valid[g]):
                name = f"col {q // 3} {'xyz'[q % 3]}"
                if not ok:
                    names.append("padding")
                elif j < H - 1 and d.relative:
                    names.append(f"displacement k-{H - j} {name}")
                else:
                    minus = f" - col {ref // 3} {'xyz'[ref % 3]}" if d.relative and ref >= 0 else ""
                    names.append(f"position k-{H - j} {name}{minus}")
        lags = [f"k-{H - j}" for j in range(H)] + (["k"] if d.next_wrench else [])
        W = max(self.wrench_width, 1)
        if W in (3, 6):
            names += [f"{'force' if q % W < 3 else 'torque'} {lag} col {q // W} {'xyz'[q % W % 3]}"
                      for lag in lags for q in d.wrench_slots[g]]
        else:                  # input II with actuation channels: numbered
            names += [f"input {q % W} {lag} col {q // W}" for lag in lags for q in d.wrench_slots[g]]
        return names

    def summary(self) -> dict:
        """JSON-ready description: mode, history, relative, next_wrench, features, alpha (min, max)."""
        return {"mode": self.config.mode, "history": self.history, "relative": self.config.relative,
                "next_wrench": self.config.next_wrench, "features": self.design.n_features,
                "modelled": list(self.modelled), "alpha_min": float(self.alpha.min()),
                "alpha_max": float(self.alpha.max())}


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


def free_run(baseline: AbstractBaseline, positions, wrenches, start: int, stop: int, *,
             modelled=None) -> np.ndarray:
    """Free-running prediction (stop - start, N, 3) [m] of samples ``start .. stop-1``.

    The window before ``start`` is the reference's (rows start-H .. start-1); every later window
    holds the baseline's own predictions for the ``modelled`` columns (default: every column) and
    the reference for the others (a clamped boundary, or the neighbours of one node as in
    ``evaluate.free_running``). The wrenches are always the reference's (known inputs).

    Parameters
    ----------
    baseline : AbstractBaseline
        The fitted baseline.
    positions : array-like (T, N, 3)
        Reference positions [m].
    wrenches : array-like (T, N, W) or None
        Reference forces [N] (and torques [N m]).
    start, stop : int
        history <= start < stop <= T.
    modelled : sequence of int or None
        Predicted columns.

    Raises
    ------
    RolloutDiverged
        A predicted coordinate beyond ``DIVERGED_M`` or not finite (``node`` is the column, ``time``
        is NaN: the arrays carry no times).
    """
    P = _positions("positions", positions)
    Wr = _wrenches("wrenches", wrenches, P.shape[:2], 0)   # any width: the baseline checks its own
    H = _history(baseline.history)
    start, stop = check_span(P.shape[0], H, start, stop, wording=WINDOWS)
    cols = _columns("modelled", modelled, P.shape[1])
    state = P[start - H:stop].copy()                                            # (H + L, N, 3)
    loads = None if Wr is None else Wr[start - H:stop]

    def step(k: int, window: np.ndarray) -> np.ndarray:
        pred = baseline.step(window, None if loads is None else loads[k - H:k], None if loads is None else loads[k])
        new = _checked(pred, P.shape[1:])[cols]
        bad_rows = ~(np.isfinite(new).all(axis=1) & (np.abs(new) <= DIVERGED_M).all(axis=1))
        if bad_rows.any():
            _diverged(int(cols[np.flatnonzero(bad_rows)[0]]), start - H + k)
        row = state[k].copy()                  # the reference, for the columns not modelled
        row[cols] = new
        return row

    with np.errstate(under="ignore"):
        free_steps(step, state, H)
    return state[H:]


def _checked(pred, shape: tuple[int, ...]) -> np.ndarray:
    out = np.asarray(pred, dtype=np.float64)
    if out.shape != tuple(shape):
        raise bad("baseline", f"a step returning shape {out.shape}", f"a step returning shape {tuple(shape)}")
    return out


def _diverged(column: int, sample: int):
    raise RolloutDiverged(f"the baseline's free run diverged: column {column} left {DIVERGED_M:g} m (or became "
                          f"not finite) at sample {sample}; report it as diverged or use a shorter span",
                          node=column, sample=sample, time=float("nan"))


def horizon_errors(pred_fn: Callable, positions, wrenches, starts, horizons=HORIZONS, *,
                   stop: int | None = None, nodes=None) -> dict[int, dict]:
    """Free-running errors after 1, 10, 100, 1000 ... predicted samples, over several starts.

    Parameters
    ----------
    pred_fn : callable
        ``pred_fn(positions, wrenches, start, stop) -> (stop - start, N, 3)``: a causal free-running
        predictor [m] seeded from the reference before ``start``, e.g.
        ``functools.partial(free_run, baseline, modelled=...)``; it may raise ``RolloutDiverged``.
    positions : array-like (T, N, 3)
        Reference [m].
    wrenches : array-like (T, N, W) or None
        Passed to ``pred_fn``.
    starts : sequence of int
        First predicted samples (each >= the predictor's history).
    horizons : sequence of int
        Horizons h >= 1 [samples]: the error at sample start + h - 1.
    stop : int or None
        End of the span (default T): a horizon is used from a start only if start + h <= stop, and
        a horizon that fits no start is left out.
    nodes : sequence of int or None
        Columns the errors are taken over (default every column; pass the modelled ones, since the
        reference-driven columns have no error).

    Returns
    -------
    dict
        {h: {'max_abs_m', 'mean_abs_m': largest and mean |predicted - reference| over every node,
        axis and start [m] (None if a run diverged before h), 'n_starts', 'diverged': runs that
        diverged before h}}.
    """
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


def _indices(name: str, value, lo: int, hi: int | None) -> list[int]:
    items = list(value) if isinstance(value, (Sequence, np.ndarray)) else None
    if not items or not all(is_int(a) and lo <= a and (hi is None or a <= hi) for a in items):
        span = f"{lo}..{hi}" if hi is not None else f">= {lo}"
        raise bad(name, value, f"a non-empty sequence of integers {span}")
    return [int(a) for a in items]


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


__all__ = ["ALPHAS", "MAX_MANIPULATOR_FEATURES", "MODES", "AbstractBaseline", "ConstantVelocity", "LinearAR",
           "LinearARConfig", "Persistence", "StateBaseline", "dataset_wrenches", "free_run", "horizon_errors",
           "one_step", "standard_baselines"]
