"""ONNX and TorchScript export of node models: the files, run in ONNX Runtime and libtorch's Python
binding, give NodeModel.predict's next positions (Fig. 2A and 2B models, relative inputs on and off,
every output mode, batch 1 and more), carry their description, and the ``softrnn export`` command
writes them or refuses bad input with one line, exit code 2 and no file."""

import json

import numpy as np
import onnxruntime as ort
import pytest
import torch

from softrnn.errors import SoftrnnInputError
from softrnn.learned.node.artifact import NodeModel, save_model
from softrnn.learned.node.data import Normalizer, SampleSpec, make_windows, split
from softrnn.learned.node.export import (
    DEFAULT_OPSET,
    FORMAT,
    TORCHSCRIPT_EXTRA_FILE,
    PhysicalNodeModel,
    export_onnx,
    export_torchscript,
    onnx_metadata,
)
from softrnn.learned.node.model import ModelConfig, NodeLSTM

from helpers import node_dataset as synthetic
from helpers import run_cli

pytestmark = pytest.mark.filterwarnings("ignore:`torch.jit.load` is deprecated:DeprecationWarning")

TOL_M = 1e-5
"""Largest allowed difference from NodeModel.predict [m] (the graph computes in float32)."""


@pytest.fixture(scope="module")
def data():
    return synthetic(60)  # node positions up to 0.5 m, random quaternions and wrenches of order 1


def node_model(ds, *, wrench="force", output="increment", relative=False, inputs="positions") -> NodeModel:
    """A randomly initialised 2-layer NodeLSTM (fixed seed) with a normaliser fitted on the training span."""
    spec = SampleSpec(node=2, wrench=wrench, inputs=inputs).resolve(ds.nodes, n_nodes_total=ds.attrs["n_nodes_total"])
    train = split(ds.n_samples, spec)[0]
    norm = Normalizer.fit(make_windows(ds, spec, train.start, train.stop), output=output, relative=relative,
                          per_node=spec.per_node)
    config = ModelConfig(pose_features=spec.pose_features, wrench_features=spec.wrench_features, history=3,
                         lstm_layers=2, lstm_units=8, dense_units=(8,), wrench_dense=(4,), output=output,
                         relative=relative)
    spec = SampleSpec(node=spec.node, neighbours=spec.neighbours, history=3, inputs=inputs, wrench=wrench)
    torch.manual_seed(0)
    module = NodeLSTM(config)
    module.set_normalizer(norm)
    module.eval()
    return NodeModel(config=config, spec=spec, normalizer=norm, module=module,
                     meta={"dataset": {"dt": 0.01, "scenario_name": "synthetic"}})


def windows(ds, model):
    w = make_windows(ds, model.spec, 0, ds.n_samples)                 # every window of the record
    feeds = {"poses": w.poses}
    if model.config.wrench_features:
        feeds["wrenches"] = w.wrenches
    return feeds, model.predict(w.poses, w.wrenches if model.config.wrench_features else None)


def run_onnx(path, feeds) -> np.ndarray:
    options = ort.SessionOptions()
    options.intra_op_num_threads = options.inter_op_num_threads = 1
    session = ort.InferenceSession(str(path), options, providers=["CPUExecutionProvider"])
    assert [i.name for i in session.get_inputs()] == list(feeds)
    return session.run(["next_position"], feeds)[0]


# ------------------------------------------------------------------------------------------ parity
@pytest.mark.parametrize("relative", [False, True])
@pytest.mark.parametrize("output", ["increment", "acceleration", "pose"])
@pytest.mark.parametrize("wrench", ["none", "force"])
def test_exported_files_match_predict(data, tmp_path, wrench, output, relative):
    """Fig. 2A (no wrench input) and 2B: the ONNX file in ONNX Runtime and the TorchScript file give
    predict's next positions to 1e-5 m for a whole record (batch 57) and one window (batch 1)."""
    model = node_model(data, wrench=wrench, output=output, relative=relative)
    feeds, ref = windows(data, model)                                   # ref (57, 3) [m]
    assert ref.shape == (57, 3) and np.ptp(feeds["poses"][:, -1, 0]) > 0.005  # windows of a moving node
    onnx_path = export_onnx(model, tmp_path / "m.onnx")
    got = run_onnx(onnx_path, feeds)
    assert got.dtype == np.float32 and got.shape == ref.shape
    np.testing.assert_allclose(got, ref, rtol=0, atol=TOL_M)
    one = run_onnx(onnx_path, {k: v[5:6] for k, v in feeds.items()})
    np.testing.assert_allclose(one, ref[5:6], rtol=0, atol=TOL_M)

    traced = torch.jit.load(str(export_torchscript(model, tmp_path / "m.pt")))
    with torch.inference_mode():
        got = traced(*[torch.from_numpy(v) for v in feeds.values()]).numpy()
        one = traced(*[torch.from_numpy(v[5:6]) for v in feeds.values()]).numpy()
    np.testing.assert_allclose(got, ref, rtol=0, atol=TOL_M)
    np.testing.assert_allclose(one, ref[5:6], rtol=0, atol=TOL_M)


@pytest.mark.parametrize("relative", [False, True])
def test_quaternion_inputs_and_torques(data, tmp_path, relative):
    """inputs='poses' (7 values per node; relative shifts positions only) with force and torque."""
    model = node_model(data, wrench="wrench", output="pose", relative=relative, inputs="poses")
    feeds, ref = windows(data, model)
    assert feeds["poses"].shape[2] == 21 and feeds["wrenches"].shape[2] == 6
    np.testing.assert_allclose(run_onnx(export_onnx(model, tmp_path / "m.onnx"), feeds), ref, rtol=0, atol=TOL_M)


def test_wrapper_is_the_normalizer_in_float32(data):
    """The torch wrapper itself (before any export) equals predict, and moving the whole window
    by 0.3 m moves a relative-input, increment model's prediction by exactly that (to float32)."""
    model = node_model(data, relative=True)
    feeds, ref = windows(data, model)
    wrapped = PhysicalNodeModel(model)
    poses, wrenches = torch.from_numpy(feeds["poses"]), torch.from_numpy(feeds["wrenches"])
    with torch.inference_mode():
        np.testing.assert_allclose(wrapped(poses, wrenches).numpy(), ref, rtol=0, atol=TOL_M)
        shifted = poses.clone().reshape(57, 3, 3, 3)
        shifted[..., 0] += 0.3                                            # every node's x [m]
        moved = wrapped(shifted.reshape(57, 3, 9), wrenches).numpy()
    np.testing.assert_allclose(moved - ref, np.broadcast_to([0.3, 0.0, 0.0], ref.shape), rtol=0, atol=TOL_M)
    with pytest.raises(SoftrnnInputError, match="model="):
        PhysicalNodeModel(model.module)


def test_static_batch_and_opset(data, tmp_path):
    model = node_model(data, wrench="none")
    feeds, ref = windows(data, model)
    path = export_onnx(model, tmp_path / "static.onnx", opset=13, dynamic_batch=False)
    session = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
    assert session.get_inputs()[0].shape == [1, 3, 9] and session.get_outputs()[0].shape == [1, 3]
    import onnx

    assert onnx.load(str(path)).opset_import[0].version == 13
    np.testing.assert_allclose(session.run(None, {"poses": feeds["poses"][:1]})[0], ref[:1], rtol=0, atol=TOL_M)
    dynamic = ort.InferenceSession(str(export_onnx(model, tmp_path / "dyn.onnx")), providers=["CPUExecutionProvider"])
    assert dynamic.get_inputs()[0].shape == ["batch", 3, 9]
    assert onnx.load(str(tmp_path / "dyn.onnx")).opset_import[0].version == DEFAULT_OPSET


# ---------------------------------------------------------------------------------------- metadata
def test_metadata_describes_the_inputs(data, tmp_path):
    model = node_model(data, wrench="force", output="acceleration", relative=True)
    meta = onnx_metadata(export_onnx(model, tmp_path / "m.onnx"))
    assert meta["format"] == FORMAT and meta["format_version"] == "1" and meta["softrnn_version"]
    assert json.loads(meta["node"]) == 2 and json.loads(meta["neighbours"]) == [1, 3]
    assert json.loads(meta["window_nodes"]) == [2, 1, 3] and json.loads(meta["history"]) == 3
    assert (meta["inputs"], meta["wrench"], meta["output"]) == ("positions", "force", "acceleration")
    assert json.loads(meta["relative"]) is True and json.loads(meta["pose_features"]) == 9
    assert json.loads(meta["wrench_features"]) == 3 and json.loads(meta["dt"]) == 0.01
    assert json.loads(meta["units"])["next_position"] == "m"
    assert json.loads(meta["input_names"]) == ["poses", "wrenches"] and meta["output_name"] == "next_position"
    assert "2, 1, 3" in meta["pose_layout"] and "[N]" in meta["wrench_layout"]

    extra = {TORCHSCRIPT_EXTRA_FILE: ""}
    torch.jit.load(str(export_torchscript(model, tmp_path / "m.pt")), _extra_files=extra)
    assert json.loads(extra[TORCHSCRIPT_EXTRA_FILE]) == meta
    fig2a = onnx_metadata(export_onnx(node_model(data, wrench="none"), tmp_path / "a.onnx"))
    assert json.loads(fig2a["input_names"]) == ["poses"] and fig2a["wrench"] == "none"


def test_bad_arguments_write_nothing(data, tmp_path):
    model = node_model(data)
    target = tmp_path / "m.onnx"
    target.write_bytes(b"old")
    for kwargs, word in (({"opset": 5}, "opset=5"), ({"opset": "17"}, "opset="),
                         ({"dynamic_batch": "no"}, "dynamic_batch")):
        with pytest.raises(SoftrnnInputError, match=word):
            export_onnx(model, target, **kwargs)
    with pytest.raises(SoftrnnInputError, match="not a folder"):
        export_onnx(model, tmp_path)
    with pytest.raises(SoftrnnInputError, match="not a folder"):
        export_torchscript(model, tmp_path)
    with pytest.raises(SoftrnnInputError, match="model="):
        export_onnx(model.module, target)
    with pytest.raises(SoftrnnInputError, match="ONNX file"):
        onnx_metadata(target)
    assert target.read_bytes() == b"old" and sorted(p.name for p in tmp_path.iterdir()) == ["m.onnx"]


# --------------------------------------------------------------------------------------------- CLI
def test_cli_export(data, tmp_path, capsys):
    model = node_model(data, wrench="force", output="increment", relative=True)
    folder = tmp_path / "model"
    save_model(folder, model)
    out = tmp_path / "out"
    assert run_cli(["export", str(folder), "--onnx", str(out / "m.onnx"), "--torchscript", str(out / "m.pt")]) == 0
    text = capsys.readouterr().out
    assert "wrote" in text and "(B, 3, 9)" in text and "(B, 3, 3)" in text
    assert text.count("-> next_position (B, 3) [m])") == 2          # one output name for ONNX and TorchScript
    feeds, ref = windows(data, model)
    np.testing.assert_allclose(run_onnx(out / "m.onnx", feeds), ref, rtol=0, atol=TOL_M)
    with torch.inference_mode():
        got = torch.jit.load(str(out / "m.pt"))(*[torch.from_numpy(v) for v in feeds.values()]).numpy()
    np.testing.assert_allclose(got, ref, rtol=0, atol=TOL_M)
    assert run_cli(["export", str(folder), "--torchscript", str(out / "only.pt")]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["m.onnx", "m.pt", "only.pt"]


def test_cli_refuses_bad_input(data, tmp_path, capsys):
    folder = tmp_path / "model"
    save_model(folder, node_model(data, wrench="none"))
    (tmp_path / "not_a_model").mkdir()
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.onnx").write_bytes(b"old")
    cases = [
        (["export", str(folder)], "nothing to write: give at least one of --onnx PATH and --torchscript PATH"),
        (["export", str(tmp_path / "not_a_model"), "--onnx", str(out / "a.onnx")], "config.json is missing"),
        (["export", str(tmp_path / "missing"), "--onnx", str(out / "a.onnx")], "no such model folder"),
        (["export", str(folder), "--onnx", str(out / "keep.onnx"), "--opset", "99", "--overwrite"], "opset=99"),
        (["export", str(folder), "--onnx", str(out / "x"), "--torchscript", str(out / "x")], "other than --onnx"),
        (["export", str(folder), "--onnx", str(out), "--torchscript", str(out / "b.pt")], "not a folder"),
        (["export", str(folder), "--onnx", str(folder / "m.onnx")], "outside the model folder"),
        (["export", str(folder), "--onnx", str(out / "a.onnx"), "--opset", "x"], "invalid int value"),
        (["export", str(folder), "--torchscript", str(out / "a.pt"), "--opset", "13"], "with --onnx PATH only"),
    ]
    for argv, message in cases:
        assert run_cli(argv) == 2, argv
        err = capsys.readouterr().err
        assert message in err and err.count("\n") == 1 and err.startswith("softrnn: error:"), (argv, err)
    assert sorted(p.name for p in out.iterdir()) == ["keep.onnx"] and (out / "keep.onnx").read_bytes() == b"old"
    assert sorted(p.name for p in folder.iterdir()) == sorted(["config.json", "meta.json", "normalizer.json",
                                                                "weights.safetensors"])
