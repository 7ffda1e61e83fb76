"""Reproduce step: the static Cosserat solver's solve time against tolerance, node count and guess
error (paper Fig. 13), under ``statics/``."""

from pathlib import Path

from ..experiments.fig13 import run_fig13_study, write_fig13
from .stepfiles import load_step, save_step


def fig13_step(out: Path, quick: bool) -> dict:
    """The static solver's solve time against tolerance, node count and guess error (Fig. 13)."""
    step_file = out / "statics" / "fig13-step.json"
    done = load_step(step_file, quick)
    if done is not None:
        return done
    (out / "statics").mkdir(parents=True, exist_ok=True)
    result = run_fig13_study(repetitions=10) if quick else run_fig13_study()
    write_fig13(result, out / "statics" / "fig13.json", out / "figures" / "fig13.png")
    summary = _fig13_summary(result)
    return save_step(step_file, {"json": "statics/fig13.json", "figure": "fig13.png", "summary": summary}, quick)


def _fig13_summary(result: dict) -> dict:
    """The parts of the study's result that the report shows."""
    keep = ("repetitions", "paper", "guess_errors", "tolerance_sweep", "node_sweep", "load_case")
    return {k: result[k] for k in keep if k in result}
