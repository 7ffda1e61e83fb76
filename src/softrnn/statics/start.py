"""Static starts for dynamic runs: the static equilibrium of a dynamic ``softrnn.rod.Setup`` as its
initial shape, frames included.

``static_solution`` turns the setup into the static problem of ``softrnn.statics`` (its rod, with the
loads, gravity (constant or a time function) and tendons evaluated at one time, clamped at the pose
the dynamic clamp holds) and solves it on an RK4 grid that has a grid point on every node of the
dynamic rod;
``static_start`` samples that solution at the nodes: positions and rotations (the static solution's
frames, twist included, not frames rebuilt from the chords).

What the static solver models, and so what a setup may hold: a cantilever clamped at node 0 (its
clamp fixed or following a prescribed pose, taken at the given time), a straight, untwisted
stress-free reference of the rod's length, a uniform rod (no ``NodeOverride``), nodal forces and
torques in the world frame or in the body frame (follower loads, solved by Newton's method on the
world-frame loads they amount to), gravity, and tendons pulled with a tension or by a displacement. Anything
else (pins, more than one clamp or a clamp elsewhere, PD tracking loads, a curved or closed
reference) is refused with a one-line ``SoftrnnInputError`` that names it.

The dynamic rod is a discretisation of the same continuum: started from the static shape at rest,
it moves only by the discretisation's difference from the continuum equilibrium (a small fraction
of the rod's length at tens of nodes, shrinking with the node spacing squared).
"""

import dataclasses

import numpy as np

from ..errors import SimulationError, SoftrnnInputError, bad, finite, integer
from ..rod.boundary import Clamp
from ..rod.loads import NodalLoad, gravity_at
from ..rod.shapes import RodShape
from ..rod.simulation import Setup
from .rod import PointLoad, StaticLoads, StaticRod
from .solver import DEFAULT_MAX_ITER, StaticSolution, StaticSolver

DEFAULT_STEPS_PER_SEGMENT = 4
"""RK4 steps of the static solve per segment of the dynamic rod."""

RELATIVE_TOL = 1e-10
"""The default tolerance on the tip wrench, relative to min(EI / L^2, EI / L) [N, N m]."""

FOLLOWER_ITERATIONS = 30
"""Newton iterations at most on the world-frame directions of the body-frame loads."""

FOLLOWER_TOL = 1e-9
"""Body-frame loads are settled when their world-frame directions match the solution's frames
within this [rad] (relative load mismatch)."""

_STRAIGHT_TOL = 1e-9  # relative: the reference is straight, untwisted and of the rod's length


def _check_boundary(setup: Setup) -> Clamp:
    """The setup's one clamp, at node 0; a one-line error for any other boundary."""
    n = setup.rod.n_nodes
    for bc in setup.boundary:
        if not isinstance(bc, Clamp):
            raise bad("boundary", f"a pin at node {setup.node_index(bc.node)}",
                      "a cantilever clamped at node 0 and nothing else for a static start (the static solver "
                      "has no pins); give the initial shape explicitly instead")
    clamps = [bc for bc in setup.boundary if isinstance(bc, Clamp)]
    if len(clamps) != 1 or setup.node_index(clamps[0].node) != 0:
        nodes = [setup.node_index(bc.node) for bc in clamps]
        raise bad("boundary", f"clamps at nodes {nodes}" if nodes else "no clamp",
                  "exactly one clamp, at node 0, for a static start (the static solver models a cantilever "
                  f"clamped at its base; a rod of {n} nodes clamped elsewhere, twice or not at all is not "
                  "supported); give the initial shape explicitly instead")
    return clamps[0]


def _check_rod(setup: Setup) -> None:
    """A uniform rod whose reference is straight, untwisted and of the rod's length."""
    spec, ref = setup.rod, setup.reference
    if spec.overrides:
        raise bad("rod.overrides", f"{len(spec.overrides)} node override(s)",
                  "a uniform rod for a static start (node overrides are not modelled by it); give the initial "
                  "shape explicitly instead")
    if spec.sections:
        raise bad("rod.sections", f"{len(spec.sections)} material sections",
                  "a rod of one material for a static start (the static solver's rod is uniform); give the "
                  "initial shape explicitly instead")
    L, n = spec.length, spec.n_nodes
    R0 = ref.rotations[0]
    straight = ref.positions[0] + np.linspace(0.0, L, n)[:, None] * R0[:, 2]
    if (np.abs(ref.rotations - R0).max() > _STRAIGHT_TOL
            or np.abs(ref.positions - straight).max() > _STRAIGHT_TOL * L):
        raise bad("reference", "a curved, twisted or resized reference shape",
                  f"a straight, untwisted reference of the rod's length {L:g} m for a static start (the static "
                  "solver's rod is straight when stress-free); give the initial shape explicitly instead")


def _at(fn, time: float, what: str) -> np.ndarray:
    value = np.asarray(fn(np.array([time])), dtype=float)
    if value.shape != (1, 3) or not np.isfinite(value).all():
        raise bad(what, f"a profile giving {value.tolist()} at t = {time:g} s", "a finite 3-vector at that time")
    return value[0]


def _nodal_loads(setup: Setup, time: float) -> tuple[list, list]:
    """World-frame point loads, and body-frame ones (s, force (3,), torque (3,)) to turn into the
    world with the solution's frames; loads on the clamped node 0 are taken by the clamp."""
    L, n = setup.rod.length, setup.rod.n_nodes
    world, body = [], []
    for load in setup.loads:
        if not isinstance(load, NodalLoad):
            raise bad("loads", f"a PD tracking load on node {setup.node_index(load.node)}",
                      "nodal forces and torques only for a static start (a PD tracking force depends on the "
                      "motion); give the initial shape explicitly instead")
        a = setup.node_index(load.node, "load node")
        if a == 0:
            continue
        zero = np.zeros(3)
        force = zero if load.force is None else _at(load.force, time, f"load on node {a} force")
        torque = zero if load.torque is None else _at(load.torque, time, f"load on node {a} torque")
        s = L * a / (n - 1)
        if load.frame == "world":
            world.append(PointLoad(s=s, force=tuple(force), torque=tuple(torque)))
        else:
            body.append((a, s, force, torque))
    return world, body


def _clamp_pose(setup: Setup, clamp: Clamp, time: float) -> tuple[np.ndarray, np.ndarray]:
    """The pose (position (3,) [m], rotation (3, 3)) the clamp holds at ``time``."""
    if clamp.motion is None:
        return setup.initial.positions[0], setup.initial.rotations[0]
    pos, rot = clamp.motion(np.array([time]))
    return np.asarray(pos, dtype=float)[0], np.asarray(rot, dtype=float)[0]


def static_problem(setup: Setup, time: float = 0.0) -> tuple[StaticRod, StaticLoads, tuple]:
    """The static problem of ``setup`` with its loads, tendons and clamp pose at ``time`` [s].

    Returns
    -------
    rod : StaticRod
        The setup's rod (material, section, gravity, tendons terminated at their nodes' arc
        lengths) clamped at the clamp's pose.
    loads : StaticLoads
        The world-frame nodal loads as point loads at their nodes' arc lengths, and the tendons'
        tensions and displacements at ``time``.
    body_loads : tuple
        The body-frame (follower) nodal loads as (node, s [m], force (3,) [N], torque (3,) [N m])
        with components in the node's frame d1, d2, d3 (``static_solution`` solves them).

    Raises
    ------
    SoftrnnInputError
        One line naming what the static solver does not model (see the module docstring).
    """
    if not isinstance(setup, Setup):
        raise bad("setup", type(setup).__name__, "a softrnn.rod.Setup")
    time = finite("time", time, "s")
    clamp = _check_boundary(setup)
    _check_rod(setup)
    spec, n = setup.rod, setup.rod.n_nodes
    l = spec.segment_length
    world, body = _nodal_loads(setup, time)
    position, rotation = _clamp_pose(setup, clamp, time)
    gravity = gravity_at(setup.gravity, time)
    tendons = tuple(dataclasses.replace(td, end_node=None, end_s=spec.length * td.end_index(n, l) / (n - 1))
                    for td in setup.tendons)
    overrides = {}
    if spec.shear_modulus is not None:
        G, r = spec.shear, spec.radius
        overrides = dict(torsional_stiffness=G * np.pi * r**4 / 2.0,
                         shear_stiffness=spec.shear_coefficient * G * np.pi * r**2)
    rod = StaticRod(length=spec.length, radius=spec.radius, youngs_modulus=spec.youngs_modulus,
                    density=spec.density, poisson_ratio=spec.poisson_ratio,
                    shear_coefficient=spec.shear_coefficient, gravity=tuple(gravity),
                    base_position=tuple(position), base_rotation=rotation, tendons=tendons, **overrides)
    t = np.array([time])
    tensions = tuple(0.0 if td.displacement_controlled else float(td.tensions(t)[0]) for td in setup.tendons)
    moved = tuple(float(td.displacements(t)[0]) if td.displacement_controlled else 0.0 for td in setup.tendons)
    loads = StaticLoads(point_loads=tuple(world), tendon_tensions=tensions, tendon_displacements=moved)
    return rod, loads, tuple(body)


def _solve_once(solver: StaticSolver, loads: StaticLoads, extra: list) -> StaticSolution:
    sol = solver.solve(dataclasses.replace(loads, point_loads=tuple(extra) + loads.point_loads))
    if not sol.converged:
        raise SimulationError(f"static start: the static solve did not converge ({sol.message})")
    return sol


class _Followers:
    """The body-frame loads as world-frame point loads x (m, 6) (force [N], torque [N m]) that must
    equal the body loads turned by the frames of the solution they produce: G(x) = R(x) b - x = 0."""

    def __init__(self, solver: StaticSolver, loads: StaticLoads, grid: list, body: tuple):
        self.solver, self.loads, self.grid, self.body = solver, loads, grid, body
        self.b = np.array([np.concatenate([f, m]) for _, _, f, m in body]).reshape(-1, 6)
        self.s = [s for _, s, _, _ in body]

    def solve(self, x: np.ndarray) -> StaticSolution:
        extra = [PointLoad(s=s, force=tuple(w[:3]), torque=tuple(w[3:])) for s, w in zip(self.s, x)]
        return _solve_once(self.solver, self.loads, self.grid + extra)

    def residual(self, x: np.ndarray) -> tuple[np.ndarray, StaticSolution]:
        sol = self.solve(x)
        R = sol.rotations[[sol.index(s) for s in self.s]]
        turned = np.concatenate([R @ self.b[:, :3, None], R @ self.b[:, 3:, None]], axis=1)[..., 0]
        return turned - x, sol

    def newton(self, frames: np.ndarray) -> StaticSolution:
        """Newton's method on G with a forward-difference Jacobian (6 m solves, warm-started) and
        step halving, from the loads turned by ``frames`` (m, 3, 3)."""
        x = np.concatenate([frames @ self.b[:, :3, None], frames @ self.b[:, 3:, None]], axis=1)[..., 0]
        scale = np.maximum(np.linalg.norm(self.b[:, :3], axis=1), np.linalg.norm(self.b[:, 3:], axis=1))
        g, sol = self.residual(x)
        size = x.size
        for _ in range(FOLLOWER_ITERATIONS):
            angle = float((np.abs(g).max(axis=1) / np.maximum(scale, 1e-300)).max())
            if angle <= FOLLOWER_TOL:
                return sol
            J = np.empty((size, size))
            for i in range(size):
                step = 1e-7 * max(abs(x.flat[i]), scale[i // 6])
                xt = x.copy()
                xt.flat[i] += step
                J[:, i] = ((self.residual(xt)[0] - g) / step).reshape(-1)
            dx = np.linalg.lstsq(J, -g.reshape(-1), rcond=None)[0].reshape(x.shape)
            for _ in range(8):
                gt, st = self.residual(x + dx)
                if np.abs(gt).max() < np.abs(g).max():
                    break
                dx = 0.5 * dx
            x, g, sol = x + dx, gt, st
        raise SimulationError(f"static start: the body-frame loads did not settle in {FOLLOWER_ITERATIONS} Newton "
                              f"iterations (their directions still off by {angle:.2g} rad); give them in the world "
                              "frame or start from a smaller load")


def static_solution(setup: Setup, time: float = 0.0, *, steps_per_segment: int = DEFAULT_STEPS_PER_SEGMENT,
                    tol: float | None = None, max_iter: int = DEFAULT_MAX_ITER) -> StaticSolution:
    """The static equilibrium of ``setup`` under its loads at ``time`` [s] (``static_problem``),
    solved with ``steps_per_segment`` RK4 steps per segment of the dynamic rod, so that every node's
    arc length s_a = a L / (n - 1) is a grid point (``StaticSolution.index(s_a)``).

    ``tol`` is the tip wrench tolerance [N, N m] (None: ``RELATIVE_TOL`` times
    min(EI / L^2, EI / L)); ``max_iter`` the Levenberg-Marquardt iterations per shooting. Body-frame
    loads are world-frame point loads whose directions follow the solution's frames: Newton's method
    on them (finite-difference Jacobian) until they are turned by the frames within
    ``FOLLOWER_TOL`` [rad] (at most ``FOLLOWER_ITERATIONS`` iterations).

    Raises ``SoftrnnInputError`` for a setup the static solver does not model and
    ``SimulationError`` (one line) when the solve or the follower iteration does not converge.
    """
    rod, loads, body = static_problem(setup, time)
    k = integer("steps_per_segment", steps_per_segment)
    L, n = rod.length, setup.rod.n_nodes
    stiffness = rod.stiffness().EI
    tol = RELATIVE_TOL * min(stiffness / L**2, stiffness / L) if tol is None else tol
    solver = StaticSolver(rod, n_steps=k * (n - 1), tol=tol, max_iter=max_iter)
    grid = [PointLoad(s=L * a / (n - 1)) for a in range(1, n - 1)]  # zero loads: grid points on the nodes
    if not body:
        return _solve_once(solver, loads, grid)
    frames = np.broadcast_to(rod.base_rotation, (len(body), 3, 3))
    return _Followers(solver, loads, grid, body).newton(frames)


def static_start(setup: Setup, time: float = 0.0, *, steps_per_segment: int = DEFAULT_STEPS_PER_SEGMENT,
                 tol: float | None = None, max_iter: int = DEFAULT_MAX_ITER) -> RodShape:
    """The static equilibrium of ``setup`` at its n nodes, as an initial shape for a dynamic run.

    Solves ``static_solution(setup, time, ...)`` and samples it at the nodes' arc lengths
    s_a = a L / (n - 1): positions (n, 3) [m] and rotations (n, 3, 3) (columns d1, d2, d3, body ->
    world) from the static solution's frames, so twist and the clamp's frame are kept. Use it as
    ``dataclasses.replace(setup, initial=static_start(setup))``; the run then starts at rest on the
    equilibrium of the loads at ``time`` [s] (the clamp held where it is at ``time``).

    Raises ``SoftrnnInputError`` (one line) for a setup the static solver does not model: pins, a
    clamp other than one at node 0, PD tracking loads, node overrides, a curved, twisted or closed
    reference; ``SimulationError`` when the static solve does not converge.
    """
    sol = static_solution(setup, time, steps_per_segment=steps_per_segment, tol=tol, max_iter=max_iter)
    n, L = setup.rod.n_nodes, setup.rod.length
    s = L * np.arange(n) / (n - 1)
    idx = np.array([sol.index(x) for x in s])
    if np.abs(sol.s[idx] - s).max() > 1e-9 * L:  # pragma: no cover - the grid has the nodes as breakpoints
        raise SoftrnnInputError("static start: the static grid misses a node; report this as a bug")
    return RodShape(np.array(sol.positions[idx]), np.array(sol.rotations[idx]))
