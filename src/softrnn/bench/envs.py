"""Throughput of the navigation environments (``softrnn.envs``): environment steps per second and
the real-time factor per environment, for one ``NavigateEnv`` and for ``NavigateVectorEnv`` at 32
environments, beside the figures the stEVE and CathSim papers publish (``PUBLISHED``); the same for
the magnetic environments (``MagneticNavigateEnv``, ``MagneticNavigateVectorEnv``), and the cost of
the fluoroscopy image observation beside the physics of a step.

``run_envs_benchmark`` returns a JSON-ready dict, ``format_envs_table`` renders it; neither prints.
It needs the optional extra ``envs`` (gymnasium): its callers import it inside their functions.
"""

import os
import time

import numba
import numpy as np

from ..envs import (
    Fluoroscopy,
    MagneticNavigateConfig,
    MagneticNavigateEnv,
    MagneticNavigateVectorEnv,
    MagneticNavigator,
    NavigateConfig,
    NavigateEnv,
    NavigateVectorEnv,
    ScriptedNavigator,
)
from ..envs.fluoro import Fluoroscope
from ._runs import goal_mark

VECTOR_ENVS = 32
"""Environments of the vectorised run."""
MIN_STEPS = 3
"""Each run takes at least this many steps (of every environment), however long they take."""
GOAL_SPEEDUP = 10.0
"""Goal: the vectorised run's steps per second at least this many times the single environment's."""
GOAL_CORES = 2
"""... on this many cores (numba's threads)."""

PUBLISHED = {
    "stEVE": {"source": "Karstensen et al. 2024, Learning-based autonomous navigation, benchmark environments and "
                        "simulation framework for endovascular interventions, arXiv:2410.01956 (SOFA BeamAdapter)",
              "env_steps_per_s": None, "real_time_factor": None,
              "note": "no throughput figure found in the sources searched (the paper's abstract and the stEVE "
                      "README): none is quoted here"},
    "CathSim": {"source": "Jianu et al. 2022, CathSim: an open-source simulator for endovascular intervention, "
                          "arXiv:2208.01455; Jianu et al. 2024, arXiv:2401.09059 (MuJoCo)",
                "env_steps_per_s": None, "real_time_factor": None,
                "note": "the papers state real-time performance; no steps-per-second figure found in the sources "
                        "searched (abstracts, the CathSim README): none is quoted here"},
}
"""The published throughput of the other navigation environments (None: not found, not invented)."""

HOW = ("NavigateConfig() defaults (the default vessel, a 31-node guidewire, 0.1 s per step, the implicit integrator "
       "at its automatic solver step); actions from ScriptedNavigator (episodes that insert, turn, reach the target or "
       "end), next-step autoreset in the vector env, reset() in the single one when an episode ends. One step to "
       "compile or load the kernels, then steps until span_s of wall time; steps_per_s = environment steps (all "
       "environments) / wall (at least 3 steps each); real_time_factor = simulated seconds per wall second "
       "per environment; kernel_fraction = the share of the wall spent in the batched kernel; numba threads: "
       "min(2, usable cores) for both runs (the single environment's batch of one runs on one). The magnetic runs: "
       "MagneticNavigateConfig() defaults (the magnetic rod in magnetic_vessel()), actions from MagneticNavigator, "
       "the same protocol (its vector env steps its rods in one call of the batched kernel, as the guidewire's). "
       "image: the fluoroscopy render of the single NavigateEnv's last state (Fluoroscopy() defaults, 64 x 64), "
       "timed over RENDER_REPEATS renders, beside that environment's kernel time per step.")
RENDER_REPEATS = 200
"""Renders timed for the image observation's cost."""


def _single(config: NavigateConfig, span_s: float, env_type=NavigateEnv, pilot_type=ScriptedNavigator) -> dict:
    """Steps per second of one ``env_type`` (``NavigateEnv``) under the scripted controller
    ``pilot_type`` over ``span_s`` of wall; with the environment itself under "env"."""
    env = env_type(config)
    pilot = pilot_type(episodes=env.episodes)
    obs, _ = env.reset(seed=0)
    obs, *_ = env.step(pilot(obs))  # compile or load the kernels
    kernel0 = env.episodes.rods.kernel_seconds
    steps, ends, start = 0, 0, time.perf_counter()
    while time.perf_counter() - start < span_s or steps < MIN_STEPS:
        obs, _, terminated, truncated, _ = env.step(pilot(obs))
        steps += 1
        if terminated or truncated:
            ends += 1
            obs, _ = env.reset()
    wall = time.perf_counter() - start
    kernel = env.episodes.rods.kernel_seconds - kernel0
    return {"envs": 1, "steps": steps, "kernel_fraction": kernel / wall, "wall_s": wall, "episodes_ended": ends,
            "steps_per_s": steps / wall,
            "real_time_factor": steps * config.step_time / wall, "substeps": env.episodes.rods.substeps,
            "solver_step_s": env.episodes.rods.h, "env": env}


def _vector(config: NavigateConfig, n: int, span_s: float, env_type=NavigateVectorEnv,
            pilot_type=ScriptedNavigator) -> dict:
    """Steps per second of ``env_type`` (``NavigateVectorEnv``) with ``n`` environments over ``span_s``
    of wall."""
    env = env_type(n, config)
    pilot = pilot_type(episodes=env.episodes)
    obs, _ = env.reset(seed=0)
    obs, *_ = env.step(pilot(obs))
    kernel0 = env.episodes.rods.kernel_seconds
    calls, ends, start = 0, 0, time.perf_counter()
    while time.perf_counter() - start < span_s or calls < MIN_STEPS:
        obs, _, terminated, truncated, _ = env.step(pilot(obs))
        calls += 1
        ends += int(np.sum(terminated | truncated))
    wall = time.perf_counter() - start
    kernel = env.episodes.rods.kernel_seconds - kernel0
    return {"envs": n, "steps": calls * n, "kernel_fraction": kernel / wall, "vector_steps": calls, "wall_s": wall,
            "episodes_ended": ends,
            "steps_per_s": calls * n / wall, "real_time_factor": calls * config.step_time / wall}


def _image_cost(single: dict) -> dict:
    """The fluoroscopy render's wall time per step [s] of the single environment's rod, beside the
    physics' (its kernel time per step)."""
    episodes = single["env"].episodes
    config = episodes.config
    camera = Fluoroscope(Fluoroscopy(), episodes.paths, episodes.rods.setups[0].contact, episodes.track.entry_radius,
                         config.device.radius, config.goal_depth, config.gravity)
    positions, target = episodes.rods.state.positions, episodes.target
    camera.render(positions, target)  # compile or load the kernel
    start = time.perf_counter()
    for _ in range(RENDER_REPEATS):
        camera.render(positions, target)
    render = (time.perf_counter() - start) / RENDER_REPEATS
    physics = single["kernel_fraction"] * single["wall_s"] / single["steps"]
    return {"size": camera.size, "render_s": render, "physics_s": physics, "share": render / physics}


def _magnetic(config: MagneticNavigateConfig, n_envs: int, span_s: float) -> dict:
    """The magnetic environments' runs: one, then ``n_envs``."""
    single = _single(config, span_s, MagneticNavigateEnv, MagneticNavigator)
    single.pop("env")
    vector = _vector(config, n_envs, span_s, MagneticNavigateVectorEnv, MagneticNavigator)
    return {"single": single, "vector": vector, "speedup": vector["steps_per_s"] / single["steps_per_s"],
            "settings": {"step_time_s": config.step_time}}


def run_envs_benchmark(quick: bool = False, span_s: float | None = None, config: NavigateConfig | None = None,
                       n_envs: int = VECTOR_ENVS, magnetic: MagneticNavigateConfig | None = None) -> dict:
    """The ``envs`` part of ``softrnn bench`` (``HOW``): one environment, then ``n_envs``, each stepped
    for ``span_s`` [s] of wall (None: 15 s, 2 s ``quick``), with ``config`` (None: the defaults); the
    same for the magnetic environments with ``magnetic`` (None: their defaults); the image's cost."""
    span = (2.0 if quick else 15.0) if span_s is None else float(span_s)
    config = NavigateConfig() if config is None else config
    usable = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    threads = max(1, min(GOAL_CORES, usable, numba.config.NUMBA_NUM_THREADS))
    before = numba.get_num_threads()
    numba.set_num_threads(threads)
    try:
        single = _single(config, span)
        vector = _vector(config, n_envs, span)
        image = _image_cost(single)
        single.pop("env")
        mag = _magnetic(MagneticNavigateConfig() if magnetic is None else magnetic, n_envs, span)
    finally:
        numba.set_num_threads(before)
    speedup = vector["steps_per_s"] / single["steps_per_s"]
    return {"single": single, "vector": vector, "speedup": speedup, "threads": threads, "magnetic": mag,
            "image": image,
            "goal": {"speedup": GOAL_SPEEDUP, "cores": GOAL_CORES, "met": bool(speedup >= GOAL_SPEEDUP)},
            "bound": _bound(single, vector, threads), "published": PUBLISHED, "how": HOW,
            "settings": {"span_s": span, "quick": bool(quick), "step_time_s": config.step_time}}


def _bound(single: dict, vector: dict, threads: int) -> dict:
    """Where the speedup stops: a batch shares the Python work of a step (the inputs, the observation,
    the reward), not the physics, which runs one rod per thread. With a share p of the single
    environment's step in the kernel, N environments on c threads run at most c / p times faster."""
    p = single["kernel_fraction"]
    limit = threads / p if p > 0 else float("inf")
    return {"kernel_fraction_single": p, "kernel_fraction_vector": vector["kernel_fraction"],
            "speedup_limit": limit,
            "reason": (f"the physics (the batched kernel, {single['substeps']} implicit solver steps per environment "
                       f"step) is {100 * p:.0f} % of a single environment's step; a batch divides it by its "
                       f"{threads} thread(s) at most, so {vector['envs']} environments run at most {limit:.1f}x "
                       "faster")}


def format_envs_table(result: dict) -> str:
    """Text table of ``run_envs_benchmark``'s result."""
    s, v, g = result["single"], result["vector"], result["goal"]
    lines = [f"navigation environments (softrnn.envs), {result['threads']} numba thread(s), "
             f"{result['settings']['span_s']:g} s of stepping each",
             f"  {'run':<22}{'envs':>6}{'steps/s':>12}{'real-time x / env':>20}",
             f"  {'NavigateEnv':<22}{1:>6}{s['steps_per_s']:>12.1f}{s['real_time_factor']:>20.3f}",
             f"  {'NavigateVectorEnv':<22}{v['envs']:>6}{v['steps_per_s']:>12.1f}{v['real_time_factor']:>20.3f}",
             f"  speedup {result['speedup']:.2f}x (goal >= {g['speedup']:g}x on {g['cores']} cores)   "
             f"{goal_mark(g['met'])}",
             f"  why: {result['bound']['reason']}"]
    if "magnetic" in result:
        m = result["magnetic"]
        lines += [f"  {'MagneticNavigateEnv':<22}{1:>6}{m['single']['steps_per_s']:>12.1f}"
                  f"{m['single']['real_time_factor']:>20.3f}",
                  f"  {'MagneticNavigateVec..':<22}{m['vector']['envs']:>6}{m['vector']['steps_per_s']:>12.1f}"
                  f"{m['vector']['real_time_factor']:>20.3f}",
                  f"  magnetic speedup {m['speedup']:.2f}x (MagneticNavigateVectorEnv: its rods in one parallel call)"]
    if "image" in result:
        im = result["image"]
        lines.append(f"  fluoroscopy image {im['size']}x{im['size']}: {1e6 * im['render_s']:.0f} us per render, "
                     f"{100 * im['share']:.2g} % of the physics of a step ({1e3 * im['physics_s']:.1f} ms)")
    for name, p in result["published"].items():
        figure = "not found" if p["env_steps_per_s"] is None else f"{p['env_steps_per_s']:g} steps/s"
        lines.append(f"  {name}: {figure} ({p['source']})")
    return "\n".join(lines)
