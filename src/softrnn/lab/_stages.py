"""The pieces of the real-robot benchmark (``softrnn.lab.benchmark``) that run apart, each in a worker
process of ``softrnn.lab._pool`` or one after the other here: each learned family with its options
chosen on the training hold-out and its refit on every training row, run over the validation session
(``family_run``), which the benchmark scores (``Ran``, ``collect_families``). Each family seeds its own
random numbers (``seeded``), so that no family's figures depend on which families ran before it in the
same process. Also the dynamic families, fitted in this process (``dynamic_models``).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..learned.metrics import tip_errors
from ._pool import WorkerPool
from .dynamic_families import DynamicHybrid, DynamicPhysics
from .families import finite_or_inf, holdout_split, remember_refits
from .nets import (
    BEYOND_GATE,
    NODE_FINAL,
    fit_hybrid,
    fit_learned_map,
    fit_node,
    fit_sequence,
    follow_physics,
    node_choice,
    node_final,
    node_single,
    seeded,
)
from .recording import Recording
from .uncertainty import InputDistance, WithInterval

LONGEST_FIRST = ("sequence", "node_lstm", "learned_map", "hybrid")
"""The learned families in the order they are handed to the workers: the longest first (on the shared
robot's recordings), so that no core idles while the longest runs at the end."""
FITS = {"learned_map": fit_learned_map, "hybrid": fit_hybrid, "sequence": fit_sequence, "node_lstm": fit_node}
"""The learned families, in report order, and how each is fitted with its options chosen on the hold-out."""
EARLY = ("sequence", "node_lstm", "learned_map")
"""The families with candidates that need no physics (``nets.early_candidates``: those on the real rows
alone), each family's fitted in a job of its own that the workers take while the physics calibrates,
then handed to ``family_run``: the longest first, as ``LONGEST_FIRST``."""


@dataclass(frozen=True)
class Ran:
    """A fitted model's free run over the validation session.

    Attributes
    ----------
    name : str
        the model or baseline
    tip : (T, 3) float [m]
        the predicted tip
    radius : (T,) float [m] or None
        the stated 90 % ball (None: the model states no uncertainty)
    details : dict
        the model's ``describe()``, with its hold-out scores {candidate: tip RMSE [mm]} where chosen
    """

    name: str
    tip: np.ndarray
    radius: np.ndarray | None
    details: dict


def run_model(name: str, model, session: Recording, holdout_scores: dict | None = None) -> Ran:
    """``model`` run free over ``session``: by ``predict_interval(session) -> (tip (T, 3) [m], radius (T,)
    [m])`` where it states a 90 % ball, else by ``predict``; ``holdout_scores`` go to its details."""
    radius = None
    if hasattr(model, "predict_interval"):
        tip, radius = model.predict_interval(session)
    else:
        tip = model.predict(session)
    details = model.describe()
    if holdout_scores is not None:
        details["holdout_rmse_mm"] = holdout_scores
    return Ran(name=name, tip=tip, radius=radius, details=details)


class HeldScore:
    """A model's score on the hold-out part ``held`` (a list of ``Recording``): the tip RMSE [mm] of its
    free run over each session, rounded to 4 digits."""

    def __init__(self, held: list):
        self.held, self.reference = list(held), np.vstack([s.tip for s in held])

    def __call__(self, model) -> float:
        return round(tip_errors(np.vstack([model.predict(s) for s in self.held]), self.reference).rmse_mm, 4)


def family_run(name: str, train: list, pair: tuple, syn, no_syn: str | None, options, validation: Recording,
               early: dict | None = None, refits: dict | None = None) -> tuple[Ran, float, np.ndarray | None]:
    """The learned family ``name`` (a key of ``FITS``) fitted on ``train`` with its options chosen on the
    hold-out part (``pair``: the physics calibrated on the fitting part and on every training row;
    ``syn``: the synthetic data's options, ``no_syn`` why there are none), run over ``validation``;
    and its best hold-out score [mm]. ``early``: candidates fitted before, in a job of their own
    (``EARLY``, ``nets.early_candidates``: {candidate: model}); ``refits``: the physics' refits made
    before (``families.shared_refits``: the physics' interval's, which the hybrid's interval makes again).
    Also, where the model follows its physics (``nets.FollowsPhysics``: the hybrid, the sequence model over
    the physics; the node LSTM over the physics, ``families.NodeFamily.physics_weights``), its learned part's
    weight (T,) over ``validation``, with which ``collect_families`` blends its interval with the physics'
    (None otherwise)."""
    remember_refits(refits)
    more = {"early": early} if early else {}
    with seeded(name):
        model, scores = FITS[name](train, pair, syn, options, HeldScore(holdout_split(train)[1]), **more)
    return _ran(name, model, scores, validation, no_syn)


def _ran(name: str, model, scores: dict, validation: Recording, no_syn: str | None) -> tuple:
    """``family_run``'s result for the fitted ``model`` of family ``name`` and its candidates' hold-out
    ``scores`` [mm]."""
    ran = run_model(name, model, validation, scores)
    if no_syn:
        ran.details["synthetic_data"] = f"not used: {no_syn}"
    weights = model.physics_weights(validation) if hasattr(model, "physics_weights") else None
    return ran, min(scores.values(), key=finite_or_inf), weights


def node_choice_run(train: list, pair: tuple, syn, options, early: dict | None = None) -> tuple:
    """The node LSTM's choice (``nets.node_choice``) as a job, seeded as ``family_run`` seeds the family: (its
    interval's parameters, the candidates' hold-out scores [mm])."""
    with seeded("node_lstm"):
        _, interval, scores = node_choice(train, pair, syn, options, HeldScore(holdout_split(train)[1]), early)
    return interval, scores


class Joined:
    """Jobs of one family that run apart (the node LSTM's choice and its refit on every training row), seen as
    one job named ``label`` (``WorkerPool.as_completed``): ready when every one is; ``get()`` hands their
    results to ``combine`` here, once."""

    def __init__(self, label: str, jobs: tuple, combine):
        self.label, self.jobs, self.combine = label, tuple(jobs), combine
        self._result, self._done = None, False

    def ready(self) -> bool:
        """Whether every job has finished (or, in this process, can run now)."""
        return all(job.ready() for job in self.jobs)

    def wait(self, timeout: float) -> None:
        """Wait at most ``timeout`` [s] for the first job that has not finished."""
        next((job for job in self.jobs if not job.ready()), self.jobs[0]).wait(timeout)

    def get(self):
        """The combined result."""
        if not self._done:
            self._result, self._done = self.combine(*(job.get() for job in self.jobs)), True
        return self._result


def submit_family(pool: WorkerPool, name: str, train: list, pair: tuple, syn, no_syn: str | None, options,
                  validation: Recording, early: dict | None = None, refits: dict | None = None):
    """The learned family ``name``'s job (``family_run``, the same arguments) in ``pool``. The node LSTM with a
    single candidate (``nets.node_single``) as two jobs side by side, its choice and its refit on every
    training row (``nets.node_final``, which waits for no choice), joined here (``Joined``): the same figures,
    the longest family's time shared between two workers."""
    if name != "node_lstm" or not node_single(pair, syn):
        return pool.submit(name, family_run, name, train, pair, syn, no_syn, options, validation, early, refits)
    choice = pool.submit(name, node_choice_run, train, pair, syn, options, early)
    final = pool.submit(NODE_FINAL, node_final, train, pair, syn, options)

    def combine(chosen: tuple, model) -> tuple:
        interval, scores = chosen
        return _ran(name, WithInterval(model, InputDistance.of(train), **interval), scores, validation, no_syn)
    return Joined(name, (choice, final), combine)


def collect_families(jobs: list, pool: WorkerPool, out, step, physics_interval=None) -> dict:
    """The learned families' runs (the jobs of ``family_run``) scored into ``out`` (the benchmark's table of
    scores) in report order, ``step(name)`` as each finishes; returns each family's hold-out score [mm].
    ``physics_interval``: the physics with its calibrated interval (``uncertainty.with_interval``), which a
    model that follows its physics (one with ``physics_weights``: ``nets.FollowsPhysics``, the node LSTM over
    the physics) states where its learned part is off."""
    runs = {}
    for job in pool.as_completed(jobs):
        runs[job.label] = job.get()
        step(job.label)
    holdout, physics_radius = {}, None
    for name in (f for f in FITS if f in runs):
        ran, score, weights = runs[name]
        if weights is not None and physics_interval is not None:
            if physics_radius is None:
                physics_radius = physics_interval.predict_interval(out.validation)[1]
            ran = replace(ran, radius=follow_physics(weights, physics_radius, ran.radius),
                          details=ran.details | BEYOND_GATE)
        out.add(out.models, ran)
        holdout[name] = score
    return holdout


def dynamic_models(train: list[Recording], families: list, robot, out, step) -> dict:
    """The calibrated dynamic physics and the hybrid on it (those of ``families``), fitted on ``train`` and
    scored into ``out`` (the benchmark's table), ``step(name)`` after each; their hold-out scores [mm]."""
    holdout = {}
    if not families:
        return holdout
    physics = DynamicPhysics(robot).fit(train)
    if "dynamic_physics" in families:
        holdout["dynamic_physics"] = physics.holdout_rmse_mm
        out.record(out.models, "dynamic_physics", physics)
        step("dynamic_physics")
    if "dynamic_hybrid" in families:
        hybrid = DynamicHybrid(physics).fit(train)
        holdout["dynamic_hybrid"] = hybrid.holdout_rmse_mm
        out.record(out.models, "dynamic_hybrid", hybrid, hybrid.holdout_scores)
        step("dynamic_hybrid")
    return holdout
