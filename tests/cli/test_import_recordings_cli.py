"""``softrnn import-csv`` with robot recordings as they come from the lab (small synthetic stand-ins:
Unix timestamps at irregular intervals with a pause, ``pattern_label``, ``servo_<id>_mm``, the tip
in mm): one file, several sessions into a folder, ``--lag N|auto`` (the estimate printed), the
softrnn layout unchanged, and one line, exit 2 and no output for every bad input."""

import contextlib
import io
from pathlib import Path

import numpy as np
import pytest

from softrnn.io import import_csv, read_dataset

from helpers import run_cli

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "lab_data.csv"
T0 = 1775513850.298145
GAIN = np.array([[4.0, -1.0, 0.5], [0.5, 3.0, -2.0], [-1.5, 0.5, 2.5]])


def recording_csv(path, *, rows=40, lag=0, seed=0, servos=(1, 20, 3)):
    """A recording in the lab's layout (timestamp, pattern_label, servo_<id>_mm, tip_x/y/z [mm]) whose
    tip is GAIN @ the inputs ``lag`` rows earlier; steps 0.5-0.7 s and one 30 s pause. Returns
    (time, inputs, tip)."""
    rng = np.random.default_rng(seed)
    steps = rng.uniform(0.5, 0.7, rows - 1)
    steps[rows // 3] = 30.0
    time = T0 + seed * 2000.0 + np.concatenate([[0.0], np.cumsum(steps)])
    inputs = np.round(rng.uniform(-5, 5, (rows, len(servos))), 6)
    tip = np.round(np.array([-14.1, 2.4, 234.0]) + inputs[np.maximum(np.arange(rows) - lag, 0)] @ GAIN[:len(servos)],
                   6)
    lines = [",".join(["timestamp", "pattern_label"] + [f"servo_{s}_mm" for s in servos] + ["tip_x", "tip_y", "tip_z"])]
    for i in range(rows):
        lines.append(",".join([repr(float(time[i])), f"rep1_tendon{i // 10}_pull"]
                              + [repr(float(v)) for v in (*inputs[i], *tip[i])]))
    Path(path).write_text("\n".join(lines) + "\n")
    return time, inputs, tip


def _run(argv) -> tuple[int, str]:
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        code = run_cli(["import-csv", *map(str, argv)])
    return code, out.getvalue()


def _one_line_error(capsys, *words) -> str:
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert err.startswith("softrnn: error:") and "Traceback" not in err
    for w in words:
        assert w in err, err
    return err


def test_one_recording(tmp_path):
    time, inputs, tip = recording_csv(tmp_path / "train.csv")
    code, out = _run([tmp_path / "train.csv", "-o", tmp_path / "train.h5", "--length", "0.24"])
    assert code == 0, out
    assert "wrote" in out and "40 samples of the tip (node 1)" in out and "servo_20 [mm]" in out
    ds = read_dataset(tmp_path / "train.h5")
    assert np.array_equal(ds.time, time - time[0]) and ds.attrs["time_origin_s"] == time[0]
    np.testing.assert_allclose(ds.positions[:, 0], tip * 1e-3, rtol=1e-6)
    np.testing.assert_allclose(ds.actuation, inputs, rtol=1e-6)
    assert ds.actuation_units == {"servo_1": "mm", "servo_20": "mm", "servo_3": "mm"}
    assert ds.attrs["lag_rows"] == 0 and ds.attrs["source_file"] == "train.csv"
    assert ds.attrs["input_columns"] == ["servo_1_mm", "servo_20_mm", "servo_3_mm"]
    assert ds.attrs["rod"] == {"length": 0.24}


def test_options_pick_columns_unit_and_node(tmp_path):
    time, inputs, tip = recording_csv(tmp_path / "s.csv")
    text = (tmp_path / "s.csv").read_text().replace("tip_x,tip_y,tip_z", "mx,my,mz")
    (tmp_path / "r.csv").write_text(text)
    code, out = _run([tmp_path / "r.csv", "-o", tmp_path / "r.h5", "--inputs", "servo_3_*,servo_1_*",
                      "--tip", "mx,my,mz", "--position-unit", "cm", "--tip-node", "9", "--lag", "2"])
    assert code == 0, out
    ds = read_dataset(tmp_path / "r.h5")
    assert list(ds.nodes) == [9] and list(ds.actuation_units) == ["servo_3", "servo_1"]
    np.testing.assert_allclose(ds.positions[:, 0], tip[2:] * 1e-2, rtol=1e-6)
    np.testing.assert_allclose(ds.actuation, inputs[:-2, [2, 0]], rtol=1e-6)
    assert ds.attrs["lag_rows"] == 2 and "lag 2 rows" in out


def test_sessions_into_a_folder_with_auto_lag(tmp_path):
    k = 2
    recording_csv(tmp_path / "train.csv", lag=k, rows=50, seed=1)
    time, inputs, tip = recording_csv(tmp_path / "val.csv", lag=k, rows=30, seed=2)
    code, out = _run([tmp_path / "train.csv", tmp_path / "val.csv", "-o", tmp_path / "sessions", "--lag", "auto"])
    assert code == 0, out
    first = out.splitlines()[0]
    assert first.startswith(f"lag: {k} rows estimated") and all(f"{j}: " in first for j in range(6))
    assert sorted(p.name for p in (tmp_path / "sessions").iterdir()) == ["train.h5", "val.h5"]
    val = read_dataset(tmp_path / "sessions" / "val.h5")
    assert val.attrs["lag_rows"] == k and set(val.attrs["lag_rms_m"]) == {str(j) for j in range(6)}
    assert np.array_equal(val.time, time[k:] - time[k])
    np.testing.assert_allclose(val.actuation, inputs[:-k], rtol=1e-6)
    assert read_dataset(tmp_path / "sessions" / "train.h5").n_samples == 50 - k


def test_softrnn_layout_is_unchanged(tmp_path):
    import_csv(EXAMPLE, tmp_path / "direct.h5")
    code, out = _run([EXAMPLE, "-o", tmp_path / "cli.h5"])
    assert code == 0
    assert out.startswith(f"wrote {tmp_path / 'cli.h5'}: 21 samples x 3 nodes, t = 0 .. 0.2 s, dt = 0.01 s; ")
    assert (tmp_path / "cli.h5").read_bytes() == (tmp_path / "direct.h5").read_bytes()
    # beside a recording, each file by its own layout
    recording_csv(tmp_path / "train.csv")
    code, out = _run([EXAMPLE, tmp_path / "train.csv", "-o", tmp_path / "both"])
    assert code == 0, out
    assert read_dataset(tmp_path / "both" / "lab_data.h5").n_nodes == 3
    assert read_dataset(tmp_path / "both" / "train.h5").n_nodes == 1


def _rows(path, edit):
    lines = Path(path).read_text().splitlines()
    Path(path).write_text("\n".join(edit(lines)) + "\n")


BAD = {
    "unsorted time": (lambda t: _rows(t / "b.csv", lambda ls: [ls[0], ls[1], ls[3], ls[2], *ls[4:]]), [],
                      ["b.csv", "line 4", "goes back", "sort the rows"]),
    "duplicated time": (lambda t: _rows(t / "b.csv", lambda ls: [*ls[:5], ls[4], *ls[5:]]), [],
                        ["b.csv", "line 6", "repeats", "drop duplicated rows"]),
    "other channels": (lambda t: recording_csv(t / "b.csv", servos=(1, 20, 4)), [],
                       ["b.csv", "servo_4_mm", "differ", "same input columns"]),
    "a part of another": (lambda t: _rows(t / "b.csv", lambda ls: (t / "a.csv").read_text().splitlines()[:21]), [],
                          ["b.csv", "repeats 20 of its 20 rows of", "a.csv", "pass each recorded row once"]),
    "lag too long": (lambda t: recording_csv(t / "b.csv", rows=6), ["--lag", "4"],
                     ["--lag=4", "b.csv", "6 rows", "at most 3"]),
    "unknown position unit": (lambda t: None, ["--position-unit", "inch"], ["--position-unit='inch'", "mm"]),
    "bad lag": (lambda t: None, ["--lag", "-1"], ["--lag='-1'", "auto"]),
    "bad tip": (lambda t: None, ["--tip", "x,y"], ["--tip='x,y'", "X,Y,Z"]),
    "no input match": (lambda t: None, ["--inputs", "valve_*"], ["a.csv", "'valve_*'"]),
}


@pytest.mark.parametrize("case, several", [(c, False) for c in BAD if c not in ("other channels", "a part of another")]
                         + [(c, True) for c in BAD])
def test_bad_input_one_line_exit_2_no_output(tmp_path, capsys, case, several):
    """One file (-o FILE) or two sessions (-o FOLDER) whose second is bad: nothing is written."""
    make, options, words = BAD[case]
    recording_csv(tmp_path / "a.csv", seed=1)
    recording_csv(tmp_path / "b.csv", seed=2)
    make(tmp_path)
    if several:
        files, out = [tmp_path / "a.csv", tmp_path / "b.csv"], tmp_path / "sessions"
    else:
        files, out = [tmp_path / ("b.csv" if "b.csv" in words else "a.csv")], tmp_path / "out.h5"
    before = sorted(p.name for p in tmp_path.iterdir())
    code, _ = _run([*files, "-o", out, *options])
    assert code == 2
    _one_line_error(capsys, *words)
    assert not out.exists() and sorted(p.name for p in tmp_path.iterdir()) == before


def test_refusals_of_the_command_line(tmp_path, capsys):
    recording_csv(tmp_path / "a.csv", seed=1)
    recording_csv(tmp_path / "b.csv", seed=2)
    code, _ = _run([tmp_path / "a.csv", tmp_path / "b.csv", "-o", tmp_path / "all.h5"])
    assert code == 2
    _one_line_error(capsys, "-o=", "a folder for 2 CSVs")
    code, _ = _run([EXAMPLE, "-o", tmp_path / "x.h5", "--lag", "1"])
    assert code == 2
    _one_line_error(capsys, "--lag='1'", "robot recordings only", "lab_data.csv")
    (tmp_path / "sub").mkdir()
    recording_csv(tmp_path / "sub" / "a.csv")
    code, _ = _run([tmp_path / "a.csv", tmp_path / "sub" / "a.csv", "-o", tmp_path / "s"])
    assert code == 2
    _one_line_error(capsys, "different names")
    # an existing output is kept unless --overwrite
    (tmp_path / "s").mkdir()
    (tmp_path / "s" / "a.h5").write_text("old")
    code, _ = _run([tmp_path / "a.csv", tmp_path / "b.csv", "-o", tmp_path / "s"])
    assert code == 2
    _one_line_error(capsys, "a.h5", "--overwrite")
    assert (tmp_path / "s" / "a.h5").read_text() == "old" and not (tmp_path / "s" / "b.h5").exists()
    code, _ = _run([tmp_path / "a.csv", tmp_path / "b.csv", "-o", tmp_path / "s", "--overwrite"])
    assert code == 0 and read_dataset(tmp_path / "s" / "a.h5").n_samples == 40
    assert sorted(p.name for p in (tmp_path / "s").iterdir()) == ["a.h5", "b.h5"]
