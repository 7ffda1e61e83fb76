"""The fluoroscopy image observation (NavigateConfig(observation="image"), softrnn.envs.fluoro): the
space and gymnasium's checks, the view of the default vessel, the lumen and the goal in the
background, the rod drawn where its nodes project, the vector env's images, the refusal of bad
settings."""

import dataclasses

import numpy as np
import pytest

gymnasium = pytest.importorskip("gymnasium")

from softrnn.envs import (  # noqa: E402 (after the skip)
    Fluoroscopy,
    Guidewire,
    MagneticNavigateConfig,
    MagneticNavigateEnv,
    MagneticRod,
    NavigateConfig,
    NavigateEnv,
    NavigateVectorEnv,
)
from softrnn.envs.fluoro import FIELD, GOAL, point_at  # noqa: E402
from softrnn.errors import SoftrnnInputError  # noqa: E402
from softrnn.magnetics import ManipulatorSpec  # noqa: E402

IMAGE = NavigateConfig(device=Guidewire(length=0.06, n_nodes=13, tip_segments=2, tip_angle=20.0), step_time=0.01,
                       checks_per_step=2, kept_nodes=3, max_steps=5, observation="image")
"""A short wire and short steps, seen as images."""


def test_the_image_environment_passes_gymnasiums_checks():
    from gymnasium.utils.env_checker import check_env

    env = NavigateEnv(IMAGE)
    check_env(env, skip_render_check=True)
    space = env.observation_space
    assert space.shape == (64, 64, 1) and space.dtype == np.uint8


def test_the_default_view_looks_down_on_the_vessel_with_the_entry_to_the_right():
    camera = NavigateEnv(IMAGE).episodes.camera
    np.testing.assert_allclose(camera.view, [0, 0, -1], atol=1e-12)
    np.testing.assert_allclose(camera.right, [1, 0, 0], atol=1e-12)
    np.testing.assert_allclose(camera.up, [0, 1, 0], atol=1e-12)
    rows_cols = camera.pixels(np.array([[0.0, 0.0, 0.0], [0.02, 0.01, 0.0]]))
    np.testing.assert_allclose(rows_cols[0], [31.5, 31.5])         # the fork at the centre
    assert rows_cols[1, 0] < 31.5 < rows_cols[1, 1]                   # +y up, +x right


def test_the_background_shows_the_lumen_darker_and_the_goal_bright():
    env = NavigateEnv(IMAGE)
    camera, paths = env.episodes.camera, env.episodes.paths
    bg = camera.backgrounds.astype(float)
    assert bg.shape == (2, 64, 64)
    assert bg[0, 0, 0] == pytest.approx(FIELD, abs=1)                # outside the lumen: the bare field
    for b, (line, arc) in enumerate(zip(paths.lines, paths.arc)):
        middle = np.round(camera.pixels(point_at(line, arc, 0.5 * (paths.fork[b] + arc[-1])))[0]).astype(int)
        assert bg[b, middle[0], middle[1]] < FIELD - 40                # in the branch: the contrast
        goal = np.round(camera.pixels(point_at(line, arc, paths.fork[b] + IMAGE.goal_depth))[0]).astype(int)
        assert bg[b, goal[0], goal[1]] == GOAL and bg[1 - b, goal[0], goal[1]] != GOAL


def test_the_image_shows_the_rod_where_its_nodes_project():
    env = NavigateEnv(dataclasses.replace(IMAGE, image=Fluoroscopy(field=0.4)))   # wide: the short wire's start
    image, _ = env.reset(seed=0)
    episodes = env.episodes
    bg = episodes.camera.backgrounds[episodes.target[0]].astype(float)
    pixels = np.round(episodes.camera.pixels(episodes.rods.state.positions[0])).astype(int)
    inside = np.all((pixels >= 0) & (pixels < 64), axis=1)
    assert inside.sum() >= 5
    i, j = pixels[inside].T
    assert np.all(image[i, j, 0] < 0.8 * bg[i, j])                    # radiopaque where the rod is
    far = np.ones((64, 64), dtype=bool)
    for di in range(-2, 3):
        for dj in range(-2, 3):
            far[np.clip(i + di, 0, 63), np.clip(j + dj, 0, 63)] = False
    assert np.array_equal(image[far, 0], episodes.camera.backgrounds[episodes.target[0]][far])   # nothing else


def test_the_vector_env_gives_the_single_envs_images():
    vector = NavigateVectorEnv(2, IMAGE)
    obs, _ = vector.reset(seed=4)
    singles = [NavigateEnv(IMAGE) for _ in range(2)]
    for b, env in enumerate(singles):
        assert np.array_equal(obs[b], env.reset(seed=4 + b)[0])
    actions = np.array([[1.0, 0.3], [0.5, -1.0]], dtype=np.float32)
    obs, *_ = vector.step(actions)
    assert obs.shape == (2, 64, 64, 1) and obs.dtype == np.uint8
    for b, env in enumerate(singles):
        assert np.array_equal(obs[b], env.step(actions[b])[0])


def test_the_magnetic_environment_gives_images_too():
    config = MagneticNavigateConfig(device=MagneticRod(manipulator=ManipulatorSpec(n_nodes=14)), step_time=0.02,
                                    checks_per_step=2, kept_nodes=3, observation="image",
                                    image=Fluoroscopy(size=32))
    env = MagneticNavigateEnv(config)
    obs, _ = env.reset(seed=0)
    assert obs.shape == (32, 32, 1) and env.observation_space.contains(obs)


@pytest.mark.parametrize("kwargs, name", [({"size": 4}, "image.size"), ({"size": 1000}, "image.size"),
                                          ({"field": -0.1}, "image.field"), ({"view": (0, 0, 0)}, "image.view")])
def test_bad_image_settings_are_refused_in_one_line(kwargs, name):
    with pytest.raises(SoftrnnInputError) as err:
        Fluoroscopy(**kwargs)
    assert str(err.value).startswith(name) and "\n" not in str(err.value)


def test_an_unknown_observation_is_refused():
    with pytest.raises(SoftrnnInputError, match="observation"):
        NavigateConfig(observation="pixels")
