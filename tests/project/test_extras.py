"""Optional extras: the simulator part (rod, scenarios, datasets, statics, magnetics, figures) works
without PyTorch, ONNX and Dask installed, and a command that needs a missing extra says in one line
which extra to install (exit code 2)."""

import subprocess
import sys

import pytest

OPTIONAL = ("torch", "safetensors", "onnx", "onnxruntime", "distributed", "dask")
BLOCK = f"import sys\nfor _m in {OPTIONAL!r}:\n    sys.modules[_m] = None   # importing _m raises ModuleNotFoundError\n"


def _python(code: str, tmp_path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", BLOCK + code], capture_output=True, text=True, cwd=tmp_path,
                          timeout=300)


def test_the_simulator_part_imports_no_optional_package(tmp_path):
    code = ("import softrnn.rod, softrnn.scenarios, softrnn.io, softrnn.statics, softrnn.magnetics, "
            "softrnn.figures.pictures, softrnn.figures.plots, softrnn.bench, softrnn.learned.node.data, "
            "softrnn.cli.main\n"
            f"print(sorted(m for m in {OPTIONAL!r} if sys.modules.get(m) is not None))\n")
    done = _python(code, tmp_path)
    assert done.returncode == 0, done.stderr[-3000:]
    assert done.stdout.strip() == "[]"


def test_simulate_runs_without_the_optional_packages(tmp_path):
    code = ("from softrnn.cli.main import main\n"
            "sys.exit(main(['simulate', 'semicircle', '--samples', '5', '-o', 'd.h5', '--quiet']))\n")
    done = _python(code, tmp_path)
    assert done.returncode == 0, done.stderr[-3000:]
    assert (tmp_path / "d.h5").is_file()


@pytest.mark.parametrize("argv, extra", [
    (["train", "d.h5", "--node", "3", "--quiet", "-o", "m"], "learn"),
    (["sweep", "semicircle", "--count", "2", "--quiet", "-o", "s"], "dask"),
    (["magnetic", "experiment", "--quick", "--quiet", "-o", "mx"], "learn"),
    (["reproduce", "--quick", "-o", "rq"], "learn"),
    (["bench", "--quick", "--json", "b.json"], "learn"),
])
def test_a_command_needing_a_missing_extra_names_it_in_one_line(tmp_path, argv, extra):
    if "d.h5" in argv:   # a data set to read, made without the extras
        made = _python("from softrnn.cli.main import main\n"
                       "sys.exit(main(['simulate', 'semicircle', '--samples', '30', '-o', 'd.h5', '--quiet']))\n",
                       tmp_path)
        assert made.returncode == 0, made.stderr[-3000:]
    done = _python(f"from softrnn.cli.main import main\nsys.exit(main({argv!r}))\n", tmp_path)
    assert done.returncode == 2, done.stderr[-3000:]
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in done.stderr
    assert f"pip install 'softrnn[{extra}]'" in lines[0] and lines[0].startswith("softrnn: error: ")
    assert not (tmp_path / argv[-1]).exists()
