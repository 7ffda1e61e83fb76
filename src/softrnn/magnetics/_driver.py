"""Numba driver of the magnetic manipulator: per solver step, the magnet wrenches from the current pose
and coil currents, then one step of ``softrnn.rod.kernels.advance_into`` (magnetic.md §2.5).

Magnet j sits between nodes a = mag_node[j] and a + 1 at the fraction t = mag_frac[j] of that
segment. Its centre is p = (1 - t) r_a + t r_{a+1}, its rotation R_c = R_a cay(t cay^-1(R_a^T R_{a+1}))
and its moment mu = R_c mu_body. The force f = G mu and torque tau = mu x B act at p; node a takes
(1 - t) and node a + 1 takes t of both, which gives the same net force and the same moment about p.

Caching: numba checks a cached function against its own source file only, so a cached driver would
keep the old code of ``rod/kernels.py`` and ``magnetics/coils.py`` after they change (their kernels
are compiled into it). ``magnet_loads_into`` and ``drive`` are therefore built as closures over a
hash of those two files: numba puts closure variables into the cache key, so an edit there
recompiles them.
"""

import hashlib
from pathlib import Path

from numba import njit

from ..rod import kernels as _rod_kernels
from ..rod.kernels import OK, advance_into
from . import coils as _coils
from .coils import MIN_DISTANCE, field_gradient_into


def _dependency_stamp() -> str:
    """Hash of the source files whose kernels are compiled into this module's cached functions."""
    digest = hashlib.sha256()
    for module in (_rod_kernels, _coils):
        try:
            digest.update(Path(module.__file__).read_bytes())
        except (OSError, TypeError):  # no source file (frozen or zipped install): nothing to track
            digest.update(module.__name__.encode())
    return digest.hexdigest()[:16]


_STAMP = _dependency_stamp()

TOO_CLOSE = 10
"""Status: a magnet came closer than ``MIN_DISTANCE`` to a coil."""


@njit(cache=True, fastmath={"contract"}, error_model="numpy")
def _interp_rotation_into(R, a, t, out):
    """out (3, 3) <- R_a cay(t x), x = cay^-1(R_a^T R_{a+1}) (rotation a fraction t from node a to a + 1)."""
    # vee(Q - Q^T) and tr Q of Q = R_a^T R_b, Q_ij = sum_c R_a[c, i] R_b[c, j]
    tr = 0.0
    v0 = 0.0
    v1 = 0.0
    v2 = 0.0
    for c in range(3):
        A0 = R[a, c, 0]
        A1 = R[a, c, 1]
        A2 = R[a, c, 2]
        B0 = R[a + 1, c, 0]
        B1 = R[a + 1, c, 1]
        B2 = R[a + 1, c, 2]
        tr += A0 * B0 + A1 * B1 + A2 * B2
        v0 += A2 * B1 - A1 * B2
        v1 += A0 * B2 - A2 * B0
        v2 += A1 * B0 - A0 * B1
    s = 2.0 * t / (1.0 + tr)
    y0 = s * v0
    y1 = s * v1
    y2 = s * v2
    ca = 4.0 / (4.0 + y0 * y0 + y1 * y1 + y2 * y2)
    cb = 0.5 * ca
    F00 = 1.0 - cb * (y1 * y1 + y2 * y2)
    F11 = 1.0 - cb * (y0 * y0 + y2 * y2)
    F22 = 1.0 - cb * (y0 * y0 + y1 * y1)
    F01 = -ca * y2 + cb * y0 * y1
    F10 = ca * y2 + cb * y0 * y1
    F02 = ca * y1 + cb * y0 * y2
    F20 = -ca * y1 + cb * y0 * y2
    F12 = -ca * y0 + cb * y1 * y2
    F21 = ca * y0 + cb * y1 * y2
    for i in range(3):
        R0 = R[a, i, 0]
        R1 = R[a, i, 1]
        R2 = R[a, i, 2]
        out[i, 0] = R0 * F00 + R1 * F10 + R2 * F20
        out[i, 1] = R0 * F01 + R1 * F11 + R2 * F21
        out[i, 2] = R0 * F02 + R1 * F12 + R2 * F22


@njit(cache=True, fastmath={"contract"}, error_model="numpy")
def currents_at(t, times, values, j, out):
    """out (n,) <- currents at time t [s], linear in time between samples times (T,), values (T, n),
    held constant before the first and after the last; j is the search start (times[j] <= t) and the
    new start is returned, so increasing times cost O(1) each."""
    T = len(times)
    if t <= times[0] or T == 1:
        for k in range(len(out)):
            out[k] = values[0, k]
        return 0
    if t >= times[T - 1]:
        for k in range(len(out)):
            out[k] = values[T - 1, k]
        return T - 1
    if j < 0 or j >= T - 1 or times[j] > t:
        j = 0
    while times[j + 1] <= t:
        j += 1
    f = (t - times[j]) / (times[j + 1] - times[j])
    for k in range(len(out)):
        out[k] = (1.0 - f) * values[j, k] + f * values[j + 1, k]
    return j


def _build_magnet_loads(stamp):
    @njit(cache=True, fastmath={"contract"}, error_model="numpy")
    def magnet_loads_into(R, r, currents, coil_pos, coil_moment, mag_node, mag_frac, mag_mu_body, ext_slot,
                          ext_w, mag_p, mag_R, mag_B, mag_G, mag_W):
        """Magnet wrenches for the pose (R (n, 3, 3), r (n, 3)) and currents (n_c,) [A].

        Writes ext_w[0] (m, 12) (world force and torque of the loaded nodes, slot ext_slot[node]) and per
        magnet: centre mag_p (M, 3) [m], rotation mag_R (M, 3, 3), field mag_B (M, 3) [T], gradient
        mag_G (M, 3, 3) [T/m], wrench mag_W (M, 6) [N, N m]. Returns -1, or the index of a magnet
        closer than MIN_DISTANCE to a coil.
        """
        if len(stamp) == 0:  # never true: references the stamp so that it is a closure variable
            return -2
        for jj in range(ext_w.shape[1]):
            for c in range(12):
                ext_w[0, jj, c] = 0.0
        for j in range(len(mag_node)):
            a = mag_node[j]
            t = mag_frac[j]
            for c in range(3):
                mag_p[j, c] = (1.0 - t) * r[a, c] + t * r[a + 1, c]
            _interp_rotation_into(R, a, t, mag_R[j])
            mu0 = 0.0
            mu1 = 0.0
            mu2 = 0.0
            for c in range(3):
                mu0 += mag_R[j, 0, c] * mag_mu_body[j, c]
                mu1 += mag_R[j, 1, c] * mag_mu_body[j, c]
                mu2 += mag_R[j, 2, c] * mag_mu_body[j, c]
            dmin = field_gradient_into(coil_pos, coil_moment, currents, mag_p[j, 0], mag_p[j, 1], mag_p[j, 2],
                                       mag_B[j], mag_G[j])
            if not dmin >= MIN_DISTANCE:
                return j
            B = mag_B[j]
            G = mag_G[j]
            W = mag_W[j]
            for c in range(3):
                W[c] = G[c, 0] * mu0 + G[c, 1] * mu1 + G[c, 2] * mu2
            W[3] = mu1 * B[2] - mu2 * B[1]
            W[4] = mu2 * B[0] - mu0 * B[2]
            W[5] = mu0 * B[1] - mu1 * B[0]
            sa = ext_slot[a]
            sb = ext_slot[a + 1]
            for c in range(6):
                ext_w[0, sa, c] += (1.0 - t) * W[c]
                ext_w[0, sb, c] += t * W[c]
        return -1
    return magnet_loads_into


magnet_loads_into = _build_magnet_loads(_STAMP)


def _build_drive(stamp):
    @njit(cache=True, no_rewrites=True)
    def drive(R, r, v, w, Kp, Gp,
              length, C1, C2, D1, D2, K0, G0, mass, inertia, ct, cr, gravity, kind, kv_on,
              h, t0, n_steps, stride,
              times, values, coil_pos, coil_moment, mag_node, mag_frac, mag_mu_body, ext_idx, ext_slot,
              save_slot, out_r, out_q, out_v, out_w, out_f, out_t, out_rf, out_rt, out_e,
              out_I, out_p, out_R, out_B, out_G, out_W,
              work_f, ext_w, pd_idx, pd_target, pd_gain, presc_r, presc_R,
              cur, mag_p, mag_R, mag_B, mag_G, mag_W):
        """Advance ``n_steps`` steps of size h [s] from time t0 [s]; returns (status, step, magnet index).

        Rod arguments as for ``rod.kernels.advance_into``; samples are written at steps k with
        k % stride == 0 into row k // stride of out_* (rod outputs as there; out_I (S, n_c) currents [A];
        per magnet out_p (S, M, 3), out_R (S, M, 3, 3), out_B (S, M, 3), out_G (S, M, 3, 3), out_W (S, M, 6)).
        Currents follow ``currents_at(t, times, values)``. Scratch: work_f (n, 6), ext_w (1, m, 12),
        empty PD and prescribed-motion arrays for ``advance_into`` (pd_idx (0,), pd_target (1, 0, 3),
        pd_gain (0, 2), presc_r (2, 0, 3), presc_R (2, 0, 3, 3)), cur (n_c,) and one row of the
        magnet outputs (mag_p, mag_R, mag_B, mag_G, mag_W as in ``magnet_loads_into``).
        """
        if len(stamp) == 0:  # never true: references the stamp so that it is a closure variable
            return -1, 0, -1
        n_mag = len(mag_node)
        # int64 from the start (a literal 0 would compile a second currents_at for Literal[int](0))
        s0 = len(mag_node) - n_mag
        one = s0 + 1
        j = s0
        for k in range(n_steps):
            t = t0 + k * h
            j = currents_at(t, times, values, j, cur)
            bad_magnet = magnet_loads_into(R, r, cur, coil_pos, coil_moment, mag_node, mag_frac, mag_mu_body,
                                           ext_slot, ext_w, mag_p, mag_R, mag_B, mag_G, mag_W)
            if bad_magnet >= 0:
                return TOO_CLOSE, k, bad_magnet
            if k % stride == 0:
                row = k // stride
                for c in range(len(cur)):
                    out_I[row, c] = cur[c]
                for jm in range(n_mag):
                    for c in range(3):
                        out_p[row, jm, c] = mag_p[jm, c]
                        out_B[row, jm, c] = mag_B[jm, c]
                        for d in range(3):
                            out_R[row, jm, c, d] = mag_R[jm, c, d]
                            out_G[row, jm, c, d] = mag_G[jm, c, d]
                    for c in range(6):
                        out_W[row, jm, c] = mag_W[jm, c]
            status, step = advance_into(
                R, r, v, w, Kp, Gp,
                length, C1, C2, D1, D2, K0, G0, mass, inertia, ct, cr, gravity, kind, kv_on,
                h, k, one, stride, s0,
                ext_idx, ext_w, pd_idx, pd_target, pd_gain, pd_idx, presc_r, presc_R,
                save_slot, out_r, out_q, out_v, out_w, out_f, out_t, out_rf, out_rt, out_e,
                work_f)
            if status != OK:
                return status, step, -1
        return OK, n_steps, -1
    return drive


drive = _build_drive(_STAMP)
