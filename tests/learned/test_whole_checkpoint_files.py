"""The whole-model training checkpoint (MODEL_DIR/checkpoint.pt) is read without running any code of
the file (``torch.load(weights_only=True)``): one written by this release, or by the previous one (a
pickled ``_Loop``), resumes to the weights of an uninterrupted run; a damaged, foreign or malicious
file is refused before any training work in one line naming it and the fix (exit 2, no traceback),
and the folder is left as it was."""

import contextlib
import io
import os
import shutil
from dataclasses import replace

import numpy as np
import pytest

from softrnn.scenarios.scenario import load_scenario
from softrnn.scenarios.summary import simulate_summary

from helpers import run_cli

torch = pytest.importorskip("torch")
pytest.importorskip("safetensors")

TINY = ["--steps", "5", "--model-dt", "0.02", "--node-stride", "10", "--width", "8", "--layers", "1", "--unroll", "2",
        "--threads", "1", "--quiet"]


def _train(data, out, *extra) -> int:
    with contextlib.redirect_stdout(io.StringIO()):
        return run_cli(["dynamic", "train", str(data), "-o", str(out), *TINY, *extra])


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """(one.h5: 61 samples 10 ms apart of the square scenario; a model trained whole on 60 % of it;
    the same training interrupted after its checkpoint of step 2)."""
    import softrnn.cli._dynamic as dynamic_cli
    import softrnn.learned.whole.training as training

    root = tmp_path_factory.mktemp("checkpoint")
    scenario = load_scenario("square")
    simulate_summary(name=scenario.name, title=scenario.title, setup=scenario.setup,
                     config=replace(scenario.config, dt=0.01, n_samples=61), node=scenario.nodes_of_interest[0],
                     out_path=str(root / "one.h5"), scenario_text=scenario.text, seed=scenario.seed,
                     attrs={"scenario_name": scenario.name})
    assert _train(root / "one.h5", root / "whole") == 0
    plain = dynamic_cli._StepBar.__call__

    def interrupt(self, done, total, info=None):
        if done == 3:
            raise KeyboardInterrupt
        plain(self, done, total, info)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(training, "CHECKPOINT_EVERY", 2)
        mp.setattr(dynamic_cli._StepBar, "__call__", interrupt)
        with contextlib.redirect_stderr(io.StringIO()):
            assert _train(root / "one.h5", root / "stopped") == 130
    assert sorted(p.name for p in (root / "stopped").iterdir()) == ["checkpoint.json", "checkpoint.pt"]
    return root / "one.h5", root / "whole", root / "stopped"


def _weights(folder) -> dict:
    from safetensors.numpy import load_file

    return load_file(str(folder / "weights.safetensors"))


def _resumes_to_the_same_weights(runs, folder) -> None:
    data, whole, _ = runs
    assert _train(data, folder, "--resume") == 0
    a, b = _weights(whole), _weights(folder)
    assert a.keys() == b.keys() and all(np.array_equal(a[k], b[k]) for k in a)


def test_a_checkpoint_holds_plain_values_and_resumes(runs, tmp_path):
    folder = tmp_path / "model"
    shutil.copytree(runs[2], folder)
    state = torch.load(folder / "checkpoint.pt", weights_only=True)      # no allow-listed class needed
    assert state["format"] == "softrnn-whole-training-checkpoint" and state["loop"]["step"] == 2
    assert isinstance(state["gen"], torch.Tensor) and set(state["net"]) and set(state["opt"]) == {"state",
                                                                                                   "param_groups"}
    _resumes_to_the_same_weights(runs, folder)


def test_a_checkpoint_of_the_previous_release_still_resumes(runs, tmp_path):
    """The previous release pickled the loop's state as a ``_Loop``: it is still read (that class
    alone allowed), with the same result."""
    from softrnn.learned.whole.training import _Loop

    folder = tmp_path / "model"
    shutil.copytree(runs[2], folder)
    state = torch.load(folder / "checkpoint.pt", weights_only=True)
    old = {"net": state["net"], "opt": state["opt"], "gen": state["gen"], "loop": _Loop(**state["loop"])}
    torch.save(old, folder / "checkpoint.pt")
    with pytest.raises(Exception, match="_Loop"):           # what made the previous release need weights_only=False
        torch.load(folder / "checkpoint.pt", weights_only=True)
    _resumes_to_the_same_weights(runs, folder)


class _Payload:
    """A pickle that runs code when loaded unsafely: it makes the folder ``path``."""

    def __init__(self, path):
        self.path = str(path)

    def __reduce__(self):
        return os.mkdir, (self.path,)


def _damage(how: str, path, marker) -> None:
    good = path.read_bytes()
    if how == "garbage":
        path.write_bytes(b"not a checkpoint\n" * 10)
    elif how == "empty":
        path.write_bytes(b"")
    elif how == "truncated":
        path.write_bytes(good[:len(good) // 2])
    elif how == "a tensor":
        torch.save(torch.zeros(3), path)
    elif how == "another dict":
        torch.save({"net": {}, "opt": {}, "gen": torch.zeros(1, dtype=torch.uint8), "loop": {"step": 2}}, path)
    elif how == "code":
        torch.save({"net": {}, "opt": {}, "gen": _Payload(marker), "loop": {}}, path)


@pytest.mark.parametrize("how", ["garbage", "empty", "truncated", "a tensor", "another dict", "code"])
def test_a_bad_checkpoint_is_one_line_before_any_work(how, runs, tmp_path, capsys, monkeypatch):
    import softrnn.learned.whole.fit as dynamic_fit

    def no_work(*args, **kwargs):
        raise AssertionError("the training started")

    folder, marker = tmp_path / "model", tmp_path / "ran"
    shutil.copytree(runs[2], folder)
    _damage(how, folder / "checkpoint.pt", marker)
    before = {p.name: p.read_bytes() for p in folder.iterdir()}
    monkeypatch.setattr(dynamic_fit, "fit", no_work)
    capsys.readouterr()
    assert _train(runs[0], folder, "--resume") == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith("softrnn: error:") and "Traceback" not in err, err
    assert str(folder / "checkpoint.pt") in err and "--overwrite" in err, err
    assert {p.name: p.read_bytes() for p in folder.iterdir()} == before
    assert not marker.exists()                                          # the file's code never ran


def test_overwrite_starts_again_from_a_bad_checkpoint(runs, tmp_path):
    folder = tmp_path / "model"
    shutil.copytree(runs[2], folder)
    (folder / "checkpoint.pt").write_bytes(b"garbage")
    assert _train(runs[0], folder, "--overwrite") == 0
    a, b = _weights(runs[1]), _weights(folder)
    assert all(np.array_equal(a[k], b[k]) for k in a)
