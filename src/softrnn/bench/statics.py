"""Speed of the static Cosserat solver (``softrnn.statics``) on this machine.

Measures, for the magnetic manipulator of ``softrnn.statics.cases`` (L 50 mm, two magnets,
N = 13 RK4 steps, tolerance E = 1e-6 as in the paper's experiment):

* warm-started solves per second: a control loop in which the 20 mT field turns slowly (1 deg
  per solve, sweeping +-30 deg), each solve starting from the previous solution and its
  shooting Jacobian; the median wall time of ``StaticSolver.solve`` gives the rate, and the loop
  rate with the construction of the new ``StaticLoads`` is reported beside it;
* a cold solve (no previous solution: rigid-rod guess and a finite-difference Jacobian);
* the accuracy of N = 13 against N = 400 (tip position error over the length).

``run_static_benchmark`` returns a JSON-ready dict and ``format_static_table`` renders it; neither
prints.
"""

import math
import statistics
import time

import numpy as np

from ..statics import StaticLoads, StaticSolver
from ..statics.cases import FIELD, GRADIENT, PAPER_FIG13, magnetic_rod

N_STEPS = 13
TOL = 1e-6
GOAL_WARM_SOLVES_PER_S = 10_000
SWEEP_DEG = 30.0            # amplitude of the field's turn in the xz-plane
STEP_DEG = 1.0              # largest turn between two solves


_FIELD_MAGNITUDE = float(np.linalg.norm(FIELD))
_GRADIENT = np.array(GRADIENT)


def _field_loads(angle_rad: float) -> StaticLoads:
    b = _FIELD_MAGNITUDE
    return StaticLoads(magnetic_field=(b * math.sin(angle_rad), 0.0, b * math.cos(angle_rad)),
                       field_gradient=_GRADIENT)


def _angles(n: int) -> np.ndarray:
    """Field angles [rad] of a triangular sweep between -SWEEP_DEG and +SWEEP_DEG in steps of
    STEP_DEG: every solve sees the same change of load (1 deg of a 20 mT field changes the magnets'
    torque by ~3e-6 N m, above the tolerance, so each solve iterates)."""
    k = np.arange(n) * STEP_DEG / SWEEP_DEG  # in units of the amplitude
    triangle = 2.0 * np.abs((k / 4.0 + 0.25) % 1.0 - 0.5) * 2.0 - 1.0  # period 4 amplitudes, starts at 0
    return np.radians(SWEEP_DEG * triangle)


def time_warm(n_solves: int) -> dict:
    """Warm-started control loop of ``n_solves`` solves with a slowly turning field."""
    rod = magnetic_rod()
    solver = StaticSolver(rod, n_steps=N_STEPS, tol=TOL)
    solver.solve(_field_loads(0.0)).raise_for_status()  # compile / load from cache, first warm state
    angles = _angles(n_solves)
    times, iterations, integrations, failures = [], [], [], 0
    start = time.perf_counter()
    for angle in angles:
        loads = _field_loads(angle)
        t = time.perf_counter()
        sol = solver.solve(loads)
        times.append(time.perf_counter() - t)
        iterations.append(sol.iterations)
        integrations.append(sol.integrations)
        failures += not sol.converged
    loop = time.perf_counter() - start
    median = statistics.median(times)
    return {
        "solves": n_solves,
        "warm_solves_per_s": 1.0 / median,
        "median_us": 1e6 * median,
        "mean_us": 1e6 * statistics.fmean(times),
        "p90_us": 1e6 * float(np.percentile(times, 90)),
        "loop_solves_per_s_with_loads": n_solves / loop,
        "mean_iterations": statistics.fmean(iterations),
        "mean_integrations": statistics.fmean(integrations),
        "failures": failures,
        "field": f"|B| = {1e3 * np.linalg.norm(FIELD):.0f} mT turning in the xz-plane, +-{SWEEP_DEG:g} deg, "
                 f"at most {STEP_DEG:g} deg per solve; gradient fixed",
    }


def time_cold(reps: int) -> dict:
    """Cold solves: the solver forgets its warm start before each one."""
    solver = StaticSolver(magnetic_rod(), n_steps=N_STEPS, tol=TOL)
    loads = _field_loads(0.0)
    solver.solve(loads)
    times, iterations = [], []
    for _ in range(reps):
        solver.reset()
        t = time.perf_counter()
        sol = solver.solve(loads)
        times.append(time.perf_counter() - t)
        iterations.append(sol.iterations)
        sol.raise_for_status()
    return {"reps": reps, "median_us": 1e6 * statistics.median(times), "mean_iterations": statistics.fmean(iterations)}


def accuracy() -> dict:
    """Tip error of N = 13 against N = 400, both solved to E = 1e-12, over the rod length."""
    rod = magnetic_rod()
    loads = _field_loads(0.0)
    ref = StaticSolver(rod, n_steps=400, tol=1e-12).solve(loads).raise_for_status()
    sol = StaticSolver(rod, n_steps=N_STEPS, tol=1e-12).solve(loads).raise_for_status()
    return {"tip_error_over_length": float(np.linalg.norm(sol.tip_position - ref.tip_position) / rod.length),
            "tip_position_m": ref.tip_position.tolist()}


def run_static_benchmark(quick: bool = False) -> dict:
    """All measurements as a JSON-ready dict (``quick``: fewer solves, less precise)."""
    warm = time_warm(3000 if quick else 20000)
    cold = time_cold(50 if quick else 300)
    return {
        "settings": {"n_steps": N_STEPS, "tol": TOL, "quick": quick,
                     "case": "magnetic manipulator (softrnn.statics.cases.magnetic_rod), 20 mT field",
                     "timing": "wall time of StaticSolver.solve, single thread, Python call included"},
        "warm": warm,
        "cold": cold,
        "accuracy": accuracy(),
        "goal": {"warm_solves_per_s": GOAL_WARM_SOLVES_PER_S,
                 "met": warm["warm_solves_per_s"] >= GOAL_WARM_SOLVES_PER_S and warm["failures"] == 0},
        "paper": {"bandwidth_hz": PAPER_FIG13["bandwidth_hz"], "nodes": PAPER_FIG13["nodes"],
                  "hardware": PAPER_FIG13["hardware"], "source": PAPER_FIG13["source"]},
    }


def format_static_table(result: dict) -> str:
    """A short text table of ``run_static_benchmark``'s result."""
    w, c, g = result["warm"], result["cold"], result["goal"]
    lo, hi = result["paper"]["bandwidth_hz"]
    rows = [
        f"static Cosserat solver, N = {result['settings']['n_steps']}, E = {result['settings']['tol']:g}",
        f"  warm-started: {w['warm_solves_per_s']:,.0f} solves/s (median {w['median_us']:.1f} us, "
        f"p90 {w['p90_us']:.1f} us; {w['mean_iterations']:.2f} iterations, {w['mean_integrations']:.2f} "
        f"integrations per solve; {w['failures']} failed)",
        f"  loop with new loads each solve: {w['loop_solves_per_s_with_loads']:,.0f} solves/s",
        f"  cold solve: {c['median_us']:.1f} us ({c['mean_iterations']:.1f} iterations)",
        f"  tip error of N = {result['settings']['n_steps']} vs N = 400: "
        f"{100 * result['accuracy']['tip_error_over_length']:.2g} % of L",
        f"  goal >= {g['warm_solves_per_s']:,} solves/s: {'met' if g['met'] else 'NOT met'}; "
        f"paper: {lo:g}-{hi:g} Hz",
    ]
    return "\n".join(rows)
