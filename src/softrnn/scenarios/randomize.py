"""The ``[randomize]`` table of a scenario: dotted keys with their distributions, and the draws
that make a sweep's variants (``Scenario.variant``)."""

from __future__ import annotations

import copy
import math

import numpy as np

from .reading import _Ctx, _is_number, _join, _show

DISTRIBUTIONS = ("uniform", "normal", "loguniform", "integers", "choice")


def _flatten_randomize(ctx: _Ctx, raw, prefix: str = "") -> dict[str, tuple[str, object]]:
    """{dotted key: (distribution, parameters)}; nested tables (unquoted dotted keys) are flattened."""
    if not isinstance(raw, dict):
        raise ctx.invalid(_join("randomize", prefix) if prefix else "randomize", raw,
                          "a table of \"dotted.key\" = {distribution = parameters}")
    out = {}
    for k, v in raw.items():
        key = _join(prefix, k)
        if isinstance(v, dict) and len(v) == 1 and next(iter(v)) in DISTRIBUTIONS:
            out[key] = _distribution(ctx, f"randomize.{key}", *next(iter(v.items())))
        elif isinstance(v, dict) and v and not any(d in v for d in DISTRIBUTIONS):
            out.update(_flatten_randomize(ctx, v, key))
        else:
            raise ctx.invalid(f"randomize.{key}", v,
                              "one distribution: {uniform = [lo, hi]}, {normal = [mean, std]}, "
                              "{loguniform = [lo, hi]}, {integers = [lo, hi]} or {choice = [...]}")
    return out


def _distribution(ctx: _Ctx, key: str, dist: str, p):
    """(distribution, parameters) checked: ``choice`` a non-empty list, ``integers`` [lo, hi] integers,
    the others two finite numbers (``normal``: mean, std >= 0; ``loguniform``: 0 < lo <= hi)."""
    where = f"{key}.{dist}"
    if dist == "choice":
        if not isinstance(p, list) or not p:
            raise ctx.invalid(where, p, "a non-empty list of values to choose from")
        return dist, p
    if dist == "integers":
        if not (isinstance(p, list) and len(p) == 2 and all(isinstance(x, int) and not isinstance(x, bool) for x in p)
                and p[0] <= p[1]):
            raise ctx.invalid(where, p, "[lo, hi], integers with lo <= hi (both included)")
        return dist, p
    if not (isinstance(p, list) and len(p) == 2 and all(_is_number(x) and math.isfinite(x) for x in p)):
        raise ctx.invalid(where, p, f"[{'mean, std' if dist == 'normal' else 'lo, hi'}], two numbers")
    if dist == "normal" and p[1] < 0:
        raise ctx.invalid(where, p, "[mean, std] with std >= 0")
    if dist in ("uniform", "loguniform") and p[0] > p[1]:
        raise ctx.invalid(where, p, "[lo, hi] with lo <= hi")
    if dist == "loguniform" and p[0] <= 0:
        raise ctx.invalid(where, p, "[lo, hi] with 0 < lo <= hi")
    return dist, [float(x) for x in p]


def _draw(rng: np.random.Generator, dist: str, p):
    """One value drawn by ``rng`` from the distribution ``dist`` with parameters ``p``."""
    if dist == "uniform":
        return float(rng.uniform(p[0], p[1]))
    if dist == "normal":
        return float(rng.normal(p[0], p[1]))
    if dist == "loguniform":
        return float(np.exp(rng.uniform(np.log(p[0]), np.log(p[1]))))
    if dist == "integers":
        return int(rng.integers(p[0], p[1], endpoint=True))
    return copy.deepcopy(p[int(rng.integers(0, len(p)))])  # choice


def _set_path(ctx: _Ctx, doc: dict, dotted: str, value, table: str = "randomize") -> None:
    """Set doc[a][b][0]... = value; every container on the way must exist (the last key of a table
    may be new, e.g. an optional key left at its default). ``table`` names the key's table in errors."""
    parts = dotted.split(".")
    if parts[0] in ("randomize", "calibrate", "format", "name", "seed"):
        raise ctx.error(f"{table}.{dotted}", f"{table}: '{dotted}' cannot be "
                                             f"{'randomised' if table == 'randomize' else 'set'}")
    node = doc
    for depth, part in enumerate(parts):
        last = depth == len(parts) - 1
        here = ".".join(parts[:depth]) or "the document"
        if isinstance(node, dict):
            if part not in node and not last:
                raise ctx.error(f"{table}.{dotted}",
                                f"{table}: '{dotted}' names no value: {here} has no key '{part}'")
            if last:
                node[part] = value
            else:
                node = node[part]
        elif isinstance(node, list):
            if not part.isdigit() or int(part) >= len(node):
                raise ctx.error(f"{table}.{dotted}", f"{table}: '{dotted}' names no value: {here} is a list of "
                                                       f"{len(node)} entries, '{part}' is not an index in it")
            if last:
                node[int(part)] = value
            else:
                node = node[int(part)]
        else:
            raise ctx.error(f"{table}.{dotted}",
                            f"{table}: '{dotted}' names no value: {here} = {_show(node)} has no entries")


def _sample(ctx: _Ctx, doc: dict, randomize: dict, seed: int, index: int) -> tuple[dict, dict]:
    """Variant ``index``: a copy of ``doc`` with every randomised key drawn, in order, by
    ``default_rng([seed, index])``; returns (the document, {dotted key: value drawn})."""
    rng = np.random.default_rng([seed, index])
    data = copy.deepcopy(doc)
    sampled = {}
    for key, (dist, p) in randomize.items():
        value = _draw(rng, dist, p)
        _set_path(ctx, data, key, value)
        sampled[key] = value
    return data, sampled

