"""Speed of the learned whole-manipulator model (``softrnn.learned.whole``) beside the simulator it
stands in for, per paper case, on one core each and in the same run.

* **simulator**: ``Simulator(setup).run(config)`` of the case for ``duration_s`` simulated seconds
  saved every ``SAVED_DT`` (the reproduce sweeps' interval; for a trained model whose step is not
  a multiple of it, its training data's), numba pinned to one thread, the node of interest saved
  (its fastest set-up; every node saved is recorded beside it), timed as ``softrnn bench``'s
  simulator part times a case (``simulator.time_single``);
* **model**: one ``DynamicEngine.step`` (NumPy, on the calling thread) per model step, timed by
  ``softrnn.timing.step_rate``. Each call steps from a recorded history of a short simulated
  trajectory of the case (the arithmetic of a free run, which a diverging model could not finish);
  ``cpu_fraction`` (process CPU / wall) shows whether NumPy used more than one core.

Simulated seconds per wall second: the simulator's ``realtime_factor``; the model's steps per
second times its step ``model_dt``. ``speed_ratio_vs_simulator`` = model / simulator.

Without a trained model the architecture of the case (the ``DynamicConfig`` given, by default
``DynamicConfig()``; ``softrnn bench`` and ``softrnn reproduce`` pass the reproduce pipeline's) is
built untrained on the short trajectory's rod: the cost of a step does not depend on the weights'
values. ``run_dynamic_benchmark`` returns a JSON-ready dict,
``format_dynamic_table`` renders it; neither prints.
"""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path

import numba
import numpy as np

from ..errors import SoftrnnInputError, bad
from ..io.reader import Dataset
from ..learned.whole.artifact import engine_of, is_dynamic_folder, load_dynamic
from ..learned.whole.config import DynamicConfig, resolve_node_stride, resolve_stride
from ..learned.whole.data import rod_length
from ..learned.whole.encoding import make_encoding
from ..progress import Progress
from ..rod import Simulator
from ..scenarios.cases import build_case
from ..sweeps.sweep import run_config
from ..timing import step_rate
from .simulator import time_single

CASES = ("ellipse", "square", "semicircle")
SAVED_DT = 0.01
"""The saved interval [s] of the stand-in model's data (the reproduce pipeline's sweeps)."""
GOAL_SPEED_RATIO = 10.0


def case_run(name: str, dt: float = SAVED_DT):
    """(setup, RunConfig saved every ``dt`` [s] with every node, node of interest) of a paper case."""
    case = build_case(name)
    config = dataclasses.replace(run_config(case.config, dt=dt), save_nodes=None)
    return case.setup, config, int(case.node_of_interest)


def simulated_dataset(setup, config, duration_s: float):
    """The first ``duration_s`` simulated seconds of ``setup`` saved every ``config.dt``, every node,
    as an in-memory ``softrnn.io.Dataset`` (what the model encodes)."""
    n = int(max(2, round(duration_s / config.dt) + 1))
    traj = Simulator(setup).run(dataclasses.replace(config, n_samples=n, save_nodes=None))
    return Dataset(time=traj.time, nodes=traj.nodes, positions=traj.positions, quaternions=traj.quaternions,
                   forces=traj.forces, torques=traj.torques,
                   attrs={"dt": float(config.dt), "rod": {"length": float(setup.rod.length)}})


def simulator_speed(setup, config, node: int, duration_s: float, reps: int) -> dict:
    """Simulated seconds per wall second of ``Simulator(setup).run`` on one thread (numba pinned to 1)."""

    previous = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        r = time_single(setup, dataclasses.replace(config, n_samples=int(round(duration_s / config.dt)) + 1),
                        (node,), reps, duration_s)
    finally:
        numba.set_num_threads(previous)
    return {"sim_s_per_wall_s": r.realtime_factor, "sim_s_per_wall_s_all_saved": r.realtime_factor_all_saved,
            "saved_dt_s": float(config.dt), "substeps": r.substeps, "step_s": r.step_s,
            "nodes": r.nodes, "simulated_s": r.simulated_s, "wall_s": r.wall_s,
            "cpu_fraction": r.cpu_fraction, "reps": reps, "threads": 1}


def model_speed(engine, traj, model_dt: float, steps: int) -> dict:
    """Model steps per wall second of ``engine.step`` on the calling thread, each call from a recorded
    history of ``traj`` (``Trajectory``, in turn; its feedback laws computed in the call, as in a
    free run), and simulated seconds per wall second."""
    H = int(engine.history)
    n = traj.n_steps - H
    if n < 1:
        raise bad("trajectory", f"{traj.n_steps} model steps", f"at least {H + 1} model steps to time")
    rows = iter(np.arange(steps + 200) % n)       # warm-up and timed calls, cycling over the windows

    def one():
        i = next(rows)
        hist = traj.states[i:i + H]
        engine.step(hist, traj.inputs(hist, i + H - 1))

    c, t = time.process_time(), time.perf_counter()
    r = step_rate(one, steps=steps, warmup=200)
    cpu = (time.process_time() - c) / max(time.perf_counter() - t, 1e-12)
    return {"steps_per_s": r.median_hz, "sim_s_per_wall_s": r.median_hz * float(model_dt),
            "median_us": r.step_us, "p99_us": r.p99_us, "calls": r.steps, "model_dt_s": float(model_dt),
            "predicted_nodes": int(engine.n_kept), "cpu_fraction": cpu}


def compare_speed(setup, config, node: int, engine, traj, model_dt: float, *, duration_s: float, reps: int,
                  steps: int) -> dict:
    """The simulator and the model timed one after the other: both rates and their ratio."""
    sim = simulator_speed(setup, config, node, duration_s, reps)
    model = model_speed(engine, traj, model_dt, steps)
    return {"simulator_sim_s_per_wall_s": sim["sim_s_per_wall_s"],
            "model_sim_s_per_wall_s": model["sim_s_per_wall_s"],
            "speed_ratio_vs_simulator": model["sim_s_per_wall_s"] / sim["sim_s_per_wall_s"],
            "simulator": sim, "model": model}


def stand_in_model(dataset, config):
    """The architecture ``config`` on ``dataset``'s rod, untrained (PyTorch's initial weights; the
    linear term and the convolution's output layer start at zero): the arithmetic of a trained
    model's step, without the ridge fit's eigenvalue checks. Returns (``DynamicEngine``, ``Encoding``)."""
    import torch  # optional extra: learn (PyTorch)

    from ..learned.whole.network import DynamicNet  # optional extra: learn (PyTorch)
    from ..learned.whole.training import scales  # optional extra: learn (PyTorch)

    enc = make_encoding([dataset], model_dt=config.model_dt,
                        node_stride=resolve_node_stride(config.node_stride, dataset.n_nodes),
                        length=rod_length(dataset))
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(config.seed)
        net = DynamicNet(config, enc.node_features(), enc.fixed, scales([enc.trajectory(dataset)]))
    return engine_of(net.eval()), enc


def _saved_dt(encoding) -> float:
    """``SAVED_DT`` if the model's step is a whole multiple of it, else its training data's interval."""
    try:
        resolve_stride(encoding.model_dt, SAVED_DT)
        return SAVED_DT
    except SoftrnnInputError:
        return float(encoding.data_dt)


def _case_entry(name: str, config, loaded, quick: bool) -> dict:
    """One case: a short simulated trajectory, the model (``loaded`` or a stand-in of ``config``)
    and both speeds."""
    duration, reps, steps = (1.0, 3, 500) if quick else (2.0, 5, 2000)
    config = loaded.config if loaded is not None else (config or DynamicConfig())
    setup, run, node = case_run(name, SAVED_DT if loaded is None else _saved_dt(loaded.encoding))
    data = simulated_dataset(setup, run, max(duration, 30 * config.model_dt))
    if loaded is not None:
        engine, enc = loaded.engine, loaded.encoding
        how = "trained model (--dynamic-model)"
    else:
        engine, enc = stand_in_model(data, config)
        how = ("the case's architecture, untrained (initial weights; the arithmetic per step is what is "
               "timed, not the weights' values)")
    out = compare_speed(setup, run, node, engine, enc.trajectory(data), enc.model_dt, duration_s=duration,
                        reps=reps, steps=steps)
    out.update(model_weights=how, trained=loaded is not None, config=config.to_dict(), nodes=enc.n_nodes,
               goal_speed_ratio=GOAL_SPEED_RATIO,
               goal_met=out["speed_ratio_vs_simulator"] >= GOAL_SPEED_RATIO)
    return out


def run_dynamic_benchmark(quick: bool = False, *, configs: dict | None = None, models: dict | None = None,
                          progress: Progress | None = None) -> dict:
    """Per paper case ({case: entry}): the simulator's and the model's simulated seconds per wall
    second, one core each, and their ratio. ``configs``: {case: DynamicConfig} of the stand-in
    models (default: ``DynamicConfig()``); ``models``: {case: LoadedDynamic} timed instead."""
    configs, models = configs or {}, models or {}
    out = {}
    for i, name in enumerate(CASES):
        if progress is not None:
            progress(i, len(CASES))
        out[name] = _case_entry(name, configs.get(name), models.get(name), quick)
    if progress is not None:
        progress(len(CASES), len(CASES))
    return {"cases": out, "goal_speed_ratio": GOAL_SPEED_RATIO,
            "goals_met": {f"speed_ratio_{name}": out[name]["goal_met"] for name in CASES}}


def find_models(folder) -> dict:
    """{case: LoadedDynamic} from ``folder``: a model folder (its case: the paper case whose rod has
    its node count) or a folder of ``CASE/model`` folders (``softrnn reproduce``'s ``dynamic/``)."""

    folder = Path(folder)
    found = {c: folder / c / "model" for c in CASES if is_dynamic_folder(folder / c / "model")}
    if found:
        return {c: load_dynamic(p) for c, p in found.items()}
    model = load_dynamic(folder)
    for name in CASES:
        if case_run(name)[0].rod.n_nodes == model.encoding.n_nodes:
            return {name: model}
    raise bad("--dynamic-model", str(folder), f"a model of one of the paper cases ({', '.join(CASES)}); "
              f"this one has {model.encoding.n_nodes} nodes")


def format_dynamic_table(r: dict) -> str:
    """A short text table of ``run_dynamic_benchmark``'s result."""
    rows = ["learned whole-manipulator model (softrnn.learned.whole) vs the simulator, one core each, same run",
            f"  {'case':<11}{'simulator sim s/s':>18}{'model sim s/s':>15}{'model dt':>10}{'us/step':>9}"
            f"{'ratio':>8}{'goal':>7}  weights"]
    for name, e in r["cases"].items():
        rows.append(f"  {name:<11}{e['simulator_sim_s_per_wall_s']:>18.1f}{e['model_sim_s_per_wall_s']:>15.1f}"
                    f"{e['model']['model_dt_s']:>9g}s{e['model']['median_us']:>9.0f}"
                    f"{e['speed_ratio_vs_simulator']:>7.1f}x{'ok' if e['goal_met'] else 'MISS':>7}  "
                    f"{'trained' if e['trained'] else 'untrained stand-in'}")
    rows.append(f"  goal: the model >= {r['goal_speed_ratio']:g}x the simulator's simulated seconds per wall second")
    return "\n".join(rows)
