"""softrnn evaluate MODEL DATA.h5 [--json out.json] [--figures DIR] [--generalisation]: a node model's
errors per axis [mm] and RMSE(t) (paper Eq. 2), one step ahead and free running, beside the paper's
and beside the baselines (persistence, constant velocity, a linear AR model; by horizon too)."""

import json
from pathlib import Path

from ..files import atomic_write_text, prepare_output
from ._progress import Bar

NAME = "evaluate"
HELP = ("evaluate a trained node model on a data set: max/mean errors per axis [mm] and in percent of the rod "
        "length, and RMSE(t), one step ahead and free running, beside the paper's figures and beside baselines "
        "(persistence, constant velocity, linear AR), also by horizon (1, 10, 100, 1000 steps)")


def add_args(p):
    p.add_argument("model", help="a model folder written by 'softrnn train'")
    p.add_argument("data", help="an HDF5 data set storing the model's node and neighbours")
    p.add_argument("--group", default=None, help="the trajectory's group inside a sweep file")
    p.add_argument("--generalisation", action="store_true",
                   help="evaluate on the whole record (data of another scenario the model never saw) "
                        "instead of the test span (a model trained with --validate-on is always evaluated on "
                        "the whole record)")
    p.add_argument("--json", default=None, metavar="PATH", help="also write the report as JSON")
    p.add_argument("--figures", default=None, metavar="DIR",
                   help="write predicted vs reference per axis (prediction.png), RMSE(t) (rmse.png) and "
                        "the RMSE(t) series (rmse_t.csv) to this folder")
    p.add_argument("--no-free-running", action="store_true",
                   help="only the one-step-ahead evaluation (of the model and the baselines; no horizons)")
    p.add_argument("--overwrite", action="store_true",
                   help="replace the --json file and the --figures files if they exist (default: refuse)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def run(args) -> int:
    from ..figures.evaluation import FIGURE_FILES, write_figures
    from ..learned.node.artifact import load_model
    from ..learned.node.evaluate import evaluate

    if args.json:
        prepare_output(args.json, "--json", overwrite=args.overwrite)
    if args.figures:
        prepare_output(args.figures, "--figures", kind="folder", overwrite=args.overwrite, holds=FIGURE_FILES,
                       fix="pass --overwrite to replace them, or choose another folder")
    model = load_model(args.model)
    with Bar(f"free-running {Path(args.data).name}", unit="step",
             enabled=not args.quiet and not args.no_free_running) as bar:
        ev = evaluate(model, args.data, group=args.group, generalisation=args.generalisation,
                      free=not args.no_free_running, progress=bar, model_name=str(args.model),
                      linear_fit="training data")
    report = ev.to_dict()
    print(format_report(report))
    if args.json:
        atomic_write_text(args.json, json.dumps(report, indent=2) + "\n")
        print(f"evaluate: wrote {args.json}")
    if args.figures:
        for path in write_figures(ev, args.figures):
            print(f"evaluate: wrote {path}")
    return 0


def _row(label: str, values, fmt: str = "{:9.3g}") -> str:
    if values is None:
        return f"  {label:<36}" + "".join(f"{'-':>9}" for _ in range(3))
    return f"  {label:<36}" + "".join(fmt.format(v) for v in values)


def format_report(r: dict) -> str:
    """The text ``softrnn evaluate`` prints for an ``Evaluation.to_dict()`` report."""
    neigh = ", ".join(map(str, r["neighbours"])) or "none"
    wrench = {"none": "", "force": " + force", "wrench": " + force, torque"}.get(r["wrench"], "")
    if r.get("channels"):
        wrench += " + actuation " + ", ".join(r["channels"])
    name = f" ({r['scenario_name']})" if r.get("scenario_name") else ""
    lines = [f"evaluate: node {r['node']} (neighbours {neigh}; history {r['history']}; {r['inputs']}{wrench}) "
             f"of {r['model'] or 'the model'} on {r['data'] or 'the data'}{name}"]
    length = f"rod length {r['length_m']:g} m" if r.get("length_m") else "rod length unknown (no % of length)"
    lines.append(f"  span: {r['span']}, samples {r['span_samples'][0]}..{r['span_samples'][1]} "
                 f"(t = {r['span_s'][0]:g} .. {r['span_s'][1]:g} s, {r['n_targets']} targets); {length}")
    if r.get("trained_on") and r.get("scenario_name") and r["trained_on"] != r["scenario_name"] \
            and r["span"] == "test":
        lines.append(f"  note: the model was trained on {r['trained_on']!r}; for another scenario's data, "
                     f"--generalisation evaluates the whole record")
    if r["span"] == "training data":
        lines.append("  note: this is the model's TRAINING data (it trained on every sample of it): these are "
                     "training errors; evaluate on a separate test session for test errors")
    elif r["span"] == "whole record":
        lines.append(f"  free running from the record's start: its first {r['history']} samples are the initial "
                     f"condition")
    lines.append(f"  {'':<36}{'x':>9}{'y':>9}{'z':>9}")
    blocks = [("one step", r["one_step"])]
    fr = r.get("free_running")
    if fr and not fr["diverged"]:
        blocks.append(("free running", fr))
    paper = r.get("paper")
    if paper:
        blocks.append((f"paper {paper['section']} {paper['figures']}", paper))
    for label, m in blocks:
        lines.append(_row(f"{label}: max [mm]", m["max_abs_mm"]))
        lines.append(_row("  mean [mm]", m["mean_abs_mm"]))
        lines.append(_row("  max [% of length]", m["max_pct_of_length"]))
    rmse = [f"one step {r['one_step']['rmse_mm']:.3g} mm (max {r['one_step']['max_rmse_t_mm']:.3g})"]
    if fr and not fr["diverged"]:
        rmse.append(f"free running {fr['rmse_mm']:.3g} mm (max {fr['max_rmse_t_mm']:.3g}; {_fed(r)})")
    lines.append("  RMSE over the span: " + ", ".join(rmse))
    euclid = [f"one step {_euclid(r['one_step'])}"]
    if fr and not fr["diverged"]:
        euclid.append(f"free running {_euclid(fr)}")
    lines.append("  Euclidean error over the span (RMSE, mean): " + "; ".join(euclid))
    if fr and fr["diverged"]:
        lines.append(f"  free running: diverged at t = {fr['time_s']:g} s (sample {fr['sample']}): the model's "
                     f"prediction left the +-16 m range when fed its own outputs")
    if paper and paper.get("predicted_node") is not None:
        lines.append(f"  (the paper's figures are for its node {paper['predicted_node']}, as the paper numbers it)")
    return "\n".join(lines + baseline_lines(r))


def _fed(r: dict) -> str:
    """What free running takes from the reference besides the node's own predictions."""
    given = [w for w, on in (("neighbours", r["neighbours"]), ("wrench", r["wrench"] != "none"),
                             ("actuation", r.get("channels"))) if on]
    return " and ".join(given) + " from the reference" if given else "its own predictions only"


def _euclid(m: dict) -> str:
    """'RMSE x mm, mean y mm (a, b % of length)' of a block's Euclidean errors."""
    if m.get("rmse_euclidean_mm") is None:
        return "-"
    text = f"{m['rmse_euclidean_mm']:.3g} mm, {m['mean_euclidean_mm']:.3g} mm"
    if m.get("rmse_euclidean_pct_of_length") is not None:
        text += f" ({m['rmse_euclidean_pct_of_length']:.3g}, {m['mean_euclidean_pct_of_length']:.3g} % of length)"
    return text


_COLUMNS = {"model": "model", "persistence": "persistence", "constant_velocity": "const. vel.", "linear": "linear AR"}


def _cell(value, fmt: str = "{:.3g}") -> str:
    """A table cell: a number, 'diverged', or '-' (not run)."""
    if isinstance(value, str):
        return f"{value:>12}"
    return f"{'-':>12}" if value is None else f"{fmt.format(value):>12}"


def _max_pct(block) -> float | str | None:
    """The largest of a free-running block's per-axis % of length, 'diverged', or None."""
    if not block:
        return None
    if block.get("diverged"):
        return "diverged"
    pct = block.get("max_pct_of_length")
    return None if pct is None else max(pct)


def baseline_lines(r: dict) -> list[str]:
    """The table of the model beside the baselines (one step, free running, by horizon) and the
    plain statements of where a baseline beats the model, for an ``Evaluation.to_dict()`` report."""
    from ..learned.node.comparison import horizon_keys

    base = r.get("baselines")
    if not base:
        return []
    lin = base.get("linear", {})
    fitted = lin.get("fitted_on", {}).get("what", "?")
    where = f" [{lin['linear_fitted_on']}]" if lin.get("linear_fitted_on") else ""
    lines = [f"  beside baselines over the same targets; linear AR (ridge, per node) on {lin.get('inputs', '?')}, "
             f"fitted on {fitted}{where}" + (f"; not fitted: {lin['skipped']}" if "skipped" in lin else ""),
             f"  {'':<36}" + "".join(f"{v:>12}" for v in _COLUMNS.values())]
    blocks = {"model": r}
    blocks.update({k: base.get(k) or {} for k in _COLUMNS if k != "model"})

    def free(b):
        fr = b.get("free_running")
        return None if not fr else "diverged" if fr.get("diverged") else fr["rmse_mm"]

    def free_euclid(b):
        fr = b.get("free_running")
        return None if not fr else "diverged" if fr.get("diverged") else fr.get("rmse_euclidean_mm")

    rows = [("one step RMSE [mm]", [b.get("one_step", {}).get("rmse_mm") for b in blocks.values()]),
            ("free running RMSE [mm]", [free(b) for b in blocks.values()]),
            ("one step Euclidean RMSE [mm]", [b.get("one_step", {}).get("rmse_euclidean_mm") for b in blocks.values()]),
            ("free running Euclidean RMSE [mm]", [free_euclid(b) for b in blocks.values()]),
            ("free running max [% of length]", [_max_pct(b.get("free_running")) for b in blocks.values()])]
    h = r.get("horizons")
    unit = (h or {}).get("unit", "% of length")
    for key in horizon_keys(h):
        row = h[key]
        label = f"at {key} step{'s' if key != '1' else ''}: max [{unit}]"
        rows.append((label, None if row is None else [row.get(k) for k in _COLUMNS]))
    for label, values in rows:
        if values is None:
            lines.append(f"  {label:<36}  (longer than the span: not evaluated)")
        else:
            lines.append(f"  {label:<36}" + "".join(_cell(v) for v in values))
    said = r.get("misses") or []
    lines += [f"  {s}" for s in said] or ["  no baseline beats the model on these figures"]
    return lines
