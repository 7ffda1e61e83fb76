"""Closed-loop control of the magnetic rod (issue 14): the frame-by-frame plant equals the batch
simulation, references and their CSV errors, the controller's currents within the limits, the
loop's bookkeeping, and the CLI's one-line errors."""

import json
import re

import numpy as np
import pytest

from softrnn.cli.main import main
from softrnn.control.references import REFERENCES, reference
from softrnn.errors import SoftrnnInputError
from softrnn.magnetics import ManipulatorRun, ManipulatorSpec, currents_for_field, simulate_manipulator
from softrnn.magnetics.stepper import ManipulatorStepper

DT = 1 / 30


def test_stepping_frame_by_frame_equals_the_batch_simulation():
    spec = ManipulatorSpec()
    I = currents_for_field(spec.coils, np.zeros(3), [0.004, 0.0, -0.008])
    batch = simulate_manipulator(spec, np.tile(I, (4, 1)), ManipulatorRun(dt=DT, n_samples=4, settle=0.1))
    stepper = ManipulatorStepper(spec, DT, I, settle=0.1)
    got = [stepper.positions]
    for _ in range(3):
        stepper.step(I)
        got.append(stepper.positions)
    np.testing.assert_allclose(np.array(got), batch.positions, rtol=0, atol=1e-13)     # round-off of t = t0 + k h
    assert stepper.time == pytest.approx(3 * DT) and stepper.frames == 3
    with pytest.raises(SoftrnnInputError, match=r"max \|currents\|=9.0 is invalid: currents within the coil limit"):
        stepper.step(np.full(6, 9.0))


@pytest.mark.parametrize("name", REFERENCES)
def test_shipped_references_start_at_rest_and_stay_in_their_span(name):
    from softrnn.control.references import REST_DEG, SPAN_DEG

    ref = reference(name, duration=30.0)
    assert ref.times.shape == (901,) and ref.angles.shape == (901, 2)
    dev = np.degrees(ref.angles) - np.array(REST_DEG)
    assert np.all(np.abs(dev) <= np.array(SPAN_DEG) + 1e-9)
    assert np.allclose(dev[0], 0.0, atol=1e-9) or name == "sine"
    np.testing.assert_array_equal(ref.window(899, 3), ref.angles[[900, 900, 900]])   # held past the end
    np.testing.assert_allclose(reference(name, duration=10.0).angles, ref.angles[:301], rtol=0, atol=1e-12)


@pytest.mark.parametrize("text, match", [
    ("t,a,b\n0,1,2\n1,2,3\n", r"the header must be time,about_y_deg,about_x_deg"),
    ("time,about_y_deg,about_x_deg\n0,1\n", r"line 2: expected 3 finite numbers"),
    ("time,about_y_deg,about_x_deg\n0,90,0\n0,91,0\n", r"the times must start at 0 and increase strictly"),
    ("time,about_y_deg,about_x_deg\n0.5,90,0\n1,91,0\n", r"the times must start at 0"),
])
def test_csv_reference_errors_are_one_line(tmp_path, text, match):
    path = tmp_path / "ref.csv"
    path.write_text(text)
    with pytest.raises(SoftrnnInputError, match=match) as err:
        reference(str(path), duration=1.0)
    assert "\n" not in str(err.value)


def test_csv_reference_is_interpolated_at_the_frames(tmp_path):
    path = tmp_path / "ref.csv"
    path.write_text("time,about_y_deg,about_x_deg\n0,90,0\n1,100,-2\n")
    ref = reference(str(path), duration=2.0)
    np.testing.assert_allclose(np.degrees(ref.angles[15]), [-1.0, 95.0])             # t = 0.5 s
    np.testing.assert_allclose(np.degrees(ref.angles[-1]), [-2.0, 100.0])            # held after the last row


@pytest.mark.parametrize("argv, match", [
    (["control", "magnetic", "--reference", "zigzag", "--controller", "static-inverse", "-o", "{out}"],
     r"--reference='zigzag' is invalid: one of step, sine, random, or a .csv file"),
    (["control", "magnetic", "--reference", "step", "--controller", "pid", "-o", "{out}"],
     r"--controller='pid' is invalid: one of static-inverse"),
    (["control", "magnetic", "--reference", "step", "--controller", "static-inverse", "-o", "{out}",
      "--duration", "0"], r"--duration=0.0 is invalid"),
    (["control", "magnetic", "--reference", "step", "--controller", "static-inverse", "-o", "{out}",
      "--stiffness", "0"], r"--stiffness=0.0 is invalid: a factor in \[0.2, 5\]"),
    (["control", "magnetic", "--reference", "step", "--controller", "mpc-physics", "-o", "{out}",
      "--plan-factors", "1,2"], r"--plan-factors='1,2' is invalid: three factors in \[0.2, 5\]"),
])
def test_cli_bad_input_exits_2_with_one_line(tmp_path, capsys, argv, match):
    assert main([a.format(out=tmp_path / "out") for a in argv]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("softrnn: error:") and "\n" not in err and re.search(match, err)
    assert not (tmp_path / "out").exists()


@pytest.fixture(scope="module")
def short_loop(tmp_path_factory):
    out = tmp_path_factory.mktemp("control")
    code = main(["control", "magnetic", "--reference", "step", "--controller", "static-inverse", "-o", str(out),
                 "--duration", "1.0", "--quiet"])
    return code, out


def test_static_inverse_closes_the_loop_within_the_limits(short_loop):
    code, out = short_loop
    assert code == 0
    s = json.loads((out / "control.json").read_text())
    assert s["frames"] == 31 and s["limit_violations"] == 0 and s["stable"]
    assert 0 < s["rms_deg"] < 10 and s["compute_ms_p99"] > 0
    from softrnn.io import read_dataset

    data = read_dataset(out / "run.h5")
    assert data.positions.shape == (31, 26, 3)
    currents = np.asarray(data.attrs["currents"])
    assert currents.shape == (31, 6) and np.max(np.abs(currents)) <= 8.0
    assert (out / "control.png").is_file()


# --------------------------------------------------------------------------- the learned MPC
def _linear_narx(rate: float = 0.5, eps: float = 1e-4):
    """A NarxModel that is linear to ~eps^2: the distal state relaxes to G u at ``rate`` per frame,
    G u = (u_y, u_z) (about x <- the field's y, about y <- its z); the proximal state stays put."""
    from softrnn.control.model import HISTORY, NarxModel

    D = HISTORY * 7
    W1 = np.eye(D)                                   # hidden = tanh(eps z) ~ eps z, z = the raw inputs
    last_y = (HISTORY - 1) * 4                       # columns of y[k] and u[k] in the input
    last_u = HISTORY * 4 + (HISTORY - 1) * 3
    W2 = np.zeros((4, D))
    W2[2, last_y + 2], W2[3, last_y + 3] = -rate, -rate
    W2[2, last_u + 1], W2[3, last_u + 2] = rate, rate
    return NarxModel(mean=np.zeros(D), std=np.full(D, 1 / eps), W1=W1, b1=np.zeros(D), W2=W2 / eps,
                     b2=np.zeros(4), meta={})


def test_mpc_on_a_known_linear_model_finds_the_input_that_holds_the_target():
    """The plant is the MPC's own (linear) model: the answer is known, c = asin(x*), a = asin(y* / cos c)."""
    from softrnn.control.fields import field_direction
    from softrnn.control.model import NarxPredictor
    from softrnn.control.mpc import BlockMPC, MPCOptions
    from softrnn.control.references import Reference

    model = _linear_narx()
    target = np.array([0.1, 0.3])                                              # (about x, about y) [rad]
    ref = Reference(name="hold", times=np.arange(80) / 30, angles=np.tile(target, (80, 1)))
    mpc = BlockMPC(NarxPredictor(model, observer_gain=1.0, disturbance_gain=0.0),
                   options=MPCOptions(move_weight=1e-8, iterations=6))
    mpc.reset(ref)
    y = np.zeros(4)
    us = np.tile(field_direction(*mpc.applied), (2, 1))
    ys = np.tile(y, (2, 1))
    for k in range(79):
        measured = np.array([[y[0], y[1], 0.0], [y[2], y[3], 0.0]])
        I = mpc(k, measured, ref)
        assert np.max(np.abs(I)) <= 8.0
        us = np.concatenate([us[1:], field_direction(*mpc.applied)[None]])
        y = model.step(ys[None], us[None])[0]
        ys = np.concatenate([ys[1:], y[None]])
    c = np.arcsin(target[0])
    np.testing.assert_allclose(mpc.applied, [np.arcsin(target[1] / np.cos(c)), c], atol=1e-5)
    np.testing.assert_allclose(y[2:], target, atol=1e-6)


def test_controllers_hold_the_last_currents_on_a_lost_measurement_and_stay_within_the_limits():
    from softrnn.control.model import NarxPredictor
    from softrnn.control.mpc import BlockMPC
    from softrnn.control.references import Reference

    mpc = BlockMPC(NarxPredictor(_linear_narx()))
    far = Reference(name="out of reach", times=np.arange(10) / 30, angles=np.tile([0.0, 3.0], (10, 1)))
    first = mpc.reset(far)
    ok = np.array([[0.0, 1.6, 0.0], [0.0, 1.7, 0.0]])
    currents = [mpc(k, ok, far) for k in range(3)]
    lost = mpc(3, np.full((2, 3), np.nan), far)
    np.testing.assert_array_equal(lost, currents[-1])
    assert mpc.held == 1
    assert max(np.max(np.abs(I)) for I in [first, *currents]) <= 0.95 * 8.0 + 1e-9


# --------------------------------------------------------------------------- the physics MPC
def test_a_restored_snapshot_replays_the_same_frame_bit_for_bit():
    spec = ManipulatorSpec()
    I = currents_for_field(spec.coils, np.zeros(3), [0.004, 0.0, -0.008])
    J = currents_for_field(spec.coils, np.zeros(3), [0.008, 0.001, -0.004])
    stepper = ManipulatorStepper(spec, DT, I, settle=0.05)
    snap = stepper.snapshot()
    stepper.step(J)
    first = stepper.positions
    stepper.step(J)
    stepper.restore(snap)
    assert stepper.frames == 0 and stepper.time == 0.0
    stepper.step(J)
    np.testing.assert_array_equal(stepper.positions, first)


def test_physics_mpc_on_its_own_model_reaches_the_target_and_holds_on_a_lost_measurement():
    """The plant is the MPC's own nominal model, the camera without noise: after a 5 deg step of the
    target, the distal magnet settles on it."""
    from softrnn.control.controllers import controller
    from softrnn.control.loop import LoopConfig, run_loop
    from softrnn.control.references import REST_DEG, Reference

    t = np.arange(31) / 30
    target = np.radians(np.where(t[:, None] < 0.1, REST_DEG, np.add(REST_DEG, (0.0, 5.0))))
    ref = Reference(name="step", times=t, angles=target)
    config = LoopConfig(stiffness=1.0, remanence=1.0, damping=1.0, camera_noise=0.0, settle=0.2)
    mpc = controller("mpc-physics", config=config)
    result = run_loop(mpc, ref, config)
    err = result.errors_deg("true")
    assert result.limit_violations == 0 and np.all(np.abs(result.currents) <= 8.0)
    assert np.max(np.abs(err[-5:])) < 0.05, err[-5:]
    moved = np.degrees(result.true[-1, 1, 1] - result.true[0, 1, 1])
    assert moved > 4.0                                         # it followed the step (from the static start)
    np.testing.assert_array_equal(mpc.predictor.disturbance, 0.0)   # its model is the plant: nothing to learn
    frames, currents = mpc.predictor.sim.frames, mpc.currents.copy()
    np.testing.assert_array_equal(mpc(30, np.full((2, 3), np.nan), ref), currents)
    assert mpc.held == 1 and mpc.predictor.sim.frames == frames + 1     # its model still follows the plant


# --------------------------------------------------------------------------- the predictor protocol and options
def test_both_predictors_satisfy_the_predictor_protocol():
    from softrnn.control.controllers import controller
    from softrnn.control.model import NarxPredictor
    from softrnn.control.mpc import BlockMPC
    from softrnn.control.physics_mpc import PhysicsPredictor
    from softrnn.control.predictors import Predictor

    assert isinstance(NarxPredictor(_linear_narx()), Predictor)
    assert isinstance(PhysicsPredictor(), Predictor)
    assert not isinstance(object(), Predictor)
    for name, kind in (("mpc-learned", NarxPredictor), ("mpc-physics", PhysicsPredictor)):
        mpc = controller(name, model=_linear_narx())
        assert type(mpc) is BlockMPC and isinstance(mpc.predictor, kind)
    with pytest.raises(SoftrnnInputError, match=r"^predictor='object' is invalid"):
        BlockMPC(object())


def test_mpc_options_are_frozen_with_one_set_of_defaults():
    import dataclasses

    from softrnn.control.mpc import BlockMPC, MPCOptions
    from softrnn.control.physics_mpc import PHYSICS_OPTIONS

    options = MPCOptions()
    with pytest.raises(dataclasses.FrozenInstanceError):
        options.horizon = 3
    assert (options.horizon, options.blocks, options.iterations, options.refresh) == (7, (1, 2, 4), 1, 1)
    assert dataclasses.replace(PHYSICS_OPTIONS, refresh=1) == options
    assert BlockMPC(_NullPredictor()).options == options


class _NullPredictor:
    history = 1

    def start(self, target):
        return np.zeros(2)

    def reset(self, applied, currents):
        pass

    def observe(self, measured):
        return False

    def predict(self, plans, block_of):
        return np.zeros((plans.shape[0], block_of.size, 2))

    def advance(self, applied, currents):
        pass

    def hold(self, currents):
        pass


@pytest.mark.parametrize("kwargs, match", [
    ({"horizon": 0, "blocks": ()}, r"^horizon=0 is invalid: at least 1 frame$"),
    ({"blocks": (1, 2)}, r"^blocks=\(1, 2\) is invalid: block lengths >= 1 that add up to the horizon 7$"),
    ({"blocks": (0, 3, 4)}, r"^blocks=\(0, 3, 4\) is invalid"),
    ({"iterations": 0}, r"^iterations=0 is invalid: at least 1 Gauss-Newton step per frame$"),
    ({"iterations": 1.5}, r"^iterations=1.5 is invalid"),
    ({"move_weight": -1.0}, r"^move_weight=-1.0 is invalid: a finite weight >= 0$"),
    ({"azimuth_weight": float("nan")}, r"^azimuth_weight=nan is invalid"),
    ({"diff_step": 0.0}, r"^diff_step=0.0 is invalid: a positive finite step in rad$"),
    ({"refresh": 0}, r"^refresh=0 is invalid: at least 1 frame$"),
])
def test_mpc_options_refuse_a_bad_value_in_one_line_naming_it(kwargs, match):
    from softrnn.control.mpc import MPCOptions

    with pytest.raises(SoftrnnInputError, match=match) as err:
        MPCOptions(**kwargs)
    assert "\n" not in str(err.value)


@pytest.mark.parametrize("gain", ["observer_gain", "disturbance_gain"])
def test_predictor_gains_are_validated(gain):
    from softrnn.control.model import NarxPredictor

    with pytest.raises(SoftrnnInputError, match=rf"^{gain}=1.5 is invalid: a gain in \[0, 1\]$"):
        NarxPredictor(_linear_narx(), **{gain: 1.5})


# --------------------------------------------------------------------------- the run's summary
def _summary_dict(result, bound_deg: float = 45.0) -> dict:
    """The summary's dict as the JSON file has always held it (keys in this order)."""
    e = result.errors_deg("true")
    m = result.errors_deg("measured")
    finite = bool(np.all(np.isfinite(e)))
    ms = 1e3 * result.compute_s
    return {
        "rms_deg": float(np.sqrt(np.mean(e ** 2))) if finite else None,
        "max_deg": float(np.max(np.abs(e))) if finite else None,
        "rms_deg_about": {axis: float(np.sqrt(np.mean(e[:, i] ** 2))) if finite else None
                          for i, axis in enumerate("xy")},
        "max_deg_about": {axis: float(np.max(np.abs(e[:, i]))) if finite else None for i, axis in enumerate("xy")},
        "measured_rms_deg": float(np.sqrt(np.nanmean(m ** 2))),
        "limit_violations": int(result.limit_violations), "held_frames": int(result.held),
        "compute_ms_median": float(np.median(ms)), "compute_ms_p99": float(np.percentile(ms, 99)),
        "wall_ms_median": float(np.median(1e3 * result.wall_s)),
        "wall_ms_p99": float(np.percentile(1e3 * result.wall_s, 99)),
        "stable": finite and float(np.max(np.abs(e))) < bound_deg,
        "frames": int(result.time.size),
    }


@pytest.mark.parametrize("lost", [False, True])
def test_loop_summary_to_dict_is_the_summary_dict_key_for_key(lost):
    from softrnn.control.loop import LoopResult

    rng = np.random.default_rng(3)
    K = 12
    measured, true = rng.normal(1.0, 0.1, (K + 1, 2, 3)), rng.normal(1.0, 0.1, (K + 1, 2, 3))
    if lost:
        measured[4] = np.nan
        true[5, 1, 0] = np.inf
    result = LoopResult(time=np.arange(K + 1) / 30, reference=rng.normal(1.0, 0.1, (K + 1, 2)), measured=measured,
                        true=true, currents=np.zeros((K + 1, 6)), compute_s=rng.uniform(0, 1e-3, K),
                        wall_s=rng.uniform(0, 1e-3, K), positions=np.zeros((K + 1, 26, 3)), limit_violations=2,
                        held=int(lost))
    summary = result.summary()
    want = _summary_dict(result)
    assert summary.to_dict() == want and list(summary.to_dict()) == list(want)
    assert json.dumps(summary.to_dict()) == json.dumps(want)
    assert summary.stable is not lost and summary.held_frames == int(lost)


def test_control_summary_file_holds_to_dict_in_its_order(short_loop):
    from softrnn.control.loop import LoopConfig

    _, out = short_loop
    s = json.loads((out / "control.json").read_text())
    assert list(s) == ["reference", "controller", "duration_s", "rms_deg", "max_deg", "rms_deg_about",
                       "max_deg_about", "measured_rms_deg", "limit_violations", "held_frames", "compute_ms_median",
                       "compute_ms_p99", "wall_ms_median", "wall_ms_p99", "stable", "frames", "config", "files"]
    assert s["config"] == LoopConfig().to_dict() and list(s["files"]) == ["run", "figure"]
    assert (s["reference"], s["controller"], s["duration_s"]) == ("step", "static-inverse", 1.0)


def test_control_imports_no_experiment():
    """Control is a product part: neither it nor the static model it inverts reaches into a study."""
    import ast
    from pathlib import Path

    import softrnn.control

    folder = Path(softrnn.control.__file__).parent
    reached = []
    for path in [*folder.glob("*.py"), folder.parent / "magnetics" / "static.py"]:
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and "experiments" in (node.module or ""):
                reached.append(f"{path.name}: {node.module}")
            elif isinstance(node, ast.Import) and any("experiments" in a.name for a in node.names):
                reached.append(path.name)
    assert reached == []
