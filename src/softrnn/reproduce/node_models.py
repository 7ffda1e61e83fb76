"""Reproduce step: the node model of each case (paper Fig. 2A/2B), trained on the first 60 % of its
data set, evaluated one step ahead and free running on the test span and on the generalisation data
set, each beside the baselines (``softrnn.learned.node.evaluate.compare_baselines``), and the compiled
inference engine's agreement with PyTorch."""

import json
import shutil
import time
from pathlib import Path

import numpy as np

from .. import __version__
from ..figures.evaluation import write_figures
from ..files import atomic_write_text, json_default
from ..io.reader import read_dataset
from ..learned.horizons import HORIZON_STARTS, RolloutDiverged
from ..learned.node.data import SampleSpec
from ..learned.node.evaluate import evaluate
from ..learned.node.rollout import rollout
from ..scenarios.cases import build_case
from .cases import GENERALISATION
from .stepfiles import load_step

WRENCH = {"ellipse": "none", "square": "force", "semicircle": "force"}  # paper Fig. 2A / 2B
QUICK_TRAIN = {"epochs": 4, "max_train_windows": 3000, "rollout_steps": 2}
QUICK_HORIZON_STARTS = 2   # --quick: free-running starts per horizon (full runs: learned.horizons.HORIZON_STARTS, 5)


def _errors(block: dict | None) -> dict | None:
    """The report's error shape: max_abs, mean_abs [mm] and max_pct_of_length as [x, y, z]."""
    if block is None or block.get("diverged"):
        return block
    return {"max_abs": block["max_abs_mm"], "mean_abs": block["mean_abs_mm"],
            "max_pct_of_length": block["max_pct_of_length"]}


def comparison(report: dict) -> dict:
    """The model beside the baselines, from an ``Evaluation.to_dict()`` report: ``one_step`` and
    ``free_running`` (the model's errors, RMSE included), ``baselines``, ``horizons`` and ``misses``
    as ``softrnn evaluate --json`` writes them."""
    return {key: report.get(key) for key in ("span", "span_samples", "one_step", "free_running", "baselines",
                                             "horizons", "misses")}


def paper_errors(paper: dict) -> dict:
    """The paper's test and generalisation figures in the report's shape, beside its raw entry."""
    out = dict(paper)
    for key in ("test", "generalisation"):
        block = paper.get(key, {})
        out[key] = {"max_abs": block.get("max_abs_mm"), "mean_abs": block.get("mean_abs_mm"),
                    "max_pct_of_length": block.get("max_pct_of_length")}
    return out


def engine_agreement(model, data_path, start: int, stop: int) -> dict:
    """The free-running rollout of ``model`` over samples start..stop-1 by the compiled engine and by
    PyTorch (``predict`` per step): the largest position difference (m) and both wall times (s)."""
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


def _train(name: str, out: Path, quick: bool, progress_factory):
    """The case's node model trained (or resumed) in ``out/models/<name>``."""
    from ..learned.node.train import TrainConfig, train_node_model  # optional extra: learn (PyTorch)

    case = build_case(name)
    folder = out / "models" / name
    if (out / "models" / f"{name}.json").exists() and folder.exists():
        # finished earlier with other settings (--quick or another version): train afresh;
        # without a step file the folder is an interrupted training, which resumes
        shutil.rmtree(folder)
    spec = SampleSpec(node=case.node_of_interest, wrench=WRENCH[name])
    train = TrainConfig(**QUICK_TRAIN) if quick else TrainConfig()
    progress = progress_factory(f"train {name}") if progress_factory else None
    bar = None if progress is None else (lambda done, total, info=None: progress(done, total))
    return train_node_model(out / "data" / f"{name}.h5", spec, None, train, folder, resume=True, progress=bar)


def model_step(name: str, out: Path, quick: bool, progress_factory) -> dict:
    """Train the case's node model on the first 60 % of its data set, evaluate it one step ahead and
    free running on the test span, and on the generalisation data set, each beside the baselines
    (persistence, constant velocity, linear AR; by horizon too); skipped when done."""
    step_file = out / "models" / f"{name}.json"
    done = load_step(step_file, quick)
    if done is not None:
        return done
    data = out / "data" / f"{name}.h5"
    model = _train(name, out, quick, progress_factory)
    starts = {"horizon_starts": QUICK_HORIZON_STARTS if quick else HORIZON_STARTS}   # the published counts
    test = evaluate(model, data, model_name=name, **starts)
    gen = evaluate(model, out / "data" / f"{GENERALISATION[name]}.h5", generalisation=True, model_name=name,
                   **starts)
    figures = []
    for tag, ev in (("test", test), ("generalisation", gen)):
        paths = write_figures(ev, out / "figures" / f"{name}_model_{tag}")
        figures += [str(p.relative_to(out / "figures")) for p in paths if p.suffix == ".png"]
    tj, gj = test.to_dict(), gen.to_dict()
    span = model.meta["test_span"]
    engine = engine_agreement(model, data, int(span[0]) + model.spec.history, int(span[1]))
    done = {"quick": quick, "softrnn_version": __version__, "engine_vs_pytorch": engine,
            "one_step": _errors(tj["one_step"]),
            "rollout": _errors(tj["free_running"]), "generalisation": _errors(gj["one_step"]),
            "generalisation_rollout": _errors(gj["free_running"]), "test_span_s": tj.get("span_s"),
            "model": {"folder": f"models/{name}", "spec": model.spec.to_dict(),
                      "training": model.meta.get("training"), "test": comparison(tj),
                      "generalisation": comparison(gj)}, "figures": figures}
    atomic_write_text(step_file, json.dumps(done, indent=2, default=json_default))
    return done
