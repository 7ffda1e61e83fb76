"""Reading a lab CSV in blocks: the same values as in one piece, progress after every block, a bad cell
still named by its line, and ``import-csv``'s bar (off with ``--quiet``)."""

from pathlib import Path

import numpy as np
import pytest

from softrnn.cli import _progress
from softrnn.io import csv_import, csv_table

from helpers import run_cli

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "lab_data.csv"


def test_blocks_give_the_same_values_and_report_each_block(monkeypatch):
    whole = csv_import.read_csv(EXAMPLE)
    rows = whole["time"].size
    monkeypatch.setattr(csv_table, "PARSE_BLOCK_ROWS", 7)
    calls = []
    blocked = csv_import.read_csv(EXAMPLE, progress=lambda done, total: calls.append((done, total)))
    for key, value in whole.items():
        if isinstance(value, np.ndarray):
            assert np.array_equal(value, blocked[key]), key
    assert calls == [(min(b, rows), rows) for b in range(7, rows + 7, 7)]


def test_a_bad_cell_in_a_later_block_is_named_by_its_line(tmp_path, monkeypatch):
    lines = EXAMPLE.read_text().splitlines()
    header_at = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    bad_at = header_at + 12                      # the 12th data row: the second block of 7
    cells = lines[bad_at].split(",")
    cells[1] = "abc"
    lines[bad_at] = ",".join(cells)
    path = tmp_path / "bad.csv"
    path.write_text("\n".join(lines) + "\n")
    monkeypatch.setattr(csv_table, "PARSE_BLOCK_ROWS", 7)
    with pytest.raises(csv_import.DatasetError, match=rf"line {bad_at + 1}, column .*'abc' is not a number"):
        csv_import.read_csv(path)


@pytest.mark.parametrize("quiet", [False, True])
def test_import_csv_bar_unless_quiet(tmp_path, capsys, monkeypatch, quiet):
    monkeypatch.setattr(csv_table, "PARSE_BLOCK_ROWS", 5)
    monkeypatch.setattr(_progress.DelayedBar, "__init__", _shown_at_once(_progress.DelayedBar.__init__))
    out = tmp_path / "lab.h5"
    assert run_cli(["import-csv", str(EXAMPLE), "-o", str(out), *(["--quiet"] if quiet else [])]) == 0
    assert out.exists()
    assert ("import-csv lab_data.csv" in capsys.readouterr().err) is not quiet


def _shown_at_once(init):
    def patched(self, *args, **kwargs):
        init(self, *args, **kwargs)
        self.after = 0.0
    return patched
