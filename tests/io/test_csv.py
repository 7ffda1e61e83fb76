"""Lab CSV import/export: the example file, exact round trips, optional columns, and one-line
errors (exit code 2, no output file) for every kind of bad CSV."""

import copy
from pathlib import Path

import numpy as np
import pytest

from softrnn.io import Dataset, DatasetError, export_csv, import_csv, read_dataset, write_trajectory
from softrnn.io.csv_import import read_csv

from helpers import run_cli

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "lab_data.csv"
FIELDS = ("positions", "quaternions", "forces", "torques")


def _dataset(T=40, nodes=(0, 4, 9), seed=0) -> Dataset:
    rng = np.random.default_rng(seed)
    N = len(nodes)
    q = rng.normal(size=(T, N, 4))
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    forces = np.zeros((T, N, 3))
    forces[:, -1] = rng.normal(size=(T, 3))  # a wrench at the last node only
    torques = np.zeros((T, N, 3))
    torques[:, -1, 2] = rng.normal(size=T) * 1e-3
    return Dataset(time=np.arange(T) * 1e-3 + 0.5, nodes=list(nodes), positions=rng.uniform(-0.6, 0.6, (T, N, 3)),
                   quaternions=q, forces=forces, torques=torques, attrs={"dt": 1e-3})


def _write(tmp_path, text, name="lab.csv"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_example_file_imports(tmp_path, capsys):
    before = EXAMPLE.read_bytes()
    out = tmp_path / "lab.h5"
    assert run_cli(["import-csv", str(EXAMPLE), "-o", str(out), "--length", "0.5", "--seed", "4"]) == 0
    assert "21 samples x 3 nodes" in capsys.readouterr().out
    assert EXAMPLE.read_bytes() == before
    ds = read_dataset(out)
    assert ds.nodes.tolist() == [0, 5, 10] and ds.n_samples == 21
    assert ds.dt == pytest.approx(0.01) and ds.has_orientations
    assert ds.attrs["rod"] == {"length": 0.5} and ds.attrs["seed"] == 4
    assert ds.attrs["source"] == "csv" and ds.attrs["source_file"] == "lab_data.csv"
    assert ds.attrs["force_nodes"] == [10] and ds.attrs["torque_nodes"] == []
    raw = np.loadtxt(EXAMPLE, delimiter=",", skiprows=3)
    np.testing.assert_array_equal(ds.time, raw[:, 0])
    np.testing.assert_array_equal(ds.positions[:, 2], raw[:, 15:18].astype(np.float32))
    np.testing.assert_array_equal(ds.forces[:, 2], raw[:, 22:25].astype(np.float32))
    assert not ds.forces[:, :2].any() and not ds.torques.any()
    norms = np.linalg.norm(ds.quaternions.astype(np.float64), axis=-1)
    assert np.abs(norms - 1).max() < 1e-6  # rounded to 5 decimals in the file, normalised on import
    assert run_cli(["show", str(out)]) == 0
    assert "nodes: 3 of 11 stored (0, 5, 10)" in capsys.readouterr().out


def test_dataset_csv_dataset_round_trip_is_exact(tmp_path):
    ds = _dataset()
    before = {n: np.array(getattr(ds, n), copy=True) for n in ("time", "nodes") + FIELDS}
    attrs = copy.deepcopy(ds.attrs)
    export_csv(ds, tmp_path / "a.csv")
    for n, v in before.items():
        np.testing.assert_array_equal(getattr(ds, n), v)
    assert ds.attrs == attrs
    header = (tmp_path / "a.csv").read_text().splitlines()[0].split(",")
    assert header[:8] == ["time", "n0_x", "n0_y", "n0_z", "n0_qw", "n0_qx", "n0_qy", "n0_qz"]
    assert "n9_fx" in header and "n9_tz" in header and "n0_fx" not in header  # zero wrenches left out

    csv_bytes = (tmp_path / "a.csv").read_bytes()
    back = import_csv(tmp_path / "a.csv", tmp_path / "a.h5")
    assert (tmp_path / "a.csv").read_bytes() == csv_bytes
    for n in ("time", "nodes") + FIELDS:
        assert getattr(back, n).dtype == getattr(ds, n).dtype, n
        np.testing.assert_array_equal(getattr(back, n), getattr(ds, n), err_msg=n)

    # CSV -> HDF5 -> CSV -> HDF5: the same columns and the same values again
    export_csv(tmp_path / "a.h5", tmp_path / "b.csv")
    assert (tmp_path / "b.csv").read_text().splitlines()[0] == ",".join(header)
    again = import_csv(tmp_path / "b.csv", tmp_path / "b.h5")
    for n in ("time", "nodes") + FIELDS:
        np.testing.assert_array_equal(getattr(again, n), getattr(back, n), err_msg=n)
    assert {k: v for k, v in again.attrs.items() if k != "source_file"} == \
        {k: v for k, v in back.attrs.items() if k != "source_file"}


def test_simulated_file_exports_and_reimports(tmp_path):
    ds = _dataset(T=25, nodes=(2, 3))
    write_trajectory(tmp_path / "s.h5", ds, dt=1e-3)
    export_csv(tmp_path / "s.h5", tmp_path / "s.csv")
    back = import_csv(tmp_path / "s.csv", tmp_path / "t.h5")
    original = read_dataset(tmp_path / "s.h5")
    for n in ("time", "nodes") + FIELDS:
        np.testing.assert_array_equal(getattr(back, n), getattr(original, n), err_msg=n)


def test_optional_columns_and_irregular_time(tmp_path):
    path = _write(tmp_path, "# positions only, irregular times\n"
                            "time,n3_x,n3_y,n3_z,n1_x,n1_y,n1_z\n"
                            "0.0,0.1,0.2,0.3,1,2,3\n"
                            "0.0101,0.1,0.2,0.3,1,2,3\n\n"
                            "0.02,0.1,0.2,0.31,1,2,3\n"
                            "0.0299,0.1,0.2,0.32,1,2,3\n")
    ds = import_csv(path, tmp_path / "o.h5")
    assert ds.nodes.tolist() == [1, 3]  # sorted by node index
    np.testing.assert_array_equal(ds.time, [0.0, 0.0101, 0.02, 0.0299])  # the real times are kept
    assert ds.dt == pytest.approx(0.0099)  # the median step
    assert not ds.has_orientations
    np.testing.assert_array_equal(ds.quaternions, np.tile(np.float32([1, 0, 0, 0]), (4, 2, 1)))
    assert not ds.forces.any() and not ds.torques.any()
    assert ds.attrs["force_nodes"] == [] and ds.attrs["rod"] is None
    np.testing.assert_array_equal(ds.positions[:, 1, 2], np.float32([0.3, 0.3, 0.31, 0.32]))
    export_csv(ds, tmp_path / "o.csv")
    assert (tmp_path / "o.csv").read_text().splitlines()[0] == "time,n1_x,n1_y,n1_z,n3_x,n3_y,n3_z"

    # quaternions slightly off unit norm (rounded lab values) are normalised
    path = _write(tmp_path, "time,n0_x,n0_y,n0_z,n0_qw,n0_qx,n0_qy,n0_qz\n"
                            "0,0,0,0,1.0002,0,0,0\n1,0,0,0,0.7071,0.7071,0,0\n")
    ds = read_csv(path)
    np.testing.assert_allclose(np.linalg.norm(ds["quaternions"], axis=-1), 1.0, rtol=0, atol=1e-15)


GOOD = "time,n0_x,n0_y,n0_z,n1_x,n1_y,n1_z\n0,0,0,0,1,0,0\n0.1,0,0,0,1,0,0.01\n"
BAD_CSV = [
    ("missing column", "time,n0_x,n0_y\n0,0,0\n1,0,0\n", ["missing column n0_z", "n{i}_x, n{i}_y, n{i}_z"]),
    ("node without position", "time,n0_x,n0_y,n0_z,n2_fx,n2_fy,n2_fz\n0,0,0,0,0,0,0\n1,0,0,0,0,0,0\n",
     ["missing columns n2_x, n2_y, n2_z"]),
    ("partial quaternion", "time,n0_x,n0_y,n0_z,n0_qw,n0_qx\n0,0,0,0,1,0\n1,0,0,0,1,0\n",
     ["missing columns n0_qy, n0_qz", "orientations need all of"]),
    ("quaternion on some nodes", "time,n0_x,n0_y,n0_z,n0_qw,n0_qx,n0_qy,n0_qz,n1_x,n1_y,n1_z\n"
                                 "0,0,0,0,1,0,0,0,1,0,0\n1,0,0,0,1,0,0,0,1,0,0\n",
     ["missing columns n1_qw, n1_qx, n1_qy, n1_qz", "every node"]),
    ("partial force", "time,n0_x,n0_y,n0_z,n0_fx,n0_fy\n0,0,0,0,0,0\n1,0,0,0,0,0\n", ["missing column n0_fz"]),
    ("unknown column", "time,n0_x,n0_y,n0_z,temperature\n0,0,0,0,20\n1,0,0,0,20\n",
     ["column 'temperature' is not recognised", "n{i}_x"]),
    ("unknown component", "time,n0_x,n0_y,n0_z,n0_w\n0,0,0,0,1\n1,0,0,0,1\n", ["'n0_w' is not recognised"]),
    ("leading zero node", "time,n01_x,n01_y,n01_z\n0,0,0,0\n1,0,0,0\n", ["'n01_x' is not recognised"]),
    ("duplicate column", "time,n0_x,n0_y,n0_z,n0_x\n0,0,0,0,0\n1,0,0,0,0\n", ["'n0_x' appears twice"]),
    ("time not first", "n0_x,n0_y,n0_z,time\n0,0,0,0\n1,0,0,1\n", ["first column is 'n0_x'", "expected 'time'"]),
    ("trailing comma in header", "time,n0_x,n0_y,n0_z,\n0,0,0,0,\n1,0,0,0,\n", ["column 5 has no name"]),
    ("non-numeric cell", "time,n0_x,n0_y,n0_z\n0,0,0,0\n0.1,0,abc,0\n",
     ["line 3, column 'n0_y' (column 3)", "'abc' is not a number"]),
    ("unit in cell", "time,n0_x,n0_y,n0_z\n0,0,0,0\n0.1,0,0,5mm\n", ["line 3, column 'n0_z'", "'5mm'"]),
    ("empty cell", "time,n0_x,n0_y,n0_z\n0,0,,0\n0.1,0,0,0\n", ["line 2, column 'n0_y'", "is empty"]),
    ("extra cell", "time,n0_x,n0_y,n0_z\n0,0,0,0\n0.1,0,0,0,7\n", ["line 3 has 5 cells but the header has 4",
                                                                   "more cells"]),
    ("missing cell", "time,n0_x,n0_y,n0_z\n0,0,0\n0.1,0,0,0\n", ["line 2 has 3 cells", "fewer cells"]),
    ("nan cell", "time,n0_x,n0_y,n0_z\n0,0,0,0\n0.1,nan,0,0\n", ["line 3, column 'n0_x'", "not a finite number"]),
    ("time not increasing", "time,n0_x,n0_y,n0_z\n0,0,0,0\n0.2,0,0,0\n0.1,0,0,0\n",
     ["line 4: time 0.1 is not after 0.2 (line 3)", "strictly increasing"]),
    ("duplicate time", "time,n0_x,n0_y,n0_z\n0,0,0,0\n0,0,0,0\n", ["line 3: time 0.0 is not after 0.0"]),
    ("empty file", "", ["is empty (no header line)"]),
    ("comments only", "# nothing\n\n", ["is empty (no header line)"]),
    ("header only", "time,n0_x,n0_y,n0_z\n", ["has 0 data rows", "at least 2"]),
    ("one row", "time,n0_x,n0_y,n0_z\n0,0,0,0\n", ["has 1 data row after"]),
    ("no nodes", "time\n0\n1\n", ["no node columns"]),
    ("millimetres", "time,n0_x,n0_y,n0_z\n0,0,0,0\n0.1,500,0,0\n", ["line 3, column 'n0_x'", "in metres"]),
    ("non-unit quaternion", "time,n0_x,n0_y,n0_z,n0_qw,n0_qx,n0_qy,n0_qz\n0,0,0,0,1,0,0,0\n1,0,0,0,2,0,0,0\n",
     ["line 3: the quaternion n0_qw..n0_qz has norm 2", "unit quaternion"]),
]


@pytest.mark.parametrize("text, words", [c[1:] for c in BAD_CSV], ids=[c[0] for c in BAD_CSV])
def test_bad_csv_is_one_line_exit_2_and_no_file(tmp_path, capsys, text, words):
    path = _write(tmp_path, text)
    out = tmp_path / "out.h5"
    assert run_cli(["import-csv", str(path), "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert err.startswith(f"softrnn: error: {path}: ") and "Traceback" not in err
    for w in words:
        assert w in err, (w, err)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["lab.csv"]  # no output, no temporary file
    assert path.read_text() == text


def test_other_import_errors(tmp_path, capsys):
    out = tmp_path / "out.h5"
    assert run_cli(["import-csv", str(tmp_path / "missing.csv"), "-o", str(out)]) == 2
    assert "missing.csv: no such file" in capsys.readouterr().err
    binary = tmp_path / "x.csv"
    binary.write_bytes(b"\x89HDF\r\n\x1a\n\xff\xfe\x00")
    assert run_cli(["import-csv", str(binary), "-o", str(out)]) == 2
    assert "not a UTF-8 text file" in capsys.readouterr().err
    good = _write(tmp_path, GOOD)
    assert run_cli(["import-csv", str(good)]) == 2  # -o is required
    assert "-o/--output" in capsys.readouterr().err
    assert run_cli(["import-csv", str(good), "-o", str(out), "--length", "-1"]) == 2
    assert "--length=-1.0" in capsys.readouterr().err
    assert not out.exists()

    # a bad CSV leaves an existing output as it was
    assert run_cli(["import-csv", str(good), "-o", str(out)]) == 0
    old = out.read_bytes()
    bad = _write(tmp_path, GOOD + "0.05,0,0,0,1,0,0\n", "bad.csv")
    assert run_cli(["import-csv", str(bad), "-o", str(out)]) == 2       # exists: refused before reading
    assert "--overwrite" in capsys.readouterr().err
    assert run_cli(["import-csv", str(bad), "-o", str(out), "--overwrite"]) == 2
    assert "not after" in capsys.readouterr().err
    assert out.read_bytes() == old
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.csv", "lab.csv", "out.h5", "x.csv"]
    with pytest.raises(DatasetError, match="not after"):
        import_csv(bad, tmp_path / "o2.h5")
