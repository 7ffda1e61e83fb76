"""Entry point of the ``softrnn`` command."""

import argparse
import os
import signal
import sys
import threading
from contextlib import contextmanager

import softrnn

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
from ._vocabulary import FLAGS, Parser, _SubParsers, in_flags

_Parser = Parser
"""The one-line-error parser of every command (``_vocabulary.Parser``; the old name)."""


COMMANDS = (_scenario, _simulate, _sweep, _reproduce, _bench, _show, _import_csv, _animate, _plot, _train,
            _evaluate, _rollout, _export, _study, _magnetic, _dynamic, _calibrate, _control, _lab, _lab_example)
"""The subcommands' modules, in the order of ``softrnn --help``. Each module imports only light parts
at its top (its ``NAME``, ``HELP``, ``add_args`` and ``run``); the library parts it needs are imported
inside its functions, when the command runs (tests/cli/test_startup.py checks which)."""


class _Version(argparse._VersionAction):
    """``--version``: prints ``softrnn VERSION``, looked up when asked for (``softrnn.__version__``)."""

    def __call__(self, parser, namespace, values, option_string=None):
        self.version = f"softrnn {softrnn.__version__}"
        super().__call__(parser, namespace, values, option_string)


class _Commands(_SubParsers):
    """The subcommands, each one's arguments added by its ``add_args`` when first needed
    (``complete``): when argparse reaches the command, or all at once for the whole tree. Some
    ``add_args`` import library parts for their defaults and choices; ``softrnn --help``,
    ``--version`` and bare ``softrnn`` run none of them."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.pending = {}

    def complete(self, name: str | None = None) -> None:
        """Add the arguments of the command ``name`` (None: of every command) if not yet added."""
        for key in (list(self.pending) if name is None else [name]):
            add_args = self.pending.pop(key, None)
            if add_args is not None:
                add_args(self.choices[key])

    def __call__(self, parser, namespace, values, option_string=None):
        self.complete(values[0])
        super().__call__(parser, namespace, values, option_string)


def build_parser(complete: bool = True) -> argparse.ArgumentParser:
    """The parser of ``softrnn``; with ``complete=False`` each command's arguments are added only
    when that command is parsed (what ``main`` uses: the help and the version start at once)."""
    parser = Parser(prog="softrnn", description="Real-time dynamic models of soft continuum manipulators.")
    parser.add_argument("--version", action=_Version)
    sub = parser.add_subparsers(title="commands", dest="command", required=True, action=_Commands)
    for module in COMMANDS:
        p = sub.add_parser(module.NAME, help=module.HELP, description=module.HELP)
        p.set_defaults(func=module.run)
        sub.pending[module.NAME] = module.add_args
    if complete:
        sub.complete()
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


def _lost_stop(info) -> None:
    """``sys.unraisablehook`` while a command runs: a stop (``_stop``) raised while Python ran a
    callback of its own (a weakref's, a finalizer's) is printed as "ignored" and lost, and the job
    would run on; deliver the signal again instead. Anything else goes to the hook before."""
    if isinstance(info.exc_value, KeyboardInterrupt):       # from another thread: not inside this hook
        signum = signal.SIGTERM if isinstance(info.exc_value, Terminated) else signal.SIGINT
        threading.Timer(_DEFER_S, os.kill, (os.getpid(), signum)).start()
        return
    _HOOKS[-1](info)


_HOOKS: list = []
"""The ``sys.unraisablehook`` each running ``stoppable`` block replaced, innermost last."""


@contextmanager
def stoppable():
    """Inside: SIGTERM and SIGINT stop the job (``_stop``), a stop lost in a callback is delivered
    again (``_lost_stop``); the caller's handlers and hook come back afterwards."""
    previous = {}
    for sig in (signal.SIGTERM, signal.SIGINT):
        try:   # only the main thread may set a handler; a caller's own handler comes back afterwards
            previous[sig] = signal.signal(sig, _stop)
        except ValueError:
            pass
    _HOOKS.append(sys.unraisablehook)
    sys.unraisablehook = _lost_stop
    try:
        yield
    finally:
        sys.unraisablehook = _HOOKS.pop()
        for sig, handler in previous.items():
            if handler is not None:    # None: a handler set outside Python, which cannot be put back
                signal.signal(sig, handler)


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    parser = build_parser(complete=False)
    if not argv:        # bare softrnn: the help
        parser.print_help()
        return 0
    args = parser.parse_args(argv)
    with stoppable():
        return _main(args)


def _main(args) -> int:
    module = sys.modules.get(args.func.__module__)
    try:
        if hasattr(module, "before_libraries"):    # what must precede NumPy's import (reproduce's pins)
            module.before_libraries()
        if getattr(module, "READS_DATASETS", True):
            # imported when a command runs: registers the scenario-record builder that reads older data files
            from .. import scenarios  # noqa: F401

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
