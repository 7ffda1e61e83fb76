"""A reproduce report against its committed reference (softrnn.reproduce.compare, ``softrnn reproduce
--compare``): an accuracy figure that moves fails, naming it; a timing that moves does not."""

import copy
import json
from pathlib import Path

import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.learned.threads import PINNED_NUMERICS
from softrnn.reproduce import compare as cmp

from helpers import run_cli


def _report(quick=True) -> dict:
    """A small stand-in of report.json: accuracy figures beside timings, paths and the machine."""
    return {
        "softrnn_version": "1.0", "quick": quick,
        "machine": {"cpu": "x86", "cores": 2, "load_average": [1.0, 1.0, 1.0]},
        "ellipse": {"simulation": {"dt_s": 0.001, "step_s": 8.3e-05, "wall_time_s": 4.5, "us_per_node_step": 0.13,
                                   "output": "/tmp/a/data/ellipse.h5", "energy_end_j": 0.018},
                    "one_step": {"max_abs": [0.0243, 0.0484, 0.0001]},
                    "engine_vs_pytorch": {"max_abs_difference_m": 1e-7, "engine_s": 0.02, "pytorch_s": 1.6}},
        "dynamic_model": {"ellipse": {"step_s": 764.5, "train_seconds": 300.0, "heldout": {"per_variant": [0.64, 0.52]},
                                      "goals": {"speed_ratio_vs_simulator": {"value": 16.1, "goal": 10.0, "met": True},
                                                "test_span_max_pct_of_length": {"value": 3.79, "goal": 2.0,
                                                                                "met": False}}}},
        "fig14": {"rmse_mm": [[0.02, 0.03]], "bandwidth_hz": [[5e5, 4e5]],
                  "regions": {"torch_bandwidth": {"best": {"units": 5}}, "rms_error": {"best": {"units": 20}}}},
        "magnetic": {"best_on_bending_axis": "rnn", "files": {"robot": "out/reproduce-quick/magnetic/robot.h5"}},
        "step_seconds": {"cases": 11.7, "control": 49.5},
        "benchmark": {"model": {"manipulator_threads": 2}, "dynamic": {"cases": {"square": {"goal_met": True}}}},
    }


def _moved_key(run, ref=None) -> list[str]:
    return [m.key for m in cmp.compare(run, ref or _report())]


def test_equal_figures_pass():
    assert cmp.compare(_report(), _report()) == []


@pytest.mark.parametrize("path,value", [
    (("step_seconds", "cases"), 99.0),
    (("ellipse", "simulation", "wall_time_s"), 9.0),
    (("ellipse", "simulation", "us_per_node_step"), 0.4),
    (("ellipse", "engine_vs_pytorch", "pytorch_s"), 3.0),
    (("dynamic_model", "ellipse", "step_s"), 1000.0),
    (("dynamic_model", "ellipse", "train_seconds"), 1.0),
    (("dynamic_model", "ellipse", "goals", "speed_ratio_vs_simulator", "met"), False),
    (("fig14", "regions", "torch_bandwidth", "best", "units"), 20),
    (("machine", "cpu"), "AMD EPYC"),
    (("softrnn_version",), "1.1"),
    (("magnetic", "files", "robot"), "/elsewhere/magnetic/robot.h5"),
    (("benchmark", "model", "manipulator_threads"), 1),                 # the fastest count, chosen by speed
    (("benchmark", "dynamic", "cases", "square", "goal_met"), False),   # a speed goal
])
def test_a_moved_timing_path_or_machine_passes(path, value):
    run = copy.deepcopy(_report())
    d = run
    for k in path[:-1]:
        d = d[k]
    d[path[-1]] = value
    assert _moved_key(run) == []


@pytest.mark.parametrize("path,value,key", [
    (("ellipse", "one_step", "max_abs"), [0.0243, 0.04840001, 0.0001], "ellipse/one_step/max_abs[1]"),
    (("ellipse", "simulation", "step_s"), 9e-05, "ellipse/simulation/step_s"),     # the integration step
    (("ellipse", "engine_vs_pytorch", "max_abs_difference_m"), 2e-7, "ellipse/engine_vs_pytorch/max_abs_difference_m"),
    (("dynamic_model", "ellipse", "goals", "test_span_max_pct_of_length", "met"), True,
     "dynamic_model/ellipse/goals/test_span_max_pct_of_length/met"),
    (("fig14", "regions", "rms_error", "best", "units"), 25, "fig14/regions/rms_error/best/units"),
    (("magnetic", "best_on_bending_axis"), "static", "magnetic/best_on_bending_axis"),
])
def test_a_moved_accuracy_figure_fails_naming_it(path, value, key):
    run = copy.deepcopy(_report())
    d = run
    for k in path[:-1]:
        d = d[k]
    d[path[-1]] = value
    assert _moved_key(run) == [key]
    text = cmp.summary(cmp.compare(run, _report()), 10)
    assert key in text and text.startswith("1 of 10 accuracy figures moved")


def test_a_figure_only_one_side_has_is_a_move():
    run = copy.deepcopy(_report())
    del run["ellipse"]["simulation"]["energy_end_j"]
    run["ellipse"]["one_step"]["mean_abs"] = [0.004]
    moved = {m.key: m for m in cmp.compare(run, _report())}
    assert moved["ellipse/simulation/energy_end_j"].run == cmp.MISSING
    assert moved["ellipse/one_step/mean_abs[0]"].reference == cmp.MISSING


def test_nan_equals_nan_and_a_relative_change_is_shown():
    ref = _report()
    ref["ellipse"]["one_step"]["max_abs"][0] = float("nan")
    assert cmp.compare(copy.deepcopy(ref), ref) == []
    assert "relative" in cmp.Moved("k", 1.0, 1.5).line()


def _write(folder, report):
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "report.json").write_text(json.dumps(report))
    (folder / "report.md").write_text("# report\n")
    return folder


def test_check_refuses_a_quick_run_against_a_full_reference(tmp_path):
    same, text = cmp.check(_write(tmp_path / "run", _report()), _write(tmp_path / "ref", _report(quick=False)))
    assert not same and "compare like with like" in text


def test_a_missing_reference_is_one_line(tmp_path):
    with pytest.raises(SoftrnnInputError, match=r"--compare=.*is invalid: a reproduce folder with report.json"):
        cmp.load_report(tmp_path / "nowhere", "--compare")


def test_save_reference_copies_the_run_and_names_it(tmp_path):
    run = _write(tmp_path / "out", _report())
    (run / "figures").mkdir()
    for name in ("fig13.png", "extra.png"):
        (run / "figures" / name).write_bytes(b"new " + name.encode())
    ref = tmp_path / "ref"
    (ref / "figures").mkdir(parents=True)
    (ref / "figures" / "fig13.png").write_bytes(b"old")
    cmp.save_reference(run, ref, notes="why")
    assert json.loads((ref / "report.json").read_text()) == _report()
    assert (ref / "figures" / "fig13.png").read_bytes() == b"new fig13.png"
    assert not (ref / "figures" / "extra.png").exists()          # only the figures the reference shows
    info = json.loads((ref / "run.json").read_text())
    assert info["wall_time_s"] == round(11.7 + 49.5) and info["notes"] == "why"
    assert info["command"].startswith("softrnn reproduce --quick -o ")
    assert cmp.check(run, ref)[0]


def _fake_run(tmp_path, monkeypatch, report):
    calls = []

    def fake(out, quick, progress_factory):
        calls.append(out)
        _write(tmp_path / "out", report)

    monkeypatch.setattr("softrnn.reproduce.pipeline.reproduce", lambda out, *, quick, progress_factory: fake(out, quick,
                                                                                             progress_factory))
    return calls


def test_cli_compare_exits_1_on_a_moved_figure_and_0_on_a_moved_timing(tmp_path, monkeypatch, capsys):
    ref = _write(tmp_path / "ref", _report())
    moved = copy.deepcopy(_report())
    moved["fig14"]["rmse_mm"][0][1] = 0.031
    _fake_run(tmp_path, monkeypatch, moved)
    argv = ["reproduce", "--quick", "--quiet", "-o", str(tmp_path / "out"), "--compare", str(ref)]
    assert run_cli(argv) == 1
    captured = capsys.readouterr()
    assert "fig14/rmse_mm[0][1]: 0.03 -> 0.031" in captured.out and "make references" in captured.err
    timing = copy.deepcopy(_report())
    timing["step_seconds"]["control"] = 500.0
    _fake_run(tmp_path, monkeypatch, timing)
    assert run_cli(argv) == 0
    assert "accuracy figures equal the reference" in capsys.readouterr().out


def test_cli_refuses_a_bad_reference_before_running(tmp_path, monkeypatch, capsys):
    calls = _fake_run(tmp_path, monkeypatch, _report())
    out = str(tmp_path / "out")
    assert run_cli(["reproduce", "--quick", "-o", out, "--compare", str(tmp_path / "nowhere")]) == 2
    full = _write(tmp_path / "full", _report(quick=False))
    assert run_cli(["reproduce", "--quick", "-o", out, "--compare", str(full)]) == 2
    err = capsys.readouterr().err
    assert "--compare=" in err and "drop --quick" in err
    assert calls == []


def test_the_committed_quick_reference_is_a_pinned_quick_run_of_every_step():
    folder = Path(__file__).resolve().parents[2] / "docs" / "results" / "reference-quick"
    report = cmp.load_report(folder)
    run = json.loads((folder / "run.json").read_text())
    assert report["quick"] is True, "CI compares a quick run: the quick reference must be one"
    assert report["machine"]["numerics"] == PINNED_NUMERICS, "made without the pinned code paths"
    assert report["machine"]["numerics_in_force"]["openblas"] == "Haswell"
    assert "AVX512" not in report["machine"]["numerics_in_force"]["numpy_simd"]
    assert report["machine"]["numerics_in_force"]["numpy_simd"] != "X86_V4"
    assert set(report["step_seconds"]) == {"cases", "node_models", "manipulator", "dynamic_model", "tendons",
                                           "magnetic", "control", "fig13", "fig14", "benchmark"}
    assert run["commit"] and run["command"].startswith("softrnn reproduce --quick")
    assert len(cmp.figures(report)) > 1000


def test_moved_figures_name_the_code_paths_that_differ_from_the_reference(tmp_path):
    ref = _report()
    ref["machine"].update(numpy="2.4.6", numerics={"OPENBLAS_CORETYPE": "Haswell"},
                          numerics_in_force={"numpy_simd": "X86_V3", "openblas": "Haswell"})
    run = copy.deepcopy(ref)
    run["machine"].update(cpu="other", numerics_in_force={"numpy_simd": "AVX512_SKX", "openblas": "SkylakeX"})
    same, text = cmp.check(_write(tmp_path / "run", run), _write(tmp_path / "ref", ref))
    assert same and "code paths" not in text                     # nothing moved: no diagnosis
    run["fig14"]["rmse_mm"][0][1] = 0.031
    same, text = cmp.check(_write(tmp_path / "run", run), _write(tmp_path / "ref", ref))
    assert not same
    assert text.splitlines()[-1] == ("the run's numeric code paths differ from the reference's: "
                                     "numerics_in_force.numpy_simd: X86_V3 -> AVX512_SKX; "
                                     "numerics_in_force.openblas: Haswell -> SkylakeX; cpu: x86 -> other")
    assert cmp.code_path_differences(ref, copy.deepcopy(ref)) == []
    run = copy.deepcopy(ref)
    run["machine"]["cpu"] = "other"                                # another processor, the same code paths
    assert cmp.code_path_differences(run, ref) == []
