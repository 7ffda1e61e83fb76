"""Shared pytest configuration: floating-point errors in NumPy code raise instead of warning.

Underflow is left alone (tiny energies and velocities of a rod at rest underflow legitimately).
The numba kernels do not consult NumPy's error state, so this only tightens the Python side.
"""

import numpy as np
import pytest


@pytest.fixture(autouse=True)
def _strict_floating_point():
    with np.errstate(divide="raise", over="raise", invalid="raise", under="ignore"):
        yield
