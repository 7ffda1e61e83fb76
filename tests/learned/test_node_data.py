"""Samples of the node models: neighbours, window layout, the chronological split (no test sample
reaches training) and the normalisation."""

import math

import numpy as np
import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.learned.node.data import (
    NODE_POSITION,
    Normalizer,
    SampleSpec,
    make_windows,
    pose_rows,
    split,
    wrench_rows,
    wrench_units,
)
from softrnn.learned.node.train import TrainConfig
from softrnn.learned.node.training_data import spans, training_windows

from helpers import swinging_rod


# ----------------------------------------------------------------------------------------- SampleSpec
def test_default_neighbours_are_the_adjacent_nodes_or_one_at_an_end():
    nodes = np.arange(5)
    assert SampleSpec(node=2).resolve(nodes).neighbours == (1, 3)
    assert SampleSpec(node=0).resolve(nodes).neighbours == (1,)
    assert SampleSpec(node=4).resolve(nodes).neighbours == (3,)
    tip = SampleSpec(node=-1).resolve(nodes, n_nodes_total=5)
    assert (tip.node, tip.neighbours) == (4, (3,))
    assert SampleSpec(node=2, neighbours=(0, 1, 3, 4)).resolve(nodes).window_nodes == (2, 0, 1, 3, 4)
    assert SampleSpec(node=2, neighbours=()).resolve(nodes).window_nodes == (2,)


@pytest.mark.parametrize("inputs, wrench, P, W", [("positions", "none", 9, 0), ("positions", "force", 9, 3),
                                                  ("poses", "wrench", 21, 6)])
def test_feature_counts(inputs, wrench, P, W):
    spec = SampleSpec(node=2, inputs=inputs, wrench=wrench).resolve(np.arange(5))
    assert (spec.pose_features, spec.wrench_features) == (P, W)


@pytest.mark.parametrize("kwargs, words", [
    ({"node": 7}, ["node=7", "stored nodes: 0..4"]),
    ({"node": 2, "neighbours": (1, 9)}, ["node 9 is not stored"]),
    ({"node": 2, "neighbours": (2, 3)}, ["neighbours", "distinct"]),
    ({"node": 2, "neighbours": (1, 1)}, ["neighbours", "distinct"]),
])
def test_bad_nodes_are_one_line_errors(kwargs, words):
    with pytest.raises(SoftrnnInputError) as err:
        SampleSpec(**kwargs).resolve(np.arange(5))
    assert "\n" not in str(err.value) and all(w in str(err.value) for w in words)


@pytest.mark.parametrize("kwargs, word", [({"node": 1.5}, "node"), ({"node": 1, "history": 0}, "history"),
                                          ({"node": 1, "inputs": "angles"}, "inputs"),
                                          ({"node": 1, "wrench": "torque"}, "wrench"),
                                          ({"node": 1, "train_fraction": 1.0}, "train_fraction"),
                                          ({"node": 1, "neighbours": "0,2"}, "neighbours")])
def test_bad_spec_fields(kwargs, word):
    with pytest.raises(SoftrnnInputError, match=word):
        SampleSpec(**kwargs)


def test_unresolved_spec_says_to_resolve():
    with pytest.raises(SoftrnnInputError, match="resolve"):
        _ = SampleSpec(node=2).pose_features


def test_spec_round_trips_through_a_dict():
    spec = SampleSpec(node=2, history=3, inputs="poses", wrench="wrench").resolve(np.arange(5))
    assert SampleSpec.from_dict(spec.to_dict()) == spec


# ----------------------------------------------------------------------------------------- windows
@pytest.mark.parametrize("inputs, wrench", [("positions", "force"), ("poses", "wrench"), ("positions", "none")])
def test_window_layout(inputs, wrench):
    data = swinging_rod(60)
    spec = SampleSpec(node=1, history=3, inputs=inputs, wrench=wrench).resolve(data.nodes)
    w = make_windows(data, spec, 10, 40)
    H, P, W = 3, spec.pose_features, spec.wrench_features
    assert w.poses.shape == (27, H, P) and w.wrenches.shape == (27, H, W) and w.targets.shape == (27, 3)
    assert w.poses.dtype == np.float32 and w.targets.dtype == np.float32
    assert list(w.index) == list(range(13, 40))
    per = 3 if inputs == "positions" else 7
    for m, i in ((0, 13), (26, 39)):
        for k in range(H):
            s = i - H + k
            for j, node in enumerate((1, 0, 2)):                               # node first, then neighbours
                block = w.poses[m, k, j * per:(j + 1) * per]
                assert np.array_equal(block[:3], data.positions[s, node])
                if per == 7:
                    assert np.array_equal(block[3:], data.quaternions[s, node])
            expect = {"none": [], "force": [data.forces[s, 1]], "wrench": [data.forces[s, 1], data.torques[s, 1]]}
            assert np.array_equal(w.wrenches[m, k], np.concatenate(expect[wrench] or [np.zeros(0, np.float32)]))
        assert np.array_equal(w.targets[m], data.positions[i, 1])
    assert np.array_equal(w.last_position, w.poses[:, -1, NODE_POSITION])
    assert np.array_equal(pose_rows(data, spec, 10, 40)[0:3], w.poses[0])
    assert np.array_equal(wrench_rows(data, spec, 10, 40)[0:3], w.wrenches[0])


def test_windows_of_a_span_too_short_are_empty():
    data = swinging_rod(60)
    spec = SampleSpec(node=1).resolve(data.nodes)
    assert len(make_windows(data, spec, 5, 7)) == 0
    with pytest.raises(SoftrnnInputError, match="stop"):
        make_windows(data, spec, 5, 61)


def test_split_is_chronological_and_no_window_straddles_the_cut():
    spec = SampleSpec(node=1, history=2)
    train, test = split(1001, spec)
    assert (train, test) == (range(0, 600), range(600, 1001))
    data = swinging_rod(1001)
    tr = make_windows(data, spec, train.start, train.stop)
    te = make_windows(data, spec, test.start, test.stop)
    assert tr.index.max() < 600                                   # targets (and their windows) before the cut
    assert te.index.min() - spec.history >= 600                   # test windows start at or after the cut
    assert len(tr) + len(te) == 1001 - 2 * spec.history


@pytest.mark.parametrize("n, history", [(10, 4), (10, 9), (3, 2)])
def test_history_longer_than_the_data_is_an_error(n, history):
    with pytest.raises(SoftrnnInputError) as err:
        split(n, SampleSpec(node=1, history=history))
    assert "history" in str(err.value) and "\n" not in str(err.value)


def test_no_test_span_sample_reaches_training():
    """The test span is NaN: any of its values in a training or validation window would show."""
    n = 500
    cut = split(n, SampleSpec(node=2))[0].stop
    data = swinging_rod(n, poison_from=cut)
    spec = SampleSpec(node=2, wrench="wrench", inputs="poses").resolve(data.nodes)
    train = TrainConfig(validation_fraction=0.25)
    fit, val, sp, stride = training_windows(data, spec, train)
    assert sp.test.start == cut and sp.fit.stop == sp.validation.start and sp.validation.stop == cut
    for w in (fit, val):
        assert len(w) > 0
        assert np.isfinite(w.poses).all() and np.isfinite(w.wrenches).all() and np.isfinite(w.targets).all()
        assert w.index.max() < cut
    assert fit.index.max() < sp.validation.start                  # the validation cut is respected too
    assert val.index.min() - spec.history >= sp.validation.start
    norm = Normalizer.fit(fit)
    assert all(np.isfinite(v).all() for v in norm.to_dict().values() if isinstance(v, list))


def test_validation_span_too_short_is_an_error():
    with pytest.raises(SoftrnnInputError, match="history"):
        spans(40, SampleSpec(node=1, history=4), 0.1)


def test_long_spans_are_subsampled_with_a_stride():
    data = swinging_rod(1000)
    spec = SampleSpec(node=2).resolve(data.nodes)
    fit, val, sp, stride = training_windows(data, spec, TrainConfig(max_train_windows=100))
    assert stride == math.ceil((sp.fit.stop - 2) / 100) and len(fit) <= 100
    assert np.all(np.diff(fit.index) == stride)


# ----------------------------------------------------------------------------------------- Normalizer
@pytest.mark.parametrize("output", ["increment", "pose", "acceleration"])
@pytest.mark.parametrize("relative", [False, True])
def test_normalizer_statistics_and_inverse(output, relative):
    data = swinging_rod(300)
    spec = SampleSpec(node=2, wrench="force").resolve(data.nodes)
    w = make_windows(data, spec, 0, 200)
    norm = Normalizer.fit(w, output=output, relative=relative, per_node=3)
    poses = w.poses.astype(np.float64)
    if relative:
        poses = poses - np.tile(poses[:, -1:, :3], (1, 1, 3))
    flat = poses.reshape(-1, 9)
    assert np.allclose(norm.pose_mean, flat.mean(0))
    assert np.allclose(norm.wrench_mean, w.wrenches.reshape(-1, 3).mean(0), atol=1e-9)
    z = norm.normalise_poses(w.poses)
    assert z.dtype == np.float32 and np.isfinite(z).all()
    assert np.allclose(z.reshape(-1, 9).mean(0), 0, atol=1e-5)
    y = norm.normalise_targets(w.targets, w.poses)
    moving = [1, 2]                                                 # x is constant (std floored)
    assert np.allclose(y.mean(0), 0, atol=1e-5) and np.allclose(y.std(0)[moving], 1, atol=1e-4)
    back = norm.denormalise_outputs(y, w.poses)
    assert back.dtype == np.float64 and np.allclose(back, w.targets, atol=1e-7)
    again = Normalizer.from_dict(norm.to_dict())
    assert all(np.array_equal(getattr(again, k), getattr(norm, k)) for k in ("pose_mean", "pose_std", "target_std"))
    assert (again.output, again.relative) == (output, relative)


def test_constant_features_stay_finite():
    data = swinging_rod(200)
    data.positions[:, :, 0] = 0.25                                  # x constant
    data.forces[:] = 0.0                                            # no force (Fig. 2A-like)
    spec = SampleSpec(node=2, wrench="force").resolve(data.nodes)
    w = make_windows(data, spec, 0, 150)
    norm = Normalizer.fit(w)
    assert np.all(norm.pose_std > 0) and np.all(norm.wrench_std == 1.0)
    assert np.isfinite(norm.normalise_poses(w.poses)).all() and np.isfinite(norm.normalise_wrenches(w.wrenches)).all()


def test_malformed_normalizer_dict_is_an_error():
    with pytest.raises(SoftrnnInputError):
        Normalizer.from_dict({"pose_mean": [0.0, 1.0, 2.0]})
    good = Normalizer.fit(make_windows(swinging_rod(100), SampleSpec(node=2).resolve(np.arange(5)), 0, 80)).to_dict()
    with pytest.raises(SoftrnnInputError, match="target_std"):
        Normalizer.from_dict(dict(good, target_std=[1.0, 0.0, 1.0]))


def test_each_unit_of_input_two_gets_its_own_floor():
    """A force of 1 mN spread beside a pressure of 100 kPa spread: fitted as one group, the force's
    spread is floored at 1e-3 x 100 = 0.1 (its inputs squeezed a hundredfold); with the units, each
    keeps its own spread. A constant channel of a unit still gets 1."""
    rng = np.random.default_rng(0)
    w = make_windows(swinging_rod(200), SampleSpec(node=2, wrench="force").resolve(np.arange(5)), 0, 150)
    M, H, _ = w.wrenches.shape
    force = rng.normal(0.0, 1e-3, (M, H, 1))
    pressure = rng.normal(50.0, 100.0, (M, H, 1))
    still = np.full((M, H, 1), 3.0)
    mixed = type(w)(poses=w.poses, wrenches=np.concatenate([force, pressure, still], axis=2).astype(np.float32),
                    targets=w.targets, index=w.index)
    one = Normalizer.fit(mixed)
    assert one.wrench_std[0] == pytest.approx(1e-3 * one.wrench_std[1])
    units = Normalizer.fit(mixed, wrench_units=("N", "kPa", "A"))
    assert units.wrench_std[0] == pytest.approx(force.std(), rel=1e-3)
    assert units.wrench_std[1] == pytest.approx(pressure.std(), rel=1e-3)
    assert units.wrench_std[2] == 1.0
    with pytest.raises(SoftrnnInputError, match=r"wrench_units.*one unit per input II column \(3\)"):
        Normalizer.fit(mixed, wrench_units=("N", "kPa"))


def test_wrench_units_follow_the_columns_of_input_two():
    data = swinging_rod(20)
    spec = SampleSpec(node=2, wrench="wrench").resolve(data.nodes)
    assert wrench_units(data, spec) == ("N",) * 3 + ("N m",) * 3
    assert wrench_units(data, SampleSpec(node=2, wrench="none").resolve(data.nodes)) == ()
