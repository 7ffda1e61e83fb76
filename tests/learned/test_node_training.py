"""Training, saving and loading node models: overfitting, determinism, resume, the test span kept
out, model folders (and their corruption), and the ``softrnn train`` command."""

import json
import math
from dataclasses import asdict

import numpy as np
import pytest
import torch

from softrnn.errors import SoftrnnInputError
from softrnn.io import write_trajectory
from softrnn.learned.node._checkpoint import training_settings
from softrnn.learned.node.artifact import CHECKPOINT, FILES, ModelFolderError, NodeModel, load_model, save_model
from softrnn.learned.node.data import SampleSpec, make_windows, split
from softrnn.learned.node.model import ModelConfig, NodeLSTM
from softrnn.learned.node.train import TrainConfig, train_node_model

from helpers import run_cli
from helpers import swinging_rod as synthetic

SMALL = {"lstm_units": 8, "dense_units": (8,), "wrench_dense": (4,)}
FAST = TrainConfig(epochs=3, batch_size=32, patience=10)


@pytest.fixture(scope="module")
def data_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("data") / "synthetic.h5"
    write_trajectory(path, synthetic(300), dt=0.01, attrs={"scenario_name": "synthetic"})
    return path


@pytest.fixture(scope="module")
def trained(data_file, tmp_path_factory):
    folder = tmp_path_factory.mktemp("models") / "n2"
    model = train_node_model(data_file, SampleSpec(node=2, wrench="force"), SMALL, FAST, folder)
    return folder, model


def _state(model: NodeModel) -> dict:
    return {k: v.clone() for k, v in model.module.state_dict().items()}


def _same(a: dict, b: dict) -> bool:
    return a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)


# ----------------------------------------------------------------------------------------- model
@pytest.mark.parametrize("W", [0, 3])
@pytest.mark.parametrize("output", ["increment", "pose"])
def test_module_shapes(W, output):
    config = ModelConfig(pose_features=9, wrench_features=W, history=2, output=output, **SMALL)
    module = NodeLSTM(config)
    y = module(torch.zeros(5, 2, 9), torch.zeros(5, 2, W))                    # (5, 3)
    assert y.shape == (5, 3) and y.dtype == torch.float32
    assert ModelConfig.from_dict(json.loads(json.dumps(config.to_dict()))) == config


@pytest.mark.parametrize("kwargs, word", [({"lstm_units": 0}, "lstm_units"), ({"dense_units": (8, -1)}, "dense_units"),
                                          ({"output": "velocity"}, "output"), ({"history": 0}, "history")])
def test_bad_model_config(kwargs, word):
    base = {"pose_features": 9, "wrench_features": 0, "history": 2}
    with pytest.raises(SoftrnnInputError, match=word):
        ModelConfig(**dict(base, **kwargs))


# ----------------------------------------------------------------------------------------- training
def test_a_model_overfits_a_tiny_dataset(tmp_path):
    """A periodic motion (period 20 samples) of 120 samples: trained one step ahead, the network
    learns its 70 training windows to a few per cent of the motion per step (the validation span
    repeats them, so the best validation epoch is a late one)."""
    data = synthetic(120, freqs=(5.0, 10.0, 5.0, 5.0))
    spec = SampleSpec(node=2, wrench="force")
    train = TrainConfig(epochs=60, batch_size=16, learning_rate=3e-3, patience=1000, rollout_steps=1)
    model = train_node_model(data, spec, {"lstm_units": 16, "dense_units": (16,)}, train, tmp_path / "m")
    fit = make_windows(data, model.spec, *model.meta["spans"]["fit"])
    losses = [h["loss"] for h in model.meta["history"]]
    assert losses[-1] < 0.01 * losses[0]
    err = np.abs(model.predict(fit.poses, fit.wrenches) - fit.targets)       # (M, 3)
    step = np.abs(fit.targets - fit.last_position)                           # (M, 3) the motion per step
    assert err[:, 1:].mean() < 0.05 * step[:, 1:].mean()                     # y and z (x does not move)


def test_the_same_seed_gives_the_same_weights(data_file, tmp_path, trained):
    again = train_node_model(data_file, SampleSpec(node=2, wrench="force"), SMALL, FAST, tmp_path / "again")
    assert _same(_state(again), _state(trained[1]))
    other = train_node_model(data_file, SampleSpec(node=2, wrench="force"), SMALL,
                             TrainConfig(epochs=3, batch_size=32, patience=10, seed=1), tmp_path / "other")
    assert not _same(_state(other), _state(trained[1]))


ONE_STEP_NOISY = TrainConfig(epochs=2, batch_size=32, rollout_steps=1, input_noise=1.0)


@pytest.mark.parametrize("train, relative", [(FAST, False), (ONE_STEP_NOISY, False), (ONE_STEP_NOISY, True)])
def test_no_test_span_sample_reaches_training(tmp_path, train, relative):
    """Every test-span value is NaN: had one reached the normalisation, a gradient step or the
    validation, the statistics, weights or losses would be NaN."""
    n = 200
    cut = split(n, SampleSpec(node=2))[0].stop
    data = synthetic(n, poison_from=cut)
    model = train_node_model(data, SampleSpec(node=2, wrench="wrench", inputs="poses"), dict(SMALL, relative=relative),
                             train, tmp_path / "m")
    norm = model.normalizer.to_dict()
    assert all(np.isfinite(v).all() for v in norm.values() if isinstance(v, list))
    assert all(torch.isfinite(v).all() for v in model.module.state_dict().values())
    assert all(math.isfinite(h["loss"]) and math.isfinite(h["validation_loss"]) for h in model.meta["history"])
    assert model.meta["test_span"] == [cut, n] and model.meta["spans"]["validation"][1] == cut


def test_resume_after_an_interruption_gives_the_same_weights(data_file, tmp_path):
    spec = SampleSpec(node=2, wrench="force")
    train = TrainConfig(epochs=4, batch_size=32, patience=10)
    whole = train_node_model(data_file, spec, SMALL, train, tmp_path / "whole")

    def stop_after_two_epochs(done, total, info=None):
        if (info or {}).get("epoch") == 3:                                # interrupted inside epoch 3
            raise KeyboardInterrupt

    folder = tmp_path / "parts"
    with pytest.raises(KeyboardInterrupt):
        train_node_model(data_file, spec, SMALL, train, folder, progress=stop_after_two_epochs)
    assert (folder / CHECKPOINT).exists() and not (folder / "config.json").exists()
    with pytest.raises(ModelFolderError, match="--resume"):
        load_model(folder)
    ckpt = torch.load(folder / CHECKPOINT, weights_only=True)
    assert ckpt["state"]["epoch"] == 2                            # both finished epochs were kept
    resumed = train_node_model(data_file, spec, SMALL, train, folder, resume=True)
    assert _same(_state(resumed), _state(whole))
    strip = [{k: v for k, v in h.items() if k != "seconds"} for h in resumed.meta["history"]]
    assert strip == [{k: v for k, v in h.items() if k != "seconds"} for h in whole.meta["history"]]
    assert not (folder / CHECKPOINT).exists()
    again = train_node_model(data_file, spec, SMALL, train, folder, resume=True)   # finished: loaded as is
    assert _same(_state(again), _state(whole))
    with pytest.raises(ModelFolderError, match="other settings"):
        train_node_model(data_file, spec, dict(SMALL, lstm_units=9), train, folder, resume=True)


def test_resume_with_other_settings_is_refused(data_file, tmp_path):
    spec = SampleSpec(node=2, wrench="force")

    def interrupt(done, total, info=None):
        if (info or {}).get("epoch") == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        train_node_model(data_file, spec, SMALL, FAST, tmp_path / "m", progress=interrupt)
    with pytest.raises(ModelFolderError, match="history"):
        train_node_model(data_file, SampleSpec(node=2, wrench="force", history=3), SMALL, FAST, tmp_path / "m",
                         resume=True)


def test_a_finished_model_trains_on_with_more_epochs_and_refuses_fewer(trained, data_file, tmp_path, capsys):
    folder = tmp_path / "m"
    save_model(folder, trained[1])
    spec = SampleSpec(node=2, wrench="force")
    with pytest.raises(ModelFolderError, match=r"already ran 3 epochs, and --epochs 2 leaves nothing to train"):
        train_node_model(data_file, spec, SMALL, TrainConfig(epochs=2, batch_size=32, patience=10), folder,
                         resume=True)
    same = train_node_model(data_file, spec, SMALL, FAST, folder, resume=True)         # the same: loaded as is
    assert _same(_state(same), _state(trained[1]))
    more = train_node_model(data_file, spec, SMALL, TrainConfig(epochs=5, batch_size=32, patience=10), folder,
                            resume=True)
    assert more.meta["epochs_run"] == 5 and more.meta["continued_after_epoch"] == 3
    assert more.meta["history"][:3] == trained[1].meta["history"]
    out = tmp_path / "cli"
    argv = ["train", str(data_file), "--node", "2", "-o", str(out), "--units", "8", "--dense", "8",
            "--batch-size", "64", "--quiet"]
    assert run_cli(argv + ["--epochs", "2"]) == 0
    files = {p.name: p.read_bytes() for p in out.iterdir()}
    capsys.readouterr()
    assert run_cli(argv + ["--epochs", "2", "--threads", "2", "--resume"]) == 2       # the same: nothing to do
    err = capsys.readouterr().err.strip()
    assert err.startswith("softrnn: error:") and "\n" not in err and "already ran 2 epochs" in err
    assert {p.name: p.read_bytes() for p in out.iterdir()} == files                  # nothing written


def test_the_checkpoint_settings_keep_the_layout_of_earlier_releases(data_file, tmp_path):
    spec = SampleSpec(node=2, wrench="force").resolve(list(range(5)))
    config = ModelConfig(pose_features=spec.pose_features, wrench_features=spec.wrench_features, history=2, **SMALL)
    earlier = {"spec": spec.to_dict(), "model": config.to_dict(),                    # as the last release stored it
               "train": {k: v for k, v in asdict(FAST).items() if k not in ("epochs", "patience", "threads")},
               "data": "f00", "pool": None}
    record = training_settings(spec, config, FAST, "f00", None)
    assert record.to_json() == json.loads(json.dumps(earlier))
    assert record.like(earlier) == record


# ----------------------------------------------------------------------------------------- folders
def test_save_and_load_give_identical_predictions(trained, data_file, tmp_path):
    folder, model = trained
    assert sorted(p.name for p in folder.iterdir()) == sorted(FILES)
    loaded = load_model(folder)
    data = synthetic(300)
    w = make_windows(data, loaded.spec, 150, 300)
    a, b = model.predict(w.poses, w.wrenches), loaded.predict(w.poses, w.wrenches)
    assert a.shape == (len(w), 3) and a.dtype == np.float64 and np.array_equal(a, b)
    assert loaded.spec == model.spec and loaded.config == model.config and not loaded.module.training
    meta = loaded.meta
    assert meta["dataset"]["file"] == "synthetic.h5" and meta["dataset"]["scenario_name"] == "synthetic"
    assert meta["dataset"]["units"]["positions"] == "m" and meta["dataset"]["dt"] == pytest.approx(0.01)
    assert meta["test_span"] == [180, 300] and len(meta["history"]) == meta["epochs_run"] == 3
    save_model(tmp_path / "copy", loaded)                                     # a loaded model saves again
    assert np.array_equal(load_model(tmp_path / "copy").predict(w.poses, w.wrenches), a)


def test_predict_checks_shapes(trained):
    model = trained[1]
    with pytest.raises(SoftrnnInputError, match="poses"):
        model.predict(np.zeros((4, 3, 9)), np.zeros((4, 3, 3)))
    with pytest.raises(SoftrnnInputError, match="wrenches"):
        model.predict(np.zeros((4, 2, 9)), None)


def _corrupt(folder, how):
    if how == "no config":
        (folder / "config.json").unlink()
    elif how == "garbage config":
        (folder / "config.json").write_text("{not json")
    elif how == "foreign config":
        (folder / "config.json").write_text(json.dumps({"format": "keras", "layers": []}))
    elif how == "newer config":
        c = json.loads((folder / "config.json").read_text())
        (folder / "config.json").write_text(json.dumps(dict(c, format_version=99)))
    elif how == "no weights":
        (folder / "weights.safetensors").unlink()
    elif how == "truncated weights":
        data = (folder / "weights.safetensors").read_bytes()
        (folder / "weights.safetensors").write_bytes(data[:len(data) // 2])
    elif how == "other weights":
        c = json.loads((folder / "config.json").read_text())
        c["model"]["lstm_units"] = 9
        (folder / "config.json").write_text(json.dumps(c))
    elif how == "bad normalizer":
        (folder / "normalizer.json").write_text(json.dumps({"pose_mean": [1.0]}))
    elif how == "no meta":
        (folder / "meta.json").unlink()


@pytest.mark.parametrize("how, file", [
    ("no config", "config.json"), ("garbage config", "config.json"), ("foreign config", "config.json"),
    ("newer config", "config.json"), ("no weights", "weights.safetensors"),
    ("truncated weights", "weights.safetensors"), ("other weights", "weights.safetensors"),
    ("bad normalizer", "normalizer.json"), ("no meta", "meta.json")])
def test_corrupt_model_folders_are_one_line_errors(trained, tmp_path, how, file):
    folder = tmp_path / "m"
    save_model(folder, trained[1])
    _corrupt(folder, how)
    with pytest.raises(ModelFolderError) as err:
        load_model(folder)
    text = str(err.value)
    assert "\n" not in text and str(folder) in text and file in text


def test_missing_and_file_folders(tmp_path):
    with pytest.raises(ModelFolderError, match="no such model folder"):
        load_model(tmp_path / "nothing")
    (tmp_path / "f").write_text("x")
    with pytest.raises(ModelFolderError, match="not a model folder"):
        load_model(tmp_path / "f")


def test_a_folder_of_other_files_is_never_replaced(trained, tmp_path):
    folder = tmp_path / "mine"
    folder.mkdir()
    (folder / "thesis.tex").write_text("precious")
    with pytest.raises(ModelFolderError, match="not a softrnn model"):
        save_model(folder, trained[1])
    assert (folder / "thesis.tex").read_text() == "precious"
    save_model(tmp_path / "m", trained[1])
    save_model(tmp_path / "m", trained[1])                                    # a model folder is replaced
    assert sorted(p.name for p in (tmp_path / "m").iterdir()) == sorted(FILES)
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]     # no temporary folders left


# ----------------------------------------------------------------------------------------- CLI
def test_cli_trains_and_reports(data_file, tmp_path, capsys):
    out = tmp_path / "cli"
    argv = ["train", str(data_file), "--node", "2", "-o", str(out), "--epochs", "2", "--units", "8",
            "--dense", "8", "--batch-size", "64", "--quiet"]
    assert run_cli(argv) == 0
    text = capsys.readouterr().out
    assert "best validation loss" in text and str(out) in text and "node 2 <- 1, 3" in text
    model = load_model(out)
    assert model.spec.wrench == "force" and model.config.lstm_units == 8 and model.config.dense_units == (8,)
    assert run_cli(argv + ["--resume"]) == 2                                  # finished: nothing left to train


@pytest.mark.parametrize("extra, words", [
    (["--node", "9"], ["node", "9", "stored nodes: 0..4"]),
    (["--node", "2", "--history", "200"], ["history=200", "shorter history"]),
    (["--node", "2", "--neighbours", "1,x"], ["--neighbours", "comma-separated"]),
    (["--node", "2", "--neighbours", "1,7"], ["node 7 is not stored"]),
    (["--node", "2", "--epochs", "0"], ["epochs=0"]),
    (["--node", "2", "--units", "0"], ["--units=0"]),
    (["--node", "2", "--pool", "1..x"], ["--pool", "A..B"]),
    (["--node", "2", "--pool", "0..3"], ["pool", "node 0", "offsets"]),
])
def test_cli_bad_input_is_one_line_and_exit_2(data_file, tmp_path, capsys, extra, words):
    assert run_cli(["train", str(data_file), "-o", str(tmp_path / "m"), "--quiet"] + extra) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("softrnn: error:") and "\n" not in err and all(w in err for w in words)
    assert not (tmp_path / "m").exists()


@pytest.mark.parametrize("how", ["garbage config", "foreign config", "truncated weights", "foreign folder",
                                 "corrupt checkpoint"])
def test_cli_corrupt_or_foreign_model_folder_exit_2(data_file, trained, tmp_path, capsys, how):
    folder = tmp_path / "m"
    if how == "foreign folder":
        folder.mkdir()
        (folder / "notes.txt").write_text("mine")
    elif how == "corrupt checkpoint":
        folder.mkdir()
        (folder / CHECKPOINT).write_bytes(b"\x00garbage")
    else:
        save_model(folder, trained[1])
        _corrupt(folder, how)
    argv = ["train", str(data_file), "--node", "2", "-o", str(folder), "--epochs", "1", "--quiet", "--resume"]
    argv += ["--units", "8", "--dense", "8"]
    assert run_cli(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("softrnn: error:") and "\n" not in err and str(folder) in err


# ------------------------------------------------------------------------------ pooled (shared) model
def test_a_pooled_model_learns_from_every_pooled_node(tmp_path):
    from softrnn.learned.node.manipulator import Manipulator
    from softrnn.learned.node.rollout import rollout
    from softrnn.learned.node.training_data import pooled_specs, training_windows

    data = synthetic(200)
    spec = SampleSpec(node=2, wrench="force")
    train = TrainConfig(epochs=2, batch_size=32, rollout_steps=1, input_noise=0.5)
    model = train_node_model(data, spec, dict(SMALL, relative=True), train, tmp_path / "shared", pool=[1, 2, 3])
    assert model.meta["pool"] == [1, 2, 3] and model.spec.node == 2 and model.normalizer.relative
    resolved = spec.resolve(data.nodes, n_nodes_total=data.attrs.get("n_nodes_total"))
    one = training_windows(data, resolved, train)[0]
    pooled = training_windows(data, resolved, train, [1, 2, 3])[0]
    assert len(pooled) == 3 * len(one) == model.meta["train_windows"]
    # the windows of node 3 are node 2's spec moved by one node
    moved = [sp.window_nodes for sp in pooled_specs(resolved, [3])]
    assert moved == [(3, 2, 4)]
    np.testing.assert_array_equal(pooled.targets[2 * len(one):], make_windows(data, pooled_specs(resolved, [3])[0],
                                                                              0, len(data.time)).targets[:len(one)])
    manip = Manipulator.of([], shared=model, shared_nodes=[1, 2, 3])
    r = rollout(manip, data, start=150, stop=170)
    assert np.isfinite(r.positions).all() and r.modelled == (1, 2, 3)
    assert load_model(tmp_path / "shared").meta["pool"] == [1, 2, 3]


@pytest.mark.parametrize("output", ["increment", "acceleration"])
def test_the_relative_multi_step_loss_at_one_step_is_the_plain_loss(output):
    from softrnn.learned.node._losses import _RelativeMultiStep
    from softrnn.learned.node.data import Normalizer

    data = synthetic(200)
    spec = SampleSpec(node=2, wrench="force", inputs="poses").resolve(data.nodes, n_nodes_total=5)
    w = make_windows(data, spec, 0, 150)
    norm = Normalizer.fit(w, output=output, relative=True, per_node=7)
    cfg = ModelConfig(pose_features=spec.pose_features, wrench_features=3, history=2, relative=True, output=output)
    torch.manual_seed(0)
    module = NodeLSTM(cfg)
    module.set_normalizer(norm)
    module.eval()
    multi = _RelativeMultiStep(norm, cfg, 1, 0.0)
    with torch.no_grad():
        got = float(multi.loss(module, *multi.tensors(w)))
        z = torch.from_numpy(norm.normalise_poses(w.poses))
        y = torch.from_numpy(norm.normalise_targets(w.targets, w.poses))
        want = float(torch.mean((module(z, torch.from_numpy(norm.normalise_wrenches(w.wrenches))) - y) ** 2))
    assert got == pytest.approx(want, rel=1e-5)
