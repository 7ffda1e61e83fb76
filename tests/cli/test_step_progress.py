"""Steps that can take more than a few seconds report progress (``softrnn.progress.Progress``): the
magnetic manipulator's simulation block by block (the same numbers bit for bit as in one block), the
magnetic experiment's ``simulate`` and ``predict`` stages, ``magnetic example-csv`` and ``show``'s
check of every value; ``--quiet`` hides the bars. An absurd ``--samples`` of the magnetic commands
is refused up front in one line naming the flag."""

import time
from types import SimpleNamespace

import numpy as np
import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.magnetics import manipulator as mm
from softrnn.rod.state import SAMPLE_FIELDS

from helpers import run_cli

MAGNET_FIELDS = ("currents", "magnet_positions", "magnet_rotations", "magnet_moments", "fields", "gradients",
                 "wrenches")


class Recorder:
    """A ``Progress`` that keeps every call."""

    def __init__(self):
        self.calls = []

    def __call__(self, done, total, info=None):
        self.calls.append((done, total, info))


def _counts_up(calls, total):
    """The calls count from 0 up to ``total`` of ``total``, each further than the last."""
    done = [d for d, _, _ in calls]
    assert {t for _, t, _ in calls} == {total}, calls
    assert done[0] == 0 and done[-1] == total, done
    assert all(b > a for a, b in zip(done, done[1:])), done


def _same(a, b):
    for name in SAMPLE_FIELDS:
        assert np.array_equal(getattr(a.rod, name), getattr(b.rod, name)), name
    for name in MAGNET_FIELDS:
        assert np.array_equal(getattr(a, name), getattr(b, name)), name


# ----------------------------------------------------------------------------------------- the magnetic drive
def test_the_blocked_magnetic_drive_is_identical_bit_for_bit(monkeypatch):
    """One sample per driver call (and the settling one step per call) gives the very numbers of
    one call for the whole run, with or without progress; the progress counts the samples."""
    spec = mm.ManipulatorSpec()
    run = mm.ManipulatorRun(dt=1e-3, n_samples=6, settle=2e-4)
    currents = mm.random_currents(spec.coils, run.duration, seed=3, band=(50.0, 200.0), ramp=0.0)
    monkeypatch.setattr(mm, "DRIVE_BLOCK_STEPS", 10**15)
    whole = mm.simulate_manipulator(spec, currents, run)
    monkeypatch.setattr(mm, "DRIVE_BLOCK_STEPS", 1)
    rec = Recorder()
    blocked = mm.simulate_manipulator(spec, currents, run, progress=rec)
    silent = mm.simulate_manipulator(spec, currents, run)
    assert np.ptp(whole.rod.positions[:, -1, 2]) > 0 and np.ptp(whole.currents) > 0   # it really moves
    _same(whole, blocked)
    _same(whole, silent)
    assert [c[:2] for c in rec.calls] == [(k, 6) for k in range(7)]


def test_the_experiment_simulation_reports_samples(tmp_path, monkeypatch):
    from softrnn.experiments.magnetic import ExperimentConfig
    from softrnn.experiments.magnetic import run as experiment

    config = ExperimentConfig(samples=50, sample_rate=1000.0, settle=0.0, field_band=(5.0, 50.0))
    monkeypatch.setattr(mm, "DRIVE_BLOCK_STEPS", 2000)
    rec = Recorder()
    experiment._simulate_robot(config, mm.ManipulatorSpec(), tmp_path / "robot.h5", rec)
    _counts_up(rec.calls, 50)
    assert len(rec.calls) > 5
    assert all(info == {"stage": "simulate"} for _, _, info in rec.calls)
    rec.calls.clear()
    *_, resumed = experiment._simulate_robot(config, mm.ManipulatorSpec(), tmp_path / "robot.h5", rec)
    assert resumed and rec.calls == [(1, 1, {"stage": "simulate"})]


def test_the_calibrated_prediction_reports_samples(monkeypatch):
    """The ``predict`` stage simulates the whole record: it counts its samples (the fit is faked here)."""
    from softrnn.experiments.magnetic import ExperimentConfig
    from softrnn.experiments.magnetic import run as experiment
    from softrnn.experiments.magnetic.calibration import MagneticModel

    spec = mm.ManipulatorSpec()
    T = 12
    currents = np.zeros((T, spec.coils.n_coils))
    currents[:, 0] = np.linspace(0.0, 2.0, T)

    def fake_calibration(I, o, p, *, dt, settle, points, degree, spec, **_):
        model = MagneticModel(spec=spec, currents=np.asarray(I), dt=dt, settle=settle, substeps=400, points=points,
                              degree=degree)
        fitted = SimpleNamespace(
            fitted=np.ones(3), std_error=np.zeros(3), trials=1, failed_trials=0, cached_trials=0, evaluations=1,
            rms_start=0.0, rms_fitted=0.0, not_identifiable=[], success=True, message="",
            to_dict=lambda: {"correlation": None, "history": []})
        return fitted, model

    monkeypatch.setattr(experiment, "calibrate_manipulator", fake_calibration)
    monkeypatch.setattr(mm, "DRIVE_BLOCK_STEPS", 800)
    config = ExperimentConfig(sample_rate=1000.0, settle=0.0, field_band=(5.0, 50.0))
    rec = Recorder()
    _, predicted = experiment.calibrate_and_predict(currents, np.zeros((T, 2, 3)), None, config, spec=spec,
                                                    workers=1, progress=rec)
    assert predicted.shape == (T, 2, 3)
    budget = config.calibration_evaluations * 4
    stages = [info["stage"] for _, _, info in rec.calls]
    assert stages == ["calibrate"] * 2 + ["predict"] * (len(stages) - 2)
    assert [c[:2] for c in rec.calls[:2]] == [(0, budget), (budget, budget)]
    _counts_up(rec.calls[2:], T)
    assert len(rec.calls) > 5


@pytest.mark.parametrize("quiet", [True, False])
def test_example_csv_shows_its_simulation_unless_quiet(tmp_path, capsys, quiet):
    path = tmp_path / "lab.csv"
    assert run_cli(["magnetic", "example-csv", str(path), "--samples", "20"] + (["--quiet"] if quiet else [])) == 0
    assert path.is_file()
    captured = capsys.readouterr()
    assert "wrote" in captured.out
    assert ("example-csv" in captured.err) is not quiet


# ----------------------------------------------------------------------------------------- show
@pytest.fixture
def dataset_file(tmp_path):
    from softrnn.experiments.magnetic import orientation_dataset
    from softrnn.io import write_dataset

    T = 300
    t = np.arange(T) * 0.01
    r = np.zeros((T, 2, 3))
    r[:, :, 1] = np.sin(t)[:, None]
    path = tmp_path / "d.h5"
    write_dataset(path, orientation_dataset(t, r, np.zeros((T, 2, 6))))
    return path


def test_show_reports_every_block_it_checks(dataset_file, monkeypatch):
    from softrnn.io import summary

    monkeypatch.setattr(summary, "TIME_CHUNK", 64)
    rec = Recorder()
    assert summary.describe(dataset_file, progress=rec)["verified"]
    assert [c[:2] for c in rec.calls] == [(0, 300), (64, 300), (128, 300), (192, 300), (256, 300), (300, 300)]
    rec.calls.clear()
    summary.describe(dataset_file, verify=False, progress=rec)
    assert rec.calls == []


@pytest.mark.parametrize("flags, shown", [([], True), (["--quiet"], False), (["--quick"], False)])
def test_show_bar_unless_quiet_or_quick(dataset_file, monkeypatch, capsys, flags, shown):
    from softrnn.cli import _show

    monkeypatch.setattr(_show, "SHOW_AFTER", 0.0)
    assert run_cli(["show", str(dataset_file), *flags]) == 0
    captured = capsys.readouterr()
    assert "samples: 300" in captured.out
    assert ("checking every value" in captured.err) is shown


def test_show_of_a_small_file_prints_no_bar(dataset_file, capsys):
    assert run_cli(["show", str(dataset_file)]) == 0
    assert capsys.readouterr().err == ""


# ----------------------------------------------------------------------------------------- run sizes
@pytest.mark.parametrize("argv", [
    ["magnetic", "experiment", "-o", "{out}", "--samples", str(10**12), "--quiet"],
    ["magnetic", "experiment", "-o", "{out}", "--quick", "--samples", str(10**12)],
    ["magnetic", "example-csv", "{out}", "--samples", str(10**12), "--quiet"],
], ids=["experiment", "experiment --quick", "example-csv"])
def test_absurd_samples_are_refused_up_front(argv, tmp_path, capsys):
    out = tmp_path / "out"
    start = time.perf_counter()
    code = run_cli([a.replace("{out}", str(out)) for a in argv])
    elapsed = time.perf_counter() - start
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert len(err) == 1 and err[0].startswith("softrnn: error: --samples=1000000000000 is invalid"), err
    assert "too large" in err[0]
    assert not out.exists()
    assert elapsed < 5.0


def test_absurd_samples_are_refused_by_the_library():
    from softrnn.experiments.magnetic import ExperimentConfig, check_experiment_size
    from softrnn.experiments.magnetic.lab import simulated_lab_data

    start = time.perf_counter()
    with pytest.raises(SoftrnnInputError, match="n_samples=1000000000000, .* too large"):
        simulated_lab_data(10**12)
    with pytest.raises(SoftrnnInputError, match="too large"):
        check_experiment_size(ExperimentConfig(samples=10**12))
    check_experiment_size(ExperimentConfig())                           # the paper's 669 samples pass
    assert time.perf_counter() - start < 5.0


@pytest.mark.parametrize("argv, flag", [
    (["magnetic", "experiment", "-o", "{out}", "--samples", "5"], "--samples=5 is invalid"),
    (["magnetic", "experiment", "-o", "{out}", "--epochs", "0"], "--epochs=0 is invalid"),
    (["magnetic", "example-csv", "{out}", "--samples", "30", "--seed", "-1"], "--seed=-1 is invalid"),
])
def test_bad_settings_name_their_flag(argv, flag, tmp_path, capsys):
    out = tmp_path / "out"
    assert run_cli([a.replace("{out}", str(out)) for a in argv]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"softrnn: error: {flag}") and "\n" not in err, err
    assert not out.exists()
