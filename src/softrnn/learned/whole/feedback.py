"""State-feedback loads (PD tracking) applied to a whole-manipulator model's own state (NumPy only).

A scenario's ``kind = "pd"`` load pulls a node toward a moving target,
``f = stiffness (target(t) - r) - damping v`` (its data's scenario record holds the law,
``softrnn.io.record.PDLaw``, with its target, a time function of ``softrnn.geometry.paths``). A data set records
the force the law produced *from the simulated rod's state*. Fed to a model as a known input, that
force carries the true trajectory with it and leaves the model's own errors uncorrected: the model
then runs the rod open loop, where the light drag lets every error persist (on the square, the
linear model's free-run error with the recorded forces is several times that with the law:
docs/guide/dynamic.md). A model used in a control loop never sees such forces either:
the controller acts on the model's state. So where a data set's scenario has PD loads (and the
model's config says ``feedback = True``), the model is driven by the law's *inputs*, the target and
the gains, and the force is computed from the model's own state at every step, as the simulator
computes it from the rod's:

    f_k = stiffness (target_k - r_k) - damping (r_k - r_(k-1)) / model_dt

with ``target_k`` the mean target over model step k and ``r_k`` the node's predicted position. The
node's recorded force is dropped from the loads (every other load stays a recorded input). The
same formula is applied to the data's states for the one-step (teacher-forced) fit and inside the
training's unrolled free runs, so training and free running see the same inputs.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...errors import bad
from ...io.record import read_record

TARGET_SAMPLES = 8
"""Target samples averaged over each model step (midpoints of equal sub-intervals)."""


@dataclass(frozen=True, eq=False)
class Feedback:
    """The PD laws of one trajectory on the kept nodes, dense over the M kept nodes (zero gains where
    a node has none).

    Parameters
    ----------
    gains : ndarray (M, 2)
        stiffness [N/m] and damping [N s/m] of each kept node's law
    targets : ndarray (S, M, 3)
        mean target over each model step, as a displacement from the kept
        node's reference position [m] (the state's coordinates)
    model_dt : float
        the model's step [s]
    nodes : tuple of int
        the rod nodes (0-based) that carry a law, for the record
    """

    gains: np.ndarray
    targets: np.ndarray
    model_dt: float
    nodes: tuple = ()

    def force(self, x: np.ndarray, x_prev: np.ndarray, k: int) -> np.ndarray:
        """The laws' loads (M, 6) [N, N m] at model step ``k`` from states ``x`` = x_k and
        ``x_prev`` = x_(k-1) (M, 6) (the torque columns are zero)."""
        return self._law(self.targets[k], x, x_prev)

    def forced(self, states: np.ndarray) -> np.ndarray:
        """The laws' loads along a recorded trajectory (S, M, 6): the teacher-forced inputs (the
        first step, which has no previous state, takes zero velocity)."""
        return self._law(self.targets, states, np.concatenate([states[:1], states[:-1]]))

    def _law(self, targets: np.ndarray, x: np.ndarray, x_prev: np.ndarray) -> np.ndarray:
        """stiffness (target - x) - damping (x - x_prev) / model_dt in the force columns of (..., M, 6)."""
        out = np.zeros(x.shape[:-1] + (6,))
        out[..., :3] = (self.gains[:, :1] * (targets - x[..., :3])
                        - self.gains[:, 1:] * (x[..., :3] - x_prev[..., :3]) / self.model_dt)
        return out


def pd_laws(dataset) -> list:
    """The PD laws (``softrnn.io.record.PDLaw``) of the scenario a data set was simulated from, as its
    scenario record stores them (a sweep variant's draws in them). [] for data without a scenario
    (lab data) or a scenario without PD loads. A file written before the record existed gets it from
    its scenario text where ``softrnn.scenarios`` is imported (``read_record``'s builder; the CLI
    always is); else, where that text has PD loads, a one-line error naming the fix."""
    record = _record(dataset, lambda text: '"pd"' in text, "feedback = false (the recorded PD forces as inputs)")
    return [] if record is None else list(record.pd)


def moving_clamps(dataset) -> tuple:
    """The nodes (0-based, increasing) that the scenario a data set was simulated from moves along a
    prescribed path, as its scenario record stores them. () for data without a scenario (lab data)
    or without such a clamp (a magnetic scenario with ``advance`` moves node 0). An older file
    without a record: as for ``pd_laws``."""
    record = _record(dataset, lambda text: ("[[boundary]]" in text and ("displacement" in text or "rotation" in text))
                     or ("[magnetic]" in text and "advance" in text), "prescribed = false")
    return () if record is None else tuple(record.moving_clamps)


def _record(dataset, needs, instead: str):
    """The data set's scenario record (``softrnn.io.record.read_record``: stored, or rebuilt from its
    text by the registered builder), or None without one; a data set without one whose scenario
    text may hold what it is read for (``needs(text)``: a file written before the record existed,
    read without ``softrnn.scenarios`` imported) is a one-line error that offers ``instead``."""
    record = read_record(dataset)
    text = dataset.attrs.get("scenario_text")
    if record is None and isinstance(text, str) and needs(text):
        raise bad("data", "a data set without its scenario record (written by an older softrnn)",
                  f"the record added (import softrnn.scenarios, softrnn.scenarios.record.upgrade_file or "
                  f"with_record), the data simulated again, or {instead}")
    return record


def feedback_of(encoding, dataset, time: np.ndarray) -> Feedback | None:
    """The ``Feedback`` of ``dataset`` at the model's step times ``time`` (S,) [s], or None when its
    scenario has no PD load. A law on a node the model does not predict is a one-line error."""
    laws = pd_laws(dataset)
    if not laws:
        return None
    M, S = encoding.n_kept, len(time)
    gains, targets = np.zeros((M, 2)), np.zeros((S, M, 3))
    sub = (np.arange(TARGET_SAMPLES) + 0.5) / TARGET_SAMPLES * encoding.model_dt
    nodes = []
    for law in laws:
        node = int(law.node) % encoding.n_nodes
        where = np.flatnonzero(encoding.kept == node)
        if len(where) == 0:
            raise bad("data", f"a PD load on node {node}, which the model does not predict",
                      "a node_stride whose kept nodes include every PD-driven node, or feedback = false")
        j = int(where[0])
        if gains[j, 0] != 0:
            raise bad("data", f"two PD loads on node {node}", "one PD law per node, or feedback = false")
        t = (np.asarray(time, dtype=np.float64)[:, None] + sub[None, :]).ravel()
        target = np.asarray(law.target(t), dtype=np.float64).reshape(S, TARGET_SAMPLES, 3).mean(axis=1)
        targets[:, j] = target - encoding.ref_positions[node]
        gains[j] = (law.stiffness, law.damping)
        nodes.append(node)
    return Feedback(gains=gains, targets=targets, model_dt=float(encoding.model_dt), nodes=tuple(sorted(nodes)))
