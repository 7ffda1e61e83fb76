"""Every figure a guide page quotes from `softrnn reproduce` is the reference run's
(docs/results/reference: report.json, run.json), rounded as the page shows it, and no guide page
sends the reader to the README for results (the README is a front page; the results are on the
Results page, docs/results/index.md).

FIGURES lists, per quoted passage: the page, the exact text (whitespace, line breaks included,
counts as one space), and each figure in it with where it comes from and its rounding. A source is
a path into report.json, keys and list indices separated by "/" ("run:" for run.json), optionally
wrapped in max(...), min(...) (over every number below the path) or ratio(A, B) (A / B), and
optionally followed by " * k" or " / k" (a unit change). The rounding is a Python format spec
(".3g" is report.md's three significant digits); a null value reads "-".

CLAIMS lists the passages that state a yes/no or a name: the page, the text, the path and the
value the report must hold.

When a new reference run changes a figure, a test here names the page and the passage to update.
"""

import json
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
REFERENCE = ROOT / "docs" / "results" / "reference"
GUIDE = ROOT / "docs" / "guide"

# The pages whose reproduction figures are checked here (docs/guide/NAME, or a path from the root).
PAGES = ["benchmarks.md", "models.md", "reproduce.md", "magnetics.md", "statics.md", "control.md",
         "dynamic.md", "calibration.md", "lab-workflow.md", "benchmarks/README.md"]

_TENDON_ROW = "| {} | {} | {} | {} |"

FIGURES = [
    # page, quoted text, ((figure, source, rounding), ...)
    ("reproduce.md", "took 66 min on the project's 2-vCPU machine (2026-11-30; with a test run beside it",
     (("66", "run:wall_time_s / 60", ".0f"), ("2026-11-30", "run:date", "s"))),
    ("reproduce.md", "(in the reference run: dynamic models 43.3 min, control 7.7 min)",
     (("43.3", "step_seconds/dynamic_model / 60", ".1f"), ("7.7", "step_seconds/control / 60", ".1f"))),

    ("models.md", "the largest error over the interior nodes is 0.0237 % of the length 10 steps (1 ms) "
                  "after a start and 1.09 % after 100 steps",
     (("0.0237", "manipulator/horizons/10/model", ".3g"), ("1.09", "manipulator/horizons/100/model", ".3g"))),
    ("models.md", "Over the whole test span it reaches 6.29 %, where holding every node still does better "
                  "(5.6 %)",
     (("6.29", "manipulator/horizons/test_span/model", ".3g"),
      ("5.6", "manipulator/horizons/test_span/persistence", ".3g"))),
    ("models.md", "the single-node models stay within 0.131, 1.15 and 0.112 % (ellipse, square, semicircle)",
     (("0.131", "max(ellipse/rollout/max_pct_of_length)", ".3g"),
      ("1.15", "max(square/rollout/max_pct_of_length)", ".3g"),
      ("0.112", "max(semicircle/rollout/max_pct_of_length)", ".3g"))),
    ("models.md", "reference run 6.0e-08, 2.4e-06 and 6.1e-08 m (ellipse, square, semicircle;",
     (("6.0e-08", "ellipse/engine_vs_pytorch/max_abs_difference_m", ".1e"),
      ("2.4e-06", "square/engine_vs_pytorch/max_abs_difference_m", ".1e"),
      ("6.1e-08", "semicircle/engine_vs_pytorch/max_abs_difference_m", ".1e"))),

    ("magnetics.md", "the fitted factors are 1.9285 ± 0.1071 for damping against 1.0395 ± 0.0008 for "
                     "stiffness and 0.9697 ± 0.0006 for remanence (the robot's: 2, 1.04 and 0.97)",
     (("1.9285", "magnetic/calibration/parameters/damping/fitted", ".4f"),
      ("0.1071", "magnetic/calibration/parameters/damping/std_error", ".4f"),
      ("1.0395", "magnetic/calibration/parameters/stiffness/fitted", ".4f"),
      ("0.0008", "magnetic/calibration/parameters/stiffness/std_error", ".4f"),
      ("0.9697", "magnetic/calibration/parameters/remanence/fitted", ".4f"),
      ("0.0006", "magnetic/calibration/parameters/remanence/std_error", ".4f"),
      ("2", "magnetic/calibration/parameters/damping/truth", ".3g"),
      ("1.04", "magnetic/calibration/parameters/stiffness/truth", ".3g"),
      ("0.97", "magnetic/calibration/parameters/remanence/truth", ".3g"))),
    ("magnetics.md", "a mean error of 0.79 against 1.31 deg at the distal magnet and 0.33 against 0.81 deg "
                     "at the proximal one; the calibrated dynamic model is lower still (0.60 and 0.16 deg)",
     # [axis][max, mean], axis 1 = y, the bending axis
     (("0.79", "magnetic/distal/rnn/1/1", ".2f"), ("1.31", "magnetic/distal/cosserat/1/1", ".2f"),
      ("0.33", "magnetic/proximal/rnn/1/1", ".2f"), ("0.81", "magnetic/proximal/cosserat/1/1", ".2f"),
      ("0.60", "magnetic/distal/calibrated/1/1", ".2f"), ("0.16", "magnetic/proximal/calibrated/1/1", ".2f"))),

    ("statics.md", "In the reference run's Fig. 13 study a solve takes 0.035–0.062 ms (the mean of 50) at N = 13",
     (("0.035", "min(fig13/summary/tolerance_sweep/mean_ms)", ".3f"),
      ("0.062", "max(fig13/summary/tolerance_sweep/mean_ms)", ".3f"),
      ("50", "fig13/summary/repetitions", "d"),
      ("13", "fig13/summary/tolerance_sweep/n_steps", "d"))),
    ("statics.md", "and 0.052–0.193 ms at N = 100 and E = 1e-6",
     (("0.052", "min(fig13/summary/node_sweep/mean_ms/-1)", ".3f"),
      ("0.193", "max(fig13/summary/node_sweep/mean_ms/-1)", ".3f"),
      ("100", "fig13/summary/node_sweep/n_steps/-1", "d"))),

    # The tendon arms' table (docs/guide/dynamic.md, "Results")
    ("dynamic.md", _TENDON_ROW.format("test span (last 40 % of the nominal run)", "0.607 (linear 1.64)",
                                      "0.444 (linear 1.77)", "< 2"),
     (("0.607", "tendons/tendon-planar/test_span/model/max_pct_of_length", ".3g"),
      ("1.64", "tendons/tendon-planar/test_span/linear/max_pct_of_length", ".3g"),
      ("0.444", "tendons/tendon-spatial/test_span/model/max_pct_of_length", ".3g"),
      ("1.77", "tendons/tendon-spatial/test_span/linear/max_pct_of_length", ".3g"),
      ("2", "tendons/tendon-planar/goals/test_span_max_pct_of_length/goal", ".3g"))),
    ("dynamic.md", _TENDON_ROW.format("held-out variants (8), median", "0.498 (linear 1.5)",
                                      "1.29 (linear 2.97)", "< 2"),
     (("0.498", "tendons/tendon-planar/heldout/median_max_pct_of_length", ".3g"),
      ("1.5", "tendons/tendon-planar/heldout/baselines/linear/median_max_pct_of_length", ".3g"),
      ("1.29", "tendons/tendon-spatial/heldout/median_max_pct_of_length", ".3g"),
      ("2.97", "tendons/tendon-spatial/heldout/baselines/linear/median_max_pct_of_length", ".3g"),
      ("8", "tendons/tendon-planar/heldout/variants", "d"),
      ("2", "tendons/tendon-planar/goals/heldout_median_max_pct_of_length/goal", ".3g"))),
    ("dynamic.md", _TENDON_ROW.format("held-out variants (8), worst", "0.94 (linear 2.55)",
                                      "3.28 (linear 4)", "< 5"),
     (("0.94", "tendons/tendon-planar/heldout/worst_max_pct_of_length", ".3g"),
      ("2.55", "tendons/tendon-planar/heldout/baselines/linear/worst_max_pct_of_length", ".3g"),
      ("3.28", "tendons/tendon-spatial/heldout/worst_max_pct_of_length", ".3g"),
      ("4", "tendons/tendon-spatial/heldout/baselines/linear/worst_max_pct_of_length", ".3g"),
      ("8", "tendons/tendon-spatial/heldout/variants", "d"),
      ("5", "tendons/tendon-planar/goals/heldout_worst_max_pct_of_length/goal", ".3g"))),
    ("dynamic.md", _TENDON_ROW.format("generalisation (`-sine` variant, 10 s)", "1.95 (linear 5.15)",
                                      "3.1 (linear 5.2)", "< 5"),
     (("1.95", "tendons/tendon-planar/generalisation/model/max_pct_of_length", ".3g"),
      ("5.15", "tendons/tendon-planar/generalisation/linear/max_pct_of_length", ".3g"),
      ("3.1", "tendons/tendon-spatial/generalisation/model/max_pct_of_length", ".3g"),
      ("5.2", "tendons/tendon-spatial/generalisation/linear/max_pct_of_length", ".3g"),
      ("5", "tendons/tendon-spatial/goals/generalisation_max_pct_of_length/goal", ".3g"))),
    ("dynamic.md", _TENDON_ROW.format("model at 10 / 100 / 1000 steps", "0.378 / 0.448 / 0.869",
                                      "0.625 / 2.58 / 3.51", "below every baseline"),
     tuple((f, f"tendons/tendon-{arm}/horizons/{h}/model", ".3g")
           for arm, figures in (("planar", ("0.378", "0.448", "0.869")), ("spatial", ("0.625", "2.58", "3.51")))
           for h, f in zip((10, 100, 1000), figures))),
    ("dynamic.md", _TENDON_ROW.format("linear at 10 / 100 / 1000", "0.305 / 2.54 / 2.55", "0.635 / 4 / 4", ""),
     tuple((f, f"tendons/tendon-{arm}/horizons/{h}/linear", ".3g")
           for arm, figures in (("planar", ("0.305", "2.54", "2.55")), ("spatial", ("0.635", "4", "4")))
           for h, f in zip((10, 100, 1000), figures))),
    ("dynamic.md", _TENDON_ROW.format("persistence at 10 / 100 / 1000", "5 / 26 / 34.7", "11.2 / 42.4 / 45.1", ""),
     tuple((f, f"tendons/tendon-{arm}/horizons/{h}/persistence", ".3g")
           for arm, figures in (("planar", ("5", "26", "34.7")), ("spatial", ("11.2", "42.4", "45.1")))
           for h, f in zip((10, 100, 1000), figures))),
    ("dynamic.md", _TENDON_ROW.format("constant velocity at 10 / 100 / 1000", "6.85 / 62.1 / -", "15.3 / 140 / -", ""),
     tuple((f, f"tendons/tendon-{arm}/horizons/{h}/constant_velocity", ".3g")
           for arm, figures in (("planar", ("6.85", "62.1", "-")), ("spatial", ("15.3", "140", "-")))
           for h, f in zip((10, 100, 1000), figures))),
    ("dynamic.md", "Every goal is met on the spatial arm, narrowly at 10 steps (0.625 against the linear "
                   "model's 0.635)",
     (("0.625", "tendons/tendon-spatial/horizons/10/model", ".3g"),
      ("0.635", "tendons/tendon-spatial/horizons/10/linear", ".3g"))),
    ("dynamic.md", "10 steps after a start the linear model is closer (0.305 against the model's 0.378); further on "
                   "the model beats it (5.67-fold at 100 steps)",
     (("0.305", "tendons/tendon-planar/horizons/10/linear", ".3g"),
      ("0.378", "tendons/tendon-planar/horizons/10/model", ".3g"),
      ("5.67", "ratio(tendons/tendon-planar/horizons/100/linear, tendons/tendon-planar/horizons/100/model)", ".3g"))),
    ("dynamic.md", "Validation keeps step 700 on the planar arm and the last, 1,000, on the spatial arm "
                   "(2.19 and 5.5 mm against the linear start's 7.88 and 9.33 mm)",
     (("700", "tendons/tendon-planar/training/selected_step", ","),
      ("1,000", "tendons/tendon-spatial/training/selected_step", ","),
      ("1,000", "tendons/tendon-spatial/train_config/steps", ","),
      ("2.19", "tendons/tendon-planar/training/validation/-1/1 * 1000", ".3g"),
      ("5.5", "tendons/tendon-spatial/training/validation/-1/1 * 1000", ".3g"),
      ("7.88", "tendons/tendon-planar/training/validation/0/1 * 1000", ".3g"),
      ("9.33", "tendons/tendon-spatial/training/validation/0/1 * 1000", ".3g"))),
    ("dynamic.md", "Training took 195 and 215 s on one thread, in the dynamic models' training pool, with a test run "
                   "beside it; the step itself, its simulations and sweeps, 0.4 min.",
     (("195", "tendons/tendon-planar/train_seconds", ".0f"), ("215", "tendons/tendon-spatial/train_seconds", ".0f"),
      ("0.4", "step_seconds/tendons / 60", ".1f"))),
]

CLAIMS = [
    # page, quoted text, path, the value the report holds
    ("dynamic.md", "The planar arm misses one", "tendons/tendon-planar/goals_met", False),
    ("dynamic.md", "Every goal is met on the spatial arm", "tendons/tendon-spatial/goals_met", True),
    ("magnetics.md", "beats the static model on the bending axis (y) at both magnets", "magnetic/bending_axis", "y"),
    ("magnetics.md", "beats the static model on the bending axis (y) at both magnets",
     "magnetic/lstm_beats_static_on_bending_axis/distal", True),
    ("magnetics.md", "beats the static model on the bending axis (y) at both magnets",
     "magnetic/lstm_beats_static_on_bending_axis/proximal", True),
    ("magnetics.md", "the calibrated dynamic model is lower still", "magnetic/best_on_bending_axis/distal/mean",
     "calibrated"),
    ("magnetics.md", "the calibrated dynamic model is lower still", "magnetic/best_on_bending_axis/proximal/mean",
     "calibrated"),
    ("statics.md", "and 0.052–0.193 ms at N = 100 and E = 1e-6", "fig13/summary/node_sweep/tol", 1e-6),
    ("reproduce.md", "took 66 min on the project's 2-vCPU machine", "quick", False),
]

# "the README's run", "From the README ("Speed")", "(README)", "(README; ...", "are in the README", ...
STALE_README = re.compile(
    r"""README(?:'s)?\s+(?:run|full\s+run|"Speed"|quotes|reports|summarises|notes|discusses|accuracy)"""
    r"""|\(README\b|\b(?:in|from|see)\s+the\s+README\b""",
    re.IGNORECASE)


def _path(page: str) -> Path:
    return ROOT / page if "/" in page else GUIDE / page


def _one_line(text: str) -> str:
    """The text with every run of whitespace (line breaks included) as one space."""
    return re.sub(r"\s+", " ", text)


def _prose(page: str) -> str:
    return _one_line(_path(page).read_text(encoding="utf-8"))


@pytest.fixture(scope="module")
def reference():
    report = json.loads((REFERENCE / "report.json").read_text())
    run = json.loads((REFERENCE / "run.json").read_text())
    return report, run


def _get(doc, path: str):
    node = doc
    for key in path.strip().split("/"):
        node = node[int(key)] if isinstance(node, list) else node[key]
    return node


def _numbers(node):
    if isinstance(node, list):
        for item in node:
            yield from _numbers(item)
    else:
        yield node


def _value(reference, source: str):
    report, run = reference
    scale = 1.0
    m = re.fullmatch(r"(.*?) ([*/]) ([0-9.]+)", source)
    if m:
        source, op, k = m.group(1), m.group(2), float(m.group(3))
        scale = k if op == "*" else 1.0 / k

    def get(path):
        return _get(run, path[4:]) if path.startswith("run:") else _get(report, path)

    m = re.fullmatch(r"(max|min|ratio)\((.*)\)", source)
    if m is None:
        value = get(source)
    elif m.group(1) == "ratio":
        a, b = m.group(2).split(",")
        value = get(a) / get(b)
    else:
        value = (max if m.group(1) == "max" else min)(_numbers(get(m.group(2))))
    return value * scale if scale != 1.0 and value is not None else value


def _format(value, rounding: str) -> str:
    return "-" if value is None else format(value, rounding)


def test_the_checked_pages_exist():
    for page in PAGES:
        assert _path(page).is_file(), page
    for page, *_ in FIGURES + CLAIMS:
        assert page in PAGES, page


@pytest.mark.parametrize("page, quote, figures", FIGURES, ids=[f"{p}: {q[:40]}" for p, q, _ in FIGURES])
def test_every_quoted_figure_is_the_reference_runs(reference, page, quote, figures):
    quote = _one_line(quote)
    assert quote in _prose(page), f"{page} no longer says {quote!r}: update FIGURES with the page"
    for figure, source, rounding in figures:
        assert figure in quote, f"{figure!r} is not in the quoted text {quote!r}"
        expected = _format(_value(reference, source), rounding)
        assert figure == expected, (
            f"{page} quotes {figure} in {quote!r}, but the reference report's {source} reads {expected} "
            f"(rounding {rounding!r}): update the page")


@pytest.mark.parametrize("page, quote, path, value", CLAIMS, ids=[f"{p}: {a}" for p, _, a, _ in CLAIMS])
def test_every_claim_is_the_reference_runs(reference, page, quote, path, value):
    quote = _one_line(quote)
    assert quote in _prose(page), f"{page} no longer says {quote!r}: update CLAIMS with the page"
    assert _get(reference[0], path) == value, f"{page} says {quote!r}, but report.json's {path} is not {value!r}"


@pytest.mark.parametrize("page", sorted({p for p, *_ in FIGURES + CLAIMS}))
def test_pages_quoting_the_reference_run_link_to_the_results_page(page):
    assert "](../results/index.md)" in _path(page).read_text(encoding="utf-8"), (
        f"{page} quotes the reference run: link to the Results page (../results/index.md)")


def _guide_pages() -> list[str]:
    return sorted({p.name for p in GUIDE.glob("*.md")} | set(PAGES))


@pytest.mark.parametrize("page", _guide_pages())
def test_no_guide_page_sends_the_reader_to_the_readme_for_results(page):
    text = _prose(page)
    hits = [m.group(0) for m in STALE_README.finditer(text)]
    assert not hits, (f"{page} refers to the README for results ({hits}); the results are on the Results "
                      "page (docs/results/index.md)")


def test_the_readme_pattern_matches_what_it_means():
    for stale in ["In the README's run the LSTM beats", 'From the README ("Speed"): softrnn bench',
                  "reaches 8,500 Hz (README).", "within 1e-6 m (README; reproduce checks it)",
                  "The README quotes one node step", "The README summarises the full run",
                  "The README reports softrnn 5-8x faster", "are in the README.", "The README's full run took"]:
        assert STALE_README.search(stale), stale
    for fine in ["`benchmarks/README.md` describes the method", "the README's table of results and the Results page",
                 "(`benchmarks/README.md`)"]:
        assert not STALE_README.search(fine), fine


def test_a_changed_report_fails_the_figures(reference):
    report, run = reference
    changed = json.loads(json.dumps(report))
    changed["tendons"]["tendon-planar"]["test_span"]["model"]["max_pct_of_length"] *= 1.1
    assert _format(_value((changed, run), "tendons/tendon-planar/test_span/model/max_pct_of_length"), ".3g") != "0.617"
    assert _format(_value(reference, "ratio(step_seconds/control, step_seconds/control) * 2"), ".0f") == "2"
    assert _value(reference, "max(fig13/summary/node_sweep/n_steps)") == 100
