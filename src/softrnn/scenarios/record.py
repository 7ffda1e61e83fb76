"""The scenario record of a data set written before the record existed: rebuilt from the scenario
text it stored (``attrs["scenario_text"]``) and a sweep variant's draws (``attrs["sampled"]``), so
that old files keep working where a feature needs the record (``softrnn.io.record``): in memory
(``with_record``) or as a new file (``upgrade_file``)."""

from __future__ import annotations

import copy
import dataclasses
import json
from pathlib import Path

from ..errors import SoftrnnInputError, bad
from ..io.reader import list_groups, read_dataset
from ..io.record import RECORD, ScenarioRecord, read_record
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


def with_record(dataset):
    """``dataset`` (a ``Dataset`` or dataset-like object) with its scenario record: itself where it
    has one or its scenario text gives none; else a copy whose ``attrs["scenario_record"]`` is
    rebuilt from that text (``record_of_text``; a sweep variant's draws, ``attrs["sampled"]``, put
    in, its index kept)."""
    attrs = dict(getattr(dataset, "attrs", None) or {})
    if read_record(attrs) is not None:
        return dataset
    index = attrs.get("variant_index")
    record = record_of_text(attrs.get("scenario_text"), attrs.get("sampled"), index if isinstance(index, int) else None)
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
