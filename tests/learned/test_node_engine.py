"""The compiled inference engine: equal to the PyTorch model (batched windows, a 1,000-step
free-running rollout, the batch-1 stepper, the whole-manipulator stepper) and one-line errors."""

import numpy as np
import pytest
import torch

from softrnn.errors import SoftrnnInputError
from softrnn.learned.node.artifact import NodeModel
from softrnn.learned.node.data import Normalizer, SampleSpec, make_windows, split
from softrnn.learned.node.engine import Engine, ManipulatorStepper, NodeStepper
from softrnn.learned.node.manipulator import Manipulator
from softrnn.learned.node.model import ModelConfig, NodeLSTM
from softrnn.learned.node.rollout import rollout

from helpers import node_dataset as synthetic

DS = synthetic(1100)


def model(node=3, *, inputs="positions", wrench="force", output="increment", relative=False, layers=2, units=32,
          dense=(32,), wrench_dense=(16,), differences=True, skip=True, history=2, seed=0, gain=1.0,
          ds=DS) -> NodeModel:
    """A NodeLSTM with seeded random weights (times ``gain``) and a normaliser fitted on the training span."""
    spec = SampleSpec(node=node, history=history, inputs=inputs, wrench=wrench).resolve(
        ds.nodes, n_nodes_total=int(ds.attrs["n_nodes_total"]))
    train = split(ds.n_samples, spec)[0]
    norm = Normalizer.fit(make_windows(ds, spec, train.start, train.stop), output=output, relative=relative,
                          per_node=spec.per_node)
    config = ModelConfig(pose_features=spec.pose_features, wrench_features=spec.wrench_features, history=history,
                         lstm_layers=layers, lstm_units=units, dense_units=dense, wrench_dense=wrench_dense,
                         output=output, differences=differences, linear_skip=skip, relative=relative)
    torch.manual_seed(seed)
    module = NodeLSTM(config)
    module.set_normalizer(norm)
    with torch.no_grad():
        for p in module.parameters():
            p.mul_(gain)
    module.eval()
    return NodeModel(config=config, spec=spec, normalizer=norm, module=module, meta={})


VARIANTS = [
    dict(),
    dict(inputs="poses", wrench="wrench", output="acceleration", relative=True, layers=1, dense=(), wrench_dense=(),
         differences=False, skip=False, history=3),
    dict(wrench="none", output="pose", layers=3, dense=(8, 8), history=1),
    dict(inputs="poses", relative=True, dense=(16,), wrench_dense=(8, 4), history=4, gain=3.0),
]


@pytest.mark.parametrize("kw", VARIANTS)
def test_engine_equals_the_pytorch_model_on_windows(kw):
    m = model(**kw)
    w = make_windows(DS, m.spec, 0, 400)
    ref = m.predict(w.poses, w.wrenches)
    got = Engine([m]).predict(w.poses, w.wrenches if m.config.wrench_features else None)
    scale = np.abs(ref - w.poses[:, -1, :3]).max()
    assert scale > 1e-4                                   # the models do move the node
    np.testing.assert_allclose(got, ref, rtol=0, atol=max(1e-7, 1e-5 * scale))


def test_stacked_models_each_use_their_own_weights():
    a, b = model(seed=1), model(seed=2, node=4)
    wa, wb = make_windows(DS, a.spec, 0, 50), make_windows(DS, b.spec, 0, 50)
    eng = Engine([a, b])
    poses = np.concatenate([wa.poses, wb.poses])
    wr = np.concatenate([wa.wrenches, wb.wrenches])
    which = np.r_[np.zeros(len(wa), int), np.ones(len(wb), int)]
    got = eng.predict(poses, wr, which)
    np.testing.assert_allclose(got[:len(wa)], a.predict(wa.poses, wa.wrenches), atol=1e-7)
    np.testing.assert_allclose(got[len(wa):], b.predict(wb.poses, wb.wrenches), atol=1e-7)


def test_a_1000_step_rollout_equals_the_pytorch_rollout():
    # random weights predicting the next position itself stay bounded when fed back for 1,000 steps
    models = [model(node=a, seed=a, output="pose", skip=False) for a in range(1, 5)]
    fast = rollout(models, DS, start=50, stop=1050, unmodelled="hold")
    slow = rollout(models, DS, start=50, stop=1050, unmodelled="hold", engine=False)
    moved = np.abs(slow.positions[-1] - slow.positions[2]).max()
    assert moved > 1e-3                                   # a real free run, not a standstill
    assert np.abs(fast.positions - slow.positions).max() < 1e-5


def test_the_node_stepper_equals_batched_windows():
    m = model()
    w = make_windows(DS, m.spec, 0, 60)
    ref = m.predict(w.poses, w.wrenches)
    st = NodeStepper(m)
    got = [st.reset(w.poses[0], w.wrenches[0]).copy()]
    for k in range(1, len(w)):
        got.append(st.step(w.poses[k, -1], w.wrenches[k, -1]).copy())
    np.testing.assert_allclose(np.array(got), ref, atol=1e-7)


def test_the_manipulator_stepper_equals_the_rollout():
    models = [model(node=a, seed=a) for a in range(1, 5)]
    ref = rollout(models, DS, start=10, stop=60, unmodelled="hold")
    st = ManipulatorStepper(Manipulator.of(models), DS.nodes)
    cols = [int(np.flatnonzero(DS.nodes == a)[0]) for a in st.modelled]
    f = DS.forces.astype(np.float32)
    st.reset(DS.positions[8:10], f[8:10][:, cols])
    for k in range(10, 60):
        got = st.step(f[k][cols])
        np.testing.assert_array_equal(got, ref.positions[k - 8])


def test_errors_are_one_line():
    m = model()
    st = NodeStepper(m)
    with pytest.raises(SoftrnnInputError, match="before reset"):
        st.step(np.zeros(9), np.zeros(3))
    with pytest.raises(SoftrnnInputError, match=r"poses=.*shape \(2, 9\)"):
        st.reset(np.zeros((3, 9)))
    st.reset(np.zeros((2, 9)), np.zeros((2, 3)))
    with pytest.raises(SoftrnnInputError, match="one row of inputs"):
        st.step(np.zeros(8), np.zeros(3))
    with pytest.raises(SoftrnnInputError, match="architecture"):
        Engine([m, model(units=8)])
    with pytest.raises(SoftrnnInputError, match="agree on history"):
        ManipulatorStepper([m, model(node=4, history=3)], DS.nodes)
    with pytest.raises(SoftrnnInputError, match="does not store"):
        ManipulatorStepper([m], [0, 1, 2, 3])
    with pytest.raises(SoftrnnInputError, match="which"):
        Engine([m]).predict(np.zeros((2, 2, 9)), np.zeros((2, 2, 3)), which=[0, 1])


def test_mixed_architectures_and_threads_give_the_same_manipulator():
    ends = [model(node=a, seed=a) for a in (1, 2, 3, 4)] + [model(node=5, seed=5)]   # node 5: one neighbour
    ref = rollout(ends, DS, start=10, stop=40, unmodelled="hold")
    f = DS.forces.astype(np.float32)
    for threads in (1, 2):
        st = ManipulatorStepper(ends, DS.nodes, threads=threads)
        cols = [int(np.flatnonzero(DS.nodes == a)[0]) for a in st.modelled]
        st.reset(DS.positions[8:10], f[8:10][:, cols])
        for k in range(10, 40):
            np.testing.assert_array_equal(st.step(f[k][cols]), ref.positions[k - 8])


@pytest.mark.parametrize("kw", VARIANTS)
def test_the_shared_weight_kernel_equals_the_one_node_kernel(kw):
    from softrnn.learned.node import _engine_kernels as K
    from softrnn.learned.node.engine import _shared_scratch

    m = model(**kw)
    w = make_windows(DS, m.spec, 0, 300)
    e = Engine([m])
    ref = e.predict(w.poses, w.wrenches if m.config.wrench_features else None)
    X = np.ascontiguousarray(w.poses, np.float32)
    Wr = np.ascontiguousarray(w.wrenches if m.config.wrench_features else np.zeros((len(w), m.config.history, 0)),
                              np.float32)
    eb = _shared_scratch(e, len(w))[2]
    out = np.empty((len(w), 3))
    K.forward_gemm(e.params[0], e.norm[0], e.arch, e.layers, X, Wr, eb, out)
    scale = np.abs(ref - w.poses[:, -1, :3]).max()
    np.testing.assert_allclose(out, ref, rtol=0, atol=1e-6 * scale)   # BLAS sums in another order


def test_a_shared_model_manipulator_equals_pytorch_and_the_stepper():
    shared = model(node=2, seed=3, output="pose", skip=False)
    manip = Manipulator.of([], shared=shared, shared_nodes=[1, 2, 3, 4])
    fast = rollout(manip, DS, start=50, stop=1050, unmodelled="hold")
    slow = rollout(manip, DS, start=50, stop=1050, unmodelled="hold", engine=False)
    assert np.abs(fast.positions - slow.positions).max() < 1e-5
    for threads in (1, 2):
        st = ManipulatorStepper(manip, DS.nodes, threads=threads)
        cols = [int(np.flatnonzero(DS.nodes == a)[0]) for a in st.modelled]
        f = DS.forces.astype(np.float32)
        st.reset(DS.positions[48:50], f[48:50][:, cols])
        for k in range(50, 80):
            np.testing.assert_allclose(st.step(f[k][cols]), fast.positions[k - 48], rtol=0, atol=1e-7)


def test_the_packed_layout_is_named_records():
    from softrnn.learned.node import _engine_kernels as K
    from softrnn.learned.node.engine import pack

    m = model(**VARIANTS[3])                 # 2 x 32 LSTM, wrench branch (8, 4), head (16,), history 4
    params, norm, arch, layers = pack([m])
    assert arch.dtype == K.ARCHITECTURE and arch.shape == (1,) and layers.dtype == K.LAYER
    a = arch[0]
    assert (a["history"], a["lstm_layers"], a["lstm_units"], a["wrench_dense"], a["head_dense"]) == (4, 2, 32, 2, 1)
    assert a["params_length"] == params.shape[1] and a["work_length"] == K.work_size(arch, layers)
    assert list(layers["n_out"]) == [128, 128, 8, 4, 16] and list(layers["n_in"][1:]) == [32, 12, 8, 36]
    assert (layers["off_u"][:2] > layers["off_w"][:2]).all() and (layers["off_u"][2:] == -1).all()
    ends = layers["off_b"] + layers["n_out"]                      # each layer's bias ends where the next begins
    assert list(layers["off_w"][1:]) == list(ends[:-1]) and ends[-1] == a["off_out"]
