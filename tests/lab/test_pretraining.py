"""The learned families taught by the physics (``softrnn.lab.nets``) on a known tendon robot: a map
pretrained on the physics' synthetic sessions carries over to commands never recorded, the hybrid
is its physics away from the training data and physics + residual on them, and the 90 % intervals
(``softrnn.lab.uncertainty``) hold about 90 % of fresh rows."""

import math
from dataclasses import dataclass, replace

import numpy as np
import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.lab.families import NODE_TRAINING, NodeFamily, NodeOptions, Physics, holdout_split
from softrnn.lab.nets import Hybrid, LearnedMap, NetOptions, Sequence, SequenceOptions
from softrnn.lab.recording import Recording, read_recording
from softrnn.lab.synthetic import SyntheticOptions
from softrnn.lab.tendon_robot import Calibration
from softrnn.lab.uncertainty import (
    InputDistance,
    WithInterval,
    calibrate,
    conformal_q,
    cross_fit,
    quantile,
    stretches,
    with_interval,
)

from helpers import Drifting, Recalling, tendon_recording, tendon_robot_truth

SMALL = NetOptions(members=3, steps=300, hidden=16)


def _physics(n_segments=1):
    robot, params = tendon_robot_truth(n_segments)
    return Physics(robot, calibration=Calibration(robot, params, 0.0, (), 0.0))


def _session(physics, u_mm, seed, noise_mm=0.1, path=""):
    """A recording of ``physics`` driven by commands ``u_mm`` (T, m) [mm], marker noise ``noise_mm`` per axis."""
    T, m = u_mm.shape
    rec = Recording(path=path, time=np.arange(T) * 0.6, inputs=u_mm, names=tuple(f"servo_{i}" for i in range(m)),
                    units=("mm",) * m, tip=np.zeros((T, 3)))
    tip = physics.predict(rec) + np.random.default_rng(seed).normal(0, noise_mm * 1e-3, (T, 3))
    return replace(rec, tip=tip)


def _one_segment_at_a_time(rows, seed, both=False):
    """Commands of a two-segment robot: smooth random pulls of one segment's tendons while the other's
    rest (``both``: both segments at once) [mm]."""
    rng = np.random.default_rng(seed)
    k = np.arange(rows)[:, None]
    u = 3.0 * np.sin(0.05 * k * (1 + 0.3 * np.arange(6)) + rng.uniform(0, 6.3, 6)) - 0.5
    if not both:
        u[: rows // 2, 3:] = -0.5
        u[rows // 2:, :3] = -0.5
    return u


@pytest.fixture(scope="module")
def two_segments():
    physics = _physics(2)
    train = _session(physics, _one_segment_at_a_time(300, 0), 0)
    test = _session(physics, _one_segment_at_a_time(200, 1, both=True), 1)
    return physics, train, test


def _rmse_mm(model, session):
    return float(np.sqrt(np.mean(np.sum((model.predict(session) - session.tip) ** 2, axis=1)))) * 1e3


def test_pretraining_on_the_physics_carries_to_unrecorded_combinations(two_segments):
    """Trained on one segment at a time, tested on both together: the map that learnt from the
    physics' synthetic sessions (segments combined) is far better than the map of the real rows alone."""
    physics, train, test = two_segments
    syn, nets = SyntheticOptions(amount=4.0), NetOptions(members=2, steps=1000, hidden=32)
    real = LearnedMap(options=nets).fit([train])
    taught = {m: LearnedMap(options=nets, mode=m, synthetic=syn, physics=physics).fit([train])
              for m in ("finetune", "mixed")}
    for m, model in taught.items():
        assert _rmse_mm(model, test) < 0.75 * _rmse_mm(real, test), m
        assert model.describe()["mode"] == m and model.describe()["synthetic"]["amount_x_real_rows"] == 4.0
    seq = Sequence(SequenceOptions(epochs=2, hidden=8), mode="finetune", synthetic=syn, physics=physics).fit([train])
    assert seq.predict(test).shape == test.tip.shape and seq.describe()["mode"] == "finetune"


def test_the_sequence_refit_trains_the_real_rows_again_from_its_pretraining(two_segments, monkeypatch):
    """The cross-fit's refit starts from the network the synthetic sessions pretrained: on the rows the
    model was fitted on it gives the model again, to the last bit, and it draws no synthetic session."""
    from softrnn.lab import nets

    physics, train, test = two_segments
    seq = Sequence(SequenceOptions(epochs=3, hidden=8), mode="finetune", synthetic=SyntheticOptions(amount=2.0),
                   physics=physics).fit([train])
    drawn = []
    monkeypatch.setattr(nets, "taught_sessions", lambda *a, **k: drawn.append(a) or [])
    again = seq.refit([train])
    assert np.array_equal(again.predict(test), seq.predict(test)) and drawn == []
    half = seq.refit([train.rows(0, train.n_rows // 2)])
    assert not np.array_equal(half.predict(test), seq.predict(test)) and drawn == []
    real = Sequence(SequenceOptions(epochs=3, hidden=8)).fit([train])
    assert real.pretrained is None
    assert np.array_equal(real.refit([train]).predict(test), real.predict(test))    # mode real: fit again


def test_the_sequence_error_scale_is_its_distance_from_the_physics_plus_the_physics_error(two_segments):
    """|GRU tip - physics tip| + the physics' RMS error over the training rows (here the marker noise,
    sqrt(3) x 0.1 mm), recomputed over the rows of a refit; 1 per row without a physics."""
    physics, train, test = two_segments
    seq = Sequence(SequenceOptions(epochs=2, hidden=8), physics=physics).fit([train])
    rms = float(np.sqrt(np.mean(np.sum((physics.predict(train) - train.tip) ** 2, axis=1))))
    assert seq.physics_rms == pytest.approx(rms, rel=1e-12) and rms == pytest.approx(math.sqrt(3) * 1e-4, rel=0.15)
    gap = np.linalg.norm(seq.predict(test) - physics.predict(test), axis=1)
    np.testing.assert_allclose(seq.error_scale(test), gap + rms, rtol=1e-12)
    assert seq.describe()["error_scale_physics_rms_mm"] == pytest.approx(rms * 1e3, abs=1e-4)
    half = train.rows(0, 150)
    refitted = seq.refit([half])
    assert refitted.physics_rms == pytest.approx(
        float(np.sqrt(np.mean(np.sum((physics.predict(half) - half.tip) ** 2, axis=1)))), rel=1e-12)
    @dataclass(frozen=True)
    class Diverged:                                   # a physics whose run leaves the numbers after row 10
        calibration: object = physics.calibration

        def predict(self, session):
            tip = physics.predict(session)
            tip[10:] = np.nan
            return tip
    scale = replace(seq, physics=Diverged()).error_scale(test)
    assert np.all(np.isfinite(scale[:10])) and np.all(np.isinf(scale[10:]))
    alone = Sequence(SequenceOptions(epochs=2, hidden=8)).fit([train])
    assert alone.physics_rms is None and np.array_equal(alone.error_scale(test), np.ones(test.n_rows))
    assert "error_scale" not in alone.describe()


def test_a_sequence_over_the_physics_learns_what_it_leaves(two_segments):
    """``on_physics``: the GRU adds to a physics that misses (its marker 8 mm off) and reads its tip. On the
    unrecorded combinations (both segments at once) it leaves far less than that physics and than the GRU
    alone, which never saw them; gated (``gate``), it is its physics far from the data and itself on them;
    without a calibrated physics it refuses in one line."""
    physics, train, test = two_segments
    crude = Physics(physics.robot, calibration=replace(
        physics.calibration, params=replace(physics.calibration.params, marker=8e-3)))
    options = SequenceOptions(epochs=60, hidden=16)
    over = Sequence(options, physics=crude, on_physics=True).fit([train])
    alone = Sequence(options).fit([train])
    assert _rmse_mm(over, test) < 0.5 * _rmse_mm(crude, test) and _rmse_mm(over, test) < 0.5 * _rmse_mm(alone, test)
    assert "over the calibrated physics' tip" in over.describe()["kind"]
    assert np.allclose(over.refit([train]).predict(test), over.predict(test), atol=1e-6)   # real rows: fit again
    # the GRU reads the commands clipped to their training range (its state would carry a command no
    # training row reached to the rows after); the physics reads them as they are
    assert np.all(over.low <= train.inputs) and np.all(train.inputs <= over.high)
    pulled = replace(test, inputs=test.inputs + np.where(np.arange(test.n_rows)[:, None] < 50, 40.0, 0.0))
    clipped = replace(pulled, inputs=np.clip(pulled.inputs, over.low, over.high))

    @dataclass(frozen=True)
    class Still:                                      # a physics whose tip ignores the commands
        calibration: object = crude.calibration

        def predict(self, session):
            return crude.predict(test)
    np.testing.assert_array_equal(replace(over, physics=Still()).predict(pulled),
                                  replace(over, physics=Still()).predict(clipped))
    assert not np.array_equal(over.predict(pulled), over.predict(clipped))         # the physics reads them all
    assert Sequence(options).fit([train]).low is None                                # the GRU alone: not clipped
    gated = replace(over, gate=0.5)                    # the hybrid's gate: its physics away from the data
    far = _session(physics, train.inputs + 6.0, 2)
    np.testing.assert_array_equal(gated.predict(far), crude.predict(far))
    np.testing.assert_allclose(gated.predict(train), over.predict(train), rtol=0, atol=1e-12)
    assert "gated off away from the training data" in gated.describe()["kind"] and gated.describe()["gate_d0"] == 0.5
    # where the gate is off it states its physics' interval too (FollowsPhysics), its own on the data
    own = WithInterval(crude, InputDistance.of([train]), interval_q=2e-3, interval_slope=1e-3, interval_knee=0.0)
    stated = replace(gated, interval_q=3.0, interval_slope=0.5, interval_knee=0.0)
    follows = replace(stated, physics_interval=own)
    farther = _session(physics, train.inputs + 60.0, 4)
    np.testing.assert_allclose(follows.predict_interval(farther)[1], own.predict_interval(farther)[1], rtol=1e-12)
    np.testing.assert_allclose(follows.predict_interval(train)[1], stated.predict_interval(train)[1], rtol=1e-12)
    assert "interval_90_beyond_gate" in follows.describe()
    alone_stated = replace(alone, interval_q=3.0, interval_slope=0.5, interval_knee=0.0)
    assert alone_stated.physics_weights(train) is None                               # no physics to follow
    np.testing.assert_array_equal(replace(alone_stated, physics_interval=own).predict_interval(farther)[1],
                                  alone_stated.predict_interval(farther)[1])
    with pytest.raises(SoftrnnInputError, match="on_physics=True is invalid: a calibrated physics"):
        Sequence(options, on_physics=True).fit([train])
    with pytest.raises(SoftrnnInputError, match="linear=True is invalid: linear=False with on_physics=True"):
        Sequence(options, physics=crude, on_physics=True, linear=True)


def test_a_node_lstm_over_the_physics_learns_what_it_leaves_from_the_commands_alone(two_segments):
    """``NodeFamily(on_physics=True)``: the node LSTM learns the residual of a physics that misses (its marker
    8 mm off). On the unrecorded combinations it leaves far less than that physics; it reads no recorded tip
    (its run starts from a zero residual); gated, it is its physics far from the data; it refuses without a
    calibrated physics and with the physics' synthetic sessions, which have no residual to learn."""
    physics, train, test = two_segments
    crude = Physics(physics.robot, calibration=replace(
        physics.calibration, params=replace(physics.calibration.params, marker=8e-3)))
    options = NodeOptions(units=16, training=replace(NODE_TRAINING, epochs=30))
    over = NodeFamily(0.08, options, physics=crude, on_physics=True).fit([train])
    assert _rmse_mm(over, test) < 0.5 * _rmse_mm(crude, test)
    np.testing.assert_array_equal(over.predict(replace(test, tip=test.tip + 0.05)), over.predict(test))
    np.testing.assert_array_equal(over.predict(test)[:options.history], crude.predict(test)[:options.history])
    # it reads the commands clipped to their training range: a servo pulled far beyond it drives the
    # physics, not the node's run (whose state would carry to the rows after)
    pulled = replace(test, inputs=test.inputs + np.where(np.arange(test.n_rows)[:, None] < 50, 40.0, 0.0))
    clipped = replace(pulled, inputs=np.clip(pulled.inputs, over.low, over.high))
    np.testing.assert_allclose(over.predict(pulled) - crude.predict(pulled),
                               over.predict(clipped) - crude.predict(clipped), rtol=0, atol=1e-15)
    assert np.all(over.low <= train.inputs) and np.all(train.inputs <= over.high)
    assert "of what the calibrated physics' tip leaves" in over.describe()["kind"]
    gated = replace(over, gate=0.5)
    far = _session(physics, train.inputs + 6.0, 2)
    np.testing.assert_array_equal(gated.predict(far), crude.predict(far))
    np.testing.assert_allclose(gated.predict(train), over.predict(train), rtol=0, atol=1e-12)
    assert "gated off away from the training data" in gated.describe()["kind"] and gated.describe()["gate_d0"] == 0.5
    # the benchmark blends its interval with the physics' by the residual's weight, as the hybrid's
    stated = WithInterval(gated, InputDistance.of([train]))
    assert np.all(stated.physics_weights(far) < 1e-60)
    np.testing.assert_allclose(stated.physics_weights(train), 1.0, atol=1e-12)
    assert WithInterval(NodeFamily(0.08, options)).physics_weights(train) is None
    with pytest.raises(SoftrnnInputError, match="on_physics=True is invalid: a calibrated physics"):
        NodeFamily(0.08, options, on_physics=True).fit([train])
    with pytest.raises(SoftrnnInputError, match="mode='mixed' is invalid: 'real' with on_physics=True"):
        NodeFamily(0.08, options, mode="mixed", physics=crude, on_physics=True)


def test_an_early_sequence_candidate_is_calibrated_with_the_scale_of_its_final_fit(two_segments):
    """The candidate of mode ``real`` fitted before the physics was calibrated (no physics, scale 1) is
    calibrated with the physics' scale, as the final model (fitted with the physics) states it: its q is
    that of the same candidate given the physics, not of the scale 1."""
    from types import SimpleNamespace

    from softrnn.lab.nets import candidate, fit_sequence

    physics, train, _ = two_segments
    options = SimpleNamespace(sequence=SequenceOptions(epochs=2, hidden=8))
    fit_part, held = holdout_split([train])
    early = Sequence(options.sequence).fit(fit_part)
    assert early.physics is None and early.physics_rms is None
    # every candidate ties but the GRU over a linear base (kept first in a tie): the early one is chosen
    model, _ = fit_sequence([train], (physics, physics), SyntheticOptions(amount=0.0), options,
                            lambda m: 2.0 if m.linear else 1.0, {candidate("real"): early})
    anchored = early.anchored(physics, fit_part)
    assert anchored.physics_rms == pytest.approx(
        float(np.sqrt(np.mean(np.sum((physics.predict(fit_part[0]) - fit_part[0].tip) ** 2, axis=1)))))
    assert model.physics_rms is not None
    assert model.interval_q == calibrate(anchored, fit_part, held)["interval_q"]
    assert model.interval_q != calibrate(early, fit_part, held)["interval_q"]


def test_modes_need_a_physics_and_synthetic_data(two_segments):
    physics, train, _ = two_segments
    without = "mode='mixed' is invalid: 'real' for the learned_map family without a calibrated physics"
    with pytest.raises(SoftrnnInputError, match=without):
        LearnedMap(options=SMALL, mode="mixed").fit([train])
    with pytest.raises(SoftrnnInputError, match="mode='finetune' is invalid: 'real' for the learned_map family"):
        LearnedMap(options=SMALL, mode="finetune", synthetic=SyntheticOptions(amount=0), physics=physics).fit([train])
    with pytest.raises(SoftrnnInputError, match="mode='finetune' is invalid: one of real, mixed for the hybrid"):
        Hybrid(physics, options=SMALL, mode="finetune").fit([train])
    with pytest.raises(SoftrnnInputError, match="mode='mixed' is invalid: one of real, finetune for the sequence"):
        Sequence(mode="mixed").fit([train])
    with pytest.raises(SoftrnnInputError, match="mode='magic' is invalid: one of real, finetune, mixed"):
        LearnedMap(options=SMALL, mode="magic").fit([train])


def test_a_long_recording_trains_on_random_draws_as_well_as_on_all_its_rows():
    """Beyond ``NetOptions.batch`` rows a step draws that many at random: on 2,400 rows of a smooth
    one-segment robot, steps on draws of 300 rows fit fresh commands about as well as steps on all
    2,400 (both within a tenth of the tip's spread), and the draws are seeded: the same fit twice is the
    same map."""
    physics = _physics(1)
    k = np.arange(2400)[:, None]
    def smooth(rows, seed):
        phase = np.random.default_rng(seed).uniform(0, 6.3, 3)
        return 3.0 * np.sin(0.013 * k[:rows] * (1 + 0.37 * np.arange(3)) + phase) - 0.5
    train, fresh = _session(physics, smooth(2400, 3), 3), _session(physics, smooth(300, 4), 4)
    whole = LearnedMap(options=replace(SMALL, batch=2400)).fit([train])
    drawn = LearnedMap(options=replace(SMALL, batch=300)).fit([train])
    spread = float(np.sqrt(np.mean(np.sum((fresh.tip - fresh.tip.mean(axis=0)) ** 2, axis=1)))) * 1e3
    assert _rmse_mm(whole, fresh) < 0.1 * spread
    assert _rmse_mm(drawn, fresh) < 1.5 * _rmse_mm(whole, fresh)
    again = LearnedMap(options=replace(SMALL, batch=300)).fit([train])
    assert np.array_equal(drawn.predict(fresh), again.predict(fresh))
    with pytest.raises(SoftrnnInputError, match="batch=0 is invalid: an integer >= 1"):
        NetOptions(batch=0)


def test_hybrid_is_its_physics_far_from_the_data_and_physics_plus_residual_on_them(two_segments):
    physics, train, _ = two_segments
    crude = Physics(physics.robot, calibration=replace(
        physics.calibration, params=replace(physics.calibration.params, marker=8e-3)))     # a physics that misses
    hybrid = Hybrid(crude, options=SMALL, gate=0.5).fit([train])
    far = _session(physics, train.inputs + 6.0, 2)                                     # every tendon pulled 6 mm more
    np.testing.assert_allclose(hybrid.predict(far), crude.predict(far), rtol=0, atol=1e-15)
    assert np.all(hybrid.weights(far) < 1e-30)
    base = crude.predict(train)
    residual = hybrid.net(hybrid._X(train, base))
    assert np.sqrt(np.mean(residual ** 2)) > 1e-4                                      # a residual that matters
    np.testing.assert_allclose(hybrid.predict(train), base + residual, rtol=1e-12, atol=1e-15)
    assert np.all(hybrid.weights(train) == 1.0)
    near = _session(physics, train.inputs + 0.3, 3)
    w = hybrid.weights(near)
    assert np.all((w > 0) & (w < 1))                                                   # falls off in between
    ungated = replace(hybrid, gate=math.inf)
    base = crude.predict(far)
    np.testing.assert_allclose(ungated.predict(far), base + ungated.net(ungated._X(far, base)))
    assert "gated off" in hybrid.describe()["kind"] and hybrid.describe()["gate_d0"] == 0.5


def test_where_the_gate_is_off_the_hybrid_states_its_physics_interval(two_segments):
    physics, train, _ = two_segments
    crude = Physics(physics.robot, calibration=replace(
        physics.calibration, params=replace(physics.calibration.params, marker=8e-3)))
    hybrid = replace(Hybrid(crude, options=SMALL, gate=0.5).fit([train]), interval_q=3.0, interval_slope=0.5,
                     interval_knee=0.0)
    own = WithInterval(crude, InputDistance.of([train]), interval_q=2e-3, interval_slope=1e-3, interval_knee=0.0)
    blended = replace(hybrid, physics_interval=own)
    far, near = _session(physics, train.inputs + 6.0, 2), _session(physics, train.inputs + 0.3, 3)
    for s in (far, near, train):
        w = hybrid.weights(s)
        tip, r = blended.predict_interval(s)
        np.testing.assert_array_equal(tip, hybrid.predict(s))
        mine, theirs = hybrid.predict_interval(s)[1], own.predict_interval(s)[1]
        np.testing.assert_allclose(r, (1 - w) * theirs + w * mine, rtol=1e-12)
    np.testing.assert_allclose(blended.predict_interval(far)[1], own.predict_interval(far)[1], rtol=1e-12)
    np.testing.assert_allclose(blended.predict_interval(train)[1], hybrid.predict_interval(train)[1], rtol=1e-12)
    # an unbounded radius of one part counts only where its weight is not zero
    unbounded = replace(blended, interval_q=math.inf)
    farther = _session(physics, train.inputs + 60.0, 4)
    assert np.all(hybrid.weights(farther) == 0.0)
    np.testing.assert_allclose(unbounded.predict_interval(farther)[1], own.predict_interval(farther)[1], rtol=1e-12)
    assert np.all(unbounded.predict_interval(train)[1] == math.inf)
    assert "physics' interval" in blended.describe()["interval_90_beyond_gate"]
    assert "interval_90_beyond_gate" not in hybrid.describe()


@pytest.fixture(scope="module")
def noisy(tmp_path_factory):
    """Sessions of the one-segment robot with 0.5 mm marker noise per axis: fit, hold-out, fresh."""
    d = tmp_path_factory.mktemp("noisy")
    out = []
    for name, rows, seed in (("fit", 300, 0), ("held", 400, 1), ("fresh", 3000, 2)):
        tendon_recording(d / f"{name}.csv", rows=rows, seed=seed, noise_mm=0.5)
        out.append(read_recording(d / f"{name}.csv"))
    return out


def _coverage(model, session):
    tip, radius = model.predict_interval(session)
    np.testing.assert_array_equal(tip, model.predict(session))
    assert radius.shape == (session.n_rows,) and np.all(radius > 0)
    return float(np.mean(np.linalg.norm(tip - session.tip, axis=1) <= radius))


def test_a_constant_interval_of_known_noise_holds_90_percent_of_fresh_rows(noisy):
    """The exact physics on data with Gaussian noise (0.5 mm per axis): the radius calibrated on 400
    hold-out rows is near the chi (3 dof) 90 % quantile, 0.5 mm x 2.50, and holds ~90 % of fresh rows."""
    _, held, fresh = noisy
    exact = _physics(1)
    model = with_interval(exact, exact, [held], [held])
    assert model.interval_q == pytest.approx(0.5e-3 * 2.5003, rel=0.1)
    assert 0.87 <= _coverage(model, fresh) <= 0.93
    assert model.describe()["interval_90_radius_mm"] == pytest.approx(model.interval_q * 1e3, abs=1e-4)
    with pytest.raises(ValueError, match="not calibrated"):
        WithInterval(exact).predict_interval(fresh)


def test_learned_intervals_hold_about_90_percent_of_fresh_rows(noisy):
    fit, held, fresh = noisy
    physics = _physics(1)
    for model in (LearnedMap(options=SMALL).fit([fit]), Hybrid(physics, options=SMALL, gate=1.0).fit([fit]),
                  with_interval(physics, physics, [fit], [held], [fit])):
        calibrated = replace(model, interval_q=conformal_q(model, [held]))
        assert 0.8 <= _coverage(calibrated, fresh) <= 0.97, model.name


def test_intervals_grow_with_the_distance_from_the_training_rows(noisy):
    fit, held, _ = noisy
    physics = _physics(1)
    model = with_interval(physics, physics, [fit], [held], [fit])
    far = replace(fit, inputs=fit.inputs + 3 * fit.inputs.std(axis=0))
    d = InputDistance.of([fit])(far)
    assert np.all(d > 0.0) and np.mean(d) > 2.0 and np.all(InputDistance.of([fit])(fit) == 0.0)
    np.testing.assert_allclose(model.predict_interval(far)[1], model.interval_q * (1 + d))
    np.testing.assert_allclose(model.predict_interval(fit)[1], model.interval_q)
    assert model.describe()["interval_grows_with_distance"]


def test_too_few_hold_out_rows_for_the_quantile_give_an_unbounded_interval(noisy):
    fit, held, fresh = noisy
    exact = _physics(1)
    five = replace(held, time=held.time[:5], inputs=held.inputs[:5], tip=held.tip[:5], labels=())
    model = with_interval(exact, exact, [fit], [five], [fit])           # rank ceil(6 x 0.9) = 6 > 5 rows
    assert model.interval_q == math.inf and model.describe()["interval_90_radius_mm"] is None
    assert np.all(model.predict_interval(fresh)[1] == math.inf)


def _line(u, seed, noise=0.5e-3):
    """A recording of the tip (u mm, 0, 0) with ``noise`` [m] per axis, one input ``u`` (T,) [mm]."""
    tip = np.column_stack([u * 1e-3, np.zeros((len(u), 2))]) + np.random.default_rng(seed).normal(0, noise, (len(u), 3))
    return Recording(path="", time=np.arange(len(u)) * 0.6, inputs=u[:, None], names=("a",), units=("mm",), tip=tip)


@pytest.mark.parametrize("c", [0.2e-3, 5e-3])
def test_two_regime_intervals_hold_90_percent_near_the_training_rows_and_beyond(c):
    """Fitted on u in [-1, 1] and held out on [1, 3]: q holds 90 % of the fitting rows (the noise's chi
    quantile, 0.5 mm x 2.50), the growth b 90 % of the held rows; refitted on both, the ball holds
    about 90 % of fresh rows inside and beyond them, however fast the error grows (the q (1 + d) law
    holds 34-74 % of them at c = 0.2 and 1 mm per standard deviation, 100 % at 5 mm)."""
    rng = np.random.default_rng(0)
    fit, held = _line(rng.uniform(-1, 1, 800), 1), _line(rng.uniform(1, 3, 300), 2)
    family = Drifting(c)
    model = with_interval(family.fit([fit, held]), family.fit([fit]), [fit], [held], [fit, held], fitted=True)
    assert model.interval_q == pytest.approx(0.5e-3 * 2.5003, rel=0.1)
    assert 0.0 < model.interval_slope <= 1.5 * c
    held_model = replace(model, model=family.fit([fit]), reach=InputDistance.of([fit]))
    assert _coverage(held_model, fit) >= 0.9 and _coverage(held_model, held) >= 0.9
    for low, high in ((-1, 3), (-2, 4.5)):
        assert 0.85 <= _coverage(model, _line(rng.uniform(low, high, 3000), 3)) <= 0.95
    probe = _line(np.linspace(3.5, 6.0, 40), 4)
    beyond = np.maximum(model.reach(probe) - model.interval_knee, 0.0)
    assert np.all(beyond > 0.0)
    np.testing.assert_allclose(model.predict_interval(probe)[1], model.interval_q + model.interval_slope * beyond)
    assert model.describe()["interval_90_growth_mm"] == pytest.approx(model.interval_slope * 1e3, abs=1e-4)


def test_calibrate_takes_the_conformal_ranks_of_both_parts():
    """q: rank ceil(10 x 0.9) = 9 of the 9 fitting rows' errors / scale; b: the same rank of the held
    rows' needed growth max(0, ratio - q) / d; inf at d = 0 for a row outside, 0 for a row inside."""
    @dataclass(frozen=True, eq=False)
    class Stub:
        errors: dict
        reach: object = None
        name: str = "stub"

        def predict(self, s):
            return s.tip + np.column_stack([self.errors[s.path], np.zeros((s.n_rows, 2))])

        def error_scale(self, s):
            return np.full(s.n_rows, 2.0)

    def part(path, d):
        d = np.asarray(d, dtype=float)
        return Recording(path=path, time=np.arange(d.size, dtype=float), inputs=d[:, None], names=("a",),
                         units=("mm",), tip=np.zeros((d.size, 3)))
    fit, held = part("fit", np.zeros(9)), part("held", np.arange(1.0, 10.0))
    errors = {"fit": np.arange(1.0, 10.0) * 2.0, "held": 2.0 * (9.0 + np.arange(1.0, 10.0) ** 2)}
    out = calibrate(Stub(errors, reach=lambda s: s.inputs[:, 0]), [fit], [held])
    assert out == {"interval_q": 9.0, "interval_slope": 9.0, "interval_knee": 0.0}   # ratio - q = d^2: need d, rank 9
    assert calibrate(Stub(errors), [fit], [held]) == {"interval_q": 90.0, "interval_slope": 0.0, "interval_knee": 0.0}
    zero = part("held", [0.0] * 9)
    out = calibrate(Stub({"fit": errors["fit"], "held": np.full(9, 30.0)}, reach=lambda s: s.inputs[:, 0]), [fit],
                    [zero])
    assert out["interval_slope"] == math.inf
    assert calibrate(Stub({"fit": errors["fit"], "held": np.full(9, 2.0)}, reach=lambda s: s.inputs[:, 0]), [fit],
                     [zero])["interval_slope"] == 0.0


def _visits(count, seed, path, spread=2e-3, noise=0.2e-3):
    """A session of ``count`` visits of 30 rows to five command levels (6 rows each, in a random
    order); the tip (u mm, 0, 0) is off by ``spread`` [m] per axis, drawn anew at each visit (hysteresis),
    plus marker noise ``noise`` [m] per axis."""
    rng = np.random.default_rng(seed)
    u = np.concatenate([np.repeat(rng.permutation(5).astype(float), 6) for _ in range(count)])
    offset = np.repeat(rng.normal(0.0, spread, (count, 3)), 30, axis=0)
    tip = np.column_stack([u * 1e-3, np.zeros((u.size, 2))]) + offset + rng.normal(0.0, noise, (u.size, 3))
    return Recording(path=path, time=np.arange(u.size) * 0.6, inputs=u[:, None], names=("a",), units=("mm",),
                     tip=tip)


def test_intervals_hold_the_spread_between_visits_of_the_same_commands():
    """A model exact on the rows it was fitted on, off by the spread between visits on any other (2 mm
    per axis): the quantile over its fitted rows is 0, a radius that holds no row of a fresh session;
    the cross-fit (refitted on every other stretch, run over those in between, which revisit the same
    commands) sees the spread, and the ball holds 80-95 % of a fresh session's rows."""
    train, fresh = _visits(40, 0, "train"), _visits(100, 1, "fresh")
    fit_part, held = holdout_split([train])
    family = Recalling()
    fitted = WithInterval(family.fit(fit_part), InputDistance.of(fit_part))
    on_fitted = np.concatenate([np.linalg.norm(fitted.predict(s) - s.tip, axis=1) for s in fit_part])
    assert quantile(on_fitted) == 0.0
    ratio, d = cross_fit(fitted, fit_part)
    assert ratio.size == sum(s.n_rows for s in stretches(fit_part, 1)) and np.all(d == 0.0)
    model = with_interval(family.fit([train]), family.fit(fit_part), fit_part, held, [train], fitted=True)
    assert model.interval_q == quantile(ratio) > 2e-3
    assert 0.8 <= _coverage(model, fresh) <= 0.95


def test_a_run_that_diverges_lies_in_no_ball_even_where_its_scale_is_unbounded():
    """Where a model's run is not finite, its scale from the physics or its refits is unbounded too
    (inf / inf): the row needs an unbounded ball, not a NaN that would make q NaN and every radius NaN."""
    @dataclass(frozen=True, eq=False)
    class Diverging:
        reach: object = None
        name: str = "diverging"

        def predict(self, s):
            tip = s.tip + np.column_stack([np.full(s.n_rows, 1e-3), np.zeros((s.n_rows, 2))])
            tip[s.inputs[:, 0] > 8.5] = np.nan
            return tip

        def error_scale(self, s):
            return np.where(s.inputs[:, 0] > 8.5, math.inf, 1.0)

    rows = Recording(path="", time=np.arange(20.0), inputs=np.arange(20.0)[:, None] / 2, names=("a",),
                     units=("mm",), tip=np.zeros((20, 3)))
    out = calibrate(Diverging(), [rows], [rows])
    assert out["interval_q"] == math.inf                     # 2 of 20 rows off without bound: rank 19 of 20
    assert calibrate(Diverging(), [rows.rows(0, 18)], [rows.rows(0, 18)])["interval_q"] == pytest.approx(1e-3)
