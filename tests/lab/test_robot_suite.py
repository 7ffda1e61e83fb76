"""A suite of robots (``softrnn.lab.suite``) on synthetic stand-ins: every robot checked before any
runs, each robot's report kept as it finishes, an interrupted suite resumed without running a finished
robot again, and one table of every robot (JSON and Markdown)."""

import json

import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.lab.benchmark import BenchmarkOptions
from softrnn.lab.recording import Layout
from softrnn.lab.suite import SuiteJob, run_suite
from softrnn.lab.tendon_robot import CalibrationOptions

from helpers import tendon_recording

QUICK = CalibrationOptions(quick_evaluations=25, evaluations=150)


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    d = tmp_path_factory.mktemp("suite")
    for name, rows, seed in (("a", 90, 0), ("av", 40, 1), ("b", 80, 2), ("bv", 40, 3)):
        tendon_recording(d / f"{name}.csv", rows=rows, seed=seed)
    return d


def _job(data, name, train, val, **options):
    return SuiteJob(name=name, entry=f"suite.toml: robots.{name}", train=(str(data / train),),
                    validation=str(data / val), layout=Layout(),
                    options=BenchmarkOptions(length=0.08, lag=0, families=("physics",), calibration=QUICK, workers=1,
                                             **options))


def test_suite_runs_every_robot_and_resumes_after_an_interruption(data, tmp_path):
    jobs = [_job(data, "a", "a.csv", "av.csv"), _job(data, "b", "b.csv", "bv.csv")]
    seen = []

    def stop_at_b(done, total, info):
        seen.append((done, total, info["stage"]))
        if info["stage"].startswith("b:"):
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_suite(jobs, tmp_path / "robots", progress=stop_at_b)
    assert seen[:2] == [(1, 4, "a: physics"), (2, 4, "a: baselines")]      # the baselines read the physics
    assert sorted(p.name for p in (tmp_path / "robots").iterdir()) == ["a.json"]
    first = json.loads((tmp_path / "robots" / "a.json").read_text())
    assert first["suite"]["entry"] == "suite.toml: robots.a"

    stages = []
    result = run_suite(jobs, tmp_path / "robots", suite="suite.toml", title="t", resume=True,
                       progress=lambda d, t, i: stages.append(i["stage"]))
    assert stages == ["b: physics", "b: baselines"]                      # a is kept, not run again
    a, b = result.rows
    assert a.resumed and not b.resumed and a.models["physics"].tip_rmse_mm == first["models"]["physics"]["tip_rmse_mm"]
    table = result.to_dict()
    assert list(table["robots"]) == ["a", "b"]
    entry = table["robots"]["b"]
    assert set(entry["models"]["physics"]) >= {"tip_rmse_aligned_mm", "tip_mean_aligned_pct_of_length"}
    assert entry["chosen_on_training"]["validation_tip_rmse_mm"] == entry["models"]["physics"]["tip_rmse_mm"]
    assert entry["ratio_chosen_to_best_baseline"] == pytest.approx(
        entry["models"]["physics"]["tip_rmse_mm"] / entry["baselines"][entry["best_baseline"]]["tip_rmse_mm"],
        rel=1e-3)
    md = result.markdown()
    assert "| a | `physics` |" in md and "| b | `static_map` (baseline) |" in md and "aligned mean [% of L]" in md
    assert "per pattern: aligned mean [% of L]" in md
    row = next(line for line in md.splitlines() if line.startswith("| a | `physics` |"))
    per_pattern = float(row.split("|")[10])            # the pattern-wise column, after the session-wide one
    assert per_pattern == pytest.approx(a.models["physics"].tip_mean_aligned_per_pattern_pct_of_length, abs=0.006)
    both = first["session_agreement"]["training_and_validation"]["validation_tip_rmse_mm"]
    assert a.agreement["training_and_validation"] == both and entry["session_agreement"] == b.agreement
    head = md.splitlines()[2:5]
    assert "physics fitted on every session [mm]" in head[0]
    assert float(head[2].split("|")[9]) == pytest.approx(both, abs=0.006)

    # another session for a: its kept report is not reused
    changed = [_job(data, "a", "b.csv", "av.csv"), jobs[1]]
    stages.clear()
    run_suite(changed, tmp_path / "robots", resume=True, progress=lambda d, t, i: stages.append(i["stage"]))
    assert stages == ["a: physics", "a: baselines"]


def test_a_bad_robot_stops_the_suite_before_anything_runs(data, tmp_path):
    far = tmp_path / "far.csv"
    tendon_recording(far, rows=40, seed=5, scale_mm=80.0)      # beyond the widest routing the calibration fits
    jobs = [_job(data, "a", "a.csv", "av.csv"), _job(data, "far", "a.csv", str(far))]
    with pytest.raises(SoftrnnInputError, match=r"^suite.toml: robots.far: .*beyond what the routing allows"):
        run_suite(jobs, tmp_path / "robots")
    assert not (tmp_path / "robots").exists()
