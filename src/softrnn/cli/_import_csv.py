"""softrnn import-csv LAB.csv -o DATA.h5: turn lab data (docs/csv-format.md) into a dataset file."""

from ..errors import bad
from ..files import prepare_output
from ..io.csv_import import import_csv

NAME = "import-csv"
HELP = ("convert a lab CSV (time, node positions, optional orientations, wrenches and actuation inputs) into a "
        "dataset file")


def add_args(p):
    p.add_argument("csv", help="CSV file, layout in docs/csv-format.md (e.g. examples/lab_data.csv)")
    p.add_argument("-o", "--output", required=True, metavar="PATH", help="HDF5 dataset to write")
    p.add_argument("--length", type=float, default=None, metavar="L", help="rod length in m (recorded)")
    p.add_argument("--seed", type=int, default=None, help="seed to record with the data")
    p.add_argument("--scenario", default="", metavar="TEXT", help="free text describing the experiment")
    p.add_argument("--overwrite", action="store_true", help="replace the -o file if it exists (default: refuse)")


def run(args) -> int:
    if args.length is not None and not args.length > 0:
        raise bad("--length", args.length, "a positive rod length in m")
    prepare_output(args.output, "-o", overwrite=args.overwrite)
    ds = import_csv(args.csv, args.output, rod_length=args.length, seed=args.seed, scenario_text=args.scenario)
    extras = []
    if not ds.has_orientations:
        extras.append("no orientations (identity placeholders)")
    if ds.attrs.get("force_nodes") or ds.attrs.get("torque_nodes"):
        extras.append(f"wrenches at nodes {sorted(set(ds.attrs['force_nodes']) | set(ds.attrs['torque_nodes']))}")
    else:
        extras.append("no wrench columns (zero)")
    if ds.n_actuation:
        extras.append("actuation " + ", ".join(f"{n} [{u}]" for n, u in ds.actuation_units.items()))
    print(f"wrote {args.output}: {ds.n_samples} samples x {ds.n_nodes} nodes, "
          f"t = {ds.time[0]:g} .. {ds.time[-1]:g} s, dt = {ds.dt:g} s; " + "; ".join(extras))
    return 0
