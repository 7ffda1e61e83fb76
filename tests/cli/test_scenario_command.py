"""softrnn scenario list | show NAME | copy NAME -o FILE: every shipped scenario listed, its text
shown exactly as shipped, a copy that loads to the same scenario, one-line errors (exit code 2) that
leave no file behind; and the shipped [calibrate] tables."""

import json

import pytest

from softrnn.cli._scenario import renamed
from softrnn.scenarios.scenario import SCENARIO_NAMES, load_scenario, scenario_text

from helpers import run_cli

CALIBRATED = ("tendon-planar", "tendon-planar-sine", "tendon-spatial", "tendon-spatial-sine", "tendon-displacement",
              "steel-wire", "nitinol-guidewire")


def test_list_shows_every_scenario_and_writes_the_same_as_json(tmp_path, capsys):
    out = tmp_path / "list.json"
    assert run_cli(["scenario", "list", "--json", str(out)]) == 0
    lines = capsys.readouterr().out.splitlines()
    listed = [line.split()[0] for line in lines[1:1 + len(SCENARIO_NAMES)]]
    assert listed == list(SCENARIO_NAMES)
    entries = json.loads(out.read_text())["scenarios"]
    assert [e["name"] for e in entries] == list(SCENARIO_NAMES)
    for line, e in zip(lines[1:], entries):
        assert line.split()[1] == str(e["n_nodes"]) and e["integrator"] in line and line.endswith(e["title"])
    wire = entries[SCENARIO_NAMES.index("steel-wire")]
    assert (wire["n_nodes"], wire["duration_s"], wire["integrator"]) == (21, 2.0, "implicit")
    assert wire["calibrate"] == ["rod.youngs_modulus", "damping.kelvin_voigt"]


def test_show_prints_the_exact_text(capsys):
    for name in SCENARIO_NAMES:
        assert run_cli(["scenario", "show", name]) == 0
        assert capsys.readouterr().out == scenario_text(name)


def test_show_summary_and_a_file(tmp_path, capsys):
    assert run_cli(["scenario", "show", "tendon-displacement", "--summary"]) == 0
    text = capsys.readouterr().out
    for words in ("tendon-displacement: ", "rod: L = 0.4 m", "boundary: clamp at node 0", "tendons: a (displacement",
                  "run: 10001 samples every 0.001 s (10 s)", "tendons.2.stiffness in [500, 8000]",
                  "assumptions:", "tendon_displacement_servo:"):
        assert words in text, words
    path = tmp_path / "wire.toml"
    path.write_text(scenario_text("steel-wire").replace("duration = 2.0", "duration = 0.5"))
    assert run_cli(["scenario", "show", str(path)]) == 0
    assert capsys.readouterr().out == path.read_text()
    assert run_cli(["scenario", "show", str(path), "--summary"]) == 0
    assert "501 samples every 0.001 s (0.5 s)" in capsys.readouterr().out


def test_copy_round_trips_every_scenario(tmp_path, capsys):
    for name in SCENARIO_NAMES:
        path = tmp_path / f"my-{name}.toml"
        assert run_cli(["scenario", "copy", name, "-o", str(path)]) == 0
        said = capsys.readouterr().out
        assert f"wrote {path}" in said and f"softrnn simulate {path}" in said
        title = f"A copy of the shipped scenario {name}, to edit"
        assert path.read_text() == renamed(scenario_text(name), f"my-{name}", title)
        copy, shipped = load_scenario(path), load_scenario(name)
        assert (copy.name, copy.title) == (f"my-{name}", title)      # the copy is named, not the shipped one
        assert (copy.text, copy.seed) == (path.read_text(), shipped.seed)
        assert {k: v for k, v in copy.data.items() if k not in ("name", "title")} == \
               {k: v for k, v in shipped.data.items() if k not in ("name", "title")}
        assert (copy.config, copy.setup.rod, copy.nodes_of_interest) == \
               (shipped.config, shipped.setup.rod, shipped.nodes_of_interest)
        assert (copy.calibrate, copy.randomize) == (shipped.calibrate, shipped.randomize)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(f"my-{n}.toml" for n in SCENARIO_NAMES)


def test_copy_refuses_an_existing_file_unless_overwrite(tmp_path, capsys):
    path = tmp_path / "mine.toml"
    path.write_text("# my edits\n")
    assert run_cli(["scenario", "copy", "square", "-o", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("softrnn: error: -o=") and "--overwrite" in err and "\n" not in err
    assert path.read_text() == "# my edits\n"
    assert run_cli(["scenario", "copy", "square", "-o", str(path), "--overwrite"]) == 0
    title = "A copy of the shipped scenario square, to edit"
    assert path.read_text() == renamed(scenario_text("square"), "mine", title)


@pytest.mark.parametrize("argv, words", [
    (["copy", "spiral", "-o", "x.toml"], ["NAME='spiral'", "steel-wire", "softrnn scenario list"]),
    (["copy", "square"], ["-o is missing", "-o my-square.toml"]),
    (["copy", "square", "-o", "x.txt"], ["-o='x.txt'", "ending in .toml"]),
    (["copy", "nope.toml", "-o", "x.toml"], ["NAME='nope.toml'", "a shipped scenario"]),
    (["copy", "-o", "x.toml"], ["required: NAME", "softrnn scenario copy --help"]),
    (["show", "spiral"], ["NAME='spiral'", "ellipse, ellipse-horizontal"]),
    (["show", "nope.toml"], ["NAME='nope.toml'", "no such file"]),
    (["show"], ["required: NAME"]),
    (["lst"], ["invalid choice: 'lst'", "softrnn scenario --help"]),
])
def test_bad_input_is_one_line_with_exit_2_and_no_file(argv, words, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert run_cli(["scenario", *argv]) == 2
    captured = capsys.readouterr()
    err = captured.err.strip()
    assert err.startswith("softrnn: error: ") and "\n" not in err and "Traceback" not in captured.err
    for w in words:
        assert w in err, (w, err)
    assert captured.out == "" and list(tmp_path.iterdir()) == []


def test_a_bad_file_is_reported_on_show(tmp_path, capsys):
    path = tmp_path / "bad.toml"
    path.write_text(scenario_text("square").replace("radius = 0.01", "radius = -0.01"))
    assert run_cli(["scenario", "show", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"softrnn: error: {path}: rod.radius") and "\n" not in err


def test_list_refuses_an_existing_json_file(tmp_path, capsys):
    out = tmp_path / "list.json"
    out.write_text("{}")
    assert run_cli(["scenario", "list", "--json", str(out)]) == 2
    assert capsys.readouterr().err.strip().startswith("softrnn: error: --json=")
    assert out.read_text() == "{}"


@pytest.mark.parametrize("name", CALIBRATED)
def test_shipped_calibrate_tables_load_and_hold_their_starts(name):
    sc = load_scenario(name)
    assert "rod.youngs_modulus" in sc.calibrate
    assert any(k.startswith("damping.") for k in sc.calibrate)
    for key, (lo, hi, start) in sc.calibrate.items():
        value = sc.data
        for part in key.split("."):
            value = value[int(part)] if isinstance(value, list) else value[part]
        assert start is None and lo < value < hi, key      # the file's value is the start, inside the bounds


def test_a_copy_steered_elsewhere_does_not_keep_the_shipped_title(tmp_path, capsys):
    path = tmp_path / "right.toml"
    assert run_cli(["scenario", "copy", "magnetic-bifurcation", "-o", str(path)]) == 0
    said = capsys.readouterr().out
    assert "a copy of the shipped scenario magnetic-bifurcation, named right" in said
    steered = path.read_text().replace("field_mT = [0.0, 15.0, 0.0]", "field_mT = [0.0, -15.0, 0.0]")
    path.write_text(steered)
    copy = load_scenario(path)
    assert copy.name == "right" and "left branch" not in copy.title
    assert run_cli(["scenario", "show", str(path), "--summary"]) == 0
    first = capsys.readouterr().out.splitlines()[0]
    assert first == "right: A copy of the shipped scenario magnetic-bifurcation, to edit"
