"""Strict numerics for every test: NumPy floating-point errors (including underflow) raise.

The numba kernels do not consult NumPy's error state, so this tightens the Python side only;
helpers that call SciPy integrators relax underflow locally (tests/helpers.py).

Every test process runs with the numeric code paths ``softrnn reproduce`` pins
(``softrnn.learned.threads.pin_numerics``), set here before NumPy and PyTorch load: a worker process
that a test starts inherits the environment, and NumPy reads it at its import, PyTorch once, at its first
operation, so a test process that took it up only later (after a test that pinned it, or after its own
NumPy import) would compute in other kernels than its workers. With the tests spread over several
processes (``make test``), which test runs first in a process varies; pinned from the start, each process
and its workers compute alike whatever the order, and so does a plain ``pytest`` run in one process.
"""

from softrnn.learned.threads import pin_numerics

# before NumPy's import, which reads NPY_DISABLE_CPU_FEATURES (and OpenBLAS OPENBLAS_CORETYPE) once: imported
# first, this process would take other code paths than the workers it starts, which inherit the pins
pin_numerics()

import numpy as np  # noqa: E402
import pytest  # noqa: E402


@pytest.fixture(autouse=True)
def _strict_floating_point():
    with np.errstate(all="raise"):
        yield


# Test modules that one process runs, one after the other, when the tests are spread over processes
# (``make test``: pytest-xdist, ``--dist loadfile``). Each of these pairs compiles the same kernels on
# first use: on two processes at once, both would compile them on a cold cache (over a minute each);
# in one, the second module loads what the first compiled.
SAME_PROCESS = (("tests/lab/test_benchmark.py", "tests/lab/test_worker_pool.py"),)


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_make_scheduler(config, log):
    """``--dist loadfile`` with the modules of each ``SAME_PROCESS`` group as one unit of work."""
    if config.getvalue("dist") != "loadfile":
        return None
    from xdist.scheduler import LoadFileScheduling

    first = {module: group[0] for group in SAME_PROCESS for module in group}

    class GroupedFiles(LoadFileScheduling):
        def _split_scope(self, nodeid: str) -> str:
            scope = super()._split_scope(nodeid)
            return first.get(scope, scope)

    return GroupedFiles(config, log)
