"""softrnn import-csv LAB.csv -o DATA.h5: turn lab data (docs/csv-format.md) into a dataset file;
several sessions of a robot (A.csv B.csv -o FOLDER) into one file each."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from ..errors import bad
from ..files import atomic_outputs, prepare_output
from ._names import AUTO_LAGS
from ._progress import DelayedBar

if TYPE_CHECKING:
    from ..lab.recording import Layout

NAME = "import-csv"
HELP = ("convert a lab CSV (time, node positions, optional orientations, wrenches and actuation inputs) or a "
        "robot recording (timestamp, inputs, tip) into a dataset file")
_RECORDING_OPTIONS = (("inputs", "--inputs"), ("tip", "--tip"), ("position_unit", "--position-unit"),
                      ("tip_node", "--tip-node"), ("lag", "--lag"))


def add_args(p):
    p.add_argument("csv", nargs="+", help="CSV file(s), layout in docs/csv-format.md (e.g. examples/lab_data.csv); "
                                          "several: one dataset each, in the -o folder")
    p.add_argument("-o", "--output", required=True, metavar="PATH",
                   help="HDF5 dataset to write (a folder for several CSVs: FOLDER/<csv name>.h5 each)")
    p.add_argument("--length", type=float, default=None, metavar="L", help="rod length in m (recorded)")
    p.add_argument("--seed", type=int, default=None, help="seed to record with the data")
    p.add_argument("--scenario", default="", metavar="TEXT", help="free text describing the experiment")
    p.add_argument("--overwrite", action="store_true", help="replace the -o file(s) if they exist (default: refuse)")
    p.add_argument("--quiet", action="store_true", help="no progress bar while a large CSV is read")
    g = p.add_argument_group("robot recordings (timestamp, inputs, tip_x/y/z; docs/csv-format.md)")
    g.add_argument("--inputs", default=None, metavar="PATTERN[,PATTERN]",
                   help="the input columns, shell-style patterns (default: act_*, else servo_*)")
    g.add_argument("--tip", default=None, metavar="X,Y,Z", help="the tip's columns (default: tip_x,tip_y,tip_z)")
    g.add_argument("--position-unit", default=None, metavar="mm|cm|m",
                   help="unit of the tip columns (default: mm for tip_*, m for n<i>_*)")
    g.add_argument("--tip-node", type=int, default=None, metavar="N",
                   help="rod node index the tip is stored as (default: 1, so the rod has 2 nodes)")
    g.add_argument("--lag", default=None, metavar="N|auto",
                   help="pair each row's tip with the inputs N rows earlier (default: 0); auto: estimate "
                        f"N over all sessions (0..{AUTO_LAGS} rows, further while the largest fits best) and "
                        "print the scores")


def _check_args(args) -> tuple:
    """(lag: int or 'auto', recording options given) after checking every option's value."""
    from ..lab.recording import POSITION_UNITS

    if args.length is not None and not args.length > 0:
        raise bad("--length", args.length, "a positive rod length in m")
    if args.position_unit is not None and args.position_unit not in POSITION_UNITS:
        raise bad("--position-unit", args.position_unit, f"one of {', '.join(POSITION_UNITS)}")
    if args.tip is not None and (len(args.tip.split(",")) != 3 or not all(s.strip() for s in args.tip.split(","))):
        raise bad("--tip", args.tip, "three column names X,Y,Z, e.g. tip_x,tip_y,tip_z")
    if args.inputs is not None and not any(s.strip() for s in args.inputs.split(",")):
        raise bad("--inputs", args.inputs, "shell-style patterns of the input columns, e.g. servo_*")
    if args.tip_node is not None and args.tip_node < 0:
        raise bad("--tip-node", args.tip_node, "a rod node index >= 0")
    lag = 0
    if args.lag is not None:
        text = args.lag.strip().lower()
        if text == "auto":
            lag = "auto"
        elif text.isdigit():
            lag = int(text)
        else:
            raise bad("--lag", args.lag, "a whole number of rows >= 0, or auto")
    given = [(attr, flag) for attr, flag in _RECORDING_OPTIONS if getattr(args, attr) is not None]
    return lag, given


def _outputs(args) -> list:
    """The file each CSV is written to, after checking -o (a file for one CSV, else a folder)."""
    csvs = [Path(c) for c in args.csv]
    if len(csvs) == 1:
        prepare_output(args.output, "-o", overwrite=args.overwrite)
        return [Path(args.output)]
    out = Path(args.output)
    if out.suffix.lower() in (".h5", ".hdf5") and not out.is_dir():
        raise bad("-o", args.output, f"a folder for {len(csvs)} CSVs (one <csv name>.h5 each), e.g. -o sessions/")
    names = [c.stem + ".h5" for c in csvs]
    for i, name in enumerate(names):
        if name in names[:i]:
            raise bad("csv", str(csvs[i]), f"CSV files with different names (two would be written as {out / name})")
    prepare_output(out, "-o", kind="folder", holds=names, overwrite=args.overwrite)
    return [out / name for name in names]


def _layout(args) -> Layout:
    from ..lab.recording import Layout

    return Layout(inputs=args.inputs or (), tip=args.tip, position_unit=args.position_unit)


def _lag(recordings: list, lag) -> tuple:
    """(lag in rows, {lag: residual RMS [m]} or None): checked against every session's length, or
    estimated (and printed)."""
    from ..lab.recording import estimate_lag

    if lag == "auto":
        best, scores = estimate_lag(recordings)
        shown = ", ".join(f"{k}: {v * 1e3:.4g}" for k, v in scores.items())
        print(f"lag: {best} row{'s' if best != 1 else ''} estimated (residual RMS of a linear fit of the tip "
              f"to the inputs, mm, per lag in rows: {shown})")
        return best, scores
    for rec in recordings:
        if lag >= rec.n_rows - 2:
            raise bad("--lag", lag, f"fewer rows than the recording {rec.path} holds less 2 ({rec.n_rows} rows, "
                                    f"so at most {rec.n_rows - 3}); a lag of a few rows at most")
    return lag, None


def _write_all(pairs: list) -> None:
    """Write every output (``pairs`` of (path, write function)) to a hidden temporary name beside it,
    then rename them all: an error leaves no output (and a folder made here is removed)."""
    made = []
    folder = pairs[0][0].parent
    if not folder.exists():
        folder.mkdir(parents=True)
        made.append(folder)
    try:
        with atomic_outputs([out for out, _ in pairs]) as temps:
            for (_, write), tmp in zip(pairs, temps):
                write(Path(tmp))
    except BaseException:
        for f in made:
            if not any(f.iterdir()):
                f.rmdir()
        raise


def _describe_nodes(out, ds) -> str:
    extras = []
    if not ds.has_orientations:
        extras.append("no orientations (identity placeholders)")
    if ds.attrs.get("force_nodes") or ds.attrs.get("torque_nodes"):
        extras.append(f"wrenches at nodes {sorted(set(ds.attrs['force_nodes']) | set(ds.attrs['torque_nodes']))}")
    else:
        extras.append("no wrench columns (zero)")
    if ds.n_actuation:
        extras.append("actuation " + ", ".join(f"{n} [{u}]" for n, u in ds.actuation_units.items()))
    return (f"wrote {out}: {ds.n_samples} samples x {ds.n_nodes} nodes, "
            f"t = {ds.time[0]:g} .. {ds.time[-1]:g} s, dt = {ds.dt:g} s; " + "; ".join(extras))


def _describe_recording(out, ds) -> str:
    steps = ds.time[1:] - ds.time[:-1]
    a = ds.attrs
    labels = (f"; {len(a['labels'])} label runs" if "labels" in a else
              f"; {a['label_runs']} label runs not stored (too many)" if a.get("label_runs") else "")
    lag = a["lag_rows"]
    return (f"wrote {out}: {ds.n_samples} samples of the tip (node {int(ds.nodes[0])}), t = 0 .. {ds.time[-1]:g} s "
            f"(recorded time {a['time_origin_s']:.6f} s at 0), dt = {ds.dt:g} s median ({steps.min():g} .. "
            f"{steps.max():g} s); actuation " + ", ".join(f"{n} [{u}]" for n, u in ds.actuation_units.items())
            + f"; lag {lag} row{'s' if lag != 1 else ''}" + labels)


def run(args) -> int:
    from ..io import read_dataset
    from ..io.csv_import import csv_layout, import_csv, read_csv, recording_trajectory, write_recording
    from ..lab.recording import check_sessions, read_recording, shift_inputs

    lag, given = _check_args(args)
    csvs = [Path(c) for c in args.csv]
    layouts = [csv_layout(c, recording=bool(given)) for c in csvs]
    if given and "nodes" in layouts:
        c = csvs[layouts.index("nodes")]
        raise bad(given[0][1], getattr(args, given[0][0]),
                  f"an option of robot recordings only, but {c} is in softrnn's node layout (n<i>_x columns); "
                  "leave it out for that file")
    outputs = _outputs(args)
    if len(csvs) == 1 and layouts[0] == "nodes":  # softrnn's layout, exactly as before
        with DelayedBar(f"import-csv {csvs[0].name}", unit="row", enabled=not args.quiet) as bar:
            ds = import_csv(csvs[0], outputs[0], rod_length=args.length, seed=args.seed, scenario_text=args.scenario,
                            progress=bar)
        print(_describe_nodes(args.output, ds))
        return 0
    # every file is read and checked before anything is written
    recordings = {}
    for c, layout in zip(csvs, layouts):
        if layout == "recording":
            recordings[c] = read_recording(c, _layout(args))
        else:
            with DelayedBar(f"import-csv {c.name}", unit="row", enabled=not args.quiet) as bar:
                read_csv(c, progress=bar)
    if len(recordings) > 1:
        check_sessions(list(recordings.values()))
    rows, scores = _lag(list(recordings.values()), lag) if recordings else (0, None)
    prepared = {}
    for c, rec in recordings.items():
        rec = shift_inputs(rec, rows)
        prepared[c] = recording_trajectory(rec.time, rec.tip, rec.inputs, rec.names, rec.units, columns=rec.columns,
                                           labels=rec.labels, source=str(c))
    tip_node = 1 if args.tip_node is None else args.tip_node
    common = {"rod_length": args.length, "seed": args.seed, "scenario_text": args.scenario}

    def writer(c):
        if c not in prepared:
            return lambda path: import_csv(c, path, **common)
        rec = recordings[c]
        attrs = {"source_file": c.name, "lag_rows": rows, "input_columns": list(rec.columns)}
        if scores is not None:
            attrs["lag_rms_m"] = {str(k): v for k, v in scores.items()}
        return lambda path: write_recording(path, prepared[c], tip_node=tip_node, attrs=attrs, **common)

    if len(csvs) == 1:
        ds = writer(csvs[0])(outputs[0])
        print(_describe_recording(args.output, ds))
        return 0
    _write_all([(out, writer(c)) for c, out in zip(csvs, outputs)])
    for c, out in zip(csvs, outputs):
        ds = read_dataset(out)
        print(_describe_recording(out, ds) if c in prepared else _describe_nodes(out, ds))
    return 0
