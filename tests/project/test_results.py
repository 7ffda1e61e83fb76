"""The README's table of results and the site's results page are rendered from the committed reference
run (docs/results/reference: report.json of one full ``softrnn reproduce``, run.json naming its commit,
date and machine), so every figure they quote is that run's; the README quotes no measured figure
outside the table."""

import json
import re
from pathlib import Path

import pytest

from softrnn.reproduce.results import BEGIN, END, headline_rows, load_reference, readme_with_table, results_page

ROOT = Path(__file__).resolve().parents[2]
REFERENCE = ROOT / "docs" / "results" / "reference"


@pytest.fixture(scope="module")
def reference():
    return load_reference(REFERENCE)


def test_the_reference_run_is_a_full_named_run(reference):
    report, run = reference
    assert report["quick"] is False, "the reference report must be a full run, not --quick"
    assert re.fullmatch(r"[0-9a-f]{40}", run["commit"]), "run.json: the full commit hash"
    assert re.fullmatch(r"\d{4}-\d{2}-\d{2}", run["date"]), "run.json: the date, YYYY-MM-DD"
    assert "softrnn reproduce" in run["command"] and "--quick" not in run["command"]
    assert run["wall_time_s"] > 0 and run["machine"]
    assert (REFERENCE / "report.md").read_text().startswith(
        f"# softrnn reproduce report (softrnn {report['softrnn_version']})")
    for step in ("cases", "node_models", "dynamic_model", "tendons", "magnetic", "benchmark"):
        assert step in report["step_seconds"], f"the reference run lacks the step {step}"


def test_the_readme_table_is_the_reference_reports(reference):
    report, _ = reference
    readme = (ROOT / "README.md").read_text()
    assert readme_with_table(readme, report) == readme, "README.md's results block is stale: run `make results`"


def test_the_results_page_is_the_reference_reports(reference):
    report, run = reference
    page = results_page(report, run, lambda p: (REFERENCE / p).is_file())
    assert (ROOT / "docs" / "results" / "index.md").read_text() == page, (
        "docs/results/index.md is stale: run `make results`")


def test_every_picture_on_the_results_page_is_committed():
    page = (ROOT / "docs" / "results" / "index.md").read_text()
    pictures = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", page)
    assert pictures, "the results page shows the run's figures"
    for p in pictures:
        assert (ROOT / "docs" / "results" / p).is_file(), p


# A measured figure: a number followed by a unit of a result (not a version, a count or a setting).
_FIGURE = re.compile(r"\d[\d,.]*\s?(?:% of (?:L\b|length|the rod)|µs|us\b|Hz\b|mm\b|deg\b|x faster|x real time|"
                     r"× real time|x the simulator)")


def _prose(text: str) -> str:
    """The text outside code blocks, HTML comments and the generated results block."""
    if BEGIN in text:
        text = text[:text.index(BEGIN)] + text[text.index(END):]
    text = re.sub(r"```.*?```", "", text, flags=re.DOTALL)
    return re.sub(r"<!--.*?-->", "", text, flags=re.DOTALL)


@pytest.mark.parametrize("page", ["README.md", "docs/index.md", "docs/guide/getting-started.md"])
def test_front_pages_quote_no_figure_outside_the_generated_table(page):
    found = _FIGURE.findall(_prose((ROOT / page).read_text()))
    assert not found, f"{page} quotes measured figures outside the generated table: {found}"


def test_the_readme_is_a_front_page():
    lines = (ROOT / "README.md").read_text().splitlines()
    assert 150 <= len(lines) <= 250, f"README.md has {len(lines)} lines; a front page has 150-250"


def test_a_diverged_or_missing_figure_reads_as_such():
    report = {"benchmark": {}, "ellipse": {"rollout": {"diverged": True}}}
    rows = dict((what, (ours, other)) for what, ours, other in headline_rows(report))
    free = next(v for k, v in rows.items() if k.startswith("Node LSTM, free running over the test span"))
    assert free == ("diverged, -, -", "linear AR model: -, -, -")


def test_the_reference_report_is_valid_json():
    json.loads((REFERENCE / "report.json").read_text())
