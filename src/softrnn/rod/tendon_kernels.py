"""The tendons' numba kernel: the tension of every tendon driven by a displacement, from its length
in the configuration at the start of a step (``rod.tendons``; inlined into ``rod.kernels`` and
``rod.implicit``, see ``rod.kernel_records``)."""

import math

from numba import njit

from .kernel_records import _INLINE, _segment_offset


@njit(**_INLINE)
def _tendon_tangent(route, j, a, ga0, ga1, ga2, ka0, ka1, ka2):
    """Tendon j's tangent t = Gamma + K x rho + rho' on segment a (not unit), and its offset rho
    [m] (body frame of node a): returns (t0, t1, t2, o0, o1, o2)."""
    o0 = route[j, a, 0]
    o1 = route[j, a, 1]
    o2 = route[j, a, 2]
    t0 = ga0 + ka1 * o2 - ka2 * o1 + route[j, a, 3]
    t1 = ga1 + ka2 * o0 - ka0 * o2 + route[j, a, 4]
    t2 = ga2 + ka0 * o1 - ka1 * o0 + route[j, a, 5]
    return t0, t1, t2, o0, o1, o2


@njit(**_INLINE)
def _tendon_springs(i, R, r, rod, inputs):
    """inputs.tendon_tension[i, j] <- k_j max(0, q_j - (l0_j - l_j)) for every tendon j driven by
    a displacement (stiffness k_j > 0), l_j = l sum_{a < e_j} |Gamma_a + K_a x rho_a + rho'_a| its
    discrete length in the configuration (R, r) at the start of step i (strains as in ``_segment``)."""
    stiffness = inputs.tendon_stiffness
    end = inputs.tendon_end
    route = inputs.tendon_route
    tension = inputs.tendon_tension
    l = rod.length
    il = 1.0 / l
    last = 0
    for j in range(len(stiffness)):
        if stiffness[j] > 0.0:
            tension[i, j] = 0.0  # the sum of |t| over the routed segments, first
            if end[j] > last:
                last = end[j]
    for a in range(last):
        Q00 = R[a, 0, 0] * R[a + 1, 0, 0] + R[a, 1, 0] * R[a + 1, 1, 0] + R[a, 2, 0] * R[a + 1, 2, 0]
        Q01 = R[a, 0, 0] * R[a + 1, 0, 1] + R[a, 1, 0] * R[a + 1, 1, 1] + R[a, 2, 0] * R[a + 1, 2, 1]
        Q02 = R[a, 0, 0] * R[a + 1, 0, 2] + R[a, 1, 0] * R[a + 1, 1, 2] + R[a, 2, 0] * R[a + 1, 2, 2]
        Q10 = R[a, 0, 1] * R[a + 1, 0, 0] + R[a, 1, 1] * R[a + 1, 1, 0] + R[a, 2, 1] * R[a + 1, 2, 0]
        Q11 = R[a, 0, 1] * R[a + 1, 0, 1] + R[a, 1, 1] * R[a + 1, 1, 1] + R[a, 2, 1] * R[a + 1, 2, 1]
        Q12 = R[a, 0, 1] * R[a + 1, 0, 2] + R[a, 1, 1] * R[a + 1, 1, 2] + R[a, 2, 1] * R[a + 1, 2, 2]
        Q20 = R[a, 0, 2] * R[a + 1, 0, 0] + R[a, 1, 2] * R[a + 1, 1, 0] + R[a, 2, 2] * R[a + 1, 2, 0]
        Q21 = R[a, 0, 2] * R[a + 1, 0, 1] + R[a, 1, 2] * R[a + 1, 1, 1] + R[a, 2, 2] * R[a + 1, 2, 1]
        Q22 = R[a, 0, 2] * R[a + 1, 0, 2] + R[a, 1, 2] * R[a + 1, 1, 2] + R[a, 2, 2] * R[a + 1, 2, 2]
        p0, p1, p2 = _segment_offset(a, R, r)
        s = 2.0 / (1.0 + Q00 + Q11 + Q22)
        x0 = s * (Q21 - Q12)
        x1 = s * (Q02 - Q20)
        x2 = s * (Q10 - Q01)
        ga0 = (p0 - 0.5 * (x1 * p2 - x2 * p1)) * il
        ga1 = (p1 - 0.5 * (x2 * p0 - x0 * p2)) * il
        ga2 = (p2 - 0.5 * (x0 * p1 - x1 * p0)) * il
        ka0 = x0 * il
        ka1 = x1 * il
        ka2 = x2 * il
        for j in range(len(stiffness)):
            if stiffness[j] > 0.0 and a < end[j]:
                t0, t1, t2, _, _, _ = _tendon_tangent(route, j, a, ga0, ga1, ga2, ka0, ka1, ka2)
                tension[i, j] += math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
    for j in range(len(stiffness)):
        if stiffness[j] > 0.0:
            stretch = inputs.tendon_displacement[i, j] - (inputs.tendon_rest[j] - l * tension[i, j])
            tension[i, j] = stiffness[j] * stretch if stretch > 0.0 else 0.0
