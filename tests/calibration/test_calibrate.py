"""softrnn calibrate: a scenario's values fitted to a recorded dataset (issue 13). A 9-node cantilever
under gravity and a sinusoidal tip force, simulated for 1 s: noise-free data from perturbed values
are recovered, the fitted file loads and keeps the user's comments, degenerate pairs are flagged,
bad input is one line with exit code 2 and no output, an interrupted run resumes from its trials,
and trials the simulator refuses are penalised and counted."""

import json
import tomllib

import numpy as np
import pytest

from softrnn.calibration import scenario as calibration
from softrnn.errors import SoftrnnInputError
from softrnn.io import Dataset, read_dataset, write_dataset
from softrnn.rod import Simulator
from softrnn.scenarios import ScenarioError, load_scenario, parse_scenario

from helpers import run_cli

E0, CT0 = 2.5e6, 0.5                 # nominal Young's modulus [Pa] and translational damping [N s/m^2]
TRUE = {"rod.youngs_modulus": 1.05 * E0, "damping.translational": 1.3 * CT0}
FIT = "rod.youngs_modulus,damping.translational"


BOUNDS = '"rod.youngs_modulus" = { bounds = [1e6, 5e6] }\ndamping.translational = { bounds = [0.1, 2.0] }'


def cantilever(*, E=E0, ct=CT0, n_nodes=9, gravity=-9.81, force=0.05, frequency=2.0, dt=0.005, substeps=48,
               calibrate=BOUNDS, extra=""):
    """The test scenario's TOML: a clamped 0.2 m rod along x, a sinusoidal tip force along y."""
    return f"""# A tiny cantilever (the user's own comment, to be kept).
name = "tiny"
gravity = [0.0, 0.0, {gravity}]

[rod]
length = 0.2
radius = 0.01
n_nodes = {n_nodes}
youngs_modulus = {E!r}   # Pa, a guess from the data sheet
density = 1000.0

[reference]
kind = "straight"
direction = [1.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]

[[boundary]]
kind = "clamp"
node = 0

[[loads]]
kind = "force"
node = -1
profile = {{ kind = "sinusoid", amplitude = [0.0, {force!r}, 0.0], frequency = {frequency!r} }}

[damping]
translational = {ct!r}   # N s/m^2

[run]
dt = {dt!r}
duration = 1.0
substeps = {substeps}
nodes_of_interest = [-1]
{extra}
[calibrate]
{calibrate}
"""


def record(folder, name, text) -> str:
    """Simulate the scenario ``text`` (every node) into ``folder/name.h5``; returns the path."""
    (folder / f"{name}.toml").write_text(text)
    out = folder / f"{name}.h5"
    assert run_cli(["simulate", str(folder / f"{name}.toml"), "-o", str(out), "--quiet"]) == 0
    return str(out)


def calibrate(data, scenario, out, *extra) -> tuple[int, dict | None]:
    """``softrnn calibrate`` in this process: (exit code, the report or None)."""
    code = run_cli(["calibrate", str(data), "--scenario", str(scenario), "--fit", FIT, "-o", str(out), "--quiet",
                    *extra])
    report = out.with_suffix(".json")
    return code, json.loads(report.read_text()) if code == 0 and report.exists() else None


@pytest.fixture(scope="module")
def case(tmp_path_factory):
    """Data from the perturbed values, the nominal scenario, and one calibration of it."""
    folder = tmp_path_factory.mktemp("calibrate")
    data = record(folder, "truth", cantilever(E=TRUE["rod.youngs_modulus"], ct=TRUE["damping.translational"]))
    (folder / "nominal.toml").write_text(cantilever())
    out = folder / "fitted" / "fitted.toml"
    code, report = calibrate(data, folder / "nominal.toml", out)
    assert code == 0
    return {"folder": folder, "data": data, "scenario": folder / "nominal.toml", "out": out, "report": report}


# ------------------------------------------------------------------------------------- the fit
def test_noise_free_data_recover_the_true_values(case):
    report = case["report"]
    for key, truth in TRUE.items():
        p = report["parameters"][key]
        assert abs(p["fitted"] / truth - 1) < 1e-3, (key, p)          # the goal: within 0.1 %
        assert p["start"] == pytest.approx(E0 if key == "rod.youngs_modulus" else CT0)
        assert 0 < p["std_error"] < 1e-3 * truth
    assert report["not_identifiable"] == []
    assert report["converged"] and report["failed_trials"] == 0
    assert report["error"]["fitted"]["rms_m"] < 1e-3 * report["error"]["start"]["rms_m"]
    assert report["span"]["samples"] == [0, 120]                      # floor(0.6 * 201): the training span
    assert report["nodes"] == list(range(9)) and report["substeps"] == 48


def test_outputs_fitted_file_loads_simulates_and_keeps_comments(case, capsys):
    out, report = case["out"], case["report"]
    text = out.read_text()
    assert text.startswith("# Calibrated by softrnn calibrate from truth.h5")
    assert "# A tiny cantilever (the user's own comment, to be kept)." in text
    assert "# Pa, a guess from the data sheet" in text and "# N s/m^2" in text
    values = tomllib.loads(text)
    assert values["rod"]["youngs_modulus"] == report["parameters"]["rod.youngs_modulus"]["fitted"]
    assert values["damping"]["translational"] == report["parameters"]["damping.translational"]["fitted"]
    sc = load_scenario(out)
    assert sc.setup.rod.youngs_modulus == report["parameters"]["rod.youngs_modulus"]["fitted"]
    assert run_cli(["simulate", str(out), "--samples", "11", "--quiet"]) == 0
    assert "tiny" in capsys.readouterr().out
    assert out.with_suffix(".png").stat().st_size > 10_000
    assert sorted(p.name for p in out.parent.iterdir()) == ["fitted.json", "fitted.png", "fitted.toml"]  # no cache


def test_identifiability_warning_for_a_load_and_the_modulus(tmp_path, capsys):
    """Slow, small deflections without gravity: the tip moves by force / stiffness, so only the ratio
    of the force amplitude and Young's modulus is fixed by the data."""
    common = dict(gravity=0.0, frequency=0.1, ct=2.0,
                  calibrate='"rod.youngs_modulus" = { bounds = [1e6, 5e6] }\n'
                            '"loads.0.profile.amplitude.1" = { bounds = [0.01, 0.04] }')
    data = record(tmp_path, "truth", cantilever(force=0.026, **common))
    (tmp_path / "nominal.toml").write_text(cantilever(force=0.02, **common))
    out = tmp_path / "fit.toml"
    code = run_cli(["calibrate", data, "--scenario", str(tmp_path / "nominal.toml"), "--fit",
                    "rod.youngs_modulus,loads.0.profile.amplitude.1", "-o", str(out), "--quiet", "--span", "all"])
    assert code == 0
    report = json.loads(out.with_suffix(".json").read_text())
    corr = report["correlation"]["rod.youngs_modulus"]["loads.0.profile.amplitude.1"]
    assert abs(corr) > 0.99
    assert any("rod.youngs_modulus and loads.0.profile.amplitude.1" in w for w in report["not_identifiable"])
    assert "warning: not identifiable" in capsys.readouterr().out


def test_resume_replays_the_finished_trials(case, monkeypatch):
    out = case["folder"] / "resume" / "fitted.toml"
    cache = out.parent / ".fitted.toml.trials"
    calls = []
    real = calibration.ScenarioModel.positions

    def interrupted(self, values):
        calls.append(values)
        if len(calls) == 6:
            raise KeyboardInterrupt
        return real(self, values)

    monkeypatch.setattr(calibration.ScenarioModel, "positions", interrupted)
    assert calibrate(case["data"], case["scenario"], out)[0] == 130           # Ctrl-C during the fit
    assert [p.name for p in out.parent.iterdir()] == [cache.name]             # only the trials, nothing half-written
    assert 3 <= len(list(cache.glob("trial-*.npy"))) <= 5                    # the batches that finished
    monkeypatch.setattr(calibration.ScenarioModel, "positions", real)

    def no_figure(*a, **k):                                                   # Ctrl-C after the fit, before writing
        raise KeyboardInterrupt

    import softrnn.cli._calibrate as command
    monkeypatch.setattr(command, "_figure_bytes", no_figure)
    assert calibrate(case["data"], case["scenario"], out)[0] == 130
    assert [p.name for p in out.parent.iterdir()] == [cache.name]
    monkeypatch.undo()
    code, report = calibrate(case["data"], case["scenario"], out)
    assert code == 0
    assert report["cached_trials"] == report["trials"] == case["report"]["trials"]
    for key in TRUE:
        assert report["parameters"][key] == case["report"]["parameters"][key]    # identical, bit for bit
    assert not cache.exists()


def test_failing_trials_are_penalised_and_counted(tmp_path, capsys):
    """With explicit run.substeps, a stiffer rod than the step allows is refused: the trials beyond
    1.02 E0 fail while the data (1.1 E0) pull the fit there; the fit still ends."""
    sc = parse_scenario(cantilever(E=1.02 * E0))
    h = Simulator(sc.setup).stable_step(sc.config.safety)
    dt = 32 * h
    data = record(tmp_path, "truth", cantilever(E=1.1 * E0, dt=dt, substeps='"auto"'))
    (tmp_path / "nominal.toml").write_text(cantilever(dt=dt, substeps=32))
    out = tmp_path / "fit.toml"
    code, report = calibrate(data, tmp_path / "nominal.toml", out)
    assert code == 0
    assert report["failed_trials"] > 0
    assert report["trials"] > report["failed_trials"]
    assert E0 < report["parameters"]["rod.youngs_modulus"]["fitted"] <= 1.02 * E0
    assert report["error"]["fitted"]["rms_m"] < report["error"]["start"]["rms_m"]
    assert f"{report['failed_trials']} failed" in capsys.readouterr().out


# ---------------------------------------------------------------------------------- bad input
def _offset_times(case, folder) -> str:
    ds = read_dataset(case["data"])
    shifted = Dataset(time=ds.time + 0.5 * ds.dt, nodes=ds.nodes, positions=ds.positions, quaternions=ds.quaternions,
                      forces=ds.forces, torques=ds.torques, attrs=ds.attrs)
    path = folder / "shifted.h5"
    write_dataset(path, shifted)
    return str(path)


@pytest.mark.parametrize("what, words", [
    ("unknown key", ["--fit='rod.youngs_modulu'", "did you mean 'youngs_modulus'?"]),
    ("unknown table", ["--fit='rods.youngs_modulus'", "has no key 'rods'"]),
    ("text key", ["--fit='reference.kind'", "value is a number"]),
    ("vector key", ["--fit='loads.0.profile.amplitude'", "name one component"]),
    ("no bounds", ["--fit='rod.density'", "[calibrate]"]),
    ("bounds exclude start", ["bad.toml: calibrate:", "'rod.youngs_modulus' exclude its start 2.5e+06"]),
    ("start outside bounds", ["bad.toml: calibrate:", "exclude its start 6e+06"]),
    ("node count", ["DATA=", "11 nodes", "rod.n_nodes"]),
    ("time grid", ["DATA=", "resample"]),
    ("span reversed", ["--span='0.5:0.2'", "T0:T1"]),
    ("span words", ["--span='first'", "train"]),
    ("span beyond", ["--span='0:9'", "the data's end"]),
    ("span short", ["--span='0:0.001'", "at least 2 samples"]),
    ("node", ["--nodes=20", "recorded node"]),
    ("suffix", ["-o=", ".toml"]),
    ("evaluations", ["--max-evaluations=1", ">= 2"]),
])
def test_bad_input_is_one_line_exit_2_and_no_output(case, tmp_path, capsys, what, words):
    scenario, data, fit, extra = case["scenario"], case["data"], FIT, []
    out = tmp_path / "out" / "fitted.toml"
    if what in ("unknown key", "unknown table", "text key", "vector key", "no bounds"):
        fit = words[0].split("'")[1]
    elif what in ("bounds exclude start", "start outside bounds"):
        scenario = tmp_path / "bad.toml"
        entry = "bounds = [3e6, 4e6]" if what == "bounds exclude start" else "bounds = [1e6, 5e6], start = 6e6"
        scenario.write_text(cantilever(calibrate=f'"rod.youngs_modulus" = {{ {entry} }}'))
    elif what == "node count":
        data = record(tmp_path, "other", cantilever(n_nodes=11))
    elif what == "time grid":
        data = _offset_times(case, tmp_path)
    elif what.startswith("span"):
        extra = ["--span", words[0].split("'")[1]]
    elif what == "node":
        extra = ["--nodes", "20"]
    elif what == "suffix":
        out = tmp_path / "out" / "fitted.txt"
    elif what == "evaluations":
        extra = ["--max-evaluations", "1"]
    capsys.readouterr()
    code = run_cli(["calibrate", str(data), "--scenario", str(scenario), "--fit", fit, "-o", str(out), "--quiet",
                    *extra])
    assert code == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert err.startswith("softrnn: error:") and "Traceback" not in err
    for w in words:
        assert w in err, (w, err)
    assert not (tmp_path / "out").exists()


def test_existing_output_is_refused_without_overwrite(case, capsys):
    code = run_cli(["calibrate", case["data"], "--scenario", str(case["scenario"]), "--fit", FIT, "-o",
                    str(case["out"]), "--quiet"])
    assert code == 2
    assert "--overwrite" in capsys.readouterr().err


# ------------------------------------------------------------------------- the [calibrate] table
def test_calibrate_table_nested_tables_and_randomize_fallback():
    text = cantilever(calibrate="[calibrate.rod]\nyoungs_modulus = { bounds = [1e6, 5e6], start = 3e6 }",
                      extra='[randomize]\n"loads.0.profile.amplitude.1" = { uniform = [0.01, 0.1] }\n')
    sc = parse_scenario(text)
    assert sc.calibrate == {"rod.youngs_modulus": (1e6, 5e6, 3e6)}
    p = calibration.parameter_of(sc, "rod.youngs_modulus")
    assert (p.start, p.lower, p.upper, p.log) == (3e6, 1e6, 5e6, True)
    q = calibration.parameter_of(sc, "loads.0.profile.amplitude.1")     # bounds from [randomize]
    assert (q.start, q.lower, q.upper) == (0.05, 0.01, 0.1)
    trial = sc.with_values({"rod.youngs_modulus": 4e6, "loads.0.profile.amplitude.1": 0.02})
    assert trial.setup.rod.youngs_modulus == 4e6 and sc.setup.rod.youngs_modulus == E0


@pytest.mark.parametrize("table, words", [
    ('"rod.youngs_modulus" = { bound = [1e6, 5e6] }', ["calibrate.rod.youngs_modulus", "bounds = [lo, hi]"]),
    ('"rod.youngs_modulus" = { bounds = [5e6, 1e6] }', ["calibrate.rod.youngs_modulus.bounds", "lo < hi"]),
    ('"rod.youngs_modulus" = { bounds = [1e6, 5e6], start = "x" }', ["calibrate.rod.youngs_modulus.start"]),
    ('"rod.colour" = { bounds = [1, 2] }', ["'rod.colour'", "start"]),
    ('"reference.kind" = { bounds = [1, 2] }', ["'reference.kind'", "not a number"]),
    ('"loads.3.node" = { bounds = [1, 2] }', ["'loads.3.node' names no value", "list of 1 entries"]),
])
def test_bad_calibrate_table_is_a_scenario_error(table, words):
    with pytest.raises(ScenarioError) as err:
        parse_scenario(cantilever(calibrate=table))
    for w in words:
        assert w in str(err.value), (w, str(err.value))
    assert "\n" not in str(err.value)


def test_substeps_are_the_most_any_corner_needs():
    sc = parse_scenario(cantilever(substeps='"auto"'))
    params = calibration.parameters_of(sc, FIT)
    n = calibration.fixed_substeps(sc, params, 0.005)
    stiffest = sc.with_values({"rod.youngs_modulus": 5e6})
    assert n == int(np.ceil(0.005 / Simulator(stiffest.setup).stable_step(sc.config.safety)))
    assert n > int(np.ceil(0.005 / Simulator(sc.setup).stable_step(sc.config.safety)))
    fixed = parse_scenario(cantilever(substeps=48))
    assert calibration.fixed_substeps(fixed, calibration.parameters_of(fixed, FIT), 0.005) == 48
    assert calibration.fixed_substeps(fixed, calibration.parameters_of(fixed, FIT), 0.02) == 192   # the same step


def test_fitted_text_replaces_an_earlier_header():
    text = cantilever()
    once = calibration.fitted_text(text, {"rod.youngs_modulus": 2.6e6}, calibration.HEADER + " first")
    twice = calibration.fitted_text(once, {"loads.0.profile.amplitude.1": 0.07}, calibration.HEADER + " second")
    assert twice.splitlines()[0] == calibration.HEADER + " second"
    assert calibration.HEADER + " first" not in twice
    values = tomllib.loads(twice)
    assert values["rod"]["youngs_modulus"] == 2.6e6 and values["loads"][0]["profile"]["amplitude"] == [0.0, 0.07, 0.0]
    with pytest.raises(SoftrnnInputError, match="each key once"):
        calibration.parameters_of(parse_scenario(text), "rod.youngs_modulus,rod.youngs_modulus")
