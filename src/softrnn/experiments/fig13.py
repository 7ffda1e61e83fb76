"""The paper's Fig. 13 study of the static Cosserat solver: solve time against the tolerance E, the
number of RK4 steps N and the initial-guess error (0-10 % of the converged base wrench), 50
repetitions each (mean and standard deviation), beside the paper's figures.

The load case (the paper's magnetic manipulator in a 20 mT field, ``magnetic_rod`` and
``magnetic_loads``) and the paper's figures (``PAPER_FIG13``) live in ``softrnn.statics.cases``,
shared with the solver's benchmark.
"""

import json
import statistics
import time

import numpy as np
from matplotlib import colormaps

from ..figures.saving import save_figure, subplots
from ..files import atomic_write_text
from ..statics.cases import FIELD, GRADIENT, PAPER_FIG13, magnetic_loads, magnetic_rod
from ..statics.rod import StaticLoads, StaticRod
from ..statics.solver import StaticSolver
from ..timing import machine_info

TOLERANCES = (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10)
N_STEPS = (6, 13, 20, 30, 50, 75, 100)
GUESS_ERRORS = (0.0, 0.02, 0.04, 0.06, 0.08, 0.10)
REPETITIONS = 50
PANEL_A_N = 13
PANEL_B_TOL = 1e-6


def _time_solves(solver: StaticSolver, loads: StaticLoads, guess: np.ndarray, reps: int) -> dict:
    times, iterations, converged = [], [], 0
    for _ in range(reps):
        t = time.perf_counter()
        sol = solver.solve(loads, guess=guess)
        times.append(time.perf_counter() - t)
        iterations.append(sol.iterations)
        converged += sol.converged
    return {"mean_ms": 1e3 * statistics.fmean(times), "std_ms": 1e3 * statistics.pstdev(times),
            "median_ms": 1e3 * statistics.median(times), "iterations": statistics.fmean(iterations),
            "converged": converged / reps}


def _sweep(rod: StaticRod, loads: StaticLoads, cases: list[tuple[int, float]], errors, reps: int) -> dict:
    """Timing table over ``cases`` (n_steps, tol) x guess ``errors``."""
    table = {key: [] for key in ("mean_ms", "std_ms", "median_ms", "iterations", "converged")}
    for n_steps, tol in cases:
        exact = StaticSolver(rod, n_steps=n_steps, tol=1e-12).solve(loads, guess=None).raise_for_status()
        solver = StaticSolver(rod, n_steps=n_steps, tol=tol)
        solver.solve(loads, guess=exact.base_wrench)  # numba dispatch warm-up
        rows = [_time_solves(solver, loads, (1.0 - e) * exact.base_wrench, reps) for e in errors]
        for key in table:
            table[key].append([row[key] for row in rows])
    return table


def run_fig13_study(repetitions: int = REPETITIONS, tolerances=TOLERANCES, n_steps=N_STEPS,
                    guess_errors=GUESS_ERRORS) -> dict:
    """Solve-time study of the paper's Fig. 13 on this machine; a JSON-ready dict.

    Panel A: N = 13 steps, each tolerance E in ``tolerances``; panel B: E = 1e-6, each N in
    ``n_steps``. For each point and each guess error e in ``guess_errors`` the solve starts from
    (1 - e) times the exact base wrench (solved to E = 1e-12 at that N) with a fresh Jacobian and
    is timed ``repetitions`` times (wall time of ``StaticSolver.solve``, Python call included).
    Tables are indexed ``[point][guess error]``.
    """
    rod, loads = magnetic_rod(), magnetic_loads()
    exact = StaticSolver(rod, n_steps=200, tol=1e-12).solve(loads).raise_for_status()
    tip_angle = float(np.degrees(np.arctan2(exact.rotations[-1][2, 2], exact.rotations[-1][0, 2])))
    panel_a = _sweep(rod, loads, [(PANEL_A_N, tol) for tol in tolerances], guess_errors, repetitions)
    panel_b = _sweep(rod, loads, [(n, PANEL_B_TOL) for n in n_steps], guess_errors, repetitions)
    return {
        "paper": PAPER_FIG13,
        "load_case": {
            "description": "magnetic manipulator defaults (magnetic.md 1.3): L 50 mm, D 3 mm, PMC-770 E 2.5 MPa, "
                           "nu 0.5, rho 1000; 2 mm NdFeB cubes (rigid segments) N42 at L/2 and N45 at L - 1 mm, "
                           "axial moments; 20 mT along +z with a weak gradient; gravity -z",
            "field_T": list(FIELD), "gradient_T_per_m": [list(row) for row in GRADIENT],
            "magnet_moments_A_m2": [m.moment_body[2] for m in rod.magnets],
            "tip_position_m": exact.tip_position.tolist(), "tip_angle_deg_from_x_toward_z": tip_angle,
            "base_wrench": exact.base_wrench.tolist(),
        },
        "repetitions": repetitions,
        "guess_errors": list(guess_errors),
        "tolerance_sweep": {"n_steps": PANEL_A_N, "tolerances": list(tolerances), **panel_a},
        "node_sweep": {"tol": PANEL_B_TOL, "n_steps": list(n_steps), **panel_b},
        "machine": machine_info(),
        "timing": "wall time of StaticSolver.solve(loads, guess=...) including the Python call, single thread",
    }


def plot_fig13(result: dict):
    """Two panels like the paper's Fig. 13: solve time [ms] (mean +- std) against E (A) and N
    (B), one line per guess error, with the paper's reported range shaded; returns the Figure."""

    fig, axes = subplots(1, 2, figsize=(11, 4.2))
    errors = result["guess_errors"]
    colors = colormaps["viridis"](np.linspace(0, 0.9, len(errors)))
    lo, hi = result["paper"]["solve_time_ms"]
    for ax, key, xkey, xlabel, title in (
            (axes[0], "tolerance_sweep", "tolerances", "tolerance E [N, N m]",
             f"(A) N = {result['tolerance_sweep']['n_steps']} steps"),
            (axes[1], "node_sweep", "n_steps", "RK4 steps N", f"(B) E = {result['node_sweep']['tol']:g}")):
        sweep = result[key]
        x = np.array(sweep[xkey], dtype=float)
        mean, std = np.array(sweep["mean_ms"]), np.array(sweep["std_ms"])
        for j, e in enumerate(errors):
            lower = np.minimum(std[:, j], 0.9 * mean[:, j])  # log axis: clip the bar above zero
            ax.errorbar(x, mean[:, j], yerr=(lower, std[:, j]), color=colors[j], marker="o", ms=3, lw=1, capsize=2,
                        label=f"guess error {100 * e:.0f} %")
        ax.axhspan(lo, hi, color="tab:red", alpha=0.15,
                   label=f"paper: {lo:g}-{hi:g} ms ({result['paper']['bandwidth_hz'][0]}-"
                         f"{result['paper']['bandwidth_hz'][1]:g} Hz), N = {result['paper']['nodes']}")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel(xlabel)
        ax.set_ylabel("solve time [ms]")
        ax.set_title(title)
        ax.grid(alpha=0.3, which="both")
    axes[0].invert_xaxis()
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=4, fontsize=8, frameon=False)
    fig.suptitle(f"Static Cosserat solve time on this machine, mean +- std of {result['repetitions']} solves "
                 "(the paper's Fig. 13 study)", fontsize=10)
    fig.tight_layout(rect=(0, 0.1, 1, 1))
    return fig


def write_fig13(result: dict, json_path, figure_path) -> None:
    """Write the study's JSON and figure atomically."""

    atomic_write_text(json_path, json.dumps(result, indent=2))
    save_figure(plot_fig13(result), figure_path)
