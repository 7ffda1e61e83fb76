"""Argument checks of the magnetic experiment beyond ``softrnn.errors``' validators: one-line
``SoftrnnInputError`` messages (``errors.bad``)."""

from __future__ import annotations

import numpy as np

from ...errors import bad, is_finite_number


def number(name: str, value, *, low: float | None = None, high: float | None = None, positive: bool = False,
           unit: str = "") -> float:
    """``value`` as a float, or a ``SoftrnnInputError`` naming ``name``, the range and the ``unit``."""
    if not is_finite_number(value) or (positive and value <= 0) or (low is not None and value < low) \
            or (high is not None and value > high):
        rng = " > 0" if positive else ""
        if low is not None or high is not None:
            rng = f" in [{'-inf' if low is None else f'{low:g}'}, {'inf' if high is None else f'{high:g}'}]"
        raise bad(name, value, f"a finite number{rng}{' ' + unit if unit else ''}")
    return float(value)


def triple(name: str, value, n: int, expected: str) -> np.ndarray:
    """``value`` as a finite float array of shape (n,), or a ``SoftrnnInputError`` saying ``expected``."""
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        a = None
    if a is None or a.shape != (n,) or not np.all(np.isfinite(a)):
        raise bad(name, value, expected)
    return a
