"""Strict numerics for every test: NumPy floating-point errors (including underflow) raise.

The numba kernels do not consult NumPy's error state, so this tightens the Python side only;
helpers that call SciPy integrators relax underflow locally (tests/helpers.py).

Every test process runs with the numeric code paths ``softrnn reproduce`` pins
(``softrnn.learned.threads.pin_numerics``), set here before PyTorch loads: a worker process that a
test starts inherits the environment, and PyTorch reads it once, at its first operation, so a test
process that took it up only later (after a test that pinned it) would compute in other kernels than
its workers. With the tests spread over several processes (``make test``), which test runs first in
a process varies; pinned from the start, each process and its workers compute alike whatever the order.
"""

import numpy as np
import pytest

from softrnn.learned.threads import pin_numerics

pin_numerics()


@pytest.fixture(autouse=True)
def _strict_floating_point():
    with np.errstate(all="raise"):
        yield
