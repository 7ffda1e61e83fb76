"""The simulator benchmark's cost of contact (``simulator.contact``): the shipped contact scenarios
(``contact-plane``, ``vessel-guidewire``) as shipped and the same setup with ``contact=None`` at the
contact run's solver step, and the overhead with/without - 1 (``CONTACT_HOW`` says exactly how).
``time_contact_cases`` returns a JSON-ready dict, ``format_contact`` renders it.
"""

import dataclasses
import math
import statistics
import time
from collections.abc import Callable

from ..errors import bad
from ..rod import RunConfig, Setup, Simulator
from ..scenarios import load_scenario
from ._runs import covering_samples, goal_mark, tracked_node, warm_runs

CONTACT_CASES = ("contact-plane", "vessel-guidewire")
"""The shipped contact scenarios whose cost of contact ``simulator.contact`` records."""
CONTACT_KEYS = ("us_per_node_step", "us_per_node_step_without_contact", "overhead")
"""The figures of every ``simulator.contact[CASE]`` entry."""
CONTACT_HOW = (
    "per scenario (softrnn.scenarios.load_scenario), its setup, saved interval dt and integrator as shipped, only "
    "the tracked node saved (its last node of interest); the solver step is the contact run's automatic one "
    "(substeps fixed to it), and the same setup with contact=None is run at that same step, so that only the "
    "contact work differs (without the obstacles the rod moves differently: it falls through the table or the "
    "vessel's floor). Timed: the first saved intervals from rest that make node_steps node-steps (solver steps * "
    "nodes), at most the first max_span_s simulated seconds (the cost per step depends a little on the motion, "
    "and the motions with and without contact drift apart: the rod of contact-plane, free of its table, swings "
    "from the clamp, and over the whole scenario its steps cost about 15 % more than over the first second), one "
    "warm-up run of each, then reps runs of Simulator(setup).run(config) alternating with and without contact, "
    "numba 1 thread, the median wall of each; us_per_node_step = wall / (steps * nodes), overhead = "
    "us_per_node_step / us_per_node_step_without_contact - 1 (goal: at most 0.30).")



def contact_configs(setup: Setup, config: RunConfig, node: int, node_steps: int,
                    max_span_s: float) -> tuple[Setup, RunConfig]:
    """(the setup without contact, the timed config) of one ``simulator.contact`` entry: the
    scenario's config saving only ``node``, its substeps fixed to the automatic ones of the run with
    contact (the run without contact takes the same solver step), over the first saved intervals
    that make ``node_steps`` node-steps (solver steps * nodes), at most ``max_span_s`` simulated
    seconds (and at least one interval)."""
    cfg = dataclasses.replace(config, save_nodes=(node,), substeps=None)
    substeps = Simulator(setup).resolve_substeps(cfg)
    enough = 1 + math.ceil(node_steps / (substeps * setup.rod.n_nodes))
    samples = min(covering_samples(cfg, max_span_s), max(2, enough))
    timed = dataclasses.replace(cfg, substeps=substeps, n_samples=samples)
    return dataclasses.replace(setup, contact=None), timed


def time_contact(setup: Setup, config: RunConfig, node: int, reps: int, node_steps: int,
                 max_span_s: float) -> dict:
    """One ``simulator.contact`` entry (``CONTACT_HOW``): the setup (with contact) against itself
    without contact at the same solver step, ``reps`` runs of each, alternating, over the span of
    ``contact_configs``."""
    if setup.contact is None:
        raise bad("setup.contact", None, "a Contact: the setup's contact is what is timed")
    bare, timed = contact_configs(setup, config, node, node_steps, max_span_s)
    pair = (setup, bare)
    for s in pair:  # warm-up: compiles the kernel or loads it from the cache
        Simulator(s).run(dataclasses.replace(timed, n_samples=2))
    runs: tuple[list, list] = ([], [])
    for _ in range(reps):
        for s, out in zip(pair, runs):
            c, t = time.process_time(), time.perf_counter()
            trajectory = Simulator(s).run(timed)
            out.append((time.perf_counter() - t, time.process_time() - c))
    with_contact, without = (statistics.median(w for w, _ in out) for out in runs)
    steps = trajectory.n_steps
    n = setup.rod.n_nodes
    per_node_step = 1e6 / (steps * n)
    return {"us_per_node_step": with_contact * per_node_step,
            "us_per_node_step_without_contact": without * per_node_step,
            "overhead": with_contact / without - 1.0,
            "integrator": timed.integrator.name, "dt_s": trajectory.step, "substeps": trajectory.substeps,
            "obstacles": [type(o).__name__ for o in setup.contact.obstacles], "tip_node": node, "nodes": n,
            "steps": steps, "simulated_s": steps * trajectory.step, "wall_s": with_contact,
            "wall_without_contact_s": without, "reps": reps,
            "cpu_fraction": min(statistics.median(c / w for w, c in out) for out in runs)}


def warm_contact_cases(node_steps: int, max_span_s: float, cases=CONTACT_CASES) -> None:
    """Run the warm-up of every ``time_contact_cases`` entry (``time_contact``'s first runs, with and
    without contact, over 2 samples), untimed (``_runs.warm_runs``)."""
    def runs(scenario):
        bare, timed = contact_configs(scenario.setup, scenario.config, tracked_node(scenario), node_steps, max_span_s)
        return [(scenario.setup, timed), (bare, timed)]
    warm_runs(cases, runs)


def time_contact_cases(reps: int, node_steps: int, max_span_s: float, cases=CONTACT_CASES,
                       tick: Callable[[], None] | None = None) -> dict:
    """``simulator.contact``: {case: entry} for ``cases`` (``time_contact``), plus "how"
    (``CONTACT_HOW``). A case that fails is recorded as {"error": ...}. Run it with numba on one
    thread."""
    out: dict = {}
    for case in cases:
        try:
            scenario = load_scenario(case)
            out[case] = time_contact(scenario.setup, scenario.config, tracked_node(scenario), reps, node_steps,
                                     max_span_s)
        except Exception as exc:  # a scenario under construction must not sink the benchmark
            out[case] = {"error": f"{type(exc).__name__}: {exc}"}
        if tick is not None:
            tick()
    out["how"] = CONTACT_HOW
    return out


def contact_overheads(sim: dict) -> list[float]:
    """The measured overheads of ``simulator.contact`` (the entries without an error)."""
    entries = sim.get("contact", {})
    return [e["overhead"] for case, e in entries.items() if case != "how" and "overhead" in e]



def format_contact(contact: dict, goal: float | None, met, settings: dict | None = None) -> list[str]:
    """Text lines of ``simulator.contact`` (one row per case), the overhead beside its ``goal``
    (None: not recorded) and whether the largest met it (``met``: True, False or None)."""
    s = (settings or {}).get("contact", {})
    span = (f"{s['node_steps']:,} node-steps, at most the first {s['max_span_s']:g} s" if "node_steps" in s
            else "a short span")
    goal_text = "" if goal is None else f"; goal: overhead <= {goal:.2f}   {goal_mark(met)}"
    lines = [f"contact, 1 thread: each contact scenario as shipped vs contact=None at the same step ({span})"
             f"{goal_text}"]
    head = (f"  {'case':<19}{'integrator':<11}{'nodes':>6}{'step [s]':>11}{'span [s]':>10}{'with':>10}{'without':>10}"
            f"{'overhead':>10}{'cpu':>6}")
    lines += [head + "   (us/node-step)", "  " + "-" * (len(head) - 2)]
    for case, e in contact.items():
        if case == "how":
            continue
        if "error" in e:
            lines.append(f"  {case:<19}  error: {e['error']}")
            continue
        lines.append(f"  {case:<19}{e['integrator']:<11}{e['nodes']:>6}{e['dt_s']:>11.3g}"
                     f"{e.get('simulated_s', float('nan')):>10.3g}{e['us_per_node_step']:>10.4f}"
                     f"{e['us_per_node_step_without_contact']:>10.4f}{100 * e['overhead']:>9.0f}%"
                     f"{100 * e.get('cpu_fraction', float('nan')):>5.0f}%")
    return lines

