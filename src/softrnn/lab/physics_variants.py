"""The tendon robot's physics variant chosen on the training hold-out: the plain model, with
gravity, with friction along the routing, with both, or with the tendons' creep (and, asked for, with
the tendons' play) (``softrnn.lab.tendon_robot``), each calibrated on the hold-out's fitting part and
scored by its free run over the held part (Euclidean tip RMSE); the simplest within one standard
error of the best (``families.parsimonious``) is refitted on every training row. A variant with creep
runs through the held rows too while it is fitted (``families.masked``): the tendons crept while the
robot ran them, and a held stretch starts from the slack it had then."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ..errors import bad
from ..learned.metrics import tip_errors
from ._pool import WorkerPool
from .families import Physics, held_rows, masked, parsimonious
from .tendon_robot import PHYSICS_OPTIONS, CalibrationOptions, TendonRobot

VARIANTS = {"plain": (False, False, False, False, False), "gravity": (True, False, False, False, False),
            "friction": (False, True, False, False, False), "creep": (False, False, False, True, False),
            "gravity+friction": (True, True, False, False, False)}
"""The physics variants tried by default, simplest first: {name: (gravity, friction, play, creep, twist)}
(``PHYSICS_OPTIONS``)."""
MORE_VARIANTS = {"play": (False, False, True, False, False), "friction+play": (False, True, True, False, False),
                 "friction+creep": (False, True, False, True, False), "creep+twist": (False, False, False, True, True)}
"""Variants tried where asked for (``choose_physics``' ``variants``), not by default: the tendons' play, fitted
to zero width on the shared robot's training session (its fit there worsens with any play); the robot's turn
with its creep, which does not carry forward along that session reliably (docs/guide/real-robots.md)."""


@dataclass(frozen=True, eq=False)
class PhysicsChoice:
    """The chosen physics variant.

    Attributes
    ----------
    variant : str
        the variant with the lowest hold-out score (a key of ``VARIANTS``)
    holdout_rmse_mm : dict
        {variant: tip RMSE [mm] of its free run over the held part}
    held : Physics
        the chosen variant calibrated on the fitting part
    physics : Physics
        the chosen variant refitted on every training row (refined from ``held``)
    """

    variant: str
    holdout_rmse_mm: dict
    held: Physics
    physics: Physics


def holdout_rmse_mm(model, held) -> float:
    """The tip RMSE [mm] of ``model``'s free run over each session of ``held`` (inf where not finite)."""
    score = tip_errors(np.vstack([model.predict(s) for s in held]), np.vstack([s.tip for s in held])).rmse_mm
    return round(score, 4) if math.isfinite(score) else math.inf


def _calibrated(model: Physics, fit_part: list, held: list) -> tuple[Physics, float]:
    """``model`` fitted on ``fit_part`` and its hold-out score on ``held`` (``holdout_rmse_mm``; its
    predictions there kept in the fitted model's memo)."""
    fitted = model.fit(fit_part)
    return fitted, holdout_rmse_mm(fitted, held)


def _fitting_rows(options, fit_part: list, held: list, train: list) -> list:
    """What a variant is fitted on for the hold-out: ``fit_part``, or with creep the training sessions
    with the held rows' tips masked (``masked``)."""
    return masked(train, held) if options.creep else fit_part


def _refit(model: Physics, train: list) -> Physics:
    return model.fit(train)


def choose_physics(robot: TendonRobot, options: CalibrationOptions, fit_part: list, held: list, train: list,
                   variants=tuple(VARIANTS), pool: WorkerPool | None = None, meanwhile=None) -> PhysicsChoice:
    """Calibrate every variant of ``variants`` on ``fit_part`` (the plain model from its multi-start
    search, the others refined from it), score each on ``held`` and refit the best on ``train``
    (lists of ``Recording``). ``options``' own gravity, friction, play and creep are replaced by each
    variant's.
    ``pool``: the plain model's search cut into one piece per worker at each of its stages, and the
    variants refined in its workers at once (``softrnn.lab._pool``; None: one by one here); the refit
    in this process, so that it waits for no job queued before it.
    ``meanwhile()``: called once the plain search's first stage is handed to the pool, to queue work
    behind it that needs no physics (the jobs go to the workers in the order submitted)."""
    known = VARIANTS | MORE_VARIANTS
    unknown = [v for v in variants if v not in known]
    if unknown or not variants:
        raise bad("variants", ",".join(variants), f"one or more of {', '.join(known)}")
    pool = WorkerPool(1) if pool is None else pool
    queued = meanwhile is None

    def spread(stage, fn, arguments):    # the plain search's fits, in the workers
        nonlocal queued
        jobs = [pool.submit("physics plain", fn, *args) for args in arguments]
        if not queued:                   # the first of them handed out: the work that needs no physics behind
            queued = True
            meanwhile()
        return [job.get() for job in jobs]

    plain = Physics(robot, replace(options, **dict.fromkeys(PHYSICS_OPTIONS, False))).fit(fit_part, spread,
                                                                                          pool.workers)
    score = holdout_rmse_mm(plain, held)
    others = [v for v in variants if v != "plain"]
    variant_options = {v: replace(options, **dict(zip(PHYSICS_OPTIONS, known[v]))) for v in others}
    jobs = [pool.submit(f"physics {v}", _calibrated, Physics(robot, variant_options[v], start=plain.calibration.params),
                        _fitting_rows(variant_options[v], fit_part, held, train), held) for v in others]
    done = {"plain": (plain, score)} | dict(zip(others, [job.get() for job in jobs]))
    fitted = {v: done[v][0] for v in variants}
    scores = {v: done[v][1] for v in variants}
    best = parsimonious(scores, held_rows(held))
    chosen = fitted[best]
    physics = pool.here("physics refit", _refit, replace(chosen, start=chosen.calibration.params,
                                                         calibration=None), train)
    return PhysicsChoice(variant=best, holdout_rmse_mm=scores, held=chosen, physics=physics)
