"""Prescribed nodes in the whole-manipulator model: a clamp the scenario moves along a path is an
input, not a prediction. The moving clamps read from a data set's scenario, the path channels (each
step's change of the clamp's state), a free run that keeps the clamp on its recorded path (the
network, the NumPy engine and the baselines alike), the PyTorch step equal to the NumPy one, the
training loss blind to the clamp, a saved model read back, and the option that predicts the clamp
instead."""

import dataclasses
import json

import numpy as np
import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.io import Dataset
from softrnn.learned.baselines import free_run
from softrnn.learned.whole import evaluation
from softrnn.learned.whole.config import DynamicConfig
from softrnn.learned.whole.encoding import make_encoding
from softrnn.learned.whole.feedback import moving_clamps

from helpers import run_cli, without_record_builder

torch = pytest.importorskip("torch")

from softrnn.learned.whole import training  # noqa: E402
from softrnn.learned.whole.artifact import load_dynamic, save_dynamic  # noqa: E402

DT = 0.01

SCENARIO = """
format = 1
name = "waved-clamp"
title = "a short rod whose clamp is moved sideways"
seed = 1
gravity = [0.0, 0.0, 0.0]

[rod]
length = 0.2
radius = 0.004
n_nodes = 11
youngs_modulus = 2.5e7
poisson_ratio = 0.5
density = 1000.0

[reference]
kind = "straight"
origin = [0.0, 0.0, 0.0]
direction = [1.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]

[[boundary]]
kind = "clamp"
node = 0
displacement = { kind = "constant", value = [0.0, AMP, 0.0], schedule = { start = START, ramp = 0.3 } }

[damping]
translational = 0.02
rotational = 1e-6

[run]
dt = 0.01
duration = 1.0
nodes_of_interest = [-1]
"""


def _dataset(amplitude: float, start: float, n_samples: int = 121) -> Dataset:
    """The scenario simulated with the clamp moved ``amplitude`` [m] sideways from ``start`` [s],
    every node saved every ``DT``."""
    from softrnn.rod import Simulator
    from softrnn.scenarios.scenario import parse_scenario

    sc = parse_scenario(SCENARIO.replace("AMP", repr(amplitude)).replace("START", repr(start)))
    config = dataclasses.replace(sc.config, dt=DT, n_samples=n_samples, save_nodes=None)
    traj = Simulator(sc.setup).run(config)
    attrs = {"dt": DT, "rod": dataclasses.asdict(sc.setup.rod), "scenario_text": sc.text,
             "scenario_record": sc.record.to_record()}
    return Dataset(time=traj.time, nodes=traj.nodes, positions=traj.positions, quaternions=traj.quaternions,
                   forces=traj.forces, torques=traj.torques, attrs=attrs)


@pytest.fixture(scope="module")
def data():
    return [_dataset(a, t) for a, t in ((0.03, 0.1), (0.05, 0.5), (0.04, 0.3))]


@pytest.fixture(scope="module")
def trained(data):
    config = DynamicConfig(model_dt=0.02, node_stride=2, steps=30, unroll=4, batch=8, ema=0.0)
    enc = make_encoding(data[:2], model_dt=config.model_dt, node_stride=2, length=0.2, prescribed=True)
    trajs = [enc.trajectory(d) for d in data[:2]]
    return training.train_dynamic_model(trajs, enc, config, threads=1), enc


def _with_text(data: Dataset, text: str) -> Dataset:
    """``data`` with the scenario ``text`` (its placeholders filled) and that scenario's record."""
    from softrnn.scenarios.scenario import parse_scenario

    text = text.replace("AMP", "0.03").replace("START", "0.1")
    return dataclasses.replace(data, attrs={**data.attrs, "scenario_text": text,
                                            "scenario_record": parse_scenario(text).record.to_record()})


def test_the_moving_clamp_is_read_from_the_scenario(data):
    assert moving_clamps(data[0]) == (0,)
    head, tail = SCENARIO.split("[[boundary]]")
    still = _with_text(data[0], head + "[damping]" + tail.split("[damping]")[1])
    assert moving_clamps(still) == ()
    lab = Dataset(time=data[0].time, nodes=data[0].nodes, positions=data[0].positions,
                  quaternions=data[0].quaternions, forces=data[0].forces, torques=data[0].torques,
                  attrs={"dt": DT})
    assert moving_clamps(lab) == ()


def test_the_path_channels_are_each_steps_change_of_the_clamps_state(data):
    enc = make_encoding(data, model_dt=0.02, node_stride=3, length=0.2, prescribed=True)
    assert enc.prescribed.tolist() == [True] + [False] * (enc.n_kept - 1)
    assert not enc.fixed.any()                      # the clamp moves: it is not a fixed node
    assert enc.load_width == 12                     # the wrench, then the clamp's 6
    traj = enc.trajectory(data[2])
    change = traj.loads[:, :, 6:]
    np.testing.assert_allclose(change[:-1, 0], np.diff(traj.states[:, 0], axis=0), rtol=0, atol=1e-15)
    assert np.all(change == change[:, :1])          # the same at every kept node
    assert np.all(change[-1] == 0)
    assert np.abs(change[:, 0, 1]).max() > 1e-3     # the clamp moves sideways (y)
    off = make_encoding(data, model_dt=0.02, node_stride=3, length=0.2, prescribed=False)
    assert not off.prescribed.any() and off.load_width == 6


def test_a_free_run_keeps_the_clamp_on_its_recorded_path(trained, data):
    result, enc = trained
    traj = enc.trajectory(data[2])                  # never trained on
    for predictor in (load_engine(result.net), *evaluation.state_baselines().values()):
        states = free_run(predictor, traj, None, 3, traj.n_steps)     # raises RolloutDiverged where it diverges
        np.testing.assert_allclose(states[:, 0], traj.states[3:, 0], rtol=0, atol=1e-9)
    # the network's own rollout (training's unroll) too, in float32
    hist = torch.as_tensor(traj.states[None, :3], dtype=torch.float32)
    loads = torch.as_tensor(traj.loads[None, 2:-1], dtype=torch.float32)
    with torch.no_grad():
        out = result.net.rollout(hist, loads)[0].double().numpy()
    np.testing.assert_allclose(out[:, 0], traj.states[3:, 0], rtol=0, atol=1e-6)


def load_engine(net):
    from softrnn.learned.whole.artifact import engine_of

    return engine_of(net)


def test_the_numpy_engine_steps_as_the_network(trained, data):
    result, enc = trained
    engine = load_engine(result.net)
    engine64 = type(engine)({k: v.detach().double().numpy() for k, v in result.net.state_dict().items()},
                            result.net.config, dtype=np.float64)
    traj = enc.trajectory(data[1])
    hist, u = traj.states[4:7], traj.loads[6]
    with torch.no_grad():
        want, _ = result.net.double()(torch.as_tensor(hist[None]), torch.as_tensor(u[None]))
    result.net.float()
    got, _ = engine64.step(hist, u)
    np.testing.assert_allclose(got, want[0].numpy(), rtol=0, atol=1e-12)
    assert engine.prescribed_columns == ((0, 6),)


def test_the_loss_and_the_linear_fit_leave_the_clamp_out(trained):
    result, _ = trained
    assert result.net.held[0] and not result.net.held[1:].any()
    W = training.damping_prior(result.net)
    assert np.all(W[:, :6] == 0)                    # no prior pulls the clamp: it is not predicted
    assert result.info["linear_radius"] > 0


def test_a_saved_model_reads_back_with_its_prescribed_clamp(trained, data, tmp_path):
    result, enc = trained
    save_dynamic(tmp_path / "m", result)
    model = load_dynamic(tmp_path / "m")
    assert model.encoding.prescribed.tolist() == enc.prescribed.tolist()
    assert model.engine.prescribed_columns == ((0, 6),)
    traj = model.encoding.trajectory(data[2])
    a = free_run(model.engine, traj, None, 3, traj.n_steps)
    b = free_run(load_engine(result.net), traj, None, 3, traj.n_steps)
    np.testing.assert_array_equal(a, b)


def test_the_path_beats_predicting_the_clamp(data):
    """With the clamp's path as an input, the linear model follows a run it never saw far better than
    the same model that must predict the clamp from its own history (which cannot know when the
    clamp starts to move, nor how far)."""
    errors = {}
    for prescribed in (True, False):
        config = DynamicConfig(model_dt=0.02, node_stride=2, steps=0, prescribed=prescribed)
        enc = make_encoding(data[:2], model_dt=0.02, node_stride=2, length=0.2, prescribed=prescribed)
        result = training.train_dynamic_model([enc.trajectory(d) for d in data[:2]], enc, config, threads=1)
        traj = enc.trajectory(data[2])
        err, _ = evaluation.run_errors(load_engine(result.linear), enc, traj, data[2], 2)
        errors[prescribed] = float(np.max(err))
    assert errors[True] < 0.1 * errors[False]


def test_old_data_without_a_record_says_so_and_gets_it_back_from_its_text(data):
    from softrnn.scenarios.record import with_record

    old = dataclasses.replace(data[0], attrs={k: v for k, v in data[0].attrs.items() if k != "scenario_record"})
    with without_record_builder():          # as where softrnn.scenarios is not imported
        with pytest.raises(SoftrnnInputError) as info:
            moving_clamps(old)
    assert "\n" not in str(info.value) and "with_record" in str(info.value)
    assert moving_clamps(with_record(old)) == (0,)
    assert moving_clamps(old) == (0,)       # softrnn.scenarios imported: rebuilt on reading


def test_an_old_file_trains_and_evaluates_through_the_cli_as_a_new_one(data, tmp_path):
    """A file written before the record existed (its ``scenario_record`` attribute deleted) trains
    and evaluates through ``softrnn dynamic`` to the same model and figures as the file with it."""
    import h5py

    from softrnn.io import write_dataset

    for name in ("new", "old"):
        for i, d in enumerate(data):
            write_dataset(tmp_path / name / f"traj-{i:05d}.h5", d)
    for path in (tmp_path / "old").glob("*.h5"):
        with h5py.File(path, "a") as f:
            del f.attrs["scenario_record"]
    reports = {}
    for name in ("new", "old"):
        model = tmp_path / f"model-{name}"
        assert run_cli(["dynamic", "train", str(tmp_path / name), "-o", str(model), "--heldout", "1",
                        "--model-dt", "0.02", "--node-stride", "2", "--steps", "2", "--width", "8", "--layers", "1",
                        "--unroll", "2", "--threads", "1", "--quiet"]) == 0
        assert load_dynamic(model).encoding.prescribed.any()          # the moving clamp is a path input
        report = tmp_path / f"eval-{name}.json"
        assert run_cli(["dynamic", "evaluate", str(model), "--heldout", str(tmp_path / name / "traj-00002.h5"),
                        "--json", str(report)]) == 0
        reports[name] = {k: v for k, v in json.loads(report.read_text()).items()
                         if k not in ("model", "heldout_files")}          # the paths differ
    assert reports["old"] == reports["new"]


def test_data_of_different_moving_clamps_are_refused(data):
    other = _with_text(data[0], data[0].attrs["scenario_text"].replace("node = 0", "node = -1"))
    with pytest.raises(SoftrnnInputError, match="prescribed = false"):
        make_encoding([data[0], other], model_dt=0.02, node_stride=2, length=0.2, prescribed=True)


def test_the_onnx_graph_follows_the_path_as_the_engine(trained, tmp_path):
    pytest.importorskip("onnxruntime")
    from softrnn.learned.whole.export import describe, export_onnx

    result, _ = trained
    save_dynamic(tmp_path / "m", result)
    model = load_dynamic(tmp_path / "m")
    exported = export_onnx(model, tmp_path / "m.onnx")
    assert exported.max_difference <= 1e-5
    assert "node 0 (columns 6-11)" in describe(model)["units"]["loads"]
