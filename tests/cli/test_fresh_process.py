"""Every subcommand once, each in a fresh process with a cold (new, empty) numba cache.

Why: numba compiles a kernel on its first call and caches it on disk (``cache=True``). With a warm
cache most kernels are loaded, not compiled, and loading skips work that compiling does (e.g. numba
re-reads its environment at every compile, not at a cache load). The rest of the suite runs in one
process, in one order, usually against a warm cache, so a bug that appears only when kernels are
compiled in another order, or in a process that did something else first, stays hidden there. A
newcomer's first ``make reproduce`` hit exactly that. Here each subprocess gets its own empty
``NUMBA_CACHE_DIR`` (so it compiles everything it uses, in its own order) and a private
``MPLCONFIGDIR``; ``NUMBA_NUM_THREADS`` is inherited from the caller as it is.

The small data set and model are made once per module (simulate and train, each itself cold) and
used by the later tests. ``softrnn reproduce --quick`` is not here: CI runs it with empty caches
(.ci/run). The subcommands whose work that run already does cold, in a fresh process, are marked
slow (run them with ``make test-all``): the sweep on Dask, the node model's evaluation and free run, the
magnetic experiment and its comparison, the benchmark, the Fig. 14 study on Dask and the whole-manipulator
model. Every subprocess has a
timeout, so a hang fails instead of blocking CI.
"""

import importlib.util
import json
import math
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from softrnn.io import read_dataset

TIMEOUT_S = 600
ROOT = Path(__file__).resolve().parents[2]
LAB_CSV = ROOT / "examples" / "lab_data.csv"
MAGNETIC_CSV = ROOT / "examples" / "magnetic_lab.csv"
SCENARIO = "semicircle"   # shipped, randomised (sweep), node of interest 50
NODE = 50
SAMPLES = 200

# the optional extras (pip install -e '.[learn]' / '.[dask]'); without them these commands cannot run
needs_learn = pytest.mark.skipif(
    any(importlib.util.find_spec(m) is None for m in ("torch", "safetensors", "onnx", "onnxruntime")),
    reason="the learned-model packages are not installed (softrnn[learn])")
needs_dask = pytest.mark.skipif(importlib.util.find_spec("distributed") is None,
                                reason="Dask is not installed (softrnn[dask])")


def _command() -> list:
    """The ``softrnn`` console script next to this interpreter (as a user runs it), else ``-m``."""
    script = Path(sys.executable).with_name("softrnn")
    return [str(script)] if script.is_file() else [sys.executable, "-m", "softrnn.cli.main"]


def _cold_env(private: Path, **changes) -> dict:
    """This process's environment with a new, empty numba cache and matplotlib folder under
    ``private``; ``changes``: more variables (value None: removed). os.environ is not touched."""
    cache, mpl = private / "numba-cache", private / "matplotlib"
    cache.mkdir()   # fails if it exists: never a warm cache
    mpl.mkdir()
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache), MPLCONFIGDIR=str(mpl), MPLBACKEND="Agg")
    for key, value in changes.items():
        if value is None:
            env.pop(key, None)
        else:
            env[key] = value
    return env


def _run(argv: list, cwd: Path, what: str, env_changes: dict | None = None) -> subprocess.CompletedProcess:
    """Run ``argv`` in ``cwd`` in a fresh process with a cold cache (its own, under
    ``cwd/.cold-WHAT``); fail on a non-zero exit, a traceback on stderr or a timeout, quoting stderr."""
    private = cwd / f".cold-{what.replace(' ', '-')}"
    private.mkdir()
    env = _cold_env(private, **(env_changes or {}))
    t0 = time.perf_counter()
    # a session of its own: on a timeout the whole group (Dask workers included) is killed
    proc = subprocess.Popen(argv, cwd=cwd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    try:
        out, err = proc.communicate(timeout=TIMEOUT_S)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        out, err = proc.communicate()
        pytest.fail(f"{what}: no exit after {TIMEOUT_S} s (killed): {' '.join(map(str, argv))}\n"
                    f"--- stderr (last 3000 characters) ---\n{err[-3000:]}")
    seconds = time.perf_counter() - t0
    result = subprocess.CompletedProcess(argv, proc.returncode, out, err)
    result.seconds = seconds
    result.cache = private / "numba-cache"
    detail = (f"{what}: {' '.join(map(str, argv))}\nexit code {proc.returncode} after {seconds:.1f} s (cold numba "
              f"cache)\n--- stderr (last 3000 characters) ---\n{err[-3000:]}\n--- stdout (last 1000 characters) "
              f"---\n{out[-1000:]}")
    assert proc.returncode == 0, detail
    assert "Traceback" not in err, detail
    return result


def _softrnn(args: list, cwd: Path, what: str | None = None) -> subprocess.CompletedProcess:
    return _run(_command() + [str(a) for a in args], cwd, what or str(args[0]))


def _nonempty(path: Path) -> Path:
    assert path.is_file() and path.stat().st_size > 0, f"{path} was not written"
    return path


def _png(path: Path) -> None:
    assert _nonempty(path).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", f"{path} is not a PNG"


# ------------------------------------------------------------------------------ shared inputs
@pytest.fixture(scope="module")
def work(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("fresh-process")


@pytest.fixture(scope="module")
def simulated(work):
    """``softrnn simulate`` (cold): the small data set every later test uses."""
    return _softrnn(["simulate", SCENARIO, "--samples", SAMPLES, "-o", work / "data.h5", "--quiet"], work)


@pytest.fixture(scope="module")
def dataset(simulated, work) -> Path:
    return work / "data.h5"


@pytest.fixture(scope="module")
def trained(dataset, work):
    """``softrnn train`` (cold): one epoch of a small model of the node of interest."""
    return _softrnn(["train", dataset, "-o", work / "model", "--epochs", 1, "--units", 4, "--quiet"], work)


@pytest.fixture(scope="module")
def model(trained, work) -> Path:
    return work / "model"


# ------------------------------------------------------------------------------ data
def test_simulate(simulated, dataset):
    d = read_dataset(dataset)
    assert d.n_samples == SAMPLES and d.positions.shape == (SAMPLES, 101, 3)
    assert d.attrs.get("scenario_name") == SCENARIO
    # the private cache was used, so the kernels really were compiled in that process
    assert list(simulated.cache.rglob("*.nbi")), f"numba wrote nothing to {simulated.cache}: was the cache cold?"


def test_show(dataset, work):
    r = _softrnn(["show", dataset, "--json"], work)
    summary = json.loads(r.stdout)
    assert summary["n_samples"] == SAMPLES and summary["verified"]


def test_plot(dataset, work):
    _softrnn(["plot", dataset, "-o", work / "node.png"], work)
    _png(work / "node.png")


def test_animate(dataset, work):
    _softrnn(["animate", dataset, "-o", work / "rod.gif", "--frames", 3, "--quiet"], work)
    assert _nonempty(work / "rod.gif").read_bytes()[:4] == b"GIF8"


def test_import_csv(work):
    _softrnn(["import-csv", LAB_CSV, "-o", work / "lab.h5"], work)
    assert read_dataset(work / "lab.h5").n_samples > 0


@pytest.mark.slow
@needs_dask
def test_sweep(work):
    """Two variants on the default local Dask cluster (two workers compiling at once into one
    empty cache), merged into one file. Slow: CI's cold quick reproduce runs sweeps on two local Dask
    workers (``run_sweep``, its dynamic step) in a fresh process with an empty cache; the merge is
    tested on a warm cache (tests/sweeps)."""
    out = work / "sweep"
    _softrnn(["sweep", SCENARIO, "--count", 2, "--samples", 50, "-o", out, "--merge", work / "sweep.h5", "--quiet"],
             work)
    for i in range(2):
        assert read_dataset(out / f"traj-{i:05d}.h5").n_samples == 50
        assert read_dataset(work / "sweep.h5", group=f"traj-{i:05d}").n_samples == 50


# ------------------------------------------------------------------------------ models
@needs_learn
def test_train(trained, model):
    meta = json.loads((model / "meta.json").read_text())
    assert meta["epochs_run"] == 1
    for name in ("config.json", "normalizer.json", "weights.safetensors"):
        _nonempty(model / name)


@pytest.mark.slow
@needs_learn
def test_evaluate(model, dataset, work):
    """Slow: CI's cold quick reproduce evaluates node models (one step ahead and free running, the compiled
    engine) in a fresh process with an empty cache; the command runs on a warm cache in the README's tour
    (tests/project/test_tour.py)."""
    _softrnn(["evaluate", model, dataset, "--json", work / "evaluate.json", "--figures", work / "evaluate",
              "--quiet"], work)
    report = json.loads((work / "evaluate.json").read_text())
    assert report["node"] == NODE and report["free_running"] is not None
    _png(work / "evaluate" / "prediction.png")
    _png(work / "evaluate" / "rmse.png")
    _nonempty(work / "evaluate" / "rmse_t.csv")


@pytest.mark.slow
@needs_learn
def test_rollout(model, dataset, work):
    """Slow: CI's cold quick reproduce runs node models free on the compiled engine in a fresh process with
    an empty cache; the command runs on a warm cache in the README's tour (tests/project/test_tour.py)."""
    _softrnn(["rollout", model, dataset, "-o", work / "rollout.h5", "--figure", work / "rollout.png", "--quiet"],
             work)
    assert read_dataset(work / "rollout.h5").n_samples > 0
    _png(work / "rollout.png")


@needs_learn
@pytest.mark.filterwarnings("ignore:.*torch.jit.load.*:DeprecationWarning")
def test_export(model, work):
    _softrnn(["export", model, "--onnx", work / "model.onnx", "--torchscript", work / "model.pt"], work)
    import onnx
    import torch

    onnx.checker.check_model(str(_nonempty(work / "model.onnx")))
    torch.jit.load(str(_nonempty(work / "model.pt")))


@pytest.mark.slow
@needs_learn
@needs_dask
def test_study_hparams(dataset, work):
    """A one-point grid on the default local Dask cluster; the bandwidth is then measured in the
    calling process, i.e. numba compiles there after the Dask step. Slow: CI's cold quick reproduce
    runs the same study (``run_study`` on a local Dask cluster, then the bandwidth) in a fresh process
    with an empty cache."""
    out = work / "study"
    _softrnn(["study", "hparams", dataset, "--node", NODE, "-o", out, "--units", 4, "--history", 2, "--epochs", 1,
              "--bandwidth-steps", 10, "--json", work / "study.json", "--quiet"], work, "study hparams")
    result = json.loads((work / "study.json").read_text())
    assert [[p["units"], p["history"]] for p in result["points"]] == [[4, 2]]
    assert result["points"][0]["bandwidth"]["stepper"]["hz"] > 0
    _png(out / "fig14.png")


# ------------------------------------------------------------------------------ magnetic, bench
@pytest.mark.slow
@needs_learn
def test_magnetic_experiment(work):
    """--quick with fewer samples and one epoch (60: a margin above the fewest that training accepts
    with its default multi-step loss, about 45). Slow: CI's cold quick reproduce runs the same
    experiment (``run_experiment`` in its quick form) in a fresh process with an empty cache."""
    out = work / "magnetic"
    _softrnn(["magnetic", "experiment", "-o", out, "--quick", "--samples", 60, "--epochs", 1, "--json",
              work / "magnetic.json", "--quiet"], work, "magnetic experiment")
    table = json.loads((out / "table1.json").read_text())
    assert set(table) >= {"proximal", "distal"}
    _png(out / "fig12.png")
    assert read_dataset(out / "robot.h5").n_samples > 0


@pytest.mark.slow
@needs_learn
def test_magnetic_compare(work):
    """Slow: CI's cold quick reproduce runs the same comparison (``compare``: the static model and the
    LSTM against the record, Table 1) on its simulated record, in a fresh process with an empty cache;
    reading a lab CSV is tested on a warm cache (tests/experiments/test_magnetic_experiment.py)."""
    out = work / "magnetic-compare"
    _softrnn(["magnetic", "compare", MAGNETIC_CSV, "-o", out, "--epochs", 1, "--quiet"], work, "magnetic compare")
    table = json.loads((out / "table1.json").read_text())
    assert set(table) >= {"proximal", "distal"}
    _png(out / "fig12.png")


@pytest.mark.slow
@needs_learn
def test_bench_quick(work):
    """All three parts (learned model, simulator, static solver), each compiling its own kernels.
    Slow: CI's cold quick reproduce runs the same benchmarks (``bench.run_all`` in its quick form) in
    a fresh process with an empty cache."""
    _softrnn(["bench", "--quick", "--json", work / "bench.json"], work)
    result = json.loads((work / "bench.json").read_text())
    assert {"model", "simulator", "statics"} <= set(result)
    integrators = result["simulator"]["integrators"]
    assert isinstance(integrators["how"], str)
    for integrator in ("explicit", "implicit"):
        for case in ("ellipse", "square", "semicircle", "steel-wire", "nitinol-guidewire"):
            entry = integrators[integrator][case]
            for key in ("us_per_node_step", "dt_s", "real_time_factor"):
                assert math.isfinite(entry[key]) and entry[key] > 0, (integrator, case, key, entry)
            error = entry["tip_error_pct_of_length"]
            assert (math.isfinite(error) and error >= 0) if error is not None else entry["tip_error_reason"]
    assert integrators["implicit"]["steel-wire"]["tip_error_pct_of_length"] is not None


@pytest.mark.slow
@needs_learn
@needs_dask
def test_dynamic_train_evaluate_rollout(simulated, work):
    """The whole-manipulator model: trained on the sweep's first variant and the data set's first
    60 % (a 0.2 ms model step: the data are 20 ms long), then evaluated and run free, each cold.
    Slow: CI's cold quick reproduce trains, evaluates and runs free the same model (its dynamic step)
    in a fresh process with an empty cache."""
    sweep = work / "sweep"
    if not (sweep / "traj-00001.h5").is_file():
        _softrnn(["sweep", SCENARIO, "--count", 2, "--samples", 50, "-o", sweep, "--quiet"], work, "sweep for dynamic")
    model = work / "dyn"
    _softrnn(["dynamic", "train", sweep, work / "data.h5", "--heldout", 1, "--model-dt", 0.0002, "--steps", 5,
              "--width", 8, "--layers", 1, "--unroll", 2, "--quiet", "-o", model], work, "dynamic train")
    _nonempty(model / "model.json")
    _softrnn(["dynamic", "evaluate", model, "--test", work / "data.h5", "--heldout", sweep / "traj-00001.h5",
              "--json", work / "dyn-eval.json"], work, "dynamic evaluate")
    report = json.loads((work / "dyn-eval.json").read_text())
    assert report["predicted_nodes"] > 0 and set(report["horizons"]["10"]) >= {"model", "linear"}
    _softrnn(["dynamic", "rollout", model, work / "data.h5", "-o", work / "dyn-pred.h5"], work, "dynamic rollout")
    assert read_dataset(work / "dyn-pred.h5").attrs.get("rollout") == "dynamic"


def test_lab_example(work):
    """The lab-like recording of the tendon arm (the simulator, the tendons' actuation channels, the
    noisy marker), then its import."""
    _softrnn(["lab-example", "-o", work / "lab-example", "--scenarios", "tendon-planar", "--duration", 5], work)
    _softrnn(["import-csv", work / "lab-example" / "tendon-planar.csv", "-o", work / "lab-tendon.h5",
              "--length", 0.4], work, "import lab example")
    ds = read_dataset(work / "lab-tendon.h5")
    assert ds.n_samples == 101 and ds.actuation.shape == (101, 2)


# ------------------------------------------------------------------------------ Dask, then numba in one process
_DASK_THEN_COMPILE = textwrap.dedent("""
    import json
    import os
    import sys

    import numba
    import numpy as np
    from numba.np.ufunc import parallel as numba_parallel

    from softrnn.rod.magnetic import currents_into
    from softrnn.scenarios.scenario import load_scenario
    from softrnn.sweeps.sweep import run_sweep


    def main():
        threads = int(numba.config.NUMBA_NUM_THREADS)

        @numba.njit(parallel=True, cache=False)
        def total(x):
            s = 0.0
            for i in numba.prange(x.size):
                s += x[i]
            return s

        first_sum = float(total(np.ones(64)))             # a parallel function: numba's thread pool starts
        launched = bool(numba_parallel._is_initialized)

        before = dict(os.environ)
        run_sweep(load_scenario("semicircle"), 2, sys.argv[1], n_workers=1, n_samples=5)   # the Dask step
        after = dict(os.environ)
        changed = {k: [before.get(k), after.get(k)] for k in sorted(set(before) | set(after))
                   if before.get(k) != after.get(k)}

        # numba compiles in this process after the Dask step (the workers compiled only the rod's
        # kernel): cached kernels of softrnn's (the coil currents' interpolation), then the parallel
        # function again (a new signature, compiled here, now)
        currents = currents_into(np.array([0.0, 0.5, 2.0]), np.array([0.0, 1.0]), np.array([[0.0], [2.0]]))
        numba.set_num_threads(threads)
        parallel_sum = float(total(np.ones(64, dtype=np.float32)))
        assert first_sum == 64.0
        print("RESULT " + json.dumps({"threads": threads, "launched": launched, "environ_changed": changed,
                                      "threads_after": int(numba.config.NUMBA_NUM_THREADS),
                                      "parallel_sum": parallel_sum, "currents": currents[:, 0].tolist()}))


    if __name__ == "__main__":   # Dask's worker processes import this file again
        main()
""")


@needs_dask
def test_dask_step_then_numba_compiles_in_the_same_process(tmp_path):
    """The old failure: the parent's numba thread pool ran, a Dask step set NUMBA_NUM_THREADS=1 in the
    parent's own environment, and the next compile in the parent raised "RuntimeError: Cannot set
    NUMBA_NUM_THREADS to a different value once the threads have been launched". Warm caches hid it
    (a cache load does not re-read the environment). NUMBA_NUM_THREADS is unset here, as in a user's
    shell, so the pool starts with one thread per core; on a one-core machine only the environment
    check below can catch the regression."""
    script = tmp_path / "dask_then_compile.py"
    script.write_text(_DASK_THEN_COMPILE)
    r = _run([sys.executable, str(script), str(tmp_path / "sweep")], tmp_path, "dask then compile",
             env_changes={"NUMBA_NUM_THREADS": None})
    lines = [line for line in r.stdout.splitlines() if line.startswith("RESULT ")]
    assert lines, f"no RESULT line:\n{r.stdout[-2000:]}\n{r.stderr[-3000:]}"
    result = json.loads(lines[-1][len("RESULT "):])
    assert result["launched"], result
    assert result["environ_changed"] == {}, f"the Dask step changed this process's environment: {result}"
    assert result["threads_after"] == result["threads"], result
    assert result["parallel_sum"] == 64.0, result
    assert result["currents"] == [0.0, 1.0, 2.0], result
