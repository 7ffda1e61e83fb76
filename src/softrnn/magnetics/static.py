"""The static Cosserat model of the magnetic manipulator: the rod of a ``ManipulatorSpec`` in the
static solver of ``softrnn.statics`` (``static_rod``), and the magnets' orientations it predicts from
the coil currents (``static_predictions``: B and G at the magnets by fixed-point iteration on their
positions; paper Sec. 5).

For each sample the field B and gradient G at the magnets depend on where the magnets are, and
where they are depends on B and G: starting from the previous sample's positions (the straight
rod for the first), B and G are evaluated at the magnets, the static BVP is solved (warm-started
``StaticSolver``) and repeated with the new positions until they move less than
``position_tol`` [m] (about 5 iterations: the field changes little over the magnets' motion).

A solve that does not converge is retried once from a cold start; a sample whose solve or fixed
point still fails is recorded in ``failures`` (NaN in the arrays, never a silent value). More
than ``max_failures`` (a fraction of the samples) failing raises ``SimulationError``.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from ..errors import SimulationError, bad, integer, is_finite_number, positive
from ..progress import Progress
from ..statics import PointMagnet, RigidSegment, StaticLoads, StaticRod, StaticSolver, Status
from .camera import rotation_vectors
from .coils import unit_field_maps
from .magnets import default_magnets
from .manipulator import ManipulatorSpec


@dataclass(frozen=True, eq=False)
class StaticPrediction:
    """The static Cosserat model's predictions for T samples and M magnets.

    Attributes
    ----------
    orientations : (T, M, 3) [rad]
        rotation vectors of the magnets' tangents (NaN where the solve failed)
    positions : (T, M, 3) [m]
        magnet centres (NaN where failed)
    converged : (T,) bool
        whether each sample's solve converged
    solves : (T,) int
        static solves per sample (the fixed-point iterations)
    failures : tuple
        (sample, message) for every failed sample
    seconds : float
        wall time of all solves (Python calls included)
    """

    orientations: np.ndarray
    positions: np.ndarray
    converged: np.ndarray
    solves: np.ndarray
    failures: tuple
    seconds: float

    @property
    def solves_per_second(self) -> float:
        """Static solves per second of wall time (inf for no time)."""
        return float(self.solves.sum()) / self.seconds if self.seconds > 0 else math.inf

    @property
    def predictions_per_second(self) -> float:
        """Samples (predictions, failed ones included) per second of wall time (inf for no time)."""
        return float(self.converged.size) / self.seconds if self.seconds > 0 else math.inf


def static_rod(spec: ManipulatorSpec | None = None) -> StaticRod:
    """The static Cosserat model of the manipulator ``spec`` (None: ``ManipulatorSpec()``): its rod
    clamped at ``spec.base`` along +x, each magnet a rigid segment of its own material over its
    length (its density the section's mean: the block plus the surrounding rod material) and a point
    dipole at its centre. ``spec`` must keep the nominal rod material and the default magnets (2 mm
    cubes at L/2 and L - 1 mm): the static model is the nominal one, the perturbation is the robot's."""
    spec = ManipulatorSpec() if spec is None else spec
    nominal = ManipulatorSpec()
    if len(spec.magnets) != len(nominal.magnets) or any(
            abs(m.arc_length - d.arc_length) > 1e-9 or any(abs(a - b) > 1e-12 for a, b in zip(m.size, d.size))
            for m, d in zip(spec.magnets, default_magnets(spec.length))):
        raise bad("spec.magnets", [(m.arc_length, m.size) for m in spec.magnets],
                  "the default magnets (2 mm cubes at L/2 and L - 1 mm) that the static model builds")
    if abs(spec.youngs_modulus - nominal.youngs_modulus) > 1e-9 * nominal.youngs_modulus \
            or abs(spec.density - nominal.density) > 1e-9 * nominal.density:
        raise bad("spec", "a modified rod material", "the nominal PMC-770 (E 2.5 MPa, rho 1000 kg/m^3) of the "
                                                     "static model; scale only the real robot")
    r = spec.diameter / 2
    area = math.pi * r * r
    segments = []
    for m in spec.magnets:
        section_volume = area * m.length
        density = (m.density * m.volume + spec.density * max(section_volume - m.volume, 0.0)) / section_volume
        segments.append(RigidSegment(s0=m.arc_length - m.length / 2, s1=m.arc_length + m.length / 2,
                                     youngs_modulus=m.youngs_modulus, density=density,
                                     poisson_ratio=m.poisson_ratio))
    magnets = tuple(PointMagnet(s=m.arc_length, moment_body=tuple(m.moment_body)) for m in spec.magnets)
    return StaticRod(length=spec.length, radius=r, youngs_modulus=spec.youngs_modulus, density=spec.density,
                     poisson_ratio=spec.poisson_ratio, gravity=spec.gravity, rigid_segments=tuple(segments),
                     magnets=magnets, base_position=spec.base)


def static_predictions(currents, *, spec: ManipulatorSpec | None = None, n_steps: int = 40, tol: float = 1e-7,
                       position_tol: float = 1e-7, max_iterations: int = 30, max_failures: float = 0.05,
                       progress: Progress | None = None) -> StaticPrediction:
    """The static Cosserat model's magnet orientations for each sample of coil currents (the fixed
    point on the magnets' positions and the failure rules: the module docstring).

    Parameters
    ----------
    currents : (T, n_c) [A]
        Coil currents, within the coil limit.
    spec : ManipulatorSpec or None
        The nominal manipulator (default ``ManipulatorSpec()``); see ``static_rod``.
    n_steps, tol :
        RK4 steps N and tolerance E of the static solver.
    position_tol, max_iterations : float, int
        Fixed-point tolerance [m] and iterations per sample.
    max_failures : float
        Largest tolerated fraction of failed samples (more raise ``SimulationError``).
    progress : softrnn.progress.Progress or None
        Called as ``progress(done, total, info)`` every 10 samples (None: no reports).
    """
    spec = ManipulatorSpec() if spec is None else spec
    I = spec.coils.check_currents(currents)
    if I.ndim != 2:
        raise bad("currents.shape", I.shape, f"(T, {spec.coils.n_coils}): one row of coil currents per sample")
    positive("position_tol", position_tol, "m")
    if not is_finite_number(max_failures) or not 0.0 <= max_failures <= 1.0:
        raise bad("max_failures", max_failures, "a fraction of the samples in [0, 1]")
    integer("max_iterations", max_iterations, 1)
    rod = static_rod(spec)
    solver = StaticSolver(rod, n_steps=n_steps, tol=tol)
    T, M = I.shape[0], len(rod.magnets)
    rest = np.asarray(rod.base_position) + np.array([m.s for m in rod.magnets])[:, None] * rod.base_rotation[:, 2]
    out_r = np.full((T, M, 3), np.nan)
    out_p = np.full((T, M, 3), np.nan)
    converged = np.zeros(T, bool)
    solves = np.zeros(T, np.int64)
    failures = []
    p = rest.copy()
    t0 = time.perf_counter()
    for k in range(T):
        sol, idx, p, solves[k], why = _fixed_point(solver, rod, spec.coils, I[k], p, position_tol=position_tol,
                                                   max_iterations=max_iterations)
        if why:
            failures.append((k, why))
            p = rest.copy()
            solver.reset()
        else:
            converged[k] = True
            out_p[k] = p
            out_r[k] = rotation_vectors(sol.rotations[idx][:, :, 2])
        if progress is not None and (k % 10 == 9 or k == T - 1):
            progress(k + 1, T, {"stage": "static"})
    seconds = time.perf_counter() - t0
    _check_failures(failures, T, max_failures)
    return StaticPrediction(orientations=out_r, positions=out_p, converged=converged, solves=solves,
                            failures=tuple(failures), seconds=seconds)


def _solve(solver, loads) -> tuple:
    """(solution, solves): one warm-started static solve, retried once from a cold start if it fails."""
    sol = solver.solve(loads)
    if sol.status is Status.CONVERGED:
        return sol, 1
    solver.reset()
    return solver.solve(loads), 2


def _fixed_point(solver, rod, coils, currents, p, *, position_tol: float, max_iterations: int) -> tuple:
    """One sample's fixed point between the static solve and the field at the magnets.

    ``currents`` (n_c,) [A]; ``p`` (M, 3) [m] the magnets' starting positions. Returns (solution,
    the magnets' node indices, their positions (M, 3) [m], solves, why), with ``why`` empty on
    success and the reason of the failure otherwise.
    """
    sol, idx, solves = None, [], 0
    for _ in range(max_iterations):
        beta, grad = unit_field_maps(coils, p)                                     # (M, 3, n), (M, n, 3, 3)
        loads = StaticLoads(magnetic_field=beta @ currents,
                            field_gradient=np.einsum("mnij,n->mij", grad, currents))
        sol, n = _solve(solver, loads)
        solves += n
        if sol.status is not Status.CONVERGED:
            return sol, idx, p, solves, f"static solve {sol.status.name.lower()}: {sol.message}"
        idx = [sol.index(m.s) for m in rod.magnets]
        new = np.array(sol.positions[idx])
        moved = float(np.max(np.linalg.norm(new - p, axis=1)))
        p = new
        if moved <= position_tol:
            return sol, idx, p, solves, ""
    return sol, idx, p, solves, (f"the magnets' positions did not settle in {max_iterations} fixed-point iterations "
                                 f"(last move {moved:.3g} m > position_tol {position_tol:g} m)")


def _check_failures(failures: list, n_samples: int, max_failures: float) -> None:
    """Raise ``SimulationError`` when more than ``max_failures`` of the samples failed."""
    if len(failures) > max_failures * n_samples:
        k, why = failures[0]
        raise SimulationError(f"the static Cosserat model failed on {len(failures)} of {n_samples} samples "
                              f"({100 * len(failures) / n_samples:.1f} % > max {100 * max_failures:g} %); first at "
                              f"sample {k}: {why}")
