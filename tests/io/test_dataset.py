"""HDF5 dataset files: round trips, streaming, partial reads, precision and size, atomic writes,
sweeps, validation of bad files and ``softrnn show``."""

import copy
import io
import json
import os
from dataclasses import asdict

import h5py
import numpy as np
import pytest

import softrnn
import softrnn.io._h5files as h5files_mod
import softrnn.io.schema as dsmod
import softrnn.io.writer as writer_mod
from softrnn.io import (
    SCHEMA_VERSION,
    Dataset,
    DatasetError,
    DatasetWriter,
    describe,
    list_groups,
    merge_files,
    read_dataset,
    read_node,
    sweep_group_name,
    trajectories,
    write_dataset,
    write_trajectory,
)
from softrnn.rod import Clamp, NodalLoad, RodSpec, RunConfig, Setup, Simulator, Sinusoid, straight

from helpers import run_cli

FIELDS = ("positions", "quaternions", "forces", "torques")
SCENARIO = "[rod]\nlength = 0.5\n# a cantilever with a swinging tip force\n"


def _setup(n_nodes: int) -> Setup:
    rod = RodSpec(length=0.5, radius=0.01, youngs_modulus=2.5e6, density=1000.0, n_nodes=n_nodes)
    shape = straight(n_nodes, 0.5, direction=(1, 0, 0), normal=(0, 0, 1))
    return Setup(rod=rod, reference=shape, boundary=(Clamp(0),), gravity=(0, 0, -9.81),
                 loads=(NodalLoad(-1, force=Sinusoid((0, 0.05, 0.02), frequency=2.0)),))


@pytest.fixture(scope="module")
def small():
    """11 nodes x 301 samples at 1 ms."""
    setup = _setup(11)
    return setup, Simulator(setup).run(RunConfig(dt=1e-3, n_samples=301))


@pytest.fixture(scope="module")
def realistic(tmp_path_factory):
    """51 nodes x 3001 samples at 1 ms (the square case's rod), written to a file."""
    setup = _setup(51)
    traj = Simulator(setup).run(RunConfig(dt=1e-3, n_samples=3001))
    path = tmp_path_factory.mktemp("real") / "cantilever.h5"
    write_trajectory(path, traj, dt=1e-3, rod=setup.rod, scenario_text=SCENARIO, seed=7)
    return setup, traj, path


def _snapshot(traj):
    return {n: np.array(getattr(traj, n), copy=True) for n in ("time", "nodes") + FIELDS}


def _assert_same_arrays(a, b):
    for n in ("time", "nodes") + FIELDS:
        x, y = getattr(a, n), getattr(b, n)
        assert x.dtype == y.dtype, n
        np.testing.assert_array_equal(x, y, err_msg=n)


def _one_line_error(capsys, *words):
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert err.startswith("softrnn: error:")
    assert "Traceback" not in err
    for w in words:
        assert w in err, (w, err)
    return err


def _leftovers(folder):
    return sorted(p.name for p in folder.iterdir() if ".tmp" in p.name)


# ----------------------------------------------------------------------------------------- round trips
def test_round_trip_preserves_values_dtypes_attrs_and_inputs(tmp_path, small):
    setup, traj = small
    before = _snapshot(traj)
    attrs = {"operator": "lab A", "gains": [5.0, 1.0], "nested": {"k": 1}, "flag": True}
    attrs_before = copy.deepcopy(attrs)
    path = tmp_path / "t.h5"
    write_trajectory(path, traj, dt=1e-3, rod=setup.rod, scenario_text=SCENARIO, seed=12, attrs=attrs)
    ds = read_dataset(path)

    # inputs untouched
    for n, v in before.items():
        assert getattr(traj, n).dtype == v.dtype
        np.testing.assert_array_equal(getattr(traj, n), v)
    assert attrs == attrs_before

    # values and dtypes: time and nodes exact, the rest exactly the float32 rounding of the input
    assert ds.time.dtype == np.float64 and ds.nodes.dtype == np.int64
    np.testing.assert_array_equal(ds.time, traj.time)
    np.testing.assert_array_equal(ds.nodes, traj.nodes)
    for n in FIELDS:
        assert getattr(ds, n).dtype == np.float32
        np.testing.assert_array_equal(getattr(ds, n), getattr(traj, n).astype(np.float32))

    # attributes, exactly
    assert ds.attrs == {
        "schema_version": SCHEMA_VERSION, "softrnn_version": softrnn.__version__,
        "units": {"time": "s", "positions": "m", "quaternions": "1 (unit, scalar first w x y z, body to world)",
                  "forces": "N", "torques": "N m"},
        "rod": json.loads(json.dumps(asdict(setup.rod))), "scenario_text": SCENARIO, "seed": 12, "dt": 1e-3,
        "n_nodes_total": 11, **attrs}
    assert ds.rod_spec() == setup.rod
    assert ds.n_samples == 301 and ds.n_nodes == 11 and ds.dt == 1e-3


def test_rewriting_a_read_dataset_is_bit_exact(tmp_path, small):
    setup, traj = small
    write_trajectory(tmp_path / "a.h5", traj, dt=1e-3, rod=setup.rod, scenario_text=SCENARIO, attrs={"x": 1})
    a = read_dataset(tmp_path / "a.h5")
    before = _snapshot(a)
    attrs_before = copy.deepcopy(a.attrs)
    write_dataset(tmp_path / "b.h5", a)
    b = read_dataset(tmp_path / "b.h5")
    _assert_same_arrays(a, b)
    assert a.attrs == b.attrs == attrs_before
    for n, v in before.items():
        np.testing.assert_array_equal(getattr(a, n), v)


def test_streaming_writer_equals_one_shot(tmp_path, small, monkeypatch):
    setup, traj = small
    monkeypatch.setattr(writer_mod, "TIME_CHUNK", 64)  # exercise buffering across several HDF5 chunks
    write_trajectory(tmp_path / "one.h5", traj, dt=1e-3, rod=setup.rod)
    with DatasetWriter(tmp_path / "many.h5", nodes=traj.nodes, n_samples=301, dt=1e-3, rod=setup.rod) as w:
        for a, b in ((0, 1), (1, 64), (64, 64), (64, 165), (165, 172), (172, 301)):
            w.append(Dataset(time=traj.time[a:b], nodes=traj.nodes, positions=traj.positions[a:b],
                             quaternions=traj.quaternions[a:b], forces=traj.forces[a:b],
                             torques=traj.torques[a:b]))
    one, many = read_dataset(tmp_path / "one.h5"), read_dataset(tmp_path / "many.h5")
    _assert_same_arrays(one, many)
    assert one.attrs == many.attrs
    with h5py.File(tmp_path / "many.h5") as f:
        assert f["positions"].chunks == (64, 1, 3)

    # as the simulator's sink: chunks as the simulator produces them
    monkeypatch.setattr(writer_mod, "TIME_CHUNK", 4096)
    with DatasetWriter(tmp_path / "sink.h5", nodes=range(11), n_samples=301, dt=1e-3, rod=setup.rod) as w:
        stats = Simulator(setup).run(RunConfig(dt=1e-3, n_samples=301), sink=w.append)
    assert stats.n_samples == 301
    _assert_same_arrays(one, read_dataset(tmp_path / "sink.h5"))


def test_partial_reads_equal_the_full_read(tmp_path, small):
    setup, traj = small
    path = tmp_path / "t.h5"
    write_trajectory(path, traj, dt=1e-3, rod=setup.rod)
    full = read_dataset(path)
    one = read_node(path, 5)
    assert one.positions.shape == (301, 1, 3) and one.nodes.tolist() == [5]
    for n in FIELDS:
        np.testing.assert_array_equal(getattr(one, n)[:, 0], getattr(full, n)[:, 5])
    tip = read_node(path, -1)
    assert tip.nodes.tolist() == [10]
    part = read_dataset(path, nodes=[7, 2], start=10, stop=50)
    np.testing.assert_array_equal(part.time, full.time[10:50])
    for n in FIELDS:
        np.testing.assert_array_equal(getattr(part, n), getattr(full, n)[10:50][:, [7, 2]])
    tail = read_dataset(path, start=-5)
    np.testing.assert_array_equal(tail.positions, full.positions[-5:])
    with pytest.raises(DatasetError, match=r"node 11 is not stored \(stored nodes: 0\.\.10\)"):
        read_node(path, 11)


class _CountingFile(io.FileIO):
    """A file that counts the bytes HDF5 reads through it."""

    total = 0

    def readinto(self, b):
        n = super().readinto(b)
        _CountingFile.total += n or 0
        return n


def test_reading_one_node_reads_only_its_chunks(realistic, monkeypatch):
    _, traj, path = realistic
    monkeypatch.setattr(h5files_mod, "_h5open", lambda p, mode="r": h5py.File(_CountingFile(str(p), "r"), mode))
    _CountingFile.total = 0
    one = read_node(path, 25)
    node_bytes = _CountingFile.total
    _CountingFile.total = 0
    read_dataset(path)
    all_bytes = _CountingFile.total
    size = path.stat().st_size
    assert all_bytes > 0.9 * size
    # one node of 51: its chunks (~1/51 of the data) plus the file's metadata
    assert node_bytes < size / 51 + 64 * 1024, (node_bytes, size)
    assert node_bytes < 0.1 * size
    np.testing.assert_array_equal(one.positions[:, 0], traj.positions[:, 25].astype(np.float32))


# ----------------------------------------------------------------------------------------- size and precision
def test_size_at_most_4_bytes_per_value_on_a_simulated_trajectory(realistic):
    _, traj, path = realistic
    T, N = traj.positions.shape[:2]
    values = T + N + T * N * (3 + 4 + 3 + 3)
    per_value = path.stat().st_size / values
    assert per_value <= 4.0
    assert per_value < 2.0  # measured ~1.2 (docs/dataset-format.md#size)
    d = describe(path)
    assert d["stored_values"] == values and d["bytes_per_value"] == pytest.approx(per_value)
    with h5py.File(path) as f:
        for n in FIELDS:
            ds = f[n]
            assert ds.dtype == np.float32 and ds.chunks == (min(T, dsmod.TIME_CHUNK), 1, ds.shape[2])
            assert ds.compression == "gzip" and ds.shuffle and ds.fletcher32


def test_float32_precision_is_enough(tmp_path, realistic):
    _, traj, path = realistic
    ds = read_dataset(path)
    # realistic data: the rounding error is within half an ulp, 2^-24 |x| (plus 2^-150, half the
    # smallest float32 subnormal, for |x| < 1.2e-38 m: the clamped nodes' 1e-40 m wiggles)
    err = np.abs(ds.positions.astype(np.float64) - traj.positions)
    assert np.all(err <= 2.0 ** -24 * np.abs(traj.positions) + 2.0 ** -150)
    assert err.max() <= 2.0 ** -24 * np.abs(traj.positions).max()
    # the bound for a rod of up to 2 m: 2^-24 * 2 m = 1.2e-7 m; the paper's longest rod (1.336 m,
    # the ellipse) stays below 1e-4 mm
    rng = np.random.default_rng(0)
    x = rng.uniform(-2.0, 2.0, size=(500, 4, 3))
    q = rng.normal(size=(500, 4, 4))
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    fake = Dataset(time=np.arange(500) * 1e-4 + 16.0, nodes=np.arange(4), positions=x, quaternions=q,
                   forces=x * 10, torques=x)
    write_trajectory(tmp_path / "p.h5", fake, dt=1e-4)
    back = read_dataset(tmp_path / "p.h5")
    err = np.abs(back.positions.astype(np.float64) - x)
    assert err.max() <= 2.0 ** -24 * np.abs(x).max() <= 1.2e-7
    assert 2.0 ** -24 * 1.336 < 1e-7  # m, i.e. 1e-4 mm
    assert np.all(err <= 2.0 ** -24 * np.abs(x))
    norms = np.linalg.norm(back.quaternions.astype(np.float64), axis=-1)
    assert np.abs(norms - 1).max() < 1e-6
    np.testing.assert_array_equal(back.time, fake.time)  # float64: exact
    # why time is float64: at t = 16 s float32 spacing is 1.9e-6 s, 2 % of a 0.1 ms step
    assert abs(float(np.float32(16.0001)) - 16.0001) > 1e-7
    # positions beyond the 1-micrometre range of float32 are refused
    far = Dataset(time=[0.0, 1.0], nodes=[0], positions=np.full((2, 1, 3), 20.0),
                  quaternions=np.tile([1.0, 0, 0, 0], (2, 1, 1)), forces=np.zeros((2, 1, 3)),
                  torques=np.zeros((2, 1, 3)))
    with pytest.raises(DatasetError, match="reaches 20 m"):
        write_trajectory(tmp_path / "far.h5", far, dt=1.0)
    assert not (tmp_path / "far.h5").exists() and _leftovers(tmp_path) == []


# ----------------------------------------------------------------------------------------- atomic writes
def test_exception_inside_with_leaves_no_file(tmp_path, small):
    setup, traj = small
    path = tmp_path / "x.h5"
    with pytest.raises(RuntimeError, match="boom"):
        with DatasetWriter(path, nodes=traj.nodes, n_samples=301, dt=1e-3, rod=setup.rod) as w:
            w.append(traj)
            assert _leftovers(tmp_path)  # being written under a temporary name
            raise RuntimeError("boom")
    assert list(tmp_path.iterdir()) == []

    # an incomplete trajectory is not saved either
    with pytest.raises(DatasetError, match="only 10 of n_samples=301"):
        with DatasetWriter(path, nodes=traj.nodes, n_samples=301, dt=1e-3) as w:
            w.append(Dataset(time=traj.time[:10], nodes=traj.nodes, positions=traj.positions[:10],
                             quaternions=traj.quaternions[:10], forces=traj.forces[:10],
                             torques=traj.torques[:10]))
    assert list(tmp_path.iterdir()) == []

    # a failed rewrite leaves the previous file as it was
    write_trajectory(path, traj, dt=1e-3)
    old = path.read_bytes()
    bad = _snapshot(traj)
    bad["positions"][3, 4, 1] = np.nan
    with pytest.raises(DatasetError, match=r"positions has a non-finite value \(nan\) at sample 3, node 4"):
        write_trajectory(path, Dataset(**bad), dt=1e-3)
    assert path.read_bytes() == old and _leftovers(tmp_path) == []


def _chunk(traj, k=5, **change):
    arrays = {n: np.array(getattr(traj, n)[:k] if n != "nodes" else traj.nodes) for n in ("time", "nodes") + FIELDS}
    arrays.update(change)
    return type("Chunk", (), arrays)()


def _zeros_chunk(k, n):
    return Dataset(time=np.arange(k) * 1e-3, nodes=np.arange(n), positions=np.zeros((k, n, 3)),
                   quaternions=np.tile([1.0, 0, 0, 0], (k, n, 1)), forces=np.zeros((k, n, 3)),
                   torques=np.zeros((k, n, 3)))


@pytest.mark.parametrize("make, words", [
    (lambda t: _chunk(t, positions=np.zeros((5, 10, 3))), ["positions has shape (5, 10, 3)", "expected (5, 11, 3)"]),
    (lambda t: _chunk(t, time=np.array([0.0, 1, 1, 2, 3])), ["not strictly increasing at sample 2"]),
    (lambda t: _chunk(t, quaternions=2 * t.quaternions[:5]), ["norm 2", "unit quaternions"]),
    (lambda t: _chunk(t, forces=np.full((5, 11, 3), 1e39)), ["beyond the float32 range"]),
    (lambda t: _chunk(t, torques=np.full((5, 11, 3), np.inf)), ["torques has a non-finite value"]),
    (lambda t: _chunk(t, nodes=np.arange(1, 12)), ["nodes 1..11 differ", "nodes 0..10"]),
    (lambda t: _zeros_chunk(302, 11), ["302 samples received but n_samples=301"]),
    (lambda t: object(), ["chunk=", "missing time, positions"]),
])
def test_writer_rejects_bad_chunks_and_leaves_nothing(tmp_path, small, make, words):
    _, traj = small
    path = tmp_path / "w.h5"
    w = DatasetWriter(path, nodes=traj.nodes, n_samples=301, dt=1e-3)
    chunk = make(traj)
    with pytest.raises(softrnn.errors.SoftrnnInputError) as info:
        w.append(chunk)
    msg = str(info.value)
    assert "\n" not in msg
    for word in words:
        assert word in msg, (word, msg)
    assert list(tmp_path.iterdir()) == []  # the failed writer discarded its temporary file
    with pytest.raises(DatasetError, match="aborted"):
        w.append(traj)


@pytest.mark.parametrize("kwargs, words", [
    ({"nodes": [0, 1, 1]}, ["nodes=[0, 1, 1]", "unique"]),
    ({"nodes": []}, ["non-empty"]),
    ({"n_samples": 0}, ["n_samples=0"]),
    ({"dt": -1.0}, ["dt=-1.0", "positive"]),
    ({"seed": 1.5}, ["seed=1.5"]),
    ({"attrs": {"dt": 2}}, ["reserved"]),
    ({"attrs": {"x": object()}}, ["JSON-serialisable"]),
    ({"attrs": {"x": float("nan")}}, ["no NaN"]),
    ({"rod": "rubber"}, ["rod='str'", "RodSpec"]),
    ({"nodes": [0, 60], "rod": RodSpec(length=0.5, radius=0.01, youngs_modulus=1e6, density=1e3, n_nodes=51)},
     ["below rod.n_nodes=51"]),
    ({"group": "a/b"}, ["group='a/b'"]),
])
def test_writer_rejects_bad_arguments(tmp_path, kwargs, words):
    args = {"nodes": [0, 1], "n_samples": 3, "dt": 0.1, "rod": None} | kwargs
    with pytest.raises(softrnn.errors.SoftrnnInputError) as info:
        DatasetWriter(tmp_path / "a.h5", **args)
    for word in words:
        assert word in str(info.value), (word, str(info.value))
    assert list(tmp_path.iterdir()) == []


# ----------------------------------------------------------------------------------------- sweeps
def test_sweep_groups_and_merging_a_folder(tmp_path, small):
    setup, traj = small
    folder = tmp_path / "runs"
    for i in range(3):
        write_trajectory(folder / f"traj-{i:05d}.h5", traj, dt=1e-3, rod=setup.rod, seed=i, attrs={"i": i})
    merged = tmp_path / "sweep.h5"
    merge_files(folder, merged)
    assert list_groups(merged) == ["/traj-00000", "/traj-00001", "/traj-00002"]
    assert list_groups(folder / "traj-00000.h5") == ["/"]
    for i, g in enumerate(list_groups(merged)):
        a, b = read_dataset(folder / f"traj-{i:05d}.h5"), read_dataset(merged, group=g)
        _assert_same_arrays(a, b)
        assert a.attrs == b.attrs and b.attrs["seed"] == i
    np.testing.assert_array_equal(read_node(merged, 3, group="traj-00002").positions,
                                  read_node(folder / "traj-00002.h5", 3).positions)
    assert [(p.name, g) for p, g in trajectories(folder)][:2] == [("traj-00000.h5", "/"), ("traj-00001.h5", "/")]
    assert len(trajectories(merged)) == 3

    with pytest.raises(DatasetError, match=r"is a sweep of 3 trajectories; pass group="):
        read_dataset(merged)
    with pytest.raises(DatasetError, match="has no trajectory group 'traj-00009'"):
        read_dataset(merged, group="traj-00009")
    with pytest.raises(DatasetError, match="holds a single trajectory"):
        read_dataset(folder / "traj-00000.h5", group="traj-00000")

    # groups streamed straight into a sweep file (created, then extended)
    sweep = tmp_path / "direct.h5"
    for i in range(2):
        write_trajectory(sweep, traj, dt=1e-3, group=sweep_group_name(i), seed=i)
    assert list_groups(sweep) == ["/traj-00000", "/traj-00001"]
    _assert_same_arrays(read_dataset(sweep, group="/traj-00001"), read_dataset(folder / "traj-00001.h5"))
    with pytest.raises(DatasetError, match="group 'traj-00001' already exists"):
        write_trajectory(sweep, traj, dt=1e-3, group="traj-00001")
    with pytest.raises(DatasetError, match="holds a single trajectory, not a sweep"):
        write_trajectory(folder / "traj-00000.h5", traj, dt=1e-3, group="traj-00005")
    assert _leftovers(tmp_path) == [] and _leftovers(folder) == []


# ----------------------------------------------------------------------------------------- bad files
def _valid(tmp_path, small, name="v.h5"):
    setup, traj = small
    path = tmp_path / name
    write_trajectory(path, traj, dt=1e-3, rod=setup.rod)
    return path


def _edit(path, fn):
    with h5py.File(path, "a") as f:
        fn(f)


def _truncate(path):
    os.truncate(path, path.stat().st_size // 2)


def _corrupt_chunk(path):
    with h5py.File(path) as f:
        offset = f["positions"].id.get_chunk_info(3).byte_offset
    with open(path, "r+b") as fh:
        fh.seek(offset + 10)
        fh.write(b"\xff" * 16)


def _replace(name, data):
    def fn(f):
        del f[name]
        f[name] = data
    return fn


BAD_FILES = {
    "truncated": (_truncate, ["truncated or corrupt HDF5 file", "re-create"]),
    "truncated to 100 bytes": (lambda p: os.truncate(p, 100), ["truncated or corrupt HDF5 file"]),
    "corrupt chunk": (_corrupt_chunk, ["truncated or corrupt HDF5 file"]),
    "not HDF5": (lambda p: p.write_text("time,n0_x\n0,1\n"), ["not an HDF5 file"]),
    "empty": (lambda p: p.write_bytes(b""), ["not an HDF5 file"]),
    "foreign HDF5": (lambda p: (p.unlink(), h5py.File(p, "w").close()),
                     ["not a softrnn dataset (no 'softrnn_schema' attribute)"]),
    "newer schema": (lambda p: _edit(p, lambda f: f.attrs.__setitem__("softrnn_schema", 99)),
                     ["schema 99", "upgrade softrnn"]),
    "missing dataset": (lambda p: _edit(p, lambda f: f.__delitem__("torques")), ["dataset 'torques' is missing"]),
    "missing attribute": (lambda p: _edit(p, lambda f: f.attrs.__delitem__("dt")), ["attribute 'dt' is missing"]),
    "wrong shape": (lambda p: _edit(p, _replace("positions", np.zeros((300, 11, 3), np.float32))),
                    ["positions has shape (300, 11, 3) but time has T=301", "expected (301, 11, 3)"]),
    "wrong dtype": (lambda p: _edit(p, _replace("forces", np.zeros((301, 11, 3)))),
                    ["forces has dtype float64; expected float32"]),
    "non-finite": (lambda p: _edit(p, lambda f: f["positions"].__setitem__((5, 2, 0), np.nan)),
                   ["positions of / has a non-finite value at sample 5, column 2"]),
    "non-unit quaternion": (lambda p: _edit(p, lambda f: f["quaternions"].__setitem__((7, 1), [2, 0, 0, 0])),
                            ["quaternion", "sample 7, column 1", "not unit"]),
}


@pytest.mark.parametrize("name", BAD_FILES)
def test_bad_files_give_one_line_errors(tmp_path, small, capsys, name):
    damage, words = BAD_FILES[name]
    path = _valid(tmp_path, small)
    damage(path)
    with pytest.raises(DatasetError) as info:
        read_dataset(path)
    msg = str(info.value)
    assert "\n" not in msg and msg.startswith(f"{path}: ")
    for w in words:
        assert w in msg, (w, msg)
    assert run_cli(["show", str(path)]) == 2
    _one_line_error(capsys, str(path), words[0])


def test_missing_file_and_folder(tmp_path, capsys):
    assert run_cli(["show", str(tmp_path / "nope.h5")]) == 2
    _one_line_error(capsys, "nope.h5: no such file")
    assert run_cli(["show", str(tmp_path)]) == 2
    _one_line_error(capsys, "is a folder")


# ----------------------------------------------------------------------------------------- describe / show
def test_describe_and_show(tmp_path, small, capsys):
    setup, traj = small
    path = tmp_path / "t.h5"
    write_trajectory(path, traj, dt=1e-3, rod=setup.rod, scenario_text=SCENARIO, seed=3, attrs={"who": "me"})
    d = describe(path)
    assert (d["n_samples"], d["n_nodes"], d["kind"], d["group"]) == (301, 11, "trajectory", "/")
    assert d["duration_s"] == pytest.approx(0.3) and d["dt_uniform"]
    assert [r["node"] for r in d["node_ranges"]] == [0, 5, 10]
    tip = traj.positions[:, 10].astype(np.float32)
    assert d["node_ranges"][2]["position_max_m"] == pytest.approx(tip.max(axis=0).tolist())
    assert d["node_ranges"][2]["max_force_n"] > 0.04
    assert d["storage"]["positions"]["compression"] == "gzip"
    assert d["verified"] and not describe(path, verify=False)["verified"]

    assert run_cli(["show", str(path)]) == 0
    out = capsys.readouterr().out
    for words in ("samples: 301", "dt = 0.001 s", "nodes: 11 of 11 stored (0..10)", "rod: L = 0.5 m", "seed: 3",
                  "scenario: [rod] ... (3 lines)", "node 10: x [", 'attrs: who="me"', "gzip level 4"):
        assert words in out, (words, out)
    assert run_cli(["show", str(path), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["n_samples"] == 301
    assert run_cli(["show", str(path), "--quick"]) == 0
    assert "values not checked (--quick)" in capsys.readouterr().out

    sweep = tmp_path / "s.h5"
    merge_files([path, path], sweep)
    assert run_cli(["show", str(sweep), "--group", "traj-00001"]) == 0
    out = capsys.readouterr().out
    assert "sweep of 2 trajectories" in out and "showing /traj-00001" in out
    assert run_cli(["show", str(sweep), "--group", "traj-7"]) == 2
    _one_line_error(capsys, "has no trajectory group 'traj-7'")
