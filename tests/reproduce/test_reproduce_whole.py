"""The whole-manipulator model in ``softrnn reproduce`` (goals, report.md, stale folders) and in
``softrnn bench`` (the simulator against the learned model, one core each). The step itself runs in
tests/cli/test_cli.py's quick pipeline test."""

import json
from dataclasses import replace

import pytest

from softrnn.bench import dynamic as bench_dynamic
from softrnn.errors import SoftrnnInputError
from softrnn.learned.whole.config import DynamicConfig
from softrnn.reproduce import dynamic as rd
from softrnn.reproduce.report import _dynamic_lines

from helpers import bending_chain

SMALL = DynamicConfig(node_stride=10, width=8, layers=1, unroll=2, batch=4)


def _entry(model_100=0.5, speed=12.0) -> dict:
    row = lambda m, p, c, lin: {"model": m, "persistence": p, "constant_velocity": c, "linear": lin}  # noqa: E731
    return {"model_dt_s": 0.02, "predicted_nodes": 21, "nodes": 59, "history": 3,
            "test_span_max_pct_of_length": 1.5, "test_span": {"start_s": 30.0, "end_s": 50.0,
                                                              "model": {"max_pct_of_length": 1.5},
                                                              "persistence": {"max_pct_of_length": 20.0},
                                                              "constant_velocity": {"max_pct_of_length": None,
                                                                                    "diverged_at": 12},
                                                              "linear": {"max_pct_of_length": 3.0}},
            "heldout": {"variants": 8, "median_max_pct_of_length": 1.0, "worst_max_pct_of_length": None,
                        "baselines": {}},
            "generalisation_max_pct_of_length": 4.0,
            "horizons": {"10": row(0.1, 1.0, 0.2, 0.3), "100": row(model_100, 9.0, 30.0, 4.0),
                         "1000": row(None, 20.0, None, 8.0)},
            "speed_ratio_vs_simulator": speed, "simulator_sim_s_per_wall_s": 10.0, "model_sim_s_per_wall_s": 10 * speed}


def test_goals_are_measured_and_stated_met_or_missed():
    g = rd.goals("ellipse", _entry(), longest=1501)
    assert g["test_span_max_pct_of_length"] == {"value": 1.5, "goal": 2.0, "met": True}
    assert g["heldout_median_max_pct_of_length"]["met"] is True
    assert g["heldout_worst_max_pct_of_length"]["met"] is False            # a held-out run diverged
    assert g["beats_every_baseline_at_10"]["met"] is True
    assert g["beats_every_baseline_at_100"]["best_baseline"] == "linear"
    assert g["times_better_than_best_baseline_at_100"]["value"] == pytest.approx(8.0)
    assert g["times_better_than_best_baseline_at_100"]["met"] is True
    assert g["beats_every_baseline_at_1000"]["met"] is False
    assert "diverged" in g["beats_every_baseline_at_1000"]["note"]
    assert g["speed_ratio_vs_simulator"]["met"] is True
    assert all(isinstance(v["met"], bool) for v in g.values())
    short = rd.goals("semicircle", _entry(model_100=1.0, speed=3.0), longest=151)
    assert "times_better_than_best_baseline_at_100" not in short            # ellipse and square only
    assert "not measured" in short["beats_every_baseline_at_1000"]["note"]
    assert short["speed_ratio_vs_simulator"]["met"] is False


def test_report_states_each_goal_and_every_baseline():
    entry = _entry(speed=3.0)
    entry["goals"] = rd.goals("square", entry, longest=1051)
    text = "\n".join(_dynamic_lines({"square": entry}))
    assert "## Whole-manipulator dynamic model" in text and "### square" in text
    assert "| at 100 model steps | 0.5 | 9 | 30 | 4 | 0.125 (linear) |" in text
    assert "| paper test span 30-50 s | 1.5 | 20 | diverged at step 12 | 3 |" in text
    assert "| held-out variants (8), worst | diverged |" in text
    assert "(>= 10x): **missed** (3x)" in text
    assert "(< 2 % of L): met (1.5 %)" in text
    assert _dynamic_lines(None) == []


def test_a_case_folder_of_other_settings_is_made_again(tmp_path):
    folder = tmp_path / "dynamic" / "square"
    rd._fresh(folder, rd.settings("square", quick=True))
    (folder / "checkpoint.pt").write_bytes(b"x")
    rd._fresh(folder, rd.settings("square", quick=True))
    assert (folder / "checkpoint.pt").exists()                             # same settings: kept
    rd._fresh(folder, rd.settings("square", quick=False))
    assert not (folder / "checkpoint.pt").exists()                         # other settings: remade
    s = rd.settings("ellipse", quick=False)["sweep"]
    n = rd.SWEEP["n_train"] + rd.SWEEP["n_validation"] + rd.SWEEP["n_heldout"]
    assert s["count"] == n and s["n_validation"] == rd.SWEEP["n_validation"] and s["n_samples"] == 3001
    assert s["dt"] == 0.01


def test_bench_times_the_simulator_and_the_stand_in_model(monkeypatch):
    from softrnn.bench import format_all, run_all

    monkeypatch.setattr(bench_dynamic, "CASES", ("square",))
    result = run_all(("dynamic",), quick=True, dynamic_configs={"square": SMALL})
    e = result["dynamic"]["cases"]["square"]
    assert e["trained"] is False and "untrained" in e["model_weights"]
    assert e["simulator_sim_s_per_wall_s"] > 0 and e["model_sim_s_per_wall_s"] > 0
    assert e["speed_ratio_vs_simulator"] == pytest.approx(e["model_sim_s_per_wall_s"] / e["simulator_sim_s_per_wall_s"])
    assert e["simulator"]["threads"] == 1 and e["model"]["predicted_nodes"] == 6 and e["config"]["width"] == 8
    assert result["goals_met"] == {"dynamic.speed_ratio_square": e["goal_met"]}
    assert "learned whole-manipulator model" in format_all(result)


def test_bench_times_a_trained_model_folder(monkeypatch, tmp_path, capsys):
    from softrnn.cli.main import main
    from softrnn.learned.whole.artifact import save_dynamic
    from softrnn.learned.whole.training import train_dynamic_model

    setup, config, _ = bench_dynamic.case_run("square")
    data = bench_dynamic.simulated_dataset(setup, config, 0.5)
    _, enc = bench_dynamic.stand_in_model(data, SMALL)
    save_dynamic(tmp_path / "m", train_dynamic_model([enc.trajectory(data)], enc, replace(SMALL, steps=0)))
    monkeypatch.setattr(bench_dynamic, "CASES", ("square",))
    out = tmp_path / "b.json"
    assert main(["bench", "--only", "dynamic", "--quick", "--dynamic-model", str(tmp_path / "m"),
                 "--json", str(out)]) == 0
    e = json.loads(out.read_text())["dynamic"]["cases"]["square"]
    assert e["trained"] is True and e["model"]["predicted_nodes"] == 6
    capsys.readouterr()
    assert main(["bench", "--only", "dynamic", "--quick", "--dynamic-model", str(tmp_path / "none")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "no such model folder" in err


def test_the_benchmarks_compile_starts_early_unless_the_benchmark_is_finished(tmp_path, monkeypatch):
    """``warm_start``: a background process (daemonic, spawned) that compiles the benchmark's kernels
    (the simulator's or the model's, of the quick or the full benchmark) into numba's cache; none once
    ``bench.json`` holds a finished benchmark."""
    from types import SimpleNamespace

    from softrnn import __version__
    from softrnn.reproduce import benchmark as rb

    started = []

    class Process:
        def __init__(self, target, name, daemon, args=()):
            started.append((target, daemon))
            started.append(args)

        def start(self):
            started.append("started")

    kinds = []
    monkeypatch.setattr(rb.multiprocessing, "get_context", lambda kind: kinds.append(kind) or SimpleNamespace(
        Process=Process))
    assert isinstance(rb.warm_start(tmp_path, True), Process)
    assert started == [(rb._warm, True), (True, "simulator"), "started"] and kinds == ["spawn"]
    started.clear()
    assert isinstance(rb.warm_start(tmp_path, False, "model"), Process)
    assert started == [(rb._warm, True), (False, "model"), "started"]
    with pytest.raises(SoftrnnInputError, match="^part='gpu' is invalid: one of simulator, model$"):
        rb.warm_start(tmp_path, True, "gpu")
    (tmp_path / "bench.json").write_text(json.dumps({"quick": True, "softrnn_version": __version__, "model": {}}))
    assert rb.warm_start(tmp_path, True) is None and rb.warm_start(tmp_path, True, "model") is None
    assert rb.warm_start(tmp_path, False) is not None


def test_the_longest_trainings_go_first():
    jobs = [(name, None, None, DynamicConfig(steps=steps)) for name, steps in (("a", 20), ("b", 4000), ("c", 2500),
                                                                              ("d", 4000))]
    assert [job[0] for job in rd.longest_first(jobs)] == ["b", "d", "c", "a"]


def test_pool_tasks_go_after_the_trainings():
    task = rd.PoolTask("control model", print)
    jobs = [task, ("a", None, None, DynamicConfig(steps=20)), ("b", None, None, DynamicConfig(steps=4000))]
    assert [rd._job_name(job) for job in rd.longest_first(jobs)] == ["b", "a", "control model"]


def test_a_pool_task_makes_what_its_step_would_make(tmp_path):
    """The control step's model identified and trained as a ``PoolTask`` in the training pool (two
    workers) equals the one the step makes in its own process with the same PyTorch threads."""
    import numpy as np
    import torch

    from softrnn.control.run import MODEL_FILE, learned_model
    from softrnn.learned.threads import REPRODUCE_TORCH_THREADS, torch_threads
    from softrnn.reproduce import control as rc

    settings = {**rc.QUICK, "identify": 2.0, "train_steps": 4}
    kwargs = rc._model_settings(settings)
    seen = {}

    def factory(desc):
        return lambda done, total, info=None: seen.setdefault(desc, []).append((done, total))

    tasks = [rd.PoolTask(f"control model {k}", learned_model, (tmp_path / f"pool{k}",), kwargs,
                         REPRODUCE_TORCH_THREADS) for k in (1, 2)]
    rd.train_cases(tasks, workers=2, threads=1, progress_factory=factory)
    with torch_threads(REPRODUCE_TORCH_THREADS):
        assert torch.get_num_threads() == REPRODUCE_TORCH_THREADS
        learned_model(tmp_path / "here", **kwargs)
    with np.load(tmp_path / "here" / MODEL_FILE) as here, np.load(tmp_path / "pool1" / MODEL_FILE) as pool:
        assert sorted(here.files) == sorted(pool.files)
        for key in here.files:
            if here[key].dtype.kind == "U":                               # the model's meta: its seconds differ
                a, b = (json.loads(str(x[key])) for x in (here, pool))
                assert a.pop("seconds") > 0 and b.pop("seconds") > 0 and a == b
            else:
                np.testing.assert_array_equal(here[key], pool[key])
    assert seen["control model 1"][-1][0] == seen["control model 1"][-1][1] > 0
    assert rc.training_jobs(tmp_path, True) == []                   # a quick run identifies it ahead
    assert rc.training_jobs(tmp_path, False)[0].kwargs == rc._model_settings(rc.FULL)


def test_trainings_side_by_side_give_the_weights_of_one_after_the_other(tmp_path):
    """``train_cases`` with two worker processes (one PyTorch thread each) writes the same models as
    training in this process, with progress reported per case; a finished model is not trained again."""
    import numpy as np
    from safetensors.numpy import load_file

    from softrnn.io import write_dataset
    from softrnn.learned.whole.data import split_inputs

    data = tmp_path / "data"
    data.mkdir()
    for i in range(3):
        chain = bending_chain(0.02 + 0.01 * i, 0.7 * i, n_nodes=5, n_samples=41, dt=0.01)
        write_dataset(data / f"traj-{i:05d}.h5", chain)
    split = split_inputs([data], heldout=1)
    config = DynamicConfig(model_dt=0.01, node_stride=2, width=8, layers=1, unroll=3, batch=8, steps=20, noise=0.05)
    jobs = lambda root: [(case, root / case, split, replace(config, seed=k))  # noqa: E731
                         for k, case in enumerate(("a", "b", "c"))]
    seen = {}

    def factory(desc):
        return lambda done, total, info=None: seen.setdefault(desc, []).append((done, total))

    rd.train_cases(jobs(tmp_path / "pool"), workers=2, threads=1, progress_factory=factory)
    rd.train_cases(jobs(tmp_path / "here"), workers=1, threads=1)
    for case in ("a", "b", "c"):
        pool = load_file(tmp_path / "pool" / case / "model" / "weights.safetensors")
        here = load_file(tmp_path / "here" / case / "model" / "weights.safetensors")
        assert pool.keys() == here.keys()
        for key in pool:
            np.testing.assert_array_equal(pool[key], here[key])
        assert not (tmp_path / "pool" / case / "checkpoint.pt").exists()
        assert seen[f"train dynamic {case}"][-1] == (20, 20)
    a = load_file(tmp_path / "pool" / "a" / "model" / "weights.safetensors")
    b = load_file(tmp_path / "pool" / "b" / "model" / "weights.safetensors")
    assert any(not np.array_equal(a[k], b[k]) for k in a)           # the seeds differ, so do the weights
    seen.clear()
    rd.train_cases(jobs(tmp_path / "pool"), workers=2, threads=1, progress_factory=factory)
    assert seen == {}                                                 # nothing left to train


def test_the_model_warm_up_runs_every_manipulator_case_the_model_benchmark_times(monkeypatch):
    """``bench.model.warm_manipulator`` (the ``model`` part of ``warm_start``) steps each case of
    ``manipulator_cases``, the list ``run_model_benchmark`` times, with a short run."""
    from softrnn.bench import model as bm

    seen = []
    monkeypatch.setattr(bm, "time_manipulator", lambda config, threads, n, n_nodes, shared=False: seen.append(
        (config, threads, n, n_nodes, shared)))
    bm.warm_manipulator()
    cases = bm.manipulator_cases()
    assert [(config, threads, n, shared) for config, threads, n, _, shared in seen] == [
        (config, threads, 1, shared) for _, config, threads, shared in cases]
    # short rods, long enough for the parallel kernels' path: two modelled nodes per thread, the ends aside
    assert all(n_nodes >= bm.WARM_NODES and n_nodes - 2 >= 2 * threads for _, threads, _, n_nodes, _ in seen)
    assert {shared for *_, shared in cases} == {False, True} and {name for name, *_ in cases} == {"default", "compact"}
