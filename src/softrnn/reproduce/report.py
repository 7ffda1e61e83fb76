"""The reproduction report in Markdown (``report.md``, docs/report-format.md) rendered from the
report dictionary that ``softrnn.reproduce.pipeline.reproduce`` returns and writes to ``report.json``."""

import json

from ..bench import format_all
from ..scenarios.cases import PAPER_CASES
from ._report_studies import control_lines, fig13_lines, fig14_lines, magnetic_lines


def render_markdown(report: dict) -> str:
    """The human-readable report (``report.md``) of a ``reproduce`` report dictionary: the data sets,
    the node models beside the paper's errors and beside the baselines, the engine, the whole
    manipulator (beside its baselines), the learned whole-manipulator dynamic model of each case, the
    Fig. 14 study, the magnetic experiment, the Fig. 13
    study, the benchmark and the assumptions."""
    lines = _dataset_lines(report) + _model_lines(report)
    lines += (_engine_lines(report) + _manipulator_lines(report.get("manipulator"))
              + _dynamic_lines(report.get("dynamic_model")) + _tendon_lines(report.get("tendons"))
              + fig14_lines(report.get("fig14"))
              + magnetic_lines(report.get("magnetic")) + control_lines(report.get("control"))
              + fig13_lines(report.get("fig13")))
    lines += _benchmark_lines(report["benchmark"]) + _assumption_lines(report["assumptions"])
    return "\n".join(lines)


def _step_time_lines(seconds: dict | None) -> list[str]:
    """One line: this run's wall time per step (``report["step_seconds"]``), and their sum."""
    if not seconds:
        return []
    parts = ", ".join(f"{name} {s / 60:.1f}" for name, s in seconds.items())
    return [f"Wall time per step [min]: {parts}; total {sum(seconds.values()) / 60:.1f} (steps finished by an "
            "earlier run count only their reading).", ""]


def _dataset_lines(report: dict) -> list[str]:
    """The title, the machine, the simulated data sets beside the paper's speed, and each case's node
    of interest with its figures."""
    lines = [f"# softrnn reproduce report (softrnn {report['softrnn_version']}"
             f"{', quick run' if report['quick'] else ''})", "",
             f"Machine: {report['machine']['cpu']}, {report['machine']['cores']} cores, "
             f"Python {report['machine']['python']}.", "",
             *_step_time_lines(report.get("step_seconds")),
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
    """The node models' errors on the test span (one step, free running, generalisation) beside the
    paper's, then beside the baselines."""
    lines = ["", "## Learned node models (paper Fig. 2A/2B): errors on the test span [mm]", "",
             "Trained on the first 60 % of each data set; one step ahead from the reference history (as "
             "the paper evaluates), free running (the node's own predictions fed back, neighbours and "
             "forces from the data), and one step ahead and free running on the generalisation data set.", "",
             "| case | what | mean abs x, y, z | max abs x, y, z | max % of length | paper mean abs | paper max abs |",
             "|---|---|---|---|---|---|---|"]
    for name in PAPER_CASES:
        r = report[name]
        for key, paper_key in (("one_step", "test"), ("rollout", None), ("generalisation", "generalisation"),
                               ("generalisation_rollout", None)):
            e = r.get(key)
            p = r["paper"].get(paper_key) if paper_key else None
            if not e or e.get("diverged"):
                lines.append(f"| {name} | {key} | {_diverged_text(e)} | | | | |")
                continue
            lines.append(f"| {name} | {key} | {_v(e['mean_abs'])} | {_v(e['max_abs'])} | "
                         f"{_v(e['max_pct_of_length'])} | "
                         f"{_v(p['mean_abs']) if p else ''} | {_v(p['max_abs']) if p else ''} |")
    return lines + _model_baseline_lines(report)


def _diverged_text(block: dict | None) -> str:
    """'diverged at t = ... s (sample ...)' for a diverged block, 'not run' for None."""
    if not block:
        return "not run"
    if block.get("time_s") is not None and block.get("sample") is not None:
        return f"diverged at t = {block['time_s']:.4g} s (sample {block['sample']})"
    return "diverged"


_NODE_BASELINES = ("persistence", "constant_velocity", "linear")
_MANIPULATOR_BASELINES = ("persistence", "constant_velocity", "linear_node", "linear_manipulator")
_LABELS = {"persistence": "persistence", "constant_velocity": "constant velocity", "linear": "linear AR",
          "linear_node": "linear AR (node)", "linear_manipulator": "linear AR (manipulator)"}


def _number(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def _cell(x) -> str:
    """A table cell: a number to 3 significant digits, 'diverged', or '-' (not run, skipped)."""
    return f"{x:.3g}" if _number(x) else x if isinstance(x, str) else "-"


def _ratio(model, baselines: dict, labels: dict = _LABELS) -> str:
    """model / the best (smallest) baseline, naming it (``labels``); above 1 a baseline beats the model."""
    known = {k: v for k, v in baselines.items() if _number(v)}
    if not known:
        return "-"
    best = min(known, key=known.get)
    if model == "diverged":
        return f"model diverged ({labels.get(best, best)}: {known[best]:.3g})"
    if not _number(model):
        return "-"
    if known[best] == 0:
        return f"{'1' if model == 0 else 'inf'} ({labels.get(best, best)})"
    return f"{model / known[best]:.3g} ({labels.get(best, best)})"


def _free_value(block: dict | None, key: str):
    """A free-running block's figure ('rmse_mm', or 'max_pct' for the largest axis's % of
    length), 'diverged', or None."""
    if not block:
        return None
    if block.get("diverged"):
        return "diverged"
    if key == "max_pct":
        return max(block["max_pct_of_length"]) if block.get("max_pct_of_length") else None
    return block.get(key)


def _comparison_rows(c: dict) -> list[tuple[str, object, dict]]:
    """(what, model value, {baseline: value}) rows of one ``model.test`` / ``model.generalisation``
    block: RMSE one step and free running [mm], the free run's largest % of length, and by horizon."""
    base = c.get("baselines") or {}
    rows = [("one step RMSE [mm]", (c.get("one_step") or {}).get("rmse_mm"),
             {k: (base.get(k, {}).get("one_step") or {}).get("rmse_mm") for k in _NODE_BASELINES})]
    for what, key in (("free running RMSE [mm]", "rmse_mm"), ("free running max [% of length]", "max_pct")):
        rows.append((what, _free_value(c.get("free_running"), key),
                     {k: _free_value(base.get(k, {}).get("free_running"), key) for k in _NODE_BASELINES}))
    return rows + _horizon_rows(c.get("horizons"), _NODE_BASELINES)


def _horizon_rows(h: dict | None, names: tuple) -> list[tuple[str, object, dict]]:
    """One row per horizon of a ``horizon_table`` (None values: longer than the span)."""
    rows = []
    for key in [k for k in (h or {}) if k.isdigit()] + (["test_span"] if "test_span" in (h or {}) else []):
        what = "whole test span" if key == "test_span" else f"at {key} step{'s' if key != '1' else ''}"
        what += f" [{h.get('unit', '% of length')}]"
        row = h[key]
        rows.append((what, None, None) if row is None else (what, row.get("model"), {k: row.get(k) for k in names}))
    return rows


def _table_row(cells: list[str], model, values: dict | None, n_baselines: int, labels: dict = _LABELS) -> str:
    """A Markdown row: the leading cells, the model, the ``n_baselines`` baselines and the ratio
    (values None: 'longer than the span', the rest empty; ``labels`` name the best baseline)."""
    if values is None:
        return "| " + " | ".join(cells) + " | longer than the span: not evaluated |" + " |" * (n_baselines + 1)
    return ("| " + " | ".join(cells + [_cell(model)] + [_cell(v) for v in values.values()]
                              + [_ratio(model, values, labels)]) + " |")


def _model_baseline_lines(report: dict) -> list[str]:
    """Each node model beside persistence, constant velocity and the linear AR model, on the test
    span and on the generalisation data set, and the plain statements of where a baseline wins."""
    blocks = [(name, span, (report[name].get("model") or {}).get(span)) for name in PAPER_CASES
              for span in ("test", "generalisation")]
    blocks = [b for b in blocks if b[2]]
    if not blocks:
        return []
    lines = ["", "### The node models beside baselines", "",
             "Over the same targets: persistence, constant velocity and a linear AR model (ridge, per node) with "
             "the model's inputs, fitted on the model's training span (on the generalisation data set: on its "
             "first 60 %, which the model never saw). By horizon: the largest error h samples after a free-"
             "running start, over a few starts spread over the span. Ratio = model / best baseline: above 1 a "
             "baseline beats the model.", "",
             "| case | span | what | model | " + " | ".join(_LABELS[k] for k in _NODE_BASELINES)
             + " | model / best baseline |", "|---|---|---|---|" + "---|" * len(_NODE_BASELINES) + "---|"]
    said = []
    for name, span, c in blocks:
        for what, model, values in _comparison_rows(c):
            lines.append(_table_row([name, span, what], model, values, len(_NODE_BASELINES)))
        said += [f"- {name}, {span}: {text}" for text in c.get("misses") or []]
    return lines + [""] + (said or ["No baseline beats the node models on these figures."])


def _benchmark_lines(bench: dict) -> list[str]:
    """The benchmark's table (``softrnn.bench.format_all``), or its JSON when it cannot be formatted."""
    lines = ["", "## Benchmark (`softrnn bench`)", "", "```"]
    try:
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


def _stepper_text(s: dict) -> str:
    """One stepper speed entry, or why it has none (the free-running stepper diverged)."""
    if "diverged" in s:
        return f"not timed on {s['threads']} thread(s): {s['diverged']}"
    return f"{s['median_us']:.1f} us median ({s['hz_median']:,.0f} Hz) on {s['threads']} thread(s)"


def _manipulator_lines(m: dict | None) -> list[str]:
    """The whole manipulator with one shared model: errors by horizon, the stepper's speed, and the
    baselines."""
    if not m:
        return []
    lines = ["", f"## Whole manipulator, one shared model (paper Fig. 2C, beyond the paper): {m['case']}", "",
             f"One {m['architecture']['lstm_layers']} x {m['architecture']['lstm_units']} LSTM shared by the "
             f"{m['modelled_nodes']} interior nodes {m['pool'][0]}..{m['pool'][1]} (neighbours at offsets "
             f"{m['neighbour_offsets']}, relative inputs), trained on the first 60 % (pooled windows); every "
             f"interior node runs free on the test span, fed its own and its neighbours' predictions; "
             f"{m['unmodelled']}."]
    if m.get("diverged"):
        return lines + ["", f"The free run diverged: {m['diverged']}"] + _manipulator_baseline_lines(m)
    lines += ["", f"| horizon | steps | node {m['node']} max abs x, y, z [mm] | max % of length "
                  "| all nodes max abs [mm] |",
              "|---|---|---|---|---|"]
    for key, e in m["errors"].items():
        lines.append(f"| {key} | {e['steps']} | {_v(e['node_max_abs_mm'])} | {_v(e['node_max_pct_of_length'])} | "
                     f"{_v(e['all_nodes_max_abs_mm'])} |")
    lines += ["", f"Holding node {m['node']} at its last seed position would be off by at most "
              f"{_v(m['hold_baseline_node_max_abs_mm'])} mm over the test span. One step of the whole manipulator "
              f"(ManipulatorStepper, {m['modelled_nodes']} nodes): "
              + "; ".join(_stepper_text(s) for s in m["stepper"]) + "."]
    return lines + _manipulator_baseline_lines(m)


def _manipulator_baseline_lines(m: dict) -> list[str]:
    """The whole manipulator's free run beside the baselines' by horizon (% of length), the ratio
    model / best baseline, and the plain statements of where a baseline wins."""
    h = m.get("horizons")
    if not h:
        return []
    names = _MANIPULATOR_BASELINES
    lines = ["", "### The whole manipulator beside baselines", "",
             "Every modelled node runs free from the same seed: persistence, constant velocity, a linear AR "
             "model per node (the shared model's neighbours and force) and one linear AR model of the whole "
             "manipulator, both fitted on the training span. Errors: the largest over the modelled nodes and "
             f"axes [{h.get('unit', '% of length')}], h samples after each of {h.get('n_starts', '?')} starts "
             "spread over the test span, and over the whole test span from its start. Ratio = model / best "
             "baseline: above 1 a baseline beats the model.", "",
             "| horizon | model | " + " | ".join(_LABELS[k] for k in names) + " | model / best baseline |",
             "|---|---|" + "---|" * len(names) + "---|"]
    for what, model, values in _horizon_rows(h, names):
        lines.append(_table_row([what], model, values, len(names)))
    skipped = [f"- {_LABELS[k]} not run: {v['skipped']}" for k, v in (m.get("baselines") or {}).items()
               if isinstance(v, dict) and v.get("skipped")]
    return lines + [""] + (m.get("misses") and [f"- {t}" for t in m["misses"]]
                           or ["No baseline beats the shared model on these figures."]) + skipped


_DYNAMIC_BASELINES = ("persistence", "constant_velocity", "linear")
_DYNAMIC_LABELS = {"persistence": "persistence", "constant_velocity": "constant velocity",
                   "linear": "linear"}
_GOAL_TEXT = {
    "test_span_max_pct_of_length": ("{trajectory} test span, largest error", "< {goal:g} % of L", "{value:.3g} %"),
    "heldout_median_max_pct_of_length": ("held-out variants, median of the largest errors", "< {goal:g} % of L",
                                         "{value:.3g} %"),
    "heldout_worst_max_pct_of_length": ("held-out variants, worst largest error", "< {goal:g} % of L",
                                        "{value:.3g} %"),
    "generalisation_max_pct_of_length": ("generalisation data set, largest error", "< {goal:g} % of L",
                                         "{value:.3g} %"),
    "beats_every_baseline_at_10": ("better than every baseline at 10 model steps", "{goal}", "{value:.3g} %"),
    "beats_every_baseline_at_100": ("better than every baseline at 100 model steps", "{goal}", "{value:.3g} %"),
    "beats_every_baseline_at_1000": ("better than every baseline at 1000 model steps", "{goal}", "{value:.3g} %"),
    "times_better_than_best_baseline_at_100": ("best baseline's error / the model's at 100 model steps",
                                               ">= {goal:g}x", "{value:.3g}x"),
    "speed_ratio_vs_simulator": ("simulated seconds per wall second, model / simulator (one core each)",
                                 ">= {goal:g}x", "{value:.3g}x"),
}


_DYNAMIC_INTRO = (
    "One learned model per case (`softrnn.learned.whole`): a subset of the nodes stepped at the model's own, "
    "coarser step, every node recovered by interpolation along the rod. Trained on the paper "
    "trajectory's first 60 % and on sweep variants of the case's scenario; the last sweep variants "
    "are held out (never trained on). Every predictor runs free (its own predictions fed back, the "
    "loads from the data); errors are the largest distance over all nodes in % of the rod length L. "
    "Baselines: persistence (the state stays), constant velocity (the last step repeats) and the "
    "linear model (ridge, the whole state) on the same inputs. Horizons: the worst over the held-out "
    "variants and a few starts in each, n model steps after the start; '-': diverged, or longer than "
    "the runs. Ratio = model / best baseline: above 1 a baseline beats the model.")
_TENDON_INTRO = (
    "The same model and measures as above, on the tendon-driven arms (`tendon-planar`: two tendons, "
    "`tendon-spatial`: three; `softrnn.reproduce.tendons`). The model's only input is the tendons' "
    "tensions (the data's actuation channels), never the forces and torques they put on the rod. Trained "
    "on the nominal trajectory's first 60 % and sweep variants with other tension profiles; the "
    "generalisation data set is the arm driven by sinusoidal tensions.")


def _dynamic_lines(d: dict | None, title: str = "Whole-manipulator dynamic model (beyond the paper)",
                   intro: str = _DYNAMIC_INTRO, trajectory: str = "paper") -> list[str]:
    """The learned whole-manipulator model of each case: horizons, spans, speed and goals; ``trajectory``:
    what a case's long trajectory is called ("paper", "nominal")."""
    if not d:
        return []
    lines = ["", f"## {title}", "", intro]
    for case, e in d.items():
        if isinstance(e, dict) and "model_dt_s" in e:
            lines += _dynamic_case_lines(case, e, trajectory)
    return lines


def _tendon_lines(d: dict | None) -> list[str]:
    """The tendon arms' whole-manipulator models, driven by their tensions alone (as ``_dynamic_lines``)."""
    return _dynamic_lines(d, "Tendon-driven arms: the whole-manipulator model driven by tensions alone",
                          _TENDON_INTRO, "nominal")


def _or_diverged(value):
    """A held-out figure, or 'diverged' (None: a run diverged, so the median or worst is infinite)."""
    return "diverged" if value is None else value


def _span_value(block: dict | None):
    """A span's largest error [% of L], or 'diverged at step k', or None."""
    if not block:
        return None
    if block.get("max_pct_of_length") is None and block.get("diverged_at") is not None:
        return f"diverged at step {block['diverged_at']}"
    return block.get("max_pct_of_length")


def _dynamic_span_rows(e: dict, trajectory: str = "paper") -> list[tuple[str, object, dict]]:
    """(what, model, {baseline: value}) of the test span, the held-out variants and generalisation."""
    rows = []
    span = e.get("test_span")
    if span:
        rows.append((f"{trajectory} test span {span['start_s']:.3g}-{span['end_s']:.3g} s",
                     _span_value(span.get("model")),
                     {k: _span_value(span.get(k)) for k in _DYNAMIC_BASELINES}))
    held = e.get("heldout")
    if held:
        base = held.get("baselines") or {}
        for key, what in (("median_max_pct_of_length", "median"), ("worst_max_pct_of_length", "worst")):
            rows.append((f"held-out variants ({held['variants']}), {what}", _or_diverged(held.get(key)),
                         {k: _or_diverged((base.get(k) or {}).get(key)) for k in _DYNAMIC_BASELINES}))
    gen = e.get("generalisation")
    if gen:
        rows.append(("generalisation data set", _span_value(gen.get("model")),
                     {k: _span_value(gen.get(k)) for k in _DYNAMIC_BASELINES}))
    return rows


def _goal_line(key: str, g: dict, trajectory: str = "paper") -> str:
    """'- what (goal): met/MISSED, measured ...'."""
    what, goal, value = _GOAL_TEXT.get(key, (key, "{goal}", "{value}"))
    text = f"- {what.format(trajectory=trajectory)} ({goal.format(goal=g.get('goal'))}): "
    if g.get("value") is None:
        return text + f"**missed** ({g.get('note') or 'not measured'})"
    measured = value.format(value=g["value"])
    if g.get("best_baseline"):
        best = _DYNAMIC_LABELS.get(g["best_baseline"], g["best_baseline"])
        measured += f"; best baseline {best}" + (f" {g['best_baseline_value']:.3g} %" if _number(
            g.get("best_baseline_value")) else "")
    return text + ("met" if g.get("met") else "**missed**") + f" ({measured})"


def _dynamic_inputs_text(e: dict) -> str:
    """What drives the model and which weights were kept, as a sentence or two (or '')."""
    text = ""
    nodes = (e.get("inputs") or {}).get("feedback_law_nodes")
    if nodes:
        text += (f" The PD tracking force on node{'s' if len(nodes) > 1 else ''} {', '.join(map(str, nodes))} is "
                 "computed by its law from the model's own state (the target and gains are the inputs), as the "
                 "simulator computes it from the rod's.")
    step = (e.get("training") or {}).get("selected_step")
    if step == 0:
        text += (" Validation free runs kept the linear start (no trained checkpoint beat it): the model is the "
                 "linear model.")
    elif step is not None:
        text += f" Validation free runs kept the weights of step {step}."
    return text


def _dynamic_case_lines(case: str, e: dict, trajectory: str = "paper") -> list[str]:
    """One case: settings, the horizons and spans beside the baselines, speed, goals, figure;
    ``trajectory``: what the case's long trajectory is called ("paper", "nominal")."""
    sweep, n = e.get("sweep") or {}, len(_DYNAMIC_BASELINES)
    lines = ["", f"### {case}", "",
             f"Model step {e['model_dt_s']:g} s, {e['predicted_nodes']} of {e.get('nodes', '?')} nodes predicted; "
             f"trained in {e.get('train_seconds', 0):.0f} s ({(e.get('train_config') or {}).get('steps', '?')} "
             f"steps) on the {trajectory} trajectory's first 60 % and {sweep.get('n_train', '?')} sweep variants "
             f"({sweep.get('duration_s', '?')} s saved every {sweep.get('dt', '?')} s); "
             f"{sweep.get('n_heldout', '?')} held out." + _dynamic_inputs_text(e), "",
             "| what [% of L] | model | " + " | ".join(_DYNAMIC_LABELS[k] for k in _DYNAMIC_BASELINES)
             + " | model / best baseline |", "|---|---|" + "---|" * n + "---|"]
    for key in ("10", "100", "1000"):
        row = (e.get("horizons") or {}).get(key) or {}
        lines.append(_table_row([f"at {key} model steps"], row.get("model"),
                                {k: row.get(k) for k in _DYNAMIC_BASELINES}, n, _DYNAMIC_LABELS))
    for what, model, values in _dynamic_span_rows(e, trajectory):
        lines.append(_table_row([what], model, values, n, _DYNAMIC_LABELS))
    if _number(e.get("speed_ratio_vs_simulator")):
        lines += ["", f"Speed, one core each: the simulator {e['simulator_sim_s_per_wall_s']:.3g} simulated s per "
                      f"wall s, the model {e['model_sim_s_per_wall_s']:.3g}: {e['speed_ratio_vs_simulator']:.3g}x."]
    lines += ["", "Goals:"] + [_goal_line(k, g, trajectory) for k, g in (e.get("goals") or {}).items()]
    if e.get("figure"):
        lines += ["", f"![dynamic {case}](figures/{e['figure']})"]
    if e.get("rollout"):
        lines += ["", f"The free run over the test span, every node: `{e['rollout']}` (`softrnn animate`)."]
    return lines
