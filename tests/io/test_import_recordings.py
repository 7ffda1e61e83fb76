"""Robot recordings as they come from the lab (Unix timestamps at irregular intervals, a pattern
label, ``servo_<id>_mm`` inputs, the tip in mm) into datasets: values, units and times kept, the
lag shift and its estimate, the unit mapping, the layout detection and one-line errors. The CSVs
are small synthetic stand-ins written here."""

from pathlib import Path

import numpy as np
import pytest

from softrnn.io import DatasetError, read_dataset
from softrnn.io.csv_import import LABELS_LIMIT, csv_layout, recording_trajectory, write_recording
from softrnn.lab.recording import Layout, estimate_lag, read_recording, shift_inputs

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "lab_data.csv"
T0 = 1775513850.298145
GAIN = np.array([[4.0, -1.0, 0.5], [0.5, 3.0, -2.0], [-1.5, 0.5, 2.5]])
"""The synthetic tip [mm] moves by GAIN @ inputs [mm] of the row ``lag`` rows earlier."""


def recording_csv(path, *, rows=40, lag=0, seed=0, servos=(1, 20, 3), pause_at=15, labels=True):
    """A robot recording in the lab's layout: ``timestamp`` (Unix time, steps of 0.5-0.7 s and one
    30 s pause), ``pattern_label``, ``servo_<id>_mm``, ``tip_x, tip_y, tip_z`` [mm]; the tip is a known
    linear function of the inputs ``lag`` rows earlier. Returns (time, inputs [mm], tip [mm])."""
    rng = np.random.default_rng(seed)
    steps = rng.uniform(0.5, 0.7, rows - 1)
    steps[pause_at - 1] = 30.0
    time = T0 + np.concatenate([[0.0], np.cumsum(steps)])
    inputs = np.round(rng.uniform(-5, 5, (rows, len(servos))), 6)
    earlier = inputs[np.maximum(np.arange(rows) - lag, 0)]
    tip = np.round(np.array([-14.1, 2.4, 234.0]) + earlier @ GAIN[:len(servos)], 6)
    header = (["timestamp"] + (["pattern_label"] if labels else []) + [f"servo_{s}_mm" for s in servos]
              + ["tip_x", "tip_y", "tip_z"])
    lines = [",".join(header)]
    for i in range(rows):
        label = [f"rep1_tendon{i // 10}_pull"] if labels else []
        lines.append(",".join([repr(float(time[i]))] + label + [repr(float(v)) for v in (*inputs[i], *tip[i])]))
    Path(path).write_text("\n".join(lines) + "\n")
    return time, inputs, tip


def _import(csv, out, *, lag=0, **kwargs):
    rec = shift_inputs(read_recording(csv), lag)
    data = recording_trajectory(rec.time, rec.tip, rec.inputs, rec.names, rec.units, columns=rec.columns,
                                labels=rec.labels, source=str(csv))
    return write_recording(out, data, attrs={"lag_rows": lag}, **kwargs)


def test_round_trip_keeps_values_units_and_irregular_times(tmp_path):
    time, inputs, tip = recording_csv(tmp_path / "s.csv")
    ds = _import(tmp_path / "s.csv", tmp_path / "s.h5")
    assert read_dataset(tmp_path / "s.h5").n_samples == 40
    assert np.array_equal(ds.time, time - time[0]) and ds.time[0] == 0.0
    assert ds.attrs["time_origin_s"] == time[0]
    steps = np.diff(ds.time)
    assert steps.max() == pytest.approx(30.0) and steps.min() >= 0.5 - 1e-6
    assert ds.dt == pytest.approx(np.median(np.diff(time)))
    assert list(ds.nodes) == [1] and ds.attrs["n_nodes_total"] == 2
    np.testing.assert_allclose(ds.positions[:, 0], tip * 1e-3, rtol=1e-6, atol=1e-9)
    assert not ds.has_orientations and np.all(ds.quaternions[..., 0] == 1)
    assert not ds.forces.any() and not ds.torques.any()
    assert ds.actuation_units == {"servo_1": "mm", "servo_20": "mm", "servo_3": "mm"}
    np.testing.assert_allclose(ds.actuation, inputs, rtol=1e-6)
    assert ds.attrs["source"] == "recording" and ds.attrs["lag_rows"] == 0
    assert ds.attrs["labels"] == [["rep1_tendon0_pull", 0, 10], ["rep1_tendon1_pull", 10, 10],
                                  ["rep1_tendon2_pull", 20, 10], ["rep1_tendon3_pull", 30, 10]]


def test_lag_shift_pairs_the_tip_with_earlier_inputs_and_auto_finds_it(tmp_path):
    k = 3
    time, inputs, tip = recording_csv(tmp_path / "s.csv", lag=k, rows=50)
    rec = read_recording(tmp_path / "s.csv")
    lag, scores = estimate_lag([rec])
    assert lag == k and scores[k] < 1e-6 * min(v for j, v in scores.items() if j != k)
    ds = _import(tmp_path / "s.csv", tmp_path / "s.h5", lag=k)
    assert ds.n_samples == 50 - k and ds.attrs["lag_rows"] == k
    assert np.array_equal(ds.time, time[k:] - time[k]) and ds.attrs["time_origin_s"] == time[k]
    np.testing.assert_allclose(ds.actuation, inputs[:-k], rtol=1e-6)
    np.testing.assert_allclose(ds.positions[:, 0], tip[k:] * 1e-3, rtol=1e-6)
    # the stored tip is the known function of the stored inputs, row by row
    np.testing.assert_allclose(ds.positions[:, 0] * 1e3, np.array([-14.1, 2.4, 234.0]) + ds.actuation @ GAIN,
                               atol=1e-3)
    assert ds.attrs["labels"][0] == ["rep1_tendon0_pull", 0, 10 - k]


def test_tip_node_rod_and_metadata(tmp_path):
    recording_csv(tmp_path / "s.csv", labels=False)
    ds = _import(tmp_path / "s.csv", tmp_path / "s.h5", tip_node=20, rod_length=0.24, seed=3, scenario_text="lab")
    assert list(ds.nodes) == [20] and ds.attrs["n_nodes_total"] == 21
    assert ds.attrs["rod"] == {"length": 0.24} and ds.attrs["seed"] == 3 and ds.attrs["scenario_text"] == "lab"
    assert "labels" not in ds.attrs
    with pytest.raises(ValueError, match="tip_node"):
        _import(tmp_path / "s.csv", tmp_path / "t.h5", tip_node=-1)
    assert not (tmp_path / "t.h5").exists()


@pytest.mark.parametrize("unit, stored", [("", "1"), ("mm", "mm"), ("N", "N"), ("n", "N"), ("ma", "mA"),
                                          ("kpa", "kPa"), ("deg", "deg")])
def test_units_are_actuation_units(unit, stored):
    T = 5
    data = recording_trajectory(np.arange(T) * 0.5, np.zeros((T, 3)), np.zeros((T, 1)), ["Servo_1"], [unit],
                                columns=[f"Servo_1_{unit}" if unit else "Servo_1"])
    assert data["actuation_units"] == {"servo_1": stored}


@pytest.mark.parametrize("names, units, columns, words", [
    (["servo_1"], ["furlong"], ["servo_1_furlong"], ["'servo_1_furlong'", "'furlong' is not recognised", "mm"]),
    (["tendon"], ["n"], ["act_tendon[n]"], ["'act_tendon[n]'", "did you mean 'N'"]),
    (["1servo"], ["mm"], ["1servo_mm"], ["'1servo_mm'", "channel name"]),
])
def test_bad_channels_one_line(names, units, columns, words):
    with pytest.raises(DatasetError) as err:
        recording_trajectory(np.arange(4.0), np.zeros((4, 3)), np.zeros((4, 1)), names, units, columns=columns,
                             source="lab.csv")
    text = str(err.value)
    assert "\n" not in text and text.startswith("lab.csv: ")
    for w in words:
        assert w in text, text


def test_bad_arrays_one_line():
    with pytest.raises(DatasetError, match="beyond 16 m; check the position unit"):
        recording_trajectory(np.arange(4.0), np.full((4, 3), 234.0), np.zeros((4, 1)), ["s"], ["mm"])
    with pytest.raises(DatasetError, match="not after"):
        recording_trajectory(np.array([0.0, 1.0, 1.0, 2.0]), np.zeros((4, 3)), np.zeros((4, 1)), ["s"], ["mm"])
    with pytest.raises(DatasetError, match="appears twice"):
        recording_trajectory(np.arange(4.0), np.zeros((4, 3)), np.zeros((4, 2)), ["s", "S"], ["mm", "mm"])


def test_many_labels_are_counted_not_stored():
    T = LABELS_LIMIT // 10
    data = recording_trajectory(np.arange(float(T)), np.zeros((T, 3)), np.zeros((T, 1)), ["s"], ["mm"],
                                labels=[f"pattern_{i}" for i in range(T)])
    assert data["labels"] is None and data["label_runs"] == T


def test_csv_layout_tells_the_layouts_apart(tmp_path):
    recording_csv(tmp_path / "rec.csv")
    assert csv_layout(tmp_path / "rec.csv") == "recording"
    assert csv_layout(EXAMPLE) == "nodes"
    (tmp_path / "plain.csv").write_text("time,x\n0,1\n1,2\n")
    assert csv_layout(tmp_path / "plain.csv") == "nodes"
    assert csv_layout(tmp_path / "plain.csv", recording=True) == "recording"
    (tmp_path / "both.csv").write_text("time,n3_x,n3_y,n3_z,tip_x\n0,0,0,0,0\n")
    assert csv_layout(tmp_path / "both.csv") == "nodes"
    assert csv_layout(tmp_path / "missing.csv") == "nodes"


def test_position_unit_m_for_a_recording_in_m(tmp_path):
    time, inputs, tip = recording_csv(tmp_path / "s.csv")
    text = (tmp_path / "s.csv").read_text().splitlines()
    rows = [line.split(",") for line in text[1:]]
    for r, row in enumerate(rows):
        row[-3:] = [repr(float(v) * 1e-3) for v in tip[r]]
    (tmp_path / "m.csv").write_text("\n".join([text[0]] + [",".join(r) for r in rows]) + "\n")
    rec = read_recording(tmp_path / "m.csv", Layout(position_unit="m"))
    data = recording_trajectory(rec.time, rec.tip, rec.inputs, rec.names, rec.units, columns=rec.columns)
    np.testing.assert_allclose(data["tip"], tip * 1e-3, rtol=1e-12)
