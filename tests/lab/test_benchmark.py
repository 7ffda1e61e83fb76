"""The real-robot benchmark on a synthetic stand-in (a known tendon robot with marker noise):
the JSON the issue's script reads, every model and baseline fitted on the training session only
and run free over the validation session, options chosen on the training session's hold-out."""

import dataclasses
import math

import numpy as np
import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.lab.benchmark import (
    BASELINES,
    FAMILIES,
    TIP_REACH,
    BenchmarkOptions,
    _Table,
    check_reach,
    prepare,
    run_benchmark,
    session_agreement,
)
from softrnn.lab.families import (
    NODE_TRAINING,
    ConstantVelocityFamily,
    LinearARXFamily,
    NodeFamily,
    NodeOptions,
    PersistenceFamily,
    Physics,
    StaticPolynomial,
    holdout_split,
    novelty,
    parsimonious,
    play,
)
from softrnn.lab.nets import NetOptions, SequenceOptions
from softrnn.lab.recording import Recording, read_recording
from softrnn.lab.synthetic import SyntheticOptions
from softrnn.lab.tendon_robot import CalibrationOptions, TendonRobot
from softrnn.learned.metrics import tip_errors

from helpers import tendon_recording, tendon_robot_truth

FAST = dict(nets=NetOptions(members=1, steps=150, hidden=16), sequence=SequenceOptions(epochs=3, hidden=8),
            node=NodeOptions(units=8, training=dataclasses.replace(NODE_TRAINING, epochs=2, rollout_steps=2)),
            calibration=CalibrationOptions(quick_evaluations=25, evaluations=150),
            workers=1)   # in this process: the figures do not depend on it (tests/lab/test_worker_pool.py)


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


def _session(inputs, start=0.0):
    inputs = np.asarray(inputs, dtype=float)
    rows = len(inputs)
    width = inputs.shape[1]
    return Recording(path="", time=start + np.arange(rows, dtype=float), inputs=inputs, names=("a", "b", "c")[:width],
                     units=("mm",) * width, tip=np.zeros((rows, 3)), labels=tuple(f"r{i}" for i in range(rows)))


def test_holdout_holds_out_the_rows_farthest_in_command_space():
    """One session: the stretch of rows whose commands reach where no other stretch goes is held out
    (wherever it lies in time); every row lands in exactly one part, in order."""
    rng = np.random.default_rng(0)
    u = rng.uniform(-1.0, 1.0, (240, 2))
    u[100:120] *= 8.0                                            # one stretch reaches far beyond the rest
    s = _session(u)
    fit, held = holdout_split([s])
    rows = [r for part in [*fit, *held] for r in part.labels]
    assert sorted(rows, key=lambda r: int(r[1:])) == list(s.labels) and len(rows) == len(set(rows))
    held_rows = {int(r[1:]) for part in held for r in part.labels}
    assert set(range(100, 120)) <= held_rows and len(held_rows) == 60          # a quarter of the rows
    for part in [*fit, *held]:
        assert np.all(np.diff(part.time) == 1.0)                # each part a contiguous run of rows
    far = novelty([s.rows(0, 100), s.rows(100, 120), s.rows(120, 240)])
    assert np.argmax(far) == 1


def test_holdout_of_several_sessions_is_the_one_least_covered():
    rng = np.random.default_rng(1)
    near, also_near = _session(rng.uniform(-1, 1, (50, 2))), _session(rng.uniform(-1, 1, (50, 2)))
    beyond = _session(rng.uniform(-1, 1, (50, 2)) * [6.0, 1.0])
    fit, held = holdout_split([near, beyond, also_near])
    assert held == [beyond] and fit == [near, also_near]


def test_the_simplest_candidate_within_one_standard_error_wins():
    """The one-standard-error rule: over 50 rows the tolerance is 1/sqrt(100) = 10 % of the best score;
    a later (more complex) candidate wins only when it is better by more than that."""
    assert parsimonious({"simple": 10.9, "complex": 10.0}, 50) == "simple"
    assert parsimonious({"simple": 11.1, "complex": 10.0}, 50) == "complex"
    assert parsimonious({"simple": 11.1, "complex": 10.0}, 5000) == "complex"
    assert parsimonious({"simple": 10.09, "complex": 10.0}, 5000) == "simple"
    assert parsimonious({"diverged": math.inf, "fine": 3.0}, 50) == "fine"
    assert parsimonious({"a": math.inf, "b": math.inf}, 50) == "a"


def test_novelty_of_a_copy_is_zero_and_a_still_channel_counts_nothing():
    u = np.column_stack([np.linspace(0, 1, 20), np.zeros(20)])
    assert novelty([_session(u), _session(u)]).tolist() == [0.0, 0.0]
    a, b = _session(u[:10]), _session(u[10:] + [0.3, 0.0])
    with_still = novelty([a, b])
    without = novelty([_session(u[:10, :1]), _session(u[10:, :1] + 0.3)])
    np.testing.assert_allclose(with_still, without, rtol=1e-12)
    assert np.all(with_still > 0)


def test_bad_options_are_refused():
    with pytest.raises(SoftrnnInputError, match="families='magic' is invalid"):
        BenchmarkOptions(length=0.1, families=("magic",))
    with pytest.raises(SoftrnnInputError, match="lag=-1 is invalid"):
        BenchmarkOptions(length=0.1, lag=-1)


def test_a_pull_beyond_the_routing_is_refused(sessions):
    """A pull beyond pi r (one segment here: 14.1 mm for the default 4.5 mm) is refused where the routing
    radius r is given; where it is not (a start value the calibration fits up to 5 times), only a pull
    beyond what that widest routing allows (70.7 mm) is: another robot's larger routing is no error."""
    train, val = sessions
    assert val.inputs.max() == pytest.approx(3.0, abs=0.1)
    wide, far = (dataclasses.replace(val, inputs=val.inputs * k) for k in (10, 30))     # up to 30 and 90 mm
    given = BenchmarkOptions(length=0.08, families=("physics",), routing_radius=4.5e-3)
    strict = (r"row 1, .*: a pull of 22.54 mm is beyond what the routing allows \(pi x routing radius 4.5 mm per "
              r"segment it runs through = 14.14 mm\); check the units and the column order$")
    with pytest.raises(SoftrnnInputError, match=strict):
        prepare([train], wide, given)
    assert prepare([train], wide, BenchmarkOptions(length=0.08, families=("physics",))).families == ("physics",)
    with pytest.raises(SoftrnnInputError, match=r"\(pi x the widest routing radius the calibration fits, 5 x 4.5 "
                                                r"mm per segment it runs through = 70.69 mm\); .*--routing-radius$"):
        run_benchmark([train], far, BenchmarkOptions(length=0.08, families=("physics",), **FAST))


def test_training_sessions_are_checked_alone_without_a_validation_session(sessions):
    """``prepare(train, None, options)`` checks and lines up the training sessions alone (as a check on
    the training session alone makes); a validation session that is the training session is refused."""
    train, _ = sessions
    options = BenchmarkOptions(length=0.08, **FAST)
    alone = prepare([train], None, options)
    assert alone.validation is None and alone.robot is not None and alone.train[0].n_rows == train.n_rows
    with pytest.raises(SoftrnnInputError, match="repeats"):
        prepare([train], train, options)


def test_fit_returns_a_new_frozen_model_and_leaves_the_family_as_it_was(sessions):
    train, val = sessions
    for family in (LinearARXFamily(2, 1), StaticPolynomial(2, 1e-3), PersistenceFamily(), ConstantVelocityFamily()):
        fitted = family.fit([train])
        assert type(fitted) is type(family) and fitted.predict(val).shape == val.tip.shape
        with pytest.raises(dataclasses.FrozenInstanceError):
            fitted.name = "changed"
    arx = LinearARXFamily(2, 1)
    assert arx.fit([train]).arx.na == 2 and arx.arx is None


def test_a_baseline_that_runs_away_is_a_miss_not_a_crash():
    """Constant velocity from a fast first step leaves the free run's bounds (16 m) within the session:
    its tip is NaN from there on, its score null in the JSON (every key kept), and the best baseline is
    another."""
    rows = 40
    tip = np.zeros((rows, 3))
    tip[1] = [2.0, 0.0, 0.0]                      # 2 m in the first row: 16 m after eight more
    s = Recording(path="", time=np.arange(rows) * 0.1, inputs=np.zeros((rows, 1)), names=("p",), units=("kPa",),
                  tip=tip)
    run = ConstantVelocityFamily().fit([s]).predict(s)
    assert np.isfinite(run[:8]).all() and np.isnan(run[-1]).all()
    out = _Table(s, 0.3)
    out.record(out.baselines, "constant_velocity", ConstantVelocityFamily().fit([s]))
    out.record(out.baselines, "persistence", PersistenceFamily().fit([s]))
    entry = out.baselines["constant_velocity"].to_dict()
    assert entry["tip_rmse_mm"] is None and entry["tip_mean_aligned_pct_of_length"] is None
    assert set(entry) == set(out.baselines["persistence"].to_dict())
    assert math.isfinite(out.baselines["persistence"].tip_rmse_mm)


def test_report_has_the_fields_metrics(report, sessions):
    """Per model and baseline: RMSE and mean, raw and after removing the session's constant offset, in mm
    and % of the length; the chosen family's validation RMSE; the coverage of the 90 % interval every
    model and baseline states."""
    _, val = sessions
    aligned_keys = {"tip_rmse_aligned_mm", "tip_mean_aligned_mm", "tip_mean_aligned_pct_of_length",
                    "tip_mean_pct_of_length", "tip_rmse_aligned_pct_of_length"}
    for entry in [*report["models"].values(), *report["baselines"].values()]:
        assert "coverage_90" in entry and 0.0 <= entry["coverage_90"] <= 1.0
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
    # the dense candidate: mixed on 4x the synthetic rows, its amount in the description where it wins
    for name in ("learned_map", "hybrid"):
        assert any(",mode=mixed,synthetic=x4" in k for k in details[name]["holdout_rmse_mm"])
        if details[name]["mode"] == "mixed":
            assert details[name]["synthetic"]["amount_x_real_rows"] in (5.0, 20.0)
    gates = {k.rsplit("gate=", 1)[1] for k in details["hybrid"]["holdout_rmse_mm"]}
    assert gates == {"0.5", "1", "2", "4", "8"}            # always finite: the hybrid follows its physics far out
    sequence = set(details["sequence"]["holdout_rmse_mm"])
    assert {"hysteresis=False,mode=real", "hysteresis=True,mode=real"} < sequence and len(sequence) == 9
    assert {k.split(",", 1)[1] for k in sequence} == {"mode=real", "mode=real,linear", "mode=finetune"} | {
        f"mode=real,physics,gate={g}" for g in ("0.5", "1", "2", "4", "8")}
    assert details["physics"]["interval_90_q"] > 0 and "jackknife" in details["physics"]["error_scale"]
    # the learned map's scale holds its distance from the calibrated physics (its candidates fitted early too)
    assert "distance from the calibrated physics' tip" in details["learned_map"]["error_scale"]
    # the hybrid states its physics' interval where its gate is off; the sequence model too, over the physics
    assert "physics' interval" in details["hybrid"]["interval_90_beyond_gate"]
    assert ("interval_90_beyond_gate" in details["sequence"]) == ("physics" in details["sequence"]["kind"])
    hybrid = details["hybrid"]["holdout_rmse_mm"]
    assert report["chosen_on_training"]["holdout_rmse_mm"]["hybrid"] == min(hybrid.values())
    node = details["node_lstm"]
    assert set(node["holdout_rmse_mm"]) == {"mode=real", "mode=mixed"} | {
        f"mode=real,physics,gate={g}" for g in ("0.5", "1", "2", "4", "8")} and node["mode"] in ("real", "mixed")
    assert ("gate_d0" in node) == ("physics' tip leaves" in node["kind"]) == ("interval_90_beyond_gate" in node)
    assert report["chosen_on_training"]["holdout_rmse_mm"]["node_lstm"] == min(node["holdout_rmse_mm"].values())


def test_node_lstm_learns_from_the_physics_sessions_only_with_a_physics(sessions):
    """Mode mixed needs a calibrated physics; its synthetic rows are capped at ``synthetic_amount``
    per real row, whatever the synthetic options ask."""
    train, _ = sessions
    with pytest.raises(SoftrnnInputError, match="mode='mixed' is invalid"):
        NodeFamily(0.08, mode="mixed")
    with pytest.raises(SoftrnnInputError, match="synthetic_amount=-1 is invalid"):
        NodeOptions(synthetic_amount=-1)
    physics = Physics(TendonRobot((0.08,), 3, 4e-3), FAST["calibration"]).fit([train])
    family = NodeFamily(0.08, NodeOptions(synthetic_amount=0.5), mode="mixed", synthetic=SyntheticOptions(amount=5),
                        physics=physics)
    taught = family._taught([train])
    assert sum(s.n_rows for s in taught) == pytest.approx(0.5 * train.n_rows, rel=0.1)
    assert NodeFamily(0.08)._taught([train]) == []


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
    assert "distance" not in out.details["learned_map"]["error_scale"]
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
    assert set(scores) == {"plain", "gravity", "friction", "creep", "gravity+friction"}
    assert physics["variant"] == min(scores, key=scores.get)
    assert report["chosen_on_training"]["holdout_rmse_mm"]["physics"] == pytest.approx(scores[physics["variant"]])


def test_a_node_run_that_diverges_is_nan_from_there_on_and_never_the_best(monkeypatch, sessions):
    """The per-node LSTM's free run diverging at row 9: the rows before come from the same run stopped
    there, NaN from row 9 on (not an error that stops the benchmark); a model scored NaN is never the
    best of its table."""
    import softrnn.learned.node.rollout as node_rollout
    from softrnn.lab.benchmark import BenchmarkResult, TipScore
    from softrnn.learned.horizons import RolloutDiverged

    calls = []

    class _Run:
        def __init__(self, start, stop):
            self.rows = np.arange(start, stop, dtype=float)

        def node_positions(self, node):
            return np.repeat(self.rows[:, None], 3, axis=1) * 1e-3

    def diverging(model, data, start, stop):
        calls.append((start, stop))
        if stop > 9:
            raise RolloutDiverged("diverged", node=1, sample=9, time=5.4)
        return _Run(start, stop)

    monkeypatch.setattr(node_rollout, "rollout", diverging)
    val = sessions[1]
    H = NodeOptions().history
    tip = NodeFamily(0.08, model=object()).predict(val)
    assert calls == [(H, val.n_rows), (H, 9)]
    np.testing.assert_array_equal(tip[:H], val.tip[:H])
    np.testing.assert_array_equal(tip[H:9], np.repeat(np.arange(H, 9.0)[:, None], 3, axis=1) * 1e-3)
    assert np.all(np.isnan(tip[9:]))
    nan, good = TipScore.of(tip, val.tip, 0.08), TipScore.of(val.tip + 1e-3, val.tip, 0.08)
    assert math.isnan(nan.tip_rmse_mm)
    assert BenchmarkResult._best({"node_lstm": nan, "physics": good}) == "physics"
    # over the physics, a diverged residual counts only where its weight is not zero: elsewhere the physics

    class Reach:                                        # rows 12 on are far from the training rows (w = 0)
        def __call__(self, session):
            return np.where(np.arange(session.n_rows) < 12, 0.0, np.inf)

    physics = Physics(TendonRobot((0.08,), 3, 4e-3), FAST["calibration"]).fit([sessions[0]])
    over = NodeFamily(0.08, model=object(), physics=physics, on_physics=True, gate=1.0, reach=Reach(),
                      anchor=np.zeros(3), low=np.full(val.n_inputs, -np.inf), high=np.full(val.n_inputs, np.inf))
    tip = over.predict(val)
    base = physics.predict(val)
    np.testing.assert_array_equal(tip[:H], base[:H])               # from a zero residual, no recorded tip
    assert np.all(np.isnan(tip[9:12])) and np.array_equal(tip[12:], base[12:])


def test_the_node_lstm_reads_every_session_at_its_training_step_however_it_is_paced(sessions):
    """The hold-out rows recorded twice as fast as the fitting rows, the validation rows at 1.5 s: the
    node LSTM reads each as rows of its training step (a quasi-static recording's rows are steps), instead
    of refusing the hold-out part as 'sampled unlike the training data'."""
    train, val = sessions
    fit_part, held = holdout_split([train])
    held_start = {float(s.time[0]) for s in held}
    dt, t = np.full(train.n_rows - 1, 0.6), train.time
    for k in range(1, train.n_rows):
        if any(s.time[0] <= t[k] <= s.time[-1] for s in held) and float(t[k]) not in held_start:
            dt[k - 1] = 0.3
    paced = dataclasses.replace(train, time=np.concatenate([[0.0], np.cumsum(dt)]))
    fit2, held2 = holdout_split([paced])
    assert np.median(np.diff(np.concatenate([s.time for s in held2]))) == pytest.approx(0.3)
    small = NodeOptions(units=4, training=dataclasses.replace(NODE_TRAINING, epochs=1, rollout_steps=2))
    model = NodeFamily(0.08, small).fit([paced])
    assert model.step == pytest.approx(0.6)
    slow = dataclasses.replace(val, time=np.arange(val.n_rows) * 1.5)
    tip = model.predict(slow)
    assert tip.shape == (val.n_rows, 3) and np.all(np.isfinite(tip))


def test_session_agreement_tells_a_robot_that_changed_between_sessions_from_one_that_did_not(sessions):
    """The validation session recorded from the training session's robot: every refit reaches the
    marker noise there. Recorded after every tendon's slack shifted by 0.8 mm (the drift a real robot
    shows between sessions): the physics' form fits that session alone as well, but no one set of
    parameters fits both sessions: together they leave several mm on the validation rows and worsen the
    training rows, and the training calibration misses most."""
    from softrnn.lab.tendon_robot import tip_positions

    train, val = sessions
    robot, truth = tendon_robot_truth()
    physics = Physics(robot, FAST["calibration"]).fit([train])
    same = session_agreement(physics, [train], val, 0.08)
    assert {"what", "variant", "training_only", "validation_only", "training_and_validation"} == set(same)
    for key in ("training_only", "validation_only", "training_and_validation"):
        assert same[key]["validation_tip_rmse_mm"] < 0.5, key
        assert same[key]["training_tip_rmse_mm"] < 0.5, key
    shifted = dataclasses.replace(truth, offsets=truth.offsets + 0.8e-3)
    noise = np.random.default_rng(7).normal(0.0, 0.1e-3, val.tip.shape)
    drifted = dataclasses.replace(val, tip=tip_positions(robot, shifted, val.inputs * 1e-3)[0] + noise)
    moved = session_agreement(physics, [train], drifted, 0.08)
    alone, both, first = (moved[k] for k in ("validation_only", "training_and_validation", "training_only"))
    assert alone["validation_tip_rmse_mm"] < 0.5
    assert both["validation_tip_rmse_mm"] > 4 * alone["validation_tip_rmse_mm"]
    assert both["training_tip_rmse_mm"] > 4 * first["training_tip_rmse_mm"]
    assert first["validation_tip_rmse_mm"] > both["validation_tip_rmse_mm"]
    assert first["validation_tip_mean_aligned_pct_of_length"] > 0


def test_the_node_lstm_s_error_scale_is_its_distance_from_the_physics_plus_the_physics_error(sessions, monkeypatch):
    """Fitted with a calibrated physics, the node LSTM states the sequence model's scale: |tip - physics
    tip| + the physics' RMS error over the rows it was fitted on (``families.Anchored``); without one, 1."""
    import softrnn.learned.node.train as node_train

    train, val = sessions
    physics = Physics(TendonRobot((0.08,), 3, 4e-3), FAST["calibration"]).fit([train])
    monkeypatch.setattr(node_train, "train_node_model", lambda *a, **k: "trained")
    monkeypatch.setattr(NodeFamily, "predict", lambda self, s: s.tip + 2e-3)
    model = NodeFamily(0.08, physics=physics).fit([train])
    rms = float(np.sqrt(np.mean(np.sum((physics.predict(train) - train.tip) ** 2, axis=1))))
    assert model.model == "trained" and model.physics_rms == pytest.approx(rms, rel=1e-12)
    gap = np.linalg.norm(val.tip + 2e-3 - physics.predict(val), axis=1)
    np.testing.assert_allclose(model.error_scale(val), gap + rms, rtol=1e-12)
    assert model.describe()["error_scale_physics_rms_mm"] == pytest.approx(rms * 1e3, abs=1e-4)
    alone = NodeFamily(0.08).fit([train])
    assert alone.physics_rms is None and np.array_equal(alone.error_scale(val), np.ones(val.n_rows))
    assert "error_scale" not in alone.describe()
    assert alone.anchored(physics, [train]).physics_rms == pytest.approx(rms, rel=1e-12)


def test_a_tip_that_moves_beyond_the_robots_reach_or_hardly_at_all_is_refused():
    """The tip's largest distance from its mean position, against the length: a tip on a sphere of the
    length's radius around its base (the farthest a robot reaches) passes, as does one that moves by 2 % of
    the length; 2.6 times the length (positions in mm read as m move 1000 times farther) and 0.5 % (m read
    as mm: 1000 times less) are refused, naming the length and the unit to give."""
    rng = np.random.default_rng(0)
    v = rng.normal(size=(400, 3))
    sphere = 0.2 * v / np.linalg.norm(v, axis=1, keepdims=True)

    def session(tip):
        return Recording(path="s.csv", time=np.arange(len(tip)) * 0.5, inputs=np.zeros((len(tip), 1)), names=("a",),
                         units=("mm",), tip=tip)
    check_reach([session(sphere)], 0.2)
    check_reach([session(sphere * 0.02)], 0.2)
    for scale, words in ((2.6, "drop --position-unit m"), (0.005, "pass --position-unit m")):
        with pytest.raises(SoftrnnInputError, match=f"length=0.2 is invalid: .*{words}") as err:
            check_reach([session(sphere * scale), session(sphere[:5] * scale)], 0.2)
        assert "\n" not in str(err.value)
    assert TIP_REACH[0] < 0.02 and TIP_REACH[1] > 1.0
