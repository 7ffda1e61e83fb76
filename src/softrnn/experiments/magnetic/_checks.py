"""Argument checks of the magnetic experiment: one-line ``SoftrnnInputError`` messages (``errors.bad``)."""

from __future__ import annotations

import math

import numpy as np

from ...errors import bad


def is_int(value) -> bool:
    """True for a Python or numpy integer that is not a bool."""
    return isinstance(value, (int, np.integer)) and not isinstance(value, bool)


def number(name: str, value, *, low: float | None = None, high: float | None = None, positive: bool = False,
           unit: str = "") -> float:
    """``value`` as a float, or a ``SoftrnnInputError`` naming ``name``, the range and the ``unit``."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)) \
            or not math.isfinite(value) or (positive and value <= 0) or (low is not None and value < low) \
            or (high is not None and value > high):
        rng = " > 0" if positive else ""
        if low is not None or high is not None:
            rng = f" in [{'-inf' if low is None else f'{low:g}'}, {'inf' if high is None else f'{high:g}'}]"
        raise bad(name, value, f"a finite number{rng}{' ' + unit if unit else ''}")
    return float(value)


def integer(name: str, value, low: int) -> int:
    """``value`` as an int >= ``low``, or a ``SoftrnnInputError`` naming ``name``."""
    if not is_int(value) or value < low:
        raise bad(name, value, f"an integer >= {low}")
    return int(value)


def triple(name: str, value, n: int, expected: str) -> np.ndarray:
    """``value`` as a finite float array of shape (n,), or a ``SoftrnnInputError`` saying ``expected``."""
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        a = None
    if a is None or a.shape != (n,) or not np.all(np.isfinite(a)):
        raise bad(name, value, expected)
    return a
