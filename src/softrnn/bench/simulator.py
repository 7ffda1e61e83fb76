"""Speed of the Lie-group rod simulator on this machine.

Measures (see benchmarks/README.md):

* single-thread cost of ``Simulator(setup).run(config)`` in microseconds per node-step
  (wall / (steps * nodes)) and the real-time factor (simulated s per wall s) for a 50-node
  cantilever, 59- and 101-node cantilevers, and the paper's three cases (``softrnn.scenarios.cases``);
  saving one node (the node of interest) and saving all nodes;
* start-up: the first tiny ``simulate`` in a fresh interpreter with an empty numba cache (cold
  compile) and again with the filled cache (cached start), import time included; and the start of
  ``softrnn --version``, ``--help`` and ``scenario list`` (``bench.startup``);
* a batch of 16 rods (59-node cantilevers, different tip loads) through ``simulate_batch`` on
  2 threads (and, for reference, on 1 thread);
* the two integrators on the paper's cases and the stiff wires (``bench.integrators``);
* the cost of contact in the shipped contact scenarios (``bench.contact``).

``run_benchmark`` returns a JSON-ready dict, ``format_table`` renders it; neither prints.
"""

import dataclasses
import os
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable

import numba

from ..progress import Progress, Ticks
from ..rod import Clamp, Constant, NodalLoad, RodSpec, RunConfig, Setup, Simulator, simulate_batch, straight
from ..scenarios.cases import build_case
from ..timing import load_average, machine_info
from ._runs import covering_samples, goal_mark
from .contact import CONTACT_CASES, contact_overheads, format_contact, time_contact_cases, warm_contact_cases
from .integrators import INTEGRATOR_CASES, INTEGRATORS, format_integrators, time_integrators, warm_integrators
from .startup import GOALS as COMMAND_GOALS
from .startup import commands_met, format_commands, time_commands

PAPER_SOURCE = "Tariverdi et al. 2021, Front. Robot. AI 8:631303, sections 4.1-4.3"
PAPER = {
    "source": PAPER_SOURCE,
    "hardware": "16 GB, 1.99 GHz Intel i7 laptop, Windows 10",
    "what": "wall time per node and time step of the paper's analytical (Cosserat) dynamic model",
    "s_per_node_step": {"ellipse": 162e-6, "square": 189e-6, "semicircle": 222e-6},
    "us_per_node_step": {"ellipse": 162.0, "square": 189.0, "semicircle": 222.0},
}
GOALS = {
    "us_per_node_step_at_59_and_101_nodes": 0.10,
    "cold_compile_s": 3.0,
    "cached_start_s": 0.5,
    "batch16_2threads_us_per_node_step": 0.07,
    "contact_overhead": 0.30,
    **{f"{name}_start_s": goal for name, goal in COMMAND_GOALS.items()},
}
PAPER_CASES = ("ellipse", "square", "semicircle")
GOAL_NODES = (59, 101)

# cantilever of the task: L = 1 m, r = 1 cm, E = 1 MPa, rho = 1000 kg/m^3, nu = 0.5, gravity,
# clamped at node 0, horizontal along +x (it falls and swings under its own weight)
_CANTILEVER = dict(length=1.0, radius=0.01, youngs_modulus=1e6, density=1000.0, poisson_ratio=0.5)
_CANTILEVER_DT = 0.01
_CANTILEVER_SAMPLES = 1001  # at most 10 s simulated

_STARTUP_CODE = """\
import time
t = time.perf_counter()
from softrnn.rod import Clamp, RodSpec, RunConfig, Setup, simulate, straight
t_import = time.perf_counter() - t
rod = RodSpec(length=0.1, radius=0.005, youngs_modulus=1e6, density=1000.0, n_nodes=5)
setup = Setup(rod=rod, reference=straight(5, 0.1), boundary=(Clamp(0),), gravity=(0.0, 0.0, -9.81))
simulate(setup, RunConfig(dt=1e-3, n_samples=3))
print(t_import, time.perf_counter() - t)
"""


# ---------------------------------------------------------------------------------------------- setups
def cantilever(n_nodes: int, tip_force=None) -> tuple[Setup, RunConfig]:
    """The benchmark cantilever with ``n_nodes`` nodes and an optional constant world tip force (3,) [N]."""
    rod = RodSpec(n_nodes=n_nodes, **_CANTILEVER)
    shape = straight(n_nodes, rod.length, direction=(1.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0))
    loads = () if tip_force is None else (NodalLoad(n_nodes - 1, force=Constant(tuple(tip_force))),)
    setup = Setup(rod=rod, reference=shape, boundary=(Clamp(0),), loads=loads, gravity=(0.0, 0.0, -9.81))
    config = RunConfig(dt=_CANTILEVER_DT, n_samples=_CANTILEVER_SAMPLES, save_nodes=(n_nodes - 1,))
    return setup, config


def _paper_case(name: str):
    """(setup, config, save_nodes) of a paper case from softrnn.scenarios.cases; accepts build_case returning
    a (setup, config) pair or an object with .setup, .config and optionally .node_of_interest."""
    built = build_case(name)
    if isinstance(built, tuple):
        setup, config = built[0], built[1]
        node = None
    else:
        setup, config = built.setup, built.config
        node = getattr(built, "node_of_interest", None)
    if node is not None:
        save = (int(node),)
    elif config.save_nodes is not None:
        save = tuple(config.save_nodes)
    else:
        save = (setup.rod.n_nodes - 1,)
    return setup, config, save


# ---------------------------------------------------------------------------------------------- timing
def _wall(fn: Callable[[], object]) -> float:
    t = time.perf_counter()
    fn()
    return time.perf_counter() - t


def _timed(fn: Callable[[], object]) -> tuple[float, float]:
    """(wall, CPU time of this process over all its threads) of one call [s]."""
    c, t = time.process_time(), time.perf_counter()
    fn()
    return time.perf_counter() - t, time.process_time() - c


@dataclasses.dataclass(frozen=True)
class SingleRodTiming:
    """One rod's timing (``time_single``); ``to_dict()`` is its JSON entry.

    Attributes
    ----------
    nodes, substeps, samples, steps, reps : int
        the rod's nodes, solver steps per saved interval, saved samples, solver steps per run, runs
    step_s, simulated_s, wall_s : float
        the solver step, the simulated span and the median wall of a run [s]
    us_per_node_step, us_per_node_step_all_saved : float
        wall / (steps * nodes) [us], saving ``saved_nodes`` and saving every node
    realtime_factor, realtime_factor_all_saved : float
        simulated s per wall s, likewise
    cpu_fraction : float
        process CPU time / wall (median; below ~0.95: the run waited for a core)
    saved_nodes : tuple of int
        the nodes saved
    """

    nodes: int
    substeps: int
    step_s: float
    us_per_node_step: float
    realtime_factor: float
    us_per_node_step_all_saved: float
    realtime_factor_all_saved: float
    cpu_fraction: float
    saved_nodes: tuple
    samples: int
    steps: int
    simulated_s: float
    wall_s: float
    reps: int

    def to_dict(self) -> dict:
        """The JSON entry (``saved_nodes`` a list)."""
        return dict(dataclasses.asdict(self), saved_nodes=list(self.saved_nodes))


def time_single(setup: Setup, config: RunConfig, save_nodes, reps: int, duration_s: float) -> SingleRodTiming:
    """Median wall of ``Simulator(setup).run(config')`` over ``reps`` runs, config' covering the
    first ``duration_s`` simulated seconds and saving ``save_nodes``; then the same with all nodes
    saved (median of 3)."""
    n = setup.rod.n_nodes
    cfg = dataclasses.replace(config, save_nodes=tuple(save_nodes))

    def run(samples, save=cfg.save_nodes):
        return Simulator(setup).run(dataclasses.replace(cfg, n_samples=samples, save_nodes=save))

    run(2)  # warm-up: compiles the kernel or loads it from the cache
    samples = covering_samples(config, duration_s)
    timed = [_timed(lambda: run(samples)) for _ in range(reps)]
    walls = [w for w, _ in timed]
    walls_all = [_wall(lambda: run(samples, None)) for _ in range(3)]
    substeps = Simulator(setup).resolve_substeps(cfg)
    steps = (samples - 1) * substeps
    wall = statistics.median(walls)
    wall_all = statistics.median(walls_all)
    simulated = (samples - 1) * cfg.dt
    return SingleRodTiming(nodes=n, substeps=substeps, step_s=cfg.dt / substeps,
                           us_per_node_step=1e6 * wall / (steps * n), realtime_factor=simulated / wall,
                           us_per_node_step_all_saved=1e6 * wall_all / (steps * n),
                           realtime_factor_all_saved=simulated / wall_all,
                           cpu_fraction=statistics.median(c / w for w, c in timed), saved_nodes=tuple(cfg.save_nodes),
                           samples=samples, steps=steps, simulated_s=simulated, wall_s=wall, reps=reps)


def time_startup(cache_dir: str) -> dict:
    """First tiny simulate in a fresh interpreter with NUMBA_CACHE_DIR=cache_dir."""
    env = dict(os.environ, NUMBA_CACHE_DIR=cache_dir, NUMBA_NUM_THREADS="1")
    proc = subprocess.run([sys.executable, "-c", _STARTUP_CODE], env=env, capture_output=True, text=True,
                          timeout=300)
    if proc.returncode != 0:
        raise RuntimeError(f"start-up subprocess failed ({proc.returncode}): {proc.stderr.strip()[-2000:]}")
    t_import, total = (float(x) for x in proc.stdout.split()[-2:])
    return {"import_s": t_import, "total_s": total}


def time_compile(cached_reps: int) -> dict:
    """Start-up cost of the compiled kernels: one ``time_startup`` with an empty numba cache (cold:
    compiles) and ``cached_reps`` more with the same cache folder (cached: loads), each in a fresh
    interpreter; total and import times [s] (medians of the cached runs)."""
    with tempfile.TemporaryDirectory(prefix="softrnn-numba-cache-") as cache:
        cold = time_startup(cache)
        cached = [time_startup(cache) for _ in range(cached_reps)]
    med = statistics.median(c["total_s"] for c in cached)
    return {
        "cold_s": cold["total_s"],
        "cached_s": med,
        "import_s": statistics.median(c["import_s"] for c in cached),
        "cold_import_s": cold["import_s"],
        "cached_reps": cached_reps,
        "what": "fresh interpreter: import softrnn.rod + first simulate of a 5-node rod (3 samples, 1 ms apart); "
                "cold = empty NUMBA_CACHE_DIR, cached = the same directory again",
    }


def time_batch(n_rods: int, n_nodes: int, threads: int, reps: int, duration_s: float) -> dict:
    """``simulate_batch`` of ``n_rods`` cantilevers with different lateral tip loads on ``threads``."""
    setups = []
    config = None
    for b in range(n_rods):
        setup, config = cantilever(n_nodes, tip_force=(0.0, 0.01 * b, 0.0))
        setups.append(setup)
    previous = numba.get_num_threads()
    numba.set_num_threads(threads)
    try:
        def run(samples):
            return simulate_batch(setups, dataclasses.replace(config, n_samples=samples))

        run(2)  # warm-up
        samples = covering_samples(config, duration_s)
        timed = [_timed(lambda: run(samples)) for _ in range(reps)]
        walls = [w for w, _ in timed]
    finally:
        numba.set_num_threads(previous)
    substeps = Simulator(setups[0]).resolve_substeps(config)
    steps = (samples - 1) * substeps
    wall = statistics.median(walls)
    return {
        "rods": n_rods,
        "nodes": n_nodes,
        "threads": threads,
        "substeps": substeps,
        "us_per_node_step": 1e6 * wall / (steps * n_nodes * n_rods),
        "realtime_factor": (samples - 1) * config.dt / wall,
        "cpu_fraction": statistics.median(c / w for w, c in timed),
        "samples": samples,
        "steps": steps,
        "wall_s": wall,
        "reps": reps,
    }


def warm_batch() -> None:
    """Compile (or load from numba's cache) the parallel batch kernel that ``time_batch`` times, on
    the smallest batch (2 rods, 3 samples): cold, it compiles for tens of seconds, which
    ``softrnn reproduce`` spends early, in a background process (``reproduce.benchmark.warm_start``)."""
    time_batch(2, 59, 1, 1, 2 * _CANTILEVER_DT)


def warm_simulator(quick: bool) -> None:
    """Compile (or load from numba's cache) every kernel ``run_benchmark(quick)`` times, untimed: the
    integrator entries' and the contact entries' (their warm-up runs, ``warm_integrators``,
    ``warm_contact_cases``) and the batch kernel (``warm_batch``). Cold, that is most of the
    benchmark's minute, which ``softrnn reproduce`` spends early, in a background process
    (``reproduce.benchmark.warm_start``). The implicit integrator's kernels first, the explicit
    rod step's last: the pipeline's first step compiles that one meanwhile, and this then loads it."""
    *_, integrator_settings, contact_settings = _settings(quick)
    previous = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        warm_integrators(*integrator_settings[1:], integrators=("implicit",))
        warm_contact_cases(*contact_settings[1:])
        warm_batch()
        warm_integrators(*integrator_settings[1:], integrators=("explicit",))
    finally:
        numba.set_num_threads(previous)


def _settings(quick: bool) -> tuple:
    """(reps, cantilever and batch simulated s, case simulated s at most, batch reps, integrator
    settings (reps, span [s], fixed solver steps), contact settings (reps, node-steps, max span [s]))
    of ``run_benchmark``."""
    # simulated seconds per timed run (fixed, so that every machine times the same work; the cost
    # per node-step depends on the motion, e.g. on the Newton iterations of fast rotations)
    reps, duration, case_duration = (5, 1.0, 1.5) if quick else (9, 2.0, 5.0)
    batch_reps = 3 if quick else 5
    # integrators: reps, simulated span [s], fixed solver steps where no reference is within reach
    integrator_settings = (3, 0.1, 10_000) if quick else (5, 0.3, 20_000)
    # contact: reps, node-steps timed per run, at most the first max_span_s simulated [s] (CONTACT_HOW)
    contact_settings = (3, 500_000, 1.0) if quick else (5, 2_000_000, 1.0)
    return reps, duration, case_duration, batch_reps, integrator_settings, contact_settings


# ---------------------------------------------------------------------------------------------- report
def _single_rods(sizes, reps: int, duration: float, case_duration: float, tick: Callable[[], None]) -> dict:
    """The single-rod entries (``cantilever50``, ``cantilever_nodes``, ``cases``); numba on 1 thread."""
    sim: dict = {}
    sizes_out = {}
    for n in sizes:
        setup, config = cantilever(n)
        sizes_out[str(n)] = time_single(setup, config, config.save_nodes, reps, duration).to_dict()
        tick()
    sim["cantilever50"] = sizes_out.pop("50")
    sim["cantilever_nodes"] = sizes_out
    cases: dict = {}
    for name in PAPER_CASES:
        try:
            setup, config, save = _paper_case(name)
            cases[name] = time_single(setup, config, save, reps, case_duration).to_dict()
            cases[name]["paper_us_per_node_step"] = PAPER["us_per_node_step"][name]
            cases[name]["speedup_vs_paper"] = PAPER["us_per_node_step"][name] / cases[name]["us_per_node_step"]
        except Exception as exc:  # a case under construction must not sink the benchmark
            cases[name] = {"error": f"{type(exc).__name__}: {exc}"}
        tick()
    sim["cases"] = cases
    return sim


def run_benchmark(quick: bool = False, progress: Progress | None = None) -> dict:
    """Run all measurements (``quick``: shorter runs, less precise) and return the results as a
    JSON-ready dict. ``progress(items_done, n_items)`` is called after every item."""
    reps, duration, case_duration, batch_reps, integrator_settings, contact_settings = _settings(quick)
    sizes = (50, 59, 101)
    n_items = len(sizes) + len(PAPER_CASES) + len(INTEGRATOR_CASES) + len(CONTACT_CASES) + 3
    tick = Ticks(progress, n_items)

    if progress is not None:
        progress(0, n_items)
    started = time.perf_counter()
    load_start = load_average()
    previous = numba.get_num_threads()
    numba.set_num_threads(1)  # the single-rod kernels are serial anyway; this pins numba's pool
    try:
        sim = _single_rods(sizes, reps, duration, case_duration, tick)
        sim["integrators"] = time_integrators(*integrator_settings, tick=tick)
        sim["contact"] = time_contact_cases(*contact_settings, tick=tick)
    finally:
        numba.set_num_threads(previous)

    sim["compile"] = time_compile(1 if quick else 3)
    tick()
    sim["commands"] = time_commands(3 if quick else 5)
    tick()

    threads = min(2, numba.config.NUMBA_NUM_THREADS)
    batch = time_batch(16, 59, threads, batch_reps, duration)
    batch1 = time_batch(16, 59, 1, batch_reps, duration)
    batch["us_per_node_step_1thread"] = batch1["us_per_node_step"]
    batch["speedup_vs_1thread"] = batch1["us_per_node_step"] / batch["us_per_node_step"]
    sim["batch16_2threads"] = batch
    tick()

    result = {
        "machine": machine_info(),
        "simulator": sim,
        "goals": dict(GOALS),
        "paper": PAPER,
        "settings": {"quick": quick, "reps": reps, "cantilever_and_batch_simulated_s": duration,
                     "case_simulated_s_max": case_duration,
                     "integrators": dict(zip(("reps", "span_s", "fixed_steps"), integrator_settings)),
                     "contact": dict(zip(("reps", "node_steps", "max_span_s"), contact_settings)),
                     "elapsed_s": time.perf_counter() - started,
                     "load_average_start": load_start, "load_average_end": load_average(),
                     "date": time.strftime("%Y-%m-%d %H:%M:%S %z")},
    }
    result["goals_met"] = goals_met(result)
    return result


def goals_met(result: dict) -> dict:
    """Each goal -> True/False (None where it was not measured)."""
    sim, goals = result["simulator"], result["goals"]
    at_nodes = [e["us_per_node_step"] for _, e in _single_rows(sim)
                if e.get("nodes") in GOAL_NODES and "us_per_node_step" in e]
    overheads = contact_overheads(sim)
    met = {
        "us_per_node_step_at_59_and_101_nodes":
            (max(at_nodes) <= goals["us_per_node_step_at_59_and_101_nodes"]) if at_nodes else None,
        "cold_compile_s": sim["compile"]["cold_s"] < goals["cold_compile_s"],
        "cached_start_s": sim["compile"]["cached_s"] < goals["cached_start_s"],
        "batch16_2threads_us_per_node_step":
            sim["batch16_2threads"]["us_per_node_step"] <= goals["batch16_2threads_us_per_node_step"],
    }
    if "contact_overhead" in goals:  # results from before the contact entries have no such goal
        met["contact_overhead"] = (max(overheads) <= goals["contact_overhead"]) if overheads else None
    if "commands" in sim:  # nor from before the command start-up entries
        met.update(commands_met(sim["commands"]))
    return met


def _single_rows(sim: dict) -> list[tuple[str, dict]]:
    rows = [("cantilever50", sim["cantilever50"])]
    rows += [(f"cantilever{n}", e) for n, e in sim.get("cantilever_nodes", {}).items()]
    rows += [(name, e) for name, e in sim.get("cases", {}).items()]
    return rows


def format_table(result: dict) -> str:
    """Plain-text table of a ``run_benchmark`` result, goals beside the measured figures."""
    m, sim, goals = result["machine"], result["simulator"], result["goals"]
    g_node = goals["us_per_node_step_at_59_and_101_nodes"]
    lines = [
        f"softrnn simulator benchmark{' (quick)' if result.get('settings', {}).get('quick') else ''}",
        f"machine: {m['cpu']}, {m['cores']} cores; Python {m['python']}, numpy {m['numpy']}, numba {m['numba']}",
        "",
        "single rod, 1 thread: Simulator(setup).run(config), median wall",
    ]
    head = (f"  {'case':<14}{'nodes':>6}{'substeps':>9}{'us/node-step':>14}{'goal':>8}{'':>6}"
            f"{'all saved':>11}{'real-time x':>13}{'cpu':>6}{'paper us':>10}{'vs paper':>10}")
    lines += [head, "  " + "-" * (len(head) - 2)]
    for name, e in _single_rows(sim):
        if "error" in e:
            lines.append(f"  {name:<14}  error: {e['error']}")
            continue
        judged = e["nodes"] in GOAL_NODES
        goal = f"<={g_node:.2f}" if judged else ""
        status = goal_mark(e["us_per_node_step"] <= g_node) if judged else ""
        paper = e.get("paper_us_per_node_step")
        lines.append(
            f"  {name:<14}{e['nodes']:>6}{e['substeps']:>9}{e['us_per_node_step']:>14.4f}{goal:>8}{status:>6}"
            f"{e['us_per_node_step_all_saved']:>11.4f}{e['realtime_factor']:>13.1f}"
            f"{100 * e.get('cpu_fraction', float('nan')):>5.0f}%"
            + (f"{paper:>10.0f}{e['speedup_vs_paper']:>9.0f}x" if paper else ""))
    if sim.get("cases_note"):
        lines.append(f"  note: {sim['cases_note']}")
    lines.append("  (all saved: every node saved at every sample; cpu: process CPU / wall, below ~95% means "
                 "the benchmark was waiting for a core)")
    if "integrators" in sim:
        lines += [""] + format_integrators(sim["integrators"], result.get("settings"))
    met = result.get("goals_met") or goals_met(result)
    if "contact" in sim:
        lines += [""] + format_contact(sim["contact"], goals.get("contact_overhead"), met.get("contact_overhead"),
                                       result.get("settings"))
    c = sim["compile"]
    b = sim["batch16_2threads"]
    lines += [
        "",
        "start-up (fresh interpreter, import + first 5-node simulate)",
        f"  cold compile (empty numba cache) {c['cold_s']:>8.2f} s   goal < {goals['cold_compile_s']:.1f} s"
        f"   {goal_mark(met['cold_compile_s'])}",
        f"  cached start                     {c['cached_s']:>8.2f} s   goal < {goals['cached_start_s']:.1f} s"
        f"   {goal_mark(met['cached_start_s'])}   (import alone {c['import_s']:.2f} s)",
        "",
        *([*format_commands(sim["commands"]), ""] if "commands" in sim else []),
        f"batch: simulate_batch, {b['rods']} x {b['nodes']}-node cantilevers, {b['threads']} threads",
        f"  {b['us_per_node_step']:.4f} us/node-step   goal <= {goals['batch16_2threads_us_per_node_step']:.2f}"
        f"   {goal_mark(met['batch16_2threads_us_per_node_step'])}   (1 thread: {b['us_per_node_step_1thread']:.4f}; "
        f"speed-up {b['speedup_vs_1thread']:.2f}x; cpu {b.get('cpu_fraction', float('nan')):.2f} cores busy)",
        "",
        f"paper: {result['paper']['source']}: analytical model "
        + ", ".join(f"{k} {v:.0f}" for k, v in result["paper"]["us_per_node_step"].items())
        + f" us/node-step ({result['paper']['hardware']})",
    ]
    settings = result.get("settings", {})
    if settings.get("load_average_start") is not None:
        lines.append(f"load average (1, 5, 15 min) at start {settings['load_average_start']}, "
                     f"at end {settings.get('load_average_end')}; elapsed {settings.get('elapsed_s', 0):.0f} s")
    contended = [name for name, e in _single_rows(sim) if e.get("cpu_fraction", 1.0) < 0.9]
    contended += [f"{case} ({name})" for name in INTEGRATORS
                  for case, e in sim.get("integrators", {}).get(name, {}).items() if e.get("cpu_fraction", 1.0) < 0.9]
    contended += [f"{case} (contact)" for case, e in sim.get("contact", {}).items()
                  if case != "how" and e.get("cpu_fraction", 1.0) < 0.9]
    if b.get("cpu_fraction", b["threads"]) < 0.9 * b["threads"]:
        contended.append("batch")
    if contended:
        lines.append(f"warning: the benchmark waited for a core in {', '.join(contended)} (other processes "
                     f"running?): those timings are inflated; rerun on an idle machine")
    return "\n".join(lines)
