"""Reproduce step: the learned whole-manipulator dynamic model (``softrnn.learned.whole``, beyond the paper)
of each paper case, trained, run free beside its baselines, and timed against the simulator.

Per case (``out/dynamic/CASE/``, step file ``out/dynamic/CASE.json``):

1. a sweep of the case's scenario (``softrnn.sweeps.run_sweep``, 2 local workers) into
   ``out/sweeps/CASE/``: ``n_train + n_heldout`` variants saved every ``dt`` (``SWEEP``); the last
   ``n_heldout`` are held out (never trained on);
2. training (``softrnn.learned.whole.fit``, config ``CONFIGS[CASE]``) on the paper trajectory's first 60 %
   (``out/data/CASE.h5``; its first sample is the reference pose) and the training variants, with a
   checkpoint in the case's folder (an interrupted run resumes); the model goes to ``model/``. The
   cases train side by side, ``TRAIN_WORKERS`` processes of one PyTorch thread each
   (``train_cases``): on small tensors two single-threaded trainings cover 1.6 times the steps of one
   two-threaded training, and one thread makes the weights the same on any machine;
3. ``evaluate_dynamic``: the paper trajectory's test span, the held-out variants (and the horizons),
   the generalisation data set (``cases.GENERALISATION``);
4. speed: the simulator and the model on one core each, one after the other
   (``softrnn.bench.dynamic.compare_speed``);
5. ``rollout.h5`` (the free run over the test span, every node, for ``softrnn animate``) and
   ``figures/dynamic_CASE.png`` (largest error over the nodes against time, model and baselines, on
   the test span and on the first held-out variant);
6. ``goals``: each goal (``GOALS``) with its measured value and whether it is met (reported, never
   asserted).

A finished case is skipped on a rerun with the same settings (``settings``: the sweep, the case's
``CONFIGS`` entry, ``--quick``) and version. A case folder or sweep made with other settings is
removed and made again, so changing ``CONFIGS`` retrains that case on the next run.
"""

from __future__ import annotations

import json
import multiprocessing
import queue as queues
import shutil
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from .. import __version__
from ..bench.dynamic import case_run, compare_speed
from ..figures.dynamic import error_over_time
from ..figures.saving import save_figure
from ..files import atomic_write_text, json_default
from ..io.reader import read_dataset
from ..io.writer import write_dataset
from ..learned.spans import start_of_test_span
from ..learned.threads import torch_threads
from ..learned.whole.artifact import is_dynamic_folder, load_dynamic, save_dynamic
from ..learned.whole.config import DynamicConfig
from ..learned.whole.data import split_inputs
from ..learned.whole.evaluation import evaluate_dynamic, run_errors, state_baselines
from ..learned.whole.rollout import rollout_dataset
from ..resume import RESUME, START_AGAIN, Settings, check
from ..scenarios.scenario import load_scenario
from ..sweeps.sweep import MANIFEST, run_sweep, trajectory_path
from .cases import GENERALISATION
from .stepfiles import load_step, save_step

CASES = ("ellipse", "square", "semicircle")
CONFIGS = {
    "ellipse": DynamicConfig(prior_tau=0.3),
    "square": DynamicConfig(steps=2500),
    "semicircle": DynamicConfig(),
}
"""The model of each case (architecture and training); ``--quick`` trains ``QUICK_STEPS`` steps.
The damping prior's time constant of each case is the one with the smallest validation error
(mean largest error of 1,000-step free runs on the validation variants, never the held-out ones)
among 0.3, 0.5 and 1 s (docs/guide/dynamic.md, fourth round); the square settles by step 2,200
(validation error 5.8 mm at 2,500 steps, 10.9 mm with 1 s at 4,000)."""
TRAIN_WORKERS = 2
"""Trainings run side by side (processes of one PyTorch thread each); 1: one after the other, here."""
TRAIN_THREADS = 1
"""PyTorch threads per training: one, so the weights do not depend on the machine's core count."""
QUICK_STEPS = 20
SWEEP = {"dt": 0.01, "n_train": 12, "n_validation": 6, "n_heldout": 8, "workers": 2,
         "duration_s": {"ellipse": 30.0, "square": 21.0, "semicircle": 21.0}}
"""Each case's sweep: variants 0..n_train-1 are trained on, the next n_validation select the weights
(``fit``'s validation), the last n_heldout are held out; saved every dt [s] for duration_s [s]."""
QUICK_SWEEP = {"dt": 0.01, "n_train": 2, "n_validation": 0, "n_heldout": 1, "workers": 2,
               "duration_s": {"ellipse": 3.0, "square": 3.0, "semicircle": 3.0}}
TRAIN_FRACTION = 0.6
SPEED = {"duration_s": 2.0, "reps": 5, "steps": 2000}
QUICK_SPEED = {"duration_s": 1.0, "reps": 3, "steps": 500}
GOALS = {"test_span_max_pct_of_length": 2.0, "heldout_median_max_pct_of_length": 2.0,
         "heldout_worst_max_pct_of_length": 5.0, "generalisation_max_pct_of_length": 5.0,
         "beats_every_baseline_at": (10, 100, 1000), "times_better_than_best_baseline_at_100": 5.0,
         "times_better_cases": ("ellipse", "square"), "speed_ratio_vs_simulator": 10.0}
"""The goals each case is measured against (``goals``): errors in % of the rod length."""


def config_for(case: str, quick: bool) -> DynamicConfig:
    """The case's ``DynamicConfig`` (``QUICK_STEPS`` optimiser steps with ``quick``)."""
    return replace(CONFIGS[case], steps=QUICK_STEPS) if quick else CONFIGS[case]


def settings(case: str, quick: bool) -> dict:
    """What makes a case's results: the sweep (dt, counts, duration, samples; not the workers, which
    change nothing), the model config and the softrnn version."""
    s = QUICK_SWEEP if quick else SWEEP
    duration = float(s["duration_s"][case])
    sweep = {"dt": s["dt"], "n_train": s["n_train"], "n_validation": s["n_validation"], "n_heldout": s["n_heldout"],
             "count": s["n_train"] + s["n_validation"] + s["n_heldout"], "duration_s": duration,
             "n_samples": int(round(duration / s["dt"])) + 1}
    return {"sweep": sweep, "config": config_for(case, quick).to_dict(), "train_fraction": TRAIN_FRACTION,
            "softrnn_version": __version__}


def _stored(path: Path):
    """The JSON in ``path``, or None (absent or unreadable)."""
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return None


def _fresh(folder: Path, want: dict) -> None:
    """Keep ``folder`` only if it was made with the settings ``want`` (its ``settings.json``)."""
    path = folder / "settings.json"
    text = json.dumps(want, indent=1, sort_keys=True, default=json_default)
    if folder.exists() and check(_stored(path), Settings.of(want), otherwise=START_AGAIN) == START_AGAIN:
        shutil.rmtree(folder)
    folder.mkdir(parents=True, exist_ok=True)
    if not path.is_file():
        atomic_write_text(path, text)


def run_case_sweep(case: str, out: Path, s: dict, workers: int, progress_factory=None) -> Path:
    """The case's sweep ``s`` (``settings(...)["sweep"]``) in ``out/sweeps/CASE`` on ``workers``
    local Dask workers (resumed; remade when it holds another sweep)."""
    folder = out / "sweeps" / case
    manifest = folder / MANIFEST
    if manifest.is_file():
        names = {trajectory_path(folder, i).name for i in range(s["count"])}
        extra = [p for p in folder.glob("traj-*.h5") if p.name not in names]
        want = Settings.of({"n_samples": s["n_samples"], "dt": s["dt"], "softrnn_version": __version__},
                           keys=("n_samples", "dt", "softrnn_version"))
        if check(_stored(manifest), want, otherwise=START_AGAIN) == START_AGAIN or extra:
            shutil.rmtree(folder)
    progress = progress_factory(f"sweep {case}") if progress_factory else None
    run_sweep(load_scenario(case), s["count"], folder, n_workers=workers, n_samples=s["n_samples"],
              dt=s["dt"], progress=progress)
    return folder


def training_split(out: Path, case: str, sweep_dir: Path, s: dict):
    """The paper trajectory's first 60 % first (its first sample: the reference pose), then the
    sweep's training variants; the sweep's last ``n_heldout`` variants held out, the
    ``n_validation`` before them for validation."""
    paper = split_inputs([out / "data" / f"{case}.h5"], train_fraction=TRAIN_FRACTION)
    return paper + split_inputs([sweep_dir], heldout=s["n_heldout"], validation=s["n_validation"])


def _fit_into(folder: Path, split, config: DynamicConfig, progress=None, threads: int | None = None) -> None:
    """Train and save the model to ``folder/model``, checkpointing to ``folder/checkpoint.pt`` (an
    interrupted training resumes from it; removed once the model is saved)."""
    from ..learned.whole.fit import fit  # optional extra: learn (PyTorch)

    trained, meta = fit(split, config, progress=progress, checkpoint=folder / "checkpoint.pt", threads=threads)
    save_dynamic(folder / "model", trained, meta)
    (folder / "checkpoint.pt").unlink(missing_ok=True)


def train_case(case: str, folder: Path, split, config: DynamicConfig, progress_factory=None,
               threads: int | None = None):
    """The model in ``folder/model`` (trained here, or read when finished earlier): (LoadedDynamic,
    the training's seconds). ``threads``: PyTorch's threads while training (None: as set)."""
    model_dir = folder / "model"
    if not is_dynamic_folder(model_dir):
        progress = progress_factory(f"train dynamic {case}") if progress_factory else None
        _fit_into(folder, split, config, progress, threads)
    loaded = load_dynamic(model_dir)
    return loaded, float((loaded.meta.get("training") or {}).get("train_seconds", 0.0))


@dataclass(frozen=True)
class PoolTask:
    """Another step's long work, run in the training pool (``train_cases``) after the trainings, so
    that it fills a worker the trainings leave idle: ``fn(*args, progress=..., **kwargs)`` with
    PyTorch on ``threads`` threads (those it has where the step runs it, so its arithmetic is the
    same), its progress shown under ``name``. ``fn`` keeps its own result (a file the step reads)."""

    name: str
    fn: Callable
    args: tuple = ()
    kwargs: dict = field(default_factory=dict)
    threads: int = 1


_QUEUE = None
"""A training worker's progress queue (``_worker_init``)."""
_PROGRESS_EVERY = 10


def _worker_init(queue) -> None:
    global _QUEUE
    _QUEUE = queue


def _train_job(case: str, folder: str, split, config: DynamicConfig, threads: int) -> str:
    """One case's training in a worker process; progress goes to the parent through ``_QUEUE`` as
    (case, done, total), every ``_PROGRESS_EVERY`` steps and at the end."""
    def progress(done, total, info=None):
        if done % _PROGRESS_EVERY == 0 or done == total:
            _QUEUE.put((case, int(done), int(total)))

    _fit_into(Path(folder), split, config, progress if _QUEUE is not None else None, threads)
    return case


def run_task(task: PoolTask, progress=None) -> None:
    """A ``PoolTask`` run here (in a worker or, with one worker, in the step's process)."""
    import torch  # noqa: F401  # optional extra: learn (PyTorch), loaded so that its threads can be set

    with torch_threads(task.threads):
        task.fn(*task.args, progress=progress, **task.kwargs)


def _task_job(task: PoolTask) -> str:
    """A ``PoolTask`` in a worker process, its progress sent to the parent as ``_train_job``'s."""
    def progress(done, total, info=None):
        if done % _PROGRESS_EVERY == 0 or done == total:
            _QUEUE.put((task.name, int(done), int(total)))

    run_task(task, progress if _QUEUE is not None else None)
    return task.name


def train_cases(jobs: list, workers: int = TRAIN_WORKERS, threads: int = TRAIN_THREADS,
                progress_factory=None) -> None:
    """Train every job (case, folder, split, config) whose ``folder/model`` is missing, ``workers``
    at a time in processes of ``threads`` PyTorch threads (1 worker: one after the other in this
    process, same arithmetic). Each training checkpoints and resumes as ``train_case``'s; an
    interruption (Ctrl-C, SIGTERM) stops the workers and keeps every finished model. ``PoolTask``
    items among ``jobs`` run in the same pool (``longest_first`` puts them last)."""
    jobs = [j for j in jobs if isinstance(j, PoolTask) or not is_dynamic_folder(Path(j[1]) / "model")]
    bars = {_job_name(j): progress_factory(j.name if isinstance(j, PoolTask) else f"train dynamic {j[0]}")
            if progress_factory else None for j in jobs}
    if workers <= 1 or len(jobs) <= 1:
        for job in jobs:
            if isinstance(job, PoolTask):
                run_task(job, bars[job.name])
            else:
                _fit_into(Path(job[1]), job[2], job[3], bars[job[0]], threads)
        return

    ctx = multiprocessing.get_context("spawn")      # no fork of a process that holds PyTorch's and numba's threads
    messages = ctx.Queue()
    pool = ctx.Pool(min(workers, len(jobs)), initializer=_worker_init, initargs=(messages,))
    def relay(timeout):
        """Pass one progress message (if any within ``timeout`` s) to its case's bar; False if none."""
        try:
            case, done, total = messages.get(timeout=timeout)
        except queues.Empty:
            return False
        if bars[case] is not None:
            bars[case](done, total)
        return True

    try:
        pending = [pool.apply_async(_task_job, (job,)) if isinstance(job, PoolTask)
                   else pool.apply_async(_train_job, (job[0], str(job[1]), job[2], job[3], threads)) for job in jobs]
        while pending:
            relay(0.2)
            for result in [r for r in pending if r.ready()]:
                result.get()                          # a training's error is raised here
                pending.remove(result)
        while relay(0.05):                            # the last messages (each bar's end)
            pass
        pool.close()
    finally:
        pool.terminate()
        pool.join()


def _speed(case: str, loaded, trajectories: list, quick: bool) -> dict:
    """The simulator and the model, one core each (``bench.dynamic.compare_speed``), the model stepped
    over the longest of ``trajectories`` (encoded), the simulator saved at the sweep's interval."""
    p = QUICK_SPEED if quick else SPEED
    setup, config, node = case_run(case, (QUICK_SWEEP if quick else SWEEP)["dt"])
    traj = max(trajectories, key=lambda t: t.n_steps)
    return compare_speed(setup, config, node, loaded.engine, traj, loaded.encoding.model_dt,
                         duration_s=p["duration_s"], reps=p["reps"], steps=p["steps"])


def span_start(loaded, traj) -> int:
    """The test span's first model step, as ``evaluate_dynamic`` starts it."""
    return start_of_test_span(max(int(loaded.engine.history), 2) - 1, traj.n_steps, TRAIN_FRACTION)


def write_rollout(loaded, dataset, path: Path) -> dict:
    """The model's free run over the test span of ``dataset``, every node decoded, as a data set
    (``softrnn animate``); up to where it diverged or left the data format's range."""
    start = span_start(loaded, loaded.encoding.trajectory(dataset))
    ds, diverged = rollout_dataset(loaded, dataset, start, attrs={"source": "softrnn.learned.whole free run"})
    ds.attrs["diverged_at_step"] = diverged
    write_dataset(path, ds)
    return {"samples": ds.n_samples, "start_s": float(ds.time[0]), "diverged_at": diverged}


def _errors(loaded, dataset, start: int | None) -> tuple[np.ndarray, dict]:
    """(times, {predictor: errors [% of L]}) of the model and the baselines run free from ``start``
    (None: the test span's start) to the end."""
    enc = loaded.encoding
    traj = enc.trajectory(dataset)
    start = span_start(loaded, traj) if start is None else start
    preds = {"model": loaded.engine, **state_baselines(), "linear": loaded.linear}
    series = {name: run_errors(p, enc, traj, dataset, start)[0] for name, p in preds.items()}
    return traj.time[start + 1:start + 1 + len(series["model"])], series


def write_figure(case: str, loaded, test, held, path: Path) -> str | None:
    """``figures/dynamic_CASE.png``: the errors over time on the test span of ``test`` and on the
    held-out variant ``held`` (either may be None); returns its name, or None when neither is given."""
    panels = []
    if test is not None:
        panels.append((f"paper trajectory, test span (last {100 * (1 - TRAIN_FRACTION):.0f} %)",
                       *_errors(loaded, test, None), GOALS["test_span_max_pct_of_length"]))
    if held is not None:
        s0 = max(int(loaded.engine.history), 2) - 1
        panels.append(("held-out sweep variant (never trained on), from its start", *_errors(loaded, held, s0),
                       GOALS["heldout_worst_max_pct_of_length"]))
    if not panels:
        return None
    save_figure(error_over_time(panels, f"{case}: whole-manipulator model, free running, every node"), path)
    return path.name


def _met(value, goal: float, below: bool = True) -> dict:
    if value is None:
        return {"value": None, "goal": goal, "met": False, "note": "diverged or not measured"}
    return {"value": value, "goal": goal, "met": bool(value < goal if below else value >= goal)}


def _horizon_goals(case: str, horizons: dict, longest: int, history: int) -> dict:
    """The model better than every baseline at each horizon, and 5x the best at 100 (some cases);
    ``longest``: the longest held-out variant [model steps] (a shorter one than a horizon needs
    leaves it unmeasured)."""
    out = {}
    for n in GOALS["beats_every_baseline_at"]:
        row = (horizons or {}).get(str(n)) or {}
        model = row.get("model")
        base = {k: v for k, v in row.items() if k != "model"}
        known = {k: v for k, v in base.items() if v is not None}
        best = min(known, key=known.get) if known else None
        entry = {"value": model, "best_baseline": best, "best_baseline_value": known.get(best),
                 "goal": "model < each baseline"}
        if model is None:
            why = (f"not measured: the held-out variants have at most {longest} model steps"
                   if longest < n + 1 + max(history - 1, 2) else "the model diverged")
            out[f"beats_every_baseline_at_{n}"] = {**entry, "met": False, "note": why}
        else:
            out[f"beats_every_baseline_at_{n}"] = {**entry, "met": all(model < v for v in known.values())}
        if n == 100 and case in GOALS["times_better_cases"]:
            k = GOALS["times_better_than_best_baseline_at_100"]
            ratio = None if model is None or best is None else (known[best] / model if model > 0 else float("inf"))
            out["times_better_than_best_baseline_at_100"] = {
                "value": ratio, "goal": k, "best_baseline": best, "met": ratio is not None and ratio >= k,
                **({} if ratio is not None else {"note": out["beats_every_baseline_at_100"].get("note", "")})}
    return out


def goals(case: str, entry: dict, longest: int) -> dict:
    """Each goal with its measured value and ``met`` (reported, never asserted); ``longest``: the
    longest held-out variant [model steps]."""
    held = entry.get("heldout") or {}
    out = {"test_span_max_pct_of_length": _met(entry.get("test_span_max_pct_of_length"),
                                               GOALS["test_span_max_pct_of_length"]),
           "heldout_median_max_pct_of_length": _met(held.get("median_max_pct_of_length"),
                                                    GOALS["heldout_median_max_pct_of_length"]),
           "heldout_worst_max_pct_of_length": _met(held.get("worst_max_pct_of_length"),
                                                   GOALS["heldout_worst_max_pct_of_length"]),
           "generalisation_max_pct_of_length": _met(entry.get("generalisation_max_pct_of_length"),
                                                    GOALS["generalisation_max_pct_of_length"])}
    out.update(_horizon_goals(case, entry.get("horizons"), longest, int(entry.get("history", 2))))
    out["speed_ratio_vs_simulator"] = _met(entry.get("speed_ratio_vs_simulator"), GOALS["speed_ratio_vs_simulator"],
                                           below=False)
    return out


def _usable(loaded, dataset, need: int, what: str, skipped: list):
    """``dataset`` if it has at least the model's history + ``need`` model steps, else None (and
    why, in ``skipped``): a free run needs a history and a step to predict (``--quick`` data can be
    shorter)."""
    n = (dataset.n_samples - 1) // loaded.encoding.stride(float(dataset.dt)) + 1
    if n >= int(loaded.engine.history) + need:
        return dataset
    skipped.append(f"{what}: {n} model steps, too short to run free (needs {int(loaded.engine.history) + need})")
    return None


def _measure(case: str, out: Path, folder: Path, loaded, split, quick: bool) -> dict:
    """Evaluation, speed, rollout and figure of a trained model: the case's entry (less training)."""
    paper = read_dataset(out / "data" / f"{case}.h5")
    held = [part.read() for part in split.heldout]
    skipped: list = []
    test = _usable(loaded, paper, 2, "paper trajectory", skipped)
    gen = _usable(loaded, read_dataset(out / "data" / f"{GENERALISATION[case]}.h5"), 1, "generalisation data set",
                  skipped)
    entry = evaluate_dynamic(loaded, test=test, heldout=held, generalisation=gen).to_dict()
    for key in ("test_span_max_pct_of_length", "generalisation_max_pct_of_length", "heldout", "horizons"):
        entry.setdefault(key, None)                  # skipped: present all the same, as null
    entry["skipped"] = skipped
    trajs = [loaded.encoding.trajectory(d) for d in [paper, *held]]
    fb = trajs[0].feedback
    entry["inputs"] = {"feedback": bool(loaded.encoding.feedback),
                       "feedback_law_nodes": [] if fb is None else list(fb.nodes),
                       "loads": "recorded forces and torques" + ("" if fb is None else
                                                                 "; PD tracking laws applied to the model's own state")}
    speed = _speed(case, loaded, trajs, quick)
    entry.update({k: speed[k] for k in ("speed_ratio_vs_simulator", "simulator_sim_s_per_wall_s",
                                        "model_sim_s_per_wall_s")}, speed=speed)
    entry["rollout"] = None if test is None else str((folder / "rollout.h5").relative_to(out))
    entry["rollout_run"] = None if test is None else write_rollout(loaded, test, folder / "rollout.h5")
    entry["figure"] = write_figure(case, loaded, test, held[0] if held else None,
                                   out / "figures" / f"dynamic_{case}.png")
    entry["goals"] = goals(case, entry, max((t.n_steps for t in trajs[1:]), default=0))
    return entry


def finished_case(step_file: Path, folder: Path, settings_: dict, quick: bool) -> dict | None:
    """The step file's result when it is finished with these settings and its model folder is there
    (the case is then skipped), else None."""
    done = load_step(step_file, quick)
    if done is None or not (folder / "model").is_dir():
        return None
    return done if check(done.get("settings"), Settings.of(settings_), otherwise=START_AGAIN) == RESUME else None


def _prepare_case(case: str, out: Path, quick: bool, progress_factory=None) -> dict:
    """A case's folder (kept only for the same settings), sweep and split: what training needs."""
    folder = out / "dynamic" / case
    s = settings(case, quick)
    t0 = time.perf_counter()
    _fresh(folder, s)
    workers = (QUICK_SWEEP if quick else SWEEP)["workers"]
    sweep_dir = run_case_sweep(case, out, s["sweep"], workers, progress_factory)
    return {"case": case, "folder": folder, "settings": s, "workers": workers, "t0": t0,
            "split": training_split(out, case, sweep_dir, s["sweep"]), "config": config_for(case, quick)}


def _finish_case(job: dict, out: Path, quick: bool) -> dict:
    """A trained case measured (``_measure``) and its step file written."""
    case, folder, s, split = job["case"], job["folder"], job["settings"], job["split"]
    loaded, train_s = train_case(case, folder, split, job["config"])
    entry = _measure(case, out, folder, loaded, split, quick)
    training = {k: v for k, v in (loaded.meta.get("training") or {}).items() if k != "losses"}
    entry.update(train_seconds=train_s, train_config=loaded.config.to_dict(), training=training,
                 model=str((folder / "model").relative_to(out)), data=split.describe(), settings=s,
                 sweep={"folder": f"sweeps/{case}", **s["sweep"], "workers": job["workers"]},
                 train_threads=TRAIN_THREADS,
                 step_s=time.perf_counter() - job["t0"])
    return save_step(out / "dynamic" / f"{case}.json", entry, quick)


def longest_first(jobs: list) -> list:
    """Training jobs (case, folder, split, config) ordered by their optimiser steps, most first (in
    order among equals), so that a pool of workers ends its last trainings close together; a
    ``PoolTask`` after every training (it fills the worker the last trainings leave idle)."""
    return sorted(jobs, key=lambda job: 1 if isinstance(job, PoolTask) else -job[3].steps)


def _job_name(job) -> str:
    """The name a pool job's progress goes under: a ``PoolTask``'s name, a training's case."""
    return job.name if isinstance(job, PoolTask) else job[0]


def dynamic_step(out: Path, quick: bool, progress_factory=None, *, cases=CASES, workers: int | None = None,
                 also=()) -> dict:
    """Every case's whole-manipulator model ({case: entry}; docs/report-format.md), a case skipped
    when its step file ``out/dynamic/CASE.json`` holds a finished result of the same settings
    (``settings``: the sweep and ``CONFIGS[CASE]``): the unfinished cases' sweeps, then their
    trainings side by side (``train_cases``, ``workers``: default ``TRAIN_WORKERS``; longest first,
    with the training jobs ``also`` of other steps, e.g. ``reproduce.tendons.training_jobs``), then
    each case's measurements, alone on the machine (the speed runs time one core each)."""
    out = Path(out)
    done = {case: finished_case(out / "dynamic" / f"{case}.json", out / "dynamic" / case, settings(case, quick),
                                quick) for case in cases}
    jobs = [_prepare_case(case, out, quick, progress_factory) for case in cases if done[case] is None]
    train_cases(longest_first([(j["case"], j["folder"], j["split"], j["config"]) for j in jobs] + list(also)),
                TRAIN_WORKERS if workers is None else workers, TRAIN_THREADS, progress_factory)
    for job in jobs:
        done[job["case"]] = _finish_case(job, out, quick)
    return done
