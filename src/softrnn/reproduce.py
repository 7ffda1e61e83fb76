"""``softrnn reproduce``: the paper's pipeline, step by step, into one output folder.

At this stage: the three simulated cases (section 4) and the simulator benchmark, with figures,
``report.json`` and ``report.md``. Each finished step leaves its files; a rerun (after an
interruption) skips the steps whose results are present for the same settings.
"""

import json
import platform
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import __version__, plotting
from .cases import ASSUMPTIONS, PAPER_CASES, Case, build_case
from .io_util import atomic_write_bytes, atomic_write_text
from .paper import paper_case
from .rod import RunConfig, Simulator

QUICK_FRACTION = 0.1  # --quick simulates this fraction of each case's duration
N_SNAPSHOTS = 6


@dataclass
class _Collector:
    """Sink keeping the node of interest's series, the energy and a few whole-rod snapshots."""

    node: int
    snapshot_rows: np.ndarray

    def __post_init__(self):
        self.parts = {"time": [], "positions": [], "forces": [], "energy": []}
        self.snapshots, self.snapshot_forces, self.snapshot_times = [], [], []
        self.max_ortho = 0.0
        self.row = 0

    def __call__(self, chunk):
        rows = np.arange(self.row, self.row + chunk.time.size)
        self.parts["time"].append(chunk.time)
        self.parts["positions"].append(chunk.positions[:, self.node])
        self.parts["forces"].append(chunk.forces[:, self.node])
        self.parts["energy"].append(chunk.energy)
        for i in np.flatnonzero(np.isin(rows, self.snapshot_rows)):
            self.snapshots.append(chunk.positions[i])
            self.snapshot_forces.append(chunk.forces[i])
            self.snapshot_times.append(chunk.time[i])
        self.row += chunk.time.size

    def arrays(self) -> dict:
        out = {k: np.concatenate(v) for k, v in self.parts.items()}
        out["snapshots"] = np.array(self.snapshots)
        out["snapshot_forces"] = np.array(self.snapshot_forces)
        out["snapshot_times"] = np.array(self.snapshot_times)
        return out


def run_case(case: Case, quick: bool, progress=None) -> tuple[dict, dict]:
    """Simulate a case saving every node; returns (summary, arrays for figures)."""
    n_samples = case.config.n_samples
    if quick:
        n_samples = int((n_samples - 1) * QUICK_FRACTION) + 1
    config = RunConfig(dt=case.config.dt, n_samples=n_samples, substeps=case.config.substeps)
    sim = Simulator(case.setup)
    rows = np.unique(np.linspace(0, n_samples - 1, N_SNAPSHOTS).round().astype(int))
    sink = _Collector(case.node_of_interest, rows)
    stats = sim.run(config, progress=progress, sink=sink)
    data = sink.arrays()
    R = sim.state.rotations
    simulated = float(data["time"][-1] - data["time"][0])
    rod = case.setup.rod
    p = data["positions"]
    E = data["energy"].sum(1)
    summary = {
        "case": case.name, "title": case.title, "paper_section": case.paper_section,
        "node": case.node_of_interest, "length_m": rod.length, "radius_m": rod.radius,
        "youngs_modulus_pa": rod.youngs_modulus, "density_kg_m3": rod.density, "n_nodes": rod.n_nodes,
        "n_samples": n_samples, "dt_s": config.dt, "duration_s": simulated, "step_s": stats.step,
        "substeps": stats.substeps, "stable_step_s": sim.stable_step(config.safety),
        "wall_time_s": stats.wall_time, "us_per_node_step_all_saved": stats.us_per_node_step,
        "realtime_factor_all_saved": simulated / stats.wall_time if stats.wall_time > 0 else None,
        "node_start_m": p[0].tolist(), "node_min_m": p.min(0).tolist(), "node_max_m": p.max(0).tolist(),
        "node_range_mm": (1e3 * (p.max(0) - p.min(0))).tolist(),
        "energy_start_j": float(E[0]), "energy_end_j": float(E[-1]),
        "max_orthogonality_error": float(np.max(np.abs(np.swapaxes(R, 1, 2) @ R - np.eye(3)))),
    }
    return summary, data


def _figures(case: Case, data: dict, fig_dir: Path) -> list[str]:
    names = []
    fig = plotting.node_trajectory(data["time"], data["positions"],
                                   f"{case.name}: node {case.node_of_interest} (analytical model)")
    plotting.save(fig, fig_dir / f"{case.name}_node.png")
    fig = plotting.rod_snapshots(data["snapshot_times"], data["snapshots"], f"{case.name}: configurations",
                                 node=case.node_of_interest, forces=data["snapshot_forces"])
    plotting.save(fig, fig_dir / f"{case.name}_rod.png")
    fig = plotting.energy(data["time"], data["energy"], f"{case.name}: energy")
    plotting.save(fig, fig_dir / f"{case.name}_energy.png")
    names += [f"{case.name}_node.png", f"{case.name}_rod.png", f"{case.name}_energy.png"]
    return names


def _load_if_done(path: Path, quick: bool):
    if not path.exists():
        return None
    try:
        done = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    return done if done.get("quick") == quick and done.get("softrnn_version") == __version__ else None


def reproduce(out_dir, *, quick: bool = False, progress_factory=None) -> dict:
    """Run every step into ``out_dir`` and return the report dictionary.

    ``progress_factory(description)`` returns a progress(done, total) callable (or None).
    """
    out = Path(out_dir)
    (out / "cases").mkdir(parents=True, exist_ok=True)
    fig_dir = out / "figures"
    report = {"softrnn_version": __version__, "quick": quick, "machine": machine_info(),
              "assumptions": ASSUMPTIONS}
    for name in PAPER_CASES:
        case = build_case(name)
        step_file = out / "cases" / f"{name}.json"
        done = _load_if_done(step_file, quick)
        if done is None:
            progress = progress_factory(f"simulate {name}") if progress_factory else None
            summary, data = run_case(case, quick, progress)
            figures = _figures(case, data, fig_dir)
            done = {"quick": quick, "softrnn_version": __version__, "simulation": summary, "figures": figures}
            atomic_write_text(step_file, json.dumps(done, indent=2))
        report[name] = {"node": case.node_of_interest, "length_m": case.setup.rod.length, "unit": "mm",
                        "simulation": done["simulation"], "figures": done["figures"],
                        "paper": paper_case(case.paper_key)}
    bench_file = out / "bench.json"
    bench = _load_if_done(bench_file, quick)
    if bench is None:
        from .bench.simulator import run_benchmark

        progress = progress_factory("benchmark") if progress_factory else None
        bench = {"quick": quick, "softrnn_version": __version__, **run_benchmark(quick=quick, progress=progress)}
        atomic_write_text(bench_file, json.dumps(bench, indent=2))
    report["simulator_benchmark"] = bench
    atomic_write_text(out / "report.json", json.dumps(report, indent=2))
    atomic_write_text(out / "report.md", render_markdown(report))
    return report


def machine_info() -> dict:
    import os

    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return {"cpu": cpu, "cores": os.cpu_count(), "python": platform.python_version(),
            "system": platform.system()}


def render_markdown(report: dict) -> str:
    """The human-readable report: cases, speed beside the paper, assumptions."""
    lines = [f"# softrnn reproduce report (softrnn {report['softrnn_version']}"
             f"{', quick run' if report['quick'] else ''})", "",
             f"Machine: {report['machine']['cpu']}, {report['machine']['cores']} cores, "
             f"Python {report['machine']['python']}.", "",
             "## Simulated cases (paper section 4): analytical model", "",
             "| case | nodes | samples x dt | solver step (substeps) | wall time | us per node-step "
             "(all nodes saved) | paper: us per node-step |",
             "|---|---|---|---|---|---|---|"]
    for name in PAPER_CASES:
        s = report[name]["simulation"]
        paper = report[name]["paper"]
        paper_us = paper.get("analytical_model_s_per_node_step")
        lines.append(
            f"| {name} | {s['n_nodes']} | {s['n_samples']} x {s['dt_s']:g} s | {s['step_s']:.3g} s ({s['substeps']}) "
            f"| {s['wall_time_s']:.2f} s | {s['us_per_node_step_all_saved']:.3f} | "
            f"{paper_us * 1e6:.0f} |" if paper_us else "| - |")
    lines += ["", "Node of interest (0-based), range of motion per axis [mm]:", ""]
    for name in PAPER_CASES:
        s = report[name]["simulation"]
        rng = ", ".join(f"{v:.1f}" for v in s["node_range_mm"])
        lines.append(f"- {name}: node {s['node']}, range [{rng}] mm over {s['duration_s']:g} s; "
                     f"energy {s['energy_start_j']:.4g} J -> {s['energy_end_j']:.4g} J; "
                     f"max |R^T R - I| = {s['max_orthogonality_error']:.1e}")
        for fig in report[name]["figures"]:
            lines.append(f"  ![{fig}](figures/{fig})")
    bench = report["simulator_benchmark"]
    lines += ["", "## Simulator benchmark (`softrnn bench`)", "", "```"]
    try:
        from .bench.simulator import format_table

        lines.append(format_table(bench))
    except Exception:  # a bench result from another version: show the JSON instead
        lines.append(json.dumps(bench.get("simulator", bench), indent=1))
    lines += ["```", "", "## Assumptions (values the paper does not give)", ""]
    for key, text in report["assumptions"].items():
        lines.append(f"- **{key}**: {text}")
    lines.append("")
    return "\n".join(lines)
