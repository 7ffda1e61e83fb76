"""Strict numerics for every test: NumPy floating-point errors (including underflow) raise.

The numba kernels do not consult NumPy's error state, so this tightens the Python side only;
helpers that call SciPy integrators relax underflow locally (tests/helpers.py).
"""

import numpy as np
import pytest


@pytest.fixture(autouse=True)
def _strict_floating_point():
    with np.errstate(all="raise"):
        yield
