"""State-feedback (PD) loads in the whole-manipulator model (softrnn.learned.whole.feedback), and how the
training chooses its weights: the law against hand computation and the simulator's recorded force,
the law's inputs rebuilt from a sweep variant's scenario, a free run that applies the law to its own
states, the PyTorch law equal to the NumPy one, the ridge penalty chosen on validation free runs,
and one-line errors."""

import dataclasses
import json

import numpy as np
import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.io import Dataset
from softrnn.learned.baselines import free_run
from softrnn.learned.whole.config import DynamicConfig
from softrnn.learned.whole.encoding import make_encoding
from softrnn.learned.whole.feedback import Feedback, pd_laws

from helpers import without_record_builder

torch = pytest.importorskip("torch")

from softrnn.learned.whole import training  # noqa: E402
from softrnn.learned.whole.network import feedback_force  # noqa: E402

DT = 0.01


def _simulate(scenario, n_samples: int = 41) -> Dataset:
    """``scenario`` simulated for ``n_samples`` samples every ``DT``, every node, with the attrs a
    sweep writes (its text and record, the variant index and the values the variant drew)."""
    from softrnn.rod import Simulator

    config = dataclasses.replace(scenario.config, dt=DT, n_samples=n_samples, save_nodes=None)
    traj = Simulator(scenario.setup).run(config)
    attrs = {"dt": DT, "rod": dataclasses.asdict(scenario.setup.rod), "scenario_text": scenario.text,
             "scenario_record": json.loads(json.dumps(scenario.record.to_record()))}   # as a file gives it
    if scenario.variant_index is not None:
        attrs["variant_index"] = scenario.variant_index
        attrs["sampled"] = json.dumps(scenario.sampled)
    return Dataset(time=traj.time, nodes=traj.nodes, positions=traj.positions, quaternions=traj.quaternions,
                   forces=traj.forces, torques=traj.torques, attrs=attrs)


@pytest.fixture(scope="module")
def square_variant():
    from softrnn.scenarios.scenario import load_scenario

    base = load_scenario("square")
    return base.variant(3), _simulate(base.variant(3))


def test_the_law_is_stiffness_times_target_error_minus_damping_times_velocity():
    M = 4
    gains = np.zeros((M, 2))
    gains[2] = (5.0, 0.5)
    targets = np.zeros((3, M, 3))
    targets[1, 2] = (0.1, -0.2, 0.3)
    fb = Feedback(gains=gains, targets=targets, model_dt=0.02, nodes=(7,))
    x, prev = np.zeros((M, 6)), np.zeros((M, 6))
    x[2, :3], prev[2, :3] = (0.01, 0.02, 0.03), (0.0, 0.01, 0.05)
    x[2, 3:] = 9.0                                                  # rotations do not enter
    f = fb.force(x, prev, 1)
    want = 5.0 * (np.array([0.1, -0.2, 0.3]) - x[2, :3]) - 0.5 * (x[2, :3] - prev[2, :3]) / 0.02
    np.testing.assert_allclose(f[2, :3], want, rtol=1e-14)
    assert np.all(f[[0, 1, 3]] == 0) and np.all(f[:, 3:] == 0)
    # the teacher-forced loads along a trajectory are the same formula, row by row
    states = np.stack([prev, x, x])
    np.testing.assert_allclose(fb.forced(states)[1], f, rtol=1e-14)
    # ... and PyTorch's, inside a training unroll
    hist = torch.as_tensor(np.stack([prev, x])[None])
    tf = feedback_force(hist, (torch.as_tensor(gains[None]), torch.as_tensor(targets[None]), 0.02), 1)
    np.testing.assert_allclose(tf[0].numpy(), f, rtol=1e-12)


def test_a_sweep_variant_gives_its_own_gains_and_target(square_variant):
    variant, ds = square_variant
    (law,) = pd_laws(ds)
    (want,) = [load for load in variant.setup.loads if type(load).__name__ == "PDTracking"]
    assert (law.stiffness, law.damping) == (want.stiffness, want.damping)
    assert law.stiffness != 5.0                         # not the base scenario's gain
    t = np.linspace(0.0, 3.0, 7)
    np.testing.assert_array_equal(law.target(t), want.target(t))
    assert [int(law.node) % 51 for law in pd_laws(ds)] == [50]


def test_the_trajectory_drops_the_recorded_pd_force_and_rebuilds_it_from_the_law(square_variant):
    variant, ds = square_variant
    enc = make_encoding([ds], model_dt=DT, node_stride=5, length=0.5, feedback=True)
    traj = enc.trajectory(ds)
    tip = enc.n_kept - 1
    fb = traj.feedback
    assert fb is not None and fb.nodes == (50,)
    assert np.all(traj.loads[:, tip] == 0)                               # the recorded force is gone
    (law,) = pd_laws(ds)
    np.testing.assert_allclose(fb.gains[tip], (law.stiffness, law.damping))
    assert np.all(fb.gains[:tip] == 0)
    # the target is the step's mean: at a step's middle within the target's curvature over a step
    mid = law.target(traj.time + DT / 2) - enc.ref_positions[50]
    np.testing.assert_allclose(fb.targets[:, tip], mid, atol=1e-5)
    # gains and reference give the force the simulator recorded at each sample (velocity by central
    # differences, second order in the step)
    rec = ds.forces[1:-1, 50].astype(float)
    x = traj.states[:, tip, :3]
    t = traj.time[1:-1]
    law_f = fb.gains[tip, 0] * (law.target(t) - enc.ref_positions[50] - x[1:-1]) \
        - fb.gains[tip, 1] * (x[2:] - x[:-2]) / (2 * DT)
    scale = np.abs(rec).max()
    assert scale > 1e-2
    assert np.abs(law_f - rec).max() < 0.01 * scale, (np.abs(law_f - rec).max(), scale)
    # the model's explicit law (the step's start) is a first-order approximation of it
    forced = fb.forced(traj.states)[1:-1, tip, :3]
    assert np.abs(forced - rec).max() < 0.3 * scale
    # without feedback the recorded force stays an input
    plain = make_encoding([ds], model_dt=DT, node_stride=5, length=0.5).trajectory(ds)
    assert plain.feedback is None and np.abs(plain.loads[:, tip, :3]).max() > 1e-3


class _Recorder:
    """A predictor that stands still and records the loads it is given."""

    history = 2

    def __init__(self):
        self.seen = []

    def step(self, hist, loads, memory=None):
        self.seen.append((hist.copy(), loads.copy()))
        return hist[-1] + 0.001, None


def test_a_free_run_applies_the_law_to_its_own_states(square_variant):
    _, ds = square_variant
    enc = make_encoding([ds], model_dt=DT, node_stride=5, length=0.5, feedback=True)
    traj = enc.trajectory(ds)
    rec = _Recorder()
    states = free_run(rec, traj, None, 4, 12)
    for k, (hist, loads) in enumerate(rec.seen):
        np.testing.assert_allclose(loads, traj.loads[3 + k] + traj.feedback.force(hist[-1], hist[-2], 3 + k))
    # from the second step on, the history is the run's own: the law sees the predicted states
    np.testing.assert_allclose(rec.seen[2][0][-1], states[1])


def test_a_pd_node_the_model_does_not_predict_is_a_one_line_error(square_variant):
    _, ds = square_variant
    enc = make_encoding([ds], model_dt=DT, node_stride=5, length=0.5, feedback=True)
    from softrnn.scenarios.scenario import parse_scenario

    text = ds.attrs["scenario_text"].replace("node = -1", "node = 48", 1)
    broken = dataclasses.replace(ds, attrs={**ds.attrs, "scenario_text": text,
                                            "scenario_record": parse_scenario(text).variant(3).record.to_record()})
    with pytest.raises(SoftrnnInputError) as info:
        enc.trajectory(broken)
    msg = str(info.value)
    assert "\n" not in msg and "node 48" in msg and "node_stride" in msg, msg


def test_data_without_a_scenario_has_no_laws(square_variant):
    _, ds = square_variant
    lab = dataclasses.replace(ds, attrs={k: v for k, v in ds.attrs.items()
                                         if k not in ("scenario_text", "scenario_record")})
    assert pd_laws(lab) == []
    enc = make_encoding([lab], model_dt=DT, node_stride=5, length=0.5, feedback=True)
    assert enc.trajectory(lab).feedback is None


def test_old_data_without_a_record_says_so_and_gets_the_same_laws_back_from_its_text(square_variant):
    from softrnn.scenarios.record import with_record

    _, ds = square_variant
    old = dataclasses.replace(ds, attrs={k: v for k, v in ds.attrs.items() if k != "scenario_record"})
    with without_record_builder():          # as where softrnn.scenarios is not imported
        with pytest.raises(SoftrnnInputError) as info:
            pd_laws(old)
    msg = str(info.value)
    assert "\n" not in msg and "with_record" in msg and "feedback = false" in msg, msg
    # with softrnn.scenarios imported (as the CLI is) the record is rebuilt on reading
    for rebuilt in (with_record(old), old):
        (law,), (want,) = pd_laws(rebuilt), pd_laws(ds)
        assert (law.node, law.stiffness, law.damping) == (want.node, want.stiffness, want.damping)
        t = np.linspace(0.0, 3.0, 7)
        np.testing.assert_array_equal(law.target(t), want.target(t))
    # a variant whose draws were not recorded cannot be rebuilt: still the one-line error
    undrawn = dataclasses.replace(old, attrs={k: v for k, v in old.attrs.items() if k != "sampled"})
    with pytest.raises(SoftrnnInputError, match="with_record"):
        pd_laws(with_record(undrawn))
    with pytest.raises(SoftrnnInputError, match="with_record"):
        pd_laws(undrawn)


def test_training_with_the_law_runs_and_the_penalty_is_chosen_on_validation(square_variant):
    from softrnn.scenarios.scenario import load_scenario

    _, ds = square_variant
    other = _simulate(load_scenario("square").variant(5))
    enc = make_encoding([ds], model_dt=DT, node_stride=10, length=0.5, feedback=True)
    train, val = [enc.trajectory(ds)], [enc.trajectory(other)]
    config = DynamicConfig(model_dt=DT, node_stride=10, width=8, layers=1, unroll=3, batch=4, steps=4)
    trained = training.train_dynamic_model(train, enc, config, validation=val, threads=1)
    tried = trained.info["ridge_validation"]
    assert len(tried) == training.RIDGE_TRIES
    finite = [(e, p) for p, e in tried if e is not None]
    assert trained.info["ridge"] == min(finite)[1]
    # the chosen penalty's linear model is what the validation error measured
    assert training.validation_error(trained.linear, val) == pytest.approx(min(finite)[0], rel=1e-6)


def test_the_convolution_reads_no_load_and_optionally_no_rotation():
    from softrnn.learned.whole.config import conv_channels, load_channels, n_channels

    H = 3
    loads = set(range(load_channels(H).start, load_channels(H).stop))
    every = conv_channels(H)
    assert len(every) == n_channels(H) - 6 and not loads & set(every)
    disp = conv_channels(H, "displacements")
    # state and both velocities lose their rotation columns (3 each); the constants stay
    assert len(disp) == len(every) - 3 * H
    assert all(c % 6 < 3 for c in disp if c < 6 * H) and set(range(6 * H + 6, n_channels(H))) <= set(disp)
    with pytest.raises(SoftrnnInputError, match="conv_reads"):
        DynamicConfig(conv_reads="rotations")
