"""Numba driver of the magnetic manipulator: per solver step, the magnet wrenches from the current pose
and coil currents (and, for an advancing base, its prescribed position), then one step of
``softrnn.rod.kernels.advance_into`` (magnetic.md §2.5).

Magnet j sits between nodes a = mag_node[j] and a + 1 at the fraction t = mag_frac[j] of that
segment. Its centre is p = (1 - t) r_a + t r_{a+1}, its rotation R_c = R_a cay(t cay^-1(R_a^T R_{a+1}))
and its moment mu = R_c mu_body. The force f = G mu and torque tau = mu x B act at p; node a takes
(1 - t) and node a + 1 takes t of both, which gives the same net force and the same moment about p.

The driver takes the rod's records of ``rod.kernels`` (``LumpedRod``, ``StateArrays``,
``StepInputs``, ``Samples``) and two of its own: ``MagnetModel`` (coils and magnets) and
``MagnetSamples`` (currents and per-magnet outputs).

Caching: numba checks a cached function against its own source file only, so a cached driver would
keep the old code of ``rod/kernels.py`` and ``magnetics/coils.py`` after they change (their kernels,
the Cayley update ``times_cayley_into`` and the record types are compiled into it).
``magnet_loads_into`` and ``drive`` are therefore built as closures over a hash of those two files:
numba puts closure variables into the cache key, so an edit there recompiles them. The helper
``_interp_rotation_into`` is not cached on its own: it is compiled into ``magnet_loads_into``.
"""

import hashlib
from pathlib import Path
from typing import NamedTuple

import numpy as np
from numba import njit

from ..rod import kernels as _rod_kernels
from ..rod.kernels import MAGNET_TOO_CLOSE, OK, advance_into, times_cayley_into
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

TOO_CLOSE = MAGNET_TOO_CLOSE
"""Status: a magnet came closer than ``MIN_DISTANCE`` to a coil (``rod.status.KernelStatus``)."""


class MagnetModel(NamedTuple):
    """The coils and magnets as the driver needs them (n_c coils, M magnets, n rod nodes).

    Attributes
    ----------
    coil_pos : (n_c, 3)
        coil dipole centres [m]
    coil_moment : (n_c, 3)
        coil moments per ampere [A m^2/A]
    mag_node : (M,) int64
        magnet j lies between nodes mag_node[j] and mag_node[j] + 1 ...
    mag_frac : (M,)
        ... at the fraction mag_frac[j] of that segment
    mag_mu_body : (M, 3)
        magnet moments in the body frame [A m^2]
    ext_slot : (n,) int64
        column of each node in the loads ext_w (StepInputs), -1: none
    """

    coil_pos: np.ndarray
    coil_moment: np.ndarray
    mag_node: np.ndarray
    mag_frac: np.ndarray
    mag_mu_body: np.ndarray
    ext_slot: np.ndarray


class MagnetSamples(NamedTuple):
    """Currents and per-magnet quantities: S samples in ``drive``'s outputs; without the S axis, the
    one row that ``magnet_loads_into`` reads (currents) and writes (the rest).

    Attributes
    ----------
    currents : (S, n_c)
        coil currents [A]
    positions : (S, M, 3)
        magnet centres [m]
    rotations : (S, M, 3, 3)
        magnet rotations, body -> world
    fields : (S, M, 3)
        field at the magnets [T]
    gradients : (S, M, 3, 3)
        field gradient at the magnets [T/m]
    wrenches : (S, M, 6)
        force G mu [N] and torque mu x B [N m] on each magnet
    """

    currents: np.ndarray
    positions: np.ndarray
    rotations: np.ndarray
    fields: np.ndarray
    gradients: np.ndarray
    wrenches: np.ndarray


def empty_magnet_samples(n_coils: int, n_magnets: int, lead: tuple = ()) -> MagnetSamples:
    """Zeroed ``MagnetSamples`` with the leading axes ``lead`` ((S,) for outputs, () for one row)."""
    lead = tuple(lead)
    M = n_magnets
    return MagnetSamples(currents=np.zeros(lead + (n_coils,)), positions=np.zeros(lead + (M, 3)),
                         rotations=np.zeros(lead + (M, 3, 3)), fields=np.zeros(lead + (M, 3)),
                         gradients=np.zeros(lead + (M, 3, 3)), wrenches=np.zeros(lead + (M, 6)))


# compiled into its callers (see the module docstring); never allocates
_INLINE = dict(fastmath={"contract"}, error_model="numpy", no_cpython_wrapper=True, no_cfunc_wrapper=True,
               forceinline=True, _nrt=False)


@njit(**_INLINE)
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
    times_cayley_into(R[a], y0, y1, y2, 4.0 / (4.0 + y0 * y0 + y1 * y1 + y2 * y2), out)


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
    def magnet_loads_into(R, r, row, magnets, ext_w):
        """Magnet wrenches for the pose (R (n, 3, 3), r (n, 3)) and the currents row.currents (n_c,) [A].

        Writes ext_w[0] (m, 12) (world force and torque of the loaded nodes, column
        magnets.ext_slot[node]) and per magnet the other fields of the ``MagnetSamples`` row: centre,
        rotation, field, gradient, wrench. Returns -1, or the index of a magnet closer than
        MIN_DISTANCE to a coil.
        """
        if len(stamp) == 0:  # never true: references the stamp so that it is a closure variable
            return -2
        mag_node = magnets.mag_node
        mag_frac = magnets.mag_frac
        mag_mu_body = magnets.mag_mu_body
        for jj in range(ext_w.shape[1]):
            for c in range(12):
                ext_w[0, jj, c] = 0.0
        for j in range(len(mag_node)):
            a = mag_node[j]
            t = mag_frac[j]
            P = row.positions[j]
            for c in range(3):
                P[c] = (1.0 - t) * r[a, c] + t * r[a + 1, c]
            Rm = row.rotations[j]
            _interp_rotation_into(R, a, t, Rm)
            mu0 = 0.0
            mu1 = 0.0
            mu2 = 0.0
            for c in range(3):
                mu0 += Rm[0, c] * mag_mu_body[j, c]
                mu1 += Rm[1, c] * mag_mu_body[j, c]
                mu2 += Rm[2, c] * mag_mu_body[j, c]
            B = row.fields[j]
            G = row.gradients[j]
            dmin = field_gradient_into(magnets.coil_pos, magnets.coil_moment, row.currents, P[0], P[1], P[2], B, G)
            if not dmin >= MIN_DISTANCE:
                return j
            W = row.wrenches[j]
            for c in range(3):
                W[c] = G[c, 0] * mu0 + G[c, 1] * mu1 + G[c, 2] * mu2
            W[3] = mu1 * B[2] - mu2 * B[1]
            W[4] = mu2 * B[0] - mu0 * B[2]
            W[5] = mu0 * B[1] - mu1 * B[0]
            sa = magnets.ext_slot[a]
            sb = magnets.ext_slot[a + 1]
            for c in range(6):
                ext_w[0, sa, c] += (1.0 - t) * W[c]
                ext_w[0, sb, c] += t * W[c]
        return -1
    return magnet_loads_into


magnet_loads_into = _build_magnet_loads(_STAMP)


@njit(**_INLINE)
def _record_row(row, out, k):
    """out[k] <- row (every field of two ``MagnetSamples``, the first without the S axis)."""
    for c in range(len(row.currents)):
        out.currents[k, c] = row.currents[c]
    for jm in range(len(row.positions)):
        for c in range(3):
            out.positions[k, jm, c] = row.positions[jm, c]
            out.fields[k, jm, c] = row.fields[jm, c]
            for d in range(3):
                out.rotations[k, jm, c, d] = row.rotations[jm, c, d]
                out.gradients[k, jm, c, d] = row.gradients[jm, c, d]
        for c in range(6):
            out.wrenches[k, jm, c] = row.wrenches[jm, c]


@njit(**_INLINE)
def _base_into(base, t, presc_r, i):
    """presc_r[i, 0] <- the advancing base's position at time t [s]: base[0:3] + d s(x) base[3:6],
    x = (t - start) / ramp clipped to [0, 1], s the smoothstep 6x^5 - 15x^4 + 10x^3; base (9,) holds
    the position [m], the axis, the distance d [m], start and ramp [s] (``manipulator._AdvancingBase``)."""
    x = (t - base[7]) / base[8]
    if x < 0.0:
        x = 0.0
    elif x > 1.0:
        x = 1.0
    d = base[6] * (x * x * x * (x * (6.0 * x - 15.0) + 10.0))
    for c in range(3):
        presc_r[i, 0, c] = base[c] + d * base[3 + c]


def _build_drive(stamp):
    @njit(cache=True, no_rewrites=True)
    def drive(rod, state, inputs, out, mag_out, magnets, times, values, h, t0, k_begin, k_end, stride, work_f, row,
              base):
        """Advance steps k_begin .. k_end - 1 of size h [s], step k at t0 + k h [s]; returns (status,
        step, magnet index).

        A run may be driven in one call (k_begin 0, k_end its number of steps) or in consecutive
        blocks of steps on the same state, out and mag_out: every step computes the same numbers
        either way (its time from its own index k, the currents' search restarting from the first
        sample), so the samples are identical bit for bit.

        rod, state, inputs, out, work_f as for ``rod.kernels.advance_into``, with inputs for one step
        (ext_w (1, m, 12), overwritten at every step with the magnet loads; no PD tracking).
        Samples are written at steps k with k % stride == 0 into row k // stride of out and of
        mag_out (``MagnetSamples``). Currents follow ``currents_at(t, times, values)``.
        magnets : ``MagnetModel``; row : one ``MagnetSamples`` row of scratch. base : the advancing
        base's profile (9,) (``_base_into``), whose position at t and t + h every step writes into
        inputs.presc_r[0] and [1] (inputs.presc_idx = [0], presc_R its held rotation); (0,): a
        fixed base (no prescribed motion).
        """
        if len(stamp) == 0:  # never true: references the stamp so that it is a closure variable
            return -1, 0, -1
        n_mag = len(magnets.mag_node)
        # int64 from the start (a literal 0 would compile a second currents_at for Literal[int](0))
        s0 = n_mag - n_mag
        one = s0 + 1
        j = s0
        for k in range(k_begin, k_end):
            t = t0 + k * h
            j = currents_at(t, times, values, j, row.currents)
            bad_magnet = magnet_loads_into(state.rotations, state.positions, row, magnets, inputs.ext_w)
            if bad_magnet >= 0:
                return TOO_CLOSE, k, bad_magnet
            if k % stride == 0:
                _record_row(row, mag_out, k // stride)
            if len(base) > 0:
                _base_into(base, t, inputs.presc_r, s0)
                _base_into(base, t0 + (k + 1) * h, inputs.presc_r, one)
            status, step = advance_into(rod, state, inputs, out, h, k, one, stride, s0, work_f)
            if status != OK:
                return status, step, -1
        return OK, k_end, -1
    return drive


drive = _build_drive(_STAMP)
