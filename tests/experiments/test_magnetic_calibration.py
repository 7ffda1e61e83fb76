"""Calibrating the magnetic manipulator's physics (issue 13): the noise estimate, exact recovery of
the stiffness, remanence and damping factors from noise-free camera readings, and the lab path's
one-line errors."""

import numpy as np
import pytest

from softrnn.calibration.fit import FitOptions
from softrnn.errors import SoftrnnInputError
from softrnn.experiments.magnetic.calibration import (
    MagneticModel,
    calibrate_manipulator,
    fixed_substeps,
    noise_levels,
)
from softrnn.experiments.magnetic.config import ExperimentConfig
from softrnn.experiments.magnetic.lab import compare_lab, simulated_lab_data, write_lab_csv
from softrnn.magnetics import ManipulatorSpec

DT = 1 / 30


def test_noise_levels_recover_white_noise_on_a_slow_signal():
    rng = np.random.default_rng(0)
    t = np.arange(2000) * DT
    clean = np.stack([0.5 * np.sin(2 * np.pi * 0.7 * t), 3e-3 * np.cos(2 * np.pi * 0.2 * t) + 0.01], 1)
    sigma = np.array([0.01, 2e-4])
    est = noise_levels(clean + rng.normal(0, 1, clean.shape) * sigma)
    np.testing.assert_allclose(est, sigma, rtol=0.06)
    # the slow motion itself adds next to nothing: a clean signal reads as far below either level
    assert np.all(noise_levels(clean) < 0.02 * sigma)


def _currents(n: int) -> np.ndarray:
    """Smooth currents (n, 6) [A] within the coil limit: a field that bends the rod and swings it."""
    from softrnn.magnetics.coils import unit_field_maps

    spec = ManipulatorSpec()
    t = np.arange(n) * DT
    B = np.stack([0.004 * np.sin(2 * np.pi * 1.5 * t), 0.001 * np.cos(2 * np.pi * 2.0 * t),
                  0.012 + 0.003 * np.sin(2 * np.pi * 2.5 * t)], 1)
    beta, _ = unit_field_maps(spec.coils, np.zeros(3))
    return B @ np.linalg.pinv(beta).T


def test_noise_free_readings_give_back_the_true_factors_within_0p1_percent():
    """The issue's goal for noise-free data: every fitted parameter within 0.1 % of the truth."""
    spec = ManipulatorSpec()
    I = _currents(13)
    model = MagneticModel(spec=spec, currents=I, dt=DT, settle=0.1, substeps=fixed_substeps(spec, DT, 0.1),
                          points=40, degree=3)
    truth = (1.03, 0.98, 1.6)
    orientations, positions = model.camera(truth)
    result, _ = calibrate_manipulator(I, orientations, positions, dt=DT, settle=0.1, points=40, degree=3,
                                      options=FitOptions(max_evaluations=12))
    np.testing.assert_allclose(result.fitted, truth, rtol=1e-3)
    assert result.failed_trials == 0 and result.rms_fitted < 1e-3 * result.rms_start
    assert result.not_identifiable == []


def test_lab_calibration_needs_currents_at_a_constant_interval(tmp_path):
    tiny = dict(samples=40, epochs=1, rollout_steps=2, lstm_units=8, settle=0.2)
    data = simulated_lab_data(40, config=ExperimentConfig(seed=2, **tiny))
    t = data.time.copy()
    t[10:] += 0.05 * DT                                                         # one step 5 % long
    uneven = type(data)(time=t, currents=data.currents, orientations=data.orientations, positions=data.positions,
                        wrenches=None)
    write_lab_csv(tmp_path / "uneven.csv", uneven)
    with pytest.raises(SoftrnnInputError, match=r"uneven.csv: has time steps up to 5.0 % off the median .* "
                                                r"--calibrate needs samples at a constant interval") as err:
        compare_lab(tmp_path / "uneven.csv", ExperimentConfig(calibrate=True, **tiny), tmp_path / "out")
    assert "\n" not in str(err.value)
    no_currents = type(data)(time=data.time, currents=None, orientations=data.orientations,
                             positions=data.positions, wrenches=np.zeros((40, 2, 6)))
    write_lab_csv(tmp_path / "wrenches.csv", no_currents)
    with pytest.raises(SoftrnnInputError, match=r"has no current columns I0..I5: --calibrate drives"):
        compare_lab(tmp_path / "wrenches.csv", ExperimentConfig(calibrate=True, **tiny), tmp_path / "out")


def test_lab_comparison_gains_the_calibrated_row(tmp_path):
    tiny = dict(samples=40, epochs=1, rollout_steps=2, lstm_units=8, settle=0.2)
    write_lab_csv(tmp_path / "lab.csv", simulated_lab_data(40, config=ExperimentConfig(seed=3, **tiny)))
    config = ExperimentConfig(calibrate=True, calibration_evaluations=2, **tiny)
    result = compare_lab(tmp_path / "lab.csv", config, tmp_path / "out", workers=1)
    cal = result["calibration"]
    assert cal["samples"] == 12 and cal["evaluations"] <= 2 and "truth" not in cal["parameters"]["stiffness"]
    assert "goals" not in cal and cal["rms_residual_fitted"] <= cal["rms_residual_start"]
    for name in ("distal", "proximal"):
        table = result[name]["calibrated"]
        assert len(table) == 3 and all(v[0] >= v[1] >= 0 for v in table)
    import json

    assert json.loads((tmp_path / "out" / "table1.json").read_text())["calibration"]["samples"] == 12
