"""The scenario record of a data set written before the record existed: rebuilt from the scenario
text it stored (``attrs["scenario_text"]``) and a sweep variant's draws (``attrs["sampled"]``), so
that old files keep working where a feature needs the record (``softrnn.io.record``): in memory
(``with_record``), as a new file (``upgrade_file``), or on reading: importing this package registers
``record_of_attrs`` as ``softrnn.io.record``'s record builder, so ``read_record`` (and every command)
reads an old file's record from its text."""

from __future__ import annotations

import copy
import dataclasses
import json
from functools import lru_cache
from pathlib import Path

import numpy as np

from ..errors import SoftrnnInputError, bad
from ..io.reader import list_groups, read_dataset
from ..io.record import RECORD, ScenarioRecord, set_record_builder
from ..io.writer import write_dataset
from .scenario import parse_scenario


def record_of_text(text: str, sampled=None, variant_index: int | None = None) -> ScenarioRecord | None:
    """The record of a scenario ``text`` (TOML) with sweep variant ``variant_index``'s draws
    ``sampled`` ({dotted key: value}, or their JSON) set into it; None where the text is empty, does
    not read as a scenario any more, its draws cannot be set, or a variant of a randomised scenario
    did not record them."""
    if not isinstance(text, str) or not text.strip():
        return None
    try:
        scenario = parse_scenario(text)
        draws = json.loads(sampled) if isinstance(sampled, str) else dict(sampled or {})
        if variant_index is not None and scenario.randomized and not draws:
            return None
        record = scenario.with_values(draws).record if draws else scenario.record
    except (SoftrnnInputError, ValueError, TypeError, KeyError, IndexError):
        return None
    return dataclasses.replace(record, variant_index=variant_index)


def record_of_attrs(attrs: dict) -> ScenarioRecord | None:
    """The record of a data set's attrs rebuilt from its ``scenario_text`` with a sweep variant's
    draws ``sampled`` and index ``variant_index`` (``record_of_text``; None where that gives none);
    the record builder registered with ``softrnn.io.record.set_record_builder``."""
    index = attrs.get("variant_index")
    sampled = attrs.get("sampled")
    if not isinstance(sampled, str):
        try:
            sampled = json.dumps(dict(sampled or {}), sort_keys=True)
        except (TypeError, ValueError):
            return None
    index = int(index) if isinstance(index, (int, np.integer)) and not isinstance(index, bool) else None
    return _cached_record(attrs.get("scenario_text"), sampled, index)


@lru_cache(maxsize=32)
def _cached_record(text, sampled: str, index: int | None) -> ScenarioRecord | None:
    """``record_of_text``, kept for the files read again (each reader of a file asks for its record)."""
    return record_of_text(text, sampled, index)


set_record_builder(record_of_attrs)


def with_record(dataset):
    """``dataset`` (a ``Dataset`` or dataset-like object) with its scenario record: itself where it
    has one or its scenario text gives none; else a copy whose ``attrs["scenario_record"]`` is
    rebuilt from that text (``record_of_text``; a sweep variant's draws, ``attrs["sampled"]``, put
    in, its index kept)."""
    attrs = dict(getattr(dataset, "attrs", None) or {})
    if attrs.get(RECORD) is not None:
        return dataset
    record = record_of_attrs(attrs)
    if record is None:
        return dataset
    attrs[RECORD] = record.to_record()
    if dataclasses.is_dataclass(dataset):
        return dataclasses.replace(dataset, attrs=attrs)
    out = copy.copy(dataset)                  # a dataset-like object (a slice read for a picture)
    out.attrs = attrs
    return out


def upgrade_file(path, out) -> int:
    """Copy the data file ``path`` (one trajectory, or a sweep: every group, as it is named) to
    ``out`` (another file, written atomically), each trajectory with its scenario record where it
    had none (``with_record``); the arrays and other attributes are copied bit for bit. Returns
    the trajectories that got a record."""
    if Path(out).resolve() == Path(path).resolve():
        raise bad("out", str(out), "another file than the one read")
    groups, added = list_groups(path), 0
    for group in groups:
        data = read_dataset(path, group=None if group == "/" else group)
        upgraded = with_record(data)
        added += upgraded is not data
        write_dataset(out, upgraded, group=None if group == "/" else group.strip("/"))
    return added
