"""Speed of the learned models on this machine: the compiled engine against eager PyTorch.

Measures (see benchmarks/README.md):

* **node step, batch 1**: ``NodeStepper.step(pose_row, wrench_row)`` called from Python, one call
  per sample, timed by ``timing.step_rate`` (each call alone, ``perf_counter_ns``; the median over
  5 runs of each run's mean rate, and the 99th percentile of the call times);
* **eager PyTorch, same model, same run**: ``module(poses, wrenches)`` on ready tensors at batch 1
  under ``torch.inference_mode`` with one torch thread (the fair, favourable baseline: no numpy
  conversion, no normalisation), and ``NodeModel.predict`` (what the paper's kind of loop pays);
* **whole manipulator**: ``ManipulatorStepper.step`` with every node of a 101-node rod modelled,
  each by its own model (101 weight sets; 1 thread and all threads) or the interior nodes by one
  shared model (the structure-of-arrays kernel; 1 thread), for the default architecture and the
  compact one used for whole-manipulator models.

The models are the package's default architectures (``ModelConfig`` defaults: 2 x 32 LSTM, dense
32, wrench dense 16, history 2, node + 2 neighbours, force input) with seeded random weights: the
cost does not depend on the weights' values. Their output layers are zeroed so a free run stays
where it starts (the arithmetic is unchanged). ``--model DIR`` times a trained model instead.

``run_model_benchmark`` returns a JSON-ready dict, ``format_model_table`` renders it; neither prints.
"""

from __future__ import annotations

import tempfile
import warnings
from pathlib import Path

import numba
import numpy as np

from ..learned.node.artifact import NodeModel
from ..learned.node.data import Normalizer, SampleSpec
from ..learned.node.engine import ManipulatorStepper, NodeStepper
from ..learned.node.manipulator import Manipulator
from ..learned.node.model import ModelConfig, NodeLSTM
from ..learned.threads import torch_threads
from ..progress import Progress, Ticks
from ..timing import step_rate

GOALS = {"node_step_hz_median": 200_000, "speedup_vs_eager_torch": 15, "manipulator_step_hz_median": 20_000}
PAPER = {"rnn_bandwidth_hz": 60.75, "source": "Tariverdi et al. 2021, section 5.3 (Fig. 7 model, i7 laptop)"}
MANIPULATOR_NODES = 101
COMPACT = {"lstm_layers": 1, "lstm_units": 16, "dense_units": (16,), "wrench_dense": (8,)}
"""The compact architecture for whole-manipulator models (one per node): the paper's Fig. 14
bandwidth region (5-15 LSTM units) at the top of its error region's lower edge."""


def synthetic_model(node: int = 1, n_nodes: int = 3, config: dict | None = None, seed: int = 0) -> NodeModel:
    """A model of the default (or ``config``-overridden) architecture with seeded random weights,
    a plausible normalisation (positions of a 0.5 m rod, mm-scale steps, 1 N forces) and a zeroed
    output layer (it predicts 'no motion'; the arithmetic is that of any trained model)."""
    import torch  # optional extra: learn (PyTorch)

    lo, hi = max(0, node - 1), min(n_nodes - 1, node + 1)
    neighbours = tuple(a for a in (node - 1, node + 1) if lo <= a <= hi)
    spec = SampleSpec(node=node, neighbours=neighbours, history=2, inputs="positions", wrench="force")
    P = 3 * (1 + len(neighbours))
    cfg = ModelConfig(pose_features=P, wrench_features=3, history=2, **(config or {}))
    norm = Normalizer(pose_mean=np.full(P, 0.25), pose_std=np.full(P, 0.1), wrench_mean=np.zeros(3),
                      wrench_std=np.ones(3), target_mean=np.zeros(3), target_std=np.full(3, 1e-3),
                      delta_mean=np.zeros(P), delta_std=np.full(P, 1e-3))
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(seed)
        module = NodeLSTM(cfg)
    module.set_normalizer(norm)
    with torch.no_grad():
        module.out.weight.zero_()
        module.out.bias.zero_()
        if module.skip is not None:
            module.skip.weight.zero_()
    module.eval()
    return NodeModel(config=cfg, spec=spec, normalizer=norm, module=module, meta={"synthetic": True})


def _stats(fn, n: int) -> dict:
    """``n`` timed calls of ``fn`` after 200 untimed ones (``timing.step_rate``): ``hz_median`` (the
    median over 5 runs of each run's calls per second), ``median_us`` (1e6 / ``hz_median``),
    ``p99_us`` (99th percentile of the single call times) and ``calls``."""
    r = step_rate(fn, steps=n, warmup=200)
    return {"median_us": r.step_us, "p99_us": r.p99_us, "hz_median": r.median_hz, "calls": r.steps}


def time_node_step(model: NodeModel, n: int) -> dict:
    """The compiled batch-1 stepper on a window of plausible inputs."""
    H, P, W = model.config.history, model.config.pose_features, model.config.wrench_features
    rng = np.random.default_rng(0)
    mean = np.asarray(model.normalizer.pose_mean, np.float32)
    poses = (mean + 1e-3 * rng.standard_normal((H, P))).astype(np.float32)
    wrench = rng.standard_normal((H, W)).astype(np.float32)
    st = NodeStepper(model)
    st.reset(poses, wrench)
    row, wrow = poses[-1].copy(), wrench[-1].copy()
    return _stats(lambda: st.step(row, wrow), n)


def time_eager_torch(model: NodeModel, n: int) -> dict:
    """The same model stepped naively in PyTorch at batch 1 (one thread): the module on ready
    tensors, and ``NodeModel.predict`` with numpy in and out."""
    import torch  # optional extra: learn (PyTorch)

    H, P, W = model.config.history, model.config.pose_features, model.config.wrench_features
    with torch_threads(1):
        z, w = torch.zeros(1, H, P), torch.zeros(1, H, W)
        poses = np.tile(np.asarray(model.normalizer.pose_mean, np.float32), (1, H, 1))
        wr = np.zeros((1, H, W), np.float32)
        with torch.inference_mode():
            module = _stats(lambda: model.module(z, w), n)
        predict = _stats(lambda: model.predict(poses, wr), max(200, n // 2))
    return {"module": module, "predict": predict, "torch_threads": 1}


def time_runtimes(model: NodeModel, n: int) -> dict:
    """The same model exported (``softrnn export``) and run at batch 1 on one thread in ONNX Runtime
    (``session.run`` with numpy inputs) and as TorchScript (``torch.jit.load``, called on ready
    tensors): the alternatives the compiled engine was chosen against. Entries are None where a
    runtime is not installed."""
    import torch  # optional extra: learn (PyTorch)

    from ..learned.node.export import export_onnx, export_torchscript  # optional extra: learn (PyTorch)

    H, W = model.config.history, model.config.wrench_features
    poses = np.tile(np.asarray(model.normalizer.pose_mean, np.float32), (1, H, 1))
    wr = np.zeros((1, H, W), np.float32)
    out = {"onnxruntime": None, "torchscript": None}
    with tempfile.TemporaryDirectory() as tmp:
        try:
            import onnxruntime as ort  # optional extra: learn (ONNX Runtime)
        except ImportError:
            ort = None
        if ort is not None:
            path = export_onnx(model, Path(tmp) / "m.onnx")
            opts = ort.SessionOptions()
            opts.intra_op_num_threads = 1
            opts.inter_op_num_threads = 1
            sess = ort.InferenceSession(str(path), opts, providers=["CPUExecutionProvider"])
            feed = {i.name: (poses if i.name.startswith("pose") else wr) for i in sess.get_inputs()}
            out["onnxruntime"] = _stats(lambda: sess.run(None, feed), n)
        old = torch.get_num_threads()
        torch.set_num_threads(1)
        try:
            path = export_torchscript(model, Path(tmp) / "m.pt")
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                ts = torch.jit.load(str(path))
            args = (torch.from_numpy(poses),) + ((torch.from_numpy(wr),) if W else ())
            with torch.inference_mode():
                out["torchscript"] = _stats(lambda: ts(*args), n)
        finally:
            torch.set_num_threads(old)
    return out


def time_manipulator(config: dict | None, threads: int, n: int, n_nodes: int = MANIPULATOR_NODES,
                     shared: bool = False) -> dict:
    """``ManipulatorStepper.step`` for a straight ``n_nodes`` rod, every node modelled: each node by
    its own model, or (``shared``) the interior nodes by one model and the two ends by their own."""

    if shared:
        models = Manipulator.of([synthetic_model(0, n_nodes, config), synthetic_model(n_nodes - 1, n_nodes, config)],
                                shared=synthetic_model(1, n_nodes, config), shared_nodes=range(1, n_nodes - 1))
    else:
        models = [synthetic_model(a, n_nodes, config, seed=a) for a in range(n_nodes)]
    old = numba.get_num_threads()
    numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
    try:
        st = ManipulatorStepper(models, np.arange(n_nodes), threads=threads)
        x = np.zeros((2, n_nodes, 3), np.float32)
        x[:, :, 0] = np.linspace(0.0, 0.5, n_nodes)
        st.reset(x, np.zeros((2, n_nodes, 3), np.float32))
        w = np.zeros((n_nodes, 3), np.float32)
        out = _stats(lambda: st.step(w), n)
        out["threads"] = int(numba.get_num_threads()) if threads > 1 else 1
    finally:
        numba.set_num_threads(old)
    out["nodes"] = n_nodes
    out["us_per_node"] = out["median_us"] / n_nodes
    return out


def manipulator_cases() -> list:
    """The ``time_manipulator`` cases of ``run_model_benchmark``: (architecture name, config or None,
    threads, shared), on one thread and, where numba has more, on all of them."""
    all_threads = max(1, numba.config.NUMBA_NUM_THREADS)
    cases = [("default", None, 1, False), ("compact", COMPACT, 1, False)]
    if all_threads > 1:
        cases += [("compact", COMPACT, all_threads, False), ("default", None, all_threads, False)]
    cases += [("default", None, 1, True), ("compact", COMPACT, 1, True)]
    if all_threads > 1:
        cases += [("compact", COMPACT, all_threads, True), ("default", None, all_threads, True)]
    return cases


WARM_NODES = 8
"""The nodes of ``warm_manipulator``'s rods, at least: the kernels are those of any node count, and a short
rod's models are quick to build (the parallel ones need two modelled nodes per thread: more on more threads)."""


def warm_manipulator() -> None:
    """Compile (or load from numba's cache) the kernels of every ``manipulator_cases`` entry, untimed (a
    few steps each, on a rod of ``WARM_NODES``): cold, about 12 s of the model benchmark on a 2-core
    machine, which ``softrnn reproduce`` spends in a background process while a core is idle
    (``reproduce.benchmark.warm_start``)."""
    for _, config, threads, shared in manipulator_cases():
        time_manipulator(config, threads, 1, n_nodes=max(WARM_NODES, 2 * threads + 2), shared=shared)


def _arch(model: NodeModel) -> dict:
    c = model.config
    return {"lstm_layers": c.lstm_layers, "lstm_units": c.lstm_units, "dense_units": list(c.dense_units),
            "wrench_dense": list(c.wrench_dense), "history": c.history, "pose_features": c.pose_features,
            "wrench_features": c.wrench_features}


def run_model_benchmark(quick: bool = False, model: NodeModel | None = None, progress: Progress | None = None) -> dict:
    """All model measurements as a JSON-ready dict (``quick``: shorter runs).

    ``model``: time this trained model for the node step (default: ``synthetic_model()``).
    ``progress(done, total)`` after each item.
    """
    n_node, n_torch, n_manip = (5000, 1000, 500) if quick else (30000, 3000, 2000)
    node_model = model if model is not None else synthetic_model()
    items = [("node", None), ("torch", None)]
    manip_cases = manipulator_cases()
    total = len(items) + len(manip_cases)
    tick = Ticks(progress, total)

    node = time_node_step(node_model, n_node)
    tick()
    torch_ = time_eager_torch(node_model, n_torch)
    runtimes = time_runtimes(node_model, n_torch)
    tick()
    manip = []
    for name, cfg, threads, shared in manip_cases:
        m = time_manipulator(cfg, threads, n_manip, shared=shared)
        m.update(architecture=name, shared=shared,
                 **{"lstm_layers": (cfg or {}).get("lstm_layers", ModelConfig.lstm_layers),
                    "lstm_units": (cfg or {}).get("lstm_units", ModelConfig.lstm_units)})
        manip.append(m)
        tick()
    best = max(manip, key=lambda m: m["hz_median"])
    default_1 = manip[0]
    eager_hz = torch_["module"]["hz_median"]
    result = {
        "node_step_hz_median": node["hz_median"],
        "node_step_p99_us": node["p99_us"],
        "node_step_median_us": node["median_us"],
        "eager_torch_node_step_hz_median": eager_hz,
        "eager_torch_predict_hz_median": torch_["predict"]["hz_median"],
        "onnxruntime_node_step_hz_median": (runtimes["onnxruntime"] or {}).get("hz_median"),
        "torchscript_node_step_hz_median": (runtimes["torchscript"] or {}).get("hz_median"),
        "speedup_vs_eager_torch": node["hz_median"] / eager_hz,
        "manipulator_step_hz_median": best["hz_median"],
        "manipulator_nodes": MANIPULATOR_NODES,
        "manipulator_architecture": best["architecture"],
        "manipulator_threads": best["threads"],
        "manipulator_shared_model": best["shared"],
        "manipulator_default_1thread_hz_median": default_1["hz_median"],
        "manipulator_cases": manip,
        "node_model": {"trained": model is not None, **_arch(node_model)},
        "compact_architecture": {k: list(v) if isinstance(v, tuple) else v for k, v in COMPACT.items()},
        "details": {"node_step": node, "eager_torch": torch_, "runtimes": runtimes},
        "goals": dict(GOALS),
        "paper": dict(PAPER),
    }
    result["goals_met"] = {
        "node_step_hz_median": result["node_step_hz_median"] >= GOALS["node_step_hz_median"],
        "speedup_vs_eager_torch": result["speedup_vs_eager_torch"] >= GOALS["speedup_vs_eager_torch"],
        "manipulator_step_hz_median": result["manipulator_step_hz_median"] >= GOALS["manipulator_step_hz_median"],
    }
    return result


def format_model_table(r: dict) -> str:
    """A short text table of ``run_model_benchmark``'s result."""
    ok = {True: "met", False: "NOT met"}
    g = r["goals_met"]
    arch = r["node_model"]
    rows = [
        f"learned model ({arch['lstm_layers']} x {arch['lstm_units']} LSTM, history {arch['history']}, "
        f"{'trained' if arch['trained'] else 'random weights'}), batch 1, one thread",
        f"  compiled node step: {r['node_step_hz_median']:,.0f} Hz median ({r['node_step_median_us']:.2f} us, "
        f"p99 {r['node_step_p99_us']:.2f} us); goal >= {GOALS['node_step_hz_median']:,}: "
        f"{ok[g['node_step_hz_median']]}",
        f"  eager PyTorch, same model: {r['eager_torch_node_step_hz_median']:,.0f} Hz (module), "
        f"{r['eager_torch_predict_hz_median']:,.0f} Hz (NodeModel.predict); speed-up "
        f"{r['speedup_vs_eager_torch']:.0f}x, goal >= {GOALS['speedup_vs_eager_torch']}x: "
        f"{ok[g['speedup_vs_eager_torch']]}",
        "  the same model exported, one thread: " + ", ".join(
            f"{name} {r[key]:,.0f} Hz" for name, key in (("ONNX Runtime", "onnxruntime_node_step_hz_median"),
                                                         ("TorchScript", "torchscript_node_step_hz_median"))
            if r.get(key)),
        f"  whole manipulator, {r['manipulator_nodes']} nodes, every node modelled:",
    ]
    for m in r["manipulator_cases"]:
        how = "one model shared by the interior nodes" if m.get("shared") else "one model per node"
        rows.append(f"    {m['architecture']:8s} ({m['lstm_layers']} x {m['lstm_units']}), {how}, "
                    f"{m['threads']} thread(s): "
                    f"{m['hz_median']:,.0f} Hz ({m['median_us']:.1f} us/step, {m['us_per_node']:.2f} us/node, "
                    f"p99 {m['p99_us']:.0f} us)")
    rows.append(f"  best: {r['manipulator_step_hz_median']:,.0f} Hz; goal >= {GOALS['manipulator_step_hz_median']:,}: "
                f"{ok[g['manipulator_step_hz_median']]}")
    rows.append(f"  paper: {PAPER['rnn_bandwidth_hz']} Hz per prediction ({PAPER['source']})")
    return "\n".join(rows)
