"""A robot's recording read as it comes: columns, units, irregular times kept, labels; the
command-to-response lag shifted and estimated; bad recordings refused in one line."""

from dataclasses import replace

import numpy as np
import pytest

from softrnn.errors import SoftrnnInputError
from softrnn.lab.recording import Layout, check_sessions, estimate_lag, read_recording, shift_inputs

from helpers import tendon_recording


def test_reads_the_motion_capture_layout(tmp_path):
    time, u, tip = tendon_recording(tmp_path / "a.csv", rows=50)
    rec = read_recording(tmp_path / "a.csv")
    assert rec.names == ("servo_1", "servo_20", "servo_23") and rec.units == ("mm",) * 3
    np.testing.assert_allclose(rec.time, np.round(time, 6), rtol=0, atol=1e-6)
    np.testing.assert_allclose(rec.inputs, u, atol=1e-6)
    np.testing.assert_allclose(rec.tip, tip * 1e-3, atol=1e-9)        # mm -> m
    assert rec.labels[0] == "pattern_0" and len(rec.labels) == 50
    assert rec.intervals.max() == pytest.approx(20.0, abs=1e-5)        # the pause is kept


def test_layout_options_pick_columns_and_units(tmp_path):
    tendon_recording(tmp_path / "a.csv", rows=20)
    rec = read_recording(tmp_path / "a.csv", Layout(inputs="servo_23_*,servo_1_*", position_unit="m"))
    assert rec.names == ("servo_23", "servo_1")
    plain = read_recording(tmp_path / "a.csv")
    np.testing.assert_allclose(rec.tip, plain.tip * 1e3)
    with pytest.raises(SoftrnnInputError, match="no column matches the input pattern 'motor_\\*'"):
        read_recording(tmp_path / "a.csv", Layout(inputs="motor_*"))


def test_a_unit_suffix_in_any_case_is_spelled_as_the_known_unit(tmp_path):
    """Pressures and currents named with a unit suffix (``chamber_a_kpa``, ``coil_MA``) read with the
    unit's spelling, so that every later stage (the node data sets' channels) knows them."""
    path = tmp_path / "p.csv"
    rows = "\n".join(f"{0.1 * k:.1f},{k},0,300,{10 + k},{20 - k},{0.5 * k}" for k in range(8))
    path.write_text("timestamp,tip_x,tip_y,tip_z,chamber_a_kpa,chamber_b_KPA,coil_MA\n" + rows + "\n")
    rec = read_recording(path, Layout(inputs="chamber_*,coil_*"))
    assert rec.names == ("chamber_a", "chamber_b", "coil") and rec.units == ("kPa", "kPa", "mA")


@pytest.mark.parametrize("swap, words", [((5, 4), "goes back from"), ((5, 5), "repeats")])
def test_unsorted_or_duplicated_rows_are_refused(tmp_path, swap, words):
    tendon_recording(tmp_path / "a.csv", rows=20)
    lines = (tmp_path / "a.csv").read_text().splitlines()
    cells = lines[swap[0] + 1].split(",")
    cells[0] = lines[swap[1]].split(",")[0] if swap[0] != swap[1] else lines[swap[0]].split(",")[0]
    lines[swap[0] + 1] = ",".join(cells)
    (tmp_path / "a.csv").write_text("\n".join(lines) + "\n")
    with pytest.raises(SoftrnnInputError, match=f"line 7: the time .* {words}.*sort the rows by time") as err:
        read_recording(tmp_path / "a.csv")
    assert "\n" not in str(err.value)


def test_sessions_with_other_channels_are_refused(tmp_path):
    tendon_recording(tmp_path / "a.csv", rows=20)
    tendon_recording(tmp_path / "b.csv", rows=20, header=["timestamp", "pattern_label", "servo_1_mm", "servo_20_mm",
                                                          "servo_7_mm", "tip_x", "tip_y", "tip_z"])
    tendon_recording(tmp_path / "c.csv", rows=20, seed=1)
    a, b, c = (read_recording(tmp_path / f"{name}.csv") for name in "abc")
    check_sessions([a, c])
    with pytest.raises(SoftrnnInputError, match="differ from those of"):
        check_sessions([a, b])


def test_a_session_that_repeats_rows_of_another_is_refused(tmp_path):
    """An excerpt of a recording passed beside it (the same rows: time, inputs and tip) would count its
    rows twice: refused in one line naming both files, whichever comes first; the same commands at
    other times, or another recording of them, are not a repeat."""
    tendon_recording(tmp_path / "a.csv", rows=40)
    lines = (tmp_path / "a.csv").read_text().splitlines()
    (tmp_path / "part.csv").write_text("\n".join(lines[:1] + lines[11:21]) + "\n")
    a, part = read_recording(tmp_path / "a.csv"), read_recording(tmp_path / "part.csv")
    for order in ([a, part], [part, a]):
        with pytest.raises(SoftrnnInputError, match=r"repeats 10 of its (10|40) rows of .*\.csv .*pass each recorded "
                                                    r"row once") as err:
            check_sessions(order)
        assert "\n" not in str(err.value) and str(order[1].path) in str(err.value)
    with pytest.raises(SoftrnnInputError, match="repeats 40 of its 40 rows"):
        check_sessions([a, a])
    later = replace(a, time=a.time + 1000.0)                 # the same commands and tips, recorded later
    noisy = replace(a, tip=a.tip + 1e-6)                     # the same commands at the same times, measured anew
    check_sessions([a, later, noisy])


def test_lag_is_shifted_and_estimated(tmp_path):
    """A tip that follows its command 2 rows late: the estimate says 2, and shifting by it pairs
    each tip with the command that made it."""
    tendon_recording(tmp_path / "a.csv", rows=150, lag=2, noise_mm=0.0)
    rec = read_recording(tmp_path / "a.csv")
    lag, scores = estimate_lag([rec])
    assert lag == 2 and scores[2] < scores[0] and scores[2] < scores[1]
    shifted = shift_inputs(rec, 2)
    assert shifted.n_rows == rec.n_rows - 2 and shifted.lag == 2
    np.testing.assert_array_equal(shifted.inputs[5], rec.inputs[5])
    np.testing.assert_array_equal(shifted.tip[5], rec.tip[7])
    with pytest.raises(SoftrnnInputError, match="lag=150 is invalid: fewer rows than the recording"):
        shift_inputs(rec, 150)


def test_a_long_lag_is_found_beyond_the_first_candidates(tmp_path):
    """A tip 9 rows late: the first candidates 0..5 fit best at their largest, so the search goes
    on (to 10) and finds 9; a fixed ``max_lag`` tries exactly 0..max_lag."""
    tendon_recording(tmp_path / "a.csv", rows=300, lag=9, noise_mm=0.0)
    rec = read_recording(tmp_path / "a.csv")
    lag, scores = estimate_lag([rec])
    assert lag == 9 and sorted(scores) == list(range(11))
    assert scores[9] < min(v for k, v in scores.items() if k != 9)
    lag, scores = estimate_lag([rec], max_lag=5)
    assert lag == 5 and sorted(scores) == list(range(6))


def test_a_bad_cell_names_its_line_and_column(tmp_path):
    tendon_recording(tmp_path / "a.csv", rows=10)
    lines = (tmp_path / "a.csv").read_text().splitlines()
    cells = lines[4].split(",")
    cells[3] = "oops"
    lines[4] = ",".join(cells)
    (tmp_path / "a.csv").write_text("\n".join(lines) + "\n")
    with pytest.raises(SoftrnnInputError, match="line 5, column 'servo_20_mm': 'oops' is not a finite number"):
        read_recording(tmp_path / "a.csv")
