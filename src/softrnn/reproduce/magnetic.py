"""Reproduce step: the paper's magnetic experiment (section 5) simulated, Table 1 and Fig. 12
(``softrnn.experiments.magnetic``), under ``magnetic/``."""

from pathlib import Path

from ..experiments.magnetic import ExperimentConfig, run_experiment
from ..progress import ProgressFactory
from .stepfiles import load_step, save_step


def magnetic_step(out: Path, quick: bool, progress_factory: ProgressFactory | None = None) -> dict:
    """The paper's experiment (section 5) simulated: Table 1 and Fig. 12
    (``softrnn.experiments.magnetic``)."""
    step_file = out / "magnetic" / "step.json"
    done = load_step(step_file, quick)
    if done is not None:
        return done
    progress = progress_factory("magnetic experiment") if progress_factory else None
    result = run_experiment(ExperimentConfig(quick=quick), out / "magnetic", progress=progress)
    fig = out / "magnetic" / "fig12.png"
    if fig.exists():
        (out / "figures").mkdir(parents=True, exist_ok=True)
        (out / "figures" / "fig12.png").write_bytes(fig.read_bytes())
    return save_step(step_file, result, quick)
