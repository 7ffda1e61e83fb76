"""``[initial]`` beyond the shape kinds: ``from = "static"`` (the scenario's own static equilibrium,
loads at ``time``), ``kind = "poses"`` (positions and quaternions inline or from a CSV file) and
``from = "dataset"`` (a sample of a softrnn HDF5 dataset): round trips give the same shape, and bad
values are one-line errors naming the key, exit code 2 from ``softrnn simulate``."""

import dataclasses

import numpy as np
import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.io import read_dataset, write_trajectory
from softrnn.rod import RunConfig, Simulator
from softrnn.rod.so3 import matrix_to_quaternion, quaternion_to_matrix
from softrnn.scenarios.scenario import load_scenario
from softrnn.statics import static_start

from helpers import run_cli

L, N = 0.2, 21
EXACT = 1e-12
REST_TOL = 1e-3            # the static start's largest node move / L over the run (21 nodes)

BASE = """
name = "cantilever"
gravity = [0.0, 0.0, -9.81]
[rod]
length = 0.2
radius = 0.01
youngs_modulus = 1e7
density = 1000.0
n_nodes = 21
[reference]
kind = "straight"
direction = [1.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
[[boundary]]
kind = "clamp"
node = 0
[[loads]]
kind = "torque"
node = -1
frame = "body"
profile = { kind = "constant", value = [0.0, 0.0, 0.4] }
[[loads]]
kind = "force"
node = -1
profile = { kind = "window", start = 1.0, stop = 2.0, function = { kind = "constant", value = [0.0, 0.3, -1.0] } }
[damping]
translational = 30.0
rotational = 1e-3
[run]
dt = 0.05
n_samples = 11
nodes_of_interest = [-1]
"""


def _write(tmp_path, initial, name="case.toml", base=BASE):
    path = tmp_path / name
    path.write_text(base + "[initial]\n" + initial + "\n")
    return path


def _rows(a) -> str:
    return "[" + ", ".join("[" + ", ".join(repr(float(x)) for x in row) + "]" for row in a) + "]"


def load_scenario_text(text, folder):
    path = folder / "base.toml"
    path.write_text(text)
    return load_scenario(path)


@pytest.fixture(scope="module")
def bent(tmp_path_factory):
    """The cantilever's static start with the window's force on (time 1.5 s): bent and twisted."""
    return static_start(load_scenario_text(BASE, tmp_path_factory.mktemp("bent")).setup, 1.5)


def assert_same_shape(a, b, tol=EXACT):
    np.testing.assert_allclose(a.positions, b.positions, rtol=0, atol=tol)
    np.testing.assert_allclose(a.rotations, b.rotations, rtol=0, atol=tol)


# --------------------------------------------------------------------------- from = "static"
def test_from_static_is_the_static_start_and_rests(tmp_path, bent):
    sc = load_scenario(_write(tmp_path, 'from = "static"\ntime = 1.5'))
    plain = load_scenario_text(BASE, tmp_path)
    assert_same_shape(sc.setup.initial, bent, 0.0)
    assert_same_shape(sc.setup.reference, plain.setup.reference, 0.0)
    assert np.linalg.norm(bent.positions[-1] - [L, 0.0, 0.0]) > 0.05 * L
    # without the window's force (time 0): the twist of the follower torque and gravity only
    at_zero = load_scenario(_write(tmp_path, 'from = "static"', "zero.toml")).setup.initial
    assert np.linalg.norm(at_zero.positions[-1] - bent.positions[-1]) > 0.02 * L
    assert_same_shape(at_zero, static_start(plain.setup), 0.0)
    # the run starts at rest on it: no node moves more than REST_TOL of L (the window is off at t < 1 s)
    resting = dataclasses.replace(sc.setup, initial=at_zero)
    traj = Simulator(resting).run(RunConfig(dt=0.05, n_samples=11))
    assert np.linalg.norm(traj.positions - at_zero.positions, axis=2).max() < REST_TOL * L


def test_from_static_through_the_cli_writes_a_resting_run(tmp_path):
    path = _write(tmp_path, 'from = "static"')
    out = tmp_path / "out.h5"
    assert run_cli(["simulate", str(path), "-o", str(out), "--quiet"]) == 0
    data = read_dataset(out)
    assert np.linalg.norm(data.positions - data.positions[0], axis=2).max() < REST_TOL * L


# --------------------------------------------------------------------------- round trips
def test_inline_poses_round_trip(tmp_path, bent):
    q = matrix_to_quaternion(bent.rotations)
    sc = load_scenario(_write(tmp_path, f'kind = "poses"\npositions = {_rows(bent.positions)}\n'
                                        f'quaternions = {_rows(q)}'))
    assert_same_shape(sc.setup.initial, bent)


def test_csv_poses_round_trip(tmp_path, bent):
    q = matrix_to_quaternion(bent.rotations)
    rows = np.concatenate([bent.positions, q], axis=1)
    (tmp_path / "poses.csv").write_text("x, y, z, qw, qx, qy, qz\n"
                                        + "\n".join(", ".join(repr(float(x)) for x in r) for r in rows))
    sc = load_scenario(_write(tmp_path, 'kind = "poses"\nfile = "poses.csv"'))
    assert_same_shape(sc.setup.initial, bent)
    # the clamp holds the start's node 0
    assert sc.setup.boundary[0].motion is None


def test_dataset_sample_round_trip(tmp_path):
    """A saved run's sample: the stored (float32) positions exactly and the stored quaternions
    normalised, so the run's float64 state to float32 precision; the last sample by default."""
    sc = load_scenario(_write(tmp_path, 'from = "static"\ntime = 1.5'))
    traj = Simulator(sc.setup).run(RunConfig(dt=0.05, n_samples=4))
    write_trajectory(tmp_path / "run.h5", traj, dt=0.05, rod=sc.setup.rod)
    stored = read_dataset(tmp_path / "run.h5")
    for sample, line in ((1, "sample = 1"), (-1, ""), (-4, "sample = -4")):
        shape = load_scenario(_write(tmp_path, f'from = "dataset"\nfile = "run.h5"\n{line}', "b.toml")).setup.initial
        np.testing.assert_allclose(shape.positions, stored.positions[sample].astype(float), rtol=0, atol=EXACT)
        np.testing.assert_allclose(shape.rotations, quaternion_to_matrix(stored.quaternions[sample].astype(float)),
                                   rtol=0, atol=EXACT)
        np.testing.assert_allclose(shape.positions, traj.positions[sample], rtol=0, atol=1e-7)
        np.testing.assert_allclose(shape.rotations, traj.rotations()[sample], rtol=0, atol=1e-6)


# --------------------------------------------------------------------------- errors
def _partial_dataset(tmp_path):
    sc = load_scenario_text(BASE, tmp_path)
    traj = Simulator(sc.setup).run(RunConfig(dt=0.05, n_samples=3, save_nodes=(0, 10, 20)))
    write_trajectory(tmp_path / "some.h5", traj, dt=0.05, rod=sc.setup.rod)


def _full_dataset(tmp_path):
    sc = load_scenario_text(BASE, tmp_path)
    write_trajectory(tmp_path / "run.h5", Simulator(sc.setup).run(RunConfig(dt=0.05, n_samples=3)), dt=0.05,
                     rod=sc.setup.rod)


def _bad_csv(tmp_path, rows=N, norm=1.0):
    body = "\n".join(f"{0.01 * i}, 0, 0, {norm}, 0, 0, 0" for i in range(rows))
    (tmp_path / "poses.csv").write_text(body)


ERRORS = [
    ('kind = "poses"\nfile = "nowhere.csv"', None, ["initial.file = 'nowhere.csv'", "readable UTF-8 CSV"]),
    ('kind = "poses"\nfile = "poses.csv"', lambda p: _bad_csv(p, rows=20), ["initial.file", "20 rows", "21 rows"]),
    ('kind = "poses"\nfile = "poses.csv"', lambda p: _bad_csv(p, norm=1.1),
     ["initial.file", "norm 1.1 in row 0", "unit quaternions"]),
    ('kind = "poses"\npositions = [[0.0, 0.0, 0.0], [0.1, 0.0, 0.0]]\nquaternions = [[1.0, 0.0, 0.0, 0.0], '
     '[1.0, 0.0, 0.0, 0.0]]', None, ["initial.positions", "2 rows", "21 rows"]),
    ('kind = "poses"\npositions = [[0.0, 0.0, 0.0]]', None, ["missing key 'initial.quaternions'"]),
    ('kind = "poses"', None, ["initial", "not both and not neither"]),
    ('from = "dataset"\nfile = "missing.h5"', None, ["initial.file", "missing.h5"]),
    ('from = "dataset"\nfile = "run.h5"\nsample = 3', _full_dataset, ["initial.sample = 3", "[-3, 2]", "3 samples"]),
    ('from = "dataset"\nfile = "run.h5"\nsample = -4', _full_dataset, ["initial.sample = -4"]),
    ('from = "dataset"\nfile = "some.h5"', _partial_dataset, ["initial.file", "every node", "saved 3 of 21"]),
    ('from = "dataset"\nfile = "run.h5"\nsampel = 1', _full_dataset, ["unknown key 'initial.sampel'"]),
    ('from = "stat"', None, ["initial.from = 'stat'", "'static', 'dataset'"]),
    ('from = "static"\nkind = "straight"', None, ["initial", "not both"]),
    ('from = "static"\ntime = "soon"', None, ["initial.time = 'soon'", "number in s"]),
    ('kind = "pose"', None, ["initial.kind = 'pose'", "'poses'"]),
]


@pytest.mark.parametrize("initial, prepare, words", ERRORS)
def test_bad_initial_tables_are_one_line_exit_2(tmp_path, capsys, initial, prepare, words):
    if prepare is not None:
        prepare(tmp_path)
    path = _write(tmp_path, initial)
    out = tmp_path / "out.h5"
    assert run_cli(["simulate", str(path), "-o", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert err.startswith(f"softrnn: error: {path}: "), err
    for w in words:
        assert w in err, err
    assert not out.exists()


def test_an_unsupported_static_start_names_the_key_and_the_reason(tmp_path, capsys):
    pinned = BASE.replace('[[loads]]\nkind = "torque"', '[[boundary]]\nkind = "pin"\nnode = -1\n[[loads]]\n'
                                                        'kind = "torque"', 1)
    path = _write(tmp_path, 'from = "static"', base=pinned)
    with pytest.raises(SoftrnnInputError, match=r"initial.from = 'static': boundary=.*pin at node 20"):
        load_scenario(path)
    assert run_cli(["simulate", str(path), "-o", str(tmp_path / "out.h5"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "initial.from" in err and "give the initial shape explicitly" in err
