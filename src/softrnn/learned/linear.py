"""The linear autoregressive baseline (``LinearAR``): a ridge model of the increment from the
learned node models' inputs (paper Fig. 2B: the last ``history`` samples of the node's and its
neighbours' positions and the node's wrenches), per node or of the whole manipulator; exact for a
linear system (a damped mass-spring chain). Arrays as in ``softrnn.learned.baselines``. Float64,
closed-form ridge by one SVD per fit, deterministic."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import final

import numpy as np

from ..errors import bad, is_finite_number, is_int
from ._arrays import _columns, _history, _positions, _window, _window_loads, _wrenches
from .spans import check_fit_span

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
        """The model of ``config`` fitted on the samples ``[start, stop)`` (default stop T; every window
        and target inside the span, like ``data.make_windows``: pass the learned model's training
        span) of ``positions`` (T, N, 3) [m] and ``wrenches`` (T, N, 6), (T, N, 3) or None [N, N m],
        predicting the ``modelled`` columns (default every column). The span needs history + 1
        samples (history + 2 where alpha is chosen on the validation tail). Shapes, a span that
        does not fit or too large a whole-manipulator model are one-line ``SoftrnnInputError``s."""
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





# ------------------------------------------------------------------------------------- LinearARX
@final
@dataclass(frozen=True, eq=False)
class LinearARX:
    """A linear ARX model of an output y (T, D) driven by known inputs u (T, m), fitted by least
    squares (``fit``) and run free on its own output (``run``): y_k = sum_{i=1..na} A_i y_{k-i} +
    sum_{j=0..nb-1} B_j u_{k-j} + c. The lab benchmark's linear baseline (``softrnn.lab.families``).

    Attributes
    ----------
    na, nb : int
        Output lags and input lags (the current input included).
    weights : ndarray (na D + nb m + 1, D) float64
        [A_1 .. A_na, B_0 .. B_nb-1, c] stacked, in the units of y per unit of each row.
    """

    na: int
    nb: int
    weights: np.ndarray

    @property
    def history(self) -> int:
        """Rows a run takes from its seed: max(na, nb - 1)."""
        return max(self.na, self.nb - 1)

    @staticmethod
    def _row(na: int, nb: int, y: np.ndarray, u: np.ndarray, k: int) -> np.ndarray:
        return np.concatenate([*(y[k - i] for i in range(1, na + 1)), *(u[k - j] for j in range(nb)), [1.0]])

    @classmethod
    def fit(cls, outputs, inputs, na: int = 1, nb: int = 1) -> LinearARX:
        """Least squares over every row k >= max(na, nb - 1) of each pair (y (T, D), u (T, m)) of
        ``outputs`` and ``inputs`` (sequences of arrays, one pair per recording)."""
        for name, value in (("na", na), ("nb", nb)):
            if not is_int(value) or value < 1:
                raise bad(name, value, "an integer >= 1 (lags)")
        m = max(na, nb - 1)
        X, Y = [], []
        for y, u in zip(outputs, inputs):
            for k in range(m, len(y)):
                X.append(cls._row(na, nb, y, u, k))
                Y.append(y[k])
        return cls(na=int(na), nb=int(nb), weights=np.linalg.lstsq(np.array(X), np.array(Y), rcond=None)[0])

    def run(self, seed, inputs) -> np.ndarray:
        """Free-running outputs (T, D) over ``inputs`` u (T, m): the first ``history`` rows are those of
        ``seed`` (T', D), T' >= history (the initial condition), every later one is predicted from
        the model's own outputs."""
        u = np.asarray(inputs)
        seed = np.asarray(seed)
        m = self.history
        y = np.empty((len(u), seed.shape[1]), dtype=seed.dtype)
        y[:m] = seed[:m]
        for k in range(m, len(u)):
            y[k] = self._row(self.na, self.nb, y, u, k) @ self.weights
        return y


__all__ = ["ALPHAS", "MAX_MANIPULATOR_FEATURES", "MODES", "LinearAR", "LinearARConfig", "LinearARX"]
