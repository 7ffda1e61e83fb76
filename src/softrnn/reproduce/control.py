"""Reproduce step: closed-loop control of the simulated magnetic rod under ``control/``:
``static-inverse`` and ``mpc-learned`` on the step, sine and random references, ``mpc-learned``
on robots 10 % stiffer and stronger, and 10 % softer and weaker, than the one it was identified on,
and ``mpc-physics`` (far from real time) on the first ``physics_duration`` seconds of each
reference, compared with the other two over the same frames."""

from __future__ import annotations

import multiprocessing
import signal
from pathlib import Path

import numpy as np

from ..control.loop import LoopConfig
from ..control.run import MODEL_FILE, learned_model, run_one
from ..figures.saving import save_figure, subplots
from ..learned.threads import REPRODUCE_TORCH_THREADS
from ..progress import ProgressFactory
from ..sweeps.dask import completed
from .dynamic import PoolTask, run_task
from .stepfiles import load_step, save_step

REFERENCES = ("step", "sine", "random")
CONTROLLERS = ("static-inverse", "mpc-learned")
"""Run over the whole ``duration``; ``mpc-physics`` over ``physics_duration``."""
PERTURBATIONS = {"+10%": 1.1, "-10%": 0.9}
"""Robustness: the plant's stiffness and remanence multiplied further by these factors."""

FULL = {"duration": 30.0, "physics_duration": 10.0, "identify": 90.0, "train_steps": 2000}
QUICK = {"duration": 2.0, "physics_duration": 0.5, "identify": 15.0, "train_steps": 300}
KEYS = ("rms_deg", "max_deg", "limit_violations", "compute_ms_median", "compute_ms_p99", "stable")


def _tasks(folder: Path, settings: dict, model) -> list:
    base = LoopConfig().to_dict()
    tasks = []
    for controller in CONTROLLERS:
        for ref in REFERENCES:
            path = folder / controller / ref
            tasks.append(((controller, ref), (run_one, (ref, controller, str(path), settings["duration"], base,
                                                        model if controller == "mpc-learned" else None))))
    for ref in REFERENCES:
        path = folder / "mpc-physics" / ref
        tasks.insert(0, (("mpc-physics", ref), (run_one, (ref, "mpc-physics", str(path), settings["physics_duration"],
                                                          base, None))))
    for name, f in PERTURBATIONS.items():
        plant = {**base, "stiffness": base["stiffness"] * f, "remanence": base["remanence"] * f}
        for ref in REFERENCES:
            path = folder / "robustness" / name / ref
            tasks.append(((name, ref), (run_one, (ref, "mpc-learned", str(path), settings["duration"], plant, model))))
    return tasks


def _model_settings(settings: dict) -> dict:
    """``learned_model``'s keyword arguments for the step's ``settings`` (``FULL`` or ``QUICK``)."""
    return {"identify_seconds": settings["identify"], "config": LoopConfig(), "seed": 0,
            "steps": settings["train_steps"]}


def training_jobs(out: Path, quick: bool) -> list:
    """The full run's MPC model identification and training as a ``PoolTask`` for the dynamic step's
    pool of trainings (``softrnn reproduce`` runs it there, on the worker the last trainings leave
    idle, with the PyTorch threads of this step; ``control_step`` then reads the model it saved); none
    with ``quick`` (``model_start`` identifies it ahead), when the step is finished or the model file
    is there."""
    folder = out / "control"
    if quick or load_step(folder / "step.json", quick) is not None or (folder / MODEL_FILE).exists():
        return []
    return [_model_task(folder, FULL)]


def _model_task(folder: Path, settings: dict) -> PoolTask:
    """``_model`` as a ``PoolTask``: the model identified and trained on PyTorch's threads of the
    pipeline (``REPRODUCE_TORCH_THREADS``), in the dynamic step's pool or in ``model_start``'s process."""
    return PoolTask("control model", learned_model, (folder,), _model_settings(settings), REPRODUCE_TORCH_THREADS)


def control_step(out: Path, quick: bool, progress_factory: ProgressFactory | None = None, workers: int = 2) -> dict:
    """The control table: ``report["control"][controller][reference]`` and
    ``report["control"]["robustness"][perturbation][reference]`` (``KEYS``), the goals, the model's
    training and ``figures/control.png``."""
    folder = out / "control"
    step_file = folder / "step.json"
    done = load_step(step_file, quick)
    if done is not None:
        return done
    settings = QUICK if quick else FULL
    progress = progress_factory("control") if progress_factory else None
    model = _model(folder, settings)            # read when model_start's process or training_jobs' task made it
    tasks = _tasks(folder, settings, model)
    jobs = [(_keyed, (key, fn, args), f"softrnn-control-{'-'.join(key)}-{quick}") for key, (fn, args) in tasks]
    if progress is not None:
        progress(0, len(jobs))
    summaries = {}
    for n, (key, summary) in enumerate(completed(jobs, None, workers), start=1):
        summaries[key] = summary.to_dict()                      # a control.run.ControlSummary
        if progress is not None:
            progress(n, len(jobs))
    result = {c: {r: {k: summaries[(c, r)][k] for k in KEYS} for r in REFERENCES} for c in CONTROLLERS}
    result["robustness"] = {p: {r: {k: summaries[(p, r)][k] for k in KEYS} for r in REFERENCES}
                            for p in PERTURBATIONS}
    result["mpc-physics"] = {r: {**{k: summaries[("mpc-physics", r)][k] for k in KEYS},
                                 "duration_s": summaries[("mpc-physics", r)]["duration_s"],
                                 "same_frames_rms_deg": _same_frames(folder, r)} for r in REFERENCES}
    result["goals"] = _goals(result)
    result["settings"] = {**settings, "references": list(REFERENCES), "perturbations": PERTURBATIONS,
                          "plant": LoopConfig().to_dict()}
    result["model"] = {k: v for k, v in model.meta.items() if k != "settings"}
    result["figure"] = _figure(out, folder)
    return save_step(step_file, result, quick)


def _model(folder: Path, settings: dict):
    """The step's NARX model (``control.run.learned_model``): read from ``folder`` when it was identified
    there with these settings, else identified, trained and saved there."""
    return learned_model(folder, **_model_settings(settings))


def _identify(folder: str, quick: bool) -> None:
    """The background process of ``model_start``: ``_model`` on PyTorch's threads of the pipeline
    (``REPRODUCE_TORCH_THREADS``), Ctrl-C left to the parent; a failure changes nothing (the step then
    identifies the model itself)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        run_task(_model_task(Path(folder), QUICK if quick else FULL))
    except Exception:  # noqa: BLE001  # only the model file was to be written
        pass


def model_start(out: Path, quick: bool):
    """Start identifying and training the step's model (``_model``) in a background process, unless
    the step is finished or its model file is there: a cold run spends those seconds while the
    steps before leave a core idle, not in this step. Returns the process (join it before the step
    runs) or None. The figures are unchanged: the same model, trained with the same PyTorch threads
    and numeric code paths (the environment of ``learned.threads.pin_numerics`` is inherited), read
    back exactly (``NarxModel.save`` keeps the weights' bits). Quick runs only: the full run's node
    models train on two PyTorch threads, and a second two-thread training beside them oversubscribes
    two cores (measured: the node models' trainings 3-5x slower, more than the identification saves)."""
    folder = out / "control"
    if not quick or load_step(folder / "step.json", quick) is not None or (folder / MODEL_FILE).exists():
        return None
    process = multiprocessing.get_context("spawn").Process(target=_identify, args=(str(folder), quick),
                                                           name="softrnn-control-model", daemon=True)
    process.start()
    return process


def _keyed(key: tuple, fn, args: tuple) -> tuple:
    """(key, fn(*args)): a task's result with the key it was submitted under (runs on a worker)."""
    return key, fn(*args)


def _same_frames(folder: Path, ref: str) -> dict:
    """RMS tracking error [deg] of each controller over the frames ``mpc-physics`` ran (the start of
    the reference), from the runs' traces."""
    out, n = {}, None
    for controller in ("mpc-physics",) + CONTROLLERS:                   # mpc-physics first: its frames
        with np.load(folder / controller / ref / "trace.npz") as t:
            n = t["time"].size if n is None else n
            e = np.degrees(t["true"][:n, 1, :2] - t["reference"][:n])
        out[controller] = float(np.sqrt(np.mean(e ** 2)))
    return out


def _goals(result: dict) -> dict:
    """The control step's goals, measured: mpc-learned's RMS at most half static-inverse's on every reference,
    its p99 below 1 ms, robustness runs stable, no limit violation anywhere."""
    ratios = {r: result["mpc-learned"][r]["rms_deg"] / result["static-inverse"][r]["rms_deg"] for r in REFERENCES}
    p99 = max(result["mpc-learned"][r]["compute_ms_p99"] for r in REFERENCES)
    runs = [result[c][r] for c in CONTROLLERS + ("mpc-physics",) for r in REFERENCES] + \
        [result["robustness"][p][r] for p in PERTURBATIONS for r in REFERENCES]
    return {
        "mpc_over_static_rms": {"value": ratios, "goal": "<= 0.5 on every reference",
                                "met": all(v <= 0.5 for v in ratios.values())},
        "mpc_compute_ms_p99": {"value": p99, "goal": "< 1", "met": p99 < 1.0},
        "robust_stable": {"value": {p: {r: result["robustness"][p][r]["stable"] for r in REFERENCES}
                                    for p in PERTURBATIONS},
                          "goal": "stable on every reference", "met": all(result["robustness"][p][r]["stable"]
                                                                          for p in PERTURBATIONS for r in REFERENCES)},
        "no_limit_violation": {"value": sum(run["limit_violations"] for run in runs), "goal": "0",
                               "met": all(run["limit_violations"] == 0 for run in runs)},
    }


def _figure(out: Path, folder: Path) -> str:
    """``figures/control.png``: the step and random references, static-inverse and mpc-learned (true
    distal orientation about y), and their errors; mpc-physics over the start it ran."""

    fig, axes = subplots(2, 2, figsize=(12, 6.5), sharex="col")
    for col, ref in enumerate(("step", "random")):
        for controller, color in (("static-inverse", "tab:red"), ("mpc-learned", "tab:blue"),
                                  ("mpc-physics", "tab:green")):
            with np.load(folder / controller / ref / "trace.npz") as t:
                if controller == "static-inverse":
                    axes[0, col].plot(t["time"], np.degrees(t["reference"][:, 1]), color="k", lw=1.2,
                                      label="reference")
                axes[0, col].plot(t["time"], np.degrees(t["true"][:, 1, 1]), color=color, lw=1.0, label=controller)
                err = np.degrees(np.hypot(*(t["true"][:, 1, :2] - t["reference"]).T))
                axes[1, col].plot(t["time"], err, color=color, lw=0.8, label=controller)
        axes[0, col].set_title(f"{ref} reference: distal magnet about y (bending)", fontsize=9)
        axes[0, col].set_ylabel("deg")
        axes[1, col].set_ylabel("|error| [deg]")
        axes[1, col].set_xlabel("t [s]")
        for ax in axes[:, col]:
            ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=7)
    fig.tight_layout()
    path = out / "figures" / "control.png"
    save_figure(fig, path)
    return str(path.relative_to(out))
