"""Commands refuse a run too large for this machine up front: exit 2, one ``softrnn: error:`` line
naming the flag, nothing written, and fast (``check_run_size``)."""

import time

import numpy as np
import pytest

from softrnn.io import Dataset, write_dataset

from helpers import run_cli

SWEEP = ["sweep", "semicircle", "-o", "{out}", "--quiet"]

CASES = {
    "lab-example --duration": (["lab-example", "-o", "{out}", "--duration", "1e9", "--quiet"], "--duration"),
    "lab-example --rate": (["lab-example", "-o", "{out}", "--rate", "1e9", "--quiet"], "--duration"),
    "control magnetic --duration": (["control", "magnetic", "--reference", "step", "--controller",
                                     "static-inverse", "--duration", "1e9", "-o", "{out}", "--quiet"], "--duration"),
    "sweep --count": ([*SWEEP, "--count", "1000000000"], "--count=1000000000"),
    "sweep --samples": ([*SWEEP, "--count", "2", "--samples", "1000000000000"], "--samples=1000000000000"),
    "sweep --dt": ([*SWEEP, "--count", "2", "--dt", "1e9"], "--dt=1000000000.0"),
    "sweep --samples --dt": ([*SWEEP, "--count", "2", "--samples", "100000000", "--dt", "10"],   # each alone fits
                             "--samples=100000000 with --dt=10.0"),
    "sweep duration": (["sweep", "{huge}", "-o", "{out}", "--count", "2", "--quiet"], "scenario="),
}


@pytest.fixture
def huge_scenario(tmp_path):
    """The shipped semicircle scenario (randomised) with a saved interval of 1e9 s: an absurd duration."""
    from softrnn.scenarios.scenario import load_scenario

    text = load_scenario("semicircle").text.replace("dt = 1e-4 ", "dt = 1e9 ")
    assert "dt = 1e9" in text
    path = tmp_path / "huge.toml"
    path.write_text(text)
    return path


@pytest.mark.parametrize("case", sorted(CASES))
def test_too_large_refused_up_front(case, tmp_path, capsys, huge_scenario):
    """An absurd duration, rate, count, length or interval is refused in one line naming the flag,
    before any output."""
    argv, flag = CASES[case]
    out = tmp_path / "out"
    start = time.perf_counter()
    code = run_cli([a.replace("{out}", str(out)).replace("{huge}", str(huge_scenario)) for a in argv])
    elapsed = time.perf_counter() - start
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert len(err) == 1 and err[0].startswith("softrnn: error:") and flag in err[0], err
    assert "too large" in err[0]
    assert not out.exists()
    assert elapsed < 5.0


def test_a_sweep_within_the_limits_reaches_the_run(monkeypatch, tmp_path):
    """The checks refuse only what is too large: the largest count, with a modest run, is simulated."""
    import softrnn.sweeps.sweep as sweeps  # softrnn sweep imports run_sweep from here when it runs
    from softrnn.sweeps.sweep import MAX_COUNT, SweepResult

    calls = []
    monkeypatch.setattr(sweeps, "run_sweep", lambda scenario, count, *a, **k: calls.append(count) or SweepResult())
    assert run_cli(["sweep", "semicircle", "-o", str(tmp_path / "out"), "--count", str(MAX_COUNT),
                    "--samples", "1000", "--dt", "0.01", "--quiet"]) == 0
    assert calls == [MAX_COUNT]


@pytest.fixture
def recording(tmp_path):
    """A small data set of every node of a 3-node rod: 11 samples 0.1 s apart (0 .. 1 s)."""
    T, N = 11, 3
    quaternions = np.zeros((T, N, 4))
    quaternions[..., 0] = 1.0
    path = tmp_path / "data.h5"
    write_dataset(path, Dataset(time=np.linspace(0.0, 1.0, T), nodes=np.arange(N), positions=np.zeros((T, N, 3)),
                                quaternions=quaternions, forces=np.zeros((T, N, 3)), torques=np.zeros((T, N, 3))))
    return path


@pytest.mark.parametrize("window, flag", [(["--stop", "1e9"], "--stop=1000000000.0"),
                                          (["--stop", "inf"], "--stop=inf"),
                                          (["--start=-1e9"], "--start=-1000000000.0"),
                                          (["--start", "nan"], "--start=nan")])
def test_a_dynamic_rollout_past_the_data_is_refused_before_the_model_is_read(window, flag, recording, tmp_path,
                                                                             capsys):
    """A free run needs the data's loads: a window outside DATA is refused from its time axis alone,
    before the model folder (here none) is read."""
    out = tmp_path / "pred.h5"
    code = run_cli(["dynamic", "rollout", str(tmp_path / "no-model"), str(recording), "-o", str(out), *window])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert len(err) == 1 and err[0].startswith(f"softrnn: error: {flag} is invalid"), err
    assert "data's end (1 s)" in err[0]
    assert not out.exists()
