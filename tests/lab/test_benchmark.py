"""The real-robot benchmark on a synthetic stand-in (a known tendon robot with marker noise):
the JSON the issue's script reads, every model and baseline fitted on the training session only
and run free over the validation session, options chosen on the training session's hold-out."""

import dataclasses
import math

import numpy as np
import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.lab.benchmark import BASELINES, FAMILIES, BenchmarkOptions, _Table, run_benchmark
from softrnn.lab.families import (
    NODE_TRAINING,
    ConstantVelocityFamily,
    LinearARXFamily,
    NodeOptions,
    PersistenceFamily,
    StaticPolynomial,
    holdout_split,
    play,
)
from softrnn.lab.nets import NetOptions, SequenceOptions
from softrnn.lab.recording import read_recording
from softrnn.lab.synthetic import SyntheticOptions
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


def test_report_has_the_fields_metrics(report, sessions):
    """Per model and baseline: RMSE and mean, raw and after removing the session's constant offset, in mm
    and % of the length; the chosen family's validation RMSE; a coverage where a model states its
    uncertainty (every family but the node LSTM), none for the baselines."""
    _, val = sessions
    aligned_keys = {"tip_rmse_aligned_mm", "tip_mean_aligned_mm", "tip_mean_aligned_pct_of_length",
                    "tip_mean_pct_of_length", "tip_rmse_aligned_pct_of_length"}
    for name, entry in report["models"].items():
        assert ("coverage_90" in entry) == (name != "node_lstm")
        assert entry.get("coverage_90", 0.5) is None or 0.0 <= entry.get("coverage_90", 0.5) <= 1.0
    for entry in report["baselines"].values():
        assert "coverage_90" not in entry
    for entry in [*report["models"].values(), *report["baselines"].values()]:
        assert set(entry) >= aligned_keys
        assert entry["tip_rmse_aligned_mm"] <= entry["tip_rmse_mm"] + 1e-3
        assert entry["tip_mean_pct_of_length"] == pytest.approx(entry["tip_mean_mm"] / 80.0 * 100, rel=1e-3)
        assert entry["tip_mean_aligned_pct_of_length"] == pytest.approx(entry["tip_mean_aligned_mm"] / 80.0 * 100,
                                                                        rel=1e-3)
    # persistence by hand: the first tip held, then the session's mean offset removed
    pred = np.repeat(val.tip[:1], val.n_rows, axis=0)
    pred = pred - (pred - val.tip).mean(axis=0)
    by_hand = np.linalg.norm(pred - val.tip, axis=1) * 1e3
    assert report["baselines"]["persistence"]["tip_mean_aligned_mm"] == pytest.approx(by_hand.mean(), abs=1e-4)
    chosen = report["chosen_on_training"]
    assert chosen["validation_tip_rmse_mm"] == report["models"][chosen["family"]]["tip_rmse_mm"]


def test_a_model_that_states_its_uncertainty_gets_its_coverage(sessions):
    """A model with ``predict_interval`` is scored on its tip, and its 90 % ball's coverage is reported."""
    _, val = sessions

    class Stated:
        def predict_interval(self, session):
            pred = session.tip + np.array([1e-3, 0, 0])                     # 1 mm off on every row
            radius = np.where(np.arange(session.n_rows) % 4 == 0, 0.5e-3, 2e-3)
            return pred, radius

        def describe(self):
            return {"kind": "stated"}

    out = _Table(val, 0.08)
    out.record(out.models, "stated", Stated())
    score = out.models["stated"]
    assert score.coverage_90 == pytest.approx(np.mean(np.arange(val.n_rows) % 4 != 0), abs=1e-4)
    assert score.tip_rmse_mm == pytest.approx(1.0) and score.tip_rmse_aligned_mm == pytest.approx(0.0, abs=1e-9)
    assert score.to_dict()["coverage_90"] == score.coverage_90


def test_learned_families_say_their_mode_and_interval(report):
    """Synthetic data by default where the physics is calibrated: each learned family's hold-out scores
    list the modes tried, the hybrid's its gates; every model but the node LSTM states its interval."""
    details = report["details"]
    for name in ("learned_map", "hybrid", "sequence"):
        assert details[name]["mode"] in ("real", "finetune", "mixed") and details[name]["interval_90_q"] > 0
        assert "synthetic_data" not in details[name]
    assert {"hysteresis=False,mode=real", "hysteresis=True,mode=real"} <= set(details["learned_map"]["holdout_rmse_mm"])
    assert any("mode=mixed" in k for k in details["learned_map"]["holdout_rmse_mm"])
    assert any(k.endswith("gate=inf") for k in details["hybrid"]["holdout_rmse_mm"])
    assert set(details["sequence"]["holdout_rmse_mm"]) == {"mode=real", "mode=finetune"}
    assert details["physics"]["interval_90_radius_mm"] > 0
    hybrid = details["hybrid"]["holdout_rmse_mm"]
    assert report["chosen_on_training"]["holdout_rmse_mm"]["hybrid"] == min(hybrid.values())


def test_synthetic_data_without_a_physics_is_refused_or_left_out(sessions, tmp_path):
    """Inputs that are not tendon displacements: synthetic data asked for is one line naming the
    option; by default the learned families run on the real rows and say why."""
    train, val = sessions
    as_kpa = [type(s)(**{**vars(s), "units": ("kpa",) * s.n_inputs}) for s in (train, val)]
    words = r"synthetic=2.0 is invalid: synthetic data need the calibrated tendon physics, which these sessions do not"
    with pytest.raises(SoftrnnInputError, match=words + r" allow \(the inputs' units"):
        run_benchmark([as_kpa[0]], as_kpa[1], BenchmarkOptions(length=0.08, families=("learned_map",), **FAST,
                                                               synthetic=SyntheticOptions(amount=2.0)))
    fast = {**FAST, "nets": NetOptions(members=1, steps=20, hidden=4)}
    out = run_benchmark([as_kpa[0]], as_kpa[1], BenchmarkOptions(length=0.08, families=("learned_map",), **fast))
    assert out.details["learned_map"]["synthetic_data"].startswith("not used: no calibrated physics")
    assert out.details["learned_map"]["mode"] == "real"
    off = run_benchmark([train], val, BenchmarkOptions(length=0.08, families=("learned_map",), **fast,
                                                       synthetic=SyntheticOptions(amount=0.0)))
    assert set(off.details["learned_map"]["holdout_rmse_mm"]) == {"hysteresis=False,mode=real",
                                                                  "hysteresis=True,mode=real"}
    with pytest.raises(SoftrnnInputError, match="synthetic=0.5 is invalid: a SyntheticOptions"):
        BenchmarkOptions(length=0.1, synthetic=0.5)


def test_the_physics_variant_is_chosen_on_the_hold_out(report):
    """Every physics variant's hold-out score is reported; the lowest is the one used."""
    physics = report["details"]["physics"]
    scores = physics["holdout_rmse_mm"]
    assert set(scores) == {"plain", "gravity", "friction", "gravity+friction"}
    assert physics["variant"] == min(scores, key=scores.get)
    assert report["chosen_on_training"]["holdout_rmse_mm"]["physics"] == pytest.approx(scores[physics["variant"]])
