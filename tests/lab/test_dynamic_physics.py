"""The dynamic physics driven by recorded tensions (``softrnn.lab.dynamic_physics``) and its
families: the exact actuator lag, calibration recovering known parameters from a session the
simulator made, the hybrid that adds nothing where the physics is right, and bad input."""

import json

import numpy as np
import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.lab.benchmark import BenchmarkOptions, run_benchmark
from softrnn.lab.dynamic_families import DynamicHybrid, DynamicPhysics, Residual, split
from softrnn.lab.dynamic_physics import (
    DynamicOptions,
    DynamicRobot,
    TensionProfile,
    calibrate_dynamics,
    coarse,
    lagged,
)
from softrnn.lab.recording import Recording, shift_inputs
from softrnn.scenarios import load_scenario, scenario_text

from helpers import run_cli

TRUTH = {"youngs_modulus": 1.3, "actuator_lag_s": 0.15}
"""The parameters the synthetic sessions are made with."""


@pytest.fixture(scope="module")
def scenario_file(tmp_path_factory):
    """tendon-spatial with an 11-node rod: quick to simulate."""
    text = scenario_text("tendon-spatial").replace("n_nodes = 41", "n_nodes = 11")
    text = text.replace("nodes_of_interest = [-1, 20]", "nodes_of_interest = [-1, 5]")
    path = tmp_path_factory.mktemp("scenario") / "arm.toml"
    path.write_text(text)
    return path


def tensions(seconds: float, seed: int, rate: float = 20.0) -> tuple[np.ndarray, np.ndarray]:
    """Row times (T,) [s] and smooth tensions (T, 3) [N] from 0 N: sums of sines of random phases."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(seconds * rate) + 1) / rate
    ramp = np.minimum(t / 0.5, 1.0)
    u = np.column_stack([3.0 + 2.0 * np.sin(2 * np.pi * f * t + p) for f, p in
                         zip(rng.uniform(0.2, 0.8, 3), rng.uniform(0, 2 * np.pi, 3))])
    return t, u * ramp[:, None]


def session(robot, seconds: float, seed: int, values=TRUTH, noise: float = 0.0, path="synthetic") -> Recording:
    """A session the simulator made at ``values``: tensions in N, the tip [m] with ``noise`` [m]."""
    t, u = tensions(seconds, seed)
    blank = Recording(path=path, time=t, inputs=u, names=("tendon_a", "tendon_b", "tendon_c"), units=("N",) * 3,
                      tip=np.zeros((t.size, 3)))
    tip = robot.tip(values, blank) + noise * np.random.default_rng(seed).standard_normal((t.size, 3))
    return Recording(path=path, time=t, inputs=u, names=blank.names, units=blank.units, tip=tip)


@pytest.fixture(scope="module")
def robot(scenario_file):
    return DynamicRobot.from_scenario(str(scenario_file), DynamicOptions(window=0.0, fit=tuple(TRUTH),
                                                                         max_evaluations=15))


@pytest.fixture(scope="module")
def sessions(robot):
    return [session(robot, 6.0, seed) for seed in (1, 2)]


def test_lag_is_the_exact_first_order_response():
    t = np.linspace(0.0, 2.0, 41)
    step = np.ones((t.size, 1))
    step[0] = 0.0
    y = lagged(t, step, 0.3, hold="zoh")                  # u = 0 on the first interval, then 1
    np.testing.assert_allclose(y[2:, 0], 1 - np.exp(-(t[2:] - t[1]) / 0.3), rtol=0, atol=1e-12)
    ramp = t[:, None] * 2.0                                # y = 2 (t - tau (1 - exp(-t / tau))) from y(0) = 0
    np.testing.assert_allclose(lagged(t, ramp, 0.3)[:, 0], 2 * (t - 0.3 * (1 - np.exp(-t / 0.3))), atol=1e-12)
    np.testing.assert_array_equal(lagged(t, ramp, 0.0), ramp)
    profile = TensionProfile(t, ramp, lagged(t, ramp, 0.3), 0.3, "linear", 0)
    mid = (t[:-1] + t[1:]) / 2                              # between rows too, and held beyond the last one
    np.testing.assert_allclose(profile(mid), 2 * (mid - 0.3 * (1 - np.exp(-mid / 0.3))), atol=1e-12)
    assert profile(np.array([5.0]))[0] == pytest.approx(lagged(t, ramp, 0.3)[-1, 0] + (4.0 - lagged(
        t, ramp, 0.3)[-1, 0]) * (1 - np.exp(-3.0 / 0.3)), abs=1e-9)


def test_calibration_recovers_the_parameters(robot, sessions):
    cal = calibrate_dynamics(robot, sessions)
    assert cal.values["youngs_modulus"] == pytest.approx(TRUTH["youngs_modulus"], rel=0.02)
    assert cal.values["actuator_lag_s"] == pytest.approx(TRUTH["actuator_lag_s"], rel=0.05)
    assert cal.values["density"] == 1.0                   # not fitted: its start
    assert cal.rmse_fitted_mm < 0.05 < cal.rmse_start_mm
    report = cal.to_dict()
    assert report["parameters"]["youngs_modulus"]["fitted_here"] and not report["parameters"]["density"]["fitted_here"]
    assert report["rows"] == sum(s.n_rows for s in sessions)


def test_a_shifted_session_is_run_on_its_inputs_own_times(robot, sessions):
    s = sessions[0]
    whole = robot.tip(TRUTH, s)
    shifted = robot.tip(TRUTH, shift_inputs(s, 3))          # its last 3 rows hold the last input it kept
    np.testing.assert_allclose(shifted[:-3], whole[3:-3], rtol=0, atol=1e-9)


@pytest.fixture(scope="module")
def physics(robot, sessions):
    return DynamicPhysics(robot).fit(sessions)          # calibrated on the first session, held out: the second


def test_hybrid_adds_nothing_where_the_physics_is_right(physics, sessions, robot):
    assert physics.holdout_rmse_mm < 0.05 and physics.radius_m > 0
    hybrid = DynamicHybrid(physics).fit(sessions)
    new = session(robot, 4.0, 3)
    assert np.max(np.abs(hybrid.predict(new) - physics.predict(new))) < 2e-5
    assert hybrid.holdout_rmse_mm <= physics.holdout_rmse_mm + 1e-3
    tip, radius = hybrid.predict_interval(new)
    assert tip.shape == (new.n_rows, 3) and radius.shape == (new.n_rows,) and np.all(radius > 0)
    assert set(hybrid.describe()["residual_holdout_rmse_mm"]) == {"none", "static", "arx"}


def test_a_residual_learns_a_constant_offset(physics, sessions):
    shifted = [Recording(path=s.path, time=s.time, inputs=s.inputs, names=s.names, units=s.units,
                         tip=s.tip + [0.004, 0.0, 0.0]) for s in sessions]
    hybrid = DynamicHybrid(physics).fit(shifted)
    assert hybrid.residual.kind != "none"
    assert np.sqrt(np.mean(np.sum((hybrid.predict(shifted[1]) - shifted[1].tip) ** 2, axis=1))) < 2e-4
    fit_part, held = split(shifted[:1])                    # one session: its last quarter held out
    assert held[0].rows.start == fit_part[0].rows.stop == 91     # of 121 rows
    assert Residual("none").fit([]).run(shifted[0], shifted[0].tip).max() == 0


def test_a_fine_rod_is_run_coarse_where_only_its_ends_are_named():
    sc = load_scenario("tendon-spatial")
    assert coarse(sc, 21).setup.rod.n_nodes == 21
    assert coarse(sc, 21, node=20) is sc and coarse(sc, 0) is sc
    robot = DynamicRobot.from_scenario("tendon-spatial")
    assert robot.scenario.setup.rod.n_nodes == 21 and robot.nodes_described == 41
    assert robot.tendons == ("a", "b", "c") and robot.length == pytest.approx(0.4)


def test_sessions_that_do_not_fit_the_scenario_are_refused(robot, sessions):
    s = sessions[0]
    two = Recording(path="two.csv", time=s.time, inputs=s.inputs[:, :2], names=s.names[:2], units=("N", "N"),
                    tip=s.tip)
    with pytest.raises(SoftrnnInputError, match=r"^scenario=.*as many tendons as the recording two.csv has input "
                                                r"columns \(2\), but the scenario has 3"):
        robot.check(two)
    mm = Recording(path="mm.csv", time=s.time, inputs=s.inputs, names=s.names, units=("mm",) * 3, tip=s.tip)
    with pytest.raises(SoftrnnInputError, match=r"^scenario=.*tendon tensions in N.*are mm$"):
        robot.check(mm)
    with pytest.raises(SoftrnnInputError, match="^scenario='steel-wire'.*tendons"):
        DynamicRobot.from_scenario("steel-wire")
    with pytest.raises(SoftrnnInputError, match="^window="):
        DynamicOptions(window=-1.0)
    with pytest.raises(SoftrnnInputError, match="^fit="):
        DynamicOptions(fit=("stiffness",))


def _csv(path, s: Recording, unit: str = "N") -> None:
    header = "time,tip_x,tip_y,tip_z," + ",".join(f"act_{n}[{unit}]" for n in s.names)
    rows = [",".join(f"{v:.6f}" for v in (t, *(p * 1e3), *u)) for t, p, u in zip(s.time, s.tip, s.inputs)]
    path.write_text("\n".join([header, *rows]) + "\n")


def test_the_benchmark_runs_the_dynamic_families(tmp_path, robot, scenario_file):
    short = [session(robot, 3.0, seed, noise=1e-4 * (seed == 3)) for seed in (1, 2, 3)]
    for k, s in enumerate(short):
        _csv(tmp_path / f"s{k}.csv", s)
    out = tmp_path / "dyn.json"
    args = ["lab", "benchmark", "--train", str(tmp_path / "s0.csv"), str(tmp_path / "s1.csv"), "--validate",
            str(tmp_path / "s2.csv"), "--length", "0.4", "--lag", "0", "--families", "dynamic_physics,dynamic_hybrid",
            "--scenario", str(scenario_file), "--json", str(out), "--quiet"]
    assert run_cli(args) == 0
    report = json.loads(out.read_text())
    assert set(report["models"]) == {"dynamic_physics", "dynamic_hybrid"}
    assert report["models"]["dynamic_physics"]["tip_rmse_mm"] < 0.5          # marker noise 0.1 mm per axis
    assert report["chosen_on_training"]["family"] in report["models"]
    assert report["details"]["dynamic_physics"]["calibration"]["parameters"]["actuator_lag_s"]["fitted_here"]


def test_the_benchmark_refuses_a_scenario_that_does_not_fit(tmp_path, sessions, scenario_file, capsys):
    for k, s in enumerate(sessions):
        _csv(tmp_path / f"n{k}.csv", s)
        _csv(tmp_path / f"m{k}.csv", s, unit="mm")
    for k in (0, 1):
        two = Recording(path="", time=sessions[k].time, inputs=sessions[k].inputs[:, :2], names=("a", "b"),
                        units=("N", "N"), tip=sessions[k].tip)
        _csv(tmp_path / f"two{k}.csv", two)
    out = tmp_path / "dyn.json"
    for train, val in (("m0", "m1"), ("two0", "two1")):
        args = ["lab", "benchmark", "--train", str(tmp_path / f"{train}.csv"), "--validate",
                str(tmp_path / f"{val}.csv"), "--length", "0.4", "--families", "dynamic_physics", "--scenario",
                str(scenario_file), "--json", str(out), "--quiet"]
        assert run_cli(args) == 2 and not out.exists()
        err = capsys.readouterr().err.strip()
        assert err.count("\n") == 0 and "--scenario=" in err
    assert run_cli(["lab", "benchmark", "--train", str(tmp_path / "n0.csv"), "--validate", str(tmp_path / "n1.csv"),
                    "--length", "0.4", "--scenario", "no-such-robot", "--json", str(out), "--quiet"]) == 2
    assert "--scenario='no-such-robot'" in capsys.readouterr().err and not out.exists()


def test_without_a_scenario_the_dynamic_families_are_skipped(sessions):
    result = run_benchmark(sessions[:1], sessions[1], BenchmarkOptions(length=0.4, lag=0, families=(
        "dynamic_physics",)))
    assert "no --scenario" in result.skipped["dynamic_physics"] and not result.models


def test_settling_runs_the_first_rows_tensions_before_the_session(scenario_file):
    """A session of constant tensions after ``settle`` seconds is the later part of a longer one."""
    def constant(seconds):
        t = np.arange(int(seconds * 20) + 1) / 20.0
        u = np.tile([2.0, 1.0, 0.5], (t.size, 1))
        return Recording(path="c", time=t, inputs=u, names=("a", "b", "c"), units=("N",) * 3,
                         tip=np.zeros((t.size, 3)))

    settled = DynamicRobot.from_scenario(str(scenario_file), DynamicOptions(settle=1.0))
    plain = DynamicRobot.from_scenario(str(scenario_file))
    np.testing.assert_allclose(settled.tip({}, constant(2.0)), plain.tip({}, constant(3.0))[20:], rtol=0, atol=1e-9)
