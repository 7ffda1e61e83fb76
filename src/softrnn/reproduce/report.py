"""The reproduction report in Markdown (``report.md``, docs/report-format.md) rendered from the
report dictionary that ``softrnn.reproduce.pipeline.reproduce`` returns and writes to ``report.json``."""

import json

from ..scenarios.cases import PAPER_CASES


def render_markdown(report: dict) -> str:
    """The human-readable report (``report.md``) of a ``reproduce`` report dictionary: the data sets,
    the node models beside the paper's errors, the engine, the whole manipulator, the Fig. 14 study,
    the magnetic experiment, the Fig. 13 study, the benchmark and the assumptions."""
    lines = _dataset_lines(report) + _model_lines(report)
    lines += (_engine_lines(report) + _manipulator_lines(report.get("manipulator")) + _fig14_lines(report.get("fig14"))
              + _magnetic_lines(report.get("magnetic")) + _fig13_lines(report.get("fig13")))
    lines += _benchmark_lines(report["benchmark"]) + _assumption_lines(report["assumptions"])
    return "\n".join(lines)


def _dataset_lines(report: dict) -> list[str]:
    """The title, the machine, the simulated data sets beside the paper's speed, and each case's node
    of interest with its figures."""
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
    return lines


def _model_lines(report: dict) -> list[str]:
    """The node models' errors on the test span (one step, free running, generalisation) beside the paper's."""
    lines = ["", "## Learned node models (paper Fig. 2A/2B): errors on the test span [mm]", "",
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
            lines.append(f"| {name} | {key} | {_v(e['mean_abs'])} | {_v(e['max_abs'])} | "
                         f"{_v(e['max_pct_of_length'])} | "
                         f"{_v(p['mean_abs']) if p else ''} | {_v(p['max_abs']) if p else ''} |")
    return lines


def _benchmark_lines(bench: dict) -> list[str]:
    """The benchmark's table (``softrnn.bench.format_all``), or its JSON when it cannot be formatted."""
    lines = ["", "## Benchmark (`softrnn bench`)", "", "```"]
    try:
        from ..bench import format_all

        lines.append(format_all(bench))
    except Exception:  # a bench result from another version: show the JSON instead
        lines.append(json.dumps(bench, indent=1)[:4000])
    return lines + ["```"]


def _assumption_lines(assumptions: dict) -> list[str]:
    """The values the paper does not give, one bullet each."""
    lines = ["", "## Assumptions (values the paper does not give)", ""]
    for key, text in assumptions.items():
        lines.append(f"- **{key}**: {text}")
    lines.append("")
    return lines


def _v(values) -> str:
    """Numbers as "a, b, c" to 3 significant digits; "-" for None."""
    return "-" if values is None else ", ".join(f"{x:.3g}" for x in values)


def _engine_lines(report: dict) -> list[str]:
    """The inference engine against PyTorch, one row per case."""
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
    """The whole manipulator with one shared model: errors by horizon and the stepper's speed."""
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
    lines += ["", f"| horizon | steps | node {m['node']} max abs x, y, z [mm] | max % of length "
                  "| all nodes max abs [mm] |",
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
    """The static solver's solve times (Fig. 13): against tolerance and against the step count."""
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
            f"{nodes['mean_ms'][k][i]:.3f} +- {nodes['std_ms'][k][i]:.3f}"
            for k in range(len(nodes["n_steps"]))) + " |")
    return lines


def _fig14_lines(f: dict | None) -> list[str]:
    """The Fig. 14 study: the best regions beside the paper's, and the trends."""
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
    """A fraction as a signed percentage; "n/a" for None."""
    return "n/a" if x is None else f"{100 * x:+.0f} %"


def _magnetic_lines(m: dict | None) -> list[str]:
    """The magnetic experiment: Table 1 beside the paper's, and the bending axis."""
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
