"""Which trajectories a whole-manipulator model trains on, and which it must never see.

Inputs are data set files (one trajectory, or a sweep file with one group per variant) and sweep
folders (``softrnn sweep ... -o DIR``: one ``traj-NNNNN.h5`` per variant). ``split_inputs`` turns
them into training parts and held-out trajectories:

* of every sweep folder or sweep file, the **last** ``heldout`` variants (highest indices) are
  held out: they never reach training (``Split.heldout``); the ``validation`` variants before them
  are only used to choose among the training's checkpoints (``Split.validation``: free runs, never
  a gradient); the others are trained on whole;
* of every single-trajectory file, the first ``train_fraction`` is trained on (the paper's 60/40
  chronological split: the rest is the test span);
* ``validate_on``: separate validation recordings (other sessions of the same robot: files, every
  group of a sweep file, or sweep folders), used whole like the ``validation`` variants; the
  training files are then trained on whole (``train_fraction`` 1).

``Split.describe()`` is what a model folder records (``meta["data"]``), so an evaluation can check
that a "held-out" file really was held out.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from ...errors import SoftrnnInputError, bad, integer
from ...io.reader import list_groups, read_dataset, read_node
from .config import resolve_stride


@dataclass(frozen=True)
class Part:
    """One trajectory: ``path``, ``group`` ('/' for a single-trajectory file) and the samples
    ``stop`` (None: all) that are used."""

    path: str
    group: str = "/"
    stop: int | None = None

    def read(self):
        """The part's ``Dataset`` (its first ``stop`` samples)."""
        return read_dataset(self.path, group=None if self.group == "/" else self.group, stop=self.stop)

    def describe(self) -> dict:
        """{path, group, stop}, as a model folder records it."""
        return {"path": self.path, "group": self.group, "stop": self.stop}


@dataclass(frozen=True)
class Split:
    """``train``, ``validation`` and ``heldout`` parts (lists of ``Part``); ``validate_on``: those
    of the validation parts that are separate recordings (``split_inputs(validate_on=...)``)."""

    train: list = field(default_factory=list)
    heldout: list = field(default_factory=list)
    validation: list = field(default_factory=list)
    validate_on: list = field(default_factory=list)

    def describe(self) -> dict:
        """{"train", "validation", "heldout"}: each a list of ``Part.describe()``; with separate
        validation recordings also "validate_on" (their ``Part.describe()``, also listed in
        "validation")."""
        out = {key: [p.describe() for p in getattr(self, key)] for key in ("train", "validation", "heldout")}
        if self.validate_on:
            out["validate_on"] = [p.describe() for p in self.validate_on]
        return out

    def __add__(self, other: Split) -> Split:
        return Split(train=self.train + other.train, heldout=self.heldout + other.heldout,
                     validation=self.validation + other.validation, validate_on=self.validate_on + other.validate_on)


def validation_parts(paths) -> list:
    """The ``Part`` of every trajectory of ``paths`` (files: every group of a sweep file; sweep
    folders: every traj-*.h5), each used whole; a one-line ``validate_on=...`` error for a path
    that is neither."""
    if isinstance(paths, (str, Path)):
        paths = [paths]
    out = []
    for raw in paths:
        path = Path(raw)
        if path.is_dir():
            files = sorted(path.glob("traj-*.h5"))
            if not files:
                raise bad("validate_on", str(path), "a data set file or a sweep folder holding traj-NNNNN.h5 files")
            out += [Part(str(f), "/") for f in files]
        elif path.is_file():
            out += [Part(str(path), g) for g in list_groups(path)]
        else:
            raise bad("validate_on", str(path), "an existing data set file (the validation session's recording) "
                                                "or sweep folder")
    return out


def check_whole_rod(paths) -> None:
    """Refuse, in one line naming what to use instead, a recording of fewer than two nodes among
    ``paths`` (files or sweep folders; the first trajectory of each is read, one sample): the
    whole-manipulator model learns the rod at nodes along it, a tip marker alone cannot train it."""
    for raw in [paths] if isinstance(paths, (str, Path)) else paths:
        path = Path(raw)
        first = next(iter(sorted(path.glob("traj-*.h5"))), None) if path.is_dir() else path
        if first is None or not first.is_file():
            continue                                    # split_inputs names what is missing
        groups = list_groups(first)
        if not groups:
            continue
        nodes = read_dataset(first, group=None if groups[0] == "/" else groups[0], stop=1).nodes
        if len(nodes) < 2:
            which = f"one node (node {int(nodes[0])})" if len(nodes) else "no node"
            raise SoftrnnInputError(
                f"{first} records {which}: the whole-manipulator model learns the rod at its nodes and needs "
                f"recordings of several nodes along it (simulations, sweeps); for a tip-only recording train the "
                f"tip's node model ('softrnn train FILE --drive actuation') or benchmark the CSV sessions with "
                f"'softrnn lab benchmark --train S1.csv --validate S2.csv'")


def split_inputs(paths, *, heldout: int = 0, validation: int = 0, train_fraction: float = 1.0,
                 validate_on=()) -> Split:
    """Training, validation and held-out parts of ``paths`` (files or sweep folders).

    ``validate_on``: separate validation recordings (``validation_parts``), used whole to choose
    among the training's checkpoints; the single-trajectory files of ``paths`` are then trained on
    whole (``train_fraction`` must be 1)."""
    heldout = integer("heldout", heldout, 0)
    validation = integer("validation", validation, 0)
    if not (0.0 < float(train_fraction) <= 1.0):
        raise bad("train_fraction", train_fraction, "a fraction in (0, 1]")
    check_whole_rod(list(paths if not isinstance(paths, (str, Path)) else [paths]) + list(validate_on or []))
    given = validation_parts(validate_on) if validate_on else []
    if given and float(train_fraction) != 1.0:
        raise bad("train_fraction", train_fraction, "1 (or no train fraction) with separate validation recordings "
                                                    "(validate_on): the training files are trained on whole")
    if isinstance(paths, (str, Path)):
        paths = [paths]
    train, held, val = [], [], []
    for raw in paths:
        path = Path(raw)
        if path.is_dir():
            variants = [(f, "/") for f in sorted(path.glob("traj-*.h5"))]
            if not variants:
                raise bad("data", str(path), "a sweep folder holding traj-NNNNN.h5 files, or a data set file")
        elif path.is_file():
            groups = list_groups(path)
            if groups == ["/"]:
                stop = None
                if train_fraction < 1.0:
                    n = len(read_node(path, 0).time)      # one column: the sample count
                    stop = int(train_fraction * (n - 1)) + 1
                train.append(Part(str(path), "/", stop))
                continue
            variants = [(path, g) for g in groups]
        else:
            raise bad("data", str(path), "an existing data set file or sweep folder")
        if heldout + validation >= len(variants):
            raise bad("heldout", heldout, f"a count that leaves training variants of the {len(variants)} in {path} "
                      f"(with {validation} for validation)")
        cut = len(variants) - heldout
        cut_val = cut - validation
        train += [Part(str(f), g) for f, g in variants[:cut_val]]
        val += [Part(str(f), g) for f, g in variants[cut_val:cut]]
        held += [Part(str(f), g) for f, g in variants[cut:]]
    where = {(Path(p.path).resolve(), p.group) for p in train + held + val}
    for part in given:
        if (Path(part.path).resolve(), part.group) in where:
            raise bad("validate_on", part.path, "a recording that is not also training, validation or held-out "
                                                "data (DATA); validate on a separate session")
    return Split(train=train, heldout=held, validation=val + given, validate_on=given)


def check_step(split: Split, config) -> None:
    """Refuse a ``DynamicConfig`` whose ``model_dt`` is not a whole multiple of every input's saved
    interval (checked on one sample of each, before any work)."""
    for part in split.train + split.validation:
        head = read_dataset(part.path, group=None if part.group == "/" else part.group, stop=1)
        resolve_stride(config.model_dt, float(head.dt))


def rod_length(dataset) -> float:
    """The rod's length [m] from a data set's ``attrs["rod"]``."""
    return rod_value(dataset, "length")


def rod_value(dataset, key: str) -> float:
    """A positive number of a data set's ``attrs["rod"]`` (``length``, ``radius``: [m]); a one-line
    error naming the key when the data set lacks it."""
    rod = dataset.attrs.get("rod")
    if isinstance(rod, dict) and isinstance(rod.get(key), (int, float)) and rod[key] > 0:
        return float(rod[key])
    raise bad("data", f"a data set without the rod's {key}",
              f"a data set written by softrnn simulate or sweep (attrs['rod'] holds the {key})")
