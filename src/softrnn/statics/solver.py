"""Static Cosserat rod solver (paper appendix): RK4 forward integration of (p, q, n, m) with N steps
and Levenberg-Marquardt shooting on the unknown base wrench [n(0), m(0)] until the free-tip
wrench is below the tolerance E, i.e. |[n(L) - n_L^d, m(L) - m_L^d]|_2 <= E (paper Sec. 5.2).

``solve(rod, loads)`` is one solve; ``StaticSolver(rod)`` keeps the last converged base wrench and
the shooting Jacobian to warm-start the next solve (a control loop with slowly changing loads).
Every result carries a ``Status``; only ``CONVERGED`` results meet the tolerance.

Tendons driven by a displacement q (``Tendon.displacement``, series stiffness k) have unknown
tensions: an outer semi-smooth Newton iteration on them, around the shooting, solves
tau = k max(0, q - (l_0 - l(tau))) with l the tendon's path length in the solution
(``kernels.tendon_lengths``) and l_0 = L_e sqrt(1 + (|rho| 2 pi / pitch)^2) its length on the
straight, stress-free rod. Its Jacobian is that of the solved equilibrium (the implicit function
theorem on the integration at the converged base wrench: 7 + m integrations, no shooting), and it
stops when every tension matches its displacement to within what the shooting tolerance resolves.
"""

import math

import numpy as np

from ..errors import bad, integer
from ..rod.so3 import matrix_to_quaternion
from . import kernels
from .grid import Grid, build_grid
from .rod import StaticLoads, StaticRod, _arc_length, shown
from .solution import NO_TENSIONS, StaticSolution, Status, outcome_message

DEFAULT_N_STEPS = 40
DEFAULT_TOL = 1e-6
DEFAULT_MAX_ITER = 100

_NO_LOADS = StaticLoads()
_TENSION_MAX_ITER = 50  # Newton updates of the tensions of tendons driven by a displacement


def _check_tol(tol) -> float:
    if isinstance(tol, bool) or not isinstance(tol, (int, float, np.floating)) or not math.isfinite(tol) or tol <= 0:
        raise bad("tol", tol, "a positive tolerance E on the tip wrench residual [N, N m]")
    return float(tol)


class StaticSolver:
    """Solves the static BVP of one ``StaticRod`` repeatedly, warm-starting each solve from the
    last converged one (its base wrench and shooting Jacobian).

    Parameters
    ----------
    rod : StaticRod
        the rod whose BVP it solves
    n_steps : int
        RK4 steps N along the rod (at least one per interval between load points)
    tol : float
        tolerance E on the tip wrench residual norm [N, N m] (see ``solve``)
    max_iter : int
        Levenberg-Marquardt iterations per shooting (per load step when a cold solve applies the
        loads in steps)
    """

    def __init__(self, rod: StaticRod, *, n_steps: int = DEFAULT_N_STEPS, tol: float = DEFAULT_TOL,
                 max_iter: int = DEFAULT_MAX_ITER):
        if not isinstance(rod, StaticRod):
            raise bad("rod", type(rod).__name__, "a StaticRod (softrnn.statics.StaticRod)")
        self.rod = rod
        self.n_steps = integer("n_steps", n_steps)
        self.tol = _check_tol(tol)
        self.max_iter = integer("max_iter", max_iter)
        self._layouts: dict[tuple, tuple] = {}
        self.grid = self._grid(())  # checks n_steps against the rod's own load points
        EI = rod.stiffness().EI
        L = rod.length
        self._scale = np.array([EI / L**2] * 3 + [EI / L] * 3)
        self._base = np.concatenate([rod.base_position, matrix_to_quaternion(rod.base_rotation)])
        self._gravity = np.array(rod.gravity)
        self._mu = np.array([m.moment_body for m in rod.magnets], dtype=float).reshape(-1, 3)
        self._B = np.zeros((len(rod.magnets), 3))
        self._G = np.zeros((len(rod.magnets), 3, 3))
        self._distributed = np.zeros(3)
        self._tension = np.zeros(len(rod.tendons))
        self._tendon_geom = np.array([[*td.offset, td.twist_rate] for td in rod.tendons], dtype=float).reshape(-1, 3)
        # tendons driven by a displacement: their indices, stiffness [N/m], displacements [m]
        self._moved = np.array([j for j, td in enumerate(rod.tendons) if td.displacement_controlled], dtype=np.int64)
        self._stiffness = np.array([rod.tendons[j].stiffness for j in self._moved], dtype=float)
        self._displacement = np.zeros(self._moved.size)
        # the tendons' lengths on the straight, stress-free rod: |e3 + rho'| = sqrt(1 + (rate |rho|)^2)
        self._rest = np.array([rod.tendon_end(td) * math.sqrt(1.0 + (td.twist_rate * math.hypot(*td.offset)) ** 2)
                               for td in rod.tendons], dtype=float)
        self._warm_xi: np.ndarray | None = None
        self._warm_jac: np.ndarray | None = None
        self._warm_tau: np.ndarray | None = None

    def reset(self) -> None:
        """Forget the warm start: the next solve starts cold."""
        self._warm_xi = None
        self._warm_jac = None
        self._warm_tau = None

    @property
    def warm(self) -> bool:
        """True when the next solve without a guess is warm-started."""
        return self._warm_xi is not None

    def _grid(self, load_points: tuple) -> Grid:
        return self._layout(load_points)[0]

    def _layout(self, load_points: tuple) -> tuple[Grid, np.ndarray, np.ndarray, np.ndarray]:
        """Grid, magnet grid points (M,), a point-load buffer (N + 1, 6) and the tendons'
        termination grid points (m,) for these load points."""
        layout = self._layouts.get(load_points)
        if layout is None:
            if len(self._layouts) > 64:
                self._layouts.clear()
            grid = build_grid(self.rod, load_points, self.n_steps)
            mag_node = np.array([grid.index(m.s) for m in self.rod.magnets], dtype=np.int64)
            tendon_end = np.array([grid.index(self.rod.tendon_end(td)) for td in self.rod.tendons], dtype=np.int64)
            layout = (grid, mag_node, np.zeros((grid.s.size, 6)), tendon_end)
            self._layouts[load_points] = layout
        return layout

    def _fill(self, name: str, value: np.ndarray | None, out: np.ndarray) -> None:
        if value is None:
            out[:] = 0.0
        elif value.shape[0] == out.shape[0] or (value.shape[0] == 1 and out.shape[0] > 0):
            out[:] = value
        else:
            M = out.shape[0]
            raise bad(f"{name}.shape", value.shape, f"({', '.join(map(str, (M,) + out.shape[1:]))}): one entry per "
                                                    f"magnet of the rod ({M} magnet{'s' if M != 1 else ''})")

    def _kernel_inputs(self, loads: StaticLoads):
        """Grid and the kernel's argument tuples for ``loads`` (reused buffers: valid until the next
        call)."""
        if loads.point_loads:
            L = self.rod.length
            points = tuple(_arc_length(f"point_loads[{i}].s", p.s, L, "a point load")
                           for i, p in enumerate(loads.point_loads))
            grid, mag_node, jumps, tendon_end = self._layout(points)
            jumps[:] = 0.0
            for p in loads.point_loads:
                a = grid.index(p.s)
                jumps[a, :3] += p.force
                jumps[a, 3:] += p.torque
        else:
            grid, mag_node, jumps, tendon_end = self._layout(())
        self._fill("magnetic_field", loads.magnetic_field, self._B)
        self._fill("field_gradient", loads.field_gradient, self._G)
        self._distributed[:] = loads.distributed_force
        self._fill_tensions(loads)
        return grid, (grid.h, grid.kinv, grid.weight, jumps), (mag_node, self._mu, self._B, self._G), \
            (self._gravity, self._distributed, 1.0, (self._tension, self._tendon_geom, tendon_end))

    def _fill_tensions(self, loads: StaticLoads) -> None:
        """The tendons' tensions [N] of a solve: ``loads.tendon_tensions`` or their own at t = 0
        (0 for the tendons driven by a displacement: the solve finds theirs), and the displacements
        [m] of those: ``loads.tendon_displacements`` or their own at t = 0."""
        tendons = self.rod.tendons
        m = len(tendons)
        if loads.tendon_tensions is None:
            self._tension[:] = [0.0 if td.displacement_controlled else td.tensions(np.zeros(1))[0] for td in tendons]
        elif len(loads.tendon_tensions) == m:
            self._tension[:] = loads.tendon_tensions
            self._tension[self._moved] = 0.0
        else:
            raise bad("tendon_tensions", loads.tendon_tensions,
                      f"{m} tension{'s' if m != 1 else ''} in N, one per tendon of the rod")
        if loads.tendon_displacements is None:
            self._displacement[:] = [tendons[j].displacements(np.zeros(1))[0] for j in self._moved]
        elif len(loads.tendon_displacements) == m:
            self._displacement[:] = np.array(loads.tendon_displacements)[self._moved]
        else:
            raise bad("tendon_displacements", loads.tendon_displacements,
                      f"{m} displacement{'s' if m != 1 else ''} in m, one per tendon of the rod")

    def _tendon_bend(self) -> float:
        """Bending measure sum tau |offset| L / EI of the tendons of the last ``_kernel_inputs``."""
        return float(sum(tau * math.hypot(*td.offset) for tau, td in zip(self._tension, self.rod.tendons))
                     * self.rod.length / self.rod.stiffness().EI)

    def _rigid_moments(self, grid: Grid, arrays) -> tuple[np.ndarray, np.ndarray]:
        """Total external force (3,) [N] and the internal moment (N + 1, 3) [N m] at the grid points
        (base side) of the undeformed straight rod under all loads: the exact statics of a rod
        that does not deform."""
        (h, _, weight, jumps), (mag_node, mu, B, G), (gravity, distributed, *_) = arrays
        R0 = self.rod.base_rotation
        arm = grid.s[:, None] * R0[:, 2]  # undeformed positions relative to the base (N + 1, 3)
        F = jumps[:, :3].copy()  # point forces, torques and their positions
        T = jumps[:, 3:].copy()
        for j, a in enumerate(mag_node):
            mu_w = R0 @ mu[j]
            F[a] += G[j] @ mu_w
            T[a] += np.cross(mu_w, B[j])
        F_steps = (weight[:, None] * gravity + distributed) * h[:, None]  # step resultants at mid-steps
        mid = 0.5 * (arm[1:] + arm[:-1])
        # moment about grid point a of everything at or beyond it: sum r x F - r_a x sum F + sum T
        rF = np.cross(arm, F) + T
        rF[:-1] += np.cross(mid, F_steps)
        Fsum = F.copy()
        Fsum[:-1] += F_steps
        rF_tail = np.cumsum(rF[::-1], axis=0)[::-1]
        F_tail = np.cumsum(Fsum[::-1], axis=0)[::-1]
        return F_tail[0], rF_tail - np.cross(arm, F_tail)

    def rigid_guess(self, loads: StaticLoads | None = None) -> np.ndarray:
        """Base wrench (6,) [N, N m] that balances all loads on the undeformed straight rod: the
        exact answer for vanishing deflection, the cold-start guess."""
        grid, *arrays = self._kernel_inputs(_NO_LOADS if loads is None else loads)
        force, moment = self._rigid_moments(grid, arrays)
        return np.concatenate([force, moment[0]])

    def solve(self, loads: StaticLoads | None = None, *, guess=None) -> StaticSolution:
        """Solve for the equilibrium under ``loads`` (None: the rod's weight only).

        guess : None, (6,) base wrench [N, N m] or a StaticSolution. An explicit guess is used as
        given, with a fresh finite-difference Jacobian, and its outcome is returned as it is. None
        warm-starts from the last converged solve (base wrench and Jacobian); without one, or if
        the warm start fails, the solve starts cold: from the rigid-rod balance (``rigid_guess``)
        when the loads bend the rod by at most ~2 rad, else (or if that fails) by continuation,
        applying the loads in steps from zero so that the stable branch of large deflections is
        followed.

        With tendons driven by a displacement, their tensions are unknowns too: an outer Newton
        iteration on them around these solves (module docstring), from the last solve's tensions
        when warm; the solution reports them (``StaticSolution.tendon_tensions``).
        """
        loads = _NO_LOADS if loads is None else loads
        if not isinstance(loads, StaticLoads):
            raise bad("loads", type(loads).__name__, "a StaticLoads (softrnn.statics.StaticLoads) or None")
        grid, *arrays = self._kernel_inputs(loads)
        xi = None if guess is None else _guess_array(guess)
        if self._moved.size:
            return self._solve_tensions(grid, arrays, xi).solution()
        return self._shoot(grid, arrays, xi).solution()

    def _shoot(self, grid: Grid, arrays, xi: np.ndarray | None) -> "_Run":
        """One solve with the tensions in ``self._tension`` (see ``solve``): from the guess ``xi``
        (6,) as given, else warm, else cold."""
        run = _Run(self, grid, arrays)
        if xi is not None:
            run.shoot(xi.copy(), None, 1.0)
        elif self._warm_xi is not None and run.shoot(self._warm_xi.copy(), self._warm_jac, 1.0):
            pass
        else:
            with np.errstate(over="ignore", invalid="ignore"):  # absurd loads: the kernel reports NOT_FINITE
                force, moments = self._rigid_moments(grid, arrays)
                bend = float(np.linalg.norm(moments, axis=1).max()) * self.rod.length / self.rod.stiffness().EI
                bend += self._tendon_bend()
            direct = bend <= _DIRECT_BEND or not math.isfinite(bend)
            if not (direct and run.shoot(np.concatenate([force, moments[0]]), None, 1.0)) and math.isfinite(bend):
                run.continuation(bend)
        if run.status is Status.CONVERGED:
            self._warm_xi = run.xi.copy()
            if run.jacobian is not None:
                self._warm_jac = run.jacobian.copy()
        return run

    # ------------------------------------------------------------------ tendons driven by a displacement
    def _lengths(self, grid: Grid, arrays, xi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Tip residual (6,) and the tendons' path lengths (m,) [m] of one integration from the base
        wrench xi (6,) with the tensions in ``self._tension``."""
        grid_arrays, mags, loads = arrays
        r = np.empty(6)
        lengths = np.empty(len(self.rod.tendons))
        # writable, as every other caller's: a read-only xi would compile the kernel a second time
        kernels.tendon_lengths(np.require(xi, np.float64, ["C", "W"]), self._base, grid_arrays, mags, loads, r, lengths)
        return r, lengths

    def _compliance(self, grid: Grid, arrays) -> np.ndarray:
        """The linear estimate (m_d, m_d) [m/N] of d(l_0 - l_i)/d tau_j between the tendons driven by a
        displacement on the straight rod: the integral of rho_i . rho_j / EI + 1 / EA over both."""
        end = arrays[2][3][2]
        mid = 0.5 * (grid.s[1:] + grid.s[:-1])
        rho = [self.rod.tendons[j].offsets_at(mid) for j in self._moved]
        C = np.zeros((self._moved.size, self._moved.size))
        for a, i in enumerate(self._moved):
            for b, j in enumerate(self._moved):
                steps = slice(0, min(end[i], end[j]))
                bend = (rho[a][steps, 0] * rho[b][steps, 0] * grid.kinv[steps, 0]
                        + rho[a][steps, 1] * rho[b][steps, 1] * grid.kinv[steps, 1])
                C[a, b] = np.sum(grid.h[steps] * (bend + grid.kinv[steps, 5]))
        return C

    def _cold_tensions(self, grid: Grid, arrays) -> np.ndarray:
        """The tensions (m_d,) [N] of the linear estimate tau = k max(0, q - C tau) (active set)."""
        C = self._compliance(grid, arrays)
        k, q = self._stiffness, self._displacement
        active = q > 0
        tau = np.zeros(k.size)
        for _ in range(k.size + 1):
            tau[:] = 0.0
            if active.any():
                A = np.diag(1.0 / k[active]) + C[np.ix_(active, active)]
                tau[active] = np.linalg.solve(A, q[active])
            pull = q - C @ tau
            changed = (active & (tau < 0)) | (~active & (pull > 0))
            if not changed.any():
                break
            active = (active & (tau >= 0)) | (~active & (pull > 0))
        return np.maximum(tau, 0.0)

    def _shortening_jacobian(self, grid: Grid, arrays, xi: np.ndarray, lengths: np.ndarray) -> np.ndarray:
        """d(l_0 - l)/d tau (m_d, m_d) [m/N] of the solved equilibrium at the converged base wrench xi:
        forward differences of one integration each, the base wrench following the tensions
        through the shooting's Jacobian (implicit function theorem)."""
        moved = self._moved
        r0, _ = self._lengths(grid, arrays, xi)
        dr_dxi = np.empty((6, 6))
        dl_dxi = np.empty((moved.size, 6))
        for i in range(6):
            step = 1e-7 * max(abs(xi[i]), self._scale[i])
            xt = xi.copy()
            xt[i] += step
            r, lengths_t = self._lengths(grid, arrays, xt)
            dr_dxi[:, i] = (r - r0) / step
            dl_dxi[:, i] = (lengths_t[moved] - lengths[moved]) / step
        dr_dtau = np.empty((6, moved.size))
        dl_dtau = np.empty((moved.size, moved.size))
        EI = self.rod.stiffness().EI
        for b, j in enumerate(moved):
            tau = self._tension[j]
            arm = max(math.hypot(*self.rod.tendons[j].offset), self.rod.radius)
            step = 1e-7 * max(tau, EI / (self.rod.length * arm))
            self._tension[j] = tau + step
            r, lengths_t = self._lengths(grid, arrays, xi)
            self._tension[j] = tau
            dr_dtau[:, b] = (r - r0) / step
            dl_dtau[:, b] = (lengths_t[moved] - lengths[moved]) / step
        try:
            dl = dl_dtau - dl_dxi @ np.linalg.solve(dr_dxi, dr_dtau)
        except np.linalg.LinAlgError:
            dl = dl_dtau
        return -dl

    def _solve_tensions(self, grid: Grid, arrays, xi: np.ndarray | None) -> "_Run":
        """Solve with the tensions of the tendons driven by a displacement as unknowns: semi-smooth
        Newton on phi(tau) = tau / k - max(0, q - (l_0 - l(tau))) [m], each evaluation a solve."""
        moved, k, q = self._moved, self._stiffness, self._displacement
        rest = self._rest[moved]
        L = self.rod.length
        stiffness = self.rod.stiffness()
        offsets = np.array([math.hypot(*self.rod.tendons[j].offset) for j in moved])
        # what the shooting tolerance resolves of a tendon's length, and of its tension
        slack = self.tol * (1.0 / k + L * (offsets / stiffness.EI + 1.0 / stiffness.EA)) + 1e-13 * L
        if self._warm_tau is not None and xi is None:
            tau = self._warm_tau.copy()
        else:
            tau = self._cold_tensions(grid, arrays)
        iterations = integrations = 0
        phi_norm = math.inf
        step = None
        run = None
        for update in range(_TENSION_MAX_ITER + 1):
            self._tension[moved] = tau
            run = self._shoot(grid, arrays, xi if update == 0 else None)
            iterations += run.iterations
            integrations += run.integrations
            if run.status is not Status.CONVERGED:
                break
            _, lengths = self._lengths(grid, arrays, run.xi)
            shortening = rest - lengths[moved]
            phi = tau / k - np.maximum(q - shortening, 0.0)
            norm = float(np.max(np.abs(phi) / slack)) if phi.size else 0.0
            if norm <= 1.0:
                plural = "s" if update != 1 else ""
                run.note += f" (tendon tensions matched to the displacements after {update} update{plural})"
                self._warm_tau = tau.copy()
                break
            if step is not None and norm > phi_norm and update < _TENSION_MAX_ITER:
                # the full Newton step made things worse: go back half-way
                step *= 0.5
                tau = np.maximum(tau - step, 0.0)
                continue
            if update == _TENSION_MAX_ITER:
                run.status = Status.ITERATION_LIMIT
                run.note += (f" (but the tendon tensions did not match the displacements in {_TENSION_MAX_ITER} "
                             f"updates: largest mismatch {float(np.max(np.abs(phi) * k)):.3g} N; apply the "
                             "displacements in smaller steps)")
                break
            phi_norm = norm
            D = self._shortening_jacobian(grid, arrays, run.xi, lengths)
            integrations += 7 + moved.size
            active = (q - shortening) > 0
            J = np.diag(1.0 / k) + active[:, None] * D
            try:
                delta = -np.linalg.solve(J, phi)
            except np.linalg.LinAlgError:
                delta = -k * phi
            new = np.maximum(tau + delta, 0.0)
            step = new - tau
            tau = new
        run.iterations, run.integrations = iterations, integrations
        return run


_DIRECT_BEND = 2.0      # rigid-rod bending measure max|m| L / EI up to which a cold solve starts directly
_STAGE_BEND = 1.0       # bending measure per continuation stage
_MAX_STAGES = 256


class _Run:
    """Book-keeping of one ``StaticSolver.solve``: shooting attempts and their totals."""

    def __init__(self, solver: StaticSolver, grid: Grid, arrays):
        self.solver = solver
        self.grid = grid
        self.grid_arrays, self.mags, (self.gravity, self.distributed, _, self.tendons) = arrays
        self.loads = (self.gravity, self.distributed, 1.0, self.tendons)
        self.Y = np.empty((grid.s.size, 13))
        self.status = Status.NOT_FINITE
        self.xi = np.zeros(6)
        self.jacobian = None
        self.iterations = self.integrations = 0
        self.residual = math.inf
        self.note = ""

    def shoot(self, xi: np.ndarray, jacobian: np.ndarray | None, scale: float) -> bool:
        """One Levenberg-Marquardt shooting from xi (6,) with the loads times ``scale``."""
        s = self.solver
        jac = np.empty((6, 6)) if jacobian is None else jacobian.copy()
        info = np.zeros(4)
        code = kernels.shoot(xi, s._scale, jac, jacobian is not None, s.tol, s.max_iter, s._base, self.grid_arrays,
                             self.mags, (self.gravity, self.distributed, scale, self.tendons), self.Y, info)
        self.status = Status(code)
        self.xi = xi
        self.iterations += int(info[kernels.INFO_ITERATIONS])
        self.integrations += int(info[kernels.INFO_INTEGRATIONS])
        self.residual = float(info[kernels.INFO_RESIDUAL])
        if jacobian is not None or info[kernels.INFO_JACOBIANS] > 0:
            self.jacobian = jac
        return self.status is Status.CONVERGED

    def continuation(self, bend: float) -> None:
        """Apply the loads in stages t = 1/K, ..., 1 (K from the bending measure), each stage
        starting from the secant extrapolation of the previous two and their Jacobian."""
        stages = int(min(max(2, math.ceil(bend / _STAGE_BEND)), _MAX_STAGES))
        previous, current = np.zeros(6), np.zeros(6)
        self.jacobian = None
        for k in range(1, stages + 1):
            guess = 2.0 * current - previous
            if not self.shoot(guess, self.jacobian, k / stages):
                self.note = f" (stopped at load fraction {k}/{stages} of a stepwise loading)"
                return
            previous, current = current, self.xi.copy()
        self.note = f" (loads applied in {stages} steps)"

    def solution(self) -> StaticSolution:
        s = self.solver
        Y, xi = self.Y, self.xi
        Y.setflags(write=False)
        xi.setflags(write=False)
        message = outcome_message(self.status, self.residual, s.tol, self.iterations, s.max_iter) + self.note
        tensions, shortening = NO_TENSIONS, NO_TENSIONS
        if s.rod.tendons:
            tensions = s._tension.copy()
            with np.errstate(over="ignore", invalid="ignore"):
                shortening = s._rest - s._lengths(self.grid, (self.grid_arrays, self.mags, self.loads), xi)[1]
            tensions.setflags(write=False)
            shortening.setflags(write=False)
        return StaticSolution(status=self.status, message=message, iterations=self.iterations,
                              residual=self.residual, tol=s.tol, integrations=self.integrations, s=self.grid.s,
                              positions=Y[:, 0:3], quaternions=Y[:, 3:7], n=Y[:, 7:10], m=Y[:, 10:13],
                              base_wrench=xi, tendon_tensions=tensions, tendon_shortening=shortening)


def _guess_array(guess) -> np.ndarray:
    if isinstance(guess, StaticSolution):
        return guess.base_wrench.copy()
    try:
        xi = np.array(guess, dtype=float)
    except (TypeError, ValueError):
        raise bad("guess", shown(guess), "a base wrench (6,) [N, N m] or a StaticSolution") from None
    if xi.shape != (6,) or not np.isfinite(xi).all():
        raise bad("guess", shown(guess), "a finite base wrench of shape (6,) [n(0) in N, m(0) in N m]")
    return xi


def solve(rod: StaticRod, loads: StaticLoads | None = None, *, tol: float = DEFAULT_TOL,
          n_steps: int = DEFAULT_N_STEPS, guess=None, max_iter: int = DEFAULT_MAX_ITER) -> StaticSolution:
    """Solve the static BVP of ``rod`` under ``loads`` once (see ``StaticSolver.solve``; the method and
    the choice of ``tol``: docs/guide/statics.md).

    Parameters
    ----------
    rod, loads : StaticRod, StaticLoads or None
        the rod; its point and distributed loads, the field at its magnets, its tendons' tensions
    tol, n_steps : float, int
        tolerance E on |[n(L+), m(L+)]|_2 [N, N m]; RK4 steps N
    guess : None, (6,) or StaticSolution
        base wrench [n(0), m(0)] to start from (None: rigid-rod balance)
    max_iter : int
        Levenberg-Marquardt iterations

    Returns
    -------
    StaticSolution
        the solution with a ``status``; call ``raise_for_status()`` to turn a failure into an error.
    """
    return StaticSolver(rod, n_steps=n_steps, tol=tol, max_iter=max_iter).solve(loads, guess=guess)
