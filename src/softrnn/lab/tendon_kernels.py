"""Numba kernels of the tendon robot's fuller physics (``softrnn.lab.tendon_robot``): gravity,
friction along the routing (capstan) and the tendons' creep, solved row by row along a session.

Each row is a fixed point of the segments' bending vectors b (S, 2) [1/m]: from the current shape,
the capstan factors of every tendon in every segment and the gravity curvature of every segment; then
the tensions (the complementarity problem of the plain model with those factors and the gravity
bending in its matrix and right side, solved exactly on the active set of the previous solution,
corrected one tendon at a time); then the new bending vectors. Passes repeat, Anderson-accelerated
with the previous pass, until b changes by less than ``FIXED_POINT_TOL``, at most
``FIXED_POINT_PASSES`` times; the first pass of a row starts from the previous row's solution. A row
the passes leave unsettled (a heavy weight far from the rows it was calibrated on makes the pass
map expand) is solved by Newton's method on b - G(b) = 0 from that start (``NEWTON_STEPS`` steps,
a finite-difference Jacobian, each step halved until the residual falls); a row that still does not
settle reports its passes negated.

Gravity: the weight per length w along the backbone, in the base frame gravity = (w / k) g_hat
(k the series stiffness), the moment about a point of the backbone is that of everything distal
(masses lumped at the midpoints of ``PIECES`` pieces per segment: the moment of a straight piece is
exact); segment s takes the constant curvature whose small-deflection tip displacement equals that of
the moment along it, u_s = int M(s') (L - s') ds' / (EI_s int (L - s') ds') over the segment (Simpson on
the piece ends; L the backbone's length), which gives Euler-Bernoulli's w L^4 / (8 EI) for a cantilever,
while a tendon's path shortens by the segment's mean gravity curvature int M ds' / (EI_s L_s) (what the
bent rod's path does), so the tensions answer the weight as in the Cosserat rod.

Friction: tendon i's tension in segment s is tau_i exp(-mu d_i phi_s) with phi_s the wrap angle from
the base to the middle of segment s (the bending angles |b| L of the segments before it and half of
its own) and d_i = +1 while the tendon is pulled in (its command grew since the previous row), -1
while released, the last direction kept while the command holds (0 at the session's start).

Play (``play``): friction that sticks. A tendon held by friction along its routing does not pass a
reversal of its servo on to the robot at once: the displacement that reaches the robot, p, stays put
until the servo has moved back by twice the play w, then follows it at the other side of the band,
p_k = min(max(p_{k-1}, q_k - w), q_k + w) (the play or backlash operator, the elementary hysteresis of
Prandtl-Ishlinskii models), p = q at a session's start. w = 0 is no play.

Creep (``creep``): the tendons lengthen slowly under load (the cables' and their anchorages' creep), so
every tendon's slack grows by the same s(t), at a rate proportional to the mean tendon tension,
ds/dt = gamma mean_i(tau_i / k), explicit in time: row k sees the slack that the rows before it left,
s_{k+1} = s_k + gamma mean_i(tau_k,i / k) dt_k. The slack carries over from one session to the next
(creep stays); no creep is counted across the gap between two sessions. gamma = 0 is no creep.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

PIECES = 8
"""Pieces per segment for the gravity moment (even: Simpson's rule on their ends)."""
FIXED_POINT_PASSES = 60
FIXED_POINT_TOL = 1e-9
"""A row's fixed point is reached when no bending vector changes by more than this [1/m]."""
NEWTON_STEPS = 30
"""Newton steps on b - G(b) = 0 for a row the accelerated passes leave unsettled."""
_NEWTON_HALVINGS = 8
"""Most halvings of a Newton step until the residual falls."""
_PGS_ITERATIONS = 200
_PGS_TOL = 1e-13
_PIVOTS = 1000
"""Most pivots of a row's exact tension solve (``_lcp``; a few from the row before's set)."""
_LCP_TOL = 1e-12
"""The tensions' conditions hold to this share of the row's largest right side (rounding)."""
_HOLD = 1e-9
"""A command change under this [m] holds the tendon's friction direction."""


@njit(cache=True)
def _copy1(src, dst):
    """dst (m,) <- src (m,), element by element (an array assignment would compile numba's shape-checked
    copy, whose error message alone takes seconds to compile in every fresh process)."""
    for i in range(src.shape[0]):
        dst[i] = src[i]


@njit(cache=True)
def _copy2(src, dst):
    """dst (m, k) <- src (m, k), element by element (``_copy1``)."""
    for i in range(src.shape[0]):
        for j in range(src.shape[1]):
            dst[i, j] = src[i, j]


@njit(cache=True)
def _arc(bx, by, sigma, R0, p0, R, p):
    """Frame R (3, 3) and position p (3,) at arclength sigma [m] of an arc with bending vector
    (bx, by) [1/m] in the frame R0 (3, 3) at p0 (3,) of its start."""
    kappa = math.hypot(bx, by)
    if kappa < 1e-9:
        dx, dy, lateral, axial, angle = 1.0, 0.0, 0.5 * kappa * sigma * sigma, sigma, 0.0
    else:
        dx, dy = bx / kappa, by / kappa
        angle = kappa * sigma
        lateral, axial = (1.0 - math.cos(angle)) / kappa, math.sin(angle) / kappa
    loc0, loc1, loc2 = dx * lateral, dy * lateral, axial
    for a in range(3):
        p[a] = p0[a] + R0[a, 0] * loc0 + R0[a, 1] * loc1 + R0[a, 2] * loc2
    # rotation about the axis (-dy, dx, 0) by angle (Rodrigues), then R = R0 @ rot
    c, s = math.cos(angle), math.sin(angle)
    ax, ay = -dy, dx
    r00, r01, r02 = c + ax * ax * (1 - c), ax * ay * (1 - c), ay * s
    r10, r11, r12 = ax * ay * (1 - c), c + ay * ay * (1 - c), -ax * s
    r20, r21, r22 = -ay * s, ax * s, c
    for a in range(3):
        R[a, 0] = R0[a, 0] * r00 + R0[a, 1] * r10 + R0[a, 2] * r20
        R[a, 1] = R0[a, 0] * r01 + R0[a, 1] * r11 + R0[a, 2] * r21
        R[a, 2] = R0[a, 0] * r02 + R0[a, 1] * r12 + R0[a, 2] * r22


@njit(cache=True)
def chain_tip(b, L, marker, frames, points, tip):
    """The tip (3,) [m] in the base frame into ``tip``: the chain of constant-curvature arcs of
    bending vectors b (S, 2) [1/m] and lengths L (S,) [m] from the base, plus ``marker`` [m] along
    the last tangent. frames (2, 3, 3) and points (2, 3) are work arrays."""
    R0, R, p0, p = frames[0], frames[1], points[0], points[1]
    R0[:] = 0.0
    for a in range(3):
        R0[a, a] = 1.0
    p0[:] = 0.0
    for s in range(L.size):
        _arc(b[s, 0], b[s, 1], L[s], R0, p0, R, p)
        _copy2(R, R0)
        _copy1(p, p0)
    for a in range(3):
        tip[a] = p0[a] + R0[a, 2] * marker


@njit(cache=True)
def _shape(b, L, frames, nodes, masses, scratch):
    """The backbone of bending vectors b (S, 2): node frames (S, P+1, 3, 3), node positions
    (S, P+1, 3) and piece midpoints (S, P, 3) [m], in the base frame; scratch (4, 3, 3)."""
    S = b.shape[0]
    P = masses.shape[1]
    piece, half, rot = scratch[0], scratch[1], scratch[2]
    eye = np.eye(3)
    origin = np.zeros(3)
    step = np.empty(3)
    mid = np.empty(3)
    for s in range(S):
        h = L[s] / P
        _arc(b[s, 0], b[s, 1], h, eye, origin, piece, step)       # one piece, in its own frame
        _arc(b[s, 0], b[s, 1], 0.5 * h, eye, origin, half, mid)
        if s == 0:
            _copy2(eye, frames[0, 0])
            _copy1(origin, nodes[0, 0])
        else:
            _copy2(frames[s - 1, P], frames[s, 0])
            _copy1(nodes[s - 1, P], nodes[s, 0])
        for k in range(P):
            R = frames[s, k]
            for a in range(3):
                nodes[s, k + 1, a] = nodes[s, k, a] + R[a, 0] * step[0] + R[a, 1] * step[1] + R[a, 2] * step[2]
                masses[s, k, a] = nodes[s, k, a] + R[a, 0] * mid[0] + R[a, 1] * mid[1] + R[a, 2] * mid[2]
                for c in range(3):
                    rot[a, c] = R[a, 0] * piece[0, c] + R[a, 1] * piece[1, c] + R[a, 2] * piece[2, c]
            _copy2(rot, frames[s, k + 1])


@njit(cache=True)
def _gravity_bend(b, L, compliance, gvec, frames, nodes, masses, scratch, out):
    """The gravity curvature of each segment for the shape b (S, 2) and gravity gvec (3,) = (w / k)
    g_hat in the base frame (see the module's docstring): out (2, S, 2) [1/m], the tip-equivalent
    one (the shape's) and the mean (the tendons' paths')."""
    S = b.shape[0]
    P = masses.shape[1]
    _shape(b, L, frames, nodes, masses, scratch)
    total = 0.0
    for s in range(S):
        total += L[s]
    m1 = np.zeros(3)                # distal first moment sum h x
    mass = 0.0                      # distal length
    start = total
    for s in range(S - 1, -1, -1):
        h = L[s] / P
        start -= L[s]
        acc0 = acc1 = weights = mean0 = mean1 = plain = 0.0
        for k in range(P, -1, -1):
            if k < P:
                for a in range(3):
                    m1[a] += h * masses[s, k, a]
                mass += h
            l0 = m1[0] - mass * nodes[s, k, 0]
            l1 = m1[1] - mass * nodes[s, k, 1]
            l2 = m1[2] - mass * nodes[s, k, 2]
            # the moment (lever x gvec) in the node's frame
            mx = l1 * gvec[2] - l2 * gvec[1]
            my = l2 * gvec[0] - l0 * gvec[2]
            mz = l0 * gvec[1] - l1 * gvec[0]
            ux = frames[s, k, 0, 0] * mx + frames[s, k, 1, 0] * my + frames[s, k, 2, 0] * mz
            uy = frames[s, k, 0, 1] * mx + frames[s, k, 1, 1] * my + frames[s, k, 2, 1] * mz
            simpson = 1.0 if k == 0 or k == P else (4.0 if k % 2 == 1 else 2.0)
            w = simpson * (total - start - k * h)
            acc0 += w * uy
            acc1 -= w * ux
            weights += w
            mean0 += simpson * uy
            mean1 -= simpson * ux
            plain += simpson
        out[0, s, 0] = compliance[s] * acc0 / weights
        out[0, s, 1] = compliance[s] * acc1 / weights
        out[1, s, 0] = compliance[s] * mean0 / plain
        out[1, s, 1] = compliance[s] * mean1 / plain


@njit(cache=True)
def _pgs(M, rhs, tau):
    """Projected Gauss-Seidel for tau >= 0, M tau - rhs >= 0, tau (M tau - rhs) = 0 from the
    given tau (n,) [m] (warm start)."""
    n = rhs.size
    for _ in range(_PGS_ITERATIONS):
        change = 0.0
        for i in range(n):
            r = rhs[i]
            for j in range(n):
                if j != i:
                    r -= M[i, j] * tau[j]
            v = r / M[i, i]
            if v < 0.0:
                v = 0.0
            change = max(change, abs(v - tau[i]))
            tau[i] = v
        if change < _PGS_TOL:
            break


@njit(cache=True)
def _solve_active(M, rhs, active, tau, A, idx):
    """tau (n,) = the solution of M_AA tau_A = rhs_A on the active set (others 0), M any matrix, by
    Gaussian elimination with partial pivoting in A (n, n+1) scratch (idx (n,) int scratch); False where
    singular."""
    n = rhs.size
    m = 0
    for i in range(n):
        if active[i]:
            idx[m] = i
            m += 1
    for r in range(m):
        for c in range(m):
            A[r, c] = M[idx[r], idx[c]]
        A[r, m] = rhs[idx[r]]
    for c in range(m):
        p = c
        for r in range(c + 1, m):
            if abs(A[r, c]) > abs(A[p, c]):
                p = r
        if abs(A[p, c]) < 1e-300:
            return False
        if p != c:
            for k in range(c, m + 1):
                A[c, k], A[p, k] = A[p, k], A[c, k]
        for r in range(c + 1, m):
            factor = A[r, c] / A[c, c]
            for k in range(c, m + 1):
                A[r, k] -= factor * A[c, k]
    tau[:] = 0.0
    for r in range(m - 1, -1, -1):
        v = A[r, m]
        for k in range(r + 1, m):
            v -= A[r, k] * tau[idx[k]]
        tau[idx[r]] = v / A[r, r]
    return True


@njit(cache=True)
def _solve_taut(M, rhs, active, tau, A, idx) -> bool:
    """tau (n,) = the solution of M_AA tau_A = rhs_A on the active set (others 0), M positive definite,
    by Cholesky in A (n, n+1) scratch (its factor, then the forward solve in its last column; idx (n,)
    int scratch); False where M_AA is not positive definite in floating point."""
    n = rhs.size
    m = 0
    for i in range(n):
        tau[i] = 0.0
        if active[i]:
            idx[m] = i
            m += 1
    for a in range(m):
        for c in range(a + 1):
            v = M[idx[a], idx[c]]
            for j in range(c):
                v -= A[a, j] * A[c, j]
            if a == c:
                if not v > 0.0:
                    return False
                A[a, a] = math.sqrt(v)
            else:
                A[a, c] = v / A[c, c]
    for a in range(m):
        v = rhs[idx[a]]
        for j in range(a):
            v -= A[a, j] * A[j, n]
        A[a, n] = v / A[a, a]
    for a in range(m - 1, -1, -1):
        v = A[a, n]
        for j in range(a + 1, m):
            v -= A[j, a] * tau[idx[j]]
        tau[idx[a]] = v / A[a, a]
    return True


@njit(cache=True)
def _lcp(M, rhs, tau, active, A, idx):
    """tau >= 0, M tau - rhs >= 0, tau (M tau - rhs) = 0 (M (n, n) a P-matrix: positive definite, or
    with friction I + A F, the capstan factors F making it unsymmetric), exactly: principal pivoting from
    the active set of the warm start tau (n,) [m] (the tendons with tau > 0), each set solved by Cholesky
    where M is symmetric (``_solve_taut``), else by Gaussian elimination with partial pivoting
    (``_solve_active``), the first index that breaks a condition (an active one with tau < 0, an inactive
    one with M tau - rhs < 0; to ``_LCP_TOL`` of the largest |rhs|) flipped until none does (Murty's
    least-index rule: finite for a P-matrix). Projected Gauss-Seidel from zero where a set's matrix is
    singular (not positive definite) in floating point or ``_PIVOTS`` run out. ``active`` (n,) bool, ``A``
    (n, n + 1) and ``idx`` (n,) int: scratch."""
    n = rhs.size
    tol = 0.0
    symmetric = True
    for i in range(n):
        active[i] = tau[i] > 0.0
        tol = max(tol, abs(rhs[i]))
        for j in range(i):
            if M[i, j] != M[j, i]:
                symmetric = False
    tol *= _LCP_TOL
    for _ in range(_PIVOTS):
        solved = _solve_taut(M, rhs, active, tau, A, idx) if symmetric else _solve_active(M, rhs, active, tau, A, idx)
        if not solved:
            break
        flip = -1
        for i in range(n):
            if not math.isfinite(tau[i]):
                flip = -2
                break
            if active[i]:
                if tau[i] < -tol:
                    flip = i
                    break
            else:
                w = -rhs[i]
                for j in range(n):
                    w += M[i, j] * tau[j]
                if w < -tol:
                    flip = i
                    break
        if flip == -1:
            return
        if flip == -2:
            break
        active[flip] = not active[flip]
    for i in range(n):
        tau[i] = 0.0
    _pgs(M, rhs, tau)


@njit(cache=True)
def _factors(b, L, seg, dirs, mu, f):
    """Capstan factors f (n, S): tendon i's tension in segment s over its tension at the base."""
    n, S = f.shape
    wrap = 0.0
    for s in range(S):
        angle = math.hypot(b[s, 0], b[s, 1]) * L[s]
        mid = wrap + 0.5 * angle
        wrap += angle
        for i in range(n):
            f[i, s] = math.exp(-mu * dirs[i] * mid) if seg[i] >= s else 0.0


@njit(cache=True)
def _pass(qk, seg, L, compliance, rho, offsets, mu, gvec, gravity, b, tau, dirs, f, gb, M, rhs, work, out):
    """One pass of a row's fixed point: out (S, 2) [1/m], the bending vectors of the tensions (tau (n,),
    solved in place from its warm start) and gravity for the capstan factors and shape of b (S, 2)."""
    n, S = f.shape
    frames, nodes, masses, scratch = work[0], work[1], work[2], work[3]
    if mu != 0.0:
        _factors(b, L, seg, dirs, mu, f)
    if gravity:
        _gravity_bend(b, L, compliance, gvec, frames, nodes, masses, scratch, gb)
    for i in range(n):
        rhs[i] = qk[i] - offsets[i]
        for s in range(seg[i] + 1):
            rhs[i] -= L[s] * (gb[1, s, 0] * rho[i, 0] + gb[1, s, 1] * rho[i, 1])
        for j in range(n):
            acc = 1.0 if i == j else 0.0
            dot = rho[i, 0] * rho[j, 0] + rho[i, 1] * rho[j, 1]
            for s in range(min(seg[i], seg[j]) + 1):
                acc += L[s] * compliance[s] * f[j, s] * dot
            M[i, j] = acc
    _lcp(M, rhs, tau, work[4], work[5], work[6])
    for s in range(S):
        for a in range(2):
            v = gb[0, s, a]
            for i in range(n):
                if seg[i] >= s:
                    v += compliance[s] * tau[i] * f[i, s] * rho[i, a]
            out[s, a] = v


@njit(cache=True)
def _row(qk, seg, L, compliance, rho, offsets, mu, gvec, gravity, b, tau, dirs, f, gb, M, rhs, work, acc):
    """One row's fixed point b = G(b) (``_pass``), Anderson-accelerated with one previous pass:
    b (S, 2) [1/m] and tau (n,) [m] updated in place from their warm start; acc (3, S, 2) scratch;
    returns the passes taken (with Newton's, ``_newton``, where the accelerated ones do not settle),
    negated where the row did not settle."""
    g, g_prev, r_prev = acc[0], acc[1], acc[2]
    S = b.shape[0]
    start_b, start_tau = b.copy(), tau.copy()
    passes = 0
    for it in range(FIXED_POINT_PASSES):
        passes += 1
        _pass(qk, seg, L, compliance, rho, offsets, mu, gvec, gravity, b, tau, dirs, f, gb, M, rhs, work, g)
        change = 0.0
        num = den = 0.0
        for s in range(S):
            for a in range(2):
                r = g[s, a] - b[s, a]
                change = max(change, abs(r))
                dr = r - r_prev[s, a]
                num += dr * r
                den += dr * dr
        if change < FIXED_POINT_TOL or (not gravity and mu == 0.0):
            _copy2(g, b)
            break
        gamma = num / den if it > 0 and den > 0.0 else 0.0
        for s in range(S):
            for a in range(2):
                r_prev[s, a] = g[s, a] - b[s, a]
                b[s, a] = g[s, a] - gamma * (g[s, a] - g_prev[s, a])
                g_prev[s, a] = g[s, a]
    else:       # unsettled: Newton from the row's start
        _copy2(start_b, b)
        _copy1(start_tau, tau)
        more = _newton(qk, seg, L, compliance, rho, offsets, mu, gvec, gravity, b, tau, dirs, f, gb, M, rhs, work, g)
        return passes + more if more > 0 else more - passes
    return passes


@njit(cache=True)
def _misfit(qk, seg, L, compliance, rho, offsets, mu, gvec, gravity, x, tau, dirs, f, gb, M, rhs, work, g, out):
    """out (2 S,) = G(x) - x for the bending vectors x (S, 2) (one ``_pass``, its result in g); its largest size."""
    _pass(qk, seg, L, compliance, rho, offsets, mu, gvec, gravity, x, tau, dirs, f, gb, M, rhs, work, g)
    worst = 0.0
    for s in range(x.shape[0]):
        for a in range(2):
            out[2 * s + a] = g[s, a] - x[s, a]
            worst = max(worst, abs(out[2 * s + a]))
    return worst


@njit(cache=True)
def _newton(qk, seg, L, compliance, rho, offsets, mu, gvec, gravity, b, tau, dirs, f, gb, M, rhs, work, g):
    """b (S, 2) [1/m] solving b = G(b) by Newton's method from its value (``NEWTON_STEPS`` steps, a
    forward-difference Jacobian, each step halved until the residual's norm falls), tau (n,) with it;
    returns the passes taken, negated where it did not settle."""
    S = b.shape[0]
    m = 2 * S
    F, Fp, step = np.empty(m), np.empty(m), np.empty(m)
    J = np.empty((m, m))
    A = np.empty((m, m + 1))
    every = np.ones(m, dtype=np.bool_)
    order = np.empty(m, dtype=np.int64)
    trial = np.empty_like(b)
    passes = 1
    worst = _misfit(qk, seg, L, compliance, rho, offsets, mu, gvec, gravity, b, tau, dirs, f, gb, M, rhs, work, g, F)
    for _ in range(NEWTON_STEPS):
        if worst < FIXED_POINT_TOL:
            _copy2(g, b)
            return passes
        for j in range(m):
            h = 1e-7 * (1.0 + abs(b[j // 2, j % 2]))
            _copy2(b, trial)
            trial[j // 2, j % 2] += h
            passes += 1
            _misfit(qk, seg, L, compliance, rho, offsets, mu, gvec, gravity, trial, tau, dirs, f, gb, M, rhs, work, g,
                    Fp)
            for i in range(m):
                J[i, j] = (Fp[i] - F[i]) / h
        for i in range(m):
            F[i] = -F[i]
        if not _solve_active(J, F, every, step, A, order):
            break
        norm = 0.0
        for i in range(m):
            norm += F[i] * F[i]
        t = 1.0
        for _ in range(_NEWTON_HALVINGS + 1):
            for j in range(m):
                trial[j // 2, j % 2] = b[j // 2, j % 2] + t * step[j]
            passes += 1
            worst = _misfit(qk, seg, L, compliance, rho, offsets, mu, gvec, gravity, trial, tau, dirs, f, gb, M, rhs,
                            work, g, Fp)
            new = 0.0
            for i in range(m):
                new += Fp[i] * Fp[i]
            if new < norm:
                break
            t *= 0.5
        _copy2(trial, b)
        _copy1(Fp, F)
    if worst < FIXED_POINT_TOL:
        _copy2(g, b)
        return passes
    return -passes


@njit(cache=True)
def play(q, reset, width, out):
    """The play operator of each column (see the module's docstring): q (K, n) [m] the commands,
    reset (K,) bool True where a session starts, width (n,) [m] each column's play w >= 0; writes
    out (K, n) [m], the displacements that reach the robot."""
    K, n = q.shape
    for k in range(K):
        for i in range(n):
            if k == 0 or reset[k]:
                out[k, i] = q[k, i]
            else:
                out[k, i] = min(max(out[k - 1, i], q[k, i] - width[i]), q[k, i] + width[i])


@njit(cache=True)
def _flush(v):
    """v, or 0 where |v| < 1e-200 (no subnormal numbers in the results)."""
    return v if abs(v) >= 1e-200 else 0.0


@njit(cache=True)
def scratch(n: int, S: int) -> tuple:
    """The work arrays of ``_pass`` for n tendons and S segments: the gravity moment's frames, nodes,
    masses and rotations, then the tension solve's active set, matrix and indices (``_lcp``)."""
    P = PIECES
    return (np.empty((S, P + 1, 3, 3)), np.empty((S, P + 1, 3)), np.empty((S, P, 3)), np.empty((3, 3, 3)),
            np.zeros(n, dtype=np.bool_), np.empty((n, n + 1)), np.empty(n, dtype=np.int64))


@njit(cache=True)
def _row_arrays(n: int, S: int) -> tuple:
    """A row's state and work arrays for n tendons and S segments: the bending vectors b (S, 2), the tensions
    (n,) and the friction directions (n,) at zero, the capstan factors (n, S) at one, the gravity bending
    (2, S, 2) at zero, the tension solve's matrix (n, n) and right side (n,), and ``scratch``."""
    return (np.zeros((S, 2)), np.zeros(n), np.zeros(n), np.ones((n, S)), np.zeros((2, S, 2)), np.empty((n, n)),
            np.empty(n), scratch(n, S))


@njit(cache=True)
def _directions(q, reset, k, dirs):
    """The friction directions dirs (n,) at row k of q (K, n): 0 where a session starts (``reset``), else
    +1 (-1) where the command grew (fell) by more than ``_HOLD`` since row k - 1, the last one kept."""
    if k == 0 or reset[k]:
        dirs[:] = 0.0
        return
    for i in range(q.shape[1]):
        dq = q[k, i] - q[k - 1, i]
        if dq > _HOLD:
            dirs[i] = 1.0
        elif dq < -_HOLD:
            dirs[i] = -1.0


@njit(cache=True)
def session_passes(q, reset, seg, L, compliance, rho, offsets, mu, gvec, bend, tau, out):
    """One fixed-point pass (``_pass``) of every row of a session from given bending vectors bend (K, S, 2)
    [1/m] and tensions tau (K, n) [m] (a solution's, ``session_solve``'s, or one near it): out (K, S, 2)
    [1/m] = G(bend) row by row, with the friction directions of the commands q (K, n) [m] (``reset`` as
    ``session_solve``'s) and the other arguments as there (no creep: the offsets are the slacks). Where
    bend is the rows' fixed point, out's change with a parameter or with bend gives the fixed point's
    sensitivity (``tendon_robot``'s implicit Jacobian)."""
    K, n = q.shape
    S = L.size
    gravity = gvec[0] != 0.0 or gvec[1] != 0.0 or gvec[2] != 0.0
    b, t, dirs, f, gb, M, rhs, work = _row_arrays(n, S)
    g = np.empty((S, 2))
    for k in range(K):
        _directions(q, reset, k, dirs)
        for a in range(S):
            b[a, 0] = bend[k, a, 0]
            b[a, 1] = bend[k, a, 1]
        for i in range(n):
            t[i] = tau[k, i]
        _pass(q[k], seg, L, compliance, rho, offsets, mu, gvec, gravity, b, t, dirs, f, gb, M, rhs, work, g)
        for a in range(S):
            out[k, a, 0] = g[a, 0]
            out[k, a, 1] = g[a, 1]


@njit(cache=True)
def session_tips(bend, L, marker, tips):
    """tips (K, 3) [m] in the base frame: the chain tip (``chain_tip``) of each row's bending vectors bend
    (K, S, 2) [1/m]."""
    frames = np.empty((2, 3, 3))
    points = np.empty((2, 3))
    tip = np.empty(3)
    for k in range(bend.shape[0]):
        chain_tip(bend[k], L, marker, frames, points, tip)
        for a in range(3):
            tips[k, a] = tip[a]


@njit(cache=True)
def session_solve(q, reset, seg, L, compliance, rho, offsets, mu, gvec, marker, creep, dt, slack0, tips, tau_out,
                  bend_out, passes_out, slack_out):
    """Solve every row of a session in order (see the module's docstring).

    q (K, n) [m] tendon displacements; reset (K,) bool, True where a session starts (straight
    warm start, friction directions 0); seg (n,) int the segment each tendon ends at; L (S,) [m];
    compliance (S,) k / EI_s [m^-3]; rho (n, 2) [m] tendon offsets; offsets (n,) [m] slacks; mu the
    friction coefficient; gvec (3,) (w / k) g_hat in the base frame (zeros: no gravity); marker [m];
    creep [1/s] the creep rate, dt (K,) [s] how long each row's load acts before the next row (0 where
    a session ends) and slack0 [m] the creep slack at the first row (see the module's docstring).
    Writes tips (K, 3) [m] (base frame), tau_out (K, n) tau / k [m] at the base, bend_out (K, S, 2)
    [1/m], passes_out (K,) the fixed-point passes of each row (negated: the row did not settle) and
    slack_out (K,) [m] the creep slack each row saw.
    """
    K, n = q.shape
    S = L.size
    slack = slack0
    off = np.empty(n)
    gravity = gvec[0] != 0.0 or gvec[1] != 0.0 or gvec[2] != 0.0
    b, tau, dirs, f, gb, M, rhs, work = _row_arrays(n, S)
    acc = np.zeros((3, S, 2))
    frames = np.empty((2, 3, 3))
    points = np.empty((2, 3))
    tip = np.empty(3)
    for k in range(K):
        if k == 0 or reset[k]:
            b[:] = 0.0
            tau[:] = 0.0
            gb[:] = 0.0
        _directions(q, reset, k, dirs)
        for i in range(n):
            off[i] = offsets[i] + slack
        passes_out[k] = _row(q[k], seg, L, compliance, rho, off, mu, gvec, gravity, b, tau, dirs, f, gb, M, rhs,
                             work, acc)
        slack_out[k] = slack
        load = 0.0
        for i in range(n):
            load += tau[i]
        slack += creep * (load / n) * dt[k]
        chain_tip(b, L, marker, frames, points, tip)
        for a in range(3):
            tips[k, a] = _flush(tip[a])
        for i in range(n):
            tau_out[k, i] = _flush(tau[i])
        for s in range(S):
            for a in range(2):
                bend_out[k, s, a] = _flush(b[s, a])
