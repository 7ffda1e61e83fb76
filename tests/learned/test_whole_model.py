"""The whole-manipulator model (softrnn.learned.whole) against physics and hand computation: the encoding
round trip and load lumping, an oracle and the baselines through the free-run evaluation, the torch
network against the NumPy engine, saving and loading, long free runs of a noise-trained model,
held-out variants that never reach training, seeded and resumed training, and config validation.
The long free runs rest on two pieces tested here: the ridge fit's damping prior (no direction the
data leave unexcited is ballistic: the linear term is strictly stable) and the envelope gate (the
network's correction is bounded and vanishes far from the data)."""

import dataclasses
import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from scipy.interpolate import CubicSpline

from softrnn.errors import SoftrnnInputError
from softrnn.io import Dataset, read_dataset, write_dataset
from softrnn.learned.baselines import ConstantVelocity, Persistence, StateBaseline, free_run
from softrnn.learned.horizons import RolloutDiverged
from softrnn.learned.whole import evaluation
from softrnn.learned.whole.config import DynamicConfig, load_channels, resolve_stride
from softrnn.learned.whole.encoding import Encoding, Trajectory, kept_nodes, lumping_matrix, make_encoding

torch = pytest.importorskip("torch")

from softrnn.learned.whole import fit as fit_mod  # noqa: E402  (needs torch)
from softrnn.learned.whole import training  # noqa: E402
from softrnn.learned.whole.artifact import DynamicFolderError, engine_of, load_dynamic, save_dynamic  # noqa: E402
from softrnn.learned.whole.data import split_inputs  # noqa: E402
from softrnn.learned.whole.engine import DynamicEngine  # noqa: E402
from softrnn.learned.whole.network import DynamicNet  # noqa: E402
from softrnn.learned.whole.training import train_dynamic_model  # noqa: E402

from helpers import LENGTH, bending_chain, chain_dataset, quat_z  # noqa: E402

PERSISTENCE, CONSTANT_VELOCITY = StateBaseline(Persistence()), StateBaseline(ConstantVelocity())


@pytest.fixture(scope="module", autouse=True)
def _one_torch_thread():
    """One PyTorch thread (the tests are small; a second thread only contends)."""
    before = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(before)


# ---------------------------------------------------------------------------------------- data
@pytest.fixture(scope="module")
def square():
    """The square scenario simulated for 0.4 s, every node saved every 10 ms."""
    from softrnn.rod import Simulator
    from softrnn.scenarios.scenario import load_scenario

    scenario = load_scenario("square")
    config = dataclasses.replace(scenario.config, dt=0.01, n_samples=41)
    traj = Simulator(scenario.setup).run(config)
    ds = Dataset(time=traj.time, nodes=traj.nodes, positions=traj.positions, quaternions=traj.quaternions,
                 forces=traj.forces, torques=traj.torques,
                 attrs={"dt": 0.01, "rod": dataclasses.asdict(scenario.setup.rod)})
    assert np.abs(ds.positions[-1] - ds.positions[0]).max() > 1e-3        # it really moves
    return ds


@pytest.fixture(scope="module")
def chains():
    """Four training variants and one validation variant of the damped chain."""
    train = [bending_chain(a, p) for a, p in ((0.04, 0.0), (0.03, 1.3), (0.05, 2.4), (0.02, 4.0))]
    return train, bending_chain(0.035, 0.7)


SMALL = DynamicConfig(model_dt=0.01, node_stride=2, width=8, layers=1, unroll=3, batch=8, steps=10, noise=0.05)


@pytest.fixture(scope="module")
def chain_encoding(chains):
    train, val = chains
    enc = make_encoding(train, model_dt=0.01, node_stride=2, length=LENGTH)
    return enc, [enc.trajectory(d, name=str(i)) for i, d in enumerate(train)], [enc.trajectory(val, name="val")]


@pytest.fixture(scope="module")
def trained(chain_encoding):
    """A model trained with noise for 150 steps on the chain (width 16, 2 layers, unroll 5)."""
    enc, trajs, _ = chain_encoding
    config = DynamicConfig(model_dt=0.01, node_stride=2, width=16, layers=2, unroll=5, steps=150, batch=16,
                           noise=0.1, seed=3)
    return train_dynamic_model(trajs, enc, config, threads=1)


# ------------------------------------------------------------------------------------ 1 encoding
def _same_rotation(q1, q2, tol):
    """Quaternions equal up to sign, row by row."""
    d = np.minimum(np.abs(q1 - q2).max(axis=-1), np.abs(q1 + q2).max(axis=-1))
    assert d.max() < tol, d.max()


def test_encoding_round_trip_every_node_is_exact(square):
    enc = make_encoding([square], model_dt=0.01, node_stride=1, length=LENGTH)
    assert enc.n_kept == 51 and enc.fixed.tolist() == [True] + [False] * 50    # the clamped base only
    X = enc.encode(square.positions, square.quaternions)
    assert X.shape == (41, 51, 6)
    np.testing.assert_array_equal(X[0], 0.0)                                     # the reference is sample 0
    p, q = enc.decode(X)
    np.testing.assert_allclose(p, square.positions, rtol=0, atol=1e-6)
    _same_rotation(q, square.quaternions.astype(np.float64), 1e-6)
    np.testing.assert_allclose(np.linalg.norm(q, axis=-1), 1.0, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(enc.positions(X), p)


def test_encoding_with_node_stride_keeps_kept_nodes_and_interpolates_the_rest(square):
    enc = make_encoding([square], model_dt=0.01, node_stride=5, length=LENGTH)
    kept = np.arange(0, 51, 5)
    np.testing.assert_array_equal(enc.kept, kept)
    p, q = enc.decode(enc.encode(square.positions, square.quaternions))
    truth_q = square.quaternions.astype(np.float64)
    np.testing.assert_allclose(p[:, kept], square.positions[:, kept], rtol=0, atol=1e-6)
    _same_rotation(q[:, kept], truth_q[:, kept], 1e-6)
    np.testing.assert_allclose(np.linalg.norm(q, axis=-1), 1.0, rtol=0, atol=1e-9)
    other = np.setdiff1d(np.arange(51), kept)
    pos = square.positions.astype(np.float64)
    disp = np.linalg.norm(pos - pos[:1], axis=-1).max()
    err = np.linalg.norm(p[:, other] - pos[:, other], axis=-1).max()
    assert 0 < err < 0.01 * disp, (err, disp)                                    # interpolated, closely
    dot = np.abs(np.sum(q[:, other] * truth_q[:, other], axis=-1))
    angle = 2 * np.arccos(np.minimum(dot, 1.0))
    assert angle.max() < 1e-3                                                    # rad
    # the decoded rod's nodes between the kept ones are a cubic spline of the kept displacements
    spline = CubicSpline(kept, square.positions[:, kept] - square.positions[:1, kept], axis=1)(np.arange(51))
    np.testing.assert_allclose(p, square.positions[:1] + spline, rtol=0, atol=1e-6)


def test_encoding_of_a_dataset_reads_every_model_step(square):
    enc = make_encoding([square], model_dt=0.02, node_stride=5, length=LENGTH)
    traj = enc.trajectory(square)
    assert traj.n_steps == 21
    np.testing.assert_allclose(traj.time, square.time[::2])
    np.testing.assert_array_equal(traj.states, enc.encode(square.positions[::2], square.quaternions[::2]))


def test_lumping_keeps_the_total_force_and_a_force_at_a_kept_node_stays_there():
    for n, stride in ((51, 5), (23, 4), (7, 1), (10, 3)):
        kept = kept_nodes(n, stride)
        assert kept[0] == 0 and kept[-1] == n - 1
        P = lumping_matrix(n, kept)
        np.testing.assert_allclose(P.sum(axis=0), 1.0, rtol=0, atol=1e-14)
        assert P.min() >= 0
        np.testing.assert_array_equal(P[:, kept], np.eye(len(kept)))
        # a node between kept nodes a < b: (b - i)/(b - a) to a, the rest to b (hat weights)
        a, b = int(kept[0]), int(kept[1])
        for i in range(a + 1, b):
            assert P[0, i] == pytest.approx((b - i) / (b - a)) and P[1, i] == pytest.approx((i - a) / (b - a))


def test_loads_are_step_means_lumped_onto_kept_nodes():
    n, T, k = 11, 9, 2
    ref = np.zeros((n, 3))
    ref[:, 0] = np.linspace(0, LENGTH, n)
    enc = Encoding(n_nodes=n, kept=kept_nodes(n, 5), model_dt=0.02, data_dt=0.01, length=LENGTH,
                   ref_positions=ref, ref_quaternions=np.tile([1.0, 0, 0, 0], (n, 1)), fixed=np.zeros(3, bool))
    rng = np.random.default_rng(0)
    # a force at kept node 5 (row 1) goes to that node only
    f = np.zeros((T, n, 3))
    f[:, 5] = rng.normal(size=(T, 3))
    U = enc.loads(f, np.zeros((T, n, 3)), 5, k)
    assert U.shape == (5, 3, 6)
    np.testing.assert_array_equal(U[:, [0, 2]], 0.0)
    np.testing.assert_array_equal(U[:, :, 3:], 0.0)
    for j in range(4):                                              # the mean over the step's k samples
        np.testing.assert_allclose(U[j, 1, :3], f[2 * j:2 * j + 2, 5].mean(axis=0), rtol=1e-12)
    np.testing.assert_allclose(U[4, 1, :3], f[8, 5])                # the last row: the last sample
    # a torque at node 7 (between kept 5 and 10): 3/5 to node 5, 2/5 to node 10, total kept
    tq = np.zeros((T, n, 3))
    tq[:, 7] = rng.normal(size=(T, 3))
    U = enc.loads(np.zeros((T, n, 3)), tq, 5, k)
    np.testing.assert_array_equal(U[:, 0], 0.0)
    np.testing.assert_allclose(U[:, 1, 3:], 0.6 * U[:, :, 3:].sum(axis=1), rtol=1e-12)
    np.testing.assert_allclose(U[:, :, 3:].sum(axis=1)[:4], tq[:8, 7].reshape(4, 2, 3).mean(axis=1), rtol=1e-12)
    # random loads everywhere: the total force and torque per step are kept
    f, tq = rng.normal(size=(T, n, 3)), rng.normal(size=(T, n, 3))
    U = enc.loads(f, tq, 5, k)
    np.testing.assert_allclose(U[:4].sum(axis=1), np.concatenate([f, tq], -1)[:8].reshape(4, 2, n, 6).mean(1).sum(1),
                               rtol=1e-12, atol=1e-12)


def test_a_pinned_node_that_rotates_is_not_held_fixed():
    n, T = 6, 21
    angle = 0.3 * np.sin(np.linspace(0, 3, T))[:, None] * np.ones(n)    # the whole rod turns about z ...
    s = np.linspace(0, LENGTH, n)
    pos = np.stack([np.cos(angle) * s, np.sin(angle) * s, np.zeros_like(angle)], axis=-1)   # ... about node 0
    ds = chain_dataset(pos, quat_z(angle), 0.01)
    enc = make_encoding([ds], model_dt=0.01, node_stride=1, length=LENGTH)
    assert np.abs(enc.trajectory(ds).states[:, 0, 3:]).max() > 0.2       # node 0's orientation does change
    assert not enc.fixed[0]


# ---------------------------------------------------------------------------------- 2 oracle
class Oracle:
    """Predicts the true next state, looked up by counting its calls."""

    history = 2

    def __init__(self, traj: Trajectory, start: int):
        self.traj, self.i = traj, start

    def step(self, hist, loads, memory=None):
        np.testing.assert_array_equal(hist[-1], self.traj.states[self.i])    # fed back unchanged
        np.testing.assert_array_equal(loads, self.traj.loads[self.i])        # this step's loads
        self.i += 1
        return self.traj.states[self.i].copy(), None


def test_an_oracle_has_zero_error_with_every_node_kept(square):
    enc = make_encoding([square], model_dt=0.02, node_stride=1, length=LENGTH)
    traj = enc.trajectory(square)
    err, diverged = evaluation.run_errors(Oracle(traj, 3), enc, traj, square, 3)
    assert diverged is None and err.shape == (traj.n_steps - 4,)
    np.testing.assert_array_equal(err, 0.0)


def test_an_oracle_has_the_interpolation_error_only(square):
    enc = make_encoding([square], model_dt=0.02, node_stride=5, length=LENGTH)
    traj = enc.trajectory(square)
    start = 2
    oracle = Oracle(traj, start)
    err, diverged = evaluation.run_errors(oracle, enc, traj, square, start)
    assert diverged is None and oracle.i == traj.n_steps - 1
    truth = square.positions[::2][start + 1:].astype(np.float64)
    ref, kept = square.positions[0].astype(np.float64), enc.kept
    interp = ref + CubicSpline(kept, truth[:, kept] - ref[kept], axis=1)(np.arange(51))
    expected = 100 * np.linalg.norm(interp - truth, axis=-1).max(axis=1) / LENGTH
    np.testing.assert_allclose(err, expected, rtol=1e-6, atol=1e-9)
    assert expected.max() > 0 and err.max() < 1.0                   # a small but real interpolation error


# ----------------------------------------------------------------------------------- 3 baselines
def _moving(accel: bool) -> tuple[Encoding, Trajectory, Dataset, np.ndarray]:
    """A straight rod of 9 nodes translating rigidly: uniform motion (``accel`` False) or uniform
    acceleration from rest; every value exact in float32. Returns the per-sample displacement unit d:
    position(n) = x0 + d * n (or d * n^2)."""
    dt, T, n = 2.0 ** -7, 33, 9
    d = np.array([2.0 ** -10, -(2.0 ** -11), 2.0 ** -12])
    i = np.arange(T, dtype=np.float64)
    steps = i ** 2 if accel else i
    x0 = np.zeros((n, 3))
    x0[:, 0] = np.arange(n) / 16.0
    pos = x0[None] + steps[:, None, None] * d
    ds = chain_dataset(pos, np.tile([1.0, 0, 0, 0], (T, n, 1)), dt)
    enc = make_encoding([ds], model_dt=2 * dt, node_stride=2, length=LENGTH)
    return enc, enc.trajectory(ds), ds, d


def test_constant_velocity_is_exact_and_persistence_lags_by_the_distance_travelled():
    enc, traj, ds, d = _moving(accel=False)
    start = 3
    k = np.arange(1, traj.n_steps - start)
    err, diverged = evaluation.run_errors(CONSTANT_VELOCITY, enc, traj, ds, start)
    assert diverged is None
    np.testing.assert_allclose(err, 0.0, rtol=0, atol=1e-12)
    err, diverged = evaluation.run_errors(PERSISTENCE, enc, traj, ds, start)
    assert diverged is None
    np.testing.assert_allclose(err, 100 * k * 2 * np.linalg.norm(d) / LENGTH, rtol=1e-12)   # 2 samples per step


def test_baselines_under_uniform_acceleration_match_hand_computation():
    enc, traj, ds, d = _moving(accel=True)
    start = 4                                        # model step s: position at sample 2s is d (2s)^2
    k = np.arange(1, traj.n_steps - start)
    unit = 100 * np.linalg.norm(d) * 4 / LENGTH      # (2 n)^2 = 4 n^2 in model steps n
    err, _ = evaluation.run_errors(CONSTANT_VELOCITY, enc, traj, ds, start)
    np.testing.assert_allclose(err, unit * (k ** 2 + k), rtol=1e-12)        # (s+k)^2 - s^2 - k(s^2 - (s-1)^2)
    err, _ = evaluation.run_errors(PERSISTENCE, enc, traj, ds, start)
    np.testing.assert_allclose(err, unit * ((start + k) ** 2 - start ** 2), rtol=1e-12)


def test_free_run_reports_a_divergence():
    enc, traj, ds, d = _moving(accel=False)

    class Runaway:
        history = 2

        def step(self, hist, loads, memory=None):
            return hist[-1] * 4.0 + 1.0, None

    with pytest.raises(RolloutDiverged) as caught:
        free_run(Runaway(), traj, None, 2, traj.n_steps)
    states, diverged = caught.value.states, caught.value.sample - 1
    assert diverged == 3                                   # 1, 5, 21 > DIVERGED_M = 16
    assert np.isfinite(states[:2]).all() and np.isnan(states[2:]).all()
    assert len(states) == traj.n_steps - 2 and caught.value.time == traj.time[4]
    err, _ = evaluation.run_errors(Runaway(), enc, traj, ds, 1)
    assert np.isfinite(err[:2]).all() and np.isinf(err[2:]).all()


# ---------------------------------------------------------------------------- 4 torch vs NumPy
@pytest.mark.parametrize("memory, bound, kernel, reads, envelope", [
    ("window", 0.0, 5, "all", None), ("lstm", 0.0, 3, "all", None), ("window", 0.5, 3, "all", 0.25),
    ("lstm", 2.0, 5, "all", 0.25), ("window", 0.0, 5, "displacements", 0.5), ("window", 0.5, 3, "loads", 0.25),
    ("lstm", 0.0, 3, "loads", None)])
def test_torch_rollout_and_numpy_engine_agree(memory, bound, kernel, reads, envelope):
    config = DynamicConfig(history=3, memory=memory, width=8, layers=2, kernel=kernel, bound=bound, conv_reads=reads,
                           envelope=envelope)
    M, H, K = 9, 3, 30
    rng = np.random.default_rng(1)
    fixed = np.zeros(M, bool)
    fixed[0] = True
    s = np.linspace(0, 1, M)
    scales = training.Scales(**{key: rng.uniform(0.5, 2.0, 6) * mag for key, mag in
                                (("sx", 0.1), ("sv", 0.01), ("su", 1.0), ("sa", 0.001))})
    net = DynamicNet(config, np.stack([s, s, fixed.astype(float)], 1), fixed, scales)
    gen = torch.Generator().manual_seed(2)
    with torch.no_grad():
        for p in net.parameters():
            p.copy_(torch.randn(p.shape, generator=gen) * 0.1)
    hist = rng.normal(size=(H, M, 6)) * 0.01
    hist[:, 0] = 0.003
    loads = rng.normal(size=(K, M, 6)) * 0.5
    if envelope is not None:     # a range some features leave: gates between 0 and 1 and clipped inputs
        G = int(net.conv_cols.numel())
        net.set_envelope(torch.as_tensor(rng.uniform(-0.3, -0.05, G), dtype=torch.float32),
                         torch.as_tensor(rng.uniform(0.05, 0.3, G), dtype=torch.float32))
    with torch.no_grad():
        ref = net.rollout(torch.as_tensor(hist[None], dtype=torch.float32),
                          torch.as_tensor(loads[None], dtype=torch.float32))[0].double().numpy()
    out = engine_of(net).run(hist, loads)
    assert out.shape == (K, M, 6)
    np.testing.assert_array_equal(out[:, 0], np.broadcast_to(hist[-1, 0], (K, 6)))       # the fixed node stays
    assert np.abs(out - hist[-1]).max() > 1e-3                                # the weights do move it
    rel = np.abs(out - ref).max() / np.abs(ref).max()
    assert rel < 1e-5, rel
    # in double precision the two are the same arithmetic
    net64 = net.double()
    with torch.no_grad():
        ref64 = net64.rollout(torch.as_tensor(hist[None]), torch.as_tensor(loads[None]))[0].numpy()
    engine64 = DynamicEngine({k: v.numpy() for k, v in net64.state_dict().items()}, config, dtype=np.float64)
    np.testing.assert_allclose(engine64.run(hist, loads), ref64, rtol=0, atol=1e-12 * np.abs(ref64).max())


# ------------------------------------------------------------------------------- 5 save / load
def test_save_load_round_trip_gives_the_same_free_run(trained, chain_encoding, tmp_path):
    enc, trajs, _ = chain_encoding
    folder = tmp_path / "model"
    save_dynamic(folder, trained, meta={"note": "test"})
    loaded = load_dynamic(folder)
    assert loaded.config == trained.config and loaded.meta["note"] == "test"
    np.testing.assert_array_equal(loaded.encoding.kept, enc.kept)
    np.testing.assert_array_equal(loaded.encoding.fixed, enc.fixed)
    np.testing.assert_array_equal(loaded.encoding.ref_quaternions, enc.ref_quaternions)
    H = trained.config.history
    for mine, theirs in ((engine_of(trained.net), loaded.engine), (engine_of(trained.linear), loaded.linear)):
        a = free_run(mine, trajs[0], None, H, trajs[0].n_steps)          # raises RolloutDiverged where it diverges
        b = free_run(theirs, trajs[0], None, H, trajs[0].n_steps)
        np.testing.assert_array_equal(a, b)


def test_the_scale_buffers_keep_their_saved_keys(trained, tmp_path):
    from safetensors.numpy import load_file

    from softrnn.learned.whole.network import SCALE_KEYS

    net = trained.net
    state = net.state_dict()
    assert set(SCALE_KEYS.values()) <= set(state) and not set(SCALE_KEYS) & set(state)
    for name, key in SCALE_KEYS.items():
        assert torch.equal(state[key], getattr(net, name))
    save_dynamic(tmp_path / "model", trained)
    saved = load_file(str(tmp_path / "model" / "weights.safetensors"))
    assert set(saved) == set(state)                                   # the folder's keys, as in earlier releases
    # a model folder's weights load into a fresh network under the new buffer names
    fresh = DynamicNet(net.config, net.node_features.numpy(), net.fixed.numpy(),
                       training.Scales(**{key: np.ones(getattr(net, name).shape)
                                          for name, key in SCALE_KEYS.items()}))
    fresh.load_state_dict({k: torch.as_tensor(v) for k, v in saved.items()} | {"fixed": net.fixed})
    assert _same_weights(fresh, net)


def test_a_broken_model_folder_is_a_one_line_error(trained, tmp_path):
    good = tmp_path / "good"
    save_dynamic(good, trained)
    cases = {"missing": lambda f: (f / "model.json").unlink(),
             "corrupt": lambda f: (f / "model.json").write_text('{"format": "softrnn-dyn'),
             "foreign": lambda f: (f / "model.json").write_text(json.dumps({"format": "other"})),
             "weights": lambda f: (f / "weights.safetensors").write_bytes(b"\x00" * 40)}
    for name, damage in cases.items():
        folder = tmp_path / name
        shutil.copytree(good, folder)
        damage(folder)
        with pytest.raises(DynamicFolderError) as info:
            load_dynamic(folder)
        msg = str(info.value)
        assert "\n" not in msg and str(folder) in msg, msg
        if name != "weights":
            assert "model.json" in msg, msg
    with pytest.raises(DynamicFolderError):
        load_dynamic(tmp_path / "nowhere")


# ------------------------------------------------------------------ 6 a long free run stays bounded
IN_PLANE = [1, 5]           # the chain moves along y and turns about z; x, z, turns about x and y never change
OUT_OF_PLANE = [0, 2, 3, 4]


def _free(engine, traj, n=10_000):
    with np.errstate(under="ignore"):              # a motion decaying to rest may underflow, harmlessly
        return engine.run(traj.states[:engine.history], np.zeros((n, traj.states.shape[1], 6)))   # or Diverged


def _one_step_errors(engine, trajs) -> np.ndarray:
    """Largest one-step error per channel (6,) from every data history of ``trajs``."""
    H, worst = engine.history, np.zeros(6)
    for traj in trajs:
        for s in range(H - 1, traj.n_steps - 1):
            nxt, _ = engine.step(traj.states[s - H + 1:s + 1], traj.loads[s])
            worst = np.maximum(worst, np.abs(nxt - traj.states[s + 1]).max(axis=0))
    return worst


def test_the_ridge_start_keeps_the_plane_and_stays_bounded_over_10000_free_steps(trained, chain_encoding):
    enc, trajs, _ = chain_encoding
    assert trained.info["linear_stable"]
    data_range = max(np.abs(t.states).max() for t in trajs)
    linear = engine_of(trained.linear)
    err = _one_step_errors(linear, trajs)
    assert err[IN_PLANE].max() < 1e-4 and np.all(err[OUT_OF_PLANE] == 0), err
    for traj in trajs[:2]:
        out = _free(linear, traj)
        assert np.isfinite(out).all() and np.abs(out).max() < 10 * data_range, (np.abs(out).max(), data_range)
        np.testing.assert_array_equal(out[..., OUT_OF_PLANE], 0.0)
        held = traj.states[linear.history - 1][enc.fixed]
        np.testing.assert_array_equal(out[:, enc.fixed], np.broadcast_to(held, out[:, enc.fixed].shape))


def test_a_noise_trained_model_of_planar_motion_stays_in_the_plane(trained, chain_encoding):
    _, trajs, _ = chain_encoding
    err = _one_step_errors(engine_of(trained.net), trajs)
    assert err[IN_PLANE].max() < 1e-3, err                       # holds: the in-plane prediction is good
    assert err[OUT_OF_PLANE].max() < 1e-4, err                   # fails: ~1e-2 m / rad


def test_a_noise_trained_model_stays_bounded_over_10000_free_steps(trained, chain_encoding):
    """Before the damping prior and the envelope (2026-11-25) this model left the rod's range."""
    enc, trajs, _ = chain_encoding
    data_range = max(np.abs(t.states).max() for t in trajs)
    engine = engine_of(trained.net)
    assert engine.envelope is not None
    for traj in trajs[:2]:
        out = _free(engine, traj)
        assert np.isfinite(out).all()
        assert np.abs(out).max() < 2 * data_range, (np.abs(out).max(), data_range)
        assert np.abs(out[-1] - out[-2]).max() < 1e-6 * data_range      # it comes to rest, as the chain does


def test_the_damping_prior_makes_the_ridge_start_strictly_stable(chain_encoding):
    """The chain excites two bending modes; its other directions are left to the prior. Shrunk
    toward zero they are ballistic (eigenvalues 1, to rounding); toward the prior they relax."""
    enc, trajs, _ = chain_encoding
    config = DynamicConfig(model_dt=0.01, node_stride=2, steps=0, conv=False)
    sc = training.scales(trajs)
    radius = {}
    for tau in (1.0, None):
        net = DynamicNet(dataclasses.replace(config, prior_tau=tau), enc.node_features(), enc.fixed, sc)
        normal, _ = training._normal_equations(net, trajs)
        training._ridge_fit(net, normal, 1e-6)
        radius[tau] = training.spectral_radius(net)
    assert radius[1.0] < 0.999 and radius[None] > 0.9999, radius
    # with no data at all the fit is the prior: each coordinate a critically damped oscillator
    W0 = training.damping_prior(net.__class__(dataclasses.replace(config, prior_tau=1.0), enc.node_features(),
                                              enc.fixed, sc))
    r, i, c, C = 0.01 / 1.0, 1, 1, net.n_in                    # node 1 (free), channel y (moving)
    assert W0[i * C + c, i * 6 + c] == pytest.approx(-r * r * sc.sx[c] / sc.sa[c])
    assert W0[i * C + 6 + c, i * 6 + c] == pytest.approx(-2 * r * sc.sv[c] / sc.sa[c])
    assert np.count_nonzero(W0) == 2 * int((~enc.fixed).sum()) * int((sc.sa > 0).sum())


def test_the_baseline_stays_the_best_linear_model_wherever_the_network_starts(chain_encoding):
    """A network may start from a stiffer ridge fit (``ridge`` above 1e-6); the linear baseline keeps
    its own ladder from 1e-6, so it is never weakened by that choice; at the default both are one fit."""
    enc, trajs, val = chain_encoding
    config = DynamicConfig(model_dt=0.01, node_stride=2, width=8, layers=1, unroll=3, batch=8, steps=0)
    default = train_dynamic_model(trajs, enc, config, validation=val, threads=1)
    assert default.info["baseline_ridge"] == default.info["ridge"]
    assert _same_weights(default.net.linear, default.linear.linear)
    stiff = train_dynamic_model(trajs, enc, dataclasses.replace(config, ridge=10.0), validation=val, threads=1)
    assert stiff.info["ridge"] >= 10.0 > stiff.info["baseline_ridge"]
    assert stiff.info["baseline_ridge"] == default.info["ridge"]          # the same ladder, the same choice
    assert _same_weights(stiff.linear, default.linear)                    # the baseline is unchanged
    start = training.validation_error(stiff.net, val)
    assert training.validation_error(stiff.linear, val) <= start


def test_a_load_penalty_of_its_own_frees_the_load_response_only():
    """``load_ridge``: the ridge solution with that penalty on the load columns and ``ridge`` on the
    rest (normal equations of random data solved directly); a lighter load penalty leaves larger
    load coefficients; the baseline's config drops it."""
    M, H = 4, 3
    sc = training.Scales(**{k: np.ones(6) for k in ("sx", "sv", "su", "sa")})
    fixed = np.zeros(M, bool)
    feats = np.stack([np.linspace(0, 1, M)] * 2 + [fixed.astype(float)], 1)
    rng = np.random.default_rng(5)
    nets = {lr: DynamicNet(DynamicConfig(history=H, load_ridge=lr), feats, fixed, sc) for lr in (None, 1e-6)}
    n_in = nets[None].n_in
    X = rng.normal(size=(400, M * n_in)) * rng.uniform(0.1, 2.0, M * n_in)
    Y = X @ rng.normal(size=(M * n_in, M * 6)) + 0.1 * rng.normal(size=(400, M * 6))
    normal = (X.T @ X, X.T @ Y, np.zeros(M * n_in), np.zeros(M * 6))
    cut = load_channels(H, 6)
    is_load = np.zeros((M, n_in), bool)
    is_load[:, cut] = True
    is_load = is_load.reshape(-1)
    scale = np.trace(normal[0]) / len(normal[0])
    coef = {}
    for lr, net in nets.items():
        training._ridge_fit(net, normal, 1.0)
        pen = np.where(is_load, 1.0 if lr is None else lr, 1.0) * scale
        prior = training.damping_prior(net)
        W = np.linalg.solve(normal[0] + np.diag(pen), normal[1] + pen[:, None] * prior)
        got = net.linear.weight.detach().double().numpy().T
        np.testing.assert_allclose(got, W, rtol=1e-4, atol=1e-5 * np.abs(W).max())
        coef[lr] = np.abs(got[is_load]).mean()
    assert coef[1e-6] > 1.5 * coef[None]                         # less shrinking on the loads
    from softrnn.learned.whole.config import linear_config

    assert linear_config(DynamicConfig(load_ridge=1e-6)).load_ridge is None


def test_start_fraction_draws_windows_from_the_trajectories_first_steps(monkeypatch):
    """A quarter of each batch begins within ``START_STEPS`` of a trajectory's start; without the
    option the windows are uniform and drawn exactly as before (the same generator calls)."""
    windows = np.stack([np.repeat([0, 1], 500), np.tile(np.arange(500), 2)], 1)
    seen = []

    def stop(trajectories, picks, H, K):
        seen.append(picks.copy())
        raise RuntimeError("picked")

    monkeypatch.setattr(training, "_batch", stop)
    for fraction in (0.0, 0.25):
        config = DynamicConfig(batch=64, start_fraction=fraction)
        with pytest.raises(RuntimeError, match="picked"):
            training._loss(None, None, windows, config, torch.Generator().manual_seed(0), 0)
    uniform, mixed = seen
    assert np.all(mixed[:16, 1] < training.START_STEPS) and set(mixed[:16, 0]) == {0, 1}
    np.testing.assert_array_equal(mixed[16:], uniform[16:])
    assert np.mean(uniform[:, 1] < training.START_STEPS) < 0.1


def test_the_envelope_gate_fades_the_correction_outside_the_data():
    net = DynamicNet(DynamicConfig(width=4, layers=1, envelope=0.5), np.zeros((3, 3)), np.zeros(3, bool),
                     training.Scales(**{k: np.ones(6) for k in ("sx", "sv", "su", "sa")}))
    G = int(net.conv_cols.numel())
    net.set_envelope(torch.full((G,), -1.0), torch.full((G,), 1.0))      # range width 2: margin 1
    g = torch.zeros(3, G)
    g[1, 0], g[2, 3] = 1.5, -4.0                                          # half the margin out; far out
    clipped, gate = net.envelope_gate(g)
    np.testing.assert_allclose(gate[:, 0].numpy(), [1.0, 0.5, 0.0])
    assert clipped[1, 0] == 1.5 and clipped[2, 3] == -2.0                # clipped at the margin
    constant = torch.zeros(G)                                            # a channel that never varies
    net.set_envelope(constant, torch.where(torch.arange(G) == 0, 1.0, 0.0))
    _, gate = net.envelope_gate(torch.full((1, G), 7.0))
    assert gate.item() == 0.0                                            # channel 0 is 6 widths (0.5) out
    _, gate = net.envelope_gate(torch.cat([torch.full((1, 1), 0.5), torch.full((1, G - 1), 7.0)], dim=1))
    assert gate.item() == 1.0                                            # constants never gate


# --------------------------------------------------------------------- 7 held-out variants
def test_heldout_variants_never_reach_training(tmp_path, monkeypatch):
    sweep = tmp_path / "sweep"
    sweep.mkdir()
    for i in range(5):
        chain = bending_chain(0.01 * (i + 1), 0.5 * i, n_nodes=5, n_samples=21, dt=0.01)
        write_dataset(sweep / f"traj-{i:05d}.h5", chain)
    split = split_inputs([sweep], heldout=2, validation=1)
    names = lambda parts: [Path(p.path).name for p in parts]  # noqa: E731
    assert names(split.train) == ["traj-00000.h5", "traj-00001.h5"]
    assert names(split.validation) == ["traj-00002.h5"]
    assert names(split.heldout) == ["traj-00003.h5", "traj-00004.h5"]
    with pytest.raises(SoftrnnInputError, match="heldout"):
        split_inputs([sweep], heldout=3, validation=2)

    seen = {}

    def capture(trajectories, encoding, config, **kwargs):
        seen.update(trajectories=trajectories, encoding=encoding, config=config, **kwargs)
        return "trained"

    monkeypatch.setattr(fit_mod, "train_dynamic_model", capture)
    config = DynamicConfig(model_dt=0.02, node_stride=2)
    trained, meta = fit_mod.fit(split, config)
    assert trained == "trained" and seen["config"] is config
    assert [e["path"] for e in meta["data"]["heldout"]] == [p.path for p in split.heldout]
    assert [e["path"] for e in meta["data"]["validation"]] == [p.path for p in split.validation]
    assert [e["path"] for e in meta["data"]["train"]] == [p.path for p in split.train]
    enc = seen["encoding"]
    first = read_dataset(split.train[0].path)
    np.testing.assert_array_equal(enc.ref_positions, first.positions[0])
    assert [t.name for t in seen["trajectories"]] == [f"{p.path}:/" for p in split.train]
    for traj, part in zip(seen["trajectories"], split.train):
        np.testing.assert_array_equal(traj.states, enc.trajectory(read_dataset(part.path)).states)
    assert [t.name for t in seen["validation"]] == [f"{p.path}:/" for p in split.validation]
    for part in split.heldout:                                       # no trajectory the trainer got is held out
        held = enc.trajectory(read_dataset(part.path)).states
        for traj in list(seen["trajectories"]) + list(seen["validation"]):
            assert not np.array_equal(traj.states, held)


# ------------------------------------------------------------------ 8 seeds and resuming
def _same_weights(a, b) -> bool:
    sa, sb = a.state_dict(), b.state_dict()
    return sa.keys() == sb.keys() and all(torch.equal(sa[k], sb[k]) for k in sa)


def test_the_same_seed_gives_the_same_weights(chain_encoding):
    enc, trajs, _ = chain_encoding
    before = torch.get_num_threads()
    torch.set_num_threads(2)
    try:
        a = train_dynamic_model(trajs, enc, SMALL, threads=1)
        assert torch.get_num_threads() == 2          # the caller's thread count is given back
    finally:
        torch.set_num_threads(before)
    b = train_dynamic_model(trajs, enc, SMALL, threads=1)
    c = train_dynamic_model(trajs, enc, dataclasses.replace(SMALL, seed=1), threads=1)
    assert _same_weights(a.net, b.net) and _same_weights(a.linear, b.linear)
    assert a.info["losses"] == b.info["losses"]
    assert not _same_weights(a.net, c.net)


def test_an_interrupted_training_resumes_to_the_same_weights(chain_encoding, tmp_path, monkeypatch):
    enc, trajs, val = chain_encoding
    monkeypatch.setattr(training, "CHECKPOINT_EVERY", 50)
    config = dataclasses.replace(SMALL, steps=200)
    whole = train_dynamic_model(trajs, enc, config, validation=val, threads=1)

    def stop_at_100(step, steps, info):
        if step == 100:
            raise KeyboardInterrupt

    ckpt = tmp_path / "train.ckpt"
    with pytest.raises(KeyboardInterrupt):
        train_dynamic_model(trajs, enc, config, validation=val, checkpoint=ckpt, progress=stop_at_100, threads=1)
    assert torch.load(ckpt, weights_only=True)["loop"]["step"] == 50          # the last checkpoint written
    done = []
    resumed = train_dynamic_model(trajs, enc, config, validation=val, checkpoint=ckpt, threads=1,
                                  progress=lambda step, steps, info: done.append(step))
    assert done == list(range(51, 201))                                     # it resumed, not restarted
    assert _same_weights(whole.net, resumed.net)
    assert whole.info["selected_step"] == resumed.info["selected_step"]
    assert whole.info["validation"] == resumed.info["validation"]
    assert whole.info["losses"] == resumed.info["losses"]


# --------------------------------------------------------------------------------- 9 config
@pytest.mark.parametrize("kwargs, name", [({"model_dt": 0.0}, "model_dt"), ({"model_dt": -0.01}, "model_dt"),
                                          ({"kernel": 4}, "kernel"), ({"memory": "gru"}, "memory"),
                                          ({"history": 1}, "history"), ({"node_stride": 0}, "node_stride"),
                                          ({"unroll": 0}, "unroll"), ({"noise": -1.0}, "noise"),
                                          ({"linear": 1}, "linear"), ({"envelope": 0.0}, "envelope"),
                                          ({"prior_tau": -1.0}, "prior_tau"), ({"load_ridge": -1.0}, "load_ridge"),
                                          ({"start_fraction": 1.0}, "start_fraction"),
                                          ({"linear": False, "conv": False}, "linear")])
def test_bad_config_values_name_the_argument(kwargs, name):
    with pytest.raises(SoftrnnInputError) as info:
        DynamicConfig(**kwargs)
    msg = str(info.value)
    assert msg.startswith(f"{name}=") and "\n" not in msg, msg


def test_config_from_dict_round_trips_and_refuses_unknown_keys():
    config = DynamicConfig(model_dt=0.01, memory="lstm", node_stride=3)
    assert DynamicConfig.from_dict(config.to_dict()) == config
    assert not {"drive", "start_fraction", "load_ridge"} & set(config.to_dict())     # as saved before them
    later = DynamicConfig(drive="actuation", start_fraction=0.25, load_ridge=1e-4)
    assert DynamicConfig.from_dict(later.to_dict()) == later
    assert {"drive", "start_fraction", "load_ridge"} <= set(later.to_dict())
    with pytest.raises(SoftrnnInputError, match="widht"):
        DynamicConfig.from_dict({**config.to_dict(), "widht": 8})
    with pytest.raises(SoftrnnInputError):
        DynamicConfig.from_dict([("width", 8)])


def test_resolve_stride_needs_a_whole_multiple():
    assert resolve_stride(0.02, 0.01) == 2 and resolve_stride(0.02, 0.02) == 1 and resolve_stride(0.03, 0.001) == 30
    for model_dt, data_dt in ((0.02, 0.003), (0.01, 0.02), (0.025, 0.01)):
        with pytest.raises(SoftrnnInputError, match="model_dt"):
            resolve_stride(model_dt, data_dt)
