"""The records and constants the rod's numba kernels share (``rod.kernels`` and the kernel modules
of each concept: ``tendon_kernels``, ``contact_kernels``, ``magnetic_kernels``), and their common
inline helpers (the Cayley update and the rotation-to-quaternion map).

The kernels take their arrays in four records (``typing.NamedTuple``, which numba passes as one
heterogeneous tuple): ``LumpedRod`` (the rod, built once per setup by ``rod.lumped.lumped_rod``),
``StateArrays`` (the state stepped in place), ``StepInputs`` (loads and prescribed motions of the
steps of one call) and ``Samples`` (the output buffers). Their fields are listed in their
docstrings, with n nodes, n - 1 segments, K steps in the call and S saved samples. Numba keys a
cached kernel on its own file and on the records' field types only, so every cached kernel that
takes them is built over ``kernel_stamp()``, which hashes this file with the other kernel modules.
"""

import hashlib
import math
from pathlib import Path
from typing import NamedTuple

import numpy as np
from numba import njit, types

KERNEL_FILES = ("kernel_records.py", "tendon_kernels.py", "contact_kernels.py", "magnetic_kernels.py", "kernels.py")
"""The kernel modules of ``softrnn.rod`` whose inline helpers are compiled into one another."""


def kernel_stamp() -> int:
    """Hash of the kernel modules (``KERNEL_FILES``), a non-negative 60-bit integer: the closure
    variable of every cached kernel that inlines their helpers, so that an edit of any of them
    recompiles it (an integer, so that referencing it costs the kernels no string code)."""
    digest = hashlib.sha256()
    folder = Path(__file__).parent
    for name in KERNEL_FILES:
        try:
            digest.update((folder / name).read_bytes())
        except OSError:  # no source file (frozen or zipped install): nothing to track
            digest.update(name.encode())
    return int(digest.hexdigest()[:15], 16)


FREE = 0
CLAMPED = 1
PINNED = 2
# A clamped node held by a driven hub (``rod.hub``): the guide holds its position across its axis d3
# and its tilt; along d3 it moves under its loads with the hub's mass (PUSHED), or it turns about d3
# under its loads with the hub's inertia (TWISTED), or both (DRIVEN); the rest is prescribed.
HUB_PUSHED = 3
HUB_TWISTED = 4
HUB_DRIVEN = 5

# Status codes returned by the kernels (``rod.status.KernelStatus`` gives them names and messages;
# they are defined here because compiled code freezes their values into the numba cache of this file).
OK = 0
DIVERGED = 1
NEWTON_FAILED = 2
MAGNET_TOO_CLOSE = 10  # a magnet of ``StepInputs`` came closer than MIN_DIPOLE_DISTANCE to a dipole source

# Obstacle kinds of ``StepInputs.contact_kind`` (``rod.contact``; frozen into the compiled code).
PLANE = 0
SPHERE = 1
CYLINDER = 2
VESSEL = 3
BIFURCATION = 4  # a union of two vessels: this column's and the next (BRANCH) column's
BRANCH = 5  # the second vessel of the BIFURCATION in the column before it; no loads of its own
SELF = 6  # contact between the rod's own segments (geom[0]: the least index gap of a segment pair)
MESH = 7  # a vessel lumen bounded by a closed triangle mesh (``geometry.mesh.MeshVessel``)

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

    In ``advance_batch`` ext_w, pd_target, presc_r, presc_R, tendon_tension, tendon_displacement,
    with obstacles the contact fields (contact_kind .. contact_applied, each rod its own obstacles)
    and with magnets source_currents and the magnets' outputs (magnet_positions .. magnet_failed;
    the magnets and sources shared) carry a leading batch axis (B, ...); ``kernels.rod_inputs``
    builds one rod's record.

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
    contact_kind : (o,) int64 or None
        obstacle kinds PLANE, SPHERE, CYLINDER, VESSEL, MESH, or BIFURCATION followed by a BRANCH
        column (one column per vessel of a ``rod.contact.Bifurcation``), and a last SELF column
        for contact between the rod's own segments; None (default): no contact, and the kernels
        compiled for these inputs leave the contact kernels out
    contact_geom : (o, 7)
        plane: point [m], unit normal; sphere: centre [m], -, -, -, radius [m]; cylinder: point [m],
        unit axis, radius [m]; self: the least index gap j - i of a pair of segments i < j that
        may touch; mesh: its seed grid's origin [m] and cell [m]; vessel, bifurcation, branch: unused
    contact_range : (o, 2) int64
        vessel, bifurcation, branch: first row and number of rows of its centreline in
        contact_points; mesh: the first entries of its arrays in contact_mesh_index and
        contact_mesh_values
    contact_friction : (o, 2)
        friction coefficient mu [-] and slip velocity v_s [m/s] per column (a bifurcation's in both)
    contact_points : (P, 3)
        the vessels' centreline polylines [m], one after another
    contact_radii : (P,)
        the vessels' radii at those points [m]
    contact_mesh_index : (I,) int64
        the meshes' integer arrays, one mesh after another (``rod.contact.mesh_arrays``): V, F,
        the seed grid's shape (3), faces (3F), face neighbours (3F), vertex ring offsets (V + 1),
        ring faces (3F), the grid's seed faces (C, -1: none)
    contact_mesh_values : (M,)
        the meshes' vertices [m] (3V), unit face normals (3F) and vertex pseudonormals (3V)
    contact_node : (n, 3)
        per node: rod radius r_a [m], contact stiffness k_a [N/m], contact damping c_a [N s/m]
    contact_segment : (n, o) int64
        per node and vessel column: the closest polyline segment (mesh column: the closest face),
        the warm start of the local search, updated in place (the array of ``RodState.contact_segment``)
    contact_samples : (S, s, 6)
        output: the contact force [N] and torque [N m] (world frame) of the saved nodes at the
        saved steps, rows as in ``Samples``
    contact_applied : (n, 6)
        scratch: the applied loads of a saved step before the contact loads join them
    magnet_node : (M,) int64 or None
        magnets (point dipoles in the rod, ``rod.magnetic.MagneticDipoles``): magnet j lies between
        nodes magnet_node[j] and magnet_node[j] + 1; None (default): no magnetic loads, and the
        kernels compiled for these inputs leave the magnetic kernel out
    magnet_body : (M, 4)
        ... at the fraction magnet_body[j, 0] of that segment, with the body-frame
        moment [A m^2] in columns 1 to 3
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
    contact_kind: np.ndarray | None = None
    contact_geom: np.ndarray = np.zeros((0, 7))
    contact_range: np.ndarray = np.zeros((0, 2), dtype=np.int64)
    contact_friction: np.ndarray = np.zeros((0, 2))
    contact_points: np.ndarray = np.zeros((0, 3))
    contact_radii: np.ndarray = np.zeros(0)
    contact_mesh_index: np.ndarray = np.zeros(0, dtype=np.int64)
    contact_mesh_values: np.ndarray = np.zeros(0)
    contact_node: np.ndarray = np.zeros((0, 3))
    contact_segment: np.ndarray = np.zeros((0, 0), dtype=np.int64)
    contact_samples: np.ndarray = np.zeros((0, 0, 6))
    contact_applied: np.ndarray = np.zeros((0, 6))
    magnet_node: np.ndarray | None = None
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


# Helpers called only from compiled code (inlined into the cached entry points, never cached themselves).
_INLINE = dict(fastmath={"contract"}, error_model="numpy", no_cpython_wrapper=True, no_cfunc_wrapper=True,
               forceinline=True, _nrt=False, no_rewrites=True)


def absent(record_type, field: str) -> bool:
    """True when the field ``field`` of the numba type of a ``StepInputs`` is None: for the
    ``overload`` of an optional load (contact, magnets), which then compiles to nothing, so that a
    rod without that load never compiles its kernel."""
    return isinstance(record_type.types[record_type.fields.index(field)], types.NoneType)


@njit(**_INLINE)
def _segment_offset(a, R, r):
    """p = R_a^T (r_{a+1} - r_a): segment a's node-to-node offset [m] in node a's frame, as p0, p1, p2."""
    d0 = r[a + 1, 0] - r[a, 0]
    d1 = r[a + 1, 1] - r[a, 1]
    d2 = r[a + 1, 2] - r[a, 2]
    p0 = R[a, 0, 0] * d0 + R[a, 1, 0] * d1 + R[a, 2, 0] * d2
    p1 = R[a, 0, 1] * d0 + R[a, 1, 1] * d1 + R[a, 2, 1] * d2
    p2 = R[a, 0, 2] * d0 + R[a, 1, 2] * d1 + R[a, 2, 2] * d2
    return p0, p1, p2


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
def _relative_rotation_parts(A, B, tr):
    """tr + tr(A^T B) and vee(A^T B - B^T A) (sk0, sk1, sk2) of rotations A, B (3, 3): the parts of
    cay^-1(A^T B) = 2 / (1 + tr(A^T B)) vee(A^T B - B^T A); the caller gives the start ``tr`` of the sum."""
    sk0 = 0.0
    sk1 = 0.0
    sk2 = 0.0
    for c in range(3):
        tr += A[c, 0] * B[c, 0] + A[c, 1] * B[c, 1] + A[c, 2] * B[c, 2]
        sk0 += A[c, 2] * B[c, 1] - A[c, 1] * B[c, 2]
        sk1 += A[c, 0] * B[c, 2] - A[c, 2] * B[c, 0]
        sk2 += A[c, 1] * B[c, 0] - A[c, 0] * B[c, 1]
    return tr, sk0, sk1, sk2


@njit(**_INLINE)
def times_cayley_into(A, y0, y1, y2, ca, out):
    """out[3, 3] <- A[3, 3] cay(y), cay(y) = I + ca (y^ + y^ y^/2), ca = 4/(4 + |y|^2) (docs/lgvi.md
    section 2.2); out may be A. The caller computes ca: ``_node`` and the magnet interpolation
    (``magnetic_kernels``) sum |y|^2 in different orders, and each keeps its own rounding. Compiled
    code only."""
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
