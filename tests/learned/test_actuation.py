"""Actuation inputs (issue 15): named (T, m) signals beside the nodal wrenches in the data sets, the
CSV importer's ``act_<name>[<unit>]`` columns, and learned models driven by them."""

import json

import h5py
import numpy as np
import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.io import (
    Dataset,
    DatasetError,
    DatasetWriter,
    describe,
    export_csv,
    import_csv,
    merge_files,
    read_dataset,
    write_dataset,
    write_trajectory,
)
from softrnn.io.schema import SCHEMA_VERSION

from helpers import run_cli

UNITS = {"tendon_1": "N", "p_chamber_2": "kPa"}


def _dataset(T=60, nodes=(0, 1, 2, 3), m=2, seed=0) -> Dataset:
    """A small trajectory whose nodes follow the actuation (so models can learn from it)."""
    rng = np.random.default_rng(seed)
    t = np.arange(T) * 0.01
    act = np.stack([np.sin(2 * np.pi * (0.7 + 0.3 * j) * t + j) for j in range(m)], axis=1)     # (T, m)
    N = len(nodes)
    pos = np.zeros((T, N, 3))
    pos[..., 0] = 0.1 * np.arange(N)
    pos[..., 1] = 0.01 * np.arange(N) * act[:, :1] + 1e-4 * rng.normal(size=(T, N))
    q = np.zeros((T, N, 4))
    q[..., 0] = 1.0
    units = dict(list({"tendon_1": "N", "p_chamber_2": "kPa", "coil_3": "A"}.items())[:m])
    return Dataset(time=t, nodes=list(nodes), positions=pos, quaternions=q, forces=np.zeros((T, N, 3)),
                   torques=np.zeros((T, N, 3)), attrs={"dt": 0.01}, actuation=act, actuation_units=units)


# ------------------------------------------------------------------------------------------ format
def test_actuation_round_trip_through_writer_and_reader(tmp_path):
    ds = _dataset()
    path = tmp_path / "a.h5"
    write_trajectory(path, ds, dt=0.01)
    back = read_dataset(path)
    assert back.actuation_units == UNITS and back.actuation_names == ("tendon_1", "p_chamber_2")
    assert back.actuation.dtype == np.float32 and back.actuation.shape == (60, 2)
    np.testing.assert_array_equal(back.actuation, ds.actuation)
    assert back.attrs["schema_version"] == SCHEMA_VERSION == 2 and "actuation_units" not in back.attrs
    with h5py.File(path) as f:                    # the documented layout
        assert f["actuation"].shape == (60, 2) and f["actuation"].dtype == np.float32
        assert json.loads(f["actuation"].attrs["names"]) == ["tendon_1", "p_chamber_2"]
        assert json.loads(f["actuation"].attrs["units"]) == ["N", "kPa"]
    part = read_dataset(path, nodes=[3], start=10, stop=20)  # a node subset still reads every channel
    np.testing.assert_array_equal(part.actuation, ds.actuation[10:20].astype(np.float32))
    write_dataset(tmp_path / "copy.h5", back)                # copies and sweeps keep it
    merge_files([path, tmp_path / "copy.h5"], tmp_path / "sweep.h5")
    np.testing.assert_array_equal(read_dataset(tmp_path / "sweep.h5", group="traj-00001").actuation, back.actuation)


def test_channels_that_share_a_unit_read_back(tmp_path):
    """Three tendons, all in N (the shipped tendon arms): units repeat, names do not."""
    ds = _dataset(m=3)
    ds = Dataset(time=ds.time, nodes=ds.nodes, positions=ds.positions, quaternions=ds.quaternions, forces=ds.forces,
                 torques=ds.torques, attrs=ds.attrs, actuation=ds.actuation,
                 actuation_units={"tendon_a": "N", "tendon_b": "N", "tendon_c": "N"})
    write_trajectory(tmp_path / "t.h5", ds, dt=0.01)
    back = read_dataset(tmp_path / "t.h5")
    assert back.actuation_units == {"tendon_a": "N", "tendon_b": "N", "tendon_c": "N"}
    np.testing.assert_array_equal(back.actuation, ds.actuation)


def test_streamed_writer_takes_actuation_per_chunk_and_checks_it(tmp_path):
    ds = _dataset(T=20)
    with DatasetWriter(tmp_path / "s.h5", nodes=ds.nodes, n_samples=20, dt=0.01, actuation_units=UNITS) as w:
        for a in range(0, 20, 7):
            chunk = Dataset(time=ds.time[a:a + 7], nodes=ds.nodes, positions=ds.positions[a:a + 7],
                            quaternions=ds.quaternions[a:a + 7], forces=ds.forces[a:a + 7],
                            torques=ds.torques[a:a + 7])
            w.append(chunk, actuation=ds.actuation[a:a + 7])
    np.testing.assert_array_equal(read_dataset(tmp_path / "s.h5").actuation, ds.actuation)
    plain = Dataset(time=ds.time, nodes=ds.nodes, positions=ds.positions, quaternions=ds.quaternions,
                    forces=ds.forces, torques=ds.torques)
    with pytest.raises(DatasetError, match="no actuation values but the writer has 2 channels"):
        write_trajectory(tmp_path / "x.h5", plain, dt=0.01, actuation_units=UNITS)
    bad = ds.actuation.copy()
    bad[5, 1] = np.nan
    with pytest.raises(DatasetError, match="non-finite value .* sample 5, channel p_chamber_2"):
        write_trajectory(tmp_path / "x.h5", plain, dt=0.01, actuation_units=UNITS, actuation=bad)
    for units, word in (({"Tendon": "N"}, "'Tendon' is not one"), ({"tendon_1": "newton"}, "a known unit")):
        with pytest.raises(SoftrnnInputError, match=word):
            write_trajectory(tmp_path / "x.h5", plain, dt=0.01, actuation_units=units, actuation=ds.actuation[:, :1])
    assert not list(tmp_path.glob("x.h5*"))       # nothing left behind


def test_old_schema_file_reads_with_no_actuation(tmp_path):
    ds = _dataset()
    plain = Dataset(time=ds.time, nodes=ds.nodes, positions=ds.positions, quaternions=ds.quaternions,
                    forces=ds.forces, torques=ds.torques)
    path = tmp_path / "old.h5"
    write_trajectory(path, plain, dt=0.01)
    with h5py.File(path, "a") as f:               # exactly what softrnn wrote before schema 2
        assert "actuation" not in f
        f.attrs["softrnn_schema"] = 1
    old = read_dataset(path)
    assert old.attrs["schema_version"] == 1
    assert old.actuation.shape == (60, 0) and old.actuation_units == {} and old.n_actuation == 0
    assert describe(path)["actuation"] == []


def test_show_lists_the_channels(tmp_path, capsys):
    path = tmp_path / "a.h5"
    write_trajectory(path, _dataset(), dt=0.01)
    assert run_cli(["show", str(path)]) == 0
    out = capsys.readouterr().out
    assert "actuation: 2 channels: tendon_1 [N]" in out and "p_chamber_2 [kPa]" in out
    assert [c["name"] for c in describe(path)["actuation"]] == ["tendon_1", "p_chamber_2"]


# ------------------------------------------------------------------------------------------ CSV
TIP_CSV = """# the tip marker only, no orientations
time,n10_x,n10_y,n10_z,act_tendon_1[N],act_P_Chamber_2[kPa]
0,0.5,0,0,0,100
0.01,0.5,0.001,0,0.5,101
0.02,0.5,0.002,0,1.0,102
"""


def test_csv_with_actuation_columns_and_one_tip_marker(tmp_path, capsys):
    csv = tmp_path / "lab.csv"
    csv.write_text(TIP_CSV)
    out = tmp_path / "lab.h5"
    assert run_cli(["import-csv", str(csv), "-o", str(out)]) == 0
    assert "actuation tendon_1 [N], p_chamber_2 [kPa]" in capsys.readouterr().out
    ds = read_dataset(out)
    assert ds.nodes.tolist() == [10] and ds.attrs["n_nodes_total"] == 11 and not ds.has_orientations
    assert ds.actuation_units == {"tendon_1": "N", "p_chamber_2": "kPa"}
    np.testing.assert_array_equal(ds.actuation, np.array([[0, 100], [0.5, 101], [1.0, 102]], np.float32))
    export_csv(ds, tmp_path / "again.csv")                 # exported and re-imported exactly
    assert "act_tendon_1[N],act_p_chamber_2[kPa]" in (tmp_path / "again.csv").read_text().splitlines()[0]
    again = import_csv(tmp_path / "again.csv", tmp_path / "again.h5")
    np.testing.assert_array_equal(again.actuation, ds.actuation)


def test_csv_a_few_markers_with_orientations_still_import(tmp_path):
    csv = tmp_path / "lab.csv"
    csv.write_text("time,n0_x,n0_y,n0_z,n0_qw,n0_qx,n0_qy,n0_qz,n7_x,n7_y,n7_z,n7_qw,n7_qx,n7_qy,n7_qz,act_coil_3[A]\n"
                   "0,0,0,0,1,0,0,0,0.3,0,0,1,0,0,0,0.1\n0.1,0,0,0,1,0,0,0,0.3,0.01,0,1,0,0,0,0.2\n")
    ds = import_csv(csv, tmp_path / "lab.h5")
    assert ds.nodes.tolist() == [0, 7] and ds.has_orientations and ds.actuation_units == {"coil_3": "A"}


HEAD = "time,n10_x,n10_y,n10_z,"
BAD_ACTUATION = [
    ("no unit", HEAD + "act_tendon_1\n0,0.5,0,0,1\n0.1,0.5,0,0,1\n",
     ["column 'act_tendon_1'", "has no unit", "act_tendon_1[<unit>]"]),
    ("empty unit", HEAD + "act_tendon_1[]\n0,0.5,0,0,1\n0.1,0.5,0,0,1\n", ["has no unit"]),
    ("unknown unit", HEAD + "act_tendon_1[Newton]\n0,0.5,0,0,1\n0.1,0.5,0,0,1\n",
     ["column 'act_tendon_1[Newton]'", "the unit 'Newton' is not recognised", "use one of"]),
    ("unit case", HEAD + "act_i[ma]\n0,0.5,0,0,1\n0.1,0.5,0,0,1\n", ["did you mean 'mA'?"]),
    ("bad prefix", HEAD + "a_tendon_1[N]\n0,0.5,0,0,1\n0.1,0.5,0,0,1\n",
     ["column 'a_tendon_1[N]' is not recognised", "act_<name>[<unit>]"]),
    ("no prefix", HEAD + "tendon_1\n0,0.5,0,0,1\n0.1,0.5,0,0,1\n", ["column 'tendon_1' is not recognised"]),
    ("bad name", HEAD + "act_1st[N]\n0,0.5,0,0,1\n0.1,0.5,0,0,1\n", ["channel name '1st' is invalid"]),
    ("same channel twice", HEAD + "act_t[N],act_T[kPa]\n0,0.5,0,0,1,1\n0.1,0.5,0,0,1,1\n", ["appears twice"]),
    ("missing value", HEAD + "act_tendon_1[N]\n0,0.5,0,0,1\n0.1,0.5,0,0,\n",
     ["line 3, column 'act_tendon_1[N]' (column 5)", "the cell is empty"]),
    ("nan value", HEAD + "act_tendon_1[N]\n0,0.5,0,0,nan\n0.1,0.5,0,0,1\n",
     ["line 2, column 'act_tendon_1[N]'", "'nan' is not a finite number"]),
    ("unit in cell", HEAD + "act_tendon_1[N]\n0,0.5,0,0,1N\n0.1,0.5,0,0,1\n", ["'1N' is not a number"]),
]


@pytest.mark.parametrize("text, words", [c[1:] for c in BAD_ACTUATION], ids=[c[0] for c in BAD_ACTUATION])
def test_bad_actuation_csv_is_one_line_exit_2_and_no_file(tmp_path, capsys, text, words):
    csv = tmp_path / "lab.csv"
    csv.write_text(text)
    out = tmp_path / "out.h5"
    assert run_cli(["import-csv", str(csv), "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith(f"softrnn: error: {csv}: "), err
    for w in words:
        assert w in err, (w, err)
    assert not out.exists() and list(tmp_path.iterdir()) == [csv]     # no partial or temporary file


# ------------------------------------------------------------------------------------------ models
def _node_data(tmp_path, actuation=True):
    path = tmp_path / ("act.h5" if actuation else "plain.h5")
    ds = _dataset(T=160)
    if not actuation:
        ds = Dataset(time=ds.time, nodes=ds.nodes, positions=ds.positions, quaternions=ds.quaternions,
                     forces=ds.forces, torques=ds.torques, attrs=ds.attrs)
    write_trajectory(path, ds, dt=0.01)
    return path


SMALL_NODE = {"lstm_units": 8, "lstm_layers": 1, "dense_units": (8,), "wrench_dense": (4,)}


def test_node_model_driven_by_actuation_trains_evaluates_and_reloads(tmp_path):
    pytest.importorskip("torch")
    from softrnn.learned.node.artifact import load_model
    from softrnn.learned.node.data import SampleSpec
    from softrnn.learned.node.evaluate import evaluate
    from softrnn.learned.node.train import TrainConfig, train_node_model

    path = _node_data(tmp_path)
    train = TrainConfig(epochs=2, batch_size=32, rollout_steps=2)
    model = train_node_model(path, SampleSpec(node=2, drive="actuation"), SMALL_NODE, train, tmp_path / "m")
    assert model.spec.wrench == "none" and model.spec.channels == ("tendon_1", "p_chamber_2")
    assert model.config.wrench_features == 2                                # input II: the two channels
    again = load_model(tmp_path / "m")
    assert again.spec == model.spec and again.meta["dataset"]["actuation_units"] == UNITS
    report = evaluate(again, path).to_json()
    assert report["drive"] == "actuation" and report["channels"] == ["tendon_1", "p_chamber_2"]
    assert report["free_running"] is not None
    base = report["baselines"]
    assert set(base) == {"persistence", "constant_velocity", "linear"}
    assert "rmse_mm" in base["linear"]["one_step"] and base["linear"]["fit"]["features"] > 0
    assert "the actuation inputs tendon_1, p_chamber_2" in base["linear"]["inputs"]      # the same inputs
    assert "force" not in base["linear"]["inputs"]
    both = train_node_model(path, SampleSpec(node=2, drive="both", channels=("p_chamber_2",)), SMALL_NODE,
                            TrainConfig(epochs=1, batch_size=32, rollout_steps=1), tmp_path / "m2")
    assert both.config.wrench_features == 3 + 1 and both.spec.wrench == "force"
    # the pressure's spread is floored within the kPa channels only, not against the forces'
    from softrnn.io import read_dataset
    from softrnn.learned.node.data import wrench_units

    assert wrench_units(read_dataset(path), both.spec) == ("N", "N", "N", "kPa")


def test_node_model_asking_for_missing_actuation_is_one_line(tmp_path, capsys):
    pytest.importorskip("torch")
    from softrnn.learned.node.data import SampleSpec
    from softrnn.learned.node.train import TrainConfig, train_node_model

    plain = _node_data(tmp_path, actuation=False)
    with pytest.raises(SoftrnnInputError, match=r"^drive='actuation' is invalid: the data set has no actuation "
                                                r"inputs; record them .* or use drive='wrench'$"):
        train_node_model(plain, SampleSpec(node=2, drive="actuation"), SMALL_NODE, TrainConfig(epochs=1),
                         tmp_path / "m")
    assert not (tmp_path / "m").exists()
    assert run_cli(["train", str(plain), "--node", "2", "--drive", "actuation", "-o", str(tmp_path / "m"),
                    "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--drive='actuation' is invalid" in err and "drive='wrench'" in err
    with pytest.raises(SoftrnnInputError, match="channels=.*no actuation channel 'coil_9'"):
        train_node_model(_node_data(tmp_path), SampleSpec(node=2, drive="actuation", channels=("coil_9",)),
                         SMALL_NODE, TrainConfig(epochs=1), tmp_path / "m")
    with pytest.raises(SoftrnnInputError, match="drive='both'"):
        SampleSpec(node=2, drive="both", wrench="none")
    assert SampleSpec(node=2).to_dict() == {"node": 2, "neighbours": None, "history": 2, "inputs": "positions",
                                            "wrench": "force", "train_fraction": 0.6}   # old model folders alike


def _rod(T=121, n_nodes=7, dt=0.01, seed=0, actuation=True) -> Dataset:
    """Every node of a planar rod bending with a tendon's tension (quaternions following the slope)."""
    t = np.arange(T) * dt
    tension = 0.5 + 0.5 * np.sin(2 * np.pi * 1.5 * t + seed)                         # (T,) [N]
    s = np.linspace(0.0, 1.0, n_nodes)
    bend = 0.05 * np.convolve(tension, np.ones(5) / 5, mode="same")                 # lagging response
    y = bend[:, None] * s ** 2
    slope = 2 * bend[:, None] * s / 0.4
    half = 0.5 * np.arctan(slope)
    q = np.stack([np.cos(half), 0 * half, 0 * half, np.sin(half)], axis=-1)
    pos = np.stack([np.broadcast_to(s * 0.4, y.shape), y, np.zeros_like(y)], axis=-1)
    zeros = np.zeros((T, n_nodes, 3))
    extra = {"actuation": tension[:, None], "actuation_units": {"tendon_1": "N"}} if actuation else {}
    return Dataset(time=t, nodes=np.arange(n_nodes), positions=pos, quaternions=q, forces=zeros, torques=zeros,
                   attrs={"dt": dt, "rod": {"length": 0.4, "n_nodes": n_nodes}}, **extra)


def test_whole_manipulator_model_driven_by_actuation(tmp_path, capsys):
    pytest.importorskip("torch")
    from softrnn.learned.whole.artifact import load_dynamic
    from softrnn.learned.whole.evaluation import evaluate_dynamic

    folder = tmp_path / "sweep"
    folder.mkdir()
    for i in range(3):
        write_trajectory(folder / f"traj-{i:05d}.h5", _rod(seed=i), dt=0.01, rod={"length": 0.4, "n_nodes": 7})
    model = tmp_path / "dyn"
    argv = ["dynamic", "train", str(folder), "-o", str(model), "--heldout", "1", "--model-dt", "0.02",
            "--node-stride", "2", "--width", "8", "--layers", "1", "--steps", "6", "--unroll", "2", "--quiet"]
    assert run_cli(argv + ["--drive", "actuation"]) == 0
    assert "driven by actuation tendon_1" in capsys.readouterr().out
    loaded = load_dynamic(model)
    assert loaded.config.drive == "actuation" and loaded.encoding.channels == ("tendon_1",)
    assert loaded.encoding.load_width == 1 and loaded.engine.load_width == 1
    report = evaluate_dynamic(loaded, heldout=[read_dataset(folder / "traj-00002.h5")], horizons=(2, 5)).to_dict()
    assert report["heldout"]["per_variant"][0] is not None
    assert set(report["heldout"]["baselines"]) == {"persistence", "constant_velocity", "linear"}
    assert set(report["horizons"]["5"]) == {"model", "persistence", "constant_velocity", "linear"}
    assert run_cli(["dynamic", "evaluate", str(model), "--heldout", str(folder / "traj-00002.h5")]) == 0
    # the same data without actuation: one line naming the option and the fix, no model folder
    plain = tmp_path / "plain"
    plain.mkdir()
    for i in range(2):
        write_trajectory(plain / f"traj-{i:05d}.h5", _rod(seed=i, actuation=False), dt=0.01,
                         rod={"length": 0.4, "n_nodes": 7})
    capsys.readouterr()
    assert run_cli(argv[:2] + [str(plain), "-o", str(tmp_path / "none")] + argv[5:] + ["--drive", "both"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--drive='both' is invalid" in err and "or use --drive='wrench'" in err
    assert not (tmp_path / "none").exists()
