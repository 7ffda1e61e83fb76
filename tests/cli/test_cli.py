"""The softrnn command in-process: summaries, one-line errors with exit code 2, reproduce resume."""

import json

import pytest

from softrnn.learned.whole.config import DynamicConfig
from softrnn.reproduce import benchmark as reproduce_benchmark
from softrnn.reproduce import cases as reproduce_cases
from softrnn.reproduce import dynamic as reproduce_dynamic
from softrnn.reproduce import pipeline as reproduce_mod
from softrnn.reproduce import tendons as reproduce_tendons

from helpers import run_cli


def test_simulate_prints_summary_and_json(tmp_path, capsys):
    out = tmp_path / "s.json"
    assert run_cli(["simulate", "semicircle", "--samples", "201", "--quiet", "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "semicircle" in text and "substeps" in text and "us per node-step" in text
    summary = json.loads(out.read_text())
    assert summary["n_samples"] == 201
    assert summary["duration_s"] == pytest.approx(0.02)
    assert summary["max_orthogonality_error"] < 1e-12


@pytest.mark.parametrize("argv, words", [
    (["simulate", "spiral"], ["scenario='spiral'", "ellipse", ".toml"]),
    (["simulate", "square", "--samples", "0"], ["--samples=0", ">= 1"]),
    (["simulate", "ellipse", "--samples", "5", "--substeps", "1"], ["stable step limit", "substeps >="]),
    (["simulate", "square", "--samples", "x"], ["invalid int value"]),
    (["frobnicate"], ["invalid choice"]),
    (["simulate", "square", "--radius", "0"], ["radius=0.0", "positive"]),
    (["simulate", "square", "--radius", "-0.01"], ["radius=-0.01", "positive"]),
    (["simulate", "ellipse", "--youngs-modulus", "-5"], ["--youngs-modulus=-5.0", "Pa"]),
    (["simulate", "semicircle", "--density", "0"], ["density=0.0", "kg/m^3"]),
    (["simulate", "semicircle", "--dt", "-1"], ["dt=-1.0", "positive"]),
    (["simulate", "semicircle", "--dt", "0.01", "--substeps", "1"], ["stable step limit", "substeps >="]),
])
def test_bad_input_is_one_line_exit_2(argv, words, capsys):
    assert run_cli(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert err.startswith("softrnn: error:")
    assert "Traceback" not in err
    for w in words:
        assert w in err


def test_rod_overrides_change_the_run(capsys):
    assert run_cli(["simulate", "square", "--samples", "11", "--quiet", "--youngs-modulus", "1e7"]) == 0
    out = capsys.readouterr().out
    assert "E = 10 MPa" in out and "2 substeps" in out  # a stiffer rod needs a smaller step


def test_bad_input_leaves_no_partial_file(tmp_path):
    target = tmp_path / "summary.json"
    assert run_cli(["simulate", "square", "--samples", "0", "--json", str(target)]) == 2
    assert list(tmp_path.iterdir()) == []


def _light_steps(monkeypatch):
    """The slow steps that have their own tests (bench, the magnetic experiment, control, Fig. 13/14) replaced by
    fakes that record their calls; the data, node-model and manipulator steps run for real."""
    calls = []

    def fake(name, value):
        def step(*a, **k):
            calls.append(name)
            return value
        return step

    monkeypatch.setattr(reproduce_benchmark, "run_all", fake("bench", {"machine": {"cpu": "x"}, "fake": True}))
    monkeypatch.setattr(reproduce_mod, "magnetic_step", fake("magnetic", None))
    monkeypatch.setattr(reproduce_mod, "control_step", fake("control", None))
    monkeypatch.setattr(reproduce_mod, "fig13_step", fake("fig13", None))
    monkeypatch.setattr(reproduce_mod, "fig14_step", fake("fig14", None))
    monkeypatch.setattr(reproduce_mod, "warm_start", lambda out, quick, part="simulator": None)  # not compiled
    monkeypatch.setattr(reproduce_mod, "model_start", lambda out, quick: None)  # the control model's: not run
    return calls


def _tiny_dynamic(monkeypatch):
    """The whole-manipulator model step at its smallest: one training and one held-out variant of
    1 s per case, a small model trained 3 steps, short speed runs."""
    cases = reproduce_dynamic.CASES
    monkeypatch.setattr(reproduce_dynamic, "QUICK_SWEEP", {"dt": 0.01, "n_train": 1, "n_validation": 0,
                                                           "n_heldout": 1, "workers": 1,
                                                           "duration_s": dict.fromkeys(cases, 1.0)})
    monkeypatch.setattr(reproduce_dynamic, "CONFIGS", dict.fromkeys(
        cases, DynamicConfig(node_stride=10, width=8, layers=1, unroll=2, batch=4)))
    monkeypatch.setattr(reproduce_dynamic, "QUICK_STEPS", 3)
    monkeypatch.setattr(reproduce_dynamic, "QUICK_SPEED", {"duration_s": 0.3, "reps": 1, "steps": 50})
    monkeypatch.setattr(reproduce_tendons, "QUICK_SWEEP", {"dt": 0.01, "n_train": 1, "n_validation": 0,
                                                           "n_heldout": 1, "workers": 1, "duration_s": 1.0})
    monkeypatch.setattr(reproduce_tendons, "CONFIGS", dict.fromkeys(
        reproduce_tendons.CASES, DynamicConfig(drive="actuation", node_stride=10, width=8, layers=1, unroll=2,
                                               batch=4)))
    monkeypatch.setattr(reproduce_tendons, "QUICK_STEPS", 3)


def _check_dynamic(out, report):
    """report.json's whole-manipulator entries have every key docs/report-format.md promises."""
    for case in reproduce_dynamic.CASES:
        e = report["dynamic_model"][case]
        for key in ("model_dt_s", "predicted_nodes", "test_span_max_pct_of_length", "generalisation_max_pct_of_length",
                    "speed_ratio_vs_simulator", "simulator_sim_s_per_wall_s", "model_sim_s_per_wall_s",
                    "train_seconds", "train_config", "figure", "rollout", "goals"):
            assert key in e, (case, key)
        assert set(e["heldout"]) >= {"variants", "median_max_pct_of_length", "worst_max_pct_of_length"}
        assert set(e["horizons"]) == {"10", "100", "1000"}
        for row in e["horizons"].values():
            assert set(row) == {"model", "persistence", "constant_velocity", "linear"}
        assert e["speed_ratio_vs_simulator"] > 0 and e["model_dt_s"] == 0.02
        assert all(isinstance(g["met"], bool) for g in e["goals"].values())
        assert (out / e["model"] / "model.json").is_file()
        assert (out / "figures" / e["figure"]).stat().st_size > 1000
    assert "## Whole-manipulator dynamic model" in (out / "report.md").read_text()
    for arm in reproduce_tendons.CASES:
        e = report["tendons"][arm]
        assert e["drive"] == "actuation" and e["channels"] and set(e["horizons"]) == {"10", "100", "1000"}
        assert all(isinstance(g["met"], bool) for g in e["goals"].values())
        assert f"### {arm}" in (out / "report.md").read_text()
    assert set(report["step_seconds"]) >= {"cases", "dynamic_model", "tendons", "benchmark"}


def test_reproduce_writes_report_and_resumes(tmp_path, monkeypatch):
    monkeypatch.setattr(reproduce_cases, "QUICK_FRACTION", 0.002)
    monkeypatch.setattr(reproduce_cases, "ANIMATION_FRAMES", 4)
    steps = _light_steps(monkeypatch)
    _tiny_dynamic(monkeypatch)
    out = tmp_path / "rep"
    assert run_cli(["reproduce", "--quick", "-o", str(out)]) == 0
    assert sorted(steps) == ["bench", "control", "fig13", "fig14", "magnetic"]
    report = json.loads((out / "report.json").read_text())
    assert report["manipulator"]["modelled_nodes"] > 0 and "errors" in report["manipulator"]
    for case in ("ellipse", "square", "semicircle"):
        assert report[case]["engine_vs_pytorch"]["steps"] > 0
    for case in ("ellipse", "square", "semicircle"):
        assert report[case]["simulation"]["n_samples"] > 1
        assert report[case]["generalisation_data"]["n_samples"] > 1
        assert (out / report[case]["dataset"]).exists()
        assert report[case]["length_m"] > 0
        assert "analytical_model_s_per_node_step" in report[case]["paper"]
        for fig in report[case]["figures"]:
            assert (out / "figures" / fig).stat().st_size > 1000
    assert (out / "report.md").read_text().startswith("# softrnn reproduce report")
    _check_dynamic(out, report)

    # an interrupted run (one case's result missing) recomputes only that case
    (out / "cases" / "square.json").unlink()
    calls = []
    original = reproduce_cases.run_case

    def counting(case, quick, data_path, progress=None):
        calls.append(case.name)
        return original(case, quick, data_path, progress)

    def boom(*a, **k):
        raise AssertionError("finished step recomputed")

    monkeypatch.setattr(reproduce_cases, "run_case", counting)
    import softrnn.learned.node.train as train_mod
    import softrnn.learned.whole.fit as dynamic_fit
    import softrnn.sweeps.sweep as sweep_mod
    monkeypatch.setattr(train_mod, "train_node_model", boom)   # no model is trained again
    monkeypatch.setattr(dynamic_fit, "fit", boom)
    monkeypatch.setattr(sweep_mod, "run_sweep", boom)          # nor a sweep run
    assert run_cli(["reproduce", "--quick", "-o", str(out)]) == 0
    assert calls == ["square"]


def test_every_command_has_a_working_help(capsys):
    from softrnn.cli.main import build_parser, main

    commands = build_parser()._subparsers._group_actions[0].choices
    for argv in [["--help"]] + [[name, "--help"] for name in commands]:
        try:
            main(argv)
        except SystemExit as exc:
            assert exc.code == 0, argv
    assert "usage" in capsys.readouterr().out


def test_bench_refuses_unknown_parts(capsys):
    from softrnn.cli.main import main

    assert main(["bench", "--only", "model,gpu"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("softrnn: error: --only") and "\n" not in err


def test_version_names_the_installed_package(capsys):
    import softrnn

    assert run_cli(["--version"]) == 0
    assert capsys.readouterr().out.strip() == f"softrnn {softrnn.__version__}"
