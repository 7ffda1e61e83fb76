"""One command-line vocabulary (docs/guide/cli.md, softrnn.cli._vocabulary): every subcommand's long
options are the vocabulary's or its documented domain options; the old spellings still parse, with one
deprecation note; an unknown option prints the subcommand's usage. In-process, parsers only."""

import argparse
from pathlib import Path

import pytest

from softrnn.cli import _vocabulary as vocabulary
from softrnn.cli.main import build_parser

ROOT = Path(__file__).resolve().parents[2]


def _commands(parser=None, path=()):
    """(the command as typed after softrnn, its parser) for the top level and every (nested) subcommand."""
    parser = build_parser() if parser is None else parser
    yield " ".join(path), parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from _commands(sub, (*path, name))


COMMANDS = dict(_commands())
LEAVES = {name: p for name, p in COMMANDS.items()
          if not any(isinstance(a, argparse._SubParsersAction) for a in p._actions)}


def _options(parser):
    """The options ``--help`` shows (deprecated aliases left out)."""
    return [a for a in parser._actions if a.option_strings and not isinstance(a, vocabulary.Deprecated)]


def _value(action) -> list:
    if action.nargs == 0:
        return []
    if action.choices is not None:
        return [str(next(iter(action.choices)))]
    return ["2"] if action.type in (int, float) else ["x.out"]


def _base(parser, leave_out=None) -> list:
    """Arguments that satisfy ``parser``'s required options and positionals (``leave_out`` aside)."""
    argv = []
    for action in parser._actions:
        if action is leave_out or isinstance(action, vocabulary.Deprecated):
            continue
        if action.option_strings and action.required:
            argv += [action.option_strings[0], *_value(action)]
        elif not action.option_strings:
            argv += _value(action)
    return argv


def test_every_parser_is_the_one_line_error_parser():
    for name, parser in COMMANDS.items():
        assert isinstance(parser, vocabulary.Parser), name


def test_long_options_are_the_vocabulary_or_documented_domain_options():
    assert set(COMMANDS) == set(vocabulary.DOMAIN), "DOMAIN in softrnn/cli/_vocabulary.py lists every command"
    for name, parser in COMMANDS.items():
        allowed = set(vocabulary.VOCABULARY) | set(vocabulary.DOMAIN[name]) | set(vocabulary.TO_RENAME.get(name, ()))
        longs = {s for a in _options(parser) for s in a.option_strings if s.startswith("--")}
        assert longs <= allowed, f"softrnn {name}: {sorted(longs - allowed)} outside the vocabulary (docs/guide/cli.md)"
        stale = set(vocabulary.DOMAIN[name]) - longs
        assert not stale, f"softrnn {name}: DOMAIN lists {sorted(stale)}, which the command lacks"


def test_domain_options_do_not_respell_a_vocabulary_concept():
    for name, options in vocabulary.DOMAIN.items():
        for option in options:
            assert option not in vocabulary.VOCABULARY, (name, option)
            words = vocabulary.concept_words(option)
            assert not words or option in vocabulary.NOT_A_CONCEPT, \
                f"softrnn {name} {option}: looks like the vocabulary's {words} (docs/guide/cli.md)"


def test_short_options_and_the_vocabulary_shapes():
    for name, parser in COMMANDS.items():
        for action in _options(parser):
            shorts = [s for s in action.option_strings if not s.startswith("--")]
            for short in shorts:
                assert vocabulary.SHORT.get(short) in action.option_strings, (name, action.option_strings)
            if "--json" in action.option_strings or "--output" in action.option_strings:
                assert action.nargs != 0, f"softrnn {name}: {action.option_strings} takes a PATH"
            if "--quiet" in action.option_strings or "--overwrite" in action.option_strings:
                assert action.nargs == 0, (name, action.option_strings)


def test_deprecated_aliases_parse_to_the_same_value_with_one_note(capsys):
    found = 0
    for name, parser in LEAVES.items():
        for alias in vocabulary.aliases(parser):
            target = alias.target
            for old in alias.option_strings:
                base = _base(parser, leave_out=target)
                value = _value(target)
                new = parser.parse_args([*base, target.option_strings[0], *value])
                assert capsys.readouterr().err == ""
                got = parser.parse_args([*base, old, *value])
                err = capsys.readouterr().err.splitlines()
                assert vars(got) == vars(new), (name, old)
                assert len(err) == 1 and err[0].startswith(f"softrnn: note: {old} is deprecated; use "
                                                           f"{vocabulary.spelled(target)}"), (name, old, err)
                found += 1
    assert found >= 15


def test_deprecated_aliases_are_documented():
    text = (ROOT / "docs" / "guide" / "cli.md").read_text()
    found = 0
    for name, parser in LEAVES.items():
        for alias in vocabulary.deprecated(parser):
            for old in alias.option_strings:
                assert f"`{old}`" in text, f"docs/guide/cli.md: softrnn {name} {old}"
                found += 1
    assert found >= 16


def test_nothing_is_left_to_rename():
    assert vocabulary.TO_RENAME == {}
    options = {s for a in _options(LEAVES["dynamic evaluate"]) for s in a.option_strings}
    assert "--start" in options and "--test-start" not in options


def test_test_start_is_a_deprecated_fraction_beside_start(capsys):
    parser = build_parser()
    base = ["dynamic", "evaluate", "m", "--test", "t.h5"]
    args = parser.parse_args([*base, "--start", "0.3"])
    assert (args.start_time, args.test_start) == (0.3, None) and capsys.readouterr().err == ""
    args = parser.parse_args([*base, "--test-start", "0.6"])
    assert (args.start_time, args.test_start) == (None, 0.6)            # a fraction, converted by the command
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith("softrnn: note: --test-start is deprecated; use --start S in seconds")
    assert parser.parse_args([*base, "--test-start=0.5"]).test_start == 0.5
    help_text = LEAVES["dynamic evaluate"].format_help()
    assert "--start S" in help_text and "--test-start" not in help_text


def test_old_output_value_still_chooses_what_a_model_predicts(capsys):
    parser = build_parser()
    args = parser.parse_args(["train", "d.h5", "-o", "model", "--output", "pose"])
    assert (args.out, args.output) == ("model", "pose")
    assert capsys.readouterr().err.startswith("softrnn: note: --output pose is deprecated; use --predict pose")
    args = parser.parse_args(["magnetic", "experiment", "--out", "dir", "--output", "pose"])
    assert (args.out, args.output) == ("dir", "pose")
    args = parser.parse_args(["magnetic", "compare", "x.csv", "-o", "increment"])    # -o is always the folder
    assert (args.out, args.output) == ("increment", "increment")


def test_show_json_switch_still_prints(capsys):
    parser = build_parser()
    assert parser.parse_args(["show", "d.h5", "--json", "-"]).json == "-"
    assert capsys.readouterr().err == ""
    assert parser.parse_args(["show", "d.h5", "--json"]).json == "-"
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith("softrnn: note: --json without a PATH is deprecated")
    assert parser.parse_args(["show", "d.h5", "--json", "s.json"]).json == "s.json"


@pytest.mark.parametrize("name", sorted(LEAVES))
def test_unknown_option_prints_the_subcommands_usage(name, capsys):
    parser = build_parser()
    with pytest.raises(SystemExit) as stop:
        parser.parse_args([*name.split(), *_base(LEAVES[name]), "--no-such-option"])
    assert stop.value.code == 2
    err = capsys.readouterr().err.splitlines()
    prog = f"softrnn {name}"
    assert len(err) == 1, err
    assert err[0].startswith("softrnn: error: unrecognized arguments: --no-such-option")
    assert f"(usage: {prog} " in err[0] and err[0].endswith(f"; see '{prog} --help')")


def test_invalid_value_names_the_nested_subcommand(capsys):
    with pytest.raises(SystemExit) as stop:
        build_parser().parse_args(["dynamic", "train", "d.h5", "-o", "m", "--steps", "many"])
    assert stop.value.code == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and "--steps: invalid int value" in err[0]
    assert "(usage: softrnn dynamic train [options] -o MODEL_DIR DATA [DATA ...]; see 'softrnn dynamic train --help')" \
        in err[0]
