"""Entry point of the ``softrnn`` command."""

import argparse
import os
import signal
import sys
import threading

from .. import __version__
from ..errors import FileFault, SimulationError, SoftrnnInputError, missing_extra
from . import (
    _animate,
    _bench,
    _calibrate,
    _control,
    _dynamic,
    _evaluate,
    _export,
    _import_csv,
    _lab,
    _lab_example,
    _magnetic,
    _plot,
    _reproduce,
    _rollout,
    _scenario,
    _show,
    _simulate,
    _study,
    _sweep,
    _train,
)
from ._progress import Terminated, stop_code
from ._vocabulary import FLAGS, Parser, in_flags

_Parser = Parser
"""The one-line-error parser of every command (``_vocabulary.Parser``; the old name)."""


def build_parser() -> argparse.ArgumentParser:
    parser = Parser(prog="softrnn", description="Real-time dynamic models of soft continuum manipulators.")
    parser.add_argument("--version", action="version", version=f"softrnn {__version__}")
    sub = parser.add_subparsers(title="commands", dest="command", required=True, parser_class=Parser)
    for module in (_scenario, _simulate, _sweep, _reproduce, _bench, _show, _import_csv, _animate, _plot, _train,
                   _evaluate, _rollout, _export, _study, _magnetic, _dynamic, _calibrate, _control, _lab, _lab_example):
        p = sub.add_parser(module.NAME, help=module.HELP, description=module.HELP)
        module.add_args(p)
        p.set_defaults(func=module.run)
    return parser


_DEFER_S = 0.05
"""How long a stop that arrives inside LLVM is put off (``_inside_llvm``)."""


def _inside_llvm(frame) -> bool:
    """Whether the stack holds llvmlite code: numba compiling, which calls back into Python from C
    (its object cache). An exception raised there cannot pass through C: Python prints it as
    "ignored", the job runs on as if never stopped, or LLVM is left half-done and the process
    crashes at exit (exit code -11 instead of 143)."""
    while frame is not None:
        if "llvmlite" in frame.f_code.co_filename:
            return True
        frame = frame.f_back
    return False


def _stop(signum, frame):
    """SIGTERM raises ``Terminated``, SIGINT (Ctrl-C) ``KeyboardInterrupt``: at once, or once a
    compile in progress has returned to Python (``_inside_llvm``)."""
    if _inside_llvm(frame):         # deliver the signal again in a moment
        threading.Timer(_DEFER_S, os.kill, (os.getpid(), signum)).start()
        return
    raise Terminated() if signum == signal.SIGTERM else KeyboardInterrupt()


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    previous = {}
    for sig in (signal.SIGTERM, signal.SIGINT):
        try:   # only the main thread may set a handler; a caller's own handler comes back afterwards
            previous[sig] = signal.signal(sig, _stop)
        except ValueError:
            pass
    try:
        return _main(args)
    finally:
        for sig, handler in previous.items():
            if handler is not None:    # None: a handler set outside Python, which cannot be put back
                signal.signal(sig, handler)


def _main(args) -> int:
    try:
        return int(args.func(args) or 0)
    except (SoftrnnInputError, SimulationError, FileFault) as err:
        print(f"softrnn: error: {in_flags(str(err), getattr(args, FLAGS, {}))}", file=sys.stderr)
        return 2
    except ImportError as err:
        missing = missing_extra(err)
        if missing is None:
            raise
        print(f"softrnn: error: softrnn {args.command}: {missing}", file=sys.stderr)
        return 2
    except OSError as err:
        line = _fault_line(err)
        if line is None:
            raise
        print(f"softrnn: error: {line}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as err:
        code = stop_code(err)
        what = "terminated" if isinstance(err, Terminated) else "interrupted"
        print(f"softrnn: {what}; no partial file was left; reproduce, sweep, study and calibrate keep their "
              "finished steps and resume when run again", file=sys.stderr)
        return code


def _fault_line(err: OSError) -> str | None:
    """The one line for an OSError that escaped a command (last resort: the writers raise
    ``FileFault`` themselves, but a disk can fill up or a folder vanish anywhere): by the file it
    names (``files.write_fault``), or a full disk without a name (e.g. numba's cache of compiled
    code); None for anything else (a bug, shown whole)."""
    from ..files import FULL, write_fault  # deferred: --version and --help stay free of numpy

    if err.filename is not None:
        return str(write_fault(err, os.fsdecode(err.filename), kept=""))
    if err.errno in FULL:
        return (f"a write failed: {os.strerror(err.errno)}; free space on the disk of the output (and of the "
                f"temporary and cache folders, e.g. numba's), or choose an output on another disk, and run again")
    return None


if __name__ == "__main__":
    sys.exit(main())
