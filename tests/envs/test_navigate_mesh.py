"""A vessel from a surface mesh in the navigation environments (softrnn.envs.MeshTrack): the track's
branches named by their ends, their forks, the straightened entry and its radius; the environment in a
meshed Y passes gymnasium's checks, the vector environment equals single ones step for step there, the
hub's travel is sized from the track; the shipped arch's three branches (slow); bad input in one line."""

import dataclasses

import numpy as np
import pytest

gymnasium = pytest.importorskip("gymnasium")

from softrnn.envs import (  # noqa: E402 (after the skip)
    Guidewire,
    MeshTrack,
    NavigateConfig,
    NavigateEnv,
    NavigateVectorEnv,
    Track,
    arch_config,
)
from softrnn.envs.rods import START_DEPTH  # noqa: E402
from softrnn.envs.track import Paths  # noqa: E402
from softrnn.errors import SoftrnnInputError  # noqa: E402
from softrnn.geometry._marching import tube_tree_surface  # noqa: E402
from softrnn.geometry.mesh import MeshVessel  # noqa: E402

RADIUS = 0.004
TRUNK = np.array([[-0.1, 0.0, 0.0], [0.0, 0.0, 0.0]])
LEFT = np.array([[0.0, 0.0, 0.0], [0.035, 0.02, 0.0]])
RIGHT = LEFT * [1.0, -1.0, 1.0]
SMALL = NavigateConfig(device=Guidewire(length=0.06, n_nodes=13, tip_segments=2, tip_angle=20.0), step_time=0.01,
                       checks_per_step=2, kept_nodes=3, max_steps=3, implicit_contact=True)
"""A short wire and short episodes (through the autoreset)."""


@pytest.fixture(scope="module")
def y_mesh() -> MeshVessel:
    """A meshed Y: an 8 mm trunk along +x to the origin, two branches at +-30 degrees."""
    vertices, faces = tube_tree_surface([(TRUNK, RADIUS), (LEFT, RADIUS), (RIGHT, RADIUS)], 0.001)
    return MeshVessel(vertices, faces, inlet=(-0.098, 0.0, 0.0))


@pytest.fixture(scope="module")
def y_track(y_mesh) -> MeshTrack:
    return MeshTrack(y_mesh, {"left": LEFT[-1], "right": RIGHT[-1]})


def test_a_meshed_y_is_a_track_with_its_branches_forks_and_entry(y_track):
    assert isinstance(y_track, Track) and y_track.branches == ("left", "right")
    left, right = (y_track.centreline(b) for b in y_track.branches)
    assert np.linalg.norm(left[-1] - LEFT[-1]) < 0.01 and np.linalg.norm(right[-1] - RIGHT[-1]) < 0.01
    start = left[0]
    axis = (left[1] - left[0]) / np.linalg.norm(left[1] - left[0])
    assert axis[0] > np.cos(0.01) and np.linalg.norm(start[1:]) < 0.0005   # the entry straight along the trunk
    assert np.all(np.linalg.norm(np.diff(left, axis=0), axis=1) > 0)             # no repeated point
    assert 0.95 * RADIUS < y_track.entry_radius <= RADIUS * 1.001
    paths = Paths(y_track)
    junction = np.linalg.norm(TRUNK[-1] - start)
    assert paths.fork[0] == pytest.approx(paths.fork[1], abs=0.002) and junction < paths.fork[0] < junction + 4 * RADIUS
    progress, branch = paths.standing(np.array([[0.02, 0.011, 0.0], [0.02, -0.011, 0.0], [-0.05, 0.0, 0.0]]),
                                      np.zeros(3, dtype=np.int64))
    assert branch.tolist() == [0, 1, -1] and progress[0] > paths.fork[0] > progress[1] > progress[2]


def test_the_environment_in_a_meshed_y_passes_gymnasiums_checks(y_track):
    from gymnasium.utils.env_checker import check_env

    env = NavigateEnv(SMALL, vessel=y_track)
    check_env(env, skip_render_check=True)
    obs, info = env.reset(seed=0, options={"target": "right"})
    for _ in range(2):
        obs, reward, terminated, truncated, info = env.step(np.array([1.0, 0.0], dtype=np.float32))
    assert info["progress"] > 0.0 and info["penetration"] < 0.1 * SMALL.device.radius and not info["perforated"]


def test_the_vector_env_in_a_meshed_y_equals_single_envs_step_for_step(y_track):
    n = 2
    vector = NavigateVectorEnv(n, SMALL, vessel=y_track)
    singles = [NavigateEnv(SMALL, vessel=y_track) for _ in range(n)]
    obs, _ = vector.reset(seed=3)
    for b, env in enumerate(singles):
        assert np.array_equal(obs[b], env.reset(seed=3 + b)[0])
    ended = np.zeros(n, dtype=bool)
    for k in range(5):
        actions = np.stack([np.cos(0.7 * k + np.arange(n)), np.sin(1.3 * k - np.arange(n))], axis=1).astype(np.float32)
        obs, reward, terminated, truncated, _ = vector.step(actions)
        for b, env in enumerate(singles):
            one, r = (env.reset()[0], 0.0) if ended[b] else env.step(actions[b])[:2]
            assert np.array_equal(obs[b], one) and reward[b] == r
        ended = terminated | truncated


def test_the_hubs_travel_is_sized_from_the_track(y_track):
    config = dataclasses.replace(SMALL, travel=None)
    env = NavigateEnv(config, vessel=y_track)
    longest = max(np.sum(np.linalg.norm(np.diff(y_track.centreline(b), axis=0), axis=1)) for b in y_track.branches)
    assert env.episodes.rods.travel == pytest.approx(longest - START_DEPTH - config.device.length, rel=1e-12)
    assert 0.05 < env.episodes.rods.travel < 0.1
    with pytest.raises(SoftrnnInputError, match="travel"):
        NavigateEnv(dataclasses.replace(config, device=Guidewire(length=0.2)), vessel=y_track)


def test_bad_meshed_tracks_are_refused_in_one_line(y_mesh):
    for build, words in ((lambda: MeshTrack("aorta.stl"), "vessel"),
                         (lambda: MeshTrack(y_mesh, {"a": LEFT[-1], "b": LEFT[-1] + 0.001}), "ends['b']"),
                         (lambda: MeshTrack(y_mesh, {}), "ends"),
                         (lambda: arch_config(colour="red"), "arch_config")):
        with pytest.raises(SoftrnnInputError) as err:
            build()
        assert "\n" not in str(err.value) and words in str(err.value), str(err.value)


@pytest.mark.slow
def test_the_shipped_arch_has_its_three_branches_beyond_its_descending_aorta():
    from softrnn.envs import arch_track
    from softrnn.geometry.mesh import ARCH_BRANCHES

    track = arch_track()
    assert track.branches == ARCH_BRANCHES
    paths = Paths(track)
    assert np.all(paths.fork > 0.2) and paths.fork[0] > paths.fork[1] > paths.fork[2]   # subclavian first
    env = NavigateEnv(arch_config(), vessel=track)
    assert env.episodes.rods.travel > 0.12                 # past the descending aorta's 0.2 m
    obs, info = env.reset(seed=0)
    assert info["target"] in ARCH_BRANCHES and np.all(np.isfinite(obs))
