"""The real-robot benchmark on a synthetic stand-in (a known tendon robot with marker noise):
the JSON the issue's script reads, every model and baseline fitted on the training session only
and run free over the validation session, options chosen on the training session's hold-out."""

import dataclasses
import math

import numpy as np
import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.lab.benchmark import BASELINES, FAMILIES, BenchmarkOptions, run_benchmark
from softrnn.lab.families import (
    NODE_TRAINING,
    ConstantVelocityFamily,
    LinearARXFamily,
    NetOptions,
    NodeOptions,
    PersistenceFamily,
    SequenceOptions,
    StaticPolynomial,
    holdout_split,
    play,
)
from softrnn.lab.recording import read_recording
from softrnn.lab.tendon_robot import CalibrationOptions
from softrnn.learned.metrics import tip_errors

from helpers import tendon_recording

FAST = dict(nets=NetOptions(members=1, steps=150, hidden=16), sequence=SequenceOptions(epochs=3, hidden=8),
            node=NodeOptions(units=8, training=dataclasses.replace(NODE_TRAINING, epochs=2, rollout_steps=2)),
            calibration=CalibrationOptions(quick_evaluations=25, evaluations=150))


@pytest.fixture(scope="module")
def sessions(tmp_path_factory):
    d = tmp_path_factory.mktemp("rec")
    tendon_recording(d / "train.csv", rows=150, seed=0)
    tendon_recording(d / "val.csv", rows=60, seed=1, scale_mm=3.5)
    return read_recording(d / "train.csv"), read_recording(d / "val.csv")


@pytest.fixture(scope="module")
def report(sessions):
    train, val = sessions
    return run_benchmark([train], val, BenchmarkOptions(length=0.08, **FAST)).to_dict()


def test_report_has_the_documented_keys(report):
    assert set(report) >= {"robot", "models", "baselines", "best_model", "best_baseline",
                           "ratio_best_model_to_best_baseline", "seconds"}
    assert set(report["models"]) == set(FAMILIES) and set(report["baselines"]) == set(BASELINES)
    assert "constant_velocity" in report["baselines"] and "constant_velocity" in BASELINES
    for entry in [*report["models"].values(), *report["baselines"].values()]:
        assert set(entry) >= {"tip_rmse_mm", "tip_mean_mm", "tip_rmse_pct_of_length"}
        assert all(math.isfinite(v) and v >= 0 for v in entry.values())
        assert entry["tip_rmse_pct_of_length"] == pytest.approx(entry["tip_rmse_mm"] / 80.0 * 100, rel=1e-3)
    best = report["best_model"]
    assert report["ratio_best_model_to_best_baseline"] == pytest.approx(
        report["models"][best]["tip_rmse_mm"] / report["baselines"][report["best_baseline"]]["tip_rmse_mm"])
    assert report["robot"]["lag_rows"] == 0 and report["robot"]["estimated"]


def test_physics_of_the_right_model_class_wins(report):
    """The data come from a tendon robot: its calibrated physics is within the marker noise
    (0.1 mm per axis) of the truth and far better than every baseline."""
    phys = report["models"]["physics"]["tip_rmse_mm"]
    assert phys < 0.5
    assert phys < 0.2 * min(b["tip_rmse_mm"] for b in report["baselines"].values())
    assert report["chosen_on_training"]["family"] in FAMILIES


def test_baselines_by_hand(sessions):
    train, val = sessions
    assert np.all(PersistenceFamily().fit([train]).predict(val) == val.tip[0])
    cv = ConstantVelocityFamily().fit([train]).predict(val)                  # the first velocity, run free
    k = np.arange(val.n_rows)[:, None]
    np.testing.assert_allclose(cv, val.tip[0] + k * (val.tip[1] - val.tip[0]), rtol=0, atol=1e-10)
    assert np.array_equal(cv[:2], val.tip[:2])
    arx = LinearARXFamily(1, 1).fit([train])
    pred = arx.predict(val)
    assert np.array_equal(pred[0], val.tip[0])
    step = np.concatenate([pred[3], val.inputs[4], [1.0]]) @ arx.W          # free: fed its own output
    np.testing.assert_allclose(pred[4], step)
    lin = StaticPolynomial(1, 1e-12).fit([train])
    X = np.column_stack([np.ones(train.n_rows), train.inputs])
    W = np.linalg.lstsq(X, train.tip, rcond=None)[0]
    np.testing.assert_allclose(lin.predict(val), np.column_stack([np.ones(val.n_rows), val.inputs]) @ W, atol=1e-9)


def test_tip_errors_are_euclidean():
    ref = np.zeros((4, 3))
    pred = np.array([[3e-3, 4e-3, 0], [0, 0, 0], [0, 0, 0], [0, 0, 0]])
    e = tip_errors(pred, ref).tip_summary()
    assert e["tip_rmse_mm"] == pytest.approx(np.sqrt(25 / 4)) and e["tip_mean_mm"] == pytest.approx(5 / 4)


def test_play_operator_lags_a_reversal_by_its_width():
    u = np.array([[0.0], [1.0], [2.0], [1.5], [1.0], [0.0]])
    np.testing.assert_allclose(play(u, np.array([0.5]))[:, 0], [0.0, 0.5, 1.5, 1.5, 1.5, 0.5])


def test_holdout_is_the_later_part_or_the_last_session(sessions):
    train, val = sessions
    fit, held = holdout_split([train])
    assert fit[0].n_rows + held[0].n_rows == train.n_rows and held[0].time[0] > fit[0].time[-1]
    fit, held = holdout_split([train, val])
    assert fit == [train] and held == [val]


def test_bad_options_are_refused():
    with pytest.raises(SoftrnnInputError, match="families='magic' is invalid"):
        BenchmarkOptions(length=0.1, families=("magic",))
    with pytest.raises(SoftrnnInputError, match="lag=-1 is invalid"):
        BenchmarkOptions(length=0.1, lag=-1)


def test_a_pull_beyond_the_routing_is_refused(sessions):
    train, val = sessions
    far = type(val)(**{**vars(val), "inputs": val.inputs * 10})
    with pytest.raises(SoftrnnInputError, match="beyond what the routing allows"):
        run_benchmark([train], far, BenchmarkOptions(length=0.08, families=("physics",), **FAST))


def test_fit_returns_a_new_frozen_model_and_leaves_the_family_as_it_was(sessions):
    train, val = sessions
    for family in (LinearARXFamily(2, 1), StaticPolynomial(2, 1e-3), PersistenceFamily(), ConstantVelocityFamily()):
        fitted = family.fit([train])
        assert type(fitted) is type(family) and fitted.predict(val).shape == val.tip.shape
        with pytest.raises(dataclasses.FrozenInstanceError):
            fitted.name = "changed"
    arx = LinearARXFamily(2, 1)
    assert arx.fit([train]).arx.na == 2 and arx.arx is None


def test_the_physics_variant_is_chosen_on_the_hold_out(report):
    """Every physics variant's hold-out score is reported; the lowest is the one used."""
    physics = report["details"]["physics"]
    scores = physics["holdout_rmse_mm"]
    assert set(scores) == {"plain", "gravity", "friction", "gravity+friction"}
    assert physics["variant"] == min(scores, key=scores.get)
    assert report["chosen_on_training"]["holdout_rmse_mm"]["physics"] == pytest.approx(scores[physics["variant"]])
