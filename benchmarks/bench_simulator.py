"""Simulator speed benchmark: prints a table with the goals and optionally writes JSON.

    .venv/bin/python benchmarks/bench_simulator.py --json benchmarks/results/simulator.json
    .venv/bin/python benchmarks/bench_simulator.py --quick

The measurements live in ``softrnn.bench.simulator`` (also behind ``softrnn bench``); see
benchmarks/README.md for what each figure means.
"""

import argparse
import json
import os
import sys

# keep BLAS single-threaded so it does not compete with the numba threads of the batch part
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", metavar="PATH", default=None, help="write the results as JSON to PATH")
    parser.add_argument("--quick", action="store_true", help="shorter runs (~30 s, less precise)")
    args = parser.parse_args(argv)

    from softrnn.bench.simulator import format_table, run_benchmark
    from softrnn.files import atomic_write_text

    def progress(done, total):
        print(f"\r[{done}/{total}]", end="" if done < total else "\n", file=sys.stderr, flush=True)

    result = run_benchmark(quick=args.quick, progress=progress)
    print(format_table(result))
    if args.json:
        atomic_write_text(args.json, json.dumps(result, indent=2) + "\n")
        print(f"wrote {args.json}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
