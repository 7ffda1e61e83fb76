"""Evaluation and rollout of node models: metrics by hand, windows like make_windows, a perfect
(oracle) model reproduces the data bit for bit, batched shared models, the written prediction
file, and the evaluate / rollout commands (reports, figures, one-line errors with exit code 2)."""

import json

import numpy as np
import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.io import UNITS, Dataset, read_dataset
from softrnn.learned.horizons import RolloutDiverged
from softrnn.learned.node.artifact import save_model
from softrnn.learned.node.data import SampleSpec, make_windows, split
from softrnn.learned.node.evaluate import evaluate, free_running, metrics, one_step, paper_reference
from softrnn.learned.node.manipulator import Manipulator, bind
from softrnn.learned.node.rollout import rollout, rollout_dataset, write_rollout

from helpers import LENGTH, N_NODES, Offset, Oracle, node_dataset, real_model, run_cli, save_h5


# ------------------------------------------------------------------------------------------ metrics
def test_metrics_match_a_hand_computation():
    ref = np.array([[0.0, 0.0, 0.0], [1.0, 1.0, 1.0], [2.0, 0.0, -1.0]])
    err_mm = np.array([[1.0, -2.0, 2.0], [-3.0, 0.0, 0.0], [0.5, 4.0, -1.0]])
    m = metrics(ref + err_mm * 1e-3, ref, rod_length=0.5)
    np.testing.assert_allclose(m.max_abs_mm, [3.0, 4.0, 2.0], rtol=1e-9)
    np.testing.assert_allclose(m.mean_abs_mm, [4.5 / 3, 6.0 / 3, 3.0 / 3], rtol=1e-9)
    np.testing.assert_allclose(m.max_pct_of_length, [0.6, 0.8, 0.4], rtol=1e-9)  # 3 mm of 500 mm = 0.6 %
    # Eq. 2: sqrt((1 + 4 + 4) / 3), sqrt(9 / 3), sqrt((0.25 + 16 + 1) / 3)
    np.testing.assert_allclose(m.rmse_t_mm, [np.sqrt(3.0), np.sqrt(3.0), np.sqrt(17.25 / 3)], rtol=1e-9)
    np.testing.assert_allclose(m.rmse_mm, np.sqrt((9.0 + 9.0 + 17.25) / 9), rtol=1e-9)
    s = m.summary()
    assert s["max_abs_mm"] == pytest.approx([3.0, 4.0, 2.0]) and s["max_rmse_t_mm"] == pytest.approx(np.sqrt(17.25 / 3))
    assert metrics(ref, ref, None).max_pct_of_length is None
    for args in ((ref[:, :2], ref[:, :2], 0.5), (ref, ref[:2], 0.5), (ref, ref, -1.0)):
        with pytest.raises(SoftrnnInputError):
            metrics(*args)


# ------------------------------------------------------------------------------------------ rollout
@pytest.mark.parametrize("inputs, wrench, history", [("positions", "force", 2), ("poses", "wrench", 3),
                                                     ("positions", "none", 1)])
def test_rollout_windows_are_make_windows(inputs, wrench, history):
    ds = node_dataset()
    spec = SampleSpec(node=3, inputs=inputs, wrench=wrench, history=history).resolve(ds.nodes)
    w = make_windows(ds, spec, 0, ds.n_samples)
    (group,) = bind(Manipulator.of([Offset(spec)]), ds)
    for m in (0, 17, len(w) - 1):
        poses, wrenches = group.gather(ds.positions, ds.quaternions, ds.forces, ds.torques, int(w.index[m]))
        assert np.array_equal(poses[0], w.poses[m]) and np.array_equal(wrenches[0], w.wrenches[m])
        assert poses.dtype == np.float32 and wrenches.dtype == np.float32


@pytest.mark.parametrize("unmodelled", ["reference", "hold"])
def test_a_perfect_model_reproduces_the_data_bit_for_bit(unmodelled):
    ds = node_dataset()
    # every moving node has its own oracle (the tip has one neighbour); node 0 is the clamp
    models = [Oracle(ds, SampleSpec(node=a, history=2, inputs="poses", wrench="force")) for a in range(1, N_NODES)]
    result = rollout(Manipulator.of(models), ds, unmodelled=unmodelled)
    assert result.positions.shape == ds.positions.shape and result.first == 0 and result.seed == 2
    assert np.array_equal(result.positions, ds.positions)            # bitwise
    # one shared oracle for nodes 1..4, its own for the tip, over a part of the record
    shared = Oracle(ds, SampleSpec(node=2, history=3), nodes=range(1, 5))
    manip = Manipulator.of([Oracle(ds, SampleSpec(node=5, history=3))], shared=shared, shared_nodes=range(1, 5))
    part = rollout(manip, ds, 20, 50, unmodelled=unmodelled)
    assert part.first == 17 and np.array_equal(part.positions, ds.positions[17:50])


def test_oracle_evaluation_has_zero_error_on_the_test_span():
    ds = node_dataset(T=50)
    oracle = Oracle(ds, SampleSpec(node=2, history=2, wrench="wrench"))
    ev = evaluate(oracle, ds)
    cut = split(50, oracle.spec)[1].start
    assert ev.one_step.index[0] == cut + 2 and ev.one_step.index[-1] == 49  # windows inside the test span
    assert np.array_equal(ev.free_running.index, ev.one_step.index)
    report = ev.to_json()
    for kind in ("one_step", "free_running"):
        assert report[kind]["max_abs_mm"] == [0.0, 0.0, 0.0] and report[kind]["rmse_mm"] == 0.0
    assert report["span"] == "test" and report["length_m"] == LENGTH and report["unit"] == "mm"
    whole = evaluate(oracle, ds, generalisation=True)
    assert whole.info["span"] == "whole record" and whole.one_step.index[0] == 2
    json.dumps(whole.to_json(), allow_nan=False)


def test_free_running_feeds_predictions_back_one_step_does_not():
    ds = node_dataset()
    model = Offset(SampleSpec(node=4, history=2).resolve(ds.nodes))
    one = one_step(model, ds, 10, 30)
    run = free_running(model, ds, 10, 30)
    assert np.array_equal(one.index, run.index) and one.index[0] == 12
    # one step: 1 mm beyond the reference's previous sample, every time
    np.testing.assert_allclose(one.predicted - ds.positions[11:29, 4], np.tile([1e-3, 0, 0], (18, 1)), atol=1e-7)
    # free running: the model's own output is its next input, so it drifts 1 mm per step from the seed
    drift = run.predicted - ds.positions[11, 4]
    np.testing.assert_allclose(drift, np.outer(np.arange(1, 19), [1e-3, 0, 0]), atol=1e-6)


def test_shared_model_runs_one_batched_call_per_step_and_matches_separate_models():
    ds = node_dataset()
    spec = SampleSpec(node=2, history=2).resolve(ds.nodes)
    shared = Offset(spec, step=(1e-4, -2e-4, 0.0))
    result = rollout(Manipulator.of(shared=shared, shared_nodes=range(1, 5)), ds, 5, 25)
    assert shared.calls == [4] * 20                                   # one call, 4 nodes, per step
    separate = [Offset(SampleSpec(node=a, history=2).resolve(ds.nodes), step=(1e-4, -2e-4, 0.0)) for a in range(1, 5)]
    alone = rollout(Manipulator.of(separate), ds, 5, 25)
    assert np.array_equal(result.positions, alone.positions)
    assert np.array_equal(result.positions[:, [0, 5]], ds.positions[3:25][:, [0, 5]])  # unmodelled: reference


def test_real_model_free_running_starts_like_one_step_and_writes_a_dataset(tmp_path):
    ds = node_dataset()
    model = real_model(ds, SampleSpec(node=3, history=2, wrench="force"))
    one = one_step(model, ds, 20, 40)
    run = free_running(model, ds, 20, 40)
    # the same window gives the same prediction (the rollout state holds it as float32, like the data)
    assert np.array_equal(run.predicted[0], one.predicted[0].astype(np.float32))
    assert not np.array_equal(one.predicted[1:], run.predicted[1:])
    result = rollout(model, ds, 22, 40)
    out = write_rollout(tmp_path / "pred.h5", result, ds, models=["m"], source="ref.h5")
    back = read_dataset(out)
    assert np.array_equal(back.nodes, ds.nodes) and np.array_equal(back.time, ds.time[20:40])
    assert np.array_equal(back.positions, result.positions)
    assert np.array_equal(back.quaternions, ds.quaternions[20:40]) and np.array_equal(back.forces, ds.forces[20:40])
    assert back.attrs["prediction"] is True and back.attrs["modelled_nodes"] == [3]
    assert back.attrs["first_predicted_sample"] == 2 and back.attrs["models"] == ["m"]
    assert back.attrs["node_of_interest"] == 3
    assert rollout_dataset(result, ds).attrs["unmodelled"] == "reference"


def test_a_diverging_free_run_is_reported_not_fatal():
    ds = node_dataset()
    model = Offset(SampleSpec(node=3, history=2).resolve(ds.nodes), step=(5.0, 0.0, 0.0))  # 5 m per step
    with pytest.raises(RolloutDiverged) as err:
        rollout(model, ds, 10, 30)
    assert err.value.node == 3 and err.value.sample == 13 and "\n" not in str(err.value)
    report = evaluate(model, ds).to_json()
    assert report["free_running"]["diverged"] is True and report["free_running"]["node"] == 3
    assert report["one_step"]["max_abs_mm"][0] > 4000.0


def test_paper_figures_follow_the_scenario():
    record = {"version": 1, "name": "x", "paper": {"key": "semicircle", "role": "generalisation"}}
    ref = paper_reference({"scenario_record": record})
    assert ref["figures"] == "generalisation" and ref["max_abs_mm"] == [3.73, 2.0, 8.1]
    assert paper_reference({"scenario_name": "square"})["figures"] == "test"
    assert paper_reference({"scenario_name": "ellipse-horizontal"})["key"] == "ellipse"
    assert paper_reference({"scenario_name": "mine"}) is None


def test_library_errors_are_one_line():
    ds = node_dataset()
    model = Offset(SampleSpec(node=3, history=2).resolve(ds.nodes))
    few = Dataset(time=ds.time[:4], nodes=ds.nodes[[0, 1, 2]], positions=ds.positions[:4, :3],
                  quaternions=ds.quaternions[:4, :3], forces=ds.forces[:4, :3], torques=ds.torques[:4, :3],
                  attrs=ds.attrs)
    for call in (lambda: rollout(model, few), lambda: evaluate(model, few),
                 lambda: rollout(model, ds, 1, 10), lambda: rollout(model, ds, 10, 10)):
        with pytest.raises(SoftrnnInputError) as err:
            call()
        assert "\n" not in str(err.value)


# ------------------------------------------------------------------------------------------ CLI
SEMICIRCLE = '[paper]\nsection = "4.3"\nkey = "semicircle"\nrole = "training"\n'


@pytest.fixture
def files(tmp_path):
    ds = node_dataset(T=80)
    data = save_h5(tmp_path / "data.h5", ds, scenario_text=SEMICIRCLE, scenario_name="semicircle")
    folders = {}
    for a in range(1, N_NODES):
        folders[a] = tmp_path / f"node{a}"
        save_model(folders[a], real_model(ds, SampleSpec(node=a, history=2, wrench="force")))
    return tmp_path, data, folders


def test_evaluate_command_reports_json_and_figures(files, capsys):
    tmp, data, folders = files
    out, figs = tmp / "ev.json", tmp / "figs"
    assert run_cli(["evaluate", str(folders[3]), str(data), "--json", str(out), "--figures", str(figs),
                    "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "one step: max [mm]" in text and "free running: max [mm]" in text and "paper 4.3 test" in text
    report = json.loads(out.read_text())
    assert report["node"] == 3 and report["neighbours"] == [2, 4] and report["span"] == "test"
    assert report["paper"]["max_abs_mm"] == [1.36, 0.23, 2.22] and len(report["free_running"]["max_abs_mm"]) == 3
    assert {p.name for p in figs.iterdir()} == {"prediction.png", "rmse.png", "rmse_t.csv"}
    rows = (figs / "rmse_t.csv").read_text().splitlines()
    assert rows[0] == "time_s,one_step_mm,free_running_mm" and len(rows) == 1 + report["n_targets"]


def test_rollout_command_writes_a_prediction_file(files, capsys):
    tmp, data, folders = files
    out = tmp / "pred.h5"
    argv = ["rollout", *map(str, folders.values()), str(data), "-o", str(out), "--quiet", "--figure",
            str(tmp / "shapes.png")]
    assert run_cli(argv) == 0
    text = capsys.readouterr().out
    assert "5 modelled nodes (1..5; 5 models)" in text and "wrote" in text
    pred, ref = read_dataset(out), read_dataset(data)
    assert np.array_equal(pred.time, ref.time) and np.array_equal(pred.positions[:2], ref.positions[:2])
    assert np.array_equal(pred.positions[:, 0], ref.positions[:, 0])   # the clamp follows the reference
    assert pred.attrs["scenario_name"] == "semicircle (predicted)" and (tmp / "shapes.png").exists()
    # one model shared by the interior nodes, the tip its own; a time span
    assert run_cli(["rollout", str(folders[5]), str(data), "--shared", str(folders[2]), "-o", str(out),
                    "--start", "0.3", "--stop", "0.5", "--quiet", "--overwrite"]) == 0
    pred = read_dataset(out)
    assert pred.n_samples == 23 and pred.attrs["modelled_nodes"] == [1, 2, 3, 4, 5]
    assert "shared: nodes 1..4" in pred.attrs["models"][1]                    # A..B, as --shared-nodes


@pytest.mark.parametrize("case, words", [
    ("node not stored", ["does not store node 3,", "stored nodes: 0, 1, 2"]),
    ("neighbour not stored", ["does not store node 4 (a neighbour of node 3)", "stored nodes: 0..3"]),
    ("history too long", ["history=2", "history + 1"]),
    ("history too long, whole record", ["has 2 samples", "history is 2"]),
    ("rollout history too long", ["has 2 samples", "history is 2"]),
    ("other nodes", ["rod of 9 nodes", "trained on one of 6"]),
    ("other units", ["positions in 'm'", "trained on 'mm'"]),
    ("other dt", ["sampled every 0.01 s", "steps of 0.001 s"]),
    ("rollout start in the seed", ["--start=0.0", "seed the history"]),
    ("no model folder", ["no such model folder"]),
    ("bad shared nodes", ["--shared-nodes='1-x'"]),
])
def test_bad_input_is_one_line_exit_2(files, case, words, capsys):
    tmp, data, folders = files
    ds = node_dataset(T=80)
    model = folders[3]
    argv = ["evaluate", str(model), str(data), "--quiet"]
    if case in ("node not stored", "neighbour not stored"):
        n = 3 if case == "node not stored" else 4
        sub = Dataset(time=ds.time, nodes=ds.nodes[:n], positions=ds.positions[:, :n],
                      quaternions=ds.quaternions[:, :n], forces=ds.forces[:, :n], torques=ds.torques[:, :n],
                      attrs=ds.attrs)
        argv[2] = str(save_h5(tmp / "sub.h5", sub))
    elif case.startswith("history too long") or case.startswith("rollout history"):
        short = Dataset(time=ds.time[:2], nodes=ds.nodes, positions=ds.positions[:2], quaternions=ds.quaternions[:2],
                        forces=ds.forces[:2], torques=ds.torques[:2], attrs=ds.attrs)
        argv[2] = str(save_h5(tmp / "short.h5", short))
        if case.endswith("whole record"):
            argv.append("--generalisation")
        if case.startswith("rollout"):
            argv = ["rollout", str(model), argv[2], "-o", str(tmp / "p.h5"), "--quiet"]
    elif case == "other nodes":
        argv[2] = str(save_h5(tmp / "nine.h5", node_dataset(T=80, n=9)))
    elif case in ("other units", "other dt"):
        meta = {"units": dict(UNITS, positions="mm")} if case == "other units" else {"dt": 0.001}
        save_model(tmp / "odd", real_model(ds, SampleSpec(node=3, history=2, wrench="force"), meta=meta))
        argv[1] = str(tmp / "odd")
    elif case == "rollout start in the seed":
        argv = ["rollout", str(model), str(data), "-o", str(tmp / "p.h5"), "--start", "0", "--quiet"]
    elif case == "no model folder":
        argv[1] = str(tmp / "missing")
    elif case == "bad shared nodes":
        argv = ["rollout", str(model), str(data), "-o", str(tmp / "p.h5"), "--shared", str(folders[2]),
                "--shared-nodes", "1-x"]
    assert run_cli(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith("softrnn: error:"), err
    for w in words:
        assert w in err, err
    assert not (tmp / "p.h5").exists()
