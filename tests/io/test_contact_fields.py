"""Contact loads in dataset files (docs/dataset-format.md, "Contact"): the optional contact_forces /
contact_torques datasets and the ``contact`` attribute round-trip through the streamed writer,
write_trajectory, write_dataset, sweeps and merge_files; files without contact stay exactly as
before (schema 2, same datasets and attributes); broken contact fields are one-line errors."""

import json
import math

import h5py
import numpy as np
import pytest

from softrnn.io import (
    DatasetError,
    DatasetWriter,
    describe,
    list_groups,
    merge_files,
    read_dataset,
    sweep_group_name,
    write_dataset,
    write_trajectory,
)
from softrnn.io.schema import CONTACT_SCHEMA, SCHEMA_VERSION, UNITS, contact_from_record, contact_record
from softrnn.rod import (
    Clamp,
    Contact,
    Cylinder,
    Plane,
    RodSpec,
    RunConfig,
    Setup,
    Simulator,
    Sphere,
    Vessel,
    straight,
)

from helpers import run_cli

N = 11
RADIUS = 0.005
TUBE = np.array([[0.3, 0.0, 0.0], [0.45, 0.02, 0.01], [0.6, 0.0, 0.0]])  # beyond the rod's tip


def _setup(contact=True):
    """A cantilever along +x sagging in gravity onto a plane just below it (contact on most nodes),
    with a sphere, a cylinder and a vessel out of reach."""
    rod = RodSpec(length=0.2, radius=RADIUS, youngs_modulus=1e5, density=1000.0, n_nodes=N)
    shape = straight(N, 0.2, direction=(1.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0))
    obstacles = (Plane((0.0, 0.0, -RADIUS - 0.002), (0.0, 0.0, 1.0), friction=0.3),
                 Sphere((0.1, 0.5, 0.0), 0.05), Cylinder((0.0, -0.5, 0.0), (1.0, 0.0, 0.0), 0.02),
                 Vessel(TUBE, [0.02, 0.03, 0.02]))
    return Setup(rod=rod, reference=shape, boundary=(Clamp(0),), gravity=(0.0, 0.0, -9.81),
                 contact=Contact(obstacles=obstacles, friction=0.5) if contact else None)


CONFIG = RunConfig(dt=2e-3, n_samples=60)


@pytest.fixture(scope="module")
def run():
    setup = _setup()
    return setup, Simulator(setup).run(CONFIG)


def _streamed(path, setup, config=CONFIG, **kw):
    nodes = np.arange(N) if config.save_nodes is None else np.asarray(config.save_nodes)
    with DatasetWriter(path, nodes=nodes, n_samples=config.n_samples, dt=config.dt, rod=setup.rod,
                       contact=setup.contact, **kw) as w:
        Simulator(setup).run(config, sink=w.append)


def test_streamed_contact_loads_round_trip(run, tmp_path):
    setup, traj = run
    assert np.abs(traj.contact_forces).max() > 0  # the rod touches the plane
    _streamed(tmp_path / "c.h5", setup)
    ds = read_dataset(tmp_path / "c.h5")
    assert ds.has_contact and ds.attrs["schema_version"] == CONTACT_SCHEMA == 3
    for name in ("contact_forces", "contact_torques"):
        assert getattr(ds, name).dtype == np.float32 and getattr(ds, name).shape == (CONFIG.n_samples, N, 3)
        np.testing.assert_array_equal(getattr(ds, name), getattr(traj, name).astype(np.float32))
    np.testing.assert_array_equal(ds.forces, traj.forces.astype(np.float32))  # contact not in forces
    assert ds.attrs["units"] == dict(UNITS, contact_forces="N", contact_torques="N m")
    with h5py.File(tmp_path / "c.h5") as f:
        for name, unit in (("contact_forces", "N"), ("contact_torques", "N m")):
            assert f[name].attrs["units"] == unit and f[name].attrs["frame"] == "world"
            assert f[name].chunks == (CONFIG.n_samples, 1, 3) and f[name].compression == "gzip"
    assert ds.contact == contact_record(setup.contact)


def test_the_contact_attribute_describes_every_obstacle(run, tmp_path):
    setup, traj = run
    write_trajectory(tmp_path / "w.h5", traj, dt=CONFIG.dt, rod=setup.rod, contact=setup.contact)
    with h5py.File(tmp_path / "w.h5") as f:
        record = json.loads(f.attrs["contact"])
    assert [o["kind"] for o in record["obstacles"]] == ["plane", "sphere", "cylinder", "vessel"]
    plane, sphere, cylinder, vessel = record["obstacles"]
    assert plane == {"kind": "plane", "point": [0.0, 0.0, -RADIUS - 0.002], "normal": [0.0, 0.0, 1.0],
                     "friction": 0.3}
    assert sphere == {"kind": "sphere", "center": [0.1, 0.5, 0.0], "radius": 0.05, "friction": 0.5}
    assert cylinder["axis"] == [1.0, 0.0, 0.0] and cylinder["radius"] == 0.02
    assert vessel["centreline"] == TUBE.tolist() and vessel["radius"] == [0.02, 0.03, 0.02]
    assert record["friction"] == 0.5 and record["slip_velocity"] == setup.contact.slip_velocity
    back = contact_from_record(record)
    assert isinstance(back.obstacles[3], Vessel)
    np.testing.assert_array_equal(back.obstacles[3].points, setup.contact.obstacles[3].points)
    assert contact_record(back) == record
    read = read_dataset(tmp_path / "w.h5")
    np.testing.assert_array_equal(read.contact_forces, traj.contact_forces.astype(np.float32))


def test_a_trajectory_alone_stores_its_loads_without_obstacles(run, tmp_path):
    """write_trajectory takes whatever the Trajectory carries; without contact= the obstacles are null."""
    _, traj = run
    write_trajectory(tmp_path / "t.h5", traj, dt=CONFIG.dt)
    ds = read_dataset(tmp_path / "t.h5")
    assert ds.has_contact and ds.contact is None and ds.attrs["contact"] is None
    np.testing.assert_array_equal(ds.contact_torques, traj.contact_torques.astype(np.float32))


def _layout(path):
    with h5py.File(path) as f:
        attrs = {k: (v if not isinstance(v, bytes) else v.decode()) for k, v in f.attrs.items()}
        return sorted(f.keys()), {k: attrs[k] for k in sorted(attrs) if k != "softrnn_version"}, \
            {k: dict(f[k].attrs) for k in f.keys()}


def test_files_without_contact_are_unchanged(tmp_path):
    """No contact: schema 2, the same datasets and attributes as a file written before contact existed."""
    setup = _setup(contact=False)
    traj = Simulator(setup).run(CONFIG)
    assert traj.contact_forces is None
    _streamed(tmp_path / "plain.h5", setup)
    names, attrs, ds_attrs = _layout(tmp_path / "plain.h5")
    assert names == ["forces", "nodes", "positions", "quaternions", "time", "torques"]
    assert sorted(attrs) == ["attrs", "dt", "kind", "n_nodes_total", "rod", "scenario", "softrnn_schema", "units"]
    assert attrs["softrnn_schema"] == SCHEMA_VERSION == 2 and json.loads(attrs["units"]) == UNITS
    ds = read_dataset(tmp_path / "plain.h5")
    assert ds.contact_forces is None and ds.contact_torques is None and not ds.has_contact
    assert ds.contact is None and "contact" not in ds.attrs
    write_trajectory(tmp_path / "whole.h5", traj, dt=CONFIG.dt, rod=setup.rod)
    assert _layout(tmp_path / "whole.h5") == (names, attrs, ds_attrs)


def test_copies_sweeps_and_merges_keep_the_contact_fields(run, tmp_path):
    setup, traj = run
    write_trajectory(tmp_path / "a.h5", traj, dt=CONFIG.dt, rod=setup.rod, contact=setup.contact)
    a = read_dataset(tmp_path / "a.h5")
    write_dataset(tmp_path / "copy.h5", a)
    copy = read_dataset(tmp_path / "copy.h5")
    np.testing.assert_array_equal(copy.contact_forces, a.contact_forces)
    assert copy.contact == a.contact and copy.attrs == a.attrs
    plain = _setup(contact=False)
    write_trajectory(tmp_path / "b.h5", Simulator(plain).run(CONFIG), dt=CONFIG.dt, rod=plain.rod)
    merge_files([tmp_path / "b.h5", tmp_path / "a.h5"], tmp_path / "sweep.h5")
    with h5py.File(tmp_path / "sweep.h5") as f:
        assert f.attrs["softrnn_schema"] == CONTACT_SCHEMA  # the newest of its groups
    first, second = (read_dataset(tmp_path / "sweep.h5", group=g) for g in list_groups(tmp_path / "sweep.h5"))
    assert first.contact_forces is None and second.contact == a.contact
    np.testing.assert_array_equal(second.contact_torques, a.contact_torques)
    # groups streamed into one sweep file: the root's schema rises with the first contact group
    write_trajectory(tmp_path / "s.h5", read_dataset(tmp_path / "b.h5"), dt=CONFIG.dt, group=sweep_group_name(0))
    with h5py.File(tmp_path / "s.h5") as f:
        assert f.attrs["softrnn_schema"] == SCHEMA_VERSION
    write_trajectory(tmp_path / "s.h5", a, dt=CONFIG.dt, group=sweep_group_name(1))
    with h5py.File(tmp_path / "s.h5") as f:
        assert f.attrs["softrnn_schema"] == CONTACT_SCHEMA and f["traj-00000"].attrs["softrnn_schema"] == 2
    assert read_dataset(tmp_path / "s.h5", group="traj-00001").contact == a.contact


def test_reading_some_nodes_and_samples(run, tmp_path):
    setup, traj = run
    write_trajectory(tmp_path / "a.h5", traj, dt=CONFIG.dt, contact=setup.contact)
    part = read_dataset(tmp_path / "a.h5", nodes=[-1, 3], start=10, stop=20)
    np.testing.assert_array_equal(part.contact_forces, traj.contact_forces[10:20][:, [N - 1, 3]].astype(np.float32))
    assert part.contact_torques.shape == (10, 2, 3)


def test_describe_and_show_mention_the_contact(run, tmp_path, capsys):
    setup, traj = run
    write_trajectory(tmp_path / "a.h5", traj, dt=CONFIG.dt, rod=setup.rod, contact=setup.contact)
    s = describe(tmp_path / "a.h5")
    assert s["contact"]["obstacles"] == ["plane", "sphere", "cylinder", "vessel"] and s["contact"]["recorded"]
    top = float(np.linalg.norm(traj.contact_forces.astype(np.float32).astype(float), axis=-1).max())
    assert math.isclose(s["contact"]["max_force_n"], top, rel_tol=1e-6)
    assert "contact_forces" in s["storage"] and "max_contact_force_n" in s["node_ranges"][-1]
    quick = describe(tmp_path / "a.h5", verify=False)["contact"]
    assert quick["fields"] == ["contact_forces", "contact_torques"]
    assert quick["max_force_n"] is None and quick["max_torque_nm"] is None   # --quick reads no contact values
    assert run_cli(["show", str(tmp_path / "a.h5")]) == 0
    out = capsys.readouterr().out
    assert "contact" in out and "plane" in out


def test_describe_without_contact(tmp_path):
    plain = _setup(contact=False)
    write_trajectory(tmp_path / "b.h5", Simulator(plain).run(CONFIG), dt=CONFIG.dt, rod=plain.rod)
    s = describe(tmp_path / "b.h5")
    assert s["contact"] is None and "contact_forces" not in s["storage"]
    assert "max_contact_force_n" not in s["node_ranges"][0]


def test_the_simulate_path_writes_the_contact_fields(run, tmp_path):
    """``softrnn simulate``'s library side (scenarios.summary.simulate_summary) with a Setup built in
    Python: the file gets the trajectory's contact loads."""
    from softrnn.scenarios.summary import simulate_summary

    setup, traj = run
    simulate_summary(name="c", title="c", setup=setup, config=CONFIG, node=-1, out_path=tmp_path / "s.h5")
    ds = read_dataset(tmp_path / "s.h5")
    np.testing.assert_array_equal(ds.contact_forces, traj.contact_forces.astype(np.float32))
    assert ds.contact is None or ds.contact == contact_record(setup.contact)


def test_bad_contact_data_is_a_one_line_error(run, tmp_path):
    setup, traj = run
    plain = _setup(contact=False)
    # obstacles given but the chunks have no contact loads
    with pytest.raises(DatasetError, match="no contact_forces"):
        with DatasetWriter(tmp_path / "x.h5", nodes=N, n_samples=CONFIG.n_samples, dt=CONFIG.dt,
                           contact=setup.contact) as w:
            Simulator(plain).run(CONFIG, sink=w.append)
    assert not (tmp_path / "x.h5").exists() and list(tmp_path.iterdir()) == []
    with pytest.raises(DatasetError, match=r"contact_torques is missing"):
        write_trajectory(tmp_path / "y.h5", _Chunk(traj, contact_torques=None), dt=CONFIG.dt)
    with pytest.raises(DatasetError, match=r"expected \(60, 11, 3\)"):
        write_trajectory(tmp_path / "y.h5", _Chunk(traj, contact_forces=traj.contact_forces[:, :3]), dt=CONFIG.dt)
    bad = traj.contact_forces.copy()
    bad[5, 2, 1] = np.nan
    with pytest.raises(DatasetError, match="contact_forces has a non-finite value"):
        write_trajectory(tmp_path / "y.h5", _Chunk(traj, contact_forces=bad), dt=CONFIG.dt)
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(Exception, match="contact"):
        write_trajectory(tmp_path / "y.h5", traj, dt=CONFIG.dt, contact={"obstacles": [{"kind": "cone"}]})


def _Chunk(traj, **changes):
    from types import SimpleNamespace

    fields = {k: getattr(traj, k) for k in ("time", "nodes", "positions", "quaternions", "forces", "torques",
                                            "contact_forces", "contact_torques")}
    return SimpleNamespace(**{**fields, **changes})


@pytest.mark.parametrize("damage", ["drop torques", "drop attribute", "bad record", "wrong shape"])
def test_damaged_contact_fields_are_refused(run, tmp_path, damage):
    setup, traj = run
    path = tmp_path / "a.h5"
    write_trajectory(path, traj, dt=CONFIG.dt, contact=setup.contact)
    with h5py.File(path, "a") as f:
        if damage == "drop torques":
            del f["contact_torques"]
        elif damage == "drop attribute":
            del f.attrs["contact"]
        elif damage == "bad record":
            f.attrs["contact"] = json.dumps({"obstacles": [{"kind": "sphere", "center": [0, 0, 0], "radius": -1}]})
        else:
            del f["contact_forces"]
            f.create_dataset("contact_forces", data=np.zeros((CONFIG.n_samples, 2, 3), np.float32))
    with pytest.raises(DatasetError) as err:
        read_dataset(path)
    assert "\n" not in str(err.value) and str(path) in str(err.value)
