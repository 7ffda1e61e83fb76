"""softrnn.rod.threads: the blocks of rods cover the batch once, every block runs (at once, on
threads), an error in any block is raised after every block has ended, and a forked process makes
helper threads of its own."""

import os
import threading

import numba
import pytest

from softrnn.rod import threads


@pytest.mark.parametrize("n_rods, n_threads", [(1, 1), (5, 2), (7, 3), (4, 4), (10, 4)])
def test_blocks_cover_every_rod_once_and_differ_by_at_most_one(n_rods, n_threads):
    spans = threads.blocks(n_rods, n_threads)
    assert len(spans) == n_threads and spans[0][0] == 0 and spans[-1][1] == n_rods
    assert all(a[1] == b[0] for a, b in zip(spans, spans[1:]))
    sizes = [b1 - b0 for b0, b1 in spans]
    assert min(sizes) >= 1 and max(sizes) - min(sizes) <= 1


def test_the_thread_count_is_numbas_at_most_one_per_rod():
    assert threads.thread_count(1) == 1
    assert threads.thread_count(10 ** 6) == numba.get_num_threads()
    assert threads.thread_count(0) == 1


def _recording(seen: list, barrier: threading.Barrier | None = None):
    def kernel(tag, b0, b1):
        if barrier is not None:
            barrier.wait(timeout=30)   # every block waits for the others: they run at once
        seen.append((tag, b0, b1, threading.get_ident()))
    return kernel


def test_every_block_runs_at_once_on_its_own_thread_the_first_on_the_callers(monkeypatch):
    monkeypatch.setattr(threads, "thread_count", lambda n_rods: 3)
    seen = []
    threads.over_rods(_recording(seen, threading.Barrier(3)), 8, "x")
    assert sorted((b0, b1) for _, b0, b1, _ in seen) == [(0, 2), (2, 5), (5, 8)]
    assert all(tag == "x" for tag, *_ in seen)
    assert len({ident for *_, ident in seen}) == 3
    assert [ident for _, b0, _, ident in seen if b0 == 0] == [threading.get_ident()]


def test_one_thread_calls_the_kernel_once_here(monkeypatch):
    monkeypatch.setattr(threads, "thread_count", lambda n_rods: 1)
    seen = []
    threads.over_rods(_recording(seen), 5, "y")
    assert seen == [("y", 0, 5, threading.get_ident())]


def test_an_error_in_a_block_is_raised_here_after_every_block_has_ended(monkeypatch):
    monkeypatch.setattr(threads, "thread_count", lambda n_rods: 3)
    ended = []

    def kernel(b0, b1):
        if b0 > 0:
            threading.Event().wait(0.2 * b0 / 3)
        ended.append(b0)
        if b0 == 1:
            raise ValueError("block one failed")

    with pytest.raises(ValueError, match="block one failed"):
        threads.over_rods(kernel, 3)
    assert sorted(ended) == [0, 1, 2]


@pytest.mark.skipif(not hasattr(os, "fork"), reason="no fork on this platform")
def test_a_forked_child_makes_helper_threads_of_its_own(monkeypatch):
    """A child inherits the pool object but none of its threads: it must not wait on them."""
    monkeypatch.setattr(threads, "thread_count", lambda n_rods: 2)
    threads.over_rods(_recording([]), 2, "parent")   # the parent's helpers exist
    pid = os.fork()
    if pid == 0:   # the child: exits 0 if the blocks ran, is killed by the parent's timeout otherwise
        seen = []
        threads.over_rods(_recording(seen, threading.Barrier(2)), 2, "child")
        os._exit(0 if len(seen) == 2 else 1)
    for _ in range(300):
        done, status = os.waitpid(pid, os.WNOHANG)
        if done:
            break
        threading.Event().wait(0.1)
    else:
        os.kill(pid, 9)
        os.waitpid(pid, 0)
        pytest.fail("the forked child hung on its parent's helper threads")
    assert os.waitstatus_to_exitcode(status) == 0
