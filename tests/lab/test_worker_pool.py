"""The lab benchmark's worker processes: the same figures with one worker (everything in this process)
and with two (the physics variants and the learned families at once), every stage reported; the pool's
results, errors, timings and a clean stop on Ctrl-C; a bad worker count refused in one line."""

import dataclasses
import json
import os
import signal
import time

import numpy as np
import pytest

from softrnn.errors import SimulationError, SoftrnnInputError
from softrnn.lab._pool import WorkerPool
from softrnn.lab.benchmark import BenchmarkOptions, run_benchmark
from softrnn.lab.families import NODE_TRAINING, NodeOptions
from softrnn.lab.nets import NetOptions, SequenceOptions, early_candidates, seeded
from softrnn.lab.recording import read_recording
from softrnn.lab.synthetic import SyntheticOptions
from softrnn.lab.tendon_robot import CalibrationOptions
from softrnn.learned.horizons import RolloutDiverged

from helpers import tendon_recording

TINY = dict(nets=NetOptions(members=2, steps=60, hidden=8), sequence=SequenceOptions(epochs=2, hidden=4),
            node=NodeOptions(units=4, training=dataclasses.replace(NODE_TRAINING, epochs=2, rollout_steps=2)),
            calibration=CalibrationOptions(quick_evaluations=15, evaluations=60, variant_evaluations=30),
            synthetic=SyntheticOptions(amount=1.0))
TIMINGS = ("seconds", "workers", "stage_seconds")
"""The JSON's keys that say how long it took and in how many processes (a calibration's own ``seconds`` too)."""


def _figures(value):
    """The JSON without its timings, as text (NaN equal to NaN)."""
    def strip(v):
        if isinstance(v, dict):
            return {k: strip(x) for k, x in v.items() if k not in TIMINGS}
        return [strip(x) for x in v] if isinstance(v, list) else v
    return json.dumps(strip(value))


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """The benchmark of a small synthetic robot with 1 and with 2 workers: (result, stages reported)."""
    d = tmp_path_factory.mktemp("rec")
    tendon_recording(d / "train.csv", rows=100, seed=3)
    tendon_recording(d / "val.csv", rows=40, seed=4, scale_mm=3.5)
    train, val = read_recording(d / "train.csv"), read_recording(d / "val.csv")
    out = {}
    for workers in (1, 2):
        stages = []
        result = run_benchmark([train], val, BenchmarkOptions(length=0.08, workers=workers, **TINY),
                               progress=lambda done, total, info, s=stages: s.append((done, total, info["stage"])))
        out[workers] = result, stages
    return out


def test_two_workers_give_the_figures_of_one(runs):
    """Every key of the JSON but the timings, and every prediction, equal to the last bit."""
    (one, _), (two, _) = runs[1], runs[2]
    a, b = one.to_dict(), two.to_dict()
    assert _figures(a) == _figures(b)
    assert list(a["models"]) == ["physics", "learned_map", "hybrid", "sequence", "node_lstm"]
    assert list(a["details"]) == list(b["details"])
    assert set(one.predictions) == set(two.predictions)
    for name, tip in one.predictions.items():
        assert np.array_equal(tip, two.predictions[name]), name
    assert a["details"]["learned_map"]["holdout_rmse_mm"]            # the families did choose on the hold-out
    assert (a["workers"], b["workers"]) == (1, 2)


def test_every_stage_is_reported_once_with_timings(runs):
    for result, stages in runs.values():
        total = 1 + 5
        assert [d for d, _, _ in stages] == list(range(1, total + 1)) and {t for _, t, _ in stages} == {total}
        assert sorted(s for _, _, s in stages) == sorted(["baselines", "physics", "learned_map", "hybrid",
                                                          "sequence", "node_lstm"])
        seconds = result.to_dict()["stage_seconds"]
        assert {"physics plain", "physics gravity", "physics friction", "physics creep",
                "physics gravity+friction",
                "physics refit", "physics session agreement", "learned_map", "hybrid", "sequence",
                "node_lstm", "sequence early", "node_lstm early", "learned_map early"} == set(seconds)
        assert all(v["cpu"] >= 0 and v["wall"] >= 0 for v in seconds.values())


@pytest.fixture(scope="module")
def fitted_physics(tmp_path_factory):
    """A small robot's training session, the benchmark's options and a physics calibrated on the
    hold-out split's fitting part."""
    from softrnn.lab.families import Physics, holdout_split
    from softrnn.lab.tendon_robot import TendonRobot

    d = tmp_path_factory.mktemp("early")
    tendon_recording(d / "train.csv", rows=100, seed=3)
    train = [read_recording(d / "train.csv")]
    options = BenchmarkOptions(length=0.08, **TINY)
    return train, options, Physics(TendonRobot((0.08,), 3), options.calibration).fit(holdout_split(train)[0])


@pytest.mark.parametrize("name", ["sequence", "node_lstm", "learned_map"])
def test_a_family_fits_the_same_with_its_candidates_fitted_early(fitted_physics, name):
    """The candidates that need no physics, fitted before the family's job (``early_candidates``, in a
    job of their own while the physics calibrates), give the family's scores and model to the last
    bit; that job in a worker process gives the figures of one worker (above)."""
    from softrnn.lab._stages import FITS, HeldScore
    from softrnn.lab.families import holdout_split

    train, options, physics = fitted_physics
    syn = dataclasses.replace(options.synthetic, amount=0.5)
    held = HeldScore(holdout_split(train)[1])
    early = early_candidates(name, train, syn, options)
    assert early and all("mode=real" in label for label in early)     # on the real rows alone
    runs = []
    for given in (None, early):
        with seeded(name):
            model, scores = FITS[name](train, (physics, physics), syn, options, held, early=given)
        runs.append((scores, model.predict(train[0])))
    assert runs[0][0] == runs[1][0] and set(early) < set(runs[0][0])
    assert np.array_equal(runs[0][1], runs[1][1], equal_nan=True)


def test_a_single_node_candidate_refits_beside_its_choice_with_the_figures_of_one_job(fitted_physics):
    """Without a calibrated physics or synthetic rows the node LSTM has one candidate: its refit on every
    training row (``node_final``) runs as a job of its own beside the choice, and gives the model, the
    hold-out scores, the interval and the run over a session of the one job (``fit_node``) to the last bit.
    With a calibrated physics there is a choice, and the refit waits for it."""
    from softrnn.lab._pool import WorkerPool
    from softrnn.lab._stages import FITS, HeldScore, Joined, submit_family
    from softrnn.lab.families import holdout_split
    from softrnn.lab.nets import NODE_FINAL, node_single

    train, options, physics = fitted_physics
    syn = dataclasses.replace(options.synthetic, amount=0.0)
    assert node_single((None, None), syn) and not node_single((physics, physics), syn)
    with seeded("node_lstm"):
        model, scores = FITS["node_lstm"](train, (None, None), syn, options, HeldScore(holdout_split(train)[1]))
    tip, radius = model.predict_interval(train[0])
    with WorkerPool(2) as pool:
        job = submit_family(pool, "node_lstm", train, (None, None), syn, None, options, train[0])
        assert isinstance(job, Joined) and list(pool.as_completed([job])) == [job]
        ran, score, weights = job.get()
        assert {"node_lstm", NODE_FINAL} == set(pool.timings)
    assert ran.details["holdout_rmse_mm"] == scores and score == min(scores.values()) and weights is None
    assert np.array_equal(ran.tip, tip, equal_nan=True) and np.array_equal(ran.radius, radius, equal_nan=True)


def test_a_family_seeds_its_own_random_numbers():
    """Inside ``seeded(name)`` PyTorch draws the same numbers whatever was drawn before; the caller's
    random state is left as it was."""
    torch = pytest.importorskip("torch")
    draws = []
    for before in (0, 5):
        torch.manual_seed(123)
        torch.rand(before)
        state = torch.random.get_rng_state()
        with seeded("hybrid"):
            draws.append(torch.rand(4))
        assert torch.equal(torch.random.get_rng_state(), state)
    assert torch.equal(draws[0], draws[1])
    with seeded("sequence"):
        assert not torch.equal(torch.rand(4), draws[0])


def _square(x):
    return x * x


def _fail(x):
    raise SoftrnnInputError(f"x={x} is invalid: a test error")


class _Unpicklable(SimulationError):
    """An error whose constructor takes keyword arguments alone: it does not survive pickling as itself."""

    def __init__(self, message, *, where):
        super().__init__(message)
        self.where = where


def _fail_unpicklably(x):
    raise _Unpicklable(f"x={x} went wrong", where=x)


def _diverge(x):
    raise RolloutDiverged(f"diverged at {x}", node=1, sample=x, time=0.5 * x)


def _nap(seconds):
    time.sleep(seconds)
    return os.getpid()


@pytest.mark.parametrize("workers", [1, 2])
def test_pool_results_in_order_and_errors_raised_here(workers):
    with WorkerPool(workers) as pool:
        assert pool.map(["a", "b", "c"], _square, [(2,), (3,), (4,)]) == [4, 9, 16]
        jobs = [pool.submit(f"j{i}", _square, i) for i in range(4)]
        assert sorted(job.get() for job in pool.as_completed(jobs)) == [0, 1, 4, 9]
        assert set(pool.timings) == {"a", "b", "c", "j0", "j1", "j2", "j3"}
        with pytest.raises(SoftrnnInputError, match="x=7 is invalid"):
            pool.submit("bad", _fail, 7).get()


def test_a_worker_error_that_does_not_pickle_comes_back_as_its_base_class_and_the_pool_goes_on():
    """An error that cannot be unpickled here would stop the pool's result thread and leave every job
    waiting for ever: it comes back as its nearest base class that pickles, with its message, and the
    pool's next job runs. A divergence of a learned model's run comes back as itself, where and when."""
    with WorkerPool(2) as pool:
        job = pool.submit("bad", _fail_unpicklably, 3)
        deadline = time.monotonic() + 300.0        # a hang is for ever; a loaded machine spawns slowly
        while not job.ready() and time.monotonic() < deadline:
            job.wait(0.1)
        assert job.ready(), "the worker's error never came back"
        with pytest.raises(SimulationError, match="^x=3 went wrong$") as err:
            job.get()
        assert type(err.value) is SimulationError
        with pytest.raises(RolloutDiverged, match="diverged at 4") as err:
            pool.submit("diverged", _diverge, 4).get()
        assert (err.value.node, err.value.sample, err.value.time) == (1, 4, 2.0)
        assert pool.submit("next", _square, 5).get() == 25
    with WorkerPool(1) as pool:                 # in this process: the error itself
        with pytest.raises(_Unpicklable):
            pool.submit("bad", _fail_unpicklably, 3).get()


def _blas_threads():
    import numpy as np  # noqa: F401  (loads NumPy's BLAS in a fresh worker)
    from threadpoolctl import threadpool_info

    return sorted({info["num_threads"] for info in threadpool_info() if info["user_api"] == "blas"})


@pytest.mark.parametrize("workers", [1, 2])
def test_jobs_run_blas_on_one_thread_and_repeated_labels_add_up(workers):
    """Every job, in a worker or here, runs the BLAS libraries on one thread (a blocked solve sums in
    another order on another thread count), and this process's own count comes back after; the jobs of
    one label add their times."""
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=2, user_api="blas"):
        with WorkerPool(workers) as pool:
            assert pool.map(["blas", "blas"], _blas_threads, [(), ()]) == [[1], [1]]
            assert list(pool.timings) == ["blas"]
            first = pool.timings["blas"]
            pool.submit("blas", _nap, 0.05).get()
            assert pool.timings["blas"][1] >= first[1] + 0.05
        assert _blas_threads() == [2]


def test_one_worker_runs_each_job_here_when_asked_for():
    with WorkerPool(1) as pool:
        job = pool.submit("pid", _nap, 0.0)
        assert "pid" not in pool.timings and job.ready()
        assert job.get() == os.getpid() and "pid" in pool.timings


def test_workers_ignore_ctrl_c_and_an_interrupt_terminates_them():
    """SIGINT sent to the workers (as Ctrl-C reaches the whole process group) stops none of their jobs;
    a KeyboardInterrupt in this process leaves the block with every worker process ended."""
    with WorkerPool(2) as pool:
        jobs = [pool.submit(f"nap {i}", _nap, 1.0) for i in range(2)]
        for process in pool._pool._pool:
            os.kill(process.pid, signal.SIGINT)
        for job in jobs:
            job.wait(60.0)
            assert job.ready() and job.get() != os.getpid()
    processes = []
    with pytest.raises(KeyboardInterrupt):
        with WorkerPool(2) as pool:
            processes = list(pool._pool._pool)
            pool.submit("long", _nap, 60.0)
            raise KeyboardInterrupt
    assert len(processes) == 2 and not any(p.is_alive() for p in processes)


@pytest.mark.parametrize("workers", [0, -1, 1.5, "2", True])
def test_bad_worker_count_one_line(workers):
    with pytest.raises(SoftrnnInputError, match=r"^workers=.* is invalid: an integer >= 1$"):
        BenchmarkOptions(length=0.1, workers=workers)


def test_worker_count_is_not_part_of_what_is_computed():
    """Options that differ only in the worker count are equal and print alike (a suite's fingerprint,
    ``--resume``, does not change with it)."""
    assert BenchmarkOptions(length=0.1, workers=1) == BenchmarkOptions(length=0.1, workers=3)
    assert repr(BenchmarkOptions(length=0.1, workers=1)) == repr(BenchmarkOptions(length=0.1, workers=3))
