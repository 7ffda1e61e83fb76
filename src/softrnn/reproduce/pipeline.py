"""``softrnn reproduce``: the paper's pipeline, step by step, into one output folder.

The steps: the data sets of the three simulated cases (section 4, Data-sets I-III) and of their
generalisation variants (``data/*.h5``) with figures and animations; the node model of each case
(trained, evaluated one step ahead and free running, generalised, checked against PyTorch); the
whole semicircle with one shared model (Fig. 2C); the magnetic experiment simulated (section 5,
Table 1, Fig. 12); the static solver's Fig. 13 study; the Fig. 14 hyper-parameter study;
``softrnn bench``; then ``report.json`` and ``report.md`` (docs/report-format.md). Each finished step
leaves its files and a step file; a rerun (after an interruption) skips the steps whose results
are present for the same settings and version.
"""

import json
import platform
import shutil
from dataclasses import replace
from pathlib import Path

import numpy as np

from .. import __version__
from ..figures import pictures
from ..figures import plots as plotting
from ..files import atomic_write_text
from ..paper import paper_case
from ..scenarios.cases import ASSUMPTIONS, PAPER_CASES, Case, build_case
from ..scenarios.summary import simulate_summary
from .steps import (
    engine_agreement,
    fig13_step,
    fig14_step,
    load_step,
    magnetic_step,
    manipulator_step,
)

QUICK_FRACTION = 0.1  # --quick simulates this fraction of each case's duration
N_SNAPSHOTS = 6
GENERALISATION = {"ellipse": "ellipse-horizontal", "square": "square-figure8", "semicircle": "semicircle-cosine"}


def run_case(case: Case, quick: bool, data_path, progress=None) -> tuple[dict, dict]:
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
        progress=progress, series=series)
    summary["paper_section"] = case.paper_section
    summary["node_range_mm"] = (1e3 * (series["node_positions"].max(0) - series["node_positions"].min(0))).tolist()
    summary["density_kg_m3"] = case.setup.rod.density
    return summary, series


def _figures(case: Case, data_path: Path, series: dict, fig_dir: Path) -> list[str]:
    """Node trajectory, rod snapshots with forces, energy, and an animation of the dataset."""
    from ..io.dataset import read_dataset

    t = series["time"]
    fig = plotting.node_trajectory(t, series["node_positions"],
                                   f"{case.name}: node {case.node_of_interest} (analytical model)")
    plotting.save(fig, fig_dir / f"{case.name}_node.png")
    rows = np.unique(np.linspace(0, t.size - 1, N_SNAPSHOTS).round().astype(int))
    snaps = [read_dataset(data_path, start=int(i), stop=int(i) + 1) for i in rows]
    fig = plotting.rod_snapshots(t[rows], np.concatenate([d.positions for d in snaps]).astype(float),
                                 f"{case.name}: configurations", node=case.node_of_interest,
                                 forces=np.concatenate([d.forces for d in snaps]).astype(float))
    plotting.save(fig, fig_dir / f"{case.name}_rod.png")
    fig = plotting.energy(t, series["energy"], f"{case.name}: energy")
    plotting.save(fig, fig_dir / f"{case.name}_energy.png")
    pictures.animate(pictures.load(data_path), fig_dir / f"{case.name}.gif", node=case.node_of_interest,
                     max_frames=120)
    return [f"{case.name}_node.png", f"{case.name}_rod.png", f"{case.name}_energy.png", f"{case.name}.gif"]


_load_if_done = load_step   # a finished step's file (same settings and version), else None


def _case_step(case: Case, out: Path, quick: bool, progress_factory, figures: bool) -> dict:
    """Dataset (and figures) of one case, skipped when a finished result is present."""
    step_file = out / "cases" / f"{case.name}.json"
    data_path = out / "data" / f"{case.name}.h5"
    done = _load_if_done(step_file, quick)
    if done is not None and data_path.exists():
        return done
    progress = progress_factory(f"simulate {case.name}") if progress_factory else None
    summary, series = run_case(case, quick, data_path, progress)
    names = _figures(case, data_path, series, out / "figures") if figures else []
    done = {"quick": quick, "softrnn_version": __version__, "simulation": summary, "figures": names,
            "dataset": str(data_path.relative_to(out))}
    atomic_write_text(step_file, json.dumps(done, indent=2))
    return done


WRENCH = {"ellipse": "none", "square": "force", "semicircle": "force"}  # paper Fig. 2A / 2B
QUICK_TRAIN = {"epochs": 4, "max_train_windows": 3000, "rollout_steps": 2}


def _errors(block: dict | None) -> dict | None:
    """The report's error shape: max_abs, mean_abs [mm] and max_pct_of_length as [x, y, z]."""
    if block is None or block.get("diverged"):
        return block
    return {"max_abs": block["max_abs_mm"], "mean_abs": block["mean_abs_mm"],
            "max_pct_of_length": block["max_pct_of_length"]}


def _model_step(name: str, out: Path, quick: bool, progress_factory) -> dict:
    """Train the case's node model on the first 60 % of its data set, evaluate it one step ahead and
    free running on the test span, and on the generalisation data set; skipped when done."""
    from ..figures.evaluation import write_figures
    from ..surrogate.data import SampleSpec
    from ..surrogate.evaluate import evaluate
    from ..surrogate.train import TrainConfig, train_node_model

    step_file = out / "models" / f"{name}.json"
    done = _load_if_done(step_file, quick)
    if done is not None:
        return done
    case = build_case(name)
    data = out / "data" / f"{name}.h5"
    folder = out / "models" / name
    if step_file.exists() and folder.exists():
        # finished earlier with other settings (--quick or another version): train afresh;
        # without a step file the folder is an interrupted training, which resumes
        shutil.rmtree(folder)
    spec = SampleSpec(node=case.node_of_interest, wrench=WRENCH[name])
    train = TrainConfig(**QUICK_TRAIN) if quick else TrainConfig()
    progress = progress_factory(f"train {name}") if progress_factory else None
    bar = None if progress is None else (lambda done, total, info=None: progress(done, total))
    model = train_node_model(data, spec, None, train, folder, resume=True, progress=bar)
    test = evaluate(model, data, model_name=name)
    gen = evaluate(model, out / "data" / f"{GENERALISATION[name]}.h5", generalisation=True, model_name=name)
    figures = []
    for tag, ev in (("test", test), ("generalisation", gen)):
        paths = write_figures(ev, out / "figures" / f"{name}_model_{tag}")
        figures += [str(p.relative_to(out / "figures")) for p in paths if p.suffix == ".png"]
    tj, gj = test.to_json(), gen.to_json()
    span = model.meta["test_span"]
    engine = engine_agreement(model, data, int(span[0]) + model.spec.history, int(span[1]))
    done = {"quick": quick, "softrnn_version": __version__, "engine_vs_pytorch": engine,
            "one_step": _errors(tj["one_step"]),
            "rollout": _errors(tj["free_running"]), "generalisation": _errors(gj["one_step"]),
            "generalisation_rollout": _errors(gj["free_running"]), "test_span_s": tj.get("span_s"),
            "model": {"folder": f"models/{name}", "spec": model.spec.to_dict(),
                      "training": model.meta.get("training")}, "figures": figures}
    atomic_write_text(step_file, json.dumps(done, indent=2, default=str))
    return done


def _paper_errors(paper: dict) -> dict:
    """The paper's test and generalisation figures in the report's shape, beside its raw entry."""
    out = dict(paper)
    for key in ("test", "generalisation"):
        block = paper.get(key, {})
        out[key] = {"max_abs": block.get("max_abs_mm"), "mean_abs": block.get("mean_abs_mm"),
                    "max_pct_of_length": block.get("max_pct_of_length")}
    return out


def reproduce(out_dir, *, quick: bool = False, progress_factory=None) -> dict:
    """Run every step into ``out_dir`` and return the report dictionary.

    ``progress_factory(description)`` returns a progress(done, total) callable (or None).
    """
    out = Path(out_dir)
    (out / "cases").mkdir(parents=True, exist_ok=True)
    report = {"softrnn_version": __version__, "quick": quick, "machine": machine_info(),
              "assumptions": ASSUMPTIONS}
    for name in PAPER_CASES:
        report[name] = {"paper": _paper_errors(paper_case(build_case(name).paper_key))}
        for key, case_name in (("simulation", name), ("generalisation_data", GENERALISATION[name])):
            case = build_case(case_name)
            done = _case_step(case, out, quick, progress_factory, figures=key == "simulation")
            report[name][key] = done["simulation"]
            if key == "simulation":
                report[name].update(node=case.node_of_interest, length_m=case.setup.rod.length, unit="mm",
                                    figures=done["figures"], dataset=done["dataset"])
    for name in PAPER_CASES:
        result = _model_step(name, out, quick, progress_factory)
        for key in ("one_step", "rollout", "generalisation", "generalisation_rollout", "model", "test_span_s",
                    "engine_vs_pytorch"):
            report[name][key] = result.get(key)
        report[name]["figures"] = report[name]["figures"] + result["figures"]
    report["manipulator"] = manipulator_step(out, quick, progress_factory)
    report["magnetic"] = magnetic_step(out, quick, progress_factory)
    report["fig13"] = fig13_step(out, quick)
    report["fig14"] = fig14_step(out, quick, progress_factory)
    bench_file = out / "bench.json"
    bench = _load_if_done(bench_file, quick)
    if bench is None or "model" not in bench:
        from ..bench import run_all

        progress = progress_factory("benchmark") if progress_factory else None
        bench = {"quick": quick, "softrnn_version": __version__, **run_all(quick=quick, progress=progress)}
        atomic_write_text(bench_file, json.dumps(bench, indent=2))
    report["benchmark"] = bench
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
             "## Datasets of the simulated cases (paper section 4): analytical model", "",
             "Every node saved at every sample (`data/*.h5`, docs/dataset-format.md). Time = simulation "
             "and writing the file.", "",
             "| case | data set | nodes | samples x dt | solver step (substeps) | time | us per node-step "
             "| paper: us per node-step |",
             "|---|---|---|---|---|---|---|---|"]
    for name in PAPER_CASES:
        paper_us = report[name]["paper"].get("analytical_model_s_per_node_step")
        for key in ("simulation", "generalisation_data"):
            s = report[name][key]
            role = "training/test" if key == "simulation" else "generalisation"
            lines.append(
                f"| {s['case']} | {role} | {s['n_nodes']} | {s['n_samples']} x {s['dt_s']:g} s | "
                f"{s['step_s']:.3g} s ({s['substeps']}) | {s['total_time_s']:.2f} s | {s['us_per_node_step']:.3f} | "
                + (f"{paper_us * 1e6:.0f} |" if paper_us and key == "simulation" else "|"))
    lines += ["", "Node of interest (0-based), range of motion per axis [mm]:", ""]
    for name in PAPER_CASES:
        s = report[name]["simulation"]
        rng = ", ".join(f"{v:.1f}" for v in s["node_range_mm"])
        lines.append(f"- {name}: node {s['node']}, range [{rng}] mm over {s['duration_s']:g} s; "
                     f"energy {s['energy_start_j']:.4g} J -> {s['energy_end_j']:.4g} J; "
                     f"max |R^T R - I| = {s['max_orthogonality_error']:.1e}")
        for fig in report[name]["figures"]:
            lines.append(f"  ![{fig}](figures/{fig})")
    lines += ["", "## Learned node models (paper Fig. 2A/2B): errors on the test span [mm]", "",
              "Trained on the first 60 % of each data set; one step ahead from the reference history (as "
              "the paper evaluates), free running (the node's own predictions fed back, neighbours and "
              "forces from the data), and one step ahead on the generalisation data set.", "",
              "| case | what | mean abs x, y, z | max abs x, y, z | max % of length | paper mean abs | paper max abs |",
              "|---|---|---|---|---|---|---|"]
    for name in PAPER_CASES:
        r = report[name]
        for key, paper_key in (("one_step", "test"), ("rollout", None), ("generalisation", "generalisation")):
            e = r.get(key)
            p = r["paper"].get(paper_key) if paper_key else None
            if not e or e.get("diverged"):
                lines.append(f"| {name} | {key} | diverged | | | | |")
                continue
            lines.append(f"| {name} | {key} | {_v(e['mean_abs'])} | {_v(e['max_abs'])} | {_v(e['max_pct_of_length'])} | "
                         f"{_v(p['mean_abs']) if p else ''} | {_v(p['max_abs']) if p else ''} |")
    lines += (_engine_lines(report) + _manipulator_lines(report.get("manipulator")) + _fig14_lines(report.get("fig14"))
              + _magnetic_lines(report.get("magnetic")) + _fig13_lines(report.get("fig13")))
    bench = report["benchmark"]
    lines += ["", "## Benchmark (`softrnn bench`)", "", "```"]
    try:
        from ..bench import format_all

        lines.append(format_all(bench))
    except Exception:  # a bench result from another version: show the JSON instead
        lines.append(json.dumps(bench, indent=1)[:4000])
    lines += ["```", "", "## Assumptions (values the paper does not give)", ""]
    for key, text in report["assumptions"].items():
        lines.append(f"- **{key}**: {text}")
    lines.append("")
    return "\n".join(lines)


def _v(values) -> str:
    return "-" if values is None else ", ".join(f"{x:.3g}" for x in values)


def _engine_lines(report: dict) -> list[str]:
    lines = ["", "## Inference engine against PyTorch (free-running rollout over each test span)", "",
             "| case | steps | max abs difference [m] | engine [s] | PyTorch [s] |", "|---|---|---|---|---|"]
    for name in PAPER_CASES:
        e = report[name].get("engine_vs_pytorch") or {}
        if "max_abs_difference_m" in e:
            lines.append(f"| {name} | {e['steps']} | {e['max_abs_difference_m']:.2g} | {e['engine_s']:.3f} | "
                         f"{e['pytorch_s']:.2f} |")
        elif e:
            lines.append(f"| {name} | {e.get('steps')} | diverged | | |")
    return lines


def _manipulator_lines(m: dict | None) -> list[str]:
    if not m:
        return []
    lines = ["", f"## Whole manipulator, one shared model (paper Fig. 2C, beyond the paper): {m['case']}", "",
             f"One {m['architecture']['lstm_layers']} x {m['architecture']['lstm_units']} LSTM shared by the "
             f"{m['modelled_nodes']} interior nodes {m['pool'][0]}..{m['pool'][1]} (neighbours at offsets "
             f"{m['neighbour_offsets']}, relative inputs), trained on the first 60 % (pooled windows); every "
             f"interior node runs free on the test span, fed its own and its neighbours' predictions; "
             f"{m['unmodelled']}."]
    if m.get("diverged"):
        return lines + ["", f"The free run diverged: {m['diverged']}"]
    lines += ["", f"| horizon | steps | node {m['node']} max abs x, y, z [mm] | max % of length | all nodes max abs [mm] |",
              "|---|---|---|---|---|"]
    for key, e in m["errors"].items():
        lines.append(f"| {key} | {e['steps']} | {_v(e['node_max_abs_mm'])} | {_v(e['node_max_pct_of_length'])} | "
                     f"{_v(e['all_nodes_max_abs_mm'])} |")
    lines += ["", f"Holding node {m['node']} at its last seed position would be off by at most "
              f"{_v(m['hold_baseline_node_max_abs_mm'])} mm over the test span. One step of the whole manipulator "
              f"(ManipulatorStepper, {m['modelled_nodes']} nodes): "
              + "; ".join(f"{s['median_us']:.1f} us median ({s['hz_median']:,.0f} Hz) on {s['threads']} thread(s)"
                          for s in m["stepper"]) + "."]
    return lines


def _fig13_lines(f: dict | None) -> list[str]:
    if not f:
        return []
    s = f["summary"]
    tol, nodes = s["tolerance_sweep"], s["node_sweep"]
    lines = ["", "## Static Cosserat solver: solve time (paper Fig. 13)", "",
             f"Mean +- std of {s['repetitions']} solves per point; rows: guess error "
             f"{', '.join(f'{100 * e:g} %' for e in s['guess_errors'])}. Paper: "
             f"{s['paper']['solve_time_ms'][0]:g}-{s['paper']['solve_time_ms'][1]:g} ms per solve "
             f"({s['paper']['bandwidth_hz'][0]:g}-{s['paper']['bandwidth_hz'][1]:g} Hz) on an i7 laptop.", "",
             f"![fig13](figures/{f['figure']})", "",
             f"| N = {tol['n_steps']}, tolerance E | " + " | ".join(f"{t:g}" for t in tol["tolerances"]) + " |",
             "|---|" + "---|" * len(tol["tolerances"])]
    for i, e in enumerate(s["guess_errors"]):
        lines.append(f"| guess error {100 * e:g} % [ms] | " + " | ".join(
            f"{tol['mean_ms'][k][i]:.3f} +- {tol['std_ms'][k][i]:.3f}" for k in range(len(tol["tolerances"]))) + " |")
    lines += ["", f"| E = {nodes['tol']:g}, steps N | " + " | ".join(str(n) for n in nodes["n_steps"]) + " |",
              "|---|" + "---|" * len(nodes["n_steps"])]
    for i, e in enumerate(s["guess_errors"]):
        lines.append(f"| guess error {100 * e:g} % [ms] | " + " | ".join(
            f"{nodes['mean_ms'][k][i]:.3f} +- {nodes['std_ms'][k][i]:.3f}" for k in range(len(nodes["n_steps"]))) + " |")
    return lines


def _fig14_lines(f: dict | None) -> list[str]:
    if not f:
        return []
    lines = ["", f"## LSTM units x history (paper Fig. 14): {f['case']}, node {f['node']}", "",
             f"![fig14](figures/{f['figure']})", ""]
    for key, what in (("bandwidth", "compiled stepper bandwidth"), ("torch_bandwidth", "eager PyTorch bandwidth"),
                      ("rms_error", "one-step RMS error")):
        r = (f.get("regions") or {}).get(key)
        if not r:
            continue
        pts = ", ".join(f"({u}, {h})" for u, h in r["points"])
        p = r["paper"]
        lines.append(f"- {what}: best region (units, history) {pts}; the paper's: units {p['lstm_units'][0]}-"
                     f"{p['lstm_units'][1]}, history {p['history'][0]}-{p['history'][1]} "
                     f"({100 * r['fraction_in_paper_region']:.0f} % of ours inside it)")
    t = f.get("trends") or {}
    lines.append(f"- trends from the smallest to the largest grid value: bandwidth {_pct(t.get('bandwidth_vs_units'))} "
                 f"with units, {_pct(t.get('bandwidth_vs_history'))} with history; RMS error "
                 f"{_pct(t.get('rms_error_vs_units'))} with units, {_pct(t.get('rms_error_vs_history'))} with history")
    return lines


def _pct(x) -> str:
    return "n/a" if x is None else f"{100 * x:+.0f} %"


def _magnetic_lines(m: dict | None) -> list[str]:
    if not m:
        return []
    axes = "xyz"
    lines = ["", "## The magnetic experiment, simulated (paper section 5, Table 1)", "",
             "Errors (max, mean) in degrees about x, y, z on the last 40 % of the samples: the LSTM one step ahead "
             "from the measured history (as the paper), the LSTM free running, and the static Cosserat model from the "
             "coil currents. The simulated robot's parameters are perturbed from the static model's (see "
             "docs/magnetic-format.md).", "",
             "| magnet | model | x | y | z | paper x | paper y | paper z |", "|---|---|---|---|---|---|---|---|"]
    paper = m.get("paper", {})
    for magnet in ("distal", "proximal"):
        for key, label, pkey in (("rnn", "LSTM (one step)", "rnn"), ("rnn_free_running", "LSTM (free running)", None),
                                 ("cosserat", "static Cosserat", "cosserat")):
            row = m[magnet].get(key)
            if row is None:
                continue
            p = paper.get(magnet, {}).get(pkey) if pkey else None
            cells = [f"{a:.2f}, {b:.2f}" for a, b in row]
            pcells = [f"{a:.2f}, {b:.2f}" for a, b in p] if p else ["", "", ""]
            lines.append(f"| {magnet} | {label} | " + " | ".join(cells) + " | " + " | ".join(pcells) + " |")
    bend = m.get("bending_axis")
    if bend is not None:
        name = axes[bend] if isinstance(bend, int) else str(bend)
        wins = m.get("lstm_beats_static_on_bending_axis") or {}
        lines += ["", f"Bending axis: {name}. The LSTM's mean error is below the static model's there: distal "
                      f"{wins.get('distal')}, proximal {wins.get('proximal')}."]
    lines += ["", "![fig12](figures/fig12.png)"]
    return lines
