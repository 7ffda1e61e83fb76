"""softrnn vs PyElastica: the same soft cantilever in both codes, speed and error against theory.

    .venv/bin/python benchmarks/vs_pyelastica.py --json benchmarks/results/vs_pyelastica.json
    .venv/bin/python benchmarks/vs_pyelastica.py --quick
    .venv/bin/python benchmarks/vs_pyelastica.py --integrator explicit    # softrnn's explicit LGVI step
    .venv/bin/python benchmarks/vs_pyelastica.py --quick --elements 400   # other resolutions (no goals)

PyElastica is an optional extra (``pip install -e '.[pyelastica]'``); without it the script says so
and exits with status 2. A benchmark, not a test: pytest never collects it. See benchmarks/README.md,
section "softrnn vs PyElastica", for the setup and the measured figures.

The problem (both codes, identical parameters):

* rod: L = 1 m, r = 1 cm (L/r = 100), E = 1 MPa, G = E/3 (nu = 0.5), rho = 1000 kg/m^3, shear
  coefficient kappa = 27/28 (PyElastica hard-codes alpha_c = 27/28; softrnn's ``shear_coefficient``
  is set to the same value), straight along +x, clamped at x = 0, no gravity;
* matched resolution: N elements. PyElastica: ``n_elements = N`` (N + 1 nodes); softrnn:
  ``n_nodes = N + 1`` (N segments). Both then have N + 1 nodes, segment length L/N, half-weight end
  nodes, and the tip load acts on node N;
* a world-fixed tip force (0, 0, -P), P = 0.01 * 3 EI / L^3 (a tip deflection of about 1 % of L),
  switched on at t = 0 on the straight rod at rest;
* (a) ``static``: mass-proportional damping at rate gamma = 2 omega_1 (critical for the first
  bending mode) for 2.5 analytic periods; the final tip deflection is compared with
  Timoshenko's P L^3 / (3 EI) + P L / (kappa G A);
* (b) ``oscillation``: no damping for 4 analytic periods; the suddenly applied load makes the tip
  oscillate about its static deflection (for a linear system the same motion as releasing the
  loaded, resting beam); the first-mode frequency of the tip deflection (zero crossings as a first
  estimate, then a least-squares fit of the first two modes) is compared with the first bending
  frequency beta_1^2 sqrt(EI/(rho A L^4)) / (2 pi) with Rayleigh's first-order rotary-inertia and
  shear corrections (-0.024 % at L/r = 100).

softrnn runs with the integrator ``--integrator`` names (default ``implicit``: the stiff-stable
step of ``softrnn.rod.implicit`` at its automatic step, ``rod.implicit.accuracy_step``, which resolves
the fourth bending mode; capped by the saved interval T_1/200), or ``explicit`` (the LGVI step at
``Simulator.stable_step()``, its default safety factor 0.5 on the estimated limit 2/omega_max, so
the largest step softrnn accepts). PyElastica (PositionVerlet) runs at the largest dt/dx in a
decreasing sequence whose trial run stays stable, lowered further if a full run diverges. Timing:
numba pinned to 1 thread, one warm-up run of each code first (JIT compilation and cache loading not
timed), then the median wall time of ``reps`` repetitions of each run, each timed from building the
system to the end of the run.

``--json`` also writes ``results``: per resolution ``{"elements", "ratio", "softrnn_error_pct",
"pyelastica_error_pct", "by_test"}`` (``RESULTS_HOW`` says how they are taken from the two tests).
"""

import argparse
import json
import math
import os
import platform
import statistics
import sys
import time
from dataclasses import dataclass

# keep BLAS single-threaded: the comparison is single-threaded
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

from softrnn.errors import bad  # noqa: E402

BETA1 = 1.8751040687119611  # first two roots of 1 + cos(b) cosh(b) = 0 (clamped-free beam)
BETA2 = 4.6940911329741746
PYELASTICA_SHEAR_COEFFICIENT = 27.0 / 28.0  # alpha_c in elastica/rod/factory_function.py (1.0.0)

RESOLUTIONS = (50, 100, 200)  # elements (PyElastica n_elements; softrnn n_nodes - 1); the goals are judged here
GOALS = {"speed_ratio_min": 5.0, "error_equal_tol": 1e-4, "previous_error_tol": 5e-6}
INTEGRATORS = ("implicit", "explicit")  # softrnn's; the first is the default
PREVIOUS_ERRORS = {  # softrnn's errors before the implicit integrator (explicit LGVI; benchmarks/README.md)
    50: {"static": -0.021e-2, "oscillation": -0.003e-2},    # 2026-11-21, rounded to 0.001 %
    100: {"static": -0.013e-2, "oscillation": 0.005e-2},    # 2026-11-21, rounded to 0.001 %
    200: {"static": -0.011e-2, "oscillation": 0.007e-2},    # 2026-11-27 (--integrator explicit), rounded
}
"""The goal "|error| within the earlier softrnn figures" allows ``previous_error_tol`` (their rounding)."""
# decreasing dt/dx [s/m] tried for PyElastica; the first whose trial run stays stable is used
PYELASTICA_FACTORS = (0.05, 0.045, 0.04, 0.035, 0.03, 0.0275, 0.025, 0.0225, 0.02, 0.0175, 0.015, 0.0125, 0.01,
                      0.0075, 0.005)
SAMPLES_PER_PERIOD = 200
STATIC_PERIODS = 2.5      # (a): damped at gamma = 2 omega_1, residual ~ (1 + w t) exp(-w t) ~ 3e-6
OSCILLATION_PERIODS = 4.0  # (b): undamped, 8 zero crossings
TRIAL_S = 3.0             # PyElastica stability trial [simulated s]
DIVERGED = 0.5            # a node moved more than DIVERGED * L (or a non-finite value): unstable


# ---------------------------------------------------------------------------------------------- problem
@dataclass(frozen=True, kw_only=True)
class Cantilever:
    """The shared rod and load (SI units); see the module docstring."""

    length: float = 1.0
    radius: float = 0.01
    youngs_modulus: float = 1e6
    shear_modulus: float = 1e6 / 3.0
    density: float = 1000.0
    shear_coefficient: float = PYELASTICA_SHEAR_COEFFICIENT
    load_fraction: float = 0.01  # tip deflection / L of the Euler-Bernoulli beam

    def __post_init__(self):
        for name in ("length", "radius", "youngs_modulus", "shear_modulus", "density", "shear_coefficient",
                     "load_fraction"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise bad(f"Cantilever.{name}", value, "a positive finite number (SI units)")
        if self.radius >= self.length:
            raise bad("Cantilever.radius", self.radius, f"a radius below the length {self.length} m")

    @property
    def area(self) -> float:
        return math.pi * self.radius**2

    @property
    def second_moment(self) -> float:
        return math.pi * self.radius**4 / 4.0

    @property
    def bending_stiffness(self) -> float:
        """EI [N m^2]."""
        return self.youngs_modulus * self.second_moment

    @property
    def shear_stiffness(self) -> float:
        """kappa G A [N]."""
        return self.shear_coefficient * self.shear_modulus * self.area

    @property
    def tip_load(self) -> float:
        """P [N] (downward, -z)."""
        return self.load_fraction * 3.0 * self.bending_stiffness / self.length**3


def static_tip_deflection(c: Cantilever) -> dict:
    """Small-deflection tip deflection [m] under the tip load: Euler-Bernoulli P L^3/(3 EI) plus
    Timoshenko's shear term P L/(kappa G A)."""
    P, L = c.tip_load, c.length
    bending = P * L**3 / (3.0 * c.bending_stiffness)
    shear = P * L / c.shear_stiffness
    return {"deflection_m": bending + shear, "euler_bernoulli_m": bending, "shear_m": shear}


def mode_shape_ratios(points: int = 20001) -> tuple[float, float]:
    """For the first clamped-free Euler-Bernoulli mode phi(s) on a unit length:
    (int phi'^2 / int phi^2, int phi'''^2 / int phi''^2), both dimensionless (times L^2 on length L)."""
    b = BETA1
    s = np.linspace(0.0, 1.0, points)
    sigma = (math.cosh(b) + math.cos(b)) / (math.sinh(b) + math.sin(b))
    ch, co, sh, si = np.cosh(b * s), np.cos(b * s), np.sinh(b * s), np.sin(b * s)
    phi = ch - co - sigma * (sh - si)
    d1 = b * (sh + si - sigma * (ch - co))
    d2 = b**2 * (ch + co - sigma * (sh + si))
    d3 = b**3 * (sh - si - sigma * (ch + co))
    return (float(np.trapezoid(d1**2, s) / np.trapezoid(phi**2, s)),
            float(np.trapezoid(d3**2, s) / np.trapezoid(d2**2, s)))


def first_bending_frequency(c: Cantilever) -> dict:
    """First bending frequency [Hz] of the clamped-free beam.

    Euler-Bernoulli: beta_1^2 sqrt(EI / (rho A L^4)) / (2 pi). Rayleigh's quotient with the
    Euler-Bernoulli mode phi, to first order in (r/L)^2, adds rotary inertia (kinetic energy
    rho I int phi'^2) and shear compliance (energy int V^2/(kappa G A), V = EI phi'''):
    omega^2 = omega_EB^2 / (1 + (I/A) int phi'^2/int phi^2 + EI/(kappa G A) int phi'''^2/int phi''^2).
    """
    L = c.length
    omega_eb = BETA1**2 * math.sqrt(c.bending_stiffness / (c.density * c.area * L**4))
    rot_ratio, shear_ratio = mode_shape_ratios()
    rotary = c.second_moment / c.area * rot_ratio / L**2
    shear = c.bending_stiffness / c.shear_stiffness * shear_ratio / L**2
    omega = omega_eb / math.sqrt(1.0 + rotary + shear)
    return {"frequency_hz": omega / (2 * math.pi), "euler_bernoulli_hz": omega_eb / (2 * math.pi),
            "omega_rad_s": omega, "rotary_inertia_term": rotary, "shear_term": shear,
            "correction": omega / omega_eb - 1.0}


def oscillation_frequency(t: np.ndarray, z: np.ndarray) -> dict:
    """First-mode frequency [Hz] of a tip oscillation z(t) (S,) about a constant.

    A first estimate comes from the linearly interpolated zero crossings of z - mean(z); then
    c + a1 cos(w1 t) + b1 sin(w1 t) + a2 cos(w2 t) + b2 sin(w2 t) is fitted by least squares
    (amplitudes linear, w1 and w2 by scipy's least_squares, w2 starting at the Euler-Bernoulli
    ratio (beta_2 / beta_1)^2 w1). The suddenly applied load also excites the second mode (a few
    % of the amplitude), which shifts zero crossings: over 4 periods the crossing estimate alone is
    0.1 % low, the fit is exact to ~1e-7 on such synthetic data. Returns frequency_hz, crossings,
    second_mode_hz and the rms fit residual relative to the amplitude.
    """
    from scipy.optimize import least_squares

    y = z - np.mean(z)
    neg = np.signbit(y)
    idx = np.nonzero(neg[:-1] != neg[1:])[0]
    if idx.size < 3:
        raise RuntimeError(f"only {idx.size} zero crossings: the run is too short to measure a frequency")
    tc = t[idx] - y[idx] * (t[idx + 1] - t[idx]) / (y[idx + 1] - y[idx])
    omega0 = np.pi / np.polyfit(np.arange(tc.size), tc, 1)[0]

    def design(omega):
        cols = [np.ones_like(t)]
        for w in omega:
            cols += [np.cos(w * t), np.sin(w * t)]
        return np.stack(cols, 1)

    def residual(omega):
        a = design(omega)
        coef = np.linalg.lstsq(a, z, rcond=None)[0]
        return a @ coef - z

    x0 = np.array([omega0, (BETA2 / BETA1) ** 2 * omega0])
    fit = least_squares(residual, x0, x_scale=x0, xtol=1e-14, ftol=1e-14, gtol=1e-14)
    amplitude = 0.5 * np.ptp(z)
    return {"frequency_hz": float(fit.x[0] / (2 * np.pi)), "crossings": int(idx.size),
            "crossing_estimate_hz": float(omega0 / (2 * np.pi)), "second_mode_hz": float(fit.x[1] / (2 * np.pi)),
            "fit_residual": float(np.sqrt(np.mean(fit.fun**2)) / amplitude)}


@dataclass(frozen=True)
class Test:
    """One run: ``damping_rate`` gamma [1/s] (0: none) for ``duration`` [s], tip sampled every
    ``sample_dt`` [s]."""

    name: str
    duration: float
    sample_dt: float
    damping_rate: float


def tests_for(c: Cantilever) -> tuple[Test, Test]:
    freq = first_bending_frequency(c)
    period = 1.0 / freq["frequency_hz"]
    sample_dt = period / SAMPLES_PER_PERIOD
    return (Test("static", STATIC_PERIODS * period, sample_dt, 2.0 * freq["omega_rad_s"]),
            Test("oscillation", OSCILLATION_PERIODS * period, sample_dt, 0.0))


# ---------------------------------------------------------------------------------------------- softrnn
def softrnn_setup(c: Cantilever, n_elements: int, damping_rate: float):
    from softrnn.rod import Clamp, Constant, Damping, NodalLoad, RodSpec, Setup, straight

    n = n_elements + 1
    rod = RodSpec(length=c.length, radius=c.radius, youngs_modulus=c.youngs_modulus, density=c.density,
                  n_nodes=n, shear_modulus=c.shear_modulus, shear_coefficient=c.shear_coefficient)
    # mass-proportional damping at rate gamma, as PyElastica's AnalyticalLinearDamper(uniform):
    # force -c_t l w v with c_t = gamma rho A, torque -c_r l w omega with c_r = gamma rho I
    damping = Damping(translational=damping_rate * c.density * c.area,
                      rotational=damping_rate * c.density * c.second_moment)
    return Setup(rod=rod, reference=straight(n, c.length, direction=(1.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0)),
                 boundary=(Clamp(0),), loads=(NodalLoad(n - 1, force=Constant((0.0, 0.0, -c.tip_load))),),
                 damping=damping)


def softrnn_run(c: Cantilever, n_elements: int, test: Test, duration: float | None = None,
                integrator: str = INTEGRATORS[0]) -> dict:
    """One timed softrnn run: ``Simulator(setup).run(config)`` saving the tip only, with the
    ``integrator`` at its automatic step (substeps None)."""
    from softrnn.rod import RunConfig, Simulator

    setup = softrnn_setup(c, n_elements, test.damping_rate)
    samples = max(1, round((test.duration if duration is None else duration) / test.sample_dt))
    config = RunConfig(dt=test.sample_dt, n_samples=samples + 1, save_nodes=(n_elements,), integrator=integrator)
    cpu, start = time.process_time(), time.perf_counter()
    sim = Simulator(setup)
    traj = sim.run(config)
    wall = time.perf_counter() - start
    cpu = time.process_time() - cpu
    return {"wall_s": wall, "cpu_s": cpu, "step_s": traj.step, "steps": traj.n_steps,
            "simulated_s": traj.n_steps * traj.step, "stable_step_s": sim.stable_step(),
            "step_limit_estimate_s": sim.stable_step(1.0),
            "time": traj.time, "tip": traj.positions[:, 0], "tip_velocity": traj.velocities[-1, 0]}


# ---------------------------------------------------------------------------------------------- PyElastica
def pyelastica_system(c: Cantilever, n_elements: int, damping_rate: float, dt: float):
    """(simulator collection, rod) of the cantilever, finalised."""
    import elastica as ea

    class Cantilever_(ea.BaseSystemCollection, ea.Constraints, ea.Forcing, ea.Damping):
        pass

    sim = Cantilever_()
    rod = ea.CosseratRod.straight_rod(
        n_elements, np.zeros(3), np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0]), c.length, c.radius,
        c.density, youngs_modulus=c.youngs_modulus, shear_modulus=c.shear_modulus)
    sim.append(rod)
    sim.constrain(rod).using(ea.OneEndFixedBC, constrained_position_idx=(0,), constrained_director_idx=(0,))
    # ramp_up_time must be > 0; with 1e-12 s the full load acts from the first force evaluation (t = dt/2)
    sim.add_forcing_to(rod).using(ea.EndpointForces, np.zeros(3), np.array([0.0, 0.0, -c.tip_load]),
                                  ramp_up_time=1e-12)
    if damping_rate > 0:
        sim.dampen(rod).using(ea.AnalyticalLinearDamper, uniform_damping_constant=damping_rate, time_step=dt)
    sim.finalize()
    return sim, rod


def pyelastica_run(c: Cantilever, n_elements: int, test: Test, factor: float,
                   duration: float | None = None) -> dict:
    """One timed PyElastica run with dt = factor * L / n_elements; the tip position is read every
    k steps (k dt ~ sample_dt) inside the stepping loop."""
    import elastica as ea

    dt = factor * c.length / n_elements
    k = max(1, round(test.sample_dt / dt))
    samples = max(1, round((test.duration if duration is None else duration) / (k * dt)))
    tip = np.empty((samples + 1, 3))
    cpu, start = time.process_time(), time.perf_counter()
    sim, rod = pyelastica_system(c, n_elements, test.damping_rate, dt)
    stepper = ea.PositionVerlet()
    position = rod.position_collection
    tip[0] = position[:, -1]
    t = np.float64(0.0)
    step = np.float64(dt)
    for j in range(1, samples + 1):
        for _ in range(k):
            t = stepper.step(sim, t, step)
        tip[j] = position[:, -1]
    wall = time.perf_counter() - start
    cpu = time.process_time() - cpu
    return {"wall_s": wall, "cpu_s": cpu, "step_s": dt, "steps": samples * k, "simulated_s": samples * k * dt,
            "time": k * dt * np.arange(samples + 1), "tip": tip,
            "tip_velocity": rod.velocity_collection[:, -1].copy(), "factor": factor}


def pyelastica_is_stable(c: Cantilever, n_elements: int, test: Test, factor: float, duration: float) -> bool:
    """Trial run; stops at the first sign of divergence (checked every 200 steps)."""
    import elastica as ea

    dt = factor * c.length / n_elements
    sim, rod = pyelastica_system(c, n_elements, test.damping_rate, dt)
    stepper = ea.PositionVerlet()
    start = rod.position_collection.copy()
    t, step = np.float64(0.0), np.float64(dt)
    for i in range(int(round(duration / dt))):
        t = stepper.step(sim, t, step)
        if i % 200 == 0 and not _bounded(rod.position_collection - start, c.length):
            return False
    return _bounded(rod.position_collection - start, c.length)


def _bounded(displacement: np.ndarray, length: float) -> bool:
    return bool(np.all(np.isfinite(displacement)) and np.abs(displacement).max() < DIVERGED * length)


def pyelastica_stable_factor(c: Cantilever, n_elements: int, test: Test) -> tuple[float, list]:
    """Largest dt/dx of PYELASTICA_FACTORS whose undamped trial run of TRIAL_S stays bounded."""
    trials = []
    for factor in PYELASTICA_FACTORS:
        ok = pyelastica_is_stable(c, n_elements, test, factor, TRIAL_S)
        trials.append({"dt_over_dx": factor, "stable": ok})
        if ok:
            return factor, trials
    raise RuntimeError(f"PyElastica was unstable at every dt/dx in {PYELASTICA_FACTORS} ({n_elements} elements)")


# ---------------------------------------------------------------------------------------------- measure
def evaluate(c: Cantilever, test: Test, run: dict) -> dict:
    """Error of one run against theory, and a stability check on the tip path."""
    ref = static_tip_deflection(c)["deflection_m"]
    tip = run["tip"]
    stable = bool(np.all(np.isfinite(tip)) and np.abs(tip[:, 2]).max() < 3.0 * ref)  # the step response peaks at 2x
    out = {"stable": stable}
    if not stable:
        return out
    if test.name == "static":
        deflection = -float(tip[-1, 2])
        omega = first_bending_frequency(c)["omega_rad_s"]
        out.update(deflection_m=deflection, reference_m=ref, error=deflection / ref - 1.0,
                   residual_speed=float(np.linalg.norm(run["tip_velocity"]) / (ref * omega)))
    else:
        freq_ref = first_bending_frequency(c)["frequency_hz"]
        fit = oscillation_frequency(run["time"], -tip[:, 2])
        out.update(fit, reference_hz=freq_ref, error=fit["frequency_hz"] / freq_ref - 1.0,
                   amplitude_m=float(np.ptp(tip[:, 2]) / 2.0))
    return out


def _timing(runs: list[dict]) -> dict:
    wall = statistics.median(r["wall_s"] for r in runs)
    first = runs[0]
    return {"wall_s": wall, "walls_s": [r["wall_s"] for r in runs], "simulated_s": first["simulated_s"],
            "steps": first["steps"], "step_s": first["step_s"],
            "us_per_step": 1e6 * wall / first["steps"],
            "wall_per_simulated_s": wall / first["simulated_s"],
            "realtime_factor": first["simulated_s"] / wall,
            "cpu_fraction": statistics.median(r["cpu_s"] / r["wall_s"] for r in runs)}


def measure_softrnn(c: Cantilever, n_elements: int, tests, reps: int, integrator: str = INTEGRATORS[0]) -> dict:
    softrnn_run(c, n_elements, tests[0], duration=tests[0].sample_dt * 2, integrator=integrator)  # warm-up
    out = {}
    for test in tests:
        runs = [softrnn_run(c, n_elements, test, integrator=integrator) for _ in range(reps)]
        entry = _timing(runs)
        entry["integrator"] = integrator
        entry["stable_step_s"] = runs[0]["stable_step_s"]  # safety 0.5 (the default) of the limit estimate:
        entry["step_limit_estimate_s"] = runs[0]["step_limit_estimate_s"]  # 2 / omega_max (safety 1)
        entry.update(evaluate(c, test, runs[0]))
        entry["deterministic"] = all(np.array_equal(r["tip"], runs[0]["tip"]) for r in runs)
        out[test.name] = entry
    return out


def measure_pyelastica(c: Cantilever, n_elements: int, tests, reps: int) -> dict:
    pyelastica_run(c, n_elements, tests[0], PYELASTICA_FACTORS[-1], duration=tests[0].sample_dt * 2)  # warm-up
    pyelastica_run(c, n_elements, tests[1], PYELASTICA_FACTORS[-1], duration=tests[1].sample_dt * 2)
    factor, trials = pyelastica_stable_factor(c, n_elements, tests[1])
    out = {"stability_trials": trials, "trial_s": TRIAL_S}
    lower = [f for f in PYELASTICA_FACTORS if f < factor]
    for test in tests:
        while True:
            first = pyelastica_run(c, n_elements, test, factor)
            result = evaluate(c, test, first)
            if result["stable"] or not lower:
                break
            trials.append({"dt_over_dx": factor, "stable": False, "full_run": test.name})
            factor = lower.pop(0)
        runs = [first] + [pyelastica_run(c, n_elements, test, factor) for _ in range(reps - 1)]
        entry = _timing(runs)
        entry["dt_over_dx"] = factor
        entry.update(result)
        entry["deterministic"] = all(np.array_equal(r["tip"], runs[0]["tip"]) for r in runs)
        out[test.name] = entry
    out["dt_over_dx"] = factor  # of the last test (a diverged full run lowers it; each test records its own)
    return out


def compare(soft: dict, pe: dict, tol: float) -> dict:
    out = {}
    for name in ("static", "oscillation"):
        s, p = soft[name], pe[name]
        if not (s.get("stable") and p.get("stable")):
            out[name] = {"speed_ratio": None, "error_not_larger": None}
            continue
        out[name] = {"speed_ratio": s["realtime_factor"] / p["realtime_factor"],
                     "step_ratio": s["step_s"] / p["step_s"],
                     "cost_per_step_ratio": p["us_per_step"] / s["us_per_step"],
                     "abs_error_softrnn": abs(s["error"]), "abs_error_pyelastica": abs(p["error"]),
                     "error_not_larger": abs(s["error"]) <= abs(p["error"]) + tol}
    return out


def machine_info() -> dict:
    import numba

    try:
        from softrnn.timing import machine_info as softrnn_machine
        info = softrnn_machine()
    except ImportError:  # pragma: no cover - older checkouts
        info = {"platform": platform.platform(), "python": platform.python_version(), "numpy": np.__version__,
                "numba": numba.__version__}
    from importlib.metadata import version

    info["pyelastica"] = version("pyelastica")
    info["softrnn"] = version("softrnn")
    return info


def _load() -> list | None:
    try:
        return [round(x, 2) for x in os.getloadavg()]
    except (AttributeError, OSError):
        return None


def run_benchmark(quick: bool = False, progress=None, elements=RESOLUTIONS, integrator: str = INTEGRATORS[0]) -> dict:
    """Run both codes on both tests at each resolution (``elements``), softrnn with ``integrator``;
    JSON-ready dict. ``progress(message)`` is called before each part."""
    import numba

    c = Cantilever()
    tests = tests_for(c)
    reps = 1 if quick else 3
    started, load_start = time.perf_counter(), _load()
    previous = numba.get_num_threads()
    numba.set_num_threads(1)
    resolutions = {}
    try:
        for n in elements:
            if progress:
                progress(f"{n} elements: softrnn")
            soft = measure_softrnn(c, n, tests, reps, integrator)
            if progress:
                progress(f"{n} elements: PyElastica")
            pe = measure_pyelastica(c, n, tests, reps)
            resolutions[str(n)] = {"elements": n, "nodes": n + 1, "softrnn": soft, "pyelastica": pe,
                                   "comparison": compare(soft, pe, GOALS["error_equal_tol"])}
    finally:
        numba.set_num_threads(previous)
    result = {
        "machine": machine_info(),
        "problem": {
            "rod": {"length_m": c.length, "radius_m": c.radius, "youngs_modulus_pa": c.youngs_modulus,
                    "shear_modulus_pa": c.shear_modulus, "density_kg_m3": c.density,
                    "shear_coefficient": c.shear_coefficient},
            "tip_load_n": c.tip_load,
            "matching": "N elements: PyElastica n_elements = N (N + 1 nodes); softrnn n_nodes = N + 1 (N segments)",
            "tests": {t.name: {"duration_s": t.duration, "sample_dt_s": t.sample_dt, "damping_rate_1_s": t.damping_rate}
                      for t in tests},
            "reference": {"static": static_tip_deflection(c), "frequency": first_bending_frequency(c)},
        },
        "resolutions": resolutions,
        "results": summary_rows(resolutions),
        "results_how": RESULTS_HOW,
        "goals": dict(GOALS),
        "previous_softrnn_errors": {str(n): e for n, e in PREVIOUS_ERRORS.items()},
        "settings": {"quick": quick, "reps": reps, "elements": list(elements), "numba_threads": 1,
                     "softrnn_integrator": integrator,
                     "pyelastica_factors": list(PYELASTICA_FACTORS),
                     "elapsed_s": time.perf_counter() - started, "load_average_start": load_start,
                     "load_average_end": _load(), "date": time.strftime("%Y-%m-%d %H:%M:%S %z")},
    }
    result["goals_met"] = goals_met(result)
    return result


RESULTS_HOW = (
    "one entry per resolution: ratio = the smaller over the two tests (static, oscillation) of softrnn's "
    "simulated s per wall s / PyElastica's; softrnn_error_pct and pyelastica_error_pct = each code's signed error "
    "against theory [%] in the test where its |error| is larger (static: tip deflection vs Timoshenko; "
    "oscillation: first-mode frequency vs Euler-Bernoulli with Rayleigh's correction); by_test: both tests")


def summary_rows(resolutions: dict) -> list[dict]:
    """``results``: per resolution the worst (smallest) speed ratio and each code's larger error [%]."""
    rows = []
    for n, entry in resolutions.items():
        by_test = {}
        for name, comp in entry["comparison"].items():
            s, p = entry["softrnn"][name], entry["pyelastica"][name]
            by_test[name] = {"ratio": comp["speed_ratio"],
                             "softrnn_error_pct": 100 * s["error"] if s.get("stable") else None,
                             "pyelastica_error_pct": 100 * p["error"] if p.get("stable") else None}
        ratios = [t["ratio"] for t in by_test.values()]
        row = {"elements": int(n), "ratio": None if None in ratios else min(ratios)}
        for code in ("softrnn", "pyelastica"):
            errs = [t[f"{code}_error_pct"] for t in by_test.values()]
            row[f"{code}_error_pct"] = None if None in errs else max(errs, key=abs)
        row["by_test"] = by_test
        rows.append(row)
    return rows


def goals_met(result: dict) -> dict:
    """speed_5x_at_N: softrnn's real-time factor >= 5x PyElastica's in both tests; error_not_larger_at_N:
    its |error| no larger than PyElastica's (within error_equal_tol) in both tests;
    error_within_previous_at_N: its |error| no larger than the earlier softrnn figure of the test
    (``PREVIOUS_ERRORS``, within previous_error_tol; None where there is none)."""
    goals = result["goals"]
    met = {}
    for n, entry in result["resolutions"].items():
        if int(n) not in RESOLUTIONS:
            continue
        comp = entry["comparison"].values()
        ratios = [v["speed_ratio"] for v in comp]
        met[f"speed_{goals['speed_ratio_min']:g}x_at_{n}"] = (None if None in ratios
                                                             else min(ratios) >= goals["speed_ratio_min"])
        errs = [v["error_not_larger"] for v in comp]
        met[f"error_not_larger_at_{n}"] = None if None in errs else all(errs)
        previous = PREVIOUS_ERRORS.get(int(n))
        soft = entry["softrnn"]
        if previous is None or not all(soft[t].get("stable") for t in previous):
            met[f"error_within_previous_at_{n}"] = None
        else:
            met[f"error_within_previous_at_{n}"] = all(abs(soft[t]["error"]) <= abs(e) + goals["previous_error_tol"]
                                                       for t, e in previous.items())
    return met


# ---------------------------------------------------------------------------------------------- report
def _ok(flag) -> str:
    return "-" if flag is None else ("ok" if flag else "MISS")


def format_table(result: dict) -> str:
    m, p = result["machine"], result["problem"]
    ref = p["reference"]
    lines = [
        f"softrnn vs PyElastica{' (quick)' if result['settings']['quick'] else ''}: soft cantilever, "
        f"L = {p['rod']['length_m']} m, r = {p['rod']['radius_m']} m, E = {p['rod']['youngs_modulus_pa']:.3g} Pa, "
        f"tip load {p['tip_load_n']:.4g} N",
        f"machine: {m.get('cpu', '?')}; {m.get('platform', '')}; Python {m.get('python')}, numba {m.get('numba')}, "
        f"PyElastica {m.get('pyelastica')}",
        f"theory: tip deflection {1e3 * ref['static']['deflection_m']:.5f} mm (Timoshenko), first bending frequency "
        f"{ref['frequency']['frequency_hz']:.6f} Hz (Euler-Bernoulli {ref['frequency']['euler_bernoulli_hz']:.6f} Hz, "
        f"rotary inertia + shear {100 * ref['frequency']['correction']:+.3f} %)",
        "",
    ]
    head = (f"  {'elements':>8}  {'test':<12}{'code':<11}{'dt [s]':>10}{'dt/dx':>8}{'us/step':>9}{'wall/sim s':>11}"
            f"{'real-time x':>12}{'error':>10}{'cpu':>6}")
    lines += [head, "  " + "-" * (len(head) - 2)]
    for n, e in result["resolutions"].items():
        dx = p["rod"]["length_m"] / int(n)
        for name in ("static", "oscillation"):
            for code in ("softrnn", "pyelastica"):
                r = e[code][name]
                err = f"{100 * r['error']:+.3f}%" if r.get("stable") else "unstable"
                lines.append(
                    f"  {n:>8}  {name:<12}{code:<11}{r['step_s']:>10.3e}{r['step_s'] / dx:>8.4f}"
                    f"{r['us_per_step']:>9.2f}"
                    f"{r['wall_per_simulated_s']:>11.4f}{r['realtime_factor']:>12.2f}{err:>10}"
                    f"{100 * r['cpu_fraction']:>5.0f}%")
            comp = e["comparison"][name]
            if comp["speed_ratio"] is not None:
                lines.append(f"  {'':>8}  {'':<12}{'ratio':<11} softrnn {comp['speed_ratio']:.2f}x PyElastica's "
                             f"simulated s per wall s (step {comp['step_ratio']:.2f}x PyElastica's, cost per step "
                             f"{1 / comp['cost_per_step_ratio']:.2f}x); |error| "
                             f"{100 * comp['abs_error_softrnn']:.3f}% vs {100 * comp['abs_error_pyelastica']:.3f}%")
        trials = ", ".join(f"{t['dt_over_dx']:g}{'' if t['stable'] else ' x'}"
                           for t in e["pyelastica"]["stability_trials"])
        lines.append(f"  {'':>8}  PyElastica dt/dx trials ({e['pyelastica']['trial_s']:g} s each, x = diverged): "
                     f"{trials}")
    goals, met = result["goals"], result["goals_met"]
    lines += ["", f"softrnn integrator: {result['settings'].get('softrnn_integrator', 'explicit')}",
              f"goals (softrnn >= {goals['speed_ratio_min']:g}x PyElastica's real-time factor in both tests, "
              f"|error| not larger, within {100 * goals['error_equal_tol']:g} %; |error| within the earlier softrnn "
              f"figures, within {100 * goals['previous_error_tol']:g} %):"]
    lines += [f"  {k:<30}{_ok(v)}" for k, v in met.items()] or [
        f"  (judged at {' and '.join(map(str, RESOLUTIONS))} elements only)"]
    s = result["settings"]
    lines.append(f"median of {s['reps']} run(s) each after a warm-up; numba 1 thread; load average (1, 5, 15 min) "
                 f"at start {s['load_average_start']}, at end {s['load_average_end']}; elapsed {s['elapsed_s']:.0f} s")
    contended = [f"{n}/{name}/{code}" for n, e in result["resolutions"].items() for code in ("softrnn", "pyelastica")
                 for name in ("static", "oscillation") if e[code][name]["cpu_fraction"] < 0.9]
    if contended:
        lines.append(f"warning: waited for a core in {', '.join(contended)}: those timings are inflated")
    return "\n".join(lines)


def _jsonable(x):
    if isinstance(x, dict):
        return {k: _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, (np.floating, np.integer, np.bool_)):
        return x.item()
    return x


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", metavar="PATH", default=None, help="write the results as JSON to PATH")
    parser.add_argument("--quick", action="store_true", help="one repetition instead of three (~30 s)")
    parser.add_argument("--elements", type=int, nargs="+", default=list(RESOLUTIONS), metavar="N",
                        help="resolutions in elements (default: 50 100 200, where the goals are judged)")
    parser.add_argument("--integrator", choices=INTEGRATORS, default=INTEGRATORS[0],
                        help="softrnn's integrator, at its automatic step (default: implicit)")
    args = parser.parse_args(argv)
    if min(args.elements) < 4:
        parser.error(f"--elements={args.elements} is invalid: expected integers >= 4 (PyElastica needs > 3 elements)")
    try:
        import elastica  # noqa: F401
    except ImportError:
        print("vs_pyelastica: PyElastica is not installed (pip install -e '.[pyelastica]'); nothing to compare",
              file=sys.stderr)
        return 2
    from softrnn.files import atomic_write_text

    result = run_benchmark(quick=args.quick, elements=tuple(args.elements), integrator=args.integrator,
                           progress=lambda msg: print(f"[{msg}]", file=sys.stderr, flush=True))
    print(format_table(result))
    if args.json:
        atomic_write_text(args.json, json.dumps(_jsonable(result), indent=2) + "\n")
        print(f"wrote {args.json}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
