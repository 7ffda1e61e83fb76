"""The magnetic kernels (docs/magnetic.md §2.5): the field and gradient of point-dipole sources, and
the wrench of the magnets embedded in the rod (``rod.magnetic.MagneticDipoles``) applied to the two
nodes around each. ``_magnet_loads_if_any`` is inlined into ``rod.kernels`` and ``rod.implicit`` (see
``rod.kernel_records``); ``field_gradient_into`` is cached on its own (it inlines nothing)."""

import math

import numpy as np
from numba import njit
from numba.extending import overload

from .kernel_records import _INLINE, _relative_rotation_parts, absent, times_cayley_into

MU0 = 4e-7 * math.pi
"""Vacuum permeability [T m/A]."""

MIN_DIPOLE_DISTANCE = 0.02
"""Closest a magnet may come to a dipole source [m]: the point-dipole field is singular at the
source (``softrnn.magnetics.coils.MIN_DISTANCE``)."""


@njit(cache=True, fastmath={"contract"}, error_model="numpy")
def field_gradient_into(coil_pos, coil_moment, currents, p0, p1, p2, B, G):
    """B (3,) [T] and G (3, 3) [T/m] at the point (p0, p1, p2) [m] for coils at coil_pos (n, 3) with
    per-ampere moments coil_moment (n, 3) and currents (n,) [A]. Returns the distance [m] to the
    nearest coil (the caller rejects distances below ``MIN_DIPOLE_DISTANCE``)."""
    c = MU0 / (4.0 * math.pi)
    for i in range(3):
        B[i] = 0.0
        for j in range(3):
            G[i, j] = 0.0
    dmin = np.inf
    for k in range(len(currents)):
        I = currents[k]
        r0 = p0 - coil_pos[k, 0]
        r1 = p1 - coil_pos[k, 1]
        r2 = p2 - coil_pos[k, 2]
        R2 = r0 * r0 + r1 * r1 + r2 * r2
        R = math.sqrt(R2)
        if R < dmin:
            dmin = R
        m0 = I * coil_moment[k, 0]
        m1 = I * coil_moment[k, 1]
        m2 = I * coil_moment[k, 2]
        rm = r0 * m0 + r1 * m1 + r2 * m2
        iR3 = 1.0 / (R2 * R)
        iR5 = iR3 / R2
        B[0] += c * (3.0 * r0 * rm * iR5 - m0 * iR3)
        B[1] += c * (3.0 * r1 * rm * iR5 - m1 * iR3)
        B[2] += c * (3.0 * r2 * rm * iR5 - m2 * iR3)
        g = 3.0 * c * iR5
        q = 5.0 * rm / R2
        G[0, 0] += g * (2.0 * m0 * r0 + rm - q * r0 * r0)
        G[1, 1] += g * (2.0 * m1 * r1 + rm - q * r1 * r1)
        G[2, 2] += g * (2.0 * m2 * r2 + rm - q * r2 * r2)
        g01 = g * (m0 * r1 + r0 * m1 - q * r0 * r1)
        g02 = g * (m0 * r2 + r0 * m2 - q * r0 * r2)
        g12 = g * (m1 * r2 + r1 * m2 - q * r1 * r2)
        G[0, 1] += g01
        G[1, 0] += g01
        G[0, 2] += g02
        G[2, 0] += g02
        G[1, 2] += g12
        G[2, 1] += g12
    return dmin


@njit(**_INLINE)
def _interp_rotation_into(R, a, t, out):
    """out (3, 3) <- R_a cay(t x), x = cay^-1(R_a^T R_{a+1}) (rotation a fraction t from node a to a + 1)."""
    # vee(Q - Q^T) and tr Q of Q = R_a^T R_b, Q_ij = sum_c R_a[c, i] R_b[c, j]
    tr, v0, v1, v2 = _relative_rotation_parts(R[a], R[a + 1], 0.0)
    s = 2.0 * t / (1.0 + tr)
    y0 = s * v0
    y1 = s * v1
    y2 = s * v2
    times_cayley_into(R[a], y0, y1, y2, 4.0 / (4.0 + y0 * y0 + y1 * y1 + y2 * y2), out)


@njit(**_INLINE)
def _magnet_loads(i, row, record, R, r, inputs, work_f):
    """work_f += the wrench of every magnet of ``inputs`` at step i (docs/magnetic.md §2.5): magnet j,
    a fraction t of the way from node a to a + 1, sits at p = (1 - t) r_a + t r_{a+1} with the
    rotation R_a cay(t cay^-1(R_a^T R_{a+1})) and the moment mu = R mu_body; f = G mu and mu x B
    act at p, node a takes (1 - t) and node a + 1 t of both. The magnets' outputs go to row ``row``
    at a saved step (``record``), else to the scratch row. Returns -1, or the index of a magnet
    closer than ``MIN_DIPOLE_DISTANCE`` to a source (also in inputs.magnet_failed[0])."""
    mag_node = inputs.magnet_node
    body = inputs.magnet_body
    w = row if record else len(inputs.magnet_positions) - 1
    currents = inputs.source_currents[i]
    for j in range(len(mag_node)):
        a = mag_node[j]
        t = body[j, 0]
        P = inputs.magnet_positions[w, j]
        for c in range(3):
            P[c] = (1.0 - t) * r[a, c] + t * r[a + 1, c]
        Rm = inputs.magnet_rotations[w, j]
        _interp_rotation_into(R, a, t, Rm)
        mu0 = 0.0
        mu1 = 0.0
        mu2 = 0.0
        for c in range(3):
            mu0 += Rm[0, c] * body[j, 1 + c]
            mu1 += Rm[1, c] * body[j, 1 + c]
            mu2 += Rm[2, c] * body[j, 1 + c]
        B = inputs.magnet_fields[w, j]
        G = inputs.magnet_gradients[w, j]
        dmin = field_gradient_into(inputs.source_positions, inputs.source_moments, currents, P[0], P[1], P[2], B, G)
        if not dmin >= MIN_DIPOLE_DISTANCE:
            inputs.magnet_failed[0] = j
            return j
        W = inputs.magnet_wrenches[w, j]
        for c in range(3):
            W[c] = G[c, 0] * mu0 + G[c, 1] * mu1 + G[c, 2] * mu2
        W[3] = mu1 * B[2] - mu2 * B[1]
        W[4] = mu2 * B[0] - mu0 * B[2]
        W[5] = mu0 * B[1] - mu1 * B[0]
        for c in range(6):
            work_f[a, c] += (1.0 - t) * W[c]
            work_f[a + 1, c] += t * W[c]
    return -1


def _magnet_loads_if_any(i, row, record, R, r, inputs, work_f):
    """``_magnet_loads`` for inputs with magnets; -1 (nothing to do) for inputs whose ``magnet_node``
    is None. Compiled code only: the choice is made by type, so a rod without magnets never compiles
    the magnetic kernel."""
    raise NotImplementedError("compiled code only")


@overload(_magnet_loads_if_any, jit_options=_INLINE)
def _magnet_loads_if_any_impl(i, row, record, R, r, inputs, work_f):
    if absent(inputs, "magnet_node"):
        return lambda i, row, record, R, r, inputs, work_f: -1

    def magnets(i, row, record, R, r, inputs, work_f):
        return _magnet_loads(i, row, record, R, r, inputs, work_f)
    return magnets
