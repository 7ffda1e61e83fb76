"""Reproduce step: the data sets of the paper's simulated cases (section 4, Data-sets I-III) and of
their generalisation variants (``data/*.h5``, every node saved), with their figures and animations."""

import json
from dataclasses import replace
from pathlib import Path

import numpy as np

from .. import __version__
from ..figures import plots as plotting
from ..figures.animation import animate
from ..figures.data import load
from ..figures.saving import save_figure
from ..files import atomic_write_text
from ..io.reader import read_dataset
from ..progress import Progress, ProgressFactory
from ..scenarios.cases import Case
from ..scenarios.summary import simulate_summary
from .stepfiles import load_step

QUICK_FRACTION = 0.1  # --quick simulates this fraction of each case's duration
N_SNAPSHOTS = 6
ANIMATION_FRAMES = 120  # the most frames of each case's animation
GENERALISATION = {"ellipse": "ellipse-horizontal", "square": "square-figure8", "semicircle": "semicircle-cosine"}


def run_case(case: Case, quick: bool, data_path, progress: Progress | None = None) -> tuple[dict, dict]:
    """Simulate a case into the dataset ``data_path`` (every node saved); returns (summary, series)."""
    n_samples = case.config.n_samples
    if quick:
        n_samples = int((n_samples - 1) * QUICK_FRACTION) + 1
    config = replace(case.config, n_samples=n_samples)
    scenario = case.scenario
    series: dict = {}
    summary = simulate_summary(
        name=case.name, title=case.title, setup=case.setup, config=config, node=case.node_of_interest,
        out_path=data_path, scenario_text=scenario.text if scenario is not None else "",
        seed=scenario.seed if scenario is not None else None,
        attrs={"scenario_name": case.name, "node_of_interest": case.node_of_interest, "quick": quick},
        progress=progress, series=series, record=scenario.record if scenario is not None else None)
    summary["paper_section"] = case.paper_section
    summary["node_range_mm"] = (1e3 * (series["node_positions"].max(0) - series["node_positions"].min(0))).tolist()
    summary["density_kg_m3"] = case.setup.rod.density
    return summary, series


def _figures(case: Case, data_path: Path, series: dict, fig_dir: Path) -> list[str]:
    """Node trajectory, rod snapshots with forces, energy, and an animation of the dataset."""
    t = series["time"]
    fig = plotting.node_trajectory(t, series["node_positions"],
                                   f"{case.name}: node {case.node_of_interest} (analytical model)")
    save_figure(fig, fig_dir / f"{case.name}_node.png")
    rows = np.unique(np.linspace(0, t.size - 1, N_SNAPSHOTS).round().astype(int))
    snaps = [read_dataset(data_path, start=int(i), stop=int(i) + 1) for i in rows]
    fig = plotting.rod_snapshots(t[rows], np.concatenate([d.positions for d in snaps]).astype(float),
                                 f"{case.name}: configurations", node=case.node_of_interest,
                                 forces=np.concatenate([d.forces for d in snaps]).astype(float))
    save_figure(fig, fig_dir / f"{case.name}_rod.png")
    fig = plotting.energy(t, series["energy"], f"{case.name}: energy")
    save_figure(fig, fig_dir / f"{case.name}_energy.png")
    animate(load(data_path), fig_dir / f"{case.name}.gif", node=case.node_of_interest, max_frames=ANIMATION_FRAMES)
    return [f"{case.name}_node.png", f"{case.name}_rod.png", f"{case.name}_energy.png", f"{case.name}.gif"]


def case_step(case: Case, out: Path, quick: bool, progress_factory: ProgressFactory | None, figures: bool) -> dict:
    """Dataset (and figures) of one case, skipped when a finished result is present.

    The dataset goes to ``out/data/<name>.h5``, the step file to ``out/cases/<name>.json`` and, when
    ``figures``, the figures to ``out/figures/``; ``quick`` simulates ``QUICK_FRACTION`` of the case's
    duration. Returns the step file's content: ``simulation`` (the run's summary), ``figures`` (file
    names under ``figures/``) and ``dataset`` (the data set's path relative to ``out``).
    """
    step_file = out / "cases" / f"{case.name}.json"
    data_path = out / "data" / f"{case.name}.h5"
    done = load_step(step_file, quick)
    if done is not None and data_path.exists():
        return done
    progress = progress_factory(f"simulate {case.name}") if progress_factory else None
    summary, series = run_case(case, quick, data_path, progress)
    names = _figures(case, data_path, series, out / "figures") if figures else []
    done = {"quick": quick, "softrnn_version": __version__, "simulation": summary, "figures": names,
            "dataset": str(data_path.relative_to(out))}
    atomic_write_text(step_file, json.dumps(done, indent=2))
    return done
