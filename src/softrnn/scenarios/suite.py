"""A suite file of ``softrnn lab benchmark --suite``: several robots, each its training and validation
sessions and the options ``lab benchmark`` takes as flags (docs/guide/real-robots.md, "A suite of
robots"). ``read_suite`` checks the TOML (unknown keys, types, missing session files) and returns a
frozen ``Suite`` of ``SuiteRobot`` entries; the run is ``softrnn.lab.suite``.

```toml
title = "tendon robots"                      # optional

[robots.opencr-tdcr-v6]                      # one table per robot, its name a file-name-safe word
train = ["train.csv"]                        # paths relative to the suite file's folder
validate = "val.csv"
length = 0.222                               # m
segments = [0.1, 0.1, 0.022]                 # optional, as every key below
```
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from pathlib import Path

from .reading import ScenarioError, _as_is, _Ctx, _Table, integer, number, string
from .scenario import _parse_toml

ROBOT_KEYS = {
    "train": "the training sessions, a list of CSV paths relative to the suite file",
    "validate": "the validation session, a CSV path relative to the suite file",
    "length": "the robot's length in m",
    "segments": "segment lengths in m, base to tip",
    "tendons_per_segment": "tendons per segment",
    "routing_radius": "the tendons' distance from the backbone in m (a start value)",
    "lag": "rows the tip lags its command, or \"auto\"",
    "families": "softrnn's model families to run, a list of names",
    "inputs": "the input columns, a list of shell patterns",
    "tip": "the tip columns [x, y, z]",
    "position_unit": "the tip columns' unit: m, mm or cm",
    "scenario": "the robot's dynamic description for the dynamic families: a scenario name or a TOML path "
                "relative to the suite file",
    "synthetic": "synthetic rows from the calibrated physics for the learned families, a multiple of the real "
                 "rows (0: none)",
}
"""The keys of a ``[robots.NAME]`` table and what each holds (the flags of ``lab benchmark``)."""
TOP_KEYS = {"title": "the suite's title", "robots": "one [robots.NAME] table per robot"}
"""The suite file's top-level keys."""
_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]*$")


@dataclass(frozen=True)
class SuiteRobot:
    """One robot of a suite: its sessions and options (None: the benchmark's default).

    Attributes
    ----------
    name : str
        the robot's name (the table's key; letters, digits, ``.``, ``_``, ``-``)
    key : str
        where it stands in the file: ``robots.NAME``
    train : tuple of str
        the training sessions' paths (resolved against the suite file's folder)
    validate : str
        the validation session's path
    length : float
        the robot's length [m]
    segments : tuple of float or None
        segment lengths [m], base to tip
    tendons_per_segment : int or None
        tendons per segment
    routing_radius : float or None
        the tendons' distance from the backbone [m]
    lag : int or str or None
        rows the tip lags its command, or "auto"
    families : tuple of str or None
        the model families to run
    inputs : tuple of str
        the input columns' patterns (() : the default)
    tip : tuple of 3 str or None
        the tip columns
    position_unit : str or None
        the tip columns' unit
    synthetic : float or None
        synthetic rows for the learned families, a multiple of the real rows (0: none)
    scenario : str or None
        the robot's dynamic description (a scenario name, or a TOML path resolved against the suite
        file's folder)
    """

    name: str
    key: str
    train: tuple
    validate: str
    length: float
    segments: tuple | None = None
    tendons_per_segment: int | None = None
    routing_radius: float | None = None
    lag: int | str | None = None
    families: tuple | None = None
    inputs: tuple = ()
    tip: tuple | None = None
    position_unit: str | None = None
    synthetic: float | None = None
    scenario: str | None = None


@dataclass(frozen=True)
class Suite:
    """A suite file's robots, in the file's order.

    Attributes
    ----------
    path : str
        the suite file
    title : str
        its title (default: the file's stem)
    robots : tuple of SuiteRobot
        the robots, at least one
    """

    path: str
    title: str
    robots: tuple


def _strings(ctx, key, x, count: int | None = None) -> tuple:
    if (not isinstance(x, list) or not x or not all(isinstance(s, str) and s.strip() for s in x)
            or (count is not None and len(x) != count)):
        what = f"a list of {count} names" if count else "a non-empty list of strings"
        raise ctx.invalid(key, x, what)
    return tuple(s.strip() for s in x)


def _lag(ctx, key, x):
    if x == "auto" or (isinstance(x, int) and not isinstance(x, bool) and x >= 0):
        return x
    raise ctx.invalid(key, x, "a whole number of rows >= 0, or \"auto\"")


def _segments(ctx, key, x) -> tuple:
    if not isinstance(x, list) or not x:
        raise ctx.invalid(key, x, "a list of positive segment lengths in m, base to tip")
    return tuple(number("m", positive=True)(ctx, key, v) for v in x)


def _session(ctx: _Ctx, key: str, x) -> str:
    """A session's path, resolved against the suite file's folder; a missing file is an error."""
    if not isinstance(x, str) or not x.strip():
        raise ctx.invalid(key, x, "a CSV path relative to the suite file")
    path = Path(os.path.normpath(x if Path(x).is_absolute() else ctx.base / x))
    if not path.is_file():
        raise ctx.error(key, f"{key}: no session file {path} ({'a folder' if path.is_dir() else 'not found'}; "
                             "paths are relative to the suite file's folder)")
    return str(path)


def _scenario(ctx: _Ctx, key: str, x) -> str:
    """A scenario name, or a TOML path (``.toml``) resolved against the suite file's folder."""
    name = string(what="a scenario name or a TOML path")(ctx, key, x)
    if not name.endswith(".toml"):
        return name
    path = Path(os.path.normpath(name if Path(name).is_absolute() else ctx.base / name))
    if not path.is_file():
        raise ctx.error(key, f"{key}: no scenario file {path} (paths are relative to the suite file's folder)")
    return str(path)


def _robot(ctx: _Ctx, name: str, raw) -> SuiteRobot:
    key = f"robots.{name}"
    if not _NAME.match(name):
        raise ctx.error(key, f"the robot name {name!r} is invalid: expected letters, digits, '.', '_' or '-' "
                             "(it names the robot's report file)")
    t = _Table(ctx, raw, key, ROBOT_KEYS)
    train = t.get("train", lambda c, k, x: tuple(_session(c, f"{k}[{i}]", p)
                                                 for i, p in enumerate(_strings(c, k, x))))
    return SuiteRobot(
        name=name, key=key, train=train, validate=t.get("validate", _session),
        length=t.get("length", number("m", positive=True)), segments=t.get("segments", _segments, None),
        tendons_per_segment=t.get("tendons_per_segment", integer(1, "an integer >= 1"), None),
        routing_radius=t.get("routing_radius", number("m", positive=True), None), lag=t.get("lag", _lag, None),
        families=t.get("families", _strings, None), inputs=t.get("inputs", _strings, ()),
        tip=t.get("tip", lambda c, k, x: _strings(c, k, x, 3), None),
        position_unit=t.get("position_unit", string(("m", "mm", "cm")), None),
        synthetic=t.get("synthetic", number("", nonnegative=True), None),
        scenario=t.get("scenario", _scenario, None))


def read_suite(path) -> Suite:
    """Read and check the suite file at ``path``: one-line ``ScenarioError`` naming the file and the
    entry (``robots.NAME.key``) for malformed TOML, an unknown or missing key, a value of the wrong
    type and a session file that does not exist."""
    path = Path(path)
    source = str(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else type(exc).__name__
        raise ScenarioError(source, "", f"cannot read the suite file ({reason})") from None
    ctx = _Ctx(source, path.parent)
    top = _Table(ctx, _parse_toml(ctx, text), "", TOP_KEYS)
    title = top.get("title", string(), path.stem)
    robots = top.get("robots", _as_is, {})
    if not isinstance(robots, dict) or not robots:
        raise ctx.error("robots", "no robots: give one [robots.NAME] table per robot, with train, validate "
                                  "and length")
    return Suite(path=source, title=title, robots=tuple(_robot(ctx, name, raw) for name, raw in robots.items()))
