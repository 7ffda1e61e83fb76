"""Numba kernels of the static Cosserat rod BVP (paper appendix; Till, Aloi & Rucker 2019): RK4
forward integration of (p, q, n, m) along s and Levenberg-Marquardt shooting on the base wrench.

State along the rod (13 numbers per grid point, ``Y[k] = [p, q, n, m]``):
    p (3,) centreline position [m], world frame
    q (4,) unit quaternion (w, x, y, z), body -> world; columns of R(q) are d1, d2, d3 (d3 tangent)
    n (3,) internal force [N], world frame (force of the distal part on the proximal part)
    m (3,) internal moment [N m], world frame

ODEs (paper appendix, with v_hat = e3 and u_hat = 0 for a straight stress-free rod):
    p' = R v,  q' = q (x) (0, u) / 2,  n' = -f,  m' = -p' x n,
    v = Ks^-1 R^T n + e3,  u = Kb^-1 R^T m,
with Ks = diag(GA, GA, EA), Kb = diag(EI, EI, GJ) and f the distributed force per length
(weight rho A g plus a uniform load). Point loads (F, T) at a grid point s_k are jumps
n(s_k+) = n(s_k-) - F, m(s_k+) = m(s_k-) - T; a point magnet with body moment mu_b in the field B
and gradient G applies T = (R mu_b) x B and F = G (R mu_b) with R at s_k.

Tendons (``StaticRod.tendons``; Rucker & Webster 2011) are an active stress: n and m are then the
total wrench of the section, rod plus tendons, which follows the ODEs above with the external
loads alone (continuous at a termination); the rod's strains solve
    v = Ks^-1 (R^T n - sum tau t) + e3,  u = Kb^-1 (R^T m - sum tau rho x t),
t the unit vector of v + u x rho + rho', over the tendons routed through the step
(``_tendon_strains``). Their arrays, in the ``loads`` tuple: tension (m,) [N], geometry (m, 3)
(offset ox, oy [m] at the base and twist rate 2 pi / pitch [rad/m]; rho(s) = Rz(rate s) (ox, oy, 0))
and end (m,) int64, the grid point of each termination.

Grid arrays (N steps, N + 1 grid points; the solver places every load point and every stiffness
change on a grid point, so each RK4 step has constant properties):
    h       (N,)       step lengths [m]
    kinv    (N, 6)     compliances [1/(N m^2)] x3 then [1/N] x3:
                       1/EI1, 1/EI2, 1/GJ, 1/GA, 1/GA, 1/EA (the last three 0 for Kirchhoff)
    weight  (N,)       mass per length rho A [kg/m]
    jumps   (N + 1, 6) dead point loads [F (N), T (N m)] per grid point, world frame
Magnets (M of them): node (M,) grid index, mu (M, 3) body moment [A m^2], B (M, 3) [T],
G (M, 3, 3) [T/m] with G[i, j] = dB_i/dx_j.

The unknowns are the base wrench xi = [n(0), m(0)] (6,); the residual is the tip wrench
[n(L+), m(L+)] after the tip's own point loads, which must vanish at a free tip.

``tendon_lengths`` integrates as ``shoot`` does, with each tendon's path length (the integral of
|v + u x rho + rho'| ds up to its termination) carried along as extra RK4 states: the solver's
outer iteration on the tensions of tendons driven by a displacement (``solver``) uses it.
"""

import math

import numpy as np
from numba import njit

# status codes of ``shoot`` (mirrored by solver.Status)
CONVERGED = 0
ITERATION_LIMIT = 1
SINGULAR = 2
NOT_FINITE = 3

# info slots written by ``shoot``
INFO_ITERATIONS = 0
INFO_RESIDUAL = 1
INFO_INTEGRATIONS = 2
INFO_JACOBIANS = 3

_LAMBDA0 = 1e-6         # initial Marquardt damping, relative to max diag(J^T J)
_LAMBDA_MAX = 1e16      # damping beyond which the LM step is deemed stalled
_FD_STEP = 1.5e-8       # forward-difference step in scaled unknowns (~ sqrt(machine epsilon))
_TENDON_MAX_ITER = 60   # fixed-point iterations of a section's strains with tendons

# Compiled-only helpers (no Python entry points, never allocate). The rotation and the ODE
# right-hand side are inlined by LLVM (``forceinline``: a call per derivative would double the
# integration's cost); the point-load jumps, the integration, the Jacobian and the step are
# called as functions, so each is optimised once. With ``no_rewrites`` this cuts the cold compile
# to about 40 % of the all-inlined version at the same speed.
_HELPER = dict(fastmath={"contract"}, error_model="numpy", no_cpython_wrapper=True, no_cfunc_wrapper=True,
               no_rewrites=True, _nrt=False)
_INLINE = dict(_HELPER, forceinline=True)


@njit(**_INLINE)
def _rotation(y, R):
    """R[3, 3] <- rotation of the (not necessarily unit) quaternion y[3:7]."""
    w, x, yy, z = y[3], y[4], y[5], y[6]
    s = 2.0 / (w * w + x * x + yy * yy + z * z)
    R[0, 0] = 1.0 - s * (yy * yy + z * z)
    R[0, 1] = s * (x * yy - w * z)
    R[0, 2] = s * (x * z + w * yy)
    R[1, 0] = s * (x * yy + w * z)
    R[1, 1] = 1.0 - s * (x * x + z * z)
    R[1, 2] = s * (yy * z - w * x)
    R[2, 0] = s * (x * z - w * yy)
    R[2, 1] = s * (yy * z + w * x)
    R[2, 2] = 1.0 - s * (x * x + yy * yy)


@njit(**_INLINE)
def _body_wrench(y, R):
    """R[3, 3] <- the rotation of the state y[13]; returns its body-frame stress resultants
    R^T n, R^T m (nb0, nb1, nb2, mb0, mb1, mb2) [N, N m]."""
    _rotation(y, R)
    nx, ny, nz = y[7], y[8], y[9]
    mx, my, mz = y[10], y[11], y[12]
    nb0 = R[0, 0] * nx + R[1, 0] * ny + R[2, 0] * nz
    nb1 = R[0, 1] * nx + R[1, 1] * ny + R[2, 1] * nz
    nb2 = R[0, 2] * nx + R[1, 2] * ny + R[2, 2] * nz
    mb0 = R[0, 0] * mx + R[1, 0] * my + R[2, 0] * mz
    mb1 = R[0, 1] * mx + R[1, 1] * my + R[2, 1] * mz
    mb2 = R[0, 2] * mx + R[1, 2] * my + R[2, 2] * mz
    return nb0, nb1, nb2, mb0, mb1, mb2


@njit(**_INLINE)
def _strains(kinv, k, n0, n1, n2, m0, m1, m2):
    """The strains (u0, u1, u2, v0, v1, v2) of the section on step k under the body-frame wrench
    (n, m): u = Kb^-1 m, v = Ks^-1 n + e3."""
    return (kinv[k, 0] * m0, kinv[k, 1] * m1, kinv[k, 2] * m2,
            kinv[k, 3] * n0, kinv[k, 4] * n1, kinv[k, 5] * n2 + 1.0)


@njit(**_INLINE)
def _tendon_path(geom, j, s, u0, u1, u2, v0, v1, v2):
    """Tendon j at arc length s [m]: its offset rho = (o0, o1, 0) [m] and t = v + u x rho + rho'
    (t0, t1, t2), the rate of its path (unnormalised tangent), for the strains (u, v)."""
    c = math.cos(geom[j, 2] * s)
    sn = math.sin(geom[j, 2] * s)
    o0 = c * geom[j, 0] - sn * geom[j, 1]
    o1 = sn * geom[j, 0] + c * geom[j, 1]
    # rho' = rate e3 x rho
    t0 = v0 - u2 * o1 - geom[j, 2] * o1
    t1 = v1 + u2 * o0 + geom[j, 2] * o0
    t2 = v2 + u0 * o1 - u1 * o0
    return o0, o1, t0, t1, t2


@njit(**_INLINE)
def _tendon_strains(kinv, k, nb0, nb1, nb2, mb0, mb1, mb2, s, tendons, scale):
    """The strains (u, v) of the section at arc length s on step k whose total body-frame wrench is
    (nb, mb), with the active stress of the tendons routed through it: the fixed point of
    v = Ks^-1 (nb - sum tau t) + e3, u = Kb^-1 (mb - sum tau rho x t), t the unit vector of
    v + u x rho + rho' (a contraction with the ratio ~ tau |rho|^2 / EI, converged to round-off)."""
    tension, geom, end = tendons
    u0, u1, u2, v0, v1, v2 = _strains(kinv, k, nb0, nb1, nb2, mb0, mb1, mb2)
    for _ in range(_TENDON_MAX_ITER):
        n0, n1, n2, m0, m1, m2 = nb0, nb1, nb2, mb0, mb1, mb2
        size = 0.0
        for j in range(len(end)):
            tau = scale * tension[j]
            if k >= end[j] or not tau > 0.0:
                continue
            o0, o1, t0, t1, t2 = _tendon_path(geom, j, s, u0, u1, u2, v0, v1, v2)
            size = max(size, abs(o0) + abs(o1))
            f = tau / math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
            n0 -= f * t0
            n1 -= f * t1
            n2 -= f * t2
            m0 -= f * o1 * t2
            m1 += f * o0 * t2
            m2 -= f * (o0 * t1 - o1 * t0)
        w0, w1, w2, z0, z1, z2 = _strains(kinv, k, n0, n1, n2, m0, m1, m2)
        change = (abs(z0 - v0) + abs(z1 - v1) + abs(z2 - v2)
                  + size * (abs(w0 - u0) + abs(w1 - u1) + abs(w2 - u2)))
        u0, u1, u2, v0, v1, v2 = w0, w1, w2, z0, z1, z2
        if change <= 4e-15:
            break
    return u0, u1, u2, v0, v1, v2


@njit(**_INLINE)
def _derivative(y, kinv, k, fx, fy, fz, s, tendons, scale, R, dy):
    """dy[13] <- y'(s) for the state y[13] with the compliances kinv[k], the distributed force
    (fx, fy, fz) [N/m] and the tendons (tension (m,) [N] times ``scale``, geometry (m, 3):
    offset [m] and twist rate [rad/m], termination step (m,)) at the arc length s [m]; R[3, 3] is
    scratch."""
    nb0, nb1, nb2, mb0, mb1, mb2 = _body_wrench(y, R)
    nx, ny, nz = y[7], y[8], y[9]
    _, _, tendon_end = tendons
    if len(tendon_end) > 0:
        u0, u1, u2, v0, v1, v2 = _tendon_strains(kinv, k, nb0, nb1, nb2, mb0, mb1, mb2, s, tendons, scale)
    else:
        u0, u1, u2, v0, v1, v2 = _strains(kinv, k, nb0, nb1, nb2, mb0, mb1, mb2)
    px = R[0, 0] * v0 + R[0, 1] * v1 + R[0, 2] * v2
    py = R[1, 0] * v0 + R[1, 1] * v1 + R[1, 2] * v2
    pz = R[2, 0] * v0 + R[2, 1] * v1 + R[2, 2] * v2
    dy[0] = px
    dy[1] = py
    dy[2] = pz
    # q' = q (x) (0, u) / 2
    w, x, yy, z = y[3], y[4], y[5], y[6]
    dy[3] = -0.5 * (x * u0 + yy * u1 + z * u2)
    dy[4] = 0.5 * (w * u0 + yy * u2 - z * u1)
    dy[5] = 0.5 * (w * u1 + z * u0 - x * u2)
    dy[6] = 0.5 * (w * u2 + x * u1 - yy * u0)
    dy[7] = -fx
    dy[8] = -fy
    dy[9] = -fz
    # m' = -p' x n
    dy[10] = -(py * nz - pz * ny)
    dy[11] = -(pz * nx - px * nz)
    dy[12] = -(px * ny - py * nx)


@njit(**_HELPER)
def _apply_jumps(y, a, jumps, scale, mag_node, mu, B, G, R):
    """Subtract the point loads of grid point a (dead loads and magnets, times ``scale``) from the
    internal wrench y[7:13]."""
    y[7] -= scale * jumps[a, 0]
    y[8] -= scale * jumps[a, 1]
    y[9] -= scale * jumps[a, 2]
    y[10] -= scale * jumps[a, 3]
    y[11] -= scale * jumps[a, 4]
    y[12] -= scale * jumps[a, 5]
    for j in range(len(mag_node)):
        if mag_node[j] != a:
            continue
        _rotation(y, R)
        wx = R[0, 0] * mu[j, 0] + R[0, 1] * mu[j, 1] + R[0, 2] * mu[j, 2]
        wy = R[1, 0] * mu[j, 0] + R[1, 1] * mu[j, 1] + R[1, 2] * mu[j, 2]
        wz = R[2, 0] * mu[j, 0] + R[2, 1] * mu[j, 1] + R[2, 2] * mu[j, 2]
        bx, by, bz = scale * B[j, 0], scale * B[j, 1], scale * B[j, 2]
        # force G mu, torque mu x B
        y[7] -= scale * (G[j, 0, 0] * wx + G[j, 0, 1] * wy + G[j, 0, 2] * wz)
        y[8] -= scale * (G[j, 1, 0] * wx + G[j, 1, 1] * wy + G[j, 1, 2] * wz)
        y[9] -= scale * (G[j, 2, 0] * wx + G[j, 2, 1] * wy + G[j, 2, 2] * wz)
        y[10] -= wy * bz - wz * by
        y[11] -= wz * bx - wx * bz
        y[12] -= wx * by - wy * bx


def _integrator(lengths_too: bool, options: dict):
    """``integrate(xi, base, grid, mags, loads, Y, work, R, r, lengths, rates)``, compiled with
    ``options``: RK4 from the base wrench xi[6] to the tip, r[6] <- the tip residual (after the tip's
    point loads) and Y[N + 1, 13] <- the grid points' states (before their point loads), or, when
    ``lengths_too`` (a constant of the code), lengths (m,) <- the tendons' path lengths [m] (extra
    RK4 states). ``work`` (5, 13), ``rates`` (4, m): scratch. False when a value is not finite."""

    @njit(**options)
    def integrate(xi, base, grid, mags, loads, Y, work, R, r, lengths, rates):
        h, kinv, weight, jumps = grid
        mag_node, mu, B, G = mags
        gravity, distributed, scale, tendons = loads
        y, yt, k1, k2, k3 = work[0], work[1], work[2], work[3], work[4]
        for i in range(3):
            y[i] = base[i]
        for i in range(4):
            y[3 + i] = base[3 + i]
        for i in range(6):
            y[7 + i] = xi[i]
        if lengths_too:
            for j in range(len(lengths)):
                lengths[j] = 0.0
        n_steps = len(h)
        sk = 0.0
        for k in range(n_steps):
            if not lengths_too:
                for i in range(13):
                    Y[k, i] = y[i]
            _apply_jumps(y, k, jumps, scale, mag_node, mu, B, G, R)
            hk = h[k]
            fx = scale * (weight[k] * gravity[0] + distributed[0])
            fy = scale * (weight[k] * gravity[1] + distributed[1])
            fz = scale * (weight[k] * gravity[2] + distributed[2])
            if lengths_too:
                _tendon_rates(y, kinv, k, sk, tendons, scale, R, rates[0])
            _derivative(y, kinv, k, fx, fy, fz, sk, tendons, scale, R, k1)
            for i in range(13):
                yt[i] = y[i] + 0.5 * hk * k1[i]
            if lengths_too:
                _tendon_rates(yt, kinv, k, sk + 0.5 * hk, tendons, scale, R, rates[1])
            _derivative(yt, kinv, k, fx, fy, fz, sk + 0.5 * hk, tendons, scale, R, k2)
            for i in range(13):
                yt[i] = y[i] + 0.5 * hk * k2[i]
            if lengths_too:
                _tendon_rates(yt, kinv, k, sk + 0.5 * hk, tendons, scale, R, rates[2])
            _derivative(yt, kinv, k, fx, fy, fz, sk + 0.5 * hk, tendons, scale, R, k3)
            for i in range(13):
                yt[i] = y[i] + hk * k3[i]
                k1[i] += 2.0 * (k2[i] + k3[i])
            if lengths_too:
                _tendon_rates(yt, kinv, k, sk + hk, tendons, scale, R, rates[3])
            _derivative(yt, kinv, k, fx, fy, fz, sk + hk, tendons, scale, R, k2)
            for i in range(13):
                y[i] += hk / 6.0 * (k1[i] + k2[i])
            if lengths_too:
                for j in range(len(lengths)):
                    lengths[j] += hk / 6.0 * (rates[0, j] + 2.0 * (rates[1, j] + rates[2, j]) + rates[3, j])
            sk += hk
            qn = 1.0 / math.sqrt(y[3] * y[3] + y[4] * y[4] + y[5] * y[5] + y[6] * y[6])
            for i in range(3, 7):
                y[i] *= qn
        if not lengths_too:
            for i in range(13):
                Y[n_steps, i] = y[i]
        _apply_jumps(y, n_steps, jumps, scale, mag_node, mu, B, G, R)
        finite = True
        for i in range(6):
            r[i] = y[7 + i]
            if not math.isfinite(r[i]):
                finite = False
        if lengths_too:
            for j in range(len(lengths)):
                if not math.isfinite(lengths[j]):
                    finite = False
        return finite

    return integrate


_integrate = _integrator(False, _HELPER)
"""``shoot``'s integration: the grid states, contracted multiply-adds (``_HELPER``)."""
_integrate_lengths = _integrator(True, dict(_HELPER, fastmath=False))
"""``tendon_lengths``' integration: the tendons' path lengths, without contraction (its arithmetic
as it always was)."""


@njit(**_HELPER)
def _scaled_residual(x, sc, base, grid, mags, loads, Y, work, R, xi, r, rs, lengths, rates):
    """rs[6] <- scaled tip residual at scaled unknowns x[6] (xi = x * sc); returns the unscaled
    residual norm, or inf when not finite."""
    for i in range(6):
        xi[i] = x[i] * sc[i]
    if not _integrate(xi, base, grid, mags, loads, Y, work, R, r, lengths, rates):
        return math.inf
    norm2 = 0.0
    for i in range(6):
        rs[i] = r[i] / sc[i]
        norm2 += r[i] * r[i]
    return math.sqrt(norm2)


@njit(**_HELPER)
def _jacobian(x, rs, sc, base, grid, mags, loads, Y, work, R, xi, r, xt, rt, J, lengths, rates, info):
    """J[6, 6] <- forward-difference Jacobian of the scaled residual at x (rs = residual at x),
    counted in ``info`` (``shoot``'s); returns False when a perturbed integration is not finite."""
    for j in range(6):
        for i in range(6):
            xt[i] = x[i]
        step = _FD_STEP * max(1.0, abs(x[j]))
        xt[j] = x[j] + step
        step = xt[j] - x[j]  # the representable step
        if not math.isfinite(_scaled_residual(xt, sc, base, grid, mags, loads, Y, work, R, xi, r, rt, lengths, rates)):
            return False
        for i in range(6):
            J[i, j] = (rt[i] - rs[i]) / step
    info[INFO_INTEGRATIONS] += 6.0
    info[INFO_JACOBIANS] += 1.0
    return True


@njit(**_HELPER)
def _lm_step(J, rs, lam, A, g, d):
    """d[6] <- the Levenberg-Marquardt step solving (J^T J + lam diag(J^T J)) d = -J^T rs by
    Cholesky. Returns False if the matrix is not positive definite (singular J)."""
    for i in range(6):
        acc = 0.0
        for k in range(6):
            acc += J[k, i] * rs[k]
        g[i] = acc
        for j in range(6):
            acc = 0.0
            for k in range(6):
                acc += J[k, i] * J[k, j]
            A[i, j] = acc
    for i in range(6):
        A[i, i] *= 1.0 + lam
    # Cholesky A = L L^T in place (lower triangle)
    for j in range(6):
        s = A[j, j]
        for k in range(j):
            s -= A[j, k] * A[j, k]
        if not s > 0.0:
            return False
        A[j, j] = math.sqrt(s)
        for i in range(j + 1, 6):
            s = A[i, j]
            for k in range(j):
                s -= A[i, k] * A[j, k]
            A[i, j] = s / A[j, j]
    for i in range(6):  # L z = -g
        s = -g[i]
        for k in range(i):
            s -= A[i, k] * d[k]
        d[i] = s / A[i, i]
    for i in range(5, -1, -1):  # L^T d = z
        s = d[i]
        for k in range(i + 1, 6):
            s -= A[k, i] * d[k]
        d[i] = s / A[i, i]
    return True


@njit(cache=True, error_model="numpy", no_rewrites=True)
def shoot(xi, sc, J, have_jacobian, tol, max_iter, base, grid, mags, loads, Y, info):
    """Levenberg-Marquardt shooting: find the base wrench xi (6,) [N, N m] (in: the guess; out:
    the last accepted iterate) whose integration gives a tip residual norm <= tol.

    The unknowns and residuals are scaled by sc (6,) (a force and a moment scale). J (6, 6) is the
    Jacobian of the scaled residual: used as given when ``have_jacobian`` (warm start), otherwise
    computed by forward differences (6 extra integrations); after each accepted step it is updated
    by Broyden's rank-one formula, and recomputed by differences when a step with a Broyden
    Jacobian fails. On return J holds the last Jacobian and Y the states of the last accepted
    iterate. ``info`` (4,) <- [iterations, residual norm, integrations, jacobian evaluations].

    Returns CONVERGED, ITERATION_LIMIT, SINGULAR (the damped step stalls or the normal matrix
    is not positive definite) or NOT_FINITE (the integration at the guess is not finite).
    """
    work = np.empty((5, 13))
    R = np.empty((3, 3))
    xi_t = np.empty(6)
    r = np.empty(6)
    x = np.empty(6)
    rs = np.empty(6)
    xt = np.empty(6)
    rt = np.empty(6)
    d = np.empty(6)
    g = np.empty(6)
    A = np.empty((6, 6))
    Yt = np.empty_like(Y)
    no_lengths = np.empty(0)  # no tendon path lengths carried
    no_rates = np.empty((4, 0))
    for i in range(6):
        x[i] = xi[i] / sc[i]
    info[INFO_ITERATIONS] = 0.0
    info[INFO_JACOBIANS] = 0.0
    norm = _scaled_residual(x, sc, base, grid, mags, loads, Y, work, R, xi_t, r, rs, no_lengths, no_rates)
    info[INFO_INTEGRATIONS] = 1.0
    info[INFO_RESIDUAL] = norm
    if not math.isfinite(norm):
        return NOT_FINITE
    if norm <= tol:
        return CONVERGED
    fresh = False
    if not have_jacobian:
        if not _jacobian(x, rs, sc, base, grid, mags, loads, Yt, work, R, xi_t, r, xt, rt, J, no_lengths, no_rates,
                         info):
            return NOT_FINITE
        fresh = True
    cost = 0.0
    for i in range(6):
        cost += rs[i] * rs[i]
    lam = _LAMBDA0
    nu = 2.0
    iterations = 0
    while iterations < max_iter:
        iterations += 1
        info[INFO_ITERATIONS] = iterations
        if not _lm_step(J, rs, lam, A, g, d):
            return SINGULAR
        for i in range(6):
            xt[i] = x[i] + d[i]
        norm_t = _scaled_residual(xt, sc, base, grid, mags, loads, Yt, work, R, xi_t, r, rt, no_lengths, no_rates)
        info[INFO_INTEGRATIONS] += 1.0
        cost_t = math.inf
        predicted = 0.0
        if math.isfinite(norm_t):
            cost_t = 0.0
            for i in range(6):
                cost_t += rt[i] * rt[i]
            # predicted decrease of |rs|^2 for the damped Gauss-Newton model: d^T (lam D d - g)
            for i in range(6):
                diag = 0.0
                for k in range(6):
                    diag += J[k, i] * J[k, i]
                predicted += d[i] * (lam * diag * d[i] - g[i])
        if cost_t < cost:
            # accept; Broyden update of J with the actual change of the residual
            dd = 0.0
            for i in range(6):
                dd += d[i] * d[i]
            if dd > 0.0:
                for i in range(6):
                    jd = 0.0
                    for k in range(6):
                        jd += J[i, k] * d[k]
                    c = (rt[i] - rs[i] - jd) / dd
                    for k in range(6):
                        J[i, k] += c * d[k]
            fresh = False
            for i in range(6):
                x[i] = xt[i]
                rs[i] = rt[i]
                xi[i] = x[i] * sc[i]
            for a in range(len(Y)):
                for i in range(13):
                    Y[a, i] = Yt[a, i]
            rho = (cost - cost_t) / predicted if predicted > 0.0 else 1.0
            cost = cost_t
            norm = norm_t
            info[INFO_RESIDUAL] = norm
            if norm <= tol:
                return CONVERGED
            # Nielsen's damping update
            lam *= max(1.0 / 3.0, 1.0 - (2.0 * min(rho, 1.0) - 1.0) ** 3)
            nu = 2.0
        elif not fresh:
            # a step with an updated (Broyden) Jacobian failed: recompute it here by differences
            if not _jacobian(x, rs, sc, base, grid, mags, loads, Yt, work, R, xi_t, r, xt, rt, J, no_lengths, no_rates,
                             info):
                return NOT_FINITE
            fresh = True
        else:
            lam *= nu
            nu *= 2.0
            if lam > _LAMBDA_MAX:
                return SINGULAR
    for i in range(6):
        xi[i] = x[i] * sc[i]
    return ITERATION_LIMIT


@njit(**_INLINE)
def _tendon_rates(y, kinv, k, s, tendons, scale, R, rates):
    """rates[j] <- |v + u x rho_j + rho_j'| (the rate of tendon j's path length per arc length) at
    the state y[13] on step k at arc length s, for the tendons routed through the step (0 for the
    others); the strains as in ``_derivative``. R[3, 3] is scratch."""
    tension, geom, end = tendons
    nb0, nb1, nb2, mb0, mb1, mb2 = _body_wrench(y, R)
    u0, u1, u2, v0, v1, v2 = _tendon_strains(kinv, k, nb0, nb1, nb2, mb0, mb1, mb2, s, tendons, scale)
    for j in range(len(end)):
        rates[j] = 0.0
        if k >= end[j]:
            continue
        _, _, t0, t1, t2 = _tendon_path(geom, j, s, u0, u1, u2, v0, v1, v2)
        rates[j] = math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)


@njit(cache=True, error_model="numpy", no_rewrites=True)
def tendon_lengths(xi, base, grid, mags, loads, r, lengths):
    """Integrate from the base wrench xi[6] as ``shoot`` does, with the path length of every
    tendon (the integral of |v + u x rho + rho'| ds up to its termination) as extra RK4 states:
    r[6] <- the tip residual, lengths (m,) <- the tendons' lengths [m]. Returns False when a value
    is not finite."""
    work = np.empty((5, 13))
    rates = np.empty((4, len(lengths)))
    R = np.empty((3, 3))
    return _integrate_lengths(xi, base, grid, mags, loads, np.empty((0, 13)), work, R, r, lengths, rates)
