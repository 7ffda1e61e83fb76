"""The stiff-stable integrator: the LGVI step with the rod's elastic and Kelvin-Voigt forces taken
implicitly (``RunConfig(integrator="implicit")``).

Why. The explicit step of ``rod.kernels`` is bounded by the rod's fastest modes: shear (about
sqrt(4 G / (rho r^2))), extension and the rotary-inertia bending and twist modes (about 2 c / l with
c = sqrt(E / rho)), and by Kelvin-Voigt damping (2 / (omega_max^2 tau)). None of them shrinks with
fewer nodes, so a steel wire needs picosecond steps. Here the step is a choice of accuracy.

The step (docs/guide/simulator.md, "Stiff rods"; docs/lgvi.md §8). The state, the staggered
velocities and the per-node update are those of ``advance_into``: per node an explicit translation
and a 3-unknown Newton solve of the Cayley rotation, with the force F and body torque t of the
configuration q^k. Two terms are added to (F, t) before the node update:

    F_imp = -beta h K (u^{k+1} - u^k) - tau_d K u^{k+1}

where u = (v world, omega body) per node (6 n values), K (6n x 6n) is the material tangent
stiffness of the internal forces at q^k (K = sum over segments of B^T C B / l, with B the 6 x 12
linearised strain map of the segment below, C = diag(C1, C2)), beta = ``IMPLICIT_BETA`` and tau_d
the Kelvin-Voigt retardation time (its explicit strain-rate term is then left out). u^{k+1} comes
from one linear solve, block tridiagonal with 6 x 6 blocks along the rod (O(n)):

    (M + h c + (beta h^2 + h tau_d) K) u^{k+1} = M u^k + h F(q^k) + beta h^2 K u^k

(M the node masses and body inertias, c the viscous drag). Prescribed velocities of clamped and
pinned nodes enter as known values. For a linear rod this is Newmark's average-acceleration family
in central-difference form: no numerical dissipation, second order, stable at any step for
beta >= 1/4. beta = 1/2 leaves a margin of 2 on the stiffness: the parts of the true tangent that K
leaves out (the geometric stiffness of the stress, the curvature terms of the strain map) need only
stay below 4 M / h^2 + K, so the step is bounded by the loads' geometric stiffness (a string of
tension N: h < 2 sqrt(m l / N)), never by E or G. Tendon springs, PD gains and applied loads stay
explicit; so do the contact loads (``rod.contact``), unless ``Contact(implicit=True)``: then the
normal spring of a node in an obstacle's wall acts on its end-of-step gap, its normal force
-k (g + h u_n^{k+1}) - c u_n^{k+1} (unclamped; g the gap at q^k, n the normal): its explicit part
-k (g + h u_n^k) - c u_n^k joins F, the tangent S = sum (h^2 k + h c) n n^T its translational block
(and S u^k the right-hand side), and -S (u^{k+1} - u^k) / h F_imp, so that the penalty stiffness no
longer bounds the step (friction and self-contact stay explicit). Contact is also predictive: a
node outside every wall at q^k whose end-of-step gap g + h u_n^{k+1} (g, n of the obstacle it nears
most) is negative gets the force -k (g + h u_n^{k+1}) along n (its tangent h^2 k n n^T in the block,
-h k g n on the right-hand side; no damper, which would push before the wall is reached). The set
of such nodes starts with g + h u_n^k < 0 and is corrected from the solution until no node changes
(at most ``CONTACT_SOLVES`` solves), so that no force acts at a positive end-of-step gap
(docs/guide/simulator.md, "Stiff rods", Contact).

The linearised strain map of segment a (nodes a, a + 1; frame of node a; body rotation
increments eps_a, eps_{a+1}; p = R_a^T (r_{a+1} - r_a), Q = R_a^T R_{a+1}, x = cay^-1(Q),
D = dcay^-1(x) = I - x^/2 + x x^T / 4, X = I - x^/2):

    l d kappa = D (Q eps_{a+1} - eps_a)
    l d gamma = X (R_a^T (dr_{a+1} - dr_a) + p x eps_a) + p x (l d kappa) / 2

the exact derivative of the SE(3)-Cayley strains of ``_segment`` (kappa l = x, gamma l = p - x x p / 2).

Caching: numba checks a cached function against its own source file only; the functions here
compile the kernel modules' helpers into themselves, so they are built as closures over
``rod.kernel_records.kernel_stamp()``, a hash of those files (as ``rod.kernels`` does): an edit of
any of them recompiles them.
"""

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from .contact_kernels import _contact_loads_tangent_if_any
from .kernel_records import _segment_offset, kernel_stamp
from .kernels import (
    CLAMPED,
    FREE,
    MAGNET_TOO_CLOSE,
    OK,
    _applied_loads,
    _applied_outputs_if_any,
    _contact_loads_if_any,
    _magnet_loads_if_any,
    _node,
    _quaternion_into,
    _segment,
    _tendon_springs,
)

IMPLICIT_BETA = 0.5
"""Weight of the implicit stiffness (Newmark beta, >= 1/4; see the module docstring)."""

IMPLICIT_THETA = 1.0
CONTACT_SOLVES = 4
"""Most linear solves of one step with predictive contact (each after the set of nodes predicted
to reach a wall changed)."""
CONTACT_COLUMNS = 12
"""Columns of ``ImplicitWork.contact_tangent`` per node (see there)."""
SINGULAR = 3
"""Status: the linear system of a step was singular (a rod without mass or stiffness)."""
HALF_KICK = -1
"""``n_steps`` of ``advance_implicit_into`` that asks for the start at rest (the half kick) instead of steps."""


class ImplicitWork(NamedTuple):
    """Scratch arrays of the implicit step (n nodes), allocated once per run by ``work_arrays``.

    Attributes
    ----------
    applied : (n, 6)
        applied world force [N] and world torque [N m] per node
    force : (n, 6)
        total explicit force (world) [N] and body torque [N m] per node
    strain_map : (n-1, 6, 12)
        the linearised strain map B of each segment [-], [m]
    diag : (n, 6, 6)
        diagonal blocks of the system, then of its factorisation
    upper : (n-1, 6, 6)
        blocks coupling node a (rows) to node a + 1 (columns); then X_a
    rhs : (n, 6)
        right-hand side, then the forward-eliminated one
    u : (n, 6)
        the new velocities u^{k+1} (v world [m/s], omega body [rad/s])
    known : (n, 6)
        prescribed velocities of constrained degrees of freedom
    fixed : (n, 6) int64
        1 where the degree of freedom is prescribed
    pivot : (6, 7)
        scratch of the 6 x 6 solves
    weighted : (6, 12)
        scratch: a segment's strain map scaled by its stiffness
    contact_tangent : (n, 12) or (0, 12)
        with linearly implicit contact (``Contact.implicit``), per node its contact tangent
        S = (h^2 k + h c) n n^T [kg] (S00, S11, S22, S01, S02, S12), then for predictive
        contact the gap g [m] and unit normal n of the obstacle it nears most (not in its wall; g = 1,
        n = 0: none), that node's k [N/m], and 1.0 where the predictive spring is in the solve (else
        0.0); empty: explicit contact
    """

    applied: np.ndarray
    force: np.ndarray
    strain_map: np.ndarray
    diag: np.ndarray
    upper: np.ndarray
    rhs: np.ndarray
    u: np.ndarray
    known: np.ndarray
    fixed: np.ndarray
    pivot: np.ndarray
    weighted: np.ndarray
    contact_tangent: np.ndarray


def work_arrays(n: int, implicit_contact: bool = False) -> ImplicitWork:
    """Zeroed ``ImplicitWork`` for a rod of n nodes; ``implicit_contact``: with a contact tangent
    per node (linearly implicit contact)."""
    return ImplicitWork(np.zeros((n, 6)), np.zeros((n, 6)), np.zeros((max(n - 1, 0), 6, 12)),
                        np.zeros((n, 6, 6)), np.zeros((max(n - 1, 0), 6, 6)), np.zeros((n, 6)),
                        np.zeros((n, 6)), np.zeros((n, 6)), np.zeros((n, 6), dtype=np.int64), np.zeros((6, 7)),
                        np.zeros((6, 12)), np.zeros((n if implicit_contact else 0, CONTACT_COLUMNS)))


_INLINE = dict(fastmath={"contract"}, error_model="numpy", no_cpython_wrapper=True, no_cfunc_wrapper=True,
               forceinline=True, _nrt=False, no_rewrites=True)


@njit(**_INLINE)
def _strain_map(a, R, r, B):
    """B[a] (6, 12) <- the linearised strain map of segment a (module docstring), times l."""
    Ba = B[a]
    p0, p1, p2 = _segment_offset(a, R, r)
    # Q = R_a^T R_{a+1} into B[a][3:6, 9:12] for now; x = cay^-1(Q)
    for i in range(3):
        for j in range(3):
            Ba[3 + i, 9 + j] = R[a, 0, i] * R[a + 1, 0, j] + R[a, 1, i] * R[a + 1, 1, j] + R[a, 2, i] * R[a + 1, 2, j]
    s = 2.0 / (1.0 + Ba[3, 9] + Ba[4, 10] + Ba[5, 11])
    x0 = s * (Ba[5, 10] - Ba[4, 11])
    x1 = s * (Ba[3, 11] - Ba[5, 9])
    x2 = s * (Ba[4, 9] - Ba[3, 10])
    # D = dcay^-1(x) = I - x^/2 + x x^T / 4 into B[a][3:6, 3:6] (negated below)
    Ba[3, 3] = 1.0 + 0.25 * x0 * x0
    Ba[4, 4] = 1.0 + 0.25 * x1 * x1
    Ba[5, 5] = 1.0 + 0.25 * x2 * x2
    Ba[3, 4] = 0.5 * x2 + 0.25 * x0 * x1
    Ba[4, 3] = -0.5 * x2 + 0.25 * x0 * x1
    Ba[3, 5] = -0.5 * x1 + 0.25 * x0 * x2
    Ba[5, 3] = 0.5 * x1 + 0.25 * x0 * x2
    Ba[4, 5] = 0.5 * x0 + 0.25 * x1 * x2
    Ba[5, 4] = -0.5 * x0 + 0.25 * x1 * x2
    # l d kappa = D Q eps_{a+1} - D eps_a
    for j in range(3):
        q0 = Ba[3, 9 + j]
        q1 = Ba[4, 9 + j]
        q2 = Ba[5, 9 + j]
        Ba[0, 9 + j] = Ba[3, 3] * q0 + Ba[3, 4] * q1 + Ba[3, 5] * q2
        Ba[1, 9 + j] = Ba[4, 3] * q0 + Ba[4, 4] * q1 + Ba[4, 5] * q2
        Ba[2, 9 + j] = Ba[5, 3] * q0 + Ba[5, 4] * q1 + Ba[5, 5] * q2
    for i in range(3):
        for j in range(3):
            Ba[3 + i, 9 + j] = Ba[i, 9 + j]
            Ba[3 + i, 3 + j] = -Ba[3 + i, 3 + j]
            Ba[i, 0 + j] = 0.0
    # l d gamma = X (R_a^T dd + p^ eps_a) + (p^/2) l d kappa, X = I - x^/2
    for j in range(3):
        # columns of X R_a^T: R_a^T e_j - x x (R_a^T e_j) / 2
        c0 = R[a, j, 0]
        c1 = R[a, j, 1]
        c2 = R[a, j, 2]
        Ba[0, 6 + j] = c0 - 0.5 * (x1 * c2 - x2 * c1)
        Ba[1, 6 + j] = c1 - 0.5 * (x2 * c0 - x0 * c2)
        Ba[2, 6 + j] = c2 - 0.5 * (x0 * c1 - x1 * c0)
        Ba[0, j] = -Ba[0, 6 + j]
        Ba[1, j] = -Ba[1, 6 + j]
        Ba[2, j] = -Ba[2, 6 + j]
        # X p^ e_j: e = p x e_j
        e0 = -p2 if j == 1 else (p1 if j == 2 else 0.0)
        e1 = p2 if j == 0 else (-p0 if j == 2 else 0.0)
        e2 = -p1 if j == 0 else (p0 if j == 1 else 0.0)
        # (p^/2) on the kappa rows' columns
        k0 = Ba[3, 3 + j]
        k1 = Ba[4, 3 + j]
        k2 = Ba[5, 3 + j]
        Ba[0, 3 + j] = e0 - 0.5 * (x1 * e2 - x2 * e1) + 0.5 * (p1 * k2 - p2 * k1)
        Ba[1, 3 + j] = e1 - 0.5 * (x2 * e0 - x0 * e2) + 0.5 * (p2 * k0 - p0 * k2)
        Ba[2, 3 + j] = e2 - 0.5 * (x0 * e1 - x1 * e0) + 0.5 * (p0 * k1 - p1 * k0)
        k0 = Ba[3, 9 + j]
        k1 = Ba[4, 9 + j]
        k2 = Ba[5, 9 + j]
        Ba[0, 9 + j] = 0.5 * (p1 * k2 - p2 * k1)
        Ba[1, 9 + j] = 0.5 * (p2 * k0 - p0 * k2)
        Ba[2, 9 + j] = 0.5 * (p0 * k1 - p1 * k0)


@njit(**_INLINE)
def _solve6(A, X, ncol):
    """X[:, :ncol] <- A^-1 X[:, :ncol] for A (6, 6) (destroyed), Gaussian elimination with partial
    pivoting. Returns False if A is singular."""
    for k in range(6):
        piv = k
        big = abs(A[k, k])
        for i in range(k + 1, 6):
            if abs(A[i, k]) > big:
                big = abs(A[i, k])
                piv = i
        if not big > 0.0:
            return False
        if piv != k:
            for j in range(6):
                tmp = A[k, j]
                A[k, j] = A[piv, j]
                A[piv, j] = tmp
            for j in range(ncol):
                tmp = X[k, j]
                X[k, j] = X[piv, j]
                X[piv, j] = tmp
        inv = 1.0 / A[k, k]
        for i in range(k + 1, 6):
            f = A[i, k] * inv
            if f != 0.0:
                for j in range(k + 1, 6):
                    A[i, j] -= f * A[k, j]
                for j in range(ncol):
                    X[i, j] -= f * X[k, j]
    for k in range(5, -1, -1):
        inv = 1.0 / A[k, k]
        for j in range(ncol):
            s = X[k, j]
            for m in range(k + 1, 6):
                s -= A[k, m] * X[m, j]
            X[k, j] = s * inv
    return True


@njit(**_INLINE)
def _known_velocities(i, h, rod, state, inputs, work):
    """work.known and work.fixed <- the prescribed velocities of constrained nodes at step i."""
    R = state.rotations
    r = state.positions
    presc_idx = inputs.presc_idx
    for a in range(len(r)):
        kd = rod.kind[a]
        for c in range(6):
            work.known[a, c] = 0.0
            work.fixed[a, c] = 0
        if kd == FREE:
            continue
        for c in range(3):
            work.fixed[a, c] = 1
            if kd == CLAMPED:
                work.fixed[a, 3 + c] = 1
        jq = len(presc_idx) - 1
        while jq >= 0 and presc_idx[jq] != a:
            jq -= 1
        if jq < 0:
            continue
        for c in range(3):
            work.known[a, c] = (inputs.presc_r[i + 1, jq, c] - r[a, c]) / h
        if kd == CLAMPED:
            tr = 1.0
            sk0 = 0.0
            sk1 = 0.0
            sk2 = 0.0
            P = inputs.presc_R[i + 1, jq]
            for c in range(3):
                tr += R[a, c, 0] * P[c, 0] + R[a, c, 1] * P[c, 1] + R[a, c, 2] * P[c, 2]
                sk0 += R[a, c, 2] * P[c, 1] - R[a, c, 1] * P[c, 2]
                sk1 += R[a, c, 0] * P[c, 2] - R[a, c, 2] * P[c, 0]
                sk2 += R[a, c, 1] * P[c, 0] - R[a, c, 0] * P[c, 1]
            s = 2.0 / (tr * h)
            work.known[a, 3] = s * sk0
            work.known[a, 4] = s * sk1
            work.known[a, 5] = s * sk2


@njit(**_INLINE)
def _assemble(h, beta, theta, tau, rod, state, work):
    """work.diag, work.upper, work.rhs <- the system of the module docstring, with the prescribed
    degrees of freedom (work.fixed) moved to the right-hand side."""
    n = len(state.positions)
    v = state.velocities
    w = state.angular_velocities
    l = rod.length
    B = work.strain_map
    D = work.diag
    U = work.upper
    rhs = work.rhs
    ck = beta * h * h + h * tau
    cu = theta * beta * h * h
    for a in range(n):
        m = rod.mass[a]
        for i in range(6):
            for j in range(6):
                D[a, i, j] = 0.0
        for c in range(3):
            D[a, c, c] = m + h * rod.ct[a]
            D[a, 3 + c, 3 + c] = rod.inertia[a, c] + h * rod.cr[a]
            rhs[a, c] = m * v[a, c] + h * work.force[a, c]
            rhs[a, 3 + c] = rod.inertia[a, c] * w[a, c] + h * work.force[a, 3 + c]
    if len(work.contact_tangent) > 0:
        _add_contact_tangent(n, h, v, work)
    for a in range(n - 1):
        Ba = B[a]
        for k in range(6):
            # beta h^2 K u^k on the right-hand side: B^T (cu C / l) (B u^k)
            ck_k = (rod.C1[a, k] if k < 3 else rod.C2[a, k - 3]) / l
            e = 0.0
            for j in range(3):
                e += (Ba[k, j] * v[a, j] + Ba[k, 3 + j] * w[a, j] + Ba[k, 6 + j] * v[a + 1, j]
                      + Ba[k, 9 + j] * w[a + 1, j])
            e *= cu * ck_k
            for j in range(6):
                rhs[a, j] += Ba[k, j] * e
                rhs[a + 1, j] += Ba[k, 6 + j] * e
        # (beta h^2 + h tau) B^T C B / l, upper triangle of the 12 x 12 block, mirrored
        W = work.weighted
        for k in range(6):
            ck_k = ck * (rod.C1[a, k] if k < 3 else rod.C2[a, k - 3]) / l
            for j in range(12):
                W[k, j] = ck_k * Ba[k, j]
        for i in range(12):
            for j in range(i, 12):
                t = (Ba[0, i] * W[0, j] + Ba[1, i] * W[1, j] + Ba[2, i] * W[2, j] + Ba[3, i] * W[3, j]
                     + Ba[4, i] * W[4, j] + Ba[5, i] * W[5, j])
                if j < 6:
                    D[a, i, j] += t
                    if j != i:
                        D[a, j, i] += t
                elif i >= 6:
                    D[a + 1, i - 6, j - 6] += t
                    if j != i:
                        D[a + 1, j - 6, i - 6] += t
                else:
                    U[a, i, j - 6] = t
    _fix_known(n, work)


@njit(**_INLINE)
def _add_contact_tangent(n, h, v, work):
    """work.diag += S, work.rhs += S v^k: each node's contact tangent S (work.contact_tangent) in its
    translational block (linearly implicit contact; docs/guide/simulator.md, "Stiff rods"); and for
    each predicted contact in the solve, h^2 k n n^T and -h k g n (module docstring)."""
    S = work.contact_tangent
    D = work.diag
    for a in range(n):
        if S[a, 11] != 0.0:
            p = (S[a, 7], S[a, 8], S[a, 9])
            q = h * h * S[a, 10]
            b = h * S[a, 10] * S[a, 6]
            for i in range(3):
                work.rhs[a, i] -= b * p[i]
                for j in range(3):
                    D[a, i, j] += q * p[i] * p[j]
        s00 = S[a, 0]
        s11 = S[a, 1]
        s22 = S[a, 2]
        s01 = S[a, 3]
        s02 = S[a, 4]
        s12 = S[a, 5]
        if s00 == 0.0 and s11 == 0.0 and s22 == 0.0:
            continue
        D[a, 0, 0] += s00
        D[a, 1, 1] += s11
        D[a, 2, 2] += s22
        D[a, 0, 1] += s01
        D[a, 1, 0] += s01
        D[a, 0, 2] += s02
        D[a, 2, 0] += s02
        D[a, 1, 2] += s12
        D[a, 2, 1] += s12
        work.rhs[a, 0] += s00 * v[a, 0] + s01 * v[a, 1] + s02 * v[a, 2]
        work.rhs[a, 1] += s01 * v[a, 0] + s11 * v[a, 1] + s12 * v[a, 2]
        work.rhs[a, 2] += s02 * v[a, 0] + s12 * v[a, 1] + s22 * v[a, 2]


@njit(**_INLINE)
def _fix_known(n, work):
    """Move the prescribed velocities of work.fixed to the right-hand side: identity rows."""
    D = work.diag
    U = work.upper
    rhs = work.rhs
    for a in range(n):
        for c in range(6):
            if work.fixed[a, c] == 0:
                continue
            z = work.known[a, c]
            for i in range(6):
                if i != c:
                    rhs[a, i] -= D[a, i, c] * z
                    D[a, i, c] = 0.0
                    D[a, c, i] = 0.0
                if a > 0:
                    rhs[a - 1, i] -= U[a - 1, i, c] * z
                    U[a - 1, i, c] = 0.0
                if a < n - 1:
                    rhs[a + 1, i] -= U[a, c, i] * z
                    U[a, c, i] = 0.0
            D[a, c, c] = 1.0
            rhs[a, c] = z


@njit(**_INLINE)
def _solve_tridiagonal(n, work):
    """work.u <- the solution of the symmetric block-tridiagonal system in work (block Thomas
    algorithm; work.diag, work.upper and work.rhs are overwritten). Returns False if a pivot block
    is singular."""
    D = work.diag
    U = work.upper
    rhs = work.rhs
    X = work.pivot
    for a in range(n):
        last = a == n - 1
        for i in range(6):
            for j in range(6):
                X[i, j] = 0.0 if last else U[a, i, j]
            X[i, 6] = rhs[a, i]
        # X <- D'_a^-1 [U_a, rhs'_a]
        if not _solve6(D[a], X, 7):
            return False
        if not last:
            # D'_{a+1} = D_{a+1} - U_a^T X_a, rhs'_{a+1} = rhs_{a+1} - U_a^T y_a
            for i in range(6):
                for j in range(7):
                    t = 0.0
                    for k in range(6):
                        t += U[a, k, i] * X[k, j]
                    if j < 6:
                        D[a + 1, i, j] -= t
                    else:
                        rhs[a + 1, i] -= t
            for i in range(6):
                for j in range(6):
                    U[a, i, j] = X[i, j]
        for i in range(6):
            rhs[a, i] = X[i, 6]
    for a in range(n - 1, -1, -1):
        for i in range(6):
            s = rhs[a, i]
            if a < n - 1:
                for k in range(6):
                    s -= U[a, i, k] * work.u[a + 1, k]
            work.u[a, i] = s
    return True


@njit(**_INLINE)
def _explicit_forces(i, row, record, h, beta, rod, state, inputs, out, work):
    """work.force <- the explicit force (world) and body torque of every node at step i, work.strain_map
    <- the segments' strain maps; the samples' positions, loads and quaternions are written when
    ``record``. ``rod.kv_on`` must be False (the Kelvin-Voigt forces are implicit). Returns False
    (a magnet too close to a source: nothing else is done) or True, and the elastic and
    gravitational energies [J]."""
    R = state.rotations
    r = state.positions
    work_f = work.applied
    _applied_loads(i, R, r, state.velocities, inputs, work_f)
    if _magnet_loads_if_any(i, row, record, R, r, inputs, work_f) >= 0:
        return False, 0.0, 0.0
    if len(inputs.tendon_stiffness) > 0:
        _tendon_springs(i, R, r, rod, inputs)
    # contact: with the applied loads (docs/lgvi.md §2.11); its tangent for the solve if implicit. Its
    # h^2 is written (beta h^2) / beta (exact for beta = 1/2): the product beta h^2 is then the one of
    # _assemble's stiffness weight beta h^2 + h tau, which the compiler computes once and so does not
    # fuse into that sum; else the weight rounds otherwise and every run with Kelvin-Voigt damping and
    # explicit contact (contact-capstan) moves in its last bits (tests/rod/test_contact_bits.py).
    if len(work.contact_tangent) > 0:
        _contact_loads_tangent_if_any(row, record, h, R, r, state.velocities, state.angular_velocities, rod,
                                      inputs, out.save_slot, work_f, beta * h * h / beta, work.contact_tangent)
    else:
        _contact_loads_if_any(row, record, h, R, r, state.velocities, state.angular_velocities, rod, inputs,
                              out.save_slot, work_f)
    n = len(r)
    g0 = rod.gravity[0]
    g1 = rod.gravity[1]
    g2 = rod.gravity[2]
    e_el = 0.0
    e_g = 0.0
    np0 = np1 = np2 = tp0 = tp1 = tp2 = 0.0
    for a in range(n):
        n0 = n1 = n2 = T0 = T1 = T2 = q0 = q1 = q2 = 0.0
        if a < n - 1:
            n0, n1, n2, T0, T1, T2, q0, q1, q2, e = _segment(
                a, i, R, r, R[a, 0, 0], R[a, 0, 1], R[a, 0, 2], R[a, 1, 0], R[a, 1, 1], R[a, 1, 2], R[a, 2, 0],
                R[a, 2, 1], R[a, 2, 2], rod, inputs, h, state.prev_curvature, state.prev_shear, record)
            e_el += e
            _strain_map(a, R, r, work.strain_map)
        m = rod.mass[a]
        work.force[a, 0] = n0 - np0 + work_f[a, 0] + m * g0
        work.force[a, 1] = n1 - np1 + work_f[a, 1] + m * g1
        work.force[a, 2] = n2 - np2 + work_f[a, 2] + m * g2
        for c in range(3):
            work.force[a, 3 + c] = R[a, 0, c] * work_f[a, 3] + R[a, 1, c] * work_f[a, 4] + R[a, 2, c] * work_f[a, 5]
        work.force[a, 3] += T0 - tp0
        work.force[a, 4] += T1 - tp1
        work.force[a, 5] += T2 - tp2
        np0 = n0
        np1 = n1
        np2 = n2
        tp0 = q0
        tp1 = q1
        tp2 = q2
        if record:
            e_g -= m * (g0 * r[a, 0] + g1 * r[a, 1] + g2 * r[a, 2])
            slot = out.save_slot[a]
            if slot >= 0:
                for c in range(3):
                    out.positions[row, slot, c] = r[a, c]
                    out.forces[row, slot, c] = work_f[a, c]
                    out.torques[row, slot, c] = work_f[a, 3 + c]
                _quaternion_into(R[a], out.quaternions[row, slot])
    if record:
        _applied_outputs_if_any(row, inputs, out)
    return True, e_el, e_g


@njit(**_INLINE)
def _add_implicit_forces(h, beta, theta, tau, rod, state, work):
    """work.force += F_imp = -beta h K (u - u^k) - tau K u with u = work.u, u^k the state's velocities,
    and the implicit contact's -S (u - u^k) / h (S the contact tangent, translations only) and
    predicted contacts' -k (g + h u_n) n."""
    v = state.velocities
    w = state.angular_velocities
    u = work.u
    B = work.strain_map
    l = rod.length
    for a in range(len(B)):
        Ba = B[a]
        for k in range(6):
            e_new = 0.0
            e_old = 0.0
            for j in range(6):
                e_new += Ba[k, j] * u[a, j] + Ba[k, 6 + j] * u[a + 1, j]
                e_old += (Ba[k, j] * (v[a, j] if j < 3 else w[a, j - 3])
                          + Ba[k, 6 + j] * (v[a + 1, j] if j < 3 else w[a + 1, j - 3]))
            s = (rod.C1[a, k] if k < 3 else rod.C2[a, k - 3]) / l * (beta * h * (e_new - theta * e_old) + tau * e_new)
            for j in range(6):
                work.force[a, j] -= Ba[k, j] * s
                work.force[a + 1, j] -= Ba[k, 6 + j] * s
    S = work.contact_tangent
    for a in range(len(S)):
        d0 = (u[a, 0] - v[a, 0]) / h
        d1 = (u[a, 1] - v[a, 1]) / h
        d2 = (u[a, 2] - v[a, 2]) / h
        work.force[a, 0] -= S[a, 0] * d0 + S[a, 3] * d1 + S[a, 4] * d2
        work.force[a, 1] -= S[a, 3] * d0 + S[a, 1] * d1 + S[a, 5] * d2
        work.force[a, 2] -= S[a, 4] * d0 + S[a, 5] * d1 + S[a, 2] * d2
        if S[a, 11] != 0.0:
            fn = -S[a, 10] * (S[a, 6] + h * (S[a, 7] * u[a, 0] + S[a, 8] * u[a, 1] + S[a, 9] * u[a, 2]))
            for c in range(3):
                work.force[a, c] += fn * S[a, 7 + c]


@njit(**_INLINE)
def _predict_contacts(h, u, work, start):
    """Predictive contact (module docstring): per node with a contact ahead (work.contact_tangent),
    in the solve where its gap at the end of the step, g + h n . u (u (n, 6) the velocities, [m/s]),
    is negative; ``start``: set every node so, else only count the nodes whose state would change
    (and change them). Returns how many changed."""
    S = work.contact_tangent
    changed = 0
    for a in range(len(S)):
        ahead = S[a, 6] + h * (S[a, 7] * u[a, 0] + S[a, 8] * u[a, 1] + S[a, 9] * u[a, 2])
        want = 1.0 if ahead < 0.0 else 0.0
        if start or want != S[a, 11]:
            changed += int(want != S[a, 11])
            S[a, 11] = want
    return changed


@njit(**_INLINE)
def _new_velocities(i, h, beta, theta, tau, rod, state, inputs, work, kick):
    """work.u <- u^{k+1} of step i (prescribed ones included), predicted contacts settled (at most
    ``CONTACT_SOLVES`` solves); ``kick``: the step from rest of the half kick instead (nothing known
    moves, the contacts predicted from rest, one solve). False if the system is singular."""
    _known_velocities(i, h, rod, state, inputs, work)
    if kick:
        for a in range(len(state.positions)):
            for c in range(6):
                work.known[a, c] = 0.0
    if len(work.contact_tangent) == 0:
        _assemble(h, beta, theta, tau, rod, state, work)
        return _solve_tridiagonal(len(state.positions), work)
    _predict_contacts(h, state.velocities, work, True)
    for it in range(CONTACT_SOLVES):
        _assemble(h, beta, theta, tau, rod, state, work)
        if not _solve_tridiagonal(len(state.positions), work):
            return False
        if kick or it == CONTACT_SOLVES - 1 or _predict_contacts(h, work.u, work, False) == 0:
            break
    return True


def _build(stamp):
    """The cached kernel, closed over ``stamp`` (``kernel_stamp()``, see the module docstring)."""

    @njit(fastmath={"contract"}, error_model="numpy", cache=True, no_cfunc_wrapper=True, no_rewrites=True)
    def advance_implicit_into(rod, state, inputs, out, h, k0, n_steps, stride, s0, work, beta, theta, tau):
        """Advance one rod by ``n_steps`` implicit steps of size ``h`` [s]; returns (status, step index).

        As ``rod.kernels.advance_into`` (same records and sample rows), with ``work`` an
        ``ImplicitWork``, ``beta`` the Newmark weight and ``tau`` the Kelvin-Voigt retardation time
        [s]; ``rod.kv_on`` must be False. status is OK, DIVERGED, NEWTON_FAILED, SINGULAR or
        MAGNET_TOO_CLOSE.

        ``n_steps`` = ``HALF_KICK`` (with ``k0`` 0, ``stride`` 1, ``s0`` 0): start the rod at rest to
        second order instead (``rod.state.half_kick`` for this step): the staggered velocities of the
        free degrees of freedom become -u/2, with u the velocities one implicit step from rest would
        reach; the state must be at rest, nothing is recorded. One kernel for both, so that its load
        tree compiles once.
        """
        if stamp < 0:  # never true: references the stamp so that it is a closure variable
            return -1, k0
        n = len(state.positions)
        kick = n_steps == HALF_KICK
        for ii in range(1 if kick else n_steps):
            k = k0 + ii
            record = (k % stride) == 0 and not kick
            row = k // stride - s0
            fine, e_el, e_g = _explicit_forces(ii, row, record, h, beta, rod, state, inputs, out, work)
            if not fine:
                return MAGNET_TOO_CLOSE, k
            if not _new_velocities(ii, h, beta, theta, tau, rod, state, inputs, work, kick):
                return SINGULAR, k
            if kick:
                for a in range(n):
                    for c in range(3):
                        if work.fixed[a, c] == 0:
                            state.velocities[a, c] = -0.5 * work.u[a, c]
                        if work.fixed[a, 3 + c] == 0:
                            state.angular_velocities[a, c] = -0.5 * work.u[a, 3 + c]
                return OK, k0
            _add_implicit_forces(h, beta, theta, tau, rod, state, work)
            e_kin = 0.0
            f = work.force
            for a in range(n):
                status, ek = _node(a, ii, row, record, h, f[a, 0], f[a, 1], f[a, 2], f[a, 3], f[a, 4], f[a, 5],
                                   rod, state, inputs, out)
                if status != OK:
                    return status, k
                e_kin += ek
            if record:
                out.energy[row, 0] = e_kin
                out.energy[row, 1] = e_el
                out.energy[row, 2] = e_g
        return OK, k0 + n_steps

    return advance_implicit_into


advance_implicit_into = _build(kernel_stamp())


def advance(rod, tau, state, inputs, out, h, k0, n_steps, stride, s0, work):
    """``advance_implicit_into`` with ``IMPLICIT_BETA``; returns (status, step index)."""
    return advance_implicit_into(rod, state, inputs, out, h, k0, n_steps, stride, s0, work, IMPLICIT_BETA,
                                 IMPLICIT_THETA, tau)


# ------------------------------------------------------------------ step choice
ACCURACY_MODE = 4
"""``substeps`` = auto resolves the rod's fourth bending mode ..."""
ACCURACY_PHASE = 0.1
"""... with h omega_4 <= this (a phase error of about 1e-3 per period of that mode)."""


def bending_frequency(rod, mode: int = ACCURACY_MODE) -> float:
    """Estimated angular frequency [rad/s] of the ``mode``-th bending mode of the lumped rod ``rod``
    (a ``LumpedRod``): ((mode - 1/2) pi / L)^2 sqrt(EI / (rho A)) with the stiffest EI / (rho A) of
    its segments (a cantilever's modes; free or pinned rods have modes of the same order)."""
    mass = np.asarray(rod.mass)
    weight = np.asarray(rod.weight)
    line_density = mass / (weight * rod.length)
    rho_a = np.minimum(line_density[:-1], line_density[1:])
    ei = np.asarray(rod.C2)[:, :2].max(axis=1)
    length = rod.length * (len(mass) - 1)
    return float(((mode - 0.5) * math.pi / length) ** 2 * math.sqrt(np.max(ei / rho_a)))


def accuracy_step(rod, pd_gain=None, safety: float = 0.5) -> float:
    """The step [s] ``substeps = "auto"`` aims at with the implicit integrator: the fourth bending
    mode resolved (``ACCURACY_PHASE``), and the explicit PD tracking forces stable
    (safety * 2 sqrt(m / kp) at the lightest node)."""
    h = ACCURACY_PHASE / bending_frequency(rod)
    if pd_gain is not None and len(pd_gain):
        m_min = float(np.min(rod.mass))
        h = min(h, safety * 2.0 * math.sqrt(m_min / float(np.max(np.asarray(pd_gain)[:, 0]))))
    return h
