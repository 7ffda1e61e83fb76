"""Reading a scenario file's TOML: ``ScenarioError``, the tables checked against their allowed keys,
the value validators (``number``, ``integer``, ``string``, ``boolean``, ``vec3``, ``numbers``,
``rows3``, ``table_list``) and CSV files named by a scenario."""

from __future__ import annotations

import difflib
import math
from pathlib import Path

import numpy as np

from ..errors import SoftrnnInputError, one_line


class ScenarioError(SoftrnnInputError):
    """A bad scenario file: ``source`` (file or builtin name) and ``key`` (dotted, '' for the file)."""

    def __init__(self, source: str, key: str, message: str):
        super().__init__(f"{source}: {one_line(message)}")
        self.source = source
        self.key = key


def _show(value) -> str:
    """A short rendering of a value for messages (strings quoted, long values cut)."""
    text = repr(value) if isinstance(value, str) else _toml_like(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _toml_like(value) -> str:
    """``value`` written as in TOML (true/false, {k = v}, [a, b])."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k} = {_toml_like(v)}" for k, v in value.items()) + "}"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml_like(v) for v in value) + "]"
    if isinstance(value, str):
        return repr(value)
    return str(value)


_MISSING = object()


class _Ctx:
    """Where errors point: the source, and the folder that relative file names are read from."""

    def __init__(self, source: str, base):
        self.source = source
        self.base = base  # a pathlib.Path or an importlib.resources Traversable, or None

    def error(self, key: str, message: str) -> ScenarioError:
        """A ``ScenarioError`` at ``key`` (dotted) of this source."""
        return ScenarioError(self.source, key, message)

    def invalid(self, key: str, value, expected: str) -> ScenarioError:
        """A ``ScenarioError``: ``key = value`` is invalid, with what was ``expected``."""
        return self.error(key, f"{key} = {_show(value)} is invalid: expected {expected}")

    def wrap(self, key: str, exc: Exception) -> ScenarioError:
        """Re-raise an API validation error with the file and the key in front."""
        return self.error(key, f"{key}: {exc}")


def _join(path: str, key) -> str:
    """The dotted key ``path.key`` (``key`` alone at the top)."""
    return f"{path}.{key}" if path else str(key)


class _Table:
    """A TOML table checked against its allowed keys; values are read with converters."""

    def __init__(self, ctx: _Ctx, raw, path: str, keys: dict[str, str]):
        if not isinstance(raw, dict):
            raise ctx.invalid(path, raw, "a table {key = value, ...}")
        self.ctx, self.raw, self.path, self.keys = ctx, raw, path, keys
        for k in raw:
            if k not in keys:
                hint = difflib.get_close_matches(k, list(keys), n=1)
                also = f"; did you mean '{hint[0]}'?" if hint else ""
                raise ctx.error(_join(path, k), f"unknown key '{_join(path, k)}' "
                                                f"(expected one of: {', '.join(keys)}{also})")

    def key(self, name: str) -> str:
        """The dotted key of ``name`` in this table."""
        return _join(self.path, name)

    def has(self, name: str) -> bool:
        """Whether the table gives ``name``."""
        return name in self.raw

    def raw_value(self, name: str):
        """The value as written (for nested tables read by their own reader); missing is an error."""
        return self.get(name, _as_is)

    def get(self, name: str, conv, default=_MISSING):
        """The value of ``name`` read by ``conv(ctx, key, value)``; ``default`` when absent (absent
        without a default is an error naming the key)."""
        if name not in self.raw:
            if default is _MISSING:
                raise self.ctx.error(self.key(name), f"missing key '{self.key(name)}' ({self.keys[name]})")
            return default
        return conv(self.ctx, self.key(name), self.raw[name])


def _as_is(ctx, key, x):
    """The converter that keeps a value as written."""
    return x


def _is_number(x) -> bool:
    """Whether ``x`` is an int or a float (not a bool)."""
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def number(unit: str = "", *, positive=False, nonnegative=False):
    """A converter to a finite float (``positive``: > 0, ``nonnegative``: >= 0; ``unit`` for messages)."""
    what = "a positive number" if positive else "a number >= 0" if nonnegative else "a number"
    what += f" in {unit}" if unit else ""

    def conv(ctx, key, x):
        if not _is_number(x) or not math.isfinite(x) or (positive and x <= 0) or (nonnegative and x < 0):
            raise ctx.invalid(key, x, what)
        return float(x)
    return conv


def integer(minimum: int | None = None, what: str = "an integer"):
    """A converter to an int (not a bool), at least ``minimum`` if given; ``what`` for messages."""
    def conv(ctx, key, x):
        if isinstance(x, bool) or not isinstance(x, int) or (minimum is not None and x < minimum):
            raise ctx.invalid(key, x, what)
        return x
    return conv


def string(choices: tuple[str, ...] | None = None, what: str = "a string"):
    """A converter to a str, one of ``choices`` if given; ``what`` for messages."""
    def conv(ctx, key, x):
        if not isinstance(x, str) or (choices is not None and x not in choices):
            expected = f"one of {', '.join(repr(c) for c in choices)}" if choices else what
            raise ctx.invalid(key, x, expected)
        return x
    return conv


def boolean(ctx, key, x):
    """The converter to a bool (true or false)."""
    if not isinstance(x, bool):
        raise ctx.invalid(key, x, "true or false")
    return x


def vec3(unit: str = "", nonzero=False):
    """A converter to a tuple of 3 finite floats [x, y, z] (not all zero when ``nonzero``)."""
    what = "a " + ("nonzero " if nonzero else "") + "3-vector [x, y, z] of numbers" + (f" in {unit}" if unit else "")

    def conv(ctx, key, x):
        if (not isinstance(x, list) or len(x) != 3 or not all(_is_number(c) and math.isfinite(c) for c in x)
                or (nonzero and not any(x))):
            raise ctx.invalid(key, x, what)
        return tuple(float(c) for c in x)
    return conv


def numbers(unit: str = "", min_len: int = 1):
    """A converter to a (K,) float array of at least ``min_len`` finite numbers."""
    what = f"a list of at least {min_len} number{'s' if min_len > 1 else ''}" + (f" in {unit}" if unit else "")

    def conv(ctx, key, x):
        if not isinstance(x, list) or len(x) < min_len or not all(_is_number(c) and math.isfinite(c) for c in x):
            raise ctx.invalid(key, x, what)
        return np.array(x, dtype=float)
    return conv


def rows3(unit: str = ""):
    """A converter to a (K, 3) float array from a non-empty list of [x, y, z] rows."""
    what = "a list of [x, y, z] rows of numbers" + (f" in {unit}" if unit else "")

    def conv(ctx, key, x):
        if not isinstance(x, list) or not x or not all(
                isinstance(r, list) and len(r) == 3 and all(_is_number(c) and math.isfinite(c) for c in r) for r in x):
            raise ctx.invalid(key, x, what)
        return np.array(x, dtype=float)
    return conv


def table_list(ctx, key, x):
    """The converter to a list of tables (a TOML array of tables, ``[[...]]``)."""
    if not isinstance(x, list) or not all(isinstance(e, dict) for e in x):
        raise ctx.invalid(key, x, "an array of tables ([[...]] entries)")
    return x


def _read_csv(ctx: _Ctx, key: str, name, columns: int) -> np.ndarray:
    """Rows of ``columns`` numbers from a CSV file relative to the scenario file ('#' comments and
    one header line allowed)."""
    if not isinstance(name, str) or not name:
        raise ctx.invalid(key, name, "a CSV file name relative to the scenario file")
    if ctx.base is None:
        raise ctx.invalid(key, name, "inline values (a scenario given as text has no folder for files)")
    target = Path(name) if Path(name).is_absolute() else ctx.base.joinpath(name)
    try:
        text = target.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else type(exc).__name__
        raise ctx.invalid(key, name, f"a readable UTF-8 CSV file ({reason}: {target})") from None
    rows = []
    for i, line in enumerate(text.splitlines()):
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        cells = [c.strip() for c in line.split(",")]
        try:
            values = [float(c) for c in cells]
        except ValueError:
            if not rows and i == 0:
                continue  # a header line
            raise ctx.invalid(key, name, f"numbers only in the CSV rows (line {i + 1}: {line[:40]!r})") from None
        if len(values) != columns or not all(math.isfinite(v) for v in values):
            raise ctx.invalid(key, name, f"{columns} finite numbers per CSV row (line {i + 1} has {len(values)})")
        rows.append(values)
    if not rows:
        raise ctx.invalid(key, name, "a CSV file with at least one row")
    return np.array(rows, dtype=float)


