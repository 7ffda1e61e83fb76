"""The vessel frame of the whole-manipulator model (DynamicConfig.frame = "vessel"): curvilinear
coordinates along a vessel's centreline and back to 1e-9 m, an orthonormal rotation-minimising frame,
the world frame's state again in a straight vessel along +x, a wire sliding round a bend that keeps
its state and that the linear term follows where the world frame's cannot, the option saved and
loaded (and absent from models without it), and one-line errors for bad input."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from softrnn.errors import SoftrnnInputError
from softrnn.geometry.contact import contact_record
from softrnn.io import Dataset, write_dataset
from softrnn.learned.whole.artifact import encoding_from_dict, encoding_to_dict
from softrnn.learned.whole.config import DynamicConfig
from softrnn.learned.whole.encoding import Encoding, check_compatible, make_encoding
from softrnn.learned.whole.frame import VesselFrame, frame_from_dict, vessel_frame
from softrnn.rod import Contact, Vessel

from helpers import run_cli

RADIUS = 0.003
ROD_RADIUS = 0.0005


def _bend(n: int = 6) -> np.ndarray:
    """A centreline (points [m]): a straight entry along +x, a 60 degree bend of radius 0.05 m toward
    +y, a short straight exit (chords of 5 mm round the bend, as the vessel-guidewire scenario)."""
    a = np.linspace(0.0, np.pi / 3, 21)[1:]
    arc = np.stack([0.05 * np.sin(a), 0.05 * (1 - np.cos(a)), 0 * a], 1)
    exit_ = arc[-1] + np.outer([0.05, 0.1], [np.cos(np.pi / 3), np.sin(np.pi / 3), 0.0])
    entry = np.stack([np.linspace(-0.4, -0.05, n), np.zeros(n), np.zeros(n)], 1)
    return np.concatenate([entry, [[0.0, 0.0, 0.0]], arc, exit_])


def _points(frame: VesselFrame, n: int, rng, reach: float = 0.0) -> np.ndarray:
    """Curvilinear coordinates (n, 3) inside the lumen, ``reach`` [m] beyond either end."""
    tau = rng.uniform(-reach, frame.end + reach, n)
    r, phi = rng.uniform(0, RADIUS - ROD_RADIUS, n), rng.uniform(0, 2 * np.pi, n)
    return np.stack([tau, r * np.cos(phi), r * np.sin(phi)], 1)


def test_cartesian_to_curvilinear_and_back_is_exact_on_the_spline():
    frame, rng = VesselFrame(_bend()), np.random.default_rng(1)
    q = _points(frame, 500, rng, reach=0.05)
    x = frame.world(q)
    assert np.abs(frame.world(frame.local(x)) - x).max() < 1e-9
    assert np.abs(frame.local(x) - q).max() < 1e-9
    centre = frame.curve(q[:, 0])[0]                  # u, w = 0 is the spline itself
    assert np.abs(frame.world(np.stack([q[:, 0], 0 * q[:, 0], 0 * q[:, 0]], 1)) - centre).max() < 1e-12
    before = q[:, 0] < 0                              # beyond the start: straight on along its tangent
    start, slope = frame.curve(np.zeros(1))[:2]
    assert before.any() and np.abs(centre[before] - start - q[before, :1] * slope).max() < 1e-12


def test_the_frame_is_orthonormal_and_rotation_minimising():
    frame = VesselFrame(_bend())
    tau = np.linspace(-0.1, frame.end + 0.1, 400)
    F = frame.rotation(tau)
    assert np.abs(np.einsum("nij,nik->njk", F, F) - np.eye(3)).max() < 1e-12
    assert np.allclose(np.linalg.det(F), 1.0)
    assert np.allclose(F[:, :, 0], frame.tangent(tau))
    assert np.allclose(F[:, :, 2], [0.0, 0.0, 1.0], atol=1e-9)      # a planar curve: n2 stays its normal
    assert np.allclose(F[0], np.eye(3), atol=1e-3)       # along +x: the world's axes (the spline wiggles 1e-4 rad)


def _straight_encoding(frame) -> Encoding:
    n = 7
    ref = np.stack([np.linspace(-0.3, -0.24, n), np.zeros(n), np.full(n, -0.001)], 1)
    return Encoding(n_nodes=n, kept=np.array([0, 2, 4, 6]), model_dt=0.02, data_dt=0.01, length=0.06,
                    ref_positions=ref, ref_quaternions=np.tile([1.0, 0, 0, 0], (n, 1)),
                    fixed=np.zeros(4, dtype=bool), frame=frame)


def test_in_a_straight_vessel_along_x_the_vessel_frame_is_the_world_frame():
    world, vessel = _straight_encoding(None), _straight_encoding(VesselFrame([[-1.0, 0, 0], [1.0, 0, 0]]))
    rng = np.random.default_rng(2)
    p = world.ref_positions[None] + rng.normal(0, 1e-3, (5, 7, 3)) + np.array([0.02, 0, 0])
    q = Rotation.from_rotvec(rng.normal(0, 0.1, (35, 3))).as_quat()[:, [3, 0, 1, 2]].reshape(5, 7, 4)
    states = world.encode(p, q)
    assert np.abs(vessel.encode(p, q) - states).max() < 1e-12
    for a, b in zip(world.decode(states), vessel.decode(states)):
        assert np.abs(a - b).max() < 1e-12
    assert np.abs(vessel.positions(states) - world.positions(states)).max() < 1e-12


def _slide(frame: VesselFrame, speed: float, n_samples: int = 61, dt: float = 0.01, contact=True) -> Dataset:
    """A wire of 9 nodes (10 mm apart) sliding at ``speed`` [m/s] along the centreline of ``frame``,
    on its axis, each node's body frame the vessel frame: every node saved every ``dt``."""
    n = 9
    t = np.arange(n_samples) * dt
    tau = 0.3 + 0.01 * np.arange(n)[None, :] + speed * t[:, None]          # (T, n)
    zeros = np.zeros_like(tau)
    pos = frame.world(np.stack([tau, zeros, zeros], -1).reshape(-1, 3)).reshape(n_samples, n, 3)
    quat = Rotation.from_matrix(frame.rotation(tau.reshape(-1))).as_quat()[:, [3, 0, 1, 2]].reshape(n_samples, n, 4)
    record = contact_record(Contact(obstacles=(Vessel(frame.centreline, RADIUS),)))
    attrs = {"dt": dt, "rod": {"length": 0.08, "radius": ROD_RADIUS}, **({"contact": record} if contact else {})}
    zero = np.zeros((n_samples, n, 3))
    walls = {"contact_forces": zero, "contact_torques": zero} if contact else {}
    return Dataset(time=t, nodes=np.arange(n), positions=pos, quaternions=quat, forces=zero, torques=zero,
                   attrs=attrs, **walls)


def test_a_wire_sliding_round_the_bend_keeps_its_state_in_the_vessel_frame():
    frame = VesselFrame(_bend())
    data = _slide(frame, 0.2)
    enc = make_encoding([data], model_dt=0.02, node_stride=2, length=0.08, prescribed=False, frame="vessel")
    states = enc.trajectory(data).states
    assert enc.frame.same(frame)
    assert np.abs(np.diff(states[:, :, 0], axis=0) - 0.2 * 0.02).max() < 1e-6       # along the vessel
    assert np.abs(states[:, :, 1:]).max() < 1e-6            # no offset, no turn
    assert np.abs(enc.positions(states) - data.positions[::2]).max() < 1e-6          # every node, on the bend
    world = make_encoding([data], model_dt=0.02, node_stride=2, length=0.08, prescribed=False)
    assert np.abs(world.trajectory(data).states[:, :, 1]).max() > 0.01               # the world frame turns


def test_the_linear_term_in_the_vessel_frame_follows_the_bend(tmp_path):
    pytest.importorskip("torch")
    from softrnn.learned.whole import training
    from softrnn.learned.whole.artifact import load_dynamic, save_dynamic
    from softrnn.learned.whole.evaluation import run_errors

    frame = VesselFrame(_bend())
    train, held = [_slide(frame, v) for v in (0.15, 0.25)], _slide(frame, 0.2)
    errors = {}
    for name in ("world", "vessel"):
        config = DynamicConfig(model_dt=0.02, node_stride=2, steps=0, unroll=1, conv=False, frame=name)
        enc = make_encoding(train, model_dt=0.02, node_stride=2, length=0.08, prescribed=False, frame=name)
        trained = training.train_dynamic_model([enc.trajectory(d) for d in train], enc, config, threads=1)
        save_dynamic(tmp_path / name, trained)
        model = load_dynamic(tmp_path / name)
        assert model.config.frame == name and (model.encoding.frame is not None) == (name == "vessel")
        errors[name] = run_errors(model.linear, model.encoding, model.encoding.trajectory(held), held, 2)[0].max()
    assert errors["vessel"] < 0.1 * errors["world"]
    assert errors["vessel"] < 1.0           # % of L


def test_the_option_is_saved_and_loaded_and_left_out_at_its_default():
    assert "frame" not in DynamicConfig().to_dict()
    d = DynamicConfig(frame="vessel").to_dict()
    assert d["frame"] == "vessel" and DynamicConfig.from_dict(d).frame == "vessel"
    vessel = _straight_encoding(VesselFrame(_bend()))
    back = encoding_from_dict(encoding_to_dict(vessel))
    assert back.frame.same(vessel.frame) and np.array_equal(back.ref_positions, vessel.ref_positions)
    assert "frame" not in encoding_to_dict(_straight_encoding(None))
    assert encoding_from_dict(encoding_to_dict(_straight_encoding(None))).frame is None


def test_bad_input_is_one_line():
    with pytest.raises(SoftrnnInputError, match="frame='tube' is invalid"):
        DynamicConfig(frame="tube")
    with pytest.raises(SoftrnnInputError, match="repeated consecutive points"):
        VesselFrame([[0.0, 0, 0], [0.0, 0, 0], [1.0, 0, 0]])
    with pytest.raises(SoftrnnInputError, match="centreline"):
        VesselFrame([[0.0, 0, 0]])
    with pytest.raises(SoftrnnInputError, match="encoding.frame"):
        frame_from_dict({"kind": "torus"})
    frame = VesselFrame(_bend())
    bare = _slide(frame, 0.2, contact=False)
    with pytest.raises(SoftrnnInputError, match="frame='vessel' is invalid: training data recorded in one vessel"):
        vessel_frame(bare)
    with pytest.raises(SoftrnnInputError, match="frame='vessel'"):
        make_encoding([bare], model_dt=0.02, node_stride=2, length=0.08, prescribed=False, frame="vessel")
    enc = make_encoding([_slide(frame, 0.2)], model_dt=0.02, node_stride=2, length=0.08, prescribed=False,
                        frame="vessel")
    other = _slide(VesselFrame(_bend(n=8)), 0.2)
    with pytest.raises(SoftrnnInputError, match="heldout=.*not recorded in the model's vessel"):
        check_compatible(enc, other, "heldout")


def test_the_command_line_trains_in_the_vessel_frame_and_refuses_data_without_a_vessel(tmp_path, capsys):
    pytest.importorskip("torch")
    from softrnn.learned.whole.artifact import load_dynamic

    frame = VesselFrame(_bend())
    for i, v in enumerate((0.15, 0.25, 0.2)):
        write_dataset(tmp_path / "sweep" / f"traj-{i:05d}.h5", _slide(frame, v))
    write_dataset(tmp_path / "bare" / "traj-00000.h5", _slide(frame, 0.2, contact=False))
    args = ["dynamic", "train", "--heldout", "1", "--steps", "0", "--node-stride", "2", "--threads", "1", "--quiet"]
    assert run_cli(args + [str(tmp_path / "sweep"), "--frame", "vessel", "-o", str(tmp_path / "m")]) == 0
    assert load_dynamic(tmp_path / "m").config.frame == "vessel"
    capsys.readouterr()
    assert run_cli(args[:3] + ["0"] + args[4:] + [str(tmp_path / "bare"), "--frame", "vessel",
                                                   "-o", str(tmp_path / "n")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "vessel" in err
    assert not (tmp_path / "n" / "model.json").exists()


def test_the_projection_and_the_contact_inputs_read_the_world_positions_of_a_framed_state():
    from softrnn.learned.whole.obstacles import ContactFeatures

    frame = VesselFrame(_bend())
    data = _slide(frame, 0.2)
    enc = make_encoding([data], model_dt=0.02, node_stride=2, length=0.08, prescribed=False, obstacles=True,
                        contact=True, frame="vessel")
    traj = enc.trajectory(data)
    state = traj.states[10].copy()
    state[2, 1] += 0.01                              # 10 mm across: through the wall
    world = enc.positions(state[None])[0, enc.kept]
    plain = ContactFeatures(data.contact, np.zeros((enc.n_kept, 3)), ROD_RADIUS, enc.length)
    assert np.allclose(traj.contact(state), plain(np.concatenate([world, 0 * world], axis=1)), atol=1e-12)
    before = state.copy()
    traj.project(state)
    assert traj.projection.moved == 1 and np.array_equal(np.delete(state, 2, 0), np.delete(before, 2, 0))
    assert state[2, 1] == pytest.approx(RADIUS - ROD_RADIUS, abs=1e-5)       # back on the wall
    assert traj.projection.depth(state) < 1e-9 < traj.projection.depth(before)
