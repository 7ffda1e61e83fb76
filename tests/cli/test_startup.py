"""The command line starts at once: ``softrnn --help``, ``--version``, bare ``softrnn`` and the
commands' ``--help`` import none of the heavy libraries (numba, SciPy, Matplotlib, PyTorch, h5py,
Dask, ONNX), which each command imports when it runs, and neither do ``scenario list`` and
``scenario show`` of a shipped scenario. Which modules a fresh interpreter imported is checked, never how long it took
(the times are in benchmarks/README.md)."""

import ast
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

import softrnn
from softrnn.bench.startup import commands_met, format_commands, time_commands
from softrnn.cli import _names
from softrnn.cli._lazy import LazyModule
from softrnn.cli.main import COMMANDS, build_parser
from softrnn.scenarios import SCENARIO_NAMES

from helpers import run_cli

HEAVY = ("numba", "scipy", "matplotlib", "mpl_toolkits", "torch", "h5py", "dask", "onnx", "onnxruntime")
"""The libraries that take a large part of a second or more to import."""

PLOTTING_AND_LEARNING = ("matplotlib", "mpl_toolkits", "torch", "dask", "onnx", "onnxruntime")

CLI = Path(softrnn.__file__).parent / "cli"

_PROBE = """
import contextlib, io, json, sys
from softrnn.cli.main import main
out = io.StringIO()
with contextlib.redirect_stdout(out):
    try:
        code = main(sys.argv[1:])
    except SystemExit as exc:
        code = exc.code
print(json.dumps({"code": code, "out": out.getvalue(), "modules": sorted({m.split(".")[0] for m in sys.modules})}))
"""


def _fresh(*argv: str) -> dict:
    """``softrnn ARGV`` in a fresh interpreter: its exit code, its standard output and the top-level
    packages it imported."""
    src = str(Path(softrnn.__file__).parents[1])
    paths = [src, *filter(None, os.environ.get("PYTHONPATH", "").split(os.pathsep))]
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(paths), NUMBA_NUM_THREADS="1")
    proc = subprocess.run([sys.executable, "-c", _PROBE, *argv], capture_output=True, text=True, env=env,
                          timeout=600, check=True)
    return json.loads(proc.stdout.splitlines()[-1])


@pytest.mark.parametrize("argv", [["--version"], ["--help"], [], ["scenario", "--help"], ["scenario", "list", "-h"],
                                  ["simulate", "--help"], ["animate", "--help"], ["show", "--help"], ["train", "-h"],
                                  ["dynamic", "train", "--help"], ["control", "magnetic", "--help"],
                                  ["lab", "benchmark", "--help"], ["import-csv", "--help"]])
def test_help_and_version_import_no_heavy_library(argv):
    run = _fresh(*argv)
    assert run["code"] == 0
    assert sorted(set(run["modules"]) & set(HEAVY)) == []
    assert "numpy" not in run["modules"]            # numpy alone is a tenth of a second


def test_the_lazy_module_loads_on_first_use():
    lazy = LazyModule("fractions")
    assert lazy.Fraction(1, 2) + lazy.Fraction(1, 2) == 1
    with pytest.raises(AttributeError):
        _ = lazy.no_such_name


def test_bare_softrnn_prints_the_help_and_succeeds(capsys):
    assert run_cli([]) == 0
    bare = capsys.readouterr()
    with pytest.raises(SystemExit) as exc:
        build_parser().parse_args(["--help"])
    assert exc.value.code == 0
    assert bare.out == capsys.readouterr().out
    assert bare.out.startswith("usage: softrnn") and "scenario" in bare.out and bare.err == ""


def test_bare_softrnn_in_a_fresh_interpreter():
    run = _fresh()
    assert run["code"] == 0 and run["out"].startswith("usage: softrnn")
    assert "lab-example" in run["out"]


def test_version_in_a_fresh_interpreter():
    run = _fresh("--version")
    assert run["code"] == 0 and run["out"].strip() == f"softrnn {softrnn.__version__}"


def test_the_start_up_benchmark_times_a_command():
    """``bench.startup`` (``simulator.commands``): wall and CPU times of fresh runs, the goal judged."""
    commands = time_commands(2, {"version": ("--version",)})
    entry = commands["version"]
    assert entry["argv"] == ["--version"] and len(entry["runs_s"]) == 2 and entry["goal_s"] == 0.3
    assert all(t > 0 for t in entry["runs_s"]) and entry["median_s"] > 0 and entry["cpu_s"] >= 0
    assert commands_met(commands) == {"version_start_s": entry["median_s"] <= 0.3}
    assert format_commands(commands)[1].startswith("  softrnn --version")


def test_scenario_list_imports_no_heavy_library():
    run = _fresh("scenario", "list")
    assert run["code"] == 0 and run["out"].splitlines()[1].split()[0] == SCENARIO_NAMES[0]
    assert sorted(set(run["modules"]) & set(HEAVY)) == []


def test_the_kept_scenario_list_is_the_one_built_from_the_scenarios():
    """``scenario list`` prints lines kept in ``cli._scenario_list``; they equal those built from the
    shipped scenarios (regenerate with ``cli._scenario.write_listing()`` after editing one)."""
    from softrnn.cli._scenario import built_listing
    from softrnn.cli._scenario_list import SCENARIO_LIST

    assert SCENARIO_LIST == built_listing()


@pytest.mark.parametrize("argv", [["scenario", "show", "square"], ["scenario", "show", "tendon-spatial", "--summary"],
                                  ["scenario", "show", "magnetic-bifurcation", "--summary"]])
def test_scenario_show_of_a_shipped_scenario_imports_no_heavy_library(argv):
    """The shipped text and the kept summary, as the built scenario gives them."""
    from softrnn.cli._scenario import summary
    from softrnn.scenarios.scenario import load_scenario, scenario_text

    run = _fresh(*argv)
    name = argv[2]
    assert run["code"] == 0
    assert run["out"] == (summary(load_scenario(name)) + "\n" if "--summary" in argv else scenario_text(name))
    assert sorted(set(run["modules"]) & set(HEAVY)) == []


def test_the_kept_scenario_summaries_are_the_ones_built_from_the_scenarios():
    """``scenario show NAME --summary`` prints lines kept in ``softrnn/data/scenario-summaries.json``;
    they equal those built from the shipped scenarios (regenerated with the list by
    ``cli._scenario.write_listing()``)."""
    from softrnn.cli._scenario import built_summaries, kept_summaries

    kept = kept_summaries()
    assert list(kept) == list(SCENARIO_NAMES)
    assert kept == built_summaries()


def test_every_command_parses_as_before_when_its_arguments_come_late():
    """``main``'s parser adds a command's arguments when it reaches the command: the same result as
    the complete tree's."""
    argv = ["simulate", "ellipse", "--samples", "3", "--integrator", "implicit", "--quiet"]
    late = build_parser(complete=False).parse_args(argv)
    assert vars(late) == vars(build_parser().parse_args(argv))


def test_the_names_the_help_shows_are_the_librarys():
    """The command line's copies of the library's names (``cli._names``, for the help) equal them."""
    from softrnn.control.controllers import CONTROLLERS
    from softrnn.control.references import REFERENCES
    from softrnn.figures.animation import STYLES
    from softrnn.lab.benchmark import FAMILIES
    from softrnn.lab.recording import AUTO_LAGS
    from softrnn.rod.simulation import INTEGRATORS

    assert _names.SCENARIO_NAMES == SCENARIO_NAMES
    assert (_names.INTEGRATORS, _names.STYLES, _names.FAMILIES, _names.AUTO_LAGS) == (INTEGRATORS, STYLES, FAMILIES,
                                                                                      AUTO_LAGS)
    assert (_names.CONTROLLERS, _names.REFERENCES) == (CONTROLLERS, REFERENCES)


def _top_imports(path: Path) -> list[str]:
    """The modules ``path`` imports at its top (outside functions and ``if TYPE_CHECKING:``)."""
    found = []
    for node in ast.parse(path.read_text(encoding="utf-8")).body:
        if isinstance(node, ast.Import):
            found += [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            found.append("." * node.level + (node.module or ""))
    return found


LIGHT = {"..errors", "..files", "__future__", "softrnn"}
"""What a command-line module may import at its top besides the standard library and its siblings."""


def test_the_command_line_modules_import_only_light_parts_at_their_top():
    """Each subcommand imports the library parts it needs inside its functions, when it runs."""
    stdlib = set(sys.stdlib_module_names)
    heavy = {f"{p.name}: {m}" for p in sorted(CLI.glob("*.py")) for m in _top_imports(p)
             if m not in LIGHT and m.split(".")[0] not in stdlib and not (m.startswith(".") and not m.startswith(".."))}
    assert heavy == set()
    assert {m.__name__.rpartition(".")[2] for m in COMMANDS} == {p.stem for p in CLI.glob("_*.py")} - {
        "__init__", "_lazy", "_names", "_progress", "_vocabulary", "_scenario_list"}
