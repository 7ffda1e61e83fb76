"""Steps of ``softrnn reproduce`` beyond the node models: the inference engine's agreement with
PyTorch, the whole manipulator with one shared model (paper Fig. 2C), the static solver's Fig. 13
study, the Fig. 14 hyper-parameter study and the magnetic experiment (Table 1).

Each step writes its results under the output folder and a step file ``<name>.json`` recording the
settings (quick or full, softrnn version); a rerun skips a finished step. Nothing here prints.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from .. import __version__
from ..files import atomic_write_text

MANIPULATOR = {
    "case": "semicircle",
    "pool": (2, 98),            # interior nodes sharing the model (inclusive); 0, 1, 99, 100 follow the data
    "neighbours": (-2, -1, 1, 2),
    "architecture": {"lstm_layers": 1, "lstm_units": 16, "dense_units": (16,), "wrench_dense": (8,),
                     "relative": True},
    "train": {"epochs": 15, "rollout_steps": 1, "input_noise": 0.5},
    "quick_train": {"epochs": 3, "rollout_steps": 1, "input_noise": 0.5, "max_train_windows": 3000},
    "horizons_s": (0.001, 0.01, 0.1),
}
"""The whole-manipulator model (beyond the paper): one compact LSTM shared by the interior nodes.
Two neighbours on each side: the bending moments that move a node depend on the curvature at its
neighbours, which needs the nodes two away. Relative inputs make the model independent of where a
node sits; input noise (offsets of the node's own history) teaches it to pull a drifted node back."""


def load_step(path: Path, quick: bool):
    """The step file's dict if it was written by this version with the same ``quick``, else None."""
    if not path.exists():
        return None
    try:
        done = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    return done if done.get("quick") == quick and done.get("softrnn_version") == __version__ else None


def save_step(path: Path, result: dict, quick: bool) -> dict:
    result = {"quick": quick, "softrnn_version": __version__, **result}
    atomic_write_text(path, json.dumps(result, indent=2, default=_jsonable))
    return result


def _jsonable(x):
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, (np.floating, np.integer)):
        return x.item()
    return str(x)


# ------------------------------------------------------------------------------ engine vs PyTorch
def engine_agreement(model, data_path, start: int, stop: int) -> dict:
    """The free-running rollout of ``model`` over [start, stop) by the compiled engine and by
    PyTorch (``predict`` per step): the largest position difference [m] and both wall times."""
    from ..io.dataset import read_dataset
    from ..surrogate.rollout import RolloutDiverged, rollout

    ds = read_dataset(data_path, nodes=list(model.spec.window_nodes))
    out = {"steps": int(stop - start)}
    try:
        t = time.perf_counter()
        fast = rollout(model, ds, start, stop)
        out["engine_s"] = time.perf_counter() - t
        t = time.perf_counter()
        slow = rollout(model, ds, start, stop, engine=False)
        out["pytorch_s"] = time.perf_counter() - t
    except RolloutDiverged as err:
        return {**out, "diverged": str(err)}
    out["max_abs_difference_m"] = float(np.abs(fast.positions.astype(np.float64) - slow.positions).max())
    return out


# ------------------------------------------------------------------------------ whole manipulator
def manipulator_step(out: Path, quick: bool, progress_factory=None) -> dict:
    """Train the shared whole-manipulator model on the semicircle's training span and run every
    interior node free on the test span (paper Fig. 2C); errors by horizon, speed."""
    from ..io.dataset import read_dataset
    from ..surrogate.data import SampleSpec
    from ..surrogate.engine import ManipulatorStepper
    from ..surrogate.evaluate import metrics
    from ..surrogate.rollout import Manipulator, RolloutDiverged, rollout
    from ..surrogate.train import TrainConfig, train_node_model

    step_file = out / "models" / "manipulator.json"
    done = load_step(step_file, quick)
    if done is not None:
        return done
    cfg = MANIPULATOR
    data_path = out / "data" / f"{cfg['case']}.h5"
    ds = read_dataset(data_path)
    n = int(ds.nodes.size)
    pool = tuple(range(cfg["pool"][0], min(cfg["pool"][1], n - 3) + 1))
    ref_node = pool[len(pool) // 2]
    spec = SampleSpec(node=ref_node, neighbours=tuple(ref_node + o for o in cfg["neighbours"]), wrench="force")
    train = TrainConfig(**(cfg["quick_train"] if quick else cfg["train"]))
    folder = out / "models" / "manipulator"
    progress = progress_factory("train shared model") if progress_factory else None
    bar = None if progress is None else (lambda d, t, info=None: progress(d, t))
    t0 = time.perf_counter()
    model = train_node_model(ds, spec, dict(cfg["architecture"]), train, folder, resume=True, progress=bar,
                             pool=pool)
    train_s = time.perf_counter() - t0
    manip = Manipulator.of([], shared=model, shared_nodes=pool)
    start = int(model.meta["test_span"][0])
    stop = ds.n_samples
    result = {"case": cfg["case"], "pool": [pool[0], pool[-1]], "modelled_nodes": len(pool),
              "unmodelled": "nodes 0, 1 and the last two follow the data (clamps and their neighbours)",
              "neighbour_offsets": list(cfg["neighbours"]), "architecture": {
                  k: list(v) if isinstance(v, tuple) else v for k, v in cfg["architecture"].items()},
              "train": {"windows": model.meta["train_windows"], "seconds": train_s,
                        "best_validation_loss": model.meta["best_validation_loss"],
                        **{k: v for k, v in (cfg["quick_train"] if quick else cfg["train"]).items()}},
              "test_span_s": [float(ds.time[start]), float(ds.time[stop - 1])], "node": ref_node}
    t = time.perf_counter()
    try:
        r = rollout(manip, ds, start=start, stop=stop)
        result["rollout_s"] = time.perf_counter() - t
    except RolloutDiverged as err:
        result["diverged"] = str(err)
        return save_step(step_file, result, quick)
    length = float(ds.attrs["rod"]["length"])
    pred = r.positions[r.seed:].astype(np.float64)                       # (T', N, 3)
    ref = np.asarray(ds.positions[start:stop], np.float64)               # (T', N, 3)
    cols = [int(np.flatnonzero(ds.nodes == a)[0]) for a in pool]
    j = int(np.flatnonzero(ds.nodes == ref_node)[0])
    dt = float(ds.dt)
    horizons = {}
    for h in (*cfg["horizons_s"], None):
        k = pred.shape[0] if h is None else max(1, min(pred.shape[0], int(round(h / dt))))
        m = metrics(pred[:k, j], ref[:k, j], length)
        all_nodes = np.abs(pred[:k, cols] - ref[:k, cols]).max(axis=(0, 1)) * 1e3
        horizons["test_span" if h is None else f"{h:g}s"] = {
            "steps": k, "node_max_abs_mm": m.max_abs_mm.tolist(), "node_mean_abs_mm": m.mean_abs_mm.tolist(),
            "node_max_pct_of_length": m.max_pct_of_length.tolist(), "all_nodes_max_abs_mm": all_nodes.tolist()}
    hold = np.abs(ref[:, j] - ref[0:1, j]).max(axis=0) * 1e3
    result["errors"] = horizons
    result["hold_baseline_node_max_abs_mm"] = hold.tolist()
    # speed of the trained manipulator in a control loop: one ManipulatorStepper.step per sample
    import numba

    result["stepper"] = []
    for threads in sorted({1, numba.config.NUMBA_NUM_THREADS}):
        st = ManipulatorStepper(manip, ds.nodes, threads=threads)
        wcols = [int(np.flatnonzero(ds.nodes == a)[0]) for a in st.modelled]
        f = np.asarray(ds.forces[start - 2:start + 2000], np.float32)[:, wcols]
        st.reset(ds.positions[start - 2:start], f[:2])
        times = []
        for k in range(2, f.shape[0]):
            t = time.perf_counter_ns()
            st.step(f[k])
            times.append(time.perf_counter_ns() - t)
        if not times:
            continue
        med = float(np.median(times[min(100, len(times) // 2):])) * 1e-3   # after a warm-up
        result["stepper"].append({"median_us": med, "hz_median": 1e6 / med, "modelled_nodes": len(st.modelled),
                                  "threads": threads})
    return save_step(step_file, result, quick)


# ------------------------------------------------------------------------------ static solver, Fig. 13
def fig13_step(out: Path, quick: bool) -> dict:
    """The static solver's solve time against tolerance, node count and guess error (Fig. 13)."""
    from ..experiments.fig13 import run_fig13_study, write_fig13

    step_file = out / "statics" / "fig13-step.json"
    done = load_step(step_file, quick)
    if done is not None:
        return done
    (out / "statics").mkdir(parents=True, exist_ok=True)
    result = run_fig13_study(repetitions=10) if quick else run_fig13_study()
    write_fig13(result, out / "statics" / "fig13.json", out / "figures" / "fig13.png")
    return save_step(step_file, {"json": "statics/fig13.json", "figure": "fig13.png", "summary": _fig13_summary(result)},
                     quick)


def _fig13_summary(result: dict) -> dict:
    keep = ("repetitions", "paper", "guess_errors", "tolerance_sweep", "node_sweep", "load_case")
    return {k: result[k] for k in keep if k in result}


# ------------------------------------------------------------------------------ Fig. 14 study
FIG14 = {"case": "semicircle", "units": (5, 10, 15, 20, 25), "history": (2, 5, 10, 20), "epochs": 10,
         "quick_units": (5, 20), "quick_history": (2, 10), "quick_epochs": 2}


def fig14_step(out: Path, quick: bool, progress_factory=None) -> dict:
    """The paper's Fig. 14 (LSTM units x history: bandwidth and RMS error) on the semicircle's node
    of interest, two Dask workers; a rerun completes only missing grid points."""
    from ..scenarios.cases import build_case
    from ..surrogate.study import StudyConfig, run_study

    step_file = out / "study" / "fig14-step.json"
    done = load_step(step_file, quick)
    if done is not None:
        return done
    case = build_case(FIG14["case"])
    config = StudyConfig(node=case.node_of_interest, units=FIG14["quick_units" if quick else "units"],
                         history=FIG14["quick_history" if quick else "history"],
                         epochs=FIG14["quick_epochs" if quick else "epochs"])
    progress = progress_factory("Fig. 14 study") if progress_factory else None
    folder = out / "study" / ("fig14-quick" if quick else "fig14")
    result = run_study(out / "data" / f"{FIG14['case']}.h5", config, folder, workers=2, progress=progress)
    figure = out / "figures" / "fig14.png"
    figure.parent.mkdir(parents=True, exist_ok=True)
    figure.write_bytes(Path(result["figure"]).read_bytes())
    keep = ("units", "history", "bandwidth_hz", "torch_bandwidth_hz", "rmse_mm", "regions", "trends", "paper",
            "wall_seconds")
    return save_step(step_file, {"case": FIG14["case"], "node": case.node_of_interest, "figure": "fig14.png",
                                 "folder": str(folder.relative_to(out)), **{k: result[k] for k in keep}}, quick)


# ------------------------------------------------------------------------------ magnetic experiment
def magnetic_step(out: Path, quick: bool, progress_factory=None) -> dict:
    """The paper's experiment (section 5) simulated: Table 1 and Fig. 12 (``softrnn.experiments.magnetic.experiment``)."""
    from ..experiments.magnetic.experiment import ExperimentConfig, run_experiment

    step_file = out / "magnetic" / "step.json"
    done = load_step(step_file, quick)
    if done is not None:
        return done
    bar = progress_factory("magnetic experiment") if progress_factory else None
    progress = None if bar is None else (lambda stage, done, total: bar(done, total))
    result = run_experiment(ExperimentConfig(quick=quick), out / "magnetic", progress=progress)
    fig = out / "magnetic" / "fig12.png"
    if fig.exists():
        (out / "figures").mkdir(parents=True, exist_ok=True)
        (out / "figures" / "fig12.png").write_bytes(fig.read_bytes())
    return save_step(step_file, result, quick)
