"""The real-robot figures the guide quotes are those of the committed benchmark
report (docs/results/real-robot/benchmark.json, written by ``make real-robot``)."""

import json
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
REPORT = ROOT / "docs" / "results" / "real-robot" / "benchmark.json"
ROW = re.compile(r"^\| `?([a-z_]+)`?(?: \(([^)]+)\))? \| ([0-9.]+) \| ([0-9.]+) \| ([0-9.]+) \|", re.MULTILINE)


def _tables(text: str) -> list[tuple]:
    return [(m.group(1), float(m.group(3)), float(m.group(4)), float(m.group(5))) for m in ROW.finditer(text)]


@pytest.mark.parametrize("page", ["docs/guide/real-robots.md"])
def test_quoted_figures_equal_the_committed_report(page):
    report = json.loads(REPORT.read_text())
    entries = {**report["models"], **report["baselines"]}
    rows = _tables((ROOT / page).read_text())
    quoted = [r for r in rows if r[0] in entries]
    assert {r[0] for r in quoted} == set(entries), f"{page} should quote every model and baseline"
    for name, rmse, mean, pct in quoted:
        e = entries[name]
        assert (rmse, mean, pct) == (round(e["tip_rmse_mm"], 2), round(e["tip_mean_mm"], 2),
                                     round(e["tip_rmse_pct_of_length"], 2)), name
    ratio = f"{report['ratio_best_model_to_best_baseline']:.2f}"
    assert ratio in (ROOT / page).read_text()


def test_quoted_session_agreement_equals_the_committed_report():
    """The guide's figures of how far the sessions agree are the report's."""
    agreement = json.loads(REPORT.read_text())["session_agreement"]
    text = (ROOT / "docs/guide/real-robots.md").read_text()
    for key in ("training_only", "validation_only", "training_and_validation"):
        entry = agreement[key]
        assert f"{entry['validation_tip_rmse_mm']:.2f} mm" in text, key
        assert f"{entry['validation_tip_mean_aligned_pct_of_length']:.2f} %" in text, key
    assert f"{agreement['training_and_validation']['training_tip_rmse_mm']:.2f} mm" in text
