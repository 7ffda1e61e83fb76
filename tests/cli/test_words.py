"""The command line's words (docs/guide/cli.md): a library error names the command's option, not a
Python argument; no ``None`` in a message; one spelling of node ranges and of ``--duration``
(simulated time); ``--overwrite`` of the resumable commands; what ``evaluate`` says free running
takes from the reference; the ``train`` bar that ends after the last validation."""

import pytest

from softrnn.cli import _evaluate, _rollout, _train
from softrnn.cli import _vocabulary as vocabulary
from softrnn.cli.main import build_parser

from helpers import run_cli


def _flags(*argv) -> dict:
    return getattr(build_parser().parse_args(list(argv)), vocabulary.FLAGS)


def _one_line_error(capsys, *words) -> str:
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith("softrnn: error:"), err
    for w in words:
        assert w in err, err
    return err


# ------------------------------------------------------------------------------- messages in flags
def test_a_library_argument_is_named_as_the_commands_option():
    flags = _flags("train", "d.h5", "-o", "m")
    text = vocabulary.in_flags("rollout_steps=4 is invalid: 1 for a model with relative inputs that predicts the "
                               "next position itself (output='pose'); or use output='increment'", flags)
    assert text == ("--rollout-steps=4 is invalid: 1 for a model with relative inputs that predicts the next "
                    "position itself (--predict='pose'); or use --predict='increment'")
    assert vocabulary.in_flags("lstm_units=0 is invalid; learning_rate=-1", flags) == "--units=0 is invalid; --lr=-1"
    assert vocabulary.in_flags("drive='wrench' with drive='both'", flags) == "--drive='wrench' with --drive='both'"
    # names the command has no option for, and spellings already in flags, stay as they are
    assert vocabulary.in_flags("kept=[0] is invalid; --validate-on=x; spec.history=2", flags) == \
        "kept=[0] is invalid; --validate-on=x; spec.history=2"
    # a message about a TOML file's entries names the file's keys, not the command's options
    lab = _flags("lab", "benchmark", "--suite", "s.toml", "--json", "s.json")
    assert "families" in lab
    assert vocabulary.in_flags("s.toml: robots.one: families='oracle' is invalid", lab) == \
        "s.toml: robots.one: families='oracle' is invalid"


def test_none_never_reaches_a_message():
    flags = _flags("simulate", "semicircle")
    assert vocabulary.in_flags("--node=None is invalid: a node to plot", flags) == \
        "--node is missing: give a node to plot"
    assert vocabulary.in_flags("substeps=2 is too few (or substeps=None to choose it automatically)", flags) == \
        "--substeps=2 is too few (or no --substeps to choose it automatically)"
    assert vocabulary.in_flags('or RunConfig(integrator="implicit") or n_samples=5', flags) == \
        'or RunConfig(integrator="implicit") or --samples=5'    # a Python call is left as it is


def test_the_innermost_subcommand_names_the_options():
    assert _flags("dynamic", "train", "d.h5", "-o", "m")["model_dt"] == "--model-dt"
    assert _flags("animate", "d.h5")["duration"] == "--playback"
    assert _flags("dynamic", "evaluate", "m", "--test", "t.h5")["start_time"] == "--start"


def test_a_library_error_through_the_command_line_names_the_option(capsys):
    assert run_cli(["simulate", "semicircle", "--dt", "1e9", "--quiet"]) == 2
    _one_line_error(capsys, "--samples=20001, --dt=1e+09 s is too large", "--integrator implicit")


def test_nothing_to_write_or_evaluate_is_said_without_none(tmp_path, capsys):
    assert run_cli(["export", str(tmp_path / "m")]) == 2
    err = _one_line_error(capsys, "nothing to write: give at least one of --onnx PATH and --torchscript PATH")
    assert "None" not in err
    assert run_cli(["dynamic", "evaluate", str(tmp_path / "m")]) == 2
    err = _one_line_error(capsys, "nothing to evaluate: give --test FILE, --heldout PATH ... or --generalisation FILE")
    assert "None" not in err


def test_fixes_name_commands_and_flags_not_python():
    from softrnn.learned import checkpoints
    from softrnn.learned.node import _checkpoint

    for module in (checkpoints, _checkpoint):
        source = open(module.__file__).read()
        assert "without --resume to start again" not in source and "without --resume to replace" not in source
    from softrnn.io import _h5files

    assert "with merge_files" not in open(_h5files.__file__).read()


def test_a_folder_given_as_a_dataset_names_the_command_that_merges(tmp_path, capsys):
    folder = tmp_path / "sweep"
    folder.mkdir()
    assert run_cli(["show", str(folder)]) == 2
    err = _one_line_error(capsys, "softrnn sweep --merge FILE.h5")
    assert "merge_files" not in err


# ------------------------------------------------------------------------------------ node ranges
@pytest.mark.parametrize("text, nodes", [("1..4", [1, 2, 3, 4]), ("1,2,10..12", [1, 2, 10, 11, 12]), ("7", [7]),
                                         ("1-3", [1, 2, 3]), ("2..2,5-6", [2, 5, 6])])
def test_one_node_range_spelling_everywhere(text, nodes):
    assert list(_train._pool(text)) == nodes
    assert _rollout.parse_nodes(text) == sorted(set(nodes))


def test_node_ranges_are_printed_as_written():
    assert _rollout._ranges([1, 2, 3, 7, 9, 10]) == "1..3,7,9..10"


def test_calibrate_nodes_take_ranges_and_negative_indices():
    assert vocabulary.node_list("-3..-1,5", "--nodes", negative=True) == [-3, -2, -1, 5]
    assert vocabulary.node_list("25,50,75", "--nodes", negative=True) == [25, 50, 75]


@pytest.mark.parametrize("text, words", [("1..x", ["--pool='1..x' is invalid", "A..B"]),
                                         ("5..2", ["a range A..B with A <= B"]), ("-1", ["node indices >= 0"])])
def test_bad_node_ranges_are_one_line(text, words):
    with pytest.raises(Exception) as err:
        _train._pool(text)
    assert all(w in str(err.value) for w in words), str(err.value)


def test_the_help_shows_one_node_range_form():
    for argv in (["train"], ["rollout"], ["calibrate"]):
        text = " ".join(build_parser()._subparsers._group_actions[0].choices[argv[0]].format_help().split())
        assert "NODES" in text and "1-49" not in text and "A,B,..." not in text, argv


# --------------------------------------------------------------------------------------- durations
def test_duration_is_simulated_time_in_simulate():
    args = build_parser().parse_args(["simulate", "semicircle", "--duration", "0.5"])
    assert args.duration == 0.5
    args.samples, args.dt = None, 0.01
    from softrnn.cli._simulate import _samples

    assert _samples(args, 0.001) == 51                 # (samples - 1) x dt = 0.5 s at the given dt
    args.dt = None
    assert _samples(args, 0.001) == 501


@pytest.mark.parametrize("extra, words", [(["--duration", "0.1", "--samples", "5"], ["not both"]),
                                          (["--duration", "-1"], ["--duration=-1.0", "a simulated time > 0 s"]),
                                          (["--duration", "inf"], ["--duration=inf"])])
def test_simulate_duration_is_checked(extra, words, capsys):
    assert run_cli(["simulate", "semicircle", "--quiet", *extra]) == 2
    _one_line_error(capsys, *words)


def test_animate_playback_is_the_movies_length_and_duration_an_old_spelling(capsys):
    parser = build_parser()
    assert parser.parse_args(["animate", "d.h5", "--playback", "3"]).duration == 3.0
    assert capsys.readouterr().err == ""
    assert parser.parse_args(["animate", "d.h5", "--duration", "3"]).duration == 3.0
    err = capsys.readouterr().err
    assert err.startswith("softrnn: note: --duration is deprecated; use --playback") and "simulated time" in err
    with pytest.raises(SystemExit):           # the old spelling is still the movie's length: not with --frames
        parser.parse_args(["animate", "d.h5", "--frames", "3", "--duration", "1"])
    assert "argument --playback: not allowed with argument --frames" in capsys.readouterr().err


def test_train_node_inputs_and_the_old_inputs(capsys):
    parser = build_parser()
    assert parser.parse_args(["train", "d.h5", "-o", "m", "--node-inputs", "poses"]).inputs == "poses"
    assert parser.parse_args(["train", "d.h5", "-o", "m", "--inputs", "poses"]).inputs == "poses"
    assert "--inputs is deprecated; use --node-inputs" in capsys.readouterr().err


# --------------------------------------------------------------------------------------- outputs
def test_magnetic_example_csv_takes_o_like_the_others(tmp_path, capsys):
    parser = build_parser()
    assert parser.parse_args(["magnetic", "example-csv", "-o", "x.csv"]).csv == "x.csv"
    assert parser.parse_args(["magnetic", "example-csv", "x.csv"]).path == "x.csv"      # the older spelling
    assert run_cli(["magnetic", "example-csv", "--quiet"]) == 2
    _one_line_error(capsys, "-o PATH.csv")
    assert run_cli(["magnetic", "example-csv", "-o", str(tmp_path / "a.csv"), str(tmp_path / "b.csv")]) == 2
    _one_line_error(capsys, "given once")
    assert run_cli(["magnetic", "example-csv", "-o", str(tmp_path / "a.csv"), "--samples", "20", "--quiet"]) == 0
    assert (tmp_path / "a.csv").is_file() and not (tmp_path / "b.csv").exists()


@pytest.mark.parametrize("argv", [["sweep"], ["study", "hparams"], ["reproduce"]])
def test_resumable_commands_have_overwrite(argv, capsys):
    assert run_cli([*argv, "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "--overwrite start again" in text


def test_overwrite_removes_the_commands_own_folder_only_when_asked(tmp_path):
    folder = tmp_path / "sweep"
    folder.mkdir()
    (folder / "traj-00000.h5").write_bytes(b"x")
    vocabulary.start_again(folder, overwrite=False)
    assert (folder / "traj-00000.h5").exists()
    vocabulary.start_again(folder, overwrite=True)
    assert not folder.exists()
    vocabulary.start_again(tmp_path / "none", overwrite=True)      # nothing there: nothing to do


# -------------------------------------------------------------------------------------- evaluate
@pytest.mark.parametrize("neighbours, wrench, channels, said", [
    ([], "none", None, "its own predictions only"),
    ([1, 3], "force", None, "neighbours and wrench from the reference"),
    ([], "none", ["tendon_1"], "actuation from the reference"),
])
def test_evaluate_says_what_free_running_takes_from_the_reference(neighbours, wrench, channels, said):
    assert _evaluate._fed({"neighbours": neighbours, "wrench": wrench, "channels": channels}) == said


# ------------------------------------------------------------------------------------- train bar
def test_the_train_bar_ends_after_the_last_validation():
    bar = _train._LossBar("train", unit="batch")
    bar(4, 4, {"epoch": 2, "epochs": 2, "loss": 0.1, "validation_loss": 0.2, "best_validation_loss": 0.2})
    assert bar.bar is not None and bar.bar.n == 3 and not bar.finished        # the last batch: validating
    bar(4, 4, {"epoch": 2, "epochs": 2, "loss": 0.1, "validation_loss": 0.1, "best_validation_loss": 0.1})
    assert bar.bar is not None and not bar.finished
    bar(4, 4, {"epoch": 2, "epochs": 2, "done": True, "best_validation_loss": 0.1})
    assert bar.bar is None and bar.finished


def test_every_command_that_writes_has_overwrite():
    """docs/guide/cli.md: "--overwrite ... every command that writes a file"."""
    import argparse

    def leaves(parser, path=()):
        subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
        if not subs:
            yield " ".join(path), parser
        for action in subs:
            for name, sub in action.choices.items():
                yield from leaves(sub, (*path, name))

    writers = {"--output", "--json", "--onnx", "--torchscript", "--figures", "--figure", "--markdown", "--merge",
               "--save-data"}
    found = 0
    for name, parser in leaves(build_parser()):
        options = {s for a in parser._actions for s in a.option_strings}
        if options & writers:
            assert "--overwrite" in options, name
            found += 1
    assert found >= 25


@pytest.mark.parametrize("extra, words", [
    (["--rollout-steps", "30"], ["--rollout-steps=30 is invalid: fewer steps", "use --rollout-steps=1 or longer data"]),
    (["--pool", "1..3", "--predict", "pose", "--rollout-steps", "4"],
     ["--rollout-steps=4 is invalid", "(--predict='pose'); or use --predict='increment'"]),
])
def test_train_names_its_options_in_the_librarys_refusals(extra, words, tmp_path, capsys):
    pytest.importorskip("torch")
    from helpers import node_dataset, save_h5

    data = save_h5(tmp_path / "d.h5", node_dataset(T=40))
    assert run_cli(["train", str(data), "--node", "2", "-o", str(tmp_path / "m"), "--quiet", *extra]) == 2
    err = _one_line_error(capsys, *words)
    assert "rollout_steps" not in err and "output=" not in err
    assert not (tmp_path / "m").exists()
