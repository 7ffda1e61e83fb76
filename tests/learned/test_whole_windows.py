"""Time windows of the whole-manipulator model's commands: ``dynamic evaluate --start S`` (seconds)
gives the same test span, and byte-identical reports, as the deprecated ``--test-start F`` it
replaces and as the default; its bad values are one line; ``dynamic rollout`` refuses a rollout too
large for this machine before DATA's node arrays are read."""

import contextlib
import io
from dataclasses import replace

import pytest

from softrnn.scenarios.scenario import load_scenario
from softrnn.scenarios.summary import simulate_summary

from helpers import run_cli

pytest.importorskip("torch")
pytest.importorskip("safetensors")

TINY = ["--steps", "5", "--model-dt", "0.02", "--node-stride", "10", "--width", "8", "--layers", "1", "--unroll", "2",
        "--threads", "1", "--quiet"]


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    """(one.h5: 61 samples 10 ms apart of the square scenario, model steps 0, 0.02 .. 0.6 s; a model
    trained on its first 37 samples (60 %), so its test span may start at 0.36 s at the earliest)."""
    root = tmp_path_factory.mktemp("windows")
    scenario = load_scenario("square")
    simulate_summary(name=scenario.name, title=scenario.title, setup=scenario.setup,
                     config=replace(scenario.config, dt=0.01, n_samples=61), node=scenario.nodes_of_interest[0],
                     out_path=str(root / "one.h5"), scenario_text=scenario.text, seed=scenario.seed,
                     attrs={"scenario_name": scenario.name})
    with contextlib.redirect_stdout(io.StringIO()):
        assert run_cli(["dynamic", "train", str(root / "one.h5"), "-o", str(root / "model"), *TINY]) == 0
    return root / "model", root / "one.h5"


def _report(trained, out, *window) -> bytes:
    model, data = trained
    with contextlib.redirect_stdout(io.StringIO()) as text:
        assert run_cli(["dynamic", "evaluate", str(model), "--test", str(data), "--json", str(out), *window]) == 0
    return out.read_bytes() + text.getvalue().replace(str(out), "OUT").encode()


@pytest.mark.parametrize("start, fraction, label", [(None, None, "0.36"), ("0.36", "0.6", "0.36"),
                                                    ("0.42", "0.7", "0.42"), ("0.43", "0.7", "0.42"),
                                                    ("0.54", "0.9", "0.54")])
def test_start_gives_the_span_and_report_of_the_test_start_it_replaces(start, fraction, label, trained, tmp_path,
                                                                       capsys):
    """``--start S`` starts at the last model step at or before S; ``--test-start F`` (deprecated) at
    the time of the step at F: the same reports, byte for byte (no flag: the default, F = 0.6)."""
    new = _report(trained, tmp_path / "new.json", *([] if start is None else ["--start", start]))
    assert capsys.readouterr().err == ""
    old = _report(trained, tmp_path / "old.json", *([] if fraction is None else ["--test-start", fraction]))
    assert new == old
    assert f"test span {label}..0.6 s" in new.decode()
    if fraction is not None:
        err = capsys.readouterr().err.splitlines()
        assert len(err) == 1 and err[0].startswith("softrnn: note: --test-start is deprecated; use --start S"), err


@pytest.mark.parametrize("window, words", [
    (["--start", "0.3"], ["--start=0.3", "trained part", "a time >= 0.36 s"]),
    (["--start", "0.6"], ["--start=0.6", "a time in [0, 0.58] s"]),
    (["--start=-1"], ["--start=-1.0", "a time in [0, 0.58] s"]),
    (["--start", "nan"], ["--start=nan", "a time in"]),
    (["--test-start", "0.3"], ["--test-start=0.3", "trained part", ">= 0.6"]),
    (["--start", "0.4", "--test-start", "0.7"], ["--test-start=0.7", "not both"]),
])
def test_a_bad_start_is_one_line(window, words, trained, tmp_path, capsys):
    model, data = trained
    out = tmp_path / "eval.json"
    argv = ["dynamic", "evaluate", str(model), "--test", str(data), *window, "--json", str(out)]
    assert run_cli(argv) == 2
    err = [line for line in capsys.readouterr().err.splitlines() if not line.startswith("softrnn: note:")]
    assert len(err) == 1 and err[0].startswith("softrnn: error:"), err
    for w in words:
        assert w in err[0], err
    assert not out.exists()


def test_start_needs_test(trained, tmp_path, capsys):
    model, data = trained
    assert run_cli(["dynamic", "evaluate", str(model), "--generalisation", str(data), "--start", "0.4"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--start=0.4" in err and "--test FILE as well" in err, err


@pytest.mark.parametrize("window", [[], ["--stop", "0.5"]])
def test_a_rollout_too_large_for_this_machine_is_refused_before_the_data_is_read(window, trained, tmp_path, capsys,
                                                                                monkeypatch):
    import softrnn.io.reader as reader
    from softrnn.rod import simulation

    model, data = trained
    read, plain = [], reader.read_dataset

    def spy(path, **kwargs):
        read.append(kwargs)
        return plain(path, **kwargs)

    monkeypatch.setattr(reader, "read_dataset", spy)
    monkeypatch.setattr(simulation, "array_limit", lambda: 10_000)
    out = tmp_path / "pred.h5"
    assert run_cli(["dynamic", "rollout", str(model), str(data), "-o", str(out), *window]) == 2
    err = capsys.readouterr().err.strip()
    start = "the rollout to the end of DATA is" if not window else "--stop=0.5 is invalid"
    assert len(err.splitlines()) == 1 and err.startswith(f"softrnn: error: {start}") and "--stop" in err, err
    assert "too large for this machine" in err and "GiB of arrays" in err
    assert not out.exists()
    assert read and all(k.get("nodes") is not None or k.get("stop") is not None for k in read)   # never whole
