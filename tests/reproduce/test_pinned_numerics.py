"""``softrnn reproduce`` pins the numeric libraries' code paths (softrnn.learned.threads.pin_numerics)
so that its figures do not depend on the processor; a value the user set is kept."""

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
