"""The simulator benchmark's integrator entries (``simulator.integrators``): the two integrators
(``RunConfig(integrator="explicit" | "implicit")``) on the paper's cases and the stiff wires
``steel-wire`` and ``nitinol-guidewire``, each at its automatic step: cost, real-time factor and the
tracked node's error against the same integrator at an 8x smaller step (``INTEGRATOR_HOW`` says
exactly how). ``time_integrators`` returns a JSON-ready dict, ``format_integrators`` renders it.
"""

import dataclasses
import statistics
import time
from collections.abc import Callable

import numpy as np

from ..rod import RunConfig, Setup, Simulator
from ..scenarios import load_scenario
from ..scenarios.cases import PAPER_CASES as SCENARIO_PAPER_CASES
from ._runs import covering_samples, tracked_node, warm_runs

INTEGRATORS = ("explicit", "implicit")
INTEGRATOR_CASES = tuple(SCENARIO_PAPER_CASES) + ("steel-wire", "nitinol-guidewire")
KEYS = ("us_per_node_step", "dt_s", "real_time_factor", "tip_error_pct_of_length")
"""The figures of every ``simulator.integrators[INTEGRATOR][CASE]`` entry (the error may be None)."""
REFERENCE_REFINE = 8          # the reference takes REFERENCE_REFINE x the substeps (a step 8x smaller)
REFERENCE_MAX_STEPS = 2_000_000  # solver steps a reference run may take; beyond: timed over fixed steps
INTEGRATOR_HOW = (
    "per scenario (softrnn.scenarios.load_scenario; the paper's cases and the stiff wires), its own saved interval "
    "dt and setup, the integrator switched, substeps=None (automatic), only the tracked node saved (the scenario's "
    "last node of interest: the free tip of square and the wires, the node of interest of ellipse and semicircle, "
    "which are clamped at both ends). dt_s = dt / substeps, the solver step the integrator chooses for that dt "
    "(explicit: the largest stable step, Simulator.stable_step; implicit: rod.implicit.accuracy_step, at most dt). "
    "Timed: the first span_s simulated seconds from rest, one warm-up run, then the median wall of reps runs of "
    "Simulator(setup).run(config), numba 1 thread; us_per_node_step = wall / (steps * nodes), real_time_factor = "
    "simulated s / wall s. tip_error_pct_of_length = 100 * max over the saved samples of |r - r_ref| / L, r the "
    "tracked node's position, r_ref that of one run of the same integrator with 8x the substeps (a step 8x "
    "smaller), same samples. Where that reference would take more than 2,000,000 solver steps (the explicit step "
    "of a stiff wire, about 1e-10 s), fixed_steps solver steps from rest are timed instead (the real-time factor "
    "from them) and the error is null with tip_error_reason.")


def integrator_configs(setup: Setup, config: RunConfig, node: int, integrator: str, span_s: float,
                       fixed_steps: int) -> tuple[float, RunConfig, RunConfig | None, str | None]:
    """(solver step h [s], timed config, reference config or None, why no reference) of one
    integrator entry: the scenario's config with the integrator, automatic substeps and only
    ``node`` saved, over its first ``span_s``; if the reference (``REFERENCE_REFINE`` x the substeps)
    would exceed ``REFERENCE_MAX_STEPS``, ``fixed_steps`` solver steps of h instead, no reference."""
    cfg = dataclasses.replace(config, integrator=integrator, substeps=None, save_nodes=(node,))
    substeps = Simulator(setup).resolve_substeps(cfg)
    h = cfg.dt / substeps
    samples = covering_samples(cfg, span_s)
    ref_steps = (samples - 1) * substeps * REFERENCE_REFINE
    if ref_steps <= REFERENCE_MAX_STEPS:
        timed = dataclasses.replace(cfg, n_samples=samples)
        return h, timed, dataclasses.replace(timed, substeps=substeps * REFERENCE_REFINE), None
    # h * (1 - 1e-9): fixed substeps must not exceed the stable step by a rounding error
    timed = dataclasses.replace(cfg, dt=fixed_steps * h * (1 - 1e-9), n_samples=2, substeps=fixed_steps)
    reason = (f"the reference over {span_s:g} s would take {ref_steps:.2g} solver steps of "
              f"{h / REFERENCE_REFINE:.3g} s (limit {REFERENCE_MAX_STEPS:,}); over the {fixed_steps} timed steps "
              f"({fixed_steps * h:.2g} s) the node barely moves")
    return h, timed, None, reason


def time_integrator(setup: Setup, config: RunConfig, node: int, integrator: str, reps: int, span_s: float,
                    fixed_steps: int) -> dict:
    """One ``simulator.integrators[integrator][case]`` entry (``INTEGRATOR_HOW``)."""
    h, timed, reference, reason = integrator_configs(setup, config, node, integrator, span_s, fixed_steps)
    Simulator(setup).run(dataclasses.replace(timed, n_samples=2))  # warm-up: compiles or loads the kernel
    runs = []
    for _ in range(reps):
        c, t = time.process_time(), time.perf_counter()
        trajectory = Simulator(setup).run(timed)
        runs.append((time.perf_counter() - t, time.process_time() - c))
    wall = statistics.median(w for w, _ in runs)
    steps = trajectory.n_steps
    simulated = steps * trajectory.step
    n = setup.rod.n_nodes
    entry = {"us_per_node_step": 1e6 * wall / (steps * n), "dt_s": h, "real_time_factor": simulated / wall,
             "tip_error_pct_of_length": None, "tip_node": node, "nodes": n, "substeps": trajectory.substeps,
             "steps": steps, "simulated_s": simulated, "wall_s": wall, "reps": reps,
             "cpu_fraction": statistics.median(c / w for w, c in runs), "reference_dt_s": None}
    if reference is None:
        entry["tip_error_reason"] = reason
        return entry
    ref = Simulator(setup).run(reference)
    error = np.linalg.norm(trajectory.positions[:, 0] - ref.positions[:, 0], axis=1)
    entry["tip_error_pct_of_length"] = float(100.0 * np.max(error) / setup.rod.length)
    entry["reference_dt_s"] = ref.step
    return entry


def warm_integrators(span_s: float, fixed_steps: int, cases=INTEGRATOR_CASES, integrators=INTEGRATORS) -> None:
    """Run the warm-up of every ``time_integrators`` entry of ``integrators`` (``time_integrator``'s
    first run: its config over 2 samples), untimed (``_runs.warm_runs``)."""
    def runs(scenario):
        node = tracked_node(scenario)
        return [(scenario.setup, integrator_configs(scenario.setup, scenario.config, node, integrator, span_s,
                                                    fixed_steps)[1]) for integrator in integrators]
    warm_runs(cases, runs)


def time_integrators(reps: int, span_s: float, fixed_steps: int, cases=INTEGRATOR_CASES,
                     tick: Callable[[], None] | None = None) -> dict:
    """``simulator.integrators``: {integrator: {case: entry}} for ``INTEGRATORS`` and ``cases``, plus
    "how" (``INTEGRATOR_HOW``). A case that fails is recorded as {"error": ...}. Run it with numba on
    one thread."""
    out: dict = {name: {} for name in INTEGRATORS}
    for case in cases:
        try:
            scenario = load_scenario(case)
            node = tracked_node(scenario)
        except Exception as exc:  # a scenario under construction must not sink the benchmark
            scenario, error = None, {"error": f"{type(exc).__name__}: {exc}"}
        for integrator in INTEGRATORS:
            if scenario is None:
                out[integrator][case] = dict(error)
                continue
            try:
                out[integrator][case] = time_integrator(scenario.setup, scenario.config, node, integrator, reps,
                                                        span_s, fixed_steps)
            except Exception as exc:
                out[integrator][case] = {"error": f"{type(exc).__name__}: {exc}"}
        if tick is not None:
            tick()
    out["how"] = INTEGRATOR_HOW
    return out



def format_integrators(integrators: dict, settings: dict | None = None) -> list[str]:
    """Text lines of ``simulator.integrators`` (one row per case and integrator)."""
    s = (settings or {}).get("integrators", {})
    span = f"the first {s['span_s']:g} s" if "span_s" in s else "a short span"
    lines = [f"integrators, 1 thread: each scenario at its own saved interval, automatic step, {span} "
             f"(stiff explicit: {s.get('fixed_steps', 'fixed')} steps); error: tracked node vs the same "
             f"integrator at a step {REFERENCE_REFINE}x smaller, % of L"]
    head = (f"  {'case':<19}{'integrator':<11}{'node':>5}{'step [s]':>11}{'us/node-step':>14}{'real-time x':>13}"
            f"{'error [% L]':>13}{'cpu':>6}")
    lines += [head, "  " + "-" * (len(head) - 2)]
    cases = list(dict.fromkeys(c for name in INTEGRATORS for c in integrators.get(name, {})))
    for case in cases:
        for name in INTEGRATORS:
            e = integrators.get(name, {}).get(case)
            if e is None:
                continue
            if "error" in e:
                lines.append(f"  {case:<19}{name:<11}  error: {e['error']}")
                continue
            err = e["tip_error_pct_of_length"]
            lines.append(f"  {case:<19}{name:<11}{e['tip_node']:>5}{e['dt_s']:>11.3g}{e['us_per_node_step']:>14.4f}"
                         f"{e['real_time_factor']:>13.3g}{'n/a' if err is None else f'{err:.2g}':>13}"
                         f"{100 * e.get('cpu_fraction', float('nan')):>5.0f}%")
    reasons = sorted({f"{case} ({name}): {e['tip_error_reason']}" for name in INTEGRATORS
                      for case, e in integrators.get(name, {}).items() if e.get("tip_error_reason")})
    lines += [f"  n/a: {r}" for r in reasons]
    return lines
