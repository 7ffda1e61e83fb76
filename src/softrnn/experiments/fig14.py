"""The paper's Fig. 14 hyper-parameter study: bandwidth and RMS error over LSTM units x history size.

Every grid point (LSTM units U, history H) trains one node model on the same data set with the same
settings (``train_node_model``), evaluates its one-step-ahead RMS error on the test span
(``learned.node.evaluate.one_step`` and ``metrics``, in mm, per axis and overall) and measures its
computation bandwidth: the rate [Hz] of ``NodeStepper.step(pose_row, wrench_row)`` calls (the
compiled batch-1 engine a control loop would use), and for reference the rate of the eager PyTorch
call ``NodeModel.predict`` at batch 1, both timed by ``softrnn.timing.step_rate`` (the median
over 5 runs of each run's mean rate) (what the paper's own bandwidths, about 60 Hz
with Keras, measure).

Where the work runs:

* training and evaluation of the grid points run in parallel on Dask: a ``distributed.LocalCluster``
  of single-threaded worker processes by default, an existing cluster given by its scheduler
  address (the workers need softrnn and the data and output folders at the same paths), or with
  ``scheduler="synchronous"`` in this process, one point after the other (no Dask);
* the bandwidths are measured **afterwards, serially, in the calling process**, one model at a time
  on a single thread, so that no timing competes with a training running on another worker (the
  timings are comparable between grid points; they still depend on the machine's other load).

The output folder:

=========================== ======================================================================
``study.json``              the manifest: the study's settings and the data file's SHA-256
``models/uUU-hHH/``         the model folder of each grid point (``artifact.save_model``)
``point-uUU-hHH.json``      each point's training record, errors and (once measured) bandwidths, with
                            the machine they were measured on
``fig14.png``               the two heatmaps (bandwidth [Hz] and RMS error [mm] over U x H)
=========================== ======================================================================

Every file is written atomically, so an interrupted study that is run again only computes what is
missing: the points without a point file are trained (an unfinished training continues from its
per-epoch checkpoint), the points without bandwidths are measured, the rest is read back. The grid
may grow or shrink between runs; any other setting, or another data file, is refused with a
one-line error (use another folder).

The paper's statements (Tariverdi et al. 2021, Front. Robot. AI 8:631303, section 5.3, Figure 14,
"Data-set IV"; the text names only Data-sets I-III in section 4, and this project runs the study on
the semicircle case, section 4.3) are copied in ``PAPER_FIG14`` (``experiments.fig14_config``, with
the study's ``StudyConfig``) and set beside the regions found here in the summary
(``experiments.fig14_summary``).
"""

from __future__ import annotations

import hashlib
import itertools
import json
import signal
import threading
import time
from contextlib import closing, contextmanager
from dataclasses import fields
from pathlib import Path

import numpy as np

from .. import __version__
from ..errors import SoftrnnInputError, bad, is_int
from ..figures.saving import save_figure
from ..files import atomic_write_text, file_sha256
from ..io.reader import read_dataset
from ..learned.node.artifact import load_model
from ..learned.node.data import pose_rows, wrench_rows
from ..learned.node.engine import NodeStepper
from ..learned.node.evaluate import evaluation_span, load_for_model, metrics, one_step, rod_length
from ..learned.node.train import TrainConfig, train_node_model
from ..learned.node.training_data import spans
from ..learned.threads import torch_threads
from ..progress import Progress
from ..resume import REFUSE, Settings, check
from ..sweeps.dask import completed, require
from ..timing import machine_info, step_rate
from .fig14_config import StudyConfig
from .fig14_summary import StudyResult, fig14_figure, summary

MANIFEST = "study.json"
FIGURE = "fig14.png"
MODELS = "models"
FORMAT = "softrnn-fig14-study"
FORMAT_VERSION = 1
SYNCHRONOUS = "synchronous"
"""``scheduler`` value that runs the grid points in the calling process, without Dask."""


# ------------------------------------------------------------------------------------------ files
def point_name(units: int, history: int) -> str:
    """``uUU-hHH`` of a grid point."""
    return f"u{units:02d}-h{history:02d}"


def point_path(out_dir, units: int, history: int) -> Path:
    """The point file of grid point (units, history)."""
    return Path(out_dir) / f"point-{point_name(units, history)}.json"


def model_folder(out_dir, units: int, history: int) -> Path:
    """The model folder of grid point (units, history)."""
    return Path(out_dir) / MODELS / point_name(units, history)


def _write_json(path: Path, value) -> None:
    atomic_write_text(path, json.dumps(value, indent=2, allow_nan=False) + "\n")


def _read_point(path: Path) -> dict | None:
    """A finished point file, or None (absent or unreadable: computed again)."""
    try:
        d = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    return d if isinstance(d, dict) and isinstance(d.get("error"), dict) else None


def _check_manifest(out_dir: Path, config: StudyConfig, data_path: Path) -> dict:
    """Write the manifest, or refuse a folder that holds a study with other settings or data."""
    data = {"path": str(data_path), "sha256": file_sha256(data_path)}
    want = {"format": FORMAT, "format_version": FORMAT_VERSION, "softrnn_version": __version__,
            "config": config.to_dict(), "data": data}
    path = out_dir / MANIFEST
    if path.exists():
        try:
            have = json.loads(path.read_text())
            old = dict(have["config"])
            old_sha = have["data"]["sha256"]
        except (OSError, ValueError, KeyError, TypeError) as err:
            raise bad("-o", str(out_dir), f"a study folder; its {MANIFEST} is unreadable ({err}); remove it or "
                                          f"use another folder") from None
        if have.get("format") != FORMAT:
            raise bad("-o", str(out_dir), f"a study folder; its {MANIFEST} is not a softrnn study's; use another "
                                          f"folder")
        check({"sha256": old_sha}, Settings.of({"sha256": data["sha256"]}), otherwise=REFUSE, refuse=lambda _: bad(
            "-o", str(out_dir), f"a folder for this study, but it holds a study of another data file "
                                f"({have['data'].get('path')}); use another folder"))
        check(old, config.settings(), otherwise=REFUSE, refuse=lambda why: bad(
            "-o", str(out_dir), f"a folder for this study, but it holds a study with other settings ({why}); use "
                                f"another folder (only the units and history grids may change)"))
    out_dir.mkdir(parents=True, exist_ok=True)
    _write_json(path, want)
    return data


def _remove_stale_temporaries(out_dir: Path) -> None:
    for p in out_dir.glob(".point-*.tmp*"):
        p.unlink(missing_ok=True)


# ------------------------------------------------------------------------------------------ a point
def train_point(data_path: str, config_dict: dict, units: int, history: int, out_dir: str) -> dict:
    """Train and evaluate grid point (units, history) and write its point file (bandwidths not yet
    measured). Runs on a Dask worker or in the calling process; returns the point record.

    ``config_dict`` is ``StudyConfig.to_dict()`` (plain data, so the call pickles cheaply). An
    unfinished training in the point's model folder continues from its checkpoint.
    """

    config = _config_from_dict(config_dict)
    folder = model_folder(out_dir, units, history)
    t0 = time.perf_counter()
    model = train_node_model(data_path, config.spec(history), {"lstm_units": units}, config.train, folder,
                             resume=True)
    dataset = load_for_model(model, data_path)
    pred = one_step(model, dataset)                                            # test span, reference history
    err = metrics(pred.predicted, pred.reference, rod_length(model, dataset))
    with np.errstate(under="ignore"):
        axis_mm = np.sqrt(np.mean(((pred.predicted - pred.reference) * 1e3) ** 2, axis=0))   # (3,) mm
    m = model.meta
    record = {
        "units": int(units), "history": int(history), "model": f"{MODELS}/{point_name(units, history)}",
        "parameters": int(sum(p.numel() for p in model.module.parameters())),
        "training": {k: m.get(k) for k in ("epochs_run", "best_epoch", "best_validation_loss", "early_stopped",
                                           "train_seconds", "train_windows", "stride")},
        "error": {"rmse_mm": float(err.rmse_mm), "rmse_axis_mm": [float(v) for v in axis_mm],
                  "max_abs_mm": [float(v) for v in err.max_abs_mm],
                  "mean_abs_mm": [float(v) for v in err.mean_abs_mm],
                  "n_targets": int(pred.index.size), "samples": [int(pred.index[0]), int(pred.index[-1])]},
        "bandwidth": None,
        "seconds": time.perf_counter() - t0,
    }
    _write_json(point_path(out_dir, units, history), record)
    return record


def _config_from_dict(d: dict) -> StudyConfig:
    d = dict(d)
    d["train"] = TrainConfig(**d["train"])
    for key in ("units", "history", "neighbours"):
        if d.get(key) is not None:
            d[key] = tuple(d[key])
    return StudyConfig(**d)


# ------------------------------------------------------------------------------------------ bandwidth
def _rate(call, n: int, warmup: int) -> dict:
    """``n`` timed calls of ``call()`` after ``warmup`` untimed ones (``softrnn.timing.step_rate``)."""
    r = step_rate(call, steps=n, warmup=warmup)
    return {"hz": r.median_hz, "median_us": r.step_us, "p90_us": r.p90_us, "mean_hz": r.mean_hz, "calls": r.steps}


def measure_bandwidth(model, dataset, *, steps: int = 2000, torch_steps: int = 200) -> dict:
    """Computation bandwidth of ``model`` on one thread, fed the rows of ``dataset``'s test span.

    Parameters
    ----------
    model : NodeModel
        The node model to time.
    dataset : softrnn.io.Dataset
        Storing the model's window nodes; its test-span rows are fed in order (cycling).
    steps : int
        Timed ``NodeStepper.step(pose_row, wrench_row)`` calls (after 200 untimed).
    torch_steps : int
        Timed ``model.predict`` calls at batch 1 (eager PyTorch; after 20 untimed); 0: none.

    Returns
    -------
    dict
        ``stepper`` and ``torch`` (or None): ``hz``, ``median_us``, ``p90_us``, ``mean_hz``, ``calls``
        as ``softrnn.timing.step_rate`` times them.
    """


    H = int(model.spec.history)
    s0, s1 = evaluation_span(model, dataset.n_samples)
    rows = pose_rows(dataset, model.spec, s0, s1)                              # (L, P) float32
    wr = wrench_rows(dataset, model.spec, s0, s1)                              # (L, W) float32
    L = rows.shape[0]
    stepper = NodeStepper(model)
    stepper.reset(rows[:H], wr[:H])

    rows_in_turn = itertools.cycle(range(H, L))

    def step():
        k = next(rows_in_turn)
        stepper.step(rows[k], wr[k])

    out = {"stepper": _rate(step, steps, 200), "torch": None}
    if torch_steps:
        windows = np.lib.stride_tricks.sliding_window_view(rows, H, axis=0).transpose(0, 2, 1)   # (L-H+1, H, P)
        wwin = np.lib.stride_tricks.sliding_window_view(wr, H, axis=0).transpose(0, 2, 1)        # (L-H+1, H, W)
        n_win = windows.shape[0]

        windows_in_turn = itertools.cycle(range(n_win))

        def predict():
            k = next(windows_in_turn)
            model.predict(windows[k:k + 1], wwin[k:k + 1])

        with torch_threads(1):
            out["torch"] = _rate(predict, torch_steps, 20)
    return out


def _measure_point(out_dir: Path, record: dict, dataset, config: StudyConfig) -> dict:
    """Measure a trained point's bandwidths and rewrite its point file (with the machine they were
    measured on, ``softrnn.timing.machine_info``)."""

    model = load_model(out_dir / record["model"])
    record = dict(record, bandwidth=measure_bandwidth(model, dataset, steps=config.bandwidth_steps,
                                                      torch_steps=config.torch_steps))
    record["bandwidth"]["threads"] = 1
    record["bandwidth"]["machine"] = machine_info()
    _write_json(point_path(out_dir, record["units"], record["history"]), record)
    return record


# ------------------------------------------------------------------------------------------ the study
def _check_data(data_path: Path, config: StudyConfig):
    """The resolved spec of the longest history, after checking that the node, its neighbours and
    that history fit the data file (one-line errors)."""

    head = read_dataset(data_path, stop=1)
    spec = config.spec(max(config.history)).resolve(head.nodes, n_nodes_total=head.attrs.get("n_nodes_total"))
    n = int(read_dataset(data_path, nodes=[spec.node]).n_samples)
    try:
        spans(n, spec, config.train.validation_fraction)
    except SoftrnnInputError:
        raise bad("history", list(config.history), f"histories that fit the data: {data_path} has {n} samples, too "
                                                   f"few for a window of history {max(config.history)} in each of "
                                                   f"its fit, validation and test spans; drop the longest "
                                                   f"histories") from None
    return spec


class _Steps:
    """Counts finished steps and reports them to ``progress(done, total)`` (if given)."""

    def __init__(self, progress, total: int, done: int):
        self.progress, self.total, self.done = progress, total, done
        self.report()

    def report(self) -> None:
        if self.progress is not None:
            self.progress(self.done, self.total)

    def __call__(self) -> None:
        self.done += 1
        self.report()


def run_study(data_path, config: StudyConfig, out_dir, *, scheduler: str | None = None, workers: int | None = None,
              progress: Progress | None = None) -> StudyResult:
    """Run (or complete: finished points are kept) a Fig. 14 study (see the module docstring).

    Parameters
    ----------
    data_path, out_dir : str or Path
        A softrnn HDF5 data set (one trajectory); the study folder (created).
    config : StudyConfig
        The study's grid and training settings.
    scheduler : str or None
        None: a local Dask cluster of ``workers`` processes (default 2); ``"synchronous"``: in this
        process, no Dask; else a Dask scheduler's address (``tcp://HOST:PORT``).
    progress : callable(done, total) or None
        Called as the study advances (two steps per grid point: trained, measured).

    Returns
    -------
    StudyResult
        ``summary(...)`` plus ``data``, ``out_dir``, ``computed``, ``measured``, ``found``, ``figure`` and
        ``wall_seconds`` (``to_dict()``: the JSON summary).
    """
    if not isinstance(config, StudyConfig):
        raise bad("config", type(config).__name__, "a StudyConfig")
    if workers is None:
        workers = 2
    if not is_int(workers) or workers < 1:
        raise bad("--workers", workers, "an integer >= 1")
    if scheduler is not None and (not isinstance(scheduler, str) or not scheduler.strip()):
        raise bad("--scheduler", scheduler, f"a Dask scheduler address tcp://HOST:PORT or {SYNCHRONOUS!r}")
    data_path = Path(data_path)
    if not data_path.is_file():
        raise bad("data", str(data_path), "an existing softrnn HDF5 data set (softrnn simulate ... -o FILE.h5)")
    import torch  # noqa: F401  (the 'learn' extra: refused here, before any output is written)  # optional extra: learn (PyTorch)

    if scheduler != SYNCHRONOUS:
        require()
    t0 = time.perf_counter()
    spec = _check_data(data_path, config)
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise bad("-o", str(out), "a folder (it exists and is a file)")
    data = _check_manifest(out, config, data_path)
    _remove_stale_temporaries(out)

    records = {p: _read_point(point_path(out, *p)) for p in config.points}
    todo = [p for p in config.points if records[p] is None]
    found = [p for p in config.points if records[p] is not None and records[p].get("bandwidth")]
    tick = _Steps(progress, 2 * len(config.points), 2 * len(found) + len(config.points) - len(todo) - len(found))
    computed = []
    with closing(_execute(str(data_path), config, str(out), todo, scheduler, workers)) as finished:
        for rec in finished:                        # an exception here closes the cluster at once
            records[(rec["units"], rec["history"])] = rec
            computed.append((rec["units"], rec["history"]))
            tick()
    measured = _measure_missing(out, records, data_path, spec, config, tick)

    result = summary(config, [records[p] for p in config.points])
    save_figure(fig14_figure(result), out / FIGURE)
    return StudyResult(**{f.name: getattr(result, f.name) for f in fields(result)}, data=data, out_dir=str(out),
                       computed=[list(p) for p in sorted(computed)], measured=[list(p) for p in sorted(measured)],
                       found=[list(p) for p in sorted(found)], figure=str(out / FIGURE),
                       wall_seconds=time.perf_counter() - t0)


def _measure_missing(out: Path, records: dict, data_path: Path, spec, config: StudyConfig, tick) -> list:
    """Measure the bandwidths of every point of ``records`` ({(units, history): record}) that has
    none yet, in this process (timings from parallel workers would disturb each other); updates
    ``records`` and returns the points measured, in grid order."""
    measured = [p for p in config.points if not records[p].get("bandwidth")]
    if measured:
        dataset = read_dataset(data_path, nodes=list(spec.window_nodes))
        for p in measured:
            records[p] = _measure_point(out, records[p], dataset, config)
            tick()
    return measured


@contextmanager
def _workers_ignore_ctrl_c():
    """Start local worker processes with SIGINT ignored (inherited), so that a Ctrl-C reaches only
    this process, which cancels the work and closes the cluster (no traceback from every worker)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old)


def _execute(data_path: str, config: StudyConfig, out_dir: str, todo: list, scheduler, workers: int):
    """Yield the point records as their trainings finish (order of completion)."""
    if not todo:
        return
    cd = config.to_dict()
    if scheduler == SYNCHRONOUS:
        for u, h in todo:
            yield train_point(data_path, cd, u, h, out_dir)
        return

    tag = hashlib.sha256(json.dumps([data_path, out_dir, cd], sort_keys=True).encode()).hexdigest()[:16]
    tasks = [(train_point, (data_path, cd, u, h, out_dir), f"softrnn-study-{tag}-{point_name(u, h)}") for u, h in todo]
    yield from completed(tasks, scheduler, workers, alternatives=f"use {SYNCHRONOUS!r} to run in this process, ",
                         local_guard=_workers_ignore_ctrl_c)
