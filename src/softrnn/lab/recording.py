"""A robot's recording as it comes from the lab: a CSV with a time column, the commanded inputs
and a tracked tip, rows at whatever times the lab's loop wrote them.

The layout (docs/csv-format.md, "Robot recordings"): a header line, then one line per row.

* time: a column ``time`` or ``timestamp`` [s] (any origin, e.g. Unix time), strictly increasing;
  the rows may come at any intervals (pauses included): they are kept as recorded.
* inputs: the commanded actuation, one column per channel, named ``act_<name>[<unit>]`` (the
  softrnn layout) or ``<name>_<unit>`` with a unit suffix such as ``servo_1_mm``; by default every
  ``act_*`` column, or else every ``servo_*`` column; ``inputs=`` picks others by shell-style
  patterns (``"tendon_*_mm"``).
* tip: ``tip_x, tip_y, tip_z`` (by default in mm, as motion capture exports) or the softrnn layout's
  ``n<i>_x, n<i>_y, n<i>_z`` of the largest node ``i`` [m].
* any other column (a pattern label, a comment) is read as text and kept as ``labels`` when it is
  called ``pattern_label`` or ``label``, otherwise ignored.

Several sessions of one robot are several files; ``check_sessions`` refuses a set whose input
channels differ, or where one repeats rows of another. ``shift_inputs`` lines a command up with a
response that lags it by whole rows.
"""

from __future__ import annotations

import fnmatch
import hashlib
import math
import re
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from ..errors import SoftrnnInputError, bad, is_int
from ..io.csv_table import ACTUATION_COLUMN, CellWords, parse_cells, read_csv_lines, shown, time_steps
from ..io.schema import ACTUATION_UNITS

TIME_COLUMNS = ("time", "timestamp")
"""Accepted names of the time column [s], first match wins."""
LABEL_COLUMNS = ("pattern_label", "label")
"""Text columns kept as row labels (first match wins)."""
DEFAULT_INPUTS = ("act_*", "servo_*")
"""Input patterns tried in turn when none are given: the first that matches any column is used."""
POSITION_UNITS = {"m": 1.0, "mm": 1e-3, "cm": 1e-2}
"""Units the tip may be given in, with their factor to m."""
_SUFFIXES = ("mm", "m", "deg", "rad", "n", "a", "ma", "v", "kpa", "pa")
_UNIT_SUFFIX = re.compile(r"_(" + "|".join(_SUFFIXES) + r")$", re.IGNORECASE)
_SUFFIX_UNITS = {u.lower(): u for u in ACTUATION_UNITS if u.lower() in _SUFFIXES}
"""A unit suffix of a column name (``servo_1_mm``, ``chamber_a_kpa``), in any case, as the unit is spelled
(``io.schema.ACTUATION_UNITS``)."""
_NODE = re.compile(r"^n(0|[1-9][0-9]*)_([xyz])$")
_CELL = "line {line}, column {name!r}: {text} is not a finite number; fix or remove the row"
WORDS = CellWords(width="line {line}: {cells} cells for {width} columns; every row needs one value per header column",
                  empty="line {line}, column {name!r}: the cell is empty; fix or remove the row",
                  not_number=_CELL, not_finite=_CELL,
                  order="line {line}: the time {time!r} {what} the previous row's {previous!r}; sort the rows by "
                        "time and drop duplicated rows",
                  step="line {line}: the step from the time {previous!r} to {time!r} is not a finite number of "
                       "seconds; times must be in s")
"""How a recording's reader words a bad row, cell or time (``softrnn.io.csv_table.CellWords``)."""


@dataclass(frozen=True)
class Layout:
    """Which columns of a recording hold what.

    Parameters
    ----------
    inputs : tuple of str
        shell-style patterns of the input columns, in the order wanted (default: ``DEFAULT_INPUTS``,
        the first that matches)
    tip : tuple of 3 str
        the tip's x, y, z columns (default: ``tip_x, tip_y, tip_z``, else the largest node's
        ``n<i>_x, n<i>_y, n<i>_z``)
    position_unit : str
        the tip's unit, a key of ``POSITION_UNITS`` (default: ``mm`` for ``tip_*`` columns, ``m``
        for the softrnn layout's node columns)
    """

    inputs: tuple = ()
    tip: tuple | None = None
    position_unit: str | None = None

    def __post_init__(self):
        if isinstance(self.inputs, str):
            object.__setattr__(self, "inputs", tuple(s.strip() for s in self.inputs.split(",") if s.strip()))
        object.__setattr__(self, "inputs", tuple(self.inputs))
        if self.tip is not None:
            tip = tuple(s.strip() for s in self.tip.split(",")) if isinstance(self.tip, str) else tuple(self.tip)
            if len(tip) != 3 or not all(tip):
                raise bad("tip", self.tip, "three column names x,y,z, e.g. tip_x,tip_y,tip_z")
            object.__setattr__(self, "tip", tip)
        if self.position_unit is not None and self.position_unit not in POSITION_UNITS:
            raise bad("position_unit", self.position_unit, f"one of {', '.join(POSITION_UNITS)}")


@dataclass(frozen=True, eq=False)
class Recording:
    """One session of a robot, as recorded.

    Attributes
    ----------
    path : str
        the file it was read from ("" when built in memory)
    time : (T,) float64
        row times [s] from the file (strictly increasing, any spacing)
    inputs : (T, m) float64
        the commanded inputs, in the channels' units
    names : tuple of m str
        the input channels' names (the column names without unit suffix)
    units : tuple of m str
        their units ("" when the column names none)
    tip : (T, 3) float64
        the tracked tip [m]
    labels : tuple of T str
        the row labels (``pattern_label`` column), or () when there are none
    lag : int
        rows the inputs were shifted by (``shift_inputs``), 0 as read
    stretch : bool
        whether this is a stretch of rows cut out of a session (``rows``: the hold-out's stretches of a
        sole session, ``families.holdout_split``, or a fold of its patterns), not a session of its own;
        False as read
    """

    path: str
    time: np.ndarray
    inputs: np.ndarray
    names: tuple
    units: tuple
    tip: np.ndarray
    labels: tuple = ()
    lag: int = 0
    columns: tuple = field(default=(), repr=False)
    stretch: bool = False

    @property
    def n_rows(self) -> int:
        """T, the rows."""
        return int(self.time.size)

    @property
    def n_inputs(self) -> int:
        """m, the input channels."""
        return int(self.inputs.shape[1])

    @property
    def intervals(self) -> np.ndarray:
        """(T - 1,) the time between consecutive rows [s]."""
        return np.diff(self.time)

    def rows(self, start: int, stop: int) -> Recording:
        """The recording cut to rows ``start`` to ``stop`` (a Python slice of the rows), a ``stretch`` where
        that leaves rows out."""
        time = self.time[start:stop]
        return replace(self, time=time, inputs=self.inputs[start:stop], tip=self.tip[start:stop],
                       labels=self.labels[start:stop] if self.labels else (),
                       stretch=self.stretch or time.size < self.time.size)

    def commands_key(self) -> str:
        """A digest of what a model driven by the commands reads of the recording (its times, inputs,
        units and lag; not the tip): equal keys, equal predictions (the models' memos)."""
        h = hashlib.sha256(np.ascontiguousarray(self.time, dtype=float).tobytes())
        h.update(np.ascontiguousarray(self.inputs, dtype=float).tobytes())
        h.update(repr((self.units, self.lag)).encode())
        return h.hexdigest()

    def describe(self) -> dict:
        """A JSON-ready summary: rows, duration, interval range, channels and units."""
        steps = self.intervals
        return {"path": self.path, "rows": self.n_rows, "duration_s": float(self.time[-1] - self.time[0]),
                "interval_s": {"min": float(steps.min()), "median": float(np.median(steps)),
                               "max": float(steps.max())} if steps.size else None,
                "inputs": list(self.names), "input_units": list(self.units), "lag_rows": self.lag}


def _fail(path, message: str) -> SoftrnnInputError:
    return SoftrnnInputError(f"{path}: {message}")


def _columns(header: list[str], most: int = 12) -> str:
    """The header's columns for a message: the first ``most``, each shortened (``shown``)."""
    listed = ", ".join(shown(c, 30) for c in header[:most])
    return listed + (f", ... ({len(header)} columns)" if len(header) > most else "")


def _split_unit(column: str) -> tuple[str, str]:
    m = ACTUATION_COLUMN.match(column)
    if m:
        return m.group(1).lower(), (m.group(2) or "")
    m = _UNIT_SUFFIX.search(column)
    if m:
        return column[:m.start()], _SUFFIX_UNITS[m.group(1).lower()]
    return column, ""


def _pick_inputs(path, header: list[str], patterns: tuple) -> list[int]:
    tried = patterns or DEFAULT_INPUTS
    for pattern in ([tried] if patterns else [(p,) for p in tried]):
        picked: list[int] = []
        for p in pattern:
            hits = [j for j, c in enumerate(header) if fnmatch.fnmatchcase(c, p) and j not in picked]
            if patterns and not hits:
                raise _fail(path, f"no column matches the input pattern {p!r}; the columns are {_columns(header)}")
            picked += hits
        if picked:
            return picked
    raise _fail(path, f"no input columns (none matches {', '.join(tried)}); name them act_<name>[<unit>] or "
                      "servo_<id>_<unit>, or pick them with --inputs PATTERN")


def _pick_tip(path, header: list[str], layout: Layout) -> tuple[list[int], float]:
    if layout.tip is not None:
        missing = [c for c in layout.tip if c not in header]
        if missing:
            raise _fail(path, f"no tip column {missing[0]!r}; the columns are {_columns(header)}")
        cols = [header.index(c) for c in layout.tip]
        unit = layout.position_unit or ("m" if _NODE.match(layout.tip[0]) else "mm")
        return cols, POSITION_UNITS[unit]
    if all(c in header for c in ("tip_x", "tip_y", "tip_z")):
        return [header.index(f"tip_{a}") for a in "xyz"], POSITION_UNITS[layout.position_unit or "mm"]
    nodes = sorted({int(m.group(1)) for c in header if (m := _NODE.match(c))})
    for node in reversed(nodes):
        names = [f"n{node}_{a}" for a in "xyz"]
        if all(c in header for c in names):
            return [header.index(c) for c in names], POSITION_UNITS[layout.position_unit or "m"]
    raise _fail(path, "no tip columns: write tip_x, tip_y, tip_z (mm) or the node columns n<i>_x, n<i>_y, n<i>_z "
                      "(m), or name them with --tip X,Y,Z")


def read_recording(path, layout: Layout = Layout()) -> Recording:
    """Read one session (layout in the module docstring). Every problem is a one-line
    ``SoftrnnInputError`` naming the file, the line or column and the fix: a missing, folder,
    binary, UTF-16, semicolon-separated or empty file (``read_csv_lines``), too few rows, a header
    without a time, input or tip column, a row with another number of cells, a value that is not a
    finite number, a time that does not increase (unsorted or duplicated rows) or whose step
    overflows."""
    path = Path(path)
    lines = read_csv_lines(path, "a header (a time or timestamp column, the inputs, the tip) and at least 3 rows",
                           SoftrnnInputError, what="the recording")
    if len(lines) < 4:
        raise _fail(path, f"has {max(len(lines) - 1, 0)} data rows; a recording needs a header and at least 3 rows")
    header = [c.strip() for c in lines[0][1].split(",")]
    if len(set(header)) != len(header):
        dup = next(c for c in header if header.count(c) > 1)
        raise _fail(path, f"line {lines[0][0]} (header): the column {shown(dup)} appears twice; name every column "
                          "once")
    tcol = next((header.index(c) for c in TIME_COLUMNS if c in header), None)
    if tcol is None:
        raise _fail(path, f"line {lines[0][0]} (header): no time column; name the first column 'time' or "
                          f"'timestamp' (s); the columns are {_columns(header)}")
    icols = _pick_inputs(path, header, layout.inputs)
    pcols, scale = _pick_tip(path, header, layout)
    lcol = next((header.index(c) for c in LABEL_COLUMNS if c in header), None)
    rows = lines[1:]
    values = parse_cells(path, header, rows, [tcol, *icols, *pcols], words=WORDS, error=SoftrnnInputError)
    labels = [line.split(",")[lcol].strip() for _, line in rows] if lcol is not None else []
    time = values[:, 0]
    time_steps(path, rows, time, words=WORDS, error=SoftrnnInputError)
    split = [_split_unit(header[j]) for j in icols]
    return Recording(path=str(path), time=time, inputs=values[:, 1:1 + len(icols)].copy(),
                     names=tuple(n for n, _ in split), units=tuple(u for _, u in split),
                     tip=values[:, 1 + len(icols):] * scale, labels=tuple(labels),
                     columns=tuple(header[j] for j in icols))


REPEATED_SHARE = 0.1
"""``check_sessions`` refuses two sessions that share this share of the shorter one's rows, or more (and
two rows at least): a file that is part of another. Simulated sessions may share a row or a few (each
starting at rest at time 0, noise-free), which is no repeat of a recording."""


def check_sessions(recordings) -> None:
    """Refuse sessions of one robot whose input channels differ (names or units, in order), and two sessions
    that share rows (the same time, inputs and tip, to the bit, ``_row_keys``; ``REPEATED_SHARE``): a file
    that is part of another (a recording's excerpt passed beside it) would count its rows twice, in
    training, or in training and validation."""
    first = recordings[0]
    for rec in recordings[1:]:
        if rec.names != first.names or rec.units != first.units:
            theirs = ", ".join(rec.columns or rec.names)
            ours = ", ".join(first.columns or first.names)
            raise _fail(rec.path, f"its input channels ({theirs}) differ from those of {first.path} ({ours}); "
                                  "every session of a robot needs the same input columns in the same order")
    keys = [_row_keys(rec) for rec in recordings]
    for j, rec in enumerate(recordings):
        for i, other in enumerate(recordings[:j]):
            shared = len(keys[j] & keys[i]) if rec.n_inputs == other.n_inputs else 0
            if shared >= max(2, math.ceil(REPEATED_SHARE * min(rec.n_rows, other.n_rows))):
                raise _fail(rec.path, f"repeats {shared} of its {rec.n_rows} rows of {other.path or 'another session'} "
                                      "(the same time, inputs and tip); pass each recorded row once: leave out "
                                      "the file that is part of the other, or the rows they share")


def _row_keys(r: Recording) -> set:
    """The distinct rows of ``r`` (time, inputs, tip) as bytes: a copy of a recording, or of part of it, shares
    them; two recordings of a robot never measure the very same tip."""
    return {row.tobytes() for row in np.hstack([r.time[:, None], r.inputs, r.tip])}


def shift_inputs(recording: Recording, lag: int) -> Recording:
    """The recording with row k's tip paired with the inputs of row k - ``lag`` (a response that
    lags its command by ``lag`` rows); the first ``lag`` rows are dropped."""
    if not is_int(lag) or lag < 0:
        raise bad("lag", lag, "a whole number of rows >= 0")
    if lag >= recording.n_rows - 2:
        raise bad("lag", lag, f"fewer rows than the recording {recording.path} holds ({recording.n_rows}); "
                              "a lag of a few rows at most")
    if lag == 0:
        return recording
    n = recording.n_rows
    return Recording(path=recording.path, time=recording.time[lag:], inputs=recording.inputs[:n - lag],
                     names=recording.names, units=recording.units, tip=recording.tip[lag:],
                     labels=recording.labels[lag:] if recording.labels else (), lag=recording.lag + lag,
                     columns=recording.columns)


AUTO_LAGS = 5
"""``estimate_lag`` tries 0..AUTO_LAGS rows first, and more while the largest lag tried fits best."""


def _lag_residual(recordings, lag: int) -> float:
    """Residual RMS [m] of the tip fitted by a linear map of the inputs ``lag`` rows earlier."""
    shifted = [shift_inputs(r, lag) for r in recordings]
    X = np.vstack([np.hstack([s.inputs, np.ones((s.n_rows, 1))]) for s in shifted])
    Y = np.vstack([s.tip for s in shifted])
    W = np.linalg.lstsq(X, Y, rcond=None)[0]
    return float(np.sqrt(np.mean(np.sum((X @ W - Y) ** 2, axis=1))))


def estimate_lag(recordings, max_lag: int | None = None) -> tuple[int, dict]:
    """The command-to-response delay in rows: the lag whose inputs explain the tip best by a linear
    map fitted on ``recordings`` (least squares, the residual RMS [m] compared). ``max_lag``: try
    0..max_lag; None: 0..``AUTO_LAGS``, then twice as far each time the largest lag tried fits best,
    up to a tenth of the shortest session's rows (a slow response recorded at a high rate lags
    many rows). Returns (lag, {lag: residual RMS [m]}) so the choice can be reported."""
    shortest = min(r.n_rows for r in recordings)
    limit = max_lag if max_lag is not None else max(AUTO_LAGS, shortest // 10)
    top = limit if max_lag is not None else min(AUTO_LAGS, limit)
    scores = {}
    while True:
        for lag in range(len(scores), top + 1):
            if lag >= shortest - 2:
                limit = top = len(scores) - 1
                break
            scores[lag] = _lag_residual(recordings, lag)
        best = min(scores, key=scores.get)
        if best < top or top >= limit:
            return best, scores
        top = min(2 * top, limit)
