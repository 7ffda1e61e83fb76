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
the semicircle case, section 4.3) are copied in ``PAPER_FIG14`` and set beside the regions found
here in the summary.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
import signal
import threading
import time
from contextlib import closing, contextmanager
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np
from matplotlib.colors import LogNorm
from matplotlib.patches import Rectangle

from .. import __version__
from ..errors import SoftrnnInputError, bad, integer, is_int
from ..figures.saving import save_figure, subplots
from ..files import atomic_write_text
from ..io.reader import read_dataset
from ..learned.node.artifact import load_model
from ..learned.node.data import SampleSpec, pose_rows, wrench_rows
from ..learned.node.engine import NodeStepper
from ..learned.node.evaluate import evaluation_span, load_for_model, metrics, one_step, rod_length
from ..learned.node.train import TrainConfig, train_node_model
from ..learned.node.training_data import spans
from ..progress import Progress
from ..resume import REFUSE, Settings, check
from ..sweeps.dask import completed, require
from ..timing import machine_info, step_rate

MANIFEST = "study.json"
GRID = ("units", "history")
"""The settings that may change between runs of a study in one folder (the grid grows or shrinks)."""
FIGURE = "fig14.png"
MODELS = "models"
FORMAT = "softrnn-fig14-study"
FORMAT_VERSION = 1
SYNCHRONOUS = "synchronous"
"""``scheduler`` value that runs the grid points in the calling process, without Dask."""

PAPER_FIG14 = {
    "source": "Tariverdi et al. 2021, 'A Recurrent Neural-Network-Based Real-Time Dynamic Model for Soft "
              "Continuum Manipulators', Front. Robot. AI 8:631303, section 5.3, Figure 14 (Data-set IV)",
    "bandwidth": "Figure 14A demonstrates the computation bandwidth required for the prediction of the next step "
                 "using the trained model with a different number of LSTM units and a different size of time "
                 "history horizons in Data-set IV. The figure suggests that computation bandwidths are fairly "
                 "unchanged with the number of LSTM units; however, increasing the length of time history reduces "
                 "bandwidth. The optimal region maximizing the bandwidth is approximately with time history size in "
                 "(2, 20) and LSTM unit size in (5, 15).",
    "rms_error": "Figure 14B suggests that RMS error of the prediction decreases by increasing the number of LSTM "
                 "units and the optimal area minimizing RMS errors is approximately with time history size in "
                 "(2, 20) and LSTM unit size in (20, 25).",
    "bandwidth_region": {"history": [2, 20], "lstm_units": [5, 15]},
    "rms_error_region": {"history": [2, 20], "lstm_units": [20, 25]},
}
"""The paper's Fig. 14 statements, quoted, and its two optimal regions (history and LSTM unit ranges)."""


def _grid(name: str, value) -> tuple[int, ...]:
    """A non-empty sequence of distinct positive integers, sorted."""
    if is_int(value):
        value = (value,)
    if isinstance(value, (str, bytes)) or not hasattr(value, "__iter__"):
        raise bad(name, value, "a non-empty list of distinct positive integers, e.g. 5,10,15")
    out = tuple(value)
    if not out or not all(is_int(a) and a >= 1 for a in out) or len(set(out)) != len(out):
        raise bad(name, list(out), "a non-empty list of distinct positive integers, e.g. 5,10,15")
    return tuple(sorted(int(a) for a in out))


def _default_train() -> TrainConfig:
    return TrainConfig(rollout_steps=1, max_train_windows=10_000)


@dataclass(frozen=True, kw_only=True)
class StudyConfig:
    """What a Fig. 14 study trains and measures.

    Parameters
    ----------
    node : int
        The predicted rod node (negative: from the rod's end).
    units : tuple of int
        LSTM units per layer of the grid (the paper's axis: 5 .. 25).
    history : tuple of int
        History sizes H (past time steps per window) of the grid (the paper's axis: 2 .. 20).
    epochs : int
        Training epochs of every point. The default, 10, keeps a 5 x 4 study of one case within a
        few minutes on two cores; the project's models train 30.
    seed : int
        Seed of every point's weights and shuffling (the same for all points).
    train : TrainConfig
        The other training settings; its ``epochs`` and ``seed`` are replaced by the fields above.
        Default: one-step training (``rollout_steps=1``, the paper's loss, and the study measures
        one-step errors) on at most 10,000 windows (``max_train_windows``).
    neighbours : tuple of int or None
        Input I's neighbour nodes (None: the adjacent ones, ``SampleSpec``).
    inputs : str
        ``"positions"`` or ``"poses"`` (``SampleSpec.inputs``).
    wrench : str
        ``"none"``, ``"force"`` or ``"wrench"`` (``SampleSpec.wrench``).
    bandwidth_steps : int
        Timed ``NodeStepper.step`` calls per point (after 200 untimed ones).
    torch_steps : int
        Timed eager PyTorch ``predict`` calls per point (0: not measured).
    region_tolerance : float
        A region is the grid points within this fraction of the best value: bandwidth >= (1 - tol)
        x the highest, RMS error <= (1 + tol) x the lowest.
    """

    node: int
    units: tuple[int, ...] = (5, 10, 15, 20, 25)
    history: tuple[int, ...] = (2, 5, 10, 20)
    epochs: int = 10
    seed: int = 0
    train: TrainConfig = field(default_factory=_default_train)
    neighbours: tuple[int, ...] | None = None
    inputs: str = "positions"
    wrench: str = "force"
    bandwidth_steps: int = 2000
    torch_steps: int = 200
    region_tolerance: float = 0.1

    def __post_init__(self):
        if not is_int(self.node):
            raise bad("node", self.node, "an integer node index")
        object.__setattr__(self, "node", int(self.node))
        object.__setattr__(self, "units", _grid("units", self.units))
        object.__setattr__(self, "history", _grid("history", self.history))
        for name, low in (("epochs", 1), ("seed", 0), ("bandwidth_steps", 10), ("torch_steps", 0)):
            object.__setattr__(self, name, integer(name, getattr(self, name), low))
        if not isinstance(self.train, TrainConfig):
            raise bad("train", type(self.train).__name__, "a TrainConfig")
        object.__setattr__(self, "train", replace(self.train, epochs=self.epochs, seed=self.seed))
        tol = self.region_tolerance
        if isinstance(tol, bool) or not isinstance(tol, (int, float, np.floating)) or not 0.0 <= tol < 1.0:
            raise bad("region_tolerance", tol, "a fraction in [0, 1), e.g. 0.1 for within 10 % of the best")
        object.__setattr__(self, "region_tolerance", float(tol))
        spec = self.spec(self.history[0])  # checks neighbours, inputs and wrench
        object.__setattr__(self, "neighbours", spec.neighbours)

    def spec(self, history: int):
        """The ``SampleSpec`` of the grid points of history ``history``."""
        return SampleSpec(node=self.node, neighbours=self.neighbours, history=history, inputs=self.inputs,
                          wrench=self.wrench)

    @property
    def points(self) -> list[tuple[int, int]]:
        """The grid points (units, history), units varying fastest."""
        return [(u, h) for h in self.history for u in self.units]

    def to_dict(self) -> dict:
        """JSON-ready settings."""
        d = asdict(self)
        d["units"], d["history"] = list(self.units), list(self.history)
        d["neighbours"] = None if self.neighbours is None else list(self.neighbours)
        return d

    def settings(self) -> Settings:
        """What every point's result depends on (everything but the grid, ``GRID``): a rerun must
        match it."""
        return Settings.of(self, may_differ=GRID)


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


def file_sha256(path) -> str:
    """SHA-256 of a file's bytes (hex)."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


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
        ``stepper`` and ``torch`` (or None), each timed by ``softrnn.timing.step_rate``: ``hz`` (the
        median over 5 runs of each run's calls per second), ``median_us`` (1e6 / ``hz``),
        ``p90_us`` (90th percentile of the single call times), ``mean_hz`` (calls / total time),
        ``calls``.
    """
    import torch  # optional extra: learn (PyTorch)


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

        old = torch.get_num_threads()
        torch.set_num_threads(1)
        try:
            out["torch"] = _rate(predict, torch_steps, 20)
        finally:
            torch.set_num_threads(old)
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
              progress: Progress | None = None) -> dict:
    """Run (or complete) a Fig. 14 study of ``data_path`` in ``out_dir``.

    Parameters
    ----------
    data_path : str or Path
        A softrnn HDF5 data set (one trajectory).
    config : StudyConfig
        The study's grid and training settings.
    out_dir : str or Path
        The study folder (created; see the module docstring). Finished points found there are kept.
    scheduler : str or None
        None: a Dask ``LocalCluster`` of ``workers`` single-threaded processes; ``"synchronous"``:
        every point in this process, no Dask; otherwise the address of a Dask scheduler
        (``tcp://HOST:PORT``).
    workers : int or None
        Local worker processes (default 2; only with ``scheduler=None``).
    progress : callable(done, total) or None
        Called as the study advances: each grid point counts two steps (trained and evaluated;
        bandwidths measured), steps found done count at once.

    Returns
    -------
    dict
        ``summary(...)``: the grids, every point's record, the bandwidth [Hz] and RMS error [mm]
        tables (rows: history, columns: units), the regions beside the paper's, ``computed``
        (points trained now), ``measured`` (points timed now), ``found`` (points already finished),
        ``figure`` (path of fig14.png) and ``wall_seconds``.
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
    result.update(data=data, out_dir=str(out), computed=[list(p) for p in sorted(computed)],
                  measured=[list(p) for p in sorted(measured)], found=[list(p) for p in sorted(found)])

    save_figure(fig14_figure(result), out / FIGURE)
    result["figure"] = str(out / FIGURE)
    result["wall_seconds"] = time.perf_counter() - t0
    return result


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


# ------------------------------------------------------------------------------------------ summary
def _table(config: StudyConfig, records: list[dict], value) -> np.ndarray:
    """(len(history), len(units)) array of ``value(record)`` (NaN where None)."""
    t = np.full((len(config.history), len(config.units)), np.nan)
    for r in records:
        v = value(r)
        if v is not None:
            t[config.history.index(r["history"]), config.units.index(r["units"])] = v
    return t


def _stepper_hz(r):
    return r["bandwidth"]["stepper"]["hz"] if r.get("bandwidth") else None


def _torch_hz(r):
    b = r.get("bandwidth")
    return b["torch"]["hz"] if b and b.get("torch") else None


def _rmse(r):
    return r["error"]["rmse_mm"]


def region(config: StudyConfig, table: np.ndarray, *, maximise: bool) -> dict | None:
    """The grid points within ``config.region_tolerance`` of the best value of ``table``
    (len(history), len(units)): ``best`` {units, history, value}, ``points`` [[units, history]],
    and the ranges they span, ``units`` [lo, hi] and ``history`` [lo, hi]. None if all NaN."""
    if not np.isfinite(table).any():
        return None
    tol = config.region_tolerance
    best = np.nanmax(table) if maximise else np.nanmin(table)
    i, j = np.argwhere(table == best)[0]
    with np.errstate(invalid="ignore"):
        inside = table >= (1 - tol) * best if maximise else table <= (1 + tol) * best
    pts = [[config.units[b], config.history[a]] for a, b in np.argwhere(inside)]
    us, hs = [p[0] for p in pts], [p[1] for p in pts]
    return {"best": {"units": config.units[j], "history": config.history[i], "value": float(best)},
            "criterion": f"{'>=' if maximise else '<='} {(1 - tol) if maximise else (1 + tol):g} x the best",
            "points": sorted(pts), "units": [min(us), max(us)], "history": [min(hs), max(hs)]}


def _in_paper_region(points: list, paper: dict) -> float:
    """Fraction of ``points`` [[units, history]] inside the paper's ranges (closed)."""
    lo_u, hi_u = paper["lstm_units"]
    lo_h, hi_h = paper["history"]
    inside = [lo_u <= u <= hi_u and lo_h <= h <= hi_h for u, h in points]
    return sum(inside) / len(inside) if inside else math.nan


def trend(table: np.ndarray, axis: int) -> float | None:
    """Mean relative change of ``table`` from the smallest to the largest grid value along
    ``axis`` (0: history, 1: units), e.g. -0.5: halved; None with a single grid value."""
    if table.shape[axis] < 2:
        return None
    first, last = (table[0], table[-1]) if axis == 0 else (table[:, 0], table[:, -1])
    ok = np.isfinite(first) & np.isfinite(last) & (first != 0)
    return float(np.mean(last[ok] / first[ok] - 1.0)) if ok.any() else None


def summary(config: StudyConfig, records: list[dict]) -> dict:
    """The tables, regions and trends of a study's point records, beside the paper's Fig. 14."""
    bw, tbw, err = (_table(config, records, f) for f in (_stepper_hz, _torch_hz, _rmse))

    def listed(t):
        return [[None if not np.isfinite(v) else float(v) for v in row] for row in t]

    regions = {}
    for name, table, maximise, paper_key in (("bandwidth", bw, True, "bandwidth_region"),
                                             ("torch_bandwidth", tbw, True, "bandwidth_region"),
                                             ("rms_error", err, False, "rms_error_region")):
        reg = region(config, table, maximise=maximise)
        if reg is not None:
            paper = PAPER_FIG14[paper_key]
            reg["paper"] = paper
            reg["fraction_in_paper_region"] = _in_paper_region(reg["points"], paper)
        regions[name] = reg
    trends = {"bandwidth_vs_units": trend(bw, 1), "bandwidth_vs_history": trend(bw, 0),
              "torch_bandwidth_vs_units": trend(tbw, 1), "torch_bandwidth_vs_history": trend(tbw, 0),
              "rms_error_vs_units": trend(err, 1), "rms_error_vs_history": trend(err, 0)}
    return {"config": config.to_dict(), "units": list(config.units), "history": list(config.history),
            "points": records, "bandwidth_hz": listed(bw), "torch_bandwidth_hz": listed(tbw),
            "rmse_mm": listed(err), "regions": regions, "trends": trends,
            "paper": {k: PAPER_FIG14[k] for k in ("source", "bandwidth", "rms_error", "bandwidth_region",
                                                  "rms_error_region")}}


# ------------------------------------------------------------------------------------------ figure
def _short(v: float) -> str:
    """3 significant digits, thousands as k: 0.357, 1.98k, 446k."""
    return f"{v / 1e3:.3g}k" if abs(v) >= 1e3 else f"{v:.3g}"


def fig14_figure(result: dict):
    """The Fig. 14 heatmaps of a study ``summary``: (A) bandwidth of the compiled stepper [Hz],
    (A') of eager PyTorch [Hz] when measured, (B) one-step RMS error [mm], over LSTM units (x) and
    history size (y). Solid outlines: the region found (within the tolerance of the best); dashed:
    the grid points inside the paper's region; the error's colour scale is logarithmic. Returns
    the matplotlib Figure."""

    units, hist = result["units"], result["history"]
    panels = [("A: bandwidth, compiled stepper [Hz]", result["bandwidth_hz"], "bandwidth", "viridis")]
    if any(v is not None for row in result["torch_bandwidth_hz"] for v in row):
        panels.append(("A': bandwidth, eager PyTorch [Hz]", result["torch_bandwidth_hz"], "torch_bandwidth",
                       "viridis"))
    panels.append(("B: one-step RMS error [mm]", result["rmse_mm"], "rms_error", "magma_r"))
    fig, axes = subplots(1, len(panels), figsize=(4.6 * len(panels), 3.2 + 0.35 * len(hist)), squeeze=False)
    for ax, (title, rows, key, cmap) in zip(axes[0], panels):
        t = np.array([[np.nan if v is None else v for v in row] for row in rows], dtype=float)
        finite = t[np.isfinite(t)]
        log = key == "rms_error" and finite.size > 0 and finite.min() > 0      # errors span decades
        norm = LogNorm(finite.min(), finite.max()) if log else None
        im = ax.imshow(t, origin="lower", cmap=cmap, aspect="auto", norm=norm)
        fig.colorbar(im, ax=ax, shrink=0.85)
        mid = (np.sqrt(finite.min() * finite.max()) if log else 0.5 * (finite.min() + finite.max())) \
            if finite.size else 0.0
        for a in range(t.shape[0]):
            for b in range(t.shape[1]):
                if np.isfinite(t[a, b]):
                    light = (t[a, b] < mid) == (cmap == "viridis")
                    ax.text(b, a, _short(t[a, b]), ha="center", va="center", fontsize=7,
                            color="white" if light else "black")
        reg = result["regions"].get(key)
        if reg is not None:
            for u, h in reg["points"]:
                ax.add_patch(Rectangle((units.index(u) - 0.5, hist.index(h) - 0.5), 1, 1, fill=False,
                                       edgecolor="red", lw=2.0))
            paper = reg["paper"]
            for a, h in enumerate(hist):
                for b, u in enumerate(units):
                    if paper["lstm_units"][0] <= u <= paper["lstm_units"][1] and \
                            paper["history"][0] <= h <= paper["history"][1]:
                        ax.add_patch(Rectangle((b - 0.42, a - 0.42), 0.84, 0.84, fill=False, edgecolor="cyan",
                                               lw=1.0, ls="--"))
        ax.set_xticks(range(len(units)), [str(u) for u in units])
        ax.set_yticks(range(len(hist)), [str(h) for h in hist])
        ax.set_xlabel("LSTM units")
        ax.set_ylabel("history size H")
        ax.set_title(title, fontsize=9)
    fig.suptitle("Fig. 14 study (red: within the tolerance of the best; dashed cyan: the paper's region)",
                 fontsize=9)
    fig.tight_layout()
    return fig
