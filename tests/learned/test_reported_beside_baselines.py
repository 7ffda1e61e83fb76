"""The learned models reported beside baselines: ``evaluate``'s baselines and horizons (documented
keys, persistence and constant velocity by hand, horizons that do not fit left out, the linear model's
training span), misses stated plainly, the ``evaluate`` command's table, the whole manipulator's
baselines in ``reproduce`` and their report.md tables."""

import json
import math

import numpy as np
import pytest

from softrnn.cli._evaluate import format_report
from softrnn.learned.baselines import ConstantVelocity, Persistence, free_run
from softrnn.learned.node.data import SampleSpec, split
from softrnn.learned.node.evaluate import evaluate, horizon_misses, horizon_table, misses
from softrnn.learned.node.manipulator import Manipulator
from softrnn.learned.node.rollout import rollout
from softrnn.reproduce.manipulator import compare_baselines as manipulator_baselines
from softrnn.reproduce.report import render_markdown
from softrnn.scenarios.cases import PAPER_CASES

from helpers import LENGTH, Offset, Oracle, real_model, run_cli, save_h5
from helpers import node_dataset as synthetic

ERROR_KEYS = {"max_abs_mm", "mean_abs_mm", "max_pct_of_length", "rmse_mm", "max_rmse_t_mm", "rmse_euclidean_mm",
              "mean_euclidean_mm", "rmse_euclidean_pct_of_length", "mean_euclidean_pct_of_length"}
NAMES = {"persistence", "constant_velocity", "linear"}


def _reference(ds, node: int) -> np.ndarray:
    return np.asarray(ds.positions, dtype=np.float64)[:, int(np.flatnonzero(ds.nodes == node)[0])]


# ------------------------------------------------------------------------------------------ evaluate()
def test_evaluate_reports_the_baselines_with_the_documented_keys():
    ds = synthetic(T=80)
    model = real_model(ds, SampleSpec(node=3, history=2, wrench="force"))
    report = evaluate(model, ds).to_json()
    json.dumps(report, allow_nan=False)
    assert set(report["baselines"]) == NAMES
    for name, b in report["baselines"].items():
        assert set(b["one_step"]) == ERROR_KEYS, name
        assert set(b["free_running"]) == ERROR_KEYS | {"diverged"} and b["free_running"]["diverged"] is False
        assert b["span_samples"] == report["span_samples"]            # the model's targets
    lin = report["baselines"]["linear"]
    cut = split(80, model.spec)[0].stop
    assert lin["fitted_on"]["samples"] == [0, cut] and "training span" in lin["fitted_on"]["what"]
    assert lin["fit"]["mode"] == "node" and lin["fit"]["history"] == 2 and "neighbours 2, 4" in lin["inputs"]
    h = report["horizons"]
    assert h["unit"] == "% of length" and h["n_starts"] == 5
    assert [k for k in h if k.isdigit()] == ["1", "10", "100", "1000"]
    for key in ("1", "10"):
        assert set(h[key]) == {"model"} | NAMES and all(isinstance(v, float) for v in h[key].values())
        assert h["max_abs_mm"][key]["persistence"] == pytest.approx(h[key]["persistence"] * LENGTH * 10)
    assert h["100"] is None and h["1000"] is None                     # 32 test samples: they do not fit
    assert isinstance(report["misses"], list)


def test_persistence_and_constant_velocity_errors_are_hand_computations():
    ds = synthetic(T=80)
    oracle = Oracle(ds, SampleSpec(node=2, history=2, wrench="wrench"))
    report = evaluate(oracle, ds).to_json()
    first, last = report["span_samples"]
    r = _reference(ds, 2)
    k = np.arange(first, last + 1)
    for name, pred_one, pred_free in (
            ("persistence", r[k - 1], np.repeat(r[first - 1:first], k.size, axis=0)),
            ("constant_velocity", 2 * r[k - 1] - r[k - 2],
             r[first - 1] + np.outer(np.arange(1, k.size + 1), r[first - 1] - r[first - 2]))):
        for kind, pred in (("one_step", pred_one), ("free_running", pred_free)):
            err = np.abs(pred - r[k]) * 1e3
            got = report["baselines"][name][kind]
            np.testing.assert_allclose(got["max_abs_mm"], err.max(axis=0), rtol=1e-9, atol=1e-12)
            np.testing.assert_allclose(got["mean_abs_mm"], err.mean(axis=0), rtol=1e-9, atol=1e-12)
            np.testing.assert_allclose(got["max_pct_of_length"], err.max(axis=0) / (LENGTH * 1e3) * 100, rtol=1e-9)
            assert got["rmse_mm"] == pytest.approx(np.sqrt(np.mean(err ** 2)), rel=1e-9), (name, kind)
    # a perfect model: nothing beats it, and its horizon errors are zero
    assert report["misses"] == [] and report["horizons"]["10"]["model"] == 0.0


def test_horizon_table_by_hand_and_what_does_not_fit_is_left_out():
    T, v = 60, np.array([1e-3, -2e-3, 0.5e-3])                       # uniform motion, m per sample
    pos = (np.arange(T)[:, None] * v)[:, None, :]                     # (T, 1, 3)
    runs = {"model": lambda p, w, s, e: free_run(ConstantVelocity(), p, w, s, e),
            "persistence": lambda p, w, s, e: free_run(Persistence(), p, w, s, e)}
    h = horizon_table(runs, pos, None, 5, T, (1, 10, 50, 100), n_starts=3, length=LENGTH).to_dict()
    assert h["100"] is None and h["starts"]["100"] is None            # 5 + 100 > 60
    assert h["starts"]["50"] == [5, 8, 10] and h["starts"]["10"] == [5, 28, 50]   # spread over [5, T - h]
    for key in ("1", "10", "50"):
        # persistence is off by h steps of the motion; constant velocity is exact
        assert h["max_abs_mm"][key]["persistence"] == pytest.approx(int(key) * 2.0, rel=1e-9)
        assert h[key]["persistence"] == pytest.approx(int(key) * 2.0 / (LENGTH * 1e3) * 100, rel=1e-9)
        assert h[key]["model"] == pytest.approx(0.0, abs=1e-9)
    assert horizon_misses(h) == []
    h["10"]["model"] = 50.0                                            # the model misses at 10 steps
    assert horizon_misses(h) == ["persistence beats the model at 10 steps (largest error 4 vs the model's 50 "
                                 "% of length)"]
    with_mm = horizon_table(runs, pos, None, 5, T, (10,), n_starts=2).to_dict()   # no length: in mm
    assert with_mm["unit"] == "mm" and with_mm["10"]["persistence"] == pytest.approx(20.0)


def test_evaluate_horizons_follow_the_span():
    ds = synthetic(T=80)
    model = Offset(SampleSpec(node=4, history=2).resolve(ds.nodes), step=(1e-4, 0.0, 0.0))
    report = evaluate(model, ds, horizons=(1, 5, 31, 40), horizon_starts=3).to_json()
    first, last = report["span_samples"]                              # 50..79: 30 targets
    h = report["horizons"]
    assert h["40"] is None and h["31"] is None and h["5"] is not None
    assert h["starts"]["5"] == [first, (first + last - 4) // 2, last - 4]
    assert all(s + 5 <= last + 1 for s in h["starts"]["5"])
    # the model's horizon error from its own free running, by hand: start s, horizon 5, node 4
    r = _reference(ds, 4)
    by_hand = max(np.abs(r[s - 1] + np.array([5e-4, 0, 0]) - r[s + 4]).max() for s in h["starts"]["5"]) * 1e3
    assert h["max_abs_mm"]["5"]["model"] == pytest.approx(by_hand, rel=1e-3)     # the rollout's float32 state
    assert evaluate(model, ds, free=False).to_json()["horizons"] is None   # no free running, no horizons


def test_generalisation_fits_the_linear_model_on_the_leading_part_of_the_record():
    ds = synthetic(T=70)
    oracle = Oracle(ds, SampleSpec(node=2, history=2, wrench="force"))
    report = evaluate(oracle, ds, generalisation=True).to_json()
    lin = report["baselines"]["linear"]
    assert lin["fitted_on"]["samples"] == [0, math.floor(0.6 * 70)]
    assert "leading 60 % of this record" in lin["fitted_on"]["what"] and "never saw" in lin["fitted_on"]["what"]
    assert report["baselines"]["persistence"]["span_samples"] == [2, 69]
    # a record too short to fit the linear model: it is skipped, with the reason, the others still run
    short = evaluate(oracle, synthetic(T=6), generalisation=True).to_json()
    assert "skipped" in short["baselines"]["linear"] and "one_step" in short["baselines"]["persistence"]
    assert "linear" not in short["horizons"]["1"]


def test_a_diverging_model_is_a_miss_beside_the_baselines():
    ds = synthetic(T=80)
    model = Offset(SampleSpec(node=3, history=2).resolve(ds.nodes), step=(5.0, 0.0, 0.0))   # 5 m per step
    report = evaluate(model, ds).to_json()
    assert report["free_running"]["diverged"] is True
    assert report["horizons"]["10"]["model"] == "diverged" and isinstance(report["horizons"]["1"]["model"], float)
    said = "\n".join(report["misses"])
    assert "persistence, constant velocity and linear AR beat the model one step ahead (RMSE" in said
    assert "beat the model free running: the model diverged" in said
    assert "beat the model at 10 steps: the model diverged" in said


def test_misses_are_stated_plainly_and_printed():
    report = {"one_step": {"rmse_mm": 0.2}, "free_running": {"rmse_mm": 3.0, "diverged": False},
              "baselines": {"persistence": {"one_step": {"rmse_mm": 0.5},
                                            "free_running": {"rmse_mm": 2.0, "diverged": False}},
                            "constant_velocity": {"one_step": {"rmse_mm": 0.1},
                                                  "free_running": {"diverged": True}},
                            "linear": {"skipped": "too short"}},
              "horizons": {"unit": "% of length", "1": {"model": 0.1, "persistence": 0.3},
                           "10": {"model": 0.4, "persistence": 0.25}, "100": None}}
    said = misses(report)
    assert said == ["constant velocity beats the model one step ahead (RMSE 0.1 vs the model's 0.2 mm)",
                    "persistence beats the model free running (RMSE 2 vs the model's 3 mm)",
                    "persistence beats the model at 10 steps (largest error 0.25 vs the model's 0.4 % of length)"]
    from softrnn.cli._evaluate import baseline_lines

    text = "\n".join(baseline_lines(dict(report, misses=said)))
    assert "not fitted: too short" in text and "(longer than the span: not evaluated)" in text
    assert "persistence beats the model at 10 steps" in text


# ------------------------------------------------------------------------------------------ the command
def test_evaluate_command_prints_the_baseline_table(tmp_path, capsys):
    from softrnn.learned.node.artifact import save_model

    ds = synthetic(T=80)
    data = save_h5(tmp_path / "data.h5", ds, scenario_name="synthetic")
    save_model(tmp_path / "m", real_model(ds, SampleSpec(node=3, history=2, wrench="force")))
    out = tmp_path / "ev.json"
    assert run_cli(["evaluate", str(tmp_path / "m"), str(data), "--json", str(out), "--quiet"]) == 0
    text = capsys.readouterr().out
    report = json.loads(out.read_text())
    assert set(report["baselines"]) == NAMES and report["horizons"]["1000"] is None
    lines = text.splitlines()
    header = next(i for i, line in enumerate(lines) if line.split() == ["model", "persistence", "const.", "vel.",
                                                                        "linear", "AR"])
    assert "fitted on the model's training span of this data set (samples 0..47)" in lines[header - 1]
    rmse = lines[header + 1].split()
    assert rmse[:4] == ["one", "step", "RMSE", "[mm]"]
    assert float(rmse[4]) == pytest.approx(report["one_step"]["rmse_mm"], rel=1e-2)
    assert float(rmse[5]) == pytest.approx(report["baselines"]["persistence"]["one_step"]["rmse_mm"], rel=1e-2)
    assert any(line.strip().startswith("at 10 steps: max [% of length]") for line in lines)
    assert "at 1000 steps: max [% of length]      (longer than the span: not evaluated)" in text
    for sentence in report["misses"]:
        assert sentence in text
    if not report["misses"]:
        assert "no baseline beats the model" in text
    assert format_report(report) in text


# ------------------------------------------------------------------------------------------ reproduce
def test_the_whole_manipulator_runs_beside_the_baselines():
    ds = synthetic(T=80)
    shared = Offset(SampleSpec(node=2, history=2).resolve(ds.nodes), step=(1e-5, 0.0, 0.0))
    shared.meta = {"test_span": [48, 80]}
    manip = Manipulator.of(shared=shared, shared_nodes=range(1, 5))
    r = rollout(manip, ds, 48, 80)
    out = manipulator_baselines(manip, shared, ds, r, (1, 2, 3, 4), 48, 80, quick=True)
    json.dumps(out, allow_nan=False)
    assert set(out["baselines"]) == {"persistence", "constant_velocity", "linear_node", "linear_manipulator"}
    for name, b in out["baselines"].items():
        assert set(b["test_span"]) == {"max_abs_mm", "max_pct_of_length", "rmse_mm"}, name
    assert out["baselines"]["linear_manipulator"]["fitted_on"]["samples"] == [0, 48]
    h = out["horizons"]
    assert h["n_starts"] == 2 and h["100"] is None and h["1000"] is None
    assert set(h["10"]) == {"model", "persistence", "constant_velocity", "linear_node", "linear_manipulator"}
    # persistence over the whole test span, by hand: the modelled nodes held at their seed position
    P = np.asarray(ds.positions, dtype=np.float64)
    hold = np.abs(P[48:80, 1:5] - P[47, 1:5]).max() * 1e3
    assert h["test_span"]["persistence"] == pytest.approx(hold / (LENGTH * 1e3) * 100, rel=1e-9)
    assert out["model_test_span"]["max_pct_of_length"] == pytest.approx(h["test_span"]["model"])
    assert out["misses"] == horizon_misses(h)


def _case_report(name: str, model: dict | None) -> dict:
    """A paper case's block of report.json with the figures report.md reads."""
    sim = {"case": name, "n_nodes": 101, "n_samples": 100, "dt_s": 1e-3, "step_s": 1e-4, "substeps": 10,
           "total_time_s": 1.0, "us_per_node_step": 0.1, "node": 50, "node_range_mm": [1.0, 2.0, 3.0],
           "duration_s": 0.1, "energy_start_j": 1.0, "energy_end_j": 0.9, "max_orthogonality_error": 1e-12}
    err = {"max_abs": [1.0, 1.0, 1.0], "mean_abs": [0.5, 0.5, 0.5], "max_pct_of_length": [0.1, 0.1, 0.1]}
    return {"paper": {"analytical_model_s_per_node_step": None, "test": err, "generalisation": err},
            "simulation": sim, "generalisation_data": dict(sim), "figures": [], "one_step": err, "rollout": err,
            "generalisation": err, "engine_vs_pytorch": {},
            "generalisation_rollout": {"diverged": True, "node": 50, "sample": 70, "time_s": 0.07},
            "model": model}


def test_report_md_renders_the_baseline_tables():
    block = {"span": "test", "span_samples": [60, 99], "one_step": {"rmse_mm": 0.3},
             "free_running": {"rmse_mm": 2.0, "max_pct_of_length": [0.1, 0.4, 0.2], "diverged": False},
             "baselines": {
                 "persistence": {"one_step": {"rmse_mm": 0.6},
                                 "free_running": {"rmse_mm": 5.0, "max_pct_of_length": [1, 1, 1], "diverged": False}},
                 "constant_velocity": {"one_step": {"rmse_mm": 0.9}, "free_running": {"diverged": True}},
                 "linear": {"skipped": "too short"}},
             "horizons": {"unit": "% of length", "n_starts": 2, "1": {"model": 0.01, "persistence": 0.02},
                          "10": {"model": 0.5, "persistence": 0.2, "constant_velocity": "diverged"},
                          "100": None, "1000": None}}
    block["misses"] = misses(block)
    h = {"unit": "% of length", "n_starts": 5,
         "10": {"model": 0.01, "persistence": 0.02, "constant_velocity": 0.03, "linear_node": "diverged",
                "linear_manipulator": 0.005},
         "100": {"model": "diverged", "persistence": 0.2, "constant_velocity": 0.3, "linear_node": "diverged"},
         "1000": None, "test_span": {"model": "diverged", "persistence": 0.4}}
    manip = {"case": "semicircle", "architecture": {"lstm_layers": 1, "lstm_units": 16}, "modelled_nodes": 97,
             "pool": [2, 98], "neighbour_offsets": [-2, -1, 1, 2], "unmodelled": "the clamps follow the data",
             "diverged": "the rollout diverged at t = 1 s", "horizons": h, "misses": horizon_misses(h),
             "baselines": {"linear_manipulator": {"skipped": "too many features"}}}
    report = {"softrnn_version": "0", "quick": True, "machine": {"cpu": "c", "cores": 2, "python": "3"},
              "assumptions": {}, "benchmark": {}, "manipulator": manip,
              **{name: _case_report(name, {"test": block} if name == "ellipse" else {}) for name in PAPER_CASES}}
    md = render_markdown(report)
    for row in ("| ellipse | generalisation_rollout | diverged at t = 0.07 s (sample 70) | | | | |",
                "| ellipse | test | one step RMSE [mm] | 0.3 | 0.6 | 0.9 | - | 0.5 (persistence) |",
                "| ellipse | test | free running RMSE [mm] | 2 | 5 | diverged | - | 0.4 (persistence) |",
                "| ellipse | test | free running max [% of length] | 0.4 | 1 | diverged | - | 0.4 (persistence) |",
                "| ellipse | test | at 10 steps [% of length] | 0.5 | 0.2 | diverged | - | 2.5 (persistence) |",
                "| ellipse | test | at 100 steps [% of length] | longer than the span: not evaluated | | | | |",
                "- ellipse, test: persistence beats the model at 10 steps (largest error 0.2 vs the model's 0.5 % "
                "of length)",
                "| at 10 steps [% of length] | 0.01 | 0.02 | 0.03 | diverged | 0.005 | 2 (linear AR (manipulator)) |",
                "| at 100 steps [% of length] | diverged | 0.2 | 0.3 | diverged | - | model diverged (persistence: "
                "0.2) |",
                "| at 1000 steps [% of length] | longer than the span: not evaluated | | | | | |",
                "| whole test span [% of length] | diverged | 0.4 | - | - | - | model diverged (persistence: 0.4) |",
                "- persistence and constant velocity beat the model at 100 steps: the model diverged, largest error "
                "0.2, 0.3 % of length",
                "- linear AR (manipulator) not run: too many features",
                "The free run diverged: the rollout diverged at t = 1 s"):
        assert row in md, row
    assert md.count("### The node models beside baselines") == 1
