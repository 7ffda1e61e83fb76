"""PyTorch's intra-op thread count, set for a block of work and restored after; the numeric libraries'
code paths pinned so that a run's figures do not depend on the machine (``pinned_numerics``); OpenMP's
idle threads put to sleep, so that processes sharing the cores do not spin against one another
(``passive_waits``)."""

from __future__ import annotations

import os
import sys
from contextlib import contextmanager
from importlib.metadata import PackageNotFoundError, version

from threadpoolctl import threadpool_info, threadpool_limits


def _numpy_avx512() -> str:
    """NumPy's AVX-512 dispatch targets, by the names of the NumPy installed (read from its metadata,
    not imported: the variable naming them is read when NumPy loads). NumPy 2.4 groups them by
    x86-64 level (``X86_V4``); earlier releases name each extension. NumPy warns (an ``ImportWarning``,
    silent by default) of a name it does not know, so each release is given only its own."""
    try:
        major, minor = (int(part) for part in version("numpy").split(".")[:2])
    except (PackageNotFoundError, ValueError):
        major, minor = 2, 4
    if (major, minor) >= (2, 4):
        return "X86_V4 AVX512_ICL AVX512_SPR"
    return "AVX512F AVX512CD AVX512_KNL AVX512_KNM AVX512_SKX AVX512_CLX AVX512_CNL AVX512_ICL" + (
        " AVX512_SPR" if major >= 2 else "")


PINNED_NUMERICS = {"MKL_CBWR": "COMPATIBLE", "ONEDNN_MAX_CPU_ISA": "AVX2", "ATEN_CPU_CAPABILITY": "avx2",
                   "NPY_DISABLE_CPU_FEATURES": _numpy_avx512(), "OPENBLAS_CORETYPE": "Haswell"}
"""The code path of each numeric library, fixed instead of chosen by the processor. Under PyTorch:
MKL's conditional numerical reproducibility branch (``COMPATIBLE``, the one branch that gives the
same results on Intel and other x86 processors), oneDNN's instruction set (its LSTM and linear
kernels) and ATen's vectorised kernels (both AVX2, which every x86-64 processor since 2013 has).
Under NumPy and SciPy: NumPy's universal functions (``sin``, ``exp``, ``tanh``, ``arctan2``, ...)
without their AVX-512 versions, which round differently in the last bit from the AVX2 ones, and
OpenBLAS's kernels (its matrix products, and the LAPACK solves, least squares and eigenvalues built
on them) at Haswell's, the AVX2 kernels, where it would take its AVX-512 (SkylakeX) kernels on a
processor that has them. Unpinned, a processor with AVX-512 and one without give float sums and
functions that differ in the last digit; training and fits amplify that to the 4th-6th digit of
their figures, and a choice on a near tie (a ridge penalty) flips. ``NPY_DISABLE_CPU_FEATURES``
and ``OPENBLAS_CORETYPE`` are read when NumPy loads: ``softrnn reproduce`` sets them before
(``pin_numerics`` at the command's start); ``numerics_in_force`` tells what a process has."""

PASSIVE_WAITS = {"OMP_WAIT_POLICY": "PASSIVE"}
"""OpenMP's waiting policy (GNU OpenMP, under PyTorch, MKL, oneDNN and numba's thread pool): a thread
with no work sleeps instead of spinning. By default each spins for milliseconds after every
parallel region; ``softrnn reproduce`` runs several processes on the cores at once (background
compiles, a two-thread PyTorch training, worker pools), and a spinning thread there takes the core
its partner, or another process, needs: measured on 2 busy cores, the control step's 300-step
model training took 160 s of CPU spinning instead of 5 s, with bit-identical weights. The work and
its partition among threads are unchanged, so are the figures."""

REPRODUCE_TORCH_THREADS = 2
"""PyTorch's threads in ``softrnn reproduce`` outside the trainings (which set their own, one each):
fixed, because MKL's results depend on its thread count, and PyTorch's default is the machine's cores."""


@contextmanager
def torch_threads(threads: int | None):
    """Torch's intra-op thread count set to ``threads`` inside (None, or torch not imported:
    unchanged), the caller's count restored after. Tiny forwards (one window per node, a batch of
    one) run fastest on one thread; training sets the count so that its results do not depend on
    the machine's."""
    torch = sys.modules.get("torch")
    if threads is None or torch is None:
        yield
        return
    old = torch.get_num_threads()
    torch.set_num_threads(int(threads))
    try:
        yield
    finally:
        torch.set_num_threads(old)


def pin_numerics() -> dict[str, str]:
    """Set each variable of ``PINNED_NUMERICS`` that the environment does not set already (a value
    the user set is kept) and return the values asked for. Effective only before PyTorch's first
    operation in this process, and for ``NPY_DISABLE_CPU_FEATURES`` and ``OPENBLAS_CORETYPE`` before
    NumPy's import; processes started after inherit them."""
    for name, value in PINNED_NUMERICS.items():
        os.environ.setdefault(name, value)
    return {name: os.environ[name] for name in PINNED_NUMERICS}


def numerics_in_force() -> dict[str, str | None]:
    """The code paths NumPy and its BLAS took in this process: ``numpy_simd``, NumPy's highest
    dispatched instruction set found (e.g. ``X86_V3``, ``AVX512_SKX``), and ``openblas``, the
    kernels of each OpenBLAS loaded (e.g. ``Haswell``; None where threadpoolctl does not tell)."""
    try:     # NumPy, which this module must not load at its top: its pins are set before NumPy loads
        from numpy._core._multiarray_umath import __cpu_dispatch__, __cpu_features__  # heavy: see above
    except ImportError:      # NumPy 1.x
        from numpy.core._multiarray_umath import __cpu_dispatch__, __cpu_features__  # heavy: see above
    found = [name for name in __cpu_dispatch__ if __cpu_features__.get(name)]
    kernels = sorted({str(info.get("architecture")) for info in threadpool_info()
                      if info.get("internal_api") == "openblas"})
    return {"numpy_simd": found[-1] if found else "baseline", "openblas": ",".join(kernels) or None}


REPRODUCE_BLAS_THREADS = 2
"""The threads of the BLAS libraries under NumPy and SciPy (OpenBLAS) in ``softrnn reproduce``: fixed,
because a blocked solve or product sums in another order on another thread count (the linear terms'
ridge solves moved in their last digits with one thread), and the default is the machine's cores or
``OMP_NUM_THREADS``. Two: the count the committed references were made with, on two cores."""


def pin_blas_threads() -> int:
    """Fix the BLAS threads at ``REPRODUCE_BLAS_THREADS``, whatever the environment says: in the
    libraries loaded in this process (``threadpoolctl``) and, through ``OPENBLAS_NUM_THREADS``, in
    those loaded later and in every process started after. Returns the count."""
    os.environ["OPENBLAS_NUM_THREADS"] = str(REPRODUCE_BLAS_THREADS)
    threadpool_limits(limits=REPRODUCE_BLAS_THREADS, user_api="blas")
    return REPRODUCE_BLAS_THREADS


def one_blas_thread():
    """A context in which the BLAS libraries under NumPy and SciPy run on one thread (``threadpoolctl``),
    restored after: a worker's job, or a calibration, gives the same figures on every machine (a blocked
    solve sums in another order on another thread count) and no threads contend over small matrices."""
    return threadpool_limits(limits=1, user_api="blas")


def passive_waits() -> dict[str, str]:
    """Set each variable of ``PASSIVE_WAITS`` that the environment does not set already (a value the
    user set is kept) and return the values in force. Effective for the OpenMP runtimes loaded after
    (PyTorch's at its import, numba's pool at its first parallel kernel) and in every process
    started after (they inherit the environment)."""
    for name, value in PASSIVE_WAITS.items():
        os.environ.setdefault(name, value)
    return {name: os.environ[name] for name in PASSIVE_WAITS}
