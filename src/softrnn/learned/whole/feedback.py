"""State-feedback loads (PD tracking) applied to a whole-manipulator model's own state (NumPy only).

A scenario's ``kind = "pd"`` load pulls a node toward a moving target,
``f = stiffness (target(t) - r) - damping v`` (``softrnn.rod.loads.PDTracking``). A data set records
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

import json
import tomllib
from dataclasses import dataclass

import numpy as np

from ...errors import SoftrnnInputError, bad
from ...rod.loads import (
    CirclePath,
    Constant,
    Figure8Path,
    PDTracking,
    RandomSmoothPath,
    Sinusoid,
    SquarePath,
    Sum,
    Window,
)

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
    """The ``PDTracking`` loads of the scenario a data set was simulated from: the ``[[loads]]``
    entries of kind ``"pd"`` in its ``attrs["scenario_text"]`` (TOML), with a sweep variant's drawn
    values (``attrs["sampled"]``: {dotted key: value}, as ``softrnn sweep`` records them) put in
    first. [] for data without a scenario (lab data) or a scenario without PD loads; a PD load that
    cannot be rebuilt is a one-line error."""
    text = dataset.attrs.get("scenario_text")
    if not isinstance(text, str) or not text.strip():
        return []
    try:
        doc = tomllib.loads(text)
        _put_sampled(doc, dataset.attrs)
        entries = doc.get("loads", [])
        return [_law(entry) for entry in entries if isinstance(entry, dict) and entry.get("kind") == "pd"]
    except (tomllib.TOMLDecodeError, SoftrnnInputError, KeyError, TypeError, ValueError, IndexError) as err:
        if '"pd"' not in text:
            return []
        raise bad("data", f"a data set whose PD loads cannot be rebuilt ({str(err)[:80]})",
                  "data whose scenario_text softrnn can read, or feedback = false (the recorded PD forces "
                  "as inputs)") from None


def moving_clamps(dataset) -> tuple:
    """The nodes (0-based, increasing) that the scenario a data set was simulated from moves along a
    prescribed path: ``[[boundary]]`` entries of kind clamp with a displacement or rotation in its
    ``attrs["scenario_text"]``. () for data without a scenario (lab data) or without such a clamp."""
    text = dataset.attrs.get("scenario_text")
    if not isinstance(text, str) or "boundary" not in text:
        return ()
    try:
        entries = tomllib.loads(text).get("boundary", [])
    except tomllib.TOMLDecodeError:
        return ()
    n = len(dataset.nodes)
    nodes = {int(e["node"]) % n for e in entries if isinstance(e, dict) and e.get("kind") == "clamp"
             and isinstance(e.get("node"), int) and ("displacement" in e or "rotation" in e)}
    return tuple(sorted(nodes))


def _put_sampled(doc: dict, attrs) -> None:
    """A sweep variant's drawn values (``attrs["sampled"]``, JSON) set into the scenario document;
    a variant whose draws of its PD loads were not recorded is a ``ValueError``."""
    sampled = attrs.get("sampled")
    sampled = json.loads(sampled) if isinstance(sampled, str) else dict(sampled or {})
    if attrs.get("variant_index") is not None and not sampled:
        pd = {str(i) for i, e in enumerate(doc.get("loads", [])) if isinstance(e, dict) and e.get("kind") == "pd"}
        if any(key.split(".")[:2] in (["loads", i] for i in pd) for key in doc.get("randomize", {})):
            raise ValueError("a sweep variant without its drawn values (attrs 'sampled')")
    for key, value in sampled.items():
        *path, last = key.split(".")
        node = doc
        for part in path:
            node = node[int(part)] if isinstance(node, list) else node[part]
        if isinstance(node, list):
            node[int(last)] = value
        else:
            node[last] = value


def _law(entry: dict) -> PDTracking:
    """A ``[[loads]]`` entry of kind ``"pd"`` as ``PDTracking`` (node as written: negative counts
    from the end)."""
    node = entry["node"]
    if isinstance(node, bool) or not isinstance(node, int):
        raise ValueError(f"loads node {node!r} is not an integer")
    return PDTracking(node, _target(entry["target"]), stiffness=float(entry["stiffness"]),
                      damping=float(entry.get("damping", 0.0)))


_PLANE_PATHS = {"square": (SquarePath, ("side", "period")), "circle": (CirclePath, ("radius", "period")),
                "figure8": (Figure8Path, ("width", "height", "period")),
                "random_smooth": (RandomSmoothPath, ("amplitude", "cutoff"))}
"""The target paths a PD law may follow: kind -> (class, its numbers besides centre, axes and ramp)."""


def _target(raw: dict):
    """The time function of a PD target's profile table, built as the scenario file builds it."""
    kind = raw["kind"]
    if kind == "constant":
        return Constant(_vec(raw["value"]))
    if kind == "sinusoid":
        return Sinusoid(_vec(raw["amplitude"]), float(raw["frequency"]), phase=float(raw.get("phase", 0.0)),
                        offset=_vec(raw.get("offset", (0.0, 0.0, 0.0))))
    if kind == "window":
        return Window(_target(raw["function"]), float(raw["start"]), float(raw["stop"]))
    if kind == "sum":
        return Sum(tuple(_target(term) for term in raw["terms"]))
    if kind not in _PLANE_PATHS:
        raise ValueError(f"a PD target of kind {kind!r}")
    cls, names = _PLANE_PATHS[kind]
    args = {name: _vec(raw[name]) for name in ("u", "v") if name in raw}
    args["ramp"] = float(raw.get("ramp", 1.0))
    numbers = [float(raw[name]) for name in names]
    if kind == "random_smooth":
        return cls(_vec(raw["center"]), *numbers, int(raw["seed"]), n_modes=int(raw.get("n_modes", 6)), **args)
    return cls(_vec(raw["center"]), *numbers, **args)


def _vec(x) -> tuple:
    """A 3-vector of floats."""
    if len(x) != 3:
        raise ValueError(f"{x!r} is not a 3-vector")
    return tuple(float(c) for c in x)


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
