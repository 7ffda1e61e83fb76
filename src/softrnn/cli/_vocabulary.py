"""The command line's one vocabulary (docs/guide/cli.md): the options every subcommand spells the
same way, each command's own domain options (as data, checked by tests/cli/test_vocabulary.py), the
one-line-error parser every command and nested subcommand uses, and the deprecated aliases that keep
an old spelling working for one release with one note on stderr."""

import argparse
import re
import sys

from ..errors import SoftrnnInputError

VOCABULARY = ("--help", "--version", "--output", "--json", "--overwrite", "--resume", "--quiet", "--seed",
              "--workers", "--scheduler", "--start", "--stop", "--group")
"""The long options that mean the same thing in every command that has them (docs/guide/cli.md)."""

SHORT = {"-h": "--help", "-o": "--output"}
"""The only short options, and the long option each one spells."""

CONCEPT_WORDS = ("out", "json", "report", "start", "stop", "time", "seed", "worker", "schedul", "quiet", "silent",
                 "verbose", "overwrite", "force", "resume", "group", "dir", "progress")
"""Stems of the vocabulary's concepts: a domain option with a word (between hyphens) that starts with
one is a new spelling of a concept (``--out``, ``--output-dir``, ``--start-time``), unless it is
listed in ``NOT_A_CONCEPT``."""

NOT_A_CONCEPT = {
    "--start-fraction": "dynamic train: the share of each batch's windows drawn from a run's first steps",
    "--validate-group": "train: the --group of the --validate-on file",
    "--no-forces": "plot: leave out the force panel",
    "--no-contact-forces": "animate: leave out the arrows of the contact forces",
}
"""Domain options that contain a concept word but name something else (option -> why)."""

TO_RENAME: dict = {}
"""Options outside the vocabulary that are still to be renamed (command -> option -> what remains);
none in this release (``dynamic evaluate --test-start F`` became ``--start S``)."""

DOMAIN = {
    "": (),
    "scenario": (),
    "scenario list": (),
    "scenario show": ("--summary",),
    "scenario copy": (),
    "simulate": ("--samples", "--duration", "--substeps", "--dt", "--integrator", "--radius", "--youngs-modulus",
                 "--density", "--poisson-ratio"),
    "sweep": ("--count", "--samples", "--dt", "--merge"),
    "reproduce": ("--quick", "--compare"),
    "bench": ("--quick", "--only", "--model", "--dynamic-model"),
    "show": ("--quick",),
    "import-csv": ("--length", "--scenario", "--inputs", "--tip", "--position-unit", "--tip-node", "--lag"),
    "animate": ("--fps", "--frames", "--playback", "--node", "--no-trail", "--view", "--elev", "--azim", "--size",
                "--no-obstacles", "--no-contact-forces", "--style", "--save-data", "--samples", "--dt", "--over"),
    "plot": ("--node", "--no-forces", "--no-inputs", "--over"),
    "train": ("--node", "--neighbours", "--history", "--node-inputs", "--wrench", "--drive", "--channels", "--predict",
              "--validate-on", "--validate-group", "--epochs", "--batch-size", "--lr", "--patience", "--units",
              "--layers", "--dense", "--rollout-steps", "--pool", "--relative", "--threads"),
    "evaluate": ("--generalisation", "--figures", "--no-free-running"),
    "rollout": ("--shared", "--shared-nodes", "--unmodelled", "--figure"),
    "export": ("--onnx", "--torchscript", "--opset", "--static-batch"),
    "study": (),
    "study hparams": ("--node", "--units", "--history", "--epochs", "--wrench", "--bandwidth-steps"),
    "magnetic": (),
    "magnetic experiment": ("--quick", "--samples", "--epochs", "--predict", "--no-calibrate"),
    "magnetic compare": ("--epochs", "--predict", "--calibrate"),
    "magnetic example-csv": ("--samples",),
    "magnetic navigate": ("--branch", "--field", "--duration", "--advance", "--rotate"),
    "dynamic": (),
    "dynamic train": ("--heldout", "--validation", "--validate-on", "--train-fraction", "--model-dt",
                      "--node-stride", "--history", "--memory", "--width", "--layers", "--steps", "--unroll",
                      "--noise", "--ema", "--envelope", "--prior-tau", "--ridge", "--load-ridge", "--linear-lr",
                      "--conv-reads", "--start-fraction", "--recorded-feedback", "--drive", "--predict-clamps",
                      "--ignore-obstacles", "--contact-inputs", "--frame", "--threads"),
    "dynamic evaluate": ("--test", "--heldout", "--generalisation"),
    "dynamic rollout": (),
    "dynamic export": ("--onnx",),
    "calibrate": ("--scenario", "--fit", "--span", "--nodes", "--max-evaluations", "--figure"),
    "control": (),
    "control magnetic": ("--reference", "--controller", "--duration", "--stiffness", "--remanence", "--model",
                         "--identify-seconds", "--plan-factors"),
    "lab": (),
    "lab benchmark": ("--train", "--validate", "--figure", "--families", "--length", "--inputs", "--tip",
                      "--position-unit", "--lag", "--segments", "--tendons-per-segment", "--routing-radius",
                      "--suite", "--markdown", "--synthetic", "--scenario"),
    "lab calibrate": ("--validate", "--length", "--inputs", "--tip", "--position-unit", "--lag", "--segments",
                      "--tendons-per-segment", "--routing-radius", "--gravity", "--friction", "--play", "--creep",
                      "--twist"),
    "lab-example": ("--scenarios", "--duration", "--rate", "--noise"),
}
"""Each command's own options beyond the vocabulary (the command as typed after ``softrnn``)."""

def concept_words(option: str) -> list:
    """The words of ``option`` that start with a stem of ``CONCEPT_WORDS``."""
    return [w for w in option.lstrip("-").split("-") if w.startswith(CONCEPT_WORDS)]


STDOUT = "-"
"""``--json -``: print the JSON on stdout instead of writing a file."""


def _metavar(action) -> str:
    if action.metavar is not None:
        return action.metavar if isinstance(action.metavar, str) else " ".join(action.metavar)
    if action.choices is not None:
        return "{" + ",".join(map(str, action.choices)) + "}"
    return action.dest if not action.option_strings else action.dest.upper()


def _argument(action) -> str:
    if isinstance(action, argparse._SubParsersAction):
        return "COMMAND ..."        # the error itself lists the commands where one is unknown
    name = _metavar(action)
    return {"?": f"[{name}]", "*": f"[{name} ...]", "+": f"{name} [{name} ...]"}.get(action.nargs, name)


def short_usage(parser: argparse.ArgumentParser) -> str:
    """One line: the command, ``[options]``, its required options and its positional arguments."""
    parts = [f"usage: {parser.prog}"]
    if any(a.option_strings and not a.required for a in parser._actions):
        parts.append("[options]")
    for action in parser._actions:
        if action.option_strings and action.required and action.help != argparse.SUPPRESS:
            parts.append(f"{action.option_strings[0]} {_argument(action)}".rstrip())
    parts += [_argument(a) for a in parser._actions if not a.option_strings]
    return " ".join(parts)


class Parser(argparse.ArgumentParser):
    """argparse with one-line errors (exit code 2, no traceback): the error, the command's short usage
    and where its full help is. Used by every command and nested subcommand (the subparsers
    of a ``Parser`` are ``Parser``s too), so an unknown option names the subcommand it was given to."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.register("action", "parsers", _SubParsers)

    def error(self, message):
        self.exit(2, f"softrnn: error: {message} ({short_usage(self)}; see '{self.prog} --help')\n")

    def parse_known_args(self, args=None, namespace=None):
        args = canonical(self, sys.argv[1:] if args is None else list(args))
        namespace, extras = super().parse_known_args(args, namespace)
        if extras and not any(isinstance(a, argparse._SubParsersAction) for a in self._actions):
            self.error("unrecognized arguments: " + " ".join(extras))   # here, not in the top-level parser
        if not hasattr(namespace, FLAGS):       # the innermost (sub)command's options name the errors
            setattr(namespace, FLAGS, flag_names(self))
        return namespace, extras


class _SubParsers(argparse._SubParsersAction):
    """Subcommands parsed by ``Parser`` whatever ``parser_class`` the caller gives."""

    def __init__(self, *args, parser_class=None, **kwargs):
        super().__init__(*args, parser_class=Parser, **kwargs)


FLAGS = "_flags"
"""The attribute of a parsed namespace that holds its command's ``flag_names`` (for ``in_flags``)."""

LIBRARY_NAMES = {"lstm_units": "units", "lstm_layers": "layers", "dense_units": "dense", "learning_rate": "lr",
                 "start": "start_time", "stop": "stop_time", "n_samples": "samples"}
"""Library argument names whose option stores into another ``dest`` (library name -> dest)."""


def flag_names(parser) -> dict:
    """``parser``'s options by the names the library gives their values: ``dest`` (and the
    ``LIBRARY_NAMES`` that store into it) -> the long option, e.g. ``rollout_steps`` -> ``--rollout-steps``."""
    flags = {}
    for action in parser._actions:
        longs = [s for s in action.option_strings if s.startswith("--")]
        if longs and not isinstance(action, Deprecated) and action.dest not in (argparse.SUPPRESS, "help"):
            flags.setdefault(action.dest, longs[-1] if longs[-1] == "--output" else longs[0])
    flags.update({name: flags[dest] for name, dest in LIBRARY_NAMES.items() if dest in flags and name not in flags})
    return flags


def in_flags(text: str, flags: dict) -> str:
    """A library message in the command's words: each ``name=value`` whose name is an option of the
    command (``flags``, from ``flag_names``) as ``--option=value``; ``--option=None is invalid: X``
    (an option not given) as ``--option is missing: give X``, any other ``--option=None`` as ``no --option``.
    A message about a TOML file's entries (``FILE.toml: ...``: a suite, a scenario) names the file's keys,
    not the command's options, and is left as it is."""
    if re.match(r"\S+\.toml: ", text):
        return text
    text = re.sub(r"(?<![\w.\-])(?<!\w\()([a-z][a-z0-9_]*)=", lambda m: f"{flags[m[1]]}=" if m[1] in flags else m[0],
                  text)                 # not an argument of a Python call: RunConfig(integrator=...)
    text = re.sub(r"(--[a-z][a-z0-9-]*)=None is invalid: (expected )?", r"\1 is missing: give ", text)
    return re.sub(r"(--[a-z][a-z0-9-]*)=None\b", r"no \1", text)


NODE_RANGES = "node indices and inclusive ranges A..B, comma-separated, e.g. 1..49 or 1,2,10..20"
"""The one spelling of a set of rod nodes (``--pool``, ``--shared-nodes``, ``--nodes``; docs/guide/cli.md)."""


def _node_item(item: str, negative: bool) -> list:
    if ".." in item:
        a, _, b = item.partition("..")
    elif not negative and "-" in item.strip().lstrip("-"):     # the older spelling A-B
        a, _, b = item.partition("-")
    else:
        return [int(item)]
    lo, hi = int(a), int(b)
    if hi < lo:
        raise ValueError(f"a range A..B with A <= B, not {item.strip()}")
    return list(range(lo, hi + 1))


def node_list(text: str, argument: str, *, negative: bool = False) -> list:
    """The rod nodes ``text`` names, in order (``NODE_RANGES``: ``1..49``, ``1,2,10..20``; ``1-49``
    is accepted too where ``negative`` is False, ``negative``: -1 is the last node); a one-line
    error naming ``argument`` otherwise."""
    out: list = []
    try:
        for item in text.split(","):
            out += _node_item(item, negative)
    except ValueError as err:
        detail = str(err) if str(err).startswith("a range") else NODE_RANGES
        raise SoftrnnInputError(f"{argument}={text!r} is invalid: {detail}") from None
    if not negative and min(out) < 0:
        raise SoftrnnInputError(f"{argument}={text!r} is invalid: node indices >= 0 ({NODE_RANGES})")
    return out


RESTART_HELP = ("start again: remove the results an earlier run left in -o DIR (its own folder) first (default: "
                "continue them)")
"""The help of ``--overwrite`` in a resumable command (sweep, study hparams, reproduce)."""


def start_again(folder, overwrite: bool) -> None:
    """``--overwrite`` of a resumable command: remove its own ``folder`` (one ``prepare_output(...,
    mine=...)`` accepted: empty or holding the command's marker) so that every step runs again;
    nothing without ``overwrite``."""
    import shutil
    from pathlib import Path

    if overwrite and Path(folder).is_dir():
        shutil.rmtree(folder)


def note(text: str) -> None:
    """One ``softrnn: note:`` line on stderr."""
    print(f"softrnn: note: {text}", file=sys.stderr)


def spelled(action) -> str:
    """How ``--help`` shows an option: ``-o/--output``."""
    return "/".join(action.option_strings)


class Deprecated(argparse.Action):
    """An option kept for one release, hidden from ``--help``: ``DeprecatedAlias`` (an old spelling)
    or ``DeprecatedConverted`` (an old option whose value the command converts)."""


class DeprecatedAlias(Deprecated):
    """An old spelling of ``target`` (hidden from ``--help``): notes once that it is deprecated, then
    stores exactly as ``target`` does."""

    def __init__(self, option_strings, dest, target=None, why="", **kwargs):
        super().__init__(option_strings, dest, nargs=target.nargs, const=target.const, default=argparse.SUPPRESS,
                         type=target.type, choices=target.choices, help=argparse.SUPPRESS, metavar=target.metavar)
        self.target, self.why = target, why

    def __call__(self, parser, namespace, values, option_string=None):
        note(f"{option_string} is deprecated; use {spelled(self.target)}{self.why}")
        self.target(parser, namespace, values, option_string)


def deprecate(parser, target, *old: str, why: str = "") -> None:
    """Keep the spellings ``old`` of the option ``target`` (the action ``add_argument`` returned)
    working for one release, hidden from ``--help``; ``why``: more words after the note's ``use ...``."""
    parser.add_argument(*old, dest=target.dest, action=DeprecatedAlias, target=target, why=why)


class DeprecatedConverted(Deprecated):
    """An old option replaced by ``target`` whose value means something else (a fraction of a record
    where ``target`` takes seconds): hidden from ``--help``, it notes once that it is deprecated and
    stores its own value into its own ``dest``, for the command to convert into ``target``'s."""

    def __init__(self, option_strings, dest, target=None, why="", **kwargs):
        super().__init__(option_strings, dest, help=argparse.SUPPRESS, **kwargs)
        self.target, self.why = target, why

    def __call__(self, parser, namespace, values, option_string=None):
        note(f"{option_string} is deprecated; use {spelled(self.target)}{self.why}")
        setattr(namespace, self.dest, values)


def deprecate_converted(parser, target, *old: str, dest: str, why: str = "", **kwargs):
    """Keep the old option ``old`` (stored into ``dest``; ``kwargs`` as for ``add_argument``: its
    ``type``, ``default``, ``metavar``) working for one release beside ``target``, the option that
    replaces it, hidden from ``--help``; the command converts its value. ``why``: more words after
    the note's ``use ...``."""
    return parser.add_argument(*old, dest=dest, action=DeprecatedConverted, target=target, why=why, **kwargs)


def deprecated(parser) -> list:
    """Every ``Deprecated`` action of ``parser`` (aliases and converted options)."""
    return [a for a in parser._actions if isinstance(a, Deprecated)]


def aliases(parser) -> list:
    """The ``DeprecatedAlias`` actions of ``parser``."""
    return [a for a in parser._actions if isinstance(a, DeprecatedAlias)]


def _respelled(token: str, old: dict):
    """(the old spelling, ``token`` in the canonical one: one or two tokens), or None when ``token``
    uses no old spelling."""
    name, eq, value = token.partition("=")
    if name in old:
        return name, [old[name].target.option_strings[0]] + ([value] if eq else [])
    short = token[:2]
    if len(token) > 2 and not token.startswith("--") and short in old:      # -oFILE
        return short, [old[short].target.option_strings[0], token[2:]]
    return None


def canonical(parser, args: list) -> list:
    """``args`` (those of ``parser``'s level) with every deprecated spelling replaced by the canonical
    one, after one note each: argparse then sees the canonical option (a required one included)."""
    old = {s: a for a in aliases(parser) for s in a.option_strings}
    if not old:
        return args
    out = []
    for i, token in enumerate(args):
        if token == "--":
            return out + args[i:]
        found = _respelled(token, old) if token.startswith("-") else None
        if found is None:
            out.append(token)
            continue
        name, tokens = found
        note(f"{name} is deprecated; use {spelled(old[name].target)}{old[name].why}")
        out += tokens
    return out


class _OutputOrLegacy(argparse._StoreAction):
    """``-o/--output PATH`` of a command whose ``--output`` once chose among ``legacy`` (what a model
    predicts): ``--output`` with one of those values still does that, with a note; ``-o`` never."""

    def __init__(self, option_strings, dest, legacy=(), legacy_dest=None, legacy_flag="", **kwargs):
        super().__init__(option_strings, dest, **kwargs)
        self.legacy, self.legacy_dest, self.legacy_flag = tuple(legacy), legacy_dest, legacy_flag

    def __call__(self, parser, namespace, values, option_string=None):
        if option_string == "--output" and values in self.legacy:
            note(f"--output {values} is deprecated; use {self.legacy_flag} {values} (-o/--output is now the "
                 "output folder)")
            setattr(namespace, self.legacy_dest, values)
            return
        super().__call__(parser, namespace, values, option_string)


def output(parser, *, dest: str = "output", old=("--out",), legacy=(), legacy_dest=None, legacy_flag="",
           **kwargs):
    """Add ``-o/--output`` (a command's main output) storing into ``dest``, with ``old`` spellings
    as deprecated aliases; ``legacy``: values of a former domain option ``--output`` now spelled
    ``legacy_flag`` (stored into ``legacy_dest``)."""
    if legacy:
        action = parser.add_argument("-o", "--output", dest=dest, action=_OutputOrLegacy, legacy=legacy,
                                     legacy_dest=legacy_dest, legacy_flag=legacy_flag, **kwargs)
    else:
        action = parser.add_argument("-o", "--output", dest=dest, **kwargs)
    if old:
        deprecate(parser, action, *old)
    return action


class JsonOrSwitch(argparse.Action):
    """``--json PATH`` of a command where ``--json`` was a switch (print the JSON): without a PATH it
    still prints, with a note; ``--json -`` prints without one."""

    def __call__(self, parser, namespace, values, option_string=None):
        if values is None:
            note("--json without a PATH is deprecated; use --json - to print the JSON (as --json did), or "
                 "--json PATH to write it to a file")
            values = STDOUT
        setattr(namespace, self.dest, values)


def settings(parser, table) -> None:
    """One option per row of ``table`` (flag, type, metavar, help; None: argparse's own), each with
    the default None: the library's own default applies where the option is not given."""
    for flag, kind, metavar, text in table:
        parser.add_argument(flag, type=kind, default=None, metavar=metavar, help=text)
