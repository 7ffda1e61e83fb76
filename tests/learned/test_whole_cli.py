"""softrnn dynamic train|evaluate|rollout|export in-process on tiny data: a model folder that
records its held-out variants, the evaluation table and JSON, a rollout that reads back as a data
set, an ONNX step that agrees with the NumPy engine, resuming, and one-line errors (exit 2, no
file left behind)."""

import contextlib
import io
import json
from dataclasses import replace

import numpy as np
import pytest

from softrnn.io import read_dataset, write_dataset
from softrnn.scenarios.scenario import load_scenario
from softrnn.scenarios.summary import simulate_summary

from helpers import run_cli

pytest.importorskip("torch")
pytest.importorskip("onnxruntime")

TINY = ["--steps", "5", "--model-dt", "0.02", "--node-stride", "10", "--width", "8", "--layers", "1", "--unroll", "2",
        "--threads", "1", "--quiet"]


def _simulate(scenario, path) -> None:
    """61 samples every 10 ms (0.6 s) of every node."""
    config = replace(scenario.config, dt=0.01, n_samples=61)
    simulate_summary(name=scenario.name, title=scenario.title, setup=scenario.setup, config=config,
                     node=scenario.nodes_of_interest[0], out_path=str(path), scenario_text=scenario.text,
                     seed=scenario.seed, attrs={"scenario_name": scenario.name})


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    """one.h5 (the square scenario), a sweep folder of three variants and some-nodes.h5 (3 nodes of one.h5)."""
    root = tmp_path_factory.mktemp("data")
    scenario = load_scenario("square")
    _simulate(scenario, root / "one.h5")
    (root / "sweep").mkdir()
    for i in range(3):
        _simulate(scenario.variant(i), root / "sweep" / f"traj-{i:05d}.h5")
    write_dataset(root / "some-nodes.h5", read_dataset(root / "one.h5", nodes=[0, 25, 50]))
    return root


def _train(data, out, *extra) -> tuple[int, str]:
    text = io.StringIO()
    with contextlib.redirect_stdout(text):
        code = run_cli(["dynamic", "train", str(data / "sweep"), str(data / "one.h5"), "-o", str(out),
                        "--heldout", "1", *TINY, *extra])
    return code, text.getvalue()


@pytest.fixture(scope="module")
def model(data, tmp_path_factory):
    """A model trained for 5 steps on the sweep's first two variants and 60 % of one.h5."""
    out = tmp_path_factory.mktemp("models") / "model"
    code, text = _train(data, out)
    assert code == 0, text
    return out, text


def _one_line_error(capsys, *words) -> str:
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert err.startswith("softrnn: error:") and "Traceback" not in err
    for w in words:
        assert w in err, err
    return err


def test_the_envelope_and_the_prior_can_be_switched_off(data, tmp_path):
    from safetensors.numpy import load_file

    code, text = _train(data, tmp_path / "m", "--envelope", "off", "--prior-tau", "OFF")
    assert code == 0, text
    config = json.loads((tmp_path / "m" / "model.json").read_text())["config"]
    assert config["envelope"] is None and config["prior_tau"] is None
    assert "env_lo" not in load_file(str(tmp_path / "m" / "weights.safetensors"))
    code, text = _train(data, tmp_path / "n", "--envelope", "0.5", "--prior-tau", "2")
    assert code == 0, text
    config = json.loads((tmp_path / "n" / "model.json").read_text())["config"]
    assert config["envelope"] == 0.5 and config["prior_tau"] == 2.0


def test_the_fit_and_training_options_reach_the_config(data, tmp_path):
    code, text = _train(data, tmp_path / "m", "--ridge", "1e-2", "--load-ridge", "1e-4", "--linear-lr", "0.1",
                        "--conv-reads", "loads", "--start-fraction", "0.25")
    assert code == 0, text
    doc = json.loads((tmp_path / "m" / "model.json").read_text())
    config = doc["config"]
    assert (config["ridge"], config["load_ridge"], config["linear_lr"]) == (1e-2, 1e-4, 0.1)
    assert config["conv_reads"] == "loads" and config["start_fraction"] == 0.25
    assert doc["meta"]["training"]["ridge"] >= 1e-2       # the network's ladder starts at --ridge


def test_train_writes_a_model_folder_that_records_the_heldout_variant(model, data):
    folder, text = model
    assert sorted(p.name for p in folder.iterdir()) == ["linear.safetensors", "model.json", "weights.safetensors"]
    assert "5 steps" in text and "model_dt 0.02 s" in text and "nodes predicted" in text and "1 held out" in text
    doc = json.loads((folder / "model.json").read_text())
    assert doc["format"] == "softrnn-dynamic-model" and doc["config"]["steps"] == 5
    held = [e["path"] for e in doc["meta"]["data"]["heldout"]]
    assert held == [str(data / "sweep" / "traj-00002.h5")]
    trained = {e["path"]: e["stop"] for e in doc["meta"]["data"]["train"]}
    assert trained[str(data / "one.h5")] == 37                      # 60 % of 61 samples


def test_evaluate_prints_the_table_and_writes_json(model, data, tmp_path, capsys):
    out = tmp_path / "eval.json"
    code = run_cli(["dynamic", "evaluate", str(model[0]), "--test", str(data / "one.h5"), "--heldout",
                    str(data / "sweep" / "traj-00002.h5"), "--generalisation", str(data / "sweep" / "traj-00002.h5"),
                    "-o", str(out)])
    assert code == 0
    text = capsys.readouterr().out
    for words in ("persistence", "const. vel.", "linear", "test span 0.36..0.6 s", "held out (1): worst",
                  "generalisation", "at 10 steps (0.2 s)", "at 1000 steps"):
        assert words in text, text
    report = json.loads(out.read_text())
    assert report["predicted_nodes"] < report["nodes"] == 51
    assert report["heldout"]["variants"] == 1 and set(report["horizons"]["10"]) == {
        "model", "persistence", "constant_velocity", "linear"}
    assert report["test_span"]["model"]["max_pct_of_length"] > 0


@pytest.mark.parametrize("args, words", [
    (["--heldout", "{sweep}"], ["--heldout=", "traj-00000.h5", "trained on it"]),
    (["--generalisation", "{sweep}/traj-00001.h5"], ["--generalisation=", "trained on it"]),
    (["--test", "{one}", "--start", "0.3"], ["--start=0.3", "trained part", ">= 0.36 s"]),
    (["--heldout", "{one}"], ["--heldout=", "one.h5", "trained on it"]),
])
def test_evaluate_refuses_data_the_model_saw(model, data, tmp_path, capsys, args, words):
    out = tmp_path / "eval.json"
    args = [a.format(sweep=data / "sweep", one=data / "one.h5") for a in args]
    assert run_cli(["dynamic", "evaluate", str(model[0]), *args, "--json", str(out)]) == 2
    _one_line_error(capsys, *words)
    assert not out.exists()


def test_rollout_writes_a_data_set_of_every_node(model, data, tmp_path, capsys):
    out = tmp_path / "pred.h5"
    assert run_cli(["dynamic", "rollout", str(model[0]), str(data / "one.h5"), "-o", str(out)]) == 0
    assert "wrote" in capsys.readouterr().out
    pred, ref = read_dataset(out), read_dataset(data / "one.h5")
    assert pred.nodes.tolist() == list(range(51))
    np.testing.assert_allclose(np.diff(pred.time), 0.02, atol=1e-12)
    assert pred.time[0] == pytest.approx(0.36) and pred.time[-1] == pytest.approx(0.6)
    np.testing.assert_allclose(np.linalg.norm(pred.quaternions, axis=-1), 1.0, atol=1e-6)
    rows = np.rint(pred.time / 0.01).astype(int)
    np.testing.assert_array_equal(pred.forces, ref.forces[rows])
    assert pred.attrs["rollout"] == "dynamic" and pred.attrs["model"] == str(model[0])
    assert pred.attrs["start_time_s"] == pytest.approx(0.36) and pred.dt == pytest.approx(0.02)
    err = np.abs(pred.positions[0] - ref.positions[rows[0]]).max()
    assert err < 1e-3                      # the start state is the data's, through the encoding
    assert run_cli(["show", str(out)]) == 0


def test_a_diverging_rollout_is_one_line_naming_the_time(model, data, tmp_path, capsys, monkeypatch):
    import softrnn.learned.whole.rollout as rollout
    from softrnn.learned.horizons import RolloutDiverged

    def diverging(predictor, traj, wrenches, start, stop):
        raise RolloutDiverged("diverged", node=0, sample=start + 2, time=float(traj.time[start + 2]),
                              states=np.full((stop - start,) + traj.states.shape[1:], np.nan))

    monkeypatch.setattr(rollout, "free_run", diverging)
    out = tmp_path / "pred.h5"
    assert run_cli(["dynamic", "rollout", str(model[0]), str(data / "one.h5"), "-o", str(out),
                    "--start", "0.2"]) == 2
    _one_line_error(capsys, "diverged at t = 0.26 s", "nothing was written")
    assert list(tmp_path.iterdir()) == []


def _onnx_against_engine(folder, onnx_path, data) -> float:
    """Largest difference between ONNX Runtime and the engine on real states of one.h5."""
    import onnxruntime

    from softrnn.learned.whole.artifact import load_dynamic

    loaded = load_dynamic(folder)
    traj = loaded.encoding.trajectory(read_dataset(data / "one.h5"))
    H, s = loaded.config.history, 20
    feeds = {"history": traj.states[s - H + 1:s + 1][None].astype(np.float32),
             "loads": traj.loads[s][None].astype(np.float32)}
    memory = None
    if loaded.config.memory == "lstm":
        rng = np.random.default_rng(1)
        memory = tuple(rng.uniform(-0.5, 0.5, (loaded.encoding.n_kept, loaded.config.width)) for _ in range(2))
        feeds.update(memory_h=memory[0][None].astype(np.float32), memory_c=memory[1][None].astype(np.float32))
    session = onnxruntime.InferenceSession(str(onnx_path), providers=["CPUExecutionProvider"])
    got = session.run(None, feeds)
    nxt, memory = loaded.engine.step(feeds["history"][0].astype(np.float64), feeds["loads"][0].astype(np.float64),
                                     None if memory is None else tuple(m.astype(np.float32) for m in memory))
    want = [nxt] + ([] if memory is None else list(memory))
    assert len(got) == len(want)
    return max(float(np.abs(g[0] - w).max()) for g, w in zip(got, want))


def test_export_agrees_with_the_engine(model, data, tmp_path, capsys):
    out = tmp_path / "step.onnx"
    assert run_cli(["dynamic", "export", str(model[0]), "--onnx", str(out)]) == 0
    assert "largest difference" in capsys.readouterr().out
    sidecar = json.loads((tmp_path / "step.onnx.json").read_text())
    assert sidecar["format"] == "softrnn-dynamic-model-export" and sidecar["inputs"]["history"][1] == 3
    assert len(sidecar["encoding"]["kept"]) == len(sidecar["lumping"])
    assert _onnx_against_engine(model[0], out, data) < 1e-5
    assert run_cli(["dynamic", "export", str(model[0]), "--onnx", str(out)]) == 2      # exists: refused
    _one_line_error(capsys, "--onnx=", "--overwrite")


def test_an_lstm_model_exports_its_memory(data, tmp_path, capsys):
    folder = tmp_path / "lstm"
    code, text = _train(data, folder, "--memory", "lstm", "--history", "2")
    assert code == 0, text
    out = tmp_path / "lstm.onnx"
    assert run_cli(["dynamic", "export", str(folder), "--onnx", str(out)]) == 0
    assert "memory_h_out" in capsys.readouterr().out
    assert _onnx_against_engine(folder, out, data) < 1e-5


def test_an_interrupted_training_resumes_to_the_same_weights(model, data, tmp_path, capsys, monkeypatch):
    from safetensors.numpy import load_file

    import softrnn.cli._dynamic as dynamic_cli
    import softrnn.learned.whole.training as training

    monkeypatch.setattr(training, "CHECKPOINT_EVERY", 2)
    plain = dynamic_cli._StepBar.__call__
    stop_at = [1]

    def interrupt(self, done, total, info=None):
        if done == stop_at[0]:
            raise KeyboardInterrupt
        plain(self, done, total, info)

    folder = tmp_path / "model"
    monkeypatch.setattr(dynamic_cli._StepBar, "__call__", interrupt)
    assert _train(data, folder)[0] == 130                                   # before the first checkpoint
    assert "nothing was kept" in capsys.readouterr().err and not folder.exists()
    stop_at[0] = 3
    assert _train(data, folder)[0] == 130                                   # after the checkpoint of step 2
    assert "--resume" in capsys.readouterr().err
    assert sorted(p.name for p in folder.iterdir()) == ["checkpoint.json", "checkpoint.pt"]
    assert _train(data, folder)[0] == 2                                     # neither --resume nor --overwrite
    _one_line_error(capsys, "-o=", "--resume")
    assert _train(data, folder, "--resume", "--seed", "1")[0] == 2          # other settings
    _one_line_error(capsys, "--resume=True", "config.seed: 0 then, 1 now")
    monkeypatch.setattr(dynamic_cli._StepBar, "__call__", plain)
    assert _train(data, folder, "--resume")[0] == 0
    assert not (folder / "checkpoint.pt").exists()
    a, b = load_file(str(model[0] / "weights.safetensors")), load_file(str(folder / "weights.safetensors"))
    assert a.keys() == b.keys() and all(np.array_equal(a[k], b[k]) for k in a)
    files = {p.name: p.read_bytes() for p in folder.iterdir()}
    assert _train(data, folder, "--resume")[0] == 2                          # finished: nothing left to train
    _one_line_error(capsys, "--resume=True", "already ran its", "--overwrite")
    assert {p.name: p.read_bytes() for p in folder.iterdir()} == files


@pytest.mark.parametrize("argv, words", [
    (["train", "{sweep}", "--steps", "-1"], ["--steps=-1", ">= 0"]),
    (["train", "{sweep}", "--model-dt", "0.015"], ["--model-dt=0.015", "whole multiple", "0.01 s"]),
    (["train", "{sweep}", "--heldout", "3"], ["--heldout=3", "variants"]),
    (["train", "{sweep}/nothing.h5"], ["DATA=", "nothing.h5"]),
    (["train", "{sweep}", "--threads", "0"], ["--threads=0", ">= 1"]),
    (["train", "{sweep}", "--memory", "gru"], ["invalid choice", "softrnn dynamic train --help"]),
    (["train", "{sweep}", "--envelope", "0"], ["--envelope=0", "positive"]),
    (["train", "{sweep}", "--prior-tau", "soon"], ["--prior-tau", "'soon'"]),
    (["train", "{sweep}", "--start-fraction", "1"], ["--start-fraction=1.0", "[0, 1)"]),
    (["train", "{sweep}", "--load-ridge", "-1"], ["--load-ridge=-1.0", ">= 0"]),
    (["evaluate", "{model}"], ["nothing to evaluate: give --test FILE, --heldout PATH ... or --generalisation FILE"]),
    (["evaluate", "{model}", "--test", "{one}", "--start", "1.5"], ["--start=1.5", "a time in [0, 0.58] s"]),
    (["evaluate", "{sweep}", "--test", "{one}"], ["model.json is missing"]),
    (["evaluate", "{model}", "--generalisation", "{sub}"], ["--generalisation=", "every node 0..50"]),
    (["rollout", "{model}", "{sub}"], ["DATA=", "every node 0..50"]),
    (["rollout", "{model}", "{one}", "--start", "0.0"], ["--start=0.0", "states"]),
    (["rollout", "{model}", "{one}", "--stop", "9"], ["--stop=9.0", "data's end"]),
    (["rollout", "{model}", "{one}", "--format-txt"], ["unrecognized arguments"]),
    (["export", "{model}", "--onnx", "{model}/step.onnx"], ["--onnx=", "outside the model folder"]),
    ([], ["dynamic", "required"]),
])
def test_bad_input_is_one_line_exit_2_and_leaves_nothing(model, data, tmp_path, capsys, argv, words):
    names = {"sweep": data / "sweep", "one": data / "one.h5", "sub": data / "some-nodes.h5", "model": model[0]}
    argv = [a.format(**names) for a in argv]
    out = tmp_path / "out"
    outputs = {"train": ["-o", str(out)], "evaluate": ["--json", str(out) + ".json"],
               "rollout": ["-o", str(out) + ".h5"]}
    before = sorted(p.name for p in model[0].iterdir())
    assert run_cli(["dynamic", *argv, *outputs.get(argv[0] if argv else "", [])]) == 2
    _one_line_error(capsys, *words)
    assert list(tmp_path.iterdir()) == []
    assert sorted(p.name for p in model[0].iterdir()) == before


def test_a_rollout_needs_an_h5_output_and_export_the_learn_extra(model, data, tmp_path, capsys, monkeypatch):
    import importlib.util

    assert run_cli(["dynamic", "rollout", str(model[0]), str(data / "one.h5"), "-o", str(tmp_path / "p.txt")]) == 2
    _one_line_error(capsys, "-o=", ".h5")
    find = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "onnxruntime" else find(name, *a))
    assert run_cli(["dynamic", "export", str(model[0]), "--onnx", str(tmp_path / "x.onnx")]) == 2
    _one_line_error(capsys, "onnxruntime", "softrnn[learn]")
    assert list(tmp_path.iterdir()) == []
