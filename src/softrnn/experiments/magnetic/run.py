"""The simulated magnetic experiment end to end (paper section 5): real robot, camera, both models, Table 1."""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from ...errors import bad
from ...magnetics.camera import camera_measure
from ...magnetics.manipulator import ManipulatorRun, ManipulatorSpec, check_manipulator_run, simulate_manipulator
from ...progress import Progress
from .comparison import compare
from .config import MAGNETS, ORIENTATION_NOTE, ROBOT_FILE, TABLE_FILE, ExperimentConfig
from .currents import experiment_currents
from .dataset import measured_wrenches, orientation_dataset
from .static import static_predictions


def _simulate_robot(config: ExperimentConfig, spec: ManipulatorSpec, path: Path, progress: Progress | None) -> tuple:
    """(time (T,), node positions (T, n, 3) as stored (float32), currents (T, n_c), wall seconds, resumed)."""
    from ...io.dataset import DatasetError, read_dataset, write_trajectory

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
    if progress is not None:
        progress(0, 1, {"stage": "simulate"})
    robot = config.robot_spec(spec)
    schedule = experiment_currents(spec, config)
    run = ManipulatorRun(dt=config.dt, n_samples=config.samples, settle=config.settle)
    t0 = time.perf_counter()
    traj = simulate_manipulator(robot, schedule, run)
    seconds = time.perf_counter() - t0
    attrs = {"experiment_fingerprint": fingerprint, "experiment": config.to_dict(),
             "currents": traj.currents.tolist(), "currents_units": "A, one row per sample, coils 0..5",
             "simulation_seconds": seconds, "scenario_name": "magnetic-experiment-robot",
             "description": "the simulated 'real robot' of the magnetic experiment "
                            "(softrnn.experiments.magnetic.experiment)"}
    write_trajectory(path, traj.rod, dt=config.dt, rod=robot.rod_spec(), seed=config.seed, attrs=attrs,
                     scenario_text=json.dumps(config.to_dict()))
    if progress is not None:
        progress(1, 1, {"stage": "simulate"})
    stored = read_dataset(path)
    return stored.time, np.asarray(stored.positions, np.float64), traj.currents, seconds, False


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
        "evaluation": "errors against the camera measurement on the test span; the LSTM one step ahead from the "
                      "measured history (as Table 1) and free running (own history, the other magnet measured)",
    }


def run_experiment(config: ExperimentConfig, out_dir, progress: Progress | None = None) -> dict:
    """Run the simulated experiment into ``out_dir`` and return the report.

    Files: ``robot.h5`` (the real robot's record: every node, the currents in its attrs; reused when
    it exists with the same simulation settings), ``models/proximal`` and ``models/distal`` (the
    LSTMs), ``table1.json`` (the report) and ``fig12.png``.

    Returns
    -------
    dict (JSON-ready)
        ``distal`` and ``proximal``, each with ``rnn``, ``cosserat`` and ``rnn_free_running`` as
        [[max, mean] per axis x, y, z] in degrees (and ``tangent_angles``); ``paper`` (Table 1 in the
        same shape); ``bending_axis`` (the axis of the largest measured range); per magnet
        ``lstm_beats_static_on_bending_axis`` (a lower mean error about it) and ``..._max`` (a lower
        max error); ``static`` (failures,
        solves); ``timings`` (simulation, static, training and total seconds, static solves and
        predictions per second, LSTM steps per second); ``assumptions``; ``config``; ``files``.
    """
    if not isinstance(config, ExperimentConfig):
        raise bad("config", type(config).__name__, "an ExperimentConfig")
    t_start = time.perf_counter()
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise bad("out_dir", str(out), "a folder (it exists and is a file)")
    spec = ManipulatorSpec()
    # refuse an absurd run before the currents are made and the folder is created
    check_manipulator_run(config.robot_spec(spec), ManipulatorRun(dt=config.dt, n_samples=config.samples,
                                                                  settle=config.settle),
                          extra_bytes=(config.samples - 1) * 10 * 17 * 8)   # experiment_currents' arrays
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
    static = static_predictions(currents, spec=spec, n_steps=config.static_steps, tol=config.static_tol,
                                position_tol=config.position_tol, max_failures=config.max_static_failures,
                                progress=progress)
    static_info = {"failures": len(static.failures), "failed_samples": [k for k, _ in static.failures][:20],
                   "first_failure": static.failures[0][1] if static.failures else None,
                   "solves": int(static.solves.sum()), "mean_solves_per_sample": float(static.solves.mean()),
                   "n_steps": config.static_steps, "tol": config.static_tol}
    dataset = orientation_dataset(time_s, cam.orientations, wrenches, extra={"experiment": config.to_dict()})
    result = compare(dataset, static.orientations, config, out, progress=progress, static_info=static_info,
                     figure_title=f"Simulated magnetic experiment ({config.samples} samples at "
                                  f"{config.sample_rate:g} Hz): orientations over the test span (the paper's Fig. 12)")
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
    from ...files import atomic_write_text

    atomic_write_text(out / TABLE_FILE, json.dumps(result, indent=2, allow_nan=False) + "\n")
    return result
