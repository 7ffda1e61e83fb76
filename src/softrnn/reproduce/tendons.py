"""The learned whole-manipulator model (``softrnn.learned.whole``) of the tendon-driven arms, driven by the
tendon tensions alone (``DynamicConfig.drive = "actuation"``), trained, run free beside its
baselines and measured against the goals of the learned dynamic model.

A step of ``softrnn reproduce`` (``report.json["tendons"]``); alone: ``tendon_step(out, quick)``
(one JSON-ready dict per case). Per case (``out/tendons/CASE/``, step file ``out/tendons/CASE.json``):

1. the nominal scenario and its sinusoidal generalisation variant (``GENERALISATION``) simulated into
   ``out/data/CASE.h5`` (``reproduce.cases.case_step``, no figures);
2. a sweep of the scenario (new tension profiles: its ``[randomize]`` table) into
   ``out/sweeps/CASE/``: ``n_train + n_validation + n_heldout`` variants saved every ``dt``; the last
   ``n_heldout`` are never trained on;
3. training (``CONFIGS[CASE]``, drive 'actuation': the model reads the tensions, never the recorded
   forces and torques) on the nominal trajectory's first 60 % and the training variants, with a
   checkpoint (an interrupted run resumes);
4. ``evaluate_dynamic``: the nominal trajectory's test span, the held-out variants (and the
   horizons), the generalisation scenario, beside persistence, constant velocity and the linear
   model fitted on the same inputs; ``goals`` as in ``reproduce.dynamic`` (no speed goal here).

The helpers are ``reproduce.dynamic``'s; a finished case is skipped on a rerun with the same settings.
"""

from __future__ import annotations

import time
from dataclasses import replace
from pathlib import Path

from .. import __version__
from ..io.reader import read_dataset
from ..learned.whole.config import DynamicConfig
from ..learned.whole.evaluation import evaluate_dynamic
from ..scenarios.cases import build_case
from .cases import case_step
from .dynamic import (
    TRAIN_FRACTION,
    _fresh,
    _usable,
    finished_case,
    goals,
    run_case_sweep,
    train_case,
    training_split,
)
from .stepfiles import load_step, save_step

CASES = ("tendon-planar", "tendon-spatial")
"""The tendon arms (shipped scenarios with a ``[randomize]`` table)."""
GENERALISATION = {"tendon-planar": "tendon-planar-sine", "tendon-spatial": "tendon-spatial-sine"}
"""Each arm's generalisation scenario: the same arm driven by sinusoidal tensions."""
_BASE = DynamicConfig(drive="actuation", steps=1000, ridge=1e-2, load_ridge=1e-4, prior_tau=0.1, linear_lr=1.0,
                      conv_reads="loads", start_fraction=0.3)
CONFIGS = {"tendon-planar": _BASE, "tendon-spatial": _BASE}
"""Each case's model, driven by the tensions alone: the default architecture and training (48
channels, 3 layers, 20-step unroll, learning rate 2e-3) for 1,000 steps, from a stiff, stable
linear start (penalties from 1e-2, 1e-4 on the tensions' coefficients, a 0.1 s damping prior), the
linear term trained at the full rate, a convolution that reads the tensions too, and 30 % of each
batch from the trajectories' first steps (docs/guide/dynamic.md, "Tendon-driven arms");
``quick`` trains ``QUICK_STEPS`` steps."""
QUICK_STEPS = 20
THREADS = 1
"""PyTorch's threads while training: a small model trains fastest on one (a second thread mostly
contends for a core, more so on a busy machine); ``reproduce.dynamic.TRAIN_THREADS`` likewise."""
SWEEP = {"dt": 0.01, "n_train": 10, "n_validation": 2, "n_heldout": 8, "workers": 2, "duration_s": 21.0}
"""Each case's sweep: variants 0..n_train-1 are trained on, the next n_validation select the weights,
the last n_heldout are held out; saved every dt [s] for duration_s [s]."""
QUICK_SWEEP = {"dt": 0.01, "n_train": 2, "n_validation": 0, "n_heldout": 1, "workers": 2, "duration_s": 3.0}
KEYS = ("model_dt_s", "predicted_nodes", "test_span_max_pct_of_length", "heldout",
        "generalisation_max_pct_of_length", "horizons")
"""The keys an entry shares with ``report["dynamic_model"][CASE]`` (null where not measured)."""


def config_for(case: str, quick: bool) -> DynamicConfig:
    """The case's ``DynamicConfig`` (``QUICK_STEPS`` optimiser steps with ``quick``)."""
    return replace(CONFIGS[case], steps=QUICK_STEPS) if quick else CONFIGS[case]


def settings(case: str, quick: bool) -> dict:
    """What makes a case's results: the sweep (not its workers), the model config, the version."""
    s = QUICK_SWEEP if quick else SWEEP
    sweep = {k: s[k] for k in ("dt", "n_train", "n_validation", "n_heldout", "duration_s")}
    sweep.update(count=s["n_train"] + s["n_validation"] + s["n_heldout"],
                 n_samples=int(round(s["duration_s"] / s["dt"])) + 1)
    return {"sweep": sweep, "config": config_for(case, quick).to_dict(), "train_fraction": TRAIN_FRACTION,
            "softrnn_version": __version__}


def simulate_inputs(case: str, out: Path, quick: bool, progress_factory=None) -> None:
    """The nominal scenario and its generalisation variant in ``out/data/`` (kept when finished)."""
    for name in (case, GENERALISATION[case]):
        case_step(build_case(name), out, quick, progress_factory, figures=False)


def measure(case: str, out: Path, loaded, split) -> dict:
    """The free-running evaluation of a trained model beside its baselines, with the goals."""
    nominal = read_dataset(out / "data" / f"{case}.h5")
    held = [part.read() for part in split.heldout]
    skipped: list = []
    test = _usable(loaded, nominal, 2, "nominal trajectory", skipped)
    gen = _usable(loaded, read_dataset(out / "data" / f"{GENERALISATION[case]}.h5"), 1,
                  "generalisation data set", skipped)
    entry = evaluate_dynamic(loaded, test=test, heldout=held, generalisation=gen,
                             test_start_fraction=TRAIN_FRACTION).to_dict()
    for key in KEYS:
        entry.setdefault(key, None)
    entry["skipped"] = skipped
    entry["drive"] = loaded.config.drive
    entry["channels"] = list(loaded.encoding.channels)
    longest = max((loaded.encoding.trajectory(d).n_steps for d in held), default=0)
    g = goals(case, entry, longest)
    g.pop("speed_ratio_vs_simulator", None)
    entry["goals"] = g
    entry["goals_met"] = all(v["met"] for v in g.values())
    return entry


def _prepared(case: str, out: Path, quick: bool, progress_factory=None) -> dict | None:
    """A tendon arm ready to train: its folder (kept only for the same settings), data sets, sweep
    and split; None when its step file ``out/tendons/CASE.json`` holds a finished result."""
    folder = out / "tendons" / case
    s = settings(case, quick)
    if finished_case(out / "tendons" / f"{case}.json", folder, s, quick) is not None:
        return None
    t0 = time.perf_counter()
    _fresh(folder, s)
    simulate_inputs(case, out, quick, progress_factory)
    workers = (QUICK_SWEEP if quick else SWEEP)["workers"]
    sweep_dir = run_case_sweep(case, out, s["sweep"], workers, progress_factory)
    return {"case": case, "folder": folder, "settings": s, "workers": workers, "t0": t0,
            "split": training_split(out, case, sweep_dir, s["sweep"]), "config": config_for(case, quick)}


def training_jobs(out, quick: bool = False, progress_factory=None, cases=CASES) -> list:
    """(case, folder, split, config) of every unfinished tendon arm, its data sets and sweep made: the
    trainings for ``reproduce.dynamic.train_cases`` (``softrnn reproduce`` runs them in the dynamic
    step's pool, beside the paper cases' trainings; ``tendon_case`` then finds each model trained)."""
    jobs = [_prepared(case, Path(out), quick, progress_factory) for case in cases]
    return [(j["case"], j["folder"], j["split"], j["config"]) for j in jobs if j is not None]


def tendon_case(case: str, out: Path, quick: bool = False, progress_factory=None) -> dict:
    """One tendon arm (``CASES``), skipped when its step file ``out/tendons/CASE.json`` holds a
    finished result of the same settings (trained here unless ``training_jobs`` trained it);
    returns the step file's dict."""
    out = Path(out)
    job = _prepared(case, out, quick, progress_factory)
    if job is None:
        return load_step(out / "tendons" / f"{case}.json", quick)
    folder, s, split = job["folder"], job["settings"], job["split"]
    loaded, train_s = train_case(case, folder, split, job["config"], progress_factory, threads=THREADS)
    t1 = time.perf_counter()
    entry = measure(case, out, loaded, split)
    training = {k: v for k, v in (loaded.meta.get("training") or {}).items() if k != "losses"}
    entry.update(train_seconds=train_s, evaluate_seconds=time.perf_counter() - t1, training=training,
                 train_config=loaded.config.to_dict(), model=str((folder / "model").relative_to(out)),
                 data=split.describe(), settings=s, step_s=time.perf_counter() - job["t0"],
                 sweep={"folder": f"sweeps/{case}", **s["sweep"], "workers": job["workers"]})
    return save_step(out / "tendons" / f"{case}.json", entry, quick)


def tendon_step(out, quick: bool = False, progress_factory=None, cases=CASES) -> dict:
    """Every tendon arm's model driven by its tensions alone: {case: entry} (``tendon_case``)."""
    return {case: tendon_case(case, Path(out), quick, progress_factory) for case in cases}
