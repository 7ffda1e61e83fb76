"""Lab data in CSV <-> the HDF5 dataset format (layout and rules: docs/csv-format.md).

A CSV holds one trajectory: a header line, then one line per sample::

    time,n0_x,n0_y,n0_z,n10_x,n10_y,n10_z,n10_fx,n10_fy,n10_fz
    0.00,0,0,0,0.5,0,0,0,0,0
    0.01,0,0,0,0.5,0,-0.0003,0,0,-0.05

``time`` [s] comes first; then, per node i (0-based rod node index), ``n{i}_x, n{i}_y, n{i}_z`` [m]
(required), optionally ``n{i}_qw, n{i}_qx, n{i}_qy, n{i}_qz`` (unit quaternion, world frame; for every
node or none), ``n{i}_fx, n{i}_fy, n{i}_fz`` [N] and ``n{i}_tx, n{i}_ty, n{i}_tz`` [N m] (applied
wrench in the world frame; zero where absent) and, anywhere after ``time``, actuation inputs
``act_<name>[<unit>]`` (e.g. ``act_tendon_1[N]``, ``act_p_chamber_2[kPa]``; the unit one of
``softrnn.io.schema.ACTUATION_UNITS``). Import validates everything before anything is written and
writes atomically, so a bad CSV leaves no output file.

A robot recording as it comes from the lab (a ``timestamp``, inputs such as ``servo_1_mm``, the tip
as ``tip_x, tip_y, tip_z``; read by ``softrnn.lab.recording.read_recording``) is written by
``recording_trajectory`` (checks, no writing) and ``write_recording`` (the tip as one stored node,
the inputs as actuation channels, time from 0); ``csv_layout`` tells the two layouts apart.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np

from ..errors import bad
from ..files import atomic_output
from ..progress import Progress
from .csv_table import ACTUATION_COLUMN, ACTUATION_PREFIX, parse_cells, read_csv_lines, shown, time_steps
from .reader import Dataset, read_dataset
from .schema import ACTUATION_NAME, ACTUATION_UNITS, POSITION_LIMIT_M, DatasetError
from .writer import DatasetWriter

_GROUPS = {
    "positions": ("x", "y", "z"),
    "quaternions": ("qw", "qx", "qy", "qz"),
    "forces": ("fx", "fy", "fz"),
    "torques": ("tx", "ty", "tz"),
}
_COMPONENT = {c: (field, k) for field, comps in _GROUPS.items() for k, c in enumerate(comps)}
_NAME = re.compile(r"^n(0|[1-9][0-9]*)_([a-z]+)$")
PATTERN = ("time, then per node i (0-based): n{i}_x, n{i}_y, n{i}_z, optional n{i}_qw, n{i}_qx, n{i}_qy, "
           "n{i}_qz, optional n{i}_fx, n{i}_fy, n{i}_fz and n{i}_tx, n{i}_ty, n{i}_tz, and optional actuation "
           "columns act_<name>[<unit>]")
_ACT_EXAMPLE = "act_<name>[<unit>], e.g. act_tendon_1[N] or act_p_chamber_2[kPa]"
QUATERNION_IMPORT_TOLERANCE = 1e-3
"""CSV quaternions farther than this from unit norm are rejected; closer ones are normalised
(those within 1e-6 of unit norm are stored as given, so that exported data re-imports exactly)."""


def _fail(path: Path, message: str) -> DatasetError:
    return DatasetError(f"{path}: {message}")


def _read_lines(path: Path) -> list[tuple[int, str]]:
    return read_csv_lines(path, f"a header with the columns {PATTERN}")


def _actuation_column(path: Path, number: int, text: str) -> tuple[str, str]:
    """(channel name, unit) of the actuation column ``text`` (``act_<name>[<unit>]``), or a
    one-line DatasetError naming the column, what is wrong and the fix."""
    where = f"line {number} (header), column {text!r}"
    m = ACTUATION_COLUMN.match(text)
    if not m:
        raise _fail(path, f"{where}: is not an actuation column; write {_ACT_EXAMPLE}")
    name, unit = m.group(1).lower(), m.group(2)
    if not ACTUATION_NAME.match(name):
        raise _fail(path, f"{where}: the channel name {name!r} is invalid; use lower-case letters, digits and '_', "
                          f"starting with a letter: {_ACT_EXAMPLE}")
    units = ", ".join(ACTUATION_UNITS)
    if unit is None or not unit:
        raise _fail(path, f"{where}: has no unit; write it as act_{name}[<unit>] with one of: {units}")
    if unit not in ACTUATION_UNITS:
        close = [u for u in ACTUATION_UNITS if u.lower() == unit.lower()]
        hint = f" (units are case-sensitive: did you mean {close[0]!r}?)" if close else ""
        raise _fail(path, f"{where}: the unit {unit!r} is not recognised{hint}; use one of: {units}")
    return name, unit


def _parse_header(path: Path, number: int, line: str) -> tuple[list[str], dict, dict]:
    """Column names (actuation columns as written, the others lower-case); per node, the columns
    of each field: {node: {field: [col, ...]}}; the actuation channels {name: (column, unit)}, in
    column order."""
    raw = [c.strip() for c in line.split(",")]
    names = [c if c.lower().startswith(ACTUATION_PREFIX) else c.lower() for c in raw]
    for j, name in enumerate(names):
        if not name:
            raise _fail(path, f"line {number} (header): column {j + 1} has no name (a stray or trailing comma?); "
                              f"expected {PATTERN}")
    if names[0] != "time":
        raise _fail(path, f"line {number} (header): the first column is {shown(names[0])}; expected 'time' [s], "
                          f"then {PATTERN.split(', then ')[1]}")
    seen = {}
    layout: dict = {}
    channels: dict[str, tuple[int, str]] = {}
    for j, name in enumerate(names):
        actuation = j > 0 and name.lower().startswith(ACTUATION_PREFIX)
        key = ACTUATION_PREFIX + _actuation_column(path, number, name)[0] if actuation else name
        if key in seen:
            raise _fail(path, f"line {number} (header): column {name!r} appears twice (columns {seen[key] + 1} "
                              f"and {j + 1}); keep one")
        seen[key] = j
        if j == 0:
            continue
        if actuation:
            channel, unit = _actuation_column(path, number, name)
            channels[channel] = (j, unit)
            continue
        m = _NAME.match(name)
        if not m or m.group(2) not in _COMPONENT:
            hint = (f"; actuation columns are named {_ACT_EXAMPLE}" if "[" in name or "]" in name
                    else f"; expected {PATTERN}")
            given = raw[j] if "[" in name or "]" in name else name
            raise _fail(path, f"line {number} (header): column {shown(given)} is not recognised{hint}")
        node, (field, k) = int(m.group(1)), _COMPONENT[m.group(2)]
        layout.setdefault(node, {}).setdefault(field, [None] * len(_GROUPS[field]))[k] = j
    if not layout:
        raise _fail(path, f"line {number} (header): no node columns; expected {PATTERN}")
    _check_node_groups(path, number, layout)
    return names, layout, channels


def _check_node_groups(path: Path, number: int, layout: dict) -> None:
    """Every node has its position and only whole groups (x, y, z; the quaternion; the force;
    the torque); orientations for every node or none."""
    with_q = sorted(a for a, f in layout.items() if "quaternions" in f)
    for node in sorted(layout):
        fields = layout[node]
        if "positions" not in fields:
            fields["positions"] = [None] * 3
        for field, cols in fields.items():
            missing = [f"n{node}_{c}" for c, col in zip(_GROUPS[field], cols) if col is None]
            if missing:
                what = {"positions": "every node needs n{i}_x, n{i}_y, n{i}_z",
                        "quaternions": "orientations need all of n{i}_qw, n{i}_qx, n{i}_qy, n{i}_qz",
                        "forces": "a force needs all of n{i}_fx, n{i}_fy, n{i}_fz",
                        "torques": "a torque needs all of n{i}_tx, n{i}_ty, n{i}_tz"}[field]
                raise _fail(path, f"line {number} (header): missing column{'s' if len(missing) > 1 else ''} "
                                  f"{', '.join(missing)} (node {node}: {what})")
        if with_q and "quaternions" not in fields:
            missing = ", ".join(f"n{node}_{c}" for c in _GROUPS["quaternions"])
            raise _fail(path, f"line {number} (header): missing columns {missing}: orientations are given for "
                              f"node {with_q[0]}, so every node needs n{{i}}_qw..n{{i}}_qz (or no node has them)")


def read_csv(csv_path, progress: Progress | None = None) -> dict:
    """Parse and validate a lab CSV without writing anything; ``progress(rows done, rows)`` while
    its values are converted (``PARSE_BLOCK_ROWS`` at a time).

    Returns
    -------
    dict
        ``time`` (T,) float64 [s], ``nodes`` (N,) int64 (ascending), ``positions`` (T, N, 3),
        ``quaternions`` (T, N, 4) (identity where absent), ``forces``, ``torques`` (T, N, 3), all
        float64, ``has_orientations`` (bool), ``force_nodes``, ``torque_nodes`` (nodes with wrench
        columns), ``actuation`` (T, m) float64 (the ``act_<name>[<unit>]`` columns in header order;
        m = 0 without any) and ``actuation_units`` ({name: unit}, in that order).

    Raises
    ------
    DatasetError
        One line naming the file, the line and the column of the first problem.
    """
    path = Path(csv_path)
    lines = _read_lines(path)
    names, layout, channels = _parse_header(path, *lines[0])
    rows = lines[1:]
    if len(rows) < 2:
        raise _fail(path, f"has {len(rows)} data row{'s' if len(rows) != 1 else ''} after the header; at least 2 "
                          f"samples are needed")
    values = parse_cells(path, names, rows, progress=progress)
    time = values[:, 0].copy()
    time_steps(path, rows, time)   # checked: every step positive and finite
    nodes = np.array(sorted(layout), dtype=np.int64)
    T, N = len(rows), nodes.size
    arrays = {field: np.zeros((T, N, len(comps))) for field, comps in _GROUPS.items()}
    arrays["quaternions"][..., 0] = 1.0
    for n, node in enumerate(nodes):
        for field, cols in layout[int(node)].items():
            arrays[field][:, n, :] = values[:, cols]
    pos = arrays["positions"]
    if np.abs(pos).max() > POSITION_LIMIT_M:
        i, n, k = (int(v) for v in np.argwhere(np.abs(pos) > POSITION_LIMIT_M)[0])
        col = f"n{nodes[n]}_{'xyz'[k]}"
        raise _fail(path, f"line {rows[i][0]}, column {col!r}: {pos[i, n, k]:g} m is beyond {POSITION_LIMIT_M:g} m; "
                          f"positions must be in metres (divide millimetres by 1000)")
    has_q = any("quaternions" in f for f in layout.values())
    if has_q:
        q = arrays["quaternions"]
        norm = np.sqrt(np.sum(q ** 2, axis=-1))
        off = np.abs(norm - 1.0)
        if off.max() > QUATERNION_IMPORT_TOLERANCE:
            i, n = (int(v) for v in np.unravel_index(int(np.argmax(off)), off.shape))
            raise _fail(path, f"line {rows[i][0]}: the quaternion n{nodes[n]}_qw..n{nodes[n]}_qz has norm "
                              f"{norm[i, n]:.6g}; expected a unit quaternion, scalar first (qw, qx, qy, qz)")
        fix = off > 1e-6
        q[fix] = q[fix] / norm[fix][:, None]
    return {"time": time, "nodes": nodes, **arrays, "has_orientations": has_q,
            "force_nodes": [int(a) for a in nodes if "forces" in layout[int(a)]],
            "torque_nodes": [int(a) for a in nodes if "torques" in layout[int(a)]],
            "actuation": values[:, [c for c, _ in channels.values()]].reshape(T, len(channels)),
            "actuation_units": {name: unit for name, (_, unit) in channels.items()}}


# ----------------------------------------------------------------------------------------- import / export
class _Chunk:
    def __init__(self, data: dict):
        self.time = data["time"]
        self.actuation = data["actuation"]
        for field in _GROUPS:
            setattr(self, field, data[field])


def import_csv(csv_path, out_path, *, rod_length: float | None = None, seed: int | None = None,
               scenario_text: str = "", progress: Progress | None = None) -> Dataset:
    """Convert a lab CSV ``csv_path`` into the HDF5 dataset ``out_path``, atomically
    (docs/csv-format.md); returns the file as read back.

    ``out_path`` is replaced if it exists and untouched when the CSV is invalid. ``rod_length`` L
    [m] is stored as ``attrs['rod'] = {'length': L}`` (None: no rod record), ``seed`` as the
    dataset's seed, ``scenario_text`` as free text describing the experiment; ``progress(rows
    done, rows)`` while the values are converted. The dataset's ``attrs``: ``dt`` the median time
    step [s] (the real times are kept), ``source='csv'``, ``source_file``, ``has_orientations``,
    ``force_nodes``, ``torque_nodes``; its ``actuation`` (T, m) and ``actuation_units`` hold the
    ``act_<name>[<unit>]`` columns (m = 0 without any).
    """
    csv_path, out_path = Path(csv_path), Path(out_path)
    if rod_length is not None and (isinstance(rod_length, bool) or not isinstance(rod_length, (int, float))
                                   or not math.isfinite(rod_length) or rod_length <= 0):
        raise bad("rod_length", rod_length, "a positive rod length in m")
    if out_path.exists() and csv_path.exists() and out_path.resolve() == csv_path.resolve():
        raise bad("out_path", str(out_path), "an output file other than the CSV itself")
    data = read_csv(csv_path, progress)
    steps = np.diff(data["time"])
    attrs = {"source": "csv", "source_file": csv_path.name, "has_orientations": data["has_orientations"],
             "force_nodes": data["force_nodes"], "torque_nodes": data["torque_nodes"]}
    with DatasetWriter(out_path, nodes=data["nodes"], n_samples=data["time"].size, dt=float(np.median(steps)),
                       rod=None if rod_length is None else {"length": float(rod_length)},
                       scenario_text=scenario_text, seed=seed, attrs=attrs,
                       actuation_units=data["actuation_units"]) as writer:
        writer.append(_Chunk(data))
    return read_dataset(out_path)


def export_csv(dataset, csv_path) -> None:
    """Write a dataset as CSV in the import layout, atomically (the inverse of ``import_csv``).

    Parameters
    ----------
    dataset : Dataset or str or Path
        The dataset, or the path of a dataset file (single trajectory).
    csv_path : str or Path
        The CSV file to write.

    Notes
    -----
    Columns: ``time`` (shortest exact repr of the float64 times), then per node x, y, z, the
    quaternion (unless ``dataset.has_orientations`` is False) and the force/torque columns of the
    nodes that have a nonzero value or are listed in ``attrs['force_nodes']``/``['torque_nodes']``,
    then the actuation channels as ``act_<name>[<unit>]``.
    Values are written with 9 significant digits, which re-import to the identical float32.
    """
    if not isinstance(dataset, Dataset):
        dataset = read_dataset(dataset)
    csv_path = Path(csv_path)
    header, columns = ["time"], []
    listed = {f: set(dataset.attrs.get(f"{f[:-1]}_nodes", ())) for f in ("forces", "torques")}
    for n, node in enumerate(dataset.nodes):
        fields = ["positions"] + (["quaternions"] if dataset.has_orientations else [])
        for f in ("forces", "torques"):
            arr = getattr(dataset, f)[:, n]
            if int(node) in listed[f] or np.any(arr != 0):
                fields.append(f)
        for f in fields:
            for k, c in enumerate(_GROUPS[f]):
                header.append(f"n{int(node)}_{c}")
                columns.append(getattr(dataset, f)[:, n, k])
    for j, (name, unit) in enumerate(dataset.actuation_units.items()):
        header.append(f"{ACTUATION_PREFIX}{name}[{unit}]")
        columns.append(dataset.actuation[:, j])
    block = np.column_stack(columns).astype(np.float64) if columns else np.zeros((dataset.n_samples, 0))
    with atomic_output(csv_path) as tmp, open(tmp, "w", encoding="utf-8", newline="\n") as fh:
        fh.write(",".join(header) + "\n")
        fmt = ",".join(["%.9g"] * block.shape[1])
        for t, row in zip(dataset.time, block):
            fh.write(repr(float(t)) + "," + fmt % tuple(row) + "\n")


# ------------------------------------------------------------------------------------------ robot recordings
RECORDING_SIGNS = ("timestamp", "tip_x", "tip_y", "tip_z", "servo_")
"""Header names (or, for ``servo_``, a prefix) that mark a robot recording as it comes from the lab
(docs/csv-format.md, "Robot recordings"), read by ``softrnn.lab.recording.read_recording``."""
LABELS_LIMIT = 16384
"""Most characters of the row labels' runs (as JSON) stored in a recording's attrs; longer are left out."""
_NODE_COLUMN = re.compile(r"^n[0-9]+_[a-z]+$")


def csv_layout(csv_path, *, recording: bool = False) -> str:
    """Which layout a CSV is in, from its header: ``"nodes"`` (softrnn's layout: any ``n{i}_...``
    column, read by ``read_csv``/``import_csv``) or ``"recording"`` (a robot recording: no node
    columns, and a ``timestamp``, ``tip_x``/``tip_y``/``tip_z`` or ``servo_*`` column, or
    ``recording=True`` when the caller was told how to read one). A file that cannot be read is
    ``"nodes"`` (``"recording"`` with ``recording=True``), so that its reader reports it."""
    try:
        lines = _read_lines(Path(csv_path))
    except DatasetError:
        return "recording" if recording else "nodes"
    names = [c.strip().lower() for c in lines[0][1].split(",")]
    if any(_NODE_COLUMN.match(n) for n in names):
        return "nodes"
    signs = any(n in RECORDING_SIGNS or n.startswith("servo_") for n in names)
    return "recording" if signs or recording else "nodes"


def _recording_unit(source, column: str, unit: str) -> str:
    """The ``ACTUATION_UNITS`` entry of an input column's unit ('' -> '1'); the ``<name>_<unit>``
    suffix style is matched ignoring case (``servo_1_N`` -> ``N``), ``act_<name>[<unit>]`` exactly."""
    unit = unit or "1"
    if unit in ACTUATION_UNITS:
        return unit
    close = [u for u in ACTUATION_UNITS if u.lower() == unit.lower()]
    if len(close) == 1 and not column.lower().startswith(ACTUATION_PREFIX):
        return close[0]
    hint = f" (units are case-sensitive: did you mean {close[0]!r}?)" if close else ""
    raise _fail(source, f"input column {column!r}: the unit {unit!r} is not recognised{hint}; use one of: "
                        f"{', '.join(ACTUATION_UNITS)}")


def _label_runs(labels) -> list:
    """Row labels as runs ``[label, first row, rows]`` (consecutive equal labels together)."""
    runs: list = []
    for i, label in enumerate(labels):
        if runs and runs[-1][0] == label:
            runs[-1][2] += 1
        else:
            runs.append([label, i, 1])
    return runs


def recording_trajectory(time, tip, inputs, names, units, *, columns=(), labels=(), source="") -> dict:
    """Check a robot recording's arrays and turn them into a dataset's content, writing nothing
    (docs/csv-format.md, "Robot recordings").

    ``time`` (T,) [s] as recorded (any origin), strictly increasing; ``tip`` (T, 3) [m];
    ``inputs`` (T, m) in their channels' units; ``names``, ``units`` one per channel (``""``:
    dimensionless, stored as ``1``; a ``<name>_<unit>`` column's unit matched ignoring case);
    ``columns`` the column names for the messages (default: the names); ``labels`` one per row, or
    (); ``source`` the file named in the messages. Returns a dict: ``time`` (T,) [s] from 0,
    ``time_origin_s`` (the first row's recorded time), ``tip`` (T, 3) [m], ``actuation`` (T, m),
    ``actuation_units`` ({name: unit}), ``labels`` (runs ``[label, first row, rows]``, or None
    without labels or beyond ``LABELS_LIMIT`` characters of JSON) and ``label_runs`` (their count).
    Raises a one-line ``DatasetError`` naming the source, the column or row and the fix.
    """
    source = source or "recording"
    time = np.asarray(time, dtype=np.float64)
    tip = np.asarray(tip, dtype=np.float64)
    inputs = np.asarray(inputs, dtype=np.float64)
    T = time.shape[0] if time.ndim == 1 else -1
    if T < 2 or tip.shape != (T, 3) or inputs.ndim != 2 or inputs.shape[0] != T:
        raise _fail(source, f"time {time.shape}, tip {tip.shape} and inputs {inputs.shape} do not fit; expected "
                            "(T,), (T, 3) and (T, m) with T >= 2")
    if len(names) != inputs.shape[1] or len(units) != inputs.shape[1]:
        raise _fail(source, f"{inputs.shape[1]} input columns but {len(names)} names and {len(units)} units; "
                            "give one name and unit per column")
    columns = tuple(columns) or tuple(names)
    for what, arr in (("time", time), ("tip", tip), ("inputs", inputs)):
        if not np.isfinite(arr).all():
            raise _fail(source, f"{what} has a non-finite value at row {int(np.argwhere(~np.isfinite(arr))[0][0])}; "
                                "every value must be finite")
    steps = np.diff(time)
    if np.any(steps <= 0):
        i = int(np.argmax(steps <= 0))
        raise _fail(source, f"row {i + 1}: time {float(time[i + 1])!r} is not after {float(time[i])!r}; rows must "
                            "be in strictly increasing time order, without duplicates")
    reach = np.abs(tip)
    if reach.max() > POSITION_LIMIT_M:
        i, k = (int(v) for v in np.argwhere(reach > POSITION_LIMIT_M)[0])
        raise _fail(source, f"row {i}: the tip's {'xyz'[k]} is {tip[i, k]:g} m, beyond {POSITION_LIMIT_M:g} m; "
                            "check the position unit (mm, cm or m)")
    channels: dict[str, str] = {}
    for name, unit, column in zip(names, units, columns):
        key = str(name).lower()
        if not ACTUATION_NAME.match(key):
            raise _fail(source, f"input column {column!r}: the channel name {key!r} is invalid; name input columns "
                                "with a letter, then letters, digits or '_' (e.g. servo_1_mm)")
        if key in channels:
            raise _fail(source, f"input column {column!r}: the channel {key!r} appears twice; name every input "
                                "channel once")
        channels[key] = _recording_unit(source, column, str(unit))
    if len(labels) and len(labels) != T:
        raise _fail(source, f"{len(labels)} labels for {T} rows; give one label per row, or none")
    runs = _label_runs(labels) if len(labels) else []
    stored = runs if runs and len(json.dumps(runs)) <= LABELS_LIMIT else None
    return {"time": time - time[0], "time_origin_s": float(time[0]), "tip": tip, "actuation": inputs,
            "actuation_units": channels, "labels": stored, "label_runs": len(runs)}


def write_recording(out_path, recording: dict, *, tip_node: int = 1, rod_length: float | None = None,
                    seed: int | None = None, scenario_text: str = "", attrs: dict | None = None) -> Dataset:
    """Write a robot recording (``recording_trajectory``'s dict) as a dataset, atomically.

    The tip is the one stored node, ``tip_node`` (``n_nodes_total`` = ``tip_node`` + 1), positions
    in m, no orientations (identity placeholders), zero forces and torques; the inputs are the
    ``actuation`` channels. ``time`` starts at 0 and ``dt`` is the median step. ``attrs``:
    ``source='recording'``, ``time_origin_s``, ``has_orientations=False``, empty ``force_nodes`` and
    ``torque_nodes``, ``labels`` (when stored) and the caller's ``attrs`` (e.g. ``source_file``,
    ``lag_rows``). Returns the file as read back.
    """
    if isinstance(tip_node, bool) or not isinstance(tip_node, (int, np.integer)) or tip_node < 0:
        raise bad("tip_node", tip_node, "a node index >= 0")
    if rod_length is not None and (isinstance(rod_length, bool) or not isinstance(rod_length, (int, float))
                                   or not math.isfinite(rod_length) or rod_length <= 0):
        raise bad("rod_length", rod_length, "a positive rod length in m")
    time, tip = recording["time"], recording["tip"]
    T = time.size
    meta = {"source": "recording", "time_origin_s": recording["time_origin_s"], "has_orientations": False,
            "force_nodes": [], "torque_nodes": []}
    if recording.get("labels") is not None:
        meta["labels"] = recording["labels"]
    meta.update(attrs or {})
    quaternions = np.zeros((T, 1, 4))
    quaternions[..., 0] = 1.0
    data = {"time": time, "actuation": recording["actuation"], "positions": tip[:, None, :],
            "quaternions": quaternions, "forces": np.zeros((T, 1, 3)), "torques": np.zeros((T, 1, 3))}
    out_path = Path(out_path)
    with DatasetWriter(out_path, nodes=[int(tip_node)], n_samples=T, dt=float(np.median(np.diff(time))),
                       rod=None if rod_length is None else {"length": float(rod_length)},
                       scenario_text=scenario_text, seed=seed, attrs=meta,
                       actuation_units=recording["actuation_units"]) as writer:
        writer.append(_Chunk(data))
    return read_dataset(out_path)
