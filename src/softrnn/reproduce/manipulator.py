"""Reproduce step: the whole manipulator with one shared model (paper Fig. 2C, beyond the paper),
trained on the semicircle's training span, every interior node run free on the test span; errors by
horizon and the speed of one ``ManipulatorStepper`` step."""

from __future__ import annotations

import time
from functools import partial
from pathlib import Path

import numba
import numpy as np

from ..errors import SoftrnnInputError
from ..io.reader import read_dataset
from ..learned.baselines import ConstantVelocity, LinearAR, LinearARConfig, Persistence, free_run
from ..learned.horizons import WHOLE_HORIZONS, RolloutDiverged
from ..learned.node.data import SampleSpec
from ..learned.node.engine import ManipulatorStepper
from ..learned.node.evaluate import horizon_misses, horizon_table, metrics
from ..learned.node.manipulator import Manipulator
from ..learned.node.rollout import rollout
from ..timing import step_rate
from .stepfiles import load_step, save_step

MANIPULATOR = {
    "case": "semicircle",
    "pool": (2, 98),            # interior nodes sharing the model (inclusive); 0, 1, 99, 100 follow the data
    "neighbours": (-2, -1, 1, 2),
    "architecture": {"lstm_layers": 1, "lstm_units": 16, "dense_units": (16,), "wrench_dense": (8,),
                     "relative": True},
    "train": {"epochs": 15, "rollout_steps": 1, "input_noise": 0.5},
    "quick_train": {"epochs": 3, "rollout_steps": 1, "input_noise": 0.5, "max_train_windows": 3000},
    "horizons_s": (0.001, 0.01, 0.1),
    "baseline_horizons": WHOLE_HORIZONS,      # samples: 10, 100, 1000
    "horizon_starts": 5,
    "quick_horizon_starts": 2,
}
"""The whole-manipulator model (beyond the paper): one compact LSTM shared by the interior nodes.
Two neighbours on each side: the bending moments that move a node depend on the curvature at its
neighbours, which needs the nodes two away. Relative inputs make the model independent of where a
node sits; input noise (offsets of the node's own history) teaches it to pull a drifted node back."""


def _train_shared(ds, out: Path, quick: bool, progress_factory):
    """The shared model trained (or resumed) on the pooled interior nodes of ``ds``: (model, pool,
    the reference node in the middle of the pool, training seconds)."""
    from ..learned.node.train import TrainConfig, train_node_model  # optional extra: learn (PyTorch)

    cfg = MANIPULATOR
    n = int(ds.nodes.size)
    pool = tuple(range(cfg["pool"][0], min(cfg["pool"][1], n - 3) + 1))
    ref_node = pool[len(pool) // 2]
    spec = SampleSpec(node=ref_node, neighbours=tuple(ref_node + o for o in cfg["neighbours"]), wrench="force")
    train = TrainConfig(**(cfg["quick_train"] if quick else cfg["train"]))
    folder = out / "models" / "manipulator"
    progress = progress_factory("train shared model") if progress_factory else None
    bar = progress
    t0 = time.perf_counter()
    model = train_node_model(ds, spec, dict(cfg["architecture"]), train, folder, resume=True, progress=bar,
                             pool=pool)
    return model, pool, ref_node, time.perf_counter() - t0


def _describe(model, ds, pool: tuple, ref_node: int, train_s: float, quick: bool, start: int, stop: int) -> dict:
    """The step's settings: the pool, the architecture, the training and the test span."""
    cfg = MANIPULATOR
    return {"case": cfg["case"], "pool": [pool[0], pool[-1]], "modelled_nodes": len(pool),
            "unmodelled": "nodes 0, 1 and the last two follow the data (clamps and their neighbours)",
            "neighbour_offsets": list(cfg["neighbours"]), "architecture": {
                k: list(v) if isinstance(v, tuple) else v for k, v in cfg["architecture"].items()},
            "train": {"windows": model.meta["train_windows"], "seconds": train_s,
                      "best_validation_loss": model.meta["best_validation_loss"],
                      **{k: v for k, v in (cfg["quick_train"] if quick else cfg["train"]).items()}},
            "test_span_s": [float(ds.time[start]), float(ds.time[stop - 1])], "node": ref_node}


def _horizon_errors(r, ds, pool: tuple, ref_node: int, start: int, stop: int) -> tuple[dict, list]:
    """Errors of the free run ``r`` by horizon (the reference node's and all modelled nodes' in mm),
    and the error of holding the reference node at its first test position (mm per axis)."""
    length = float(ds.attrs["rod"]["length"])
    pred = r.positions[r.seed:].astype(np.float64)                       # (T', N, 3)
    ref = np.asarray(ds.positions[start:stop], np.float64)               # (T', N, 3)
    cols = [int(np.flatnonzero(ds.nodes == a)[0]) for a in pool]
    j = int(np.flatnonzero(ds.nodes == ref_node)[0])
    dt = float(ds.dt)
    horizons = {}
    for h in (*MANIPULATOR["horizons_s"], None):
        k = pred.shape[0] if h is None else max(1, min(pred.shape[0], int(round(h / dt))))
        m = metrics(pred[:k, j], ref[:k, j], length)
        all_nodes = np.abs(pred[:k, cols] - ref[:k, cols]).max(axis=(0, 1)) * 1e3
        horizons["test_span" if h is None else f"{h:g}s"] = {
            "steps": k, "node_max_abs_mm": m.max_abs_mm.tolist(), "node_mean_abs_mm": m.mean_abs_mm.tolist(),
            "node_max_pct_of_length": m.max_pct_of_length.tolist(), "all_nodes_max_abs_mm": all_nodes.tolist()}
    hold = np.abs(ref[:, j] - ref[0:1, j]).max(axis=0) * 1e3
    return horizons, hold.tolist()


def _fit_baselines(model, P, Wr, pool_cols: list, cut: int) -> tuple[dict, dict]:
    """The baselines of the whole manipulator: persistence, constant velocity and the linear AR
    models (``"node"``: one per modelled node with the shared model's neighbours; ``"manipulator"``:
    one of every node), fitted on the training span [0, cut); ({name: baseline}, {name: {skipped:
    reason, ...} or the linear models' fit details})."""
    ready = {"persistence": Persistence(), "constant_velocity": ConstantVelocity()}
    details = {}
    for name, mode in (("linear_node", "node"), ("linear_manipulator", "manipulator")):
        config = LinearARConfig(history=int(model.spec.history), mode=mode, neighbours=MANIPULATOR["neighbours"])
        info = {"fitted_on": {"samples": [0, cut], "what": f"the training span (samples 0..{cut - 1})"}}
        try:
            ready[name] = LinearAR.fit(config, P, Wr, 0, cut, modelled=pool_cols)
            details[name] = dict(info, fit=ready[name].summary())
        except SoftrnnInputError as err:
            details[name] = dict(info, skipped=str(err))
    return ready, details


def _span_errors(pred, ref, cols: list, length: float) -> dict:
    """Errors of a whole-manipulator free run over the modelled columns: max_abs_mm [x, y, z] (the
    largest over the nodes and samples), max_pct_of_length (the largest axis) and rmse_mm."""
    err_mm = (pred[:, cols] - ref[:, cols]) * 1e3                          # (T', n, 3)
    max_abs = np.abs(err_mm).max(axis=(0, 1))
    with np.errstate(under="ignore"):
        rmse = float(np.sqrt(np.mean(err_mm ** 2)))
    return {"max_abs_mm": max_abs.tolist(), "max_pct_of_length": float(max_abs.max() / (length * 1e3) * 100.0),
            "rmse_mm": rmse}


def _model_run(manip, ds, positions, wrenches, start: int, stop: int) -> np.ndarray:
    """The shared model's whole-manipulator free run as a ``horizon_table`` predictor: (T', N, 3) [m]."""
    r = rollout(manip, ds, start=start, stop=stop)
    return r.positions[r.seed:].astype(np.float64)


def compare_baselines(manip, model, ds, r, pool: tuple, start: int, stop: int, quick: bool) -> dict:
    """The shared model's free run beside the baselines, all run free over the test span from the
    same seed (``baselines.free_run``; the unmodelled nodes follow the data).

    Parameters
    ----------
    manip : Manipulator
        The shared model over ``pool``.
    model : NodeModel
        The shared model: its ``spec.history``, and ``meta['test_span']`` (the linear models are
        fitted on the samples before it).
    ds : Dataset
        The whole record, every node stored (positions (T, N, 3) [m], forces (T, N, 3) [N]).
    r : Rollout or None
        The model's free run over [start, stop) (None: it diverged).
    pool : tuple of int
        The modelled nodes.
    start, stop : int
        The test span's predicted samples.
    quick : bool
        Fewer starts per horizon (``quick_horizon_starts``).

    Returns
    -------
    dict
        {baselines: {name: {test_span: errors, or {diverged, node, sample, time_s}} or {skipped},
        model_test_span, horizons: ``evaluate.horizon_table`` at ``baseline_horizons`` plus
        ``test_span`` (% of length, the largest over the modelled nodes), misses, baselines_s}.
    """
    t0 = time.perf_counter()
    cfg, length = MANIPULATOR, float(ds.attrs["rod"]["length"])
    P = np.asarray(ds.positions, dtype=np.float64)                          # (T, N, 3)
    Wr = np.asarray(ds.forces, dtype=np.float64)                            # the shared model's wrench input
    cols = [int(np.flatnonzero(ds.nodes == a)[0]) for a in pool]
    ready, out = _fit_baselines(model, P, Wr, cols, int(model.meta["test_span"][0]))
    whole = {"model": {"diverged": True} if r is None
             else _span_errors(r.positions[r.seed:], P[start:stop], cols, length)}
    for name, b in ready.items():
        try:
            whole[name] = _span_errors(free_run(b, P, Wr, start, stop, modelled=cols), P[start:stop], cols, length)
        except RolloutDiverged as exc:
            whole[name] = {"diverged": True, "node": int(ds.nodes[exc.node]), "sample": exc.sample,
                           "time_s": float(ds.time[exc.sample])}
        out[name] = dict(out.get(name, {}), test_span=whole[name])
    runs = {"model": partial(_model_run, manip, ds)}
    runs.update({k: partial(free_run, b, modelled=cols) for k, b in ready.items()})
    n = cfg["quick_horizon_starts"] if quick else cfg["horizon_starts"]
    table = horizon_table(runs, P, Wr, start, stop, cfg["baseline_horizons"], n_starts=n, nodes=cols,
                          length=length).to_dict()
    table["test_span"] = {k: v.get("max_pct_of_length", "diverged") for k, v in whole.items()}
    return {"baselines": out, "model_test_span": whole["model"], "horizons": table, "misses": horizon_misses(table),
            "baselines_s": time.perf_counter() - t0}


def _stepper_speed(manip, ds, start: int) -> list[dict]:
    """The speed of the trained manipulator in a control loop: one ``ManipulatorStepper.step`` per
    sample (the recorded forces in turn), timed by ``softrnn.timing.step_rate``, on one thread and
    on numba's thread count."""
    speeds = []
    for threads in sorted({1, numba.config.NUMBA_NUM_THREADS}):
        st = ManipulatorStepper(manip, ds.nodes, threads=threads)
        wcols = [int(np.flatnonzero(ds.nodes == a)[0]) for a in st.modelled]
        f = np.asarray(ds.forces[start - 2:start + 2000], np.float32)[:, wcols]
        n = f.shape[0] - 2
        if n < 10:
            continue
        st.reset(ds.positions[start - 2:start], f[:2])
        rows = iter(range(2, f.shape[0]))         # each recorded sample once: warm-up and timed steps
        warmup = min(100, n // 2)
        try:
            rate = step_rate(lambda st=st, f=f, rows=rows: st.step(f[next(rows)]), steps=n - warmup, warmup=warmup)
        except RolloutDiverged as err:   # a speed check must not stop the report: say so instead
            speeds.append({"diverged": str(err), "modelled_nodes": len(st.modelled), "threads": threads})
            continue
        speeds.append({"median_us": rate.step_us, "hz_median": rate.median_hz, "p99_us": rate.p99_us,
                       "modelled_nodes": len(st.modelled), "threads": threads})
    return speeds


def manipulator_step(out: Path, quick: bool, progress_factory=None) -> dict:
    """Train the shared whole-manipulator model on the semicircle's training span and run every
    interior node free on the test span (paper Fig. 2C); errors by horizon, speed."""
    step_file = out / "models" / "manipulator.json"
    done = load_step(step_file, quick)
    if done is not None:
        return done
    ds = read_dataset(out / "data" / f"{MANIPULATOR['case']}.h5")
    model, pool, ref_node, train_s = _train_shared(ds, out, quick, progress_factory)
    manip = Manipulator.of([], shared=model, shared_nodes=pool)
    start = int(model.meta["test_span"][0])
    stop = ds.n_samples
    result = _describe(model, ds, pool, ref_node, train_s, quick, start, stop)
    t = time.perf_counter()
    try:
        r = rollout(manip, ds, start=start, stop=stop)
        result["rollout_s"] = time.perf_counter() - t
    except RolloutDiverged as err:
        r = None
        result["diverged"] = str(err)
    result.update(compare_baselines(manip, model, ds, r, pool, start, stop, quick))   # a diverged model beside them too
    if r is None:
        return save_step(step_file, result, quick)
    result["errors"], result["hold_baseline_node_max_abs_mm"] = _horizon_errors(r, ds, pool, ref_node, start, stop)
    result["stepper"] = _stepper_speed(manip, ds, start)
    return save_step(step_file, result, quick)
