"""Output paths and run sizes: every command checks its outputs before any long work (a one-line
error naming the argument, the path and the fix, exit code 2, nothing left behind), refuses to
replace an existing output without --overwrite (train: or --resume), turns an escaping OSError
into one line, and refuses a run too large for the machine before anything is allocated."""

import errno
import os
import tracemalloc
from pathlib import Path

import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.files import prepare_output
from softrnn.io import write_trajectory
from softrnn.rod.batch import simulate_batch
from softrnn.rod.simulation import RunConfig, Simulator
from softrnn.scenarios.scenario import load_scenario

from helpers import run_cli
from helpers import swinging_rod as synthetic

ROOT = Path(__file__).resolve().parents[2]
LAB_CSV = ROOT / "examples" / "lab_data.csv"
MAGNETIC_CSV = ROOT / "examples" / "magnetic_lab.csv"
SEMICIRCLE = ROOT / "src" / "softrnn" / "scenarios" / "semicircle.toml"


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    path = tmp_path_factory.mktemp("data") / "synthetic.h5"
    write_trajectory(path, synthetic(300), dt=0.01, attrs={"scenario_name": "synthetic"})
    return path


@pytest.fixture(scope="module")
def model(data, tmp_path_factory):
    folder = tmp_path_factory.mktemp("models") / "n2"
    assert run_cli(["train", str(data), "--node", "2", "-o", str(folder), "--epochs", "1", "--units", "8",
                    "--dense", "8", "--batch-size", "64", "--quiet"]) == 0
    return folder


def one_line_error(capsys, *words) -> str:
    err = capsys.readouterr().err.strip()
    assert err.startswith("softrnn: error:") and "\n" not in err, err
    assert "Traceback" not in err
    for w in words:
        assert w in err, (w, err)
    return err


def listing(folder: Path) -> list:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


# (argument named in the error, argv with {out} for the output path), the output a file unless noted
def _commands(data, model):
    d, m = str(data), str(model)
    return {
        "simulate -o": ("-o", ["simulate", "semicircle", "--samples", "5", "--quiet", "-o", "{out}.h5"]),
        "simulate --json": ("--json", ["simulate", "semicircle", "--samples", "5", "--quiet", "--json", "{out}"]),
        "import-csv": ("-o", ["import-csv", str(LAB_CSV), "-o", "{out}"]),
        "rollout -o": ("-o", ["rollout", m, d, "-o", "{out}.h5", "--quiet"]),
        "rollout --figure": ("--figure", ["rollout", m, d, "-o", "{tmp}/pred.h5", "--figure", "{out}.png",
                                          "--quiet"]),
        "export --onnx": ("--onnx", ["export", m, "--onnx", "{out}"]),
        "export --torchscript": ("--torchscript", ["export", m, "--torchscript", "{out}"]),
        "evaluate --json": ("--json", ["evaluate", m, d, "--json", "{out}", "--quiet"]),
        "animate": ("--output", ["animate", d, "-o", "{out}.gif", "--quiet"]),
        "plot": ("--output", ["plot", d, "--node", "2", "-o", "{out}.png"]),
        "bench --json": ("--json", ["bench", "--only", "statics", "--quick", "--json", "{out}"]),
        "magnetic --json": ("--json", ["magnetic", "experiment", "-o", "{tmp}/mag", "--json", "{out}",
                                       "--quiet"]),
        "magnetic example-csv": ("PATH", ["magnetic", "example-csv", "{out}"]),
    }


FOLDER_COMMANDS = {
    "train": ("-o", ["train", "{data}", "--node", "2", "-o", "{out}", "--quiet"]),
    "evaluate --figures": ("--figures", ["evaluate", "{model}", "{data}", "--figures", "{out}", "--quiet"]),
    "magnetic experiment": ("-o", ["magnetic", "experiment", "-o", "{out}", "--quiet"]),
    "magnetic compare": ("-o", ["magnetic", "compare", str(MAGNETIC_CSV), "-o", "{out}", "--quiet"]),
    "reproduce": ("-o", ["reproduce", "--quick", "-o", "{out}"]),
    "sweep": ("-o", ["sweep", "semicircle", "--count", "2", "-o", "{out}", "--quiet"]),
    "study": ("-o", ["study", "hparams", "{data}", "--node", "2", "-o", "{out}", "--quiet"]),
}


def _fill(argv, **subs):
    return [a.format(**subs) for a in argv]


# ----------------------------------------------------------------------------------------- OSError
FILE_CASES = ["simulate -o", "simulate --json", "import-csv", "rollout -o", "rollout --figure", "export --onnx",
              "export --torchscript", "evaluate --json", "animate", "plot", "bench --json", "magnetic --json",
              "magnetic example-csv"]


@pytest.mark.parametrize("name", FILE_CASES)
def test_a_file_output_below_a_file_is_one_line_and_exit_2(name, data, model, tmp_path, capsys):
    """The issue's example: '-o somefile.toml/x.h5' gave a FileExistsError traceback."""
    (tmp_path / "somefile.toml").write_text("x")
    argument, argv = _commands(data, model)[name]
    argv = _fill(argv, out=str(tmp_path / "somefile.toml" / "x"), tmp=str(tmp_path))
    before = listing(tmp_path)
    assert run_cli(argv) == 2
    one_line_error(capsys, f"{argument}=", "somefile.toml/x", "is a file, not a folder")
    assert listing(tmp_path) == before


@pytest.mark.parametrize("name", sorted(FOLDER_COMMANDS))
def test_a_folder_output_below_a_file_is_one_line_and_exit_2(name, data, model, tmp_path, capsys):
    (tmp_path / "somefile.toml").write_text("x")
    argument, argv = FOLDER_COMMANDS[name]
    out = tmp_path / "somefile.toml" / "dir"
    assert run_cli(_fill(argv, out=str(out), data=str(data), model=str(model))) == 2
    one_line_error(capsys, f"{argument}=", "somefile.toml/dir", "is a file, not a folder")
    assert listing(tmp_path) == ["somefile.toml"]


@pytest.mark.parametrize("name", sorted(FOLDER_COMMANDS))
def test_a_folder_output_that_is_a_file_is_refused(name, data, model, tmp_path, capsys):
    out = tmp_path / "taken"
    out.write_text("precious")
    argument, argv = FOLDER_COMMANDS[name]
    assert run_cli(_fill(argv, out=str(out), data=str(data), model=str(model))) == 2
    one_line_error(capsys, f"{argument}=", "taken", "is a file")
    assert out.read_text() == "precious" and listing(tmp_path) == ["taken"]


def test_the_simulate_example_from_the_issue(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    Path("somefile.toml").touch()
    assert run_cli(["simulate", "semicircle", "--samples", "5", "-o", "somefile.toml/x.h5"]) == 2
    one_line_error(capsys, "-o='somefile.toml/x.h5'", "choose another path")
    assert os.listdir(tmp_path) == ["somefile.toml"]


def test_an_unwritable_folder_is_one_line(tmp_path, monkeypatch, capsys):
    """Permission denied (os.access mocked: the tests may run as root, who may write anywhere)."""
    monkeypatch.setattr("softrnn.files.os.access", lambda *a, **k: False)
    assert run_cli(["simulate", "semicircle", "--samples", "5", "--quiet", "-o", str(tmp_path / "a" / "x.h5")]) == 2
    one_line_error(capsys, "-o=", "not writable (permission denied)")
    assert listing(tmp_path) == []


def test_an_oserror_while_checking_is_one_line(tmp_path, monkeypatch):
    def denied(self):
        raise PermissionError(errno.EACCES, "Permission denied", str(self))

    with monkeypatch.context() as mp:
        mp.setattr(Path, "is_dir", denied)
        with pytest.raises(SoftrnnInputError, match=r"--json=.*Permission denied.*choose another path"):
            prepare_output(tmp_path / "x.json", "--json")


def test_an_escaping_oserror_with_a_file_name_is_one_line(monkeypatch, capsys):
    """Last resort in cli/main.py: e.g. the disk fills up while a command writes."""
    def full(**kwargs):
        raise OSError(errno.ENOSPC, "No space left on device", "/data/run.h5")

    monkeypatch.setattr("softrnn.scenarios.summary.simulate_summary", full)   # what simulate runs
    assert run_cli(["simulate", "semicircle", "--samples", "5", "--quiet"]) == 2
    one_line_error(capsys, "cannot write /data/run.h5: No space left on device")


def test_an_oserror_without_a_file_name_is_not_hidden(monkeypatch):
    def odd(**kwargs):
        raise OSError("something else")

    monkeypatch.setattr("softrnn.scenarios.summary.simulate_summary", odd)
    with pytest.raises(OSError, match="something else"):
        run_cli(["simulate", "semicircle", "--samples", "5", "--quiet"])


# ----------------------------------------------------------------------------------------- existing outputs
@pytest.mark.parametrize("name", FILE_CASES)
def test_an_existing_file_is_not_replaced_without_overwrite(name, data, model, tmp_path, capsys):
    argument, argv = _commands(data, model)[name]
    argv = _fill(argv, out=str(tmp_path / "old"), tmp=str(tmp_path))
    target = Path(next(a for a in argv if a.startswith(str(tmp_path / "old"))))
    target.write_text("precious")
    before = listing(tmp_path)
    assert run_cli(argv) == 2
    one_line_error(capsys, f"{argument}=", target.name, "exists", "--overwrite")
    assert target.read_text() == "precious" and listing(tmp_path) == before


def test_overwrite_replaces_a_file(tmp_path, capsys):
    out = tmp_path / "run.h5"
    argv = ["simulate", "semicircle", "--samples", "5", "--quiet", "-o", str(out)]
    assert run_cli(argv) == 0
    assert run_cli(argv) == 2
    one_line_error(capsys, "-o=", "--overwrite")
    assert run_cli(argv + ["--overwrite"]) == 0
    assert listing(tmp_path) == ["run.h5"]


def test_train_refuses_a_finished_model_without_resume_or_overwrite(data, model, tmp_path, capsys):
    folder = tmp_path / "m"
    argv = ["train", str(data), "--node", "2", "-o", str(folder), "--epochs", "1", "--units", "8", "--dense", "8",
            "--batch-size", "64", "--quiet"]
    assert run_cli(argv) == 0
    files = {p.name: p.read_bytes() for p in folder.iterdir()}
    capsys.readouterr()
    assert run_cli(argv) == 2
    one_line_error(capsys, "-o=", "config.json", "pass --overwrite to replace it or --resume to continue it")
    assert {p.name: p.read_bytes() for p in folder.iterdir()} == files
    assert run_cli(argv + ["--resume"]) == 2                                  # finished: nothing left to train
    one_line_error(capsys, "already ran 1 epoch,", "pass --epochs above 1")
    assert {p.name: p.read_bytes() for p in folder.iterdir()} == files
    assert run_cli(argv + ["--overwrite"]) == 0
    assert run_cli(argv + ["--overwrite", "--resume"]) == 2                   # one or the other
    one_line_error(capsys, "--resume", "--overwrite")


def test_train_refuses_an_unfinished_training_without_resume_or_overwrite(data, tmp_path, capsys):
    folder = tmp_path / "m"
    folder.mkdir()
    (folder / "checkpoint.pt").write_bytes(b"not really")
    assert run_cli(["train", str(data), "--node", "2", "-o", str(folder), "--quiet"]) == 2
    one_line_error(capsys, "-o=", "checkpoint.pt", "--resume")
    assert (folder / "checkpoint.pt").read_bytes() == b"not really"


def test_train_refuses_a_foreign_folder_before_reading_data(tmp_path, capsys):
    folder = tmp_path / "thesis"
    folder.mkdir()
    (folder / "thesis.tex").write_text("precious")
    assert run_cli(["train", str(tmp_path / "missing.h5"), "--node", "2", "-o", str(folder), "--quiet"]) == 2
    one_line_error(capsys, "not a softrnn model")


def test_evaluate_figures_refuses_only_its_own_files(model, data, tmp_path, capsys):
    figs = tmp_path / "figs"
    figs.mkdir()
    (figs / "notes.txt").write_text("kept")
    argv = ["evaluate", str(model), str(data), "--figures", str(figs), "--quiet", "--no-free-running"]
    assert run_cli(argv) == 0                                                 # other files are fine
    assert sorted(p.name for p in figs.iterdir()) == ["notes.txt", "prediction.png", "rmse.png", "rmse_t.csv"]
    capsys.readouterr()
    assert run_cli(argv) == 2
    one_line_error(capsys, "--figures=", "prediction.png", "--overwrite")
    assert run_cli(argv + ["--overwrite"]) == 0


@pytest.mark.parametrize("sub", ["experiment", "compare"])
def test_magnetic_refuses_a_finished_folder(sub, tmp_path, capsys):
    out = tmp_path / "mag"
    out.mkdir()
    (out / "table1.json").write_text("{}")
    argv = ["magnetic", "experiment"] if sub == "experiment" else ["magnetic", "compare", str(MAGNETIC_CSV)]
    assert run_cli(argv + ["-o", str(out), "--quiet"]) == 2
    one_line_error(capsys, "-o=", "table1.json", "--overwrite")
    assert listing(tmp_path) == ["mag", "mag/table1.json"]


@pytest.mark.parametrize("name, own", [("reproduce", "cases"), ("sweep", "sweep.json"), ("study", "study.json")])
def test_resumable_commands_refuse_a_folder_that_is_not_theirs(name, own, data, model, tmp_path, capsys):
    out = tmp_path / "busy"
    out.mkdir()
    (out / "thesis.tex").write_text("precious")
    argument, argv = FOLDER_COMMANDS[name]
    assert run_cli(_fill(argv, out=str(out), data=str(data), model=str(model))) == 2
    one_line_error(capsys, f"{argument}=", "holds other files (thesis.tex)", own)
    assert listing(tmp_path) == ["busy", "busy/thesis.tex"]


def test_every_writing_command_has_overwrite_in_its_help(capsys):
    for argv in (["simulate"], ["import-csv"], ["rollout"], ["export"], ["evaluate"], ["animate"], ["plot"],
                 ["bench"], ["train"], ["magnetic", "experiment"], ["magnetic", "compare"],
                 ["magnetic", "example-csv"]):
        assert run_cli(argv + ["--help"]) == 0
        assert "--overwrite" in capsys.readouterr().out, argv


# ----------------------------------------------------------------------------------------- run sizes
def test_an_absurd_dt_is_refused_before_allocating(capsys):
    """dt = 1e9 s made NumPy try to allocate 85 TiB: now a one-line error with the sizes."""
    assert run_cli(["simulate", "semicircle", "--dt", "1e9", "--quiet"]) == 2
    one_line_error(capsys, "dt=1e+09", "of arrays in memory", "solver steps (limit 1e+10)", "smaller dt")


def test_an_absurd_scenario_file_is_refused(tmp_path, capsys):
    text = SEMICIRCLE.read_text().replace("dt = 1e-4 ", "dt = 1e9 ")
    assert "dt = 1e9" in text
    (tmp_path / "huge.toml").write_text(text)
    out = tmp_path / "huge.h5"
    assert run_cli(["simulate", str(tmp_path / "huge.toml"), "--quiet", "-o", str(out)]) == 2
    one_line_error(capsys, "dt=1e+09", "solver steps")
    assert listing(tmp_path) == ["huge.toml"]                                # no file, no temporary file


def test_absurd_samples_are_refused_and_leave_nothing(tmp_path, capsys):
    out = tmp_path / "many.h5"
    assert run_cli(["simulate", "semicircle", "--samples", str(10**12), "--quiet", "-o", str(out)]) == 2
    one_line_error(capsys, "--samples=1000000000000", "TiB", "fewer samples")   # the option given
    assert listing(tmp_path) == []


def test_the_check_allocates_nothing():
    setup = load_scenario("semicircle").setup
    sim = Simulator(setup)
    tracemalloc.start()
    try:
        with pytest.raises(SoftrnnInputError, match="PiB of arrays"):
            sim.run(RunConfig(dt=1e9, n_samples=5))
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 10 * 2**20
    assert sim.steps_done == 0


def test_streaming_holds_only_a_chunk():
    """10^8 samples of every node do not fit in memory, but streamed to a sink they are a chunk at
    a time (and 2 x 10^8 solver steps are allowed)."""
    sim = Simulator(load_scenario("semicircle").setup)
    config = RunConfig(dt=1e-4, n_samples=10**8)
    with pytest.raises(SoftrnnInputError, match="save fewer nodes.*write to a file, which streams"):
        sim.check_size(config, streamed=False)
    assert sim.check_size(config, streamed=True) >= 1


def test_a_batch_and_the_magnetic_driver_are_checked():
    from softrnn.magnetics.manipulator import ManipulatorRun, ManipulatorSpec, simulate_manipulator

    setup = load_scenario("semicircle").setup
    with pytest.raises(SoftrnnInputError, match="2 rods.*fewer rods per batch"):
        simulate_batch([setup, setup], RunConfig(dt=1e-4, n_samples=10**8))
    with pytest.raises(SoftrnnInputError, match="dt=1e\\+09 s is too large.*solver steps"):
        simulate_manipulator(ManipulatorSpec(), [[0.0] * 6] * 5, ManipulatorRun(dt=1e9, n_samples=5))


def test_an_absurd_magnetic_experiment_creates_no_folder(tmp_path, capsys):
    out = tmp_path / "mag"
    assert run_cli(["magnetic", "experiment", "-o", str(out), "--samples", str(10**11), "--quiet"]) == 2
    one_line_error(capsys, "--samples=100000000000", "TiB")
    assert not out.exists()
