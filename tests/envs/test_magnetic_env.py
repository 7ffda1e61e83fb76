"""The magnetic navigation environment (softrnn.envs.MagneticNavigateEnv): gymnasium's checks, the field
steering the tip toward its side, the refusal of an action out of bounds and of a field beyond the
coils' limit, seeded determinism, the physics as the simulator's with the magnetic load, the vector
environment as N single ones, and the scripted controller reaching the target."""

import dataclasses

import numpy as np
import pytest

gymnasium = pytest.importorskip("gymnasium")

from softrnn.envs import (  # noqa: E402 (after the skip)
    MAGNETIC_ENV_ID,
    Guidewire,
    MagneticNavigateConfig,
    MagneticNavigateEnv,
    MagneticNavigateVectorEnv,
    MagneticNavigator,
    MagneticRod,
    NavigateConfig,
    default_vessel,
)
from softrnn.errors import SoftrnnInputError  # noqa: E402
from softrnn.magnetics import CurrentSchedule, ManipulatorSpec  # noqa: E402
from softrnn.magnetics.manipulator import magnetic_load  # noqa: E402
from softrnn.rod import Clamp, Hub, Simulator  # noqa: E402
from softrnn.rod.integrators import Implicit  # noqa: E402

SMALL = MagneticNavigateConfig(device=MagneticRod(manipulator=ManipulatorSpec(n_nodes=14, magnet_stiffness_factor=3.0)),
                               step_time=0.02, checks_per_step=2, kept_nodes=3, max_steps=20)
"""A coarser rod and short steps: the same code paths at a fraction of the cost."""


def _field(x: float, y: float, z: float = 0.0) -> np.ndarray:
    """The action that holds the hub still and sets the field (fractions of max_field)."""
    return np.array([0.0, 0.0, x, y, z], dtype=np.float32)


def test_the_magnetic_environment_passes_gymnasiums_checks():
    from gymnasium.utils.env_checker import check_env

    env = MagneticNavigateEnv(SMALL)
    check_env(env, skip_render_check=True)
    assert env.action_space.shape == (5,)
    assert env.observation_space.shape == (9 + 2 + 3 * 3 + 3,)


def test_it_is_registered_with_gymnasium():
    env = gymnasium.make(MAGNETIC_ENV_ID, config=SMALL)
    obs, info = env.reset(seed=2)
    assert obs.shape == env.observation_space.shape and info["target"] in ("left", "right")


def _tip_after(action: np.ndarray, steps: int = 10) -> np.ndarray:
    env = MagneticNavigateEnv(SMALL)
    env.reset(seed=0)
    for _ in range(steps):
        obs, *_ = env.step(action)
    return obs[:3]


def test_a_field_pointing_right_steers_the_tip_right():
    """The magnets (magnetised along the rod) turn toward the field: across the trunk toward -y (the
    right branch's side) the tip moves toward -y, toward +y it moves toward +y."""
    still = _tip_after(_field(0.0, 0.0))
    right = _tip_after(_field(0.0, -1.0))
    left = _tip_after(_field(0.0, 1.0))
    assert right[1] < still[1] - 5e-4 and left[1] > still[1] + 5e-4
    assert right[1] == pytest.approx(-left[1], abs=2e-4)   # the vessel and the rod are symmetric in y


def test_the_field_is_in_the_observation_and_capped_at_its_bound():
    env = MagneticNavigateEnv(SMALL)
    env.reset(seed=0)
    obs, *_ = env.step(_field(1.0, 1.0, 0.0))
    np.testing.assert_allclose(obs[-3:], [2 ** -0.5, 2 ** -0.5, 0.0], rtol=1e-6)
    rods = env.episodes.rods
    assert np.linalg.norm(rods.field[0]) == pytest.approx(SMALL.max_field)
    limit = SMALL.device.manipulator.coils.current_limit
    assert np.max(np.abs(rods.currents)) <= limit


@pytest.mark.parametrize("action", [[0.0, 0.0, 1.5, 0.0, 0.0], [1.2, 0.0, 0.0, 0.0, 0.0],
                                    [0.0, 0.0, 0.0, np.nan, 0.0], [1.0, 0.0]])
def test_an_action_outside_the_bounds_is_refused_in_one_line(action):
    env = MagneticNavigateEnv(SMALL)
    env.reset(seed=0)
    with pytest.raises(SoftrnnInputError) as err:
        env.step(np.array(action))
    text = str(err.value)
    assert "\n" not in text and text.startswith("action") and "[-1, 1]" in text and "field" in text


def test_a_field_beyond_the_coils_limit_and_a_guidewire_are_refused():
    with pytest.raises(SoftrnnInputError, match="max_field"):
        MagneticNavigateConfig(max_field=0.05)
    with pytest.raises(SoftrnnInputError, match="MagneticRod"):
        MagneticNavigateConfig(device=Guidewire())
    with pytest.raises(SoftrnnInputError, match="MagneticNavigateConfig"):
        MagneticNavigateEnv(NavigateConfig())


def test_a_vessel_that_starts_the_magnets_outside_the_coils_workspace_is_refused():
    with pytest.raises(SoftrnnInputError) as err:
        MagneticNavigateEnv(SMALL, vessel=default_vessel())   # its entry is 0.2 m from the coils' centre
    text = str(err.value)
    assert text.startswith("vessel") and "workspace" in text and "\n" not in text


def _rollout(seed: int, steps: int = 4) -> np.ndarray:
    env = MagneticNavigateEnv(SMALL)
    obs, _ = env.reset(seed=seed)
    out = [obs]
    for k in range(steps):
        obs, reward, *_ = env.step(np.array([1.0, 0.0, 0.3, (-1) ** k, 0.0], dtype=np.float32))
        out += [obs, np.array([reward])]
    return np.concatenate(out)


def test_a_seed_gives_the_same_episode():
    assert np.array_equal(_rollout(5), _rollout(5))


def test_the_physics_is_the_simulators_with_the_magnetic_load():
    """The environment's rod follows ``Simulator.advance`` (implicit) of its setup with the
    manipulator's magnetic load of the same currents (off over the first step, then held) and the
    same hub motion."""
    env = MagneticNavigateEnv(SMALL)
    env.reset(seed=0)
    actions = [np.array([0.5, 0.0, 0.0, 0.0, 0.0], dtype=np.float32),
               np.array([0.5, 0.0, 0.2, -0.8, 0.1], dtype=np.float32)]
    for action in actions:
        env.step(action)
    rods = env.episodes.rods
    step = rods.substeps * rods.h
    schedule = CurrentSchedule(np.array([0.0, step - 0.5 * rods.h, step]),
                               np.stack([0 * rods.currents[0], 0 * rods.currents[0], rods.currents[0]]))
    load = magnetic_load(SMALL.device.manipulator, schedule)
    hub = Hub.commanded(rods.hubs[0].entry, rods.hubs[0].axis, rods.hubs[0].rotation0, travel=SMALL.travel)
    sim = Simulator(dataclasses.replace(rods.setups[0], boundary=(Clamp(0, motion=hub),), loads=(load,)))
    sim.start(rods.h, Implicit())
    for action in actions:
        hub.command(sim.state.time, insertion_rate=float(action[0]) * SMALL.max_insertion_speed, rotation_rate=0.0)
        sim.advance(rods.substeps, rods.h, Implicit())
    np.testing.assert_allclose(rods.state.positions[0], sim.state.positions, rtol=0, atol=1e-12)


def test_the_vector_env_equals_n_single_envs():
    n, steps = 2, 3
    vector = MagneticNavigateVectorEnv(n, SMALL)
    singles = [MagneticNavigateEnv(SMALL) for _ in range(n)]
    obs, _ = vector.reset(seed=3)
    for b, env in enumerate(singles):
        assert np.array_equal(obs[b], env.reset(seed=3 + b)[0])
    actions = np.array([[1.0, 0.0, 0.0, 1.0, 0.0], [0.5, 0.2, 0.0, -1.0, 0.3]], dtype=np.float32)
    for _ in range(steps):
        obs, reward, *_ = vector.step(actions)
        for b, env in enumerate(singles):
            one, r, *_ = env.step(actions[b])
            assert np.array_equal(obs[b], one) and reward[b] == r


def test_make_vec_builds_the_magnetic_vector_env():
    envs = gymnasium.make_vec(MAGNETIC_ENV_ID, num_envs=2, vectorization_mode="vector_entry_point", config=SMALL)
    obs, _ = envs.reset(seed=0)
    assert obs.shape == (2,) + envs.single_observation_space.shape and envs.single_action_space.shape == (5,)


@pytest.mark.parametrize("target", ["left", "right"])
def test_the_scripted_controller_steers_into_the_target_branch(target):
    env = MagneticNavigateEnv()
    pilot = MagneticNavigator(episodes=env.episodes)
    obs, info = env.reset(seed=0, options={"target": target})
    for _ in range(env.config.max_steps):
        obs, _, terminated, truncated, info = env.step(pilot(obs))
        if terminated or truncated:
            break
    assert info["success"] and info["branch"] == target


def test_the_benchmark_reports_the_magnetic_runs_and_the_image_cost():
    from softrnn.bench.envs import format_envs_table, run_envs_benchmark

    wire = NavigateConfig(device=Guidewire(length=0.06, n_nodes=13, tip_segments=2, tip_angle=20.0), step_time=0.01,
                          checks_per_step=2, kept_nodes=3, max_steps=3)
    result = run_envs_benchmark(span_s=0.0, config=wire, n_envs=2, magnetic=SMALL)
    single, vector = result["magnetic"]["single"], result["magnetic"]["vector"]
    assert single["envs"] == 1 and vector["envs"] == 2 and vector["vector_steps"] >= 3
    assert single["real_time_factor"] == pytest.approx(single["steps_per_s"] * SMALL.step_time)
    image = result["image"]
    assert image["size"] == 64 and image["render_s"] > 0
    assert image["share"] == pytest.approx(image["render_s"] / image["physics_s"])
    table = format_envs_table(result)
    assert "MagneticNavigateEnv" in table and "fluoroscopy image" in table


def test_pushing_without_a_field_ends_at_the_carina_not_in_a_branch():
    """The straight rod pushed without a field runs into the carina's crease, as near one branch as
    the other: no success for either target (the field is what steers)."""
    env = MagneticNavigateEnv()
    env.reset(seed=0, options={"target": "left"})
    for _ in range(25):
        _, _, terminated, _, info = env.step(np.array([1.0, 0.0, 0.0, 0.0, 0.0], dtype=np.float32))
    assert not terminated and not info["success"]
    assert abs(env.episodes.tip[0, 1]) < 1e-3 and env.episodes.tip[0, 0] > 0.0   # past the junction, on the plane
