"""``softrnn train --validate-on`` / ``softrnn dynamic train --validate-on`` and the evaluation of a
separate test session in-process on tiny data: the model records both files, a separate file is
evaluated whole from its start, the training file is said to be training data, the Euclidean tip
error is reported, and a mismatched validation recording is one line (exit 2, nothing written)."""

import contextlib
import io
import json
from dataclasses import replace

import numpy as np
import pytest

from softrnn.io import Dataset, read_dataset, write_dataset

from helpers import node_dataset, run_cli, save_h5

pytest.importorskip("torch")

T = 120
NODE_TINY = ["--node", "2", "--epochs", "2", "--units", "8", "--layers", "1", "--dense", "8", "--rollout-steps", "1",
             "--quiet"]


def _run(argv) -> tuple[int, str]:
    text = io.StringIO()
    with contextlib.redirect_stdout(text):
        code = run_cli(argv)
    return code, text.getvalue()


def _one_line_error(capsys, *words) -> str:
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert err.startswith("softrnn: error:") and "Traceback" not in err
    for w in words:
        assert w in err, err
    return err


def _with_actuation(ds: Dataset, names) -> Dataset:
    act = np.stack([np.sin(ds.time * (1 + j)) for j in range(len(names))], axis=1)
    return Dataset(time=ds.time, nodes=ds.nodes, positions=ds.positions, quaternions=ds.quaternions, forces=ds.forces,
                   torques=ds.torques, attrs=ds.attrs, actuation=act, actuation_units=dict.fromkeys(names, "N"))


@pytest.fixture(scope="module")
def sessions(tmp_path_factory):
    root = tmp_path_factory.mktemp("sessions")
    ds = node_dataset(T=T)
    save_h5(root / "train.h5", ds)
    save_h5(root / "val.h5", Dataset(time=ds.time, nodes=ds.nodes, positions=ds.positions + 0.002,
                                     quaternions=ds.quaternions, forces=ds.forces, torques=ds.torques, attrs=ds.attrs))
    other = node_dataset(T=T + 30)
    save_h5(root / "test.h5", Dataset(time=other.time, nodes=other.nodes, positions=other.positions[::-1].copy(),
                                      quaternions=other.quaternions, forces=other.forces, torques=other.torques,
                                      attrs=other.attrs))
    save_h5(root / "act.h5", _with_actuation(ds, ("tendon_1", "tendon_2")))
    save_h5(root / "act-other.h5", _with_actuation(ds, ("tendon_1", "p_chamber")))
    return root


@pytest.fixture(scope="module")
def node_model(sessions, tmp_path_factory):
    out = tmp_path_factory.mktemp("node") / "model"
    code, text = _run(["train", str(sessions / "train.h5"), "--validate-on", str(sessions / "val.h5"), "-o", str(out),
                       *NODE_TINY])
    assert code == 0, text
    assert "every sample of train.h5 trained on, validation samples all of val.h5 (0..119), no test span" in text
    return out


def test_train_records_both_sessions(node_model, sessions):
    meta = json.loads((node_model / "meta.json").read_text())
    assert meta["training_data"]["span"] == "whole record"
    assert meta["training_data"]["train"]["path"] == str(sessions / "train.h5")
    assert meta["training_data"]["validation"]["path"] == str(sessions / "val.h5")
    assert meta["spans"]["fit"] == [0, T]


def test_evaluate_a_test_session_covers_the_whole_file(node_model, sessions, tmp_path):
    out = tmp_path / "e.json"
    code, text = _run(["evaluate", str(node_model), str(sessions / "test.h5"), "--json", str(out), "--quiet"])
    assert code == 0, text
    r = json.loads(out.read_text())
    assert r["span"] == "whole record" and r["span_samples"] == [2, T + 29] and r["n_targets"] == T + 28
    assert r["linear_fitted_on"] == "training data" and r["baselines"]["linear"]["fitted_on"]["samples"] == [0, T]
    for block in [r["one_step"], r["free_running"]] + [b["one_step"] for b in r["baselines"].values()]:
        assert block["rmse_euclidean_mm"] == pytest.approx(np.sqrt(3) * block["rmse_mm"])
        assert block["mean_euclidean_mm"] <= block["rmse_euclidean_mm"] + 1e-12
        assert block["rmse_euclidean_pct_of_length"] is not None
    assert "free running from the record's start: its first 2 samples are the initial condition" in text
    assert "Euclidean error over the span (RMSE, mean): one step" in text
    assert "free running Euclidean RMSE [mm]" in text


def test_evaluate_on_the_training_session_says_so(node_model, sessions):
    code, text = _run(["evaluate", str(node_model), str(sessions / "train.h5"), "--no-free-running", "--quiet"])
    assert code == 0, text
    assert "span: training data, samples 2..119" in text and "TRAINING data" in text


def test_a_validation_session_of_other_channels_is_refused(sessions, tmp_path, capsys):
    out = tmp_path / "model"
    code = run_cli(["train", str(sessions / "act.h5"), "--drive", "actuation", "--validate-on",
                    str(sessions / "act-other.h5"), "-o", str(out), *NODE_TINY])
    assert code == 2
    _one_line_error(capsys, "--validate-on=", "act-other.h5", "tendon_2", "validate on a session")
    assert not out.exists()
    code = run_cli(["train", str(sessions / "train.h5"), "--validate-on", str(tmp_path / "missing.h5"), "-o", str(out),
                    *NODE_TINY])
    assert code == 2
    _one_line_error(capsys, "--validate-on=", "missing.h5", "an existing data set file")
    assert not out.exists()
    assert run_cli(["train", str(sessions / "train.h5"), "--validate-group", "traj-00000", "-o", str(out),
                    *NODE_TINY]) == 2
    _one_line_error(capsys, "--validate-group", "--validate-on")


def test_without_validate_on_the_split_of_one_record_is_kept(sessions, tmp_path):
    code, text = _run(["train", str(sessions / "train.h5"), "-o", str(tmp_path / "m"), *NODE_TINY])
    assert code == 0, text
    assert "validation samples 57..71, test samples 72..119" in text
    meta = json.loads((tmp_path / "m" / "meta.json").read_text())
    assert "training_data" not in meta and meta["test_span"] == [72, T]
    code, text = _run(["evaluate", str(tmp_path / "m"), str(sessions / "train.h5"), "--json",
                       str(tmp_path / "e.json"), "--quiet", "--no-free-running"])
    r = json.loads((tmp_path / "e.json").read_text())
    assert r["span"] == "test" and r["span_samples"] == [74, T - 1] and r["linear_fitted_on"] == "training data"
    assert r["baselines"]["linear"]["fitted_on"]["samples"] == [0, 72]


# ------------------------------------------------------------------------------------------ whole model
DYN_TINY = ["--steps", "5", "--model-dt", "0.02", "--node-stride", "10", "--width", "8", "--layers", "1", "--unroll",
            "2", "--threads", "1", "--quiet"]


def _simulate(scenario, path) -> None:
    from softrnn.scenarios.summary import simulate_summary

    config = replace(scenario.config, dt=0.01, n_samples=61)
    simulate_summary(name=scenario.name, title=scenario.title, setup=scenario.setup, config=config,
                     node=scenario.nodes_of_interest[0], out_path=str(path), scenario_text=scenario.text,
                     seed=scenario.seed, attrs={"scenario_name": scenario.name})


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """Three sessions of the square scenario (variants 0, 1, 2) and some-nodes.h5 (3 nodes of the first)."""
    from softrnn.scenarios.scenario import load_scenario

    root = tmp_path_factory.mktemp("runs")
    scenario = load_scenario("square")
    for i, name in enumerate(("train", "val", "test")):
        _simulate(scenario.variant(i), root / f"{name}.h5")
    write_dataset(root / "some-nodes.h5", read_dataset(root / "val.h5", nodes=[0, 25, 50]))
    return root


@pytest.fixture(scope="module")
def dyn_model(runs, tmp_path_factory):
    out = tmp_path_factory.mktemp("dyn") / "model"
    code, text = _run(["dynamic", "train", str(runs / "train.h5"), "--validate-on", str(runs / "val.h5"), "-o",
                       str(out), *DYN_TINY])
    assert code == 0, text
    assert "1 training trajectories (every sample trained on), 1 for validation (1 separate recording: val.h5)" in text
    return out


def test_dynamic_train_validates_on_the_separate_recording(dyn_model, runs):
    data = json.loads((dyn_model / "model.json").read_text())["meta"]["data"]
    assert [(p["path"], p["stop"]) for p in data["train"]] == [(str(runs / "train.h5"), None)]
    assert [p["path"] for p in data["validation"]] == [p["path"] for p in data["validate_on"]] == [str(runs / "val.h5")]


def test_dynamic_evaluate_runs_a_separate_test_file_from_its_start(dyn_model, runs, tmp_path, capsys):
    out = tmp_path / "e.json"
    code, text = _run(["dynamic", "evaluate", str(dyn_model), "--test", str(runs / "test.h5"), "--json", str(out)])
    assert code == 0, text
    r = json.loads(out.read_text())
    t = r["test_span"]
    assert t["span"] == "whole record" and t["start_s"] == pytest.approx(0.02 * (r["history"] - 1))
    for name in ("model", "persistence", "constant_velocity", "linear"):
        for block in (t[name], t[name]["one_step"]):
            assert set(block) >= {"rmse_euclidean_mm", "mean_euclidean_mm", "rmse_euclidean_pct_of_length"}
    assert "test file (whole)" in text and "Euclidean RMSE [mm]" in text
    code = run_cli(["dynamic", "evaluate", str(dyn_model), "--test", str(runs / "train.h5")])
    assert code == 2
    _one_line_error(capsys, "--test", "trained on all of it")


def test_dynamic_train_refuses_a_validation_recording_of_other_nodes(runs, tmp_path, capsys):
    out = tmp_path / "model"
    code = run_cli(["dynamic", "train", str(runs / "train.h5"), "--validate-on", str(runs / "some-nodes.h5"), "-o",
                    str(out), *DYN_TINY])
    assert code == 2
    _one_line_error(capsys, "--validate-on=", "some-nodes.h5", "every node")
    assert not out.exists()
    code = run_cli(["dynamic", "train", str(runs / "train.h5"), "--validate-on", str(runs / "val.h5"),
                    "--train-fraction", "0.6", "-o", str(out), *DYN_TINY])
    assert code == 2
    _one_line_error(capsys, "--train-fraction=0.6", "separate validation recordings")
    assert not out.exists()
