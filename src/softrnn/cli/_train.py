"""softrnn train DATA.h5 --node N -o FOLDER: train one node's LSTM model (paper Fig. 2A/B)."""

import sys
from pathlib import Path

from ..errors import SoftrnnInputError, bad
from ._progress import Bar, stop_code
from ._vocabulary import output, settings

NAME = "train"
PREDICTS = ("increment", "acceleration", "pose")
"""What a node model can predict (--predict)."""

HELP = "train a node's LSTM model (paper Fig. 2A/B) on a dataset and save it as a model folder"


_TRAINING = (
    ("--epochs", int, None, "most epochs (default: 30)"),
    ("--batch-size", int, None, "windows per step (default: 256; the paper used 1, about 100x slower on a CPU)"),
    ("--lr", float, None, "Adam's initial learning rate (default: 0.002, cosine decay)"),
    ("--patience", int, None, "early-stopping patience in epochs (default: 8)"),
    ("--units", int, None, "LSTM units per layer (default: 32)"),
    ("--layers", int, None, "LSTM layers (default: 2)"),
    ("--dense", None, "W,...", "dense widths after the LSTM (default: 32)"),
    ("--rollout-steps", int, None, "steps of the multi-step loss, feeding the node's predictions back (default: 4; "
                                   "1: plain one-step training, about 3x faster)"),
)
"""The training's and the network's options (``settings`` rows): none given, ``TrainConfig``'s and
``ModelConfig``'s defaults."""


def add_args(p):
    from ._vocabulary import deprecate

    p.add_argument("data", help="an HDF5 dataset written by softrnn (simulate, sweep, import-csv)")
    p.add_argument("--group", default=None, metavar="NAME",
                   help="the trajectory's group inside a merged sweep file (required where it holds several; "
                        "'softrnn show' lists them)")
    p.add_argument("--node", type=int, default=None,
                   help="the node to model (default: the node of interest the file names, or the only node it "
                        "stores)")
    output(p, dest="out", required=True, metavar="FOLDER", help="the model folder to write", legacy=PREDICTS,
           legacy_dest="output", legacy_flag="--predict")
    p.add_argument("--neighbours", default=None, metavar="A,B",
                   help="nodes whose poses join the node's, comma-separated ('none' for none; default: the "
                        "adjacent nodes n-1, n+1, one at an end of the rod)")
    p.add_argument("--history", type=int, default=2,
                   help="past time steps per window, eta + 1 (default: 2, the paper's)")
    node_inputs = p.add_argument("--node-inputs", dest="inputs", choices=("positions", "poses"), default="positions",
                                 help="input I per node: positions (3) or positions and quaternions (7) (default: "
                                      "positions)")
    deprecate(p, node_inputs, "--inputs", why=" (--inputs names a CSV's input columns in import-csv and lab)")
    p.add_argument("--wrench", choices=("none", "force", "wrench"), default=None,
                   help="input II: the node's force, force and torque, or none (Fig. 2A) (default: force if any "
                        "force acts on the node in the training span, else none)")
    p.add_argument("--drive", choices=("wrench", "actuation", "both"), default="wrench",
                   help="what input II holds: the node's wrench (--wrench; default), the data set's actuation inputs "
                        "(tendon tensions, pressures, currents: docs/dataset-format.md), or both")
    p.add_argument("--channels", default=None, metavar="NAME,...",
                   help="the actuation channels of input II with --drive actuation/both (default: all the data "
                        "set's)")
    p.add_argument("--predict", dest="output", choices=PREDICTS, default=None,
                   help="what the network predicts: the next position minus the last (default), the change of "
                        "that increment, or the next position itself (as the paper)")
    p.add_argument("--validate-on", default=None, metavar="VAL.h5",
                   help="a separate validation recording (another session with the same node(s), neighbours and "
                        "actuation channels): train on the whole of DATA and stop early on this file instead of "
                        "on the last part of DATA's first 60 %%")
    p.add_argument("--validate-group", default=None, metavar="G",
                   help="the trajectory's group inside a sweep file given as --validate-on")
    settings(p, _TRAINING)
    p.add_argument("--pool", default=None, metavar="NODES",
                   help="beyond the paper: train one model shared by these nodes (their windows pooled; "
                        "e.g. 1..99 for every interior node); implies --relative")
    p.add_argument("--relative", action="store_true",
                   help="express the window's positions relative to the node's last position (translation-invariant)")
    p.add_argument("--seed", type=int, default=None, help="random seed of the weights and shuffling (default: 0)")
    p.add_argument("--threads", type=int, default=None, help="CPU threads (default: 1)")
    again = p.add_mutually_exclusive_group()
    again.add_argument("--resume", action="store_true",
                       help="continue an interrupted training from FOLDER/checkpoint.pt (no finished epoch is lost), "
                            "or train a finished model on up to a larger --epochs")
    again.add_argument("--overwrite", action="store_true",
                       help="replace the model or unfinished training in FOLDER (default: refuse)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def _pool(text: str) -> tuple:
    """'A..B' (inclusive), 'A,B,...' or both (``_vocabulary.node_list``)."""
    from ._vocabulary import node_list

    return tuple(node_list(text, "--pool"))


def _ints(text: str, argument: str) -> tuple:
    if text.strip().lower() in ("", "none"):
        return ()
    try:
        return tuple(int(a) for a in text.split(","))
    except ValueError:
        raise bad(argument, text, "comma-separated integers, e.g. 29,31 (or 'none')") from None


class _LossBar(Bar):
    """The tqdm bar with the epoch and the losses in its postfix."""

    finished = False

    def __call__(self, done, total, info=None):
        if self.finished:
            return
        if done >= total and info is not None and not info.get("done"):
            done = total - 1            # the last epoch's validation is still to come: the bar ends after it
        self.finished = done >= total
        super().__call__(done, total)
        if self.bar is not None and info:
            text = f"epoch {info.get('epoch')}/{info.get('epochs')} loss {info.get('loss', float('nan')):.3g}"
            if "validation_loss" in info:
                text += f" val {info['validation_loss']:.3g} best {info['best_validation_loss']:.3g}"
            self.bar.set_postfix_str(text, refresh=False)


def run(args) -> int:
    from ..io.reader import read_dataset
    from ..learned.checkpoints import CHECKPOINT, output_folder
    from ..learned.node.artifact import check_replaceable
    from ..learned.node.train import TrainConfig, train_node_model

    output_folder(args.out, holds=("config.json", CHECKPOINT), overwrite=args.overwrite or args.resume)
    check_replaceable(args.out)   # a folder of other files is never replaced
    args.group = one_group(args.data, args.group, "--group")
    if args.validate_on is not None:
        args.validate_group = one_group(args.validate_on, args.validate_group, "--validate-group")
    node = args.node
    head = None
    if node is None:
        from ..figures.data import describe_nodes
        from ._plot import named_node

        head = read_dataset(args.data, group=args.group, stop=1)
        node = named_node(head)
        if node is None and len(head.nodes) == 1:    # one marker (a lab CSV of the tip alone): that node
            node = int(head.nodes[0])
        if node is None:
            raise SoftrnnInputError(f"--node is missing: the file names no node of interest; choose the node to "
                                    f"model, one of {describe_nodes(head.nodes)}")
    if args.validate_group is not None and args.validate_on is None:
        raise bad("--validate-group", args.validate_group, "no group without --validate-on VAL.h5")
    spec = _spec(args, node)
    overrides = {k: v for k, v in (("lstm_units", args.units), ("lstm_layers", args.layers),
                                   ("output", args.output)) if v is not None}
    if args.dense is not None:
        overrides["dense_units"] = _ints(args.dense, "--dense")
    pool = _pool(args.pool) if args.pool is not None else None
    if args.relative or pool is not None:
        overrides["relative"] = True
    train = {k: v for k, v in (("epochs", args.epochs), ("batch_size", args.batch_size), ("learning_rate", args.lr),
                               ("patience", args.patience), ("seed", args.seed), ("threads", args.threads),
                               ("rollout_steps", args.rollout_steps))
             if v is not None}
    config = TrainConfig(**train)
    with _LossBar(f"train node {node}", unit="batch", enabled=not args.quiet) as bar:
        try:
            model = train_node_model(args.data, spec, overrides, config, args.out, resume=args.resume, progress=bar,
                                     pool=pool, validation=args.validate_on, validation_group=args.validate_group,
                                     group=args.group, refuse_done=True)
        except SoftrnnInputError as err:     # name the command's option
            text = str(err)
            if text.startswith("validate_on="):
                raise SoftrnnInputError("--validate-on=" + text[len("validate_on="):]) from None
            raise
        except KeyboardInterrupt as err:
            bar.close()
            print(f"softrnn: interrupted; the finished epochs are kept in {args.out}/{CHECKPOINT}; run the same "
                  f"command with --resume to continue", file=sys.stderr)
            return stop_code(err)
    m = model.meta
    spans = m["spans"]
    shared = f" (shared by {len(m['pool'])} pooled nodes)" if m.get("pool") else ""
    if m.get("training_data"):
        val = m["training_data"]["validation"]
        where = f"all of {val['file'] or 'the validation data'}" + (f":{val['group']}" if val.get("group") else "")
        span_text = (f"every sample of {_named(args.data, args.group)} trained on, validation samples {where} "
                     f"(0..{val['n_samples'] - 1}), no test span")
    else:
        span_text = (f"validation samples {spans['validation'][0]}..{spans['validation'][1] - 1}, test samples "
                     f"{spans['test'][0]}..{spans['test'][1] - 1}")
    print(f"train: node {model.spec.node}{shared} <- {', '.join(map(str, model.spec.neighbours)) or 'no neighbours'}, "
          f"history {model.spec.history}, {model.spec.inputs} + {_input_two(model.spec)}; "
          f"{m['train_windows']} training windows (stride {m['stride']}), {span_text}")
    print(f"train: best validation loss {m['best_validation_loss']:.4g} at epoch {m['best_epoch']} of "
          f"{m['epochs_run']}{' (early stop)' if m['early_stopped'] else ''}, {m['train_seconds']:.1f} s; "
          + (f"trained on from epoch {m['continued_after_epoch']}, " if "continued_after_epoch" in m else "")
          + f"model written to {args.out}")
    return 0


def _spec(args, node):
    """The ``SampleSpec`` of the command line (the wrench chosen by ``_default_wrench`` unless given;
    with ``--drive actuation`` none, with ``--drive both`` at least the force)."""
    from ..io.reader import read_dataset
    from ..learned.node.data import SampleSpec

    if args.channels is not None and args.drive == "wrench":
        raise bad("--channels", args.channels, "no channels with --drive wrench (pass --drive actuation or both)")
    wrench = args.wrench
    if args.drive == "actuation":
        wrench = "none"
    elif wrench is None:
        wrench = _default_wrench(args.data, node, whole=args.validate_on is not None, group=args.group)
        wrench = "force" if args.drive == "both" and wrench == "none" else wrench
    channels = None
    if args.channels is not None:
        channels = tuple(a.strip() for a in args.channels.split(",") if a.strip())
    neighbours = None if args.neighbours is None else _ints(args.neighbours, "--neighbours")
    if args.inputs == "poses" and not read_dataset(args.data, group=args.group, stop=1).has_orientations:
        raise bad("--node-inputs", "poses", "'positions' (the data set has no orientations: a CSV without "
                                       "n{i}_qw..qz columns stores identity placeholders)")
    try:
        spec = SampleSpec(node=node, neighbours=neighbours, history=args.history, inputs=args.inputs, wrench=wrench,
                          drive=args.drive, channels=channels)
        if args.drive != "wrench":           # checked here to name the options (training checks it again)
            spec.resolve_channels(read_dataset(args.data, group=args.group, stop=1).actuation_names)
        return spec
    except SoftrnnInputError as err:     # name the command's option
        text = str(err)
        for name in ("drive", "channels"):
            if text.startswith(f"{name}="):
                text = f"--{text}"
        raise SoftrnnInputError(text) from None


def _default_wrench(path, node, whole: bool = False, group: str | None = None) -> str:
    """'force' if any force or torque acts on ``node`` in the training span (the first 60 % of the
    samples, the test span is not looked at; ``whole``: every sample, all trained on) of the
    trajectory (``group`` of a sweep file), else 'none' (Fig. 2A)."""
    import numpy as np

    from ..io.reader import read_dataset
    from ..learned.node.data import SampleSpec, split

    d = read_dataset(path, nodes=[node], group=group)
    cut = d.n_samples
    if not whole and d.n_samples >= 4:
        cut = split(d.n_samples, SampleSpec(node=node, history=1))[0].stop
    return "force" if np.any(d.forces[:cut] != 0) or np.any(d.torques[:cut] != 0) else "none"


def one_group(path, group: str | None, option: str) -> str | None:
    """The trajectory to read of ``path``: ``group`` where given (``read_dataset`` checks it), the
    only group of a sweep file holding one, None for a single-trajectory file; a one-line error
    naming the groups and ``option`` for a sweep file of several without ``group``."""
    from ..io.reader import list_groups

    if group is not None or not Path(path).is_file():   # a missing file: read_dataset says so
        return group
    groups = list_groups(path)
    if groups == ["/"]:
        return None
    if len(groups) == 1:
        return groups[0]
    names = ", ".join(g.lstrip("/") for g in groups[:8]) + (", ..." if len(groups) > 8 else "")
    raise bad(option, None, f"a trajectory of {path}, a sweep file of {len(groups)} ({names}); pass {option} NAME "
                            f"for one of them")


def _named(path, group: str | None) -> str:
    """'file.h5' or 'file.h5:group'."""
    return Path(path).name + (f":{group.lstrip('/')}" if group not in (None, "/") else "")


def _input_two(spec) -> str:
    """Input II in words: the wrench kind, and the actuation channels where the model reads them."""
    if spec.drive == "wrench":
        return spec.wrench
    act = "actuation " + ", ".join(spec.channels)
    return act if spec.drive == "actuation" else f"{spec.wrench} + {act}"
