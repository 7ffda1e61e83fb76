"""Resuming work: the settings a checkpoint, a finished result or an output folder must match, and
the one check that compares them.

A ``Settings`` record holds the settings (a JSON-ready dict, built from a dict or a dataclass) that
decide a result, without the keys that may change between runs (``may_differ``, dotted paths such
as ``"train.epochs"``). ``check(then, now)`` compares the record stored by an earlier run with this
run's and answers ``RESUME`` when they match; when they differ it answers ``START_AGAIN`` or raises
the caller's one-line error (``REFUSE``), naming the first setting that differs with its old and new
value (``Difference``: ``"train.seed: 0 then, 1 now"``).

A record is stored as its plain dict (``Settings.to_json``), so the files of earlier releases are
read as they are (``Settings.like``): a key they lack counts as ``None``, or as empty where the
other side holds a dict.
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass

from .errors import SoftrnnInputError, bad
from .files import json_default

RESUME = "resume"
"""``check``'s answer when the settings match: continue or reuse what is there."""
START_AGAIN = "start again"
"""``check``'s answer, when the caller asks for it, if the settings differ: discard and redo."""
REFUSE = "refuse"
"""What ``check`` does, when the caller asks for it, if the settings differ: raise a one-line error."""
_ANSWERS = (START_AGAIN, REFUSE)


def _plain(value):
    """``value`` as JSON would give it back: dicts, lists, strings, numbers, booleans and None
    (tuples as lists, numpy scalars as numbers, paths as strings; ``files.json_default``)."""
    return json.loads(json.dumps(value, default=json_default))


def _source_dict(source) -> dict:
    """A settings dict from a dict, or from a dataclass instance (its ``to_dict()`` when it has
    one, else ``dataclasses.asdict``)."""
    if dataclasses.is_dataclass(source) and not isinstance(source, type):
        source = source.to_dict() if callable(getattr(source, "to_dict", None)) else dataclasses.asdict(source)
    if not isinstance(source, Mapping):
        raise bad("settings", type(source).__name__, "a dict or a dataclass instance")
    return dict(source)


def _without(values: dict, path: str) -> None:
    """Remove the dotted ``path`` from the nested dict ``values`` (in place; absent: nothing)."""
    *parents, leaf = path.split(".")
    for key in parents:
        values = values.get(key)
        if not isinstance(values, dict):
            return
    values.pop(leaf, None)


@dataclass(frozen=True)
class Difference:
    """The first setting that differs: its dotted ``key``, the ``old`` (stored) and ``new`` values,
    and for a setting recorded as a fingerprint (``Settings.opaque``) the ``phrase`` said instead
    of the values. ``str()``: ``"key: old then, new now"`` (or the phrase)."""

    key: str
    old: object
    new: object
    phrase: str | None = None

    def __str__(self) -> str:
        return self.phrase if self.phrase is not None else f"{self.key}: {self.old!r} then, {self.new!r} now"


@dataclass(frozen=True)
class Settings:
    """The settings a result depends on, as a resumed run must match them.

    Parameters
    ----------
    values : dict
        The settings, JSON-ready (made so: tuples become lists, numpy scalars numbers), without
        ``may_differ``.
    may_differ : tuple of str
        Dotted keys that may change between runs (removed from ``values``, never compared), e.g.
        ``"train.epochs"`` where a run may be extended.
    keys : tuple of str or None
        The top-level keys that are settings (None: every key); ``like`` keeps only these of a
        stored dict that holds more (a manifest with the version, the scenario's name, ...).
    opaque : tuple of (str, str)
        Top-level keys whose values are fingerprints, compared after the others and reported by a
        phrase instead of their values; ``{name}`` in a phrase is the key just below it
        (``("data", "the {name} data differ")``).
    """

    values: dict
    may_differ: tuple[str, ...] = ()
    keys: tuple[str, ...] | None = None
    opaque: tuple[tuple[str, str], ...] = ()

    def __post_init__(self):
        for name in ("may_differ",) + (("keys",) if self.keys is not None else ()):
            seq = getattr(self, name)
            if not isinstance(seq, (tuple, list)) or not all(isinstance(k, str) and k for k in seq):
                raise bad(name, seq, "a tuple of non-empty key names")
            object.__setattr__(self, name, tuple(seq))
        opaque = tuple(tuple(p) for p in (self.opaque.items() if isinstance(self.opaque, Mapping) else self.opaque))
        if not all(len(p) == 2 and all(isinstance(s, str) for s in p) for p in opaque):
            raise bad("opaque", self.opaque, "(key, phrase) pairs of strings")
        object.__setattr__(self, "opaque", opaque)
        values = _source_dict(self.values)
        if self.keys is not None:
            values = {k: values.get(k) for k in self.keys}
        values = _plain(values)
        for path in self.may_differ:
            _without(values, path)
        object.__setattr__(self, "values", values)

    @classmethod
    def of(cls, source, *, may_differ=(), keys=None, opaque=()) -> Settings:
        """The record of ``source`` (a dict, or a dataclass instance: its ``to_dict()`` or
        ``asdict``); the other arguments are the fields'."""
        return cls(_source_dict(source), may_differ, keys, opaque)

    def like(self, stored) -> Settings:
        """The record, in this record's terms (its ``may_differ``, ``keys`` and ``opaque``), of a
        dict stored by an earlier run (``to_json``'s, or a larger dict that holds it: a manifest,
        a model's meta); anything but a dict counts as an empty one."""
        return Settings.of(stored if isinstance(stored, Mapping) else {}, may_differ=self.may_differ, keys=self.keys,
                           opaque=self.opaque)

    def to_json(self) -> dict:
        """The settings as stored (a copy of ``values``): ``like`` reads them back."""
        return _plain(self.values)

    def difference(self, then: Settings) -> Difference | None:
        """The first setting where ``then`` differs from this record, or None: keys sorted at every
        level, the opaque ones last; a key missing on one side counts as None (as {} beside a dict)."""
        phrases = dict(self.opaque)
        top = sorted(set(then.values) | set(self.values), key=lambda k: (k in phrases, k))
        for key in top:
            d = _first(then.values.get(key), self.values.get(key), key)
            if d is not None:
                if key in phrases:
                    below = d.key.split(".")[1] if "." in d.key else key
                    return Difference(d.key, d.old, d.new, phrases[key].format(name=below))
                return d
        return None


def _first(old, new, key: str) -> Difference | None:
    """The first difference between two plain values at dotted ``key`` (dicts compared key by key,
    sorted; None beside a dict counts as {})."""
    if isinstance(old, dict) or isinstance(new, dict):
        a = old if isinstance(old, dict) else ({} if old is None else None)
        b = new if isinstance(new, dict) else ({} if new is None else None)
        if a is not None and b is not None:
            for name in sorted(set(a) | set(b)):
                d = _first(a.get(name), b.get(name), f"{key}.{name}")
                if d is not None:
                    return d
            return None
    return None if _same(old, new) else Difference(key, old, new)


def _same(a, b) -> bool:
    """Plain values equal, a NaN equal to a NaN (a setting stored as NaN matches itself)."""
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    return a == b


def check(then, now: Settings, *, otherwise: str = REFUSE,
          refuse: Callable[[Difference], Exception] | None = None) -> str:
    """Whether a run with the settings ``now`` may resume from, or reuse, what an earlier run left
    with ``then`` (a ``Settings``, the dict it stored, or None when nothing readable was stored).

    Returns ``RESUME`` when they match. When they differ: returns ``START_AGAIN`` if ``otherwise``
    is ``START_AGAIN``; with ``otherwise=REFUSE`` raises ``refuse(difference)`` (the caller's
    one-line error, ``Difference`` naming the setting, its old and new value), by default a
    ``SoftrnnInputError`` saying which setting differs and to start again.
    """
    if otherwise not in _ANSWERS:
        raise bad("otherwise", otherwise, f"one of {', '.join(map(repr, _ANSWERS))}")
    if not isinstance(now, Settings):
        raise bad("now", type(now).__name__, "a Settings record")
    if then is None:
        diff = Difference("", None, None, "no settings were recorded")
    else:
        diff = now.difference(then if isinstance(then, Settings) else now.like(then))
    if diff is None:
        return RESUME
    if otherwise == START_AGAIN:
        return START_AGAIN
    if refuse is None:
        raise SoftrnnInputError(f"the settings differ from the earlier run's ({diff}); use the same settings, "
                                f"or start again")
    raise refuse(diff)
