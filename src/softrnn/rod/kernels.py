"""Numba kernels of the Lie group variational integrator (Variant A of docs/lgvi.md §2.4).

Per node: explicit translation (T) and a 3-unknown Newton solve on the Cayley vector for the
rotation (R); segment strains use the SE(3)-Cayley measure (second order in space). One call
advances many steps; ``advance_batch`` advances a block of independent rods without the GIL
(``rod.threads.over_rods`` runs the blocks at once on threads), each rod's record built by
``rod_inputs`` (shared with the environments' kernel, ``softrnn.envs._kernels``).

The records (``LumpedRod``, ``StateArrays``, ``StepInputs``, ``Samples``) and the constants live in
``rod.kernel_records``; the loads of each concept in their own kernel modules (``tendon_kernels``,
``contact_kernels``, ``magnetic_kernels``); this module holds the rod step and re-exports their
names. ``advance_into`` never allocates and writes its results into the arrays passed in.

Structure, for compile time (a cold start compiles everything here; numba's Python front end
costs far more than LLVM and grows faster than linearly with the size of a function):

* one time step of ``advance_into`` is split into helpers that numba types and lowers on their
  own: ``_applied_loads`` (per step), ``_segment`` (strains and stress resultants of segment a),
  ``_node`` (translation, rotation with ``_solve_rotation`` and ``times_cayley_into``, sample
  outputs of node a) and ``_quaternion_into``. They take the records whole and read the fields
  they need. They carry ``forceinline`` (LLVM inlines them into ``advance_into``, so
  the machine code is that of one function: no call overhead per node) and ``_nrt=False`` (they
  never allocate; without it the reference counting of the arrays they receive survives the
  inlining as atomic calls in the node loop). They have no Python/C entry points and are not
  cached themselves: their code is part of the cached entry points' code.
* ``no_rewrites``: numba's IR rewrites cost time and mark operations with a constant operand
  (``0.5 * x``) for a second, literal type resolution at lowering. Without them, take array
  lengths with ``len(a)``, not ``a.shape[0]`` (a literal index into a tuple would compile a
  numba overload).
* loop-carried variables get their final type before the loop (``jq``, ``f0``), so that type
  inference needs no extra pass over the function.
* optional loads are chosen by type: without obstacles ``StepInputs.contact_kind`` is None, without
  magnets ``magnet_node`` is None, and their kernels (``_contact_loads_if_any``,
  ``_magnet_loads_if_any``: ``numba.extending.overload``s) compile to nothing, so a plain rod's cold
  start never compiles contact or magnetic code (a rod with them compiles its own specialisation).

Caching: numba checks a cached function against its own source file only. The helpers of the
kernel modules (``kernel_records``, ``tendon_kernels``, ``contact_kernels``, ``magnetic_kernels``
and this one) are inlined into the cached entry points, so those are built as closures over
``kernel_stamp()``, a hash of all of these files: numba puts closure variables into the cache key,
so an edit of any of them recompiles the entry points (``rod.implicit`` does the same).
"""

import math

import numpy as np
from numba import njit
from numba.extending import overload

from .contact_kernels import _applied_outputs_if_any, _contact_loads, _contact_loads_if_any
from .kernel_records import _INLINE, _relative_rotation_parts, absent, kernel_stamp
from .kernel_records import BIFURCATION as BIFURCATION
from .kernel_records import BRANCH as BRANCH
from .kernel_records import CLAMPED as CLAMPED
from .kernel_records import CYLINDER as CYLINDER
from .kernel_records import DIVERGED as DIVERGED
from .kernel_records import FREE as FREE
from .kernel_records import HUB_DRIVEN as HUB_DRIVEN
from .kernel_records import HUB_PUSHED as HUB_PUSHED
from .kernel_records import HUB_TWISTED as HUB_TWISTED
from .kernel_records import MAGNET_TOO_CLOSE as MAGNET_TOO_CLOSE
from .kernel_records import MESH as MESH
from .kernel_records import NEWTON_FAILED as NEWTON_FAILED
from .kernel_records import OK as OK
from .kernel_records import PINNED as PINNED
from .kernel_records import PLANE as PLANE
from .kernel_records import SELF as SELF
from .kernel_records import SPHERE as SPHERE
from .kernel_records import UNION_BLEND as UNION_BLEND
from .kernel_records import VESSEL as VESSEL
from .kernel_records import LumpedRod as LumpedRod
from .kernel_records import Samples as Samples
from .kernel_records import StateArrays as StateArrays
from .kernel_records import StepInputs as StepInputs
from .kernel_records import _quaternion_into as _quaternion_into
from .kernel_records import times_cayley_into as times_cayley_into
from .magnetic_kernels import MIN_DIPOLE_DISTANCE as MIN_DIPOLE_DISTANCE
from .magnetic_kernels import MU0 as MU0
from .magnetic_kernels import _magnet_loads, _magnet_loads_if_any
from .magnetic_kernels import field_gradient_into as field_gradient_into
from .tendon_kernels import _tendon_springs, _tendon_tangent

_NEWTON_MAX_ITER = 12
_NEWTON_RTOL = 1e-13
_ROWS = dict(no_cpython_wrapper=True, no_cfunc_wrapper=True)
"""The batch's row helpers (``rod_inputs``, ``rod_state``, ``rod_samples``, ``contact_rows``): compiled
into the batched kernels (they return views, so they keep numba's reference counting)."""


@njit(**_INLINE)
def _solve_rotation(clamped, y0, y1, y2, b0, b1, b2, ja0, ja1, ja2, hc, tol):
    """Newton on Phi(y) = J y + y x J y / 2 + (y.Jy) y / 4 + hc y - b from the start y (docs/lgvi.md
    section 2.5). Returns (converged, y, Phi(y)); for a clamped node, Phi at its prescribed y."""
    f0 = f1 = f2 = 0.0  # typed before the loop (no extra type-inference pass)
    for it in range(_NEWTON_MAX_ITER + 1):
        jy0 = ja0 * y0
        jy1 = ja1 * y1
        jy2 = ja2 * y2
        yjy = y0 * jy0 + y1 * jy1 + y2 * jy2
        f0 = jy0 + 0.5 * (y1 * jy2 - y2 * jy1) + 0.25 * yjy * y0 + hc * y0 - b0
        f1 = jy1 + 0.5 * (y2 * jy0 - y0 * jy2) + 0.25 * yjy * y1 + hc * y1 - b1
        f2 = jy2 + 0.5 * (y0 * jy1 - y1 * jy0) + 0.25 * yjy * y2 + hc * y2 - b2
        if clamped or abs(f0) + abs(f1) + abs(f2) <= tol:
            return True, y0, y1, y2, f0, f1, f2
        if it == _NEWTON_MAX_ITER:
            break
        # DPhi = J + (y^ J - (Jy)^)/2 + (2 y (Jy)^T + (y.Jy) I)/4 + hc I
        dg = 0.25 * yjy + hc
        A00 = ja0 + 0.5 * y0 * jy0 + dg
        A11 = ja1 + 0.5 * y1 * jy1 + dg
        A22 = ja2 + 0.5 * y2 * jy2 + dg
        A01 = 0.5 * (-y2 * ja1 + jy2) + 0.5 * y0 * jy1
        A02 = 0.5 * (y1 * ja2 - jy1) + 0.5 * y0 * jy2
        A10 = 0.5 * (y2 * ja0 - jy2) + 0.5 * y1 * jy0
        A12 = 0.5 * (-y0 * ja2 + jy0) + 0.5 * y1 * jy2
        A20 = 0.5 * (-y1 * ja0 + jy1) + 0.5 * y2 * jy0
        A21 = 0.5 * (y0 * ja1 - jy0) + 0.5 * y2 * jy1
        C00 = A11 * A22 - A12 * A21
        C01 = A02 * A21 - A01 * A22
        C02 = A01 * A12 - A02 * A11
        det = A00 * C00 + A10 * C01 + A20 * C02
        idet = 1.0 / det
        C10 = A12 * A20 - A10 * A22
        C11 = A00 * A22 - A02 * A20
        C12 = A02 * A10 - A00 * A12
        C20 = A10 * A21 - A11 * A20
        C21 = A01 * A20 - A00 * A21
        C22 = A00 * A11 - A01 * A10
        y0 -= idet * (C00 * f0 + C01 * f1 + C02 * f2)
        y1 -= idet * (C10 * f0 + C11 * f1 + C12 * f2)
        y2 -= idet * (C20 * f0 + C21 * f1 + C22 * f2)
    return False, y0, y1, y2, f0, f1, f2


@njit(**_INLINE)
def _solve_twist(s, b, ja, hc, tol):
    """Newton on ja (s + s^3 / 4) + hc s = b from the start s: the Cayley vector (0, 0, s) of a node
    that turns about its d3 only (a driven hub, ``rod.hub``; Phi of ``_solve_rotation`` along d3)."""
    for _ in range(_NEWTON_MAX_ITER):
        g = ja * (s + 0.25 * s * s * s) + hc * s - b
        if abs(g) <= tol:
            break
        s -= g / (ja * (1.0 + 0.75 * s * s) + hc)
    return s


@njit(**_INLINE)
def _applied_loads(i, R, r, v, inputs, work_f):
    """work_f <- applied world force and torque of every node at step i of the call."""
    ext_idx = inputs.ext_idx
    ext_w = inputs.ext_w
    pd_idx = inputs.pd_idx
    pd_target = inputs.pd_target
    pd_gain = inputs.pd_gain
    for a in range(len(work_f)):
        for c in range(6):
            work_f[a, c] = 0.0
    for j in range(len(ext_idx)):
        a = ext_idx[j]
        for c in range(3):
            work_f[a, c] += ext_w[i, j, c] + (R[a, c, 0] * ext_w[i, j, 6] + R[a, c, 1] * ext_w[i, j, 7]
                                              + R[a, c, 2] * ext_w[i, j, 8])
            work_f[a, 3 + c] += ext_w[i, j, 3 + c] + (R[a, c, 0] * ext_w[i, j, 9]
                                                      + R[a, c, 1] * ext_w[i, j, 10]
                                                      + R[a, c, 2] * ext_w[i, j, 11])
    for j in range(len(pd_idx)):
        a = pd_idx[j]
        for c in range(3):
            work_f[a, c] += pd_gain[j, 0] * (pd_target[i, j, c] - r[a, c]) - pd_gain[j, 1] * v[a, c]


@njit(**_INLINE)
def _segment(a, i, R, r, Ra00, Ra01, Ra02, Ra10, Ra11, Ra12, Ra20, Ra21, Ra22, rod, inputs, h, Kp, Gp, record):
    """Stress resultants of segment a (nodes a, a + 1) in the old configuration at step i, R_a =
    Ra..: returns (n_a spatial force, T_a torque in frame a, T'_a = Q^T (T - p x c) torque carried
    to node a + 1 in its frame, elastic energy of the segment when ``record``). Updates Kp, Gp when
    ``rod.kv_on``. The tendons routed through the segment add tau t and tau rho x t to its
    resultants (``rod.tendons``)."""
    l = rod.length
    C1 = rod.C1
    C2 = rod.C2
    K0 = rod.K0
    G0 = rod.G0
    Rb00 = R[a + 1, 0, 0]
    Rb01 = R[a + 1, 0, 1]
    Rb02 = R[a + 1, 0, 2]
    Rb10 = R[a + 1, 1, 0]
    Rb11 = R[a + 1, 1, 1]
    Rb12 = R[a + 1, 1, 2]
    Rb20 = R[a + 1, 2, 0]
    Rb21 = R[a + 1, 2, 1]
    Rb22 = R[a + 1, 2, 2]
    # Q = R_a^T R_{a+1}
    Q00 = Ra00 * Rb00 + Ra10 * Rb10 + Ra20 * Rb20
    Q01 = Ra00 * Rb01 + Ra10 * Rb11 + Ra20 * Rb21
    Q02 = Ra00 * Rb02 + Ra10 * Rb12 + Ra20 * Rb22
    Q10 = Ra01 * Rb00 + Ra11 * Rb10 + Ra21 * Rb20
    Q11 = Ra01 * Rb01 + Ra11 * Rb11 + Ra21 * Rb21
    Q12 = Ra01 * Rb02 + Ra11 * Rb12 + Ra21 * Rb22
    Q20 = Ra02 * Rb00 + Ra12 * Rb10 + Ra22 * Rb20
    Q21 = Ra02 * Rb01 + Ra12 * Rb11 + Ra22 * Rb21
    Q22 = Ra02 * Rb02 + Ra12 * Rb12 + Ra22 * Rb22
    d0 = r[a + 1, 0] - r[a, 0]
    d1 = r[a + 1, 1] - r[a, 1]
    d2 = r[a + 1, 2] - r[a, 2]
    # p = R_a^T d
    p0 = Ra00 * d0 + Ra10 * d1 + Ra20 * d2
    p1 = Ra01 * d0 + Ra11 * d1 + Ra21 * d2
    p2 = Ra02 * d0 + Ra12 * d1 + Ra22 * d2
    # x = cay^-1(Q) = 2/(1 + tr Q) vee(Q - Q^T)
    s = 2.0 / (1.0 + Q00 + Q11 + Q22)
    x0 = s * (Q21 - Q12)
    x1 = s * (Q02 - Q20)
    x2 = s * (Q10 - Q01)
    # u = 2 (I + Q)^-1 p = p - x x p / 2
    u0 = p0 - 0.5 * (x1 * p2 - x2 * p1)
    u1 = p1 - 0.5 * (x2 * p0 - x0 * p2)
    u2 = p2 - 0.5 * (x0 * p1 - x1 * p0)
    il = 1.0 / l
    ka0 = x0 * il
    ka1 = x1 * il
    ka2 = x2 * il
    ga0 = u0 * il
    ga1 = u1 * il
    ga2 = u2 * il
    eg0 = ga0 - G0[a, 0]
    eg1 = ga1 - G0[a, 1]
    eg2 = ga2 - G0[a, 2]
    ek0 = ka0 - K0[a, 0]
    ek1 = ka1 - K0[a, 1]
    ek2 = ka2 - K0[a, 2]
    N0 = C1[a, 0] * eg0
    N1 = C1[a, 1] * eg1
    N2 = C1[a, 2] * eg2
    M0 = C2[a, 0] * ek0
    M1 = C2[a, 1] * ek1
    M2 = C2[a, 2] * ek2
    e = 0.0
    if record:
        e = 0.5 * l * (N0 * eg0 + N1 * eg1 + N2 * eg2 + M0 * ek0 + M1 * ek1 + M2 * ek2)
    if rod.kv_on:
        D1 = rod.D1
        D2 = rod.D2
        ih = 1.0 / h
        N0 += D1[a, 0] * (ga0 - Gp[a, 0]) * ih
        N1 += D1[a, 1] * (ga1 - Gp[a, 1]) * ih
        N2 += D1[a, 2] * (ga2 - Gp[a, 2]) * ih
        M0 += D2[a, 0] * (ka0 - Kp[a, 0]) * ih
        M1 += D2[a, 1] * (ka1 - Kp[a, 1]) * ih
        M2 += D2[a, 2] * (ka2 - Kp[a, 2]) * ih
        Gp[a, 0] = ga0
        Gp[a, 1] = ga1
        Gp[a, 2] = ga2
        Kp[a, 0] = ka0
        Kp[a, 1] = ka1
        Kp[a, 2] = ka2
    # tendons: N += tau t, M += tau rho x t with t the unit tangent of Gamma + K x rho + rho'
    tendon_end = inputs.tendon_end
    for j in range(len(tendon_end)):
        tau = inputs.tendon_tension[i, j]
        if a < tendon_end[j] and tau > 0.0:
            t0, t1, t2, o0, o1, o2 = _tendon_tangent(inputs.tendon_route, j, a, ga0, ga1, ga2, ka0, ka1, ka2)
            s = tau / math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
            t0 *= s
            t1 *= s
            t2 *= s
            N0 += t0
            N1 += t1
            N2 += t2
            M0 += o1 * t2 - o2 * t1
            M1 += o2 * t0 - o0 * t2
            M2 += o0 * t1 - o1 * t0
    # c = N + x x N / 2
    c0 = N0 + 0.5 * (x1 * N2 - x2 * N1)
    c1 = N1 + 0.5 * (x2 * N0 - x0 * N2)
    c2 = N2 + 0.5 * (x0 * N1 - x1 * N0)
    # T = M + x x M / 2 + x (x.M) / 4 + u x c / 2
    xm = 0.25 * (x0 * M0 + x1 * M1 + x2 * M2)
    T0 = M0 + 0.5 * (x1 * M2 - x2 * M1) + xm * x0 + 0.5 * (u1 * c2 - u2 * c1)
    T1 = M1 + 0.5 * (x2 * M0 - x0 * M2) + xm * x1 + 0.5 * (u2 * c0 - u0 * c2)
    T2 = M2 + 0.5 * (x0 * M1 - x1 * M0) + xm * x2 + 0.5 * (u0 * c1 - u1 * c0)
    # n_a = R_a c (spatial)
    n0 = Ra00 * c0 + Ra01 * c1 + Ra02 * c2
    n1 = Ra10 * c0 + Ra11 * c1 + Ra12 * c2
    n2 = Ra20 * c0 + Ra21 * c1 + Ra22 * c2
    # T' = Q^T (T - p x c), carried to node a + 1
    z0 = T0 - (p1 * c2 - p2 * c1)
    z1 = T1 - (p2 * c0 - p0 * c2)
    z2 = T2 - (p0 * c1 - p1 * c0)
    q0 = Q00 * z0 + Q10 * z1 + Q20 * z2
    q1 = Q01 * z0 + Q11 * z1 + Q21 * z2
    q2 = Q02 * z0 + Q12 * z1 + Q22 * z2
    return n0, n1, n2, T0, T1, T2, q0, q1, q2, e


@njit(**_INLINE)
def _node(a, i, row, record, h, F0, F1, F2, tb0, tb1, tb2, rod, state, inputs, out):
    """Advance node a from the total non-inertial force F (world, without drag) and body torque
    tb: r, v, w, R updated in place, outputs of the sample ``row`` written when ``record``.
    Returns (status, kinetic energy of the node when ``record``)."""
    l = rod.length
    inertia = rod.inertia
    R = state.rotations
    r = state.positions
    v = state.velocities
    w = state.angular_velocities
    presc_idx = inputs.presc_idx
    presc_r = inputs.presc_r
    presc_R = inputs.presc_R
    save_slot = out.save_slot
    out_v = out.velocities
    out_w = out.angular_velocities
    out_rf = out.reaction_forces
    out_rt = out.reaction_torques
    m = rod.mass[a]
    ja0 = inertia[a, 0]
    ja1 = inertia[a, 1]
    ja2 = inertia[a, 2]
    vo0 = v[a, 0]
    vo1 = v[a, 1]
    vo2 = v[a, 2]
    wo0 = w[a, 0]
    wo1 = w[a, 1]
    wo2 = w[a, 2]
    cta = rod.ct[a]
    kd = rod.kind[a]
    slot = save_slot[a]
    # row of node a in the prescribed-motion arrays (-1: none); the last match, as a forward
    # search would find; jq starts as an int64 (no extra type-inference pass)
    jq = len(presc_idx) - 1
    if kd == FREE:
        jq = -1
    while jq >= 0 and presc_idx[jq] != a:
        jq -= 1
    # ---- translation (T) ----
    if kd == FREE:
        den = 1.0 / (m + h * cta)
        vn0 = (m * vo0 + h * F0) * den
        vn1 = (m * vo1 + h * F1) * den
        vn2 = (m * vo2 + h * F2) * den
        dx0 = h * vn0
        dx1 = h * vn1
        dx2 = h * vn2
        if not (dx0 * dx0 + dx1 * dx1 + dx2 * dx2 < l * l):
            return DIVERGED, 0.0
        r[a, 0] += dx0
        r[a, 1] += dx1
        r[a, 2] += dx2
    else:
        if kd == HUB_PUSHED or kd == HUB_DRIVEN:
            # a pushed hub: free along its axis d3 (m holds the hub's mass), held across it
            e0 = R[a, 0, 2]
            e1 = R[a, 1, 2]
            e2 = R[a, 2, 2]
            sp = (m * (vo0 * e0 + vo1 * e1 + vo2 * e2) + h * (F0 * e0 + F1 * e1 + F2 * e2)) / (m + h * cta)
            vn0 = sp * e0
            vn1 = sp * e1
            vn2 = sp * e2
            if not (h * h * sp * sp < l * l):
                return DIVERGED, 0.0
            r[a, 0] += h * vn0
            r[a, 1] += h * vn1
            r[a, 2] += h * vn2
        elif jq >= 0:
            vn0 = (presc_r[i + 1, jq, 0] - r[a, 0]) / h
            vn1 = (presc_r[i + 1, jq, 1] - r[a, 1]) / h
            vn2 = (presc_r[i + 1, jq, 2] - r[a, 2]) / h
            r[a, 0] = presc_r[i + 1, jq, 0]
            r[a, 1] = presc_r[i + 1, jq, 1]
            r[a, 2] = presc_r[i + 1, jq, 2]
        else:
            vn0 = 0.0
            vn1 = 0.0
            vn2 = 0.0
        if record and slot >= 0:
            # reaction = inertia + drag - applied
            out_rf[row, slot, 0] = (m * (vn0 - vo0) / h + cta * vn0) - F0
            out_rf[row, slot, 1] = (m * (vn1 - vo1) / h + cta * vn1) - F1
            out_rf[row, slot, 2] = (m * (vn2 - vo2) / h + cta * vn2) - F2
    # ---- rotation (R) ----
    # b = h pi~ ; pi~ = J w- - h/2 w- x J w- + h^2/4 (w- . J w-) w- + h tb
    jw0 = ja0 * wo0
    jw1 = ja1 * wo1
    jw2 = ja2 * wo2
    wjw = wo0 * jw0 + wo1 * jw1 + wo2 * jw2
    hh = h * h
    half_h = 0.5 * h
    cw = 0.25 * hh * wjw
    b0 = h * (jw0 - half_h * (wo1 * jw2 - wo2 * jw1) + cw * wo0 + h * tb0)
    b1 = h * (jw1 - half_h * (wo2 * jw0 - wo0 * jw2) + cw * wo1 + h * tb1)
    b2 = h * (jw2 - half_h * (wo0 * jw1 - wo1 * jw0) + cw * wo2 + h * tb2)
    hc = h * rod.cr[a]
    # held: the rotation is given (clamped, or a driven hub's: prescribed, or its twist solved below)
    held = kd != FREE and kd != PINNED
    if kd == CLAMPED or kd == HUB_PUSHED:
        y0 = 0.0
        y1 = 0.0
        y2 = 0.0
        if jq >= 0:
            # y = cay^-1(A), A = R^T R_next: s = 2 / (1 + tr A), y = s vee(A - A^T)
            tr, sk0, sk1, sk2 = _relative_rotation_parts(R[a], presc_R[i + 1, jq], 1.0)  # tr = 1 + tr A
            s = 2.0 / tr
            y0 = s * sk0
            y1 = s * sk1
            y2 = s * sk2
    else:
        # linearised solution as the start: one Newton iteration fewer than y = h w-
        y0 = b0 / (ja0 + hc)
        y1 = b1 / (ja1 + hc)
        y2 = b2 / (ja2 + hc)
    # Newton on Phi(y) = J y + y x J y / 2 + (y.Jy) y / 4 + h cr y - b; for a clamped node
    # y is prescribed and Phi(y) = h^2 (body reaction torque)
    tol = _NEWTON_RTOL * (abs(b0) + abs(b1) + abs(b2)
                          + (ja0 + ja1 + ja2) * h * (abs(wo0) + abs(wo1) + abs(wo2)))
    if kd == HUB_TWISTED or kd == HUB_DRIVEN:
        # a twisted hub: turns about its d3 only (ja2 holds the hub's inertia)
        y0 = 0.0
        y1 = 0.0
        y2 = _solve_twist(y2, b2, ja2, hc, tol)
    ok, y0, y1, y2, f0, f1, f2 = _solve_rotation(held, y0, y1, y2, b0, b1, b2, ja0, ja1, ja2, hc, tol)
    if not ok:
        return NEWTON_FAILED, 0.0
    if kd != CLAMPED:
        if not (y0 * y0 + y1 * y1 + y2 * y2 < 0.25):
            return DIVERGED, 0.0
    ih = 1.0 / h
    wn0 = y0 * ih
    wn1 = y1 * ih
    wn2 = y2 * ih
    e_kin = 0.0
    if record:
        jwn0 = ja0 * wn0
        jwn1 = ja1 * wn1
        jwn2 = ja2 * wn2
        e_kin = 0.25 * (m * (vo0 * vo0 + vo1 * vo1 + vo2 * vo2 + vn0 * vn0 + vn1 * vn1 + vn2 * vn2)
                        + wjw + wn0 * jwn0 + wn1 * jwn1 + wn2 * jwn2)
        if slot >= 0:
            mw0 = 0.5 * (wo0 + wn0)
            mw1 = 0.5 * (wo1 + wn1)
            mw2 = 0.5 * (wo2 + wn2)
            for c in range(3):
                out_w[row, slot, c] = R[a, c, 0] * mw0 + R[a, c, 1] * mw1 + R[a, c, 2] * mw2
            out_v[row, slot, 0] = 0.5 * (vo0 + vn0)
            out_v[row, slot, 1] = 0.5 * (vo1 + vn1)
            out_v[row, slot, 2] = 0.5 * (vo2 + vn2)
            # reaction torque: Phi(y) / h^2 (body) of a clamped node, in the world frame; none
            # for pinned and free nodes (and no reaction force for free ones)
            ihh = 1.0 / hh
            for c in range(3):
                rt = 0.0
                if held:
                    rt = (R[a, c, 0] * f0 + R[a, c, 1] * f1 + R[a, c, 2] * f2) * ihh
                out_rt[row, slot, c] = rt
                if kd == FREE:
                    out_rf[row, slot, c] = 0.0
    v[a, 0] = vn0
    v[a, 1] = vn1
    v[a, 2] = vn2
    w[a, 0] = wn0
    w[a, 1] = wn1
    w[a, 2] = wn2
    # R <- R cay(y)
    if kd == CLAMPED and y0 == 0.0 and y1 == 0.0 and y2 == 0.0:
        return OK, e_kin
    times_cayley_into(R[a], y0, y1, y2, 4.0 / (4.0 + (y0 * y0 + y1 * y1 + y2 * y2)), R[a])
    return OK, e_kin


def _build_advance(stamp):
    """``advance_into``, the cached rod step, closed over ``stamp`` (``kernel_stamp()``, see the module
    docstring)."""

    @njit(fastmath={"contract"}, error_model="numpy", cache=True, no_cfunc_wrapper=True, no_rewrites=True)
    def advance_into(rod, state, inputs, out, h, k0, n_steps, stride, s0, work_f):
        """Advance one rod by ``n_steps`` steps of size ``h`` [s]; returns (status, step index).

        rod : LumpedRod; state : StateArrays, advanced in place; inputs : StepInputs of the steps of
        this call (step i at t = (k0 + i) h); out : Samples. A sample is written when
        (k0 + i) % stride == 0, at row (k0 + i) // stride - s0, for the nodes with
        out.save_slot >= 0, and the energies of the whole rod (with obstacles, the contact loads into
        inputs.contact_samples). work_f (n, 6): scratch for the applied world force and torque of each
        node. status is OK, DIVERGED, NEWTON_FAILED or MAGNET_TOO_CLOSE; the step index
        is k0 + n_steps, or that of the failed step.
        """
        if stamp < 0:  # never true: references the stamp so that it is a closure variable
            return -1, k0
        R = state.rotations
        r = state.positions
        Kp = state.prev_curvature
        Gp = state.prev_shear
        mass = rod.mass
        save_slot = out.save_slot
        out_r = out.positions
        out_q = out.quaternions
        out_f = out.forces
        out_t = out.torques
        out_e = out.energy
        n = len(r)
        g0 = rod.gravity[0]
        g1 = rod.gravity[1]
        g2 = rod.gravity[2]
        for i in range(n_steps):
            k = k0 + i
            record = (k % stride) == 0
            row = k // stride - s0
            # ---- applied loads at t_k into work_f (world force, world torque) ----
            _applied_loads(i, R, r, state.velocities, inputs, work_f)
            # ---- magnetic loads from the configuration at t_k (none without magnets) ----
            if _magnet_loads_if_any(i, row, record, R, r, inputs, work_f) >= 0:
                return MAGNET_TOO_CLOSE, k
            # ---- tensions of the tendons driven by a displacement, from the configuration at t_k ----
            if len(inputs.tendon_stiffness) > 0:
                _tendon_springs(i, R, r, rod, inputs)
            # ---- contact loads from the configuration at t_k (none without obstacles) ----
            _contact_loads_if_any(row, record, h, R, r, state.velocities, state.angular_velocities, rod, inputs,
                                  save_slot, work_f)
            e_kin = 0.0
            e_el = 0.0
            e_g = 0.0
            # carried from segment a - 1: spatial force n_{a-1}, torque T'_{a-1} in frame a
            np0 = 0.0
            np1 = 0.0
            np2 = 0.0
            tp0 = 0.0
            tp1 = 0.0
            tp2 = 0.0
            for a in range(n):
                # R_a is still the old rotation: node a is updated at the end of this iteration
                Ra00 = R[a, 0, 0]
                Ra01 = R[a, 0, 1]
                Ra02 = R[a, 0, 2]
                Ra10 = R[a, 1, 0]
                Ra11 = R[a, 1, 1]
                Ra12 = R[a, 1, 2]
                Ra20 = R[a, 2, 0]
                Ra21 = R[a, 2, 1]
                Ra22 = R[a, 2, 2]
                # ---- segment a (nodes a, a + 1), old configuration; none after the last node ----
                # n_a (world), T_a (frame a), T'_a (frame a + 1)
                n0 = n1 = n2 = T0 = T1 = T2 = q0 = q1 = q2 = 0.0
                if a < n - 1:
                    n0, n1, n2, T0, T1, T2, q0, q1, q2, e = _segment(
                        a, i, R, r, Ra00, Ra01, Ra02, Ra10, Ra11, Ra12, Ra20, Ra21, Ra22, rod, inputs, h, Kp, Gp,
                        record)
                    e_el += e
                # ---- node a: internal force and torque from segments a - 1 and a, then the update ----
                fi0 = n0 - np0
                fi1 = n1 - np1
                fi2 = n2 - np2
                ti0 = T0 - tp0
                ti1 = T1 - tp1
                ti2 = T2 - tp2
                np0 = n0
                np1 = n1
                np2 = n2
                tp0 = q0
                tp1 = q1
                tp2 = q2
                m = mass[a]
                te0 = work_f[a, 3]
                te1 = work_f[a, 4]
                te2 = work_f[a, 5]
                # total force on the node except inertia and viscous drag
                F0 = fi0 + work_f[a, 0] + m * g0
                F1 = fi1 + work_f[a, 1] + m * g1
                F2 = fi2 + work_f[a, 2] + m * g2
                # body torque
                tb0 = ti0 + Ra00 * te0 + Ra10 * te1 + Ra20 * te2
                tb1 = ti1 + Ra01 * te0 + Ra11 * te1 + Ra21 * te2
                tb2 = ti2 + Ra02 * te0 + Ra12 * te1 + Ra22 * te2
                if record:
                    e_g -= m * (g0 * r[a, 0] + g1 * r[a, 1] + g2 * r[a, 2])
                    slot = save_slot[a]
                    if slot >= 0:
                        for c in range(3):
                            out_r[row, slot, c] = r[a, c]
                            out_f[row, slot, c] = work_f[a, c]
                            out_t[row, slot, c] = work_f[a, 3 + c]
                        _quaternion_into(R[a], out_q[row, slot])
                status, ek = _node(a, i, row, record, h, F0, F1, F2, tb0, tb1, tb2, rod, state, inputs, out)
                if status != OK:
                    return status, k
                e_kin += ek
            if record:
                out_e[row, 0] = e_kin
                out_e[row, 1] = e_el
                out_e[row, 2] = e_g
                _applied_outputs_if_any(row, inputs, out)
        return OK, k0 + n_steps

    return advance_into


advance_into = _build_advance(kernel_stamp())


def contact_rows(inputs, b):
    """Rod ``b``'s contact fields (contact_kind .. contact_applied, the 12 of ``StepInputs``) of batched
    ``inputs`` whose contact fields carry a leading batch axis (``advance_batch``); the shared empty
    fields for inputs without obstacles. Compiled code only (a numba ``overload``)."""
    raise NotImplementedError("compiled code only")


@overload(contact_rows, jit_options=_ROWS)
def _contact_rows_impl(inputs, b):
    if absent(inputs, "contact_kind"):
        return lambda inputs, b: (None, inputs.contact_geom, inputs.contact_range, inputs.contact_friction,
                                  inputs.contact_points, inputs.contact_radii, inputs.contact_mesh_index,
                                  inputs.contact_mesh_values, inputs.contact_node, inputs.contact_segment,
                                  inputs.contact_samples, inputs.contact_applied)
    return lambda inputs, b: (inputs.contact_kind[b], inputs.contact_geom[b], inputs.contact_range[b],
                              inputs.contact_friction[b], inputs.contact_points[b], inputs.contact_radii[b],
                              inputs.contact_mesh_index[b], inputs.contact_mesh_values[b], inputs.contact_node[b],
                              inputs.contact_segment[b], inputs.contact_samples[b], inputs.contact_applied[b])


def magnet_rows(inputs, b):
    """Rod ``b``'s magnetic fields (magnet_node .. magnet_failed, the 11 of ``StepInputs``) of batched
    ``inputs`` with magnets: the magnets and sources shared (magnet_node, magnet_body, source_positions,
    source_moments: one rod design, one set of coils), rows b of the currents and of the output
    buffers (source_currents .. magnet_failed, (B, ...) in ``inputs``); the shared empty fields, untouched,
    for inputs without magnets. Compiled code only (a numba ``overload``)."""
    raise NotImplementedError("compiled code only")


@overload(magnet_rows, jit_options=_ROWS)
def _magnet_rows_impl(inputs, b):
    if absent(inputs, "magnet_node"):
        return lambda inputs, b: (None, inputs.magnet_body, inputs.source_positions, inputs.source_moments,
                                  inputs.source_currents, inputs.magnet_positions, inputs.magnet_rotations,
                                  inputs.magnet_fields, inputs.magnet_gradients, inputs.magnet_wrenches,
                                  inputs.magnet_failed)
    return lambda inputs, b: (inputs.magnet_node, inputs.magnet_body, inputs.source_positions, inputs.source_moments,
                              inputs.source_currents[b], inputs.magnet_positions[b], inputs.magnet_rotations[b],
                              inputs.magnet_fields[b], inputs.magnet_gradients[b], inputs.magnet_wrenches[b],
                              inputs.magnet_failed[b])


@njit(**_ROWS)
def rod_inputs(inp, b, contact, magnets):
    """Rod ``b``'s ``StepInputs`` of batched inputs ``inp`` (``advance_batch``, the environments'
    kernel): rows b of ext_w, pd_target, presc_r, presc_R, tendon_tension and tendon_displacement
    ((B, ...) in ``inp``), the contact fields ``contact`` passed explicitly per rod (the 12 of
    contact_kind .. contact_applied, in ``StepInputs`` order: a batch's rows, ``contact_rows``, or
    arrays the rods share), the magnetic fields ``magnets`` likewise (the 11 of magnet_node ..
    magnet_failed: ``magnet_rows``), the rest shared."""
    kind, geom, rng, friction, points, radii, mesh_index, mesh_values, node, segment, samples, applied = contact
    (m_node, m_body, s_positions, s_moments, s_currents, m_positions, m_rotations, m_fields, m_gradients,
     m_wrenches, m_failed) = magnets
    return StepInputs(inp.ext_idx, inp.ext_w[b], inp.pd_idx, inp.pd_target[b], inp.pd_gain, inp.presc_idx,
                      inp.presc_r[b], inp.presc_R[b], inp.tendon_route, inp.tendon_end, inp.tendon_tension[b],
                      inp.tendon_stiffness, inp.tendon_rest, inp.tendon_displacement[b], kind, geom, rng, friction,
                      points, radii, mesh_index, mesh_values, node, segment, samples, applied, m_node, m_body,
                      s_positions, s_moments, s_currents, m_positions, m_rotations, m_fields, m_gradients,
                      m_wrenches, m_failed)


@njit(**_ROWS)
def rod_state(st, b):
    """Rod ``b``'s ``StateArrays`` (views) of a batch's states, (B, ...) each."""
    return StateArrays(st.rotations[b], st.positions[b], st.velocities[b], st.angular_velocities[b],
                       st.prev_curvature[b], st.prev_shear[b])


@njit(**_ROWS)
def rod_samples(out, b):
    """Rod ``b``'s ``Samples`` (views) of a batch's outputs, (B, ...) each except save_slot."""
    return Samples(out.save_slot, out.positions[b], out.quaternions[b], out.velocities[b], out.angular_velocities[b],
                   out.forces[b], out.torques[b], out.reaction_forces[b], out.reaction_torques[b], out.energy[b])


def _build_batch(stamp):
    """``advance_batch`` over ``advance_into``, closed over ``stamp`` (see the module docstring)."""

    @njit(nogil=True, cache=True)
    def advance_batch(rod, state, inputs, out, h, k0, n_steps, stride, s0, status, b0, b1):
        """Advance rods b0 .. b1 - 1 of a batch of B independent rods of one ``rod`` (see
        ``advance_into``): state, inputs (except the node indices, gains and tendon routing; the
        contact fields with obstacles, each rod its own: ``contact_rows``; with magnets, the currents
        and the magnets' buffers: ``magnet_rows``) and out (except save_slot) carry a leading batch
        axis (B, ...). status (B, 2) int64 receives (code, step) per rod. Without the GIL: blocks of
        rods run at once on threads (``rod.threads.over_rods``)."""
        if stamp < 0:  # never true: references the stamp so that it is a closure variable
            return
        for b in range(b0, b1):
            work_f = np.empty((state.positions.shape[1], 6))
            code, step = advance_into(rod, rod_state(state, b),
                                      rod_inputs(inputs, b, contact_rows(inputs, b), magnet_rows(inputs, b)),
                                      rod_samples(out, b), h, k0, n_steps, stride, s0, work_f)
            status[b, 0] = code
            status[b, 1] = step

    return advance_batch


advance_batch = _build_batch(kernel_stamp())


def _build_wrenches(stamp):
    """The contact and magnetic loads of the start at rest, closed over ``stamp``."""

    @njit(fastmath={"contract"}, error_model="numpy", cache=True, no_cfunc_wrapper=True, no_rewrites=True)
    def contact_wrench_into(h, R, r, v, w, rod, inputs, work_f):
        """work_f (n, 6) += the contact force [N] and torque [N m] (world frame) of every node in the
        configuration R (n, 3, 3), r (n, 3) [m] with the staggered velocities v (n, 3) [m/s] (world)
        and w (n, 3) [rad/s] (body), step h [s], as ``advance_into`` applies them (``inputs`` a
        ``StepInputs`` with contact; its tracked vessel segments are updated). For the start at rest."""
        if stamp < 0:  # never true: references the stamp so that it is a closure variable
            return
        # step 0, nothing recorded; typed int64 and bool, so that advance_into's compiled loads serve
        # (a literal 0 or False would compile them again, specialised on it)
        _contact_loads(np.int64(0), np.bool_(False), h, R, r, v, w, rod, inputs, inputs.contact_kind, work_f)

    @njit(fastmath={"contract"}, error_model="numpy", cache=True, no_cfunc_wrapper=True, no_rewrites=True)
    def magnet_wrench_into(R, r, inputs, work_f):
        """work_f (n, 6) += the magnets' force [N] and torque [N m] (world frame) in the configuration
        R (n, 3, 3), r (n, 3) [m] with the currents of the first step of ``inputs``, as ``advance_into``
        applies them (outputs in the scratch row). Returns -1, or the index of a magnet too close to a
        source. For the start at rest."""
        if stamp < 0:  # never true: references the stamp so that it is a closure variable
            return -2
        first = np.int64(0)   # step 0, row 0, nothing recorded: typed as advance_into's (see contact_wrench_into)
        return _magnet_loads(first, first, np.bool_(False), R, r, inputs, work_f)

    return contact_wrench_into, magnet_wrench_into


contact_wrench_into, magnet_wrench_into = _build_wrenches(kernel_stamp())


def advance(rod, state, inputs, out, h, k0, n_steps, stride, s0):
    """``advance_into`` with its scratch array allocated here; returns (status, step index)."""
    return advance_into(rod, state, inputs, out, h, k0, n_steps, stride, s0,
                        np.empty((len(state.positions), 6)))
