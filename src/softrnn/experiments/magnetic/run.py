"""The simulated magnetic experiment end to end (paper section 5): real robot, camera, both models, Table 1."""

from __future__ import annotations

import hashlib
import json
import shutil
import time
from dataclasses import replace as dc_replace
from pathlib import Path

import numpy as np

from ...calibration.parallel import Evaluator
from ...errors import bad
from ...files import atomic_write_text
from ...fitting import FitOptions
from ...io.reader import read_dataset
from ...io.schema import DatasetError
from ...io.writer import write_trajectory
from ...magnetics.camera import camera_measure
from ...magnetics.manipulator import ManipulatorRun, ManipulatorSpec, check_manipulator_run, simulate_manipulator
from ...magnetics.static import static_predictions
from ...progress import Progress
from .calibration import BOUNDS, FACTORS, calibrate_manipulator
from .comparison import compare
from .config import CALIBRATION_FILE, MAGNETS, ORIENTATION_NOTE, ROBOT_FILE, TABLE_FILE, ExperimentConfig
from .currents import experiment_currents
from .dataset import measured_wrenches, orientation_dataset
from .static import static_summary


def _staged(progress: Progress | None, stage: str) -> Progress | None:
    """``progress`` with ``{"stage": stage}`` added to every report (None: None)."""
    if progress is None:
        return None

    def report(done: int, total: int, info: dict | None = None) -> None:
        progress(done, total, {**(info or {}), "stage": stage})
    return report


def check_experiment_size(config: ExperimentConfig) -> None:
    """Refuse, before the currents are made or anything is written, a simulated robot run of
    ``config.samples`` too large for this machine (``check_manipulator_run``: the run's arrays and
    the currents ``experiment_currents`` makes, 10 per sample; the solver steps).

    Raises
    ------
    SoftrnnInputError
        The ``check_run_size`` line (``the run n_samples=... is too large for this machine ...``).
    """
    check_manipulator_run(config.robot_spec(ManipulatorSpec()),
                          ManipulatorRun(dt=config.dt, n_samples=config.samples, settle=config.settle),
                          extra_bytes=(config.samples - 1) * 10 * 17 * 8)   # experiment_currents' arrays


def _simulate_robot(config: ExperimentConfig, spec: ManipulatorSpec, path: Path, progress: Progress | None) -> tuple:
    """(time (T,), node positions (T, n, 3) as stored (float32), currents (T, n_c), wall seconds, resumed)."""
    fingerprint = config.simulation_fingerprint()
    if path.exists():
        try:
            data = read_dataset(path)
            if data.attrs.get("experiment_fingerprint") == fingerprint:
                if progress is not None:
                    progress(1, 1, {"stage": "simulate"})
                return (data.time, np.asarray(data.positions, np.float64), np.asarray(data.attrs["currents"], float),
                        float(data.attrs.get("simulation_seconds", 0.0)), True)
        except (DatasetError, KeyError, TypeError, ValueError):
            pass                                                                   # re-simulate and replace it
    robot = config.robot_spec(spec)
    schedule = experiment_currents(spec, config)
    run = ManipulatorRun(dt=config.dt, n_samples=config.samples, settle=config.settle)
    t0 = time.perf_counter()
    traj = simulate_manipulator(robot, schedule, run, progress=_staged(progress, "simulate"))
    seconds = time.perf_counter() - t0
    attrs = {"experiment_fingerprint": fingerprint, "experiment": config.to_dict(),
             "currents": traj.currents.tolist(), "currents_units": "A, one row per sample, coils 0..5",
             "simulation_seconds": seconds, "scenario_name": "magnetic-experiment-robot",
             "description": "the simulated 'real robot' of the magnetic experiment "
                            "(softrnn.experiments.magnetic.experiment)"}
    write_trajectory(path, traj.rod, dt=config.dt, rod=robot.rod_spec(), seed=config.seed, attrs=attrs,
                     scenario_text=json.dumps(config.to_dict()))
    stored = read_dataset(path)
    return stored.time, np.asarray(stored.positions, np.float64), traj.currents, seconds, False


def _calibration_fingerprint(config: ExperimentConfig) -> str:
    keys = ("camera_noise", "camera_points", "polynomial_degree", "train_fraction", "calibration_fraction",
            "calibration_evaluations")
    d = {k: config.to_dict()[k] for k in keys}
    d["simulation"] = config.simulation_fingerprint()
    return hashlib.sha256(json.dumps(d, sort_keys=True).encode()).hexdigest()[:16]


def calibrate_and_predict(currents, orientations, positions, config: ExperimentConfig, *, spec: ManipulatorSpec,
                          dt: float | None = None, truth: dict | None = None, workers: int = 2,
                          scheduler: str | None = None, progress: Progress | None = None,
                          cache_dir=None) -> tuple[dict, np.ndarray]:
    """Fit the dynamic model's stiffness, remanence and damping factors to the first
    ``config.calibration_samples`` samples of a record (``currents`` (T, n_c) [A], measured
    ``orientations`` (T, M, 3) [rad], ``positions`` (T, M, 3) [m] or None; samples ``dt`` [s] apart,
    None: ``config.dt``), then predict the whole record from the currents alone with the fitted
    model. Returns (the report's ``calibration`` dict, the predicted orientations (T, M, 3) [rad]).
    ``truth``: the real robot's factors, when known (the simulated experiment), reported beside
    the fitted ones."""

    T = int(np.asarray(currents).shape[0])
    n = config.calibration_samples(T)
    dt = config.dt if dt is None else float(dt)
    budget = config.calibration_evaluations * (len(FACTORS) + 1)     # the fit's most simulations (fitting.fit)
    if progress is not None:   # the bar from the start (the fit reports after each batch of simulations)
        progress(0, budget, {"stage": "calibrate"})
    t0 = time.perf_counter()
    with Evaluator(workers=workers, scheduler=scheduler) as evaluator:
        fitted, model = calibrate_manipulator(
            currents[:n], orientations[:n], None if positions is None else positions[:n], dt=dt,
            settle=config.settle, points=config.camera_points, degree=config.polynomial_degree, spec=spec,
            evaluator=evaluator, options=FitOptions(max_evaluations=config.calibration_evaluations),
            progress=_staged(progress, "calibrate"), cache_dir=cache_dir)
        n_workers = evaluator.workers
    if progress is not None:   # done, also when the fit converged before its budget
        progress(budget, budget, {"stage": "calibrate"})
    seconds = time.perf_counter() - t0
    t1 = time.perf_counter()
    full = dc_replace(model, currents=np.asarray(currents, dtype=np.float64))
    predicted, _ = full.camera(fitted.fitted, progress=_staged(progress, "predict"))   # samples simulated
    predict_seconds = time.perf_counter() - t1
    d = spec.damping
    nominal = {"stiffness": f"Young's modulus {spec.youngs_modulus:g} Pa",
               "remanence": "remanence " + ", ".join(f"{m.br:g} T" for m in spec.magnets),
               "damping": f"damping (translational {d.translational:g} N s/m^2, rotational {d.rotational:g} N m s/m, "
                          f"Kelvin-Voigt {d.kelvin_voigt:g} s)"}
    summary = fitted.to_dict()
    params = {}
    for i, name in enumerate(FACTORS):
        entry = {"fitted": float(fitted.fitted[i]), "std_error": float(fitted.std_error[i]), "start": 1.0,
                 "bounds": list(BOUNDS[name]), "factor_of": nominal[name]}
        if truth is not None:
            entry["truth"] = float(truth[name])
            entry["error_pct"] = 100.0 * (entry["fitted"] / entry["truth"] - 1.0)
        params[name] = entry
    info = {"parameters": params, "seconds": seconds, "trials": fitted.trials, "failed_trials": fitted.failed_trials,
            "cached_trials": fitted.cached_trials, "evaluations": fitted.evaluations, "workers": n_workers,
            "samples": n, "span_s": [0.0, (n - 1) * dt],
            "measured": "each magnet's orientation about x and y" + ("" if positions is None else " and position")
                        + ", per channel over its noise level (estimated from the fourth differences)",
            "rms_residual_start": fitted.rms_start, "rms_residual_fitted": fitted.rms_fitted,
            "correlation": summary["correlation"], "not_identifiable": fitted.not_identifiable,
            "success": fitted.success, "message": fitted.message, "prediction_seconds": predict_seconds,
            "history": summary["history"]}
    if truth is not None:
        err = {k: abs(v["error_pct"]) for k, v in params.items()}
        info["goals"] = {"stiffness_within_1pct": err["stiffness"] <= 1.0,
                         "remanence_within_1pct": err["remanence"] <= 1.0,
                         "damping_within_10pct": err["damping"] <= 10.0,
                         "within_2_minutes": seconds <= 120.0}
    return info, predicted


def _calibrated(config: ExperimentConfig, spec: ManipulatorSpec, currents, cam, out: Path, workers: int,
                scheduler: str | None, progress: Progress | None) -> tuple:
    """(calibration dict, predicted orientations (T, M, 3) [rad]), reused from ``calibration.json``
    when it holds this record's calibration."""
    path = out / CALIBRATION_FILE
    fingerprint = _calibration_fingerprint(config)
    if path.exists():
        try:
            stored = json.loads(path.read_text())
            if stored.get("fingerprint") == fingerprint:
                if progress is not None:
                    progress(1, 1, {"stage": "predict"})
                return stored["calibration"], np.asarray(stored["predicted_orientations"], float)
        except (OSError, ValueError, KeyError, TypeError):
            pass                                                                  # calibrate again
    truth = {"stiffness": config.stiffness, "remanence": config.remanence, "damping": config.damping}
    info, predicted = calibrate_and_predict(currents, cam.orientations, cam.positions, config, spec=spec, truth=truth,
                                            workers=workers, scheduler=scheduler, progress=progress,
                                            cache_dir=out / ".calibration-trials")
    atomic_write_text(path, json.dumps({"fingerprint": fingerprint, "calibration": info,
                                        "predicted_orientations": predicted.tolist()}) + "\n")

    shutil.rmtree(out / ".calibration-trials", ignore_errors=True)
    return info, predicted


def assumptions(config: ExperimentConfig) -> dict:
    """The documented modelling choices of the simulated experiment (for the report)."""
    return {
        "robot": f"the dynamic Cosserat model (softrnn.magnetics, 26 nodes, magnetic.md defaults: L 50 mm, D 3 mm, "
                 f"N42 at L/2 and N45 at L - 1 mm) plays the real robot with Young's modulus x{config.stiffness:g}, "
                 f"remanence x{config.remanence:g}, damping x{config.damping:g} and density x{config.density:g} of "
                 f"the nominal values the static model uses, so the comparison is not circular",
        "currents": f"minimum-norm coil currents for a smooth random field at the workspace centre, peaks "
                    f"{[round(1e3 * a, 3) for a in config.field_amplitude]} mT (x, y, z), {config.field_band[0]:g}-"
                    f"{config.field_band[1]:g} Hz; y is out of plane (the paper's motion is planar); "
                    f"{config.settle:g} s of settling before the first sample",
        "camera": f"{config.camera_points} centreline points at {config.sample_rate:g} Hz with "
                  f"{1e3 * config.camera_noise:g} mm Gaussian noise per coordinate, a degree-"
                  f"{config.polynomial_degree} polynomial P(s) per coordinate, magnet pose from P(s_m) and "
                  f"dP/ds(s_m) (paper Sec. 5.2)",
        "orientation": ORIENTATION_NOTE,
        "static_model": f"static Cosserat BVP (softrnn.statics, RK4 N = {config.static_steps}, E = "
                        f"{config.static_tol:g}) with the nominal parameters, from the currents alone; B and G at "
                        f"the magnets by fixed-point iteration on their positions (to {config.position_tol:g} m); "
                        f"failed samples are counted and left out, never used",
        "lstm": f"paper Fig. 11: one model per magnet, input I both magnets' measured orientations, input II the "
                f"magnet's wrench [f, tau] from the measured pose, the nominal moment and the currents (as the "
                f"paper computed it); history {config.history}, first {100 * config.train_fraction:g} % for "
                f"training (its last 20 % for early stopping), {config.epochs} epochs, batch {config.batch_size}, "
                f"2 x {config.lstm_units} LSTM units",
        "calibration": (f"the dynamic Cosserat model (the robot's structure, nominal values) with its Young's "
                        f"modulus, remanence and damping scaled by factors fitted (softrnn.calibration, bounded least "
                        f"squares) to the camera's magnet orientations about x and y and positions over the first "
                        f"{100 * config.calibration_fraction:g} % of the training span, each channel weighted by its "
                        f"noise level; the recorded 30 Hz currents drive it, linear in between (the robot had them "
                        f"10x finer); it then predicts the whole record from the currents alone"
                        if config.calibrate else "not run"),
        "evaluation": "errors against the camera measurement on the test span; the LSTM one step ahead from the "
                      "measured history (as Table 1) and free running (own history, the other magnet measured)",
    }


def run_experiment(config: ExperimentConfig, out_dir, progress: Progress | None = None, *, workers: int = 2,
                   scheduler: str | None = None) -> dict:
    """Run the simulated experiment into ``out_dir`` and return the report.

    Files: ``robot.h5`` (the real robot's record: every node, the currents in its attrs; reused when
    it exists with the same simulation settings), ``calibration.json`` (the calibration and the
    calibrated model's predictions; reused likewise), ``models/proximal`` and ``models/distal``
    (the LSTMs), ``table1.json`` (the report) and ``fig12.png``. ``workers``, ``scheduler``: where
    the calibration's simulations run (``softrnn.calibration.parallel.Evaluator``).

    Returns
    -------
    dict (JSON-ready)
        ``distal`` and ``proximal`` (the errors of ``rnn``, ``cosserat``, ``calibrated`` and
        ``rnn_free_running`` as [[max, mean] per axis x, y, z] in degrees), ``paper`` (Table 1 in that
        shape), the bending-axis comparisons, ``calibration``, ``static``, ``timings``,
        ``assumptions``, ``config``, ``files``; every key: docs/report-format.md.
    """
    if not isinstance(config, ExperimentConfig):
        raise bad("config", type(config).__name__, "an ExperimentConfig")
    t_start = time.perf_counter()
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise bad("out_dir", str(out), "a folder (it exists and is a file)")
    spec = ManipulatorSpec()
    check_experiment_size(config)     # an absurd run is refused before the currents are made and the folder created
    out.mkdir(parents=True, exist_ok=True)
    time_s, X, currents, sim_seconds, resumed = _simulate_robot(config, spec, out / ROBOT_FILE, progress)
    s_nodes = np.linspace(0.0, spec.length, spec.n_nodes)
    s_magnets = np.array([m.arc_length for m in spec.magnets])
    rng = np.random.default_rng([config.seed, 0x63616D])
    cam = camera_measure(X, s_nodes, s_magnets, config.camera_noise, rng, points=config.camera_points,
                         degree=config.polynomial_degree)
    wrenches = measured_wrenches(spec, currents, cam.positions, cam.tangents)
    if progress is not None:
        progress(1, 1, {"stage": "camera"})
    calibration, calibrated = None, None
    if config.calibrate:
        calibration, calibrated = _calibrated(config, spec, currents, cam, out, workers, scheduler, progress)
    static = static_predictions(currents, spec=spec, n_steps=config.static_steps, tol=config.static_tol,
                                position_tol=config.position_tol, max_failures=config.max_static_failures,
                                progress=progress)
    static_info = static_summary(static, config.static_steps, config.static_tol)
    dataset = orientation_dataset(time_s, cam.orientations, wrenches, extra={"experiment": config.to_dict()})
    result = compare(dataset, static.orientations, config, out, progress=progress, static_info=static_info,
                     figure_title=f"Simulated magnetic experiment ({config.samples} samples at "
                                  f"{config.sample_rate:g} Hz): orientations over the test span (the paper's Fig. 12)",
                     calibrated_orientations=calibrated)
    result["calibration"] = calibration
    result["timings"].update({
        "simulation_s": sim_seconds, "simulation_resumed": resumed,
        "simulated_seconds": float(time_s[-1] - time_s[0]) + config.settle,
        "static_s": static.seconds, "static_solves_per_second": static.solves_per_second,
        "static_predictions_per_second": static.predictions_per_second,
        "total_s": time.perf_counter() - t_start})
    result["assumptions"] = assumptions(config)
    result["config"] = config.to_dict()
    result["files"] = {"robot": str(out / ROBOT_FILE), "table": str(out / TABLE_FILE), "figure": result["figure"],
                       "models": {name: result[name]["model"] for name in MAGNETS}}

    atomic_write_text(out / TABLE_FILE, json.dumps(result, indent=2, allow_nan=False) + "\n")
    return result
