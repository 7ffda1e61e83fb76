"""Contact inputs of the whole-manipulator model (DynamicConfig.contact): each kept node's gap to the
nearest obstacle and its normal, measured as the simulator measures them; where they sit among the
loads; a free run measuring them on its own state; the linear term blind to them (the linear
baseline the same as without them); the correction reading them, clipped but never faded by the
envelope; the NumPy engine, a saved model and the ONNX step as the network; and the option off by
default, so models of data without obstacles are trained as before."""

import dataclasses

import numpy as np
import pytest

from softrnn.io import Dataset, write_dataset
from softrnn.io.schema import contact_record
from softrnn.learned.baselines import free_run
from softrnn.learned.whole.config import DynamicConfig, conv_channels
from softrnn.learned.whole.encoding import make_encoding
from softrnn.learned.whole.obstacles import ContactFeatures, vessel_gap_into
from softrnn.rod import Contact, Plane, Sphere, Vessel

from helpers import run_cli

torch = pytest.importorskip("torch")

from softrnn.learned.whole import training  # noqa: E402
from softrnn.learned.whole.artifact import engine_of, load_dynamic, save_dynamic  # noqa: E402
from softrnn.learned.whole.network import contact_inputs  # noqa: E402

DT = 0.01
RADIUS = 0.004

SCENARIO = """
format = 1
name = "rod-dragged-on-a-floor"
title = "a short rod lying on the floor, its clamp dragged sideways"
seed = 3
gravity = [0.0, 0.0, -9.81]

[rod]
length = 0.2
radius = 0.004
n_nodes = 9
youngs_modulus = 5e6
poisson_ratio = 0.5
density = 1000.0

[reference]
kind = "straight"
origin = [0.0, 0.0, 0.00399]
direction = [1.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]

[[boundary]]
kind = "clamp"
node = 0
displacement = { kind = "constant", value = [0.0, SIDE, 0.02], schedule = { start = 0.1, ramp = 0.5 } }

[contact]
friction = 0.3

[[contact.obstacles]]
kind = "plane"
point = [0.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]

[damping]
translational = 0.02
rotational = 1e-6

[run]
dt = 0.01
duration = 0.8
nodes_of_interest = [-1]
"""


def _dataset(side: float, contact: bool = True) -> Dataset:
    """The scenario with the clamp dragged ``side`` [m], every node saved every ``DT``; ``contact``:
    the obstacles recorded (as ``softrnn simulate`` records them)."""
    from softrnn.rod import Simulator
    from softrnn.scenarios.scenario import parse_scenario

    sc = parse_scenario(SCENARIO.replace("SIDE", repr(side)))
    config = dataclasses.replace(sc.config, dt=DT, n_samples=81, save_nodes=None)
    traj = Simulator(sc.setup).run(config)
    attrs = {"dt": DT, "rod": dataclasses.asdict(sc.setup.rod), "scenario_text": sc.text,
             "scenario_record": sc.record.to_record()}
    if not contact:
        return Dataset(time=traj.time, nodes=traj.nodes, positions=traj.positions, quaternions=traj.quaternions,
                       forces=traj.forces, torques=traj.torques, attrs=attrs)
    return Dataset(time=traj.time, nodes=traj.nodes, positions=traj.positions, quaternions=traj.quaternions,
                   forces=traj.forces, torques=traj.torques,
                   attrs={**attrs, "contact": contact_record(sc.setup.contact)},
                   contact_forces=traj.contact_forces, contact_torques=traj.contact_torques)


@pytest.fixture(scope="module")
def data():
    return [_dataset(side) for side in (0.04, 0.07, 0.055)]


def _config(**kw) -> DynamicConfig:
    return DynamicConfig(**{"model_dt": 0.02, "node_stride": 2, "steps": 20, "unroll": 3, "batch": 4, "width": 8,
                            "layers": 1, "ema": 0.0, "contact": True, **kw})


def _train(data, config):
    enc = make_encoding(data[:2], model_dt=config.model_dt, node_stride=2, length=0.2, prescribed=True,
                        obstacles=True, contact=config.contact)
    return training.train_dynamic_model([enc.trajectory(d) for d in data[:2]], enc, config, threads=1), enc


@pytest.fixture(scope="module")
def trained(data):
    return _train(data, _config())


def test_the_gap_and_normal_are_those_of_the_nearest_obstacle_within_reach():
    floor_and_ball = Contact(obstacles=(Plane((0.0, 0.0, 0.0), (0.0, 0.0, 1.0)), Sphere((1.0, 0.0, 0.0), 0.05)))
    ref = np.array([[0.0, 0.0, 0.01], [0.96, 0.0, 0.1], [0.5, 0.0, 2.0]])
    features = ContactFeatures(floor_and_ball, ref, RADIUS, far=0.3)
    states = np.zeros((2, 3, 6))
    states[1, 0, 2] = -0.02                           # sunk 10 mm below the floor
    out = features(states)
    assert out.shape == (2, 3, 4)
    np.testing.assert_allclose(out[0, 0], [0.01 - RADIUS, 0.0, 0.0, 1.0], atol=1e-15)
    np.testing.assert_allclose(out[1, 0], [-0.01 - RADIUS, 0.0, 0.0, 1.0], atol=1e-15)
    d = np.hypot(0.04, 0.1)                            # the ball is nearer than the floor's 0.1 m
    np.testing.assert_allclose(out[0, 1], [d - 0.05 - RADIUS, -0.04 / d, 0.0, 0.1 / d], atol=1e-15)
    np.testing.assert_array_equal(out[0, 2], [0.3, 0.0, 0.0, 0.0])      # out of reach: capped, no normal
    assert ContactFeatures(None, ref, RADIUS, far=0.3)(states)[..., 0].tolist() == [[0.3] * 3] * 2


def test_the_compiled_vessel_gap_is_the_vessels_own():
    bend = np.array([[-0.1, 0.0, 0.0], [0.0, 0.0, 0.0], [0.03, 0.01, 0.0], [0.05, 0.04, 0.0], [0.06, 0.1, 0.0]])
    vessel = Vessel(bend, np.array([0.003, 0.003, 0.004, 0.003, 0.003]))
    rng = np.random.default_rng(0)
    x = vessel.points[rng.integers(0, len(vessel.points), 200)] + rng.normal(0.0, 0.003, (200, 3))
    x[:2] = [[-0.2, 0.0, 0.0], [0.0, 0.001, 0.0]]         # beyond the open end; inside, near the wall's axis
    gap, normal = np.empty(200), np.empty((200, 3))
    vessel_gap_into(vessel.points, vessel.radii, x, RADIUS, gap, normal)
    want_gap, want_normal = vessel.gap(x, np.full(200, RADIUS))
    assert gap[0] == np.inf and np.isfinite(gap[1]) and np.isfinite(gap).sum() > 150
    np.testing.assert_allclose(gap, want_gap, rtol=0, atol=1e-15)
    np.testing.assert_allclose(normal, want_normal, rtol=0, atol=1e-12)
    states = np.pad(x, ((0, 0), (0, 3)))
    features = ContactFeatures(Contact(obstacles=vessel), np.zeros((200, 3)), RADIUS, far=0.3)(states)
    np.testing.assert_allclose(features[:, 0], np.minimum(want_gap, 0.3), rtol=0, atol=1e-15)


def test_the_contact_inputs_follow_the_wrench_and_precede_the_clamps_path(data):
    enc = make_encoding(data[:2], model_dt=0.02, node_stride=2, length=0.2, prescribed=True, contact=True)
    assert enc.contact and enc.load_width == 6 + 4 + 6 and enc.contact_columns == slice(6, 10)
    assert enc.prescribed_columns == ((0, 10),)
    traj = enc.trajectory(data[2])
    np.testing.assert_array_equal(traj.loads[..., 6:10], traj.contact(traj.states))
    lying = traj.loads[0, -1, 6:10]                     # the tip lies on the floor at the start
    assert abs(lying[0]) < 1e-4 and lying[3] == 1.0
    hist = traj.states[3:6].copy()
    hist[-1, :, 2] += 0.01                              # a free run's own state, 1 cm higher
    u = traj.inputs(hist, 5)
    np.testing.assert_allclose(u[:, 6], traj.loads[5, :, 6] + 0.01, atol=1e-12)
    np.testing.assert_array_equal(np.delete(u, np.s_[6:10], axis=1), np.delete(traj.loads[5], np.s_[6:10], axis=1))


def test_without_the_option_or_without_obstacles_there_are_no_contact_inputs(data):
    assert "contact" not in DynamicConfig().to_dict() and _config().to_dict()["contact"] is True
    off = make_encoding(data[:2], model_dt=0.02, node_stride=2, length=0.2, prescribed=True)
    assert not off.contact and off.load_width == 12 and off.trajectory(data[2]).contact is None
    bare = [_dataset(0.04, contact=False)]
    assert not make_encoding(bare, model_dt=0.02, node_stride=2, length=0.2, contact=True).contact
    enc = make_encoding(data[:2], model_dt=0.02, node_stride=2, length=0.2, prescribed=True, contact=True)
    far = enc.trajectory(bare[0]).loads[..., 6:10]          # a data set without obstacles: none in reach
    assert np.all(far[..., 0] == 0.2) and np.all(far[..., 1:] == 0)


def test_the_linear_term_never_reads_the_contact_inputs(trained, data):
    result, enc = trained
    C = result.net.n_in
    for net in (result.net, result.linear):
        W = net.linear.weight.detach().numpy().reshape(-1, enc.n_kept, C)
        assert np.all(W[..., 18 + 6:18 + 10] == 0)          # trained, and still exactly zero
    plain, plain_enc = _train(data, _config(contact=False, steps=0))
    a = free_run(engine_of(result.linear), enc.trajectory(data[2]), None, 3, 41)
    b = free_run(engine_of(plain.linear), plain_enc.trajectory(data[2]), None, 3, 41)
    np.testing.assert_allclose(a, b, rtol=0, atol=5e-5)      # the baseline of a model without them, to rounding


def test_the_correction_reads_the_contact_inputs_and_the_envelope_clips_but_never_fades_them(trained):
    result, _ = trained
    net = result.net
    cols = net.conv_cols.tolist()
    assert cols == conv_channels(3, "all", 16, slice(6, 10)) and set(range(24, 28)) <= set(cols)
    assert not set(range(18, 24)) & set(cols) and not set(range(28, 34)) & set(cols)
    contact = [cols.index(c) for c in range(24, 28)]
    assert torch.all(net.env_inv[contact] == 0) and torch.all(net.env_inv[:18] > 0)
    features = torch.zeros(1, net.n_kept, net.n_in)
    features[..., cols] = (net.env_lo + net.env_hi) / 2
    features[0, 2, 24] = net.env_lo[contact[0]] - 100.0      # far deeper into the floor than the data
    clipped, gate = net.correction_inputs(features)
    assert torch.all(gate == 1) and clipped[0, 2, contact[0]] == net.env_lo[contact[0]]


def test_the_engine_and_a_saved_model_step_as_the_network(trained, data, tmp_path):
    result, enc = trained
    engine = engine_of(result.net)
    engine64 = type(engine)({k: v.detach().double().numpy() for k, v in result.net.state_dict().items()},
                            result.net.config, dtype=np.float64)
    traj = enc.trajectory(data[1])
    hist, u = traj.states[4:7], traj.inputs(traj.states[4:7], 6)
    with torch.no_grad():
        want, _ = result.net.double()(torch.as_tensor(hist[None]), torch.as_tensor(u[None]))
    result.net.float()
    got, _ = engine64.step(hist, u)
    np.testing.assert_allclose(got, want[0].numpy(), rtol=0, atol=1e-12)
    save_dynamic(tmp_path / "m", result)
    model = load_dynamic(tmp_path / "m")
    assert model.encoding.contact and model.config.contact
    traj = model.encoding.trajectory(data[2])
    np.testing.assert_array_equal(free_run(model.engine, traj, None, 3, traj.n_steps),
                                  free_run(engine, traj, None, 3, traj.n_steps))


def test_the_torch_free_run_measures_the_contact_inputs_on_its_own_state(trained, data):
    result, enc = trained
    traj = enc.trajectory(data[2])
    hist = torch.as_tensor(traj.states[None, 2:5], dtype=torch.float32)
    loads = torch.as_tensor(traj.loads[None, 4:14], dtype=torch.float32)
    measure = contact_inputs([traj], np.array([[0, 2]]))
    with torch.no_grad():
        got = result.net.rollout(hist, loads, None, measure)[0].double().numpy()
    want = free_run(engine_of(result.net), traj, None, 5, 15)
    unprojected = free_run(engine_of(result.net), dataclasses.replace(traj, projection=None), None, 5, 15)
    np.testing.assert_allclose(got, unprojected, rtol=0, atol=2e-5)
    assert np.all(np.isfinite(want))


def test_the_onnx_step_takes_the_contact_inputs_as_loads(trained, tmp_path):
    pytest.importorskip("onnxruntime")
    from softrnn.learned.whole.export import describe, export_onnx

    result, _ = trained
    save_dynamic(tmp_path / "m", result)
    model = load_dynamic(tmp_path / "m")
    assert export_onnx(model, tmp_path / "m.onnx").max_difference <= 1e-5
    assert "contact inputs measured on the current state (columns 6-9)" in describe(model)["units"]["loads"]


def test_the_command_line_trains_with_contact_inputs(data, tmp_path):
    for i, d in enumerate(data):
        write_dataset(tmp_path / "sweep" / f"traj-{i:05d}.h5", d)
    args = ["dynamic", "train", str(tmp_path / "sweep"), "--heldout", "1", "--steps", "0", "--node-stride", "2",
            "--threads", "1", "--quiet", "-o", str(tmp_path / "m")]
    assert run_cli(args + ["--contact-inputs"]) == 0
    assert load_dynamic(tmp_path / "m").encoding.contact
    assert run_cli(args[:-1] + [str(tmp_path / "plain")]) == 0
    assert not load_dynamic(tmp_path / "plain").encoding.contact
