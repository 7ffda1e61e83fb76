"""The Dask runner: local workers get their own settings, and the calling process's environment is
never changed (numba re-reads it at every compile and refuses a new thread count once its pool runs)."""

import os

import numpy as np

from softrnn.scenarios.scenario import load_scenario
from softrnn.sweeps.dask import WORKER_ENV, completed, restored_environ
from softrnn.sweeps.sweep import run_sweep


def _worker_settings(tag):
    import numba

    return tag, os.environ.get("NUMBA_NUM_THREADS"), int(numba.config.NUMBA_NUM_THREADS)


def test_local_workers_run_single_threaded_numba_and_the_parent_is_untouched():
    before = dict(os.environ)
    results = sorted(completed([(_worker_settings, (k,), f"settings-{k}") for k in range(2)], None, 1))
    assert dict(os.environ) == before
    assert results == [(0, "1", 1), (1, "1", 1)]
    assert WORKER_ENV == {"NUMBA_NUM_THREADS": "1"}


def test_restored_environ_undoes_additions_changes_and_removals(monkeypatch):
    monkeypatch.setenv("SOFTRNN_TEST_KEEP", "a")
    monkeypatch.setenv("SOFTRNN_TEST_GONE", "b")
    before = dict(os.environ)
    with restored_environ():
        os.environ["SOFTRNN_TEST_NEW"] = "c"
        os.environ["SOFTRNN_TEST_KEEP"] = "changed"
        del os.environ["SOFTRNN_TEST_GONE"]
    assert dict(os.environ) == before


def test_a_sweep_leaves_the_environment_as_it_was_and_numba_still_compiles(tmp_path, monkeypatch):
    scenario = load_scenario("semicircle")
    with monkeypatch.context() as m:
        m.delenv("NUMBA_NUM_THREADS", raising=False)   # as a user's shell has it: unset
        before = dict(os.environ)
        run_sweep(scenario, 2, tmp_path, n_workers=1, n_samples=5)
        assert dict(os.environ) == before

    import numba

    @numba.njit(parallel=True, cache=False)
    def _total(x):
        s = 0.0
        for i in numba.prange(x.size):
            s += x[i]
        return s

    assert _total(np.ones(64)) == 64.0   # compiling here used to raise RuntimeError (NUMBA_NUM_THREADS)
