"""The one reader of lab CSV files, whatever their layout (softrnn's node layout,
``softrnn.io.csv_import``; a robot recording, ``softrnn.lab.recording``; the magnetic experiment's
record, ``softrnn.experiments.magnetic.lab``): the file's text, checked for what is often given
instead of a CSV (``read_text_file``), its lines (``read_csv_lines``), its cells as numbers
(``parse_cells``) and its time steps (``time_steps``). Each layout reads its own header and words
its own messages (``CellWords``); every problem is a one-line error naming the file, the line and
the column (layouts: docs/csv-format.md, docs/magnetic-format.md).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import FileFault
from ..files import read_whole
from ..progress import Progress
from .schema import DatasetError

ACTUATION_PREFIX = "act_"
"""Prefix of an actuation column: ``act_<name>[<unit>]``, e.g. ``act_tendon_1[N]``."""
ACTUATION_COLUMN = re.compile(r"^act_([^\[\]]*?)\s*(?:\[\s*([^\[\]]*?)\s*\])?$", re.IGNORECASE)
"""An actuation column ``act_<name>[<unit>]``: group 1 the name, group 2 the unit (None without brackets)."""
PARSE_BLOCK_ROWS = 65536
"""Rows of a CSV file converted to numbers at a time (``parse_cells`` reports its progress per block)."""


@dataclass(frozen=True)
class CellWords:
    """How a layout words a bad row, cell or time (``str.format`` templates).

    Attributes
    ----------
    width : str
        a row with another number of cells; fields ``line``, ``cells``, ``width``, ``more``
        ("more" or "fewer")
    empty, not_number, not_finite : str
        an empty cell, a cell that is not a number, a cell that is not finite; fields ``line``,
        ``name`` (the column's name), ``column`` (its 1-based index) and ``text`` (the cell, shortened)
    order : str
        a time that does not increase; fields ``line``, ``time``, ``previous``, ``previous_line``,
        ``what`` ("repeats" or "goes back from") and ``fix``
    step : str
        a step between two times that is not finite; fields ``line``, ``time``, ``previous``
    """

    width: str
    empty: str
    not_number: str
    not_finite: str
    order: str = "line {line}: time {time!r} is not after {previous!r} (line {previous_line}); {fix}"
    step: str = ("line {line}: the step from time {previous!r} to {time!r} is not a finite number of seconds; "
                 "times must be in s")


_NUMBER = "every cell must be a number (decimal point '.', no units)"
NODE_WORDS = CellWords(
    width="line {line} has {cells} cells but the header has {width} columns ({more} cells than column names); "
          "every row needs one value per column",
    empty="line {line}, column {name!r} (column {column}): the cell is empty; " + _NUMBER,
    not_number="line {line}, column {name!r} (column {column}): the cell {text} is not a number; " + _NUMBER,
    not_finite="line {line}, column {name!r} (column {column}): the cell {text} is not a finite number; every value "
               "must be finite")
"""The words of softrnn's node layout (``softrnn.io.csv_import``)."""


def shown(text, limit: int = 40) -> str:
    """``repr`` of a piece of a user's file for a message: at most ``limit`` characters (then ``...``),
    so that a header or cell of binary garbage stays short and on one line."""
    text = str(text)
    return repr(text) if len(text) <= limit else repr(text[:limit]) + "..."


_SIGNATURES = ((b"\x89HDF\r\n\x1a\n", "an HDF5 file (a softrnn dataset?)"),
               (b"PK\x03\x04", "a ZIP archive (an Excel .xlsx workbook or a NumPy .npz?)"),
               (b"\xd0\xcf\x11\xe0", "an old Excel .xls workbook"))
"""Leading bytes of files that are often given where a CSV is expected, and what they are."""


def read_text_file(path: Path, what: str, error=None) -> str:
    """The text of a UTF-8 file (a byte-order mark is dropped); a missing, folder, unreadable,
    UTF-16, non-UTF-8 or binary file (one holding NUL bytes; an HDF5 file or a workbook, named as
    such by its first bytes, ``_SIGNATURES``) raises ``error`` (default
    ``DatasetError``) with a one-line message naming the file and the fix (``what``: what the file
    should be, e.g. ``"the lab data"``)."""
    def fail(message):
        return (error or DatasetError)(f"{path}: {message}")

    if not path.exists():
        raise fail("no such file; check the path")
    if path.is_dir():
        raise fail("is a folder; pass a CSV file")
    try:
        data = read_whole(path)
    except FileFault as err:      # another program still writing it
        raise fail(str(err)[len(f"{path}: "):]) from None
    except OSError as err:
        raise fail(f"cannot be read ({err.strerror or type(err).__name__}); check the file and its "
                   "permissions") from None
    kind = next((name for magic, name in _SIGNATURES if data.startswith(magic)), None)
    if kind:
        raise fail(f"is {kind}, not a UTF-8 text file; export {what} as CSV (comma-separated text)")
    if data[:2] in (b"\xff\xfe", b"\xfe\xff"):
        raise fail(f"is a UTF-16 text file, not a UTF-8 text file; save {what} as UTF-8 CSV (comma-separated text)")
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise fail(f"is not a UTF-8 text file; export {what} as CSV (comma-separated text)") from None
    if "\x00" in text:
        raise fail(f"holds NUL bytes, so it is not a text file (binary data, or UTF-16 text without a byte-order "
                   f"mark); export {what} as UTF-8 CSV (comma-separated text)")
    return text


def read_csv_lines(path: Path, expected: str, error=None, what: str = "the lab data") -> list[tuple[int, str]]:
    """The non-empty, non-comment lines of a UTF-8 CSV file as (line number, stripped text);
    a missing, folder, unreadable, non-UTF-8, binary or empty file, or one whose header is separated
    by semicolons or tabs, raises ``error`` (default ``DatasetError``) with a one-line message naming
    the file (``expected``: what the header should hold; ``what``: what the file should be,
    ``read_text_file``)."""
    text = read_text_file(Path(path), what, error)
    lines = [(n, line.strip()) for n, line in enumerate(text.splitlines(), start=1)
             if line.strip() and not line.strip().startswith("#")]
    if not lines:
        raise (error or DatasetError)(f"{path}: is empty (no header line); expected {expected}")
    number, header = lines[0]
    separator = next((name for sep, name in ((";", "semicolons"), ("\t", "tabs")) if sep in header), None)
    if "," not in header and separator:
        raise (error or DatasetError)(f"{path}: line {number} (header): the columns are separated by {separator}; "
                                      "save the file comma-separated, with a decimal point '.'")
    return lines


def parse_cells(path: Path, names: list[str], rows: list[tuple[int, str]], columns=None, *,
                words: CellWords = NODE_WORDS, error=DatasetError, progress: Progress | None = None) -> np.ndarray:
    """The cells of ``columns`` (indices into ``names``; None: all) of a CSV file's data ``rows``
    ((line number, text) pairs, ``read_csv_lines``) as a (T, k) float64 array, checked: one cell per
    header column in every row, every cell read a finite number; else ``error`` worded by ``words``.
    Converted ``PARSE_BLOCK_ROWS`` rows at a time, ``progress(done, T)`` after each block."""
    width = len(names)
    columns = list(range(width)) if columns is None else list(columns)
    cells = [line.split(",") for _, line in rows]
    for (number, _), row in zip(rows, cells):
        if len(row) != width:
            more = "more" if len(row) > width else "fewer"
            raise error(f"{path}: " + words.width.format(line=number, cells=len(row), width=width, more=more))
    values = np.empty((len(rows), len(columns)))
    for a in range(0, len(rows), PARSE_BLOCK_ROWS):
        b = min(a + PARSE_BLOCK_ROWS, len(rows))
        values[a:b] = _numbers(path, names, rows[a:b], [[row[j] for j in columns] for row in cells[a:b]], columns,
                               words, error)
        if progress is not None:
            progress(b, len(rows))
    finite = np.isfinite(values)
    if not finite.all():
        i, k = (int(v) for v in np.argwhere(~finite)[0])
        j = columns[k]
        raise error(f"{path}: " + words.not_finite.format(line=rows[i][0], name=names[j], column=j + 1,
                                                           text=shown(cells[i][j].strip())))
    return values


def _numbers(path: Path, names: list[str], rows: list, cells: list, columns: list, words: CellWords,
             error) -> np.ndarray:
    """``cells`` (rows of strings of ``columns``) as a float64 array; a cell that is not a number is
    named with its line and column."""
    try:
        return np.array(cells, dtype=np.float64).reshape(len(rows), len(columns))
    except ValueError:
        for (number, _), row in zip(rows, cells):
            for j, cell in zip(columns, row):
                try:
                    float(cell)
                except ValueError:
                    text = cell.strip()
                    template = words.not_number if text else words.empty
                    raise error(f"{path}: " + template.format(line=number, name=names[j], column=j + 1,
                                                               text=shown(text))) from None
        raise  # pragma: no cover - numpy and float() accept the same strings


def time_steps(path: Path, rows: list, time: np.ndarray,
               fix: str = "rows must be in strictly increasing time order, without duplicates", *,
               words: CellWords = NODE_WORDS, error=DatasetError) -> np.ndarray:
    """The (T - 1,) steps [s] between the times (T,) [s] of a CSV file's data ``rows`` ((line
    number, text) pairs), every one checked positive and finite; else ``error`` (one line, worded
    by ``words``, ``fix`` saying what to do about a time that does not increase)."""
    with np.errstate(over="ignore"):   # times near +-1.8e308: refused below
        steps = np.diff(time)
    if np.any(steps <= 0):
        i = int(np.argmax(steps <= 0))
        what = "repeats" if steps[i] == 0 else "goes back from"
        raise error(f"{path}: " + words.order.format(line=rows[i + 1][0], time=float(time[i + 1]),
                                                      previous=float(time[i]), previous_line=rows[i][0], what=what,
                                                      fix=fix))
    if not np.isfinite(steps).all():
        i = int(np.argmax(~np.isfinite(steps)))
        raise error(f"{path}: " + words.step.format(line=rows[i + 1][0], time=float(time[i + 1]),
                                                     previous=float(time[i])))
    return steps
