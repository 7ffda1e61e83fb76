"""``softrnn train --resume`` on a finished model: a larger --epochs trains on from it and rewrites
the model; a budget that leaves nothing to train is refused in one line (exit 2, nothing
rewritten). A stopped training exits 128 + the signal's number: 143 after SIGTERM, 130 after Ctrl-C."""

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from softrnn.cli import _train
from softrnn.cli import main as cli_main
from softrnn.cli._progress import stop_code
from softrnn.io import write_trajectory
from softrnn.learned.node.artifact import CHECKPOINT

from helpers import run_cli
from helpers import swinging_rod as synthetic

TINY = ["--node", "2", "--units", "8", "--dense", "8", "--batch-size", "64", "--quiet", "--rollout-steps", "1"]


@pytest.fixture(scope="module")
def data_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("data") / "synthetic.h5"
    write_trajectory(path, synthetic(200), dt=0.01, attrs={"scenario_name": "synthetic"})
    return path


def _files(folder: Path) -> dict:
    return {p.name: (p.stat().st_mtime_ns, p.read_bytes()) for p in sorted(folder.iterdir())}


def _meta(folder: Path) -> dict:
    return json.loads((folder / "meta.json").read_text())


def test_resume_with_a_larger_budget_trains_on(data_file, tmp_path, capsys):
    out = tmp_path / "m"
    argv = ["train", str(data_file), "-o", str(out), "--patience", "50"] + TINY
    assert run_cli(argv + ["--epochs", "2"]) == 0
    before = _files(out)
    capsys.readouterr()
    assert run_cli(argv + ["--epochs", "4", "--resume"]) == 0
    text = capsys.readouterr().out
    assert "trained on from epoch 2" in text and f"model written to {out}" in text
    meta = _meta(out)
    assert meta["epochs_run"] == 4 and meta["continued_after_epoch"] == 2
    assert [h["epoch"] for h in meta["history"]] == [1, 2, 3, 4]
    assert meta["train_config"]["epochs"] == 4
    after = _files(out)
    assert sorted(after) == sorted(before) and CHECKPOINT not in after
    assert after["weights.safetensors"] != before["weights.safetensors"]
    assert after["meta.json"][0] > before["meta.json"][0]


@pytest.mark.parametrize("epochs", ["3", "2"])
def test_resume_with_no_budget_left_is_refused(data_file, tmp_path, capsys, epochs):
    out = tmp_path / "m"
    argv = ["train", str(data_file), "-o", str(out), "--patience", "50"] + TINY
    assert run_cli(argv + ["--epochs", "3"]) == 0
    before = _files(out)
    capsys.readouterr()
    assert run_cli(argv + ["--epochs", epochs, "--resume"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("softrnn: error:") and "\n" not in err, err
    assert "already ran 3 epochs" in err and "pass --epochs above 3" in err, err
    assert _files(out) == before                                         # nothing rewritten


def test_the_stop_code_is_128_plus_the_signal():
    assert stop_code(cli_main.Terminated()) == 128 + signal.SIGTERM == 143
    assert stop_code(KeyboardInterrupt()) == 128 + signal.SIGINT == 130


@pytest.mark.parametrize("stop, code", [(cli_main.Terminated, 143), (KeyboardInterrupt, 130)])
def test_a_stopped_training_keeps_its_epochs_and_exits_128_plus_the_signal(data_file, tmp_path, capsys, monkeypatch,
                                                                          stop, code):
    """The signal handler of ``main`` raises ``Terminated`` for SIGTERM and ``KeyboardInterrupt``
    for SIGINT; here raised from the progress bar inside the second epoch."""
    def stop_in_epoch_two(self, done, total, info=None):
        if (info or {}).get("epoch") == 2:
            raise stop()

    monkeypatch.setattr(_train._LossBar, "__call__", stop_in_epoch_two)
    out = tmp_path / "m"
    assert run_cli(["train", str(data_file), "-o", str(out), "--epochs", "4"] + TINY) == code
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and err.startswith("softrnn: interrupted;") and "--resume" in err, err
    assert (out / CHECKPOINT).is_file() and not (out / "config.json").exists()


def _command() -> list:
    script = Path(sys.executable).with_name("softrnn")
    return [str(script)] if script.is_file() else [sys.executable, "-m", "softrnn.cli.main"]


@pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")
def test_sigterm_during_training_exits_143(data_file, tmp_path):
    out = tmp_path / "m"
    argv = ["train", str(data_file), "-o", str(out), "--epochs", "100000", "--patience", "100000"] + TINY
    proc = subprocess.Popen(_command() + argv, cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, start_new_session=True)
    try:
        deadline = time.monotonic() + 120
        while not (out / CHECKPOINT).is_file():
            assert proc.poll() is None, proc.communicate()
            assert time.monotonic() < deadline, "no checkpoint appeared"
            time.sleep(0.02)
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 143, err
    lines = err.strip().splitlines()
    assert lines and lines[-1].startswith("softrnn: interrupted;") and "--resume" in lines[-1], err
    assert (out / CHECKPOINT).is_file() and not (out / "config.json").exists()
