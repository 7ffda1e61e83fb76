"""The rollout-as-dataset core of every learned model: a free run written like the data it ran on.

A rollout (the node models' ``softrnn.learned.node.rollout``, the whole model's
``softrnn.learned.whole.rollout``) becomes a data set of the reference's format, so ``softrnn
animate`` and ``softrnn plot`` show it beside the reference: the predicted positions, the inputs
copied from the reference's rows (``reference_columns``) and the reference's metadata marked as a
prediction (``predicted_attrs``).
"""

from __future__ import annotations


def predicted_attrs(attrs: dict, drop, marks: dict) -> dict:
    """The reference's ``attrs`` without the keys in ``drop``, then updated with ``marks`` (what marks
    the data as a prediction: ``prediction``, the models, where the free run starts, ...)."""
    keep = {k: v for k, v in attrs.items() if k not in drop}
    keep.update(marks)
    return keep


def reference_columns(reference, rows) -> dict:
    """The inputs a rollout copies from the reference's samples ``rows`` (a slice or an index array):
    ``forces``, ``torques`` (T', N, 3) [N, N m], ``actuation`` (T', m) (None where the reference has
    none) and ``actuation_units``, as ``Dataset`` keyword arguments."""
    act = getattr(reference, "actuation", None)
    return {"forces": reference.forces[rows], "torques": reference.torques[rows],
            "actuation": None if act is None else act[rows],
            "actuation_units": getattr(reference, "actuation_units", None)}
