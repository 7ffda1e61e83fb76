"""Long steps report progress (``softrnn.progress.Progress``): the control model's identification
and training, and the lab example's recordings; ``--quiet`` hides the bar."""

import numpy as np
import pytest

from softrnn.experiments.lab_example import LabExampleConfig, samples, write_lab_example


class Recorder:
    """A ``Progress`` that keeps every call."""

    def __init__(self):
        self.calls = []

    def __call__(self, done, total, info=None):
        self.calls.append((done, total, info))


def _counts_up(calls):
    done = [d for d, _, _ in calls]
    totals = {t for _, t, _ in calls}
    assert len(totals) == 1, totals
    assert done == sorted(done) and len(set(done)) == len(done)
    assert done[-1] == totals.pop()


def test_train_narx_reports_steps():
    pytest.importorskip("torch")
    from softrnn.control.model import train_narx

    rng = np.random.default_rng(0)
    runs = [(rng.standard_normal((40, 4)) * 0.01, rng.standard_normal((40, 3)))]
    rec = Recorder()
    train_narx(runs, hidden=4, steps=3, progress=rec)
    _counts_up(rec.calls)
    assert rec.calls[-1][:2] == (3, 3) and rec.calls[-1][2] == {"stage": "train"}


def test_identification_run_reports_frames():
    from softrnn.control.identify import identification_frames, identification_run

    rec = Recorder()
    y, u = identification_run(0.2, progress=rec)
    _counts_up(rec.calls)
    assert rec.calls[-1][1] == identification_frames(0.2) == y.shape[0] - 1


def test_lab_example_reports_samples(tmp_path):
    config = LabExampleConfig(scenarios=("tendon-planar",), duration=0.5)
    rec = Recorder()
    write_lab_example(tmp_path, config, progress=rec)
    _counts_up(rec.calls)
    assert rec.calls[-1][1] == samples(config)
    assert rec.calls[-1][2] == {"scenario": "tendon-planar"}


@pytest.mark.parametrize("quiet", [True, False])
def test_lab_example_quiet_hides_the_bar(tmp_path, capsys, quiet):
    from softrnn.cli.main import main

    args = ["lab-example", "-o", str(tmp_path), "--scenarios", "tendon-planar", "--duration", "0.5"]
    assert main(args + (["--quiet"] if quiet else [])) == 0
    err = capsys.readouterr().err
    assert ("lab-example" in err) is not quiet
