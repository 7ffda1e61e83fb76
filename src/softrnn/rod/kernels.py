"""Numba kernels of the Lie group variational integrator (Variant A of docs/lgvi.md §2.4).

Per node: explicit translation (T) and a 3-unknown Newton solve on the Cayley vector for the
rotation (R); segment strains use the SE(3)-Cayley measure (second order in space). One call
advances many steps; ``advance_batch`` advances many independent rods with ``prange``.

The kernels take their arrays in four records (``typing.NamedTuple``, which numba passes as one
heterogeneous tuple): ``LumpedRod`` (the rod, built once per setup by ``rod.lumped.lumped_rod``),
``StateArrays`` (the state stepped in place), ``StepInputs`` (loads and prescribed motions of the
steps of one call) and ``Samples`` (the output buffers). Their fields are listed in their
docstrings, with n nodes, n - 1 segments, K steps in the call and S saved samples. The records are
defined here, not in ``rod/lumped.py``, because numba keys a cached kernel on this file and on the
records' field types only: reordering two fields of one type in another file would leave a stale
cache entry that reads the wrong arrays.

``advance_into`` never allocates and writes its results into the arrays passed in.

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
  cached themselves: their code is part of ``advance_into``'s cache entry, which numba keys on
  this file, so they must stay in this module (``magnetics._driver`` also compiles
  ``times_cayley_into`` into its functions, and hashes this file for that reason).
* ``no_rewrites``: numba's IR rewrites cost time and mark operations with a constant operand
  (``0.5 * x``) for a second, literal type resolution at lowering. Without them, take array
  lengths with ``len(a)``, not ``a.shape[0]`` (a literal index into a tuple would compile a
  numba overload).
* loop-carried variables get their final type before the loop (``jq``, ``f0``), so that type
  inference needs no extra pass over the function.

Contact (docs/lgvi.md §2.11): ``_contact_loads`` adds the contact loads of the obstacles in
``StepInputs`` (and, with a SELF column, between the rod's own segments: ``_self_contact``) to the
applied loads once per step, before the node loop, and only when there are obstacles
(``contact_kind`` not empty): without them a step does no contact work.
"""

import math
from typing import NamedTuple

import numpy as np
from numba import njit, prange

FREE = 0
CLAMPED = 1
PINNED = 2

# Status codes returned by the kernels (``rod.status.KernelStatus`` gives them names and messages;
# they are defined here because compiled code freezes their values into the numba cache of this file).
OK = 0
DIVERGED = 1
NEWTON_FAILED = 2
MAGNET_TOO_CLOSE = 10  # a magnet of ``StepInputs`` came closer than MIN_DIPOLE_DISTANCE to a dipole source

MU0 = 4e-7 * math.pi
"""Vacuum permeability [T m/A]."""

MIN_DIPOLE_DISTANCE = 0.02
"""Closest a magnet may come to a dipole source [m]: the point-dipole field is singular at the
source (``softrnn.magnetics.coils.MIN_DISTANCE``)."""

# Obstacle kinds of ``StepInputs.contact_kind`` (``rod.contact``; frozen into the compiled code).
PLANE = 0
SPHERE = 1
CYLINDER = 2
VESSEL = 3
BIFURCATION = 4  # a union of two vessels: this column's and the next (BRANCH) column's
BRANCH = 5  # the second vessel of the BIFURCATION in the column before it; no loads of its own
SELF = 6  # contact between the rod's own segments (geom[0]: the least index gap of a segment pair)

UNION_BLEND = 0.25
"""Blend width of a bifurcation's normal, a fraction of the rod radius: where the gaps of its two
vessels differ by less (the crease where their walls meet, at the carina), the normal blends theirs
(``_union_gap``, docs/lgvi.md §2.11)."""


class LumpedRod(NamedTuple):
    """The rod's lumped arrays, one record per setup (built by ``rod.lumped.lumped_rod``).

    Attributes
    ----------
    length : float
        segment length l [m]
    weight : (n,)
        trapezoid weights w_a, 1/2 at the ends [-]
    mass : (n,)
        node masses m_a [kg]
    inertia : (n, 3)
        node inertias J_a, body frame [kg m^2]
    C1 : (n - 1, 3)
        diag(kappa G A, kappa G A, E A) per segment [N]
    C2 : (n - 1, 3)
        diag(E I, E I, G J) per segment [N m^2]
    D1, D2 : (n - 1, 3)
        Kelvin-Voigt coefficients tau_d C1 [N s], tau_d C2 [N m^2 s]
    K0 : (n - 1, 3)
        stress-free curvature and twist [1/m]
    G0 : (n - 1, 3)
        stress-free shear and stretch [-]
    ct : (n,)
        translational drag per node [N s/m]
    cr : (n,)
        rotational drag per node [N m s]
    gravity : (3,)
        gravitational acceleration [m/s^2], world frame
    kind : (n,) int64
        FREE, CLAMPED or PINNED
    kv_on : bool
        Kelvin-Voigt damping on (tau_d > 0)
    """

    length: float
    weight: np.ndarray
    mass: np.ndarray
    inertia: np.ndarray
    C1: np.ndarray
    C2: np.ndarray
    D1: np.ndarray
    D2: np.ndarray
    K0: np.ndarray
    G0: np.ndarray
    ct: np.ndarray
    cr: np.ndarray
    gravity: np.ndarray
    kind: np.ndarray
    kv_on: bool


class StateArrays(NamedTuple):
    """The integrator state, stepped in place (a leading batch axis (B, ...) in ``advance_batch``).

    Attributes
    ----------
    rotations : (n, 3, 3)
        node rotations Lambda (columns d1, d2, d3), world <- body
    positions : (n, 3)
        node positions [m]
    velocities : (n, 3)
        staggered linear velocities v^{k-1} [m/s], world frame
    angular_velocities : (n, 3)
        staggered angular velocities omega^{k-1} [rad/s], body frame
    prev_curvature : (n - 1, 3)
        previous segment curvature (Kelvin-Voigt memory) [1/m]
    prev_shear : (n - 1, 3)
        previous segment shear and stretch [-]
    """

    rotations: np.ndarray
    positions: np.ndarray
    velocities: np.ndarray
    angular_velocities: np.ndarray
    prev_curvature: np.ndarray
    prev_shear: np.ndarray


class StepInputs(NamedTuple):
    """Loads and prescribed motions of the K steps of one call (step i at t = (k0 + i) h).

    In ``advance_batch`` ext_w, pd_target, presc_r and presc_R carry a leading batch axis (B, ...).

    Attributes
    ----------
    ext_idx : (m,) int64
        nodes with tabulated loads
    ext_w : (K, m, 12)
        force world, torque world, force body, torque body [N], [N m]
    pd_idx : (p,) int64
        nodes with PD tracking forces f = kp (target - r) - kd v
    pd_target : (K, p, 3)
        target positions [m]
    pd_gain : (p, 2)
        kp [N/m] and kd [N s/m]
    presc_idx : (q,) int64
        constrained nodes with prescribed motion
    presc_r : (K + 1, q, 3)
        their positions at t and t + h [m]
    presc_R : (K + 1, q, 3, 3)
        their rotations at t and t + h
    tendon_route : (m_t, n - 1, 6)
        per tendon and segment: the body-frame offset rho [m] and its rate d rho / ds [-] at the
        segment's middle (``rod.tendons.routing_arrays``; default: no tendons)
    tendon_end : (m_t,) int64
        their termination nodes (>= 1): segments a < end carry them
    tendon_tension : (K, m_t)
        their tensions [N], >= 0 (a leading batch axis in ``advance_batch``); the kernel writes the
        tensions of the tendons driven by a displacement into their columns
    tendon_stiffness : (m_s,)
        series stiffness k [N/m] per tendon, 0 for a tendon pulled with a tension; m_s = m_t, or 0
        when no tendon is driven by a displacement (default)
    tendon_rest : (m_s,)
        the tendons' discrete lengths l_0 in the reference [m]
    tendon_displacement : (K, m_s)
        the displacements q [m] (a leading batch axis in ``advance_batch``):
        tau = k max(0, q - (l_0 - l)) from the tendon length l at the start of each step
    contact_kind : (o,) int64
        obstacle kinds PLANE, SPHERE, CYLINDER, VESSEL, or BIFURCATION followed by a BRANCH
        column (one column per vessel of a ``rod.contact.Bifurcation``), and a last SELF column
        for contact between the rod's own segments; o = 0 (default): no contact, and the kernels
        do no contact work
    contact_geom : (o, 7)
        plane: point [m], unit normal; sphere: centre [m], -, -, -, radius [m]; cylinder: point [m],
        unit axis, radius [m]; self: the least index gap j - i of a pair of segments i < j that
        may touch; vessel, bifurcation, branch: unused
    contact_range : (o, 2) int64
        vessel, bifurcation, branch: first row and number of rows of its centreline in
        contact_points
    contact_friction : (o, 2)
        friction coefficient mu [-] and slip velocity v_s [m/s] per column (a bifurcation's in both)
    contact_points : (P, 3)
        the vessels' centreline polylines [m], one after another
    contact_radii : (P,)
        the vessels' radii at those points [m]
    contact_node : (n, 3)
        per node: rod radius r_a [m], contact stiffness k_a [N/m], contact damping c_a [N s/m]
    contact_segment : (n, o) int64
        per node and vessel column: the closest polyline segment, the warm start of the local search,
        updated in place (the array of ``RodState.contact_segment``)
    contact_samples : (S, s, 6)
        output: the contact force [N] and torque [N m] (world frame) of the saved nodes at the
        saved steps, rows as in ``Samples``
    contact_applied : (n, 6)
        scratch: the applied loads of a saved step before the contact loads join them
    magnet_node : (M,) int64
        magnets (point dipoles in the rod, ``rod.magnetic.MagneticDipoles``): magnet j lies between
        nodes magnet_node[j] and magnet_node[j] + 1; M = 0 (default): no magnetic loads
    magnet_body : (M, 4)
        ... at the fraction magnet_body[j, 0] of that segment, with the body-frame moment
        magnet_body[j, 1:4] [A m^2]
    source_positions : (n_c, 3)
        the dipole sources (coils) [m]
    source_moments : (n_c, 3)
        their moments per ampere [A m^2/A]
    source_currents : (K, n_c)
        their currents at each step [A]
    magnet_positions, magnet_fields : (S + 1, M, 3)
        output: the magnets' centres [m] and the field there [T] at the saved steps (rows as in
        ``Samples``; the last row is the scratch of the other steps)
    magnet_rotations, magnet_gradients : (S + 1, M, 3, 3)
        output: the magnets' rotations (body -> world) and the field gradient [T/m], likewise
    magnet_wrenches : (S + 1, M, 6)
        output: force G mu [N] and torque mu x B [N m] on each magnet, likewise
    magnet_failed : (1,) int64
        output: the magnet that came too close (status MAGNET_TOO_CLOSE)
    """

    ext_idx: np.ndarray
    ext_w: np.ndarray
    pd_idx: np.ndarray
    pd_target: np.ndarray
    pd_gain: np.ndarray
    presc_idx: np.ndarray
    presc_r: np.ndarray
    presc_R: np.ndarray
    tendon_route: np.ndarray = np.zeros((0, 0, 6))
    tendon_end: np.ndarray = np.zeros(0, dtype=np.int64)
    tendon_tension: np.ndarray = np.zeros((0, 0))
    tendon_stiffness: np.ndarray = np.zeros(0)
    tendon_rest: np.ndarray = np.zeros(0)
    tendon_displacement: np.ndarray = np.zeros((0, 0))
    contact_kind: np.ndarray = np.zeros(0, dtype=np.int64)
    contact_geom: np.ndarray = np.zeros((0, 7))
    contact_range: np.ndarray = np.zeros((0, 2), dtype=np.int64)
    contact_friction: np.ndarray = np.zeros((0, 2))
    contact_points: np.ndarray = np.zeros((0, 3))
    contact_radii: np.ndarray = np.zeros(0)
    contact_node: np.ndarray = np.zeros((0, 3))
    contact_segment: np.ndarray = np.zeros((0, 0), dtype=np.int64)
    contact_samples: np.ndarray = np.zeros((0, 0, 6))
    contact_applied: np.ndarray = np.zeros((0, 6))
    magnet_node: np.ndarray = np.zeros(0, dtype=np.int64)
    magnet_body: np.ndarray = np.zeros((0, 4))
    source_positions: np.ndarray = np.zeros((0, 3))
    source_moments: np.ndarray = np.zeros((0, 3))
    source_currents: np.ndarray = np.zeros((0, 0))
    magnet_positions: np.ndarray = np.zeros((0, 0, 3))
    magnet_rotations: np.ndarray = np.zeros((0, 0, 3, 3))
    magnet_fields: np.ndarray = np.zeros((0, 0, 3))
    magnet_gradients: np.ndarray = np.zeros((0, 0, 3, 3))
    magnet_wrenches: np.ndarray = np.zeros((0, 0, 6))
    magnet_failed: np.ndarray = np.zeros(1, dtype=np.int64)


class Samples(NamedTuple):
    """Output buffers: S samples of the s saved nodes (a leading batch axis (B, ...) in
    ``advance_batch``, except save_slot). The field names are those of ``Trajectory``.

    Attributes
    ----------
    save_slot : (n,) int64
        column of each node in the outputs, -1: not saved
    positions : (S, s, 3)
        node positions [m], world frame
    quaternions : (S, s, 4)
        unit, scalar first (w, x, y, z), body -> world
    velocities : (S, s, 3)
        mid-step velocities [m/s], world frame
    angular_velocities : (S, s, 3)
        mid-step angular velocities [rad/s], world frame
    forces, torques : (S, s, 3)
        applied force [N] and torque [N m], world frame
    reaction_forces : (S, s, 3)
        support reaction force of constrained nodes [N], world frame
    reaction_torques : (S, s, 3)
        support reaction torque of clamped nodes [N m], world frame
    energy : (S, 3)
        kinetic, elastic and gravitational energy [J]
    """

    save_slot: np.ndarray
    positions: np.ndarray
    quaternions: np.ndarray
    velocities: np.ndarray
    angular_velocities: np.ndarray
    forces: np.ndarray
    torques: np.ndarray
    reaction_forces: np.ndarray
    reaction_torques: np.ndarray
    energy: np.ndarray


_NEWTON_MAX_ITER = 12
_NEWTON_RTOL = 1e-13

# Helpers called only from compiled code (see the module docstring).
_INLINE = dict(fastmath={"contract"}, error_model="numpy", no_cpython_wrapper=True, no_cfunc_wrapper=True,
               forceinline=True, _nrt=False, no_rewrites=True)


@njit(**_INLINE)
def _quaternion_into(M, q):
    """q[4] <- unit quaternion (w, x, y, z), w >= 0, of the rotation matrix M[3, 3] (Shepperd)."""
    m00 = M[0, 0]
    m11 = M[1, 1]
    m22 = M[2, 2]
    tr = m00 + m11 + m22
    # the largest of 4 w^2, 4 x^2, 4 y^2, 4 z^2 gives the best conditioned formula
    if tr > 0.0:
        s = math.sqrt(tr + 1.0) * 2.0
        w = 0.25 * s
        x = (M[2, 1] - M[1, 2]) / s
        y = (M[0, 2] - M[2, 0]) / s
        z = (M[1, 0] - M[0, 1]) / s
    elif m00 > m11 and m00 > m22:
        s = math.sqrt(1.0 + m00 - m11 - m22) * 2.0
        w = (M[2, 1] - M[1, 2]) / s
        x = 0.25 * s
        y = (M[0, 1] + M[1, 0]) / s
        z = (M[0, 2] + M[2, 0]) / s
    elif m11 > m22:
        s = math.sqrt(1.0 + m11 - m00 - m22) * 2.0
        w = (M[0, 2] - M[2, 0]) / s
        x = (M[0, 1] + M[1, 0]) / s
        y = 0.25 * s
        z = (M[1, 2] + M[2, 1]) / s
    else:
        s = math.sqrt(1.0 + m22 - m00 - m11) * 2.0
        w = (M[1, 0] - M[0, 1]) / s
        x = (M[0, 2] + M[2, 0]) / s
        y = (M[1, 2] + M[2, 1]) / s
        z = 0.25 * s
    nrm = math.sqrt(w * w + x * x + y * y + z * z)
    if w < 0.0:
        nrm = -nrm
    q[0] = w / nrm
    q[1] = x / nrm
    q[2] = y / nrm
    q[3] = z / nrm


@njit(**_INLINE)
def times_cayley_into(A, y0, y1, y2, ca, out):
    """out[3, 3] <- A[3, 3] cay(y), cay(y) = I + ca (y^ + y^ y^/2), ca = 4/(4 + |y|^2) (docs/lgvi.md
    section 2.2); out may be A. The caller computes ca: ``_node`` and ``magnetics._driver`` sum
    |y|^2 in different orders, and each keeps its own rounding. Compiled code only."""
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
    for c in range(3):
        A0 = A[c, 0]
        A1 = A[c, 1]
        A2 = A[c, 2]
        out[c, 0] = A0 * F00 + A1 * F10 + A2 * F20
        out[c, 1] = A0 * F01 + A1 * F11 + A2 * F21
        out[c, 2] = A0 * F02 + A1 * F12 + A2 * F22


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
        d0 = r[a + 1, 0] - r[a, 0]
        d1 = r[a + 1, 1] - r[a, 1]
        d2 = r[a + 1, 2] - r[a, 2]
        p0 = R[a, 0, 0] * d0 + R[a, 1, 0] * d1 + R[a, 2, 0] * d2
        p1 = R[a, 0, 1] * d0 + R[a, 1, 1] * d1 + R[a, 2, 1] * d2
        p2 = R[a, 0, 2] * d0 + R[a, 1, 2] * d1 + R[a, 2, 2] * d2
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
                o0 = route[j, a, 0]
                o1 = route[j, a, 1]
                o2 = route[j, a, 2]
                t0 = ga0 + ka1 * o2 - ka2 * o1 + route[j, a, 3]
                t1 = ga1 + ka2 * o0 - ka0 * o2 + route[j, a, 4]
                t2 = ga2 + ka0 * o1 - ka1 * o0 + route[j, a, 5]
                tension[i, j] += math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
    for j in range(len(stiffness)):
        if stiffness[j] > 0.0:
            stretch = inputs.tendon_displacement[i, j] - (inputs.tendon_rest[j] - l * tension[i, j])
            tension[i, j] = stiffness[j] * stretch if stretch > 0.0 else 0.0


_VESSEL_WINDOW = 3
"""Segments searched either way of a node's tracked vessel segment before walking further."""


@njit(**_INLINE)
def _segment_projection(P, k, x0, x1, x2):
    """Squared distance [m^2] from x to the segment P[k] -> P[k + 1] and the parameter t of the
    projection of x on its line (not clipped: t < 0 or t > 1 lies beyond the segment's ends)."""
    e0 = P[k + 1, 0] - P[k, 0]
    e1 = P[k + 1, 1] - P[k, 1]
    e2 = P[k + 1, 2] - P[k, 2]
    q0 = x0 - P[k, 0]
    q1 = x1 - P[k, 1]
    q2 = x2 - P[k, 2]
    t = (q0 * e0 + q1 * e1 + q2 * e2) / (e0 * e0 + e1 * e1 + e2 * e2)
    tc = min(max(t, 0.0), 1.0)
    d0 = q0 - tc * e0
    d1 = q1 - tc * e1
    d2 = q2 - tc * e2
    return d0 * d0 + d1 * d1 + d2 * d2, t


@njit(**_INLINE)
def _vessel_gap(a, o, x0, x1, x2, ra, inputs):
    """Gap [m] and inward unit normal of node a (centreline point x, rod radius ra) inside vessel o.
    The tracked segment inputs.contact_segment[a, o] is the warm start of a local search (a window
    of _VESSEL_WINDOW segments either way, then a walk while the distance decreases) and is
    updated. Beyond the vessel's open ends, and on its centreline, the gap is 1 (no contact)."""
    P = inputs.contact_points
    rad = inputs.contact_radii
    p0 = inputs.contact_range[o, 0]
    last = inputs.contact_range[o, 1] - 2
    j = inputs.contact_segment[a, o]
    lo = max(j - _VESSEL_WINDOW, 0)
    hi = min(j + _VESSEL_WINDOW, last)
    best = lo
    bd = math.inf
    for jj in range(lo, hi + 1):
        d2, t = _segment_projection(P, p0 + jj, x0, x1, x2)
        if d2 < bd:
            bd = d2
            best = jj
    while best == lo and lo > 0:
        lo -= 1
        d2, t = _segment_projection(P, p0 + lo, x0, x1, x2)
        if d2 <= bd:  # ties to the lower index, as a search from the start would find
            bd = d2
            best = lo
    while best == hi and hi < last:
        hi += 1
        d2, t = _segment_projection(P, p0 + hi, x0, x1, x2)
        if d2 < bd:
            bd = d2
            best = hi
    inputs.contact_segment[a, o] = best
    d2, t = _segment_projection(P, p0 + best, x0, x1, x2)
    if (best == 0 and t < 0.0) or (best == last and t > 1.0):
        return 1.0, 0.0, 0.0, 0.0
    tc = min(max(t, 0.0), 1.0)
    k = p0 + best
    c0 = P[k, 0] + tc * (P[k + 1, 0] - P[k, 0]) - x0
    c1 = P[k, 1] + tc * (P[k + 1, 1] - P[k, 1]) - x1
    c2 = P[k, 2] + tc * (P[k + 1, 2] - P[k, 2]) - x2
    d = math.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
    if not d > 0.0:
        return 1.0, 0.0, 0.0, 0.0
    radius = rad[k] + tc * (rad[k + 1] - rad[k])
    return radius - ra - d, c0 / d, c1 / d, c2 / d


@njit(**_INLINE)
def _union_gap(a, o, x0, x1, x2, ra, inputs):
    """Gap [m] and inward unit normal of node a in the union of the vessels of columns o and o + 1
    (a bifurcation, docs/lgvi.md §2.11): the larger of their gaps, so that a node inside either
    (gap >= 0) touches no wall. Its normal is that vessel's, blended with the other's where their
    gaps differ by less than UNION_BLEND ra (weights 1 - difference / (UNION_BLEND ra)), so that a
    node on the crease between the two walls is pushed straight back from it. Both vessels' tracked
    segments are updated."""
    g, n0, n1, n2 = _vessel_gap(a, o, x0, x1, x2, ra, inputs)
    h, m0, m1, m2 = _vessel_gap(a, o + 1, x0, x1, x2, ra, inputs)
    best = max(g, h)
    if best >= 0.0:
        return best, 0.0, 0.0, 0.0
    width = UNION_BLEND * ra
    u = max(0.0, 1.0 - (best - g) / width)
    w = max(0.0, 1.0 - (best - h) / width)
    b0 = u * n0 + w * m0
    b1 = u * n1 + w * m1
    b2 = u * n2 + w * m2
    size = math.sqrt(b0 * b0 + b1 * b1 + b2 * b2)
    if not size > 0.0:  # opposite normals: no direction to push
        return 1.0, 0.0, 0.0, 0.0
    return best, b0 / size, b1 / size, b2 / size


@njit(**_INLINE)
def _friction(a, h, mu, vs, fn, ra, n0, n1, n2, R, v, w, rod):
    """Regularised Coulomb friction f_t = -mu fn v_t / max(|v_t|, v_s') at the contact point -ra n
    of node a (docs/lgvi.md §2.11): v_t the tangential velocity of that point from the staggered
    v (world) and w (body), v_s' = max(v_s, h mu fn / m_eff) with 1/m_eff the node's inverse mass
    along v_t, rotation included. Returns the force and its moment (-ra n) x f_t, world frame."""
    W0 = R[a, 0, 0] * w[a, 0] + R[a, 0, 1] * w[a, 1] + R[a, 0, 2] * w[a, 2]
    W1 = R[a, 1, 0] * w[a, 0] + R[a, 1, 1] * w[a, 1] + R[a, 1, 2] * w[a, 2]
    W2 = R[a, 2, 0] * w[a, 0] + R[a, 2, 1] * w[a, 1] + R[a, 2, 2] * w[a, 2]
    # velocity of the contact point: v + W x (-ra n), then its tangential part
    c0 = v[a, 0] - ra * (W1 * n2 - W2 * n1)
    c1 = v[a, 1] - ra * (W2 * n0 - W0 * n2)
    c2 = v[a, 2] - ra * (W0 * n1 - W1 * n0)
    vn = c0 * n0 + c1 * n1 + c2 * n2
    c0 -= vn * n0
    c1 -= vn * n1
    c2 -= vn * n2
    speed = math.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
    if not speed > 0.0:
        return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    # moment axis k = n x v_t/|v_t| in the body frame: 1/m_eff = 1/m + ra^2 k . J^-1 k
    k0 = (n1 * c2 - n2 * c1) / speed
    k1 = (n2 * c0 - n0 * c2) / speed
    k2 = (n0 * c1 - n1 * c0) / speed
    kb0 = R[a, 0, 0] * k0 + R[a, 1, 0] * k1 + R[a, 2, 0] * k2
    kb1 = R[a, 0, 1] * k0 + R[a, 1, 1] * k1 + R[a, 2, 1] * k2
    kb2 = R[a, 0, 2] * k0 + R[a, 1, 2] * k1 + R[a, 2, 2] * k2
    inertia = rod.inertia
    im = 1.0 / rod.mass[a] + ra * ra * (kb0 * kb0 / inertia[a, 0] + kb1 * kb1 / inertia[a, 1]
                                        + kb2 * kb2 / inertia[a, 2])
    s = -mu * fn / max(speed, vs, h * mu * fn * im)
    f0 = s * c0
    f1 = s * c1
    f2 = s * c2
    return f0, f1, f2, -ra * (n1 * f2 - n2 * f1), -ra * (n2 * f0 - n0 * f2), -ra * (n0 * f1 - n1 * f0)


@njit(**_INLINE)
def _obstacle_gap(a, o, x0, x1, x2, ra, inputs):
    """Gap [m] between the surface of node a (centreline point x, rod radius ra) and obstacle o,
    and the obstacle's unit normal at the node, pointing to the rod's side; gap 1 where the normal
    is undefined (a node on a sphere's centre or a cylinder's axis, a vessel's open ends) and in a
    BRANCH column (a bifurcation's gap is its BIFURCATION column's, ``_union_gap``)."""
    geom = inputs.contact_geom
    kd = inputs.contact_kind[o]
    if kd == PLANE:
        n0 = geom[o, 3]
        n1 = geom[o, 4]
        n2 = geom[o, 5]
        return (x0 - geom[o, 0]) * n0 + (x1 - geom[o, 1]) * n1 + (x2 - geom[o, 2]) * n2 - ra, n0, n1, n2
    if kd == VESSEL:
        return _vessel_gap(a, o, x0, x1, x2, ra, inputs)
    if kd == BIFURCATION:
        return _union_gap(a, o, x0, x1, x2, ra, inputs)
    if kd == BRANCH or kd == SELF:  # part of the BIFURCATION column's gap; self-contact: ``_self_contact``
        return 1.0, 0.0, 0.0, 0.0
    q0 = x0 - geom[o, 0]
    q1 = x1 - geom[o, 1]
    q2 = x2 - geom[o, 2]
    if kd == CYLINDER:
        qa = q0 * geom[o, 3] + q1 * geom[o, 4] + q2 * geom[o, 5]
        q0 -= qa * geom[o, 3]
        q1 -= qa * geom[o, 4]
        q2 -= qa * geom[o, 5]
    d = math.sqrt(q0 * q0 + q1 * q1 + q2 * q2)
    if not d > 0.0:
        return 1.0, 0.0, 0.0, 0.0
    return d - geom[o, 6] - ra, q0 / d, q1 / d, q2 / d


@njit(**_INLINE)
def _segment_pair(p0, p1, q0, q1, r):
    """Parameters (s, t) in [0, 1] of the closest points p0 + s (p1 - p0) and q0 + t (q1 - q0) of
    segments (p0, p1) and (q0, q1) of the rows of r (n, 3); both of nonzero length."""
    d1x = r[p1, 0] - r[p0, 0]
    d1y = r[p1, 1] - r[p0, 1]
    d1z = r[p1, 2] - r[p0, 2]
    d2x = r[q1, 0] - r[q0, 0]
    d2y = r[q1, 1] - r[q0, 1]
    d2z = r[q1, 2] - r[q0, 2]
    ex = r[p0, 0] - r[q0, 0]
    ey = r[p0, 1] - r[q0, 1]
    ez = r[p0, 2] - r[q0, 2]
    a = d1x * d1x + d1y * d1y + d1z * d1z
    e = d2x * d2x + d2y * d2y + d2z * d2z
    b = d1x * d2x + d1y * d2y + d1z * d2z
    c = d1x * ex + d1y * ey + d1z * ez
    f = d2x * ex + d2y * ey + d2z * ez
    den = a * e - b * b
    s = min(max((b * f - c * e) / den, 0.0), 1.0) if den > 1e-12 * a * e else 0.0
    t = (b * s + f) / e
    if t < 0.0:
        t = 0.0
        s = min(max(-c / a, 0.0), 1.0)
    elif t > 1.0:
        t = 1.0
        s = min(max((b - c) / a, 0.0), 1.0)
    return s, t


@njit(**_INLINE)
def _push_pair(a, wa, f0, f1, f2, row, record, save_slot, inputs, work_f):
    """work_f[a] += wa f (and the saved contact loads of node a at a saved step)."""
    work_f[a, 0] += wa * f0
    work_f[a, 1] += wa * f1
    work_f[a, 2] += wa * f2
    if record and save_slot[a] >= 0:
        smp = inputs.contact_samples
        smp[row, save_slot[a], 0] += wa * f0
        smp[row, save_slot[a], 1] += wa * f1
        smp[row, save_slot[a], 2] += wa * f2


@njit(**_INLINE)
def _self_contact(row, record, r, v, gap_index, inputs, save_slot, work_f):
    """Frictionless contact between the rod's own segments i < j, j - i >= gap_index (docs/lgvi.md
    §2.11): where their closest points P (on i) and Q (on j) are nearer than the sum of the rod
    radii there, fn = max(0, -k gap - c v_n) along n = (P - Q) / |P - Q|, with k and c the series
    combination of the two points' (nodal values interpolated), v_n the normal velocity of P
    relative to Q; +fn n goes to segment i's nodes and -fn n to segment j's, split as the closest
    points divide the segments (the pair's forces sum to zero). Brute force over the pairs, each
    rejected first by its bounding spheres."""
    node = inputs.contact_node
    n = len(r)
    for i in range(n - 1):
        li = math.sqrt((r[i + 1, 0] - r[i, 0]) ** 2 + (r[i + 1, 1] - r[i, 1]) ** 2 + (r[i + 1, 2] - r[i, 2]) ** 2)
        for j in range(i + gap_index, n - 1):
            mx = 0.5 * (r[i, 0] + r[i + 1, 0] - r[j, 0] - r[j + 1, 0])
            my = 0.5 * (r[i, 1] + r[i + 1, 1] - r[j, 1] - r[j + 1, 1])
            mz = 0.5 * (r[i, 2] + r[i + 1, 2] - r[j, 2] - r[j + 1, 2])
            lj = math.sqrt((r[j + 1, 0] - r[j, 0]) ** 2 + (r[j + 1, 1] - r[j, 1]) ** 2 + (r[j + 1, 2] - r[j, 2]) ** 2)
            reach = 0.5 * (li + lj) + max(node[i, 0], node[i + 1, 0]) + max(node[j, 0], node[j + 1, 0])
            if mx * mx + my * my + mz * mz >= reach * reach or not (li > 0.0 and lj > 0.0):
                continue
            s, t = _segment_pair(i, i + 1, j, j + 1, r)
            d0 = (1 - s) * r[i, 0] + s * r[i + 1, 0] - (1 - t) * r[j, 0] - t * r[j + 1, 0]
            d1 = (1 - s) * r[i, 1] + s * r[i + 1, 1] - (1 - t) * r[j, 1] - t * r[j + 1, 1]
            d2 = (1 - s) * r[i, 2] + s * r[i + 1, 2] - (1 - t) * r[j, 2] - t * r[j + 1, 2]
            dist = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
            gap = dist - ((1 - s) * node[i, 0] + s * node[i + 1, 0] + (1 - t) * node[j, 0] + t * node[j + 1, 0])
            if gap >= 0.0 or not dist > 0.0:
                continue
            n0 = d0 / dist
            n1 = d1 / dist
            n2 = d2 / dist
            ki = (1 - s) * node[i, 1] + s * node[i + 1, 1]
            kj = (1 - t) * node[j, 1] + t * node[j + 1, 1]
            ci = (1 - s) * node[i, 2] + s * node[i + 1, 2]
            cj = (1 - t) * node[j, 2] + t * node[j + 1, 2]
            u0 = (1 - s) * v[i, 0] + s * v[i + 1, 0] - (1 - t) * v[j, 0] - t * v[j + 1, 0]
            u1 = (1 - s) * v[i, 1] + s * v[i + 1, 1] - (1 - t) * v[j, 1] - t * v[j + 1, 1]
            u2 = (1 - s) * v[i, 2] + s * v[i + 1, 2] - (1 - t) * v[j, 2] - t * v[j + 1, 2]
            vn = u0 * n0 + u1 * n1 + u2 * n2
            fn = -ki * kj / (ki + kj) * gap - (ci * cj / (ci + cj) if ci + cj > 0.0 else 0.0) * vn
            if fn > 0.0:
                f0 = fn * n0
                f1 = fn * n1
                f2 = fn * n2
                _push_pair(i, 1 - s, f0, f1, f2, row, record, save_slot, inputs, work_f)
                _push_pair(i + 1, s, f0, f1, f2, row, record, save_slot, inputs, work_f)
                _push_pair(j, t - 1, f0, f1, f2, row, record, save_slot, inputs, work_f)
                _push_pair(j + 1, -t, f0, f1, f2, row, record, save_slot, inputs, work_f)


@njit(**_INLINE)
def _contact_loads(row, record, h, R, r, v, w, rod, inputs, save_slot, work_f):
    """work_f += the contact force and torque (world) of every node (docs/lgvi.md §2.11): penalty
    normal force fn = max(0, -k_a gap - c_a v_n) along the obstacle normal at the node, and
    friction (``_friction``), from the configuration (R, r) and the staggered velocities v (world)
    and w (body). At a saved step (``record``), the saved nodes' applied loads before the contact
    (inputs.contact_applied) and their contact loads (inputs.contact_samples[row]) are kept."""
    node = inputs.contact_node
    fric = inputs.contact_friction
    for a in range(len(r)):
        x0 = r[a, 0]
        x1 = r[a, 1]
        x2 = r[a, 2]
        ra = node[a, 0]
        touched = False
        f0 = f1 = f2 = t0 = t1 = t2 = 0.0
        for o in range(len(inputs.contact_kind)):
            gap, n0, n1, n2 = _obstacle_gap(a, o, x0, x1, x2, ra, inputs)
            if gap < 0.0:
                fn = -node[a, 1] * gap - node[a, 2] * (n0 * v[a, 0] + n1 * v[a, 1] + n2 * v[a, 2])
                if fn > 0.0:
                    touched = True
                    f0 += fn * n0
                    f1 += fn * n1
                    f2 += fn * n2
                    if fric[o, 0] > 0.0:
                        ft0, ft1, ft2, m0, m1, m2 = _friction(a, h, fric[o, 0], fric[o, 1], fn, ra, n0, n1, n2,
                                                              R, v, w, rod)
                        f0 += ft0
                        f1 += ft1
                        f2 += ft2
                        t0 += m0
                        t1 += m1
                        t2 += m2
        if record:
            slot = save_slot[a]
            if slot >= 0:
                for c in range(6):
                    inputs.contact_applied[a, c] = work_f[a, c]
                smp = inputs.contact_samples
                smp[row, slot, 0] = f0
                smp[row, slot, 1] = f1
                smp[row, slot, 2] = f2
                smp[row, slot, 3] = t0
                smp[row, slot, 4] = t1
                smp[row, slot, 5] = t2
        if touched:
            work_f[a, 0] += f0
            work_f[a, 1] += f1
            work_f[a, 2] += f2
            work_f[a, 3] += t0
            work_f[a, 4] += t1
            work_f[a, 5] += t2
    last = len(inputs.contact_kind) - 1
    if inputs.contact_kind[last] == SELF:
        _self_contact(row, record, r, v, int(inputs.contact_geom[last, 0]), inputs, save_slot, work_f)


@njit(**_INLINE)
def _applied_outputs(row, inputs, out):
    """out.forces[row], out.torques[row] <- the saved nodes' applied loads without the contact
    loads (kept by ``_contact_loads`` at this saved step)."""
    save_slot = out.save_slot
    for a in range(len(save_slot)):
        slot = save_slot[a]
        if slot >= 0:
            for c in range(3):
                out.forces[row, slot, c] = inputs.contact_applied[a, c]
                out.torques[row, slot, c] = inputs.contact_applied[a, 3 + c]


@njit(fastmath={"contract"}, error_model="numpy", cache=True, no_cfunc_wrapper=True, no_rewrites=True)
def contact_wrench_into(h, R, r, v, w, rod, inputs, work_f):
    """work_f (n, 6) += the contact force [N] and torque [N m] (world frame) of every node in the
    configuration R (n, 3, 3), r (n, 3) [m] with the staggered velocities v (n, 3) [m/s] (world)
    and w (n, 3) [rad/s] (body), step h [s], as ``advance_into`` applies them (``inputs`` a
    ``StepInputs`` with contact; its tracked vessel segments are updated). For the start at rest."""
    _contact_loads(0, False, h, R, r, v, w, rod, inputs, inputs.contact_kind, work_f)


# ------------------------------------------------------------------ magnetic loads (docs/magnetic.md §2.5)
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


@njit(fastmath={"contract"}, error_model="numpy", cache=True, no_cfunc_wrapper=True, no_rewrites=True)
def magnet_wrench_into(R, r, inputs, work_f):
    """work_f (n, 6) += the magnets' force [N] and torque [N m] (world frame) in the configuration
    R (n, 3, 3), r (n, 3) [m] with the currents of the first step of ``inputs``, as ``advance_into``
    applies them (outputs in the scratch row). Returns -1, or the index of a magnet too close to a
    source. For the start at rest."""
    return _magnet_loads(0, 0, False, R, r, inputs, work_f)


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
            route = inputs.tendon_route
            o0 = route[j, a, 0]
            o1 = route[j, a, 1]
            o2 = route[j, a, 2]
            t0 = ga0 + ka1 * o2 - ka2 * o1 + route[j, a, 3]
            t1 = ga1 + ka2 * o0 - ka0 * o2 + route[j, a, 4]
            t2 = ga2 + ka0 * o1 - ka1 * o0 + route[j, a, 5]
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
        if jq >= 0:
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
    if kd == CLAMPED:
        y0 = 0.0
        y1 = 0.0
        y2 = 0.0
        if jq >= 0:
            # y = cay^-1(A), A = R^T R_next: s = 2 / (1 + tr A), y = s vee(A - A^T)
            tr = 1.0
            sk0 = 0.0
            sk1 = 0.0
            sk2 = 0.0
            for c in range(3):
                R0 = R[a, c, 0]
                R1 = R[a, c, 1]
                R2 = R[a, c, 2]
                P0 = presc_R[i + 1, jq, c, 0]
                P1 = presc_R[i + 1, jq, c, 1]
                P2 = presc_R[i + 1, jq, c, 2]
                tr += R0 * P0 + R1 * P1 + R2 * P2
                sk0 += R2 * P1 - R1 * P2
                sk1 += R0 * P2 - R2 * P0
                sk2 += R1 * P0 - R0 * P1
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
    ok, y0, y1, y2, f0, f1, f2 = _solve_rotation(kd == CLAMPED, y0, y1, y2, b0, b1, b2, ja0, ja1, ja2, hc, tol)
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
                if kd == CLAMPED:
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
        if len(inputs.magnet_node) > 0:
            if _magnet_loads(i, row, record, R, r, inputs, work_f) >= 0:
                return MAGNET_TOO_CLOSE, k
        # ---- tensions of the tendons driven by a displacement, from the configuration at t_k ----
        if len(inputs.tendon_stiffness) > 0:
            _tendon_springs(i, R, r, rod, inputs)
        # ---- contact loads from the configuration at t_k (none without obstacles) ----
        contact = len(inputs.contact_kind) > 0
        if contact:
            _contact_loads(row, record, h, R, r, state.velocities, state.angular_velocities, rod, inputs,
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
                    a, i, R, r, Ra00, Ra01, Ra02, Ra10, Ra11, Ra12, Ra20, Ra21, Ra22, rod, inputs, h, Kp, Gp, record)
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
            if contact:
                _applied_outputs(row, inputs, out)
    return OK, k0 + n_steps


def advance(rod, state, inputs, out, h, k0, n_steps, stride, s0):
    """``advance_into`` with its scratch array allocated here; returns (status, step index)."""
    return advance_into(rod, state, inputs, out, h, k0, n_steps, stride, s0,
                        np.empty((len(state.positions), 6)))


@njit(parallel=True, cache=True)
def advance_batch(rod, state, inputs, out, h, k0, n_steps, stride, s0, status):
    """Advance B independent rods of one ``rod`` (see ``advance_into``): state, inputs (except
    the node indices and gains, and the contact arrays: a batch has no obstacles) and out (except
    save_slot) carry a leading batch axis (B, ...).
    status (B, 2) int64 receives (code, step) per rod."""
    st = state
    inp = inputs
    n_batch = len(st.positions)
    for b in prange(n_batch):
        work_f = np.empty((st.positions.shape[1], 6))
        code, step = advance_into(
            rod,
            StateArrays(st.rotations[b], st.positions[b], st.velocities[b], st.angular_velocities[b],
                        st.prev_curvature[b], st.prev_shear[b]),
            StepInputs(inp.ext_idx, inp.ext_w[b], inp.pd_idx, inp.pd_target[b], inp.pd_gain, inp.presc_idx,
                       inp.presc_r[b], inp.presc_R[b], inp.tendon_route, inp.tendon_end, inp.tendon_tension[b],
                       inp.tendon_stiffness, inp.tendon_rest, inp.tendon_displacement[b], inp.contact_kind,
                       inp.contact_geom, inp.contact_range, inp.contact_friction, inp.contact_points,
                       inp.contact_radii, inp.contact_node, inp.contact_segment, inp.contact_samples,
                       inp.contact_applied, inp.magnet_node, inp.magnet_body, inp.source_positions,
                       inp.source_moments, inp.source_currents, inp.magnet_positions, inp.magnet_rotations,
                       inp.magnet_fields, inp.magnet_gradients, inp.magnet_wrenches, inp.magnet_failed),
            Samples(out.save_slot, out.positions[b], out.quaternions[b], out.velocities[b],
                    out.angular_velocities[b], out.forces[b], out.torques[b], out.reaction_forces[b],
                    out.reaction_torques[b], out.energy[b]),
            h, k0, n_steps, stride, s0, work_f)
        status[b, 0] = code
        status[b, 1] = step
