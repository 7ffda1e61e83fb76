"""The simulated magnetic experiment (paper section 5, Table 1): the camera model on analytic curves,
the static model against the settled dynamic model, failures reported, the Table 1 shape and
determinism, the lab CSV format and its one-line errors, and the CLI's exit codes."""

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

from softrnn.cli.main import main
from softrnn.errors import SimulationError, SoftrnnInputError
from softrnn.experiments.magnetic.comparison import check_result_shape
from softrnn.experiments.magnetic.config import ExperimentConfig
from softrnn.experiments.magnetic.dataset import measured_wrenches
from softrnn.experiments.magnetic.lab import LabData, read_lab_csv, simulated_lab_data, write_lab_csv
from softrnn.experiments.magnetic.run import run_experiment
from softrnn.magnetics import ManipulatorRun, ManipulatorSpec, currents_for_field, simulate_manipulator
from softrnn.magnetics.camera import (
    camera_measure,
    camera_orientations,
    rotation_vectors,
    tangents_from_rotation_vectors,
)
from softrnn.magnetics.static import static_predictions
from softrnn.paper import paper_case

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "magnetic_lab.csv"
L = 0.05
TINY = dict(samples=60, epochs=1, rollout_steps=2, lstm_units=8, settle=0.2)


# --------------------------------------------------------------------------- orientation formulas, camera
def _arc(s, kappa, theta0, yaw):
    """A circular arc from the origin: tangent angle theta0 + kappa s in the vertical plane at heading
    yaw; positions (n, 3) [m] and unit tangents (n, 3)."""
    th = theta0 + kappa * s
    t = np.stack([np.cos(th) * math.cos(yaw), np.cos(th) * math.sin(yaw), np.sin(th)], -1)
    if kappa == 0:
        r = s[:, None] * t
    else:
        u = (np.sin(th) - math.sin(theta0)) / kappa          # integral of cos
        w = (math.cos(theta0) - np.cos(th)) / kappa          # integral of sin
        r = np.stack([u * math.cos(yaw), u * math.sin(yaw), w], -1)
    return r, t


def test_rotation_vectors_follow_the_papers_definition():
    deg = np.degrees
    # horizontal along +x: 90 deg about y; tilted up by 20 deg: 70 deg about y (phi measured from z)
    np.testing.assert_allclose(deg(rotation_vectors([1.0, 0.0, 0.0])), [0.0, 90.0, 0.0], atol=1e-12)
    up = [math.cos(math.radians(20)), 0.0, math.sin(math.radians(20))]
    np.testing.assert_allclose(deg(rotation_vectors(up)), [0.0, 70.0, 0.0], atol=1e-12)
    # a heading psi out of the xz-plane: k = (-sin psi, cos psi, 0), so x = -phi sin psi and z = 0 always
    psi = math.radians(10)
    r = rotation_vectors([math.cos(psi), math.sin(psi), 0.0])
    np.testing.assert_allclose(r, 0.5 * math.pi * np.array([-math.sin(psi), math.cos(psi), 0.0]), atol=1e-12)
    t = np.random.default_rng(0).normal(size=(50, 3))
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    r = rotation_vectors(t)
    assert np.all(r[:, 2] == 0.0)
    np.testing.assert_allclose(np.linalg.norm(r, axis=1), np.arccos(t[:, 2]), atol=1e-12)
    np.testing.assert_allclose(tangents_from_rotation_vectors(r), t, atol=1e-12)
    np.testing.assert_allclose(rotation_vectors([0.0, 0.0, 1.0]), [0.0, 0.0, 0.0], atol=0)


@pytest.mark.parametrize("kappa, theta0, yaw", [(0.0, -0.2, 0.0), (12.0, -0.3, 0.0), (-15.0, 0.1, 0.25)])
def test_camera_recovers_the_orientation_of_a_circular_arc(kappa, theta0, yaw):
    s = np.linspace(0.0, L, 26)
    sm = np.array([L / 2, L - 1e-3])
    r, _ = _arc(s, kappa, theta0, yaw)
    X = np.repeat(r[None], 400, axis=0)                                          # 400 identical frames
    true = rotation_vectors(_arc(sm, kappa, theta0, yaw)[1])                     # (2, 3)
    errors = []
    for noise in (2e-4, 2e-5, 0.0):
        cam = camera_measure(X, s, sm, noise, np.random.default_rng(3), points=100, degree=5)
        e = np.degrees(np.abs(cam.orientations - true))                          # (400, 2, 3)
        errors.append(float(e.mean()))
        if noise == 0.0:
            np.testing.assert_allclose(cam.positions[0], _arc(sm, kappa, theta0, yaw)[0], atol=1e-5)  # chords
    # noise-limited: the error shrinks with the noise (by ~10x), and without noise it is the fit's bias
    assert errors[0] < 2.0 and errors[1] < 0.25 * errors[0] and errors[2] < 0.02
    assert errors[2] < 0.5 * errors[1] or errors[1] < 0.02
    same = camera_orientations(X[:2], s, sm, 0.0, np.random.default_rng(0), points=100, degree=5)
    np.testing.assert_array_equal(same, camera_measure(X[:2], s, sm, 0.0, None, points=100, degree=5).orientations)


def test_camera_checks_its_input():
    s = np.linspace(0.0, L, 5)
    with pytest.raises(SoftrnnInputError, match="positions"):
        camera_orientations(np.zeros((3, 4, 3)), s, [0.01], 0.0, None)
    with pytest.raises(SoftrnnInputError, match=r"s_magnets=\[0.07\] is invalid"):
        camera_orientations(np.zeros((3, 5, 3)), s, [0.07], 0.0, None)
    with pytest.raises(SoftrnnInputError, match="points > degree"):
        camera_orientations(np.zeros((3, 5, 3)), s, [0.01], 0.0, None, points=4, degree=5)


# --------------------------------------------------------------------------- static vs dynamic model
@pytest.fixture(scope="module")
def settled():
    """The nominal robot (no perturbation) held at constant currents until it rests: an in-plane
    field and one with an out-of-plane component."""
    spec = ManipulatorSpec()
    out = []
    for b in ((0.003, 0.0, 0.012), (0.002, 0.004, -0.010)):
        I = currents_for_field(spec.coils, np.zeros(3), b)
        run = ManipulatorRun(dt=0.02, n_samples=2, settle=1.5)
        out.append((I, simulate_manipulator(spec, np.tile(I, (2, 1)), run)))
    return spec, out


def test_static_predictions_equal_the_settled_dynamic_model(settled):
    spec, runs = settled
    for I, traj in runs:
        assert np.max(np.abs(traj.rod.velocities[-1])) < 1e-4                  # at rest
        truth = rotation_vectors(traj.magnet_rotations[-1, :, :, 2])             # (2, 3)
        pred = static_predictions(I[None], spec=spec)
        assert pred.converged.all() and not pred.failures
        # two discretisations of one rod (26 lumped nodes vs RK4 with 41.4 GPa magnets) agree to 0.05 deg
        assert np.degrees(np.abs(pred.orientations[0] - truth)).max() < 0.05
        np.testing.assert_allclose(pred.positions[0], traj.magnet_positions[-1], atol=2e-5)
        assert np.degrees(np.linalg.norm(truth - rotation_vectors([1.0, 0.0, 0.0]), axis=1)).min() > 5  # it bent
    # the out-of-plane case turned the magnets about x too
    assert abs(np.degrees(rotation_vectors(runs[1][1].magnet_rotations[-1, 1, :, 2]))[0]) > 2


def test_measured_wrenches_are_the_simulators_from_the_true_pose(settled):
    spec, runs = settled
    _, traj = runs[1]
    W = measured_wrenches(spec, traj.currents, traj.magnet_positions, traj.magnet_rotations[..., 2])
    np.testing.assert_allclose(W, traj.wrenches, rtol=1e-9, atol=1e-15)


def test_failed_static_solves_are_counted_never_used():
    I = np.zeros((3, 6))
    with pytest.raises(SimulationError, match=r"failed on 3 of 3 samples .* first at sample 0: the magnets' "
                                              r"positions did not settle in 1 fixed-point iterations"):
        static_predictions(I, max_iterations=1, position_tol=1e-12)
    pred = static_predictions(I, tol=1e-30, max_failures=1.0)                   # below round-off: no convergence
    assert not pred.converged.any() and len(pred.failures) == 3
    assert "static solve" in pred.failures[0][1] and np.isnan(pred.orientations).all()
    with pytest.raises(SoftrnnInputError, match=r"max \|currents\|=9.0 is invalid: currents within the coil limit"):
        static_predictions(np.full((2, 6), 9.0))


# --------------------------------------------------------------------------- the experiment end to end
@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("experiment")
    config = ExperimentConfig(**TINY, calibration_evaluations=3)
    return config, out, run_experiment(config, out, workers=1)


def test_table1_has_the_documented_shape(tiny_run):
    config, out, result = tiny_run
    check_result_shape(result)
    paper = paper_case("magnetic_experiment")["test_max_mean_abs_deg"]
    assert result["paper"] == paper
    for name in ("distal", "proximal"):
        for model in ("rnn", "cosserat", "calibrated"):
            table = result[name][model]
            assert all(v[0] >= v[1] >= 0 for v in table)                       # max >= mean
        assert result[name]["cosserat"][2] == [0.0, 0.0]                         # about z: 0 by definition,
        assert result[name]["rnn"][2][0] < 0.05                                  # the LSTM learns a constant
    assert result["bending_axis"] == "y"
    for key in ("lstm_beats_static_on_bending_axis", "lstm_beats_static_on_bending_axis_max"):
        assert set(result[key]) == {"distal", "proximal"} and all(isinstance(v, bool) for v in result[key].values())
    assert result["samples"] == 60 and result["train_samples"] == 36 and result["test_targets"] == 60 - 36 - 2
    assert result["static"]["failures"] == 0
    for key in ("simulation_s", "static_solves_per_second", "static_predictions_per_second", "training_s",
                "rnn_steps_per_second", "total_s"):
        assert key in result["timings"]
    assert set(result["assumptions"]) >= {"robot", "camera", "orientation", "static_model", "lstm"}
    cal = result["calibration"]
    assert set(cal["parameters"]) == {"stiffness", "remanence", "damping"}
    for name, p in cal["parameters"].items():
        assert p["truth"] == getattr(config, name) and p["std_error"] > 0
        assert p["bounds"][0] <= p["fitted"] <= p["bounds"][1]
    assert cal["samples"] == 18 and cal["evaluations"] <= 3 and cal["failed_trials"] == 0
    assert cal["rms_residual_fitted"] < cal["rms_residual_start"]
    assert set(result["best_on_bending_axis"]) == {"distal", "proximal"}
    assert not (out / ".calibration-trials").exists()
    for f in ("robot.h5", "table1.json", "fig12.png", "calibration.json", "models/proximal/config.json",
              "models/distal/config.json"):
        assert (out / f).is_file()
    assert json.loads((out / "table1.json").read_text())["distal"] == result["distal"]


def test_a_rerun_reuses_the_simulation_and_gives_the_same_table(tiny_run):
    config, out, result = tiny_run
    again = run_experiment(config, out, workers=1)
    assert again["timings"]["simulation_resumed"] and not result["timings"]["simulation_resumed"]
    for name in ("distal", "proximal"):
        assert again[name]["rnn"] == result[name]["rnn"]
        assert again[name]["cosserat"] == result[name]["cosserat"]
        assert again[name]["calibrated"] == result[name]["calibrated"]
    assert again["calibration"] == result["calibration"]                         # read from calibration.json


@pytest.mark.slow
def test_full_experiment_lstm_beats_the_static_model_on_the_bending_axis(tmp_path):
    """The paper's claim on the full simulated experiment (669 samples; about a minute)."""
    result = run_experiment(ExperimentConfig(), tmp_path)
    b = "xyz".index(result["bending_axis"])
    for name in ("distal", "proximal"):
        assert result[name]["rnn"][b][1] < result[name]["cosserat"][b][1]
    assert result["static"]["failures"] == 0


@pytest.mark.parametrize("kwargs, match", [
    (dict(samples=5), "samples=5 is invalid"),
    (dict(samples=12), "samples=12 is invalid: enough samples"),
    (dict(samples=40), "samples=40 is invalid: at least 44 samples: the validation part"),
    (dict(stiffness=0.0), "stiffness=0.0 is invalid"),
    (dict(field_amplitude=(0.1, 0, 0)), r"field_amplitude=\(0.1, 0, 0\) is invalid"),
    (dict(field_band=(1.0, 0.5)), "field_band"),
    (dict(polynomial_degree=12), "polynomial_degree=12"),
    (dict(camera_noise=-1e-4), "camera_noise"),
    (dict(output="position"), "output='position'"),
    (dict(quick="yes"), "quick='yes'"),
])
def test_bad_config_gives_a_one_line_message(kwargs, match):
    with pytest.raises(SoftrnnInputError, match=match) as err:
        ExperimentConfig(**kwargs)
    assert "\n" not in str(err.value)


def test_quick_mode_defaults():
    assert (ExperimentConfig().samples, ExperimentConfig().epochs) == (669, 25)
    assert (ExperimentConfig(quick=True).samples, ExperimentConfig(quick=True).epochs) == (240, 8)
    assert ExperimentConfig(quick=True, samples=100).samples == 100


# --------------------------------------------------------------------------- lab CSV
def _lab(T=8, wrenches=True, positions=True):
    rng = np.random.default_rng(5)
    r = rotation_vectors(np.array([1.0, 0.0, -0.3]) + 0.05 * rng.normal(size=(T, 2, 3)))
    return LabData(time=0.05 * np.arange(T), currents=rng.uniform(-7.9, 7.9, (T, 6)), orientations=r,
                   positions=0.02 * rng.uniform(-1, 1, (T, 2, 3)) if positions else None,
                   wrenches=rng.normal(size=(T, 2, 6)) * [1e-4, 1e-4, 1e-4, 1e-5, 1e-5, 1e-5] if wrenches else None)


@pytest.mark.parametrize("wrenches, positions", [(True, True), (False, False)])
def test_lab_csv_round_trip(tmp_path, wrenches, positions):
    data = _lab(wrenches=wrenches, positions=positions)
    write_lab_csv(tmp_path / "lab.csv", data, comment="a test\nof two lines")
    back = read_lab_csv(tmp_path / "lab.csv")
    np.testing.assert_allclose(back.time, data.time, atol=1e-6)
    np.testing.assert_allclose(back.currents, data.currents, atol=5e-5)
    np.testing.assert_allclose(np.degrees(back.orientations), np.degrees(data.orientations), atol=5e-5)
    if positions:
        np.testing.assert_allclose(back.positions, data.positions, atol=5e-8)
    else:
        assert back.positions is None
    if wrenches:
        np.testing.assert_allclose(back.wrenches, data.wrenches, rtol=1e-5)
    else:
        assert back.wrenches is None


def test_the_example_file_reads_and_is_small():
    data = read_lab_csv(EXAMPLE)
    assert data.n_samples == 300 and data.currents.shape == (300, 6) and data.positions.shape == (300, 2, 3)
    assert EXAMPLE.stat().st_size < 100_000
    assert data.wrenches is None and np.all(np.abs(data.currents) <= 8.0)
    # about y (bending) it moves by tens of degrees, about z not at all
    ranges = np.degrees(np.ptp(data.orientations, axis=0))
    assert np.all(ranges[:, 1] > 20) and np.all(ranges[:, 2] == 0)


HEADER = "time,I0,I1,I2,I3,I4,I5,m0_rx,m0_ry,m0_rz,m1_rx,m1_ry,m1_rz"
ROW = "{t},1,2,3,-1,-2,-3,0,90,0,0,95,0"


@pytest.mark.parametrize("text, match", [
    (HEADER.replace(",m1_ry", "") + "\n", r"line 1 \(header\): missing column 'm1_ry'|missing column m1_ry"),
    (HEADER.replace("I0,", "") + "\n", "missing column I0: the coil currents I0..I5 are given for all or none"),
    ("time,m0_rx,m0_ry,m0_rz,m1_rx,m1_ry,m1_rz\n0,0,90,0,0,90,0\n", "missing columns I0..I5"),
    (HEADER + ",volts\n", "column 'volts' is not recognised"),
    (HEADER + ",I0\n", "column 'I0' appears twice"),
    ("I0,time\n", "the first column is 'I0'"),
    (HEADER + "\n" + ROW.format(t=0) + "\n0,1,2,abc,-1,-2,-3,0,90,0,0,95,0\n",
     r"line 3, column 'I2': the cell 'abc' is not a number"),
    (HEADER + "\n" + ROW.format(t=0) + "\n0.1,1,2,,-1,-2,-3,0,90,0,0,95,0\n",
     r"line 3, column 'I2': the cell is empty"),
    (HEADER + "\n" + ROW.format(t=0) + "\n0.1,1,2,3,-1,-2,nan,0,90,0,0,95,0\n", "column 'I5': 'nan' is not a finite"),
    (HEADER + "\n" + ROW.format(t=0) + "\n" + ROW.format(t=0.1).replace(",-2,-3,", ",-9.5,-3,") + "\n",
     r"line 3, column 'I4': -9.5 A is beyond the coil limit \+/-8 A"),
    (HEADER + "\n" + ROW.format(t=0) + "\n" + ROW.format(t=0) + "\n", "line 3: time 0.0 is not after 0.0"),
    (HEADER + "\n" + "\n".join(ROW.format(t=t) for t in (0, 0.1, 0.2, 0.35)) + "\n",
     "line 5: the time step 0.15 s differs from the median 0.1 s by 50 %"),
    (HEADER + "\n" + ROW.format(t=0) + "\n0.1,1,2\n", "line 3 has 3 cells but the header has 13 columns"),
    (HEADER + "\n" + ROW.format(t=0) + "\n" + ROW.format(t=0.1).replace(",0,95,", ",0,195,") + "\n",
     "columns m1_rx..m1_rz: a rotation vector of 195 deg"),
    (HEADER + "\n" + ROW.format(t=0) + "\n", "has 1 data row"),
    ("# only a comment\n", "is empty"),
])
def test_bad_lab_csv_gives_a_one_line_message(tmp_path, text, match):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(SoftrnnInputError, match=match) as err:
        read_lab_csv(path)
    assert "\n" not in str(err.value) and str(path) in str(err.value)


def test_missing_lab_file(tmp_path):
    with pytest.raises(SoftrnnInputError, match="no such file"):
        read_lab_csv(tmp_path / "nope.csv")


# --------------------------------------------------------------------------- CLI
def test_cli_compares_lab_data(tmp_path, capsys):
    data = simulated_lab_data(60, config=ExperimentConfig(seed=2, **TINY))
    write_lab_csv(tmp_path / "lab.csv", data)
    code = main(["magnetic", "compare", str(tmp_path / "lab.csv"), "-o", str(tmp_path / "out"), "--epochs", "1",
                 "--quiet", "--json", str(tmp_path / "t.json")])
    assert code == 0
    out = capsys.readouterr().out
    assert "static Cosserat model" in out and "paper: RNN-based model" in out and "bending axis: y" in out
    result = json.loads((tmp_path / "t.json").read_text())
    check_result_shape(result)
    assert result["wrenches_from"] == "the currents at the measured magnet positions"
    assert (tmp_path / "out" / "fig12.png").is_file()


@pytest.mark.parametrize("argv, match", [
    (["magnetic", "compare", "{bad}", "-o", "{out}"], r"column 'I4': -9.5 A is beyond the coil limit"),
    (["magnetic", "compare", "{missing}", "-o", "{out}"], "no such file"),
    (["magnetic", "experiment", "-o", "{out}", "--samples", "5"], "samples=5 is invalid"),
    (["magnetic", "experiment", "-o", "{out}", "--epochs", "0"], "epochs=0 is invalid"),
    (["magnetic", "example-csv", "{out}/x.csv", "--samples", "3"], "--samples"),
])
def test_cli_bad_input_exits_2_with_one_line(tmp_path, capsys, argv, match):
    bad = tmp_path / "bad.csv"
    bad.write_text(HEADER + "\n" + ROW.format(t=0) + "\n" + ROW.format(t=0.1).replace(",-2,-3,", ",-9.5,-3,") + "\n")
    subs = {"bad": str(bad), "missing": str(tmp_path / "missing.csv"), "out": str(tmp_path / "out")}
    assert main([a.format(**subs) for a in argv]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("softrnn: error:") and "\n" not in err
    assert re.search(match, err)


def test_cli_usage_errors_exit_2(capsys):
    with pytest.raises(SystemExit) as exit_:
        main(["magnetic", "shake"])
    assert exit_.value.code == 2 and "\n" not in capsys.readouterr().err.strip()
