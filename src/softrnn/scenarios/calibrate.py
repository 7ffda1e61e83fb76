"""The ``[calibrate]`` table of a scenario: for each value ``softrnn calibrate`` may fit, named by a
dotted key as in ``[randomize]``, its search bounds and optionally its start (default: the file's
value at that key)."""

from __future__ import annotations

import math

import tomlkit

from .reading import _Ctx, _is_number, _join, _show

ENTRY_KEYS = ("bounds", "start")
"""The keys of one ``[calibrate]`` entry: ``bounds = [lo, hi]`` (required), ``start = value``."""

RESERVED = ("format", "name", "title", "seed", "paper", "assumptions", "randomize", "calibrate")
"""Top-level keys that name no physical value (they cannot be randomised or fitted)."""


def _flatten_calibrate(ctx: _Ctx, raw, prefix: str = "") -> dict[str, tuple[float, float, float | None]]:
    """{dotted key: (lower, upper, start or None)}; nested tables (unquoted dotted keys) are flattened."""
    where = _join("calibrate", prefix) if prefix else "calibrate"
    if not isinstance(raw, dict):
        raise ctx.invalid(where, raw, "a table of \"dotted.key\" = {bounds = [lo, hi]}")
    out = {}
    for k, v in raw.items():
        key = _join(prefix, k)
        if isinstance(v, dict) and v and set(v) <= set(ENTRY_KEYS):
            out[key] = _entry(ctx, f"calibrate.{key}", v)
        elif isinstance(v, dict) and v and not set(v) & set(ENTRY_KEYS):
            out.update(_flatten_calibrate(ctx, v, key))
        else:
            raise ctx.invalid(f"calibrate.{key}", v, "{bounds = [lo, hi]} with lo < hi, and optionally start = value")
    return out


def _entry(ctx: _Ctx, where: str, v: dict) -> tuple[float, float, float | None]:
    """(lower, upper, start or None) of one entry, checked."""
    b = v.get("bounds")
    if b is None:
        raise ctx.error(f"{where}.bounds", f"missing key '{where}.bounds' (the search range [lo, hi])")
    if not (isinstance(b, list) and len(b) == 2 and all(_is_number(x) and math.isfinite(x) for x in b)
            and b[0] < b[1]):
        raise ctx.invalid(f"{where}.bounds", b, "[lo, hi], two numbers with lo < hi")
    start = v.get("start")
    if start is not None and not (_is_number(start) and math.isfinite(start)):
        raise ctx.invalid(f"{where}.start", start, "a number (default: the file's value at the key)")
    return float(b[0]), float(b[1]), None if start is None else float(start)


def _lookup(doc: dict, dotted: str) -> tuple[str, object]:
    """What the dotted key names in ``doc``: ("value", the value), ("absent", None) for a key an
    existing table leaves out (an optional key at its default), or ("none", why it names nothing)."""
    parts = dotted.split(".")
    if not dotted or any(not p for p in parts):
        return "none", "it is not a dotted key such as rod.youngs_modulus"
    if parts[0] in RESERVED:
        return "none", f"'{parts[0]}' holds no physical value"
    node = doc
    for depth, part in enumerate(parts):
        here = ".".join(parts[:depth]) or "the document"
        last = depth == len(parts) - 1
        if isinstance(node, dict):
            if part not in node:
                return ("absent", None) if last else ("none", f"{here} has no key '{part}'")
            node = node[part]
        elif isinstance(node, list):
            if not part.isdigit() or int(part) >= len(node):
                return "none", f"{here} is a list of {len(node)} entries, '{part}' is not an index in it"
            node = node[int(part)]
        else:
            return "none", f"{here} = {_show(node)} has no entries"
    return "value", node


def _check_calibrate(ctx: _Ctx, doc: dict, entries: dict) -> dict[str, tuple[float, float, float]]:
    """The entries with their starts resolved against ``doc`` (the file's value where no start is
    given): each key must name a number, or a key its table leaves out (then ``start`` is
    required), and its bounds must hold its start."""
    out = {}
    for key, (lo, hi, start) in entries.items():
        where = f"calibrate.{key}"
        kind, found = _lookup(doc, key)
        if kind == "none":
            raise ctx.error(where, f"calibrate: '{key}' names no value: {found}")
        if kind == "value" and not _is_number(found):
            raise ctx.error(where, f"calibrate: '{key}' = {_show(found)} is not a number; only numbers can be "
                                   f"fitted (name one component of a vector, e.g. '{key}.0')")
        if start is None and kind == "absent":
            raise ctx.error(where, f"calibrate: '{key}' is not in the file; give its start: "
                                   f"\"{key}\" = {{ bounds = [{lo:g}, {hi:g}], start = ... }}")
        s = float(found) if start is None else start
        if not lo <= s <= hi:
            raise ctx.error(where, f"calibrate: the bounds [{lo:g}, {hi:g}] of '{key}' exclude its start {s:g}"
                                   f"{' (the value in the file)' if start is None else ''}; widen the bounds or "
                                   f"give another start")
        out[key] = (lo, hi, s)
    return out


def edited_text(text: str, values: dict) -> str:
    """The scenario ``text`` with each dotted key of ``values`` (as in ``[randomize]``, the path
    existing in the file) set to its value, comments and layout kept (tomlkit)."""
    doc = tomlkit.parse(text)
    for key, value in values.items():
        *path, last = key.split(".")
        node = doc
        for part in path:
            node = node[int(part)] if isinstance(node, list) else node[part]
        if isinstance(node, list):
            node[int(last)] = value
        else:
            node[last] = value
    return tomlkit.dumps(doc)
