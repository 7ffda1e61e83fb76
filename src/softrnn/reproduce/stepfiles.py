"""The resumable step files of ``softrnn reproduce``: one JSON file per finished step, recording the
settings (quick or full) and the softrnn version that made it; a rerun skips a step whose file matches."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from .. import __version__
from ..files import atomic_write_text


def load_step(path: Path, quick: bool) -> dict | None:
    """The step file's dict if it was written by this version with the same ``quick``, else None."""
    if not path.exists():
        return None
    try:
        done = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    return done if done.get("quick") == quick and done.get("softrnn_version") == __version__ else None


def save_step(path: Path, result: dict, quick: bool) -> dict:
    """Write ``result`` with ``quick`` and the softrnn version in front to the step file ``path``
    (atomically; numpy arrays and scalars as JSON lists and numbers) and return what was written."""
    result = {"quick": quick, "softrnn_version": __version__, **result}
    atomic_write_text(path, json.dumps(result, indent=2, default=_jsonable))
    return result


def _jsonable(x):
    """``json.dumps``'s fallback: numpy arrays as lists, numpy scalars as numbers, the rest as str."""
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, (np.floating, np.integer)):
        return x.item()
    return str(x)
