"""A prediction drawn over its reference data (``softrnn plot/animate PRED.h5 --over DATA.h5``): the
reference a prediction file records (``recorded_reference``), the reference's samples and nodes
matched to the prediction's (``align``), and the error of a node between them (``node_error_mm``).

A prediction file (``softrnn rollout``, ``softrnn dynamic rollout``) holds the predicted samples of
its reference: the same times (every one, or every model step) and the same node indices. Its
attrs record the reference as given on the command line (``reference``) and when the prediction
starts (``predicted_from_s`` or ``start_time_s``; docs/guide/datasets.md#pictures).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import SoftrnnInputError
from .data import _fields, _text, describe_nodes


def recorded_reference(path, attrs: dict) -> Path | None:
    """The reference data set that the prediction file ``path`` records (its ``attrs['reference']``),
    as recorded if that file exists, else relative to the prediction's folder; None when it records
    none. A recorded file that is found nowhere is a one-line error asking for ``--over PATH``."""
    text = _text(attrs.get("reference"))
    if not text:
        return None
    for candidate in (Path(text), Path(path).parent / text, Path(path).parent / Path(text).name):
        if candidate.is_file():
            return candidate
    raise SoftrnnInputError(f"{path} records its reference as {text}, which is not found (from here or beside "
                            f"{Path(path).name}); give it with --over REFERENCE.h5")


def predicted_from(attrs: dict) -> float | None:
    """The time [s] the prediction starts from (its seed history before), if the attrs record it."""
    for key in ("predicted_from_s", "start_time_s"):
        value = attrs.get(key)
        if isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool):
            return float(value)
    return None


def align(prediction, reference) -> tuple[np.ndarray, np.ndarray]:
    """The reference's samples and node columns that match the prediction's.

    Parameters
    ----------
    prediction, reference : dataset-like (``figures.data``)
        time (T,) and (T', ) [s], nodes (N,) and (N',)

    Returns
    -------
    rows : (T,) int
        the reference sample at each prediction time (equal within 1e-6 of the reference's step)
    cols : (N,) int
        the reference column of each prediction node

    Raises
    ------
    SoftrnnInputError
        one line, for a prediction time or node that the reference lacks
    """
    t_pred = np.asarray(prediction.time, dtype=float)
    t_ref = np.asarray(reference.time, dtype=float)
    step = float(np.median(np.diff(t_ref))) if t_ref.size > 1 else 1.0
    tol = 1e-6 * max(step, 1e-12) + 1e-9 * max(abs(t_ref[0]), abs(t_ref[-1]), 1.0)
    rows = np.clip(np.searchsorted(t_ref, t_pred), 0, t_ref.size - 1)
    left = np.clip(rows - 1, 0, t_ref.size - 1)
    rows = np.where(np.abs(t_ref[left] - t_pred) < np.abs(t_ref[rows] - t_pred), left, rows)
    off = np.abs(t_ref[rows] - t_pred) > tol
    if off.any():
        k = int(np.argmax(off))
        raise SoftrnnInputError(f"the reference has no sample at t = {t_pred[k]:g} s of the prediction (it covers "
                                f"{t_ref[0]:g} .. {t_ref[-1]:g} s every {step:g} s): pass the data set the "
                                f"prediction was made from with --over")
    lookup = {int(a): j for j, a in enumerate(np.asarray(reference.nodes))}
    missing = [int(a) for a in np.asarray(prediction.nodes) if int(a) not in lookup]
    if missing:
        raise SoftrnnInputError(f"the reference stores no node {missing[0]} of the prediction (it stores "
                                f"{describe_nodes(np.asarray(reference.nodes))}): pass the data set the "
                                f"prediction was made from with --over")
    return rows, np.array([lookup[int(a)] for a in np.asarray(prediction.nodes)], dtype=int)


def reference_positions(prediction, reference) -> np.ndarray:
    """The reference's positions (T, N, 3) [m] at the prediction's samples and nodes (``align``)."""
    _fields(reference)                    # the reference checked like any picture's data
    rows, cols = align(prediction, reference)
    return np.asarray(reference.positions, dtype=float)[rows][:, cols]


def node_error_mm(predicted: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """|predicted - reference| (T,) [mm] of one node's positions (T, 3) [m]."""
    d = np.asarray(predicted, dtype=float) - np.asarray(reference, dtype=float)
    return np.sqrt((d * d).sum(-1)) * 1e3
