"""Separate training / validation / test sessions (``train_node_model(..., validation=...)``,
``split_inputs(..., validate_on=...)``) and the Euclidean tip error of the evaluations: every
training sample trained on, early stopping on the other recording, whole-record evaluation, the
linear baseline fitted on the training data, one-line refusals of mismatched recordings."""

import json
from dataclasses import replace

import numpy as np
import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.io import Dataset
from softrnn.learned.node.data import SampleSpec, make_windows
from softrnn.learned.node.evaluate import evaluate, metrics
from softrnn.learned.node.training_data import check_validation_data
from softrnn.learned.whole.data import split_inputs
from softrnn.learned.whole.evaluation import tip_summary

from helpers import LENGTH, node_dataset, save_h5

pytest.importorskip("torch")

T = 160
TINY = {"lstm_units": 8, "lstm_layers": 1, "dense_units": (8,)}


def _shifted(ds: Dataset, offset: float) -> Dataset:
    """``ds`` with every position moved by ``offset`` [m] along x, y and z."""
    return Dataset(time=ds.time, nodes=ds.nodes, positions=ds.positions + offset, quaternions=ds.quaternions,
                   forces=ds.forces, torques=ds.torques, attrs=ds.attrs)


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """train.h5, val.h5 (train.h5 moved by 1 cm) and test.h5 (another motion) of the same 6-node rod."""
    root = tmp_path_factory.mktemp("sessions")
    ds = node_dataset(T=T)
    save_h5(root / "train.h5", ds)
    save_h5(root / "val.h5", _shifted(ds, 0.01))
    other = node_dataset(T=T + 40)
    save_h5(root / "test.h5", Dataset(time=other.time, nodes=other.nodes, positions=other.positions[::-1].copy(),
                                      quaternions=other.quaternions, forces=other.forces, torques=other.torques,
                                      attrs=other.attrs))
    return root


def _train(files, out, validation, **train):
    from softrnn.learned.node.train import TrainConfig, train_node_model

    config = TrainConfig(**{"epochs": 2, "rollout_steps": 1, "batch_size": 64, **train})
    return train_node_model(files / "train.h5", SampleSpec(node=2, wrench="force"), dict(TINY), config, out,
                            validation=validation)


@pytest.fixture(scope="module")
def folder(files, tmp_path_factory):
    out = tmp_path_factory.mktemp("m") / "model"
    _train(files, out, files / "val.h5")
    return out


@pytest.fixture(scope="module")
def model(folder):
    from softrnn.learned.node.artifact import load_model

    return load_model(folder)


def test_every_sample_of_the_training_record_is_trained_on(model, folder):
    m = model.meta
    spec = model.spec
    assert m["spans"]["fit"] == [0, T] and m["spans"]["validation"] == [0, T] and m["test_span"] == [T, T]
    assert m["stride"] == 1
    assert m["train_windows"] == len(make_windows(node_dataset(T=T), spec, 0, T)) == T - spec.history
    sessions = m["training_data"]
    assert sessions["span"] == "whole record"
    assert sessions["train"]["file"] == "train.h5" and sessions["validation"]["file"] == "val.h5"
    assert sessions["train"]["n_samples"] == sessions["validation"]["n_samples"] == T
    assert json.loads((folder / "meta.json").read_text())["training_data"] == sessions


def test_the_validation_loss_comes_from_the_other_recording(files, model, tmp_path):
    """The same training on the same record: validated on itself the validation loss differs from
    the one on the recording moved by 1 cm; the training losses are the same."""
    itself = _train(files, tmp_path / "self", files / "train.h5")
    assert itself.meta["history"][0]["loss"] == model.meta["history"][0]["loss"]
    assert itself.meta["history"][0]["validation_loss"] != model.meta["history"][0]["validation_loss"]
    assert itself.meta["best_validation_loss"] < model.meta["best_validation_loss"]


def test_without_a_validation_recording_nothing_changes(files, tmp_path):
    plain = _train(files, tmp_path / "plain", None)
    assert "training_data" not in plain.meta
    assert plain.meta["spans"] == {"fit": [0, 76], "validation": [76, 96], "test": [96, T]}


def test_a_separate_recording_is_evaluated_whole_free_running_from_its_start(model, files):
    report = evaluate(model, files / "test.h5", horizons=(1, 10)).to_dict()
    H = model.spec.history
    assert report["span"] == "whole record"
    assert report["span_samples"] == [H, T + 40 - 1] and report["n_targets"] == T + 40 - H
    assert report["free_running"]["seed_samples"] == H and not report["free_running"]["diverged"]
    assert report["linear_fitted_on"] == "training data"
    assert report["baselines"]["linear"]["fitted_on"]["samples"] == [0, T]
    for block in (report["one_step"], report["free_running"], report["baselines"]["linear"]["one_step"]):
        assert np.isclose(block["rmse_euclidean_mm"], np.sqrt(3) * block["rmse_mm"])
        assert block["rmse_euclidean_pct_of_length"] == pytest.approx(block["rmse_euclidean_mm"] / (LENGTH * 1e3) * 100)


def test_its_own_training_record_is_said_to_be_training_data(model, files):
    report = evaluate(model, files / "train.h5", free=False).to_dict()
    assert report["span"] == "training data" and report["span_samples"][0] == model.spec.history
    assert report["linear_fitted_on"] == "training data"


def test_the_linear_baseline_falls_back_to_the_evaluated_record_when_the_training_file_is_gone(model, files,
                                                                                                tmp_path):
    gone = replace(model, meta={**model.meta, "training_data": {
        **model.meta["training_data"], "train": {**model.meta["training_data"]["train"],
                                                  "path": str(tmp_path / "moved.h5")}},
        "dataset": {**model.meta["dataset"], "path": str(tmp_path / "moved.h5")}})
    report = evaluate(gone, files / "test.h5", free=False).to_dict()
    lin = report["baselines"]["linear"]
    assert report["linear_fitted_on"] == lin["linear_fitted_on"] == "evaluated record"
    assert "no longer exists" in lin["fitted_on"]["what"]


def test_the_euclidean_rmse_of_a_known_error():
    rng = np.random.default_rng(3)
    ref = rng.normal(size=(50, 3))
    d = 2e-3
    iso = metrics(ref + d, ref, LENGTH)                      # the same 2 mm on every axis
    assert iso.rmse_mm == pytest.approx(2.0)
    assert iso.rmse_euclidean_mm == pytest.approx(np.sqrt(3) * iso.rmse_mm) == pytest.approx(np.sqrt(3) * 2.0)
    assert iso.mean_euclidean_mm == pytest.approx(np.sqrt(3) * 2.0)
    err = rng.normal(scale=1e-3, size=(50, 3))
    m = metrics(ref + err, ref, None).summary()
    dist = np.linalg.norm(err * 1e3, axis=1)
    assert m["rmse_euclidean_mm"] == pytest.approx(np.sqrt(np.mean(dist ** 2)))
    assert m["mean_euclidean_mm"] == pytest.approx(np.mean(dist))
    assert m["rmse_euclidean_pct_of_length"] is None
    assert m["rmse_mm"] == pytest.approx(m["rmse_euclidean_mm"] / np.sqrt(3))


def test_a_validation_recording_of_other_nodes_or_channels_is_refused():
    ds = node_dataset(T=20)
    spec = SampleSpec(node=2).resolve(ds.nodes, n_nodes_total=6)
    few = Dataset(time=ds.time, nodes=ds.nodes[:2], positions=ds.positions[:, :2], quaternions=ds.quaternions[:, :2],
                  forces=ds.forces[:, :2], torques=ds.torques[:, :2], attrs=ds.attrs)
    with pytest.raises(SoftrnnInputError, match=r"^validate_on='v.h5' is invalid: .*no node 2"):
        check_validation_data(ds, few, spec, [1, 2, 3], "v.h5")
    act = Dataset(time=ds.time, nodes=ds.nodes, positions=ds.positions, quaternions=ds.quaternions, forces=ds.forces,
                  torques=ds.torques, attrs=ds.attrs, actuation=np.zeros((20, 1)), actuation_units={"tendon_1": "N"})
    driven = replace(spec, drive="actuation", wrench="none", channels=("tendon_1",))
    check_validation_data(act, act, driven, [1, 2, 3], "v.h5")
    with pytest.raises(SoftrnnInputError, match=r"validate_on='v.h5' is invalid: .*no channel 'tendon_1'"):
        check_validation_data(act, ds, driven, [1, 2, 3], "v.h5")
    other_dt = Dataset(time=ds.time, nodes=ds.nodes, positions=ds.positions, quaternions=ds.quaternions,
                       forces=ds.forces, torques=ds.torques, attrs={**ds.attrs, "dt": 0.02})
    with pytest.raises(SoftrnnInputError, match="sampled every"):
        check_validation_data(ds, other_dt, spec, [1, 2, 3], "v.h5")


# ------------------------------------------------------------------------------------------ whole model
def test_separate_validation_recordings_make_the_training_files_whole(files):
    split = split_inputs([files / "train.h5"], validate_on=[files / "val.h5"])
    assert [p.stop for p in split.train] == [None]
    assert [p.path for p in split.validation] == [p.path for p in split.validate_on] == [str(files / "val.h5")]
    assert split.describe()["validate_on"] == [{"path": str(files / "val.h5"), "group": "/", "stop": None}]
    assert "validate_on" not in split_inputs([files / "train.h5"], train_fraction=0.6).describe()
    with pytest.raises(SoftrnnInputError, match="^train_fraction=0.6 is invalid"):
        split_inputs([files / "train.h5"], validate_on=[files / "val.h5"], train_fraction=0.6)
    with pytest.raises(SoftrnnInputError, match="^validate_on=.* is invalid: a recording that is not also"):
        split_inputs([files / "train.h5"], validate_on=[files / "train.h5"])
    with pytest.raises(SoftrnnInputError, match="^validate_on=.* is invalid: an existing data set file"):
        split_inputs([files / "train.h5"], validate_on=[files / "missing.h5"])


class _Tip:
    """An encoding stand-in: every node kept, the states' first three channels are positions."""

    length = LENGTH

    @staticmethod
    def positions(states):
        return np.asarray(states, dtype=np.float64)[..., :3]


def test_the_tip_euclidean_error_is_the_hand_computed_one():
    truth = np.zeros((4, 3, 3))
    states = np.zeros((4, 3, 6))
    states[:, -1, :3] = [[3e-3, 4e-3, 0], [0, 0, 0], [1e-3, 1e-3, 1e-3], [0, 0, 2e-3]]     # 5, 0, sqrt(3), 2 mm
    states[:, 0, :3] = 1.0                                                                 # not the tip: ignored
    out = tip_summary(_Tip, states, truth)
    d = np.array([5.0, 0.0, np.sqrt(3), 2.0])
    assert out["rmse_euclidean_mm"] == pytest.approx(np.sqrt(np.mean(d ** 2)))
    assert out["mean_euclidean_mm"] == pytest.approx(d.mean())
    assert out["mean_euclidean_pct_of_length"] == pytest.approx(d.mean() / (LENGTH * 1e3) * 100)
    states[2] = np.nan
    assert set(tip_summary(_Tip, states, truth).values()) == {None}
