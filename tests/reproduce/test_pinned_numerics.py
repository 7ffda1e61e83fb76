"""``softrnn reproduce`` pins the numeric libraries' code paths (softrnn.learned.threads.pin_numerics)
so that its figures do not depend on the processor; a value the user set is kept."""

import os

import pytest

from softrnn.learned import threads


def test_pin_numerics_sets_what_is_unset_and_keeps_what_the_user_set(monkeypatch):
    for name in threads.PINNED_NUMERICS:
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setenv("MKL_CBWR", "AVX2")
    pinned = threads.pin_numerics()
    assert pinned["MKL_CBWR"] == "AVX2"                          # the user's
    assert pinned["ONEDNN_MAX_CPU_ISA"] == "AVX2" and pinned["ATEN_CPU_CAPABILITY"] == "avx2"
    assert set(pinned) == set(threads.PINNED_NUMERICS)


def test_torch_threads_sets_and_restores_the_count():
    torch = pytest.importorskip("torch")
    old = torch.get_num_threads()
    with threads.torch_threads(threads.REPRODUCE_TORCH_THREADS):
        assert torch.get_num_threads() == threads.REPRODUCE_TORCH_THREADS
    assert torch.get_num_threads() == old


def _unset(monkeypatch, names):
    """Each variable unset here and restored after the test (set first, so that monkeypatch records it)."""
    for name in names:
        monkeypatch.setenv(name, "")
        monkeypatch.delenv(name)


def test_passive_waits_sets_what_is_unset_and_keeps_what_the_user_set(monkeypatch):
    _unset(monkeypatch, threads.PASSIVE_WAITS)
    assert threads.passive_waits() == {"OMP_WAIT_POLICY": "PASSIVE"}
    monkeypatch.setenv("OMP_WAIT_POLICY", "ACTIVE")
    assert threads.passive_waits() == {"OMP_WAIT_POLICY": "ACTIVE"}   # the user's


def test_reproduce_puts_openmp_waits_to_sleep_before_its_steps_and_reports_it(monkeypatch, tmp_path):
    pytest.importorskip("torch")
    from softrnn.reproduce import pipeline

    _unset(monkeypatch, [*threads.PASSIVE_WAITS, *threads.PINNED_NUMERICS, "OPENBLAS_NUM_THREADS"])
    seen = []
    monkeypatch.setattr(pipeline, "_steps", lambda report, out, quick, factory: seen.append(
        os.environ.get("OMP_WAIT_POLICY")))
    monkeypatch.setattr(pipeline, "render_markdown", lambda report: "")
    report = pipeline.reproduce(tmp_path / "out", quick=True)
    assert seen == ["PASSIVE"]                       # in force for the steps and the processes they start
    assert report["machine"]["waits"] == {"OMP_WAIT_POLICY": "PASSIVE"}
    assert report["machine"]["blas_threads"] == threads.REPRODUCE_BLAS_THREADS


def test_pin_blas_threads_overrides_the_environment_in_loaded_and_later_libraries(monkeypatch):
    import numpy  # noqa: F401  # its BLAS loaded before the pin
    from threadpoolctl import threadpool_info, threadpool_limits

    monkeypatch.setenv("OMP_NUM_THREADS", "1")
    monkeypatch.setenv("OPENBLAS_NUM_THREADS", "1")
    with threadpool_limits(limits=1, user_api="blas"):         # a BLAS already on one thread, restored after
        assert threads.pin_blas_threads() == threads.REPRODUCE_BLAS_THREADS
        assert os.environ["OPENBLAS_NUM_THREADS"] == str(threads.REPRODUCE_BLAS_THREADS)   # for later ones
        blas = [i for i in threadpool_info() if i["user_api"] == "blas"]
        assert blas and all(i["num_threads"] == threads.REPRODUCE_BLAS_THREADS for i in blas)


@pytest.mark.parametrize("release,names", [
    ("2.4.6", "X86_V4 AVX512_ICL AVX512_SPR"),
    ("2.1.0", "AVX512F AVX512CD AVX512_KNL AVX512_KNM AVX512_SKX AVX512_CLX AVX512_CNL AVX512_ICL AVX512_SPR"),
    ("1.26.4", "AVX512F AVX512CD AVX512_KNL AVX512_KNM AVX512_SKX AVX512_CLX AVX512_CNL AVX512_ICL"),
])
def test_numpy_avx512_targets_are_named_as_the_installed_release_names_them(monkeypatch, release, names):
    monkeypatch.setattr(threads, "version", lambda name: release)
    assert threads._numpy_avx512() == names


def test_the_installed_numpy_knows_every_target_it_is_told_to_leave_out():
    import numpy

    try:
        from numpy._core._multiarray_umath import __cpu_dispatch__
    except ImportError:
        from numpy.core._multiarray_umath import __cpu_dispatch__
    assert set(threads._numpy_avx512().split()) <= set(__cpu_dispatch__), numpy.__version__


_PINS_FIRST = """
import json, sys
from softrnn.learned import threads
threads.PINNED_NUMERICS.update(NPY_DISABLE_CPU_FEATURES=sys.argv[1], OPENBLAS_CORETYPE="Sandybridge")
assert "numpy" not in sys.modules
from softrnn.cli.main import main
try:
    main(["reproduce", "--quick", "-o", sys.argv[2], "--compare", sys.argv[3]])  # refused: no such reference
except SystemExit:
    pass
print(json.dumps(threads.numerics_in_force()))
"""


def test_softrnn_reproduce_pins_numpy_and_openblas_before_numpy_loads(tmp_path):
    """The command sets the pins before anything it runs imports NumPy: pins it could only set after
    would leave NumPy on the processor's code paths. Pins that every processor obeys stand in for the
    real ones here (every dispatch target off, OpenBLAS's Sandybridge kernels)."""
    import subprocess
    import sys

    import numpy

    try:
        from numpy._core._multiarray_umath import __cpu_dispatch__
    except ImportError:
        from numpy.core._multiarray_umath import __cpu_dispatch__
    env = {k: v for k, v in os.environ.items() if k not in threads.PINNED_NUMERICS}
    done = subprocess.run([sys.executable, "-c", _PINS_FIRST, " ".join(__cpu_dispatch__), str(tmp_path / "out"),
                           str(tmp_path / "nowhere")], env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    import json

    in_force = json.loads(done.stdout.strip().splitlines()[-1])
    assert in_force == {"numpy_simd": "baseline", "openblas": "Sandybridge"}, numpy.__version__
