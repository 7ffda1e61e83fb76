"""Checks and shapes of the arrays the baselines read (``softrnn.learned.baselines``,
``softrnn.learned.linear``): positions (T, N, 3) [m], wrenches (T, N, W), windows (H, N, 3), each
refused with a one-line ``SoftrnnInputError`` naming the argument."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..errors import bad, is_int


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


def _checked(pred, shape: tuple[int, ...]) -> np.ndarray:
    out = np.asarray(pred, dtype=np.float64)
    if out.shape != tuple(shape):
        raise bad("baseline", f"a step returning shape {out.shape}", f"a step returning shape {tuple(shape)}")
    return out



def _indices(name: str, value, lo: int, hi: int | None) -> list[int]:
    items = list(value) if isinstance(value, (Sequence, np.ndarray)) else None
    if not items or not all(is_int(a) and lo <= a and (hi is None or a <= hi) for a in items):
        span = f"{lo}..{hi}" if hi is not None else f">= {lo}"
        raise bad(name, value, f"a non-empty sequence of integers {span}")
    return [int(a) for a in items]

