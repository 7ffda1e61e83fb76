"""The model families of dynamic recordings driven by tendon tensions (``softrnn.lab.dynamic_physics``).

* ``DynamicPhysics``: the robot's dynamic simulation, calibrated on the training sessions, run free
  over a session on its recorded tensions alone.
* ``DynamicHybrid``: that simulation plus a learned residual r = tip - simulated tip, a linear model
  of the tensions and the simulated tip run free (``RESIDUALS``: none, a static linear map, or an
  ARX model of the residual), chosen on the training hold-out.

Both follow ``softrnn.lab.families.Family`` and hold out the training sessions' last one (with one
session: its last quarter, the session simulated whole and scored on those rows): the physics is
calibrated on the rest, the residual's kind is chosen on it, and the 90 % interval
(``predict_interval``) is a ball whose radius is the 90th percentile of the hold-out's Euclidean
tip errors. The physics keeps the calibration of the fitting part; the chosen residual is then
refitted on every training row.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from ..learned.linear import LinearARX
from .dynamic_physics import DynamicCalibration, DynamicRobot, calibrate_dynamics
from .families import HOLDOUT_FRACTION, parsimonious
from .recording import Recording
from .uncertainty import COVERAGE

RESIDUALS = ("none", "static", "arx")
"""The residual models tried: none (the physics alone), r_k = W (u_k, p_k, 1) by least squares, and
the linear ARX model of r driven by (u, p) with two lags each (``softrnn.learned.linear.LinearARX``)."""


@dataclass(frozen=True)
class _Part:
    """A session and the rows of it that a stage uses (fit or score)."""

    session: Recording
    rows: slice


def split(sessions) -> tuple[list[_Part], list[_Part]]:
    """(fitting parts, hold-out parts): the last session held out, or with one session its rows
    from ``HOLDOUT_FRACTION`` on (the session is still simulated from its start)."""
    sessions = list(sessions)
    if len(sessions) >= 2:
        return [_Part(s, slice(0, None)) for s in sessions[:-1]], [_Part(sessions[-1], slice(0, None))]
    s = sessions[0]
    cut = int(round(HOLDOUT_FRACTION * s.n_rows))
    return [_Part(s, slice(0, cut))], [_Part(s, slice(cut, None))]


def _head(part: _Part) -> Recording:
    """The part's session cut to its rows (a fitting part starts at the session's start)."""
    return part.session.rows(part.rows.start or 0, part.rows.stop)


def _errors(pred: np.ndarray, ref: np.ndarray) -> np.ndarray:
    return np.linalg.norm(pred - ref, axis=1)


def _rmse_mm(errors: np.ndarray) -> float:
    return round(float(np.sqrt(np.mean(errors ** 2))) * 1e3, 4)


@dataclass(frozen=True, eq=False)
class DynamicPhysics:
    """The robot's dynamic simulation driven by the recorded tensions, calibrated on the training
    sessions' fitting part (``calibrate_dynamics``); ``progress`` goes to the calibration."""

    robot: DynamicRobot
    name: str = "dynamic_physics"
    calibration: DynamicCalibration | None = None
    holdout_rmse_mm: float | None = None
    radius_m: float | None = None
    progress: object = None
    memo: dict = field(default_factory=dict, repr=False)

    def fit(self, sessions) -> DynamicPhysics:
        """The model calibrated on training sessions (a list of ``Recording``)."""
        fit_part, held = split(sessions)
        cal = calibrate_dynamics(self.robot, [_head(p) for p in fit_part], progress=self.progress)
        out = replace(self, calibration=cal, memo={})
        err = np.concatenate([_errors(out.predict(p.session)[p.rows], p.session.tip[p.rows]) for p in held])
        return replace(out, holdout_rmse_mm=_rmse_mm(err), radius_m=float(np.quantile(err, COVERAGE)))

    def predict(self, session: Recording) -> np.ndarray:
        """The tip (T, 3) [m] over ``session``, free running from rest at its start on its tensions."""
        key = session.commands_key()
        if key not in self.memo:
            if len(self.memo) > 16:
                self.memo.clear()
            self.memo[key] = self.robot.tip(self.calibration.values, session)
        return self.memo[key].copy()

    def predict_interval(self, session: Recording) -> tuple[np.ndarray, np.ndarray]:
        """(tip (T, 3) [m], radius (T,) [m]): the prediction and its 90 % ball (hold-out calibrated)."""
        return self.predict(session), np.full(session.n_rows, self.radius_m)

    def describe(self) -> dict:
        """What the model is, its calibration and hold-out figures, JSON-ready."""
        sc = self.robot.scenario
        return {"kind": "calibrated dynamic rod simulation driven by the recorded tensions", "scenario": sc.name,
                "rod_nodes": sc.setup.rod.n_nodes, "scenario_rod_nodes": self.robot.nodes_described,
                "hold": self.robot.options.hold, "calibration": self.calibration.to_dict(),
                "holdout_rmse_mm_of_fitting_part_calibration": self.holdout_rmse_mm,
                "interval_90_radius_mm": round(self.radius_m * 1e3, 4)}


def _static_features(u: np.ndarray, p: np.ndarray) -> np.ndarray:
    return np.hstack([u, p, np.ones((len(u), 1))])


@dataclass(frozen=True, eq=False)
class Residual:
    """A residual model r = tip - simulated tip of ``kind`` (one of ``RESIDUALS``), fitted (``fit``)
    and run free over a session (``run``)."""

    kind: str
    weights: np.ndarray | None = None
    arx: LinearARX | None = None

    def fit(self, rows: list) -> Residual:
        """Fitted on ``rows``: (inputs (T, m), simulated tip (T, 3) [m], recorded tip (T, 3) [m]) each."""
        if self.kind == "none":
            return self
        if self.kind == "static":
            X = np.vstack([_static_features(u, p) for u, p, _ in rows])
            Y = np.vstack([y - p for _, p, y in rows])
            return replace(self, weights=np.linalg.lstsq(X, Y, rcond=None)[0])
        arx = LinearARX.fit([y - p for _, p, y in rows], [np.hstack([u, p]) for u, p, _ in rows], na=2, nb=2)
        return replace(self, arx=arx)

    def run(self, session: Recording, base: np.ndarray) -> np.ndarray:
        """The residual (T, 3) [m] over ``session`` given its simulated tip ``base`` (T, 3) [m], run
        free (the ARX model from the first rows' recorded residual, its initial condition)."""
        if self.kind == "none":
            return np.zeros_like(base)
        if self.kind == "static":
            return _static_features(session.inputs, base) @ self.weights
        return self.arx.run(session.tip - base, np.hstack([session.inputs, base]))


@dataclass(frozen=True, eq=False)
class DynamicHybrid:
    """The calibrated dynamic physics plus a residual model (``Residual``) whose kind is chosen on
    the training hold-out; ``physics`` fitted or to be fitted with it."""

    physics: DynamicPhysics
    name: str = "dynamic_hybrid"
    residual: Residual | None = None
    holdout_rmse_mm: float | None = None
    holdout_scores: dict | None = None
    radius_m: float | None = None

    def fit(self, sessions) -> DynamicHybrid:
        """The model fitted on training sessions (a list of ``Recording``)."""
        sessions = list(sessions)
        physics = self.physics if self.physics.calibration is not None else self.physics.fit(sessions)
        fit_part, held = split(sessions)

        def rows(parts):
            out = []
            for p in parts:
                base = physics.predict(p.session)
                out.append((p.session.inputs[p.rows], base[p.rows], p.session.tip[p.rows]))
            return out

        fit_rows = rows(fit_part)
        scores, errors = {}, {}
        for kind in RESIDUALS:
            model = Residual(kind).fit(fit_rows)
            err = []
            for p in held:
                base = physics.predict(p.session)
                pred = base + model.run(p.session, base)
                err.append(_errors(pred[p.rows], p.session.tip[p.rows]))
            errors[kind] = np.concatenate(err)
            rmse = _rmse_mm(errors[kind])
            scores[kind] = rmse if np.isfinite(rmse) else float("inf")
        best = parsimonious(scores, sum(len(e) for e in err))
        every = rows([_Part(s, slice(0, None)) for s in sessions])
        return replace(self, physics=physics, residual=Residual(best).fit(every), holdout_rmse_mm=scores[best],
                       holdout_scores=scores, radius_m=float(np.quantile(errors[best], COVERAGE)))

    def predict(self, session: Recording) -> np.ndarray:
        """The tip (T, 3) [m] over ``session``, free running from its start on its tensions."""
        base = self.physics.predict(session)
        return base + self.residual.run(session, base)

    def predict_interval(self, session: Recording) -> tuple[np.ndarray, np.ndarray]:
        """(tip (T, 3) [m], radius (T,) [m]): the prediction and its 90 % ball (hold-out calibrated)."""
        return self.predict(session), np.full(session.n_rows, self.radius_m)

    def describe(self) -> dict:
        """What the model is, the residual chosen and the hold-out figures, JSON-ready."""
        return {"kind": "calibrated dynamic physics + linear residual run free", "residual": self.residual.kind,
                "residual_holdout_rmse_mm": self.holdout_scores, "physics": self.physics.describe(),
                "interval_90_radius_mm": round(self.radius_m * 1e3, 4)}
