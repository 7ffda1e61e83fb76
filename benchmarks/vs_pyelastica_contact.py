"""softrnn vs PyElastica with contact: a soft rod dropped or pushed onto a plane with friction.

    .venv/bin/python benchmarks/vs_pyelastica_contact.py --json benchmarks/results/vs_pyelastica_contact.json
    .venv/bin/python benchmarks/vs_pyelastica_contact.py --quick                    # 1 repetition
    .venv/bin/python benchmarks/vs_pyelastica_contact.py --integrators explicit     # softrnn's explicit step only

PyElastica is an optional extra (``pip install -e '.[pyelastica]'``); without it the script says so
and exits with status 2. A benchmark, not a test: pytest never collects it. See benchmarks/README.md,
section "softrnn vs PyElastica: contact", for the setup and the measured figures.

The problem (both codes, identical parameters):

* rod: L = 0.5 m, r = 5 mm, E = 1 MPa, G = E/3, rho = 1000 kg/m^3, shear coefficient 27/28
  (PyElastica's hard-coded alpha_c), free (no supports), gravity -9.81 m/s^2 along z;
* matched resolution: 50 elements (PyElastica ``n_elements = 50``, softrnn ``n_nodes = 51``);
* the plane z = 0, normal +z; contact penalty k per length = rho A g / (0.005 r) (softrnn's default:
  a node's weight sinks 0.5 % of r) and critical damping c = 2 sqrt(k rho A) per length, given to
  both codes: softrnn ``Contact(stiffness=k, damping=c)`` (node a: k w_a l), PyElastica
  ``RodPlaneContactWithAnisotropicFriction(k=k dx, nu=c dx)`` per element; Coulomb friction
  mu = 0.4, static = kinetic, isotropic (PyElastica's forward, backward and sideways mu all 0.4),
  slip velocity 1e-4 m/s in both (softrnn ``slip_velocity``, PyElastica ``slip_velocity_tol``);
* variants:
  - ``drop``: the straight rod along +x, horizontal, its surface 2 cm above the plane, released at
    rest; mass-proportional damping at rate gamma = 2 /s (softrnn ``Damping(translational=gamma rho
    A, rotational=gamma rho I)``, PyElastica ``AnalyticalLinearDamper(uniform_damping_constant=
    gamma)``), 3 s;
  - ``tilted_drop``: the same rod tilted 10 degrees about y (its lower end's surface 2 cm above the
    plane): one end lands first, the rod slaps down and its lower end slides (friction matters);
    gamma = 2 /s, 3 s;
  - ``slide``: the rod lying on the plane (centreline at height r), given a uniform initial
    velocity v0 = 0.5 m/s along its axis at t = 0; no bulk damping; 1 s. A rigid rod stops after
    v0^2 / (2 mu g) (31.86 mm) at t = v0 / (mu g) (0.127 s).

Measured per variant and code: the final node positions (the rest state), the max distance between
the two codes' rest shapes (% of L), the height of the centreline above the plane against r (the
penetration), the residual speed, for ``slide`` the slide distance of the centre of mass against
v0^2 / (2 mu g), its deceleration (a line fitted to its speed between 20 % and 80 % of v0) against
mu g and its creep (mean speed over the last 0.2 s), and the wall time per simulated second. Each
code is also run once more at a 4x smaller step (untimed, ``refined`` in the JSON): how far its rest
shape moves, and how far apart the two codes' refined rest shapes are.

Steps: softrnn runs each of ``--integrators`` (default both, ``implicit`` and ``explicit``) at its
automatic step (saved interval 5 ms, substeps None: ``Simulator.resolve_substeps``; the contact
springs and dampers bound the implicit step here, the rod's own stiffness the explicit one);
PyElastica (PositionVerlet) at the largest dt/dx of a decreasing sequence whose full run stays
bounded and comes to rest (every node slower than 1 mm/s at the end). Timing: numba pinned to 1
thread, one warm-up run of each code first, then the median wall time of ``reps`` repetitions, each
timed from building the system to the end of the run, both codes copying every node's position every
5 ms. softrnn's ``Setup`` has no initial velocity: ``slide`` adds v0 to the staggered velocities of
the first half kick through the private ``Simulator._half_kick`` (PyElastica:
``rod.velocity_collection`` after ``finalize``).

PyElastica's plane contact differs from softrnn's in its normal force: within 1e-4 m of the plane
it cancels the normal component of the element's internal + external forces (so the weight is
carried without penetration; the penalty spring only pushes the element back up to the surface),
and friction uses that cancelled force as the normal force; softrnn's normal force is the penalty
spring and damper alone (a node rests 0.5 % of r deep). Gravity is added before the contact in
PyElastica (``add_forcing_to`` before ``detect_contact_between``: its operators run in that order),
as its friction needs.
"""

import argparse
import json
import math
import os
import statistics
import sys
import time
from dataclasses import dataclass

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402
from vs_pyelastica import PYELASTICA_SHEAR_COEFFICIENT, _load, machine_info  # noqa: E402

INTEGRATORS = ("implicit", "explicit")
PYELASTICA_FACTORS = (0.05, 0.04, 0.03, 0.025, 0.02, 0.0175, 0.015, 0.0125, 0.01, 0.0075, 0.005)
SAMPLE_DT = 5e-3          # saved interval [s], both codes
REST_SPEED = 1e-3         # a run "comes to rest": every node slower than this at the end [m/s]
REFINE = 4               # the convergence check runs each code again at a 4x smaller step (untimed)
GOALS = {"rest_shape_max_diff_pct_L": 1.0}


# ---------------------------------------------------------------------------------------------- problem
@dataclass(frozen=True, kw_only=True)
class Problem:
    length: float = 0.5
    radius: float = 0.005
    youngs_modulus: float = 1e6
    shear_modulus: float = 1e6 / 3.0
    density: float = 1000.0
    shear_coefficient: float = PYELASTICA_SHEAR_COEFFICIENT
    elements: int = 50
    gravity: float = 9.81
    friction: float = 0.4
    slip_velocity: float = 1e-4
    penetration: float = 0.005   # the contact stiffness: rho A g / (penetration r) per length

    @property
    def area(self) -> float:
        return math.pi * self.radius**2

    @property
    def second_moment(self) -> float:
        return math.pi * self.radius**4 / 4.0

    @property
    def dx(self) -> float:
        return self.length / self.elements

    @property
    def contact_stiffness(self) -> float:
        """k per length [N/m^2]."""
        return self.density * self.area * self.gravity / (self.penetration * self.radius)

    @property
    def contact_damping(self) -> float:
        """c per length [N s/m^2], critical for the mass per length."""
        return 2.0 * math.sqrt(self.contact_stiffness * self.density * self.area)


@dataclass(frozen=True)
class Variant:
    """The rod starts straight, tilted by ``tilt`` [rad] about -y (its end at node N higher), its
    lowest surface point ``height`` [m] above the plane, with uniform velocity ``v0`` [m/s] along
    its axis; damping rate ``gamma`` [1/s]; run for ``duration`` [s]."""

    name: str
    height: float
    tilt: float
    v0: float
    gamma: float
    duration: float


VARIANTS = (
    Variant("drop", 0.02, 0.0, 0.0, 2.0, 3.0),
    Variant("tilted_drop", 0.02, math.radians(10.0), 0.0, 2.0, 3.0),
    Variant("slide", 0.0, 0.0, 0.5, 0.0, 1.0),
)


def initial_line(p: Problem, v: Variant) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(start point, axis direction, normal d1) of the initial straight rod."""
    d = np.array([math.cos(v.tilt), 0.0, math.sin(v.tilt)])
    normal = np.array([-math.sin(v.tilt), 0.0, math.cos(v.tilt)])
    # the lowest surface point is at node 0: its centre sits r / cos(tilt) above the surface point
    start = np.array([0.0, 0.0, v.height + p.radius / math.cos(v.tilt)])
    return start, d, normal


def slide_reference(p: Problem, v: Variant) -> dict:
    """A rigid rod sliding on Coulomb friction (no damping): distance v0^2 / (2 mu g), time v0 / (mu g)."""
    a = p.friction * p.gravity
    return {"distance_m": v.v0**2 / (2 * a), "stop_time_s": v.v0 / a}


# ---------------------------------------------------------------------------------------------- softrnn
def softrnn_setup(p: Problem, v: Variant):
    from softrnn.rod import Contact, Damping, Plane, RodSpec, Setup, straight

    n = p.elements + 1
    rod = RodSpec(length=p.length, radius=p.radius, youngs_modulus=p.youngs_modulus, density=p.density, n_nodes=n,
                  shear_modulus=p.shear_modulus, shear_coefficient=p.shear_coefficient)
    start, d, normal = initial_line(p, v)
    shape = straight(n, p.length, origin=tuple(start), direction=tuple(d), normal=tuple(normal))
    contact = Contact(obstacles=(Plane(point=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0)),), friction=p.friction,
                      slip_velocity=p.slip_velocity, stiffness=p.contact_stiffness, damping=p.contact_damping)
    damping = Damping(translational=v.gamma * p.density * p.area, rotational=v.gamma * p.density * p.second_moment)
    return Setup(rod=rod, reference=straight(n, p.length, direction=(1.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0)),
                 initial=shape, gravity=(0.0, 0.0, -p.gravity), contact=contact, damping=damping), d


def _pushed_simulator(setup, velocity: np.ndarray):
    """A ``Simulator`` whose nodes start with ``velocity`` (3,) [m/s] (a rigid translation).

    softrnn's ``Setup`` has no initial velocity. The first run's half kick (private
    ``Simulator._half_kick``) sets the staggered velocities of a start at rest, v^-1/2 = -(h/2) a^0;
    here it is evaluated with the nodes already moving at v0, so that a^0 holds the friction of the
    moving rod, and shifted to v^-1/2 = v0 - (h/2) a^0. The explicit half kick returns -(h/2) a^0
    (v0 is added); the implicit one returns -u/2 with u = v0 + h a^0 the velocities one implicit step
    reaches (a rigid translation strains nothing; no bulk damping), so 1.5 v0 is added. (With a^0
    from the rod at rest, friction is missing from the half kick and the slide comes out v0 h / 2
    short.)"""
    from softrnn.rod import Simulator

    class Pushed(Simulator):
        def _half_kick(self, h: float) -> None:
            self.state.velocities[:] = velocity
            super()._half_kick(h)
            self.state.velocities[:] += (1.5 if self._integrator == "implicit" else 1.0) * velocity

    return Pushed(setup)


def softrnn_run(p: Problem, v: Variant, integrator: str, duration: float | None = None,
                substeps: int | None = None) -> dict:
    """One timed softrnn run saving every node every SAMPLE_DT; ``substeps`` None: automatic."""
    from softrnn.rod import RunConfig

    duration = v.duration if duration is None else duration
    samples = max(1, round(duration / SAMPLE_DT))
    config = RunConfig(dt=SAMPLE_DT, n_samples=samples + 1, integrator=integrator, substeps=substeps)
    cpu, start = time.process_time(), time.perf_counter()
    setup, d = softrnn_setup(p, v)
    sim = _pushed_simulator(setup, v.v0 * d)
    traj = sim.run(config)
    wall = time.perf_counter() - start
    cpu = time.process_time() - cpu
    return {"wall_s": wall, "cpu_s": cpu, "step_s": traj.step, "steps": traj.n_steps, "substeps": traj.substeps,
            "simulated_s": traj.n_steps * traj.step, "time": traj.time, "positions": traj.positions,
            "final_velocities": traj.velocities[-1]}


# ---------------------------------------------------------------------------------------------- PyElastica
def pyelastica_system(p: Problem, v: Variant, dt: float):
    import elastica as ea

    class Drop(ea.BaseSystemCollection, ea.Forcing, ea.Contact, ea.Damping):
        pass

    sim = Drop()
    start, d, normal = initial_line(p, v)
    rod = ea.CosseratRod.straight_rod(p.elements, start, d, normal, p.length, p.radius, p.density,
                                      youngs_modulus=p.youngs_modulus, shear_modulus=p.shear_modulus)
    plane = ea.Plane(plane_origin=np.zeros(3), plane_normal=np.array([0.0, 0.0, 1.0]))
    sim.append(rod)
    sim.append(plane)
    # gravity first: the contact's normal force and friction read the forces already applied
    sim.add_forcing_to(rod).using(ea.GravityForces, acc_gravity=np.array([0.0, 0.0, -p.gravity]))
    mu = np.full(3, p.friction)
    sim.detect_contact_between(rod, plane).using(
        ea.RodPlaneContactWithAnisotropicFriction, k=p.contact_stiffness * p.dx, nu=p.contact_damping * p.dx,
        slip_velocity_tol=p.slip_velocity, static_mu_array=mu, kinetic_mu_array=mu.copy())
    if v.gamma > 0:
        sim.dampen(rod).using(ea.AnalyticalLinearDamper, uniform_damping_constant=v.gamma, time_step=dt)
    sim.finalize()
    rod.velocity_collection[:] = (v.v0 * d)[:, None]
    return sim, rod


def pyelastica_run(p: Problem, v: Variant, factor: float, duration: float | None = None) -> dict:
    import elastica as ea

    duration = v.duration if duration is None else duration
    dt = factor * p.dx
    k = max(1, round(SAMPLE_DT / dt))
    samples = max(1, round(duration / (k * dt)))
    out = np.empty((samples + 1, p.elements + 1, 3))
    cpu, start = time.process_time(), time.perf_counter()
    sim, rod = pyelastica_system(p, v, dt)
    stepper = ea.PositionVerlet()
    position = rod.position_collection
    out[0] = position.T
    t, step = np.float64(0.0), np.float64(dt)
    for j in range(1, samples + 1):
        for _ in range(k):
            t = stepper.step(sim, t, step)
        out[j] = position.T
        if not np.all(np.isfinite(out[j])):  # diverged: stop early
            out = out[: j + 1]
            break
    wall = time.perf_counter() - start
    cpu = time.process_time() - cpu
    steps = (len(out) - 1) * k
    return {"wall_s": wall, "cpu_s": cpu, "step_s": dt, "steps": steps, "simulated_s": steps * dt,
            "time": k * dt * np.arange(len(out)), "positions": out,
            "final_velocities": rod.velocity_collection.T.copy(), "factor": factor}


# ---------------------------------------------------------------------------------------------- measure
def slide_fit(t: np.ndarray, com: np.ndarray, v0: float) -> dict:
    """The centre of mass' deceleration [m/s^2]: a line fitted to its speed (finite differences of
    the samples, at their midpoints) while it is between 20 % and 80 % of v0, and its zero, the
    stop time [s] of that constant deceleration; ``creep_m_s``: its mean speed over the last 0.2 s."""
    tm = 0.5 * (t[1:] + t[:-1])
    speed = np.diff(com) / np.diff(t)
    sel = (speed > 0.2 * v0) & (speed < 0.8 * v0)
    slope, intercept = np.polyfit(tm[sel], speed[sel], 1)
    last = t >= t[-1] - 0.2 - 1e-12
    creep = float((com[-1] - com[last][0]) / (t[-1] - t[last][0]))
    return {"deceleration_m_s2": float(-slope), "stop_time_s": float(intercept / -slope), "creep_m_s": creep}


def evaluate(p: Problem, v: Variant, run: dict, complete: int) -> dict:
    """Rest state and, for ``slide``, the slide against the rigid rod. ``complete``: the samples of
    a full run (a shorter one diverged)."""
    x = run["positions"]
    stable = bool(len(x) == complete and np.all(np.isfinite(x))
                  and np.abs(x - x[0]).max() < 0.5 * p.length and x[:, :, 2].min() > -p.radius)
    speed = float(np.linalg.norm(run["final_velocities"], axis=1).max()) if stable else math.inf
    out = {"stable": stable, "at_rest": stable and speed < REST_SPEED, "residual_speed_m_s": speed}
    if not stable:
        return out
    z = x[-1, :, 2]
    out.update(final_positions=x[-1], height_mean_m=float(z.mean()), height_min_m=float(z.min()),
               height_max_m=float(z.max()),
               penetration_mean_pct_r=float(100 * (p.radius - z.mean()) / p.radius),
               penetration_max_pct_r=float(100 * (p.radius - z.min()) / p.radius),
               impact_penetration_pct_r=float(100 * (p.radius - x[1:, :, 2].min()) / p.radius))
    if v.v0 > 0:
        ref = slide_reference(p, v)
        w = np.ones(x.shape[1])  # node masses: half-weight end nodes
        w[[0, -1]] = 0.5
        com = (x[:, :, 0] @ w) / w.sum()
        distance = float(com[-1] - com[0])
        fit = slide_fit(run["time"], com, v.v0)
        out.update(slide_m=distance, slide_reference_m=ref["distance_m"],
                   slide_error=distance / ref["distance_m"] - 1.0, **fit,
                   deceleration_reference_m_s2=p.friction * p.gravity,
                   deceleration_error=fit["deceleration_m_s2"] / (p.friction * p.gravity) - 1.0,
                   stop_time_reference_s=ref["stop_time_s"])
    return out


def _timing(runs: list[dict]) -> dict:
    wall = statistics.median(r["wall_s"] for r in runs)
    first = runs[0]
    return {"wall_s": wall, "walls_s": [r["wall_s"] for r in runs], "simulated_s": first["simulated_s"],
            "steps": first["steps"], "step_s": first["step_s"], "us_per_step": 1e6 * wall / max(first["steps"], 1),
            "wall_per_simulated_s": wall / first["simulated_s"], "realtime_factor": first["simulated_s"] / wall,
            "cpu_fraction": statistics.median(r["cpu_s"] / r["wall_s"] for r in runs)}


def measure_softrnn(p: Problem, v: Variant, reps: int, integrator: str) -> dict:
    softrnn_run(p, v, integrator, duration=2 * SAMPLE_DT)  # warm-up (numba cache)
    runs = [softrnn_run(p, v, integrator) for _ in range(reps)]
    entry = _timing(runs)
    entry["integrator"] = integrator
    complete = round(v.duration / SAMPLE_DT) + 1
    entry.update(evaluate(p, v, runs[0], complete))
    entry["deterministic"] = all(np.array_equal(r["positions"], runs[0]["positions"]) for r in runs)
    fine = softrnn_run(p, v, integrator, substeps=REFINE * runs[0]["substeps"])
    entry["refined"] = _refined(p, v, entry, fine, complete)
    return entry


def _refined(p: Problem, v: Variant, entry: dict, fine: dict, complete: int) -> dict:
    """The run at a REFINE times smaller step (untimed): its results and how far the benchmark
    run's rest shape is from it [% of L]."""
    result = evaluate(p, v, fine, complete)
    out = {"step_s": fine["step_s"], **result}
    if result["stable"] and entry.get("stable"):
        diff = np.linalg.norm(entry["final_positions"] - result["final_positions"], axis=1)
        out["rest_shape_change_pct_L"] = float(100 * diff.max() / p.length)
    return out


def measure_pyelastica(p: Problem, v: Variant, reps: int) -> dict:
    pyelastica_run(p, v, PYELASTICA_FACTORS[-1], duration=2 * SAMPLE_DT)  # warm-up
    trials = []
    for factor in PYELASTICA_FACTORS:
        first = pyelastica_run(p, v, factor)
        k = max(1, round(SAMPLE_DT / (factor * p.dx)))
        result = evaluate(p, v, first, max(1, round(v.duration / (k * factor * p.dx))) + 1)
        trials.append({"dt_over_dx": factor, "stable": result["stable"], "at_rest": result["at_rest"]})
        if result["stable"] and result["at_rest"]:
            break
    else:
        raise RuntimeError(f"PyElastica did not come to rest at any dt/dx in {PYELASTICA_FACTORS} ({v.name})")
    runs = [first] + [pyelastica_run(p, v, factor) for _ in range(reps - 1)]
    entry = _timing(runs)
    entry["dt_over_dx"] = factor
    entry["trials"] = trials
    entry.update(result)
    entry["deterministic"] = all(np.array_equal(r["positions"], runs[0]["positions"]) for r in runs)
    fine = pyelastica_run(p, v, factor / REFINE)
    k = max(1, round(SAMPLE_DT / (factor / REFINE * p.dx)))
    entry["refined"] = _refined(p, v, entry, fine, max(1, round(v.duration / (k * factor / REFINE * p.dx))) + 1)
    entry["refined"]["dt_over_dx"] = factor / REFINE
    return entry


def compare(p: Problem, soft: dict, pe: dict) -> dict:
    if not (soft.get("stable") and pe.get("stable")):
        return {"rest_shape_max_diff_pct_L": None, "speed_ratio": None}
    diff = np.linalg.norm(soft["final_positions"] - pe["final_positions"], axis=1)
    fs, fp = soft["refined"], pe["refined"]
    refined = (float(100 * np.linalg.norm(fs["final_positions"] - fp["final_positions"], axis=1).max() / p.length)
               if fs.get("stable") and fp.get("stable") else None)
    return {"rest_shape_max_diff_pct_L": float(100 * diff.max() / p.length),
            "refined_rest_shape_max_diff_pct_L": refined,
            "rest_shape_max_diff_node": int(diff.argmax()),
            "rest_height_diff_mm": 1e3 * (soft["height_mean_m"] - pe["height_mean_m"]),
            "speed_ratio": soft["realtime_factor"] / pe["realtime_factor"],
            "step_ratio": soft["step_s"] / pe["step_s"],
            "cost_per_step_ratio": soft["us_per_step"] / pe["us_per_step"]}


def run_benchmark(quick: bool = False, integrators=INTEGRATORS, variants=VARIANTS, progress=None) -> dict:
    """Every variant in softrnn (each of ``integrators``) and PyElastica; a JSON-ready dict."""
    import numba

    p = Problem()
    reps = 1 if quick else 3
    started, load_start = time.perf_counter(), _load()
    previous = numba.get_num_threads()
    numba.set_num_threads(1)
    out = {}
    try:
        for v in variants:
            soft = {}
            for integrator in integrators:
                if progress:
                    progress(f"{v.name}: softrnn ({integrator})")
                soft[integrator] = measure_softrnn(p, v, reps, integrator)
            if progress:
                progress(f"{v.name}: PyElastica")
            pe = measure_pyelastica(p, v, reps)
            entry = {"variant": {"height_m": v.height, "tilt_deg": math.degrees(v.tilt), "v0_m_s": v.v0,
                                 "damping_rate_1_s": v.gamma, "duration_s": v.duration},
                     "softrnn": soft, "pyelastica": pe,
                     "comparison": {i: compare(p, s, pe) for i, s in soft.items()}}
            if v.v0 > 0:
                entry["reference"] = slide_reference(p, v) | {"deceleration_m_s2": p.friction * p.gravity}
            out[v.name] = entry
    finally:
        numba.set_num_threads(previous)
    result = {
        "machine": machine_info(),
        "problem": {
            "rod": {"length_m": p.length, "radius_m": p.radius, "youngs_modulus_pa": p.youngs_modulus,
                    "shear_modulus_pa": p.shear_modulus, "density_kg_m3": p.density,
                    "shear_coefficient": p.shear_coefficient, "elements": p.elements},
            "gravity_m_s2": p.gravity, "friction": p.friction, "slip_velocity_m_s": p.slip_velocity,
            "contact_stiffness_n_m2": p.contact_stiffness, "contact_damping_n_s_m2": p.contact_damping,
            "pyelastica_k_n_m": p.contact_stiffness * p.dx, "pyelastica_nu_n_s_m": p.contact_damping * p.dx,
            "plane": {"point": [0, 0, 0], "normal": [0, 0, 1]},
        },
        "variants": out,
        "goals": dict(GOALS),
        "settings": {"quick": quick, "reps": reps, "numba_threads": 1, "softrnn_integrators": list(integrators),
                     "sample_dt_s": SAMPLE_DT, "rest_speed_m_s": REST_SPEED, "refine": REFINE,
                     "pyelastica_factors": list(PYELASTICA_FACTORS), "elapsed_s": time.perf_counter() - started,
                     "load_average_start": load_start, "load_average_end": _load(),
                     "date": time.strftime("%Y-%m-%d %H:%M:%S %z")},
    }
    tol = GOALS["rest_shape_max_diff_pct_L"]
    result["goals_met"] = {
        f"rest_shape_within_{tol:g}pct_L_{name}_{i}": None if c["rest_shape_max_diff_pct_L"] is None
        else c["rest_shape_max_diff_pct_L"] <= tol
        for name, e in out.items() for i, c in e["comparison"].items()}
    return result


# ---------------------------------------------------------------------------------------------- report
def format_table(result: dict) -> str:
    m, p, s = result["machine"], result["problem"], result["settings"]
    rod = p["rod"]
    lines = [
        f"softrnn vs PyElastica, rod on a plane with friction{' (quick)' if s['quick'] else ''}: "
        f"L = {rod['length_m']} m, r = {rod['radius_m']} m, E = {rod['youngs_modulus_pa']:.3g} Pa, "
        f"{rod['elements']} elements, mu = {p['friction']}, contact k = {p['contact_stiffness_n_m2']:.4g} N/m^2, "
        f"c = {p['contact_damping_n_s_m2']:.4g} N s/m^2 per length",
        f"machine: {m.get('cpu', '?')}; {m.get('platform', '')}; Python {m.get('python')}, numba {m.get('numba')}, "
        f"PyElastica {m.get('pyelastica')}",
        "",
    ]
    head = (f"  {'variant':<12}{'code':<19}{'dt [s]':>10}{'us/step':>9}{'real-time x':>12}{'cpu':>5}"
            f"{'z-r [um]':>9}{'impact':>8}{'resid v':>9}{'slide mm':>9}{'vs rigid':>9}{'decel':>8}{'creep':>9}")
    lines += [head, "  " + "-" * (len(head) - 2)]
    for name, e in result["variants"].items():
        rows = [(f"softrnn {i}", r) for i, r in e["softrnn"].items()] + [("pyelastica", e["pyelastica"])]
        for label, r in rows:
            if not r.get("stable"):
                lines.append(f"  {name:<12}{label:<19} unstable")
                continue
            slide = (f"{1e3 * r['slide_m']:>9.2f}{100 * r['slide_error']:>+8.2f}%"
                     f"{100 * r['deceleration_error']:>+7.2f}%{r['creep_m_s']:>9.1e}" if "slide_m" in r else "")
            lines.append(f"  {name:<12}{label:<19}{r['step_s']:>10.3e}{r['us_per_step']:>9.2f}"
                         f"{r['realtime_factor']:>12.2f}{100 * r['cpu_fraction']:>4.0f}%"
                         f"{1e6 * (r['height_mean_m'] - rod['radius_m']):>+9.1f}"
                         f"{r['impact_penetration_pct_r']:>7.1f}%{r['residual_speed_m_s']:>9.1e}{slide}")
        for i, c in e["comparison"].items():
            if c["speed_ratio"] is not None:
                lines.append(f"  {'':<12}{'vs PyElastica':<19}softrnn {i}: rest shapes differ by "
                             f"{c['rest_shape_max_diff_pct_L']:.3f} % of L (max, node {c['rest_shape_max_diff_node']});"
                             f" {c['speed_ratio']:.2f}x PyElastica's real-time factor (step {c['step_ratio']:.2f}x, "
                             f"cost per step {c['cost_per_step_ratio']:.2f}x)")
                ch = (e["softrnn"][i]["refined"].get("rest_shape_change_pct_L"),
                      e["pyelastica"]["refined"].get("rest_shape_change_pct_L"), c["refined_rest_shape_max_diff_pct_L"])
                if None not in ch:
                    lines.append(f"  {'':<12}{'':<19}at {result['settings']['refine']}x smaller steps the rest shapes "
                                 f"move by {ch[0]:.3f} % (softrnn {i}) and {ch[1]:.3f} % of L (PyElastica) and "
                                 f"differ by {ch[2]:.3f} % of L")
        ref = e.get("reference")
        if ref:
            lines.append(f"  {'':<12}{'rigid rod':<19}slide v0^2/(2 mu g) = {1e3 * ref['distance_m']:.2f} mm, "
                         f"deceleration mu g = {ref['deceleration_m_s2']:.4g} m/s^2, "
                         f"stop at {ref['stop_time_s']:.4f} s")
        lines.append(f"  {'':<12}PyElastica dt/dx trials (x: diverged or not at rest): " + ", ".join(
            f"{t['dt_over_dx']:g}{'' if t['stable'] and t['at_rest'] else ' x'}" for t in e["pyelastica"]["trials"]))
    lines += ["", "columns: z-r = mean centreline height at rest minus r (negative: penetration); impact = deepest "
              "penetration of any node in the samples (every 5 ms, so not the peak) [% of r]; "
              "resid v = largest node speed at the end [m/s]; "
              "slide = centre-of-mass travel vs v0^2/(2 mu g); decel = fitted deceleration vs mu g; creep = "
              "centre-of-mass speed over the last 0.2 s [m/s]", "",
              f"goals (rest shapes within {GOALS['rest_shape_max_diff_pct_L']:g} % of L of PyElastica's):"]
    lines += [f"  {k:<50}{'-' if v is None else ('ok' if v else 'MISS')}" for k, v in result["goals_met"].items()]
    lines.append(f"median of {s['reps']} run(s) each after a warm-up; numba 1 thread; load average (1, 5, 15 min) "
                 f"at start {s['load_average_start']}, at end {s['load_average_end']}; elapsed {s['elapsed_s']:.0f} s")
    contended = [f"{name}/{label}" for name, e in result["variants"].items()
                 for label, r in [*e["softrnn"].items(), ("pyelastica", e["pyelastica"])]
                 if r.get("cpu_fraction", 1.0) < 0.9]
    if contended:
        lines.append(f"warning: waited for a core in {', '.join(contended)}: those timings are inflated")
    return "\n".join(lines)


def _jsonable(x):
    if isinstance(x, dict):
        return {k: _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, (np.floating, np.integer, np.bool_)):
        return x.item()
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", metavar="PATH", default=None, help="write the results as JSON to PATH")
    parser.add_argument("--quick", action="store_true", help="one repetition instead of three")
    parser.add_argument("--integrators", choices=INTEGRATORS, nargs="+", default=list(INTEGRATORS),
                        help="softrnn's integrators, each at its automatic step (default: both)")
    parser.add_argument("--only", nargs="+", choices=[v.name for v in VARIANTS], default=None,
                        help="run only these variants")
    args = parser.parse_args(argv)
    try:
        import elastica  # noqa: F401
    except ImportError:
        print("vs_pyelastica_contact: PyElastica is not installed (pip install -e '.[pyelastica]'); nothing to "
              "compare", file=sys.stderr)
        return 2
    from softrnn.files import atomic_write_text

    variants = VARIANTS if args.only is None else tuple(v for v in VARIANTS if v.name in args.only)
    result = run_benchmark(quick=args.quick, integrators=tuple(args.integrators), variants=variants,
                           progress=lambda msg: print(f"[{msg}]", file=sys.stderr, flush=True))
    print(format_table(result))
    if args.json:
        atomic_write_text(args.json, json.dumps(_jsonable(result), indent=2) + "\n")
        print(f"wrote {args.json}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
