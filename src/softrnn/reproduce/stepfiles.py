"""The resumable step files of ``softrnn reproduce``: one JSON file per finished step, recording the
settings (quick or full) and the softrnn version that made it; a rerun skips a step whose file matches."""

from __future__ import annotations

import json
from pathlib import Path

from .. import __version__
from ..files import atomic_write_text, json_default
from ..resume import RESUME, START_AGAIN, Settings, check

KEYS = ("quick", "softrnn_version")
"""The settings every step file starts with."""


def step_settings(quick: bool) -> Settings:
    """What every step file must match to be reused: ``quick`` and the softrnn version."""
    return Settings.of({"quick": quick, "softrnn_version": __version__}, keys=KEYS)


def load_step(path: Path, quick: bool) -> dict | None:
    """The step file's dict if it was written by this version with the same ``quick``, else None
    (the step is then run again)."""
    if not path.exists():
        return None
    try:
        done = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    if not isinstance(done, dict) or check(done, step_settings(quick), otherwise=START_AGAIN) != RESUME:
        return None
    return done


def save_step(path: Path, result: dict, quick: bool) -> dict:
    """Write ``result`` with ``quick`` and the softrnn version in front to the step file ``path``
    (atomically; numpy arrays and scalars as JSON lists and numbers, ``files.json_default``) and
    return what was written."""
    result = {**step_settings(quick).to_json(), **result}
    atomic_write_text(path, json.dumps(result, indent=2, default=_jsonable))
    return result


def _jsonable(x):
    """``json.dumps``'s fallback: ``files.json_default``, and anything it refuses as its ``str`` (a
    finished step is never lost to an odd value in its result)."""
    try:
        return json_default(x)
    except TypeError:
        return str(x)
